"""
Paper Fig. 2: the shape factors c_sa(H) and c_ro(H)
===================================================

``c_sa`` and ``c_ro`` link G to the scale-dependent rms gradient: ``gbar^2 = c_sa G /
dr^2`` in the self-affine range (eq. 41) and ``gbar^2 = c_ro sigma_h^2 lambda_r^2 / dr^4``
beyond the roll-off (eq. 42). Here they are measured from their definitions with the
public API (eq. 9 and eq. 26 of the spectrum of eq. 35, ``q_s / q_r = 10^16``, no lower
cutoff) and drawn with the closed forms ``c_sa = 4 pi^(2-2H) H Gamma(1+H) / Gamma(2-H)``
and ``c_ro = 2 pi^2 H / (1 + H)`` (the limit of a wide self-affine range; with ``x = q_s /
q_r``, ``c_ro = pi^2 / (1/2 + (1 - x^(-2H)) / (2H))``, which the points meet). The
corrections at finite cutoffs, ``(q_r dr)^(2-2H)`` and ``(q_s dr)^(-2H)``, are balanced by
taking ``dr = 10^(-16 H) / (2 pi)``: both then are ``10^(-32 H (1-H))``, 0.13 % at H = 0.1
and 0.9 (the script prints the largest difference), far less between; near H = 0 or 1 the
self-affine range needs many decades. Where this differs from the paper: its right
ordinate, read as ``c_ro``, is the reciprocal ``1 / c_ro`` (drawn dashed); with it, eq. 41
and 42 read as printed.
"""

import matplotlib.pyplot as plt
import numpy as np
from scipy.special import gamma

import xrough
from xrough.gradient import gradient_from_spectrum

hursts = np.round(np.arange(0.1, 0.95, 0.1), 2)
c_sa, c_ro = [], []
for H in hursts:
    C = xrough.model_spectrum(hurst=H, lambda_r=1.0, lambda_s=1e-16, rms_height=1.0,
                              unit="um")
    deep = 10 ** (-16 * H) / (2 * np.pi)  # um: where both corrections are equal
    far = 1e3  # um: far beyond lambda_r
    G = xrough.acf_from_spectrum(C, [deep])
    gbar = gradient_from_spectrum(C, [deep, far]).values
    c_sa.append(gbar[0] ** 2 * deep**2 / float(G[0]))
    c_ro.append(gbar[1] ** 2 * far**4 / (1.0 * 1.0**2))
c_sa, c_ro = np.array(c_sa), np.array(c_ro)
exact_sa = 4 * np.pi ** (2 - 2 * hursts) * hursts * gamma(1 + hursts) / gamma(2 - hursts)
exact_ro = np.pi**2 / (0.5 + (1 - 1e16 ** (-2 * hursts)) / (2 * hursts))  # x = 10^16
print("largest relative difference from the closed forms: "
      f"c_sa {np.max(np.abs(c_sa / exact_sa - 1)):.1e}, "
      f"c_ro {np.max(np.abs(c_ro / exact_ro - 1)):.1e}")

fig, ax = plt.subplots(figsize=(6, 4.5))
h = np.linspace(0.02, 0.98, 97)
ax.plot(h, 4 * np.pi ** (2 - 2 * h) * h * gamma(1 + h) / gamma(2 - h), "r-")
ax.plot(hursts, c_sa, "rs", label="c_sa (left)")
ax.set_xlabel("Hurst exponent H")
ax.set_ylabel("c_sa(H)", color="r")
right = ax.twinx()
right.plot(h, 2 * np.pi**2 * h / (1 + h), "b-")
right.plot(hursts, c_ro, "bo", label="c_ro (right)")
right.plot(h, (1 + h) / (2 * np.pi**2 * h), "b--", label="1 / c_ro (the paper's axis)")
right.set_ylim(0, 12)
right.set_ylabel("c_ro(H), 1 / c_ro", color="b")
fig.legend(loc="upper center", fontsize=8)
fig.tight_layout()
plt.show()
