"""Plain-text topographies: height matrices, x-y profiles, x-y-z point lists, CSV exports.

The reader finds the block of numeric lines in the file (whitespace, comma or semicolon
separated), takes everything before it as a header, and decides the layout from the number
of columns:

- one column: heights of a profile (the lateral scale must be given: ``spacing=``/``size=``);
- two columns: a profile ``x, h``;
- three columns: ``x, y, z`` points, reshaped into a map when they lie on a regular grid;
- four or more columns: a height matrix, one line per ``y``, one column per ``x``.

A matrix is written in image order: its first line is the *top* row of the image (as
Gwyddion, SPIP or MountainsMap export it, and as SurfaceTopography reads it). xrough's row
0 is at ``y = 0`` and plots at the bottom, so the lines are reversed on read (and on
:func:`write`): the picture is the same in every program.

Header lines (with or without ``#``/``%`` comment markers) of the forms ``key: value``,
``key = value`` or ``key,value`` (CSV exports such as Bruker Dektak) become attributes, and
the usual keys give sizes and units: ``Width``/``Height`` and ``Value units`` (Gwyddion
ASCII export; ``Breite``/``Höhe`` in its German version, and ``Channel``/``Kanal`` gives
``attrs["channel"]``), ``x-length``/``y-length``, ``x-unit``/``z-unit``, ``unit``,
``pixel size``... A line of column names just above the data (``Lateral um,Raw
Micrometer``, ``x [mm]  h [nm]``, ``µm µm`` or ``[mm];[mm]``, possibly under a line of
titles such as ``X;Y;valid``) gives the unit of each column. A header scale factor such as
``height conversion factor (-> m)=6.30079e-008`` multiplies the raw heights and gives their
unit. A header that states the size (or the points) of a map along x and y makes the block
a matrix whatever its number of columns. UTF-16 files (with a byte-order mark) are decoded.

Some columns are not data: a first column titled ``index`` (or ``no``, ``nr``...) that
counts up by one is dropped (``attrs["index_column"]``); a last column titled ``valid``
(1 = measured, 0 = missing, as in ``.hfm`` profile exports) turns the heights it marks 0
into NaN and is dropped (``attrs["valid_column"]``, ``attrs["invalid_points"]``). A single
whole number on the line before x-y pairs is their count (``attrs["points"]``), checked
against them (equal, or one less: the last index counted from 0).

Header-stated sizes are checked against the data, never silently spread over fewer
points: stated point counts must match and a profile must cover the stated ``Length``.
Every line of numbers must have the same number of values (the line that differs is
named), and after a Gwyddion export's commented header (``# Channel``, ``# Width``,
``# Height``) every line that is not a comment must be a row of numbers. A NUL byte
refuses the file as damaged text (:func:`damaged_text`), however many there are. A
matrix's ``Width``/``Height`` are ``n * spacing`` along x and y, each with its own pixel
size: rectangular pixels are read as stated (a matrix cut at a line boundary without
stated point counts cannot be told from one with rectangular pixels).

Profiles whose ``x`` column is uniform are read on a uniform grid (the spacing from a
least-squares fit of the positions): exactly uniform, or departing from a uniform grid by
no more than the rounding of the printed digits, when those digits resolve the sampling
(one unit of the last digit at most a tenth of the step) or the header states the step
(a spacing, or a length over the points). Whole numbers for a step of about 1 cannot tell
a missing or extra sample from rounding: ``0, 1, 2, 4, 5...`` is not uniform. Others are
**non-uniformly sampled** and never resampled silently: they are returned on their
measured ``x`` with ``attrs["sampling"] = "non-uniform"`` unless ``resample=True`` asks for
linear interpolation onto a uniform grid.
"""

from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from .. import units as u
from ..topography import grid_of, topography
from ..units import QuantityLike
from ._common import MissingOptionError, micro_as_u, nonuniform_profile, reader_errors

__all__ = ["sniff", "read", "write", "looks_binary", "text_with_nul", "damaged_text"]

_NUM = r"[-+]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|nan|inf|infinity)"
_NUM_RE = re.compile(rf"^{_NUM}$", re.IGNORECASE)
_DATA_LINE = re.compile(rf"^\s*{_NUM}(?:(?:\s*[,;]\s*|\s+){_NUM})*[\s,;]*$", re.IGNORECASE)
_COMMENT = ("#", "%", "//", "!", ";")
_TOKEN_PARTS = re.compile(r"^[-+]?(\d*)(?:\.(\d*))?(?:[eE]([-+]?\d+))?$")
# Magic strings of text-based formats that have their own reader.
_OTHER_TEXT_FORMATS = (b"aISO-1.0", b"aBCR-1.0", b"bISO-1.0", b"bBCR-1.0", b"\\*File list",
                       b"?*File list")
#: Printed rounding is taken as the only departure of ``x`` from a uniform grid only when one
#: unit of the last printed digit is at most this fraction of the step.
_ROUNDING_RESOLVES = 0.1
_RESERVED_ATTRS = {"units", "long_name", "periodic", "sampling", "source", "source_file",
                   "source_sha256", "format", "overrides", "name", "standard_name"}

# Normalised header keys (lower case, without spaces, '-', '_', '.') and what they mean.
# (``Breite``, ``Höhe``: Gwyddion's ASCII export in German)
_X_SIZE = {"width", "breite", "xlength", "lengthx", "xrange", "rangex", "xscansize",
           "scansizex", "sizex", "xscanrange", "fastscansize"}
_Y_SIZE = {"height", "höhe", "hoehe", "ylength", "lengthy", "yrange", "rangey", "yscansize",
           "scansizey", "sizey", "yscanrange", "slowscansize"}
_XY_SIZE = {"scansize", "scanrange", "imagesize", "size"}
_PROFILE_SIZE = {"length", "scanlength", "profilelength", "evaluationlength"}
_X_SPACING = {"pixelsize", "xspacing", "spacingx", "dx", "xstep", "stepx", "stepsize",
              "spacing", "scalex", "xpixelsize", "samplingdistance", "resolution"}
_Y_SPACING = {"yspacing", "spacingy", "dy", "ystep", "stepy", "scaley", "ypixelsize"}
_X_UNIT = {"xunit", "xunits", "unitx", "lateralunit", "lateralunits", "xyunit",
           "xyunits", "unitxy"}
_Y_UNIT = {"yunit", "yunits", "unity"}
_Z_UNIT = {"zunit", "zunits", "unitz", "valueunits", "valueunit", "heightunit",
           "heightunits", "unitdata", "dataunit", "dataunits", "zscaleunit"}
_ANY_UNIT = {"unit", "units", "lengthunit"}
# Keys too common to mean a size or spacing unless the value carries a length unit.
_NEEDS_UNIT = {"width", "height", "breite", "höhe", "hoehe", "size", "length", "resolution",
               "spacing", "range"}
# Raw values times this factor are heights, e.g. ``height conversion factor (-> m)=6.3e-08``.
_CONVERSION = re.compile(r"^(?:height|z|value|data)\s*(?:conversion|scale|scaling)\s*"
                         r"factor\s*(?:[(\[]\s*-*>\s*(?P<unit>[^)\]]*?)\s*[)\]])?\s*$",
                         re.IGNORECASE)
