"""Persson theory from G against the boundary-element solver: the paper's Figs. 5-7.

Periodic random-phase surfaces (eq. 35, sharp roll-off, rms gradient 0.1) of ``N^2``
pixels with ``L = ratio_l * lambda_r`` are pressed at reduced pressures
``p* = p0 / (E* gbar(0))`` from 0.001 to 0.3 and beyond full contact
(:func:`xrough.compare_with_simulation`), for each Hurst exponent, short cutoff
``lambda_s`` (in pixels: the resolution) and seed. Every run is cached as NetCDF in
``<out>/runs`` (an interrupted study resumes); the summary writes ``<out>/tables.md``
(full-contact error, contact areas, kappa against resolution, bandwidth and load, stress
ACF errors per theory; mean and standard deviation over the seeds) and four figures.

Usage::

    python benchmarks/validation_study.py --out study            # N = 1024, 3 seeds
    python benchmarks/validation_study.py --n 4096 --lambda-s 4 --seeds 1 --out big
    python benchmarks/validation_study.py --n 64 --lambda-s 4 --seeds 1 --hurst 0.8 \\
        --loads 0.01 0.1 --out /tmp/tiny                          # seconds (CI)
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402
from scipy.special import erf, erfinv  # noqa: E402

import xrough  # noqa: E402
from xrough.validation import compare_with_simulation  # noqa: E402

E_STAR = 1e6  # Pa
GBAR = 0.1  # rms gradient of every surface
LOADS = (0.001, 0.003, 0.01, 0.03, 0.1, 0.3)  # reduced pressures p*


def parse(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="validation-study", help="output directory")
    p.add_argument("--n", type=int, default=1024, help="pixels per side")
    p.add_argument("--ratio-l", type=float, default=4.0, help="L / lambda_r")
    p.add_argument("--lambda-s", type=float, nargs="+", default=[4, 8, 16],
                   help="short cutoffs in pixels (the resolutions)")
    p.add_argument("--hurst", type=float, nargs="+", default=[0.5, 0.8])
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--loads", type=float, nargs="+", default=list(LOADS),
                   help="reduced pressures p*")
    p.add_argument("--rolloff", default="sharp", choices=("sharp", "smooth"))
    p.add_argument("--summary-only", action="store_true",
                   help="only summarise the cached runs in <out>/runs")
    return p.parse_args(argv)


def run_name(n, hurst, lambda_s, seed, ratio_l, rolloff) -> str:
    return f"n{n}_L{ratio_l:g}_H{hurst:g}_ls{lambda_s:g}_{rolloff}_seed{seed}.nc"


def one_run(args, hurst, lambda_s, seed) -> xr.Dataset:
    """Solve one surface at every load (cached)."""
    path = Path(args.out) / "runs" / run_name(args.n, hurst, lambda_s, seed, args.ratio_l,
                                              args.rolloff)
    if path.exists():
        return xr.load_dataset(path)
    n = args.n
    topo = xrough.self_affine_surface(
        hurst=hurst, lambda_r=n / args.ratio_l, lambda_s=lambda_s, size=n, n=n,
        rms_gradient=GBAR, seed=seed, unit="nm", rolloff=args.rolloff)
    h = topo.values
    q = 2 * np.pi * np.fft.fftfreq(n)
    q2 = q[:, None] ** 2 + q[None, :] ** 2
    gbar0 = float(np.sqrt((q2 * np.abs(np.fft.fft2(h)) ** 2).sum()) / n**2)
    t0 = time.perf_counter()
    cmp = compare_with_simulation(topo, E_star=E_STAR,
                                  p0=np.asarray(args.loads) * E_STAR * gbar0)
    cmp = cmp.assign_attrs(hurst=hurst, lambda_s_px=lambda_s, seed=seed, n=n,
                           ratio_l=args.ratio_l, rolloff=args.rolloff,
                           lambda_r_px=n / args.ratio_l,
                           seconds=time.perf_counter() - t0)
    path.parent.mkdir(parents=True, exist_ok=True)
    cmp.to_netcdf(path)
    return cmp


def kappa_eff(cmp: xr.Dataset) -> np.ndarray:
    """Slope of eq. 29 that reproduces each simulated area: 2 erfinv(a) / (sqrt(pi) p*)."""
    a, p = cmp.contact_area.values, cmp.p_star.values
    with np.errstate(divide="ignore", invalid="ignore"):
        k = 2 * erfinv(a) / (np.sqrt(np.pi) * p)
    return np.where((a > 0) & (a < 1), k, np.nan)


def ms(values) -> str:
    """Mean ± standard deviation over seeds (just the value for one seed)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return "–"
    if v.size == 1:
        return f"{v[0]:.3g}"
    return f"{v.mean():.3g} ± {v.std(ddof=1):.2g}"


