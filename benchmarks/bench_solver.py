"""Run time, iterations and memory of ``solve_contact`` against two peer contact solvers.

The same problem is handed to every solver: a periodic self-affine surface (Hurst 0.8,
roll-off at L/4, short-wavelength cutoff 4 pixels) of N x N points on a square periodic
domain of side L, pressed against a linear-elastic half-space of contact modulus ``E*``
at the mean pressure ``p0 = 0.01 E* gbar`` (``gbar``: the rms gradient of the realised
map). The peers are

* tamaas (``tm.PolonskyKeerRey`` on a ``basic_2d`` model with ``E = E*``, ``nu = 0``;
  ``solve(p0)`` takes the mean pressure);
* ContactMechanics (``constrained_conjugate_gradients`` on a
  ``PeriodicFFTElasticHalfSpace(young=E*)``; it works with pixel forces, so the external
  force is ``p0 L^2``; convergence by ``pentol = tol * rms(h)``, ``forcetol`` and
  ``thermotol = tol``).

All three take the heights as the rigid surface, peaks towards the elastic body, and
use the periodic Green's function ``u~ = 2 p~ / (E* |q|)``.

For each size the solvers run at a ladder of tolerances (``--tols``) until the relative
contact areas of all solvers agree to ``--agree`` (relative), each solve in a fresh
subprocess so that the peak resident memory (``resource.getrusage``) is its own. Per
size and tolerance the table gives time, iterations, peak memory (total, and above the
state before the solve), contact area, and the ratio of xrough's time to the faster
peer's. Peers that are not installed are skipped (``pip install xrough[bench]``).

Usage::

    python benchmarks/bench_solver.py                    # 256, 512, 1024, 2048
    python benchmarks/bench_solver.py --sizes 256 512
    python benchmarks/bench_solver.py --tols 1e-8 1e-10 --agree 1e-4
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import textwrap

import numpy as np

L = 1.0  # um, side of the periodic domain
E_STAR = 1.0  # the problem is linear in E*: pressures are in units of E*
HURST = 0.8
RMS_GRADIENT = 0.1

CHILD = textwrap.dedent(
    r"""
    import json, re, resource, sys, time
    import numpy as np
    what, path, L, E, p0, tol = sys.argv[1], sys.argv[2], *map(float, sys.argv[3:7])

    def rss():
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024

    def current():  # resident set size now (Linux), the baseline before the solve
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * resource.getpagesize()

    h = np.load(path)
    n = h.shape[0]
    if what == "xrough":
        import xrough
        topo = xrough.topography(h, spacing=L / n, unit="um", periodic=True)
        base = current()
        t0 = time.perf_counter()
        res = xrough.solve_contact(topo, E_star=E, p0=p0, tol=tol, max_iter=100_000,
                                   progress=False)
        dt = time.perf_counter() - t0
        area, its = float(res.contact_area), int(res.iterations)
        mean_p = float(res.mean_pressure)
    elif what == "tamaas":
        import tamaas as tm
        tm.set_log_level(tm.LogLevel.info)  # the iteration count is only logged
        base = current()
        t0 = time.perf_counter()
        model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [L, L], [n, n])
        model.E, model.nu = E, 0.0  # E* = E / (1 - nu^2)
        solver = tm.PolonskyKeerRey(model, h, tol)
        solver.max_iter = 100_000
        solver.solve(p0)
        dt = time.perf_counter() - t0
        p = np.asarray(model.traction)
        area, its, mean_p = float(np.mean(p > 0)), -1, float(p.mean())
    elif what == "ContactMechanics":
        from ContactMechanics import PeriodicFFTElasticHalfSpace
        from ContactMechanics.Optimization import constrained_conjugate_gradients
        base = current()
        t0 = time.perf_counter()
        sub = PeriodicFFTElasticHalfSpace((n, n), E, physical_sizes=(L, L))
        res = constrained_conjugate_gradients(
            sub, h, external_force=p0 * L * L, pentol=tol * float(h.std()),
            forcetol=tol, thermotol=tol, maxiter=100_000)
        dt = time.perf_counter() - t0
        f = np.asarray(res.jac)  # pixel forces, compressive positive
        area, its = float(np.mean(f > 0)), int(res.nit)
        mean_p = float(f.sum() / (L * L))
        if not res.success:
            its = -its
    sys.stdout.flush()
    print("RESULT " + json.dumps({"time": dt, "iterations": its, "area": area,
                                  "mean_p": mean_p, "peak": rss(), "base": base}))
    """
)

PEERS = ("tamaas", "ContactMechanics")


def installed(name: str) -> bool:
    return importlib.util.find_spec(name) is not None


def surface(n: int, seed: int) -> tuple[np.ndarray, float]:
    """Heights (um) of the periodic test surface and their rms gradient."""
    import xrough

    topo = xrough.self_affine_surface(
        hurst=HURST, lambda_r=L / 4, lambda_s=4 * L / n, size=L, n=n,
        rms_gradient=RMS_GRADIENT, seed=seed, unit="um")
    h = np.ascontiguousarray(topo.transpose("y", "x").values, dtype=float)
    # rms gradient of this realisation, spectrally (periodic map)
    q = 2 * np.pi * np.fft.fftfreq(n, d=L / n)
    q2 = q[:, None] ** 2 + q[None, :] ** 2
    gbar = float(np.sqrt(np.sum(q2 * np.abs(np.fft.fft2(h)) ** 2)) / n**2)
    return h, gbar


def run(what: str, path: str, p0: float, tol: float) -> dict:
    out = subprocess.run(
        [sys.executable, "-c", CHILD, what, path, repr(L), repr(E_STAR), repr(p0),
         repr(tol)], capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise RuntimeError(f"{what} failed:\n{out.stderr[-2000:]}")
    lines = out.stdout.splitlines() + out.stderr.splitlines()
    res = json.loads(next(s for s in reversed(lines) if s.startswith("RESULT "))[7:])
    if what == "tamaas":  # last row of the logged convergence table: "iter cost error"
        rows = [s.split() for s in lines if len(s.split()) == 3 and s.split()[0].isdigit()]
        res["iterations"] = int(rows[-1][0]) if rows else -1
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 512, 1024, 2048])
    ap.add_argument("--tols", type=float, nargs="+", default=[1e-6, 1e-8, 1e-10])
    ap.add_argument("--agree", type=float, default=1e-4,
                    help="relative agreement of the contact areas to stop tightening")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    solvers = ["xrough"] + [p for p in PEERS if installed(p)]
    missing = [p for p in PEERS if p not in solvers]
    if missing:
        print(f"# skipped (not installed): {', '.join(missing)}")
    print(f"# cores: {os.cpu_count()}; H = {HURST}, lambda_r = L/4, lambda_s = 4 px, "
          f"p0 = 0.01 E* gbar")
    print("| N | tol | solver | time (s) | iterations | peak RSS (MB) | solve RSS (MB) "
          "| contact area | rel. diff. to xrough | xrough / fastest peer |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.sizes:
            h, gbar = surface(n, args.seed)
            path = os.path.join(tmp, f"h{n}.npy")
            np.save(path, h)
            p0 = 0.01 * E_STAR * gbar
            for tol in args.tols:
                res = {s: run(s, path, p0, tol) for s in solvers}
                a_ref = res["xrough"]["area"]
                peer_t = [res[s]["time"] for s in solvers if s != "xrough"]
                ratio = (f"{res['xrough']['time'] / min(peer_t):.2f}" if peer_t else "-")
                spread = 0.0
                for s in solvers:
                    r = res[s]
                    d = (r["area"] - a_ref) / a_ref
                    spread = max(spread, abs(d))
                    print(f"| {n} | {tol:.0e} | {s} | {r['time']:.3g} | {r['iterations']} "
                          f"| {r['peak'] / 2**20:.0f} | {(r['peak'] - r['base']) / 2**20:.0f} "
                          f"| {r['area']:.6f} | {d:+.1e} "
                          f"| {ratio if s == 'xrough' else ''} |", flush=True)
                if spread <= args.agree:
                    print(f"# N={n}: contact areas agree to {spread:.1e} (relative) at "
                          f"tol={tol:g}; gbar={gbar:.4f}", flush=True)
                    break
            else:
                print(f"# N={n}: best agreement {spread:.1e} (relative) at the tightest "
                      "tolerance", flush=True)


if __name__ == "__main__":
    main()
