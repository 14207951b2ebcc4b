"""Archive a whole analysis to one NetCDF4 file or Zarr store and reopen it identical.

An analysis is a mapping of names to results (topography, G, fit, Persson results...),
or a mapping of measurement names to such mappings. It is written as a
:class:`xarray.DataTree`: one group per measurement and result, CF ``units`` on every
variable and coordinate (the results carry them already), and provenance at the root
(xrough version, creation time, the ``Conventions``) and per measurement (input file name
and SHA-256 where the topography came from a file, every parameter in the results'
attrs). :func:`open_analysis` returns the same nested mapping, each object identical to
what was saved (:func:`xarray.testing.assert_identical`).

Two storage formats
-------------------
- **NetCDF4** (the default): one file, read by every NetCDF tool.
- **Zarr** (a path ending in ``.zarr``, or ``format="zarr"``; ``pip install
  xrough[zarr]``): a directory store of Zarr format 2 with consolidated metadata, one
  compressed file per chunk; dask-backed variables keep their chunks, and
  :func:`open_analysis` with ``chunks={}`` reopens them lazily with the same chunks.

Both formats hold the same archive: the same groups, names, attributes and rules.

Nothing is lost
---------------
Writes are atomic (a failed or killed save leaves the previous archive untouched); every
chunk of every numeric variable carries the storage library's checksum and everything
else a SHA-256 digest, so a changed file is refused with a
:class:`~xrough.io._common.CorruptedFileError`; each group is plain CF for other tools,
what xrough needs to reopen it being one JSON global attribute ``xrough``; errors name
the file; incomplete Zarr stores and sizes their metadata cannot hold are refused; what
NetCDF cannot hold is refused before anything is written; attributes keep their Python
type; any measurement name is stored under a safe group name (:func:`safe_name`) and
restored; the top-level key ``"_provenance"`` is reserved. The rules in full, and why
Zarr format 2: docs/archives.md; measurements (timings, flipped bytes): docs/io.md,
"Archiving".
"""

from __future__ import annotations

import base64
import contextlib
import datetime as _dt
import json
import math
import os
import re
import secrets
import shutil
import time
import unicodedata
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .._version import __version__
from . import _checksum
from ._common import CONVENTIONS, HDF5_LOCK, MAX_CHUNKS, MAX_POINTS, CorruptedFileError
from .netcdf import check_declared_sizes

__all__ = ["save_analysis", "open_analysis", "safe_name", "PROVENANCE_KEY"]

#: Key of the root's provenance in the mapping :func:`open_analysis` returns (reserved).
PROVENANCE_KEY = "_provenance"

_KIND = "xrough_object"  # "DataArray", "Dataset" or "mapping": what a group reopens as
_NAME = "xrough_dataarray_name"  # the DataArray's name (any type the attrs can hold)
_VARIABLE = "xrough_dataarray_variable"  # the variable that holds the DataArray
_ORIGINAL = "xrough_name"  # the entry's name when its group name differs
_TYPES = "xrough_attr_types"  # JSON: attr name -> how to restore its Python type
_DATA = "xrough_data"  # variable name of a DataArray whose name cannot be one
#: Attributes xrough adds to groups and variables to reopen them; written into the global
#: attribute ``xrough`` (:data:`._checksum.KEY`) instead, put back in place when read.
_LIFTED = (_KIND, _NAME, _VARIABLE, _ORIGINAL, _TYPES)

#: Storage formats of an archive, for ``format=``: one NetCDF4 file, or a Zarr store.
_FORMATS = ("netcdf", "zarr")
_ZARR_SUFFIX = ".zarr"
#: Files that make a directory a Zarr store: its root group's metadata (Zarr format 2, 3).
_ZARR_ROOTS = (".zgroup", "zarr.json")
_ZARR_CONSOLIDATED = ".zmetadata"
#: Temporary files of the earlier naming (no process id) older than this are stale.
_STALE_SECONDS = 3600
#: The suffix :func:`temporary_name` appends: ``.<pid>-<12 hex digits>.tmp`` (or ``.old``).
_TEMP_SUFFIX = re.compile(r"\.(?:(\d+)-)?[0-9a-f]{12}\.(?:tmp|old)$")

#: Longest name, in bytes of UTF-8, that NetCDF-4 writes and reads back (NC_MAX_NAME - 1).
_MAX_NAME_BYTES = 255
#: Numeric dtypes NetCDF4 attributes hold natively.
_NC_DTYPES = {np.dtype(t) for t in ("i1", "i2", "i4", "i8", "u1", "u2", "u4", "u8",
                                    "f4", "f8")}
_INT64 = np.iinfo(np.int64)
_CONTROL = re.compile(r"[\x00-\x1f\x7f/]")


def _valid_first(char: str) -> bool:
    return char == "_" or char.isalnum()


def _is_safe(name: str) -> bool:
    """Whether NetCDF-4 accepts ``name`` unchanged as a group, variable or attribute name."""
    return (bool(name) and _valid_first(name[0]) and not _CONTROL.search(name)
            and not name[-1].isspace() and unicodedata.normalize("NFC", name) == name
            and len(name.encode("utf-8")) <= _MAX_NAME_BYTES)


