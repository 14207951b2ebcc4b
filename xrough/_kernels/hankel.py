"""Hankel-type integrals of isotropic spectra (pure numpy/scipy, no xarray).

Conventions (docs/theory.md): angular wavenumber ``q``; isotropic 2D spectrum ``C(q)`` (length^4);

* eq. 9, height-difference ACF:
  ``G(dr) = (1/2pi) int_0^inf dq q C(q) [1 - J0(q dr)]``;
* eq. 10, spectrum from the height-difference ACF:
  ``C(q) = 2 pi int_0^inf d(dr) dr J0(q dr) [sigma_h^2 - G(dr)]``;
* spectral moments ``(1/2pi) int_0^inf dq q^(1+k) C(q)`` (k=0: sigma_h^2, k=2: gbar^2);
* 1D spectrum of a line scan through an isotropic surface,
  ``C1D(qx) = (1/pi) int_|qx|^inf dq q C(q) / sqrt(q^2 - qx^2)`` (length^3), normalised so that
  ``G(x) = (1/pi) int_0^inf dqx C1D(qx) [1 - cos(qx x)]`` equals the 2D ``G``.

Spectra are vectorised callables ``C(q)`` that vanish outside ``[breakpoints[0],
breakpoints[-1]]`` and are smooth (analytic) between consecutive breakpoints; jumps and kinks
are allowed only at breakpoints.

Method for eq. 9 (with ``t = q dr`` and a split point ``T``, default 64):

* ``t < T``: composite Gauss-Legendre on panels whose edges are the breakpoints, a
  logarithmic grid in ``q`` (resolves power laws over many decades) and a grid of spacing 2 in
  ``t`` (resolves the at most ``T/pi`` oscillations of ``J0``).  ``1 - J0(t)`` comes from its
  power series for ``t < 1``, so ``G ~ gbar^2 dr^2 / 4`` keeps full relative precision at small
  ``dr``.
* ``t > T``: ``int q C dq`` minus ``int q C J0(q dr) dq``.  The first comes from
  Gauss-Legendre integrals over the fixed ``q`` panels, summed from the top (positive terms,
  no cancellation), plus one partial panel at ``q = T/dr``.  For the second, ``C`` is
  represented between knots as a power law through both knots (the breakpoints themselves
  when ``C`` is a power law between them: exact), or, for smooth spectra, times a quadratic
  correction that also matches ``C`` at the geometric midpoint (``knots_per_decade`` knots;
  error ~ h^3 and only ~T^-1.5 of ``G`` is affected).  Each power law ``int t^beta J0(t) dt``
  is integrated in closed form from the Hankel asymptotic expansion of ``J0`` combined with
  the asymptotic antiderivative of ``t^gamma e^{it}``, regrouped into one series
  ``sum_m d_m(beta) t^-m`` that is truncated where its terms fall below 1e-17.  The cost is
  O(1) per piece, whatever the number of oscillations.  Pieces with a steep exponent
  (``|beta|`` comparable to ``T``, e.g. noisy measured spectra) start the expansion later
  and are integrated by Gauss-Legendre in between.

The moment of sampled spectra (eq. 26, :func:`power_law_moment_kernel`) is exact per piece.
The quadrature and the asymptotic series that both directions use are in
:mod:`xrough._kernels.bessel`.

The inverse direction, ``C`` from samples of ``G`` (eq. 10/11), is
:mod:`xrough._kernels.spectrum_of_acf`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .bessel import (
    blocks,
    gauss_legendre,
    log_grid,
    one_minus_j0,
    oscillatory_terms,
    panel_quadrature,
)
from .checks import require_increasing

__all__ = [
    "acf_from_spectrum_kernel",
    "spectral_moment_kernel",
    "power_law_moment_kernel",
    "binned_moment_kernel",
    "profile_spectrum_kernel",
    "PowerLawInterpolant",
]

Spectrum = Callable[[np.ndarray], np.ndarray]

#: Relative offset used to evaluate one-sided limits of C at knots (C may jump there).
_NUDGE = 1e-11


def _check_breakpoints(breakpoints) -> np.ndarray:
    bp = np.unique(np.asarray(breakpoints, dtype=float).ravel())
    if bp.size < 2 or not np.all(np.isfinite(bp)) or bp[0] < 0:
        raise ValueError(
            "breakpoints must hold at least two distinct finite wavenumbers >= 0 (the support "
            f"of C and the places where it jumps or kinks), got {breakpoints!r}"
        )
    return bp


# --------------------------------------------------------------------------------------
# piecewise power laws
# --------------------------------------------------------------------------------------
class PowerLawInterpolant:
    """Piecewise power law through samples ``(q_j, C_j)`` (log-log interpolation).

    ``C(q) = C_j (q/q_j)^alpha_j`` on ``[q_j, q_{j+1}]``; zero outside ``[q_0, q_last]`` and on
    pieces that touch a zero sample.  Callable (vectorised); :attr:`breakpoints` are the
    samples, and the interpolant is an exact power law between consecutive breakpoints.

    Parameters
    ----------
    q : array_like
        Strictly increasing positive wavenumbers.
    values : array_like
        Non-negative finite samples ``C(q)``.
    """

    def __init__(self, q, values) -> None:
        q = np.asarray(q, dtype=float)
        c = np.asarray(values, dtype=float)
        if q.ndim != 1 or q.shape != c.shape or q.size < 2:
            raise ValueError("q and values must be 1-D arrays of the same length >= 2")
        require_increasing(q, "q", noun="wavenumbers")
        if not (np.all(np.isfinite(c)) and np.all(c >= 0)):
            raise ValueError("spectrum values must be finite and >= 0")
        self.q = q
        self.values = c
        pos = (c[:-1] > 0) & (c[1:] > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            alpha = np.log(c[1:] / c[:-1]) / np.log(q[1:] / q[:-1])
        self.alpha = np.where(pos, alpha, 0.0)
        self.coef = np.where(pos, c[:-1], 0.0)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """The sample wavenumbers."""
        return tuple(self.q)

    def __call__(self, q: np.ndarray) -> np.ndarray:
        """Interpolated ``C(q)``."""
        x = np.asarray(q, dtype=float)
        j = np.clip(np.searchsorted(self.q, x, side="right") - 1, 0, self.q.size - 2)
        inside = (x >= self.q[0]) & (x <= self.q[-1])
        with np.errstate(all="ignore"):
            val = self.coef[j] * np.exp(self.alpha[j] * np.log(x / self.q[j]))
        out = np.where(inside, val, 0.0)
        # exact sample values (the last sample belongs to the last piece)
        return np.where(x == self.q[-1], self.values[-1] if self.coef[-1] > 0 else 0.0, out)


def _power_law_pieces(spectrum: Spectrum, bp: np.ndarray, knots_per_decade: float,
                      q_min: float):
    """Piecewise representation of ``C`` for the oscillatory integral.

    Returns ``(K_lo, K_hi, c_top, alpha, kappa)`` for the pieces that reach above ``q_min``,
    with ``C(q) = c_top x^alpha [1 + kappa (x - rho)(x - 1)]``, ``x = q / K_hi``,
    ``rho = K_lo / K_hi``: a power law through both knots, times a quadratic correction that
    also matches ``C`` at the geometric midpoint (``kappa = 0`` when ``C`` is declared a power
    law between breakpoints).  One-sided limits at the knots come from evaluations nudged into
    the piece, rescaled with the piece's own exponent.
    """
    refine = bool(knots_per_decade) and knots_per_decade > 0
    lo_list, hi_list = [], []
    for a, b in zip(bp[:-1], bp[1:], strict=True):
        if b <= q_min:
            continue
        if refine:
            # (a segment from 0 ends in one power-law piece [0, start]; C(q) is analytic
            # there, so start <= 1e-12 b is plenty)
            start = a if a > 0 else max(min(b * 1e-3, 0.5 * q_min), b * 1e-12)
            n = max(1, int(np.ceil(knots_per_decade * np.log10(b / start))))
            k = np.geomspace(start, b, n + 1)
            k[0], k[-1] = start, b
            if a == 0:
                k = np.concatenate([[0.0], k])
        else:
            k = np.array([a, b])
        lo_list.append(k[:-1])
        hi_list.append(k[1:])
    if not lo_list:
        empty = np.empty(0)
        return empty, empty, empty, empty, empty
    klo = np.concatenate(lo_list)
    khi = np.concatenate(hi_list)
    keep = khi > q_min
    klo, khi = klo[keep], khi[keep]
    # evaluation points inside each piece
    p_hi = khi * (1.0 - _NUDGE)
    p_lo = np.where(klo > 0, klo * (1.0 + _NUDGE), 0.5 * khi)
    with np.errstate(all="ignore"):
        c_hi = np.asarray(spectrum(p_hi), dtype=float)
        c_lo = np.asarray(spectrum(p_lo), dtype=float)
        alpha = np.log(c_hi / c_lo) / np.log(p_hi / p_lo)
        ok = (c_hi > 0) & (c_lo > 0) & np.isfinite(alpha)
        c_top = np.where(ok, c_hi * (khi / p_hi) ** alpha, 0.0)
        alpha = np.where(ok, alpha, 0.0)
        kappa = np.zeros_like(khi)
        if refine:
            rho = klo / khi
            x_mid = np.sqrt(rho)
            c_mid = np.asarray(spectrum(khi * x_mid), dtype=float)
            kappa = (c_mid / (c_top * x_mid**alpha) - 1.0) / ((x_mid - rho) * (x_mid - 1.0))
            kappa = np.where(ok & (klo > 0) & np.isfinite(kappa), kappa, 0.0)
    return klo, khi, c_top, alpha, kappa


def _oscillatory_part(r: np.ndarray, pieces, t_split: float, order: int) -> np.ndarray:
    """``int_{T/r}^inf q C(q) J0(q r) dq`` for the piecewise representation ``pieces``."""
    klo, khi, c_top, alpha, kappa = pieces
    rho = klo / khi
    # q C(q) = c_top K_hi sum_j g_j x^(1 + alpha + j), x = q / K_hi
    g = np.stack([1.0 + kappa * rho, -kappa * (1.0 + rho), kappa])
    return oscillatory_terms(r, klo, khi, c_top, alpha, g, t_split, order)


# --------------------------------------------------------------------------------------
# public kernels
# --------------------------------------------------------------------------------------
def acf_from_spectrum_kernel(
    dr,
    spectrum: Spectrum,
    breakpoints,
    *,
    knots_per_decade: float = 160.0,
    t_split: float = 64.0,
    panels_per_decade: float = 6.0,
    order: int = 16,
) -> np.ndarray:
    """Height-difference ACF from an isotropic spectrum, eq. 9.

    ``G(dr) = (1/2pi) int_0^inf dq q C(q) [1 - J0(q dr)]``.

    Parameters
    ----------
    dr : array_like
        Lag distances (length, >= 0), any shape.
    spectrum : callable
        Vectorised ``C(q)`` (length^4, in the inverse of the unit of ``dr`` for ``q``); zero
        outside ``[breakpoints[0], breakpoints[-1]]``.
    breakpoints : sequence of float
        Increasing wavenumbers: the support of ``C`` and every place where it jumps or kinks.
    knots_per_decade : float
        Knot density of the piecewise power law that represents ``C`` in the oscillatory
        range ``q dr > t_split``.  ``0`` declares that ``C`` is an exact power law between
        consecutive breakpoints (the sharp model, log-log interpolated samples); the
        breakpoints are then the only knots and the representation is exact.
    t_split : float
        ``T``: Gauss-Legendre with the full ``1 - J0`` below ``q dr = T``, asymptotic
        closed form of the ``J0`` part above.
    panels_per_decade, order : float, int
        Logarithmic panel density in ``q`` and Gauss-Legendre order per panel.

    Returns
    -------
    numpy.ndarray
        ``G`` (length^2) with the shape of ``dr``.

    Notes
    -----
    Measured relative accuracy (against 30-digit mpmath) over 16 decades of ``dr``
    (``1e-4/q_s`` to ``1e6/q_r``, ``q_s/q_r = 1e6``, ``0.05 <= H <= 0.95``): a few 1e-15 for
    the sharp model (an exact piecewise power law), about 1e-10 for the smooth roll-off with
    the default knot density (run times: docs/performance.md).

    Examples
    --------
    A flat disc of spectrum, ``C = 1`` for ``q < 1``:
    ``G = (1/2pi)(1/2 - J1(dr)/dr)``.

    >>> import numpy as np
    >>> from scipy.special import j1
    >>> flat = lambda q: np.where(q < 1.0, 1.0, 0.0)
    >>> dr = np.array([0.5, 1.0, 1e4])
    >>> G = acf_from_spectrum_kernel(dr, flat, [0.0, 1.0], knots_per_decade=0)
    >>> exact = (0.5 - j1(dr) / dr) / (2 * np.pi)
    >>> bool(np.allclose(G, exact, rtol=1e-12, atol=0))
    True
    """
    r_in = np.asarray(dr, dtype=float)
    r = r_in.ravel()
    if not np.all(np.isfinite(r)) or np.any(r < 0):
        raise ValueError("dr must be finite and >= 0")
    bp = _check_breakpoints(breakpoints)
    out = np.zeros(r.size)
    pos = np.nonzero(r > 0)[0]
    if pos.size:
        rp, T = r[pos], float(t_split)
        qgrid = log_grid(bp, panels_per_decade, depth=4.0)
        total = (_below_split(rp, spectrum, qgrid, bp, T, order)
                 + _mass_above_split(rp, spectrum, qgrid, bp, T, order))
        osc = _oscillation_above_split(rp, spectrum, bp, T, knots_per_decade, order)
        out[pos] = (total - osc) / (2.0 * np.pi)
    return out.reshape(r_in.shape)


def _below_split(rp, spectrum: Spectrum, qgrid, bp, T: float, order: int) -> np.ndarray:
    """``int q C(q) [1 - J0(q r)] dq`` over ``q r < T``: Gauss-Legendre on t-panels.

    ``r`` is processed in increasing order, so that each block only carries the q-panels
    that lie below ``t = T`` for its smallest ``r``.
    """
    q_lo, q_hi = bp[0], bp[-1]
    tgrid = np.append(np.arange(2.0, T, 2.0), T)
    order_r = np.argsort(rp)
    out = np.empty(rp.size)
    for blk in blocks(rp.size, (qgrid.size + tgrid.size) * order):
        idx = order_r[blk]
        rb = rp[idx][:, None]
        cols = qgrid[qgrid * rb[0, 0] < T]
        edges = np.concatenate([cols[None, :] * rb,
                                np.broadcast_to(tgrid, (rb.shape[0], tgrid.size))], axis=1)
        edges = np.sort(np.clip(edges, q_lo * rb, np.minimum(q_hi * rb, T)), axis=1)

        def integrand(t, r3=rb[..., None]):
            q = t / r3
            return q * np.asarray(spectrum(q), dtype=float) * one_minus_j0(t)

        # sum over t-panels of q C (1 - J0) dt, and dq = dt / r
        out[idx] = panel_quadrature(edges, integrand, order) / rb[:, 0]
    return out


def _mass_above_split(rp, spectrum: Spectrum, qgrid, bp, T: float, order: int) -> np.ndarray:
    """``int q C dq`` over ``q r > T``: per-panel integrals summed from the top (all > 0)."""
    out = np.zeros(rp.size)
    far = bp[-1] * rp > T
    if not np.any(far):
        return out
    x, w = gauss_legendre(order)

    def panel_integrals(a, b):
        half, mid = 0.5 * (b - a), 0.5 * (b + a)
        qn = mid[:, None] + half[:, None] * x
        with np.errstate(all="ignore"):
            f = qn * np.asarray(spectrum(qn), dtype=float)
        return np.where(half > 0, (f @ w) * half, 0.0)

    above = np.concatenate([np.cumsum(panel_integrals(qgrid[:-1], qgrid[1:])[::-1])[::-1],
                            [0.0]])  # above[p] = int_{qgrid[p]}^{q_hi} q C dq
    q_t = np.maximum(T / rp[far], bp[0])
    p = np.clip(np.searchsorted(qgrid, q_t, side="right"), 1, qgrid.size - 1)
    out[far] = above[p] + panel_integrals(q_t, qgrid[p])
    return out


def _oscillation_above_split(rp, spectrum: Spectrum, bp, T: float, knots_per_decade: float,
                             order: int) -> np.ndarray:
    """``int q C(q) J0(q r) dq`` over ``q r > T`` (asymptotic closed form per piece)."""
    out = np.zeros(rp.size)
    far = bp[-1] * rp > T
    if np.any(far):
        pieces = _power_law_pieces(spectrum, bp, knots_per_decade, T / rp[far].max())
        out[far] = _oscillatory_part(rp[far], pieces, T, order)
    return out


def spectral_moment_kernel(
    spectrum: Spectrum,
    breakpoints,
    k: float,
    *,
    panels_per_decade: float = 8.0,
    order: int = 16,
) -> float:
    """Spectral moment ``(1/2pi) int dq q^(1+k) C(q)``.

    ``k = 0`` gives the height variance ``sigma_h^2`` (length^2), ``k = 2`` the mean-square
    gradient ``gbar^2`` (dimensionless), for ``C`` in length^4 and ``q`` in 1/length.

    Parameters
    ----------
    spectrum : callable
        Vectorised ``C(q)``, zero outside ``[breakpoints[0], breakpoints[-1]]``.
    breakpoints : sequence of float
        Support and jump/kink locations of ``C``.
    k : float
        Order of the moment (``k > -2`` if the support reaches ``q = 0``).
    panels_per_decade, order : float, int
        Logarithmic panel density and Gauss-Legendre order.

    Returns
    -------
    float

    Examples
    --------
    >>> import numpy as np
    >>> flat = lambda q: np.where(q < 2.0, 1.0, 0.0)
    >>> m2 = spectral_moment_kernel(flat, [0.0, 2.0], 2)   # (1/2pi) 2^4/4
    >>> print(f"{m2 * 2 * np.pi:.12f}")
    4.000000000000
    """
    bp = _check_breakpoints(breakpoints)
    edges = log_grid(bp, panels_per_decade, depth=12.0)[None, :]

    def integrand(q):
        return q ** (1.0 + k) * np.asarray(spectrum(q), dtype=float)

    return float(panel_quadrature(edges, integrand, order)[0] / (2.0 * np.pi))


def power_law_moment_kernel(q_cut, q, values, k: float, *,
                            nonpositive: str = "zero") -> np.ndarray:
    """``(1/2pi) int_0^{q_cut} dq q^(1+k) C(q)`` for sampled ``C``, exactly.

    ``C`` is the power law through consecutive samples where both are positive (as
    :class:`PowerLawInterpolant`), zero outside the samples, and on the other intervals
    zero (``nonpositive="zero"``, as :class:`PowerLawInterpolant`) or the straight line
    through the samples (``"linear"``, for estimates that may dip below zero).  ``k = 2``
    gives eq. 26, ``gbar^2(dr)`` with ``q_cut = 2 pi / dr``.

    Parameters
    ----------
    q_cut : array_like
        Upper limits (1/length), ``>= 0`` (``inf`` for the whole moment), any shape.
    q, values : array_like
        Strictly increasing positive wavenumbers and finite samples of ``C``.
    k : float
        Order of the moment, ``k > -2``.
    nonpositive : {'zero', 'linear'}
        Treatment of intervals with a sample ``<= 0``.

    Returns
    -------
    numpy.ndarray
        With the shape of ``q_cut``.

    Examples
    --------
    >>> import numpy as np
    >>> m = power_law_moment_kernel([0.5, 1.5, 3.0], [1.0, 2.0], [1.0, 1.0], 2)
    >>> bool(np.allclose(m, [0.0, (1.5**4 - 1) / (8 * np.pi), 15 / (8 * np.pi)]))
    True
    """
    qc_in = np.asarray(q_cut, dtype=float)
    qc = qc_in.ravel()
    qs = np.asarray(q, dtype=float)
    c = np.asarray(values, dtype=float)
    if nonpositive not in ("zero", "linear"):
        raise ValueError(f"nonpositive must be 'zero' or 'linear', got {nonpositive!r}")
    positive = (c[:-1] > 0) & (c[1:] > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = np.where(positive, np.log(c[1:] / c[:-1]) / np.log(qs[1:] / qs[:-1]), 0.0)
    e = alpha + 2.0 + k
    slope = (c[1:] - c[:-1]) / (qs[1:] - qs[:-1])
    linear = ~positive & (nonpositive == "linear")

    def piece(j, upper):
        """``int_{q_j}^{upper} q^(1+k) C`` on interval ``j``."""
        a = qs[j]
        log_ratio = np.log(upper / a)
        x = e[j] * log_ratio
        factor = np.where(np.abs(x) < 1e-8, log_ratio * (1.0 + 0.5 * x),
                          np.expm1(x) / np.where(e[j] != 0, e[j], 1.0))
        power = np.where(positive[j], c[j] * a ** (2.0 + k) * factor, 0.0)
        # straight line c_j + s (x - q_j) = (c_j - s q_j) + s x
        const = c[j] - slope[j] * a
        line = (const * (upper ** (2.0 + k) - a ** (2.0 + k)) / (2.0 + k)
                + slope[j] * (upper ** (3.0 + k) - a ** (3.0 + k)) / (3.0 + k))
        return np.where(linear[j], line, power)

    whole = piece(np.arange(qs.size - 1), qs[1:])
    cumulative = np.concatenate([[0.0], np.cumsum(whole)])
    j = np.clip(np.searchsorted(qs, qc, side="right") - 1, 0, qs.size - 2)
    inside = (qc > qs[0]) & (qc < qs[-1])
    partial = piece(j, np.clip(qc, qs[0], qs[-1]))
    total = np.where(qc >= qs[-1], cumulative[-1],
                     np.where(inside, cumulative[j] + partial, 0.0))
    return (total / (2.0 * np.pi)).reshape(qc_in.shape)


def binned_moment_kernel(q_cut, q, values, measure, k: float) -> np.ndarray:
    """``sum_b q_b^k C_b m_b`` over the bins of a periodogram below ``q_cut``.

    A periodogram averaged over the modes of each ``|q|`` bin (:func:`xrough.power_spectrum`) is a
    sum, not samples of a smooth function: ``m_b`` (its ``bin_measure``, the bin's share
    of ``d^2q / (2 pi)^2``) makes ``sum_b C_b m_b`` the variance of the heights exactly
    (Parseval), and ``sum_b q_b^2 C_b m_b`` the mean-square gradient of all its modes to
    the spread of ``q^2`` within a bin.  Integrated as a power law between bins instead,
    a spectrum that drops sharply inside a bin loses 1 to 2 % of ``gbar^2``.  A bin
    counts with the fraction of it (in ``ln q``, between the geometric means of
    neighbouring bin wavenumbers) below ``q_cut``.

    Parameters
    ----------
    q_cut : array_like
        Upper limits (1/length), ``>= 0`` (``inf`` for the whole moment), any shape.
    q, values, measure : array_like
        Strictly increasing positive bin wavenumbers, ``C`` of each bin and its measure.
    k : float
        Order of the moment.

    Returns
    -------
    numpy.ndarray
        With the shape of ``q_cut``.

    Examples
    --------
    >>> import numpy as np
    >>> m = binned_moment_kernel([np.inf, 2.0], [1.0, 2.0], [3.0, 1.0], [0.5, 0.25], 0)
    >>> print(np.round(m, 6))  # all; the first bin and half of the second (sqrt 2 to 2 sqrt 2)
    [1.75  1.625]
    """
    qc_in = np.asarray(q_cut, dtype=float)
    lq = np.log(np.asarray(q, dtype=float))
    terms = np.exp(k * lq) * np.asarray(values, dtype=float) * np.asarray(measure, dtype=float)
    mid = 0.5 * (lq[1:] + lq[:-1])
    lo = np.concatenate([[2 * lq[0] - mid[0] if mid.size else lq[0] - 0.05], mid])
    hi = np.concatenate([mid, [2 * lq[-1] - mid[-1] if mid.size else lq[-1] + 0.05]])
    with np.errstate(divide="ignore"):
        lc = np.log(qc_in.ravel())[:, None]
    share = np.clip((lc - lo) / (hi - lo), 0.0, 1.0)
    return (share @ terms).reshape(qc_in.shape)


def profile_spectrum_kernel(
    qx,
    spectrum: Spectrum,
    breakpoints,
    *,
    panels_per_decade: float = 5.0,
    order: int = 12,
) -> np.ndarray:
    """1D spectrum of a line scan through an isotropic surface.

    ``C1D(qx) = (1/pi) int_|qx|^inf dq q C(q) / sqrt(q^2 - qx^2)`` (length^3), the 1D
    convention ``C1D = L <|h~(qx)|^2>``, so that the profile's
    ``G(x) = (1/pi) int_0^inf dqx C1D(qx) [1 - cos(qx x)]`` equals the 2D ``G`` of eq. 9.

    With ``s = sqrt(q^2 - qx^2)`` the integral becomes
    ``(1/pi) int_0^inf ds C(sqrt(s^2 + qx^2))`` without the inverse square-root singularity;
    it is split at the images of the breakpoints and integrated on logarithmic panels.

    Parameters
    ----------
    qx : array_like
        Profile wavenumbers (1/length), any shape and sign.
    spectrum : callable
        Vectorised isotropic ``C(q)`` (length^4), zero outside the breakpoints' range.
    breakpoints : sequence of float
        Support and jump/kink locations of ``C``.
    panels_per_decade, order : float, int
        Logarithmic panel density and Gauss-Legendre order.

    Returns
    -------
    numpy.ndarray
        ``C1D`` with the shape of ``qx``.

    Examples
    --------
    For ``C = 1`` on ``q < 1``: ``C1D(qx) = sqrt(1 - qx^2) / pi``.

    >>> import numpy as np
    >>> flat = lambda q: np.where(q < 1.0, 1.0, 0.0)
    >>> c1 = profile_spectrum_kernel([0.0, 0.6, 2.0], flat, [0.0, 1.0])
    >>> print(np.round(c1 * np.pi, 12))
    [1.  0.8 0. ]
    """
    qx_in = np.asarray(qx, dtype=float)
    a = np.abs(qx_in.ravel())
    if not np.all(np.isfinite(a)):
        raise ValueError("qx must be finite")
    bp = _check_breakpoints(breakpoints)
    qgrid = log_grid(bp, panels_per_decade, depth=1.0)
    out = np.empty(a.size)
    for blk in blocks(a.size, (qgrid.size + 2) * order):
        ab = a[blk][:, None]
        s_grid = np.sqrt(np.maximum(qgrid[None, :] ** 2 - ab**2, 0.0))
        # split the first panel [0, ~qx] once more: C(sqrt(s^2+qx^2)) has branch points at
        # s = +-i qx
        extra = np.concatenate([0.5 * ab, ab], axis=1)
        s_max = s_grid[:, -1:]
        edges = np.sort(np.concatenate([s_grid, np.minimum(extra, s_max)], axis=1), axis=1)
        a3 = ab[..., None]

        def integrand(s, a3=a3):
            return np.asarray(spectrum(np.sqrt(s * s + a3 * a3)), dtype=float)

        out[blk] = panel_quadrature(edges, integrand, order) / np.pi
    return out.reshape(qx_in.shape)
