"""All-pairs sums of squared height differences by FFT (pure numpy/scipy).

For every lattice lag ``d`` the kernel returns, exactly up to floating-point round-off,

    S(d) = sum over valid pairs (r, r + d) of (h(r) - h(r + d))**2
    N(d) = number of such pairs

folded onto the quarter plane (see :mod:`.binning`). With a validity mask ``m`` (0 where
the height is NaN) and ``h`` set to 0 there,

    S(d) = corr(h**2, m)(d) + corr(m, h**2)(d) - 2 corr(h, h)(d),   N(d) = corr(m, m)(d),

and every correlation is one product of real FFTs. Non-periodic maps are zero padded by the
largest lag needed (not by the full size unless asked), so circular wrap-around never mixes
in. Without missing points cheaper exact forms are used: periodic maps need one forward and
one inverse transform; non-periodic ones get the ``h**2`` terms from a summed-area table.
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sfft

from .binning import lag_multiplicity

__all__ = ["folded_pair_sums", "folded_geometric_counts", "padded_shape"]


def padded_shape(shape: tuple[int, ...], ks: tuple[int, ...], periodic: bool) -> tuple[int, ...]:
    """FFT shape: the map itself (periodic) or padded by the largest lag, to a fast length."""
    if periodic:
        return tuple(shape)
    nd = len(shape)
    return tuple(sfft.next_fast_len(n + k, real=(ax == nd - 1))
                 for ax, (n, k) in enumerate(zip(shape, ks)))


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
    np.cumsum(np.cumsum(h2, axis=-2), axis=-1, out=t[..., 1:, 1:])
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
        Folded sum of ``(h(r) - h(r+d))**2`` and number of valid pairs per lag.
    """
    nd = len(ks)
    axes = tuple(range(-nd, 0))
    shape = h.shape[-nd:]
    fshape = padded_shape(shape, ks, periodic)
    h = np.asarray(h, dtype=np.float64)
    valid = np.isfinite(h)
    if valid.all():
        return _unmasked(h, ks, shape, fshape, axes, periodic, workers)
    return _masked(h, valid, ks, fshape, axes, workers)


def _abs2_inplace(a: np.ndarray) -> np.ndarray:
    """|a|^2 written into the real part of ``a`` (imaginary part zeroed); returns ``a``."""
    re, im = a.real, a.imag
    np.multiply(re, re, out=re)
    np.multiply(im, im, out=im)
    re += im
    im[...] = 0.0
    return a


def _unmasked(h, ks, shape, fshape, axes, periodic, workers):
    batch = h.shape[: h.ndim - len(ks)]
    counts = np.broadcast_to(folded_geometric_counts(shape, ks, periodic),
                             batch + tuple(k + 1 for k in ks))
    if periodic:
        a = sfft.rfftn(h, axes=axes, workers=workers)
        a[(...,) + (0,) * len(ks)] = 0.0  # remove the mean exactly
        corr = sfft.irfftn(_abs2_inplace(a), s=fshape, axes=axes, workers=workers,
                           overwrite_x=True)
        del a
        zero = corr[(...,) + (0,) * len(ks)][(...,) + (None,) * len(ks)].copy()
        folded = fold(corr, ks)
        del corr
        folded_zero = zero * folded_geometric_counts(shape, ks, True) / np.prod(shape)
        return 2.0 * (folded_zero - folded), counts.copy()
    hc = h - h.mean(axis=axes, keepdims=True)
    a = sfft.rfftn(hc, s=fshape, axes=axes, workers=workers)
    corr = sfft.irfftn(_abs2_inplace(a), s=fshape, axes=axes, workers=workers,
                       overwrite_x=True)
    del a
    folded = fold(corr, ks)
    del corr
    np.multiply(hc, hc, out=hc)
    return _sq_terms_nonperiodic(hc, ks) - 2.0 * folded, counts.copy()


def _masked(h, valid, ks, fshape, axes, workers):
    m = valid.astype(np.float64)
    nvalid = m.sum(axis=axes, keepdims=True)
    mean = np.nansum(h, axis=axes, keepdims=True) / np.maximum(nvalid, 1)
    hz = np.where(valid, h - mean, 0.0)
    fm = sfft.rfftn(m, s=fshape, axes=axes, workers=workers)
    del m
    fb = sfft.rfftn(hz * hz, s=fshape, axes=axes, workers=workers)
    w = fb.real * fm.real
    w += fb.imag * fm.imag
    w *= 2.0
    del fb
    n_plane = sfft.irfftn(_abs2_inplace(fm), s=fshape, axes=axes, workers=workers,
                          overwrite_x=True)
    del fm
    counts = np.rint(fold(n_plane, ks))
    del n_plane
    fa = sfft.rfftn(hz, s=fshape, axes=axes, workers=workers)
    del hz
    w -= 2.0 * _abs2_inplace(fa).real
    del fa
    s_plane = sfft.irfftn(w, s=fshape, axes=axes, workers=workers)
    del w
    sums = fold(s_plane, ks)
    sums[counts == 0] = 0.0  # no pairs: only round-off was there
    return sums, counts
