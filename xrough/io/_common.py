"""Helpers shared by the instrument readers: errors that name the file, size limits, channels."""

from __future__ import annotations

import contextlib
import re
import struct
import threading
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np
import xarray as xr

from .. import quality
from .. import units as u
from ..topography import topography

__all__ = ["CONVENTIONS", "CorruptedFileError",
           "fail", "MissingOptionError", "reader_errors", "check_file", "check_points",
           "check_height_scale", "check_lateral_size", "invalid_as_missing", "MAX_POINTS",
           "MAX_CHUNKS", "MAX_HEIGHT_TO_SIZE",
           "micro_as_u", "describe_channel", "channel_listing", "select_channel",
           "ChannelChoiceWarning", "InvalidPointsWarning", "READER_WARNINGS",
           "channel_rank", "choose_height_channel",
           "default_channel_reader", "nonuniform_profile", "HDF5_LOCK", "raw_hdf5"]


#: One lock for every NetCDF (HDF5) file xrough opens or writes itself: the HDF5 library
#: here is not thread-safe, and 20 threads saving their own archives crashed the
#: interpreter (SIGSEGV, SIGBUS). Reentrant, process-wide; lazy reads that dask makes later
#: go through xarray's own lock.
HDF5_LOCK = threading.RLock()

#: How deep each thread is in :func:`raw_hdf5` (xarray's lock is not reentrant).
_RAW = threading.local()


@contextlib.contextmanager
def raw_hdf5():
    """Hold the HDF5 library for calls to netCDF4 or h5py outside xarray.

    :data:`HDF5_LOCK`, then xarray's own HDF5 lock (always in this order, as xrough's
    writes through xarray take them): xarray closes a file it garbage-collects, in
    whatever thread, only when it gets its lock, so no such close runs in HDF5 beside
    these calls (one did, from a dask thread, and crashed the interpreter).
    """
    from_xarray = getattr(xr.backends.locks, "HDF5_LOCK", None)
    depth = getattr(_RAW, "depth", 0)
    with HDF5_LOCK:
        if depth == 0 and from_xarray is not None:
            from_xarray.acquire()
        _RAW.depth = depth + 1
        try:
            yield
        finally:
            _RAW.depth = depth
            if depth == 0 and from_xarray is not None:
                from_xarray.release()

#: Largest number of points a reader of this package's native formats (X3P, SUR, SDF)
#: accepts unless the caller passes ``max_points=``: a larger header is taken as corrupted.
MAX_POINTS = 2**31

#: Largest number of chunks one array of a NetCDF-4 file or Zarr store may declare: each is
#: a name to look up (Zarr), an entry of the index of chunks and a dask task (a lazy open).
#: A larger number is taken as a corrupted or forged header (a shape edited to 1e6 x 1e6
#: with chunks of 64 x 64 declares 244 million chunks), refused before any is looked up.
MAX_CHUNKS = 2**20

#: Largest height (in absolute value) a map or profile may have, as a multiple of its
#: lateral extent, before :func:`check_height_scale` takes the values as damaged binary
#: data (float bytes read at a shifted offset give heights of ``1e15`` to ``3.4e38``); an
#: absolute stage position of a few centimetres on a 100 um scan is about ``1e3`` times its
#: extent, and a height scale mistaken by a factor of 1e6 (metres for micrometres) still
#: reads.
MAX_HEIGHT_TO_SIZE = 1e9

#: The conventions every NetCDF file xrough writes follows (its global ``Conventions``).
CONVENTIONS = "CF-1.10"

#: Third-party exceptions and what they mean in a file reader, in words.
_ERROR_WORDS = (
    (UnicodeError, "text that is not validly encoded"),
    (ElementTree.ParseError, "malformed XML"),
    (zlib.error, "corrupted compressed data"),
    (zipfile.BadZipFile, "a corrupted zip archive"),
    (struct.error, "a truncated or corrupted binary structure"),
    (EOFError, "data that ends too early (truncated file)"),
    (ZeroDivisionError, "a zero size or spacing"),
    (OverflowError, "a number out of range"),
    (MemoryError, "sizes too large for memory"),
    (RecursionError, "structures nested too deeply"),
    (KeyError, "a missing entry"),
    (IndexError, "a missing entry"),
)



