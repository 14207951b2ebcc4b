"""Read and write topographies: instrument formats, detection by content, overrides.

Each format lives in its own module ``xrough.io.<name>`` with

- ``sniff(head: bytes, path: pathlib.Path) -> bool``: does this file look like the format
  (by content; the extension only as a last hint);
- ``read(path, **options) -> xarray.DataArray``: a validated topography
  (:func:`xrough.topography`) with heights and sizes as the file states them, units on data
  and coordinates, and the file's metadata in attrs (netCDF-legal values only);
- optionally ``write(topography, path)``.

:func:`open_topography` detects the format, reads, applies the user's overrides (size,
unit, height scale, periodicity) and records provenance (file name, SHA-256).
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import inspect
from dataclasses import dataclass
from pathlib import Path

from .. import units as u
from ..topography import topography

__all__ = ["FORMATS", "BRIDGE", "detect_format", "open_topography", "file_sha256"]


@dataclass(frozen=True)
class Format:
    """A file format: the module implementing it and its usual extensions."""

    module: str
    extensions: tuple[str, ...]
    description: str


#: Known formats, in the order their ``sniff`` functions are tried.
FORMATS: dict[str, Format] = {
    "x3p": Format("xrough.io.x3p", (".x3p",), "ISO 25178-72 XML 3D surface profile"),
    "sur": Format("xrough.io.sur", (".sur",), "Digital Surf SUR"),
    "sdf": Format("xrough.io.sdf", (".sdf",), "ISO 25178-71 surface data file"),
    "nanoscope": Format("xrough.io.nanoscope", (".di", ".spm", ".001", ".002", ".003"),
                        "Digital Instruments / Bruker Nanoscope AFM"),
    "gwy": Format("xrough.io.gwy", (".gwy",), "Gwyddion native"),
    "ibw": Format("xrough.io.ibw", (".ibw",), "Igor binary wave (Asylum AFM)"),
    "netcdf": Format("xrough.io.netcdf", (".nc", ".nc4", ".netcdf"), "NetCDF"),
    "npy": Format("xrough.io.npy", (".npy",), "NumPy array"),
    "text": Format("xrough.io.text", (".txt", ".asc", ".csv", ".dat", ".xyz"),
                   "plain text: matrix, x-y profile, x-y-z points, CSV with header"),
}


#: Name of the fallback format: any file SurfaceTopography reads (optional dependency,
#: ``pip install xrough[formats]``), tried when no native format recognises the file.
BRIDGE = "surfacetopography"
_BRIDGE_MODULE = "xrough.io.bridge"
_BRIDGE_DESCRIPTION = "a format read by SurfaceTopography"


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes (hex)."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _module(name: str):
    if name == BRIDGE:
        return importlib.import_module(_BRIDGE_MODULE)
    return importlib.import_module(FORMATS[name].module)


def _has_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(FORMATS[name].module) is not None
    except (ImportError, ValueError):
        return False


def _bridge_reads(head: bytes, path: Path) -> bool:
    try:
        bridge = _module(BRIDGE)
    except ImportError:
        return False
    return bridge.available() and bridge.sniff(head, path)


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
    When no native format recognises the file, by content or by extension, and
    SurfaceTopography is installed, returns :data:`BRIDGE` if SurfaceTopography reads it.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    with open(path, "rb") as fh:
        head = fh.read(4096)
    if not head:
        raise ValueError(f"{path.name}: the file is empty")
    by_extension = [n for n, f in FORMATS.items()
                    if path.suffix.lower() in f.extensions and _has_module(n)]
    for name in list(FORMATS):
        try:
            if _module(name).sniff(head, path):
                return name
        except ImportError:  # optional reader dependency missing
            continue
    if by_extension:
        return by_extension[0]
    if _bridge_reads(head, path):
        return BRIDGE
    raise ValueError(f"{path.name}: unknown file format (known: {', '.join(FORMATS)})")


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
        One of :data:`FORMATS` or :data:`BRIDGE` (default: detected from the content).
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
        ``source_sha256``, ``format`` and the overrides applied.

    Raises
    ------
    FileNotFoundError, ValueError
        Missing, unknown or corrupted file (the message names the file and the problem).
    """
    path = Path(path)
    name = format or detect_format(path)
    if name not in FORMATS and name != BRIDGE:
        raise ValueError(f"unknown format {name!r}; known: {', '.join(FORMATS)}, {BRIDGE}")
    description = FORMATS[name].description if name in FORMATS else _BRIDGE_DESCRIPTION
    try:
        read = _module(name).read
        # readers of files that may lack sizes or units (text, npy...) take them directly
        accepted = _keyword_parameters(read)
        for key, value in (("size", size), ("unit", unit), ("height_unit", height_unit)):
            if value is not None and key in accepted:
                options.setdefault(key, value)
        da = read(path, **options)
    except (ValueError, FileNotFoundError):
        raise
    except ImportError as err:  # optional reader dependency (e.g. SurfaceTopography)
        raise ValueError(f"{path.name}: cannot read as {description}: {err}") from err
    except Exception as err:  # a reader choking on a corrupted file
        raise ValueError(f"{path.name}: cannot read as {description} "
                         f"({type(err).__name__}: {err})") from err
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
        attrs = dict(da.attrs)
        da = da * float(height_scale)
        da.attrs = attrs
        applied.append(f"height_scale={float(height_scale)!r}")
    if size is not None:
        dims = tuple(d for d in ("y", "x") if d in da.dims)
        da = topography(da.drop_vars(list(dims)), size=size,
                        unit=unit or da["x"].attrs["units"], height_unit=da.attrs["units"])
        applied.append(f"size={size!r}")
    if periodic is not None:
        da = da.assign_attrs(periodic=int(bool(periodic)))
        applied.append(f"periodic={bool(periodic)}")
    da.attrs.update(source_file=path.name, source_sha256=file_sha256(path), format=name,
                    overrides="; ".join(applied) if applied else "none")
    da.attrs.setdefault("source", path.name)
    if da.attrs.get("sampling") == "non-uniform":  # kept as measured, on request only
        return da
    return topography(da)


def _keyword_parameters(func) -> set[str]:
    """Names of the keyword parameters ``func`` declares explicitly (not via ``**``)."""
    try:
        params = inspect.signature(func).parameters.values()
    except (TypeError, ValueError):
        return set()
    return {p.name for p in params
            if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)}
