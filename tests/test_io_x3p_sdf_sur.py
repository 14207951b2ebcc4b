"""Native readers of X3P (ISO 25178-72, also written), SDF (ISO 25178-71) and Digital Surf SUR.

Real files are checked against the numbers their own headers state (parsed here,
independently of the readers) and against SurfaceTopography's readers when installed.
"""

import hashlib
import os
import re
import struct
import warnings
import zipfile
import zlib

import numpy as np
import pytest
import xarray as xr

import xrough
from conftest import data_path
from xrough.io import detect_format, open_topography, sdf, sur, x3p
from xrough.topography import grid_of

NS = "http://www.opengps.eu/2008/ISO5436_2"


@pytest.fixture
def x3p_file():
    return data_path("instruments", "x3p-2.x3p")


@pytest.fixture
def sdf_file():
    return data_path("instruments", "sdf-1.sdf")


@pytest.fixture
def sur_file():
    return data_path("instruments", "sur-2.sur")


def surface_topography(path):
    """SurfaceTopography's reading of ``path``: the topography and heights (y, x), NaN-masked.

    SurfaceTopography keeps the file's row order with the first row at the top of the
    picture (as Gwyddion); the heights are returned in xrough's orientation, bottom row
    first, so that they compare with xrough's readers.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            from SurfaceTopography import read_topography
        except ImportError:
            pytest.skip("SurfaceTopography is not installed")
        topo = read_topography(str(path))
        heights = np.ma.filled(np.ma.asarray(topo.heights(), dtype=float), np.nan).T
    return topo, heights[::-1]


def tag(xml, name):
    match = re.search(rf"<{name}>([^<]*)</{name}>", xml)
    return match.group(1).strip() if match else None


# ------------------------------------------------------------------------------ X3P


@pytest.mark.data
def test_x3p_real_file_matches_its_header(x3p_file):
    with zipfile.ZipFile(x3p_file) as zf:
        xml = zf.read("main.xml").decode()
        raw = zf.read(tag(xml, "PointDataLink"))
    cx = re.search(r"<CX>(.*?)</CX>", xml, re.S).group(1)
    cy = re.search(r"<CY>(.*?)</CY>", xml, re.S).group(1)
    nx, ny = int(tag(xml, "SizeX")), int(tag(xml, "SizeY"))
    dx, dy = float(tag(cx, "Increment")), float(tag(cy, "Increment"))
    assert tag(xml, "DataType") is not None and "<DataType>D</DataType>" in xml
    expected = np.frombuffer(raw, "<f8").reshape(ny, nx)[::-1]  # file's last row at y = 0

    topo = x3p.read(x3p_file)
    assert topo.dims == ("y", "x") and topo.shape == (ny, nx) == (650, 650)
    assert topo.attrs["units"] == topo.x.attrs["units"] == topo.y.attrs["units"] == "m"
    assert float(topo.x[1]) == dx and float(topo.y[1]) == dy
    assert float(topo.x[0]) == 0.0
    grid = grid_of(topo)
    assert grid.size == pytest.approx((ny * dy, nx * dx), rel=1e-12)
    assert grid.size == pytest.approx((2.044783737930349e-4, 8.29767313942749e-5), rel=1e-12)
    np.testing.assert_array_equal(topo.values, expected)
    assert topo.attrs["x_offset"] == float(tag(cx, "Offset"))
    assert topo.attrs["y_offset"] == float(tag(cy, "Offset"))
    assert topo.attrs["instrument_manufacturer"] == tag(xml, "Manufacturer") == "DIGITAL SURF"
    assert topo.attrs["instrument_model"] == tag(xml, "Model")
    assert topo.attrs["instrument_version"] == tag(xml, "Version") == "6.2"
    assert topo.attrs["date"] == tag(xml, "Date")
    assert "comment" not in topo.attrs  # <Comment/> is empty
    assert all(isinstance(v, (str, int, float)) for v in topo.attrs.values())


@pytest.mark.data
def test_x3p_real_file_matches_surfacetopography(x3p_file):
    st, heights = surface_topography(x3p_file)
    topo = x3p.read(x3p_file)
    assert st.unit == "m"
    assert grid_of(topo).size == pytest.approx(st.physical_sizes[::-1], rel=1e-12)
    np.testing.assert_allclose(topo.values, heights, rtol=1e-12, atol=0)


@pytest.mark.data
def test_x3p_real_file_write_read_identical(x3p_file, tmp_path):
    topo = x3p.read(x3p_file)
    x3p.write(topo, tmp_path / "copy.x3p")
    back = x3p.read(tmp_path / "copy.x3p")
    xr.testing.assert_identical(back, topo)
    st, heights = surface_topography(tmp_path / "copy.x3p")
    np.testing.assert_array_equal(heights, topo.values)


@pytest.mark.data
def test_x3p_detected_by_content(x3p_file, tmp_path):
    renamed = tmp_path / "measurement.dat"
    os.symlink(x3p_file, renamed)
    assert detect_format(renamed) == "x3p"
    head = x3p_file.read_bytes()[:4096]
    assert x3p.sniff(head, x3p_file)
    assert not sdf.sniff(head, x3p_file) and not sur.sniff(head, x3p_file)
    topo = open_topography(renamed)
    assert topo.attrs["format"] == "x3p" and topo.shape == (650, 650)


def random_map(shape=(5, 7), nan=((2, 3), (0, 0)), seed=1):
    h = np.random.default_rng(seed).normal(scale=1e-7, size=shape)
    for idx in nan:
        h[idx] = np.nan
    return h


def test_x3p_round_trip_map_with_nans(tmp_path):
    topo = xrough.topography(random_map(), spacing=(0.3e-6, 0.1e-6), unit="m")
    path = tmp_path / "map.x3p"
    x3p.write(topo, path)
    back = x3p.read(path)
    # the reader counts the points the validity mask marks (2 here)
    assert back.attrs.pop("invalid_points") == 2
    assert back.attrs.pop("invalid_marker") == "the validity mask"
    xr.testing.assert_identical(back, topo)
    with zipfile.ZipFile(path) as zf:
        xml = zf.read("main.xml").decode()
        bits = zf.read("bindata/valid.bin")
        assert tag(xml, "FeatureType") == "SUR"
        assert tag(xml, "MD5ChecksumPointData").lower() == hashlib.md5(
            zf.read("bindata/data.bin")).hexdigest()
        listed = zf.read("md5checksum.hex").decode().split()[0]
        assert listed == hashlib.md5(zf.read("main.xml")).hexdigest()
    valid = np.unpackbits(np.frombuffer(bits, np.uint8), bitorder="little")[:35]
    np.testing.assert_array_equal(valid.reshape(5, 7), np.isfinite(topo.values)[::-1])
    st, heights = surface_topography(path)
    assert st.physical_sizes == pytest.approx((7 * 0.1e-6, 5 * 0.3e-6), rel=1e-12)
    np.testing.assert_array_equal(heights, topo.values)


def test_x3p_round_trip_profile(tmp_path):
    h = random_map(shape=(40,), nan=((5,),))
    topo = xrough.topography(h, spacing=0.25e-6, unit="m")
    path = tmp_path / "profile.x3p"
    x3p.write(topo, path)
    back = x3p.read(path)
    assert back.attrs.pop("invalid_points") == 1
    del back.attrs["invalid_marker"]
    xr.testing.assert_identical(back, topo)
    assert back.dims == ("x",)
    with zipfile.ZipFile(path) as zf:
        xml = zf.read("main.xml").decode()
    assert tag(xml, "FeatureType") == "PRF" and tag(xml, "SizeY") == "1"


def test_x3p_round_trip_metadata_and_offsets(tmp_path):
    attrs = {"date": "2024-03-01T10:00:00+01:00", "creator": "A. Tester",
             "instrument_manufacturer": "ACME", "instrument_model": "Profilometer 3",
             "instrument_serial": "42", "instrument_version": "1.0",
             "calibration_date": "2024-01-01T00:00:00", "probing_system_type": "Contacting",
             "probing_system_identification": "2 um tip", "comment": "polished steel",
             "instrument": "ACME Profilometer 3", "x_offset": 1.5e-3, "y_offset": -2e-4}
    topo = xrough.topography(random_map(nan=()), spacing=1e-6, unit="m", attrs=attrs)
    x3p.write(topo, tmp_path / "meta.x3p")
    xr.testing.assert_identical(x3p.read(tmp_path / "meta.x3p"), topo)


def test_x3p_write_converts_units_to_metres(tmp_path):
    h = random_map() * 1e9
    topo = xrough.topography(h, size=(1.7, 2.3), unit="um", height_unit="nm")
    x3p.write(topo, tmp_path / "nm.x3p")
    back = x3p.read(tmp_path / "nm.x3p")
    assert back.attrs["units"] == back.x.attrs["units"] == "m"
    np.testing.assert_allclose(back.values, h * 1e-9, rtol=1e-15)
    np.testing.assert_allclose(back.x.values, topo.x.values * 1e-6, rtol=1e-15)
    assert grid_of(back).size == pytest.approx((1.7e-6, 2.3e-6), rel=1e-14)


def test_x3p_write_float32(tmp_path):
    topo = xrough.topography(random_map(), spacing=1e-6, unit="m")
    x3p.write(topo, tmp_path / "f.x3p", dtype="F")
    back = x3p.read(tmp_path / "f.x3p")
    np.testing.assert_array_equal(back.values, topo.values.astype(np.float32))


def test_x3p_write_rejects_stacks_and_bad_dtype(tmp_path):
    topo = xrough.topography(random_map(nan=()), spacing=1e-6, unit="m")
    stack = xr.concat([topo, topo], dim="scan")
    with pytest.raises(ValueError, match="scan"):
        x3p.write(stack, tmp_path / "s.x3p")
    with pytest.raises(ValueError, match="dtype"):
        x3p.write(topo, tmp_path / "s.x3p", dtype="L")
    with pytest.raises(ValueError, match="decreases"):
        x3p.write(topo.isel(x=slice(None, None, -1)), tmp_path / "s.x3p")
    with pytest.raises(ValueError, match="unknown X3P metadata"):
        x3p.write(topo, tmp_path / "s.x3p", metadata={"operator": "me"})


def x3p_by_hand(path, *, nx, ny, z, data=None, valid=None, feature="SUR", xoff="0.0",
                datalist=None, record2=""):
    """An X3P file written here from the standard, independently of the writer."""
    link = ""
    if datalist is None:
        link = (f"<DataLink><PointDataLink>bindata/data.bin</PointDataLink>"
                f"<MD5ChecksumPointData>{hashlib.md5(data).hexdigest().upper()}"
                "</MD5ChecksumPointData>")
        if valid is not None:
            link += ("<ValidPointsLink>bindata/valid.bin</ValidPointsLink>"
                     f"<MD5ChecksumValidPoints>{hashlib.md5(valid).hexdigest()}"
                     "</MD5ChecksumValidPoints>")
        link += "</DataLink>"
    else:
        link = "<DataList>" + "".join(f"<Datum>{d}</Datum>" for d in datalist) + "</DataList>"
    xml = (f'<?xml version="1.0" encoding="UTF-8"?>\n<p:ISO5436_2 xmlns:p="{NS}">'
           f"<Record1><Revision>ISO5436 - 2000</Revision><FeatureType>{feature}</FeatureType>"
           "<Axes><CX><AxisType>I</AxisType><DataType>D</DataType><Increment>2.5E-6"
           f"</Increment><Offset>{xoff}</Offset></CX><CY><AxisType>I</AxisType><DataType>D"
           "</DataType><Increment>5.0E-6</Increment><Offset>0</Offset></CY>"
           f"<CZ><AxisType>A</AxisType>{z}</CZ></Axes></Record1>{record2}"
           f"<Record3><MatrixDimension><SizeX>{nx}</SizeX><SizeY>{ny}</SizeY><SizeZ>1"
           f"</SizeZ></MatrixDimension>{link}</Record3>"
           "<Record4><ChecksumFile>md5checksum.hex</ChecksumFile></Record4></p:ISO5436_2>"
           ).encode()
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("main.xml", xml)
        if data is not None:
            zf.writestr("bindata/data.bin", data)
        if valid is not None:
            zf.writestr("bindata/valid.bin", valid)
        zf.writestr("md5checksum.hex", f"{hashlib.md5(xml).hexdigest()} *main.xml\n")
    return path


def test_x3p_integer_data_with_increment_offset_and_validity_mask(tmp_path):
    raw = np.array([[0, 1, 2, 3], [-4, 5, 32767, -32768]], dtype="<i2")
    valid_bits = np.array([1, 1, 0, 1, 1, 1, 1, 0], dtype=bool)  # points 2 and 7 invalid
    valid = np.packbits(valid_bits, bitorder="little").tobytes()
    z = "<DataType>I</DataType><Increment>1.0E-9</Increment><Offset>2.0E-6</Offset>"
    path = x3p_by_hand(tmp_path / "int.x3p", nx=4, ny=2, z=z, data=raw.tobytes(),
                       valid=valid, xoff="1.0E-3")
    topo = x3p.read(path)
    expected = raw * 1e-9 + 2e-6
    expected[~valid_bits.reshape(2, 4)] = np.nan
    expected = expected[::-1]  # the file's last row is y = 0
    np.testing.assert_allclose(topo.values, expected, rtol=1e-15)
    assert np.isnan(topo.values).sum() == 2
    assert float(topo.x[1]) == 2.5e-6 and float(topo.y[1]) == 5e-6
    assert topo.attrs["x_offset"] == 1e-3 and "y_offset" not in topo.attrs
    for code, dtype in (("L", "<i4"), ("F", "<f4")):
        raw2 = np.arange(8, dtype=dtype).reshape(2, 4)
        path = x3p_by_hand(tmp_path / f"{code}.x3p", nx=4, ny=2, data=raw2.tobytes(),
                           z=f"<DataType>{code}</DataType>")
        np.testing.assert_array_equal(x3p.read(path).values, raw2[::-1].astype(float))


def test_x3p_inline_datalist_profile(tmp_path):
    record2 = ("<Record2><Date>2020-05-04T03:02:01</Date><Instrument><Manufacturer>unknown"
               "</Manufacturer><Model>Stylus X</Model><Serial>7</Serial><Version>2"
               "</Version></Instrument><CalibrationDate>2020-01-01T00:00:00</CalibrationDate>"
               "<ProbingSystem><Type>Contacting</Type><Identification>tip</Identification>"
               "</ProbingSystem><Comment>hello</Comment></Record2>")
    path = x3p_by_hand(tmp_path / "list.x3p", nx=5, ny=1, feature="PRF", datalist=[
        "1.0E-6", "2.0E-6", "", "4.0E-6", "5.0E-6"], z="<DataType>D</DataType>",
        record2=record2)
    topo = x3p.read(path)
    assert topo.dims == ("x",)
    np.testing.assert_array_equal(topo.values, [1e-6, 2e-6, np.nan, 4e-6, 5e-6])
    assert topo.attrs["instrument_model"] == "Stylus X"
    assert topo.attrs["instrument"] == "Stylus X"  # the placeholder manufacturer is left out
    assert topo.attrs["comment"] == "hello" and topo.attrs["date"] == "2020-05-04T03:02:01"
    assert topo.attrs["probing_system_type"] == "Contacting"


def rezip(src, dst, **replace):
    """Copy an archive, replacing members (``bindata__data_bin=...`` for bindata/data.bin)."""
    replace = {k.replace("__", "/").replace("_bin", ".bin").replace("_xml", ".xml")
               .replace("_hex", ".hex"): v for k, v in replace.items()}
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
        for name in zin.namelist():
            zout.writestr(name, replace.get(name, zin.read(name)))
    return dst


@pytest.fixture
def written_x3p(tmp_path):
    topo = xrough.topography(random_map(shape=(6, 8)), spacing=1e-6, unit="m")
    path = tmp_path / "good.x3p"
    x3p.write(topo, path)
    return path


def test_x3p_wrong_data_checksum(written_x3p, tmp_path):
    with zipfile.ZipFile(written_x3p) as zf:
        data = bytearray(zf.read("bindata/data.bin"))
    data[10] ^= 0xFF
    bad = rezip(written_x3p, tmp_path / "bad.x3p", bindata__data_bin=bytes(data))
    with pytest.raises(ValueError, match=r"bad\.x3p: MD5 checksum mismatch.*data\.bin"):
        x3p.read(bad)
    with pytest.raises(ValueError, match=r"bad\.x3p.*checksum"):
        open_topography(bad)
    assert x3p.read(bad, verify_checksums=False).shape == (6, 8)


def test_x3p_wrong_main_xml_checksum(written_x3p, tmp_path):
    with zipfile.ZipFile(written_x3p) as zf:
        xml = zf.read("main.xml").replace(b"<SizeZ>1</SizeZ>", b"<SizeZ>1 </SizeZ>")
    bad = rezip(written_x3p, tmp_path / "edited.x3p", main_xml=xml)
    with pytest.raises(ValueError, match=r"edited\.x3p: MD5 checksum mismatch for main\.xml"):
        x3p.read(bad)


def test_x3p_data_of_wrong_size(tmp_path):
    data = np.zeros(7).tobytes()  # 8 points announced
    path = x3p_by_hand(tmp_path / "short.x3p", nx=4, ny=2, data=data,
                       z="<DataType>D</DataType>")
    with pytest.raises(ValueError, match=r"short\.x3p: bindata/data\.bin has 56 bytes.*64"):
        x3p.read(path)


def test_x3p_truncated_and_bad_zip(written_x3p, tmp_path):
    raw = written_x3p.read_bytes()
    truncated = tmp_path / "truncated.x3p"
    truncated.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(ValueError, match=r"truncated\.x3p: not a valid X3P file"):
        x3p.read(truncated)
    garbage = tmp_path / "garbage.x3p"
    garbage.write_bytes(b"PK\x03\x04" + bytes(range(256)) * 4)
    with pytest.raises(ValueError, match=r"garbage\.x3p: not a valid X3P"):
        x3p.read(garbage)
    assert not x3p.sniff(garbage.read_bytes()[:4096], garbage)
    other = tmp_path / "other.x3p"
    with zipfile.ZipFile(other, "w") as zf:
        zf.writestr("index.xml", "<a/>")
    with pytest.raises(ValueError, match=r"other\.x3p: .*no main\.xml"):
        x3p.read(other)
    assert not x3p.sniff(other.read_bytes(), other)
    broken = rezip(written_x3p, tmp_path / "broken.x3p", main_xml=b"<p:ISO5436_2><Record1>",
                   md5checksum_hex=b"")
    with pytest.raises(ValueError, match=r"broken\.x3p: main\.xml is not well-formed"):
        x3p.read(broken)


def test_x3p_corrupted_member_crc(written_x3p, tmp_path):
    raw = bytearray(written_x3p.read_bytes())
    with zipfile.ZipFile(written_x3p) as zf:
        info = zf.getinfo("bindata/data.bin")
    # flip a byte inside the compressed data of bindata/data.bin
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    raw[start + info.compress_size // 2] ^= 0x55
    bad = tmp_path / "crc.x3p"
    bad.write_bytes(bytes(raw))
    with pytest.raises(ValueError, match=r"crc\.x3p: .*(corrupted|checksum)"):
        x3p.read(bad)


def test_x3p_unsupported_layouts(tmp_path):
    path = x3p_by_hand(tmp_path / "pcl.x3p", nx=4, ny=2, feature="PCL",
                       data=np.zeros(8).tobytes(), z="<DataType>D</DataType>")
    with pytest.raises(ValueError, match=r"pcl\.x3p: point clouds"):
        x3p.read(path)
    path = x3p_by_hand(tmp_path / "zi.x3p", nx=4, ny=2, data=np.zeros(8).tobytes(),
                       z="<DataType>D</DataType>")
    with zipfile.ZipFile(path) as zf:
        xml = zf.read("main.xml").replace(b"<CZ><AxisType>A", b"<CZ><AxisType>I")
    bad = rezip(path, tmp_path / "zaxis.x3p", main_xml=xml,
                md5checksum_hex=f"{hashlib.md5(xml).hexdigest()} *main.xml".encode())
    with pytest.raises(ValueError, match=r"zaxis\.x3p: the Z axis has AxisType 'I'"):
        x3p.read(bad)


# ------------------------------------------------------------------------------ SDF


def parse_sdf(path):
    text = path.read_bytes().decode("latin-1")
    head, body = text.split("\n*\n", 1)
    header = dict(re.findall(r"^\s*(\w+)\s*=\s*(\S+)\s*$", head, re.M))
    values = body.split("\n*", 1)[0].split()
    return header, values, body


@pytest.mark.data
def test_sdf_real_file_matches_its_header(sdf_file):
    header, values, body = parse_sdf(sdf_file)
    nx, ny = int(header["NumPoints"]), int(header["NumProfiles"])
    topo = sdf.read(sdf_file)
    assert topo.dims == ("y", "x") and topo.shape == (ny, nx) == (4, 7)
    assert topo.attrs["units"] == topo.x.attrs["units"] == topo.y.attrs["units"] == "m"
    assert float(topo.x[1]) == float(header["Xscale"]) == 1e-6
    assert float(topo.y[1]) == float(header["Yscale"])
    assert grid_of(topo).size == pytest.approx((4e-6, 7e-6), rel=1e-14)
    expected = np.array(values, dtype=float).reshape(ny, nx) * float(header["Zscale"])
    np.testing.assert_array_equal(topo.values, expected[::-1])  # last profile at y = 0
    assert topo.values[-1, 1] == 0.99874 * 1e-6
    assert topo.attrs["manufacturer_id"] == header["ManufacID"] == "ISOTC213"
    assert topo.attrs["create_date"] == header["CreateDate"]
    assert topo.attrs["z_resolution"] == float(header["Zresolution"])
    assert topo.attrs["data_type"] == 7
    assert topo.attrs["operator_name"] == "Tom Jones"
    assert topo.attrs["part_name"] == "S2 Softgauges Example"
    assert "OperatorName" in topo.attrs["trailer"]


@pytest.mark.data
def test_sdf_real_file_matches_surfacetopography(sdf_file):
    st, heights = surface_topography(sdf_file)
    topo = sdf.read(sdf_file)
    assert st.unit == "µm"
    np.testing.assert_allclose(topo.values * 1e6, heights, rtol=1e-12)
    np.testing.assert_allclose(np.array(grid_of(topo).size) * 1e6, st.physical_sizes[::-1],
                               rtol=1e-12)


@pytest.mark.data
def test_sdf_detected_by_content(sdf_file, tmp_path):
    renamed = tmp_path / "profile.txt"
    os.symlink(sdf_file, renamed)
    assert detect_format(renamed) == "sdf"
    head = sdf_file.read_bytes()[:4096]
    assert sdf.sniff(head, sdf_file)
    assert not x3p.sniff(head, sdf_file) and not sur.sniff(head, sdf_file)


SDF_HEADER = """aISO-1.0
ManufacID = Test
CreateDate = 010120240000
ModDate = 010120240000
NumPoints = {nx}
NumProfiles = {ny}
Xscale = 2.0E-6
Yscale = 3.0E-6
Zscale = {dz}
Zresolution = -1
Compression = 0
DataType = {code}
CheckType = 0
*
"""


def test_sdf_text_integer_data_with_missing_points(tmp_path):
    path = tmp_path / "int.sdf"
    path.write_text(SDF_HEADER.format(nx=3, ny=2, dz="1.0E-9", code=5)
                    + "1 2 BAD\n-32768 5\n6\n*\n")
    topo = sdf.read(path)
    np.testing.assert_array_equal(topo.values, np.array([[np.nan, 5, 6], [1, 2, np.nan]])
                                  * 1e-9)
    assert float(topo.y[1]) == 3e-6 and "trailer" not in topo.attrs


def test_sdf_single_profile_and_binary(tmp_path):
    path = tmp_path / "profile.sdf"
    path.write_text(SDF_HEADER.format(nx=4, ny=1, dz="1.0E-6", code=7) + "1 2 3 4\n*\n")
    topo = sdf.read(path)
    assert topo.dims == ("x",) and float(topo.x[1]) == 2e-6
    np.testing.assert_array_equal(topo.values, np.array([1.0, 2, 3, 4]) * 1e-6)

    values = np.array([[10, 20, 30], [40, 2**16 - 1, 60]], dtype="<u2")
    header = struct.pack("<8s10s12s12sHHddddBBB", b"bISO-1.0", b"Bin", b"010120240000",
                         b"010120240000", 3, 2, 1e-6, 2e-6, 1e-9, 1e-10, 0, 1, 0)
    binary = tmp_path / "binary.sdf"
    binary.write_bytes(header + values.tobytes())
    topo = sdf.read(binary)
    np.testing.assert_allclose(topo.values, np.array([[40, np.nan, 60], [10, 20, 30]])
                               * 1e-9, rtol=1e-15)
    assert topo.attrs["manufacturer_id"] == "Bin" and topo.attrs["z_resolution"] == 1e-10
    assert detect_format(binary) == "sdf"
    binary.write_bytes(header + values.tobytes()[:-3])
    with pytest.raises(ValueError, match=r"binary\.sdf: .*truncated"):
        sdf.read(binary)


@pytest.mark.parametrize("text, match", [
    (SDF_HEADER.format(nx=3, ny=2, dz="1e-6", code=7) + "1 2 3 4 5\n*\n",
     r"5 values.*3 x 2 = 6"),
    (SDF_HEADER.format(nx=3, ny=2, dz="1e-6", code=7) + "1 2 3 4 5 x\n*\n",
     r"not a number: 'x'"),
    (SDF_HEADER.format(nx=3, ny=2, dz="1e-6", code=7).replace("Zscale", "Zscal")
     + "1 2 3 4 5 6\n*\n", r"lacks Zscale"),
    (SDF_HEADER.format(nx="three", ny=2, dz="1e-6", code=7) + "1\n*\n",
     r"NumPoints = 'three' is not an integer"),
    (SDF_HEADER.format(nx=3, ny=2, dz="1e-6", code=9) + "1 2 3 4 5 6\n*\n",
     r"unknown DataType 9"),
    (SDF_HEADER.format(nx=3, ny=2, dz="1e-6", code=7).replace("Compression = 0",
                                                              "Compression = 1")
     + "1 2 3 4 5 6\n*\n", r"compressed"),
    ("aISO-1.0\nNumPoints = 3\n\x00\x01garbage\n*\n1\n*\n", r"malformed SDF header line"),
    ("aISO-1.0\nNumPoints = 3\n", r"not terminated"),
    ("bISO-1.0\x00\x01", r"header is truncated"),
    ("ISO-1.0\n", r"not an SDF file"),
], ids=["few values", "not a number", "missing field", "bad integer", "data type",
        "compressed", "garbage header", "unterminated", "binary truncated", "bad magic"])
def test_sdf_corrupted(tmp_path, text, match):
    path = tmp_path / "corrupt.sdf"
    path.write_bytes(text.encode("latin-1"))
    with pytest.raises(ValueError, match=r"corrupt\.sdf: .*" + match):
        sdf.read(path)


def _binary_sdf(path, dx=1e-6, dy=2e-6, dz=1e-9, ny=2):
    values = np.arange(1, 3 * ny + 1, dtype="<i2")
    path.write_bytes(struct.pack("<8s10s12s12sHHddddBBB", b"bISO-1.0", b"Bin",
                                 b"010120240000", b"010120240000", 3, ny, dx, dy, dz, -1.0,
                                 0, 5, 0) + values.tobytes())
    return path


@pytest.mark.parametrize("field, value", [
    ("Zscale", "0"), ("Zscale", "0.0E+00"), ("Zscale", "nan"), ("Zscale", "inf"),
    ("Xscale", "0"), ("Xscale", "-2.0E-6"), ("Yscale", "0"), ("Yscale", "nan"),
])
def test_sdf_scale_that_is_zero_or_not_finite_is_refused(tmp_path, field, value):
    """``Zscale = 0`` read every height as exactly 0, silently (a flat map of the right
    size: no later check can tell). Zscale must be finite and nonzero, the spacings
    Xscale and Yscale finite and positive; the message names the field and its value,
    for text and binary files, through open_topography too."""
    text = SDF_HEADER.format(nx=3, ny=2, dz="1.0E-9", code=5) + "1 2 3\n4 5 6\n*\n"
    text = re.sub(rf"^{field} = .*$", f"{field} = {value}", text, flags=re.M)
    path = tmp_path / "scale.sdf"
    path.write_text(text)
    shown = re.escape(repr(float(value)))
    with pytest.raises(ValueError, match=rf"scale\.sdf: header field {field} = {shown} "
                                         r"must be a finite, (nonzero|positive)"):
        open_topography(path)
    binary = _binary_sdf(tmp_path / "scale_b.sdf", **{f"d{field[0].lower()}": float(value)})
    with pytest.raises(ValueError, match=rf"scale_b\.sdf: header field {field} = {shown}"):
        sdf.read(binary)


def test_sdf_scales_that_are_valid_still_read(tmp_path):
    """A negative Zscale flips the heights, as the header states (read exactly: the
    products of small integers and a power of ten compare to 1e-15 relative); a single
    profile's Yscale is not used and may be 0, as some files write it."""
    topo = sdf.read(_binary_sdf(tmp_path / "neg.sdf", dz=-1e-9))
    np.testing.assert_allclose(topo.values, -np.array([[4, 5, 6], [1, 2, 3]]) * 1e-9,
                               rtol=1e-15)
    profile = sdf.read(_binary_sdf(tmp_path / "profile.sdf", dy=0.0, ny=1))
    assert profile.dims == ("x",) and float(profile.x[1]) == 1e-6


