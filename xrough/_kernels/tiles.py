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
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sfft

from .pairs import fold

__all__ = ["point_stats", "coarsen_stats", "tile_pair_sums"]


def point_stats(h: np.ndarray) -> np.ndarray:
    """Block statistics ``(3, ny, nx)`` = ``(n, mu, M2)`` of a map of single points.

    Raises
    ------
    ValueError
        Infinite heights.
    """
    h = np.asarray(h, dtype=np.float64)
    valid = np.isfinite(h)
    if np.isinf(h).any():
        raise ValueError("heights contain infinite values; mark missing points as NaN")
    out = np.zeros((3,) + h.shape)
    out[0] = valid
    np.copyto(out[1], h, where=valid)
    return out


def coarsen_stats(stats: np.ndarray, factor: int) -> np.ndarray:
    """Merge ``factor x factor`` cells of block statistics (exact, partial cells at the end).

    Parameters
    ----------
    stats : ndarray (3, ny, nx)
        ``(n, mu, M2)`` per cell.
    factor : int
        Cells merged per axis; trailing rows/columns that do not fill a block form partial
        blocks.

    Returns
    -------
    ndarray (3, ceil(ny / factor), ceil(nx / factor))
    """
    _, ny, nx = stats.shape
    my, mx = -(-ny // factor), -(-nx // factor)
    full = np.zeros((3, my * factor, mx * factor))
    full[:, :ny, :nx] = stats
    n, mu, m2 = (a.reshape(my, factor, mx, factor) for a in full)
    nn = n.sum(axis=(1, 3))
    s = (n * mu).sum(axis=(1, 3))
    mean = np.divide(s, nn, out=np.zeros_like(s), where=nn > 0)
    dev = mu - mean[:, None, :, None]
    m2n = m2.sum(axis=(1, 3)) + (n * dev * dev).sum(axis=(1, 3))
    return np.stack([nn, mean, m2n])


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
