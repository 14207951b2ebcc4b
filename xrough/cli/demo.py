"""``xrough demo``: the main job on a synthetic self-affine surface.

It computes G(dr) with both estimators, compares them with the exact G of the model
spectrum (eq. 9), fits G, runs the contact mechanics (elastic energy, real-space Persson
theory, adhesive patch radius), archives the results to NetCDF, draws a figure and prints
a summary table.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from .._version import __version__
from ..io.netcdf import write as write_netcdf
from ..plot import plot_dataset, pyplot
from ..spectra import acf_from_spectrum, model_spectrum
from ..synthetic import self_affine_surface
from ._common import (
    EXIT_OK,
    CLIError,
    exact_of,
    finest,
    output,
    show,
    show_errors,
    text,
    write_atomic,
)

#: Grid limits: below 64 points the short cutoff (4 pixels) passes the roll-off.
_N = (64, 8192)
#: The model: roll-off, size and rms gradient of the surface.
_LAMBDA_R, _SIZE, _RMS_GRADIENT = "2 um", "16 um", 0.5
#: The contact problem solved on it.
_E_STAR, _P0, _GAMMA = "25 MPa", "0.1 MPa", "50 mJ/m^2"
_FILES = ("topography.nc", "G_fft.nc", "G_random.nc", "persson.nc", "demo.png")


def add_parser(sub, **common) -> None:
    """Add ``demo`` to the commands ``sub``."""
    demo = sub.add_parser("demo", help="run the main job on built-in synthetic data",
                          **common)
    demo.add_argument("-o", "--output", default="xrough-demo",
                      help="output folder (created if missing)")
    demo.add_argument("-n", type=int, default=1024,
                      help=f"grid points per side ({_N[0]} to {_N[1]})")
    demo.add_argument("--hurst", type=float, default=0.8, help="Hurst exponent, 0 < H < 1")
    demo.add_argument("--pairs", type=int, default=400_000, help="random-pair budget")
    demo.add_argument("--seed", type=int, default=1, help="random seed of the surface")
    demo.set_defaults(func=run)


def _check(args: argparse.Namespace) -> None:
    lo, hi = _N
    if not lo <= args.n <= hi:
        raise CLIError(f"-n {args.n}: grid points per side must be {lo} to {hi}")
    if not 0 < args.hurst < 1:
        raise CLIError(f"--hurst {args.hurst}: the Hurst exponent must be between 0 and 1")
    if args.pairs < 1000:
        raise CLIError(f"--pairs {args.pairs}: the random-pair budget must be at least 1000")


def _timed(compute):
    t0 = time.perf_counter()
    result = compute()
    return result, time.perf_counter() - t0


def _compute(args: argparse.Namespace) -> dict:
    """Compute the surface, its G by both estimators, the exact G and the contact mechanics."""
    lambda_s = f"{4 * 16 / args.n!r} um"  # the short cutoff at four pixels
    topo = self_affine_surface(hurst=args.hurst, lambda_r=_LAMBDA_R, lambda_s=lambda_s,
                               size=_SIZE, n=args.n, rms_gradient=_RMS_GRADIENT,
                               seed=args.seed, unit="um")
    G, t_fft = _timed(lambda: topo.rough.acf(points_per_decade=10))
    Gr, t_rnd = _timed(lambda: topo.rough.acf(estimator="random", n_pairs=args.pairs,
                                              seed=args.seed, points_per_decade=10))
    exact = acf_from_spectrum(model_spectrum(
        hurst=args.hurst, lambda_r=_LAMBDA_R, lambda_s=lambda_s, lambda_0=_SIZE,
        rms_gradient=_RMS_GRADIENT, unit="um"), dr=G.dr.values)
    return {"topo": topo, "G": G, "Gr": Gr, "exact": exact, "t_fft": t_fft,
            "t_rnd": t_rnd, "fit": G.rough.fit(),
            "contact": G.rough.persson(E_star=_E_STAR, p0=_P0),
            "energy": G.rough.energy(E_star=_E_STAR),
            "patch": G.rough.patch_radius(E_star=_E_STAR, gamma=_GAMMA)}


def _figure(r: dict, args: argparse.Namespace):
    """Draw the surface, G by both estimators with the exact G, and the contact area."""
    G, contact = r["G"], r["contact"]
    plt = pyplot("Agg")  # figures go to files
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5), layout="constrained")  # titles fit
    r["topo"].rough.plot(ax=axes[0])
    G.rough.plot(ax=axes[1], label="all pairs (FFT)")
    r["Gr"].rough.plot(ax=axes[1], label=f"random pairs ({args.pairs:,} pairs)",
                       linestyle="--")
    axes[1].plot(r["exact"].dr, r["exact"], "k:", label="model spectrum, eq. 9")
    axes[1].legend()
    # its error band and expected exact area; a log axis where it spans decades (the
    # finest value, the one quoted, sat on the floor of a linear one)
    plot_dataset(contact, variables=["a_r"], axes=[axes[2]])
    axes[0].set_title(f"synthetic surface, H = {args.hurst}, rms gradient {_RMS_GRADIENT}")
    axes[1].set_title("height-difference ACF G(dr)")
    axes[2].set_title(f"Persson theory, E* = {_E_STAR}, p0 = {_P0}")
    return fig


def _write(out: Path, r: dict, args: argparse.Namespace) -> None:
    """Write the topography (with checksums), G, Persson theory and the figure."""
    write_atomic(out / "topography.nc", lambda tmp: write_netcdf(r["topo"], tmp))
    for name, key in (("G_fft.nc", "G"), ("G_random.nc", "Gr"), ("persson.nc", "contact")):
        write_atomic(out / name, r[key].to_netcdf)
    fig = _figure(r, args)
    try:
        write_atomic(out / "demo.png", lambda p: fig.savefig(p, dpi=120, format="png"))
    finally:
        pyplot().close(fig)


def _print_curves(r: dict) -> None:
    """Print about eight lags of G by both estimators, the exact G and the standard error."""
    G, Gr, exact = r["G"], r["Gr"], r["exact"]
    print(f"\n{'dr (um)':>10} {'G fft (um2)':>12} {'G rnd (um2)':>12} {'G eq.9 (um2)':>12} "
          f"{'std err (um2)':>13}")
    for k in range(0, G.sizes["dr"], max(1, G.sizes["dr"] // 8)):
        print(f"{G.dr.values[k]:10.4g} {G.values[k]:12.4g} {Gr.values[k]:12.4g} "
              f"{exact.values[k]:12.4g} {G.standard_error.values[k]:13.2g}")
    topo, unit = r["topo"], r["topo"].attrs["units"]
    rel = np.abs(G.values / exact.values - 1)
    print(f"\nrms height {text(float(topo.std()), unit)} (model "
          f"{text(topo.attrs['rms_height'], unit)}); FFT estimator {r['t_fft']:.2f} s, "
          f"random pairs {r['t_rnd']:.2f} s; median |G/G_model - 1| = {np.median(rel):.2%}")


def _print_table(r: dict, args: argparse.Namespace) -> None:
    """Print what the fit and the contact mechanics found, next to the model's values."""
    fit, at, topo = r["fit"], finest(r["contact"]), r["topo"]
    rows = [
        ("Hurst exponent H (fit)", f"{float(fit.hurst):.3f} +- {float(fit.hurst_std):.3f}",
         f"{args.hurst}"),
        ("rms height sigma_h (fit)", _with_std(fit, "sigma_h", "no plateau"),
         text(topo.attrs["rms_height"], topo.attrs["units"])),
        ("roll-off wavelength lambda_r (fit)", _with_std(fit, "lambda_r", "no roll-off"),
         text(2, "um")),
        ("elastic energy of full contact", _with_std(r["energy"], "v_el"), ""),
        (f"contact area (Persson) at dr = {show(at.dr)}",
         show_errors(at.a_r, at.get("a_r_std"), exact_of(at, "a_r")), ""),
        (f"contact stress (Persson) at dr = {show(at.dr)}",
         show_errors(at.sigma_c, at.get("sigma_c_std"), exact_of(at, "sigma_c")), ""),
        (f"adhesive patch radius (gamma = {_GAMMA.replace('^2', '²')})",
         _with_std(r["patch"], "a_c"), ""),
    ]
    print(f"\n{'quantity':<42} {'from G':>50} {'model':>10}")
    for name, value, model in rows:
        print(f"{name:<42} {value:>50} {model:>10}")
    print("+- (stat): one standard deviation from the measurement's statistics; exact: what "
          "a contact solver is expected to give on this surface [one sigma], from Persson "
          "theory's error in a solver study")


def _with_std(ds, name: str, none: str = "") -> str:
    """``value +-std (stat) unit`` of ``ds[name]`` where ``<name>_std`` is there."""
    if not np.isfinite(float(ds[name])):
        return show(ds[name], none=none) if none else show(ds[name])
    return show_errors(ds[name], ds.get(f"{name}_std"))


def run(args: argparse.Namespace) -> int:
    """Run the demo: compute, write, print."""
    _check(args)
    out = output(args.output, folder=True)
    print(f"xrough {__version__} demo: synthetic self-affine surface, "
          f"{args.n}x{args.n} points, H = {args.hurst}")
    results = _compute(args)
    _write(out, results, args)
    _print_curves(results)
    _print_table(results, args)
    print(f"\nwrote {', '.join(str(out / name) for name in _FILES)}")
    return EXIT_OK

