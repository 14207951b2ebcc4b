"""Spectra and the height-difference ACF: model spectra and eq. 9.

Conventions (docs/theory.md): ``q`` is the angular wavenumber (``2 pi / wavelength``, never
cycles); ``C(q) = A <|h~(q)|^2>`` is the isotropic 2D height spectrum (units length^4);
``G(dr) = 1/2 <(h(r) - h(r + dr))^2>`` is the height-difference autocorrelation function
(length^2), with ``G(inf) = sigma_h^2``.

Every output carries ``units`` on its data and its dimension coordinate, computed here (never
through ``keep_attrs``), and only netCDF-legal attributes (str, float, int).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pint
import xarray as xr

from . import units as _units
from ._kernels.hankel import PowerLawInterpolant, acf_from_spectrum_kernel
from ._kernels.spectral_models import SpectrumModel
from .models import model_attrs, model_from_attrs, self_affine_model

__all__ = ["model_spectrum", "acf_from_spectrum"]

_EQUATIONS = {
    "sharp": "eq. 35",
    "smooth": "C_r [1 + (q/q_r)^2]^-(1+H) for q_0 <= q <= q_s (smooth variant of eq. 35)",
}


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------
def _spectrum_model(attrs: dict, c_factor: float) -> SpectrumModel | None:
    """Rebuild the model described by ``attrs`` (None if absent), ``C_r`` times ``c_factor``."""
    try:
        model = model_from_attrs(attrs)
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(f"the spectrum's model attributes are incomplete or invalid ({err!r}); "
                         "drop attrs['model'] to treat the samples as a piecewise power "
                         "law") from None
    if model is None:
        return None
    return dataclasses.replace(model, C_r=model.C_r * c_factor)


def _sample_model(model: SpectrumModel, q: np.ndarray) -> np.ndarray:
    """``C(q)`` on the closed interval ``[q_0, q_s]`` (the left limit at ``q = q_s``)."""
    closed = dataclasses.replace(model, q_s=2.0 * model.q_s)
    return np.where(q == model.q_s, closed(q), model(q))


def _log_grid(knots: list[float], points_per_decade: float) -> np.ndarray:
    """Logarithmic grid through every knot exactly."""
    knots = sorted(set(knots))
    parts = [np.array(knots[:1])]
    for a, b in zip(knots[:-1], knots[1:], strict=True):
        n = max(1, int(np.ceil(points_per_decade * np.log10(b / a))))
        seg = np.geomspace(a, b, n + 1)
        seg[-1] = b
        parts.append(seg[1:])
    return np.concatenate(parts)


# --------------------------------------------------------------------------------------
# public functions
# --------------------------------------------------------------------------------------
def model_spectrum(
    q: Any = None,
    *,
    hurst: float,
    lambda_r: Any,
    lambda_s: Any,
    lambda_0: Any = None,
    C_r: Any = None,
    rms_height: Any = None,
    rms_gradient: Any = None,
    rolloff: str = "sharp",
    unit: str = "m",
    points_per_decade: float = 50,
) -> xr.DataArray:
    """Isotropic spectrum of a self-affine surface with roll-off (paper eq. 35).

    ``rolloff="sharp"`` (eq. 35)::

        C(q) = C_r                           for q_0 <= q < q_r
        C(q) = C_r (q/q_r)^(-2(1+H))         for q_r <= q <= q_s
        C(q) = 0                             otherwise

    ``rolloff="smooth"``: ``C(q) = C_r [1 + (q/q_r)^2]^-(1+H)`` for ``q_0 <= q <= q_s``.
    Here ``q_r = 2 pi / lambda_r``, ``q_s = 2 pi / lambda_s`` and ``q_0 = 2 pi / lambda_0``.

    Parameters
    ----------
    q : array_like or pint.Quantity, optional
        Wavenumbers (angular, in ``1/unit`` when plain numbers), ``>= 0``.  Default: a
        logarithmic grid with ``points_per_decade`` from ``min(q_0, q_r/10)`` (``q_r/100``
        without ``lambda_0``) up to ``q_s`` that contains ``q_0``, ``q_r`` and ``q_s`` exactly.
    hurst : float
        Hurst exponent ``H``, ``0 < H < 1``.
    lambda_r, lambda_s : float, str or pint.Quantity
        Roll-off and short-wavelength cutoff wavelengths (length; plain numbers in ``unit``),
        ``lambda_s < lambda_r``.
    lambda_0 : float, str or pint.Quantity, optional
        Longest wavelength (system size), ``lambda_0 >= lambda_r``; None for no lower cutoff.
    C_r, rms_height, rms_gradient : float, str or pint.Quantity
        Exactly one sets the amplitude: the plateau ``C_r`` (length^4, plain numbers in ``unit``^4),
        the rms height ``sigma_h`` (length) or the rms gradient ``gbar`` (dimensionless), with
        ``sigma_h^2 = (1/2pi) int dq q C`` and ``gbar^2 = (1/2pi) int dq q^3 C``.
    rolloff : {'sharp', 'smooth'}
        Shape of the roll-off.
    unit : str
        Length unit of the output (``"m"``, ``"um"``, ``"nm"``...).
    points_per_decade : float
        Density of the default ``q`` grid.

    Returns
    -------
    xarray.DataArray
        ``C`` on dim ``"q"`` (``units`` ``"<unit>-1"``, long_name "angular wavenumber"), data in
        ``"<unit>4"``.  The attributes describe the model completely (so that
        :func:`acf_from_spectrum` can evaluate it exactly), in the DataArray's own units:
        ``model``, ``rolloff``, ``hurst``, ``q_r``, ``q_s``, ``q_0`` (0.0 when there is no lower
        cutoff), ``C_r``, ``rms_height``, ``rms_gradient``, ``equation``, ``spectrum_kind``.

    Raises
    ------
    ValueError
        For ``H`` outside (0, 1), a non-positive or non-length wavelength, ``lambda_s >=
        lambda_r``, ``lambda_0 < lambda_r``, not exactly one amplitude, an unknown ``rolloff``
        or invalid ``q``.

    See Also
    --------
    acf_from_spectrum : ``G(dr)`` of this spectrum (eq. 9).

    Examples
    --------
    >>> from xrough.spectra import model_spectrum
    >>> C = model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
    ...                    rms_height="2 nm", unit="nm")
    >>> C.attrs["units"], C["q"].attrs["units"]
    ('nm4', 'nm-1')
    >>> print(f"q_r = {C.attrs['q_r']:.6f} nm-1, sigma_h = {C.attrs['rms_height']:.6f} nm")
    q_r = 0.006283 nm-1, sigma_h = 2.000000 nm
    >>> print(f"C(q_r) = C_r: {float(C.sel(q=C.attrs['q_r'])) == C.attrs['C_r']}")
    C(q_r) = C_r: True
    """
    length_unit = _units.as_length_unit(unit, what="unit")
    unit_str = _units.format_units(length_unit)
    if rolloff not in _EQUATIONS:
        raise ValueError(f"rolloff must be one of {tuple(_EQUATIONS)}, got {rolloff!r}")
    model = self_affine_model(hurst=hurst, lambda_r=lambda_r, lambda_s=lambda_s,
                              lambda_0=lambda_0, C_r=C_r, rms_height=rms_height,
                              rms_gradient=rms_gradient, rolloff=rolloff, unit=unit_str)
    q_0, q_r, q_s = model.q_0, model.q_r, model.q_s

    if q is None:
        if not (np.isfinite(points_per_decade) and points_per_decade > 0):
            raise ValueError(f"points_per_decade must be positive, got {points_per_decade!r}")
        q_min = min(q_0, q_r / 10.0) if q_0 > 0 else q_r / 100.0
        q_arr = _log_grid([q_min, q_0 if q_0 > 0 else q_min, q_r, q_s], points_per_decade)
    else:
        if isinstance(q, pint.Quantity):
            q = _units.quantity(q, what="q").to(length_unit**-1).magnitude
        q_arr = np.atleast_1d(np.asarray(q, dtype=float))
        if q_arr.ndim != 1 or not np.all(np.isfinite(q_arr)) or np.any(q_arr < 0):
            raise ValueError("q must be a 1-D array of finite wavenumbers >= 0 "
                             f"(in {unit_str}-1)")
    values = _sample_model(model, q_arr)

    q_unit = _units.power_units(unit_str, -1)
    attrs = {
        "units": _units.power_units(unit_str, 4),
        "long_name": "isotropic height spectrum",
        **model_attrs(model),
        "equation": _EQUATIONS[rolloff],
        "spectrum_kind": "isotropic 2D",
    }
    return xr.DataArray(
        values,
        dims=("q",),
        coords={"q": ("q", q_arr, {"units": q_unit, "long_name": "angular wavenumber"})},
        name="C",
        attrs=attrs,
    )


def _lag_values(dr: Any, length_unit: pint.Unit) -> np.ndarray:
    if isinstance(dr, xr.DataArray):
        u = dr.attrs.get("units")
        factor = 1.0 if u is None else _units.conversion_factor(
            _units.as_length_unit(u, what="dr"), length_unit)
        values = np.asarray(dr.values, dtype=float) * factor
    elif isinstance(dr, pint.Quantity):
        qty = _units.quantity(dr, what="dr")
        if not qty.check("[length]"):
            raise ValueError(f"dr must be a length, got {dr!r}")
        values = np.asarray(qty.to(length_unit).magnitude, dtype=float)
    else:
        values = np.asarray(dr, dtype=float)
    values = np.atleast_1d(values)
    if values.ndim != 1 or not np.all(np.isfinite(values)) or np.any(values < 0):
        raise ValueError("dr must be a 1-D array of finite distances >= 0")
    return values


def acf_from_spectrum(
    spectrum: xr.DataArray,
    dr: Any = None,
    *,
    points_per_decade: float = 20,
    dr_min: Any = None,
    dr_max: Any = None,
) -> xr.DataArray:
    r"""Height-difference ACF from an isotropic spectrum (paper eq. 9).

    .. math::

        G(\Delta r) = \frac{1}{2\pi} \int_0^\infty dq\, q\, C(q)
                       \left[1 - J_0(q \Delta r)\right]

    the stable form of eq. 8 (no cancellation at small ``dr``).  If ``spectrum`` carries the
    attributes written by :func:`model_spectrum`, the exact model is evaluated (its samples
    are only checked against it).  Otherwise the samples are a piecewise power law
    (log-log interpolation; zero outside the sampled range and on intervals that touch a
    zero sample), which is integrated exactly.

    The integral is evaluated to about 1e-9 relative accuracy at every ``dr`` (Gauss-Legendre
    below ``q dr = 64``, closed-form asymptotic integration of the Bessel part above).

    Parameters
    ----------
    spectrum : xarray.DataArray with one dim (``"q"``)
        ``C(q)`` in length^4 with an angular-wavenumber coordinate in 1/length (``units``
        attributes required on both).  Without model attributes the coordinate must be
        positive and strictly increasing, and the values finite and ``>= 0``.
    dr : array_like, pint.Quantity or xarray.DataArray, optional
        Lag distances ``>= 0``; plain numbers are in the length unit of the spectrum's ``q``
        coordinate (e.g. nm for ``"nm-1"``).  Default: logarithmic from
        ``0.01 * 2 pi / q_max`` to ``100 * 2 pi / q_min`` (positive ``q`` of the coordinate).
    points_per_decade : float
        Density of the default ``dr`` grid.
    dr_min, dr_max : float, str or pint.Quantity, optional
        Override the range of the default grid (plain numbers in the spectrum's length unit).

    Returns
    -------
    xarray.DataArray
        ``G`` on dim ``"dr"`` (``units`` the spectrum's length unit, long_name "lag
        distance"), data in length^2, attrs ``equation="eq. 9"``, ``estimator="spectrum"``
        and, for a model spectrum, the model attributes (in the output's units).

    Raises
    ------
    ValueError
        Missing or wrong units, a coordinate that is not an inverse length, spectrum values
        that are not length^4, non-increasing or non-positive ``q``, negative or non-finite
        ``C``, model attributes that contradict the values, or a bad ``dr``.

    See Also
    --------
    model_spectrum : the idealised spectrum of eq. 35.

    Examples
    --------
    >>> from xrough.spectra import acf_from_spectrum, model_spectrum
    >>> C = model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
    ...                    rms_height="2 nm", unit="nm")
    >>> G = acf_from_spectrum(C, [0.01, 1e6])
    >>> G.attrs["units"], G["dr"].attrs["units"]
    ('nm2', 'nm')

    At small ``dr``, ``G = gbar^2 dr^2 / 4``; at large ``dr``, ``G -> sigma_h^2``:

    >>> gbar2 = C.attrs["rms_gradient"] ** 2
    >>> print(f"{float(G[0]) / (gbar2 * 0.01**2 / 4):.6f}")
    1.000000
    >>> print(f"{float(G[1]):.6f} nm2")
    4.000000 nm2
    """
    if not isinstance(spectrum, xr.DataArray):
        raise TypeError(f"spectrum must be an xarray.DataArray, got {type(spectrum).__name__}")
    if spectrum.ndim != 1:
        raise ValueError(f"spectrum must be 1-D (an isotropic C(q) on dim 'q'), got dims "
                         f"{spectrum.dims}")
    dim = spectrum.dims[0]
    if dim not in spectrum.coords:
        raise ValueError(f"spectrum needs a wavenumber coordinate on its dim {dim!r}")
    q_unit = _units.units_of(spectrum[dim], what=f"coordinate {dim!r} of the spectrum")
    if q_unit.dimensionality != (1 / _units.ureg.meter).dimensionality:
        raise ValueError(f"coordinate {dim!r} must be an angular wavenumber in 1/length (e.g. "
                         f"'nm-1'), but its units are {_units.format_units(q_unit)!r}")
    length_unit = q_unit**-1
    unit_str = _units.format_units(length_unit)
    c_unit = _units.units_of(spectrum, what="spectrum")
    if c_unit.dimensionality != (_units.ureg.meter**4).dimensionality:
        raise ValueError(f"spectrum values must be in length^4 (e.g. "
                         f"{_units.power_units(unit_str, 4)!r}), but their units are "
                         f"{_units.format_units(c_unit)!r}")
    c_factor = _units.conversion_factor(c_unit, length_unit**4)
    q = np.asarray(spectrum[dim].values, dtype=float)
    values = np.asarray(spectrum.values, dtype=float) * c_factor

    model = _spectrum_model(spectrum.attrs, c_factor)
    if model is not None:
        expected = _sample_model(model, q)
        if not np.allclose(values, expected, rtol=1e-6, atol=0.0):
            raise ValueError(
                "the spectrum's attributes describe a self-affine model (attrs['model']) that "
                "does not match its values (were the data modified?); drop attrs['model'] to "
                "treat the samples as a piecewise power law"
            )
        func, bp = model, model.breakpoints
        knots = 0.0 if model.rolloff == "sharp" else 160.0
    else:
        if q.size < 2 or not (np.all(np.isfinite(q)) and q[0] > 0 and np.all(np.diff(q) > 0)):
            raise ValueError(f"coordinate {dim!r} must hold at least two positive, finite, "
                             "strictly increasing wavenumbers")
        if not (np.all(np.isfinite(values)) and np.all(values >= 0)):
            raise ValueError("spectrum values must be finite and >= 0 (no NaN)")
        func = PowerLawInterpolant(q, values)
        bp, knots = func.breakpoints, 0.0

    if dr is None:
        q_pos = q[np.isfinite(q) & (q > 0)]
        if q_pos.size == 0:
            raise ValueError(f"coordinate {dim!r} has no positive wavenumber; pass dr")
        lo = (_units.length_in(dr_min, length_unit, what="dr_min") if dr_min is not None
              else 0.01 * 2 * np.pi / q_pos.max())
        hi = (_units.length_in(dr_max, length_unit, what="dr_max") if dr_max is not None
              else 100.0 * 2 * np.pi / q_pos.min())
        if not hi > lo:
            raise ValueError(f"dr_max must exceed dr_min (got {hi:g} and {lo:g} {unit_str})")
        if not (np.isfinite(points_per_decade) and points_per_decade > 0):
            raise ValueError(f"points_per_decade must be positive, got {points_per_decade!r}")
        n = max(2, int(np.ceil(points_per_decade * np.log10(hi / lo))) + 1)
        dr_arr = np.geomspace(lo, hi, n)
    else:
        dr_arr = _lag_values(dr, length_unit)

    G = acf_from_spectrum_kernel(dr_arr, func, bp, knots_per_decade=knots)

    attrs: dict[str, Any] = {
        "units": _units.power_units(unit_str, 2),
        "long_name": "height-difference autocorrelation function",
        "equation": "eq. 9",
        "estimator": "spectrum",
    }
    if model is not None:
        attrs.update(model_attrs(model))
    return xr.DataArray(
        G,
        dims=("dr",),
        coords={"dr": ("dr", dr_arr, {"units": unit_str, "long_name": "lag distance"})},
        name="G",
        attrs=attrs,
    )
