"""Scale-dependent rms gradient of one G curve (eq. 26), by every route (pure numpy/scipy).

* :func:`exact_gradient`: eq. 26 of the spectrum of G (eq. 10/11), with the range of lags
  where the data determine it;
* :func:`auto_gradient`: the exact gradient where it covers at least half of the lags of G,
  else eq. 26 of the fitted model spectrum, else the ballistic ``sqrt(4 G / dr^2)``; the
  per-curve choice is returned as a code (:data:`AUTO_METHODS`), with the problems of the
  fit and a quality code (:mod:`xrough.quality`).

All lengths in one unit; G in its square.
"""

from __future__ import annotations

import numpy as np

from .acf_curve import require_acf
from .binning import log_range
from .deferred import optimize
from .fitting import (
    PROBLEMS,
    SPECTRUM_OUTPUTS,
    fit_covariance,
    fit_spectrum_kernel,
    fitted_spectrum_gradient,
    fitted_spectrum_gradient_std,
)
from .hankel import power_law_moment_kernel
from .spectral_models import shape_code
from .spectrum_of_acf import (
    principal_axes,
    smooth_acf_kernel,
    spectrum_from_acf_kernel,
    spectrum_variants_kernel,
    supported_interval,
)
from .uncertainty import PREDICTION_PER_DECADE, relative_covariance

__all__ = ["AUTO_METHODS", "BEYOND_RESOLUTION", "beyond_resolution", "EVEN_START",
           "EVEN_SERIES_CORRECTION", "EVEN_THREE", "EVEN_AGREE", "exact_gradient",
           "exact_support", "exact_on_lags", "auto_gradient", "even_start", "with_even_start",
           "simple_gradient", "gradient_std"]

#: Share of the variance of ``ln G`` whose principal axes carry the error of gbar: 99 %
#: leaves 5-10 % of the scatter at one pixel out (which lives in the smallest axes), all
#: of them cost twice the time for 1-2 % more (256^2 maps, 100 seeds).
GRADIENT_ERROR_CAPTURED = 0.999
#: At most this many axes are propagated through eq. 26 (5-10 on maps, whose bins are
#: nearly rigidly correlated; up to 26 on long profiles); the variance left
#: over, mostly of single bins, enters as the ballistic response (half the relative
#: error of G at the lag).
GRADIENT_ERROR_AXES = 8

#: A fitted gradient at the first lag that owes more than this share of its square to
#: wavelengths below two lags (beyond the data's Nyquist wavenumber) is the model's, not the
#: data's: the curve is questionable.  A map through a Gaussian transfer at one pixel
#: (512^2, H 0.3) gave such a gbar 8 % above the map's own full gradient, rated good, with
#: a third of its square there (H 0.05: 1.9 % above, 22-24 % there); a cutoff the map
#: resolves (at 4 pixels) puts < 1 % there, eq. 35's sharp cutoff at two pixels (H 0.1)
#: 11 % with gbar right to 0.5 %.  A power law at the first lags puts ``1 - 2^-(2-2H)``
#: there (H 0.3: 62 %, 0.7: 34 %, 0.85: 19 %).
BEYOND_RESOLUTION = 0.2

#: Codes of the route :func:`auto_gradient` took, per curve.
AUTO_METHODS = ("exact", "fit", "simple", "exact+fit", "exact+simple")

