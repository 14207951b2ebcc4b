"""ISO 25178-72 X3P (XML 3D surface profile): read and write.

An X3P file is a zip archive holding ``main.xml`` (geometry, data types, metadata and MD5
checksums) and, usually, the heights as little-endian binary ``bindata/data.bin`` with an
optional validity bit mask ``bindata/valid.bin``. Lengths are in metres by the standard.

Reading
    Areal maps (``FeatureType`` ``SUR``) and line profiles (``PRF``, or one line of a map)
    on incremental lateral axes (``AxisType`` ``I``: position = offset + index *
    increment); heights of type ``D`` (float64), ``F`` (float32), ``L`` (int32) or ``I``
    (int16) as ``raw * Increment + Offset`` of the Z axis; points stored in the binary
    member or inline as ``<DataList>``; invalid points (NaN, a cleared bit of the validity
    mask, an empty ``<Datum>``) become NaN. Every MD5 checksum the file carries (of
    ``main.xml``, of the point data, of the validity mask) is verified.
    The coordinates of the returned topography start at zero; non-zero axis offsets (the
    position of the first point on the instrument's stage) are kept in
    ``attrs["x_offset"]`` and ``attrs["y_offset"]`` (metres).
Row orientation
    ISO 25178-72 numbers the points row by row, the first row at the ``CY`` offset, and
    leaves the orientation of the picture to the software. Gwyddion and SurfaceTopography
    (whose rows xrough's bridge reverses) show the file's first row at the *top* of the
    image, like row 0 of a ``.gwy`` file. xrough's rule for every reader is that row 0 of
    the returned array is ``y = 0`` and ``y = 0`` is the picture's *bottom* row as that
    software displays it, so the rows are reversed on read (the file's last row is
    ``y = 0``) and again on write: the picture is the same in every program. xrough's
    ``y`` then runs against the standard's ``CY``; ``attrs["y_offset"]`` stays the file's
    ``CY`` offset (the position of its first row).
Safety
    Untrusted files cannot make the reader allocate more than the header declares: the
    header may declare at most ``max_points`` points (default :data:`MAX_POINTS`), each
    archive member is decompressed in a stream capped at the size the header requires
    (and refused before decompression when the archive states more, or a compression
    ratio no real data reaches), and inline ``<DataList>`` points are counted before any
    array is allocated. Every failure is a ``ValueError`` naming the file.
Not read
    Point clouds (``PCL``, ``ListDimension``), absolute lateral axes (coordinates stored per
    point), several layers (``SizeZ > 1``) and the optional rotation matrix.
Writing
    :func:`write` stores a map or a profile as float64 (or float32) in metres with all
    checksums, so that :func:`read` gives back an identical DataArray.
"""

from __future__ import annotations

import datetime
import hashlib
import re
import struct
import zipfile
import zlib
from pathlib import Path
from xml.etree import ElementTree

import numpy as np

from .. import units as u
from ..topography import grid_of, stored_step, topography
from ._common import check_file, check_points, invalid_as_missing, reader_errors

__all__ = ["sniff", "read", "write", "NAMESPACE"]

#: Deflate does not compress real data by more than about 1000:1; a member claiming more
#: is a zip bomb or a corrupted archive.
_MAX_RATIO = 1100
#: Unless the caller sets ``max_points``, a member expanding more than ``_LARGE_RATIO``-fold
#: to more than ``_LARGE_SIZE`` bytes is refused too: measured heights hardly compress.
_LARGE_RATIO, _LARGE_SIZE = 100, 256 << 20
#: Upper bound on the uncompressed size of ``main.xml`` and of the checksum file.
_MAX_XML = 2**31
_MAX_CHECKSUM_FILE = 1 << 16

#: XML namespace of ``main.xml``.
NAMESPACE = "http://www.opengps.eu/2008/ISO5436_2"
_XSI = "http://www.w3.org/2001/XMLSchema-instance"
_REVISION = "ISO5436 - 2000"
_DTYPES: dict[str, np.dtype] = {"I": np.dtype("<i2"), "L": np.dtype("<i4"),
                                "F": np.dtype("<f4"), "D": np.dtype("<f8")}
