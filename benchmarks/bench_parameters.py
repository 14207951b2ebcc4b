"""Run time of the roughness parameters against one ``np.diff`` of the same map.

For each map size this prints the time of ``np.diff(h, axis=1)`` (the baseline: one
finite difference of the map, measured in the same run), then of ``parameters()``,
``scale_dependent_slope()`` (its default steps), ``scale_dependent_curvature()``, the
height, slope and curvature distributions and the bearing-area curve, each as the best
of ``--repeats`` rounds in which all take turns (same process state and load), and its
ratio to the baseline; the scale-dependent curves also per step.

Usage::

    python benchmarks/bench_parameters.py                # 1024
    python benchmarks/bench_parameters.py --sizes 512 2048 --repeats 9
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import xrough


def _calls(topo):
    return {
        "parameters": lambda: topo.rough.parameters(),
        "scale_dependent_slope": lambda: topo.rough.scale_dependent_slope(),
        "scale_dependent_curvature": lambda: topo.rough.scale_dependent_curvature(),
        "height_distribution": lambda: topo.rough.height_distribution(),
        "slope_distribution": lambda: topo.rough.slope_distribution(),
        "curvature_distribution": lambda: topo.rough.curvature_distribution(),
        "bearing_area_curve": lambda: topo.rough.bearing_area_curve(),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1024])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    warnings.simplefilter("ignore", xrough.QualityWarning)
    for n in args.sizes:
        h = np.random.default_rng(0).normal(size=(n, n))
        topo = xrough.topography(h, spacing=1.0, unit="nm", attrs={"detrend": "plane"})
        calls = {"np.diff (baseline)": lambda h=h: np.diff(h, axis=1), **_calls(topo)}
        steps = topo.rough.scale_dependent_slope().sizes["dr"]
        best = dict.fromkeys(calls, np.inf)
        for call in calls.values():  # warm up: imports, caches
            call()
        for _ in range(args.repeats):
            for name, call in calls.items():
                t0 = time.perf_counter()
                call()
                best[name] = min(best[name], time.perf_counter() - t0)
        base = best["np.diff (baseline)"]
        print(f"{n} x {n}, {steps} default steps, best of {args.repeats}")
        for name, t in best.items():
            per_step = (f"  ({t / steps * 1e3:.2f} ms, {t / steps / base:.1f} x per step)"
                        if name.startswith("scale") else "")
            print(f"  {name:28s} {t * 1e3:8.2f} ms {t / base:8.0f} x{per_step}")


if __name__ == "__main__":
    main()