def safe_name(name: Any, taken: Any = ()) -> str:
    """Make a NetCDF-safe name for a measurement or result, distinct from ``taken``.

    Valid names are kept as they are (``a(1).sur``, ``scan 2``, ``µm``). Otherwise: the
    name is normalised to Unicode NFC (NetCDF does the same, so two spellings of ``é``
    would collide), ``/`` and control characters become ``_``, trailing whitespace becomes
    ``_``, a first character that is neither a letter, a digit nor ``_`` gets a ``_`` in
    front (``(1).sur`` -> ``_(1).sur``, ``-x`` -> ``_-x``), an empty name becomes ``_``,
    and a name longer than 255 bytes of UTF-8 (NetCDF's limit) is shortened. A result in
    ``taken`` or equal to the reserved ``"_provenance"`` gets a suffix ``_2``, ``_3``...

    Use it to name the entries of an analysis after files: ``save_analysis`` applies it
    to group names itself (and keeps the original names), but the keys of one mapping
    must be distinct, and two files ``a/scan.sdf`` and ``b/scan.sur`` share the stem.

    Parameters
    ----------
    name : object
        The wanted name (``str(name)`` is used).
    taken : collection of str
        Names already in use (e.g. the keys chosen so far).

    Returns
    -------
    str
        A name that NetCDF-4 accepts unchanged, not in ``taken`` and not reserved.

    Examples
    --------
    >>> safe_name("(1).sur"), safe_name("-scan"), safe_name("a/b"), safe_name("ok(1)")
    ('_(1).sur', '_-scan', 'a_b', 'ok(1)')
    >>> names = []
    >>> for stem in ["scan", "scan", "_provenance"]:
    ...     names.append(safe_name(stem, taken=names))
    >>> names
    ['scan', 'scan_2', '_provenance_2']
    """
    text = unicodedata.normalize("NFC", str(name))
    text = _CONTROL.sub("_", text)
    stripped = text.rstrip()
    text = stripped + "_" * (len(text) != len(stripped))
    if not text or not _valid_first(text[0]):
        text = "_" + text
    taken = set(taken) | {PROVENANCE_KEY}
    candidate, k = _shorten(text, 0), 1
    while candidate in taken:
        k += 1
        candidate = _shorten(text, len(f"_{k}")) + f"_{k}"
    return candidate


def _shorten(text: str, reserve: int) -> str:
    """``text`` cut to at most 255 - ``reserve`` bytes of UTF-8, on a character boundary."""
    limit = _MAX_NAME_BYTES - reserve
    while len(text.encode("utf-8")) > limit:
        text = text[:-1]
    text = text.rstrip()
    return text if text and not text[-1].isspace() else text + "_"


# --- attributes ---------------------------------------------------------------------


def _refuse(where: str, name: str, value: Any, why: str) -> ValueError:
    return ValueError(f"cannot archive {where}: attribute {name!r} = {value!r:.80} "
                      f"({type(value).__name__}) {why}; store it as a string, number, "
                      "bool, None, list, dict or numeric array")


def _json_default(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def _to_json(value: Any, where: str, name: str) -> str:
    def check_keys(obj):
        if isinstance(obj, Mapping):
            for key, item in obj.items():
                if not isinstance(key, str):
                    raise _refuse(where, name, value, f"has a non-string dict key {key!r}")
                check_keys(item)
        elif isinstance(obj, (list, tuple)):
            for item in obj:
                check_keys(item)

    check_keys(value)
    try:
        return json.dumps(value, default=_json_default)
    except (TypeError, ValueError) as err:
        raise _refuse(where, name, value, f"cannot be stored as JSON ({err})") from None


def _numeric_array(array: np.ndarray, where: str, name: str, value: Any) -> np.ndarray:
    if array.dtype.kind == "b":
        return array.astype(np.int8)
    if array.dtype not in _NC_DTYPES:
        raise _refuse(where, name, value, f"has dtype {array.dtype}, which NetCDF "
                      "attributes cannot hold")
    return array


def _encode_value(value: Any, where: str, name: str) -> tuple[Any, Any]:
    """NetCDF form of one attribute value and the tag that restores it (None: native)."""
    if value is None:
        return "", "none"
    if isinstance(value, (bool, np.bool_)):
        return np.int8(bool(value)), "bool"
    if isinstance(value, str):
        return (value, None) if "\x00" not in value else (_to_json(value, where, name), "json")
    if isinstance(value, bytes):
        return base64.b64encode(value).decode("ascii"), "bytes"
    if isinstance(value, int):
        if _INT64.min <= value <= _INT64.max:
            return value, None
        return _to_json(value, where, name), "json"
    if isinstance(value, float):
        return value, None
    if isinstance(value, np.generic):
        if value.dtype in _NC_DTYPES:
            return value, {"dtype": value.dtype.str}
        raise _refuse(where, name, value, f"has dtype {value.dtype}, which NetCDF "
                      "attributes cannot hold")
    if isinstance(value, np.ndarray):
        tag = {"shape": list(value.shape), "dtype": value.dtype.str}
        if value.dtype.kind in "biuf":
            return _numeric_array(value, where, name, value).ravel(), tag
        if value.dtype.kind in "USO":
            return _to_json(value.tolist(), where, name), {**tag, "json": True}
        raise _refuse(where, name, value, f"has dtype {value.dtype}, which NetCDF "
                      "attributes cannot hold")
    if isinstance(value, (list, tuple)):
        kind = type(value).__name__ if type(value) in (list, tuple) else "list"
        numbers = value and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                for v in value)
        if numbers:
            array = np.asarray(value)
            if array.dtype in (np.dtype("i8"), np.dtype("f8")):
                return array, kind
        return _to_json(value, where, name), f"json_{kind}"
    if isinstance(value, Mapping):
        return _to_json(value, where, name), "json"
    raise _refuse(where, name, value, "has a type NetCDF cannot hold")


