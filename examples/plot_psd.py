"""
The power spectrum of a measured map, and C(q) from G
=====================================================

``topo.rough.psd()`` computes the power spectral density ``C(q) = A <|h~(q)|^2>``
(eq. 4) from the heights: the periodogram of the map, with a Hann window because a
measured map is not periodic, averaged over the Fourier modes in log-spaced bins of the
angular wavenumber ``q``. ``G.rough.spectrum()`` computes the same ``C(q)`` from the
height-difference ACF by eq. 10/11. Both come out in the same units (the lateral unit to
the fourth power, on ``q`` in the inverse lateral unit), so they share one axes.

This example reads an AFM map (Nanoscope format), removes a plane, and draws both. Over
eight decades of ``C`` the two follow each other: at the longest wavelengths within the
PSD's statistical error (few modes per bin), in the middle and up to the Nyquist
wavenumber within a factor of about two, C from G above the PSD where the image's scan
lines weigh more in G (explained below). Beyond the Nyquist wavenumber neither means
much. The printout gives the numbers.

The measurement file is not shipped with xrough: set ``XROUGH_DATA`` to the folder that
holds ``instruments/`` (see ``examples/_data.py``).
"""

import warnings

import matplotlib.pyplot as plt
import numpy as np
from _data import data_file

import xrough

path = data_file("instruments", "di-1.di")
topo = xrough.open_topography(path).rough.detrend(mode="plane")

# The PSD of the heights: Hann window (the map is open), 20 bins per decade.
C = topo.rough.psd()

# C(q) from G on the same q (eq. 10/11). The map is anisotropic and G says so: silence
# the quality warnings here, they are about G and C, not about the comparison.
with warnings.catch_warnings():
    warnings.simplefilter("ignore", xrough.QualityWarning)
    G = topo.rough.acf()
    C_G = G.rough.spectrum(q=C.q)

# %%
# Where do they agree? The ratio of the two, in four ranges of ``q``: the longest
# wavelengths (up to 20 modes across the map: few modes per bin, the PSD's statistical
# error above ~20 %), the middle, the last octave below the Nyquist wavenumber, and the
# corners of the grid of modes beyond it (where the PSD averages only the corners, and C
# from G rests on G's continuation below one pixel).
ratio = (C_G / C).values
q, unit = C.q.values, C.q.attrs["units"]
q_low, q_nyquist = 20 * 2 * np.pi / C.attrs["scan_size"], C.attrs["q_nyquist"]
ranges = {"long wavelengths": q < q_low, "middle": (q >= q_low) & (q <= q_nyquist / 2),
          "last octave": (q > q_nyquist / 2) & (q <= q_nyquist), "corners": q > q_nyquist}
for name, inside in ranges.items():
    lo, mid, hi = np.percentile(ratio[inside], [10, 50, 90])
    error = float(np.median((C.standard_error / C).values[inside]))
    print(f"{name:>16} (q = {q[inside][0]:.3g} to {q[inside][-1]:.3g} {unit}): C from G / "
          f"PSD = {mid:.2f} (10-90 %: {lo:.2f} to {hi:.2f}; PSD's error {error:.0%})")

# %%
# At the shortest wavelengths C from G lies above the PSD. This AFM image has
# line-to-line offsets (visible as stripes along x): at large ``q`` the 1D spectrum of the
# lines along y (the slow scan axis) is far above that of the lines along x. Such noise
# sits on the ``q_y`` axis, a line of modes that weighs little in the PSD's rings; G's
# rings of a few pixels hold few lags, half of them on the axes, where it weighs much
# more. ``detrend(mode="plane", per_line=True)`` levels the lines and brings the two
# closer.
C_x, C_y = topo.rough.psd(direction="x"), topo.rough.psd(direction="y")
top = C_x.q > q_nyquist / 2
print(f"1D spectra at q > {q_nyquist / 2:.3g} {unit}: lines along y / lines along x = "
      f"{float(np.median((C_y / C_x).where(top, drop=True))):.0f}")

# %%
# One axes, both curves: the recipe of docs/psd.md. ``C_G`` is drawn where it is
# positive (outside the range G determines it may not be); the dotted line is
# ``q_nyquist``.
fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(11, 4.5))
topo.rough.plot(ax=ax0)
ax0.set_title(f"{path.name}, plane removed")
C.rough.plot(ax=ax1, label="PSD of the heights (Hann)")
C_G.where(C_G > 0).rough.plot(ax=ax1, label="C from G (eq. 10/11)", error=False)
ax1.axvline(q_nyquist, color="0.5", linestyle=":", linewidth=1)
ax1.set_title("isotropic height spectrum")
fig.tight_layout()
plt.show()
