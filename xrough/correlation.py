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
``"tiled"`` (maps larger than memory, :func:`height_difference_acf_tiled`)
    Exact pair sums tile by tile up to a halo, coarse block levels for longer lags.

Maps larger than memory
-----------------------
G(dr) of maps larger than memory: exact pair sums by tiles, coarse levels for long lags.

:func:`height_difference_acf_tiled` never transforms the whole map. The pair sums of every
lag up to the halo ``K`` are accumulated tile by tile (:mod:`xrough._kernels.tiles`): each
tile is cross-correlated with itself extended by ``K`` on every side, an FFT of about
``(tile + 2K)^2`` points, so every pair is counted exactly once and the sums equal those of
the in-memory FFT estimator to round-off. Longer lags come from coarser levels: the map is
cut into blocks of ``factor**l`` points, each summarised by its count, mean and sum of
squared deviations, and the same tiled algorithm runs on the blocks. Those sums are the
exact sums over all pairs of points, grouped by the lag between their blocks instead of
their own lag; a level is only used for lags of at least ``min_lag_cells`` blocks, where
this regrouping moves pairs by at most one block per axis (see Notes of the function for
the error).

The computation is one dask graph on the chunks of the (possibly NetCDF- or zarr-backed)
map: each chunk is read once, by one task that scales its heights by their own power of
two (so no tile waits for a maximum over the whole map) and from which its block
statistics at every level are derived; a tile takes its chunks and thin halo strips cut
from the neighbouring ones; the reduction is a tree of sums of small lag planes.
"""

from __future__ import annotations

import functools
import os
import sys
from dataclasses import dataclass
from typing import Any

import dask
import dask.array as dsa
import numpy as np
import xarray as xr
from dask.diagnostics import ProgressBar
from dask.highlevelgraph import HighLevelGraph
from tqdm.auto import tqdm

from . import quality
from . import units as u
from ._kernels import binning, tiles
from ._kernels.pairs import folded_geometric_counts, folded_pair_sums
from ._kernels.random_pairs import random_pair_sums, valid_points
from ._kernels.uncertainty import g_variance
from .acf import result_attrs
from .topography import Grid, grid_of, require_whole_maps

__all__ = ["height_difference_acf", "height_difference_acf_tiled"]

ESTIMATORS = ("auto", "fft", "random", "tiled")
_DEFAULT_PAIRS = 1_000_000
DIRECTIONS = ("radial", "x", "y")
#: More linear bins than this would be mostly empty and cost memory without information.
MAX_BINS = 100_000
#: Points per map whose largest |h| scales the heights of the random-pair estimator.
_SCALE_SAMPLE = 2**16


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
        edges = u.array_in(bins, lateral_unit, what="bins", noun="bin edges")
        if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0) or edges[0] < 0:
            raise ValueError("bin edges must be a 1D increasing array of >= 2 lags >= 0")
        return edges
    if not (lo > 0 and hi >= lo and (hi > lo or dr_min is None)):
        raise ValueError(f"need 0 < dr_min < dr_max; got dr_min={lo:g}, dr_max={hi:g} "
                         f"{lateral_unit} (largest lag on this grid: {longest:g})")
    hi_edge = hi * (1 + 1e-12)  # include dr_max itself
    if bins == "log":
        if not (np.isfinite(points_per_decade) and 0 < points_per_decade <= 1000):
            raise ValueError(f"points_per_decade must be a positive number up to 1000, got "
                             f"{points_per_decade!r}")
        return binning.log_bin_edges(lo, hi_edge, points_per_decade)
    if bins == "linear":
        width = min(spacing) if bin_width is None else _length(bin_width, lateral_unit,
                                                               "bin_width")
        n_bins = (hi_edge - lo) / width
        if n_bins > MAX_BINS:
            raise ValueError(
                f"bin_width={width:g} {lateral_unit} gives {n_bins:.3g} linear bins between "
                f"{lo:g} and {hi:g} {lateral_unit}; at most {MAX_BINS:,} are allowed (the "
                f"lattice has no more distinct lags than that: use a bin_width of at least "
                f"{(hi_edge - lo) / MAX_BINS:.3g} {lateral_unit})")
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
    return tqdm(total=total, desc=desc, disable=None if progress is None else not progress,
                leave=False)


def _fft_kernel(h: np.ndarray, *, plan: _Plan, workers: int, progress) -> np.ndarray:
    """Map (..., *core) heights to their sums of G per kept bin, packed (:func:`_packed`).

    Each map is scaled by its own power of two (nearest its largest ``|h|``, see
    :func:`_scaled_map`), so that no square of a height overflows; the sums are those of
    the scaled heights, and the exponent of each map is packed with them.
    """
    ncore = len(plan.shape)
    batch = h.shape[: h.ndim - ncore]
    flat = h.reshape((-1,) + plan.shape)
    idx, _, _ = _geometry(plan.shape[-plan.lag_axes:], plan.spacing, plan.periodic, plan.ks,
                          tuple(plan.edges.tolist()))
    nb = len(plan.edges) - 1
    sums = np.empty((flat.shape[0], int(plan.keep.sum())))
    counts = np.empty_like(sums)
    nvalid = np.empty(flat.shape[0])
    exponents = np.zeros(flat.shape[0])
    bar = _progress_bar(flat.shape[0], progress, "G(dr) by FFT")
    try:
        for b in range(flat.shape[0]):
            scaled, exponents[b] = _scaled_map(flat[b], b, batch)
            s, n = folded_pair_sums(scaled, plan.ks, periodic=plan.periodic, workers=workers)
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
    return _packed(batch, 0.5 * sums, counts, np.zeros_like(sums), nvalid, exponents)


def _scaled_map(h: np.ndarray, index: int, batch: tuple[int, ...]) -> tuple[np.ndarray, int]:
    """One map as ``(h / 2**e, e)``, ``2**e`` the power of two nearest its largest ``|h|``.

    Raises
    ------
    ValueError
        Infinite heights, or fewer than 2 valid points (naming the map of a stack).
    """
    scaled, exponent = tiles.scaled_heights(h)
    if exponent is None:
        raise ValueError(_few_points_message(index, batch))
    return scaled, exponent


def _few_points_message(index: int, batch: tuple[int, ...]) -> str:
    where = (f" (map {tuple(int(i) for i in np.unravel_index(index, batch))} of the stack)"
             if batch else "")
    return f"topography has fewer than 2 valid (non-NaN) points{where}"


def _random_kernel(h: np.ndarray, seeds: np.ndarray, *, plan: _Plan, n_per_bin: int,
                   progress) -> np.ndarray:
    """Sum G, G^2 and count random pairs per kept bin of each map, packed (:func:`_packed`).

    Reads the drawn points and counts the valid ones in one pass
    (:func:`~xrough._kernels.random_pairs.valid_points`); no copy of the maps. Each map's
    heights are scaled by the power of two nearest the largest ``|h|`` of a regular sample
    of it (:func:`_sampled_exponent`), returned with the sums.
    """
    ncore = len(plan.shape)
    batch = h.shape[: h.ndim - ncore]
    maps = h.reshape((-1,) + plan.shape)
    seeds = np.broadcast_to(seeds, batch).reshape(-1)
    edges = plan.edges
    nb = len(edges) - 1
    out = np.empty((maps.shape[0], 3, int(plan.keep.sum())))
    nvalid = np.empty(maps.shape[0])
    exponents = np.zeros(maps.shape[0])
    bar = _progress_bar(maps.shape[0] * nb, progress, "G(dr) by random pairs")
    try:
        for b in range(maps.shape[0]):
            nvalid[b] = valid_points(maps[b])
            if nvalid[b] < 2:
                raise ValueError(_few_points_message(b, batch))
            exponents[b] = _sampled_exponent(maps[b])
            rng = np.random.default_rng(int(seeds[b]))
            res = random_pair_sums(maps[b], plan.spacing, edges, n_per_bin,
                                   periodic=plan.periodic, rng=rng,
                                   scale=np.ldexp(1.0, int(exponents[b])),
                                   progress=None if bar is None else bar.update)
            out[b] = res[:, plan.keep]
    finally:
        if bar is not None:
            bar.close()
    return _packed(batch, out[:, 0], out[:, 2], out[:, 1], nvalid, exponents)


def _packed(batch, gsum, counts, gsq, nvalid, exponents) -> np.ndarray:
    """Pack per map its sums of G, pair counts, sums of G^2, valid points and exponent.

    The sums and counts have one value per kept bin, the exponent is that of the map's
    scale; shape ``batch + (3 nb + 2,)``.

    One array per map is one task output per map for dask, and pools with one reduction
    (:func:`_pool`).
    """
    n = gsum.shape[0]
    out = np.concatenate([gsum, counts, gsq, np.reshape(nvalid, (n, 1)),
                          np.reshape(exponents, (n, 1))], axis=-1)
    return out.reshape(batch + out.shape[-1:])


def _pool(packed: np.ndarray, axis, keepdims: bool = False) -> np.ndarray:
    """Pool packed sums (:func:`_packed`) over ``axis``: each brought to the largest exponent.

    Sums of G scale with the square of the heights' scale, sums of G^2 with its fourth
    power, counts not at all; a map whose scale is far below the largest contributes
    (under)flowing nothing. Usable as the chunk, combine and aggregate step of a dask
    reduction.
    """
    nb = (packed.shape[-1] - 2) // 3
    exponent = packed[..., -1:]
    top = np.max(exponent, axis=axis, keepdims=True)
    shift = exponent - top
    factor = np.concatenate([np.broadcast_to(np.exp2(2 * shift), shift.shape[:-1] + (nb,)),
                             np.ones(shift.shape[:-1] + (nb,)),
                             np.broadcast_to(np.exp2(4 * shift), shift.shape[:-1] + (nb,)),
                             np.ones(shift.shape[:-1] + (1,))], axis=-1)
    out = np.sum(packed[..., :-1] * factor, axis=axis, keepdims=keepdims)
    return np.concatenate([out, top if keepdims else np.squeeze(top, axis)], axis=-1)


def _pool_over(data, axis):
    """:func:`_pool` of numpy data, or one tree reduction of dask data (for ``reduce``)."""
    if isinstance(data, dsa.Array):
        return dsa.reduction(data, chunk=_pool, combine=_pool, aggregate=_pool, axis=axis,
                             dtype=float, concatenate=True, name="pool-pair-sums")
    return _pool(data, axis)


def _finish(packed, *, dr, pixel_area, geometry, height_unit, random) -> np.ndarray:
    """G, pair count, standard error and sampling error ``(..., 4, nb)`` from packed sums.

    G is the mean of the pair values per bin; its standard error combines the finite-area
    variance (:func:`_area_variance`) with the Monte-Carlo variance of random pairs (0 for
    all pairs, ``random=False``); all back from the scaled heights (``2**exponent``).
    """
    nb = (packed.shape[-1] - 2) // 3
    gsum, counts, gsq = packed[..., :nb], packed[..., nb:2 * nb], packed[..., 2 * nb:3 * nb]
    valid, exponent = packed[..., -2], packed[..., -1:]
    has = counts > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        G = np.where(has, gsum / np.where(has, counts, 1.0), np.nan)
        var = np.clip(gsq / np.where(has, counts, 1.0) - G**2, 0.0, None)
        sampling = (np.where(counts > 1, np.sqrt(var / np.where(counts > 1, counts - 1, 1.0)),
                             np.nan) if random else np.zeros_like(G))
    area_var = _area_variance(G, counts, valid, dr=dr, pixel_area=pixel_area,
                              geometry=geometry)
    total = np.where(has, np.sqrt(area_var + np.nan_to_num(sampling) ** 2), np.nan)
    G, total, sampling = (_times_power_of_two(x, exponent, power=2, height_unit=height_unit)
                          for x in (G, total, np.where(has, sampling, np.nan)))
    return np.stack([G, counts, total, sampling], axis=-2)


def _area_variance(g, pairs, valid, *, dr, pixel_area, geometry):
    """Kernel wrapper: finite-area variance of G per bin (see :mod:`.uncertainty`)."""
    g, pairs, valid = np.broadcast_arrays(g, pairs, valid[..., None])
    out = np.empty(g.shape)
    for k in np.ndindex(g.shape[:-1]):
        area = float(valid[k][0]) * pixel_area
        out[k] = g_variance(dr, g[k], pairs[k], area=area, pixel_area=pixel_area,
                            geometry=geometry)
    return out


def _sampled_exponent(h: np.ndarray, points: int | None = None) -> int:
    """Exponent of the power of two nearest the largest ``|h|`` of a regular sample of a map.

    About ``points`` (default ``_SCALE_SAMPLE``) points: every ``n / points^(1/ndim)``-th
    along each axis, instead of a pass over the whole map; enough for an estimator that
    reads few points and checks each against the scale (random pairs). A sample without a
    valid point falls back to the whole map.
    """
    points = _SCALE_SAMPLE if points is None else points
    per_dim = max(1, int(round(points ** (1 / h.ndim))))
    sample = h[tuple(slice(None, None, max(1, n // per_dim)) for n in h.shape)]
    valid = np.isfinite(sample)
    if not valid.any():
        sample = h[np.isfinite(h)]
        valid = np.ones(sample.shape, dtype=bool)
    return int(tiles.power_of_two_exponent(np.max(np.abs(sample[valid]), initial=0.0)))


def _times_power_of_two(values, exponent, *, power: int, height_unit: str):
    """Return ``values * 2^(exponent power)``, or a clear error outside float64's range.

    Heights were scaled by ``2^exponent`` (a number, or one per curve broadcasting against
    ``values``); ``values`` is a ``power`` of them.
    """
    values = np.asarray(values, dtype=float)
    exponent = np.broadcast_to(np.asarray(exponent, dtype=int) * power, values.shape)
    with np.errstate(over="ignore", under="ignore"):
        out = np.ldexp(values, exponent)
    lost = np.isfinite(values) & (values != 0) & ~(np.isfinite(out) & (out != 0))
    if np.any(lost):
        worst = np.argmax(np.where(lost, np.abs(values), -np.inf))
        e = int(exponent.reshape(-1)[worst])
        decade = np.log10(np.abs(values.reshape(-1)[worst])) + e * np.log10(2.0)
        raise ValueError(
            f"heights of about 1e{e / power * np.log10(2.0):.0f} {height_unit} make "
            f"G reach about 1e{decade:.0f} {u.power_units(height_unit, 2)}, outside the "
            "range of float64 numbers (1e-308 to 1.8e308): check the height scale of the "
            "data (a wrong unit or scale factor), or express the heights in a unit that "
            "brings them nearer to 1")
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
    levels beyond; see :func:`height_difference_acf_tiled`) keeps memory flat.
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


@dataclass(frozen=True)
class _Choice:
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

    Cached per grid and bins (the quadrature costs about 10 ms for 30 radial bins).
    """
    dr = np.asarray(dr)
    out = np.sqrt(g_variance(dr, np.ones_like(dr), np.asarray(pairs), area=area,
                             pixel_area=pixel_area, geometry=geometry))
    out.setflags(write=False)
    return out


