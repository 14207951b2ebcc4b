"""Least-squares fits of the height-difference ACF, one curve at a time (pure numpy/scipy).

All lengths in one unit.  Both models minimise ``sum_i [(ln G_model - ln G_i) / s_i]^2``
with ``s_i`` the standard error of ``ln G`` (1 unweighted); see
:func:`xrough.fitting.fit_acf` for the models, the parametrisation and the uncertainties.

* eq. 36, ``1/G = C_b/dr^2 + C_sa/dr^(2H) + 1/sigma_h^2`` (:func:`fit_eq36_kernel`):
  started from non-negative linear least squares in ``1/G`` on a grid of ``H``;
* the model spectrum (eq. 35) through its exact G of eq. 9 (:func:`fit_spectrum_kernel`),
  started from the fit of eq. 36; :func:`fitted_spectrum_acf` and
  :func:`fitted_spectrum_gradient` evaluate such a fit.

A fit returns one vector of floats in the order of :data:`EQ36_OUTPUTS` or
:data:`SPECTRUM_OUTPUTS`: the parameters, their standard deviations, the reduced chi^2, the
number of bins and (spectrum) the flags of the resolved cutoffs.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .acf_curve import relative_error_problem
from .deferred import optimize, special
from .hankel import acf_from_spectrum_kernel
from .model_acf import cutoff_slopes, sharp_acf, smooth_acf, smooth_closed_form_applies
from .shape_factors import ROLLOFFS, rolloff_crossover, self_affine_constant
from .spectral_models import CUTOFFS, SpectrumModel, model_gradient2, shape_names
from .uncertainty import relative_covariance

__all__ = [
    "MODELS",
    "PARAMETERS",
    "SPECTRUM_PARAMETERS",
    "FLAGS",
    "EQ36_OUTPUTS",
    "SPECTRUM_OUTPUTS",
    "H_BOUNDS",
    "PROBLEMS",
    "PROBLEM_LEVELS",
    "AIC_MARGIN",
    "information_criterion",
    "fit_problems",
    "fit_eq36_kernel",
    "fit_spectrum_kernel",
    "fitted_spectrum_acf",
    "fitted_spectrum_gradient",
    "fitted_spectrum_gradient_std",
    "fit_covariance",
    "COVARIANCE_PARAMETERS",
]

MODELS = ("spectrum", "eq36")
PARAMETERS = ("sigma_h", "G_sa", "hurst", "C_b", "lambda_r")
EQ36_OUTPUTS = (*PARAMETERS, *(f"{p}_std" for p in PARAMETERS), "reduced_chi2", "n_bins",
                "rms_misfit", "max_misfit_factor", "fit_problems", "quality")
SPECTRUM_PARAMETERS = ("sigma_h", "G_sa", "hurst", "lambda_r", "lambda_s", "C_r")
FLAGS = ("lambda_r_resolved", "lambda_s_resolved")
#: The parameters of a spectrum fit's covariance (the last outputs of
#: :data:`SPECTRUM_OUTPUTS`, row by row; :func:`fit_covariance`): ``ln G_sa``, ``H``,
#: ``eta = (dr_ref / lambda_r)^(2 - 2H)`` and ``eps = (lambda_s / dr_ref)^(2H)`` (0: no
#: such cutoff), the parameters in which the fit is linearised
#: (:func:`fitted_spectrum_gradient_std`).
COVARIANCE_PARAMETERS = ("ln_G_sa", "hurst", "eta", "eps")
SPECTRUM_OUTPUTS = (*SPECTRUM_PARAMETERS, *(f"{p}_std" for p in SPECTRUM_PARAMETERS),
                    "reduced_chi2", "n_bins", *FLAGS, "rms_misfit", "max_misfit_factor",
                    "reduced_chi2_eq36",
                    "rolloff_shape", "reduced_chi2_other_rolloff", "fit_problems", "quality",
                    "cutoff_shape", "reduced_chi2_other_cutoff",
                    *(f"cov_{a}_{b}" for a in COVARIANCE_PARAMETERS
                      for b in COVARIANCE_PARAMETERS))


def fit_covariance(values):
    """Return the ``(..., 4, 4)`` covariance in :data:`COVARIANCE_PARAMETERS` of fits.

    ``values``: outputs of :func:`fit_spectrum_kernel` on the last axis (numpy or dask).
    """
    n = len(COVARIANCE_PARAMETERS)
    k = SPECTRUM_OUTPUTS.index(f"cov_{COVARIANCE_PARAMETERS[0]}_{COVARIANCE_PARAMETERS[0]}")
    block = values[..., k:k + n * n]
    return block.reshape((*block.shape[:-1], n, n))
#: The checks of a fit (bit k of ``fit_problems``) and the quality level each implies
#: (1 questionable, 2 failed; see :func:`fit_problems`).
PROBLEM_LEVELS = {
    "poor_fit": 1,              # the model misses G beyond its errors, or by > 10 % rms
    "failed_fit": 2,            # ... by more than 20 % rms
    "hurst_at_bound": 1,        # H within HURST_MARGIN of its bound 0.01 or 0.99
    "other_model_better": 1,    # chi^2 > 10 and eq. 36 has a 3 times smaller one
    "no_self_affine_range": 2,  # the cutoffs leave no self-affine range inside the lags
    "outside_range": 1,         # lambda_r more than 10 times beyond the largest lag
    "not_finite": 2,            # H, chi^2 or sigma_h undefined
    "hurst_undetermined": 1,    # std of H above HURST_STD_MAX
    "misses_data": 1,           # model and G differ by more than MISS_FACTOR in a bin
    "sigma_h_below_data": 1,    # 2 sigma_h^2 below G (G <= 2 sigma_h^2 on any surface)
    "cutoff_undetermined": 1,   # a resolved cutoff's standard deviation exceeds its value
    "hurst_pinned": 2,          # H at its bound: not 2 std (HURST_SEPARATION) inside it
    "too_few_bins": 2,          # fewer than MIN_BINS_PER_PARAMETER bins per free parameter
    "cutoff_shape_undetermined": 1,  # sharp and Gaussian cutoffs fit alike, H's spread
                                     # beyond SHAPE_SPREAD_MAX (fit_spectrum_kernel)
}
PROBLEMS = tuple(PROBLEM_LEVELS)
#: A fit is poor (questionable) when its rms misfit of ln G exceeds MISFIT_QUESTIONABLE
#: (10 %: a smaller misfit moves gbar ~ G^(1/2), and what follows from it, by less than
#: 5 %), or, weighted, when its reduced chi^2 exceeds CHI2_ALONE (the model misses G by
#: more than 4.5 standard errors rms: the standard errors are lower bounds, so a large map
#: whose model is right by 1 % must not reach it; correct models of synthetic maps give
#: 0.02 to 0.12).  A fit whose misfit exceeds MISFIT_FAILED (20 %: the model is off G by a
#: factor e^0.2 = 1.22 in a typical bin, gbar ~ G^(1/2) and the contact results by more
#: than 10 %, the tolerance of the calibration's gbar; and the fitted curve no longer
#: follows the measured one, so its parameters describe neither) has failed, whatever
#: its reduced chi^2: wide standard errors (a profile of 76 to 134 points, 30 to 80 % per
#: bin) make a 50 to 70 % misfit look like chi^2 = 2 to 3.5, but then the data do not
#: pin the model either.  See docs/quality.md for the measurements behind them.
CHI2_QUESTIONABLE, CHI2_ALONE = 10.0, 20.0
MISFIT_QUESTIONABLE, MISFIT_FAILED = 0.1, 0.2
#: ... but not when the misfit is below MISFIT_NEGLIGIBLE (2 %: gbar moves by < 1 %),
#: however small the standard errors (a large map or an exact G).
MISFIT_NEGLIGIBLE = 0.02
#: A model that misses G by more than this factor in any fitted bin (either way) is not
#: what a reader of the plot would call a fit, whatever the rms (the weights are smallest
#: where a model of the wrong shape misses most: at the largest lags).
MISS_FACTOR = 3.0
#: A free H closer than this to its bound (H_BOUNDS) is near it (questionable): the data
#: may ask for an exponent outside 0 < H < 1 (a tilt, a form, a plateau).
HURST_MARGIN = 0.05
#: ... and pinned there (failed: H and every fitted parameter NaN) when, within that
#: margin, it lies less than HURST_SEPARATION standard deviations from the bound: the data
#: do not tell H from the bound where the search stopped (al3d-1: H = 0.01 +- 0.25, plu-1:
#: 0.041 +- 0.16), or the search stopped on it (a G ~ dr^2 of a tilt asks for H > 1).  Two
#: standard deviations, the test that tells a resolved cutoff from none (_SIGNIFICANCE);
#: an exponent measured near the bound (the exact G of H = 0.05: 0.05 +- 2e-14) stays a
#: measurement, questionable by HURST_MARGIN.
HURST_SEPARATION = 2.0
#: A fit of fewer bins than this many per free parameter has failed: each parameter is
#: set by a feature of the curve (the amplitude by a level, H by a slope, a cutoff by a
#: bend), which takes two bins at least, so below that some parameter rests on one bin or
#: on none and the fit interpolates rather than measures; with n < 2 p the residuals also
#: keep fewer degrees of freedom than the fit has parameters.  The 4 x 7 points of
#: sdf-1.sdf give 7 bins for 4 parameters (H = 0.155 +- 8.6); with fewer bins than
#: parameters + 1 (xyz-1.txt, 4 x 4 points: 4 bins) the fit is refused (_check_count).
MIN_BINS_PER_PARAMETER = 2
#: The other model is "clearly better" when its reduced chi^2 is this many times smaller.
OTHER_BETTER = 3.0
#: A cutoff more than this factor outside the fitted lags is an extrapolation.
OUTSIDE = 10.0
#: Largest standard deviation of a fitted H that is a finding: beyond it the 1-sigma
#: interval spans half of the range 0 < H < 1 (a rough and a smooth surface alike), e.g.
#: on a map of a few pixels or a G of a few bins.
HURST_STD_MAX = 0.25
#: ``rolloff="auto"`` fits both shapes of :data:`ROLLOFFS` and keeps the smooth one only
#: when its Akaike information criterion (AIC = chi^2 + 2 p weighted, n ln(RSS/n) + 2 p
#: unweighted; both shapes have the same p, so this compares chi^2) is lower than the
#: sharp one's by more than AIC_MARGIN: a difference of 2 (a likelihood ratio of e) is the
#: usual threshold of substantial support (Burnham & Anderson 2002); below it the data do
#: not tell the shapes apart and the paper's eq. 35 (sharp) is kept.
AIC_MARGIN = 2.0
#: Bounds of H in the fit (the model degenerates at H = 0 and H = 1).
H_BOUNDS = (0.01, 0.99)
#: Hurst exponents tried for the starting point (linear least squares at each).
_H_GRID = np.linspace(0.02, 0.98, 49)
#: Lower bound of ln(eta), ln(eps): a cutoff that changes G by less than e^-16 (1e-7) is
#: absent (it is then set to none, below _MIN_EFFECT).
_LN_FLOOR = -16.0
#: Cutoffs further than these factors beyond the lags (below for lambda_s, above for
#: lambda_r) are moved there and corrected to leading order.
_FAR_S, _FAR_R = 1e3, 1e5
#: Eq. 9 is in closed form (model_acf) except for the smooth shape with lambda_s within a
#: factor 4 of lambda_r or with lambda_0: there the quadrature, with these knots per
#: decade of the power-law representation of C (sharp: exact with 0) and settings:
#: relative error <= 5e-15 (sharp) and 5e-9 (smooth, set by _KNOTS) against the defaults
#: over 16 decades of dr, 0.02 <= H <= 0.99; half the cost.
_KNOTS = {"sharp": 0.0, "smooth": 40.0}
_QUADRATURE: dict[str, Any] = {"t_split": 32.0, "order": 10, "panels_per_decade": 4.0}
#: A cutoff is resolved when its eta (eps) exceeds this many standard deviations and
#: _MIN_EFFECT (a relative change of G below 1e-6 is no cutoff, even in exact data).
_SIGNIFICANCE, _MIN_EFFECT = 2.0, 1e-6
#: A first fit of the spectrum that is poor (reduced chi^2 above CHI2_QUESTIONABLE or
#: above that of eq. 36; unweighted, rms misfit above _RESTART_MISFIT) restarts from the
#: _N_RESTARTS best points of this grid of ``[H, ln eta, ln eps]``: on self-affine
#: surfaces whose cutoffs are one decade apart (e.g. 1024^2 with lambda_r = 20 and
#: lambda_s = 2 pixels) the start from eq. 36 can end in a local minimum with lambda_s
#: beyond lambda_r, H = 0.15 and a reduced chi^2 of 1e4.
_GRID = (np.array([0.1, 0.3, 0.5, 0.7, 0.9]), np.array([-4.0, -1.0, 2.0, 5.0]),
         np.array([-4.0, -1.0, 2.0, 5.0]))
_N_RESTARTS = 3
_RESTART_MISFIT = 0.03
#: ... or (weighted) one with a reduced chi^2 above this that lost a cutoff which its
#: fit needed: the refit without it worse by more than this in chi^2 (the likelihood
#: ratio of one parameter at two standard deviations; the test that dropped it is on
#: the cutoff's standard deviation, linear, and a cutoff near its bound is not).
_RESTART_CHI2_LOST, _LOST_CHI2 = 1.0, 4.0
#: Evaluations of eq. 9 a fit of one shape keeps for reuse (see :func:`_acf_shape`).
_MEMO_SIZE = 1024
#: A restart whose search comes this close to the end of an earlier search (see
#: :func:`_same_end`) ends there.
_REACHED = 1e-4
#: Tolerances of one search (relative change of chi^2 and of the parameters) and its cap on
#: the evaluations of the residuals (each step takes one more for the Jacobian's column of
#: H, and of a cutoff without closed-form slopes, :meth:`_ShapeProblem.slopes`): with the
#: amplitude solved for, a search converges in 5 to 20 steps; the cap ends those that
#: crawl along a direction the data do not determine.
_FTOL, _XTOL, _GTOL, _MAX_NFEV = 1e-8, 1e-10, 1e-10, 30


# --------------------------------------------------------------------------------------
# the bins of one G
# --------------------------------------------------------------------------------------
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
    problem = relative_error_problem(G[sel], se[sel], dr[sel], unit=unit) if weighted else ""
    if problem:
        raise ValueError(f"the {problem} (or use weights=None)")
    return sel


def _rms_misfit(r, w):
    """Weighted rms of ``ln G_model - ln G`` from the residuals ``r = (...) / w``.

    Each bin counts with ``1/w^2`` (``w``: standard error of ``ln G``; 1 unweighted), so
    that noisy bins do not dominate; the value is the typical relative misfit of G.
    """
    return float(np.sqrt(np.sum(r**2) / np.sum(1.0 / w**2)))


def _max_factor(r, w) -> float:
    """Return the largest factor between model and data, ``exp(max |ln G_model - ln G|)``."""
    return float(np.exp(np.max(np.abs(r * w))))


def _g_max(G_sel, w, weighted) -> float:
    """Return the largest fitted G less two standard errors (``w``: of ``ln G``)."""
    return float(np.max(G_sel * (1.0 - 2.0 * w))) if weighted else float(np.max(G_sel))


def _check_count(n, p, what):
    if n < p + 1:
        raise ValueError(f"too few bins to fit {what}: {n} valid bin(s) in the dr range, "
                         f"but {p} free parameters need at least {p + 1} (widen "
                         "dr_min/dr_max or fix parameters)")


def _fit_data(G, se, *, dr, use, dr_ref, weighted, fixed, unit, what):
    """Select and scale the bins of one G to fit: ``(free, n, p, x, G_sel, G_ref, w, sel)``.

    ``free`` flags the fitted parameters (the amplitude, and those of ``fixed`` that are
    NaN), ``n`` and ``p`` count bins and free parameters, ``x = dr / dr_ref``, ``G_ref`` is
    the power of two nearest the geometric mean of the selected ``G_sel`` (so that
    ``G_sel / G_ref`` is the same to the last bit when G is scaled by a power of two: the
    search, which can end in one of several near-equal minima on a G that no model
    describes, then takes the same path in every unit) and ``w`` the standard error of
    ``ln G`` (1 unweighted).
    """
    G = np.asarray(G, dtype=float)
    se = np.asarray(se, dtype=float)
    sel = _select(G, se, use, weighted, dr, unit, what)
    free = np.array([True, np.isnan(fixed[0]), np.isnan(fixed[1]), np.isnan(fixed[2])])
    n, p = int(sel.sum()), int(free.sum())
    _check_count(n, p, what)
    x = dr[sel] / dr_ref
    G_ref = float(2.0 ** np.round(np.mean(np.log2(G[sel]))))
    w = se[sel] / G[sel] if weighted else np.ones(n)  # standard error of ln G
    return free, n, p, x, G[sel], G_ref, w, sel


# --------------------------------------------------------------------------------------
# eq. 36
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
        coef = _nonnegative_lstsq(A, rhs * scale)
        trial = theta.copy()
        trial[1] = H
        for k, c in zip(names, coef):
            trial[k] = c
        trial[0] = np.log(max(trial[0], 1e-3 * np.min(y)))  # a > 0 (it is fitted in log)
        cost = np.sum(_residuals(trial, x, y, w) ** 2)
        if cost < best_cost:
            best, best_cost = trial, cost
    return best


def _nonnegative_lstsq(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``argmin |A c - b|`` with ``c >= 0``.

    scipy 1.12-1.13's ``nnls`` can stop at its iteration cap with a RuntimeError on
    nearly collinear columns; the bounded least squares of ``lsq_linear`` then solves it.
    """
    try:
        return optimize.nnls(A, b)[0]
    except RuntimeError:
        return optimize.lsq_linear(A, b, bounds=(0.0, np.inf)).x


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