#: G is a smooth surface's even expansion ``a dr^2 + b dr^4`` at its first lags when
#: ``|b| dr^2 / a`` is at most ``EVEN_START[0]`` there: eq. 26's full gradient ``4 a``
#: (corrected by :data:`EVEN_SERIES_CORRECTION`) is then gbar there, its weight falling
#: linearly to 0 at ``EVEN_START[1]``. On 512^2 maps (H 0.1-0.8; sharp, smooth and
#: Gaussian short cutoffs at 2-8 px; two seeds) the ratio at one pixel is 0.01-0.19, and
#: the corrected ``sqrt(4 a)`` is within 0.35 % of the map's spectral gradient at every
#: ratio; the fitted spectrum (a sharp cutoff) was 0.9-2.1 % low on the smooth and
#: Gaussian cutoffs (z -1.2 to -1.7 of its stated error), and eq. 26 of the spectrum of G
#: does not reach one pixel there.
EVEN_START = (0.15, 0.20)
#: The two- or three-term series through the first bins leaves out the next term
#: (``+ c dr^6``, ``c = m6 / 2304``), which lowers ``a`` by about ``K (b/a)^2`` with
#: ``K = m2 m6 / m4^2 >= 1``: ``sqrt(4 a)`` is then low by ``EVEN_SERIES_CORRECTION
#: (|b| dr^2 / a)^2``. Measured 0.50 (the bias of ``sqrt(4 a)`` over the maps above, ratio
#: 0.05-0.19); corrected, the largest error is 0.35 % against 1.5 % uncorrected.
EVEN_SERIES_CORRECTION = 0.5
#: ``a`` from the two terms up to a ratio of ``EVEN_THREE[0]``, from three (through the
#: third bin as well) from ``EVEN_THREE[1]``: the two are within 0.01 % of the lattice's
#: gbar at ``lambda_s`` = 8 px (ratio 0.01) and 0.1-0.2 % at 4 px (0.03-0.05), where the
#: three are within 0.02 %; but the third bin of a map mixes lattice radii (2 and sqrt 5
#: px), whose mean square differs from the square of their mean by 0.3 %, which a third
#: term through it turns into several percent on a surface with little curvature (4 % on
#: two cosines of 32 px).
EVEN_THREE = (0.02, 0.03)
#: Where three terms take part, they must agree with the two within ``EVEN_AGREE[0]``
#: (the weight falling to 0 at ``EVEN_AGREE[1]``): on a smooth surface they differ by
#: about the square of that ratio (0.2 % at ``lambda_s`` = 4 px, 0.5 % at 3 px; 0.2-1.7 %
#: on the profiles of the test data, whose third bin lies at three pixels); a G that
#: bends or zig-zags over its first three bins (the axis and diagonal lags of a map whose
#: scan lines differ: 10 % on the UNCD AFM map) is no smooth surface's.
EVEN_AGREE = (0.02, 0.04)


def _cumulative(q, values):
    """gbar^2 at every grid q: C flat below the grid, a power law between points."""
    below = values[0] * q[0] ** 4 / (8.0 * np.pi)
    return below + power_law_moment_kernel(q, q, values, 2, nonpositive="linear")


def exact_support(dr, g, noise, *, smooth, support_rtol, interpolation) -> tuple[float, float]:
    """Lags ``(dr_lo, dr_hi)`` where eq. 26 of the spectrum of G is determined (NaN: none).

    ``dr``, ``g``, ``noise``: the valid bins (``dr > 0``). The extrapolation variants of the
    spectrum (the end slopes of G turning sooner or later), leaving out C below the grid,
    and the noise may change ``gbar`` by at most ``support_rtol`` (the largest change within
    +-0.2 decades counts).
    """
    lo, hi = 0.02 * np.pi / dr[-1], 2 * np.pi / dr[0]
    q = log_range(lo, hi, 10)
    base, extrapolated, noisy = spectrum_variants_kernel(
        q, dr, g, noise=noise, smooth=smooth, interpolation=interpolation)
    total = _cumulative(q, base)
    below = np.abs(base[0] * q[0] ** 4 / (8.0 * np.pi))
    variants = [_cumulative(q, v) for v in extrapolated] + [total - below]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = np.sqrt(np.maximum(np.array(variants), 0.0) / total)
        change = np.max(np.abs(ratios - 1.0), axis=0)
        if noisy.shape[0]:
            sample = np.sqrt(np.maximum([_cumulative(q, v) for v in noisy], 0.0) / total)
            change = np.maximum(change, np.std(sample, axis=0))
        change = np.where(total > 0, change, np.inf)
    q_lo, q_hi = supported_interval(q, change, support_rtol, envelope=0.2)
    if not np.isfinite(q_lo):
        return np.nan, np.nan
    return 2 * np.pi / q_hi, 2 * np.pi / q_lo


