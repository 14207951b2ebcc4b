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
    "_coarse_start",
    "_full_contact_stress",
    "_full_contact_solution",
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
        self.spacing = (float(dy), float(dx))
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
        self._kernels: dict = {}

    def _real_kernel(self, dtype) -> np.ndarray:
        """Return the displacement of a unit pressure at pixel (0, 0), on the transform grid."""
        key = ("real", dtype)
        if key not in self._kernels:
            self._kernels[key] = sfft.irfft2(self.kernel, s=self.fshape,
                                             workers=self.workers).astype(dtype)
        return self._kernels[key]

    def add_point_loads(self, u: np.ndarray, flat: np.ndarray, values: np.ndarray) -> None:
        """Add ``K c`` to ``u`` in place for ``c`` nonzero at a few pixels only.

        Each pixel adds the real-space kernel shifted to it (one pass over ``u`` per
        pixel), which is cheaper than a pair of transforms for a handful of pixels.

        Parameters
        ----------
        u : numpy.ndarray
            Displacement field of the grid's shape, updated in place.
        flat : numpy.ndarray
            Flat indices of the loaded pixels.
        values : numpy.ndarray
            Pressures (over ``E*``) at those pixels.
        """
        k = self._real_kernel(u.dtype.type)
        ny, nx = self.shape
        fy, fx = self.fshape
        for j, c in zip(flat.tolist(), values.tolist()):
            sy, sx = divmod(j, nx)
            for (u0, u1), (k0, k1) in (((sy, ny), (0, ny - sy)), ((0, sy), (fy - sy, fy))):
                if u1 == u0:
                    continue
                for (v0, v1), (l0, l1) in (((sx, nx), (0, nx - sx)),
                                           ((0, sx), (fx - sx, fx))):
                    if v1 > v0:
                        blk = u[u0:u1, v0:v1]
                        blk += c * k[k0:k1, l0:l1]

    def __call__(self, p: np.ndarray) -> np.ndarray:
        """Displacement field (same shape as ``p``) for the pressure ``p / E*``.

        The transforms run in the precision of ``p``: float32 input gives a float32
        result (half the memory traffic of float64), anything else float64.
        """
        return self._convolve(p, inverse=False)

    def inverse(self, g: np.ndarray) -> np.ndarray:
        r"""Apply the inverse of the kernel's transform, ``F^-1 [F g / K~]``.

        On a periodic grid this is the exact inverse on zero-mean fields, the pressure
        ``|q| g~ / 2`` that the displacement ``g`` needs (the full-contact stress); on an
        open grid it inverts the zero-padded circular convolution, an approximate inverse
        of the open-grid operator (the preconditioner of :func:`_solve_load`). Same
        precision rule as :meth:`__call__`.
        """
        return self._convolve(g, inverse=True)

    def _transform_kernel(self, dtype, inverse: bool) -> np.ndarray:
        """Return the kernel's transform (or its inverse, 0 where it vanishes) in ``dtype``."""
        key = (dtype, inverse)
        kernel = self._kernels.get(key)
        if kernel is None:
            kernel = self.kernel
            if inverse:
                with np.errstate(divide="ignore"):
                    kernel = np.where(kernel != 0, 1.0 / np.where(kernel != 0, kernel, 1.0),
                                      0.0)
            if dtype == np.float32:
                # in the transform's precision (a float64 kernel would promote the
                # float32 product to complex128 and back)
                kernel = kernel.astype(np.complex64 if np.iscomplexobj(kernel)
                                       else np.float32)
            self._kernels[key] = kernel
        return kernel

    def _convolve(self, p: np.ndarray, inverse: bool) -> np.ndarray:
        dtype = np.float32 if p.dtype == np.float32 else np.float64
        ph = sfft.rfft2(p, s=self.fshape, workers=self.workers)
        ph *= self._transform_kernel(dtype, inverse)  # ph is fresh: in place
        u = sfft.irfft2(ph, s=self.fshape, workers=self.workers, overwrite_x=True)
        if not self.periodic:
            u = u[: self.shape[0], : self.shape[1]]
        return u