_MAIN = "main.xml"
_DATA_MEMBER = "bindata/data.bin"
_VALID_MEMBER = "bindata/valid.bin"
_CHECKSUM_MEMBER = "md5checksum.hex"

#: Record2 metadata: attribute name and element path below ``Record2``, in schema order.
_RECORD2 = (
    ("date", ("Date",)),
    ("creator", ("Creator",)),
    ("instrument_manufacturer", ("Instrument", "Manufacturer")),
    ("instrument_model", ("Instrument", "Model")),
    ("instrument_serial", ("Instrument", "Serial")),
    ("instrument_version", ("Instrument", "Version")),
    ("calibration_date", ("CalibrationDate",)),
    ("probing_system_type", ("ProbingSystem", "Type")),
    ("probing_system_identification", ("ProbingSystem", "Identification")),
    ("comment", ("Comment",)),
)
_PLACEHOLDERS = {"", "unknown", "not available", "n/a", "none"}


def sniff(head: bytes, path: Path | None = None) -> bool:
    """Tell whether the file is a zip archive whose ``main.xml`` is an ISO 5436-2 document.

    Parameters
    ----------
    head : bytes
        The first bytes of the file.
    path : Path, optional
        The file, opened to look for ``main.xml`` (which is not necessarily the first
        member of the archive).

    Returns
    -------
    bool
    """
    if not head.startswith(b"PK\x03\x04"):
        return False
    if path is None:
        return b"main.xml" in head
    try:
        with zipfile.ZipFile(path) as zf:
            main = _main_member(zf.namelist())
            if main is None:
                return False
            with zf.open(main) as fh:
                start = fh.read(2048)
    except (OSError, zipfile.BadZipFile, zlib.error, RuntimeError, ValueError, EOFError,
            NotImplementedError, struct.error, KeyError):
        return False
    return b"ISO5436_2" in start


# ------------------------------------------------------------------ shared safety rules


# ---------------------------------------------------------------------------- reading


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _child(elem, *names):
    """Descendant of ``elem`` along local tag ``names`` (namespaces ignored), or None."""
    for name in names:
        if elem is None:
            return None
        elem = next((c for c in elem if _local(c.tag) == name), None)
    return elem


def _text(elem, *names) -> str | None:
    node = _child(elem, *names)
    if node is None or node.text is None:
        return None
    return node.text.strip()


def _member(zf: zipfile.ZipFile, name: str, path: Path, what: str, limit: int,
            trusted: bool = False) -> bytes:
    """Extract one member, never decompressing more than ``limit`` bytes.

    ``trusted`` (the caller set ``max_points``) lifts the rule on large members that
    expand more than ``_LARGE_RATIO``-fold.
    """
    try:
        info = zf.getinfo(name)
    except KeyError:
        raise ValueError(f"{path.name}: the {what} {name!r} named in main.xml is missing "
                         "from the archive") from None
    if info.file_size > limit:
        raise ValueError(f"{path.name}: the {what} {name!r} holds {info.file_size} bytes, "
                         f"more than the {limit} the header allows (corrupted file)")
    if (info.compress_type != zipfile.ZIP_STORED
            and info.file_size > _MAX_RATIO * max(info.compress_size, 1)):
        raise ValueError(f"{path.name}: the {what} {name!r} claims to expand "
                         f"{info.compress_size} bytes to {info.file_size}, a compression "
                         "ratio no measured data reaches (zip bomb or corrupted archive)")
    if (not trusted and info.compress_type != zipfile.ZIP_STORED
            and info.file_size > max(_LARGE_SIZE, _LARGE_RATIO * info.compress_size)):
        raise ValueError(f"{path.name}: the {what} {name!r} expands {info.compress_size} "
                         f"bytes to {info.file_size}, more than {_LARGE_RATIO}-fold, which "
                         "measured heights do not (zip bomb?); pass max_points= to read it "
                         "anyway")
    try:
        with zf.open(info) as fh:
            data = fh.read(limit + 1)
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, RuntimeError,
            NotImplementedError) as err:
        raise ValueError(f"{path.name}: cannot extract {name!r} from the archive "
                         f"(corrupted or truncated file: {err})") from None
    if len(data) > limit:
        raise ValueError(f"{path.name}: the {what} {name!r} expands to more than the "
                         f"{limit} bytes the header allows (corrupted file)")
    return data


