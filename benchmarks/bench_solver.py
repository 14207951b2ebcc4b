"""Run time, iterations and memory of ``solve_contact`` against two peer contact solvers.

The same problem is handed to every solver: a periodic self-affine surface (Hurst 0.8,
roll-off at L/4, short-wavelength cutoff 4 pixels) of N x N points on a square periodic
domain of side L, pressed against a linear-elastic half-space of contact modulus ``E*``
at the mean pressure ``p0 = p* E* gbar`` (``--load p*``, default 0.01; ``gbar``: the rms
gradient of the realised map), at one tolerance (``--tol``, default 1e-8). The peers are

* tamaas (``tm.PolonskyKeerRey`` on a ``basic_2d`` model with ``E = E*``, ``nu = 0``;
  ``solve(p0)`` takes the mean pressure);
* ContactMechanics (``constrained_conjugate_gradients`` on a
  ``PeriodicFFTElasticHalfSpace(young=E*)``; it works with pixel forces, so the external
  force is ``p0 L^2``; convergence by ``pentol = tol * rms(h)``, ``forcetol`` and
  ``thermotol = tol``).

All three take the heights as the rigid surface, peaks towards the elastic body, and
use the periodic Green's function ``u~ = 2 p~ / (E* |q|)``.

Method. One process per size, so that every solver runs in the same process state. Each
solver is first warmed up (imported and run once on a 128^2 map); then the solvers take
turns, ``--repeats`` rounds of one solve each. Times cover set-up and solve. Each
solver's row gives its best and median time and the spread (max / min). The ratio of
xrough to the faster peer is given three ways: best over best with its worst-case range
(best over the peer's worst to worst over the peer's best), and the median and range of
the ratios within each round (both solves of a round ran minutes apart at most, under
the same load).

Two-FFT floor. Right before and right after each xrough solve, a block of as many
``scipy.fft.rfft2`` plus ``irfft2`` pairs of the N x N float64 map (same ``workers``) as
xrough took fine-grid iterations runs back to back, so that the floor is measured over a
similar stretch of time and load as the solve (a single pair's best time catches quiet
moments a long solve cannot). xrough's time per fine-grid iteration (the whole solve,
coarse grid included, over the fine-grid iterations) is divided by the mean pair time
of the two blocks; the median and range over the rounds are printed, also in CPU time
(the process's CPU time over all threads, for the solve and for the floor blocks), which
other jobs on the machine disturb less than wall-clock time, and for reference the
ratio to the best single pair.

xrough runs with its defaults, the FFT preconditioner included; ``--plain`` adds a row
of xrough without it (``precondition=False``, one transform pair less per iteration).
For each xrough row the time per transform pair (the solve over half its forward plus
inverse transforms) over the floor pair is printed too: what the solver spends beyond
its transforms (float32 transforms cost about half a float64 floor pair, so the ratio
can fall below 1).

Memory. The peak memory of one xrough solve is measured in a fresh subprocess: the peak
resident set size above the state before the solve (``resource``), and the peak of the
memory allocated through Python and numpy (``tracemalloc``), both in units of the map's
size in float64 (8 N^2 bytes). ``--peer-memory`` measures the peers' resident memory the
same way (their allocations are invisible to tracemalloc).

Peers that are not installed are skipped (``pip install xrough[bench]``).

Usage::

    python benchmarks/bench_solver.py                    # 1024 and 2048
    python benchmarks/bench_solver.py --sizes 256 512 --repeats 5
"""

from __future__ import annotations

import argparse
import ctypes
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import textwrap
import time

import numpy as np
from scipy import fft as sfft

import xrough

L = 1.0  # um, side of the periodic domain
E_STAR = 1.0  # the problem is linear in E*: pressures are in units of E*
HURST = 0.8
RMS_GRADIENT = 0.1
PEERS = ("tamaas", "ContactMechanics")

MEMORY_CHILD = textwrap.dedent(
    r"""
    import json, resource, sys, tracemalloc
    import numpy as np
    sys.path.insert(0, sys.argv[5])
    import bench_solver as b
    what, path, p0, tol = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
    h = np.load(path)

    def current():  # resident set size now (Linux), the baseline before the solve
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * resource.getpagesize()

    b.SOLVERS[what](h[:128, :128].copy(), p0, tol)  # libraries loaded before the baseline
    base = current()
    tracemalloc.start()
    b.SOLVERS[what](h, p0, tol)
    traced = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    print("RESULT " + json.dumps({"rss": peak - base, "traced": traced}))
    """
)


