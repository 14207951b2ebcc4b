"""
Reading a vendor file
=====================

``xrough.open_topography`` reads a measurement in its instrument's format (X3P, SDF,
SUR, Nanoscope, Gwyddion, Igor, NetCDF, text, and more through SurfaceTopography),
detecting the format from the content. The result is a DataArray with the file's units
on the heights and the coordinates, and the file's name, checksum and header in
``attrs``. This example reads an X3P file (ISO 25178-72) of a measured surface when the
project's measurement files are present, and otherwise one it writes itself.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import xrough
from xrough.io import x3p

try:
    ROOT = Path(__file__).resolve().parents[1]
except NameError:  # executed without a file (gallery builders, notebooks)
    ROOT = Path.cwd()
path = ROOT.parent / "shared" / "data" / "instruments" / "x3p-2.x3p"
if not path.exists():
    print(f"{path.name} not found: writing a synthetic X3P file instead")
    path = Path(tempfile.mkdtemp()) / "synthetic.x3p"
    surface = xrough.self_affine_surface(hurst=0.8, lambda_r="20 um", lambda_s="1 um",
                                         size="200 um", n=512, rms_height="0.5 um",
                                         seed=4, unit="um")
    x3p.write(surface.assign_attrs(periodic=0), path)

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
