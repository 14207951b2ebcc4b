"""Command line: ``xrough demo`` (more subcommands come with the file readers).

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

__all__ = ["main"]


def _demo(args: argparse.Namespace) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    import xrough

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    print(f"xrough {xrough.__version__} demo: synthetic self-affine surface, "
          f"{args.n}x{args.n} points, H = {args.hurst}")
    lambda_s = f"{4 * 16 / args.n!r} um"  # the short cutoff at four pixels
    topo = xrough.self_affine_surface(hurst=args.hurst, lambda_r="2 um", lambda_s=lambda_s,
                                      size="16 um", n=args.n, rms_gradient=0.5,
                                      seed=args.seed, unit="um")
    t0 = time.perf_counter()
    G = topo.rough.acf(points_per_decade=10)
    t_fft = time.perf_counter() - t0
    t0 = time.perf_counter()
    Gr = topo.rough.acf(estimator="random", n_pairs=args.pairs, seed=args.seed,
                        points_per_decade=10)
    t_rnd = time.perf_counter() - t0
    exact = xrough.acf_from_spectrum(xrough.model_spectrum(
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


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``xrough`` command."""
    from . import __version__

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
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, TypeError, OSError) as err:
        print(f"xrough: error: {err}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
