"""Command line: ``xrough demo | info | acf | report``.

``xrough demo`` generates a synthetic self-affine surface, computes its G(dr) with both
estimators, compares them with the exact G of the model spectrum (eq. 9), fits G, runs the
contact mechanics (elastic energy, real-space Persson theory, adhesive patch radius),
archives the results to NetCDF, draws a figure and prints a summary table.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from tqdm.auto import tqdm

from . import units as u
from ._version import __version__
from .io import open_topography
from .io.archive import save_analysis
from .preprocess import detrend
from .spectra import acf_from_spectrum, model_spectrum
from .synthetic import self_affine_surface

__all__ = ["main"]


def _demo(args: argparse.Namespace) -> int:
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    print(f"xrough {__version__} demo: synthetic self-affine surface, "
          f"{args.n}x{args.n} points, H = {args.hurst}")
    lambda_s = f"{4 * 16 / args.n!r} um"  # the short cutoff at four pixels
    topo = self_affine_surface(hurst=args.hurst, lambda_r="2 um", lambda_s=lambda_s,
                                      size="16 um", n=args.n, rms_gradient=0.5,
                                      seed=args.seed, unit="um")
    t0 = time.perf_counter()
    G = topo.rough.acf(points_per_decade=10)
    t_fft = time.perf_counter() - t0
    t0 = time.perf_counter()
    Gr = topo.rough.acf(estimator="random", n_pairs=args.pairs, seed=args.seed,
                        points_per_decade=10)
    t_rnd = time.perf_counter() - t0
    exact = acf_from_spectrum(model_spectrum(
        hurst=args.hurst, lambda_r="2 um", lambda_s=lambda_s, lambda_0="16 um",
        rms_gradient=0.5, unit="um"), dr=G.dr.values)
    fit = G.rough.fit()
    E_star, p0, gamma = "25 MPa", "0.1 MPa", "50 mJ/m^2"
    contact = G.rough.persson(E_star=E_star, p0=p0)
    energy = G.rough.energy(E_star=E_star)
    patch = G.rough.patch_radius(E_star=E_star, gamma=gamma)
    topo.to_netcdf(out / "topography.nc")
    G.to_netcdf(out / "G_fft.nc")
    Gr.to_netcdf(out / "G_random.nc")
    contact.to_netcdf(out / "persson.nc")
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    topo.rough.plot(ax=axes[0])
    G.rough.plot(ax=axes[1], label="all pairs (FFT)")
    Gr.rough.plot(ax=axes[1], label=f"random pairs ({args.pairs:,} pairs)", linestyle="--")
    axes[1].plot(exact.dr, exact, "k:", label="model spectrum, eq. 9")
    axes[1].legend()
    axes[2].semilogx(contact.dr, contact.a_r)
    axes[2].set_xlabel(f"resolution dr ({G.dr.attrs['units']})")
    axes[2].set_ylabel("relative contact area a_r")
    axes[0].set_title(f"synthetic surface, H = {args.hurst}, rms gradient 0.5")
    axes[1].set_title("height-difference ACF G(dr)")
    axes[2].set_title(f"Persson theory, E* = {E_star}, p0 = {p0}")
    fig.tight_layout()
    fig.savefig(out / "demo.png", dpi=120)
    rel = np.abs(G.values / exact.values - 1)
    print(f"\n{'dr (um)':>10} {'G fft (um2)':>12} {'G rnd (um2)':>12} {'G eq.9 (um2)':>12} "
          f"{'std err (um2)':>13}")
    for k in range(0, G.sizes["dr"], max(1, G.sizes["dr"] // 8)):
        print(f"{G.dr.values[k]:10.4g} {G.values[k]:12.4g} {Gr.values[k]:12.4g} "
              f"{exact.values[k]:12.4g} {G.standard_error.values[k]:13.2g}")
    print(f"\nrms height {float(topo.std()):.4g} um (model {topo.attrs['rms_height']:.4g}); "
          f"FFT estimator {t_fft:.2f} s, random pairs {t_rnd:.2f} s; median |G/G_model - 1| "
          f"= {np.median(rel):.2%}")
    finest = contact.isel(dr=0)
    rows = [
        ("Hurst exponent H (fit)", f"{float(fit.hurst):.3f} +- {float(fit.hurst_std):.3f}",
         f"{args.hurst}"),
        ("rms height sigma_h (fit)", f"{float(fit.sigma_h):.4g} um",
         f"{topo.attrs['rms_height']:.4g} um"),
        ("roll-off wavelength lambda_r (fit)", f"{float(fit.lambda_r):.3g} um", "2 um"),
        ("elastic energy of full contact", f"{float(energy.v_el):.3g} J/m^2", ""),
        (f"contact area at dr = {float(finest.dr):.3g} um", f"{float(finest.a_r):.3g}", ""),
        (f"contact stress at dr = {float(finest.dr):.3g} um",
         f"{float(finest.sigma_c) / 1e6:.3g} MPa", ""),
        (f"adhesive patch radius (gamma = {gamma})", f"{float(patch.a_c):.3g} um", ""),
    ]
    print(f"\n{'quantity':<40} {'from G':>20} {'model':>10}")
    for name, value, model in rows:
        print(f"{name:<40} {value:>20} {model:>10}")
    print(f"\nwrote {out / 'topography.nc'}, {out / 'G_fft.nc'}, {out / 'G_random.nc'}, "
          f"{out / 'persson.nc'}, {out / 'demo.png'}")
    return 0


def _open(path: str, args: argparse.Namespace):
    size = None
    if args.size:
        parts = [p.strip() for p in args.size.split(",")]
        size = parts[0] if len(parts) == 1 else tuple(parts)
    options = {"channel": args.channel} if getattr(args, "channel", None) else {}
    if getattr(args, "resample", False):
        options["resample"] = True
    topo = open_topography(path, size=size, unit=args.unit, height_scale=args.height_scale,
                           periodic=True if args.periodic else None, **options)
    if getattr(args, "detrend", None) and args.detrend != "none":
        topo = detrend(topo, mode=args.detrend)
    return topo


def _info(args: argparse.Namespace) -> int:
    for path in args.files:
        topo = _open(path, args)
        valid = np.isfinite(topo.values)
        size = " x ".join(f"{float(topo[d][-1] - topo[d][0]) + float(topo[d][1] - topo[d][0]):.4g}"
                          for d in topo.dims if d in ("y", "x"))
        print(f"{path}: {topo.attrs.get('format', '?')}, "
              f"{' x '.join(str(n) for n in topo.shape)} points, "
              f"{size} {topo['x'].attrs['units']}, heights in {topo.attrs['units']}, "
              f"rms {float(np.nanstd(topo.values)):.4g} {topo.attrs['units']}, "
              f"{1 - valid.mean():.1%} missing, periodic={bool(topo.attrs.get('periodic'))}")
        for key, value in topo.attrs.items():
            if key not in ("units", "long_name", "periodic", "format"):
                print(f"    {key}: {value}")
    return 0


def _acfs(args: argparse.Namespace) -> dict:
    results = {}
    for path in tqdm(args.files, desc="G(dr)", disable=None, leave=False):
        topo = _open(path, args)
        G = topo.rough.acf(direction=args.direction, points_per_decade=args.points_per_decade)
        results[Path(path).stem.replace("/", "_") or "measurement"] = {"topography": topo,
                                                                       "G": G}
    return results


def _acf(args: argparse.Namespace) -> int:
    results = _acfs(args)
    tree = {name: {"G": r["G"]} for name, r in results.items()}
    save_analysis(args.output, tree, history="xrough acf " + " ".join(args.files))
    for name, r in results.items():
        G = r["G"]
        print(f"{name}: {G.sizes['dr']} bins, dr {float(G.dr[0]):.4g}..{float(G.dr[-1]):.4g} "
              f"{G.dr.attrs['units']}, G {float(G.min()):.4g}..{float(G.max()):.4g} "
              f"{G.attrs['units']}")
    print(f"wrote {args.output}")
    return 0


def _length_text(value: float, unit: str, *, none: str = "inf") -> str:
    """Format a length with a readable prefix (``12.3 nm``, not ``1.23e-08 m``)."""
    if not np.isfinite(value):
        return none
    q = u.ureg.Quantity(value, u.parse_units(unit)).to_compact()
    return f"{q.magnitude:.4g} {u.format_units(q.units)}"


def _report(args: argparse.Namespace) -> int:
    E_star = u.to_si(args.E_star, "[pressure]", what="--E-star")
    p0 = u.to_si(args.p0, "[pressure]", what="--p0")
    results = _acfs(args)
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    rows = []
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4.5))
    for name, r in results.items():
        G = r["G"]
        fit = G.rough.fit()
        gbar = G.rough.gradient()
        contact = G.rough.persson(E_star=E_star, p0=p0, gradient=gbar, fit=fit)
        energy = G.rough.energy(E_star=E_star)
        r.update(fit=fit, gradient=gbar, persson=contact, energy=energy)
        if args.gamma:
            r["patch"] = G.rough.patch_radius(E_star=E_star, gamma=args.gamma)
        del r["topography"]  # the archive refers to the file (name, SHA-256 in G's attrs)
        unit = G.dr.attrs["units"]
        finest = contact.isel(dr=0)
        patch = "-"
        if args.gamma:
            a_c = float(r["patch"].a_c)
            patch = _length_text(a_c, unit) if np.isfinite(a_c) else "none: sticks everywhere"
        rows.append((name, _length_text(float(fit.sigma_h), unit, none="no plateau"),
                     f"{float(fit.hurst):.3f}+-{float(fit.hurst_std):.3f}",
                     _length_text(float(fit.lambda_r), unit, none="no roll-off"),
                     f"{float(gbar[0]):.3g}",
                     f"{float(energy.v_el):.3g}", f"{float(finest.a_r):.3g}",
                     f"{float(finest.sigma_c) / 1e6:.3g}",
                     f"{_length_text(float(finest.dr), unit)}", patch))
        G.rough.plot(ax=ax0, label=name)
        ax1.semilogx(contact.dr, contact.a_r, label=name)
    ax1.set_xlabel(f"resolution dr ({G.dr.attrs['units']})")
    ax1.set_ylabel(f"relative contact area at p0 = {args.p0}")
    ax1.legend()
    fig.tight_layout()
    png = out.with_suffix(".png")
    fig.savefig(png, dpi=120)
    parameters = f"E_star={args.E_star}, p0={args.p0}, gamma={args.gamma}"
    save_analysis(out, results, history=f"xrough report {' '.join(args.files)} "
                  f"({parameters})")
    head = ("measurement", "sigma_h", "H", "lambda_r", "rms grad", "v_el J/m2", "a_r",
            "sigma_c MPa", "at dr", "patch radius")
    widths = [max(len(h), *(len(r[k]) for r in rows)) for k, h in enumerate(head)]
    print("  ".join(h.ljust(w) for h, w in zip(head, widths)))
    for row in rows:
        print("  ".join(c.ljust(w) for c, w in zip(row, widths)))
    print("rms grad, a_r and sigma_c at the finest resolution where the rms gradient is "
          f"determined (column 'at dr'); {parameters}")
    print(f"wrote {out} and {png}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``xrough`` command."""
    matplotlib.use("Agg")  # figures go to files
    parser = argparse.ArgumentParser(
        prog="xrough", description="Contact mechanics of rough surfaces from the "
        "height-difference autocorrelation function G(dr).")
    parser.add_argument("--version", action="version", version=f"xrough {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="run the main job on built-in synthetic data")
    demo.add_argument("-o", "--output", default="xrough-demo", help="output folder")
    demo.add_argument("-n", type=int, default=1024, help="grid points per side")
    demo.add_argument("--hurst", type=float, default=0.8, help="Hurst exponent, 0 < H < 1")
    demo.add_argument("--pairs", type=int, default=400_000, help="random-pair budget")
    demo.add_argument("--seed", type=int, default=1, help="random seed of the surface")
    demo.set_defaults(func=_demo)

    def file_options(p, detrend=True):
        p.add_argument("files", nargs="+", help="topography files (any supported format)")
        p.add_argument("--size", help="physical size replacing the file's, e.g. '100 nm' or "
                       "'10 um,20 um' (y, x)")
        p.add_argument("--unit", help="length unit replacing the file's (relabels)")
        p.add_argument("--height-scale", type=float, help="factor applied to the heights")
        p.add_argument("--periodic", action="store_true", help="the maps are periodic")
        p.add_argument("--channel", help="channel of multi-channel AFM files")
        p.add_argument("--resample", action="store_true",
                       help="resample non-uniformly sampled profiles onto a uniform grid")
        if detrend:
            p.add_argument("--detrend", default="none",
                           choices=["none", "mean", "plane", "curvature"],
                           help="detrending before G (default none)")

    info = sub.add_parser("info", help="what is in a topography file")
    file_options(info, detrend=False)
    info.set_defaults(func=_info)
    for name, func, helptext in (("acf", _acf, "G(dr) of files, archived to NetCDF"),
                                 ("report", _report, "contact mechanics report of files")):
        p = sub.add_parser(name, help=helptext)
        file_options(p)
        p.add_argument("-o", "--output", default=f"xrough-{name}.nc", help="NetCDF output")
        p.add_argument("--direction", default="radial", choices=["radial", "x", "y"])
        p.add_argument("--points-per-decade", type=float, default=10)
        if name == "report":
            p.add_argument("--E-star", required=True, dest="E_star",
                           help="contact modulus, e.g. 25MPa")
            p.add_argument("--p0", required=True, help="mean pressure, e.g. 0.1MPa")
            p.add_argument("--gamma", help="work of adhesion, e.g. 50mJ/m^2")
        p.set_defaults(func=func)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, TypeError, OSError, KeyError, ImportError) as err:
        message = str(err).splitlines()[0] if str(err) else type(err).__name__
        print(f"xrough: error: {message}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
