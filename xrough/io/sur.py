"""Digital Surf SUR (MountainsMap studiables): read.

A SUR file is a sequence of objects, each a 512-byte little-endian header followed by a
comment, a private zone and the points: 16- or 32-bit integers, stored plainly (signature
``DIGITAL SURF``) or zlib-compressed in streams (``DSCOMPRESSED``). The header states the
object type (profile, surface, series...), the numbers of points per line and of lines,
the axis spacings with their unit strings, the Z spacing and offset, and whether
non-measured points are present (marked by the value ``Zmin - 2``).

Heights are ``raw * Zspacing + Zoffset`` in the Z step unit, the lateral spacings are in
the X (and Y) step units; an inverted object (``inversion`` 1, 2, 3) has its heights
negated and, for 2 and 3, is mirrored left-right or upside-down, as MountainsMap shows it.
The header's float32 values are taken at their shortest decimal form (a Z spacing stored
as the float32 nearest to ``1e-7`` is 1e-07, not 1.0000000116860974e-07).

Row orientation: the points are stored line after line; Gwyddion and SurfaceTopography
(whose rows xrough's bridge reverses) keep that order with the first line at the *top* of
the image, and Gwyddion applies the inversion flag to that picture. xrough's rule for every
reader is that row 0 of the returned array is ``y = 0`` and ``y = 0`` is the picture's
*bottom* row as that software displays it, so the lines are reversed on read (the last
stored line is ``y = 0``), after the inversion flag has been applied.

Safety: the points a header declares are checked against the file's size (plain data) or
against ``max_points`` (default :data:`xrough.io._common.MAX_POINTS`) and the stream
directory (compressed data, each stream inflated with a cap at the size the directory
states) before anything is allocated; the objects' sizes (header, comment, private zone,
points or compressed streams) must add up to the file's size, so that inserted or cut
bytes, which shift the data, are refused; every failure is a ``ValueError`` naming the
file.

Not read: the private zone, the client zone, intensity/RGB/binary images, spectra and
force curves (only height objects: profiles, surfaces and series or layers of them).
"""

from __future__ import annotations

import datetime
import struct
import zlib
from pathlib import Path

import numpy as np

from .. import units as u
from ..topography import topography
from ._common import check_file, check_points, invalid_as_missing, micro_as_u, reader_errors

__all__ = ["sniff", "read", "OBJECT_TYPES"]

_MAGICS = (b"DIGITAL SURF", b"DSCOMPRESSED")
_HEADER_SIZE = 512
_LARGE_RATIO, _LARGE_SIZE = 100, 256 << 20
#: Object ("studiable") types of MountainsMap.
OBJECT_TYPES = {
    0: "unknown", 1: "profile", 2: "surface", 3: "binary image", 4: "series of profiles",
    5: "series of surfaces", 6: "meridian disc", 7: "multilayer profile",
    8: "multilayer surface", 9: "parallel disc", 10: "intensity image",
    11: "intensity surface", 12: "RGB image", 13: "RGB surface", 14: "force curve",
    15: "series of force curves", 16: "RGB intensity surface", 17: "contour profile",
    18: "series of RGB images", 20: "spectrum", 21: "hyperspectral cube",
}
_HEIGHT_TYPES = {0, 1, 2, 4, 5, 7, 8, 11, 13, 16}
_ACQUISITION = {
    1: "contact stylus", 2: "scanning optical gauge", 3: "thermocouple",
    5: "contact stylus with skid", 6: "AFM", 7: "STM", 8: "video", 9: "interferometer",
    10: "structured light projection",
}
# (name, struct format, offset) of the header fields read
_FIELDS = (
    ("signature", "12s", 0), ("format", "H", 12), ("n_objects", "H", 14),
    ("version", "H", 16), ("object_type", "H", 18), ("object_name", "30s", 20),
    ("operator_name", "30s", 50), ("material_code", "H", 80), ("acquisition", "H", 82),
    ("range", "H", 84), ("special_points", "H", 86), ("absolute", "H", 88),
    ("w_size", "i", 94), ("point_size", "H", 98), ("z_min", "i", 100),
    ("z_max", "i", 104), ("nx", "i", 108), ("ny", "i", 112), ("n_points", "i", 116),
    ("dx", "f", 120), ("dy", "f", 124), ("dz", "f", 128), ("x_name", "16s", 132),
    ("y_name", "16s", 148), ("z_name", "16s", 164), ("dx_unit", "16s", 180),
    ("dy_unit", "16s", 196), ("dz_unit", "16s", 212), ("x_unit", "16s", 228),
    ("y_unit", "16s", 244), ("z_unit", "16s", 260), ("x_ratio", "f", 276),
    ("y_ratio", "f", 280), ("z_ratio", "f", 284), ("imprint", "H", 288),
    ("inversion", "H", 290), ("leveling", "H", 292), ("second", "H", 306),
    ("minute", "H", 308), ("hour", "H", 310), ("day", "H", 312), ("month", "H", 314),
    ("year", "H", 316), ("compressed_size", "I", 324), ("comment_size", "H", 334),
    ("private_size", "H", 336), ("x_offset", "f", 466), ("y_offset", "f", 470),
    ("z_offset", "f", 474),
)


