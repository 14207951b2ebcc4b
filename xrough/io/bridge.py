"""Optional bridge to SurfaceTopography's readers for the long tail of instrument formats.

SurfaceTopography (``pip install xrough[formats]``) reads many formats xrough has no
native reader for: Keyence (``.vk4``, ``.vk6``), Zygo (``.dat``, ``.datx``), Sensofar
(``.plu``, ``.plux``), Olympus (``.lext``, ``.oir``), Wyko (``.opd``), Alicona
(``.al3d``), Agilent/Keysight (``.mi``), Nanosurf (``.nid``, ``.ezd``), NT-MDT
(``.mdt``), Mitutoyo, ... :func:`read_with_surfacetopography` converts what it returns
into an xrough topography: heights as a ``(y, x)`` map or ``(x,)`` profile, the physical
size and unit the file states, and the file's metadata (the items that are numbers or
text, flattened) in ``attrs``.

SurfaceTopography follows Gwyddion's orientation for every format: its row 0 is the *top*
of the image. xrough's row 0 is at ``y = 0`` and plots at the bottom, so rows are reversed
(as xrough's native readers of formats stored top line first do: Gwyddion, X3P, SDF, SUR,
text): the native readers and the bridge agree row by row, and the picture is the same in
every program.

:func:`xrough.io.open_topography` falls back to this bridge when no native reader
recognises a file and SurfaceTopography is installed.

SurfaceTopography reads the data where a header says it is, without comparing the header
with the file. The bridge checks what it can: the sizes and offsets stated by the headers
of Alicona ``.al3d``, Nanosurf ``.nid``/``.ezd`` and Molecular Imaging ``.mi`` files
against the file's size (:func:`xrough.io._layout.check_layout`), and, for every format,
that no height is more than a billion times the lateral size of the scan
(:func:`xrough.io._common.check_height_scale`: float bytes read out of step give heights
up to ``3.4e38``), and that the file is not text with NUL bytes (a damaged text file, which
SurfaceTopography reads up to the first NUL: :func:`xrough.io.text.text_with_nul`). A file
that fails is refused with a ``ValueError`` naming it. A file SurfaceTopography would take
for an SRTM ``.hgt`` elevation tile (which has no magic bytes: any file of ``2 n**2``
bytes) is one only when its name and size are an SRTM tile's (:func:`srtm_tile`).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import re
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

from .. import quality
from .. import units as u
from ..topography import topography
from ._common import (
    READER_WARNINGS,
    MissingOptionError,
    check_height_scale,
    choose_height_channel,
    fail,
    invalid_as_missing,
    micro_as_u,
    nonuniform_profile,
    select_channel,
)
from ._layout import check_layout
from .text import damaged_text, text_with_nul

__all__ = ["available", "sniff", "read", "read_with_surfacetopography", "channels",
           "default_channel", "info_attrs", "srtm_tile", "EXTENSIONS", "DESCRIPTION",
           "FALLBACK"]

#: What the bridge says of itself as a reader (:mod:`xrough.io.readers`): no extension of
#: its own (it reads many), tried after every native reader.
EXTENSIONS: tuple[str, ...] = ()
DESCRIPTION = "a format read by SurfaceTopography"
FALLBACK = True

_INSTALL_HINT = ("reading this format needs SurfaceTopography: pip install xrough[formats] "
                 "(or pip install SurfaceTopography)")
_RESERVED = {"units", "long_name", "periodic", "sampling", "source", "source_file",
             "source_sha256", "format", "overrides", "name"}
_MAX_RAW_ITEMS = 500
_MAX_TEXT = 2000
#: SRTM tiles: ``N47E008.hgt`` (latitude and longitude of the south-west corner) of 1201**2
#: (3 arc-seconds) or 3601**2 (1 arc-second) big-endian 16-bit samples.
_SRTM_NAME = re.compile(r"^[NS]\d{2}[EW]\d{3}\.hgt$", re.IGNORECASE)
_SRTM_SIZES = (2 * 1201**2, 2 * 3601**2)


def _import():
    """Import SurfaceTopography quietly (it warns about optional MPI support)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import SurfaceTopography
            import SurfaceTopography.IO
    except ImportError as err:
        raise ImportError(_INSTALL_HINT) from err
    return SurfaceTopography


