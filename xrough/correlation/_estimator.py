"""``height_difference_acf``: options, plan, estimator, computation, result."""

from __future__ import annotations

import functools
from dataclasses import replace
from typing import Any

import numpy as np
import xarray as xr

from .. import quality
from .. import units as u
from .._kernels.deferred import dask_array as dsa
from .._kernels.deferred import is_dask_array
from .._kernels.pairs import g_from_packed, pool
from ..preprocess import tip_window
from ..topography import Grid, grid_of, require_whole_maps, stored_step
from ._anisotropy import anisotropy, combine, diagonal_anisotropy
from ._choice import choose_estimator, choose_for_target, report_choice, target_value
from ._fft import fft_kernel, split_directions
from ._plan import Plan, check_bin_width, plan
from ._random import check_n_pairs, map_seeds, random_kernel
from ._regions import judge_regions, quarters
from ._result import g_result, g_unit, height_variance
from ._tiled import height_difference_acf_tiled

ESTIMATORS = ("auto", "fft", "random", "tiled")
DEFAULT_PAIRS = 1_000_000


@u.accepts_quantified
def height_difference_acf(
    topography: xr.DataArray,
    *,
    direction: str = "radial",
    estimator: str = "auto",
    bins: Any = "log",
    points_per_decade: float = 10,
    bin_width: Any = None,
    dr_min: Any = None,
    dr_max: Any = None,
    pool: str | tuple[str, ...] | None = None,
    n_pairs: int = 1_000_000,  # keep equal to DEFAULT_PAIRS
    seed: int | None = None,
    workers: int | None = None,
    progress: bool | None = None,
    target_error: Any = None,
    reliable: bool = True,
    memory_limit: Any = None,
) -> xr.DataArray:
    r"""Height-difference autocorrelation function ``G(dr)`` of a topography (eq. 1).

    ``G(dr) = <[h(r) - h(r + dr)]^2> / 2`` over the pairs of valid points with lags in a bin.  Notes
    (estimators, target_error, all outputs): docs/performance.md, "height_difference_acf in detail".

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        Heights with length units (:func:`xrough.topography`), NaN where missing; extra dims kept.
    direction : {'radial', 'x', 'y'}
        Average over all orientations of the lag, or only lags along one axis.
    estimator : {'auto', 'fft', 'random', 'tiled'}
        All pairs (exact), random pairs (section 3.1), tiled; ``'auto'``: fft unless too large.
    bins : {'log', 'linear'} or array_like
        Log bins centred on ``10**(k/points_per_decade)``, linear bins, or edges (lateral unit).
    points_per_decade : float
        Bins per decade for ``bins='log'`` (0 < ... <= 1000).
    bin_width : float, str or Quantity, optional
        Width of linear bins (numbers in the lateral unit; default one pixel).
    dr_min, dr_max : float, str or Quantity, optional
        Lag range (lateral unit); default one pixel to half the period or the scan length.
    pool : str or tuple of str, optional
        Extra dims whose pair sums are combined into one G (exact pooling of scans).
    n_pairs, seed : int, optional
        Random pairs: the budget of valid pairs (split over the bins), and the seed.
    workers : int, optional
        FFT threads (default: all cores).
    progress : bool, optional
        Progress bar over maps (FFT) or bins (random); default: only in a terminal.
    target_error : float or str, optional
        Relative standard error wanted per bin (``0.02``, ``"2 %"``): picks estimator and budget.
    reliable : bool
        Apply the tip rule of the metadata (:func:`xrough.preprocess.tip_window`), or not.
    memory_limit : int, float or str, optional
        Bytes the FFT of an open map may take before ``'auto'`` tiles (default: half the RAM).

    Returns
    -------
    xarray.DataArray
        ``G`` on dim ``dr`` (mean lag of each bin), in height units squared, with coords
        ``pair_count``, ``standard_error``, ``sampling_error`` and ``height_variance``.

    Raises
    ------
    ValueError
        Invalid topography, options or lag range, chunked core dims, G beyond float64.

    See Also
    --------
    xrough.acf_from_spectrum : G of a model spectrum (eq. 9).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> topo = xrough.topography(np.sin(2 * np.pi * np.arange(256.0) / 32), spacing=1.0,
    ...                          unit="um", periodic=True)
    >>> G = topo.rough.acf(bins="linear")
    >>> float(G.sel(dr=16.0)), G.attrs["units"]  # half a period apart: h differs by 2 sin
    (1.0, 'um2')
    """
    if reliable:  # the window of a tip radius the file states (once, then as asked)
        topography, note = tip_window(topography)
        G = height_difference_acf(
            topography, direction=direction, estimator=estimator, bins=bins,
            points_per_decade=points_per_decade, bin_width=bin_width, dr_min=dr_min,
            dr_max=dr_max, pool=pool, n_pairs=n_pairs, seed=seed, workers=workers,
            progress=progress, target_error=target_error, reliable=False,
            memory_limit=memory_limit)
        return quality.mark(G, note, what="height_difference_acf") if note else G
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator must be one of {ESTIMATORS}, got {estimator!r}")
    topography = _in_double(topography)
    options = dict(bins=bins, points_per_decade=points_per_decade, bin_width=bin_width,
                   dr_min=dr_min, dr_max=dr_max)
    run: dict[str, Any] = dict(direction=direction, pool=pool, workers=workers,
                               progress=progress)
    if target_error is not None:
        return _for_target(topography, target_error, estimator=estimator, n_pairs=n_pairs,
                           seed=seed, options=options, memory_limit=memory_limit, **run)
    if estimator != "random" and (seed is not None or n_pairs != DEFAULT_PAIRS):
        raise ValueError("n_pairs and seed apply to estimator='random' only")
    check_bin_width(bins, bin_width)
    grid = grid_of(topography)
    if estimator == "auto":
        estimator, reason = choose_estimator(topography, grid, direction, pool, memory_limit,
                                             dr_max)
    else:
        reason = None
    if estimator == "tiled":
        if direction != "radial" or pool or len(grid.dims) != 2 or topography.ndim != 2:
            raise ValueError("estimator='tiled' computes the radial G of one map (no "
                             "extra dims, direction='radial')")
        G = height_difference_acf_tiled(topography, progress=progress, **options)
    else:
        G = _in_memory(topography, grid, estimator, n_pairs=n_pairs, seed=seed,
                       options=options, **run)
    if reason is not None:
        G.attrs["estimator_reason"] = reason
    return _stored_precision(topography, G)


