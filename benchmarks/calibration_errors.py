"""Calibration of xrough's statistical error bars over random seeds of synthetic surfaces.

Random periodic self-affine maps (:func:`xrough.self_affine_surface`, sharp roll-off of
eq. 35, Gaussian random amplitudes) of ``--size`` pixels (pixel 1 nm, ``lambda_s`` =
``--lambda-s`` pixels, rms gradient ``--rms-gradient``) in four configurations,
``H`` in {0.5, 0.8} x ``L / lambda_r`` in {2, 8}, each with seeds ``0 .. --seeds - 1``.
Every map goes through the chain a user writes::

    G = topo.rough.acf()                                  # default arguments
    fit = G.rough.fit()
    G.rough.energy(E_star=E_STAR)                         # v_el
    G.rough.gradient(fit=fit)                             # gbar(dr)
    G.rough.persson(E_star=E_STAR, p0=P0, fit=fit)        # a_r(dr), sigma_c(dr)

What is measured, per configuration:

1. **G**: at every lag bin up to ``L/2``, the ratio of the mean over the seeds of G's
   coordinate ``standard_error`` to the standard deviation of G over the seeds (1 is
   calibrated; below 1 the error bars are too small; with N seeds the ratio itself
   scatters by about ``1 / sqrt(2 (N - 1))``, 13 % for 30). Printed: its minimum, median
   and maximum over the bins and the three bins (in pixels) farthest from 1 in log. The
   standard deviation is taken about the seed mean. The exact mean of G over
   realisations is known as well: G of a map of the same model with fixed amplitudes
   ``|h(q)|^2 = C(q) / A`` on every mode (``random_amplitudes=False``; G depends on the
   moduli only, so any phases give the same G) is the lattice sum over the map's modes,
   bin by bin, through the library's own estimator. ``t max`` is the largest
   ``|seed mean - E[G]| / (sd / sqrt(N))`` over the bins (about 2 or less when the
   estimator is unbiased; the bins are correlated, so the largest of them is not a sum of
   independent draws). ``--verbose`` lists every bin, with ``model/E[G] - 1``: how far
   the continuum G of the model spectrum (eq. 9, :func:`xrough.acf_from_spectrum`) lies
   from that lattice sum (largest near ``L/2``).

2. **The predictions of the chain**: the fit's ``sigma_h``, ``hurst`` and ``lambda_r``,
   the elastic energy ``v_el``, ``gbar``, ``a_r`` and ``sigma_c`` at resolution 1 pixel
   and ``lambda_r / 8`` (the bins of G nearest to them in log; their lag is printed).
   Columns:

   * ``truth``: the value of the model spectrum of the surface, from the library
     (``SpectrumModel.moment``: ``sigma_h^2 = moment(0)``, ``v_el = E*/4 moment(1)``,
     eq. 16 of eq. 9; :func:`xrough.gradient_from_spectrum` for ``gbar`` (eq. 26) at the
     bin's lag, :func:`xrough.persson` with that exact ``gbar`` for ``a_r`` and
     ``sigma_c``; the model's ``H`` and ``lambda_r``). The model includes the map's
     longest wavelength ``lambda_0 = L`` as its lower cutoff;
   * ``on E[G]``: the chain run on the fixed-amplitude map above, i.e. on the exact
     expected G of this map size: for ``v_el``, nearly linear in G, close to the mean of
     the estimator; for the others their value at the mean G. Its distance from
     ``truth`` is what the map's lattice of modes and the estimator do, not scatter;
   * ``mean``, ``sd/mean``: over the seeds (``n``: seeds with a finite value);
   * ``bias``: ``(mean - truth) / sd``; noise alone gives about ``1 / sqrt(n)``;
   * ``std/sd``: mean of the stated one-sigma error ``<name>_std`` over the seeds, divided
     by the scatter over the seeds (1 is calibrated, whatever the bias; noise about
     ``1 / sqrt(2 (n - 1))``);
   * ``z mean``, ``z sd``, ``|z|>2``: of ``z = (X - truth) / X_std`` (calibrated and
     unbiased: 0, 1 and about 5 %).

   The stated error is the variable ``<name>_std`` of the result (a coordinate of that
   name, or ``standard_error`` on a DataArray, counts as well); where a result has none
   the last four columns are ``-``. ``truth`` is ``-`` where the library gives no exact
   value; then ``bias`` and ``z`` use the seed mean instead and say so.

3. **Run time**: seconds per configuration (every seed, the fixed-amplitude map and the
   truth), after an untimed warm-up, in one process. Failing seeds are reported with
   their error and left out; warnings (e.g. :class:`xrough.QualityWarning`) and quality
   marks other than good are counted per configuration.

Seed ``s`` draws the same white noise in every configuration (only the spectrum that
shapes it differs), so the configurations are not independent samples of each other.

Usage::

    python benchmarks/calibration_errors.py                      # 4 x 30 maps of 256^2, ~25 s
    python benchmarks/calibration_errors.py --size 512 --hurst 0.8 --ratio 8   # ~5 s
    python benchmarks/calibration_errors.py --seeds 10 --verbose --markdown
"""