def _gap_scale(h: np.ndarray, p0: float, op: _ElasticOperator) -> float:
    """Length that normalises the gap error: rms height, else the elastic scale."""
    rms = float(np.std(h))
    return rms if rms > 0 else float(np.max(np.abs(op(np.full(h.shape, p0))))) or 1.0


def _gap(u: np.ndarray, h: np.ndarray, inc: np.ndarray, idx: np.ndarray, d: np.ndarray,
         below: np.ndarray) -> tuple:
    """Mean-shifted gap on the contact set and at the overlapping points out of contact.

    ``inc`` is the contact mask (True on ``idx``); ``d`` and ``below`` are work arrays of
    the map's shape (``u``'s and bool dtype).

    Returns
    -------
    tuple
        ``g_s`` (gap on ``idx`` minus its mean ``m``, float64), ``m``, ``off`` (flat
        indices out of contact with a gap below ``m``), ``g_off`` (their shifted gaps,
        negative), ``G = sum g_s^2`` and ``G_off = sum g_off^2``.
    """
    np.subtract(u, h, out=d)
    dflat = d.ravel()
    g_s = dflat[idx].astype(float)
    m = float(g_s.mean()) if idx.size else np.nan
    g_s -= m
    np.less(d, m, out=below)
    np.greater(below, inc, out=below)  # below and not in contact
    off = np.flatnonzero(below)
    g_off = dflat[off].astype(float) - m
    return g_s, m, off, g_off, _dot(g_s, g_s), _dot(g_off, g_off)


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """Sum of ``a * b`` over all elements.

    ``einsum`` runs single-threaded, so no BLAS thread pool competes with the FFT workers.
    """
    return float(np.einsum("i,i->", a.ravel(), b.ravel()))


#: Residual at which a mixed-precision solve leaves its float32 phase (float32 transforms
#: carry a relative error of a few 1e-7 in the displacement, so the gap error of that phase
#: levels off near 1e-7 of the rms height, 1e-8 for the gap error alone).
FLOAT32_TOL = 1e-6
#: Largest number of pixels entering or leaving the contact set for which the
#: displacement is corrected pixel by pixel instead of by a pair of transforms, by the
#: displacement's dtype (each pixel costs a pass over the map; a float32 pair costs
#: about half a float64 one: 1024^2 on 2 cores, 4 and 7-13 ms, a pixel 0.5 ms).
POINT_LOADS_MAX = {np.float32: 6, np.float64: 12}
#: Maps smaller than this solve in float64 throughout (their transforms are too cheap
#: for float32 to pay).
MIXED_MIN_SIZE = 256 * 256
#: Iterations without a new lowest residual after which the float32 phase ends, once
#: the residual has been below ``STALL_BELOW`` (above it, float32 round-off cannot be
#: what holds the residual up, so only ``4 * STALL`` such iterations end the phase).
STALL = 5
STALL_BELOW = 1e-4
#: Tolerance of the coarse-grid solves of the coarse-to-fine start.
COARSE_TOL = 1e-3
#: Proportioning constant ``Gamma`` (Dostal's MPRGP): points out of contact with a
#: negative gap enter the contact set (and reset the conjugation) only in iterations
#: where their gap error exceeds ``Gamma`` times the gap error on the contact set.
PROPORTION = 0.5


