"""Stitching G(dr) of several instruments into one curve (xrough.stitching)."""

import warnings

import numpy as np
import pytest
import xarray as xr

import xrough
from conftest import uncd_measurements
from xrough.stitching import (
    LevelFactorWarning,
    StitchingMismatchWarning,
    level_factors,
    stitch,
    stitch_curves,
    stitch_mismatch,
)

N = 2**18  # points of the periodic model profile (pixel 1 nm)


@pytest.fixture(scope="module")
def surface():
    # H = 0.7 self-affine from lambda_s = 4 nm to lambda_r = N / 16: 4 decades of scales
    return xrough.self_affine_surface(hurst=0.7, lambda_r=N / 16, lambda_s=4.0,
                                      size=float(N), n=N, rms_height=1.0, profile=True,
                                      seed=11, unit="nm")


def _instrument(heights, spacing, *, noise, rng, unit="nm", scale=1.0, periodic=False):
    """Heights (scan, x) or (x,) on a grid of `spacing` nm, plus white noise of
    `noise` x the rms one-pixel height difference, converted to `unit`."""
    h = heights + noise * np.std(np.diff(heights, axis=-1)) * rng.normal(size=heights.shape)
    f = xrough.units.conversion_factor("nm", unit)
    dims = ("scan", "x") if h.ndim == 2 else ("x",)
    return xr.DataArray(scale * h * f, dims=dims,
                        coords={"x": ("x", np.arange(h.shape[-1]) * spacing * f,
                                      {"units": unit})},
                        attrs={"units": unit, "periodic": int(periodic)})


