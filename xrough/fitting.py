"""Fits of the height-difference ACF G and the gradient they imply.

Two models (:func:`fit_acf`, ``model=...``):

``"spectrum"`` (default)
    the self-affine model spectrum (eq. 35, sharp or smooth roll-off) through its exact G
    of eq. 9, ``G(dr) = (1/2pi) int dq q C(q) [1 - J0(q dr)]``; the gradient is eq. 26 of
    the fitted spectrum.  No model bias for surfaces with that spectrum.
``"eq36"``
    the paper's three-regime interpolation ``1/G = C_b/dr^2 + C_sa/dr^(2H) +
    1/sigma_h^2`` and its gradient (eq. 37/38); closed form and fast, but its crossovers
    have other exponents than G of eq. 35, which biases ``H`` by up to 0.1.

Representation of a fit (netCDF-legal, every variable with CF ``units``, each parameter
with ``<name>_std``, one standard deviation in the same units):

``sigma_h``
    rms height (``G -> sigma_h^2`` at large ``dr``), height unit; ``inf`` when the data
    show no plateau.
``G_sa``
    the self-affine asymptote at the reference lag ``dr_ref`` (a scalar coordinate), so
    that ``G -> G_sa (dr/dr_ref)^(2H)`` between the cutoffs (eq. 36: ``G_sa = dr_ref^(2H) /
    C_sa``).  ``C_sa`` has the units length^(2H-2), which CF cannot spell for
    non-integer exponents; ``G_sa`` is a plain length^2 and, because ``dr_ref`` (the power
    of ten nearest the geometric mean of the fitted lags) lies inside the fitted range,
    far less correlated with ``H`` than ``C_sa``.
``hurst``
    Hurst exponent ``H`` (dimensionless).
``lambda_r``
    roll-off wavelength ``2 pi / q_r``, lateral unit (eq. 36: from where G levels off).
``lambda_s``, ``C_r`` (spectrum)
    short-wavelength cutoff ``2 pi / q_s`` (lateral unit) and the plateau ``C(q -> 0)`` of
    the spectrum (units of G times lateral^2), with the flags ``lambda_s_resolved`` and
    ``lambda_r_resolved`` (0: the data do not resolve that cutoff; see :func:`fit_acf`)
    and the scalar coordinate ``lambda_0`` (the fixed lower cutoff; ``inf``: none).
``C_b`` (eq. 36)
    ballistic coefficient (dimensionless once ``dr`` and ``G`` are in the same length unit;
    ``gbar^2(0) = 4/C_b``, eq. 38a), ``>= 0``; 0 when the ballistic regime is unresolved.

plus ``reduced_chi2`` and ``n_bins``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pint
import xarray as xr
from scipy import optimize

from . import units as u
from ._kernels.hankel import acf_from_spectrum_kernel
from ._kernels.shape_factors import (
    ROLLOFFS,
    rolloff_crossover,
    rolloff_factor,
    self_affine_constant,
    self_affine_factor,
)
from ._kernels.spectral_models import SpectrumModel

__all__ = ["fit_acf", "model_acf", "gradient_from_fit"]

PARAMETERS = ("sigma_h", "G_sa", "hurst", "C_b", "lambda_r")
_FIXABLE = ("sigma_h", "hurst", "C_b")
_OUTPUTS = (*PARAMETERS, *(f"{p}_std" for p in PARAMETERS), "reduced_chi2", "n_bins")
#: Bounds of H in the fit (the model degenerates at H = 0 and H = 1).
_H_BOUNDS = (0.01, 0.99)
#: Hurst exponents tried for the starting point (linear least squares at each).
_H_GRID = np.linspace(0.02, 0.98, 49)
MODELS = ("spectrum", "eq36")
SPECTRUM_PARAMETERS = ("sigma_h", "G_sa", "hurst", "lambda_r", "lambda_s", "C_r")
_SPECTRUM_FIXABLE = ("hurst", "lambda_r", "lambda_s")
_SPECTRUM_OUTPUTS = (*SPECTRUM_PARAMETERS, *(f"{p}_std" for p in SPECTRUM_PARAMETERS),
                     "reduced_chi2", "n_bins", "lambda_r_resolved", "lambda_s_resolved")
_FLAGS = ("lambda_r_resolved", "lambda_s_resolved")
_SPECTRUM_EQ = ("eq. 9 of the {rolloff} model spectrum (eq. 35): G(dr) = (1/2pi) int dq q "
                "C(q) [1 - J0(q dr)], G -> G_sa (dr/dr_ref)^(2H) for lambda_s << dr << "
                "lambda_r")
_CUTOFFS = ("a cutoff counts as resolved when eps = (lambda_s/dr_min)^(2H) (eta = "
            "(dr_max/lambda_r)^(2-2H)) exceeds 2 standard deviations; otherwise it is "
            "removed and the rest refitted: lambda_s_resolved = 0 reports lambda_s as the "
            "upper bound dr_min (2 std(eps))^(1/(2H)); lambda_r_resolved = 0 reports "
            "lambda_r = sigma_h = C_r = inf (lambda_r = lambda_0 when given)")
#: Lower bound of ln(eta), ln(eps): a cutoff that changes G by less than e^-16 (1e-7) is
#: absent (it is then set to none, below _MIN_EFFECT).
_LN_FLOOR = -16.0
#: Cutoffs further than these factors beyond the lags (below for lambda_s, above for
#: lambda_r) are moved there and corrected to leading order.
_FAR_S, _FAR_R = 1e3, 1e5
#: Knots per decade of the power-law representation of C in eq. 9 (sharp: exact with 0).
_KNOTS = {"sharp": 0.0, "smooth": 40.0}
#: Quadrature of eq. 9 in the fit: relative error <= 5e-15 (sharp) and 5e-9 (smooth, set
#: by _KNOTS) against the defaults over 16 decades of dr, 0.02 <= H <= 0.99; half the cost.
_QUADRATURE = {"t_split": 32.0, "order": 10, "panels_per_decade": 4.0}
#: A cutoff is resolved when its eta (eps) exceeds this many standard deviations and
#: _MIN_EFFECT (a relative change of G below 1e-6 is no cutoff, even in exact data).
_SIGNIFICANCE, _MIN_EFFECT = 2.0, 1e-6
_EQ36 = "eq. 36: 1/G(dr) = C_b/dr^2 + C_sa/dr^(2H) + 1/sigma_h^2, C_sa = dr_ref^(2H)/G_sa"


# --------------------------------------------------------------------------------------
# numpy kernel: one fit
# --------------------------------------------------------------------------------------
def _terms(theta: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, ...]:
    """Ballistic, self-affine and plateau terms of ``1/g`` for ``theta = [ln a, H, b, s]``."""
    ln_a, H, b, s = theta
    sa = np.exp(ln_a - 2.0 * H * np.log(x))
    return b / x**2, sa, np.full_like(x, s)


def _start(x, y, w, free, theta):
    """Find a starting point: non-negative linear least squares in ``1/g`` on a grid of H.

    ``1/g`` is linear in ``(b, a, s)`` at fixed ``H``; rows are scaled by ``1/(y w)`` so that
    the residuals approximate the relative (log) residuals of the fit.
    """
    best, best_cost = None, np.inf
    grid = _H_GRID if free[1] else [theta[1]]
    scale = 1.0 / (y * w)
    for H in grid:
        rhs = y.copy()
        cols, names = [], []
        if free[2]:
            cols.append(x**-2.0)
            names.append(2)
        else:
            rhs -= theta[2] / x**2
        cols.append(x ** (-2.0 * H))
        names.append(0)
        if free[3]:
            cols.append(np.ones_like(x))
            names.append(3)
        else:
            rhs -= theta[3]
        A = np.column_stack(cols) * scale[:, None]
        coef, _ = optimize.nnls(A, rhs * scale)
        trial = theta.copy()
        trial[1] = H
        for k, c in zip(names, coef):
            trial[k] = c
        trial[0] = np.log(max(trial[0], 1e-3 * np.min(y)))  # a > 0 (it is fitted in log)
        cost = np.sum(_residuals(trial, x, y, w) ** 2)
        if cost < best_cost:
            best, best_cost = trial, cost
    return best


def _residuals(theta, x, y, w):
    with np.errstate(over="ignore"):
        total = sum(_terms(theta, x))
    return (np.log(y) - np.log(total)) / w  # ln g_model - ln g, with 1/g = y


def _jacobian(theta, x, w):
    tb, tsa, ts = _terms(theta, x)
    total = tb + tsa + ts
    # d ln(g_model) / d theta = - (d total / d theta) / total
    cols = [-tsa, 2.0 * np.log(x) * tsa, -1.0 / x**2, -np.ones_like(x)]
    return np.column_stack(cols) / (total * w)[:, None]


def _select(G, se, use, weighted, dr, unit, what):
    """Bins to fit (in the dr range, finite, with a standard error when weighted)."""
    sel = use & np.isfinite(G)
    if weighted:
        sel &= np.isfinite(se)
    bad = sel & ~(G > 0)
    if np.any(bad):
        raise ValueError(f"G must be positive to fit {what}, but G = {G[bad][0]:g} at "
                         f"dr = {dr[bad][0]:g} {unit}; restrict the range with "
                         "dr_min/dr_max")
    if weighted and np.any(sel & ~(se > 0)):
        k = np.flatnonzero(sel & ~(se > 0))[0]
        raise ValueError(f"standard_error must be positive where G is fitted, got "
                         f"{se[k]:g} at dr = {dr[k]:g} {unit} (or use weights=None)")
    return sel


def _check_count(n, p, what):
    if n < p + 1:
        raise ValueError(f"too few bins to fit {what}: {n} valid bin(s) in the dr range, "
                         f"but {p} free parameters need at least {p + 1} (widen "
                         "dr_min/dr_max or fix parameters)")


def _fit_kernel(G, se, *, dr, use, dr_ref, weighted, fixed, rolloff, unit):
    """Fit eq. 36 to one G (all lengths in one unit); returns the values of ``_OUTPUTS``."""
    G = np.asarray(G, dtype=float)
    se = np.asarray(se, dtype=float)
    sel = _select(G, se, use, weighted, dr, unit, "eq. 36")
    free = np.array([True, np.isnan(fixed[0]), np.isnan(fixed[1]), np.isnan(fixed[2])])
    n, p = int(sel.sum()), int(free.sum())
    _check_count(n, p, "eq. 36")
    x = dr[sel] / dr_ref
    G_ref = float(np.exp(np.mean(np.log(G[sel]))))
    y = G_ref / G[sel]  # 1/g with g = G/G_ref
    w = se[sel] / G[sel] if weighted else np.ones(n)  # standard error of ln G

    theta = np.array([0.0, fixed[0], fixed[1] * G_ref / dr_ref**2, fixed[2] * G_ref])
    theta = _start(x, y, w, free, np.where(free, 0.0, theta))
    lower = np.array([-np.inf, _H_BOUNDS[0], 0.0, 0.0])[free]
    upper = np.array([np.inf, _H_BOUNDS[1], np.inf, np.inf])[free]

    def fun(t):
        full = theta.copy()
        full[free] = t
        return _residuals(full, x, y, w)

    def jac(t):
        full = theta.copy()
        full[free] = t
        return _jacobian(full, x, w)[:, free]

    t0 = np.clip(theta[free], lower, upper)
    res = optimize.least_squares(fun, t0, jac=jac, bounds=(lower, upper), method="dogbox",
                                 x_scale="jac", ftol=1e-12, xtol=1e-12, gtol=1e-12,
                                 max_nfev=2000)
    theta[free] = res.x
    # a ballistic or plateau term that ends on its bound, or that nowhere reaches 1e-9 of
    # the fitted 1/g, is exactly zero
    active = np.zeros(4, dtype=bool)
    active[free] = res.active_mask != 0
    tb, tsa, ts = _terms(theta, x)
    for k, term in ((2, tb), (3, ts)):
        if free[k] and (active[k] or np.all(term < 1e-9 * (tb + tsa + ts))):
            theta[k] = 0.0
    dof = n - p
    chi2 = float(np.sum(_residuals(theta, x, y, w) ** 2)) / dof
    J = _jacobian(theta, x, w)[:, free]
    cov_free = np.linalg.pinv(J.T @ J)
    # unweighted: the residual scatter sets the error scale; weighted: the standard errors
    # do, inflated when the model does not describe the data to within them (chi2 > 1)
    cov_free *= chi2 if not weighted else max(1.0, chi2)
    cov = np.zeros((4, 4))
    cov[np.ix_(free, free)] = cov_free
    var = np.diag(cov)

    ln_a, H, b, s = theta
    G_sa = G_ref * np.exp(-ln_a)
    C_b = b * dr_ref**2 / G_ref
    if s > 0:
        sigma_h = np.sqrt(G_ref / s)
        sigma_std = sigma_h * np.sqrt(var[3]) / (2.0 * s)
        # lambda_r = 2 pi dr_x / kappa(H), dr_x = dr_ref (a/s)^(1/(2H))
        kappa = rolloff_crossover(H, rolloff=rolloff)
        lam = 2.0 * np.pi * dr_ref * np.exp((ln_a - np.log(s)) / (2.0 * H)) / kappa
        dH = 1e-6
        dlnk = (np.log(rolloff_crossover(min(H + dH, 0.999999), rolloff=rolloff))
                - np.log(rolloff_crossover(max(H - dH, 1e-6), rolloff=rolloff))) / (2 * dH)
        grad = np.array([1.0 / (2 * H), -(ln_a - np.log(s)) / (2 * H * H) - dlnk, 0.0,
                         -1.0 / (2 * H * s)])
        lam_std = lam * np.sqrt(max(grad @ cov @ grad, 0.0))
    else:
        sigma_h, sigma_std, lam, lam_std = np.inf, np.nan, np.inf, np.nan
    values = [sigma_h, G_sa, H, C_b, lam]
    stds = [sigma_std, G_sa * np.sqrt(var[0]), np.sqrt(var[1]),
            np.sqrt(var[2]) * dr_ref**2 / G_ref, lam_std]
    return np.array([*values, *stds, chi2, n], dtype=float)


# --------------------------------------------------------------------------------------
# numpy kernel: the exact G of the model spectrum and its fit
# --------------------------------------------------------------------------------------
def _rolloff_coefficient(H: float, rolloff: str) -> float:
    """Return ``A = int_0^inf x^3 [C(x)/C_r - x^(-2-2H)] dx`` (``q_r = 1``), roll-off term.

    At fixed self-affine amplitude, ``G`` moves by ``A c q_r^(2-2H) dr^2 / (8 pi)`` when a
    roll-off at ``q_r << 1/dr`` is switched on (``c = C_r q_r^(2+2H)``).
    """
    return 0.25 - 1.0 / (2.0 - 2.0 * H) if rolloff == "sharp" else -1.0 / (2 * H * (1 - H))


def _acf_shape(x, H, lam_r, lam_s, lam_0, rolloff):
    """G (eq. 9) of the model spectrum whose self-affine asymptote is ``x^(2H)``.

    All lengths in one unit; ``lam_r = inf`` (no roll-off; only without ``lam_0``),
    ``lam_s = 0`` (no short cutoff) and ``lam_0 = inf`` (no lower cutoff) are allowed.
    A cutoff far beyond the lags (``_FAR_S``, ``_FAR_R``) is evaluated nearer and moved to its
    value with the leading term, which is linear in ``q_s^(-2H)`` (a constant shift of G)
    resp. ``q_r^(2-2H)`` (a term in ``dr^2``); the next terms are smaller by
    ``(q_s dr)^(-3/2)`` resp. ``(q_r dr)^(2H)`` or ``(q_r dr)^2``.
    """
    kernel_I = float(self_affine_constant(H))
    lo, hi = float(np.min(x)), float(np.max(x))
    lr = min(lam_r, _FAR_R * hi) if np.isinf(lam_0) else min(lam_r, lam_0)
    ls = min(max(lam_s, lo / _FAR_S), lr / (1.0 + 1e-6))
    q_r, q_s = 2 * np.pi / lr, 2 * np.pi / ls
    q_0 = 0.0 if np.isinf(lam_0) else 2 * np.pi / lam_0
    model = SpectrumModel(hurst=H, q_r=q_r, q_s=q_s, q_0=q_0, rolloff=rolloff,
                          C_r=2 * np.pi / (kernel_I * q_r ** (2 + 2 * H)))
    G = acf_from_spectrum_kernel(x, model, model.breakpoints,
                                 knots_per_decade=_KNOTS[rolloff], **_QUADRATURE)
    if lam_s < ls:
        G = G + ((ls / (2 * np.pi)) ** (2 * H) - (lam_s / (2 * np.pi)) ** (2 * H)) / (
            2 * H * kernel_I)
    if lam_r > lr and np.isinf(lam_0):
        G = G + _rolloff_coefficient(H, rolloff) * x**2 / (4 * kernel_I) * (
            (2 * np.pi / lam_r) ** (2 - 2 * H) - q_r ** (2 - 2 * H))
    return G


def _spectrum_moments(c, H, q_r, q_s, q_0, rolloff):
    """``sigma_h^2`` and ``C_r`` of the model with ``c = C_r q_r^(2+2H)`` (``q_r`` may be 0)."""
    if q_r == 0.0:
        return np.inf, np.inf
    C_r = c / q_r ** (2 + 2 * H)
    s0, ss = (q_0 / q_r) ** 2, (q_s / q_r) ** 2
    if rolloff == "sharp":
        m0 = (1 - s0) / 2 + (1 - (q_r / q_s) ** (2 * H)) / (2 * H)
    else:
        m0 = ((1 + s0) ** -H - (1 + ss) ** -H) / (2 * H)
    return C_r * q_r**2 * m0 / (2 * np.pi), C_r


def _em1x(v):
    """``exp(v) - 1 - v`` without cancellation."""
    v = np.asarray(v, dtype=float)
    small = np.abs(v) < 0.1
    vs = np.where(small, v, 0.0)
    series, term = np.zeros_like(vs), vs.copy()
    for k in range(2, 14):
        term = term * vs / k
        series += term
    return np.where(small, series, np.expm1(np.where(small, 0.0, v)) - v)


def _gbar2_shape(dr, c, H, q_r, q_s, q_0, rolloff):
    """Eq. 26, ``(1/2pi) int_0^{2pi/dr} dq q^3 C(q)``, of the model, in closed form."""
    qc = np.minimum(2 * np.pi / dr, q_s)
    e = 2.0 - 2.0 * H
    if q_r == 0.0:  # pure power law c q^(-2-2H) (no lower cutoff)
        return c * qc**e / e / (2 * np.pi)
    if rolloff == "sharp":
        a = np.clip(qc, q_0, q_r)
        b = np.clip(qc, q_r, q_s)
        flat = (a**4 - q_0**4) / (4 * q_r ** (2 + 2 * H))
        return c * (flat + (b**e - q_r**e) / e) / (2 * np.pi)

    # smooth: int q^3 [1 + (q/q_r)^2]^-(1+H) dq = (q_r^4 / 2) [Phi(u)], u = (q/q_r)^2,
    # Phi(u) = [(1+u)^(1-H) - 1]/(1-H) + [(1+u)^-H - 1]/H, the linear parts cancelled
    def phi(v):
        L = np.log1p(v)
        return _em1x((1 - H) * L) / (1 - H) + _em1x(-H * L) / H

    u = (np.maximum(qc, q_0) / q_r) ** 2
    return c * q_r**e / 2 * (phi(u) - phi((q_0 / q_r) ** 2)) / (2 * np.pi)


def _spectrum_start(G, se, *, dr, use, dr_ref, weighted, fixed, rolloff, unit, G_ref, x_lo,
                    x_hi):
    """Start ``[ln(G_sa/G_ref), H, ln eta, ln eps]`` from the fit of eq. 36."""
    try:
        out = _fit_kernel(G, se, dr=dr, use=use, dr_ref=dr_ref, weighted=weighted,
                          fixed=np.array([fixed[0], np.nan, np.nan]), rolloff=rolloff,
                          unit=unit)
    except ValueError:  # too few bins for eq. 36 (the spectrum has fixed cutoffs)
        H = 0.5 if np.isnan(fixed[0]) else fixed[0]
        out = [np.nan, G_ref, H, 0.0, np.inf]
    _, G_sa, H, C_b, lam = out[:5]
    H = float(np.clip(H, 0.05, 0.95))
    ln_eta = (2 - 2 * H) * np.log(x_hi * dr_ref / lam) if np.isfinite(lam) else -5.0
    ln_eps = -5.0
    if C_b > 0:  # gbar^2(0) = 4/C_b = (K/I) q_s^(2-2H)/(2-2H) for q_s >> q_r
        K = G_sa / dr_ref ** (2 * H)
        q_s = (4.0 / C_b * self_affine_constant(H) * (2 - 2 * H) / K) ** (1 / (2 - 2 * H))
        ln_eps = 2 * H * np.log(2 * np.pi / q_s / dr_ref / x_lo)
    return np.array([np.log(G_sa / G_ref), H, ln_eta, ln_eps])


def _gradients(physical, pvec, values, free, sd, grad):
    """Fill ``grad`` with d physical / d pvec by central differences (one-sided at 0)."""
    for k in np.flatnonzero(free):
        h = 1e-6 if k < 2 else 1e-5 * pvec[k]
        if h > 0:
            hi_p, lo_p = pvec.copy(), pvec.copy()
            hi_p[k] += h
            lo_p[k] -= h
            grad[:, k] = (physical(hi_p) - physical(lo_p)) / (2 * h)
        elif sd[k] > 0:  # a cutoff set to none: one-sided
            h = 1e-4 * sd[k]
            hi_p = pvec.copy()
            hi_p[k] += h
            grad[:, k] = (physical(hi_p) - values) / h


def _fit_spectrum_kernel(G, se, *, dr, use, dr_ref, weighted, fixed, rolloff, lambda_0, unit):
    """Fit the model spectrum to one G (one length unit); the values of ``_SPECTRUM_OUTPUTS``.

    Optimiser parameters ``theta = [ln(G_sa/G_ref), H, ln eta, ln eps]`` with
    ``eta = (dr_max/lambda_r)^(2-2H)`` and ``eps = (lambda_s/dr_min)^(2H)``: each of
    ``eta``, ``eps`` is, to leading order, the relative change of G at the end of the fitted
    range that its cutoff causes, linear in it once the cutoff lies outside the lags, and 0
    when there is no cutoff.  ``fixed = [H, lambda_r, lambda_s]`` (NaN: free).
    """
    G = np.asarray(G, dtype=float)
    se = np.asarray(se, dtype=float)
    sel = _select(G, se, use, weighted, dr, unit, "the model spectrum")
    free = np.array([True, np.isnan(fixed[0]), np.isnan(fixed[1]), np.isnan(fixed[2])])
    n, p = int(sel.sum()), int(free.sum())
    _check_count(n, p, "the model spectrum")
    x = dr[sel] / dr_ref
    G_ref = float(np.exp(np.mean(np.log(G[sel]))))
    ly = np.log(G[sel] / G_ref)
    w = se[sel] / G[sel] if weighted else np.ones(n)  # standard error of ln G
    x_lo, x_hi = float(x.min()), float(x.max())
    lam_0 = lambda_0 / dr_ref
    fix_r, fix_s = fixed[1] / dr_ref, fixed[2] / dr_ref

    def cutoffs(t):
        with np.errstate(over="ignore", divide="ignore"):
            lr = x_hi * np.exp(-t[2] / (2 - 2 * t[1])) if free[2] else fix_r
            ls = x_lo * np.exp(t[3] / (2 * t[1])) if free[3] else fix_s
        return min(lr, lam_0), ls

    def residuals(t):
        lr, ls = cutoffs(t)
        return (t[0] + np.log(_acf_shape(x, t[1], lr, ls, lam_0, rolloff)) - ly) / w

    theta = _spectrum_start(G, se, dr=dr, use=use, dr_ref=dr_ref, weighted=weighted,
                            fixed=fixed, rolloff=rolloff, unit=unit, G_ref=G_ref,
                            x_lo=x_lo, x_hi=x_hi)
    if not free[1]:
        theta[1] = fixed[0]
    span = 2 * np.log(10 * x_hi / x_lo)
    lower = np.array([-np.inf, _H_BOUNDS[0], _LN_FLOOR, _LN_FLOOR])
    upper = np.array([np.inf, _H_BOUNDS[1], span, span])
    theta = np.clip(theta, lower + 1e-3, upper - 1e-3)
    steps = np.array([0.0, 1e-5, 1e-5, 1e-5])

    def optimise(theta, active):
        cache = {}

        def full(t):
            out = theta.copy()
            out[active] = t
            return out

        def fun(t):
            cache["t"], cache["r"] = t.copy(), residuals(full(t))
            return cache["r"]

        def jac(t):
            r0 = cache["r"] if np.array_equal(cache.get("t"), t) else residuals(full(t))
            cols = []
            for k in np.flatnonzero(active):
                if k == 0:
                    cols.append(1.0 / w)
                    continue
                h = steps[k] if full(t)[k] + steps[k] <= upper[k] else -steps[k]
                tt = full(t)
                tt[k] += h
                cols.append((residuals(tt) - r0) / h)
            return np.column_stack(cols)

        res = optimize.least_squares(fun, theta[active], jac=jac,
                                     bounds=(lower[active], upper[active]), method="trf",
                                     x_scale="jac", ftol=1e-10, xtol=1e-10, gtol=1e-10,
                                     max_nfev=200)
        return full(res.x)

    def linear_jacobian(t):
        """Jacobian in ``[ln(G_sa/G_ref), H, eta, eps]`` over the free parameters."""
        r0 = residuals(t)
        cols = []
        for k in np.flatnonzero(free):
            tt = t.copy()
            if k == 0:
                cols.append(1.0 / w)
                continue
            if k == 1:
                h = 1e-6 if t[1] + 1e-6 <= upper[1] else -1e-6
                tt[1] += h
            else:
                v = np.exp(t[k])
                h = 1e-6 * max(v, 1e-3)
                tt[k] = np.log(v + h)
            cols.append((residuals(tt) - r0) / h)
        return np.column_stack(cols), r0

    dof = n - p
    index = {k: i for i, k in enumerate(np.flatnonzero(free))}
    active = free.copy()
    moved = True
    for _ in range(3):  # refit after dropping cutoffs that the data do not resolve
        if moved:
            theta = optimise(theta, active)
        J, r = linear_jacobian(theta)
        chi2 = float(np.sum(r**2)) / dof
        # unweighted: the residual scatter sets the error scale; weighted: the standard
        # errors do, inflated when the model does not describe the data within them
        cov_free = np.linalg.pinv(J.T @ J) * (max(1.0, chi2) if weighted else chi2)
        moved = False
        for k in (2, 3):
            if not active[k] or (k == 2 and np.isfinite(lam_0)):
                continue
            v, s = np.exp(theta[k]), np.sqrt(max(cov_free[index[k], index[k]], 0.0))
            if not v > max(_SIGNIFICANCE * s, _MIN_EFFECT):
                moved |= theta[k] > _LN_FLOOR + 1e-9
                theta[k], active[k] = _LN_FLOOR, False
        if not moved:
            break

    cov = np.zeros((4, 4))
    cov[np.ix_(free, free)] = cov_free
    lr_fit, _ = cutoffs(theta)
    resolved_r = bool(active[2] and lr_fit < lam_0 * (1 - 1e-9)) or not free[2]
    resolved_s = bool(active[3]) or not free[3]
    pvec = np.array([theta[0], theta[1],
                     np.exp(theta[2]) if resolved_r else 0.0,
                     np.exp(theta[3]) if resolved_s else 0.0])
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))

    def physical(pv):
        """``[ln sigma_h, ln G_sa, H, ln lambda_r, ln lambda_s, ln C_r]`` (lateral unit)."""
        a, H, eta, eps = pv
        with np.errstate(divide="ignore", over="ignore"):
            lr, ls = cutoffs([a, H, np.log(eta), np.log(eps)])
            lr, ls = lr * dr_ref, ls * dr_ref
            c = 2 * np.pi * G_ref * np.exp(a) / dr_ref ** (2 * H) / self_affine_constant(H)
            q_0 = 0.0 if np.isinf(lambda_0) else 2 * np.pi / lambda_0
            sigma2, C_r = _spectrum_moments(c, H, 2 * np.pi / lr, 2 * np.pi / ls, q_0,
                                            rolloff)
            return np.array([0.5 * np.log(sigma2), a + np.log(G_ref), H, np.log(lr),
                             np.log(ls), np.log(C_r)])

    values = physical(pvec)
    grad = np.zeros((6, 4))
    with np.errstate(invalid="ignore"):  # inf - inf where there is no roll-off: NaN
        _gradients(physical, pvec, values, free, sd, grad)
    with np.errstate(invalid="ignore"):
        rel = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", grad, cov, grad), 0.0))
    out = np.exp(values)
    out[2] = values[2]
    with np.errstate(invalid="ignore"):
        std = np.where(np.isfinite(out), out * rel, np.nan)
    std[2] = sd[1]
    if free[2] and not resolved_r:
        std[3] = np.nan
    if free[3] and not resolved_s:  # 2-sigma upper bound of lambda_s (< lambda_r)
        with np.errstate(over="ignore"):
            bound = x_lo * dr_ref * (_SIGNIFICANCE * sd[3]) ** (1 / (2 * theta[1]))
        out[4], std[4] = min(bound, out[3]), np.nan
    if free[2] and not resolved_r:
        out[3] = lambda_0
    if not free[2]:
        out[3], std[3] = fixed[1], 0.0
    if not free[3]:
        out[4], std[4] = fixed[2], 0.0
    return np.array([*out, *std, chi2, n, resolved_r, resolved_s], dtype=float)


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------
def _lateral_unit(da: xr.DataArray, dim: str = "dr") -> pint.Unit:
    if dim not in da.dims or dim not in da.coords:
        raise ValueError(f"G must have a dimension coordinate {dim!r} (lag distance), got "
                         f"dims {da.dims}")
    return u.as_length_unit(u.units_of(da[dim], what=f"coordinate {dim!r}"),
                            what=f"coordinate {dim!r}")


def _area_unit(da: xr.DataArray, what: str) -> pint.Unit:
    unit = u.units_of(da, what=what)
    if unit.dimensionality != (u.ureg.meter**2).dimensionality:
        raise ValueError(f"{what} must be in length^2 (e.g. 'nm2'), but its units are "
                         f"{u.format_units(unit)!r}")
    return unit


def _fixed_hurst(value) -> float:
    H = float(value)
    if not _H_BOUNDS[0] <= H <= _H_BOUNDS[1]:
        raise ValueError(f"fix: hurst must lie in [{_H_BOUNDS[0]}, {_H_BOUNDS[1]}], got "
                         f"{value!r}")
    return H


def _fixed_values(fix, lateral: pint.Unit, height: pint.Unit) -> tuple[np.ndarray, str]:
    """``[H, C_b, 1/sigma_h^2]`` (NaN where free; lengths in ``lateral``) and a description."""
    fix = dict(fix or {})
    unknown = sorted(set(fix) - set(_FIXABLE))
    if unknown:
        raise ValueError(f"fix: cannot fix {unknown} with model='eq36'; fixable parameters "
                         f"are {_FIXABLE}")
    out = np.full(3, np.nan)
    text = []
    if "hurst" in fix:
        out[0] = _fixed_hurst(fix["hurst"])
        text.append(f"hurst={out[0]:g}")
    if "C_b" in fix:
        q = u.quantity(fix["C_b"], default_units="", what="fix['C_b']")
        if not q.dimensionless or not (np.isfinite(q.to("").magnitude)
                                       and q.to("").magnitude >= 0):
            raise ValueError(f"fix: C_b must be a dimensionless number >= 0, got "
                             f"{fix['C_b']!r}")
        out[1] = float(q.to("").magnitude)
        text.append(f"C_b={out[1]:g}")
    if "sigma_h" in fix:
        value = fix["sigma_h"]
        if isinstance(value, (int, float, np.integer, np.floating)) and np.isinf(value) \
                and value > 0:
            out[2] = 0.0
            text.append("sigma_h=inf")
        else:
            sig = u.length_in(value, height, what="fix['sigma_h']")
            out[2] = 1.0 / (sig * u.conversion_factor(height, lateral)) ** 2
            text.append(f"sigma_h={sig:g} {u.format_units(height)}")
    return out, ", ".join(text) or "none"


def _reference_lag(dr: np.ndarray, lateral: pint.Unit) -> float:
    """Return the power of ten (decided in metres) nearest the geometric mean of ``dr``."""
    to_m = u.conversion_factor(lateral, "m")
    mean_m = float(np.exp(np.mean(np.log(dr)))) * to_m
    return float(f"{10.0 ** np.round(np.log10(mean_m)) / to_m:.14g}")


def _variable(da: xr.DataArray, units: str, long_name: str) -> xr.DataArray:
    return da.assign_attrs({"units": units, "long_name": long_name})


def _params_units(params: xr.Dataset) -> tuple[pint.Unit, pint.Unit, str]:
    """Lateral and height units and model of a fit, checking that it has what it needs."""
    if not isinstance(params, xr.Dataset):
        raise TypeError(f"params must be the xarray.Dataset of fit_acf, got "
                        f"{type(params).__name__}")
    model = params.attrs.get("model", "eq36")
    if model not in MODELS:
        raise ValueError(f"params.attrs['model'] must be one of {MODELS}, got {model!r}")
    needed = PARAMETERS if model == "eq36" else (*SPECTRUM_PARAMETERS, *_FLAGS)
    missing = [v for v in (*needed, "dr_ref") if v not in params.variables]
    if missing:
        raise ValueError(f"params lacks {missing}; pass the Dataset returned by fit_acf")
    lateral = u.as_length_unit(u.units_of(params["lambda_r"], what="lambda_r"),
                               what="lambda_r")
    height = u.as_length_unit(u.units_of(params["sigma_h"], what="sigma_h"), what="sigma_h")
    return lateral, height, model


def _fixed_spectrum(fix, lateral: pint.Unit, lambda_0: float) -> tuple[np.ndarray, str]:
    """``[H, lambda_r, lambda_s]`` (NaN where free; lengths in ``lateral``), description."""
    fix = dict(fix or {})
    unknown = sorted(set(fix) - set(_SPECTRUM_FIXABLE))
    if unknown:
        raise ValueError(f"fix: cannot fix {unknown} with model='spectrum'; fixable "
                         f"parameters are {_SPECTRUM_FIXABLE}")
    out = np.full(3, np.nan)
    text = []
    lat = u.format_units(lateral)
    if "hurst" in fix:
        out[0] = _fixed_hurst(fix["hurst"])
        text.append(f"hurst={out[0]:g}")
    for k, name, limit in ((1, "lambda_r", np.inf), (2, "lambda_s", 0.0)):
        if name not in fix:
            continue
        value = fix[name]
        if isinstance(value, (int, float, np.integer, np.floating)) and value == limit:
            out[k] = limit
            text.append(f"{name}={limit:g}")
        else:
            out[k] = u.length_in(value, lateral, what=f"fix[{name!r}]")
            text.append(f"{name}={out[k]:g} {lat}")
    if out[1] > lambda_0:
        raise ValueError(f"fix: lambda_r must not exceed lambda_0 = {lambda_0:g} {lat}")
    if not np.isnan(out[1]) and out[2] >= out[1]:
        raise ValueError("fix: lambda_s must be shorter than lambda_r")
    return out, ", ".join(text) or "none"


def _lags(dr: Any, lateral: pint.Unit, params: xr.Dataset) -> np.ndarray:
    if dr is None:
        lo, hi = params.attrs.get("dr_min"), params.attrs.get("dr_max")
        if lo is None or hi is None:
            raise ValueError("pass dr (params has no dr_min/dr_max attributes)")
        f = u.conversion_factor(u.parse_units(params.attrs.get("dr_units", lateral)),
                                lateral)
        return np.geomspace(lo * f, hi * f, 50)
    if isinstance(dr, xr.DataArray):
        unit = dr.attrs.get("units")
        f = 1.0 if unit is None else u.conversion_factor(u.as_length_unit(unit, what="dr"),
                                                        lateral)
        values = np.asarray(dr.values, dtype=float) * f
    elif isinstance(dr, (pint.Quantity, str)):
        q = u.quantity(dr, default_units=lateral, what="dr")
        if not q.check("[length]"):
            raise ValueError(f"dr must be a length, got {dr!r}")
        values = np.asarray(q.to(lateral).magnitude, dtype=float)
    else:
        values = np.asarray(dr, dtype=float)
    values = np.atleast_1d(values)
    if values.ndim != 1 or not np.all(np.isfinite(values)) or np.any(values <= 0):
        raise ValueError("dr must be a 1-D array of finite positive distances")
    return values


def _lag_coord(values: np.ndarray, lateral: pint.Unit) -> dict:
    return {"dr": ("dr", values, {"units": u.format_units(lateral),
                                  "long_name": "lag distance"})}


def _in_lateral(params: xr.Dataset, lateral: pint.Unit, height: pint.Unit) -> dict:
    """``sigma_h``, ``G_sa``, ``dr_ref``, ``lambda_r`` in the lateral unit, ``hurst``, ``C_b``.

    (``C_b`` is None for the spectrum model.)
    """
    h2l = u.conversion_factor(height, lateral)
    g_unit = u.units_of(params["G_sa"], what="G_sa")
    ref_unit = u.as_length_unit(u.units_of(params["dr_ref"], what="dr_ref"), what="dr_ref")
    return {
        "sigma_h": params["sigma_h"] * h2l,
        "G_sa": params["G_sa"] * u.conversion_factor(g_unit, lateral**2),
        "dr_ref": float(params["dr_ref"]) * u.conversion_factor(ref_unit, lateral),
        "lambda_r": params["lambda_r"],
        "hurst": params["hurst"],
        "C_b": params.get("C_b"),
    }


# --------------------------------------------------------------------------------------
# public functions
# --------------------------------------------------------------------------------------
def fit_acf(
    G: xr.DataArray,
    *,
    model: str = "spectrum",
    dr_min: Any = None,
    dr_max: Any = None,
    weights: str | None = "standard_error",
    fix: dict | None = None,
    rolloff: str = "sharp",
    lambda_0: Any = None,
) -> xr.Dataset:
    r"""Fit the height-difference ACF with the model spectrum (eq. 9 of eq. 35) or eq. 36.

    ``model="spectrum"`` (default) fits the parameters of the self-affine model spectrum,
    ``q = 2 pi / lambda``,

    .. math::

        C(q) = C_r \;\; (q_0 \le q < q_r), \qquad
        C(q) = C_r\, (q/q_r)^{-2(1+H)} \;\; (q_r \le q < q_s)

    (``rolloff="sharp"``, eq. 35) or ``C = C_r [1 + (q/q_r)^2]^-(1+H)`` on ``[q_0, q_s)``
    (``"smooth"``), through its exact G of eq. 9,

    .. math::

        G(\Delta r) = \frac{1}{2\pi} \int_0^\infty dq\, q\, C(q) [1 - J_0(q \Delta r)].

    ``model="eq36"`` fits the paper's three-regime closed form

    .. math::

        \frac{1}{G(\Delta r)} = \frac{C_b}{\Delta r^2} + \frac{C_{sa}}{\Delta r^{2H}}
                                + \frac{1}{\sigma_h^2}

    with ``C_b >= 0``, ``1/sigma_h^2 >= 0`` (``sigma_h = inf``: no plateau in the data),
    ``C_sa > 0``.  Both keep ``0.01 <= H <= 0.99``.

    Parameters
    ----------
    G : xarray.DataArray with dims (..., "dr")
        Height-difference ACF in length^2 on a lag coordinate ``dr`` in length (``units``
        required on both), e.g. from :func:`xrough.height_difference_acf` or
        :func:`xrough.acf_from_spectrum`.  Extra dims (e.g. ``scan``) are fitted one by
        one; NaN bins are skipped.
    model : {'spectrum', 'eq36'}
        The model spectrum (default: no model bias for self-affine surfaces with a
        roll-off; see Notes, *Which model*) or eq. 36 (closed form, 100 times faster,
        biased by up to 0.1 in ``H`` on such surfaces).
    dr_min, dr_max : float, str or pint.Quantity, optional
        Range of lags to fit (plain numbers in the unit of ``dr``); default: all.
    weights : {'standard_error', None}
        Weight each bin by the coordinate ``standard_error`` of ``G`` (in length^2) when it
        exists; unweighted otherwise, or with None.  ``attrs["weighting"]`` says which.
    fix : dict, optional
        Parameters held fixed (lengths as plain numbers in the unit of ``dr``).
        ``'spectrum'``: ``"hurst"``, ``"lambda_r"`` (``np.inf``: no roll-off),
        ``"lambda_s"`` (``0``: no short-wavelength cutoff).  ``'eq36'``: ``"hurst"``,
        ``"C_b"`` (dimensionless, e.g. 0 when the ballistic regime is unresolved) and
        ``"sigma_h"`` (plain numbers in the height unit of ``G``; ``np.inf`` for no
        plateau).
    rolloff : {'sharp', 'smooth'}
        Shape of the model spectrum.  For eq. 36, the shape assumed to convert the
        crossover lag into ``lambda_r``; both models keep it for
        :func:`gradient_from_fit`.
    lambda_0 : float, str or pint.Quantity, optional
        ``'spectrum'`` only: long-wavelength cutoff ``2 pi / q_0`` of the model (e.g. the
        size of a periodic map, whose G knows no longer wavelengths); default none.

    Returns
    -------
    xarray.Dataset
        On the extra dims of ``G``; each parameter with ``<name>_std`` (one standard
        deviation, same units), plus ``reduced_chi2`` and ``n_bins``, and the scalar
        coordinate ``dr_ref`` (the lag at which ``G_sa`` is given).

        * ``'spectrum'``: ``sigma_h`` (height unit), ``G_sa`` (units of ``G``), ``hurst``
          ("1"), ``lambda_r``, ``lambda_s`` (lateral unit), ``C_r`` (units of ``G`` times
          lateral^2), the flags ``lambda_r_resolved`` and ``lambda_s_resolved`` (1 or 0,
          see Notes) and the scalar coordinate ``lambda_0`` (``inf``: none).
        * ``'eq36'``: ``sigma_h``, ``G_sa``, ``hurst``, ``C_b`` ("1"), ``lambda_r``.

        Attrs: ``model``, ``equation``, ``weighting``, ``residuals``,
        ``dr_min``/``dr_max``/``dr_units`` (range of bins used), ``fixed``, ``rolloff``,
        ``uncertainty``, ``source``, ``lambda_r_definition`` (eq36) or ``cutoffs``
        (spectrum) and, for a single fit, ``reduced_chi2`` and (spectrum)
        ``ballistic_regime`` and ``plateau`` ("resolved" or why not).

    Raises
    ------
    ValueError
        Missing or non-length units, no ``dr`` coordinate, non-positive ``G`` or standard
        error in the range, fewer valid bins than free parameters + 1, invalid ``model``,
        ``fix``, ``weights``, ``rolloff`` or ``lambda_0``.

    See Also
    --------
    model_acf : the fitted curve G(dr).
    gradient_from_fit : the scale-dependent rms gradient (eq. 26 of the fitted spectrum,
        or eq. 37/38).

    Notes
    -----
    *Residuals.*  Both models minimise ``sum_i [(ln G_model(dr_i) - ln G_i) / s_i]^2``
    with ``s_i = standard_error_i / G_i`` (the standard error of ``ln G``), or ``s_i = 1``
    unweighted: G spans decades and its errors are relative, so log residuals give every
    decade its weight and keep a large plateau from swamping the small-``dr`` bins.

    *Uncertainties.*  One standard deviation from the covariance ``(J^T J)^-1`` of the
    weighted residuals, multiplied by ``max(1, reduced chi^2)`` (by the reduced chi^2
    alone when unweighted), and propagated to derived quantities to first order.  The
    bins of a G measured on one surface are correlated (they share the same large-scale
    heights), so for such data the uncertainties are a lower bound; they are honest for
    independent errors.  On synthetic Gaussian surfaces (``L = 8 lambda_r``) with the
    standard errors of :func:`xrough.height_difference_acf`, ``hurst_std`` was 1.4 to 1.6
    times the scatter of ``H`` between realisations at 512^2 (``lambda_r`` = 64 pixels)
    but 0.5 to 0.8 times at 1024^2 (128 pixels): finer maps shrink the standard errors of
    the bins, not the scatter of the few modes near ``q_r``.

    *Spectrum model.*  ``G_sa`` is the self-affine asymptote at ``dr_ref``,
    ``G -> G_sa (dr/dr_ref)^(2H)`` for ``lambda_s << dr << lambda_r``, i.e.
    ``G_sa = C_r q_r^(2+2H) I(H) dr_ref^(2H) / 2pi`` with
    ``I(H) = 2^(-1-2H) Gamma(1-H) / (H Gamma(1+H))``; ``sigma_h^2`` and ``C_r`` follow
    from the moments of the fitted spectrum.  G is eq. 9 evaluated by
    :func:`xrough._kernels.hankel.acf_from_spectrum_kernel` (exact for the sharp shape,
    to about 1e-8 for the smooth one).  The optimiser (``scipy.optimize.least_squares``,
    trust-region reflective, about 50 evaluations of eq. 9, 0.1 to 0.5 s per curve)
    works on ``ln G_sa``, ``H``, ``ln eta`` and ``ln eps`` with
    ``eta = (dr_max/lambda_r)^(2-2H)`` and ``eps = (lambda_s/dr_min)^(2H)``
    (``dr_min``, ``dr_max``: the fitted range), started from the fit of eq. 36.  To
    leading order ``eps`` (``eta``) is the relative change of G at the short (long) end
    of the range that its cutoff causes: once the cutoff lies beyond the lags, G depends
    on it only through ``eps`` (a constant shift of G, ``-G_sa (lambda_s/2 pi
    dr_ref)^(2H) / (2H I)``) or ``eta`` (a term in ``dr^2``), linearly, and ``eps = 0``
    (``eta = 0``) is the spectrum without that cutoff.

    *Unresolved cutoffs.*  A cutoff is resolved when its ``eps`` (``eta``) exceeds twice
    its standard deviation.  Otherwise the data cannot tell it from no cutoff: it is set
    to none (``lambda_s = 0``, ``lambda_r = inf``) and the rest refitted.  Then
    ``lambda_s_resolved = 0`` and ``lambda_s`` is the upper bound
    ``dr_min (2 std(eps))^(1/(2H))`` (about 98 % one-sided) with NaN std: no ballistic
    regime in the data; and ``lambda_r_resolved = 0`` with ``lambda_r = sigma_h = C_r =
    inf`` (NaN std): no plateau.  With ``lambda_0`` the roll-off cannot move beyond
    ``lambda_0``; if it ends there, ``lambda_r = lambda_0`` (NaN std,
    ``lambda_r_resolved = 0``) and ``sigma_h`` is that of the truncated power law.  The
    standard deviations of the other parameters include the freedom of the unresolved
    cutoff (its column of ``J``), e.g. a ``lambda_s`` just below the data.

    *Which model.*  Eq. 36 approaches the self-affine law as ``dr^(2H-2)`` from the
    ballistic side and as ``dr^(2H)`` from the plateau side, whereas G of eq. 35 does so
    as ``(q_s dr)^(-2H)`` and ``(q_r dr)^(2-2H)``: the crossovers match in form only at
    ``H = 1/2``, and eq. 36 levels off more slowly than G.  Its parameters are those of
    the best interpolation, not of the surface: on the exact G of eq. 35
    (``lambda_r/lambda_s = 1e6``, fitted from ``lambda_s/100`` to ``100 lambda_r``) ``H``
    comes out 0.321, 0.501, 0.764 for ``H = 0.3, 0.5, 0.8``, ``sigma_h`` 9, 6, 3 % high and
    ``lambda_r`` at 0.75, 1.02, 1.25 of its value; with only 1.8 decades of self-affine
    scaling (``lambda_r/lambda_s = 64``) ``H`` is off by up to 0.1 and ``lambda_r`` by up
    to 40 %, and the standard deviations do not include this bias.  The spectrum model
    returns the parameters of the exact G to 1e-9, and on synthetic Gaussian surfaces
    (512^2, ``L = 8 lambda_r``, ``lambda_s`` = 4 pixels, 20 seeds) ``H`` without bias
    (mean error <= 0.003; scatter 0.009 to 0.026 between realisations, growing with
    ``H``) and ``sigma_h`` within 1 % of each realisation's rms height.  It is therefore
    the default; eq. 36 stays for its closed form (the paper's eq. 37/38 build on it),
    for speed, and for G that is not of the self-affine form.

    *Eq. 36 details.*  Parameters of the optimiser (method ``dogbox``, whose active set
    puts a parameter exactly on its bound) are ``ln C_sa``, ``H``, ``C_b`` and
    ``1/sigma_h^2`` (the last two linear, so that they can reach their bound 0), started
    from the best of non-negative linear least-squares fits of ``1/G`` on a grid of
    ``H``.  ``G_sa = dr_ref^(2H) / C_sa`` (``C_sa`` has the units length^(2H-2), which CF
    cannot spell); ``dr_ref`` is the power of ten nearest the geometric mean of the fitted
    lags, so that ``G_sa`` is far less correlated with ``H`` than ``C_sa``.  The roll-off
    wavelength: ``dr_x = (C_sa sigma_h^2)^(1/(2H))`` is where the self-affine term equals
    the plateau term; for the model spectra (no lower cutoff, ``lambda_s << lambda_r``)
    the self-affine asymptote of G meets ``sigma_h^2`` at ``q_r dr_x = kappa(H)`` (see
    :func:`xrough._kernels.shape_factors.rolloff_crossover`; ``kappa = 1.674, 1.5,
    1.066`` at ``H = 0.3, 0.5, 0.8`` for the sharp shape), so
    ``lambda_r = 2 pi dr_x / kappa(H)``, exact when the fitted ``C_sa`` and ``sigma_h``
    are the asymptotic ones.

    Examples
    --------
    The exact G of eq. 35 (``H = 1/2``, ``sigma_h = 2 nm``, two decades of self-affine
    scaling):

    >>> import xrough
    >>> from xrough.fitting import fit_acf
    >>> C = xrough.model_spectrum(hurst=0.5, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_height="2 nm", unit="nm")
    >>> G = xrough.acf_from_spectrum(C, dr_min=1, dr_max=1e5)
    >>> p = fit_acf(G)
    >>> print(f"H = {float(p.hurst):.4f}, sigma_h = {float(p.sigma_h):.4f} nm, "
    ...       f"lambda_r = {float(p.lambda_r):.1f} nm, lambda_s = {float(p.lambda_s):.3f} nm")
    H = 0.5000, sigma_h = 2.0000 nm, lambda_r = 1000.0 nm, lambda_s = 10.000 nm
    >>> p.attrs["weighting"], p.attrs["plateau"]
    ('none (G has no standard_error coordinate)', 'resolved')

    The closed form of eq. 36 on the same data:

    >>> q = fit_acf(G, model="eq36")
    >>> print(f"H = {float(q.hurst):.3f}, sigma_h = {float(q.sigma_h):.2f} nm")
    H = 0.560, sigma_h = 2.05 nm
    """
    if not isinstance(G, xr.DataArray):
        raise TypeError(f"G must be an xarray.DataArray, got {type(G).__name__}")
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")
    if rolloff not in ROLLOFFS:
        raise ValueError(f"rolloff must be one of {ROLLOFFS}, got {rolloff!r}")
    lateral = _lateral_unit(G)
    g_unit = _area_unit(G, "G")
    height = g_unit**0.5
    g_factor = u.conversion_factor(g_unit, lateral**2)
    dr = np.asarray(G["dr"].values, dtype=float)
    if dr.ndim != 1 or not np.all(np.isfinite(dr) & (dr > 0)):
        raise ValueError("coordinate 'dr' must hold finite positive lags")
    lo = 0.0 if dr_min is None else u.length_in(dr_min, lateral, what="dr_min")
    hi = np.inf if dr_max is None else u.length_in(dr_max, lateral, what="dr_max")
    use = (dr >= lo * (1 - 1e-12)) & (dr <= hi * (1 + 1e-12))
    if not np.any(use):
        raise ValueError(f"no lag of G lies in [dr_min, dr_max] = [{lo:g}, {hi:g}] "
                         f"{u.format_units(lateral)}")

    if weights not in ("standard_error", None):
        raise ValueError(f"weights must be 'standard_error' or None, got {weights!r}")
    if G.chunks is not None and len(G.chunksizes["dr"]) > 1:
        raise ValueError("dim 'dr' is split into several dask chunks; each fit needs all "
                         "lags: use G.chunk({'dr': -1})")
    weighted = weights == "standard_error" and "standard_error" in G.coords
    if weighted:
        se_da = G.coords["standard_error"]
        se_factor = u.conversion_factor(_area_unit(se_da, "coordinate 'standard_error'"),
                                        lateral**2)
        se = (se_da * se_factor).broadcast_like(G)
        weighting = "standard_error (1/standard error of ln G)"
    else:
        se = xr.ones_like(G)
        weighting = ("none" if weights is None
                     else "none (G has no standard_error coordinate)")
    if model == "eq36":
        if lambda_0 is not None:
            raise ValueError("lambda_0 applies to model='spectrum' only")
        fixed, fixed_text = _fixed_values(fix, lateral, height)
        kernel, names = _fit_kernel, _OUTPUTS
        kwargs = {}
    else:
        lam0 = np.inf if lambda_0 is None else u.length_in(lambda_0, lateral,
                                                           what="lambda_0")
        fixed, fixed_text = _fixed_spectrum(fix, lateral, lam0)
        kernel, names = _fit_spectrum_kernel, _SPECTRUM_OUTPUTS
        kwargs = {"lambda_0": lam0}

    dr_ref = _reference_lag(dr[use], lateral)
    Gl = (G * g_factor).drop_vars([c for c in G.coords if "dr" in G[c].dims and c != "dr"])
    se = se.drop_vars([c for c in se.coords if "dr" in se[c].dims and c != "dr"])
    out = xr.apply_ufunc(
        kernel, Gl, se,
        input_core_dims=[["dr"], ["dr"]], output_core_dims=[["fit_output"]],
        vectorize=True, dask="parallelized", output_dtypes=[float],
        dask_gufunc_kwargs={"output_sizes": {"fit_output": len(names)}},
        kwargs={"dr": dr, "use": use, "dr_ref": dr_ref, "weighted": weighted,
                "fixed": fixed, "rolloff": rolloff, "unit": u.format_units(lateral),
                **kwargs},
        keep_attrs=False,
    )
    l2h = u.conversion_factor(lateral, height)
    lat_s, h_s, g_s = u.format_units(lateral), u.format_units(height), u.format_units(g_unit)
    part = {name: out.isel(fit_output=k, drop=True) for k, name in enumerate(names)}
    spec = {
        "sigma_h": (l2h, h_s, "rms height (plateau of G: G -> sigma_h^2)"),
        "G_sa": (1.0 / g_factor, g_s, "self-affine term of G at dr_ref"),
        "hurst": (1.0, "1", "Hurst exponent"),
    }
    if model == "eq36":
        spec["C_b"] = (1.0, "1", "ballistic coefficient (gbar^2(0) = 4/C_b)")
        spec["lambda_r"] = (1.0, lat_s, "roll-off wavelength")
    else:
        spec["lambda_r"] = (1.0, lat_s, "roll-off wavelength 2 pi / q_r")
        spec["lambda_s"] = (1.0, lat_s, "short-wavelength cutoff 2 pi / q_s (upper bound "
                                        "where lambda_s_resolved = 0)")
        spec["C_r"] = (1.0 / g_factor, u.format_units(g_unit * lateral**2),
                       "plateau of the spectrum, C(q -> 0)")
    data = {}
    for name, (factor, units, long_name) in spec.items():
        data[name] = _variable(part[name] * factor, units, long_name)
        data[f"{name}_std"] = _variable(part[f"{name}_std"] * factor, units,
                                        f"standard deviation of {name}")
    data["reduced_chi2"] = _variable(part["reduced_chi2"], "1",
                                     "reduced chi^2 of the fit (log residuals)")
    data["n_bins"] = _variable(part["n_bins"].astype(np.int64), "1", "number of bins fitted")
    used = dr[use]
    attrs = {
        "long_name": ("fit of the three-regime form of G" if model == "eq36"
                      else "fit of the model spectrum to G"),
        "model": model,
        "equation": _EQ36 if model == "eq36" else _SPECTRUM_EQ.format(rolloff=rolloff),
        "weighting": weighting,
        "residuals": "ln G",
        "dr_min": float(used.min()),
        "dr_max": float(used.max()),
        "dr_units": lat_s,
        "fixed": fixed_text,
        "rolloff": rolloff,
        "uncertainty": ("1 standard deviation from the least-squares covariance times "
                        + ("max(1, reduced_chi2)" if weighted else "reduced_chi2")),
        "source": str(G.attrs.get("source", G.attrs.get("estimator", ""))),
    }
    single = out.ndim == 1 and out.chunks is None
    if model == "eq36":
        attrs["lambda_r_definition"] = (
            "2 pi dr_x / kappa(H): dr_x = (C_sa sigma_h^2)^(1/(2H)) where the self-affine "
            f"and plateau terms are equal, kappa(H) = q_r dr_x of the {rolloff} model "
            "spectrum")
    else:
        data["lambda_r_resolved"] = _variable(
            part["lambda_r_resolved"].astype(np.int8), "1",
            "1: lambda_r fitted; 0: no roll-off in the data")
        data["lambda_s_resolved"] = _variable(
            part["lambda_s_resolved"].astype(np.int8), "1",
            "1: lambda_s fitted; 0: no ballistic regime in the data, lambda_s is an "
            "upper bound")
        attrs["cutoffs"] = _CUTOFFS
        if single:
            attrs["ballistic_regime"] = ("resolved" if int(part["lambda_s_resolved"])
                                         else "unresolved: lambda_s is an upper bound")
            attrs["plateau"] = ("resolved" if int(part["lambda_r_resolved"]) else
                                "unresolved: lambda_r = " + ("sigma_h = inf" if
                                                             np.isinf(kwargs["lambda_0"])
                                                             else "lambda_0"))
    if single:  # a single fit: its chi^2 as an attribute too
        attrs["reduced_chi2"] = float(part["reduced_chi2"])
    ds = xr.Dataset(data, attrs=attrs)
    ds = ds.assign_coords(dr_ref=((), dr_ref, {"units": lat_s,
                                               "long_name": "reference lag of G_sa"}))
    if model == "spectrum":
        ds = ds.assign_coords(lambda_0=((), kwargs["lambda_0"], {
            "units": lat_s, "long_name": "long-wavelength cutoff of the model (inf: none)"}))
    return ds


def _spectrum_inputs(params: xr.Dataset, lateral: pint.Unit) -> tuple[list, dict]:
    """Per-fit inputs of the spectrum model (lengths in ``lateral``, ``G_sa`` as stored)."""
    ref_unit = u.as_length_unit(u.units_of(params["dr_ref"], what="dr_ref"), what="dr_ref")
    lam_0 = np.inf
    if "lambda_0" in params.variables:
        unit = u.as_length_unit(u.units_of(params["lambda_0"], what="lambda_0"),
                                what="lambda_0")
        lam_0 = float(params["lambda_0"]) * u.conversion_factor(unit, lateral)
    s_unit = u.as_length_unit(u.units_of(params["lambda_s"], what="lambda_s"),
                              what="lambda_s")
    arrays = [params["hurst"], params["G_sa"], params["lambda_r"],
              params["lambda_s"] * u.conversion_factor(s_unit, lateral),
              params["lambda_r_resolved"], params["lambda_s_resolved"]]
    arrays = [a.drop_vars([c for c in a.coords if c not in a.dims]) for a in arrays]
    scalars = {"dr_ref": float(params["dr_ref"]) * u.conversion_factor(ref_unit, lateral),
               "lam_0": lam_0, "rolloff": params.attrs.get("rolloff", "sharp")}
    return arrays, scalars


def _fitted_cutoffs(lam_r, lam_s, r_ok, s_ok, lam_0):
    """Cutoffs of the fitted spectrum: none where the data did not resolve them."""
    lr = lam_r if r_ok else lam_0
    ls = lam_s if s_ok else 0.0
    return lr, ls


def _spectrum_curve(H, G_sa, lam_r, lam_s, r_ok, s_ok, *, dr, dr_ref, lam_0, rolloff):
    if not (np.isfinite(H) and np.isfinite(G_sa)):
        return np.full(dr.shape, np.nan)
    lr, ls = _fitted_cutoffs(lam_r, lam_s, r_ok, s_ok, lam_0)
    return G_sa * _acf_shape(dr / dr_ref, H, lr / dr_ref, ls / dr_ref, lam_0 / dr_ref,
                             rolloff)


def _spectrum_gradient(H, G_sa, lam_r, lam_s, r_ok, s_ok, *, dr, dr_ref, lam_0, rolloff,
                       g_factor):
    if not (np.isfinite(H) and np.isfinite(G_sa)):
        return np.full(dr.shape, np.nan)
    lr, ls = _fitted_cutoffs(lam_r, lam_s, r_ok, s_ok, lam_0)
    c = 2 * np.pi * G_sa * g_factor / dr_ref ** (2 * H) / self_affine_constant(H)
    with np.errstate(divide="ignore"):
        q_r, q_s, q_0 = 2 * np.pi / np.array([lr, ls, lam_0], dtype=float)
    return np.sqrt(_gbar2_shape(dr, c, H, q_r, q_s, q_0, rolloff))


def _per_fit(func, arrays, values, lateral, **kwargs) -> xr.DataArray:
    return xr.apply_ufunc(
        func, *arrays, input_core_dims=[[]] * len(arrays), output_core_dims=[["dr"]],
        vectorize=True, dask="parallelized", output_dtypes=[float],
        dask_gufunc_kwargs={"output_sizes": {"dr": values.size}},
        kwargs={"dr": values, **kwargs}, keep_attrs=False,
    ).assign_coords(_lag_coord(values, lateral))


def model_acf(params: xr.Dataset, dr: Any = None) -> xr.DataArray:
    r"""Evaluate the fitted height-difference ACF ``G(dr)`` (plots, checks).

    For ``model="spectrum"``, eq. 9 of the fitted spectrum; for ``model="eq36"``,

    .. math::

        G(\Delta r) = \left[\frac{C_b}{\Delta r^2} + \frac{C_{sa}}{\Delta r^{2H}}
                      + \frac{1}{\sigma_h^2}\right]^{-1},
        \qquad C_{sa} = \Delta r_{ref}^{2H} / G_{sa}

    Parameters
    ----------
    params : xarray.Dataset
        The result of :func:`fit_acf` (any extra dims are broadcast).
    dr : array_like, str, pint.Quantity or xarray.DataArray, optional
        Positive lags; plain numbers in the unit of ``params.lambda_r``.  Default: 50
        logarithmic points over the fitted range.

    Returns
    -------
    xarray.DataArray
        ``G`` on dim ``dr`` (units of ``params.lambda_r``) and the extra dims of
        ``params``, in the units of ``params.G_sa``; ``attrs["equation"]`` is
        ``"eq. 9"`` or ``"eq. 36"``.

    Raises
    ------
    ValueError
        ``params`` without the fitted variables or units; invalid ``dr``.

    Notes
    -----
    A cutoff that the fit did not resolve (``lambda_s_resolved = 0``,
    ``lambda_r_resolved = 0``) is absent from the curve (``lambda_s = 0``,
    ``lambda_r = inf`` or ``lambda_0``), as in the fit.

    Examples
    --------
    >>> import xrough
    >>> from xrough.fitting import fit_acf, model_acf
    >>> C = xrough.model_spectrum(hurst=0.5, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_height="2 nm", unit="nm")
    >>> p = fit_acf(xrough.acf_from_spectrum(C, dr_min=1, dr_max=1e5))
    >>> curve = model_acf(p, [1e9])   # far out: sigma_h^2
    >>> print(f"{float(curve[0]):.4f} {curve.attrs['units']} = "
    ...       f"{float(p.sigma_h)**2:.4f} {p.sigma_h.attrs['units']}^2")
    4.0000 nm2 = 4.0000 nm^2
    """
    lateral, height, model = _params_units(params)
    values = _lags(dr, lateral, params)
    g_unit = u.units_of(params["G_sa"], what="G_sa")
    if model == "spectrum":
        arrays, scalars = _spectrum_inputs(params, lateral)
        out = _per_fit(_spectrum_curve, arrays, values, lateral, **scalars)
        equation, what = "eq. 9", "model spectrum"
    else:
        p = _in_lateral(params, lateral, height)
        x = xr.DataArray(values, dims="dr", coords=_lag_coord(values, lateral))
        c_sa = p["dr_ref"] ** (2 * p["hurst"]) / p["G_sa"]
        inv = p["C_b"] / x**2 + c_sa / x ** (2 * p["hurst"]) + 1.0 / p["sigma_h"] ** 2
        out = (1.0 / inv) * u.conversion_factor(lateral**2, g_unit)
        equation, what = "eq. 36", "eq. 36"
    out = out.drop_vars([c for c in out.coords if c not in out.dims and c != "dr"])
    out.name = "G"
    out.attrs = {"units": u.format_units(g_unit),
                 "long_name": f"height-difference ACF (fit of {what})",
                 "equation": equation}
    return out.transpose(..., "dr")


def gradient_from_fit(params: xr.Dataset, dr: Any = None, *,
                      rolloff: str | None = None) -> xr.DataArray:
    r"""Scale-dependent rms gradient ``gbar(dr)`` from a fit of G.

    For ``model="spectrum"``, eq. 26 of the fitted spectrum in closed form,

    .. math::

        \bar g^2(\Delta r) = \frac{1}{2\pi} \int_0^{2\pi/\Delta r} dq\, q^3\, C(q);

    for ``model="eq36"``, the paper's eq. 37/38,

    .. math::

        \frac{1}{\bar g^2(\Delta r)} = \frac{1}{\bar g^2(0)}
            + \frac{\Delta r^{2(1-H)}}{C'_{sa}} + \frac{\Delta r^4}{r_{ro}},
        \quad \bar g^2(0) = \frac{4}{C_b},\;
        C'_{sa} = \frac{c_{sa}(H)}{C_{sa}},\;
        r_{ro} = c_{ro}(H)\, \sigma_h^2 \lambda_r^2

    Parameters
    ----------
    params : xarray.Dataset
        The result of :func:`fit_acf`.
    dr : array_like, str, pint.Quantity or xarray.DataArray, optional
        Positive lags; plain numbers in the unit of ``params.lambda_r``.  Default: 50
        logarithmic points over the fitted range.
    rolloff : {'sharp', 'smooth'}, optional
        Roll-off shape; default ``params.attrs["rolloff"]``.  For eq. 36 it selects
        ``c_ro(H)``; a spectrum fit only accepts its own shape.

    Returns
    -------
    xarray.DataArray
        ``gbar`` (units "1") on dim ``dr`` and the extra dims of ``params``;
        ``attrs["equation"]`` is ``"eq. 26"`` or ``"eq. 37/38"``.

    Raises
    ------
    ValueError
        ``params`` without the fitted variables or units; invalid ``dr`` or ``rolloff``.

    Notes
    -----
    *Spectrum model.*  Exact for the fitted spectrum; with ``lambda_s_resolved = 0`` the
    spectrum has no short cutoff and ``gbar`` grows without bound as ``dr -> 0``
    (as ``dr^-(1-H)``), and ``lambda_r_resolved = 0`` drops the plateau.

    *Eq. 36.*  xrough's convention for the shape factors (docs/theory.md):
    ``gbar^2(dr) = c_sa(H) G(dr)/dr^2`` in the self-affine regime and ``gbar^2(dr) =
    c_ro(H) sigma_h^2 lambda_r^2 / dr^4`` for ``dr >> lambda_r``, with gbar from eq. 26,
    so that

    * ``c_sa(H) = 4 pi^(2-2H) H Gamma(1+H) / Gamma(2-H)``
      (:func:`xrough._kernels.shape_factors.self_affine_factor`, both roll-off shapes);
    * ``c_ro(H) = 2 pi^2 H / (1+H)`` (sharp, eq. 35) or ``2 pi^2 H`` (smooth), in the limit
      ``lambda_s/lambda_r -> 0`` (:func:`xrough._kernels.shape_factors.rolloff_factor`).

    Each term is exact deep inside its regime (``dr << lambda_s``: ``gbar -> gbar(0)``;
    ``lambda_s << dr << lambda_r``; ``dr >> lambda_r``) and the sum of reciprocals is
    an interpolation between them: near the crossovers it can be off by tens of percent.
    ``C_b = 0`` gives ``gbar(0) = inf``; ``sigma_h = inf`` drops the roll-off term.

    Examples
    --------
    >>> import xrough
    >>> from xrough.fitting import fit_acf, gradient_from_fit
    >>> C = xrough.model_spectrum(hurst=0.5, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_height="2 nm", unit="nm")
    >>> G = xrough.acf_from_spectrum(C, dr_min=1, dr_max=1e5)
    >>> g = gradient_from_fit(fit_acf(G), [1e-6, 100.0])
    >>> g.attrs["units"], g.attrs["equation"]
    ('1', 'eq. 26')
    >>> print(f"gbar(0) = {float(g[0]):.4f} (model {C.attrs['rms_gradient']:.4f})")
    gbar(0) = 0.1026 (model 0.1026)
    >>> g36 = gradient_from_fit(fit_acf(G, model="eq36"), [1e-6, 100.0])
    >>> print(f"eq. 37/38: gbar(0) = {float(g36[0]):.4f}")
    eq. 37/38: gbar(0) = 0.1236
    """
    lateral, height, model = _params_units(params)
    own = params.attrs.get("rolloff", "sharp")
    rolloff = own if rolloff is None else rolloff
    if rolloff not in ROLLOFFS:
        raise ValueError(f"rolloff must be one of {ROLLOFFS}, got {rolloff!r}")
    values = _lags(dr, lateral, params)
    if model == "spectrum":
        if rolloff != own:
            raise ValueError(f"rolloff={rolloff!r} differs from the {own!r} spectrum that "
                             "was fitted; refit with that shape")
        arrays, scalars = _spectrum_inputs(params, lateral)
        g_factor = u.conversion_factor(u.units_of(params["G_sa"], what="G_sa"), lateral**2)
        out = _per_fit(_spectrum_gradient, arrays, values, lateral, g_factor=g_factor,
                       **scalars)
        equation, what = "eq. 26", "fitted spectrum"
    else:
        p = _in_lateral(params, lateral, height)
        x = xr.DataArray(values, dims="dr", coords=_lag_coord(values, lateral))
        H = p["hurst"]
        c_sa = xr.apply_ufunc(self_affine_factor, H, dask="parallelized",
                              output_dtypes=[float], keep_attrs=False)
        c_ro = xr.apply_ufunc(lambda h: rolloff_factor(h, rolloff=rolloff), H,
                              dask="parallelized", output_dtypes=[float], keep_attrs=False)
        C_sa = p["dr_ref"] ** (2 * H) / p["G_sa"]
        with np.errstate(divide="ignore", invalid="ignore"):
            r_ro = c_ro * p["sigma_h"] ** 2 * p["lambda_r"] ** 2
            inv = p["C_b"] / 4.0 + x ** (2 * (1 - H)) * C_sa / c_sa + x**4 / r_ro
            out = np.sqrt(1.0 / inv)
        equation, what = "eq. 37/38", "fit of eq. 36"
    out = out.drop_vars([c for c in out.coords if c not in out.dims and c != "dr"])
    out.name = "gbar"
    out.attrs = {"units": "1", "long_name": f"scale-dependent rms gradient ({what})",
                 "equation": equation, "rolloff": rolloff}
    return out.transpose(..., "dr")
