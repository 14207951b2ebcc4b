"""The model error of Persson's contact area against solver runs it was not built from.

``xrough/data/persson_area_error.csv`` (the build set of ``benchmarks/model_error_study.py``)
gives :func:`xrough.persson` its ``a_r_exact`` / ``sigma_c_exact`` (the expected exact
solution) and their one-sigma interval ``_exact_lower`` / ``_exact_upper``, as a function of
``p*`` and of G's local exponents at the lag (``xrough._kernels.model_error``). Here they
meet the study's held-out set: surfaces of other Hurst exponents, roll-offs, cutoffs and
geometries (H 0.3 smooth roll-off with a Gaussian cutoff at bandwidth 32, H 0.65 smooth at
bandwidth 8, H 0.65 sharp at ``lambda_s = 2 px``, H 0.3 sharp at bandwidth 8, and open,
plane-detrended windows at H 0.2 and 0.7), two seeds, ``p*`` 1e-4 to 0.5.

Printed per class of surface: the theory's own error ``a_r / a_exact - 1`` (median), the
corrected one ``a_r_exact / a_exact - 1`` (median and largest), and ``z = ln(a_exact /
a_r_exact) / spread`` (median, and the share within 1 and 2 sigma); then the same over the
whole set, for ``a_r``, ``a_ri`` and ``sigma_c`` (``sigma_c = p0 / a_r``: its z is ``a_r``'s
with the sign turned). Loads where fewer than 100 pixels touch are left out (the solver's
area then measures the grid). The stress ACF ``G_sigma`` (eq. 30/48) the same way, its
fluctuating part ``F = G_sigma - p0^2`` at every lag its model covers (``G_sigma_exact``, from
``xrough/data/persson_stress_error.csv.gz``), per class and by lag. The runs are those of
the study (cached in ``<out>/runs``; about 1 minute of solving on two cores when not
cached).

Usage::

    python benchmarks/model_error_heldout.py --out model-error-study
"""

from __future__ import annotations

import argparse
from collections import defaultdict

import model_error_study as study
import numpy as np

from xrough._kernels import model_error as me


def evaluate(table: list[dict]) -> dict:
    """Per row: the theory's error, the corrected one and z, for a_r, a_ri and sigma_c."""
    rows = [r for r in table if r["contact_pixels"] >= me.MIN_PIXELS and r["converged"]]
    out: dict = {"class": [], "p_star": []}
    for r in rows:
        out["class"].append(f"H {r['hurst']:g} {r['rolloff']} roll-off, {r['cutoff']} cutoff,"
                            f" ls {r['lambda_s_px']:g} px, bw {r['bandwidth']:g}"
                            + (", open" if r["open"] else ""))
        out["p_star"].append(r["p_star"])
    for area in ("a_r", "a_ri"):
        p = np.array([r["p_star"] for r in rows])
        features = [np.array([r[f] for r in rows]) for f in me.FEATURES]
        periodic = np.array([not r["open"] for r in rows])
        bias, spread = me.area_model_error(p, *features, periodic=periodic, area=area)
        theory = np.array([r[area] for r in rows])
        exact = np.array([r["contact_area"] for r in rows])
        expected = theory * np.exp(-bias)
        out[area] = {"theory": theory / exact - 1, "corrected": expected / exact - 1,
                     "z": np.log(exact / expected) / spread}
    out["sigma_c"] = {"theory": 1 / (1 + out["a_r"]["theory"]) - 1,
                      "corrected": 1 / (1 + out["a_r"]["corrected"]) - 1,
                      "z": -out["a_r"]["z"]}
    return out


