"""Contact mechanics of one G curve and the formulas of real-space Persson theory (numpy).

All quantities in SI (m, m^2, Pa, J m-2). The curve functions take G on its lags (NaN for
empty bins, a ``dr = 0`` bin allowed) and evaluate it through
:class:`~xrough._kernels.acf_curve.AcfCurve`; the Persson formulas are elementwise and work
on numpy, dask or xarray arrays alike.
"""

from __future__ import annotations

import numpy as np

from .acf_curve import AcfCurve, require_acf
from .deferred import optimize, special
from .shape_factors import rolloff_factor, self_affine_factor
from .uncertainty import linear_std, propagated_std, relative_covariance

__all__ = ["KAPPA_PERSSON", "STEEP_DECAY", "WEIGHTINGS", "EQ51_PRINTED", "contact_area",
           "improved_area", "weighting", "asymptote_weight", "nonincreasing",
           "quick_stress", "stress_asymptote", "energy_curve", "laplacian_curve",
           "UNDETERMINED", "OUTSIDE_WINDOW", "ROUGH_START", "first_decade_slope",
           "smooth_tail", "smooth_tail_std", "patch_radius_curve"]

#: Persson's small-pressure slope of the contact area, ``a_r ~ kappa p*`` (eq. 29).
KAPPA_PERSSON = float(np.sqrt(8 / np.pi))

#: Weightings ``W(a_r)`` of eq. 49 by theory name: the original ``a_r``; the modified
#: ``a_ri^2 / a_r`` (the reading of the garbled print that the subscripts' order, eq. 51's
#: prefactor and the contact solver support); the other reading ``a_r^2 / a_ri``.
WEIGHTINGS = {"persson": "a_r", "modified": "a_ri^2 / a_r", "modified_ar2": "a_r^2 / a_ri"}

#: Prefactor of eq. 51 as printed, ``pi / 2``, relative to the small-p* limit of the
#: original theory (``w = 1`` in :func:`stress_asymptote`).
EQ51_PRINTED = float(np.pi / 2)

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


def weighting(theory: str, a_r, a_ri):
    """Eq. 49: the weighting ``W`` of ``G_sigma_full`` in partial contact (dimensionless).

    ``a_r`` for ``"persson"`` (original theory), ``a_ri^2 / a_r`` for ``"modified"`` and
    ``a_r^2 / a_ri`` for ``"modified_ar2"`` (:data:`WEIGHTINGS`); ``a_ri`` is only read by
    the modified ones (eq. 50). At small ``p*`` (``a_r -> kappa p*``, ``a_ri -> 2 p*``)
    ``W / a_r`` tends to 1, ``4 / kappa^2`` (``pi / 2`` for Persson's ``kappa``) and
    ``kappa / 2``.
    """
    if theory == "persson":
        return a_r
    if theory == "modified":
        return a_ri**2 / a_r
    if theory == "modified_ar2":
        return a_r**2 / a_ri
    raise ValueError(f"theory must be one of {tuple(WEIGHTINGS)}, got {theory!r}")


def asymptote_weight(theory: str, kappa: float = KAPPA_PERSSON) -> float:
    """Prefactor ``w`` of :func:`stress_asymptote` for ``theory`` (eq. 47-50 at small p*).

    ``Gamma_sigma = (G_sigma - p0^2) / a(0)`` with ``W`` of eq. 49 and ``a = a_r`` (original)
    or ``a_ri`` (modified), in the limits ``a_r -> kappa p*``, ``a_ri -> 2 p*``: ``w = 1``
    (original), ``2 / kappa`` (``"modified"``; ``sqrt(pi / 2)`` for Persson's ``kappa``) and
    ``kappa^2 / 4`` (``"modified_ar2"``; ``2 / pi``).
    """
    weights = {"persson": 1.0, "modified": 2 / kappa, "modified_ar2": kappa**2 / 4}
    if theory not in weights:
        raise ValueError(f"theory must be one of {tuple(WEIGHTINGS)}, got {theory!r}")
    return float(weights[theory])


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

    ``hurst``: one per curve, or the local exponent of G per lag.

    The small-pressure limit of eq. 47/48 in the self-affine range, from
    ``G_sigma_full = (E*/2)^2 (2H)^2 G / dr^2``, ``gbar^2(dr) = c_sa G / dr^2`` (xrough's
    ``c_sa``) and ``a_r -> kappa p*``, ``a_ri -> 2 p*``: ``w`` of :func:`asymptote_weight`
    per theory (``w = 1`` for the original weighting, where ``kappa`` cancels).
    ``w =`` :data:`EQ51_PRINTED` is eq. 51 as printed,
    ``pi gbar(lambda_s) H^2 E*^2 sqrt(G c_sa) / (2 dr)``, whose ``c_sa`` is the reciprocal
    of xrough's (``G / (gbar^2 dr^2)``).
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


