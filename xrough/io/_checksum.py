"""Integrity of the NetCDF files and Zarr stores xrough writes: no flipped byte reopens changed.

Two layers, each doing what the other cannot:

- **Per-chunk checksums of the storage library** on the values of every numeric variable
  (:func:`chunk_encoding`): HDF5's Fletcher-32 filter in NetCDF-4 files (not on scalars,
  which HDF5 stores unchunked), a CRC-32C filter (``numcodecs.CRC32C``) in Zarr stores.
  The library checks a chunk each time it reads it, eagerly or lazily from a dask task,
  with no second read; :func:`reading` and :func:`checked_getter` turn its failure into
  a :class:`~xrough.io._common.CorruptedFileError` naming the file and the variable.
- **SHA-256 digests of the rest**, in the one global attribute ``xrough`` (JSON, see
  :data:`KEY`): per group, of its attributes, of the names, dims, shapes, dtypes,
  attributes and decoding (fill value, scale) of its variables, and of the values of the
  variables without a per-chunk checksum (scalars and strings; every variable of a
  NetCDF-3 file, which has no filters). :func:`digests` computes them from the file read
  back after writing, :func:`verify` compares them when it is opened; no values of
  checksummed variables are read for that, so a lazy open stays lazy.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
from collections.abc import Iterable, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import netCDF4
import numpy as np
import xarray as xr

from .._kernels.deferred import dask_array_core
from ._common import HDF5_LOCK, CorruptedFileError, raw_hdf5

__all__ = ["KEY", "LEGACY", "chunk_encoding", "digests", "stamp", "stored", "verify",
           "reading", "checked_getter", "lazy_kwargs", "missing_counts", "check_missing"]

#: The global attribute that holds, as JSON, ``{"groups": {path: entry}}``: per group the
#: SHA-256 digests (``entry["sha256"]``: ``""`` for the group, else a variable's name) and
#: whatever else the writer keeps there (the archive's record of what each group holds).
KEY = "xrough"
#: The per-variable attribute of files written by xrough before :data:`KEY` (not verified).
LEGACY = "xrough_sha256"
#: Encoding entries that change the values xarray decodes, hashed with the attributes.
_DECODING = ("dtype", "_FillValue", "missing_value", "scale_factor", "add_offset",
             "_Unsigned", "units", "calendar")


def chunk_encoding(var: xr.Variable, fmt: str) -> dict:
    """Return the encoding that gives ``var`` a per-chunk checksum in format ``fmt``, if any.

    Parameters
    ----------
    var : xarray.Variable
        The variable to write.
    fmt : {"netcdf4", "netcdf3", "zarr"}
        NetCDF-4 (HDF5, also the classic model), NetCDF-3 or a Zarr store.

    Returns
    -------
    dict
        ``{"fletcher32": True}`` (NetCDF-4, numeric with dimensions; a dask-backed
        variable's chunks as its ``chunksizes``, as Zarr stores them), ``{"filters":
        [CRC32C()]}`` (Zarr, numeric), else ``{}`` (strings; NetCDF-3 has no filters).

    Examples
    --------
    >>> chunk_encoding(xr.Variable(("x",), [1.0, 2.0]), "netcdf4")
    {'fletcher32': True}
    >>> chunk_encoding(xr.Variable((), 1.0), "netcdf4"), chunk_encoding(xr.Variable(
    ...     ("x",), ["a"]), "zarr"), chunk_encoding(xr.Variable(("x",), [1.0]), "netcdf3")
    ({}, {}, {})
    """
    if var.dtype.kind not in "biufmM":
        return {}
    if fmt == "zarr":
        import zarr

        return {"filters": [zarr.registry.get_numcodec({"id": "crc32c"})]}
    if fmt != "netcdf4" or not var.ndim:
        return {}
    if var.chunks is None:
        return {"fletcher32": True}
    return {"fletcher32": True, "chunksizes": tuple(c[0] for c in var.chunks)}


def _has_chunk_checksum(var: xr.Variable) -> bool:
    """Whether the storage library checks ``var`` (as opened) chunk by chunk."""
    filters = var.encoding.get("filters") or ()
    return (var.encoding.get("fletcher32") is True
            or any(getattr(f, "codec_id", None) == "crc32c" for f in filters))


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


def _sha256(head: Any, values: np.ndarray | None = None) -> str:
    digest = hashlib.sha256(json.dumps(_canonical(head), sort_keys=True).encode("utf-8"))
    if values is not None and values.dtype.kind in "biufcmM":
        digest.update(np.ascontiguousarray(values, values.dtype.newbyteorder("<")).tobytes())
    elif values is not None:
        digest.update(json.dumps(_canonical(values.ravel().tolist())).encode("utf-8"))
    return digest.hexdigest()


def _variable_sha256(var: xr.Variable) -> str:
    """Digest of a variable's dims, shape, dtype, attributes, decoding, and values.

    The values only without a per-chunk checksum (they must then be in memory).
    """
    checked = _has_chunk_checksum(var)
    head = {"dims": [str(d) for d in var.dims], "shape": list(var.shape),
            "dtype": var.dtype.str, "attrs": dict(var.attrs), "chunk_checksum": checked,
            "decoding": {k: var.encoding[k] for k in _DECODING if k in var.encoding}}
    return _sha256(head, None if checked else np.asarray(var.values))


def digests(ds: xr.Dataset, children: Iterable[str] = (), entry: Mapping | None = None
            ) -> dict[str, str]:
    """SHA-256 digests of one group as read: ``""`` the group's, else each variable's.

    Parameters
    ----------
    ds : xarray.Dataset
        The group as opened (the values of variables without a per-chunk checksum in
        memory); its attribute :data:`KEY` is left out.
    children : iterable of str
        Names of its subgroups.
    entry : mapping, optional
        What the writer records about the group in :data:`KEY` (JSON); its ``"sha256"``
        is left out.

    Returns
    -------
    dict

    Examples
    --------
    >>> ds = xr.Dataset({"h": ("x", [1.0, 2.0], {"units": "nm"})})
    >>> sums = digests(ds)
    >>> sorted(sums), sums == digests(ds.copy(deep=True))
    (['', 'h'], True)
    >>> sums["h"] == digests(ds.assign(h=ds.h.assign_attrs(units="um")))["h"]
    False
    """
    group = {"attrs": {k: v for k, v in ds.attrs.items() if k != KEY},
             "coords": sorted(map(str, ds.coords)), "data_vars": sorted(map(str, ds.data_vars)),
             "children": sorted(map(str, children)),
             "entry": {k: v for k, v in (entry or {}).items() if k != "sha256"}}
    return {"": _sha256(group), **{str(n): _variable_sha256(v) for n, v in ds.variables.items()}}


def stamp(path: Path, fmt: str, groups: Mapping[str, Mapping]) -> None:
    """Store ``{"groups": groups}`` in the global attribute :data:`KEY` of a file or store."""
    text = json.dumps({"groups": groups}, sort_keys=True)
    if fmt == "zarr":
        import zarr

        zarr.open_group(path, mode="r+").attrs[KEY] = text
        zarr.consolidate_metadata(path)
        return
    with raw_hdf5(), netCDF4.Dataset(path, "a") as nc:
        nc.setncattr(KEY, text)


def stored(name: str, attrs: Mapping) -> dict | None:
    """Return the groups recorded in a root's attribute :data:`KEY` (``None`` without one).

    Raises
    ------
    CorruptedFileError
        The attribute is not the JSON xrough writes.
    """
    if KEY not in attrs:
        return None
    try:
        groups = json.loads(attrs[KEY])["groups"]
        if isinstance(groups, dict) and all(isinstance(e.get("sha256"), dict)
                                            for e in groups.values()):
            return groups
    except (TypeError, ValueError, KeyError, AttributeError):
        pass
    raise CorruptedFileError(f"{name}: corrupted file: its attribute {KEY!r} is not the "
                             "record of checksums xrough writes; refused")


def verify(name: str, group: str, ds: xr.Dataset, children: Iterable[str],
           entry: Mapping | None) -> None:
    """Compare a group's and its variables' digests with those stored for it.

    The values of variables without a per-chunk checksum are read (into ``ds``) if they
    are not in memory yet; those of the others are checked by the storage library as
    their chunks are read, and are not read here.

    Parameters
    ----------
    name : str
        The file, named in the message.
    group : str
        The group's path, named in the message.
    ds : xarray.Dataset
        The group as opened.
    children : iterable of str
        Names of its subgroups.
    entry : mapping or None
        The group's record in :data:`KEY` (``None``: the file has none for the group).

    Raises
    ------
    CorruptedFileError
        A digest that differs, a variable or group without one, a stored digest of a
        variable the group lacks; the message names the file and the group or variable.

    Examples
    --------
    >>> ds = xr.Dataset({"h": ("x", [1.0, 2.0])})
    >>> verify("a.nc", "/", ds, (), {"sha256": {**digests(ds), "h": "0" * 64}})
    Traceback (most recent call last):
    ...
    xrough.io._common.CorruptedFileError: a.nc: checksum mismatch in variable 'h' of group '/': ...
    """
    if entry is None:
        raise CorruptedFileError(f"{name}: group {group!r} has no checksum although the "
                                 "rest of the file has: a corrupted file; refused")
    for var_name, var in ds.variables.items():
        if not _has_chunk_checksum(var):
            with reading(name, f"variable {str(var_name)!r} of group {group!r}"):
                var.load()
    sums = digests(ds, children, entry)
    for key in sorted(set(sums) | set(entry["sha256"]), key=bool):
        if entry["sha256"].get(key) != sums.get(key):
            what = f"variable {key!r} of group {group!r}" if key else f"group {group!r}"
            raise CorruptedFileError(
                f"{name}: checksum mismatch in {what}: its values, attributes or layout are "
                "not those xrough wrote (a corrupted file); refused rather than returning "
                "changed numbers")


def _unwritten(values: np.ndarray) -> np.ndarray:
    """Mask of the values a skipped chunk reads as: NaN, or NetCDF's default fill value.

    xarray gives floating variables a ``_FillValue`` of NaN; a variable without one (a
    coordinate variable, which CF forbids it; integers) reads as the NetCDF library's
    default fill value of its type (``9.97e36``, ``-2147483647``...).
    """
    mask = np.isnan(values) if values.dtype.kind == "f" else np.zeros(values.shape, bool)
    fill = netCDF4.default_fillvals.get(f"{values.dtype.kind}{values.dtype.itemsize}")
    if fill is not None:
        mask |= values == fill
    return mask


def missing_counts(variables: Mapping[Any, xr.Variable]) -> dict[str, int]:
    """Count the missing values of each numeric variable in memory with a per-chunk checksum.

    Missing values are NaN and the NetCDF library's default fill value of the type (what
    a chunk it skips reads as without a ``_FillValue``). Recorded when written and
    compared by :func:`check_missing`: a damaged index of chunks (HDF5's B-tree nodes have
    no checksum) makes the library skip a chunk and return fill values without reading,
    hence without checking, it.

    Examples
    --------
    >>> missing_counts({"x": xr.Variable(("x",), [0.0, np.nan, 9.969209968386869e36]),
    ...                 "n": xr.Variable(("n",), np.array([1, -2147483647], "i4"))})
    {'x': 2, 'n': 1}
    """
    return {str(n): int(_unwritten(v.values).sum()) for n, v in variables.items()
            if v.dtype.kind in "iuf" and v.ndim and v.chunks is None}


def _no_missing(name: str, where: str, block: np.ndarray) -> np.ndarray:
    if _unwritten(block).any():
        raise CorruptedFileError(f"{name}: corrupted data in {where}: a chunk reads as "
                                 "missing values, none were written (a damaged index of "
                                 "chunks); refused rather than returning changed numbers")
    return block


def check_missing(name: str, group: str, ds: xr.Dataset, counts: Mapping[str, int]) -> None:
    """Compare the missing values of ``ds`` with ``counts`` from :func:`missing_counts`.

    A variable in memory is counted now; a dask-backed one that had none is checked
    chunk by chunk as it is computed (in the same task as the read), else not at all.

    Raises
    ------
    CorruptedFileError
        Naming the file and the variable.
    """
    for var_name, count in counts.items():
        var, where = ds.variables[var_name], f"variable {var_name!r} of group {group!r}"
        if var.chunks is None and int(_unwritten(var.values).sum()) != count:
            raise CorruptedFileError(f"{name}: corrupted data in {where}: {count} missing "
                                     "values were written, other ones read (a damaged "
                                     "index of chunks); refused")
        if var.chunks is not None and count == 0:
            var.data = var.data.map_blocks(functools.partial(_no_missing, name, where),
                                           dtype=var.dtype)


@contextmanager
def reading(name: str, what: str):
    """Turn a failure to read data (a chunk failing its checksum) into a corruption error.

    Parameters
    ----------
    name : str
        The file, named in the message.
    what : str
        What is read (``"variable 'h' of group '/'"``), named in the message.

    Raises
    ------
    CorruptedFileError
        For any error of the storage library but ``MemoryError`` and ``PermissionError``,
        chained: ``"<file>: corrupted data in <what> (<library's error>) ..."``.

    Examples
    --------
    >>> with reading("a.nc", "variable 'h'"):
    ...     raise RuntimeError("NetCDF: HDF error")
    Traceback (most recent call last):
    ...
    xrough.io._common.CorruptedFileError: a.nc: corrupted data in variable 'h' (RuntimeError: ...
    """
    try:
        yield
    except (MemoryError, PermissionError, CorruptedFileError):
        raise
    except Exception as err:  # noqa: BLE001 - HDF5, NetCDF, numcodecs, zarr errors alike
        raise CorruptedFileError(
            f"{name}: corrupted data in {what} ({type(err).__name__}: {str(err)[:200]}): a "
            "chunk fails its checksum or does not decode; refused rather than returning "
            "changed numbers") from err


def _described(array: Any) -> str:
    """Name the variable behind xarray's lazily indexed backend array (best effort)."""
    for _ in range(32):  # xarray's wrappers (lazy indexing, decoding) hold it in .array
        if not hasattr(array, "array"):
            break
        array = array.array
    if hasattr(array, "variable_name"):  # NetCDF4ArrayWrapper
        group = getattr(getattr(array, "datastore", None), "_group", None) or "/"
        return f"variable {array.variable_name!r} of group {group!r}"
    path = getattr(getattr(array, "_array", None), "path", None)  # ZarrArrayWrapper
    if isinstance(path, str):
        group, _, var = path.rpartition("/")
        return f"variable {var!r} of group {'/' + group!r}"
    return "a variable"


def checked_getter(name: str, array, index, asarray=True, lock=None, *,
                   serialize: bool = False):
    """Dask's getter of a chunk, its read failures as :class:`CorruptedFileError`.

    Pass it to :func:`xarray.open_datatree` as ``from_array_kwargs={"getitem":
    functools.partial(checked_getter, name)}``: each dask task reads its chunk once, the
    storage library checks it, and a failure names the file and the variable. With
    ``serialize`` (NetCDF: HDF5 is not thread-safe here) one chunk is read at a time
    under :data:`~xrough.io._common.HDF5_LOCK`: dask's threads reading and closing one
    NetCDF file at once crashed the interpreter.
    """
    with HDF5_LOCK if serialize else contextlib.nullcontext(), reading(
            name, f"a chunk of {_described(array)}"):
        return dask_array_core.getter(array, index, asarray=asarray, lock=lock)


def lazy_kwargs(name: str, fmt: str = "netcdf") -> dict:
    """``from_array_kwargs`` for a lazy open whose chunk reads fail as corruption errors."""
    return {"getitem": functools.partial(checked_getter, name,
                                         serialize=fmt != "zarr")}
