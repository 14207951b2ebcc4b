"""Maps larger than memory: exact pair sums by tiles, coarse block levels for long lags.

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

The computation is a dask array built from dask's own operations on the chunks of the
(possibly NetCDF- or zarr-backed) map, each chunk read once: the map in chunks of one
tile, extended by the halo from the neighbouring chunks (:func:`dask.array.overlap.overlap`),
one task per tile (:func:`dask.array.blockwise`; for the default options it gives the
tile's planes at level 0 and at level 1 from the same extended heights), and tree
reductions (:func:`dask.array.reduction`) along each row of tiles and over the rows, so
that the partial sums are added as the map is swept. Coarser levels take block
statistics derived chunk by chunk (:meth:`dask.array.Array.map_blocks`), with tiles and
trees of their own.
"""

from __future__ import annotations

import functools
import sys
from typing import Any

import numpy as np
import xarray as xr

from .._kernels import binning, tiles
from .._kernels.deferred import dask_array as dsa
from .._kernels.deferred import dask_diagnostics, is_dask_array
from ..topography import Grid, grid_of
from ._plan import OpenMapBins, check_bin_width, open_map_bins
from ._result import g_result, g_unit, height_variance


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
        Show dask's progress bar while computing numpy input (default: in a terminal);
        lazy results show it when computed under ``dask.diagnostics.ProgressBar()``.

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
    Accuracy of the coarse levels, scaling, memory: docs/performance.md,
    "height_difference_acf_tiled in detail".

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
    grid = _checked_grid(topography, tile=tile, halo=halo, factor=factor,
                         min_lag_cells=min_lag_cells, bins=bins, bin_width=bin_width)
    lag_bins = open_map_bins(grid, bins=bins, points_per_decade=points_per_decade,
                          bin_width=bin_width, dr_min=dr_min, dr_max=dr_max)
    cells, ks_levels, assign = _levels(grid, lag_bins, halo=halo, factor=factor,
                                       min_lag_cells=min_lag_cells)
    res = _computed(topography, grid, lag_bins, cells=cells, ks_levels=ks_levels,
                    assign=assign, tile=tile, factor=factor, progress=progress)
    block = np.asarray(cells)[assign[lag_bins.keep]]
    part = [xr.DataArray(res[k], dims=("dr",)) for k in range(3)]
    return g_result(
        topography, grid, part[0], dr=lag_bins.dr, pair_count=part[1], standard_error=part[2],
        coords={"block": ("dr", block, {"units": "1",
                                        "long_name": "points per block side (1: exact)"}),
                "height_variance": height_variance(topography, grid, lag_dims=grid.dims)},
        estimator="tiled (exact within the halo, block levels beyond)", direction="radial",
        geometry="radial", bins=bins, points_per_decade=points_per_decade, tile=int(tile),
        halo=int(halo), factor=int(factor), min_lag_cells=int(min_lag_cells))


def _checked_grid(topography: xr.DataArray, *, tile, halo, factor, min_lag_cells, bins,
                  bin_width) -> Grid:
    """Return the grid of one open map, with the tiling options checked."""
    grid = grid_of(topography)
    if topography.dims != ("y", "x"):
        raise ValueError(f"the tiled estimator takes one map with dims ('y', 'x'), got "
                         f"{topography.dims}; loop over extra dims")
    if grid.periodic:
        raise ValueError("the tiled estimator is for open maps; periodic maps: use "
                         "height_difference_acf (its FFT needs no padding)")
    if not (tile >= 1 and halo >= 1 and factor >= 2 and min_lag_cells >= 1):
        raise ValueError("need tile >= 1, halo >= 1, factor >= 2, min_lag_cells >= 1")
    check_bin_width(bins, bin_width)
    return grid


def _levels(grid: Grid, lag_bins: OpenMapBins, *, halo, factor, min_lag_cells):
    """Block side and lags per level, and the level of each bin (refusing a small halo)."""
    cells, ks_levels = tiles.block_levels(grid.shape, halo, factor, lag_bins.ks)
    edges = lag_bins.edges
    assign = tiles.bin_levels(edges, grid.spacing, grid.shape, cells, ks_levels, lag_bins.ks)
    shortest = min_lag_cells * np.asarray(cells)[assign] * min(grid.spacing) * (1 - 1e-12)
    coarse = (assign > 0) & lag_bins.keep & (edges[:-1] < shortest)
    if coarse.any():
        b = int(np.argmax(coarse))
        raise ValueError(
            f"halo={halo} is too small: lags from {edges[b]:g} {grid.lateral_unit} would "
            f"come from blocks of {cells[assign[b]]} points, fewer than "
            f"min_lag_cells={min_lag_cells} blocks; raise halo to at least "
            f"{int(np.ceil(1.3 * min_lag_cells * factor))}")
    used = int(assign.max()) + 1
    return cells[:used], ks_levels[:used], assign


