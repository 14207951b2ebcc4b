"""Fourier filters of heights on a uniform grid: pure numpy/scipy."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .deferred import fft as sfft

__all__ = ["fourier_filter_kernel", "wavevectors"]


def wavevectors(shape: tuple[int, ...], spacing: tuple[float, ...]) -> list[np.ndarray]:
    """Angular wavevector components ``2 pi k / (n d)`` of a real FFT of ``shape``.

    One array per grid axis, broadcastable to the ``rfftn`` output (the last axis halved).
    """
    out = []
    nd = len(shape)
    for axis, (n, d) in enumerate(zip(shape, spacing)):
        k = sfft.rfftfreq(n, d) if axis == nd - 1 else sfft.fftfreq(n, d)
        view = [1] * nd
        view[axis] = k.size
        out.append((2.0 * np.pi * k).reshape(view))
    return out


def fourier_filter_kernel(h: np.ndarray, *, spacing: tuple[float, ...],
                          function: Callable, isotropic: bool) -> np.ndarray:
    """Multiply the Fourier transform of each map by ``function`` and transform back.

    Parameters
    ----------
    h : numpy.ndarray (..., [ny,] nx)
        Heights without missing points (the grid the last ``len(spacing)`` axes).
    spacing : tuple of float
        Grid spacing per axis.
    function : callable
        ``function(q)`` of the wavevector magnitude (``isotropic``) or
        ``function(q_y, q_x)`` (``function(q_x)`` for a profile) of its components, in
        radians per unit of ``spacing``; its value multiplies the Fourier coefficients.
    isotropic : bool
        Which of the two forms ``function`` takes.

    Returns
    -------
    numpy.ndarray
        The filtered heights, real, the shape of ``h``.

    Examples
    --------
    >>> x = np.arange(64.0)
    >>> h = np.sin(2 * np.pi * x / 32) + np.sin(2 * np.pi * x / 4)  # two wavelengths
    >>> out = fourier_filter_kernel(h, spacing=(1.0,), function=lambda q: q < 1.0,
    ...                             isotropic=True)
    >>> bool(np.allclose(out, np.sin(2 * np.pi * x / 32)))  # the 4-pixel one is gone
    True
    """
    nd = len(spacing)
    axes = tuple(range(h.ndim - nd, h.ndim))
    grid = h.shape[h.ndim - nd:]
    q = wavevectors(grid, spacing)
    if isotropic:
        weight = function(np.sqrt(sum(c * c for c in q)))
    else:
        weight = function(*q)
    weight = np.broadcast_to(np.asarray(weight, dtype=float),
                             np.broadcast_shapes(*(c.shape for c in q)))
    spectrum = sfft.rfftn(np.asarray(h, dtype=float), axes=axes)
    return sfft.irfftn(spectrum * weight, s=grid, axes=axes)
