"""Run time against error of eq. 9 (G from C) and eq. 10/11 (C from G, gbar of eq. 26).

Each section varies one density and compares with a closed form or a dense reference; the
times are also given as ratios to the default setting (the baseline, marked ``*``),
measured in the same run, so that they carry over to other machines.

* ``acf_from_spectrum`` (eq. 9), smooth model (H = 0.8, 6 decades between q_r and q_s),
  200 lags over 12 decades, by ``knots_per_decade`` of the power-law representation of C
  above ``q dr = 64``; reference: 2560 knots per decade with finer panels.  The sharp
  model is an exact piecewise power law: its row is the same kernel at 0 extra knots.
* ``spectrum`` (eq. 10/11), by points per decade of the input G: (a) the exponential
  height ACF ``exp(-dr)`` <-> ``C = 2 pi / (1 + q^2)^1.5`` over 6 decades of lags, q from
  ``2 pi / dr_max`` to ``0.05 / dr_min`` (beyond, the extrapolation below ``dr_min``
  dominates: the supported range ends at ``0.4 / dr_min``); (b) the smooth model through
  eq. 9 over 8 decades (ballistic to plateau), errors over its supported range below
  ``q_s / 4``; also the bare power-law interpolation (kinks at the samples) for
  comparison.  Times are of the whole call (the supported range costs five transforms on a
  coarse grid) and of the kernel alone.
* ``rms_gradient_exact`` (eq. 26 via eq. 10/11) on the same G, against the closed form,
  errors away from ``lambda_s`` (where C jumps).

Usage::

    python benchmarks/bench_spectra.py
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from xrough._kernels.hankel import acf_from_spectrum_kernel
from xrough._kernels.spectrum_of_acf import spectrum_from_acf_kernel
from xrough.gradient import gradient_from_spectrum, rms_gradient_exact
from xrough.memo import forget
from xrough.models import self_affine_model
from xrough.spectra import acf_from_spectrum, model_spectrum, spectrum


def best_time(func, repeat=3):
    """Best of ``repeat`` wall-clock times (after one warm-up call) and the last result."""
    out = func()
    times = []
    for _ in range(repeat):
        forget()  # each time a first call: xrough keeps spectra by content (xrough.memo)
        t0 = time.perf_counter()
        out = func()
        times.append(time.perf_counter() - t0)
    return min(times), out


def table(title, head, rows):
    print(f"\n{title}")
    print(head)
    print("-" * len(head))
    for row in rows:
        print(row, flush=True)


def bench_acf(repeat):
    model = self_affine_model(hurst=0.8, lambda_r="1 um", lambda_s="1 nm", rms_height="1 nm",
                              rolloff="smooth", unit="nm")
    dr = np.geomspace(1e-4, 1e8, 200)
    reference = acf_from_spectrum_kernel(dr, model, model.breakpoints, knots_per_decade=2560,
                                         panels_per_decade=12, order=24)
    results = {}
    for knots in (10, 20, 40, 80, 160, 320):
        t, G = best_time(lambda k=knots: acf_from_spectrum_kernel(
            dr, model, model.breakpoints, knots_per_decade=k), repeat)
        results[knots] = (t, np.max(np.abs(G / reference - 1)))
    sharp = self_affine_model(hurst=0.8, lambda_r="1 um", lambda_s="1 nm", rms_height="1 nm",
                              unit="nm")
    t_sharp, _ = best_time(lambda: acf_from_spectrum_kernel(dr, sharp, sharp.breakpoints,
                                                            knots_per_decade=0), repeat)
    base = results[160][0]
    rows = [f"{'smooth':>8} {k:>6}{'*' if k == 160 else ' '} {t * 1e3:9.1f} {t / base:7.2f} "
            f"{err:10.1e}" for k, (t, err) in results.items()]
    rows.append(f"{'sharp':>8} {'exact':>7} {t_sharp * 1e3:9.1f} {t_sharp / base:7.2f} "
                f"{'(1e-15)':>10}")
    table("acf_from_spectrum (eq. 9): 200 lags over 12 decades",
          f"{'model':>8} {'knots':>7} {'time ms':>9} {'/ base':>7} {'max rel':>10}", rows)


def bench_spectrum(repeat):
    rows = []
    # (a) exponential height ACF, closed form
    results = {}
    for ppd in (5, 10, 20, 40, 80):
        dr = np.logspace(-4, 2, 6 * ppd + 1)
        q = np.geomspace(2 * np.pi / dr[-1], 0.05 / dr[0], 60)
        G = -np.expm1(-dr)
        t, C = best_time(lambda q=q, dr=dr, G=G: spectrum_from_acf_kernel(q, dr, G), repeat)
        results[ppd] = (t, np.max(np.abs(C / (2 * np.pi / (1 + q**2) ** 1.5) - 1)))
    base = results[20][0]
    rows += [f"{'exp':>7} {ppd:>5}{'*' if ppd == 20 else ' '} {'kernel':>9} {t * 1e3:9.1f} "
             f"{t / base:7.2f} {err:10.1e} {'':>10}" for ppd, (t, err) in results.items()]
    t, C = best_time(lambda: spectrum_from_acf_kernel(q, dr, G, interpolation="power law"),
                     repeat)
    err = np.max(np.abs(C / (2 * np.pi / (1 + q**2) ** 1.5) - 1))
    rows.append(f"{'exp':>7} {80:>5}  {'bare pl':>9} {t * 1e3:9.1f} {t / base:7.2f} "
                f"{err:10.1e} {'':>10}")
    table("spectrum (eq. 10/11) of exp(-dr): 60 q from 2 pi / dr_max to 0.05 / dr_min",
          f"{'G':>7} {'ppd':>6} {'what':>9} {'time ms':>9} {'/ base':>7} {'max rel':>10} "
          f"{'':>10}", rows)

    # (b) model round trip through eq. 9
    rows = []
    kw = dict(hurst=0.8, lambda_r="1 um", lambda_s="10 nm", rms_height="1 nm", unit="nm",
              rolloff="smooth")
    C_model = model_spectrum(**kw)
    q_s = C_model.attrs["q_s"]
    timing = {}
    for ppd in (5, 10, 20, 40, 80):
        G = acf_from_spectrum(C_model, np.logspace(-1, 7, 8 * ppd + 1))
        t_call, C = best_time(lambda G=G: spectrum(G), repeat)
        q = C.q.values
        use = (C.supported.values == 1) & (q < q_s / 4)
        rel = np.abs(C.values[use] / model_spectrum(q[use], **kw).values - 1)
        t_kernel, _ = best_time(lambda G=G, q=q: spectrum_from_acf_kernel(
            q, G.dr.values, G.values), repeat)
        timing[ppd] = (t_call, t_kernel, rel, C.attrs)
    base = timing[20][0]
    for ppd, (t_call, t_kernel, rel, a) in timing.items():
        rows.append(f"{ppd:>5}{'*' if ppd == 20 else ' '} {t_call * 1e3:9.1f} "
                    f"{t_call / base:7.2f} {t_kernel * 1e3:9.1f} {np.median(rel):10.1e} "
                    f"{rel.max():10.1e}  [{a['q_min_supported']:.2g}, "
                    f"{a['q_max_supported']:.2g}]")
    table("spectrum (eq. 10/11), smooth model through eq. 9 (8 decades, q_s = 0.63 nm-1)",
          f"{'ppd':>6} {'call ms':>9} {'/ base':>7} {'kernel ms':>9} {'median rel':>10} "
          f"{'max rel':>10}  supported q (nm-1)", rows)

    rows = []
    exact_model = model_spectrum(**kw)
    timing = {}
    for ppd in (5, 10, 20, 40, 80):
        G = acf_from_spectrum(C_model, np.logspace(-1, 7, 8 * ppd + 1))
        t, gbar = best_time(lambda G=G: rms_gradient_exact(G), repeat)
        dr = gbar.dr.values
        use = (dr < 10 / 1.5) | (dr > 10 * 1.5)
        exact = gradient_from_spectrum(exact_model, dr[use]).values
        timing[ppd] = (t, np.abs(gbar.values[use] / exact - 1), gbar.attrs)
    base = timing[20][0]
    for ppd, (t, rel, a) in timing.items():
        rows.append(f"{ppd:>5}{'*' if ppd == 20 else ' '} {t * 1e3:9.1f} {t / base:7.2f} "
                    f"{np.median(rel):10.1e} {rel.max():10.1e}  [{a['dr_min_supported']:.2g}, "
                    f"{a['dr_max_supported']:.2g}]")
    table("rms_gradient_exact (eq. 26 via eq. 10/11), same G, dr not within 1.5x lambda_s",
          f"{'ppd':>6} {'call ms':>9} {'/ base':>7} {'median rel':>10} {'max rel':>10}  "
          "supported dr (nm)", rows)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    bench_acf(args.repeat)
    bench_spectrum(args.repeat)


if __name__ == "__main__":
    main()