def _decode_value(value: Any, tag: Any) -> Any:
    if tag == "none":
        return None
    if tag == "bool":
        return bool(value)
    if tag == "bytes":
        return base64.b64decode(value)
    if tag in ("json", "json_list"):
        return json.loads(value)
    if tag == "json_tuple":
        return tuple(json.loads(value))
    if tag in ("list", "tuple"):
        items = np.atleast_1d(value).tolist()
        return items if tag == "list" else tuple(items)
    if isinstance(tag, dict):
        dtype = np.dtype(tag["dtype"])
        if "shape" not in tag:  # a numpy scalar
            return dtype.type(value)
        if tag.get("json"):
            return np.asarray(json.loads(value), dtype=dtype).reshape(tag["shape"])
        return np.asarray(value).astype(dtype).reshape(tag["shape"])
    return value


def _check_name(name: Any, where: str, what: str) -> None:
    if not isinstance(name, str) or not _is_safe(name):
        raise ValueError(f"cannot archive {where}: {what} name {name!r} is not a valid "
                         "NetCDF name (it must start with a letter, digit or '_', contain "
                         "no '/' or control characters, not end in a space and have at "
                         "most 255 bytes); rename it (xrough.io.archive.safe_name)")


def _encode_attrs(attrs: Mapping, where: str) -> dict:
    out: dict = {}
    types: dict = {}
    for name, value in attrs.items():
        _check_name(name, where, "attribute")
        if name == _TYPES:
            continue
        out[name], tag = _encode_value(value, where, name)
        if tag is not None:
            types[name] = tag
    if types:
        out[_TYPES] = json.dumps(types)
    return out


def _decode_attrs(attrs: Mapping) -> dict:
    attrs = dict(attrs)
    types = json.loads(attrs.pop(_TYPES, "{}"))
    return {k: _decode_value(v, types.get(k)) for k, v in attrs.items()}


# --- objects ------------------------------------------------------------------------


def _encoded(ds: xr.Dataset, where: str) -> xr.Dataset:
    """``ds`` with every name checked and every attribute in NetCDF form (no encoding)."""
    for dim in ds.dims:
        _check_name(dim, where, "dimension")
    out = ds.copy(deep=False)  # new Variable objects with their own attrs dicts
    for name, var in out.variables.items():
        _check_name(name, where, "variable")
        if var.dtype.kind == "c":
            raise ValueError(f"cannot archive {where}: variable {name!r} is complex, "
                             "which NetCDF cannot hold; store its real and imaginary "
                             "parts")
        var.attrs = _encode_attrs(var.attrs, f"{where} (variable {name!r})")
        var.encoding = {}  # no packing or chunking inherited from a source file
    out.attrs = _encode_attrs(ds.attrs, where)
    out.encoding = {}
    return out


def _as_dataset(obj: Any, where: str, extra: dict) -> xr.Dataset:
    if isinstance(obj, xr.DataArray):
        name = obj.name
        variable = name if isinstance(name, str) and _is_safe(name) else _DATA
        if variable in obj.coords:
            variable = _DATA
        ds = obj.to_dataset(name=variable, promote_attrs=False)
        ds.attrs = {_KIND: "DataArray", _NAME: name, _VARIABLE: variable, **extra}
    elif isinstance(obj, xr.Dataset):
        ds = obj.copy(deep=False)
        ds.attrs = {**obj.attrs, _KIND: "Dataset", **extra}
    else:
        raise TypeError(f"{where}: can only archive xarray DataArrays and Datasets, got "
                        f"{type(obj).__name__}")
    return _encoded(ds, where)


def _restore(ds: xr.Dataset) -> xr.DataArray | xr.Dataset:
    for var in ds.variables.values():
        var.attrs = _decode_attrs(var.attrs)
    attrs = _decode_attrs(ds.attrs)
    attrs.pop(_ORIGINAL, None)
    kind = attrs.pop(_KIND, None)
    if kind == "DataArray":
        name = attrs[_NAME]
        da = ds[attrs.get(_VARIABLE, name)]  # older archives: the variable is the name
        da.name = name
        return da
    ds = ds.copy()
    ds.attrs = attrs
    return ds


def _group_names(mapping: Mapping, where: str) -> list[tuple[str, str, Any]]:
    """(name, NetCDF-safe group name, value) per entry: valid names kept, all distinct."""
    entries = [(str(key), value) for key, value in mapping.items()]
    keys = [key for key, _ in entries]
    if len(set(keys)) < len(keys):
        raise ValueError(f"{where or '/'}: two entries have the same name as strings: "
                         f"{keys}")
    groups = {key: key for key in keys if _is_safe(key)}
    taken = set(groups.values())
    for key in keys:
        if key not in groups:
            groups[key] = safe_name(key, taken)
            taken.add(groups[key])
    return [(key, groups[key], value) for key, value in entries]