def energy_std_curve(g, *, dr, size, pixel, geometry, n_maps, inflation=None) -> np.ndarray:
    """Statistical standard deviation of ``int G / r^2 dr`` (per unit ``E*/4``).

    The finite-area errors of G's bins with their full covariance
    (:func:`~xrough._kernels.uncertainty.relative_covariance`, from the spectrum of G for
    a map of ``size`` with pixels ``pixel``, raised by ``inflation`` where the regions of
    the map disagree), propagated linearly; shape ``(1,)``.
    """
    def total(values):
        return AcfCurve(dr, values, None).cumulative_g_over_r2(np.array([np.inf]))[0]

    if not np.all(np.isfinite(g)):
        return np.array([np.nan])
    cov = relative_covariance(dr, g, size=size, pixel=pixel, geometry=geometry,
                              n_maps=n_maps, inflation=inflation)
    return propagated_std(total, g, cov)


def patch_radius_std_curve(g, *, dr, E_star, gamma, size, pixel, geometry, n_maps,
                           inflation=None) -> np.ndarray:
    """Statistical standard deviations of ``[a_c, a_c upper]`` of one curve (m).

    The finite-area errors of G's bins with their full covariance (as
    :func:`energy_std_curve`) propagated linearly through the roots of
    :func:`patch_radius_curve`: a root ``a*`` of ``f(a; G)`` moves by ``-(df/dln g_i) /
    (df/da)``, the conditions of the moved G evaluated at ``a*`` alone (one evaluation
    per bin, no search); NaN where a radius is infinite (the surfaces stick everywhere:
    no root to move) or G is not finite.
    """
    if not np.all(np.isfinite(g)):
        return np.array([np.nan, np.nan])
    radii = patch_radius_curve(g, dr=dr, E_star=E_star, gamma=gamma)[:2]
    finite = np.isfinite(radii)
    if not finite.any():
        return np.array([np.nan, np.nan])
    cov = relative_covariance(dr, g, size=size, pixel=pixel, geometry=geometry,
                              n_maps=n_maps, inflation=inflation)
    # each radius is the first root a* of f(a; G): it moves by -(df/dln g_i) / (df/da)
    # (implicit functions), f of the moved curve evaluated at a* alone, not searched again
    roots = np.where(finite, radii, 1.0)[:, None]
    conditions = _patch_conditions(_curve(g, None, dr), E_star, gamma)
    h = 1e-6
    at = roots * np.array([1.0, 1.0 - h, 1.0 + h])  # a*, and a* -+ h a* for df/da
    with np.errstate(all="ignore"):
        f = np.array([c(a) for c, a in zip(conditions, at)])
        slope = (f[:, 2] - f[:, 1]) / (2 * h * roots[:, 0])
        J = np.zeros((2, g.size))
        valid = np.flatnonzero(np.isfinite(g) & (g > 0) & (dr > 0))
        for i in valid:
            moved = g.copy()
            moved[i] *= np.exp(h)
            f_i = [c(a[:1])[0] for c, a in zip(_patch_conditions(_curve(moved, None, dr),
                                                                 E_star, gamma), at)]
            J[:, i] = -(np.array(f_i) - f[:, 0]) / h / slope
    std = linear_std(J, cov)
    return np.where(finite & (slope > 0), std, np.nan)


def first_decade_slope(g, error=None, *, dr) -> float:
    """Log-log slope of one G over its first decade of lags (:class:`AcfCurve`).

    Below :data:`~xrough._kernels.acf_curve.FLAT_SLOPE` G is flat from the first lag; NaN
    with fewer than 3 samples in that decade.
    """
    return _curve(g, error, dr).first_decade_slope()


#: Codes of :func:`laplacian_curve`'s second row: why a lag has no Laplacian.
UNDETERMINED, OUTSIDE_WINDOW, ROUGH_START = 1.0, 2.0, 3.0