# ------------------------------------------------------------------------------ SUR


def parse_sur_header(raw, pos=0):
    """The SUR header fields this test needs, at their documented byte offsets."""
    def s(off, n):
        return raw[pos + off:pos + off + n].split(b"\0")[0].decode("latin-1").strip()

    def v(fmt, off):
        return struct.unpack_from("<" + fmt, raw, pos + off)[0]

    return {"signature": raw[pos:pos + 12], "n_objects": v("H", 14), "type": v("H", 18),
            "special": v("H", 86), "bits": v("H", 98), "zmin": v("i", 100),
            "nx": v("i", 108), "ny": v("i", 112), "dx": v("f", 120), "dy": v("f", 124),
            "dz": v("f", 128), "dx_unit": s(180, 16), "dy_unit": s(196, 16),
            "dz_unit": s(212, 16), "inversion": v("H", 290), "zoff": v("f", 474),
            "comment": v("H", 334), "private": v("H", 336)}


@pytest.mark.data
def test_sur_real_file_matches_its_header(sur_file):
    raw = sur_file.read_bytes()
    h = parse_sur_header(raw)
    assert h["signature"] == b"DIGITAL SURF" and h["type"] == 2 and h["inversion"] == 0
    start = 512 + h["comment"] + h["private"]
    points = np.frombuffer(raw, "<i4" if h["bits"] == 32 else "<i2", h["nx"] * h["ny"],
                           start).reshape(h["ny"], h["nx"])
    expected = points * float(np.float32(h["dz"])) + h["zoff"]
    missing = points == h["zmin"] - 2
    expected[missing] = np.nan
    expected, missing = expected[::-1], missing[::-1]  # the last line is y = 0

    topo = sur.read(sur_file)
    assert topo.dims == ("y", "x") and topo.shape == (h["ny"], h["nx"]) == (484, 563)
    assert h["dx_unit"] == h["dz_unit"] == "mm"
    assert topo.attrs["units"] == topo.x.attrs["units"] == topo.y.attrs["units"] == "mm"
    assert float(topo.x[1]) == pytest.approx(h["dx"], rel=1e-7)
    assert float(topo.x[1]) == 0.0034840002  # the float32 header value, shortest decimal
    assert float(topo.y[1]) == pytest.approx(h["dy"], rel=1e-7)
    assert grid_of(topo).size == pytest.approx((484 * 0.0034840002, 563 * 0.0034840002),
                                          rel=1e-12)
    assert h["special"] == 1 and missing.sum() == 117
    np.testing.assert_array_equal(np.isnan(topo.values), missing)
    np.testing.assert_allclose(topo.values, expected, rtol=1e-7)
    assert topo.attrs["object_type"] == "surface"