def fit_eq36_kernel(G, se, *, dr, use, dr_ref, weighted, fixed, rolloff, unit, check=True):
    """Fit eq. 36 to one G (all lengths in one unit); returns the values of ``EQ36_OUTPUTS``.

    ``check=False`` keeps the parameters of a failed fit (a starting point needs them).
    """
    free, n, p, x, G_sel, G_ref, w, _ = _fit_data(G, se, dr=dr, use=use, dr_ref=dr_ref,
                                               weighted=weighted, fixed=fixed, unit=unit,
                                               what="eq. 36")
    y = G_ref / G_sel  # 1/g with g = G/G_ref

    theta = np.array([0.0, fixed[0], fixed[1] * G_ref / dr_ref**2, fixed[2] * G_ref])
    theta = _start(x, y, w, free, np.where(free, 0.0, theta))
    lower = np.array([-np.inf, H_BOUNDS[0], 0.0, 0.0])[free]
    upper = np.array([np.inf, H_BOUNDS[1], np.inf, np.inf])[free]

    def fun(t):
        full = theta.copy()
        full[free] = t
        return _residuals(full, x, y, w)

    def jac(t):
        full = theta.copy()
        full[free] = t
        return _jacobian(full, x, w)[:, free]

    t0 = np.clip(theta[free], lower, upper)
    # trf: where the plateau s sits at its bound 0 (plu-1.plu), dogbox crawled along it
    # for its 2000 evaluations without converging; trf, reflecting off the bound, reaches
    # a lower misfit in 8 (and the same fits wherever dogbox converged)
    res = optimize.least_squares(fun, t0, jac=jac, bounds=(lower, upper), method="trf",
                                 x_scale="jac", ftol=1e-12, xtol=1e-12, gtol=1e-12,
                                 max_nfev=2000)
    theta[free] = res.x
    # a ballistic or plateau term that ends on its bound, that nowhere reaches 1e-9 of the
    # fitted 1/g, or without which the fit is as good (trf stays strictly inside its
    # bounds: a term the data do not want ends near 1e-11, not at 0), is exactly zero
    active = np.zeros(4, dtype=bool)
    active[free] = res.active_mask != 0
    for k in (2, 3):
        if not free[k] or theta[k] == 0.0:
            continue
        tb, tsa, ts = _terms(theta, x)
        term = tb if k == 2 else ts
        cost = float(np.sum(_residuals(theta, x, y, w) ** 2))
        without = theta.copy()
        without[k] = 0.0
        if (active[k] or np.all(term < 1e-9 * (tb + tsa + ts))
                or np.sum(_residuals(without, x, y, w) ** 2) <= cost + 1e-9 * max(cost, 1.0)):
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
    var = np.maximum(np.diag(cov), 0.0)  # round-off of a singular covariance

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
    values = np.array([sigma_h, G_sa, H, C_b, lam])
    stds = np.array([sigma_std, G_sa * np.sqrt(var[0]), np.sqrt(var[1]),
                     np.sqrt(var[2]) * dr_ref**2 / G_ref, lam_std])
    r = _residuals(theta, x, y, w)
    rms_misfit, max_factor = _rms_misfit(r, w), _max_factor(r, w)
    bits, code = fit_problems(chi2, rms_misfit, H, weighted=weighted, dr_min=x[0] * dr_ref,
                              dr_max=x[-1] * dr_ref, sigma_h=sigma_h, lambda_r=lam,
                              lambda_s=0.0, r_ok=s > 0, s_ok=False,
                              hurst_free=bool(free[1]), hurst_std=stds[2],
                              max_factor=max_factor, g_max=_g_max(G_sel, w, weighted),
                              n_bins=n, n_free=p)
    if code == 2 and check:  # the numbers mean nothing (but a fixed value stays)
        keep = np.array([np.isfinite(fixed[2]), False, not free[1], not free[2], False])
        values[~keep], stds[~keep] = np.nan, np.nan
    return np.array([*values, *stds, chi2, n, rms_misfit, max_factor, bits, code],
                    dtype=float)


