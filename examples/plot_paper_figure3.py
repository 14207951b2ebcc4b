"""
Paper Fig. 3: the scale-dependent rms gradient and its three regimes
====================================================================

``gbar(dr)`` of eq. 26 for the spectrum of Fig. 1 (eq. 35, H = 0.5, ``q_s / q_r = 10^4``,
``q_r / q_0 = 10``), from the spectrum in closed form and from its G (``rms_gradient``,
the route a measurement takes: the spectrum of G by eq. 10/11, then eq. 26; within 0.8 %
of the closed form below ``lambda_0 / 2``, the script prints it). Gray lines: the
asymptotes ``gbar(0)`` (ballistic), ``sqrt(c_sa G) / dr`` (self-affine, eq. 41) and
``sqrt(c_ro) lambda_r sigma_h / dr^2`` (roll-off, eq. 42); circles: eq. 37's interpolation
``1/gbar^2 = 1/gbar^2(0) + dr^(2-2H)/C'_sa + dr^4/r_ro`` with the coefficients of eq. 38
(``gradient_from_fit`` of eq. 36 fitted to G). Where the numbers differ from the paper:
with xrough's ``c_sa`` and ``c_ro`` (Fig. 2) eq. 38 reads as printed. The paper's example
below the figure (H = 0.8, ``lambda_r = 10^5 a0``: the contact stress ``E* gbar`` falls by
``(10^5)^0.2 = 10`` from ``a0`` to ``lambda_r``) is the pure power law; eq. 26 at
``dr = lambda_r`` is past the crossover, and the fall is 31 (sharp roll-off) or 48 (smooth),
printed below.
"""

import matplotlib.pyplot as plt
import numpy as np

import xrough
from xrough.gradient import gradient_from_fit, gradient_from_spectrum

C = xrough.model_spectrum(hurst=0.5, lambda_r=1.0, lambda_s=1e-4, lambda_0=10.0,
                          rms_height=1.0, unit="um")
q_r, H = C.attrs["q_r"], 0.5
dr = np.logspace(-6, 2, 161) / q_r
exact = gradient_from_spectrum(C, dr)
G = xrough.acf_from_spectrum(C, dr)
from_g = G.rough.gradient()
fit = G.rough.fit(model="eq36")
eq37 = gradient_from_fit(fit, G.dr)
# below half the lower cutoff lambda_0 = 10 lambda_r (eq. 26 falls to 0 at lambda_0)
inside = np.isfinite(from_g.values) & (dr < np.pi / C.attrs["q_0"])
print(f"gbar from G against eq. 26 of the spectrum: largest difference "
      f"{np.max(np.abs(from_g.values[inside] / exact.values[inside] - 1)):.1e} over "
      f"{inside.sum()} lags below lambda_0 / 2")

for rolloff in ("sharp", "smooth"):  # the paper's "factor 10": a0 = 0.5 nm, 10^5 a0
    spectrum = xrough.model_spectrum(hurst=0.8, lambda_r="50 um", lambda_s="0.5 nm",
                                     rms_gradient=1.0, unit="nm", rolloff=rolloff)
    ends = gradient_from_spectrum(spectrum, [0.5, 5e4]).values
    print(f"H = 0.8, {rolloff} roll-off: gbar(a0) / gbar(lambda_r) = {ends[0] / ends[1]:.1f}"
          " (the pure power law: 10)")

c_sa = 4 * np.pi ** (2 - 2 * H) * H  # 4 pi^(2-2H) H Gamma(1+H) / Gamma(2-H) at H = 0.5
c_ro = np.pi**2 / (0.5 + (1 - 1e4 ** (-2 * H)) / (2 * H))  # q_s / q_r = 10^4
fig, ax = plt.subplots(figsize=(6, 4.5))
x = dr * q_r
ax.loglog(x, exact, "k-", label="eq. 26 of the spectrum")
ax.loglog(x, from_g, "C1--", label="rms_gradient(G)")
ax.axhline(C.attrs["rms_gradient"], color="0.6", ls="--", label="ballistic, gbar(0)")
ax.loglog(x, np.sqrt(c_sa * G.values) / dr, color="0.6", ls="-.", label="self-affine, eq. 41")
ax.loglog(x, np.sqrt(c_ro) * (2 * np.pi / q_r) / dr**2, color="0.6", ls=":",
          label="roll-off, eq. 42")
ax.loglog(x[::6], eq37.values[::6], "o", mfc="none", label="eq. 37/38, fitted")
ax.set_ylim(1e-4, 2e3)
ax.set_xlabel("q_r dr")
ax.set_ylabel("gbar (sigma_h = 1 um)")
ax.legend(fontsize=8)
fig.tight_layout()
plt.show()
