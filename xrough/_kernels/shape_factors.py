"""Shape factors ``c_sa(H)`` and ``c_ro(H)`` that link G to the scale-dependent gradient.

Pure numpy/scipy, no xarray.  Conventions (docs/theory.md): angular wavenumber ``q``,
isotropic spectrum ``C(q)``, height-difference ACF ``G(dr)`` of eq. 9 and the
scale-dependent mean-square gradient of eq. 26,

    gbar^2(dr) = (1/2pi) int_0^{2pi/dr} dq q^3 C(q).

The two factors are *defined* by the asymptotic relations (xrough's convention for the
paper's eq. 37/38 and 41/42)

* self-affine regime, ``lambda_s << dr << lambda_r``:
  ``gbar^2(dr) = c_sa(H) G(dr) / dr^2``;
* roll-off regime, ``dr >> lambda_r`` (``lambda_r = 2 pi / q_r``):
  ``gbar^2(dr) = c_ro(H) sigma_h^2 lambda_r^2 / dr^4``,

and both are evaluated in closed form for the model spectra of
:mod:`xrough._kernels.spectral_models`.

Self-affine factor
------------------
Deep inside the self-affine range (``q_r dr -> 0`` and ``q_s dr -> inf``) both G and
``gbar^2`` only see the power law ``C = c q^(-2-2H)``, whatever the roll-off shape.  With
``t = q dr``,

    G(dr)      = (c/2pi) dr^(2H) int_0^inf t^(-1-2H) (1 - J0(t)) dt
               = (c/2pi) dr^(2H) 2^(-1-2H) Gamma(1-H) / (H Gamma(1+H)),
    gbar^2(dr) = (c/2pi) int_0^{2pi/dr} q^(1-2H) dq = (c/2pi) (2pi/dr)^(2-2H) / (2-2H),

hence

    c_sa(H) = gbar^2 dr^2 / G = 4 pi^(2-2H) H Gamma(1+H) / Gamma(2-H).

It tends to 4 for ``H -> 1`` (the ballistic relation ``gbar^2 = 4 G/dr^2``) and to 0 for
``H -> 0``.  The leading corrections at finite cutoffs are of relative order
``(q_r dr)^(2-2H)`` and ``(q_s dr)^(-2H)``, so the self-affine regime needs
``q_s/q_r`` of several decades for ``H`` near 0.

Roll-off factor
---------------
For ``dr -> inf`` (with no lower cutoff, ``q_0 = 0``) only the plateau ``C -> C_r``
contributes to eq. 26: ``gbar^2(dr) -> (1/2pi) C_r (2pi/dr)^4 / 4``, exactly for the sharp
shape once ``2pi/dr < q_r`` and to leading order in ``(q_r dr)^-2`` for the smooth one.
With the height variance ``sigma_h^2 = (1/2pi) int dq q C(q) = (C_r q_r^2 / 2pi) m_0``,

    c_ro(H) = lim gbar^2 dr^4 / (sigma_h^2 lambda_r^2) = pi^2 / m_0,

where, with ``x = q_s/q_r``,

* sharp (eq. 35):  ``m_0 = 1/2 + (1 - x^(-2H)) / (2H)``  ->  ``c_ro = 2 pi^2 H / (1 + H)``;
* smooth, ``C = C_r [1 + (q/q_r)^2]^-(1+H)``:  ``m_0 = (1 - (1 + x^2)^(-H)) / (2H)``
  ->  ``c_ro = 2 pi^2 H``

(the arrows give the limit ``x -> inf``).  With a lower cutoff ``q_0 > 0`` the roll-off
regime is the window ``lambda_r << dr << lambda_0`` (eq. 26 vanishes for
``2pi/dr < q_0``), and the factors above hold to relative order ``(q_0/q_r)^2``.
"""

from __future__ import annotations

import numpy as np

from .deferred import special

__all__ = [
    "self_affine_constant",
    "self_affine_factor",
    "rolloff_factor",
    "rolloff_crossover",
]

