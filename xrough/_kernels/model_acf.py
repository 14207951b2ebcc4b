"""Eq. 9 of the two model spectra in closed form: G(dr) of the sharp and the smooth roll-off.

The model spectra (:class:`~xrough._kernels.spectral_models.SpectrumModel`) are

- sharp (eq. 35):  ``C = C_r`` for ``q_0 <= q < q_r``, ``C_r (q/q_r)^(-2-2H)`` up to ``q_s``;
- smooth:          ``C = C_r (1 + (q/q_r)^2)^(-1-H)`` for ``q_0 <= q < q_s``,

and eq. 9 is ``G(dr) = (1/2pi) int q C(q) [1 - J0(q dr)] dq``.  With ``t = q dr`` both reduce
to a few one-dimensional functions, evaluated here without a quadrature over ``q``:

- ``g(a) = int_0^a t (1 - J0) dt = a^2/2 - a J1(a)`` (the flat part of the sharp shape);
- ``T_h(a) = int_a^inf t^(-1-2h) (1 - J0) dt`` (the power-law part; ``h > 0`` not an
  integer).  Below ``a = 8``: ``T_h = I_h - D_h(a)`` with the power series ``D_h`` of
  ``1 - J0`` integrated term by term and ``I_h = 2^(-1-2h) Gamma(1-h) / (h Gamma(1+h))``
  (the Mellin transform of ``1 - J0``, continued analytically for ``h > 1``); between 8 and
  48: 16-point Gauss-Legendre on panels two wide (their ``J0`` values are tabulated once)
  plus ``T_h(48)``; beyond 48: ``a^(-2h)/(2h) - int_a^inf t^(-1-2h) J0 dt``, the last by
  repeated integration by parts (``d(t J1) = t J0 dt``, ``dJ0 = -J1 dt``), an asymptotic
  series whose terms fall by ``((2h + 2 + 2n)/a)^2``;
- the smooth shape integrated to infinity is a Matern correlation:
  ``int_0^inf q (1 + q^2/q_r^2)^(-1-H) [1 - J0(q dr)] dq = q_r^2 M(q_r dr)`` with
  ``M(z) = 1/(2H) - (z/2)^H K_H(z) / Gamma(1+H)`` (series of ``K_H`` below ``z = 1``, where
  the difference cancels); the part beyond ``q_s`` is the binomial series of
  ``(1 + q_r^2/q^2)^(-1-H)``, ``sum_j binom(-1-H, j) z^(2H+2j) T_(H+j)(q_s dr)``, which falls
  as ``(q_r/q_s)^(2j)``.  Where ``q_s dr < 2`` (lags below the cutoff, where the terms of
  that split would cancel) the integral over ``q`` is done directly (Gauss-Legendre in
  ``ln q``, no oscillation there).

The smooth shape needs ``q_s >= 4 q_r`` and ``q_0 = 0`` for this route
(:func:`smooth_closed_form_applies`); :mod:`~xrough._kernels.fitting` falls back to the
general quadrature of :func:`~xrough._kernels.hankel.acf_from_spectrum_kernel` otherwise.
Accuracy against that quadrature and 30-digit mpmath: tests/test_model_acf.py.
"""

from __future__ import annotations

from functools import lru_cache
from math import lgamma

import numpy as np

from .bessel import gauss_legendre, one_minus_j0
from .deferred import special

__all__ = ["sharp_acf", "smooth_acf", "smooth_closed_form_applies", "power_tail",
           "cutoff_slopes"]

#: Below: the power series of 1 - J0 (largest term 113 times the sum: two digits lost).
_A_SERIES = 8.0
#: Beyond: the asymptotic series of the J0 tail (terms fall by ((2h+2+2n)/48)^2).
_A_FAR = 48.0
_PANEL, _ORDER = 2.0, 16
_N_SERIES = 40  # terms of the power series at a = 8: (16^k/k!^2) < 1e-17 beyond k = 34
_N_FAR = 24  # terms of the asymptotic series at a = 48
_N_MATERN = 20  # terms of the series of K_H below z = 1 (s = z^2/4 < 1/4)
#: The smooth shape: binomial series beyond q_s converges as (q_r/q_s)^(2j).
_MIN_SMOOTH_RATIO = 4.0
#: The smooth shape below q_s dr = _A_DIRECT: Gauss-Legendre in ln q.
_A_DIRECT = 2.0
_DIRECT_PANELS_PER_DECADE, _DIRECT_DEPTH = 4, 8.0


def _tail_total(h):
    """``I_h = int_0^inf t^(-1-2h) (1 - J0) dt`` (analytic continuation for ``h > 1``)."""
    return 2.0 ** (-1 - 2 * h) * special.gamma(1 - h) / (h * special.gamma(1 + h))


