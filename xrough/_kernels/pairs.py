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
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sfft

from .binning import lag_multiplicity

__all__ = ["folded_pair_sums", "folded_geometric_counts", "padded_shape"]


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
    ky, kx = ks
    ny, nx = h2.shape[-2:]
    t = np.zeros(h2.shape[:-2] + (ny + 1, nx + 1))
    inner = t[..., 1:, 1:]
    np.cumsum(h2, axis=-2, out=inner)
    np.cumsum(inner, axis=-1, out=inner)
    # Rectangle sums R(r0:r1, c0:c1) from the summed-area table t (t[0, :] = t[:, 0] = 0).
    # For lags (+i, +j) and (+i, -j) the corners are 0, i, ny - i, ny (and likewise in j),
    # so every term is a (reversed) slice of t: views, no gathers.
    fi, ri = slice(0, ky + 1), slice(ny, ny - ky - 1 if ny - ky - 1 >= 0 else None, -1)
    fj, rj = slice(0, kx + 1), slice(nx, nx - kx - 1 if nx - kx - 1 >= 0 else None, -1)
    total = t[..., ny:ny + 1, nx:nx + 1]
    e = t[..., ri, rj] + t[..., fi, fj]
    e -= t[..., ri, fj]
    e -= t[..., fi, rj]
    e += total
    e -= t[..., fi, nx:nx + 1]
    e -= t[..., ny:ny + 1, fj]
    e += t[..., ri, nx:nx + 1]
    e += t[..., ny:ny + 1, rj]
    w = np.multiply.outer(lag_multiplicity(ny, ky, False), lag_multiplicity(nx, kx, False)) / 2
    e *= w
    return e


def folded_pair_sums(h: np.ndarray, ks: tuple[int, ...], *, periodic: bool,
                     workers: int = -1) -> tuple[np.ndarray, np.ndarray]:
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