@pytest.mark.data
def test_sur_real_file_matches_surfacetopography(sur_file):
    st, heights = surface_topography(sur_file)
    topo = sur.read(sur_file)
    assert st.unit == "mm"
    np.testing.assert_array_equal(np.isnan(topo.values), np.isnan(heights))
    np.testing.assert_allclose(topo.values, heights, rtol=1e-7)
    np.testing.assert_allclose(grid_of(topo).size, st.physical_sizes[::-1], rtol=1e-7)


@pytest.mark.data
def test_sur_detected_by_content(sur_file, tmp_path):
    renamed = tmp_path / "scan.x3p"
    os.symlink(sur_file, renamed)
    assert detect_format(renamed) == "sur"
    head = sur_file.read_bytes()[:4096]
    assert sur.sniff(head, sur_file)
    assert not x3p.sniff(head, sur_file) and not sdf.sniff(head, sur_file)
    topo = open_topography(renamed)
    assert topo.attrs["format"] == "sur" and topo.attrs["units"] == "mm"


def sur_object(points, *, kind=2, n_objects=1, dx=0.5, dy=0.25, dz=0.01, units="um",
               y_unit=None, zoff=0.0, zmin=0, special=0, inversion=0, comment=b"",
               compressed=False, bits=16):
    """One SUR object (header, comment, points) packed here from the format description."""
    points = np.atleast_2d(np.asarray(points, dtype="<i2" if bits == 16 else "<i4"))
    ny, nx = points.shape
    h = bytearray(512)
    h[:12] = b"DSCOMPRESSED" if compressed else b"DIGITAL SURF"
    struct.pack_into("<HHHH", h, 12, 0, n_objects, 1, kind)
    h[20:20 + 6] = b"sample"
    struct.pack_into("<HH", h, 86, special, 0)
    struct.pack_into("<Hiiiii", h, 98, bits, zmin, int(points.max()), nx, ny, nx * ny)
    struct.pack_into("<fff", h, 120, dx, dy, dz)
    for off, unit in ((180, units), (196, y_unit or units), (212, units)):
        h[off:off + len(unit)] = unit.encode("latin-1")
    struct.pack_into("<H", h, 290, inversion)
    struct.pack_into("<HHHHHH", h, 306, 5, 4, 3, 2, 1, 2021)
    struct.pack_into("<HH", h, 334, len(comment), 0)
    struct.pack_into("<f", h, 474, zoff)
    data = points.tobytes()
    if compressed:
        half = len(data) // 2
        streams = [zlib.compress(data[:half]), zlib.compress(data[half:])]
        data = struct.pack("<IIIII", 2, half, len(streams[0]), len(data) - half,
                           len(streams[1])) + b"".join(streams)
    return bytes(h) + comment + data


