"""Finite differences at a given step: the one derivative stencil of xrough (pure numpy).

Every slope and curvature that xrough reports (the roughness parameters, their
distributions, the scale-dependent slope and curvature, the tip check) is built from the
two stencils of this module, taken between grid points ``k`` pixels apart along one grid
axis of spacing ``d``:

``slope``
    the forward difference ``s_k(x) = [h(x + k d) - h(x)] / (k d)``, one value per pair of
    points ``k d`` apart (the pairs of ``G(k d)``, eq. 1);
``curvature``
    the central second difference ``c_k(x) = [h(x + k d) - 2 h(x) + h(x - k d)] / (k d)^2``,
    one value per point with both neighbours.

On an open grid a stencil is evaluated only where all its points lie inside the grid (the
output is shorter along the axis: ``n - k`` slopes, ``n - 2k`` curvatures); on a periodic
grid it wraps around (``n`` values). NaN marks a missing height, and any stencil that
touches one is NaN: a derivative exists only where all its points are valid.

Maps combine the two axes at common points: :func:`gradient` (both forward differences
from the same point, the "corner" stencil) and :func:`mean_curvature` (half the
five-point Laplacian).

Heights and spacings are plain numbers in whatever units the caller chose (a slope is in
height unit per spacing unit). Arrays carry the grid axes last: ``(..., n)`` for profiles,
``(..., ny, nx)`` for maps, ``nd`` says how many.
"""

from __future__ import annotations

import numpy as np

from .checks import require_count

__all__ = ["check_step", "difference", "second_difference", "slope", "curvature",
           "gradient", "mean_curvature", "mean_of_axis_curvatures"]


def _cut(ndim: int, ax: int, start, stop) -> tuple[slice, ...]:
    return tuple(slice(start, stop) if i == ax else slice(None) for i in range(ndim))


def _axis(h: np.ndarray, nd: int, axis: int) -> int:
    if not 0 <= axis < nd or h.ndim < nd:
        raise ValueError(f"axis {axis} is not one of the {nd} grid axes of an array of "
                         f"shape {h.shape}")
    return h.ndim - nd + axis


def check_step(step, n: int, *, periodic: bool, width: int = 1) -> int:
    """Return ``step`` as an int if the stencil ``width * step`` fits a grid of ``n`` points.

    Parameters
    ----------
    step : int
        Pixels between the points of the stencil (``k``).
    n : int
        Points along the axis.
    periodic : bool
        A periodic grid wraps around: ``1 <= k < n``.
    width : int
        The stencil spans ``width * k`` pixels: 1 for a slope, 2 for a curvature. An open
        grid needs ``width * k < n``.

    Examples
    --------
    >>> check_step(3, 10, periodic=False, width=2)
    3
    >>> check_step(5, 10, periodic=False, width=2)
    Traceback (most recent call last):
    ...
    ValueError: a stencil of 2 x 5 pixels does not fit an open grid of 10 points
    """
    k = require_count(step, "the step of a finite difference (pixels)", minimum=1)
    if periodic and k >= n:
        raise ValueError(f"a step of {k} pixels wraps once around a periodic grid of {n} "
                         "points or more")
    if not periodic and width * k >= n:
        raise ValueError(f"a stencil of {width} x {k} pixels does not fit an open grid of "
                         f"{n} points")
    return k