def _check_md5(data: bytes, expected: str | None, path: Path, what: str) -> None:
    if expected is None:
        return
    expected = expected.strip().lower()
    actual = hashlib.md5(data).hexdigest()
    if actual != expected:
        raise ValueError(f"{path.name}: MD5 checksum mismatch for {what}: the file states "
                         f"{expected}, the content has {actual} (corrupted file)")


def _float(text: str | None, path: Path, what: str, default=None) -> float | None:
    if text is None or text == "":
        return default
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"{path.name}: {what} is not a number: {text!r}") from None


def _int(text: str | None, path: Path, what: str) -> int:
    try:
        value = int(text or "")  # None: not an integer either
    except ValueError:
        raise ValueError(f"{path.name}: {what} must be an integer, got {text!r}") from None
    if value < 1:
        raise ValueError(f"{path.name}: {what} must be positive, got {value}")
    return value


def _axis(axes, name: str, path: Path) -> dict:
    node = _child(axes, name)
    if node is None:
        raise ValueError(f"{path.name}: main.xml has no axis {name} in Record1/Axes")
    return {
        "type": (_text(node, "AxisType") or "").upper(),
        "dtype": (_text(node, "DataType") or "").upper(),
        "increment": _float(_text(node, "Increment"), path, f"{name} Increment"),
        "offset": _float(_text(node, "Offset"), path, f"{name} Offset", default=0.0),
    }


def _read_datalist(datalist, n: int, path: Path) -> np.ndarray:
    """Heights stored inline in ``<DataList>``: one ``<Datum>`` per point, empty = invalid.

    The points are counted before the array is allocated, so a header claiming more
    points than the list holds fails without allocating.
    """
    data = [d for d in datalist if _local(d.tag) == "Datum"]
    if len(data) != n:
        raise ValueError(f"{path.name}: <DataList> holds {len(data)} points, the matrix "
                         f"dimensions ask for {n}")
    values = np.full(n, np.nan)
    for i, datum in enumerate(data):
        text = (datum.text or "").strip()
        if text:
            values[i] = _float(text.split(";")[-1], path, f"Datum {i}")
    return values


def read(path: str | Path, *, verify_checksums: bool = True, max_points: int | None = None):
    """Read an ISO 25178-72 X3P file.

    Parameters
    ----------
    path : str or Path
        The ``.x3p`` file.
    verify_checksums : bool, default True
        Check the MD5 checksums of ``main.xml``, of the point data and of the validity
        mask where the file states them.
    max_points : int, optional
        Refuse a file declaring more points (default :data:`MAX_POINTS`): a guard against
        corrupted headers and zip bombs.

    Returns
    -------
    xarray.DataArray
        Heights in metres on dims ``("y", "x")`` (map) or ``("x",)`` (profile), lateral
        coordinates in metres starting at zero (spacing = the axis increments), the file's
        last row at ``y = 0`` (see the module notes on row orientation). Attributes
        hold the file's metadata when present: ``date``, ``creator``,
        ``instrument_manufacturer``, ``instrument_model``, ``instrument_serial``,
        ``instrument_version``, ``instrument`` (manufacturer and model),
        ``calibration_date``, ``probing_system_type``, ``probing_system_identification``,
        ``comment``, and the non-zero axis offsets ``x_offset``, ``y_offset`` (metres).

    Raises
    ------
    ValueError
        Not a zip archive, no or malformed ``main.xml``, unsupported layout (point cloud,
        absolute lateral axes, several layers), a data member of the wrong size, more points
        than ``max_points``, a zip bomb, or a checksum mismatch; the message names the file
        and the problem.
    FileNotFoundError, IsADirectoryError
        ``path`` is not a file.

    Examples
    --------
    See :func:`write` for a round trip through a file.
    """
    path = Path(path)
    check_file(path)
    with reader_errors(path, "ISO 25178-72 X3P"):
        return _read(path, verify_checksums, max_points)


