"""Folders of measurements: which files are measurements, and a name for each.

One definition for the command line (a folder given as a file) and for
:func:`xrough.open_set`: the files of a folder whose extension is a reader's, or the files
a contact.engineering container (``meta.yml``) lists; names that are the files' stems,
unique and legal as NetCDF groups and DataTree nodes.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from . import FORMATS, detect_format
from .archive import safe_name
from .container import META, container_entries
from .readers import registered

__all__ = ["EXTENSIONS", "measurement_files", "measurement_names"]

#: The file extensions of xrough's own readers (a folder is searched for these and those of
#: the readers of plugins, :func:`xrough.io.readers.registered`).
EXTENSIONS = frozenset(ext for f in FORMATS.values() for ext in f.extensions)


def measurement_files(folder: str | Path) -> list[Path]:
    """Return the measurement files of ``folder``, sorted.

    With a ``meta.yml`` of contact.engineering, the files it lists (that exist), in its
    order; else the files (not subfolders) whose extension is a reader's
    (:data:`EXTENSIONS`) or that SurfaceTopography reads when it is installed (the
    bridge: ``.al3d``, ``.opd``, ``.nid``...), leaving out hidden files and archives
    xrough wrote (``xrough-*``).

    Raises
    ------
    ValueError
        ``folder`` is not a folder, or holds no measurement file.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> for name in ("b.x3p", "a.sur", "notes.md"):
    ...     _ = (d / name).write_text("")
    >>> [p.name for p in measurement_files(d)]
    ['a.sur', 'b.x3p']
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: not a folder")
    listed = [folder / e["file"] for e in container_entries(folder / META)]
    extensions = {ext for f in registered().values() for ext in f.extensions}
    found = [p for p in listed if p.is_file()] if listed else sorted(
        f for f in folder.iterdir()
        if f.is_file() and not f.name.startswith((".", "xrough-")) and f.name != META
        and (f.suffix.lower() in extensions or _by_a_fallback(f)))
    if not found:
        raise ValueError(f"{folder}: a folder with no measurement file (extensions "
                         f"{', '.join(sorted(extensions))}, or a {META} listing them)")
    return found


def _by_a_fallback(path: Path) -> bool:
    """Say whether a fallback reader (SurfaceTopography's bridge) reads the file."""
    try:
        return registered()[detect_format(path)].fallback
    except (OSError, ValueError):
        return False


def measurement_names(paths: Sequence[str | Path]) -> list[str]:
    """Return unique names, legal as NetCDF groups, for the measurements in ``paths``.

    The file stem; files with the same stem get their parent folder's name in front
    (``a_scan``, ``b_scan``); :func:`xrough.io.archive.safe_name` makes each name legal
    and distinct (and never the reserved ``_provenance``).

    Examples
    --------
    >>> measurement_names(["a/scan.x3p", "b/scan.x3p", "c/other.sur"])
    ['a_scan', 'b_scan', 'other']
    """
    stems = [Path(p).stem for p in paths]
    names: list[str] = []
    for p, stem in zip(paths, stems):
        parent = Path(p).resolve().parent.name
        wanted = f"{parent}_{stem}" if stems.count(stem) > 1 and parent else stem
        names.append(safe_name(wanted, names))
    return names