def difference(h, *, nd: int, axis: int, step: int, periodic: bool) -> np.ndarray:
    """Height differences ``h(x + k) - h(x)`` of every pair of points ``k`` pixels apart.

    Parameters
    ----------
    h : numpy.ndarray, shape (..., [ny,] nx)
        Heights; NaN marks missing points.
    nd : int
        Number of grid axes at the end of ``h`` (1 or 2).
    axis : int
        The grid axis the pairs lie along (``0`` for ``y`` of a map or ``x`` of a profile,
        ``nd - 1`` for ``x``).
    step : int
        ``k``, in pixels.
    periodic : bool
        Wrap around the edge (``n`` pairs) instead of keeping the ``n - k`` pairs inside.

    Returns
    -------
    numpy.ndarray
        Shorter by ``k`` along ``axis`` when open; NaN where a point of the pair is.

    Examples
    --------
    >>> difference(np.array([0.0, 1.0, 4.0, 9.0]), nd=1, axis=0, step=2, periodic=False)
    array([4., 8.])
    >>> difference(np.array([0.0, 1.0, 4.0, 9.0]), nd=1, axis=0, step=1, periodic=True)
    array([ 1.,  3.,  5., -9.])
    """
    h = np.asarray(h, dtype=float)
    ax = _axis(h, nd, axis)
    n = h.shape[ax]
    k = check_step(step, n, periodic=periodic)
    if not periodic:
        return h[_cut(h.ndim, ax, k, None)] - h[_cut(h.ndim, ax, None, n - k)]
    out = np.empty_like(h)
    np.subtract(h[_cut(h.ndim, ax, k, None)], h[_cut(h.ndim, ax, None, n - k)],
                out=out[_cut(h.ndim, ax, None, n - k)])
    np.subtract(h[_cut(h.ndim, ax, None, k)], h[_cut(h.ndim, ax, n - k, None)],
                out=out[_cut(h.ndim, ax, n - k, None)])
    return out


def second_difference(h, *, nd: int, axis: int, step: int, periodic: bool) -> np.ndarray:
    """``h(x + k) - 2 h(x) + h(x - k)`` at every point with both neighbours.

    Parameters
    ----------
    h, nd, axis, step, periodic
        As for :func:`difference`.

    Returns
    -------
    numpy.ndarray
        Open: the points ``k .. n - k - 1`` (shorter by ``2 k``); periodic: every point.

    Examples
    --------
    >>> second_difference(np.arange(6.0) ** 2, nd=1, axis=0, step=2, periodic=False)
    array([8., 8.])
    """
    h = np.asarray(h, dtype=float)
    ax = _axis(h, nd, axis)
    n = h.shape[ax]
    k = check_step(step, n, periodic=periodic, width=1 if periodic else 2)
    if not periodic:
        out = h[_cut(h.ndim, ax, 2 * k, None)] + h[_cut(h.ndim, ax, None, n - 2 * k)]
        out -= 2.0 * h[_cut(h.ndim, ax, k, n - k)]
        return out
    out = -2.0 * h  # + h(x + k) and + h(x - k), wrapped, in place (no padded copy)
    out[_cut(h.ndim, ax, None, n - k)] += h[_cut(h.ndim, ax, k, None)]
    out[_cut(h.ndim, ax, n - k, None)] += h[_cut(h.ndim, ax, None, k)]
    out[_cut(h.ndim, ax, k, None)] += h[_cut(h.ndim, ax, None, n - k)]
    out[_cut(h.ndim, ax, None, k)] += h[_cut(h.ndim, ax, n - k, None)]
    return out


def slope(h, *, nd: int, axis: int, step: int, spacing: float,
          periodic: bool) -> np.ndarray:
    """Forward-difference slope ``[h(x + k d) - h(x)] / (k d)`` of every pair (see module).

    Examples
    --------
    >>> slope(np.array([0.0, 1.0, 4.0]), nd=1, axis=0, step=1, spacing=0.5, periodic=False)
    array([2., 6.])
    """
    out = difference(h, nd=nd, axis=axis, step=step, periodic=periodic)
    out /= step * spacing
    return out


def curvature(h, *, nd: int, axis: int, step: int, spacing: float,
              periodic: bool) -> np.ndarray:
    """Central second difference ``[h(x + k d) - 2 h(x) + h(x - k d)] / (k d)^2`` (see module).

    Examples
    --------
    >>> x = np.arange(7.0) * 0.5
    >>> curvature(0.5 * x**2, nd=1, axis=0, step=2, spacing=0.5, periodic=False)
    array([1., 1., 1.])
    """
    out = second_difference(h, nd=nd, axis=axis, step=step, periodic=periodic)
    out /= (step * spacing) ** 2
    return out