def _main_member(names: list[str]) -> str | None:
    """``main.xml`` at the archive's root, else in its one top folder, else None.

    The x3ptools R package (forensic surface metrology) writes ``NAME/main.xml``, with the
    members main.xml names (``bindata/data.bin``) and the checksum file in that folder.
    """
    if _MAIN in names:
        return _MAIN
    nested = [n for n in names if n.endswith("/" + _MAIN) and n.count("/") == 1]
    return nested[0] if len(nested) == 1 else None


def _read(path: Path, verify_checksums: bool, max_points: int | None):
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as err:
        raise ValueError(f"{path.name}: not a valid X3P file, the zip archive cannot be "
                         f"opened ({err})") from None
    with zf:
        root, folder = _document(zf, path, verify_checksums)
        grid = _grid(root, path, max_points)
        values, marker = _point_values(zf, folder, _child(root, "Record3"), grid, path,
                                       verify_checksums, max_points)
    attrs = _metadata(root)
    if folder:
        attrs["x3p_folder"] = folder.rstrip("/")
    values = invalid_as_missing(path, values, attrs, marker=marker)
    return _topography(values, grid, attrs, path)


def _document(zf: zipfile.ZipFile, path: Path, verify_checksums: bool):
    """Parse ``main.xml`` (checked against the checksum file) and check its records.

    Returns the document's root and the folder of ``main.xml`` (``""`` at the archive's
    root, else ``"NAME/"``), in which the members it names lie.
    """
    main = _main_member(zf.namelist())
    if main is None:
        raise ValueError(f"{path.name}: not an X3P file, the zip archive has no "
                         f"main.xml at its root or in one folder (members: "
                         f"{', '.join(zf.namelist()[:5])})")
    folder = main[:-len(_MAIN)]
    xml = _member(zf, main, path, "document", _MAX_XML)
    try:
        root = ElementTree.fromstring(xml)
    except ElementTree.ParseError as err:
        raise ValueError(f"{path.name}: main.xml is not well-formed XML ({err})") from None
    if _local(root.tag) != "ISO5436_2":
        raise ValueError(f"{path.name}: main.xml is not an ISO 5436-2 document (root "
                         f"element <{_local(root.tag)}>)")
    if _child(root, "Record1") is None or _child(root, "Record3") is None:
        raise ValueError(f"{path.name}: main.xml lacks Record1 or Record3")
    checksum_name = _text(root, "Record4", "ChecksumFile")
    if verify_checksums and checksum_name:
        listed = _member(zf, folder + checksum_name, path, "checksum file",
                         _MAX_CHECKSUM_FILE).decode("ascii", "replace")
        match = re.match(r"\s*([0-9a-fA-F]{32})", listed)
        if match is None:
            raise ValueError(f"{path.name}: the checksum file {checksum_name!r} holds "
                             "no MD5 checksum")
        _check_md5(xml, match.group(1), path, "main.xml")
    return root, folder


def _grid(root, path: Path, max_points: int | None) -> dict:
    """Return the feature type, the axes ``cx, cy, cz`` and the matrix size ``nx, ny``."""
    record1, record3 = _child(root, "Record1"), _child(root, "Record3")
    feature = (_text(record1, "FeatureType") or "SUR").upper()
    if feature == "PCL":
        raise ValueError(f"{path.name}: point clouds (FeatureType PCL) are not "
                         "supported, only maps (SUR) and profiles (PRF)")
    axes = _child(record1, "Axes")
    if axes is None:
        raise ValueError(f"{path.name}: main.xml has no Record1/Axes")
    cx, cy, cz = (_axis(axes, n, path) for n in ("CX", "CY", "CZ"))
    _check_axes(cx, cy, cz, path)
    if _child(record3, "ListDimension") is not None:
        raise ValueError(f"{path.name}: unordered point lists (ListDimension) are not "
                         "supported, only matrices")
    matrix = _child(record3, "MatrixDimension")
    if matrix is None:
        raise ValueError(f"{path.name}: main.xml has no Record3/MatrixDimension")
    nx = _int(_text(matrix, "SizeX"), path, "SizeX")
    ny = _int(_text(matrix, "SizeY"), path, "SizeY")
    nz = _int(_text(matrix, "SizeZ") or "1", path, "SizeZ")
    if nz != 1:
        raise ValueError(f"{path.name}: SizeZ = {nz}; several layers per point are not "
                         "supported")
    check_points(path, nx * ny, max_points, f"main.xml ({nx} x {ny})")
    return {"feature": feature, "cx": cx, "cy": cy, "cz": cz, "nx": nx, "ny": ny}


