"""AFM readers: Nanoscope (.spm/.001/.di), Gwyddion (.gwy, read and write), Igor (.ibw).

Numbers are checked against what the files' own headers state (parsed here independently
of the readers) and, when installed, against SurfaceTopography's readers. SurfaceTopography
and Gwyddion put the top image row first; xrough keeps row 0 at y = 0 (plotted at the
bottom), so their arrays are ours flipped upside down.
"""

import re
import struct
import warnings

import numpy as np
import pytest
import xarray as xr

import xrough
from conftest import data_path
from xrough.io import detect_format, gwy, ibw, nanoscope, open_topography
from xrough.topography import grid_of

DI = ("instruments", "di-1.di")
UNCD = ("uncd", "gain_control_uncd_35_z03tr3R.001")
IBW = ("instruments", "spot_1-1000nm.ibw")


def surfacetopography():
    return pytest.importorskip("SurfaceTopography")


def st_read(path, channel_index=0):
    """Heights (row 0 = top), physical sizes and unit from SurfaceTopography."""
    st = surfacetopography()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = st.open_topography(str(path))
        topo = reader.topography(channel_index=channel_index)
        heights = topo.heights()
    return np.ma.filled(np.ma.asarray(heights, dtype=float), np.nan).T, topo


# --------------------------------------------------------------------------- Nanoscope


def parse_di_header(path):
    """Independent minimal parse: global entries and one dict per image section."""
    raw = path.read_bytes()
    text = raw[: raw.index(b"\\*File list end")].decode("latin-1")
    glob, images, current = {}, [], None
    for line in text.splitlines():
        line = line.strip()
        if line.startswith("\\*"):
            current = {} if line == "\\*Ciao image list" else None
            if current is not None:
                images.append(current)
            continue
        key, _, value = line[1:].partition(": ")
        (current if current is not None else glob).setdefault(key, value.strip())
    return glob, images


def di_expected(path, image):
    """Raw counts * V_hard / 2**(8 b) * S_soft, computed from the header text."""
    glob, images = parse_di_header(path)
    sec = images[image]
    soft_name, hard = re.match(r"V \[(.+?)\] \(.*?\) ([-\d.]+) V$", sec["@2:Z scale"]).groups()
    soft = float(glob["@" + soft_name].split()[1])
    bpp = int(sec["Bytes/pixel"])
    nx, ny = int(sec["Samps/line"]), int(sec["Number of lines"])
    raw = np.fromfile(path, dtype=f"<i{bpp}", count=nx * ny, offset=int(sec["Data offset"]))
    scale = float(hard) / 2 ** (8 * bpp) * soft
    sx, sy, unit = sec["Scan Size"].split()
    return raw.reshape(ny, nx) * scale, scale, (float(sy), float(sx)), unit, glob, sec


@pytest.mark.data
def test_uncd_afm_height_scale_matches_published_value():
    """The UNCD AFM scan: 512 x 512 points over 100 nm x 100 nm, heights in nm.

    Header: ``@2:Z scale: V [Sens. Zsens] (0.005035400 V/LSB) 329.9950 V`` and
    ``@Sens. Zsens: V 22.25786 nm/V``, 16-bit data. Our scaling gives
    329.9950 V / 2**16 * 22.25786 nm/V = 0.11207553879852296 nm per count;
    meta.yml states height_scale 0.112075538798523: equal to 3e-16 (relative).
    The rounded per-LSB value 0.005035400 V/LSB would give 0.1120772 nm (1.5e-5 too
    large), so the published value was made with the same formula (full-range hard value
    divided by 2**16), not with the parenthesised number.
    """
    path = data_path(*UNCD)
    meta = (path.parent / "meta.yml").read_text(encoding="utf-8")
    block = meta[meta.index("original: gain_control_uncd_35_z03tr3R.001"):]
    published = float(re.search(r"height_scale: ([0-9.eE+-]+)", block).group(1))
    assert published == 0.112075538798523

    topo = nanoscope.read(path)
    grid = grid_of(topo)
    assert topo.shape == (512, 512) and grid.shape == (512, 512)
    assert grid.size == (100.0, 100.0) and grid.lateral_unit == "nm"
    assert topo.attrs["units"] == "nm"
    assert topo.attrs["height_scale"] == pytest.approx(329.9950 / 2**16 * 22.25786, rel=1e-15)
    assert topo.attrs["height_scale"] == pytest.approx(published, rel=1e-14)
    assert abs(0.005035400 * 22.25786 / published - 1) > 1e-5  # the rounded per-LSB value
    expected, scale, size, unit, glob, _ = di_expected(path, 0)
    np.testing.assert_allclose(topo.values, expected, rtol=1e-14)
    assert size == (100.0, 100.0) and unit == "nm"
    assert topo.attrs["date"] == "2018-04-05T15:08:09"  # \Date: 03:08:09 PM Thu Apr 05 2018
    assert topo.attrs["instrument"] == glob["Microscope"] == "Dimension V"
    assert topo.attrs["channel"] == "Height" and topo.attrs["line_direction"] == "Trace"
    assert topo.attrs["header"].startswith("\\*File list")