def test_sur_synthetic_objects(tmp_path):
    surface = np.array([[1, 2, 3], [4, -32767, 6]])
    path = tmp_path / "two.sur"
    path.write_bytes(sur_object([10, 20, 30, 40], kind=1, n_objects=2, comment=b"first")
                     + sur_object(surface, zmin=-32765, special=1, zoff=1.5,
                                  units="\xb5m", compressed=True))
    profile = sur.read(path)
    assert profile.dims == ("x",) and profile.attrs["units"] == "um"
    np.testing.assert_allclose(profile.values, [0.1, 0.2, 0.3, 0.4], rtol=1e-7)
    assert profile.attrs["comment"] == "first" and profile.attrs["object_type"] == "profile"
    assert profile.attrs["n_objects"] == 2 and profile.attrs["object_index"] == 0
    assert profile.attrs["date"] == "2021-01-02T03:04:05"
    topo = sur.read(path, index=1)
    expected = np.array([[4, np.nan, 6], [1, 2, 3]]) * 0.01 + 1.5  # last line at y = 0
    np.testing.assert_allclose(topo.values, expected, rtol=1e-7)
    assert float(topo.x[1]) == 0.5 and float(topo.y[1]) == 0.25
    assert topo.attrs["object_index"] == 1 and topo.attrs["object_name"] == "sample"
    with pytest.raises(ValueError, match=r"two\.sur: index=2 but the file has 2 objects"):
        sur.read(path, index=2)


