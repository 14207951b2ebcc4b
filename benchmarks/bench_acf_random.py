"""Run time against error of the random-pair estimator, with the FFT estimator as baseline.

On one synthetic map per size, the all-pairs FFT estimate is the reference (the random
estimator samples exactly those bin averages). For several pair budgets this prints the
time, its ratio to the FFT time measured in the same run, the median and largest relative
deviation from the FFT G over the bins, and the median reported ``sampling_error``
(relative), which should track the deviation.

``--scaling`` instead times a fixed budget (default 1e4 pairs) on maps of growing size and
prints each time as a ratio to the smallest map's, and to one pass over the map
(``np.nanmax(np.abs(h))``, the least any whole-map step costs), all measured in the same
run: a cost independent of the map size gives ratios near 1 in the first column.
``--cost-model`` measures the constants of the cost model of ``target_error`` (seconds
per random pair and per bin, FFT seconds per ``M log2 M`` of the transformed shape, tiled
seconds per point); ``--check`` times what ``target_error`` chose against the
alternative on a few maps.

Usage::

    python benchmarks/bench_acf_random.py
    python benchmarks/bench_acf_random.py --sizes 1024 --budgets 1e4 1e5
    python benchmarks/bench_acf_random.py --scaling --sizes 1024 2048 4096 8192
    python benchmarks/bench_acf_random.py --cost-model
    python benchmarks/bench_acf_random.py --check
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
        t = best_of(lambda topo=topo: topo.rough.acf(estimator="random", n_pairs=budget,
                                                     seed=1), args.repeat)
        t_pass = best_of(lambda h=h: np.nanmax(np.abs(h)), args.repeat)
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
        t_fft = best_of(lambda topo=topo: topo.rough.acf(estimator="fft"), args.repeat)
        t1 = best_of(lambda topo=topo: topo.rough.acf(estimator="random", n_pairs=10_000,
                                                      seed=1), args.repeat)
        t2 = best_of(lambda topo=topo: topo.rough.acf(estimator="random", n_pairs=1_000_000,
                                                      seed=1), args.repeat)
        t_count = best_of(lambda topo=topo: valid_points(topo.values), args.repeat)
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
            t_tiled = best_of(lambda topo=topo: topo.rough.acf(estimator="tiled"),
                              max(1, args.repeat // 2))
            print(f"open map: tiled {t_tiled:.4f} s, {t_tiled / topo.size:.3g} s per point, "
                  f"tiled / fft = {t_tiled / t_fft:.2f}", flush=True)


#: (size, periodic, dr_max in px, target) of --check
CHECKS = [(1024, True, None, 0.05), (1024, False, 100, 0.05), (1024, False, 100, 0.01),
          (2048, False, None, 0.02), (4096, False, None, 0.05)]


def check_choices(args) -> None:
    """Time what ``target_error`` chose against the alternative, in the same run.

    The alternative of random pairs is the exact FFT; that of the FFT, random pairs with
    the budget the target would need (``n_pairs`` from the model's rule). A ratio
    ``other / chosen`` above 1 means the model chose the faster one. Both are called
    with the estimator given explicitly; "choice s" is what the call with
    ``target_error`` took on top (the choice itself and the achieved error).
    """
    import math
    import warnings

    from xrough.correlation import SAMPLING_KAPPA

    print(f"choices of target_error against the alternative, best of {args.repeat}")
    head = (f"{'size':>6} {'periodic':>8} {'dr_max':>7} {'target':>7} {'chosen':>8} "
            f"{'pairs':>9} {'chosen s':>9} {'other s':>9} {'other / chosen':>15} "
            f"{'choice s':>9}")
    print(head)
    print("-" * len(head))
    warnings.simplefilter("ignore")
    for n, periodic, dr_max, target in CHECKS:
        topo = surface(n).assign_attrs(periodic=int(periodic))
        G = topo.rough.acf(target_error=target, dr_max=dr_max, seed=1)
        chosen = G.attrs["estimator"].split()[0]
        nb = G.sizes["dr"]
        pairs = math.ceil(SAMPLING_KAPPA / (target / 2) ** 2) * nb
        explicit = dict(estimator="random", n_pairs=pairs, seed=1) if chosen == "random" \
            else {}
        t_target = best_of(lambda topo=topo, target=target, dr_max=dr_max: topo.rough.acf(
            target_error=target, dr_max=dr_max, seed=1), args.repeat)
        t_chosen = best_of(lambda topo=topo, dr_max=dr_max, explicit=explicit: topo.rough.acf(
            dr_max=dr_max, **explicit), args.repeat)
        other = {} if chosen == "random" else dict(estimator="random", n_pairs=pairs, seed=1)
        t_other = best_of(lambda topo=topo, dr_max=dr_max, other=other: topo.rough.acf(
            dr_max=dr_max, **other), args.repeat)
        print(f"{n:>6} {periodic!s:>8} {dr_max or '-':>7} {target:7.2f} {chosen:>8} "
              f"{pairs:9d} {t_chosen:9.4f} {t_other:9.4f} {t_other / t_chosen:15.2f} "
              f"{t_target - t_chosen:9.4f}", flush=True)
        del topo, G


DEFAULT_BUDGETS = [1e4, 1e5, 1e6, 1e7]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+")
    parser.add_argument("--budgets", type=float, nargs="+", default=DEFAULT_BUDGETS)
    parser.add_argument("--scaling", action="store_true",
                        help="time one budget against the map size")
    parser.add_argument("--cost-model", action="store_true",
                        help="measure the constants of the cost model of target_error")
    parser.add_argument("--check", action="store_true",
                        help="time the choices of target_error against the alternative")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    if args.check:
        check_choices(args)
    elif args.scaling:
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
