"""Windows that stated tips set in stitching (xrough.stitching, xrough.preprocess).

A topography without ``reliable_dr_min`` whose metadata state a tip or stylus radius gets
the short end of its window from the tip rule, as ``acf()`` does (``tip_window``); one
whose tip resolves no lag of its window is left out, with a warning; ``windows=`` wins.
"""

import warnings

import numpy as np
import pytest

import xrough
from conftest import uncd_measurements
from xrough.preprocess import reliability_window, reliable
from xrough.stitching import stitch, stitch_curves

STYLUS = "Radius: 2.5 µm"  # as a Dektak header states it (attr "Stylus")


@pytest.fixture(scope="module")
def surface():
    return xrough.self_affine_surface(hurst=0.8, lambda_r="20 um", lambda_s="50 nm",
                                      size="80 um", n=2**13, rms_height="0.5 um",
                                      profile=True, seed=4, unit="um")


def _parts(surface, *, coarse_tip=STYLUS, blunt=False):
    """A fine crop (4096 px of 9.8 nm, no tip stated), the whole profile at 39 nm whose
    attrs state a stylus; with ``blunt``, a third crop whose stylus (1 mm) resolves no lag
    of it."""
    fine = surface.isel(x=slice(0, 4096)).assign_attrs(periodic=0)
    coarse = surface.isel(x=slice(None, None, 4)).assign_attrs(Stylus=coarse_tip)
    parts = {"fine": fine, "coarse": coarse}
    if blunt:
        parts["blunt"] = surface.isel(x=slice(4096, 6144)).assign_attrs(
            periodic=0, Stylus="Radius: 1 mm")
    return parts


def _rows_below(curves, name, dr_min):
    """The bins of ``name``'s row below ``dr_min`` that hold data."""
    row = curves.sel(measurement=name)
    below = curves.dr.values < dr_min
    return int(np.isfinite(row.G.values[below]).sum() + row.pair_count.values[below].sum())


def test_stated_stylus_sets_the_short_end_as_acf_does(surface):
    parts = _parts(surface)
    curves = stitch_curves(parts, points_per_decade=5)
    # the tip rule's cutoff, as acf() records it (reliable_dr_min of its G)
    want = parts["coarse"].rough.acf().attrs["reliable_dr_min"]
    pixels4 = 4 * float(parts["coarse"].x[1] - parts["coarse"].x[0])
    assert want > 10 * pixels4  # the tip, not the pixels, limits
    lo = float(curves.dr_min.sel(measurement="coarse"))
    assert lo == pytest.approx(want, rel=1e-12)
    rule = str(curves.window_rule.sel(measurement="coarse").values)
    assert rule.startswith("dr_min: tip rule") and "2.5 um" in rule and "'Stylus'" in rule
    assert "tip rule" in curves.attrs["window_rules"]
    # nothing of the coarse part below its tip window; the fine one untouched (4 pixels)
    assert _rows_below(curves, "coarse", lo) == 0
    assert np.isfinite(curves.G.sel(measurement="coarse").values[curves.dr.values >= lo]).any()
    fine_rule = str(curves.window_rule.sel(measurement="fine").values)
    assert fine_rule.startswith("dr_min: 4 pixels") and "tip" not in fine_rule
    assert "'coarse': G from" in curves.attrs["quality_remarks"]
    G = stitch(curves)
    bit = 2 ** ["fine", "coarse"].index("coarse")
    covered = (G.coverage.values & bit) > 0
    assert covered.any() and (G.dr.values[covered] >= lo).all()
    assert "tip rule" in G.attrs["window_rules"] and G.attrs["left_out"] == ""
    assert "'coarse': G from" in G.attrs["quality_remarks"]
    assert G.attrs["quality"] == "good" and G.attrs["quality_notes"] == ""