def sniff(head: bytes, path: Path | None = None) -> bool:
    """Tell whether the file starts with ``DIGITAL SURF`` or ``DSCOMPRESSED``."""
    return head[:12] in _MAGICS


def _f32(value: float) -> float:
    """Return a float32 header value at its shortest decimal representation."""
    return float(str(np.float32(value)))


def _string(raw: bytes) -> str:
    return raw.split(b"\0", 1)[0].decode("latin-1").strip()


def _unit(text: str, path: Path, what: str) -> str:
    # besides its usual spellings, the micro sign appears as 0xE6 (an MS-DOS code page)
    clean = micro_as_u(text).replace("\xe6", "u")
    if not clean:
        raise ValueError(f"{path.name}: the {what} unit is empty; the file states no unit")
    try:
        return u.format_units(u.as_length_unit(clean, what=f"{what} unit"))
    except ValueError as err:
        raise ValueError(f"{path.name}: {err}") from err


def _header(raw: bytes, pos: int, path: Path, index: int) -> dict:
    if len(raw) < pos + _HEADER_SIZE:
        raise ValueError(f"{path.name}: object {index} is truncated: its 512-byte header "
                         f"ends at byte {pos + _HEADER_SIZE}, the file has {len(raw)}")
    h = {name: struct.unpack_from("<" + fmt, raw, pos + offset)[0]
         for name, fmt, offset in _FIELDS}
    if h["signature"] not in _MAGICS:
        raise ValueError(f"{path.name}: object {index} does not start with 'DIGITAL SURF' "
                         f"or 'DSCOMPRESSED' but with {h['signature']!r} (corrupted file)")
    if h["format"] not in (0, 1):
        raise ValueError(f"{path.name}: object {index} has format code {h['format']}; "
                         "only the PC (little-endian) layout is supported")
    for key in ("object_name", "operator_name", "x_name", "y_name", "z_name", "dx_unit",
                "dy_unit", "dz_unit", "x_unit", "y_unit", "z_unit"):
        h[key] = _string(h[key])
    if h["point_size"] not in (16, 32):
        raise ValueError(f"{path.name}: object {index} has {h['point_size']} bits per "
                         "point; SUR points have 16 or 32 (garbage header?)")
    if h["nx"] < 1 or h["ny"] < 1 or h["n_points"] != h["nx"] * h["ny"]:
        raise ValueError(f"{path.name}: object {index} states {h['nx']} points per line, "
                         f"{h['ny']} lines and {h['n_points']} points in total, which is "
                         "inconsistent (garbage header?)")
    h["data_start"] = pos + _HEADER_SIZE + h["comment_size"] + h["private_size"]
    return h


