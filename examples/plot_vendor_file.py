"""
Reading a vendor file
=====================

``xrough.open_topography`` reads a measurement in its instrument's format (X3P, SDF,
SUR, Nanoscope, Gwyddion, Igor, NetCDF, text, and more through SurfaceTopography),
detecting the format from the content. The result is a DataArray with the file's units
on the heights and the coordinates, and the file's name, checksum and header in
``attrs``. This example reads an X3P file (ISO 25178-72) of a measured surface. The
measurement files are not shipped with xrough: set ``XROUGH_DATA`` to the folder that
holds ``instruments/`` (see ``examples/_data.py``).
"""

import matplotlib.pyplot as plt
from _data import data_file

import xrough

path = data_file("instruments", "x3p-2.x3p")

topo = xrough.open_topography(path)
print(f"{path.name}: format {topo.attrs.get('format')}, {topo.sizes['x']} x "
      f"{topo.sizes['y']} points, heights in {topo.attrs['units']}, "
      f"x in {topo.x.attrs['units']}, sha256 {topo.attrs.get('source_sha256', '')[:12]}...")

G = topo.rough.detrend(mode="plane").rough.acf()

fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(11, 4.5))
topo.rough.plot(ax=ax0)
ax0.set_title(path.name)
G.rough.plot(ax=ax1)
ax1.set_title("G(dr) after removing a plane")
fig.tight_layout()
plt.show()
