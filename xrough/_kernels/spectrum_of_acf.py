"""The spectrum of a height-difference ACF: ``C(q)`` from samples of ``G`` (eq. 10/11).

Pure numpy/scipy, no xarray.  Conventions as in :mod:`xrough._kernels.hankel`:
``C(q) = 2 pi int_0^inf d(dr) dr J0(q dr) [sigma_h^2 - G(dr)]``.  Besides the transform
(:func:`spectrum_from_acf_kernel`): the level ``sigma_h^2`` of the extended ``G``, smoothing
of noisy samples, and the variants of the extrapolation and the noise that measure the
range of ``q`` the data determine (:func:`spectrum_support_kernel`).

Method (see :func:`spectrum_from_acf_kernel`):
two integrations by parts give ``q^2 C / 2pi = sum_k J_k J0(q r_k) + int f(r) J0(q r) dr``
with ``f = (r G')'`` and ``J_k`` the jumps of ``r G'``; ``sigma_h^2`` drops out, so nothing
cancels where ``G ~ sigma_h^2``. Split at ``dr = 1/q`` as in eq. 11, the part below uses
``-(1 - J0)`` plus ``r G'(1/q)``, so nothing cancels at small ``q`` either. ``G`` is a
piecewise power law through the samples times a quintic Hermite correction (twice
continuously differentiable, no kinks), extended smoothly to ``G ~ dr^2`` below and to a
plateau beyond the data; ``f`` is then a sum of power laws per piece and is integrated like
``q C`` in eq. 9 (panels below ``t = T``, asymptotic antiderivatives above,
:mod:`xrough._kernels.bessel`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .bessel import (
    blocks,
    log_grid,
    one_minus_j0,
    one_minus_j0_over_t2,
    oscillatory_terms,
    panel_quadrature,
)
from .checks import require_increasing
from .deferred import interpolate, special
from .detrend import MAD_TO_SIGMA

__all__ = [
    "spectrum_from_acf_kernel",
    "acf_plateau_kernel",
    "smooth_acf_kernel",
    "spectrum_variants_kernel",
    "spectrum_support_kernel",
    "spectrum_error_kernel",
    "support_grid",
    "supported_interval",
]


# --------------------------------------------------------------------------------------
# G through its samples: piecewise power laws with a quintic correction
# --------------------------------------------------------------------------------------
class _RadialPieces(NamedTuple):
    """``G(r) = sum_m coef[m] (r / hi)^(p0 + m)`` on ``[lo, hi]``; flat beyond the last ``hi``.

    Piece 0 starts at ``r = 0``.
    """

    lo: np.ndarray
    hi: np.ndarray
    coef: np.ndarray  # (terms, pieces)
    p0: np.ndarray

    def laplacian(self, r: np.ndarray) -> np.ndarray:
        """``f = d/dr (r dG/dr) = r * Laplacian(G)``, zero beyond the last knot."""
        j = np.clip(np.searchsorted(self.hi, r, side="left"), 0, self.hi.size - 1)
        x = r / self.hi[j]
        p0 = self.p0[j]
        g = self._laplacian_coef()[:, j]  # one gather of all terms
        out = g[-1].copy()
        for m in range(g.shape[0] - 2, -1, -1):  # Horner in x
            out *= x
            out += g[m]
        return np.where(r <= self.hi[-1], out * np.exp(p0 * np.log(x)) / r, 0.0)

    def _laplacian_coef(self) -> np.ndarray:
        """``coef[m] (p0 + m)^2``: the terms of :meth:`laplacian` per piece."""
        m = np.arange(self.coef.shape[0])[:, None]
        return self.coef * (self.p0[None, :] + m) ** 2

    def r_dG(self, r: np.ndarray) -> np.ndarray:
        """``r dG/dr`` (right-hand limit at knots), zero beyond the last knot."""
        j = np.clip(np.searchsorted(self.hi, r, side="right"), 0, self.hi.size - 1)
        log_x = np.log(r / self.hi[j])
        out = np.zeros_like(r)
        for m in range(self.coef.shape[0]):
            p = self.p0[j] + m
            out += self.coef[m, j] * p * np.exp(p * log_x)
        return np.where(r < self.hi[-1], out, 0.0)

    def jumps(self) -> np.ndarray:
        """Jump of ``r dG/dr`` across every knot ``hi`` (zero where ``G`` is smooth)."""
        p = self.p0[None, :] + np.arange(self.coef.shape[0])[:, None]
        upper = np.sum(self.coef * p, axis=0)
        rho = np.where(self.lo > 0, self.lo / self.hi, 1.0)
        lower = np.where(self.lo > 0, np.sum(self.coef * p * rho**p, axis=0), 0.0)
        return np.append(lower[1:], 0.0) - upper


def _smoothstep_integral(v: np.ndarray) -> np.ndarray:
    """``int_0^v S``, ``S = 10 v^3 - 15 v^4 + 6 v^5`` (C2 step from 0 to 1 on [0, 1])."""
    v = np.clip(v, 0.0, 1.0)
    return v**4 * (2.5 - 3.0 * v + v * v)


def _smoothstep(v: np.ndarray) -> np.ndarray:
    """``S = 10 v^3 - 15 v^4 + 6 v^5`` on [0, 1] (0 below, 1 above)."""
    v = np.clip(v, 0.0, 1.0)
    return v**3 * (10.0 - 15.0 * v + 6.0 * v * v)


def _extension(s_end: float, s_far: float, step: float, delay: float, width: float,
               rise: float | None = None):
    """``(u, ln G - ln G_end)`` of virtual samples at log-distances ``u > 0`` from a data end.

    The log-log slope (with respect to ``u``) keeps its end value ``s_end`` over ``delay``,
    then turns to ``s_far`` along a C2 smoothstep over ``width``.  With ``rise``, a bump
    ``a S'(v)`` (zero with zero derivative at both ends of the turn, so ``G`` stays twice
    continuously differentiable) is added to the slope during the turn, ``a`` such that
    ``ln G`` ends ``rise`` above ``ln G_end``.
    """
    total = delay + width
    u = np.linspace(0.0, total, max(2, int(np.ceil(total / step))) + 1)[1:]
    v = (u - delay) / width
    out = s_end * u + (s_far - s_end) * width * _smoothstep_integral(v)
    if rise is not None:
        plain = s_end * total + 0.5 * (s_far - s_end) * width  # where the turn alone ends
        out = out + (rise - plain) * _smoothstep(v)
    return u, out


#: y^j = (x - 1)^j = sum_i _BINOMIAL[j, i] x^i
_BINOMIAL = np.array([[math.comb(j, i) * (-1.0) ** (j - i) if i <= j else 0.0
                       for i in range(6)] for j in range(6)])


def _hermite_factor(rho, d, s0, s1, k0, k1) -> np.ndarray:
    """Coefficients of ``P(x) = sum_m c_m x^m`` (shape ``(6, pieces)``) on ``[rho, 1]``.

    ``G = G_hi x^alpha P(x)`` with ``alpha`` the chord slope matches, at both ends, the
    value (``P = 1``), the log-log slope ``alpha + s`` (``x P'/P = s``) and its derivative
    ``k`` with respect to ``ln x``, so that ``G`` is twice continuously differentiable;
    ``s0, k0`` at ``x = rho``, ``s1, k1`` at ``x = 1``, ``d = 1 - rho``.
    ``P = 1 + y (y + d) Q(y)`` in ``y = x - 1``
    with ``Q`` the cubic Hermite interpolant of the values and slopes that the conditions
    fix, expanded to powers of ``x`` at the end (the expansion cancels to the size of the
    correction, well below round-off of ``G`` for smooth data).
    """
    # x P'(x) = s and x^2 P''(x) = k - s + s^2 where P = 1
    p1_lo, p1_hi = s0 / rho, s1
    p2_lo = (k0 - s0 + s0 * s0) / rho**2
    p2_hi = k1 - s1 + s1 * s1
    # w = y (y + d): w' = d at x = 1, -d at x = rho, w'' = 2
    q_hi, q_lo = p1_hi / d, -p1_lo / d
    dq_hi = (p2_hi - 2.0 * q_hi) / (2.0 * d)
    dq_lo = (2.0 * q_lo - p2_lo) / (2.0 * d)
    # Q(y) = q_hi + dq_hi y + c2 y^2 + c3 y^3 with Q(-d) = q_lo, Q'(-d) = dq_lo
    e = q_lo - q_hi + dq_hi * d
    f = dq_lo - dq_hi
    c3 = (f + 2.0 * e / d) / (d * d)
    c2 = (e + c3 * d**3) / (d * d)
    q = np.stack([q_hi, dq_hi, c2, c3])
    # P in powers of y: 1 + sum_k q_k (y^(k+2) + d y^(k+1))
    in_y = np.zeros((6,) + d.shape)
    in_y[0] = 1.0
    for k in range(4):
        in_y[k + 2] += q[k]
        in_y[k + 1] += d * q[k]
    return _BINOMIAL.T @ in_y


def _acf_pieces(dr: np.ndarray, G: np.ndarray, *, interpolation: str, low_delay: float,
                high_delay: float, low_transition: float, high_transition: float,
                flat_falling_end: bool = False, plateau: float | None = None) -> _RadialPieces:
    """Representation of ``G`` through the samples ``(dr_j, G_j)``, extended smoothly.

    Beyond the data, virtual samples continue ``G``: its log-log slope (from a cubic spline
    through the samples; at the last sample not below 0 with ``flat_falling_end``) keeps
    its end value for ``low_delay`` / ``high_delay`` decades,
    then turns smoothly (C2) within ``low_transition`` / ``high_transition`` decades to 2
    below the data (ballistic, ``G ~ dr^2`` below the first virtual sample) and to 0
    beyond it (``G`` flat beyond the last one).  Between samples: the power law through
    both (``"power law"``), or that power law times a quintic in ``x = dr / dr_{j+1}``
    that also matches, at both samples, the log-log slope and curvature of a cubic spline
    of ``ln G`` against ``ln dr`` (clamped to slopes 2 and 0 at the ends; ``"hermite"``:
    ``G`` twice continuously differentiable, so that no kink adds a slowly decaying
    ``q^-2.5`` tail to ``C``, nor a jump of ``G''`` a ``q^-3.5`` one).  With ``plateau``
    (the variance of the heights, which G reaches in the mean over all pairs), the turn
    beyond the data ends at that level (:func:`_extension` with ``rise``) instead of
    wherever the slope's turn leads.
    """
    u, v = np.log(dr), np.log(G)
    # virtual samples as dense as the data, 10 to 50 per decade
    step = float(np.clip(np.median(np.diff(u)), np.log(10.0) / 50, np.log(10.0) / 10))
    if u.size >= 4:
        s_lo, s_hi = interpolate.CubicSpline(u, v, bc_type="not-a-knot")(u[[0, -1]], 1)
    else:
        s_lo, s_hi = np.gradient(v, u)[[0, -1]]
    ln10 = np.log(10.0)
    if flat_falling_end:
        s_hi = max(float(s_hi), 0.0)
    # below the data u runs downwards, so the slopes change sign
    du_lo, dv_lo = _extension(-s_lo, -2.0, step, low_delay * ln10, low_transition * ln10)
    rise = None if plateau is None else float(np.log(plateau) - v[-1])
    du_hi, dv_hi = _extension(s_hi, 0.0, step, high_delay * ln10, high_transition * ln10,
                              rise)
    u = np.concatenate([u[0] - du_lo[::-1], u, u[-1] + du_hi])
    v = np.concatenate([v[0] + dv_lo[::-1], v, v[-1] + dv_hi])
    dr, G = np.exp(u), np.exp(v)
    alpha = np.diff(v) / np.diff(u)
    if interpolation == "hermite":
        coef = np.zeros((6, dr.size))
        coef[0] = G
        # scipy-stubs want arrays of end derivatives; a number is the 1-D case of one
        spline = interpolate.CubicSpline(u, v, bc_type=((1, 2.0), (1, 0.0)))  # type: ignore[arg-type]
        slope, curvature = spline(u, 1), spline(u, 2)
        coef[:, 1:] = G[1:] * _hermite_factor(
            dr[:-1] / dr[1:], -np.expm1(-np.diff(u)), slope[:-1] - alpha, slope[1:] - alpha,
            curvature[:-1], curvature[1:])
    elif interpolation == "power law":
        coef = G[None, :]
    else:
        raise ValueError(f"interpolation must be 'hermite' or 'power law', got {interpolation!r}")
    lo = np.concatenate([[0.0], dr[:-1]])
    return _RadialPieces(lo, dr, coef, np.concatenate([[2.0], alpha]))


class _Grids(NamedTuple):
    """Panel edges in ``r`` (knots, a log grid) and in ``t = q r``; Gauss-Legendre order."""

    r: np.ndarray
    t: np.ndarray
    order: int


def _hankel_of_pieces(q: np.ndarray, pieces: _RadialPieces, *, t_split: float,
                      panels_per_decade: float, order: int) -> np.ndarray:
    """``C(q) = 2 pi int_0^inf dr r J0(q r) [G(inf) - G(r)]`` for a piecewise ``G``.

    Two integrations by parts turn eq. 10 into the Hankel transform of the Laplacian of
    ``G``: ``q^2 C / 2pi = sum_k J_k J0(q r_k) + int dr f(r) J0(q r)`` with
    ``f = (r G')'`` and ``J_k`` the jump of ``r G'`` at knot ``r_k``; ``G(inf)`` drops out.
    As in eq. 11, the integral is split at ``a = 1/q``: below, the parts with ``J0 -> 1``
    sum to ``r G'(a)``, leaving ``-(1 - J0)`` (small, from its power series), so nothing
    cancels at small ``q`` either; above, ``J0`` (Gauss-Legendre below ``q r = T``, the
    asymptotic antiderivative of each power law of ``f`` beyond).  For ``q r_end < 1`` the
    whole form is divided by ``q^2`` analytically (``(1 - J0(t)) / t^2``), exact at
    ``q = 0``.
    """
    grids = _Grids(log_grid(np.concatenate([[0.0], pieces.hi]), panels_per_decade, depth=1.0),
                   np.concatenate([[1.0], np.arange(2.0, t_split, 2.0), [t_split]]), order)
    out = np.empty(q.size)
    small = q * pieces.hi[-1] < 1.0
    if np.any(small):
        out[small] = _hankel_below_range(q[small], pieces, grids)
    if np.any(~small):
        out[~small] = _hankel_within_range(q[~small], pieces, grids, float(t_split))
    return out


def _laplacian_quadrature(qs: np.ndarray, pieces: _RadialPieces, weight, t_max: np.ndarray,
                          grids: _Grids) -> np.ndarray:
    """``int_0^{t_max/q} f(r) weight(t, r) dr`` for each ``q`` (panels in ``t = q r``).

    ``q`` is processed in increasing order, so that each block only carries the r-panels
    that lie below ``t_max`` for its smallest ``q``.
    """
    res = np.empty(qs.size)
    order_q = np.argsort(qs)
    for blk in blocks(qs.size, (grids.r.size + grids.t.size) * grids.order):
        idx = order_q[blk]
        qb, tb = qs[idx][:, None], t_max[idx][:, None]
        cols = grids.r[grids.r * qb[0, 0] < tb.max()]
        edges = np.concatenate([cols[None, :] * qb,
                                np.broadcast_to(grids.t, (qb.shape[0], grids.t.size))], axis=1)
        edges = np.sort(np.clip(edges, 0.0, tb), axis=1)

        def integrand(t, q3=qb[..., None]):
            r = t / q3
            return pieces.laplacian(r) * weight(t, r)

        res[idx] = panel_quadrature(edges, integrand, grids.order) / qb[:, 0]
    return res


def _hankel_below_range(q: np.ndarray, pieces: _RadialPieces, grids: _Grids) -> np.ndarray:
    """``C`` for ``q r_end < 1``: the whole form divided by ``q^2`` analytically.

    ``(1 - J0(t)) / t^2`` from its power series, exact at ``q = 0``.
    """
    knots, r_end = pieces.hi, pieces.hi[-1]
    qs = np.maximum(q, 1e-300 / r_end)
    lap = _laplacian_quadrature(qs, pieces, lambda t, r: r * r * one_minus_j0_over_t2(t),
                                qs * r_end, grids)
    kn = (one_minus_j0_over_t2(qs[:, None] * knots) * knots**2) @ pieces.jumps()
    return -2.0 * np.pi * (kn + lap)


def _near_weight(t: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``J0(t)``, and ``-(1 - J0(t))`` below ``t = 1`` (its power series): one ``J0`` pass."""
    out = special.j0(t)
    small = t < 1.0
    if np.any(small):
        out[small] = -one_minus_j0(t[small])
    return out


def _hankel_within_range(q: np.ndarray, pieces: _RadialPieces, grids: _Grids,
                         T: float) -> np.ndarray:
    """``C`` for ``q r_end >= 1``: ``r G'(1/q)``, the knots, panels below ``T``, series above."""
    near = _laplacian_quadrature(
        q, pieces, _near_weight,
        np.minimum(q * pieces.hi[-1], T), grids)
    # f above t = T in the form of oscillatory_terms: r f(r) -> "q C(q)" with
    # c_top = 1 / hi^2, alpha = p0 - 2 and g_m = coef_m (p0 + m)^2
    p = pieces.p0[None, :] + np.arange(pieces.coef.shape[0])[:, None]
    g = pieces.coef * p * p
    c_top = np.where(np.any(g != 0, axis=0), pieces.hi**-2.0, 0.0)
    far = oscillatory_terms(q, pieces.lo, pieces.hi, c_top, pieces.p0 - 2.0, g, T,
                            grids.order)
    t_k = q[:, None] * pieces.hi
    kn = np.where(t_k <= 1.0, -one_minus_j0(t_k), special.j0(t_k)) @ pieces.jumps()
    return 2.0 * np.pi * (pieces.r_dG(1.0 / q) + kn + near + far) / q**2


def _check_acf(dr, G) -> tuple[np.ndarray, np.ndarray]:
    r = np.asarray(dr, dtype=float)
    g = np.asarray(G, dtype=float)
    if r.ndim != 1 or r.shape != g.shape or r.size < 4:
        raise ValueError("dr and G must be 1-D arrays of the same length >= 4")
    require_increasing(r, "dr", noun="lags")
    if not (np.all(np.isfinite(g)) and np.all(g > 0)):
        raise ValueError("G must be finite and > 0")
    return r, g


def spectrum_from_acf_kernel(
    q,
    dr,
    G,
    *,
    interpolation: str = "hermite",
    low_delay: float = 0.0,
    high_delay: float = 0.0,
    low_transition: float = 1.0,
    high_transition: float = 1.0,
    plateau: float | None = None,
    t_split: float = 64.0,
    panels_per_decade: float = 6.0,
    order: int = 8,
) -> np.ndarray:
    """Isotropic spectrum from samples of the height-difference ACF, eq. 10/11.

    ``C(q) = 2 pi int_0^inf d(dr) dr J0(q dr) [sigma_h^2 - G(dr)]``, evaluated (after two
    integrations by parts) as ``C = (2 pi / q^2) int d(dr) J0(q dr) d/d(dr)[dr dG/d(dr)]``,
    which has no ``sigma_h^2 - G`` cancellation: ``sigma_h^2`` drops out.

    Parameters
    ----------
    q : array_like
        Angular wavenumbers (1/length, in the inverse unit of ``dr``), ``>= 0``, any shape.
    dr, G : array_like
        At least four samples: strictly increasing positive lags and ``G > 0`` (length^2).
    interpolation : {'hermite', 'power law'}
        Between samples, the power law through both, times a quintic correction that
        matches the slopes and curvatures of a log-log cubic spline (``'hermite'``, twice
        continuously differentiable), or the bare power law (kinks at the samples).
    low_delay, high_delay : float
        Decades over which the log-log slope of the first / last samples continues
        unchanged before it turns to 2 (below the data) or 0 (beyond).
    low_transition, high_transition : float
        Decades over which the slope then turns (a C2 smoothstep).
    plateau : float, optional
        The level ``sigma_h^2`` (length^2) that ``G`` reaches beyond the data, e.g. the
        variance of the heights it was measured from: the turn to flat ends there
        (changing ``C`` only below ``q ~ 2 pi / dr_max``, where the data leave it open).
        Default: wherever the turn of the slope leads.
    t_split, panels_per_decade, order : float, float, int
        Quadrature below ``q dr = t_split`` (panels at every sample, a logarithmic grid
        and spacing 2 in ``q dr``; ``f`` is smooth between samples, so order 8 reaches the
        accuracy of order 16), asymptotic antiderivatives above (as in
        :func:`~xrough._kernels.hankel.acf_from_spectrum_kernel`).

    Returns
    -------
    numpy.ndarray
        ``C`` (length^4) with the shape of ``q``.

    Notes
    -----
    The level ``sigma_h^2`` and the accuracy: docs/spectra.md, "spectrum_from_acf_kernel".

    Raises
    ------
    ValueError
        Fewer than 4 samples, lags not positive and strictly increasing, ``G <= 0`` or not
        finite, negative or non-finite ``q``, an unknown ``interpolation``.

    Examples
    --------
    A Gaussian height ACF, ``G = 1 - exp(-dr^2/2)``, has ``C = 2 pi exp(-q^2/2)``:

    >>> import numpy as np
    >>> dr = np.logspace(-3, 2, 101)
    >>> q = np.array([0.1, 1.0, 2.0])
    >>> C = spectrum_from_acf_kernel(q, dr, -np.expm1(-dr**2 / 2))
    >>> bool(np.allclose(C, 2 * np.pi * np.exp(-q**2 / 2), rtol=1e-4, atol=0))
    True
    """
    q_in = np.asarray(q, dtype=float)
    if not (np.all(np.isfinite(q_in)) and np.all(q_in >= 0)):
        raise ValueError("q must be finite and >= 0")
    pieces = _acf_pieces(*_check_acf(dr, G), interpolation=interpolation, low_delay=low_delay,
                         high_delay=high_delay, low_transition=low_transition,
                         high_transition=high_transition, plateau=_plateau(plateau))
    return _hankel_of_pieces(q_in.ravel(), pieces, t_split=t_split,
                             panels_per_decade=panels_per_decade,
                             order=order).reshape(q_in.shape)


def _plateau(plateau) -> float | None:
    """Return a checked ``plateau`` option: ``None`` or a finite positive level."""
    if plateau is None:
        return None
    value = float(plateau)
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"plateau must be a finite level > 0 (length^2), got {plateau!r}")
    return value


def acf_plateau_kernel(dr, G, *, high_transition: float = 1.0) -> float:
    """``sigma_h^2``: the level at large ``dr`` of ``G`` as extended by the spectrum kernel.

    A ``G`` that falls at its last lag (a periodic map near ``L/2``, an oscillation) is
    held at its last level instead: the spectrum kernel continues the fall for the
    extrapolation check of ``C`` at the smallest ``q``, which no ``G`` measured up to
    there determines, but a decade of that fall is no plateau (it put ``sigma_h^2`` at
    a sixth of the variance of a periodic profile).

    Examples
    --------
    >>> import numpy as np
    >>> dr = np.logspace(-2, 2, 41)
    >>> print(f"{acf_plateau_kernel(dr, 3.0 * -np.expm1(-dr**2)):.6f}")
    3.000000
    """
    r, g = _check_acf(dr, G)
    pieces = _acf_pieces(r, g, interpolation="power law", low_delay=0.0, high_delay=0.0,
                         low_transition=1.0, high_transition=high_transition,
                         flat_falling_end=True)
    return float(pieces.coef[0, -1])


def smooth_acf_kernel(dr, G, width: float) -> np.ndarray:
    """``G`` smoothed by local quadratic regression of ``ln G`` on ``log10 dr``.

    Tricube weights over a window of ``width`` decades centred on each sample (LOESS);
    power laws and log-log parabolas pass unchanged.  Samples whose window holds fewer than
    four points keep their value.

    Examples
    --------
    >>> import numpy as np
    >>> dr = np.logspace(0, 3, 31)
    >>> bool(np.allclose(smooth_acf_kernel(dr, 2.0 * dr**0.6, 0.5), 2.0 * dr**0.6))
    True
    """
    r, g = _check_acf(dr, G)
    x, v = np.log10(r), np.log(g)
    d = (x[None, :] - x[:, None]) / (0.5 * width)
    w = np.where(np.abs(d) < 1.0, (1.0 - np.abs(d) ** 3) ** 3, 0.0)
    powers = d[..., None] ** np.arange(5)  # (j, i, k)
    moments = np.einsum("ji,jik->jk", w, powers)
    normal = moments[:, np.array([[0, 1, 2], [1, 2, 3], [2, 3, 4]])]
    rhs = np.einsum("ji,jik,i->jk", w, powers[..., :3], v)
    enough = np.count_nonzero(w > 0, axis=1) >= 4
    out = v.copy()
    if np.any(enough):
        out[enough] = np.linalg.solve(normal[enough], rhs[enough][..., None])[:, 0, 0]
    return np.exp(out)


#: Half width (decades) of the running maximum of the changes of C: the difference
#: between two extrapolations oscillates in q, and its zeros are no agreement.
_ENVELOPE = 0.2
#: How the extrapolations of G are varied to test what the data leave open: each end's
#: slope turns later (kept one decade longer) or sooner (within 0.2 instead of 1 decade).
_EXTRAPOLATION_VARIANTS = (dict(low_delay=1.0), dict(low_transition=0.2),
                           dict(high_delay=1.0), dict(high_transition=0.2))
#: The same where the level beyond the data is known (``plateau``): the turn to it takes
#: three decades instead of one, or 0.2 (a slope kept for a decade and then undone to
#: reach the level would be a swing no G with that variance makes).
_PLATEAU_VARIANTS = _EXTRAPOLATION_VARIANTS[:2] + (dict(high_transition=3.0),
                                                   dict(high_transition=0.2))


def spectrum_variants_kernel(
    q,
    dr,
    G,
    *,
    noise=0.0,
    smooth: float | None = None,
    draws: int = 16,
    **options,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``C`` from ``G`` and from the variants that measure what the data leave open.

    Returns ``(base, extrapolated, noisy)``: ``C`` at ``q`` from ``G`` (smoothed over
    ``smooth`` decades of local quadratic regression if given); from the same data with
    the log-log slope at the smallest and at the largest lag turning later (kept one
    decade longer) or sooner (within 0.2 instead of 1 decade) than by default, without
    ``plateau``, and with a ``plateau`` also by default without it (shape
    ``(4 or 5, q.size)``: the level the heights' variance sets is one extrapolation more,
    and a turn forced to it within 0.2 decades would be a kink no measured G has); and
    from ``draws`` copies of ``G`` with independent relative noise ``noise`` per sample
    (a value or one per sample; seeded, so reproducible; shape ``(0, q.size)`` without
    noise).  ``options`` go to :func:`spectrum_from_acf_kernel`.
    """
    r, g = _check_acf(dr, G)
    base = _smoothed_spectrum(q, r, g, smooth, **options)
    free = {k: v for k, v in options.items() if k != "plateau"}
    variants = list(_EXTRAPOLATION_VARIANTS)
    if options.get("plateau") is not None:
        variants.append({})
    extrapolated = np.array([_smoothed_spectrum(q, r, g, smooth, **free, **kw)
                             for kw in variants])
    noise = np.broadcast_to(np.asarray(noise, dtype=float), g.shape)
    noisy = np.empty((0,) + base.shape)
    if np.any(noise > 0):
        rng = np.random.default_rng(0)
        noisy = np.array([
            _smoothed_spectrum(q, r, g * np.exp(noise * rng.standard_normal(g.size)), smooth,
                               **options)
            for _ in range(draws)])
    return base, extrapolated, noisy


def _smoothed_spectrum(q, r, g, smooth: float | None, **options) -> np.ndarray:
    """``C`` at ``q`` from ``G``, smoothed first over ``smooth`` decades if given."""
    values = g if smooth is None else smooth_acf_kernel(r, g, smooth)
    return spectrum_from_acf_kernel(q, r, values, **options)


def spectrum_error_kernel(q, dr, G, covariance, *, smooth: float | None = None,
                          interpolation: str = "hermite", plateau: float | None = None,
                          captured: float = 1.0) -> np.ndarray:
    """Propagate a covariance of the relative errors of ``G`` to the standard error of ``C``.

    Linear propagation along the principal axes of ``covariance`` (``Cov(dG_i / G_i,
    dG_j / G_j)``): ``G`` is moved by one standard deviation along each eigenvector, in
    decreasing order of eigenvalue until ``captured`` of the trace is reached, and the
    changes of ``C`` add in quadrature.  Deterministic (no random draws).  All of them by
    default: the finite-area error of G (:func:`~xrough._kernels.uncertainty.g_covariance`)
    has most of its variance in a few smooth eigenvectors, but ``C`` at large ``q``
    depends on the curvature of ``G`` at small lags, which lives in the smallest ones
    (on a 2^14-point profile, keeping 99.99 % of the trace gives a third of the scatter
    of ``C`` at ``q_s / 2``).

    Parameters
    ----------
    q, dr, G : array_like
        Wavenumbers and the samples of ``G`` (as for :func:`spectrum_from_acf_kernel`).
    covariance : array_like (n, n)
        Covariance of the relative errors of the samples (dimensionless).
    smooth, interpolation, plateau
        As for :func:`spectrum_variants_kernel` (``plateau`` held fixed).
    captured : float
        Fraction of the total relative variance the eigenvectors used account for (the
        eigenvectors with eigenvalues below ``1e-12`` of the largest are left out).

    Returns
    -------
    numpy.ndarray
        Standard error of ``C`` at ``q`` (length^4), 0 where ``G`` has no error.

    Examples
    --------
    A 10 % error common to all bins (a height calibration) scales ``C`` by 10 %:

    >>> import numpy as np
    >>> dr = np.logspace(-2, 2, 41)
    >>> G = -np.expm1(-dr**2)
    >>> q = np.array([0.5, 2.0])
    >>> C = spectrum_from_acf_kernel(q, dr, G)
    >>> err = spectrum_error_kernel(q, dr, G, np.full((41, 41), 0.01))
    >>> print(np.round(err / C, 3))
    [0.105 0.105]
    """
    r, g = _check_acf(dr, G)
    q = np.asarray(q, dtype=float)
    scale, axes = principal_axes(covariance, g.size, captured)
    if scale.size == 0:
        return np.zeros(q.shape)
    options = dict(interpolation=interpolation, plateau=plateau)
    base = _smoothed_spectrum(q, r, g, smooth, **options)
    var = np.zeros(q.shape)
    for k in range(scale.size):
        moved = g * np.exp(scale[k] * axes[:, k])
        var += (_smoothed_spectrum(q, r, moved, smooth, **options) - base) ** 2
    return np.sqrt(var)


def principal_axes(covariance, size: int, captured: float) -> tuple[np.ndarray, np.ndarray]:
    """Return the standard deviations and eigenvectors that hold ``captured`` of ``covariance``.

    In decreasing order of eigenvalue, until ``captured`` of the trace is reached, leaving
    out eigenvalues below ``1e-12`` of the largest; none if the covariance is 0.
    """
    cov = np.asarray(covariance, dtype=float)
    if cov.shape != (size, size):
        raise ValueError(f"covariance must have shape {(size, size)}, got {cov.shape}")
    w, v = np.linalg.eigh(0.5 * (cov + cov.T))
    order = np.argsort(w)[::-1]
    w, v = np.clip(w[order], 0.0, None), v[:, order]
    if not w.sum() > 0:
        return np.empty(0), np.empty((size, 0))
    n = min(int(np.searchsorted(np.cumsum(w) / w.sum(), captured)) + 1,
            int(np.count_nonzero(w > 1e-12 * w[0])))
    return np.sqrt(w[:n]), v[:, :n]


def supported_interval(x, change, rtol: float, *, envelope: float = 0.0,
                       smooth_change=None) -> tuple[float, float]:
    """Longest run of increasing ``x`` with ``change <= rtol``, ends interpolated in log.

    ``change`` is first replaced by its maximum over ``+-envelope`` decades of ``x`` (so
    that the zero crossings of an oscillating difference do not count as agreement), and
    then by its maximum with ``smooth_change`` (a change that does not oscillate, taken
    as it is).
    Each end then moves from the last point inside towards the first outside, to where
    ``log(change)`` interpolated linearly in ``log x`` crosses ``log(rtol)``.
    ``(nan, nan)`` if no point qualifies.

    Examples
    --------
    >>> lo, hi = supported_interval([1.0, 10.0, 100.0, 1e3], [1.0, 1e-3, 1e-4, 1e-1], 1e-2)
    >>> print(f"{lo:.4f} {hi:.2f}")  # 10^(2/3) and 10^(8/3)
    4.6416 464.16
    """
    x = np.asarray(x, dtype=float)
    change = np.asarray(change, dtype=float)
    if envelope > 0:
        lx10 = np.log10(x)
        near = np.abs(lx10[:, None] - lx10[None, :]) <= envelope * (1 + 1e-9)  # grid round-off
        change = np.max(np.where(near, change[None, :], -np.inf), axis=1)
    if smooth_change is not None:
        change = np.maximum(change, np.asarray(smooth_change, dtype=float))
    ok = change <= rtol
    if not np.any(ok):
        return float("nan"), float("nan")
    edges = np.diff(np.concatenate([[0], ok.astype(int), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    k = int(np.argmax(np.log(x[stops]) - np.log(x[starts])))
    i, j = starts[k], stops[k]
    lx = np.log(x)

    def crossing(a: int, b: int) -> float:
        ca = np.log(max(change[a], 1e-300))
        if not np.isfinite(change[b]):
            return lx[a]
        cb = np.log(change[b])
        return lx[a] + (lx[b] - lx[a]) * (np.log(rtol) - ca) / (cb - ca)

    lo = np.exp(crossing(i, i - 1)) if i > 0 else x[0]
    hi = np.exp(crossing(j, j + 1)) if j < x.size - 1 else x[-1]
    return float(lo), float(hi)


def spectrum_support_kernel(
    dr,
    G,
    *,
    rtol: float = 0.01,
    points_per_decade: float = 10.0,
    error=None,
    max_error: float = 0.1,
    **options,
) -> tuple[float, float]:
    """Range of ``q`` where :func:`spectrum_from_acf_kernel` gives a ``C`` fixed by the data.

    On a logarithmic grid over ``[2 pi / dr_max, 2 pi / dr_min]``: where ``C > 0`` and
    neither extrapolation variant nor the noise (standard deviation over the noisy copies)
    of :func:`spectrum_variants_kernel` nor, below the roll-off, the choice of samples
    (``C`` from the even against the odd samples, :func:`_sampling_change`) changes ``C``
    by more than ``rtol |C|`` (taking the largest change within +-0.2 decades), and, with
    ``error``, the standard error of ``C`` (:func:`spectrum_error_kernel`) is at most
    ``max_error |C|``; the longest such interval (:func:`supported_interval`).

    Parameters
    ----------
    dr, G : array_like
        The samples of ``G`` (as for :func:`spectrum_from_acf_kernel`).
    rtol : float
        Largest relative change of ``C`` that counts as supported.
    points_per_decade : float
        Density of the ``q`` grid the changes are evaluated on.
    error : array_like, optional
        Standard error of ``C`` on :func:`support_grid` (``points_per_decade``), e.g.
        from :func:`spectrum_error_kernel`.
    max_error : float
        Largest relative standard error of ``C`` that counts as supported.
    **options
        ``noise``, ``smooth``, ``draws`` and options of
        :func:`spectrum_from_acf_kernel`, passed to :func:`spectrum_variants_kernel`.

    Returns
    -------
    tuple of float
        ``(q_lo, q_hi)``, ``(nan, nan)`` where nothing qualifies.

    Examples
    --------
    An exponential height ACF is not ballistic at small ``dr``: ``C`` is supported up to
    about ``0.4 / dr_min`` only (not ``2 pi / dr_min``).

    >>> import numpy as np
    >>> dr = np.logspace(-2, 2, 81)
    >>> lo, hi = spectrum_support_kernel(dr, -np.expm1(-dr))
    >>> print(f"{lo:.3f} {hi:.0f}")
    0.063 41
    """
    r, g = _check_acf(dr, G)
    q = support_grid(r, points_per_decade)
    base, extrapolated, noisy = spectrum_variants_kernel(q, r, g, **options)
    change = np.max(np.abs(extrapolated - base), axis=0)
    if noisy.shape[0]:
        change = np.maximum(change, np.std(noisy, axis=0))
    change = np.maximum(change, _sampling_change(q, r, g, base, rtol, **options))
    with np.errstate(divide="ignore", invalid="ignore"):
        change = np.where(base > 0, change / base, np.inf) / rtol
        statistical = (None if error is None else
                       np.where(base > 0, np.asarray(error) / base, np.inf) / max_error)
    return supported_interval(q, change, 1.0, envelope=_ENVELOPE, smooth_change=statistical)


def support_grid(dr, points_per_decade: float = 10.0) -> np.ndarray:
    """Return the ``q`` on which :func:`spectrum_support_kernel` judges (``2 pi / dr``)."""
    r = np.asarray(dr, dtype=float)
    return np.geomspace(2 * np.pi / r[-1], 2 * np.pi / r[0],
                        max(2, int(np.ceil(points_per_decade * np.log10(r[-1] / r[0]))) + 1))


def _sampling_change(q, r, g, base, rtol: float, *, smooth: float | None = None,
                     interpolation: str = "hermite", plateau: float | None = None,
                     **_) -> np.ndarray:
    """How much ``C`` below its roll-off depends on which samples of ``G`` are used.

    ``C`` from the even and from the odd samples (both keep the first and the last), half
    their difference, at the ``q`` up to the maximum of ``q^2 C`` (the roll-off), 0
    above. A kink of ``C`` at the roll-off (the sharp eq. 35) rings in ``G`` beyond
    ``lambda_r`` as ``dr^-5/2``, faster than a logarithmic grid samples: each half of the
    samples aliases that ringing with its own phase, and ``C`` far below the roll-off
    from the two halves differs by about the error of ``C`` from all samples (sharp
    eq. 35, H = 0.8, 20 per decade: 19 % both). A smooth ``G`` gives nearly the same
    ``C`` from both halves (1e-4), and so does a ``G`` measured on a lattice: the scatter
    of the lattice distances between bins changes ``C`` from both halves alike (the
    half-sum), not their difference. Above the roll-off the difference is not measured:
    there the jump of ``C`` at ``q_s`` rings in both halves, and measured ``G`` give
    differences of a few % where ``C`` agrees with its model to 2 %. A ``G`` whose own
    bin-to-bin scatter (:func:`_scatter`, not declared as noise) exceeds ``rtol`` is not
    compared: the halves of its samples differ by that scatter, amplified far below the
    roll-off, and would leave nothing supported (5 % scatter at 10 per decade).

    Parameters
    ----------
    q, r, g : numpy.ndarray
        The grid of wavenumbers and the checked samples of ``G``.
    base : numpy.ndarray
        ``C`` at ``q`` from all samples.
    rtol : float
        The relative change allowed; a larger scatter of ``G`` skips the comparison.
    smooth, interpolation, plateau
        As for :func:`spectrum_variants_kernel`; other options are ignored.

    Returns
    -------
    numpy.ndarray
        Half the difference of the two ``C`` (length^4), 0 above the roll-off.
    """
    out = np.zeros_like(base)
    even = np.unique(np.r_[0:r.size:2, r.size - 1])
    odd = np.unique(np.r_[0, 1:r.size:2, r.size - 1])
    if odd.size < 4 or not np.any(base > 0):
        return out
    values = g if smooth is None else smooth_acf_kernel(r, g, smooth)
    if _scatter(r, values) > rtol:
        return out
    below = q <= q[np.argmax(np.where(base > 0, q * q * base, -np.inf))]
    halves = [spectrum_from_acf_kernel(q[below], r[k], values[k], interpolation=interpolation,
                                       plateau=plateau) for k in (even, odd)]
    out[below] = 0.5 * np.abs(halves[0] - halves[1])
    return out


def _scatter(r: np.ndarray, g: np.ndarray) -> float:
    """Return the robust relative bin-to-bin scatter of ``G``.

    The median residual of ``ln G`` from the cubic (in ``ln dr``) through the two samples
    on either side, scaled to a standard deviation (0 with fewer than 5 samples).

    Parameters
    ----------
    r, g : numpy.ndarray
        The checked samples of ``G``.

    Returns
    -------
    float
        The relative scatter (0.05 for 5 % independent scatter; ~1e-5 for a smooth ``G``
        at 20 per decade, 1e-4 to 1e-3 for ``G`` measured on a lattice).
    """
    if r.size < 5:
        return 0.0
    x, v = np.log(r), np.log(g)
    k = np.arange(2, r.size - 2)
    nb = np.stack([k - 2, k - 1, k + 1, k + 2])  # (4, n)
    weights = np.ones(nb.shape)
    for j in range(4):
        for m in range(4):
            if m != j:
                weights[j] *= (x[k] - x[nb[m]]) / (x[nb[j]] - x[nb[m]])
    res = (v[k] - np.sum(weights * v[nb], axis=0)) / np.sqrt(1 + np.sum(weights**2, axis=0))
    return float(MAD_TO_SIGMA * np.median(np.abs(res)))