@lru_cache(maxsize=1)
def _terms_table() -> np.ndarray:
    """Terms of the series of ``1 - J0`` up to ``a = 0, 1, ..., 8``.

    The first ``k`` where ``(a^2/4)^k / k!^2`` falls below 1e-17 times the largest term,
    plus one.
    """
    k = np.arange(1, _N_SERIES + 1)
    ln_fact2 = 2 * np.cumsum(np.log(k))
    out = []
    for a in np.arange(0, int(_A_SERIES) + 1):
        size = k * np.log(max(0.25 * a * a, 1e-300)) - ln_fact2
        small = size < np.log(1e-17) + max(size.max(), 0.0)
        out.append(min(int(np.argmax(small)) + 2, _N_SERIES))
    return np.array(out)


def _series_terms(a_max: float) -> int:
    """Terms of the series of ``1 - J0`` for arguments up to ``a_max <= 8``."""
    return int(_terms_table()[min(int(np.ceil(a_max)), int(_A_SERIES))])


def _powers(a, n_terms: int):
    """``(-a^2/4)^k / k!^2`` for ``k = 1..n_terms`` along a last axis."""
    k = np.arange(1, n_terms + 1)
    return np.cumprod(np.multiply.outer(-0.25 * a * a, 1.0 / (k * k)), axis=-1)


def _from_zero(h, a):
    """``D_h(a)``: the power series of ``int_0^a t^(-1-2h) (1 - J0) dt`` (``a <= 8``)."""
    a = np.asarray(a, dtype=float)
    if a.size == 0:
        return np.zeros(np.broadcast(h, a).shape)
    h = np.asarray(h, dtype=float)
    n = _series_terms(float(np.max(a)))
    k = np.arange(1, n + 1)
    total = -np.sum(_powers(a, n) / (2 * k - 2 * h[..., None]), axis=-1)
    return total * a ** (-2 * h)


@lru_cache(maxsize=1)
def _middle_table():
    """Gauss-Legendre nodes and weights of the panels from 8 to 48, and ``1 - J0`` there."""
    x, w = gauss_legendre(_ORDER)
    edges = np.arange(_A_SERIES, _A_FAR + _PANEL / 2, _PANEL)
    mid, half = 0.5 * (edges[1:] + edges[:-1]), 0.5 * _PANEL
    t = mid[:, None] + half * x  # (panels, order)
    return edges, t, w * half, one_minus_j0(t), x, w


def _j0_tail(mu, a):
    """``int_a^inf t^(-mu) J0(t) dt`` for ``a >= 48`` (integration by parts, asymptotic)."""
    mu, a = np.broadcast_arrays(np.asarray(mu, dtype=float), np.asarray(a, dtype=float))
    m = mu[..., None] + 2 * np.arange(_N_FAR)  # the exponent of term n
    # coefficient of term n: (-1)^n prod_{i<n} (mu + 2i + 1)^2
    coef = np.cumprod(np.concatenate([np.ones(mu.shape + (1,)), -(m[..., :-1] + 1) ** 2],
                                     axis=-1), axis=-1)
    a3 = a[..., None]
    terms = coef * np.exp(-m * np.log(a3)) * ((m + 1) * special.j0(a3) / a3 - special.j1(a3))
    return terms.sum(axis=-1)


def power_tail(h, a):
    """``T_h(a) = int_a^inf t^(-1-2h) [1 - J0(t)] dt`` for ``a > 0``, ``h > 0`` not an integer.

    Broadcasts ``h`` against ``a``.
    """
    h, a = np.broadcast_arrays(np.asarray(h, dtype=float), np.asarray(a, dtype=float))
    out, low = _from_zero_or_tail(h, a)
    out[low] = _tail_total(h[low]) - out[low]
    return out


def _from_zero_or_tail(h, a):
    """``D_h(a)`` where ``a <= 8`` (the mask returned), ``T_h(a)`` elsewhere; ``h`` like ``a``."""
    out = np.empty(a.shape)
    low, far = a <= _A_SERIES, a > _A_FAR
    mid = ~(low | far)
    if np.any(low):
        out[low] = _from_zero(h[low], a[low])
    if np.any(far):
        hf, af = h[far], a[far]
        out[far] = af ** (-2 * hf) / (2 * hf) - _j0_tail(1 + 2 * hf, af)
    if np.any(mid):
        out[mid] = _middle(h[mid], a[mid])
    return out, low