def summarise(args, runs: dict) -> str:
    """Markdown tables of the runs, keyed (hurst, lambda_s, seed)."""
    hursts = sorted({k[0] for k in runs})
    cutoffs = sorted({k[1] for k in runs})
    first = next(iter(runs.values()))
    loads = first.p_star.values / first.p_star.values[0] * args.loads[0]
    lines = [f"Surfaces: N = {args.n}, L = {args.ratio_l:g} lambda_r, {args.rolloff} "
             f"roll-off, rms gradient {GBAR}, E* = {E_STAR:g} Pa; "
             f"{len({k[2] for k in runs})} seed(s) per row (mean ± sd).", ""]

    lines += ["**Full contact** (eq. 24 against the simulated stress ACF; largest and rms "
              "error over 2 px to L/8, relative to the simulated stress variance):", "",
              "| H | lambda_s (px) | lambda_r / lambda_s | max error | rms error |",
              "|---|---|---|---|---|"]
    for h in hursts:
        for ls in cutoffs:
            sel = [c for k, c in runs.items() if k[0] == h and k[1] == ls]
            lines.append(f"| {h} | {ls:g} | {args.n / args.ratio_l / ls:g} | "
                         f"{ms([float(c.full_contact_error) for c in sel])} | "
                         f"{ms([float(c.full_contact_error_rms) for c in sel])} |")

    lines += ["", "**Contact area** (simulated a_sim, the slope kappa_eff = 2 erfinv(a_sim) "
              "/ (sqrt(pi) p*) that eq. 29 needs to reproduce it, and the relative errors "
              "of the paper's a_r (Persson, kappa = sqrt(8/pi) = 1.60) and a_ri (eq. 50)):",
              "", "| H | lambda_s (px) | p* | a_sim | kappa_eff | a_r / a_sim - 1 | "
              "a_ri / a_sim - 1 |", "|---|---|---|---|---|---|---|"]
    for h in hursts:
        for ls in cutoffs:
            sel = [c for k, c in runs.items() if k[0] == h and k[1] == ls]
            for i, p in enumerate(loads):
                area = [float(c.contact_area[i]) for c in sel]
                err = [c.area_error.sel(theory=t).values[i] for c in sel
                       for t in ("persson",)]
                erri = [c.area_error.sel(theory="modified").values[i] for c in sel]
                lines.append(f"| {h} | {ls:g} | {p:g} | {ms(area)} | "
                             f"{ms([kappa_eff(c)[i] for c in sel])} | {ms(err)} | "
                             f"{ms(erri)} |")

    lines += ["", "**kappa against resolution** (kappa_eff at the smallest load with at "
              "least 100 contact pixels, mean ± sd over seeds, and its extrapolation "
              "kappa_inf + b / lambda_s to infinite resolution):", "",
              "| H | " + " | ".join(f"lambda_s = {ls:g} px" for ls in cutoffs)
              + " | kappa_inf |", "|---" * (len(cutoffs) + 2) + "|"]
    for h in hursts:
        row, means = [], []
        for ls in cutoffs:
            vals = []
            for k, c in runs.items():
                if k[0] == h and k[1] == ls:
                    ok = np.flatnonzero(c.contact_area.values * args.n**2 >= 100)
                    vals.append(kappa_eff(c)[ok[0]] if ok.size else np.nan)
            row.append(ms(vals))
            means.append(np.nanmean(vals))
        inf = "–"
        if len(cutoffs) >= 2 and np.all(np.isfinite(means)):
            b, k_inf = np.polyfit(1 / np.asarray(cutoffs), means, 1)
            inf = f"{k_inf:.2f}"
        lines.append(f"| {h} | " + " | ".join(row) + f" | {inf} |")

    theories = [str(t) for t in first.theory.values]
    lines += ["", "**Stress ACF in partial contact** (largest |G_sigma - G_sigma_sim| over "
              "2 px to L/8 relative to <p^2>, per theory):", "",
              "| H | lambda_s (px) | p* | " + " | ".join(theories) + " |",
              "|---|---|---" + "|---" * len(theories) + "|"]
    for h in hursts:
        for ls in cutoffs:
            sel = [c for k, c in runs.items() if k[0] == h and k[1] == ls]
            for i, p in enumerate(loads):
                errs = [ms([float(c.stress_error.sel(theory=t)[i]) for c in sel])
                        for t in theories]
                lines.append(f"| {h} | {ls:g} | {p:g} | " + " | ".join(errs) + " |")
    secs = sum(float(c.attrs.get("seconds", 0)) for c in runs.values())
    lines += ["", f"{len(runs)} runs, {secs / 60:.1f} min of solving."]
    return "\n".join(lines)


def _panels(n: int):
    fig, axes = plt.subplots(1, n, figsize=(5 * n, 4), squeeze=False,
                             constrained_layout=True)
    return fig, axes[0]