from __future__ import annotations

import argparse
import collections
import re
import sys
import time
import traceback
import warnings

import numpy as np

import xrough
from xrough._kernels.uncertainty import g_variance
from xrough.memo import forget
from xrough.models import model_from_attrs

E_STAR, P0 = "25 MPa", "0.15 MPa"  # a_r about 0.1 to 0.3 at rms gradient 0.1
#: Scalar predictions: name, the result it comes from, the variable, the lag (None, or
#: "pixel" / "lambda_r/8").
QUANTITIES = (
    ("sigma_h", "fit", "sigma_h", None),
    ("hurst", "fit", "hurst", None),
    ("lambda_r", "fit", "lambda_r", None),
    ("v_el", "energy", "v_el", None),
    ("gbar(1 px)", "gradient", "gbar", "pixel"),
    ("gbar(lr/8)", "gradient", "gbar", "lambda_r/8"),
    ("a_r(1 px)", "persson", "a_r", "pixel"),
    ("a_r(lr/8)", "persson", "a_r", "lambda_r/8"),
    ("sigma_c(1 px)", "persson", "sigma_c", "pixel"),
    ("sigma_c(lr/8)", "persson", "sigma_c", "lambda_r/8"),
)
RESULTS = ("fit", "gradient", "energy", "persson")


# ---------------------------------------------------------------------------------------
# one map through the chain
# ---------------------------------------------------------------------------------------
def surface(cfg: dict, seed: int, random_amplitudes: bool = True):
    n = cfg["n"]
    return xrough.self_affine_surface(
        hurst=cfg["hurst"], lambda_r=n / cfg["ratio"], lambda_s=cfg["lambda_s"],
        size=float(n), n=n, rms_gradient=cfg["rms_gradient"], unit="nm", seed=seed,
        random_amplitudes=random_amplitudes)


def chain(topo, e_star: str, p0: str) -> dict:
    G = topo.rough.acf()
    fit = G.rough.fit()
    return {"G": G, "fit": fit,
            "energy": G.rough.energy(E_star=e_star),
            "gradient": G.rough.gradient(fit=fit),
            "persson": G.rough.persson(E_star=e_star, p0=p0, fit=fit)}


def lag_index(dr: np.ndarray, target: float) -> int:
    """The bin of G nearest to ``target`` in log."""
    return int(np.argmin(np.abs(np.log(dr / target))))


def stated_std(result, var: str, k: int | None) -> float:
    """The one-sigma error the result states for ``var`` (NaN: none)."""
    names = [f"{var}_std"]
    if not hasattr(result, "data_vars"):  # a DataArray: its own error coordinate
        names.append("standard_error")
    for name in names:
        if name in result.coords or (hasattr(result, "data_vars") and name in result):
            v = result[name]
            return float(v.isel(dr=k) if k is not None and "dr" in v.dims else v)
    return np.nan


def values(res: dict, lags: dict) -> dict:
    """Each quantity's value and stated error: ``{name: (x, std)}``."""
    out = {}
    for name, result, var, lag in QUANTITIES:
        r = res[result]
        da = r[var] if hasattr(r, "data_vars") else r
        k = None if lag is None else lags[lag]
        x = float(da.isel(dr=k) if k is not None else da)
        out[name] = (x, stated_std(r, var, k))
    return out


def quality_of(result) -> str:
    return str(result.attrs.get("quality", "good"))


