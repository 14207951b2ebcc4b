"""Which estimator: ``'auto'`` by memory and chunks, and the cheapest for a ``target_error``."""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from .. import quality
from .. import units as u
from .._kernels.binning import max_lags
from .._kernels.deferred import dask, dask_utils
from .._kernels.pairs import padded_shape
from .._kernels.uncertainty import finite_area_variance
from ..topography import Grid
from ._plan import lag_geometry, open_map_bins, plan

#: Cost model of ``target_error``, seconds on the reference machine (2 cores, shared),
#: measured by ``python benchmarks/bench_acf_random.py --cost-model`` (1024² maps and a
#: 16384-point profile; the machine's load scatters them by up to 2x, see
#: docs/performance.md). Costs common to every estimator (standard error, bookkeeping)
#: cancel in the comparison and are left out.
COST = {
    "fft": 1.5e-9,  # per M log2 M, M the transformed points (the map padded by the lags)
    "tiled": 3.3e-7,  # per map point (tiles, halos and block levels)
    "pair": 1.6e-7,  # per random pair
    "bin_2d": 8e-4,  # per bin of radial lags (drawing lag vectors of a 2D annulus)
    "bin_1d": 2e-4,  # per bin of lags along one axis
    "count": 3e-10,  # per map point: the random estimator's count of valid points
}
#: Variance of ``g = (h(r) - h(r + d))^2 / 2`` over ``G^2`` for Gaussian increments
#: (``g / G`` is chi-squared with one degree of freedom): random pairs' relative sampling
#: error per bin is ``sqrt(SAMPLING_KAPPA / pairs)``, the value their ``sampling_error``
#: reports (measured 7.2-8.0 % against 7.4 % predicted at 370 pairs per bin).
SAMPLING_KAPPA = 2.0


#: dask config key of the memory budget of ``estimator='auto'`` (bytes, or a string such
#: as ``"4 GB"``): ``dask.config.set({"xrough.memory_limit": "4 GB"})``. The argument
#: ``memory_limit`` takes precedence.
MEMORY_LIMIT_KEY = "xrough.memory_limit"
#: Share of the available memory the all-pairs FFT of one map may take when no budget is
#: given: the rest stays for the caller's own arrays and other processes.
AVAILABLE_SHARE = 0.5
#: Where Linux states the memory available (``MemAvailable``).
MEMINFO = "/proc/meminfo"


