"""The height-difference autocorrelation function G(dr) of topographies (paper eq. 1).

``G(dr) = 1/2 <(h(r) - h(r + dr))^2>`` averaged over every pair of valid points whose lag
falls in a bin of ``|dr|``: over all orientations (``direction="radial"``) or along one
axis (``"x"``, ``"y"``). Two estimators:

``"fft"`` (systematic, all pairs)
    Exact pair sums by FFT (:mod:`xrough._kernels.pairs`); periodic maps wrap around,
    open maps are zero padded by the largest lag asked for, missing points (NaN) are
    excluded pair by pair.
``"random"`` (paper section 3.1)
    Uniformly drawn pairs per log-spaced bin, a fixed budget, seedable; a Monte-Carlo
    estimate of the same bin averages with its sampling error
    (:mod:`xrough._kernels.random_pairs`).
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from . import __version__
from . import units as u
from ._kernels import binning
from ._kernels.pairs import folded_geometric_counts, folded_pair_sums
from ._kernels.random_pairs import random_pair_sums
from ._kernels.uncertainty import g_variance
from .topography import Grid, grid_of, require_whole_maps

__all__ = ["height_difference_acf"]

ESTIMATORS = ("auto", "fft", "random", "tiled")
_DEFAULT_PAIRS = 1_000_000
DIRECTIONS = ("radial", "x", "y")


@dataclass(frozen=True)
class _Plan:
    """What the kernel needs: which axes are transformed, lags, bins, geometry."""

    core_dims: tuple[str, ...]  # dims handed to the kernel, in kernel order
    shape: tuple[int, ...]  # kernel core shape
    lag_axes: int  # number of trailing axes with lags (1 or 2)
    spacing: tuple[float, ...]  # spacing of the lag axes
    periodic: bool
    ks: tuple[int, ...]
    edges: np.ndarray
    keep: np.ndarray  # bins that contain at least one lattice lag
    dr: np.ndarray  # pair-weighted mean lag distance of the kept bins
    geometric_counts: np.ndarray  # pairs per kept bin on a map without missing points


@functools.lru_cache(maxsize=4)
def _geometry(shape, spacing, periodic, ks, edges_key):
    edges = np.asarray(edges_key)
    r2 = binning.lag_radius2(ks, spacing)
    idx = binning.bin_index(r2, edges)
    nb = len(edges) - 1
    idx[(0,) * len(ks)] = nb  # a point paired with itself is no pair, whatever the bins
    geo = folded_geometric_counts(shape, ks, periodic)
    counts = binning.binned_sum(geo, idx, nb)
    rsum = binning.binned_sum(geo * np.sqrt(r2), idx, nb)
    idx.setflags(write=False)
    return idx, counts, rsum


def _length(value, lateral_unit: str, what: str) -> float | None:
    return None if value is None else u.length_in(value, lateral_unit, what=what,
                                                  positive=False)


def bin_edges(lag_shape: tuple[int, ...], spacing: tuple[float, ...], periodic: bool,
              lateral_unit: str, *, bins, points_per_decade, bin_width, dr_min,
              dr_max) -> np.ndarray:
    """Lag-bin edges (lateral unit) for the lag axes of a grid, as every estimator uses.

    Defaults: ``dr_min`` one pixel, ``dr_max`` half the period (periodic) or the scan
    length (open); ``dr_max`` itself is included.
    """
    lo = _length(dr_min, lateral_unit, "dr_min")
    hi = _length(dr_max, lateral_unit, "dr_max")
    if periodic:
        longest = min(n * d for n, d in zip(lag_shape, spacing)) / 2
    else:
        longest = max((n - 1) * d for n, d in zip(lag_shape, spacing))
    lo = min(spacing) if lo is None else lo
    hi = longest if hi is None else min(hi, np.sqrt(sum(((n - 1) * d) ** 2 for n, d in
                                                         zip(lag_shape, spacing))))
    if not isinstance(bins, str):
        edges = np.asarray(bins, dtype=float)
        if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0) or edges[0] < 0:
            raise ValueError("bin edges must be a 1D increasing array of >= 2 lags >= 0")
        return edges
    if not (lo > 0 and hi >= lo and (hi > lo or dr_min is None)):
        raise ValueError(f"need 0 < dr_min < dr_max; got dr_min={lo:g}, dr_max={hi:g} "
                         f"{lateral_unit} (largest lag on this grid: {longest:g})")
    hi_edge = hi * (1 + 1e-12)  # include dr_max itself
    if bins == "log":
        return binning.log_bin_edges(lo, hi_edge, points_per_decade)
    if bins == "linear":
        width = min(spacing) if bin_width is None else _length(bin_width, lateral_unit,
                                                               "bin_width")
        return binning.linear_bin_edges(lo, hi_edge, width)
    raise ValueError(f"bins must be 'log', 'linear' or an array of edges, got {bins!r}")


def _plan(grid: Grid, *, direction: str, bins, points_per_decade, bin_width, dr_min,
          dr_max) -> _Plan:
    if direction not in DIRECTIONS:
        raise ValueError(f"direction must be one of {DIRECTIONS}, got {direction!r}")
    if len(grid.dims) == 1:
        if direction == "y":
            raise ValueError("a profile has no 'y' direction; use direction='x'")
        core, lag_axes = ("x",), 1
    elif direction == "radial":
        core, lag_axes = ("y", "x"), 2
    elif direction == "x":
        core, lag_axes = ("y", "x"), 1
    else:
        core, lag_axes = ("x", "y"), 1
    sp = dict(zip(grid.dims, grid.spacing))
    shape_all = dict(zip(grid.dims, grid.shape))
    shape = tuple(shape_all[d] for d in core)
    lag_dims = core[-lag_axes:]
    spacing = tuple(sp[d] for d in lag_dims)
    lag_shape = shape[-lag_axes:]
    edges = bin_edges(lag_shape, spacing, grid.periodic, grid.lateral_unit, bins=bins,
                      points_per_decade=points_per_decade, bin_width=bin_width,
                      dr_min=dr_min, dr_max=dr_max)
    hi_lag = edges[-1]
    ks = binning.max_lags(lag_shape, spacing, grid.periodic, hi_lag)
    idx, counts, rsum = _geometry(lag_shape, spacing, grid.periodic, ks,
                                  tuple(edges.tolist()))
    keep = counts > 0
    mean_dr = rsum[keep] / counts[keep]
    counts = counts / 2  # unordered pairs
    if lag_axes < len(shape):  # one-direction G of a map: every row contributes
        counts = counts * shape[0]
    if not keep.any():
        raise ValueError(f"no lattice lag between {edges[0]:g} and {edges[-1]:g} "
                         f"{grid.lateral_unit}")
    return _Plan(core_dims=core, shape=shape, lag_axes=lag_axes, spacing=spacing,
                 periodic=grid.periodic, ks=ks, edges=edges, keep=keep,
                 dr=mean_dr, geometric_counts=counts[keep])


def _progress_bar(total: int, progress, desc: str):
    if progress is False or total <= 1 and progress is None:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, disable=None if progress is None else not progress,
                leave=False)


def _fft_kernel(h: np.ndarray, *, plan: _Plan, workers: int, progress) -> tuple:
    """Map (..., *core) heights to pair sums, pair counts per kept bin and valid points."""
    ncore = len(plan.shape)
    batch = h.shape[: h.ndim - ncore]
    flat = h.reshape((-1,) + plan.shape)
    idx, _, _ = _geometry(plan.shape[-plan.lag_axes:], plan.spacing, plan.periodic, plan.ks,
                          tuple(plan.edges.tolist()))
    nb = len(plan.edges) - 1
    sums = np.empty((flat.shape[0], int(plan.keep.sum())))
    counts = np.empty_like(sums)
    nvalid = np.empty(flat.shape[0])
    bar = _progress_bar(flat.shape[0], progress, "G(dr) by FFT")
    try:
        for b in range(flat.shape[0]):
            s, n = folded_pair_sums(flat[b], plan.ks, periodic=plan.periodic, workers=workers)
            # the ordered pairs at lag 0 are the valid points themselves
            nvalid[b] = np.prod(plan.shape) if n is None else n[(...,) + (0,) * len(
                plan.ks)].sum()
            if nvalid[b] < 2:
                raise ValueError(_few_points_message(b, batch))
            if plan.lag_axes < ncore:  # pool the rows of a one-direction G
                s = s.sum(axis=0)
                n = None if n is None else n.sum(axis=0)
            # the folded sums run over ordered pairs (r, r+d) and (r, r-d): halve them to
            # count each unordered pair once
            sums[b] = 0.5 * binning.binned_sum(s, idx, nb)[plan.keep]
            counts[b] = (plan.geometric_counts if n is None else
                         0.5 * binning.binned_sum(n, idx, nb)[plan.keep])
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    shape = batch + (sums.shape[-1],)
    return sums.reshape(shape), counts.reshape(shape), nvalid.reshape(batch)


def _few_points_message(index: int, batch: tuple[int, ...]) -> str:
    where = (f" (map {tuple(int(i) for i in np.unravel_index(index, batch))} of the stack)"
             if batch else "")
    return f"topography has fewer than 2 valid (non-NaN) points{where}"


def _random_kernel(h: np.ndarray, seeds: np.ndarray, *, plan: _Plan, n_per_bin: int,
                   progress) -> tuple:
    ncore = len(plan.shape)
    batch = h.shape[: h.ndim - ncore]
    flat = h.reshape((-1,) + plan.shape)
    if np.isinf(flat).any():
        raise ValueError("heights contain infinite values; mark missing points as NaN")
    nvalid = np.isfinite(flat).reshape(flat.shape[0], -1).sum(axis=1)
    for b in np.flatnonzero(nvalid < 2)[:1]:
        raise ValueError(_few_points_message(int(b), batch))
    seeds = np.broadcast_to(seeds, batch).reshape(-1)
    edges = plan.edges
    nb = len(edges) - 1
    out = np.empty((flat.shape[0], 3, int(plan.keep.sum())))
    bar = _progress_bar(flat.shape[0] * nb, progress, "G(dr) by random pairs")
    try:
        for b in range(flat.shape[0]):
            rng = np.random.default_rng(int(seeds[b]))
            res = random_pair_sums(flat[b], plan.spacing, edges, n_per_bin,
                                   periodic=plan.periodic, rng=rng,
                                   progress=None if bar is None else bar.update)
            out[b] = res[:, plan.keep]
    finally:
        if bar is not None:
            bar.close()
    out = out.reshape(batch + out.shape[1:])
    return out[..., 0, :], out[..., 1, :], out[..., 2, :], nvalid.reshape(batch).astype(float)


def _area_variance(g, pairs, valid, *, dr, pixel_area, geometry):
    """Kernel wrapper: finite-area variance of G per bin (see :mod:`.uncertainty`)."""
    g, pairs, valid = np.broadcast_arrays(g, pairs, valid[..., None])
    out = np.empty(g.shape)
    for k in np.ndindex(g.shape[:-1]):
        area = float(valid[k][0]) * pixel_area
        out[k] = g_variance(dr, g[k], pairs[k], area=area, pixel_area=pixel_area,
                            geometry=geometry)
    return out


def _available_memory() -> float:
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_AVPHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return 8e9


def _choose_estimator(da: xr.DataArray, grid: Grid, direction: str, pool) -> str:
    """``'fft'`` unless one open map is chunked in y/x or too large for its padded FFT.

    The all-pairs FFT of an open map needs about six arrays of the padded size
    ``(2 ny)(2 nx)`` float64 at once; beyond a quarter of the available memory, or when
    the map is split into dask chunks, the tiled estimator (exact up to its halo, block
    levels beyond; see :mod:`xrough.large`) keeps memory flat.
    """
    single_open_map = (len(grid.dims) == 2 and da.ndim == 2 and not grid.periodic
                       and direction == "radial" and not pool)
    if not single_open_map:
        return "fft"
    chunked = da.chunks is not None and any(len(da.chunksizes[d]) > 1 for d in grid.dims)
    padded_bytes = 6 * 8 * (2 * grid.shape[0]) * (2 * grid.shape[1])
    if chunked or padded_bytes > 0.25 * _available_memory():
        return "tiled"
    return "fft"


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
    n_pairs: int = 1_000_000,  # keep equal to _DEFAULT_PAIRS
    seed: int | None = None,
    workers: int | None = None,
    progress: bool | None = None,
) -> xr.DataArray:
    r"""Height-difference autocorrelation function ``G(dr)`` of a topography (eq. 1).

    .. math:: G(\Delta r) = \tfrac12 \langle [h(\mathbf r) - h(\mathbf r + \Delta\mathbf r)]^2
              \rangle

    averaged over all pairs of valid points whose lag length falls in a bin.

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        Heights with length units on data and coordinates (see :func:`xrough.topography`);
        NaN marks missing points; ``attrs["periodic"]`` selects circular lags. Extra dims
        (e.g. ``scan``) are kept, or pooled with ``pool``.
    direction : {'radial', 'x', 'y'}
        Average over all orientations of the lag (the full lag plane, all four quadrants),
        or only lags along one axis.
    estimator : {'auto', 'fft', 'random', 'tiled'}
        All pairs by FFT (exact); the random-pair estimator of section 3.1; or tile by tile
        for maps larger than memory (exact up to a halo, block levels beyond; see
        :func:`xrough.large.height_difference_acf_tiled`). ``'auto'`` (default) takes
        ``'fft'`` unless one open map is split into dask chunks in y/x or its padded FFT
        would not fit in a quarter of the available memory (then ``'tiled'``).
    bins : {'log', 'linear'} or array_like
        Log-spaced bins centred on ``10**(k/points_per_decade)`` (in the lateral unit),
        linear bins of ``bin_width`` (default: one pixel), or explicit edges in the lateral
        unit. A point is never paired with itself, whatever the edges.
    points_per_decade : float
        Bins per decade for ``bins='log'``.
    bin_width : float, str or Quantity, optional
        Width of linear bins (numbers in the lateral unit; default one pixel).
    dr_min, dr_max : float, str or Quantity, optional
        Lag range to compute (numbers in the lateral unit). Defaults: one pixel, and half the period
        (periodic) or the scan length (open). Only the lags needed are computed: an open
        map is padded by ``dr_max``, not by its full size.
    pool : str or tuple of str, optional
        Extra dims whose pair sums are combined into one G (exact pooling of scans).
    n_pairs : int
        Random-pair budget: valid pairs, split evenly over the bins (pairs touching a NaN
        are replaced by new draws, up to 1000 draws per pair).
    seed : int, optional
        Seed of the random-pair estimator (each map along extra dims gets its own stream,
        so numpy and dask give the same numbers).
    workers : int, optional
        FFT threads (default: all cores).
    progress : bool, optional
        Progress bar over maps (FFT) or bins (random); default: only in a terminal.

    Returns
    -------
    xarray.DataArray
        ``G`` on dim ``dr`` (the mean lag of each bin over the pairs of a complete map;
        bins without any lattice lag are dropped), units of height squared, with coords
        ``pair_count`` (pairs averaged), ``standard_error`` (statistical error of G as an
        estimate of the surface's G: finite-area model plus, for random pairs, the
        sampling error) and
        ``sampling_error`` (Monte-Carlo error against the all-pairs value; 0 for ``fft``).
        A bin whose pairs all touch missing points is NaN with ``pair_count`` 0.

    Raises
    ------
    ValueError
        Invalid topography (dims, units, spacing, fewer than 2 valid points), unknown
        options, an empty lag range, chunked core dims.

    See Also
    --------
    xrough.acf_from_spectrum : G of a model spectrum (eq. 9).

    Notes
    -----
    With a validity mask ``m`` and heights zeroed where missing, the pair sums are
    ``S(d) = corr(h^2, m) + corr(m, h^2) - 2 corr(h, h)`` and ``N(d) = corr(m, m)``, each
    correlation a product of real FFTs; ``G = S / (2N)`` per bin. Without missing points a
    periodic map needs one forward and one inverse FFT.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> x = np.arange(256) * 1.0
    >>> topo = xrough.topography(np.sin(2 * np.pi * x / 32), spacing=1.0, unit="um",
    ...                          periodic=True)
    >>> G = topo.rough.acf(bins="linear")
    >>> float(G.sel(dr=16.0))  # half a period apart: h differs by 2 sin, G = 1
    1.0
    >>> G.attrs["units"], G.dr.attrs["units"]
    ('um2', 'um')
    """
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator must be one of {ESTIMATORS}, got {estimator!r}")
    if estimator != "random" and (seed is not None or n_pairs != _DEFAULT_PAIRS):
        raise ValueError("n_pairs and seed apply to estimator='random' only")
    if bin_width is not None and not (isinstance(bins, str) and bins == "linear"):
        raise ValueError("bin_width applies to bins='linear' only")
    grid = grid_of(topography)
    if estimator == "auto":
        estimator = _choose_estimator(topography, grid, direction, pool)
    if estimator == "tiled":
        from .large import height_difference_acf_tiled

        if direction != "radial" or pool or len(grid.dims) != 2 or topography.ndim != 2:
            raise ValueError("estimator='tiled' computes the radial G of one map (no "
                             "extra dims, direction='radial')")
        return height_difference_acf_tiled(topography, bins=bins,
                                           points_per_decade=points_per_decade,
                                           bin_width=bin_width, dr_min=dr_min, dr_max=dr_max,
                                           progress=progress)
    plan = _plan(grid, direction=direction, bins=bins, points_per_decade=points_per_decade,
                 bin_width=bin_width, dr_min=dr_min, dr_max=dr_max)
    da = topography
    require_whole_maps(da, grid, purpose="G")
    pool_dims = (pool,) if isinstance(pool, str) else tuple(pool or ())
    for d in pool_dims:
        if d not in da.dims or d in grid.dims:
            raise ValueError(f"pool: {d!r} is not an extra dim of the topography "
                             f"(extra dims: {[x for x in da.dims if x not in grid.dims]})")
    nb = int(plan.keep.sum())
    workers = workers if workers is not None else (os.cpu_count() or 1)
    common = dict(input_core_dims=[list(plan.core_dims)], dask="parallelized",
                  dask_gufunc_kwargs={"output_sizes": {"dr": nb}}, keep_attrs=False)
    if estimator == "fft":
        sums, counts, valid = xr.apply_ufunc(
            _fft_kernel, da, output_core_dims=[["dr"], ["dr"], []],
            output_dtypes=[float, float, float],
            kwargs={"plan": plan, "workers": workers, "progress": progress}, **common)
        gsum, gsq = 0.5 * sums, None
    else:
        if not (isinstance(n_pairs, (int, np.integer)) and n_pairs > 0):
            raise ValueError(f"n_pairs must be a positive integer, got {n_pairs!r}")
        extra = [d for d in da.dims if d not in grid.dims]
        nmaps = int(np.prod([da.sizes[d] for d in extra])) if extra else 1
        seeds = np.random.SeedSequence(seed).generate_state(nmaps, dtype=np.uint64)
        seeds = xr.DataArray(seeds.reshape([da.sizes[d] for d in extra]), dims=extra)
        common["input_core_dims"] = [list(plan.core_dims), []]
        gsum, gsq, counts, valid = xr.apply_ufunc(
            _random_kernel, da, seeds, output_core_dims=[["dr"], ["dr"], ["dr"], []],
            output_dtypes=[float, float, float, float],
            kwargs={"plan": plan, "n_per_bin": max(1, int(n_pairs) // nb),
                    "progress": progress}, **common)
    if pool_dims:
        gsum, counts, valid = (x.sum(pool_dims) for x in (gsum, counts, valid))
        gsq = gsq.sum(pool_dims) if gsq is not None else None
    has = counts > 0
    G = (gsum / counts.where(has)).where(has)
    dr = plan.dr
    geometry = ("profile" if len(plan.shape) == 1 else
                "radial" if plan.lag_axes == 2 else "axis")
    area_var = xr.apply_ufunc(
        _area_variance, G, counts, valid, input_core_dims=[["dr"], ["dr"], []],
        output_core_dims=[["dr"]], dask="parallelized", output_dtypes=[float],
        kwargs={"dr": plan.dr, "pixel_area": grid.pixel_area,
                "geometry": geometry}, keep_attrs=False)
    if gsq is None:
        sampling = xr.zeros_like(G).where(has)
    else:
        var = (gsq / counts.where(has) - G**2).clip(min=0.0)
        sampling = np.sqrt(var / (counts - 1).where(counts > 1))
    total = np.sqrt(area_var + sampling.fillna(0.0) ** 2).where(has)
    hunit = grid.height_unit
    G = G.assign_coords(
        dr=("dr", dr, {"units": grid.lateral_unit, "long_name": "lag distance"}),
        pair_count=counts.astype(np.int64).assign_attrs(
            long_name="number of point pairs averaged", units="1"),
        standard_error=total.assign_attrs(
            units=u.power_units(hunit, 2), long_name="standard error of G"),
        sampling_error=sampling.assign_attrs(
            units=u.power_units(hunit, 2),
            long_name="Monte-Carlo error of G against the all-pairs average"),
    )
    G.name = "G"
    attrs = {
        "units": u.power_units(hunit, 2),
        "long_name": "height-difference autocorrelation function",
        "symbol": "G",
        "equation": "eq. 1: G(dr) = 1/2 <(h(r) - h(r + dr))^2>",
        "estimator": "fft (all pairs)" if estimator == "fft" else "random pairs",
        "direction": direction if len(grid.dims) == 2 else "x",
        "periodic": int(grid.periodic),
        "bins": bins if isinstance(bins, str) else "explicit",
        "pixel_size": float(min(grid.spacing)),
        "scan_size": float(max(grid.size)),
        "source": str(topography.attrs.get("source", topography.name or "")),
        "xrough_version": __version__,
    }
    for key in ("source_file", "source_sha256", "format", "overrides", "detrend",
                "reliable_dr_min", "reliable_dr_max"):  # provenance of the topography
        if key in topography.attrs:
            attrs[key] = topography.attrs[key]
    if isinstance(bins, str) and bins == "log":
        attrs["points_per_decade"] = float(points_per_decade)
    if estimator == "random":
        attrs["n_pairs"] = int(n_pairs)
        attrs["seed"] = -1 if seed is None else int(seed)
    if pool_dims:
        attrs["pooled_over"] = " ".join(pool_dims)
    G.attrs = attrs
    return G
