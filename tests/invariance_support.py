"""Inputs and comparisons shared by the invariance tests (test_invariance, test_backends).

- model inputs: G of the model spectrum of eq. 35 (optionally with a seeded scatter and
  the matching ``standard_error``, like a measured G), synthetic topographies;
- :func:`in_length_unit`: the same physics in another length unit (every variable whose
  units are a power of length is converted, nothing else);
- :func:`assert_same_physics`: results equal after both are converted to SI;
- :func:`assert_same_attrs`: attrs equal, with attrs that are lengths converted;
"""

from __future__ import annotations

import numpy as np
import xarray as xr

import xrough
from xrough import units as xu
from xrough.testing import assert_units_equal

#: Factor from nm to each length unit the unit-invariance tests use.
FROM_NM = {"nm": 1.0, "um": 1e-3, "m": 1e-9}

#: Lags of the model G: log-spaced, not starting or ending on a power of ten (see
#: test_invariance.test_exact_gradient_support_does_not_depend_on_the_unit for why that
#: matters), from below lambda_s = 10 nm to far beyond lambda_r = 1 um.
LAGS_NM = (1.3, 0.9e5)

#: Model parameters of every G and topography here (eq. 35).
MODEL = {"lambda_r": "1 um", "lambda_s": "10 nm"}


def model_spectrum_nm(*, hurst: float = 0.8, rms_gradient: float = 0.5,
                      rolloff: str = "sharp") -> xr.DataArray:
    return xrough.model_spectrum(hurst=hurst, rms_gradient=rms_gradient, rolloff=rolloff,
                                 unit="nm", **MODEL)


def model_G(*, hurst: float = 0.8, rms_gradient: float = 0.5, n_lags: int = 41,
            scatter: float = 0.02, seed: int = 0, rolloff: str = "sharp") -> xr.DataArray:
    """G in nm of the model spectrum, times ``1 + scatter * N(0, 1)`` (seeded).

    With ``scatter > 0`` the G carries a ``standard_error`` coordinate of ``scatter * G``
    (as a measured G does) and no model attributes (they would no longer describe the
    data). The scatter makes fits well conditioned: on a noise-free G the reduced chi^2
    and the standard deviations of a fit are round-off.
    """
    C = model_spectrum_nm(hurst=hurst, rms_gradient=rms_gradient, rolloff=rolloff)
    G = xrough.acf_from_spectrum(C, np.geomspace(*LAGS_NM, n_lags))
    if scatter:
        rng = np.random.default_rng(seed)
        values = G.values * (1 + scatter * rng.standard_normal(G.shape))
        G = G.copy(data=values).assign_coords(
            standard_error=("dr", scatter * values, {"units": "nm2",
                                                     "long_name": "standard error of G"}))
        G.attrs = {"units": "nm2", "long_name": "height-difference autocorrelation function",
                   "source": f"model G with {scatter:g} relative scatter"}
    return G


def model_G_stack(n_scans: int = 2, **kwargs) -> xr.DataArray:
    """Several model G (different H and amplitude) on a ``scan`` dim, same lags."""
    params = [(0.8, 0.5), (0.6, 0.3), (0.9, 1.0)][:n_scans]
    curves = [model_G(hurst=h, rms_gradient=g, seed=k, **kwargs)
              for k, (h, g) in enumerate(params)]
    G = xr.concat(curves, dim="scan", combine_attrs="override")
    return G.assign_coords(scan=("scan", np.arange(n_scans)))


def surface_nm(*, n: int = 128, seed: int = 1, periodic: bool = True,
               hurst: float = 0.8) -> xr.DataArray:
    """A synthetic map of 4 n nm with lambda_r = 200 nm and lambda_s = 8 nm, in nm."""
    topo = xrough.self_affine_surface(hurst=hurst, lambda_r="200 nm", lambda_s="8 nm",
                                      size=f"{4 * n} nm", n=n, rms_gradient=0.3, seed=seed,
                                      unit="nm")
    return topo if periodic else topo.assign_attrs(periodic=0)


