"""Pair sums of a map tile by tile, and block statistics for coarser levels (pure numpy).

A map is described at every level by *block statistics*: for each cell, the number ``n`` of
valid points it holds, their mean ``mu`` and the sum ``M2`` of squared deviations from that
mean. At the finest level a cell is one point (``n`` = 1 or 0, ``M2`` = 0).

For two cells ``A`` and ``B`` the sum of squared height differences over all pairs of
valid points ``a`` in ``A``, ``b`` in ``B`` is exactly

    sum (h_a - h_b)^2 = n_B q_A + n_A q_B - 2 s_A s_B,   s = n (mu - c),  q = M2 + n (mu - c)^2

for any constant ``c`` (the offset cancels), and the number of pairs is ``n_A n_B``. Summed
over all cell pairs at cell lag ``d`` this is the masked pair-sum formula of
:mod:`.pairs` with the mask replaced by ``n``: three cross-correlations. At the finest level
it gives the exact pair sums; at a coarse level it gives the exact sums over all point
pairs, grouped by the lag of their cells rather than by their own lag (which differs by less
than one cell per axis).

Tiles: the pair sums for lags ``|i| <= Ky, |j| <= Kx`` are additive over the first point of
each ordered pair. For a tile, the cross-correlation of the tile's statistics with the
statistics of the tile extended by the halo ``K`` on every side (zero outside the map)
counts every ordered pair whose first point is in the tile exactly once; the folded lag
planes of all tiles add up to those of the whole map.

Scales: heights are divided by a power of two per *piece* (a chunk of the map, or the
block statistics derived from it) so that no square overflows; a piece is a pair
``(values, e)`` meaning ``values * 2**e`` (``e`` is None for a piece without valid
points). Pieces, tiles and partial sums meet on the largest exponent among them; a
multiplication by a power of two is exact, so the result is the same as with one global
scale, without a pass over the whole map first.
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sfft

from .binning import binned_sum
from .pairs import area_variance, fold, require_no_inf, times_power_of_two

__all__ = ["power_of_two_exponent", "scaled_heights", "point_stats", "coarsen_stats",
           "coarsen_piece", "cut_piece", "merge_stats", "tile_piece_sums", "add_scaled",
           "tile_pair_sums", "block_levels", "bin_levels", "chunk_bounds", "overlaps",
           "scaled_chunk", "assemble"]


def power_of_two_exponent(peak) -> np.ndarray:
    """Exponent ``e`` of the power of two nearest ``peak`` (0 for a non-finite or zero peak)."""
    peak = np.asarray(peak, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        exponent = np.where(np.isfinite(peak) & (peak > 0), np.round(np.log2(peak)), 0.0)
    return exponent.astype(int)


def scaled_heights(h: np.ndarray) -> tuple[np.ndarray, int | None]:
    """Return a chunk of heights as a piece ``(h / 2**e, e)``, ``2**e`` nearest max ``|h|``.

    ``e`` is None when the chunk has no valid (non-NaN) point.

    Raises
    ------
    ValueError
        Infinite heights.
    """
    h = np.asarray(h, dtype=np.float64)
    top, bottom = np.fmax.reduce(h, axis=None), np.fmin.reduce(h, axis=None)  # NaN skipped
    if np.isnan(top):
        return h, None
    peak = max(float(top), -float(bottom))
    if np.isinf(peak):
        require_no_inf(h)
    e = int(power_of_two_exponent(peak))
    return np.ldexp(h, -e), e


def point_stats(h: np.ndarray) -> np.ndarray:
    """Block statistics ``(3, ny, nx)`` = ``(n, mu, M2)`` of a map of single points.

    Raises
    ------
    ValueError
        Infinite heights.
    """
    h = np.asarray(h, dtype=np.float64)
    valid = np.isfinite(h)
    require_no_inf(h)
    out = np.zeros((3,) + h.shape)
    out[0] = valid
    np.copyto(out[1], h, where=valid)
    return out


def coarsen_stats(stats: np.ndarray, factor: int, offset: tuple[int, int] = (0, 0)
                  ) -> np.ndarray:
    """Merge ``factor x factor`` cells of block statistics (exact, partial blocks at the ends).

    Parameters
    ----------
    stats : ndarray (3, ny, nx)
        ``(n, mu, M2)`` per cell.
    factor : int
        Cells merged per axis; rows/columns that do not fill a block form partial blocks.
    offset : (int, int)
        Index of the first cell of ``stats`` in the whole map: blocks are aligned to
        multiples of ``factor`` there, so that the first block may be partial too (the
        rest of it lies in another piece, see :func:`merge_stats`).

    Returns
    -------
    ndarray (3, my, mx)
        Blocks ``offset // factor`` to ``(offset + shape - 1) // factor`` per axis.
    """
    _, ny, nx = stats.shape
    oy, ox = (o % factor for o in offset)
    my, mx = -(-(ny + oy) // factor), -(-(nx + ox) // factor)
    full = np.zeros((3, my * factor, mx * factor))
    full[:, oy:oy + ny, ox:ox + nx] = stats
    n, mu, m2 = (a.reshape(my, factor, mx, factor) for a in full)
    nn = n.sum(axis=(1, 3))
    s = (n * mu).sum(axis=(1, 3))
    mean = np.divide(s, nn, out=np.zeros_like(s), where=nn > 0)
    dev = mu - mean[:, None, :, None]
    m2n = m2.sum(axis=(1, 3)) + (n * dev * dev).sum(axis=(1, 3))
    return np.stack([nn, mean, m2n])


def _cells(values: np.ndarray) -> np.ndarray:
    """Block statistics of a piece's values: heights (2D) are single points."""
    return values if values.ndim == 3 else point_stats(values)


