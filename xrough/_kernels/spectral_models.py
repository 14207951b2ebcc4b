"""Model height spectra C(q) of isotropic self-affine surfaces (pure numpy).

Conventions (docs/theory.md): angular wavenumber q = 2 pi / wavelength; C(q) = A <|h~(q)|^2>
for a 2D map (units length^4); moments ``(1/2pi) int dq q^(1+k) C(q)``.

Two shapes:

``"sharp"`` (paper eq. 35)
    ``C = C_r`` for ``q_0 <= q < q_r``, ``C_r (q/q_r)^(-2(1+H))`` for ``q_r <= q < q_s``,
    zero otherwise.
``"smooth"``
    ``C = C_r [1 + (q/q_r)^2]^-(1+H)`` for ``q_0 <= q < q_s``, zero otherwise.

Both tend to the same power law ``C_r (q/q_r)^(-2(1+H))`` for ``q >> q_r``; ``C_r`` is the
plateau value for ``q -> 0``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import integrate

__all__ = ["SpectrumModel", "model_gradient2"]

ROLLOFFS = ("sharp", "smooth")


@dataclass(frozen=True)
class SpectrumModel:
    """An isotropic model spectrum in one consistent length unit.

    Parameters
    ----------
    hurst : float
        Hurst exponent H, 0 < H < 1.
    q_r, q_s : float
        Roll-off and short-wavelength cutoff wavenumbers (1/length), ``q_r < q_s``.
    q_0 : float
        Lower cutoff (``2 pi / L``), 0 for none; ``q_0 <= q_r``.
    C_r : float
        Plateau value (length^4).
    rolloff : {'sharp', 'smooth'}
    """

    hurst: float
    q_r: float
    q_s: float
    q_0: float = 0.0
    C_r: float = 1.0
    rolloff: str = "sharp"

    def __post_init__(self) -> None:
        if not 0.0 < self.hurst < 1.0:
            raise ValueError(f"hurst must lie in (0, 1), got {self.hurst}")
        if not (0.0 <= self.q_0 <= self.q_r < self.q_s) or not np.isfinite(self.q_s):
            raise ValueError(
                "cutoffs must satisfy 0 <= q_0 <= q_r < q_s < inf (i.e. lambda_0 >= lambda_r "
                f"> lambda_s > 0); got q_0={self.q_0:g}, q_r={self.q_r:g}, q_s={self.q_s:g}"
            )
        if self.rolloff not in ROLLOFFS:
            raise ValueError(f"rolloff must be one of {ROLLOFFS}, got {self.rolloff!r}")
        if not (self.C_r > 0 and np.isfinite(self.C_r)):
            raise ValueError(f"C_r must be positive and finite, got {self.C_r}")

    # -- evaluation -------------------------------------------------------------------
    def shape(self, q: np.ndarray) -> np.ndarray:
        """C(q)/C_r, vectorised; zero outside ``[q_0, q_s)``."""
        q = np.asarray(q, dtype=float)
        e = -2.0 * (1.0 + self.hurst)
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            if self.rolloff == "sharp":
                val = np.where(q < self.q_r, 1.0, (q / self.q_r) ** e)
            else:
                val = (1.0 + (q / self.q_r) ** 2) ** (-(1.0 + self.hurst))
        inside = (q >= self.q_0) & (q < self.q_s)
        return np.where(inside, val, 0.0)

    def __call__(self, q: np.ndarray) -> np.ndarray:
        """C(q) in length^4."""
        return self.C_r * self.shape(q)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Wavenumbers where C or its slope jumps (integration must split there)."""
        pts = [self.q_0, self.q_r, self.q_s] if self.q_0 > 0 else [0.0, self.q_r, self.q_s]
        return tuple(pts)

    # -- moments ----------------------------------------------------------------------
    def moment(self, k: int) -> float:
        """``(1/2pi) int dq q^(1+k) C(q)``: k=0 gives sigma_h^2, k=2 the mean-square gradient.

        Closed form for the sharp shape; adaptive quadrature (rtol 1e-12) for the smooth one.
        """
        return self.C_r * self.shape_moment(k)

    def shape_moment(self, k: int) -> float:
        """``moment(k) / C_r``."""
        H, q0, qr, qs = self.hurst, self.q_0, self.q_r, self.q_s
        if self.rolloff == "sharp":
            flat = (qr ** (2 + k) - q0 ** (2 + k)) / (2 + k)
            p = k - 2 * H
            if abs(p) < 1e-12:
                tail = qr ** (2 + 2 * H) * np.log(qs / qr)
            else:
                tail = qr ** (2 + 2 * H) * (qs**p - qr**p) / p
            return float((flat + tail) / (2 * np.pi))
        # smooth: integrate in log q for accuracy over many decades
        def f(lnq: float) -> float:
            q = np.exp(lnq)
            return q ** (2 + k) * (1 + (q / qr) ** 2) ** (-(1 + H))

        lo = np.log(q0) if q0 > 0 else np.log(qr) - 40.0
        pts = sorted({lo, np.log(qr), np.log(qs)})
        total = 0.0
        for a, b in zip(pts[:-1], pts[1:]):
            val, _ = integrate.quad(f, a, b, epsrel=1e-13, epsabs=0.0, limit=200)
            total += val
        return float(total / (2 * np.pi))