def _points(raw: bytes, h: dict, path: Path, index: int, decode: bool,
            trusted: bool = False):
    """Return the object's raw points (if ``decode``) and the position after them.

    Compressed data expanding more than ``_LARGE_RATIO``-fold to more than
    ``_LARGE_SIZE`` bytes is refused unless ``trusted`` (the caller set ``max_points``).
    """
    dtype = np.dtype("<i2" if h["point_size"] == 16 else "<i4")
    start = h["data_start"]
    count = h["n_points"] * (max(h["w_size"], 1) if h["object_type"] in (20, 21) else 1)
    if h["signature"] == b"DIGITAL SURF":
        end = start + count * dtype.itemsize
        if len(raw) < end:
            raise ValueError(f"{path.name}: object {index} is truncated: {count} points of "
                             f"{h['point_size']} bits need {end - start} bytes after the "
                             f"header, the file has {max(len(raw) - start, 0)}")
        return (np.frombuffer(raw, dtype, count, start) if decode else None), end
    # DSCOMPRESSED: stream count, (raw size, zipped size) per stream, then the streams
    if len(raw) < start + 4:
        raise ValueError(f"{path.name}: object {index} is truncated in its compressed "
                         "data directory")
    (n_streams,) = struct.unpack_from("<I", raw, start)
    if len(raw) < start + 4 + 8 * n_streams:
        raise ValueError(f"{path.name}: object {index} is truncated in its compressed "
                         f"data directory ({n_streams} streams announced)")
    sizes = struct.unpack_from(f"<{2 * n_streams}I", raw, start + 4)
    expected = count * dtype.itemsize
    if decode and sum(sizes[::2]) != expected:
        raise ValueError(f"{path.name}: object {index}: the compressed streams expand to "
                         f"{sum(sizes[::2])} bytes by their directory, {count} points of "
                         f"{h['point_size']} bits need {expected} (corrupted file)")
    pos = start + 4 + 8 * n_streams
    packed = sum(sizes[1::2])
    if decode and not trusted and expected > max(_LARGE_SIZE, _LARGE_RATIO * packed):
        raise ValueError(f"{path.name}: object {index}: {packed} bytes of compressed data "
                         f"are to expand to {expected}, more than {_LARGE_RATIO}-fold, "
                         "which measured heights do not (a corrupted or malicious file?); "
                         "pass max_points= to read it anyway")
    chunks = []
    for raw_size, zip_size in zip(sizes[::2], sizes[1::2]):
        if len(raw) < pos + zip_size:
            raise ValueError(f"{path.name}: object {index} is truncated in its compressed "
                             "data")
        if decode:
            chunks.append(_inflate(raw[pos:pos + zip_size], raw_size, path, index))
        pos += zip_size
    if not decode:
        return None, pos
    data = b"".join(chunks)
    if len(data) != count * dtype.itemsize:
        raise ValueError(f"{path.name}: object {index} decompresses to {len(data)} bytes, "
                         f"{count} points of {h['point_size']} bits need "
                         f"{count * dtype.itemsize}")
    return np.frombuffer(data, dtype, count), pos


def _inflate(stream: bytes, raw_size: int, path: Path, index: int) -> bytes:
    """Decompress one zlib stream, never producing more than ``raw_size`` bytes."""
    inflater = zlib.decompressobj()
    try:
        chunk = inflater.decompress(stream, raw_size + 1)
    except zlib.error as err:
        raise ValueError(f"{path.name}: object {index} has corrupted compressed data "
                         f"({err})") from None
    if len(chunk) > raw_size or inflater.unconsumed_tail:
        raise ValueError(f"{path.name}: object {index} has corrupted compressed data: a "
                         f"stream expands to more than the {raw_size} bytes the directory "
                         "states")
    if len(chunk) != raw_size or not inflater.eof:
        raise ValueError(f"{path.name}: object {index}: a compressed stream expands to "
                         f"{len(chunk)} bytes, the directory states {raw_size} "
                         "(truncated or corrupted)")
    return chunk


