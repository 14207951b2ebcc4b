"""All-pairs sums of squared height differences by FFT (pure numpy/scipy).

For every lattice lag ``d`` the kernel returns, exactly up to floating-point round-off,

    S(d) = sum over valid pairs (r, r + d) of (h(r) - h(r + d))**2
    N(d) = number of such pairs

folded onto the quarter plane (see :mod:`.binning`). With a validity mask ``m`` (0 where
the height is NaN) and ``h`` set to 0 there,

    S(d) = corr(h**2, m)(d) + corr(m, h**2)(d) - 2 corr(h, h)(d),   N(d) = corr(m, m)(d),

and every correlation is one product of real FFTs. Non-periodic maps are zero padded by the
largest lag needed (not by the full size unless asked), so circular wrap-around never mixes
in. Only the folded sums are needed, so each inverse transform runs as a type-I DCT of the
quarter spectrum (see :func:`_inverse_folded`). Without missing points cheaper exact forms
are used: periodic maps need one forward transform and one quarter-size DCT; non-periodic
ones get the ``h**2`` terms from a summed-area table.

A single map is summed per bin as it is transformed (:func:`binned_map_sums`): the half
spectrum of the padded map is the one full-size array (its rows filled block by block
from the heights, its columns transformed, squared, folded and transformed back slab by
slab in place), and the rows of the folded lag plane are binned a block at a time, so
that neither a padded copy of the map nor the lag plane is formed.

The sums of each map travel as one *packed* array (:func:`packed`): per kept bin the sums
of G, the pair counts and the sums of G^2, then the valid points and the exponent of the
power of two that scaled the map's heights. :func:`pool` adds maps on their largest
exponent; :func:`g_from_packed` turns the sums into G and its errors.
"""

from __future__ import annotations

import functools
import os
import threading

import numpy as np

from .binning import binned_sum, folded_bin_index, lag_multiplicity, lag_radius2
from .deferred import fft as sfft
from .uncertainty import finite_area_variance

__all__ = ["folded_pair_sums", "binned_map_sums", "map_kernel_applies", "extremes",
           "folded_geometric_counts", "padded_shape", "binned_geometry", "require_no_inf",
           "few_points_message", "packed", "pool", "g_from_packed", "area_variance",
           "times_power_of_two", "resolve_workers", "cores"]


def padded_shape(shape: tuple[int, ...], ks: tuple[int, ...], periodic: bool) -> tuple[int, ...]:
    """FFT shape: the map itself (periodic) or padded by the largest lag to an even fast length.

    Even lengths let the inverse transform run as a type-I DCT on the quarter plane.
    """
    if periodic:
        return tuple(shape)
    out = []
    for ax, (n, k) in enumerate(zip(shape, ks)):
        target = n + k
        while True:
            m = sfft.next_fast_len(target, real=(ax == len(shape) - 1))
            if m % 2 == 0:
                break
            target = m + 1
        out.append(m)
    return tuple(out)


def _rfftn(x: np.ndarray, fshape: tuple[int, ...], axes: tuple[int, ...],
           workers: int) -> np.ndarray:
    """Real FFT over ``axes`` zero padded to ``fshape``, padding one axis at a time.

    Transforming the last axis first on the unpadded rows skips the rows of zeros.
    """
    out = sfft.rfft(x, n=fshape[-1], axis=axes[-1], workers=workers)
    for ax, m in zip(axes[:-1][::-1], fshape[:-1][::-1]):
        out = sfft.fft(out, n=m, axis=ax, workers=workers, overwrite_x=True)
    return out


def _inverse_folded(spec: np.ndarray, fshape: tuple[int, ...], ks: tuple[int, ...],
                    workers: int) -> np.ndarray:
    """Folded inverse transform of a real, point-symmetric half spectrum.

    ``spec`` is the rfft half spectrum (last axis halved) of a real correlation plane
    ``c``; returns ``sum over distinct signed lags (+-i, +-j) of c`` for lags ``0..k``.
    With even lengths the spectrum is averaged over ``k`` and ``-k`` along the full axes,
    which makes it even in every axis, and the inverse DFT of an even sequence is a type-I
    DCT of its quarter: a quarter of the work of ``irfftn`` and no full-size output.
    """
    nd = len(ks)
    spec = np.asarray(spec.real if np.iscomplexobj(spec) else spec)
    if any(m % 2 for m in fshape):
        plane = sfft.irfftn(spec, s=fshape, axes=tuple(range(-nd, 0)), workers=workers)
        return fold(plane, ks)
    quarter = spec
    for off, m in enumerate(fshape[:-1]):
        axis = spec.ndim - nd + off
        half = m // 2
        q = _take(quarter, axis, slice(0, half + 1)).copy()
        inner = _take(q, axis, slice(1, half))
        inner += _take(quarter, axis, slice(m - 1, half, -1))
        inner *= 0.5
        quarter = q
    c = sfft.dctn(quarter, type=1, axes=tuple(range(-nd, 0)), workers=workers,
                  overwrite_x=True)
    c = c[(...,) + tuple(slice(0, k + 1) for k in ks)]
    weight = np.ones(())
    for m, k in zip(fshape, ks):
        weight = np.multiply.outer(weight, lag_multiplicity(m, k, True))
    return c * (weight / np.prod(fshape))


def fold(plane: np.ndarray, ks: tuple[int, ...]) -> np.ndarray:
    """Fold a circular lag plane onto lags ``0..k`` per axis, adding ``-i`` onto ``+i``.

    Index ``i`` of an axis of length ``P`` holds lag ``+i`` and index ``P - i`` lag ``-i``;
    on a periodic axis of even length the Nyquist lag ``P/2`` is its own negative and is
    counted once. Only basic slicing is used (no gathers), so this costs one pass.
    """
    out = plane
    nd = len(ks)
    for off, k in enumerate(ks):
        axis = plane.ndim - nd + off
        P = out.shape[axis]
        m = k - 1 if P - k == k else k  # number of lags i >= 1 whose -i is distinct
        pos = _take(out, axis, slice(0, k + 1)).copy()
        if m > 0:
            dst = _take(pos, axis, slice(1, m + 1))
            dst += _take(out, axis, slice(P - 1, P - 1 - m, -1))
        out = pos
    return out


