"""The default fit and gbar on surfaces seen through an instrument's Gaussian transfer.

Random Gaussian maps of the smooth-roll-off model spectrum (``lambda_r = L/4``) whose
short end is either eq. 35's sharp cutoff or the spectrum times ``exp(-(q/q_s)^2)`` (a tip,
optics or stylus) at ``lambda_s`` = 4 pixels (1 and 2 for H 0.05, 1 for H 0.3).  Each setting runs
``--seeds`` realisations through ``topo.rough.acf()`` (open maps: a window of a periodic
map twice as wide, plane removed), ``fit_acf(G)`` (default: both cutoffs where the data
resolve ``lambda_s``) and ``fit_acf(G, cutoff="sharp")`` (eq. 35 only), and
``G.rough.gradient()`` at one pixel.  Per setting and fit it prints

* ``H``: mean +- standard deviation over the seeds (the scatter),
* ``std/sd``: the mean ``hurst_std`` over that scatter (1: the stated error is what a
  second map gives),
* ``z``: mean and standard deviation of ``(H - H_true) / hurst_std``,
* ``gauss``: how many fits kept the Gaussian cutoff; ``rated``: good/questionable/failed,
* ``sigma_h``: ``sigma_h_std`` over the scatter of ``sigma_h``;

and for gbar(1 px): the mean of ``gbar / gbar_lattice - 1`` (``gbar_lattice``: the expected
full gradient of the map, the model spectrum summed over the modes of its lattice, which is
eq. 26 at one pixel of what the map holds), its scatter and the mean stated ``gbar_std``.

Usage::

    python benchmarks/instrument_cutoffs.py --seeds 40            # about 10 min
    python benchmarks/instrument_cutoffs.py --seeds 8 --only 0 2
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import xrough
from xrough.fitting import fit_acf
from xrough.models import model_from_attrs

#: (map size, H, periodic, cutoff of the surface, lambda_s in pixels)
SETTINGS = [
    (512, 0.65, True, "gaussian", 4.0),
    (512, 0.65, False, "gaussian", 4.0),
    (512, 0.3, True, "gaussian", 4.0),
    (1024, 0.3, True, "gaussian", 4.0),
    (512, 0.65, True, "sharp", 4.0),
    (512, 0.3, True, "sharp", 4.0),
    (512, 0.05, True, "gaussian", 1.0),
    (512, 0.05, True, "gaussian", 2.0),
    (512, 0.3, True, "gaussian", 1.0),
]


def surface(n: int, hurst: float, periodic: bool, cutoff: str, lambda_s: float, seed: int):
    """One realisation (lengths in pixels) and its model spectrum."""
    m = n if periodic else 2 * n
    topo = xrough.self_affine_surface(hurst=hurst, lambda_r=n / 4, lambda_s=lambda_s,
                                      size=float(m), n=m, rms_height=1.0, rolloff="smooth",
                                      cutoff=cutoff, seed=seed, unit="um")
    model = model_from_attrs(topo.attrs)
    if not periodic:
        window = topo.isel(x=slice(0, n), y=slice(0, n)).values
        topo = xrough.topography(window, spacing=1.0, unit="um",
                                 periodic=False).rough.detrend()
    return topo, model


def lattice_gradient(model, m: int) -> float:
    """The expected full gradient of an ``m``-by-``m`` map of unit pixels of ``model``."""
    q = 2 * np.pi * np.fft.fftfreq(m)
    Q = np.hypot(q[:, None], q[None, :])
    C = model(Q)
    C[0, 0] = 0.0
    return float(np.sqrt(np.sum(Q**2 * C)) / m)


def run(n, hurst, periodic, cutoff, lambda_s, seeds):
    rows = {"default": [], "sharp": []}
    gb = []
    t_fit = {"default": 0.0, "sharp": 0.0}
    for seed in range(seeds):
        topo, model = surface(n, hurst, periodic, cutoff, lambda_s, seed)
        G = topo.rough.acf()
        for name, kw in (("default", {}), ("sharp", {"cutoff": "sharp"})):
            t0 = time.perf_counter()
            f = fit_acf(G, **kw)
            t_fit[name] += time.perf_counter() - t0
            rows[name].append([float(f.hurst), float(f.hurst_std), float(f.sigma_h),
                               float(f.sigma_h_std), int(f.cutoff_shape),
                               int(f.quality_flag)])
        g = G.rough.gradient().isel(dr=0)
        exact = lattice_gradient(model, n if periodic else 2 * n)
        gb.append([float(g) / exact - 1, float(g.gbar_std) / exact])
    label = (f"{n}^2 H {hurst} {'periodic' if periodic else 'open'} {cutoff} "
             f"{lambda_s:g} px")
    for name, v in rows.items():
        a = np.array(v)
        ok = np.isfinite(a[:, 0]) & np.isfinite(a[:, 1])
        h, s = a[ok, 0], a[ok, 1]
        z = (h - hurst) / s
        sd = h.std(ddof=1)
        rated = np.bincount(a[:, 5].astype(int), minlength=3)
        print(f"{label:40s} {name:8s} H {h.mean():.3f} +- {sd:.3f}  std/sd {s.mean() / sd:4.2f}"
              f"  z {z.mean():+.2f} sd {z.std(ddof=1):.2f}  gauss {int(a[:, 4].sum())}/{len(a)}"
              f"  rated {rated[0]}/{rated[1]}/{rated[2]}  sigma_h std/sd "
              f"{np.nanmean(a[:, 3]) / np.nanstd(a[:, 2], ddof=1):4.2f}"
              f"  fit {t_fit[name] / seeds:.2f} s")
    b = np.array(gb)
    print(f"{label:40s} gbar(1 px) bias {100 * b[:, 0].mean():+.2f} %  scatter "
          f"{100 * b[:, 0].std(ddof=1):.2f} %  stated {100 * b[:, 1].mean():.2f} %")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=40)
    parser.add_argument("--only", type=int, nargs="*", help="indices into SETTINGS")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    chosen = args.only if args.only else range(len(SETTINGS))
    for k in chosen:
        run(*SETTINGS[k], args.seeds)


if __name__ == "__main__":
    main()