def test_sur_inversion_units_and_32_bit(tmp_path):
    points = np.array([[1, 2, 3], [4, 5, 6]])
    # as Gwyddion: 1 negates, 2 also mirrors left-right, 3 upside-down; then the last
    # line of the picture is y = 0
    for code, expected in ((1, -points[::-1]), (2, -points[::-1, ::-1]), (3, -points)):
        path = tmp_path / f"inv{code}.sur"
        path.write_bytes(sur_object(points, inversion=code, dz=1.0, units="nm", bits=32))
        topo = sur.read(path)
        np.testing.assert_array_equal(topo.values, expected)
        assert topo.attrs["inversion"] == code and topo.attrs["units"] == "nm"
    path = tmp_path / "units.sur"
    path.write_bytes(sur_object(points, dy=2.0, units="um", y_unit="mm"))
    topo = sur.read(path)
    assert float(topo.y[1]) == 2000.0 and topo.y.attrs["units"] == "um"


def test_sur_corrupted(tmp_path):
    good = sur_object(np.arange(12).reshape(3, 4))
    cases = {
        "truncated.sur": (good[:-5], r"object 0 is truncated"),
        "short.sur": (good[:300], r"truncated: its 512-byte header"),
        "bits.sur": (good[:98] + b"\x07\x00" + good[100:], r"7 bits per point"),
        "counts.sur": (good[:116] + struct.pack("<i", 99) + good[120:], r"inconsistent"),
        "unit.sur": (good[:212] + b"V".ljust(16, b"\0") + good[228:], r"Z unit must be a "
                     r"length"),
        "image.sur": (good[:18] + b"\x0a\x00" + good[20:], r"intensity image, not heights"),
        "magic.sur": (b"DIGITAL SURX" + good[12:], r"not a SUR file"),
    }
    zipped = sur_object(np.arange(12).reshape(3, 4), compressed=True)
    cases["zlib.sur"] = (zipped[:540] + b"\xff" * 8 + zipped[548:], r"corrupted compressed")
    for name, (content, match) in cases.items():
        path = tmp_path / name
        path.write_bytes(content)
        with pytest.raises(ValueError, match=re.escape(name) + ": .*" + match):
            sur.read(path)


