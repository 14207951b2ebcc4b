"""G(dr) as a function: interpolation, extrapolation, exact integrals, smooth derivatives.

A G sampled on (log-spaced) lags is continued as

* a monotone cubic in log-log between the samples (PCHIP of ``ln G`` against ``ln r``:
  no overshoot, a power law where the samples are one), which integrals such as
  ``int G / r^2 dr`` (eq. 16, 44) evaluate by Gauss-Legendre quadrature on each piece;
* below the first sample, the even expansion ``G = a r^2 + b r^4`` of a surface smooth
  below its finest resolved scale (``a = gbar^2 / 4``), through the first two samples
  when they give a concave ``G(r^2)`` rising all the way (``b <= 0``,
  ``r_0^2 <= a / (2 |b|)``), else the ballistic law ``G = G_0 (r / r_0)^2`` (``b = 0``).
  On periodic maps with a sharp cutoff ``lambda_s`` of 2 to 8 px, the ballistic law with
  power laws between the samples put ``int G / r^2 dr`` 0.04 to 3.2 % low; these two
  give -0.8 to +0.2 % (``benchmarks/calibration_errors.py``, column "on E[G]");
* a constant ``G = G_last`` beyond the last sample (the surface is flat at larger scales).

Derivatives, which amplify noise, come from a smoothing spline of ``ln G`` against
``ln r`` weighted by the per-bin relative standard error, whose smoothing length is fixed
in ``ln r`` (:data:`SMOOTHING_DECADES`; the same for every binning) or larger where
generalised cross-validation asks for it; the 2D radial Laplacian is then
``(1/r) d/dr (r dG/dr) = G (y'' + y'^2) / r^2`` with ``y = ln G``, ``x = ln r``.

Whether the samples determine that second derivative is checked as the support of a
spectrum is (:mod:`xrough._kernels.spectrum_of_acf`): the Laplacian is estimated three times, from
all samples and from the even and the odd ones alone (each keeping both ends), and a lag
where these estimates differ by more than :data:`DETERMINED` of a lower bound of the
Laplacian at ``dr = 0`` is not determined, nor is any smaller lag
(:meth:`AcfCurve.determined_laplacian`). On a measured map this is what the lattice does
at the first few pixels: the bins there hold a few discrete distances each (1, sqrt(2),
2, sqrt(5) px ...) along different directions, a scanned surface is not isotropic at the
pixel scale, and G zig-zags between neighbouring bins by far more than its standard error.
"""

from __future__ import annotations

import inspect
from functools import lru_cache

import numpy as np

from .deferred import interpolate

__all__ = ["AcfCurve", "DETERMINED", "FIRST_LAG_SMOOTH", "FLAT_SLOPE", "G_RANGE",
           "RELATIVE_ERROR_RANGE", "acf_problem", "relative_error_problem", "require_acf"]

#: Smoothing length of the derivatives of G, in decades of dr (a spline penalty
#: ``lam = (samples per unit ln dr) * (0.05 ln 10)^4``): fine enough for the roll-offs
#: of a surface (G's log-slope turns over about half a decade), coarse enough that the
#: scatter of lattice distances in bins finer than 20 per decade is not read as curvature.
SMOOTHING_DECADES = 0.05

#: Relative scatter of G between neighbouring bins of a lattice that its statistical error
#: does not hold (at the smallest lags a bin holds a few lattice vectors of different
#: directions; pixel noise and a scan that differs along its fast and slow axes make G
#: zig-zag between them). Added in quadrature to the relative errors that weight the
#: smoothing spline: a G whose finite-area error at one pixel is 0.6 % (the UNCD AFM map)
#: would otherwise pin the spline to that zig-zag and flip the sign of its Laplacian.
LATTICE_JITTER = 0.02

#: Largest difference between the Laplacians of G from all samples, the even and the odd
#: samples, relative to a lower bound of the Laplacian at dr = 0 (the largest value all
#: three agree on, or 4 G(dr_1) / dr_1^2), at which the Laplacian still counts as
#: determined. Periodic synthetic maps (lambda_s = 2-8 px, H = 0.3-0.8, 5-40 bins per
#: decade) keep every lag from 2 px on; measured maps lose their first 1-6 px
#: (benchmarks/bench_stress_determined.py).
DETERMINED = 0.15

