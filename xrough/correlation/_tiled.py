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

The computation is one dask graph on the chunks of the (possibly NetCDF- or zarr-backed)
map: each chunk is read once, by one task that scales its heights by their own power of
two (so no tile waits for a maximum over the whole map) and from which its block
statistics at every level are derived; a tile takes its chunks and thin halo strips cut
from the neighbouring ones; the reduction is a tree of sums of small lag planes.
"""

from __future__ import annotations

import functools
import sys
from typing import Any

import dask
import dask.array as dsa
import numpy as np
import xarray as xr
from dask.diagnostics import ProgressBar
from dask.highlevelgraph import HighLevelGraph

from .._kernels import binning, tiles
from ..topography import Grid, grid_of
from ._plan import OpenMapBins, check_bin_width, open_map_bins
from ._result import g_result, g_unit


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
                                        "long_name": "points per block side (1: exact)"})},
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
    lazy = isinstance(data, dsa.Array)
    arr = data if lazy else dsa.from_array(np.asarray(data), chunks=(tile, tile))
    edges = lag_bins.edges
    idxs = [binning.folded_bin_index(ks, tuple(d * cell for d in grid.spacing), edges)
            for ks, cell in zip(ks_levels, cells)]
    finish = functools.partial(tiles.assemble, idxs=idxs, assign=assign, keep=lag_bins.keep,
                               nb=len(edges) - 1, dr=lag_bins.dr, pixel_area=grid.pixel_area,
                               height_unit=grid.height_unit, g_unit=g_unit(grid))
    res = _tiled_graph(arr, tile=tile, factor=factor, ks_levels=ks_levels, finish=finish,
                       n_out=int(lag_bins.keep.sum()))
    if lazy:
        return res
    if progress if progress is not None else sys.stderr.isatty():
        with ProgressBar(minimum=1.0):
            return res.compute()
    return res.compute()


class _Graph:
    """The tasks of the tiled estimator under construction (see :func:`_tiled_graph`).

    ``piece[i, j]`` is the key of chunk ``(i, j)``'s piece at the current level; ``step``
    maps every key to the last chunk, in row-major order, that its task needs.
    """

    def __init__(self, arr: dsa.Array, name: str):
        self.name = name
        self.bounds = [tiles.chunk_bounds(ch) for ch in arr.chunks]
        self.width = len(arr.chunks[1])
        self.dsk: dict = {}
        self.piece: dict = {}
        self.step: dict = {}
        for i in range(len(arr.chunks[0])):
            for j in range(self.width):
                self.piece[i, j] = (f"{name}-piece-0", i, j)
                self.step[self.piece[i, j]] = i * self.width + j

    def coarsen(self, lev: int, factor: int) -> None:
        """Derive each chunk's piece at level ``lev`` from its piece one level finer."""
        finer = factor ** (lev - 1)
        for (i, j), key in list(self.piece.items()):
            offset = (int(self.bounds[0][i]) // finer, int(self.bounds[1][j]) // finer)
            self.piece[i, j] = (f"{self.name}-piece-{lev}", i, j)
            self.dsk[self.piece[i, j]] = (functools.partial(
                tiles.coarsen_piece, factor=factor, offset=offset), key)
            self.step[self.piece[i, j]] = self.step[key]

    def tile_sums(self, lev: int, cell: int, ks: tuple[int, int], tile: int) -> list:
        """Add one task per tile of level ``lev`` (blocks of ``cell`` points); their keys."""
        # cells [lo, hi) of each chunk's piece at this level, per axis
        spans = [(b[:-1] // cell, -(-b[1:] // cell)) for b in self.bounds]
        n_cells = [int(-(-b[-1] // cell)) for b in self.bounds]
        parts = []
        for ty, r0 in enumerate(range(0, n_cells[0], tile)):
            for tx, c0 in enumerate(range(0, n_cells[1], tile)):
                start = (r0, c0)
                end = (min(n_cells[0], r0 + tile), min(n_cells[1], c0 + tile))
                origin = tuple(s - k for s, k in zip(start, ks))  # of the extended tile
                hits = [tiles.overlaps(*spans[ax], (max(0, origin[ax]),
                                                    min(n_cells[ax], end[ax] + ks[ax])))
                        for ax in range(2)]
                args, origins = self._tile_args(lev, ty, tx, hits, origin)
                tile_key = (f"{self.name}-tile-{lev}", ty, tx)
                self.dsk[tile_key] = (functools.partial(
                    tiles.tile_piece_sums, origins=origins,
                    shape=tuple(e - s + 2 * k for s, e, k in zip(start, end, ks)),
                    inner=tuple(slice(k, k + e - s) for s, e, k in zip(start, end, ks)),
                    ks=ks), args)
                self.step[tile_key] = max(self.step[a] for a in args)
                parts.append(tile_key)
        return parts

    def _tile_args(self, lev, ty, tx, hits, origin):
        """Pieces of a tile (whole, or cut to its region) and their origins in the tile."""
        args, origins = [], []
        for i, rows, y, whole_y in hits[0]:
            for j, cols, x, whole_x in hits[1]:
                if whole_y and whole_x:
                    args.append(self.piece[i, j])
                else:
                    args.append((f"{self.name}-cut-{lev}", ty, tx, i, j))
                    self.dsk[args[-1]] = (functools.partial(tiles.cut_piece, rows=rows,
                                                            cols=cols), self.piece[i, j])
                    self.step[args[-1]] = self.step[self.piece[i, j]]
                origins.append((y - origin[0], x - origin[1]))
        return args, origins

    def tree_sum(self, parts: list, name: str, fan_in: int = 8):
        """Add a tree of :func:`~xrough._kernels.tiles.add_scaled` over ``parts``; its root."""
        depth = 0
        while len(parts) > 1:
            grouped = []
            for k in range(0, len(parts), fan_in):
                grouped.append((name, depth, k // fan_in))
                self.dsk[grouped[-1]] = (tiles.add_scaled, *parts[k:k + fan_in])
                self.step[grouped[-1]] = max(self.step[p] for p in parts[k:k + fan_in])
            parts, depth = grouped, depth + 1
        return parts[0]

    def read_chunks(self, keys, window: int) -> None:
        """Add the task reading each chunk, after the tasks that needed no later chunk.

        A chunk is read only once the tiles, cuts and coarser pieces that needed no chunk
        after the one ``window`` steps earlier are done: the computation sweeps the map
        row by row, holding about a row of chunks, whatever order the scheduler prefers.
        """
        first = f"{self.name}-piece-0"
        after: dict = {}
        for key, s in self.step.items():
            if not key[0].startswith(first):
                after.setdefault(s + window, []).append(key)
        for i, j in self.piece:
            self.dsk[(first, i, j)] = (tiles.scaled_chunk, keys[i][j],
                                       after.get(i * self.width + j, []))


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
    g = _Graph(arr, name)
    roots = []
    for lev, ks in enumerate(ks_levels):
        if lev > 0:
            g.coarsen(lev, factor)
        roots.append(g.tree_sum(g.tile_sums(lev, factor**lev, ks, tile), f"{name}-sum-{lev}"))
    g.read_chunks(arr.__dask_keys__(), window)
    g.dsk[(name, 0, 0)] = (finish, roots)
    graph = HighLevelGraph.from_collections(name, g.dsk, dependencies=[arr])
    return dsa.Array(graph, name, chunks=((3,), (n_out,)), dtype=float)
