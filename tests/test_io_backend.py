"""xarray backend (``engine="xrough"``) and the SurfaceTopography bridge.

Every native format is opened through ``xr.open_dataset`` and compared with
``xrough.io.open_topography``; reader modules still missing are skipped. Files read by the
bridge are compared with SurfaceTopography's own reading (its row 0 is the top of the
image, xrough's is y = 0, so its arrays are ours upside down) and with the sizes their
headers state.
"""

import importlib
import importlib.util
import re
import sys
import warnings

import numpy as np
import pytest
import xarray as xr

import xrough
from conftest import data_path
from xrough.io import BRIDGE, FORMATS, bridge, detect_format, open_topography
from xrough.io.backend import XroughBackendEntrypoint
from xrough.testing import assert_units_equal
from xrough.topography import grid_of

ENGINE = "xrough" if "xrough" in xr.backends.list_engines() else XroughBackendEntrypoint

# (format, file parts, reader options)
NATIVE = [
    ("x3p", ("instruments", "x3p-2.x3p"), {}),
    ("sur", ("instruments", "sur-2.sur"), {}),
    ("sdf", ("instruments", "sdf-1.sdf"), {}),
    ("nanoscope", ("instruments", "di-1.di"), {}),
    ("nanoscope", ("uncd", "gain_control_uncd_35_z03tr3R.001"), {}),
    ("ibw", ("instruments", "spot_1-1000nm.ibw"), {}),
    ("netcdf", ("instruments", "nc-1.nc"), {}),
    ("text", ("instruments", "matrix-3.txt"), {}),
    ("text", ("instruments", "dektak-1.csv"), {}),
    ("text", ("instruments", "xyz-1.txt"), {"unit": "nm"}),
    ("text", ("instruments", "nonuniform.asc"), {"unit": "nm"}),
    ("text", ("uncd", "uncd_stylus_300um_5mar_3_k0HpKJt.txt"), {"unit": "mm"}),
]
BRIDGED = ["plu-1.plu", "opd-1.opd", "al3d-1.al3d", "mi-1.mi", "nid-1.nid"]


def needs_module(fmt):
    if importlib.util.find_spec(FORMATS[fmt].module) is None:
        pytest.skip(f"reader module {FORMATS[fmt].module} not available yet")


def surfacetopography():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pytest.importorskip("SurfaceTopography")


def st_read(path, **kwargs):
    """Heights as xrough orients them (rows reversed), and SurfaceTopography's object."""
    st = surfacetopography()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        topo = st.open_topography(str(path)).topography(**kwargs)
        heights = np.ma.filled(np.ma.asarray(topo.heights(), dtype=float), np.nan)
    return (heights.T[::-1] if heights.ndim == 2 else heights), topo


def size_of(da, dim):
    return float(da[dim][1] - da[dim][0]) * da.sizes[dim]


def legal_attrs(attrs):
    for key, value in attrs.items():
        assert re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", key), key
        assert isinstance(value, (str, int, float)) and not isinstance(value, bool), key


# --------------------------------------------------------------------------------------
# backend


def test_backend_parameters_and_engine():
    params = XroughBackendEntrypoint.open_dataset_parameters
    for name in ("filename_or_obj", "drop_variables", "format", "size", "unit",
                 "height_unit", "height_scale", "periodic", "channel", "resample"):
        assert name in params


@pytest.mark.parametrize("fmt, parts, options", NATIVE,
                         ids=[p[-1] for _, p, _ in NATIVE])
def test_open_dataset_every_native_format(fmt, parts, options):
    needs_module(fmt)
    path = data_path(*parts)
    assert detect_format(path) == fmt
    assert XroughBackendEntrypoint().guess_can_open(str(path))
    ds = xr.open_dataset(path, engine=ENGINE, **options)
    expected = open_topography(path, **options)
    assert isinstance(ds, xr.Dataset) and list(ds.data_vars) == ["height"]
    height = ds["height"]
    assert height.dims == expected.dims and height.shape == expected.shape
    np.testing.assert_array_equal(height.values, expected.values)
    assert_units_equal(height, expected)  # data and every coord
    for d in expected.dims:
        np.testing.assert_array_equal(height[d].values, expected[d].values)
        assert height[d].attrs["units"] == expected[d].attrs["units"]
    assert ds.attrs["format"] == height.attrs["format"] == fmt
    assert ds.attrs["source_file"] == path.name
    assert ds.attrs["source_sha256"] == expected.attrs["source_sha256"]