def _tree(analysis: Mapping) -> dict[str, xr.Dataset]:
    if PROVENANCE_KEY in analysis:
        raise ValueError(f"{PROVENANCE_KEY!r} is reserved for the archive's provenance; "
                         "give that entry another name (e.g. xrough.io.archive.safe_name"
                         f"({PROVENANCE_KEY!r}) = {safe_name(PROVENANCE_KEY)!r})")
    tree: dict[str, xr.Dataset] = {}

    def walk(prefix: str, label: str, mapping: Mapping) -> None:
        for key, group, value in _group_names(mapping, label):
            where = f"{label}/{key}" if label else key
            extra = {_ORIGINAL: key} if group != key else {}
            path = f"{prefix}/{group}"
            if isinstance(value, Mapping) and not isinstance(value, xr.Dataset):
                tree[path] = xr.Dataset(attrs=_encode_attrs({_KIND: "mapping", **extra},
                                                            where))
                walk(path, where, value)
            else:
                tree[path] = _as_dataset(value, where, extra)

    walk("", "", analysis)
    return tree


def _format(path: Path, format: str | None) -> str:
    """Return the storage format: ``format``, else Zarr for a ``.zarr`` path or store."""
    if format is None:
        zarr = path.suffix.lower() == _ZARR_SUFFIX or _is_zarr_store(path)
        return "zarr" if zarr else "netcdf"
    if not isinstance(format, str) or format.lower() not in _FORMATS:
        raise ValueError(f"format={format!r}: an archive is 'netcdf' or 'zarr'")
    return format.lower()


def _is_zarr_store(path: Path) -> bool:
    return path.is_dir() and any((path / name).is_file() for name in _ZARR_ROOTS)


def _zarr():
    """Import zarr, or raise an ImportError saying how to install it."""
    try:
        import zarr
    except ImportError as err:
        raise ImportError("Zarr archives need the zarr package: pip install "
                          "'xrough[zarr]' (or pip install zarr)") from err
    return zarr


def _write_netcdf(tree: xr.DataTree, target: Path) -> None:
    tree.to_netcdf(target, engine="netcdf4")


def _write_zarr(tree: xr.DataTree, target: Path) -> None:
    # every chunk is written, even one of fill values only: open_analysis checks that
    # none is missing (a missing chunk would otherwise read as fill values)
    tree.to_zarr(target, mode="w-", consolidated=True, zarr_format=2,
                 write_empty_chunks=True)


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def temporary_name(path: Path, kind: str = "tmp") -> Path:
    """Return a temporary name next to ``path`` that :func:`remove_stale_temporaries` knows.

    ``.<name>.<process id>-<12 random hex digits>.<kind>``, in the directory of ``path``:
    hidden, unique, and telling which process writes it.

    Parameters
    ----------
    path : Path
        The target file or store.
    kind : {"tmp", "old"}
        ``"tmp"`` for a file or store being written, ``"old"`` for a store set aside.

    Returns
    -------
    Path

    Examples
    --------
    >>> import os
    >>> name = temporary_name(Path("out/a.nc")).name
    >>> name.startswith(f".a.nc.{os.getpid()}-") and name.endswith(".tmp")
    True
    """
    return path.parent / f".{path.name}.{os.getpid()}-{secrets.token_hex(6)}.{kind}"


def _running(pid: int) -> bool:
    """Whether process ``pid`` may still be running (and writing its temporary file)."""
    if pid == os.getpid() or os.name == "nt":  # os.kill(pid, 0) would end it on Windows
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by someone else
        return True
    return True


def _temp_of(name: str, target: str) -> tuple[bool, str | None]:
    """Tell whether ``name`` is a temporary name of ``target``, and its process id.

    Names made by :func:`temporary_name`, also nested (the temporary file of a save to such a name).
    """
    pid, depth = None, 0
    while name != target:
        match = _TEMP_SUFFIX.search(name)
        if match is None or not name.startswith("."):
            return False, None
        pid = match[1] if depth == 0 else pid
        name, depth = name[1:match.start()], depth + 1
    return depth > 0, pid


def restore_set_aside(path: Path) -> bool:
    """Put back the store a killed save set aside, if nothing is at ``path``.

    A Zarr store is replaced by renaming the old one aside (``.<name>.<pid>-<hex>.old``),
    then the new one in: a kill between the two renames leaves nothing at the path. The
    newest store set aside for ``path`` by a process no longer running goes back, with a
    warning. Called before every save and open.

    Returns
    -------
    bool
        Whether a store was put back.
    """
    if path.exists():
        return False
    aside = []
    try:
        with os.scandir(path.parent) as entries:
            for entry in entries:
                ours, pid = _temp_of(entry.name, path.name)
                if (ours and entry.name.endswith(".old") and pid is not None
                        and not _running(int(pid)) and _is_zarr_store(Path(entry.path))):
                    aside.append(Path(entry.path))
    except OSError:
        return False
    if not aside:
        return False
    newest = max(aside, key=lambda p: p.stat().st_mtime)
    os.replace(newest, path)
    warnings.warn(f"{path}: a save was killed while it replaced this archive; the previous "
                  f"archive, set aside as {newest.name}, is back in place", UserWarning,
                  stacklevel=3)
    return True