def _check_axes(cx: dict, cy: dict, cz: dict, path: Path) -> None:
    """Refuse lateral axes stored per point and a Z axis the standard does not allow."""
    for name, ax in (("CX", cx), ("CY", cy)):
        if ax["type"] != "I":
            raise ValueError(
                f"{path.name}: lateral axis {name} has AxisType {ax['type']!r}; only "
                "incremental axes ('I') are supported, not coordinates stored per point")
    if cz["type"] != "A":
        raise ValueError(f"{path.name}: the Z axis has AxisType {cz['type']!r}, the "
                         "standard requires 'A' (absolute)")
    if cz["dtype"] not in _DTYPES:
        raise ValueError(f"{path.name}: unknown Z data type {cz['dtype']!r} (known: "
                         f"{', '.join(_DTYPES)})")


def _point_values(zf: zipfile.ZipFile, folder: str, record3, grid: dict, path: Path,
                  verify_checksums: bool, max_points: int | None) -> tuple[np.ndarray, str]:
    """Return the raw heights (NaN where invalid) and how the file marks invalid points.

    The heights come from a binary member or from inline XML.
    """
    link, datalist = _child(record3, "DataLink"), _child(record3, "DataList")
    n = grid["nx"] * grid["ny"]
    if link is not None:
        values = _linked_values(zf, folder, link, grid, path, verify_checksums, max_points)
        has_mask = bool(_text(link, "ValidPointsLink"))
        return values, "the validity mask" if has_mask else "NaN"
    if datalist is not None:
        return _read_datalist(datalist, n, path), "empty <Datum> elements"
    raise ValueError(f"{path.name}: main.xml has neither DataLink nor DataList")


