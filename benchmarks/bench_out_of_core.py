"""G(dr) of a map larger than memory with the tiled estimator, read from a chunked NetCDF file.

Steps, each in a fresh subprocess so that peak resident memory (``ru_maxrss``) is its own:

1. for each size ``n`` asked for, write an ``n x n`` map (float32 by default,
   ``--dtype``) to a chunked NetCDF file, chunk by chunk (a sum of plane waves plus white
   noise, 5 % missing points), so that generation stays within a chunk's memory: in a
   temporary folder, deleted after the run, or in ``--data``, where it is kept and reused
   by later runs (written once; delete it yourself);
2. open it lazily (``xr.open_dataarray(..., chunks=...)``) and compute G with
   :func:`xrough.correlation.height_difference_acf_tiled` on two threads; print time
   (graph build included), peak memory, the number of tasks in the graph, how often the
   NetCDF file was read per chunk (each chunk should be read once) and the most tile lag
   sums and partial sums held at once (a dask callback: they are added as the map is
   swept, so this grows with one row of tiles, not with the map);
3. on a small map (default 2048^2) compare time and error against the exact in-memory
   FFT estimator.

At the end a table of all sizes, with the per-size growth of time and memory.

Usage::

    python benchmarks/bench_out_of_core.py                        # 16384^2 and 2048^2
    python benchmarks/bench_out_of_core.py --sizes 8192 16384 32768 --small 0
    python benchmarks/bench_out_of_core.py --sizes 65536 --small 0 --data /big/disk
        # 16 GiB of disk (float32), kept in /big/disk
    python benchmarks/bench_out_of_core.py --sizes 65536 --graph-only   # tasks only
"""

from __future__ import annotations

import argparse
import contextlib
import json
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import numpy as np

COMMON = textwrap.dedent(
    r"""
    import json, resource, sys, time
    import numpy as np

    def rss():
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024

    def waves(seed=0, k=12):
        rng = np.random.default_rng(seed)
        lam = np.logspace(1, 3.5, k)  # wavelengths 10 to ~3000 pixels
        ang = rng.uniform(0, 2 * np.pi, k)
        amp = lam ** 0.8 / 100
        phase = rng.uniform(0, 2 * np.pi, k)
        return [(2 * np.pi / l * np.cos(a), 2 * np.pi / l * np.sin(a), A, p)
                for l, a, A, p in zip(lam, ang, amp, phase)]

    def block(r0, r1, c0, c1, seed):
        y = np.arange(r0, r1, dtype=float)[:, None]
        x = np.arange(c0, c1, dtype=float)[None, :]
        z = np.zeros((r1 - r0, c1 - c0), dtype=complex)
        for kx, ky, A, p in waves():  # A cos(kx x + ky y + p), one outer product per wave
            z += (A * np.exp(1j * (ky * y + p))) * np.exp(1j * kx * x)
        h = z.real
        rng = np.random.default_rng([seed, r0, c0])
        h += 0.05 * rng.standard_normal(h.shape)
        h[rng.random(h.shape) < 0.05] = np.nan
        return h
    """
)

WRITE = COMMON + textwrap.dedent(
    r"""
    import netCDF4
    path, n, chunk, dtype = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    t0 = time.perf_counter()
    with netCDF4.Dataset(path, "w") as ds:
        ds.createDimension("y", n); ds.createDimension("x", n)
        for d in ("y", "x"):
            v = ds.createVariable(d, "f8", (d,)); v[:] = np.arange(n) * 1.0; v.units = "nm"
        v = ds.createVariable("height", np.dtype(dtype), ("y", "x"),
                              chunksizes=(chunk, chunk), fill_value=np.nan)
        v.units = "nm"; v.periodic = 0
        for r0 in range(0, n, chunk):
            for c0 in range(0, n, chunk):
                r1, c1 = min(n, r0 + chunk), min(n, c0 + chunk)
                v[r0:r1, c0:c1] = block(r0, r1, c0, c1, 0)
    print(json.dumps({"t": time.perf_counter() - t0, "peak": rss()}))
    """
)

