"""The short-wavelength cutoff of the model spectrum: eq. 35's sharp end or a Gaussian transfer.

An instrument (tip, optics, stylus) rolls a measured spectrum off like ``exp(-(q/q_s)^2)``.
Independent references: scipy's adaptive quadrature and 30-digit mpmath for the model's
moments and G (eq. 9), the closed form of the bare power law with a Gaussian cutoff
(``int_0^inf q^(1-2H) exp(-q^2/q_s^2) dq = q_s^(2-2H) Gamma(1-H) / 2``), and synthetic maps
drawn from the model spectrum.
"""

from __future__ import annotations

import warnings

import mpmath
import numpy as np
import pytest
from scipy import integrate, special

import xrough
from xrough._kernels.fitting import (
    AIC_MARGIN,
    PROBLEMS,
    SHAPE_SPREAD_MAX,
    SPECTRUM_OUTPUTS,
    _acf_shape,
    _model_spread,
)
from xrough._kernels.spectral_models import (
    SpectrumModel,
    model_gradient2,
    shape_code,
    shape_names,
)
from xrough.fitting import fit_acf, model_acf
from xrough.gradient import gradient_from_fit, gradient_from_spectrum
from xrough.models import model_attrs, model_from_attrs
from xrough.testing import assert_netcdf_round_trip

AT = {name: k for k, name in enumerate(SPECTRUM_OUTPUTS)}


def gaussian_model(H=0.5, rolloff="smooth", q_r=0.05, q_s=2.0, q_0=0.0, C_r=3.0):
    return SpectrumModel(hurst=H, q_r=q_r, q_s=q_s, q_0=q_0, C_r=C_r, rolloff=rolloff,
                         cutoff="gaussian")


# --------------------------------------------------------------------------------------
# the model
# --------------------------------------------------------------------------------------
def test_shape_codes_round_trip():
    for rolloff in ("sharp", "smooth"):
        for cutoff in ("sharp", "gaussian"):
            assert shape_names(shape_code(rolloff, cutoff)) == (rolloff, cutoff)
    assert shape_code("smooth") == 1 and shape_code("sharp", "gaussian") == 2


def test_gaussian_spectrum_is_the_sharp_one_times_the_transfer():
    q = np.geomspace(1e-3, 12.99, 200)  # below q_end = 6.5 q_s, from which C is 0
    g = gaussian_model(rolloff="sharp", q_s=2.0)
    power = SpectrumModel(hurst=0.5, q_r=0.05, q_s=1e9, C_r=3.0)  # no cutoff within q
    np.testing.assert_allclose(g(q), power(q) * np.exp(-(q / 2.0) ** 2), rtol=1e-14)
    assert g.q_end == pytest.approx(6.5 * 2.0) and not g.piecewise_power_law
    assert float(g(np.array([g.q_end * 1.01]))[0]) == 0.0  # exp(-42) and beyond: none
    with pytest.raises(ValueError, match="cutoff must be one of"):
        SpectrumModel(hurst=0.5, q_r=1.0, q_s=2.0, cutoff="optical")


@pytest.mark.parametrize("rolloff", ["sharp", "smooth"])
@pytest.mark.parametrize("H", [0.05, 0.5, 0.95])
def test_gaussian_moments_against_quadrature(rolloff, H):
    """sigma_h^2 and gbar^2 (eq. 26 at every q_cut) against scipy.quad, rtol 1e-9."""
    m = gaussian_model(H=H, rolloff=rolloff, q_r=0.1, q_s=5.0)

    def quad(k, top):
        return integrate.quad(lambda q: q ** (1 + k) * m(q) / (2 * np.pi), 0.0,
                              min(top, m.q_end), points=[m.q_r], epsrel=1e-13,
                              limit=500)[0]

    assert m.moment(0) == pytest.approx(quad(0, np.inf), rel=1e-9)
    q_cut = np.array([0.05, 0.5, 3.0, 10.0, 1e3])
    c = m.C_r * m.q_r ** (2 + 2 * H)
    got = model_gradient2(q_cut, c=c, hurst=H, q_r=m.q_r, q_s=m.q_s, rolloff=rolloff,
                          cutoff="gaussian")
    np.testing.assert_allclose(got, [quad(2, a) for a in q_cut], rtol=1e-9)


