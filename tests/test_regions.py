"""The regions of a map: G of its quarters against their finite-area error.

A map whose quarters scatter beyond the Gaussian finite-area error of G is not what that
error describes; its ``standard_error`` (and every error derived from G) becomes the
quarters' scatter, and G says why (``xrough.correlation._regions``).
"""

import warnings

import numpy as np
import pytest
import xarray as xr

import xrough
from conftest import data_path, needs_bridge
from xrough._kernels.uncertainty import REGIONS_DISAGREE, regional_scatter


def _surface(seed=1, n=256, unit="nm", **kw):
    topo = xrough.self_affine_surface(hurst=0.7, lambda_r=f"{n // 4} nm", lambda_s="4 nm",
                                      size=f"{n} nm", n=n, rms_gradient=0.2, seed=seed,
                                      unit="nm", **kw)
    topo.attrs["periodic"] = 0
    return topo if unit == "nm" else xrough.convert_units(topo, unit, lateral=unit)


def _banded(seed=1, n=256):
    """A self-affine map whose first quarter of rows is three times as rough (a band)."""
    topo = _surface(seed, n)
    gain = np.where(np.arange(n) < n // 4, 3.0, 1.0)[:, None]
    return topo.copy(data=topo.values * gain)


def _acf(topo, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        return topo.rough.acf(**kw)


def test_regional_scatter_against_the_sample_variance():
    """r^2 is the quarters' sample variance over the quarter's Gaussian variance (the
    whole map's times the area ratio); the factor the regions' error of the mean over the
    map's error, held beyond the judged lags, 1 where no lag disagrees."""
    rng = np.random.default_rng(0)
    g = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    se = np.array([0.01, 0.02, 0.03, 0.04, 0.05])
    regions = g + rng.normal(size=(4, 5)) * np.array([1.0, 2.0, 3.0, 4.0, 5.0]) * 0.5
    judged = np.array([True, True, True, False, False])
    r2, k = regional_scatter(regions, g, se, judged=judged, area_ratio=4.0)
    var = regions.var(axis=0, ddof=1)
    np.testing.assert_allclose(r2[:3], var[:3] / (4.0 * se[:3] ** 2), rtol=1e-12)
    assert np.all(np.isnan(r2[3:]))
    expected = np.maximum(np.sqrt(var[:3] / 4) / se[:3], 1.0)
    np.testing.assert_allclose(k[:3], expected, rtol=1e-12)
    np.testing.assert_allclose(k[3:], expected[2], rtol=1e-12)  # held beyond
    # regions within their errors: nothing raised
    quiet = g + rng.normal(size=(4, 5)) * se * 2.0 * 0.5
    r2, k = regional_scatter(quiet, g, se, judged=judged, area_ratio=4.0)
    assert np.nanmax(r2) < REGIONS_DISAGREE and np.all(k == 1.0)
    # G near the float range: no overflow (computed relative to G)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r2_big, k_big = regional_scatter(regions * 1e300, g * 1e300, se * 1e300,
                                         judged=judged, area_ratio=4.0)
    r2, k = regional_scatter(regions, g, se, judged=judged, area_ratio=4.0)
    np.testing.assert_allclose(r2_big[:3], r2[:3], rtol=1e-10)
    np.testing.assert_allclose(k_big, k, rtol=1e-10)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_stationary_map_keeps_its_gaussian_errors(seed):
    """Self-affine Gaussian maps: the quarters agree (the largest variance ratio over 72
    such maps was 3.8, the threshold 9), G is not marked, error_inflation is 1."""
    G = _acf(_surface(seed))
    assert "quality" not in G.attrs and int(G.quality_flag) == 0
    np.testing.assert_array_equal(G.error_inflation.values, 1.0)
    assert "regions_ratio_max" not in G.attrs


def test_a_banded_map_is_questionable_and_its_errors_are_the_regions_scatter():
    """A band of rows three times as rough: the quarters disagree, G says so (one
    warning naming the regions), standard_error is the Gaussian one times the factor,
    and the errors of the fit, the gradient and the energy grow with it."""
    topo = _banded()
    with pytest.warns(xrough.QualityWarning, match="the regions of the map disagree"):
        G = topo.rough.acf()
    assert G.attrs["quality"] == "questionable" and int(G.quality_flag) == 1
    k = G.error_inflation.values
    assert k.min() >= 1.0 and k.max() > 3.0
    assert G.attrs["error_inflation_max"] == pytest.approx(k.max())
    # the same G with its Gaussian errors
    plain = G.assign_coords(standard_error=(G.standard_error / G.error_inflation)
                            .assign_attrs(G.standard_error.attrs)).drop_vars(
        "error_inflation").pipe(xrough.quality.unrated)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        e_reg = G.rough.energy(E_star="25 MPa")
        e_gauss = plain.rough.energy(E_star="25 MPa")
        g_reg, g_gauss = G.rough.gradient(), plain.rough.gradient()
    assert float(e_reg.v_el) == pytest.approx(float(e_gauss.v_el), rel=1e-12)
    assert float(e_reg.v_el_std) > 2.0 * float(e_gauss.v_el_std)
    assert float(g_reg.gbar_std[0]) > 2.0 * float(g_gauss.gbar_std[0])


def test_the_verdict_is_the_same_in_every_unit_and_with_dask():
    """nm against m, and a dask stack against numpy: the same flag, factor and errors,
    those of G and those of the fit, the gradient and the energy drawn from it."""
    topo = _banded()
    G_nm = _acf(topo)
    G_m = _acf(xrough.convert_units(topo, "m", lateral="m"))
    np.testing.assert_allclose(G_m.error_inflation.values, G_nm.error_inflation.values,
                               rtol=1e-9)
    assert int(G_m.quality_flag) == int(G_nm.quality_flag) == 1
    stack = xr.concat([topo, _surface(2)], dim="scan").assign_attrs(topo.attrs)
    eager = _acf(stack)
    lazy = _acf(stack.chunk({"scan": 1}))
    assert lazy.quality_flag.chunks is not None and lazy.error_inflation.chunks is not None
    assert eager.quality_flag.values.tolist() == [1, 0]
    computed = lazy.compute()
    assert computed.quality_flag.values.tolist() == [1, 0]
    assert xrough.quality.worst(lazy) == "questionable"
    # why, per map, lazily and the same as numpy's: the regions, and nothing else
    assert lazy.quality_reasons.chunks is not None
    bit = xrough.quality.reason_bit("regions_disagree")
    assert eager.quality_reasons.values.tolist() == [bit, 0]
    assert computed.quality_reasons.values.tolist() == [bit, 0]
    assert xrough.quality.reasons_of(lazy) == ["regions_disagree"]
    np.testing.assert_allclose(computed.error_inflation.values,
                               eager.error_inflation.values, rtol=1e-12)
    np.testing.assert_allclose(computed.standard_error.values,
                               eager.standard_error.values, rtol=1e-10)
    # the errors of what is drawn from G, curve by curve (the stationary map keeps its
    # Gaussian error) and lazily
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        for of in (lambda g: g.rough.fit().hurst_std,
                   lambda g: g.rough.gradient().gbar_std.isel(dr=0),
                   lambda g: g.rough.energy(E_star="25 MPa").v_el_std):
            np.testing.assert_allclose(of(lazy).compute().values, of(eager).values,
                                       rtol=1e-6)
            single = float(of(_acf(_surface(2))))
            assert float(of(eager)[1]) == pytest.approx(single, rel=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        # what is drawn from the banded map says why it is questionable, lazily too
        for of in (lambda g: g.rough.fit(), lambda g: g.rough.gradient(),
                   lambda g: g.rough.energy(E_star="25 MPa"),
                   lambda g: g.rough.persson(E_star="25 MPa", p0="0.1 MPa")):
            got_eager, got_lazy = of(eager), of(lazy).compute()
            np.testing.assert_array_equal(got_lazy.quality_flag.values,
                                          got_eager.quality_flag.values)
            np.testing.assert_array_equal(got_lazy.quality_reasons.values,
                                          got_eager.quality_reasons.values)
            assert int(got_eager.quality_reasons[0]) & bit, got_eager.quality_reasons


def test_a_map_with_missing_points_and_a_small_map():
    """An empty quarter (NaN) has no G and leaves the verdict to the others; a map whose
    quarters are narrower than 16 pixels is not judged (no error_inflation)."""
    topo = _surface(4)
    holed = topo.where((topo.y > 130) | (topo.x > 130))  # the first quarter missing
    G = _acf(holed)
    assert np.all(np.isfinite(G.error_inflation.values))
    small = _acf(_surface(5, n=24))
    assert "error_inflation" not in small.coords


@pytest.mark.data
@needs_bridge  # .nid is read through SurfaceTopography
def test_the_halves_of_a_real_map_agree_within_their_errors():
    """nid-1.nid (a scan-start band): its halves along y gave gbar at one pixel 59 of
    their stated errors apart (0.036 against 0.0056: one holds the band). With the
    regions' errors they are 3.5 apart (measured: 0.036 against 0.0053), and each half
    says why its errors are wide and its G questionable: what differs is named, as a
    referee needs."""
    topo = xrough.open_topography(data_path("instruments", "nid-1.nid"),
                                  channel="Scan forward (Z-Axis)")
    parts = []
    for half in (slice(0, 128), slice(128, 256)):
        part = topo.isel(y=half).rough.detrend(mode="plane")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            G = part.rough.acf()
            gbar = G.rough.gradient()
        assert any("the regions of the map disagree" in str(w.message) for w in caught)
        parts.append((float(gbar[0]), float(gbar.gbar_std[0])))
    (a, sa), (b, sb) = parts
    assert abs(a - b) / np.hypot(sa, sb) < 4.0, parts


def test_the_fit_and_the_gradient_of_a_questionable_g_are_questionable():
    """What makes G questionable (its regions disagree) holds for what is drawn from it:
    the fit and the gradient carry G's flag and notes, each with one warning; their
    values are those of G with its Gaussian errors (the regions change errors only)."""
    G = _acf(_banded())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit = G.rough.fit()
    said = [w for w in caught if issubclass(w.category, xrough.QualityWarning)]
    assert len(said) == 1 and "the regions of the map disagree" in str(said[0].message)
    assert fit.attrs["quality"] != "good" and int(fit.quality_flag) >= 1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        gbar = G.rough.gradient()
        plain = G.assign_coords(standard_error=(G.standard_error / G.error_inflation)
                                .assign_attrs(G.standard_error.attrs)).drop_vars(
            "error_inflation").pipe(xrough.quality.unrated)
        fit_plain = plain.rough.fit()
    assert gbar.attrs["quality"] == "questionable"
    assert "the regions of the map disagree" in gbar.attrs["quality_notes"]
    assert float(fit.hurst) == pytest.approx(float(fit_plain.hurst), rel=1e-9)
    # wider (measured 0.139 against 0.115: the sandwich of the plain fit already widens
    # by the misfit that the band leaves beyond the Gaussian errors)
    assert float(fit.hurst_std) > 1.1 * float(fit_plain.hurst_std)


@pytest.mark.data
def test_a_map_of_too_few_points_has_no_gradient_and_no_contact_area():
    """sdf-1.sdf (4 x 7 points, 7 bins for a fit of 4 parameters): the fit fails (too few
    bins), and so do the gradient and Persson theory (a_r was 0.38 +- 0.04 from the
    ballistic form), each saying why."""
    topo = xrough.open_topography(data_path("instruments", "sdf-1.sdf")).rough.detrend()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        G = topo.rough.acf()
        gbar = G.rough.gradient()
        contact = G.rough.persson(E_star="25 MPa", p0="0.1 MPa")
    assert gbar.attrs["quality"] == "failed" and np.all(np.isnan(gbar.values))
    assert "too few bins" in gbar.attrs["quality_notes"]
    assert contact.attrs["quality"] == "failed" and np.all(np.isnan(contact.a_r.values))