ROLLOFFS = ("sharp", "smooth")


def _hurst(hurst) -> np.ndarray:
    H = np.asarray(hurst, dtype=float)
    if not np.all((H > 0) & (H < 1)):
        raise ValueError(f"hurst must lie in (0, 1), got {hurst!r}")
    return H


def self_affine_constant(hurst):
    """``int_0^inf t^(-1-2H) (1 - J0(t)) dt = 2^(-1-2H) Gamma(1-H) / (H Gamma(1+H))``.

    The constant of ``G(dr) = (c/2pi) I(H) dr^(2H)`` for a pure power-law spectrum
    ``C = c q^(-2-2H)`` (eq. 9).

    Parameters
    ----------
    hurst : float or array_like
        Hurst exponent(s), ``0 < H < 1``.

    Returns
    -------
    float or numpy.ndarray
        ``I(H)`` (dimensionless), same shape as ``hurst``.

    Raises
    ------
    ValueError
        If any ``H`` is outside (0, 1).

    Examples
    --------
    >>> print(f"{self_affine_constant(0.5):.12f}")
    1.000000000000
    """
    H = _hurst(hurst)
    out = 2.0 ** (-1.0 - 2.0 * H) * special.gamma(1.0 - H) / (H * special.gamma(1.0 + H))
    return out[()] if out.ndim == 0 else out


def self_affine_factor(hurst):
    """Self-affine shape factor ``c_sa(H) = 4 pi^(2-2H) H Gamma(1+H) / Gamma(2-H)``.

    Defined by ``gbar^2(dr) = c_sa(H) G(dr)/dr^2`` deep in the self-affine range
    (``lambda_s << dr << lambda_r``, i.e. in the limit ``q_r dr -> 0``, ``q_s dr -> inf``),
    with ``gbar^2`` from eq. 26 and ``G`` from eq. 9.  It depends only on the power law
    ``C ~ q^(-2-2H)``, so it is the same for the sharp (eq. 35) and smooth roll-off.

    Parameters
    ----------
    hurst : float or array_like
        Hurst exponent(s), ``0 < H < 1``.

    Returns
    -------
    float or numpy.ndarray
        ``c_sa(H)`` (dimensionless), same shape as ``hurst``.

    Raises
    ------
    ValueError
        If any ``H`` is outside (0, 1).

    Notes
    -----
    ``c_sa = (2pi)^(2-2H) / ((2-2H) I(H))`` with ``I(H)`` from
    :func:`self_affine_constant`; ``c_sa -> 4`` for ``H -> 1`` (ballistic limit
    ``gbar^2 = 4 G/dr^2``).

    Examples
    --------
    >>> import numpy as np
    >>> print(f"{self_affine_factor(0.5):.10f} = 2 pi = {2 * np.pi:.10f}")
    6.2831853072 = 2 pi = 6.2831853072
    """
    H = _hurst(hurst)
    out = (4.0 * np.pi ** (2.0 - 2.0 * H) * H * special.gamma(1.0 + H)
           / special.gamma(2.0 - H))
    return out[()] if out.ndim == 0 else out


def _m0(H: np.ndarray, rolloff: str, q_ratio: float) -> np.ndarray:
    """``sigma_h^2 / (C_r q_r^2 / 2pi)`` for the model shapes with ``q_0 = 0``."""
    x = float(q_ratio)
    if rolloff == "sharp":
        tail = 1.0 if np.isinf(x) else -np.expm1(-2.0 * H * np.log(x))
        return 0.5 + tail / (2.0 * H)
    tail = 1.0 if np.isinf(x) else -np.expm1(-H * np.log1p(x * x))
    return tail / (2.0 * H)


def _check(rolloff: str, q_ratio: float) -> None:
    if rolloff not in ROLLOFFS:
        raise ValueError(f"rolloff must be one of {ROLLOFFS}, got {rolloff!r}")
    if not float(q_ratio) > 1.0:
        raise ValueError(f"q_ratio = q_s/q_r must exceed 1, got {q_ratio!r}")


