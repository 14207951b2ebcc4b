"""Gwyddion native files (``.gwy``): read a data field, write a topography.

A ``.gwy`` file is the magic ``GWYP`` followed by a serialised ``GwyContainer`` whose
entries ``/N/data`` are ``GwyDataField`` channels (``xres``, ``yres``, ``xreal``,
``yreal``, ``xoff``, ``yoff``, ``si_unit_xy``, ``si_unit_z`` and the values row by row),
with an optional title ``/N/data/title``, mask ``/N/mask`` (1 = marked) and metadata
container ``/N/meta``. Parsing and serialising are done by the ``gwyfile`` package, after
:func:`check_structure` has walked the whole serialised tree with bounds: every object's
declared size, every component's type and every array's length must fit in the file, so a
corrupted file is refused in time proportional to its size instead of sending the parser
into an endless loop or a huge allocation.

Conventions:

- Gwyddion's row 0 is the *top* of the image (its y axis points down); xrough's row 0 is
  at ``y = 0`` and plots at the bottom (``origin="lower"``), so rows are reversed on read
  and on write: the picture is the same in both programs.
- Units are taken as the file states them. Gwyddion itself writes base SI units (``m``)
  and ignores a prefix in a stored unit string, so :func:`write` always stores metres.
- A mask marks points as NaN on read (``mask=False`` ignores it); on write, NaN points are
  filled with the mean of the valid heights and marked in a mask, so Gwyddion shows valid
  numbers and the round trip restores the NaNs.
- Metadata strings become attributes; values that read as integers or decimal numbers
  become ``int`` or ``float``. :func:`write` stores the attributes (except those it writes
  as structure: ``units``, ``channel``, ``channel_index``, ``x_offset``, ``y_offset``,
  ``masked_points``) as metadata strings.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path

import gwyfile
import numpy as np

from .. import units as u
from ..topography import grid_of, topography
from ._common import (
    check_file,
    choose_height_channel,
    default_channel_reader,
    describe_channel,
    fail,
    micro_as_u,
    reader_errors,
    select_channel,
)

__all__ = ["sniff", "read", "write", "channels", "default_channel"]

MAGIC = b"GWYP"
_STRUCTURAL = ("units", "channel", "channel_index", "x_offset", "y_offset", "masked_points")
_INT = re.compile(r"[-+]?\d+")
_FLOAT = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_DATA_KEY = re.compile(r"/(\d+)/data")
#: Bytes of the fixed-size component types and of the items of the fixed-size arrays.
_SCALAR_SIZES = {ord("b"): 1, ord("c"): 1, ord("i"): 4, ord("q"): 8, ord("d"): 8}
_ARRAY_SIZES = {ord("C"): 1, ord("I"): 4, ord("Q"): 8, ord("D"): 8}
_MAX_DEPTH = 64


def sniff(head: bytes, path: Path | None = None) -> bool:
    r"""Whether ``head`` starts with the Gwyddion magic ``GWYP``.

    Examples
    --------
    >>> sniff(b"GWYP" + b"GwyContainer\\0")
    True
    >>> sniff(b"GWYO")  # Gwyddion 1.x files are not supported
    False
    """
    return head[:4] == MAGIC


def _string_end(blob: bytes, pos: int, end: int, what: str) -> int:
    """Position after the NUL ending the string at ``pos``, which must end before ``end``."""
    stop = blob.find(b"\0", pos, end)
    if stop < 0:
        raise ValueError(f"{what} at byte {pos} is not terminated before byte {end}")
    return stop + 1


def _walk_object(blob: bytes, pos: int, end: int, depth: int) -> int:
    """Check the serialised object at ``pos`` (bounded by ``end``); return its end."""
    if depth > _MAX_DEPTH:
        raise ValueError(f"objects nested more than {_MAX_DEPTH} deep")
    name_end = _string_end(blob, pos, end, "an object name")
    if name_end == pos + 1:
        raise ValueError(f"an object at byte {pos} has an empty name")
    if name_end + 4 > end:
        raise ValueError(f"the object at byte {pos} lacks its size")
    (size,) = struct.unpack_from("<I", blob, name_end)
    start, stop = name_end + 4, name_end + 4 + size
    if stop > end:
        raise ValueError(f"the object at byte {pos} declares {size} bytes, only "
                         f"{end - start} are left")
    pos = start
    while pos < stop:
        pos = _walk_component(blob, pos, stop, depth)
    return stop


def _walk_component(blob: bytes, pos: int, end: int, depth: int) -> int:
    """Check one named component at ``pos`` (bounded by ``end``); return its end."""
    pos = _string_end(blob, pos, end, "a component name")
    if pos >= end:
        raise ValueError(f"the component ending at byte {pos} has no type")
    kind = blob[pos]
    pos += 1
    if kind in _SCALAR_SIZES:
        pos += _SCALAR_SIZES[kind]
    elif kind == ord("s"):
        pos = _string_end(blob, pos, end, "a string")
    elif kind == ord("o"):
        pos = _walk_object(blob, pos, end, depth + 1)
    elif kind in _ARRAY_SIZES or kind in (ord("S"), ord("O")):
        if pos + 4 > end:
            raise ValueError(f"the array at byte {pos} lacks its length")
        (n,) = struct.unpack_from("<I", blob, pos)
        pos += 4
        if n == 0:
            raise ValueError(f"the array at byte {pos} is empty (Gwyddion never writes one)")
        if kind in _ARRAY_SIZES:
            if kind == ord("C"):  # gwyfile cannot parse character arrays
                raise ValueError("character arrays (type 'C') are not supported")
            pos += n * _ARRAY_SIZES[kind]
        elif n > end - pos:
            raise ValueError(f"the array at byte {pos} declares {n} items, only "
                             f"{end - pos} bytes are left")
        else:
            for _ in range(n):
                pos = (_string_end(blob, pos, end, "a string") if kind == ord("S")
                       else _walk_object(blob, pos, end, depth + 1))
    else:
        raise ValueError(f"unknown component type {bytes([kind])!r} at byte {pos - 1}")
    if pos > end:
        raise ValueError(f"a component ends at byte {pos}, past the end of its object "
                         f"(byte {end})")
    return pos


def check_structure(blob: bytes, path: Path) -> None:
    r"""Walk a serialised ``.gwy`` file with bounds before it is parsed.

    The format is the magic ``GWYP`` and one object: a NUL-terminated type name, a 32-bit
    size and that many bytes of components, each a NUL-terminated name, a one-letter type
    (``b c i q d s o`` or the arrays ``C I Q D S O`` with a 32-bit length) and its value.
    Every size, length and string must fit inside the object that holds it, and the
    top-level object must end exactly at the end of the file.

    Parameters
    ----------
    blob : bytes
        The whole file.
    path : Path
        The file, named in the message.

    Raises
    ------
    ValueError
        Anything that does not fit; the message names the file and what is wrong.

    Examples
    --------
    >>> check_structure(b"GWYP" + b"GwyContainer\0" + bytes(4), Path("a.gwy"))
    >>> check_structure(b"GWYP" + b"GwyContainer\0" + b"\xff" * 4, Path("a.gwy"))
    Traceback (most recent call last):
    ...
    ValueError: a.gwy: truncated file: the container declares 4294967295 bytes ...
    """
    if blob[:4] != MAGIC:
        raise fail(path, "not a Gwyddion file (no 'GWYP' magic)")
    name_end = blob.find(b"\0", 4, 4 + 256)
    if name_end < 0 or len(blob) < name_end + 5:
        raise fail(path, "truncated file: the top-level object header is incomplete")
    (size,) = struct.unpack("<I", blob[name_end + 1:name_end + 5])
    if name_end + 5 + size > len(blob):
        raise fail(path, f"truncated file: the container declares {size} bytes but only "
                         f"{len(blob) - name_end - 5} follow")
    try:
        end = _walk_object(blob, 4, len(blob), 0)
    except ValueError as err:
        raise fail(path, f"corrupted Gwyddion file: {err}") from None
    if end != len(blob):
        raise fail(path, f"corrupted Gwyddion file: {len(blob) - end} bytes follow the "
                         "top-level object")


def _load(path: Path):
    """Load the top-level container after checking the whole serialised structure."""
    with open(path, "rb") as fh:
        blob = fh.read()
    check_structure(blob, path)
    try:
        obj = gwyfile.objects.GwyObject.frombuffer(blob[4:])
    except Exception as err:  # noqa: BLE001 - a corrupted stream fails in many ways
        raise fail(path, f"corrupted Gwyddion file ({type(err).__name__}: {err})") from None
    if not isinstance(obj, dict) or getattr(obj, "name", None) != "GwyContainer":
        raise fail(path, "the top-level object is not a GwyContainer")
    return obj


def _unit_of(field, key: str) -> str:
    unit = field.get(key)
    if unit is None:
        return ""
    try:
        return micro_as_u(str(unit["unitstr"] or ""))
    except (KeyError, TypeError):
        return ""


def _fields(container) -> list[dict]:
    out = []
    for key, value in container.items():
        match = _DATA_KEY.fullmatch(str(key))
        if match is None or getattr(value, "name", None) != "GwyDataField":
            continue
        index = int(match.group(1))
        xy, z = _unit_of(value, "si_unit_xy"), _unit_of(value, "si_unit_z")
        out.append({"index": index, "field": value,
                    "name": str(container.get(f"/{index}/data/title", f"channel {index}")),
                    "lateral_unit": xy, "unit": z,
                    "is_height": bool(xy and z and u.is_length(xy) and u.is_length(z))})
    return sorted(out, key=lambda c: c["index"])


def channels(path: str | Path) -> list[dict]:
    """List the data fields (channels) of a ``.gwy`` file.

    Returns
    -------
    list of dict
        ``index`` (Gwyddion's channel id, the ``N`` of ``/N/data``), ``name`` (title),
        ``unit``, ``lateral_unit`` and ``is_height`` (both are lengths).
    """
    path = Path(path)
    check_file(path)
    with reader_errors(path, "Gwyddion"):
        return [{k: c[k] for k in ("index", "name", "unit", "lateral_unit", "is_height")}
                for c in _fields(_load(path))]


def _default(path: Path, fields: list[dict], listing: str, *, warn: bool) -> dict:
    """Pick the data field read without ``channel=``: lengths for values and sizes.

    Among those, by what its title says (:func:`xrough.io._common.choose_height_channel`).
    """
    heights = [c for c in fields if c["is_height"]]
    if not heights:
        raise fail(path, f"no data field has length units for values and sizes; "
                         f"channels: {listing}")
    return choose_height_channel(path, heights, warn=warn)


default_channel = default_channel_reader(channels, _default, __name__)


def _parse_meta(value):
    if not isinstance(value, str):
        return value if isinstance(value, (int, float)) else str(value)
    text = value.strip()
    if _INT.fullmatch(text):
        number = int(text)
        return number if abs(number) < 2**63 else value
    if _FLOAT.fullmatch(text):
        return float(text)
    return value


def _meta_key(key: str) -> str:
    return str(key).lstrip("/").replace("/", "_") or "meta"


def read(path: str | Path, *, channel: str | int | None = None, mask: bool = True):
    """Read one data field of a Gwyddion ``.gwy`` file as a topography.

    Parameters
    ----------
    path : str or Path
        The file (recognised by its ``GWYP`` magic).
    channel : str or int, optional
        Title of the data field (case-insensitive) or Gwyddion's channel id (the ``N`` of
        ``/N/data``). Default: the first data field whose values and lateral sizes are
        lengths.
    mask : bool, default True
        Set the points marked by the channel's mask (``/N/mask``) to NaN.

    Returns
    -------
    xarray.DataArray
        Heights ``(y, x)`` in ``si_unit_z``, rows reversed so that Gwyddion's top row is
        at the largest ``y``; size ``(yreal, xreal)`` in ``si_unit_xy``. Attributes:
        ``channel`` (title), ``channel_index``, ``x_offset``/``y_offset`` (``xoff``,
        ``yoff``), ``masked_points`` (when a mask was applied) and the channel's
        metadata.

    Raises
    ------
    ValueError
        Unknown channel or one without length units (the message lists the channels),
        corrupted or truncated file (the message names the file).
    FileNotFoundError, IsADirectoryError
        ``path`` is not a file.
    TypeError
        ``channel`` is neither a title nor an id.
    """
    path = Path(path)
    if channel is not None and (isinstance(channel, bool) or not isinstance(
            channel, (str, int, np.integer))):
        raise TypeError(f"channel must be a title (str) or an id (int), got {channel!r}")
    check_file(path)
    with reader_errors(path, "Gwyddion"):
        return _read(path, channel, mask)


def _read(path: Path, channel, mask: bool):
    container = _load(path)
    fields = _fields(container)
    if not fields:
        raise fail(path, "the file holds no data fields (/N/data)")
    chosen = select_channel(path, fields, channel, default=_default, by_id=True)
    name = chosen["name"]
    if not chosen["is_height"]:
        raise fail(path, f"channel {describe_channel(chosen)} has values in "
                         f"{chosen['unit'] or 'no unit'!r} and sizes in "
                         f"{chosen['lateral_unit'] or 'no unit'!r}; a topography needs "
                         f"lengths for both")
    field = chosen["field"]
    try:
        xres, yres = int(field["xres"]), int(field["yres"])
        xreal, yreal = float(field["xreal"]), float(field["yreal"])
        values = np.asarray(field["data"], dtype=float)
    except (KeyError, TypeError, ValueError) as err:
        raise fail(path, f"channel {name!r}: incomplete data field ({err})") from None
    if xres < 2 or yres < 2 or values.size != xres * yres:
        raise fail(path, f"channel {name!r}: {values.size} values do not fill "
                         f"{xres} x {yres} points")
    if not (xreal > 0 and yreal > 0 and np.isfinite(xreal) and np.isfinite(yreal)):
        raise fail(path, f"channel {name!r}: sizes xreal={xreal!r}, yreal={yreal!r} are "
                         "not positive")
    values = values.reshape(yres, xres).copy()
    attrs: dict = {}
    meta = container.get(f"/{chosen['index']}/meta")
    if isinstance(meta, dict):
        codes = getattr(meta, "typecodes", {})
        for key, value in meta.items():
            if codes.get(key) == "c" and isinstance(value, int):  # a one-character string
                value = chr(value)
            key = _meta_key(key)
            if key in _STRUCTURAL:  # the reader sets these itself
                key = f"meta_{key}"
            attrs[key] = _parse_meta(value)
    mask_field = container.get(f"/{chosen['index']}/mask")
    if mask and mask_field is not None and getattr(mask_field, "name", "") == "GwyDataField":
        marked = np.asarray(mask_field.get("data", ()), dtype=float)
        if marked.size != values.size:
            raise fail(path, f"channel {name!r}: the mask has {marked.size} points, the "
                             f"data {values.size}")
        marked = marked.reshape(yres, xres) > 0.5
        values[marked] = np.nan
        attrs["masked_points"] = int(marked.sum())
    attrs.update(channel=name, channel_index=int(chosen["index"]),
                 x_offset=float(field.get("xoff", 0.0)),
                 y_offset=float(field.get("yoff", 0.0)))
    periodic = attrs.pop("periodic", None)
    return topography(values[::-1], size=(yreal, xreal), unit=chosen["lateral_unit"],
                      height_unit=chosen["unit"], name="height", attrs=attrs,
                      periodic=None if periodic is None else bool(periodic))


def _meta_string(value) -> str:
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return repr(value)
    return str(value)


def write(topo, path: str | Path) -> None:
    """Write a height map to a Gwyddion ``.gwy`` file (channel 0).

    Parameters
    ----------
    topo : xarray.DataArray
        A map ``(y, x)`` (:func:`xrough.topography`); profiles and stacks are refused.
    path : str or Path
        Output file.

    Notes
    -----
    Values and sizes are stored in metres (Gwyddion's convention), rows reversed to
    Gwyddion's top-down order, NaN points filled with the mean height and marked in
    ``/0/mask``; the title is ``attrs["channel"]`` (else the array's name) and the other
    attributes go to ``/0/meta``. :func:`read` of the written file gives back the map (in
    metres), its NaNs and its attributes.

    Raises
    ------
    ValueError
        If ``topo`` is not a single map or has no valid point.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib, xrough
    >>> topo = xrough.topography(np.arange(12.0).reshape(3, 4) * 1e-9, spacing="1 nm",
    ...                          unit="m")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     write(topo, pathlib.Path(tmp) / "map.gwy")
    ...     back = read(pathlib.Path(tmp) / "map.gwy")
    >>> bool((back.values == topo.values).all()), back.attrs["units"]
    (True, 'm')
    """
    path = Path(path)
    grid = grid_of(topo)
    if grid.dims != ("y", "x") or topo.ndim != 2:
        raise ValueError(f"a .gwy channel is one map with dims ('y', 'x'); got dims "
                         f"{topo.dims} (write each map of a stack separately)")
    fz = u.conversion_factor(grid.height_unit, "m")
    fxy = u.conversion_factor(grid.lateral_unit, "m")
    values = np.asarray(topo.transpose("y", "x").values, dtype=float)
    if fz != 1.0:
        values = values * fz
    data = values[::-1].copy()
    nan = np.isnan(data)
    if nan.all():
        raise ValueError("the map has no valid (non-NaN) point")
    if nan.any():
        data[nan] = float(np.mean(data[~nan]))
    (dy, dx), (ny, nx) = grid.spacing, grid.shape
    xreal, yreal = nx * dx * fxy, ny * dy * fxy
    x0 = float(topo["x"].values[0]) + float(topo.attrs.get("x_offset", 0.0))
    y0 = float(topo["y"].values[0]) + float(topo.attrs.get("y_offset", 0.0))
    objects = gwyfile.objects
    field = objects.GwyDataField(data, xreal=xreal, yreal=yreal, xoff=x0 * fxy,
                                 yoff=y0 * fxy, si_unit_xy="m", si_unit_z="m")
    container = objects.GwyContainer()
    container["/0/data"] = field
    container["/0/data/title"] = str(topo.attrs.get("channel") or topo.name or "height")
    container.typecodes["/0/data/title"] = "s"
    if nan.any():
        container["/0/mask"] = objects.GwyDataField(nan.astype(float), xreal=xreal,
                                                    yreal=yreal, xoff=x0 * fxy, yoff=y0 * fxy)
    meta = {str(k): _meta_string(v) for k, v in topo.attrs.items() if k not in _STRUCTURAL}
    if meta:
        container["/0/meta"] = objects.GwyContainer(meta, typecodes=dict.fromkeys(meta, "s"))
    with open(path, "wb") as fh:
        container.tofile(fh)
