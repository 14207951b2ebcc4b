"""The readers of topography files: what a reader is, the built-in ones and plugins.

A reader is any object (usually a module) with

- ``sniff(head: bytes, path: pathlib.Path) -> bool``: does the file look like the format
  (``head``: its first 4096 bytes; by content, the extension only as a last hint);
- ``read(path: pathlib.Path, **options) -> xarray.DataArray``: the topography with heights
  and sizes as the file states them, units on data and coordinates, the file's metadata
  in attrs (netCDF-legal values); the keywords it declares are the options
  :func:`xrough.open_topography` passes on (``channel=``, ``size=``, ``unit=``...);

and optionally ``EXTENSIONS`` (a tuple such as ``(".foo",)``: a folder is searched for
them, and a file no reader recognises by content is tried by them), ``DESCRIPTION`` (one
line), ``FALLBACK = True`` (tried only after every other reader and the extensions: a
bridge to another library), ``available() -> bool`` (its own dependency is installed),
``channels(path)`` and ``default_channel(path)`` (files of several channels) and
``write(topography, path)``.

xrough's own readers are the modules of :data:`FORMATS`. Other packages add readers
through the entry-point group ``xrough.readers``: in their ``pyproject.toml``::

    [project.entry-points."xrough.readers"]
    myformat = "mypackage.xrough_reader"        # a module, or "module:object"

and ``open_topography`` then reads their files, ``format="myformat"`` names them. The
bridge to SurfaceTopography's readers is such a plugin, registered by xrough itself.
"""

from __future__ import annotations

import functools
import importlib
import importlib.metadata
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

__all__ = ["Reader", "Format", "FORMATS", "GROUP", "BRIDGE", "CATCH_ALL", "registered",
           "reader_of", "available"]

#: The entry-point group of readers from other packages.
GROUP = "xrough.readers"

#: Name of the fallback reader of any file SurfaceTopography reads (optional dependency,
#: ``pip install xrough[formats]``), registered in :data:`GROUP` by xrough itself.
BRIDGE = "surfacetopography"


@runtime_checkable
class Reader(Protocol):
    """What :func:`xrough.open_topography` needs of a reader (see the module's docs)."""

    def sniff(self, head: bytes, path: Path) -> bool:
        """Say whether the file looks like this format."""

    def read(self, path: Path, **options: Any) -> Any:
        """Read the file into a topography (an ``xarray.DataArray``)."""


@dataclass(frozen=True)
class Format:
    """A file format: where its reader is and what it says of itself.

    ``module``: the import path of the reader (``"package.module"`` or
    ``"package.module:object"``); ``fallback``: tried after every other reader.
    """

    module: str
    extensions: tuple[str, ...]
    description: str
    fallback: bool = False


#: xrough's own formats, in the order their ``sniff`` functions are tried.
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
    "text": Format("xrough.io.text", (".txt", ".asc", ".csv", ".dat", ".xyz", ".hfm"),
                   "plain text: matrix, x-y profile, x-y-z points, CSV with header"),
}


def _load(value: str) -> Any:
    """Import ``"module"`` or ``"module:object"``."""
    module, _, attr = value.partition(":")
    obj = importlib.import_module(module)
    for part in filter(None, attr.split(".")):
        obj = getattr(obj, part)
    return obj


@functools.cache
def _plugins() -> dict[str, Format]:
    """Return the readers of :data:`GROUP` by name (built-in names and broken ones left out).

    Each is imported here, once per process: its ``EXTENSIONS``, ``DESCRIPTION`` and
    ``FALLBACK`` are read from it. A plugin that does not import, is no :class:`Reader`
    or takes a built-in's name is left out with a warning naming it and its distribution.
    """
    found: dict[str, Format] = {}
    for ep in sorted(importlib.metadata.entry_points(group=GROUP), key=lambda e: e.name):
        dist = getattr(ep.dist, "name", "?")
        where = f"reader {ep.name!r} ({ep.value}, distribution {dist!r}, entry point " \
                f"group {GROUP!r})"
        if ep.name in FORMATS or ep.name in found:
            warnings.warn(f"{where}: the name is taken by another reader; left out",
                          stacklevel=3)
            continue
        try:
            obj = _load(ep.value)
        except Exception as err:  # noqa: BLE001 - a third party's import error of any kind
            warnings.warn(f"{where}: cannot be imported ({type(err).__name__}: {err}); "
                          "left out", stacklevel=3)
            continue
        if not isinstance(obj, Reader):
            warnings.warn(f"{where}: has no sniff(head, path) and read(path, **options); "
                          "left out", stacklevel=3)
            continue
        extensions = tuple(str(e).lower() for e in getattr(obj, "EXTENSIONS", ()))
        found[ep.name] = Format(ep.value, extensions,
                                str(getattr(obj, "DESCRIPTION", f"{ep.name} ({dist})")),
                                bool(getattr(obj, "FALLBACK", False)))
    return found


#: The built-in reader that takes any file of numbers: tried after the plugins' readers,
#: whose formats may be text too.
CATCH_ALL = "text"


def registered() -> dict[str, Format]:
    """Return every reader by name: xrough's own, plugins, plain text, the fallbacks last.

    The order in which :func:`xrough.io.detect_format` tries them: a plugin's format is
    asked before plain text (:data:`CATCH_ALL`, which reads any file of numbers), and a
    fallback (SurfaceTopography's bridge) only after every other reader and extension.

    Examples
    --------
    >>> names = list(registered())
    >>> names[:2], "text" in names
    (['x3p', 'sur'], True)
    """
    plugins = _plugins()
    return {**{n: f for n, f in FORMATS.items() if n != CATCH_ALL},
            **{n: f for n, f in plugins.items() if not f.fallback},
            CATCH_ALL: FORMATS[CATCH_ALL],
            **{n: f for n, f in plugins.items() if f.fallback}}


def reader_of(name: str) -> Any:
    """Return the reader of the format ``name`` (imported on first use).

    Raises
    ------
    ValueError
        ``name`` is no registered format (the message lists them).
    ImportError
        Its module does not import (an optional dependency missing).
    """
    formats = registered()
    if name not in formats:
        raise ValueError(f"unknown format {name!r}; known: {', '.join(formats)}")
    return _load(formats[name].module)


def available(name: str) -> bool:
    """Whether the reader ``name`` imports and says its dependencies are installed."""
    try:
        reader = reader_of(name)
    except (ImportError, ValueError):
        return False
    check = getattr(reader, "available", None)
    return bool(check()) if callable(check) else True