def test_no_stated_tip_keeps_the_default_window(surface):
    parts = _parts(surface)
    parts["coarse"] = parts["coarse"].assign_attrs(Stylus="")  # states nothing
    curves = stitch_curves(parts, points_per_decade=5)
    pixel = float(parts["coarse"].x[1] - parts["coarse"].x[0])
    assert float(curves.dr_min.sel(measurement="coarse")) == pytest.approx(4 * pixel)
    assert "tip" not in curves.attrs["window_rules"]
    assert "quality_remarks" not in curves.attrs and curves.attrs["left_out"] == ""
    # reliable=False (as for acf): the stated tip is not applied
    unapplied = stitch_curves(_parts(surface), points_per_decade=5, reliable=False)
    assert float(unapplied.dr_min.sel(measurement="coarse")) == pytest.approx(4 * pixel)


def test_tip_that_resolves_nothing_leaves_the_part_out(surface):
    parts = _parts(surface, blunt=True)
    with pytest.warns(xrough.QualityWarning, match="measurement 'blunt' left out") as rec:
        curves = stitch_curves(parts, points_per_decade=5)
    said = [str(w.message) for w in rec if "left out" in str(w.message)]
    assert len(said) == 1 and "tip radius 1 mm" in said[0] and "'Stylus'" in said[0]
    assert "resolves no lag" in said[0]
    assert list(curves.measurement.values) == ["fine", "coarse"]
    assert curves.attrs["left_out"] == "blunt"
    with warnings.catch_warnings(record=True) as again:
        warnings.simplefilter("always")
        G = stitch(curves)  # said once, by stitch_curves; G carries it
    assert not [w for w in again if "left out" in str(w.message)]
    assert G.attrs["stitched_from"] == "fine, coarse" and G.attrs["left_out"] == "blunt"
    assert G.attrs["quality"] == "questionable"
    assert "measurement 'blunt' left out" in G.attrs["quality_notes"]
    assert int(G.quality_flag) == 1
    # stitch() on the measurements: one warning too
    with pytest.warns(xrough.QualityWarning, match="'blunt' left out") as rec:
        G2 = stitch(parts, points_per_decade=5)
    assert len([w for w in rec if "left out" in str(w.message)]) == 1
    np.testing.assert_allclose(G2.values, G.values)
    # all parts left out: an error, not an empty G
    with pytest.raises(ValueError, match="every measurement is left out"):
        stitch_curves({"blunt": parts["blunt"]})


