"""Curves of a fit of G: the fitted G(dr) and the rms gradient it implies.

:func:`model_acf` and :func:`gradient_from_fit` evaluate the Dataset of
:func:`xrough.fitting.fit_acf` (its representation is described in :mod:`xrough.fitting`)
on any lags, for every fit along its extra dims; both are importable from
:mod:`xrough.fitting` too.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pint
import xarray as xr

from . import units as u
from ._kernels.fitting import (
    FLAGS,
    MODELS,
    PARAMETERS,
    SPECTRUM_PARAMETERS,
    fitted_spectrum_acf,
    fitted_spectrum_gradient,
)
from ._kernels.shape_factors import ROLLOFFS, rolloff_factor, self_affine_factor

__all__ = ["model_acf", "gradient_from_fit"]


# --------------------------------------------------------------------------------------
# reading a fit
# --------------------------------------------------------------------------------------
def _params_units(params: xr.Dataset) -> tuple[pint.Unit, pint.Unit, str]:
    """Lateral and height units and model of a fit, checking that it has what it needs."""
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
    lateral = u.as_length_unit(u.units_of(params["lambda_r"], what="lambda_r"),
                               what="lambda_r")
    height = u.as_length_unit(u.units_of(params["sigma_h"], what="sigma_h"), what="sigma_h")
    return lateral, height, model


def _lags(dr: Any, lateral: pint.Unit, params: xr.Dataset) -> np.ndarray:
    if dr is None:
        lo, hi = params.attrs.get("dr_min"), params.attrs.get("dr_max")
        if lo is None or hi is None:
            raise ValueError("pass dr (params has no dr_min/dr_max attributes)")
        f = u.conversion_factor(u.parse_units(params.attrs.get("dr_units", lateral)),
                                lateral)
        return np.geomspace(lo * f, hi * f, 50)
    if isinstance(dr, xr.DataArray):
        unit = dr.attrs.get("units")
        f = 1.0 if unit is None else u.conversion_factor(u.as_length_unit(unit, what="dr"),
                                                        lateral)
        values = np.asarray(dr.values, dtype=float) * f
    elif isinstance(dr, (pint.Quantity, str)):
        q = u.quantity(dr, default_units=lateral, what="dr")
        if not q.check("[length]"):
            raise ValueError(f"dr must be a length, got {dr!r}")
        values = np.asarray(q.to(lateral).magnitude, dtype=float)
    else:
        values = np.asarray(dr, dtype=float)
    values = np.atleast_1d(values)
    if values.ndim != 1 or not np.all(np.isfinite(values)) or np.any(values <= 0):
        raise ValueError("dr must be a 1-D array of finite positive distances")
    return values


def _lag_coord(values: np.ndarray, lateral: pint.Unit) -> dict:
    return {"dr": ("dr", values, {"units": u.format_units(lateral),
                                  "long_name": "lag distance"})}


def _in_lateral(params: xr.Dataset, lateral: pint.Unit, height: pint.Unit) -> dict:
    """``sigma_h``, ``G_sa``, ``dr_ref``, ``lambda_r`` in the lateral unit, ``hurst``, ``C_b``.

    (``C_b`` is None for the spectrum model.)
    """
    h2l = u.conversion_factor(height, lateral)
    g_unit = u.units_of(params["G_sa"], what="G_sa")
    ref_unit = u.as_length_unit(u.units_of(params["dr_ref"], what="dr_ref"), what="dr_ref")
    return {
        "sigma_h": params["sigma_h"] * h2l,
        "G_sa": params["G_sa"] * u.conversion_factor(g_unit, lateral**2),
        "dr_ref": float(params["dr_ref"]) * u.conversion_factor(ref_unit, lateral),
        "lambda_r": params["lambda_r"],
        "hurst": params["hurst"],
        "C_b": params.get("C_b"),
    }


def _spectrum_inputs(params: xr.Dataset, lateral: pint.Unit) -> tuple[list, dict]:
    """Per-fit inputs of the spectrum model (lengths in ``lateral``, ``G_sa`` as stored)."""
    ref_unit = u.as_length_unit(u.units_of(params["dr_ref"], what="dr_ref"), what="dr_ref")
    lam_0 = np.inf
    if "lambda_0" in params.variables:
        unit = u.as_length_unit(u.units_of(params["lambda_0"], what="lambda_0"),
                                what="lambda_0")
        lam_0 = float(params["lambda_0"]) * u.conversion_factor(unit, lateral)
    s_unit = u.as_length_unit(u.units_of(params["lambda_s"], what="lambda_s"),
                              what="lambda_s")
    arrays = [params["hurst"], params["G_sa"], params["lambda_r"],
              params["lambda_s"] * u.conversion_factor(s_unit, lateral),
              params["lambda_r_resolved"], params["lambda_s_resolved"]]
    arrays = [a.drop_vars([c for c in a.coords if c not in a.dims]) for a in arrays]
    scalars = {"dr_ref": float(params["dr_ref"]) * u.conversion_factor(ref_unit, lateral),
               "lam_0": lam_0, "rolloff": params.attrs.get("rolloff", "sharp")}
    return arrays, scalars


def _per_fit(func, arrays, values, lateral, **kwargs) -> xr.DataArray:
    return xr.apply_ufunc(
        func, *arrays, input_core_dims=[[]] * len(arrays), output_core_dims=[["dr"]],
        vectorize=True, dask="parallelized", output_dtypes=[float],
        dask_gufunc_kwargs={"output_sizes": {"dr": values.size}},
        kwargs={"dr": values, **kwargs}, keep_attrs=False,
    ).assign_coords(_lag_coord(values, lateral))


def model_acf(params: xr.Dataset, dr: Any = None) -> xr.DataArray:
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
    lateral, height, model = _params_units(params)
    values = _lags(dr, lateral, params)
    g_unit = u.units_of(params["G_sa"], what="G_sa")
    if model == "spectrum":
        arrays, scalars = _spectrum_inputs(params, lateral)
        out = _per_fit(fitted_spectrum_acf, arrays, values, lateral, **scalars)
        equation, what = "eq. 9", "model spectrum"
    else:
        p = _in_lateral(params, lateral, height)
        x = xr.DataArray(values, dims="dr", coords=_lag_coord(values, lateral))
        c_sa = p["dr_ref"] ** (2 * p["hurst"]) / p["G_sa"]
        inv = p["C_b"] / x**2 + c_sa / x ** (2 * p["hurst"]) + 1.0 / p["sigma_h"] ** 2
        out = (1.0 / inv) * u.conversion_factor(lateral**2, g_unit)
        equation, what = "eq. 36", "eq. 36"
    out = out.drop_vars([c for c in out.coords if c not in out.dims and c != "dr"])
    out.name = "G"
    out.attrs = {"units": u.format_units(g_unit),
                 "long_name": f"height-difference ACF (fit of {what})",
                 "equation": equation}
    return out.transpose(..., "dr")


def gradient_from_fit(params: xr.Dataset, dr: Any = None, *,
                      rolloff: str | None = None) -> xr.DataArray:
    r"""Scale-dependent rms gradient ``gbar(dr)`` from a fit of G.

    For ``model="spectrum"``, eq. 26 of the fitted spectrum in closed form,

    .. math::

        \bar g^2(\Delta r) = \frac{1}{2\pi} \int_0^{2\pi/\Delta r} dq\, q^3\, C(q);

    for ``model="eq36"``, the paper's eq. 37/38,

    .. math::

        \frac{1}{\bar g^2(\Delta r)} = \frac{1}{\bar g^2(0)}
            + \frac{\Delta r^{2(1-H)}}{C'_{sa}} + \frac{\Delta r^4}{r_{ro}},
        \quad \bar g^2(0) = \frac{4}{C_b},\;
        C'_{sa} = \frac{c_{sa}(H)}{C_{sa}},\;
        r_{ro} = c_{ro}(H)\, \sigma_h^2 \lambda_r^2

    Parameters
    ----------
    params : xarray.Dataset
        The result of :func:`fit_acf`.
    dr : array_like, str, pint.Quantity or xarray.DataArray, optional
        Positive lags; plain numbers in the unit of ``params.lambda_r``.  Default: 50
        logarithmic points over the fitted range.
    rolloff : {'sharp', 'smooth'}, optional
        Roll-off shape; default ``params.attrs["rolloff"]``.  For eq. 36 it selects
        ``c_ro(H)``; a spectrum fit only accepts its own shape.

    Returns
    -------
    xarray.DataArray
        ``gbar`` (units "1") on dim ``dr`` and the extra dims of ``params``;
        ``attrs["equation"]`` is ``"eq. 26"`` or ``"eq. 37/38"``.

    Raises
    ------
    ValueError
        ``params`` without the fitted variables or units; invalid ``dr`` or ``rolloff``.

    Notes
    -----
    *Spectrum model.*  Exact for the fitted spectrum; with ``lambda_s_resolved = 0`` the
    spectrum has no short cutoff and ``gbar`` grows without bound as ``dr -> 0``
    (as ``dr^-(1-H)``), and ``lambda_r_resolved = 0`` drops the plateau.

    *Eq. 36.*  xrough's convention for the shape factors (docs/theory.md):
    ``gbar^2(dr) = c_sa(H) G(dr)/dr^2`` in the self-affine regime and ``gbar^2(dr) =
    c_ro(H) sigma_h^2 lambda_r^2 / dr^4`` for ``dr >> lambda_r``, with gbar from eq. 26,
    so that

    * ``c_sa(H) = 4 pi^(2-2H) H Gamma(1+H) / Gamma(2-H)``
      (:func:`xrough._kernels.shape_factors.self_affine_factor`, both roll-off shapes);
    * ``c_ro(H) = 2 pi^2 H / (1+H)`` (sharp, eq. 35) or ``2 pi^2 H`` (smooth), in the limit
      ``lambda_s/lambda_r -> 0`` (:func:`xrough._kernels.shape_factors.rolloff_factor`).

    Each term is exact deep inside its regime (``dr << lambda_s``: ``gbar -> gbar(0)``;
    ``lambda_s << dr << lambda_r``; ``dr >> lambda_r``) and the sum of reciprocals is
    an interpolation between them: near the crossovers it can be off by tens of percent.
    ``C_b = 0`` gives ``gbar(0) = inf``; ``sigma_h = inf`` drops the roll-off term.

    Examples
    --------
    >>> import xrough
    >>> from xrough.fitting import fit_acf, gradient_from_fit
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
    lateral, height, model = _params_units(params)
    own = params.attrs.get("rolloff", "sharp")
    rolloff = own if rolloff is None else rolloff
    if rolloff not in ROLLOFFS:
        raise ValueError(f"rolloff must be one of {ROLLOFFS}, got {rolloff!r}")
    values = _lags(dr, lateral, params)
    if model == "spectrum":
        if rolloff != own:
            raise ValueError(f"rolloff={rolloff!r} differs from the {own!r} spectrum that "
                             "was fitted; refit with that shape")
        arrays, scalars = _spectrum_inputs(params, lateral)
        g_factor = u.conversion_factor(u.units_of(params["G_sa"], what="G_sa"), lateral**2)
        out = _per_fit(fitted_spectrum_gradient, arrays, values, lateral, g_factor=g_factor,
                       **scalars)
        equation, what = "eq. 26", "fitted spectrum"
    else:
        p = _in_lateral(params, lateral, height)
        x = xr.DataArray(values, dims="dr", coords=_lag_coord(values, lateral))
        H = p["hurst"]
        c_sa = xr.apply_ufunc(self_affine_factor, H, dask="parallelized",
                              output_dtypes=[float], keep_attrs=False)
        c_ro = xr.apply_ufunc(lambda h: rolloff_factor(h, rolloff=rolloff), H,
                              dask="parallelized", output_dtypes=[float], keep_attrs=False)
        C_sa = p["dr_ref"] ** (2 * H) / p["G_sa"]
        with np.errstate(divide="ignore", invalid="ignore"):
            r_ro = c_ro * p["sigma_h"] ** 2 * p["lambda_r"] ** 2
            inv = p["C_b"] / 4.0 + x ** (2 * (1 - H)) * C_sa / c_sa + x**4 / r_ro
            out = np.sqrt(1.0 / inv)
        equation, what = "eq. 37/38", "fit of eq. 36"
    out = out.drop_vars([c for c in out.coords if c not in out.dims and c != "dr"])
    out.name = "gbar"
    out.attrs = {"units": "1", "long_name": f"scale-dependent rms gradient ({what})",
                 "equation": equation, "rolloff": rolloff}
    return out.transpose(..., "dr")