def available() -> bool:
    """Whether SurfaceTopography can be imported.

    Returns
    -------
    bool
    """
    try:
        _import()
    except ImportError:
        return False
    return True


def sniff(head: bytes, path: Path | None = None) -> bool:
    """Whether SurfaceTopography recognises the file (False when it is not installed).

    This opens the file with SurfaceTopography's format detection, so it is slower than the
    native readers' checks; :func:`xrough.io.detect_format` calls it last.

    Parameters
    ----------
    head : bytes
        The first bytes of the file (unused: detection needs the whole file).
    path : pathlib.Path
        The file.

    Returns
    -------
    bool
    """
    if path is None:
        return False
    try:
        st = _import()
    except ImportError:
        return False
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            found = st.IO.detect_format(str(path))
    except Exception:  # noqa: BLE001 - any failure means "not recognised"
        return False
    return found != "hgt" or srtm_tile(path)


def srtm_tile(path: Path) -> bool:
    """Whether ``path`` is named and sized as an SRTM ``.hgt`` elevation tile.

    The format has no magic bytes (SurfaceTopography takes any file of ``2 n**2`` bytes
    for one); a tile is named after its south-west corner (``N47E008.hgt``) and holds
    1201 x 1201 or 3601 x 3601 big-endian 16-bit samples.

    Parameters
    ----------
    path : pathlib.Path
        The file.

    Returns
    -------
    bool

    Examples
    --------
    >>> srtm_tile(Path("scan.bin"))
    False
    """
    path = Path(path)
    try:
        size = path.stat().st_size
    except OSError:
        return False
    return bool(_SRTM_NAME.match(path.name)) and size in _SRTM_SIZES


def _attr_key(key: str) -> str:
    name = re.sub(r"[^0-9A-Za-z_]+", "_", key).strip("_")
    if name and not name[0].isalpha():
        name = "k_" + name
    if name.lower() in _RESERVED:
        name = "file_" + name
    return name


def _legal(value):
    """Convert a metadata value to str, int or float; None if it has no such form."""
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, (int, np.integer)):
        return int(value) if abs(int(value)) < 2**63 else str(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, (_dt.datetime, _dt.date, _dt.time)):
        return value.isoformat()
    if isinstance(value, bytes):
        value = value.decode("utf-8", errors="replace")
    if isinstance(value, str):
        printable = "".join(c for c in value if c.isprintable() or c in "\t\n")
        if len(printable) < 0.9 * len(value):  # binary bytes read as text: not metadata
            return None
        printable = printable.strip()
        return printable[:_MAX_TEXT] if printable else None
    if isinstance(value, np.ndarray) and value.size == 1:
        return _legal(value.reshape(()).item())
    if isinstance(value, (list, tuple, np.ndarray)) and 0 < len(value) <= 16:
        items = [_legal(v) for v in value]
        if all(isinstance(v, (int, float, str)) for v in items):
            return " ".join(str(v) for v in items)
    if hasattr(value, "value") and hasattr(value, "unit"):  # a value with its unit
        return _legal(f"{value.value} {value.unit}")
    return None


def _flatten(info, prefix: str = "", out: dict | None = None, depth: int = 0) -> dict:
    out = {} if out is None else out
    for key, value in info.items():
        name = _attr_key(f"{prefix}_{key}" if prefix else str(key))
        if not name or len(out) >= _MAX_RAW_ITEMS:
            continue
        if isinstance(value, dict):
            if {"value", "unit"} <= set(value) and len(value) == 2:
                legal = _legal(f"{value['value']} {value['unit']}")
            elif depth < 4:
                _flatten(value, name, out, depth + 1)
                continue
            else:
                continue
        else:
            legal = _legal(value)
        if legal is not None and name not in out:
            out[name] = legal
    return out


