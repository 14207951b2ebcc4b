r"""Digital Instruments / Veeco / Bruker Nanoscope AFM files (``.spm``, ``.001``, ``.di``...).

A Nanoscope file starts with a text header and continues with binary images::

    \*File list
    \Version: 0x07200000
    \Date: 03:08:09 PM Thu Apr 05 2018
    ...
    \*Scanner list
    \@Sens. Zsens: V 22.25786 nm/V                     <- soft scale (sensitivity)
    ...
    \*Ciao image list                                  <- one section per channel
    \Data offset: 40960
    \Data length: 524288
    \Bytes/pixel: 2
    \Samps/line: 512
    \Number of lines: 512
    \Scan Size: 100 100 nm
    \@2:Image Data: S [Height] "Height"
    \@2:Z scale: V [Sens. Zsens] (0.005035400 V/LSB) 329.9950 V
    ...
    \*File list end

Each image is ``Number of lines`` lines of ``Samps/line`` little-endian signed integers
(``Bytes/pixel`` 2 or 4) at ``Data offset``.

Height scaling
--------------
The ``@2:Z scale`` entry ``V [soft] (per-LSB) hard_value unit`` gives the *hard value*
``V_hard`` (here 329.9950 V), the voltage spanned by the full integer range, and names a
*soft scale* (``Sens. Zsens``) that is looked up as ``\@Sens. Zsens: V S unit`` in the other
sections (here S = 22.25786 nm/V). A raw integer ``n`` becomes the height

.. math:: z = n \cdot \frac{V_\mathrm{hard}}{2^{8\,b}} \cdot S

with ``b`` = ``Bytes/pixel`` as stated in the image section (``2^16`` for 16-bit data),
in the numerator unit of ``S`` (nm); a hard unit other than the sensitivity's denominator
(mV against nm/V) is converted. The parenthesised per-LSB value (0.005035400 V/LSB) is
the same quantity rounded to seven digits and is not used. If the Z scale names no soft
scale, the hard value's own unit is the height unit. Channels whose unit is not a length
(phase, amplitude error...) are listed but cannot be read as topographies.

Sizes: the data length of each image must be ``Samps/line x Number of lines x
Bytes/pixel``. When it is not, but the scan list's resolution fits, the image is read with
the scan list's points over the stated ``Scan Size``, with a ``UserWarning`` and
``attrs["header_inconsistency"]``; any other mismatch is an error naming the file.
The header text must fit in the header length the ``\*File list`` states, every section's
data must lie after it, and the last ``Data offset + Data length`` must be the file's size:
bytes inserted into the file or cut from it (which would shift the data against the
offsets) are refused.

Channels: :func:`channels` lists them, :func:`default_channel` names the one read without
``channel=``; two different height quantities on the main scan line (``Height`` and
``ZSensor``) make that choice ambiguous and :func:`read` warns.

Orientation: lines are kept in file order, the first stored line at ``y = 0`` (the bottom
of the image as the instrument displays it; Gwyddion and SurfaceTopography flip the rows
because their row 0 is the top). Lateral sizes come from ``Scan Size`` (fast axis ``x``,
slow axis ``y``; one number means a square scan).
"""

from __future__ import annotations

import re
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from .. import quality
from .. import units as u
from ..topography import topography
from ._common import (
    channel_listing,
    choose_height_channel,
    default_channel_reader,
    fail,
    micro_as_u,
    reader_errors,
    select_channel,
)

__all__ = ["sniff", "read", "channels", "default_channel", "parse_value"]

_MAGICS = (b"\\*File list", b"\\\\*File list", b"?*File list")
_END = "*file list end"
_IMAGE_SECTIONS = ("ciao image list", "afm image list", "stm image list",
                   "ncafm image list", "image list")
_MAX_HEADER = 1 << 24  # 16 MiB of header text is far beyond any real file
# Files of Nanoscope 9.2 and later are reported to hold 32-bit integers even when
# Bytes/pixel says 2 (which then only sets the scaling); recognised by the data length.
_VERSION_32BIT = 0x09200000
_HEIGHT_NAMES = ("height", "height sensor", "zsensor", "z sensor")


def sniff(head: bytes, path: Path | None = None) -> bool:
    r"""Whether ``head`` starts like a Nanoscope file (``\*File list``), by content only.

    Examples
    --------
    >>> sniff(b"\\*File list\r\n\\Version: 0x07200000\r\n")
    True
    >>> sniff(b"GWYP")
    False
    """
    return head.lstrip(b"\r\n\t ").startswith(_MAGICS)


