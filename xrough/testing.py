"""Assertions for xarray objects whose units live in ``units`` attributes.

Like :mod:`xarray.testing` (and pint-xarray's ``pint_xarray.testing``), for the objects
xrough reads and writes: the data and every coordinate carry a CF ``units`` attribute, and
two results that describe the same physics in different units (a G in nm2 over lags in nm,
and the same G in m2 over lags in m) compare equal.

- :func:`assert_units_equal`: the same units on the data and on every coordinate;
- :func:`assert_allclose`: the same numbers once converted to the units of the first
  object, with an absolute tolerance that may carry its own unit;
- :func:`assert_netcdf_round_trip`: written to NetCDF and read back, identical (values,
  coordinates, attributes, names).

``import xrough.testing`` (it is not imported by ``import xrough``).
"""

from __future__ import annotations

import os
from collections.abc import Hashable

import numpy as np
import xarray as xr

from xrough import units as xu
from xrough.units import QuantityLike

__all__ = ["assert_units_equal", "assert_allclose", "assert_netcdf_round_trip"]

#: The key of a DataArray's own data among its variables (coordinates use their names).
DATA = "<data>"


def _require(ok: bool, message: str) -> None:
    """Raise AssertionError(message) unless ``ok`` (kept under ``python -O``)."""
    if not ok:
        raise AssertionError(message)


def _variables(obj: xr.DataArray | xr.Dataset) -> dict[Hashable, xr.Variable]:
    """Every variable: a DataArray's data (as :data:`DATA`) and coords, or a Dataset's."""
    if isinstance(obj, xr.DataArray):
        return {DATA: obj.variable, **{k: obj.coords[k].variable for k in obj.coords}}
    if isinstance(obj, xr.Dataset):
        return dict(obj.variables)
    raise TypeError(f"expected an xarray DataArray or Dataset, got {type(obj).__name__}")


def _same_variables(a, b) -> tuple[dict, dict]:
    """Return the variables of ``a`` and ``b``; fail unless names, dims and shapes agree."""
    va, vb = _variables(a), _variables(b)
    _require(type(a) is type(b), f"types differ: {type(a).__name__} != {type(b).__name__}")
    _require(set(va) == set(vb), f"variables differ: {sorted(set(va) ^ set(vb), key=str)}")
    for name, x in va.items():
        _require(x.dims == vb[name].dims, f"{name}: dims {x.dims} != {vb[name].dims}")
        _require(x.shape == vb[name].shape,
                 f"{name}: shape {x.shape} != {vb[name].shape}")
    return va, vb


def _units(var: xr.Variable, name: str):
    """Return the parsed ``units`` of a variable, or None when it has none."""
    text = var.attrs.get("units")
    return None if text is None else xu.parse_units(text, what=f"units of {name}")


def assert_units_equal(a: xr.DataArray | xr.Dataset, b: xr.DataArray | xr.Dataset) -> None:
    """Assert that ``a`` and ``b`` have the same units on the data and on every coordinate.

    Units are compared by meaning (``"nm2"``, ``"nm^2"`` and ``"nm**2"`` are equal), not
    by spelling; a variable without a ``units`` attribute must have none in the other
    object too. Values and other attributes are not compared.

    Parameters
    ----------
    a, b : xarray.DataArray or xarray.Dataset
        Objects with the same variables (a DataArray's data and coords, or a Dataset's
        data variables and coords).

    Raises
    ------
    AssertionError
        Naming the first variable whose units differ (or the variables one object lacks).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> from xrough.testing import assert_units_equal
    >>> topo = xrough.topography(np.zeros((2, 3)), spacing=1.0, unit="nm")
    >>> assert_units_equal(topo, topo.assign_attrs(units="nm^1"))
    >>> assert_units_equal(topo, topo.assign_coords(x=topo.x.assign_attrs(units="um")))
    Traceback (most recent call last):
    ...
    AssertionError: x: units 'nm' != 'um'
    """
    va, vb = _same_variables(a, b)
    for name, x in va.items():
        ua, ub = _units(x, name), _units(vb[name], name)
        _require(ua == ub, f"{name}: units {x.attrs.get('units')!r} != "
                           f"{vb[name].attrs.get('units')!r}")


def _in_units_of(x: xr.Variable, y: xr.Variable, name: str) -> np.ndarray:
    """Return the values of ``y`` in the units of ``x`` (no units on both: unchanged)."""
    ux, uy = _units(x, name), _units(y, name)
    if ux is None or uy is None:
        _require(ux is None and uy is None, f"{name}: units {x.attrs.get('units')!r} "
                                            f"!= {y.attrs.get('units')!r}")
        return np.asarray(y.values)
    try:
        factor = xu.conversion_factor(uy, ux)
    except Exception as err:  # noqa: BLE001 - pint's DimensionalityError and the like
        raise AssertionError(f"{name}: units {y.attrs['units']!r} cannot be converted to "
                             f"{x.attrs['units']!r} ({err})") from None
    return np.asarray(y.values) * factor if factor != 1 else np.asarray(y.values)


