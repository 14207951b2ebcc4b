"""NetCDF topographies: xrough's own files and the common ``heights(x, y)`` layout.

xrough writes a topography with :meth:`xarray.DataArray.to_netcdf` (CF ``units`` on the
heights and on every coordinate), with HDF5's Fletcher-32 checksum on every chunk of the
heights and coordinates (NetCDF-4) and the SHA-256 digests of what that does not cover
(attributes, names, dims; all values in NetCDF-3, which has no checksums of its own) in
the one global attribute ``xrough`` (:mod:`xrough.io._checksum`); :func:`read` checks both,
refuses a file whose values or attributes changed since (naming the file and the
variable) and gives back the identical DataArray.

Files from other programs are read too when they hold one height variable (``height``,
``heights``, ``topography``, ``z``... or the only data variable) on dims ``x`` and ``y`` in
either order (``heights(x, y)`` is transposed to xrough's ``(y, x)``), with units in a
``units`` or ``unit`` attribute. A ``length`` attribute on a coordinate (as written by
SurfaceTopography) gives the physical size ``n * spacing`` along it, and a ``periodic``
attribute the periodicity.

Untrusted files: the header of a NetCDF-3 file (classic, 64-bit offset, CDF-5) is walked
with bounds before the NetCDF library sees it, and every variable's declared size and
offset is compared with the file's size. A truncated file, a header declaring more data
than the file holds (the library would read the missing bytes as zeros, or allocate what
the header claims), variables whose data overlap, or bytes beyond the data the header
places (inserted bytes shift the data) are refused. Every failure is a ``ValueError``
naming the file.
"""

from __future__ import annotations

import math
import mmap
from pathlib import Path
from typing import Any

import netCDF4
import numpy as np
import xarray as xr

from .. import units as u
from ..topography import topography
from . import _checksum
from ._common import (
    CONVENTIONS,
    HDF5_LOCK,
    MAX_CHUNKS,
    MAX_POINTS,
    MissingOptionError,
    check_file,
    micro_as_u,
    raw_hdf5,
    reader_errors,
)

__all__ = ["sniff", "read", "write"]

_NETCDF3 = (b"CDF\x01", b"CDF\x02", b"CDF\x05")
_HDF5 = b"\x89HDF\r\n\x1a\n"
_EXTENSIONS = (".nc", ".nc4", ".netcdf", ".cdf")
_HEIGHT_NAMES = ("height", "heights", "topography", "topo", "z", "h",
                 "__xarray_dataarray_variable__")
_DATAARRAY_DEFAULT = "__xarray_dataarray_variable__"
#: Bytes per value of the NetCDF-3 external types (CDF-5 adds 7 to 11).
_NC_TYPE_SIZES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 4, 6: 8, 7: 1, 8: 2, 9: 4, 10: 8, 11: 8}
_NC_DIMENSION, _NC_VARIABLE, _NC_ATTRIBUTE = 10, 11, 12
_MAX_NESTING = 10_000  # more dims, attributes or variables than this: a corrupted header
#: The most bytes deflate (zlib) data decompress to per byte stored (its limit is 1032:1).
_DEFLATE_RATIO = 1032
#: Bytes a NetCDF-4 file may leave unwritten in all (read as fill values from nothing), or
#: the file's size if larger: chunks a writer left out of a sparse variable, not a forgery.
_UNWRITTEN_BYTES = 2**26


