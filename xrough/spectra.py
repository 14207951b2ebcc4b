"""Spectra and G: model spectra, G of a spectrum (eq. 9) and the spectrum of a G (eq. 10/11).

Conventions (docs/theory.md): ``q`` is the angular wavenumber (``2 pi / wavelength``, never
cycles); ``C(q) = A <|h~(q)|^2>`` is the isotropic 2D height spectrum (units length^4);
``G(dr) = 1/2 <(h(r) - h(r + dr))^2>`` is the height-difference autocorrelation function
(length^2), with ``G(inf) = sigma_h^2``.

Every output carries ``units`` on its data and its dimension coordinate, computed here (never
through ``keep_attrs``), and only netCDF-legal attributes (str, float, int).

The rms gradient of a spectrum or of a G by eq. 26 is in :mod:`xrough.gradient`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Hashable
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from . import quality
from . import units as _units
from ._kernels.binning import check_points_per_decade, decade_aligned_grid, log_range
from ._kernels.checks import require_increasing
from ._kernels.hankel import PowerLawInterpolant, acf_from_spectrum_kernel
from ._kernels.spectral_models import SpectrumModel
from ._kernels.spectrum_of_acf import (
    acf_plateau_kernel,
    smooth_acf_kernel,
    spectrum_error_kernel,
    spectrum_from_acf_kernel,
    spectrum_support_kernel,
    support_grid,
)
from ._kernels.uncertainty import covariance_from_acf
from .acf import height_variance, mark_gaps, read_acf, result_attrs
from .memo import by_content
from .models import model_attrs, model_from_attrs, self_affine_model
from .units import QuantityLike

if TYPE_CHECKING:
    from pint.facets.plain import PlainUnit

__all__ = [
    "model_spectrum",
    "acf_from_spectrum",
    "spectrum",
]

_GAUSSIAN = ", times exp(-(q/q_s)^2) with no sharp end (Gaussian cutoff)"
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
    if model.cutoff != "sharp":
        return model(q)
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
    q: QuantityLike | None = None,
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
    points_per_decade: float = 50,
    cutoff: str = "sharp",
) -> xr.DataArray:
    """Isotropic spectrum of a self-affine surface with roll-off (paper eq. 35).

    ``rolloff="sharp"`` (eq. 35): ``C = C_r`` for ``q_0 <= q < q_r``, ``C_r (q/q_r)^(-2(1+H))``
    for ``q_r <= q <= q_s``, 0 otherwise; ``"smooth"``: ``C_r [1 + (q/q_r)^2]^-(1+H)`` on ``[q_0,
    q_s]``; ``q_x = 2 pi / lambda_x``.  ``cutoff="gaussian"``: no sharp end at ``q_s``, the
    spectrum times ``exp(-(q/q_s)^2)`` (an instrument's Gaussian transfer: tip, optics, stylus).

    Parameters
    ----------
    q : array_like or pint.Quantity, optional
        Angular wavenumbers ``>= 0`` (plain numbers in ``1/unit``).  Default: a log grid from
        ``min(q_0, q_r/10)`` (``q_r/100`` without ``lambda_0``) to ``q_s``, through each ``q_x``.
    hurst : float
        Hurst exponent, ``0 < H < 1``.
    lambda_r, lambda_s : float, str or pint.Quantity
        Roll-off and cutoff wavelengths (plain numbers in ``unit``), ``lambda_s < lambda_r``.
    lambda_0 : float, str or pint.Quantity, optional
        Longest wavelength (system size), ``lambda_0 >= lambda_r``; None for no lower cutoff.
    C_r, rms_height, rms_gradient : float, str or pint.Quantity
        Exactly one sets the amplitude: the plateau ``C_r`` (length^4, plain numbers in
        ``unit``^4), the rms height ``sigma_h`` (length, ``sigma_h^2 = (1/2pi) int dq q C``) or
        the rms gradient ``gbar`` (dimensionless, ``gbar^2 = (1/2pi) int dq q^3 C``).
    rolloff : {'sharp', 'smooth'}
        Shape of the roll-off.
    unit : str
        Length unit of the output (``"m"``, ``"um"``, ``"nm"``...).
    points_per_decade : float
        Density of the default ``q`` grid.
    cutoff : {'sharp', 'gaussian'}
        Shape of the short-wavelength cutoff.

    Returns
    -------
    xarray.DataArray
        ``C`` on dim ``"q"`` (``"<unit>-1"``, "angular wavenumber") in ``"<unit>4"``; attrs (own
        units) that :func:`acf_from_spectrum` evaluates exactly: ``model``, ``rolloff``,
        ``hurst``, ``q_r``, ``q_s``, ``q_0`` (0.0: none), ``C_r``, ``rms_height``,
        ``rms_gradient``, ``equation``, ``spectrum_kind``.

    Raises
    ------
    ValueError
        ``H`` outside (0, 1), a wavelength not a positive length, ``lambda_s >= lambda_r``,
        ``lambda_0 < lambda_r``, not exactly one amplitude, an unknown ``rolloff``, a bad ``q``.

    See Also
    --------
    acf_from_spectrum : ``G(dr)`` of this spectrum (eq. 9).

    Examples
    --------
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
                              rms_gradient=rms_gradient, rolloff=rolloff, unit=unit_str,
                              cutoff=cutoff)
    q_0, q_r, q_s = model.q_0, model.q_r, model.q_end

    check_points_per_decade(points_per_decade)
    if q is None:
        q_min = min(q_0, q_r / 10.0) if q_0 > 0 else q_r / 100.0
        q_arr = _log_grid([q_min, q_0 if q_0 > 0 else q_min, q_r, q_s], points_per_decade)
    else:
        q_arr = _units.array_in(q, length_unit**-1, what="q", noun="wavenumbers")
    values = _sample_model(model, q_arr)

    q_unit = _units.power_units(unit_str, -1)
    attrs = {
        "units": _units.power_units(unit_str, 4),
        "long_name": "isotropic height spectrum",
        **model_attrs(model),
        "equation": _EQUATIONS[rolloff] + (_GAUSSIAN if cutoff == "gaussian" else ""),
        "spectrum_kind": "isotropic 2D",
    }
    return xr.DataArray(
        values,
        dims=("q",),
        coords={"q": ("q", q_arr, {"units": q_unit, "long_name": "angular wavenumber"})},
        name="C",
        attrs=attrs,
    )