#: Gauss-Legendre nodes and weights on [-1, 1] for ``int G / r^2 dr`` on one piece of the
#: continued curve (exact to 1e-9 relative on pieces of up to a decade).
_GAUSS = np.polynomial.legendre.leggauss(8)

#: A G whose last third lies this factor below its first third (medians) is a height ACF.
DECREASE = 1.1

#: Log-log slope of G over its first decade of lags below which G counts as flat from the
#: first lag (:meth:`AcfCurve.first_decade_slope`): G rises by less than 26 % per decade
#: (a self-affine G rises as dr^2H, a smooth one as dr^2), so the roughness is not
#: resolved by the lags (white noise: heights uncorrelated from one pixel to the next).
#: White-noise maps of 16^2 to 512^2 give |slope| < 0.02; self-affine maps (H 0.3-0.8,
#: lambda_s = 4 px) 1.0 or more, also with white noise of half their rms step added; the
#: measurements of the test data 0.27 (a 4 x 7 map) or more.
FLAT_SLOPE = 0.1

#: Below this log-log slope of G's first piece (between its first two samples:
#: :meth:`AcfCurve.rough_start`) the surface is already rough at the first lag: the
#: curvature of G there depends on what lies below it, which no sample holds, and the
#: Laplacian at the first lag is not determined. At or above it G is within 10 % of the
#: smooth ``dr^2`` regime, where the even start below the first sample (which the
#: smoothing spline is anchored to, see :meth:`AcfCurve._smooth`) holds: on the exact
#: expected G of periodic 512^2 maps (H 0.3, 0.5, 0.8; sharp cutoff at 2-8 px) the stress
#: ACF at 1 px is then within 0.4 % of ``G_sigma(0)`` of the map's exact stress field;
#: below it, where the first lag is NaN, it was 3-6 % high (``tests/test_contact.py``).
FIRST_LAG_SMOOTH = 1.8

#: Largest (and reciprocal of the smallest) nonzero |G| in the square of its lag unit that
#: the functions of G accept: up to about 1e284 every one gives the result of a G scaled
#: down by the same factor; fits fail near 1e294.
G_RANGE = 1e280


#: Range of the relative standard error of G (of ln G) that the functions of G accept (a
#: wider one overflows the squared weights; measured values lie between 1e-8 and 10).
RELATIVE_ERROR_RANGE = 1e100


#: Fewer valid bins than this cannot show how a G grows (a map of a few pixels per side).
FEW_BINS = 8


