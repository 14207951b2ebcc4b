"""Readers of text and AFM files: detection fallbacks, header-stated scales and sizes checked
against the data, channel listings, the row orientation, and fuzzing.

Every file here is synthetic (written byte by byte from the published layouts, or by the
project's own writers), so these tests run everywhere; the real instrument files are used
only where marked ``data``.
"""

import io
import re
import struct
import tracemalloc
import warnings
from pathlib import Path

import numpy as np
import numpy.lib.format as npformat
import pytest
import xarray as xr
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_io_afm import make_ibw

import xrough
from conftest import data_path
from xrough.io import detect_format, ibw, list_channels, nanoscope, open_topography, text
from xrough.io.backend import XroughBackendEntrypoint
from xrough.topography import grid_of

FUZZ = settings(max_examples=200, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])


# --------------------------------------------------------------------------- builders


def make_nanoscope(images, *, scan_size="400 200 nm", sens=20.0, hard=100.0,
                   scan_list_res=None):
    r"""A minimal Nanoscope file: a ``\*File list`` header, then 16-bit images.

    ``images`` is a list of ``(name, counts, extra)`` with ``counts`` an int16 array
    ``(ny, nx)`` in storage order and ``extra`` a dict of header entries to replace.
    """
    header_size = 8192
    lines = ["\\*File list", "\\Version: 0x07200000",
             "\\Date: 03:08:09 PM Thu Apr 05 2018", f"\\Data length: {header_size}",
             "\\*Equipment list", "\\Microscope: Synthetic",
             "\\*Scanner list", f"\\@Sens. Zsens: V {sens} nm/V"]
    if scan_list_res is not None:
        lines += ["\\*Ciao scan list", f"\\Samps/line: {scan_list_res[1]}",
                  f"\\Lines: {scan_list_res[0]}", f"\\Scan Size: {scan_size}"]
    offset = header_size
    blobs = []
    for name, counts, extra in images:
        counts = np.asarray(counts, dtype="<i2")
        ny, nx = counts.shape
        entries = {"Data offset": str(offset), "Data length": str(counts.nbytes),
                   "Bytes/pixel": "2", "Samps/line": str(nx), "Number of lines": str(ny),
                   "Scan Size": scan_size, "Line Direction": "Trace", "Scan Line": "Main",
                   "@2:Image Data": f'S [{name}] "{name}"',
                   "@2:Z scale": f"V [Sens. Zsens] (0.0015 V/LSB) {hard} V"}
        entries.update(extra)
        lines.append("\\*Ciao image list")
        lines += [f"\\{k}: {v}" for k, v in entries.items()]
        offset += counts.nbytes
        blobs.append(counts.tobytes())
    lines.append("\\*File list end")
    head = "\r\n".join(lines).encode("latin-1") + b"\r\n"
    assert len(head) <= header_size
    return head + bytes(header_size - len(head)) + b"".join(blobs)


def make_metropro(heights_counts, *, lateral_res=1e-6, wavelength=632.8e-9):
    """A Zygo MetroPro ``.dat`` (header format 1, 834 bytes, no intensity data).

    The field layout (names, formats, byte orders) is taken from SurfaceTopography's own
    declarative description of the format, so this needs SurfaceTopography.
    """
    reader = pytest.importorskip("SurfaceTopography.IO.MetroPro").MetroProReader
    fields = reader._file_layout._structures[0]._structure_format
    offsets, pos = {}, 0
    for field in fields:
        fmt = field[1] if field[1][0] in "<>" else ">" + field[1]
        offsets[field[0]] = (pos, fmt)
        pos += struct.calcsize(fmt)
    assert pos == 834
    counts = np.asarray(heights_counts, dtype=">i4")
    ny, nx = counts.shape
    header = bytearray(834)
    values = {"magic": b"\x88\x1b\x03\x6f", "header_format": 1, "header_size": 834,
              "cn_org_width": nx, "cn_org_height": ny, "cn_n_bytes": counts.nbytes,
              "intf_scale_factor": 0.5, "wavelength_in": wavelength,
              "obliquity_factor": 1.0, "lateral_res": lateral_res, "phase_res": 1}
    for key, value in values.items():
        at, fmt = offsets[key]
        struct.pack_into(fmt, header, at, value)
    return bytes(header) + counts.tobytes()