def gradient(h, *, steps: tuple[int, int], spacing: tuple[float, float],
             periodic: bool) -> tuple[np.ndarray, np.ndarray]:
    """Slopes along ``y`` and ``x`` from the same points of a map (the corner stencil).

    The forward differences from ``(y, x)`` to ``(y + ky, x)`` and to ``(y, x + kx)``; on an
    open map only the points from which both partners lie inside it, ``(ny - ky, nx - kx)``.

    Parameters
    ----------
    h : numpy.ndarray, shape (..., ny, nx)
    steps : (int, int)
        ``(ky, kx)`` in pixels.
    spacing : (float, float)
        ``(dy, dx)``.
    periodic : bool

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        ``(slope along y, slope along x)``, of one shape.

    Examples
    --------
    >>> h = np.add.outer(np.arange(3.0), 2 * np.arange(4.0))  # h = y + 2 x
    >>> sy, sx = gradient(h, steps=(1, 1), spacing=(1.0, 1.0), periodic=False)
    >>> sy.shape, float(sy.max()), float(sx.min())
    ((2, 3), 1.0, 2.0)
    """
    h = np.asarray(h, dtype=float)
    (ky, kx), (dy, dx) = steps, spacing
    sy = slope(h, nd=2, axis=0, step=ky, spacing=dy, periodic=periodic)
    sx = slope(h, nd=2, axis=1, step=kx, spacing=dx, periodic=periodic)
    if not periodic:
        ny, nx = h.shape[-2:]
        sy, sx = sy[..., :, : nx - kx], sx[..., : ny - ky, :]
    return sy, sx


def mean_curvature(h, *, steps: tuple[int, int], spacing: tuple[float, float],
                   periodic: bool) -> np.ndarray:
    """Half the five-point Laplacian, ``(c_y + c_x) / 2``, at the points where both exist.

    The mean curvature of a map in the small-slope approximation; on an open map the
    interior ``(ny - 2 ky, nx - 2 kx)`` points.

    Parameters
    ----------
    h : numpy.ndarray, shape (..., ny, nx)
    steps, spacing, periodic
        As for :func:`gradient`.

    Examples
    --------
    >>> y, x = np.meshgrid(np.arange(5.0), np.arange(6.0), indexing="ij")
    >>> mean_curvature(x**2 + 3 * y**2, steps=(1, 1), spacing=(1.0, 1.0),
    ...                periodic=False).round(12).tolist()
    [[4.0, 4.0, 4.0, 4.0], [4.0, 4.0, 4.0, 4.0], [4.0, 4.0, 4.0, 4.0]]
    """
    h = np.asarray(h, dtype=float)
    (ky, kx), (dy, dx) = steps, spacing
    cy = curvature(h, nd=2, axis=0, step=ky, spacing=dy, periodic=periodic)
    cx = curvature(h, nd=2, axis=1, step=kx, spacing=dx, periodic=periodic)
    return mean_of_axis_curvatures(cy, cx, steps=steps, periodic=periodic)


def mean_of_axis_curvatures(cy: np.ndarray, cx: np.ndarray, *, steps: tuple[int, int],
                            periodic: bool) -> np.ndarray:
    """Return ``(c_y + c_x) / 2`` at the points the two curvatures share.

    ``cy`` and ``cx`` as :func:`curvature` returns them, each on its own points; for a
    caller that needs the curvatures along the axes as well as their mean.
    """
    if not periodic:
        ky, kx = steps
        cy = cy[..., :, kx: cy.shape[-1] - kx]
        cx = cx[..., ky: cx.shape[-2] - ky, :]
    out = cy + cx
    out *= 0.5
    return out