def warning_key(w) -> str:
    """One warning, numbers blanked so that one cause is one key."""
    text = re.sub(r"[-+]?\d[\d.e+-]*", "#", str(w.message))
    return f"{w.category.__name__}: {text[:110]}"


# ---------------------------------------------------------------------------------------
# truth of the model spectrum
# ---------------------------------------------------------------------------------------
def lattice_moments(topo, dr: np.ndarray) -> dict:
    """The exact expectations of the map's own lattice of modes (fixed-amplitude map).

    ``sigma_h^2 = sum |h_q|^2``, ``int G / r^2 dr = sum |q| |h_q|^2`` (eq. 16 over the
    modes) and ``gbar^2(dr) = sum_{|q| < 2 pi / dr} q^2 |h_q|^2`` (eq. 26), the mean (q = 0)
    left out; in the map's unit (nm).
    """
    h = topo.values
    power = np.abs(np.fft.fft2(h) / h.size) ** 2
    power[0, 0] = 0.0
    q1 = [2 * np.pi * np.fft.fftfreq(k, d=float(abs(topo[d][1] - topo[d][0])))
          for k, d in zip(h.shape, topo.dims)]
    q = np.hypot(q1[0][:, None], q1[1][None, :])
    order = np.argsort(q, axis=None)
    qs, cum = q.ravel()[order], np.cumsum((q**2 * power).ravel()[order])
    below = np.searchsorted(qs, 2 * np.pi / dr, side="left")  # modes with |q| < 2 pi / dr
    gbar = np.sqrt(np.where(below > 0, cum[np.maximum(below - 1, 0)], 0.0))
    return {"sigma_h": float(np.sqrt(power.sum())), "energy": float((q * power).sum()),
            "gbar": gbar}


def truth(cfg: dict, topo, G, lags: dict, e_star_pa: float, p0: str) -> dict:
    """Each quantity's exact value (NaN where there is none): of the map's lattice of modes
    (``values``), and of the continuum model spectrum (``continuum``)."""
    n = cfg["n"]
    model = model_from_attrs(topo.attrs)
    C = xrough.model_spectrum(hurst=cfg["hurst"], lambda_r=n / cfg["ratio"],
                              lambda_s=cfg["lambda_s"], lambda_0=float(n),
                              rms_gradient=cfg["rms_gradient"], unit="nm")
    dr = G.dr.values
    lattice = lattice_moments(topo, dr)
    nm = xrough.units.conversion_factor("nm", "m")
    out, continuum = {}, {}
    for kind, sigma_h, energy, gbar_values in (
            ("lattice", lattice["sigma_h"], lattice["energy"], lattice["gbar"]),
            ("continuum", float(np.sqrt(model.moment(0))), model.moment(1),
             xrough.gradient_from_spectrum(C, dr).values)):
        gbar = xrough.gradient_from_spectrum(C, dr).copy(data=gbar_values)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            Gm = xrough.acf_from_spectrum(C, dr)
            pers = xrough.persson(Gm, E_star=e_star_pa, p0=p0, gradient=gbar,
                                  variables=("a_r", "sigma_c"))
        values = {"sigma_h": sigma_h, "hurst": model.hurst, "lambda_r": 2 * np.pi / model.q_r,
                  "v_el": e_star_pa / 4 * energy * nm}
        for name, _, var, lag in QUANTITIES:
            if lag is not None:
                source = gbar if var == "gbar" else pers[var]
                values[name] = float(source.isel(dr=lags[lag]))
        (out if kind == "lattice" else continuum).update(values)
    return {"values": out, "continuum": continuum, "G_model": Gm.values}


