"""Igor binary waves (``.ibw``), as written by Asylum Research (Oxford Instruments) AFMs.

An Igor binary wave (version 5) is a binary header, a wave header (dimensions ``nDim``,
wave scaling ``x = sfA * i + sfB`` per dimension, 3-character data and dimension units),
the wave data in column-major order, then optional sections: dependency formula, note,
extended data and dimension units, dimension labels. The ``igor2`` package parses it.

Asylum AFM images are 3D waves ``(x, y, channel)``: the labels of the third dimension name
the channels (``HeightTrace``, ``HeightRetrace``, ``AmplitudeTrace``, ``PhaseTrace``...) and
the note holds the instrument settings as ``Key: value`` lines. Asylum writes the same data
unit (``m``) for every channel, also for phase (degrees) or potential (volts); so with a
note, only channels named ``Height``, ``ZSensor``, ``Amplitude`` or ``Deflection`` (after
removing ``Trace``/``Retrace``, a ``Mod`` suffix and a ``Nap``/``DAC`` prefix) count as
lengths in the wave's data unit, unless the note gives ``<name>Unit``.

Orientation: Igor displays an image with ``x`` (rows, dimension 0) to the right and ``y``
(columns, dimension 1) upwards, which is xrough's convention: heights are the transposed
layer, ``values[j, i] = wave[i, j]``, at ``x = i * sfA[0]``, ``y = j * sfA[1]`` (the offsets
``sfB`` are kept in attributes). A negative ``sfA`` reverses that axis so that coordinates
increase. Note that Asylum's ``ScanSize`` is ``(n - 1) * sfA``, the distance between the
first and last points, while a topography's size is ``n * sfA``.

Sizes: the wave header's point count ``npnts`` must be the product of its dimensions and
fill the data size the binary header's ``wfmSize`` leaves; the sections end the file,
except for the thumbnails and text trailer Asylum's software appends, whose stated start,
sizes and length must then end it. Inserted or cut bytes are refused, naming the file.
"""

from __future__ import annotations

import io
import re
import struct
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np
from igor2 import binarywave

from .. import units as u
from ..topography import topography
from ._common import (
    MissingOptionError,
    channel_listing,
    choose_height_channel,
    default_channel_reader,
    describe_channel,
    fail,
    invalid_as_missing,
    micro_as_u,
    reader_errors,
    select_channel,
)

__all__ = ["sniff", "read", "channels", "default_channel"]

# Bytes summed by the header checksum (binary header + wave header), per version.
_CHECKSUM_BYTES = {1: (8 + 110,), 2: (16 + 110,), 3: (20 + 110,), 5: (64 + 320, 64 + 316)}
_LENGTH_PREFIXES = ("Height", "ZSensor", "Amplitude", "Deflection")
_OTHER_UNITS = (("Phase", "deg"), ("Potential", "V"), ("Current", "A"), ("Frequency", "Hz"))
#: Bytes per point of Igor's numeric types (the type code without its flags).
_ITEM_SIZES = {2: 4, 4: 8, 8: 1, 0x10: 2, 0x20: 4, 0x80: 8}
_ASYLUM_TAIL = re.compile(rb" (\d{4}) MFP3D\Z")


def _byte_order(head: bytes) -> tuple[str, int] | None:
    """Byte order and version from the first two bytes (the low byte is never 0)."""
    if len(head) < 2:
        return None
    if head[0]:
        return "<", struct.unpack("<h", head[:2])[0]
    return ">", struct.unpack(">h", head[:2])[0]


def _checksum_ok(head: bytes) -> bool:
    found = _byte_order(head)
    if found is None or found[1] not in _CHECKSUM_BYTES:
        return False
    order, version = found
    for size in _CHECKSUM_BYTES[version]:
        if len(head) >= size and \
                int(np.frombuffer(head[:size], dtype=f"{order}i2").sum()) % 65536 == 0:
            return True
    return False


def sniff(head: bytes, path: Path | None = None) -> bool:
    """Whether ``head`` starts with an Igor binary wave header (version and checksum).

    The version (1, 2, 3 or 5) in the first two bytes gives the byte order; the 16-bit
    words of the binary and wave headers must sum to zero (the header checksum).

    Examples
    --------
    >>> sniff(b"GWYP" + bytes(400))
    False
    """
    return _checksum_ok(head)


