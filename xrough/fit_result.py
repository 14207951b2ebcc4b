"""Reading a fit of G: its units and lags, the G it implies and the gradient it implies.

A fit is the Dataset of :func:`xrough.fit_acf` (its variables and attributes are listed
in :mod:`xrough.fitting`).  Everything that reads one goes through :func:`read_fit`, which
checks that the Dataset has what its model needs and finds its units once:

:func:`model_acf`
    the fitted ``G(dr)``: eq. 9 of the fitted spectrum, or eq. 36;
:func:`gradient_from_fit`
    the scale-dependent rms gradient: eq. 26 of the fitted spectrum, or eq. 37/38;
:func:`rolloff_shapes`, :func:`spectrum_shapes`
    the roll-off shape of each fit, and its roll-off and cutoff in one code.

:func:`xrough.fitting.model_acf` and :func:`xrough.gradient.gradient_from_fit` are these
functions.  The numpy kernels are :func:`xrough._kernels.fitting.fitted_spectrum_acf` and
:func:`~xrough._kernels.fitting.fitted_spectrum_gradient`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from . import units as u
from ._kernels.fitting import (
    COVARIANCE_PARAMETERS,
    FLAGS,
    MODELS,
    PARAMETERS,
    SPECTRUM_PARAMETERS,
    fitted_spectrum_acf,
    fitted_spectrum_gradient,
    fitted_spectrum_gradient_std,
)
from ._kernels.shape_factors import ROLLOFFS, rolloff_factor, self_affine_factor
from ._kernels.spectral_models import shape_code
from .acf import lag_coord
from .units import QuantityLike

if TYPE_CHECKING:
    from pint.facets.plain import PlainUnit

__all__ = ["read_fit", "model_acf", "gradient_from_fit", "rolloff_shapes", "spectrum_shapes",
           "COVARIANCE",
           "COVARIANCE_DIMS"]

#: The variable of a spectrum fit that holds the covariance of its parameters, and its dims
#: (those of ``xarray.DataArray.curvefit``); the parameters are
#: :data:`xrough._kernels.fitting.COVARIANCE_PARAMETERS`.
COVARIANCE, COVARIANCE_DIMS = "parameter_covariance", ("cov_i", "cov_j")


def _length_unit(params: xr.Dataset, name: str) -> PlainUnit:
    return u.as_length_unit(u.units_of(params[name], what=name), what=name)


@dataclass(frozen=True)
class FitReading:
    """A fit of G with its units, as :func:`read_fit` found them.

    Attributes
    ----------
    params : xarray.Dataset
        The result of :func:`xrough.fit_acf`.
    model : str
        ``'spectrum'`` or ``'eq36'``.
    lateral, height : pint.Unit
        Units of ``lambda_r`` (the lags) and of ``sigma_h``.
    g_unit : pint.Unit
        Units of ``G_sa`` (those of the fitted G).
    """

    params: xr.Dataset
    model: str
    lateral: PlainUnit
    height: PlainUnit
    g_unit: PlainUnit

    @property
    def lateral_str(self) -> str:
        return u.format_units(self.lateral)

    def in_lateral(self, name: str) -> xr.DataArray:
        """Variable ``name`` (a length or, for ``G_sa``, an area) in the lateral unit."""
        unit = self.g_unit if name == "G_sa" else _length_unit(self.params, name)
        target = self.lateral**2 if name == "G_sa" else self.lateral
        return self.params[name] * u.conversion_factor(unit, target)

    def scalar(self, name: str) -> float:
        """Scalar coordinate ``name`` (``dr_ref``, ``lambda_0``) in the lateral unit."""
        return float(self.in_lateral(name))

    def lags(self, dr: QuantityLike | None) -> np.ndarray:
        """Lags in the lateral unit (any form :func:`xrough.units.quantity` reads).

        Default (``dr=None``): 50 logarithmic points over the fitted range.
        """
        if dr is not None:
            return u.array_in(dr, self.lateral, what="dr", noun="distances", positive=True)
        lo, hi = self.params.attrs.get("dr_min"), self.params.attrs.get("dr_max")
        if lo is None or hi is None:
            raise ValueError("pass dr (params has no dr_min/dr_max attributes)")
        f = u.conversion_factor(u.parse_units(self.params.attrs.get("dr_units",
                                                                    self.lateral)),
                                self.lateral)
        return np.geomspace(lo * f, hi * f, 50)

    def lag_axis(self, values: np.ndarray) -> xr.DataArray:
        return xr.DataArray(values, dims="dr", coords=lag_coord(values, self.lateral_str))

    def per_fit(self, func, values: np.ndarray, *, covariance: bool = False,
                **kwargs) -> xr.DataArray:
        """``func`` of the fitted spectrum at the lags ``values``, one curve per fit.

        ``covariance``: ``func`` also takes the fit's ``parameter_covariance``.
        """
        arrays = [self.params["hurst"], self.params["G_sa"], self.params["lambda_r"],
                  self.in_lateral("lambda_s"), self.params["lambda_r_resolved"],
                  self.params["lambda_s_resolved"], spectrum_shapes(self.params)]
        core: list[list[str]] = [[]] * len(arrays)
        if covariance:
            arrays.append(self.params[COVARIANCE])
            core = [*core, list(COVARIANCE_DIMS)]
        arrays = [a.reset_coords(drop=True) for a in arrays]
        lam_0 = self.scalar("lambda_0") if "lambda_0" in self.params.variables else np.inf
        return xr.apply_ufunc(
            func, *arrays, input_core_dims=core, output_core_dims=[["dr"]],
            vectorize=True, dask="parallelized", output_dtypes=[float],
            dask_gufunc_kwargs={"output_sizes": {"dr": values.size}},
            kwargs={"dr": values, "dr_ref": self.scalar("dr_ref"), "lam_0": lam_0,
                    **kwargs},
            keep_attrs=False,
        ).assign_coords(lag_coord(values, self.lateral_str))


def read_fit(params: xr.Dataset) -> FitReading:
    """Check that ``params`` is a fit of :func:`xrough.fit_acf` and find its units.

    Examples
    --------
    >>> import xrough
    >>> C = xrough.model_spectrum(hurst=0.5, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_height="2 nm", unit="nm")
    >>> params = xrough.fit_acf(xrough.acf_from_spectrum(C, dr_min=1, dr_max=1e5))
    >>> fit = read_fit(params)
    >>> fit.model, u.format_units(fit.lateral), u.format_units(fit.g_unit)
    ('spectrum', 'nm', 'nm2')
    >>> read_fit(params.drop_vars("hurst"))
    Traceback (most recent call last):
    ...
    ValueError: params lacks ['hurst']; pass the Dataset returned by fit_acf
    """
    if not isinstance(params, xr.Dataset):
        raise TypeError(f"params must be the xarray.Dataset of fit_acf, got "
                        f"{type(params).__name__}")
    model = params.attrs.get("model", "eq36")
    if model not in MODELS:
        raise ValueError(f"params.attrs['model'] must be one of {MODELS}, got {model!r}")
    needed = PARAMETERS if model == "eq36" else (*SPECTRUM_PARAMETERS, *FLAGS)
    missing = [v for v in (*needed, "dr_ref") if v not in params.variables]
    if missing:
        raise ValueError(f"params lacks {missing}; pass the Dataset returned by fit_acf")
    if COVARIANCE in params.variables:
        _check_covariance(params[COVARIANCE])
    return FitReading(params=params, model=model,
                      lateral=_length_unit(params, "lambda_r"),
                      height=_length_unit(params, "sigma_h"),
                      g_unit=u.units_of(params["G_sa"], what="G_sa"))


def _check_covariance(cov: xr.DataArray) -> None:
    """Raise a clear error for a ``parameter_covariance`` not of the shape a fit makes."""
    n = len(COVARIANCE_PARAMETERS)
    dims = {d: cov.sizes.get(d) for d in COVARIANCE_DIMS}
    if any(size != n for size in dims.values()):
        raise ValueError(
            f"params[{COVARIANCE!r}] must have dims {COVARIANCE_DIMS} of {n} each (the "
            f"covariance of {', '.join(COVARIANCE_PARAMETERS)}), got dims "
            f"{dict(cov.sizes)}; pass the Dataset returned by fit_acf, or drop the "
            "variable (the fitted gradient then states no error of its own)")


def rolloff_shapes(params: xr.Dataset) -> xr.DataArray:
    """Return the roll-off shape of each fit (index in ``ROLLOFFS``).

    The variable ``rolloff_shape``, or, for fits without it, ``attrs["rolloff"]``
    (default ``'sharp'``).
    """
    if "rolloff_shape" in params.variables:
        return params["rolloff_shape"]
    own = params.attrs.get("rolloff", "sharp")
    if own not in ROLLOFFS:
        raise ValueError(f"params.attrs['rolloff'] = {own!r} without a variable "
                         "'rolloff_shape'; pass the Dataset returned by fit_acf")
    return xr.full_like(params["hurst"], ROLLOFFS.index(own), dtype=np.int8)


def spectrum_shapes(params: xr.Dataset) -> xr.DataArray:
    """Return the roll-off and cutoff of each fitted spectrum in one integer.

    :func:`~xrough._kernels.spectral_models.shape_code`: :func:`rolloff_shapes` plus 2
    where the variable ``cutoff_shape`` is 1 (Gaussian); fits without it have the sharp
    cutoff of eq. 35.
    """
    shapes = rolloff_shapes(params)
    if "cutoff_shape" in params.variables:
        shapes = shape_code(shapes, params["cutoff_shape"])
    return shapes


def _curve(out: xr.DataArray, name: str, attrs: dict) -> xr.DataArray:
    """``out`` on dim ``dr`` last, without the scalar coords of the fit."""
    out = out.drop_vars([c for c in out.coords if c not in out.dims and c != "dr"])
    out.name = name
    out.attrs = attrs
    return out.transpose(..., "dr")


def _eq36_acf(fit: FitReading, values: np.ndarray) -> xr.DataArray:
    """Eq. 36 at the lags ``values``, in the lateral unit squared."""
    H, x = fit.params["hurst"], fit.lag_axis(values)
    sigma_h = fit.in_lateral("sigma_h")
    c_sa = fit.scalar("dr_ref") ** (2 * H) / fit.in_lateral("G_sa")
    return 1.0 / (fit.params["C_b"] / x**2 + c_sa / x ** (2 * H) + 1.0 / sigma_h**2)


def _eq36_gradient(fit: FitReading, values: np.ndarray, rolloff: str) -> xr.DataArray:
    """Eq. 37/38 at the lags ``values``."""
    H, x = fit.params["hurst"], fit.lag_axis(values)
    sigma_h = fit.in_lateral("sigma_h")
    c_sa = xr.apply_ufunc(self_affine_factor, H, dask="parallelized",
                          output_dtypes=[float], keep_attrs=False)
    c_ro = xr.apply_ufunc(lambda h: rolloff_factor(h, rolloff=rolloff), H,
                          dask="parallelized", output_dtypes=[float], keep_attrs=False)
    C_sa = fit.scalar("dr_ref") ** (2 * H) / fit.in_lateral("G_sa")
    with np.errstate(divide="ignore", invalid="ignore"):
        r_ro = c_ro * sigma_h**2 * fit.params["lambda_r"] ** 2
        inv = fit.params["C_b"] / 4.0 + x ** (2 * (1 - H)) * C_sa / c_sa + x**4 / r_ro
        return np.sqrt(1.0 / inv)


@u.accepts_quantified
def model_acf(params: xr.Dataset, dr: QuantityLike | None = None) -> xr.DataArray:
    r"""Evaluate the fitted height-difference ACF ``G(dr)`` (plots, checks).

    For ``model="spectrum"``, eq. 9 of the fitted spectrum; for ``model="eq36"``,

    .. math::

        G(\Delta r) = \left[\frac{C_b}{\Delta r^2} + \frac{C_{sa}}{\Delta r^{2H}}
                      + \frac{1}{\sigma_h^2}\right]^{-1},
        \qquad C_{sa} = \Delta r_{ref}^{2H} / G_{sa}

    Parameters
    ----------
    params : xarray.Dataset
        The result of :func:`fit_acf` (any extra dims are broadcast).
    dr : array_like, str, pint.Quantity or xarray.DataArray, optional
        Positive lags; plain numbers in the unit of ``params.lambda_r``.  Default: 50
        logarithmic points over the fitted range.

    Returns
    -------
    xarray.DataArray
        ``G`` on dim ``dr`` (units of ``params.lambda_r``) and the extra dims of
        ``params``, in the units of ``params.G_sa``; ``attrs["equation"]`` is
        ``"eq. 9"`` or ``"eq. 36"``.

    Raises
    ------
    ValueError
        ``params`` without the fitted variables or units; invalid ``dr``.

    Notes
    -----
    A cutoff that the fit did not resolve (``lambda_s_resolved = 0``,
    ``lambda_r_resolved = 0``) is absent from the curve (``lambda_s = 0``,
    ``lambda_r = inf`` or ``lambda_0``), as in the fit.

    Examples
    --------
    >>> import xrough
    >>> from xrough.fitting import fit_acf, model_acf
    >>> C = xrough.model_spectrum(hurst=0.5, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_height="2 nm", unit="nm")
    >>> p = fit_acf(xrough.acf_from_spectrum(C, dr_min=1, dr_max=1e5))
    >>> curve = model_acf(p, [1e9])   # far out: sigma_h^2
    >>> print(f"{float(curve[0]):.4f} {curve.attrs['units']} = "
    ...       f"{float(p.sigma_h)**2:.4f} {p.sigma_h.attrs['units']}^2")
    4.0000 nm2 = 4.0000 nm^2
    """
    fit = read_fit(params)
    values = fit.lags(dr)
    if fit.model == "spectrum":
        out = fit.per_fit(fitted_spectrum_acf, values)
        equation, what = "eq. 9", "model spectrum"
    else:
        out = _eq36_acf(fit, values) * u.conversion_factor(fit.lateral**2, fit.g_unit)
        equation, what = "eq. 36", "eq. 36"
    return _curve(out, "G", {"units": u.format_units(fit.g_unit),
                             "long_name": f"height-difference ACF (fit of {what})",
                             "equation": equation})


def _gradient_rolloff(fit: FitReading, rolloff: str | None) -> str:
    """Check the roll-off shape ``rolloff`` asked of :func:`gradient_from_fit`."""
    own = fit.params.attrs.get("rolloff", "sharp")
    rolloff = own if rolloff is None else rolloff
    if rolloff not in ROLLOFFS and not (fit.model == "spectrum" and rolloff == own == "auto"):
        raise ValueError(f"rolloff must be one of {ROLLOFFS}, got {rolloff!r}")
    if fit.model == "spectrum" and rolloff != own:
        raise ValueError(f"rolloff={rolloff!r} differs from the {own!r} spectrum that "
                         "was fitted; refit with that shape")
    return rolloff


@u.accepts_quantified
def gradient_from_fit(params: xr.Dataset, dr: QuantityLike | None = None, *,
                      rolloff: str | None = None) -> xr.DataArray:
    r"""Scale-dependent rms gradient ``gbar(dr)`` from a fit of G.

    ``model="spectrum"``: eq. 26 of the fitted spectrum in closed form, ``gbar^2(dr) = (1/2pi)
    int_0^(2pi/dr) dq q^3 C(q)``; ``model="eq36"``: the paper's eq. 37/38,

    .. math::

        \frac{1}{\bar g^2(\Delta r)} = \frac{1}{\bar g^2(0)}
            + \frac{\Delta r^{2(1-H)}}{C'_{sa}} + \frac{\Delta r^4}{r_{ro}},
        \quad \bar g^2(0) = \frac{4}{C_b},\;
        C'_{sa} = \frac{c_{sa}(H)}{C_{sa}},\;
        r_{ro} = c_{ro}(H)\, \sigma_h^2 \lambda_r^2

    an interpolation that can be off by tens of percent near the crossovers.  Notes (the
    shape factors, unresolved cutoffs): docs/theory.md, "gradient_from_fit in detail".

    Parameters
    ----------
    params : xarray.Dataset
        The result of :func:`fit_acf`.
    dr : array_like, str, pint.Quantity or xarray.DataArray, optional
        Positive lags; plain numbers in the unit of ``params.lambda_r``.  Default: 50
        logarithmic points over the fitted range.
    rolloff : {'sharp', 'smooth'}, optional
        Default ``params.attrs["rolloff"]`` (per fit ``rolloff_shape`` if ``"auto"``); eq. 36:
        selects ``c_ro(H)``; a spectrum fit only accepts its own shape.

    Returns
    -------
    xarray.DataArray
        ``gbar`` (units "1") on dim ``dr`` and the extra dims of ``params``;
        ``attrs["equation"]`` is ``"eq. 26"`` or ``"eq. 37/38"``.  A spectrum fit with
        its ``parameter_covariance`` adds the coordinate ``gbar_std``, the statistical
        standard deviation of gbar (eq. 26 linearised in the fit's parameters).

    Raises
    ------
    ValueError
        ``params`` without the fitted variables or units; invalid ``dr`` or ``rolloff``.

    See Also
    --------
    xrough.rms_gradient : gbar from G, choosing the method.

    Examples
    --------
    >>> import xrough
    >>> from xrough.fitting import fit_acf
    >>> C = xrough.model_spectrum(hurst=0.5, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_height="2 nm", unit="nm")
    >>> G = xrough.acf_from_spectrum(C, dr_min=1, dr_max=1e5)
    >>> g = gradient_from_fit(fit_acf(G), [1e-6, 100.0])
    >>> g.attrs["units"], g.attrs["equation"]
    ('1', 'eq. 26')
    >>> print(f"gbar(0) = {float(g[0]):.4f} (model {C.attrs['rms_gradient']:.4f})")
    gbar(0) = 0.1026 (model 0.1026)
    >>> g36 = gradient_from_fit(fit_acf(G, model="eq36"), [1e-6, 100.0])
    >>> print(f"eq. 37/38: gbar(0) = {float(g36[0]):.4f}")
    eq. 37/38: gbar(0) = 0.1236
    """
    fit = read_fit(params)
    rolloff = _gradient_rolloff(fit, rolloff)
    values = fit.lags(dr)
    std = None
    if fit.model == "spectrum":
        g_factor = u.conversion_factor(fit.g_unit, fit.lateral**2)
        out = fit.per_fit(fitted_spectrum_gradient, values, g_factor=g_factor)
        if COVARIANCE in params.variables:
            std = fit.per_fit(fitted_spectrum_gradient_std, values, covariance=True,
                              g_factor=g_factor) * out
        equation, what = "eq. 26", "fitted spectrum"
    else:
        out = _eq36_gradient(fit, values, rolloff)
        equation, what = "eq. 37/38", "fit of eq. 36"
    out = _curve(out, "gbar", {"units": "1",
                               "long_name": f"scale-dependent rms gradient ({what})",
                               "equation": equation, "rolloff": rolloff})
    if std is None:
        return out
    of = params[COVARIANCE].attrs.get("error_of", "")
    return out.assign_coords(gbar_std=xr.Variable(out.dims, std.transpose(*out.dims).data, {
        "units": "1", "long_name": "statistical standard deviation of gbar",
        "error_of": f"{of}; eq. 26 of the fitted spectrum, linear in the fit's "
                    "parameter_covariance"}))
