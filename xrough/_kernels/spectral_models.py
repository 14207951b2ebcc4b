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

Two short-wavelength cutoffs: ``"sharp"`` (zero from ``q_s`` on, eq. 35) and ``"gaussian"``
(the spectrum times ``exp(-(q/q_s)^2)`` at every ``q``: an instrument's transfer, a tip,
optics or a stylus that blurs the heights with a Gaussian of standard deviation
``sqrt(2)/q_s``; ``q_s = 2 pi / lambda_s`` as for the sharp cutoff).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .deferred import special
from .shape_factors import ROLLOFFS

__all__ = ["SpectrumModel", "model_gradient2", "shape_code", "shape_names"]

CUTOFFS = ("sharp", "gaussian")


def shape_code(rolloff, cutoff="sharp"):
    """One integer for a model's roll-off and cutoff: ``ROLLOFFS`` index + 2 ``CUTOFFS`` index.

    Each of ``rolloff``, ``cutoff`` is a name or its index (a number or an array of them,
    e.g. the variables ``rolloff_shape`` and ``cutoff_shape`` of a fit).
    """
    r = ROLLOFFS.index(rolloff) if isinstance(rolloff, str) else rolloff
    c = CUTOFFS.index(cutoff) if isinstance(cutoff, str) else cutoff
    return r + len(ROLLOFFS) * c


def shape_names(code) -> tuple[str, str]:
    """``(rolloff, cutoff)`` of a :func:`shape_code`."""
    cutoff, rolloff = divmod(int(code), len(ROLLOFFS))
    return ROLLOFFS[rolloff], CUTOFFS[cutoff]


