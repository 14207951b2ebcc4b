"""One call archives a whole analysis; reopening gives identical objects."""

import numpy as np
import pytest
import xarray as xr

import xrough


def _analysis():
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="100 nm",
                                      size="8 um", n=256, rms_gradient=0.5, seed=1,
                                      unit="nm")
    G = topo.rough.acf()
    return {
        "topography": topo,
        "G": G,
        "fit": G.rough.fit(),
        "persson": G.rough.persson(E_star="25 MPa", p0=[1e5, 1e6]),
        "energy": G.rough.energy(E_star="25 MPa"),
        "patch": G.rough.patch_radius(E_star="25 MPa", gamma="50 mJ/m^2"),
    }


def test_round_trip_of_several_measurements(tmp_path):
    one = _analysis()
    other = {"G": one["G"] * 2}
    other["G"].attrs = one["G"].attrs
    path = xrough.save_analysis(tmp_path / "a.nc", {"afm": one, "stylus": other},
                                history="xrough report afm.x3p")
    back = xrough.open_analysis(path)
    for key, value in one.items():
        assert type(back["afm"][key]) is type(value)
        xr.testing.assert_identical(back["afm"][key], value)
    xr.testing.assert_identical(back["stylus"]["G"], other["G"])
    prov = back["_provenance"]
    assert prov["xrough_version"] == xrough.__version__
    assert prov["Conventions"].startswith("CF")
    assert "xrough report afm.x3p" in prov["history"]
    # units travel with every variable
    assert back["afm"]["persson"]["sigma_c"].attrs["units"] == "Pa"
    assert back["afm"]["energy"]["v_el"].attrs["units"] == "J m-2"


def test_flat_analysis_and_bad_entries(tmp_path):
    topo = xrough.topography(np.zeros((4, 4)), spacing=1.0, unit="nm")
    back = xrough.open_analysis(xrough.save_analysis(tmp_path / "b.nc", {"topo": topo}))
    xr.testing.assert_identical(back["topo"], topo)
    with pytest.raises(TypeError, match="can only archive"):
        xrough.save_analysis(tmp_path / "c.nc", {"x": 3})
    with pytest.raises(ValueError, match="group names"):
        xrough.save_analysis(tmp_path / "d.nc", {"a/b": topo})
