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
from scipy import special

from .hankel import PowerLawInterpolant, profile_spectrum_kernel

__all__ = ["g_covariance", "g_variance"]


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
    rho0, sx, sy, ws = _polar_grid(area, pixel_area, n_s, n_angle)
    # relative orientation of d' against d = (d, 0): all of them for a radial bin
    psi = (np.arange(n_orient) + 0.5) * np.pi / n_orient if geometry == "radial" else \
        np.zeros(1)
    d = dr[:, None, None, None]
    dpx, dpy = d * np.cos(psi), d * np.sin(psi)
    mean_sq = (_gamma(G, sx, sy, d, dpx, dpy) ** 2).mean(axis=(2, 3))  # angle of s and d'
    centre = (_gamma(G, 0.0, 0.0, d, dpx, dpy) ** 2).mean(axis=(1, 2, 3))
    integral = centre * np.pi * rho0**2 + 2 * np.pi * (mean_sq * ws).sum(-1)
    var = integral / (2 * area)
    return np.fmax(var, floor)


def _gamma(G, x, y, d, dpx, dpy):
    """Increment covariance ``gamma(s; d, d')`` with ``d = (d, 0)``, ``d' = (dpx, dpy)``."""
    return (G(np.hypot(x + dpx, y + dpy)) + G(np.hypot(x - d, y))
            - G(np.hypot(x, y)) - G(np.hypot(x + dpx - d, y + dpy)))


def _polar_grid(area, pixel_area, n_s, n_angle):
    """Separations ``s`` of a map: central disk radius, ``(sx, sy)`` and ``s ds`` weights."""
    rho0 = np.sqrt(pixel_area / np.pi)  # the central cell, as a disk
    s = np.geomspace(rho0, max(np.sqrt(area / np.pi), 2 * rho0), n_s)
    ws = np.gradient(np.log(s)) * s * s  # s ds in log steps
    phi = (np.arange(n_angle) + 0.5) * 2 * np.pi / n_angle
    sx = (s[:, None] * np.cos(phi)[None, :])[None, :, :, None]
    sy = (s[:, None] * np.sin(phi)[None, :])[None, :, :, None]
    return rho0, sx, sy, ws