# --------------------------------------------------------------------------- variables
def variables(obj) -> dict[str, xr.Variable]:
    """Every variable of a Dataset, or a DataArray's data (as ``"<data>"``) and coords."""
    if isinstance(obj, xr.DataArray):
        out = {"<data>": obj.variable}
        out.update({k: obj.coords[k].variable for k in obj.coords})
        return out
    return dict(obj.variables)


def _map_variables(obj, func):
    """``obj`` with ``func(name, variable)`` applied to every data variable and coord."""
    if isinstance(obj, xr.DataArray):
        mapped = func("<data>", obj.variable)
        coords = {k: func(k, obj.coords[k].variable) for k in obj.coords}
        return xr.DataArray(mapped, coords=coords, name=obj.name)
    variables = {k: func(k, v) for k, v in obj.variables.items()}
    return xr.Dataset({k: variables[k] for k in obj.data_vars},
                      coords={k: variables[k] for k in obj.coords}, attrs=dict(obj.attrs))


def _length_power(units: str | None) -> int | None:
    """``p`` if ``units`` is length^p (0 for dimensionless), None otherwise."""
    if units is None:
        return None
    dim = xu.parse_units(units).dimensionality
    if not dim:
        return 0
    if set(dim) == {"[length]"}:
        return int(dim["[length]"])
    return None


def in_length_unit(obj, unit: str, *, own_unit: str = "nm"):
    """The same data with every variable in length^p (p != 0) expressed in ``unit^p``.

    Heights and coordinates of a topography, G and its ``dr``, ``standard_error``...:
    the same physics in another unit. Counts, Pa and dimensionless data are untouched.
    The attrs in :data:`LENGTH_ATTRS` (e.g. the model wavenumbers of a synthetic surface,
    in ``own_unit``) are converted too.
    """
    def convert(name, var):
        units = var.attrs.get("units")
        p = _length_power(units)
        if not p:
            return var
        new = xu.power_units(unit, p)
        out = var.copy(data=np.asarray(var.values, dtype=float)
                       * xu.conversion_factor(units, new))
        out.attrs = {**var.attrs, "units": new}
        return out

    out = _map_variables(obj, convert)
    factor = xu.conversion_factor(own_unit, unit)
    for key, power in LENGTH_ATTRS.items():
        if key in obj.attrs:
            value = np.asarray(obj.attrs[key], dtype=float) * factor**power
            out.attrs[key] = float(value) if value.ndim == 0 else value
    return out


def to_si(obj):
    """Every variable with ``units`` converted to SI base units (kg, m, s)."""
    def convert(name, var):
        units = var.attrs.get("units")
        if units is None:
            return var
        q = xu.ureg.Quantity(1.0, xu.parse_units(units)).to_base_units()
        out = var.copy()
        if var.dtype.kind == "f":
            out = var.copy(data=var.values * q.magnitude)
        elif q.magnitude != 1:
            raise AssertionError(f"{name}: integer data in {units!r}")
        out.attrs = {**var.attrs, "units": str(q.units)}
        return out

    return _map_variables(obj, convert)


def assert_same_physics(a, b, *, rtol: float, atol_frac: float = 0.0,
                        tolerances: dict | None = None) -> None:
    """``a`` and ``b`` hold the same numbers once both are in SI units.

    Same variables, dims and SI units; float values within ``rtol`` plus ``atol_frac``
    times the largest ``|value|`` of the variable (for data that cross zero), or the
    per-variable ``tolerances[name] = (rtol, atol_frac)``; other dtypes equal.
    """
    sa, sb = to_si(a), to_si(b)
    assert_units_equal(sa, sb)  # also the same variables, dims and shapes
    va, vb = variables(sa), variables(sb)
    tolerances = tolerances or {}
    for name, x in va.items():
        y = vb[name]
        r, af = tolerances.get(name, (rtol, atol_frac))
        if x.dtype.kind == "f":
            xv = np.asarray(x.values, dtype=float)
            finite = np.abs(xv[np.isfinite(xv)])
            scale = float(finite.max()) if finite.size else 0.0
            np.testing.assert_allclose(np.asarray(y.values, dtype=float), xv, rtol=r,
                                       atol=af * scale, equal_nan=True, err_msg=name)
        else:
            np.testing.assert_array_equal(y.values, x.values, err_msg=name)


