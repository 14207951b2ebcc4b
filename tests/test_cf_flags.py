"""Flag variables follow CF (1.10, sec. 3.5): ``flag_values`` / ``flag_masks`` are arrays of
the variable's own type (they were strings, "0 1 2", which cf-xarray cannot decode), and a
reopened archive's flags decode with cf-xarray, through xrough or plain xarray."""

import warnings

import numpy as np
import pytest
import xarray as xr

import xrough
from xrough.quality import cf_flags

cf_xarray = pytest.importorskip("cf_xarray")


def test_cf_flags_are_arrays_of_the_variables_type():
    attrs = cf_flags(["good", "questionable", "failed"], np.int8)
    assert attrs["flag_values"].dtype == np.int8 and attrs["flag_values"].tolist() == [0, 1, 2]
    masks = cf_flags(["a", "b", "c"], np.int16, masks=True)["flag_masks"]
    assert masks.dtype == np.int16 and masks.tolist() == [1, 2, 4]
    with pytest.raises(ValueError, match="single words"):
        cf_flags(["two words"], np.int8)


@pytest.fixture(scope="module")
def reopened(tmp_path_factory):
    path = tmp_path_factory.mktemp("flags") / "flags.nc"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        topo = xrough.self_affine_surface(hurst=0.8, lambda_r=32.0, lambda_s=4.0, size=128.0,
                                          n=128, rms_gradient=0.1, unit="nm", seed=0)
        G = topo.rough.acf()
        fit = G.rough.fit()
        gbar = G.rough.gradient(fit=fit)
        contact = G.rough.persson(E_star="25 MPa", p0="0.15 MPa", fit=fit)
    xrough.save_analysis(path, {"m": {"G": G, "fit": fit, "gradient": gbar,
                                      "persson": contact}})
    return path, fit


def test_reopened_flags_decode_with_cf_xarray(reopened):
    path, fit = reopened
    analysis = xrough.open_analysis(path)["m"]
    plain = xr.open_dataset(path, group="m/fit")
    # plain CF for other tools: xrough's own attributes are one global attribute, no
    # xrough_object, xrough_dataarray_name or xrough_sha256 in the groups any more
    assert not [name for attrs in (plain.attrs, *(v.attrs for v in plain.variables.values()))
                for name in attrs if name.startswith("xrough_") and name != "xrough_version"]
    for ds in (analysis["fit"], plain):
        shape = ds.rolloff_shape
        assert bool(shape.cf == str(fit.rolloff_shape.attrs["flag_meanings"].split()[
            int(fit.rolloff_shape)]))
        assert shape.attrs["flag_values"].dtype == shape.dtype
        assert ds.fit_problems.attrs["flag_masks"].dtype == ds.fit_problems.dtype
    flag = analysis["persson"].quality_flag
    assert flag.attrs["flag_values"].dtype == np.int8
    assert bool(flag.cf == analysis["persson"].attrs["quality"])
    route = analysis["gradient"].gradient_method
    assert route.attrs["flag_values"].dtype == np.int8
    meanings = route.attrs["flag_meanings"].split()
    assert bool(route.cf == meanings[int(route)])


def test_a_written_topography_says_its_conventions(tmp_path):
    """io.netcdf.write left the file without a global Conventions (the archives had it)."""
    from xrough.io import netcdf

    topo = xrough.topography(np.arange(12.0).reshape(3, 4), spacing="2 nm", unit="nm")
    netcdf.write(topo, tmp_path / "t.nc")
    with xr.open_dataset(tmp_path / "t.nc") as ds:
        assert ds.attrs["Conventions"] == "CF-1.10"
    assert netcdf.read(tmp_path / "t.nc").identical(topo)
