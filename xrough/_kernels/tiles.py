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

Scales: heights are divided by a power of two so that no square overflows. An extended
tile of heights is scaled by its own power of two (nearest its largest ``|h|``); block
statistics carry their power of two per cell, as a fourth channel ``e`` (a cell of
``(n, mu, M2, e)`` means ``(n, mu 2**e, M2 4**e)``), set by the chunk of heights they
were derived from and brought to the largest one wherever cells meet (a block, a tile).
The sums of a tile are a pair ``(planes, e)`` meaning ``S * 4**e`` (``e`` None without
valid points); partial sums meet on the largest exponent. A multiplication by a power of
two is exact, so the result is the same as with one global scale, without a pass over the
whole map first.
"""

from __future__ import annotations

import numpy as np

from .binning import binned_sum
from .deferred import fft as sfft
from .pairs import area_variance, fold, require_no_inf, times_power_of_two

__all__ = ["power_of_two_exponent", "scaled_heights", "point_stats", "coarsen_stats",
           "merge_stats", "height_stats", "height_block_stats", "coarsen_scaled",
           "tile_height_sums", "tile_stats_sums", "tile_two_levels", "encode", "decode",
           "add_encoded", "first", "tile_pair_sums", "block_levels", "bin_levels", "assemble"]


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


def encode(planes: np.ndarray, e) -> np.ndarray:
    """Return a piece ``(planes, e)`` as one row of numbers: ``planes`` flattened, ``e``.

    Shape ``(1, 1, planes.size + 1)`` (one tile of a dask array of pieces); ``e`` None
    becomes NaN. See :func:`decode` and :func:`add_encoded`.
    """
    return np.concatenate([planes.ravel(), [np.nan if e is None else float(e)]])[None, None]


def decode(row: np.ndarray, ks_levels) -> list:
    """Return the pieces ``((S, N), e)`` of the levels, from their rows (:func:`encode`)."""
    pieces, start = [], 0
    for ky, kx in ks_levels:
        size = 2 * (ky + 1) * (kx + 1)
        e = row[start + size]
        pieces.append((row[start:start + size].reshape(2, ky + 1, kx + 1),
                       None if np.isnan(e) else int(e)))
        start += size + 1
    return pieces


def add_encoded(x: np.ndarray, axis, keepdims: bool = False, *, sizes) -> np.ndarray:
    """Sum encoded pieces along ``axis``, ``S`` brought to the largest exponent (exact).

    ``x`` ``(..., sum(sizes))``: along the last axis the encoded pieces (:func:`encode`)
    of one or more levels, of lengths ``sizes``; the combine and aggregate of a
    :func:`dask.array.reduction`.
    """
    axis = tuple(a % x.ndim for a in np.atleast_1d(axis))
    parts, start = [], 0
    for size in sizes:
        block = x[..., start:start + size]
        half = (size - 1) // 2
        s, n, e = block[..., :half], block[..., half:-1], block[..., -1:]
        top = np.fmax.reduce(e, axis=axis, keepdims=True)  # NaN (no valid point) skipped
        shift = np.where(np.isnan(e), 0, e - np.where(np.isnan(top), 0, top)).astype(int)
        s = np.where(np.isnan(e), 0.0, np.ldexp(s, 2 * shift)).sum(axis=axis, keepdims=True)
        parts += [s, n.sum(axis=axis, keepdims=True), top]
        start += size
    out = np.concatenate(parts, axis=-1)
    return out if keepdims else out.squeeze(axis)


def first(x, axis=None, keepdims=None):
    """Return ``x`` (the ``chunk`` of a reduction whose blocks are already pieces)."""
    return x


def height_stats(h: np.ndarray, factor: int) -> np.ndarray:
    """Block statistics ``(4, my, mx)`` = ``(n, mu, M2, e)`` of ``factor x factor`` blocks.

    ``h``: heights of a part of the map starting at a multiple of ``factor`` per axis
    (partial blocks at its end); they are scaled by one power of two ``2**e``, nearest
    their largest ``|h|`` (``e`` = 0 for cells without valid points).
    """
    scaled, e = scaled_heights(h)
    st = coarsen_stats(point_stats(scaled), factor)
    return np.concatenate([st, np.full((1,) + st.shape[1:], float(e or 0))])


def _block_max(a: np.ndarray, factor: int) -> np.ndarray:
    """Largest value of each ``factor x factor`` block (partial blocks at the end)."""
    ny, nx = a.shape
    my, mx = -(-ny // factor), -(-nx // factor)
    full = np.full((my * factor, mx * factor), -np.inf)
    full[:ny, :nx] = a
    return full.reshape(my, factor, mx, factor).max(axis=(1, 3))


def _to_exponent(stats: np.ndarray, e) -> np.ndarray:
    """``(n, mu, M2)`` of cells ``(n, mu, M2, e_cell)`` brought to exponents ``e`` (exact)."""
    n, mu, m2, ec = stats
    shift = np.where(n > 0, ec - e, 0.0).astype(int)
    if not shift.any():
        return stats[:3]
    return np.stack([n, np.ldexp(mu, shift), np.ldexp(m2, 2 * shift)])


def coarsen_scaled(stats: np.ndarray, factor: int) -> np.ndarray:
    """:func:`coarsen_stats` of cells with their own powers of two ``(n, mu, M2, e)``.

    ``stats`` starts at a multiple of ``factor`` per axis; each block comes to the largest
    exponent of its valid cells (exact), which it keeps as its own.
    """
    n, e = stats[0], stats[3]
    top = _block_max(np.where(n > 0, e, -np.inf), factor)
    top = np.where(np.isfinite(top), top, 0.0)
    per_cell = np.repeat(np.repeat(top, factor, axis=0), factor, axis=1)
    per_cell = per_cell[:n.shape[0], :n.shape[1]]
    st = coarsen_stats(_to_exponent(stats, per_cell), factor)
    return np.concatenate([st, top[None]])


def height_block_stats(h: np.ndarray, factor: int, rows: int = 256) -> np.ndarray:
    """Block statistics ``(3, my, mx)`` of (scaled) heights in ``factor x factor`` blocks.

    The same as ``coarsen_stats(point_stats(h), factor)`` (partial blocks at the end),
    slab by slab of rows so that no full-size temporaries are made.
    """
    ny, nx = h.shape
    my, mx = -(-ny // factor), -(-nx // factor)
    out = np.zeros((3, my, mx))
    step = max(1, rows // factor) * factor
    for r0 in range(0, ny, step):
        slab = h[r0:r0 + step]
        b0 = r0 // factor
        st = coarsen_stats(point_stats(slab), factor)
        out[:, b0:b0 + st.shape[1]] = st
    return out


def tile_two_levels(ext: np.ndarray, *, ks0, ks1, depth, factor) -> np.ndarray:
    """Return the folded ``(S, N)`` of a tile of heights and of its blocks, encoded.

    ``ext``: heights of the tile extended by ``depth`` on every side (NaN outside the
    map), ``depth`` at least ``ks0`` and ``ks1 * factor`` and a multiple of ``factor``
    per axis, the tile starting at a multiple of ``factor`` of the map. Level 0: the
    tile with the halo ``ks0``; level 1: the blocks of ``factor x factor`` points of the
    tile with the halo ``ks1`` blocks. Both in units of the same ``4**e`` (one power of
    two for the whole extended tile). Returns ``encode(level 0)`` then ``encode(level 1)``.
    """
    scaled, e = scaled_heights(ext)
    size = tuple(m - 2 * d for m, d in zip(ext.shape, depth))
    cut0 = tuple(slice(d - k, d + m + k) for d, k, m in zip(depth, ks0, size))
    s0, n0 = tile_pair_sums(point_stats(scaled[cut0]), _inner(scaled[cut0].shape, ks0), ks0)
    stats = height_block_stats(scaled, factor)
    cut1 = (slice(None),) + tuple(
        slice(d // factor - k, d // factor - (-m // factor) + k)
        for d, k, m in zip(depth, ks1, size))
    st = stats[cut1]
    s1, n1 = tile_pair_sums(st, _inner(st.shape[1:], ks1), ks1)
    return np.concatenate([encode(np.stack([s0, n0]), e), encode(np.stack([s1, n1]), e)],
                          axis=-1)


def _inner(shape, ks):
    """Return the slices of the tile inside a block extended by ``ks`` on every side."""
    return tuple(slice(k, m - k) for m, k in zip(shape, ks))


def tile_height_sums(ext: np.ndarray, *, ks) -> np.ndarray:
    """Folded ``(S, N)`` of one tile of heights, encoded (:func:`encode`).

    ``ext``: heights of the tile extended by ``ks`` on every side (NaN outside the map),
    scaled here by their own power of two ``2**e``; ``S`` is in units of ``4**e``.
    """
    scaled, e = scaled_heights(ext)
    s, n = tile_pair_sums(point_stats(scaled), _inner(ext.shape, ks), ks)
    return encode(np.stack([s, n]), e)


def tile_stats_sums(ext: np.ndarray, *, ks) -> np.ndarray:
    """Folded ``(S, N)`` of one tile of block statistics ``(n, mu, M2, e)``, encoded.

    ``ext`` ``(4, Ey, Ex)``: the tile extended by ``ks`` on every side (``n`` = 0 outside
    the map); its cells come to their largest exponent ``e``.
    """
    valid = ext[0] > 0
    e = int(ext[3][valid].max()) if valid.any() else None
    s, n = tile_pair_sums(_to_exponent(ext, 0 if e is None else e), _inner(ext.shape[1:], ks),
                          ks)
    return encode(np.stack([s, n]), e)


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
def block_levels(shape: tuple[int, ...], halo: int, factor: int, ks_full: tuple[int, ...]
                 ) -> tuple[list[int], list[tuple[int, ...]]]:
    """Block side (points) and largest lag index (blocks) per level, up to ``ks_full``.

    Level ``l`` has blocks of ``factor**l`` points and covers lags up to ``halo`` blocks
    per axis (fewer on a map of fewer blocks); levels are added until one reaches the
    largest lag wanted, ``ks_full`` points per axis.
    """
    cells: list[int] = []
    ks_levels: list[tuple[int, ...]] = []
    while True:
        f = factor ** len(cells)
        n_l = tuple(-(-n // f) for n in shape)
        ks_l = tuple(min(halo, m - 1) for m in n_l)
        cells.append(f)
        ks_levels.append(ks_l)
        if all(k == m - 1 or (k + 1) * f >= kf for k, m, kf in zip(ks_l, n_l, ks_full)):
            return cells, ks_levels


def bin_levels(edges: np.ndarray, spacing: tuple[float, ...], shape: tuple[int, ...],
               cells: list[int], ks_levels: list[tuple[int, ...]],
               ks_full: tuple[int, ...]) -> np.ndarray:
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


def assemble(total, *, ks_levels, idxs, assign, keep, nb, dr, pixel_area, height_unit,
             g_unit):
    """Bin each level's folded sums and keep, per bin, the level assigned to it.

    ``total``: the encoded sums of the levels (:func:`add_encoded`), pieces ``((S, N), e)``
    once decoded; returns ``(G, pair count, standard error)``
    of the kept bins, G and its standard error scaled back from the largest exponent.
    """
    level_sums = decode(np.ravel(total), ks_levels)
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