def info_attrs(info: dict) -> dict:
    """NetCDF-legal attributes from a SurfaceTopography ``info`` dictionary.

    Nested dictionaries are flattened with ``_`` (``instrument_name``), datetimes become
    ISO strings, short lists space-separated strings; other items are left out. The
    file's raw header (``raw_metadata``) is kept with the prefix ``raw_``.

    Parameters
    ----------
    info : dict

    Returns
    -------
    dict
        Attribute names (letters, digits, ``_``) to str, int or float.

    Examples
    --------
    >>> import datetime
    >>> info_attrs({"instrument": {"name": "PLu neox", "vendor": "Sensofar"},
    ...             "acquisition_time": datetime.datetime(2023, 3, 10, 16, 35, 59)})
    {'instrument_name': 'PLu neox', 'instrument_vendor': 'Sensofar', 'acquisition_time': '2023-03-10T16:35:59'}
    """  # noqa: E501
    info = dict(info or {})
    raw = info.pop("raw_metadata", None)
    out = _flatten(info)
    if isinstance(raw, dict):
        out.update({k: v for k, v in _flatten(raw, "raw").items() if k not in out})
    return out


def _is_length(unit: str) -> bool:
    try:
        return u.is_length(micro_as_u(unit))
    except ValueError:
        return False


def _st_unit(unit) -> str | None:
    unit = _unit_text(unit)
    if not unit:
        return None
    return u.format_units(u.as_length_unit(micro_as_u(str(unit)),
                                           what="SurfaceTopography unit"))


def channels(path) -> list[dict]:
    """List the data channels SurfaceTopography finds in a file.

    Parameters
    ----------
    path : str or Path
        The file, in any format SurfaceTopography reads.

    Returns
    -------
    list of dict
        ``index``, ``name``, ``unit`` (lateral), ``data_unit`` and ``is_height``.
    """
    with _opened(path) as reader:
        return [{"index": c.index, "name": c.name, "unit": c.unit, "data_unit": c.data_unit,
                 "is_height": bool(getattr(c, "is_height_channel", True))}
                for c in reader.channels]


def default_channel(path) -> int:
    """Index of the channel SurfaceTopography reads without ``channel=``.

    Parameters
    ----------
    path : str or Path
        The file, in any format SurfaceTopography reads.

    Returns
    -------
    int
    """
    with _opened(path) as reader:
        return int(_default(reader, Path(path), _listed(reader), warn=False)["index"])


@contextlib.contextmanager
def _opened(path):
    """SurfaceTopography's reader of ``path`` (its warnings silenced), closed after use."""
    st = _import()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = st.open_topography(str(path))
    try:
        yield reader
    finally:
        _close(reader)


def _close(reader) -> None:
    close = getattr(reader, "close", None)
    if close is not None:
        try:
            close()
        except Exception:  # noqa: BLE001, S110 - closing must not hide the result
            pass


def _unit_text(unit) -> str:
    """Return a unit as text (SurfaceTopography gives some as a tuple, one per axis)."""
    if isinstance(unit, (tuple, list)):
        unit = unit[0] if unit else None
    return "" if unit is None else str(unit)


def _select(reader, channel, path: Path):
    """Find the channel ``channel``: a name, SurfaceTopography's channel id or an index."""
    chans = list(reader.channels)
    if isinstance(channel, str):
        for c in chans:
            if getattr(c, "channel_id", None) == channel:
                return c
    def default(path, channels, listing, *, warn):
        return _default(reader, path, channels, warn=warn)

    return select_channel(path, _listed(reader), channel, default=default)["channel"]


def _listed(reader) -> list[dict]:
    return [{"index": c.index, "name": str(c.name), "unit": _unit_text(c.data_unit),
             "channel": c} for c in reader.channels]


def _default(reader, path: Path, channels: list[dict], *, warn: bool) -> dict:
    """Pick the channel read without ``channel=``: by meaning, as the native readers.

    A Nanosurf file's first channel in metres may be the deflection; SurfaceTopography's
    default (its first height channel) breaks ties.
    """
    heights = [c for c in channels if getattr(c["channel"], "is_height_channel", True)
               and c["unit"] and _is_length(c["unit"])]
    first = reader.default_channel.index
    if not heights:
        return next(c for c in channels if c["index"] == first)
    return choose_height_channel(path, heights, warn=warn, key=lambda c: c["index"] != first)


