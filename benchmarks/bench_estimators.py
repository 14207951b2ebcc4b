"""Run time against error of every G estimator on the same map, with a plot.

The exact all-pairs FFT estimate of an open map with missing points is the reference; the
tiled estimator (exact within its halo, block levels beyond) and the random-pair estimator
at several budgets are timed and compared with it (largest relative deviation over the
bins). Times are also printed as ratios to the FFT time measured in the same run.

Usage::

    python benchmarks/bench_estimators.py                    # 2048^2
    python benchmarks/bench_estimators.py --n 1024 --plot docs/estimators.png
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import xrough


def timed(func):
    t0 = time.perf_counter()
    out = func()
    return out, time.perf_counter() - t0


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=2048)
    parser.add_argument("--plot", help="write the time-error plot to this PNG")
    args = parser.parse_args(argv)
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="1 um", lambda_s="8 nm",
                                      size="4 um", n=args.n, rms_height="1 nm", seed=0,
                                      unit="nm").assign_attrs(periodic=0)
    topo = topo.where(np.random.default_rng(1).random(topo.shape) > 0.05)
    topo.rough.acf()  # warm up
    ref, t_fft = timed(lambda: topo.rough.acf(estimator="fft"))
    rows = [("fft", t_fft, 0.0)]
    tiled, t = timed(lambda: topo.rough.acf(estimator="tiled"))
    rows.append(("tiled", t, float(np.nanmax(np.abs(tiled.values / ref.values - 1)))))
    for budget in (1e4, 1e5, 1e6, 1e7):
        G, t = timed(lambda b=budget: topo.rough.acf(estimator="random", n_pairs=int(b),
                                                     seed=1))
        rows.append((f"random {budget:.0e}", t,
                     float(np.nanmax(np.abs(G.values / ref.values - 1)))))
    print(f"{'estimator':>14} {'time s':>8} {'/ fft':>7} {'max rel. error':>15}")
    for name, t, err in rows:
        print(f"{name:>14} {t:8.3f} {t / t_fft:7.2f} {err:15.2e}")
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(5.5, 4))
        for name, t, err in rows:
            ax.loglog(t, max(err, 1e-16), "o")
            ax.annotate(name, (t, max(err, 1e-16)), textcoords="offset points",
                        xytext=(5, 3), fontsize=8)
        ax.set_xlabel("run time (s)")
        ax.set_ylabel("largest relative error of G")
        ax.set_title(f"G estimators on a {args.n}² open map, 5 % missing")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=110)
        print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