#: A key that names a conversion or scale factor of the values: when it does not read as
#: one (:data:`_CONVERSION` with a number), the heights would come out unscaled.
_NAMES_A_FACTOR = re.compile(r"conversion|(?:scale|scaling)\s*factor", re.IGNORECASE)
#: Keys naming the channel (Gwyddion's ASCII export writes ``Channel``, ``Kanal`` in German).
_CHANNEL = {"channel", "kanal", "channelname", "kanalname"}
_X_COUNT = {"xpixels", "nx", "pointsperline", "samplesperline", "xres", "npointsx"}
_Y_COUNT = {"ypixels", "ny", "lines", "numberoflines", "yres", "npointsy"}


# ---------------------------------------------------------------------------------------
# decoding and line classification


def _decode(data: bytes) -> str:
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        return data.decode("utf-16", errors="replace")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")  # never fails; instrument exports use it (µ = 0xB5)


def looks_binary(data: bytes) -> bool:
    """Whether ``data`` (the start of a file) holds bytes that plain text never has.

    NUL bytes in what is otherwise text make a damaged text file, not a binary one: a
    few (two, or 1 in 1000), or any number in text with lines of numbers and no other
    control byte (:func:`text_with_nul`: a block of zeroed bytes in a profile, say). Such
    a file goes to the text reader, which refuses it naming the byte
    (:func:`damaged_text`), instead of to a binary reader (SurfaceTopography) that stops
    at the NUL (a 132-point profile read as 27).

    Parameters
    ----------
    data : bytes
        The start of the file (4 kB when detecting the format, 64 kB when reading).

    Returns
    -------
    bool
    """
    if data.startswith(_UTF16_BOMS):
        return False
    nul = data.count(b"\x00")
    if nul > max(2, 0.001 * len(data)):
        return not text_with_nul(data)
    head = data.replace(b"\x00", b"")[:4096]
    return _control_bytes(head) > 0.01 * max(1, len(head))


def text_with_nul(data: bytes) -> bool:
    """Whether ``data`` is text with lines of numbers but for its NUL bytes (damaged text).

    A binary format's bytes hold other control bytes too (the instrument files of the
    test data all do, within their first 4 kB or 64 kB), so do the headers of formats
    padded with NULs; UTF-16 text with a byte-order mark is not meant.

    Parameters
    ----------
    data : bytes
        The start of the file.

    Returns
    -------
    bool
        True if ``data`` holds a NUL byte, no control byte but NUL, tab, line feed, form
        feed and carriage return, and a line of numbers.
    """
    if b"\x00" not in data or data.startswith(_UTF16_BOMS):
        return False
    text = data.replace(b"\x00", b"")
    return _control_bytes(text) == 0 and _has_numbers(text)


_UTF16_BOMS = (b"\xff\xfe", b"\xfe\xff")
#: Control bytes plain text does not hold (all but tab, line feed, form feed, return).
_CONTROL = bytes(b for b in range(32) if b not in (9, 10, 12, 13))


def _control_bytes(data: bytes) -> int:
    """Count the control bytes of ``data`` that plain text does not hold."""
    return len(data) - len(data.translate(None, _CONTROL))


def _has_numbers(data: bytes) -> bool:
    """Whether ``data`` (text) has a line of numbers, its last (perhaps cut) line aside."""
    lines = [line for line in _decode(data).splitlines()
             if line.strip() and not _is_comment(line)]
    return any(_DATA_LINE.match(line) for line in lines[:-1] or lines)


def damaged_text(name: str, data: bytes) -> None:
    """Refuse text with a NUL byte (a damaged file), naming its line and offset.

    Parameters
    ----------
    name : str
        The file's name, for the message.
    data : bytes
        The file's bytes (or its start).

    Raises
    ------
    ValueError
        If ``data`` holds a NUL byte; UTF-16 text without a byte-order mark (a NUL in
        every other byte) is told to pass ``encoding=``.
    """
    at = data.find(b"\x00")
    if at < 0:
        return
    line = data.count(b"\n", 0, at) + 1
    sample = data[:4096]
    even, odd = sample[0::2].count(b"\x00"), sample[1::2].count(b"\x00")
    if max(even, odd) > 0.4 * len(sample) and min(even, odd) == 0:
        order = "le" if odd else "be"
        raise ValueError(f"{name}: a NUL byte at offset {at} (line {line}), and one in every "
                         f"other byte: UTF-16 text without a byte-order mark? pass "
                         f"encoding='utf-16-{order}'")
    raise ValueError(f"{name}: contains a NUL byte at offset {at} (line {line}): a damaged text "
                     "file (or not a text file); refused rather than read without the values "
                     "it broke")


def _is_comment(line: str) -> bool:
    return line.lstrip().startswith(_COMMENT)


def _strip_comment(line: str) -> str:
    text = line.strip()
    for marker in _COMMENT:
        if text.startswith(marker):
            return text.lstrip(marker[0]).strip()
    return text


def sniff(head: bytes, path: Path) -> bool:
    """Whether ``head`` looks like plain text with lines of numbers.

    Parameters
    ----------
    head : bytes
        The first bytes of the file (up to 4 kB).
    path : pathlib.Path
        The file (unused: plain text is recognised by content only).

    Returns
    -------
    bool
    """
    if not head or looks_binary(head) or head.lstrip().startswith(_OTHER_TEXT_FORMATS):
        return False
    lines = _decode(head).splitlines()
    if len(head) >= 4096 and len(lines) > 1:
        lines = lines[:-1]  # the last line may be cut
    elif len(head) >= 4096 and lines:  # one very long line: drop its cut last number
        lines = [re.sub(r"[\s,;]*[^\s,;]*$", "", lines[0])]
    return any(_DATA_LINE.match(line) for line in lines if line.strip()
               and not _is_comment(line))


# ---------------------------------------------------------------------------------------
# header parsing


def _norm_key(key: str) -> str:
    return re.sub(r"[\s\-_.()\[\]/]+", "", key).lower()


def _attr_name(key: str) -> str:
    name = re.sub(r"[^0-9A-Za-z_]+", "_", key.strip()).strip("_")
    if not name:
        return ""
    if not name[0].isalpha():
        name = "k_" + name
    if name.lower() in _RESERVED_ATTRS:
        name = "file_" + name
    return name


def _attr_value(text: str):
    text = text.strip()
    if re.fullmatch(r"[-+]?\d+", text):
        try:
            value = int(text)
        except ValueError:  # pragma: no cover - regex guarantees digits
            return text
        return value if abs(value) < 2**63 else text
    if _NUM_RE.match(text) and text.lower() not in ("nan", "inf", "infinity"):
        return float(text)
    return text


def _length_unit(word: str) -> str | None:
    """CF string of a length unit written as ``word`` (``µm``, ``Micrometer``...), or None."""
    return u.length_unit_word(micro_as_u(word))


def _unit_in(text: str) -> str | None:
    """Find the length unit named in a column title or header value (None if none)."""
    for inner in re.findall(r"[\[(]\s*([^\])]+?)\s*[\])]", text):
        found = _length_unit(inner)
        if found:
            return found
    m = re.search(r"(?:/|\bin\b)\s*(\S+)\s*$", text)
    if m and _length_unit(m.group(1)):
        return _length_unit(m.group(1))
    for word in reversed(re.split(r"[\s_:=/\[\]()]+", text)):
        found = _length_unit(word)
        if found:
            return found
    return None


