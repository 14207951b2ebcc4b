"""Mean gap, stiffness and elastic energy of partial contact: theory from G against the solver.

Builds ``xrough/data/gap_error.csv``, from which :func:`xrough.mean_gap` takes the model
error of ``mean_gap``, ``stiffness`` and ``elastic_energy`` (the expected exact value and
its interval, against ``p*`` at the finest lag), and checks it on surfaces it was not built
from.

Each surface is a periodic random-phase map (eq. 35, rms gradient 0.1, 1 nm pixels,
``E* = 1 MPa``) of ``N = (L / lambda_r) (lambda_r / lambda_s) lambda_s`` pixels a side,
pressed at ``p* = p0 / (E* gbar) = 1e-4, 1e-3, 1e-2, 0.03, 0.1, 0.3`` (``gbar`` at the
map's finest lag, as :func:`xrough.mean_gap` reads it), each load also 1 % below and above
for the solver's stiffness. Two sets:

- ``build``: H 0.3, 0.5 and 0.8, roll-off sharp and smooth, ``lambda_s`` 2 px,
  bandwidths 8, 32 and 64, ``L / lambda_r`` 2 and 4, seeds 0 and 1;
- ``heldout``: never used to build the table: H 0.4, 0.65 and 0.75, smooth and sharp,
  ``lambda_s`` 2 and 4 px, bandwidths 16 and 128 (at most 512 px), ``L / lambda_r`` 2,
  seeds 7 and 8; and bandwidth 256 (1024 px, smooth roll-off, seed 7) for each H.

For every load the theory comes from the map's G (:func:`xrough.mean_gap`: the real-space
form) and from the map's own Fourier modes (the same sums over the binned periodogram,
:func:`xrough.gradient_from_spectrum` of :func:`xrough.power_spectrum`: Persson's Fourier form); the
solver gives the mean of the gap, ``(1/2) <(p - p0) u>`` and ``-dp0/d gap``.

Usage::

    python benchmarks/gap_study.py --set build --out /tmp/gap      # ~5 min
    python benchmarks/gap_study.py --set heldout --out /tmp/gap    # ~6 min
    python benchmarks/gap_study.py --out /tmp/gap --write-table    # ship build's table
    python benchmarks/gap_study.py --out /tmp/gap --report         # held-out summary
"""

from __future__ import annotations

import argparse
import itertools
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

import xrough
from xrough._kernels.separation import separation_kernel
from xrough.gradient import gradient_from_spectrum
from xrough.separation import exact_interval

E_STAR = 1e6
GBAR = 0.1
P_STARS = (1e-4, 1e-3, 1e-2, 0.03, 0.1, 0.3)
TABLE = Path(__file__).resolve().parents[1] / "xrough" / "data" / "gap_error.csv"
QUANTITIES = ("mean_gap", "stiffness", "elastic_energy")


def cases(which: str):
    if which == "build":
        grid = itertools.product((0.3, 0.5, 0.8), ("sharp", "smooth"), (2,), (8, 32, 64),
                                 (2, 4), (0, 1))
    else:
        grid = itertools.product((0.4, 0.65, 0.75), ("smooth", "sharp"), (2, 4), (16, 128),
                                 (2,), (7, 8))
    if which == "heldout":
        grid = itertools.chain(grid, itertools.product((0.4, 0.65, 0.75), ("smooth",), (2,),
                                                       (256,), (2,), (7,)))
    for hurst, rolloff, ls, bw, ratio, seed in grid:
        n = int(ratio * bw * ls)
        if n <= 512 or bw == 256:
            yield dict(hurst=hurst, rolloff=rolloff, lambda_s=ls, bandwidth=bw, ratio=ratio,
                       seed=seed, n=n)