def remove_stale_temporaries(path: Path) -> None:
    """Remove the temporary files that killed saves to ``path`` left behind.

    Removed are names made by :func:`temporary_name` for this very target (also nested:
    the temporary file of a save to such a temporary name) whose process is no longer
    running, and names of the earlier form without a process id (``.<name>.<12 hex>.tmp``)
    untouched for an hour. Nothing else in the directory is touched; a temporary file of
    a save still running is kept. On Windows only the earlier form is removed. Best
    effort: a file that cannot be removed is left, without an error.

    Parameters
    ----------
    path : Path
        The target file or store, after a successful save to it.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> for name in (".a.nc.999999999-0123456789ab.tmp", ".b.nc.999999999-0123456789ab.tmp"):
    ...     _ = (folder / name).write_bytes(b"left by a killed save")
    >>> remove_stale_temporaries(folder / "a.nc")  # process 999999999 is not running
    >>> sorted(p.name for p in folder.iterdir())  # another target's is kept
    ['.b.nc.999999999-0123456789ab.tmp']
    """
    stale = []
    try:
        with os.scandir(path.parent) as entries:
            for entry in entries:
                ours, pid = _temp_of(entry.name, path.name)
                if not ours:
                    continue
                if pid is not None:
                    if not _running(int(pid)):
                        stale.append(Path(entry.path))
                elif time.time() - entry.stat(follow_symlinks=False).st_mtime > _STALE_SECONDS:
                    stale.append(Path(entry.path))
        for temp in stale:
            _remove(temp)
    except OSError:  # best effort: the save itself has succeeded
        pass


def _move_into_place(tmp: Path, path: Path) -> None:
    """Rename the complete ``tmp`` to ``path``; a previous store there is deleted last."""
    if not (tmp.is_dir() and path.exists()):
        os.replace(tmp, path)
        return
    old = temporary_name(path, "old")
    os.replace(path, old)
    try:
        os.replace(tmp, path)
    except BaseException:
        os.replace(old, path)
        raise
    _remove(old)


def _open_tree(path: Path, fmt: str, chunks=None, **kwargs) -> xr.DataTree:
    """Open an archive as a DataTree, the same way for checksumming and for reading."""
    if fmt == "zarr":
        return xr.open_datatree(path, chunks=chunks, engine="zarr",
                                consolidated=(path / _ZARR_CONSOLIDATED).is_file() or None,
                                **kwargs)
    return xr.open_datatree(path, chunks=chunks, engine="netcdf4", **kwargs)


def _lift(tree: dict[str, xr.Dataset], fmt: str) -> dict:
    """Move xrough's own attributes of every group and variable into a record, in place.

    Each variable also gets the encoding of its per-chunk checksum, each coordinate
    variable none of ``_FillValue`` (CF forbids it there), and string coordinate variables
    become labels (:func:`_as_labels`). Returns ``{group path: {"attrs": {...},
    "variables": {name: {...}}, "labels": {label: dimension}}}`` as JSON reads it back.
    """
    record: dict = {}
    for group in list(tree):
        ds, labels = _as_labels(tree[group])
        tree[group] = ds
        entry = {"attrs": {k: ds.attrs.pop(k) for k in _LIFTED if k in ds.attrs},
                 "variables": {}, "labels": labels}
        for name, var in ds.variables.items():
            lifted = {k: var.attrs.pop(k) for k in _LIFTED if k in var.attrs}
            if lifted:
                entry["variables"][str(name)] = lifted
            var.encoding = _checksum.chunk_encoding(var, "zarr" if fmt == "zarr" else "netcdf4")
            if var.dims == (name,):  # a coordinate variable: CF forbids _FillValue
                var.encoding["_FillValue"] = None
        entry["missing"] = _checksum.missing_counts(ds.variables)
        record[group] = {k: v for k, v in entry.items() if v}
    return json.loads(json.dumps(record, default=_json_default))


def _as_labels(ds: xr.Dataset) -> tuple[xr.Dataset, dict[str, str]]:
    """Store string coordinate variables as labels: CF's coordinate variables are numbers.

    A coordinate variable of strings (the fit's ``cov_i``, ``cov_j``) becomes an
    auxiliary coordinate ``<dim>_label`` on the same dimension, which then has no
    coordinate variable (CF 1.10, sections 5 and 6.1); :func:`_from_labels` turns it back.
    Returns the dataset and ``{label: dimension}``.
    """
    strings = [str(name) for name, var in ds.variables.items()
               if var.dims == (name,) and var.dtype.kind in "USO"]
    labels: dict[str, str] = {}
    taken = {str(n) for n in ds.variables} | {str(d) for d in ds.dims}
    for name in strings:
        label = safe_name(f"{name}_label", taken)
        taken.add(label)
        labels[label] = name
        var = ds.variables[name]
        ds = ds.drop_vars(name).assign_coords(
            {label: xr.Variable(var.dims, var.values, var.attrs, encoding=var.encoding)})
    return ds, labels


def _from_labels(ds: xr.Dataset, labels: Mapping[str, str]) -> xr.Dataset:
    """Turn the labels :func:`_as_labels` wrote back into string coordinate variables."""
    for label, name in labels.items():
        var = ds.variables[label]
        ds = ds.drop_vars(label).assign_coords(
            {name: xr.Variable(var.dims, np.asarray(var.values), var.attrs)})
    return ds


def _add_checksums(tmp: Path, fmt: str, record: Mapping[str, dict]) -> None:
    """Store the record and digests of every group of the written ``tmp``, read back."""
    with _open_tree(tmp, fmt) as tree:
        groups = {node.path: {**record.get(node.path, {}), "sha256": _checksum.digests(
            node.to_dataset(inherit=False), node.children, record.get(node.path))}
            for node in tree.subtree}
    _checksum.stamp(tmp, fmt, groups)