def evaluate_stress(table: list[dict]) -> dict:
    """Per row of the stress table: Persson's error of ``F = G_sigma - p0^2``, the
    corrected one and z, at every lag the model covers."""
    col = {k: np.array([r[k] for r in table]) for k in study.STRESS_COLUMNS}
    bias, spread = me.stress_model_error(
        col["p_star"], col["p_star_0"], col["decay"], *(col[f] for f in me.FEATURES),
        periodic=col["open"].astype(float) == 0)
    ok = np.isfinite(bias)
    cls = np.array([f"H {h:g} {ro} roll-off, {co} cutoff, ls {ls:g} px, bw {bw:g}"
                    + (", open" if op else "") for h, ro, co, ls, bw, op in zip(
                        *(col[k] for k in ("hurst", "rolloff", "cutoff", "lambda_s_px",
                                           "bandwidth", "open")))])
    return {"class": cls[ok], "lag_px": col["lag_px"][ok],
            "G_sigma": {"theory": np.exp(col["ln_ratio"][ok]) - 1,
                        "corrected": np.exp(col["ln_ratio"][ok] - bias[ok]) - 1,
                        "z": (bias[ok] - col["ln_ratio"][ok]) / spread[ok]}}


def summary(z: np.ndarray, corrected: np.ndarray, theory: np.ndarray) -> str:
    ok = np.isfinite(z)
    z, c = z[ok], np.abs(corrected[ok])
    within = [np.mean(np.abs(z) <= k) for k in (1, 2)]
    return (f"{ok.sum():>4} | {np.median(np.abs(theory[ok])):>7.1%} | {np.median(c):>6.1%}"
            f" {np.quantile(c, 0.9):>6.1%} | {np.median(z):>+6.2f} | {within[0]:>5.0%}"
            f" {within[1]:>5.0%}")


HEAD = ("   n | theory | corrected (median, 90 %) |  z med | in 1s  in 2s\n"
        "---:|---:|---:|---:|---:")


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="model-error-study", help="the study's directory")
    p.add_argument("--jobs", type=int, default=1)
    args = p.parse_args(argv)
    tables = study.main(["--out", args.out, "--set", "heldout", "--jobs", str(args.jobs)])
    res = evaluate(tables["heldout"])
    print("\nheld-out a_r per class: |a_r / a_exact - 1| of the theory (median); of the "
          "expected exact value (median, 90th percentile); z = ln(a_exact / expected) / "
          "spread (median; share within 1 and 2 sigma)\n")
    print("class | " + HEAD.replace("\n", "\n---|"))
    classes = defaultdict(list)
    for i, c in enumerate(res["class"]):
        classes[c].append(i)
    for c, idx in classes.items():
        idx = np.array(idx)
        print(f"{c} | " + summary(*(res["a_r"][k][idx] for k in ("z", "corrected", "theory")))
              .replace(" | ", " | "))
    print("\nover the whole held-out set:\n")
    print("quantity | " + HEAD.replace("\n", "\n---|"))
    for name in ("a_r", "a_ri", "sigma_c"):
        print(f"{name} | " + summary(*(res[name][k] for k in ("z", "corrected", "theory"))))
    stress = evaluate_stress(tables["heldout_stress"])
    print("\nheld-out G_sigma, its fluctuating part F = G_sigma - p0^2 at every lag the model "
          "covers: |F / F_exact - 1| of the theory and of the expected exact value; z = "
          "ln(F_exact / expected) / spread\n")
    print("class | " + HEAD.replace("\n", "\n---|"))
    for c in dict.fromkeys(stress["class"]):
        idx = stress["class"] == c
        print(f"{c} | " + summary(*(stress["G_sigma"][k][idx]
                                    for k in ("z", "corrected", "theory"))))
    for lo, hi in ((1, 1.01), (1.01, 4), (4, np.inf)):
        idx = (stress["lag_px"] >= lo) & (stress["lag_px"] < hi)
        print(f"lags {lo:g}-{hi:g} px | " + summary(*(stress["G_sigma"][k][idx]
                                                    for k in ("z", "corrected", "theory"))))
    print("G_sigma, all | " + summary(*(stress["G_sigma"][k]
                                        for k in ("z", "corrected", "theory"))))
    res["G_sigma"] = stress
    return res


if __name__ == "__main__":
    main()