def fail(path: Path, message: str) -> ValueError:
    """Return (not raise) a ``ValueError`` whose message starts with the file's name.

    Examples
    --------
    >>> fail(Path("scan.spm"), "truncated file")
    ValueError('scan.spm: truncated file')
    """
    return ValueError(f"{path.name}: {message}")


class CorruptedFileError(ValueError):
    """A file or store xrough wrote whose contents fail their checksums (a corrupted file).

    Raised when it is opened, or for a lazy open when a chunk is computed; the message
    starts with the file's name and names the group or variable. A ``ValueError``, as every
    other refusal of a damaged file.
    """


class MissingOptionError(ValueError):
    """A file that reads only with an option of :func:`xrough.open_topography` it lacks.

    The file does not state something a topography needs (a unit, a physical size) or is
    laid out so that an option must say what to do (a non-uniform profile and
    ``resample=``). The message names the file, what it lacks and the keywords to pass; the
    attributes let a front end name its own options instead (the command line says
    ``--unit``) without reading the message.

    Parameters
    ----------
    file : str
        The file's name.
    lacks : str
        What the file lacks, in words ("the file states no unit for the heights").
    options : tuple of str
        Keywords of :func:`xrough.open_topography` that supply it.
    either : bool
        Whether any one of ``options`` is enough (``unit=`` or ``height_unit=``), else all
        are needed.
    advice : str
        The rest of the message after the keywords (an example, what is not guessed).

    Examples
    --------
    >>> err = MissingOptionError("h.npy", "a .npy file stores no units", ("unit",),
    ...                          advice=" (e.g. unit='nm')")
    >>> str(err), err.options
    ("h.npy: a .npy file stores no units: pass unit= (e.g. unit='nm')", ('unit',))
    >>> isinstance(err, ValueError)
    True
    """

    def __init__(self, file: str, lacks: str, options: tuple[str, ...], *,
                 either: bool = False, advice: str = "") -> None:
        self.file, self.lacks, self.options, self.either = file, lacks, tuple(options), either
        keywords = (" or " if either else " and ").join(f"{o}=" for o in self.options)
        super().__init__(f"{file}: {lacks}: pass {keywords}{advice}")


def check_file(path: Path) -> None:
    """Raise ``FileNotFoundError`` or ``IsADirectoryError`` unless ``path`` is a file.

    Examples
    --------
    >>> check_file(Path("no-such-file.x3p"))
    Traceback (most recent call last):
    ...
    FileNotFoundError: no such file: no-such-file.x3p
    """
    if path.is_dir():
        raise IsADirectoryError(f"{path.name}: is a directory, not a file")
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")


def check_points(path: Path, n: int, max_points: int | None, what: str) -> None:
    """Refuse a header that declares more than ``max_points`` points.

    Parameters
    ----------
    path : Path
        The file, named in the message.
    n : int
        The number of points the header declares.
    max_points : int or None
        The limit (``None``: :data:`MAX_POINTS`).
    what : str
        What declares them, for the message.

    Raises
    ------
    ValueError
        ``n > max_points``.

    Examples
    --------
    >>> check_points(Path("a.sur"), 10, 100, "the header")
    >>> check_points(Path("a.sur"), 60000 * 60000, None, "the header")
    Traceback (most recent call last):
    ...
    ValueError: a.sur: the header declares 3600000000 points, more than ...
    """
    limit = MAX_POINTS if max_points is None else int(max_points)
    if n > limit:
        raise ValueError(f"{path.name}: {what} declares {n} points, more than the limit of "
                         f"{limit} (a corrupted header? pass max_points= to read a larger "
                         "file)")


