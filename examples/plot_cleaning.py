"""
Cleaning a measurement: detrending, outliers and the reliability window
=======================================================================

Instruments add what the surface does not have: a tilt of the sample, spikes from a
noisy detector, and resolution limits at both ends of the scale. A tilt adds
``(slope dr)^2 / 2`` to ``G(dr)`` and dominates its long lags; a few spikes raise every
lag. ``detrend`` removes a least-squares plane, ``mask_outliers`` marks spikes as missing
(every estimator skips missing points), and ``reliable`` records the window of lags that
describe the surface rather than the instrument: here from the tip radius of an AFM
(20 nm) up to a quarter of the scan.
"""

import matplotlib.pyplot as plt
import numpy as np

import xrough

surface = xrough.self_affine_surface(hurst=0.8, lambda_r="1 um", lambda_s="20 nm",
                                     size="4 um", n=512, rms_gradient=0.5, seed=2,
                                     unit="nm").assign_attrs(periodic=0)
rng = np.random.default_rng(1)
spikes = np.zeros(surface.shape)
spikes[tuple(rng.integers(0, 512, (2, 50)))] = rng.choice([-1, 1], 50) * 300.0
measured = (surface + 0.05 * surface.x + 0.02 * surface.y + spikes).assign_attrs(
    surface.attrs)

clean = (measured.rough.detrend(mode="plane")
         .rough.mask_outliers(threshold=5)
         .rough.reliable(tip_radius="20 nm", long_fraction=0.25))
lo, hi = clean.rough.reliability_window()
print(f"masked {int(clean.isnull().sum())} points; reliable lags {lo:.3g}-{hi:.3g} nm")

fig, axes = plt.subplots(1, 3, figsize=(15, 4.3))
measured.rough.plot(ax=axes[0])
axes[0].set_title("as measured: tilt and spikes")
clean.rough.plot(ax=axes[1])
axes[1].set_title("plane removed, spikes masked")
ax = axes[2]
measured.rough.acf().rough.plot(ax=ax, label="as measured")
clean.rough.acf().rough.plot(ax=ax, label="cleaned")
surface.rough.acf().rough.plot(ax=ax, label="true surface", linestyle=":")
ax.axvspan(lo, hi, color="C2", alpha=0.1, label="reliability window")
ax.legend()
fig.tight_layout()
plt.show()
