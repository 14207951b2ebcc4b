"""Persson's theory of the interfacial separation, in real space: pure numpy/scipy.

Persson (2007) and Yang and Persson (2008) give the elastic energy stored at load ``p``
and the mean separation ``u(p)`` as sums over wavenumbers of the spectrum. With
``gbar^2(dr) = (1/2 pi) int_0^{2 pi/dr} dq q^3 C(q)`` (eq. 26) the weight
``q^2 C(q) dq`` of a band of wavenumbers is ``dmu / (4 pi^2)`` (Persson's convention has
another ``(2 pi)^2``), with the measure

    dmu = dr (-d gbar^2 / d dr) d(dr),

and the contact area at resolution ``dr`` is eq. 29's ``P = erf(sqrt(2) p*)``,
``p* = p / (E* gbar(dr))``. Then, per area,

    U(p)     = E* / (8 pi) int dmu P S,          S = gamma + (1 - gamma) P^2,
    dU/dp    = c int dmu exp(-2 p*^2) [gamma + 3 (1 - gamma) P^2] / gbar,
    u(p)     = int_p^inf dp'/p' dU/dp' = c int dmu J(p*) / gbar,
    K(p)     = -dp/du = p / (dU/dp),

with ``c = sqrt(2) / (4 pi^(3/2))`` and the universal
``J(s) = int_s^inf dt/t [gamma + 3 (1 - gamma) erf^2(sqrt(2) t)] exp(-2 t^2)``.
In full contact ``U = E*/(8 pi) int dmu = E*/4 int G/dr^2 d(dr)`` (eq. 16).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy import integrate, interpolate, special

from .contact import contact_area

__all__ = ["separation_kernel", "j_function", "SEPARATION_OUTPUTS"]

#: What :func:`separation_kernel` returns per load, in this order.
SEPARATION_OUTPUTS = ("mean_gap", "energy", "dU_dp", "beyond")

_C = np.sqrt(2.0) / (4.0 * np.pi**1.5)
#: Gauss-Legendre nodes per interval between lags (in ln dr; gbar a power law there).
_ORDER = 8
#: Decades beyond the largest lag over which gbar is continued as dr^-2 (the roll-off).
_TAIL_DECADES = 4.0


@functools.lru_cache(maxsize=1)
def _k_table() -> tuple[interpolate.CubicSpline, float]:
    """Tabulate ``K(s) = int_s^inf erf^2(sqrt(2) t) exp(-2 t^2) dt / t``.

    A cubic spline in ``ln s`` over 1e-7 to 7 (to 1e-9 of ``J`` up to ``s = 1``), and
    ``K`` at its lower end.
    """
    s = np.geomspace(1e-7, 7.0, 4001)
    x = np.log(s)
    f = special.erf(np.sqrt(2.0) * s) ** 2 * np.exp(-2.0 * s * s)  # integrand in ln t
    tail = integrate.cumulative_simpson(f[::-1], x=-x[::-1], initial=0.0)[::-1]
    return interpolate.CubicSpline(x, tail), float(tail[0])


def j_function(s, gamma: float) -> np.ndarray:
    """``J(s) = gamma E1(2 s^2) / 2 + 3 (1 - gamma) K(s)`` for ``s > 0`` (see module).

    Examples
    --------
    >>> from scipy import integrate, interpolate, special
    >>> import numpy as np
    >>> f = lambda t: (0.4 + 1.8 * special.erf(np.sqrt(2) * t) ** 2) * np.exp(-2 * t * t) / t
    >>> ref = integrate.quad(f, 0.3, np.inf)[0]
    >>> bool(abs(j_function(0.3, 0.4) / ref - 1) < 1e-7)
    True
    """
    s = np.asarray(s, dtype=float)
    spline, k0 = _k_table()
    k = np.where(s < 1e-7, k0, np.where(s > 7.0, 0.0,
                                         spline(np.log(np.clip(s, 1e-7, 7.0)))))
    return 0.5 * gamma * special.exp1(2.0 * s * s) + 3.0 * (1.0 - gamma) * k


def separation_kernel(gbar, *, dr, p0, E: float, gamma: float) -> np.ndarray:
    """Mean gap, energy, ``dU/dp`` and the share of the gap from beyond the lags.

    Parameters
    ----------
    gbar : numpy.ndarray (..., n)
        The rms gradient on the lags (eq. 26), non-increasing along the last axis; NaN
        lags are left out (a curve with fewer than two finite values gives NaN).
    dr : numpy.ndarray
        Increasing positive lags (m).
    p0 : numpy.ndarray (m,)
        Mean pressures (Pa), > 0.
    E : float
        Contact modulus (Pa).
    gamma : float
        Persson's ``gamma`` of ``S = gamma + (1 - gamma) P^2``.

    Returns
    -------
    numpy.ndarray (..., m, 4)
        Per load :data:`SEPARATION_OUTPUTS`: the mean gap (m), the elastic energy per
        area (J m-2), ``dU/dp`` (m) and the share of the mean gap from beyond the largest
        lag (gbar continued there as ``dr^-2``, the roll-off of eq. 37).
    """
    g = np.asarray(gbar, dtype=float)
    p = np.asarray(p0, dtype=float)
    batch = g.shape[:-1]
    flat = g.reshape(-1, g.shape[-1])
    out = np.full((flat.shape[0], p.size, 4), np.nan)
    for i, row in enumerate(flat):
        ok = np.isfinite(row) & (row > 0)
        if np.count_nonzero(ok) >= 2:
            out[i] = _one_curve(np.asarray(dr, dtype=float)[ok], row[ok], p, E, gamma)
    return out.reshape(batch + (p.size, 4))


def _nodes(dr: np.ndarray, gbar: np.ndarray) -> tuple[np.ndarray, ...]:
    """Quadrature nodes in ``ln dr``: ``(gbar, weight of dmu)`` inside and beyond the lags."""
    t, w = np.polynomial.legendre.leggauss(_ORDER)
    x = np.log(dr)
    lg = np.log(np.minimum.accumulate(gbar))  # non-increasing
    beta = np.diff(lg) / np.diff(x)  # gbar ~ dr^beta per interval
    h = 0.5 * np.diff(x)
    xs = (0.5 * (x[1:] + x[:-1]))[:, None] + h[:, None] * t[None, :]
    lgs = lg[:-1, None] + beta[:, None] * (xs - x[:-1, None])
    # dmu = dr (-d gbar^2/d dr) d(dr) = -2 beta gbar^2 dr d(ln dr)
    weight = -2.0 * beta[:, None] * np.exp(2.0 * lgs + xs) * (h[:, None] * w[None, :])
    # beyond: gbar = gbar_end (dr / dr_end)^-2 over _TAIL_DECADES, in panels of a decade
    panels = int(_TAIL_DECADES)
    ht = 0.5 * np.log(10.0)
    xt = (x[-1] + ht * (2 * np.arange(panels) + 1))[:, None] + ht * t[None, :]
    lgt = lg[-1] - 2.0 * (xt - x[-1])
    wt = 4.0 * np.exp(2.0 * lgt + xt) * (ht * w[None, :])
    return np.exp(lgs).ravel(), weight.ravel(), np.exp(lgt).ravel(), wt.ravel()


def _one_curve(dr, gbar, p, E, gamma) -> np.ndarray:
    g_in, w_in, g_out, w_out = _nodes(dr, gbar)
    g = np.concatenate([g_in, g_out])
    w = np.concatenate([w_in, w_out])
    s = p[:, None] / (E * g[None, :])  # p* at every node, per load
    area = contact_area(s)  # eq. 29, Persson's kappa: erf(sqrt(2) p*)
    gap_terms = w * j_function(s, gamma) / g
    gap = _C * gap_terms.sum(axis=1)
    beyond = _C * gap_terms[:, g_in.size:].sum(axis=1)
    energy = E / (8.0 * np.pi) * (w * area * (gamma + (1.0 - gamma) * area**2)).sum(axis=1)
    dudp = _C * (w * np.exp(-2.0 * s * s) * (gamma + 3.0 * (1.0 - gamma) * area**2)
                 / g).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(gap > 0, beyond / gap, np.nan)
    return np.stack([gap, energy, dudp, share], axis=-1)
