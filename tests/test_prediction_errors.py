"""Error bars of the contact predictions: gbar_std, a_r_std, sigma_c_std and the model error.

Statistical tests use fixed seeds of periodic self-affine maps (256^2, one pixel 1 nm,
lambda_s = 4 px, rms gradient 0.1). With N seeds the ratio of the mean stated error to the
scatter has a noise of about 1/sqrt(2 (N - 1)): 13 % for 30, so 0.75-1.3 is two of those
each side; benchmarks/calibration_errors.py measures 0.83-1.03 over 100 seeds.
"""


import warnings

import numpy as np
import pytest

import xrough
from xrough._kernels import model_error as me
from xrough._kernels.contact import KAPPA_PERSSON
from xrough._kernels.model_error import FULL_CONTACT_P_STAR, P_STAR_RANGE, area_model_error
from xrough._kernels.uncertainty import relative_covariance
from xrough.acf import error_model

N, SEEDS = 256, 30
E_STAR, P0 = "25 MPa", "0.15 MPa"


def surface(seed, hurst=0.8, ratio=8.0, n=N, **kw):
    return xrough.self_affine_surface(hurst=hurst, lambda_r=n / ratio, lambda_s=4.0,
                                      size=float(n), n=n, rms_gradient=0.1, unit="nm",
                                      seed=seed, **kw)


@pytest.fixture(scope="module")
def seeds():
    """G, gbar and Persson theory of 30 seeds (H = 0.5, L = 2 lambda_r: the exact route
    covers the small lags, the fit the rest)."""
    out = []
    for seed in range(SEEDS):
        G = surface(seed, hurst=0.5, ratio=2.0).rough.acf()
        out.append((G, G.rough.gradient(), G.rough.persson(E_star=E_STAR, p0=P0)))
    return out


@pytest.mark.parametrize("lag", [1.0, 16.0])
def test_gbar_std_matches_the_scatter_over_seeds(seeds, lag):
    k = int(np.argmin(np.abs(np.log(seeds[0][0].dr.values / lag))))
    gbar = np.array([float(g[k]) for _, g, _ in seeds])
    std = np.array([float(g.gbar_std[k]) for _, g, _ in seeds])
    ratio = std.mean() / gbar.std(ddof=1)
    assert 0.75 < ratio < 1.3, ratio


@pytest.mark.parametrize("name", ["a_r", "sigma_c"])
def test_area_and_stress_std_match_the_scatter_over_seeds(seeds, name):
    k = 0  # one pixel
    x = np.array([float(p[name][k]) for _, _, p in seeds])
    std = np.array([float(p[f"{name}_std"][k]) for _, _, p in seeds])
    ratio = std.mean() / x.std(ddof=1)
    assert 0.75 < ratio < 1.3, ratio


@pytest.mark.parametrize("lag", [2.0, 4.0, 16.0])
def test_partial_contact_stress_acf_std_matches_the_scatter_over_seeds(seeds, lag):
    """Persson's G_sigma_std (the Laplacian's error and W's, through gbar) against the
    scatter of G_sigma over the 30 seeds: within 0.75-1.3 (1 px is NaN: G is rough there,
    lambda_s = 4 px, H 0.5)."""
    k = int(np.argmin(np.abs(np.log(seeds[0][0].dr.values / lag))))
    x = np.array([float(p.G_sigma[k]) for _, _, p in seeds])
    std = np.array([float(p.G_sigma_std[k]) for _, _, p in seeds])
    ratio = std.mean() / x.std(ddof=1)
    assert 0.75 < ratio < 1.3, ratio
    assert seeds[0][2].G_sigma_std.attrs["units"] == "Pa2"


def test_area_std_is_the_derivative_of_eq29_times_the_gradient_error(seeds):
    """Independent: d erf(c p*) / d ln p* = 2 c p* exp(-(c p*)^2) / sqrt(pi), c = kappa
    sqrt(pi) / 2; the relative error of p* is that of gbar."""
    _, g, p = seeds[0]
    c = KAPPA_PERSSON * np.sqrt(np.pi) / 2
    ps = p.p_star.values
    rel = (g.gbar_std / g).values
    expected = 2 * c * ps * np.exp(-(c * ps) ** 2) / np.sqrt(np.pi) * rel
    ok = np.isfinite(expected)
    np.testing.assert_allclose(p.a_r_std.values[ok], expected[ok], rtol=1e-5)
    np.testing.assert_allclose(p.sigma_c_std.values[ok],
                               (p.sigma_c * p.a_r_std / p.a_r).values[ok], rtol=1e-5)
    np.testing.assert_allclose(p.p_star_std.values[ok], (ps * rel)[ok], rtol=1e-5)


def test_ballistic_gradient_error_is_half_the_relative_error_of_g():
    G = surface(0).rough.acf()
    g = xrough.rms_gradient(G, method="simple")
    cov = relative_covariance(G.dr.values, G.values, **error_model(G))
    np.testing.assert_allclose(g.gbar_std.values, 0.5 * np.sqrt(np.diag(cov)) * g.values,
                               rtol=1e-12)


def test_gbar_std_is_the_same_in_every_unit_and_for_dask():
    topo = surface(3)
    G = topo.rough.acf()
    g = G.rough.gradient()
    in_um = xrough.convert_units(topo, "um").rough.acf().rough.gradient()
    np.testing.assert_allclose(in_um.gbar_std.values, g.gbar_std.values, rtol=1e-6)
    stack = G.expand_dims(scan=2).chunk({"scan": 1})
    lazy = xrough.rms_gradient(stack)
    assert lazy.chunks is not None
    np.testing.assert_allclose(lazy.gbar_std.isel(scan=1).values, g.gbar_std.values,
                               rtol=1e-12)
    p = G.rough.persson(E_star=E_STAR, p0=P0)
    lazy_p = stack.rough.persson(E_star=E_STAR, p0=P0).compute()
    for name in ("a_r_std", "sigma_c_std", "a_r_model_error", "a_r_exact",
                 "sigma_c_exact_upper"):
        np.testing.assert_allclose(lazy_p[name].isel(scan=0).values, p[name].values,
                                   rtol=1e-12)


