"""SHA-256 checksums of the groups and variables xrough writes to NetCDF files and Zarr stores.

A byte flipped in a NetCDF or Zarr file can reopen without any error from the library,
with other numbers (a changed height, a changed coordinate, a changed fill value that turns
data into missing values). So xrough stores, after writing, an attribute ``xrough_sha256``
on every variable and every group, and compares it with the values it reads:

- a **variable's** checksum is the SHA-256 of its dimensions, shape, dtype, attributes and
  values as read back (decoded by xarray), in C order, little-endian;
- a **group's** checksum is the SHA-256 of its attributes, the names, dimensions and
  attributes of its variables and the names of its subgroups (what a lazy open checks
  without reading any data).

The digests are taken from the file itself, read back the way a reader opens it, so they
are the same for NetCDF-4, NetCDF-3 and Zarr (one mechanism for all formats), and hold
whatever the library does to the values on the way (fill values, dtypes). Reading is
done in blocks along the first dimension, so a variable larger than memory is hashed
without loading it whole.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import netCDF4
import numpy as np
import xarray as xr

__all__ = ["CHECKSUM", "variable_sha256", "group_sha256", "tree_checksums",
           "dataset_checksums", "stamp", "verify_group", "has_checksums", "strip_checksums"]

#: Attribute holding the SHA-256 (hexadecimal) of a group or variable.
CHECKSUM = "xrough_sha256"
#: Bytes of a variable read and hashed at a time (at least one row of its first dim).
_BLOCK_BYTES = 1 << 24


def _canonical(value: Any) -> Any:
    """Return a JSON-able form of an attribute value that keeps its dtype and every bit."""
    if isinstance(value, (np.ndarray, np.generic)):
        return [value.dtype.str, _canonical(np.asarray(value).tolist())]
    if isinstance(value, bytes):
        return ["bytes", value.hex()]
    if isinstance(value, float):
        return ["float", value.hex()]
    if isinstance(value, Mapping):
        return {str(k): _canonical(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    if value is None or isinstance(value, (str, int)):
        return value
    return ["repr", repr(value)]


def _attrs_text(attrs: Mapping) -> str:
    return json.dumps({str(k): _canonical(v) for k, v in attrs.items() if k != CHECKSUM},
                      sort_keys=True)


def _data_bytes(values: np.ndarray) -> bytes:
    if values.dtype.kind in "biufcmM":
        little = values.dtype.newbyteorder("<")
        return np.ascontiguousarray(values, dtype=little).tobytes()
    return json.dumps(_canonical(values.ravel().tolist())).encode("utf-8")


def variable_sha256(var: xr.Variable) -> str:
    """SHA-256 of a variable's dims, shape, dtype, attributes (but its checksum) and values.

    Parameters
    ----------
    var : xarray.Variable
        In memory, lazily indexed from a file, or dask-backed (computed block by block).

    Returns
    -------
    str
        64 hexadecimal digits.

    Examples
    --------
    >>> v = xr.Variable(("x",), np.arange(3.0), {"units": "nm"})
    >>> variable_sha256(v) == variable_sha256(v.copy(deep=True))
    True
    >>> variable_sha256(v) == variable_sha256(xr.Variable(("x",), v.values, {"units": "um"}))
    False
    """
    head = {"dims": [str(d) for d in var.dims], "shape": list(var.shape),
            "dtype": var.dtype.str, "attrs": _attrs_text(var.attrs)}
    digest = hashlib.sha256(json.dumps(head, sort_keys=True).encode("utf-8"))
    if var.ndim == 0 or var.size == 0:
        digest.update(_data_bytes(np.asarray(var.values)))
        return digest.hexdigest()
    row = max(1, var.size // var.shape[0] * var.dtype.itemsize)
    rows = max(1, _BLOCK_BYTES // row)
    for start in range(0, var.shape[0], rows):
        digest.update(_data_bytes(np.asarray(var[start:start + rows].values)))
    return digest.hexdigest()


def group_sha256(attrs: Mapping, variables: Mapping[Any, xr.Variable],
                 children: Iterable[str] = ()) -> str:
    """SHA-256 of a group's attributes, its variables' names, dims and attributes, subgroups.

    Checksum attributes are left out. A lazy open checks this one without reading data.

    Examples
    --------
    >>> a = group_sha256({"title": "x"}, {"h": xr.Variable(("y",), [1.0])})
    >>> a == group_sha256({"title": "x"}, {"h": xr.Variable(("y",), [2.0])})
    True
    >>> a == group_sha256({"title": "x"}, {"g": xr.Variable(("y",), [1.0])})
    False
    """
    text = json.dumps({"attrs": _attrs_text(attrs),
                       "variables": sorted([str(n), [str(d) for d in v.dims],
                                            _attrs_text(v.attrs)]
                                           for n, v in variables.items()),
                       "children": sorted(str(c) for c in children)}, sort_keys=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def dataset_checksums(attrs: Mapping, variables: Mapping[Any, xr.Variable],
                      children: Iterable[str] = ()) -> dict[str | None, str]:
    """Checksums of one group (key ``None``) and of each of its variables (by name)."""
    return {None: group_sha256(attrs, variables, children),
            **{str(n): variable_sha256(v) for n, v in variables.items()}}


def tree_checksums(tree: xr.DataTree) -> dict[str, dict[str | None, str]]:
    """:func:`dataset_checksums` of every group of a tree, by group path."""
    return {node.path: dataset_checksums(node.attrs, node.to_dataset(inherit=False).variables,
                                         node.children)
            for node in tree.subtree}


def stamp(path: Path, sums: Mapping[str, Mapping[str | None, str]], fmt: str) -> None:
    """Store ``sums`` (from :func:`tree_checksums`) as attributes in a NetCDF file or Zarr store."""
    if fmt == "zarr":
        import zarr

        root = zarr.open_group(path, mode="r+")
        for group, entries in sums.items():
            node = root if group == "/" else root[group.lstrip("/")]
            for name, digest in entries.items():
                (node if name is None else node[name]).attrs[CHECKSUM] = digest
        zarr.consolidate_metadata(path)
        return
    with netCDF4.Dataset(path, "a") as nc:
        for group, entries in sums.items():
            node = nc if group == "/" else nc[group.lstrip("/")]
            for name, digest in entries.items():
                (node if name is None else node.variables[name]).setncattr(CHECKSUM, digest)


def has_checksums(attrs: Mapping, variables: Mapping[Any, xr.Variable]) -> bool:
    """Whether a group or any of its variables carries a checksum."""
    return CHECKSUM in attrs or any(CHECKSUM in v.attrs for v in variables.values())


def _check(name: str, what: str, stored: Any, actual: str) -> None:
    if stored is None:
        raise ValueError(f"{name}: {what} has no checksum ({CHECKSUM}) although the rest "
                         "of the file has: a corrupted file; refused")
    if stored != actual:
        raise ValueError(f"{name}: checksum mismatch in {what}: its values or attributes "
                         "are not those xrough wrote (a corrupted file); refused rather "
                         "than returning changed numbers")


def verify_group(name: str, group: str, attrs: Mapping, variables: Mapping[Any, xr.Variable],
                 children: Iterable[str] = ()) -> None:
    """Compare the stored checksums of a group and of its variables with their contents.

    Every variable's values and attributes are compared, then the group's checksum (its
    attributes, and the names, dims and attributes of its variables). The values of
    dask-backed variables (a lazy open) are not read, hence not compared; their
    attributes are, through the group's checksum.

    Parameters
    ----------
    name : str
        The file, named in the message.
    group : str
        The group's path, named in the message.
    attrs, variables, children
        The group's attributes, variables and subgroup names as read.

    Raises
    ------
    ValueError
        A checksum that differs or is missing; the message names the file and the group
        or variable.

    Examples
    --------
    >>> v = xr.Variable(("x",), [1.0, 2.0], {CHECKSUM: "0" * 64})
    >>> verify_group("a.nc", "/", {CHECKSUM: group_sha256({}, {"h": v})}, {"h": v})
    Traceback (most recent call last):
    ...
    ValueError: a.nc: checksum mismatch in variable 'h' of group '/': ...
    """
    for var_name, var in variables.items():
        if var.chunks is None:
            _check(name, f"variable {str(var_name)!r} of group {group!r}",
                   var.attrs.get(CHECKSUM), variable_sha256(var))
    _check(name, f"group {group!r}", attrs.get(CHECKSUM),
           group_sha256(attrs, variables, children))


def strip_checksums(ds: xr.Dataset) -> None:
    """Remove the checksum attributes of ``ds`` and its variables, in place."""
    ds.attrs.pop(CHECKSUM, None)
    for var in ds.variables.values():
        var.attrs.pop(CHECKSUM, None)