def laplacian_curve(g, error, *, dr, window=(0.0, np.inf)) -> np.ndarray:
    """2D radial Laplacian of the smoothed G at its lags, NaN where G does not determine it.

    Returns three rows on ``dr``: the Laplacian (NaN at ``dr = 0``, in empty bins and
    where it is not determined), why a lag has none: 0 (it has one, or ``dr = 0`` / an
    empty bin), :data:`UNDETERMINED` (at or below the largest lag where the estimates
    from all, the even and the odd bins disagree, :meth:`AcfCurve.determined_laplacian`)
    or :data:`OUTSIDE_WINDOW` (outside the reliable lag range ``window`` of the
    instrument) or :data:`ROUGH_START` (the first lag, where G is rough already:
    :meth:`AcfCurve.rough_start`), and the local exponent
    ``H(dr) = (1/2) dln G / dln dr`` of the same smoothed curve (NaN at ``dr = 0`` and
    in empty bins; not clipped).
    """
    # the curve of the lags inside the window only: what the instrument does not resolve
    # enters neither the smoothing nor the check of what G determines (whose scale, a
    # lower bound of G_sigma(0), would otherwise come from the unresolved lags)
    outside = (dr > 0) & ((dr < window[0]) | (dr > window[1]))
    inside = ~outside
    g, dr_in = np.asarray(g, dtype=float)[inside], dr[inside]
    error = None if error is None else np.asarray(error, dtype=float)[inside]
    out = np.full((3, dr.size), np.nan)
    out[1] = 0.0
    out[1, outside] = OUTSIDE_WINDOW
    curve = _curve(g, error, dr_in)
    lap, determined = curve.determined_laplacian()
    at = np.searchsorted(dr, curve.dr)  # the curve's samples among the lags
    out[0, at] = np.where(determined, lap, np.nan)
    out[1, at] = np.where(determined, 0.0, UNDETERMINED)
    if determined[0] and curve.rough_start():
        out[:2, at[0]] = np.nan, ROUGH_START
    out[2, at] = 0.5 * curve.log_slopes(curve.dr)[0]  # the same smoothing spline
    return out


def laplacian_std_curve(g, error, inflation, *, dr, window=(0.0, np.inf), size, pixel,
                        geometry, n_maps) -> np.ndarray:
    """Statistical standard deviation of :func:`laplacian_curve`'s Laplacian, per lag.

    The finite-area covariance of G's bins (as :func:`energy_std_curve`) propagated
    linearly through the smoothing spline of the lags inside ``window`` (its weights, from
    the standard errors, and its even start held: one fit of a column per bin,
    :meth:`AcfCurve.laplacian_response`; its smoothing the fixed length: where G's noise
    makes the spline smooth more, this is an upper bound); NaN outside the window, at
    ``dr = 0`` and where G is not finite.
    """
    g = np.asarray(g, dtype=float)
    inside = ~((dr > 0) & ((dr < window[0]) | (dr > window[1])))
    out = np.full(dr.size, np.nan)
    g_in, dr_in = g[inside], dr[inside]
    if not np.all(np.isfinite(g_in)) or np.count_nonzero(dr_in > 0) < 5:
        return out
    err = None if error is None else np.asarray(error, dtype=float)[inside]
    infl = None if inflation is None else np.asarray(inflation, dtype=float)[inside]
    require_acf(dr_in, g_in)
    curve = AcfCurve(dr_in, g_in, err, smoothing="fixed")
    kept = np.isin(dr_in, curve.dr)  # its samples (positive lags, finite errors)
    if np.count_nonzero(kept) < 5:
        return out
    cov = relative_covariance(dr_in, g_in, size=size, pixel=pixel, geometry=geometry,
                              n_maps=n_maps, inflation=infl)
    lags = dr_in > 0
    _, J = curve.laplacian_response(dr_in[lags])
    out[np.flatnonzero(inside)[lags]] = linear_std(J, cov[np.ix_(kept, kept)])
    return out


def _tail_start(lap: np.ndarray, g: np.ndarray, dr: np.ndarray, steep: float) -> int | None:
    """Index of ``r_c`` of :func:`smooth_tail` (None: the curve has no such lag)."""
    ok = np.flatnonzero(np.isfinite(lap) & np.isfinite(g) & (dr > 0))
    if ok.size < 2:
        return None
    after = ok[g[ok] >= 0.25 * np.max(g[ok])]
    for prev, k in zip(after[:-1], after[1:]):
        if not lap[prev] > 0:
            return None  # already not positive where the search starts: leave it alone
        if lap[k] <= 0 or (np.log(lap[k] / lap[prev]) / np.log(dr[k] / dr[prev]) <= -steep):
            return int(prev)
    return None


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
    return smooth_tail_std(lap, lap, g, dr=dr, steep=steep)


def smooth_tail_std(std, lap, g, *, dr, steep: float = STEEP_DECAY) -> np.ndarray:
    """Continue ``std`` beyond ``r_c`` of :func:`smooth_tail` (of ``lap``) as it does ``lap``.

    The standard deviation of the continued Laplacian: ``std(r_c) (dr / r_c)^-steep``
    beyond ``r_c``, unchanged up to it.
    """
    lap, g = np.asarray(lap, dtype=float), np.asarray(g, dtype=float)
    out = np.array(std, dtype=float)
    prev = _tail_start(lap, g, dr, steep)
    if prev is not None:
        beyond = dr > dr[prev]
        out[beyond] = out[prev] * (dr[beyond] / dr[prev]) ** -steep
    return out