def _bin_header5(blob: bytes, order: str) -> dict:
    names = ("version", "checksum", "wfmSize", "formulaSize", "noteSize", "dataEUnitsSize")
    values = struct.unpack(order + "hhiiii", blob[:20])
    header = dict(zip(names, values))
    header["dimEUnitsSize"] = struct.unpack(order + "4i", blob[20:36])
    header["dimLabelsSize"] = struct.unpack(order + "4i", blob[36:52])
    header["sIndicesSize"] = struct.unpack(order + "i", blob[52:56])[0]
    return header


def _check(path: Path, blob: bytes) -> tuple[str, dict]:
    found = _byte_order(blob)
    if found is None or found[1] not in _CHECKSUM_BYTES:
        raise fail(path, "not an Igor binary wave (unknown version in the first two bytes)")
    order, version = found
    if version != 5:
        raise fail(path, f"Igor binary wave version {version}: only version 5 (Igor Pro 3+, "
                         "multidimensional waves as written by AFMs) is supported")
    if len(blob) < 384:
        raise fail(path, f"truncated file: {len(blob)} bytes, shorter than the 384-byte "
                         "headers")
    if not _checksum_ok(blob):
        raise fail(path, "corrupted Igor binary wave: the header checksum is wrong")
    header = _bin_header5(blob, order)
    sizes = [header["wfmSize"], header["formulaSize"], header["noteSize"],
             header["dataEUnitsSize"], *header["dimEUnitsSize"], *header["dimLabelsSize"],
             header["sIndicesSize"]]
    if min(sizes) < 0 or header["wfmSize"] < 320:
        raise fail(path, f"corrupted Igor binary wave: negative or too small section sizes "
                         f"{sizes}")
    needed = 64 + sum(sizes)
    if len(blob) < needed:
        raise fail(path, f"truncated file: the headers declare {needed} bytes but the file "
                         f"has {len(blob)}")
    _check_points(path, blob, order, header)
    _check_tail(path, blob, needed)
    return order, header


def _check_points(path: Path, blob: bytes, order: str, header: dict) -> None:
    """Refuse a wave whose point count, dimensions and data size disagree."""
    npnts, kind = struct.unpack_from(order + "ih", blob, 64 + 12)
    ndim = struct.unpack_from(order + "4i", blob, 64 + 68)
    itemsize = _ITEM_SIZES.get(kind & ~0x41)  # without the unsigned and complex flags
    if itemsize is None:  # text or unknown data: left to the wave parser
        return
    itemsize *= 2 if kind & 0x01 else 1
    dims = [n for n in ndim if n]
    count = int(np.prod(dims, dtype=object)) if dims else 0
    data_size = header["wfmSize"] - 320
    if min(ndim) < 0 or count != npnts:
        raise fail(path, f"corrupted Igor binary wave: the wave header's point count npnts "
                         f"{npnts} is not the product of its dimensions nDim {list(ndim)}")
    if data_size != npnts * itemsize:
        raise fail(path, f"corrupted Igor binary wave: the wave header's point count npnts "
                         f"{npnts} of {itemsize} bytes needs {npnts * itemsize} bytes of "
                         f"data, the binary header's wfmSize {header['wfmSize']} leaves "
                         f"{data_size}")


def _check_tail(path: Path, blob: bytes, end: int) -> None:
    """Refuse bytes after the wave's sections unless they are Asylum's thumbnails.

    Asylum's software appends 8-bit thumbnails of the channels and a text trailer
    (``...;HeightTraceFileStart:2112969;...;IsARDF:0; 0506 MFP3D``: the trailer's length
    and the thumbnails' start, number and length); their sum must end the file.
    """
    extra = len(blob) - end
    if not extra:
        return
    match = _ASYLUM_TAIL.search(blob[-16:])
    if match is None or int(match.group(1)) > extra:
        raise fail(path, f"{extra} bytes follow the wave's sections, which end at byte "
                         f"{end} by the binary header's section sizes (bytes inserted into "
                         "the file shift the data)")
    length = int(match.group(1))
    fields = dict(re.findall(rb"(\w+):([^;]*);", blob[-length:]))
    try:
        start = min(int(v) for k, v in fields.items() if k.endswith(b"FileStart"))
        thumbnails = int(fields[b"NumberOfFiles"]) * int(fields[b"DataLength"])
    except (KeyError, ValueError) as err:
        raise fail(path, f"corrupted Igor binary wave: the Asylum thumbnail trailer at the "
                         f"end of the file does not state its thumbnails ({err!r})") from err
    if start != end or end + thumbnails + length != len(blob):
        raise fail(path, f"the file has {len(blob)} bytes; the wave's sections end at byte "
                         f"{end}, the Asylum thumbnail trailer states thumbnails from byte "
                         f"{start} of {thumbnails} bytes and {length} bytes of trailer, "
                         f"{end + thumbnails + length} in all (bytes inserted into the file "
                         "shift the data)")


