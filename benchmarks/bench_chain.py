"""Run time of the whole chain a user runs on a measurement, step by step, against its G.

For every real measurement of ``../shared/data`` (the table ``CASES`` of
``tests/test_real_data.py``: its files, open options and detrending; the cases whose chain
must stop are left out, and those read through SurfaceTopography when it is not
installed) and for one synthetic 2048 x 2048 map (a periodic self-affine surface, H = 0.8),
each step of the chain is timed as a user writes it::

    topo = open + detrend + mask_outliers      (the synthetic map: its generation)
    G = topo.rough.acf()
    G.rough.fit()
    G.rough.persson(E_star="25 MPa", p0="0.1 MPa")     # no fit=: is the fit redone?
    G.rough.energy(E_star="25 MPa")
    G.rough.stress_acf(E_star="25 MPa")
    G.rough.patch_radius(E_star="25 MPa", gamma="50 mJ/m^2")
    xrough.save_analysis(path, {"m": {"topography": topo, "G": G, ...results...}})

and, after them on the same G, ``G.rough.fit(model="eq36")`` (the closed form, a
reference column). Every step is printed as a multiple of the time of ``acf`` on the same
map, in CPU time (``time.process_time``, all threads) and in wall time
(``time.perf_counter``), with the time of ``acf`` itself in ms.

``chain`` is the cost of the chain after G (fit + persson + energy + stress_acf +
patch_radius) as a multiple of acf's CPU time, and ``check`` compares it with the target:
at most 10 x acf, or at most 0.3 s of CPU when acf takes less than 30 ms. ``scene`` is the
whole scene, open + acf + chain + save, as a multiple of acf's CPU time, and ``aim``
compares it with the stricter aim: at most 5 x acf for a map, 10 x for a profile.

Method: interleaved rounds, after an untimed warm-up (the chain of a small synthetic map
and profile: the library's lazy imports and first calls). Round 1 runs the chain of every
map once, then round 2 again, and so on (``--rounds``), each round from a freshly opened
map and a fresh G, as a user runs it. Before each chain the results the library keeps
(:func:`xrough.memo.forget`: results kept by content would answer round 2 from round
1) are forgotten, so that every round computes what a user's
first run on that map computes; within a chain, what one step keeps serves the next. A
step's time is its median over the rounds, ``chain`` the median of the per-round sums.
Interleaving spreads the noise of a shared machine over all maps instead of letting it
land on one.

Last, the command line ``xrough report FILE --E-star 25MPa --p0 0.1MPa`` is timed as a
whole process (wall time, imports included) on the files of ``--report-files``, the
open options of ``CASES`` passed as flags (``--unit``, ``--resample``, ``--detrend``); the
target is at most 3 s.

The data folder is ``../shared/data`` next to the project (``--data`` to change it); the
benchmark says so and stops when it is absent.

Usage::

    python benchmarks/bench_chain.py                        # everything, 3 rounds
    python benchmarks/bench_chain.py --files di-1 uncd-TEM --rounds 1 --no-synthetic
    python benchmarks/bench_chain.py --no-report --markdown # the table of docs/performance.md
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

import xrough
from xrough.memo import forget

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
from _data import data_root  # noqa: E402  (where the measurement files are)

DATA = data_root()
E_STAR, P0, GAMMA = "25 MPa", "0.1 MPa", "50 mJ/m^2"
SYNTHETIC = "synthetic-2048"
#: The steps timed, in order; ``eq36`` comes after the chain so it cannot feed it.
STEPS = ("open", "acf", "fit", "persson", "energy", "stress_acf", "patch_radius", "save",
         "eq36")
#: The chain after G, whose cost is checked.
CHAIN = ("fit", "persson", "energy", "stress_acf", "patch_radius")
#: Targets: chain <= RATIO x acf CPU, or <= FLOOR s CPU when acf < FAST s; report <= REPORT s.
RATIO, FLOOR, FAST, REPORT = 10.0, 0.3, 0.03, 3.0
#: The whole scene (open, acf, chain, save) as a multiple of acf: the aim for maps, profiles.
SCENE = ("open", "acf", *CHAIN, "save")
SCENE_AIM = {2: 5.0, 1: 10.0}
REPORT_FILES = ("x3p-2", "di-1", "uncd-AFM", "dektak-1")


def _load_cases(data: Path):
    """``CASES`` and ``_open_clean`` of tests/test_real_data.py, reading from ``data``."""
    sys.path.insert(0, str(ROOT / "tests"))
    import conftest

    conftest.DATA = data  # before test_real_data imports it (its table reads meta.yml)
    import test_real_data

    return test_real_data.CASES, test_real_data._open_clean, conftest.needs_bridge


def _synthetic(n: int = 2048, profile: bool = False) -> xr.DataArray:
    return xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="50 nm",
                                      size=f"{20 * n / 2048} um", n=n, rms_gradient=0.5,
                                      seed=1, unit="nm", profile=profile)


def _chain(open_map, folder: Path) -> tuple[dict, dict, str | None]:
    """One run of the chain: CPU and wall seconds per step, and the failure if any."""
    cpu, wall, r = {}, {}, {}
    forget()  # computed as the first time in a process, each round

    def acf():
        topo = r["open"]
        return topo.rough.acf(unit="nm") if isinstance(topo, xr.DataTree) else topo.rough.acf()

    def save():
        topo = r["open"]
        maps = ({f"topography_{n}": topo[n]["h"] for n in topo.children}
                if isinstance(topo, xr.DataTree) else {"topography": topo})
        results = {k: v for k, v in r.items() if k not in ("open", "acf")}
        return xrough.save_analysis(folder / "analysis.nc",
                                    {"m": {**maps, "G": r["acf"], **results}})

    steps = {
        "open": open_map,
        "acf": acf,
        "fit": lambda: r["acf"].rough.fit(),
        "persson": lambda: r["acf"].rough.persson(E_star=E_STAR, p0=P0),
        "energy": lambda: r["acf"].rough.energy(E_star=E_STAR),
        "stress_acf": lambda: r["acf"].rough.stress_acf(E_star=E_STAR),
        "patch_radius": lambda: r["acf"].rough.patch_radius(E_star=E_STAR, gamma=GAMMA),
        "save": save,
        "eq36": lambda: r["acf"].rough.fit(model="eq36"),
    }
    for step in STEPS:
        if step == "acf":
            topo = r["open"]
            cpu["ndim"] = wall["ndim"] = (min(topo[n]["h"].ndim for n in topo.children)
                                          if isinstance(topo, xr.DataTree) else topo.ndim)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # real data carries QualityWarnings
            c0, w0 = time.process_time(), time.perf_counter()
            try:
                r[step] = steps[step]()
            except Exception as err:  # noqa: BLE001 - a failing step is reported, not fatal
                return cpu, wall, f"{step}: {type(err).__name__}: {err}"
            cpu[step] = time.process_time() - c0
            wall[step] = time.perf_counter() - w0
    return cpu, wall, None


def _median(runs: list[dict], step: str) -> float:
    values = [run[step] for run in runs if step in run]
    return float(np.median(values)) if values else np.nan


def _summary(cpu_runs: list[dict], wall_runs: list[dict]) -> dict:
    """Median seconds per step and of the chain after G, CPU and wall."""
    out = {}
    for kind, runs in (("cpu", cpu_runs), ("wall", wall_runs)):
        out[kind] = {step: _median(runs, step) for step in STEPS}
        chains = [sum(run[s] for s in CHAIN) for run in runs if all(s in run for s in CHAIN)]
        out[kind]["chain"] = float(np.median(chains)) if chains else np.nan
        scenes = [sum(run[s] for s in SCENE) for run in runs if all(s in run for s in SCENE)]
        out[kind]["scene"] = float(np.median(scenes)) if scenes else np.nan
    acf, chain = out["cpu"]["acf"], out["cpu"]["chain"]
    ndim = next((run["ndim"] for run in cpu_runs if "ndim" in run), 2)
    scene = out["cpu"]["scene"]
    out["aim"] = ("-" if np.isnan(scene)
                  else "PASS" if scene <= SCENE_AIM[min(ndim, 2)] * acf else "FAIL")
    if np.isnan(chain):
        out["check"] = "-"
    else:
        ok = chain <= RATIO * acf or (acf < FAST and chain <= FLOOR)
        out["check"] = "PASS" if ok else "FAIL"
    return out


def _table(title: str, kind: str, rows: dict, markdown: bool) -> None:
    cols = ["acf ms", *[s for s in STEPS if s != "acf"], "chain", "scene"]
    if kind == "cpu":
        cols += ["chain s", "check", "aim"]
    cells = {}
    for cid, row in rows.items():
        times = row[kind]
        line = [f"{1e3 * times['acf']:.1f}"]
        for step in cols[1:]:
            value = times.get(step, np.nan) / times["acf"]
            line.append(row[step] if step in ("check", "aim")
                        else f"{times['chain']:.2f}" if step == "chain s"
                        else "-" if np.isnan(value)
                        else f"{value:.2f}" if value < 10 else f"{value:.0f}")
        cells[cid] = line
    if markdown:
        print(f"\n**{title}**\n")
        print("| map | " + " | ".join(cols) + " |")
        print("|:---|" + "---:|" * len(cols))
        for cid, line in cells.items():
            print(f"| {cid} | " + " | ".join(line) + " |")
        return
    first = max([len("map"), *map(len, cells)])
    widths = [max([len(c), *(len(line[k]) for line in cells.values())])
              for k, c in enumerate(cols)]
    print(f"\n{title}")
    head = f"{'map':<{first}}  " + " ".join(f"{c:>{w}}" for c, w in zip(cols, widths))
    print(head)
    print("-" * len(head))
    for cid, line in cells.items():
        print(f"{cid:<{first}}  " + " ".join(f"{c:>{w}}" for c, w in zip(line, widths)))


def _report_argv(case) -> list[str] | None:
    """The ``xrough report`` flags of a case's open options (None: not one file)."""
    if len(case.parts) < 2:
        return None
    flags = []
    for key, value in case.open.items():
        if key == "unit":
            flags += ["--unit", value]
        elif key == "resample" and value:
            flags.append("--resample")
        else:
            return None  # an open option the command line does not have
    return [*flags, "--detrend", case.detrend]