# ---------------------------------------------------------------------------------------
# one configuration
# ---------------------------------------------------------------------------------------
def run_config(cfg: dict, args) -> dict:
    t0 = time.perf_counter()
    n = cfg["n"]
    G_vals, se_vals, real_vals, xs, stds = [], [], [], [], []
    failed: list[str] = []
    warned: dict[str, list[int]] = collections.defaultdict(list)  # warning -> seeds
    marks: collections.Counter = collections.Counter()
    lags = None
    for seed in range(args.seeds):
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                res = chain(surface(cfg, seed), E_STAR, args.p0)
                dr = res["G"].dr.values
                if lags is None:
                    lags = {"pixel": lag_index(dr, 1.0),
                            "lambda_r/8": lag_index(dr, n / cfg["ratio"] / 8)}
                    keep = dr <= n / 2
                    dr0 = dr
                elif not np.array_equal(dr, dr0):
                    raise RuntimeError("the lags of G differ between seeds")
                v = values(res, lags)
            for key in dict.fromkeys(warning_key(w) for w in caught):
                warned[key].append(seed)
            for r in RESULTS:
                marks[r, quality_of(res[r])] += 1
            G_vals.append(res["G"].values[keep])
            se_vals.append(res["G"].standard_error.values[keep])
            real_vals.append(real_space_se(res["G"], n)[keep])
            xs.append([v[q[0]][0] for q in QUANTITIES])
            stds.append([v[q[0]][1] for q in QUANTITIES])
        except Exception as err:  # noqa: BLE001 - a failing seed is reported, not fatal
            frames = traceback.extract_tb(err.__traceback__)
            where = ([f for f in frames if "site-packages" not in f.filename]
                     or frames)[-1]  # the innermost line of xrough or of this script
            failed.append(f"seed {seed}: {type(err).__name__}: {err} "
                          f"[{where.filename.split('/')[-1]}:{where.lineno}]")
            print(f"\n    failed: {failed[-1]}", file=sys.stderr, flush=True)
        finally:
            forget()  # results kept by content: bounded memory, every seed a first run
    out = {"cfg": cfg, "failed": failed, "warned": warned, "marks": marks,
           "ok": len(G_vals)}
    if len(G_vals) < 2:
        out["seconds"] = time.perf_counter() - t0
        return out
    # the exact mean of G and the chain on it: the fixed-amplitude map
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fixed_topo = surface(cfg, 0, random_amplitudes=False)
        fixed = chain(fixed_topo, E_STAR, args.p0)
        on_mean = values(fixed, lags)
        t = truth(cfg, fixed_topo, fixed["G"], lags, fixed["energy"].attrs["E_star"],
                  args.p0)
    forget()
    out.update(
        dr=dr0[keep], G=np.array(G_vals), se=np.array(se_vals),
        real_space=np.array(real_vals),
        G_exact=fixed["G"].values[keep], G_model=t["G_model"][keep],
        x=np.array(xs), std=np.array(stds), truth=t["values"], continuum=t["continuum"],
        on_mean={k: v[0] for k, v in on_mean.items()},
        lag_px={k: float(dr0[i]) for k, i in lags.items()},
        fixed_warnings=sorted({warning_key(w) for w in caught}),
        seconds=time.perf_counter() - t0)
    return out


# ---------------------------------------------------------------------------------------
# statistics and tables
# ---------------------------------------------------------------------------------------
def fmt(x: float, digits: int = 4) -> str:
    if x is None or not np.isfinite(x):
        return "-" if x is None or np.isnan(x) else ("inf" if x > 0 else "-inf")
    return f"{x:.{digits}g}"


def table(title: str, cols: list[str], rows: list[list[str]], markdown: bool) -> None:
    if markdown:
        cols = [c.replace("|", "\\|") for c in cols]
        rows = [[c.replace("|", "\\|") for c in row] for row in rows]
        print(f"\n**{title}**\n")
        print("| " + " | ".join(cols) + " |")
        print("|:---|" + "---:|" * (len(cols) - 1))
        for row in rows:
            print("| " + " | ".join(row) + " |")
        return
    widths = [max([len(c), *(len(r[k]) for r in rows)]) for k, c in enumerate(cols)]
    print(f"\n{title}")
    head = "  ".join(c.ljust(w) if k == 0 else c.rjust(w)
                     for k, (c, w) in enumerate(zip(cols, widths)))
    print(head)
    print("-" * len(head))
    for row in rows:
        print("  ".join(c.ljust(w) if k == 0 else c.rjust(w)
                        for k, (c, w) in enumerate(zip(row, widths))))


def real_space_se(G, n: int) -> np.ndarray:
    """The finite-area standard error of the real-space closure
    (:func:`xrough._kernels.uncertainty.g_variance`, what ``standard_error`` was before it
    became :func:`~xrough._kernels.uncertainty.finite_area_variance`), for comparison."""
    return np.sqrt(g_variance(
        G.dr.values, G.values, G.pair_count.values, area=float(n * n), pixel_area=1.0,
        geometry=G.attrs["lag_geometry"]))