def installed(name: str) -> bool:
    """Whether ``name`` can be imported."""
    return importlib.util.find_spec(name) is not None


def surface(n: int, seed: int) -> tuple[np.ndarray, float]:
    """Heights (um) of the periodic test surface and their rms gradient."""
    topo = xrough.self_affine_surface(
        hurst=HURST, lambda_r=L / 4, lambda_s=4 * L / n, size=L, n=n,
        rms_gradient=RMS_GRADIENT, seed=seed, unit="um")
    h = np.ascontiguousarray(topo.transpose("y", "x").values, dtype=float)
    # rms gradient of this realisation, spectrally (periodic map)
    q = 2 * np.pi * np.fft.fftfreq(n, d=L / n)
    q2 = q[:, None] ** 2 + q[None, :] ** 2
    gbar = float(np.sqrt(np.sum(q2 * np.abs(np.fft.fft2(h)) ** 2)) / n**2)
    return h, gbar


def solve_xrough(h: np.ndarray, p0: float, tol: float, precondition: bool = True) -> dict:
    """Solve with xrough; contact area, iterations, the float32 share and transforms."""
    n = h.shape[0]
    topo = xrough.topography(h, spacing=L / n, unit="um", periodic=True)
    res = xrough.solve_contact(topo, E_star=E_STAR, p0=p0, tol=tol, max_iter=100_000,
                               progress=False, workers=os.cpu_count(),
                               precondition=precondition)
    coarse = int(res.coarse_iterations)
    return {"area": float(res.contact_area), "iterations": int(res.iterations),
            "fine_iterations": int(res.iterations) - coarse, "coarse_iterations": coarse,
            "float32_iterations": int(res.float32_iterations),
            "transforms": int(res.transforms), "converged": bool(res.converged)}


def _captured_stderr(func):
    """Run ``func()`` with the process's stderr (file descriptor 2, tamaas' log) as text."""
    libc = ctypes.CDLL(None)
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile(mode="w+") as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            func()
        finally:
            libc.fflush(None)  # C and C++ streams buffered in the library
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
        tmp.seek(0)
        return tmp.read()


def solve_tamaas(h: np.ndarray, p0: float, tol: float) -> dict:
    """Solve with tamaas' PolonskyKeerRey (the iteration count is read from its log)."""
    import tamaas as tm  # optional peer

    n = h.shape[0]
    tm.set_log_level(tm.LogLevel.info)
    model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [L, L], [n, n])
    model.E, model.nu = E_STAR, 0.0  # E* = E / (1 - nu^2)
    solver = tm.PolonskyKeerRey(model, h, tol)
    solver.max_iter = 100_000
    log = _captured_stderr(lambda: solver.solve(p0))
    rows = [s.split() for s in log.splitlines() if len(s.split()) == 3
            and s.split()[0].isdigit()]
    p = np.asarray(model.traction)
    return {"area": float(np.mean(p > 0)), "iterations": int(rows[-1][0]) if rows else -1,
            "converged": True}


def solve_contactmechanics(h: np.ndarray, p0: float, tol: float) -> dict:
    """Solve with ContactMechanics' constrained conjugate gradients."""
    from ContactMechanics import PeriodicFFTElasticHalfSpace  # optional peer
    from ContactMechanics.Optimization import constrained_conjugate_gradients

    n = h.shape[0]
    sub = PeriodicFFTElasticHalfSpace((n, n), E_STAR, physical_sizes=(L, L))
    res = constrained_conjugate_gradients(
        sub, h, external_force=p0 * L * L, pentol=tol * float(h.std()),
        forcetol=tol, thermotol=tol, maxiter=100_000)
    f = np.asarray(res.jac)  # pixel forces, compressive positive
    return {"area": float(np.mean(f > 0)), "iterations": int(res.nit),
            "converged": bool(res.success)}


def solve_xrough_plain(h: np.ndarray, p0: float, tol: float) -> dict:
    """Solve with xrough without the preconditioner (one transform pair less per iteration)."""
    return solve_xrough(h, p0, tol, precondition=False)


SOLVERS = {"xrough": solve_xrough, "xrough-plain": solve_xrough_plain,
           "tamaas": solve_tamaas, "ContactMechanics": solve_contactmechanics}