def test_windows_override_wins_over_the_tip(surface):
    parts = _parts(surface, blunt=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error", xrough.QualityWarning)  # nothing left out
        curves = stitch_curves(parts, points_per_decade=5,
                               windows={"blunt": ("0.1 um", None), "coarse": (0.3, None)})
    assert list(curves.measurement.values) == ["fine", "coarse", "blunt"]
    assert float(curves.dr_min.sel(measurement="blunt")) == pytest.approx(0.1)
    assert float(curves.dr_min.sel(measurement="coarse")) == pytest.approx(0.3)
    rule = str(curves.window_rule.sel(measurement="blunt").values)
    assert rule.startswith("dr_min: windows= override (the tip radius 1 mm")
    assert curves.attrs["left_out"] == "" and "quality_remarks" not in curves.attrs
    # an override of the long end only leaves the short end to the tip: empty, said
    with pytest.raises(ValueError, match="'blunt'.*give windows\\['blunt'\\] a dr_min"):
        stitch_curves(parts, points_per_decade=5, windows={"blunt": (None, 10.0)})


def test_precomputed_G_keeps_its_recorded_window(surface):
    parts = _parts(surface)
    G_coarse = parts["coarse"].rough.acf()
    lo, _ = reliability_window(G_coarse)
    curves = stitch_curves({"fine": parts["fine"], "coarse": G_coarse}, points_per_decade=5)
    assert float(curves.dr_min.sel(measurement="coarse")) == pytest.approx(lo)
    assert "reliable_dr (recorded)" in str(curves.window_rule.sel(measurement="coarse").values)
    ref = stitch_curves(parts, points_per_decade=5)
    assert float(curves.dr_min.sel(measurement="coarse")) == pytest.approx(
        float(ref.dr_min.sel(measurement="coarse")))
    assert _rows_below(curves, "coarse", lo) == 0


def test_lazy_map_with_a_stated_tip_says_it_was_not_applied(surface):
    """The tip rule reads the whole map and the window must be known before compute: a
    lazy map keeps its default window, with a remark saying how to apply the tip
    (reliable() first, as the remark spells it: then the same window as in memory)."""
    parts = _parts(surface)
    lazy = {**parts, "coarse": parts["coarse"].chunk()}
    curves = stitch_curves(lazy, points_per_decade=5)
    pixel = float(parts["coarse"].x[1] - parts["coarse"].x[0])
    assert float(curves.dr_min.sel(measurement="coarse")) == pytest.approx(4 * pixel)
    remark = curves.attrs["quality_remarks"]
    assert "'coarse': the tip radius 2.5 um" in remark and "is not applied" in remark
    assert "xrough.reliable(topography, tip_radius='2.5 um', min_pixels=4, " \
           "long_fraction=0.25)" in remark
    G = stitch(lazy, points_per_decade=5)
    assert G.chunks is not None and "quality" not in G.attrs  # verdict after compute only
    assert "is not applied" in G.attrs["quality_remarks"]
    # applied as the remark says, lazily: the window of the map in memory
    recorded = reliable(parts["coarse"], tip_radius="2.5 um", min_pixels=4,
                        long_fraction=0.25).chunk()
    eager = stitch_curves(parts, points_per_decade=5)
    done = stitch_curves({**parts, "coarse": recorded}, points_per_decade=5)
    np.testing.assert_allclose(done.dr_min.values, eager.dr_min.values)
    np.testing.assert_allclose(done.G.values, eager.G.values, equal_nan=True)


@pytest.mark.data
def test_uncd_tips_set_the_windows():
    """UNCD as meta.yml describes it: the AFM's 26 nm tip resolves no lag of its window
    (the tip rule's 44.4 nm, measured, lies beyond a quarter of the 100 nm scan: left out,
    questionable, one warning naming it); the stylus starts where acf()
    puts its limit (tip 5 um: 2.07 um, measured), not at 4 pixels (0.40 um)."""
    meas = uncd_measurements()  # detrend modes of meta.yml
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        curves = stitch_curves(meas, unit="nm")
        G = stitch(curves)
    said = [str(w.message) for w in caught if "left out" in str(w.message)]
    assert len(said) == 1 and "'AFM'" in said[0] and "26 nm" in said[0]
    assert "the cutoff of the tip rule, 44.38 nm, is not below the window's long end 25 nm" \
        in said[0]
    assert list(curves.measurement.values) == ["TEM", "stylus"]
    assert G.attrs["left_out"] == "AFM" and G.attrs["stitched_from"] == "TEM, stylus"
    assert G.attrs["quality"] == "questionable" and "'AFM' left out" in G.attrs["quality_notes"]
    # the stylus: acf()'s own reliable_dr_min of that topography (mm), in nm
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        G_sty = meas["stylus"].rough.acf()
    want = G_sty.attrs["reliable_dr_min"] * xrough.units.conversion_factor(
        G_sty.attrs["reliable_dr_units"], "nm")
    lo = float(curves.dr_min.sel(measurement="stylus"))
    assert lo == pytest.approx(want, rel=1e-9)
    assert 2000 < lo < 2100  # 2.07 um (the 4-pixel default: 398 nm)
    assert _rows_below(curves, "stylus", lo) == 0
    bit = 2 ** G.attrs["stitched_from"].split(", ").index("stylus")
    assert (G.dr.values[(G.coverage.values & bit) > 0] >= lo).all()
    assert "'stylus': G from 0.00207 mm" in G.attrs["quality_remarks"]
    # the gap TEM/stylus is wider: 58 nm to the stylus's tip window
    np.testing.assert_allclose(G.attrs["uncovered_dr_max"], [lo])
