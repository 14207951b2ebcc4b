"""
Mean gap, contact stiffness and elastic energy against load: theory from G and the solver
=========================================================================================

Beyond the paper: Persson's theory of the interfacial separation in real space
(:func:`xrough.mean_gap`) predicts from G alone, per load, the mean gap between the
surfaces, the normal contact stiffness per area ``K = -dp0/d(gap)`` and the elastic energy
stored. The boundary-element solver gives the exact values on the map itself
(``solve_contact``: ``mean_gap``, ``stiffness`` from loads 1 % apart, ``elastic_energy``).
The band is the theory's 90 % interval for the exact value (the solver study of
``benchmarks/gap_study.py`` and the statistical error of G); at light loads the theory
overestimates the gap and underestimates the stiffness, which the band absorbs. The
fourth panel is the gap distribution at three loads (``gap_quantiles``: Almqvist et al.'s
form of the theory, lines; the solver's, dots).
"""

import matplotlib.pyplot as plt
import numpy as np

import xrough

topo = xrough.self_affine_surface(hurst=0.7, lambda_r="64 nm", lambda_s="2 nm",
                                  size="256 nm", n=256, rms_gradient=0.1, seed=3, unit="nm")
G = topo.rough.acf()
gbar = G.rough.gradient()  # computed once, passed on
E_star = 1e6  # Pa
p_star = np.array([1e-3, 3e-3, 0.01, 0.03, 0.1, 0.3])
p0 = p_star * E_star * float(gbar[0])
theory = G.rough.mean_gap(E_star=E_star, p0=p0, gradient=gbar)
loads = (p0[:, None] * np.array([0.99, 1.0, 1.01])).ravel()
exact = topo.rough.solve_contact(E_star=E_star, p0=loads, progress=False).isel(
    p0=slice(1, None, 3))

for k, ps in enumerate(p_star):
    t, e = theory.isel(p0=k), exact.isel(p0=k)
    print(f"p* {ps:g}: gap {float(t.mean_gap):.3f} nm (exact expected "
          f"{float(t.mean_gap_exact):.3f} [{float(t.mean_gap_exact_lower):.3f}, "
          f"{float(t.mean_gap_exact_upper):.3f}]), solver {float(e.mean_gap):.3f} nm")

fig, axes = plt.subplots(1, 4, figsize=(17, 4))
for ax, name, unit in zip(axes, ("mean_gap", "stiffness", "elastic_energy"),
                          ("nm", "Pa/nm", "J/m^2")):
    ax.fill_between(p0, theory[f"{name}_exact_lower"], theory[f"{name}_exact_upper"],
                    color="C0", alpha=0.2, label="90 % interval of the exact value")
    ax.plot(p0, theory[name], "C0-", label="theory from G")
    ax.plot(p0, exact[name], "ko", label="solver")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("mean pressure p0 (Pa)")
    ax.set_ylabel(f"{name.replace('_', ' ')} ({unit})")
axes[0].legend(fontsize=8)
for k, colour in zip((1, 3, 5), ("C1", "C2", "C3")):
    share = theory.area_share
    axes[3].plot(theory.gap_quantiles[k], share, color=colour, label=f"p* {p_star[k]:g}")
    axes[3].plot(exact.gap_quantiles[k].clip(min=0), share, "o", color=colour, ms=3)
axes[3].set_xlabel("gap (nm)")
axes[3].set_ylabel("share of the area with a smaller gap")
axes[3].legend(fontsize=8)
fig.tight_layout()
plt.show()