# formats without a sample file here: written by xrough, then opened through the engine
WRITTEN = {"gwy": ("map.gwy", {}), "npy": ("map.npy", {"size": ("3 um", "4 um"), "unit": "m"}),
           "netcdf": ("own.nc", {}), "text": ("map.txt", {})}


def test_every_format_is_covered():
    assert {fmt for fmt, _, _ in NATIVE} | set(WRITTEN) == set(FORMATS)


@pytest.mark.parametrize("fmt", sorted(WRITTEN))
def test_open_dataset_written_files(fmt, tmp_path):
    needs_module(fmt)
    name, options = WRITTEN[fmt]
    module = importlib.import_module(FORMATS[fmt].module)
    topo = xrough.topography(np.random.default_rng(1).normal(size=(6, 8)) * 1e-9,
                             size=("3 um", "4 um"), unit="m")
    path = tmp_path / name
    if fmt == "npy":
        np.save(path, topo.values)
    else:
        try:
            module.write(topo, path)
        except ImportError as err:  # the format's optional dependency
            pytest.skip(str(err))
    assert detect_format(path) == fmt
    ds = xr.open_dataset(path, engine=ENGINE, **options)
    np.testing.assert_allclose(ds["height"].values, topo.values, rtol=1e-15)
    assert ds["height"].attrs["units"] == "m" and ds.attrs["format"] == fmt
    for d in ("y", "x"):
        assert size_of(ds["height"], d) == pytest.approx(size_of(topo, d), rel=1e-12)
        assert xrough.units.conversion_factor(ds[d].attrs["units"], "um") * size_of(
            ds["height"], d) == pytest.approx({"y": 3.0, "x": 4.0}[d])


def test_open_dataset_overrides_pass_through(tmp_path):
    needs_module("npy")
    path = tmp_path / "h.npy"
    heights = np.arange(12.0).reshape(3, 4)
    np.save(path, heights)
    ds = xr.open_dataset(path, engine=ENGINE, size=("3 um", "4 um"), height_unit="nm",
                         height_scale=2.0, periodic=True)
    np.testing.assert_array_equal(ds["height"].values, 2 * heights)
    assert ds["height"].attrs["units"] == "nm" and ds["x"].attrs["units"] == "um"
    assert ds["height"].attrs["periodic"] == 1
    assert "height_scale=2.0" in ds.attrs["overrides"]
    assert list(xr.open_dataset(path, engine=ENGINE, size=4, unit="nm",
                                drop_variables="height").data_vars) == []


def test_open_dataset_nonuniform_resample():
    path = data_path("instruments", "nonuniform.asc")
    ds = xr.open_dataset(path, engine=ENGINE, unit="nm")
    assert ds["height"].attrs["sampling"] == "non-uniform"
    ds = xr.open_dataset(path, engine=ENGINE, unit="nm", resample=True)
    grid_of(ds["height"])


def test_guess_can_open_and_errors(tmp_path):
    backend = XroughBackendEntrypoint()
    assert not backend.guess_can_open(tmp_path / "missing.txt")
    assert not backend.guess_can_open(object())
    junk = tmp_path / "junk.bin"
    junk.write_bytes(bytes(range(256)) * 7)
    assert not backend.guess_can_open(junk)
    with pytest.raises(ValueError, match=r"junk\.bin"):
        xr.open_dataset(junk, engine=ENGINE)
    with pytest.raises(TypeError, match="path"):
        backend.open_dataset(object())


def test_netcdf_written_dataset_round_trip(tmp_path):
    topo = xrough.topography(np.arange(20.0).reshape(4, 5), spacing="2 nm", unit="nm")
    topo.to_netcdf(tmp_path / "t.nc")
    ds = xr.open_dataset(tmp_path / "t.nc", engine=ENGINE)
    xr.testing.assert_equal(ds["height"], topo)


# --------------------------------------------------------------------------------------
# bridge


@pytest.mark.parametrize("name", BRIDGED)
def test_bridge_matches_surfacetopography(name, tmp_path):
    surfacetopography()
    path = data_path("instruments", name)
    heights, st = st_read(path)
    topo = bridge.read_with_surfacetopography(path, channel=0)  # SurfaceTopography's
    nx, ny = st.nb_grid_pts
    sx, sy = st.physical_sizes
    assert topo.dims == ("y", "x") and topo.shape == (ny, nx)
    assert size_of(topo, "x") == pytest.approx(sx, rel=1e-12)
    assert size_of(topo, "y") == pytest.approx(sy, rel=1e-12)
    unit = xrough.units.format_units(st.unit)
    assert topo.attrs["units"] == topo.x.attrs["units"] == unit
    np.testing.assert_array_equal(topo.values, heights)
    assert topo.attrs["reader"] == type(st).__name__ or topo.attrs["reader"].endswith("Reader")
    legal_attrs(topo.attrs)
    topo.to_netcdf(tmp_path / "bridged.nc")  # the attributes are netCDF-legal
    xr.testing.assert_identical(xr.open_dataarray(tmp_path / "bridged.nc").load(), topo)