def exact_gradient(dr, g, dr_out, *, smooth, interpolation, points_per_decade,
                   order: int = 8) -> np.ndarray:
    """``gbar`` (eq. 26 of the spectrum of G, eq. 10/11) at ``dr_out``; NaN where gbar^2 <= 0.

    ``dr``, ``g``: the valid bins of G (``dr > 0``, G > 0).  ``gbar^2`` integrates
    ``q^3 C >= 0`` up to ``2 pi / dr``, so it cannot rise with ``dr``; where the spectrum
    of G rings around a sharp cutoff (negative lobes beyond ``q_s``, which ten bins per
    decade cannot resolve), it would rise by up to 1-1.5 %.  ``gbar^2`` over ``dr_out`` is
    therefore the non-increasing curve nearest to it in least squares (isotonic
    regression, :func:`scipy.optimize.isotonic_regression`): a projection onto what eq. 26
    allows, which averages the ringing and leaves a curve that already falls unchanged.
    ``order``: of the Gauss-Legendre panels of :func:`spectrum_from_acf_kernel`.
    """
    lo, hi = 0.02 * np.pi / dr[-1], 2 * np.pi / dr[0]
    q = log_range(lo, hi, points_per_decade)
    gs = g if smooth is None else smooth_acf_kernel(dr, g, smooth)
    values = spectrum_from_acf_kernel(q, dr, gs, interpolation=interpolation, order=order)
    dr_out = np.asarray(dr_out, dtype=float)
    gbar2 = values[0] * q[0] ** 4 / (8.0 * np.pi) + power_law_moment_kernel(
        2 * np.pi / dr_out, q, values, 2, nonpositive="linear")
    gbar2 = nonincreasing_in_lag(dr_out, gbar2)
    with np.errstate(invalid="ignore"):
        return np.where(gbar2 > 0, np.sqrt(np.abs(gbar2)), np.nan)


def nonincreasing_in_lag(dr, values) -> np.ndarray:
    """Return the curve nearest to ``values`` (least squares) that does not rise with dr.

    Isotonic regression over the finite, positive values, in the order of ``dr``; the
    others are returned as they are.
    """
    values = np.array(values, dtype=float)
    use = np.flatnonzero(np.isfinite(values) & (values > 0))
    if use.size > 1:
        order = use[np.argsort(np.asarray(dr, dtype=float)[use], kind="stable")]
        values[order] = optimize.isotonic_regression(values[order], increasing=False).x
    return values


