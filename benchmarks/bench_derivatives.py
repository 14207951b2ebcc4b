"""Run time against error of the stress ACF (eq. 24), a second derivative of G.

Reference: for a model spectrum the full-contact stress ACF has the exact spectral form
``(E*/2)^2 (1/2pi) int dq q^3 C(q) J0(q dr) = (E*/2)^2 [gbar^2 - G_{q^2 C}(dr)]``, where
``G_{q^2 C}`` is eq. 9 applied to the spectrum ``q^2 C(q)`` (a power law per piece, so the
eq. 9 engine evaluates it to ~1e-12). The estimate differentiates G sampled at
``points_per_decade`` (exact values, or with 5 % multiplicative noise and that standard
error), by the log-log smoothing spline of :func:`xrough.stress_acf`. Errors are relative to
the stress variance ``G_sigma(0)`` (the stress ACF crosses zero), over the self-affine and
roll-off range ``[2 lambda_s, 10 lambda_r]``. The baseline time is computing G itself
(eq. 9) on the same grid, measured in the same run.

Usage::

    python benchmarks/bench_derivatives.py
"""

from __future__ import annotations

import time

import numpy as np

import xrough


def main() -> None:
    E = 1.0
    head = (f"{'H':>4} {'rolloff':>7} {'noise':>6} {'pts/dec':>7} {'G time s':>9} "
            f"{'stress s':>9} {'ratio':>6} {'max err':>9} {'median err':>10}")
    print(head)
    print("-" * len(head))
    rng = np.random.default_rng(0)
    for hurst, rolloff in [(0.3, "smooth"), (0.8, "smooth"), (0.8, "sharp")]:
        C = xrough.model_spectrum(hurst=hurst, lambda_r="1 um", lambda_s="1 nm",
                                  rms_gradient=1.0, unit="nm", rolloff=rolloff)
        for noise in (0.0, 0.05):
            for ppd in (5, 10, 20, 40):
                t0 = time.perf_counter()
                G = xrough.acf_from_spectrum(C, dr_min="0.01 nm", dr_max="100 um",
                                             points_per_decade=ppd)
                t_g = time.perf_counter() - t0
                if noise:
                    G = (G * rng.lognormal(0, noise, G.shape)).assign_attrs(G.attrs)
                    G = G.assign_coords(standard_error=("dr", noise * G.values))
                t0 = time.perf_counter()
                S = xrough.stress_acf(G, E_star=E)
                t_s = time.perf_counter() - t0
                dr = G.dr.values
                sel = (dr >= 2.0) & (dr <= 1e4)
                ref = xrough.stress_acf_from_spectrum(C, dr[sel], E_star=E).values
                err = np.abs(S.values[sel] - ref) / ((E / 2) ** 2 * C.attrs["rms_gradient"]
                                                       ** 2)
                print(f"{hurst:4.1f} {rolloff:>7} {noise:6.2f} {ppd:7d} {t_g:9.4f} "
                      f"{t_s:9.4f} {t_s / t_g:6.2f} {err.max():9.2e} {np.median(err):10.2e}",
                      flush=True)


if __name__ == "__main__":
    main()