def _target_value(target_error) -> float:
    """Read ``target_error`` (a number or a dimensionless string such as ``"2 %"``)."""
    if isinstance(target_error, (bool, np.bool_)):
        raise ValueError(f"target_error must be a positive number below 1 (a relative "
                         f"error), got {target_error!r}")
    t = u.positive_si(target_error, "[]", what="target_error")
    if t >= 1:
        raise ValueError(f"target_error is the relative standard error of G per bin and "
                         f"must be below 1 (100 %), got {target_error!r}")
    return t


def _choose_for_target(da: xr.DataArray, grid: Grid, target: float, *, direction: str,
                       pool, binning_options: dict) -> _Choice:
    """Pick the estimator and budget that reach ``target`` at the least modelled cost.

    Shapes, bins and chunks only (no data): the same for numpy and dask. Error model:
    the finite-area error of :func:`~xrough._kernels.uncertainty.g_variance` (the model
    of ``standard_error``) for a G flat over the bins asked for (uncorrelated heights
    when the bins start at a pixel; the model takes G as ballistic below the first bin)
    on a map of this size bounds what any estimator can reach (a G that still rises over
    the bins gets more); random pairs add
    ``sqrt(SAMPLING_KAPPA / pairs per bin)`` and get at most half the target (a quarter
    of its variance) per bin. Cost model: :data:`COST`.
    """
    exact = _choose_estimator(da, grid, direction, pool)
    if exact == "tiled":  # the geometry without the (ky+1, kx+1) plane, cached for tiled
        edges = bin_edges(grid.shape, grid.spacing, False, grid.lateral_unit,
                          **binning_options)
        ks = binning.max_lags(grid.shape, grid.spacing, False, edges[-1])
        geo, rsum = _lattice_bins(tuple(grid.shape), tuple(grid.spacing), ks,
                                  tuple(edges.tolist()))
        keep = geo > 0
        dr, pairs = rsum[keep] / geo[keep], geo[keep] / 2
        shape, lag_axes, transformed = grid.shape, 2, 0.0
    else:
        plan = _plan(grid, direction=direction, **binning_options)
        dr, pairs, shape, lag_axes = plan.dr, plan.geometric_counts, plan.shape, \
            plan.lag_axes
        lag_shape = [n if plan.periodic else n + k for n, k in
                     zip(shape[-lag_axes:], plan.ks)]
        per_transform = float(np.prod(lag_shape))
        transformed = float(np.prod(shape[:-lag_axes])) * per_transform * np.log2(
            max(per_transform, 2.0))
    pool_dims = (pool,) if isinstance(pool, str) else tuple(pool or ())
    extra = [d for d in da.dims if d not in grid.dims]
    pooled = int(np.prod([da.sizes[d] for d in pool_dims if d in da.sizes]))
    maps = int(np.prod([da.sizes[d] for d in extra]))
    points = float(np.prod(shape))
    geometry = ("profile" if len(shape) == 1 else "radial" if lag_axes == 2 else "axis")
    floor = _error_floor(tuple(dr.tolist()), tuple((pairs * pooled).tolist()),
                         points * pooled * grid.pixel_area, grid.pixel_area, geometry)
    worst = int(np.nanargmax(floor))
    nb = dr.size
    cost = {exact: maps * (COST["fft"] * transformed if exact == "fft" else
                           COST["tiled"] * points)}
    whole = da.chunks is None or all(len(da.chunksizes[d]) == 1 for d in grid.dims)
    common = dict(floor=float(floor[worst]), floor_dr=float(dr[worst]), cost=cost)
    where = (f"the finite-area error of G is at least {floor[worst]:.2g} at dr = "
             f"{dr[worst]:.4g} {grid.lateral_unit} on a map of this size and these bins "
             "(standard_error of a G flat over the bins, the most favourable surface)")
    if target <= floor[worst]:
        return _Choice(exact, 0, sampling=0.0, reason=(
            f"target_error={target:g} is below what this map can give: {where}; no "
            f"estimator reaches it, so the exact one ({exact}) was used: a larger map, "
            "more maps (pool) or a narrower dr range lower the error"), **common)
    sampling = np.minimum(target / 2, np.sqrt(target**2 - floor**2))
    per_bin = int(np.ceil(SAMPLING_KAPPA / float(np.min(sampling)) ** 2))
    n_pairs = per_bin * nb
    per_bin_cost = COST["bin_2d"] if lag_axes == 2 else COST["bin_1d"]
    cost["random"] = maps * (per_bin_cost * nb + COST["pair"] * n_pairs
                             + COST["count"] * points)
    budget = (f"random pairs need {n_pairs:,} pairs ({per_bin:,} per bin) for a sampling "
              f"error of {float(np.min(sampling)):.2g} (at most half the target)")
    if not whole:
        return _Choice(exact, 0, sampling=0.0, reason=(
            f"{exact}: the map is split into dask chunks, which random pairs cannot read "
            f"({budget}); {where}"), **common)
    times = f"modelled {cost['random']:.3g} s against {cost[exact]:.3g} s for {exact}"
    if cost["random"] < cost[exact]:
        return _Choice("random", n_pairs, sampling=float(np.min(sampling)), reason=(
            f"random: {budget}, {times}; {where}"), **common)
    return _Choice(exact, 0, sampling=0.0, reason=(
        f"{exact}: cheaper than random pairs ({budget}, {times}); {where}"), **common)