def acf_problem(dr: np.ndarray, lines: np.ndarray, *, min_bins: int = 2,
                unit: str = "", estimated: bool = False) -> str:
    """Say what is wrong with the values of G (the rules of :mod:`xrough.acf`), or ``""``.

    Parameters
    ----------
    dr : ndarray
        Lags (checked already: finite, increasing, >= 0).
    lines : ndarray
        G in the square of the lag unit, one curve per row (or a single 1-D curve).
    min_bins : int
        Valid bins needed per curve.
    unit : str
        Lag unit, for messages.
    estimated : bool
        G says it was estimated from heights (xrough's estimators, attr ``equation``
        "eq. 1: ..."): with fewer than :data:`FEW_BINS` bins a G that falls is one of too
        few points, and with more the message also names what else makes such a G fall.
    """
    lines = np.atleast_2d(np.asarray(lines, dtype=float))
    if np.any(np.isinf(lines)):
        return "has infinite values (NaN marks an empty bin; inf is never a valid G)"
    size = np.abs(lines[np.isfinite(lines) & (lines != 0)])
    if size.size and not (size.max() <= G_RANGE and size.min() >= 1 / G_RANGE):
        sq = f"{unit}^2" if unit else "(lag unit)^2"
        return (f"has values from {size.min():g} to {size.max():g} {sq}, beyond "
                f"{1 / G_RANGE:g} to {G_RANGE:g} {sq}: the fits and spectra of G square "
                "and exponentiate it and would overflow float64 (check the height scale "
                "of the data; in physical units no G comes near these bounds)")
    zero_lag = dr == 0
    if np.any(lines[:, zero_lag][np.isfinite(lines[:, zero_lag])] != 0):
        return "must be 0 at dr = 0 (a point differs from itself by nothing)"
    positive_lag = ~zero_lag
    for line in lines:
        g = line[positive_lag]
        valid = np.isfinite(g)
        if not valid.any():
            return "is all NaN (no valid bin)"
        pos = g[valid & (g > 0)] if np.any(valid) else g[:0]
        if pos.size >= 2:
            ln_g = np.log(pos)
            third = max(1, ln_g.size // 3)
            if np.median(ln_g[-third:]) < np.median(ln_g[:third]) - np.log(DECREASE):
                found = ("decreases overall (its last third is more than 10 % below its "
                         "first third)")
                if estimated and pos.size < FEW_BINS:
                    return (f"{found} over its {pos.size} bins: estimated from so few "
                            "points, G does not show how it grows (a map of a few pixels "
                            "per side); measure a larger map")
                return (f"{found}: that is a height ACF <h(r) h(r+dr)> = sigma_h^2 - G, "
                        "not the height-difference ACF G(dr) = 1/2 <(h(r) - h(r+dr))^2>, "
                        "which grows from 0 at dr = 0 to sigma_h^2" + (
                            "; or, if it is G of measured heights, they repeat at these "
                            "lags (a periodic surface: G falls past half a period) or a "
                            "few features dominate them" if estimated else ""))
        if np.any(g[valid] < 0):
            return ("has negative values: a height-difference ACF is "
                    "1/2 <(h(r) - h(r+dr))^2> >= 0")
        if np.any(g[valid] == 0):
            at = dr[positive_lag][valid & (g == 0)][:3]
            return (f"is 0 at dr = {at} {unit}: a rough surface has G > 0 at every lag > 0 "
                    "(0 means a flat surface or heights below their resolution; drop those "
                    "bins with G.where(G > 0))")
        if valid.sum() < min_bins:
            return (f"has {int(valid.sum())} valid (non-NaN) bins at dr > 0; at least "
                    f"{min_bins} are needed")
    return ""


def relative_error_problem(g: np.ndarray, se: np.ndarray, dr: np.ndarray, *,
                           unit: str = "") -> str:
    """Say what is wrong with a ``standard_error`` ``se`` of G ``g`` (one unit), or ``""``.

    Its ratio to G, the standard error of ln G, weights fits and smoothing squared: it must
    lie within ``1/RELATIVE_ERROR_RANGE`` to ``RELATIVE_ERROR_RANGE`` where both are valid.
    """
    g, se = np.broadcast_arrays(np.asarray(g, dtype=float), np.asarray(se, dtype=float))
    with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
        ratio = se / g
    used = np.isfinite(ratio) & (g > 0) & (se > 0)
    odd = used & ~((ratio > 1 / RELATIVE_ERROR_RANGE) & (ratio < RELATIVE_ERROR_RANGE))
    if not np.any(odd):
        return ""
    k = np.unravel_index(np.flatnonzero(odd)[0], odd.shape)
    return (f"standard_error is {ratio[k]:.3g} times G at dr = {dr[k[-1]]:g} {unit} "
            f"(G = {g[k]:g}, standard_error = {se[k]:g}), outside "
            f"{1 / RELATIVE_ERROR_RANGE:g} to {RELATIVE_ERROR_RANGE:g}: G and its "
            "standard_error coordinate are not in one unit (scaling G's values leaves its "
            "coordinates as they were: scale both, or drop the coordinate)")


def require_acf(dr: np.ndarray, g: np.ndarray, *, min_bins: int = 2) -> None:
    """Raise ValueError if one curve of G breaks a value rule (for kernels on dask chunks)."""
    problem = acf_problem(dr, g, min_bins=min_bins)
    if problem:
        raise ValueError(f"G {problem}")


@lru_cache(maxsize=1)
def _batched() -> bool:
    """Whether make_smoothing_spline fits many columns of ordinates at once (its ``axis``).

    Not in the oldest SciPy supported (1.13): there the columns are fitted one by one.
    """
    return "axis" in inspect.signature(interpolate.make_smoothing_spline).parameters


def _smoothing_splines(x, ys, w, lam) -> interpolate.BSpline:
    """Return the smoothing splines of the columns of ``ys`` (one fit where SciPy batches)."""
    if _batched():
        return interpolate.make_smoothing_spline(x, ys, w=w, lam=lam)
    fits = [interpolate.make_smoothing_spline(x, col, w=w, lam=lam) for col in ys.T]
    return interpolate.BSpline(fits[0].t, np.stack([f.c for f in fits], axis=-1), fits[0].k)


def _roughness(spline, x: np.ndarray) -> float:
    """``int y''^2 dx`` of a cubic spline over the samples ``x`` (Simpson per interval)."""
    mid = 0.5 * (x[1:] + x[:-1])
    d2 = spline.derivative(2)
    return float(np.sum(np.diff(x) * (d2(x[:-1]) ** 2 + 4 * d2(mid) ** 2 + d2(x[1:]) ** 2))
                 / 6)


class AcfCurve:
    """One G curve on lags ``dr`` (any consistent unit), NaN bins dropped.

    Parameters
    ----------
    dr, g : ndarray
        Lags (> 0, increasing) and G values (> 0 where finite).
    error : ndarray, optional
        Standard error of G per bin (weights of the smoothing spline).
    smoothing : {'auto', 'fixed'}
        The smoothing spline's choice (:meth:`_smooth`), or its fixed length alone (the
        response of a curve that chose it to small changes of G: one fit, not two).
    """

    def __init__(self, dr: np.ndarray, g: np.ndarray, error: np.ndarray | None = None,
                 smoothing: str = "auto"):
        dr = np.asarray(dr, dtype=float)
        g = np.asarray(g, dtype=float)
        ok = np.isfinite(g) & (g > 0) & (dr > 0)
        if error is not None:
            error = np.asarray(error, dtype=float)
            ok &= np.isfinite(error)
        if ok.sum() < 2:
            raise ValueError("G needs at least 2 positive, finite values")
        self.dr, self.g = dr[ok], g[ok]
        self.error = None if error is None else error[ok]
        self.x, self.y = np.log(self.dr), np.log(self.g)
        self.slope = np.diff(self.y) / np.diff(self.x)  # mean log-log slope per piece
        self._pchip_: interpolate.PchipInterpolator | None = None
        self.a, self.b = self._even_start()
        self._spline: interpolate.BSpline | None = None
        self.smoothing = smoothing
        # the smoothing spline anchored below the first sample where G is smooth there
        self.anchor = not self.rough_start()

    def _even_start(self, g01=None) -> tuple[float, float]:
        """Return ``(a, b)`` of ``G = a r^2 + b r^4`` below the first sample (module docstring).

        ``g01``: the first two values of G instead of the curve's.
        """
        (r0, r1), (g0, g1) = self.dr[:2] ** 2, self.g[:2] if g01 is None else g01
        b = (g1 / r1 - g0 / r0) / (r1 - r0)
        a = g0 / r0 - b * r0
        if not (b <= 0 and a > 0 and r0 * 2 * -b <= a):
            return g0 / r0, 0.0
        return a, b

    @property
    def _pchip(self) -> interpolate.PchipInterpolator:
        """The monotone interpolant of ``ln G`` in ``ln dr``, built at its first use.

        The smoothed derivatives (one curve per perturbed G in an error propagation) need none.
        """
        if self._pchip_ is None:
            self._pchip_ = interpolate.PchipInterpolator(self.x, self.y)
        return self._pchip_

    # -- values -----------------------------------------------------------------------
    def __call__(self, r: np.ndarray) -> np.ndarray:
        """G at ``r`` with the even start below and the flat continuation beyond."""
        r = np.asarray(r, dtype=float)
        lr = np.log(np.maximum(r, 1e-300))
        out = np.exp(self._pchip(np.clip(lr, self.x[0], self.x[-1])))
        out = np.where(lr < self.x[0], self.a * r**2 + self.b * r**4, out)
        return np.where(r > 0, out, 0.0)

    @property
    def plateau(self) -> float:
        """G beyond the last sample (the flat continuation)."""
        return float(self.g[-1])

    # -- integrals --------------------------------------------------------------------
    def cumulative_g_over_r2(self, a: np.ndarray) -> tuple[np.ndarray, float, float]:
        """``int_0^a G(r) / r^2 dr`` for each ``a``, for the continued curve.

        Returns the integrals, the part below the first sample (``a r_0 + b r_0^3 / 3`` of
        the even start) and the flat part beyond the last sample to infinity
        (``G_last / r_last``).
        """
        a = np.asarray(a, dtype=float)
        r0 = self.dr[0]
        below = self.a * r0 + self.b * r0**3 / 3
        pieces = self._log_integral(self.x[:-1], self.x[1:])
        edges_cum = np.concatenate([[0.0], np.cumsum(pieces)])
        k = np.clip(np.searchsorted(self.dr, a, side="left") - 1, 0, len(self.slope) - 1)
        la = np.log(np.clip(a, r0, self.dr[-1]))
        part = below + edges_cum[k] + self._log_integral(self.x[k], la)
        inner = np.minimum(a, r0)
        start = self.a * inner + self.b * inner**3 / 3
        beyond = below + edges_cum[-1] + self.g[-1] * (1 / self.dr[-1] - 1 / np.maximum(
            a, self.dr[-1]))
        out = np.where(a <= r0, start, np.where(a > self.dr[-1], beyond, part))
        return out, float(below), float(self.g[-1] / self.dr[-1])

    def _log_integral(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """``int G / r^2 dr = int exp(y(x) - x) dx`` from ``x = lo`` to ``hi`` (one piece)."""
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        nodes, weights = _GAUSS
        half = (hi - lo)[..., None] / 2
        x = (hi + lo)[..., None] / 2 + half * nodes
        return (half * np.exp(self._pchip(x) - x) * weights).sum(axis=-1)

    # -- smooth derivatives -------------------------------------------------------------
    def _smooth(self):
        """Return the smoothing spline of ``ln G`` against ``ln dr`` (None below 5 samples).

        Its smoothing is the larger of a fixed length in ``ln dr``
        (:data:`SMOOTHING_DECADES`, the same for every binning, so that lattice jitter of
        fine bins is not read as curvature) and what generalised cross-validation asks
        for given the standard errors (noisy G); "larger" is decided by the roughness
        ``int y''^2 dx``, which falls monotonically with the smoothing parameter.
        """
        if self._spline is None and self.x.size >= 5:
            w = self._weights()
            x, y, w_all, lam = self._fixed_samples(w)
            fixed = interpolate.make_smoothing_spline(x, y, w=w_all, lam=lam)
            self._spline = fixed
            if self.error is not None and self.smoothing == "auto":
                # a noisy G: cross-validation's smoothing, of G's samples alone (the even
                # start below rests on the first two, as noisy)
                gcv = interpolate.make_smoothing_spline(self.x, self.y, w=w)
                if _roughness(gcv, self.x) < _roughness(fixed, self.x):
                    self._spline = gcv
        return self._spline

    def _weights(self) -> np.ndarray | None:
        """Weights of the smoothing spline: one over G's relative variance (None: equal)."""
        if self.error is None:
            return None
        w = 1.0 / np.hypot(self.error / self.g, LATTICE_JITTER) ** 2
        return w / w.mean()

    def _fixed_samples(self, w: np.ndarray | None):
        """``x, y, w, lam`` of the fixed-length smoothing spline (:meth:`_smooth`)."""
        span = self.x[-1] - self.x[0]
        density = (self.x.size - 1) / span  # samples per unit ln(dr)
        return *self._anchored(w), density * (SMOOTHING_DECADES * np.log(10)) ** 4

    def laplacian_response(self, r: np.ndarray,
                           step: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
        """Return the fixed-length spline's Laplacian at ``r`` and its response to ``ln G``.

        Returns the Laplacian at ``r`` (:meth:`laplacian` of a ``smoothing="fixed"``
        curve; NaN outside the samples' lags) and ``J[k, i] = d laplacian(r_k) / d ln g_i``
        by forward differences of ``step``, with the even start following the first two
        samples and the spline's weights held: the spline is linear in ``ln G`` then, and
        all the perturbed curves are one fit of as many columns.  The weights are G's
        relative errors, which scale with G in a measurement: held, a rescaled G rescales
        the Laplacian exactly (each row of ``J`` sums to the Laplacian), where weights
        recomputed from the perturbed G and the same errors would move the spline by their
        residuals.
        ``i`` runs over the samples of the curve (``dr``: the finite, positive G given,
        with a finite error).
        """
        if self.x.size < 5:
            raise ValueError("the smoothing spline needs at least 5 samples")
        x, y, w, lam = self._fixed_samples(self._weights())
        n, first = self.x.size, y.size - self.x.size  # the even start's samples come first
        ys = np.repeat(y[:, None], n + 1, axis=1)
        ys[first + np.arange(n), 1 + np.arange(n)] += step
        for i in range(first and 2):  # the even start follows the first two samples
            g01 = self.g[:2].copy()
            g01[i] *= np.exp(step)
            ys[:first, 1 + i] = self._start_samples(*self._even_start(g01))[1]
        splines = _smoothing_splines(x, ys, w, lam)
        r = np.asarray(r, dtype=float)
        lr = np.log(r)
        lap = np.exp(splines(lr)) * (splines(lr, 2) + splines(lr, 1) ** 2) / (r[:, None] ** 2)
        lap[(lr < self.x[0]) | (lr > self.x[-1])] = np.nan
        return lap[:, 0], (lap[:, 1:] - lap[:, :1]) / step

    def _anchored(self, w: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Give the samples of the smoothing spline: G's, and two of the even start below.

        A natural spline ends with ``y'' = 0``: at the first sample that would put the
        Laplacian ``G (y'' + y'^2) / r^2`` of a G bending from ``dr^2`` into its power law
        3-6 % of ``G_sigma(0)`` high. Two samples of the even start ``a r^2 + b r^4`` at
        ``r_0 / 2`` and ``0.7 r_0`` (weighted as G's best sample) carry its curvature
        below the first lag; the spline is evaluated only from ``r_0`` on. Not where G is
        rough at the first lag (:meth:`rough_start`): the even start does not hold there;
        nor where cross-validation smooths more (:meth:`_smooth`).
        """
        w = np.ones_like(self.x) if w is None else w
        if not self.anchor:
            return self.x, self.y, w
        x, y = self._start_samples(self.a, self.b)
        return np.r_[x, self.x], np.r_[y, self.y], np.r_[np.full(2, w[0]), w]

    def _start_samples(self, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
        """``ln r`` and ``ln G`` of the even start's two samples (:meth:`_anchored`)."""
        r = self.dr[0] * np.array([0.5, 0.7])
        return np.log(r), np.log(a * r**2 + b * r**4)

    def log_slopes(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``y' = dlnG/dlnr`` and ``y''`` of the smoothed curve at ``r``.

        Below the first sample those of the even start ``a r^2 + b r^4`` (``y' = 2,
        y'' = 0`` for ``b = 0``); beyond the last one the flat continuation gives
        ``y' = y'' = 0``.
        """
        r = np.asarray(r, dtype=float)
        lr = np.log(r)
        spline = self._smooth()
        if spline is None:
            k = np.clip(np.searchsorted(self.x, lr) - 1, 0, len(self.slope) - 1)
            d1, d2 = self.slope[k], np.zeros_like(lr)
        else:
            inside = np.clip(lr, self.x[0], self.x[-1])
            d1, d2 = spline.derivative(1)(inside), spline.derivative(2)(inside)
        t = self.b / self.a * r**2  # b r^2 / a: scale-free (G may be 1e156 of its unit)
        start1 = (2 + 4 * t) / (1 + t)
        start2 = 4 * t / (1 + t) ** 2
        d1 = np.where(lr < self.x[0], start1, np.where(lr > self.x[-1], 0.0, d1))
        d2 = np.where(lr < self.x[0], start2, np.where(lr > self.x[-1], 0.0, d2))
        return d1, d2

    def smooth_values(self, r: np.ndarray) -> np.ndarray:
        """G of the smoothed curve (same continuation as :meth:`__call__`)."""
        spline = self._smooth()
        r = np.asarray(r, dtype=float)
        if spline is None:
            return self(r)
        lr = np.log(r)
        inside = (lr >= self.x[0]) & (lr <= self.x[-1])
        smooth = np.exp(spline(np.clip(lr, self.x[0], self.x[-1])))
        return smooth if np.all(inside) else np.where(inside, smooth, self(r))

    def laplacian(self, r: np.ndarray) -> np.ndarray:
        """2D radial Laplacian ``(1/r) d/dr (r dG/dr)`` of the smoothed curve."""
        r = np.asarray(r, dtype=float)
        d1, d2 = self.log_slopes(r)
        return self.smooth_values(r) * (d2 + d1**2) / r**2

    def rough_start(self) -> bool:
        """Say whether G is rough at its first sample (its Laplacian there not determined).

        True where the log-log slope of the first piece lies below
        :data:`FIRST_LAG_SMOOTH`: the curvature of G at the first lag then depends on what
        lies below it. (Its statistical error does not enter: G's errors at neighbouring
        lags of one map are nearly fully correlated, so the slope's is small.)
        """
        return bool(self.dr.size >= 2 and not self.slope[0] >= FIRST_LAG_SMOOTH)

    def first_decade_slope(self) -> float:
        """Log-log slope of G over its first decade of lags (NaN below 3 samples there).

        The least-squares slope of ``ln G`` against ``ln dr`` over the samples from the
        first one to 10 times its lag, weighted by the relative standard errors if given.
        Below :data:`FLAT_SLOPE` G is flat from the first lag: the lags do not resolve the
        roughness.
        """
        first = self.dr <= 10 * self.dr[0] * (1 + 1e-9)
        if first.sum() < 3:
            return np.nan
        w = None if self.error is None else (self.g[first] / np.maximum(
            self.error[first], 1e-300 * self.g[first]))
        return float(np.polyfit(self.x[first], self.y[first], 1, w=w)[0])

    def _subset(self, index: np.ndarray) -> AcfCurve:
        """Return the curve of the samples ``index`` only (anchored as this one)."""
        out = AcfCurve(self.dr[index], self.g[index],
                       None if self.error is None else self.error[index])
        out.anchor = self.anchor
        return out

    def determined_laplacian(self, tol: float = DETERMINED) -> tuple[np.ndarray, np.ndarray]:
        """Laplacian at the samples and where the samples determine it.

        The Laplacian from all samples is compared with those from the even and from the
        odd samples alone (both keep the first and the last sample; their smoothing
        length in ``ln dr`` is the same, so on a smooth G the three agree). Their largest
        pairwise difference ``D`` is measured against the scale ``S``, a lower bound of the
        Laplacian at ``dr = 0`` (where that of an ACF is largest): the larger of the largest
        Laplacian all three agree on (same sign; the smallest of the three magnitudes) and
        ``4 G(dr_1) / dr_1^2`` of the first sample (``1 - J0(x) <= x^2 / 4``). A
        sample with ``D > tol S`` is not determined, nor is any sample at a smaller lag:
        the result is a lower bound of the lags where the second derivative means
        something, as the smoothing ties each value to its neighbours.

        Parameters
        ----------
        tol : float
            Largest ``D / S`` that counts as determined.

        Returns
        -------
        (ndarray, ndarray)
            The Laplacian at ``self.dr`` (as :meth:`laplacian`) and a boolean mask of the
            samples where it is determined. Fewer than 4 samples: no halves to compare,
            all determined.
        """
        full = self.laplacian(self.dr)
        n = self.dr.size
        determined = np.ones(n, dtype=bool)
        if n < 4:
            return full, determined
        even = np.unique(np.r_[0:n:2, n - 1])
        odd = np.unique(np.r_[0, 1:n:2, n - 1])
        estimates = np.array([full] + [self._subset(k).laplacian(self.dr)
                                       for k in (even, odd)])
        spread = np.ptp(estimates, axis=0)
        agree = np.all(np.sign(estimates) == np.sign(full), axis=0) & (full != 0)
        # two lower bounds of the Laplacian at dr = 0: |Lap G| of an ACF is largest there,
        # and 1 - J0(x) <= x^2 / 4 gives 4 G(dr) / dr^2 <= gbar^2 at every lag
        scale = max(np.max(np.where(agree, np.min(np.abs(estimates), axis=0), 0.0)),
                    4 * self.g[0] / self.dr[0] ** 2)
        bad = np.flatnonzero(~(spread <= tol * scale))
        if bad.size:
            determined[: bad[-1] + 1] = False
        return full, determined