def g_stats(res: dict) -> dict:
    G, se = res["G"], res["se"]
    N = G.shape[0]
    sd = G.std(axis=0, ddof=1)
    ratio = se.mean(axis=0) / sd
    t = (G.mean(axis=0) - res["G_exact"]) / (sd / np.sqrt(N))
    return {"sd": sd, "ratio": ratio, "t": t, "N": N,
            "real_space": res["real_space"].mean(axis=0) / sd}


def g_table(results: list[dict], markdown: bool) -> None:
    rows = []
    for res in results:
        if res["ok"] < 2:
            continue
        s = g_stats(res)
        r = s["ratio"]
        worst = np.argsort(-np.abs(np.log(r)))[:3]
        rows.append([res["cfg"]["label"], str(s["N"]), str(r.size), f"{r.min():.3f}",
                     f"{np.median(r):.3f}", f"{r.max():.3f}",
                     ", ".join(f"{res['dr'][k]:.3g}: {r[k]:.2f}" for k in worst),
                     f"{s['real_space'].min():.3f}", f"{s['real_space'].max():.3f}",
                     f"{np.abs(s['t']).max():.2f}"])
    noise = 1 / np.sqrt(2 * (max(r["ok"] for r in results) - 1)) if rows else np.nan
    table("G: mean(standard_error) / sd(G) over the seeds, per lag bin up to L/2 (sd about "
          f"the seed mean; noise of the ratio ~ {noise:.2f}); t max = max |mean - E[G]| / "
          "(sd / sqrt(N)), E[G] exact (fixed-amplitude map)",
          ["configuration", "seeds", "bins", "min", "median", "max",
           "worst bins (dr px: ratio)", "real-space min", "real-space max", "t max"], rows,
          markdown)


def g_listing(res: dict, markdown: bool) -> None:
    s = g_stats(res)
    rows = [[f"{res['dr'][k]:.4g}", fmt(res["G"][:, k].mean()), fmt(res["G_exact"][k]),
             fmt(s["sd"][k], 3), fmt(res["se"][:, k].mean(), 3), f"{s['ratio'][k]:.3f}",
             f"{s['t'][k]:+.2f}", f"{res['G_model'][k] / res['G_exact'][k] - 1:+.4f}"]
            for k in range(res["dr"].size)]
    table(f"G per bin, {res['cfg']['label']} (nm^2)",
          ["dr px", "mean G", "E[G]", "sd", "mean se", "se/sd", "t", "model/E[G]-1"],
          rows, markdown)


def quantity_table(res: dict, markdown: bool) -> None:
    rows = []
    for j, (name, _, _, lag) in enumerate(QUANTITIES):
        x, std = res["x"][:, j], res["std"][:, j]
        ok = np.isfinite(x)
        xo = x[ok]
        mean = xo.mean() if xo.size else np.nan
        sd = xo.std(ddof=1) if xo.size > 1 else np.nan
        true = res["truth"].get(name, np.nan)
        ref = true if np.isfinite(true) else mean  # no exact value: the seed mean
        has_std = np.isfinite(std[ok]).any()
        if has_std:
            good = ok & np.isfinite(std) & (std > 0)
            z = (x[good] - ref) / std[good]
            zcols = [fmt(np.nanmean(std[good]) / sd, 3), f"{z.mean():+.2f}",
                     f"{z.std(ddof=1):.2f}", f"{np.mean(np.abs(z) > 2):.0%}"]
        else:
            zcols = ["-"] * 4
        label = name if lag is None else f"{name} [{res['lag_px'][lag]:.3g}]"
        rows.append([label, f"{ok.sum()}/{x.size}", fmt(res["continuum"].get(name, np.nan)),
                     fmt(true) if np.isfinite(true) else "- (seed mean)",
                     fmt(res["on_mean"][name]), fmt(mean), fmt(sd / abs(mean), 3),
                     f"{(mean - ref) / sd:+.2f}" if sd > 0 else "-", *zcols])
    cfg = res["cfg"]
    table(f"{cfg['label']}: predictions over {res['ok']} seeds (sigma_h, lambda_r in nm; "
          f"v_el in J/m^2; sigma_c in Pa; [dr of the bin used, px]); noise of bias ~ "
          f"{1 / np.sqrt(res['ok']):.2f}, of std/sd ~ "
          f"{1 / np.sqrt(2 * (res['ok'] - 1)):.2f}",
          ["quantity", "n", "continuum", "truth", "on E[G]", "mean", "sd/mean", "bias", "std/sd",
           "z mean", "z sd", "|z|>2"], rows, markdown)