def invalid_as_missing(path: Path, values: np.ndarray, attrs: dict, *,
                       marker: str) -> np.ndarray:
    """Heights with every invalid point as NaN, the count in ``attrs["invalid_points"]``.

    Infinite values are what some instruments store for the points they could not
    measure (Alicona's X3P files: ``+inf``; ISO 5436-2 allows invalid points); they become
    NaN and an :class:`InvalidPointsWarning` says how many, once per file. The points the
    format itself marks (a validity mask, a sentinel value: ``marker``), already NaN in
    ``values``, are counted with them.

    Parameters
    ----------
    path : Path
        The file, named in the warning.
    values : numpy.ndarray
        The heights, NaN where the format marks a point invalid.
    attrs : dict
        The attributes of the topography to be; ``invalid_points`` (the number of NaN
        heights after the conversion) and ``invalid_marker`` are set when there are any.
    marker : str
        How the format marks invalid points, in words (``"the validity mask"``).

    Returns
    -------
    numpy.ndarray
        ``values`` (a copy where infinite values were replaced).

    Examples
    --------
    >>> attrs = {}
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     h = invalid_as_missing(Path("a.x3p"), np.array([1.0, np.inf, np.nan]), attrs,
    ...                            marker="the validity mask")
    >>> h.tolist(), attrs["invalid_points"], str(caught[0].message)[:40]
    ([1.0, nan, nan], 2, 'a.x3p: 1 of 3 points stored as +inf (inv')
    """
    if values.dtype.kind != "f":
        return values
    infinite = np.isinf(values)
    n_inf = int(np.count_nonzero(infinite))
    if n_inf:
        signs = sorted({"+inf" if v > 0 else "-inf" for v in values[infinite][:1000]})
        values = np.where(infinite, np.nan, values)
        quality.warn(f"{path.name}: {n_inf} of {values.size} points stored as "
                     f"{' and '.join(signs)} (invalid points, not measured): read as "
                     "missing (NaN); attrs['invalid_points'] counts every missing point",
                     InvalidPointsWarning)
        marker = f"{marker} and {' and '.join(signs)}" if marker else " and ".join(signs)
    n = int(np.count_nonzero(np.isnan(values)))
    if n:
        attrs["invalid_points"] = n
        attrs["invalid_marker"] = marker
    return values


#: Readers of scanning-probe files (native names, SurfaceTopography's reader classes): their
#: scans are at most :data:`MAX_PROBE_SCAN` across.
PROBE_READERS = frozenset({
    "nanoscope", "ibw", "DIReader", "IBWReader", "MIReader", "MDTReader", "PSReader",
    "EZDReader", "BCRReader", "JPKReader", "WSXMReader"})
#: Readers of data that no instrument bounds: xrough's own and numpy archives, elevation
#: tiles (SRTM, kilometres across); plugins are bounded as instruments.
UNBOUNDED_READERS = frozenset({"netcdf", "npy", "HGTReader", "NCReader", "NPYReader",
                               "NPZReader", "H5Reader", "MatReader"})
#: The widest scan of a scanning-probe microscope (large-range AFMs reach 100-200 um;
#: a nanomeasuring machine, 25 mm, is read as a profilometer).
MAX_PROBE_SCAN = 1e-3
#: The widest scan or longest profile of any other instrument (stylus profilometers
#: travel up to about 0.2 m).
MAX_SCAN = 1.0
#: The smallest lateral pixel of any instrument (an AFM scan of 10 nm over 512 points has
#: 20 pm; a TEM profile about 0.1 nm).
MIN_PIXEL = 1e-12


