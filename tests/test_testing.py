"""xrough.testing: unit-aware assertions pass on the same physics and name what differs."""

import numpy as np
import pytest
import xarray as xr

import xrough
from xrough.testing import assert_allclose, assert_netcdf_round_trip, assert_units_equal


def _topo(unit="nm", factor=1.0, **attrs):
    """A 3 x 4 map of 1 nm pixels and heights 0..11 nm, written in ``unit`` (factor from nm)."""
    h = np.arange(12.0).reshape(3, 4) * factor
    return xrough.topography(h, spacing=factor, unit=unit, attrs=attrs or None)


def _G(unit="nm", factor=1.0):
    """G of a model spectrum in nm2 over lags in nm, or the same in ``unit`` (factor from nm)."""
    C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
                              rms_gradient=0.5, unit="nm")
    G = xrough.acf_from_spectrum(C, np.geomspace(1.3, 9e4, 21))
    out = G.copy(data=G.values * factor**2).assign_attrs(units=f"{unit}2")
    return out.assign_coords(dr=("dr", G.dr.values * factor, {**G.dr.attrs, "units": unit}))


def test_units_equal_by_meaning_and_named_where_not():
    topo = _topo()
    assert_units_equal(topo, topo.assign_attrs(units="nanometer"))
    assert_units_equal(_G(), _G().assign_attrs(units="nm^2"))
    with pytest.raises(AssertionError, match="y: units 'nm' != 'um'"):
        assert_units_equal(topo, topo.assign_coords(y=topo.y.assign_attrs(units="um")))
    with pytest.raises(AssertionError, match="<data>: units 'nm' != None"):
        assert_units_equal(topo, topo.assign_attrs(units=None).drop_attrs())
    with pytest.raises(AssertionError, match="variables differ: \\['scan'\\]"):
        assert_units_equal(topo, topo.assign_coords(scan=0))


def test_allclose_converts_data_and_coords_to_the_first_units():
    """The same G in nm, um and m: equal to 1e-12 (the factors are exact decimals; the
    products differ from the nm values by float64 round-off only, ~1e-16)."""
    for unit, factor in (("um", 1e-3), ("m", 1e-9)):
        assert_allclose(_G(), _G(unit, factor), rtol=1e-12)
        assert_allclose(_G(unit, factor), _G(), rtol=1e-12)
    wrong_lags = _G("um", 1e-3).assign_coords(dr=_G().dr.assign_attrs(units="um"))
    with pytest.raises(AssertionError, match="dr"):
        assert_allclose(_G(), wrong_lags, rtol=1e-6)
    with pytest.raises(AssertionError, match="<data>"):
        assert_allclose(_G(), _G("um", 1e-3) * 1.001, rtol=1e-6)


def test_allclose_atol_with_units_applies_to_its_dimension_only():
    nm, um = _topo(), _topo("um", 1e-3)
    shifted = um + 1e-9  # 1e-6 nm higher, same coords
    assert_allclose(nm, shifted, rtol=0, atol="0.01 nm")
    assert_allclose(nm, shifted, rtol=0, atol=xrough.units.ureg.Quantity(1e-5, "nm"))
    with pytest.raises(AssertionError, match="<data>"):
        assert_allclose(nm, shifted, rtol=0, atol="1e-9 nm")
    with pytest.raises(AssertionError, match="<data>"):  # a pressure is no height
        assert_allclose(nm, shifted, rtol=0, atol="1 MPa")
    with pytest.raises(ValueError, match="atol"):
        assert_allclose(nm, shifted, rtol=0, atol="1 parsec-ish")


def test_allclose_refuses_incompatible_units_and_compares_others_exactly():
    topo = _topo()
    with pytest.raises(AssertionError, match="<data>: units 'Pa' cannot be converted to 'nm'"):
        assert_allclose(topo, topo.assign_attrs(units="Pa"))
    stack = xr.concat([topo, topo], dim="scan").assign_coords(scan=[0, 1])
    assert_allclose(stack, stack.copy())
    with pytest.raises(AssertionError, match="scan"):
        assert_allclose(stack, stack.assign_coords(scan=[0, 2]))
    ds = xr.Dataset({"G": _G()})
    assert_allclose(ds, xr.Dataset({"G": _G("m", 1e-9)}), rtol=1e-12)
    with pytest.raises(AssertionError, match="types differ"):
        assert_allclose(_G(), ds)


def test_netcdf_round_trip_returns_the_identical_object(tmp_path):
    topo = _topo(instrument="AFM", note="é ü")
    back = assert_netcdf_round_trip(topo, tmp_path / "t.nc")
    xr.testing.assert_identical(back, topo)
    assert (tmp_path / "t.nc").exists()
    ds = xrough.elastic_energy(_G(), E_star="25 MPa")
    assert_netcdf_round_trip(ds, tmp_path / "e.nc")
    # a one-element list attribute comes back as a scalar: not identical, and said so
    with pytest.raises(AssertionError, match="not identical"):
        assert_netcdf_round_trip(_topo(factors=[2.0]), tmp_path / "f.nc")