def _linked_values(zf: zipfile.ZipFile, folder: str, link, grid: dict, path: Path,
                   verify_checksums: bool, max_points: int | None) -> np.ndarray:
    """Heights from the binary point data member, masked by the validity mask if any."""
    nx, ny, cz = grid["nx"], grid["ny"], grid["cz"]
    n = nx * ny
    name = _text(link, "PointDataLink") or _DATA_MEMBER
    dtype = _DTYPES[cz["dtype"]]
    raw = _member(zf, folder + name, path, "point data", n * dtype.itemsize,
                  trusted=max_points is not None)
    if verify_checksums:
        _check_md5(raw, _text(link, "MD5ChecksumPointData"), path, name)
    if len(raw) != n * dtype.itemsize:
        raise ValueError(
            f"{path.name}: {name} has {len(raw)} bytes, but {nx} x {ny} points of "
            f"type {cz['dtype']} need {n * dtype.itemsize} (truncated or corrupted)")
    values = np.frombuffer(raw, dtype=dtype).astype(float)
    valid_name = _text(link, "ValidPointsLink")
    if valid_name:
        bits = _member(zf, folder + valid_name, path, "validity mask", (n + 7) // 8)
        if verify_checksums:
            _check_md5(bits, _text(link, "MD5ChecksumValidPoints"), path, valid_name)
        if len(bits) < (n + 7) // 8:
            raise ValueError(f"{path.name}: the validity mask {valid_name!r} has "
                             f"{len(bits)} bytes, {n} points need {(n + 7) // 8}")
        valid = np.unpackbits(np.frombuffer(bits, np.uint8), count=n,
                              bitorder="little").astype(bool)
        values[~valid] = np.nan
    return values


def _topography(values: np.ndarray, grid: dict, attrs: dict, path: Path):
    """Scale the heights by the Z axis and lay them out as a map or profile in metres."""
    cx, cy, cz, nx, ny = (grid[k] for k in ("cx", "cy", "cz", "nx", "ny"))
    dtype = _DTYPES.get(cz["dtype"])
    if dtype is not None and dtype.kind == "f":  # float32 heights: their rounding, said
        step = stored_step(values.astype(dtype))  # exact: the values came from that type
        if step is not None:
            attrs = {**attrs, "stored_height_step": step * abs(cz["increment"] or 1.0),
                     "stored_dtype": "float32 (X3P type F)"}
    if cz["increment"] is not None:
        values = values * cz["increment"]
    if cz["offset"]:
        values = values + cz["offset"]
    profile = ny == 1 or grid["feature"] == "PRF"
    if profile and ny != 1:
        raise ValueError(f"{path.name}: FeatureType PRF with SizeY = {ny}; a profile has "
                         "one line")
    for name, ax, dim in (("CX", cx, "x"), ("CY", cy, "y")):
        if dim == "y" and profile:
            continue
        if ax["increment"] is None or not ax["increment"] > 0:
            raise ValueError(f"{path.name}: axis {name} needs a positive Increment, got "
                             f"{ax['increment']!r}")
        if ax["offset"]:
            attrs[f"{dim}_offset"] = ax["offset"]
    try:
        if profile:
            return topography(values, spacing=cx["increment"], unit="m", attrs=attrs)
        # the file's first row is the top of the picture: reversed, the last is y = 0
        return topography(values.reshape(ny, nx)[::-1], spacing=(cy["increment"],
                                                                  cx["increment"]),
                          unit="m", attrs=attrs)
    except ValueError as err:
        raise ValueError(f"{path.name}: {err}") from None


def _metadata(root) -> dict:
    record2 = _child(root, "Record2")
    attrs: dict = {}
    if record2 is None:
        return attrs
    for key, names in _RECORD2:
        value = _text(record2, *names)
        if value:
            attrs[key] = value
    parts = [attrs.get(k) for k in ("instrument_manufacturer", "instrument_model")]
    named = [p for p in parts if p and p.lower() not in _PLACEHOLDERS]
    if named:
        attrs["instrument"] = " ".join(named)
    return attrs


# ---------------------------------------------------------------------------- writing


def _exact_step(values: np.ndarray) -> float:
    """Find ``d`` with ``values == values[0] + arange(n) * d`` exactly, if there is one."""
    n = values.size
    mean = (values[-1] - values[0]) / (n - 1)
    candidates = [values[1] - values[0], mean, float(f"{mean:.15g}"), float(f"{mean:.12g}")]
    rel = values - values[0]
    for step in candidates:
        if np.array_equal(np.arange(n) * step, rel):
            return float(step)
    return float(mean)


def write(topography, path: str | Path, *, dtype: str = "D",
          metadata: dict | None = None) -> None:
    """Write a map or profile to an ISO 25178-72 X3P file.

    Heights and lateral lengths are converted to metres. Rows are stored from the largest
    ``y`` down (the top of the picture first, see the module notes on row orientation).
    Missing points (NaN) are stored as NaN and flagged in a validity mask. The file
    carries MD5 checksums of ``main.xml`` and of the binary members.

    Parameters
    ----------
    topography : xarray.DataArray
        A map ``("y", "x")`` or profile ``("x",)`` (see :func:`xrough.topography`).
    path : str or Path
        Output file (usually ``.x3p``); overwritten if it exists.
    dtype : {"D", "F"}, default "D"
        Height data type: float64 (lossless) or float32.
    metadata : dict, optional
        Record2 fields by attribute name (``date``, ``creator``,
        ``instrument_manufacturer``, ``instrument_model``, ``instrument_serial``,
        ``instrument_version``, ``calibration_date``, ``probing_system_type``,
        ``probing_system_identification``, ``comment``), overriding the topography's attrs
        of the same name. Record2 is written only when at least one of them is given;
        required fields left out are written as ``"unknown"`` (dates: the current time).

    Notes
    -----
    The axis offsets are ``attrs["x_offset"]`` / ``attrs["y_offset"]`` (in the unit of
    the coordinate) plus the first coordinate value. Periodicity, other attributes and the
    DataArray's name are not stored. :func:`read` returns the written topography
    identically when its units are metres, its coordinates start at zero and its attrs are
    among those above.

    Raises
    ------
    ValueError
        Not a valid topography, a stack of several maps, decreasing coordinates, or an
        unknown ``dtype`` or metadata field.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np, xarray as xr, xrough
    >>> from xrough.io import x3p
    >>> h = np.random.default_rng(0).normal(scale=1e-7, size=(3, 4))
    >>> h[1, 2] = np.nan
    >>> topo = xrough.topography(h, spacing=(2e-6, 1e-6), unit="m")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "map.x3p")
    ...     x3p.write(topo, path)
    ...     back = x3p.read(path)
    >>> back.attrs.pop("invalid_points"), back.attrs.pop("invalid_marker")
    (1, 'the validity mask')
    >>> xr.testing.assert_identical(back, topo)
    >>> back.sizes["y"], back.sizes["x"], back.attrs["units"], float(back.x[1])
    (3, 4, 'm', 1e-06)
    """
    path = Path(path)
    dtype = str(dtype).upper()
    if dtype not in ("D", "F"):
        raise ValueError(f"dtype must be 'D' (float64) or 'F' (float32), got {dtype!r}")
    heights, increments, offsets = _in_metres(topography)
    profile = "y" not in increments
    ny, nx = (1, heights.size) if profile else heights.shape
    data, valid = _point_bytes(heights, dtype)
    fields = _record2_fields(topography, metadata)

    ElementTree.register_namespace("p", NAMESPACE)
    ElementTree.register_namespace("xsi", _XSI)
    root = ElementTree.Element(f"{{{NAMESPACE}}}ISO5436_2", {
        f"{{{_XSI}}}schemaLocation": f"{NAMESPACE} {NAMESPACE}/ISO5436_2.xsd"})
    _record1(root, profile, increments, offsets, dtype)
    if fields:
        _record2(root, fields)
    _records3_4(root, nx, ny, data, valid)
    ElementTree.indent(root)
    xml = ElementTree.tostring(root, encoding="UTF-8", xml_declaration=True)
    checksum = f"{hashlib.md5(xml).hexdigest()} *{_MAIN}\n".encode("ascii")
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.writestr(_MAIN, xml)
        zf.writestr(_DATA_MEMBER, data)
        if valid is not None:
            zf.writestr(_VALID_MEMBER, valid)
        zf.writestr(_CHECKSUM_MEMBER, checksum)


def _in_metres(topography) -> tuple[np.ndarray, dict, dict]:
    """Heights in metres (the top row first) and each axis' increment and offset in metres."""
    grid = grid_of(topography)
    extra = [d for d in topography.dims if d not in grid.dims]
    if extra:
        raise ValueError(f"an X3P file holds one map or profile; select one along {extra} "
                         "first")
    da = topography.transpose(*grid.dims)
    hfac = u.conversion_factor(grid.height_unit, "m")
    heights = np.asarray(da.values, dtype=float)
    if hfac != 1.0:
        heights = heights * hfac
    increments, offsets = {}, {}
    for dim in grid.dims:
        coord = np.asarray(da[dim].values, dtype=float)
        fac = u.conversion_factor(da[dim].attrs["units"], "m")
        step = _exact_step(coord)
        if not step > 0:
            raise ValueError(f"coordinate {dim!r} decreases; X3P axes increase, sort the "
                             f"topography first (topography.sortby({dim!r}))")
        increments[dim] = step * fac if fac != 1.0 else step
        offset = float(topography.attrs.get(f"{dim}_offset", 0.0)) + coord[0]
        offsets[dim] = offset * fac if fac != 1.0 else offset
    if grid.dims != ("x",):  # y = 0 is the picture's bottom row, X3P stores the top row first
        heights = heights[::-1]
    return heights, increments, offsets


def _point_bytes(heights: np.ndarray, dtype: str) -> tuple[bytes, bytes | None]:
    """Return the point data member and the validity mask (None if every point is valid)."""
    data = heights.astype(_DTYPES[dtype]).tobytes()
    invalid = np.isnan(heights).ravel()
    if not invalid.any():
        return data, None
    # one bit per point, least significant first, 1 = valid; the unused bits are set
    bits = np.ones(8 * ((invalid.size + 7) // 8), dtype=bool)
    bits[: invalid.size] = ~invalid
    return data, np.packbits(bits, bitorder="little").tobytes()


def _sub(parent, tag: str, text: str | None = None):
    el = ElementTree.SubElement(parent, tag)
    if text is not None:
        el.text = text
    return el


def _record1(root, profile: bool, increments: dict, offsets: dict, dtype: str) -> None:
    """Record1: the feature type and the axes."""
    record1 = _sub(root, "Record1")
    _sub(record1, "Revision", _REVISION)
    _sub(record1, "FeatureType", "PRF" if profile else "SUR")
    axes = _sub(record1, "Axes")
    for name, dim in (("CX", "x"), ("CY", "y")):
        ax = _sub(axes, name)
        _sub(ax, "AxisType", "I")
        _sub(ax, "DataType", "D")
        # a profile has one line; its CY increment is a placeholder equal to CX's
        _sub(ax, "Increment", repr(float(increments.get(dim, increments["x"]))))
        _sub(ax, "Offset", repr(float(offsets.get(dim, 0.0))))
    cz = _sub(axes, "CZ")
    _sub(cz, "AxisType", "A")
    _sub(cz, "DataType", dtype)


def _record2_fields(topography, metadata: dict | None) -> dict:
    """Record2 fields from the topography's attrs, overridden by ``metadata`` (checked)."""
    fields = {k: topography.attrs[k] for k, _ in _RECORD2 if k in topography.attrs}
    if "instrument_model" not in fields and "instrument" in topography.attrs and (
            "instrument_manufacturer" not in fields):
        fields["instrument_model"] = topography.attrs["instrument"]
    fields.update(metadata or {})
    unknown = set(fields) - {k for k, _ in _RECORD2}
    if unknown:
        raise ValueError(f"unknown X3P metadata fields: {sorted(unknown)}; known: "
                         f"{[k for k, _ in _RECORD2]}")
    return fields


def _record2(root, fields: dict) -> None:
    """Record2: the metadata, with the required fields left out written as defaults."""
    now = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    defaults = {"date": now, "calibration_date": fields.get("date", now),
                "probing_system_type": "Software"}
    record2 = _sub(root, "Record2")
    for key, names in _RECORD2:
        value = fields.get(key)
        if value is None and key in ("creator", "comment"):
            if key == "comment":
                _sub(record2, "Comment")
            continue
        value = str(value) if value is not None else defaults.get(key, "unknown")
        parent = record2
        for name in names[:-1]:
            found = _child(parent, name)
            parent = found if found is not None else _sub(parent, name)
        _sub(parent, names[-1], value)


def _records3_4(root, nx: int, ny: int, data: bytes, valid: bytes | None) -> None:
    """Record3 (the matrix size and the links to the binary members) and Record4."""
    record3 = _sub(root, "Record3")
    matrix = _sub(record3, "MatrixDimension")
    _sub(matrix, "SizeX", str(nx))
    _sub(matrix, "SizeY", str(ny))
    _sub(matrix, "SizeZ", "1")
    link = _sub(record3, "DataLink")
    _sub(link, "PointDataLink", _DATA_MEMBER)
    _sub(link, "MD5ChecksumPointData", hashlib.md5(data).hexdigest().upper())
    if valid is not None:
        _sub(link, "ValidPointsLink", _VALID_MEMBER)
        _sub(link, "MD5ChecksumValidPoints", hashlib.md5(valid).hexdigest().upper())
    record4 = _sub(root, "Record4")
    _sub(record4, "ChecksumFile", _CHECKSUM_MEMBER)