def test_bridge_sizes_as_headers_state():
    surfacetopography()
    plu = bridge.read(data_path("instruments", "plu-1.plu"))
    # Sensofar: micrometres per pixel in the calibration block
    assert size_of(plu, "x") == pytest.approx(
        plu.attrs["raw_calibration_micrometers_per_pixel_x"] * plu.sizes["x"])
    assert plu.attrs["instrument_vendor"] == "Sensofar"
    opd = bridge.read(data_path("instruments", "opd-1.opd"))
    # Wyko: Pixel_size (mm) and Aspect
    assert float(opd.x[1]) == pytest.approx(opd.attrs["raw_Pixel_size"])
    assert float(opd.y[1]) == pytest.approx(opd.attrs["raw_Pixel_size"]
                                            * opd.attrs["raw_Aspect"])
    nid = bridge.read(data_path("instruments", "nid-1.nid"), channel=0)
    assert nid.shape == (int(nid.attrs["raw_Lines"]), int(nid.attrs["raw_Points"]))


def test_open_topography_falls_back_to_bridge():
    surfacetopography()
    path = data_path("instruments", "plu-1.plu")
    assert detect_format(path) == BRIDGE
    topo = open_topography(path)
    assert topo.attrs["format"] == BRIDGE and topo.attrs["source_file"] == path.name
    ds = xr.open_dataset(path, engine=ENGINE)
    np.testing.assert_array_equal(ds["height"].values, topo.values)
    topo = open_topography(path, size=("1 mm", "2 mm"), height_scale=1e-3, height_unit="mm")
    assert (size_of(topo, "y"), size_of(topo, "x")) == pytest.approx((1000.0, 2000.0))
    assert topo.x.attrs["units"] == "um" and topo.attrs["units"] == "mm"  # relabelled
    np.testing.assert_allclose(topo.values, 1e-3 * ds["height"].values, rtol=1e-15)


def test_bridge_channels():
    surfacetopography()
    path = data_path("instruments", "nid-1.nid")
    chans = bridge.channels(path)
    assert len(chans) == 4 and all(c["is_height"] for c in chans)
    topo = open_topography(path, format=BRIDGE, channel=chans[2]["name"])
    heights, _ = st_read(path, channel_index=2)
    np.testing.assert_array_equal(topo.values, heights)
    assert topo.attrs["channel"] == chans[2]["name"]
    with pytest.raises(ValueError, match=r"nid-1\.nid.*no channel"):
        bridge.read(path, channel="nope")
    mi = data_path("instruments", "mi-1.mi")
    with pytest.raises(ValueError, match=r"mi-1\.mi.*not heights"):
        bridge.read(mi, channel="Deflection")


def test_bridge_nonuniform_profile_as_measured():
    surfacetopography()
    path = data_path("instruments", "nonuniform.asc")
    with pytest.raises(ValueError, match="unit="):
        bridge.read(path)
    prof = bridge.read(path, unit="nm")
    x, h = np.loadtxt(path, unpack=True)
    assert prof.attrs["sampling"] == "non-uniform"
    np.testing.assert_allclose(prof.x.values, x - x[0], atol=1e-9)
    np.testing.assert_array_equal(prof.values, h)


def test_bridge_missing_surfacetopography(monkeypatch, tmp_path):
    for mod in list(sys.modules):
        if mod == "SurfaceTopography" or mod.startswith("SurfaceTopography."):
            monkeypatch.delitem(sys.modules, mod)
    monkeypatch.setitem(sys.modules, "SurfaceTopography", None)
    assert not bridge.available()
    with pytest.raises(ImportError, match=re.escape("pip install xrough[formats]")):
        bridge.read_with_surfacetopography(tmp_path / "x.plu")
    junk = tmp_path / "junk.zzz"
    junk.write_bytes(b"\x01\x02" * 100)
    with pytest.raises(ValueError, match=r"junk\.zzz.*unknown file format"):
        open_topography(junk)
