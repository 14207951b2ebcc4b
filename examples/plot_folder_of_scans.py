"""
A folder of scans: one table, one averaged PSD, one stitched G
==============================================================

contact.engineering's workflow on the UNCD demo container (a TEM profile, an AFM map and
a stylus profile of ultrananocrystalline diamond, with the container's ``meta.yml``):
:func:`xrough.open_set` opens the folder as one DataTree (the two text profiles state no
unit, the ``meta.yml`` does; a file that does not read would be a line of ``failed``),
:func:`xrough.analyse_set` gives one row per measurement (its quality and why,
the fit of G, the roughness parameters), :func:`xrough.mean_psd` averages the 1D spectra
of all three bin by bin in one unit, and :func:`xrough.stitch` gives one G over the
seven decades the instruments cover together.

The measurement files are not shipped with xrough (public, CC BY 4.0): set
``XROUGH_DATA`` to the folder that holds ``uncd/`` (see ``examples/_data.py``); without
it the example stops and says so.
"""

import warnings

import matplotlib.pyplot as plt
import numpy as np
from _data import data_file

import xrough

folder = data_file("uncd", "meta.yml").parent
with warnings.catch_warnings():
    warnings.simplefilter("ignore", xrough.QualityWarning)  # the table says them
    tree = xrough.open_set(folder, progress=False)
    table = xrough.analyse_set(tree, mode="plane", progress=False)
    detrended = {name: xrough.detrend(tree[name].to_dataset()["heights"])
                 for name in tree.children}
    C = xrough.mean_psd(detrended, unit="um")
    G = xrough.stitch(tree)

print(table[["quality", "hurst", "hurst_std", "Rq", "Sq"]].to_dataframe().to_string())
print("failed:", tree.attrs["failed"] or "none")

fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(11, 4.2))
for name, topo in detrended.items():
    one = xrough.convert_units(topo, "um", lateral="um").rough.psd(direction="x")
    ax0.loglog(one.q, one, lw=2.5, alpha=0.5, label=name[:24])  # 1D along x, as C
ax0.loglog(C.q, C, "k", lw=1.5, label="averaged (mean_psd)")
ax0.set_xlabel("q (rad/µm)")
ax0.set_ylabel("1D PSD C (µm³)")
ax0.legend(fontsize=7)
G.rough.plot(ax=ax1)
ax1.set_title(f"stitched G of {G.attrs['stitched_from'].count(',') + 1} instruments")
fig.tight_layout()
plt.show()
print(f"averaged PSD over {C.q.size} bins, from {float(C.q.min()):.3g} to "
      f"{float(C.q.max()):.3g} rad/um; at most {int(C.n_measurements.max())} "
      f"measurements a bin; G from {float(G.dr.min()):.3g} to {float(G.dr.max()):.3g} "
      f"{G.dr.attrs['units']}")
_ = np  # numpy for the reader's own follow-ups
