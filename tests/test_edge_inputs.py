"""Absurd arguments get a ValueError that names them, never an overflow or a huge allocation."""

import numpy as np
import pytest
import xarray as xr

import xrough


@pytest.fixture(scope="module")
def topo():
    return xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="400 nm",
                                      size="10 um", n=64, rms_gradient=0.5, seed=1, unit="nm")


@pytest.fixture(scope="module")
def G(topo):
    return topo.rough.acf()


@pytest.mark.parametrize("E_star", [1e300, "1e300 Pa", 1e-300])
@pytest.mark.parametrize("call", [
    lambda G, E: G.rough.persson(E_star=E, p0=1e5),
    lambda G, E: G.rough.stress_acf(E_star=E),
    lambda G, E: G.rough.energy(E_star=E),
    lambda G, E: G.rough.patch_radius(E_star=E, gamma=0.05),
])
def test_modulus_whose_square_overflows_is_refused(G, E_star, call):
    # (E*/2)^2 of 1e300 Pa overflows float64: the old code raised OverflowError deep inside
    with pytest.raises(ValueError, match="E_star .* outside 1e-100 to 1e100"):
        call(G, E_star)


@pytest.mark.parametrize("ppd", [np.inf, np.nan, 0, -1, 1e9])
def test_points_per_decade_must_be_finite_and_sane(topo, ppd):
    with pytest.raises(ValueError, match="points_per_decade must be a positive number"):
        topo.rough.acf(points_per_decade=ppd)


def test_linear_bins_finer_than_the_lattice_are_refused_before_allocating(topo):
    # 1e-6 nm bins over 5 um: 5e9 bins (the old code tried to allocate 37 GiB)
    with pytest.raises(ValueError, match="bin_width=1e-06 nm gives .* linear bins"):
        topo.rough.acf(bins="linear", bin_width=1e-6)


# ------------------------------------------------------------------ extreme heights, G


@pytest.fixture(scope="module")
def small_map():
    return xrough.self_affine_surface(hurst=0.8, lambda_r="1 um", lambda_s="200 nm",
                                      size="2 um", n=32, rms_gradient=0.5, seed=2, unit="nm")


def test_contact_solver_on_heights_of_1e180_is_the_scaled_solution(small_map):
    # The contact problem is linear in (h, p0/E*): heights times s with the load times s
    # have s times the pressure and gap. s = 2**600 (4e180 nm heights: their squares
    # overflow float64) against the same map at s = 1; E* = 2**-300 Pa keeps p0 of both
    # within 1e-100..1e100 Pa. The solver scales the heights by a power of two itself, and
    # a power of two commutes exactly with every float operation, so the two solutions
    # must agree bit for bit (no tolerance). The old code squared the heights to inf and
    # reported full contact, converged, with residual 0.
    s, E, tau = 2.0**600, 2.0**-300, 0.05
    big = (small_map * s).assign_attrs(small_map.attrs)
    ref = xrough.solve_contact(small_map, E_star=E, p0=tau * E)
    out = xrough.solve_contact(big, E_star=E, p0=tau * E * s)
    assert 0 < float(ref.contact_area) < 1 and bool(out.converged)
    assert float(out.contact_area) == float(ref.contact_area)
    np.testing.assert_array_equal(out.pressure.values, ref.pressure.values * s)
    np.testing.assert_array_equal(out.gap.values, ref.gap.values * s)
    np.testing.assert_array_equal(out.approach.values, ref.approach.values * s)


def test_contact_load_beyond_float64_of_the_heights_is_refused(small_map):
    # heights of about 1e299 nm with p0 / E* = 1e-199: the load is about 1e-498 of the
    # heights' scale, below the smallest float64; refused instead of solved as no load
    big = (small_map * 1e298).assign_attrs(small_map.attrs)
    with pytest.raises(ValueError, match=r"p0 / E_star = 1e-199 is .* times the largest "
                                         r"height"):
        xrough.solve_contact(big, E_star=1e99, p0=1e-100)


