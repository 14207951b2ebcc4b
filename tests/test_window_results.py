"""The instrument's window (reliable_dr_min/max) in every result of G.

energy, patch_radius, rms_gradient, persson and the report use the lags inside the window
and state the share of a result that comes from below it (docs/quality.md, "The
instrument's window in every result"). Numbers come from closed forms of a ballistic
G = c dr^2 (flat beyond its last lag rL), for which eq. 16 gives
``int_0^a G / r^2 dr = c a`` (a <= rL) and ``2 c rL`` to infinity, so the share of v_el
below ``lo`` is ``lo / (2 rL)``; eq. 44/46 give ``a_c_upper = 4 gamma / (E* c)`` and
``a_c = 8 gamma / (3 E* c)``, and the share of v_el(a_c) below ``lo`` is ``lo / a_c``.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import xarray as xr
from scipy.special import erf

import xrough
from conftest import data_path
from xrough import quality
from xrough.cli import main
from xrough.contact import BELOW_WINDOW, EXTRAPOLATED
from xrough.preprocess import NO_WINDOW, lag_window

E_STAR = 25e6
C = 0.01  # G = C dr^2: gbar = sqrt(4 C) = 0.2
DR = np.geomspace(1.0, 1000.0, 31)  # um


def ballistic(lo=None, hi=None, *, unit="um", stored="um", c=C) -> xr.DataArray:
    """G = c dr^2 on DR (in ``unit``), the window (in ``stored``) in its attrs."""
    f = {"um": 1.0, "nm": 1e3}[unit]
    g = {"um": 1.0, "nm": 1e3}[stored]
    attrs = {"units": f"{unit}2"}
    if lo is not None:
        attrs.update(reliable_dr_min=lo * g, reliable_dr_units=stored,
                     reliable_rule="dr_min: tip radius (test)")
    if hi is not None:
        attrs.update(reliable_dr_max=hi * g, reliable_dr_units=stored)
    dr = DR * f
    return xr.DataArray(c * dr**2, dims="dr", coords={"dr": ("dr", dr, {"units": unit})},
                        attrs=attrs)


def quiet(func, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", quality.QualityWarning)
        return func(*args, **kwargs)


def test_threshold_is_that_of_the_continuation():
    assert BELOW_WINDOW == EXTRAPOLATED == 0.25


# --------------------------------------------------------------------- elastic energy
@pytest.mark.parametrize("lo", [300.0, 600.0])
def test_energy_states_its_share_below_the_window(lo):
    """v_el as before; v_el_below_window = lo / (2 rL) (0.15 and 0.30): above 25 % a
    note with the share and the window (questionable), below it a remark. (Half of this
    v_el comes from the flat continuation beyond rL, which its own check marks.)"""
    plain = quiet(xrough.elastic_energy, ballistic(), E_star=E_STAR)
    e = quiet(xrough.elastic_energy, ballistic(lo), E_star=E_STAR)
    assert float(e.v_el) == pytest.approx(E_STAR / 4 * 2 * C * 1e-6 * 1000, rel=1e-9)
    assert float(e.v_el) == float(plain.v_el)
    assert float(e.v_el_below_window) == pytest.approx(lo / 2000, rel=1e-9)
    if lo == 300.0:
        assert "15% of v_el" in e.attrs["quality_remarks"]
        assert "v_el_below_window" not in e.attrs["quality_notes"]
    else:
        assert "30% of v_el (variable v_el_below_window)" in e.attrs["quality_notes"]
        assert "reliable_dr_min = 600 um" in e.attrs["quality_notes"]


def plateau(lo, corner, c=C) -> xr.DataArray:
    """G = c min(dr, corner)^2 on 1 um to 1 m (um): v_el nearly all from inside the lags,
    so the window's share decides the rating (about lo / (2 corner))."""
    dr = np.geomspace(1.0, 1e6, 61)
    return xr.DataArray(c * np.minimum(dr, corner) ** 2, dims="dr",
                        coords={"dr": ("dr", dr, {"units": "um"})},
                        attrs={"units": "um2", "reliable_dr_min": lo,
                               "reliable_dr_units": "um", "reliable_rule": "test"})


