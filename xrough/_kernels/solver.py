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
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .deferred import fft as sfft
from .deferred import optimize

__all__ = [
    "ElasticOperator",
    "pixel_influence",
    "solve_load",
    "solve_approach",
    "coarse_start",
    "full_contact_stress",
    "full_contact_solution",
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


def pixel_influence(x: np.ndarray, y: np.ndarray, dx: float, dy: float) -> np.ndarray:
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


class ElasticOperator:
    r"""Surface displacement ``u / 1`` of the half-space under pressure ``p / E*``.

    Periodic grids use the periodic Green's function in Fourier space,
    ``u~(q) = 2 p~(q) / (E* |q|)`` with the ``q = 0`` term set to zero (the mean
    displacement of a periodic half-space is undefined; the rigid-body offset absorbs it).
    Pressures are point samples, so full contact gives ``p~ = (E*/2)|q| h~`` exactly.

    Non-periodic grids are piecewise-constant pressure pixels in free space: the pixel
    influence of :func:`pixel_influence` is sampled at all pixel-centre offsets on a grid
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
            k = pixel_influence(ox[None, :], oy[:, None], dx, dy)
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
        of the open-grid operator (the preconditioner of :func:`solve_load`). Same
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


def _gap_scale(h: np.ndarray, p0: float, op: ElasticOperator) -> float:
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
#: displacement's dtype (each pixel costs a pass over the map; a float32 pair of
#: transforms costs about half a float64 one, so it is worth fewer pixels).
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


@dataclass
class _Problem:
    """What a load-controlled solve keeps fixed: the map, the operator and the load."""

    h: np.ndarray
    op: ElasticOperator
    total: float  #: ``n p0``, the sum of the pressure over the map
    scale: float  #: length that normalises the gap error (:func:`_gap_scale`)
    tol: float
    precondition: bool


@dataclass
class _Stall:
    """Lowest residual so far and the iterations since it was reached."""

    best: float = np.inf
    count: int = 0

    def update(self, res: float) -> int:
        """Record the residual ``res``; return the iterations without a new lowest one."""
        self.count = 0 if res < self.best else self.count + 1
        self.best = min(self.best, res)
        return self.count


#: A work map of :class:`_State` not (or no longer) allocated: released before the next.
_RELEASED = np.empty(0)
_RELEASED.setflags(write=False)


@dataclass
class _State:
    """Iterate of :func:`solve_load`: pressure and direction on the contact set, work maps.

    ``p_s`` and ``t_s`` (float64) are the pressure and the search direction on the
    contact set ``idx`` (sorted flat indices; ``inc`` is its mask). The work maps are in
    the precision ``dtype`` of the phase (``tf`` and ``zf`` in that of the direction):
    ``hh`` the heights, ``pf`` the pressure as of the last contact-set change, ``tf`` the
    direction and ``zf`` the gap for the preconditioner (on ``idx``, zero elsewhere),
    ``u`` the displacement ``K p``, ``d`` and ``below`` scratch maps for :func:`_gap`.
    ``exact``: ``u = K p`` to the precision of ``u`` (false after float32 updates);
    ``fresh``: ``u`` was transformed from ``pf = p`` and not updated since.
    """

    idx: np.ndarray
    p_s: np.ndarray
    t_s: np.ndarray
    inc: np.ndarray
    dtype: type
    hh: np.ndarray = field(default_factory=lambda: _RELEASED)
    pf: np.ndarray = field(default_factory=lambda: _RELEASED)
    tf: np.ndarray = field(default_factory=lambda: _RELEASED)
    zf: np.ndarray | None = None
    u: np.ndarray = field(default_factory=lambda: _RELEASED)
    d: np.ndarray = field(default_factory=lambda: _RELEASED)
    below: np.ndarray = field(default_factory=lambda: _RELEASED)
    exact: bool = True
    fresh: bool = True
    delta: float = 0.0  #: 1 to conjugate the next direction, 0 to restart it
    g_old: float = 1.0  #: ``G`` (``g.z`` preconditioned) of the previous iteration
    iteration: int = 0
    history: list = field(default_factory=list)
    transforms: int = 0
    float32_iterations: int = 0
    deferred_entries: int = 0
    refreshes: int = 0
    stall32: _Stall = field(default_factory=_Stall)
    stall64: _Stall = field(default_factory=_Stall)


@dataclass
class _Step:
    """Outcome of one iteration: residual, pressure change and what stopping needs."""

    res: float
    eps_p: float
    denom: float  #: ``r.t``; not positive when the direction gives no step
    G: float  #: gap error on the contact set
    n_off: int  #: overlapping points out of contact that were let in


def _initial_state(prob: _Problem, p0: float, p_init: np.ndarray | None,
                   dtype: type) -> _State:
    """Start from ``p_init`` rescaled to the mean ``p0`` (uniform ``p0`` when absent or 0)."""
    shape = prob.h.shape
    if p_init is None or not np.any(p_init > 0):
        p = np.full(shape, p0, dtype=float)
    else:
        p = np.clip(np.asarray(p_init, dtype=float), 0.0, None)
        p *= p0 / p.mean()
    idx = np.flatnonzero(p)
    p_s = p.ravel()[idx]
    inc = np.zeros(shape, dtype=bool)
    inc.ravel()[idx] = True
    st = _State(idx=idx, p_s=p_s, t_s=np.zeros_like(p_s), inc=inc, dtype=dtype)
    _set_precision(prob, st, dtype, dtype)
    return st


def _set_precision(prob: _Problem, st: _State, dtype: type, t_dtype: type) -> None:
    """Make the work maps in ``dtype`` (``t_dtype`` for the direction) and ``u = K p``.

    The maps of the previous phase are released first, so that both are never alive.
    """
    st.hh = st.pf = st.tf = st.u = st.d = st.below = _RELEASED
    st.zf = None
    shape = prob.h.shape
    st.dtype = dtype
    st.hh = np.ascontiguousarray(prob.h, dtype=dtype)
    st.pf = np.zeros(shape, dtype=dtype)
    st.tf = np.zeros(shape, dtype=t_dtype)
    st.pf.ravel()[st.idx] = st.p_s
    st.u = prob.op(st.pf)
    st.transforms += 2
    st.d = np.empty(shape, dtype=dtype)
    st.below = np.empty(shape, dtype=bool)
    st.exact = st.fresh = True


def _refresh_displacement(prob: _Problem, st: _State) -> None:
    """Transform ``u = K p`` afresh in ``pf``'s precision (the old ``u`` released first).

    ``pf`` holds ``p`` only as of the last contact-set change: brought up to date first.
    """
    st.u = _RELEASED
    st.pf.ravel()[st.idx] = st.p_s
    st.u = prob.op(st.pf)
    st.transforms += 2
    st.exact = st.fresh = True


def _rescale(u: np.ndarray, r: np.ndarray, tau: float, s: float) -> None:
    """Update the displacement ``u <- s (u - tau K t)`` in place (``r = K t``, overwritten)."""
    r *= -tau
    u += r
    u *= s


def _direction(prob: _Problem, st: _State, g_s: np.ndarray, G: float) -> float:
    """Conjugate the direction ``t <- z + delta (Gc / Gc_old) t``; return ``Gc``.

    ``z = g`` and ``Gc = G``, or preconditioned ``z = R K^-1 R^T g``: the gap on the
    contact set, zero elsewhere, mapped through the inverse kernel (one pair of
    transforms, in the direction's precision), restricted to the contact set and
    mean-shifted, with ``Gc = g.z``.
    """
    if prob.precondition:
        if st.zf is None:
            st.zf = np.zeros(prob.h.shape, dtype=st.tf.dtype)
        st.zf.ravel()[st.idx] = g_s
        z_s = prob.op.inverse(st.zf).ravel()[st.idx].astype(float)
        st.transforms += 2
        z_s -= z_s.mean()
        Gc = _dot(g_s, z_s)
    else:
        z_s, Gc = g_s, G
    st.t_s *= st.delta * (Gc / st.g_old)
    st.t_s += z_s
    st.g_old = Gc if Gc > 0 else 1.0
    return Gc


def _project(st: _State, g_s: np.ndarray, off: np.ndarray, g_off: np.ndarray, tau: float,
             tau_g: float) -> tuple:
    """Step ``q = p - tau t`` projected on ``q >= 0``, with the points that (re-)enter.

    Clipped points with a negative gap re-enter, and the overlapping points ``off`` out of
    contact enter, at ``-tau_g g``; either restarts the conjugation.

    Returns
    -------
    tuple
        ``q_s`` (on the contact set), ``q_off`` (on ``off``), the mask ``zero`` of the
        clipped points of the contact set, and the next ``delta``.
    """
    q_s = st.p_s - tau * st.t_s
    np.maximum(q_s, 0.0, out=q_s)
    zero = q_s == 0.0
    enter_s = zero & (g_s < 0)
    q_s[enter_s] = -tau_g * g_s[enter_s]
    if off.size:
        return q_s, np.maximum(-tau_g * g_off, 0.0), zero, 0.0
    return q_s, g_off, zero, 1.0 if not enter_s.any() else 0.0


def _enforce_load(q_s: np.ndarray, q_off: np.ndarray, total: float) -> float:
    """Scale the new pressure in place to the sum ``total``; return the factor ``s``."""
    s = total / (float(q_s.sum()) + float(q_off.sum()))
    q_s *= s
    q_off *= s
    return s


def _correction(st: _State, q_s: np.ndarray, q_off: np.ndarray, zero: np.ndarray,
                off: np.ndarray, tau: float, s: float) -> tuple[np.ndarray, np.ndarray]:
    """Return the pixels and values of ``c = p_new - s (p - tau t)``.

    ``c`` is nonzero only where a point left or (re-)entered the contact set; read
    before the contact set changes.
    """
    ent_off = np.flatnonzero(q_off)
    c_idx = np.concatenate([st.idx[zero], off[ent_off]])
    c_val = np.concatenate([q_s[zero] - s * (st.p_s[zero] - tau * st.t_s[zero]),
                            q_off[ent_off]])
    return c_idx, c_val


def _update_contact_set(st: _State, q_s: np.ndarray, q_off: np.ndarray, off: np.ndarray,
                        delta: float) -> None:
    """Take the new pressure: points at zero leave, entering ones join (merged, sorted)."""
    keep = q_s > 0  # the re-entered points of the clipped ones stay
    left = st.idx[~keep]
    st.pf.ravel()[left] = 0.0
    st.tf.ravel()[left] = 0.0
    if st.zf is not None:
        st.zf.ravel()[left] = 0.0
    st.inc.ravel()[left] = False
    if delta == 0.0:
        new = q_off > 0
        idx_new, p_new = off[new], q_off[new]
        idx, p_s = st.idx[keep], q_s[keep]
        at = np.searchsorted(idx, idx_new)  # both sorted: merge, not sort
        st.idx, st.p_s = np.insert(idx, at, idx_new), np.insert(p_s, at, p_new)
        st.inc.ravel()[idx_new] = True
        st.t_s = np.zeros_like(st.p_s)  # reset by delta = 0
    else:
        st.idx, st.p_s, st.t_s = st.idx[keep], q_s[keep], st.t_s[keep]
    st.pf.ravel()[st.idx] = st.p_s


def _advance_displacement(prob: _Problem, st: _State, r: np.ndarray, tau: float, s: float,
                          c_idx: np.ndarray | None, c_val: np.ndarray | None) -> None:
    """Update ``u <- s (u - tau K t) + K c`` without transforming ``p``.

    ``c`` (``c_idx``, ``c_val``; None when the contact set kept its points) is the
    pressure of the points that left or (re-)entered. A few are added pixel by pixel;
    more (a float64 ``u`` with a float32 direction) by a float32 pair of transforms, whose
    rounding is a few 1e-7 of the correction, like that of ``K t``.
    """
    _rescale(st.u, r, tau, s)
    if c_idx is None or c_idx.size <= POINT_LOADS_MAX[st.u.dtype.type]:
        if c_idx is not None:
            assert c_val is not None  # given with c_idx
            prob.op.add_point_loads(st.u, c_idx, c_val)
        st.exact = st.exact and r.dtype == st.u.dtype
    else:
        r.fill(0.0)
        r.ravel()[c_idx] = c_val
        st.u += prob.op(r)
        st.transforms += 2
        st.exact = False
    st.fresh = False


def _cg_step(prob: _Problem, st: _State) -> _Step:
    """One iteration of :func:`solve_load`.

    The iterates ``p`` and ``t`` live on the contact set only (gathered by index), so the
    full-map work per iteration is the transform of ``t``, one pass for the gap and one
    comparison for the points out of contact with a negative gap. The displacement
    ``u = K p`` is updated linearly, ``u <- s (u - tau K t)``, in iterations where no
    point leaves or re-enters the contact set; where some do, the correction ``K c``
    (``c = p_new - s (p - tau t)``, nonzero at those points) is added pixel by pixel for
    a few (``POINT_LOADS_MAX``), by a float32 pair of transforms in the float64 phase,
    and ``u`` is transformed afresh in the float32 phase: most late iterations cost one
    forward and one inverse transform.
    """
    g_s, _, off, g_off, G, G_off = _gap(st.u, st.hh, st.inc, st.idx, st.d, st.below)
    eps_g = np.sqrt((G + G_off) / st.inc.size) / prob.scale
    if off.size and G_off <= PROPORTION**2 * G:
        # proportioning: while the gradient on the contact set dominates, keep the
        # conjugate iteration on it and let the overlapping points enter later
        off, g_off = off[:0], g_off[:0]
        st.deferred_entries += 1
    Gc = _direction(prob, st, g_s, G)
    st.tf.ravel()[st.idx] = st.t_s
    r = prob.op(st.tf)
    st.transforms += 2
    r_s = r.ravel()[st.idx].astype(float)
    r_s -= float(r_s.mean()) if st.idx.size else np.nan
    denom = _dot(r_s, st.t_s)
    if not denom > 0:
        return _Step(max(0.0, eps_g), 0.0, denom, G, off.size)
    tau = _dot(g_s, st.t_s) / denom
    # re-entering points get the step along the gap, -tau g; preconditioned, tau is per
    # unit of K^-1 g, so the gap is scaled by g.z / g.g (units 1/length) to stay a pressure
    tau_g = tau * (Gc / G) if prob.precondition and G > 0 else tau
    q_s, q_off, zero, st.delta = _project(st, g_s, off, g_off, tau, tau_g)
    s = _enforce_load(q_s, q_off, prob.total)
    eps_p = (float(np.abs(q_s - st.p_s).sum()) + float(np.abs(q_off).sum())) / prob.total
    c_idx = c_val = None
    if zero.any() or off.size:
        c_idx, c_val = _correction(st, q_s, q_off, zero, off, tau, s)
        _update_contact_set(st, q_s, q_off, off, st.delta)
    else:
        st.p_s = q_s
    if (c_idx is not None and c_idx.size > POINT_LOADS_MAX[st.u.dtype.type]
            and r.dtype == st.u.dtype):
        del r  # released before the new transform pair
        _refresh_displacement(prob, st)
    else:
        _advance_displacement(prob, st, r, tau, s, c_idx, c_val)
    return _Step(max(eps_p, eps_g), eps_p, denom, G, off.size)


def _float32_phase_ends(st: _State, step: _Step, tol: float) -> bool:
    """Count a float32 iteration; True once its residual is low, stalls or stops."""
    st.float32_iterations += 1
    stall = st.stall32.update(step.res)
    stalled = stall >= (STALL if st.stall32.best < STALL_BELOW else 4 * STALL)
    return step.res < max(tol, FLOAT32_TOL) or stalled or step.denom <= 0


def _float64_stalled(st: _State, step: _Step, tol: float) -> bool:
    """Tell whether ``2 STALL`` float64 iterations above ``tol`` made no progress.

    The float32 rounding of the steps' ``K t`` that ``u`` accumulates (largest when the
    float32 phase ended early, far from the solution) then holds the residual up.
    """
    return st.stall64.update(step.res) >= 2 * STALL and step.res >= tol


def _exact_residual(prob: _Problem, st: _State, eps_p: float) -> float:
    """Residual on ``u`` transformed afresh in float64, replacing the last in the history.

    ``u`` carries the float32 rounding of the steps' ``K t`` (a few 1e-7 of the steps).
    """
    _refresh_displacement(prob, st)
    _, _, _, _, G, G_off = _gap(st.u, st.hh, st.inc, st.idx, st.d, st.below)
    res = max(eps_p, np.sqrt((G + G_off) / st.inc.size) / prob.scale)
    st.history[-1] = res
    return res


def _restarts(prob: _Problem, st: _State, step: _Step) -> bool:
    """Start a new phase where one is due; True when the iteration restarts.

    The float32 phase ends (:func:`_float32_phase_ends`) in a restart of the conjugation
    on the float64 displacement; a float64 phase that stalls on a displacement carrying
    float32 rounding (:func:`_float64_stalled`) starts again from ``u`` transformed afresh.
    """
    if st.dtype == np.float32:
        if not _float32_phase_ends(st, step, prob.tol):
            return False
        _set_precision(prob, st, np.float64, np.float32)
    elif not st.exact and _float64_stalled(st, step, prob.tol):
        _refresh_displacement(prob, st)
        st.stall64 = _Stall()
        st.refreshes += 1
    else:
        return False
    st.delta = 0.0
    return True


def _converged(prob: _Problem, st: _State, step: _Step) -> bool | None:
    """Whether the solve stopped converged; None while it goes on.

    Below ``tol`` on a displacement updated in float32 the residual is checked on ``u``
    transformed afresh (:func:`_exact_residual`).
    """
    res = step.res
    if res < prob.tol and not st.exact:
        res = _exact_residual(prob, st, step.eps_p)
    if res < prob.tol or step.denom <= 0:
        return res < prob.tol or (step.G == 0 and step.n_off == 0)
    return None


def _result(prob: _Problem, st: _State, converged: bool) -> dict:
    """Full maps of the solution; ``u`` is reused when transformed afresh in float64."""
    u = st.u if st.fresh and st.u.dtype == np.float64 else None
    st.hh = st.pf = st.tf = st.u = st.d = st.below = _RELEASED  # before the result
    st.zf = None
    pressure: np.ndarray = np.zeros(prob.h.size)
    pressure[st.idx] = st.p_s
    pressure = pressure.reshape(prob.h.shape)
    if u is None:
        u = prob.op(pressure)
    u = np.ascontiguousarray(u)  # open maps: not a view of the padded grid
    gap = np.subtract(u, prob.h)
    offset = float(np.mean(gap.ravel()[st.idx]))
    gap -= offset
    return {"pressure": pressure, "displacement": u, "gap": gap, "offset": offset,
            "history": np.asarray(st.history), "iterations": st.iteration,
            "converged": converged, "float32_iterations": st.float32_iterations,
            "transforms": st.transforms, "deferred_entries": st.deferred_entries,
            "refreshes": st.refreshes}


def solve_load(
    h: np.ndarray,
    op: ElasticOperator,
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
    (``p`` and ``p0`` in units of ``E*``), with proportioning (Dostal's MPRGP test,
    ``PROPORTION``) and, optionally, Vollebregt's preconditioner. Stops when
    ``max(eps_p, eps_g) < tol``: the relative pressure change
    ``eps_p = sum|p - p_old| / sum p`` and gap error
    ``eps_g = rms(g on I_c, and g < 0 elsewhere) / rms(h)``. The steps:
    :func:`_cg_step` (gap, proportioning, direction, step, projection, load),
    :func:`_restarts` (the float32 phase's end, float64 refreshes) and :func:`_converged`.
    Notes: docs/solver.md, "Equations and iteration".

    Parameters
    ----------
    h : numpy.ndarray
        Heights (lengths), 2-D.
    op : ElasticOperator
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
        ``"mixed"`` runs in float32 until the residual falls below ``max(tol,
        FLOAT32_TOL)`` (or stops decreasing for ``STALL`` iterations), then restarts the
        conjugation on the float64 displacement and continues to ``tol`` (only the
        transform of the direction stays float32), confirming the final residual on a
        fresh float64 ``u``. Maps under ``MIXED_MIN_SIZE`` points, and ``"float64"``,
        use float64 throughout.
    precondition : bool
        Build the direction from ``z = K^-1 g`` (:meth:`ElasticOperator.inverse`,
        restricted to the contact set and mean-shifted), ``G = g.z`` in the conjugation.

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
    mixed = precision == "mixed" and h.size >= MIXED_MIN_SIZE
    prob = _Problem(h=h, op=op, total=h.size * p0, scale=_gap_scale(h, p0, op), tol=tol,
                    precondition=precondition)
    st = _initial_state(prob, p0, p_init, np.float32 if mixed else np.float64)
    converged = False
    for it in range(1, max_iter + 1):
        st.iteration = it
        step = _cg_step(prob, st)
        st.history.append(step.res)
        if callback is not None:
            callback(it, step.res)
        if _restarts(prob, st, step):
            continue
        stop = _converged(prob, st, step)
        if stop is not None:
            converged = stop
            break
    return _result(prob, st, converged)


def full_contact_stress(h: np.ndarray, op: ElasticOperator) -> np.ndarray | None:
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


def full_contact_solution(h: np.ndarray, op: ElasticOperator, p0: float) -> dict:
    """Return the solve's result for a periodic map in full contact.

    For ``p0`` above ``-min`` of :func:`full_contact_stress` (recomputed here: the
    caller keeps only its minimum, not a map). The displacement is ``K p`` transformed
    like every solve's final field; the residual (the gap error, as in
    :func:`solve_load`) is measured on it, so the result is checked, not assumed.
    """
    p = full_contact_stress(h, op)
    assert p is not None  # a periodic grid (see above)
    p += p0
    u = op(p)
    gap = np.subtract(u, h)
    offset = float(gap.mean())
    gap -= offset
    res = float(np.sqrt(np.mean(gap**2))) / _gap_scale(h, p0, op)
    return {"pressure": p, "displacement": u, "gap": gap, "offset": offset,
            "history": np.array([res]), "iterations": 1, "converged": True,
            "float32_iterations": 0, "transforms": 4, "deferred_entries": 0}


def coarse_start(h: np.ndarray, op: ElasticOperator, p0: float, *, levels: int,
                  tol: float, max_iter: int, precision: str,
                  precondition: bool = True) -> tuple[np.ndarray | None, int]:
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
    opc = ElasticOperator(hc.shape, spacing, periodic=op.periodic, workers=op.workers)
    p_c, its = coarse_start(hc, opc, p0, levels=levels - 1, tol=tol, max_iter=max_iter,
                             precision=precision, precondition=precondition)
    out = solve_load(hc, opc, p0, tol=max(tol, COARSE_TOL), max_iter=max_iter, p_init=p_c,
                      precision=precision, precondition=precondition)
    p = np.repeat(np.repeat(out["pressure"], 2, axis=0), 2, axis=1)
    return p, its + out["iterations"]


def solve_approach(
    h: np.ndarray,
    op: ElasticOperator,
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
    whose load-controlled solution (:func:`solve_load`, each warm-started from the
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
    state: dict[str, Any] = {"p": p_init, "iterations": 0, "last": None, "p0": None}
    hmax = float(h.max())

    def mismatch(p0: float) -> float:
        out = solve_load(h, op, p0, tol=tol, max_iter=max_iter, p_init=state["p"],
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
