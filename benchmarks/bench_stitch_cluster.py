"""Stitching file-backed stacks of three instruments: threads against a dask cluster.

A DataTree of three instruments, each a stack of scans in its own NetCDF file opened
lazily with one scan per chunk (18 maps, about 100 MB of heights), is stitched as
``tree.rough.acf()``: one lazy graph, computed once. Timed, interleaved over
``--repeats`` rounds, each on the same graph:

- ``single``: dask's synchronous scheduler (one thread), the baseline of the scaling;
- ``threads``: dask's threaded scheduler (the default; one thread per core);
- ``cluster N``: a ``dask.distributed`` ``LocalCluster`` of N worker processes with one
  thread each (``--workers``, default 1, 2 and 4), started before the rounds (its start-up
  is not counted) and kept for all of them, in distributed's default worker environment;
- ``cluster N, no trim``: the same with ``MALLOC_TRIM_THRESHOLD_`` left unset in the
  workers (``distributed.nanny.pre-spawn-environ``). distributed sets it to 64 KiB by
  default, which makes glibc return every large freed array to the system at once, so
  that each temporary array of the FFTs is mapped afresh (page faults on every use).

Printed per scheduler: best and median wall time, the ratio of the best to the threaded
best of the run, and the median (range) of each cluster round over the threaded round
just before it (the target is a cluster of as many workers as cores within 1.2x of
threads).
Every scheduler's G is checked equal to the threaded one to 1e-12.

Then, per scheduler, the time of a graph of trivial tasks as many as the stitched graph
runs after optimisation (``ones * 3`` summed, one chunk per task): the fixed cost of the
scheduler, which a cluster pays per task and threads barely do.

Usage::

    python benchmarks/bench_stitch_cluster.py                  # about 100 MB, 3 rounds
    python benchmarks/bench_stitch_cluster.py --scale 0.5 --workers 2 --repeats 5
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings
from pathlib import Path

import dask
import numpy as np
import xarray as xr
from dask.callbacks import Callback

import xrough

#: (name, pixel in nm, pixels per side at scale 1, scans)
INSTRUMENTS = (("tem", 0.5, 512, 6), ("afm", 4.0, 1024, 6), ("optical", 64.0, 1024, 6))


def write_stacks(folder: Path, scale: float) -> dict[str, Path]:
    """Write each instrument's stack of open self-affine maps to NetCDF; return the paths."""
    paths = {}
    for k, (name, pixel, n, scans) in enumerate(INSTRUMENTS):
        n = max(64, int(n * np.sqrt(scale)))
        maps = [xrough.self_affine_surface(hurst=0.8, lambda_r=n * pixel / 4,
                                           lambda_s=4 * pixel, size=n * pixel, n=n,
                                           rms_gradient=0.3, seed=100 * k + s, unit="nm")
                for s in range(scans)]
        stack = xr.concat(maps, dim="scan").assign_attrs(periodic=0)
        stack.name = "h"
        paths[name] = folder / f"{name}.nc"
        stack.to_dataset().to_netcdf(paths[name])
    return paths


def open_tree(paths: dict[str, Path]) -> xr.DataTree:
    return xr.DataTree.from_dict({name: xr.open_dataset(path, chunks={"scan": 1})
                                  for name, path in paths.items()})


def stitched(paths):
    """The lazy stitched G of the file-backed tree (built anew: nothing cached)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return open_tree(paths).rough.acf(points_per_decade=10)


class TaskCounter(Callback):
    """Counts the tasks a local scheduler runs."""

    def __init__(self) -> None:
        super().__init__()
        self.count = 0

    def _pretask(self, key, dsk, state):
        self.count += 1


def trivial(n_tasks: int):
    """A graph of about ``n_tasks`` trivial tasks (one block of ones per task, summed)."""
    import dask.array as dsa

    return (dsa.ones((n_tasks // 2, 10), chunks=(1, 10)) * 3).sum(split_every=n_tasks)


def timed(paths, **compute_kwargs):
    G = stitched(paths)
    t0 = time.perf_counter()
    out = G.compute(**compute_kwargs)
    return time.perf_counter() - t0, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scale", type=float, default=1.0,
                        help="data size relative to about 100 MB")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    from dask.distributed import Client, LocalCluster

    with tempfile.TemporaryDirectory() as tmp:
        paths = write_stacks(Path(tmp), args.scale)
        size = sum(p.stat().st_size for p in paths.values()) / 2**20
        print(f"xrough {xrough.__version__}, dask {dask.__version__}, {os.cpu_count()} cores; "
              f"{size:.0f} MiB in 3 files, 18 scans, one per chunk")
        G = stitched(paths)
        counter = TaskCounter()
        with counter:
            G.compute(scheduler="synchronous")
        n_tasks = counter.count
        print(f"graph: {len(G.__dask_graph__())} tasks, {n_tasks} run after optimisation")
        overhead: dict[str, list[float]] = {}
        times: dict[str, list[float]] = {"single": [], "threads": []}
        paired: dict[str, list[float]] = {}  # cluster / threads, timed one after the other
        timed(paths)  # warm-up: imports, FFT plans, the page cache of the files
        for _ in range(args.repeats):
            t, single = timed(paths, scheduler="synchronous")
            times["single"].append(t)
            t, ref = timed(paths, scheduler="threads")
            times["threads"].append(t)
            xr.testing.assert_allclose(single, ref, rtol=1e-12, atol=0)
            for sched in ("single", "threads"):
                t0 = time.perf_counter()
                trivial(n_tasks).compute(
                    scheduler="synchronous" if sched == "single" else "threads")
                overhead.setdefault(sched, []).append(time.perf_counter() - t0)
        for trim in (True, False):  # one cluster at a time: idle ones would add noise
            for n in args.workers:
                env = {} if trim else {
                    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}
                name = f"cluster {n}" + ("" if trim else ", no trim")
                times[name], paired[name] = [], []
                with dask.config.set(env), LocalCluster(
                        n_workers=n, threads_per_worker=1, processes=True,
                        dashboard_address=None) as cluster, Client(cluster) as client:
                    client.compute(stitched(paths)).result()  # warm-up of the workers
                    for _ in range(args.repeats):
                        t_threads, _ = timed(paths, scheduler="threads")
                        times["threads"].append(t_threads)
                        G = stitched(paths)
                        t0 = time.perf_counter()
                        got = client.compute(G).result()
                        times[name].append(time.perf_counter() - t0)
                        paired[name].append(times[name][-1] / t_threads)
                        xr.testing.assert_allclose(got, ref, rtol=1e-12, atol=0)
                        t0 = time.perf_counter()
                        client.compute(trivial(n_tasks)).result()
                        overhead.setdefault(name, []).append(time.perf_counter() - t0)
    base = min(times["threads"])
    print(f"{'scheduler':<22} {'best s':>8} {'median s':>9} {'/ threads':>10} "
          f"{'paired':>16} {'single / it':>12} {'trivial s':>10}")
    for name, ts in times.items():
        pair = (f"{np.median(paired[name]):.2f} ({min(paired[name]):.2f}-"
                f"{max(paired[name]):.2f})" if name in paired else "")
        print(f"{name:<22} {min(ts):8.2f} {np.median(ts):9.2f} {min(ts) / base:10.2f} "
              f"{pair:>16} {min(times['single']) / min(ts):12.2f} "
              f"{min(overhead[name]):10.3f}")
    print("every scheduler's G equal to the threaded one to 1e-12")


if __name__ == "__main__":
    main()