def _three(surface, *, scale_medium=1.0):
    """A fine small-scan instrument (32 scans of 2048 px of 1 nm), a medium one (8 scans
    of 4096 px, block-averaged to 4 nm, in um) and a coarse one (the whole periodic
    profile block-averaged to 16 nm)."""
    rng = np.random.default_rng(5)
    h = surface.values
    fine = np.stack([h[s:s + 2048] for s in range(0, N, N // 32)])
    medium = np.stack([h[s:s + 16384].reshape(-1, 4).mean(-1) for s in range(0, N, N // 8)])
    coarse = h.reshape(-1, 16).mean(-1)
    return {"fine": _instrument(fine, 1.0, noise=0.1, rng=rng),
            "medium": _instrument(medium, 4.0, noise=0.1, rng=rng, unit="um",
                                  scale=scale_medium),
            "coarse": _instrument(coarse, 16.0, noise=0.1, rng=rng, periodic=True)}


@pytest.fixture(scope="module")
def three(surface):
    return _three(surface)


@pytest.fixture(scope="module")
def curves(three):
    return stitch_curves(three)


def _reference(surface, dr):
    G = surface.rough.acf()
    return np.exp(np.interp(np.log(dr), np.log(G.dr.values), np.log(G.values)))


def test_recovers_true_G_over_union_of_windows(surface, curves):
    G = stitch(curves)
    assert G.name == "G" and G.dims == ("dr",)
    # windows: 4 px .. scan / 4 of each instrument, in the first instrument's unit (nm)
    np.testing.assert_allclose(curves.dr_min.values, [4.0, 16.0, 64.0])
    np.testing.assert_allclose(curves.dr_max.values, [512.0, 4096.0, N / 4])
    assert G.dr.attrs["units"] == "nm" and G.attrs["units"] == "nm2"
    # the bins whose centre lies in a window: from the first centre >= 4 nm to the last
    # one <= N / 4 (10 per decade)
    assert G.dr.values[0] == pytest.approx(10**0.7)
    assert G.dr.values[-1] == pytest.approx(10**4.8)
    assert int(G.n_measurements.max()) == 3 and int(G.n_measurements.min()) == 1
    # 5 %: the statistical error of the fine/medium scans is 1-10 %, the reference
    # is the G of the very profile they sample (same realisation), so only the
    # scan-to-surface sampling error and noise remain
    rel = G.values / _reference(surface, G.dr.values) - 1
    assert np.abs(rel).max() < 0.05, rel
    # and the true G of the model, over the range a single realisation pins down
    # (its own finite-size scatter grows towards lambda_r)
    C = xrough.model_spectrum(hurst=0.7, lambda_r=N / 16, lambda_s=4.0, lambda_0=float(N),
                              rms_height=1.0, unit="nm")
    exact = xrough.acf_from_spectrum(C, G.dr.values)
    model = G.values / exact.values - 1
    # up to lambda_r / 2: no further from the model than the realisation itself (which
    # scatters by up to 7 % there) plus 3.5 %: the level is the instruments' consensus
    # (levelling shares each step by precision), and the 'medium' scans lie 4-9 % below
    # the profile's G, which pulls it down by about 2 % (measured: at most 2.5 % beyond
    # the realisation's own deviation); near lambda_r one realisation scatters by ~15 %
    small = G.dr.values < N / 32
    own = _reference(surface, G.dr.values) / exact.values - 1
    assert np.all(np.abs(model[small]) <= np.abs(own[small]) + 0.035), model


def test_curves_are_nan_outside_windows(curves):
    for m in curves.measurement.values:
        c = curves.sel(measurement=m)
        inside = (c.dr >= c.dr_min) & (c.dr <= c.dr_max)
        assert bool(c.G.where(~inside).isnull().all())
        assert bool((c.pair_count.where(~inside, 0) == 0).all())
        assert int(np.isfinite(c.G).sum()) >= 8


def test_weighting_rule(curves):
    G = stitch(curves)
    factors = xr.DataArray(G.attrs["level_factors"], dims="measurement")
    g = curves.G.sel(dr=G.dr) * factors
    w = (g / (curves.standard_error.sel(dr=G.dr) * factors)) ** 2
    expected = np.exp((w * np.log(g)).sum("measurement") / w.sum("measurement"))
    np.testing.assert_allclose(G.values, expected.values, rtol=1e-12)
    np.testing.assert_allclose(G.standard_error.values,
                               (expected / np.sqrt(w.sum("measurement"))).values, rtol=1e-12)
    np.testing.assert_array_equal(G.pair_count.values,
                                  curves.pair_count.sel(dr=G.dr).sum("measurement").values)
    # the combination beats each instrument where they overlap
    best = (curves.standard_error / curves.G).min("measurement").sel(dr=G.dr)
    assert bool((G.standard_error / G <= best * (1 + 1e-12)).all())


def test_consistent_instruments_do_not_warn(curves):
    with warnings.catch_warnings():
        warnings.simplefilter("error", StitchingMismatchWarning)
        mm = stitch_mismatch(curves)
    assert set(mm.pair.values) == {"fine/medium", "fine/coarse", "medium/coarse"}
    assert not bool(mm.significant.any())
    # the scans differ from each other within their errors (a few %)
    assert bool((abs(mm.log_ratio) < 2 * mm.log_ratio_error).all())
    np.testing.assert_allclose(mm.ratio.values, 1.0, atol=0.1)


def test_miscalibrated_instrument_warns(surface, curves):
    bad = _three(surface, scale_medium=1.3)  # heights x 1.3 -> G x 1.69
    with pytest.warns(StitchingMismatchWarning) as record:
        G = stitch(bad)
    messages = [str(w.message) for w in record]
    assert any("'fine' and 'medium'" in m for m in messages), messages
    assert not any("'fine' and 'coarse'" in m for m in messages), messages
    ratio = dict(zip(G.attrs["mismatch_pairs"].split(", "), G.attrs["mismatch_ratio"]))
    good = stitch_mismatch(curves).set_index(pair="pair").ratio
    # noise scaled with the heights: G of 'medium' is exactly 1.69 x the consistent one
    assert ratio["fine/medium"] == pytest.approx(float(good.sel(pair="fine/medium")) / 1.69,
                                                 rel=1e-9)
    assert ratio["medium/coarse"] == pytest.approx(
        float(good.sel(pair="medium/coarse")) * 1.69, rel=1e-9)
    assert 1.5 < ratio["medium/coarse"] < 1.9


def test_precomputed_G_and_dataset_input(three, curves):
    Gs = {k: v.rough.acf(pool="scan" if v.ndim == 2 else None) for k, v in three.items()}
    # precomputed G carry no window: give the topographies' defaults
    win = {k: (float(curves.dr_min.sel(measurement=k)) * (1e-3 if k == "medium" else 1),
               float(curves.dr_max.sel(measurement=k)) * (1e-3 if k == "medium" else 1))
           for k in three}
    other = stitch_curves(Gs, windows=win)
    both = np.isfinite(other.G) & np.isfinite(curves.G)
    assert int(both.sum()) > 40
    # re-binned fine bins vs G computed on the common edges: the same pairs
    np.testing.assert_allclose(other.G.where(both), curves.G.where(both), rtol=0.05)
    assert (three["fine"].attrs, three["fine"].dims) == ({"units": "nm", "periodic": 0},
                                                          ("scan", "x"))
    ds = xr.Dataset({"coarse": three["coarse"]})
    one = stitch_curves(ds)
    assert list(one.measurement.values) == ["coarse"]


def test_datatree_input(three, curves):
    tree = xr.DataTree.from_dict({k: xr.Dataset({"h": v}) for k, v in three.items()})
    other = stitch_curves(tree)
    assert sorted(other.measurement.values) == ["coarse", "fine", "medium"]  # the nodes
    np.testing.assert_allclose(other.G.sel(measurement="fine"),
                               curves.G.sel(measurement="fine"), rtol=1e-12)


def test_windows_override_and_reliable_attrs(three):
    t = dict(three)
    t["fine"] = xrough.reliable(t["fine"], short_cutoff="10 nm", long_cutoff="100 nm")
    c = stitch_curves(t, windows={"coarse": ("1 um", None)}, parallel=False)
    np.testing.assert_allclose(c.dr_min.values, [10.0, 16.0, 1000.0])
    np.testing.assert_allclose(c.dr_max.values, [100.0, 4096.0, N / 4])
    assert "windows= override" in c.attrs["window_rules"]
    with pytest.raises(ValueError, match="unknown measurements"):
        stitch_curves(three, windows={"nope": (1, 2)})
    with pytest.raises(ValueError, match="empty window"):
        stitch_curves(three, windows={"fine": (100, 10)})
    with pytest.raises(ValueError, match="set by stitching"):
        stitch_curves(three, dr_min=3)
    with pytest.raises(TypeError):
        stitch_curves([three["fine"]])


def test_level_removes_a_calibration_factor(surface, curves):
    # 'medium' with heights x 1.3 (G x 1.69): levelled, the stitched G is the consistent
    # one times a constant (the step is shared, so the level lies between 1 and 1.69),
    # with no step; the mismatch is still reported on the curves as measured
    with pytest.warns(StitchingMismatchWarning):
        bad = stitch(_three(surface, scale_medium=1.3))
    good = stitch(curves)
    ratio = bad.values / good.values
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-9)
    assert 1.0 < ratio[0] < 1.69
    f_bad, f_good = bad.attrs["level_factors"], good.attrs["level_factors"]
    np.testing.assert_allclose(f_bad * [1, 1.69, 1], f_good * ratio[0], rtol=1e-9)
    np.testing.assert_allclose(level_factors(curves), f_good, rtol=0)
    # the consistent instruments differ by a few %, within their errors
    np.testing.assert_allclose(f_good, 1.0, atol=0.05)
    # level=False: factors 1, the curves combined as measured (differs from levelled)
    raw = stitch(curves, level=False)
    np.testing.assert_array_equal(raw.attrs["level_factors"], [1.0, 1.0, 1.0])
    assert np.abs(raw.values / good.values - 1).max() > 1e-3


def test_level_factors_share_the_step_by_precision():
    # two curves 10 % apart: with equal errors the step is split evenly; a precise
    # curve (errors 10x smaller, level variance 100x smaller) moves 100x less than the
    # noisy one; a third curve that overlaps neither keeps factor 1
    dr = np.array([1.0, 2.0, 4.0, 8.0, 16.0])
    G = np.array([[1.0, 2.0, 4.0, np.nan, np.nan], [np.nan, 2.2, 4.4, 8.8, np.nan],
                  [np.nan, np.nan, np.nan, np.nan, 5.0]])

    def curves_with(rel):
        se = np.asarray(rel)[:, None] * G
        return xr.Dataset({"G": (("measurement", "dr"), G),
                           "standard_error": (("measurement", "dr"), se)},
                          coords={"measurement": ["a", "b", "c"], "dr": dr,
                                  "scan_size": ("measurement", [10.0, 100.0, 1.0])})

    f = level_factors(curves_with([0.05, 0.05, 0.05]))
    assert f[0] == pytest.approx(f[1] * 1.1, rel=1e-12)  # no step left
    assert np.log(f[0]) == pytest.approx(-np.log(f[1]), rel=1e-12)  # split evenly
    assert f[2] == 1.0
    f = level_factors(curves_with([0.05, 0.005, 0.05]))
    assert f[0] == pytest.approx(f[1] * 1.1, rel=1e-12)
    assert abs(np.log(f[1])) == pytest.approx(abs(np.log(f[0])) / 100, rel=1e-9)


@pytest.mark.parametrize("hurst", [0.5, 0.8])
def test_stress_acf_of_stitched_maps_has_no_seam(hurst):
    """Eq. 24 from a stitched G: within 3 % of G_sigma(0) from 2 nm to L/8.

    A 512^2 crop at 1 nm and the whole 2048^2 map at 4 nm (lambda_s = 4 nm, lambda_r =
    512 nm, seed 1), against the exact stress field (q E*/2) h~ of the whole map. The
    crop's G lies 5-8 % below the map's; combined as measured, the step where the coarse
    window begins gave 3.3 % (H = 0.5) and 6.1 % (H = 0.8) next to the seam. Levelled
    (default): measured 1.3 % for both, and at most 1.3 % for seeds 2 and 3.
    """
    from scipy import fft as sfft
    n, e_star = 2048, 1e6
    topo = xrough.self_affine_surface(hurst=hurst, lambda_r=n / 4, lambda_s=4, size=n, n=n,
                                      rms_gradient=0.1, seed=1, unit="nm")
    h = topo.transpose("y", "x").values
    meas = {"fine": xrough.topography(h[:512, :512], spacing=1, unit="nm", periodic=False),
            "coarse": xrough.topography(h[::4, ::4], spacing=4, unit="nm", periodic=True)}
    q = 2 * np.pi * np.hypot(sfft.fftfreq(n)[:, None], sfft.fftfreq(n)[None, :])
    stress = sfft.ifft2(q * e_star / 2 * sfft.fft2(h)).real
    field = xrough.topography(stress, spacing=1, unit="nm", height_unit="m", periodic=True)
    var = stress.var()
    Gs = field.rough.acf(points_per_decade=40)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StitchingMismatchWarning)
        S = stitch(meas).rough.stress_acf(E_star=e_star)
    ref = var - np.exp(np.interp(np.log(S.dr.values), np.log(Gs.dr.values),
                                 np.log(Gs.values)))
    sel = (S.dr.values >= 2) & (S.dr.values <= n / 8)
    err = (S.values - ref)[sel] / var
    # the first lag of the fine map's window is rough already: NaN by design (a remark)
    assert np.isfinite(err[1:]).all() and "the first lag" in S.attrs["quality_remarks"]
    assert np.nanmax(np.abs(err)) < 0.03, err


def test_stitched_G_feeds_fit_and_persson(curves):
    G = stitch(curves)
    assert G.attrs["stitched"] == 1 and G.attrs["stitched_from"] == "fine, medium, coarse"
    fit = G.rough.fit()
    assert 0.6 < float(fit.hurst) < 0.8
    # a power law at its first lag: gbar there is the fit's, beyond the data's resolution
    with pytest.warns(xrough.QualityWarning, match="Nyquist"):
        ds = G.rough.persson(E_star="25 MPa", p0="1 MPa")
    assert "a_r" in ds and np.isfinite(ds.a_r).any()


@pytest.mark.data
def test_uncd_stitched():
    meas = uncd_measurements()  # detrend modes of meta.yml
    # the G as measured (reliable=False: the tips the container states not applied, which
    # leave the AFM out and start the stylus at 2.07 um, tests/test_stitching_windows.py):
    # three instruments, TEM and AFM overlapping
    curves = stitch_curves(meas, unit="nm", reliable=False)
    assert curves.attrs["left_out"] == "" and "tip" not in curves.attrs["window_rules"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StitchingMismatchWarning)
        mm = stitch_mismatch(curves)
        with pytest.warns(xrough.stitching.StitchingGapWarning, match="57.99-398.2 nm"):
            G = stitch(curves)  # TEM/stylus leave a gap (tests/test_stitching_gaps.py)
    assert G.dr.attrs["units"] == "nm" and G.attrs["units"] == "nm2"
    assert G.dr.values[0] < 10 and G.dr.values[-1] > 5e4  # > 4 decades
    assert np.isfinite(G.values).all() and (np.diff(G.values) > -0.5 * G.values[1:]).all()
    assert mm.sizes["pair"] >= 1 and np.isfinite(mm.ratio).all()
    # continuous: between neighbouring bins G changes no faster than dr^2 (the steepest
    # G of a smooth surface), also across the gap the windows leave (TEM/stylus)
    slope = np.diff(np.log(G.values)) / np.diff(np.log(G.dr.values))
    assert np.abs(slope).max() < 2.0, slope
    # one model spectrum over 4 decades of three instruments misses G by 14 % rms: said
    with pytest.warns(xrough.QualityWarning, match="misses G by 1[0-9]% rms"):
        fit = G.rough.fit()
    assert 0 < float(fit.hurst) < 1 and fit.attrs["quality"] == "questionable"


def _levelled_pair(rel, eps, cover=((0, 4), (2, 8)), scans=(10.0, 100.0)):
    """Curves G = dr^1.4 x exp(eps_m) on their ranges of bins, errors rel_m x G."""
    dr = 2.0 ** np.arange(8)
    G = np.full((len(cover), dr.size), np.nan)
    for m, (a, b) in enumerate(cover):
        G[m, a:b] = dr[a:b] ** 1.4 * np.exp(eps[m])
    names = [f"m{i}" for i in range(len(cover))]
    return xr.Dataset({"G": (("measurement", "dr"), G, {"units": "nm2"}),
                       "standard_error": (("measurement", "dr"), np.asarray(rel)[:, None] * G,
                                          {"units": "nm2"}),
                       "pair_count": (("measurement", "dr"), np.isfinite(G) * 100)},
                      coords={"measurement": names, "dr": ("dr", dr, {"units": "nm"}),
                              "scan_size": ("measurement", list(scans)),
                              "pixel_size": ("measurement", [dr[a] for a, _ in cover]),
                              "dr_min": ("measurement", [dr[a] for a, _ in cover]),
                              "dr_max": ("measurement", [dr[b - 1] for _, b in cover]),
                              "source": ("measurement", names)})


def test_level_factor_errors_closed_form_and_monte_carlo():
    """Errors of ln(level factor): the closed form of two curves, and their scatter.

    Two curves with level errors of 30 % and 10 % (one factor at all lags of each):
    the step r = eps_coarse - eps_fine has variance v_f + v_c, and ln f_fine = r v_f /
    (v_f + v_c) scatters by v_f / sqrt(v_f + v_c). Over 4000 random levels the standard
    deviation of ln f agrees with the stated error to 5 % (the standard deviation of a
    standard deviation from 4000 draws is 1.1 %). Three curves levelled in a chain: the
    errors of the steps are summed as independent, which overstates the scatter (measured
    4-15 % here), never understates it by more than the Monte Carlo's own 5 %.
    """
    v_f, v_c = 0.3**2, 0.1**2
    f, err = level_factors(_levelled_pair([0.3, 0.1], [0.0, 0.2]), with_errors=True)
    np.testing.assert_allclose(err, [v_f / np.sqrt(v_f + v_c), v_c / np.sqrt(v_f + v_c)],
                               rtol=1e-12)
    np.testing.assert_allclose(np.log(f), [0.2 * v_f / (v_f + v_c), -0.2 * v_c / (v_f + v_c)],
                               rtol=1e-12)
    rng = np.random.default_rng(0)
    for rel, cover, scans in [([0.3, 0.1], ((0, 4), (2, 8)), (10.0, 100.0)),
                              ([0.3, 0.2, 0.1], ((0, 3), (2, 6), (4, 8)), (1.0, 10.0, 100.0))]:
        rel = np.asarray(rel)
        runs = [level_factors(_levelled_pair(rel, rng.normal(size=rel.size) * rel, cover,
                                             scans), with_errors=True) for _ in range(4000)]
        scatter = np.std([np.log(f) for f, _ in runs], axis=0)
        stated = runs[0][1]
        if rel.size == 2:
            np.testing.assert_allclose(scatter, stated, rtol=0.05)
        else:
            assert np.all(stated > 0.95 * scatter) and np.all(stated < 1.2 * scatter), (
                stated, scatter)


def test_unexplained_level_factor_warns():
    # errors of 5 %: a step of 10 % is 1.4 sigma (quiet), of 50 % 7 sigma (warns)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        quiet = stitch(_levelled_pair([0.05, 0.05], [0.0, 0.1]), warn=True)
    assert quiet.attrs["quality"] == "good" and int(quiet.quality_flag) == 0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        loud = stitch(_levelled_pair([0.05, 0.05], [0.0, 0.4]))
    level = [str(w.message) for w in caught if w.category is LevelFactorWarning]
    assert len(level) == 1 and "'m0' x 1.22 (ln f = +0.20 +- 0.04, 5.7 sigma)" in level[0]
    assert "the level errors of the scans do not explain it" in level[0]
    assert [w for w in caught if w.category is StitchingMismatchWarning]  # z = 5.7 too
    assert loud.attrs["quality"] == "questionable" and int(loud.quality_flag) == 1
    # errors of 100 %: a factor 9 in G is within 1.6 sigma, but beyond the bound [1/2, 2]
    with pytest.warns(LevelFactorWarning, match=r"outside \[1/2, 2\]"):
        stitch(_levelled_pair([1.0, 1.0], [0.0, np.log(9.0)]))
    # level=False: nothing levelled, nothing to warn about the factors
    with warnings.catch_warnings():
        warnings.simplefilter("error", LevelFactorWarning)
        warnings.simplefilter("ignore", StitchingMismatchWarning)
        raw = stitch(_levelled_pair([0.05, 0.05], [0.0, 0.4]), level=False)
    np.testing.assert_array_equal(raw.attrs["level_factor_errors"], [0.0, 0.0])


def test_window_of_a_map_with_y_and_x_in_other_units():
    # the same 2 um map with x in nm and y in um: one lateral unit (the Grid's, y's) for the
    # default window, and for the window recorded by reliable(); before, the pixel and scan
    # size of one axis were read in the other's unit and the window came out 1000x wrong
    t = xrough.self_affine_surface(hurst=0.8, lambda_r="0.5 um", lambda_s="40 nm",
                                   size="2 um", n=128, rms_height="1 nm", unit="nm", seed=1)
    mixed = t.assign_coords(y=("y", t.y.values / 1000, dict(t.y.attrs, units="um")))
    c = stitch_curves({"nm": t, "mixed": mixed}, parallel=False)
    f = xrough.units.conversion_factor(c.attrs.get("lateral_unit", c.dr.attrs["units"]), "nm")
    np.testing.assert_allclose(c.dr_min.values * f, [62.5, 62.5], rtol=1e-12)  # 4 px of 15.6 nm
    np.testing.assert_allclose(c.dr_max.values * f, [500.0, 500.0], rtol=1e-12)
    kept = xrough.reliable(mixed, short_cutoff="40 nm", long_cutoff="0.4 um")
    assert xrough.reliability_window(kept) == pytest.approx((0.04, 0.4))  # um, as y
    c = stitch_curves({"nm": t, "mixed": kept}, parallel=False)
    np.testing.assert_allclose(c.dr_min.values * f, [62.5, 40.0], rtol=1e-12)
    np.testing.assert_allclose(c.dr_max.values * f, [500.0, 400.0], rtol=1e-12)


def test_refuses_a_g_that_is_no_g(three):
    """A G holding inf (one bin of an overflowed estimate) or in the wrong units is
    refused by name, as every estimator refuses it (xrough.acf.check_acf): stitch dropped
    the bin and combined the rest without a word."""
    G = {name: t.rough.acf() for name, t in three.items()}
    name = next(iter(G))
    bad = G[name].copy()
    bad[5] = np.inf
    with pytest.raises(ValueError, match=f"measurement '{name}'.*infinite"):
        xrough.stitch({**G, name: bad})
    with pytest.raises(ValueError, match=f"measurement '{name}'.*length\\^2"):
        xrough.stitch({**G, name: G[name].assign_attrs(units="nm")})