# --------------------------------------------------------------------------------------
# the exact G of the model spectrum and its fit
# --------------------------------------------------------------------------------------
def _rolloff_coefficient(H: float, rolloff: str) -> float:
    """Return ``A = int_0^inf x^3 [C(x)/C_r - x^(-2-2H)] dx`` (``q_r = 1``), roll-off term.

    At fixed self-affine amplitude, ``G`` moves by ``A c q_r^(2-2H) dr^2 / (8 pi)`` when a
    roll-off at ``q_r << 1/dr`` is switched on (``c = C_r q_r^(2+2H)``).
    """
    return 0.25 - 1.0 / (2.0 - 2.0 * H) if rolloff == "sharp" else -1.0 / (2 * H * (1 - H))


def _acf_shape(x, H, lam_r, lam_s, lam_0, rolloff, memo=None, cutoff="sharp"):
    """G (eq. 9) of the model spectrum whose self-affine asymptote is ``x^(2H)``.

    All lengths in one unit; ``lam_r = inf`` (no roll-off; only without ``lam_0``),
    ``lam_s = 0`` (no short cutoff) and ``lam_0 = inf`` (no lower cutoff) are allowed.
    A cutoff far beyond the lags (``_FAR_S``, ``_FAR_R``) is evaluated nearer and moved to its
    value with the leading term, which is linear in ``q_s^(-2H)`` (a constant shift of G)
    resp. ``q_r^(2-2H)`` (a term in ``dr^2``); the next terms are smaller by
    ``(q_s dr)^(-3/2)`` resp. ``(q_r dr)^(2H)`` or ``(q_r dr)^2``.  A Gaussian ``cutoff``
    (the spectrum times ``exp(-(q/q_s)^2)``) is integrated by quadrature; its far shift is
    ``Gamma(1-H)`` times the sharp cutoff's (``G -> x^(2H) - Gamma(1-H) (q_s^-2H) / (2H I)``
    beyond it, against ``q_s^-2H / (2H I)``).

    ``memo``: a dict that keeps the evaluations of eq. 9 by ``(H, lambda_r, lambda_s)`` as
    evaluated (after the moves above), for calls with the same ``x``, ``lam_0`` and
    ``rolloff``: a fit asks for the same one again where a cutoff is far beyond the lags,
    or ``lambda_s`` beyond ``lambda_r`` (the step in that cutoff of a Jacobian, the point
    a covariance is computed at).  The values are the same, bit for bit.
    """
    kernel_I = float(self_affine_constant(H))
    lr, ls = _evaluated_cutoffs(x, lam_r, lam_s, lam_0)
    key = (float(H), float(lr), float(ls))
    q_r = 2 * np.pi / lr
    G = None if memo is None else memo.get(key)
    if G is None:
        q_s = 2 * np.pi / ls
        q_0 = 0.0 if np.isinf(lam_0) else 2 * np.pi / lam_0
        C_r = 2 * np.pi / (kernel_I * q_r ** (2 + 2 * H))
        if cutoff != "sharp":
            model = SpectrumModel(hurst=H, q_r=q_r, q_s=q_s, q_0=q_0, rolloff=rolloff,
                                  C_r=C_r, cutoff=cutoff)
            G = acf_from_spectrum_kernel(x, model, model.breakpoints,
                                         knots_per_decade=_KNOTS["smooth"], **_QUADRATURE)
        elif rolloff == "sharp":
            G = sharp_acf(x, H, q_r, q_s, q_0, C_r)
        elif smooth_closed_form_applies(q_r, q_s, q_0):
            G = smooth_acf(x, H, q_r, q_s, C_r)
        else:
            model = SpectrumModel(hurst=H, q_r=q_r, q_s=q_s, q_0=q_0, rolloff=rolloff,
                                  C_r=C_r)
            G = acf_from_spectrum_kernel(x, model, model.breakpoints,
                                         knots_per_decade=_KNOTS[rolloff], **_QUADRATURE)
        if memo is not None:
            if len(memo) >= _MEMO_SIZE:
                memo.pop(next(iter(memo)))  # the oldest
            memo[key] = G
    if lam_s < ls:
        G = G + ((ls / (2 * np.pi)) ** (2 * H) - (lam_s / (2 * np.pi)) ** (2 * H)) / (
            2 * H * kernel_I) * (special.gamma(1 - H) if cutoff == "gaussian" else 1.0)
    if lam_r > lr and np.isinf(lam_0):
        G = G + _rolloff_coefficient(H, rolloff) * x**2 / (4 * kernel_I) * (
            (2 * np.pi / lam_r) ** (2 - 2 * H) - q_r ** (2 - 2 * H))
    return G


def _evaluated_cutoffs(x, lam_r, lam_s, lam_0) -> tuple[float, float]:
    """Return the cutoffs :func:`_acf_shape` evaluates eq. 9 at (far ones moved nearer)."""
    lr = min(lam_r, _FAR_R * float(np.max(x))) if np.isinf(lam_0) else min(lam_r, lam_0)
    return lr, min(max(lam_s, float(np.min(x)) / _FAR_S), lr / (1.0 + 1e-6))


def _acf_shape_slopes(x, H, lam_r, lam_s, lam_0, rolloff, cutoff="sharp"):
    """``(dG/dlambda_r, dG/dlambda_s)`` of :func:`_acf_shape` (same arguments), or ``None``.

    In closed form (:func:`~xrough._kernels.model_acf.cutoff_slopes`, and the leading
    terms :func:`_acf_shape` moves a far cutoff with) where there is one: ``lambda_s``
    with a sharp cutoff or a far one, ``lambda_r`` with the sharp roll-off and a sharp
    cutoff, or a far one, or one held at ``lambda_0`` (0).  ``None`` where there is none
    (a fit takes a finite difference there): the smooth roll-off's ``lambda_r``, a
    Gaussian cutoff, and ``lambda_s`` held just below ``lambda_r``.
    """
    kernel_I = float(self_affine_constant(H))
    lr, ls = _evaluated_cutoffs(x, lam_r, lam_s, lam_0)
    if ls < max(lam_s, float(np.min(x)) / _FAR_S):  # held just below lambda_r
        return None, None
    q_r, q_s = 2 * np.pi / lr, 2 * np.pi / ls
    q_0 = 0.0 if np.isinf(lam_0) else 2 * np.pi / lam_0
    slope_r = slope_s = None
    if cutoff == "sharp":
        C_r = 2 * np.pi / (kernel_I * q_r ** (2 + 2 * H))
        d_r, d_s = cutoff_slopes(x, H, q_r, q_s, q_0, C_r, rolloff)
        slope_s = -q_s / ls * d_s  # dq/dlambda = -q/lambda
        slope_r = None if d_r is None else -q_r / lr * d_r
    if lam_s < ls:  # moved: the leading term of its move (eq. 9 at ls does not move)
        slope_s = np.zeros_like(x) if lam_s <= 0 else np.full(
            x.shape, -(lam_s / (2 * np.pi)) ** (2 * H - 1) / (2 * np.pi * kernel_I)
            * (special.gamma(1 - H) if cutoff == "gaussian" else 1.0))
    if lam_r > lr:  # held at lambda_0, or moved
        slope_r = (np.zeros_like(x) if np.isfinite(lam_0) or np.isinf(lam_r) else
                   _rolloff_coefficient(H, rolloff) * x**2 / (4 * kernel_I) * (2 - 2 * H)
                   * (2 * np.pi / lam_r) ** (1 - 2 * H) * (-2 * np.pi / lam_r**2))
    return slope_r, slope_s


def _spectrum_moments(c, H, q_r, q_s, q_0, rolloff, cutoff="sharp"):
    """``sigma_h^2`` and ``C_r`` of the model with ``c = C_r q_r^(2+2H)`` (``q_r`` may be 0)."""
    if q_r == 0.0:
        return np.inf, np.inf
    C_r = c / q_r ** (2 + 2 * H)
    s0, ss = (q_0 / q_r) ** 2, (q_s / q_r) ** 2
    if cutoff != "sharp" and np.isfinite(q_s):
        model = SpectrumModel(hurst=H, q_r=q_r, q_s=q_s, q_0=q_0, rolloff=rolloff,
                              cutoff=cutoff, C_r=C_r)
        return model.moment(0), C_r
    if rolloff == "sharp":
        m0 = (1 - s0) / 2 + (1 - (q_r / q_s) ** (2 * H)) / (2 * H)
    else:
        m0 = ((1 + s0) ** -H - (1 + ss) ** -H) / (2 * H)
    return C_r * q_r**2 * m0 / (2 * np.pi), C_r