def test_no_map_geometry_no_statistical_error():
    C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
                              rms_gradient=0.5, unit="nm")
    G = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="10 um")
    g = G.rough.gradient()
    assert np.all(np.isnan(g.gbar_std.values))
    assert g.gbar_std.attrs["error_of"].startswith("none")
    p = G.rough.persson(E_star=E_STAR, p0=P0)
    assert np.all(np.isnan(p.a_r_std.values))
    assert p.a_r_std.attrs["error_of"].startswith("none")
    assert np.isfinite(p.a_r_model_error.values).any()  # the theory's error stays


@pytest.mark.parametrize("name", ["persson_area_error.csv", "persson_stress_error.csv.gz",
                                  "gap_error.csv"])
def test_study_tables_read_as_python_parses_each_field(name):
    """Every field of the shipped tables, against Python's own ``float`` of its text.

    The columns whose first value is a number hold floats equal to the last bit (``nan``
    where the table says so), the others the text itself; comment lines are skipped.
    """
    import gzip
    from importlib import resources

    data = resources.files("xrough").joinpath(f"data/{name}").read_bytes()
    text = (gzip.decompress(data) if name.endswith(".gz") else data).decode()
    lines = [line for line in text.splitlines() if line and not line.startswith("#")]
    names, rows = lines[0].split(","), [line.split(",") for line in lines[1:]]
    got = me.read_table(name)
    assert list(got) == names
    for j, col in enumerate(names):
        fields = [r[j] for r in rows]
        try:
            want = np.array([float(f) for f in fields])
        except ValueError:
            assert got[col].tolist() == fields, col
        else:
            assert got[col].dtype == float
            np.testing.assert_array_equal(got[col], want, err_msg=col)


# ------------------------------------------------------------------- the model error
def test_held_out_residuals_are_those_of_fits_without_the_group():
    """The closed form (I - H_gg)^-1 r_g against refitting without each group."""
    rng = np.random.default_rng(0)
    X = np.column_stack([np.ones(60), rng.normal(size=(60, 3))])
    y = X @ [1.0, 0.5, -0.2, 0.1] + rng.normal(scale=0.1, size=60)
    groups = np.repeat(np.arange(12), 5)
    got = me.held_out_residuals(X, y, groups)
    for g in range(12):
        out = groups == g
        b = np.linalg.lstsq(X[~out], y[~out], rcond=None)[0]
        np.testing.assert_allclose(got[out], y[out] - X[out] @ b, rtol=1e-10, atol=1e-12)


def test_features_read_the_local_exponent_of_G():
    """A power law dr^(2H) gives H at every lag; a plateau reached by dr gives 0 there;
    range is ln sqrt(G_max / G(dr)) (closed forms)."""
    dr = np.geomspace(1.0, 1e4, 60)
    f = me.features_on_lags(dr, dr**1.3)
    inside = dr <= 1e4 / 8
    np.testing.assert_allclose(f[:2, inside], 0.65, rtol=1e-12)
    assert np.all(np.isnan(f[1, ~inside]))
    np.testing.assert_allclose(f[2], 0.5 * np.log(1e4**1.3 / dr**1.3), rtol=1e-12, atol=1e-12)
    flat = me.features_on_lags(dr, np.minimum(dr, 10.0) ** 2)
    plateau = flat[:2, dr >= 10]
    assert np.allclose(plateau[np.isfinite(plateau)], 0.0) and np.isfinite(plateau).sum() > 40
    assert np.allclose(flat[0, dr <= 4], 1.0)  # to 2 dr below the kink
    assert np.all(np.isnan(me.features_on_lags(dr, np.full(dr.size, np.nan))))
    assert me.features_of(dr, dr**1.3, 3.0)["h_local"] == pytest.approx(0.65, rel=1e-12)


def _inside(h_local=0.7, h_wide=0.55, rng=1.5):
    return h_local, h_wide, rng


def test_model_error_domain_and_full_contact():
    """NaN below p* = 1e-4 and where G's shape lies outside the study's; beyond p* = 0.5
    falling linearly in ln p* to zero at FULL_CONTACT_P_STAR (a_r = 0.999), no error left
    in full contact; an unknown area or a missing feature is refused."""
    lo, hi = P_STAR_RANGE
    p = np.array([lo / 2, lo, 0.01, hi, np.sqrt(hi * FULL_CONTACT_P_STAR),
                  FULL_CONTACT_P_STAR, 10.0, np.nan])
    bias, spread = area_model_error(p, *_inside(), periodic=True)
    assert np.isnan(bias[0]) and np.isnan(bias[-1]) and np.isnan(spread[0])
    assert np.all(bias[1:3] < 0) and np.all(spread[1:4] > 0)
    assert bias[4] == pytest.approx(bias[3] / 2, rel=1e-9)  # halfway in ln p*
    assert bias[5] == bias[6] == 0 and spread[5] == spread[6] == 0
    bounds = me._model("a_r").bounds
    for k, name in enumerate(me.FEATURES):
        outside = list(_inside())
        outside[k] = bounds[name][1] + 0.2 * (bounds[name][1] - bounds[name][0])
        assert np.isnan(area_model_error(0.01, *outside)[0]), name
        assert me.outside_domain(0.01, *outside) == 2
    assert me.outside_domain(lo / 2, *_inside()) == 1
    with pytest.raises(ValueError, match="area"):
        area_model_error(0.1, *_inside(), area="a_x")
    with pytest.raises(ValueError, match="features"):
        area_model_error(0.1, 0.7)


def test_model_error_reproduces_the_study_it_was_built_from():
    """On the study's own rows, the expected exact area is within 2 spreads of the
    solver's in at least 90 % (the spread is calibrated to the residuals of surfaces left
    out of the fit, so in-sample they sit inside it), and the bias has the sign of the
    solver's: Persson's area is low wherever the solver's is more than 10 % higher."""
    t = me.area_table()
    use = me.used_rows(t)
    for area in ("a_r", "a_ri"):
        bias, spread = area_model_error(t["p_star"][use], *(t[f][use] for f in me.FEATURES),
                                        periodic=t["open"][use] == 0, area=area)
        y = np.log(t[area][use] / t["contact_area"][use])
        z = (y - bias) / spread
        assert np.mean(np.abs(z) <= 2) >= 0.9, area
        assert np.all(bias[y < np.log(1 / 1.1)] < 0), area


