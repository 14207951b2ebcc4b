"""Tests of the Hankel-type kernels (eq. 9, spectral moments, profile spectra).

Reference values for eq. 9 were computed with mpmath at 30 digits by the script below
(about 20 minutes; kept here so that the tests do not need slow mpmath quadrature at run
time).  It is independent of the kernel: below t = 40 it uses the 2F3 series of
int_0^x t^(-1-2H) (1 - J0) dt or direct quadrature, above it int t^(-1-2H) dt in closed form
minus int t^(-1-2H) J0(t) dt from sums over half periods with nsum extrapolation (no Hankel
asymptotics).

    import mpmath as mp
    mp.mp.dps = 30
    X = mp.mpf(40)

    def P(x, H):  # int_0^x t^(-1-2H) (1 - J0(t)) dt
        x = mp.mpf(x)
        return x**(2 - 2*H) / (4*(2 - 2*H)) * mp.hyp2f3(1, 1 - H, 2, 2, 2 - H, -x**2/4)

    def osc_tail(f, a, scale=1):  # int_a^inf f for f ~ J0(scale t)
        a = mp.mpf(a)
        n0 = int(mp.floor(a*scale/mp.pi + mp.mpf(1)/4)) + 1
        z = lambda n: (n0 + n - 1 - mp.mpf(1)/4)*mp.pi/scale
        s = mp.quad(f, [a, z(1)])
        return s + mp.nsum(lambda k: mp.quad(f, [z(k), z(k + 1)]), [1, mp.inf])

    def I_sharp(a, b, H):  # int_a^b t^(-1-2H) (1 - J0(t)) dt
        a, b = mp.mpf(a), mp.mpf(b)
        if b <= X:
            return P(b, H) - P(a, H)
        lo = max(a, X)
        res = 0 if a >= X else P(X, H) - P(a, H)
        res += (lo**(-2*H) - b**(-2*H)) / (2*H)
        f = lambda t: t**(-1 - 2*H) * mp.besselj(0, t)
        return res - (osc_tail(f, lo) - osc_tail(f, b))

    def flat_F(q, r):  # int_0^q q' (1 - J0(q' r)) dq'
        q = mp.mpf(q)
        if q == 0:
            return mp.mpf(0)
        t = q*r
        if t < mp.mpf("1e-3"):
            return q**2/2*mp.nsum(lambda k: (-1)**(k + 1)*(t/2)**(2*k)
                                  / (mp.factorial(k)*mp.factorial(k + 1)), [1, mp.inf])
        return q**2/2 - q*mp.besselj(1, t)/r

    def G_sharp(r, H, q0=0, qr=1, qs=10**6):  # eq. 9 for eq. 35, C_r = 1
        r, H = mp.mpf(r), mp.mpf(H)
        flat = flat_F(qr, r) - flat_F(q0, r)
        tail = mp.mpf(qr)**(2 + 2*H)*r**(2*H)*I_sharp(qr*r, qs*r, H)
        return (flat + tail)/(2*mp.pi)

    def G_smooth(r, H, qs=1000):  # C = (1 + q^2)^-(1+H) on [0, q_s), q_r = C_r = 1
        r, H, qs = mp.mpf(r), mp.mpf(H), mp.mpf(qs)
        C = lambda q: (1 + q*q)**(-1 - H)
        omj0 = lambda t: (-mp.nsum(lambda k: (-t*t/4)**k/mp.factorial(k)**2, [1, mp.inf])
                          if t < 1 else 1 - mp.besselj(0, t))
        qx = min(qs, X/r)
        pts = sorted({mp.mpf(0), qx} | {p for p in (1, 10, 100) if p < qx}
                     | {k*mp.pi/r for k in range(1, int(X/mp.pi) + 1) if k*mp.pi/r < qx})
        low = mp.quad(lambda q: q*C(q)*omj0(q*r), pts)
        if qx >= qs:
            return low/(2*mp.pi)
        flat = ((1 + qx**2)**(-H) - (1 + qs**2)**(-H))/(2*H)
        f = lambda q: q*C(q)*mp.besselj(0, q*r)
        return (low + flat - (osc_tail(f, qx, r) - osc_tail(f, qs, r)))/(2*mp.pi)

    # SHARP_REF[H] = [G_sharp(r, H) for r in SHARP_DR]
    # SHARP_Q0_REF = [G_sharp(r, 0.7, q0=1e-3) for r in SHARP_Q0_DR]
    # SMOOTH_REF[H] = [G_smooth(r, H) for r in SMOOTH_DR]
    # The same script confirmed the self-affine constant
    #   int_0^inf t^(-1-2H) (1 - J0(t)) dt = 2^(-1-2H) Gamma(1-H) / (H Gamma(1+H))
    # to 30 digits for H = 0.05, 0.3, 0.5, 0.8, 0.95
    #   (P(X) + X^(-2H)/(2H) - osc_tail(t^(-1-2H) J0, X)).
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest
from scipy import integrate, special

from xrough._kernels.hankel import (
    PowerLawInterpolant,
    acf_from_spectrum_kernel,
    profile_spectrum_kernel,
    spectral_moment_kernel,
)
from xrough._kernels.spectral_models import SpectrumModel
from xrough._kernels.spectrum_of_acf import spectrum_from_acf_kernel

# q_r = 1, q_s = 1e6, C_r = 1, q_0 = 0: dr spans 1e-4/q_s ... 1e6/q_r (16 decades)
SHARP_DR = np.array([1e-10, 1e-8, 1e-6, 3e-5, 1e-3, 0.1, 2, 7, 60, 1e3, 1e5, 1e6])
SHARP_REF = {
    0.05: [5.2602518676006327205e-11, 5.2602358524391708166e-7, 0.0051029908337822621932,
           0.15568737099925221974, 0.38876995930922960646, 0.84987735335282793414,
           1.245913465103324283, 1.2695651224017959557, 1.2713560817929965711,
           1.2713477521171030561, 1.2713477604047472104, 1.2713477604046896414],
    0.5: [3.9788705923132684261e-16, 3.9788623038360632361e-12, 3.8973436470667213549e-8,
          4.6160452687175405015e-6, 0.00015896594585669532955, 0.015616961077365599727,
          0.20525494363923596818, 0.23639709144035142218, 0.23874403034375629358,
          0.23873224364153391643, 0.23873225548298199492, 0.2387322554828997537],
    0.95: [1.1960779280142948609e-20, 1.1960774566281501122e-16, 1.1914299632714834468e-12,
           7.8771669503283710872e-10, 5.0188369022020758826e-7, 0.0017350863479958431212,
           0.12445983000942805241, 0.16059005745145327393, 0.16335838564115830315,
           0.16334321567137058345, 0.16334323106777107419, 0.16334323106766416163],
}
# H = 0.7, q_0 = 1e-3, q_r = 1, q_s = 1e6
SHARP_Q0_DR = np.array([1e-6, 0.5, 30, 1e4, 1e7])
SHARP_Q0_REF = [2.6019805098840103434e-10, 0.03968418569460790868, 0.19331833095878800575,
                0.19325949445467894223, 0.19325949372445424127]
# smooth roll-off, q_r = 1, q_s = 1e3, q_0 = 0
SMOOTH_DR = np.array([1e-5, 0.01, 0.3, 3, 50, 1e3, 1e5])
SMOOTH_REF = {
    0.2: [1.5689410246825379755e-7, 0.035386949689410512167, 0.2043050535376490485,
          0.36621378485187583805, 0.37278236818477884243, 0.372782367694484872,
          0.3727823676871873629],
    0.8: [1.4521816795326892632e-10, 0.000088012623301811195643, 0.012560164612774211766,
          0.090460014177532628914, 0.099470262911409205446, 0.099470262911286052353,
          0.099470262911284219301],
}


def sharp(H, q_s=1e6, q_0=0.0):
    return SpectrumModel(H, 1.0, q_s, q_0, 1.0, "sharp")


def self_affine_constant(H):
    """int_0^inf t^(-1-2H) (1 - J0(t)) dt (Mellin transform of 1 - J0, checked above)."""
    return 2.0 ** (-1 - 2 * H) * special.gamma(1 - H) / (H * special.gamma(1 + H))


# --------------------------------------------------------------------------------------
# eq. 9 against mpmath
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("H", sorted(SHARP_REF))
@pytest.mark.parametrize("knots_per_decade", [0, 160])
def test_sharp_model_matches_mpmath_over_sixteen_decades(H, knots_per_decade):
    # The sharp model is an exact piecewise power law: the only error is round-off
    # (measured max 2.5e-15).  rtol 1e-12 leaves room for other BLAS/libm; atol 0 because
    # G spans 1e-20 ... 1 and each value must be right relative to itself.
    # knots_per_decade=160 runs the generic (smooth-spectrum) path on the same model.
    m = sharp(H)
    G = acf_from_spectrum_kernel(SHARP_DR, m, m.breakpoints, knots_per_decade=knots_per_decade)
    np.testing.assert_allclose(G, SHARP_REF[H], rtol=1e-12, atol=0)


def test_sharp_model_with_lower_cutoff_matches_mpmath():
    # same accuracy argument as above (measured 1.3e-15)
    m = sharp(0.7, q_0=1e-3)
    G = acf_from_spectrum_kernel(SHARP_Q0_DR, m, m.breakpoints, knots_per_decade=0)
    np.testing.assert_allclose(G, SHARP_Q0_REF, rtol=1e-12, atol=0)


@pytest.mark.parametrize("H", sorted(SMOOTH_REF))
def test_smooth_model_matches_mpmath(H):
    # smooth C is represented by power laws with a quadratic correction between 160 knots
    # per decade in the oscillatory range: measured max error 1.2e-11; rtol 1e-9 is the
    # documented accuracy of that path
    m = SpectrumModel(H, 1.0, 1e3, 0.0, 1.0, "smooth")
    G = acf_from_spectrum_kernel(SMOOTH_DR, m, m.breakpoints)
    np.testing.assert_allclose(G, SMOOTH_REF[H], rtol=1e-9, atol=0)


# --------------------------------------------------------------------------------------
# limits and closed forms
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("rolloff", ["sharp", "smooth"])
@pytest.mark.parametrize("H", [0.05, 0.5, 0.95])
def test_ballistic_limit(rolloff, H):
    # 1 - J0(t) = t^2/4 - t^4/64 + O(t^6) gives G = gbar^2 dr^2/4 - m_4 dr^4/64 + ...,
    # m_k = (1/2pi) int q^(1+k) C dq; the next term is (q_s dr)^4/2304 <= 5e-16 relative for
    # q_s dr <= 1e-3.  rtol 1e-12 then tests that no round-off creeps in at small dr
    # (1 - J0 is never formed as a difference); atol 0 as G ~ 1e-26 ... 1e-18.
    m = SpectrumModel(H, 1.0, 1e6, 0.0, 1.0, rolloff)
    dr = np.array([1e-13, 1e-11, 1e-9])
    G = acf_from_spectrum_kernel(dr, m, m.breakpoints)
    expected = m.moment(2) * dr**2 / 4 - m.moment(4) * dr**4 / 64
    np.testing.assert_allclose(G, expected, rtol=1e-12, atol=0)


@pytest.mark.parametrize("rolloff", ["sharp", "smooth"])
@pytest.mark.parametrize("H", [0.05, 0.5, 0.95])
def test_saturation_limit(rolloff, H):
    # G(dr) - sigma_h^2 = -(1/2pi) int q C J0(q dr) dq ~ C_r q_r^2 (q_r dr)^-1.5 ~ 3e-11 at
    # q_r dr = 1e7, so rtol 1e-9 (atol 0: sigma_h^2 is O(1) here)
    m = SpectrumModel(H, 1.0, 1e6, 0.0, 1.0, rolloff)
    dr = np.array([1e7, 3.3e8])
    G = acf_from_spectrum_kernel(dr, m, m.breakpoints)
    np.testing.assert_allclose(G, m.moment(0), rtol=1e-9, atol=0)


@pytest.mark.parametrize("H", [0.1, 0.3, 0.5, 0.7, 0.9])
def test_self_affine_range_matches_power_law_closed_form(H):
    # For q_r << 1/dr << q_s:
    #   2 pi G / C_r = q_r^(2+2H) dr^(2H) [K(H) - (q_r dr)^(2-2H)/(4(2-2H))
    #                  - (q_s dr)^(-2H)/(2H)] + q_r^4 dr^2/16
    # with K(H) = int_0^inf t^(-1-2H) (1 - J0) dt in closed form and the leading corrections
    # of both cutoffs.  The neglected terms are <= (q_s dr)^(-2H-1.5) ~ 1.3e-7 of the
    # correction scale (H = 0.1), hence rtol 1e-7.
    q_s, dr = 1e8, 1e-4
    m = sharp(H, q_s=q_s)
    G = acf_from_spectrum_kernel(np.array([dr]), m, m.breakpoints, knots_per_decade=0)[0]
    x, y = dr, q_s * dr
    expected = (dr ** (2 * H) * (self_affine_constant(H) - x ** (2 - 2 * H) / (4 * (2 - 2 * H))
                                 - y ** (-2 * H) / (2 * H)) + dr**2 / 16) / (2 * np.pi)
    assert G == pytest.approx(expected, rel=1e-7, abs=0)


def flat_annulus_reference(a, b, r):
    """(1/2pi) int_a^b q (1 - J0(q r)) dq = (1/2pi) [q^2/2 - q J1(q r)/r]_a^b (mpmath)."""
    mp.mp.dps = 40

    def F(q):
        q, rr = mp.mpf(q), mp.mpf(r)
        return q * q / 2 - q * mp.besselj(1, q * rr) / rr

    return float((F(b) - F(a)) / (2 * mp.pi))


@pytest.mark.parametrize("a, b", [(0.0, 1.0), (0.3, 1.0)])
def test_flat_piece_closed_form(a, b):
    # a flat disc / annulus has the closed form above (evaluated at 40 digits to avoid its
    # cancellation at small r); rtol 1e-12 is a few hundred ulp (measured ~1e-15)
    r = np.geomspace(1e-5, 1e6, 23)
    m = lambda q: np.where((q >= a) & (q < b), 1.0, 0.0)  # noqa: E731
    G = acf_from_spectrum_kernel(r, m, [a, b], knots_per_decade=0)
    ref = [flat_annulus_reference(a, b, x) for x in r]
    np.testing.assert_allclose(G, ref, rtol=1e-12, atol=0)


def test_thin_ring_is_an_orientation_averaged_sinusoid():
    # A thin ring of spectral weight at |q| = q1 is a superposition of sinusoids with
    # random orientation, so G = sigma_h^2 (1 - J0(q1 dr)) (THEORY.md section 1); the ring
    # width eps = 1e-6 changes that by O(eps q1 dr) <= 1e-4, hence rtol 2e-4 and atol
    # 1e-4 sigma_h^2 (absolute near the zeros of 1 - J0's oscillation around 1).
    q1, eps = 3.0, 1e-6
    ring = lambda q: np.where((q >= q1) & (q < q1 * (1 + eps)), 1.0, 0.0)  # noqa: E731
    bp = [q1, q1 * (1 + eps)]
    sigma2 = spectral_moment_kernel(ring, bp, 0)
    dr = np.linspace(0.1, 30, 40)
    G = acf_from_spectrum_kernel(dr, ring, bp, knots_per_decade=0)
    np.testing.assert_allclose(G, sigma2 * (1 - special.j0(q1 * dr)), rtol=2e-4,
                               atol=1e-4 * sigma2)


def test_steep_pieces_of_noisy_samples_match_dense_quadrature():
    # A noisy spectrum on a linear q grid (like a measured PSD) has local power-law exponents
    # of several hundred, where the asymptotic series is not valid at t = 64; the kernel then
    # integrates those pieces numerically.  Reference: Gauss-Legendre (20 nodes) on panels
    # cut at every sample and at most 0.25 wide in t, with no asymptotics: converged to
    # ~1e-14, so rtol 1e-10 (atol 0, G > 0).
    rng = np.random.default_rng(20240611)
    q = np.arange(1, 301, dtype=float)
    c = q**-3.0 * np.exp(rng.normal(0.0, 1.0, q.size))
    spec = PowerLawInterpolant(q, c)
    dr = np.array([0.05, 0.7, 2.0, 9.0])
    G = acf_from_spectrum_kernel(dr, spec, spec.breakpoints, knots_per_decade=0)
    x, w = np.polynomial.legendre.leggauss(20)
    ref = []
    for r in dr:
        edges = np.unique(np.concatenate([q * r, np.arange(q[0] * r, q[-1] * r, 0.25),
                                          [q[-1] * r]]))
        lo, hi = edges[:-1], edges[1:]
        t = 0.5 * (lo + hi)[:, None] + 0.5 * (hi - lo)[:, None] * x
        f = t * spec(t / r) * (1 - special.j0(t))
        ref.append(np.sum((f @ w) * 0.5 * (hi - lo)) / r**2 / (2 * np.pi))
    np.testing.assert_allclose(G, ref, rtol=1e-10, atol=0)


def test_shape_zero_and_bad_input():
    m = sharp(0.5, q_s=100.0)
    dr = np.array([[0.0, 1.0], [2.0, 3.0]])
    G = acf_from_spectrum_kernel(dr, m, m.breakpoints)
    assert G.shape == (2, 2)
    assert G[0, 0] == 0.0  # G(0) = 0 exactly
    flat = acf_from_spectrum_kernel(dr.ravel(), m, m.breakpoints).reshape(2, 2)
    np.testing.assert_array_equal(G, flat)
    with pytest.raises(ValueError, match="dr must be finite"):
        acf_from_spectrum_kernel([-1.0], m, m.breakpoints)
    with pytest.raises(ValueError, match="breakpoints"):
        acf_from_spectrum_kernel([1.0], m, [1.0])


@pytest.mark.parametrize(
    "check, match",
    [
        (lambda: PowerLawInterpolant([1.0, 3.0, 2.0], [1.0, 1.0, 1.0]),
         r"^q must hold wavenumbers that are finite, positive and strictly increasing; "
         r"got 2 at index 2 after 3$"),
        (lambda: PowerLawInterpolant([0.0, 1.0], [1.0, 1.0]),
         r"^q must .* positive .*got 0 first$"),
        (lambda: spectrum_from_acf_kernel([1.0], [1.0, np.nan, 3.0, 4.0], np.ones(4)),
         r"^dr must hold lags that are finite, positive .*; got nan at index 1$"),
    ],
)
def test_increasing_grids_are_checked_by_one_rule_naming_the_argument(check, match):
    """The q of a sampled spectrum and the dr of sampled G: one check, naming the argument
    and the first value that breaks it."""
    with pytest.raises(ValueError, match=match):
        check()


# --------------------------------------------------------------------------------------
# moments
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("rolloff", ["sharp", "smooth"])
@pytest.mark.parametrize("H", [0.05, 0.5, 0.95])
@pytest.mark.parametrize("q_0", [0.0, 1e-3])
@pytest.mark.parametrize("k", [0, 1, 2, 4])
def test_spectral_moment_matches_model(rolloff, H, q_0, k):
    # closed form (sharp) or rtol-1e-13 adaptive quadrature (smooth); Gauss-Legendre on log
    # panels is exact to round-off (measured 2e-15), so rtol 1e-12
    m = SpectrumModel(H, 1.0, 1e6, q_0, 2.5, rolloff)
    got = spectral_moment_kernel(m, m.breakpoints, k)
    assert got == pytest.approx(m.moment(k), rel=1e-12, abs=0)


def test_eq9_consistent_with_moments_through_power_law_interpolant():
    # sampled sharp model (q_0 and q_r on the grid) is an exact piecewise power law:
    # the interpolant reproduces the model, its moments and G to round-off (rtol 1e-11)
    m = sharp(0.6, q_s=1e4, q_0=1e-2)
    q = np.unique(np.concatenate([np.geomspace(1e-2, 1.0, 21), np.geomspace(1.0, 1e4, 61)]))
    c = m(q)
    c[-1] = m.C_r * (q[-1] / m.q_r) ** (-2 * 1.6)  # closed interval at q_s
    spec = PowerLawInterpolant(q, c)
    probe = np.geomspace(1e-2, 1e4, 333)[1:-1]
    np.testing.assert_allclose(spec(probe), m(probe), rtol=1e-12, atol=0)
    assert spectral_moment_kernel(spec, spec.breakpoints, 2) == pytest.approx(
        m.moment(2), rel=1e-11, abs=0)
    dr = np.geomspace(1e-6, 1e4, 11)
    np.testing.assert_allclose(
        acf_from_spectrum_kernel(dr, spec, spec.breakpoints, knots_per_decade=0),
        acf_from_spectrum_kernel(dr, m, m.breakpoints, knots_per_decade=0), rtol=1e-11, atol=0)


# --------------------------------------------------------------------------------------
# profile (1D) spectrum
# --------------------------------------------------------------------------------------
def test_profile_spectrum_of_flat_disc():
    # C = 1 for q < 1: C1D(qx) = sqrt(1 - qx^2)/pi exactly; rtol 1e-12 (round-off)
    qx = np.linspace(-1.5, 1.5, 301)
    flat = lambda q: np.where(q < 1.0, 1.0, 0.0)  # noqa: E731
    got = profile_spectrum_kernel(qx, flat, [0.0, 1.0])
    np.testing.assert_allclose(got, np.sqrt(np.clip(1 - qx**2, 0, None)) / np.pi,
                               rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("rolloff", ["sharp", "smooth"])
def test_profile_spectrum_matches_weighted_quadrature(rolloff):
    # independent route: QUADPACK with the algebraic weight (q - qx)^(-1/2) on the original
    # integral (no substitution), rtol 1e-12 requested; compared at rtol 1e-9
    m = SpectrumModel(0.7, 1.0, 1e3, 0.0, 1.0, rolloff)
    qx = np.array([0.0, 1e-3, 0.5, 0.999, 1.0, 1.001, 3.0, 999.0])
    got = profile_spectrum_kernel(qx, m, m.breakpoints)

    def reference(k):
        f = lambda q: m(q) * q / np.sqrt(q + k)  # noqa: E731
        if k == 0:
            return integrate.quad(lambda q: m(q), 0, 1)[0] + integrate.quad(
                lambda q: m(q), 1, 1e3, limit=500, epsabs=0, epsrel=1e-13)[0]
        segs = [k, 1.0, 1e3] if k < 1.0 else [k, 1e3]
        total = integrate.quad(f, segs[0], segs[1], weight="alg", wvar=(-0.5, 0.0),
                               epsabs=0, epsrel=1e-13, limit=500)[0]
        if len(segs) == 3:
            total += integrate.quad(lambda q: f(q) / np.sqrt(q - k), 1.0, 1e3, epsabs=0,
                                    epsrel=1e-13, limit=500)[0]
        return total

    ref = np.array([reference(k) for k in qx]) / np.pi
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=0)


def _graded_edges(points, lo, hi, levels=40):
    """Panel edges graded geometrically towards singular ``points`` (exponential GL rate)."""
    edges = [lo, hi]
    for p in points:
        for side in (-1, 1):
            span = (p - lo) if side < 0 else (hi - p)
            if span > 0:
                edges.extend(p + side * span * 0.5 ** np.arange(1, levels))
    return np.unique(np.clip(edges, lo, hi))


@pytest.mark.parametrize("H", [0.3, 0.8])
def test_profile_cosine_transform_equals_2d_acf(H):
    # G(x) = (1/pi) int_0^inf C1D(k) (1 - cos(k x)) dk must equal eq. 9.  C1D has
    # square-root-type singularities at k = q_r and k = q_s (kink / jump of C), handled by
    # geometric grading; panels are also at most 0.5/x wide for the oscillation.  Both
    # routes are ~1e-12 accurate; rtol 1e-9 (atol 0, G > 0).
    m = sharp(H, q_s=100.0)
    xs = np.array([0.003, 0.1, 1.0, 10.0])
    G2 = acf_from_spectrum_kernel(xs, m, m.breakpoints, knots_per_decade=0)
    nodes, weights = np.polynomial.legendre.leggauss(16)
    base = _graded_edges([1.0, 100.0], 0.0, 100.0)
    G1 = []
    for x in xs:
        edges = np.unique(np.concatenate([base, np.arange(0.0, 100.0, 0.5 / x)]))
        lo, hi = edges[:-1], edges[1:]
        k = 0.5 * (lo + hi)[:, None] + 0.5 * (hi - lo)[:, None] * nodes
        f = profile_spectrum_kernel(k, m, m.breakpoints) * 2 * np.sin(0.5 * k * x) ** 2
        G1.append(np.sum((f @ weights) * 0.5 * (hi - lo)) / np.pi)
    np.testing.assert_allclose(G1, G2, rtol=1e-9, atol=0)