def _quantity_in(text: str) -> tuple[float, str | None] | None:
    """``(value, unit)`` of a header value such as ``10.00 µm`` or ``0.156 um/sample``."""
    m = re.match(rf"^\s*({_NUM})\s*(.*?)\s*$", text, re.IGNORECASE)
    if not m:
        return None
    value = float(m.group(1))
    rest = re.sub(r"\s*/\s*(sample|samples|pt|pts|point|points|pixel|pixels|px|line|"
                  r"lines)\s*$", "", m.group(2), flags=re.IGNORECASE)
    if not rest:
        return value, None
    unit = _length_unit(rest)
    return (value, unit) if unit else None


def _split_key_value(line: str) -> tuple[str, str] | None:
    text = _strip_comment(line)
    if not text:
        return None
    head = text.split(",", 1)[0]
    if "," in text and not re.search(r"[:=：]", head):
        fields = [f.strip() for f in text.split(",")]
        while fields and not fields[-1]:
            fields.pop()
        if len(fields) >= 2 and fields[0]:
            return fields[0], ", ".join(fields[1:])
        return None
    m = re.match(r"^([^:=：]+?)\s*[:=：]\s*(.*)$", text)
    if m:
        return m.group(1).strip(), m.group(2).strip()
    if "\t" in text:
        key, value = text.split("\t", 1)
        return key.strip(), value.strip()
    return None


class _Header:
    """Metadata found before the data: raw attributes plus the recognised geometry."""

    def __init__(self):
        self.attrs: dict[str, str | int | float] = {}
        self.size: dict[str, tuple[float, str | None] | None] = {
            "x": None, "y": None, "xy": None, "profile": None}
        self.spacing: dict[str, tuple[float, str | None] | None] = {"x": None, "y": None}
        self.unit: dict[str, str | None] = {"x": None, "y": None, "z": None, "any": None}
        self.count: dict[str, int | None] = {"x": None, "y": None}
        self.height_factor: tuple[float, str | None, str] | None = None
        self.unread_factor: str | None = None  # a line naming a factor that does not parse
        self.channel: str | None = None
        self.lines: set[int] = set()  # indices of lines read as titles, units or counts

    def add(self, key: str, value: str) -> None:
        name = _attr_name(key)
        if name and value:
            while name in self.attrs:
                name += "_"
            self.attrs[name] = _attr_value(value)
        k = _norm_key(key)
        if k in _CHANNEL and value and self.channel is None:
            self.channel = value.strip()
        factor = _CONVERSION.match(key.strip())
        if factor and self.height_factor is None and _NUM_RE.match(value.strip()):
            target = factor.group("unit")
            self.height_factor = (float(value), _length_unit(target) if target else None,
                                  f"{key.strip()}={value.strip()}")
        elif _NAMES_A_FACTOR.search(key) and self.unread_factor is None:
            self.unread_factor = f"{key.strip()}={value.strip()}"[:80]
        q = _quantity_in(value) if value else None
        if q is not None and q[1] is None and k in _NEEDS_UNIT:
            q = None
        for keys, slot in ((_X_SIZE, "x"), (_Y_SIZE, "y"), (_XY_SIZE, "xy"),
                           (_PROFILE_SIZE, "profile")):
            if k in keys and q is not None and self.size[slot] is None:
                self.size[slot] = q
        for keys, slot in ((_X_SPACING, "x"), (_Y_SPACING, "y")):
            if k in keys and q is not None and self.spacing[slot] is None:
                self.spacing[slot] = q
        for keys, slot in ((_X_UNIT, "x"), (_Y_UNIT, "y"), (_Z_UNIT, "z"), (_ANY_UNIT, "any")):
            if k in keys and self.unit[slot] is None:
                self.unit[slot] = _length_unit(value) or _unit_in(value)
        for keys, slot in ((_X_COUNT, "x"), (_Y_COUNT, "y")):
            if k in keys and re.fullmatch(r"\d+", value.strip()):
                self.count[slot] = int(value)

    def lateral_unit(self) -> str | None:
        for q in (self.size["x"], self.size["xy"], self.size["profile"], self.spacing["x"]):
            if q is not None and q[1]:
                return q[1]
        return self.unit["x"] or self.unit["any"]

    def height_unit(self) -> str | None:
        return self.unit["z"] or self.unit["any"]


def _column_names(line: str, ncols: int, delimiter: str | None) -> list[str] | None:
    text = _strip_comment(line)
    if not text or _DATA_LINE.match(text) or re.search(r"[:=：]", text):
        return None
    candidates = []
    if delimiter:
        candidates.append(text.split(delimiter))
    candidates += [text.split(";"), text.split(","), text.split("\t"),
                   re.split(r"\s{2,}", text),
                   re.findall(r"[^\s\[(]+(?:\s*[\[(][^\])]*[\])])?", text), text.split()]
    for names in candidates:
        names = [n.strip() for n in names]
        while names and not names[-1]:
            names.pop()
        if len(names) == ncols and all(names):
            return names
    return None


# ---------------------------------------------------------------------------------------
# the data block


def _tokens(line: str, delimiter: str | None, decimal_comma: bool) -> list[str]:
    text = line.strip().rstrip(",;").strip()
    if delimiter:
        fields = [f.strip() for f in text.split(delimiter)]
    else:
        fields = text.split()
    if decimal_comma:
        fields = [f.replace(",", ".") for f in fields]
    return fields


def _quanta(tokens: list[str]) -> np.ndarray:
    """Value of one unit in the last printed digit of each number (its rounding step)."""
    out = np.empty(len(tokens))
    for i, tok in enumerate(tokens):
        m = _TOKEN_PARTS.match(tok)
        if not m:  # nan, inf
            out[i] = np.nan
            continue
        decimals = len(m.group(2) or "")
        exponent = int(m.group(3) or 0)
        out[i] = 10.0 ** (exponent - decimals)
    return out


