"""
Quick start: from a topography to contact area in five lines
============================================================

A synthetic self-affine surface (Hurst exponent H = 0.8, roll-off at 2 um, smooth below
40 nm) stands in for a measured map. ``acf()`` gives its height-difference
autocorrelation function ``G(dr)`` with a standard error, ``fit()`` the parameters of the
model spectrum, and ``persson()`` the relative contact area against a flat elastic
body (contact modulus 25 MPa) at the resolution ``dr``. Every result is an
``xarray`` object with units.
"""

import matplotlib.pyplot as plt

import xrough

topo = xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="40 nm",
                                  size="8 um", n=512, rms_gradient=0.5, seed=1, unit="nm")
G = topo.rough.acf()                       # G(dr), eq. 1, all pairs
fit = G.rough.fit()                        # H, sigma_h, lambda_r, lambda_s with errors
contact = G.rough.persson(E_star="25 MPa", p0=["0.1 MPa", "1 MPa"])  # eq. 29, 39

print(f"H = {float(fit.hurst):.2f} +- {float(fit.hurst_std):.2f}, "
      f"sigma_h = {float(fit.sigma_h):.3g} {fit.sigma_h.attrs['units']}")

fig, axes = plt.subplots(1, 3, figsize=(14, 4))
topo.rough.plot(ax=axes[0])
G.rough.plot(ax=axes[1])
for p0 in contact.p0.values:
    axes[2].semilogx(contact.dr, contact.a_r.sel(p0=p0), label=f"p0 = {p0 / 1e6:g} MPa")
axes[2].set(xlabel=f"resolution dr ({contact.dr.attrs['units']})",
            ylabel="relative contact area a_r", title="real-space Persson theory")
axes[2].legend()
fig.tight_layout()
plt.show()