#: The share of G at its first lag above which the rounding of heights stored in a float
#: of fewer than 64 bits is said (questionable): ``q^2 / 12`` over ``G``, ``q`` the
#: spacing of the stored floats at the largest height.
STORED_PRECISION = 1e-3


def _in_double(topography: xr.DataArray) -> xr.DataArray:
    """Give heights of a float of fewer than 64 bits as float64 (lazy stays lazy).

    Their rounding when stored (``stored_height_step``, :func:`stored_step`) is recorded
    first, read from the data unless they are lazy or the attr already says it.
    """
    if topography.dtype.kind != "f" or topography.dtype.itemsize >= 8:
        return topography
    attrs = dict(topography.attrs)
    if "stored_height_step" not in attrs and topography.chunks is None:
        step = stored_step(topography.values)
        if step is not None:
            attrs.update(stored_height_step=step, stored_dtype=str(topography.dtype))
    return topography.astype(np.float64).assign_attrs(attrs)


def _stored_precision(topography: xr.DataArray, G: xr.DataArray) -> xr.DataArray:
    """Say where heights stored in float32 (or less) are too coarse for G's first lag.

    A stored height is rounded to the spacing ``q`` of its float type at its magnitude,
    which adds white noise of variance ``q^2 / 12`` to every point, and as much to G at
    every lag. Heights far from zero (an offset of 2.6e5 rms heights in float32) lose
    1.8e-3 of G at one pixel that way: computing in float64 cannot bring it back. ``q``
    is the topography's ``stored_height_step`` (recorded by :func:`xrough.topography` or
    :func:`_in_double` before the heights became float64).
    """
    q = topography.attrs.get("stored_height_step")
    if q is None or "dr" not in G.dims:
        return G
    q = float(q)
    G.attrs["stored_height_step"] = q
    if G.chunks is not None:
        return G
    values = np.moveaxis(np.asarray(G.values, dtype=float), G.get_axis_num("dr"), -1)
    first = values[..., np.asarray(G["dr"].values) > 0][..., :1]
    share = (q**2 / 12) / np.nanmin(first) if np.any(first > 0) else np.nan
    if not share > STORED_PRECISION:
        return G
    unit = topography.attrs.get("units", "")
    dtype = topography.attrs.get("stored_dtype", "a float of fewer than 64 bits")
    note = (f"the heights were stored as {dtype}, which near their largest magnitude "
            f"resolves steps of {q:.3g} {unit}: the rounding adds {share:.2g} of G at its "
            "first lag (q^2 / 12, at every lag); subtract the mean height before storing "
            "in a 32-bit float, or store float64")
    return quality.mark(G, note, what="height_difference_acf")