def _uniform_fit(x: np.ndarray, quanta: np.ndarray, stated_steps=()):
    """Least-squares uniform grid through ``x`` and whether ``x`` lies on it.

    ``x`` is uniform when it is exactly uniform (to floating-point precision), or when its
    departures from the fitted grid are those of rounding to the printed digits: every
    position within half a unit of its last printed digit (plus the fit's own error,
    ``2 / sqrt(n)`` units) of the grid. Rounding is only accepted as the explanation when
    the printed digits resolve the sampling (one unit of the last digit at most
    :data:`_ROUNDING_RESOLVES` of the step) or when the header states the step (a spacing,
    or a length over the points: ``stated_steps``) and the fit agrees with it to 0.5 %.
    Otherwise (whole numbers for a step of about 1, say) a missing or shifted sample
    looks like rounding, and only exactly uniform ``x`` is uniform.

    Returns
    -------
    uniform : bool
    step, origin, max_deviation : float
    """
    n = x.size
    i = np.arange(n, dtype=float)
    scale = np.max(np.abs(x))
    step, origin = (x[-1] - x[0]) / (n - 1), x[0]
    dev = np.abs(x - (origin + step * i))
    if dev.max() <= 1e-12 * scale:
        return bool(step > 0), float(step), float(origin), float(dev.max())
    # not exactly uniform: fit through the rounded values
    step, origin = np.polyfit(i, x, 1)
    dev = np.abs(x - (origin + step * i))
    finite = np.isfinite(quanta)
    finest = np.nanmin(quanta) if np.any(finite) else 0.0
    if abs(origin) < 0.5 * finest:  # the fit's offset is below the printed precision
        origin = 0.0
    q = np.where(finite, quanta, 0.0)
    tol = q * (0.5 * (1 + 1e-9) + 2 / np.sqrt(n)) + 1e-12 * scale
    resolved = bool(np.all(q <= _ROUNDING_RESOLVES * abs(step))) or any(
        abs(step - s) <= 0.005 * abs(s) for s in stated_steps)
    uniform = bool(step > 0 and resolved and np.all(dev <= tol))
    return uniform, float(step), float(origin), float(dev.max())


def _stated_steps(header: _Header, n: int, lunit: str | None) -> list[float]:
    """List the steps of a profile's ``x`` that its header states (spacing, length / points).

    In ``lunit``; a length gives two candidates, ``L / n`` and ``L / (n - 1)``.
    """
    out: list[float] = []
    for q, divisors in ((header.spacing["x"], (1,)),
                        (header.size["profile"] or header.size["x"], (n, n - 1))):
        if q is None:
            continue
        value = q[0]
        if q[1] is not None and lunit is not None and q[1] != lunit:
            try:
                value *= u.conversion_factor(q[1], lunit)
            except Exception:  # noqa: BLE001 - a unit pint cannot convert states nothing
                continue
        out += [value / d for d in divisors if value > 0 and d > 0]
    return out


def _data_block(name: str, lines: list[str]):
    """Locate the numeric block: ``(start, stop, numeric line indices)``."""
    runs: list[list[int]] = []
    current: list[int] = []
    breaks: dict[int, int] = {}  # run index -> the text line that ended it
    for i, line in enumerate(lines):
        if not line.strip() or _is_comment(line):
            continue
        if _DATA_LINE.match(line):
            current.append(i)
        else:
            if current:
                breaks[len(runs)] = i
                runs.append(current)
                current = []
    if current:
        runs.append(current)
    if not runs:
        raise ValueError(f"{name}: no lines of numbers found: not a text topography "
                         "(matrix, x-y profile, x-y-z points or CSV export)")
    main = max(range(len(runs)), key=lambda k: (len(runs[k]), k))
    ncols = len(re.split(r"(?:\s*[,;]\s*|\s+)", lines[runs[main][0]].strip().strip(",;")))
    for k, run in enumerate(runs):
        if k == main:
            continue
        width = len(re.split(r"(?:\s*[,;]\s*|\s+)", lines[run[0]].strip().strip(",;")))
        if len(run) > 2 or width == ncols:
            bad = breaks.get(min(k, main))
            where = (f"line {bad + 1}: cannot read {lines[bad].strip()[:60]!r} as numbers"
                     if bad is not None else "several blocks of numbers")
            raise ValueError(f"{name}: {where} (the block of numbers is interrupted; "
                             "the file looks corrupted)")
    _damaged_edges(name, lines, runs[main], ncols)
    return runs[main]


def _shape(token: str) -> tuple[int, int] | None:
    """How a number is printed: ``(digits of its exponent, number of decimals)``."""
    m = _TOKEN_PARTS.match(token)
    if m is None:
        return None
    return len((m.group(3) or "").lstrip("+-")), len(m.group(2) or "")


def _cut_last_number(name: str, rows: list[int], tokens: list[list[str]]) -> None:
    """Refuse a file cut inside its last number (it ends without a line break).

    The last number of such a file still reads as a number (``-1.0`` of ``-1.0108e+00``);
    when the numbers of its column on the lines before are all printed alike (a fixed
    format, such as ``%.4e``) and the last one is not, the file was cut inside it.
    """
    if len(tokens) < 2 or not tokens[-1]:
        return
    col = len(tokens[-1]) - 1
    before = {_shape(t[col]) for t in tokens[-21:-1] if len(t) > col}
    last = _shape(tokens[-1][col])
    if len(before) == 1 and None not in before and last != next(iter(before)):
        raise ValueError(f"{name}: line {rows[-1] + 1} ends the file inside a number "
                         f"({tokens[-1][col]!r}, printed unlike the numbers above it, "
                         "without a line break after it): a truncated file")


def _damaged_edges(name: str, lines: list[str], rows: list[int], ncols: int) -> None:
    """Refuse a damaged line of numbers just before or after the block of numbers.

    A first or last data line with a number cut off or garbage in it is no longer a line
    of numbers: read as a header line or ignored as a trailer, it would silently drop a
    row, and a map's stated ``Width``/``Height`` would be spread over fewer rows. The line
    next to the block (blank lines skipped, comments not) is refused when it starts with a
    number and at least half of its fields are numbers, or when it has the block's number
    of fields, some of them numbers, and is not a ``key: value`` line.
    """
    for step, start in ((-1, rows[0] - 1), (1, rows[-1] + 1)):
        i = start
        while 0 <= i < len(lines) and not lines[i].strip():
            i += step
        if not 0 <= i < len(lines) or _is_comment(lines[i]):
            continue
        fields = [f for f in re.split(r"\s*[,;]\s*|\s+", lines[i].strip()) if f]
        numeric = [bool(_NUM_RE.match(f)) for f in fields]
        key_value = re.search(r"[:=：]", lines[i]) is not None
        if (numeric[0] and 2 * sum(numeric) >= len(fields)) or (
                len(fields) == ncols and any(numeric) and not key_value):
            where = "first" if step < 0 else "last"
            raise ValueError(
                f"{name}: line {i + 1} ({lines[i].strip()[:60]!r}), next to the {where} "
                f"line of numbers, is a damaged line of numbers: refused rather than read "
                f"without that row (a truncated or damaged file)")


def _gwyddion_export_edges(name: str, lines: list[str], rows: list[int]) -> None:
    """Refuse a line that is not numbers before or after the rows of a Gwyddion export.

    Gwyddion's text export writes a header of comment lines (``# Channel:``, ``# Width:``,
    ``# Height:``, ``# Value units:``, or their translations) and then only rows of
    numbers. Any other line outside the rows is a damaged row (garbage in place of the
    numbers, a row cut to a few characters): read as a header line or trailer, it would
    drop the row and spread the stated ``Height`` over the rows left.
    """
    keys = set()
    for i in range(rows[0]):
        if _is_comment(lines[i]):
            kv = _split_key_value(lines[i])
            if kv:
                keys.add(_norm_key(kv[0]))
    if not (keys & _CHANNEL and keys & _X_SIZE and keys & _Y_SIZE):
        return
    for i in [*range(rows[0]), *range(rows[-1] + 1, len(lines))]:
        if lines[i].strip() and not _is_comment(lines[i]):
            where = "before the first" if i < rows[0] else "after the last"
            raise ValueError(
                f"{name}: line {i + 1} ({lines[i].strip()[:60]!r}), {where} row of numbers "
                "of a Gwyddion text export (a '# Channel', '# Width', '# Height' header, "
                "then only rows of numbers), is not a row of numbers: a damaged row; "
                "refused rather than read without it (the stated Height would be spread "
                "over the rows left)")


