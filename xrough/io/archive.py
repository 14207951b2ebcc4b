"""Archive a whole analysis to one NetCDF4 file and reopen it identical.

An analysis is a mapping of names to results (topography, G, fit, Persson results...),
or a mapping of measurement names to such mappings. It is written as a
:class:`xarray.DataTree`: one group per measurement and result, CF ``units`` on every
variable and coordinate (the results carry them already), and provenance at the root
(xrough version, creation time, the ``Conventions``) and per measurement (input file name
and SHA-256 where the topography came from a file, every parameter in the results'
attrs). :func:`open_analysis` returns the same nested mapping, each object identical to
what was saved.
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Mapping
from pathlib import Path

import xarray as xr

from .._version import __version__

__all__ = ["save_analysis", "open_analysis"]

_KIND = "xrough_object"  # "DataArray" or "Dataset", so that reopening restores the type
_NAME = "xrough_dataarray_name"


def _as_dataset(obj: xr.DataArray | xr.Dataset, where: str) -> xr.Dataset:
    if isinstance(obj, xr.DataArray):
        name = obj.name if obj.name is not None else "data"
        ds = obj.to_dataset(name=str(name), promote_attrs=False)
        ds.attrs = {_KIND: "DataArray", _NAME: str(name)}
        return ds
    if isinstance(obj, xr.Dataset):
        ds = obj.copy()
        ds.attrs = {**obj.attrs, _KIND: "Dataset"}
        return ds
    raise TypeError(f"{where}: can only archive xarray DataArrays and Datasets, got "
                    f"{type(obj).__name__}")


def _restore(ds: xr.Dataset) -> xr.DataArray | xr.Dataset:
    kind = ds.attrs.get(_KIND)
    if kind == "DataArray":
        name = ds.attrs[_NAME]
        da = ds[name]
        da.name = name
        return da
    attrs = {k: v for k, v in ds.attrs.items() if k != _KIND}
    ds = ds.copy()
    ds.attrs = attrs
    return ds


def save_analysis(path: str | Path, analysis: Mapping, *, history: str | None = None) -> Path:
    """Write an analysis (nested mapping of results) to a NetCDF4 file.

    Parameters
    ----------
    path : str or Path
        Output file (``.nc``).
    analysis : mapping
        ``{"topography": topo, "G": G, "fit": fit, ...}`` for one measurement, or
        ``{"afm": {...}, "stylus": {...}}`` for several (one group each).
    history : str, optional
        A line for the ``history`` attribute (e.g. the command that produced it).

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    TypeError
        An entry that is not an xarray object or a mapping.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np, xrough
    >>> topo = xrough.topography(np.random.default_rng(0).normal(size=(32, 32)),
    ...                          spacing=1.0, unit="nm")
    >>> G = topo.rough.acf()
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "analysis.nc"
    >>> _ = xrough.save_analysis(path, {"topography": topo, "G": G})
    >>> back = xrough.open_analysis(path)
    >>> xr.testing.assert_identical(back["G"], G)
    """
    path = Path(path)
    tree: dict[str, xr.Dataset] = {}

    def walk(prefix: str, mapping: Mapping) -> None:
        for key, value in mapping.items():
            key = str(key)
            if "/" in key or not key:
                raise ValueError(f"group names must be non-empty and contain no '/': {key!r}")
            where = f"{prefix}/{key}"
            if isinstance(value, Mapping) and not isinstance(value, xr.Dataset):
                walk(where, value)
            else:
                tree[where] = _as_dataset(value, where)

    walk("", analysis)
    now = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    root = xr.Dataset(attrs={
        "Conventions": "CF-1.10",
        "title": "xrough analysis",
        "xrough_version": __version__,
        "created": now,
        "history": f"{now}: {history or 'written by xrough.save_analysis'}",
    })
    dt = xr.DataTree.from_dict({"/": root, **tree})
    dt.to_netcdf(path, engine="netcdf4")
    return path


def open_analysis(path: str | Path) -> dict:
    """Reopen a file written by :func:`save_analysis` as the same nested mapping.

    The root's provenance attributes are under the key ``"_provenance"``.
    """
    path = Path(path)
    out: dict = {}
    with xr.open_datatree(path, engine="netcdf4") as dt:
        for node in dt.subtree:
            if node.is_root:
                out["_provenance"] = dict(node.attrs)
                continue
            ds = node.to_dataset(inherit=False).load()
            if _KIND not in ds.attrs:
                continue  # an intermediate group
            parts = node.path.strip("/").split("/")
            target = out
            for part in parts[:-1]:
                target = target.setdefault(part, {})
            target[parts[-1]] = _restore(ds)
    return out
