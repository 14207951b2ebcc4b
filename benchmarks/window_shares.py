"""The instrument's window in every result: what the real files with a stated tip give.

For each measurement whose file (or its contact.engineering ``meta.yml``) states a tip or
stylus radius, runs the chain of tests/test_real_data.py (detrend as the metadata say,
``mask_outliers(threshold=5)``, ``acf()``, E* = 25 MPa, p0 = 0.1 MPa) and prints the
window ``acf()`` set, v_el with its share from below the window (``v_el_below_window``)
and rating, the patch radius at gamma = 50 and 0.05 mJ/m^2 (a_c, share, rating), the rms
gradient at the first lag and at the smallest lag inside the window, and what
``xrough report`` prints as rms grad (and where).

Usage::

    python benchmarks/window_shares.py
"""

from __future__ import annotations

import json
import re
import sys
import tempfile
import warnings
from contextlib import redirect_stdout
from io import StringIO
from pathlib import Path

import numpy as np

import xrough
from xrough.cli import main
from xrough.preprocess import lag_window

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
from _data import data_file  # noqa: E402

CASES = {  # name: (parts, open options, detrend mode)
    "dektak-1": (("instruments", "dektak-1.csv"), {}, "plane"),
    "UNCD stylus": (("uncd", "uncd_stylus_300um_5mar_3_k0HpKJt.txt"), {"unit": "mm"},
                    "curvature"),
    "UNCD AFM": (("uncd", "gain_control_uncd_35_z03tr3R.001"), {}, "plane"),
}


def _report(path: Path, detrend: str, opts: dict) -> dict:
    args = ["report", str(path), "--E-star", "25MPa", "--p0", "0.1MPa", "--json",
            "--detrend", detrend, *(["--unit", opts["unit"]] if "unit" in opts else [])]
    with tempfile.TemporaryDirectory() as folder:
        out = StringIO()
        with redirect_stdout(out):
            main([*args, "-o", str(Path(folder) / "r.nc")])
    return json.loads(out.getvalue())["measurements"][0]


def main_() -> None:
    warnings.simplefilter("ignore")
    for name, (parts, opts, mode) in CASES.items():
        path = data_file(*parts)
        topo = xrough.open_topography(path, **opts)
        G = topo.rough.detrend(mode=mode).rough.mask_outliers(threshold=5).rough.acf()
        unit = G.dr.attrs["units"]
        window = lag_window(G)
        bounds = (None if window.lo is None and window.hi is None else
                  f"{window.lo or 0:.4g} to {window.hi or np.inf:.4g} {unit}")
        print(f"{name}: lags {G.dr.values[0]:.4g} to {G.dr.values[-1]:.4g} {unit}; window "
              + (bounds if not window.empty else
                 f"{bounds}, holding no lag of G" if bounds else
                 f"none ({window.empty[:60]}...)"))
        e = G.rough.energy(E_star="25 MPa")
        print(f"  v_el = {1e3 * float(e.v_el):.3g} +- {1e3 * float(e.v_el_std):.2g} mJ/m2, "
              f"below the window {float(e.v_el_below_window):.1%} "
              f"(below the first lag {float(e.extrapolated_below):.1%}): "
              f"{e.attrs['quality']}")
        for gamma in ("50 mJ/m^2", "0.05 mJ/m^2"):
            p = G.rough.patch_radius(E_star="25 MPa", gamma=gamma)
            said = re.search(r"\(a_c = ([^)]*)\) lies below", p.attrs["quality_notes"])
            value = (f"NaN (the root, {said.group(1)}, lies below the window)" if said else
                     f"{float(p.a_c):.4g} {unit}")
            print(f"  patch radius at {gamma}: a_c = {value}, share below the window "
                  f"{float(p.a_c_below_window):.1%}: {p.attrs['quality']}")
        g = G.rough.gradient()
        inside = np.flatnonzero(np.isfinite(g.values))
        first = (f"{g.values[inside[0]]:.4g} at {g.dr.values[inside[0]]:.4g} {unit}"
                 if inside.size else "none")
        print(f"  gbar: first finite {first}; {g.attrs['quality']}")
        m = _report(path, mode, opts)
        grad, at = m["rms_gradient"], m["at_dr"]
        shown = "none" if grad["value"] is None else f"{grad['value']:.4g}"
        where = "no lag" if at["value"] is None else f"{at['value']:.4g} {at['units']}"
        print(f"  report: rms grad {shown} ({m['quality']['gradient']['level']}) at {where}; "
              f"v_el {m['quality']['energy']['level']}")


if __name__ == "__main__":
    main_()