def _text(raw) -> str:
    if isinstance(raw, np.ndarray):
        raw = b"".join(raw.ravel().tolist()) if raw.dtype.kind == "S" else raw.tobytes()
    if isinstance(raw, (list, tuple)):
        raw = b"".join(raw)
    return bytes(raw).split(b"\0", 1)[0].decode("latin-1").strip()


def _extended_units(blob: bytes, header: dict) -> tuple[str, list[str]]:
    """Return the extended (over 3 characters) data and dimension units, '' if absent."""
    pos = 64 + header["wfmSize"] + header["formulaSize"] + header["noteSize"]
    data_unit = _text(blob[pos:pos + header["dataEUnitsSize"]])
    pos += header["dataEUnitsSize"]
    dims = []
    for size in header["dimEUnitsSize"]:
        dims.append(_text(blob[pos:pos + size]))
        pos += size
    return data_unit, dims


def _unit(text: str) -> str:
    """Igor unit spelling to a pint-readable one (SI symbols: ``A`` is the ampere)."""
    return micro_as_u(text.strip())


def _parse_note(note: str) -> dict[str, str]:
    entries: dict[str, str] = {}
    for line in note.replace("\r\n", "\n").replace("\r", "\n").split("\n"):
        key, sep, value = line.partition(":")
        if sep and key.strip():
            entries.setdefault(key.strip(), value.strip())
    return entries


def _base_name(name: str) -> str:
    base = re.sub(r"Mod\d*$", "", name)
    for suffix in ("Retrace", "Trace"):
        if base.endswith(suffix):
            base = base[: -len(suffix)]
            break
    for prefix in ("Nap", "DAC"):
        if base.startswith(prefix) and base[len(prefix):]:
            base = base[len(prefix):]
            break
    return base


def _channel_unit(name: str, data_unit: str, note: dict[str, str], labelled: bool) -> str:
    """Return the unit of one channel (see the module docstring)."""
    if not (note and labelled):
        return data_unit
    base = _base_name(name)
    for key in (f"{base}Unit", f"{name}Unit"):
        if note.get(key):
            return _unit(note[key])
    if base.startswith(_LENGTH_PREFIXES):
        return data_unit
    for prefix, unit in _OTHER_UNITS:
        if base.startswith(prefix):
            return unit
    return ""  # unknown quantity: not read as heights


def _load(path: Path):
    with open(path, "rb") as fh:
        blob = fh.read()
    _, header = _check(path, blob)
    try:
        wave = binarywave.load(io.BytesIO(blob))["wave"]
    except Exception as err:  # noqa: BLE001 - a corrupted stream fails in many ways
        raise fail(path, f"corrupted Igor binary wave ({type(err).__name__}: {err})") from err
    return blob, header, wave