def test_float32_files_state_their_rounding(tmp_path):
    """Heights stored as float32 (X3P type F, binary SDF FLOAT) keep the step that type
    resolves at their largest height (stored_height_step, in metres), so acf() can say
    when that rounding matters: heights 2.6e5 rms heights from zero (docs/quality.md,
    "Heights stored in float32"); near zero it does not."""
    t = xrough.self_affine_surface(hurst=0.8, lambda_r=64, lambda_s=4, size=256, n=256,
                                   rms_height=1.0, seed=1, unit="nm")
    m = xrough.convert_units(t, "m", lateral="m")
    for offset, said in ((0.0, False), (2.6e5 * 1e-9, True)):
        shifted = (m + offset).assign_attrs(m.attrs)
        path = tmp_path / "f.x3p"
        x3p.write(shifted, path, dtype="F")
        topo = xrough.open_topography(path)
        top = np.float32(np.abs(shifted.values).max())
        assert topo.attrs["stored_height_step"] == pytest.approx(float(np.spacing(top)),
                                                                 rel=1e-6)
        assert topo.attrs["stored_dtype"] == "float32 (X3P type F)"
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            G = topo.rough.acf()
        assert (G.attrs.get("quality", "good") == "questionable") == said
        assert any("stored as float32 (X3P type F)" in str(w.message)
                   for w in caught) == said
    # a binary SDF of FLOAT heights (DataType 3) in units of Zscale = 1 nm
    h = (t.transpose("y", "x").values[:8, :8] + 2.6e5).astype("<f4")
    header = struct.pack("<8s10s12s12sHHddddBBB", b"bISO-1.0", b"Bin", b"010120240000",
                         b"010120240000", 8, 8, 1e-9, 1e-9, 1e-9, 1e-10, 0, 3, 0)
    path = tmp_path / "f.sdf"
    path.write_bytes(header + h.tobytes())
    topo = sdf.read(path)
    assert topo.attrs["stored_height_step"] == pytest.approx(
        float(np.spacing(np.abs(h).max())) * 1e-9, rel=1e-9)
    assert topo.attrs["stored_dtype"] == "float32 (SDF type FLOAT)"