@pytest.mark.parametrize("value", [np.inf, -np.inf])
def test_infinite_height_is_masked_by_mask_outliers_and_refused_elsewhere(small_map, value):
    # An infinite height is an invalid point. mask_outliers, the step that turns invalid
    # points into NaN, masks it (and leaves it out of the robust statistics: the result
    # is exactly that of the map with the point already NaN); every other preprocessing
    # step refuses it with the message that points to mask_outliers.
    bad, missing = small_map.copy(), small_map.copy()
    bad.values[5, 7], missing.values[5, 7] = value, np.nan
    out = xrough.mask_outliers(bad)
    expected = xrough.mask_outliers(missing)
    np.testing.assert_array_equal(np.isnan(out.values), np.isnan(expected.values))
    assert out.attrs["outliers_masked"] == expected.attrs["outliers_masked"] + 1
    for call in (xrough.detrend, xrough.fit_trend, xrough.reliable,
                 lambda t: xrough.reliable(t, tip_radius="10 nm"),
                 lambda t: xrough.detrend(t.chunk(), per_line=True).compute()):
        with pytest.raises(ValueError, match="contain 1 infinite value.*mask_outliers"):
            call(bad)


def _scaled_acf(G, s):
    """G times s with its standard_error coordinate (scaling the values alone leaves it)."""
    return (G * s).assign_attrs(G.attrs).assign_coords(standard_error=G.standard_error * s)


@pytest.mark.slow  # 90-110 s a case in a timed run on two busy cores
@pytest.mark.filterwarnings("ignore::xrough.QualityWarning")  # H is loose on this small G
@pytest.mark.parametrize("k", [-520, 520])
def test_functions_of_G_are_invariant_under_its_scale(G, k):
    # G times 2**k (about 1e-157 and 1e156 of G's unit, where the old code overflowed in
    # squared weights): the rms height and gradient scale by 2**(k/2), the stress ACF by
    # 2**k, and Persson's a_r is unchanged when E* scales by 2**(-k/2). Fits iterate to
    # ftol 1e-12 from starts that depend on round-off; the measured deviations are below
    # 3e-9, hence rtol 1e-7.
    s = 2.0**k
    Gs = _scaled_acf(G, s)
    ref_fit, fit = xrough.fit_acf(G), xrough.fit_acf(Gs)
    np.testing.assert_allclose(float(fit.sigma_h), float(ref_fit.sigma_h) * s**0.5,
                               rtol=1e-7)
    np.testing.assert_allclose(xrough.rms_gradient(Gs).values,
                               xrough.rms_gradient(G).values * s**0.5, rtol=1e-7)
    np.testing.assert_allclose(xrough.stress_acf(Gs, E_star=1e6).values,
                               xrough.stress_acf(G, E_star=1e6).values * s, rtol=1e-7)
    a = xrough.persson(G, E_star=1e6, p0=1e5).a_r.values
    a_s = xrough.persson(Gs, E_star=1e6 / s**0.5, p0=1e5).a_r.values
    np.testing.assert_allclose(a_s, a, rtol=1e-7)


@pytest.mark.parametrize("s", [1e290, 1e-290])
@pytest.mark.parametrize("call", [
    xrough.fit_acf, xrough.rms_gradient,
    lambda G: xrough.stress_acf(G, E_star=1e6),
    lambda G: xrough.persson(G, E_star=1e6, p0=1e5),
])
def test_G_beyond_the_float64_range_of_its_functions_is_refused(G, s, call):
    # G of 1e294 nm2 made the fits fail inside scipy ("Residuals are not finite") and the
    # rms gradient come out 5.5 % low without a word; such a G is refused, naming it
    with pytest.raises(ValueError, match=r"G has values from .* beyond 1e-280 to 1e\+280"):
        call(_scaled_acf(G, s))


