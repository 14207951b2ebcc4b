"""CPU time of ``import xrough`` and of ``xrough report`` against ``import xarray``.

Each command runs as a fresh Python process (the CPU time of the child, user + system, from
:func:`resource.getrusage`), in interleaved rounds after one untimed run of each (which
writes the byte code a wheel install has from the start: a checkout run with
``PYTHONDONTWRITEBYTECODE`` would compile xrough on every import). Printed: the median CPU
time of each command and its ratio to ``import xarray`` in the same rounds, and the report's
ratio to ``import xrough``. What the report spends beyond the import is the work it does on
the file (open, G, fit, Persson theory, plots, HTML).

``report floor`` is what any report process pays before its first result, none of it
xrough's: ``import xrough``, xarray's first DataArray (with dask installed, xarray imports
``dask.array`` to check each new array's type), ``matplotlib.pyplot`` and the unit registry
(pint's definitions parsed, in cf-xarray's registry). The report's ratio to it is the share
of the work itself.

The targets: ``import xrough`` at most 1.5 x ``import xarray``; the report of a real file
at most 1.5 x ``import xrough`` (``--file``, default ``../shared/data/instruments/di-1.di``,
opened with ``--detrend plane``; skipped when absent).

Usage::

    python benchmarks/bench_import.py --rounds 7
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def _cpu(argv: list[str], env: dict) -> float:
    """CPU seconds (user + system) of one child process running ``argv``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(argv, check=True, env=env, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--file", type=Path, default=DATA / "instruments" / "di-1.di")
    args = parser.parse_args()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["MPLBACKEND"] = "Agg"
    out = Path(tempfile.mkdtemp()) / "report.html"
    floor = ("import numpy, xarray, xrough; xarray.DataArray(numpy.zeros(2)); "
             "import matplotlib.pyplot; xrough.units.parse_units('nm')")
    commands = {"import xarray": [sys.executable, "-c", "import xarray"],
                "import xrough": [sys.executable, "-c", "import xrough"],
                "report floor": [sys.executable, "-c", floor]}
    if args.file.exists():
        commands["xrough report"] = [sys.executable, "-m", "xrough.cli", "report", str(args.file),
                                     "--E-star", "25MPa", "--p0", "0.1MPa",
                                     "--detrend", "plane", "-o", str(out)]
    else:
        print(f"{args.file} is absent: the report is not timed")
    for argv in commands.values():  # byte code, disk cache
        _cpu(argv, env)
    times: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(args.rounds):
        for name, argv in commands.items():
            times[name].append(_cpu(argv, env))
    med = {name: statistics.median(t) for name, t in times.items()}
    base = med["import xarray"]
    print(f"CPU time, median of {args.rounds} interleaved rounds (Python {sys.version.split()[0]})")
    for name, t in med.items():
        print(f"{name:15s} {t:6.3f} s  {t / base:5.2f} x import xarray")
    ratio = med["import xrough"] / base
    print(f"import xrough / import xarray = {ratio:.2f} (target <= 1.5): "
          f"{'PASS' if ratio <= 1.5 else 'FAIL'}")
    if "xrough report" in med:
        ratio = med["xrough report"] / med["import xrough"]
        print(f"xrough report / import xrough = {ratio:.2f} (target <= 1.5): "
              f"{'PASS' if ratio <= 1.5 else 'FAIL'}")
        print(f"report floor / import xrough = {med['report floor'] / med['import xrough']:.2f}"
              f"; xrough report / report floor = {med['xrough report'] / med['report floor']:.2f}")


if __name__ == "__main__":
    main()