class _Header:
    """Bounded reader of a NetCDF-3 header (big-endian integers, 4-byte padding)."""

    def __init__(self, buf, name: str):
        self.buf, self.name, self.pos, self.size = buf, name, 0, len(buf)
        version = buf[3]
        self.count = 8 if version == 5 else 4
        self.offset = 4 if version == 1 else 8

    def fail(self, what: str) -> ValueError:
        return ValueError(f"{self.name}: truncated or corrupted NetCDF-3 file: {what}")

    def need(self, n: int, what: str) -> None:
        if n < 0 or self.pos + n > self.size:
            raise self.fail(f"the header's {what} needs {n} bytes at byte {self.pos}, the "
                            f"file has {self.size}")

    def integer(self, n: int, what: str) -> int:
        self.need(n, what)
        value = int.from_bytes(self.buf[self.pos:self.pos + n], "big")
        self.pos += n
        return value

    def skip(self, n: int, what: str) -> None:
        padded = n + (-n) % 4
        self.need(padded, what)
        self.pos += padded

    def name_(self, what: str) -> bytes:
        n = self.integer(self.count, what)
        self.need(n, what)
        text = bytes(self.buf[self.pos:self.pos + n])
        self.skip(n, what)
        return text

    def list_(self, tag: int, what: str, least: int) -> int:
        found = self.integer(4, f"{what} list")
        n = self.integer(self.count, f"{what} list")
        if found == 0 and n == 0:
            return 0
        if found != tag:
            raise self.fail(f"the {what} list has tag {found}, expected {tag}")
        if n > _MAX_NESTING or n * least > self.size - self.pos:
            raise self.fail(f"the header declares {n} {what}s, more than the file can hold")
        return n

    def attributes(self, where: str) -> None:
        for _ in range(self.list_(_NC_ATTRIBUTE, f"attribute of {where}", 12)):
            self.name_(f"attribute name of {where}")
            kind = self.integer(4, f"attribute type of {where}")
            if kind not in _NC_TYPE_SIZES:
                raise self.fail(f"an attribute of {where} has unknown type {kind}")
            n = self.integer(self.count, f"attribute of {where}")
            self.skip(n * _NC_TYPE_SIZES[kind], f"attribute values of {where}")


def check_netcdf3(path: Path) -> None:
    """Check a NetCDF-3 file's header against the file before the library opens it.

    Walks the header with bounds (every count, name and attribute must fit in the file)
    and checks that every variable's data, at the offset the header states and with the
    size its dimensions (and the number of records) declare, lies inside the file.

    Parameters
    ----------
    path : Path
        The file; files that are not NetCDF-3 are left alone.

    Raises
    ------
    ValueError
        Truncated file or corrupted header; the message names the file, the variable and
        the sizes.
    """
    size = path.stat().st_size
    if size < 4:
        return
    with open(path, "rb") as fh:
        if fh.read(4) not in _NETCDF3:
            return
        with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as buf:
            _check_netcdf3_header(buf, path.name)


def check_hdf5_size(path: Path) -> None:
    r"""Check a NetCDF-4 (HDF5) file's size against the end of file its superblock states.

    The HDF5 library refuses a file shorter than that address but reads a longer one
    without a word; bytes inserted into the file shift every object after them.

    Parameters
    ----------
    path : Path
        The file; files that do not start with the HDF5 signature are left alone.

    Raises
    ------
    ValueError
        The file's size is not the superblock's end-of-file address; the message names the
        file and both numbers.

    Examples
    --------
    A version-2 superblock (8-byte addresses) stating an end of file at byte 100:

    >>> import tempfile
    >>> head = b"\x89HDF\r\n\x1a\n" + bytes([2, 8, 8, 0]) + bytes(16)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = Path(tmp) / "short.nc"
    ...     _ = path.write_bytes(head + (100).to_bytes(8, "little") + bytes(16))
    ...     check_hdf5_size(path)
    Traceback (most recent call last):
    ...
    ValueError: short.nc: truncated NetCDF-4 (HDF5) file: the superblock states an end ...
    """
    with open(path, "rb") as fh:
        head = fh.read(64)
    if not head.startswith(_HDF5) or len(head) < 14:
        return
    version = head[8]
    if version in (0, 1):  # then base, free-space and end-of-file addresses
        width, at = head[13], 24 + 4 * version
    elif version in (2, 3):  # then base, superblock-extension and end-of-file addresses
        width, at = head[9], 12
    else:
        return  # an unknown superblock: left to the library
    if width not in (2, 4, 8) or len(head) < at + 3 * width:
        return
    base = int.from_bytes(head[at:at + width], "little")
    end = base + int.from_bytes(head[at + 2 * width:at + 3 * width], "little")
    size = path.stat().st_size
    if size != end:
        raise ValueError(f"{path.name}: {'truncated' if size < end else 'corrupted'} "
                         f"NetCDF-4 (HDF5) file: the superblock states an end of file at "
                         f"byte {end}, the file has {size} bytes (bytes inserted into or cut "
                         "from the file shift its objects)")