def _first_root(f, lo: float, hi: float, n: int = 4000) -> float:
    """Smallest root of ``f`` on a log grid of [lo, hi]; NaN if ``f`` stays negative.

    ``f(lo) >= 0`` returns ``lo``: the caller handles a root below ``lo`` itself.
    """
    grid = np.geomspace(lo, hi, n)
    vals = f(grid)
    sign = np.flatnonzero(vals >= 0)
    if sign.size == 0:
        return np.nan
    k = sign[0]
    if k == 0:
        return float(grid[0])
    return float(optimize.brentq(lambda x: float(f(np.array([x]))[0]), grid[k - 1], grid[k],
                                 xtol=1e-14 * grid[k], rtol=1e-12))


def _patch_conditions(curve: AcfCurve, E_star: float, gamma: float) -> tuple:
    """Return the functions of ``a`` whose first roots are ``a_c`` (eq. 46), its upper (eq. 44).

    ``v_el(a) - gamma`` with ``v_el(a) = E* int_0^a G / r^2 dr / 4`` (eq. 44), and that plus
    ``E* G(a) / (8 a)`` (eq. 46), on G continued as :class:`AcfCurve` continues it.
    """
    def upper(a):
        return E_star / 4 * curve.cumulative_g_over_r2(a)[0] - gamma

    def refined(a):
        return upper(a) + E_star * curve(a) / (8 * a)

    return refined, upper


def patch_radius_curve(g, *, dr, E_star, gamma) -> np.ndarray:
    """``[a_c (eq. 46), a_c upper (eq. 44), v_el]`` of one curve (m, m, J m-2).

    ``inf`` radii: the surfaces stick everywhere (``gamma >= v_el``, the elastic energy of
    full contact per area, eq. 16, which the search needs and returns).

    Between the first and the last sample the smallest root is searched on a log grid and
    refined; outside them G is continued as in :class:`AcfCurve` and the roots are closed
    forms of that continuation, so no search bound is ever returned. Below the first
    sample ``r0``, the even start ``G = A r^2 + B r^4`` gives
    ``v_el(a) = E* (A a + B a^3 / 3) / 4`` and the roots of the cubics
    ``A a + B a^3 / 3 = 4 gamma / E*`` (eq. 44) and ``3 A a / 8 + 5 B a^3 / 24 = gamma / E*``
    (eq. 46), both increasing on ``[0, r0]`` from ``-gamma`` at ``a = 0``; for ``B = 0``
    (ballistic, ``A = G0 / r0^2``) ``4 gamma / (E* A)`` and ``8 gamma / (3 E* A)``.
    Beyond the last sample ``(rL, GL)``, ``G = GL`` gives
    ``v_el(a) = v_el - E* GL / (4 a)`` with ``v_el`` of full contact (eq. 16), and the
    roots ``E* GL / (4 (v_el - gamma))`` (eq. 44) and ``E* GL / (8 (v_el - gamma))``
    (eq. 46), which exist for ``gamma < v_el`` only (inf otherwise).
    """
    curve = _curve(g, None, dr)
    r0, r_last = curve.dr[0], curve.dr[-1]
    v_full = E_star / 4 * curve.cumulative_g_over_r2(np.array([np.inf]))[0][0]
    refined, upper = _patch_conditions(curve, E_star, gamma)

    def root(f, below, beyond):
        if f(np.array([r0]))[0] >= 0:  # in the even start below r0
            return below
        inside = _first_root(f, r0, r_last)
        if np.isfinite(inside):
            return inside
        if gamma >= v_full:  # f -> v_full - gamma <= 0 at a -> inf: no root
            return np.inf
        return beyond  # in the flat continuation (f increases there)

    def start_root(cubic, linear, rhs):
        """Return the root in ``(0, r0]`` of ``cubic a^3 + linear a = rhs`` (increasing there)."""
        if cubic == 0:
            return rhs / linear
        roots = np.roots([cubic, 0.0, linear, -rhs])
        real = roots[(np.abs(roots.imag) <= 1e-9 * np.abs(roots)) & (roots.real > 0)].real
        return float(np.min(real, initial=np.inf))

    A, B = curve.a, curve.b
    return np.array([
        root(refined, start_root(5 * B / 24, 3 * A / 8, gamma / E_star),
             E_star * curve.plateau / (8 * (v_full - gamma))),
        root(upper, start_root(B / 3, A, 4 * gamma / E_star),
             E_star * curve.plateau / (4 * (v_full - gamma))),
        v_full])