def test_energy_without_window_states_the_share_below_the_first_lag():
    e = quiet(xrough.elastic_energy, ballistic(), E_star=E_STAR)
    assert float(e.v_el_below_window) == pytest.approx(float(e.extrapolated_below), rel=1e-12)
    assert float(e.v_el_below_window) == pytest.approx(1 / 2000, rel=1e-9)


def test_unit_invariance_of_the_window_shares():
    """G in nm with its window stored in um (and the reverse): the same shares, flags."""
    a = quiet(xrough.elastic_energy, ballistic(600.0), E_star=E_STAR)
    b = quiet(xrough.elastic_energy, ballistic(600.0, unit="nm", stored="um"), E_star=E_STAR)
    c = quiet(xrough.elastic_energy, ballistic(600.0, unit="um", stored="nm"), E_star=E_STAR)
    for other in (b, c):
        assert float(other.v_el_below_window) == pytest.approx(
            float(a.v_el_below_window), rel=1e-10)
        assert float(other.v_el) == pytest.approx(float(a.v_el), rel=1e-10)
        assert other.attrs["quality"] == a.attrs["quality"] == "questionable"
    pa = quiet(xrough.patch_radius, ballistic(30.0), E_star=E_STAR, gamma=6.25)
    pb = quiet(xrough.patch_radius, ballistic(30.0, unit="nm", stored="um"),
               E_star=E_STAR, gamma=6.25)
    assert float(pb.a_c) == pytest.approx(1e3 * float(pa.a_c), rel=1e-9)
    assert float(pb.a_c_below_window) == pytest.approx(float(pa.a_c_below_window), rel=1e-9)
    ga = xrough.rms_gradient(ballistic(30.0), method="simple")
    gb = xrough.rms_gradient(ballistic(30.0, unit="nm", stored="um"), method="simple")
    np.testing.assert_array_equal(np.isnan(ga.values), np.isnan(gb.values))


@pytest.mark.parametrize("how", ["above every lag", "tip"])
def test_energy_fails_when_the_window_holds_no_lag(how):
    G = ballistic(2000.0) if how == "above every lag" else ballistic().assign_attrs(
        reliable_rule=NO_WINDOW + "the tip radius 5 mm stated in the file resolves no lag")
    with pytest.warns(quality.QualityWarning, match="no lag of G is resolved"):
        e = xrough.elastic_energy(G, E_star=E_STAR)
    assert e.attrs["quality"] == "failed" and np.isnan(float(e.v_el))
    assert "acf(reliable=False)" in e.attrs["quality_notes"]


def test_energy_numpy_and_dask_agree():
    """Two curves against lo = 30 um: corners at 100 um (share 0.15, good) and 40 um
    (0.37, questionable): the same values and flags lazily, the same attrs."""
    curves = xr.concat([plateau(30.0, 100.0), plateau(30.0, 40.0)], dim="scan")
    curves.attrs = plateau(30.0, 100.0).attrs
    now = quiet(xrough.elastic_energy, curves, E_star=E_STAR)
    lazy = xrough.elastic_energy(curves.chunk({"scan": 1}), E_star=E_STAR)
    assert lazy.v_el_below_window.chunks is not None
    done = lazy.compute()
    np.testing.assert_allclose(done.v_el_below_window, now.v_el_below_window, rtol=1e-12)
    np.testing.assert_allclose(done.v_el, now.v_el, rtol=1e-12)
    np.testing.assert_array_equal(done[quality.FLAG].values, now[quality.FLAG].values)
    assert now[quality.FLAG].values.tolist() == [0, 1]
    np.testing.assert_allclose(now.v_el_below_window, [0.15, 0.375], rtol=0.02)
    assert lazy.attrs == now.attrs


# ----------------------------------------------------------------------- patch radius
GAMMA = 6.25  # J/m^2: a_c_upper = 4 gamma / (E* c) = 100 um, a_c = 66.7 um