def check_lateral_size(path: Path, da: xr.DataArray, reader: str) -> None:
    """Refuse a scan size or pixel no instrument of its class measures, in its own numbers.

    A lateral unit or scale misread from the header (a pixel of 312.5 read in metres
    instead of nanometres: a 160 m AFM scan) gives heights that look right and a
    topography whose every length is wrong by the same factor.

    Parameters
    ----------
    path : Path
        The file, named in the message.
    da : xarray.DataArray
        The topography as read, before ``size=`` or ``unit=`` override it.
    reader : str
        The format's name (``"x3p"``) or, through the bridge, SurfaceTopography's reader
        class (``"NMSReader"``): :data:`PROBE_READERS` are bounded by
        :data:`MAX_PROBE_SCAN`, :data:`UNBOUNDED_READERS` not at all, others by
        :data:`MAX_SCAN`; every pixel is at least :data:`MIN_PIXEL`.

    Raises
    ------
    ValueError
        Naming the size or pixel the file states, the bound, and ``size=``/``unit=``.
    """
    if reader in UNBOUNDED_READERS:
        return
    probe = reader in PROBE_READERS
    widest, kind = (MAX_PROBE_SCAN, "a scanning-probe microscope") if probe else (
        MAX_SCAN, "an instrument")
    for dim in ("y", "x"):
        if dim not in da.dims or da.sizes[dim] < 2:
            continue
        coord = da[dim]
        unit = str(coord.attrs.get("units", ""))
        if not u.is_length(unit):
            continue  # topography() refuses it, with the file's name
        to_m = u.conversion_factor(unit, "m")
        values = np.asarray(coord.values, dtype=float)
        pixel = float(np.min(np.abs(np.diff(values))))
        extent = float(abs(values[-1] - values[0])) + pixel
        stated = (f"{da.sizes[dim]} points, {pixel:.6g} {unit} apart: {extent:.6g} {unit} "
                  f"along {dim}")
        advice = ("the header's lateral unit or scale is wrong (a pixel stated in m where "
                  "it is in nm or um?); pass size= (and unit=) to state the right one")
        if extent * to_m > widest:
            raise fail(path, f"the file states {stated}, wider than {kind} scans "
                             f"({widest:g} m): {advice}")
        if 0 < pixel * to_m < MIN_PIXEL:
            raise fail(path, f"the file states {stated}, a pixel below what any instrument "
                             f"resolves ({MIN_PIXEL:g} m): {advice}")


def check_height_scale(path: Path, heights: np.ndarray, extent: float, unit: str) -> None:
    """Refuse heights absurdly large for the lateral size: binary data read out of step.

    Parameters
    ----------
    path : Path
        The file, named in the message.
    heights : numpy.ndarray
        The heights (NaN for missing points).
    extent : float
        The largest lateral extent of the map or profile, in the unit of the heights.
    unit : str
        That unit, for the message.

    Raises
    ------
    ValueError
        A finite height larger in absolute value than :data:`MAX_HEIGHT_TO_SIZE` times
        ``extent``.

    Examples
    --------
    >>> check_height_scale(Path("a.al3d"), np.array([0.0763, 0.0764]), 8.7e-5, "m")
    >>> check_height_scale(Path("a.al3d"), np.array([0.0763, 2.5e38]), 8.7e-5, "m")
    Traceback (most recent call last):
    ...
    ValueError: a.al3d: a height of 2.5e+38 m on a scan 8.7e-05 m across: ...
    """
    if not (np.isfinite(extent) and extent > 0) or heights.size == 0:
        return
    finite = np.abs(heights[np.isfinite(heights)])
    largest = float(finite.max()) if finite.size else 0.0
    if largest > MAX_HEIGHT_TO_SIZE * extent:
        raise fail(path, f"a height of {largest:.3g} {unit} on a scan {extent:.3g} {unit} "
                         f"across: more than {MAX_HEIGHT_TO_SIZE:g} times the lateral size, "
                         "the values of a damaged file (data read out of step with its "
                         "header?)")