def _middle(h, a):
    """``T_h(a)`` for ``8 < a <= 48``: panels to 48, then the asymptotic tail there."""
    edges, t, wt, omj, x, w = _middle_table()
    p = np.minimum(((a - _A_SERIES) // _PANEL).astype(int), edges.size - 2)
    # whole panels above a's panel: int over panel k of t^(-1-2h) (1 - J0), summed from p+1
    if h.min() == h.max():  # one exponent (the sharp shape)
        hu, inverse = h[:1], np.zeros(h.shape, dtype=int)
    else:
        hu, inverse = np.unique(h, return_inverse=True)
    panel = (t[None] ** (-1 - 2 * hu[:, None, None]) * omj[None]) @ wt  # (n_h, panels)
    # and beyond 48 the asymptotic series
    far = _A_FAR ** (-2 * hu) / (2 * hu) - _j0_tail(1 + 2 * hu, np.full(hu.shape, _A_FAR))
    above = np.concatenate([np.cumsum(panel[:, ::-1], axis=1)[:, ::-1],
                            np.zeros((hu.size, 1))], axis=1) + far[:, None]
    whole = above[inverse, p + 1]
    # the part of a's panel above a
    hi = edges[p + 1]
    half, mid = 0.5 * (hi - a), 0.5 * (hi + a)
    tn = mid[:, None] + half[:, None] * x
    part = (tn ** (-1 - 2 * h[:, None]) * one_minus_j0(tn)) @ w * half
    return whole + part


def _flat(a):
    """``g(a) = int_0^a t (1 - J0) dt`` (series below a = 2, where a^2/2 and a J1 cancel)."""
    a = np.asarray(a, dtype=float)
    out = np.empty(a.shape)
    small = a < 2.0
    s = a[small]
    if s.size:
        n = _series_terms(float(s.max()))
        out[small] = -(_powers(s, n) @ (1.0 / (2 * np.arange(1, n + 1) + 2))) * s * s
    b = a[~small]
    out[~small] = 0.5 * b * b - b * special.j1(b)
    return out


def sharp_acf(dr, hurst: float, q_r: float, q_s: float, q_0: float = 0.0, C_r: float = 1.0):
    """G (eq. 9) of the sharp model spectrum (eq. 35) at the lags ``dr > 0``.

    ``G = C_r / (2 pi) [dr^-2 (g(q_r dr) - g(q_0 dr)) + q_r^(2+2H) dr^(2H) (F(q_s dr) -
    F(q_r dr))]`` with ``F(a) = int_0^a t^(-1-2H) (1 - J0) dt`` (module docstring).
    """
    x = np.asarray(dr, dtype=float)
    H = float(hurst)
    ar, as_ = q_r * x, q_s * x
    flat = _flat(ar) - (_flat(q_0 * x) if q_0 > 0 else 0.0)
    # F(a_s) - F(a_r) without cancellation: F = D from zero below 8, I - T from infinity
    # above, and T(a_r) - T(a_s) where both are above
    n = x.size
    a = np.concatenate([ar.ravel(), as_.ravel()])
    v, low = _from_zero_or_tail(np.full(a.shape, H), a)
    F = np.where(low, v, _tail_total(H) - v)
    diff = np.where(low[n:] | low[:n], F[n:] - F[:n], v[:n] - v[n:]).reshape(x.shape)
    return C_r / (2 * np.pi) * (flat / (x * x) + q_r ** (2 + 2 * H) * x ** (2 * H) * diff)


def cutoff_slopes(dr, hurst: float, q_r: float, q_s: float, q_0: float = 0.0,
                  C_r: float = 1.0, rolloff: str = "sharp"):
    """``(dG/dq_r, dG/dq_s)`` of eq. 9 at the lags ``dr``, the self-affine part held fixed.

    The spectrum ``C_r (q/q_r)^(-2-2H)`` above ``q_r`` stays put (``c = C_r q_r^(2+2H)``
    fixed, as in a fit of the shape to ``G``) while a cutoff moves, and the upper cutoff
    is sharp at ``q_s > q_r``.  Moving the end of an integral gives its integrand there:
    ``dG/dq_s = q_s C(q_s) [1 - J0(q_s dr)] / (2 pi)`` for either roll-off.  For the sharp
    roll-off (eq. 35) the two ends at ``q_r`` cancel (the spectrum is continuous there) and
    only the plateau's height ``C_r = c q_r^(-2-2H)`` moves:
    ``dG/dq_r = -(2 + 2H) / q_r G_flat`` with ``G_flat = C_r [g(q_r dr) - g(q_0 dr)] /
    (2 pi dr^2)`` (module docstring).  The smooth roll-off's ``dG/dq_r`` has no such form
    (it is ``None``).  Units: those of G times a length (``q`` in the inverse unit of
    ``dr``, ``C_r`` in G's unit times a length squared).
    """
    x = np.asarray(dr, dtype=float)
    H = float(hurst)
    ratio = q_s / q_r
    C_s = C_r * (ratio ** (-2 - 2 * H) if rolloff == "sharp"
                 else (1 + ratio * ratio) ** (-1 - H))
    d_s = q_s * C_s * one_minus_j0(q_s * x) / (2 * np.pi)
    if rolloff != "sharp":
        return None, d_s
    flat = _flat(q_r * x) - (_flat(q_0 * x) if q_0 > 0 else 0.0)
    return -(2 + 2 * H) / q_r * C_r * flat / (2 * np.pi * x * x), d_s


def smooth_closed_form_applies(q_r: float, q_s: float, q_0: float) -> bool:
    """Whether :func:`smooth_acf` covers these cutoffs (``q_s >= 4 q_r``, no ``q_0``)."""
    return q_0 == 0.0 and q_s >= _MIN_SMOOTH_RATIO * q_r


def _matern(H: float, z):
    """``M(z) = 1/(2H) - (z/2)^H K_H(z) / Gamma(1+H)`` (series of ``K_H`` below z = 1)."""
    out = np.empty(z.shape)
    small = z < 1.0
    s = 0.25 * z[small] ** 2  # (z/2)^2
    if s.size:
        # (z/2)^H K_H / Gamma(1+H) = pi / (2 sin(pi H) Gamma(1+H)) [sum_k s^k / (k!
        # Gamma(k-H+1)) - s^H sum_k s^k / (k! Gamma(k+H+1))]; the k = 0 term of the first
        # sum is 1/(2H) after the prefactor: M is the rest
        pre = np.pi / (2 * np.sin(np.pi * H) * special.gamma(1 + H))
        k = np.arange(_N_MATERN)
        ln_fact = special.gammaln(k + 1)
        ln_s = np.log(s)[:, None]
        first = np.exp(k[1:] * ln_s - ln_fact[1:]) @ special.rgamma(k[1:] - H + 1)
        second = np.exp((k + H) * ln_s - ln_fact - special.gammaln(k + H + 1)).sum(axis=1)
        out[small] = -pre * (first - second)
    b = z[~small]
    out[~small] = 0.5 / H - np.exp(H * np.log(0.5 * b) - lgamma(1 + H)) * special.kv(H, b)
    return out


def _smooth_direct(x, H: float, q_r: float, q_s: float):
    """``int_0^q_s q (1 + q^2/q_r^2)^(-1-H) (1 - J0(q x)) dq`` for ``q_s x <= 2``."""
    nodes, weights = gauss_legendre(_ORDER)
    lo = np.log(q_r) - _DIRECT_DEPTH * np.log(10)  # below: (q/q_r)^4 of the integral
    hi = np.log(q_s)
    n = max(int(np.ceil((hi - lo) / np.log(10) * _DIRECT_PANELS_PER_DECADE)), 1)
    e = np.linspace(lo, hi, n + 1)
    half, mid = 0.5 * np.diff(e), 0.5 * (e[1:] + e[:-1])
    lnq = (mid[:, None] + half[:, None] * nodes).ravel()
    wq = (half[:, None] * weights).ravel()
    q = np.exp(lnq)
    f = q * q * (1 + (q / q_r) ** 2) ** (-1 - H) * wq  # dq = q d(ln q)
    return one_minus_j0(np.multiply.outer(x, q)) @ f


def smooth_acf(dr, hurst: float, q_r: float, q_s: float, C_r: float = 1.0):
    """G (eq. 9) of the smooth model spectrum at the lags ``dr > 0`` (no ``q_0``, ``q_s >= 4 q_r``).

    ``G = C_r q_r^2 / (2 pi) [M(z) - sum_j binom(-1-H, j) z^(2H+2j) T_(H+j)(q_s dr)]``,
    ``z = q_r dr`` (module docstring); directly in ``ln q`` where ``q_s dr < 2``.
    """
    x = np.asarray(dr, dtype=float)
    H = float(hurst)
    if not smooth_closed_form_applies(q_r, q_s, 0.0):
        raise ValueError(f"smooth_acf needs q_s >= {_MIN_SMOOTH_RATIO} q_r")
    out = np.empty(x.shape)
    direct = q_s * x < _A_DIRECT
    if np.any(direct):
        out[direct] = _smooth_direct(x[direct], H, q_r, q_s)
    far = ~direct
    if np.any(far):
        xf = x[far]
        z = q_r * xf
        rho = (q_r / q_s) ** 2
        n_terms = int(np.ceil(17.0 / -np.log10(rho))) + 1
        j = np.arange(n_terms)[:, None]
        binom = special.binom(-1.0 - H, j)
        h = H + j
        terms = binom * np.exp((2 * h) * np.log(z)) * power_tail(h, q_s * xf)
        out[far] = q_r**2 * (_matern(H, z) - terms.sum(axis=0))
    return C_r / (2 * np.pi) * out
