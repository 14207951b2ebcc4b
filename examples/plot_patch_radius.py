"""
Patch radius of an adhesive contact
===================================

Adhesion pulls a soft solid into contact with a rough counter-surface wherever the
energy gained, the work of adhesion ``gamma`` per area, exceeds the elastic energy
needed to flatten the roughness. Over a patch of radius ``a_c`` that energy is
``v_el(a_c) = (E*/4) int_0^a_c G(r) / r^2 dr`` (eq. 43), which grows with ``a_c``:
patches up to the radius where ``v_el`` reaches ``gamma`` close spontaneously (eq. 44,
an upper estimate; eq. 46 refines it). Rougher surfaces (larger rms gradient) close
smaller patches; a stickier or softer pair closes larger ones, and once ``gamma``
exceeds the full-contact energy the surfaces stick everywhere (``a_c = inf``).
"""

import warnings

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

import xrough

gradients = [0.2, 0.5, 1.0]
G = xr.concat(
    [xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="20 nm", size="8 um",
                                n=1024, rms_gradient=g, seed=1, unit="nm").rough.acf()
     for g in gradients], dim=xr.Variable("rms_gradient", gradients))

gammas = np.geomspace(1e-3, 0.5, 30)  # J/m^2
E_star = "25 MPa"
# The sweep runs past both ends of what the maps resolve: radii below the smallest lag
# rest on G continued as dr^2, and beyond the full-contact energy a_c is infinite. Each
# such result says so with a QualityWarning; here the plot marks the smallest lag instead.
with warnings.catch_warnings():
    warnings.simplefilter("ignore", xrough.QualityWarning)
    radii = xr.concat([G.rough.patch_radius(E_star=E_star, gamma=float(g)) for g in gammas],
                      dim=xr.Variable("gamma", gammas, {"units": "J m-2"}))
energy = G.rough.energy(E_star=E_star)
print("a_c (nm) at gamma = 10 mJ/m^2:",
      radii.a_c.sel(gamma=0.01, method="nearest").round(1).values.tolist())

fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4.5))
for g in gradients:
    line, = ax0.loglog(gammas, radii.a_c.sel(rms_gradient=g), label=f"gbar = {g}")
    ax0.loglog(gammas, radii.a_c_upper.sel(rms_gradient=g), ":", color=line.get_color())
    # beyond the full-contact energy (eq. 16) no finite radius: the surfaces stick
    ax0.axvline(float(energy.v_el.sel(rms_gradient=g)), color=line.get_color(), lw=0.8,
                linestyle="--")
ax0.axhline(float(G.dr[0]), color="0.5", lw=0.8)
ax0.text(gammas[0], float(G.dr[0]) * 1.15, "smallest lag of G", color="0.4", fontsize=8)
ax0.set(xlabel="work of adhesion gamma (J/m$^2$)", ylabel="patch radius a_c (nm)",
        title=f"E* = {E_star}: eq. 46 (solid), eq. 44 (dotted),\n"
              "full-contact energy (dashed): sticks everywhere beyond")
ax0.legend()
with warnings.catch_warnings():  # the roughest surface's a_c lies below its smallest lag
    warnings.simplefilter("ignore", xrough.QualityWarning)
    patch = G.rough.patch_radius(E_star=E_star, gamma="10 mJ/m^2")
xrough.plot.plot_patch_radius(patch, ax=ax1)
ax1.set_title("gamma = 10 mJ/m$^2$")
fig.tight_layout()
plt.show()