def _for_target(topography, target_error, *, estimator, n_pairs, seed, options, direction,
                pool, workers, progress, memory_limit) -> xr.DataArray:
    """G by the estimator and budget that :func:`choose_for_target` picks, reported."""
    target = target_value(target_error)
    if estimator != "auto":
        raise ValueError(f"target_error chooses the estimator: give estimator="
                         f"{estimator!r} or target_error={target_error!r}, not both")
    if n_pairs != DEFAULT_PAIRS:
        raise ValueError("target_error chooses n_pairs: give n_pairs or target_error, "
                         "not both")
    check_bin_width(options["bins"], options["bin_width"])
    choice = choose_for_target(topography, grid_of(topography), target,
                               direction=direction, pool=pool, binning_options=options,
                               memory_limit=memory_limit)
    random = choice.estimator == "random"
    G = height_difference_acf(
        topography, direction=direction, estimator=choice.estimator, pool=pool,
        n_pairs=choice.n_pairs if random else DEFAULT_PAIRS,
        seed=seed if random else None, workers=workers, progress=progress,
        memory_limit=memory_limit, **options)
    return report_choice(G, choice, target)


def _pool_dims(da: xr.DataArray, grid: Grid, pool) -> tuple[str, ...]:
    """Return the extra dims to pool over, checked."""
    pool_dims = (pool,) if isinstance(pool, str) else tuple(pool or ())
    for d in pool_dims:
        if d not in da.dims or d in grid.dims:
            raise ValueError(f"pool: {d!r} is not an extra dim of the topography "
                             f"(extra dims: {[x for x in da.dims if x not in grid.dims]})")
    return pool_dims


