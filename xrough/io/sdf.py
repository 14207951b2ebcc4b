"""ISO 25178-71 SDF (surface data file): read.

An SDF file starts with the magic ``aISO-1.0`` (text) or ``bISO-1.0`` (binary), then a
header (``NumPoints`` per profile, ``NumProfiles``, the scales ``Xscale``, ``Yscale``,
``Zscale`` in metres, ``Zresolution``, ``Compression``, ``DataType``...), the data (profile
after profile, ``NumPoints`` values each) and an optional free-text trailer::

    aISO-1.0
    ManufacID = ISOTC213
    NumPoints = 3
    NumProfiles = 2
    Xscale = 1.0E-6
    ...
    *
    1.0 2.0 3.0
    4.0 BAD 6.0
    *
    <OperatorName> Tom Jones </OperatorName>
    *

Heights are ``value * Zscale`` metres, the grid spacings ``Xscale`` and ``Yscale`` metres.
Missing points are ``BAD`` in text files and, for 16- and 32-bit integer data types, the
reserved extreme value (the minimum of signed and the maximum of unsigned types); they
become NaN. Not read: compressed data (``Compression`` other than 0) and the data
checksum (``CheckType``), whose algorithm the header does not identify.

Row orientation: ISO 25178-71 stores the profiles in the order of increasing ``y`` and
leaves the orientation of the picture to the software; Gwyddion and SurfaceTopography show
the first profile at the *top* of the image. xrough's rule for every reader is that row 0
of the returned array is ``y = 0`` and ``y = 0`` is the picture's *bottom* row as that
software displays it, so the profiles are reversed on read (the last profile is ``y = 0``).

Safety: the number of points the header declares is checked against the data the file
holds, and against ``max_points`` (default :data:`xrough.io._common.MAX_POINTS`), before any
array is allocated; ``Zscale`` must be finite and nonzero (0 made every height 0),
``Xscale`` and ``Yscale`` (of a map) finite and positive. Every failure is a
``ValueError`` naming the file (and the field, with its value).
"""

from __future__ import annotations

import math
import re
import struct
from pathlib import Path

import numpy as np

from ..topography import stored_step, topography
from ._common import check_file, check_points, invalid_as_missing, reader_errors

__all__ = ["sniff", "read"]

_TEXT_MAGIC = b"aISO-1.0"
_BINARY_MAGIC = b"bISO-1.0"
_BOM = b"\xef\xbb\xbf"
#: ``DataType`` codes of ISO 25178-71: numpy type and the marker of missing points.
_DATA_TYPES: dict[int, tuple[str, np.dtype, int | None]] = {
    0: ("UINT8", np.dtype("u1"), None),
    1: ("UINT16", np.dtype("<u2"), 2**16 - 1),
    2: ("UINT32", np.dtype("<u4"), 2**32 - 1),
    3: ("FLOAT", np.dtype("<f4"), None),
    4: ("INT8", np.dtype("i1"), None),
    5: ("INT16", np.dtype("<i2"), -(2**15)),
    6: ("INT32", np.dtype("<i4"), -(2**31)),
    7: ("DOUBLE", np.dtype("<f8"), None),
}
_REQUIRED = ("NumPoints", "NumProfiles", "Xscale", "Yscale", "Zscale", "DataType")
# binary header after the magic: ManufacID, CreateDate, ModDate, NumPoints, NumProfiles,
# Xscale, Yscale, Zscale, Zresolution, Compression, DataType, CheckType
_BINARY_HEADER = struct.Struct("<10s12s12sHHddddBBB")
_ATTR_NAMES = {"ManufacID": "manufacturer_id", "CreateDate": "create_date",
               "ModDate": "modification_date", "Zresolution": "z_resolution",
               "Compression": "compression", "DataType": "data_type",
               "CheckType": "check_type"}
_RESERVED = {"units", "long_name", "periodic", "name", "sampling", "format", "overrides",
             "source", "source_file", "source_sha256"}


