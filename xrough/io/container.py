"""The metadata a contact.engineering container (``meta.yml``) states about one of its files.

A surface container of contact.engineering (and of SurfaceTopography's ``write_containers``)
is a folder (or zip) whose ``meta.yml`` lists its topographies with their file
(``datafile: original: <name>``), description, instrument, unit, size and the detrending
the uploader chose.  Opening one of those files, :func:`xrough.open_topography` keeps what
the container says about it as attrs named ``container_<key>``: descriptions often state
what no file header does (the tip radius of an AFM, the stylus of a profilometer), which
:func:`xrough.preprocess.stated_tip_radius` reads.  ``open_topography`` changes nothing
of the data by it (its ``unit``, ``size`` and ``height_scale`` are recorded, not applied);
:func:`xrough.toolbox.ensemble.open_measurement` (``open_set``, the command line) takes the unit
and size from it for a file that states none, and only then.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import yaml

#: The file name of a container's metadata.
META = "meta.yml"


class _Loader(yaml.SafeLoader):
    """Safe YAML with the one Python tag containers write: ``!!python/tuple`` (sizes)."""


def _sequence(loader: yaml.SafeLoader, node: yaml.SequenceNode) -> list:
    return loader.construct_sequence(node)


_Loader.add_constructor("tag:yaml.org,2002:python/tuple", _sequence)


def container_attrs(path: Path) -> dict:
    r"""Attrs ``container_<key>`` for ``path`` from the ``meta.yml`` beside it (``{}``: none).

    Scalars are kept as they are (strings, numbers; booleans as 0/1), lists as a
    space-joined string, nested entries (creator, datafile) left out; ``container_file`` is
    the metadata file's name.  A ``meta.yml`` that does not parse or does not list the file
    gives ``{}`` (an unreadable one with a warning: the data are read all the same).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "meta.yml").write_text(
    ...     "surfaces:\n- topographies:\n  - datafile: {original: scan.txt}\n"
    ...     "    description: 'Tip radius - 20 nm.'\n    size: !!python/tuple [1.0, 2.0]\n")
    >>> container_attrs(folder / "scan.txt")["container_description"]
    'Tip radius - 20 nm.'
    >>> container_attrs(folder / "scan.txt")["container_size"]
    '1.0 2.0'
    """
    for topo in container_entries(Path(path).parent / META, stacklevel=4):
        if topo["file"] == Path(path).name:
            out: dict[str, str | int | float] = {"container_file": META}
            for key, value in topo.items():
                if key == "file":
                    continue
                if isinstance(value, bool):
                    out[f"container_{key}"] = int(value)
                elif isinstance(value, (str, int, float)):
                    out[f"container_{key}"] = value
                elif isinstance(value, (list, tuple)) and all(
                        isinstance(v, (str, int, float)) for v in value):
                    out[f"container_{key}"] = " ".join(str(v) for v in value)
                elif value is not None and hasattr(value, "isoformat"):
                    out[f"container_{key}"] = value.isoformat()
            return out
    return {}


def container_entries(meta: Path, *, stacklevel: int = 2) -> list[dict]:
    """Return the topographies a ``meta.yml`` lists, each with its ``file`` name (``[]``: none).

    Each entry is the container's dict of the topography (description, unit, size,
    height_scale, ...) with ``file`` its data file's name (``datafile: original``); a
    file that is missing, does not parse (with a warning) or lists nothing gives ``[]``.
    """
    meta = Path(meta)
    if not meta.is_file():
        return []
    try:
        doc = yaml.load(meta.read_text(encoding="utf-8"), Loader=_Loader)  # noqa: S506
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        warnings.warn(f"{meta}: not read as a contact.engineering container ({err}); "
                      "its metadata are not attached", UserWarning, stacklevel=stacklevel)
        return []
    out = []
    for surface in (doc or {}).get("surfaces", []) or [] if isinstance(doc, dict) else []:
        for topo in (surface or {}).get("topographies", []) or []:
            name = ((topo or {}).get("datafile") or {}).get("original")
            if isinstance(name, str) and name:
                out.append({**topo, "file": name})
    return out
