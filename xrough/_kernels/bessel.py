"""Quadrature building blocks of the Hankel transforms (pure numpy/scipy, no xarray).

Shared by eq. 9 (:mod:`xrough._kernels.hankel`, ``G`` from ``C``) and eq. 10/11
(:mod:`xrough._kernels.spectrum_of_acf`, ``C`` from ``G``):

* composite Gauss-Legendre on panels (:func:`panel_quadrature`), on grids that are
  logarithmic between breakpoints (:func:`log_grid`), processed in blocks of rows;
* ``1 - J0(t)`` and ``(1 - J0(t)) / t^2`` without cancellation at small ``t`` (power series
  for ``t < 1``);
* ``int q f(q) J0(q r) dq`` beyond ``q r = T`` for ``f`` a sum of power laws per piece
  (:func:`oscillatory_terms`): each ``int t^beta J0(t) dt`` in closed form from the Hankel
  asymptotic expansion of ``J0`` times the asymptotic antiderivative of ``t^gamma e^{it}``,
  regrouped into one series ``sum_m d_m(beta) t^-m`` and truncated where its terms fall below
  1e-17 (O(1) per piece, whatever the number of oscillations); steep pieces start the
  expansion later and are integrated by Gauss-Legendre in between.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .deferred import special

__all__ = ["gauss_legendre", "one_minus_j0", "one_minus_j0_over_t2", "log_grid", "blocks",
           "panel_quadrature", "oscillatory_terms"]

#: Number of terms of the combined asymptotic series and its relative truncation target.
_N_ASYMPTOTIC = 30
_ASYMPTOTIC_TOL = 1e-17
_TERM_TIERS = np.array([4, 6, 9, 13, 19, 25, _N_ASYMPTOTIC])
#: Work arrays are processed in blocks of about this many quadrature nodes.
_BLOCK_NODES = 2**19


# --------------------------------------------------------------------------------------
# Gauss-Legendre panels and 1 - J0 without cancellation
# --------------------------------------------------------------------------------------
@lru_cache(maxsize=16)
def gauss_legendre(order: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes on [-1, 1] and weights (cached, read-only)."""
    x, w = np.polynomial.legendre.leggauss(order)
    x.setflags(write=False)
    w.setflags(write=False)
    return x, w


def _j0_series(t: np.ndarray) -> np.ndarray:
    """``(1 - J0(t)) / (t^2/4)`` from the power series of ``J0`` (accurate for ``|t| < 1``).

    ``1 - J0 = -sum_{k>=1} z^k/(k!)^2 = (t^2/4) (1 + z/4 (1 + z/9 (1 + ...)))``, ``z = -t^2/4``.
    """
    z = -0.25 * t * t
    acc = np.ones_like(t)
    for k in range(12, 1, -1):
        acc = 1.0 + acc * z / (k * k)
    return acc


def one_minus_j0(t: np.ndarray) -> np.ndarray:
    """``1 - J0(t)`` without cancellation at small ``t`` (power series for ``t < 1``)."""
    t = np.asarray(t, dtype=float)
    out = 1.0 - special.j0(t)
    small = np.abs(t) < 1.0
    if np.any(small):
        ts = t[small]
        out[small] = 0.25 * ts * ts * _j0_series(ts)
    return out


def one_minus_j0_over_t2(t: np.ndarray) -> np.ndarray:
    """``(1 - J0(t)) / t^2`` (``1/4`` at ``t = 0``) without cancellation at small ``t``."""
    t = np.asarray(t, dtype=float)
    small = t < 1.0
    safe = np.where(small, 1.0, t)
    acc = _j0_series(np.where(small, t, 0.0))
    return np.where(small, 0.25 * acc, (1.0 - special.j0(safe)) / safe**2)