def sniff(head: bytes, path: Path | None = None) -> bool:
    """Tell whether the file starts with the SDF magic ``aISO-1.0`` or ``bISO-1.0``."""
    head = head.removeprefix(_BOM)
    return head.startswith((_TEXT_MAGIC, _BINARY_MAGIC))


def _snake(name: str) -> str:
    name = re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", name.strip())
    return re.sub(r"\W+", "_", name).strip("_").lower()


def _number(text: str, key: str, path: Path, kind=float):
    try:
        value = float(text)
        if kind is int:
            if not value.is_integer():
                raise ValueError
            return int(value)
        return value
    except ValueError:
        raise ValueError(f"{path.name}: header field {key} = {text!r} is not "
                         f"{'an integer' if kind is int else 'a number'}") from None


def _parse_text(raw: bytes, path: Path):
    text = raw.decode("latin-1")
    lines = text.splitlines()
    try:
        end = next(i for i, line in enumerate(lines) if line.strip() == "*")
    except StopIteration:
        raise ValueError(f"{path.name}: the SDF header is not terminated by a line '*' "
                         "(truncated or not an SDF file)") from None
    header: dict[str, str] = {}
    for line in lines[1:end]:
        if not line.strip():
            continue
        key, sep, value = line.partition("=")
        if not sep:
            raise ValueError(f"{path.name}: malformed SDF header line {line.strip()!r} "
                             "(expected 'Key = value')")
        header[key.strip()] = value.strip()
    rest = lines[end + 1:]
    stop = next((i for i, line in enumerate(rest) if line.strip() == "*"), len(rest))
    tokens = " ".join(rest[:stop]).split()
    trailer_lines = rest[stop + 1:]
    if trailer_lines and trailer_lines[-1].strip() == "*":
        trailer_lines = trailer_lines[:-1]
    return header, tokens, "\n".join(trailer_lines).strip()


def _parse_binary(raw: bytes, path: Path):
    start = len(_BINARY_MAGIC)
    if len(raw) < start + _BINARY_HEADER.size:
        raise ValueError(f"{path.name}: the binary SDF header is truncated ({len(raw)} "
                         f"bytes, the header alone needs {start + _BINARY_HEADER.size})")
    fields = _BINARY_HEADER.unpack_from(raw, start)
    names = ("ManufacID", "CreateDate", "ModDate", "NumPoints", "NumProfiles", "Xscale",
             "Yscale", "Zscale", "Zresolution", "Compression", "DataType", "CheckType")
    header = {}
    for name, value in zip(names, fields):
        if isinstance(value, bytes):
            value = value.split(b"\0", 1)[0].decode("latin-1").strip()
        header[name] = str(value) if not isinstance(value, float) else repr(value)
    return header, raw[start + _BINARY_HEADER.size:]