def _atol_in(atol: QuantityLike, var: xr.Variable, name: str) -> float:
    """Return ``atol`` in the units of ``var``.

    Plain numbers as they are; with units, converted where the dimensions agree and 0
    where they do not (a height tolerance on the lateral coordinate ``x``).
    """
    if isinstance(atol, (int, float, np.number)) and np.ndim(atol) == 0:
        return float(atol)
    units = _units(var, name)
    q = xu.quantity(atol, what="atol")
    if units is None or q.dimensionality != xu.ureg.Quantity(1, units).dimensionality:
        return 0.0
    return float(q.to(units).magnitude)


def assert_allclose(a: xr.DataArray | xr.Dataset, b: xr.DataArray | xr.Dataset, *,
                    rtol: float = 1e-7, atol: QuantityLike = 0.0) -> None:
    """Assert that ``a`` and ``b`` hold the same values once ``b`` is in the units of ``a``.

    Every variable of ``b`` (data and coordinates) is converted to the units of the same
    variable of ``a`` and compared with ``|b - a| <= atol + rtol |a|`` (NaN where both are
    NaN); variables without units, or that are not floats, compare as they are (integers,
    strings and dates exactly). Names of variables, dims and shapes must agree; attributes
    other than ``units`` are not compared (like :func:`xarray.testing.assert_allclose`).

    Parameters
    ----------
    a, b : xarray.DataArray or xarray.Dataset
        The reference and the object checked against it.
    rtol : float
        Relative tolerance, dimensionless.
    atol : float, str or pint.Quantity
        Absolute tolerance. A plain number is in the units of each variable of ``a`` (as
        in :func:`numpy.testing.assert_allclose`). With units (``"1e-3 nm"``, a pint
        Quantity) it applies to the variables of the same dimension, converted to their
        units, and the others get ``atol = 0``.

    Raises
    ------
    AssertionError
        Naming the first variable that differs, or whose units cannot be converted
        (``"nm"`` against ``"Pa"``).
    ValueError
        If ``atol`` is a string that is not a quantity.

    Examples
    --------
    The same topography in nm and in um:

    >>> import numpy as np, xrough
    >>> from xrough.testing import assert_allclose
    >>> nm = xrough.topography(np.array([[0.0, 2.0], [3.0, 4.0]]), spacing=1.0, unit="nm")
    >>> um = xrough.topography(nm.values * 1e-3, spacing=1e-3, unit="um")
    >>> assert_allclose(nm, um, rtol=1e-12)
    >>> assert_allclose(nm, um + 1e-9, rtol=0, atol="0.01 nm")  # 1e-9 um = 1e-6 nm
    >>> assert_allclose(nm, um * 1.01, rtol=1e-3)
    Traceback (most recent call last):
    ...
    AssertionError: ...
    """
    va, vb = _same_variables(a, b)
    for name, x in va.items():
        y = _in_units_of(x, vb[name], name)
        if x.dtype.kind in "fc" and np.asarray(y).dtype.kind in "fc":
            np.testing.assert_allclose(y, x.values, rtol=rtol, atol=_atol_in(atol, x, name),
                                       equal_nan=True, err_msg=name)
        else:
            np.testing.assert_array_equal(y, x.values, err_msg=name)


def assert_netcdf_round_trip(obj: xr.DataArray | xr.Dataset,
                             path: str | os.PathLike) -> xr.DataArray | xr.Dataset:
    """Write ``obj`` to the NetCDF file ``path``, read it back and assert it is identical.

    Identical as :func:`xarray.testing.assert_identical` sees it: values, dims, coordinates,
    names and every attribute (provenance, units, quality flags) of the data and of each
    variable. The file stays at ``path``.

    Parameters
    ----------
    obj : xarray.DataArray or xarray.Dataset
        A topography, a G, or any result of xrough.
    path : str or os.PathLike
        The file to write (overwritten if it exists).

    Returns
    -------
    xarray.DataArray or xarray.Dataset
        The object read back, loaded into memory (the file is closed).

    Raises
    ------
    AssertionError
        If the object read back differs, with xarray's description of the difference.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np, xrough
    >>> from xrough.testing import assert_netcdf_round_trip
    >>> topo = xrough.topography(np.ones((4, 4)), spacing=1.0, unit="nm",
    ...                          attrs={"instrument": "AFM"})
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     back = assert_netcdf_round_trip(topo.rough.acf(), pathlib.Path(folder) / "G.nc")
    >>> back.attrs["units"], back.dr.attrs["units"], back.attrs["instrument"]
    ('nm2', 'nm', 'AFM')
    """
    obj.to_netcdf(path)
    opener = xr.open_dataarray if isinstance(obj, xr.DataArray) else xr.open_dataset
    with opener(path) as stored:
        back = stored.load()
    xr.testing.assert_identical(back, obj)
    return back
