"""Plain text, NumPy and NetCDF readers.

Numbers are checked against what the files state: their headers and columns are parsed
here independently of the readers (and, when installed, compared with SurfaceTopography's
readers). Text matrices are in image order (first line = top row) and xrough's row 0 is
y = 0, so a matrix as loaded with ``np.loadtxt`` is ours upside down.
"""

import re
import warnings

import netCDF4
import numpy as np
import pytest
import xarray as xr

import xrough
from conftest import data_path
from xrough.io import detect_format, netcdf, npy, open_topography, text
from xrough.testing import assert_units_equal
from xrough.topography import grid_of

INSTR = "instruments"


def size_of(da, dim):
    """Physical size n * spacing along ``dim``."""
    return float(da[dim][1] - da[dim][0]) * da.sizes[dim]


def st_topography(path, **kwargs):
    """SurfaceTopography's reading of ``path`` (skips when it is not installed)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = pytest.importorskip("SurfaceTopography")
        return st.open_topography(str(path)).topography(**kwargs)


def meta_yml_entry(path, original):
    """``(size, unit)`` of a topography in a contact.engineering meta.yml (parsed by hand)."""
    text_ = path.read_text()
    block = text_[text_.index(f"original: {original}"):]
    block = block[: block.find("- creator:") if "- creator:" in block else None]
    sizes = re.search(r"size: !!python/tuple\n((?:\s+- [-\d.eE+]+\n)+)", block).group(1)
    unit = re.search(r"\n\s+unit: (\S+)", block).group(1)
    return [float(v) for v in re.findall(r"- ([-\d.eE+]+)", sizes)], unit


# --------------------------------------------------------------------------------------
# text: real files


def test_matrix_gwyddion_export():
    path = data_path(INSTR, "matrix-3.txt")
    header = dict(re.findall(r"^#\s*([^:]+):\s*(.*?)\s*$", path.read_text("utf-8"), re.M))
    width, wunit = header["Width"].split()
    height, hunit = header["Height"].split()
    assert (wunit, hunit, header["Value units"]) == ("µm", "µm", "m")
    expected = np.loadtxt(path, comments="#")
    assert detect_format(path) == "text"
    topo = text.read(path)
    grid = grid_of(topo)
    assert topo.dims == ("y", "x") and topo.shape == expected.shape == (256, 256)
    assert topo.x.attrs["units"] == topo.y.attrs["units"] == "um"
    assert topo.attrs["units"] == "m"
    assert size_of(topo, "x") == pytest.approx(float(width), rel=1e-12)
    assert size_of(topo, "y") == pytest.approx(float(height), rel=1e-12)
    assert grid.spacing == pytest.approx((10 / 256, 10 / 256))
    np.testing.assert_array_equal(topo.values, expected[::-1])
    assert topo.attrs["Channel"] == "ZSensor"
    assert float(topo.x[0]) == 0.0

    st = st_topography(path)
    assert st.physical_sizes == pytest.approx((1e-5, 1e-5))  # SurfaceTopography: in m
    np.testing.assert_allclose(topo.values, st.heights().T[::-1], rtol=1e-12)


def test_matrix_unit_override_relabels():
    path = data_path(INSTR, "matrix-3.txt")
    topo = open_topography(path, unit="nm")
    assert topo.attrs["units"] == topo.x.attrs["units"] == "nm"
    assert size_of(topo, "x") == pytest.approx(10.0)
    topo = open_topography(path, height_unit="um", size=("5 um", "4 um"))
    assert topo.attrs["units"] == "um" and topo.x.attrs["units"] == "um"
    assert (size_of(topo, "y"), size_of(topo, "x")) == pytest.approx((5.0, 4.0))


def test_xy_profile_nonuniform_needs_unit_and_is_kept_as_measured():
    path = data_path(INSTR, "xy-1.txt")
    x, h = np.loadtxt(path, unpack=True)
    with pytest.raises(ValueError, match=r"xy-1\.txt.*unit"):
        text.read(path)
    prof = text.read(path, unit="um")
    assert prof.dims == ("x",) and prof.shape == (132,) == x.shape
    assert prof.attrs["sampling"] == "non-uniform"
    np.testing.assert_array_equal(prof.x.values, x)
    np.testing.assert_array_equal(prof.values, h)
    assert prof.x.attrs["units"] == prof.attrs["units"] == "um"
    with pytest.raises(ValueError, match="not uniformly spaced"):
        grid_of(prof)

    st = st_topography(path)
    assert not st.is_uniform
    x_st, h_st = st.positions_and_heights()  # SurfaceTopography shifts x to start at 0
    np.testing.assert_allclose(prof.x.values, x_st + x[0], rtol=1e-14)
    np.testing.assert_array_equal(prof.values, h_st)
    assert float(prof.x[-1] - prof.x[0]) == pytest.approx(st.physical_sizes[0])


def test_xy_profile_resample_on_request():
    path = data_path(INSTR, "xy-1.txt")
    x, h = np.loadtxt(path, unpack=True)
    topo = text.read(path, unit="um", resample=True)
    grid = grid_of(topo)
    assert topo.shape == x.shape
    assert grid.spacing[0] == pytest.approx((x[-1] - x[0]) / (x.size - 1), rel=1e-12)
    np.testing.assert_allclose(topo.values, np.interp(np.linspace(x[0], x[-1], x.size), x, h),
                               rtol=1e-12)
    assert topo.values[0] == h[0] and topo.values[-1] == pytest.approx(h[-1], rel=1e-12)
    assert topo.attrs["sampling"] == "resampled"
    assert "linear interpolation" in topo.attrs["resampling"]
    assert topo.attrs["x_offset"] == x[0]


def test_xyz_points_on_a_grid():
    path = data_path(INSTR, "xyz-1.txt")
    x, y, z = np.loadtxt(path, unpack=True)
    with pytest.raises(ValueError, match=r"xyz-1\.txt.*unit"):
        text.read(path)
    topo = text.read(path, unit="nm")
    assert topo.shape == (np.unique(y).size, np.unique(x).size) == (4, 4)
    for xi, yi, zi in zip(x, y, z):
        assert float(topo.sel(x=xi, y=yi)) == zi
    assert (size_of(topo, "x"), size_of(topo, "y")) == (4.0, 4.0)
    assert topo.attrs["text_layout"] == "xyz"

    st = st_topography(path)
    assert st.physical_sizes == pytest.approx((4.0, 4.0))
    np.testing.assert_array_equal(topo.values, st.heights().T)


def test_dektak_csv():
    path = data_path(INSTR, "dektak-1.csv")
    lines = [line for line in path.read_bytes().decode("latin-1").splitlines() if line]
    start = lines.index("Scan Data") + 1
    names = lines[start].rstrip(",").split(",")
    assert names == ["Lateral um", "Raw Micrometer"]
    header = dict(line.split(",", 1) for line in lines[:start] if "," in line)
    length, length_unit = header["Length"].split()
    resolution = float(header["Resolution"].split()[0])
    x, h = np.array([line.split(",")[:2] for line in lines[start + 1:] if line.strip()],
                    dtype=float).T

    topo = text.read(path)
    assert topo.dims == ("x",) and topo.shape == x.shape == (9600,)
    assert topo.x.attrs["units"] == "um" == length_unit
    assert topo.attrs["units"] == "um"  # "Raw Micrometer"
    np.testing.assert_array_equal(topo.values, h)
    # uniform within the 0.1 um to which the file prints x
    assert topo.attrs["sampling"] == "uniform"
    assert np.abs(topo.x.values - x).max() <= 0.1
    assert size_of(topo, "x") == pytest.approx(float(length), rel=1e-6)
    assert float(topo.x[1]) == pytest.approx(resolution, rel=5e-3)
    assert topo.attrs["Length"] == "1500.0 um" and topo.attrs["Stylus"] == "Radius: 2.5 µm"
    assert topo.attrs["columns"] == "Lateral um, Raw Micrometer"

    st = st_topography(path)  # SurfaceTopography keeps the rounded positions
    np.testing.assert_array_equal(st.heights(), h)
    assert st.unit == "µm"


def test_nonuniform_asc_kept_and_resampled():
    path = data_path(INSTR, "nonuniform.asc")
    x, h = np.loadtxt(path, unpack=True)
    prof = open_topography(path, unit="nm")
    assert prof.attrs["sampling"] == "non-uniform"
    assert prof.attrs["format"] == "text" and prof.attrs["source_file"] == "nonuniform.asc"
    np.testing.assert_array_equal(prof.x.values, x)
    np.testing.assert_array_equal(prof.values, h)
    assert prof.x.attrs["units"] == prof.attrs["units"] == "nm"
    with pytest.raises(ValueError, match="non-uniform"):
        open_topography(path, unit="nm", size=1000)
    topo = open_topography(path, unit="nm", resample=True)
    grid = grid_of(topo)
    assert topo.shape == (134,)
    assert grid.spacing[0] * 133 == pytest.approx(x[-1] - x[0], rel=1e-12)
    st = st_topography(path)
    assert float(prof.x[-1] - prof.x[0]) == pytest.approx(st.physical_sizes[0])


def test_uncd_tem_profile():
    path = data_path("uncd", "80_Scale10.472_FIXEDv2p1_D7eHXiT.asc")
    (length,), unit = meta_yml_entry(data_path("uncd", "meta.yml"),
                                     "80_Scale10.472_FIXEDv2p1_D7eHXiT.asc")
    x, h = np.loadtxt(path, unpack=True)
    prof = open_topography(path, unit=unit)
    assert unit == "nm" and prof.attrs["sampling"] == "non-uniform"
    assert prof.shape == (76,)
    assert float(prof.x[-1] - prof.x[0]) == pytest.approx(length, rel=1e-9)
    np.testing.assert_array_equal(prof.values, h)


def test_uncd_stylus_profile():
    path = data_path("uncd", "uncd_stylus_300um_5mar_3_k0HpKJt.txt")
    (length,), unit = meta_yml_entry(data_path("uncd", "meta.yml"),
                                     "uncd_stylus_300um_5mar_3_k0HpKJt.txt")
    x, h = np.loadtxt(path, unpack=True)
    with pytest.raises(ValueError, match="unit"):
        open_topography(path)
    topo = open_topography(path, unit=unit)
    assert unit == "mm" and topo.attrs["units"] == topo.x.attrs["units"] == "mm"
    assert topo.shape == (3001,) and topo.attrs["sampling"] == "uniform"
    assert size_of(topo, "x") == pytest.approx(length, rel=1e-6)
    assert topo.attrs["x_max_deviation"] <= 1e-6  # printed to 1e-6 mm
    np.testing.assert_array_equal(topo.values, h)


# --------------------------------------------------------------------------------------
# text: synthetic files


def write(tmp_path, name, content, mode="w"):
    path = tmp_path / name
    if mode == "wb":
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    return path


def test_matrix_without_lateral_size_asks_for_it(tmp_path):
    path = write(tmp_path, "bare.txt", "1 2 3 4\n5 6 7 8\n9 10 11 12\n")
    with pytest.raises(ValueError, match=r"bare\.txt.*size=.*spacing="):
        text.read(path, unit="nm")
    with pytest.raises(ValueError, match=r"bare\.txt.*unit"):
        text.read(path, size=(3, 4))
    topo = open_topography(path, unit="nm", size=(3, 4))
    assert grid_of(topo).spacing == (1.0, 1.0)
    topo = text.read(path, spacing="2 um", height_unit="nm")
    assert topo.x.attrs["units"] == "um" and topo.attrs["units"] == "nm"
    assert topo.values[0].tolist() == [9, 10, 11, 12]


def test_header_unit_hints(tmp_path):
    path = write(tmp_path, "hint.txt", "% instrument: stylus\n% unit: nm\n"
                 "0 1.5\n2 2.5\n4 3.5\n6 1.0\n")
    prof = text.read(path)
    assert prof.attrs["units"] == prof.x.attrs["units"] == "nm"
    assert grid_of(prof).spacing == (2.0,)
    assert prof.attrs["instrument"] == "stylus"

    path = write(tmp_path, "sizes.txt", "x-length = 8 um\ny-length = 4 um\nz-unit = nm\n"
                 "x-pixels = 4\n" + "1 2 3 4\n" * 2)
    topo = text.read(path)
    assert (size_of(topo, "y"), size_of(topo, "x")) == (4.0, 8.0)
    assert topo.attrs["units"] == "nm" and topo.x.attrs["units"] == "um"

    path = write(tmp_path, "pixel.txt", "# Pixel size: 0.5 um\n# Value units: nm\n"
                 + "1 2 3 4\n" * 3)
    assert grid_of(text.read(path)).spacing == (0.5, 0.5)

    path = write(tmp_path, "cols.csv", "x [mm],height [um]\n0,1\n0.1,2\n0.2,3\n")
    prof = text.read(path)
    assert prof.x.attrs["units"] == "mm" and prof.attrs["units"] == "um"
    assert grid_of(prof).spacing == pytest.approx((0.1,))


def test_column_of_heights_and_profile_table(tmp_path):
    path = write(tmp_path, "col.txt", "1\n2\n3\n4\n")
    with pytest.raises(ValueError, match=r"col\.txt.*size="):
        text.read(path, unit="nm")
    prof = text.read(path, unit="nm", size=8)
    assert grid_of(prof).spacing == (2.0,)
    path = write(tmp_path, "table.csv", "x (um),raw (nm),filtered (nm)\n0,1,2\n1,3,4\n2,5,6\n")
    with pytest.raises(ValueError, match="column="):
        text.read(path)
    prof = text.read(path, column="filtered (nm)")
    assert prof.values.tolist() == [2, 4, 6] and prof.attrs["units"] == "nm"


def test_semicolon_decimal_comma(tmp_path):
    path = write(tmp_path, "eu.csv", "x;z\n0,0;1,5\n0,5;2,5\n1,0;3,5\n")
    prof = text.read(path, unit="um")
    assert prof.values.tolist() == [1.5, 2.5, 3.5] and grid_of(prof).spacing == (0.5,)


@pytest.mark.parametrize("name, content, match", [
    ("words.txt", "hello world\nthis is not a topography\n", "no lines of numbers"),
    ("broken.txt", "1 2 3 4\n5 6 7 8\n1 2 oops 4\n5 6 7 8\n1 2 3 4\n", "line 3"),
    ("ragged.txt", "1 2 3 4\n5 6 7 8\n1 2 3\n5 6 7 8\n", "line 3 has 3 values"),
    ("binary.txt", bytes(range(256)) * 4, "binary"),
    ("empty.txt", "\n\n", "empty"),
    ("cloud.xyz", "0 0 1\n0.3 1.7 2\n2.2 0.1 3\n1.1 1.1 4\n", "regular grid"),
    ("reentrant.txt", "0 1\n1 2\n0.5 3\n2 4\n", "not monotonic"),
])
def test_garbage_raises_value_error_naming_the_file(tmp_path, name, content, match):
    path = write(tmp_path, name, content, "wb" if isinstance(content, bytes) else "w")
    with pytest.raises(ValueError, match=rf"{re.escape(name)}.*{match}"):
        text.read(path, unit="nm", size=(2, 4))
    with pytest.raises(ValueError, match=re.escape(name)):
        open_topography(path, unit="nm", size=(2, 4))


def test_text_write_read_round_trip(tmp_path):
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="1 um", lambda_s="0.3 um",
                                      size=("2 um", "3 um"), n=(16, 24), rms_height="2 nm",
                                      seed=3, unit="nm")
    text.write(topo, tmp_path / "map.txt")
    back = open_topography(tmp_path / "map.txt")
    np.testing.assert_array_equal(back.values, topo.values)
    assert_units_equal(back, topo)  # data and every coord
    assert grid_of(back).spacing == pytest.approx(grid_of(topo).spacing, rel=1e-15)
    prof = topo.isel(y=0, drop=True)
    text.write(prof, tmp_path / "prof.txt")
    back = text.read(tmp_path / "prof.txt")
    np.testing.assert_array_equal(back.values, prof.values)
    assert back.attrs["sampling"] == "uniform"
    assert grid_of(back).spacing == pytest.approx(grid_of(prof).spacing, rel=1e-12)


def test_sniff_text():
    assert text.sniff(b"# header\n1 2 3\n4 5 6\n", None)
    assert text.sniff(b"a,b\n1.5,2e-3,\n", None)
    assert not text.sniff(b"\x93NUMPY\x01\x00", None)
    assert not text.sniff(b"aISO-1.0\nManufacID = x\n1 2 3\n", None)  # SDF
    assert not text.sniff(b"just words\n", None)


# --------------------------------------------------------------------------------------
# npy


def test_npy_needs_size_and_unit(tmp_path):
    heights = np.random.default_rng(0).normal(size=(6, 8))
    path = tmp_path / "map.npy"
    np.save(path, heights)
    assert detect_format(path) == "npy"
    with pytest.raises(ValueError, match=r"map\.npy.*size="):
        npy.read(path, unit="nm")
    with pytest.raises(ValueError, match=r"map\.npy.*unit"):
        npy.read(path, size=(6, 8))
    with pytest.raises(ValueError, match=r"map\.npy"):
        open_topography(path)
    topo = open_topography(path, size=("3 um", "4 um"), height_unit="nm")
    np.testing.assert_array_equal(topo.values, heights)
    assert grid_of(topo).spacing == (0.5, 0.5)
    assert topo.x.attrs["units"] == "um" and topo.attrs["units"] == "nm"
    prof = npy.read(_save(tmp_path / "p.npy", heights[0]), spacing=2, unit="nm")
    assert prof.dims == ("x",) and size_of(prof, "x") == 16.0


def _save(path, array):
    np.save(path, array)
    return path


def test_npy_rejects_other_arrays(tmp_path):
    with pytest.raises(ValueError, match=r"cube\.npy.*1D or 2D"):
        npy.read(_save(tmp_path / "cube.npy", np.zeros((2, 2, 2))), spacing=1, unit="nm")
    with pytest.raises(ValueError, match=r"obj\.npy"):
        npy.read(_save(tmp_path / "obj.npy", np.array([{}, 1], dtype=object)), spacing=1,
                 unit="nm")
    (tmp_path / "cut.npy").write_bytes((tmp_path / "cube.npy").read_bytes()[:70])
    with pytest.raises(ValueError, match=r"cut\.npy"):
        open_topography(tmp_path / "cut.npy", size=1, unit="nm")


# --------------------------------------------------------------------------------------
# netcdf


def test_netcdf_heights_x_y_layout():
    path = data_path(INSTR, "nc-1.nc")
    with netCDF4.Dataset(path) as nc:
        heights = nc["heights"][:].filled(np.nan)  # (x, y)
        assert nc["heights"].dimensions == ("x", "y")
        unit = nc["heights"].getncattr("unit")
        lengths = {d: float(nc[d].getncattr("length")) for d in ("x", "y")}
        units = {d: nc[d].getncattr("unit") for d in ("x", "y")}
    assert detect_format(path) == "netcdf"
    topo = open_topography(path)
    assert topo.dims == ("y", "x") and topo.shape == heights.T.shape == (10, 5)
    np.testing.assert_array_equal(topo.values, heights.T)
    assert topo.attrs["units"] == unit == "nm"
    for d in ("x", "y"):
        assert topo[d].attrs["units"] == units[d]
        assert size_of(topo, d) == pytest.approx(lengths[d])
    assert topo.attrs["periodic"] == 0

    st = st_topography(path)
    assert st.physical_sizes == pytest.approx((lengths["x"], lengths["y"]))
    np.testing.assert_array_equal(topo.values, st.heights().T)


@pytest.mark.parametrize("kind", ["map", "profile", "stack", "nan"])
def test_netcdf_own_round_trip_identical(tmp_path, kind):
    topo = xrough.self_affine_surface(hurst=0.7, lambda_r="1 um", lambda_s="0.2 um",
                                      size="2 um", n=32, rms_height="2 nm", seed=1, unit="nm")
    topo.attrs.update(instrument="AFM", scan_rate=1.5, lines=32)
    if kind == "profile":
        topo = topo.isel(y=3, drop=True)
    elif kind == "stack":
        topo = xr.concat([topo, 2 * topo], dim="scan").assign_attrs(topo.attrs)
    elif kind == "nan":
        topo = topo.where(topo.x > 0.1).assign_attrs(topo.attrs)
        topo.x.attrs.update(units="um")
        topo = xrough.topography(topo, periodic=True)
    path = tmp_path / f"{kind}.nc"
    netcdf.write(topo, path)
    back = netcdf.read(path)
    xr.testing.assert_identical(back, topo)
    assert all(isinstance(v, (str, int, float)) for v in back.attrs.values())
    opened = open_topography(path)
    assert opened.attrs["format"] == "netcdf"
    np.testing.assert_array_equal(opened.values, topo.values)


def test_netcdf_dataarray_without_name_and_errors(tmp_path):
    topo = xrough.topography(np.arange(12.0).reshape(3, 4), spacing=1, unit="nm")
    topo.name = None
    topo.to_netcdf(tmp_path / "anon.nc")
    assert netcdf.read(tmp_path / "anon.nc").name == "height"

    xr.Dataset({"a": ("x", np.zeros(3)), "b": ("x", np.ones(3))}).to_netcdf(
        tmp_path / "two.nc")
    with pytest.raises(ValueError, match=r"two\.nc.*variable="):
        netcdf.read(tmp_path / "two.nc")
    with pytest.raises(ValueError, match=r"two\.nc.*units"):
        netcdf.read(tmp_path / "two.nc", variable="a")
    assert netcdf.read(tmp_path / "two.nc", variable="b", unit="nm",
                       size=6).x.attrs["units"] == "nm"

    with netCDF4.Dataset(tmp_path / "groups.nc", "w") as nc:
        nc.createGroup("afm")
    with pytest.raises(ValueError, match=r"groups\.nc.*open_analysis"):
        netcdf.read(tmp_path / "groups.nc")

    (tmp_path / "cut.nc").write_bytes((tmp_path / "two.nc").read_bytes()[:200])
    with pytest.raises(ValueError, match=r"cut\.nc"):
        open_topography(tmp_path / "cut.nc")
