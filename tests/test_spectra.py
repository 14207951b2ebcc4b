"""Tests of xrough.spectra: the model spectrum (eq. 35) and G from a spectrum (eq. 9)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import xarray as xr

import xrough
from conftest import DATA
from xrough import units
from xrough._kernels.hankel import spectral_moment_kernel
from xrough._kernels.spectral_models import SpectrumModel
from xrough.spectra import acf_from_spectrum, model_spectrum
from xrough.testing import assert_netcdf_round_trip

BASE = dict(hurst=0.8, lambda_r="1 um", lambda_s="10 nm")


def spectrum_nm(**kw):
    args = {**BASE, "rms_height": "2 nm", "unit": "nm", **kw}
    return model_spectrum(**args)


# --------------------------------------------------------------------------------------
# model_spectrum
# --------------------------------------------------------------------------------------
def test_units_names_and_attrs():
    C = spectrum_nm(lambda_0="20 um")
    assert C.name == "C" and C.dims == ("q",)
    assert C.attrs["units"] == "nm4"
    assert C.attrs["long_name"] == "isotropic height spectrum"
    assert C["q"].attrs == {"units": "nm-1", "long_name": "angular wavenumber"}
    assert C.attrs["model"] == "self-affine"
    assert C.attrs["equation"] == "eq. 35"
    assert C.attrs["spectrum_kind"] == "isotropic 2D"
    # netCDF-legal attributes only
    for value in C.attrs.values():
        assert isinstance(value, (str, float, int)) and not isinstance(value, bool)
    # q_r = 2 pi / 1000 nm etc. (exact arithmetic, rtol 1e-15 for the conversions)
    assert C.attrs["q_r"] == pytest.approx(2 * np.pi / 1000, rel=1e-15)
    assert C.attrs["q_s"] == pytest.approx(2 * np.pi / 10, rel=1e-15)
    assert C.attrs["q_0"] == pytest.approx(2 * np.pi / 20000, rel=1e-15)
    assert spectrum_nm().attrs["q_0"] == 0.0


def test_default_grid_contains_cutoffs():
    C = spectrum_nm(lambda_0="20 um", points_per_decade=10)
    q = C["q"].values
    assert np.all(np.diff(q) > 0)
    for key in ("q_0", "q_r", "q_s"):
        assert np.any(q == C.attrs[key])  # exactly on the grid
    assert q[0] == C.attrs["q_0"] and q[-1] == C.attrs["q_s"]
    # without lambda_0: from q_r / 100; with lambda_0 shorter than 10 lambda_r: from q_r / 10
    assert spectrum_nm()["q"].values[0] == pytest.approx(C.attrs["q_r"] / 100, rel=1e-15)
    assert spectrum_nm(lambda_0="3 um")["q"].values[0] == pytest.approx(
        C.attrs["q_r"] / 10, rel=1e-15)
    # about points_per_decade points per decade
    assert 10 * np.log10(q[-1] / q[0]) <= q.size <= 10 * np.log10(q[-1] / q[0]) + 4


def test_values_follow_eq35():
    # the sampled values are eq. 35 on the closed interval [q_0, q_s]; exact arithmetic on
    # the same formula, so rtol 1e-14
    C = spectrum_nm(lambda_0="20 um")
    a = C.attrs
    q = C["q"].values
    H = a["hurst"]
    expected = np.where(q < a["q_r"], a["C_r"], a["C_r"] * (q / a["q_r"]) ** (-2 * (1 + H)))
    np.testing.assert_allclose(C.values, expected, rtol=1e-14, atol=0)
    smooth = spectrum_nm(rolloff="smooth")
    q = smooth["q"].values
    expected = smooth.attrs["C_r"] * (1 + (q / smooth.attrs["q_r"]) ** 2) ** (-(1 + H))
    np.testing.assert_allclose(smooth.values, expected, rtol=1e-14, atol=0)
    assert smooth.attrs["rolloff"] == "smooth" and "smooth" in smooth.attrs["equation"]


@pytest.mark.parametrize("rolloff", ["sharp", "smooth"])
def test_amplitude_options_agree(rolloff):
    # sigma_h and gbar are moments of C (closed form or rtol-1e-13 quadrature): every
    # route must give back the same C_r to rtol 1e-12 (atol 0, all values positive)
    from_h = spectrum_nm(rolloff=rolloff)
    assert from_h.attrs["rms_height"] == pytest.approx(2.0, rel=1e-12)
    g = from_h.attrs["rms_gradient"]
    from_g = spectrum_nm(rolloff=rolloff, rms_height=None, rms_gradient=g)
    from_c = spectrum_nm(rolloff=rolloff, rms_height=None,
                         C_r=f"{from_h.attrs['C_r']!r} nm^4")
    from_c_si = spectrum_nm(rolloff=rolloff, rms_height=None,
                            C_r=from_h.attrs["C_r"])  # plain number: in unit^4 (nm^4)
    for other in (from_g, from_c, from_c_si):
        np.testing.assert_allclose(other.values, from_h.values, rtol=1e-12, atol=0)
        assert other.attrs["rms_height"] == pytest.approx(2.0, rel=1e-12)
        assert other.attrs["rms_gradient"] == pytest.approx(g, rel=1e-12)
    # and the moments of the sampled model agree with the attributes
    a = from_h.attrs
    model = SpectrumModel(a["hurst"], a["q_r"], a["q_s"], a["q_0"], a["C_r"], rolloff)
    assert np.sqrt(spectral_moment_kernel(model, model.breakpoints, 0)) == pytest.approx(
        2.0, rel=1e-12)


def test_quantity_and_plain_number_inputs():
    # plain lengths are in the output unit (nm here), strings and Quantities carry theirs
    ref = spectrum_nm()
    alt = model_spectrum(hurst=0.8, lambda_r=1000, lambda_s=units.ureg.Quantity(10, "nm"),
                         rms_height=2.0, unit="nm")
    xr.testing.assert_identical(ref, alt)


@pytest.mark.parametrize("rolloff", ["sharp", "smooth"])
def test_nm_and_m_give_the_same_physics(rolloff):
    # the same surface in m and in nm: q scales by 1e-9, C by 1e36, G by 1e18 and dr by 1e9.
    # Unit factors are exact decimals; rtol 1e-12 allows for the different floating-point
    # paths (atol 0: all values positive)
    kw = dict(BASE, lambda_0="30 um", rms_gradient=0.3, rolloff=rolloff)
    c_nm = model_spectrum(**kw, unit="nm")
    c_m = model_spectrum(**kw, unit="m")
    assert c_m.attrs["units"] == "m4" and c_m["q"].attrs["units"] == "m-1"
    np.testing.assert_allclose(c_m["q"].values * 1e-9, c_nm["q"].values, rtol=1e-12, atol=0)
    np.testing.assert_allclose(c_m.values * 1e36, c_nm.values, rtol=1e-12, atol=0)
    for key, power in (("q_r", -1), ("q_s", -1), ("q_0", -1), ("C_r", 4), ("rms_height", 1)):
        assert c_m.attrs[key] * 1e9**power == pytest.approx(c_nm.attrs[key], rel=1e-12)
    assert c_m.attrs["rms_gradient"] == pytest.approx(c_nm.attrs["rms_gradient"], rel=1e-12)
    g_nm = acf_from_spectrum(c_nm)
    g_m = acf_from_spectrum(c_m)
    assert g_m.attrs["units"] == "m2" and g_m["dr"].attrs["units"] == "m"
    np.testing.assert_allclose(g_m["dr"].values * 1e9, g_nm["dr"].values, rtol=1e-12, atol=0)
    np.testing.assert_allclose(g_m.values * 1e18, g_nm.values, rtol=1e-9, atol=0)


def test_given_q_in_output_units():
    q = np.array([0.0, 1e-4, 6e-3, 0.1, 0.6, 1.0])  # nm-1; beyond q_s = 0.628 -> 0
    C = spectrum_nm(q=q)
    np.testing.assert_array_equal(C["q"].values, q)
    assert C.values[-1] == 0.0 and np.all(C.values[:-1] > 0)
    Cq = spectrum_nm(q=units.ureg.Quantity(q * 1e9, "1/m"))
    np.testing.assert_allclose(Cq.values, C.values, rtol=1e-12, atol=0)


@pytest.mark.parametrize("name", ["c.nc"])
def test_netcdf_round_trip(tmp_path, name):
    C = spectrum_nm(lambda_0="20 um", rolloff="smooth")
    back = assert_netcdf_round_trip(C, tmp_path / name)
    G = acf_from_spectrum(C)
    assert_netcdf_round_trip(G, tmp_path / "g.nc")
    # the re-opened spectrum still evaluates through its model
    xr.testing.assert_identical(acf_from_spectrum(back), G)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(hurst=1.0), r"hurst must lie in \(0, 1\)"),
        (dict(hurst=0.0), r"hurst must lie in \(0, 1\)"),
        (dict(hurst=float("nan")), r"hurst must lie in \(0, 1\)"),
        (dict(lambda_s="1 um"), "lambda_s must be shorter than lambda_r"),
        (dict(lambda_s="2 um"), "lambda_s must be shorter than lambda_r"),
        (dict(lambda_0="0.5 um"), "lambda_0 .* must be at least lambda_r"),
        (dict(C_r="1 nm^4"), r"exactly one of C_r, rms_height, rms_gradient .*'C_r', 'rms_h"),
        (dict(rms_height=None), r"exactly one of C_r, rms_height, rms_gradient .*\(got none\)"),
        (dict(lambda_r="-1 um"), "lambda_r must be a positive length"),
        (dict(lambda_r=0.0), "lambda_r must be a positive length"),
        (dict(lambda_r="1 MPa"), "lambda_r: '1 MPa' is not a length"),
        (dict(rms_height="2 nm^2"), "rms_height: .* is not a length"),
        (dict(rms_height="-2 nm"), "rms_height must be a positive length"),
        (dict(rms_height=None, rms_gradient=-0.1), "rms_gradient must be positive"),
        (dict(rms_height=None, rms_gradient="1 nm"), "rms_gradient must be dimensionless"),
        (dict(rms_height=None, C_r="1 nm^3"), "C_r must have units of length\\^4"),
        (dict(rms_height=None, C_r=-1.0), "C_r must be positive"),
        (dict(rolloff="soft"), "rolloff must be one of"),
        (dict(unit="Pa"), "unit must be a length"),
        (dict(q=[0.1, -1.0]), "q must be a 1-D array of finite wavenumbers >= 0"),
        (dict(points_per_decade=0), "points_per_decade must be a positive number up to 1000"),
    ],
)
def test_model_spectrum_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        spectrum_nm(**kwargs)


# --------------------------------------------------------------------------------------
# acf_from_spectrum
# --------------------------------------------------------------------------------------
def test_acf_units_attrs_and_default_grid():
    C = spectrum_nm(lambda_0="20 um")
    with xr.set_options(keep_attrs=True):  # must not matter: units are built explicitly
        G = acf_from_spectrum(C, points_per_decade=10)
    assert G.name == "G" and G.dims == ("dr",)
    assert G.attrs["units"] == "nm2"
    assert G.attrs["long_name"] == "height-difference autocorrelation function"
    assert G["dr"].attrs == {"units": "nm", "long_name": "lag distance"}
    assert G.attrs["equation"] == "eq. 9" and G.attrs["estimator"] == "spectrum"
    for key in ("model", "rolloff", "hurst", "q_r", "q_s", "q_0", "C_r", "rms_height",
                "rms_gradient"):
        assert G.attrs[key] == C.attrs[key]
    q = C["q"].values
    dr = G["dr"].values
    # default range 0.01 * 2pi/q_max ... 100 * 2pi/q_min (rtol 1e-12: geomspace end points)
    assert dr[0] == pytest.approx(0.01 * 2 * np.pi / q.max(), rel=1e-12)
    assert dr[-1] == pytest.approx(100 * 2 * np.pi / q.min(), rel=1e-12)
    G2 = acf_from_spectrum(C, dr_min="1 nm", dr_max=1e4)  # plain numbers: nm here
    assert G2["dr"].values[0] == pytest.approx(1.0, rel=1e-12)
    assert G2["dr"].values[-1] == pytest.approx(1e4, rel=1e-12)


@pytest.mark.parametrize("rolloff", ["sharp", "smooth"])
def test_acf_limits_through_public_api(rolloff):
    # G -> gbar^2 dr^2/4 (correction (q_s dr)^2/16 ~ 2.5e-7 at dr = 0.001 nm, hence rtol 1e-6)
    # and G -> sigma_h^2 (oscillating remainder ~ (q_r dr)^-1.5 ~ 1e-10 at 1e5 lambda_r,
    # hence rtol 1e-8)
    C = spectrum_nm(rolloff=rolloff)
    G = acf_from_spectrum(C, [1e-3, 1e8])
    gbar2 = C.attrs["rms_gradient"] ** 2
    assert float(G[0]) == pytest.approx(gbar2 * 1e-6 / 4, rel=1e-6, abs=0)
    assert float(G[1]) == pytest.approx(C.attrs["rms_height"] ** 2, rel=1e-8, abs=0)


def test_samples_without_model_attrs_are_a_piecewise_power_law():
    # With lambda_0 set, the default grid starts at q_0 and contains q_r and q_s, so the
    # log-log interpolant of the samples *is* the sharp model: both routes agree to
    # round-off (rtol 1e-10, atol 0)
    C = spectrum_nm(lambda_0="20 um", hurst=0.35)
    data = xr.DataArray(C.values, dims="q", coords={"q": ("q", C["q"].values,
                                                          {"units": "nm-1"})},
                        attrs={"units": "nm4"})
    dr = np.geomspace(0.01, 1e6, 41)
    exact = acf_from_spectrum(C, dr)
    sampled = acf_from_spectrum(data, dr)
    np.testing.assert_allclose(sampled.values, exact.values, rtol=1e-10, atol=0)
    assert "model" not in sampled.attrs and sampled.attrs["units"] == "nm2"


def test_sampled_smooth_spectrum_close_to_model():
    # the log-log interpolation of the smooth roll-off at 100 points per decade differs
    # from the model by at most h^2/8 max|d^2 ln C / d(ln q)^2| = h^2/8 (1+H) ~ 1.2e-4
    # (h = ln 10 / 100, maximum at q = q_r); G averages that error (measured 5.5e-5), so
    # rtol 1.2e-4
    C = spectrum_nm(lambda_0="20 um", rolloff="smooth", points_per_decade=100)
    data = C.copy()
    data.attrs = {"units": "nm4"}
    dr = np.geomspace(0.01, 1e6, 31)
    np.testing.assert_allclose(acf_from_spectrum(data, dr).values,
                               acf_from_spectrum(C, dr).values, rtol=1.2e-4, atol=0)


def test_mixed_units_are_converted():
    # spectrum values in um4 with q in nm-1: G comes out in nm2 (factor 1e12 exact)
    C = spectrum_nm(lambda_0="20 um")
    data = xr.DataArray(C.values * 1e-12, dims="q",
                        coords={"q": ("q", C["q"].values, {"units": "nm-1"})},
                        attrs={"units": "um4"})
    dr = [1.0, 100.0]
    np.testing.assert_allclose(acf_from_spectrum(data, dr).values,
                               acf_from_spectrum(C, dr).values, rtol=1e-10, atol=0)
    assert acf_from_spectrum(data, dr).attrs["units"] == "nm2"


def test_dr_as_quantity_or_dataarray():
    C = spectrum_nm()
    G = acf_from_spectrum(C, [10.0, 1000.0])
    Gq = acf_from_spectrum(C, units.ureg.Quantity([0.01, 1.0], "um"))
    Gd = acf_from_spectrum(C, xr.DataArray([1e-8, 1e-6], dims="x", attrs={"units": "m"}))
    for other in (Gq, Gd):
        np.testing.assert_allclose(other["dr"].values, G["dr"].values, rtol=1e-14)
        np.testing.assert_allclose(other.values, G.values, rtol=1e-12)


def _data(q, c, q_units="nm-1", c_units="nm4"):
    qa = {"units": q_units} if q_units else {}
    ca = {"units": c_units} if c_units else {}
    return xr.DataArray(np.asarray(c, float), dims="q", coords={"q": ("q", q, qa)}, attrs=ca)


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: _data([1.0, 2.0], [1.0, 1.0], c_units=None), "spectrum has no 'units'"),
        (lambda: _data([1.0, 2.0], [1.0, 1.0], q_units=None), "coordinate 'q'.*no 'units'"),
        (lambda: _data([1.0, 2.0], [1.0, 1.0], q_units="nm"), "must be an angular wavenumber"),
        (lambda: _data([1.0, 2.0], [1.0, 1.0], c_units="nm2"), "must be in length\\^4"),
        (lambda: _data([2.0, 1.0], [1.0, 1.0]), "strictly increasing"),
        (lambda: _data([1.0, 1.0, 2.0], [1.0, 1.0, 1.0]), "strictly increasing"),
        (lambda: _data([0.0, 1.0], [1.0, 1.0]), "positive"),
        (lambda: _data([1.0, 2.0], [1.0, -1.0]), "finite and >= 0"),
        (lambda: _data([1.0, 2.0], [1.0, np.nan]), "finite and >= 0"),
        (lambda: xr.DataArray(np.ones((2, 2)), dims=("a", "q")), "must be 1-D"),
        (lambda: xr.DataArray(np.ones(2), dims="q", attrs={"units": "nm4"}),
         "needs a wavenumber coordinate"),
    ],
)
def test_acf_bad_spectrum(make, match):
    with pytest.raises(ValueError, match=match):
        acf_from_spectrum(make(), [1.0])


def test_acf_model_attrs_must_match_values():
    C = spectrum_nm()
    tampered = C.copy(data=C.values * 2)  # copy keeps the model attrs
    with pytest.raises(ValueError, match="does not match its values"):
        acf_from_spectrum(tampered)


def test_acf_bad_dr():
    C = spectrum_nm()
    with pytest.raises(ValueError, match="dr must be a 1-D array"):
        acf_from_spectrum(C, [-1.0])
    with pytest.raises(ValueError, match="dr_max must exceed dr_min"):
        acf_from_spectrum(C, dr_min="1 um", dr_max="1 nm")
    with pytest.raises(ValueError, match="dr_min: .* is not a length"):
        acf_from_spectrum(C, dr_min="1 s")
    with pytest.raises(TypeError, match="DataArray"):
        acf_from_spectrum(C.values)


def test_model_gradient_is_never_negative_below_the_rolloff():
    """Regression: below q_r the power-law term of eq. 26 was b^e - q_r^e with b = q_r,
    which numpy's array and scalar powers can make -1 ulp; beside the tiny flat term of
    a large lag that gave gbar^2 < 0 (a sqrt warning, then NaN) on a fit with H = 0.95."""
    from xrough._kernels.spectral_models import model_gradient2

    q = 2 * np.pi / np.geomspace(1e-5, 1e5, 101)
    g2 = model_gradient2(q, c=0.08767418290355335, hurst=0.950244120871398,
                         q_r=0.006313766691069956, q_s=5334.066300105561)
    assert np.all(g2 > 0)
    below = q < 0.006313766691069956  # only the flat part: C_r q^4 / 4 / (2 pi)
    c_r = 0.08767418290355335 / 0.006313766691069956 ** (2 + 2 * 0.950244120871398)
    np.testing.assert_allclose(g2[below], c_r * q[below] ** 4 / 4 / (2 * np.pi), rtol=1e-12)


# ---------------------------------------------------------------- G that fixes C nowhere
def _spectrum_quietly(G):
    with pytest.warns(xrough.QualityWarning, match="determines C nowhere|max_error"):
        return G.rough.spectrum()


@pytest.mark.parametrize("case", ["power law 512x256", "white noise 16x16",
                                  "periodic profile 256"])
def test_spectrum_returns_where_g_fixes_c_nowhere(case):
    """A G still self-affine at its first lag and still rising (or noisy) at its last fixes
    C nowhere to 1 %: C comes back on the data's range, nothing supported, questionable,
    with the way out in its notes (these raised before)."""
    rng = np.random.default_rng(0)
    if case == "power law 512x256":
        topo = xrough.self_affine_surface(hurst=0.7, lambda_r=512.0, lambda_s=2.0,
                                          size=(256.0, 512.0), n=(256, 512),
                                          rms_gradient=0.1, unit="nm", seed=0)
    elif case == "white noise 16x16":
        topo = xrough.topography(rng.normal(size=(16, 16)), spacing="1 nm", unit="nm")
    else:
        topo = xrough.topography(np.cumsum(rng.normal(size=256)), spacing="1 nm", unit="nm",
                                 periodic=True)
    G = topo.rough.acf()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        C = G.rough.spectrum()
    assert C.sizes["q"] > 0 and np.all(np.isfinite(C.values))
    q = C.q.values
    assert q[0] <= 2 * np.pi / G.dr.values[-1] and q[-1] >= 2 * np.pi / G.dr.values[0]
    if not C.supported.any():
        assert C.attrs["quality"] == "questionable"
        assert "psd()" in C.attrs["quality_notes"] or "max_error" in C.attrs["quality_notes"]
        assert np.isnan(C.attrs["q_min_supported"])


def test_spectrum_of_the_shared_afm_map_with_defaults():
    path = DATA / "instruments" / "di-1.di"
    if not path.exists():
        pytest.skip("shared data not present")
    with warnings.catch_warnings():  # G's own notes (anisotropy): not what is tested
        warnings.simplefilter("ignore", xrough.QualityWarning)
        G = xrough.detrend(xrough.open_topography(path), mode="plane").rough.acf()
    C = _spectrum_quietly(G)
    assert C.attrs["quality"] == "questionable" and not C.supported.any()
    assert "determines C nowhere" in C.attrs["quality_notes"]


def test_sigma_h2_does_not_follow_a_falling_end():
    """A periodic profile's G falls near L/2.  With the variance of its heights (the coord
    ``height_variance`` of a measured G) sigma_h2 is that variance; without it, that fall
    is not continued into the plateau: sigma_h2 is the last level, not a decade further
    down (0.02 against a variance of 1.25 before)."""
    rng = np.random.default_rng(0)
    n = 256
    q = np.fft.rfftfreq(n) * 2 * np.pi
    amp = np.where(q > 0, np.maximum(q, 2 * np.pi / 64) ** -1.8, 0.0)
    h = np.fft.irfft(np.fft.rfft(rng.normal(size=n)) * amp, n)
    h *= np.sqrt(1.25) / h.std()
    G = xrough.topography(h, spacing="1 nm", unit="nm", periodic=True).rough.acf()
    assert G.values[-1] < G.values[-2]  # this G falls at its end
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        C = G.rough.spectrum()
        C_free = G.drop_vars("height_variance").rough.spectrum()
    assert C.attrs["sigma_h2"] == pytest.approx(1.25, rel=1e-12)
    assert C.attrs["sigma_h2_from"].startswith("the variance of the heights")
    assert C_free.attrs["sigma_h2"] == pytest.approx(float(G[-1]), rel=0.02)
    assert C_free.attrs["sigma_h2_from"].startswith("the extension of G")