def _parse(path: Path, encoding: str | None):
    """Return the numbers, their printed tokens, the column names and the header."""
    name = path.name
    lines, complete = _lines(path, encoding)
    rows = _data_block(name, lines)
    _gwyddion_export_edges(name, lines, rows)
    delimiter, decimal_comma = _delimiter([lines[i] for i in rows[:50]])
    tokens = [_tokens(lines[i], delimiter, decimal_comma) for i in rows]
    if not complete and rows[-1] == len(lines) - 1:
        _cut_last_number(name, rows, tokens)
    header = _Header()
    rows, tokens = _point_count_line(name, lines, rows, tokens, header)
    values = _numbers(name, rows, tokens)
    names = _column_titles(lines, rows[0], values.shape[1], delimiter, header)
    _read_header(lines, rows[0], header)
    values, tokens, names = _drop_index_column(values, tokens, names, header)
    values, tokens, names = _apply_valid_column(name, values, tokens, names, header)
    return values, tokens, names, header


def _lines(path: Path, encoding: str | None) -> tuple[list[str], bool]:
    """Return the lines of the file and whether its last line ends with a line break.

    An empty, binary or undecodable file is refused.
    """
    name = path.name
    if path.is_dir():
        raise IsADirectoryError(f"{name}: is a directory, not a file")
    data = path.read_bytes()
    if not data.strip():
        raise ValueError(f"{name}: the file is empty")
    if encoding is None and looks_binary(data[:65536]):
        raise ValueError(f"{name}: binary content, not a text file")
    utf16 = data.startswith((b"\xff\xfe", b"\xfe\xff")) or (
        encoding is not None and encoding.lower().replace("_", "-").startswith("utf-16"))
    if not utf16:  # UTF-16 holds a NUL in every other byte of ASCII text
        damaged_text(name, data)
    try:
        text = data.decode(encoding) if encoding else _decode(data)
    except (UnicodeError, LookupError) as err:
        raise ValueError(f"{name}: cannot decode the file as {encoding!r} text "
                         f"({err})") from None
    return text.splitlines(), text.endswith(("\n", "\r"))


def _delimiter(sample: list[str]) -> tuple[str | None, bool]:
    """Return the data lines' delimiter (None: whitespace) and whether ``,`` is decimal.

    A comma is the decimal mark in lines separated by semicolons.
    """
    if any(";" in s for s in sample):
        return ";", any("," in s for s in sample)
    if any("," in s for s in sample):
        return ",", False
    return None, False


def _numbers(name: str, rows: list[int], tokens: list[list[str]]) -> np.ndarray:
    """Return the data lines' numbers as a matrix; refuse lines of another width.

    The width is that of most lines (of the first, if no width is the most common), so
    that the message names the damaged line, the first one included.
    """
    widths = Counter(len(tok) for tok in tokens)
    ncols = max(widths, key=lambda w: widths[w] + (w == len(tokens[0])) / 2)
    for i, tok in zip(rows, tokens):
        if len(tok) != ncols:
            raise ValueError(f"{name}: line {i + 1} has {len(tok)} value"
                             f"{'' if len(tok) == 1 else 's'} where "
                             f"{widths[ncols]} of the {len(rows)} lines of numbers have "
                             f"{ncols}: every line must have the same number of values (a "
                             "damaged or truncated line)")
    try:
        return np.array(tokens, dtype=float)
    except ValueError:
        pass
    values = np.empty((len(tokens), ncols))  # one by one, to name the line
    for r, (i, tok) in enumerate(zip(rows, tokens)):
        for c, t in enumerate(tok):
            try:
                values[r, c] = float(t)
            except ValueError:
                raise ValueError(f"{name}: line {i + 1}: cannot read {t!r} as a number "
                                 "(a damaged line)") from None
    return values


def _column_titles(lines: list[str], first: int, ncols: int, delimiter: str | None,
                   header: _Header) -> list[str] | None:
    """Return the column names on the last header line (with a line of units: both)."""
    before = [i for i in range(first) if lines[i].strip() and i not in header.lines]
    if not before:
        return None
    names = _column_names(lines[before[-1]], ncols, delimiter)
    if names is None:
        return None
    header.lines.add(before[-1])
    if len(before) > 1 and all(_is_unit_label(n) for n in names):
        # a line of units under a line of titles: ``X;Y;valid`` then ``[mm];[mm];[1/0]``
        titles = _column_names(lines[before[-2]], ncols, delimiter)
        if titles is not None:
            header.lines.add(before[-2])
            names = [f"{t} {n}" for t, n in zip(titles, names)]
    return names


def _read_header(lines: list[str], first: int, header: _Header) -> None:
    """Add the ``key: value`` lines before the data and the comments after it to ``header``."""
    for i in range(first):
        if lines[i].strip() and i not in header.lines:
            kv = _split_key_value(lines[i])
            if kv:
                header.add(*kv)
            elif _NAMES_A_FACTOR.search(lines[i]) and header.unread_factor is None:
                header.unread_factor = lines[i].strip()[:80]  # no key = value: damaged
    for i in range(first, len(lines)):  # comments between and after the data lines
        if _is_comment(lines[i]):
            kv = _split_key_value(lines[i])
            if kv:
                header.add(*kv)


def _is_unit_label(name: str) -> bool:
    """Whether a column name is only a unit, such as ``[mm]`` or ``[1/0]``."""
    return bool(re.fullmatch(r"[\[(][^\])]*[\])]", name.strip()))


def _point_count_line(name, lines, rows, tokens, header):
    """Take a first data line holding one whole number before wider lines as a point count.

    Some x-y exports write a line of units, then the number of points, then the points.
    The count is checked against the lines that follow and kept in ``attrs["points"]``: it
    may equal their number or their number less one (the index of the last point counted
    from 0, as in such files found in the wild); anything else is refused.
    """
    if len(tokens) < 2 or len(tokens[0]) != 1 or len(tokens[1]) < 2 or \
            not re.fullmatch(r"\+?\d+", tokens[0][0]):
        return rows, tokens
    stated, found = int(tokens[0][0]), len(rows) - 1
    if stated not in (found, found - 1):
        raise ValueError(f"{name}: line {rows[0] + 1} states {stated} points but {found} "
                         "lines of points follow (truncated file?)")
    header.lines.add(rows[0])
    header.attrs["points"] = stated
    return rows[1:], tokens[1:]