def read(path: str | Path, *, index: int = 0, max_points: int | None = None):
    """Read one object of a Digital Surf SUR file.

    Parameters
    ----------
    path : str or Path
        The ``.sur`` file.
    index : int, default 0
        Which object of a multi-object file (series, layers, surface with images) to
        read, counting from 0.
    max_points : int, optional
        Refuse an object declaring more points (default
        :data:`xrough.io._common.MAX_POINTS`), a guard against corrupted headers.

    Returns
    -------
    xarray.DataArray
        Heights in the file's Z step unit on dims ``("y", "x")`` (lines, points per line)
        or ``("x",)`` for a one-line object, lines reversed (the last stored line at
        ``y = 0``, see the module notes on row orientation), lateral coordinates in the X
        step unit (the Y spacing converted to it), non-measured points NaN.
        Attributes, where the file states them: ``object_type``, ``object_name``,
        ``operator_name``, ``acquisition``, ``date`` (ISO 8601), ``comment``, ``x_offset``
        / ``y_offset`` (lateral unit), ``inversion``, ``n_objects``, ``object_index``.

    Raises
    ------
    ValueError
        Bad signature, inconsistent header, truncated or corrupted data, an object that
        holds no heights, more points than ``max_points``, or ``index`` out of range; the
        message names the file and the problem.
    FileNotFoundError, IsADirectoryError
        ``path`` is not a file.

    Examples
    --------
    A one-object file of 2 lines of 3 points, 16-bit, packed by hand:

    >>> import os, struct, tempfile
    >>> import numpy as np
    >>> from xrough.io import sur
    >>> header = bytearray(512)
    >>> header[:12] = b"DIGITAL SURF"
    >>> struct.pack_into("<4H", header, 12, 0, 1, 1, 2)  # PC layout, 1 object, surface
    >>> struct.pack_into("<H5i", header, 98, 16, 0, 6, 3, 2, 6)  # bits, Zmin, Zmax, sizes
    >>> struct.pack_into("<3f", header, 120, 0.5, 0.25, 0.01)  # dx, dy, dz
    >>> for offset in (180, 196, 212):  # units of dx, dy, dz
    ...     header[offset:offset + 2] = b"um"
    >>> points = np.array([[1, 2, 3], [4, 5, 6]], dtype="<i2")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "map.sur")
    ...     with open(path, "wb") as fh:
    ...         _ = fh.write(bytes(header) + points.tobytes())
    ...     topo = sur.read(path)
    >>> topo.shape, topo.attrs["units"], float(topo.x[1]), float(topo.y[1])
    ((2, 3), 'um', 0.5, 0.25)
    >>> topo.values  # the last stored line is y = 0
    array([[0.04, 0.05, 0.06],
           [0.01, 0.02, 0.03]])
    """
    path = Path(path)
    check_file(path)
    index = int(index)
    with reader_errors(path, "Digital Surf SUR"):
        return _read(path, index, max_points)


