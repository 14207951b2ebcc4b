"""``xrough report`` on a folder of scans: one process against worker processes (``--jobs``).

A folder holds ``--scans`` copies (symbolic links) of one measurement of ``../shared/data``
(``--file``, default the 512 x 512 AFM map ``instruments/di-1.di``). The command line
``xrough report FOLDER --E-star 25MPa --p0 0.1MPa --jobs J`` is timed as a whole process
(wall time, imports included) for each ``J`` of ``--jobs`` in turn, ``--rounds`` times,
interleaved; the table gives the median wall time, the time per scan and the ratio to
``--jobs 1`` of the same round. Each worker process imports the library before its first
scan, which sets :data:`xrough.cli._files.AUTO_JOBS_FILES` (the folder size from which
``--jobs 0`` uses one process per core).

Usage::

    python benchmarks/bench_cli_folder.py                       # 8 and 32 scans, jobs 1 and 2
    python benchmarks/bench_cli_folder.py --scans 4 8 16 --jobs 1 2 4 --rounds 3
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def _run(folder: Path, out: Path, jobs: int) -> float:
    cmd = [sys.executable, "-m", "xrough.cli", "report", str(folder), "--E-star", "25MPa",
           "--p0", "0.1MPa", "--jobs", str(jobs), "-o", str(out)]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--file", default="instruments/di-1.di",
                    help="measurement under the data folder")
    ap.add_argument("--data", type=Path, default=DATA, help="measurement folder")
    ap.add_argument("--scans", type=int, nargs="+", default=[8, 32])
    ap.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args()
    source = args.data / args.file
    if not source.is_file():
        sys.exit(f"{source}: not found (the benchmark needs the data folder; --data)")
    print(f"{os.cpu_count()} cores; {source.name} copied into each folder")
    print(f"{'scans':>5} {'jobs':>4} {'wall s':>7} {'s/scan':>7} {'vs jobs 1':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        for scans in args.scans:
            folder = Path(tmp) / f"scans{scans}"
            folder.mkdir()
            for k in range(scans):
                (folder / f"scan{k:03d}{source.suffix}").symlink_to(source)
            times: dict[int, list[float]] = {j: [] for j in args.jobs}
            for _ in range(args.rounds):
                for j in args.jobs:
                    times[j].append(_run(folder, Path(tmp) / f"out{scans}_{j}.nc", j))
            base = np.array(times[args.jobs[0]])
            for j in args.jobs:
                t = np.array(times[j])
                print(f"{scans:>5} {j:>4} {np.median(t):7.2f} {np.median(t) / scans:7.3f} "
                      f"{np.median(t / base):9.2f}")


if __name__ == "__main__":
    main()
