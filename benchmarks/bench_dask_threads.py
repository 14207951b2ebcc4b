"""Threads of a dask computation of G: one per task, not a full set per task.

Computes G of ``--maps`` maps of ``--n``² (open, so each is padded; chunked one map per
task) on dask's threaded scheduler, twice in turn for ``--rounds`` rounds:

- default: ``acf()`` chooses its FFT threads where the task runs (one in a dask task,
  :func:`xrough._kernels.pairs.resolve_workers`);
- all cores per task: ``acf(workers=os.cpu_count())``, what every task started before
  the threads were chosen where they run (the oversubscription of threads in threads);

and prints the wall time of each (median of the rounds), their paired ratio, and the
peak number of the process's threads (sampled every millisecond from ``/proc``, Linux),
against dask's worker count. The results agree to round-off (1e-12, checked: threads
add the blocks' sums in another order).

Usage::

    python benchmarks/bench_dask_threads.py               # 16 maps of 512^2, 5 rounds
    python benchmarks/bench_dask_threads.py --n 1024 --maps 8
"""

from __future__ import annotations

import argparse
import os
import statistics
import threading
import time
import warnings
from pathlib import Path

import dask
import numpy as np
import xarray as xr

import xrough


def _threads() -> int:
    """Return the threads of this process (Linux: /proc/self/status)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("Threads:"):
            return int(line.split()[1])
    return threading.active_count()


def _run(maps: xr.DataArray, workers: int | None) -> tuple[float, int, xr.DataArray]:
    """Return the wall time, the peak thread count and G of one computation."""
    peak = [_threads()]
    done = threading.Event()

    def sample():
        while not done.is_set():
            peak[0] = max(peak[0], _threads())
            time.sleep(0.001)

    sampler = threading.Thread(target=sample)
    sampler.start()
    t0 = time.perf_counter()
    G = maps.rough.acf(workers=workers).compute(scheduler="threads")
    elapsed = time.perf_counter() - t0
    done.set()
    sampler.join()
    return elapsed, peak[0] - 1, G  # less the sampler itself


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maps", type=int, default=16)
    parser.add_argument("--n", type=int, default=512)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    maps = xr.concat([xrough.self_affine_surface(
        hurst=0.8, n=args.n, size=f"{args.n} nm", lambda_r=f"{args.n // 4} nm",
        lambda_s="4 nm", rms_gradient=0.1, unit="nm", seed=s).assign_attrs(periodic=0)
        for s in range(args.maps)], dim="scan").chunk({"scan": 1})
    cores = os.cpu_count() or 1
    idle = _threads()
    _run(maps, None)  # warm up (imports, dask's pool)
    times: dict[str, list[float]] = {"default": [], "all cores per task": []}
    peaks: dict[str, int] = {}
    results = {}
    for _ in range(args.rounds):
        for name, workers in (("default", None), ("all cores per task", cores)):
            t, peak, G = _run(maps, workers)
            times[name].append(t)
            peaks[name] = max(peaks.get(name, 0), peak)
            results[name] = G
    np.testing.assert_allclose(results["default"].values,  # the order of the sums
                               results["all cores per task"].values, rtol=1e-12)
    workers = dask.config.get("num_workers", None) or cores
    print(f"{args.maps} open maps of {args.n}^2 on dask's threaded scheduler "
          f"({workers} workers, {cores} cores; {idle} threads before)")
    for name, ts in times.items():
        print(f"  {name:20s} {statistics.median(ts):7.3f} s   peak threads {peaks[name]}")
    ratios = [a / b for a, b in zip(times["default"], times["all cores per task"])]
    print(f"  paired ratio default / all cores per task: {statistics.median(ratios):.3f} "
          f"(min {min(ratios):.3f}, max {max(ratios):.3f})")


if __name__ == "__main__":
    main()