TILED = COMMON + textwrap.dedent(
    r"""
    import collections, threading
    import dask, xarray as xr, xrough
    from dask.callbacks import Callback
    from xarray.backends.netCDF4_ import NetCDF4ArrayWrapper
    from xrough.correlation import height_difference_acf_tiled
    path, chunk, tile, halo, threads = (sys.argv[1], int(sys.argv[2]), int(sys.argv[3]),
                                        int(sys.argv[4]), int(sys.argv[5]))
    reads, lock, getitem = collections.Counter(), threading.Lock(), NetCDF4ArrayWrapper.__getitem__

    def counted(self, key):  # every read of the height variable from the file
        out = getitem(self, key)
        if out.ndim == 2 and out.size:
            with lock:
                reads[repr(key)] += 1
        return out

    def is_sum(key):  # a tile's lag planes or a partial sum of them
        return "tile-sums" in str(key[0] if isinstance(key, tuple) else key)

    class Partials(Callback):  # the most tile lag sums (and partial sums) held at once
        def __init__(self):
            super().__init__()
            self.most = 0

        def _posttask(self, key, result, dsk, state, worker_id):
            if is_sum(key):
                self.most = max(self.most, sum(map(is_sum, state["cache"])))

    NetCDF4ArrayWrapper.__getitem__ = counted
    topo = xr.open_dataarray(path, chunks={"y": chunk, "x": chunk})
    base = rss()
    t0 = time.perf_counter()
    G = height_difference_acf_tiled(topo, tile=tile, halo=halo)
    t_graph, peak_graph = time.perf_counter() - t0, rss()
    tasks = len(G.data.__dask_graph__())
    with dask.config.set(scheduler="threads", num_workers=threads), Partials() as partials:
        G = G.compute()
    t = time.perf_counter() - t0
    print(json.dumps({"t": t, "t_graph": t_graph, "peak": rss(), "base": base,
                      "peak_graph": peak_graph, "nbins": G.sizes["dr"],
                      "exact_bins": int((G.block == 1).sum()), "tasks": tasks,
                      "chunks": topo.data.npartitions, "read_chunks": len(reads),
                      "reads": sum(reads.values()), "max_reads": max(reads.values()),
                      "max_partials": partials.most,
                      "blocks": sorted(set(int(b) for b in G.block.values))}))
    """
)

GRAPH = textwrap.dedent(
    r"""
    import json, sys, time
    import dask.array as dsa, numpy as np, xarray as xr, xrough
    from xrough.correlation import height_difference_acf_tiled
    n, chunk, tile, halo = map(int, sys.argv[1:5])
    small = xrough.topography(np.zeros((2, 2)), spacing=1.0, unit="nm")
    axis = np.arange(n, dtype=float)
    topo = xr.DataArray(dsa.zeros((n, n), chunks=chunk), dims=("y", "x"),
                        coords={d: (d, axis, small[d].attrs) for d in "yx"},
                        attrs=small.attrs)
    t0 = time.perf_counter()
    G = height_difference_acf_tiled(topo, tile=tile, halo=halo)
    print(json.dumps({"t": time.perf_counter() - t0, "tasks": len(G.data.__dask_graph__()),
                      "chunks": topo.data.npartitions}))
    """
)

SMALL = COMMON + textwrap.dedent(
    r"""
    import xrough
    from xrough.correlation import height_difference_acf_tiled
    n, tile, halo = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    topo = xrough.topography(block(0, n, 0, n, 1), spacing=1.0, unit="nm")
    t0 = time.perf_counter(); ref = topo.rough.acf(); t_fft = time.perf_counter() - t0
    t0 = time.perf_counter()
    G = height_difference_acf_tiled(topo, tile=tile, halo=halo)
    t_tiled = time.perf_counter() - t0
    t0 = time.perf_counter()
    R = topo.rough.acf(estimator="random", n_pairs=1_000_000, seed=0)
    t_rand = time.perf_counter() - t0
    rel = np.abs(G.values / ref.values - 1)
    ex = G.block.values == 1
    rr = np.abs(R.values / ref.values - 1)
    print(json.dumps({"t_fft": t_fft, "t_tiled": t_tiled, "t_random": t_rand,
                      "err_exact": float(rel[ex].max()),
                      "err_coarse": float(rel[~ex].max()) if (~ex).any() else 0.0,
                      "err_random": float(np.nanmax(rr))}))
    """
)


