"""
Paper Fig. 1: the height-difference ACF of the idealised spectrum and its three regimes
=======================================================================================

G(dr) of eq. 35 with H = 0.5, ``q_s / q_r = 10^4`` and ``q_r / q_0 = 10`` (eq. 9), in the
paper's units: G over the height variance, dr times the roll-off wavenumber ``q_r``. The
gray lines are the three asymptotes: ballistic ``G = gbar^2 dr^2 / 4`` below ``lambda_s``,
self-affine ``G ~ dr^(2H)`` between the cutoffs, and the plateau ``sigma_h^2`` beyond
``lambda_r``. The circles are eq. 36's interpolation through them,
``1/G = C_b/dr^2 + C_sa/dr^(2H) + 1/sigma_h^2``, fitted to this G (``fit_acf(G,
model="eq36")``): H 0.497 and sigma_h 1.09 (0.5 and 1 in the spectrum), G missed by up to
30 % at the crossovers, which eq. 36 is not built to follow (rated questionable). The
paper's figure shows the same three regimes; it states no fitted values to compare.
"""

import matplotlib.pyplot as plt
import numpy as np

import xrough

C = xrough.model_spectrum(hurst=0.5, lambda_r=1.0, lambda_s=1e-4, lambda_0=10.0,
                          rms_height=1.0, unit="um")
q_r = C.attrs["q_r"]
G = xrough.acf_from_spectrum(C, np.logspace(-6, 2, 161) / q_r)
x, y = G.dr.values * q_r, G.values  # sigma_h = 1: G is already over the variance
gbar2 = C.attrs["rms_gradient"] ** 2
sa = y[np.argmin(abs(x - 1e-2))] * (x / 1e-2) ** 1.0  # the self-affine power law, 2H = 1

fit = xrough.fit_acf(G, model="eq36")
model = xrough.model_acf(fit, G.dr)
print(f"eq. 36 fitted to G: H = {float(fit.hurst):.3f} (0.5 in the spectrum), "
      f"sigma_h = {float(fit.sigma_h):.3f} um (1); largest miss of G: "
      f"{float(np.max(np.abs(np.log(model.values / y)))):.2f} in ln G")

fig, ax = plt.subplots(figsize=(6, 4.5))
ax.loglog(x, y, "k-", label="G(dr) of eq. 35 (eq. 9)")
ax.loglog(x, gbar2 * (x / q_r) ** 2 / 4, color="0.6", ls="--", label="ballistic, dr^2")
ax.loglog(x, sa, color="0.6", ls="-.", label="self-affine, dr^(2H)")
ax.axhline(1.0, color="0.6", ls=":", label="plateau, sigma_h^2")
ax.loglog(x[::6], model.values[::6], "o", mfc="none", label="eq. 36 fitted to G")
ax.set_ylim(1e-9, 3)
ax.set_xlabel("q_r dr")
ax.set_ylabel("G / sigma_h^2")
ax.legend(fontsize=8)
fig.tight_layout()
plt.show()