@contextlib.contextmanager
def reader_errors(path: Path, description: str):
    """Turn every error raised inside the block into a ``ValueError`` naming the file.

    ``FileNotFoundError`` and ``IsADirectoryError`` pass unchanged, a ``ValueError``
    that already starts with the file's name too; other errors of a reader choking on a
    corrupted file (``zlib.error``, ``struct.error``, ``UnicodeDecodeError``, XML errors,
    ``ZeroDivisionError``, ``OverflowError``, ``MemoryError``...) are re-raised as
    ``ValueError("<file>: cannot read as <description>: <what is wrong>")``.

    Parameters
    ----------
    path : Path
        The file.
    description : str
        The format, for the message.

    Examples
    --------
    >>> with reader_errors(Path("scan.sur"), "Digital Surf SUR"):
    ...     1 / 0
    Traceback (most recent call last):
    ...
    ValueError: scan.sur: cannot read as Digital Surf SUR: a zero size or spacing ...
    """
    prefix = f"{path.name}:"
    try:
        yield
    except (FileNotFoundError, IsADirectoryError):
        raise
    except Exception as err:  # noqa: BLE001 - a corrupted file fails in many ways
        if isinstance(err, ValueError) and not isinstance(err, UnicodeError):
            if str(err).startswith(prefix):
                raise
            raise ValueError(f"{prefix} {err}") from err
        words = next((w for kind, w in _ERROR_WORDS if isinstance(err, kind)),
                     "a corrupted file")
        raise ValueError(f"{prefix} cannot read as {description}: {words} "
                         f"({type(err).__name__}: {err})") from err


#: How the micro sign reaches a reader, longest first: UTF-8 bytes of the micro sign
#: (U+00B5) or of the Greek mu (U+03BC) decoded as Latin-1 (``Âµ``, ``Î¼``), then the two
#: characters themselves.
_MICRO_SPELLINGS = ("\xc2\xb5", "\xce\xbc", "\xb5", "\u03bc")


def micro_as_u(text: str) -> str:
    r"""Spell the micro prefix of a unit ``u``, as CF/UDUNITS does.

    The micro sign (U+00B5), the Greek mu (U+03BC) and their UTF-8 bytes read as Latin-1
    (``Âµ``, ``Î¼``) all become ``u``; format-specific spellings (Nanoscope's ``~``, a
    DOS code page's ``æ``) are left to their readers.

    Examples
    --------
    >>> [micro_as_u(s) for s in ("\xb5m", "\u03bcm", "\xc2\xb5m", "\xce\xbcm", "um", "nm")]
    ['um', 'um', 'um', 'um', 'um', 'nm']
    """
    for spelling in _MICRO_SPELLINGS:
        text = text.replace(spelling, "u")
    return text


def describe_channel(channel: dict) -> str:
    """One channel as text for listings: ``index: 'name' (scan, unit)``.

    ``scan`` (such as ``Main Retrace``) is optional; a channel without a ``unit`` says
    ``no unit``.

    Examples
    --------
    >>> describe_channel({"index": 3, "name": "Topo", "unit": "m"})
    "3: 'Topo' (m)"
    >>> describe_channel({"index": 0, "name": "Phase", "unit": "", "scan": "Main Trace"})
    "0: 'Phase' (Main Trace, no unit)"
    """
    details = [d for d in (channel.get("scan"), channel.get("unit") or "no unit") if d]
    return f"{channel['index']}: {channel['name']!r} ({', '.join(details)})"


def channel_listing(channels: list[dict]) -> str:
    """List the channels for an error message: :func:`describe_channel` of each, ``"; "``.

    Examples
    --------
    >>> channel_listing([{"index": 0, "name": "Height", "unit": "nm"},
    ...                  {"index": 1, "name": "Phase", "unit": "deg"}])
    "0: 'Height' (nm); 1: 'Phase' (deg)"
    >>> channel_listing([])
    'none'
    """
    return "; ".join(describe_channel(c) for c in channels) or "none"