def _available_memory() -> float:
    """Memory the system can give without swapping, in bytes.

    ``MemAvailable`` of :data:`MEMINFO` (Linux: free memory plus the page cache and
    reclaimable caches, which the kernel gives up on demand); elsewhere the free pages.
    Not the free pages on Linux: a machine that has read a few GB of files has little
    free memory though all of it is available.
    """
    try:
        with open(MEMINFO, encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024  # kB
    except (OSError, ValueError, IndexError):
        pass
    try:  # pragma: no cover - not Linux
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_AVPHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return 8e9


def memory_budget(memory_limit=None) -> tuple[float, str]:
    """Bytes the all-pairs FFT of one map may take, and where that number came from.

    ``memory_limit`` (bytes, or a string such as ``"4 GB"``), else the dask config key
    :data:`MEMORY_LIMIT_KEY`, else :data:`AVAILABLE_SHARE` of :func:`_available_memory`.

    Raises
    ------
    ValueError
        A limit that is not a positive number of bytes.
    """
    source = "memory_limit"
    if memory_limit is None:
        memory_limit = dask.config.get(MEMORY_LIMIT_KEY, None)
        source = f"dask config {MEMORY_LIMIT_KEY!r}"
    if memory_limit is None:
        return AVAILABLE_SHARE * _available_memory(), (
            f"{AVAILABLE_SHARE:g} of the memory available")
    try:
        value = float(dask_utils.parse_bytes(memory_limit) if isinstance(memory_limit, str)
                      else memory_limit)
    except (TypeError, ValueError):
        value = float("nan")
    if isinstance(memory_limit, bool) or not (np.isfinite(value) and value > 0):
        raise ValueError(f"memory_limit must be a positive number of bytes or a string "
                         f"such as '4 GB', got {memory_limit!r}")
    return value, f"{source}={memory_limit!r}: {dask_utils.format_bytes(int(value))}"


def fft_memory(shape: tuple[int, ...], ks: tuple[int, ...], periodic: bool) -> float:
    """Peak bytes of the all-pairs FFT of one 2D map (``pairs.binned_map_sums``).

    An upper bound: one and a half times its half spectrum (complex, padded shape) and
    one map-sized array (float64), 7x an open map, where it holds 3x (its row
    transforms and a real quarter of the spectrum) and 6x with missing points (two of
    each); from the shape alone, since the heights are not read.
    """
    fshape = padded_shape(tuple(shape), tuple(ks), periodic)
    spectrum = 16.0 * fshape[0] * (fshape[-1] // 2 + 1)
    return 1.5 * spectrum + 8.0 * float(np.prod(shape))


def choose_estimator(da: xr.DataArray, grid: Grid, direction: str, pool,
                     memory_limit=None, dr_max=None) -> tuple[str, str | None]:
    """``'fft'`` unless one open map is chunked in y/x or its FFT exceeds the memory budget.

    The all-pairs FFT of an open map holds three times the map, six with missing points
    (:func:`fft_memory` bounds both); beyond the
    budget of :func:`memory_budget`, or when the map is split into dask chunks, the tiled
    estimator (exact up to its halo, block levels beyond; see
    :func:`~xrough.correlation.height_difference_acf_tiled`) keeps memory flat. The
    choice reads the shape, the chunks and the budget only: the same map and budget give
    the same estimator whatever the machine did before.

    Returns
    -------
    estimator : str
        ``'fft'`` or ``'tiled'``.
    reason : str or None
        Why, where the memory budget decided (attr ``estimator_reason`` of G; the
        budget is named by its source, its number only when it was given, so that the
        text does not move with the machine's free memory); None where the input alone
        decides (a chunked map, or anything but one open map: always the same estimator).
    """
    single_open_map = (len(grid.dims) == 2 and da.ndim == 2 and not grid.periodic
                       and direction == "radial" and not pool)
    if not single_open_map:
        return "fft", None
    if da.chunks is not None and any(len(da.chunksizes[d]) > 1 for d in grid.dims):
        return "tiled", None
    ks = _open_ks(grid, dr_max)
    need = fft_memory(grid.shape, ks, False)
    budget, source = memory_budget(memory_limit)
    fits = need <= budget
    return ("fft" if fits else "tiled"), (
        f"{'fft' if fits else 'tiled'}: the all-pairs FFT of this map needs about "
        f"{dask_utils.format_bytes(int(need))}, {'within' if fits else 'beyond'} the memory budget "
        f"({source})")


def _open_ks(grid: Grid, dr_max) -> tuple[int, ...]:
    """Largest lags of an open map for ``dr_max`` (the scan length by default)."""
    if dr_max is None:
        return tuple(n - 1 for n in grid.shape)
    hi = u.length_in(dr_max, grid.lateral_unit, what="dr_max", positive=False)
    return max_lags(grid.shape, grid.spacing, False, float(hi))


@dataclass(frozen=True)
class Choice:
    """What ``target_error`` chose, from the shape of the map and the bins alone."""

    estimator: str
    n_pairs: int  # random pairs in all (0 for an exact estimator)
    floor: float  # smallest relative error a map of this size can give (largest bin)
    floor_dr: float  # the lag of that bin
    sampling: float  # relative sampling error given to random pairs (0 if exact)
    cost: dict  # modelled seconds per candidate
    reason: str


@functools.lru_cache(maxsize=16)
def _error_floor(dr: tuple, pairs: tuple, area: float, pixel_area: float,
                 geometry: str) -> np.ndarray:
    """Relative ``standard_error`` of a G flat over the bins, taken as the least possible.

    Cached per grid and bins: the quadrature is worth computing once per geometry.
    """
    lags = np.asarray(dr)
    out = np.sqrt(finite_area_variance(lags, np.ones_like(lags), np.asarray(pairs), area=area,
                                       pixel_area=pixel_area, geometry=geometry))
    out.setflags(write=False)
    return out


def target_value(target_error) -> float:
    """Read ``target_error`` (a number or a dimensionless string such as ``"2 %"``)."""
    if isinstance(target_error, (bool, np.bool_)):
        raise ValueError(f"target_error must be a positive number below 1 (a relative "
                         f"error), got {target_error!r}")
    t = u.positive_si(target_error, "[]", what="target_error")
    if t >= 1:
        raise ValueError(f"target_error is the relative standard error of G per bin and "
                         f"must be below 1 (100 %), got {target_error!r}")
    return t


@dataclass(frozen=True)
class _Shape:
    """What the cost and error models read of a map, its bins and its stack."""

    dr: np.ndarray  # mean lag per kept bin
    pairs: np.ndarray  # pairs per kept bin of one complete map
    shape: tuple[int, ...]  # core shape of one map
    lag_axes: int
    transformed: float  # M log2 M of the FFTs of one map (0 for tiled)


def _shape(grid: Grid, exact: str, direction: str, binning_options: dict) -> _Shape:
    if exact == "tiled":  # the geometry without the (ky+1, kx+1) plane, cached for tiled
        b = open_map_bins(grid, **binning_options)
        return _Shape(b.dr, b.pairs, grid.shape, 2, 0.0)
    p = plan(grid, direction=direction, **binning_options)
    lag_shape = [n if p.periodic else n + k for n, k in zip(p.shape[-p.lag_axes:], p.ks)]
    per_transform = float(np.prod(lag_shape))
    transformed = float(np.prod(p.shape[:-p.lag_axes])) * per_transform * np.log2(
        max(per_transform, 2.0))
    return _Shape(p.dr, p.geometric_counts, p.shape, p.lag_axes, transformed)


def choose_for_target(da: xr.DataArray, grid: Grid, target: float, *, direction: str,
                      pool, binning_options: dict, memory_limit=None) -> Choice:
    """Pick the estimator and budget that reach ``target`` at the least modelled cost.

    Shapes, bins and chunks only (no data): the same for numpy and dask. Error model:
    the finite-area error of :func:`~xrough._kernels.uncertainty.finite_area_variance` (the model
    of ``standard_error``) for a G flat over the bins asked for (uncorrelated heights
    when the bins start at a pixel; the model takes G as ballistic below the first bin)
    on a map of this size bounds what any estimator can reach (a G that still rises over
    the bins gets more); random pairs add
    ``sqrt(SAMPLING_KAPPA / pairs per bin)`` and get at most half the target (a quarter
    of its variance) per bin. Cost model: :data:`COST`.
    """
    exact, _ = choose_estimator(da, grid, direction, pool, memory_limit,
                                binning_options.get("dr_max"))
    s = _shape(grid, exact, direction, binning_options)
    pool_dims = (pool,) if isinstance(pool, str) else tuple(pool or ())
    pooled = int(np.prod([da.sizes[d] for d in pool_dims if d in da.sizes]))
    maps = int(np.prod([da.sizes[d] for d in da.dims if d not in grid.dims]))
    points = float(np.prod(s.shape))
    geometry = lag_geometry(len(s.shape), s.lag_axes)
    floor = _error_floor(tuple(s.dr.tolist()), tuple((s.pairs * pooled).tolist()),
                         points * pooled * grid.pixel_area, grid.pixel_area, geometry)
    worst = int(np.nanargmax(floor))
    cost = {exact: maps * (COST["fft"] * s.transformed if exact == "fft" else
                           COST["tiled"] * points)}
    common: dict[str, Any] = dict(floor=float(floor[worst]), floor_dr=float(s.dr[worst]),
                                  cost=cost)
    where = (f"the finite-area error of G is at least {floor[worst]:.2g} at dr = "
             f"{s.dr[worst]:.4g} {grid.lateral_unit} on a map of this size and these bins "
             "(standard_error of a G flat over the bins, the most favourable surface)")
    if target <= floor[worst]:
        return Choice(exact, 0, sampling=0.0, reason=(
            f"target_error={target:g} is below what this map can give: {where}; no "
            f"estimator reaches it, so the exact one ({exact}) was used: a larger map, "
            "more maps (pool) or a narrower dr range lower the error"), **common)
    sampling = float(np.min(np.minimum(target / 2, np.sqrt(target**2 - floor**2))))
    per_bin = int(np.ceil(SAMPLING_KAPPA / sampling ** 2))
    n_pairs = per_bin * s.dr.size
    per_bin_cost = COST["bin_2d"] if s.lag_axes == 2 else COST["bin_1d"]
    cost["random"] = maps * (per_bin_cost * s.dr.size + COST["pair"] * n_pairs
                             + COST["count"] * points)
    budget = (f"random pairs need {n_pairs:,} pairs ({per_bin:,} per bin) for a sampling "
              f"error of {sampling:.2g} (at most half the target)")
    if not (da.chunks is None or all(len(da.chunksizes[d]) == 1 for d in grid.dims)):
        return Choice(exact, 0, sampling=0.0, reason=(
            f"{exact}: the map is split into dask chunks, which random pairs cannot read "
            f"({budget}); {where}"), **common)
    times = f"modelled {cost['random']:.3g} s against {cost[exact]:.3g} s for {exact}"
    if cost["random"] < cost[exact]:
        return Choice("random", n_pairs, sampling=sampling, reason=(
            f"random: {budget}, {times}; {where}"), **common)
    return Choice(exact, 0, sampling=0.0, reason=(
        f"{exact}: cheaper than random pairs ({budget}, {times}); {where}"), **common)


def report_choice(G: xr.DataArray, choice: Choice, target: float) -> xr.DataArray:
    """Attach the choice (attrs) and the achieved error (coordinate, lazy for dask) to G.

    A curve whose ``standard_error / G`` exceeds the target in any bin is questionable
    (:func:`xrough.quality.mark_curves`); a target below the map's floor is marked at once.
    """
    attrs = dict(G.attrs, target_error=float(target), estimator_choice=choice.reason,
                 error_floor=choice.floor, error_floor_dr=choice.floor_dr,
                 sampling_error_budget=choice.sampling,
                 **{f"modelled_seconds_{k}": float(v) for k, v in choice.cost.items()})
    rel = (G.standard_error / G).max("dr", skipna=True)
    G = G.assign_coords(achieved_error=rel.assign_attrs(
        units="1", long_name="largest relative standard error of G over the bins "
                             "(standard_error / G)"))
    G.attrs = attrs
    what = f"height_difference_acf(target_error={target:g})"
    lazy = G.chunks is not None
    detail = "" if lazy or rel.ndim else f" ({float(rel):.3g})"
    notes = (f"standard_error / G exceeds target_error={target:g} in some bins{detail}: "
             "its finite-area part, sqrt(standard_error^2 - sampling_error^2), is the "
             "map's own and no estimator lowers it (a larger map, more maps pooled or a "
             "narrower dr range do); see coordinate achieved_error")
    unreachable = target <= choice.floor  # known from the shape: one warning says so
    G = quality.mark_curves(G, (rel > target).astype(np.int8), what=what,
                            reason="above_target_error", notes=notes,
                            warn=not unreachable)
    if unreachable:
        G = quality.mark(G, choice.reason, level="questionable", what=what)
    return G