#: A Gaussian cutoff's support ends at this multiple of ``q_s``: ``exp(-42)``, 6e-19.
GAUSSIAN_END = 6.5


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
    cutoff : {'sharp', 'gaussian'}
        Zero from ``q_s`` on, or the spectrum times ``exp(-(q/q_s)^2)`` (module docstring).
    """

    hurst: float
    q_r: float
    q_s: float
    q_0: float = 0.0
    C_r: float = 1.0
    rolloff: str = "sharp"
    cutoff: str = "sharp"

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
        if self.cutoff not in CUTOFFS:
            raise ValueError(f"cutoff must be one of {CUTOFFS}, got {self.cutoff!r}")
        if not (self.C_r > 0 and np.isfinite(self.C_r)):
            raise ValueError(f"C_r must be positive and finite, got {self.C_r}")

    # -- evaluation -------------------------------------------------------------------
    def shape(self, q: np.ndarray) -> np.ndarray:
        """C(q)/C_r, vectorised; zero below ``q_0`` and beyond the cutoff's end."""
        q = np.asarray(q, dtype=float)
        e = -2.0 * (1.0 + self.hurst)
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            if self.rolloff == "sharp":
                val = np.where(q < self.q_r, 1.0, (q / self.q_r) ** e)
            else:
                val = (1.0 + (q / self.q_r) ** 2) ** (-(1.0 + self.hurst))
        if self.cutoff == "gaussian":
            val = val * np.exp(-((q / self.q_s) ** 2))
        inside = (q >= self.q_0) & (q < self.q_end)
        return np.where(inside, val, 0.0)

    @property
    def q_end(self) -> float:
        """Where the spectrum ends: ``q_s`` (sharp cutoff), ``GAUSSIAN_END q_s`` (Gaussian)."""
        return self.q_s * (GAUSSIAN_END if self.cutoff == "gaussian" else 1.0)

    def __call__(self, q: np.ndarray) -> np.ndarray:
        """C(q) in length^4."""
        return self.C_r * self.shape(q)

    @property
    def piecewise_power_law(self) -> bool:
        """Whether C is an exact power law between its :attr:`breakpoints` (eq. 35)."""
        return self.rolloff == self.cutoff == "sharp"

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Wavenumbers where C or its slope jumps (integration must split there)."""
        mid = [self.q_r, self.q_s] if self.cutoff == "gaussian" else [self.q_r]
        return (self.q_0, *mid, self.q_end)

    # -- moments ----------------------------------------------------------------------
    def moment(self, k: int) -> float:
        """``(1/2pi) int dq q^(1+k) C(q)``: k=0 gives sigma_h^2, k=2 the mean-square gradient.

        Closed form for eq. 35; Gauss-Legendre in ``ln q`` for the others
        (:func:`_cumulative_moment`: relative error below 1e-13).
        """
        return self.C_r * self.shape_moment(k)

    def shape_moment(self, k: int) -> float:
        """``moment(k) / C_r``."""
        H, q0, qr, qs = self.hurst, self.q_0, self.q_r, self.q_s
        if self.piecewise_power_law:
            flat = (qr ** (2 + k) - q0 ** (2 + k)) / (2 + k)
            p = k - 2 * H
            if abs(p) < 1e-12:
                tail = qr ** (2 + 2 * H) * np.log(qs / qr)
            else:
                tail = qr ** (2 + 2 * H) * (qs**p - qr**p) / p
            return float((flat + tail) / (2 * np.pi))
        # Gauss-Legendre in ln q, as eq. 26 to any q (model_gradient2)
        return float(_cumulative_moment(np.inf, self, k)) / (2 * np.pi * self.C_r)


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
                    q_0: float = 0.0, rolloff: str = "sharp",
                    cutoff: str = "sharp") -> np.ndarray:
    """Eq. 26 of the model spectrum in closed form: ``(1/2pi) int_0^{q_cut} dq q^3 C(q)``.

    ``c = C_r q_r^(2+2H)`` is the amplitude of the self-affine power law
    ``C -> c q^(-2-2H)``, so that the limits a fit can reach are allowed besides those of
    :class:`SpectrumModel`: ``q_r = 0`` (no roll-off: the bare power law, no lower cutoff)
    and ``q_s = inf`` (no short-wavelength cutoff).

    Parameters
    ----------
    q_cut : array_like
        Upper limits (1/length, ``2 pi / dr``), ``>= 0`` (``inf`` for the whole moment).
    c, hurst, q_r, q_s, q_0, rolloff, cutoff
        Amplitude, Hurst exponent, cutoffs (``q_0 = 0``: none) and shapes of the model.

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
    parts cancel exactly).  Gaussian cutoff: the bare power law in closed form,
    ``c q_s^(2-2H) gamma(1-H, (q_cut/q_s)^2) / 2`` (the lower incomplete gamma function);
    with a roll-off, Gauss-Legendre in ``ln q`` (16 points on panels of 1/8 decade, split
    at ``q_r``: relative error below 1e-13).

    Examples
    --------
    >>> g2 = model_gradient2([1.0, 1e3], c=1.0, hurst=0.5, q_r=0.0, q_s=100.0)
    >>> print(g2 * 2 * np.pi)  # c q_c^(2-2H) / (2-2H), q_c = min(q_cut, q_s)
    [  1. 100.]
    """
    H = hurst
    e = 2.0 - 2.0 * H
    if cutoff == "gaussian" and np.isfinite(q_s):
        q_cut = np.asarray(q_cut, dtype=float)
        if q_r == 0.0:
            z = (q_cut / q_s) ** 2
            return (c * q_s**e / 2 * special.gamma(1 - H) * special.gammainc(1 - H, z)
                    / (2 * np.pi))
        model = SpectrumModel(hurst=H, q_r=q_r, q_s=q_s, q_0=q_0, rolloff=rolloff,
                              cutoff=cutoff, C_r=c / q_r ** (2 + 2 * H))
        return _cumulative_moment(q_cut, model, 2) / (2 * np.pi)
    qc = np.minimum(q_cut, q_s)
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


#: :func:`_cumulative_moment`: Gauss-Legendre order and panels per decade of ``q``, and how
#: far below ``q_r`` a model without ``q_0`` starts (its flat part adds ``q^(2+k)``).
_CUMULATIVE_ORDER, _CUMULATIVE_PANELS, _CUMULATIVE_DEPTH = 16, 8.0, 8.0


def _cumulative_moment(q_cut, model: SpectrumModel, k: int) -> np.ndarray:
    """``int_0^{q_cut} dq q^(1+k) C(q)`` at every ``q_cut`` (Gauss-Legendre in ``ln q``).

    Panels of 1/:data:`_CUMULATIVE_PANELS` decade with an edge at every breakpoint; whole
    panels below ``q_cut`` are summed, the panel it cuts integrated to it.
    """
    q_cut = np.asarray(q_cut, dtype=float)
    x, w = np.polynomial.legendre.leggauss(_CUMULATIVE_ORDER)
    lo = model.q_0 if model.q_0 > 0 else model.q_r * 10.0**-_CUMULATIVE_DEPTH
    hi = model.q_end
    inner = [b for b in model.breakpoints if lo < b < hi]
    n = int(np.ceil(np.log10(hi / lo) * _CUMULATIVE_PANELS))
    edges = np.unique(np.concatenate([np.geomspace(lo, hi, n + 1), inner]))
    ln_e = np.log(edges)

    def panels(a, b):  # int over [e^a, e^b] of q^(2+k) C(q) d(ln q), rowwise
        half, mid = 0.5 * (b - a), 0.5 * (b + a)
        q = np.exp(mid[:, None] + half[:, None] * x)
        return (q ** (2 + k) * model(q)) @ w * half

    below = np.concatenate([[0.0], np.cumsum(panels(ln_e[:-1], ln_e[1:]))])
    flat = np.clip(q_cut.ravel(), lo, hi)
    j = np.clip(np.searchsorted(edges, flat, side="right") - 1, 0, edges.size - 2)
    out = below[j] + panels(ln_e[j], np.log(flat))
    return out.reshape(q_cut.shape)