def report(results: list[dict], args, total: float) -> None:
    g_table(results, args.markdown)
    for res in results:
        if args.verbose and res["ok"] >= 2:
            g_listing(res, args.markdown)
    for res in results:
        if res["ok"] >= 2:
            quantity_table(res, args.markdown)
        else:
            print(f"\n{res['cfg']['label']}: {res['ok']} seed(s) went through: no scatter")
    rows = []
    for res in results:
        marks = res["marks"]
        rows.append([res["cfg"]["label"], str(res["ok"]), str(len(res["failed"])),
                     f"{res['seconds']:.1f}", f"{res['seconds'] / args.seeds:.2f}",
                     *(f"{marks[r, 'questionable']}/{marks[r, 'failed']}"
                       for r in RESULTS)])
    table(f"run time (wall, one process) and quality marks (questionable/failed) over the "
          f"seeds; total {total:.1f} s",
          ["configuration", "ok", "failed", "seconds", "s/seed",
           *(f"{r} q/f" for r in RESULTS)], rows, args.markdown)
    for res in results:
        label = res["cfg"]["label"]
        if res["failed"]:
            print(f"\n{label}: {len(res['failed'])} seed(s) failed:")
            for why in res["failed"]:
                print(f"  {why}")
        if res["warned"]:
            print(f"\n{label}: warnings (numbers as #), how many seeds raised each, and "
                  "which:")
            for key, seeds in sorted(res["warned"].items(), key=lambda kv: -len(kv[1])):
                which = ", ".join(map(str, seeds[:12])) + (" ..." if len(seeds) > 12 else "")
                print(f"  {len(seeds):4d}  {key}\n        seeds {which}")
        if res.get("fixed_warnings"):
            print(f"{label}: warnings on the fixed-amplitude map (E[G]):")
            for key in res["fixed_warnings"]:
                print(f"        {key}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256, help="pixels per side (e.g. 512)")
    parser.add_argument("--seeds", type=int, default=30, help="seeds 0 .. N-1")
    parser.add_argument("--hurst", type=float, nargs="+", default=[0.5, 0.8])
    parser.add_argument("--ratio", type=float, nargs="+", default=[2.0, 8.0],
                        help="L / lambda_r")
    parser.add_argument("--lambda-s", type=float, default=4.0, help="pixels")
    parser.add_argument("--rms-gradient", type=float, default=0.1)
    parser.add_argument("--p0", default=P0, help=f"mean pressure (default {P0}; E* is "
                        f"{E_STAR})")
    parser.add_argument("--verbose", action="store_true", help="G bin by bin")
    parser.add_argument("--markdown", action="store_true", help="Markdown tables")
    args = parser.parse_args(argv)
    if args.seeds < 2:
        parser.error("--seeds must be at least 2 (a scatter needs two)")
    configs = [dict(hurst=h, ratio=r, n=args.size, lambda_s=args.lambda_s,
                    rms_gradient=args.rms_gradient,
                    label=f"H={h:g} L/lambda_r={r:g} n={args.size}")
               for h in args.hurst for r in args.ratio]
    print(f"{len(configs)} configuration(s) x {args.seeds} seeds, {args.size}^2 pixels of "
          f"1 nm, lambda_s = {args.lambda_s:g} px, rms gradient {args.rms_gradient:g}, "
          f"E* = {E_STAR}, p0 = {args.p0}; xrough {xrough.__version__}")
    with warnings.catch_warnings():  # warm-up, untimed: lazy imports, first calls
        warnings.simplefilter("ignore")
        chain(surface(dict(configs[0], n=64, ratio=2.0), 0), E_STAR, args.p0)
    forget()
    t0 = time.perf_counter()
    results = []
    for cfg in configs:
        print(f"  {cfg['label']} ...", end=" ", flush=True)
        results.append(run_config(cfg, args))
        print(f"{results[-1]['seconds']:.1f} s", flush=True)
    report(results, args, time.perf_counter() - t0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
