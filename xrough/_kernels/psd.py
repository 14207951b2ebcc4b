"""Power spectral density of heights on a uniform grid (numpy and scipy only; eq. 4).

The periodogram of ``C(q) = A <|h~(q)|^2>`` with ``h~(q) = (1/A) sum_r dA h(r) exp(-i q.r)``
(``A`` the area of the map, or the length of a line; ``dA`` the area, or length, of one
pixel). For each Fourier mode ``q`` of a grid of ``N`` points,

    C(q) = dA |sum_r w(r) m(r) (h(r) - mu) exp(-i q.r)|^2 / sum_r w(r)^2 m(r),

with ``m`` 1 at valid points and 0 at missing (NaN) ones, ``w`` the window (1 without one)
and ``mu = sum w m h / sum w m`` the window-weighted mean of the valid heights, so that
``C(0) = 0``. Without a window and without missing points the denominator is ``N`` and
``sum_q C(q) / A`` is the variance of the heights exactly (Parseval); in general it is the
``w^2 m``-weighted variance: the window and the missing points form one spectral window,
normalised so that the variance is kept.

Modes are held in the layout of a real FFT (the last axis halved); ``weight`` counts how
many modes of the full grid each entry stands for (``+q`` and ``-q``: 2, or 1 where a mode
is its own conjugate). Bins average ``C`` over the modes whose ``|q|`` lies in
``[edge_b, edge_b+1)``, each mode counted with its weight, so that
``sum_b n_b C_b / A`` is the sum over every binned mode.

The lines of a map (``direction`` ``'x'`` or ``'y'``) are transformed one by one along their
axis, each with its own mean removed, and their periodograms pooled (summed and divided
by the summed ``sum w^2 m`` of the lines with at least 2 valid points).
"""

from __future__ import annotations

import functools
from typing import overload

import numpy as np

from .binning import bin_index
from .deferred import fft as sfft
from .pairs import few_points_message, resolve_workers
from .tiles import scaled_heights

__all__ = ["WINDOWS", "DIRECTIONS", "window_1d", "mode_range", "mode_bins", "error_factors",
           "psd_kernel", "psd2d_kernel"]

#: Windows for open (non-periodic) maps, by their scipy names.
WINDOWS = ("hann", "hamming", "blackman", "blackmanharris")
#: ``'radial'``: the 2D modes of a map; ``'x'``, ``'y'``: the lines of a map along that
#: axis; ``'profile'``: a line profile (one line along x).
DIRECTIONS = ("radial", "x", "y", "profile")


@overload
def window_1d(name: str, n: int) -> np.ndarray: ...
@overload
def window_1d(name: None, n: int) -> None: ...
def window_1d(name: str | None, n: int) -> np.ndarray | None:
    """Return the window ``name`` of ``n`` points, scaled to a mean square of 1 (None: none).

    The DFT-even ("periodic") form of :func:`scipy.signal.get_window`, as used for spectral
    estimation. The scale does not change ``C`` (the normalisation divides by ``sum w^2 m``).

    Examples
    --------
    >>> w = window_1d("hann", 8)
    >>> round(float(np.mean(w**2)), 12), float(w[0])
    (1.0, 0.0)
    """
    if name is None:
        return None
    if name not in WINDOWS:
        raise ValueError(f"window must be one of {WINDOWS} or None, got {name!r}")
    from scipy.signal import get_window  # here: scipy.signal is slow to import

    w = np.asarray(get_window(name, n, fftbins=True), dtype=float)
    return w / np.sqrt(np.mean(w**2))


