"""
Roughness parameters, distributions and the tip check of a real AFM map
=======================================================================

The toolbox of surface metrology on a tapping-mode AFM map of ultrananocrystalline
diamond (100 nm x 100 nm, 512 x 512 points): the ISO 25178-2 parameters (``Sq``, ``Sdq``,
``Sdr``, ...), the distributions of heights, slopes and curvatures, the bearing-area
(Abbott-Firestone) curve, and the rms slope and curvature of finite differences at every
step ``dr`` (the scale-dependent roughness parameters of Sanner et al. 2022).

The rms slope at step ``dr`` is ``sqrt(2 [G_x(dr) + G_y(dr)]) / dr`` exactly: it sits
beside ``gbar(dr)`` of eq. 26, which the contact mechanics reads. The rms curvature at
step ``dr`` meets the tip: the file's metadata state a tip radius of 26 nm, and a tip of
radius ``R`` cannot image a peak curved more sharply than ``1/R``. Where the map is curved
beyond that, it shows the tip rather than the diamond; the check marks those scales
(``beyond_tip``) and the result questionable, and ``acf()`` leaves them out of G.

The measurement file is not shipped with xrough (it is public, CC BY 4.0, from the
contact.engineering demo data set): set ``XROUGH_DATA`` to the folder that holds
``uncd/`` (see ``examples/_data.py``); without it the example stops and says so.
"""

import warnings

import matplotlib.pyplot as plt
import numpy as np
from _data import data_file

import xrough

path = data_file("uncd", "gain_control_uncd_35_z03tr3R.001")
raw = xrough.open_topography(path)
topo = raw.rough.detrend(mode="plane")  # as meta.yml says ("height")

params = topo.rough.parameters()
for name, value in params.data_vars.items():
    print(f"{name:>14s} = {float(value):10.4g} {value.attrs['units']:5s} "
          f"{value.attrs['long_name']}")

# %%
# The AFM digitised its heights in steps of ``dz = 0.112 nm`` (the file's height scale),
# on pixels of ``dx = 0.195 nm``. So the slopes along x at one pixel are whole multiples
# of ``dz / dx`` (shifted by the tilt the plane removed) and the mean curvatures of
# ``dz / (2 dx^2)``: bins one step wide, centred on those values, keep the histograms
# free of aliasing combs. Digitisation dominates at the pixel scale: the rms slope of
# 2.2 at one pixel falls to 0.54 at ten.

dz = float(np.diff(np.unique(raw.values)).min())
dx = float(topo.x[1] - topo.x[0])
tilt = float(xrough.fit_trend(raw, mode="plane").slope_x)
step_s, step_c = dz / dx, dz / (2 * dx**2)
heights = topo.rough.height_distribution(bins=60)
bearing = topo.rough.bearing_area_curve()
slopes = topo.rough.slope_distribution(direction="x",
                                       bins=-tilt + (np.arange(-7, 7) + 0.5) * step_s)
curvatures = topo.rough.curvature_distribution(bins=(np.arange(-16, 16) + 0.5) * step_c)

# %%
# The scale-dependent slope and curvature, G and gbar of eq. 26. The file states its tip
# radius (26 nm), so the curvature is checked against it: a QualityWarning names the
# scales curved beyond it. ``acf()`` would leave them out of G by default (the tip
# window); ``reliable=False`` keeps every lag here, to compare the curves on all of them
# (G warns too: this AFM map differs along its fast and slow scan axes).

slope = topo.rough.scale_dependent_slope()
with warnings.catch_warnings(record=True) as said:
    warnings.simplefilter("always", xrough.QualityWarning)
    curvature = topo.rough.scale_dependent_curvature()
    G = topo.rough.acf(reliable=False)
    gbar = G.rough.gradient()
for warning in said:
    print(f"{warning.category.__name__}: {str(warning.message)[:160]}...")
route = gbar.attrs.get("method", "auto")
print(f"gbar from G by route {route!r}; at one pixel {float(gbar[0]):.4g}, Sdq "
      f"{float(params.Sdq):.4g}")
R = curvature.attrs["tip_radius"]

fig, axes = plt.subplots(3, 2, figsize=(11, 13))
topo.rough.plot(ax=axes[0, 0])
axes[0, 0].set_title(f"{path.name}: Sq = {float(params.Sq):.2f} nm, "
                     f"Sdq = {float(params.Sdq):.2f}")

ax = axes[0, 1]  # heights upright: the histogram and the Abbott-Firestone curve
sq = float(params.Sq)
ax.plot(heights, heights.height, label="height distribution")
ax.plot(np.exp(-0.5 * (heights.height / sq) ** 2) / (sq * np.sqrt(2 * np.pi)),
        heights.height, "k--", lw=1, label="Gaussian of the same Sq")
ax.set(xlabel="probability density (1/nm)", ylabel="height (nm)")
ax.text(0.97, 0.97, f"Ssk = {float(params.Ssk):.2f}\nSku = {float(params.Sku):.2f}",
        transform=ax.transAxes, ha="right", va="top")
top = ax.twiny()
top.plot(100 * bearing.material_ratio, bearing, color="C1", label="bearing-area curve")
top.set_xlabel("material ratio (%)")
lines = ax.get_lines() + top.get_lines()
ax.legend(lines, [line.get_label() for line in lines], loc="lower right")

ax = axes[1, 0]
ax.plot(slopes.slope, slopes, drawstyle="steps-mid")
ax.set(xlabel="slope along x (one pixel)", ylabel="probability density",
       title=f"slopes: Sdq = {float(params.Sdq):.2f} (x and y), "
             f"Sdr = {100 * float(params.Sdr):.0f} %")

ax = axes[1, 1]
ax.semilogy(curvatures.curvature, curvatures, drawstyle="steps-mid")
ax.set(xlabel="mean curvature (1/nm, one pixel)", ylabel="probability density (nm)",
       title=f"curvatures: rms {float(params.rms_curvature):.3g}/nm, the tip's 1/R = "
             f"{1 / R:.2g}/nm")

ax = axes[2, 0]
ax.loglog(slope.dr, slope, "o-", ms=3, label="rms slope of differences at dr")
ax.loglog(gbar.dr, gbar, "--", label=f"gbar(dr) from G (rms_gradient, {route})")
ax.set(xlabel="dr (nm)", ylabel="rms slope", title="scale-dependent slope")
ax.legend()

ax = axes[2, 1]
ax.loglog(curvature.dr, curvature, "s-", ms=3, label="rms curvature at dr")
ax.loglog(curvature.dr, -curvature.curvature_min, ":", label="most negative (tail)")
ax.axhline(1 / R, color="C3", lw=1, label="1/R")
for level, alpha, what in ((1, 0.1, "tail beyond the tip"), (2, 0.25, "rms beyond the tip")):
    beyond = curvature.dr.where(curvature.beyond_tip >= level, drop=True)
    if beyond.size:
        ax.axvspan(float(curvature.dr[0]), float(beyond.max()), color="C3", alpha=alpha,
                   label=what)
ax.set(xlabel="dr (nm)", ylabel="curvature (1/nm)", title="scale-dependent curvature")
ax.legend()
fig.tight_layout()
plt.show()
