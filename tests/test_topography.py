"""Topography construction, validation, units and the NetCDF contract."""

import numpy as np
import pint
import pytest
import xarray as xr

import xrough
from xrough import units as u
from xrough.testing import assert_netcdf_round_trip


def test_from_array_with_string_spacing_and_units():
    h = np.arange(12.0).reshape(3, 4)
    topo = xrough.topography(h, spacing=("2 nm", "0.5 nm"), unit="nm", periodic=True)
    assert topo.dims == ("y", "x")
    assert topo.attrs["units"] == "nm" and topo.attrs["periodic"] == 1
    np.testing.assert_allclose(topo.x, [0, 0.5, 1.0, 1.5])
    np.testing.assert_allclose(topo.y, [0, 2, 4])
    assert topo.x.attrs["units"] == "nm" and topo.y.attrs["units"] == "nm"


def test_size_and_units_conversions():
    topo = xrough.topography(np.zeros((4, 8)), size=("4 um", "8 um"), unit="nm")
    np.testing.assert_allclose(float(topo.x[1]), 1000.0)
    # plain-number spacing is in the lateral unit; without one it is refused
    topo_nm = xrough.topography(np.zeros(10), spacing=5, unit="nm")
    np.testing.assert_allclose(float(topo_nm.x[1]), 5.0)
    topo_um = xrough.topography(np.zeros(10), spacing="5 nm", height_unit="um")
    assert topo_um.x.attrs["units"] == "nm" and topo_um.attrs["units"] == "um"
    with pytest.raises(ValueError, match="plain-number spacing needs a lateral unit"):
        xrough.topography(np.zeros(10), spacing=5, height_unit="nm")


def test_pint_quantity_heights_and_profile():
    q = np.linspace(0, 1, 11) * u.ureg.micrometer
    topo = xrough.topography(q, spacing=u.ureg.Quantity(0.1, "um"))
    assert topo.dims == ("x",)
    assert topo.attrs["units"] == "um"
    assert topo.x.attrs["units"] == "um"


def test_height_unit_differs_from_lateral_unit():
    topo = xrough.topography(np.zeros((3, 3)), spacing=1.0, unit="um", height_unit="nm")
    assert topo.attrs["units"] == "nm" and topo.x.attrs["units"] == "um"
    G = topo.rough.acf()
    assert G.attrs["units"] == "nm2" and G.dr.attrs["units"] == "um"


def test_dataarray_input_keeps_metadata():
    da = xr.DataArray(np.ones((3, 4)), dims=("y", "x"),
                      coords={"x": ("x", np.arange(4.0), {"units": "um"}),
                              "y": ("y", np.arange(3.0), {"units": "um"})},
                      attrs={"units": "nm", "instrument": "AFM"}, name="h")
    topo = xrough.topography(da)
    assert topo.attrs["instrument"] == "AFM" and topo.name == "h"
    assert topo.attrs["periodic"] == 0


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"heights": np.zeros((3, 3)), "spacing": 1.0}, "need a unit"),
        ({"heights": np.zeros((3, 3)), "unit": "nm"}, "spacing or the physical size"),
        ({"heights": np.zeros((2, 3, 3)), "spacing": 1.0, "unit": "nm"}, "2D .* or 1D"),
        ({"heights": np.zeros((3, 3)), "spacing": 1.0, "unit": "Pa"}, "must be a length"),
        ({"heights": np.zeros((3, 3)), "spacing": "1 s", "unit": "nm"}, "not a length"),
        ({"heights": np.zeros((3, 3)), "spacing": -1.0, "unit": "nm"}, "positive length"),
        ({"heights": np.zeros((3, 3)), "spacing": 1.0, "size": 2.0, "unit": "nm"},
         "either spacing or size"),
        ({"heights": np.array([[1.0, np.inf], [0, 0]]), "spacing": 1.0, "unit": "nm"},
         "infinite"),
        ({"heights": np.full((3, 3), np.nan), "spacing": 1.0, "unit": "nm"},
         "fewer than 2 valid"),
        ({"heights": np.zeros((1, 5)), "spacing": 1.0, "unit": "nm"}, "at least 2 points"),
        ({"heights": np.array(["a", "b"]), "spacing": 1.0, "unit": "nm"}, "real numbers"),
        ({"heights": np.zeros(4), "spacing": 1.0, "unit": "parsec2"}, "cannot understand"
         "|must be a length"),
    ],
)
def test_constructor_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        xrough.topography(**kwargs)


def test_non_uniform_coordinate_named():
    da = xr.DataArray(np.zeros((3, 4)), dims=("y", "x"),
                      coords={"x": ("x", [0.0, 1.0, 2.0, 3.5], {"units": "nm"}),
                              "y": ("y", [0.0, 1.0, 2.0], {"units": "nm"})},
                      attrs={"units": "nm"})
    with pytest.raises(ValueError, match="coordinate 'x' is not uniformly spaced"):
        xrough.topography(da)