def test_gaussian_power_law_gradient_in_closed_form():
    """No roll-off: ``c q_s^(2-2H) gamma(1-H, (q_cut/q_s)^2) / 2`` (scipy.quad, 1e-12)."""
    H, q_s = 0.3, 2.0
    got = model_gradient2(np.array([1.0, 10.0, np.inf]), c=1.0, hurst=H, q_r=0.0, q_s=q_s,
                          cutoff="gaussian")
    ref = [integrate.quad(lambda q: q ** (1 - 2 * H) * np.exp(-(q / q_s) ** 2), 0, a)[0]
           / (2 * np.pi) for a in (1.0, 10.0, np.inf)]
    np.testing.assert_allclose(got, ref, rtol=1e-12)
    assert got[-1] == pytest.approx(q_s ** (2 - 2 * H) * special.gamma(1 - H) / 4 / np.pi,
                                    rel=1e-14)


@pytest.mark.parametrize("rolloff", ["sharp", "smooth"])
def test_gaussian_acf_against_mpmath(rolloff):
    """Eq. 9 of the Gaussian-cutoff model (the fit's quadrature) against 30-digit mpmath.

    The fit evaluates it with 40 knots per decade (:data:`_KNOTS`): measured 3e-9 at most
    over 0.05 <= H <= 0.95 and 20 <= lambda_r/lambda_s <= 250; asserted 1e-7.
    """
    mpmath.mp.dps = 30
    H, lam_r, lam_s = 0.4, 100.0, 4.0
    x = np.array([0.5, 3.0, 40.0, 600.0])
    G = _acf_shape(x, H, lam_r, lam_s, np.inf, rolloff, cutoff="gaussian")
    m = SpectrumModel(hurst=H, q_r=2 * np.pi / lam_r, q_s=2 * np.pi / lam_s, rolloff=rolloff,
                      cutoff="gaussian",
                      C_r=2 * np.pi / (float(xrough._kernels.shape_factors.self_affine_constant(
                          H)) * (2 * np.pi / lam_r) ** (2 + 2 * H)))
    for xi, g in zip(x, G):
        def f(q, xi=xi):
            return q * mpmath.mpf(float(m(float(q)))) * (1 - mpmath.besselj(0, q * xi))
        edges = [0, m.q_r, *np.linspace(m.q_r, m.q_end, 60)[1:]]
        ref = mpmath.quad(f, edges) / (2 * mpmath.pi)
        assert g == pytest.approx(float(ref), rel=1e-7)


def test_gaussian_far_cutoff_shift():
    """A Gaussian lambda_s far below the lags shifts G by Gamma(1-H) times a sharp one's.

    Moved there by :func:`_acf_shape` and shifted to leading order: against the direct
    quadrature at the true lambda_s, relative 1e-6 (the next term ``(q_s dr)^-2``).
    """
    H, x = 0.5, np.geomspace(10.0, 1e3, 7)
    moved = _acf_shape(x, H, 1e4, 1e-5, np.inf, "sharp", cutoff="gaussian")
    direct = _acf_shape(x, H, 1e4, 1e-2, np.inf, "sharp", cutoff="gaussian")
    sharp = _acf_shape(x, H, 1e4, 1e-2, np.inf, "sharp")
    sharp_moved = _acf_shape(x, H, 1e4, 1e-5, np.inf, "sharp")
    # from lambda_s = 1e-2 to 1e-5 the shift is Gamma(1-H) times that of the sharp cutoff
    np.testing.assert_allclose(moved - direct, special.gamma(1 - H) * (sharp_moved - sharp),
                               rtol=1e-6)


def test_model_attrs_and_surfaces_carry_the_cutoff():
    m = xrough.models.self_affine_model(hurst=0.5, lambda_r=100, lambda_s=3, rms_height=1,
                                        unit="nm", cutoff="gaussian")
    assert model_from_attrs(model_attrs(m)) == m
    assert m.moment(0) == pytest.approx(1.0, rel=1e-12)
    # one pixel is enough for a Gaussian transfer; two for eq. 35's sharp end
    topo = xrough.self_affine_surface(hurst=0.5, lambda_r=32, lambda_s=1, size=64, n=64,
                                      rms_height=1, cutoff="gaussian", seed=0, unit="nm")
    assert topo.attrs["cutoff"] == "gaussian"
    with pytest.raises(ValueError, match="two pixels"):
        xrough.self_affine_surface(hurst=0.5, lambda_r=32, lambda_s=1, size=64, n=64,
                                   rms_height=1, seed=0, unit="nm")
    C = xrough.model_spectrum(hurst=0.5, lambda_r=100, lambda_s=3, rms_height=1, unit="nm",
                              cutoff="gaussian")
    assert "Gaussian" in C.attrs["equation"] and float(C.q[-1]) == pytest.approx(
        6.5 * 2 * np.pi / 3)


