"""``xrough acf``: G(dr) of topography files, archived to NetCDF (or Zarr)."""

from __future__ import annotations

import argparse

from .._version import __version__
from ..io.archive import save_analysis
from ._common import EXIT_OK, array, emit_json, output, text
from ._files import add_acf_options, add_file_options, measure_all


def add_parser(sub, **common) -> None:
    """Add ``acf`` to the commands ``sub``."""
    p = sub.add_parser("acf", help="G(dr) of files, archived to NetCDF", **common)
    add_file_options(p)
    add_acf_options(p, "acf")
    p.set_defaults(func=run)


def _record(m: dict) -> dict:
    G = m["results"]["G"]
    return {"name": m["name"], "file": m["file"], "detrend": m["detrend"],
            "warnings": m["warnings"], "dr": array(G.dr), "G": array(G),
            "standard_error": array(G.standard_error),
            "pair_count": [int(v) for v in G.pair_count.values.ravel()]}


def _line(m: dict) -> str:
    G = m["results"]["G"]
    dr_unit, g_unit = G.dr.attrs["units"], G.attrs["units"]
    return (f"{m['name']}: {m['file']}, detrend before G: {m['detrend']}, "
            f"{G.sizes['dr']} bins, dr {text(float(G.dr.min()), dr_unit)} to "
            f"{text(float(G.dr.max()), dr_unit)}, G {text(float(G.min()), g_unit)} to "
            f"{text(float(G.max()), g_unit)}")


def run(args: argparse.Namespace) -> int:
    """Compute, archive and print G of each file."""
    out = output(args.output)
    measured = measure_all(args)
    save_analysis(out, {m["name"]: {"G": m["results"]["G"]} for m in measured},
                  history="xrough acf " + " ".join(args.files))
    if args.json:
        emit_json({"xrough_version": __version__, "output": str(out),
                   "measurements": [_record(m) for m in measured]})
        return EXIT_OK
    for m in measured:
        print(_line(m))
    print(f"wrote {out}")
    return EXIT_OK
