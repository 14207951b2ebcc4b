"""
One G(dr) over five decades, one of them bridged: stitching TEM, AFM and stylus on UNCD
=======================================================================================

Ultrananocrystalline diamond (UNCD) was measured with three instruments: a TEM side view
of a wedge (a 229 nm profile, nm resolution), a tapping-mode AFM map (100 nm x 100 nm) and
a stylus profilometer (a 300 um line scan). Each resolves the height-difference ACF
``G(dr)`` only inside its reliability window (a few pixels up to a quarter of its scan);
stitching brings the three curves to one unit and one log grid of lags and combines them
where they overlap, weighting ``ln G`` by the inverse of its variance. Where two
instruments overlap, the ratio of their G tests their consistency (height calibration,
tip convolution). The stitched curve is then fitted with the self-affine model.

The windows do not cover every lag: the TEM's ends at 58 nm and the stylus's begins at
398 nm, so G is measured from 0.8 nm to 58 nm and from 398 nm to 75 um, and the decade
between is not measured. ``stitch`` says so (``StitchingGapWarning``, attrs
``uncovered_dr_min/max``, coordinate ``coverage``), the plot shades it, and every result
that integrates or differentiates G across it marks what rests on the power-law bridge
(the fit: the model bridges it; the elastic energy: the share of ``v_el`` from the
bridge and its uncertainty).

The container's ``meta.yml`` states the tips: 17-26 nm for the AFM, ~5 um for the
stylus. By default (``reliable=True``, as ``acf()`` of each measurement) stitching applies
them: the 26 nm tip resolves no lag of the AFM's window (the tip rule's 44.4 nm lies
beyond a quarter of the 100 nm scan), so the AFM is left out (the stitched G is
questionable and says why), and the stylus starts at 2.07 um. This example
stitches the G as measured (``reliable=False``) to show the three instruments and their
overlap, and prints what the default keeps (see docs/stitching.md, windows from stated
tips).

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


measurements, title = uncd_measurements(UNCD), "UNCD as measured: TEM + AFM + stylus"

with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # the AFM left out, the gap: printed below
    default = stitch(measurements, unit="nm")
print(f"with the stated tips (default): {default.attrs['windows']}; left out: "
      f"{default.attrs['left_out']}")

curves = stitch_curves(measurements, unit="nm", reliable=False)  # G as measured
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always", StitchingMismatchWarning)
    mismatch = stitch_mismatch(curves)
for w in caught:
    print("warning:", w.message)
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    G = stitch(curves)
for w in caught:  # the mismatch warnings were printed above
    if w.category is not StitchingMismatchWarning:
        print("warning:", w.message)
fit = G.rough.fit()

print(f"windows: {G.attrs['windows']}")
for p in mismatch.pair.values:
    row = mismatch.sel(pair=p)
    print(f"overlap {p}: {int(row.n_bins)} bins, {float(row.dr_lo):.3g}-{float(row.dr_hi):.3g} "
          f"nm, G ratio {float(row.ratio):.3f} +- {float(row.log_ratio_error):.2f} (log), "
          f"z = {float(row.z):.2f}, chi2 = {float(row.chi2):.2f}")
factors = ", ".join(f"{m} x {f:.3f}" for m, f in zip(G.attrs["stitched_from"].split(", "),
                                                      G.attrs["level_factors"]))
print(f"levelled (no step at the seams) before combining: {factors}; errors of ln f: "
      + ", ".join(f"{e:.2f}" for e in G.attrs["level_factor_errors"]))
gaps = list(zip(G.attrs["uncovered_dr_min"], G.attrs["uncovered_dr_max"]))
for lo, hi in gaps:
    print(f"not measured: {lo:.4g}-{hi:.4g} {G.attrs['uncovered_dr_units']} (bridged)")
if gaps:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        energy = G.rough.energy(E_star="1 GPa")
    print(f"elastic energy: {float(energy.gap_share):.1%} of v_el from the bridge, "
          f"uncertain by {float(energy.gap_share_error):.1%} ({energy.attrs['quality']})")
print(f"stitched G: {G.sizes['dr']} bins from {float(G.dr[0]):.3g} to {float(G.dr[-1]):.3g} "
      f"nm; fitted Hurst exponent H = {float(fit.hurst):.3f}")

fig, ax = plt.subplots(figsize=(7, 5))
for m in curves.measurement.values:
    c = curves.sel(measurement=m)
    ax.errorbar(c.dr, c.G, yerr=c.standard_error, fmt="o", ms=3, alpha=0.6, label=str(m))
ax.loglog(G.dr, G, "k-", lw=1.5, label="stitched")
ax.fill_between(G.dr, G - G.standard_error, G + G.standard_error, color="k", alpha=0.15)
for k, (lo, hi) in enumerate(gaps):
    ax.axvspan(lo, hi, color="tab:red", alpha=0.1,
               label="no measurement (bridged)" if k == 0 else None)
ax.set_xlabel("lag dr (nm)")
ax.set_ylabel("G(dr) (nm$^2$)")
ax.set_title(f"{title}; fit H = {float(fit.hurst):.2f}")
ax.legend()
fig.tight_layout()
plt.show()