# --------------------------------------------------------------------------------------
# the fit
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("rolloff", ["sharp", "smooth"])
def test_fit_recovers_the_exact_gaussian_model(rolloff, tmp_path):
    """The exact G of a Gaussian-cutoff spectrum: 'auto' keeps the Gaussian, parameters to
    1e-7; eq. 35's sharp cutoff alone misses H by 0.03 on it."""
    C = xrough.model_spectrum(hurst=0.5, lambda_r="1 um", lambda_s="10 nm", rms_height="2 nm",
                              unit="nm", cutoff="gaussian", rolloff=rolloff)
    G = xrough.acf_from_spectrum(C, dr_min=0.1, dr_max=1e5)
    p = fit_acf(G)
    assert int(p.cutoff_shape) == 1 and p.attrs["cutoff"] == "gaussian"
    assert "AIC" in p.attrs["cutoff_choice"]
    for name, true in (("hurst", 0.5), ("sigma_h", 2.0), ("lambda_r", 1000.0),
                       ("lambda_s", 10.0)):
        assert float(p[name]) == pytest.approx(true, rel=1e-7), name
    sharp = fit_acf(G, cutoff="sharp")
    assert int(sharp.cutoff_shape) == 0 and sharp.attrs["cutoff_choice"] == "given"
    assert abs(float(sharp.hurst) - 0.5) > 0.03
    assert float(p.reduced_chi2_other_cutoff) == pytest.approx(float(sharp.reduced_chi2))
    # the fitted curve and gradient are those of the Gaussian model
    dr = np.array([1.0, 30.0, 3e3])
    np.testing.assert_allclose(model_acf(p, dr).values,
                               xrough.acf_from_spectrum(C, dr).values, rtol=1e-6)
    gb = gradient_from_fit(p, dr)
    q_cut = 2 * np.pi / dr
    m = model_from_attrs(C.attrs)
    exact = np.sqrt(model_gradient2(q_cut, c=m.C_r * m.q_r ** 3, hurst=0.5, q_r=m.q_r,
                                    q_s=m.q_s, rolloff=rolloff, cutoff="gaussian"))
    np.testing.assert_allclose(gb.values, exact, rtol=1e-6)
    # eq. 26 of the model spectrum itself (closed form of its attributes)
    np.testing.assert_allclose(gradient_from_spectrum(C, dr).values, exact, rtol=1e-12)
    assert_netcdf_round_trip(p, tmp_path / "fit.nc")


def test_fit_keeps_the_sharp_cutoff_of_eq35():
    """The exact G of eq. 35: the Gaussian is fitted and rejected, H exact."""
    C = xrough.model_spectrum(hurst=0.7, lambda_r=500, lambda_s=5, rms_height=1, unit="nm")
    G = xrough.acf_from_spectrum(C, dr_min=0.5, dr_max=1e4)
    p = fit_acf(G)
    assert int(p.cutoff_shape) == 0 and float(p.hurst) == pytest.approx(0.7, rel=1e-7)
    assert np.isfinite(float(p.reduced_chi2_other_cutoff))


def test_fit_without_a_resolved_lambda_s_tries_no_gaussian():
    """Without a ballistic regime in the lags the two cutoffs are the same power law."""
    C = xrough.model_spectrum(hurst=0.6, lambda_r=500, lambda_s=0.01, rms_height=1, unit="nm")
    p = fit_acf(xrough.acf_from_spectrum(C, dr_min=2, dr_max=1e4))
    assert int(p.lambda_s_resolved) == 0 and int(p.cutoff_shape) == 0
    assert np.isnan(float(p.reduced_chi2_other_cutoff))


