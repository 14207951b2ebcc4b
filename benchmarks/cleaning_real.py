"""Which results of the real maps depend on how they are cleaned? ``cleaning_sensitivity``.

For every map of the test data: the chain (G, fit, gradient, energy, Persson theory at
E* = 25 MPa, p0 = 0.1 MPa) with a plane removed, with a line removed per scan line, and
with a plane and the outliers masked; z of each result against the plane's (at the
finest lag where Persson theory has a number), and the time of the comparison as a
multiple of one ``acf()`` of the map.

Run: ``python benchmarks/cleaning_real.py``.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np

import xrough

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
MAPS = ["instruments/al3d-1.al3d", "instruments/di-1.di", "instruments/matrix-3.txt",
        "instruments/mi-1.mi", "instruments/nid-1.nid", "instruments/opd-1.opd",
        "instruments/plu-1.plu", "instruments/spot_1-1000nm.ibw", "instruments/sur-2.sur",
        "instruments/x3p-2.x3p", "uncd/gain_control_uncd_35_z03tr3R.001"]
QUANTITIES = ("gbar", "v_el", "a_r", "hurst")


def _cell(found, q) -> str:
    z = found[f"z_{q}"].values[1:]
    return " / ".join("nan" if not np.isfinite(v) else
                      f"{v:+.1f}{'*' if abs(v) > 3 else ''}" for v in z)


def main():
    warnings.filterwarnings("ignore", category=xrough.QualityWarning)
    print("z against the plane: line by line / plane with outliers masked; * beyond 3\n")
    print("| map | at dr | " + " | ".join(QUANTITIES) + " | time / acf |")
    print("|---|---|" + "---|" * (len(QUANTITIES) + 1))
    for rel in MAPS:
        path = DATA / rel
        if not path.exists():
            print(f"| {rel} | not available |")
            continue
        topo = xrough.open_topography(path)
        t = time.perf_counter()
        topo.rough.detrend().rough.acf()
        t_acf = time.perf_counter() - t
        t = time.perf_counter()
        found = xrough.cleaning_sensitivity(topo, E_star="25 MPa", p0="0.1 MPa")
        t_all = time.perf_counter() - t

        dr = float(found.dr)
        where = "none" if not np.isfinite(dr) else f"{dr:.3g} {found.dr.attrs['units']}"
        print(f"| {Path(rel).name} | {where} | " + " | ".join(_cell(found, q) for q in QUANTITIES)
              + f" | {t_all / t_acf:.0f} |")


if __name__ == "__main__":
    main()
