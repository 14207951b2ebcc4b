"""Damaged files that used to read silently as wrong values, and standard input.

- Files read through SurfaceTopography (the bridge): the sizes and offsets that Alicona
  ``.al3d``, Nanosurf ``.nid`` and Molecular Imaging ``.mi`` headers state are checked
  against the file (a byte cut from an ``.al3d`` comment gave heights of ``+-2.5e38 m``),
  and heights a billion times the scan's lateral size are refused for every format.
- Gwyddion text exports whose first or last line of numbers is damaged (cut, garbage)
  lost that row and spread the stated ``Height`` over fewer rows.
- Any file of ``2 n**2`` bytes was taken for an SRTM ``.hgt`` tile, random bytes read as
  a map with ``size=``.
- The command line read ``-`` and ``/dev/stdin`` as file names ("no such file").
"""

import io
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import xrough
from conftest import data_path, needs_bridge
from xrough.cli import main
from xrough.io import detect_format, text
from xrough.io._common import MAX_HEIGHT_TO_SIZE, check_height_scale
from xrough.topography import grid_of

needs_st = needs_bridge


def read_quietly(path, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return xrough.open_topography(path, **options)


def refused(path, pattern, **options):
    """The file is refused with a ValueError naming it and matching ``pattern``."""
    with pytest.raises(ValueError, match=re.escape(path.name) + ": " + pattern):
        read_quietly(path, **options)


# -------------------------------------------------------------------------- the bridge

AL3D_HEADER = 17 + 52 * (2 + 17) + 256  # magic, Version, TagCount, 17 tags, comment


@needs_st
@pytest.mark.data
@pytest.mark.parametrize("at", [1100, 1255, 1261, 100000, 300000])
def test_al3d_deleted_byte_is_refused(tmp_path, at):
    """One byte cut from the comment (1100) gave heights of +-2.5e38 m."""
    raw = data_path("instruments", "al3d-1.al3d").read_bytes()
    assert len(raw) == 474861 and raw[AL3D_HEADER - 2:AL3D_HEADER] == b"\r\n"
    path = tmp_path / "cut.al3d"
    path.write_bytes(raw[:at] + raw[at + 1:])
    refused(path, r"(corrupted AL3D header: the comment does not end with CR LF|"
                  r"truncated file: the texture .* ends at byte 474861, the file has "
                  r"474860 bytes)", format="surfacetopography")


@needs_st
@pytest.mark.data
@pytest.mark.parametrize("at", [1200, 1261, 5000, 238061, 400000])
def test_al3d_inserted_bytes_are_refused(tmp_path, at):
    raw = data_path("instruments", "al3d-1.al3d").read_bytes()
    path = tmp_path / "shifted.al3d"
    path.write_bytes(raw[:at] + b"\0\0\0\0" + raw[at:])
    refused(path, r"(corrupted AL3D header|the file has 474865 bytes, 4 more than its "
                  r"header accounts for)", format="surfacetopography")


@needs_st
@pytest.mark.data
def test_al3d_truncated_and_intact_files(tmp_path):
    raw = data_path("instruments", "al3d-1.al3d").read_bytes()
    original = read_quietly(data_path("instruments", "al3d-1.al3d"))
    path = tmp_path / "short.al3d"
    path.write_bytes(raw[:200000])  # inside the depth image
    refused(path, r"truncated file: the depth image \(DepthImageOffset 1261, Rows 296 x "
                  r"Cols 200 floats\) ends at byte 238061, the file has 200000 bytes")
    path.write_bytes(raw[:-10])  # inside the texture
    refused(path, r"truncated file: the texture")
    # a flipped byte inside the data cannot be detected: the other values are intact
    damaged = bytearray(raw)
    damaged[1261 + 4 * 1000 + 1] ^= 0x01
    path.write_bytes(bytes(damaged))
    changed = ~np.isclose(read_quietly(path).values, original.values, rtol=0, atol=0)
    assert changed.sum() == 1
    # the texture's bytes do not matter to the heights
    damaged = bytearray(raw)
    damaged[300000] ^= 0xFF
    path.write_bytes(bytes(damaged))
    np.testing.assert_array_equal(read_quietly(path).values, original.values)


@needs_st
@pytest.mark.data
@pytest.mark.parametrize("name, header_end", [("nid-1.nid", 30748), ("mi-1.mi", 5073)])
def test_nid_and_mi_data_sizes_are_checked(tmp_path, name, header_end):
    raw = data_path("instruments", name).read_bytes()
    original = read_quietly(data_path("instruments", name))
    path = tmp_path / name
    path.write_bytes(raw[:header_end] + b"\0\0" + raw[header_end:])  # data shifted by 2
    refused(path, rf"the file has {len(raw) + 2} bytes, 2 more than its header accounts "
                  rf"for \(the (data sets|4 buffers) ")
    path.write_bytes(raw[:header_end + 1000] + raw[header_end + 1001:])
    refused(path, rf"truncated file: the (data sets|4 buffers) .* ends at byte {len(raw)}, "
                  rf"the file has {len(raw) - 1} bytes")
    path.write_bytes(raw[:-3])
    refused(path, r"truncated file")
    path.write_bytes(raw)
    np.testing.assert_array_equal(read_quietly(path).values, original.values)


@needs_st
@pytest.mark.data
@pytest.mark.parametrize("inserted", [b"\0", b"\0\0"])
def test_bridge_heights_far_beyond_the_scan_size_are_refused(tmp_path, inserted):
    """A Sensofar .plu (its header does not state where the file ends) with the data
    shifted by one or two bytes: heights of 4e18-4e37 um on a 1.27 mm scan."""
    raw = data_path("instruments", "plu-1.plu").read_bytes()
    path = tmp_path / "shifted.plu"
    path.write_bytes(raw[:600] + inserted + raw[600:])
    refused(path, r"a height of [0-9.]+e\+(18|37) µm on a scan 1\.27e\+03 µm across: more "
                  r"than 1e\+09 times the lateral size")


def test_height_scale_check_keeps_absolute_stage_positions():
    """An Alicona map 87 um across at a stage height of 7.6 cm reads (ratio ~ 900)."""
    check_height_scale(Path("a.al3d"), np.array([0.0763, np.nan, -0.0762]), 8.7e-5, "m")
    with pytest.raises(ValueError, match=r"^a\.al3d: a height of 2\.52e\+38 m"):
        check_height_scale(Path("a.al3d"), np.array([0.0763, -2.52e38]), 8.7e-5, "m")
    assert MAX_HEIGHT_TO_SIZE >= 1e6  # a height scale off by 1e6 still reads


@needs_st
@pytest.mark.data
@pytest.mark.parametrize("name", ["al3d-1.al3d", "nid-1.nid", "mi-1.mi", "opd-1.opd",
                                  "plu-1.plu"])
def test_intact_bridged_files_still_read(name):
    path = data_path("instruments", name)
    assert detect_format(path) == "surfacetopography"
    topo = read_quietly(path)
    assert np.isfinite(topo.values).any()


# ------------------------------------------------------------------- SRTM .hgt sniffing


@needs_st
@pytest.mark.parametrize("name", ["noise.bin", "noise.dat", "N47E008.hgt", "scan.hgt"])
def test_random_bytes_of_2n2_bytes_are_not_an_srtm_tile(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(np.random.default_rng(5).bytes(2 * 40 * 40))
    with pytest.raises(ValueError, match=re.escape(name) + ": unknown file format"):
        detect_format(path)
    with pytest.raises(ValueError, match=re.escape(name)):
        read_quietly(path, size="1 um", unit="um")
    refused(path, r"not an SRTM elevation tile: .* this file has 3200 bytes",
            format="surfacetopography", size="1 um", unit="um")


@needs_st
def test_srtm_tile_named_and_sized_as_such_reads(tmp_path):
    path = tmp_path / "N47E008.hgt"
    heights = np.random.default_rng(1).integers(200, 3000, (1201, 1201)).astype(">i2")
    path.write_bytes(heights.tobytes())
    assert detect_format(path) == "surfacetopography"
    topo = read_quietly(path, size="100 km", unit="m")
    assert topo.shape == (1201, 1201) and topo.attrs["reader"] == "HGTReader"
    assert float(topo.max()) == heights.max()


# ---------------------------------------------------------------- Gwyddion text export

GWY_HEADER = "# Channel: Height\n# Width: 10.00 µm\n# Height: 12.00 µm\n# Value units: nm\n"
GWY_ROWS = ["1.8910e-01\t-5.2270e-01\t-4.1310e-01\t-2.4415e+00",
            "1.1442e+00\t-3.2540e-01\t7.7380e-01\t2.8120e-01",
            "9.7760e-01\t-3.1060e-01\t-3.2880e-01\t-7.9210e-01",
            "8.4150e-01\t1.8800e-01\t3.3060e-01\t-1.0108e+00"]


def gwyddion(path, rows=GWY_ROWS, end="\n"):
    path.write_bytes((GWY_HEADER + "\n".join(rows) + end).encode("utf-8"))
    return path


def test_intact_gwyddion_export_reads(tmp_path):
    topo = text.read(gwyddion(tmp_path / "gwy.txt"))
    assert topo.shape == (4, 4) and grid_of(topo).spacing == pytest.approx((3.0, 2.5))
    # without a final line break too: the last number is printed like the others
    assert text.read(gwyddion(tmp_path / "gwy.txt", end="")).shape == (4, 4)


@pytest.mark.parametrize("last", [
    "8.4150e-01\t1.8800e-01\t3.3060e-01\t-1.01\x0708e+00",  # garbage in a number
    "8.4150e-01\t1.8800e-01\t3.3\xb7\x89e-01",               # cut, then garbage
    "8.4150e-01\t1.8800e-01\t3.3060e-01\t-1.0108e+",         # the exponent cut off
    "8.4150e-01\t1.8800e-01\t3.3060e-01\t-1.0",              # cut inside the last number
])
def test_gwyddion_export_with_a_damaged_last_line_is_refused(tmp_path, last):
    """The damaged row was dropped and Height spread over 3 rows (pixel 33 % too large)."""
    path = gwyddion(tmp_path / "gwy.txt", [*GWY_ROWS[:3], last], end="")
    with pytest.raises(ValueError, match=r"gwy\.txt: line 8 (\(.*\), next to the last line"
                                         r" of numbers, is a damaged line|ends the file "
                                         r"inside a number)"):
        text.read(path)


@pytest.mark.parametrize("first", [
    "1.8910e-01\t-5.2\x0070e-01\t-4.1310e-01\t-2.4415e+00".replace("\x00", "#"),
    "1.8910e-01\t-5.2270e-01\t-4.13\xff0e-01\t-2.4415e+00",
    "\x811.8910e-01\t-5.2270e-01\t-4.1310e-01\t-2.4415e+00",
])
def test_gwyddion_export_with_a_damaged_first_line_is_refused(tmp_path, first):
    path = gwyddion(tmp_path / "gwy.txt", [first, *GWY_ROWS[1:]])
    with pytest.raises(ValueError, match=r"gwy\.txt: line 5 \(.*\), next to the first "
                                         r"line of numbers, is a damaged line of numbers"):
        text.read(path)


@pytest.mark.parametrize("rows, match", [
    (["garbage", *GWY_ROWS[1:]], r"line 5 \('garbage'\), before the first row of numbers "
                                 r"of a Gwyddion text export"),
    (["abc\t-5.2270e-01", *GWY_ROWS[1:]], r"line 5 \('abc\\t-5\.2270e-01'\), before the "
                                          r"first row"),
    (["---", *GWY_ROWS[1:]], r"line 5 \('---'\), before the first row"),
    (["1.8910e-01: -5.2270e-01\t-4.1310e-01\t-2.4415e+00", *GWY_ROWS[1:]],
     r"line 5 .*, before the first row"),
    ([*GWY_ROWS[:3], "garbage"], r"line 8 \('garbage'\), after the last row"),
    (["1.8910e-01\t-5.2270e-01\t-4.1310e-01", *GWY_ROWS[1:]],
     r"line 5 has 3 values where 3 of the 4 lines of numbers have 4: every line must"),
    (["1.8910e-01", *GWY_ROWS[1:]], r"line 5 has 1 value where 3 of the 4 lines"),
    ([*GWY_ROWS[:2], "9.7760e-01\t-3.1060e-01", GWY_ROWS[3]], r"line 7 has 2 values where"),
], ids=["garbage-line", "garbage-token-and-fewer", "dashes", "colon", "garbage-last",
        "fewer-values", "one-value", "fewer-values-inside"])
def test_gwyddion_export_with_a_first_row_that_is_not_numbers_is_refused(tmp_path, rows,
                                                                         match):
    """A first row replaced by garbage (a line that is not numbers at all, or starts with
    one) was taken for a header line: a 4 x 4 export read as 3 x 4 with the stated
    Height spread over 3 rows (pixel 33 % too tall). After Gwyddion's commented header
    only rows of numbers may follow; rows of another width are named by their own line
    (the first row's width is no longer taken for the file's)."""
    path = gwyddion(tmp_path / "gwy.txt", rows)
    with pytest.raises(ValueError, match=r"gwy\.txt: " + match):
        read_quietly(path)


def test_gwyddion_export_rows_are_checked_against_stated_points(tmp_path):
    """Where the header states the points (``XRes``/``YRes``), the rows must match them:
    a row lost cleanly at a line boundary cannot be told from rectangular pixels
    otherwise."""
    path = tmp_path / "gwy.txt"
    path.write_bytes((GWY_HEADER + "# XRes: 4\n# YRes: 4\n" + "\n".join(GWY_ROWS[1:])
                      + "\n").encode("utf-8"))
    with pytest.raises(ValueError, match=r"gwy\.txt: the header states 4 points along y "
                                         r"but the matrix has 3"):
        read_quietly(path)


def test_text_profile_cut_inside_its_last_number_is_refused(tmp_path):
    path = tmp_path / "p.txt"
    path.write_text("x [um]\th [nm]\n0.000\t0.1891\n0.500\t-0.5227\n1.000\t-0.4")
    with pytest.raises(ValueError, match=r"p\.txt: line 4 ends the file inside a number "
                                         r"\('-0\.4'"):
        text.read(path)
    path.write_text("x [um]\th [nm]\n0\t1.5\n1\t2\n2\t-3")  # %g: printed unalike anyway
    assert text.read(path).shape == (3,)


@pytest.mark.data
@pytest.mark.parametrize("name", ["matrix-3.txt", "xy-1.txt", "xyz-1.txt", "dektak-1.csv",
                                  "nonuniform.asc"])
def test_real_text_files_still_read(name):
    stated = {} if name in ("matrix-3.txt", "dektak-1.csv") else {"unit": "um"}
    assert read_quietly(data_path("instruments", name), **stated).size > 1


# -------------------------------------------------------------------- standard input


def run_cli(*args, stdin):
    return subprocess.run([sys.executable, "-m", "xrough.cli", *args], input=stdin,
                          capture_output=True, timeout=120)


@pytest.mark.parametrize("name", ["-", "/dev/stdin"])
def test_cli_reads_a_text_profile_from_stdin(name):
    """A pipe, in a subprocess: ``-`` and ``/dev/stdin`` said "no such file"."""
    profile = b"x [um]\th [nm]\n0\t1\n1\t2\n2\t1.5\n3\t0.5\n"
    res = run_cli("info", "--json", name, stdin=profile)
    assert res.returncode == 0, res.stderr.decode()
    out = res.stdout.decode()
    assert '"source_file": "stdin"' in out and '"format": "text"' in out
    assert b"no such file" not in res.stderr


@pytest.mark.data
def test_cli_reads_a_binary_file_from_stdin(monkeypatch, capsys):
    """In-process: standard input holding an SDF file, then an empty one."""
    raw = data_path("instruments", "sdf-1.sdf").read_bytes()
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(raw)))
    assert main(["info", "-"]) == 0
    assert "sdf" in capsys.readouterr().out
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(b"")))
    assert main(["info", "-"]) == 1
    assert "stdin: the file is empty" in capsys.readouterr().err