def peak(topo):
    """``(x, y)`` of a map's highest point."""
    iy, ix = np.unravel_index(int(np.nanargmax(topo.values)), topo.shape)
    return float(topo.x[ix]), float(topo.y[iy])


def bump(ny, nx):
    """An asymmetric map: one raised pixel near the first stored line's left end."""
    counts = np.zeros((ny, nx), dtype=np.int16)
    counts[1, 2] = 1000
    return counts


# --------------------------------------------------------------------------- detection


def test_metropro_dat_goes_to_the_bridge_not_the_text_reader(tmp_path):
    pytest.importorskip("SurfaceTopography")
    counts = np.arange(12 * 8, dtype=np.int32).reshape(8, 12) * 3 - 100
    path = tmp_path / "zygo.dat"
    path.write_bytes(make_metropro(counts))
    assert detect_format(path) == xrough.io.BRIDGE
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        topo = open_topography(path)
    assert topo.shape == (8, 12) and topo.attrs["format"] == xrough.io.BRIDGE
    assert grid_of(topo).spacing == pytest.approx((1e-6, 1e-6), rel=1e-6)
    scale = 0.5 * 632.8e-9 / 32768  # intf_scale * wavelength / phase resolution
    # SurfaceTopography's row 0 is the picture's top: xrough's y = 0 is the last line
    np.testing.assert_allclose(topo.values, counts[::-1] * scale, rtol=1e-6)


def test_binary_dat_without_bridge_is_unknown_not_bad_text(tmp_path, monkeypatch):
    path = tmp_path / "zygo.dat"
    path.write_bytes(b"\x88\x1b\x03\x6f" + bytes(range(256)) * 8)
    monkeypatch.setattr(xrough.io, "available", lambda name: False)  # no bridge
    with pytest.raises(ValueError, match=r"zygo\.dat: unknown file format") as err:
        detect_format(path)
    assert "binary content" not in str(err.value)
    text_file = tmp_path / "ok.dat"
    text_file.write_text("# Width: 2 um\n# Height: 2 um\n# Value units: nm\n1 2\n3 4\n")
    assert detect_format(text_file) == "text"


def test_directory_and_empty_file(tmp_path):
    (tmp_path / "d.txt").mkdir()
    with pytest.raises(OSError, match=r"d\.txt: is a directory"):
        open_topography(tmp_path / "d.txt")
    (tmp_path / "e.spm").write_bytes(b"")
    with pytest.raises(ValueError, match=r"e\.spm: the file is empty"):
        open_topography(tmp_path / "e.spm")


# --------------------------------------------------------------------------- text


GWY_FACTOR = """Channel: Height
Width: 10.000 µm
Height: 5.000 µm
Value units: m
height conversion factor (-> m)=6.30079e-008
"""


def test_gwyddion_text_conversion_factor_applied(tmp_path):
    raw = np.array([[1, 2, 3, 4], [5, 6, 7, 8]])
    path = tmp_path / "export.txt"
    path.write_text(GWY_FACTOR + "\n".join("\t".join(map(str, r)) for r in raw) + "\n",
                    encoding="utf-8")
    topo = open_topography(path)
    assert topo.attrs["units"] == "m" and topo.x.attrs["units"] == "um"
    # the first line is the picture's top row: y = 0 is the last line
    np.testing.assert_allclose(topo.values, raw[::-1] * 6.30079e-8, rtol=1e-15)
    assert grid_of(topo).spacing == pytest.approx((2.5, 2.5))
    assert "6.30079e-008" in topo.attrs["height_conversion"]
    # without Value units the factor's target unit is the height unit
    path.write_text(GWY_FACTOR.replace("Value units: m\n", "")
                    + "\n".join("\t".join(map(str, r)) for r in raw) + "\n", encoding="utf-8")
    again = open_topography(path)
    assert again.attrs["units"] == "m"
    np.testing.assert_array_equal(again.values, topo.values)