def test_persson_gives_the_expected_exact_values():
    """a_r_exact = a_r exp(-bias) with the bias at each lag's p* and G's features there;
    sigma_c_exact = p0 / a_r_exact; the bounds exp(-bias -+ spread) around it; the model
    error is a_r - a_r_exact; no model error for another kappa (the study is Persson's)."""
    G = surface(1, hurst=0.7, ratio=4.0).rough.acf()
    p = G.rough.persson(E_star=E_STAR, p0=P0)
    f = me.features_on_lags(G.dr.values, G.values)
    bias, spread = area_model_error(p.p_star.values, *f, periodic=True)
    ok = np.isfinite(p.a_r.values) & np.isfinite(bias)
    assert ok[0], "the finest lag of this surface lies inside the study"
    a = p.a_r.values[ok]
    np.testing.assert_allclose(p.a_r_exact.values[ok], a * np.exp(-bias[ok]), rtol=1e-12)
    np.testing.assert_allclose(p.a_r_exact_lower.values[ok], a * np.exp(-bias - spread)[ok],
                               rtol=1e-12)
    np.testing.assert_allclose(p.a_r_exact_upper.values[ok], a * np.exp(-bias + spread)[ok],
                               rtol=1e-12)
    np.testing.assert_allclose(p.a_r_model_error.values[ok], a - p.a_r_exact.values[ok],
                               rtol=1e-12)
    np.testing.assert_allclose(p.sigma_c_exact.values[ok], P0_PA / p.a_r_exact.values[ok],
                               rtol=1e-12)
    np.testing.assert_allclose(p.sigma_c_exact_lower.values[ok],
                               P0_PA / p.a_r_exact_upper.values[ok], rtol=1e-12)
    assert np.all(p.a_r_model_error.values[ok] < 0)  # Persson's area is low
    assert np.all(np.isnan(p.a_r_exact.values[np.isfinite(p.a_r.values) & np.isnan(bias)]))
    assert "boundary-element study" in p.a_r_exact.attrs["error_of"]
    other = G.rough.persson(E_star=E_STAR, p0=P0, kappa=2.0)
    for name in ("a_r_model_error", "a_r_exact", "a_r_exact_lower", "sigma_c_exact"):
        assert np.all(np.isnan(other[name].values)), name
    assert "kappa" in other.a_r_exact.attrs["error_of"]


P0_PA = 0.15e6


def test_model_error_holds_on_a_held_out_solver_run():
    """A surface outside the study (H = 0.65, 256^2, lambda_r / lambda_s = 16 at
    lambda_s = 4 px, a seed the study never drew): the solver's contact area lies within
    two spreads of the expected exact one at p* = 0.01 and 0.1, where Persson's own area
    misses it by more than 25 % and 15 % (benchmarks/model_error_heldout.py checks 100 such
    cases: docs/quality.md).  The map's 1.2 decades of self-affine range cannot tell H
    from the shape of its cutoff (sharp or Gaussian): the result says so, questionable."""
    topo = xrough.self_affine_surface(hurst=0.65, lambda_r=64.0, lambda_s=4.0, size=256.0,
                                      n=256, rms_gradient=0.1, unit="nm", seed=7)
    G = topo.rough.acf()
    loads = np.array([0.01, 0.1])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        unit = G.rough.persson(E_star=1e6, p0=1.0, variables=("p_star",)).p_star.values[0]
        theory = G.rough.persson(E_star=1e6, p0=loads / unit).isel(dr=0)
        assert "shape of the cutoff" in G.rough.fit().attrs["quality_notes"]
    sim = xrough.solve_contact(topo, E_star=1e6, p0=loads / unit, progress=False)
    exact = sim.contact_area.values
    for name in ("a_r", "a_ri"):
        expected = theory[f"{name}_exact"].values
        lo, hi = theory[f"{name}_exact_lower"].values, theory[f"{name}_exact_upper"].values
        z = np.log(exact / expected) / (0.5 * np.log(hi / lo))
        assert np.all(np.abs(z) < 2), (name, exact, expected, lo, hi)
    assert np.all(theory.a_r.values / exact - 1 < [-0.25, -0.15])


def test_stress_model_error_reproduces_the_study_it_was_built_from():
    """In-sample, the solver's fluctuating stress ACF lies within 2 spreads of the
    expected exact one in at least 90 % of the study's rows that the model covers."""
    t = me.stress_table()
    bias, spread = me.stress_model_error(t["p_star"], t["p_star_0"], t["decay"],
                                         *(t[f] for f in me.FEATURES),
                                         periodic=t["open"] == 0)
    ok = np.isfinite(bias) & np.isfinite(t["ln_ratio"]) & (spread > 0)  # 0: full contact
    assert ok.sum() > 30000
    z = (t["ln_ratio"][ok] - bias[ok]) / spread[ok]
    assert np.mean(np.abs(z) <= 2) >= 0.9


def test_persson_gives_the_expected_exact_stress_acf():
    """G_sigma_exact = p0^2 + F exp(-bias) with F = G_sigma - p0^2 and the bias at each
    lag's p*, the finest lag's p*, F's decay and G's features; the bounds exp(-bias -+
    spread); none for the modified theory (the study is of W = a_r)."""
    G = surface(1, hurst=0.7, ratio=4.0).rough.acf()
    p = G.rough.persson(E_star=E_STAR, p0=P0)
    F = p.G_sigma.values - P0_PA**2
    first = F[np.flatnonzero(np.isfinite(F))[0]]
    ps = p.p_star.values
    f = me.features_on_lags(G.dr.values, G.values)
    bias, spread = me.stress_model_error(ps, ps[np.isfinite(ps)][0], F / first, *f,
                                         periodic=True)
    ok = np.isfinite(F) & np.isfinite(bias)
    assert ok.sum() >= 5
    np.testing.assert_allclose(p.G_sigma_exact.values[ok],
                               P0_PA**2 + F[ok] * np.exp(-bias[ok]), rtol=1e-12)
    np.testing.assert_allclose(p.G_sigma_exact_lower.values[ok],
                               P0_PA**2 + F[ok] * np.exp(-bias - spread)[ok], rtol=1e-12)
    np.testing.assert_allclose(p.G_sigma_model_error.values[ok],
                               p.G_sigma.values[ok] - p.G_sigma_exact.values[ok], rtol=1e-9)
    assert np.all(np.isnan(p.G_sigma_exact.values[np.isfinite(F) & np.isnan(bias)]))
    assert p.G_sigma_exact.attrs["units"] == "Pa2"
    modified = G.rough.persson(E_star=E_STAR, p0=P0, theory="modified")
    assert np.all(np.isnan(modified.G_sigma_exact.values))
    assert modified.G_sigma_exact.attrs["error_of"].startswith("none")