def run(script: str, *args) -> dict:
    proc = subprocess.run([sys.executable, "-c", script, *map(str, args)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _map_file(folder: Path, n: int, chunk: int, dtype: str) -> tuple[Path, dict | None]:
    """The map file of one size in ``folder``, written unless it is there already."""
    path = folder / f"map-{n}-{chunk}-{dtype}.nc"
    if path.exists():
        return path, None
    part = path.with_suffix(".part")
    w = run(WRITE, part, n, chunk, dtype)
    part.rename(path)
    return path, w


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[16384],
                        help="map sizes (points per side) of the out-of-core runs")
    parser.add_argument("--small", type=int, default=2048,
                        help="size of the in-memory comparison (0: skip it)")
    parser.add_argument("--chunk", type=int, default=1024, help="NetCDF and dask chunks")
    parser.add_argument("--tile", type=int, default=1024)
    parser.add_argument("--halo", type=int, default=256)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--dtype", default="float32", choices=["float32", "float64"],
                        help="heights in the NetCDF file")
    parser.add_argument("--tmp", default=None, help="folder for temporary NetCDF files")
    parser.add_argument("--data", default=None,
                        help="keep the NetCDF files in this folder and reuse them (written "
                             "once; delete them yourself)")
    parser.add_argument("--write-only", action="store_true",
                        help="only write the files of --data (no computation)")
    parser.add_argument("--graph-only", action="store_true",
                        help="only build the graphs (no file, no computation): tasks")
    args = parser.parse_args(argv)
    gib = 2.0**30
    if args.graph_only:
        for n in args.sizes:
            r = run(GRAPH, n, args.chunk, args.tile, args.halo)
            print(f"{n}^2: {r['chunks']} chunks, {r['tasks']} tasks "
                  f"({r['tasks'] / r['chunks']:.1f} per chunk), built in {r['t']:.1f} s")
        return
    if args.write_only and args.data is None:
        parser.error("--write-only needs --data")
    size = np.dtype(args.dtype).itemsize
    rows = []
    for n in args.sizes:
        with contextlib.ExitStack() as stack:
            if args.data is not None:
                folder = Path(args.data)
                folder.mkdir(parents=True, exist_ok=True)
            else:
                folder = Path(stack.enter_context(tempfile.TemporaryDirectory(dir=args.tmp)))
            path, w = _map_file(folder, n, args.chunk, args.dtype)
            if w is not None:
                print(f"write {n}^2 ({n**2 * size / gib:.2f} GiB): {w['t']:.1f} s, "
                      f"peak {w['peak'] / gib:.2f} GiB", flush=True)
            if args.write_only:
                continue
            r = run(TILED, path, args.chunk, args.tile, args.halo, args.threads)
        print(f"tiled G {n}^2: {r['t']:.1f} s (graph {r['t_graph']:.1f} s), peak "
              f"{r['peak'] / gib:.2f} GiB (after imports {r['base'] / gib:.2f} GiB, after "
              f"the graph {r['peak_graph'] / gib:.2f} GiB), {r['tasks']} tasks, "
              f"{r['reads']} reads of {r['read_chunks']}/{r['chunks']} chunks (at most "
              f"{r['max_reads']} per chunk), at most {r['max_partials']} tile sums held, "
              f"{r['nbins']} bins, {r['exact_bins']} exact, block sizes {r['blocks']}",
              flush=True)
        rows.append((n, r))
    if args.write_only:
        return
    print("\n| map | file GiB | chunks | tasks | reads per chunk | time s | peak GiB |")
    print("|---|---|---|---|---|---|---|")
    for n, r in rows:
        print(f"| {n}² | {n**2 * size / gib:.2f} | {r['chunks']} | {r['tasks']} | "
              f"{r['max_reads']} | {r['t']:.1f} | {r['peak'] / gib:.2f} |")
    for (n0, r0), (n1, r1) in zip(rows, rows[1:]):
        print(f"{n0}² -> {n1}²: points x{(n1 / n0) ** 2:.0f}, time x{r1['t'] / r0['t']:.2f}, "
              f"peak x{r1['peak'] / r0['peak']:.2f}")
    if args.small:
        s = run(SMALL, args.small, args.tile, args.halo)
        print(f"{args.small}^2 in memory: fft {s['t_fft']:.2f} s, tiled {s['t_tiled']:.2f} "
              f"s, random (1e6 pairs) {s['t_random']:.2f} s; max relative error of tiled: "
              f"{s['err_exact']:.1e} (exact bins), {s['err_coarse']:.1e} (block levels); "
              f"random: {s['err_random']:.1e}")


if __name__ == "__main__":
    main()
