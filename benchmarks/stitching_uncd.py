"""What the stitched UNCD G measures, what it bridges, and how far levelling goes.

The three UNCD measurements (TEM profile, AFM map, stylus profile; detrended as their
metadata say) are stitched as a DataTree, as ``tree.rough.acf(unit="nm")``. Parts 1-3
stitch the G as measured (``reliable=False``: the tips meta.yml states not applied, so
that the AFM takes part); part 0 with them applied (the default). Printed:

0. with the stated tips (default): the windows and their rules, what is left out, the
   gaps and the fit of the stitched G;

1. the lag ranges no window covers (``uncovered_dr_min/max``) and the bins around them;
2. the level factors with the standard errors of their logarithms, for the AFM heights as
   calibrated and multiplied by 2 (G x 4), with the mismatch statistic of TEM/AFM and
   which warnings fire;
3. what each consumer of the stitched G says about the gap: its quality level, the share
   of the elastic energy from the bridge and its error;
4. on a synthetic H = 0.7 profile measured by two instruments, with and without a gap of
   one decade (40-400 nm): the bridge's share of v_el, its stated error and the actual
   error (v_el of the G measured over the gap too).

The data are read from ``../shared/data/uncd`` (seen from the project root); without
them parts 1-3 are skipped. The measurements are built as in
``tests/test_stitching_gaps.py``, whose helpers this script imports.

Usage::

    python benchmarks/stitching_uncd.py
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

import xrough

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
from _data import data_root  # noqa: E402  (where the measurement files are)

UNCD = data_root() / "uncd"
sys.path.insert(0, str(ROOT / "tests"))  # the measurements of tests/test_stitching_gaps.py
from test_stitching_gaps import two_instruments, uncd_tree  # noqa: E402


def stitched(tree_or_dict, **kwargs):
    """Stitch, returning G and the categories and messages of the warnings."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        G = (tree_or_dict.rough.acf(**kwargs) if isinstance(tree_or_dict, xr.DataTree)
             else xrough.stitch(tree_or_dict, **kwargs))
    return G, [(w.category.__name__, str(w.message)) for w in caught]


def consumers(G: xr.DataArray) -> None:
    calls = {
        "fit_acf": lambda: G.rough.fit(),
        "elastic_energy": lambda: G.rough.energy(E_star="1 GPa"),
        "rms_gradient auto": lambda: G.rough.gradient(),
        "rms_gradient exact": lambda: G.rough.gradient(method="exact"),
        "stress_acf": lambda: G.rough.stress_acf(E_star="1 GPa"),
        "persson": lambda: G.rough.persson(E_star="1 GPa", p0="10 MPa"),
        "patch_radius": lambda: G.rough.patch_radius(E_star="1 GPa", gamma="50 mJ/m^2"),
        "spectrum": lambda: G.rough.spectrum(),
    }
    for name, call in calls.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                r = call()
            except ValueError as err:
                print(f"  {name:20s} ValueError: {str(err)[:90]}")
                continue
        gap = "not measured" in r.attrs.get("quality_notes", "")
        extra = ""
        if name == "fit_acf":
            extra = (f"H = {float(r.hurst):.3f} ({r.attrs['rolloff']} roll-off, "
                     f"{r.attrs['cutoff']} cutoff)")
        if name == "elastic_energy":
            extra = (f"v_el = {float(r.v_el):.4g} J/m2, gap_share = "
                     f"{float(r.gap_share):.3f} +- {float(r.gap_share_error):.3f}")
        if name.startswith("rms_gradient"):
            extra = f"route {r.attrs.get('method')}"
        if name == "patch_radius":
            extra = f"a_c = {float(r.a_c):.3g} nm"
        print(f"  {name:20s} {r.attrs.get('quality', '-'):12s} gap note: {gap!s:5s} {extra}")


def synthetic() -> None:
    meas = two_instruments()
    gapped, _ = stitched(meas, windows={"fine": (None, 40.0), "coarse": (400.0, None)})
    whole, _ = stitched(meas)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        e_gap, e_all = gapped.rough.energy(E_star="1 MPa"), whole.rough.energy(E_star="1 MPa")
    print(f"  gap 40-400 nm: gap_share {float(e_gap.gap_share):.3f}, stated error "
          f"{float(e_gap.gap_share_error):.3f}, actual error of v_el "
          f"{float(e_all.v_el) / float(e_gap.v_el) - 1:+.3f}")


def with_tips() -> None:
    """The stitched UNCD G with the tips meta.yml states (the default, reliable=True)."""
    G, caught = stitched(uncd_tree(UNCD), unit="nm")
    print("UNCD, stated tips applied (default):")
    print(f"  windows: {G.attrs['windows']}")
    print(f"  rules: {G.attrs['window_rules']}")
    print(f"  left out: {G.attrs['left_out'] or '-'}; G quality: {G.attrs.get('quality')}")
    print(f"  remarks: {G.attrs.get('quality_remarks', '')}")
    for lo, hi in zip(G.attrs["uncovered_dr_min"], G.attrs["uncovered_dr_max"]):
        print(f"  uncovered: {lo:.4g}-{hi:.4g} {G.attrs['uncovered_dr_units']}")
    print(f"  warnings: {sorted({c for c, _ in caught})}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = G.rough.fit()
    print(f"  fit: H = {float(fit.hurst):.3f} +- {float(fit.hurst_std):.3f} "
          f"({fit.attrs.get('quality')}: {fit.attrs.get('quality_notes', '')[:160]})")


def main() -> None:
    if UNCD.is_dir():
        with_tips()
        for scale in (1.0, 2.0):
            G, caught = stitched(uncd_tree(UNCD, scale), unit="nm", reliable=False)
            print(f"UNCD as measured (reliable=False), AFM heights x {scale:g}:")
            for lo, hi in zip(G.attrs["uncovered_dr_min"], G.attrs["uncovered_dr_max"]):
                dr = G.dr.values
                print(f"  uncovered: {lo:.4g}-{hi:.4g} {G.attrs['uncovered_dr_units']} "
                      f"(bins {dr[dr <= lo].max():.4g} and {dr[dr >= hi].min():.4g})")
            names = G.attrs["stitched_from"].split(", ")
            for m, f, e in zip(names, G.attrs["level_factors"],
                               G.attrs["level_factor_errors"]):
                print(f"  level factor {m:9s} x {f:.3f}  (ln f = {np.log(f):+.3f} +- {e:.3f})")
            print(f"  mismatch {G.attrs['mismatch_pairs']}: ratio "
                  f"{G.attrs['mismatch_ratio'][0]:.3f}, z = {G.attrs['mismatch_z'][0]:.2f}")
            print(f"  warnings: {sorted({c for c, _ in caught})}; G quality: "
                  f"{G.attrs.get('quality', '-')}")
            if scale == 1.0:
                consumers(G)
    else:
        print(f"UNCD data not found ({UNCD}): parts 1-3 skipped")
    print("synthetic H = 0.7, two instruments:")
    synthetic()


if __name__ == "__main__":
    main()