def coarsen_piece(piece, factor: int, offset: tuple[int, int]):
    """:func:`coarsen_stats` of a piece ``(values, e)`` (same scale)."""
    values, e = piece
    return coarsen_stats(_cells(values), factor, offset), e


def cut_piece(piece, rows: tuple[int, int], cols: tuple[int, int]):
    """Return a copy of part of a piece (so that the rest of it can be freed)."""
    values, e = piece
    return values[..., rows[0]:rows[1], cols[0]:cols[1]].copy(), e


def _rescale(stats: np.ndarray, shift: int) -> np.ndarray:
    """Statistics of heights multiplied by ``2**shift`` (exact)."""
    n, mu, m2 = stats
    return np.stack([n, np.ldexp(mu, shift), np.ldexp(m2, 2 * shift)])


def merge_stats(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Statistics of the union of the points of cells ``a`` and ``b`` (exact merge).

    Cells empty in one of them take the other's values unchanged.
    """
    na, nb = a[0], b[0]
    out = np.where(na > 0, a, b)
    both = (na > 0) & (nb > 0)
    if both.any():
        na, nb = na[both], nb[both]
        mua, mub = a[1][both], b[1][both]
        n = na + nb
        delta = mub - mua
        out[0][both] = n
        out[1][both] = mua + delta * (nb / n)
        out[2][both] = a[2][both] + b[2][both] + delta * delta * (na * nb / n)
    return out


def _gather(pieces, origins, shape):
    """Merge pieces into the statistics of a region of ``shape`` cells, on one scale."""
    exponents = [e for _, e in pieces if e is not None]
    e = max(exponents) if exponents else None
    out = np.zeros((3,) + tuple(shape))
    for (values, ep), (y, x) in zip(pieces, origins):
        if ep is None:
            continue
        st = _cells(values)
        if ep != e:
            st = _rescale(st, ep - e)
        where = (slice(None), slice(y, y + st.shape[1]), slice(x, x + st.shape[2]))
        out[where] = merge_stats(out[where], st)
    return out, e


def tile_piece_sums(pieces, *, origins, shape, inner, ks):
    """Folded ``(S, N)`` of one tile, as a piece ``(planes (2, Ky+1, Kx+1), e)``.

    ``pieces`` cover the tile extended by the halo (region of ``shape`` cells, zero where
    no piece lies: outside the map); ``origins`` are their positions in that region and
    ``inner`` the tile's. ``S`` is in units of ``2**(2 e)``.
    """
    ext, e = _gather(pieces, origins, shape)
    s, n = tile_pair_sums(ext, inner, ks)
    return np.stack([s, n]), e


def add_scaled(*parts):
    """Sum of folded ``(S, N)`` pieces, ``S`` brought to the largest exponent (exact)."""
    exponents = [e for _, e in parts if e is not None]
    total = np.zeros_like(parts[0][0])
    if not exponents:
        return total, None
    e = max(exponents)
    for planes, ep in parts:
        if ep is None:
            continue
        total[0] += planes[0] if ep == e else np.ldexp(planes[0], 2 * (ep - e))
        total[1] += planes[1]
    return total, e


def tile_pair_sums(ext: np.ndarray, inner: tuple[slice, slice], ks: tuple[int, int],
                   workers: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Folded pair sums of the ordered pairs whose first point lies in one tile.

    Parameters
    ----------
    ext : ndarray (3, Ey, Ex)
        Block statistics of the tile extended by the halo, zero (``n = 0``) outside the
        map; ``Ey >= tile rows + Ky`` below and above the tile (the tile sits at ``inner``
        with at least ``Ky`` rows and ``Kx`` columns of halo on each side).
    inner : (slice, slice)
        Position of the tile in ``ext``.
    ks : (int, int)
        Largest lag index per axis.
    workers : int
        Threads for :mod:`scipy.fft`.

    Returns
    -------
    S, N : ndarray (Ky + 1, Kx + 1)
        Folded sum over ordered pairs ``(r, r + d)``, ``r`` in the tile and ``d`` over the
        distinct signed lags ``(+-i, +-j)``, of the squared height difference, and the
        number of pairs (products of counts at coarse levels).
    """
    n, mu, m2 = ext
    tot = n.sum()
    if tot == 0 or n[inner].sum() == 0:
        return np.zeros((ks[0] + 1, ks[1] + 1)), np.zeros((ks[0] + 1, ks[1] + 1))
    c = (n * mu).sum() / tot  # offset: keeps the cancellation in the h^2 terms small
    d = np.where(n > 0, mu - c, 0.0)
    s = n * d
    q = m2 + s * d
    fshape = tuple(sfft.next_fast_len(m, real=(ax == 1)) for ax, m in enumerate(n.shape))
    for m, k, ax in zip(n.shape, ks, range(2)):
        lo = inner[ax].start
        hi = inner[ax].stop
        if lo < k or m - hi < k:
            raise ValueError("the extended block must hold the halo on every side")

    def spec(a):
        return sfft.rfft2(a, s=fshape, workers=workers)

    def tile(a):
        t = np.zeros_like(a)
        t[inner] = a[inner]
        return t

    fn, fs, fq = spec(n), spec(s), spec(q)
    tn, ts, tq = spec(tile(n)), spec(tile(s)), spec(tile(q))
    # corr(a, b)(d) = sum_r a(r) b(r + d) has the spectrum conj(A) B
    ws = np.conj(tq) * fn
    ws += np.conj(tn) * fq
    ws -= 2.0 * (np.conj(ts) * fs)
    wn = np.conj(tn) * fn
    del fs, fq, ts, tq
    # no wrap-around: the tile starts >= K inside ext, so r + d stays within [0, E)
    sums = fold(sfft.irfft2(ws, s=fshape, workers=workers), ks)
    counts = np.rint(fold(sfft.irfft2(wn, s=fshape, workers=workers), ks))
    sums[counts == 0] = 0.0
    return sums, counts


# ---------------------------------------------------------------------------------------
# levels, chunks and the final assembly of the tiled estimator
# ---------------------------------------------------------------------------------------
def block_levels(shape: tuple[int, int], halo: int, factor: int, ks_full: tuple[int, int]
                 ) -> tuple[list[int], list[tuple[int, int]]]:
    """Block side (points) and largest lag index (blocks) per level, up to ``ks_full``.

    Level ``l`` has blocks of ``factor**l`` points and covers lags up to ``halo`` blocks
    per axis (fewer on a map of fewer blocks); levels are added until one reaches the
    largest lag wanted, ``ks_full`` points per axis.
    """
    cells, ks_levels = [], []
    while True:
        f = factor ** len(cells)
        n_l = tuple(-(-n // f) for n in shape)
        ks_l = tuple(min(halo, m - 1) for m in n_l)
        cells.append(f)
        ks_levels.append(ks_l)
        if all(k == m - 1 or (k + 1) * f >= kf for k, m, kf in zip(ks_l, n_l, ks_full)):
            return cells, ks_levels


def bin_levels(edges: np.ndarray, spacing: tuple[float, float], shape: tuple[int, int],
               cells: list[int], ks_levels: list[tuple[int, int]],
               ks_full: tuple[int, int]) -> np.ndarray:
    """Level of each bin: the finest whose lattice holds all the bin's lags (0 if none)."""
    assign = np.zeros(len(edges) - 1, dtype=int)
    for b, e1 in enumerate(edges[1:]):
        # largest lag index (points) with a lag shorter than e1, within the map
        need = [min(kf, int(np.ceil(e1 / d)) - 1) for d, kf in zip(spacing, ks_full)]
        for lev, (f, ks_l) in enumerate(zip(cells, ks_levels)):
            n_l = tuple(-(-n // f) for n in shape)
            if all(k == m - 1 or nd <= (k if lev == 0 else (k + 1) * f - 1)
                   for k, m, nd in zip(ks_l, n_l, need)):
                assign[b] = lev
                break
    return assign


def chunk_bounds(chunks: tuple[int, ...]) -> np.ndarray:
    """Start of each chunk along an axis, and the end of the last."""
    return np.concatenate([[0], np.cumsum(chunks)]).astype(int)


def overlaps(lo: np.ndarray, hi: np.ndarray, region: tuple[int, int]) -> list:
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


def scaled_chunk(block, after=()):
    """Return :func:`scaled_heights` of a chunk.

    ``after`` are results of tasks that must run before this chunk is read (unused: they
    only order the graph).
    """
    return scaled_heights(block)


def assemble(level_sums, *, idxs, assign, keep, nb, dr, pixel_area, height_unit, g_unit):
    """Bin each level's folded sums and keep, per bin, the level assigned to it.

    ``level_sums`` are pieces ``((S, N), e)``; returns ``(G, pair count, standard error)``
    of the kept bins, G and its standard error scaled back from the largest exponent.
    """
    exponents = [e for _, e in level_sums if e is not None]
    top = max(exponents) if exponents else 0
    sums = np.zeros(nb)
    counts = np.zeros(nb)
    for lev, ((plane, e), idx) in enumerate(zip(level_sums, idxs)):
        s = plane[0] if e is None or e == top else np.ldexp(plane[0], 2 * (e - top))
        s = 0.5 * binned_sum(s, idx, nb)
        n = 0.5 * binned_sum(plane[1], idx, nb)
        sel = assign == lev
        sums[sel], counts[sel] = s[sel], n[sel]
    sums, counts = sums[keep], counts[keep]
    valid = level_sums[0][0][1][0, 0]
    has = counts > 0
    g = np.full(counts.shape, np.nan)
    g[has] = 0.5 * sums[has] / counts[has]
    se = area_variance(g[None], counts[None], np.array([valid]), dr=dr,
                       pixel_area=pixel_area, geometry="radial")[0]
    se = np.sqrt(se)
    se[~has] = np.nan
    g, se = (times_power_of_two(x, top, power=2, height_unit=height_unit, g_unit=g_unit)
             for x in (g, se))
    return np.stack([g, counts, se])