@pytest.mark.parametrize("H", [0.3, 0.65])
def test_instrument_map_gives_the_true_hurst(H):
    """A 512^2 map through a Gaussian transfer at lambda_s = 4 px (smooth roll-off, L/4).

    eq. 35's sharp cutoff fits H 0.12-0.18 high, rated good (over 40 seeds: 0.77 for 0.65,
    0.48 for 0.3; benchmarks/instrument_cutoffs.py); the default fit keeps the Gaussian and
    H within 3 of its standard deviations (over 40 seeds z = +0.10 +- 1.00 and +0.01 +- 0.85).
    """
    topo = xrough.self_affine_surface(hurst=H, lambda_r=128, lambda_s=4, size=512, n=512,
                                      rms_height=1.0, rolloff="smooth", cutoff="gaussian",
                                      seed=11, unit="um")
    G = topo.rough.acf()
    p, sharp = fit_acf(G), fit_acf(G, cutoff="sharp")
    assert int(p.cutoff_shape) == 1 and p.attrs["quality"] == "good"
    assert abs(float(p.hurst) - H) < 3 * float(p.hurst_std)
    assert float(sharp.hurst) - H > 0.1 and sharp.attrs["quality"] == "good"


def _outputs(hurst, hurst_std, chi2, n=40):
    out = np.full(len(SPECTRUM_OUTPUTS), np.nan)
    out[AT["hurst"]], out[AT["hurst_std"]] = hurst, hurst_std
    out[AT["sigma_h"]], out[AT["sigma_h_std"]] = 1.0, 0.01
    out[AT["reduced_chi2"]], out[AT["n_bins"]] = chi2, n
    out[AT["fit_problems"]], out[AT["quality"]] = 0, 0
    return out


def test_model_spread_enters_the_error_and_the_rating():
    """Akaike weights: a tie adds half the squared difference; a clear choice adds nothing.

    Two fits with equal AIC and H 0.5 / 0.7 (std 0.02): the variance about the kept one
    gains ``0.5 * 0.2^2``, std ``sqrt(0.02^2 + 0.02) = 0.1428``, and the fit is questionable
    (spread 0.14 > 0.05); with the other fit 40 worse in AIC nothing changes.
    """
    kept, other = _outputs(0.5, 0.02, 1.0), _outputs(0.7, 0.02, 1.0)
    _model_spread(kept, [kept, other], [10.0, 10.0])
    assert kept[AT["hurst_std"]] == pytest.approx(np.sqrt(0.02**2 + 0.5 * 0.2**2), rel=1e-12)
    bit = 1 << PROBLEMS.index("cutoff_shape_undetermined")
    assert int(kept[AT["fit_problems"]]) & bit and kept[AT["quality"]] == 1
    kept, other = _outputs(0.5, 0.02, 1.0), _outputs(0.7, 0.02, 1.0)
    _model_spread(kept, [kept, other], [10.0, 50.0])
    assert kept[AT["hurst_std"]] == pytest.approx(0.02, rel=1e-6)  # weight e^-20
    assert int(kept[AT["fit_problems"]]) == 0
    # a tie of fits closer than SHAPE_SPREAD_MAX: error widened, rating kept
    kept, other = _outputs(0.5, 0.01, 1.0), _outputs(0.52, 0.01, 1.0)
    _model_spread(kept, [kept, other], [10.0, 10.0 + AIC_MARGIN / 2])
    assert 0.01 < kept[AT["hurst_std"]] < SHAPE_SPREAD_MAX
    assert int(kept[AT["fit_problems"]]) == 0


def test_cutoff_argument_is_checked():
    C = xrough.model_spectrum(hurst=0.5, lambda_r=100, lambda_s=3, rms_height=1, unit="nm")
    G = xrough.acf_from_spectrum(C, dr_min=1, dr_max=1e3)
    with pytest.raises(ValueError, match="cutoff must be one of"):
        fit_acf(G, cutoff="lorentzian")
    with pytest.raises(ValueError, match="model='spectrum' only"):
        fit_acf(G, model="eq36", cutoff="gaussian")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert fit_acf(G, cutoff="gaussian").attrs["cutoff"] == "gaussian"


