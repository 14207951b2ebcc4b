"""Statistical error of an all-pairs G estimate from a finite map (pure numpy).

The estimate ``G^(d) = (1/A) int d2r f(r)`` with ``f = (h(r+d) - h(r))^2 / 2`` scatters
from map to map because nearby squared differences are correlated. For Gaussian heights
``Cov(f(0; d), f(s; d')) = gamma(s)^2 / 2`` with the increment covariance

    gamma(s; d, d') = G(s + d') + G(s - d) - G(s) - G(s + d' - d),

so that

    Var G^(d) = (1 / 2A) int d2s < gamma(s; d, d')^2 >,

averaged over the orientations of ``d`` and ``d'`` that the radial bin mixes (none for a
profile or one axis). ``G`` itself (the estimate, log-log interpolated, ballistic ``r^2``
below the first bin and flat beyond the last) closes the expression. For ``H > 1/2`` the
integral is dominated by the largest scales, which is why small-lag errors of
self-affine maps are much larger than ``1/sqrt(pairs)``. The variance is never taken
below that of independent pairs, ``2 G^2 / pairs``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["g_variance"]


def _interpolator(dr: np.ndarray, g: np.ndarray):
    ok = np.isfinite(g) & (g > 0) & (dr > 0)
    x = np.log(dr[ok])
    y = np.log(g[ok])
    if x.size == 0:
        return None
    if x.size == 1:
        x = np.array([x[0], x[0] + 1.0])
        y = np.array([y[0], y[0]])

    def G(r):
        r = np.asarray(r)
        with np.errstate(divide="ignore"):
            lr = np.log(np.maximum(r, 1e-300))
        out = np.exp(np.interp(lr, x, y))
        small = lr < x[0]
        out = np.where(small, np.exp(y[0] + 2.0 * (lr - x[0])), out)  # ballistic
        return np.where(r > 0, out, 0.0)

    return G


def g_variance(dr: np.ndarray, g: np.ndarray, pairs: np.ndarray, *, area: float,
               pixel_area: float, geometry: str, n_s: int = 40, n_angle: int = 16,
               n_orient: int = 6) -> np.ndarray:
    """Variance of the all-pairs G estimate per bin (Gaussian, finite area).

    Parameters
    ----------
    dr, g, pairs : ndarray (nbins,)
        Bin lags, the G estimate and the number of pairs per bin.
    area : float
        Valid area (2D, length^2) or valid length (profile).
    pixel_area : float
        Area (length) of one grid cell.
    geometry : {'radial', 'axis', 'profile'}
        Radial average on a map, one axis of a map, or a profile.

    Returns
    -------
    ndarray (nbins,)
    """
    G = _interpolator(dr, g)
    if G is None or area <= 0:
        return np.full(dr.shape, np.nan)
    floor = np.where(pairs > 0, 2.0 * g**2 / np.maximum(pairs, 1), np.nan)
    if geometry == "profile":
        # gamma(s) = G(|s + d|) + G(|s - d|) - 2 G(|s|) is even in s
        half = 0.5 * pixel_area
        s = np.geomspace(half, max(0.5 * area, 2 * half), n_s)
        ws = np.gradient(np.log(s)) * s  # ds in log steps
        d = dr[:, None]
        gam = G(s + d) + G(np.abs(s - d)) - 2 * G(s)
        integral = (2 * G(dr)) ** 2 * pixel_area + 2 * (gam**2 * ws).sum(-1)
        return np.fmax(integral / (2 * area), floor)
    rho0 = np.sqrt(pixel_area / np.pi)  # the central cell, as a disk
    s = np.geomspace(rho0, max(np.sqrt(area / np.pi), 2 * rho0), n_s)
    ws = np.gradient(np.log(s)) * s * s  # s ds in log steps
    phi = (np.arange(n_angle) + 0.5) * 2 * np.pi / n_angle
    sx = (s[:, None] * np.cos(phi)[None, :])[None, :, :, None]
    sy = (s[:, None] * np.sin(phi)[None, :])[None, :, :, None]
    # relative orientation of d' against d = (d, 0): all of them for a radial bin
    psi = (np.arange(n_orient) + 0.5) * np.pi / n_orient if geometry == "radial" else \
        np.zeros(1)
    d = dr[:, None, None, None]
    dpx, dpy = d * np.cos(psi), d * np.sin(psi)

    def gamma(x, y):
        return (G(np.hypot(x + dpx, y + dpy)) + G(np.hypot(x - d, y))
                - G(np.hypot(x, y)) - G(np.hypot(x + dpx - d, y + dpy)))

    mean_sq = (gamma(sx, sy) ** 2).mean(axis=(2, 3))  # over the angle of s and of d'
    centre = (gamma(0.0, 0.0) ** 2).mean(axis=(1, 2, 3))
    integral = centre * np.pi * rho0**2 + 2 * np.pi * (mean_sq * ws).sum(-1)
    var = integral / (2 * area)
    return np.fmax(var, floor)