def _write_atomic(tree: xr.DataTree, record: Mapping[str, dict], path: Path,
                  format: str) -> None:
    """Write ``tree`` to ``path`` through a temporary file or store in the same directory.

    The ``record`` (from :func:`_lift`) and the digests are added to the temporary file
    from what it holds, read back; once it is in place, temporary files that earlier,
    killed saves to ``path`` left are removed.
    """
    directory = path.parent
    if not directory.is_dir():
        raise FileNotFoundError(f"{path}: the directory {directory} does not exist")
    if format == "netcdf" and path.is_dir():
        raise IsADirectoryError(f"{path} is a directory; give a file name (.nc), or a "
                                "name ending in .zarr for a Zarr store")
    if format == "zarr":
        _zarr()
        if path.exists() and not _is_zarr_store(path):
            what = "a directory" if path.is_dir() else "a file"
            raise FileExistsError(f"{path} is {what}, not a Zarr store, and is left as it "
                                  "is; remove it or choose another name")
    write = _write_netcdf if format == "netcdf" else _write_zarr
    tmp = temporary_name(path, "tmp")
    try:
        with HDF5_LOCK if format == "netcdf" else contextlib.nullcontext():
            write(tree, tmp)
            _add_checksums(tmp, format, record)
            _move_into_place(tmp, path)
    except BaseException as err:
        _remove(tmp)
        if isinstance(err, (OSError, KeyboardInterrupt, SystemExit, MemoryError)):
            raise
        raise ValueError(f"{path}: could not write the archive ({type(err).__name__}: "
                         f"{err}); any previous file at this path is unchanged") from err
    remove_stale_temporaries(path)


def save_analysis(path: str | Path, analysis: Mapping, *, history: str | None = None,
                  format: str | None = None) -> Path:
    """Write an analysis (nested mapping of results) to a NetCDF4 file or Zarr store, atomically.

    Every attribute reopens identical, every chunk and the metadata are checksummed (verified
    by :func:`open_analysis`). Notes (the rules, Zarr chunks): docs/archives.md.

    Parameters
    ----------
    path : str or Path
        Output file (``.nc``) or Zarr store (``.zarr``, a directory), written under a
        temporary name and renamed over ``path`` when complete (a failed save changes nothing).
    analysis : mapping
        ``{"topography": topo, "G": G, "fit": fit, ...}`` for one measurement, or
        ``{"afm": {...}, "stylus": {...}}`` for several (one group each), nested to any
        depth; names may hold any characters (:func:`safe_name`). Dask-backed objects are
        computed while written, in one pass, and keep their chunks in a Zarr store.
    history : str, optional
        A line for the ``history`` attribute (e.g. the command that produced it).
    format : {"netcdf", "zarr"}, optional
        Default: ``"zarr"`` for a path ending in ``.zarr`` or an existing Zarr store
        (``pip install xrough[zarr]``), ``"netcdf"`` otherwise.

    Returns
    -------
    Path
        The file or store written.

    Raises
    ------
    TypeError
        An entry that is not an xarray object or a mapping.
    ValueError
        Before anything is written: an attribute, name or variable NetCDF cannot hold,
        ``"_provenance"``, two keys equal as strings, an unknown ``format``. While
        writing: any failure of the NetCDF or Zarr library (the previous file is kept).
    OSError
        No such directory, ``path`` a directory (NetCDF) or an existing non-Zarr path
        (Zarr: ``FileExistsError``), or the disk failed.
    ImportError
        ``format="zarr"`` without the zarr package.

    See Also
    --------
    open_analysis, safe_name

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np, xrough
    >>> topo = xrough.topography(np.random.default_rng(0).normal(size=(32, 32)),
    ...                          spacing=1.0, unit="nm")
    >>> G = topo.rough.acf()
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "analysis.nc"
    >>> _ = xrough.save_analysis(path, {"(1).sur": {"topography": topo, "G": G}})
    >>> back = xrough.open_analysis(path)
    >>> xr.testing.assert_identical(back["(1).sur"]["G"], G)
    >>> store = pathlib.Path(tempfile.mkdtemp()) / "analysis.zarr"  # a Zarr store, by name
    >>> _ = xrough.save_analysis(store, {"(1).sur": {"topography": topo, "G": G}})
    >>> xr.testing.assert_identical(xrough.open_analysis(store)["(1).sur"]["G"], G)
    """
    if not isinstance(analysis, Mapping):
        raise TypeError("analysis must be a mapping of names to results ({'G': G}, or "
                        "{'scan 1': {'G': G, 'fit': fit}}), got "
                        f"{type(analysis).__name__}")
    path = Path(path)
    fmt = _format(path, format)
    restore_set_aside(path)  # a killed replacement left the previous store aside
    tree = _tree(analysis)
    now = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
    root = xr.Dataset(attrs={
        "Conventions": CONVENTIONS,
        "title": "xrough analysis",
        "xrough_version": __version__,
        "created": now,
        "history": f"{now}: {history or 'written by xrough.save_analysis'}",
    })
    if fmt == "zarr":
        _zarr()  # says how to install it
    tree = {"/": root, **tree}
    record = _lift(tree, fmt)
    _write_atomic(xr.DataTree.from_dict(tree), record, path, fmt)
    return path