def _rezip(path, out, rename=lambda name: name, data=None):
    """Copy an X3P archive member by member, renamed, with ``data`` replacing members."""
    data = data or {}
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(out, "w") as dst:
        for name in src.namelist():
            dst.writestr(rename(name), data.get(name, src.read(name)))
    return out


def _with_points(path, out, values):
    """The archive with its point data replaced by ``values`` (float64, type D) and the
    checksum of the point data in main.xml and of main.xml in the checksum file fixed."""
    raw = np.asarray(values, dtype="<f8").tobytes()
    with zipfile.ZipFile(path) as zf:
        xml = zf.read("main.xml").decode()
    old = tag(xml, "MD5ChecksumPointData")
    xml = xml.replace(old, hashlib.md5(raw).hexdigest().upper()).encode()
    listed = f"{hashlib.md5(xml).hexdigest()} *main.xml\n".encode()
    return _rezip(path, out, data={"bindata/data.bin": raw, "main.xml": xml,
                                   "md5checksum.hex": listed})


def test_x3p_infinite_points_are_missing_counted_and_said_once(tmp_path):
    """Alicona's focus-variation scans store unmeasured points as +inf (ISO 5436-2 allows
    invalid points): they read as NaN, with the count in attrs and one warning."""
    h = np.arange(20.0).reshape(4, 5) * 1e-9
    topo = xrough.topography(h, spacing=1e-6, unit="m")
    path = tmp_path / "plain.x3p"
    x3p.write(topo, path, dtype="D")
    stored = h[::-1].copy()  # the file's first row is the top of the picture
    stored[0, 1] = stored[2, 3] = stored[3, 4] = np.inf
    inf_path = _with_points(path, tmp_path / "inf.x3p", stored.ravel())
    with pytest.warns(UserWarning, match=r"3 of 20 points stored as \+inf") as caught:
        back = xrough.open_topography(inf_path)
    assert len([w for w in caught if "stored as" in str(w.message)]) == 1
    assert back.attrs["invalid_points"] == 3
    assert "+inf" in back.attrs["invalid_marker"]
    expected = h.copy()
    expected[3, 1] = expected[1, 3] = expected[0, 4] = np.nan
    np.testing.assert_array_equal(back.values, expected)
    G = back.rough.acf()  # the missing points are left out of G, not refused
    assert np.isfinite(G.values).all()