def gradient_std(g, gbar=None, fitted=None, *, dr, errors: dict, ballistic: bool = False,
                 smooth=None, interpolation: str = "hermite") -> np.ndarray:
    """Relative statistical standard deviation of gbar on every lag of one G curve.

    ``errors``: the map geometry of G, the keywords of
    :func:`~xrough._kernels.uncertainty.relative_covariance` (the covariance of the
    relative errors of G's bins). The ballistic ``gbar = sqrt(4 G) / dr``
    (``ballistic=True``) has half the relative error of G at its lag. Otherwise the
    response of the exact gradient (eq. 26 of eq. 10/11, :func:`exact_gradient`) on every
    valid lag, also where G does not determine its value: linear propagation along the
    principal axes of the covariance (:data:`GRADIENT_ERROR_CAPTURED` of its trace), ``g``
    moved by one standard deviation along each, the changes of gbar added in quadrature,
    on the grid of :data:`~xrough._kernels.uncertainty.PREDICTION_PER_DECADE` (the error
    of an error: 2-5 % against 40 per decade, at a quarter of the cost), at most
    :data:`GRADIENT_ERROR_AXES` of them, the variance of the rest as the ballistic
    response; the ballistic value where the exact gradient has none.  ``fitted``: the
    relative error of gbar on the lags where the fitted model gives it (NaN elsewhere;
    :func:`~xrough._kernels.fitting.fitted_spectrum_gradient_std`, the fit's response to
    G's errors), which stands there.  NaN at invalid lags and where the
    covariance cannot be formed.  ``gbar``: the values of :func:`auto_gradient`, whose
    even start (:func:`with_even_start`) has the error of ``sqrt(4 a)`` (half the
    relative error of ``a``, linear in the first three bins of G), by its weight at the
    first lags and on the lags it caps.
    """
    g = np.asarray(g, dtype=float)
    out = np.full(dr.shape, np.nan)
    ok = np.isfinite(g) & (g > 0) & (dr > 0)
    if ok.sum() < 4:
        return out
    r, v = dr[ok], g[ok]
    cov = relative_covariance(dr, g, **errors)[np.ix_(ok, ok)]  # as the fit and energy
    if not np.all(np.isfinite(cov)):
        return out
    out[ok] = 0.5 * np.sqrt(np.diag(cov))  # ballistic: gbar ~ sqrt(G)
    if ballistic:
        return out
    fit = np.full(dr.shape, np.nan) if fitted is None else np.asarray(fitted, dtype=float)
    if np.all(np.isfinite(fit[ok])):  # the fit gives every lag: no exact response needed
        out[ok] = fit[ok]
        return out if gbar is None else _even_start_std(out, g, np.asarray(gbar), dr, errors)
    # order-4 panels: the errors move by 2e-6 to 1e-3 of themselves against order 8 on
    # the test files, at 3/4 of the cost
    options = dict(smooth=smooth, interpolation=interpolation,
                   points_per_decade=PREDICTION_PER_DECADE, order=4)
    try:
        base = exact_gradient(r, v, r, **options)
    except ValueError:
        return out
    scale, axes = principal_axes(cov, v.size, GRADIENT_ERROR_CAPTURED)
    scale, axes = scale[:GRADIENT_ERROR_AXES], axes[:, :GRADIENT_ERROR_AXES]
    var = np.zeros(r.shape)
    for k in range(scale.size):
        var += (exact_gradient(r, v * np.exp(scale[k] * axes[:, k]), r, **options)
                - base) ** 2
    left = np.diag(cov) - np.einsum("ik,k->i", axes**2, scale**2)  # not propagated
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.sqrt(var / base**2 + 0.25 * np.maximum(left, 0.0))
    out[ok] = np.where(np.isfinite(rel) & (base > 0), rel, out[ok])
    out = np.where(np.isfinite(fit), fit, out)
    return out if gbar is None else _even_start_std(out, g, np.asarray(gbar), dr, errors)


def _even_start_std(rel, g, gbar, dr, errors):
    """Relative errors ``rel`` of a gbar with :func:`even_start`, where it took part."""
    full, weight, d_ln_a, sys = even_start(dr, g)
    if not np.isfinite(full):
        return rel
    cov = np.nan_to_num(relative_covariance(dr, g, **errors))
    own = np.hypot(0.5 * np.sqrt(max(float(d_ln_a @ cov @ d_ln_a), 0.0)), sys)
    w0 = _first_weight(weight)
    with np.errstate(invalid="ignore"):
        capped = (weight == 0) & (np.abs(gbar / full - 1.0) < 1e-9)
    share = np.where(capped, w0, weight)
    return np.where(share > 0, (1.0 - share) * rel + share * own, rel)