def _layout(path: Path, blob: bytes, header: dict, wave) -> dict:
    wh = wave["wave_header"]
    data = wave["wData"]
    if not isinstance(data, np.ndarray) or data.dtype.kind not in "iuf":
        kind = "complex" if isinstance(data, np.ndarray) and data.dtype.kind == "c" else "text"
        raise fail(path, f"the wave holds {kind} data, not real numbers")
    ndim = [int(n) for n in wh["nDim"]]
    if ndim[3]:
        raise fail(path, "4D waves are not supported")
    shape = tuple(n for n in ndim if n)
    if data.shape != shape:
        raise fail(path, f"the wave data has shape {data.shape}, the header says {shape}")
    ext_data, ext_dims = _extended_units(blob, header)
    data_unit = _unit(ext_data or _text(wh["dataUnits"]))
    dim_units = [_unit(ext_dims[d] or _text(wh["dimUnits"][d])) for d in range(4)]
    note_text = _text(wave.get("note", b"")).replace("\r\n", "\n").replace("\r", "\n")
    note = _parse_note(note_text)
    labels = wave.get("labels") or []
    if len(shape) == 3:
        names = [_text(x) for x in (labels[2][1:] if len(labels) > 2 else [])]
        labelled = bool(names)
        names = (names + [""] * shape[2])[: shape[2]]
        names = [n or f"layer {k}" for k, n in enumerate(names)]
    else:
        labelled = False
        names = [_text(wh["bname"]) or "wave"]
    chans: list[dict[str, Any]] = [{"index": k, "name": n,
              "unit": _channel_unit(n, data_unit, note, labelled)}
             for k, n in enumerate(names)]
    for c in chans:
        c["is_height"] = bool(c["unit"]) and u.is_length(c["unit"])
    return {"data": data, "wave_header": wh, "shape": shape, "dim_units": dim_units,
            "note": note, "note_text": note_text, "channels": chans}


def channels(path: str | Path) -> list[dict]:
    """List the channels (layers) of an Igor binary wave.

    Returns
    -------
    list of dict
        ``index``, ``name`` (the layer's dimension label), ``unit`` (``""`` if not a
        known quantity) and ``is_height`` (the unit is a length).
    """
    path = Path(path)
    layout = _layout(path, *_load(path))
    return [dict(c) for c in layout["channels"]]


def _default(path: Path, chans: list[dict], listing: str, *, warn: bool) -> dict:
    """Pick the channel read without ``channel=``; warn when the choice is ambiguous.

    Among the channels with a length unit, by what their names say
    (:func:`xrough.io._common.choose_height_channel`); among heights ``Height...`` before
    ``ZSensor...``. A file with both (the feedback signal and the calibrated sensor) makes
    the choice ambiguous: a ``ChannelChoiceWarning`` names them.
    """
    heights = [c for c in chans if c["is_height"]]
    if heights:
        prefixes = ("Height", "ZSensor")
        return choose_height_channel(path, heights, warn=warn, key=lambda c: next(
            (i for i, p in enumerate(prefixes) if _base_name(c["name"]).startswith(p)),
            len(prefixes)))
    lacks = f"no height channel (with a length unit); channels: {listing}"
    if any(not c["unit"] for c in chans):
        raise MissingOptionError(path.name, f"{lacks}; a wave without a data unit needs one",
                                 ("unit", "height_unit"), either=True)
    raise fail(path, lacks)


def _channel_list(path: Path) -> list[dict]:
    return _layout(path, *_load(path))["channels"]


default_channel = default_channel_reader(_channel_list, _default, __name__)


def _date(note: dict[str, str]) -> str | None:
    date, time = note.get("Date"), note.get("Time")
    if not date:
        return None
    for fmt in ("%Y-%m-%d %I:%M:%S %p", "%Y-%m-%d %H:%M:%S"):
        try:
            return datetime.strptime(f"{date} {time}", fmt).isoformat()
        except ValueError:
            continue
    return f"{date} {time or ''}".strip()