def _check_netcdf3_header(buf, name: str) -> None:
    h = _Header(buf, name)
    h.pos = 4
    numrecs = h.integer(h.count, "number of records")
    streaming = numrecs == (1 << (8 * h.count)) - 1
    dims = []
    for _ in range(h.list_(_NC_DIMENSION, "dimension", 8)):
        dim_name = h.name_("dimension name")
        dims.append((dim_name, h.integer(h.count, "dimension length")))
    h.attributes("the file")
    variables = []
    for _ in range(h.list_(_NC_VARIABLE, "variable", 24)):
        var = h.name_("variable name").decode("utf-8", "replace")
        ndims = h.integer(h.count, f"dimensions of {var!r}")
        if ndims * h.count > h.size - h.pos:
            raise h.fail(f"variable {var!r} declares {ndims} dimensions")
        ids = [h.integer(h.count, f"dimension ids of {var!r}") for _ in range(ndims)]
        if any(i >= len(dims) for i in ids):
            raise h.fail(f"variable {var!r} refers to a dimension that does not exist")
        h.attributes(f"variable {var!r}")
        kind = h.integer(4, f"type of {var!r}")
        if kind not in _NC_TYPE_SIZES:
            raise h.fail(f"variable {var!r} has unknown type {kind}")
        vsize = h.integer(h.count, f"size of {var!r}")
        begin = h.integer(h.offset, f"offset of {var!r}")
        lengths = [dims[i][1] for i in ids]
        record = bool(lengths) and lengths[0] == 0
        count = 1
        for n in lengths[1:] if record else lengths:
            count *= n
        nbytes = count * _NC_TYPE_SIZES[kind]
        # the stated size is the data's (padded to 4 bytes), or all ones beyond 4 GiB
        if vsize not in (nbytes, nbytes + (-nbytes) % 4) and not (
                vsize == (1 << (8 * h.count)) - 1 and nbytes >= vsize - 3):
            raise h.fail(f"variable {var!r} states a size of {vsize} bytes, its dimensions "
                         f"and type make {nbytes}")
        variables.append((var, record, begin, nbytes))
    header_end = h.pos
    records = [v for v in variables if v[1]]
    recsize = sum(n + (-n) % 4 for *_, n in records) if len(records) > 1 else (
        records[0][3] if records else 0)
    spans = []  # (begin, end with padding, variable) of the data the header places
    for var, record, begin, nbytes in variables:
        if begin < header_end:
            raise h.fail(f"variable {var!r} starts at byte {begin}, inside the header "
                         f"(which ends at byte {header_end})")
        if record:
            if streaming or numrecs == 0:
                continue
            end = begin + (numrecs - 1) * recsize + nbytes
        else:
            end = begin + nbytes
        if end > h.size:
            raise h.fail(f"variable {var!r} needs the bytes {begin} to {end} by its "
                         f"header, the file has {h.size} bytes")
        spans.append((begin, end + (-nbytes) % 4, var, record))
    if streaming:
        return
    fixed = sorted(s for s in spans if not s[3])
    for (_, end, var, _), (begin, _, other, _) in zip(fixed, fixed[1:]):
        if begin < end:
            raise h.fail(f"the data of variable {other!r} (from byte {begin}) overlaps that "
                         f"of {var!r} (to byte {end}) by their offsets in the header")
    last = max((end for _, end, *_ in spans), default=header_end)
    if h.size > last:
        raise h.fail(f"the file has {h.size} bytes, {h.size - last} more than its header "
                     f"accounts for (the data end at byte {last} by the variables' offsets "
                     "and sizes): bytes inserted into the file shift the data")


def _walk(group, recursive: bool):
    yield group
    if recursive:
        for child in group.groups.values():
            yield from _walk(child, recursive)


def _storage(h5, var) -> tuple[int, int] | None:
    """Return the chunks allocated (-1: not chunked) and bytes stored of ``var``, or ``None``."""
    if h5 is None:
        return None
    group = var.group().path.rstrip("/")
    try:  # a variable named as a dimension it does not span has an internal HDF5 name
        found = h5.get(f"{group}/{var.name}") or h5.get(f"{group}/_nc4_non_coord_{var.name}")
        if found is None or not hasattr(found, "id"):
            return None
        chunked = found.chunks is not None
        return (found.id.get_num_chunks() if chunked else -1), found.id.get_storage_size()
    except Exception:  # noqa: BLE001 - a damaged index: left to the NetCDF library
        return None