def _eq36_fit(G, se, *, dr, use, dr_ref, weighted, fixed, unit, **_):
    """Fit eq. 36 to start the spectrum fit (``lambda_r`` of the sharp shape).

    It depends on neither the roll-off shape (only its ``lambda_r`` does, converted by
    :func:`_spectrum_start`) nor the cutoff's, so :func:`fit_spectrum_kernel` computes it
    once per G for every shape and cutoff it fits.
    """
    try:
        return fit_eq36_kernel(G, se, dr=dr, use=use, dr_ref=dr_ref, weighted=weighted,
                               fixed=np.array([fixed[0], np.nan, np.nan]), rolloff="sharp",
                               unit=unit, check=False)
    except ValueError:  # too few bins for eq. 36 (the spectrum has fixed cutoffs)
        H = 0.5 if np.isnan(fixed[0]) else fixed[0]
        return np.array([np.nan, np.nan, H, 0.0, np.inf] + [np.nan] * 5 + [np.inf])


def _spectrum_start(eq36, *, dr_ref, rolloff, G_ref, x_lo, x_hi):
    """Start ``[ln(G_sa/G_ref), H, ln eta, ln eps]`` from the fit of eq. 36, and its chi^2.

    The reduced chi^2 of eq. 36 (inf when it cannot be fitted) is the yardstick of
    :func:`fit_problems`: the model spectrum should fit a self-affine G at least as well.
    ``eq36``: the values of :func:`_eq36_fit` (once per G, :func:`fit_spectrum_kernel`).
    """
    out = eq36
    _, G_sa, H, C_b, lam = out[:5]
    G_sa = G_ref if np.isnan(G_sa) else G_sa
    if rolloff != "sharp":  # the fit is the same; its lambda_r is the sharp shape's
        lam = lam * rolloff_crossover(H, rolloff="sharp") / rolloff_crossover(H, rolloff=rolloff)
    chi2 = float(out[len(PARAMETERS) * 2])
    H = float(np.clip(H, 0.05, 0.95))
    ln_eta = ((2 - 2 * H) * np.log(x_hi * dr_ref / lam) if np.isfinite(lam) and lam > 0
              else -5.0)
    ln_eps = -5.0
    if C_b > 0:  # gbar^2(0) = 4/C_b = (K/I) q_s^(2-2H)/(2-2H) for q_s >> q_r
        K = G_sa / dr_ref ** (2 * H)
        with np.errstate(over="ignore", divide="ignore", under="ignore"):
            q_s = (4.0 / C_b * self_affine_constant(H) * (2 - 2 * H) / K) ** (
                1 / (2 - 2 * H))
            ln_eps = 2 * H * np.log(2 * np.pi / q_s / dr_ref / x_lo)
        ln_eps = ln_eps if np.isfinite(ln_eps) else -5.0
    return np.array([np.log(G_sa / G_ref), H, ln_eta, ln_eps]), chi2


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


def _grid_starts(theta, free, lower, upper, x, ly, w, cutoffs, lam_0, rolloff, memo=None,
                 cutoff="sharp"):
    """Return the best points of :data:`_GRID` as ``(chi^2, start)``, best first.

    Only the free parameters vary; chi^2 is not reduced.
    """
    axes = [g if free[k + 1] else np.array([theta[k + 1]]) for k, g in enumerate(_GRID)]
    trials = []
    for H, le, lp in ((a, b, c) for a in axes[0] for b in axes[1] for c in axes[2]):
        t = np.clip(np.array([0.0, H, le, lp]), lower + 1e-3, upper - 1e-3)
        lr, ls = cutoffs(t)
        with np.errstate(all="ignore"):
            d = np.log(_acf_shape(x, t[1], lr, ls, lam_0, rolloff, memo, cutoff)) - ly
        if not np.all(np.isfinite(d)):
            continue
        t[0] = -np.sum(d / w**2) / np.sum(1.0 / w**2)  # the best amplitude
        trials.append((float(np.sum(((t[0] + d) / w) ** 2)), t))
    trials.sort(key=lambda item: item[0])
    return trials[:_N_RESTARTS]


def information_criterion(chi2: float, n: int, p: int, weighted: bool) -> float:
    """Akaike's information criterion of a least-squares fit (Gaussian errors).

    ``chi2``: reduced chi^2 of the (log) residuals, ``n`` bins, ``p`` free parameters.
    Weighted (known standard errors): ``chi^2 + 2 p``; unweighted (variance estimated):
    ``n ln(RSS/n) + 2 p``.  Only differences between fits of the same bins mean anything.
    """
    total = chi2 * (n - p)
    if not weighted:
        with np.errstate(divide="ignore"):
            total = n * np.log(total / n)
    return float(total + 2 * p)


def fit_spectrum_kernel(G, se, *, dr, use, dr_ref, weighted, fixed, rolloff, lambda_0, unit,
                        errors=None, cutoff="sharp"):
    """Fit the model spectrum to one G (one length unit); the values of ``SPECTRUM_OUTPUTS``.

    ``rolloff``: one of :data:`ROLLOFFS`, or ``"auto"``: both are fitted and the sharp one
    is kept unless the smooth one has an AIC lower by more than :data:`AIC_MARGIN`
    (``rolloff_shape`` is the index of the shape kept in :data:`ROLLOFFS`,
    ``reduced_chi2_other_rolloff`` the reduced chi^2 of the other; NaN for one shape).

    ``cutoff``: one of :data:`CUTOFFS`, or ``"auto"``: where the fit of the sharp cutoff
    resolves ``lambda_s``, the roll-off kept is fitted again with a Gaussian cutoff
    (started where the sharp one ended, its ``lambda_s`` moved to the same shift of G), and
    the Gaussian kept where its AIC is lower by more than :data:`AIC_MARGIN` (eq. 35
    otherwise; ``cutoff_shape``, ``reduced_chi2_other_cutoff``).  The spread between the
    two (:func:`_model_spread`) enters the standard deviations of ``H`` and ``sigma_h``.

    ``errors``: the map geometry of G (:func:`xrough.acf.error_model`); the standard
    deviations of the parameters then carry the covariance of G's bins
    (:meth:`_ShapeProblem.sandwich`), otherwise they take the bins as independent.
    """
    kw = {"dr": dr, "use": use, "dr_ref": dr_ref, "weighted": weighted, "fixed": fixed,
          "lambda_0": lambda_0, "unit": unit,
          "cutoff": CUTOFFS[0] if cutoff == "auto" else cutoff}
    rel_cov = None if not errors else relative_covariance(dr, np.asarray(G, dtype=float),
                                                          **errors)
    kw["eq36"] = _eq36_fit(G, se, **kw)  # the start of every shape and cutoff: once
    if rolloff != "auto":
        out, theta = _fit_spectrum_shape(G, se, rolloff=rolloff, rel_cov=rel_cov,
                                         theta_out=True, **kw)
        out = _with_shape(out, ROLLOFFS.index(rolloff), np.nan)
    else:
        # the second shape starts where the first ended (its roll-off converted), without
        # restarts: the first shape's (from eq. 36 and the grid) searched the landscape
        sharp_fit, theta = _fit_spectrum_shape(
            G, se, rolloff=ROLLOFFS[0], theta_out=True, rel_cov=rel_cov, **kw)
        seed = _converted(theta, ROLLOFFS[0], ROLLOFFS[1])
        fits = [(sharp_fit, theta), _fit_spectrum_shape(
            G, se, rolloff=ROLLOFFS[1], seed=seed, rel_cov=rel_cov, theta_out=True, **kw)]
        sharp, smooth = (_aic(out, fixed, weighted) for out, _ in fits)
        k = 1 if smooth < sharp - AIC_MARGIN or (np.isinf(sharp) and np.isfinite(smooth)) else 0
        out, theta = fits[k]
        out = _with_shape(out, k, fits[1 - k][0][_AT["reduced_chi2"]])
        rolloff = ROLLOFFS[k]
    out[_AT["cutoff_shape"]] = CUTOFFS.index(kw["cutoff"])
    if cutoff != "auto" or not out[_AT["lambda_s_resolved"]] or out[_AT["quality"]] == 2 \
            or not np.isnan(fixed[2]):
        return out
    kw["cutoff"] = CUTOFFS[1]
    seed = theta.copy()
    seed[3] -= np.log(special.gamma(1 - theta[1]))  # the same shift of G beyond lambda_s
    try:
        gauss = _fit_spectrum_shape(G, se, rolloff=rolloff, seed=seed, rel_cov=rel_cov, **kw)
    except (ValueError, FloatingPointError, np.linalg.LinAlgError):
        return out  # a Gaussian search that breaks down does not cost the sharp fit
    gauss = _with_shape(gauss, int(out[_AT["rolloff_shape"]]),
                        out[_AT["reduced_chi2_other_rolloff"]])
    gauss[_AT["cutoff_shape"]] = 1
    fits = [out, gauss]
    aics = _cutoff_evidence(fits, fixed, weighted)
    k = 1 if aics[1] < aics[0] - AIC_MARGIN or (np.isinf(aics[0]) and np.isfinite(aics[1])) \
        else 0
    kept = fits[k]
    kept[_AT["reduced_chi2_other_cutoff"]] = fits[1 - k][_AT["reduced_chi2"]]
    _model_spread(kept, fits, aics)
    return kept


_AT = {name: k for k, name in enumerate(SPECTRUM_OUTPUTS)}


def _aic(out, fixed, weighted) -> float:
    """AIC of one fit's outputs (inf where it failed)."""
    chi2, n = out[_AT["reduced_chi2"]], int(out[_AT["n_bins"]])
    if not np.isfinite(chi2) or out[_AT["quality"]] == 2:
        return np.inf
    return information_criterion(chi2, n, int(np.count_nonzero(np.isnan(fixed))) + 1,
                                 weighted)