def test_stress_model_error_holds_on_a_held_out_solver_run():
    """The surface of the area's held-out test (H = 0.65, not in the study): the solver's
    stress ACF (ring average of <p p'>, binned as G) lies within two spreads of the
    expected exact one at 9 of 10 lags or more where the model has a value, at p* = 0.01
    and 0.1 (benchmarks/model_error_heldout.py checks 800 such lags: docs/quality.md)."""
    topo = xrough.self_affine_surface(hurst=0.65, lambda_r=64.0, lambda_s=4.0, size=256.0,
                                      n=256, rms_gradient=0.1, unit="nm", seed=7)
    G = topo.rough.acf()
    with warnings.catch_warnings():  # H and the cutoff's shape: see the area's test
        warnings.simplefilter("ignore", xrough.QualityWarning)
        unit = G.rough.persson(E_star=1e6, p0=1.0, variables=("p_star",)).p_star.values[0]
        p0 = np.array([0.01, 0.1]) / unit
        theory = G.rough.persson(E_star=1e6, p0=p0)
    sim = xrough.solve_contact(topo, E_star=1e6, p0=p0, progress=False)
    for i in range(2):
        field = sim.pressure.values[i]
        as_map = xrough.topography(field, spacing=1.0, unit="nm", periodic=True)
        with warnings.catch_warnings():  # a stress field is no stationary Gaussian surface
            warnings.simplefilter("ignore", xrough.QualityWarning)
            exact = np.mean(field**2) - as_map.rough.acf().values - p0[i] ** 2
        t = theory.isel(p0=i)
        F = t.G_sigma.values - p0[i] ** 2
        ok = np.isfinite(t.G_sigma_exact.values) & (exact > 0)
        assert ok.sum() >= 5
        expected = t.G_sigma_exact.values[ok] - p0[i] ** 2
        half = 0.5 * np.log((t.G_sigma_exact_upper.values[ok] - p0[i] ** 2)
                            / (t.G_sigma_exact_lower.values[ok] - p0[i] ** 2))
        z = np.log(exact[ok] / expected) / half
        assert np.mean(np.abs(z) < 2) >= 0.9, z
        # and the correction does not make it worse than the theory on the whole
        assert (np.median(np.abs(np.log(expected / exact[ok])))
                <= np.median(np.abs(np.log(F[ok] / exact[ok]))) + 0.02)


@pytest.mark.parametrize("height, lateral", [("m", "m"), ("um", "nm"), ("nm", "um")])
def test_persson_errors_are_the_same_in_every_unit(height, lateral):
    """The same map in m, and with heights and lags in different units: a_r, its
    statistical and model errors are numbers, sigma_c and its errors are pressures (the
    same in Pa); E* and p0 given as strings in other units too. Values to 1e-6; the
    statistical errors to 1e-5 (the response of gbar to one-sigma steps of G along its
    covariance's principal axes, through the smoothing and the isotonic projection: unit
    factors move its last digits, measured 1.3e-6)."""
    topo = surface(5)
    base = topo.rough.acf().rough.persson(E_star=E_STAR, p0=P0)
    other = xrough.convert_units(topo, height, lateral=lateral)
    got = other.rough.acf().rough.persson(E_star="25e6 Pa", p0="150 kPa")
    for name in ("a_r", "a_r_std", "a_r_model_error", "a_r_exact", "a_r_exact_lower",
                 "G_sigma_std", "G_sigma_exact", "G_sigma_exact_lower",
                 "sigma_c", "sigma_c_std", "sigma_c_model_error", "sigma_c_exact_upper",
                 "p_star_std"):
        assert got[name].attrs.get("units") == base[name].attrs.get("units"), name
        # an error near full contact (1e-9 of the largest) is zero to this tolerance: it
        # differed by 4 % on the oldest supported versions
        scale = 1e-6 * np.nanmax(np.abs(base[name].values))
        np.testing.assert_allclose(got[name].values, base[name].values,
                                   rtol=1e-5 if name.endswith("_std") else 1e-6,
                                   atol=scale if name.endswith("_std") else 0,
                                   err_msg=name)
    f = xrough.units.conversion_factor("nm", lateral)
    np.testing.assert_allclose(got.dr.values, base.dr.values * f, rtol=1e-12)


