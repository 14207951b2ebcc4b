"""Run time against error of the fits of G (:func:`xrough.fit_acf`).

G is the exact G (eq. 9) of a model spectrum with known ``H``, ``lambda_r`` and
``lambda_s`` (sharp or smooth roll-off), on lags from 1 nm to 100 um at 10 points per
decade (``lambda_s`` = 10 nm, ``lambda_r`` = 1 um: both cutoffs two decades inside the
lags), exact or with 5 % multiplicative log-normal noise and that standard error. Each is
fitted by:

* ``eq36``: the closed form of eq. 36 (the baseline: its time, measured in the same run,
  is the denominator of ``ratio``);
* ``spectrum`` with ``rolloff="sharp"``, ``"smooth"`` and the default ``"auto"`` (both
  shapes fitted, the better kept): eq. 9 of the model spectrum, evaluated at every step of
  the least-squares search; each with the default ``cutoff="auto"`` (where ``lambda_s`` is
  resolved, a Gaussian short-wavelength cutoff fitted too, the better kept: column
  ``cutoff``);
* ``eq35``: the default roll-off with ``cutoff="sharp"`` (eq. 35's cutoff alone).

Last, a pure power law ``G = dr^(2H)`` (H = 0.6, 1 nm to 1 um, 5 % errors): no cutoff in the
lags, so the spectrum fit finds neither and restarts from a grid of starting points before
it says so (the slowest case).

Errors are those of the fitted ``H`` (absolute) and of ``lambda_r`` and ``lambda_s``
(relative). Eq. 36 is not the model spectrum: its cutoffs are those of its own closed form,
so its errors include that model difference, not only the fit's.

Usage::

    python benchmarks/bench_fit.py            # the table
    python benchmarks/bench_fit.py --repeat 3 # each time the best of three
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
import xarray as xr

import xrough
from xrough.memo import forget

LAMBDA_R, LAMBDA_S = 1000.0, 10.0  # nm
FITS = [("eq36", {"model": "eq36"}), ("sharp", {"rolloff": "sharp"}),
        ("smooth", {"rolloff": "smooth"}), ("auto", {}), ("eq35", {"cutoff": "sharp"})]


def _curve(hurst: float, rolloff: str, noise: float, rng) -> xr.DataArray:
    C = xrough.model_spectrum(hurst=hurst, lambda_r=f"{LAMBDA_R} nm",
                              lambda_s=f"{LAMBDA_S} nm", rms_height="10 nm", unit="nm",
                              rolloff=rolloff)
    G = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="100 um", points_per_decade=10)
    if noise:
        G = (G * rng.lognormal(0.0, noise, G.shape)).assign_attrs(G.attrs)
        G = G.assign_coords(standard_error=("dr", noise * G.values, {"units": G.attrs["units"]}))
    return G


def _power_law(noise: float, rng) -> xr.DataArray:
    dr = np.geomspace(1.0, 1000.0, 31)
    values = dr**1.2 * rng.lognormal(0.0, noise, dr.size)
    return xr.DataArray(values, dims="dr", name="G", attrs={"units": "nm2"}, coords={
        "dr": ("dr", dr, {"units": "nm"}),
        "standard_error": ("dr", noise * values, {"units": "nm2"})})


def _timed(G, kwargs: dict, repeat: int):
    best, fit = np.inf, None
    for _ in range(repeat):
        forget()  # each time a first fit: xrough keeps fits by content (xrough.memo)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # quality marks are read from the result
            fit = xrough.fit_acf(G, **kwargs)
        best = min(best, time.perf_counter() - t0)
    return best, fit


def _rows(label: str, G: xr.DataArray, hurst: float, cutoffs: bool, repeat: int) -> None:
    """One row per fit of ``G``: time, ratio to the first (eq. 36), errors, quality."""
    base = None
    for name, kwargs in FITS:
        seconds, fit = _timed(G, kwargs, repeat)
        base = seconds if base is None else base
        err_r = abs(float(fit.lambda_r) / LAMBDA_R - 1) if cutoffs else np.nan
        err_s = (abs(float(fit.lambda_s) / LAMBDA_S - 1) if cutoffs and "lambda_s" in fit
                 else np.nan)
        print(f"{label} {name:>6} {seconds:7.3f} {seconds / base:6.0f} "
              f"{abs(float(fit.hurst) - hurst):7.1e} {err_r:8.1e} {err_s:8.1e} "
              f"{fit.attrs.get('quality', '?'):>12} {fit.attrs.get('cutoff', '-'):>8}",
              flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1)
    repeat = parser.parse_args().repeat
    head = (f"{'H':>4} {'spectrum':>8} {'noise':>5} {'fit':>6} {'time s':>7} {'ratio':>6} "
            f"{'err H':>7} {'err l_r':>8} {'err l_s':>8} {'quality':>12} {'cutoff':>8}")
    print(head)
    print("-" * len(head))
    rng = np.random.default_rng(0)
    for hurst in (0.3, 0.8):
        for rolloff in ("sharp", "smooth"):
            for noise in (0.0, 0.05):
                _rows(f"{hurst:4.1f} {rolloff:>8} {noise:5.2f}",
                      _curve(hurst, rolloff, noise, rng), hurst, True, repeat)
    _rows(f"{0.6:4.1f} {'power':>8} {0.05:5.2f}", _power_law(0.05, rng), 0.6, False, repeat)


if __name__ == "__main__":
    main()