def _computed(topography: xr.DataArray, grid: Grid, lag_bins: OpenMapBins, *, cells,
              ks_levels, assign, tile, factor, progress):
    """``(G, pair count, standard error)`` of the kept bins: lazy for dask input."""
    data = topography.data
    lazy = is_dask_array(data)
    arr = data if lazy else dsa.from_array(np.asarray(data), chunks=(tile, tile))
    edges = lag_bins.edges
    idxs = [binning.folded_bin_index(ks, tuple(d * cell for d in grid.spacing), edges)
            for ks, cell in zip(ks_levels, cells)]
    finish = functools.partial(tiles.assemble, ks_levels=ks_levels, idxs=idxs, assign=assign,
                               keep=lag_bins.keep, nb=len(edges) - 1, dr=lag_bins.dr,
                               pixel_area=grid.pixel_area, height_unit=grid.height_unit,
                               g_unit=g_unit(grid))
    res = _tiled_graph(arr, tile=tile, factor=factor, ks_levels=ks_levels, finish=finish,
                       n_out=int(lag_bins.keep.sum()))
    if lazy:
        return res
    if progress if progress is not None else sys.stderr.isatty():
        with dask_diagnostics.ProgressBar(minimum=1.0):
            return res.compute()
    return res.compute()


def _tiled_graph(arr: dsa.Array, *, tile: int, factor: int, ks_levels, finish,
                 n_out: int, row_every: int = 8, split_every: int = 2) -> dsa.Array:
    """Build the tiled estimator as one dask array on the chunks of ``arr`` (2D heights).

    Per level ``l`` (blocks of ``factor**l`` points): the map in chunks of one tile of
    ``tile`` cells, each extended by the level's halo with cells of its neighbours
    (:func:`dask.array.overlap.overlap`; NaN heights or empty blocks outside the map),
    reduced to its folded lag planes (one task per tile, :func:`dask.array.blockwise`;
    encoded by :func:`~xrough._kernels.tiles.encode`); a tree sums them along each row of
    tiles (``row_every`` per step) and a tree over the rows (``split_every``), both
    :func:`dask.array.reduction`; ``finish`` takes the level sums, and its
    ``(3, n_out)`` result is the one chunk of the returned array.

    Levels 0 and 1 share their tiles when the halo of level 1 (``ks1 * factor`` points)
    fits in one chunk (the default ``tile=1024, halo=256, factor=4``): the heights of
    each tile are extended once, by ``depth`` = the larger halo, and one task gives both
    levels' planes (:func:`~xrough._kernels.tiles.tile_two_levels`), so both are summed
    as the map is swept (dask orders the tasks by the trees): the sweep holds a band of
    about two rows of chunks and the partial sums of a few rows. Otherwise level 1, and
    always the coarser levels (``factor**2`` times fewer cells and fewer), take block
    statistics ``(n, mu, M2, e)`` derived from each chunk of heights
    (:func:`~xrough._kernels.tiles.height_stats`) or from the level before
    (:func:`~xrough._kernels.tiles.coarsen_scaled`, chunks aligned to the blocks), with
    their own tiles and trees; their statistics are small (a level-2 map has 256 times
    fewer cells than the map has points). Each chunk of ``arr`` is read once: its tasks
    (halo strips, tiles, block statistics) all take the one read.
    """
    if any(np.isnan(c) for ch in arr.chunks for c in ch):
        raise ValueError("the tiled estimator needs known chunk sizes; call "
                         "compute_chunk_sizes() on the dask array first")
    if arr.dtype.kind != "f":
        arr = arr.astype(float)
    sizes = [2 * (ky + 1) * (kx + 1) + 1 for ky, kx in ks_levels]
    depth = None
    if len(ks_levels) > 1:  # halo of a tile for both level 0 and level 1, if it can be
        depth = tuple(-(-max(k0, k1 * factor) // factor) * factor
                      for k0, k1 in zip(*ks_levels[:2]))
        chunks = _tile_chunks(arr.shape, tile, depth)
        if tile % factor or any(min(c) < d for c, d in zip(chunks, depth)):
            depth = None
    if depth is not None:
        # one task per tile for levels 0 and 1 (the blocks of level 1 from the heights
        # of the tile and its halo of one block tile), one tree
        heights = arr.rechunk(chunks)
        ext = dsa.overlap.overlap(heights, depth=dict(enumerate(depth)), boundary=np.nan)
        both = functools.partial(tiles.tile_two_levels, ks0=ks_levels[0], ks1=ks_levels[1],
                                 depth=depth, factor=factor)
        levels = [dsa.blockwise(both, "yxp", ext, "yx", new_axes={"p": sizes[0] + sizes[1]},
                                adjust_chunks={"y": 1, "x": 1}, dtype=float,
                                meta=np.empty((0, 0, 0)), token="tiled-g-tile-sums")]
        sizes[:2] = [sizes[:2]]
        first_coarse = 2
    else:
        heights = arr.rechunk(_tile_chunks(arr.shape, tile, ks_levels[0]))
        levels = [_tile_sums(heights, ks_levels[0], np.nan, tiles.tile_height_sums)]
        first_coarse = 1
    stats = None
    for lev, ks in enumerate(ks_levels[first_coarse:], start=first_coarse):
        if stats is None:  # the first level of its own: from the heights of each chunk
            step = factor**lev
            aligned = _aligned(heights, step, (0, 1))
            stats = dsa.map_blocks(
                tiles.height_stats, aligned, step,
                chunks=((4,),) + _coarse_chunks(aligned, step),
                new_axis=0, dtype=float, meta=np.empty((0, 0, 0)))
        else:
            aligned = _aligned(stats, factor, (1, 2))
            stats = dsa.map_blocks(tiles.coarsen_scaled, aligned, factor,
                                       chunks=((4,),) + _coarse_chunks(aligned, factor, 1),
                                       dtype=float, meta=np.empty((0, 0, 0)))
        cells = stats.rechunk(((4,),) + _tile_chunks(stats.shape[1:], tile, ks))
        levels.append(_tile_sums(cells, (0,) + ks, 0.0, tiles.tile_stats_sums))
    totals = []
    for level, size in zip(levels, sizes):
        add = functools.partial(tiles.add_encoded, sizes=np.atleast_1d(size).tolist())
        # a tree along each row of tiles, then a tree over the rows
        rows = dsa.reduction(level, tiles.first, add, combine=add, axis=1, keepdims=True,
                             split_every={1: row_every}, dtype=float,
                             meta=np.empty((0, 0, 0)), name="tiled-g-tile-sums")
        totals.append(dsa.reduction(rows, tiles.first, add, combine=add, axis=(0, 1),
                                    split_every={0: split_every, 1: 2}, dtype=float,
                                    meta=np.empty((0,)), name="tiled-g-tile-sums"))
    total = dsa.concatenate(totals).rechunk(-1) if len(totals) > 1 else totals[0]
    return total.map_blocks(finish, chunks=((3,), (n_out,)), new_axis=1, dtype=float,
                            meta=np.empty((0, 0)))


def _tile_chunks(shape, tile: int, ks) -> tuple:
    """Return chunks of ``tile`` cells along each axis.

    The last is merged into the one before if it is thinner than the halo ``ks`` (a halo
    is taken from the neighbouring chunk only).
    """
    out = []
    for n, k in zip(shape, ks):
        ch = [tile] * (n // tile) + ([n % tile] if n % tile else [])
        if len(ch) > 1 and ch[-1] < k:
            ch[-2:] = [ch[-2] + ch[-1]]
        out.append(tuple(ch))
    return tuple(out)


def _aligned(arr: dsa.Array, factor: int, axes) -> dsa.Array:
    """``arr`` with its chunks along ``axes`` starting at multiples of ``factor``."""
    chunks = list(arr.chunks)
    for ax in axes:
        bounds = np.cumsum(arr.chunks[ax])
        inner = sorted({int(b) // factor * factor for b in bounds[:-1]} - {0})
        chunks[ax] = tuple(np.diff([0, *inner, int(bounds[-1])]).tolist())
    return arr.rechunk(tuple(chunks))


def _coarse_chunks(arr: dsa.Array, factor: int, first: int = 0):
    """Chunks of blocks of ``factor`` cells of the (aligned) chunks along the last 2 axes."""
    return tuple(tuple(-(-c // factor) for c in arr.chunks[ax])
                 for ax in range(first, first + 2))


def _tile_sums(cells: dsa.Array, ks, outside, tile_sums) -> dsa.Array:
    """Return the encoded lag planes of each tile of one level: ``(tiles y, tiles x, size)``.

    ``cells``: the level's map in chunks of one tile (heights, or block statistics with
    their channel first); ``ks``: the halo per axis; ``outside``: the value beyond the
    map's edges.
    """
    depth = dict(enumerate(ks))
    boundary = {ax: (outside if k else "none") for ax, k in depth.items()}
    ext = dsa.overlap.overlap(cells, depth=depth, boundary=boundary)
    size = 2 * (ks[-2] + 1) * (ks[-1] + 1) + 1
    return dsa.blockwise(functools.partial(tile_sums, ks=tuple(ks[-2:])), "yxp", ext,
                         "cyx"[-cells.ndim:], new_axes={"p": size},
                         adjust_chunks={"y": 1, "x": 1}, concatenate=True, dtype=float,
                         meta=np.empty((0, 0, 0)), token="tiled-g-tile-sums")