def _cutoff_evidence(fits, fixed, weighted) -> list[float]:
    """AIC of the cutoff shapes' fits, on the scale of their misfit where it is below G's errors.

    A weighted fit whose reduced chi^2 is below 1 misses G by less than G's standard
    errors say: those carry the scatter of the whole curve between surfaces (its bins
    move together), which no shape of the cutoff can follow, and leave little for the
    bins' misfit against each other.  Where the better fit's reduced chi^2 is below 1
    both are compared as unweighted fits are (``n ln(RSS/n) + 2 p``, the error scale
    estimated from the misfit): on 512^2 maps with lambda_s = 4 px the shape the surface
    was made with is then preferred by 20 to 60 in AIC, against 2 to 40 in chi^2.
    """
    chi2 = [f[_AT["reduced_chi2"]] for f in fits]
    scaled = weighted and np.nanmin(chi2) < 1.0
    return [_aic(f, fixed, weighted and not scaled) for f in fits]


#: The parameters whose standard deviation carries the spread between the cutoff shapes.
#: A spread of H beyond SHAPE_SPREAD_MAX (and beyond its statistical std) makes the fit
#: questionable: the H quoted depends on a choice the data do not make (a tie of two fits
#: 0.02 apart in H, as on an exact G with 5 % noise per bin, is not that).
SPREAD_PARAMETERS = ("hurst", "sigma_h")
SHAPE_SPREAD_MAX = 0.05


def _model_spread(kept, fits, aics) -> None:
    """Add the spread between the cutoff shapes' fits to ``kept``'s std (in place).

    Akaike weights ``w_i ~ exp(-AIC_i / 2)`` (Burnham & Anderson's model averaging): the
    variance about the kept value is ``sum_i w_i [s_i^2 + (p_i - p_kept)^2]``; a shape the
    data rule out (weight ~0) adds nothing.  ``H``'s variance in the covariance gains the
    same spread (the fitted gradient's error carries it).  Where the spread of ``H``
    exceeds its statistical std and :data:`SHAPE_SPREAD_MAX`, the problem
    ``cutoff_shape_undetermined`` is set: the self-affine range is too short to tell ``H``
    from the cutoff's shape.
    """
    a = np.array(aics, dtype=float)
    if not np.all(np.isfinite(a)):
        return
    w = np.exp(-(a - a.min()) / 2)
    w /= w.sum()
    for name in SPREAD_PARAMETERS:
        value, std = kept[_AT[name]], kept[_AT[f"{name}_std"]]
        others = np.array([f[_AT[name]] for f in fits])
        if not np.all(np.isfinite(others)):  # no plateau (sigma_h = inf): no spread to add
            continue
        spread2 = float(np.sum(w * (others - value) ** 2))
        if name == "hurst":
            kept[_AT["cov_hurst_hurst"]] += spread2
        if name == "hurst" and spread2 > max(std, SHAPE_SPREAD_MAX) ** 2:
            kept[_AT["fit_problems"]] = int(kept[_AT["fit_problems"]]) | (
                1 << PROBLEMS.index("cutoff_shape_undetermined"))
            kept[_AT["quality"]] = max(kept[_AT["quality"]],
                                       PROBLEM_LEVELS["cutoff_shape_undetermined"])
        kept[_AT[f"{name}_std"]] = np.sqrt(std**2 + spread2)


def _converted(theta, shape: str, to: str):
    """``theta`` of roll-off ``shape`` with the same ``lambda_r`` crossover in shape ``to``.

    The crossover of the two shapes' G lies at different multiples of their ``lambda_r``
    (:func:`rolloff_crossover`); a ``lambda_r`` at its floor (none) stays there.
    """
    theta = np.array(theta, dtype=float)
    H = theta[1]
    if theta[2] > _LN_FLOOR + 1e-9:
        ratio = rolloff_crossover(H, rolloff=shape) / rolloff_crossover(H, rolloff=to)
        theta[2] = max(theta[2] - (2 - 2 * H) * np.log(ratio), _LN_FLOOR)
    return theta


def _with_shape(out, shape, chi2_other):
    at = SPECTRUM_OUTPUTS.index("rolloff_shape")
    out[at], out[at + 1] = shape, chi2_other
    return out


class _Reached(Exception):
    """A search reached the known end ``k`` of an earlier one (:meth:`_ShapeProblem.solve`)."""

    def __init__(self, k):
        super().__init__(k)
        self.k = k


def _same_end(r, r_end, rss_end, dof) -> bool:
    """Whether the residuals ``r`` are (statistically) those of a known end of a search.

    The same curve: the sum of squared differences to ``r_end`` is below _REACHED times
    the reduced chi^2 there (a minute fraction of one standard error of the data, weighted
    or as the scatter estimates it); and no better fit than it (a search that is below the
    known end may be on its way to a lower minimum).
    """
    rss = float(r @ r)
    return rss >= rss_end and float(np.sum((r - r_end) ** 2)) < _REACHED * rss_end / dof


