"""NetCDF topographies: xrough's own files and the common ``heights(x, y)`` layout.

xrough writes a topography with :meth:`xarray.DataArray.to_netcdf` (CF ``units`` on the
heights and on every coordinate); :func:`read` gives back the identical DataArray.

Files from other programs are read too when they hold one height variable (``height``,
``heights``, ``topography``, ``z``... or the only data variable) on dims ``x`` and ``y`` in
either order (``heights(x, y)`` is transposed to xrough's ``(y, x)``), with units in a
``units`` or ``unit`` attribute. A ``length`` attribute on a coordinate (as written by
SurfaceTopography) gives the physical size ``n * spacing`` along it, and a ``periodic``
attribute the periodicity.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from .. import units as u
from ..topography import topography

__all__ = ["sniff", "read", "write"]

_NETCDF3 = (b"CDF\x01", b"CDF\x02", b"CDF\x05")
_HDF5 = b"\x89HDF\r\n\x1a\n"
_EXTENSIONS = (".nc", ".nc4", ".netcdf", ".cdf")
_HEIGHT_NAMES = ("height", "heights", "topography", "topo", "z", "h",
                 "__xarray_dataarray_variable__")
_DATAARRAY_DEFAULT = "__xarray_dataarray_variable__"


def sniff(head: bytes, path: Path) -> bool:
    """Whether ``head`` starts like a NetCDF file.

    NetCDF-3 is recognised by its signature; NetCDF-4 (HDF5) by the HDF5 signature plus a
    NetCDF extension or the NetCDF-4 attributes in the first bytes.

    Parameters
    ----------
    head : bytes
        The first bytes of the file.
    path : pathlib.Path
        The file.

    Returns
    -------
    bool
    """
    if head.startswith(_NETCDF3):
        return True
    if head.startswith(_HDF5):
        return (Path(path).suffix.lower() in _EXTENSIONS or b"_NCProperties" in head
                or b"_Netcdf4" in head)
    return False


def _plain(value):
    """Convert a netCDF attribute value to a Python str, int or float."""
    if isinstance(value, bytes):
        return value.decode("utf-8", errors="replace")
    if isinstance(value, np.ndarray):
        if value.size == 1:
            return _plain(value.reshape(()).item())
        return " ".join(str(_plain(v)) for v in value.ravel().tolist())
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, (list, tuple)):
        return " ".join(str(_plain(v)) for v in value)
    return value


def _units(attrs: dict) -> str | None:
    units = attrs.get("units", attrs.get("unit"))
    return str(_plain(units)) if units is not None else None


def _choose(ds: xr.Dataset, name: str, variable: str | None) -> str:
    if variable is not None:
        if variable not in ds.data_vars:
            raise ValueError(f"{name}: no variable {variable!r} (variables: "
                             f"{', '.join(map(str, ds.data_vars)) or 'none'})")
        return variable
    candidates = [v for v in ds.data_vars if ds[v].ndim >= 1]
    for preferred in _HEIGHT_NAMES:
        if preferred in candidates:
            return preferred
    if len(candidates) == 1:
        return candidates[0]
    if not candidates:
        raise ValueError(f"{name}: no data variable in the root group (an xrough analysis "
                         "archive? open it with xrough.open_analysis, or pass group=)")
    raise ValueError(f"{name}: several variables ({', '.join(map(str, candidates))}); "
                     "choose the heights with variable=")


def read(path, *, variable: str | None = None, group: str | None = None,
         unit: str | None = None, height_unit: str | None = None, size=None) -> xr.DataArray:
    """Read a topography from a NetCDF file.

    Parameters
    ----------
    path : str or Path
        The file.
    variable : str, optional
        Name of the height variable (default: ``height``, ``heights``... or the only one).
    group : str, optional
        NetCDF-4 group holding it.
    unit, height_unit : str, optional
        Units for files that state none (relabel otherwise, as in
        :func:`xrough.io.open_topography`).
    size : float, str, Quantity or pair, optional
        Physical size ``(Ly, Lx)`` for files without coordinates.

    Returns
    -------
    xarray.DataArray
        The topography; a DataArray written by xrough comes back identical.

    Raises
    ------
    ValueError
        No or several candidate variables, dims other than ``x``/``y``, missing units.

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np, xrough
    >>> topo = xrough.topography(np.arange(12.0).reshape(3, 4), spacing="2 nm", unit="nm")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     write(topo, pathlib.Path(tmp) / "t.nc")
    ...     back = read(pathlib.Path(tmp) / "t.nc")
    >>> back.identical(topo)
    True
    """
    path = Path(path)
    name = path.name
    try:
        with xr.open_dataset(path, engine="netcdf4", group=group, decode_times=False) as ds:
            ds = ds.load()
    except OSError as err:
        if not path.is_file():
            raise FileNotFoundError(f"no such file: {path}") from err
        raise ValueError(f"{name}: cannot read as NetCDF ({err})") from None
    var = _choose(ds, name, variable)
    da = ds[var]
    own = "units" in da.attrs and all("units" in da[d].attrs for d in ("x", "y")
                                       if d in da.coords)
    if var == _DATAARRAY_DEFAULT:
        da.name = None
    if "x" not in da.dims:
        raise ValueError(f"{name}: variable {var!r} has dims {da.dims}; a topography needs "
                         "dims ('y', 'x') or ('x',)")
    core = ("y", "x") if "y" in da.dims else ("x",)
    da = da.transpose(..., *core)
    attrs = {str(k): _plain(v) for k, v in da.attrs.items()}
    hunit = height_unit or unit or _units(attrs)
    if hunit is None:
        raise ValueError(f"{name}: variable {var!r} has no units attribute; pass unit= or "
                         "height_unit=")
    attrs.pop("unit", None)
    attrs["units"] = hunit if own and not (height_unit or unit) else u.format_units(hunit)
    periodic = attrs.get("periodic")
    lunit = unit
    for d in core:
        if d not in da.coords:
            continue
        cattrs = {str(k): _plain(v) for k, v in da[d].attrs.items()}
        values = da[d].values
        if not own:  # SurfaceTopography's layout: unit, length and periodic per coordinate
            flag = cattrs.pop("periodic", None)
            periodic = flag if periodic is None else periodic
            length = cattrs.pop("length", None)
            if length is not None:  # the stated size n * spacing wins over the values
                values = values[0] + np.arange(da.sizes[d]) * float(length) / da.sizes[d]
        cunit = unit or _units(cattrs)
        if cunit is None:
            raise ValueError(f"{name}: coordinate {d!r} has no units attribute; pass unit=")
        cattrs.pop("unit", None)
        cattrs["units"] = cunit if own and not unit else u.format_units(cunit)
        lunit = lunit or cunit
        da = da.assign_coords({d: (d, values, cattrs)})
    if periodic is not None:
        attrs["periodic"] = int(bool(int(periodic)))
    da.attrs = attrs
    da.encoding = {}
    for d in da.coords:
        da[d].encoding = {}
    if not own:
        da.name = "height"
        da.attrs.setdefault("long_name", "height")
    missing = [d for d in core if d not in da.coords]
    if missing:
        if size is None:
            raise ValueError(f"{name}: no coordinate for {', '.join(missing)}: pass size=")
        return topography(da, size=size, unit=lunit, height_unit=da.attrs["units"])
    if size is not None:
        return topography(da.drop_vars(list(core)), size=size, unit=lunit,
                          height_unit=da.attrs["units"])
    return topography(da)


def write(topo: xr.DataArray, path) -> None:
    """Write a topography to NetCDF (the DataArray as it is, read back identical).

    Parameters
    ----------
    topo : xarray.DataArray
        A topography (:func:`xrough.topography`).
    path : str or Path
        The output file (NetCDF-4).
    """
    topography(topo)  # validate before writing
    topo.to_netcdf(path, engine="netcdf4")