def _axis_modes(n: int, d: float, half: bool) -> tuple[np.ndarray, np.ndarray]:
    """Wavenumbers ``2 pi k / (n d)`` of one axis, and the weight of each entry."""
    if half:  # the halved axis of a real FFT: k = 0 .. n // 2, +-k folded in
        k = np.arange(n // 2 + 1, dtype=float)
        weight = np.full(k.size, 2.0)
        weight[0] = 1.0
        if n % 2 == 0:
            weight[-1] = 1.0  # the Nyquist mode is its own conjugate
    else:
        k = np.fft.fftfreq(n, 1.0 / n)
        weight = np.ones(n)
    return 2.0 * np.pi * k / (n * d), weight


def _modes(shape: tuple[int, ...], spacing: tuple[float, ...]):
    """``|q|^2`` and weight of every entry of the real FFT of a grid (last axis halved)."""
    q2: float | np.ndarray = 0.0
    weight: float | np.ndarray = 1.0
    for axis, (n, d) in enumerate(zip(shape, spacing)):
        q, w = _axis_modes(n, d, half=axis == len(shape) - 1)
        view = [1] * len(shape)
        view[axis] = q.size
        q2 = q2 + (q**2).reshape(view)
        weight = weight * w.reshape(view)
    full = tuple(n // 2 + 1 if a == len(shape) - 1 else n for a, n in enumerate(shape))
    return np.broadcast_to(q2, full), np.broadcast_to(weight, full)


@functools.lru_cache(maxsize=16)
def mode_range(shape: tuple[int, ...], spacing: tuple[float, ...]) -> tuple[float, float]:
    """Return the smallest positive and the largest ``|q|`` of the modes of a grid.

    Examples
    --------
    >>> lo, hi = mode_range((4,), (1.0,))  # modes 2 pi k / 4 for k = 1, 2
    >>> round(lo / np.pi, 12), round(hi / np.pi, 12)
    (0.5, 1.0)
    """
    q2 = _modes(shape, spacing)[0]
    positive = q2[q2 > 0]
    return float(np.sqrt(positive.min())), float(np.sqrt(q2.max()))


@functools.lru_cache(maxsize=8)
def mode_bins(shape: tuple[int, ...], spacing: tuple[float, ...],
              edges_key: tuple[float, ...]):
    """Bin the modes of a grid (a property of the grid: computed once per grid and bins).

    Parameters
    ----------
    shape, spacing : tuple
        The transformed axes (one for a line, two for a map) and their spacings.
    edges_key : tuple of float
        Bin edges in ``|q|`` (half-open bins), as a tuple (the cache key).

    Returns
    -------
    idx : ndarray of int
        Bin of each real-FFT entry, numbered among the kept bins; ``keep.sum()`` (one past
        the last) for entries outside every bin, and for ``q = 0``.
    n_modes : ndarray of int
        Modes per kept bin.
    q_mean : ndarray
        Mean ``|q|`` of the modes of each kept bin.
    keep : ndarray of bool
        Which of the bins hold at least one mode (the others are dropped).

    All arrays are read-only.
    """
    edges = np.asarray(edges_key, dtype=float)
    nb = edges.size - 1
    q2, weight = _modes(shape, spacing)
    idx = bin_index(np.array(q2), edges)
    idx[(0,) * len(shape)] = nb  # the mean, removed
    n_modes = np.bincount(idx.ravel(), weights=weight.ravel(), minlength=nb + 1)[:nb]
    q_sum = np.bincount(idx.ravel(), weights=(weight * np.sqrt(q2)).ravel(),
                        minlength=nb + 1)[:nb]
    keep = n_modes > 0
    out = (_renumber(idx, keep), np.rint(n_modes[keep]).astype(np.int64),
           q_sum[keep] / n_modes[keep], keep)
    for a in out:
        a.setflags(write=False)
    return out


def _renumber(idx: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Bin numbers among the kept bins; ``keep.sum()`` for the others and the discard slot."""
    renumber = np.full(keep.size + 1, int(keep.sum()), dtype=idx.dtype)
    renumber[np.flatnonzero(keep)] = np.arange(int(keep.sum()), dtype=idx.dtype)
    return renumber[idx]


@functools.lru_cache(maxsize=8)
def error_factors(shape: tuple[int, ...], spacing: tuple[float, ...],
                  edges_key: tuple[float, ...], window: str | None) -> np.ndarray:
    """How much a window correlates the modes of each kept bin: ``f_b >= 1`` (1: none).

    The variance of the mean periodogram of a bin of ``n`` modes of a Gaussian surface is
    ``(2 / n^2) sum_{k, k' in bin} rho^2(k - k') C^2``, where ``rho(d)`` is the correlation
    of two mode amplitudes ``d`` modes apart: the DFT of ``w^2`` normalised to 1 at 0 (the
    product of the axes' for a separable window). Without a window ``rho^2`` is 1 at 0
    and 0 elsewhere, and the variance ``2 C^2 / n``; with one, it is ``2 f_b C^2 / n`` with
    ``f_b = (1 / n) sum_{k, k'} rho^2(k - k')``: about ``sum_d rho^2(d)`` (1.94 per axis
    for Hann) for a bin many modes wide, less for a narrow one. Computed once per grid,
    bins and window, over the lags ``d`` where ``rho^2 > 1e-6``.
    """
    n_modes, keep = mode_bins(shape, spacing, edges_key)[1::2]
    if window is None:
        return np.ones(n_modes.size)
    edges = np.asarray(edges_key, dtype=float)
    q2: float | np.ndarray = 0.0
    for axis, (n, d) in enumerate(zip(shape, spacing)):  # the full plane of modes
        view = [1] * len(shape)
        view[axis] = n
        q2 = q2 + ((2.0 * np.pi * np.fft.fftfreq(n, 1.0 / n) / (n * d)) ** 2).reshape(view)
    idx = bin_index(np.array(np.broadcast_to(q2, shape)), edges)
    idx[(0,) * len(shape)] = edges.size - 1
    idx = _renumber(idx, keep)
    nb = n_modes.size
    rho2 = []
    for n in shape:
        w2 = window_1d(window, n) ** 2
        r = np.abs(np.fft.fft(w2)) ** 2 / np.sum(w2) ** 2
        lags = np.fft.fftfreq(n, 1.0 / n).astype(int)
        rho2.append({int(lag): float(v) for lag, v in zip(lags, r) if v > 1e-6})
    total = n_modes.astype(float)  # the lag 0
    for lag in np.ndindex(*(2 * max(abs(k) for k in r) + 1 for r in rho2)):
        shift = tuple(k - max(abs(j) for j in r) for k, r in zip(lag, rho2))
        if not all(k in r for k, r in zip(shift, rho2)) or shift <= (0,) * len(shape):
            continue  # rho^2 below 1e-6, or counted as its mirror image (rho^2 is even)
        weight = float(np.prod([r[k] for k, r in zip(shift, rho2)]))
        same = idx == np.roll(idx, [-k for k in shift], axis=tuple(range(len(shape))))
        pairs = np.bincount(idx[same & (idx < nb)], minlength=nb)
        total += 2.0 * weight * pairs
    out = total / n_modes
    out.setflags(write=False)
    return out


def _binned(power: np.ndarray, idx: np.ndarray, n: int, nb: int) -> np.ndarray:
    """Sum of ``power`` (real-FFT layout, last axis of length ``n // 2 + 1``) per kept bin.

    Each entry counts for the modes it stands for: twice inside the halved axis, once on
    its first entry (and on the last, the Nyquist mode, when ``n`` is even). ``power`` is
    overwritten.
    """
    power[..., 1:(-1 if n % 2 == 0 else None)] *= 2.0
    return np.bincount(idx.ravel(), weights=power.ravel(), minlength=nb + 1)[:nb]


def _window_nd(windows: tuple[np.ndarray | None, ...]) -> np.ndarray | float:
    """Return the separable window of a map (the outer product), or 1.0 without any."""
    out: np.ndarray | float = 1.0
    for axis, w in enumerate(windows):
        if w is not None:
            view = [1] * len(windows)
            view[axis] = w.size
            out = out * w.reshape(view)
    return out


def _masked(h: np.ndarray, valid: np.ndarray, w, axes: tuple[int, ...]):
    """``w m (h - mu)`` with ``mu`` the ``w m``-weighted mean over ``axes`` (per line).

    Returns it and, over ``axes``, ``sum w m``, ``sum (w m)^2`` and ``sum (w m)^4``. ``w``
    is 1.0 (no window) or broadcasts against ``h``.
    """
    wm = valid * w
    s1 = np.sum(wm, axis=axes)
    with np.errstate(invalid="ignore", divide="ignore"):
        mu = np.sum(np.where(valid, h, 0.0) * wm, axis=axes, keepdims=True) / np.expand_dims(
            s1, axes)
    x = np.where(valid, h - mu, 0.0)
    if np.ndim(w):
        x *= w
    wm2 = wm * wm
    return x, s1, np.sum(wm2, axis=axes), np.sum(wm2 * wm2, axis=axes)


def _prepared(h: np.ndarray, windows) -> tuple:
    """Return a map's windowed, mean-free heights, ``sum w^2 m`` and the mask factor.

    ``(None, None, None)`` where the window leaves no weight on the valid points.
    """
    valid = np.isfinite(h)
    if valid.all() and all(w is None for w in windows):  # the common case, at the least cost
        return h - np.mean(h), float(h.size), 1.0
    w = _window_nd(windows)
    if valid.all():
        return (h - np.sum(h * w) / np.sum(w)) * w, float(np.sum(w * w)), 1.0
    x, s1, s2, s4 = _masked(h, valid, w, (0, 1))
    if not s1 > 0:
        return None, None, None
    w2 = np.broadcast_to(w * w, h.shape)
    g = (float(s4) / float(s2) ** 2) / (float(np.sum(w2 * w2)) / float(np.sum(w2)) ** 2)
    return x, float(s2), g


def psd2d_kernel(h: np.ndarray, *, spacing: tuple[float, float], window: str | None,
                 workers: int | None = None) -> np.ndarray:
    """Compute the periodogram ``C(q_x, q_y)`` of each map, unbinned, ``q = 0`` centred.

    The definition of :func:`psd_kernel` per mode (``fftshift`` order along both axes):
    its ring averages are :func:`psd_kernel`'s ``'radial'`` bins.

    Examples
    --------
    >>> h = np.random.default_rng(0).normal(size=(8, 8))
    >>> C = psd2d_kernel(h, spacing=(1.0, 1.0), window=None)
    >>> C.shape, bool(np.isclose(C.sum() / 64, h.var()))  # Parseval: sum C / A
    ((8, 8), True)
    """
    workers = resolve_workers(workers)
    h = np.asarray(h)
    batch = h.shape[:-2]
    flat = h.reshape((-1,) + h.shape[-2:])
    windows = tuple(window_1d(window, n) for n in h.shape[-2:])
    out = np.empty(flat.shape)
    for b in range(flat.shape[0]):
        scaled, exponent = scaled_heights(flat[b])
        if exponent is None or int(np.isfinite(scaled).sum()) < 2:
            raise ValueError(few_points_message(b, batch))
        x, denominator, _ = _prepared(scaled, windows)
        if x is None:
            raise ValueError("the window leaves no weight on 2 or more valid (non-NaN) "
                             "points of the map: pass window=None, or mask less")
        power = _abs2(sfft.fftn(x, workers=workers))
        C = float(np.prod(spacing)) * sfft.fftshift(power) / denominator
        out[b] = np.ldexp(C, 2 * exponent)
    return out.reshape(h.shape)


def _map_psd(h: np.ndarray, spacing, windows, geometry, workers):
    """``C`` per kept bin of one map and its mask factor (None: no weight on valid points).

    The mask factor ``g = enbw(w m) / enbw(w)``, ``enbw(v) = N sum v^4 / (sum v^2)^2``,
    is 1 without missing points: by how much the missing points reduce the number of
    independent modes (for a compact hole; scattered points reduce it less).
    """
    idx, n_modes = geometry[:2]
    x, denominator, g = _prepared(h, windows)
    if x is None:
        return None, None
    power = _abs2(sfft.rfftn(x, workers=workers))
    sums = _binned(power, idx, h.shape[-1], n_modes.size)
    return float(np.prod(spacing)) * sums / (denominator * n_modes), g


def _lines_psd(h: np.ndarray, d: float, window, geometry, workers):
    """``C`` per kept bin of the lines (rows, along the last axis) of a map, pooled.

    Lines with fewer than 2 valid points (or no weight on them) are left out. The mask
    factor is that of the pooled lines (:func:`_map_psd`).
    """
    idx, n_modes = geometry[:2]
    valid = np.isfinite(h)
    w = 1.0 if window is None else window
    x, s1, s2, s4 = _masked(h, valid, w, (-1,))
    good = (valid.sum(axis=-1) >= 2) & (s1 > 0)
    if not good.any():
        return None, None
    x[~good] = 0.0
    power = _abs2(sfft.rfft(x, axis=-1, workers=workers)).sum(axis=0)
    denominator = float(np.sum(s2[good]))
    sums = _binned(power, idx, h.shape[-1], n_modes.size)
    w2 = np.broadcast_to(np.asarray(w, dtype=float) ** 2, h.shape[-1:])
    own = h.shape[-1] * float(np.sum(w2 * w2)) / float(np.sum(w2)) ** 2
    g = good.sum() * h.shape[-1] * float(np.sum(s4[good])) / denominator**2 / own
    return d * sums / (denominator * n_modes), g


def _abs2(a: np.ndarray) -> np.ndarray:
    """``|a|^2`` of a complex array, with one allocation."""
    v = a.view(np.float64).reshape(a.shape + (2,))
    v *= v
    return v[..., 0] + v[..., 1]


def psd_kernel(h: np.ndarray, *, direction: str, spacing: tuple[float, ...],
               window: str | None, edges: tuple[float, ...],
               workers: int | None = None) -> np.ndarray:
    """Binned power spectral density of each map or line profile of a stack.

    Parameters
    ----------
    h : ndarray, shape (..., ny, nx) or (..., nx)
        Heights (NaN: missing), in any unit; ``C`` comes out in that unit squared times the
        unit of ``spacing`` to the power of the transformed axes.
    direction : {'radial', 'x', 'y', 'profile'}
        What is transformed (see :data:`DIRECTIONS`).
    spacing : tuple of float
        Spacing of the core axes (``(dy, dx)`` for a map, ``(dx,)`` for a profile).
    window : str or None
        Window (:data:`WINDOWS`) along each transformed axis.
    edges : tuple of float
        Bin edges in ``|q|`` (angular wavenumber, inverse unit of ``spacing``).
    workers : int, optional
        FFT threads (:func:`~xrough._kernels.pairs.resolve_workers`: by default all cores
        in the main thread, one in a dask task).

    Returns
    -------
    ndarray, shape (..., nb + 2)
        Per map: ``C`` of the ``nb`` kept bins (:func:`mode_bins`), the mask factor of
        its standard error (:func:`_map_psd`; multiplies :func:`error_factors`), and
        the fraction of valid points.

    Raises
    ------
    ValueError
        A map (or every line of one) with fewer than 2 valid points (naming the map of a
        stack), infinite heights, or a ``C`` beyond the float64 range.
    """
    workers = resolve_workers(workers)
    h = np.asarray(h)
    core = 1 if direction == "profile" else 2
    if direction == "y":
        h = np.swapaxes(h, -1, -2)
        spacing = spacing[::-1]
    batch = h.shape[: h.ndim - core]
    flat = h.reshape((-1,) + h.shape[h.ndim - core:])
    axes = (0, 1) if direction == "radial" else (-1,)
    shape = tuple(flat.shape[1:][a] for a in axes)
    geometry = mode_bins(shape, tuple(spacing[a] for a in axes), tuple(edges))
    windows = tuple(window_1d(window, n) for n in shape)
    nb = geometry[1].size
    out = np.empty((flat.shape[0], nb + 2))
    for b in range(flat.shape[0]):
        scaled, exponent = scaled_heights(flat[b])
        nvalid = int(np.isfinite(scaled).sum())
        if exponent is None or nvalid < 2:
            raise ValueError(few_points_message(b, batch))
        if direction == "radial":
            C, g = _map_psd(scaled, spacing, windows, geometry, workers)
        else:
            C, g = _lines_psd(scaled.reshape((-1, scaled.shape[-1])), float(spacing[-1]),
                              windows[-1], geometry, workers)
        if C is None:
            where = few_points_message(b, batch).partition(" points")[2]
            what = ("the map" if direction == "radial" else
                    f"any line along {'y' if direction == 'y' else 'x'}")
            raise ValueError(f"the window leaves no weight on 2 or more valid (non-NaN) "
                             f"points of {what}{where}: pass window=None, or mask less")
        with np.errstate(over="ignore"):
            C = np.ldexp(C, 2 * exponent)
        if not np.all(np.isfinite(C)):
            raise ValueError("the power spectrum leaves the float64 range: convert the "
                             "heights to a larger or smaller unit (convert_units)")
        out[b, :nb], out[b, nb], out[b, nb + 1] = C, g, nvalid / flat[b].size
    return out.reshape(batch + (nb + 2,))