def _report_choice(G: xr.DataArray, choice: _Choice, target: float) -> xr.DataArray:
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
    G = quality.mark_curves(G, (rel > target).astype(np.int8), what=what, notes=notes,
                            warn=not unreachable)
    if unreachable:
        G = quality.mark(G, choice.reason, level="questionable", what=what)
    return G


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
    target_error: Any = None,
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
        :func:`height_difference_acf_tiled`). ``'auto'`` (default) takes
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
    target_error : float or str, optional
        Relative standard error of G wanted in every bin (dimensionless: ``0.02`` or
        ``"2 %"``), the same in any unit of the map. The estimator and its budget are then
        chosen for it at the least modelled cost, from the shapes of the map and bins
        alone (so a dask map stays lazy): random pairs with ``n_pairs`` such that their
        sampling error ``sqrt(2 / pairs per bin)`` is at most half the target, when the
        cost model says that is cheaper than the exact estimator (``'fft'``, or
        ``'tiled'`` where ``'auto'`` would take it); the exact one otherwise, and when
        the target lies below what a map of this size can give at all (then the result
        is marked questionable, with a :class:`~xrough.QualityWarning`). Cannot be
        combined with ``estimator`` (other than ``'auto'``) or ``n_pairs``; ``seed`` is
        used if random pairs are chosen. See Notes and ``docs/performance.md``.

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
        Attrs name the measurement: ``direction``, ``lag_geometry`` (``'profile'``,
        ``'axis'`` or ``'radial'``: how the bins average, which sets how their errors
        correlate, :func:`xrough.spectrum`), ``pixel_size``, ``scan_size`` (in the unit
        of ``dr``), ``periodic``, ``bins``. With ``target_error``: coordinate
        ``achieved_error`` (largest ``standard_error / G`` over the bins, per curve;
        lazy for dask), ``quality_flag`` (questionable where it exceeds the target) and
        attrs ``target_error``, ``estimator_choice`` (what was
        chosen and why), ``n_pairs`` (random), ``sampling_error_budget``,
        ``error_floor`` and ``error_floor_dr`` (the smallest relative error a map of
        this size can give, and where), ``modelled_seconds_<estimator>``.

    Raises
    ------
    ValueError
        Invalid topography (dims, units, spacing, fewer than 2 valid points), unknown
        options, an empty lag range, chunked core dims; heights so large or small that G
        leaves the float64 range (G is computed from heights scaled by a power of two,
        so anything short of that is exact; raised at compute time for dask input);
        a ``target_error`` that is not a number in (0, 1) or is given with ``estimator``
        or ``n_pairs``.

    See Also
    --------
    xrough.acf_from_spectrum : G of a model spectrum (eq. 9).

    Notes
    -----
    With a validity mask ``m`` and heights zeroed where missing, the pair sums are
    ``S(d) = corr(h^2, m) + corr(m, h^2) - 2 corr(h, h)`` and ``N(d) = corr(m, m)``, each
    correlation a product of real FFTs; ``G = S / (2N)`` per bin. Without missing points a
    periodic map needs one forward and one inverse FFT.

    ``target_error`` ``t`` (section 3.1: run time against error). Errors, relative to G
    per bin: the finite-area error ``a`` of eq. 1 on this map (in ``standard_error``)
    and, for random pairs, the sampling error ``s = sqrt(2 / n)`` of ``n`` pairs per bin
    (``g / G`` of Gaussian increments is chi-squared with one degree of freedom; the
    reported ``sampling_error`` follows it), adding to ``sqrt(a^2 + s^2)``. ``a`` needs
    the data, so the choice uses its least value, ``a_min``: the model of
    ``standard_error`` for a G flat over the bins asked for, on a map of this size
    (uncorrelated heights, if the bins start at a pixel; a G that rises over the bins
    gets more). If ``t <= a_min`` the exact estimator is used and the result marked;
    otherwise random pairs get ``s = min(t / 2, sqrt(t^2 - a_min^2))`` per bin, which
    keeps ``sqrt(a^2 + s^2) <= t`` wherever ``a <= 0.87 t``. Cost model (seconds,
    measured by ``benchmarks/bench_acf_random.py --cost-model``, :data:`COST`): FFT
    ``1.5e-9 M log2 M`` (``M`` points transformed: the map, padded by the largest lag
    when open), tiled ``3.3e-7`` per map point, random ``8e-4`` per radial bin (``2e-4``
    along one axis) ``+ 1.6e-7`` per pair ``+ 3e-10`` per map point, each times the
    number of maps. Whether the target was met is data: ``achieved_error``.

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

    Run time against error: a 1024² open map, where 5 % per bin costs less with random
    pairs than with the padded FFT:

    >>> h = np.random.default_rng(0).normal(size=(1024, 1024))
    >>> rough = xrough.topography(h, spacing=1.0, unit="nm")
    >>> Gt = rough.rough.acf(target_error=0.05, dr_max=100, seed=0)
    >>> Gt.attrs["estimator"], Gt.attrs["n_pairs"], bool(Gt.achieved_error < 0.05)
    ('random pairs', 60800, True)
    """
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator must be one of {ESTIMATORS}, got {estimator!r}")
    if target_error is not None:
        target = _target_value(target_error)
        if estimator != "auto":
            raise ValueError(f"target_error chooses the estimator: give estimator="
                             f"{estimator!r} or target_error={target_error!r}, not both")
        if n_pairs != _DEFAULT_PAIRS:
            raise ValueError("target_error chooses n_pairs: give n_pairs or target_error, "
                             "not both")
        options = dict(bins=bins, points_per_decade=points_per_decade, bin_width=bin_width,
                       dr_min=dr_min, dr_max=dr_max)
        if bin_width is not None and not (isinstance(bins, str) and bins == "linear"):
            raise ValueError("bin_width applies to bins='linear' only")
        choice = _choose_for_target(topography, grid_of(topography), target,
                                    direction=direction, pool=pool, binning_options=options)
        random = choice.estimator == "random"
        G = height_difference_acf(
            topography, direction=direction, estimator=choice.estimator, pool=pool,
            n_pairs=choice.n_pairs if random else _DEFAULT_PAIRS,
            seed=seed if random else None, workers=workers, progress=progress, **options)
        return _report_choice(G, choice, target)
    if estimator != "random" and (seed is not None or n_pairs != _DEFAULT_PAIRS):
        raise ValueError("n_pairs and seed apply to estimator='random' only")
    if bin_width is not None and not (isinstance(bins, str) and bins == "linear"):
        raise ValueError("bin_width applies to bins='linear' only")
    grid = grid_of(topography)
    if estimator == "auto":
        estimator = _choose_estimator(topography, grid, direction, pool)
    if estimator == "tiled":
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
    common = dict(output_core_dims=[["packed"]], dask="parallelized",
                  dask_gufunc_kwargs={"output_sizes": {"packed": 3 * nb + 2}},
                  output_dtypes=[float], keep_attrs=False)
    if estimator == "fft":
        packed = xr.apply_ufunc(
            _fft_kernel, da, input_core_dims=[list(plan.core_dims)],
            kwargs={"plan": plan, "workers": workers, "progress": progress}, **common)
        random = False
    else:
        if not (isinstance(n_pairs, (int, np.integer)) and n_pairs > 0):
            raise ValueError(f"n_pairs must be a positive integer, got {n_pairs!r}")
        extra = [d for d in da.dims if d not in grid.dims]
        nmaps = int(np.prod([da.sizes[d] for d in extra])) if extra else 1
        seeds = np.random.SeedSequence(seed).generate_state(nmaps, dtype=np.uint64)
        seeds = xr.DataArray(seeds.reshape([da.sizes[d] for d in extra]), dims=extra)
        packed = xr.apply_ufunc(
            _random_kernel, da, seeds, input_core_dims=[list(plan.core_dims), []],
            kwargs={"plan": plan, "n_per_bin": max(1, int(n_pairs) // nb),
                    "progress": progress}, **common)
        random = True
    if pool_dims:  # one tree reduction over the maps
        packed = packed.reduce(_pool_over, dim=list(pool_dims))
    dr = plan.dr
    geometry = ("profile" if len(plan.shape) == 1 else
                "radial" if plan.lag_axes == 2 else "axis")
    hunit = grid.height_unit
    out = xr.apply_ufunc(
        _finish, packed, input_core_dims=[["packed"]], output_core_dims=[["part", "dr"]],
        dask="parallelized", output_dtypes=[float], keep_attrs=False,
        dask_gufunc_kwargs={"output_sizes": {"part": 4, "dr": nb}},
        kwargs={"dr": dr, "pixel_area": grid.pixel_area, "geometry": geometry,
                "height_unit": hunit, "random": random})
    G, counts, total, sampling = (out.isel(part=k, drop=True) for k in range(4))
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
        "lag_geometry": geometry,
        "periodic": int(grid.periodic),
        "bins": bins if isinstance(bins, str) else "explicit",
        "pixel_size": float(min(grid.spacing)),
        "scan_size": float(max(grid.size)),
        "source": str(topography.attrs.get("source", topography.name or "")),
    }
    attrs = result_attrs(topography, **attrs)  # with the topography's provenance
    if isinstance(bins, str) and bins == "log":
        attrs["points_per_decade"] = float(points_per_decade)
    if estimator == "random":
        attrs["n_pairs"] = int(n_pairs)
        attrs["seed"] = -1 if seed is None else int(seed)
    if pool_dims:
        attrs["pooled_over"] = " ".join(pool_dims)
    G.attrs = attrs
    return G


# ---------------------------------------------------------------------------------------
# maps larger than memory: tile by tile
# ---------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=4)
def _lattice_bins(shape, spacing, ks, edges_key, rows_per_block: int = 256):
    """Geometric pair counts and count-weighted lag sums per bin, a block of rows at a time.

    Equal to the in-memory estimator's geometry without a ``(ky+1, kx+1)`` array (ordered
    pairs; ``edges_key`` is the tuple of the bin edges). Cached per grid and bins: the
    choice of :func:`height_difference_acf` for a ``target_error`` reads it too.
    """
    edges = np.asarray(edges_key)
    nb = len(edges) - 1
    counts = np.zeros(nb + 1)
    rsum = np.zeros(nb + 1)
    (ny, nx), (dy, dx), (ky, kx) = shape, spacing, ks
    j = np.arange(kx + 1)
    wx = binning.lag_multiplicity(nx, kx, False) * (nx - j).astype(float)
    e2 = edges**2
    for i0 in range(0, ky + 1, rows_per_block):
        i = np.arange(i0, min(ky + 1, i0 + rows_per_block))
        wy = binning.lag_multiplicity(ny, ky, False)[i] * (ny - i).astype(float)
        r2 = (i[:, None] * dy) ** 2 + (j[None, :] * dx) ** 2
        idx = np.searchsorted(e2, r2, side="right") - 1
        idx[(idx < 0) | (idx >= nb)] = nb
        if i0 == 0:
            idx[0, 0] = nb
        w = wy[:, None] * wx[None, :]
        counts += np.bincount(idx.ravel(), weights=w.ravel(), minlength=nb + 1)
        rsum += np.bincount(idx.ravel(), weights=(w * np.sqrt(r2)).ravel(), minlength=nb + 1)
    counts, rsum = counts[:nb], rsum[:nb]
    counts.setflags(write=False)
    rsum.setflags(write=False)
    return counts, rsum


def _bin_idx(ks, spacing, edges):
    idx = binning.bin_index(binning.lag_radius2(ks, spacing), edges)
    idx[0, 0] = len(edges) - 1
    return idx


def _chunk_bounds(chunks: tuple[int, ...]) -> np.ndarray:
    return np.concatenate([[0], np.cumsum(chunks)]).astype(int)


def _overlaps(lo: np.ndarray, hi: np.ndarray, region: tuple[int, int]) -> list:
    """List the pieces ``[lo, hi)`` (per axis) that overlap ``region``.

    Each as (index, cut within the piece, start of the cut, whether the whole piece lies
    in the region).
    """
    first = int(np.searchsorted(hi, region[0], side="right"))
    last = int(np.searchsorted(lo, region[1], side="left"))
    out = []
    for i in range(first, last):
        a, b = max(int(lo[i]), region[0]), min(int(hi[i]), region[1])
        if a < b:
            out.append((i, (a - int(lo[i]), b - int(lo[i])), a,
                        a == lo[i] and b == hi[i]))
    return out


def _scaled_chunk(block, after=()):
    """Return :func:`~xrough._kernels.tiles.scaled_heights` of a chunk.

    ``after`` are results of tasks that must run before this chunk is read (unused: they
    only order the graph).
    """
    return tiles.scaled_heights(block)


def _tiled_graph(arr: dsa.Array, *, tile: int, factor: int, ks_levels, finish,
                 n_out: int, window: int = 4) -> dsa.Array:
    """Build the tiled estimator as one explicit dask graph on the chunks of ``arr`` (2D).

    Per chunk of the input (each read once, by one task): its heights scaled by their own
    power of two (a piece ``(values, e)``, see :mod:`xrough._kernels.tiles`), then its
    block statistics at each coarser level, coarsened within the chunk (blocks aligned to
    the whole map; a block that straddles chunks is split into partial blocks, merged
    exactly where a tile gathers them). Per level and tile: the pieces of the chunks that
    overlap the tile plus its halo, cut to that region where a piece is not wholly inside
    it (so that the rest of the chunk can be freed), gathered on their largest exponent
    and summed, one task per tile; a tree of sums per level; one task ``finish`` taking
    the level sums, whose ``(3, n_out)`` result is the one chunk of the returned array.
    Each chunk's first task also waits for the tasks that needed no chunk after the one
    ``window`` steps before it (row-major), so that the work sweeps the map and memory
    holds about two chunk rows.

    Tasks: ``C`` per level (``C`` chunks), one per tile, at most one cut per (tile,
    overlapping chunk) and about ``tiles / 7`` additions per level, plus one.
    """
    if any(np.isnan(c) for ch in arr.chunks for c in ch):
        raise ValueError("the tiled estimator needs known chunk sizes; call "
                         "compute_chunk_sizes() on the dask array first")
    name = "tiled-g-" + dask.base.tokenize(arr.name, tile, factor, ks_levels, finish)
    keys = arr.__dask_keys__()
    bounds = [_chunk_bounds(ch) for ch in arr.chunks]
    width = len(arr.chunks[1])
    dsk: dict = {}
    piece = {}
    step = {}  # the last chunk, in row-major order, that each task needs
    for i in range(len(arr.chunks[0])):
        for j in range(width):
            piece[i, j] = (f"{name}-piece-0", i, j)
            step[piece[i, j]] = i * width + j
    roots = []
    for lev, ks in enumerate(ks_levels):
        cell = factor**lev
        if lev > 0:
            finer = cell // factor
            for (i, j), key in list(piece.items()):
                offset = (int(bounds[0][i]) // finer, int(bounds[1][j]) // finer)
                piece[i, j] = (f"{name}-piece-{lev}", i, j)
                dsk[piece[i, j]] = (functools.partial(tiles.coarsen_piece, factor=factor,
                                                      offset=offset), key)
                step[piece[i, j]] = step[key]
        # cells [lo, hi) of each chunk's piece at this level, per axis
        spans = [(b[:-1] // cell, -(-b[1:] // cell)) for b in bounds]
        n_cells = [int(-(-b[-1] // cell)) for b in bounds]
        parts = []
        for ty, r0 in enumerate(range(0, n_cells[0], tile)):
            for tx, c0 in enumerate(range(0, n_cells[1], tile)):
                start, end = (r0, c0), (min(n_cells[0], r0 + tile), min(n_cells[1], c0 + tile))
                origin = tuple(s - k for s, k in zip(start, ks))  # of the extended tile
                hits = [_overlaps(*spans[ax], (max(0, origin[ax]),
                                               min(n_cells[ax], end[ax] + ks[ax])))
                        for ax in range(2)]
                args, origins = [], []
                for i, rows, y, whole_y in hits[0]:
                    for j, cols, x, whole_x in hits[1]:
                        if whole_y and whole_x:
                            args.append(piece[i, j])
                        else:
                            args.append((f"{name}-cut-{lev}", ty, tx, i, j))
                            dsk[args[-1]] = (functools.partial(tiles.cut_piece, rows=rows,
                                                               cols=cols), piece[i, j])
                            step[args[-1]] = step[piece[i, j]]
                        origins.append((y - origin[0], x - origin[1]))
                tile_key = (f"{name}-tile-{lev}", ty, tx)
                dsk[tile_key] = (functools.partial(
                    tiles.tile_piece_sums, origins=origins,
                    shape=tuple(e - s + 2 * k for s, e, k in zip(start, end, ks)),
                    inner=tuple(slice(k, k + e - s) for s, e, k in zip(start, end, ks)),
                    ks=ks), args)
                step[tile_key] = max(step[a] for a in args)
                parts.append(tile_key)
        roots.append(_tree_sum(dsk, parts, f"{name}-sum-{lev}", step))
    # A chunk is read only once the tiles, cuts and coarser pieces that needed no chunk
    # after the one `window` steps earlier are done: the computation sweeps the map row
    # by row, holding about a row of chunks, whatever order the scheduler prefers.
    after: dict = {}
    for key, s in step.items():
        if not key[0].startswith(f"{name}-piece-0"):
            after.setdefault(s + window, []).append(key)
    for (i, j), key in [(ij, (f"{name}-piece-0",) + ij) for ij in piece]:
        dsk[key] = (_scaled_chunk, keys[i][j], after.get(i * width + j, []))
    dsk[(name, 0, 0)] = (finish, roots)
    graph = HighLevelGraph.from_collections(name, dsk, dependencies=[arr])
    return dsa.Array(graph, name, chunks=((3,), (n_out,)), dtype=float)


def _tree_sum(dsk: dict, parts: list, name: str, step: dict, fan_in: int = 8):
    """Add a tree of :func:`~xrough._kernels.tiles.add_scaled` over ``parts`` to ``dsk``.

    Each sum's last chunk goes to ``step``; returns the key of the root.
    """
    depth = 0
    while len(parts) > 1:
        grouped = []
        for k in range(0, len(parts), fan_in):
            grouped.append((name, depth, k // fan_in))
            dsk[grouped[-1]] = (tiles.add_scaled, *parts[k:k + fan_in])
            step[grouped[-1]] = max(step[p] for p in parts[k:k + fan_in])
        parts, depth = grouped, depth + 1
    return parts[0]


def _assemble(level_sums, *, idxs, assign, keep, nb, dr, pixel_area, height_unit):
    """Bin each level's folded sums and keep, per bin, the level assigned to it.

    ``level_sums`` are pieces ``((S, N), e)`` (see :mod:`xrough._kernels.tiles`); G and
    its standard error are scaled back from the largest of their exponents.
    """
    exponents = [e for _, e in level_sums if e is not None]
    top = max(exponents) if exponents else 0
    sums = np.zeros(nb)
    counts = np.zeros(nb)
    for lev, ((plane, e), idx) in enumerate(zip(level_sums, idxs)):
        s = plane[0] if e is None or e == top else np.ldexp(plane[0], 2 * (e - top))
        s = 0.5 * binning.binned_sum(s, idx, nb)
        n = 0.5 * binning.binned_sum(plane[1], idx, nb)
        sel = assign == lev
        sums[sel], counts[sel] = s[sel], n[sel]
    sums, counts = sums[keep], counts[keep]
    valid = level_sums[0][0][1][0, 0]
    has = counts > 0
    g = np.full(counts.shape, np.nan)
    g[has] = 0.5 * sums[has] / counts[has]
    se = _area_variance(g[None], counts[None], np.array([valid]), dr=dr,
                        pixel_area=pixel_area, geometry="radial")[0]
    se = np.sqrt(se)
    se[~has] = np.nan
    g, se = (_times_power_of_two(x, top, power=2, height_unit=height_unit) for x in (g, se))
    return np.stack([g, counts, se])


def height_difference_acf_tiled(
    topography: xr.DataArray,
    *,
    tile: int = 1024,
    halo: int = 256,
    factor: int = 4,
    min_lag_cells: int = 16,
    bins: Any = "log",
    points_per_decade: float = 10,
    bin_width: Any = None,
    dr_min: Any = None,
    dr_max: Any = None,
    progress: bool | None = None,
) -> xr.DataArray:
    r"""Radial ``G(dr)`` of a map too large for one FFT, tile by tile (out of core).

    Parameters
    ----------
    topography : xarray.DataArray with dims ("y", "x")
        Heights of an open (non-periodic) map, numpy- or dask-backed (e.g. opened from
        NetCDF or zarr with ``chunks=``); NaN marks missing points. Any chunking works;
        each chunk is read once. Chunks of about ``tile`` points per side keep the graph
        small (numpy input is split into such chunks).
    tile : int
        Tile size in cells (points at the finest level, blocks at coarser ones).
    halo : int
        ``K``: lags up to ``K`` cells per axis are summed exactly at each level. Lags
        whose bin lies within ``K`` pixels (per axis) are exact.
    factor : int
        Block size ratio between levels (level ``l`` has blocks of ``factor**l`` points).
    min_lag_cells : int
        A coarse level is only used for bins whose lags are at least this many of its
        blocks; ``halo`` must be large enough for that (``halo >= 1.3 min_lag_cells
        factor`` for the default log bins).
    bins, points_per_decade, bin_width, dr_min, dr_max
        As for :func:`xrough.height_difference_acf`; the bins and the ``dr`` coordinate
        are the same, so results compare bin by bin.
    progress : bool, optional
        Show dask's progress bar while computing numpy input (default: in a terminal).
        Lazy (dask) results show it when computed under
        ``dask.diagnostics.ProgressBar()``.

    Returns
    -------
    xarray.DataArray
        ``G`` on dim ``dr`` with coords ``pair_count``, ``standard_error`` and
        ``block`` (points per block side of the level that gave each bin: 1 is exact).
        Dask-backed (lazy) if the input is, else computed.

    Raises
    ------
    ValueError
        Invalid topography, a periodic map or extra dims, a halo too small for
        ``min_lag_cells``, or the options refused by the in-memory estimator.

    See Also
    --------
    xrough.height_difference_acf : the in-memory estimators.

    Notes
    -----
    For bins within the halo the pair sums are those of ``estimator='fft'`` (the sums of
    the tiles' folded lag planes, equal to round-off). A coarse level sums, exactly, all
    pairs of points whose blocks are ``R`` blocks apart, and files them at lag
    ``R factor**l``; a pair's true lag differs by less than one block per axis. Within a
    bin of lags ``>= min_lag_cells`` blocks this shifts G by about
    ``G''(r) b^2 / 6`` (``b`` the block length), a relative error of order
    ``(b / r)^2``: measured below 1e-3 for self-affine and Gaussian-correlated maps with
    the defaults (``tests/test_scale.py``).

    Heights are scaled per chunk by a power of two (exactly undone when the sums meet), so
    the tiles need no pass over the whole map first. Peak memory is a few tile FFTs per
    thread plus about two chunk rows of pieces and halo strips; 11 to 15 tasks per chunk (see
    ``docs/scale.md`` for measured time and memory against the map size).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> from xrough.correlation import height_difference_acf_tiled
    >>> h = np.random.default_rng(0).normal(size=(128, 128))
    >>> topo = xrough.topography(h, spacing=1.0, unit="nm")
    >>> G = height_difference_acf_tiled(topo, tile=64, halo=32, factor=2, min_lag_cells=8)
    >>> ref = topo.rough.acf()
    >>> bool(np.allclose(G.values, ref.values, rtol=0.05))
    True
    """
    grid = grid_of(topography)
    if topography.dims != ("y", "x"):
        raise ValueError(f"the tiled estimator takes one map with dims ('y', 'x'), got "
                         f"{topography.dims}; loop over extra dims")
    if grid.periodic:
        raise ValueError("the tiled estimator is for open maps; periodic maps: use "
                         "height_difference_acf (its FFT needs no padding)")
    if not (tile >= 1 and halo >= 1 and factor >= 2 and min_lag_cells >= 1):
        raise ValueError("need tile >= 1, halo >= 1, factor >= 2, min_lag_cells >= 1")
    if bin_width is not None and not (isinstance(bins, str) and bins == "linear"):
        raise ValueError("bin_width applies to bins='linear' only")
    shape, spacing = grid.shape, grid.spacing
    edges = bin_edges(grid.shape, grid.spacing, grid.periodic, grid.lateral_unit,
                      bins=bins, points_per_decade=points_per_decade, bin_width=bin_width,
                      dr_min=dr_min, dr_max=dr_max)
    nb = len(edges) - 1
    ks_full = binning.max_lags(shape, spacing, False, edges[-1])
    geo, rsum = _lattice_bins(tuple(shape), tuple(spacing), ks_full, tuple(edges.tolist()))
    keep = geo > 0
    if not keep.any():
        raise ValueError("no lattice lag in the requested dr range")
    dr = rsum[keep] / geo[keep]

    # levels: level l covers lags up to K cells of factor**l points per axis
    cells, ks_levels = [], []
    lev = 0
    while True:
        f = factor**lev
        n_l = tuple(-(-n // f) for n in shape)
        ks_l = tuple(min(halo, m - 1) for m in n_l)
        cells.append(f)
        ks_levels.append(ks_l)
        reach = all(k == m - 1 or (k + 1) * f >= kf for k, m, kf in zip(ks_l, n_l, ks_full))
        if reach:
            break
        lev += 1
    # each bin goes to the finest level whose lattice holds all its lags
    assign = np.zeros(nb, dtype=int)
    for b in range(nb):
        e1 = edges[b + 1]
        for lev, (f, ks_l) in enumerate(zip(cells, ks_levels)):
            n_l = tuple(-(-n // f) for n in shape)
            # largest lag index (points) with a lag shorter than e1, within the map
            need = [min(kf, int(np.ceil(e1 / d)) - 1) for d, kf in zip(spacing, ks_full)]
            if all(k == m - 1 or nd <= (k if lev == 0 else (k + 1) * f - 1)
                   for k, m, nd in zip(ks_l, n_l, need)):
                assign[b] = lev
                break
        if assign[b] > 0 and keep[b] and edges[b] < min_lag_cells * cells[assign[b]] * min(
                spacing) * (1 - 1e-12):
            raise ValueError(
                f"halo={halo} is too small: lags from {edges[b]:g} {grid.lateral_unit} would "
                f"come from blocks of {cells[assign[b]]} points, fewer than "
                f"min_lag_cells={min_lag_cells} blocks; raise halo to at least "
                f"{int(np.ceil(1.3 * min_lag_cells * factor))}")
    used = int(assign.max()) + 1

    data = topography.data
    lazy = isinstance(data, dsa.Array)
    arr = data if lazy else dsa.from_array(np.asarray(data), chunks=(tile, tile))
    idxs = [_bin_idx(ks, tuple(d * cell for d in spacing), edges)
            for ks, cell in zip(ks_levels[:used], cells)]
    finish = functools.partial(_assemble, idxs=idxs, assign=assign, keep=keep, nb=nb, dr=dr,
                               pixel_area=grid.pixel_area, height_unit=grid.height_unit)
    res = _tiled_graph(arr, tile=tile, factor=factor, ks_levels=ks_levels[:used],
                       finish=finish, n_out=int(keep.sum()))
    hunit = grid.height_unit
    if not lazy:
        show = progress if progress is not None else sys.stderr.isatty()
        if show:
            with ProgressBar(minimum=1.0):
                res = res.compute()
        else:
            res = res.compute()
    h2 = u.power_units(hunit, 2)
    G = xr.DataArray(
        res[0], dims=("dr",), name="G",
        coords={
            "dr": ("dr", dr, {"units": grid.lateral_unit, "long_name": "lag distance"}),
            "pair_count": ("dr", res[1], {"long_name": "number of point pairs averaged",
                                          "units": "1"}),
            "standard_error": ("dr", res[2], {"units": h2,
                                              "long_name": "standard error of G"}),
            "block": ("dr", np.asarray(cells)[assign[keep]],
                      {"units": "1", "long_name": "points per block side (1: exact)"}),
        })
    attrs = {
        "units": h2,
        "long_name": "height-difference autocorrelation function",
        "symbol": "G",
        "equation": "eq. 1: G(dr) = 1/2 <(h(r) - h(r + dr))^2>",
        "estimator": "tiled (exact within the halo, block levels beyond)",
        "direction": "radial",
        "lag_geometry": "radial",
        "periodic": 0,
        "bins": bins if isinstance(bins, str) else "explicit",
        "pixel_size": float(min(spacing)),
        "scan_size": float(max(grid.size)),
        "tile": int(tile),
        "halo": int(halo),
        "factor": int(factor),
        "min_lag_cells": int(min_lag_cells),
        "source": str(topography.attrs.get("source", topography.name or "")),
    }
    if isinstance(bins, str) and bins == "log":
        attrs["points_per_decade"] = float(points_per_decade)
    G.attrs = result_attrs(topography, **attrs)  # with the topography's provenance
    return G