def _take(a: np.ndarray, axis: int, sl: slice) -> np.ndarray:
    index = [slice(None)] * a.ndim
    index[axis] = sl
    return a[tuple(index)]


def folded_geometric_counts(shape: tuple[int, ...], ks: tuple[int, ...],
                            periodic: bool) -> np.ndarray:
    """Pair counts per folded lag for a map without missing points."""
    counts = np.ones((), dtype=np.float64)
    for n, k in zip(shape, ks):
        counts = np.multiply.outer(counts, _axis_counts(n, k, periodic))
    return counts


def _axis_counts(n: int, k: int, periodic: bool) -> np.ndarray:
    mult = lag_multiplicity(n, k, periodic).astype(float)
    if periodic:
        return mult * n
    return mult * (n - np.arange(k + 1))


def _sq_terms_nonperiodic(h2: np.ndarray, ks: tuple[int, ...]) -> np.ndarray:
    """Folded sum over pairs of h(r)^2 + h(r+d)^2 for a full rectangle (summed-area table)."""
    if len(ks) == 1:
        (k,) = ks
        n = h2.shape[-1]
        cs = np.concatenate([np.zeros(h2.shape[:-1] + (1,)), np.cumsum(h2, axis=-1)], axis=-1)
        i = np.arange(k + 1)
        e = cs[..., n - i] + cs[..., n:n + 1] - cs[..., i]
        return e * lag_multiplicity(n, k, False)
    ny, nx = h2.shape[-2:]
    e = np.zeros(h2.shape[:-2] + (ks[0] + 1, ks[1] + 1))
    _add_sq_rows(e, sq_table([(0, ny, h2)], ny, nx, ks[1], h2.shape[:-2]), 0, ks[0] + 1)
    e *= lag_multiplicity(ny, ks[0], False)[:, None] / 2
    e *= lag_multiplicity(nx, ks[1], False)
    return e


def cumulative_rows(t: np.ndarray) -> np.ndarray:
    """``t`` replaced by its cumulative sum along axis -2 (the rows of each map), in place.

    Row by row, each addition vectorised along a row: numpy's ``cumsum(axis=0)`` walks
    each column with the row stride, out of the cache.
    """
    for y in range(1, t.shape[-2]):
        np.add(t[..., y - 1, :], t[..., y, :], out=t[..., y, :])
    return t


def sq_table(blocks, ny: int, nx: int, kx: int, batch: tuple[int, ...] = (),
             scale: float = 1.0) -> np.ndarray:
    """Return the table ``U`` whose rows give the folded ``h(r)^2 + h(r+d)^2`` sums.

    ``blocks``: ``(r0, r1, h2)``, the squared heights of rows ``r0:r1`` (``h2`` of shape
    ``batch + (r1 - r0, nx)``), covering the ``ny`` rows in order. With the summed-area
    table ``t`` of ``h^2`` (``t[0, :] = t[:, 0] = 0``), the sums over the pairs at lags
    ``(+i, +j)`` and ``(+i, -j)`` are rectangles with corners ``0, i, ny - i, ny`` (and
    likewise in ``j``): nine terms of ``t``, which make three rows of

        U[x, j] = t[x, nx - j] - t[x, j] + t[x, nx]      (j = 0..kx),

    ``e(i, j) = U[ny - i, j] - U[i, j] + U[ny, j]``. ``U`` is linear in a row of ``t``: it
    is made from each row's cumulative sum and then summed along the rows, so that ``t``
    itself is never formed. ``scale``: ``U`` times it (exact for a power of two).
    """
    u = np.zeros(batch + (ny + 1, kx + 1))
    for r0, r1, h2 in blocks:
        c = np.empty(h2.shape[:-1] + (nx + 1,))
        c[..., 0] = 0.0
        np.cumsum(h2, axis=-1, out=c[..., 1:])
        if scale != 1.0:
            c *= scale
        out = u[..., 1 + r0:1 + r1, :]
        np.subtract(c[..., nx - kx:][..., ::-1], c[..., :kx + 1], out=out)
        out += c[..., nx:nx + 1]
    return cumulative_rows(u)


def _add_sq_rows(b: np.ndarray, u: np.ndarray, i0: int, i1: int) -> None:
    """Add rows ``i0:i1`` of the folded ``h(r)^2 + h(r+d)^2`` sums (unweighted) to ``b``.

    From the table of :func:`sq_table`, ``(..., ny + 1, kx + 1)``: views, no gathers,
    three passes, no temporary.
    """
    ny = u.shape[-2] - 1
    b += u[..., _reversed_rows(ny, i0, i1), :]
    b -= u[..., i0:i1, :]
    b += u[..., ny:ny + 1, :]


def _reversed_rows(ny: int, i0: int, i1: int) -> slice:
    """Rows ``ny - i`` for ``i = i0..i1-1``."""
    return slice(ny - i0, ny - i1 if ny - i1 >= 0 else None, -1)


