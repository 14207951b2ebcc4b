"""
One G(dr) over five decades: stitching TEM, AFM and stylus measurements of UNCD
===============================================================================

Ultrananocrystalline diamond (UNCD) was measured with three instruments: a TEM side view
of a wedge (a 229 nm profile, nm resolution), a tapping-mode AFM map (100 nm x 100 nm) and
a stylus profilometer (a 300 um line scan). Each resolves the height-difference ACF
``G(dr)`` only inside its reliability window (a few pixels up to a quarter of its scan);
stitching brings the three curves to one unit and one log grid of lags and combines them
where they overlap, weighting ``ln G`` by the inverse of its variance. Where two
instruments overlap, the ratio of their G tests their consistency (height calibration,
tip convolution). The stitched curve is then fitted with the self-affine model.

The measurement files are not shipped with xrough (they are public, CC BY 4.0, from the
contact.engineering demo data set): set ``XROUGH_DATA`` to the folder that holds ``uncd/``
(see ``examples/_data.py``); without them the example stops and says so.
"""

import warnings

import matplotlib.pyplot as plt
from _data import data_file

import xrough
from xrough.stitching import StitchingMismatchWarning, stitch, stitch_curves, stitch_mismatch

UNCD = data_file("uncd")


def uncd_measurements(folder):
    """The three UNCD measurements, detrended as their metadata say."""
    tem = xrough.open_topography(folder / "80_Scale10.472_FIXEDv2p1_D7eHXiT.asc",
                                 resample=True, unit="nm")
    afm = xrough.open_topography(folder / "gain_control_uncd_35_z03tr3R.001")
    stylus = xrough.open_topography(folder / "uncd_stylus_300um_5mar_3_k0HpKJt.txt",
                                    unit="mm")
    return {"TEM": tem.rough.detrend(mode="mean"),
            "AFM": afm.rough.detrend(mode="plane"),
            "stylus": stylus.rough.detrend(mode="curvature")}


measurements, title = uncd_measurements(UNCD), "UNCD: TEM + AFM + stylus"

curves = stitch_curves(measurements, unit="nm")
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always", StitchingMismatchWarning)
    mismatch = stitch_mismatch(curves)
for w in caught:
    print("warning:", w.message)
G = stitch(curves, warn=False)
fit = G.rough.fit()

print(f"windows: {G.attrs['windows']}")
for p in mismatch.pair.values:
    row = mismatch.sel(pair=p)
    print(f"overlap {p}: {int(row.n_bins)} bins, {float(row.dr_lo):.3g}-{float(row.dr_hi):.3g} "
          f"nm, G ratio {float(row.ratio):.3f} +- {float(row.log_ratio_error):.2f} (log), "
          f"z = {float(row.z):.2f}, chi2 = {float(row.chi2):.2f}")
factors = ", ".join(f"{m} x {f:.3f}" for m, f in zip(G.attrs["stitched_from"].split(", "),
                                                      G.attrs["level_factors"]))
print(f"levelled (no step at the seams) before combining: {factors}")
print(f"stitched G: {G.sizes['dr']} bins from {float(G.dr[0]):.3g} to {float(G.dr[-1]):.3g} "
      f"nm; fitted Hurst exponent H = {float(fit.hurst):.3f}")

fig, ax = plt.subplots(figsize=(7, 5))
for m in curves.measurement.values:
    c = curves.sel(measurement=m)
    ax.errorbar(c.dr, c.G, yerr=c.standard_error, fmt="o", ms=3, alpha=0.6, label=str(m))
ax.loglog(G.dr, G, "k-", lw=1.5, label="stitched")
ax.fill_between(G.dr, G - G.standard_error, G + G.standard_error, color="k", alpha=0.15)
ax.set_xlabel("lag dr (nm)")
ax.set_ylabel("G(dr) (nm$^2$)")
ax.set_title(f"{title}; fit H = {float(fit.hurst):.2f}")
ax.legend()
fig.tight_layout()
plt.show()