class _ShapeProblem:
    """The fit of the model spectrum of one roll-off shape to one G (one length unit).

    Optimiser parameters ``theta = [ln(G_sa/G_ref), H, ln eta, ln eps]`` with
    ``eta = (dr_max/lambda_r)^(2-2H)`` and ``eps = (lambda_s/dr_min)^(2H)``; lengths in
    units of ``dr_ref`` (``x = dr / dr_ref``).
    """

    def __init__(self, G, se, *, dr, use, dr_ref, weighted, fixed, rolloff, lambda_0, unit,
                 cutoff="sharp"):
        self.free, self.n, p, self.x, G_sel, self.G_ref, self.w, self.sel = _fit_data(
            G, se, dr=dr, use=use, dr_ref=dr_ref, weighted=weighted, fixed=fixed, unit=unit,
            what="the model spectrum")
        self.p, self.dof = p, self.n - p
        self.index = {int(k): i for i, k in enumerate(np.flatnonzero(self.free))}
        self.ly = np.log(G_sel / self.G_ref)
        self.g_max = _g_max(G_sel, self.w, weighted)
        self.x_lo, self.x_hi = float(self.x.min()), float(self.x.max())
        self.dr_ref, self.lambda_0, self.lam_0 = dr_ref, lambda_0, lambda_0 / dr_ref
        self.fixed, self.fix_r, self.fix_s = fixed, fixed[1] / dr_ref, fixed[2] / dr_ref
        self.weighted, self.rolloff, self.cutoff = weighted, rolloff, cutoff
        span = 2 * np.log(10 * self.x_hi / self.x_lo)
        self.lower = np.array([-np.inf, H_BOUNDS[0], _LN_FLOOR, _LN_FLOOR])
        self.upper = np.array([np.inf, H_BOUNDS[1], span, span])
        self.steps = np.array([0.0, 1e-5, 1e-5, 1e-5])
        self.u = 1.0 / self.w  # the column of the amplitude in the Jacobian
        self.uu = float(self.u @ self.u)
        self.memo = {}  # evaluations of eq. 9 (see _acf_shape)
        self.ends, self.outcomes = [], []  # of the first searches of the solves (solve)
        self.lost: set[bytes] = set()  # ends of solves that dropped a cutoff they needed

    def cutoffs(self, t):
        """``(lambda_r, lambda_s)`` of ``theta`` in units of ``dr_ref``."""
        with np.errstate(over="ignore", divide="ignore"):
            lr = self.x_hi * np.exp(-t[2] / (2 - 2 * t[1])) if self.free[2] else self.fix_r
            ls = self.x_lo * np.exp(t[3] / (2 * t[1])) if self.free[3] else self.fix_s
        if self.free[2]:  # far below the lags G is flat; eta at its bound with H near 1
            lr = max(lr, self.x_lo / _FAR_S)  # would underflow to lambda_r = 0 (C_r = 0)
        return min(lr, self.lam_0), ls

    def released(self, theta, active):
        """``theta`` with a fitted ``lambda_s`` at or beyond ``lambda_r`` moved just below it.

        :func:`_acf_shape` keeps ``lambda_s`` below ``lambda_r``: beyond, G does not depend
        on ``eps`` and a search could not move it (e.g. ``eps`` at ``H`` = 0.01, where
        ``lambda_s = dr_min eps^(1/(2H))``, after ``lambda_r`` was dropped).
        """
        if not (active[3] and self.free[3]):
            return theta
        lr, ls = self.cutoffs(theta)
        edge = (min(lr, _FAR_R * self.x_hi) if np.isinf(self.lam_0) else lr) / (1.0 + 1e-6)
        if ls < edge:
            return theta
        theta = theta.copy()
        theta[3] = np.clip(2 * theta[1] * np.log(0.9 * edge / self.x_lo), self.lower[3],
                           self.upper[3])
        return theta

    def residuals(self, t):
        return t[0] / self.w + self.deviations(t)

    def misfit(self, t) -> float:
        return _rms_misfit(self.residuals(t), self.w)

    def deviations(self, t):
        """``(ln G_model - ln G) / w`` without the amplitude ``t[0]`` (it adds ``t[0] / w``)."""
        lr, ls = self.cutoffs(t)
        return (np.log(_acf_shape(self.x, t[1], lr, ls, self.lam_0, self.rolloff,
                                  self.memo, self.cutoff))
                - self.ly) / self.w

    def slopes(self, t, active) -> dict:
        """``d deviations / d theta_k`` of the active cutoffs ``k`` (2, 3) in closed form.

        Only where :func:`_acf_shape_slopes` has one (a search takes a finite difference
        for the others and for ``H``): one evaluation of eq. 9 per step of a search instead
        of one per parameter.
        """
        if not (active[2] or active[3]):
            return {}
        H = float(t[1])
        lr, ls = self.cutoffs(t)
        out = {}
        with np.errstate(all="ignore"):  # a column that overflows is taken by differences
            slope_r, slope_s = _acf_shape_slopes(self.x, H, lr, ls, self.lam_0,
                                                 self.rolloff, self.cutoff)
            G = _acf_shape(self.x, H, lr, ls, self.lam_0, self.rolloff, self.memo,
                           self.cutoff)
            if active[2] and slope_r is not None:
                # lambda_r = x_hi exp(-ln eta / (2 - 2H)), unless held at a bound (cutoffs)
                raw = self.x_hi * np.exp(-t[2] / (2 - 2 * H))
                out[2] = slope_r * (-raw / (2 - 2 * H) if raw == lr else 0.0) / (G * self.w)
            if active[3] and slope_s is not None:  # lambda_s = x_lo exp(ln eps / (2H))
                out[3] = slope_s * ls / (2 * H) / (G * self.w)
        return {k: v for k, v in out.items() if np.all(np.isfinite(v))}

    def amplitude(self, d) -> float:
        """Return the amplitude ``t[0]`` minimising ``sum (t[0] / w + d)^2`` (``d``: deviations)."""
        return -float(self.u @ d) / self.uu

    def optimise(self, theta, active, ends=()):
        """Least squares over the ``active`` parameters, the others held at ``theta``.

        ``ends``: ``(residuals, chi^2)`` of known ends of searches; a search that reaches
        one (:func:`_same_end`) stops with :class:`_Reached` (its index).

        The amplitude ``theta[0]`` enters the residuals linearly (a column ``1/w``): it is
        solved for at each evaluation (variable projection), and the search runs over the
        other active parameters only, with the residuals and their Jacobian projected onto
        the complement of ``1/w``.  The same minimum, without the long narrow valley of
        the amplitude against ``H`` that the search over all four parameters zig-zags down.
        """
        profile = bool(active[0])
        rest = active.copy()
        rest[0] = False
        theta = np.array(theta, dtype=float)
        if not np.any(rest):
            if profile:
                theta[0] = self.amplitude(self.deviations(theta))
            return theta
        u = self.u
        cache = {}

        def full(t):
            out = theta.copy()
            out[rest] = t
            return out

        def project(v):
            return v - np.multiply.outer(u, u @ v) / self.uu if profile else v

        def dev(t):
            d = self.deviations(full(t))
            return d if profile else d + theta[0] * u

        def fun(t):
            cache["t"], cache["d"] = t.copy(), dev(t)
            r = project(cache["d"])
            for k, (r_end, rss_end) in enumerate(ends):
                if _same_end(r, r_end, rss_end, self.dof):
                    raise _Reached(k)
            return r

        def jac(t):
            d0 = cache["d"] if "t" in cache and np.array_equal(cache["t"], t) else dev(t)
            exact = self.slopes(full(t), rest)
            cols = []
            for i, k in enumerate(np.flatnonzero(rest)):
                if k in exact:
                    cols.append(exact[k])
                    continue
                h = self.steps[k] if t[i] + self.steps[k] <= self.upper[k] else -self.steps[k]
                tt = t.copy()
                tt[i] += h
                cols.append((dev(tt) - d0) / h)
            return project(np.column_stack(cols))

        res = optimize.least_squares(fun, theta[rest], jac=jac,
                                     bounds=(self.lower[rest], self.upper[rest]),
                                     method="trf", x_scale="jac", ftol=_FTOL, xtol=_XTOL,
                                     gtol=_GTOL, max_nfev=_MAX_NFEV)
        theta = full(res.x)
        if profile:
            d = (cache["d"] if "t" in cache and np.array_equal(cache["t"], res.x)
                 else dev(res.x))
            theta[0] = self.amplitude(d)
        return theta

    def linear_jacobian(self, t):
        """Jacobian in ``[ln(G_sa/G_ref), H, eta, eps]`` over the free parameters."""
        r0 = self.residuals(t)
        cols = []
        for k in np.flatnonzero(self.free):
            tt = t.copy()
            if k == 0:
                cols.append(1.0 / self.w)
                continue
            if k == 1:
                h = 1e-6 if t[1] + 1e-6 <= self.upper[1] else -1e-6
                tt[1] += h
            else:
                v = np.exp(t[k])
                h = 1e-6 * max(v, 1e-3)
                tt[k] = np.log(v + h)
            cols.append((self.residuals(tt) - r0) / h)
        return np.column_stack(cols), r0

    def covariance(self, theta):
        """Covariance of the free parameters at ``theta`` and the reduced chi^2."""
        J, r = self.linear_jacobian(theta)
        chi2 = float(np.sum(r**2)) / self.dof
        # unweighted: the residual scatter sets the error scale; weighted: the standard
        # errors do, inflated when the model does not describe the data within them
        return np.linalg.pinv(J.T @ J) * (max(1.0, chi2) if self.weighted else chi2), chi2

    def sandwich(self, theta, rel_cov, chi2):
        """Covariance of the free parameters for errors of ``ln G`` of covariance ``rel_cov``.

        The least-squares estimate moves by ``A^-1 J^T d`` for a change ``d`` of the
        residuals (``A = J^T J``), and the residuals ``(ln G_model - ln G) / w`` carry
        ``rel_cov / (w w^T)``: ``A^-1 J^T (D rel_cov D) J A^-1`` with ``D = 1/w``
        (:meth:`covariance` takes the bins as independent: G's are nearly rigidly
        correlated).  Inflated by the ratio of the squared residuals to what G's errors
        leave after the fit, where the model misses G beyond them.
        """
        J, r = self.linear_jacobian(theta)
        A = np.linalg.pinv(J.T @ J)
        d = 1.0 / self.w
        noise = d[:, None] * rel_cov * d[None, :]
        # the residuals the errors of G leave after the fit: (I - H) noise (I - H), H the
        # hat matrix; the misfit beyond them inflates (with G's errors mis-scaled, both
        # scale alike)
        left = np.eye(r.size) - J @ A @ J.T
        expected = float(np.trace(left @ noise @ left))
        misfit = float(r @ r) / expected if expected > 0 else np.inf
        return A @ (J.T @ noise @ J) @ A * max(1.0, misfit)

    def drop_unresolved(self, theta, active, cov_free, seen=(False,) * 4) -> bool:
        """Set the cutoffs the data do not resolve to none; whether one moved.

        ``seen``: cutoffs the fit needs (:meth:`needs`), kept whatever their std.
        """
        lr, ls = self.cutoffs(theta)
        # a cutoff beyond a decade outside the lags is an extrapolation: not resolved
        far = {2: lr > OUTSIDE * self.x_hi, 3: ls < self.x_lo / OUTSIDE}
        moved = False
        for k in (2, 3):
            if not active[k] or seen[k] or (k == 2 and np.isfinite(self.lam_0)):
                continue
            i = self.index[k]
            v, s = np.exp(theta[k]), np.sqrt(max(cov_free[i, i], 0.0))
            if far[k] or not v > max(_SIGNIFICANCE * s, _MIN_EFFECT):
                moved |= theta[k] > _LN_FLOOR + 1e-9
                theta[k], active[k] = _LN_FLOOR, False
        return moved

    def needs(self, theta, without) -> bool:
        """Whether the fit ``theta`` needs the roll-off that the refit ``without`` it lost.

        The test that dropped it is on the standard deviation of ``eta``, linear in it:
        right for a roll-off near none, not for one inside the lags (``eta`` of order 1,
        G changed by that much at the largest lag), whose std it overstates.  The roll-off
        is needed when the refit without it is worse by more than the same two standard
        deviations in chi^2 (a likelihood ratio, scaled as the covariance is), or when
        it misses G by more than MISS_FACTOR in a bin where the fit with it does not: a
        reader of the plot sees the plateau, whatever the chi^2.  The std and the chi^2
        are scaled by the misfit of the whole curve, and the roll-off's bins (the largest
        lags) have the widest errors: di-1.di (512^2, plane removed) levels off at its
        9.8 nm rms height, but the misfit of its first lags (reduced chi^2 13, where its
        scan axes differ) hid its roll-off (1.6 std, chi^2 worse by 1.7 times 13 without
        it), and the fit became a power law 3.8 times above G at the largest lag.
        """
        r, r_without = self.residuals(theta), self.residuals(without)
        rss = float(r @ r)
        scale = max(1.0, rss / self.dof) if self.weighted else rss / self.dof
        return (float(r_without @ r_without) - rss > _SIGNIFICANCE**2 * scale
                or _max_factor(r_without, self.w) > MISS_FACTOR >= _max_factor(r, self.w))

    def solve(self, theta):
        """Optimise from ``theta``, refitting after dropping cutoffs the data do not resolve.

        A first search that reaches the end of the first search of an earlier solve (see
        :meth:`optimise`) would go on as that one did: it stops there, and the solve
        returns that solve's result (a restart that funnels into a known minimum).
        """
        active = self.free.copy()
        try:
            theta = self.optimise(theta, active, self.ends)
        except _Reached as hit:
            theta, active, cov_free, chi2 = self.outcomes[hit.k]
            return theta.copy(), active.copy(), cov_free, chi2
        r_end = self.residuals(theta)
        rss, seen = np.inf, np.zeros(4, dtype=bool)
        # each pass drops a cutoff at least, or keeps the roll-off G shows: 4 suffice
        for _ in range(4):
            cov_free, chi2 = self.covariance(theta)
            if self.weighted and chi2 * self.dof - rss > _LOST_CHI2:  # it needed the cutoff
                self.lost.add(theta.tobytes())
            rss = chi2 * self.dof
            dropped, left = theta.copy(), active.copy()
            if not self.drop_unresolved(dropped, left, cov_free, seen):
                active = left  # a cutoff already at none is no longer active
                break
            # a refit after a cutoff was dropped may start where G ignores lambda_s
            refit = self.optimise(self.released(dropped, left), left)
            if active[2] and not left[2] and self.needs(theta, refit):
                seen[2] = True  # G shows the plateau: keep the roll-off, drop the rest
                continue
            theta, active = refit, left
        else:  # not reached (three passes at most), but the covariance must be theta's
            cov_free, chi2 = self.covariance(theta)
        if np.all(np.isfinite(r_end)):
            self.ends.append((r_end, float(r_end @ r_end)))
            self.outcomes.append((theta.copy(), active.copy(), cov_free, chi2))
        return theta, active, cov_free, chi2

    def physical(self, pv):
        """``[ln sigma_h, ln G_sa, H, ln lambda_r, ln lambda_s, ln C_r]`` (lateral unit)."""
        a, H, eta, eps = pv
        dr_ref, lambda_0 = self.dr_ref, self.lambda_0
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            lr, ls = self.cutoffs([a, H, np.log(eta), np.log(eps)])
            lr, ls = lr * dr_ref, ls * dr_ref
            c = (2 * np.pi * self.G_ref * np.exp(a) / dr_ref ** (2 * H)
                 / self_affine_constant(H))
            q_0 = 0.0 if np.isinf(lambda_0) else 2 * np.pi / lambda_0
            sigma2, C_r = _spectrum_moments(c, H, 2 * np.pi / lr, 2 * np.pi / ls, q_0,
                                            self.rolloff, self.cutoff)
            return np.array([0.5 * np.log(sigma2), a + np.log(self.G_ref), H, np.log(lr),
                             np.log(ls), np.log(C_r)])