#: A reader's choice of the channel read without ``channel=``:
#: ``default(path, channels, listing, warn=...)`` returns one of ``channels`` or raises
#: (naming the file and the ``listing``); ``warn`` says whether an ambiguous choice warns.
DefaultChannel = Callable[..., dict]


class InvalidPointsWarning(UserWarning):
    """Points stored as infinite (not measured) were read as missing (NaN)."""


class ChannelChoiceWarning(UserWarning):
    """A file holds several quantities in a length unit and the reader took one of them.

    The message names the channel read and the others; ``channel=`` chooses
    (:func:`xrough.io.list_channels` lists them).
    """


#: Words of a channel's name that say it holds heights (``Height``, ``Topography``,
#: ``ZSensor``, ``Z-Axis``).
HEIGHT_WORDS = frozenset({"height", "heights", "topography", "topo", "z", "zsensor"})
#: Words that say it holds another signal, even in a length unit (a cantilever's
#: deflection or amplitude in metres): never a default height when a height is there.
SIGNAL_WORDS = frozenset({
    "deflection", "amplitude", "phase", "error", "friction", "lateral", "current",
    "force", "adhesion", "stiffness", "modulus", "dissipation", "deformation", "potential",
    "frequency", "voltage", "input", "aux", "lfm", "kpfm", "magnitude", "peak", "tip"})
#: Words of the scan direction: trace and retrace of one quantity are one quantity.
DIRECTION_WORDS = frozenset({"trace", "retrace", "forward", "backward", "fwd", "bwd",
                             "scan", "left", "right", "up", "down"})


