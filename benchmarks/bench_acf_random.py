"""Run time against error of the random-pair estimator, with the FFT estimator as baseline.

On one synthetic map per size, the all-pairs FFT estimate is the reference (the random
estimator samples exactly those bin averages). For several pair budgets this prints the
time, its ratio to the FFT time measured in the same run, the median and largest relative
deviation from the FFT G over the bins, and the median reported ``sampling_error``
(relative), which should track the deviation.

Usage::

    python benchmarks/bench_acf_random.py
    python benchmarks/bench_acf_random.py --sizes 1024 --budgets 1e4 1e5
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import xrough


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1024, 4096])
    parser.add_argument("--budgets", type=float, nargs="+", default=[1e4, 1e5, 1e6, 1e7])
    args = parser.parse_args(argv)
    head = (f"{'size':>6} {'pairs':>8} {'time s':>8} {'/ fft':>7} {'median err':>11} "
            f"{'max err':>8} {'median reported':>16}")
    print(head)
    print("-" * len(head))
    for n in args.sizes:
        topo = xrough.self_affine_surface(hurst=0.8, lambda_r="1 um", lambda_s="8 nm",
                                          size="4 um", n=n, rms_height="1 nm", seed=0,
                                          unit="nm")
        topo.rough.acf()  # warm up
        t0 = time.perf_counter()
        ref = topo.rough.acf()
        t_fft = time.perf_counter() - t0
        print(f"{n:>6} {'fft':>8} {t_fft:8.3f} {1.0:7.2f} {0.0:11.2e} {0.0:8.2e} {'-':>16}")
        for budget in args.budgets:
            t0 = time.perf_counter()
            G = topo.rough.acf(estimator="random", n_pairs=int(budget), seed=1)
            t = time.perf_counter() - t0
            rel = np.abs(G.values / ref.values - 1)
            rep = np.median(G.sampling_error.values / G.values)
            print(f"{n:>6} {budget:8.0e} {t:8.3f} {t / t_fft:7.2f} {np.median(rel):11.2e} "
                  f"{rel.max():8.2e} {rep:16.2e}", flush=True)


if __name__ == "__main__":
    main()