def test_gwyddion_text_narrow_matrix_is_a_matrix_not_xyz(tmp_path):
    path = tmp_path / "narrow.txt"
    path.write_text("# Width: 3.0 um\n# Height: 4.0 um\n# Value units: nm\n"
                    "1 2 3\n4 5 6\n7 8 9\n10 11 12\n", encoding="utf-8")
    topo = open_topography(path)
    assert topo.attrs["text_layout"] == "matrix" and topo.shape == (4, 3)
    assert grid_of(topo).spacing == pytest.approx((1.0, 1.0))
    assert topo.values[0].tolist() == [10, 11, 12]  # last line at y = 0


@pytest.mark.parametrize("body", [
    "X;Z\n[mm];[mm]\n0\t0.001\n0.1\t0.002\n0.2\t0.0015\n",
    "[mm];[mm]\n0 0.001\n0.1 0.002\n0.2 0.0015\n",
    "X;Z\n[mm];[mm]\n0;0,001\n0,1;0,002\n0,2;0,0015\n",
])
def test_hfm_bracketed_column_units(tmp_path, body):
    path = tmp_path / "profile.hfm"
    path.write_text(body, encoding="utf-8")
    topo = open_topography(path)
    assert topo.x.attrs["units"] == "mm" and topo.attrs["units"] == "mm"
    np.testing.assert_allclose(topo.values, [0.001, 0.002, 0.0015])


def test_text_matrix_with_stated_counts_truncated_at_a_row_boundary_is_refused(tmp_path):
    # Without point counts, a matrix cut at a line boundary cannot be told from one with
    # rectangular pixels (Gwyddion writes only Width and Height): it is read with dy != dx
    # (tests/test_io_text_wild.py). Stated point counts are checked.
    rows = ["\t".join(str(v) for v in range(8))] * 8
    path = tmp_path / "cut.txt"
    path.write_text("# Width: 8 um\n# Height: 8 um\n# Value units: nm\n# ny: 8\n# nx: 8\n"
                    + "\n".join(rows[:4]) + "\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"cut\.txt: the header states 8 points along y "
                                         r"but the matrix has 4"):
        open_topography(path)
    # the user's size= replaces the header's sizes (the counts are still checked)
    path.write_text("# Width: 8 um\n# Height: 8 um\n# Value units: nm\n"
                    + "\n".join(rows[:4]) + "\n", encoding="utf-8")
    topo = open_topography(path, size=("4 um", "8 um"))
    assert grid_of(topo).spacing == pytest.approx((1.0, 1.0))


DEKTAK = """Scan Parameters
Scan Type,Standard Scan
Length,100.0 um
Resolution,0.5 um/sample

Scan Data
Lateral um,Raw Micrometer,
"""


def test_dektak_csv_truncated_is_refused(tmp_path):
    x = np.arange(201) * 0.5
    lines = [f"{a:.1f},{0.01 * np.sin(a):.5f},," for a in x]
    path = tmp_path / "dektak.csv"
    path.write_text(DEKTAK + "\n".join(lines) + "\n", encoding="utf-8")
    topo = open_topography(path)
    assert topo.sizes["x"] == 201
    path.write_text(DEKTAK + "\n".join(lines[:20]) + "\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"dektak\.csv: the header states a length of 100 um "
                                         r"but the 20 points cover 9\.5 um.*truncated"):
        open_topography(path)


