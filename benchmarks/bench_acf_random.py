"""Run time against error of the random-pair estimator, with the FFT estimator as baseline.

On one synthetic map per size, the all-pairs FFT estimate is the reference (the random
estimator samples exactly those bin averages). For several pair budgets this prints the
time, its ratio to the FFT time measured in the same run, the median and largest relative
deviation from the FFT G over the bins, and the median reported ``sampling_error``
(relative), which should track the deviation.

``--scaling`` instead times a fixed budget (default 1e4 pairs) on maps of growing size and
prints each time as a ratio to the smallest map's, and to one pass over the map
(``np.nanmax(np.abs(h))``, the least any whole-map step costs), all measured in the same
run: a cost independent of the map size gives ratios near 1 in the first column. The
same command gives the numbers of the cost model of ``target_error``
(``--cost-model``): seconds per random pair and per bin, and FFT seconds per
``M log2 M`` of the transformed shape.

Usage::

    python benchmarks/bench_acf_random.py
    python benchmarks/bench_acf_random.py --sizes 1024 --budgets 1e4 1e5
    python benchmarks/bench_acf_random.py --scaling --sizes 1024 2048 4096 8192
    python benchmarks/bench_acf_random.py --cost-model
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import xrough


def surface(n: int, **kw):
    return xrough.self_affine_surface(hurst=0.8, lambda_r="1 um", lambda_s="8 nm",
                                      size="4 um", n=n, rms_height="1 nm", seed=0,
                                      unit="nm", **kw)


def best_of(func, repeat: int) -> float:
    func()  # warm up
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        func()
        times.append(time.perf_counter() - t0)
    return min(times)


def error_table(args) -> None:
    head = (f"{'size':>6} {'pairs':>8} {'time s':>8} {'/ fft':>7} {'median err':>11} "
            f"{'max err':>8} {'median reported':>16}")
    print(head)
    print("-" * len(head))
    for n in args.sizes:
        topo = surface(n)
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


def scaling_table(args) -> None:
    budget = int(args.budgets[0]) if args.budgets != DEFAULT_BUDGETS else 10_000
    print(f"random estimator, {budget:.0e} pairs, best of {args.repeat}")
    head = (f"{'size':>6} {'time s':>8} {'/ smallest':>11} {'one pass s':>11} "
            f"{'/ one pass':>11}")
    print(head)
    print("-" * len(head))
    first = None
    for n in args.sizes:
        topo = surface(n)
        h = topo.values
        t = best_of(lambda: topo.rough.acf(estimator="random", n_pairs=budget, seed=1),
                    args.repeat)
        t_pass = best_of(lambda: np.nanmax(np.abs(h)), args.repeat)
        first = t if first is None else first
        print(f"{n:>6} {t:8.4f} {t / first:11.2f} {t_pass:11.4f} {t / t_pass:11.2f}",
              flush=True)
        del topo, h


def cost_model(args) -> None:
    """Measure the constants of the cost model of ``target_error`` in this run.

    FFT: seconds per ``M log2 M`` (``M`` transformed points: the map when periodic, the
    map padded by the largest lag when open); tiled: seconds per map point; random pairs:
    seconds per pair and per bin (from 1e4 and 1e6 pairs), and per map point of the
    counting pass. The ratios at the end compare the measured times with the model's.
    """
    from xrough._kernels.random_pairs import valid_points

    n = args.sizes[0]
    print(f"cost model constants, {n}^2 maps and a {16 * n}-point profile, best of "
          f"{args.repeat}")
    rows = []
    for what, topo in (("periodic map", surface(n)),
                       ("open map", surface(n).assign_attrs(periodic=0)),
                       ("profile", surface(16 * n, profile=True))):
        m = topo.size if topo.attrs.get("periodic") else int(
            np.prod([2 * s - 1 for s in topo.shape]))
        t_fft = best_of(lambda: topo.rough.acf(estimator="fft"), args.repeat)
        t1 = best_of(lambda: topo.rough.acf(estimator="random", n_pairs=10_000, seed=1),
                     args.repeat)
        t2 = best_of(lambda: topo.rough.acf(estimator="random", n_pairs=1_000_000, seed=1),
                     args.repeat)
        t_count = best_of(lambda: valid_points(topo.values), args.repeat)
        nb = topo.rough.acf(estimator="random", n_pairs=10_000, seed=1).sizes["dr"]
        per_pair = (t2 - t1) / 990_000
        per_bin = (t1 - 1e4 * per_pair - t_count) / nb
        rows.append((what, t_fft / (m * np.log2(m)), per_pair, per_bin,
                     t_count / topo.size))
        print(f"{what}: fft {t_fft:.4f} s ({t_fft / (m * np.log2(m)):.3g} s per M log2 M, "
              f"M = {m}); random 1e4 {t1:.4f} s, 1e6 {t2:.4f} s: {per_pair:.3g} s per "
              f"pair, {per_bin:.3g} s per bin ({nb} bins); count {t_count / topo.size:.3g} "
              f"s per point; fft / random 1e4 = {t_fft / t1:.2f}", flush=True)
        if what == "open map":
            t_tiled = best_of(lambda: topo.rough.acf(estimator="tiled"), max(1, args.repeat // 2))
            print(f"open map: tiled {t_tiled:.4f} s, {t_tiled / topo.size:.3g} s per point, "
                  f"tiled / fft = {t_tiled / t_fft:.2f}", flush=True)


DEFAULT_BUDGETS = [1e4, 1e5, 1e6, 1e7]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+")
    parser.add_argument("--budgets", type=float, nargs="+", default=DEFAULT_BUDGETS)
    parser.add_argument("--scaling", action="store_true",
                        help="time one budget against the map size")
    parser.add_argument("--cost-model", action="store_true",
                        help="measure the constants of the cost model of target_error")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    if args.scaling:
        args.sizes = args.sizes or [1024, 2048, 4096, 8192]
        scaling_table(args)
    elif args.cost_model:
        args.sizes = args.sizes or [1024]
        cost_model(args)
    else:
        args.sizes = args.sizes or [1024, 4096]
        error_table(args)


if __name__ == "__main__":
    main()