#: Numeric attrs that are lengths (power of the length unit of the object they sit on).
LENGTH_ATTRS = {
    "pixel_size": 1, "scan_size": 1, "dr_min": 1, "dr_max": 1, "dr_min_supported": 1,
    "dr_max_supported": 1, "reliable_dr_min": 1, "reliable_dr_max": 1, "rms_height": 1,
    "sigma_h2": 2, "q_r": -1, "q_s": -1, "q_0": -1, "q_min_supported": -1,
    "q_max_supported": -1, "C_r": 4, "x_centre": 1, "y_centre": 1,
    "uncovered_dr_min": 1, "uncovered_dr_max": 1,
}
#: String attrs that spell a unit or lengths with their unit (compared through the data).
UNIT_TEXT = {"dr_units", "reliable_dr_units", "lateral_units", "windows", "window_rules",
             "dr_restricted_to", "fixed", "overrides", "reliable_rule",
             "uncovered_dr_units"}


def assert_same_attrs(a, b, unit_a: str, unit_b: str, *, rtol: float = 1e-10,
                      tolerances: dict | None = None) -> None:
    """Attrs of ``a`` (lengths in ``unit_a``) and ``b`` (in ``unit_b``) say the same.

    Same keys everywhere; numeric attrs equal within ``rtol`` after converting those in
    :data:`LENGTH_ATTRS` (``tolerances[key]`` overrides ``rtol``); strings equal except
    those in :data:`UNIT_TEXT`; every
    variable's attrs other than ``units`` identical (units are compared through the data
    by :func:`assert_same_physics`).
    """
    assert set(a.attrs) == set(b.attrs), f"attrs differ: {sorted(set(a.attrs) ^ set(b.attrs))}"
    for key, x in a.attrs.items():
        y = b.attrs[key]
        if key == "units" or key in UNIT_TEXT:
            continue
        if isinstance(x, (str, bytes)):
            assert x == y, f"attr {key!r}: {x!r} != {y!r}"
            continue
        factor = xu.conversion_factor(unit_b, unit_a) ** LENGTH_ATTRS.get(key, 0)
        np.testing.assert_allclose(np.asarray(y, dtype=float) * factor,
                                   np.asarray(x, dtype=float),
                                   rtol=(tolerances or {}).get(key, rtol),
                                   err_msg=f"attr {key!r}")
    va, vb = variables(a), variables(b)
    for name, var in va.items():
        if name == "<data>":
            continue
        ka = {k: v for k, v in var.attrs.items() if k != "units"}
        kb = {k: v for k, v in vb[name].attrs.items() if k != "units"}
        # flag values are arrays (CF): compare them as arrays, the rest as they are
        assert set(ka) == set(kb) and all(
            np.array_equal(ka[k], kb[k]) if isinstance(ka[k], np.ndarray) else ka[k] == kb[k]
            for k in ka), f"attrs of {name!r} differ: {ka} != {kb}"


def assert_attrs_close(got: dict, ref: dict, *, rtol: float, what: str = "attrs") -> None:
    """Same keys; numbers (and numeric arrays) within ``rtol``; everything else equal."""
    assert set(got) == set(ref), f"{what} differ: {sorted(set(got) ^ set(ref))}"
    for key, x in ref.items():
        y = got[key]
        if isinstance(x, (str, bytes)) or isinstance(y, (str, bytes)):
            assert x == y, f"{what}[{key!r}]: {y!r} != {x!r}"
        else:
            np.testing.assert_allclose(np.asarray(y, dtype=float), np.asarray(x, dtype=float),
                                       rtol=rtol, err_msg=f"{what}[{key!r}]")