def _in_memory(da: xr.DataArray, grid: Grid, estimator: str, *, n_pairs, seed, options,
               direction, pool, workers, progress, judge: bool = True) -> xr.DataArray:
    """G by all pairs (``'fft'``) or random pairs, one map at a time, pooled on request.

    ``judge``: check the directions and the regions of a radial G of a map
    (:mod:`._anisotropy`, :mod:`._regions`).
    """
    p = plan(grid, direction=direction, **options)
    require_whole_maps(da, grid, purpose="G")
    pool_dims = _pool_dims(da, grid, pool)
    random = estimator == "random"
    if random:
        n_pairs = check_n_pairs(n_pairs)
        sums = _random_sums(da, grid, p, n_pairs=n_pairs, seed=seed, progress=progress)
    else:
        # G along each axis too, for the check of directions: of a computed map only (a
        # lazy G is not judged, so its graph carries nothing for it)
        directional = judge and p.directional and da.chunks is None
        sums = _apply(fft_kernel, da, p, kwargs={"plan": p, "workers": workers,
                                                 "progress": progress,
                                                 "directional": directional},
                      blocks=3 if directional else 1)
    if pool_dims:  # one tree reduction over the maps
        sums = sums.reduce(_pool_over, dim=list(pool_dims))
    parts = _split(sums, p)
    G, counts, total, sampling = _g_parts(parts[0], grid, p, random=random)
    extra = {"n_pairs": n_pairs, "seed": -1 if seed is None else int(seed)} if random else {}
    if pool_dims:
        extra["pooled_over"] = " ".join(pool_dims)
        extra["pooled_count"] = int(np.prod([da.sizes[d] for d in pool_dims]))
    found = None
    if len(parts) == 3 and G.chunks is None:  # G along y and x: the verdict (eager only)
        axis = replace(p, lag_axes=1)
        # their errors only where the ratio alone leaves the band (most maps: nowhere)
        axes = [_g_parts(part, grid, axis, random=False, errors=False)[0]
                for part in parts[1:]]

        @functools.cache
        def errors() -> tuple:  # of G along y and x, computed once if either check asks
            return tuple(_g_parts(part, grid, axis, random=False)[2] for part in parts[1:])

        def rel_error() -> np.ndarray:  # of G along x, for the diagonals
            return np.asarray((errors()[1] / axes[1]).transpose(..., "dr").values)

        found = combine(anisotropy(*axes, dr=p.dr, grid=grid, errors=errors),
                        None if pool_dims else diagonal_anisotropy(
                            da, grid=grid, dr=p.dr, rel_error=rel_error))
        if found is not None:
            extra.update(found[2])
    lines = len(p.core_dims) - p.lag_axes
    G = g_result(
        da, grid, G, dr=p.dr, pair_count=counts.astype(np.int64), standard_error=total,
        coords={"sampling_error": sampling.assign_attrs(
            units=g_unit(grid),
            long_name="Monte-Carlo error of G against the all-pairs average"),
            "height_variance": height_variance(
                da, grid, lag_dims=p.core_dims[lines:],
                mean_dims=p.core_dims[:lines] + tuple(pool_dims))},
        estimator="random pairs" if random else "fft (all pairs)", direction=direction,
        geometry=p.geometry, bins=options["bins"],
        points_per_decade=options["points_per_decade"], **extra)
    regions = quarters(da, grid) if (judge and not random and p.directional
                                     and not pool_dims) else None
    if regions is not None:  # do the regions of the map agree? (lazy where G is)
        G = judge_regions(G, edges=p.edges, grid=grid, region_g=lambda window: _region_g(
            regions, p.edges, window, workers=workers))
    if found is None:
        return G
    codes, note, _ = found  # one verdict per curve (quality_flag), said once
    return quality.mark_curves(G, codes, what="height_difference_acf", reason="anisotropic",
                              notes=note)


def _region_g(region: xr.DataArray, edges: np.ndarray, window: float, *,
              workers) -> xr.DataArray:
    """G of regions of a map (open maps) on the bins ``edges`` that end by ``window``.

    No errors, no check of directions: the sums of an open FFT padded by ``window``.
    """
    grid = grid_of(region)
    edges = edges[edges <= window * (1 + 1e-12)].copy()
    edges[0] *= 1 - 1e-9  # the first lag of the map at its edge: the region's spacing
    # (from its own coordinates) may differ from the map's in the last digit
    p = plan(grid, direction="radial", bins=edges,
             points_per_decade=10, bin_width=None, dr_min=None, dr_max=None)
    sums = _apply(_region_kernel, region, p, kwargs={"plan": p, "workers": workers})
    g = _g_parts(sums, grid, p, random=False, errors=False)[0]
    return g.assign_coords(dr=("dr", p.dr))