def rolloff_factor(hurst, *, rolloff: str = "sharp", q_ratio: float = np.inf):
    """Roll-off shape factor ``c_ro(H)``: ``gbar^2(dr) -> c_ro sigma_h^2 lambda_r^2 / dr^4``.

    The limit ``dr -> inf`` (``dr >> lambda_r = 2 pi/q_r``) of
    ``gbar^2(dr) dr^4 / (sigma_h^2 lambda_r^2)`` with ``gbar^2`` from eq. 26 and the height
    variance ``sigma_h^2`` of the model spectrum without lower cutoff (``q_0 = 0``).

    Parameters
    ----------
    hurst : float or array_like
        Hurst exponent(s), ``0 < H < 1``.
    rolloff : {'sharp', 'smooth'}
        Eq. 35's flat plateau, or ``C = C_r [1 + (q/q_r)^2]^-(1+H)``.
    q_ratio : float
        ``q_s / q_r`` (enters through ``sigma_h``); default infinite (the limit
        ``lambda_s / lambda_r -> 0``).

    Returns
    -------
    float or numpy.ndarray
        ``c_ro(H)`` (dimensionless), same shape as ``hurst``.

    Raises
    ------
    ValueError
        ``H`` outside (0, 1), an unknown ``rolloff`` or ``q_ratio <= 1``.

    Notes
    -----
    ``c_ro = pi^2 / m_0`` with ``sigma_h^2 = (C_r q_r^2 / 2pi) m_0``;
    ``c_ro = 2 pi^2 H / (1 + H)`` (sharp) and ``2 pi^2 H`` (smooth) for ``q_ratio -> inf``.

    Examples
    --------
    >>> import numpy as np
    >>> print(f"{rolloff_factor(0.5):.10f} = 2 pi^2 / 3 = {2 * np.pi**2 / 3:.10f}")
    6.5797362674 = 2 pi^2 / 3 = 6.5797362674
    >>> print(f"{rolloff_factor(0.5, rolloff='smooth'):.10f}")
    9.8696044011
    """
    H = _hurst(hurst)
    _check(rolloff, q_ratio)
    out = np.asarray(np.pi**2 / _m0(H, rolloff, q_ratio))
    return out[()] if out.ndim == 0 else out


def rolloff_crossover(hurst, *, rolloff: str = "sharp", q_ratio: float = np.inf):
    """``kappa(H) = q_r dr_x``: where the self-affine asymptote of G reaches ``sigma_h^2``.

    For the model spectra (``q_0 = 0``) the self-affine asymptote
    ``G_sa(dr) = (C_r q_r^(2+2H) / 2pi) I(H) dr^(2H)`` (eq. 9, :func:`self_affine_constant`)
    equals the plateau ``sigma_h^2 = (C_r q_r^2 / 2pi) m_0`` at
    ``dr_x = kappa(H) / q_r``, so ``lambda_r = 2 pi dr_x / kappa(H)``.

    Parameters
    ----------
    hurst : float or array_like
        Hurst exponent(s), ``0 < H < 1``.
    rolloff : {'sharp', 'smooth'}
        Shape of the roll-off.
    q_ratio : float
        ``q_s / q_r`` (default infinite).

    Returns
    -------
    float or numpy.ndarray
        ``kappa(H) = [m_0 / I(H)]^(1/(2H))`` (dimensionless).

    Raises
    ------
    ValueError
        ``H`` outside (0, 1), an unknown ``rolloff`` or ``q_ratio <= 1``.

    Examples
    --------
    >>> print(f"{rolloff_crossover(0.5):.10f}")   # (3/2) / 1
    1.5000000000
    """
    H = _hurst(hurst)
    _check(rolloff, q_ratio)
    out = np.asarray((_m0(H, rolloff, q_ratio) / self_affine_constant(H)) ** (0.5 / H))
    return out[()] if out.ndim == 0 else out