def _check_zarr_store(path: Path, lazy: bool) -> None:
    """Refuse a directory that is no Zarr store, or a store with missing or too many chunks.

    The chunks each array declares (its shape by its chunks, or shards) are counted from
    its metadata and refused beyond :data:`~xrough.io._common.MAX_CHUNKS` in all, and
    each array of more than :data:`~xrough.io._common.MAX_POINTS` points too unless the
    open is ``lazy``, before any chunk is looked up: a shape edited to 1e6 x 1e6 declares
    244 million chunks. The names of the chunks are then looked up in one listing of the
    store's files.
    """
    if not path.is_dir():
        raise ValueError(f"{path}: not a Zarr store (a Zarr store is a directory); a "
                         "NetCDF archive opens with format='netcdf' or without format=")
    if not _is_zarr_store(path):
        raise ValueError(f"{path}: not a Zarr store: the directory has no "
                         f"{' or '.join(_ZARR_ROOTS)}")
    zarr = _zarr()
    try:
        group = zarr.open_group(path, mode="r")
        arrays = [(name, node) for name, node in group.members(max_depth=None)
                  if isinstance(node, zarr.Array)]
        grids = [_chunk_grid(path, name, node, lazy) for name, node in arrays]
        total = 0
        for (name, node), grid in zip(arrays, grids):
            total += math.prod(grid)
            if total > MAX_CHUNKS:
                before = f" ({total} with the arrays before it)" * (total > math.prod(grid))
                raise _too_large(path, name, node, f"{math.prod(grid)} chunks{before}, more "
                                 f"than the limit of {MAX_CHUNKS}")
        files = _store_files(path)
        missing = []
        for (name, node), grid in zip(arrays, grids):
            prefix = f"{node.path}/" if node.path else ""
            lost = sum(f"{prefix}{node.metadata.encode_chunk_key(index)}" not in files
                       for index in np.ndindex(*grid))
            if lost:
                missing.append((name, lost, math.prod(grid)))
    except Exception as err:  # corrupted metadata: zarr's own errors, JSON errors...
        if isinstance(err, ValueError) and str(err).startswith(f"{path}: "):
            raise  # one of ours, naming the array
        raise ValueError(f"{path}: corrupted Zarr store ({type(err).__name__}: "
                         f"{str(err)[:300]})") from err
    if missing:
        listed = ", ".join(f"{name!r} ({lost} of {total})" for name, lost, total in missing)
        raise ValueError(f"{path}: incomplete Zarr store: chunks missing from {listed}; "
                         "save_analysis writes every chunk, so files of the store were "
                         "lost (an interrupted copy?)")


def _too_large(path: Path, name: str, node: Any, why: str) -> ValueError:
    return ValueError(f"{path}: array {name!r} of the Zarr store declares shape "
                      f"{tuple(node.shape)} with chunks {tuple(node.chunks)}: {why}; refused "
                      "before reading it (a corrupted or forged store?)")