def read(path: str | Path, *, max_points: int | None = None):
    """Read an ISO 25178-71 SDF file (text ``aISO-1.0`` or binary ``bISO-1.0``).

    Parameters
    ----------
    path : str or Path
        The ``.sdf`` file.
    max_points : int, optional
        Refuse a header declaring more points (default :data:`xrough.io._common.MAX_POINTS`).

    Returns
    -------
    xarray.DataArray
        Heights ``value * Zscale`` in metres on dims ``("y", "x")`` (one row per
        profile, the last profile at ``y = 0``, see the module notes on row orientation)
        or ``("x",)`` when the file has a single profile; spacings ``Xscale``
        and ``Yscale`` in metres. Attributes: ``manufacturer_id``, ``create_date``,
        ``modification_date`` (as written, ``DDMMYYYYHHMM``), ``z_resolution`` (metres;
        negative: unknown), ``compression``, ``data_type`` (code), ``check_type``, other
        header fields in snake case, and the text trailer as ``trailer`` with its
        ``<Tag>value</Tag>`` pairs as snake-case attributes (``operator_name``...).

    Raises
    ------
    ValueError
        Bad magic, missing or malformed header fields, compressed or too little data,
        more points than ``max_points``; the message names the file and the problem.
    FileNotFoundError, IsADirectoryError
        ``path`` is not a file.

    Examples
    --------
    >>> import os, tempfile
    >>> from xrough.io import sdf
    >>> text = '''aISO-1.0
    ... ManufacID = Example
    ... NumPoints = 3
    ... NumProfiles = 2
    ... Xscale = 1.0E-6
    ... Yscale = 2.0E-6
    ... Zscale = 1.0E-9
    ... Zresolution = -1
    ... Compression = 0
    ... DataType = 5
    ... CheckType = 0
    ... *
    ... 10 20 30
    ... 40 BAD 60
    ... *
    ... '''
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "map.sdf")
    ...     with open(path, "w") as fh:
    ...         _ = fh.write(text)
    ...     topo = sdf.read(path)
    >>> topo.shape, topo.attrs["units"], float(topo.x[1]), float(topo.y[1])
    ((2, 3), 'm', 1e-06, 2e-06)
    >>> topo.values * 1e9  # the last profile is y = 0
    array([[40., nan, 60.],
           [10., 20., 30.]])
    """
    path = Path(path)
    check_file(path)
    with reader_errors(path, "ISO 25178-71 SDF"):
        return _read(path, max_points)


def _read(path: Path, max_points: int | None):
    raw = path.read_bytes().removeprefix(_BOM)
    binary = raw.startswith(_BINARY_MAGIC)
    if not (binary or raw.startswith(_TEXT_MAGIC)):
        raise ValueError(f"{path.name}: not an SDF file (it does not start with "
                         f"'aISO-1.0' or 'bISO-1.0' but with {raw[:8]!r})")
    if binary:
        header, data = _parse_binary(raw, path)
        trailer = ""
    else:
        header, data, trailer = _parse_text(raw, path)
    field = _fields(header, path)
    nx, ny = field("NumPoints", int), field("NumProfiles", int)
    if nx < 1 or ny < 1:
        raise ValueError(f"{path.name}: NumPoints = {nx} and NumProfiles = {ny} must be "
                         "positive")
    check_points(path, nx * ny, max_points, f"the header ({nx} x {ny})")
    _check_scales(field, ny, path)
    heights, step = _heights(data, field, nx, ny, path)
    attrs = _attrs(header, trailer, path)
    heights = invalid_as_missing(path, heights, attrs, marker="the missing-point marker")
    if step is not None:  # float32 heights: their rounding, said by acf()
        attrs.update(stored_height_step=step, stored_dtype="float32 (SDF type FLOAT)")
    try:
        if ny == 1:
            return topography(heights, spacing=field("Xscale"), unit="m", attrs=attrs)
        # the first profile is the top of the picture: reversed, the last is y = 0
        return topography(heights.reshape(ny, nx)[::-1],
                          spacing=(field("Yscale"), field("Xscale")), unit="m", attrs=attrs)
    except ValueError as err:
        raise ValueError(f"{path.name}: {err}") from None


def _fields(header: dict[str, str], path: Path):
    """Check that the header has the required keys; return a reader of its numbers."""
    lower = {k.lower(): k for k in header}
    missing = [k for k in _REQUIRED if k.lower() not in lower]
    if missing:
        raise ValueError(f"{path.name}: the SDF header lacks {', '.join(missing)}")

    def field(key, kind=float, default=None):
        if key.lower() not in lower:
            return default
        return _number(header[lower[key.lower()]], key, path, kind)

    return field