def _open_h5(path: Path):
    """Open the file with h5py, to ask HDF5 what it stores; ``None`` without h5py."""
    try:
        import h5py
    except ImportError:
        return None
    try:
        return h5py.File(path, "r", locking=False)
    except Exception:  # noqa: BLE001 - not HDF5, or damaged: left to the NetCDF library
        return None


def check_declared_sizes(path: Path, name: str, *, group: str | None = None,
                         recursive: bool = False, max_points: int | None = MAX_POINTS,
                         advice: str = "pass max_points= to read a larger variable") -> None:
    """Refuse a NetCDF file whose variables declare more data than it holds, before reading.

    Only the metadata are read. A header is cheap to forge: a 1.5 MB file can declare a
    compressed 100000 x 100000 variable whose chunks are not written, which the NetCDF
    library reads as 74.5 GiB of fill values. Refused, naming the variable, its shape and
    why, are a variable

    - with more than ``max_points`` points;
    - with more than :data:`~xrough.io._common.MAX_CHUNKS` chunks (each an entry of the
      index and a dask task);
    - whose data are not in the file: with h5py installed, chunks HDF5 has not allocated
      (or contiguous data not stored) that, with those of the variables before it, would
      fill more than the file's size or 64 MiB, whichever is larger, with fill values;
      without h5py, variables whose data, uncompressed or deflated at zlib's largest
      ratio (1032:1), need more than twice the file's size (data compressed otherwise are
      bounded by ``max_points`` only).

    Parameters
    ----------
    path : Path
        The file (NetCDF-3 or NetCDF-4).
    name : str
        How messages name the file.
    group : str, optional
        The group whose variables are read (default: the root group).
    recursive : bool
        Also check the groups below it (an archive opens them all).
    max_points : int or None
        Most points of one variable; ``None``: no limit (a lazy open reads no variable
        whole).
    advice : str
        What to do about a variable of more than ``max_points``, for the message.

    Raises
    ------
    ValueError
        The message starts with ``name`` and names the variable, its group and shape.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = Path(tmp) / "forged.nc"
    ...     with netCDF4.Dataset(path, "w") as nc:
    ...         _ = nc.createDimension("x", 10**6)
    ...         _ = nc.createVariable("height", "f8", ("x",), chunksizes=(10**3,))
    ...     check_declared_sizes(path, "forged.nc", max_points=100)
    Traceback (most recent call last):
    ...
    ValueError: forged.nc: variable 'height' of group '/' declares shape (1000000,) ...
    """
    size = path.stat().st_size
    with open(path, "rb") as fh:
        hdf5 = fh.read(len(_HDF5)) == _HDF5
    with raw_hdf5():
        h5 = _open_h5(path) if hdf5 else None
        try:
            with netCDF4.Dataset(path) as nc:
                top = nc if group in (None, "", "/") else nc[group]
                _check_sizes(nc.data_model, _walk(top, recursive), h5, size, name,
                             max_points, advice)
        finally:
            if h5 is not None:
                h5.close()


_COMPRESSORS = ("zlib", "szip", "zstd", "bzip2", "blosc")