def folded_pair_sums(h: np.ndarray, ks: tuple[int, ...], *, periodic: bool,
                     workers: int = -1) -> tuple[np.ndarray, np.ndarray | None]:
    """Folded sums of squared differences and pair counts over the last ``len(ks)`` axes.

    Parameters
    ----------
    h : ndarray (..., [ny,] nx)
        Heights, NaN for missing points; leading axes are independent maps.
    ks : tuple of int
        Largest lag index per transformed axis.
    periodic : bool
        Circular lags (one period of a periodic surface) or open boundaries.
    workers : int
        Threads for :mod:`scipy.fft`.

    Returns
    -------
    S, N : ndarray (..., ks[0]+1[, ks[1]+1])
        Folded sum of ``(h(r) - h(r+d))**2`` and number of valid pairs per lag; ``N`` is
        None when no point is missing (the counts are then
        :func:`folded_geometric_counts`).

    Raises
    ------
    ValueError
        Infinite heights. (Rows or maps without valid points just contribute no pairs.)
    """
    nd = len(ks)
    axes = tuple(range(-nd, 0))
    shape = h.shape[-nd:]
    fshape = padded_shape(shape, ks, periodic)
    h = np.asarray(h, dtype=np.float64)
    valid = np.isfinite(h)
    if valid.all():
        return _unmasked(h, ks, fshape, axes, periodic, workers), None
    require_no_inf(h)
    return _masked(h, valid, ks, fshape, axes, workers)


def require_no_inf(h: np.ndarray, what: str = "heights") -> np.ndarray:
    """Return ``h`` as an array; raise if any value is infinite (NaN marks a missing point).

    The one check of infinite heights, for every estimator and preprocessing step.
    """
    h = np.asarray(h)
    n = int(np.isinf(h).sum()) if h.dtype.kind == "f" else 0
    if n:
        raise ValueError(f"{what} contain {n} infinite value(s); mark missing points as NaN "
                         "(mask_outliers masks them)")
    return h


def _unmasked(h, ks, fshape, axes, periodic, workers):
    if periodic:
        a = sfft.rfftn(h, axes=axes, workers=workers)
        a[(...,) + (0,) * len(ks)] = 0.0  # remove the mean exactly
        power = _abs2(a)
        del a
        corr = _inverse_folded(power, fshape, ks, workers)
        del power
        # sum of squared differences over pairs: 2 (C(0) - C(d)) per distinct signed lag
        zero = corr[(...,) + (0,) * len(ks)][(...,) + (None,) * len(ks)].copy()
        mult = folded_geometric_counts(fshape, ks, True) / np.prod(fshape)
        corr *= -2.0
        corr += (2.0 * zero) * mult
        return corr
    hc = h - h.mean(axis=axes, keepdims=True)
    power = _abs2(_rfftn(hc, fshape, axes, workers))
    corr = _inverse_folded(power, fshape, ks, workers)
    del power
    np.multiply(hc, hc, out=hc)
    corr *= -2.0
    corr += _sq_terms_nonperiodic(hc, ks)
    return corr


def _abs2(a: np.ndarray) -> np.ndarray:
    """|a|^2 as a new real array; overwrites ``a`` (squares its parts in place)."""
    v = a.view(np.float64)
    np.square(v, out=v)
    return np.add(v[..., 0::2], v[..., 1::2])