@pytest.mark.data
def test_real_dektak_truncated_to_ten_percent_is_refused(tmp_path):
    blob = data_path("instruments", "dektak-1.csv").read_bytes()
    lines = blob.splitlines(keepends=True)
    start = next(i for i, line in enumerate(lines) if line.startswith(b"Lateral"))
    keep = start + 1 + (len(lines) - start - 1) // 10
    cut = tmp_path / "dektak-cut.csv"
    cut.write_bytes(b"".join(lines[:keep]))
    with pytest.raises(ValueError, match=r"dektak-cut\.csv: the header states a length of "
                                         r"1500 um"):
        open_topography(cut)


def test_undecodable_text_names_the_file(tmp_path):
    path = tmp_path / "latin.txt"
    path.write_bytes("# Width: 2 µm\n# Height: 2 µm\n# Value units: nm\n1 2\n3 4\n"
                     .encode("latin-1"))
    with pytest.raises(ValueError, match=r"latin\.txt: cannot decode the file as 'ascii'"):
        open_topography(path, encoding="ascii")
    with pytest.raises(ValueError, match=r"latin\.txt: cannot decode.*'no-such-codec'"):
        open_topography(path, encoding="no-such-codec")
    assert open_topography(path).x.attrs["units"] == "um"  # Latin-1 fallback


def test_third_party_value_errors_are_wrapped(tmp_path, monkeypatch):
    """A ValueError subclass from a parser (dateutil's ParserError...) names the file."""

    class ParserError(ValueError):
        pass

    def broken(path, **options):
        raise ParserError("Unknown string format: \x00\x00 12:00")

    path = tmp_path / "m.txt"
    path.write_text("# Width: 2 um\n# Height: 2 um\n# Value units: nm\n1 2\n3 4\n")
    monkeypatch.setattr(text, "read", broken)
    with pytest.raises(ValueError, match=r"^m\.txt: cannot read as plain text.*corrupted.*"
                                         r"ParserError"):
        open_topography(path)

    def divide(path, **options):
        return 1 / 0

    monkeypatch.setattr(text, "read", divide)
    with pytest.raises(ValueError, match=r"^m\.txt: cannot read as plain text.*corrupted or "
                                         r"inconsistent.*ZeroDivisionError"):
        open_topography(path)


def test_channel_on_a_format_without_channels(tmp_path):
    path = tmp_path / "m.txt"
    path.write_text("# Width: 2 um\n# Height: 2 um\n# Value units: nm\n1 2\n3 4\n")
    with pytest.raises(ValueError, match=r"m\.txt: the text reader has no option channel= "
                                         r"\(the format has no channels\)"):
        open_topography(path, channel="Height")
    assert list_channels(path) == []


def test_acf_of_a_nonuniform_profile_points_to_resample():
    x = np.cumsum(np.r_[0.0, np.linspace(1.0, 2.0, 63)])
    profile = xrough.topography(np.sin(x), spacing=1.0, unit="um").assign_coords(x=x)
    profile.x.attrs["units"] = "um"
    with pytest.raises(ValueError, match=r"not uniformly spaced.*resample=True"):
        profile.rough.acf()


# --------------------------------------------------------------------------- Nanoscope


def test_nanoscope_height_and_zsensor_warns_and_lists(tmp_path):
    counts = bump(4, 6)
    path = tmp_path / "two.spm"
    path.write_bytes(make_nanoscope([("Height", counts, {}), ("ZSensor", counts * 2, {}),
                                     ("Phase", counts, {"@2:Z scale": "V (0.1 deg/LSB) 9 deg"})]))
    with pytest.warns(UserWarning, match=r"two\.spm: several quantities in a length unit "
                                         r"\('Height', 'ZSensor'\); reading channel 0: "
                                         r"'Height'.*channel="):
        topo = open_topography(path)
    assert topo.attrs["channel"] == "Height"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        z = open_topography(path, channel="ZSensor")
    np.testing.assert_allclose(z.values, 2 * topo.values)
    listed = list_channels(path)
    assert [c["name"] for c in listed] == ["Height", "ZSensor", "Phase"]
    assert [c["default"] for c in listed] == [True, False, False]
    assert [c["is_height"] for c in listed] == [True, True, False]
    assert listed[0]["description"] == "0: Height [nm] height, Main, Trace (default)"
    assert listed[2]["description"] == "2: Phase [deg], Main, Trace"
    assert nanoscope.default_channel(path) == 0