def _read(path: Path, index: int, max_points: int | None):
    raw = path.read_bytes()
    if raw[:12] not in _MAGICS:
        raise ValueError(f"{path.name}: not a SUR file (it starts with {raw[:12]!r}, not "
                         "'DIGITAL SURF' or 'DSCOMPRESSED')")
    headers = _object_headers(raw, path)
    n_objects = len(headers)
    if not 0 <= index < n_objects:
        raise ValueError(f"{path.name}: index={index} but the file has {n_objects} "
                         f"object{'s' if n_objects > 1 else ''} (0 to {n_objects - 1})")
    h = headers[index]
    kind = OBJECT_TYPES.get(h["object_type"], f"type {h['object_type']}")
    if h["object_type"] not in _HEIGHT_TYPES:
        raise ValueError(f"{path.name}: object {index} is a {kind}, not heights; choose "
                         "another object with index=")
    check_points(path, h["n_points"], max_points, f"object {index}")
    points, _ = _points(raw, h, path, index, decode=True, trusted=max_points is not None)
    heights = _heights(points, h)
    attrs = _attrs(raw, h, kind)
    heights = invalid_as_missing(path, heights, attrs, marker="Zmin - 2 (non-measured)")
    if n_objects > 1:
        attrs.update(n_objects=n_objects, object_index=index)
    height_unit = _unit(h["dz_unit"], path, "Z")
    lateral_unit = _unit(h["dx_unit"], path, "X")
    dx = _f32(h["dx"])
    if not dx > 0:
        raise ValueError(f"{path.name}: the X spacing must be positive, got {dx}")
    # a ValueError without the file's name gets it from ``reader_errors``
    if h["ny"] == 1:
        return topography(heights[0], spacing=dx, unit=lateral_unit,
                          height_unit=height_unit, attrs=attrs)
    y_unit = _unit(h["dy_unit"], path, "Y")
    to_lateral = u.conversion_factor(y_unit, lateral_unit) if y_unit != lateral_unit else 1
    dy = _f32(h["dy"]) * to_lateral
    if h["y_offset"]:
        attrs["y_offset"] = _f32(h["y_offset"]) * u.conversion_factor(y_unit, lateral_unit)
    if not dy > 0:
        raise ValueError(f"the Y spacing must be positive, got {dy}")
    return topography(heights, spacing=(dy, dx), unit=lateral_unit, height_unit=height_unit,
                      attrs=attrs)


def _object_headers(raw: bytes, path: Path) -> list[dict]:
    """Read the header of every object and check their sizes against the file's."""
    first = _header(raw, 0, path, 0)
    n_objects = max(first["n_objects"], 1)
    pos, headers = 0, []
    for k in range(n_objects):
        headers.append(first if k == 0 else _header(raw, pos, path, k))
        _, pos = _points(raw, headers[-1], path, k, decode=False)
    if pos != len(raw):
        raise ValueError(f"{path.name}: the file has {len(raw)} bytes, {len(raw) - pos} more "
                         f"than the headers of its {n_objects} object(s) account for (the "
                         f"last data ends at byte {pos} by their comment, private zone and "
                         "point sizes): bytes inserted into the file shift the data")
    return headers


def _heights(points: np.ndarray, h: dict) -> np.ndarray:
    """Heights ``(ny, nx)`` in the Z unit, row 0 at y = 0, NaN at non-measured points."""
    heights = points.astype(float) * _f32(h["dz"])
    if h["z_offset"]:
        heights += _f32(h["z_offset"])
    if h["special_points"] == 1:
        heights[points == h["z_min"] - 2] = np.nan
    heights = heights.reshape(h["ny"], h["nx"])
    if h["inversion"] in (1, 2, 3):
        heights = -heights
        if h["inversion"] == 2:
            heights = heights[:, ::-1]
        elif h["inversion"] == 3:
            heights = heights[::-1, :]
    return heights[::-1]  # the first line is the top of the picture, the last y = 0


def _attrs(raw: bytes, h: dict, kind: str) -> dict:
    """Attrs of one object: its names, acquisition, date, comment, offset and inversion."""
    attrs: dict = {"object_type": kind}
    for key in ("object_name", "operator_name"):
        if h[key]:
            attrs[key] = h[key]
    if h["acquisition"] in _ACQUISITION:
        attrs["acquisition"] = _ACQUISITION[h["acquisition"]]
    if h["year"] > 0:
        try:
            attrs["date"] = datetime.datetime(h["year"], h["month"], h["day"], h["hour"],
                                              h["minute"], h["second"]).isoformat()
        except ValueError:
            pass
    start = h["data_start"] - h["comment_size"] - h["private_size"]
    comment = _string(raw[start:start + h["comment_size"]])
    if comment:
        attrs["comment"] = comment
    if h["x_offset"]:
        attrs["x_offset"] = _f32(h["x_offset"])
    if h["inversion"]:
        attrs["inversion"] = int(h["inversion"])
    return attrs
