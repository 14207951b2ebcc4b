"""Eq. 9 of the model spectra in closed form (xrough._kernels.model_acf).

References, each independent of the closed forms:

- 30-digit mpmath quadrature of ``T_h(a) = int_a^inf t^(-1-2h) (1 - J0) dt``, written as
  ``I_h - int_0^a`` (a finite, non-oscillating-at-infinity integral);
- the exact Matern case ``H = 1/2``: ``M(z) = 1 - exp(-z)``;
- the general quadrature of eq. 9 (:func:`acf_from_spectrum_kernel`: Gauss-Legendre below
  ``q dr = T``, asymptotic expansion above; documented accuracy a few 1e-15 for the sharp
  shape and 1e-10 for the smooth one with 160 knots per decade), over ten decades of lags,
  ``0.02 <= H <= 0.99`` and cutoff ratios from 4 to 1e7.

Tolerances are those of the references plus the closed forms' own rounding: 1e-12 against
mpmath and the exact case (two digits lost in the power series of ``1 - J0`` at its largest
argument, 8), 1e-12 (sharp) and 1e-9 (smooth, the quadrature's 1e-10 with margin) against
the quadrature.
"""

import mpmath as mp
import numpy as np
import pytest

from xrough._kernels import model_acf
from xrough._kernels.hankel import acf_from_spectrum_kernel
from xrough._kernels.shape_factors import self_affine_constant
from xrough._kernels.spectral_models import SpectrumModel


def _tail_mp(h: float, a: float) -> float:
    """``int_a^A t^(-1-2h) (1 - J0) dt + A^(-2h)/(2h) - int_A^inf t^(-1-2h) J0 dt``, A = a + 40.

    ``1 - J0(t) = (t^2/4) 1F2(1; 2, 2; -t^2/4)`` (no cancellation near 0); the last integral
    by mpmath's quadrature for oscillatory integrands.
    """
    mp.mp.dps = 30
    h, a = mp.mpf(h), mp.mpf(a)
    A = a + 40
    f = lambda t: t ** (1 - 2 * h) / 4 * mp.hyp1f2(1, 2, 2, -t * t / 4)  # noqa: E731
    g = lambda t: t ** (-1 - 2 * h) * mp.besselj(0, t)  # noqa: E731
    pts = [a, *[mp.mpf(v) for v in np.arange(float(a) + 2.0, float(A), 2.0)], A]
    return float(mp.quad(f, pts) + A ** (-2 * h) / (2 * h) - mp.quadosc(g, [A, mp.inf],
                                                                            omega=1))


FAST_POINTS = [3.0, 8.1, 48.1]


@pytest.mark.parametrize("h, a", [
    (0.5, FAST_POINTS), (1.3, FAST_POINTS),
    *(pytest.param(h, [1e-3, 3.0, 7.9, 8.1, 30.0, 47.9, 48.1, 75.0], marks=pytest.mark.slow)
      for h in (0.01, 0.3, 0.5, 0.8, 0.99, 1.3, 2.7))])
def test_power_tail_matches_mpmath(h, a):
    # every region: series (a <= 8), panels (8 < a <= 48), asymptotic series (a > 48);
    # mpmath takes about a second per point: the full grid is a slow test
    a = np.array(a)
    ref = np.array([_tail_mp(h, v) for v in a])
    np.testing.assert_allclose(model_acf.power_tail(h, a), ref, rtol=1e-12, atol=0)


def test_power_tail_total_is_the_self_affine_constant():
    H = np.array([0.05, 0.5, 0.95])
    np.testing.assert_allclose(model_acf._tail_total(H), self_affine_constant(H), rtol=1e-14)
    # far out T_h(a) -> a^(-2h) / (2h) (the J0 part falls as a^(-1/2) faster)
    a = 1e6
    np.testing.assert_allclose(model_acf.power_tail(0.4, a), a ** -0.8 / 0.8, rtol=1e-8)


def test_matern_at_one_half_is_exponential():
    z = np.logspace(-8, 1.7, 60)
    np.testing.assert_allclose(model_acf._matern(0.5, z), -np.expm1(-z), rtol=1e-13, atol=0)


def _quadrature(x, H, q_r, q_s, q_0, rolloff):
    m = SpectrumModel(hurst=H, q_r=q_r, q_s=q_s, q_0=q_0, rolloff=rolloff)
    return acf_from_spectrum_kernel(x, m, m.breakpoints,
                                    knots_per_decade=0 if rolloff == "sharp" else 160)


CUTOFFS = [(1.0, 1e4, 0.0), (1.0, 4.0, 0.0), (1.0, 30.0, 0.0), (1e-3, 1e4, 0.0),
           (1.0, 1e3, 0.3), (1.0, 1e3, 1.0)]