def even_start(dr, g) -> tuple[float, np.ndarray, np.ndarray, float]:
    """Return the full gradient of a G that is smooth at its first lags, and where it holds.

    A smooth surface's G starts as the even series ``a dr^2 + b dr^4 + c dr^6`` (``a = m2 /
    4``, ``b = -m4 / 64``, ``c = m6 / 2304`` with the moments ``m_n = (1/2pi) int q^(n+1) C
    dq``), and eq. 26 at lags where it holds is the full gradient, ``gbar^2 = m2 = 4 a``,
    the largest gbar of any lag. Whether it holds: ``|b| dr^2 / a`` of the two terms
    through the first two valid bins (:data:`EVEN_START`). ``a`` comes from those two
    terms where that ratio is at most :data:`EVEN_THREE` [0], from the three terms through
    the first three bins from :data:`EVEN_THREE` [1] (linear between), and the three must
    agree with the two (:data:`EVEN_AGREE`). Returns ``(gbar, weight, d_ln_a, sys)``:
    ``gbar = sqrt(4 a)`` raised by :data:`EVEN_SERIES_CORRECTION` for the term the series
    leaves out; the weight per lag (on the first two valid bins, 0 elsewhere, and 0
    everywhere when ``a <= 0`` or ``b > 0``, which no surface's G has); the derivatives of
    ``ln a`` with respect to ``ln G`` per bin (for its statistical error); and ``sys``,
    the relative uncertainty of that correction (half of it). NaN and zeros when there
    are fewer than two valid bins.
    """
    dr, g = np.asarray(dr, dtype=float), np.asarray(g, dtype=float)
    weight, d_ln_a = np.zeros(dr.shape), np.zeros(dr.shape)
    first = np.flatnonzero(np.isfinite(g) & (g > 0) & (dr > 0))[:3]
    if first.size < 2:
        return np.nan, weight, d_ln_a, np.nan
    # in units of the first lag and of G there: the same numbers in nm, m or km
    x, v = dr[first] / dr[first[0]], g[first] / g[first[0]]
    two_terms = np.linalg.inv(np.c_[x[:2] ** 2, x[:2] ** 4])
    a2, b2 = two_terms @ v[:2]
    if not (a2 > 0 and b2 <= 1e-9 * a2):  # b > 0 beyond round-off
        return np.nan, weight, d_ln_a, np.nan
    ratio = abs(b2) / a2  # |b| dr^2 / a at the first lag
    three = float(1.0 - _ramp(ratio, EVEN_THREE)) if first.size == 3 else 0.0
    row = np.r_[two_terms[0], 0.0][:first.size]  # a = row @ v
    agree = 1.0
    if three > 0:
        row3 = np.linalg.inv(np.c_[x**2, x**4, x**6])[0]
        agree = float(_ramp(abs((row3 @ v) / a2 - 1.0), EVEN_AGREE))
        row = (1.0 - three) * row + three * row3
    a = float(row @ v)
    if not a > 0:
        return np.nan, weight, d_ln_a, np.nan
    two = first[:2]
    weight[two] = _ramp(ratio * x[:2] ** 2, EVEN_START) * (1.0 - three * (1.0 - agree))
    d_ln_a[first] = row * v / a
    a *= g[first[0]] / dr[first[0]] ** 2
    correction = float(EVEN_SERIES_CORRECTION * ratio**2)
    return float(np.sqrt(4.0 * a) * (1.0 + correction)), weight, d_ln_a, 0.5 * correction


def _ramp(x, limits):
    """1 up to ``limits[0]``, 0 from ``limits[1]``, linear between."""
    lo, hi = limits
    return np.clip((hi - np.asarray(x, dtype=float)) / (hi - lo), 0.0, 1.0)


def _first_weight(weight: np.ndarray) -> float:
    """Return the weight of :func:`even_start` at the first lag (0: none anywhere)."""
    return float(weight[np.flatnonzero(weight)[0]]) if np.any(weight) else 0.0


def with_even_start(gbar, dr, g, start=None) -> np.ndarray:
    """``gbar`` of one curve with :func:`even_start`: the full gradient where G is smooth.

    At the first lags, ``gbar`` is moved to ``sqrt(4 a)`` by the weight there; at every
    lag, a ``gbar`` above it (which eq. 26 does not allow: gbar^2 <= m2) is lowered to it
    by the weight at the first lag.  ``start``: :func:`even_start` of this curve, if known.
    """
    full, weight, _, _ = even_start(dr, g) if start is None else start
    gbar = np.array(gbar, dtype=float)
    if not np.isfinite(full):
        return gbar
    gbar = (1.0 - weight) * gbar + weight * full
    w0 = _first_weight(weight)
    excess = np.where(np.isfinite(gbar), np.maximum(gbar - full, 0.0), 0.0)
    return gbar - w0 * excess


