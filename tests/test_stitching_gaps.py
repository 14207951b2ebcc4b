"""Lags that no measurement covers: recorded by stitching, and read by every consumer of G."""

import warnings

import numpy as np
import pytest
import xarray as xr
from scipy.interpolate import PchipInterpolator

import xrough
from conftest import data_path
from xrough._kernels.gaps import bridge_energy
from xrough.stitching import (
    LevelFactorWarning,
    StitchingGapWarning,
    StitchingMismatchWarning,
    stitch,
    stitch_curves,
)

N = 2**16  # points of the periodic model profile (pixel 1 nm)
GAP = (40.0, 400.0)  # nm: the fine window ends, the coarse one begins


def two_instruments(n=N):
    """A fine instrument (32 scans of 1024 px of 1 nm) and a coarse one (the whole
    periodic H = 0.7 profile of ``n`` px block-averaged to 8 nm), 2 % white noise."""
    topo = xrough.self_affine_surface(hurst=0.7, lambda_r=n / 16, lambda_s=4.0,
                                      size=float(n), n=n, rms_height=1.0, profile=True,
                                      seed=4, unit="nm")
    h = topo.values
    rng = np.random.default_rng(2)

    def instrument(heights, spacing, periodic):
        dims = ("scan", "x") if heights.ndim == 2 else ("x",)
        noisy = heights + 0.02 * np.std(np.diff(heights, axis=-1)) * rng.normal(
            size=heights.shape)
        return xr.DataArray(noisy, dims=dims, attrs={"units": "nm", "periodic": periodic},
                            coords={"x": ("x", np.arange(heights.shape[-1]) * spacing,
                                          {"units": "nm"})})

    return {"fine": instrument(np.stack([h[s:s + 1024] for s in range(0, n, n // 32)]), 1.0,
                               0),
            "coarse": instrument(h.reshape(-1, 8).mean(-1), 8.0, 1)}


@pytest.fixture(scope="module")
def measurements():
    return two_instruments()


@pytest.fixture(scope="module")
def curves(measurements):
    return stitch_curves(measurements, points_per_decade=10)


@pytest.fixture(scope="module")
def gapped(measurements):
    """The two instruments with windows that leave 40-400 nm uncovered."""
    with pytest.warns(StitchingGapWarning) as record:
        G = stitch(measurements, windows={"fine": (None, GAP[0]), "coarse": (GAP[1], None)})
    assert len([w for w in record if w.category is StitchingGapWarning]) == 1
    G.attrs["_warning"] = str(record[0].message)  # for the test below (removed there)
    return G


@pytest.fixture(scope="module")
def whole(curves):
    with warnings.catch_warnings():
        warnings.simplefilter("error", StitchingGapWarning)
        return stitch(curves)


def test_gap_recorded_and_warned(gapped):
    G = gapped.copy()
    message = G.attrs.pop("_warning")
    assert "40-400 nm" in message and "'fine'" in message and "'coarse'" in message
    np.testing.assert_array_equal(G.attrs["uncovered_dr_min"], [GAP[0]])
    np.testing.assert_array_equal(G.attrs["uncovered_dr_max"], [GAP[1]])
    assert G.attrs["uncovered_dr_units"] == "nm"
    # the bins next to it: 10 per decade, last centre <= 40 nm, first >= 400 nm
    dr = G.dr.values
    assert not ((dr > GAP[0]) & (dr < GAP[1])).any()
    below, above = dr[dr <= GAP[0]].max(), dr[dr >= GAP[1]].min()
    assert below == pytest.approx(10**1.6) and above == pytest.approx(10**2.7)
    assert f"no bin between {below:.4g} and {above:.4g} nm" in message
    # coverage: bit 1 the fine instrument, bit 2 the coarse one, each in its window
    cov = G.coverage.values
    assert G.coverage.attrs["flag_masks"].tolist() == [1, 2]
    assert G.coverage.attrs["flag_meanings"] == "fine coarse"
    np.testing.assert_array_equal(cov, np.where(dr <= GAP[0], 1, 2))
    np.testing.assert_array_equal(G.n_measurements.values, 1)
    # the check of G reads the gap in any unit
    spec = xrough.acf.check_acf(G.assign_attrs(
        uncovered_dr_min=G.attrs["uncovered_dr_min"] / 1000,
        uncovered_dr_max=G.attrs["uncovered_dr_max"] / 1000, uncovered_dr_units="um"))
    np.testing.assert_allclose(spec.gaps, [GAP], rtol=1e-12)
    with pytest.raises(ValueError, match="uncovered_dr_min"):
        xrough.acf.check_acf(G.assign_attrs(uncovered_dr_max=np.array([1.0, 2.0])))


def test_warn_false_keeps_the_record(measurements, gapped):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        quiet = stitch(measurements, warn=False,
                       windows={"fine": (None, GAP[0]), "coarse": (GAP[1], None)})
    np.testing.assert_array_equal(quiet.attrs["uncovered_dr_min"], [GAP[0]])
    np.testing.assert_array_equal(quiet.coverage, gapped.coverage)


def test_no_gap_when_windows_overlap(curves, whole):
    assert whole.attrs["uncovered_dr_min"].size == 0
    assert whole.attrs["uncovered_dr_max"].size == 0
    assert xrough.acf.check_acf(whole).gaps.shape == (0, 2)
    both = whole.coverage.values == 3
    np.testing.assert_array_equal(both, whole.n_measurements.values == 2)
    assert both.sum() >= 8
    # and no consumer speaks of one
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        notes = [whole.rough.fit().attrs["quality_notes"],
                 whole.rough.energy(E_star="1 MPa").attrs["quality_notes"]]
        energy = whole.rough.energy(E_star="1 MPa")
    assert not any("not measured" in n for n in notes), notes
    assert "gap_share" not in energy


def test_windows_touching_leave_no_gap(measurements):
    # the coarse window begins where the fine one ends: no lag is uncovered
    with warnings.catch_warnings():
        warnings.simplefilter("error", StitchingGapWarning)
        G = stitch(measurements, windows={"fine": (None, 100.0), "coarse": (100.0, None)})
    assert G.attrs["uncovered_dr_min"].size == 0


def test_energy_bridges_the_gap_with_an_error_that_covers_it(gapped, whole):
    """v_el of the gapped G against that of the G measured over the gap too.

    The bridge is the log-log line between the bins around the gap; the error is the
    largest change of v_el when either neighbour's local slope is continued instead.
    The actual error of the bridge (v_el of the whole G, which has data there, minus
    that of the gapped one) must lie within it: the two G differ only in the gap (same
    instruments, same bins elsewhere, levelled alike to within 1 %).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        e_gap = gapped.rough.energy(E_star="1 MPa")
        e_all = whole.rough.energy(E_star="1 MPa")
    share, err = float(e_gap.gap_share), float(e_gap.gap_share_error)
    # H = 0.7: G / r^2 ~ r^-0.6, a decade of lags holds a good part of the integral
    assert 0.1 < share < 0.5
    actual = abs(float(e_all.v_el) / float(e_gap.v_el) - 1)
    assert actual <= err, (actual, err)
    assert "not measured over dr = 40-400 nm" in e_gap.attrs["quality_notes"]
    assert f"{share:.1%} of v_el" in e_gap.attrs["quality_notes"]
    expected = "questionable" if err > xrough.contact.BRIDGED else "good"
    assert e_gap.attrs["quality"] == expected
    assert int(e_gap.quality_flag) == xrough.quality.level_code(expected)
    assert e_gap.gap_share.attrs["units"] == "1"


def test_bridge_energy_closed_form():
    """A pure power law G = r^1.4 on bins 1..1000 with a gap 10-100: the bridge is exact,
    so are both alternatives (same slope on either side), and its share is the closed
    form of int_10^100 r^-0.6 dr over the whole integral (the even start a r^2 + b r^4
    through the bins at 1 and 3 below 1, flat beyond 1000)."""
    dr = np.array([1.0, 3.0, 10.0, 100.0, 300.0, 1000.0])
    g = dr**1.4
    share, err = bridge_energy(g, dr=dr, lo=np.array([20.0]), hi=np.array([50.0]))
    part = (100**0.4 - 10**0.4) / 0.4
    b = (3**1.4 / 9 - 1) / 8  # G(1) = a + b = 1, G(3) = 9 a + 81 b = 3^1.4
    total = (1 - b) + b / 3 + (1000**0.4 - 1) / 0.4 + 1000**1.4 / 1000
    assert share == pytest.approx(part / total, rel=1e-12)
    assert err == pytest.approx(0.0, abs=1e-12)
    # a kink at the gap: below slope 2 (ballistic), above 0.4; the bridge is the curve's
    # monotone cubic in log-log (scipy's PCHIP, integrated here by a fine trapezoid
    # rule), the alternatives continue each slope from its side, the error is the larger
    # departure
    g = np.where(dr <= 10, dr**2, 100 * (dr / 10) ** 0.4)
    share, err = bridge_energy(g, dr=dr, lo=np.array([20.0]), hi=np.array([50.0]))
    pchip = PchipInterpolator(np.log(dr), np.log(g))

    def integral(a, c):
        x = np.linspace(np.log(a), np.log(c), 2_000_001)
        return np.trapezoid(np.exp(pchip(x) - x), x)

    bridge = integral(10, 100)
    left = 100 / 10**2 * (100 - 10)  # G = r^2: int r^0 dr
    right = g[3] * 100**-0.4 * (100**-0.6 - 10**-0.6) / -0.6
    total = 1.0 + integral(1, 1000) + g[-1] / dr[-1]  # ballistic start (G = r^2 at 1, 3)
    assert share == pytest.approx(bridge / total, rel=1e-9)
    assert err == pytest.approx(max(abs(left - bridge), abs(right - bridge)) / total,
                                rel=1e-9)


def _said(result) -> str:
    """Notes and remarks (a check at level good says it as a remark: notes stay empty)."""
    return (result.attrs.get("quality_notes", "") + " | "
            + result.attrs.get("quality_remarks", ""))


def _marked(result, level):
    assert "not measured over dr = 40-400 nm" in _said(result)
    assert result.attrs["quality"] == level
    assert int(np.max(result.quality_flag.values)) == xrough.quality.level_code(level)


@pytest.mark.parametrize("consumer, level, expect", [
    ("fit", "good", "bridged by the fitted model"),
    ("gradient_exact", "questionable", "exact route"),
    ("gradient_simple", "good", "only G at each lag"),
    ("rms_gradient_exact", "questionable", "exact route"),
    ("stress_acf", "questionable", "Laplacian of G at the bins next to the gap"),
    ("persson", "questionable", "G_sigma and Gamma_sigma at the bins next to the gap"),
    ("spectrum", "questionable", "C(q), a transform of G over all lags"),
])
def test_every_consumer_marks_the_gap(gapped, whole, consumer, level, expect):
    G = gapped.copy()
    G.attrs.pop("_warning", None)
    run = {
        "fit": lambda g: g.rough.fit(),
        "gradient_exact": lambda g: g.rough.gradient(method="exact"),
        "gradient_simple": lambda g: g.rough.gradient(method="simple"),
        "rms_gradient_exact": lambda g: xrough.rms_gradient_exact(g),
        "stress_acf": lambda g: g.rough.stress_acf(E_star="1 MPa"),
        "persson": lambda g: g.rough.persson(E_star="1 MPa", p0="1 kPa"),
        "spectrum": lambda g: g.rough.spectrum(support_rtol=0.05),
    }[consumer]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run(G)
    _marked(result, "questionable" if level == "questionable" else result.attrs["quality"])
    assert expect in _said(result)
    if level == "questionable":
        assert any("not measured over dr = 40-400 nm" in str(w.message) for w in caught
                   if w.category is xrough.QualityWarning)
    # the same consumer of the G without a gap says nothing of one
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        other = run(whole)
    assert "not measured" not in other.attrs.get("quality_notes", "")


def test_fit_uses_measured_bins_only(gapped):
    G = gapped.copy()
    G.attrs.pop("_warning", None)
    fit = G.rough.fit()
    assert fit.attrs["quality"] == "good"  # a remark, not a doubt: no warning
    assert 0.6 < float(fit.hurst) < 0.8


def test_patch_radius_beyond_the_gap_is_questionable(gapped):
    G = gapped.copy()
    G.attrs.pop("_warning", None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        energy = G.rough.energy(E_star="1 MPa")
    v_el = float(energy.v_el)
    # gamma just above the energy of the patches up to the gap: a_c lies beyond it
    with pytest.warns(xrough.QualityWarning, match="integrates G across the bridge"):
        far = G.rough.patch_radius(E_star="1 MPa", gamma=0.9 * v_el)
    assert float(far.a_c_upper) > GAP[0]
    _marked(far, "questionable")
    # gamma of the patches of 10 nm: the patch closes below the gap, only the remark on
    # the gap; but two thirds of v_el(a_c) come from below reliable_dr_min (4 nm, the fine
    # instrument's window): questionable for that, said (docs/quality.md, "The
    # instrument's window in every result"; it was rated good)
    with pytest.warns(xrough.QualityWarning, match="a_c_below_window"):
        near = G.rough.patch_radius(E_star="1 MPa", gamma=float(
            energy.v_el_patch.sel(a_c=10.0, method="nearest")))
    assert float(near.a_c_upper) < GAP[0]
    assert float(near.a_c_below_window) > 0.25
    assert "integrates G across the bridge" not in near.attrs["quality_notes"]
    _marked(near, "questionable")


def test_archive_round_trip_of_stitched_G(tmp_path, gapped):
    G = gapped.copy()
    G.attrs.pop("_warning", None)
    assert G.attrs["uncovered_dr_min"].dtype == float
    path = xrough.save_analysis(tmp_path / "g.nc", {"uncd": {"G": G}})
    back = xrough.open_analysis(path)["uncd"]["G"]
    xr.testing.assert_identical(back, G)
    np.testing.assert_array_equal(xrough.acf.check_acf(back).gaps, [GAP])
    # the levelled case has no gap: empty arrays round-trip too
    H = G.assign_attrs(uncovered_dr_min=np.array([]), uncovered_dr_max=np.array([]))
    path = xrough.save_analysis(tmp_path / "h.nc", {"x": {"G": H}})
    xr.testing.assert_identical(xrough.open_analysis(path)["x"]["G"], H)


# ------------------------------------------------------------------------- UNCD data
def uncd_tree(folder, afm_scale=1.0):
    """The three UNCD measurements as a DataTree, detrended as meta.yml says (height:
    mean / plane, curvature for the stylus), the AFM heights times ``afm_scale``."""
    tem = xrough.open_topography(folder / "80_Scale10.472_FIXEDv2p1_D7eHXiT.asc",
                                 resample=True, unit="nm")
    afm = xrough.open_topography(folder / "gain_control_uncd_35_z03tr3R.001")
    sty = xrough.open_topography(folder / "uncd_stylus_300um_5mar_3_k0HpKJt.txt", unit="mm")
    afm = (afm * afm_scale).assign_attrs(afm.attrs)
    return xr.DataTree.from_dict({
        "TEM": tem.rough.detrend(mode="mean").to_dataset(name="h"),
        "AFM": afm.rough.detrend(mode="plane").to_dataset(name="h"),
        "stylus": sty.rough.detrend(mode="curvature").to_dataset(name="h")})


def _uncd(afm_scale=1.0):
    return uncd_tree(data_path("uncd"), afm_scale)


# The UNCD tests below stitch the G as measured (reliable=False): the tips that meta.yml
# states would leave the AFM out (its 26 nm tip resolves no lag of its window: the tip
# rule's 44.4 nm lies beyond a quarter of the 100 nm scan) and
# start the stylus at 2.07 um (tests/test_stitching_windows.py); here the TEM/AFM overlap
# is what levelling and the mismatch test are checked on.
@pytest.mark.data
def test_uncd_gap_is_recorded_warned_and_marked():
    tree = _uncd()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        G = tree.rough.acf(unit="nm", reliable=False)
    gap = [str(w.message) for w in caught if w.category is StitchingGapWarning]
    assert len(gap) == 1
    # the TEM window (a quarter of its 229 nm profile) ends at 58 nm, the stylus one
    # (4 pixels of 100 nm) begins at 398 nm: 9 bins of the grid have no data
    assert "no measurement covers dr = 57.99-398.2 nm" in gap[0], gap
    assert "no bin between 50.12 and 501.2 nm, 9 bins" in gap[0], gap
    np.testing.assert_allclose(G.attrs["uncovered_dr_min"], [57.99], rtol=1e-3)
    np.testing.assert_allclose(G.attrs["uncovered_dr_max"], [398.2], rtol=1e-3)
    # true calibration: levelling by about 1.11 (TEM) and 0.97 (AFM), within the errors
    assert not [w for w in caught if issubclass(w.category, LevelFactorWarning)]
    f, err = G.attrs["level_factors"], G.attrs["level_factor_errors"]
    np.testing.assert_allclose(f, [1.106, 0.970, 1.0], atol=1e-3)
    assert np.all(np.abs(np.log(f[:2])) < err[:2])
    assert G.attrs["quality"] == "good" and int(G.quality_flag) == 0
    names = G.coverage.attrs["flag_meanings"].split()
    assert names == ["TEM", "AFM", "stylus"]
    assert set(np.unique(G.coverage.values)) == {1, 2, 3, 4}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        fit = G.rough.fit()
        energy = G.rough.energy(E_star="1 GPa")
        stress = G.rough.stress_acf(E_star="1 GPa")
    assert "bridged by the fitted model" in fit.attrs["quality_remarks"]
    # H = 0.33: a fifth of v_el lies in the bridged decade, uncertain by about a tenth
    assert 0.1 < float(energy.gap_share) < 0.3
    assert 0.05 < float(energy.gap_share_error) < 0.2
    assert stress.attrs["quality"] == "questionable"


@pytest.mark.data
@pytest.mark.parametrize("scale", [2.0, 0.5])
def test_uncd_miscalibrated_afm_warns(scale):
    """AFM heights x 2 (G x 4): the mismatch test gives z = -3.2, beyond its threshold of
    3; x 0.5: z = +2.6, within it (the TEM's one profile gives its G a level error of
    ~50 % at those lags). Levelling would rescale the TEM's G by 3.2 and 0.38: beyond
    the bound, it warns either way."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        G = _uncd(scale).rough.acf(unit="nm", reliable=False)
    level = [str(w.message) for w in caught if w.category is LevelFactorWarning]
    assert len(level) == 1, [str(w.message) for w in caught]
    assert "'TEM' x " in level[0] and "'AFM' x " in level[0]
    f = G.attrs["level_factors"]
    assert not 0.5 <= f[0] <= 2.0
    assert f"'TEM' x {f[0]:.3g}" in level[0]
    assert G.attrs["quality"] == "questionable"
    assert "height calibrations" in G.attrs["quality_notes"]
    # the mismatch warning fires where |z| > 3 (docs/stitching.md: x 2 only)
    z = G.attrs["mismatch_z"][0]
    fired = bool([w for w in caught if w.category is StitchingMismatchWarning])
    assert fired == (abs(z) > 3) and fired == (scale == 2.0), z