def _chunk_grid(path: Path, name: str, node: Any, lazy: bool) -> tuple[int, ...]:
    """Return the number of stored chunks (shards) along each dimension of a Zarr array."""
    points = math.prod(node.shape)
    if not lazy and points > MAX_POINTS:
        raise _too_large(path, name, node, f"{points} points, more than the limit of "
                         f"{MAX_POINTS} (open the archive lazily with chunks= to compute it "
                         "chunk by chunk)")
    stored = node.shards or node.chunks
    return tuple(-(-int(n) // max(int(c), 1)) for n, c in zip(node.shape, stored))


def _store_files(path: Path) -> set[str]:
    """Return the paths of the files of a directory store, relative and with ``/``."""
    files: set[str] = set()
    for folder, _, names in os.walk(path):
        relative = Path(folder).relative_to(path).as_posix()
        prefix = "" if relative == "." else f"{relative}/"
        files.update(prefix + name for name in names)
    return files


def _unreadable(path: Path, fmt: str, err: Exception) -> ValueError:
    return ValueError(f"{path}: cannot read as an xrough archive ({fmt}): "
                      f"{type(err).__name__}: {str(err)[:300]}")


def open_analysis(path: str | Path, *, format: str | None = None, chunks=None) -> dict:
    """Reopen a file or store written by :func:`save_analysis` as the same nested mapping.

    Checksums are verified as the data are read. Notes (lazy opening, checks): docs/archives.md.

    Parameters
    ----------
    path : str or Path
        A NetCDF file or Zarr store written by :func:`save_analysis`.
    format : {"netcdf", "zarr"}, optional
        The storage format. Default: Zarr for a directory, NetCDF for a file.
    chunks : None, dict, int or "auto", optional
        ``None`` (default): every object is read into memory (NumPy) and the file closed.
        Else lazily as dask arrays, ``chunks`` as in :func:`xarray.open_datatree` (``{}``:
        the stored chunks), each chunk read and checked when computed.

    Returns
    -------
    dict
        The saved mapping under its original names, each object identical, and the root's
        provenance (version, creation time, history, ``Conventions``) under ``"_provenance"``.

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    CorruptedFileError
        Values, attributes or layout that fail their checksums (a ``ValueError`` naming
        ``path`` and the variable; with ``chunks``, raised by ``compute``).
    ValueError
        Not an archive, a corrupted file or store (unreadable metadata, missing Zarr chunks,
        any library error on the file, chained), or an unknown ``format``.
    PermissionError
        ``path`` cannot be read (the message names it).
    ImportError
        A Zarr store without the zarr package.

    Warns
    -----
    UserWarning
        An archive written by an earlier version of xrough: its values are not verified.

    See Also
    --------
    save_analysis

    Examples
    --------
    Scans saved to Zarr one per chunk reopen lazily with those chunks; G reads the store:

    >>> import tempfile, pathlib, numpy as np, xarray as xr, xrough
    >>> scans = xr.concat([xrough.topography(np.random.default_rng(s).normal(size=(32, 32)),
    ...                                      spacing=1.0, unit="nm") for s in range(4)],
    ...                   dim="scan").chunk({"scan": 1})
    >>> store = pathlib.Path(tempfile.mkdtemp()) / "scans.zarr"
    >>> _ = xrough.save_analysis(store, {"scans": scans})
    >>> lazy = xrough.open_analysis(store, chunks={})["scans"]
    >>> lazy.chunks == scans.chunks
    True
    >>> G = lazy.rough.acf(pool="scan").compute()
    """
    path = Path(path)
    restore_set_aside(path)  # a killed replacement left the previous store aside
    if not path.exists():
        raise FileNotFoundError(f"no such archive: {path}")
    fmt = _format(path, format) if format is not None else (
        "zarr" if path.is_dir() else "netcdf")
    lazy = chunks is not None
    if fmt == "zarr":
        _check_zarr_store(path, lazy)
    elif path.is_dir():
        raise IsADirectoryError(f"{path} is a directory, not a NetCDF file (a Zarr "
                                "store opens with format='zarr' or without format=)")
    with HDF5_LOCK if fmt == "netcdf" else contextlib.nullcontext():
        return _open_archive(path, fmt, chunks, lazy)


def _open_archive(path: Path, fmt: str, chunks, lazy: bool) -> dict:
    """Open, check and read an archive (:func:`open_analysis`, under the HDF5 lock)."""
    try:
        if fmt == "netcdf":  # nothing read of a variable that declares more than is there
            check_declared_sizes(path, str(path), recursive=True,
                                 max_points=None if lazy else MAX_POINTS,
                                 advice="open the archive lazily with chunks= to compute "
                                 "it chunk by chunk")
        dt = _open_tree(path, fmt, chunks, **(
            {"from_array_kwargs": _checksum.lazy_kwargs(str(path), fmt)} if lazy else {}))
    except ImportError:
        raise
    except PermissionError as err:
        raise PermissionError(f"{path}: cannot read the archive ({err})") from err
    except ValueError as err:
        if str(err).startswith(f"{path}: "):
            raise  # already says what is wrong with which file
        raise _unreadable(path, fmt, err) from err
    except Exception as err:  # the NetCDF library's OSErrors (also FileNotFoundError for a
        raise _unreadable(path, fmt, err) from err  # corrupted file), zarr's errors, JSON
    try:
        out = _read_tree(dt, path, lazy)
    except Exception as err:
        dt.close()
        if isinstance(err, ValueError) and str(err).startswith(f"{path}: "):
            raise  # already says what is wrong with which file
        raise _unreadable(path, fmt, err) from err
    if not lazy:
        dt.close()
    return out


def _read_tree(dt: xr.DataTree, path: Path, lazy: bool) -> dict:
    """Return the nested mapping of an opened archive, checking every group on the way."""
    name = str(path)
    groups = _checksum.stored(name, dt.attrs)
    if groups is None and not any(_KIND in node.attrs for node in dt.subtree):
        raise ValueError(
            f"{path}: not an analysis archive of xrough.save_analysis (no record of what "
            f"its groups hold, attribute {_checksum.KEY!r}): open a topography with "
            "xrough.open_topography, any other NetCDF with xarray.open_dataset")
    if groups is None:
        warnings.warn(f"{path}: an archive written by an earlier version of xrough; its "
                      "values cannot be verified (save it again to add checksums)",
                      UserWarning, stacklevel=3)
    elif lost := sorted(set(groups) - {node.path for node in dt.subtree}):
        raise CorruptedFileError(f"{path}: corrupted file: the groups {lost} are recorded "
                                 "but missing; refused")

    def opened(node: xr.DataTree) -> xr.Dataset:
        ds = node.to_dataset(inherit=False)
        for var_name, var in ds.variables.items():  # lazily: dask reads and checks the rest
            if not lazy or var.chunks is None:
                with _checksum.reading(name, f"variable {str(var_name)!r} of group "
                                             f"{node.path!r}"):
                    var.load()
        entry: dict = {}
        if groups is not None:
            found = groups.get(node.path)
            _checksum.verify(name, node.path, ds, node.children, found)  # refuses None
            entry = found or {}
            _checksum.check_missing(name, node.path, ds, entry.get("missing", {}))
        ds = ds.copy()
        ds.attrs = {k: v for k, v in ds.attrs.items()
                    if k not in (_checksum.KEY, _checksum.LEGACY)} | entry.get("attrs", {})
        for var_name, var in ds.variables.items():
            var.attrs = ({k: v for k, v in var.attrs.items() if k != _checksum.LEGACY}
                         | entry.get("variables", {}).get(str(var_name), {}))
        return _from_labels(ds, entry.get("labels", {}))

    out: dict = {PROVENANCE_KEY: opened(dt).attrs}

    def walk(node: xr.DataTree, target: dict) -> None:
        for child in node.children.values():
            ds = opened(child)
            attrs = _decode_attrs(ds.attrs)
            key = attrs.get(_ORIGINAL, child.name)
            if attrs.get(_KIND) in ("DataArray", "Dataset"):
                target[key] = _restore(ds)
            else:  # a mapping (or an intermediate group of an older archive)
                walk(child, target.setdefault(key, {}))

    walk(dt, out)
    return out