def read_with_surfacetopography(path, *, channel: int | str | None = None, size=None,
                                unit: str | None = None, height_unit: str | None = None,
                                resample: bool = False) -> xr.DataArray:
    """Read a topography with SurfaceTopography and convert it to an xrough topography.

    Parameters
    ----------
    path : str or Path
        The file, in any format SurfaceTopography reads.
    channel : int or str, optional
        Channel index or name (default: the file's default channel).
    size : float, str, Quantity or pair, optional
        Physical size ``(Ly, Lx)`` (or ``Lx``), replacing the file's or for files without.
    unit : str, optional
        Lateral unit (and height unit unless ``height_unit``), replacing the file's or for
        files without (relabels, does not convert).
    height_unit : str, optional
        Height unit replacing the file's.
    resample : bool
        For a non-uniformly sampled profile: interpolate linearly onto a uniform grid with
        the same number of points over the same range; by default it is returned as
        measured with ``attrs["sampling"] = "non-uniform"``.

    Returns
    -------
    xarray.DataArray
        Heights ``(y, x)`` or ``(x,)`` in the unit SurfaceTopography reports (it gives
        heights and lateral sizes in one unit), the file's metadata in attrs, and
        ``attrs["reader"]`` naming SurfaceTopography's reader.

    Raises
    ------
    ImportError
        SurfaceTopography is not installed (the message says what to install).
    ValueError
        Unrecognised or corrupted file, unknown channel, non-height channel, missing size
        or unit.
    """
    st = _import()
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    _refuse_damaged_text(path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            reader = st.open_topography(str(path))
        except Exception as err:  # noqa: BLE001 - ST raises its own exception types
            raise ValueError(f"{path.name}: SurfaceTopography cannot read the file "
                             f"({type(err).__name__}: {str(err).strip()[:300]})") from None
        try:
            _check_file(path, type(reader).__name__)
            with _data_errors(path.name):
                data = _channel_data(reader, channel, path, size, unit)
        finally:
            _close(reader)
    for w in caught:  # what xrough said while reading: said again, to the user
        if issubclass(w.category, READER_WARNINGS):
            quality.warn(str(w.message), w.category)
    notes = sorted({str(w.message).strip() for w in caught
                    if not issubclass(w.category, (ImportWarning, *READER_WARNINGS))})
    if notes:
        data["attrs"]["reader_warnings"] = " | ".join(notes)[:_MAX_TEXT]
    data["attrs"].update(reader=type(reader).__name__, channel=str(data["channel"].name),
                         channel_index=int(data["channel"].index))
    with _data_errors(path.name):  # sizes of zero, say
        return _as_topography(data, path.name, size, unit, height_unit, resample)


def _refuse_damaged_text(path: Path) -> None:
    """Refuse a text file with NUL bytes, which SurfaceTopography reads up to the first NUL.

    Refused when the start of the file (64 kB, as far as the text reader looks for binary
    bytes) is text with lines of numbers but for its NUL bytes
    (:func:`xrough.io.text.text_with_nul`); a binary format's bytes hold other control
    bytes.
    """
    with open(path, "rb") as fh:
        head = fh.read(65536)
    if text_with_nul(head):
        damaged_text(path.name, head)


def _check_file(path: Path, reader: str) -> None:
    """Refuse what SurfaceTopography would read as garbage: a damaged layout, a non-tile."""
    if reader == "HGTReader" and not srtm_tile(path):
        raise fail(path, f"not an SRTM elevation tile: a .hgt tile is named after its "
                         f"corner (such as N47E008.hgt) and holds 1201 x 1201 or 3601 x "
                         f"3601 16-bit samples; this file has {path.stat().st_size} bytes "
                         "(SurfaceTopography takes any file of 2 n**2 bytes for one)")
    check_layout(path, reader)


@contextlib.contextmanager
def _data_errors(name: str):
    """Errors of SurfaceTopography reading the data as ``ValueError`` naming the file."""
    try:
        yield
    except ValueError as err:
        if str(err).startswith(name):
            raise
        raise ValueError(f"{name}: SurfaceTopography failed to read the data: the file "
                         f"is corrupted or holds values it cannot parse "
                         f"({type(err).__name__}: {str(err).strip()[:300]!r})") from None
    except Exception as err:  # noqa: BLE001
        raise ValueError(f"{name}: SurfaceTopography failed to read the data "
                         f"({type(err).__name__}: {str(err).strip()[:300]})") from None


def _channel_data(reader, channel, path: Path, size, unit) -> dict:
    """Read the chosen channel: heights, positions of a non-uniform profile, sizes, info."""
    name = path.name
    chan = _select(reader, channel, path)
    if not getattr(chan, "is_height_channel", True):
        raise ValueError(f"{name}: channel {chan.name!r} holds {chan.data_unit} data, "
                         "not heights")
    kwargs = {"channel_index": chan.index}
    nb = tuple(chan.nb_grid_pts)
    if chan.physical_sizes is None:  # the file has none: a placeholder, then size=
        if size is None:
            raise MissingOptionError(name, "the file states no physical size", ("size",))
        kwargs["physical_sizes"] = tuple(float(n) for n in nb)
    if _st_unit(chan.unit) is None:
        if unit is None:
            raise MissingOptionError(name, "the file states no unit", ("unit",),
                                     advice=" (e.g. unit='um')")
        kwargs["unit"] = "m"  # placeholder label; relabelled below
    topo = reader.topography(**kwargs)
    raw: np.ma.MaskedArray = np.ma.asarray(topo.heights(), dtype=float)
    heights: np.ndarray = np.ma.filled(raw, np.nan)
    if "physical_sizes" not in kwargs:  # sizes as the file states them: compare
        check_height_scale(path, heights, max(float(s) for s in topo.physical_sizes),
                           _unit_text(topo.unit) or "(file unit)")
    attrs = info_attrs(topo.info)
    marker = "the file's mask" if np.ma.is_masked(raw) else "NaN"
    heights = invalid_as_missing(path, heights, attrs, marker=marker)
    return {"channel": chan, "attrs": attrs,
            "heights": heights,
            "positions": topo.positions() if topo.dim == 1 and not topo.is_uniform else None,
            "unit": topo.unit, "nb": nb, "periodic": bool(topo.is_periodic),
            "sizes": tuple(float(s) for s in topo.physical_sizes)}


def _as_topography(data: dict, name: str, size, unit, height_unit, resample):
    """Build a topography (or a non-uniform profile) from SurfaceTopography's data."""
    lunit = unit or _st_unit(data["unit"])
    hunit = height_unit or unit or _st_unit(data["unit"])
    heights, sizes, nb, attrs = data["heights"], data["sizes"], data["nb"], data["attrs"]
    if data["positions"] is not None:  # non-uniform line scan
        return _nonuniform(name, np.asarray(data["positions"], dtype=float), heights, lunit,
                           hunit, attrs, resample, size)
    if heights.ndim == 2:  # SurfaceTopography indexes [x, y], row y = 0 at the top
        values = heights.T[::-1]
        spacing = (sizes[1] / nb[1], sizes[0] / nb[0])
    else:
        values = heights
        spacing = sizes[0] / nb[0]
    topo = topography(values, spacing=spacing, unit=lunit, height_unit=hunit,
                      periodic=data["periodic"], attrs=attrs)
    if size is not None:
        topo = topography(topo.drop_vars([d for d in ("y", "x") if d in topo.dims]),
                          size=size, unit=lunit, height_unit=hunit)
    return topo


def _nonuniform(name, x, h, lunit, hunit, attrs, resample, size):
    if x.size > 1 and x[0] > x[-1]:
        x, h = x[::-1], h[::-1]
    return nonuniform_profile(name, x, h, lunit, hunit, attrs, resample, size)


#: Module protocol of :mod:`xrough.io`: ``read(path, **options)``.
read = read_with_surfacetopography
