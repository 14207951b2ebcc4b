"""Parameters of the self-affine model spectrum (eq. 35) with units.

One place turns user parameters (wavelengths as numbers in ``unit``, strings or pint
Quantities; one of ``C_r``, ``rms_height``, ``rms_gradient``) into a
:class:`~xrough._kernels.spectral_models.SpectrumModel` in a chosen length unit, and
back and forth between a model and netCDF-legal attributes.
"""

from __future__ import annotations

import numpy as np

from . import units as u
from ._kernels.spectral_models import SpectrumModel
from .units import QuantityLike

__all__ = ["self_affine_model", "model_attrs", "model_from_attrs", "MODEL_ATTR_POWERS"]

#: Powers ``(lateral, height)`` of the length units in each dimensional attribute of
#: :func:`model_attrs`: what a change of units rescales (``C_r`` is a height^2 times an
#: area; the rms gradient is a slope, the same in every unit).
MODEL_ATTR_POWERS = {"q_r": (-1, 0), "q_s": (-1, 0), "q_0": (-1, 0), "C_r": (2, 2),
                     "rms_height": (0, 1)}


def self_affine_model(
    *,
    hurst: float,
    lambda_r: QuantityLike,
    lambda_s: QuantityLike,
    lambda_0: QuantityLike | None = None,
    C_r: QuantityLike | None = None,
    rms_height: QuantityLike | None = None,
    rms_gradient: QuantityLike | None = None,
    rolloff: str = "sharp",
    unit: str = "m",
    cutoff: str = "sharp",
) -> SpectrumModel:
    """Build the model spectrum of eq. 35 in ``unit`` from physical parameters.

    Amplitudes given as rms height or gradient are converted with the model's moments
    ``sigma_h^2 = (1/2pi) int q C dq`` and ``gbar^2 = (1/2pi) int q^3 C dq`` (eq. 26 at
    ``dr -> 0``).

    Parameters
    ----------
    hurst : float
        Hurst exponent, 0 < H < 1.
    lambda_r, lambda_s : float, str or Quantity
        Roll-off and short-cutoff wavelengths (``q = 2 pi / lambda``); numbers in ``unit``.
    lambda_0 : float, str or Quantity, optional
        Long-wavelength cutoff (system size); None for none.
    C_r, rms_height, rms_gradient : optional
        Exactly one: plateau value (length^4; numbers in ``unit``^4), rms height (length;
        numbers in ``unit``) or rms gradient.
    rolloff : {'sharp', 'smooth'}
    unit : str
        Length unit of the model's wavenumbers and ``C_r``.
    cutoff : {'sharp', 'gaussian'}
        Eq. 35's sharp end at ``q_s``, or the spectrum times ``exp(-(q/q_s)^2)`` (an
        instrument's Gaussian transfer).

    Returns
    -------
    SpectrumModel

    Raises
    ------
    ValueError
        Not exactly one amplitude, non-positive or wrongly dimensioned parameters,
        ``lambda_s >= lambda_r``, H outside (0, 1).

    Examples
    --------
    >>> m = self_affine_model(hurst=0.5, lambda_r="1 um", lambda_s="10 nm",
    ...                       rms_height="2 nm", unit="nm")
    >>> round(float(m.moment(0)) ** 0.5, 6)
    2.0
    """
    given = {k: v for k, v in (("C_r", C_r), ("rms_height", rms_height),
                               ("rms_gradient", rms_gradient)) if v is not None}
    if len(given) != 1:
        raise ValueError("give exactly one of C_r, rms_height, rms_gradient to set the "
                         f"amplitude (got {sorted(given) or 'none'})")
    if not isinstance(hurst, (int, float, np.integer, np.floating)):
        raise TypeError(f"hurst must be a number, got {type(hurst).__name__}")
    u.as_length_unit(unit, what="unit")
    q_r = 2 * np.pi / u.length_in(lambda_r, unit, what="lambda_r")
    q_s = 2 * np.pi / u.length_in(lambda_s, unit, what="lambda_s")
    q_0 = 0.0 if lambda_0 is None else 2 * np.pi / u.length_in(lambda_0, unit, what="lambda_0")
    if q_s <= q_r:
        raise ValueError("lambda_s must be shorter than lambda_r")
    if q_0 > q_r:
        raise ValueError("lambda_0 (system size) must be at least lambda_r")
    shape = SpectrumModel(hurst=float(hurst), q_r=q_r, q_s=q_s, q_0=q_0, C_r=1.0,
                          rolloff=rolloff, cutoff=cutoff)
    (name, value), = given.items()
    if name == "C_r":
        q = u.quantity(value, default_units=u.parse_units(unit) ** 4, what="C_r")
        if not q.check("[length] ** 4"):
            raise ValueError(f"C_r must have units of length^4, got {value!r}")
        amplitude = float(q.to(u.parse_units(unit) ** 4).magnitude)
    elif name == "rms_height":
        amplitude = u.length_in(value, unit, what="rms_height")
    else:
        q = u.quantity(value, default_units="", what="rms_gradient")
        if not q.dimensionless:
            raise ValueError(f"rms_gradient must be dimensionless, got {value!r}")
        amplitude = float(q.to("").magnitude)
    if not (np.isfinite(amplitude) and amplitude > 0):
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    if name != "C_r":  # the range where the square of an rms (C_r) fits in a float
        u.positive_si(f"{amplitude!r} {unit}" if name == "rms_height" else amplitude,
                      "[length]" if name == "rms_height" else "[]", what=name)
    try:
        with np.errstate(over="ignore", under="ignore"):
            c_r = {"C_r": amplitude,
                   "rms_height": np.square(amplitude) / shape.shape_moment(0),
                   "rms_gradient": np.square(amplitude) / shape.shape_moment(2)}[name]
            model = SpectrumModel(hurst=float(hurst), q_r=q_r, q_s=q_s, q_0=q_0,
                                  C_r=float(c_r), rolloff=rolloff, cutoff=cutoff)
            moments = (model.C_r, model.moment(0), model.moment(2))
    except OverflowError as err:
        raise ValueError(
            f"the moments of this spectrum overflow float64: lambda_r = {lambda_r!r}, "
            f"lambda_s = {lambda_s!r}, lambda_0 = {lambda_0!r} span "
            f"{np.log10(q_s / max(q_r, q_0)):.3g} decades of wavenumber with H = {hurst}; "
            "give lengths within about 100 decades of each other") from err
    if not all(np.isfinite(m) and m >= np.finfo(float).tiny for m in moments):
        raise ValueError(
            f"{name} = {value!r} gives C_r = {moments[0]:g} {unit}^4, rms height^2 = "
            f"{moments[1]:g} {unit}^2 and rms gradient^2 = {moments[2]:g}: not all "
            f"within float64 (1e-308 to 1e308); choose {name} or the unit so that they are")
    return model


def model_attrs(model: SpectrumModel) -> dict:
    """NetCDF-legal attributes that describe ``model`` (in its own length unit)."""
    return {
        "model": "self-affine",
        "rolloff": model.rolloff,
        "cutoff": model.cutoff,
        "hurst": float(model.hurst),
        "q_r": float(model.q_r),
        "q_s": float(model.q_s),
        "q_0": float(model.q_0),
        "C_r": float(model.C_r),
        "rms_height": float(np.sqrt(model.moment(0))),
        "rms_gradient": float(np.sqrt(model.moment(2))),
    }


def model_from_attrs(attrs: dict) -> SpectrumModel | None:
    """Rebuild a :class:`SpectrumModel` from :func:`model_attrs` output (None if absent)."""
    if attrs.get("model") != "self-affine":
        return None
    return SpectrumModel(hurst=float(attrs["hurst"]), q_r=float(attrs["q_r"]),
                         q_s=float(attrs["q_s"]), q_0=float(attrs["q_0"]),
                         C_r=float(attrs["C_r"]), rolloff=str(attrs["rolloff"]),
                         cutoff=str(attrs.get("cutoff", "sharp")))
