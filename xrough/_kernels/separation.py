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

from .contact import contact_area
from .deferred import integrate, interpolate, special

__all__ = ["separation_kernel", "gap_distribution_kernel", "j_function",
           "SEPARATION_OUTPUTS", "GAP_SHARES"]

#: What :func:`separation_kernel` returns per load, in this order.
SEPARATION_OUTPUTS = ("mean_gap", "energy", "dU_dp", "beyond")

#: The shares of the area at which a gap distribution is given (``gap_quantiles``).
GAP_SHARES = np.linspace(0.0, 1.0, 21)

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
    >>> from .deferred import integrate, interpolate, special
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
    """Quadrature nodes in ``ln dr``: ``(gbar, weight of dmu, dr)`` inside and beyond the lags.

    Six arrays: ``gbar``, the weight of ``dmu`` and ``dr`` at the nodes between the lags,
    then the same beyond the largest lag.
    """
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
    return (np.exp(lgs).ravel(), weight.ravel(), np.exp(xs).ravel(), np.exp(lgt).ravel(),
            wt.ravel(), np.exp(xt).ravel())


def _one_curve(dr, gbar, p, E, gamma) -> np.ndarray:
    g_in, w_in, _, g_out, w_out, _ = _nodes(dr, gbar)
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


def gap_distribution_kernel(gbar, *, dr, p0, E: float, gamma: float,
                            shares=GAP_SHARES) -> np.ndarray:
    """Quantiles of the distribution of the gap over the nominal area (Almqvist et al. 2011).

    Persson's picture, in real space: going from coarse to fine resolution ``D``, the
    area in contact ``P(D)`` (eq. 29) shrinks; the area that detaches at ``D`` has the
    gap of the roughness finer than ``D`` pressed at ``p0 / P(D)``: a normal
    distribution, reflected at zero, of mean ``u(D)`` (the mean gap of the finer
    roughness, ``gbar_D^2(r) = gbar^2(r) - gbar^2(D)`` for ``r < D``) and variance
    ``h^2(D) = int_0^D r^2 / (4 pi^2) (-d gbar^2 / dr) dr`` (the heights' variance from
    wavenumbers above ``2 pi / D`` by eq. 26). What stays in contact at the finest lag,
    ``P(dr_1)``, has gap 0:

        P(u) = P(dr_1) delta(u) + int dP(D) [N(u; u(D), h(D)) + N(-u; u(D), h(D))].

    Parameters
    ----------
    gbar, dr, p0, E, gamma
        As :func:`separation_kernel`.
    shares : numpy.ndarray (k,)
        Shares of the nominal area in [0, 1].

    Returns
    -------
    numpy.ndarray (..., m, k)
        Per load the gap (m) below which each share of the area lies: 0 for shares
        within the contact area, ``inf`` for share 1 (the normal tails are unbounded).

    Examples
    --------
    >>> import numpy as np
    >>> dr = np.geomspace(1e-9, 1e-6, 40)
    >>> gbar = 0.1 * (1 + (dr / 1e-7) ** 2) ** -0.7   # a roll-off at 100 nm
    >>> q = gap_distribution_kernel(gbar, dr=dr, p0=np.array([1e3]), E=1e6, gamma=0.42,
    ...                             shares=np.array([0.0, 0.5, 1.0]))
    >>> q.shape, bool(q[0, 0] == 0 and 0 < q[0, 1] < np.inf and q[0, 2] == np.inf)
    ((1, 3), True)
    """
    g = np.asarray(gbar, dtype=float)
    p = np.asarray(p0, dtype=float)
    shares = np.asarray(shares, dtype=float)
    batch = g.shape[:-1]
    flat = g.reshape(-1, g.shape[-1])
    out = np.full((flat.shape[0], p.size, shares.size), np.nan)
    for i, row in enumerate(flat):
        ok = np.isfinite(row) & (row > 0)
        if np.count_nonzero(ok) >= 2:
            out[i] = _one_distribution(np.asarray(dr, dtype=float)[ok], row[ok], p, E,
                                       gamma, shares)
    return out.reshape(batch + (p.size, shares.size))