@pytest.mark.parametrize("s", [1e160, 1e-160])
@pytest.mark.parametrize("call", [
    xrough.fit_acf, xrough.rms_gradient,
    lambda G: xrough.stress_acf(G, E_star=1e6),
    lambda G: xrough.persson(G, E_star=1e6, p0=1e5),
    lambda G: xrough.fit_acf(G.chunk()).compute(),  # dask: checked in the fit itself
])
def test_G_scaled_without_its_standard_error_is_refused(G, s, call):
    # G * 1e160 keeps the standard_error coordinate as it was: a relative error of 1e-162
    # whose squared weights overflow. The old code raised "TypeError: 'NoneType' object
    # is not subscriptable" from the fit and returned an all-NaN stress ACF.
    with pytest.raises(ValueError, match="standard_error is .* times G .* not in one unit"):
        call((G * s).assign_attrs(G.attrs))


@pytest.mark.parametrize("kw", [{"rms_gradient": 1e200}, {"rms_gradient": 1e-200},
                                {"rms_height": 1e200}, {"rms_height": "1e-200 nm"},
                                {"C_r": 1e-300}])
def test_synthetic_amplitude_beyond_float64_is_refused(kw):
    # rms_gradient=1e200 raised OverflowError (its square); 1e-200 gave a flat map of zeros
    name = next(iter(kw))
    with pytest.raises(ValueError, match=name):
        xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="400 nm",
                                   size="10 um", n=64, seed=1, unit="nm", **kw)


@pytest.fixture(scope="module")
def model_C():
    return xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
                                 rms_gradient=0.1, unit="nm")


@pytest.mark.parametrize("change, message", [
    (lambda C: C * np.nan, "does not match its values"),
    (lambda C: -C, "does not match its values"),
    (lambda C: xr.DataArray(C.values, dims=C.dims, coords=C.coords),
     "no 'units' attribute"),
    (lambda C: C.assign_attrs(units="nm2"), "must be in length\\^4"),
])
def test_stress_acf_from_spectrum_reads_the_spectrum_values_and_units(model_C, change,
                                                                      message):
    # the old code read only the model in the attrs: NaN, negated or unit-less values
    # gave the same stress ACF as the model spectrum
    C = change(model_C)
    C.attrs.update({k: v for k, v in model_C.attrs.items() if k != "units"})
    with pytest.raises(ValueError, match=message):
        xrough.stress_acf_from_spectrum(C, [1.0], E_star="1 MPa")


def test_stress_acf_from_spectrum_follows_the_unit_of_C(model_C):
    # the same numbers labelled pm^4 instead of nm^4 are 1e-12 times the spectrum, hence
    # 1e-12 times the stress ACF (a linear functional of C); rtol 1e-12 is round-off of
    # the unit conversion
    pm = model_C.assign_attrs(units="pm4")
    ref = xrough.stress_acf_from_spectrum(model_C, [1.0, 100.0], E_star="1 MPa")
    out = xrough.stress_acf_from_spectrum(pm, [1.0, 100.0], E_star="1 MPa")
    np.testing.assert_allclose(out.values, ref.values * 1e-12, rtol=1e-12)


def test_a_falling_G_from_few_points_is_not_called_a_height_acf():
    """A 4 x 4 map's G (xrough's own estimate) that falls over its 4 bins: the message
    names too few points, not a height ACF given by mistake; the same values given
    without the estimator's attrs keep the height-ACF diagnosis."""
    h = np.array([[0.0, 1.0, 0.2, 0.9], [0.8, 0.1, 1.0, 0.0],
                  [0.1, 0.9, 0.0, 1.1], [1.0, 0.0, 0.9, 0.2]])
    G = xrough.topography(h, spacing=1.0, unit="nm").rough.acf()
    assert G.values[-1] < 0.9 * G.values[0]
    with pytest.raises(ValueError, match="from so few points"):
        xrough.fit_acf(G)
    given = xr.DataArray(G.values, dims="dr", coords={"dr": G.dr}, attrs={"units": "nm2"})
    with pytest.raises(ValueError, match="that is a height ACF"):
        xrough.fit_acf(given)
