"""Flipped bytes in the files xrough writes: how many reopen with changed numbers (must be 0).

For each kind of file, one byte at each of ``N`` positions spread over the whole file (one
drawn at random in each of ``N`` equal slices, so that header, metadata and data are all
hit) is replaced by its complement (``byte ^ 0xFF``), or with ``--bit`` by one flipped bit,
and the file is opened the way xrough opens it:

- ``topography.nc``: a 64 x 64 topography written by :func:`xrough.io.netcdf.write`
  (NetCDF-4, and NetCDF-3 64-bit offset), read by :func:`xrough.io.netcdf.read`;
- ``analysis.nc``: the same topography, its G and its fit archived by
  :func:`xrough.save_analysis`, reopened by :func:`xrough.open_analysis` eagerly
  (``chunks=None``) and lazily (``chunks={}``, then every object computed);
- ``analysis.zarr``: the same as a Zarr store (positions over all its files, in the order
  of their sorted paths), eagerly and lazily (needs ``zarr``).

Each trial counts as *refused* (an exception whose message names the file), *identical*
(:func:`xarray.testing.assert_identical` to what was written: a byte never read, or read
and found unchanged) or *changed* (any other outcome: other numbers, names or attributes,
or an error that does not name the file). The counts are printed as a table.

Usage::

    python benchmarks/archive_fuzz.py            # 1024 positions per file
    python benchmarks/archive_fuzz.py -n 128     # quicker
    python benchmarks/archive_fuzz.py --bit      # one bit instead of a whole byte
    python benchmarks/archive_fuzz.py --timing 2048   # seconds to save and open instead
"""

from __future__ import annotations

import argparse
import importlib.util
import shutil
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

import xrough
from xrough.io import netcdf


def positions(size: int, n: int, seed: int) -> np.ndarray:
    """``n`` positions in ``[0, size)``: one at random in each of ``n`` equal slices."""
    edges = np.linspace(0, size, n + 1).astype(int)
    rng = np.random.default_rng(seed)
    return np.array([rng.integers(lo, max(hi, lo + 1)) for lo, hi in zip(edges[:-1], edges[1:])])


def flipped(raw: bytes, at: int, bit: int | None) -> bytes:
    out = bytearray(raw)
    out[at] ^= 0xFF if bit is None else 1 << bit
    return bytes(out)


def analysis() -> dict:
    """A topography, its G and its fit: what an archive typically holds."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        topo = xrough.self_affine_surface(hurst=0.8, lambda_r=32.0, lambda_s=4.0, size=64.0,
                                          n=64, rms_gradient=0.1, unit="nm", seed=0)
        G = topo.rough.acf()
        fit = G.rough.fit()
    return {"m": {"topography": topo, "G": G, "fit": fit}}


def same_analysis(back: dict, original: dict) -> None:
    for key, value in original["m"].items():
        xr.testing.assert_identical(back["m"][key].compute(), value)


def trial(path: Path, label: str, read, check) -> str:
    """Open ``path`` with ``read`` and classify the outcome."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            back = read(path)
            check(back)
    except AssertionError:
        return "changed"
    except Exception as err:  # noqa: BLE001 - every refusal must name the file
        return "refused" if label in str(err) else "changed"
    return "identical"


def fuzz_file(raw: bytes, target: Path, readers: dict, n: int, bit: bool, seed: int) -> dict:
    """Flip bytes of one file; return ``{mode: {outcome: count}}``.

    Each trial and way of opening gets a file of its own name: the NetCDF library keeps
    files open (a lazy open) and would otherwise read a later trial from its cache.
    """
    rng = np.random.default_rng(seed + 1)
    counts = {mode: {"refused": 0, "identical": 0, "changed": 0} for mode in readers}
    for at in positions(len(raw), n, seed):
        data = flipped(raw, int(at), int(rng.integers(8)) if bit else None)
        for mode, (read, check) in readers.items():
            path = target.with_name(f"{target.stem}-{mode}-{at}{target.suffix}")
            path.write_bytes(data)
            counts[mode][trial(path, path.name, read, check)] += 1
    return counts