def test_patch_radius_below_the_window_is_not_resolved():
    """a_c = 66.7 um below reliable_dr_min = 300 um: failed, NaN, the radius in the note."""
    assert float(xrough.patch_radius(ballistic(), E_star=E_STAR, gamma=GAMMA).a_c) == \
        pytest.approx(200 / 3, rel=1e-6)
    with pytest.warns(quality.QualityWarning, match="lies below reliable_dr_min"):
        p = xrough.patch_radius(ballistic(300.0), E_star=E_STAR, gamma=GAMMA)
    assert p.attrs["quality"] == "failed" and np.isnan(float(p.a_c))
    assert "a_c = 66.7 um" in p.attrs["quality_notes"]
    assert "sharper tip" in p.attrs["quality_notes"]


@pytest.mark.parametrize("lo, level", [(10.0, "good"), (30.0, "questionable")])
def test_patch_radius_states_its_share_below_the_window(lo, level):
    """a_c_below_window = lo / a_c (0.15 and 0.45)."""
    p = quiet(xrough.patch_radius, ballistic(lo), E_star=E_STAR, gamma=GAMMA)
    assert float(p.a_c) == pytest.approx(200 / 3, rel=1e-6)
    assert float(p.a_c_below_window) == pytest.approx(lo / (200 / 3), rel=1e-6)
    assert p.attrs["quality"] == level


def test_patch_radius_beyond_the_window_is_questionable():
    p = quiet(xrough.patch_radius, ballistic(10.0, 80.0), E_star=E_STAR, gamma=GAMMA)
    assert p.attrs["quality"] == "questionable"
    assert "beyond reliable_dr_max = 80 um" in p.attrs["quality_notes"]


def test_patch_radius_numpy_and_dask_agree():
    """Two curves: a_c 66.7 um (c = 0.01) and 6.67 um (c = 0.1) against lo = 30 um:
    questionable (share 0.45) and failed (below the window)."""
    curves = xr.concat([ballistic(30.0), ballistic(30.0, c=0.1)], dim="scan")
    curves.attrs = ballistic(30.0).attrs
    now = quiet(xrough.patch_radius, curves, E_star=E_STAR, gamma=GAMMA)
    done = xrough.patch_radius(curves.chunk({"scan": 1}), E_star=E_STAR,
                               gamma=GAMMA).compute()
    assert now[quality.FLAG].values.tolist() == [1, 2]
    np.testing.assert_array_equal(done[quality.FLAG].values, now[quality.FLAG].values)
    np.testing.assert_allclose(done.a_c.values[0], now.a_c.values[0], rtol=1e-12)
    np.testing.assert_allclose(done.a_c_below_window.values[0],
                               now.a_c_below_window.values[0], rtol=1e-12)
    assert np.isnan(now.a_c.values[1])  # failed: NaN (a lazy result keeps it; its flag says)


# ----------------------------------------------------------------------- rms gradient
def test_gradient_is_nan_outside_the_window():
    """gbar = 0.2 inside [30, 300] um, NaN outside, the lags named in a remark; good."""
    g = xrough.rms_gradient(ballistic(30.0, 300.0), method="simple")
    inside = (DR >= 30) & (DR <= 300)
    np.testing.assert_allclose(g.values[inside], 0.2, rtol=1e-12)
    assert np.isnan(g.values[~inside]).all() and np.isnan(g.gbar_std.values[~inside]).all()
    assert g.attrs["quality"] == "good"
    assert "NaN at dr = 1 to 25.12 and 316.2 to 1000 um" in g.attrs["quality_remarks"]


@pytest.mark.parametrize("method", ["simple", "auto"])
def test_gradient_fails_when_the_window_holds_no_lag(method):
    with pytest.warns(quality.QualityWarning, match="no lag of G is resolved"):
        g = xrough.rms_gradient(ballistic(2000.0), method=method)
    assert g.attrs["quality"] == "failed" and np.isnan(g.values).all()


def test_gradient_numpy_and_dask_agree():
    curves = xr.concat([ballistic(30.0), ballistic(30.0, c=0.04)], dim="scan")
    curves.attrs = ballistic(30.0).attrs
    now = xrough.rms_gradient(curves, method="simple")
    lazy = xrough.rms_gradient(curves.chunk({"scan": 1}), method="simple")
    np.testing.assert_array_equal(lazy.compute().values, now.values)
    np.testing.assert_array_equal(lazy.compute()[quality.FLAG].values,
                                  now[quality.FLAG].values)
    assert lazy.attrs == now.attrs