# ------------------------------------------------------------------ the even start of gbar
def test_even_start_of_a_smooth_g_in_closed_form():
    """G = a r^2 + b r^4 (a smooth surface's expansion): sqrt(4 a) exactly, raised by the
    correction for the next term, which a surface's spectrum always has (0.5 ratio^2, and
    half of it as its uncertainty); weight 1 where |b| r^2 / a <= EVEN_START[0] and 0
    from EVEN_START[1] (linear between), on the first two bins only; no even start where
    b > 0 or a <= 0, which no surface's G has; d ln a / d ln G from the two-point solve,
    against finite differences."""
    from xrough._kernels.gradient import (
        EVEN_SERIES_CORRECTION,
        EVEN_START,
        even_start,
        with_even_start,
    )

    dr = np.array([1.0, np.sqrt(2.0), 2.0, 3.0])
    a = 0.25
    for ratio in (0.0, 0.02, EVEN_START[0], 0.17, EVEN_START[1], 0.3):
        b = -ratio * a  # |b| r0^2 / a = ratio at r0 = 1
        full, weight, d_ln_a, sys = even_start(dr, a * dr**2 + b * dr**4)
        correction = EVEN_SERIES_CORRECTION * ratio**2
        assert full == pytest.approx(1.0 + correction, rel=1e-12)
        assert sys == pytest.approx(0.5 * correction, abs=1e-15)
        expected = np.clip((EVEN_START[1] - ratio * dr[:2] ** 2)
                           / (EVEN_START[1] - EVEN_START[0]), 0, 1)
        np.testing.assert_allclose(weight, np.r_[expected, 0, 0], atol=1e-12)
        g = a * dr**2 + b * dr**4
        for i in (0, 1) if ratio > 0.01 else ():  # b = 0 moves to b > 0
            step = g.copy()
            step[i] *= np.exp(1e-7)
            moved, _, _, sys1 = even_start(dr, step)
            a1 = (moved / (1.0 + 2.0 * sys1)) ** 2 / 4  # a itself, without the correction
            assert d_ln_a[i] == pytest.approx(np.log(a1 / a) / 1e-7, rel=1e-5)
    assert np.isnan(even_start(dr, 0.25 * dr**2 + 0.01 * dr**4)[0])  # b > 0
    assert np.isnan(even_start(dr, np.array([1.0, 5.0, 6.0, 7.0]))[0])  # a < 0
    # the same in any unit (lags in m, G in m^2; a km-sized lag with G in km^2)
    g = a * dr**2 - 0.04 * a * dr**4 + 1e-4 * a * dr**6
    ref = even_start(dr, g)
    for scale in (1e-9, 1e3):
        other = even_start(dr * scale, g * scale**2)
        assert other[0] == pytest.approx(ref[0], rel=1e-12)
        np.testing.assert_allclose(other[1], ref[1], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(other[2], ref[2], rtol=1e-9, atol=1e-12)
    # the route's values: moved at the first lags, capped at the full gradient beyond
    g = a * dr**2 - 0.01 * a * dr**4
    full = 1.0 + EVEN_SERIES_CORRECTION * 0.01**2
    out = with_even_start(np.array([1.02, 1.01, 1.005, 0.9]), dr, g)
    np.testing.assert_allclose(out, [full, full, full, 0.9], rtol=1e-12)


@pytest.mark.parametrize("lambda_s", [4.0, 8.0])
def test_gbar_at_one_pixel_below_a_sharp_cutoff_is_the_lattice_value(lambda_s):
    """The exact expected G of a map smooth at its pixel (fixed amplitudes, lambda_s = 4
    and 8 px, L = 2 lambda_r): gbar at one pixel within 0.1 % of the lattice's own rms
    gradient (measured -0.01 % and +0.03 %; the spectrum of G gave +0.96 % and +0.47 %),
    and its stated error is that of sqrt(4 a) from the first bins (their covariance;
    two terms through two bins at 8 px, where the ratio |b| / a is 0.01, three through
    three at 4 px, 0.05) and of the correction for the next term (0.25 ratio^2)."""
    topo = surface(0, hurst=0.5, ratio=2.0, random_amplitudes=False).pipe(
        lambda t: t) if lambda_s == 4.0 else xrough.self_affine_surface(
        hurst=0.5, lambda_r=N / 2, lambda_s=lambda_s, size=float(N), n=N,
        rms_gradient=0.1, unit="nm", seed=0, random_amplitudes=False)
    h = topo.values
    power = np.abs(np.fft.fft2(h) / h.size) ** 2
    q1 = 2 * np.pi * np.fft.fftfreq(N)
    truth = np.sqrt(((q1[:, None] ** 2 + q1[None, :] ** 2) * power).sum())  # all modes
    G = topo.rough.acf()
    g = G.rough.gradient()
    assert float(g[0]) == pytest.approx(truth, rel=1e-3)
    cov = relative_covariance(G.dr.values, G.values, **error_model(G))
    r, v = G.dr.values[:3], G.values[:3]
    two = np.linalg.inv(np.c_[r[:2] ** 2, r[:2] ** 4])  # a r^2 + b r^4
    a2, b2 = two @ v[:2]
    three = np.clip((abs(b2) / a2 - 0.02) / 0.01, 0, 1)  # ratio at r = 1 px
    row = ((1 - three) * np.r_[two[0], 0.0]
           + three * np.linalg.inv(np.c_[r**2, r**4, r**6])[0])  # ... + c r^6
    d = row * v / (row @ v)
    own = np.hypot(0.5 * np.sqrt(d @ cov[:3, :3] @ d), 0.25 * (abs(b2) / a2) ** 2)
    assert float(g.gbar_std[0] / g[0]) == pytest.approx(own, rel=1e-9)


def _cut_map(hurst, cutoff, lambda_s, n=512, seed=1):
    """A periodic map whose short cutoff is sharp, smooth ([1 + (q/q_s)^2]^-2) or Gaussian
    (exp(-(q/q_s)^2), an instrument's transfer), as in benchmarks/model_error_study.py."""
    base = lambda_s if cutoff == "sharp" else 2.0
    t = xrough.self_affine_surface(hurst=hurst, lambda_r=n / 4, lambda_s=base, size=float(n),
                                   n=n, rms_gradient=0.1, seed=seed, unit="nm")
    h = t.transpose("y", "x").values
    if cutoff != "sharp":
        q = 2 * np.pi * np.fft.fftfreq(n)
        u = np.hypot(q[:, None], q[None, :]) * lambda_s / (2 * np.pi)
        gain = np.exp(-u**2) if cutoff == "gaussian" else (1 + u**2) ** -2.0
        h = np.fft.ifft2(np.fft.fft2(h) * np.sqrt(gain)).real
    return xrough.topography(h, spacing=1.0, unit="nm", periodic=True)


@pytest.mark.parametrize("hurst, cutoff, lambda_s", [
    (0.3, "gaussian", 4), (0.3, "smooth", 3), (0.5, "gaussian", 2), (0.1, "gaussian", 3),
    (0.5, "sharp", 2), (0.1, "sharp", 2), (0.8, "smooth", 2)])
def test_gbar_at_one_pixel_below_an_instruments_cutoff(hurst, cutoff, lambda_s):
    """gbar at one pixel against the map's own spectral gradient (all its modes), below
    sharp, smooth and Gaussian short cutoffs: within 0.5 % or one stated error. The
    fitted spectrum (a sharp cutoff) was 0.9-2.1 % low below smooth and Gaussian ones (z
    -1.2 to -1.7); the even start with the next term's correction is within 0.4 % here
    (measured; 0.85 % at H 0.1 and 2 px, where its ratio passes 0.15: not tested)."""
    topo = _cut_map(hurst, cutoff, lambda_s)
    n = topo.sizes["x"]
    q = 2 * np.pi * np.fft.fftfreq(n)
    power = np.abs(np.fft.fft2(topo.values) / topo.size) ** 2
    truth = np.sqrt(((q[:, None] ** 2 + q[None, :] ** 2) * power).sum())
    g = topo.rough.acf().rough.gradient()
    bias = float(g[0]) - truth
    assert abs(bias) < 0.005 * truth or abs(bias) < float(g.gbar_std[0]), (
        bias / truth, bias / float(g.gbar_std[0]))


def test_a_fitted_gradient_does_not_exceed_the_full_gradient_of_a_smooth_start():
    """xy-1 (a profile smooth at its pixel: G's log-log slope 1.82 over its first two
    bins): the fit, which misses G (questionable), put gbar at 1.25 at the first lag
    where G's ballistic start gives 0.59; gbar is now at most the full gradient
    sqrt(4 a) at every lag, and within 5 % of the ballistic sqrt(4 G) / dr at the first."""
    from conftest import DATA

    path = DATA / "instruments" / "xy-1.txt"
    if not path.exists():
        pytest.skip(f"{path} not present")
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        G = xrough.open_topography(path, unit="um", resample=True).rough.detrend().rough.acf()
        g = G.rough.gradient()
        simple = G.rough.gradient(method="simple")
    from xrough._kernels.gradient import even_start

    full = even_start(G.dr.values, G.values)[0]
    assert np.all(g.values[np.isfinite(g.values)] <= full * (1 + 1e-12))
    assert float(g[0]) == pytest.approx(float(simple[0]), rel=0.05)


# ------------------------------------------------- where the fitted model gives gbar
@pytest.fixture(scope="module")
def rough_seeds():
    """gbar of 30 seeds of maps rough to the pixel (lambda_s = 2 px, H = 0.5, L = 8
    lambda_r): eq. 26 of G's spectrum does not reach its first lags; at one pixel the
    even start gives gbar (ratio |b| / a about 0.13), beyond it the fitted spectrum.

    Its error was the exact route's response to G's, a third of the scatter (z sd 3.2
    over 100 seeds, benchmarks/calibration_errors.py --lambda-s 2): the fit adds the
    jitter of its cutoffs."""
    out = []
    for seed in range(SEEDS):
        topo = xrough.self_affine_surface(hurst=0.5, lambda_r=N / 8, lambda_s=2.0,
                                          size=float(N), n=N, rms_gradient=0.1, unit="nm",
                                          seed=seed)
        G = topo.rough.acf()
        out.append((G, G.rough.fit(), G.rough.gradient()))
    return out


def test_fitted_gbar_std_matches_the_scatter_over_seeds(rough_seeds):
    gbar = np.array([float(g[0]) for _, _, g in rough_seeds])
    std = np.array([float(g.gbar_std[0]) for _, _, g in rough_seeds])
    routes = {int(g.gradient_method) for _, _, g in rough_seeds}
    assert routes <= {1, 3}  # the fit gives gbar at one pixel on every seed
    ratio = std.mean() / gbar.std(ddof=1)
    assert 0.75 < ratio < 1.3, ratio


def test_gbar_std_where_the_fit_gives_gbar_is_the_fits(rough_seeds):
    """auto (the fit on the lags the exact route leaves open), 'fit' and
    gradient_from_fit state one error for the fitted spectrum's gbar."""
    G, fit, g = rough_seeds[0]
    from_fit = xrough.gradient_from_fit(fit, G.dr.values[1:])
    by_fit = xrough.rms_gradient(G, method="fit", fit=fit)
    np.testing.assert_allclose(by_fit.gbar_std.values[1:], from_fit.gbar_std.values,
                               rtol=1e-12)
    # at the second lag (1.4 px: the even start's weight is 0 there) the fit's gbar
    assert abs(float(g[1]) / float(from_fit[0]) - 1) < 1e-12
    np.testing.assert_allclose(float(g.gbar_std[1]), float(from_fit.gbar_std[0]),
                               rtol=1e-12)
    assert "parameter_covariance" in by_fit.gbar_std.attrs["error_of"]


def test_fit_covariance_holds_the_parameters_errors(rough_seeds):
    """Independent: the standard deviations of H, G_sa and lambda_r from the covariance of
    (ln G_sa, H, eta = (dr_ref / lambda_r)^(2 - 2H), eps), through ln lambda_r = ln dr_ref
    - ln(eta) / (2 - 2H)."""
    _, fit, _ = rough_seeds[0]
    cov = fit.parameter_covariance
    assert cov.dims == ("cov_i", "cov_j") and list(cov.cov_i.values) == [
        "ln_G_sa", "hurst", "eta", "eps"]
    np.testing.assert_allclose(cov.values, cov.values.T, rtol=1e-12)
    C = cov.values
    assert float(fit.hurst_std) == pytest.approx(np.sqrt(C[1, 1]), rel=1e-12)
    assert float(fit.G_sa_std / fit.G_sa) == pytest.approx(np.sqrt(C[0, 0]), rel=1e-6)
    H, lr, dr_ref = float(fit.hurst), float(fit.lambda_r), float(fit.dr_ref)
    eta = (dr_ref / lr) ** (2 - 2 * H)
    grad = np.array([0.0, -2 * np.log(eta) / (2 - 2 * H) ** 2, -1 / ((2 - 2 * H) * eta), 0])
    assert float(fit.lambda_r_std / fit.lambda_r) == pytest.approx(
        np.sqrt(grad @ C @ grad), rel=1e-3)


def test_fitted_gradient_std_is_the_spread_of_draws_of_the_parameters():
    """Independent: draws of the parameters from a small covariance (the linear regime)
    give the spread of ln gbar that the linearisation states, to the draws' noise
    (20000 draws: 1 %; tolerance 4 %). A cutoff at none is one-sided: the change of gbar
    within one standard deviation of it."""
    from xrough._kernels.fitting import fitted_spectrum_gradient, fitted_spectrum_gradient_std
    H, G_sa, lr, ls, dr_ref = 0.7, 2.0, 300.0, 3.0, 10.0
    dr = np.array([0.5, 1.0, 2.0, 10.0, 100.0])
    kw = dict(dr=dr, dr_ref=dr_ref, lam_0=np.inf, g_factor=1.0)
    sd = np.array([0.02, 0.01, 0.05 * (dr_ref / lr) ** (2 - 2 * H),
                   0.05 * (ls / dr_ref) ** (2 * H)])
    corr = np.array([[1, 0.9, 0.3, -0.5], [0.9, 1, 0.2, -0.4], [0.3, 0.2, 1, 0.1],
                     [-0.5, -0.4, 0.1, 1]])
    cov = corr * np.outer(sd, sd)
    rel = fitted_spectrum_gradient_std(H, G_sa, lr, ls, 1, 1, 0, cov, **kw)
    rng = np.random.default_rng(1)
    p = rng.multivariate_normal([0.0, H, (dr_ref / lr) ** (2 - 2 * H),
                                 (ls / dr_ref) ** (2 * H)], cov, size=20000)
    drawn = np.array([np.log(fitted_spectrum_gradient(
        h, G_sa * np.exp(a), dr_ref * e ** (-1 / (2 - 2 * h)), dr_ref * s ** (1 / (2 * h)),
        1, 1, 0, **kw)) for a, h, e, s in p])
    np.testing.assert_allclose(rel, drawn.std(axis=0), rtol=0.04)
    # no short cutoff (eps = 0) with a variance: one standard deviation of it
    cov0 = np.zeros((4, 4))
    cov0[3, 3] = 0.3**2
    rel0 = fitted_spectrum_gradient_std(H, G_sa, lr, 0.0, 1, 0, 0, cov0, **kw)
    ls_one_sd = dr_ref * 0.3 ** (1 / (2 * H))
    step = np.log(fitted_spectrum_gradient(H, G_sa, lr, ls_one_sd, 1, 1, 0, **kw)
                  / fitted_spectrum_gradient(H, G_sa, lr, 0.0, 1, 0, 0, **kw))
    np.testing.assert_allclose(rel0, np.abs(step), rtol=1e-12)  # J sd = the step
    assert rel0[-1] == 0.0 and rel0[0] > 0.01  # only lags the cutoff reaches move


def test_fitted_gbar_std_is_the_same_in_every_unit_and_for_dask(rough_seeds):
    G, _, g = rough_seeds[1]
    in_um = xrough.convert_units(
        xrough.self_affine_surface(hurst=0.5, lambda_r=N / 8, lambda_s=2.0, size=float(N),
                                   n=N, rms_gradient=0.1, unit="nm", seed=1), "um"
    ).rough.acf().rough.gradient()
    np.testing.assert_allclose(in_um.gbar_std.values, g.gbar_std.values, rtol=1e-6)
    lazy = xrough.rms_gradient(G.expand_dims(scan=2).chunk({"scan": 1}))
    assert lazy.chunks is not None
    np.testing.assert_allclose(lazy.gbar_std.isel(scan=1).values, g.gbar_std.values,
                               rtol=1e-12)


def test_no_fit_loses_a_cutoff_it_needs(rough_seeds):
    """No fit of the 30 seeds sits in a local minimum: a search that dropped a cutoff its
    refit needed (chi^2 up by more than 4) restarts from the grid. Seed 7, with G's
    errors 0.3 % different (another interpolation of G's spectrum), lost lambda_s from
    eq. 36's start, and its H went to 0.69 (0.83 with the other roll-off) at a reduced
    chi^2 of 3.5, where the grid finds H 0.53 at 0.097."""
    hurst = np.array([float(fit.hurst) for _, fit, _ in rough_seeds])
    chi2 = np.array([float(fit.reduced_chi2) for _, fit, _ in rough_seeds])
    assert np.all(np.abs(hurst - 0.5) < 0.1), hurst
    assert np.all(chi2 < 1.0), chi2


@pytest.mark.parametrize("edit", ["drop_row", "rename_dim", "scalar"])
def test_an_edited_parameter_covariance_is_named_in_a_clear_error(rough_seeds, edit):
    """A fit whose ``parameter_covariance`` a user has cut, renamed or replaced fails at
    once with a message naming the variable and the shape it needs, not inside
    ``apply_ufunc``; dropping the variable leaves a fitted gradient without its error."""
    _, fit, _ = rough_seeds[0]
    cov = fit.parameter_covariance
    bad = {"drop_row": cov.isel(cov_i=slice(0, 3)),
           "rename_dim": cov.rename(cov_j="k"),
           "scalar": cov.isel(cov_i=0, cov_j=0)}[edit]
    edited = fit.drop_vars(["parameter_covariance", "cov_i", "cov_j"]).assign(
        parameter_covariance=bad)
    with pytest.raises(ValueError, match=r"parameter_covariance.*dims \('cov_i', 'cov_j'\)"):
        xrough.gradient_from_fit(edited, [1.0, 10.0])
    g = xrough.gradient_from_fit(fit.drop_vars("parameter_covariance"), [1.0, 10.0])
    assert np.all(np.isfinite(g)) and "gbar_std" not in g.coords


def test_no_expected_exact_value_for_a_map_unlike_the_study():
    """G whose regions or directions disagree (a real map with a band, a scratch, a scan
    direction): the study's stationary isotropic Gaussian surfaces say nothing of its
    solver area (benchmarks/model_error_real.py: 20-70 % off on such maps), so a_r_exact
    is NaN there and a remark says why; a_r itself stays."""
    import warnings

    G = surface(1, hurst=0.7, ratio=4.0).rough.acf()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        odd = xrough.quality.mark_curves(G, np.int8(1), what="acf", reason="anisotropic",
                                         notes="G_x and G_y differ (a test)")
        p = odd.rough.persson(E_star=E_STAR, p0=P0)
    plain = G.rough.persson(E_star=E_STAR, p0=P0)
    assert np.isfinite(plain.a_r_exact.values[0])
    np.testing.assert_array_equal(p.a_r.values, plain.a_r.values)
    for name in ("a_r_exact", "a_r_exact_lower", "sigma_c_exact", "a_r_model_error"):
        assert np.all(np.isnan(p[name].values)), name
    assert "regions or directions disagree" in p.attrs["quality_remarks"]
    assert "anisotropic" in xrough.quality.reasons_of(p)


# ------------------------------------------------------------------- the patch radius
@pytest.mark.parametrize("gamma", ["0.1 mJ/m^2", "0.03 mJ/m^2"])
def test_patch_radius_std_matches_the_scatter_over_seeds(gamma):
    """a_c_std and a_c_upper_std (G's covariance through the roots of eq. 44/46) against
    the scatter of a_c over 30 seeds (256^2 periodic maps, H 0.5, lambda_r = L/2): within
    0.75-1.3 as the other errors (measured 0.92-0.93 at both gamma)."""
    radii, stds = [], []
    for seed in range(SEEDS):
        G = surface(seed, hurst=0.5, ratio=2.0).rough.acf()
        p = G.rough.patch_radius(E_star=E_STAR, gamma=gamma)
        radii.append([float(p.a_c), float(p.a_c_upper)])
        stds.append([float(p.a_c_std), float(p.a_c_upper_std)])
    ratio = np.mean(stds, axis=0) / np.std(radii, axis=0, ddof=1)
    assert np.all((0.75 < ratio) & (ratio < 1.3)), ratio


@pytest.mark.parametrize("gamma", [1e-4, 3e-5, 1e-6])
def test_patch_radius_std_is_the_response_of_the_roots(gamma):
    """The radii's std from the moved conditions at the roots (implicit functions) equals
    the std of the roots searched again on every moved G (forward differences of 1e-6 in
    each ln G, the radii re-solved: brentq to 1e-12): to 1e-4 (measured 5e-6 at most on
    the 18 real files).  One map, three energies: a root in the even start below the
    first lag (1e-6 J/m^2), and two among the lags."""
    from xrough._kernels.contact import patch_radius_curve, patch_radius_std_curve
    from xrough._kernels.uncertainty import propagated_std

    G = surface(5, hurst=0.5, ratio=2.0).rough.acf()
    dr, g = G.dr.values * 1e-9, G.values * 1e-18  # m, m^2
    geometry = dict(size=256e-9, pixel=1e-9, geometry="periodic", n_maps=1)
    std = patch_radius_std_curve(g, dr=dr, E_star=25e6, gamma=gamma, **geometry)
    cov = relative_covariance(dr, g, **geometry)
    radii = patch_radius_curve(g, dr=dr, E_star=25e6, gamma=gamma)[:2]
    ref = propagated_std(lambda v: patch_radius_curve(v, dr=dr, E_star=25e6,
                                                      gamma=gamma)[:2], g, cov)
    assert np.all(np.isfinite(radii)) and np.all(std > 0)
    np.testing.assert_allclose(std, ref, rtol=1e-4)


def test_patch_radius_std_units_and_where_there_is_none():
    """The same a_c_std in nm and um (as lengths); NaN with error_of 'none' for a G with
    no map geometry (a model G) and where a_c is infinite (the surfaces stick)."""
    topo = surface(2)
    base = topo.rough.acf().rough.patch_radius(E_star=E_STAR, gamma="0.1 mJ/m^2")
    other = xrough.convert_units(topo, "um", lateral="um").rough.acf().rough.patch_radius(
        E_star=E_STAR, gamma="1e-4 J/m^2")
    assert other.a_c_std.attrs["units"] == "um"
    np.testing.assert_allclose(float(other.a_c_std) * 1e3, float(base.a_c_std), rtol=1e-5)
    assert 0 < float(base.a_c_std) < float(base.a_c)
    sticks = topo.rough.acf().rough.patch_radius(E_star=E_STAR, gamma="1 J/m^2")
    assert np.isinf(float(sticks.a_c)) and np.isnan(float(sticks.a_c_std))
    C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
                              rms_gradient=0.5, unit="nm")
    model = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="10 um").rough.patch_radius(
        E_star=E_STAR, gamma="0.1 J/m^2")
    assert np.isnan(float(model.a_c_std)) and model.a_c_std.attrs["error_of"].startswith("none")