def g_covariance(dr: np.ndarray, q: np.ndarray, C: np.ndarray, *, size: float,
                 pixel: float, geometry: str, exact_modes: int = 65536,
                 bands_per_decade: float = 200) -> np.ndarray:
    """Covariance of the finite-area errors of G between bins, from the surface's spectrum.

    A Gaussian surface is a sum of independent Fourier modes whose powers ``P_k`` scatter
    as much as they are large (``Var P_k = <P_k>^2``), and the all-pairs G of a periodic
    map is linear in them, ``G(d) = sum_k P_k w_k(d)``, so that

        Cov(G_i, G_j) = sum_k <P_k>^2 w_k(d_i) w_k(d_j)

    over the modes of the map, with ``w = 1 - cos(k d)`` along a profile or an axis and
    ``w = 1 - J0(k d)`` for a radial bin (all orientations). ``<P_k>`` comes from the
    isotropic spectrum ``C``: ``2 C1D(k) / L`` per mode of a profile (the 1D spectrum of
    :func:`~xrough._kernels.hankel.profile_spectrum_kernel`), ``2 C(|k|) / A`` per mode
    of a map (half of the ``k`` plane: ``k`` and ``-k`` are one mode). This is the
    variance of :func:`g_variance` in Fourier space, where it is a smooth sum: in real
    space it is a second difference of G over the whole map, which a quadrature resolves
    only on a fine grid around four moving points. The first ``exact_modes`` wavenumbers
    are summed one by one, the rest in logarithmic bands (each ``w`` averaged over the
    band: the average of the product is then approximated by the product of the
    averages, which leaves out the diagonal's share of rapidly oscillating long lags at
    short wavelengths, where ``C`` is small). Radial bins are rings (``1 - J0``): the few
    lattice vectors of a bin at the smallest lags see each mode at its own angle, which
    this leaves out; within a factor 2 of a sharp cutoff of C the scatter of C is then
    larger than modelled (docs/spectra.md). A map that is not periodic has fewer pairs at
    long lags, which this leaves out (callers scale to the measured variance).

    Parameters
    ----------
    dr : ndarray (nbins,)
        Bin lags (length).
    q, C : ndarray
        Samples of the isotropic spectrum (angular wavenumber, length^4), increasing
        ``q``; log-log interpolated, 0 outside.
    size, pixel : float
        Scan size ``L`` (largest side; a square map is assumed) and pixel size.
    geometry : {'profile', 'axis', 'radial'}
        As for :func:`g_variance`.
    exact_modes, bands_per_decade : int, float
        Modes summed individually, and the density of the bands beyond.

    Returns
    -------
    ndarray (nbins, nbins)
        Symmetric, in the square of ``G``'s unit (the unit of ``C`` over length^2).

    Examples
    --------
    Profiles whose 1D spectrum is ``1 / k^2`` (``C = 1 / q^3``, ``G = dr / 2 pi``), 4096
    pixels: the error of G at one pixel is 1.76 % of ``1 / 2 pi``, and the errors at 8
    and 16 pixels are correlated by 0.88 (3000 simulated sets of 2048 random mode powers
    give 1.73 % and 0.89).

    >>> import numpy as np
    >>> q = np.geomspace(1e-4, 1e3, 701)
    >>> dr = 2.0 ** np.arange(8)
    >>> cov = g_covariance(dr, q, q**-3.0, size=4096.0, pixel=1.0, geometry="profile")
    >>> sd = np.sqrt(np.diag(cov))
    >>> print(np.round(sd[0] * 2 * np.pi, 4), np.round(cov[3, 4] / (sd[3] * sd[4]), 2))
    0.0176 0.88
    """
    dr = np.asarray(dr, dtype=float)
    nb = dr.size
    ok = np.isfinite(dr) & (dr > 0)
    if not (ok.any() and size > 0 and pixel > 0):
        return np.zeros((nb, nb))
    d = dr[ok]
    spectrum = PowerLawInterpolant(np.asarray(q, dtype=float),
                                   np.clip(np.nan_to_num(C), 0.0, None))
    n_max = max(1, int(np.ceil(0.5 * size / pixel * (np.sqrt(2) if geometry == "radial"
                                                         else 1.0))))
    step = 2 * np.pi / size
    m_exact = np.arange(1, min(exact_modes, n_max) + 1, dtype=float)
    edges = (np.geomspace(m_exact[-1] + 0.5, n_max + 0.5,
                          max(2, int(bands_per_decade * np.log10((n_max + 0.5)
                                                                 / (m_exact[-1] + 0.5))) + 1))
             if n_max > m_exact[-1] else np.empty(0))
    m = np.r_[m_exact, 0.5 * (edges[1:] + edges[:-1])]
    width = np.r_[np.ones(m_exact.size), np.diff(edges)]  # modes per band along k
    k = m * step
    if geometry == "profile":
        kk = np.geomspace(k[0], k[-1], max(2, int(50 * np.log10(k[-1] / k[0])) + 2))
        c1 = np.maximum(profile_spectrum_kernel(kk, spectrum, (q[0], q[-1])), 1e-300)
        c1 = np.exp(np.interp(np.log(k), np.log(kk), np.log(c1)))  # smooth: 50 per decade
        per_mode = (2.0 * c1 / size) ** 2
        weight = width * per_mode
    elif geometry == "axis":
        n = np.r_[-m_exact[::-1], 0.0, m_exact, m[m_exact.size:], -m[m_exact.size:]]
        wn = np.r_[np.ones(2 * m_exact.size + 1), width[m_exact.size:], width[m_exact.size:]]
        ky = n * step
        weight = width * ((2.0 * spectrum(np.hypot(k[:, None], ky[None, :])) / size**2) ** 2
                          @ wn)
    else:
        per_mode = (2.0 * spectrum(k) / size**2) ** 2
        weight = width * np.pi * m * per_mode  # half of each annulus
    cov = np.zeros((d.size, d.size))
    for blk in range(0, k.size, 4096):  # bounded memory
        kb, wb = k[blk:blk + 4096, None], weight[blk:blk + 4096, None]
        if geometry == "radial":
            w = 1.0 - special.j0(kb * d[None, :])
        else:  # the cosine averaged over each band (1 for single modes)
            band = (width[blk:blk + 4096, None] - 1.0).clip(0.0) * step
            w = 1.0 - np.cos(kb * d[None, :]) * np.sinc(band * d[None, :] / (2 * np.pi))
        cov += (w * wb).T @ w
    out = np.zeros((nb, nb))
    idx = np.flatnonzero(ok)
    out[np.ix_(idx, idx)] = 0.5 * (cov + cov.T)
    return out