@pytest.mark.data
@pytest.mark.parametrize("parts", [DI, UNCD], ids=["di-1", "uncd"])
@pytest.mark.parametrize("image", [0, 1])
def test_nanoscope_heights_and_sizes_from_header(parts, image):
    path = data_path(*parts)
    topo = nanoscope.read(path, channel=image)
    expected, scale, size, unit, _, sec = di_expected(path, image)
    np.testing.assert_allclose(topo.values, expected, rtol=1e-14)
    grid = grid_of(topo)
    assert grid.size == pytest.approx(size, rel=1e-15) and grid.lateral_unit == unit
    assert grid.spacing[1] == pytest.approx(size[1] / int(sec["Samps/line"]), rel=1e-15)
    assert topo.attrs["height_scale"] == pytest.approx(scale, rel=1e-14)
    assert topo.attrs["scan_line"] == sec["Scan Line"]
    assert all(isinstance(v, (str, int, float)) for v in topo.attrs.values())


@pytest.mark.data
def test_di1_numbers():
    """di-1.di: 500 nm scan, Z scale 2.910461 V with Zsens 20.82646 nm/V."""
    topo = nanoscope.read(data_path(*DI))
    assert grid_of(topo).size == (500.0, 500.0)
    assert topo.attrs["height_scale"] == pytest.approx(2.910461 / 65536 * 20.82646, rel=1e-15)
    assert topo.attrs["date"] == "2016-01-12T09:57:48"
    assert float(topo.min()) == pytest.approx(-30.306374893640626, rel=1e-12)
    assert float(topo.max()) == pytest.approx(28.892194553286718, rel=1e-12)


@pytest.mark.data
@pytest.mark.parametrize("parts", [DI, UNCD], ids=["di-1", "uncd"])
def test_nanoscope_agrees_with_surfacetopography(parts):
    path = data_path(*parts)
    heights, ref = st_read(path, 0)
    topo = nanoscope.read(path)
    np.testing.assert_allclose(topo.values, heights[::-1], rtol=1e-13)
    assert grid_of(topo).size == pytest.approx(tuple(ref.physical_sizes)[::-1], rel=1e-14)
    assert ref.unit == topo.attrs["units"]


@pytest.mark.data
def test_nanoscope_channels_and_selection():
    path = data_path(*DI)
    listed = nanoscope.channels(path)
    assert [c["name"] for c in listed] == ["Height", "Height", "Phase", "Amplitude Error"]
    assert [c["is_height"] for c in listed] == [True, True, False, False]
    assert nanoscope.read(path, channel="height").attrs["channel_index"] == 0
    interleave = nanoscope.read(path, channel=1)
    assert interleave.attrs["scan_line"] == "Interleave"
    with pytest.raises(ValueError, match=r"di-1\.di: channel 2 'Phase' holds 'deg', not "
                                         r"heights.*0: 'Height'"):
        nanoscope.read(path, channel="Phase")
    with pytest.raises(ValueError, match=r"no channel named 'Deflection'.*'Amplitude Error'"):
        nanoscope.read(path, channel="Deflection")
    with pytest.raises(ValueError, match="channel index 7 out of range"):
        nanoscope.read(path, channel=7)


@pytest.mark.data
def test_nanoscope_detected_by_content_and_opened(tmp_path):
    path = data_path(*UNCD)
    head = path.read_bytes()[:4096]
    assert nanoscope.sniff(head, path)
    assert nanoscope.sniff(b"\\\\*File list\r\n\\\\Version: 0x05300001\r\n", None)
    assert not nanoscope.sniff(b"GWYP\0", None) and not nanoscope.sniff(head[1:], None)
    renamed = tmp_path / "scan.dat"
    renamed.symlink_to(path)
    assert detect_format(renamed) == "nanoscope"
    topo = open_topography(renamed)
    assert topo.attrs["format"] == "nanoscope" and topo.attrs["channel"] == "Height"