def simple_gradient(dr, g) -> np.ndarray:
    """``sqrt(4 G / dr^2)``, the ballistic approximation of eq. 26 (NaN at ``dr = 0``)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(dr > 0, np.sqrt(4.0 * g / np.where(dr > 0, dr, 1.0) ** 2), np.nan)


def exact_on_lags(g, noise, *, dr, smooth, support_rtol, interpolation,
                  points_per_decade) -> np.ndarray:
    """Compute the exact gbar on every lag of one G curve, NaN outside the supported lags."""
    require_acf(dr, g, min_bins=4)
    ok = np.isfinite(g) & (dr > 0)
    r, v = dr[ok], g[ok]
    out = np.full(dr.shape, np.nan)
    if ok.sum() < 4:
        return out
    try:
        dr_lo, dr_hi = exact_support(r, v, noise[ok], smooth=smooth, support_rtol=support_rtol,
                                     interpolation=interpolation)
    except ValueError:
        return out
    if not np.isfinite(dr_lo):
        return out
    tol = 1e-9 * dr_hi
    inside = ok & (dr >= dr_lo - tol) & (dr <= dr_hi + tol)
    if inside.any():
        out[inside] = exact_gradient(r, v, dr[inside], smooth=smooth,
                                     interpolation=interpolation,
                                     points_per_decade=points_per_decade)
    return out


def auto_gradient(g, se, noise, fitted=None, fitted_std=None, *, dr, exact: dict,
                  fit: dict | None, fit_gradient: dict | None
                  ) -> tuple[np.ndarray, np.ndarray, int, int, int, int, float]:
    """Gbar of one curve by the first route that covers it, the route, and why.

    The exact gradient where G determines it; if that is fewer than half of the valid
    lags, the fitted spectrum's gradient everywhere; the fit also fills the lags the exact
    gradient leaves open (code 3); the ballistic form where no fit succeeds (code 2, or 4
    on the lags the exact gradient leaves open).  A fit that its checks rate failed
    (:func:`~xrough._kernels.fitting.fit_problems`) counts as no fit.
    ``fitted``: the gradient of a fit already made on the lags ``dr`` (then no fit runs),
    ``fitted_std`` its relative error (NaN: none);
    ``exact``: options of :func:`exact_on_lags`; ``fit``/``fit_gradient``: options of
    :func:`~xrough._kernels.fitting.fit_spectrum_kernel` (with its lags ``dr``) and
    :func:`~xrough._kernels.fitting.fitted_spectrum_gradient` (None: no fit), as
    :class:`xrough.fitting.FitSetup` makes them.

    Whatever the route, where G is a smooth surface's at its first lags, gbar there is
    eq. 26's full gradient and no lag's gbar exceeds it (:func:`with_even_start`): the
    spectrum of G rings by up to 1 % there at a sharp cutoff, and a fitted model that puts
    roughness below the scales G resolves gave up to twice the full gradient.

    Where the fitted model gives gbar at the first lag and puts more than
    :data:`BEYOND_RESOLUTION` of its ``gbar^2`` there at wavelengths shorter than two first
    lags (beyond the Nyquist wavenumber of a map with that pixel: the data hold no such
    wavelength, the model extends them), the curve is questionable and ``share`` says how
    much (NaN otherwise).

    Returns ``(gbar, fit_std, route, n_exact, fit_problems, quality, share)``: ``fit_std`` the
    relative error of gbar where the fitted model gives it (NaN elsewhere; see
    :func:`~xrough._kernels.fitting.fitted_spectrum_gradient_std`), the route's code in
    :data:`AUTO_METHODS`, the number of lags the exact gradient covers, the problem bits of
    the fit made here (-1: none made) and the quality code (0 good; 1 questionable: the
    fit was questionable or the ballistic form was used; 2 failed: no lag determined).
    """
    gbar, fit_std, route, n_exact, bits, level, share = _auto_route(
        g, se, noise, fitted, fitted_std, dr=dr, exact=exact, fit=fit,
        fit_gradient=fit_gradient)
    start = even_start(dr, g)
    if _first_weight(start[1]) > 0 or not (np.isfinite(share) and share > BEYOND_RESOLUTION):
        share = np.nan  # the first lag is G's own (its even start), or the fit's is resolved
    else:
        level = max(level, 1)
    return (with_even_start(gbar, dr, g, start), fit_std, route, n_exact, bits, level,
            share)


#: The fit's problem bit of a G with too few bins for its parameters: the ballistic form on
#: such a G (sdf-1.sdf, 4 x 7 points) gives numbers that mean nothing.
TOO_FEW_BINS = 1 << PROBLEMS.index("too_few_bins")


def _auto_route(g, se, noise, fitted, fitted_std, *, dr, exact, fit, fit_gradient):
    """:func:`auto_gradient` before its even start (``share``: :func:`beyond_resolution`)."""
    valid = np.isfinite(g) & (dr > 0)
    none = np.full(dr.shape, np.nan)
    out = exact_on_lags(g, noise, dr=dr, **exact)
    covered = np.isfinite(out) & valid
    n_exact = int(covered.sum())
    if n_exact == valid.sum():
        return out, none, 0, n_exact, -1, 0, np.nan
    use_exact = 2 * n_exact >= valid.sum()
    bits, fit_code = -1, 0
    if fitted is None:
        fitted, fitted_std, bits, fit_code = _fit_gradient(g, se, dr, fit, fit_gradient)
    if fitted is not None and np.all(np.isfinite(fitted[valid])):
        taken = valid & ~covered if use_exact else valid
        std = none if fitted_std is None else np.where(taken, fitted_std, np.nan)
        share = beyond_resolution(dr, fitted, taken)
        if use_exact:
            return (np.where(covered, out, np.where(valid, fitted, np.nan)), std, 3, n_exact,
                    bits, fit_code, share)
        return np.where(valid, fitted, np.nan), std, 1, n_exact, bits, fit_code, share
    if not use_exact and bits > 0 and bits & TOO_FEW_BINS:
        return none, none, 2, n_exact, bits, 2, np.nan  # G has too few bins for any gbar
    simple = simple_gradient(dr, g)
    if use_exact:
        gbar = np.where(covered, out, np.where(valid, simple, np.nan))
        route = 4
    else:
        gbar, route = np.where(valid, simple, np.nan), 2
    return gbar, none, route, n_exact, bits, 1 if np.any(np.isfinite(gbar)) else 2, np.nan


def beyond_resolution(dr, fitted, taken) -> float:
    """Share of the fitted ``gbar^2`` at the first lag from wavelengths below two first lags.

    ``1 - (gbar(2 dr_0) / gbar(dr_0))^2`` of the fitted gradient (log-log between the lags;
    eq. 26: the part of ``int q^3 C dq`` between ``pi / dr_0``, the Nyquist wavenumber of a
    map of pixel ``dr_0``, and ``2 pi / dr_0``).  NaN where the fit does not give the first
    lag (``taken``) or no lag reaches ``2 dr_0``.
    """
    ok = np.flatnonzero(np.isfinite(fitted) & (fitted > 0) & (dr > 0))
    if ok.size < 2 or not taken[ok[0]] or dr[ok[-1]] < 2 * dr[ok[0]]:
        return np.nan
    at_two = np.exp(np.interp(np.log(2 * dr[ok[0]]), np.log(dr[ok]), np.log(fitted[ok])))
    return float(1.0 - (at_two / fitted[ok[0]]) ** 2)


def _fit_gradient(g, se, dr, fit, fit_gradient):
    """Fit one G: the fitted spectrum's gbar (None if it fails), its error, problems, quality.

    The error is relative (:func:`~xrough._kernels.fitting.fitted_spectrum_gradient_std`).
    """
    if fit is None:
        return None, None, -1, 0
    try:
        values = fit_spectrum_kernel(g, se, **fit)
    except (ValueError, FloatingPointError, np.linalg.LinAlgError):
        return None, None, -1, 2
    params = dict(zip(SPECTRUM_OUTPUTS, values))
    bits, code = int(params["fit_problems"]), int(params["quality"])
    if code == 2:
        return None, None, bits, code
    cov = fit_covariance(values)
    args = (params["hurst"], params["G_sa"], params["lambda_r"], params["lambda_s"],
            params["lambda_r_resolved"], params["lambda_s_resolved"],
            shape_code(params["rolloff_shape"], params["cutoff_shape"]))
    lags = np.where(dr > 0, dr, np.nan)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return (fitted_spectrum_gradient(*args, dr=lags, **fit_gradient),
                fitted_spectrum_gradient_std(*args, cov, dr=lags, **fit_gradient), bits, code)