# ---------------------------------------------------------------------------- persson
def test_persson_fails_when_the_window_holds_no_lag():
    with pytest.warns(quality.QualityWarning, match="no lag of G is resolved"):
        p = xrough.persson(ballistic(2000.0), E_star=E_STAR, p0=1e5,
                           gradient_method="simple")
    assert p.attrs["quality"] == "failed" and np.isnan(p.a_r.values).all()


def egg_crate() -> xr.DataArray:
    n = 256
    x = np.arange(n)
    h = np.sin(2 * np.pi * x[:, None] / 32) * np.sin(2 * np.pi * x[None, :] / 32)
    return xrough.topography(h, spacing="1 nm", unit="nm").rough.acf()


def test_a_failed_fit_blanks_only_what_needs_it():
    """An egg-crate map: its fit fails (no self-affine range), which sigma_quick (eq. 42)
    needs and nothing else: a_r = erf(sqrt(2) p0 / (E* gbar)) (eq. 29) stays, from the
    gradient, which is finite; the result is questionable and says which variable is NaN.
    (Before, the failed fit failed the whole result: a_r NaN.)"""
    G = egg_crate()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gbar = G.rough.gradient()
        p = G.rough.persson(E_star=E_STAR, p0=1e5)
    assert quality.worst(quiet(G.rough.fit)) == "failed"
    assert np.isnan(p.sigma_quick.values).all()
    ok = np.isfinite(gbar.values)
    assert ok.sum() > 10
    running = np.fmax.accumulate(gbar.values[::-1])[::-1]  # gbar cannot rise (eq. 26)
    np.testing.assert_allclose(p.a_r.values[ok], erf(np.sqrt(2) * 1e5 / (E_STAR * running[ok])),
                               rtol=1e-12)
    assert p.attrs["quality"] == "questionable"
    assert p.attrs["quality_notes"].startswith("sigma_quick NaN: the fit of G it needs")
    said = [w for w in caught if "persson" in str(w.message)]
    assert len(said) == 1


def test_a_failed_gradient_blanks_all_but_sigma_quick():
    """The gradient failed on a curve (given, flagged failed): every variable that needs
    gbar is NaN, sigma_quick (fit and G only) stays; numpy and dask flag it alike."""
    G = ballistic()
    gbar = xrough.rms_gradient(G, method="simple")
    broken = quality.mark(gbar, "test: failed", level="failed", what="test", warn=False)
    fit = xrough.fit_acf(xrough.acf_from_spectrum(
        xrough.model_spectrum(hurst=0.8, lambda_r="100 um", lambda_s="1 um",
                              rms_gradient=0.2, unit="um"), DR))
    p = quiet(xrough.persson, G, E_star=E_STAR, p0=1e5, gradient=broken, fit=fit)
    assert np.isnan(p.a_r.values).all() and np.isfinite(p.sigma_quick.values).any()
    assert p.attrs["quality"] == "questionable"
    assert "every variable but sigma_quick NaN" in p.attrs["quality_notes"]


# ------------------------------------------------------------------ lag_window itself
def test_lag_window_reads_the_tip_that_resolves_nothing():
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="64 nm", lambda_s="4 nm",
                                      size="256 nm", n=128, rms_gradient=0.1, seed=1,
                                      unit="nm").assign_attrs(Stylus="Radius: 5 mm")
    G = quiet(topo.rough.acf)
    assert "reliable_dr_min" not in G.attrs
    w = lag_window(G)
    assert w.empty is not None and "5 mm" in w.empty and w.outside.all()
    assert lag_window(topo.rough.acf(reliable=False)).empty is None