def test_x3p_written_by_x3ptools_in_a_folder_reads_with_its_checksums(tmp_path):
    """x3ptools (R) writes NAME/main.xml, NAME/bindata/data.bin, NAME/md5checksum.hex."""
    topo = xrough.topography(random_map(), spacing=(0.3e-6, 0.1e-6), unit="m")
    path = tmp_path / "plain.x3p"
    x3p.write(topo, path)
    nested = _rezip(path, tmp_path / "nested.x3p", rename=lambda n: "scan01/" + n)
    assert xrough.io.detect_format(nested) == "x3p"
    back = xrough.open_topography(nested)
    assert back.attrs.pop("x3p_folder") == "scan01"
    np.testing.assert_array_equal(back.values, topo.values)
    assert back.attrs["invalid_points"] == 2
    # the checksums in the folder are verified as for a plain X3P
    with zipfile.ZipFile(nested) as zf:
        raw = bytearray(zf.read("scan01/bindata/data.bin"))
    raw[0] ^= 0xFF
    broken = _rezip(nested, tmp_path / "broken.x3p", data={"scan01/bindata/data.bin": raw})
    with pytest.raises(ValueError, match="checksum"):
        xrough.open_topography(broken)
    # two folders with a main.xml each: not one X3P
    with zipfile.ZipFile(nested) as zf, zipfile.ZipFile(tmp_path / "two.x3p", "w") as two:
        for name in zf.namelist():
            two.writestr(name, zf.read(name))
            two.writestr(name.replace("scan01/", "scan02/"), zf.read(name))
    with pytest.raises(ValueError, match="main.xml at its root or in one folder"):
        x3p.read(tmp_path / "two.x3p")