def _corrupt(tmp_path, src, name, edit):
    data = edit(src.read_bytes())
    out = tmp_path / name
    out.write_bytes(data)
    return out


@pytest.mark.data
def test_nanoscope_corrupted_files_raise_value_error(tmp_path):
    src = data_path(*UNCD)
    blob = src.read_bytes()
    cases = {
        "cut_data.001": (lambda b: b[:300_000], r"cut_data\.001: truncated file: channel "
                                                r"'Height' needs bytes 40960\.\.565248"),
        "cut_header.001": (lambda b: b[:20_000], r"cut_header\.001: the header ends before"),
        "bad_lines.001": (lambda b: b.replace(b"\\Number of lines: 512", b"\\Number of lines: "
                                                                         b"abc", 1),
                          r"bad_lines\.001: channel 'Height': 'Number of lines: abc' is not "
                          r"an integer"),
        "no_sens.001": (lambda b: b.replace(b"\\@Sens. Zsens: V", b"\\@Sens. Zxxxx: V", 1),
                        r"no_sens\.001: channel 'Height': the soft scale '@Sens\. Zsens'"),
        "not_di.001": (lambda b: b"\\*Something else\r\n" + b[20:], r"not_di\.001: not a "
                                                                     r"Nanoscope file"),
    }
    assert b"\\Number of lines: 512" in blob
    for name, (edit, message) in cases.items():
        path = _corrupt(tmp_path, src, name, edit)
        with pytest.raises(ValueError, match=message):
            nanoscope.read(path)


# --------------------------------------------------------------------------- Igor