def _read_header(path: Path) -> tuple[str, bool]:
    r"""Read the header text up to ``\*File list end``; and whether the data is text."""
    raw = b""
    with open(path, "rb") as fh:
        while len(raw) <= _MAX_HEADER:
            block = fh.read(1 << 16)
            if not block:
                break
            raw += block
            if not sniff(raw[:64]):
                raise fail(path, "not a Nanoscope file (no '\\*File list' header)")
            if b"file list end" in raw[-len(block) - 16:].lower():
                break
    if not raw:
        raise fail(path, "the file is empty")
    end = raw.lower().find(b"file list end")
    if end < 0:
        raise fail(path, "the header ends before '\\*File list end' (truncated file?)")
    text = raw[: end + len(b"file list end")].decode("latin-1")
    return text, raw.lstrip().startswith(b"?")


def _parse_header(path: Path, text: str) -> list[tuple[str, dict[str, str]]]:
    """Split the header into ``(section name, {key: value})`` in file order."""
    sections: list[tuple[str, dict[str, str]]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.strip()
        if not line:
            continue
        if line.startswith("?"):  # text-data files mark lines with '?'
            line = "\\" + line[1:]
        if not line.startswith("\\"):
            raise fail(path, f"header line {number} does not start with '\\': {line[:60]!r}")
        line = line.lstrip("\\")
        if line.startswith("*"):
            name = line[1:].strip()
            if name.lower() == _END[1:]:
                break
            sections.append((name, {}))
            continue
        if not sections:
            raise fail(path, f"header line {number} comes before any '\\*' section")
        key, sep, value = line.partition(": ")
        if not sep:
            key, value = line.rstrip(":"), ""
        sections[-1][1][key.strip()] = value.strip()
    if not sections or sections[0][0].lower() not in ("file list", "ec file list"):
        raise fail(path, "the header does not start with a '\\*File list' section")
    return sections


def parse_value(value: str) -> tuple[str, str | None, str | None, str]:
    r"""Split a ``\@`` header value into type, soft scale, per-LSB scale and hard value.

    Parameters
    ----------
    value : str
        For example ``"V [Sens. Zsens] (0.005035400 V/LSB) 329.9950 V"``.

    Returns
    -------
    tuple
        ``(type, soft_scale, per_lsb, hard_value)``; type is ``V`` (value), ``C``
        (scale) or ``S`` (selection), the others ``None`` when absent.

    Examples
    --------
    >>> parse_value("V [Sens. Zsens] (0.005035400 V/LSB) 329.9950 V")
    ('V', 'Sens. Zsens', '0.005035400 V/LSB', '329.9950 V')
    >>> parse_value("V 22.25786 nm/V")
    ('V', None, None, '22.25786 nm/V')
    >>> parse_value('S [Height] "Height"')
    ('S', 'Height', None, '"Height"')
    """
    value = value.strip()
    kind, rest = value[:1], value[1:].strip()
    soft = None
    if rest.startswith("["):
        end = rest.find("]")
        if end < 0:
            raise ValueError(f"unbalanced '[' in {value!r}")
        soft = rest[1:end].strip() or None
        rest = rest[end + 1:].strip()
    per_lsb = None
    if rest.startswith("("):
        depth, end = 0, -1
        for pos, char in enumerate(rest):  # units may contain parentheses: log(Arb)
            depth += {"(": 1, ")": -1}.get(char, 0)
            if depth == 0:
                end = pos
                break
        if end < 0:
            raise ValueError(f"unbalanced '(' in {value!r}")
        per_lsb = rest[1:end].strip()
        rest = rest[end + 1:].strip()
    return kind, soft, per_lsb, rest


def _number_unit(text: str, what: str) -> tuple[float, str]:
    parts = text.split(None, 1)
    try:
        number = float(parts[0])
    except (IndexError, ValueError):
        raise ValueError(f"{what}: expected a number, got {text!r}") from None
    return number, parts[1].strip() if len(parts) > 1 else ""


def _unit(text: str) -> str:
    """Nanoscope unit spelling to a pint-readable one (``~m`` and ``µm`` are micrometres)."""
    text = micro_as_u(text.strip().replace("~", "u"))
    return {"\xba": "deg", "\xb0": "deg"}.get(text, text)


def _lookup(sections, key: str) -> str | None:
    key = key.lower()
    for _, entries in sections:
        for k, v in entries.items():
            if k.lower() == key:
                return v
    return None


def _section_value(entries: dict[str, str], *keys: str) -> str | None:
    lowered = {k.lower(): v for k, v in entries.items()}
    for key in keys:
        if key.lower() in lowered:
            return lowered[key.lower()]
    return None


def _scale_entry(path: Path, raw: str, what: str) -> tuple[str | None, float, str]:
    r"""Soft scale name, number and unit of a ``\@`` value (a Z scale or a sensitivity)."""
    try:
        _, soft_name, _, text = parse_value(raw)
        number, unit = _number_unit(text, what)
    except ValueError as err:
        raise fail(path, str(err)) from None
    return soft_name, number, _unit(unit)


def _z_scale(path, sections, entries, name) -> tuple[float, str, str, str]:
    """Height per LSB (before the 2**(8 b) division), its unit, and a formula text."""
    raw = None
    for key, value in entries.items():
        if re.fullmatch(r"@\d:z scale", key.lower()):
            raw = value
            if key.startswith("@2"):
                break
    if raw is None:
        if _section_value(entries, "Z scale") is not None:
            raise fail(path, f"channel {name!r}: old-style 'Z scale' without '@' (Nanoscope "
                             "software before version 5) is not supported")
        raise fail(path, f"channel {name!r} has no '@2:Z scale' entry")
    soft_name, hard, hard_unit = _scale_entry(path, raw, f"channel {name!r} Z scale")
    if soft_name is None:
        return hard, hard_unit, f"{hard!r} {hard_unit}", raw
    soft_raw = _lookup(sections, "@" + soft_name)
    if soft_raw is None:
        raise fail(path, f"channel {name!r}: the soft scale '@{soft_name}' named by its Z "
                         "scale is missing from the header")
    _, soft, soft_unit = _scale_entry(path, soft_raw, f"soft scale '@{soft_name}'")
    if "/" not in soft_unit:  # a dimensionless sensitivity: heights stay in the hard unit
        unit = hard_unit if not soft_unit else f"{hard_unit}*{soft_unit}"
        return hard * soft, unit, f"{hard!r} {hard_unit} * {soft!r} {soft_unit}", raw
    numerator, denominator = (s.strip() for s in soft_unit.split("/", 1))
    try:
        factor = u.conversion_factor(hard_unit, denominator)
    except Exception:  # noqa: BLE001 - pint raises several error types here
        raise fail(path, f"channel {name!r}: the Z scale unit {hard_unit!r} does not match "
                         f"the sensitivity unit {soft_unit!r}") from None
    formula = f"{hard!r} {hard_unit} * {soft!r} {soft_unit}"
    if factor != 1:
        formula += f" * {factor!r} {denominator}/{hard_unit}"
    return hard * factor * soft, numerator, formula, raw


def _scan_size(path, text: str, name: str) -> tuple[float, float, str]:
    parts = text.split()
    try:
        sx = float(parts[0])
    except (IndexError, ValueError):
        raise fail(path, f"channel {name!r}: cannot read 'Scan Size: {text}'") from None
    try:
        sy = float(parts[1])
        unit = " ".join(parts[2:])
    except (IndexError, ValueError):
        sy, unit = sx, " ".join(parts[1:])
    unit = _unit(unit)
    if not u.is_length(unit) or not (sx > 0 and sy > 0):
        raise fail(path, f"channel {name!r}: 'Scan Size: {text}' is not a positive length")
    return sx, sy, unit


def _int(path, entries, key, name, default=None) -> int:
    value = _section_value(entries, key)
    if value is None:
        if default is not None:
            return default
        raise fail(path, f"channel {name!r} has no '{key}' entry")
    try:
        return int(float(value.split()[0]))
    except (IndexError, ValueError):
        raise fail(path, f"channel {name!r}: '{key}: {value}' is not an integer") from None


def _image_name(entries: dict[str, str], index: int) -> str:
    for key, value in entries.items():
        if re.fullmatch(r"@\d:image data", key.lower()):
            kind, soft, _, hard = parse_value(value)
            match = re.search(r'"([^"]*)"', hard)
            if match and match.group(1):
                return match.group(1)
            return soft or hard or f"channel {index}"
    return _section_value(entries, "Image data") or f"channel {index}"


def _channels(path: Path):
    """Header sections and one description dict per image section."""
    text, is_text = _read_header(path)
    sections = _parse_header(path, text)
    globals_ = [(n, e) for n, e in sections if n.lower() not in _IMAGE_SECTIONS]
    try:
        version = int(_lookup(globals_, "Version") or "0", 16)
    except ValueError:
        version = 0
    scan = next((e for n, e in sections if n.lower() in ("ciao scan list", "afm list",
                                                         "stm list", "nc afm list")), {})
    gx = _int(path, scan, "Samps/line", "scan list", default=0)
    gy = _int(path, scan, "Lines", "scan list", default=0)
    out: list[dict[str, Any]] = []
    for n, entries in sections:
        if n.lower() not in _IMAGE_SECTIONS:
            continue
        index = len(out)
        name = _image_name(entries, index)
        info: dict[str, Any] = {"index": index, "name": name, "entries": entries,
                                "scan": _scan(entries)}
        try:
            per_lsb, unit, formula, raw_scale = _z_scale(path, sections, entries, name)
            info.update(per_lsb=per_lsb, unit=unit, formula=formula, z_scale=raw_scale)
        except ValueError as err:
            info.update(per_lsb=None, unit=None, error=str(err))
        out.append(info)
        info.update(nx=_int(path, entries, "Samps/line", name),
                    ny=_int(path, entries, "Number of lines", name),
                    bpp=_int(path, entries, "Bytes/pixel", name, default=2),
                    offset=_int(path, entries, "Data offset", name),
                    length=_int(path, entries, "Data length", name))
        sx, sy, lunit = _scan_size(path, _section_value(entries, "Scan Size") or
                                   _section_value(scan, "Scan Size") or "", name)
        info.update(sx=sx, sy=sy, lateral_unit=lunit)
        if info["bpp"] not in (2, 4):
            raise fail(path, f"channel {name!r}: Bytes/pixel {info['bpp']} is not 2 or 4")
        elsize = info["bpp"]
        if version >= _VERSION_32BIT and info["length"] == 4 * info["nx"] * info["ny"]:
            elsize = 4
        stated = elsize * info["nx"] * info["ny"]
        if info["length"] != stated and gx and gy and info["length"] == elsize * gx * gy:
            # The image section's resolution contradicts its data length, the scan list's
            # agrees: the data are gx x gy points over the stated Scan Size (never a
            # silent rescale of the size: the warning and an attribute say what was done).
            info["header_inconsistency"] = (
                f"channel {name!r}: Samps/line {info['nx']} x Number of lines "
                f"{info['ny']} contradict Data length {info['length']}; read as the scan "
                f"list's {gx} x {gy} points over the stated Scan Size")
            info["nx"], info["ny"] = gx, gy
        elif info["length"] != stated and info["nx"] >= 1 and info["ny"] >= 1:
            raise fail(path, f"channel {name!r}: the header is inconsistent: Data length "
                             f"{info['length']} bytes is not Samps/line {info['nx']} x "
                             f"Number of lines {info['ny']} x {elsize} bytes = {stated}")
        if info["nx"] < 1 or info["ny"] < 1 or info["length"] < elsize * info["nx"] * info["ny"]:
            raise fail(path, f"channel {name!r}: Data length {info['length']} is smaller than "
                             f"{info['nx']} x {info['ny']} points of {elsize} bytes")
        info["elsize"] = elsize
    if not is_text:
        _check_layout(path, text, sections, out)
    return text, is_text, sections, version, out


def _check_layout(path: Path, text: str, sections, infos: list[dict]) -> None:
    r"""Refuse a file whose size or header length disagrees with its header.

    The ``\*File list``'s ``Data length`` is the length of the header, every section's
    ``Data offset`` and ``Data length`` place its data after it, and the last of them ends
    where the file ends: bytes inserted or cut anywhere before the end shift the data
    against the offsets, which these sums reveal.
    """
    size = path.stat().st_size
    header = _section_value(sections[0][1], "Data length")
    header_length = None
    if header is not None:
        try:
            header_length = int(float(header.split()[0]))
        except (IndexError, ValueError):
            raise fail(path, f"the file list's 'Data length: {header}' (the header length) "
                             "is not an integer") from None
        if len(text) > header_length:
            raise fail(path, f"the header text runs to byte {len(text)}, beyond the header "
                             f"length {header_length} its file list states (bytes inserted "
                             "into the header?)")
    names = {id(info["entries"]): f"channel {info['name']!r}" for info in infos}
    last = None
    for number, (name, entries) in enumerate(sections[1:], start=1):
        what = names.get(id(entries), f"section {number} ({name!r})")
        offset_text, length_text = (_section_value(entries, key) for key in ("Data offset",
                                                                            "Data length"))
        if offset_text is None or length_text is None:
            continue
        try:
            offset = int(float(offset_text.split()[0]))
            length = int(float(length_text.split()[0]))
        except (IndexError, ValueError):
            raise fail(path, f"{what}: 'Data offset: {offset_text}' or "
                             f"'Data length: {length_text}' is not an integer") from None
        if header_length is not None and offset < header_length:
            raise fail(path, f"{what}: Data offset {offset} lies inside "
                             f"the {header_length}-byte header")
        end = offset + length
        if end > size:
            raise fail(path, f"truncated file: {what} needs bytes "
                             f"{offset}..{end} by its Data offset and Data length, the file "
                             f"has {size} bytes")
        last = end if last is None else max(last, end)
    if last is not None and size != last:
        raise fail(path, f"the file has {size} bytes, {size - last} more than its header "
                         f"accounts for (the last data ends at byte {last} by Data offset + "
                         "Data length): bytes inserted into the file shift the data")


def _scan(entries: dict[str, str]) -> str:
    """Return the scan line and direction of an image section (``Main Retrace``), for listings."""
    return " ".join(v for v in (_section_value(entries, "Scan Line"),
                                _section_value(entries, "Line Direction")) if v)


def channels(path: str | Path) -> list[dict]:
    """List the image channels of a Nanoscope file.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    list of dict
        One dict per image section with ``index``, ``name``, ``unit`` (of the scaled
        values, ``None`` if unknown), ``is_height`` (unit is a length), ``scan_line`` and
        ``line_direction``.
    """
    path = Path(path)
    *_, infos = _channels(path)
    return [{"index": c["index"], "name": c["name"], "unit": c["unit"],
             "is_height": bool(c["unit"] and u.is_length(c["unit"])),
             "scan_line": _section_value(c["entries"], "Scan Line") or "",
             "line_direction": _section_value(c["entries"], "Line Direction") or ""}
            for c in infos]


def _default(path: Path, infos: list[dict], listing: str, *, warn: bool) -> dict:
    """Pick the channel read without ``channel=``; warn when the choice is ambiguous.

    Among the channels with a length unit, by what their names say
    (:func:`xrough.io._common.choose_height_channel`); among heights ``Height`` before
    ``Height Sensor`` and ``ZSensor``, the main scan line before the interleave. Two height
    quantities (``Height`` and ``ZSensor``: the feedback signal and the calibrated sensor)
    make the choice ambiguous: a ``ChannelChoiceWarning`` names them.
    """
    heights = [c for c in infos if c["unit"] and u.is_length(c["unit"])]
    if not heights:
        broken = [c["error"] for c in infos if c.get("error")]
        if broken:  # e.g. a height channel whose scale cannot be worked out
            raise ValueError(f"{broken[0]}; channels: {listing}")
        raise fail(path, f"no height channel (with a length unit); channels: {listing}")

    def order(c):
        name = c["name"].lower()
        named = _HEIGHT_NAMES.index(name) if name in _HEIGHT_NAMES else len(_HEIGHT_NAMES)
        return named, _is_interleave(c)

    return choose_height_channel(path, heights, warn=warn, key=order)


def _is_interleave(info: dict) -> bool:
    return (_section_value(info["entries"], "Scan Line") or "").lower() == "interleave"


def _image_sections(path: Path, infos: list[dict]) -> list[dict]:
    """Return the file's image sections (channels); refuse a file without any."""
    if not infos:
        raise fail(path, "the file holds no image sections ('\\*Ciao image list')")
    return infos


def _channel_list(path: Path) -> list[dict]:
    return _image_sections(path, _channels(path)[-1])


default_channel = default_channel_reader(_channel_list, _default, __name__)


def _date(text: str | None) -> str | None:
    if not text:
        return None
    for fmt in ("%I:%M:%S %p %a %b %d %Y", "%H:%M:%S %a %b %d %Y"):
        try:
            return datetime.strptime(text.strip(), fmt).isoformat()
        except ValueError:
            continue
    return None


def read(path: str | Path, *, channel: str | int | None = None):
    r"""Read one channel of a Nanoscope file as a topography.

    Parameters
    ----------
    path : str or Path
        The file (``.spm``, ``.001``, ``.di``..., recognised by its header).
    channel : str or int, optional
        Image data name (``"Height"``, case-insensitive; the first match) or index of the
        image section (0-based, file order). Default: the first channel named ``Height``
        (or ``Height Sensor``/``ZSensor``), else the first channel with a length unit.

    Returns
    -------
    xarray.DataArray
        Heights ``(y, x)`` in the unit of the sensitivity (usually nm), scaled as
        ``raw * V_hard / 2**(8 * Bytes/pixel) * S`` (see the module docstring), lateral
        coordinates from ``Scan Size``. Attributes: ``channel``, ``channel_index``,
        ``scan_line``, ``line_direction``, ``height_scale`` (height unit per raw count),
        ``height_scale_formula``, ``z_scale`` (the header entry), ``bytes_per_pixel``,
        ``instrument``, ``scanner``, ``imaging_mode``, ``date`` (ISO 8601),
        ``nanoscope_version``, ``scan_rate`` (lines per second), ``realtime_planefit``,
        ``offline_planefit`` and ``header`` (the whole header text).

    Raises
    ------
    ValueError
        For a missing channel (the message lists the channels), a channel that is not a
        height, text-data files, or a corrupted or truncated file (the message names the
        file and the problem).
    """
    path = Path(path)
    with reader_errors(path, "Nanoscope"):
        return _read(path, channel)


def _read(path: Path, channel):
    text, is_text, sections, version, infos = _channels(path)
    if is_text:
        raise fail(path, "Nanoscope files with the data stored as text ('?*File list') are "
                         "not supported; export a binary file")
    info = select_channel(path, _image_sections(path, infos), channel, default=_default)
    listing = channel_listing([c for c in infos if c["unit"] and u.is_length(c["unit"])])
    if info["unit"] is None:
        raise ValueError(info.get("error") or f"{path.name}: channel {info['name']!r} has "
                                              "no height scale")
    if not u.is_length(info["unit"]):
        raise fail(path, f"channel {info['index']} {info['name']!r} holds "
                         f"{info['unit']!r}, not heights (a topography needs a length unit); "
                         f"height channels: {listing}")
    nx, ny, elsize = info["nx"], info["ny"], info["elsize"]
    count = nx * ny
    file_size = path.stat().st_size
    end = info["offset"] + elsize * count
    if info["offset"] < 0 or end > file_size:
        raise fail(path, f"truncated file: channel {info['name']!r} needs bytes "
                         f"{info['offset']}..{end} but the file has {file_size} bytes")
    raw = np.fromfile(path, dtype=f"<i{elsize}", count=count, offset=info["offset"])
    if raw.size != count:  # pragma: no cover - guarded by the size check above
        raise fail(path, f"truncated file: read {raw.size} of {count} values")
    scale = info["per_lsb"] / 2.0 ** (8 * info["bpp"])
    heights = raw.reshape(ny, nx).astype(float) * scale

    entries = info["entries"]
    globals_ = [(n, e) for n, e in sections if n.lower() not in _IMAGE_SECTIONS]
    mode = _lookup(globals_, "@MicroscopeList")
    if mode:
        match = re.search(r'"([^"]*)"', mode)
        mode = match.group(1) if match else None
    attrs = {
        "channel": info["name"],
        "channel_index": int(info["index"]),
        "scan_line": _section_value(entries, "Scan Line") or "",
        "line_direction": _section_value(entries, "Line Direction") or "",
        "height_scale": float(scale),
        "height_scale_formula": f"raw * {info['formula']} / 2^{8 * info['bpp']}",
        "z_scale": info["z_scale"],
        "bytes_per_pixel": int(info["bpp"]),
        "instrument": _lookup(globals_, "Microscope") or _lookup(globals_, "Description"),
        "scanner": _lookup(globals_, "Scanner file"),
        "imaging_mode": mode or _lookup(globals_, "Operating mode"),
        "date": _date(_lookup(globals_, "Date")) or _lookup(globals_, "Date"),
        "nanoscope_version": _lookup(globals_, "Version"),
        "scan_rate": _lookup(globals_, "Scan Rate"),
        "realtime_planefit": _section_value(entries, "Realtime Planefit"),
        "offline_planefit": _section_value(entries, "Offline Planefit"),
        "header": text,
        "header_inconsistency": info.get("header_inconsistency"),
    }
    if info.get("header_inconsistency"):
        quality.warn(f"{path.name}: {info['header_inconsistency']}", UserWarning)
    try:
        attrs["scan_rate"] = float(attrs["scan_rate"])
    except (TypeError, ValueError):
        pass
    attrs = {k: v for k, v in attrs.items() if v not in (None, "")}
    return topography(heights, size=(info["sy"], info["sx"]), unit=info["lateral_unit"],
                      height_unit=info["unit"], name="height", attrs=attrs)