@dataclasses.dataclass(frozen=True)
class _SpectrumInput:
    """A validated isotropic spectrum: ``q``, units and the function that evaluates ``C``."""

    dim: Hashable
    q: np.ndarray
    length_unit: PlainUnit
    unit_str: str
    model: SpectrumModel | None
    func: Any  # the model, or a PowerLawInterpolant through the samples


def spectrum_input(spectrum: Any) -> _SpectrumInput:
    """Check a C(q) DataArray (dims, units, values) and convert it to its ``q`` unit."""
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
        func: Any = model
    else:
        require_increasing(q, f"coordinate {dim!r}", noun="wavenumbers", min_size=2)
        if not (np.all(np.isfinite(values)) and np.all(values >= 0)):
            hint = (" (C from xrough.spectrum can be negative where G does not determine it: "
                    "keep C.where(C.supported == 1, drop=True))" if "supported" in
                    spectrum.coords else "")
            raise ValueError(f"spectrum values must be finite and >= 0 (no NaN){hint}")
        func = PowerLawInterpolant(q, values)
    return _SpectrumInput(dim, q, length_unit, unit_str, model, func)


def spectrum_lags(spec: _SpectrumInput, dr: QuantityLike | None, points_per_decade: float,
                  dr_min: QuantityLike | None, dr_max: QuantityLike | None) -> np.ndarray:
    """``dr`` in the spectrum's length unit; by default logarithmic over its wavelengths."""
    check_points_per_decade(points_per_decade)
    if dr is not None:
        return _units.array_in(dr, spec.length_unit, what="dr", noun="distances")
    q_pos = spec.q[np.isfinite(spec.q) & (spec.q > 0)]
    if q_pos.size == 0:
        raise ValueError(f"coordinate {spec.dim!r} has no positive wavenumber; pass dr")
    lo = (_units.length_in(dr_min, spec.length_unit, what="dr_min") if dr_min is not None
          else 0.01 * 2 * np.pi / q_pos.max())
    hi = (_units.length_in(dr_max, spec.length_unit, what="dr_max") if dr_max is not None
          else 100.0 * 2 * np.pi / q_pos.min())
    if not hi > lo:
        raise ValueError(f"dr_max must exceed dr_min (got {hi:g} and {lo:g} {spec.unit_str})")
    return log_range(lo, hi, points_per_decade)


