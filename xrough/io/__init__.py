"""Read and write topographies: instrument formats, detection by content, overrides.

Each format has a reader (:class:`xrough.io.readers.Reader`): xrough's own are the modules
``xrough.io.<name>`` of :data:`FORMATS`; other packages register theirs in the entry-point
group ``xrough.readers`` (:mod:`xrough.io.readers`), as xrough registers its bridge to
SurfaceTopography (:data:`BRIDGE`).

:func:`open_topography` detects the format, reads, applies the user's overrides (size,
unit, height scale, periodicity) and records provenance (file name, SHA-256).
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import importlib.util
import inspect
import math
import os
import struct
from pathlib import Path

from .. import units as u
from .._kernels.checks import require_flag
from ..topography import topography
from ._common import (
    ChannelChoiceWarning,
    InvalidPointsWarning,
    MissingOptionError,
    check_lateral_size,
)
from .container import container_attrs
from .readers import BRIDGE, FORMATS, Format, Reader, available, reader_of, registered

__all__ = ["FORMATS", "BRIDGE", "Reader", "detect_format", "open_topography", "file_sha256",
           "list_channels", "registered", "MissingOptionError", "ChannelChoiceWarning",
           "InvalidPointsWarning"]


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes (hex)."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _has_module(name: str, formats: dict[str, Format]) -> bool:
    try:
        return importlib.util.find_spec(formats[name].module.partition(":")[0]) is not None
    except (ImportError, ValueError):
        return False


def detect_format(path: str | Path) -> str:
    """Name of the format of ``path``, decided by content (the extension may lie).

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ValueError
        If no format recognises the file (the message names the file).

    Notes
    -----
    Every native format's ``sniff`` is tried first (by content). When none recognises
    the file, the formats its extension names are considered, but only those its content
    does not contradict (a ``.dat`` holding binary data is not plain text, whatever its
    extension says). Last, when SurfaceTopography is installed, :data:`BRIDGE` if
    SurfaceTopography reads the file (Zygo MetroPro ``.dat``, Sensofar, Wyko...).
    """
    path = Path(path)
    if path.is_dir():
        hint = (" (a Zarr store? an xrough archive opens with xrough.open_analysis, "
                "other stores with xarray.open_zarr)") if path.suffix.lower() == ".zarr" else ""
        raise IsADirectoryError(f"{path.name}: is a directory, not a file{hint}")
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError as err:
        raise OSError(f"{path.name}: cannot read the file ({err.strerror or err})") from err
    if not head:
        raise ValueError(f"{path.name}: the file is empty")
    formats = registered()
    first = [n for n, f in formats.items() if not f.fallback]
    for name in first:
        try:
            if reader_of(name).sniff(head, path):
                return name
        except ImportError:  # optional reader dependency missing
            continue
    by_extension = [n for n in first if path.suffix.lower() in formats[n].extensions
                    and _has_module(n, formats) and _plausible(n, head)]
    if by_extension:
        return by_extension[0]
    for name in (n for n, f in formats.items() if f.fallback):
        if available(name) and reader_of(name).sniff(head, path):
            return name
    hint = ""
    if BRIDGE in formats and not available(BRIDGE):
        hint = ("; SurfaceTopography (pip install xrough[formats]) reads many more "
                "formats and is not installed")
    raise ValueError(f"{path.name}: unknown file format (known: {', '.join(first)}"
                     f"{hint})")


def _plausible(name: str, head: bytes) -> bool:
    """Whether the content does not rule out ``name`` (binary bytes rule out text)."""
    if name == "text":
        return not reader_of("text").looks_binary(head)
    return True


def list_channels(path: str | Path, *, format: str | None = None) -> list[dict]:
    """List the data channels of a file (for a listing such as ``xrough info``).

    Parameters
    ----------
    path : str or Path
        The file.
    format : str, optional
        A registered format (:func:`xrough.io.readers.registered`: :data:`FORMATS`,
        :data:`BRIDGE`, plugins; default: detected from the content).

    Returns
    -------
    list of dict
        One dict per channel with ``index``, ``name``, ``unit`` (of the values, ``""``
        if the file states none), ``is_height`` (the unit is a length), ``default``
        (whether :func:`open_topography` reads this channel without ``channel=``) and
        ``description``, one line of text naming all of these. Formats without
        channels (text, X3P, SDF, SUR, NetCDF, NumPy) give an empty list.

    Raises
    ------
    FileNotFoundError, ValueError
        Missing, unknown or corrupted file.

    Examples
    --------
    >>> for c in list_channels("scan.spm"):  # doctest: +SKIP
    ...     print(c["description"])
    0: Height [nm] height, Main Trace (default)
    1: ZSensor [nm] height, Main Trace
    2: Phase [deg]
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a file name (str or os.PathLike), got "
                        f"{type(path).__name__} {path!r}")
    path = Path(path)
    name = format or detect_format(path)
    module = reader_of(name)
    lister = getattr(module, "channels", None)
    if lister is None:
        return []
    try:
        found = lister(path)
        default = getattr(module, "default_channel", None)
        chosen = default(path) if default is not None and found else None
    except (ValueError, OSError):
        raise
    except Exception as err:  # a third-party parser choking on a corrupted file
        raise ValueError(f"{path.name}: cannot list the channels ({type(err).__name__}: "
                         f"{err})") from err
    if chosen is None and found:
        heights = [c for c in found if c.get("is_height")]
        chosen = (heights or found)[0]["index"] if heights else None
    out = []
    for c in found:
        unit = c.get("data_unit") if name == BRIDGE else c.get("unit")
        unit = "" if unit is None else str(unit)
        where = ", ".join(str(c[k]) for k in ("scan_line", "line_direction") if c.get(k))
        entry = {"index": int(c["index"]), "name": str(c["name"]), "unit": unit,
                 "is_height": bool(c.get("is_height")),
                 "default": c["index"] == chosen}
        text = f"{entry['index']}: {entry['name']} [{unit or 'no unit'}]"
        if entry["is_height"]:
            text += " height"
        if where:
            text += f", {where}"
        if entry["default"]:
            text += " (default)"
        entry["description"] = text
        out.append(entry)
    return out