def _solve_load(
    h: np.ndarray,
    op: _ElasticOperator,
    p0: float,
    *,
    tol: float,
    max_iter: int,
    p_init: np.ndarray | None = None,
    callback: Callable[[int, float], None] | None = None,
    precision: str = "mixed",
    precondition: bool = True,
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
    the pressure is rescaled to the mean ``p0``. Proportioning (the test of Dostal's
    MPRGP): the overlapping points enter only in iterations where their gap error
    ``sum g_off^2`` exceeds ``PROPORTION^2 G``; otherwise the conjugate iteration goes on
    on ``I_c`` and they enter later. Without it nearly every iteration of a rough
    surface resets the conjugation and the method degrades to steepest descent.

    Stops when ``max(eps_p, eps_g) < tol``, with the relative pressure change
    ``eps_p = sum|p - p_old| / sum p`` and the relative gap error
    ``eps_g = rms(g on I_c, and g < 0 elsewhere) / rms(h)``.

    Implementation: the iterates ``p`` and ``t`` live on the contact set only (gathered by
    index), so the full-map work per iteration is the transform of ``t``, one pass for the
    gap and one comparison for the points out of contact with a negative gap. The
    displacement ``u = K p`` is updated linearly, ``u <- s (u - tau K t)``, in iterations
    where no point leaves or re-enters the contact set; where some do, the correction
    ``K c`` (``c = p_new - s (p - tau t)``, nonzero at those points) is added pixel by
    pixel for a few (``POINT_LOADS_MAX``), by a float32 pair of transforms in the float64
    phase, and ``u`` is transformed afresh in the float32 phase: most late iterations
    cost one forward and one inverse transform.

    Parameters
    ----------
    h : numpy.ndarray
        Heights (lengths), 2-D.
    op : _ElasticOperator
        Green's function operator of the grid.
    p0 : float
        Mean pressure over ``E*``.
    tol : float
        Relative tolerance of the residual.
    max_iter : int
        Maximal number of iterations.
    p_init : numpy.ndarray, optional
        Initial pressure (rescaled to ``p0``); a uniform ``p0`` when absent or zero.
    callback : callable, optional
        Called as ``callback(iteration, residual)``.
    precision : {"mixed", "float64"}
        ``"mixed"`` runs everything in float32 until the residual falls below
        ``max(tol, FLOAT32_TOL)`` (or stops decreasing for ``STALL`` iterations), then
        restarts the conjugation on the float64 displacement ``u = K p`` and continues
        to ``tol``: the displacement, the gap and every transform of ``p`` are float64,
        only the transform of the direction ``t`` stays float32 (its rounding enters
        ``u`` as a few 1e-7 of each step, far below the gap error). A residual below
        ``tol`` is confirmed on ``u`` transformed afresh in float64 before the solve
        stops. Maps of fewer than ``MIXED_MIN_SIZE`` points use float64 throughout.
        ``"float64"`` uses float64 throughout.
    precondition : bool
        Build the direction from ``z = K^-1 g`` (the gap on the contact set, zero
        elsewhere, through :meth:`_ElasticOperator.inverse`, restricted to the contact
        set and mean-shifted) instead of ``g``, with ``G = g.z`` in the conjugation
        (Vollebregt 2014): one more pair of transforms per iteration, in the direction's
        precision. Proportioning keeps comparing the plain gap errors.

    Returns
    -------
    dict
        ``pressure``, ``displacement``, ``gap`` (lengths), ``offset``, ``history``
        (residual per iteration), ``iterations``, ``float32_iterations``, ``transforms``
        (forward plus inverse FFTs), ``converged``, ``deferred_entries`` (iterations in
        which proportioning kept overlapping points out), ``refreshes`` (restarts of the
        float64 phase from a fresh displacement after ``2 STALL`` iterations without
        progress).
    """
    if precision not in ("mixed", "float64"):
        raise ValueError(f"precision must be 'mixed' or 'float64', got {precision!r}")
    if precision == "mixed" and h.size < MIXED_MIN_SIZE:
        precision = "float64"
    n = h.size
    shape = h.shape
    if p_init is None or not np.any(p_init > 0):
        p = np.full(shape, p0, dtype=float)
    else:
        p = np.clip(np.asarray(p_init, dtype=float), 0.0, None)
        p *= p0 / p.mean()
    scale = _gap_scale(h, p0, op)
    total = n * p0
    idx = np.flatnonzero(p)  # the contact set, as flat indices
    p_s = p.ravel()[idx]
    t_s = np.zeros_like(p_s)
    del p

    inc = np.zeros(shape, dtype=bool)  # the contact mask, True on idx
    inc.ravel()[idx] = True

    def precision_state(dtype, t_dtype):
        """Work arrays in ``dtype`` (``t_dtype`` for the direction) and ``u = K p``.

        ``pf`` holds ``p`` on ``idx`` (updated when the contact set changes) and ``tf``
        the direction on ``idx``; both are zero elsewhere.
        """
        hh = np.ascontiguousarray(h, dtype=dtype)
        pf = np.zeros(shape, dtype=dtype)
        tf = np.zeros(shape, dtype=t_dtype)
        pf.ravel()[idx] = p_s
        return hh, pf, tf, op(pf), np.empty(shape, dtype=dtype), np.empty(shape, dtype=bool)

    def exact_displacement():
        """``u = K p`` transformed afresh in ``pf``'s precision.

        ``pf`` holds ``p`` only as of the last contact-set change: brought up to date
        first. The caller releases the old ``u`` before, so that it is not alive
        during the transform.
        """
        pf.ravel()[idx] = p_s
        return op(pf)

    dtype = np.float32 if precision == "mixed" else np.float64
    hh, pf, tf, u, d, below = precision_state(dtype, dtype)
    zf = None  # the gap on idx, zero elsewhere, for the preconditioner
    exact = True  # whether u = K p to the precision of u (false after float32 updates)
    fresh = True  # whether u was transformed from pf = p (no update since)
    transforms = 2
    f32_its = 0
    best32 = best64 = np.inf
    stall = stall64 = 0
    refreshes = 0
    deferred = 0
    delta = 0.0
    g_old = 1.0
    history: list[float] = []
    converged = False
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007 - the count is reported
        g_s, m, off, g_off, G, G_off = _gap(u, hh, inc, idx, d, below)
        eps_g = np.sqrt((G + G_off) / n) / scale
        if off.size and G_off <= PROPORTION**2 * G:
            # proportioning: while the gradient on the contact set dominates, keep the
            # conjugate iteration on it and let the overlapping points enter later
            off, g_off = off[:0], g_off[:0]
            deferred += 1
        if precondition:
            # z = R K^-1 R^T g: the gap on the contact set, zero elsewhere, mapped
            # through the inverse kernel (one pair of transforms, in the direction's
            # precision), restricted to the contact set and mean-shifted
            if zf is None:
                zf = np.zeros(shape, dtype=tf.dtype)
            zf.ravel()[idx] = g_s
            z = op.inverse(zf)
            transforms += 2
            z_s = z.ravel()[idx].astype(float)
            z = None
            z_s -= z_s.mean()
            Gc = _dot(g_s, z_s)
        else:
            z_s, Gc = g_s, G
        t_s *= delta * (Gc / g_old)
        t_s += z_s
        g_old = Gc if Gc > 0 else 1.0
        tflat = tf.ravel()
        tflat[idx] = t_s
        r = op(tf)
        transforms += 2
        r_s = r.ravel()[idx].astype(float)
        r_mean = float(r_s.mean()) if idx.size else np.nan
        r_s -= r_mean
        denom = _dot(r_s, t_s)
        if denom > 0:
            tau = _dot(g_s, t_s) / denom
            q_s = p_s - tau * t_s
            np.maximum(q_s, 0.0, out=q_s)
            zero = q_s == 0.0
            enter_s = zero & (g_s < 0)  # clipped points with a negative gap re-enter
            # re-entering points get the step along the gap, -tau g; preconditioned,
            # tau is per unit of K^-1 g, so the gap is scaled by g.z / g.g, the mean
            # ratio of K^-1 g to g (units 1/length), to stay a pressure
            tau_g = tau * (Gc / G) if precondition and G > 0 else tau
            q_s[enter_s] = -tau_g * g_s[enter_s]
            changed = bool(zero.any()) or off.size > 0
            if off.size:
                delta = 0.0
                q_off = np.maximum(-tau_g * g_off, 0.0)
            else:
                q_off = g_off
                delta = 1.0 if not enter_s.any() else 0.0
            s = total / (float(q_s.sum()) + float(q_off.sum()))
            q_s *= s
            q_off *= s
            eps_p = (float(np.abs(q_s - p_s).sum()) + float(np.abs(q_off).sum())) / total
            if changed:
                # c = p_new - s (p - tau t): nonzero where a point left or (re-)entered
                ent_off = np.flatnonzero(q_off)
                c_idx = np.concatenate([idx[zero], off[ent_off]])
                c_val = np.concatenate([q_s[zero] - s * (p_s[zero] - tau * t_s[zero]),
                                        q_off[ent_off]])
                n_changed = c_idx.size
            if changed:
                keep = q_s > 0
                left = idx[~keep]
                pf.ravel()[left] = 0.0
                tflat[left] = 0.0
                if zf is not None:
                    zf.ravel()[left] = 0.0
                inc.ravel()[left] = False
                if delta == 0.0:
                    new = q_off > 0
                    idx_new, p_new = off[new], q_off[new]
                    idx, p_s = idx[keep], q_s[keep]
                    at = np.searchsorted(idx, idx_new)  # both sorted: merge, not sort
                    idx, p_s = np.insert(idx, at, idx_new), np.insert(p_s, at, p_new)
                    inc.ravel()[idx_new] = True
                    t_s = np.zeros_like(p_s)  # reset below by delta = 0
                else:
                    idx, p_s, t_s = idx[keep], q_s[keep], t_s[keep]
                pf.ravel()[idx] = p_s
                if n_changed <= POINT_LOADS_MAX[u.dtype.type]:
                    # u <- s (u - tau K t) + K c, c on a few pixels
                    r *= -tau
                    u += r
                    u *= s
                    op.add_point_loads(u, c_idx, c_val)
                    exact = exact and r.dtype == u.dtype
                    fresh = False
                elif r.dtype != u.dtype:
                    # float64 u, float32 direction: K c in float32 too (its rounding is
                    # a few 1e-7 of the correction, like that of K t of the step), a
                    # cheaper pair than u = K p afresh in float64
                    r *= -tau
                    u += r
                    u *= s
                    r.fill(0.0)
                    r.ravel()[c_idx] = c_val
                    u += op(r)
                    transforms += 2
                    exact = fresh = False
                else:
                    r = u = None  # released before the new transform pair
                    u = op(pf)
                    transforms += 2
                    exact = fresh = True
            else:
                p_s = q_s
                r *= -tau
                u += r
                u *= s
                exact = exact and r.dtype == u.dtype
                fresh = False
        else:
            eps_p = 0.0
        r = None  # K t is spent: one map fewer at the next transform
        res = max(eps_p, eps_g)
        history.append(res)
        if callback is not None:
            callback(it, res)
        if dtype == np.float32:
            f32_its += 1
            stall = 0 if res < best32 else stall + 1
            best32 = min(best32, res)
            stalled = stall >= (STALL if best32 < STALL_BELOW else 4 * STALL)
            if res < max(tol, FLOAT32_TOL) or stalled or denom <= 0:
                dtype = np.float64
                delta = 0.0  # restart the conjugation on the exact displacement
                hh = pf = tf = u = d = below = r = zf = None  # free float32 first
                hh, pf, tf, u, d, below = precision_state(dtype, np.float32)
                transforms += 2
                exact = fresh = True
                continue
        elif not exact:
            stall64 = 0 if res < best64 else stall64 + 1
            best64 = min(best64, res)
            if stall64 >= 2 * STALL and res >= tol:
                # the float32 rounding of the steps' K t that u accumulates (largest
                # when the float32 phase ended early, far from the solution) holds the
                # residual up: start again from u transformed afresh in float64
                u = None
                u = exact_displacement()
                transforms += 2
                exact = fresh = True
                delta = 0.0
                stall64, best64 = 0, np.inf
                refreshes += 1
                continue
        if res < tol and not exact:
            # u carries the float32 rounding of the steps' K t (a few 1e-7 of the
            # steps, far below tol): check the residual on the exact displacement
            u = None
            u = exact_displacement()
            transforms += 2
            exact = fresh = True
            _, _, _, _, G_v, G_off_v = _gap(u, hh, inc, idx, d, below)
            res = max(eps_p, np.sqrt((G_v + G_off_v) / n) / scale)
            history[-1] = res
        if res < tol or denom <= 0:
            converged = res < tol or (G == 0 and off.size == 0)
            break
    # u = K p transformed afresh in float64 with pf = p (the check above): reused
    reuse = fresh and u.dtype == np.float64
    hh = pf = tf = d = below = r = zf = None  # the work arrays go before the result
    if not reuse:
        u = None
    pfull = np.zeros(n)
    pfull[idx] = p_s
    pfull = pfull.reshape(shape)
    if not reuse:
        u = op(pfull)
    u = np.ascontiguousarray(u)  # open maps: not a view of the padded grid
    gap = np.subtract(u, h)
    offset = float(np.mean(gap.ravel()[idx]))
    gap -= offset
    return {"pressure": pfull, "displacement": u, "gap": gap, "offset": offset,
            "history": np.asarray(history), "iterations": it, "converged": converged,
            "float32_iterations": f32_its, "transforms": transforms,
            "deferred_entries": deferred, "refreshes": refreshes}


def _full_contact_stress(h: np.ndarray, op: _ElasticOperator) -> np.ndarray | None:
    r"""Pressure (over ``E*``) that full contact adds to the mean: ``K^-1 (h - mean h)``.

    On a periodic grid ``K^-1`` is diagonal in Fourier space, ``p~(q) = |q| h~(q) / 2``
    (``q = 0`` dropped), so full contact at mean pressure ``p0`` is
    ``p = p0 + K^-1 (h - mean h)`` exactly, and it is the solution whenever that ``p`` is
    positive everywhere, i.e. for ``p0 > -min(K^-1 h)``. ``None`` for open grids, where
    the kernel has no such inverse.
    """
    if not op.periodic:
        return None
    return op.inverse(np.asarray(h, dtype=float))


def _full_contact_solution(h: np.ndarray, op: _ElasticOperator, p0: float) -> dict:
    """Return the solve's result for a periodic map in full contact.

    For ``p0`` above ``-min`` of :func:`_full_contact_stress` (recomputed here: the
    caller keeps only its minimum, not a map). The displacement is ``K p`` transformed
    like every solve's final field; the residual (the gap error, as in
    :func:`_solve_load`) is measured on it, so the result is checked, not assumed.
    """
    p = _full_contact_stress(h, op)
    p += p0
    u = op(p)
    gap = np.subtract(u, h)
    offset = float(gap.mean())
    gap -= offset
    res = float(np.sqrt(np.mean(gap**2))) / _gap_scale(h, p0, op)
    return {"pressure": p, "displacement": u, "gap": gap, "offset": offset,
            "history": np.array([res]), "iterations": 1, "converged": True,
            "float32_iterations": 0, "transforms": 4, "deferred_entries": 0}


def _coarse_start(h: np.ndarray, op: _ElasticOperator, p0: float, *, levels: int,
                  tol: float, max_iter: int, precision: str,
                  precondition: bool = True) -> tuple[np.ndarray, int]:
    """Start from the solution on grids restricted ``levels`` times by 2.

    Each restriction averages 2 x 2 pixels of ``h`` (the spacing doubles); the coarse
    solution, itself started from a coarser one, is repeated onto 2 x 2 pixels. Stops
    early at odd sizes or below 64 points a side. The coarse grids are solved only to
    ``max(tol, COARSE_TOL)``: their solution differs from the fine one by far more than
    that anyway (the contact edges move by a pixel), so a tighter solve buys nothing.

    Returns
    -------
    tuple
        The pressure on the grid of ``h`` (or None when no coarser grid exists) and the
        iterations spent on the coarse grids.
    """
    ny, nx = h.shape
    if levels < 1 or ny % 2 or nx % 2 or min(ny, nx) < 128:
        return None, 0
    hc = h.reshape(ny // 2, 2, nx // 2, 2).mean(axis=(1, 3))
    spacing = (2 * op.spacing[0], 2 * op.spacing[1])
    opc = _ElasticOperator(hc.shape, spacing, periodic=op.periodic, workers=op.workers)
    p_c, its = _coarse_start(hc, opc, p0, levels=levels - 1, tol=tol, max_iter=max_iter,
                             precision=precision, precondition=precondition)
    out = _solve_load(hc, opc, p0, tol=max(tol, COARSE_TOL), max_iter=max_iter, p_init=p_c,
                      precision=precision, precondition=precondition)
    p = np.repeat(np.repeat(out["pressure"], 2, axis=0), 2, axis=1)
    return p, its + out["iterations"]


def _solve_approach(
    h: np.ndarray,
    op: _ElasticOperator,
    approach: float,
    *,
    tol: float,
    max_iter: int,
    p_init: np.ndarray | None = None,
    callback: Callable[[int, float], None] | None = None,
    precision: str = "mixed",
    precondition: bool = True,
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
                          callback=callback, precision=precision,
                          precondition=precondition)
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