def _real_cross(b: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Re(conj(b) m) as a new real array; overwrites ``b``."""
    v = b.view(np.float64)
    np.multiply(v, m.view(np.float64), out=v)
    return np.add(v[..., 0::2], v[..., 1::2])


def _masked(h, valid, ks, fshape, axes, workers):
    m = valid.astype(np.float64)
    nvalid = m.sum(axis=axes, keepdims=True)
    mean = np.nansum(h, axis=axes, keepdims=True) / np.maximum(nvalid, 1)
    hz = np.subtract(h, mean)
    np.copyto(hz, 0.0, where=~valid)
    fm = _rfftn(m, fshape, axes, workers)
    del m
    fb = _rfftn(np.square(hz), fshape, axes, workers)
    # 2 Re(conj(B) M) is the spectrum of corr(h^2, m) + corr(m, h^2)
    w = _real_cross(fb, fm)
    del fb
    w *= 2.0
    counts = np.rint(_inverse_folded(_abs2(fm), fshape, ks, workers))
    del fm
    fa = _rfftn(hz, fshape, axes, workers)
    del hz
    power = _abs2(fa)
    del fa
    power *= 2.0
    w -= power
    del power
    sums = _inverse_folded(w, fshape, ks, workers)
    del w
    sums[counts == 0] = 0.0  # no pairs: only round-off was there
    return sums, counts


# ---------------------------------------------------------------------------------------
# one map, binned as it is transformed: no full-size temporaries
# ---------------------------------------------------------------------------------------
#: Elements per block of rows (or slab of columns) that the map kernel works on at once:
#: 2^19 complex numbers are 8 MB, small against a map and large enough for the FFT's
#: threads.
BLOCK_ELEMENTS = 2**19


def binned_map_sums(h: np.ndarray, exponent: int, ks: tuple[int, ...], *, periodic: bool,
                    index: np.ndarray, nbins: int, lines=None, workers: int = -1,
                    complete: bool | None = None):
    """Binned folded sums of squared differences and pair counts of one map, by FFT.

    The sums of :func:`folded_pair_sums` for a single map (the heights scaled by
    ``2**-exponent``), added up per bin of the folded lags as they come out of the
    transforms, so that the lag plane is never formed: the row transforms (about 2x the
    map for an open one, 1x for a periodic one) and the real quarter of the folded power
    (1x, 0.25x) are the only full-size arrays (a map with missing points has two row
    transforms and two quarters at once). The rows are transformed block by block from
    the heights (zero padded, the scale, the mean and the mask applied block by block;
    a periodic float64 map's at once, scaled after), the columns slab by slab, each slab
    turned at once into its power (or cross) spectrum, averaged over ``k`` and ``-k`` and
    transformed back along the columns (type-I DCT) into the quarter; its rows are then
    transformed back, weighted and binned a block at a time.

    Parameters
    ----------
    h : ndarray (ny, nx)
        Heights (any length unit), NaN for missing points; read, never copied whole.
    exponent : int
        The heights are taken as ``h * 2**-exponent`` (an exact scale that keeps squares
        in range).
    ks : tuple of int
        Largest lag index per axis.
    periodic : bool
        Circular lags or open boundaries (zero padding by ``ks``).
    index : ndarray (ks[0] + 1, ks[1] + 1) of int
        Bin of each folded lag, ``nbins`` for lags in no bin.
    nbins : int
        Number of bins.
    lines : pair of ndarray, optional
        Bins of the lags along y (``d_x = 0``, ``ks[0] + 1``) and along x (``d_y = 0``,
        ``ks[1] + 1``): their sums follow the radial ones as two further blocks.
    workers : int
        Threads for :mod:`scipy.fft` and for the slabs and blocks (:func:`_in_threads`).
    complete : bool, optional
        Whether ``h`` has no missing point, when the caller knows (None: looked for).

    Returns
    -------
    sums, counts : ndarray ((1 or 3) nbins,)
        Sums of ``(h(r) - h(r + d))**2`` and of pairs over the ordered pairs of each bin
        (each unordered pair twice); ``counts`` is None without missing points.
    nvalid : float
        Valid points of the map.
    """
    fshape = padded_shape(h.shape, ks, periodic)
    # a finite sum has no NaN (one pass, no temporary); otherwise look
    valid_all = complete if complete is not None else bool(
        np.isfinite(np.add.reduce(h, axis=None)) or not np.isnan(h).any())
    if not valid_all:
        require_no_inf(h)
    kw = dict(ks=ks, fshape=fshape, workers=workers)
    binner = functools.partial(_binned_rows, index=index, nbins=nbins, lines=lines,
                               workers=workers)
    if not valid_all:
        return _masked_binned(h, exponent, binner, **kw)
    nvalid = float(h.size)
    if periodic:
        return _periodic_binned(h, exponent, binner, **kw), None, nvalid
    return _open_binned(h, exponent, binner, **kw), None, nvalid


def extremes(h: np.ndarray, workers: int = 1) -> tuple[float, float]:
    """Return ``(max, min)`` of ``h`` (NaN if any point is), a block of rows at a time.

    Both reductions of a block run while it is in the cache, the blocks on ``workers``
    threads (:func:`_in_threads`), not two passes of ``np.max`` and ``np.min`` over the
    whole map.
    """
    if h.ndim != 2:
        return float(np.max(h)), float(np.min(h))
    parts = _in_threads(lambda rows, threads: (np.max(h[rows[0]:rows[1]]),
                                               np.min(h[rows[0]:rows[1]])),
                        h.shape[0], h.shape[1], workers)
    tops, bottoms = zip(*parts)
    return float(np.max(tops)), float(np.min(bottoms))


def map_kernel_applies(shape: tuple[int, ...], ks: tuple[int, ...], periodic: bool) -> bool:
    """Whether :func:`binned_map_sums` takes a map: two axes, even transform lengths."""
    return (len(shape) == 2 and len(ks) == 2
            and all(m % 2 == 0 for m in padded_shape(shape, ks, periodic)))


def _row_blocks(rows: int, width: int, parts: int = 1):
    """Return blocks ``(r0, r1)`` of ``rows`` rows of ``width``, of equal size (but the last).

    A multiple of ``parts`` of them, each of at most :data:`BLOCK_ELEMENTS` (or 8 rows).
    """
    count = -(-rows * max(width, 1) // BLOCK_ELEMENTS)
    count = -(-count // parts) * parts
    step = max(8, -(-rows // count))
    return ((r, min(rows, r + step)) for r in range(0, rows, step))


def _binned_rows(block, rows: int, *, index, nbins, lines, workers: int = 1):
    """Bin a folded plane given block by block, the blocks on ``workers`` threads.

    ``block(i0, i1, threads)``: rows ``i0:i1``, transformed with ``threads``.
    """
    line_y = np.empty(rows)  # the first column of each row (the lags along y)
    first: list = []

    def one(rows_of, threads):
        i0, i1 = rows_of
        b = block(i0, i1, threads)
        if lines is not None:
            line_y[i0:i1] = b[:, 0]
            if i0 == 0:
                first.append(b[0].copy())
        return np.bincount(index[i0:i1].ravel(), weights=b.ravel(), minlength=nbins + 1)

    out = np.sum(_in_threads(one, rows, index.shape[1], workers), axis=0)
    line_x = first[0] if first else None
    if lines is None:
        return out[:nbins]
    return np.concatenate([out[:nbins]] + [np.bincount(ix, weights=v, minlength=nbins + 1)
                                           [:nbins] for ix, v in zip(lines,
                                                                     (line_y, line_x))])


def _spectrum_rows(fill, n: int, width: int, workers: int) -> np.ndarray:
    """Return the row transforms ``(n, width // 2 + 1)`` of a map (``fill(r0, r1)``: rows).

    Each row zero padded to ``width``, a block of rows at a time (so that only a block of
    the rows ``fill`` makes, scaled or centred, exists at once).
    """
    out = np.empty((n, width // 2 + 1), dtype=np.complex128)
    for r0, r1 in _row_blocks(n, width):
        out[r0:r1] = sfft.rfft(fill(r0, r1), n=width, axis=-1, workers=workers)
    return out


def _fold_columns(x: np.ndarray, m: int, workers: int) -> np.ndarray:
    """Add rows ``k`` and ``m - k`` of a real slab in place, DCT-I of rows ``0..m/2``.

    ``x`` holds a real, point-symmetric spectrum along axis 0 (length ``m``, even); the
    result, rows ``0..m/2`` of ``x``, is twice the folded inverse along that axis
    (unnormalised): the rows ``0`` and ``m/2``, which have no partner, are doubled, so
    that the inner rows need no halving pass (:func:`_folded_row_block` takes the 2).
    """
    half = m // 2
    x[1:half] += x[m - 1:half:-1]
    x[0] *= 2.0
    x[half] *= 2.0
    return sfft.dct(x[:half + 1], type=1, axis=0, workers=workers, overwrite_x=True)


def _folded_row_block(plane: np.ndarray, i0: int, i1: int, ks, fshape, workers, *,
                      scale: float = 1.0, offset=0.0, overwrite: bool = False):
    """Rows ``i0:i1`` of the folded inverse: DCT-I along the rows, lags ``0..kx``, weighted.

    ``plane`` holds rows ``0..m0/2`` of twice the columns' folded inverse (the real
    quarter, :func:`_fold_columns`); the weights are the distinct signed lags per folded
    lag over the transformed points. Returns ``(scale * inverse + offset / 4)`` weighted:
    ``offset`` is a number, or a function that adds four times the term to the block in
    place. A folded lag off the axes (and off half a periodic length) has four signed
    lags: a factor 4 with the scale (2 with the plane's 2), the rows and columns of fewer
    halved (two passes over the block). With ``overwrite`` the block is transformed in
    the plane's memory (a plane read once).
    """
    b = sfft.dct(plane[i0:i1], type=1, axis=-1, workers=workers,
                 overwrite_x=overwrite)[:, :ks[1] + 1]
    b *= 2.0 * scale / np.prod(fshape)
    if callable(offset):
        offset(b)
    elif offset:
        b += offset
    for axis, (m, k) in enumerate(zip(fshape, ks)):
        single = np.flatnonzero(lag_multiplicity(m, k, True) == 1)
        if axis == 0:
            b[single[(single >= i0) & (single < i1)] - i0] *= 0.5
        else:
            b[:, single] *= 0.5
    return b


class _Scratch:
    """Buffers for one sweep of slabs or blocks, one per thread and name.

    A slab reuses the memory of the thread's previous slab: memory fresh from the system
    is paged in (zeroed) as it is first written, which cost as much as the numpy passes
    over it (a 1024^2 open map made 50 MB of slab buffers per G).
    """

    def __init__(self):
        self._buffers: dict = {}

    def get(self, name: str, shape: tuple[int, ...], dtype=np.float64) -> np.ndarray:
        key = (threading.get_ident(), name)
        size = int(np.prod(shape))
        buf = self._buffers.get(key)
        if buf is None or buf.size < size:
            buf = self._buffers[key] = np.empty(size, dtype)
        return buf[:size].reshape(shape)


def _column_slab(rows: np.ndarray, c0: int, c1: int, m0: int, workers: int,
                 scratch: _Scratch, name: str = "slab") -> np.ndarray:
    """Return the transformed columns ``c0:c1`` of ``rows``, each zero padded to ``m0``.

    In the thread's buffer ``name`` of ``scratch``, so that slabs can run on threads of
    their own.
    """
    ny = rows.shape[0]
    slab = scratch.get(name, (m0, c1 - c0), np.complex128)
    slab[:ny] = rows[:, c0:c1]
    slab[ny:] = 0.0
    return sfft.fft(slab, axis=0, workers=workers, overwrite_x=True)


def _folded_power(slab: np.ndarray, m0: int, workers: int) -> np.ndarray:
    """Return the folded inverse of ``|slab|^2`` along axis 0 (:func:`_fold_columns`).

    Rows ``0..m0/2``, made in the slab's memory (its real parts: a strided view).
    """
    v = slab.view(np.float64).reshape(slab.shape + (2,))
    np.square(v, out=v)  # one pass over the real and imaginary parts
    re = v[..., 0]
    re += v[..., 1]
    return _fold_columns(re, m0, workers)


#: Arrays below this many elements are not split over threads (:func:`_in_threads`):
#: 512^2 open maps and 1024^2 periodic ones and larger are (below, starting the threads
#: costs more than they win; ``python benchmarks/bench_acf.py`` times both sides).
THREAD_MIN_ELEMENTS = 2**18


def _in_threads(func, rows: int, width: int, workers: int) -> list:
    """``[func(block, threads) for block in _row_blocks(rows, width)]`` on ``workers`` threads.

    The blocks (of rows, or slabs of columns: ``rows`` is then the number of columns)
    are as many as the threads or a multiple, of equal size; each thread, the caller's
    among them, takes the next block until none is left. Each call then transforms with
    one thread (``threads = 1``): the numpy passes between the transforms (powers, folds,
    weights, binning) run in parallel too, which one call's threaded transforms alone do
    not.  One thread, which transforms with ``workers``, where the array (``rows *
    width``) is small or the machine has one core.

    The helper threads are started per call: a pool's idle threads wake one at a time,
    and a second slab waits for the first (a ``ThreadPoolExecutor`` runs the two slabs
    of a 1024^2 map one after the other). An interrupt (or an error, in any thread)
    stops every thread after its current block.
    """
    threads = _thread_count(workers)
    if threads <= 1 or rows * width < THREAD_MIN_ELEMENTS:
        return [func(block, workers) for block in _row_blocks(rows, width)]
    blocks = list(_row_blocks(rows, width, threads))
    out: list = [None] * len(blocks)
    order = iter(range(len(blocks)))
    lock = threading.Lock()
    stopped: list = []  # the error that stopped the sweep (None: the caller's)

    def share():
        while not stopped:
            with lock:
                i = next(order, None)
            if i is None:
                return
            out[i] = func(blocks[i], 1)

    def helper():
        try:
            share()
        except BaseException as error:  # noqa: BLE001 - raised again by the caller
            stopped.append(error)

    helpers = [threading.Thread(target=helper, daemon=True, name="xrough-slabs")
               for _ in range(min(threads, len(blocks)) - 1)]
    for t in helpers:
        t.start()
    try:
        share()
    except BaseException:
        stopped.append(None)
        raise
    finally:
        for t in helpers:
            t.join()
    errors = [e for e in stopped if e is not None]
    if errors:
        raise errors[0]
    return out


def _power_slabs(spec: np.ndarray, workers: int) -> np.ndarray:
    """Columns of a periodic map's row transforms in place, slab by slab, to the folded power.

    ``spec``: ``(m0, width)`` complex, all of the map's rows (no padding); the mean is
    removed (exactly: the power at ``k = 0`` set to 0). Returns the real quarter (rows
    ``0..m0/2``), a strided view into ``spec``: no array of the map's size is made (a
    contiguous copy, for the rows' transforms and binning, costs more than it saves).
    The slabs (disjoint columns) run on
    ``workers`` threads.
    """
    m0 = spec.shape[0]

    def one(cols, threads):
        c0, c1 = cols
        slab = spec[:, c0:c1]
        sfft.fft(slab, axis=0, workers=threads, overwrite_x=True)
        if c0 == 0:
            slab[0, 0] = 0.0
        _folded_power(slab, m0, threads)

    _in_threads(one, spec.shape[1], m0, workers)
    return spec.view(np.float64)[:m0 // 2 + 1, ::2]


def cores() -> int:
    """Return the cores this process may run on (its CPU affinity where the system has one).

    Examples
    --------
    >>> 1 <= cores() <= (os.cpu_count() or 1)
    True
    """
    counted = getattr(os, "process_cpu_count", None)  # Python 3.13
    if counted is not None:
        return counted() or 1
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0)) or 1
    return os.cpu_count() or 1


def _thread_count(workers: int) -> int:
    """Threads for ``workers`` as :mod:`scipy.fft` reads it (negative: from the cores)."""
    return max(1, cores() + 1 + workers if workers < 0 else workers)


def resolve_workers(workers: int | None) -> int:
    """Return the FFT threads of a kernel: ``workers``, or by default where it runs.

    ``None`` means all cores when the kernel runs in the main thread, and one thread
    anywhere else: in a task of dask's threaded scheduler, of a distributed worker or of
    the caller's own thread pool, whose threads already use the cores (a full set of
    threads per task would oversubscribe them). Resolved when the kernel runs, in the
    thread that runs it, so a graph built in the main thread and computed by dask gets
    one thread per task.

    Examples
    --------
    >>> resolve_workers(3), resolve_workers(None) == cores()
    (3, True)
    """
    if workers is not None:
        return int(workers)
    if threading.current_thread() is not threading.main_thread():
        return 1
    return cores()


def _power_quarter(rows: np.ndarray, m0: int, workers: int) -> np.ndarray:
    """Return the real quarter ``(m0/2 + 1, width)`` of the folded power of a map.

    ``rows``: the row transforms of the map (``(ny, width)`` complex, ``ny <= m0``), each
    column zero padded to ``m0`` and transformed a slab of columns at a time, its power
    folded (:func:`_fold_columns`) into the quarter: the one full-size array made here, a
    real one of about a quarter of the padded spectrum (of a map padded to twice its
    size, half of the map's). The slabs run on ``workers`` threads, each with its own
    slab buffer.
    """
    width = rows.shape[1]
    quarter = np.empty((m0 // 2 + 1, width))
    scratch = _Scratch()

    def one(cols, threads):  # a slab of columns
        c0, c1 = cols
        slab = _column_slab(rows, c0, c1, m0, threads, scratch)
        quarter[:, c0:c1] = _folded_power(slab, m0, threads)

    _in_threads(one, width, m0, workers)
    return quarter


#: Largest |exponent| of the heights' scale for which a float64 map is transformed as it
#: is and its sums scaled at the end: a mode's power (at most 2^(2e + 66) for up to 2^32
#: points) stays far from overflow, and its smallest values far from subnormal numbers,
#: so that scaling the sums by 2^(-2 exponent) is exact, as scaling the heights first.
SCALE_AFTER = 400


def _periodic_binned(h, exponent, binner, *, ks, fshape, workers):
    ny, nx = h.shape
    scale_after = h.dtype == np.float64 and abs(exponent) < SCALE_AFTER
    if scale_after:  # all rows at once, straight from the heights: no copy of them
        rows = sfft.rfft(h, axis=-1, workers=workers)
    else:  # a float32 map, or an extreme scale: block by block, scaled first
        rows = _spectrum_rows(lambda r0, r1: scaled_rows(h[r0:r1], exponent), ny,
                              fshape[1], workers)
    quarter = _power_slabs(rows, workers)
    # sum of squared differences over pairs: 2 (C(0) - C(d)) per distinct signed lag (the
    # points of a periodic map are pairs at every lag)
    zero = _folded_row_block(quarter, 0, 1, ks, fshape, workers)[0, 0]

    def block(i0, i1, threads):
        return _folded_row_block(quarter, i0, i1, ks, fshape, threads, scale=-2.0,
                                 offset=8.0 * zero, overwrite=True)

    sums = binner(block, ks[0] + 1)
    if scale_after:
        sums *= 2.0 ** (-2 * exponent)
    return sums


def scaled_rows(h: np.ndarray, exponent: int) -> np.ndarray:
    """``h * 2**-exponent`` in float64, one pass (a new array; float32 maps in double).

    A multiplication by the power of two where it is a normal number (exact, as
    ``ldexp``, which is several times slower), ``ldexp`` beyond.
    """
    if abs(exponent) < 1000:
        return np.multiply(h, 2.0 ** -exponent, dtype=np.float64)
    return np.ldexp(h.astype(np.float64), -exponent)


def _scaled_centred(h, exponent, mean, r0, r1, square=False, complete=False):
    """Rows ``r0:r1`` of ``h 2**-exponent - mean``, 0 where missing (squared if asked).

    ``complete``: the map has no missing point (nothing to look for).
    """
    b = scaled_rows(h[r0:r1], exponent)
    b -= mean
    if not complete:
        np.copyto(b, 0.0, where=np.isnan(b))
    if square:
        np.square(b, out=b)
    return b


def _open_binned(h, exponent, binner, *, ks, fshape, workers):
    ny, nx = h.shape
    mean = np.ldexp(h.mean(dtype=np.float64), -exponent)
    rows = _spectrum_rows(lambda r0, r1: _scaled_centred(h, exponent, mean, r0, r1,
                                                         complete=True),
                          ny, fshape[1], workers)
    quarter = _power_quarter(rows, fshape[0], workers)
    del rows
    # the h(r)^2 + h(r+d)^2 terms from the table of sq_table (the size of the map), made
    # once the row transforms are gone, and binned with the correlations in one pass
    # (doubled: the four signed lags of a folded one, over the pair's two squares)
    u = sq_table(((r0, r1, _scaled_centred(h, exponent, mean, r0, r1, square=True,
                                           complete=True))
                  for r0, r1 in _row_blocks(ny, nx)), ny, nx, ks[1], scale=2.0)

    def block(i0, i1, threads):
        return _folded_row_block(quarter, i0, i1, ks, fshape, threads, scale=-2.0,
                                 offset=lambda b: _add_sq_rows(b, u, i0, i1),
                                 overwrite=True)

    return binner(block, ks[0] + 1)


def _masked_binned(h, exponent, binner, *, ks, fshape, workers):
    """Bin the sums and counts of a map with missing points (correlations of :func:`_masked`).

    The row transforms of the mask and of ``h^2`` first: per column slab their
    transforms ``M`` and ``B`` give the folded ``|M|^2`` (counts) and
    ``2 Re(conj(B) M)`` (sums) in two real quarters; then those of ``h``, whose folded
    ``2 |A|^2`` each slab takes from the sums (folding is linear).
    """
    ny, nx = h.shape
    m0 = fshape[0]
    valid = np.isfinite(h)
    nvalid = float(np.count_nonzero(valid))
    del valid
    mean = np.ldexp(np.nansum(h, dtype=np.float64) / max(nvalid, 1.0), -exponent)

    def rows_of(square):  # the row transforms of h^2 (square) or h, centred and scaled
        return _spectrum_rows(lambda r0, r1: _scaled_centred(h, exponent, mean, r0, r1,
                                                             square), ny, fshape[1], workers)

    mask = _spectrum_rows(lambda r0, r1: np.isfinite(h[r0:r1]).astype(np.float64), ny,
                          fshape[1], workers)
    width = mask.shape[1]
    counts_q, sums_q = np.empty((2, m0 // 2 + 1, width))
    scratch = _Scratch()

    def cross(cols, threads, squares, mask):  # a slab of columns of h^2 and of the mask
        c0, c1 = cols
        b, m = (_column_slab(r, c0, c1, m0, threads, scratch, name)
                for r, name in ((squares, "b"), (mask, "m")))
        w = np.multiply(b.real, m.real, out=scratch.get("w", b.shape))
        w += np.multiply(b.imag, m.imag, out=b.imag)
        w *= 2.0  # 2 Re(conj(B) M)
        sums_q[:, c0:c1] = _fold_columns(w, m0, threads)
        counts_q[:, c0:c1] = _folded_power(m, m0, threads)  # |M|^2

    def power(cols, threads, rows):  # a slab of columns of h
        c0, c1 = cols
        p = _folded_power(_column_slab(rows, c0, c1, m0, threads, scratch), m0, threads)
        p *= 2.0  # 2 |A|^2
        sums_q[:, c0:c1] -= p

    _in_threads(functools.partial(cross, squares=rows_of(True), mask=mask), width, m0,
                workers)
    del mask
    _in_threads(functools.partial(power, rows=rows_of(False)), width, m0, workers)
    empty = np.zeros((ks[0] + 1, ks[1] + 1), dtype=bool)  # lags without pairs

    def count_block(i0, i1, threads):
        c = np.rint(_folded_row_block(counts_q, i0, i1, ks, fshape, threads,
                                      overwrite=True))
        empty[i0:i1] = c == 0
        return c

    def sum_block(i0, i1, threads):
        s = _folded_row_block(sums_q, i0, i1, ks, fshape, threads, overwrite=True)
        s[empty[i0:i1]] = 0.0  # no pairs: only round-off was there
        return s

    counts = binner(count_block, ks[0] + 1)
    sums = binner(sum_block, ks[0] + 1)
    return sums, counts, nvalid


# ---------------------------------------------------------------------------------------
# binned geometry and packed sums, shared by the FFT and random-pair estimators
# ---------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=4)
def binned_geometry(shape: tuple[int, ...], spacing: tuple[float, ...], periodic: bool,
                    ks: tuple[int, ...], edges_key: tuple[float, ...]):
    """Bin of each folded lag, ordered pairs and their lag sums per bin, of a complete map.

    Cached per grid and bins (``edges_key`` is the tuple of the bin edges); returns
    ``(index, counts, lag sums)``, the index read-only.
    """
    edges = np.asarray(edges_key)
    idx = folded_bin_index(ks, spacing, edges)
    nb = len(edges) - 1
    if len(ks) == 1:
        geo = folded_geometric_counts(shape, ks, periodic)
        counts = binned_sum(geo, idx, nb)
        rsum = binned_sum(geo * np.sqrt(lag_radius2(ks, spacing)), idx, nb)
    else:  # a block of rows at a time: no plane of the map's size
        cy, cx = (_axis_counts(n, k, periodic) for n, k in zip(shape, ks))
        x2 = (np.arange(ks[1] + 1) * spacing[1]) ** 2
        counts, rsum = np.zeros(nb + 1), np.zeros(nb + 1)
        for i0, i1 in _row_blocks(ks[0] + 1, ks[1] + 1):
            i = np.arange(i0, i1)
            b = idx[i0:i1].ravel()
            geo = np.multiply.outer(cy[i0:i1], cx)
            counts += np.bincount(b, weights=geo.ravel(), minlength=nb + 1)
            geo *= np.sqrt(((i * spacing[0]) ** 2)[:, None] + x2)
            rsum += np.bincount(b, weights=geo.ravel(), minlength=nb + 1)
        counts, rsum = counts[:nb], rsum[:nb]
    idx.setflags(write=False)
    return idx, counts, rsum


def few_points_message(index: int, batch: tuple[int, ...]) -> str:
    """Message for a map with fewer than 2 valid points, naming it within a stack."""
    where = (f" (map {tuple(int(i) for i in np.unravel_index(index, batch))} of the stack)"
             if batch else "")
    return f"topography has fewer than 2 valid (non-NaN) points{where}"


def packed(batch, gsum, counts, gsq, nvalid, exponents) -> np.ndarray:
    """Pack per map its sums of G, pair counts, sums of G^2, valid points and exponent.

    The sums and counts have one value per kept bin, the exponent is that of the map's
    scale; shape ``batch + (3 nb + 2,)``. One array per map is one task output per map for
    dask, and pools with one reduction (:func:`pool`).
    """
    n = gsum.shape[0]
    out = np.concatenate([gsum, counts, gsq, np.reshape(nvalid, (n, 1)),
                          np.reshape(exponents, (n, 1))], axis=-1)
    return out.reshape(batch + out.shape[-1:])


def pool(sums: np.ndarray, axis, keepdims: bool = False) -> np.ndarray:
    """Pool packed sums (:func:`packed`) over ``axis``: each brought to the largest exponent.

    Sums of G scale with the square of the heights' scale, sums of G^2 with its fourth
    power, counts not at all; a map whose scale is far below the largest contributes
    (under)flowing nothing. Usable as the chunk, combine and aggregate step of a dask
    reduction.
    """
    nb = (sums.shape[-1] - 2) // 3
    exponent = sums[..., -1:]
    top = np.max(exponent, axis=axis, keepdims=True)
    shift = exponent - top
    factor = np.concatenate([np.broadcast_to(np.exp2(2 * shift), shift.shape[:-1] + (nb,)),
                             np.ones(shift.shape[:-1] + (nb,)),
                             np.broadcast_to(np.exp2(4 * shift), shift.shape[:-1] + (nb,)),
                             np.ones(shift.shape[:-1] + (1,))], axis=-1)
    out = np.sum(sums[..., :-1] * factor, axis=axis, keepdims=keepdims)
    return np.concatenate([out, top if keepdims else np.squeeze(top, axis)], axis=-1)


def g_from_packed(sums, *, dr, pixel_area, geometry, height_unit, g_unit,
                  random, errors: bool = True) -> np.ndarray:
    """G, pair count, standard error and sampling error ``(..., 4, nb)`` from packed sums.

    G is the mean of the pair values per bin; its standard error combines the finite-area
    variance (:func:`area_variance`) with the Monte-Carlo variance of random pairs (0 for
    all pairs, ``random=False``); all back from the scaled heights (``2**exponent``).
    ``errors=False``: the standard error is NaN, not computed (the spectrum of G that the
    finite-area variance needs is most of the cost of a small map's G).
    """
    nb = (sums.shape[-1] - 2) // 3
    gsum, counts, gsq = sums[..., :nb], sums[..., nb:2 * nb], sums[..., 2 * nb:3 * nb]
    valid, exponent = sums[..., -2], sums[..., -1:]
    has = counts > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        G = np.where(has, gsum / np.where(has, counts, 1.0), np.nan)
        var = np.clip(gsq / np.where(has, counts, 1.0) - G**2, 0.0, None)
        sampling = (np.where(counts > 1, np.sqrt(var / np.where(counts > 1, counts - 1, 1.0)),
                             np.nan) if random else np.zeros_like(G))
    if errors:
        area_var = area_variance(G, counts, valid, dr=dr, pixel_area=pixel_area,
                                 geometry=geometry,
                                 smooth=RANDOM_PAIRS_SMOOTHING if random else None)
        total = np.where(has, np.sqrt(area_var + np.nan_to_num(sampling) ** 2), np.nan)
    else:
        total = np.full(G.shape, np.nan)
    G, total, sampling = (times_power_of_two(x, exponent, power=2, height_unit=height_unit,
                                             g_unit=g_unit)
                          for x in (G, total, np.where(has, sampling, np.nan)))
    return np.stack([G, counts, total, sampling], axis=-2)


#: Decades over which G from random pairs is smoothed before its finite-area variance is
#: formed from its spectrum (:func:`.uncertainty.finite_area_variance`).
RANDOM_PAIRS_SMOOTHING = 0.5


def area_variance(g, pairs, valid, *, dr, pixel_area, geometry, smooth=None):
    """Finite-area variance of G per bin, curve by curve.

    In Fourier space from the spectrum of G itself (:func:`.uncertainty.
    finite_area_variance`; calibrated within 0.91-1.03 of the scatter over seeds at every
    lag up to ``L/2``, where the real-space closure was 0.61-1.45 off).
    """
    g, pairs, valid = np.broadcast_arrays(g, pairs, valid[..., None])
    out = np.empty(g.shape)
    for k in np.ndindex(g.shape[:-1]):
        area = float(valid[k][0]) * pixel_area
        out[k] = finite_area_variance(dr, g[k], pairs[k], area=area, pixel_area=pixel_area,
                                      geometry=geometry, smooth=smooth)
    return out


def times_power_of_two(values, exponent, *, power: int, height_unit: str, g_unit: str):
    """Return ``values * 2^(exponent power)``, or a clear error outside float64's range.

    Heights (in ``height_unit``) were scaled by ``2^exponent`` (a number, or one per curve
    broadcasting against ``values``); ``values`` is a ``power`` of them, G in ``g_unit``.
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
            f"G reach about 1e{decade:.0f} {g_unit}, outside the "
            "range of float64 numbers (1e-308 to 1.8e308): check the height scale of the "
            "data (a wrong unit or scale factor), or express the heights in a unit that "
            "brings them nearer to 1")
    return out
