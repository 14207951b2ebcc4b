"""The two routes to eq. 41 and eq. 51: G's own local exponent against the fitted H.

``persson`` evaluates the quick stress estimate (eq. 41, ``sigma_quick``) and the
small-pressure asymptote of the reduced stress ACF (eq. 51, ``Gamma_sigma_sa``) with
``c_sa(H)`` and ``H``. One route takes ``H(dr) = dln G / (2 dln dr)`` of the smoothed G
at each lag (no model; ``persson`` takes it for eq. 51), the other the one ``H`` of the
spectrum fit of G (``persson`` takes it for eq. 41, whose eq. 42 needs the fit anyway).
Both are compared with what they estimate:

* ``sigma_quick`` with ``E* gbar(dr)``, ``gbar`` of eq. 26 of the true spectrum (closed
  form, :func:`xrough.gradient_from_spectrum`), from ``2 lambda_s`` to ``lambda_r / 2``
  (the range where eq. 41 is meant to hold, crossovers included);
* ``Gamma_sigma_sa`` with ``Gamma_sigma`` of the full theory (eq. 47/48) at
  ``p* = 1e-5``, from ``10 lambda_s`` to ``lambda_r / 10`` (the self-affine range of
  eq. 51).

Cases: the exact G of eq. 35 (sharp and smooth roll-off, ``H = 0.3, 0.5, 0.8``,
``lambda_r / lambda_s = 1e3``) and G measured on synthetic surfaces (1024^2, four
seeds each, ``lambda_r`` = 128 and ``lambda_s`` = 4 pixels). Printed: the largest and the
median relative error over the range, per route.

Usage::

    python benchmarks/routes_from_g.py
"""

from __future__ import annotations

import warnings

import numpy as np

import xrough
from xrough._kernels.shape_factors import self_affine_factor

E_STAR = 25e6


def _errors(values, truth, where):
    rel = np.abs(np.asarray(values)[where] / np.asarray(truth)[where] - 1)
    rel = rel[np.isfinite(rel)]
    return (np.max(rel), np.median(rel)) if rel.size else (np.nan, np.nan)


def _compare(G, C, lambda_r, lambda_s):
    fit = G.rough.fit()
    H_fit = float(fit.hurst)
    dr = G.dr.values
    gbar = xrough.gradient_from_spectrum(C, G.dr).values
    ds = G.rough.persson(E_star=E_STAR, p0=1.0, fit=fit, variables=("sigma_quick",))
    p_small = 1e-5 * E_STAR * float(np.nanmax(gbar))
    full = G.rough.persson(E_star=E_STAR, p0=p_small, fit=fit,
                           variables=("Gamma_sigma", "Gamma_sigma_sa"))
    g = G.values
    quick_fit = ds.sigma_quick.values  # persson's route: the fitted H
    asym_local = full.Gamma_sigma_sa.values  # persson's route: the local exponent
    # the fitted-H asymptote: the local one rescaled by H^2 / sqrt(c_sa) of each
    from xrough.contact import _laplacian  # the local exponent the default route uses
    h_loc = np.clip(_laplacian(G)[2].values, 1e-3, 1 - 1e-3)
    asym_fit = asym_local * (H_fit / h_loc) ** 2 * np.sqrt(
        self_affine_factor(h_loc) / self_affine_factor(H_fit))
    quick_range = (dr >= 2 * lambda_s) & (dr <= lambda_r / 2)
    asym_range = (dr >= 10 * lambda_s) & (dr <= lambda_r / 10)
    return {
        "sigma_quick local": _errors(E_STAR * np.sqrt(self_affine_factor(h_loc) * g) / dr,
                                     E_STAR * gbar, quick_range),
        "sigma_quick fit": _errors(quick_fit, E_STAR * gbar, quick_range),
        "Gamma_sa local": _errors(asym_local, full.Gamma_sigma.values, asym_range),
        "Gamma_sa fit": _errors(asym_fit, full.Gamma_sigma.values, asym_range),
        "H_fit": H_fit,
    }


def main() -> None:
    warnings.simplefilter("ignore")
    rows = []
    for rolloff in ("sharp", "smooth"):
        for hurst in (0.3, 0.5, 0.8):
            C = xrough.model_spectrum(hurst=hurst, lambda_r="10 um", lambda_s="10 nm",
                                      rms_gradient=0.5, unit="nm", rolloff=rolloff)
            G = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="1 mm",
                                         points_per_decade=10)
            rows.append((f"exact G, {rolloff}, H={hurst}", _compare(G, C, 1e4, 10.0)))
    for hurst in (0.3, 0.5, 0.8):
        C = xrough.model_spectrum(hurst=hurst, lambda_r="128 nm", lambda_s="4 nm",
                                  rms_gradient=0.5, unit="nm")
        for seed in range(4):
            topo = xrough.self_affine_surface(hurst=hurst, lambda_r="128 nm",
                                              lambda_s="4 nm", size="1024 nm", n=1024,
                                              rms_gradient=0.5, seed=seed, unit="nm")
            rows.append((f"1024^2 map, H={hurst}, seed {seed}",
                         _compare(topo.rough.acf(), C, 128.0, 4.0)))
    print("largest (median) relative error over the range of each estimate")
    head = ("case", "H fit", "sigma_quick: local H", "fitted H", "Gamma_sigma_sa: local H",
            "fitted H")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for name, r in rows:
        cells = [name, f"{r['H_fit']:.3f}"] + [
            f"{r[k][0]:.3f} ({r[k][1]:.3f})" for k in
            ("sigma_quick local", "sigma_quick fit", "Gamma_sa local", "Gamma_sa fit")]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
