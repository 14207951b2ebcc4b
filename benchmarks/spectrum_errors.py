"""Statistical error of C(q) from the G of one profile: modelled against measured.

Random-amplitude (Gaussian) profiles of the sharp model (eq. 35) are generated with
different seeds; each one's G (``acf()``, default log bins) goes through
``spectrum(G, q)`` on a common grid.  For every ``q`` the table compares

* ``scatter``: the standard deviation of ``C / C_model`` over the seeds (what one
  profile really tells about the surface's spectrum),
* ``modelled``: the median over the seeds of ``standard_error / C_model`` (what
  ``spectrum`` reports: the finite-area error of G, correlated between the bins,
  propagated to C), and their ratio,
* ``bias``: the mean of ``C / C_model - 1`` (deterministic: binning and the lattice),
* ``supported``: how many of the seeds' default ``spectrum(G)`` count ``q`` as supported
  (``max_error = 0.1``), and how many did before the statistical bound
  (``max_error = inf``),

then, over every seed's supported range, the largest and median ``|C / C_model - 1|``
with and without the bound.  Times: the default call against the same G without its
``standard_error`` (no error model: the cost before the bound), same run.

Usage::

    python benchmarks/spectrum_errors.py            # 2^17 points, 24 seeds (~1 min)
    python benchmarks/spectrum_errors.py --n 15 --seeds 8 --lambda-r 256
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import xrough
from xrough.spectra import model_spectrum


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=int, default=17, help="log2 of the profile's points")
    parser.add_argument("--seeds", type=int, default=24)
    parser.add_argument("--hurst", type=float, default=0.8)
    parser.add_argument("--lambda-r", type=float, default=1024.0, help="pixels")
    parser.add_argument("--lambda-s", type=float, default=4.0, help="pixels")
    parser.add_argument("--points-per-decade", type=float, default=10.0)
    args = parser.parse_args()
    n = 2**args.n
    model = dict(hurst=args.hurst, lambda_r=args.lambda_r, lambda_s=args.lambda_s,
                 rms_height=1.0, unit="nm")
    q_r = 2 * np.pi / args.lambda_r
    q = np.geomspace(0.5 * q_r, 2 * np.pi / args.lambda_s, 31)
    exact = np.asarray(model_spectrum(q, **model))
    ratio, modelled, inside, inside_before = [], [], [], []
    worst = {"bound": [], "none": []}
    t_bound = t_none = 0.0
    for seed in range(args.seeds):
        topo = xrough.self_affine_surface(size=float(n), n=n, profile=True, seed=seed,
                                          **model)
        G = topo.rough.acf(points_per_decade=args.points_per_decade)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            C = xrough.spectrum(G, q, max_error=np.inf, support_rtol=1e3)
            ratio.append(C.values / exact)
            modelled.append(C.standard_error.values / exact)
            start = time.perf_counter()
            xrough.spectrum(G.drop_vars("standard_error"))
            t_none += time.perf_counter() - start
            for key, max_error in (("bound", 0.1), ("none", np.inf)):
                start = time.perf_counter()
                try:
                    D = xrough.spectrum(G, max_error=max_error)
                except ValueError:
                    D = None
                if key == "bound":
                    t_bound += time.perf_counter() - start
                lo, hi = ((D.attrs["q_min_supported"], D.attrs["q_max_supported"])
                          if D is not None else (np.nan, np.nan))
                (inside if key == "bound" else inside_before).append((q >= lo) & (q <= hi))
                if D is not None and D.supported.any():
                    sup = D.supported.values == 1
                    err = np.abs(D.values[sup] / np.asarray(
                        model_spectrum(D.q.values[sup], **model)) - 1)
                    worst[key].append((err.max(), np.median(err), lo / q_r, hi / q_r))
                else:
                    worst[key].append((np.nan, np.nan, np.nan, np.nan))
    ratio, modelled = np.array(ratio), np.array(modelled)
    inside, inside_before = np.array(inside), np.array(inside_before)
    print(f"profile of 2^{args.n} points, H = {args.hurst}, lambda_r = {args.lambda_r:g} px, "
          f"lambda_s = {args.lambda_s:g} px, {args.points_per_decade:g} bins per decade, "
          f"{args.seeds} seeds")
    print(f"{'q/q_r':>8} {'scatter':>8} {'modelled':>9} {'ratio':>6} {'bias':>7} "
          f"{'supported':>10} {'before':>7}")
    scatter = ratio.std(axis=0, ddof=1)
    median_model = np.median(modelled, axis=0)
    for k in range(q.size):
        print(f"{q[k] / q_r:8.3g} {scatter[k]:8.3f} {median_model[k]:9.3f} "
              f"{median_model[k] / scatter[k]:6.2f} {ratio[:, k].mean() - 1:+7.3f} "
              f"{inside[:, k].sum():>5d}/{args.seeds:<4d} {inside_before[:, k].sum():>3d}")
    for key, label in (("bound", "max_error = 0.1"), ("none", "max_error = inf (before)")):
        w = np.array(worst[key])
        print(f"{label}: supported from {np.nanmedian(w[:, 2]):.3g} to "
              f"{np.nanmedian(w[:, 3]):.3g} q_r (median over seeds); |C/C_model - 1| inside: "
              f"largest {np.nanmax(w[:, 0]):.3f}, median of the seeds' medians "
              f"{np.nanmedian(w[:, 1]):.3f}; no support on {int(np.isnan(w[:, 0]).sum())} seeds")
    print(f"time per call: {t_bound / args.seeds:.3f} s with the error model, "
          f"{t_none / args.seeds:.3f} s without (ratio {t_bound / t_none:.1f})")


if __name__ == "__main__":
    main()