def _apply_valid_column(name, values, tokens, names, header):
    """Turn a last column titled ``valid`` (1 = measured, 0 = missing) into NaN heights.

    The column is removed and the heights (the column before it) of the points it marks
    0 become NaN; ``attrs["valid_column"]`` keeps its title and ``attrs["invalid_points"]``
    the number of missing points.
    """
    if not names or values.shape[1] < 3 or not _norm_key(names[-1]).startswith("valid"):
        return values, tokens, names
    flag = values[:, -1]
    if not np.all(np.isin(flag, (0.0, 1.0))):
        bad = int(np.argmax(~np.isin(flag, (0.0, 1.0))))
        raise ValueError(f"{name}: the column {names[-1]!r} marks valid points with 1 and "
                         f"missing ones with 0, but data line {bad + 1} has {flag[bad]:g}")
    values = values[:, :-1].copy()
    values[flag == 0, -1] = np.nan
    header.attrs["valid_column"] = names[-1]
    header.attrs["invalid_points"] = int(np.count_nonzero(flag == 0))
    return values, [t[:-1] for t in tokens], names[:-1]


def _drop_index_column(values, tokens, names, header):
    """Remove a leading column of row numbers (``index, x in µm, y in µm``).

    Only a column whose title says it is an index *and* whose values count up by one is
    removed; its title is kept in ``attrs["index_column"]``.
    """
    if not names or values.shape[1] < 2 or \
            _norm_key(names[0]) not in ("index", "idx", "no", "nr", "number", "pointindex"):
        return values, tokens, names
    first = values[:, 0]
    if not (np.all(np.isfinite(first)) and np.all(np.diff(first) == 1)
            and first[0] == round(first[0])):
        return values, tokens, names
    header.attrs["index_column"] = names[0]
    return values[:, 1:], [t[1:] for t in tokens], names[1:]


# ---------------------------------------------------------------------------------------
# building the topography


def _lateral_pair(name, qx, qy, unit, fallback):
    """``((y, x), unit)`` from header quantities along x and y (y converted to x's unit)."""
    ux = qx[1] or qy[1] or fallback
    if ux is None:
        raise _need_unit(name, "lateral size", ("unit",))
    factor = u.conversion_factor(qy[1], ux) if qy[1] else 1.0
    return (qy[0] * factor, qx[0]), unit or ux


def _header_has_map_geometry(header: _Header) -> bool:
    """Whether the header states the lateral size or points of a map along x and y."""
    sizes = (header.size["x"] is not None and header.size["y"] is not None)
    counts = header.count["x"] is not None and header.count["y"] is not None
    return sizes or counts


def _check_profile_length(name, x, header, lunit) -> None:
    """Refuse a profile whose positions do not cover the length or points the header states."""
    n = x.size
    if header.count["x"] is not None and header.count["x"] != n and \
            header.count["y"] is None:
        raise ValueError(f"{name}: the header states {header.count['x']} points but the "
                         f"file has {n} (truncated file?)")
    stated = header.size["profile"]
    if stated is None or n < 2 or not np.all(np.isfinite(x[[0, -1]])):
        return
    length, sunit = stated
    if sunit is not None and lunit is not None and sunit != lunit:
        try:
            length *= u.conversion_factor(sunit, lunit)
        except Exception:  # noqa: BLE001 - a unit pint cannot convert: no check possible
            return
    extent = abs(float(x[-1] - x[0]))
    step = extent / (n - 1)
    tol = 0.02 * abs(length) + 2 * step
    if length > 0 and abs(extent - length) > tol and abs(extent + step - length) > tol:
        raise ValueError(
            f"{name}: the header states a length of {stated[0]:g} {stated[1] or lunit} but "
            f"the {n} points cover {extent:g} {lunit} (x from {x[0]:g} to {x[-1]:g}): a "
            "truncated or inconsistent file; pass size= or spacing= to read the points as "
            "they are")


def _need_unit(name: str, what: str, options: tuple[str, ...]) -> MissingOptionError:
    return MissingOptionError(name, f"the file states no unit for the {what}", options,
                              either=True, advice=" (e.g. unit='nm'); no unit is guessed")


@dataclass
class _Table:
    """The numbers of a file with what the file says about them.

    ``values`` (rows x columns, heights already multiplied by a header conversion factor),
    their printed ``tokens``, the column ``names`` (or None), the ``header``, the attributes
    of the result, the unit each column title names and the unit a conversion factor gives
    the heights.
    """

    name: str
    values: np.ndarray
    tokens: list[list[str]]
    names: list[str] | None
    header: _Header
    attrs: dict
    column_units: list[str | None]
    factor_unit: str | None

    @property
    def ncols(self) -> int:
        return self.values.shape[1]


@dataclass(frozen=True)
class _Options:
    """What the caller of :func:`read` states about the file (None: the file says)."""

    unit: str | None
    height_unit: str | None
    spacing: QuantityLike | None
    size: QuantityLike | None
    resample: bool
    column: int | str | None

    @property
    def lateral_given(self) -> bool:
        return self.spacing is not None or self.size is not None


def _height_unit(t: _Table, opts: _Options, column_unit: str | None = None) -> str:
    """Return the heights' unit: the caller's, the factor's, the column's, the header's."""
    hunit = opts.height_unit or opts.unit or t.factor_unit or column_unit \
        or t.header.height_unit()
    if hunit is None:
        raise _need_unit(t.name, "heights", ("unit", "height_unit"))
    return hunit


def _detect_layout(shape: tuple[int, int], header: _Header, column) -> str:
    """Decide the layout from ``column=``, the header or the number of columns."""
    nrows, ncols = shape
    if column is not None:
        return "profile"
    if nrows >= 2 and ncols >= 2 and _header_has_map_geometry(header):
        return "matrix"  # e.g. a Gwyddion export of a narrow map: Width and Height
    return {1: "column", 2: "profile", 3: "xyz"}.get(ncols, "matrix")


#: The columns holding heights, per layout (what a height conversion factor multiplies).
_HEIGHT_COLUMNS = {"matrix": slice(None), "column": slice(None), "profile": slice(1, None),
                   "xyz": slice(2, 3)}


def _table(name: str, parsed, layout: str) -> _Table:
    """Gather the parsed file, its attributes and units, and apply its height factor."""
    values, tokens, names, header = parsed
    attrs = dict(header.attrs)
    if header.channel is not None:
        attrs.setdefault("channel", header.channel)
    if names:
        attrs["columns"] = ", ".join(names)
    attrs["text_layout"] = layout
    column_units: list[str | None] = ([_unit_in(n) for n in names] if names
                                      else [None] * values.shape[1])
    factor_unit = None
    if names and header.unread_factor is None and _NAMES_A_FACTOR.search(" ".join(names)):
        header.unread_factor = " ".join(names)[:80]  # a factor line taken for titles
    if header.height_factor is None and header.unread_factor is not None:
        raise ValueError(f"{name}: the header line {header.unread_factor!r} names a "
                         "conversion factor of the values that does not read as one "
                         "(damaged?): the heights would be unscaled; refused")
    if header.height_factor is not None:
        factor, factor_unit, stated = header.height_factor
        if not (np.isfinite(factor) and factor != 0):
            raise ValueError(f"{name}: the header's height conversion factor ({stated}) is "
                             "not a finite non-zero number")
        attrs["height_conversion"] = stated
        values = values.copy()
        values[:, _HEIGHT_COLUMNS[layout]] *= factor
    return _Table(name, values, tokens, names, header, attrs, column_units, factor_unit)


# ---------------------------------------------------------------------------------------
# one reader per layout