def _region_kernel(h: np.ndarray, *, plan: Plan, workers) -> np.ndarray:
    """:func:`fft_kernel` of the regions of maps: a region without 2 valid points has none."""
    batch, maps = plan.maps(h)
    nb = int(plan.keep.sum())
    out = np.zeros((maps.shape[0], 3 * nb + 2))
    for i, m in enumerate(maps):
        if np.count_nonzero(np.isfinite(m)) >= 2:  # else no pairs: G is NaN there
            out[i] = fft_kernel(m, plan=plan, workers=workers, progress=False,
                                directional=False)
    return out.reshape(batch + (out.shape[-1],))


def _apply(kernel, da: xr.DataArray, p: Plan, *args, kwargs: dict,
           blocks: int = 1) -> xr.DataArray:
    """Packed sums (dim ``packed``) of each map of ``da`` by ``kernel``, lazy for dask.

    ``blocks``: bins per kept bin (3 for the FFT of a radial G: radial, along y, along x).
    """
    nb = int(p.keep.sum()) * blocks
    return xr.apply_ufunc(
        kernel, da, *args, input_core_dims=[list(p.core_dims)] + [[] for _ in args],
        output_core_dims=[["packed"]], dask="parallelized",
        dask_gufunc_kwargs={"output_sizes": {"packed": 3 * nb + 2}},
        output_dtypes=[float], keep_attrs=False, kwargs=kwargs)


def _random_sums(da: xr.DataArray, grid: Grid, p: Plan, *, n_pairs: int, seed,
                 progress) -> xr.DataArray:
    """Packed random-pair sums, one seed per map, ``n_pairs`` split over the bins."""
    seeds = map_seeds(da, [d for d in da.dims if d not in grid.dims], seed)
    n_per_bin = max(1, n_pairs // int(p.keep.sum()))
    return _apply(random_kernel, da, p, seeds,
                  kwargs={"plan": p, "n_per_bin": n_per_bin, "progress": progress})


def _pool_over(data, axis):
    """:func:`~xrough._kernels.pairs.pool` of numpy data, or one tree reduction of dask data."""
    if is_dask_array(data):
        return dsa.reduction(data, chunk=pool, combine=pool, aggregate=pool, axis=axis,
                             dtype=float, concatenate=True, name="pool-pair-sums")
    return pool(data, axis)


def _split(sums: xr.DataArray, p: Plan) -> tuple[xr.DataArray, ...]:
    """Packed sums as ``(radial,)`` or ``(radial, along y, along x)`` (:func:`split_directions`)."""
    nb = int(p.keep.sum())
    if sums.sizes["packed"] != 3 * (3 * nb) + 2:
        return (sums,)
    return tuple(xr.apply_ufunc(
        lambda x, d=d: split_directions(x, nb)[d], sums, input_core_dims=[["packed"]],
        output_core_dims=[["packed"]], exclude_dims={"packed"}, dask="parallelized",
        dask_gufunc_kwargs={"output_sizes": {"packed": 3 * nb + 2}}, output_dtypes=[float],
        keep_attrs=False) for d in range(3))


def _g_parts(sums: xr.DataArray, grid: Grid, p: Plan, *, random: bool,
             errors: bool = True):
    """G, pair count, standard error and sampling error (dim ``dr``) from packed sums.

    ``errors=False``: the standard error is NaN, not computed (:func:`g_from_packed`).
    """
    nb = int(p.keep.sum())
    out = xr.apply_ufunc(
        g_from_packed, sums, input_core_dims=[["packed"]], output_core_dims=[["part", "dr"]],
        dask="parallelized", output_dtypes=[float], keep_attrs=False,
        dask_gufunc_kwargs={"output_sizes": {"part": 4, "dr": nb}},
        kwargs={"dr": p.dr, "pixel_area": grid.pixel_area, "geometry": p.geometry,
                "height_unit": grid.height_unit, "g_unit": g_unit(grid), "random": random,
                "errors": errors})
    return tuple(out.isel(part=k, drop=True) for k in range(4))