def log_grid(bp: np.ndarray, per_decade: float, *, depth: float) -> np.ndarray:
    """Breakpoints plus a logarithmic grid inside every segment.

    A segment starting at 0 gets a logarithmic grid over ``depth`` decades below its upper
    end (and 0 itself).
    """
    lo = np.where(bp[:-1] > 0, bp[:-1], bp[1:] * 10.0**-depth)
    n = np.ceil(per_decade * np.log10(bp[1:] / lo)).astype(int)
    fine = n > 1
    a, b, n = lo[fine], bp[1:][fine], n[fine]
    # k = 0..n in each fine segment: a (b/a)^(k/n), both ends exact
    seg = np.repeat(np.arange(n.size), n + 1)
    k = np.arange(seg.size) - np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)
    pts = np.where(k == n[seg], b[seg], a[seg] * (b[seg] / a[seg]) ** (k / n[seg]))
    return np.unique(np.concatenate([bp, pts, lo]))


def blocks(n_rows: int, row_nodes: int):
    """Slices of ``range(n_rows)``, about ``_BLOCK_NODES`` nodes each (``row_nodes`` a row)."""
    step = max(1, _BLOCK_NODES // max(row_nodes, 1))
    for start in range(0, n_rows, step):
        yield slice(start, min(start + step, n_rows))


def panel_quadrature(edges: np.ndarray, integrand, order: int) -> np.ndarray:
    """Sum of Gauss-Legendre panels between sorted ``edges`` along the last axis.

    ``integrand(t, row)`` gets node positions ``t`` of shape ``(rows, panels, order)`` and
    must return values of the same shape.  Zero-width panels contribute nothing (even if the
    integrand is not finite there).
    """
    x, w = gauss_legendre(order)
    lo = edges[:, :-1]
    hi = edges[:, 1:]
    half = 0.5 * (hi - lo)
    mid = 0.5 * (hi + lo)
    t = mid[..., None] + half[..., None] * x
    with np.errstate(all="ignore"):
        f = integrand(t)
    f = np.where((half > 0)[..., None], f, 0.0)
    return np.einsum("rpn,n,rp->r", f, w, half)


# --------------------------------------------------------------------------------------
# the asymptotic oscillatory integral
# --------------------------------------------------------------------------------------
@lru_cache(maxsize=1)
def _hankel_coefficients() -> np.ndarray:
    """``a_k(0)`` of ``H0^(1)(t) ~ sqrt(2/(pi t)) e^{i(t-pi/4)} sum_k i^k a_k t^-k``."""
    a = np.empty(_N_ASYMPTOTIC + 1)
    a[0] = 1.0
    for k in range(1, _N_ASYMPTOTIC + 1):
        a[k] = a[k - 1] * (-((2 * k - 1) ** 2)) / (8.0 * k)
    return a


def _asymptotic_coefficients(beta: np.ndarray) -> np.ndarray:
    """Real coefficients ``e_m(beta)``, shape ``(M+1, pieces)``.

    ``int t^beta J0(t) dt = Re[ sqrt(2/pi) e^{i(t - pi/4)} t^(beta-1/2) sum_m d_m t^-m ]``
    with ``d_m = -i^(m+1) e_m``: the Hankel series of ``J0`` term by term times the asymptotic
    antiderivative of ``t^gamma e^{it}`` (``c_0 = -i``, ``c_n = i (gamma - n + 1) c_{n-1}``),
    regrouped by total power; ``e_0 = 1``, ``e_{m+1} = (beta - 1/2 - m) e_m + a_{m+1}``.
    """
    a = _hankel_coefficients()
    e = np.empty((_N_ASYMPTOTIC + 1, beta.size))
    e[0] = 1.0
    for m in range(_N_ASYMPTOTIC):
        e[m + 1] = (beta - 0.5 - m) * e[m] + a[m + 1]
    return e


def _asymptotic_start(e: np.ndarray, t_split: float) -> np.ndarray:
    """Smallest ``t >= t_split`` where the truncated series is accurate for each piece."""
    last = np.abs(e[-1])
    with np.errstate(divide="ignore"):
        t_ok = (last / _ASYMPTOTIC_TOL) ** (1.0 / _N_ASYMPTOTIC)
    return np.maximum(t_split, t_ok)


def _phase(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``sqrt(2/(pi t)) (cos, sin)(t - pi/4)``."""
    c, s = np.cos(t), np.sin(t)
    amp = np.sqrt(1.0 / (np.pi * t))  # sqrt(2/(pi t)) / sqrt(2)
    return amp * (c + s), amp * (s - c)


#: Signs of the real and imaginary parts of ``d_m = -i^(m+1) e_m`` (m = 0, 1, 2, 3, ...:
#: ``-i e0, +e1, +i e2, -e3``), repeating with period 4.
_RE_SIGN = np.tile([0.0, 1.0, 0.0, -1.0], _N_ASYMPTOTIC // 4 + 1)[:_N_ASYMPTOTIC + 1]
_IM_SIGN = np.tile([-1.0, 0.0, 1.0, 0.0], _N_ASYMPTOTIC // 4 + 1)[:_N_ASYMPTOTIC + 1]


def _series_lengths(t: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Per ``t``: the shortest series of ``_TERM_TIERS`` whose truncation error is negligible.

    The first omitted term ``|e_n| t^-n`` must stay below ``_ASYMPTOTIC_TOL`` (``e``:
    coefficients of all pieces, shape ``(M+1, ...)``); the longest series is always
    accurate beyond :func:`_asymptotic_start`.
    """
    big = np.abs(e.reshape(e.shape[0], -1)).max(axis=1)  # (M+1,)
    n = np.minimum(_TERM_TIERS, big.size - 1)
    with np.errstate(divide="ignore"):
        threshold = (big[n] / _ASYMPTOTIC_TOL) ** (1.0 / n)
    threshold[-1] = 0.0
    return n[np.argmax(t[:, None] >= threshold[None, :], axis=1)]


def _series(t: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """``sqrt(2/(pi t)) Re[e^{i(t-pi/4)} sum_m d_m t^-m]``, ``d_m = -i^(m+1) coef_m``.

    ``coef`` has shape ``(n, points)``: the series has ``n`` terms.
    """
    n = coef.shape[0]
    u = np.empty(coef.shape)
    u[0] = 1.0
    if n > 1:
        u[1:] = 1.0 / t
        np.cumprod(u[1:], axis=0, out=u[1:])
    terms = coef * u
    cos_p, sin_p = _phase(t)
    return (_RE_SIGN[:n] @ terms) * cos_p - (_IM_SIGN[:n] @ terms) * sin_p


def _power_law_sum(x, idx, khi, c_top, alpha, rows):
    """``q f(q) / r`` at ``x = q / K_hi`` for the pieces ``idx``: the physical prefactor."""
    return c_top[idx] * khi[idx] * np.exp((1.0 + alpha[idx]) * np.log(x)) / rows


def _closed_form(t, idx, rows, pieces, e) -> np.ndarray:
    """Asymptotic antiderivative of ``q f(q) J0(q r)`` at ``t = q r`` for the pieces ``idx``.

    ``e``: coefficients of every term ``j`` of ``f``, shape ``(M+1, terms, pieces)``; the
    terms are combined per point, ``sum_j g_j x^j e_m(1 + alpha + j)``, into one series,
    evaluated in tiers of length (far fewer terms are needed at large ``t``).
    """
    khi, c_top, alpha, g = pieces
    x = t / (rows * khi[idx])
    out = _power_law_sum(x, idx, khi, c_top, alpha, rows)
    lengths = _series_lengths(t, e)
    tiers = np.unique(lengths)
    for n in tiers:
        sel = slice(None) if tiers.size == 1 else np.flatnonzero(lengths == n)
        ii, xs = idx[sel], x[sel]
        coef = e[:n, 0, ii] * g[0, ii]
        xj = np.ones_like(xs)
        for j in range(1, g.shape[0]):
            xj = xj * xs
            coef += e[:n, j, ii] * (g[j, ii] * xj)
        out[sel] *= _series(t[sel], coef)
    return out


def _steep_panels(a, b, idx, rows, pieces, order: int):
    """Gauss-Legendre of ``q f(q) J0(q r)`` on ``[a, b]`` in ``t`` (panels of width <= 2).

    Returns ``(pair, value)``: the index into ``a`` of every panel and its integral.
    """
    khi, c_top, alpha, g = pieces
    n_pan = np.ceil((b - a) / 2.0).astype(int)
    rep = np.repeat(np.arange(idx.size), n_pan)
    k = np.arange(rep.size) - np.repeat(np.cumsum(n_pan) - n_pan, n_pan)
    width = (b - a)[rep] / n_pan[rep]
    x, w = gauss_legendre(order)
    t = (a[rep] + k * width)[:, None] + 0.5 * width[:, None] * (x + 1.0)
    ii, rw = idx[rep][:, None], rows[rep][:, None]
    xq = t / (rw * khi[ii])
    poly = g[0, ii]
    for j in range(1, g.shape[0]):
        poly = poly + g[j, ii] * xq**j
    f = _power_law_sum(xq, ii, khi, c_top, alpha, rw) * poly
    return rep, ((f * special.j0(t)) @ w) * 0.5 * width


def oscillatory_terms(r: np.ndarray, klo, khi, c_top, alpha, g, t_split: float,
                      order: int) -> np.ndarray:
    """``int_{T/r}^inf q f(q) J0(q r) dq`` for pieces ``q f = c_top K_hi sum_j g_j x^(1+alpha+j)``.

    ``x = q / K_hi`` on ``[K_lo, K_hi]``; ``g`` has shape ``(terms, pieces)``.  Each power
    law is integrated with the asymptotic antiderivative beyond ``t_split`` (Gauss-Legendre
    where a steep exponent delays the expansion).
    """
    out = np.zeros(r.size)
    use = c_top > 0
    if not np.any(use) or r.size == 0:
        return out
    klo, khi, c_top, alpha, g = klo[use], khi[use], c_top[use], alpha[use], g[:, use]
    nonzero = np.flatnonzero(np.any(g != 0, axis=1))
    g = g[:int(nonzero[-1]) + 1 if nonzero.size else 1]
    pieces = (khi, c_top, alpha, g)
    n_terms = g.shape[0]
    beta = (1.0 + alpha)[None, :] + np.arange(n_terms)[:, None]  # (terms, pieces)
    e = _asymptotic_coefficients(beta.ravel()).reshape(-1, n_terms, alpha.size)
    t_start = _asymptotic_start(e.reshape(e.shape[0], -1), t_split).reshape(
        n_terms, -1).max(axis=0)
    # all (r, piece) pairs that reach beyond t_split
    ri, pj = np.nonzero(khi[None, :] * r[:, None] > t_split)
    if ri.size == 0:
        return out
    rr = r[ri]
    t_lo = np.maximum(klo[pj] * rr, t_split)
    t_hi = khi[pj] * rr
    t_asy = np.maximum(t_lo, t_start[pj])
    # closed-form (asymptotic) part on [t_asy, t_hi]
    act = t_hi > t_asy
    if np.any(act):
        idx, rows = np.tile(pj[act], 2), np.tile(rr[act], 2)
        val = _closed_form(np.concatenate([t_hi[act], t_asy[act]]), idx, rows, pieces, e)
        k = idx.size // 2
        out += np.bincount(ri[act], val[:k] - val[k:], minlength=out.size)
    # steep pieces: Gauss-Legendre on [t_lo, min(t_hi, t_asy)]
    b_all = np.minimum(t_hi, t_asy)
    steep = b_all > t_lo
    if np.any(steep):
        rep, vals = _steep_panels(t_lo[steep], b_all[steep], pj[steep], rr[steep], pieces,
                                  order)
        out += np.bincount(ri[steep][rep], vals, minlength=out.size)
    return out