def run_case(case: dict) -> pd.DataFrame:
    n = case["n"]
    topo = xrough.self_affine_surface(
        hurst=case["hurst"], lambda_r=f"{case['bandwidth'] * case['lambda_s']} nm",
        lambda_s=f"{case['lambda_s']} nm", size=f"{n} nm", n=n, rms_gradient=GBAR,
        rolloff=case["rolloff"], unit="nm", seed=case["seed"])
    G = topo.rough.acf()
    gbar = G.rough.gradient()
    gbar0 = float(gbar[0])
    p_mid = np.array(P_STARS) * E_STAR * gbar0
    loads = (p_mid[:, None] * np.array([0.99, 1.0, 1.01])).ravel()
    t0 = time.perf_counter()
    sol = topo.rough.solve_contact(E_star=E_STAR, p0=loads, progress=False)
    seconds = time.perf_counter() - t0
    mid = sol.isel(p0=slice(1, None, 3))
    theory = G.rough.mean_gap(E_star=E_STAR, p0=p_mid, gradient=gbar)
    # the Fourier form: the same sums over the map's own modes (binned periodogram)
    psd = topo.rough.psd()
    gbar_f = gradient_from_spectrum(psd, G.dr.values).values
    fourier = separation_kernel(np.minimum.accumulate(gbar_f), dr=G.dr.values * 1e-9,
                                p0=p_mid, E=E_STAR, gamma=xrough.separation.GAMMA)
    rows = []
    for k, ps in enumerate(P_STARS):
        t = theory.isel(p0=k)
        # the gap distributions' quantile functions over shares 0 to 0.95 (the theory's
        # share 1 is unbounded): their mean absolute difference, the L1 (Wasserstein)
        # distance between the two distributions
        shares = t.area_share.values[:-1]
        q_t = t.gap_quantiles.values[:-1]
        q_e = mid.gap_quantiles[k].values[:-1]
        rows.append({
            "gap_distance": np.trapezoid(np.abs(q_t - q_e), shares) / shares[-1],
            "gap_median_theory": float(t.gap_quantiles.sel(area_share=0.5)),
            "gap_median_exact": float(mid.gap_quantiles[k].sel(area_share=0.5)),
            "gap_q90_theory": float(t.gap_quantiles.sel(area_share=0.9)),
            "gap_q90_exact": float(mid.gap_quantiles[k].sel(area_share=0.9)),
            **case, "p_star": ps, "p0": p_mid[k], "seconds": seconds,
            "contact_area": float(mid.contact_area[k]),
            "converged": int(sol.converged.all()),
            "mean_gap_exact": float(mid.mean_gap[k]),
            "stiffness_exact": float(mid.stiffness[k]),
            "elastic_energy_exact": float(mid.elastic_energy[k]),
            "mean_gap_theory": float(t.mean_gap), "mean_gap_std": float(t.mean_gap_std),
            "stiffness_theory": float(t.stiffness), "stiffness_std": float(t.stiffness_std),
            "elastic_energy_theory": float(t.elastic_energy),
            "elastic_energy_std": float(t.elastic_energy_std),
            "elastic_energy_34": float(t.elastic_energy_34),
            "gap_beyond_lags": float(t.gap_beyond_lags),
            "mean_gap_fourier": fourier[k, 0] * 1e9,
            "stiffness_fourier": p_mid[k] / fourier[k, 2] * 1e-9,
            "elastic_energy_fourier": fourier[k, 1],
        })
    return pd.DataFrame(rows)


def run_set(which: str, out: Path) -> pd.DataFrame:
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{which}.csv"
    frames = []
    for case in cases(which):
        frames.append(run_case(case))
        print(f"{which}: H {case['hurst']} {case['rolloff']} ls {case['lambda_s']} "
              f"bw {case['bandwidth']} L {case['ratio']} seed {case['seed']}: "
              f"{frames[-1].seconds.iloc[0]:.1f} s", flush=True)
    df = pd.concat(frames, ignore_index=True)
    df.to_csv(path, index=False)
    return df