def _float(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def read(path: str | Path, *, channel: str | int | None = None, unit: str | None = None,
         height_unit: str | None = None):
    """Read one channel of an Igor binary wave (Asylum AFM image) as a topography.

    Parameters
    ----------
    path : str or Path
        The file (recognised by its header version and checksum).
    channel : str or int, optional
        Layer name (``"HeightRetrace"``, case-insensitive) or index. Default: the first
        ``Height...`` channel (``HeightTrace`` in a usual Asylum file), else the first
        ``ZSensor...`` one, else the first channel with a length unit (a ``UserWarning``
        when both ``Height`` and ``ZSensor`` channels exist).
    unit : str, optional
        Lateral unit for a wave whose dimensions state none, and height unit for a wave
        (layer) whose data state none, unless ``height_unit`` is given. Units the file
        states are kept (:func:`xrough.open_topography` relabels them on request).
    height_unit : str, optional
        Height unit for a wave whose data state none.

    Returns
    -------
    xarray.DataArray
        Heights ``(y, x)`` (or ``(x,)`` for a 1D wave) in the wave's data unit, spacing
        from the wave scaling ``sfA`` in the dimension units. Attributes: ``channel``,
        ``channel_index``, ``wave_name``, ``x_offset``/``y_offset`` (``sfB``), and from an
        Asylum note ``instrument``, ``software_version``, ``igor_version``, ``date``
        (ISO 8601), ``imaging_mode``, ``scan_size`` (m), ``scan_angle`` (degrees),
        ``scan_rate`` (Hz) and
        ``note`` (the whole note text).

    Raises
    ------
    ValueError
        Missing channel or one that is not a height (the message lists the channels),
        unsupported wave, corrupted or truncated file (the message names the file).
    """
    path = Path(path)
    with reader_errors(path, "Igor binary wave"):
        return _read(path, channel, unit, height_unit)


def _read(path: Path, channel, unit, height_unit):
    layout = _layout(path, *_load(path))
    wh, shape, dim_units = layout["wave_header"], layout["shape"], layout["dim_units"]
    given = height_unit or unit
    if given is not None:  # the user's unit for data that state none
        given = u.format_units(u.as_length_unit(given, what="height_unit"))
        for c in layout["channels"]:
            if not c["unit"]:
                c.update(unit=given, is_height=True, unit_from="user")
    if unit is not None:
        lateral_given = u.format_units(u.as_length_unit(unit, what="unit"))
        dim_units = [d or lateral_given for d in dim_units]
    chosen = select_channel(path, layout["channels"], channel, default=_default)
    if not chosen["is_height"]:
        heights = channel_listing([c for c in layout["channels"] if c["is_height"]])
        raise fail(path, f"channel {describe_channel(chosen)} is not a height (a topography "
                         f"needs a length unit); height channels: {heights}")
    data = layout["data"]
    if len(shape) == 3:
        data = data[:, :, chosen["index"]]
    ndim = data.ndim
    if ndim not in (1, 2):
        raise fail(path, f"a {len(shape)}D wave of shape {shape} is not a map or profile")
    sfa = [float(v) for v in wh["sfA"][:ndim]]
    sfb = [float(v) for v in wh["sfB"][:ndim]]
    values = np.asarray(data, dtype=float)
    for d in range(ndim):
        if not (np.isfinite(sfa[d]) and sfa[d] != 0):
            raise fail(path, f"the wave scaling of dimension {d} is {sfa[d]!r}")
        if sfa[d] < 0:  # a reversed axis: flip so that coordinates increase
            values = np.flip(values, axis=d)
            sfb[d] += sfa[d] * (values.shape[d] - 1)
            sfa[d] = -sfa[d]
    lateral = dim_units[0]
    if not lateral:
        raise MissingOptionError(path.name, "the wave states no unit for its x dimension",
                                 ("unit",), advice=" (e.g. unit='um'); no unit is guessed")
    if not u.is_length(lateral):
        raise fail(path, f"the x dimension unit {lateral!r} is not a length")
    spacing = [sfa[0]]
    if ndim == 2:
        if not dim_units[1]:
            raise MissingOptionError(path.name, "the wave states no unit for its y dimension",
                                     ("unit",))
        if not u.is_length(dim_units[1]):
            raise fail(path, f"the y dimension unit {dim_units[1]!r} is not a length")
        spacing.append(sfa[1] * u.conversion_factor(dim_units[1], lateral))
        values = values.T  # Igor (x, y) -> (y, x)
    note = layout["note"]
    attrs = {
        "channel": chosen["name"],
        "channel_index": int(chosen["index"]),
        "wave_name": _text(wh["bname"]),
        "x_offset": sfb[0],
        "y_offset": sfb[1] if ndim == 2 else None,
        "instrument": note.get("MicroscopeModel"),
        "software_version": note.get("Version"),
        "igor_version": note.get("IgorFileVersion"),
        "date": _date(note),
        "imaging_mode": note.get("ImagingMode"),
        "scan_size": _float(note.get("ScanSize")),
        "scan_angle": _float(note.get("ScanAngle")),
        "scan_rate": _float(note.get("ScanRate")),
        "note": layout["note_text"],
        "units_from": "user (the file states none)" if chosen.get("unit_from") else None,
    }
    attrs = {k: v for k, v in attrs.items() if v not in (None, "")}
    values = invalid_as_missing(path, values, attrs, marker="NaN")
    return topography(values, spacing=tuple(reversed(spacing)), unit=lateral,
                      height_unit=chosen["unit"], name="height", attrs=attrs)