@pytest.mark.parametrize("line", [
    "height conversioneight conversion factor (-> m)=6.30079e-008",  # a repeated chunk
    "height conversion f\ufffd\ufffd> m)=6.30079e-008",            # flipped bytes
    "height conversion factor (-> m)=6.30079e-00ctor (-> m)=6.3e-8",  # a value run on
    "height conversion factor \u00e1\u00cc.30079e-008",               # no '=' left
    "Z scale factor = n/a",
])
def test_a_damaged_height_conversion_factor_is_refused(tmp_path, line):
    """A header line that names a conversion factor of the values but does not read as
    one is refused naming it: read without it, the heights of the fuzzed export were
    raw numbers, 1.6e7 times too large (11 of the 45 garbage reads of the text fuzz);
    the intact line still multiplies them."""
    head = "Channel: Height\nWidth: 10.000 um\nHeight: 5.000 um\nValue units: m\n"
    rows = "1\t2\t3\t4\n5\t6\t7\t8\n"
    path = tmp_path / "factor.txt"
    path.write_text(head + line + "\n" + rows, encoding="utf-8")
    with pytest.raises(ValueError, match=r"factor\.txt: the header line .* names a "
                                         r"conversion factor"):
        text.read(path)
    path.write_text(head + "height conversion factor (-> m)=6.30079e-008\n" + rows)
    heights = text.read(path)
    np.testing.assert_allclose(heights.values.max() / heights.values.min(), 8.0,
                               rtol=1e-12)
    assert heights.attrs["height_conversion"].endswith("6.30079e-008")