def test_relabelling_units_is_refused():
    topo = xrough.topography(np.zeros(4), spacing=1.0, unit="nm")
    with pytest.raises(ValueError, match="already have units"):
        xrough.topography(topo, unit="um")


def test_units_parsing_and_formatting():
    assert u.format_units(u.parse_units("J m-2")) == "J m-2"
    assert u.format_units(u.parse_units("mJ/m^2")) == "mJ m-2"
    assert u.format_units(u.parse_units("um") ** 2) == "um2"
    assert u.format_units(u.parse_units("µm")) == "um"
    assert u.conversion_factor("um", "nm") == 1000.0
    assert u.to_si("25 MPa", "[pressure]", what="E_star") == 25e6
    assert u.to_si(u.ureg.Quantity(3, "kPa"), "[pressure]", what="p0") == 3000.0
    with pytest.raises(ValueError, match="E_star.*not a pressure"):
        u.to_si("25 nm", "[pressure]", what="E_star")
    with pytest.raises(ValueError, match="cannot understand"):
        u.parse_units("furlongs per blorg squared")
    # quantities from another registry are accepted
    other = pint.UnitRegistry()
    assert u.to_si(other.Quantity(2, "nm"), "[length]", what="dx") == pytest.approx(2e-9)


@pytest.mark.parametrize("text, expected", [
    ("50 mJ/m2", ("[mass] / [time] ** 2", 0.05)),
    ("1 J/m2", ("[mass] / [time] ** 2", 1.0)),
    ("25 N/mm2", ("[pressure]", 25e6)),
    ("3 kg*m/s2 / mm2", ("[pressure]", 3e6)),
    ("1e-6 m", ("[length]", 1e-6)),
])
def test_unit_strings_as_people_write_them(text, expected):
    """Powers glued to a symbol ("m2") parse inside pint's grammar ("mJ/m2") as they do in
    a CF product ("J m-2"); an exponent after a number ("1e-6") stays a number."""
    dimension, si = expected
    assert u.to_si(text, dimension, what="x") == pytest.approx(si, rel=1e-12)


def test_unit_in_the_wrong_case_is_named_with_a_suggestion():
    with pytest.raises(ValueError) as err:
        u.quantity("25 MPA", what="E_star")
    message = str(err.value)
    assert message.startswith("E_star: 'MPA' is not a unit (did you mean 'MPa'")
    assert message.count("MPA") == 2  # the symbol and the value, not the prefix twice more


def test_netcdf_round_trip_topography_and_G(tmp_path):
    rng = np.random.default_rng(0)
    h = rng.normal(size=(16, 20))
    h[rng.random(h.shape) < 0.1] = np.nan
    topo = xrough.topography(h, spacing=("3 nm", "2 nm"), unit="nm", periodic=False,
                             attrs={"instrument": "AFM", "tip_radius": 5.0})
    G = topo.rough.acf()
    Gr = topo.rough.acf(estimator="random", n_pairs=2000, seed=1)
    for k, da in enumerate((topo, G, Gr)):
        path = tmp_path / f"a{k}.nc"
        assert_netcdf_round_trip(da, path)


def test_netcdf_round_trip_synthetic_and_stack(tmp_path):
    topo = xrough.self_affine_surface(hurst=0.3, lambda_r="1 um", lambda_s="80 nm",
                                      size="2 um", n=64, rms_height="3 nm", seed=2,
                                      unit="nm")
    stack = xr.concat([topo, topo * 2], dim=xr.DataArray(["a", "b"], dims="scan",
                                                          name="scan"))
    G = stack.rough.acf()
    for k, da in enumerate((topo, G)):
        path = tmp_path / f"b{k}.nc"
        assert_netcdf_round_trip(da, path)


def test_plots_return_axes():
    topo = xrough.topography(np.random.default_rng(0).normal(size=(16, 16)), spacing=1.0,
                             unit="nm")
    ax = topo.rough.plot()
    assert ax.get_ylabel() == "y position (nm)"
    ax = topo.isel(y=0).rough.plot()
    assert ax.get_ylabel() == "height (nm)"
    G = topo.rough.acf()
    ax = G.rough.plot()
    assert "nm²" in ax.get_ylabel() and ax.get_xscale() == "log"
    stack = xr.concat([topo, 2 * topo], dim="scan").rough.acf()
    ax = stack.rough.plot()
    assert len(ax.get_lines()) == 2
    with pytest.raises(ValueError, match="one map"):
        xr.concat([topo, topo], dim="scan").rough.plot()