def fuzz_store(store: Path, readers: dict, n: int, bit: bool, seed: int) -> dict:
    """Flip bytes of a Zarr store (positions over its files in sorted order), restoring each."""
    files = sorted(p for p in store.rglob("*") if p.is_file())
    sizes = np.cumsum([0] + [p.stat().st_size for p in files])
    rng = np.random.default_rng(seed + 1)
    counts = {mode: {"refused": 0, "identical": 0, "changed": 0} for mode in readers}
    for at in positions(int(sizes[-1]), n, seed):
        k = int(np.searchsorted(sizes, at, side="right")) - 1
        raw = files[k].read_bytes()
        files[k].write_bytes(flipped(raw, int(at - sizes[k]), int(rng.integers(8)) if bit
                                     else None))
        for mode, (read, check) in readers.items():
            counts[mode][trial(store, store.name, read, check)] += 1
        files[k].write_bytes(raw)
    return counts


def run(n: int = 1024, bit: bool = False, seed: int = 0, zarr: bool = True) -> dict:
    """All measurements; returns ``{(file, format, open): {outcome: count}}``."""
    results = {}
    original = analysis()
    topo = original["m"]["topography"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for fmt in ("NETCDF4", "NETCDF3_64BIT"):
            netcdf.write(topo, tmp / "seed.nc", format=fmt)
            counts = fuzz_file((tmp / "seed.nc").read_bytes(), tmp / "topography.nc",
                               {"eager": (netcdf.read,
                                          lambda back: xr.testing.assert_identical(back, topo))},
                               n, bit, seed)
            results[("topography.nc", fmt, "eager")] = counts["eager"]
        readers = {"eager": (xrough.open_analysis,
                             lambda back: same_analysis(back, original)),
                   "lazy": (lambda p: xrough.open_analysis(p, chunks={}),
                            lambda back: same_analysis(back, original))}
        xrough.save_analysis(tmp / "seed.nc", original)
        counts = fuzz_file((tmp / "seed.nc").read_bytes(), tmp / "analysis.nc", readers, n,
                           bit, seed)
        results.update({("analysis.nc", "NETCDF4", m): c for m, c in counts.items()})
        if zarr:
            xrough.save_analysis(tmp / "seed.zarr", original)
            shutil.copytree(tmp / "seed.zarr", tmp / "analysis.zarr")
            counts = fuzz_store(tmp / "analysis.zarr", readers, n, bit, seed)
            results.update({("analysis.zarr", "Zarr 2", m): c for m, c in counts.items()})
    return results


def timing(n: int = 2048, repeat: int = 3) -> dict:
    """Best-of-``repeat`` seconds to save and to open (eagerly) an ``n x n`` topography and
    its G, as NetCDF and as Zarr; ``{(format, "save" or "open"): seconds, ...}``."""
    topo = xrough.topography(np.random.default_rng(0).normal(size=(n, n)), spacing=1.0,
                             unit="nm")
    data = {"m": {"topography": topo, "G": topo.rough.acf()}}
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for suffix in (".nc", ".zarr") if importlib.util.find_spec("zarr") else (".nc",):
            path = Path(tmp) / f"t{suffix}"
            for what, call in (("save", xrough.save_analysis), ("open", xrough.open_analysis)):
                times = []
                for _ in range(repeat):
                    start = time.perf_counter()
                    call(path, data) if what == "save" else call(path)
                    times.append(time.perf_counter() - start)
                out[(suffix, what)] = min(times)
            out[(suffix, "MB")] = sum(p.stat().st_size for p in [path, *path.rglob("*")]
                                      if p.is_file()) / 1e6
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=1024, help="positions per file (1024)")
    parser.add_argument("--bit", action="store_true", help="flip one bit, not a whole byte")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timing", type=int, metavar="N", default=0,
                        help="only time save and open of an N x N topography and its G")
    args = parser.parse_args()
    if args.timing:
        for (suffix, what), value in timing(args.timing).items():
            print(f"{suffix:<6}{what:<5}{value:8.2f}{' MB' if what == 'MB' else ' s'}")
        return
    zarr = importlib.util.find_spec("zarr") is not None
    start = time.perf_counter()
    results = run(args.n, args.bit, args.seed, zarr)
    flip = "one bit" if args.bit else "one byte (^0xFF)"
    print(f"{args.n} positions per file, {flip} flipped, xrough {xrough.__version__}"
          f"{'' if zarr else ' (no zarr: Zarr skipped)'}")
    print(f"{'file':<15}{'format':<15}{'open':<7}{'refused':>9}{'identical':>11}{'changed':>9}")
    for (name, fmt, mode), c in results.items():
        print(f"{name:<15}{fmt:<15}{mode:<7}{c['refused']:>9}{c['identical']:>11}"
              f"{c['changed']:>9}")
    print(f"{time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