def _read_matrix(t: _Table, opts: _Options) -> xr.DataArray:
    """Read a height matrix in image order (its first line is the top row)."""
    nrows, ncols = t.values.shape
    if nrows < 2 or ncols < 2:
        raise ValueError(f"{t.name}: a height matrix needs at least 2 rows and 2 columns, "
                         f"got {nrows} x {ncols}")
    for dim, n in (("x", ncols), ("y", nrows)):
        stated = t.header.count[dim]
        if stated is not None and stated != n:
            raise ValueError(f"{t.name}: the header states {stated} points along {dim} but "
                             f"the matrix has {n} (truncated file?)")
    hunit = _height_unit(t, opts)
    spacing, size, lunit = _matrix_lateral(t, opts)
    return topography(t.values[::-1], spacing=spacing, size=size, unit=lunit,
                      height_unit=hunit, attrs=t.attrs)


def _matrix_lateral(t: _Table, opts: _Options):
    """``(spacing, size, lateral unit)`` of a matrix: the caller's, else the header's."""
    header = t.header
    lunit = opts.unit or header.lateral_unit()
    if opts.lateral_given:
        return opts.spacing, opts.size, lunit
    sx = header.size["x"] or header.size["xy"]
    sy = header.size["y"] or header.size["xy"]
    dx = header.spacing["x"]
    dy = header.spacing["y"] or dx
    if sx is not None and sy is not None:
        size, lunit = _lateral_pair(t.name, sx, sy, opts.unit, header.lateral_unit())
        return None, size, lunit
    if dx is not None:
        spacing, lunit = _lateral_pair(t.name, dx, dy, opts.unit, header.lateral_unit())
        return spacing, None, lunit
    raise MissingOptionError(t.name, "a height matrix without lateral size", ("size", "spacing"),
                             either=True, advice=" ((Ly, Lx) or (dy, dx): numbers in unit=, "
                             "or strings such as '10 um')")


def _read_column(t: _Table, opts: _Options) -> xr.DataArray:
    """Heights of a profile, one column (or every number of the block, in reading order)."""
    single = t.ncols == 1
    hunit = _height_unit(t, opts, t.column_units[0] if single else None)
    h = t.values[:, 0] if single else t.values.ravel()
    spacing, size, lunit = _column_lateral(t, opts)
    return topography(h, spacing=spacing, size=size, unit=lunit, height_unit=hunit,
                      attrs=t.attrs)


def _column_lateral(t: _Table, opts: _Options):
    """``(spacing, size, lateral unit)`` of a column: the caller's, else the header's."""
    header, spacing, size = t.header, opts.spacing, opts.size
    if opts.lateral_given:
        lunit = opts.unit or header.lateral_unit()
    elif header.spacing["x"] is not None:
        spacing = header.spacing["x"][0]
        lunit = opts.unit or header.spacing["x"][1] or header.lateral_unit()
    elif (length := header.size["profile"] or header.size["x"]) is not None:
        size, stated = length
        lunit = opts.unit or stated or header.lateral_unit()
    else:
        raise MissingOptionError(t.name, "a column of heights without lateral size",
                                 ("size", "spacing"), either=True,
                                 advice=" (the profile length or the step)")
    if lunit is None and not any(isinstance(v, str) for v in (spacing, size)):
        raise _need_unit(t.name, "lateral size", ("unit",))
    return spacing, size, lunit


def _read_profile(t: _Table, opts: _Options) -> xr.DataArray:
    """Read a profile ``x, h`` (or ``x, h1, h2...``, ``column=`` choosing the heights)."""
    if t.ncols < 2:
        raise ValueError(f"{t.name}: a profile needs two columns (x, h), found {t.ncols}")
    hcol = _height_column(t, opts.column)
    header = t.header
    lunit = opts.unit or t.column_units[0] or header.unit["x"] or header.unit["any"] \
        or header.lateral_unit()
    if lunit is None:
        raise _need_unit(t.name, "x positions", ("unit",))
    if not opts.lateral_given:
        _check_profile_length(t.name, t.values[:, 0], header, lunit)
    hunit = _height_unit(t, opts, t.column_units[hcol])
    if opts.column is not None and t.names:
        t.attrs["height_column"] = t.names[hcol]
    return _profile(t, opts, hcol, lunit, hunit)


def _height_column(t: _Table, column: int | str | None) -> int:
    """Index of the column of heights of a profile table (1 without ``column=``)."""
    if column is None:
        if t.ncols > 2:
            raise ValueError(f"{t.name}: {t.ncols} columns; pass column= to choose the height "
                             "column of a profile table, or layout='matrix'/'xyz'")
        return 1
    if isinstance(column, str):
        if not t.names or column not in t.names:
            raise ValueError(f"{t.name}: no column named {column!r} (columns: "
                             f"{', '.join(t.names) if t.names else 'no names'})")
        hcol = t.names.index(column)
    else:
        hcol = int(column)
    if not 0 < hcol < t.ncols:
        raise ValueError(f"{t.name}: column must name a height column 1..{t.ncols - 1}")
    return hcol


def _profile(t: _Table, opts: _Options, hcol: int, lunit: str, hunit: str) -> xr.DataArray:
    """Heights at the positions of the first column: on a uniform grid when they are one."""
    name, attrs = t.name, t.attrs
    x, h = t.values[:, 0], t.values[:, hcol]
    if x.size < 2:
        raise ValueError(f"{name}: a profile needs at least 2 points")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name}: the x column has missing (NaN) or infinite positions")
    q = _quanta([tok[0] for tok in t.tokens])
    if np.all(np.diff(x) < 0):
        x, h, q = x[::-1], h[::-1], q[::-1]
        attrs["x_reversed"] = 1
    if not np.all(np.diff(x) > 0):
        bad = int(np.argmax(np.diff(x) <= 0))
        raise ValueError(f"{name}: the x column is not monotonic (point {bad + 1} at "
                         f"{x[bad]:g}, the next at {x[bad + 1]:g}): a re-entrant or "
                         "unsorted profile cannot be read")
    uniform, step, origin, dev = _uniform_fit(x, q, _stated_steps(t.header, x.size, lunit))
    if not uniform:
        return nonuniform_profile(name, x, h, lunit, hunit, attrs, opts.resample, opts.size,
                                  opts.spacing)
    attrs.update(sampling="uniform", x_offset=float(origin))
    if opts.lateral_given:
        return topography(h, spacing=opts.spacing, size=opts.size, unit=lunit,
                          height_unit=hunit, attrs=attrs)
    attrs["x_max_deviation"] = dev
    return topography(h, spacing=step, unit=lunit, height_unit=hunit, attrs=attrs)


def _read_xyz(t: _Table, opts: _Options) -> xr.DataArray:
    """Points ``x, y, z`` on a regular grid, as a map."""
    if t.ncols != 3:
        raise ValueError(f"{t.name}: x-y-z points need three columns, found {t.ncols}")
    cu = t.column_units
    lunit = opts.unit or cu[0] or cu[1] or t.header.lateral_unit()
    if lunit is None:
        raise _need_unit(t.name, "x-y positions", ("unit",))
    hunit = _height_unit(t, opts, cu[2])
    try:
        topo = _xyz(t.name, t.values, t.tokens, lunit, hunit, t.attrs)
    except ValueError as err:
        raise ValueError(f"{err} (if the three columns are x and two height columns, pass "
                         "column=; if they are a height matrix, layout='matrix')") from None
    if opts.lateral_given:
        topo = topography(topo.drop_vars(["y", "x"]), spacing=opts.spacing, size=opts.size,
                          unit=lunit, height_unit=hunit)
    return topo