def open_topography(
    path: str | Path,
    *,
    format: str | None = None,
    size=None,
    unit: str | None = None,
    height_unit: str | None = None,
    height_scale: float | None = None,
    periodic: bool | None = None,
    **options,
):
    """Read a topography from an instrument or data file.

    Parameters
    ----------
    path : str or Path
        The file.
    format : str, optional
        A registered format (:func:`xrough.io.readers.registered`: :data:`FORMATS`,
        :data:`BRIDGE`, plugins; default: detected from the content).
    size : float, str, Quantity or pair, optional
        Physical size ``(Ly, Lx)`` (or ``Lx`` of a profile) replacing the file's (which is
        often missing or wrong); numbers are in ``unit`` or the file's lateral unit.
    unit : str, optional
        Lateral unit replacing the file's, and the height unit too unless ``height_unit``
        is given. Relabels, does not convert (for files that state no or a wrong unit).
    height_unit : str, optional
        Height unit replacing the file's (relabels).
    height_scale : float, optional
        Factor applied to the heights (e.g. a calibration the file lacks).
    periodic : bool, optional
        Mark the map as periodic (files never say).
    **options
        Passed to the format's reader (e.g. ``channel=`` for multi-channel AFM files,
        ``resample=True`` for non-uniformly sampled profiles).

    Returns
    -------
    xarray.DataArray
        Topography with units, the file's metadata, and provenance attrs ``source_file``,
        ``source_sha256``, ``format`` and the overrides applied; what a contact.engineering
        container's ``meta.yml`` beside the file says about it, as ``container_<key>``
        (:func:`xrough.io.container.container_attrs`; e.g. a description that states the
        tip radius, which :func:`xrough.height_difference_acf` then uses).

    Raises
    ------
    FileNotFoundError, ValueError
        Missing, unknown or corrupted file (the message names the file and the problem).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a file name (str or os.PathLike), got "
                        f"{type(path).__name__} {path!r}")
    path = Path(path)
    name = format or detect_format(path)
    description = registered()[name].description if name in registered() else name
    with _reader_errors_in_words(path, description):
        read = reader_of(name).read
        stated = {"size": size, "unit": unit, "height_unit": height_unit}
        da = read(path, **_reader_options(path, name, read, options, stated))
    if size is None and unit is None:  # what the file states, unless the user states it
        check_lateral_size(path, da, str(da.attrs.get("reader", name)) if name == BRIDGE
                           else name)
    da, applied = _overrides(da, size=size, unit=unit, height_unit=height_unit,
                             height_scale=height_scale, periodic=periodic)
    for key, value in container_attrs(path).items():  # a contact.engineering container
        da.attrs.setdefault(key, value)
    da.attrs.update(source_file=path.name, source_sha256=file_sha256(path), format=name,
                    overrides="; ".join(applied) if applied else "none")
    da.attrs.setdefault("source", path.name)
    if da.attrs.get("sampling") == "non-uniform":  # kept as measured, on request only
        return da
    return topography(da)


def _reader_options(path: Path, name: str, read, options: dict, stated: dict) -> dict:
    """Check ``options`` against the reader's keywords; pass it what the user states.

    Readers of files that may lack sizes or units (text, npy...) take ``size``, ``unit``
    and ``height_unit`` directly.
    """
    accepted = _keyword_parameters(read)
    unknown = sorted(set(options) - accepted)
    if unknown and not _takes_any_keyword(read):
        raise ValueError(
            f"{path.name}: the {name} reader has no option "
            f"{', '.join(k + '=' for k in unknown)}"
            + (" (the format has no channels)" if "channel" in unknown else "")
            + f"; its options: {', '.join(sorted(accepted - {'path'})) or 'none'}")
    for key, value in stated.items():
        if value is not None and key in accepted:
            options.setdefault(key, value)
    return options


@contextlib.contextmanager
def _reader_errors_in_words(path: Path, description: str):
    """Re-raise what a reader raises as an error naming the file and saying what it means."""
    try:
        yield
    except UnicodeError as err:
        reason = getattr(err, "reason", err)  # a bare UnicodeError has no reason
        raise ValueError(f"{path.name}: the text cannot be decoded ({reason} at byte "
                         f"{getattr(err, 'start', '?')}); pass encoding= if the file is "
                         "text in another encoding") from err
    except ValueError as err:
        if str(err).startswith(path.name):
            raise
        # third-party parsers (dateutil, numpy, igor2...) raise ValueErrors of their own
        raise ValueError(f"{path.name}: cannot read as {description}: the file is "
                         f"corrupted or not in this format ({type(err).__name__}: "
                         f"{str(err)[:300]})") from err
    except (FileNotFoundError, Warning):  # a warning turned into an error: not the file's
        raise
    except MemoryError as err:
        raise ValueError(f"{path.name}: cannot read as {description}: the header declares "
                         "more data than fits in memory (corrupted file?)") from err
    except ImportError as err:  # optional reader dependency (e.g. SurfaceTopography)
        raise ValueError(f"{path.name}: cannot read as {description}: {err}") from err
    except (ArithmeticError, IndexError, KeyError, TypeError, struct.error, EOFError) \
            as err:  # a reader choking on a corrupted file
        raise ValueError(f"{path.name}: cannot read as {description}: the file is "
                         "corrupted or inconsistent (its header states impossible values: "
                         f"{type(err).__name__}: {str(err)[:300]})") from err
    except OSError as err:
        if path.name in str(err):
            raise
        raise OSError(f"{path.name}: cannot read the file ({err})") from err
    except Exception as err:  # noqa: BLE001 - anything else a third-party parser raises
        raise ValueError(f"{path.name}: cannot read as {description} "
                         f"({type(err).__name__}: {str(err)[:300]})") from err


def _overrides(da, *, size, unit, height_unit, height_scale, periodic):
    """Apply what the user states over the file: ``(topography, list of what changed)``."""
    applied = []
    if unit is not None or height_unit is not None:
        lat = unit or da["x"].attrs["units"]
        hu = height_unit or unit or da.attrs["units"]
        da = da.copy()
        da.attrs["units"] = u.format_units(u.as_length_unit(hu, what="height_unit"))
        for d in ("x", "y"):
            if d in da.coords:
                da.coords[d].attrs["units"] = u.format_units(u.as_length_unit(lat,
                                                                              what="unit"))
        applied.append(f"unit={lat!r}, height_unit={hu!r}")
    if height_scale is not None:
        try:
            scale = float(height_scale)
        except (TypeError, ValueError):
            scale = math.nan
        if isinstance(height_scale, (str, bool)) or not (math.isfinite(scale) and scale):
            raise ValueError(f"height_scale must be a finite nonzero factor, got "
                             f"{height_scale!r} (0 would erase every height)")
        attrs = dict(da.attrs)
        da = da * scale
        da.attrs = attrs
        applied.append(f"height_scale={scale!r}")
    if size is not None:
        dims = tuple(d for d in ("y", "x") if d in da.dims)
        da = topography(da.drop_vars(list(dims)), size=size,
                        unit=unit or da["x"].attrs["units"], height_unit=da.attrs["units"])
        applied.append(f"size={size!r}")
    if periodic is not None:
        periodic = require_flag(periodic, "periodic")
        da = da.assign_attrs(periodic=int(periodic))
        applied.append(f"periodic={periodic}")
    return da, applied


def _takes_any_keyword(func) -> bool:
    """Whether ``func`` accepts arbitrary keywords (``**kwargs``)."""
    try:
        params = inspect.signature(func).parameters.values()
    except (TypeError, ValueError):
        return True
    return any(p.kind is p.VAR_KEYWORD for p in params)


def _keyword_parameters(func) -> set[str]:
    """Names of the keyword parameters ``func`` declares explicitly (not via ``**``)."""
    try:
        params = inspect.signature(func).parameters.values()
    except (TypeError, ValueError):
        return set()
    return {p.name for p in params
            if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)}