def _expm1_minus_linear(v):
    """``exp(v) - 1 - v`` without cancellation."""
    v = np.asarray(v, dtype=float)
    small = np.abs(v) < 0.1
    vs = np.where(small, v, 0.0)
    series, term = np.zeros_like(vs), vs.copy()
    for k in range(2, 14):
        term = term * vs / k
        series += term
    return np.where(small, series, np.expm1(np.where(small, 0.0, v)) - v)


def model_gradient2(q_cut, *, c: float, hurst: float, q_r: float, q_s: float,
                    q_0: float = 0.0, rolloff: str = "sharp") -> np.ndarray:
    """Eq. 26 of the model spectrum in closed form: ``(1/2pi) int_0^{q_cut} dq q^3 C(q)``.

    ``c = C_r q_r^(2+2H)`` is the amplitude of the self-affine power law
    ``C -> c q^(-2-2H)``, so that the limits a fit can reach are allowed besides those of
    :class:`SpectrumModel`: ``q_r = 0`` (no roll-off: the bare power law, no lower cutoff)
    and ``q_s = inf`` (no short-wavelength cutoff).

    Parameters
    ----------
    q_cut : array_like
        Upper limits (1/length, ``2 pi / dr``), ``>= 0`` (``inf`` for the whole moment).
    c, hurst, q_r, q_s, q_0, rolloff
        Amplitude, Hurst exponent, cutoffs (``q_0 = 0``: none) and shape of the model.

    Returns
    -------
    numpy.ndarray
        ``gbar^2`` (dimensionless for ``C`` in length^4) with the shape of ``q_cut``.

    Notes
    -----
    Sharp (eq. 35), with ``q_c = min(q_cut, q_s)``: ``2 pi gbar^2 = C_r (min(q_c, q_r)^4 -
    q_0^4) / 4 + c (q_c^(2-2H) - q_r^(2-2H)) / (2 - 2H)`` (second term for ``q_c > q_r``,
    evaluated as ``c q_r^(2-2H) expm1((2-2H) ln(q_c/q_r)) / (2-2H)``: never below 0).
    Smooth: ``int q^3 [1 + (q/q_r)^2]^-(1+H) dq = (q_r^4 / 2) Phi(u)``, ``u = (q/q_r)^2``,
    with ``Phi(u) = [(1+u)^(1-H) - 1]/(1-H) + [(1+u)^-H - 1]/H`` evaluated as
    ``E((1-H) L)/(1-H) + E(-H L)/H``, ``L = ln(1+u)``, ``E(x) = e^x - 1 - x`` (the linear
    parts cancel exactly).

    Examples
    --------
    >>> g2 = model_gradient2([1.0, 1e3], c=1.0, hurst=0.5, q_r=0.0, q_s=100.0)
    >>> print(g2 * 2 * np.pi)  # c q_c^(2-2H) / (2-2H), q_c = min(q_cut, q_s)
    [  1. 100.]
    """
    H = hurst
    qc = np.minimum(q_cut, q_s)
    e = 2.0 - 2.0 * H
    if q_r == 0.0:  # pure power law c q^(-2-2H) (no lower cutoff)
        return c * qc**e / e / (2 * np.pi)
    if rolloff == "sharp":
        a = np.clip(qc, q_0, q_r)
        b = np.clip(qc, q_r, q_s)
        flat = (a**4 - q_0**4) / (4 * q_r ** (2 + 2 * H))
        # b^e - q_r^e as q_r^e expm1(e ln(b/q_r)): 0 at b = q_r to the last bit (numpy's
        # array and scalar powers can differ by an ulp), no cancellation just above q_r
        power = q_r**e * np.expm1(e * np.log(b / q_r)) / e
        return c * (flat + power) / (2 * np.pi)

    def phi(v):
        L = np.log1p(v)
        return _expm1_minus_linear((1 - H) * L) / (1 - H) + _expm1_minus_linear(-H * L) / H

    u = (np.maximum(qc, q_0) / q_r) ** 2
    return c * q_r**e / 2 * (phi(u) - phi((q_0 / q_r) ** 2)) / (2 * np.pi)
