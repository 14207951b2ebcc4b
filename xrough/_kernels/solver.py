r"""Boundary-element contact solver: Green's function operators and Polonsky-Keer CG.

Pure numpy/scipy. Frictionless, non-adhesive normal contact between a linear-elastic
half-space (contact modulus ``E*``) and a rigid rough surface ``h`` in the small-slope
approximation. Everything here is dimensionless in pressure: pressures are ``p / E*`` and
all lengths (heights, spacings, displacements, gaps) share one unit, so a displacement is
``length * (p / E*)``.

Sign convention: the elastic body's surface lies at ``z = d + u(r)`` above the rigid
surface ``z = h(r)``, where ``u >= 0`` is the elastic displacement caused by the contact
pressure (away from the rigid surface) and ``d`` the rigid-body position of the body. The
gap is ``g = u - h - offset`` with ``offset = -d``; the approach from first contact is
``delta = max(h) - d = max(h) + offset``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import fft as sfft
from scipy import optimize

__all__ = [
    "_ElasticOperator",
    "_pixel_influence",
    "_solve_load",
    "_solve_approach",
]


def _pixel_integral(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    r"""Primitive of ``1/r`` up to terms that cancel in a rectangle's corner sum.

    ``F(x, y) = x asinh(y/|x|) + y asinh(x/|y|)`` (0 on the axes), so that
    ``int_{x1}^{x2} int_{y1}^{y2} dx dy / sqrt(x^2 + y^2)
    = F(x2, y2) - F(x1, y2) - F(x2, y1) + F(x1, y1)``.
    """
    ax, ay = np.abs(x), np.abs(y)
    with np.errstate(divide="ignore", invalid="ignore"):
        fx = np.where(ax > 0, x * np.arcsinh(y / np.where(ax > 0, ax, 1.0)), 0.0)
        fy = np.where(ay > 0, y * np.arcsinh(x / np.where(ay > 0, ay, 1.0)), 0.0)
    return fx + fy


def _pixel_influence(x: np.ndarray, y: np.ndarray, dx: float, dy: float) -> np.ndarray:
    r"""Displacement ``u E* / p`` at ``(x, y)`` from a uniform pressure on one pixel.

    Love's (1929) solution: the Boussinesq point-load displacement ``P / (pi E* r)``
    integrated over the rectangle ``|x'| <= dx/2, |y'| <= dy/2`` centred at the origin:

    .. math:: K(x, y) = \frac{1}{\pi} \sum_{\pm\pm} \pm F(x \pm dx/2,\, y \pm dy/2),
              \qquad F(x, y) = x\,\mathrm{asinh}(y/|x|) + y\,\mathrm{asinh}(x/|y|)

    At the centre of a square pixel ``K = (4 dx / pi) asinh(1)``.
    """
    a, b = dx / 2, dy / 2
    return (_pixel_integral(x + a, y + b) - _pixel_integral(x - a, y + b)
            - _pixel_integral(x + a, y - b) + _pixel_integral(x - a, y - b)) / np.pi


class _ElasticOperator:
    r"""Surface displacement ``u / 1`` of the half-space under pressure ``p / E*``.

    Periodic grids use the periodic Green's function in Fourier space,
    ``u~(q) = 2 p~(q) / (E* |q|)`` with the ``q = 0`` term set to zero (the mean
    displacement of a periodic half-space is undefined; the rigid-body offset absorbs it).
    Pressures are point samples, so full contact gives ``p~ = (E*/2)|q| h~`` exactly.

    Non-periodic grids are piecewise-constant pressure pixels in free space: the pixel
    influence of :func:`_pixel_influence` is sampled at all pixel-centre offsets on a grid
    doubled along both axes (offsets ``-n..n-1``), Fourier-transformed once, and applied
    by zero-padded circular convolution, which equals the linear convolution on the
    original grid (no periodic images).
    """

    def __init__(self, shape: tuple[int, int], spacing: tuple[float, float], *,
                 periodic: bool, workers: int = -1) -> None:
        self.shape = tuple(int(n) for n in shape)
        self.periodic = bool(periodic)
        self.workers = workers
        ny, nx = self.shape
        dy, dx = spacing
        self.length = float(np.sqrt(ny * dy * nx * dx))
        if self.periodic:
            self.fshape = self.shape
            qy = 2 * np.pi * sfft.fftfreq(ny, d=dy)
            qx = 2 * np.pi * sfft.rfftfreq(nx, d=dx)
            q = np.hypot(qy[:, None], qx[None, :])
            with np.errstate(divide="ignore"):
                self.kernel = np.where(q > 0, 2.0 / np.where(q > 0, q, 1.0), 0.0)
        else:
            self.fshape = (2 * ny, 2 * nx)
            iy = np.arange(2 * ny)
            ix = np.arange(2 * nx)
            oy = np.where(iy < ny, iy, iy - 2 * ny) * dy
            ox = np.where(ix < nx, ix, ix - 2 * nx) * dx
            k = _pixel_influence(ox[None, :], oy[:, None], dx, dy)
            self.kernel = sfft.rfft2(k, workers=workers)

    def __call__(self, p: np.ndarray) -> np.ndarray:
        """Displacement field (same shape as ``p``) for the pressure ``p / E*``."""
        ph = sfft.rfft2(p, s=self.fshape, workers=self.workers)
        ph *= self.kernel  # ph is a fresh array: multiply in place, then let irfft2 reuse it
        u = sfft.irfft2(ph, s=self.fshape, workers=self.workers, overwrite_x=True)
        if not self.periodic:
            u = u[: self.shape[0], : self.shape[1]]
        return u


def _gap_scale(h: np.ndarray, p0: float, op: _ElasticOperator) -> float:
    """Length that normalises the gap error: rms height, else the elastic scale."""
    rms = float(np.sqrt(np.mean((h - h.mean()) ** 2)))
    return rms if rms > 0 else float(np.max(np.abs(op(np.full(h.shape, p0))))) or 1.0


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """Sum of ``a * b`` over all elements.

    ``einsum`` runs single-threaded, so no BLAS thread pool competes with the FFT workers.
    """
    return float(np.einsum("i,i->", a.ravel(), b.ravel()))


def _solve_load(
    h: np.ndarray,
    op: _ElasticOperator,
    p0: float,
    *,
    tol: float,
    max_iter: int,
    p_init: np.ndarray | None = None,
    callback: Callable[[int, float], None] | None = None,
) -> dict:
    r"""Constrained conjugate gradients of Polonsky & Keer (1999) at mean pressure ``p0``.

    Minimises the elastic energy ``p.K.p/2 - p.h`` over ``p >= 0`` with ``mean(p) = p0``
    (``p`` and ``p0`` in units of ``E*``). Per iteration: the gap ``g = K p - h`` is
    shifted by its mean over the contact set ``I_c = {p > 0}`` (the Lagrange multiplier of
    the load constraint, i.e. the rigid-body offset); the conjugate direction
    ``t = g + delta (G / G_old) t`` on ``I_c`` (``G = sum_{I_c} g^2``) is mapped to
    ``r = K t`` (also mean-shifted over ``I_c``); the step ``tau = (g.t)/(r.t)`` updates
    ``p <- p - tau t``; negative pressures are set to zero; non-contact points with a
    negative gap re-enter with ``p = -tau g`` and reset the conjugation (``delta = 0``);
    the pressure is rescaled to the mean ``p0``.

    Stops when ``max(eps_p, eps_g) < tol``, with the relative pressure change
    ``eps_p = sum|p - p_old| / sum p`` and the relative gap error
    ``eps_g = rms(g on I_c, and g < 0 elsewhere) / rms(h)``.

    Returns
    -------
    dict
        ``pressure``, ``displacement``, ``gap`` (lengths), ``offset``, ``history``
        (residual per iteration), ``iterations``, ``converged``.
    """
    n = h.size
    if p_init is None or not np.any(p_init > 0):
        p = np.full(h.shape, p0, dtype=float)
    else:
        p = np.clip(np.asarray(p_init, dtype=float), 0.0, None)
        p *= p0 / p.mean()
    scale = _gap_scale(h, p0, op)
    # Work arrays reused across iterations. ``t`` is kept exactly zero outside the contact
    # set ``S`` and ``w`` is the 0/1 indicator of ``S``, so sums over ``S`` become dot
    # products over the whole array (no boolean-mask copies).
    t = np.zeros_like(p)
    g = np.empty_like(p)
    tmp = np.empty_like(p)
    p_old = np.empty_like(p)
    w = np.empty_like(p)
    S = np.empty(h.shape, dtype=bool)
    mask = np.empty(h.shape, dtype=bool)
    delta = 0.0
    g_old = 1.0
    history: list[float] = []
    converged = False
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007 - the count is reported
        np.subtract(op(p), h, out=g)
        np.greater(p, 0.0, out=S)
        np.copyto(w, S)
        n_s = int(np.count_nonzero(S))
        g -= _dot(w, g) / n_s if n_s else np.nan
        np.multiply(g, w, out=tmp)  # g on S, 0 elsewhere
        G = _dot(tmp, tmp)
        np.subtract(g, tmp, out=tmp)  # g off S, 0 on S
        np.minimum(tmp, 0.0, out=tmp)  # g < 0 off S
        eps_g = np.sqrt((G + _dot(tmp, tmp)) / n) / scale
        t *= delta * (G / g_old)
        t += g
        t *= w
        g_old = G if G > 0 else 1.0
        r = op(t)
        r -= _dot(w, r) / n_s if n_s else np.nan
        denom = _dot(r, t)
        np.copyto(p_old, p)
        if denom > 0:
            tau = _dot(g, t) / denom
            np.multiply(t, tau, out=tmp)
            p -= tmp  # t = 0 off S, so only S changes
            np.maximum(p, 0.0, out=p)
            np.equal(p, 0.0, out=mask)
            np.logical_and(mask, np.less(g, 0.0, out=S), out=mask)  # overlap
            if mask.any():
                delta = 0.0
                np.multiply(g, tau, out=tmp)
                np.subtract(p, tmp, out=p, where=mask)
            else:
                delta = 1.0
            p *= p0 / p.mean()
        np.subtract(p, p_old, out=tmp)
        np.abs(tmp, out=tmp)
        eps_p = float(np.sum(tmp)) / (n * p0)
        res = max(eps_p, eps_g)
        history.append(res)
        if callback is not None:
            callback(it, res)
        if res < tol or denom <= 0:
            outside = bool(np.any((p_old <= 0) & (g < 0)))
            converged = res < tol or (G == 0 and not outside)
            break
    u = op(p)
    S = p > 0
    offset = float(np.mean(u[S] - h[S]))
    return {"pressure": p, "displacement": u, "gap": u - h - offset, "offset": offset,
            "history": np.asarray(history), "iterations": it, "converged": converged}


def _solve_approach(
    h: np.ndarray,
    op: _ElasticOperator,
    approach: float,
    *,
    tol: float,
    max_iter: int,
    p_init: np.ndarray | None = None,
    callback: Callable[[int, float], None] | None = None,
) -> dict:
    r"""Contact at a prescribed approach ``delta = max(h) + offset`` (lengths).

    The approach is monotonic in the mean pressure, so Brent's method finds the ``p0``
    whose load-controlled solution (:func:`_solve_load`, each warm-started from the
    nearest previous solution) has the requested approach, to a relative ``tol``.
    On a periodic grid the approach saturates at full contact, ``max(h) - mean(h)``; larger
    values leave the mean pressure undetermined and raise.
    """
    if op.periodic and approach >= h.max() - h.mean():
        raise ValueError(
            f"displacement {approach:g} reaches full contact of the periodic map "
            f"(max(h) - mean(h) = {h.max() - h.mean():g}), where the mean pressure is not "
            "determined by the displacement; prescribe p0 instead"
        )
    state = {"p": p_init, "iterations": 0, "last": None, "p0": None}
    hmax = float(h.max())

    def mismatch(p0: float) -> float:
        out = _solve_load(h, op, p0, tol=tol, max_iter=max_iter, p_init=state["p"],
                          callback=callback)
        state.update(p=out["pressure"], last=out, p0=p0)
        state["iterations"] += out["iterations"]
        return (hmax + out["offset"]) - approach

    lo = hi = approach / op.length  # a first guess of p / E* ~ strain
    f_lo = f_hi = mismatch(lo)
    for _ in range(80):
        if f_lo < 0:
            break
        lo /= 4
        f_lo = mismatch(lo)
    for _ in range(80):
        if f_hi > 0:
            break
        hi *= 4
        f_hi = mismatch(hi)
    if not (f_lo < 0 < f_hi):
        raise RuntimeError("could not bracket the mean pressure for the displacement")
    p0 = optimize.brentq(mismatch, lo, hi, rtol=max(tol, 4 * np.finfo(float).eps),
                         xtol=1e-300)
    if state["p0"] != p0:
        mismatch(p0)
    out = dict(state["last"])
    out["iterations"] = state["iterations"]  # all solves; the history is the last one's
    return out