# ------------------------------------------------------------------------------ report
def test_report_of_a_tip_that_resolves_no_lag(tmp_path, monkeypatch, capsys):
    """No scale-dependent number from a window without lags: rms grad, a_r, v_el failed,
    'at dr' none, and the reason said (JSON: nulls and the window's no_lag)."""
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="64 nm", lambda_s="4 nm",
                                      size="256 nm", n=128, rms_gradient=0.1, seed=1,
                                      unit="nm").assign_attrs(Stylus="Radius: 5 mm")
    topo.to_netcdf(tmp_path / "blunt.nc")
    monkeypatch.chdir(tmp_path)
    assert main(["report", "blunt.nc", "--E-star", "25MPa", "--p0", "0.1MPa",
                 "--json", "-o", "b.nc"]) == 0
    m = json.loads(capsys.readouterr().out)["measurements"][0]
    assert m["rms_gradient"]["value"] is None and m["at_dr"]["value"] is None
    assert m["a_r"]["value"] is None and m["v_el"]["value"] is None
    assert m["quality"]["gradient"]["level"] == "failed"
    assert m["quality"]["energy"]["level"] == "failed"
    assert "5 mm" in m["window"]["no_lag"]
    assert main(["report", "blunt.nc", "--E-star", "25MPa", "--p0", "0.1MPa",
                 "-o", "b.nc"]) == 0
    out = capsys.readouterr().out
    row = out.splitlines()[1]
    assert "none: no lag in the window" in row and "failed" in row
    assert "resolves no lag" in out


# ------------------------------------------------------------------------- real files
def _stylus_G():
    topo = xrough.open_topography(
        data_path("uncd", "uncd_stylus_300um_5mar_3_k0HpKJt.txt"), unit="mm")
    return quiet(lambda: topo.rough.detrend(mode="curvature")
                 .rough.mask_outliers(threshold=5).rough.acf())


def _dektak_G():
    topo = xrough.open_topography(data_path("instruments", "dektak-1.csv"))
    return quiet(lambda: topo.rough.detrend().rough.mask_outliers(threshold=5).rough.acf())


@pytest.mark.data
@pytest.mark.parametrize("which, share", [("stylus", 0.84), ("dektak", 0.32)])
def test_real_profiles_state_their_share_below_the_window(which, share):
    """Measured: 84 % of the UNCD stylus' v_el (2.62 mJ/m^2) and 32 % of dektak-1's come
    from below their windows (2.07 and 1.55 um): questionable, values as before; gbar NaN
    below the window; a patch radius below the window (gamma = 0.05 mJ/m^2: 0.007 and
    0.12 um) failed."""
    G = _stylus_G() if which == "stylus" else _dektak_G()
    lo = G.attrs["reliable_dr_min"]
    e = quiet(G.rough.energy, E_star="25 MPa")
    assert float(e.v_el_below_window) == pytest.approx(share, abs=0.01)
    assert e.attrs["quality"] == "questionable" and "v_el_below_window" in \
        e.attrs["quality_notes"]
    g = quiet(G.rough.gradient)
    assert np.isnan(g.values[G.dr.values < lo]).all()
    assert np.isfinite(g.values[G.dr.values >= lo]).any()
    p = quiet(G.rough.patch_radius, E_star="25 MPa", gamma="0.05 mJ/m^2")
    assert p.attrs["quality"] == "failed" and "lies below reliable_dr_min" in \
        p.attrs["quality_notes"]


@pytest.mark.data
def test_real_afm_whose_window_holds_no_lag(tmp_path, monkeypatch, capsys):
    """The UNCD AFM (26 nm tip, 100 nm scan): its window, 44.4 to 50 nm, holds no lag of
    G, so every result of its G fails, and the report prints no rms gradient (was 2.22 at
    195 pm, questionable)."""
    path = data_path("uncd", "gain_control_uncd_35_z03tr3R.001")
    G = quiet(lambda: xrough.open_topography(path).rough.detrend().rough.acf())
    for result in (quiet(G.rough.energy, E_star="25 MPa"), quiet(G.rough.gradient),
                   quiet(G.rough.patch_radius, E_star="25 MPa", gamma="50 mJ/m^2"),
                   quiet(G.rough.persson, E_star="25 MPa", p0="0.1 MPa")):
        assert result.attrs["quality"] == "failed"
        assert "26 nm" in result.attrs["quality_notes"]
    monkeypatch.chdir(tmp_path)
    assert main(["report", str(path), "--E-star", "25MPa", "--p0", "0.1MPa", "--json",
                 "-o", "afm.nc"]) == 0
    m = json.loads(capsys.readouterr().out)["measurements"][0]
    assert m["rms_gradient"]["value"] is None and m["at_dr"]["value"] is None
    assert m["quality"]["gradient"]["level"] == "failed"