def _time_reports(ids: list[str], cases: dict, data: Path, rounds: int) -> None:
    runs: dict[str, list[float]] = {}
    failed: dict[str, str] = {}
    argvs = {}
    for cid in ids:
        argv = _report_argv(cases[cid])
        if argv is None:
            print(f"report: {cid} skipped (not one file, or options the command lacks)")
        else:
            argvs[cid] = [str(data.joinpath(*cases[cid].parts)), *argv]
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(rounds):
            for cid, argv in argvs.items():
                cmd = [sys.executable, "-m", "xrough.cli", "report", *argv, "--E-star",
                       "25MPa", "--p0", "0.1MPa", "-o", str(Path(tmp) / f"{cid}.nc")]
                t0 = time.perf_counter()
                done = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True)
                seconds = time.perf_counter() - t0
                if done.returncode:
                    failed[cid] = f"exit {done.returncode}: {done.stderr.strip()[-300:]}"
                runs.setdefault(cid, []).append(seconds)
    if not argvs:
        return
    print(f"\nxrough report FILE --E-star 25MPa --p0 0.1MPa (whole process, wall; "
          f"target <= {REPORT:g} s)")
    width = max(map(len, argvs))
    for cid, times in runs.items():
        seconds = float(np.median(times))
        verdict = "ERROR" if cid in failed else "PASS" if seconds <= REPORT else "FAIL"
        flags = " ".join(argvs[cid][1:])
        print(f"{cid:<{width}} {seconds:6.2f} s  {verdict}   [{flags}]")
    for cid, why in failed.items():
        print(f"  {cid}: {why}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", nargs="*", metavar="ID",
                        help="case ids of tests/test_real_data.py (default: all; none: "
                             "only the synthetic map)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--no-synthetic", action="store_true")
    parser.add_argument("--no-report", action="store_true")
    parser.add_argument("--report-files", nargs="+", metavar="ID", default=REPORT_FILES)
    parser.add_argument("--data", type=Path, default=DATA, help="measurement folder")
    parser.add_argument("--markdown", action="store_true", help="Markdown tables")
    args = parser.parse_args()

    data = args.data.resolve()
    if not data.is_dir():
        print(f"measurement data not available ({data}): nothing to benchmark "
              "(--data to point at it)")
        return 0
    cases, open_clean, needs_bridge = _load_cases(data)
    no_bridge = needs_bridge.mark.args[0]  # the skipif condition: bridge not importable
    unknown = (set(args.files or ()) | set(args.report_files)) - set(cases)
    if unknown:
        parser.error(f"unknown case ids {sorted(unknown)}; known: {sorted(cases)}")

    maps = {}
    for cid in cases if args.files is None else args.files:
        case = cases[cid]
        if case.refuses:
            print(f"{cid}: skipped (its chain must stop at {case.refuses[0]})")
        elif case.bridge and no_bridge:
            print(f"{cid}: skipped ({needs_bridge.mark.kwargs['reason']})")
        elif not data.joinpath(*case.parts).exists():
            print(f"{cid}: skipped (not in {data})")
        else:
            maps[cid] = lambda case=case: open_clean(case)
    if not args.no_synthetic:
        maps[SYNTHETIC] = _synthetic

    print("results the library keeps (xrough.memo) are forgotten before each chain")
    cpu = {cid: [] for cid in maps}
    wall = {cid: [] for cid in maps}
    errors: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for profile in (False, True):  # warm-up, untimed: lazy imports, first calls
            _chain(lambda profile=profile: _synthetic(256, profile), Path(tmp))
        for k in range(args.rounds):
            print(f"round {k + 1}/{args.rounds}: ", end="", flush=True)
            for cid, open_map in maps.items():
                folder = Path(tmp) / cid
                folder.mkdir(exist_ok=True)
                c, w, err = _chain(open_map, folder)
                cpu[cid].append(c)
                wall[cid].append(w)
                if err:
                    errors.setdefault(cid, err)
                print(cid if not err else f"{cid}(!)", end=" ", flush=True)
            print()

    rows = {cid: _summary(cpu[cid], wall[cid]) for cid in maps
            if any("acf" in run for run in cpu[cid])}
    if rows:
        rounds = f"median of {args.rounds} interleaved round(s)"
        _table(f"CPU time, multiples of acf's ({rounds}); chain = {' + '.join(CHAIN)}; "
               f"check: chain <= {RATIO:g} x acf, or <= {FLOOR:g} s when acf < "
               f"{1e3 * FAST:g} ms; scene = {' + '.join(SCENE)}; aim: scene <= "
               f"{SCENE_AIM[2]:g} x acf (map), {SCENE_AIM[1]:g} x (profile)", "cpu", rows,
               args.markdown)
        _table(f"wall time, multiples of acf's ({rounds})", "wall", rows, args.markdown)
        fit = {cid: row["cpu"]["fit"] / row["cpu"]["acf"] for cid, row in rows.items()
               if np.isfinite(row["cpu"]["fit"])}
        checks = [row["check"] for row in rows.values()]
        if fit:
            worst = max(fit, key=fit.get)
            print(f"\nfit / acf (CPU): median {np.median(list(fit.values())):.2f}, max "
                  f"{fit[worst]:.2f} ({worst}); check: {checks.count('PASS')} PASS, "
                  f"{checks.count('FAIL')} FAIL of {len(checks)}")
        aims = [row["aim"] for row in rows.values()]
        print(f"scene / acf (CPU): aim {aims.count('PASS')} PASS, {aims.count('FAIL')} FAIL "
              f"of {len(aims)}")
    for cid, err in errors.items():
        print(f"{cid}: the chain stopped at {err}")

    if not args.no_report:
        _time_reports(list(args.report_files), cases, data, args.rounds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