def _shape_start(problem: _ShapeProblem, eq36) -> tuple[np.ndarray, float]:
    """Start from the fit of eq. 36, within the bounds; and the reduced chi^2 of eq. 36."""
    theta, chi2_eq36 = _spectrum_start(eq36, dr_ref=problem.dr_ref, rolloff=problem.rolloff,
                                       G_ref=problem.G_ref, x_lo=problem.x_lo,
                                       x_hi=problem.x_hi)
    if not problem.free[1]:
        theta[1] = problem.fixed[0]
    return np.clip(theta, problem.lower + 1e-3, problem.upper - 1e-3), chi2_eq36


def _best_solution(problem: _ShapeProblem, theta, chi2_eq36: float, seed=None) -> tuple:
    """Solve from ``theta`` and, if that fit is poor, from the best points of a grid.

    ``seed``: the end of the fit of the other roll-off shape (``rolloff="auto"``) or of
    the sharp cutoff (the Gaussian one), the only start: no restart from eq. 36's start
    and no grid (the first fit's restarts searched the landscape; a restart from eq. 36
    after a poor seeded search found no better fit on the real files or on the synthetic
    family of ``benchmarks/fit_false_alarms.py``).

    A fit that lost both cutoffs (dropped as unresolved) is a pure power law, which eq. 36
    contains: eq. 36 always fits it at least as well, and where the data resolve no cutoff
    every restart ends at the same power law.  Unless it is poor by itself (as a local
    minimum that lost its cutoffs is, e.g. chi^2 = 807 in the case of :data:`_GRID`), such
    a fit restarts only from the grid points that already fit better than it does.
    """
    def poor_alone(theta, chi2):
        if not problem.weighted:
            return problem.misfit(theta) > _RESTART_MISFIT
        # a fit that lost a cutoff the data needed (:meth:`_ShapeProblem.solve`) and
        # misses G beyond its errors sits in a local minimum (a 256^2 map, H 0.5,
        # lambda_s = 2 px: H 0.69 at reduced chi^2 3.5 from eq. 36's start, 0.53 at 0.097
        # from the grid)
        return chi2 > CHI2_QUESTIONABLE or (chi2 > _RESTART_CHI2_LOST
                                            and theta.tobytes() in problem.lost)

    def poor(theta, chi2):
        return chi2 > chi2_eq36 or poor_alone(theta, chi2)

    if seed is not None:
        return problem.solve(np.clip(seed, problem.lower + 1e-3, problem.upper - 1e-3))
    best = problem.solve(theta)
    if np.any(problem.free[1:]) and poor(best[0], best[3]):
        # a poor fit may sit in a local minimum (e.g. lambda_s beyond lambda_r): restart
        # from the best points of a coarse grid (amplitude solved for at each)
        starts = _grid_starts(best[0], problem.free, problem.lower, problem.upper,
                              problem.x, problem.ly, problem.w, problem.cutoffs,
                              problem.lam_0, problem.rolloff, problem.memo, problem.cutoff)
        power_law = problem.free[2] and problem.free[3] and not (best[1][2] or best[1][3])
        if power_law and not poor_alone(best[0], best[3]):
            starts = [(cost, t) for cost, t in starts if cost < best[3] * problem.dof]
        for _, start in starts:
            candidate = problem.solve(start)
            if candidate[3] < best[3] * (1 - 1e-6):
                best = candidate
            if not poor(best[0], best[3]):
                break
    return best


def _shape_parameters(problem: _ShapeProblem, theta, active, cov_free) -> tuple:
    """Read the parameters off ``theta``: values, std (lateral unit), resolved cutoffs."""
    free, fixed = problem.free, problem.fixed
    cov = np.zeros((4, 4))
    cov[np.ix_(free, free)] = cov_free
    lr_fit, _ = problem.cutoffs(theta)
    resolved_r = bool(active[2] and lr_fit < problem.lam_0 * (1 - 1e-9)) or not free[2]
    resolved_s = bool(active[3]) or not free[3]
    pvec = np.array([theta[0], theta[1],
                     np.exp(theta[2]) if resolved_r else 0.0,
                     np.exp(theta[3]) if resolved_s else 0.0])
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    values = problem.physical(pvec)
    grad = np.zeros((6, 4))
    with np.errstate(invalid="ignore"):  # inf - inf where there is no roll-off: NaN
        _gradients(problem.physical, pvec, values, free, sd, grad)
        rel = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", grad, cov, grad), 0.0))
    out = np.exp(values)
    out[2] = values[2]
    with np.errstate(invalid="ignore", over="ignore"):  # an error beyond float64: inf
        std = np.where(np.isfinite(out), out * rel, np.nan)
    std[2] = sd[1]
    if free[2] and not resolved_r:
        std[3] = np.nan
    if free[3] and not resolved_s:  # 2-sigma upper bound of lambda_s (< lambda_r)
        with np.errstate(over="ignore"):
            bound = problem.x_lo * problem.dr_ref * (_SIGNIFICANCE * sd[3]) ** (
                1 / (2 * theta[1]))
        out[4], std[4] = min(bound, out[3]), np.nan
    if free[2] and not resolved_r:
        out[3] = problem.lambda_0
    if not free[2]:
        out[3], std[3] = fixed[1], 0.0
    if not free[3]:
        out[4], std[4] = fixed[2], 0.0
    if free[3] and not resolved_s and out[4] > problem.x_hi * problem.dr_ref:
        out[4] = np.nan  # a bound beyond the lags says nothing
    return out, std, resolved_r, resolved_s


def _reference_covariance(problem: _ShapeProblem, theta, cov_free, resolved_r: bool,
                          resolved_s: bool) -> np.ndarray:
    """Return the covariance of the fit in :data:`COVARIANCE_PARAMETERS` (per ``dr_ref``).

    The fit's own ``eta``, ``eps`` are referred to its first and last bins (``x_hi``,
    ``x_lo``), which may differ between curves with missing bins: ``eta_ref = eta
    x_hi^-(2-2H)``, ``eps_ref = eps x_lo^(2H)``, and the covariance moves with their
    Jacobian (``H`` enters both).  A cutoff set to none keeps its variance: its effect
    within one standard deviation is the fit's uncertainty about it.
    """
    free = problem.free
    cov = np.zeros((4, 4))
    cov[np.ix_(free, free)] = cov_free
    H = theta[1]
    eta = np.exp(theta[2]) if resolved_r and free[2] else 0.0
    eps = np.exp(theta[3]) if resolved_s and free[3] else 0.0
    f_r, f_s = problem.x_hi ** -(2 - 2 * H), problem.x_lo ** (2 * H)
    T = np.eye(4)
    T[2, 1:3] = 2 * np.log(problem.x_hi) * eta * f_r, f_r
    T[3, [1, 3]] = 2 * np.log(problem.x_lo) * eps * f_s, f_s
    return T @ cov @ T.T


def _fit_spectrum_shape(G, se, *, seed=None, theta_out=False, rel_cov=None, **kw):
    """Fit the model spectrum of one roll-off shape to one G (see :func:`fit_spectrum_kernel`).

    Optimiser parameters ``theta = [ln(G_sa/G_ref), H, ln eta, ln eps]`` with
    ``eta = (dr_max/lambda_r)^(2-2H)`` and ``eps = (lambda_s/dr_min)^(2H)``: each of
    ``eta``, ``eps`` is, to leading order, the relative change of G at the end of the fitted
    range that its cutoff causes, linear in it once the cutoff lies outside the lags, and 0
    when there is no cutoff.  ``kw["fixed"] = [H, lambda_r, lambda_s]`` (NaN: free).
    """
    problem = _ShapeProblem(G, se, **{k: v for k, v in kw.items() if k != "eq36"})
    theta, chi2_eq36 = _shape_start(problem, kw["eq36"])
    theta, active, cov_free, chi2 = _best_solution(problem, theta, chi2_eq36, seed)
    if rel_cov is not None and np.all(np.isfinite(rel_cov)):
        sel = problem.sel
        cov_free = problem.sandwich(theta, rel_cov[np.ix_(sel, sel)], chi2)
    r = problem.residuals(theta)
    rms_misfit, max_factor = _rms_misfit(r, problem.w), _max_factor(r, problem.w)
    out, std, resolved_r, resolved_s = _shape_parameters(problem, theta, active, cov_free)
    free = problem.free
    bits, code = fit_problems(chi2, rms_misfit, out[2], weighted=problem.weighted,
                              dr_min=problem.x_lo * problem.dr_ref,
                              dr_max=problem.x_hi * problem.dr_ref, sigma_h=out[0],
                              lambda_r=out[3], lambda_s=out[4],
                              r_ok=resolved_r and free[2], s_ok=resolved_s and free[3],
                              hurst_free=bool(free[1]), chi2_other=chi2_eq36,
                              hurst_std=std[2], max_factor=max_factor,
                              g_max=problem.g_max, cutoff_std=(std[3], std[4]),
                              n_bins=problem.n, n_free=problem.p)
    cov = _reference_covariance(problem, theta, cov_free, resolved_r, resolved_s)
    if code == 2:  # the numbers mean nothing (but a fixed value stays what it was)
        keep = np.array([False, False, not free[1], not free[2], not free[3], False])
        out[~keep], std[~keep], cov[:] = np.nan, np.nan, np.nan
    values = np.array([*out, *std, chi2, problem.n, resolved_r, resolved_s, rms_misfit,
                       max_factor, chi2_eq36, np.nan, np.nan, bits, code, 0, np.nan,
                       *cov.ravel()],
                      dtype=float)
    return (values, theta) if theta_out else values