def channel_words(name: str) -> list[str]:
    """Split a channel's name into lower-case words.

    ``"Scan forward (Z-AxisSensor)"``: scan, forward, z, axis, sensor; ``"HeightRetrace"``:
    height, retrace.
    """
    return [w.lower() for w in re.findall(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+", name)]


def channel_rank(name: str) -> int:
    """Rank a channel by what its name says it holds: 0 heights, 1 nothing, 2 a signal.

    Examples
    --------
    >>> [channel_rank(n) for n in ("Height", "Scan forward (Deflection)", "layer0",
    ...                            "Z-AxisSensor", "AmplitudeTrace", "Topography")]
    [0, 2, 1, 0, 2, 0]
    """
    words = set(channel_words(name))
    if words & SIGNAL_WORDS:
        return 2
    return 0 if words & HEIGHT_WORDS else 1


def choose_height_channel(path: Path, heights: list[dict], *, warn: bool,
                          key: Callable[[dict], Any] | None = None) -> dict:
    """Pick the default height among the channels in a length unit, by what they hold.

    The channels whose names say heights come first, then those that say nothing, then
    other signals (:func:`channel_rank`); among equals ``key`` (the reader's own order,
    default the file's). Quantities are names without their scan direction
    (``HeightTrace`` and ``HeightRetrace`` are one). The choice is a guess, said by a
    :class:`ChannelChoiceWarning` that names the channel read, where two quantities rank
    alike (``Height`` and ``ZSensor``) or where the one read is not named a height beside
    others; a height named beside other signals in metres (``Amplitude``) is not.

    Parameters
    ----------
    path : Path
        The file, named in the warning.
    heights : list of dict
        The channels in a length unit, each with a ``name`` and an ``index``; not empty.
    warn : bool
        Whether to warn when the choice is ambiguous.
    key : callable, optional
        Order among channels of the same rank.

    Returns
    -------
    dict
        The channel read.
    """
    order = {id(c): i for i, c in enumerate(heights)}
    chosen = min(heights, key=lambda c: (channel_rank(c["name"]),
                                         key(c) if key else 0, order[id(c)]))
    best = channel_rank(chosen["name"])
    quantities: dict[tuple, list[dict]] = {}
    for c in heights:
        words = tuple(w for w in channel_words(c["name"]) if w not in DIRECTION_WORDS)
        quantities.setdefault(words, []).append(c)
    # a choice by name is certain where one quantity is named a height and the others
    # other signals (Height beside Amplitude in metres); it is a guess where two
    # quantities rank alike (Height and ZSensor) or where no name says height
    rivals = [q[0] for q in quantities.values()
              if any(channel_rank(c["name"]) == best for c in q)]
    if warn and len(quantities) > 1 and (len(rivals) > 1 or best > 0):
        names = ", ".join(repr(q[0]["name"]) for q in quantities.values())
        quality.warn(f"{path.name}: several quantities in a length unit ({names}); reading "
                     f"channel {chosen['index']}: {chosen['name']!r}. Pass channel= to "
                     "choose (xrough.io.list_channels lists them)", ChannelChoiceWarning)
    return chosen


#: What a reader itself says while reading, apart from what a third-party parser says
#: (which the bridge keeps in attrs).
READER_WARNINGS = (InvalidPointsWarning, ChannelChoiceWarning)


def select_channel(path: Path, channels: list[dict], channel, *, default: DefaultChannel,
                   by_id: bool = False) -> dict:
    """Pick a channel by name (case-insensitive), position or id in ``channels``.

    Parameters
    ----------
    path : Path
        The file, named in error messages.
    channels : list of dict
        The file's channels, each with a ``name``, an ``index`` and a ``unit``.
    channel : str, int or None
        The user's choice; ``None`` returns ``default(path, channels, listing, warn=True)``.
    default : callable
        The reader's default choice (:data:`DefaultChannel`).
    by_id : bool
        Whether an int is a channel's ``index`` (an id the file gives it, such as
        Gwyddion's ``N`` of ``/N/data``) rather than its position in ``channels``.

    Raises
    ------
    ValueError
        An index out of range, an unknown id or name, or ``channel`` neither a name nor an
        index; the message lists the channels (:func:`channel_listing`).

    Examples
    --------
    >>> chans = [{"index": 0, "name": "Height"}, {"index": 1, "name": "Phase"}]
    >>> select_channel(Path("a.spm"), chans, "phase", default=None)["name"]
    'Phase'
    >>> select_channel(Path("a.spm"), chans, -2, default=None)["name"]
    'Height'
    >>> select_channel(Path("a.spm"), chans, "Deflection", default=None)
    Traceback (most recent call last):
    ...
    ValueError: a.spm: no channel named 'Deflection'; channels: 0: 'Height' (no unit); ...
    """
    listing = channel_listing(channels)
    if channel is None:
        return default(path, channels, listing, warn=True)
    if isinstance(channel, (int, np.integer)) and not isinstance(channel, bool):
        return _channel_at(path, channels, int(channel), listing, by_id)
    if isinstance(channel, str):
        for c in channels:
            if c["name"].lower() == channel.strip().lower():
                return c
        raise fail(path, f"no channel named {channel!r}; channels: {listing}")
    raise fail(path, f"channel must be a name (str) or an index (int), got {channel!r}; "
                     f"channels: {listing}")


def _channel_at(path: Path, channels: list[dict], channel: int, listing: str,
                by_id: bool) -> dict:
    if by_id:
        found = next((c for c in channels if c["index"] == channel), None)
        if found is None:
            raise fail(path, f"no channel with id {channel}; channels: {listing}")
        return found
    if not -len(channels) <= channel < len(channels):
        raise fail(path, f"channel index {channel} out of range; channels: {listing}")
    return channels[channel]


def default_channel_reader(channels_of: Callable[[Path], list[dict]],
                           default: DefaultChannel, module: str) -> Callable:
    """Make a reader's public ``default_channel(path)`` from its channels and its choice.

    Parameters
    ----------
    channels_of : callable
        ``channels_of(path)``: the file's channels (as :func:`select_channel` takes them).
    default : callable
        The reader's default choice (:data:`DefaultChannel`); it is asked not to warn.
    module : str
        The reader's module (``__name__``), where the function is documented.

    Examples
    --------
    >>> last = lambda path, chans, listing, warn: chans[-1]
    >>> chans = [{"index": 0, "name": "A"}, {"index": 4, "name": "B"}]
    >>> pick = default_channel_reader(lambda path: chans, last, "m")
    >>> pick("a.ibw")
    4
    """
    def default_channel(path: str | Path) -> int:
        """Index of the channel :func:`read` reads without ``channel=``.

        Parameters
        ----------
        path : str or Path

        Returns
        -------
        int
        """
        path = Path(path)
        channels = channels_of(path)
        return int(default(path, channels, channel_listing(channels), warn=False)["index"])

    default_channel.__module__ = module
    return default_channel


def nonuniform_profile(name: str, x: np.ndarray, h: np.ndarray, lunit: str, hunit: str,
                       attrs: dict, resample: bool, size=None, spacing=None) -> xr.DataArray:
    """Build a profile measured at increasing positions ``x`` that are not uniform.

    Returned on its measured ``x`` with ``attrs["sampling"] = "non-uniform"``, or with
    ``resample=True`` interpolated linearly onto as many uniform points over the same range
    (``attrs["sampling"] = "resampled"``, ``attrs["resampling"]`` says how). ``size`` or
    ``spacing`` relabel a resampled profile's lateral scale; they cannot replace measured
    positions.

    Parameters
    ----------
    name : str
        The file's name, for error messages.
    x, h : numpy.ndarray
        Positions (in ``lunit``, increasing) and heights (in ``hunit``).
    lunit, hunit : str
        Lateral and height units.
    attrs : dict
        Attributes of the result (the file's metadata).
    resample : bool
        Interpolate onto a uniform grid.
    size, spacing : optional
        As for :func:`xrough.topography`, with ``resample=True`` only.

    Examples
    --------
    >>> p = nonuniform_profile("p.txt", np.array([0.0, 1.0, 3.0]), np.zeros(3), "um", "nm",
    ...                        {}, resample=False)
    >>> p.attrs["sampling"], p.x.values.tolist(), p.x.attrs["units"]
    ('non-uniform', [0.0, 1.0, 3.0], 'um')
    >>> nonuniform_profile("p.txt", np.array([0.0, 1.0, 3.0]), np.zeros(3), "um", "nm",
    ...                    {}, resample=True).x.values.tolist()
    [0.0, 1.5, 3.0]
    """
    if resample:
        return _resampled(x, h, lunit, hunit, attrs, size, spacing)
    if size is not None or spacing is not None:
        raise MissingOptionError(
            name, "the profile is sampled non-uniformly; size=/spacing= cannot replace its "
            "measured positions", ("resample",),
            advice="True to interpolate it onto a uniform grid first")
    return xr.DataArray(
        h, dims=("x",), name="height",
        coords={"x": ("x", x, {"units": u.format_units(lunit), "long_name": "x position"})},
        attrs={"units": u.format_units(hunit), "long_name": "height", "periodic": 0,
               **attrs, "sampling": "non-uniform"},
    )


def _resampled(x, h, lunit, hunit, attrs, size, spacing) -> xr.DataArray:
    """Linear interpolation of a non-uniform profile onto as many uniform points."""
    xu = np.linspace(x[0], x[-1], x.size)
    dx = (x[-1] - x[0]) / (x.size - 1)
    attrs = dict(attrs, sampling="resampled",
                 resampling=(f"linear interpolation of {x.size} non-uniformly sampled "
                             f"points onto {x.size} uniform points over "
                             f"[{x[0]:.10g}, {x[-1]:.10g}] {lunit}"),
                 x_offset=float(x[0]))
    topo = topography(np.interp(xu, x, h), spacing=dx, unit=lunit, height_unit=hunit,
                      attrs=attrs)
    if size is not None or spacing is not None:
        topo = topography(topo.drop_vars("x"), size=size, spacing=spacing, unit=lunit,
                          height_unit=hunit)
    return topo