def _grid_axis(name, values, tokens, what):
    uniq, first = np.unique(values, return_index=True)
    if uniq.size < 2:
        raise ValueError(f"{name}: the {what} column takes a single value: not a map")
    uniform, step, origin, _ = _uniform_fit(uniq, _quanta([tokens[i] for i in first]))
    if not uniform:
        raise ValueError(f"{name}: the x-y-z points are not on a regular grid (the {what} "
                         "values are not uniformly spaced); interpolate them onto a "
                         "uniform grid first (e.g. scipy.interpolate.griddata)")
    return uniq, step, origin


def _xyz(name, values, tokens, lunit, hunit, attrs):
    x, y, z = values.T
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError(f"{name}: some x-y-z points have no x or y position")
    ux, dx, x0 = _grid_axis(name, x, [t[0] for t in tokens], "x")
    uy, dy, y0 = _grid_axis(name, y, [t[1] for t in tokens], "y")
    ix = np.searchsorted(ux, x)
    iy = np.searchsorted(uy, y)
    flat = iy * ux.size + ix
    if np.unique(flat).size != flat.size:
        raise ValueError(f"{name}: some x-y positions appear more than once: not a map")
    if flat.size < 0.5 * ux.size * uy.size:
        raise ValueError(f"{name}: the x-y-z points are not on a regular grid ({flat.size} "
                         f"points for a {uy.size} x {ux.size} grid); interpolate them onto "
                         "a uniform grid first")
    grid = np.full((uy.size, ux.size), np.nan)
    grid[iy, ix] = z
    if flat.size < grid.size:
        attrs["missing_points"] = int(grid.size - flat.size)
    if not np.isclose(dx, dy, rtol=1e-6):
        spacing = (dy, dx)
    else:
        spacing = dx
    attrs.update(x_offset=float(x0), y_offset=float(y0), sampling="uniform")
    return topography(grid, spacing=spacing, unit=lunit, height_unit=hunit, attrs=attrs)


def read(path, *, unit: str | None = None, height_unit: str | None = None, spacing=None,
         size=None, resample: bool = False, layout: str | None = None,
         column: int | str | None = None, encoding: str | None = None) -> xr.DataArray:
    r"""Read a topography from a plain-text file.

    Parameters
    ----------
    path : str or Path
        The file.
    unit : str, optional
        Lateral unit, and the height unit unless ``height_unit`` is given. Replaces what
        the file states (relabels); required when the file states no unit.
    height_unit : str, optional
        Unit of the heights (replaces the file's).
    spacing : float, str, Quantity or pair, optional
        Grid spacing ``(dy, dx)`` or ``dx``, for files without lateral information (a bare
        matrix or column of heights); replaces the file's otherwise.
    size : float, str, Quantity or pair, optional
        Physical size ``(Ly, Lx)`` or ``Lx`` (alternative to ``spacing``).
    resample : bool
        For a non-uniformly sampled profile: interpolate linearly onto a uniform grid with
        the same number of points over the same range. By default (False) such a profile
        is returned as measured, on its non-uniform ``x``.
    layout : {"matrix", "profile", "xyz", "column"}, optional
        Force the layout instead of deciding it from the number of columns.
    column : int or str, optional
        For a table with several height columns (``x, h1, h2...``): the column (index or
        name) holding the heights; ``x`` is the first column.
    encoding : str, optional
        Text encoding (default: UTF-8, falling back to Latin-1).

    Returns
    -------
    xarray.DataArray
        A topography (:func:`xrough.topography`), or for a non-uniformly sampled profile
        read without ``resample`` a profile on its measured ``x`` with
        ``attrs["sampling"] = "non-uniform"``. Header entries are in ``attrs``; lateral
        offsets of the file's coordinates in ``attrs["x_offset"]`` (``y_offset``).

    Raises
    ------
    ValueError
        Garbage or corrupted text, irregular x-y-z points, missing size or units (the
        message names the file and says what to pass).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     p = pathlib.Path(tmp) / "m.txt"
    ...     _ = p.write_text("# Width: 4 um\n# Height: 2 um\n# Value units: nm\n"
    ...                      "1 2 3 4\n5 6 7 8\n")
    ...     t = read(p)
    >>> t.dims, t.shape, t.x.attrs["units"], t.attrs["units"], float(t.x[1])
    (('y', 'x'), (2, 4), 'um', 'nm', 1.0)
    >>> t.isel(y=0).values.tolist()  # the last line of the file is the bottom row, y = 0
    [5.0, 6.0, 7.0, 8.0]
    """
    path = Path(path)
    with reader_errors(path, "text"):
        return _read(path, unit=unit, height_unit=height_unit, spacing=spacing, size=size,
                     resample=resample, layout=layout, column=column, encoding=encoding)


#: The reader of each layout.
_LAYOUTS = {"matrix": _read_matrix, "profile": _read_profile, "xyz": _read_xyz,
            "column": _read_column}


def _read(path: Path, *, layout, encoding, **options) -> xr.DataArray:
    if layout not in (None, *_LAYOUTS):
        raise ValueError(f"layout must be 'matrix', 'profile', 'xyz' or 'column', got "
                         f"{layout!r}")
    parsed = _parse(path, encoding)
    opts = _Options(**options)
    layout = layout or _detect_layout(parsed[0].shape, parsed[3], opts.column)
    return _LAYOUTS[layout](_table(path.name, parsed, layout), opts)


def write(topo: xr.DataArray, path, *, fmt: str = "%.17g") -> None:
    """Write a topography as text that :func:`read` reads back.

    A map is written as a matrix (one line per ``y``, the top row first) under a
    Gwyddion-style header
    (``# Width``, ``# Height``, ``# Value units``); a profile as two columns ``x`` and
    height under a line of column names with units.

    Parameters
    ----------
    topo : xarray.DataArray
        A topography (no extra dims).
    path : str or Path
        The output file.
    fmt : str
        Number format (default: enough digits to read back the same floats).
    """
    grid = grid_of(topo)
    if topo.ndim != len(grid.dims):
        raise ValueError("only a single map or profile can be written as text; select "
                         "one scan of the stack first")
    lu, hu = grid.lateral_unit, grid.height_unit
    if grid.dims == ("y", "x"):
        header = (f"Channel: {topo.name or 'height'}\n"
                  f"Width: {grid.size[1]:.17g} {lu}\n"
                  f"Height: {grid.size[0]:.17g} {lu}\n"
                  f"Value units: {hu}")
        np.savetxt(path, topo.transpose("y", "x").values[::-1], fmt=fmt, delimiter="\t",
                   header=header, comments="# ")
    else:
        data = np.column_stack([topo["x"].values, topo.values])
        np.savetxt(path, data, fmt=fmt, delimiter="\t", header=f"x [{lu}]\theight [{hu}]",
                   comments="# ")