OURS = ("xrough", "xrough-plain")


def fft_floor(n: int, repeats: int) -> list[float]:
    """Times of single pairs of one rfft2 plus one irfft2 of an n x n float64 map."""
    a = np.random.default_rng(0).standard_normal((n, n))
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        b = sfft.rfft2(a, workers=os.cpu_count())
        sfft.irfft2(b, s=(n, n), workers=os.cpu_count(), overwrite_x=True)
        out.append(time.perf_counter() - t0)
    return out


def fft_floor_block(n: int, pairs: int) -> tuple[float, float]:
    """Mean wall-clock and CPU time of one rfft2 plus irfft2 pair over ``pairs`` pairs."""
    a = np.random.default_rng(0).standard_normal((n, n))
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(pairs):
        b = sfft.rfft2(a, workers=os.cpu_count())
        sfft.irfft2(b, s=(n, n), workers=os.cpu_count(), overwrite_x=True)
    return (time.perf_counter() - t0) / pairs, (time.process_time() - c0) / pairs


def spread(values: list[float]) -> str:
    """Median and range of ``values`` as text."""
    return f"{np.median(values):.2f} ({min(values):.2f}-{max(values):.2f})"


def memory(what: str, path: str, p0: float, tol: float) -> dict:
    """Peak memory of one solve in a fresh subprocess (bytes)."""
    out = subprocess.run(
        [sys.executable, "-c", MEMORY_CHILD, what, path, repr(p0), repr(tol),
         os.path.dirname(os.path.abspath(__file__))],
        capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise RuntimeError(f"{what} failed:\n{out.stderr[-2000:]}")
    line = next(s for s in reversed(out.stdout.splitlines()) if s.startswith("RESULT "))
    return json.loads(line[7:])


def bench_size(n: int, args, solvers: list[str]) -> None:
    """Time all solvers on one size in this process and print one table block."""
    h, gbar = surface(n, args.seed)
    p0 = args.load * E_STAR * gbar
    for s in solvers:  # warm-up: imports, code paths, thread pools
        SOLVERS[s](h[:128, :128].copy(), p0, args.tol)
    times = {s: [] for s in solvers}
    ours = [s for s in solvers if s in OURS]
    # per xrough variant and round: time per fine iteration / floor pair, the same in
    # CPU time (all threads) of this process, and time per transform pair / floor pair
    per_it_floor = {s: [] for s in ours}
    per_it_cpu = {s: [] for s in ours}
    per_pair = {s: [] for s in ours}
    single: list[float] = []
    last = {}
    pairs = {s: 100 for s in ours}  # floor pairs per block: the fine iterations once known
    for _ in range(args.repeats):
        for s in solvers:
            if s in ours:
                before = fft_floor_block(n, pairs[s])
            t0, c0 = time.perf_counter(), time.process_time()
            last[s] = SOLVERS[s](h, p0, args.tol)
            times[s].append(time.perf_counter() - t0)
            cpu = time.process_time() - c0
            if s in ours:
                after = fft_floor_block(n, pairs[s])
                x = last[s]
                floor = 0.5 * (before[0] + after[0])
                per_it_floor[s].append(times[s][-1] / x["fine_iterations"] / floor)
                per_it_cpu[s].append(cpu / x["fine_iterations"] / (
                    0.5 * (before[1] + after[1])))
                per_pair[s].append(times[s][-1] / (x["transforms"] / 2) / floor)
                pairs[s] = x["fine_iterations"]
                single += fft_floor(n, 3)
    best = {s: min(t) for s, t in times.items()}
    med = {s: float(np.median(t)) for s, t in times.items()}
    peers = [s for s in solvers if s not in OURS]
    faster = min(peers, key=best.get) if peers else None
    a_ref = last[ours[0]]["area"]
    print(f"# N={n}: gbar={gbar:.4f}, p0={p0:.3e} E* (p* = {args.load:g}), "
          f"tol={args.tol:g}, {args.repeats} rounds, all solvers warm, interleaved")
    print("| N | solver | best time (s) | median (s) | max/min | iterations | contact area "
          "| area diff. | / faster peer: best/best (range); per round median (range) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for s in solvers:
        r = last[s]
        d = (r["area"] - a_ref) / a_ref
        ratio = ""
        if s in ours and faster:
            lo = min(times[s]) / max(times[faster])
            hi = max(times[s]) / min(times[faster])
            rounds = [a / b for a, b in zip(times[s], times[faster])]
            ratio = (f"{best[s] / best[faster]:.3f} ({lo:.3f}-{hi:.3f}); "
                     f"{np.median(rounds):.3f} ({min(rounds):.3f}-{max(rounds):.3f}) "
                     f"vs {faster}")
        its = r["iterations"]
        if s in ours:
            its = (f"{r['fine_iterations']} + {r['coarse_iterations']} coarse "
                   f"({r['float32_iterations']} float32)")
        print(f"| {n} | {s} | {best[s]:.3g} | {med[s]:.3g} | {max(times[s]) / best[s]:.2f} "
              f"| {its} | {r['area']:.6f} | {d:+.1e} | {ratio} |", flush=True)
    agree = max(abs(last[s]["area"] - a_ref) / a_ref for s in solvers)
    print(f"# N={n}: contact areas agree to {agree:.1e} (relative; target {args.agree:g}): "
          f"{'yes' if agree <= args.agree else 'NO'}")
    for s in ours:
        x = last[s]
        per_it = best[s] / x["fine_iterations"]
        print(f"# N={n}: {s} {per_it * 1e3:.1f} ms per fine iteration (best run) = "
              f"{spread(per_it_floor[s])} x the two-FFT floor measured around each solve "
              f"(median (range) over rounds; {per_it / min(single):.2f} x the best single "
              f"pair, {min(single) * 1e3:.1f} ms); in CPU time (all threads of this "
              f"process, less sensitive to other jobs) {spread(per_it_cpu[s])} x the floor; "
              f"{x['transforms'] / x['fine_iterations']:.2f} transforms per fine iteration, "
              f"time per transform pair {spread(per_pair[s])} x the floor pair", flush=True)
    if "xrough" in ours and "xrough-plain" in ours:
        rounds = [a / b for a, b in zip(times["xrough"], times["xrough-plain"])]
        print(f"# N={n}: preconditioned / plain solve time: {spread(rounds)} "
              f"(per round), iterations {last['xrough']['iterations']} / "
              f"{last['xrough-plain']['iterations']}", flush=True)
    for s in peers:
        r = last[s]
        per_it = best[ours[0]] / last[ours[0]]["fine_iterations"]
        print(f"# N={n}: {s} {best[s] / r['iterations'] * 1e3:.1f} ms per iteration "
              f"(best run; {ours[0]} {per_it * 1e3:.1f} ms)")
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "h.npy")
        np.save(path, h)
        for s in ours + (peers if args.peer_memory else []):
            m = memory(s, path, p0, args.tol)
            size = 8 * n * n
            traced = f", traced {m['traced'] / size:.1f}" if s in ours else ""
            print(f"# N={n}: {s} peak memory of a solve / map size (8 N^2 bytes): "
                  f"resident {m['rss'] / size:.1f}{traced}", flush=True)


def main() -> None:
    """Parse the arguments and run every size."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 2048])
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--repeats", type=int, default=3, help="rounds of solves per size")
    ap.add_argument("--agree", type=float, default=1e-4,
                    help="relative agreement of the contact areas required")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--load", type=float, default=0.01,
                    help="p* = p0 / (E* gbar), the mean pressure over E* and the rms gradient")
    ap.add_argument("--plain", action="store_true",
                    help="also time xrough without the preconditioner (precondition=False)")
    ap.add_argument("--peers", nargs="*", default=list(PEERS),
                    help="peers to run (default: all installed; none for xrough alone)")
    ap.add_argument("--peer-memory", action="store_true",
                    help="also measure the peers' peak memory (one more solve each)")
    args = ap.parse_args()

    solvers = (["xrough"] + (["xrough-plain"] if args.plain else [])
               + [p for p in args.peers if installed(p)])
    missing = [p for p in args.peers if p not in solvers]
    if missing:
        print(f"# skipped (not installed): {', '.join(missing)}")
    print(f"# cores: {os.cpu_count()}; H = {HURST}, lambda_r = L/4, lambda_s = 4 px, "
          f"p0 = {args.load:g} E* gbar; xrough {xrough.__version__}")
    for n in args.sizes:
        bench_size(n, args, solvers)


if __name__ == "__main__":
    main()
