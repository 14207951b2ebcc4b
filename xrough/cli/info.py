"""``xrough info``: what is in topography files (size, units, channels, header)."""

from __future__ import annotations

import argparse
import warnings

import numpy as np
import xarray as xr

from .._version import __version__
from ..io import list_channels, registered
from ._common import EXIT_OK, CLIError, emit_json, fail, number, text, warn_lines
from ._files import add_file_options, open_file

#: Attributes shown without ``--all`` (provenance and instrument).
_INFO_KEYS = ("channel", "channel_index", "instrument", "instrument_manufacturer",
              "instrument_model", "date", "sampling", "detrend")
_PROVENANCE = ("source_file", "source_sha256", "format", "overrides")


def add_parser(sub, **common) -> None:
    """Add ``info`` to the commands ``sub``."""
    info = sub.add_parser("info", help="what is in a topography file", **common)
    add_file_options(info, detrend=False)
    info.add_argument("--all", action="store_true",
                      help="print every attribute (the file's whole header)")
    info.set_defaults(func=run)


def _channels(topo: xr.DataArray, path: str) -> list[dict]:
    """List the file's channels, where its format has them (else an empty list)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            found = list_channels(path, format=topo.attrs.get("format"))
    except (ValueError, OSError):  # the listing is extra information only
        return []
    return [{k: (v if isinstance(v, (int, float, str, bool)) or v is None else str(v))
             for k, v in c.items()} for c in found]


def _channel_text(c: dict) -> str:
    if c.get("description"):
        return str(c["description"])
    unit = c.get("unit") or "no unit"
    return f"{c.get('index')}: {c.get('name')} ({unit}{', height' if c.get('is_height') else ''})"


def _facts(path: str, topo: xr.DataArray) -> dict:
    """Collect what ``info`` tells of a topography, in the units of the file."""
    dims = [d for d in ("y", "x") if d in topo.dims]
    nonuniform = topo.attrs.get("sampling") == "non-uniform"
    steps, extents = {}, {}
    for d in dims:
        c = np.asarray(topo[d].values, dtype=float)
        steps[d] = (c[-1] - c[0]) / (c.size - 1) if c.size > 1 else np.nan
        extents[d] = ((c[-1] - c[0]) + (0 if nonuniform else steps[d]) if c.size > 1
                      else np.nan)
    values = np.asarray(topo.values, dtype=float)
    valid = np.isfinite(values)
    n_valid = int(valid.sum())
    fmt = topo.attrs.get("format", "?")
    return {"dims": dims, "steps": steps, "extents": extents, "nonuniform": nonuniform,
            "lateral": topo["x"].attrs["units"], "height": topo.attrs["units"],
            "rms": float(np.std(values[valid])) if n_valid else float("nan"),
            "n_valid": n_valid, "n": values.size, "format": fmt,
            "description": (registered()[fmt].description if fmt in registered()
                            else fmt),
            "kind": "map" if len(dims) == 2 else "profile",
            "channels": _channels(topo, path)}


def _summary(path: str, topo: xr.DataArray, f: dict) -> list[str]:
    """Return the lines on the grid, its units and heights."""
    dims, lateral = f["dims"], f["lateral"]
    extra = [d for d in topo.dims if d not in dims]
    lines = [path,
             f"  format        {f['format']} ({f['description']})",
             f"  points        {' x '.join(str(topo.sizes[d]) for d in dims)} "
             f"({', '.join(dims)}), {f['kind']}" + (f"; extra dims {extra}" if extra else ""),
             f"  size          {' x '.join(text(f['extents'][d], lateral) for d in dims)}",
             f"  pixel size    {' x '.join(text(f['steps'][d], lateral) for d in dims)}"
             + (" (mean; non-uniform sampling)" if f["nonuniform"] else ""),
             f"  units         lateral {lateral}, height {f['height']}",
             f"  rms height    {text(f['rms'], f['height'], none='no valid point')}",
             f"  valid points  {f['n_valid'] / max(f['n'], 1):.2%} ({f['n_valid']} of "
             f"{f['n']})",
             f"  periodic      {'yes' if topo.attrs.get('periodic') else 'no'}"]
    if f["channels"]:
        lines.append(f"  channels      {'; '.join(_channel_text(c) for c in f['channels'])}")
    return lines


def _attribute_lines(topo: xr.DataArray, rest: dict, everything: bool) -> list[str]:
    """Return lines of the instrument, provenance and other attributes (or their count)."""
    shown = [k for k in _INFO_KEYS if k in topo.attrs]
    shown += [k for k in _PROVENANCE if k in topo.attrs and k != "format"]
    lines = [f"  {key:<13} {topo.attrs[key]}" for key in shown]
    if everything:
        lines.append("  attributes:")
        lines += [f"    {k}: {' '.join(str(v).split())}" for k, v in rest.items()]
    elif rest:
        lines.append(f"  ({len(rest)} more attributes: xrough info --all)")
    return lines


def _record(path: str, topo: xr.DataArray, f: dict, rest: dict, everything: bool) -> dict:
    """Return the same as JSON-ready values, numbers with their units."""
    dims, lateral = f["dims"], f["lateral"]
    info = {
        "file": path, "format": f["format"], "kind": f["kind"], "dims": dims,
        "shape": {d: int(topo.sizes[d]) for d in dims},
        "size": {d: number(f["extents"][d], lateral) for d in dims},
        "pixel_size": {d: number(f["steps"][d], lateral) for d in dims},
        "lateral_units": lateral, "height_units": f["height"],
        "rms_height": number(f["rms"], f["height"]),
        "valid_fraction": f["n_valid"] / max(f["n"], 1),
        "periodic": bool(topo.attrs.get("periodic")),
        "channels": f["channels"],
        "provenance": {k: topo.attrs[k] for k in _PROVENANCE if k in topo.attrs},
        **{k: topo.attrs[k] for k in _INFO_KEYS if k in topo.attrs},
    }
    if everything:
        info["attrs"] = {k: v.tolist() if isinstance(v, np.ndarray) else v
                         for k, v in rest.items()}
    return info


def describe(path: str, topo: xr.DataArray, everything: bool) -> tuple[list[str], dict]:
    """Lines of ``xrough info`` and the same as a JSON-ready dict."""
    facts = _facts(path, topo)
    shown = {"units", "long_name", "periodic", "source", *_INFO_KEYS, *_PROVENANCE}
    rest = {k: v for k, v in topo.attrs.items() if k not in shown}
    lines = _summary(path, topo, facts) + _attribute_lines(topo, rest, everything)
    return lines, _record(path, topo, facts, rest, everything)


def run(args: argparse.Namespace) -> int:
    """Describe each file, as text or JSON."""
    records = []
    for path in args.files:
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                topo = open_file(path, args)
            lines, info = describe(path, topo, args.all)
        except CLIError:
            raise
        except Exception as err:  # noqa: BLE001 - one line naming the file
            raise fail(path, err) from err
        info["warnings"] = warn_lines(path, caught)
        records.append(info)
        if not args.json:
            print("\n".join(lines))
    if args.json:
        emit_json({"xrough_version": __version__, "files": records})
    return EXIT_OK