@_units.accepts_quantified
def acf_from_spectrum(
    spectrum: xr.DataArray,
    dr: QuantityLike | None = None,
    *,
    points_per_decade: float = 20,
    dr_min: QuantityLike | None = None,
    dr_max: QuantityLike | None = None,
) -> xr.DataArray:
    r"""Height-difference ACF from an isotropic spectrum (paper eq. 9).

    :math:`G(\Delta r) = \frac{1}{2\pi} \int_0^\infty dq\, q\, C(q) [1 - J_0(q \Delta r)]`,
    the stable form of eq. 8 (no cancellation at small ``dr``).  If ``spectrum`` carries the
    attributes written by :func:`model_spectrum`, the exact model is evaluated (its samples
    are only checked against it).  Otherwise the samples are a piecewise power law (log-log;
    zero outside the sampled range and on intervals that touch a zero sample), integrated
    exactly: to about 1e-9 relative accuracy at every ``dr`` (Gauss-Legendre below
    ``q dr = 64``, closed-form asymptotic integration of the Bessel part above).

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
    spec = spectrum_input(spectrum)
    unit_str, model = spec.unit_str, spec.model
    if model is not None:
        func, bp = model, model.breakpoints
        knots = 0.0 if model.piecewise_power_law else 160.0
    else:
        func = spec.func
        bp, knots = func.breakpoints, 0.0

    dr_arr = spectrum_lags(spec, dr, points_per_decade, dr_min, dr_max)

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


# --------------------------------------------------------------------------------------
# eq. 26: the scale-dependent rms gradient
# --------------------------------------------------------------------------------------


# --------------------------------------------------------------------------------------
# G(dr) as input
# --------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class _AcfInput:
    """A validated G(dr): valid samples in one length unit and their random scatter."""

    dr: np.ndarray
    G: np.ndarray  # in length_unit^2
    noise: np.ndarray  # relative independent scatter per sample (0: none known)
    length_unit: PlainUnit
    unit_str: str
    gaps: np.ndarray  # lag ranges no measurement covers (AcfSpec.gaps)
    covariance: np.ndarray | None = None  # of the relative statistical errors (bins x bins)
    error_model: str = "none"  # how ``covariance`` was built
    plateau: float | None = None  # variance of the heights G was measured from (length^2)


#: What of C(q) depends on G inside a gap (:func:`xrough.acf.mark_gaps`).
_GAP = ("C(q), a transform of G over all lags, takes G there as the bridge: C at q of the "
        "order of 2 pi / dr inside the gap rests on it")


def acf_samples(G: Any, noise: Any = None, *, min_bins: int = 4,
                covariance: bool = False) -> _AcfInput:
    """One checked G (:func:`xrough.acf.check_acf`): its valid bins at ``dr > 0`` in ``dr``'s unit.

    ``noise`` is the relative independent scatter per bin; default ``sampling_error / G``
    when G has that coordinate (the random-pair estimator), else 0.  With ``covariance``,
    also the covariance of the relative statistical errors of the bins
    (:func:`_error_covariance`).
    """
    G, spec = read_acf(G, single=True, min_bins=min_bins)
    dr = spec.dr
    g = np.asarray(G.values, dtype=float) * spec.g_factor
    if noise is None:
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = (np.asarray(G["sampling_error"].values, dtype=float) * spec.g_factor / g
                   if "sampling_error" in G.coords else np.zeros_like(g))
    else:
        rel = np.broadcast_to(np.asarray(noise, dtype=float), g.shape)
        if not np.all(np.isfinite(rel) & (rel >= 0)):
            raise ValueError(f"noise must be a relative scatter >= 0, got {noise!r}")
    valid = np.isfinite(g) & (dr > 0)
    rel = np.nan_to_num(rel[valid])
    cov, model = (_error_covariance(G, spec, dr[valid], g[valid], valid, rel) if covariance
                  else (None, "none"))
    return _AcfInput(dr[valid], g[valid], rel, spec.length_unit, spec.unit_str, spec.gaps,
                     cov, model, height_variance(G, spec))


def _error_covariance(G, spec, dr, g, valid, noise) -> tuple[np.ndarray | None, str]:
    """Covariance of the relative statistical errors of G's valid bins, and its model.

    The finite-area error of G as :func:`~xrough._kernels.uncertainty.g_covariance`
    models it for the lag geometry of G (attr ``lag_geometry``; the area from
    ``scan_size``; periodic), scaled bin by bin to G's own finite-area variance
    (``standard_error^2 - sampling_error^2``: it knows the valid area and the pairs of
    an open map), that scale smoothed over 0.25 decades; plus ``noise`` (independent).
    A G without ``standard_error`` has ``noise`` alone; one without the geometry (a
    stitched G) is taken as a radial average over a square of twice its largest lag with
    pixels of its smallest.
    """
    diag = np.diag(noise**2)
    if "standard_error" not in G.coords:
        return (diag if np.any(noise > 0) else None,
                "noise (independent)" if np.any(noise > 0) else "none")
    se = np.asarray(G["standard_error"].values, dtype=float)[valid] * spec.g_factor
    sampling = (np.asarray(G["sampling_error"].values, dtype=float)[valid] * spec.g_factor
                if "sampling_error" in G.coords else np.zeros_like(se))
    area_var = se**2 - np.nan_to_num(sampling) ** 2
    geometry = G.attrs.get("lag_geometry")
    pixel, size = G.attrs.get("pixel_size"), G.attrs.get("scan_size")
    if geometry in ("profile", "axis", "radial") and pixel and size:
        pixel, size = float(pixel), float(size)  # in the unit of dr, as G was made
        model = f"finite-area model of a {geometry} G over its scan_size"
    else:
        geometry, pixel, size = "radial", float(dr[0]), 2.0 * float(dr[-1])
        model = ("finite-area model of a radial G over a square twice its largest lag (G "
                 "has no lag_geometry: assumed)")
    # (computed in units of the pixel and of G's median: the relative covariance is the
    # same in any unit, and so is its quadrature)
    cov = covariance_from_acf(dr, g, size=size, pixel=pixel, geometry=geometry,
                              per_decade=40.0, estimated_over=0.0, relative=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        log_ratio = np.log(area_var / np.diag(cov))
    ok = np.isfinite(log_ratio)
    if not ok.any():
        return (diag if np.any(noise > 0) else None), model
    # G's own variance sets the level, smoothly (a Gaussian window of 0.25 decades in
    # log dr): it knows the valid area and the pairs of an open map; bin-to-bin wiggles
    # of it would become spurious curvature of G
    x = np.log10(dr)
    kernel = np.exp(-0.5 * ((x[:, None] - x[None, ok]) / 0.25) ** 2)
    scale = np.exp(kernel @ log_ratio[ok] / kernel.sum(axis=1))
    return np.sqrt(np.outer(scale, scale)) * cov / np.outer(g, g) + diag, model


def check_spectrum_options(smooth, support_rtol, interpolation, points_per_decade) -> None:
    if smooth is not None and not (np.isfinite(smooth) and smooth > 0):
        raise ValueError(f"smooth must be a positive width in decades or None, got {smooth!r}")
    if not support_rtol > 0:
        raise ValueError(f"support_rtol must be positive, got {support_rtol!r}")
    if interpolation not in ("hermite", "power law"):
        raise ValueError(f"interpolation must be 'hermite' or 'power law', got "
                         f"{interpolation!r}")
    check_points_per_decade(points_per_decade)


def _support(acf: _AcfInput, *, smooth, support_rtol, interpolation,
             max_error: float = np.inf) -> tuple[float, float, np.ndarray | None, bool]:
    """Return ``(q_lo, q_hi)``, the error of C on the support grid, and the bound's fate.

    The last is whether the statistical bound was met; if not, the range is that without it.
    ``(q_lo, q_hi)`` is NaN where G determines C nowhere to ``support_rtol``.
    """
    statistical = acf.covariance is not None and np.isfinite(max_error)
    error = (spectrum_error_kernel(support_grid(acf.dr), acf.dr, acf.G, acf.covariance,
                                   smooth=smooth, interpolation=interpolation,
                                   plateau=acf.plateau)
             if acf.covariance is not None else None)
    # the noise is statistical: it enters through the covariance, against max_error
    options = dict(rtol=support_rtol, smooth=smooth, interpolation=interpolation,
                   plateau=acf.plateau)
    q_lo, q_hi = spectrum_support_kernel(acf.dr, acf.G, error=error if statistical else None,
                                         max_error=max_error, **options)
    met = bool(np.isfinite(q_lo))
    if not met and statistical:
        q_lo, q_hi = spectrum_support_kernel(acf.dr, acf.G, **options)
    return q_lo, q_hi, error, met or not statistical


def _error_at(q: np.ndarray, acf: _AcfInput, grid_error, *, smooth, interpolation):
    """Return the standard error of C at ``q`` (log-log interpolated inside the grid)."""
    if acf.covariance is None:
        return np.zeros(q.shape)
    grid = support_grid(acf.dr)
    if grid_error is None:
        grid_error = spectrum_error_kernel(grid, acf.dr, acf.G, acf.covariance,
                                           smooth=smooth, interpolation=interpolation,
                                           plateau=acf.plateau)
    out = np.empty(q.shape)
    inside = (q >= grid[0]) & (q <= grid[-1])
    with np.errstate(divide="ignore"):
        out[inside] = np.exp(np.interp(np.log(q[inside]), np.log(grid),
                                       np.log(np.maximum(grid_error, 1e-300))))
    if not inside.all():
        out[~inside] = spectrum_error_kernel(q[~inside], acf.dr, acf.G, acf.covariance,
                                             smooth=smooth, interpolation=interpolation,
                                             plateau=acf.plateau)
    return out


@by_content()
@_units.accepts_quantified
def spectrum(
    G: xr.DataArray,
    q: QuantityLike | None = None,
    *,
    smooth: float | None = None,
    noise: ArrayLike | None = None,
    support_rtol: float = 0.01,
    max_error: float = 0.1,
    interpolation: str = "hermite",
    points_per_decade: float = 20,
) -> xr.DataArray:
    r"""Isotropic height spectrum from the height-difference ACF (paper eq. 10/11).

    ``C(q) = 2 pi int dr dr J0(q dr) [sigma_h^2 - G(dr)]``, evaluated in the form integrated
    twice by parts (no ``sigma_h^2 - G``), split at ``dr = 1/q`` as in eq. 11, of ``G`` as a C2
    piecewise power law in log-log, ballistic below and flat above its lags.  Notes (method,
    supported range, statistical error, accuracy): docs/spectra.md, "spectrum in detail".

    Parameters
    ----------
    G : xarray.DataArray with one dim (``"dr"``)
        Height-difference ACF in length^2 on a lag coordinate in length (``units`` on both),
        e.g. from :func:`xrough.height_difference_acf`; at least 4 valid (non-NaN) bins.
    q : array_like, pint.Quantity or xarray.DataArray, optional
        Angular wavenumbers ``>= 0`` (plain numbers in the inverse length unit of ``dr``).
        Default: ``10**(k / points_per_decade)`` over the supported range, widened by 2.
    smooth : float, optional
        Smooth ``ln G`` over a window of this many decades first (noisy ``G``: 0.5 to 1).
    noise : float or array_like, optional
        Relative independent scatter of the bins (default ``sampling_error / G`` or 0).
    support_rtol : float
        Relative change of ``C`` under a change of the extrapolation allowed in support.
    max_error : float
        Largest relative standard error of ``C`` in support; ``numpy.inf`` to leave it out.
    interpolation : {'hermite', 'power law'}
        ``'power law'`` drops the quintic correction (kinks at the samples; for comparison).
    points_per_decade : float
        Density of the default ``q`` grid.

    Returns
    -------
    xarray.DataArray
        ``C`` on dim ``"q"`` (``"<len>-1"``) in ``"<len>4"``, ``<len>`` the unit of ``dr``;
        coords ``supported`` (1 inside the supported range) and ``standard_error``; attrs
        ``equation``, ``q_min_supported``, ``q_max_supported``, ``sigma_h2`` and the options.
        Where no ``q`` is supported: questionable, with a :class:`~xrough.QualityWarning`.

    Raises
    ------
    ValueError
        ``G`` not 1-D or length^2, no units, < 4 valid bins, bad lags, ``G <= 0``, bad options.

    See Also
    --------
    acf_from_spectrum : the inverse, eq. 9.
    rms_gradient_exact : eq. 26 from this spectrum.

    Examples
    --------
    >>> import numpy as np
    >>> model = dict(hurst=0.8, lambda_r="1 um", lambda_s="10 nm", rms_height="1 nm",
    ...              unit="nm", rolloff="smooth")
    >>> G = acf_from_spectrum(model_spectrum(**model), np.logspace(-1, 6, 141))
    >>> C = spectrum(G, [1e-4, 1e-3, 1e-2])
    >>> C.attrs["units"], C.q.attrs["units"], C.attrs["equation"]
    ('nm4', 'nm-1', 'eq. 10/11')
    >>> print(np.round((C / model_spectrum(C.q.values, **model)).values, 3))
    [1. 1. 1.]
    >>> C.supported.values.tolist()
    [1, 1, 1]
    """
    check_spectrum_options(smooth, support_rtol, interpolation, points_per_decade)
    if not (isinstance(max_error, (int, float, np.floating)) and max_error > 0):
        raise ValueError(f"max_error must be a positive relative error, got {max_error!r}")
    acf = acf_samples(G, noise, covariance=True)
    q_lo, q_hi, grid_error, bounded = _support(
        acf, smooth=smooth, support_rtol=support_rtol, interpolation=interpolation,
        max_error=max_error)
    determined = bool(np.isfinite(q_lo))
    if not determined:  # nothing supported: C over the data's range, said so
        bounded = False
        q_lo, q_hi = 2 * np.pi / acf.dr[-1], 2 * np.pi / acf.dr[0]
    q_arr = (decade_aligned_grid(0.5 * q_lo, 2.0 * q_hi, points_per_decade) if q is None
             else _units.array_in(q, acf.length_unit**-1, what="q", noun="wavenumbers"))
    g = acf.G if smooth is None else smooth_acf_kernel(acf.dr, acf.G, smooth)
    values = spectrum_from_acf_kernel(q_arr, acf.dr, g, interpolation=interpolation,
                                      plateau=acf.plateau)
    error = _error_at(q_arr, acf, grid_error, smooth=smooth, interpolation=interpolation)
    q_unit = _units.power_units(acf.unit_str, -1)
    supported = ((q_arr >= q_lo) & (q_arr <= q_hi) & bounded).astype(np.int8)
    attrs = {
        "units": _units.power_units(acf.unit_str, 4),
        "long_name": "isotropic height spectrum",
        "equation": "eq. 10/11",
        "estimator": "Hankel transform of G (eq. 10/11)",
        "spectrum_kind": "isotropic 2D",
        "q_min_supported": q_lo if bounded else np.nan,
        "q_max_supported": q_hi if bounded else np.nan,
        "support_rtol": float(support_rtol),
        "max_error": float(max_error),
        "error_model": acf.error_model,
        "sigma_h2": (acf_plateau_kernel(acf.dr, g) if acf.plateau is None
                     else acf.plateau),
        "sigma_h2_from": ("the extension of G beyond its last lag" if acf.plateau is None
                          else "the variance of the heights (coord height_variance of G)"),
        "smooth_decades": 0.0 if smooth is None else float(smooth),
        "noise": float(np.median(acf.noise)),
        "interpolation": interpolation,
        "dr_min": float(acf.dr[0]),
        "dr_max": float(acf.dr[-1]),
    }
    attrs = result_attrs(G, **attrs)
    C = xr.DataArray(
        values,
        dims=("q",),
        coords={
            "q": ("q", q_arr, {"units": q_unit, "long_name": "angular wavenumber"}),
            "supported": ("q", supported, {
                "long_name": "1 where G determines C (q_min_supported <= q <= "
                             "q_max_supported), 0 where extrapolation or noise dominates",
                "units": "1"}),
            "standard_error": ("q", error, {
                "long_name": "standard error of C", "units": _units.power_units(
                    acf.unit_str, 4)}),
        },
        name="C",
        attrs=attrs,
    )
    if not determined:
        C = quality.mark(C, (
            f"G determines C nowhere to support_rtol={support_rtol:g}: the continuation "
            f"of G beyond dr = {acf.dr[0]:.4g} to {acf.dr[-1]:.4g} {acf.unit_str} (still "
            "self-affine at its first lag, or still rising at its last) changes C by more "
            "than that at every q, so nothing is marked supported and the values are those "
            "of the continuation; the power spectrum of the heights (psd()) needs no "
            "continuation, or pass a larger support_rtol"), what="spectrum")
    elif not bounded:
        C = quality.mark(C, (
            f"the standard error of C exceeds max_error={max_error:g} at every q that G "
            f"determines to support_rtol={support_rtol:g} (q = {q_lo:.4g} to {q_hi:.4g} "
            f"{q_unit}; model: {acf.error_model}): nothing is marked supported; average "
            "more measurements, pass smooth=<decades> or a larger max_error"),
            what="spectrum")
    return mark_gaps(C, acf, what="spectrum", depends=_GAP)
