"""A folder of scans: the cost per scan of the set analysis against one G per scan.

Writes ``--scans`` synthetic maps (``--n`` points a side, NetCDF, one of them broken)
into a temporary folder, then times, in one process:

- the baseline: ``acf()`` of each map already in memory (one G per scan);
- ``open_set`` of the folder (reading every file, the broken one a line of ``failed``);
- G + PSD + parameters per scan (detrend, ``acf``, ``psd``, ``parameters``) over the tree;
- the whole scene per scan: :func:`xrough.analyse_set` with ``E_star`` and ``p0``
  (detrend, G, its fit, the parameters, Persson theory's contact area; one row per
  scan), one scan after another (``scheduler="sync"``: the CPU cost), then on dask's
  process pool (the wall time a user waits, all cores);

and prints each as a multiple of the baseline (the acceptance: G + PSD + parameters within
3x, the scene within 10x), with the table's rows and its failed one.

Usage::

    python benchmarks/bench_batch.py                 # 100 scans of 256^2
    python benchmarks/bench_batch.py --scans 20 --n 512
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings
from pathlib import Path

import xrough
from xrough.memo import forget


def _write(folder: Path, scans: int, n: int) -> list:
    maps = []
    for seed in range(scans - 1):
        topo = xrough.self_affine_surface(hurst=0.8, n=n, size=f"{n} nm", lambda_r=f"{n // 4} nm",
                                          lambda_s="2 nm", rms_gradient=0.1, unit="nm",
                                          seed=seed)
        topo.to_netcdf(folder / f"scan{seed:03d}.nc")
        maps.append(topo)
    (folder / "broken.nc").write_bytes(b"CDF\x01" + bytes(20))
    return maps


def _timed(func):
    t0 = time.perf_counter()
    out = func()
    return out, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scans", type=int, default=100)
    parser.add_argument("--n", type=int, default=256)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        maps = _write(folder, args.scans, args.n)
        maps[0].rough.acf()  # warm up (imports, caches)
        _, base = _timed(lambda: [m.rough.acf() for m in maps])
        tree, t_open = _timed(lambda: xrough.open_set(folder, progress=False))

        def g_psd_parameters():
            for name in tree.children:
                clean = xrough.detrend(tree[name].to_dataset()["heights"])
                clean.rough.acf()
                clean.rough.psd()
                clean.rough.parameters()

        _, t_gpp = _timed(g_psd_parameters)
        table, t_scene = _timed(lambda: xrough.analyse_set(
            tree, E_star="1 MPa", p0="10 kPa", progress=False, scheduler="sync"))
        forget()  # the second run must not find the first one's fits
        _, t_procs = _timed(lambda: xrough.analyse_set(
            tree, E_star="1 MPa", p0="10 kPa", progress=False, scheduler="processes"))
    good = int((table.quality != "failed").sum())
    print(f"{args.scans} scans of {args.n}^2 ({args.scans - 1} maps and a broken file)")
    print(f"baseline, acf() per scan:            {base / len(maps) * 1e3:8.1f} ms")
    print(f"open_set per scan:                   {t_open / args.scans * 1e3:8.1f} ms "
          f"({t_open / base:.2f} x)")
    print(f"G + PSD + parameters per scan:       {t_gpp / len(maps) * 1e3:8.1f} ms "
          f"({t_gpp / base:.2f} x; with reading {(t_gpp + t_open) / base:.2f} x)")
    print(f"whole scene (analyse_set) per scan:  {t_scene / len(maps) * 1e3:8.1f} ms "
          f"({t_scene / base:.2f} x; with reading {(t_scene + t_open) / base:.2f} x)")
    print(f"whole scene, dask processes (wall):  {t_procs / len(maps) * 1e3:8.1f} ms "
          f"({t_procs / base:.2f} x on {os.cpu_count()} cores)")
    print(f"table: {table.sizes['measurement']} rows, {good} analysed, failed: "
          f"{', '.join(table.measurement.values[table.quality.values == 'failed'])}")


if __name__ == "__main__":
    main()