# ------------------------------------------------------------------- the stress ACF
def test_stress_acf_std_matches_the_scatter_over_seeds():
    """G_sigma_std (G's covariance through the smoothing spline's Laplacian) against the
    scatter of the full-contact G_sigma over 30 seeds (256^2 periodic maps, H 0.5,
    lambda_r = L/2), at 1, 4 and 16 pixels: within 0.75-1.3 (measured 0.96-1.01 there,
    0.87-1.34 over all lags)."""
    values, stds = [], []
    for seed in range(SEEDS):
        S = surface(seed, hurst=0.5, ratio=2.0).rough.acf().rough.stress_acf(E_star=E_STAR)
        values.append(S.values)
        stds.append(S.G_sigma_std.values)
    dr = S.dr.values
    ratio = np.nanmean(stds, axis=0) / np.nanstd(values, axis=0, ddof=1)
    for lag in (1.0, 4.0, 16.0):
        k = int(np.argmin(np.abs(np.log(dr / lag))))
        assert 0.75 < ratio[k] < 1.3, (lag, ratio[k])


def test_stress_acf_std_units_and_where_there_is_none():
    """The same G_sigma_std (Pa^2) with lags in um; NaN with error_of 'none' for a G
    without map geometry; NaN wherever G_sigma is."""
    topo = surface(4)
    S = topo.rough.acf().rough.stress_acf(E_star=E_STAR)
    other = xrough.convert_units(topo, "um", lateral="um").rough.acf().rough.stress_acf(
        E_star="25e6 Pa")
    assert S.G_sigma_std.attrs["units"] == "Pa2"
    ok = np.isfinite(S.G_sigma_std.values)
    assert ok.sum() > 10 and np.all(np.isnan(S.G_sigma_std.values[np.isnan(S.values)]))
    # finite differences of a spline fit: 1e-5, and 1e-6 of the largest where it is tiny
    np.testing.assert_allclose(other.G_sigma_std.values[ok], S.G_sigma_std.values[ok],
                               rtol=1e-5, atol=1e-6 * np.nanmax(S.G_sigma_std.values))
    C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
                              rms_gradient=0.5, unit="nm")
    model = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="10 um").rough.stress_acf(
        E_star=E_STAR)
    assert np.all(np.isnan(model.G_sigma_std.values))
    assert model.G_sigma_std.attrs["error_of"].startswith("none")