def _check_scales(field, ny: int, path: Path) -> None:
    """Refuse a zero or non-finite ``Zscale`` and a spacing that is not a positive length.

    ``Zscale`` multiplies every stored value: 0 would make every height 0, NaN or inf
    every height missing or infinite (a negative one flips the heights, as stated).
    ``Yscale`` of a single profile is not used (files write 0 there).
    """
    z = field("Zscale")
    if not (math.isfinite(z) and z != 0):
        effect = "0" if z == 0 else "missing or infinite"
        raise ValueError(f"{path.name}: header field Zscale = {z!r} must be a finite, "
                         f"nonzero number of metres per stored value (every height would be "
                         f"{effect}); a damaged header")
    for key in ("Xscale", "Yscale") if ny > 1 else ("Xscale",):
        value = field(key)
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{path.name}: header field {key} = {value!r} must be a "
                             "finite, positive spacing (metres); a damaged header")


def _heights(data, field, nx: int, ny: int, path: Path) -> tuple[np.ndarray, float | None]:
    """Read the heights in metres, NaN at missing points, and their stored step.

    ``data`` is the binary payload (bytes) or the text tokens (a list of str). The step
    is that of binary float32 heights (:func:`xrough.topography.stored_step`, in metres),
    else None.
    """
    code = field("DataType", int)
    if code not in _DATA_TYPES:
        raise ValueError(f"{path.name}: unknown DataType {code} (known: 0-7)")
    compression = field("Compression", int, 0)
    if compression != 0:
        raise ValueError(f"{path.name}: compressed SDF data (Compression = {compression}) "
                         "is not supported")
    name, dtype, marker = _DATA_TYPES[code]
    n = nx * ny
    if isinstance(data, bytes):
        if len(data) < n * dtype.itemsize:
            raise ValueError(f"{path.name}: the file holds {len(data)} bytes of data, "
                             f"{nx} x {ny} points of type {name} need {n * dtype.itemsize} "
                             "(truncated)")
        stored = np.frombuffer(data, dtype=dtype, count=n)
        values = stored.astype(float)
    else:
        stored = None
        if len(data) != n:
            raise ValueError(f"{path.name}: the data section holds {len(data)} values, "
                             f"NumPoints x NumProfiles = {nx} x {ny} = {n} (truncated or "
                             "corrupted)")
        values = _text_values(data, path)
    if marker is not None:
        values[values == marker] = np.nan
    step = None
    if stored is not None and stored.dtype.kind == "f":
        step = stored_step(np.where(np.isnan(values), np.nan, stored))
    scale = field("Zscale")
    return values * scale, None if step is None else step * abs(scale)


def _text_values(tokens: list[str], path: Path) -> np.ndarray:
    """Numbers of the text data section; ``BAD`` (any case) is a missing point."""
    text = np.array(tokens)
    text[np.char.upper(text) == "BAD"] = "nan"
    try:
        return text.astype(float)
    except ValueError:  # numpy and Python parse a few spellings differently: one by one
        pass
    values = np.empty(len(tokens))
    for i, tok in enumerate(text):
        try:
            values[i] = float(tok)
        except ValueError:
            raise ValueError(f"{path.name}: data value {i} is not a number: "
                             f"{str(tok)!r}") from None
    return values


def _attrs(header: dict[str, str], trailer: str, path: Path) -> dict:
    """Attrs from the header (but the grid keys) and the XML-like tags of the trailer."""
    attrs: dict = {}
    for key, value in header.items():
        if key in _REQUIRED and key != "DataType":
            continue
        name = _ATTR_NAMES.get(key, _snake(key))
        if name in _RESERVED or not name:
            name = f"sdf_{name}"
        if key in ("Zresolution", "Xscale", "Yscale", "Zscale"):
            attrs[name] = _number(value, key, path)
        elif key in ("Compression", "DataType", "CheckType"):
            attrs[name] = _number(value, key, path, int)
        else:
            attrs[name] = value
    if trailer:
        attrs["trailer"] = trailer
        for tag, value in re.findall(r"<\s*([A-Za-z_][\w.-]*)\s*>(.*?)<\s*/\s*\1\s*>",
                                     trailer, flags=re.S):
            name = _snake(tag)
            if name in _RESERVED or name in attrs:
                name = f"trailer_{name}"
            attrs.setdefault(name, value.strip())
    return attrs