# --------------------------------------------------------------------------------------
# gbar at the pixel scale where the fitted spectrum runs on beyond the data's resolution
# --------------------------------------------------------------------------------------
def test_beyond_resolution_of_a_power_law():
    """A bare power law's gbar^2 ~ dr^-(2-2H): the share beyond two first lags is
    ``1 - 2^-(2-2H)`` exactly (log-log interpolation of a power law is exact)."""
    from xrough._kernels.gradient import beyond_resolution
    dr = np.geomspace(1.0, 100.0, 21)
    for H in (0.05, 0.3, 0.8):
        gbar = dr ** -(1 - H)
        share = beyond_resolution(dr, gbar, np.ones(dr.size, dtype=bool))
        assert share == pytest.approx(1 - 2.0 ** -(2 - 2 * H), rel=1e-12)
    assert np.isnan(beyond_resolution(dr, gbar, np.r_[False, np.ones(20, dtype=bool)]))


def test_gradient_at_one_pixel_through_a_gaussian_transfer_at_one_pixel():
    """A map whose Gaussian transfer sits at one pixel: the fitted spectrum runs on beyond
    the map's Nyquist wavenumber, and gbar at one pixel counts wavelengths the data do not
    resolve (512^2, H 0.3: 8 % above the map's own full gradient, 40 % of gbar^2 there):
    questionable, saying why.  At four pixels the same gradient is good and right."""
    for lambda_s, rated in ((1.0, "questionable"), (4.0, "good")):
        topo = xrough.self_affine_surface(hurst=0.3, lambda_r=64, lambda_s=lambda_s,
                                          size=256, n=256, rms_height=1.0,
                                          rolloff="smooth", cutoff="gaussian", seed=2,
                                          unit="um")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", xrough.QualityWarning)
            g = topo.rough.acf().rough.gradient()
        assert g.attrs["quality"] == rated, (lambda_s, g.attrs["quality_notes"])
        assert ("Nyquist" in g.attrs["quality_notes"]) == (lambda_s == 1.0)


def test_gaussian_fit_is_the_same_physics_in_nm_um_and_m():
    """The same perturbed Gaussian-cutoff G in nm, um and m: the same fit to 1e-8 (the
    optimiser works in units of dr_ref and of the mean G; the standard deviations come from
    finite differences, measured 2e-9 apart)."""
    fits = []
    for unit, f in (("nm", 1.0), ("um", 1e-3), ("m", 1e-9)):
        C = xrough.model_spectrum(hurst=0.4, lambda_r=f * 1000, lambda_s=f * 10,
                                  rms_height=f * 2, unit=unit, cutoff="gaussian",
                                  rolloff="smooth")
        G = xrough.acf_from_spectrum(C, dr_min=f * 0.5, dr_max=f * 1e5)
        G = G * np.exp(0.01 * np.sin(np.arange(G.size)))  # not exactly the model
        p = fit_acf(G)
        assert int(p.cutoff_shape) == 1
        fits.append([float(p.hurst), float(p.hurst_std), float(p.lambda_s) / f,
                     float(p.sigma_h) / f, float(p.sigma_h_std) / f])
    np.testing.assert_allclose(fits[1], fits[0], rtol=1e-8)
    np.testing.assert_allclose(fits[2], fits[0], rtol=1e-8)


def test_a_gaussian_search_that_breaks_down_leaves_the_sharp_fit(monkeypatch):
    """A Gaussian-cutoff search that raises (a singular covariance, say) costs nothing: the
    sharp fit is returned as if no Gaussian had been tried."""
    import xrough._kernels.fitting as kf

    C = xrough.model_spectrum(hurst=0.7, lambda_r=500, lambda_s=5, rms_height=1, unit="nm")
    G = xrough.acf_from_spectrum(C, dr_min=0.5, dr_max=1e4)
    sharp = fit_acf(G, cutoff="sharp")
    original = kf._fit_spectrum_shape

    def breaking(*args, **kw):
        if kw.get("cutoff") == "gaussian":
            raise np.linalg.LinAlgError("singular")
        return original(*args, **kw)

    monkeypatch.setattr(kf, "_fit_spectrum_shape", breaking)
    fit_acf.cache_clear()
    p = fit_acf(G)
    assert int(p.cutoff_shape) == 0 and float(p.hurst) == float(sharp.hurst)
    assert np.isnan(float(p.reduced_chi2_other_cutoff))