def _save(fig, path: Path) -> Path:
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def figures(args, runs: dict, out: Path) -> list[Path]:
    """The paper's Figs. 5-7 and the area and kappa plots, as PNGs."""
    hursts = sorted({k[0] for k in runs})
    cutoffs = sorted({k[1] for k in runs})
    ls0 = cutoffs[0]
    paths = []

    # Fig. 5: full contact on log axes, negative values (ringing) as open markers
    fig, axes = _panels(len(hursts))
    for ax, h in zip(axes, hursts):
        c = runs[(h, ls0, 0)]
        dr = c.dr.values
        sim, th = c.G_sigma_full_sim.values, c.G_sigma_full.values
        ax.loglog(dr[sim > 0], sim[sim > 0], "o", ms=4, color="C0", label="simulation")
        ax.loglog(dr[sim < 0], -sim[sim < 0], "o", ms=4, mfc="none", color="C0",
                  label="simulation < 0")
        ax.loglog(dr[th > 0], th[th > 0], "-", color="C3", label="eq. 24 from G")
        ax.loglog(dr[th < 0], -th[th < 0], "x", color="C3", label="eq. 24 < 0")
        ax.set(xlabel="dr (px)", ylabel="|G_sigma_full| (Pa^2)",
               title=f"H = {h}, lambda_s = {ls0:g} px: full contact")
        ax.legend(fontsize=7)
    paths.append(_save(fig, out / "fig5_full_contact.png"))

    # Figs. 6-7: reduced stress ACF at two loads, theories and eq. 51
    fig, axes = _panels(len(hursts))
    for ax, h in zip(axes, hursts):
        c = runs[(h, ls0, 0)]
        dr = c.dr.values
        picks = [int(np.argmin(np.abs(c.p_star.values - p))) for p in (0.01, 0.1)]
        for i, color in zip(picks, ("C0", "C3")):
            sub = c.isel(p0=i)
            ax.loglog(dr, sub.Gamma_sigma_sim, "o", ms=4, color=color,
                      label=f"simulation, p* = {float(sub.p_star):.2g}")
            for t, ls in (("persson", "--"), ("modified", "-"), ("modified_ar2", "-."),
                          ("persson_kappa", ":")):
                if t in c.theory:
                    ax.loglog(dr, sub.Gamma_sigma.sel(theory=t), ls, color=color,
                              label=t if i == picks[0] else None)
            if i == picks[0] and "Gamma_sigma_51" in c:
                ax.loglog(dr, sub.Gamma_sigma_51, color="0.4", ls=(0, (1, 3)),
                          label="eq. 51 as printed")
        ax.set(xlabel="dr (px)", ylabel="Gamma_sigma (Pa^2)",
               title=f"H = {h}, lambda_s = {ls0:g} px: partial contact")
        ax.legend(fontsize=7)
    paths.append(_save(fig, out / "fig67_partial_contact.png"))

    # contact area and kappa
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4), constrained_layout=True)
    ps = np.geomspace(min(args.loads) / 2, 1, 200)
    for (h, ls, seed), c in runs.items():
        m = "os^v"[hursts.index(h) % 4]
        color = f"C{cutoffs.index(ls)}"
        label = f"H = {h}, lambda_s = {ls:g} px" if seed == 0 else None
        ax.loglog(c.p_star, c.contact_area, m, ms=4, color=color, label=label)
        bx.semilogx(c.p_star, kappa_eff(c), m + "-", ms=4, color=color, lw=0.6,
                    label=label)
    ax.loglog(ps, erf(np.sqrt(2) * ps), "k--", label="a_r, Persson (eq. 29)")
    a_r = erf(np.sqrt(2) * ps)
    ax.loglog(ps, (1 - a_r**2) * erf(np.sqrt(np.pi) * ps) + a_r**3, "k-",
              label="a_ri (eq. 50)")
    ax.set(xlabel="p* = p0 / (E* gbar(0))", ylabel="relative contact area",
           ylim=(1e-4, 1.5))
    ax.legend(fontsize=7)
    bx.axhline(np.sqrt(8 / np.pi), color="k", ls="--", lw=0.8, label="sqrt(8/pi)")
    bx.axhline(2.0, color="k", lw=0.8, label="2 (a_ri)")
    bx.set(xlabel="p*", ylabel="kappa_eff = 2 erfinv(a_sim) / (sqrt(pi) p*)")
    bx.legend(fontsize=7)
    paths.append(_save(fig, out / "area_kappa.png"))
    return paths


def main(argv=None) -> str:
    args = parse(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    runs = {}
    todo = [(h, ls, s) for h in args.hurst for ls in args.lambda_s
            for s in range(args.seeds)]
    for k, (h, ls, s) in enumerate(todo):
        path = out / "runs" / run_name(args.n, h, ls, s, args.ratio_l, args.rolloff)
        if args.summary_only and not path.exists():
            continue
        t0 = time.perf_counter()
        runs[(h, ls, s)] = one_run(args, h, ls, s)
        print(f"[{k + 1}/{len(todo)}] H = {h}, lambda_s = {ls:g} px, seed {s}: "
              f"{time.perf_counter() - t0:.1f} s", flush=True)
    table = summarise(args, runs)
    (out / "tables.md").write_text(table + "\n")
    for path in figures(args, runs, out):
        print("wrote", path)
    print(table)
    return table


if __name__ == "__main__":
    main()
