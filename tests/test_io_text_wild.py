"""Text exports found in the wild, and profiles whose x is not uniform.

Every file is written here byte by byte in the layout of the program that exports it
(Gwyddion's ASCII export in English and German, ``.hfm`` profiles with a validity column,
x-y files with a unit line and a point count, UTF-16 CSV with an index column), and read
without options. Expected numbers are computed from the written values; when
SurfaceTopography is installed its readers are compared too (heights, sizes, rms to 1e-5).

Pixel convention: a text matrix's ``Width``/``Height`` is ``n * spacing`` (Gwyddion's and
SurfaceTopography's convention), coordinates at ``i * spacing``.
"""

import warnings

import numpy as np
import pytest
from test_io_text_nc import st_topography

import xrough
from conftest import data_path, needs_bridge
from xrough.io import open_topography, text
from xrough.topography import grid_of


def st_rms(st):
    """SurfaceTopography's rms height (its functions warn about deprecated aliases)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if st.dim == 2:
            return st.rms_height_from_area()
        return st.rms_height_from_profile()


# ---------------------------------------------------------------------------------------
# uneven x is never read as uniform


def _profile_file(path, xs, fmt="{}"):
    h = [(-1) ** i * (i % 3) for i in range(len(xs))]
    path.write_text("x [um]\th [nm]\n" + "".join(f"{fmt.format(x)}\t{v}\n"
                                                    for x, v in zip(xs, h)))
    return np.asarray(h, float)


@pytest.mark.parametrize("xs", [
    [0, 1, 2, 3, 4, 4.5, 5, 6, 7, 8, 9],       # one extra sample between 4 and 5
    [0, 1, 2, 4, 5, 6, 7, 8, 9, 10],           # the sample at 3 is missing
], ids=["extra-sample", "missing-sample"])
def test_uneven_whole_number_x_is_read_non_uniform(tmp_path, xs):
    path = tmp_path / "uneven.txt"
    h = _profile_file(path, xs)
    prof = open_topography(path)
    assert prof.attrs["sampling"] == "non-uniform"
    # the measured positions, exactly as written (no resampling, no fitted step)
    np.testing.assert_array_equal(prof.x.values, np.asarray(xs, float))
    np.testing.assert_array_equal(prof.values, h)
    with pytest.raises(ValueError, match=r"uneven\.txt: .*non-uniformly.*resample=True"):
        open_topography(path, size="10 um")
    res = open_topography(path, resample=True)
    assert res.attrs["sampling"] == "resampled" and res.sizes["x"] == len(xs)


def test_whole_number_x_exactly_uniform_is_uniform(tmp_path):
    path = tmp_path / "even.txt"
    h = _profile_file(path, list(range(11)))
    topo = open_topography(path)
    assert topo.attrs["sampling"] == "uniform"
    assert grid_of(topo).spacing == (1.0,)  # exact: the positions are exact
    np.testing.assert_array_equal(topo.values, h)


@pytest.mark.parametrize("n", [5, 20, 2000])
def test_uniform_x_rounded_to_three_decimals_is_uniform(tmp_path, n):
    # step 0.0133337 printed with 3 decimals: rounding moves x by up to 0.0005, 3.7 % of a
    # step; the printed digits resolve the sampling (0.001 < step / 10)
    step, x0 = 0.0133337, 0.01
    path = tmp_path / "rounded.txt"
    _profile_file(path, x0 + step * np.arange(n), "{:.3f}")
    topo = open_topography(path)
    assert topo.attrs["sampling"] == "uniform"
    # the least-squares step through values rounded to +-0.0005 is within
    # 0.0005 * sqrt(12 / n^3) * 3.5 (3.5 standard errors) of the true step
    assert abs(grid_of(topo).spacing[0] - step) <= 3.5 * 0.0005 * np.sqrt(12 / n**3)
    assert topo.attrs["x_max_deviation"] <= 0.0005 * (1 + 4 / np.sqrt(n))


def test_rounding_coarser_than_a_tenth_of_the_step_is_not_taken_for_uniform(tmp_path):
    # step 0.0033337 printed with 3 decimals: 0.001 is 30 % of a step, so a shifted
    # sample cannot be told from rounding; nothing in the file states the step
    path = tmp_path / "coarse.txt"
    xs = [f"{v:.3f}" for v in 0.0033337 * np.arange(50)]
    _profile_file(path, xs)
    prof = open_topography(path)
    assert prof.attrs["sampling"] == "non-uniform"
    np.testing.assert_array_equal(prof.x.values, np.asarray(xs, float))


DEKTAK_HEADER = ("Scan Parameters\nLength,150.0 um\nResolution,0.156 um/sample\n\n"
                 "Scan Data\nLateral um,Raw Micrometer,\n")


def test_coarse_rounding_is_uniform_when_the_header_states_the_step(tmp_path):
    # a Dektak export prints x with 1 decimal for a step of 0.15625 um: the header's
    # Length / points (150 / 960) and Resolution (0.156) state the step
    x = np.round(0.15625 * np.arange(960), 1)
    body = "".join(f"{a:.1f},{i % 7 / 100:.5f},,\n" for i, a in enumerate(x))
    path = tmp_path / "dektak.csv"
    path.write_text(DEKTAK_HEADER + body)
    topo = open_topography(path)
    assert topo.attrs["sampling"] == "uniform"
    assert grid_of(topo).spacing[0] == pytest.approx(0.15625, rel=1e-4)  # LSQ through +-0.05
    # the same file with one sample missing in the middle is no longer uniform
    lines = body.splitlines(keepends=True)
    path.write_text(DEKTAK_HEADER + "".join(lines[:480] + lines[481:]))
    prof = open_topography(path)
    assert prof.attrs["sampling"] == "non-uniform" and prof.sizes["x"] == 959


# ---------------------------------------------------------------------------------------
# Gwyddion ASCII export (English and German keys), rectangular pixels

# the header keys of Gwyddion's ASCII export in English and in German
GWY_LANGUAGES = pytest.mark.parametrize(
    "keys", [("Channel", "Width", "Height", "Value units"),
             ("Kanal", "Breite", "Höhe", "Value units")], ids=["english", "german"])
GWY_VALUES = np.array([[1, 1.5, 3], [-2, -3, -6], [0, 0, 0], [9, 9, 9]])


def _gwyddion_file(path, keys=("Channel", "Width", "Height", "Value units"), width="12.34 µm",
                   height="5678.9 nm", values=GWY_VALUES):
    head = (f"# {keys[0]}: My Channel Name\n# {keys[1]}: {width}\n# {keys[2]}: {height}\n"
            f"# {keys[3]}: m\n")
    rows = "\n".join(" ".join(f"{v:g}" for v in row) for row in values)
    path.write_bytes((head + rows + "\n").encode("utf-8"))


@GWY_LANGUAGES
def test_gwyddion_export_with_rectangular_pixels(tmp_path, keys):
    path = tmp_path / "gwy.txt"
    _gwyddion_file(path, keys)
    topo = open_topography(path)
    assert topo.dims == ("y", "x") and topo.shape == (4, 3)
    g = grid_of(topo)
    assert g.lateral_unit == "um" and topo.attrs["units"] == "m"
    # Width = 3 dx, Height = 4 dy (5678.9 nm = 5.6789 um); exact up to float rounding
    assert g.spacing == pytest.approx((5.6789 / 4, 12.34 / 3), rel=1e-12)
    assert g.size == pytest.approx((5.6789, 12.34), rel=1e-12)
    np.testing.assert_array_equal(topo.values, GWY_VALUES[::-1])  # first line = top row
    assert float(topo.std()) == pytest.approx(np.std(GWY_VALUES), rel=1e-12)
    assert topo.attrs["channel"] == "My Channel Name"
    assert topo.attrs[keys[0]] == "My Channel Name"  # the header entry itself is kept


def test_gwyddion_export_square_area_rectangular_pixels(tmp_path):
    path = tmp_path / "m.txt"
    values = np.arange(1.0, 13.0).reshape(3, 4)
    _gwyddion_file(path, width="10 µm", height="10 µm", values=values)
    topo = open_topography(path)
    assert grid_of(topo).spacing == pytest.approx((10 / 3, 10 / 4), rel=1e-12)
    np.testing.assert_array_equal(topo.values, values[::-1])


@GWY_LANGUAGES
def test_gwyddion_export_agrees_with_surfacetopography(tmp_path, keys):
    path = tmp_path / "gwy.txt"
    _gwyddion_file(path, keys)
    ours = open_topography(path)
    st = st_topography(path)
    # SurfaceTopography: first axis x, sizes in the height unit (m); ours in um
    sx, sy = st.physical_sizes
    assert grid_of(ours).size == pytest.approx((sy * 1e6, sx * 1e6), rel=1e-5)
    np.testing.assert_allclose(ours.transpose("x", "y").values[:, ::-1],
                               st.heights(), rtol=1e-5)
    assert float(ours.std()) == pytest.approx(st_rms(st), rel=1e-5)


# ---------------------------------------------------------------------------------------
# what rectangular pixels mean downstream


def _rect(values, periodic=False):
    return xrough.topography(values, spacing=(2.0, 1.0), unit="um", height_unit="nm",
                             periodic=periodic)


def test_height_difference_acf_uses_both_spacings(tmp_path):
    rng = np.random.default_rng(1)
    h = rng.normal(size=(6, 8))
    topo = _rect(h)
    edges = np.array([0.5, 1.5, 2.1, 2.9, 4.5, 7.0, 12.0])
    G = xrough.height_difference_acf(topo, bins=edges)
    # brute force over every pair, lag length from dx = 1 and dy = 2
    ny, nx = h.shape
    yy, xx = np.meshgrid(np.arange(ny) * 2.0, np.arange(nx) * 1.0, indexing="ij")
    p = np.column_stack([yy.ravel(), xx.ravel()])
    z = h.ravel()
    i, j = np.triu_indices(z.size, 1)
    r = np.hypot(*(p[i] - p[j]).T)
    sq = 0.5 * (z[i] - z[j]) ** 2
    k = np.digitize(r, edges) - 1
    for dr, g, n in zip(G.dr.values, G.values, G.pair_count.values):
        b = np.searchsorted(edges, dr) - 1
        sel = k == b
        assert n == sel.sum()
        assert g == pytest.approx(sq[sel].mean(), rel=1e-9)  # FFT sums: float rounding
        assert dr == pytest.approx(r[sel].mean(), rel=1e-9)


def test_detrend_and_plot_on_rectangular_pixels():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from xrough.plot import plot_topography
    y, x = np.mgrid[0:6, 0:8]
    topo = _rect(0.5 * x + 0.25 * 2 * y + 3)
    flat = xrough.detrend(topo)
    assert float(abs(flat).max()) < 1e-12  # a plane is removed whatever the pixels
    ax = plot_topography(topo)
    # the image spans the physical area: pixel centres at i dx, j dy, edges half a pixel out
    assert ax.images[0].get_extent() == pytest.approx([-0.5, 7.5, -1.0, 11.0])
    plt.close(ax.figure)


def test_stitching_window_on_rectangular_pixels():
    rng = np.random.default_rng(2)
    topo = _rect(rng.normal(size=(32, 64)))
    curves = xrough.stitch_curves({"rect": topo})
    # the shortest reliable lag counts pixels of the larger spacing (dy = 2 um) and the
    # longest is a fraction of the smaller side (32 x 2 um = 64 um = 64 x 1 um)
    assert curves.attrs["window_rules"] == ("rect: dr_min: 4 pixels of 2 um; dr_max: 0.25 x "
                                            "scan size 64 um")
    assert float(curves.dr_min[0]) == 8.0 and float(curves.dr_max[0]) == 16.0


@pytest.mark.parametrize("axis", ["x", "y"])
def test_contact_solver_on_rectangular_pixels(axis):
    # full contact of a periodic sinusoid: p = p0 + (E*/2) q h0 cos(q r) exactly, with q
    # from the physical wavelength (8 dx = 8 um along x, 8 dy = 16 um along y)
    y, x = np.mgrid[0:16, 0:16]
    h0 = 1e-3  # um
    phase = 2 * np.pi * (x if axis == "x" else y) / 8
    topo = xrough.topography(h0 * np.cos(phase), spacing=(2.0, 1.0), unit="um",
                             height_unit="um", periodic=True)
    res = xrough.solve_contact(topo, E_star="1 MPa", p0="1 MPa")
    assert float(res.contact_area) == 1.0
    q = 2 * np.pi / (8.0 if axis == "x" else 16.0)  # 1/um
    amplitude = 0.5 * 1e6 * q * h0  # Pa
    p = res.pressure.values
    np.testing.assert_allclose(p, 1e6 + amplitude * np.cos(phase), rtol=0, atol=1e-6 * amplitude)


# ---------------------------------------------------------------------------------------
# .hfm profiles: X;Y;valid with a line of units

def _hfm(path, n=40, invalid=(7, 8, 30)):
    x = 8.6722 + 0.0005 * np.arange(n)
    y = 106.6068 + 1e-6 * ((np.arange(n) * 37) % 11)
    valid = np.ones(n, int)
    valid[list(invalid)] = 0
    body = "".join(f"{a:.6f};{b:.6f};{v}\r\n" for a, b, v in zip(x, y, valid))
    path.write_bytes(("X;Y;valid\r\n[mm];[mm];[1/0]\r\n" + body).encode("ascii"))
    return x, np.round(y, 6), valid


def test_hfm_profile_with_validity_column(tmp_path):
    path = tmp_path / "p.hfm"
    x, y, valid = _hfm(path)
    topo = open_topography(path)
    assert topo.dims == ("x",) and topo.sizes["x"] == 40
    assert topo.attrs["sampling"] == "uniform"
    assert topo.x.attrs["units"] == "mm" and topo.attrs["units"] == "mm"
    g = grid_of(topo)
    assert g.spacing[0] == pytest.approx(0.0005, rel=1e-9)  # x printed exactly (6 decimals)
    assert topo.attrs["x_offset"] == pytest.approx(8.6722, rel=1e-12)
    expected = np.where(valid == 1, y, np.nan)
    np.testing.assert_array_equal(topo.values, expected)
    assert topo.attrs["invalid_points"] == 3 and topo.attrs["valid_column"] == "valid [1/0]"
    assert topo.attrs["columns"] == "X [mm], Y [mm]"
    assert float(topo.std()) == pytest.approx(np.nanstd(expected), rel=1e-12)


def test_hfm_validity_column_other_than_0_1_is_refused(tmp_path):
    path = tmp_path / "bad.hfm"
    path.write_text("X;Y;valid\n[mm];[mm];[1/0]\n0.0;1.0;1\n0.5;1.1;2\n1.0;1.2;1\n")
    with pytest.raises(ValueError, match=r"bad\.hfm: the column 'valid \[1/0\]' .* data "
                                         r"line 2 has 2"):
        open_topography(path)


def test_hfm_agrees_with_surfacetopography(tmp_path):
    path = tmp_path / "p.hfm"
    _hfm(path, invalid=())  # SurfaceTopography does not read the validity column
    ours = open_topography(path)
    st = st_topography(path)
    assert st.unit == "mm"
    assert grid_of(ours).size[0] == pytest.approx(st.physical_sizes[0], rel=1e-5)
    np.testing.assert_allclose(ours.values, st.heights(), rtol=1e-5)
    assert float(ours.std()) == pytest.approx(st_rms(st), rel=1e-5)


# ---------------------------------------------------------------------------------------
# x-y with a unit line and a point count

XY_POINTS = [(13.381669, 17.85497), (14.911003, 17.85497), (16.287403, 17.549103),
             (17.663803, 18.466703), (19.040203, 18.925503), (20.875404, 18.925503)]


@pytest.mark.parametrize("count", [6, 5], ids=["points", "last-index"])
def test_xy_with_unit_and_count_lines(tmp_path, count):
    path = tmp_path / "xy.txt"
    path.write_bytes(("µm µm\n" + f"{count}\n" + "".join(
        f"   {a:.7e},   {b:.7e}\n" for a, b in XY_POINTS)).encode("utf-8"))
    prof = open_topography(path)
    x, h = np.array(XY_POINTS).T
    assert prof.attrs["sampling"] == "non-uniform"  # steps 1.53, 1.38, 1.38, 1.38, 1.84
    np.testing.assert_allclose(prof.x.values, x, rtol=1e-12)
    np.testing.assert_allclose(prof.values, h, rtol=1e-12)
    assert prof.x.attrs["units"] == "um" and prof.attrs["units"] == "um"
    assert prof.attrs["points"] == count


def test_xy_count_line_contradicting_the_points_is_refused(tmp_path):
    path = tmp_path / "cut.txt"
    path.write_text("µm µm\n9\n" + "".join(f"{a}, {b}\n" for a, b in XY_POINTS),
                    encoding="utf-8")
    with pytest.raises(ValueError, match=r"cut\.txt: line 2 states 9 points but 6 lines "
                                         r"of points follow"):
        open_topography(path)


def test_xy_with_count_agrees_with_surfacetopography(tmp_path):
    path = tmp_path / "xy.txt"
    path.write_bytes(("µm µm\n6\n" + "".join(
        f"{a:.7e}, {b:.7e}\n" for a, b in XY_POINTS)).encode("utf-8"))
    ours = open_topography(path)
    st = st_topography(path)
    sx, sh = st.positions_and_heights()
    # SurfaceTopography moves x to start at 0; ours keeps the file's positions
    np.testing.assert_allclose(ours.x.values - ours.x.values[0], sx, rtol=1e-5)
    np.testing.assert_allclose(ours.values, sh, rtol=1e-5)


# ---------------------------------------------------------------------------------------
# UTF-16 CSV with an index column

def _utf16_csv(path, n=12):
    x = -99.958333333333 + 0.0833333333333 * np.arange(n)
    h = -1.4274328574349 + 0.01 * np.sin(np.arange(n))
    rows = "".join(f"{i},{a:.12f},{b:.13f}\r\n" for i, (a, b) in enumerate(zip(x, h)))
    path.write_bytes(("index, x in µm, y in µm\r\n" + rows).encode("utf-16"))
    return x, h


def test_utf16_csv_with_index_column(tmp_path):
    path = tmp_path / "p.csv"
    x, h = _utf16_csv(path)
    assert path.read_bytes()[:2] in (b"\xff\xfe", b"\xfe\xff")  # the BOM
    topo = open_topography(path)
    assert topo.dims == ("x",) and topo.attrs["sampling"] == "uniform"
    assert topo.x.attrs["units"] == "um" and topo.attrs["units"] == "um"
    assert grid_of(topo).spacing[0] == pytest.approx(0.0833333333333, rel=1e-9)
    assert topo.attrs["x_offset"] == pytest.approx(-99.958333333333, rel=1e-12)
    np.testing.assert_allclose(topo.values, h, rtol=0, atol=1e-13)  # 13 printed decimals
    assert topo.attrs["index_column"] == "index"
    assert topo.attrs["columns"] == "x in µm, y in µm"


def test_index_column_that_does_not_count_is_kept(tmp_path):
    # a first column titled index whose values do not count up by one is data: three
    # columns are then x-y-z points, and these are not on a grid
    path = tmp_path / "p.csv"
    path.write_text("index, x in um, y in um\n0,0,1\n2,1,2\n5,2,3\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"p\.csv: the x-y-z points"):
        open_topography(path)


def test_utf16_csv_agrees_with_surfacetopography(tmp_path):
    path = tmp_path / "p.csv"
    _utf16_csv(path)
    ours = open_topography(path)
    st = st_topography(path)
    assert grid_of(ours).size[0] == pytest.approx(st.physical_sizes[0], rel=1e-5)
    np.testing.assert_allclose(ours.values, st.heights(), rtol=1e-5)
    assert float(ours.std()) == pytest.approx(st_rms(st), rel=1e-5)


@pytest.mark.parametrize("suffix", [".txt", ".dat"])
def test_a_text_file_with_a_nul_byte_is_refused_not_bridged(tmp_path, suffix):
    """A NUL byte in a text profile made it look binary: the bridge read it and stopped at
    the NUL (a 40-point profile read as 19). Now the text reader refuses it, naming the
    byte."""
    lines = "\n".join(f"{i * 0.1:.3f} {np.sin(i / 5):.5f}" for i in range(40)).encode()
    path = tmp_path / f"profile{suffix}"
    path.write_bytes(lines[:200] + b"\x00" + lines[200:])
    with pytest.raises(ValueError, match="a NUL byte at offset 200 .line 15.: a damaged text"):
        xrough.open_topography(path, unit="um")


def _xy_profile(n=132):
    """A profile of ``n`` x-y pairs, one per line, of 14 or 15 bytes each."""
    return "".join(f"{i * 0.1:.3f} {np.sin(i / 5):.5f}\n" for i in range(n)).encode()


#: Damage by blocks of NUL bytes: zeroed bytes in place of some lines (more than the two
#: NULs a text file was allowed before it counted as binary), or a zeroed first 4 kB (no
#: line of numbers left where the format is detected).
NUL_DAMAGE = {"zeroed-block": (1000, 512), "zeroed-start": (0, 4096)}


def _nul_damaged(path, where):
    at, n = NUL_DAMAGE[where]
    raw = _xy_profile(132 if where == "zeroed-block" else 600)
    path.write_bytes(raw[:at] + b"\x00" * n + raw[at + n:])
    return at, raw[:at].count(b"\n") + 1


@pytest.mark.parametrize("suffix", [".txt", ".xy", ".dat"])
@pytest.mark.parametrize("options", [{}, {"format": "text"}], ids=["detected", "text"])
def test_a_text_profile_with_a_block_of_nul_bytes_is_refused(tmp_path, suffix, options):
    """A block of 512 zeroed bytes in a 132-point x-y profile made it binary for the
    format detection (more than two NULs): SurfaceTopography read 27 of the 132 points,
    silently (``format="text"`` said "binary content"). Text with lines of numbers and no
    control byte but NUL is damaged text: the text reader refuses it, naming the first
    NUL's offset and line, whatever the extension (``.xy`` is none of the text reader's)."""
    path = tmp_path / f"profile{suffix}"
    at, line = _nul_damaged(path, "zeroed-block")
    with pytest.raises(ValueError, match=rf"profile\{suffix}: contains a NUL byte at offset "
                                         rf"{at} \(line {line}\): a damaged text file"):
        xrough.open_topography(path, unit="um", **options)


@needs_bridge
@pytest.mark.parametrize("where", list(NUL_DAMAGE))
@pytest.mark.parametrize("options", [{}, {"format": "surfacetopography"}],
                         ids=["detected", "bridge"])
def test_the_bridge_refuses_a_text_profile_with_nul_bytes(tmp_path, where, options):
    """The bridge refuses text with NUL bytes too, before SurfaceTopography reads it: a
    file whose first 4 kB are zeroed has no line of numbers where the format is detected
    and goes to the bridge (which read 328 of its 600 points); ``format="surfacetopography"``
    sends any file there. The intact profile still reads through the bridge, every point
    of it."""
    path = tmp_path / "profile.txt"
    at, line = _nul_damaged(path, where)
    with pytest.raises(ValueError, match=rf"profile\.txt: contains a NUL byte at offset "
                                         rf"{at} \(line {line}\)"):
        xrough.open_topography(path, unit="um", **options)
    path.write_bytes(_xy_profile())  # intact, the same profile reads: all its points
    assert xrough.open_topography(path, unit="um", **options).size == 132


def test_utf16_text_without_a_byte_order_mark_is_told_its_encoding(tmp_path):
    """UTF-16 without a byte-order mark has a NUL in every other byte: not damage. The
    message says which encoding= reads it, and that reads it (all 132 points)."""
    path = tmp_path / "profile.txt"
    path.write_bytes(_xy_profile().decode().encode("utf-16-le"))
    with pytest.raises(ValueError, match=r"profile\.txt: a NUL byte at offset 1 .*UTF-16 "
                                         r"text without a byte-order mark\? pass "
                                         r"encoding='utf-16-le'"):
        xrough.open_topography(path, unit="um")
    assert xrough.open_topography(path, unit="um", encoding="utf-16-le").size == 132


@pytest.mark.data
@pytest.mark.parametrize("name", ["al3d-1.al3d", "di-1.di", "mi-1.mi", "nid-1.nid",
                                  "opd-1.opd", "plu-1.plu", "spot_1-1000nm.ibw",
                                  "sur-2.sur", "x3p-2.x3p", "nc-1.nc"])
def test_binary_instrument_files_are_not_taken_for_damaged_text(name):
    """Text with NUL bytes is told from binary data by the absence of any other control
    byte: the start of every binary instrument file of the test data (4 kB as detected,
    64 kB as the bridge looks) has some, or no NUL at all; none is detected as text (with
    or without SurfaceTopography to read it)."""
    raw = data_path("instruments", name).read_bytes()
    for size in (4096, 65536):
        assert not text.text_with_nul(raw[:size])
    try:
        found = xrough.io.detect_format(data_path("instruments", name))
    except ValueError as err:  # without SurfaceTopography: no reader, and not text
        assert "unknown file format" in str(err)
        found = None
    assert found != "text"


@pytest.mark.data
def test_real_xy_profile_with_a_nul_block_is_refused(tmp_path):
    """The instrument's own x-y profile (132 points), 40 bytes zeroed at byte 990: read
    as 100 points through the bridge before, silently; refused now, naming the offset."""
    raw = data_path("instruments", "xy-1.txt").read_bytes()
    path = tmp_path / "xy-damaged.txt"
    path.write_bytes(raw[:990] + b"\x00" * 40 + raw[1030:])
    with pytest.raises(ValueError, match=r"xy-damaged\.txt: contains a NUL byte at offset "
                                         r"990 \(line 31\)"):
        xrough.open_topography(path, unit="um")