def _check_sizes(model: str, groups, h5, size: int, name: str, max_points: int | None,
                 advice: str) -> None:
    unwritten = needed = 0  # bytes of fill values from nothing; bytes the data need stored
    budget = max(size, _UNWRITTEN_BYTES)
    for grp in groups:
        for var in grp.variables.values():
            shape = tuple(int(n) for n in var.shape)
            points = math.prod(shape)
            itemsize = (var.dtype.itemsize if isinstance(var.dtype, np.dtype) else 0) or 8
            declared = points * itemsize
            head = (f"{name}: variable {var.name!r} of group {grp.path!r} declares shape "
                    f"{shape} ({points} points of {var.dtype}, {declared} bytes)")
            tail = "; refused before reading it (a corrupted or forged file?)"
            if max_points is not None and points > max_points:
                raise ValueError(f"{head}: more than the limit of {max_points} points "
                                 f"({advice}){tail}")
            layout = var.chunking() if model.startswith("NETCDF4") else "contiguous"
            chunked = layout != "contiguous"
            chunks = math.prod(-(-n // int(c)) for n, c in zip(shape, layout)) if chunked else 1
            if chunks > MAX_CHUNKS:
                raise ValueError(f"{head}: {chunks} chunks of {tuple(layout)}, more than "
                                 f"the limit of {MAX_CHUNKS}{tail}")
            stored = _storage(h5, var)
            if stored is not None:  # what HDF5 holds: allocated chunks, bytes stored
                allocated, nbytes = stored
                if allocated >= 0:
                    backed = allocated * math.prod(map(int, layout)) * itemsize
                    written = f"{allocated} of its {chunks} chunks are"
                else:
                    backed, written = nbytes, f"{nbytes} of its bytes are"
                unwritten += max(declared - backed, 0)
                if unwritten > budget:
                    raise ValueError(
                        f"{head}: only {written} written in the file of {size} bytes, the "
                        f"rest would be read as fill values ({declared - min(backed, declared)}"
                        f" bytes from nothing){tail}")
                continue
            filters = (var.filters() or {}) if chunked else {}
            compressed = [k for k in _COMPRESSORS if filters.get(k)]
            if not compressed:
                needed += declared
            elif compressed == ["zlib"]:
                needed += -(-declared // _DEFLATE_RATIO)
            if needed > 2 * size:
                how = "deflated at most 1032:1" if compressed else "uncompressed"
                raise ValueError(f"{head}: its data ({how}) cannot be in the file of {size} "
                                 "bytes: they are not written, and would be read as fill "
                                 f"values{tail}")


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
    return micro_as_u(str(_plain(units))) if units is not None else None


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
        return str(candidates[0])
    if not candidates:
        raise ValueError(f"{name}: no data variable in the root group (an xrough analysis "
                         "archive? open it with xrough.open_analysis, or pass group=)")
    raise ValueError(f"{name}: several variables ({', '.join(map(str, candidates))}); "
                     "choose the heights with variable=")


def read(path, *, variable: str | None = None, group: str | None = None,
         unit: str | None = None, height_unit: str | None = None, size=None,
         max_points: int | None = None) -> xr.DataArray:
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
    max_points : int, optional
        Refuse a variable of more points (default :data:`xrough.io._common.MAX_POINTS`);
        variables whose data the file does not hold are refused whatever their size
        (:func:`check_declared_sizes`).

    Returns
    -------
    xarray.DataArray
        The topography; a DataArray written by xrough comes back identical.

    Raises
    ------
    ValueError
        No or several candidate variables, dims other than ``x``/``y``, missing units, a
        truncated or corrupted file, a checksum that does not match, a variable declaring
        more data than ``max_points`` or than the file holds (the message names the file).
    FileNotFoundError, IsADirectoryError
        ``path`` is not a file.

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
    check_file(path)
    with reader_errors(path, "NetCDF"), HDF5_LOCK:
        return _read(path, variable, group, unit, height_unit, size, max_points)


def _open(path: Path, group: str | None = None) -> xr.Dataset:
    """Open a NetCDF file as :func:`read` does (and as :func:`write` checksums it)."""
    return xr.open_dataset(path, engine="netcdf4", group=group, decode_times=False)


def _root_attrs(path: Path) -> dict:
    with raw_hdf5(), netCDF4.Dataset(path) as nc:
        return {k: nc.getncattr(k) for k in nc.ncattrs()}


def _read(path: Path, variable, group, unit, height_unit, size, max_points) -> xr.DataArray:
    name = path.name
    check_netcdf3(path)
    check_hdf5_size(path)
    check_declared_sizes(path, name, group=group,
                         max_points=MAX_POINTS if max_points is None else int(max_points))
    try:
        with _open(path, group) as ds:
            for var_name, stored in ds.variables.items():
                with _checksum.reading(name, f"variable {var_name!r}"):
                    stored.load()
    except OSError as err:
        raise ValueError(f"{name}: cannot read as NetCDF ({err})") from err
    where = "/" + (group or "").strip("/")
    groups = _checksum.stored(name, ds.attrs if where == "/" else _root_attrs(path))
    if groups is not None:  # written by xrough: verify
        _checksum.verify(name, where, ds, (), groups.get(where))
        _checksum.check_missing(name, where, ds, groups[where].get("missing", {}))
    ds.attrs.pop(_checksum.KEY, None)
    for stored in ds.variables.values():  # files of earlier versions: their checksums
        stored.attrs.pop(_checksum.LEGACY, None)
    ds.attrs.pop(_checksum.LEGACY, None)
    chosen = _choose(ds, name, variable)
    da = ds[chosen]
    own = "units" in da.attrs and all("units" in da[d].attrs for d in ("x", "y")
                                       if d in da.coords)
    if chosen == _DATAARRAY_DEFAULT:
        da.name = None
    if "x" not in da.dims:
        raise ValueError(f"{name}: variable {chosen!r} has dims {da.dims}; a topography needs "
                         "dims ('y', 'x') or ('x',)")
    core = ("y", "x") if "y" in da.dims else ("x",)
    da = da.transpose(..., *core)
    attrs = {str(k): _plain(v) for k, v in da.attrs.items()}
    hunit = height_unit or unit or _units(attrs)
    if hunit is None:
        raise MissingOptionError(name, f"variable {chosen!r} has no units attribute",
                                 ("unit", "height_unit"), either=True)
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
            raise MissingOptionError(name, f"coordinate {d!r} has no units attribute",
                                     ("unit",))
        cattrs.pop("unit", None)
        cattrs["units"] = cunit if own and not unit else u.format_units(cunit)
        lunit = lunit or cunit
        da = da.assign_coords({d: (d, values, cattrs)})
    if periodic is not None:
        attrs["periodic"] = int(bool(int(periodic)))
    da.attrs = attrs
    da.encoding = {}
    for coord in da.coords:
        da[coord].encoding = {}
    if not own:
        da.name = "height"
        da.attrs.setdefault("long_name", "height")
    missing = [d for d in core if d not in da.coords]
    if missing:
        if size is None:
            raise MissingOptionError(name, f"no coordinate for {', '.join(missing)}", ("size",))
        return topography(da, size=size, unit=lunit, height_unit=da.attrs["units"])
    if size is not None:
        return topography(da.drop_vars(list(core)), size=size, unit=lunit,
                          height_unit=da.attrs["units"])
    return topography(da)


def write(topo: xr.DataArray, path, *, format: str = "NETCDF4") -> None:
    """Write a topography to NetCDF (the DataArray as it is, read back identical).

    In NetCDF-4 the heights and coordinates get HDF5's Fletcher-32 checksum per chunk; the
    SHA-256 digests of what it does not cover (attributes, dims, names, and in NetCDF-3
    every value) go to the global attribute ``xrough``. :func:`read` checks both and
    refuses a file whose values changed since (a corrupted file).

    Parameters
    ----------
    topo : xarray.DataArray
        A topography (:func:`xrough.topography`).
    path : str or Path
        The output file.
    format : {"NETCDF4", "NETCDF4_CLASSIC", "NETCDF3_64BIT", "NETCDF3_CLASSIC"}
        The NetCDF format (as in :meth:`xarray.DataArray.to_netcdf`).

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np, xrough
    >>> topo = xrough.topography(np.arange(12.0).reshape(3, 4), spacing="2 nm", unit="nm")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     write(topo, pathlib.Path(tmp) / "t.nc", format="NETCDF3_64BIT")
    ...     back = read(pathlib.Path(tmp) / "t.nc")
    >>> back.identical(topo)
    True
    """
    with HDF5_LOCK:  # the HDF5 library is not thread-safe
        _write(topo, path, format)


def _write(topo: xr.DataArray, path, format: str) -> None:
    topography(topo)  # validate before writing
    path = Path(path)
    fmt = "netcdf4" if format.upper().startswith("NETCDF4") else "netcdf3"
    name = topo.name
    if name is None or name in topo.coords or name in topo.dims:
        name = _DATAARRAY_DEFAULT  # what DataArray.to_netcdf names it
    variables = {name: topo.variable, **topo.coords.variables}
    encoding = {k: _checksum.chunk_encoding(v, fmt) for k, v in variables.items()}
    for k, v in variables.items():
        if v.dims == (k,):  # a coordinate variable: CF forbids it a _FillValue
            encoding[k]["_FillValue"] = None
    topo.to_netcdf(path, engine="netcdf4", format=format,  # type: ignore[call-overload]
                   encoding=encoding)  # format is checked by netCDF4 (a clear message)
    with raw_hdf5(), netCDF4.Dataset(path, "a") as nc:  # what the file follows (archives)
        nc.setncattr("Conventions", CONVENTIONS)
    entry: dict[str, Any] = {"missing": _checksum.missing_counts(variables)}
    with _open(path) as ds:
        entry["sha256"] = _checksum.digests(ds, (), entry)  # reads values without checksums
    _checksum.stamp(path, "netcdf", {"/": entry})