@pytest.mark.parametrize("H", [0.02, 0.3, 0.5, 0.8, 0.99])
@pytest.mark.parametrize("q_r, q_s, q_0", CUTOFFS)
def test_sharp_matches_the_quadrature(H, q_r, q_s, q_0):
    x = np.logspace(-5, 5, 120)
    got = model_acf.sharp_acf(x, H, q_r, q_s, q_0, C_r=2.5)
    ref = 2.5 * _quadrature(x, H, q_r, q_s, q_0, "sharp")
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=0)


@pytest.mark.parametrize("H", [0.02, 0.3, 0.5, 0.8, 0.99])
@pytest.mark.parametrize("q_r, q_s", [(1.0, 1e4), (1.0, 4.0), (1.0, 30.0), (1e-3, 1e4)])
def test_smooth_matches_the_quadrature(H, q_r, q_s):
    x = np.logspace(-5, 5, 120)
    got = model_acf.smooth_acf(x, H, q_r, q_s, C_r=2.5)
    ref = 2.5 * _quadrature(x, H, q_r, q_s, 0.0, "smooth")
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=0)


def test_limits_of_the_models():
    x = np.logspace(-3, 3, 40)
    H = 0.7
    # far inside the self-affine range G = (c/2pi) I(H) x^(2H) with c = C_r q_r^(2+2H)
    # (the cutoffs move it by (q_r x)^(2-2H) < 1e-10 and (q_s x)^(-2H) < 1e-24)
    for f in (model_acf.sharp_acf, model_acf.smooth_acf):  # the same power law inside
        G = f(x, H, 1e-20, 1e20)
        np.testing.assert_allclose(G, 1e-20 ** (2 + 2 * H) * self_affine_constant(H)
                                   * x ** (2 * H) / (2 * np.pi), rtol=1e-9)
    # far beyond the roll-off both reach sigma_h^2 = moment 0 of the spectrum
    for rolloff, f in (("sharp", model_acf.sharp_acf), ("smooth", model_acf.smooth_acf)):
        sigma2 = SpectrumModel(hurst=H, q_r=1.0, q_s=1e3, rolloff=rolloff).moment(0)
        np.testing.assert_allclose(f(np.array([1e7]), H, 1.0, 1e3), sigma2, rtol=1e-4)


def test_smooth_needs_separated_cutoffs():
    assert not model_acf.smooth_closed_form_applies(1.0, 3.0, 0.0)
    assert not model_acf.smooth_closed_form_applies(1.0, 100.0, 0.5)
    with pytest.raises(ValueError, match=r"q_s >= 4\.0 q_r"):
        model_acf.smooth_acf(np.ones(3), 0.5, 1.0, 2.0)


def _five_point(f, v, h):
    """``df/dv`` by the five-point stencil with the step ``h v`` (error ``(h v)^4 f^(5)/30``)."""
    s = h * v
    return (f(v - 2 * s) - 8 * f(v - s) + 8 * f(v + s) - f(v + 2 * s)) / (12 * s)


@pytest.mark.parametrize("H", [0.02, 0.3, 0.5, 0.8, 0.99])
@pytest.mark.parametrize("rolloff, q_0", [("sharp", 0.0), ("sharp", 0.1), ("smooth", 0.0)])
def test_cutoff_slopes_against_differences(H, rolloff, q_0):
    """``dG/dq_s`` (the integrand at q_s) and ``dG/dq_r`` (sharp: the plateau's height).

    Against five-point differences of the closed forms, the self-affine part
    ``c = C_r q_r^(2+2H)`` held fixed.  The lags end where ``q dr = 50`` (beyond, ``1 - J0``
    turns by more than the step of the difference); the step, 1e-3 of ``q``, turns it by
    0.05 rad at most: truncation ``(0.05)^4 / 30`` = 2e-7 and round-off 1e-12/1e-3 of G
    (the closed forms' accuracy above): asserted 1e-6 of ``G`` per relative change of q.
    """
    q_r, q_s = 1.0, 40.0
    c = 2.5

    def G(x, qr, qs):
        C_r = c / qr ** (2 + 2 * H)
        return (model_acf.sharp_acf(x, H, qr, qs, q_0, C_r) if rolloff == "sharp"
                else model_acf.smooth_acf(x, H, qr, qs, C_r))

    for q, x in (("r", np.logspace(-3, np.log10(50 / q_r), 40)),
                 ("s", np.logspace(-3, np.log10(50 / q_s), 40))):
        d_r, d_s = model_acf.cutoff_slopes(x, H, q_r, q_s, q_0, c / q_r ** (2 + 2 * H),
                                           rolloff)
        if q == "r":
            if rolloff == "smooth":
                assert d_r is None  # no closed form: a fit takes differences
                continue
            ref = _five_point(lambda v, x=x: G(x, v, q_s), q_r, 1e-3)
            got, v = d_r, q_r
        else:
            ref = _five_point(lambda v, x=x: G(x, q_r, v), q_s, 1e-3)
            got, v = d_s, q_s
        assert np.all(np.abs(got - ref) * v <= 1e-6 * G(x, q_r, q_s)), q
