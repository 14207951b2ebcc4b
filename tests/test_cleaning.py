"""Results that depend on how a map was cleaned: the chain once per choice, compared."""

import json
import warnings

import numpy as np
import pytest

import xrough
from conftest import data_path
from xrough.cli import main
from xrough.toolbox.cleaning import DIFFER, cleaning_sensitivity

E_STAR, P0 = "25 MPa", "0.1 MPa"
QUANTITIES = ("gbar", "v_el", "a_r", "hurst")


def _surface(seed=1):
    topo = xrough.self_affine_surface(hurst=0.7, lambda_r="64 nm", lambda_s="4 nm",
                                      size="256 nm", n=256, rms_gradient=0.2, seed=seed,
                                      unit="nm")
    topo.attrs["periodic"] = 0
    return topo


def _with_line_offsets(topo, seed=1, scale=1.0):
    """What an AFM records: each scan line (row) shifted by its own offset."""
    rows = np.random.default_rng(seed).normal(scale=scale, size=(topo.sizes["y"], 1))
    return topo + rows


def _compare(topo, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        return cleaning_sensitivity(topo, E_star=E_STAR, p0=P0, **kw)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_clean_map_does_not_depend_on_its_levelling(seed):
    """An isotropic map without line offsets: the three cleanings agree within their
    errors (measured |z| <= 1.2), and nothing is marked."""
    found = _compare(_surface(seed))
    assert found.choice.values.tolist() == ["plane", "line by line",
                                            "plane, outliers masked"]
    for q in QUANTITIES:
        z = found[f"z_{q}"].values
        assert z[0] == 0.0 and np.all(np.abs(z[np.isfinite(z)]) <= DIFFER)
    assert "quality" not in found.attrs


def test_line_offsets_make_the_result_depend_on_the_levelling():
    """Scan lines shifted by offsets of 1 nm (5 times the pixel step's rms): a plane
    leaves them in G (gbar at one pixel 1.38 against the surface's 0.2), line by line
    removes them (0.19); gbar, v_el and a_r are marked with both values, each z the
    difference over the combined standard deviation."""
    found = _compare(_with_line_offsets(_surface()))
    assert found.attrs["quality"] == "questionable"
    notes = found.attrs["quality_notes"]
    for q in ("gbar", "v_el", "a_r"):
        assert f"{q} depends on the cleaning" in notes and "'line by line' gives" in notes
        v, s = found[q].values, found[f"{q}_std"].values
        np.testing.assert_allclose(found[f"z_{q}"].values[1], (v[1] - v[0]) / np.hypot(
            s[1], s[0]), rtol=1e-12)
        assert abs(float(found[f"z_{q}"].values[1])) > DIFFER
    line = float(found.gbar.sel(choice="line by line"))
    assert line == pytest.approx(0.2, rel=0.1)  # the surface's own gradient at 1 px
    assert float(found.gbar.sel(choice="plane")) > 5 * line
    assert found.dr.attrs["units"] == "nm" and float(found.dr) == pytest.approx(1.0)


def test_the_comparison_is_the_same_in_every_unit():
    """nm against m: the same z (to 1e-5: H comes from an iterative fit, which lands
    within 3.5e-6 of itself in the other unit under the oldest supported scipy), the lag
    in the map's unit."""
    topo = _with_line_offsets(_surface())
    nm = _compare(topo)
    m = _compare(xrough.convert_units(topo, "m", lateral="m"))
    for q in QUANTITIES:
        np.testing.assert_allclose(m[f"z_{q}"].values, nm[f"z_{q}"].values, rtol=1e-5,
                                   atol=1e-9)
    assert float(m.dr) == pytest.approx(1e-9) and m.dr.attrs["units"] == "m"


def test_bad_input_is_refused_with_a_clear_message():
    topo = _surface()
    with pytest.raises(ValueError, match="one map"):
        cleaning_sensitivity(topo.isel(y=0), E_star=E_STAR, p0=P0)
    with pytest.raises(ValueError, match="at least two"):
        cleaning_sensitivity(topo, E_star=E_STAR, p0=P0,
                             choices={"plane": lambda t: t.rough.detrend()})
    with pytest.raises(ValueError, match="E_star"):
        cleaning_sensitivity(topo, E_star="-25 MPa", p0=P0)


@pytest.mark.data
def test_report_compares_the_cleaning_of_a_real_map(tmp_path, capsys):
    """di-1.di: a line per scan line instead of a plane moves gbar at one pixel from 0.77
    to 0.35 (z = -54) and a_r by 28 of its errors (measured); the report marks them with
    both values and the JSON gives every choice."""
    path = data_path("instruments", "di-1.di")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = main(["report", str(path), "--E-star", "25MPa", "--p0", "0.1MPa",
                     "--compare-cleaning", "--json", "-o", str(tmp_path / "r.nc")])
    assert code == 0
    record = json.loads(capsys.readouterr().out)["measurements"][0]
    choices = record["cleaning"]["choices"]
    assert list(choices) == ["as reported (plane)", "line by line",
                             "plane, outliers masked"]
    assert choices["line by line"]["gbar"]["z"] < -DIFFER
    assert record["quality"]["gradient"]["level"] == "questionable"
    assert any("gbar depends on the cleaning" in n
               for n in record["quality"]["gradient"]["notes"])