#: Resolutions per decade at which the detaching area's gap is evaluated beyond the lags.
_TAIL_PER_DECADE = 8
#: Resolutions per decade at which the detaching area's gap is evaluated over the lags.
_D_PER_DECADE = 40
#: Points of the gap grid on which the distribution is inverted (log-spaced).
_GAP_GRID = 4000


def _one_distribution(dr, gbar, p, E, gamma, shares) -> np.ndarray:
    """:func:`gap_distribution_kernel` for one curve of finite positive ``gbar``."""
    gbar = np.minimum.accumulate(gbar)
    g_in, w_in, r_in, g_out, w_out, r_out = _nodes(dr, gbar)
    g_nodes = np.concatenate([g_in, g_out])
    w_nodes = np.concatenate([w_in, w_out])
    r_nodes = np.concatenate([r_in, r_out])
    # the resolutions D: log-spaced over the lags (gbar a power law between two), then
    # the roll-off's dr^-2 continuation
    x = np.log(dr)
    xD = np.linspace(x[0], x[-1], max(2, int(np.ceil((x[-1] - x[0]) / np.log(10.0)
                                                      * _D_PER_DECADE)) + 1))
    steps = np.arange(1, int(_TAIL_DECADES * _TAIL_PER_DECADE) + 1) / _TAIL_PER_DECADE
    edges = np.concatenate([np.exp(xD), dr[-1] * 10.0**steps])
    g_edges = np.concatenate([np.exp(np.interp(xD, x, np.log(gbar))),
                              gbar[-1] * 10.0 ** (-2.0 * steps)])
    # the area detaching between two edges has the gap of the resolution midway (in ln D)
    D = np.sqrt(edges[1:] * edges[:-1])
    gD = np.sqrt(g_edges[1:] * g_edges[:-1])
    finer = r_nodes[None, :] < D[:, None]  # (K, N)
    # variance of the heights finer than D
    h2 = (finer * (w_nodes * r_nodes / (4.0 * np.pi**2))[None, :]).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        g_fine = np.sqrt(np.where(finer, g_nodes[None, :] ** 2 - gD[:, None] ** 2, 0.0))
    use = finer & (g_fine > 0)
    out = np.empty((p.size, shares.size))
    for m, load in enumerate(p):
        area = contact_area(load / (E * gD))  # eq. 29 at each D
        s = np.where(use, load / area[:, None] / (E * np.where(use, g_fine, 1.0)), 1.0)
        terms = np.where(use, w_nodes[None, :] * j_function(s, gamma)
                         / np.where(use, g_fine, 1.0), 0.0)
        mean = _C * terms.sum(axis=1)  # mean gap of the roughness finer than D
        # the area between two edges; what is out of contact at the coarsest edge too
        at_edges = contact_area(load / (E * g_edges))
        weight = np.diff(at_edges)
        weight[-1] += 1.0 - at_edges[-1]
        out[m] = _quantiles(at_edges[0], weight, mean, np.sqrt(h2), shares)
    return out


def _quantiles(stuck, weight, mean, sd, shares) -> np.ndarray:
    """Invert ``F(u) = stuck + sum w [Phi((u - m)/s) + Phi((u + m)/s) - 1]`` at ``shares``."""
    keep = (weight > 0) & (sd > 0)
    w, m, s = weight[keep], mean[keep], sd[keep]
    top = float(np.max(m + 10.0 * s)) if w.size else 0.0
    out = np.where(shares <= stuck, 0.0, np.inf)
    if top <= 0:
        return out
    u = np.concatenate([[0.0], np.geomspace(top * 1e-8, top, _GAP_GRID)])
    z = (u[:, None] - m[None, :]) / s[None, :]
    zr = (u[:, None] + m[None, :]) / s[None, :]
    F = stuck + (w[None, :] * (special.ndtr(z) + special.ndtr(zr) - 1.0)).sum(axis=1)
    F = np.maximum.accumulate(F)
    inside = (shares > stuck) & (shares < 1.0)
    out[inside] = np.interp(shares[inside], F, u)
    return out
