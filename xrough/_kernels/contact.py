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

__all__ = ["KAPPA_PERSSON", "STEEP_DECAY", "contact_area", "improved_area", "nonincreasing",
           "quick_stress", "stress_asymptote", "energy_curve", "laplacian_curve",
           "UNDETERMINED", "OUTSIDE_WINDOW",
           "smooth_tail", "patch_radius_curve"]

#: Persson's small-pressure slope of the contact area, ``a_r ~ kappa p*`` (eq. 29).
KAPPA_PERSSON = float(np.sqrt(8 / np.pi))

#: Power law ``dr^-STEEP_DECAY`` that replaces the full-contact stress ACF beyond its
#: roll-off in partial contact (the paper's "steep power law", section 3.7).
STEEP_DECAY = 4.0


# ---------------------------------------------------------------------------------------
# Persson theory, elementwise (eq. 29, 41, 42, 50)
# ---------------------------------------------------------------------------------------
def contact_area(p_star, kappa=KAPPA_PERSSON):
    """Eq. 29 with slope ``kappa``: ``a_r = erf(sqrt(pi) kappa p* / 2)``."""
    return special.erf(0.5 * np.sqrt(np.pi) * kappa * p_star)


def nonincreasing(g) -> np.ndarray:
    """Return the smallest curve >= ``g`` that does not grow along its last axis.

    The running maximum from the last sample back: for ``gbar(dr)``, which eq. 26 makes
    non-increasing in ``dr`` (it integrates ``q^2 C(q)`` up to ``2 pi / dr``), so that
    ``a_r`` of eq. 29 does not fall with ``dr`` where noise lets an estimate of ``gbar``
    rise.
    """
    g = np.asarray(g, dtype=float)
    env = np.fmax.accumulate(g[..., ::-1], axis=-1)[..., ::-1]
    return np.where(np.isnan(g), np.nan, env)


def improved_area(p_star, a_r):
    """Eq. 50: ``a_ri = (1 - a_r^2) erf(sqrt(pi) p*) + a_r^3``."""
    return (1 - a_r**2) * special.erf(np.sqrt(np.pi) * p_star) + a_r**3


def _hurst_or_nan(hurst):
    """H clipped into (0, 1) for the shape factors; a failed fit's NaN H stays NaN later."""
    return np.clip(np.where(np.isfinite(hurst), hurst, 0.5), 1e-3, 1 - 1e-3)


def quick_stress(dr, g, hurst, sigma_h, lambda_r, shape, *, E_star):
    """Eq. 41 below ``lambda_r`` and eq. 42 beyond it: quick mean contact stress (Pa).

    ``E* sqrt(c_sa(H) G) / dr`` and ``E* sqrt(c_ro(H)) lambda_r sigma_h / dr^2``;
    ``shape``: the roll-off of each fit, index in ``ROLLOFFS`` (0 sharp, 1 smooth).
    """
    h = _hurst_or_nan(hurst)
    c_sa = self_affine_factor(h)
    c_ro = np.where(np.asarray(shape) == 1, rolloff_factor(h, rolloff="smooth"),
                    rolloff_factor(h, rolloff="sharp"))
    with np.errstate(divide="ignore", invalid="ignore"):
        sa = E_star * np.sqrt(c_sa * g) / dr
        ro = E_star * np.sqrt(c_ro) * lambda_r * sigma_h / dr**2
    return np.where(np.isfinite(hurst), np.where(dr < lambda_r, sa, ro), np.nan)


def stress_asymptote(dr, g, hurst, gbar0, E_star, weight=1.0):
    """Eq. 51: ``Gamma_sigma ~ w E*^2 H^2 gbar(0) sqrt(G / c_sa(H)) / dr`` (Pa^2).

    The small-pressure limit of eq. 47/48 in the self-affine range, from
    ``G_sigma_full = (E*/2)^2 (2H)^2 G / dr^2``, ``gbar^2(dr) = c_sa G / dr^2`` and
    ``a_r -> kappa p*``: ``w = 1`` for the original weighting (``kappa`` cancels) and
    ``w = kappa^2 / 4`` for the modified one (``2 / pi`` for Persson's ``kappa``).
    """
    h = _hurst_or_nan(hurst)
    with np.errstate(divide="ignore", invalid="ignore"):
        value = weight * E_star**2 * h**2 * gbar0 * np.sqrt(g / self_affine_factor(h)) / dr
    return np.where(np.isfinite(hurst), value, np.nan)


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


#: Codes of :func:`laplacian_curve`'s second row: why a lag has no Laplacian.
UNDETERMINED, OUTSIDE_WINDOW = 1.0, 2.0


def laplacian_curve(g, error, *, dr, window=(0.0, np.inf)) -> np.ndarray:
    """2D radial Laplacian of the smoothed G at its lags, NaN where G does not determine it.

    Returns two rows on ``dr``: the Laplacian (NaN at ``dr = 0``, in empty bins and where
    it is not determined) and why a lag has none: 0 (it has one, or ``dr = 0`` / an empty
    bin), :data:`UNDETERMINED` (at or below the largest lag where the estimates from all,
    the even and the odd bins disagree, :meth:`AcfCurve.determined_laplacian`) or
    :data:`OUTSIDE_WINDOW` (outside the reliable lag range ``window`` of the instrument).
    """
    curve = _curve(g, error, dr)
    lap, determined = curve.determined_laplacian()
    out = np.full((2, dr.size), np.nan)
    out[1] = 0.0
    at = np.searchsorted(dr, curve.dr)  # the curve's samples among the lags
    out[0, at] = np.where(determined, lap, np.nan)
    out[1, at] = np.where(determined, 0.0, UNDETERMINED)
    outside = (dr > 0) & ((dr < window[0]) | (dr > window[1]))
    out[0, outside] = np.nan
    out[1, outside] = np.maximum(out[1, outside], OUTSIDE_WINDOW)
    return out


def smooth_tail(lap, g, *, dr, steep: float = STEEP_DECAY) -> np.ndarray:
    """Remove the roll-off ringing of the full-contact stress ACF (paper, section 3.7).

    ``lap`` (the Laplacian of G on ``dr``, NaN allowed) is kept up to ``r_c`` and
    continued as ``lap(r_c) (dr / r_c)^-steep`` beyond. ``r_c`` is the last lag before the
    curve first falls faster than ``dr^-steep`` or stops being positive, searched from
    where G reaches a quarter of its largest value, i.e. in the roll-off, not among the
    sign changes of a sharp short-wavelength cutoff at ``lambda_s`` (which are physical:
    small H puts the stress at the smallest scales). A curve without such a lag is
    returned unchanged.
    """
    lap = np.asarray(lap, dtype=float)
    g = np.asarray(g, dtype=float)
    out = lap.copy()
    ok = np.flatnonzero(np.isfinite(lap) & np.isfinite(g) & (dr > 0))
    if ok.size < 2:
        return out
    after = ok[g[ok] >= 0.25 * np.max(g[ok])]
    for prev, k in zip(after[:-1], after[1:]):
        if not lap[prev] > 0:
            break  # already not positive where the search starts: leave it alone
        falls = lap[k] <= 0 or (np.log(lap[k] / lap[prev]) / np.log(dr[k] / dr[prev])
                                <= -steep)
        if falls:
            beyond = dr > dr[prev]
            out[beyond] = lap[prev] * (dr[beyond] / dr[prev]) ** -steep
            break
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
