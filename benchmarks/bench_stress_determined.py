"""Where the Laplacian of G is determined: measured maps and periodic synthetic maps.

For each measured map in ``../shared/data`` (plane-detrended, default G: 10 bins per
decade) prints the lags that :func:`xrough.stress_acf` leaves NaN (the estimates of the
Laplacian from all, the even and the odd bins disagree), the full-contact stress ACF at the
first lag it keeps, the largest value of a kept bin whose sign differs from both
neighbours' and the smallest kept value (both relative to the largest magnitude kept), and
the same for the values of the smoothing spline before the rule (all lags). For periodic
synthetic 512^2 maps (lambda_r = 128 px, seed 1) it prints the largest disagreement of the
three estimates relative to the rule's scale, the NaN lags, and the largest error against
the exact stress field from 2 px to L/8 (relative to G_sigma(0)).

Usage::

    python benchmarks/bench_stress_determined.py
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
from scipy import fft as sfft

import xrough
from xrough._kernels.acf_curve import AcfCurve

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
from _data import data_root  # noqa: E402  (where the measurement files are)

DATA = data_root()
MAPS = [("instruments", n) for n in (
    "di-1.di", "x3p-2.x3p", "sdf-1.sdf", "sur-2.sur", "spot_1-1000nm.ibw", "mi-1.mi",
    "nid-1.nid", "plu-1.plu", "al3d-1.al3d", "opd-1.opd")] + [
    ("uncd", "gain_control_uncd_35_z03tr3R.001")]
E_STAR = 25e6


def sign_flip(values: np.ndarray) -> tuple[float, float]:
    """Largest isolated sign flip and smallest value, relative to the largest magnitude."""
    k = values[np.isfinite(values)]
    worst = 0.0
    for m in range(k.size):
        nb = [k[j] for j in (m - 1, m + 1) if 0 <= j < k.size]
        if nb and all(np.sign(k[m]) != np.sign(x) for x in nb):
            worst = max(worst, abs(k[m]))
    top = np.max(np.abs(k))
    return worst / top, k.min() / top


def measured() -> None:
    print(f"{'file':34} {'NaN lags (px)':>14} {'G_s first kept Pa2':>18} {'flip':>6} "
          f"{'min':>6} | before: {'G_s(1px)':>9} {'flip':>6} {'min':>6}")
    for parts in MAPS:
        path = DATA.joinpath(*parts)
        if not path.exists():
            print(f"{parts[-1]:34} absent")
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", xrough.QualityWarning)
            G = xrough.open_topography(path).rough.detrend().rough.acf()
            S = G.rough.stress_acf(E_star=E_STAR)
        px = G.attrs["pixel_size"]
        dr = S.dr.values
        nan = np.isnan(S.values) & (dr > 0)
        ok = np.isfinite(G.values) & (dr > 0)
        before = np.full(dr.shape, np.nan)
        f = G.coords["standard_error"].values
        before[ok] = (E_STAR / 2) ** 2 * AcfCurve(dr[ok], G.values[ok], f[ok]).laplacian(
            dr[ok])
        scale = float(np.nanmax(np.abs(before))) / float(np.nanmax(np.abs(S.values)))
        span = f"{dr[nan].min() / px:.2f}-{dr[nan].max() / px:.2f}" if nan.any() else "none"
        first = S.values[np.isfinite(S.values)][0]
        flip, low = sign_flip(S.values)
        bflip, blow = sign_flip(before)
        print(f"{parts[-1]:34} {span:>14} {first:18.3g} {flip:6.3f} {low:6.3f} | "
              f"{scale:9.3g}x {bflip:6.3f} {blow:6.3f}")
    print("(before: G_s(1px) is the largest magnitude before, as a multiple of the largest "
          "kept now)")


def synthetic() -> None:
    print(f"{'H':>4} {'rolloff':>7} {'lambda_s':>8} {'pts/dec':>7} {'NaN lags':>9} "
          f"{'max err 2px-L/8':>15}")
    for hurst, rolloff in ((0.8, "smooth"), (0.5, "sharp"), (0.8, "sharp"), (0.5, "smooth"),
                           (0.3, "smooth")):
        for lambda_s in (2, 4, 8):
            topo = xrough.self_affine_surface(hurst=hurst, lambda_r=128, lambda_s=lambda_s,
                                              size=512, n=512, rms_gradient=0.1, seed=1,
                                              unit="nm", rolloff=rolloff)
            n = 512
            k = 2 * np.pi * sfft.fftfreq(n, 1.0)
            q = np.hypot(k[:, None], k[None, :])
            stress = sfft.ifft2(q * E_STAR / 2 * sfft.fft2(topo.values)).real
            field = xrough.topography(stress, spacing=1.0, unit="nm", height_unit="m",
                                      periodic=True)
            var = stress.var()
            for ppd in (5, 10, 20, 40):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", xrough.QualityWarning)
                    S = topo.rough.acf(points_per_decade=ppd).rough.stress_acf(
                        E_star=E_STAR)
                ref = var - field.rough.acf(points_per_decade=ppd).values
                dr = S.dr.values
                nan = np.isnan(S.values) & (dr > 0)
                sel = (dr >= 2) & (dr <= n / 8) & ~nan
                err = np.max(np.abs(S.values[sel] - ref[sel])) / var
                span = f"{dr[nan].min():.1f}-{dr[nan].max():.1f}" if nan.any() else "none"
                print(f"{hurst:4} {rolloff:>7} {lambda_s:8} {ppd:7} {span:>9} "
                      f"{100 * err:14.1f}%")


if __name__ == "__main__":
    measured()
    synthetic()