def test_nanoscope_trace_and_interleave_height_is_not_ambiguous(tmp_path):
    counts = bump(4, 6)
    path = tmp_path / "lift.spm"
    path.write_bytes(make_nanoscope([("Height", counts, {}),
                                     ("Height", counts, {"Scan Line": "Interleave"})]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert open_topography(path).attrs["channel_index"] == 0


def test_nanoscope_orientation_first_stored_line_at_y0(tmp_path):
    """Nanoscope stores the picture's bottom line first: it is xrough's y = 0."""
    counts = bump(4, 6)
    path = tmp_path / "bump.spm"
    path.write_bytes(make_nanoscope([("Height", counts, {})], scan_size="600 400 nm"))
    topo = open_topography(path)
    assert peak(topo) == pytest.approx((200.0, 100.0))
    assert topo.values[1, 2] == pytest.approx(1000 * 100.0 / 65536 * 20.0)


def test_nanoscope_inconsistent_samps_line_is_never_a_silent_rescale(tmp_path):
    counts = bump(4, 6)
    path = tmp_path / "bad.spm"
    path.write_bytes(make_nanoscope([("Height", counts, {"Samps/line": "3"})],
                                    scan_size="600 400 nm"))
    with pytest.raises(ValueError, match=r"bad\.spm: channel 'Height': the header is "
                                         r"inconsistent: Data length 48 bytes is not "
                                         r"Samps/line 3 x Number of lines 4"):
        open_topography(path)
    # the scan list states the resolution that fits: read with a warning and an attr,
    # the stated Scan Size kept (the old reader scaled it by 6/3)
    path.write_bytes(make_nanoscope([("Height", counts, {"Samps/line": "3"})],
                                    scan_size="600 400 nm", scan_list_res=(4, 6)))
    with pytest.warns(UserWarning, match=r"bad\.spm: channel 'Height': Samps/line 3"):
        topo = open_topography(path)
    assert topo.shape == (4, 6) and grid_of(topo).size == pytest.approx((400.0, 600.0))
    assert "contradict Data length" in topo.attrs["header_inconsistency"]


@pytest.mark.data
def test_real_nanoscope_lists_channels_without_warning():
    path = data_path("instruments", "di-1.di")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        topo = open_topography(path)
    listed = list_channels(path)
    assert [c["default"] for c in listed].index(True) == topo.attrs["channel_index"] == 0
    assert listed[1]["description"] == "1: Height [nm] height, Interleave, Retrace"


# --------------------------------------------------------------------------- Igor


def test_ibw_without_unit_takes_unit(tmp_path):
    data = np.arange(12.0).reshape(4, 3)
    path = tmp_path / "nounit.ibw"
    path.write_bytes(make_ibw(data, (0.5, 0.25), data_unit=b"", dim_units=(b"", b"")))
    with pytest.raises(ValueError, match=r"nounit\.ibw: no height channel.*needs one: "
                                         r"pass unit= or height_unit="):
        open_topography(path)
    topo = open_topography(path, unit="um")
    assert topo.attrs["units"] == "um" and topo.x.attrs["units"] == "um"
    assert grid_of(topo).spacing == pytest.approx((0.25, 0.5))
    np.testing.assert_array_equal(topo.values, data.T)
    nm = open_topography(path, unit="um", height_unit="nm")
    assert nm.attrs["units"] == "nm" and nm.x.attrs["units"] == "um"
    # lateral units in the file, none for the data: height_unit= alone is enough
    path.write_bytes(make_ibw(data, (0.5, 0.25), data_unit=b""))
    assert ibw.read(path, height_unit="nm").attrs["units"] == "nm"


def test_ibw_orientation_igor_y_up(tmp_path):
    """Igor shows dimension 0 to the right and dimension 1 upwards: column j at y = j dy."""
    data = np.zeros((6, 4))
    data[2, 1] = 5.0  # x index 2, y index 1
    path = tmp_path / "bump.ibw"
    path.write_bytes(make_ibw(data, (1.0, 2.0), data_unit=b"nm", dim_units=(b"nm", b"nm")))
    topo = open_topography(path)
    assert peak(topo) == (2.0, 2.0)


# --------------------------------------------------------------------------- orientation


def test_text_orientation_first_line_is_top(tmp_path):
    """A matrix export lists the picture's top line first: the last line is at y = 0."""
    grid = np.zeros((4, 5))
    grid[0, 1] = 7.0  # first line of the file
    path = tmp_path / "bump.txt"
    np.savetxt(path, grid, header="Width: 5 um\nHeight: 4 um\nValue units: nm")
    topo = open_topography(path)
    assert peak(topo) == (1.0, 3.0)


def test_bridge_orientation_agrees_with_native_text(tmp_path):
    pytest.importorskip("SurfaceTopography")
    grid = np.zeros((4, 5))
    grid[0, 1] = 7.0
    path = tmp_path / "bump.txt"
    np.savetxt(path, grid, header="Width: 5 um\nHeight: 4 um\nValue units: um")
    native = open_topography(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bridged = open_topography(path, format=xrough.io.BRIDGE, unit="um")
    np.testing.assert_array_equal(bridged.values, native.values)


# --------------------------------------------------------------------------- fuzzing


def _outcome(path: Path, reader=open_topography, **options):
    """Read ``path``: a clean error naming the file, or a topography."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            topo = reader(path, **options)
    except (ValueError, OSError) as err:
        assert path.name in str(err), f"error does not name the file: {err!r}"
        return None
    if topo.attrs.get("sampling") == "non-uniform":  # kept as measured, on its own x
        assert np.all(np.diff(topo.x.values) > 0)
    else:
        assert np.all(np.isfinite(np.asarray(grid_of(topo).spacing)))
    return topo


def _mutate(blob: bytes, data) -> bytes:
    kind = data.draw(st.sampled_from(["truncate", "flip", "insert", "zero", "splice",
                                      "number", "number"]))
    n = len(blob)
    if kind == "number":  # an absurd header value: sizes, counts, offsets, scales
        numbers = [m.span() for m in re.finditer(rb"\d+(?:\.\d+)?", blob[:8192])]
        if numbers:
            a, b = data.draw(st.sampled_from(numbers))
            value = data.draw(st.sampled_from([b"0", b"-1", b"1e308", b"nan", b"2147483647",
                                               b"99999999999999999999", b"0.0", b"1e-300"]))
            return blob[:a] + value + blob[b:]
        kind = "flip"
    if kind == "truncate":
        return blob[:data.draw(st.integers(0, n))]
    if kind == "zero":
        return b""
    if kind == "insert":
        at = data.draw(st.integers(0, n))
        return blob[:at] + data.draw(st.binary(min_size=1, max_size=16)) + blob[at:]
    if kind == "splice":
        a = data.draw(st.integers(0, n))
        b = data.draw(st.integers(a, n))
        return blob[:a] + blob[b:]
    out = bytearray(blob)
    for _ in range(data.draw(st.integers(1, 8))):
        at = data.draw(st.integers(0, n - 1))
        out[at] ^= data.draw(st.integers(1, 255))
    return bytes(out)


TEXT_SEEDS = {
    "matrix.txt": (b"# Width: 4 um\n# Height: 2 um\n# Value units: nm\n"
                   b"1 2 3 4\n5 6 7 8\n"),
    "factor.txt": (GWY_FACTOR + "1\t2\t3\t4\n5\t6\t7\t8\n").encode("utf-8"),
    "dektak.csv": (DEKTAK + "\n".join(f"{a:.1f},{a / 10:.3f},," for a in
                                      np.arange(201) * 0.5) + "\n").encode(),
    "profile.hfm": b"X;Z\n[mm];[mm]\n0;0,001\n0,1;0,002\n0,2;0,0015\n",
    "points.xyz": b"0 0 1\n0 1 2\n1 0 3\n1 1 4\n2 0 5\n2 1 6\n",
}


@FUZZ
@given(data=st.data())
def test_fuzz_text_reader(tmp_path_factory, data):
    name = data.draw(st.sampled_from(sorted(TEXT_SEEDS)))
    blob = _mutate(TEXT_SEEDS[name], data)
    suffix = data.draw(st.sampled_from(["", ".spm", ".ibw", ".dat"]))
    path = tmp_path_factory.mktemp("fuzz") / (name + suffix)
    path.write_bytes(blob)
    _outcome(path, unit="um") if name == "points.xyz" else _outcome(path)
    _outcome(path, text.read, unit="um")


@FUZZ
@given(data=st.data())
def test_fuzz_nanoscope_reader(tmp_path_factory, data):
    seed = make_nanoscope([("Height", bump(6, 8), {}), ("ZSensor", bump(6, 8), {})],
                          scan_list_res=(6, 8))
    blob = _mutate(seed, data)
    path = tmp_path_factory.mktemp("fuzz") / "scan.spm"
    path.write_bytes(blob)
    topo = _outcome(path, nanoscope.read)
    if topo is not None:  # a correct read: sizes as stated, never more points than bytes
        assert topo.size * 2 <= len(blob)


@FUZZ
@given(data=st.data())
def test_fuzz_ibw_reader(tmp_path_factory, data):
    seed = make_ibw(np.arange(30.0).reshape(6, 5), (1e-9, 2e-9))
    blob = _mutate(seed, data)
    path = tmp_path_factory.mktemp("fuzz") / "wave.ibw"
    path.write_bytes(blob)
    topo = _outcome(path, ibw.read)
    if topo is not None:
        assert topo.size * 8 <= len(blob)


SAME_PICTURE = [("instruments", "x3p-2.x3p"), ("instruments", "sur-2.sur"),
                ("instruments", "sdf-1.sdf"), ("instruments", "di-1.di"),
                ("instruments", "spot_1-1000nm.ibw"), ("instruments", "matrix-3.txt")]


@pytest.mark.data
@pytest.mark.parametrize("parts", SAME_PICTURE, ids=[p[1] for p in SAME_PICTURE])
def test_native_and_surfacetopography_give_the_same_picture(parts):
    """One orientation for every format: the native reader and the bridge agree, row by row.

    SurfaceTopography orients each format on its own (it flips Nanoscope and Igor images,
    not X3P...); the bridge maps its arrays to xrough's convention once.
    """
    pytest.importorskip("SurfaceTopography")
    path = data_path(*parts)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        native = open_topography(path)
        bridged = open_topography(path, format=xrough.io.BRIDGE)
    factor = xrough.units.conversion_factor(bridged.attrs["units"], native.attrs["units"])
    a, b = native.values, bridged.values * factor
    scale = np.nanmax(np.abs(a))
    np.testing.assert_allclose(b, a, rtol=1e-6, atol=1e-9 * scale)
    assert not np.allclose(b[::-1], a, rtol=1e-6, atol=1e-9 * scale, equal_nan=True)


@pytest.mark.parametrize("suffix", [".x3p", ".gwy", ".txt"])
def test_written_and_read_back_by_both_readers_keeps_a_corner_feature(tmp_path, suffix):
    pytest.importorskip("SurfaceTopography")
    heights = np.zeros((6, 9))
    heights[1, 2] = 1e-6
    topo = xrough.topography(heights, spacing=(1e-6, 1e-6), unit="m")
    path = tmp_path / f"bump{suffix}"
    writer = {".x3p": xrough.io.x3p.write, ".gwy": xrough.io.gwy.write,
              ".txt": text.write}[suffix]
    writer(topo, path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        native = open_topography(path)
        bridged = open_topography(path, format=xrough.io.BRIDGE)
    assert peak(native) == pytest.approx((2e-6, 1e-6))
    assert peak(bridged) == pytest.approx((2e-6, 1e-6))



def test_npy_declaring_more_data_than_the_file_holds_allocates_nothing(tmp_path):
    buffer = io.BytesIO()
    npformat.write_array_header_1_0(buffer, {"descr": "<f8", "fortran_order": False,
                                             "shape": (30000, 30000)})
    path = tmp_path / "bomb.npy"
    path.write_bytes(buffer.getvalue() + bytes(800))
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=r"bomb\.npy: truncated or damaged file: the "
                                             r"header declares shape \(30000, 30000\)"):
            open_topography(path, size="1 um", unit="nm")
        peak_bytes = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak_bytes < 50e6
    np.save(path, np.arange(12.0).reshape(3, 4))
    assert open_topography(path, size="1 um", unit="nm").shape == (3, 4)


@FUZZ
@given(data=st.data())
def test_fuzz_npy_reader(tmp_path_factory, data):
    buffer = io.BytesIO()
    np.save(buffer, np.arange(24.0).reshape(4, 6))
    blob = _mutate(buffer.getvalue(), data)
    path = tmp_path_factory.mktemp("fuzz") / "h.npy"
    path.write_bytes(blob)
    topo = _outcome(path, size="6 um", unit="nm")
    if topo is not None:
        assert topo.size * topo.dtype.itemsize <= len(blob)


def test_xarray_backend_passes_the_text_encoding(tmp_path):
    path = tmp_path / "latin.txt"
    path.write_bytes("# Width: 2 µm\n# Height: 2 µm\n# Value units: nm\n1 2\n3 4\n"
                     .encode("latin-1"))
    ds = xr.open_dataset(path, engine=XroughBackendEntrypoint, encoding="latin-1")
    assert ds["height"].x.attrs["units"] == "um"
    with pytest.raises(ValueError, match=r"latin\.txt: cannot decode the file as 'ascii'"):
        xr.open_dataset(path, engine=XroughBackendEntrypoint, encoding="ascii")


def test_ibw_height_and_zsensor_is_ambiguous(tmp_path):
    chans = [{"index": k, "name": n, "unit": u, "is_height": u == "m"}
             for k, (n, u) in enumerate([("HeightTrace", "m"), ("HeightRetrace", "m"),
                                         ("ZSensorTrace", "m"), ("PhaseTrace", "deg")])]
    path = tmp_path / "asylum.ibw"
    with pytest.warns(UserWarning, match=r"asylum\.ibw: several quantities in a length "
                                         r"unit \('HeightTrace', 'ZSensorTrace'\); "
                                         r"reading channel 0.*channel="):
        assert ibw._default(path, chans, "", warn=True)["name"] == "HeightTrace"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert ibw._default(path, chans[:2], "", warn=True)["index"] == 0


@pytest.mark.data
def test_list_channels_of_igor_and_bridge_files():
    listed = list_channels(data_path("instruments", "spot_1-1000nm.ibw"))
    assert listed[0]["description"] == "0: HeightTrace [m] height (default)"
    assert listed[4]["description"] == "4: PhaseTrace [deg]"
    pytest.importorskip("SurfaceTopography")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bridged = list_channels(data_path("instruments", "plu-1.plu"))
    assert sum(c["default"] for c in bridged) == 1
