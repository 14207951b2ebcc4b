"""
Run time against error of the G(dr) estimators
==============================================

Three ways to the height-difference ACF of a map with missing points: all pairs by FFT
(``estimator="fft"``, exact), tile by tile (``height_difference_acf_tiled``, exact
within the halo, block averages beyond), and the paper's random pairs
(``estimator="random"``, a Monte-Carlo estimate whose cost does not depend on the map
size, with its error in ``sampling_error``). The error is the largest relative deviation
from the exact G over all bins. The map is 1024 x 1024 here (``XROUGH_EXAMPLE_N`` sets
the size); ``benchmarks/bench_estimators.py`` measures larger ones. Timings depend on
the machine: read the figure for the ordering, not the seconds.
"""

import os
import time

import matplotlib.pyplot as plt
import numpy as np

import xrough
from xrough.correlation import height_difference_acf_tiled

n = int(os.environ.get("XROUGH_EXAMPLE_N", 1024))
topo = xrough.self_affine_surface(hurst=0.8, lambda_r="4 um", lambda_s="40 nm",
                                  size=f"{16 * n / 1024} um", n=n, rms_gradient=0.5,
                                  seed=5, unit="nm").assign_attrs(periodic=0)
topo = topo.where(np.random.default_rng(0).random(topo.shape) > 0.05)  # 5 % missing


def timed(func, repeat=3):
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        out = func()
        best = min(best, time.perf_counter() - start)
    return best, out


t_fft, exact = timed(lambda: topo.rough.acf(estimator="fft"))
rows = [("fft (all pairs)", t_fft, 0.0)]
t, G = timed(lambda: height_difference_acf_tiled(topo, tile=256, halo=96, progress=False))
rows.append(("tiled", t, float(abs(G / exact - 1).max())))
for n_pairs in [10**4, 10**5, 10**6]:
    t, G = timed(lambda n_pairs=n_pairs: topo.rough.acf(estimator="random", n_pairs=n_pairs,
                                                         seed=1, progress=False))
    rows.append((f"random, {n_pairs:.0e} pairs", t, float(abs(G / exact - 1).max())))

for name, t, err in rows:
    print(f"{name:22s} {t * 1e3:8.1f} ms   max relative error {err:.1e}")

fig, ax = plt.subplots(figsize=(7, 4.5))
for i, (name, t, err) in enumerate(rows):
    ax.loglog(t, max(err, 1e-16), "o", ms=9, color=f"C{i}", label=name)
ax.set(xlabel="run time (s)", ylabel="max relative error of G (exact: 1e-16)",
       title=f"{n} x {n} map, 5 % missing points")
ax.legend()
fig.tight_layout()
plt.show()