def parse_ibw(path):
    """Independent parse of a version-5 little-endian wave: header fields and layers."""
    raw = path.read_bytes()
    version, _, wfm_size, formula, note_size, data_e = struct.unpack("<hhiiii", raw[:20])
    dim_e = struct.unpack("<4i", raw[20:36])
    labels_size = struct.unpack("<4i", raw[36:52])
    assert version == 5
    dtype = {2: "<f4", 4: "<f8"}[struct.unpack("<h", raw[80:82])[0]]
    ndim = struct.unpack("<4i", raw[132:148])
    sfa = struct.unpack("<4d", raw[148:180])
    sfb = struct.unpack("<4d", raw[180:212])
    units = raw[212:216].split(b"\0")[0].decode(), raw[216:220].split(b"\0")[0].decode()
    shape = tuple(n for n in ndim if n)
    data = np.frombuffer(raw, dtype=dtype, count=int(np.prod(shape)), offset=384)
    data = data.reshape(shape, order="F")
    pos = 64 + wfm_size + formula
    note = raw[pos:pos + note_size].decode("latin-1")
    pos += note_size + data_e + sum(dim_e) + labels_size[0] + labels_size[1]
    block = raw[pos:pos + labels_size[2]]
    labels = [block[32 * k:32 * k + 32].split(b"\0")[0].decode() for k in
              range(1, labels_size[2] // 32)]
    entries = dict(line.split(":", 1) for line in note.split("\r") if ":" in line)
    return data, sfa, sfb, units, labels, {k: v.strip() for k, v in entries.items()}


@pytest.mark.data
def test_ibw_heights_sizes_units_from_header():
    path = data_path(*IBW)
    data, sfa, sfb, units, labels, note = parse_ibw(path)
    assert labels[:2] == ["HeightTrace", "HeightRetrace"] and data.shape == (256, 256, 8)
    topo = ibw.read(path)
    assert topo.attrs["channel"] == "HeightTrace" and topo.shape == (256, 256)
    np.testing.assert_array_equal(topo.values, data[:, :, 0].T.astype(float))
    retrace = ibw.read(path, channel="HeightRetrace")
    np.testing.assert_array_equal(retrace.values, data[:, :, 1].T.astype(float))
    grid = grid_of(topo)
    assert units == ("m", "m") and topo.attrs["units"] == "m" and grid.lateral_unit == "m"
    assert grid.spacing == pytest.approx((sfa[1], sfa[0]), rel=1e-15)
    assert sfa[:2] == pytest.approx((20e-6 / 255, 20e-6 / 255), rel=1e-15)
    # Asylum's ScanSize (20 um) spans first to last point: (n - 1) * spacing
    assert float(note["ScanSize"]) == pytest.approx(255 * sfa[0], rel=1e-12)
    assert float(topo.x[-1]) == pytest.approx(float(note["ScanSize"]), rel=1e-12)
    assert (topo.attrs["x_offset"], topo.attrs["y_offset"]) == (sfb[0], sfb[1])
    assert topo.attrs["date"] == "2019-10-24T12:14:13"  # Date:2019-10-24, Time:12:14:13 PM
    assert topo.attrs["instrument"] == note["MicroscopeModel"] == "Cypher"
    assert topo.attrs["scan_angle"] == 330.0
    assert "ImagingMode:AC Mode" in topo.attrs["note"]
    assert all(isinstance(v, (str, int, float)) for v in topo.attrs.values())


@pytest.mark.data
@pytest.mark.parametrize("index", [0, 1])
def test_ibw_agrees_with_surfacetopography(index):
    path = data_path(*IBW)
    heights, ref = st_read(path, index)
    topo = ibw.read(path, channel=index)
    np.testing.assert_array_equal(topo.values, heights[::-1])
    assert grid_of(topo).size == pytest.approx(tuple(ref.physical_sizes)[::-1], rel=1e-14)
    assert ref.unit == "m"


@pytest.mark.data
def test_ibw_channels_and_errors(tmp_path):
    path = data_path(*IBW)
    listed = {c["name"]: c["unit"] for c in ibw.channels(path)}
    assert listed["HeightTrace"] == "m" and listed["PhaseTrace"] == "deg"
    assert listed["NapPotentialTrace"] == "V"
    with pytest.raises(ValueError, match=r"spot_1-1000nm\.ibw: channel 4: 'PhaseTrace' "
                                         r"\(deg\) is not a height.*'HeightRetrace'"):
        ibw.read(path, channel="PhaseTrace")
    with pytest.raises(ValueError, match=r"no channel named 'ZSensorTrace'.*"
                                         r"'NapPotentialRetrace'"):
        ibw.read(path, channel="ZSensorTrace")
    blob = path.read_bytes()
    assert ibw.sniff(blob[:4096], path) and not ibw.sniff(blob[1:4097], path)
    renamed = tmp_path / "scan.bin"
    renamed.symlink_to(path)
    assert detect_format(renamed) == "ibw"
    cases = {
        "cut.ibw": (blob[:100_000], r"cut\.ibw: truncated file: the headers declare "
                                    r"\d+ bytes but the file has 100000"),
        "tiny.ibw": (blob[:200], r"tiny\.ibw: truncated file: 200 bytes"),
        "checksum.ibw": (blob[:150] + bytes([blob[150] ^ 0xFF]) + blob[151:],
                         r"checksum\.ibw: corrupted Igor binary wave: the header checksum"),
        "version.ibw": (b"\x07\x00" + blob[2:], r"version\.ibw: not an Igor binary wave"),
    }
    for name, (data, message) in cases.items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(ValueError, match=message):
            ibw.read(tmp_path / name)


def make_ibw(data, sfa, sfb=(0.0, 0.0), data_unit=b"m", dim_units=(b"m", b"m"), name=b"w"):
    """A minimal version-5 wave (no note, no labels) built from the published layout."""
    data = np.asarray(data, dtype="<f8")
    ndim = list(data.shape) + [0] * (4 - data.ndim)
    body = data.tobytes(order="F")
    wave = struct.pack("<4i", 0, 0, 0, data.size) + struct.pack("<hh6sh", 4, 0, b"", 1)
    wave += struct.pack("<32s", name) + struct.pack("<ii", 0, 0) + struct.pack("<4i", *ndim)
    wave += struct.pack("<4d", *(list(sfa) + [1.0] * (4 - len(sfa))))
    wave += struct.pack("<4d", *(list(sfb) + [0.0] * (4 - len(sfb))))
    wave += struct.pack("<4s", data_unit)
    wave += b"".join(struct.pack("<4s", u) for u in (list(dim_units) + [b""] * 4)[:4])
    wave += bytes(320 - len(wave))
    assert len(wave) == 320
    wfm_size = 320 + len(body)
    head = struct.pack("<hhiiii4i4iiii", 5, 0, wfm_size, 0, 0, 0, *[0] * 8, 0, 0, 0)
    total = int(np.frombuffer(head + wave, dtype="<i2").astype(np.int64).sum())
    head = head[:2] + struct.pack("<H", -total % 65536) + head[4:]  # words sum to 0
    return head + wave + body


def test_ibw_plain_waves(tmp_path):
    """2D and 1D waves without Asylum note: units and scaling from the wave header."""
    data = np.arange(12.0).reshape(4, 3)  # Igor rows = x (4 points), columns = y (3)
    path = tmp_path / "plain.ibw"
    path.write_bytes(make_ibw(data * 1e-3, (0.5, 0.25), (1.0, 2.0), b"um", (b"um", b"nm")))
    assert ibw.sniff(path.read_bytes()[:4096], path)
    topo = ibw.read(path)
    np.testing.assert_array_equal(topo.values, data.T * 1e-3)
    assert topo.attrs["units"] == "um" and topo.x.attrs["units"] == "um"
    assert grid_of(topo).spacing == pytest.approx((0.25e-3, 0.5), rel=1e-15)  # nm -> um
    assert (topo.attrs["x_offset"], topo.attrs["channel"]) == (1.0, "w")
    # a negative wave scaling reverses the axis so that coordinates increase
    path.write_bytes(make_ibw(data, (-0.5, 0.25), (3.0, 0.0)))
    flipped = ibw.read(path)
    np.testing.assert_array_equal(flipped.values, data[::-1].T)
    assert flipped.attrs["x_offset"] == 1.5 and grid_of(flipped).spacing[1] == 0.5
    path.write_bytes(make_ibw(np.arange(6.0), (2e-9,), dim_units=(b"m",)))
    profile = ibw.read(path)
    assert profile.dims == ("x",) and grid_of(profile).spacing == pytest.approx((2e-9,))
    path.write_bytes(make_ibw(data, (0.5, 0.25), data_unit=b"V"))
    with pytest.raises(ValueError, match=r"plain\.ibw: no height channel.*0: 'w' \(V\)"):
        ibw.read(path)


# --------------------------------------------------------------------------- Gwyddion


@pytest.fixture
def height_map():
    rng = np.random.default_rng(7)
    h = rng.normal(scale=3e-9, size=(37, 53))
    h[4, 9] = h[20, 0] = np.nan
    return xrough.topography(h, spacing=(2.5e-8, 1.5e-8), unit="m", periodic=True,
                             attrs={"instrument": "synthetic", "seed": 7, "dx_nm": 15.0})


def test_gwy_write_read_round_trip(tmp_path, height_map):
    path = tmp_path / "map.gwy"
    gwy.write(height_map, path)
    assert gwy.sniff(path.read_bytes()[:64], path)
    back = gwy.read(path)
    np.testing.assert_array_equal(back.values, height_map.values)  # NaNs at the same points
    for dim in ("x", "y"):
        xr.testing.assert_identical(back[dim], height_map[dim])
    assert {k: back.attrs[k] for k in height_map.attrs} == height_map.attrs
    assert back.attrs["masked_points"] == 2 and back.attrs["channel"] == "height"
    # a topography read from a .gwy file comes back identical
    gwy.write(back, tmp_path / "again.gwy")
    xr.testing.assert_identical(gwy.read(tmp_path / "again.gwy"), back)


def test_gwy_writes_metres(tmp_path, height_map):
    in_nm = xrough.topography(height_map.values * 1e9, spacing=(25.0, 15.0), unit="nm")
    gwy.write(in_nm, tmp_path / "nm.gwy")
    back = gwy.read(tmp_path / "nm.gwy")
    assert back.attrs["units"] == "m" and back.x.attrs["units"] == "m"
    np.testing.assert_array_equal(back.values, in_nm.values * 1e-9)
    assert grid_of(back).size == pytest.approx((37 * 25e-9, 53 * 15e-9), rel=1e-14)


def test_gwy_written_file_read_by_surfacetopography(tmp_path, height_map):
    path = tmp_path / "map.gwy"
    gwy.write(height_map, path)
    heights, ref = st_read(path)
    np.testing.assert_array_equal(heights[::-1], height_map.values)
    assert tuple(ref.physical_sizes)[::-1] == pytest.approx(grid_of(height_map).size,
                                                            rel=1e-14)


def _gwyfile_container(gwyfile, data, **extra):
    """A .gwy written with gwyfile directly (not through xrough): phase and height."""
    objects = gwyfile.objects
    c = objects.GwyContainer()
    c["/0/data"] = objects.GwyDataField(np.zeros((4, 5)), xreal=1e-6, yreal=1e-6,
                                        si_unit_xy="m", si_unit_z="deg")
    c["/0/data/title"] = "Phase"
    c["/3/data"] = objects.GwyDataField(data, xreal=5e-6, yreal=2e-6, xoff=1e-6, yoff=-2e-6,
                                        si_unit_xy="m", si_unit_z="m")
    c["/3/data/title"] = "Topo"
    for key, value in extra.items():
        c[key] = value
    return c


def test_gwy_reads_independently_written_file(tmp_path):
    gwyfile = pytest.importorskip("gwyfile")
    data = np.arange(20.0).reshape(4, 5) * 1e-9
    mask = np.zeros((4, 5))
    mask[0, 1] = 1.0  # top row in Gwyddion = last row in xrough
    meta = gwyfile.objects.GwyContainer({"Operator": "someone", "Scan rate": "1.5",
                                         "Lines": "4"})
    c = _gwyfile_container(gwyfile, data, **{
        "/3/mask": gwyfile.objects.GwyDataField(mask, xreal=5e-6, yreal=2e-6),
        "/3/meta": meta})
    path = tmp_path / "two.gwy"
    c.tofile(str(path))
    topo = gwy.read(path)  # the first channel with length units
    assert topo.attrs["channel"] == "Topo" and topo.attrs["channel_index"] == 3
    expected = data[::-1].copy()
    expected[3, 1] = np.nan
    np.testing.assert_array_equal(topo.values, expected)
    assert grid_of(topo).size == pytest.approx((2e-6, 5e-6), rel=1e-15)
    assert (topo.attrs["x_offset"], topo.attrs["y_offset"]) == (1e-6, -2e-6)
    assert topo.attrs["Operator"] == "someone" and topo.attrs["Scan rate"] == 1.5
    assert topo.attrs["Lines"] == 4 and topo.attrs["masked_points"] == 1
    unmasked = gwy.read(path, channel="topo", mask=False)
    np.testing.assert_array_equal(unmasked.values, data[::-1])
    assert [c["name"] for c in gwy.channels(path)] == ["Phase", "Topo"]
    with pytest.raises(ValueError, match=r"two\.gwy: channel 0: 'Phase' \(deg\) has values "
                                         r"in 'deg'"):
        gwy.read(path, channel=0)
    with pytest.raises(ValueError, match=r"no channel named 'Height'; channels: 0: 'Phase' "
                                         r"\(deg\); 3: 'Topo' \(m\)"):
        gwy.read(path, channel="Height")


def test_gwy_corrupted_files_raise_value_error(tmp_path, height_map):
    gwyfile = pytest.importorskip("gwyfile")
    good = tmp_path / "good.gwy"
    gwy.write(height_map, good)
    blob = good.read_bytes()
    cases = {
        "cut.gwy": (blob[: len(blob) // 2], r"cut\.gwy: truncated file: the container "
                                            r"declares \d+ bytes"),
        "head.gwy": (blob[:10], r"head\.gwy: truncated file"),
        "magic.gwy": (b"GWYO" + blob[4:], r"magic\.gwy: not a Gwyddion file"),
        "garbled.gwy": (blob[:30] + b"\xff" * 40 + blob[70:], r"garbled\.gwy: corrupted "
                                                                r"Gwyddion file"),
    }
    for name, (data, message) in cases.items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(ValueError, match=message):
            gwy.read(tmp_path / name)
    empty = tmp_path / "empty.gwy"
    gwyfile.objects.GwyContainer({"/filename": "x"}).tofile(str(empty))
    with pytest.raises(ValueError, match=r"empty\.gwy: the file holds no data fields"):
        gwy.read(empty)


def test_gwy_write_refuses_profiles_and_stacks(tmp_path, height_map):
    profile = xrough.topography(np.arange(5.0), spacing=1.0, unit="nm")
    with pytest.raises(ValueError, match="one map with dims"):
        gwy.write(profile, tmp_path / "p.gwy")
    stack = xr.concat([height_map, height_map], dim="scan")
    with pytest.raises(ValueError, match="one map with dims"):
        gwy.write(stack, tmp_path / "s.gwy")


def test_gwy_detected_by_content(tmp_path, height_map):
    path = tmp_path / "map.txt"  # the extension lies
    gwy.write(height_map, path)
    assert detect_format(path) == "gwy"
    assert not gwy.sniff(b"\\*File list", None)