def table(df: pd.DataFrame) -> pd.DataFrame:
    """Per p* and quantity: the 5, 50 and 95 % quantiles of ln(exact / theory)."""
    rows = []
    for ps, group in df.groupby("p_star"):
        for q in QUANTITIES:
            r = np.log(group[f"{q}_exact"] / group[f"{q}_theory"])
            r = r[np.isfinite(r)]
            rows.append({"p_star": ps, "quantity": q, "n": r.size,
                         "median": np.median(r), "lower": np.quantile(r, 0.05),
                         "upper": np.quantile(r, 0.95)})
    return pd.DataFrame(rows)


def report(held: pd.DataFrame) -> None:
    """Held-out check: exact within the stated 90 % interval; medians of the errors."""
    surfaces = held[["hurst", "rolloff", "lambda_s", "bandwidth", "seed"]].drop_duplicates()
    print(f"held-out: {len(surfaces)} surfaces, {len(held)} loads")
    for q in QUANTITIES:
        value = held[f"{q}_theory"].to_numpy()
        std = held[f"{q}_std"].to_numpy()
        exact = held[f"{q}_exact"].to_numpy()
        centre, low, high = (np.asarray(v) for v in exact_interval(
            value, std, xr.DataArray(held.p_star.to_numpy()), q))
        inside = (exact >= low) & (exact <= high)
        real = np.abs(value / exact - 1)
        four = np.abs(held[f"{q}_fourier"].to_numpy() / exact - 1)
        print(f"{q:15s} within the 90 % interval: {inside.mean():.0%} of {inside.size}; "
              f"median |theory/exact - 1| real space {np.median(real):.1%}, Fourier form "
              f"{np.median(four):.1%}; corrected (exact expected) "
              f"{np.median(np.abs(centre / exact - 1)):.1%}")
        for ps in P_STARS:
            sel = held.p_star.to_numpy() == ps
            print(f"    p* {ps:g}: theory/exact median {np.median(value[sel] / exact[sel]):.3f}"
                  f" (Fourier {np.median(held[f'{q}_fourier'].to_numpy()[sel] / exact[sel]):.3f}"
                  f"), within {inside[sel].mean():.0%}")
    dist = held.gap_distance / held.mean_gap_exact
    print("gap distribution: median L1 distance / exact mean gap "
          f"{np.median(dist):.1%} (p* 1e-4 to 0.3: "
          + ", ".join(f"{np.median(dist[held.p_star == p]):.1%}" for p in P_STARS) + ")")
    for name in ("median", "q90"):  # as a share of the mean gap (the exact median is 0
        # where more than half the area is in contact)
        r = (held[f"gap_{name}_theory"] - held[f"gap_{name}_exact"]) / held.mean_gap_exact
        print(f"    {name} gap, theory - exact over the exact mean gap, by p*: "
              + ", ".join(f"{np.median(r[held.p_star == p]):+.2f}" for p in P_STARS))
    e34 = held.elastic_energy_34 / held.elastic_energy_exact
    per_load = ", ".join(f"{np.median(e34[held.p_star == p]):.2f}" for p in P_STARS)
    print(f"eq. 34 energy: theory/exact median {np.median(e34):.2f} "
          f"(p* 1e-4 to 0.3: {per_load})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", choices=("build", "heldout"))
    parser.add_argument("--out", type=Path, default=Path("gap-study"))
    parser.add_argument("--write-table", action="store_true")
    parser.add_argument("--report", action="store_true")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    if args.set:
        run_set(args.set, args.out)
    if args.write_table:
        tab = table(pd.read_csv(args.out / "build.csv"))
        header = ("# Model error of xrough.mean_gap against the solver (xrough.solve_contact).\n"
                  "# Made by: python benchmarks/gap_study.py --write-table (build set).\n"
                  "# Quantiles (5, 50, 95 %) of ln(exact / theory) over the build surfaces,"
                  " per p* = p0 / (E* gbar) at the finest lag.\n")
        TABLE.write_text(header + tab.to_csv(index=False, float_format="%.5g"))
        print(tab.to_string())
    if args.report:
        report(pd.read_csv(args.out / "heldout.csv"))


if __name__ == "__main__":
    main()
