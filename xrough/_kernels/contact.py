"""Contact mechanics of one G curve and the formulas of real-space Persson theory (numpy).

All quantities in SI (m, m^2, Pa, J m-2). The curve functions take G on its lags (NaN for
empty bins, a ``dr = 0`` bin allowed) and evaluate it through
:class:`~xrough._kernels.acf_curve.AcfCurve`; the Persson formulas are elementwise and work
on numpy, dask or xarray arrays alike.
"""

from __future__ import annotations

import numpy as np
from scipy import optimize, special

from .acf_curve import AcfCurve, require_acf
from .shape_factors import rolloff_factor, self_affine_factor

__all__ = ["KAPPA_PERSSON", "contact_area", "improved_area", "quick_stress",
           "energy_curve", "laplacian_curve", "patch_radius_curve"]

#: Persson's small-pressure slope of the contact area, ``a_r ~ kappa p*`` (eq. 29).
KAPPA_PERSSON = float(np.sqrt(8 / np.pi))


# ---------------------------------------------------------------------------------------
# Persson theory, elementwise (eq. 29, 41, 42, 50)
# ---------------------------------------------------------------------------------------
def contact_area(p_star, kappa=KAPPA_PERSSON):
    """Eq. 29 with slope ``kappa``: ``a_r = erf(sqrt(pi) kappa p* / 2)``."""
    return special.erf(0.5 * np.sqrt(np.pi) * kappa * p_star)


def improved_area(p_star, a_r):
    """Eq. 50: ``a_ri = (1 - a_r^2) erf(sqrt(pi) p*) + a_r^3``."""
    return (1 - a_r**2) * special.erf(np.sqrt(np.pi) * p_star) + a_r**3


def quick_stress(dr, g, hurst, sigma_h, lambda_r, E_star, rolloff: str = "sharp"):
    """Eq. 41 below ``lambda_r`` and eq. 42 beyond it: quick mean contact stress (Pa).

    ``E* sqrt(c_sa(H) G) / dr`` and ``E* sqrt(c_ro(H)) lambda_r sigma_h / dr^2``.
    """
    h = np.clip(hurst, 1e-3, 1 - 1e-3)
    c_sa = self_affine_factor(h)
    c_ro = rolloff_factor(h, rolloff=rolloff)
    with np.errstate(divide="ignore", invalid="ignore"):
        sa = E_star * np.sqrt(c_sa * g) / dr
        ro = E_star * np.sqrt(c_ro) * lambda_r * sigma_h / dr**2
    return np.where(dr < lambda_r, sa, ro)


# ---------------------------------------------------------------------------------------
# one curve
# ---------------------------------------------------------------------------------------
def _curve(g, error, dr) -> AcfCurve:
    require_acf(dr, g)
    return AcfCurve(dr, g, error)


def energy_curve(g, *, dr, a_c) -> np.ndarray:
    """``int G / r^2 dr`` to infinity and to each ``a_c`` (eq. 16, 44), per unit ``E*/4``.

    Returns ``[total, share below the first bin, share beyond the last bin, *cumulative]``.
    """
    curve = _curve(g, None, dr)
    cum, below, above = curve.cumulative_g_over_r2(a_c)
    total = curve.cumulative_g_over_r2(np.array([np.inf]))[0][0]
    return np.concatenate([[total, below / total, above / total], cum])


def laplacian_curve(g, error, *, dr) -> np.ndarray:
    """2D radial Laplacian of the smoothed G at its lags (NaN at ``dr = 0``)."""
    curve = _curve(g, error, dr)
    out = np.full(dr.shape, np.nan)
    positive = dr > 0
    out[positive] = curve.laplacian(dr[positive])
    return out


def _first_root(f, lo: float, hi: float, n: int = 4000) -> float:
    """Smallest root of ``f`` on a log grid of [lo, hi] (inf if ``f`` stays negative)."""
    grid = np.geomspace(lo, hi, n)
    vals = f(grid)
    sign = np.flatnonzero(vals >= 0)
    if sign.size == 0:
        return np.inf
    k = sign[0]
    if k == 0:
        return float(grid[0])
    return float(optimize.brentq(lambda x: float(f(np.array([x]))[0]), grid[k - 1], grid[k],
                                 xtol=1e-14 * grid[k], rtol=1e-12))


def patch_radius_curve(g, *, dr, E_star, gamma) -> np.ndarray:
    """``[a_c (eq. 46), a_c upper (eq. 44)]`` of one curve (m; inf: sticks everywhere)."""
    curve = _curve(g, None, dr)
    lo, hi = curve.dr[0] * 1e-6, curve.dr[-1] * 1e6

    def upper(a):
        return E_star / 4 * curve.cumulative_g_over_r2(a)[0] - gamma

    def refined(a):
        return upper(a) + E_star * curve(a) / (8 * a)

    return np.array([_first_root(refined, lo, hi), _first_root(upper, lo, hi)])
