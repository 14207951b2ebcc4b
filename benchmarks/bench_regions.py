"""The check of a map's regions (``xrough.correlation._regions``): what it costs, what it sees.

Two parts, both in one run:

1. **Cost.** ``acf()`` of self-affine maps (256² to 2048², periodic and open) with the
   check and without it (the same call with the quarters switched off, measured in the
   same run, interleaved; best of ``--repeat``), and the ratio.
2. **False alarms and findings.** The largest variance ratio of the quarters (their
   scatter over their Gaussian finite-area error, squared) on self-affine maps of known
   stationarity (H 0.3-0.8, open and periodic, lambda_r from L/8 to 2L, ``--seeds``
   each), and on the instrument maps of the test data (plane removed), against the
   threshold ``REGIONS_DISAGREE``.

Run: ``python benchmarks/bench_regions.py [--seeds 12] [--repeat 3] [--sizes 256 512
1024 2048]``.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

import xrough
from xrough._kernels import uncertainty
from xrough.correlation import _estimator, _regions

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
MAPS = ["instruments/x3p-2.x3p", "instruments/sur-2.sur", "instruments/di-1.di",
        "instruments/spot_1-1000nm.ibw", "instruments/plu-1.plu", "instruments/opd-1.opd",
        "instruments/mi-1.mi", "instruments/nid-1.nid", "instruments/al3d-1.al3d",
        "instruments/matrix-3.txt", "uncd/gain_control_uncd_35_z03tr3R.001"]


def _surface(n, hurst=0.7, ratio=4, seed=1, periodic=True):
    topo = xrough.self_affine_surface(hurst=hurst, lambda_r=f"{n / ratio:g} nm",
                                      lambda_s="4 nm", size=f"{n} nm", n=n,
                                      rms_gradient=0.2, seed=seed, unit="nm")
    topo.attrs["periodic"] = int(periodic)
    return topo


def _best(topo, repeat, judge):
    quarters = _estimator.quarters
    if not judge:
        _estimator.quarters = lambda da, grid: None
    try:
        best = np.inf
        for _ in range(repeat):
            t = time.perf_counter()
            topo.rough.acf()
            best = min(best, time.perf_counter() - t)
    finally:
        _estimator.quarters = quarters
    return best


def cost(sizes, repeat):
    print("| map | with the check (ms) | without (ms) | ratio |\n|---|---|---|---|")
    for n in sizes:
        for periodic in (True, False):
            topo = _surface(n, periodic=periodic)
            with_, without = np.inf, np.inf
            for _ in range(2):  # interleaved
                with_ = min(with_, _best(topo, repeat, True))
                without = min(without, _best(topo, repeat, False))
            kind = "periodic" if periodic else "open"
            print(f"| {n}² {kind} | {with_ * 1e3:.0f} | {without * 1e3:.0f} | "
                  f"{with_ / without:.2f} |")


def _ratio(topo) -> float:
    """The largest variance ratio of the quarters (the check made to record it)."""
    threshold = _regions.REGIONS_DISAGREE
    _regions.REGIONS_DISAGREE = -1.0
    uncertainty.REGIONS_DISAGREE = -1.0
    try:
        G = topo.rough.acf(reliable=False)
    finally:
        _regions.REGIONS_DISAGREE = threshold
        uncertainty.REGIONS_DISAGREE = threshold
    return float(G.attrs.get("regions_ratio_max", np.nan)) ** 2


def findings(seeds):
    print(f"\nthreshold REGIONS_DISAGREE = {_regions.REGIONS_DISAGREE:g} (variance ratio)\n")
    print("| self-affine maps | largest variance ratio over seeds | median |\n|---|---|---|")
    worst = 0.0
    for n, hurst, ratio, periodic in [(256, 0.5, 8, True), (256, 0.5, 1, True),
                                      (256, 0.5, 4, True), (256, 0.8, 2, False),
                                      (256, 0.3, 8, False), (512, 0.5, 2, False)]:
        r = [_ratio(_surface(n, hurst, ratio, seed, periodic)) for seed in range(seeds)]
        worst = max(worst, max(r))
        print(f"| {n}², H {hurst}, L = {ratio} lambda_r, "
              f"{'periodic' if periodic else 'open'} | {max(r):.3g} | {np.median(r):.3g} |")
    print(f"\nlargest over {6 * seeds} self-affine maps: {worst:.3g}\n")
    print("| instrument map (plane removed) | variance ratio | flagged |\n|---|---|---|")
    for rel in MAPS:
        path = DATA / rel
        if not path.exists():
            print(f"| {rel} | (not available) | |")
            continue
        topo = xrough.open_topography(path).rough.detrend(mode="plane")
        r = _ratio(topo)
        flagged = "yes" if r > _regions.REGIONS_DISAGREE else "no"
        print(f"| {Path(rel).name} | {r:.3g} | {flagged} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=12)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 512, 1024, 2048])
    args = ap.parse_args()
    warnings.filterwarnings("ignore", category=xrough.QualityWarning)
    cost(args.sizes, args.repeat)
    findings(args.seeds)


if __name__ == "__main__":
    main()