def test_plot_labels_and_profile_stacks():
    topo = xrough.topography(np.random.default_rng(0).normal(size=(16, 16)), spacing=1.0,
                             unit="nm")
    ax = topo.rough.acf().rough.plot(label="my map")
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["my map"]
    profiles = xr.concat([topo.isel(y=0), topo.isel(y=1)], dim="scan")
    ax = profiles.rough.plot()
    assert len(ax.get_lines()) == 2


# --------------------------------------------------------------------------------------
# convert_units: the same surface in other units
# --------------------------------------------------------------------------------------
def _surface_in(unit):
    return xrough.self_affine_surface(hurst=0.8, lambda_r="1 um", lambda_s="200 nm",
                                      size="4 um", n=64, rms_gradient=0.5, seed=3,
                                      unit=unit)


def test_convert_units_is_the_same_surface_as_generated_in_those_units():
    """Metres converted to nm heights and um coordinates equal the surface generated with
    those units (rtol 1e-12: the same random amplitudes, scaled once in each route), and
    G, a function of the physical surface, follows (rtol 1e-10)."""
    in_m = _surface_in("m")
    out = xrough.convert_units(in_m, "nm", lateral="um")
    in_nm = _surface_in("nm")
    assert out.attrs["units"] == "nm" and out.x.attrs["units"] == out.y.attrs["units"] == "um"
    np.testing.assert_allclose(out.values, in_nm.values, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(out.x.values, in_nm.x.values * 1e-3, rtol=1e-12, atol=1e-15)
    # model attrs: q in 1/um, C_r in nm^2 um^2, rms height in nm, the slope unchanged
    assert out.attrs["q_r"] == pytest.approx(in_nm.attrs["q_r"] * 1e3, rel=1e-12)
    assert out.attrs["C_r"] == pytest.approx(in_nm.attrs["C_r"] * 1e-6, rel=1e-12)
    assert out.attrs["rms_height"] == pytest.approx(in_nm.attrs["rms_height"], rel=1e-12)
    assert out.attrs["rms_gradient"] == pytest.approx(0.5, rel=1e-12)
    G_m, G_conv = in_m.rough.acf(), out.rough.acf()
    assert G_conv.attrs["units"] == "nm2" and G_conv.dr.attrs["units"] == "um"
    np.testing.assert_allclose(G_conv.values, G_m.values * 1e18, rtol=1e-10)
    np.testing.assert_allclose(G_conv.dr.values, G_m.dr.values * 1e6, rtol=1e-12)


@pytest.mark.parametrize("height, lateral", [("um", None), (None, "mm"),
                                             (u.ureg.nm, u.ureg.Unit("km"))])
def test_convert_units_round_trip_and_forms(height, lateral):
    """String and pint.Unit forms; converting back restores values to round-off (1e-14)
    and keeps every attribute."""
    topo = _surface_in("nm").rough.reliable(min_pixels=2)
    out = xrough.convert_units(topo, height, lateral=lateral)
    back = xrough.convert_units(out, "nm", lateral="nm")
    np.testing.assert_allclose(back.values, topo.values, rtol=1e-14)
    np.testing.assert_allclose(back.x.values, topo.x.values, rtol=1e-14)
    assert back.attrs.keys() == topo.attrs.keys()
    # the reliability window is the same physical window in the new unit
    factor = u.conversion_factor("nm", out.x.attrs["units"])
    lo, hi = xrough.reliability_window(topo)
    assert xrough.reliability_window(out) == pytest.approx((lo * factor, hi * factor))


def test_convert_units_keeps_dtype_and_dask_laziness():
    topo = _surface_in("m").astype(np.float32)
    topo.attrs = _surface_in("m").attrs
    out = xrough.convert_units(topo, "nm")
    assert out.dtype == np.float32
    np.testing.assert_allclose(out.values, topo.values.astype(np.float64) * 1e9, rtol=1e-6)
    lazy = xrough.convert_units(topo.chunk({"y": 16}), "nm", lateral="um")
    assert lazy.chunks is not None and lazy.chunksizes["y"] == (16,) * 4
    np.testing.assert_array_equal(lazy.values, out.values)


@pytest.mark.parametrize("kwargs, match", [
    ({"height": "MPa"}, "height must be a length"),
    ({"lateral": "s"}, "lateral must be a length"),
    ({"lateral": "um2"}, "lateral must be a length"),
    ({"height": "nmm"}, "nmm"),
])
def test_convert_units_refuses_what_is_not_a_length(kwargs, match):
    with pytest.raises(ValueError, match=match):
        xrough.convert_units(_surface_in("nm"), **kwargs)


def test_convert_units_needs_a_topography():
    G = _surface_in("nm").rough.acf()
    with pytest.raises(ValueError, match="dim"):
        xrough.convert_units(G, "um")
