"""Eq. 26 of a binned spectrum of heights against the map's own Fourier modes.

``gradient_from_spectrum(topo.rough.psd(), dr)`` sums the log-binned periodogram over its
bins (``sum C q^2 bin_measure``, the bin that holds ``2 pi / dr`` counted by its share in
``ln q``).  On periodic maps (512^2, ``lambda_r`` = 128 px, sharp and Gaussian short
cutoffs) this prints its relative error against the exact sum over the map's modes,
``gbar^2 = sum_{|q| <= 2 pi / dr} q^2 |h_q|^2 / N^2``, at lags of 2 to 64 pixels, next to
the integral of the same bins as a piecewise power law between their mean wavenumbers
(what a spectrum without ``bin_measure`` gets).

Usage::

    python benchmarks/binned_spectrum_gradient.py      # a few seconds
"""

from __future__ import annotations

import warnings

import numpy as np

import xrough
from xrough.gradient import gradient_from_spectrum

LAGS = np.array([2.0, 3.0, 4.0, 6.0, 8.0, 16.0, 64.0])
CASES = [(0.8, 4, "sharp"), (0.3, 4, "sharp"), (0.5, 8, "sharp"), (0.3, 4, "gaussian")]


def main() -> None:
    warnings.simplefilter("ignore")
    n = 512
    q = 2 * np.pi * np.fft.fftfreq(n)
    Q = np.hypot(q[:, None], q[None, :])
    print("lags (px):", " ".join(f"{d:6g}" for d in LAGS))
    for hurst, lambda_s, cutoff in CASES:
        topo = xrough.self_affine_surface(hurst=hurst, lambda_r=128, lambda_s=lambda_s,
                                          size=n, n=n, rms_height=1.0, seed=1, unit="nm",
                                          cutoff=cutoff)
        power = np.abs(np.fft.fft2(topo.values - topo.values.mean())) ** 2 / n**4
        exact = np.array([np.sqrt(np.sum((Q**2 * power)[Q <= 2 * np.pi / d])) for d in LAGS])
        C = topo.rough.psd()
        power_law = gradient_from_spectrum(C.drop_vars("bin_measure"), LAGS).values
        bins = gradient_from_spectrum(C, LAGS).values
        label = f"H {hurst} {cutoff} cutoff at {lambda_s} px"
        for name, got in (("power law", power_law), ("bin sums", bins)):
            print(f"{label:32s} {name:10s}",
                  " ".join(f"{100 * v:+6.2f}" for v in got / exact - 1), "%")


if __name__ == "__main__":
    main()