# --------------------------------------------------------------------------------------
# the checks of a fit
# --------------------------------------------------------------------------------------
def fit_problems(chi2, rms_misfit, hurst, *, weighted, dr_min, dr_max, sigma_h, lambda_r,
                 lambda_s, r_ok, s_ok, hurst_free, chi2_other=np.inf,
                 hurst_std=np.nan, max_factor=1.0, g_max=0.0,
                 cutoff_std=(np.nan, np.nan), n_bins=np.inf,
                 n_free=0) -> tuple[int, int]:
    """Return the problems of one fit (bits of :data:`PROBLEMS`) and its quality code.

    Code 0 good, 1 questionable, 2 failed (see :mod:`xrough.quality`).  ``dr_min``,
    ``dr_max``: the fitted lags; ``lambda_r``/``lambda_s`` (same unit) count only where
    ``r_ok``/``s_ok`` (resolved, fitted); ``chi2_other``: reduced chi^2 of the other
    model on the same bins (inf: none); ``hurst_std``: standard deviation of H;
    ``max_factor``: the largest factor between model and G over the fitted bins;
    ``g_max``: the largest G of the fitted bins less two standard errors (unit of
    ``sigma_h^2``), which no surface exceeds by ``2 sigma_h^2`` (``G = sigma_h^2 - C(dr)``,
    ``|C| <= sigma_h^2``); ``cutoff_std``: the standard deviations of ``lambda_r`` and
    ``lambda_s`` (a resolved cutoff with one beyond its value is not determined: zero
    lies within one error); ``n_bins``, ``n_free``: the bins fitted and the free
    parameters (the amplitude included).  Thresholds: :data:`CHI2_QUESTIONABLE`,
    :data:`CHI2_ALONE`, :data:`MISFIT_QUESTIONABLE`, :data:`MISFIT_FAILED`,
    :data:`MISS_FACTOR`, :data:`HURST_MARGIN`, :data:`HURST_SEPARATION`,
    :data:`OTHER_BETTER`, :data:`OUTSIDE`, :data:`HURST_STD_MAX`,
    :data:`MIN_BINS_PER_PARAMETER`.
    """
    found = set()
    if rms_misfit > MISFIT_QUESTIONABLE or (
            weighted and chi2 > CHI2_ALONE and rms_misfit > MISFIT_NEGLIGIBLE):
        found.add("poor_fit")
    if rms_misfit > MISFIT_FAILED:
        found.add("failed_fit")
    if max_factor > MISS_FACTOR:
        found.add("misses_data")
    if hurst_free and not (H_BOUNDS[0] + HURST_MARGIN < hurst < H_BOUNDS[1] - HURST_MARGIN):
        found.add("hurst_at_bound")
        if np.isfinite(hurst) and not (min(hurst - H_BOUNDS[0], H_BOUNDS[1] - hurst)
                                       >= HURST_SEPARATION * hurst_std):
            found.add("hurst_pinned")
    if n_bins < MIN_BINS_PER_PARAMETER * n_free:
        found.add("too_few_bins")
    if chi2 > CHI2_QUESTIONABLE and chi2_other * OTHER_BETTER < chi2:
        found.add("other_model_better")
    if (r_ok and lambda_r <= dr_min) or (s_ok and lambda_s >= dr_max) or (
            r_ok and s_ok and lambda_r < 2.0 * lambda_s):
        found.add("no_self_affine_range")
    if r_ok and lambda_r > OUTSIDE * dr_max:
        found.add("outside_range")
    if not (np.isfinite(hurst) and np.isfinite(chi2)) or np.isnan(sigma_h):
        found.add("not_finite")
    if hurst_free and not hurst_std <= HURST_STD_MAX and np.isfinite(hurst):
        found.add("hurst_undetermined")
    if np.isfinite(sigma_h) and g_max > 2.0 * sigma_h**2:
        found.add("sigma_h_below_data")
    std_r, std_s = cutoff_std
    if (r_ok and np.isfinite(std_r) and std_r >= lambda_r) or (
            s_ok and np.isfinite(std_s) and std_s >= lambda_s):
        found.add("cutoff_undetermined")
    bits = sum(1 << k for k, name in enumerate(PROBLEMS) if name in found)
    code = max((PROBLEM_LEVELS[name] for name in found), default=0)
    return bits, code


# --------------------------------------------------------------------------------------
# a fitted spectrum
# --------------------------------------------------------------------------------------
def _fitted_cutoffs(lam_r, lam_s, r_ok, s_ok, lam_0):
    """Cutoffs of the fitted spectrum: none where the data did not resolve them."""
    lr = lam_r if r_ok else lam_0
    ls = lam_s if s_ok else 0.0
    return lr, ls


def fitted_spectrum_acf(H, G_sa, lam_r, lam_s, r_ok, s_ok, shape, *, dr, dr_ref, lam_0):
    """G (eq. 9) at lags ``dr`` of one fitted spectrum (NaN where the fit failed).

    ``shape``: the roll-off and cutoff, :func:`~.spectral_models.shape_code` (variables
    ``rolloff_shape`` and ``cutoff_shape``).
    """
    if not (np.isfinite(H) and np.isfinite(G_sa)):
        return np.full(dr.shape, np.nan)
    rolloff, cutoff = shape_names(shape)
    lr, ls = _fitted_cutoffs(lam_r, lam_s, r_ok, s_ok, lam_0)
    return G_sa * _acf_shape(dr / dr_ref, H, lr / dr_ref, ls / dr_ref, lam_0 / dr_ref,
                             rolloff, cutoff=cutoff)


def fitted_spectrum_gradient(H, G_sa, lam_r, lam_s, r_ok, s_ok, shape, *, dr, dr_ref, lam_0,
                             g_factor):
    """Gbar (eq. 26, closed form) at lags ``dr`` of one fitted spectrum (NaN if it failed).

    ``shape``: the roll-off and cutoff (:func:`~.spectral_models.shape_code`); ``g_factor``
    converts ``G_sa`` to the lateral unit squared.
    """
    if not (np.isfinite(H) and np.isfinite(G_sa)):
        return np.full(dr.shape, np.nan)
    rolloff, cutoff = shape_names(shape)
    lr, ls = _fitted_cutoffs(lam_r, lam_s, r_ok, s_ok, lam_0)
    c = 2 * np.pi * G_sa * g_factor / dr_ref ** (2 * H) / self_affine_constant(H)
    with np.errstate(divide="ignore"):
        q_r, q_s, q_0 = 2 * np.pi / np.array([lr, ls, lam_0], dtype=float)
    return np.sqrt(model_gradient2(2 * np.pi / dr, c=c, hurst=H, q_r=q_r, q_s=q_s,
                                   q_0=q_0, rolloff=rolloff, cutoff=cutoff))


def fitted_spectrum_gradient_std(H, G_sa, lam_r, lam_s, r_ok, s_ok, shape, cov, *, dr,
                                 dr_ref, lam_0, g_factor):
    """Relative standard deviation of :func:`fitted_spectrum_gradient` at lags ``dr``.

    ``cov``: the fit's covariance in :data:`COVARIANCE_PARAMETERS` (the parameters of
    :func:`fit_spectrum_kernel`, linear in a cutoff that the data barely resolve), carried
    through eq. 26 of the fitted spectrum: ``var ln gbar = J cov J^T`` with ``J`` from
    central differences at a thousandth of each standard deviation.  A cutoff the data do
    not resolve (``eta`` or ``eps`` = 0, at its bound) is one-sided: its column is the
    secant over one standard deviation, the change of gbar that the fit cannot exclude
    (its tangent at none is 0 on every lag the cutoff does not reach).  NaN where the
    fit failed or has no covariance.
    """
    cov = np.asarray(cov, dtype=float)
    if not (np.isfinite(H) and np.isfinite(G_sa)) or not np.all(np.isfinite(cov)):
        return np.full(np.shape(dr), np.nan)
    lr, ls = _fitted_cutoffs(lam_r, lam_s, r_ok, s_ok, lam_0)
    p0 = np.array([0.0, H, (dr_ref / lr) ** (2 - 2 * H) if np.isfinite(lr) and r_ok else 0.0,
                   (ls / dr_ref) ** (2 * H) if s_ok and ls > 0 else 0.0])

    def ln_gbar(p):
        with np.errstate(divide="ignore", over="ignore"):
            lr_p = dr_ref * p[2] ** (-1 / (2 - 2 * p[1])) if p[2] > 0 else np.inf
            ls_p = dr_ref * p[3] ** (1 / (2 * p[1])) if p[3] > 0 else 0.0
        return np.log(fitted_spectrum_gradient(
            p[1], G_sa * np.exp(p[0]), min(lr_p, lam_0), ls_p, p[2] > 0, p[3] > 0, shape,
            dr=dr, dr_ref=dr_ref, lam_0=lam_0, g_factor=g_factor))

    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    base = ln_gbar(p0)
    J = np.zeros((np.size(dr), 4))
    for k in np.flatnonzero(sd > 0):
        h = 1e-3 * sd[k]
        up = p0.copy()
        if k >= 2 and p0[k] < h:  # at (or within a step of) no cutoff: one-sided
            up[k] += sd[k] if p0[k] == 0 else h
            J[:, k] = (ln_gbar(up) - base) / (up[k] - p0[k])
            continue
        down = p0.copy()
        up[k] += h
        down[k] -= h
        J[:, k] = (ln_gbar(up) - ln_gbar(down)) / (2 * h)
    with np.errstate(invalid="ignore"):
        return np.sqrt(np.maximum(np.einsum("ik,kl,il->i", J, cov, J), 0.0))
