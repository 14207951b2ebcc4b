"""Figures: gaps stay gaps, error bands stay visible, labels stay inside, every result plots.

Two kinds of checks. Structural ones read the artists (line segments, band polygons and
their vertices, label extents against the figure). Image ones render the data layer
(lines, bands, markers; text and axes hidden and the axes filling the figure, so that
font rendering and layout of different matplotlib versions do not matter) to a small PNG
with Agg and compare it with a committed baseline in ``tests/baseline``
(:func:`matplotlib.testing.compare.compare_images` with a tolerance). To rewrite the
baselines after an intended change, run this file with ``XROUGH_UPDATE_BASELINES=1``.
"""

import os
import warnings
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr
from matplotlib.testing.compare import compare_images

import xrough
from xrough import plot

BASELINE = Path(__file__).parent / "baseline"
DPI = 40
TOLERANCE = 2.0  # RMS of the 0-255 pixel difference


def _check_image(fig, name, tmp_path):
    """Compare the data layer of ``fig`` with ``baseline/<name>.png``."""
    fig.set_layout_engine("none")  # the layout depends on text: fix it instead
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert len(visible) == 1, "image checks are for one-panel figures"
    for ax in fig.axes:
        for text in [ax.title, *ax.texts]:
            text.set_visible(False)
        if ax.get_legend() is not None:
            ax.get_legend().remove()
        ax.set_axis_off()
    visible[0].set_position([0.02, 0.02, 0.96, 0.96])
    with matplotlib.rc_context({"savefig.facecolor": "white"}):
        actual = tmp_path / f"{name}.png"
        fig.savefig(actual, dpi=DPI)
    expected = BASELINE / f"{name}.png"
    if os.environ.get("XROUGH_UPDATE_BASELINES") == "1":
        BASELINE.mkdir(exist_ok=True)
        expected.write_bytes(actual.read_bytes())
    assert expected.exists(), f"no baseline {expected.name}: run with XROUGH_UPDATE_BASELINES=1"
    result = compare_images(str(expected), str(actual), tol=TOLERANCE)
    assert result is None, result


def _segments(line) -> int:
    """Number of runs of finite points in a Line2D (NaN breaks a line)."""
    y = np.asarray(line.get_ydata(), dtype=float)
    x = np.asarray(line.get_xdata(), dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    return int(ok[0]) + int(np.sum(ok[1:] & ~ok[:-1])) if ok.size else 0


def _inside_figure(fig, *texts):
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    box = fig.bbox
    for text in texts:
        if not text.get_text():
            continue
        ext = text.get_window_extent(renderer)
        assert (ext.x0 >= box.x0 - 0.5 and ext.y0 >= box.y0 - 0.5
                and ext.x1 <= box.x1 + 0.5 and ext.y1 <= box.y1 + 0.5), (
            f"{text.get_text()!r} at {ext} outside the figure {box}")


def _model_G(unit="nm"):
    C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
                              rms_gradient=0.5, unit=unit)
    return xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="100 um",
                                    points_per_decade=5)


@pytest.fixture(scope="module")
def gapped():
    """Two instruments whose windows do not overlap, and their stitched G."""
    prof = xrough.self_affine_surface(hurst=0.7, lambda_r="2 um", lambda_s="20 nm",
                                      size="8 um", n=1024, rms_height="10 nm",
                                      profile=True, seed=3, unit="nm")
    measurements = {"fine": prof.isel(x=slice(0, 256)).assign_attrs(periodic=0),
                    "coarse": prof.isel(x=slice(None, None, 4))}
    windows = {"fine": (None, "100 nm"), "coarse": ("1 um", None)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        G = xrough.stitch(measurements, windows=windows, points_per_decade=5)
    return measurements, windows, G


# --- gaps ---------------------------------------------------------------------------------


def test_stitched_line_and_band_break_at_the_gap(gapped, tmp_path):
    """Regression: the line and the band were drawn straight across the uncovered lags."""
    _, _, G = gapped
    dr = G.dr.values
    assert np.any(dr[1:] / dr[:-1] > 10 ** (1.5 / 5)), "the example should have a gap"
    ax = G.rough.plot()
    (line,) = ax.get_lines()
    assert _segments(line) == 2
    (band,) = ax.collections
    assert len(band.get_paths()) == 2
    _check_image(ax.figure, "stitched_gap", tmp_path)


def test_plot_stitched_keeps_gaps(gapped):
    measurements, windows, _ = gapped
    ax = plot.plot_stitched(measurements, windows=windows, points_per_decade=5, warn=False)
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    assert list(lines) == ["fine", "coarse", "stitched"]
    assert _segments(lines["stitched"]) == 2
    assert _segments(lines["fine"]) == _segments(lines["coarse"]) == 1


def test_nan_bins_break_lines_and_bands():
    G = _model_G()
    G = G.assign_coords(standard_error=0.2 * G)
    G[10:13] = np.nan
    ax = G.rough.plot()
    assert _segments(ax.get_lines()[0]) == 2
    assert len(ax.collections[0].get_paths()) == 2


def test_unstitched_curve_is_not_split():
    G = _model_G()
    ax = G.drop_vars([c for c in G.coords if c != "dr"]).rough.plot()
    assert _segments(ax.get_lines()[0]) == 1


# --- error band ------------------------------------------------------------------------------


def test_error_band_stays_visible_where_the_error_reaches_G(tmp_path):
    """Regression: the band vanished where standard_error >= G on the log axis."""
    G = _model_G()
    rel = np.where(np.arange(G.sizes["dr"]) % 7 < 3, 1.5, 0.3)  # 150 % error in places
    G = G.assign_coords(standard_error=("dr", G.values * rel, {"units": "nm2"}))
    ax = G.rough.plot()
    (band,) = ax.collections
    paths = band.get_paths()
    assert len(paths) == 1  # one band over every lag
    vertices = paths[0].vertices
    assert np.all(np.isfinite(vertices)) and np.all(vertices[:, 1] > 0)
    x = G.dr.values
    assert vertices[:, 0].min() <= x.min() and vertices[:, 0].max() >= x.max()
    floor = vertices[:, 1].min()
    assert floor >= plot.BAND_FLOOR * G.values.min() * (1 - 1e-9)
    _check_image(ax.figure, "band_floor", tmp_path)


def test_error_band_not_clipped_on_linear_axes():
    G = _model_G()
    sacf = G.rough.stress_acf(E_star="25 MPa")
    se = 0.5 * np.abs(sacf.values) + 1.0
    sacf = sacf.assign_coords(standard_error=("dr", se))
    ax = sacf.rough.plot()
    assert ax.get_yscale() == "linear"
    vertices = ax.collections[0].get_paths()[0].vertices
    assert vertices[:, 1].min() < 0


# --- labels ----------------------------------------------------------------------------------


def test_energy_labels_inside_the_figure(tmp_path):
    """Regression: the energy plot's y label ran off the figure."""
    energy = _model_G().rough.energy(E_star="25 MPa")
    axes = energy.rough.plot()
    ax = axes[0]
    _inside_figure(ax.figure, ax.xaxis.label, ax.yaxis.label, ax.title)
    _check_image(ax.figure, "energy", tmp_path)


def test_labels_inside_on_the_callers_axes():
    G = _model_G()
    fig, ax = plt.subplots(figsize=(3, 2.5))
    G.rough.energy(E_star="25 MPa").rough.plot(axes=np.array([ax]))
    _inside_figure(fig, ax.xaxis.label, ax.yaxis.label)


@pytest.mark.parametrize("kind", ["persson", "gradient", "spectrum", "topography", "G"])
def test_every_label_inside(kind):
    G = _model_G()
    objs = {
        "persson": lambda: G.rough.persson(E_star="25 MPa", p0=[1e5, 1e6]),
        "gradient": lambda: G.rough.gradient(method="simple"),
        "spectrum": lambda: G.rough.spectrum(),
        "topography": lambda: xrough.topography(np.zeros((8, 8)), spacing=1.0, unit="um"),
        "G": lambda: G,
    }
    out = objs[kind]().rough.plot()
    axes = np.ravel(out) if isinstance(out, np.ndarray) else [out]
    for ax in axes:
        _inside_figure(ax.figure, ax.xaxis.label, ax.yaxis.label, ax.title)


def test_micrometres_print_as_mu():
    """Regression: lengths printed as 'um' instead of 'µm'."""
    topo = xrough.topography(np.zeros((4, 5)), spacing=1.0, unit="um")
    ax = topo.rough.plot()
    assert ax.get_xlabel() == "x position (µm)"
    assert topo.x.attrs["units"] == "um"  # data stay CF
    G = _model_G(unit="um")
    ax = G.rough.plot()
    assert "(µm)" in ax.get_xlabel() and "(µm²)" in ax.get_ylabel()
    assert "um" not in ax.get_xlabel().replace("µm", "")
    assert G.attrs["units"] == "um2" and G.dr.attrs["units"] == "um"
    assert plot.display_unit("um") == "µm"
    assert plot.display_unit("um2") == "µm²"
    assert plot.display_unit("um-1") == "1/µm"
    assert plot.display_unit("J m-2") == "J/m²"
    assert plot.display_unit("mJ m-2") == "mJ/m²"
    assert plot.display_unit("Pa2") == "Pa²"
    assert plot.display_unit("1") == ""  # dimensionless: no "(1)"
    assert plot.display_unit("not a unit um") == "not a unit µm"  # as written


def test_dimensionless_labels_have_no_unit():
    da = xrough.topography(np.zeros(4), spacing=1.0, unit="nm")
    a_r = xr.DataArray([0.1, 0.2], dims="dr", name="a_r",
                       coords={"dr": ("dr", [1.0, 2.0], {"units": "nm"})},
                       attrs={"units": "1", "long_name": "relative contact area"})
    ax = a_r.rough.plot()
    assert ax.get_ylabel() == "relative contact area"
    assert da.attrs["units"] == "nm"
    plt.close("all")


# --- fits and patch radii -------------------------------------------------------------------


@pytest.mark.parametrize("model", ["spectrum", "eq36"])
def test_fit_plots_its_model(model, tmp_path):
    """Regression: fit.rough.plot() raised 'nothing to plot'."""
    G = _model_G()
    fit = G.rough.fit(model=model)
    axes = fit.rough.plot()
    assert len(axes) == 1
    ax = axes[0]
    (line,) = ax.get_lines()
    x = line.get_xdata()
    assert x.min() == pytest.approx(fit.attrs["dr_min"]) and x.max() == pytest.approx(
        fit.attrs["dr_max"])
    assert np.all(line.get_ydata() > 0)
    assert ax.get_title().startswith("H = ")
    assert "σ_h" in ax.get_title()
    assert ax.get_xscale() == ax.get_yscale() == "log"
    assert "fit" in ax.get_legend().get_texts()[0].get_text()
    _inside_figure(ax.figure, ax.xaxis.label, ax.yaxis.label, ax.title)
    if model == "spectrum":
        _check_image(ax.figure, "fit", tmp_path)


def test_fit_with_data_and_several_curves():
    G = _model_G()
    ax = plot.plot_fit(G.rough.fit(), G=G)
    assert [ln.get_label() for ln in ax.get_lines()] == ["data", "fit: model spectrum (eq. 9)"]
    many = xr.concat([G, 2 * G.assign_attrs(G.attrs)], dim="scan")
    ax = many.rough.fit().rough.plot()[0]
    assert len(ax.get_lines()) == 2


def test_patch_radius_plots(tmp_path):
    """Regression: patch.rough.plot() raised 'nothing to plot'."""
    G = _model_G()
    many = xr.concat([G, 4 * G, 100 * G], dim="scan").assign_attrs(G.attrs)
    with pytest.warns(xrough.QualityWarning, match="below the smallest lag"):
        patch = many.rough.patch_radius(E_star="25 MPa", gamma="30 mJ/m^2")  # 100 G
    ax = patch.rough.plot()[0]
    assert ax.get_xscale() == "log"
    assert ax.get_xlabel() == "adhesive patch radius (nm)"
    assert len(ax.get_yticks()) == 3
    dots = [ln for ln in ax.get_lines() if ln.get_marker() == "o"]
    np.testing.assert_allclose(sorted(float(d.get_xdata()[0]) for d in dots),
                               sorted(patch.a_c.values))
    assert "γ" in ax.get_title()
    _inside_figure(ax.figure, ax.xaxis.label, ax.yaxis.label, ax.title)
    _check_image(ax.figure, "patch_radius", tmp_path)


def test_infinite_patch_radius_is_marked():
    G = _model_G()
    patch = G.rough.patch_radius(E_star="25 MPa", gamma="10 J/m^2")
    assert np.isinf(float(patch.a_c))
    ax = patch.rough.plot()[0]
    assert any("inf" in t.get_text() for t in ax.texts)
    assert any(ln.get_marker() == ">" for ln in ax.get_lines())
    # no finite radius: no scale, so no tick values drawn at arbitrary radii
    ax.figure.canvas.draw()
    assert all(t.get_text() == "" for t in ax.get_xticklabels())
    assert ax.get_title() == "γ = 10 J/m², E* = 25 MPa"


def test_legends_and_titles_write_values_with_their_units():
    G = _model_G()
    ax = G.rough.persson(E_star="25 MPa", p0=["0.1 MPa", "1 MPa"]).a_r.rough.plot()
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["p0 = 100 kPa",
                                                                   "p0 = 1 MPa"]
    ax = G.rough.patch_radius(E_star="25 MPa", gamma="50 mJ/m2").rough.plot()[0]
    assert ax.get_title() == "γ = 50 mJ/m², E* = 25 MPa"
    plt.close("all")


def test_other_datasets_still_say_nothing_to_plot():
    with pytest.raises(ValueError, match="nothing to plot"):
        xr.Dataset({"a": 1.0}).rough.plot()


def test_fit_plot_through_the_accessor_draws_the_data_given():
    """``fit.rough.plot(G=G)`` draws G (a line and its error band) under the model;
    without G only the model; G= on a Dataset that is not a fit is refused."""
    C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
                              rms_gradient=0.5, unit="nm")
    G = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="100 um")
    G = G.assign_coords(standard_error=0.02 * G)
    fit = G.rough.fit()
    (alone,) = fit.rough.plot()
    (both,) = fit.rough.plot(G=G)
    assert len(both.lines) == len(alone.lines) + 1
    assert len(both.collections) >= 1  # the error band of G
    np.testing.assert_allclose(both.lines[0].get_ydata()[:3], G.values[:3])
    with pytest.raises(ValueError, match="not one"):
        G.rough.persson(E_star="25 MPa", p0="0.1 MPa").rough.plot(G=G)
    plt.close("all")


def _tick_labels_overlap(ax, axis):
    """Pairs of drawn tick labels (major and minor) of ``axis`` whose boxes intersect."""
    ax.figure.canvas.draw()
    renderer = ax.figure.canvas.get_renderer()
    ticks = [*axis.get_major_ticks(), *axis.get_minor_ticks()]
    boxes = [t.label1.get_window_extent(renderer) for t in ticks
             if t.label1.get_visible() and t.label1.get_text()
             and t.get_loc() is not None
             and axis.get_view_interval().min() <= t.get_loc()
             <= axis.get_view_interval().max()]
    return [(a, b) for i, a in enumerate(boxes) for b in boxes[i + 1:] if a.overlaps(b)]


@pytest.mark.parametrize("span", [("10 nm", "20 um"), ("100 nm", "2 um"), ("150 nm", "700 nm"),
                                  ("180 nm", "400 nm")])
def test_log_tick_labels_never_overlap(span):
    """Regression: on a log axis spanning about a decade, matplotlib labels every minor
    tick (2, 3, 4, 6 x 10^k) and they overlapped on a small axes. Labels are drawn on a
    3 x 2.5 inch figure and their boxes must not intersect; where fewer than two powers
    of ten are in view, at least one label (2 or 5 x 10^k, or a power) still gives the
    scale."""
    G = _model_G().sel(dr=slice(*(xrough.units.length_in(s, "nm", what="dr") for s in span)))
    fig, ax = plt.subplots(figsize=(3, 2.5), layout="constrained")
    G.rough.plot(ax=ax)
    assert _tick_labels_overlap(ax, ax.xaxis) == []
    labels = [t.get_text() for t in ax.get_xticklabels(which="both") if t.get_text()]
    assert labels, "no scale on the x axis"
    plt.close(fig)


def test_patch_radius_ticks_do_not_overlap():
    """The patch-radius axis spans about a decade around a_c: its labels stay apart."""
    ax = _model_G().rough.patch_radius(E_star="25 MPa", gamma="50 mJ/m2").rough.plot()[0]
    ax.figure.set_size_inches(4, 3)
    assert _tick_labels_overlap(ax, ax.xaxis) == []
    plt.close("all")


def test_dataset_plots_take_ax_like_dataarrays():
    """``ds.rough.plot(ax=ax)`` draws a one-panel Dataset into the caller's Axes, as a
    DataArray's does; too few axes for the panels, or ax and axes together, are refused
    (before, extra panels were dropped silently)."""
    G = _model_G()
    fig, ax = plt.subplots()
    (drawn,) = G.rough.patch_radius(E_star="25 MPa", gamma="50 mJ/m2").rough.plot(ax=ax)
    assert drawn is ax and ax.get_xscale() == "log"
    (drawn,) = G.rough.fit().rough.plot(ax=ax, G=G)
    assert drawn is ax
    persson = G.rough.persson(E_star="25 MPa", p0="0.1 MPa")
    (drawn,) = persson.rough.plot(ax=ax, variables=["a_r"])
    assert drawn is ax and ax.get_title() == "contact area a_r (eq. 29)"
    with pytest.raises(ValueError, match="1 Axes given for 2 panels"):
        persson.rough.plot(ax=ax)
    with pytest.raises(ValueError, match="not both"):
        persson.rough.plot(ax=ax, axes=[ax])
    plt.close("all")


def test_questionable_curves_are_drawn_as_such():
    """A questionable result is dashed with hollow points and says so in the legend; a
    good one is drawn plain, without a legend entry for its quality."""
    import warnings

    C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
                              rms_gradient=0.5, unit="nm")
    G = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="100 um")
    good = G.rough.persson(E_star="25 MPa", p0="0.1 MPa")
    assert good.attrs["quality"] == "good"
    ax = good.rough.plot(variables=["a_r"])[0]
    assert ax.lines[0].get_linestyle() == "-"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["expected exact"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        bad = xrough.quality.mark(good, "a test of the marks", what="persson")
    ax = bad.rough.plot(variables=["a_r"])[0]
    assert ax.lines[0].get_linestyle() == "--"
    assert ax.lines[0].get_markerfacecolor() == "none"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["questionable",
                                                                   "expected exact"]


def test_persson_plots_its_errors_as_bands_not_panels():
    """a_r_std is a filled band of one standard deviation around a_r; a_r_exact, where a
    contact solver is expected, a dotted line in the hatched band of a_r_exact_lower to
    _upper; none of them gets a panel."""
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r=32.0, lambda_s=4.0, size=128.0,
                                      n=128, rms_gradient=0.1, unit="nm", seed=0)
    ds = topo.rough.acf().rough.persson(E_star="25 MPa", p0="0.15 MPa")
    errors = ("_std", "_model_error", "_exact", "_exact_lower", "_exact_upper")
    everything = ds.rough.plot(variables=[n for n in ds.data_vars
                                          if not n.endswith(errors)])
    assert len(everything) == 10  # errors are bands, not panels
    axes = ds.rough.plot()  # by default the area and the stress, readably titled
    assert [ax.get_title() for ax in axes] == ["contact area a_r (eq. 29)",
                                               "mean contact stress sigma_c (eq. 39/40)"]
    a = ds.a_r.values[np.isfinite(ds.a_r.values)]
    assert axes[0].get_yscale() == ("linear" if a.max() < 10 * a.min() else "log")
    narrow = ds.isel(dr=slice(0, 4))  # a_r within a decade: a linear axis reads better
    assert narrow.rough.plot()[0].get_yscale() == "linear"
    ax = axes[0]
    filled, hatched = ax.collections[0], ax.collections[1]
    assert hatched.get_hatch() == "///" and not filled.get_hatch()
    y, std = ds.a_r.values, ds.a_r_std.values
    exact, lo, hi = (ds[f"a_r{s}"].values for s in errors[2:])
    k = int(np.flatnonzero(np.isfinite(std) & np.isfinite(exact))[0])
    top = filled.get_paths()[0].vertices[:, 1]
    assert np.isclose(top, y[k] + std[k]).any()
    edges = hatched.get_paths()[0].vertices[:, 1]
    assert np.isclose(edges, lo[k]).any() and np.isclose(edges, hi[k]).any()
    dotted = [ln for ln in ax.lines if ln.get_linestyle() == ":"]
    assert len(dotted) == 1 and dotted[0].get_label() == "expected exact"
    assert np.isclose(dotted[0].get_ydata()[k], exact[k]) and exact[k] > y[k]


@pytest.mark.parametrize("name", ["x3p-2.x3p", "spot_1-1000nm.ibw", "nid-1.nid",
                                  "al3d-1.al3d", "sdf-1.sdf"])
def test_maps_in_metres_plot_in_readable_units(name):
    """Maps in m were drawn in m, with 1e-5 offsets on the axes and labels overlapping;
    now each axis in the unit where its values are 1 to 1000, without offsets."""
    from conftest import DATA

    path = DATA / "instruments" / name
    if not path.exists():
        pytest.skip("shared data not present")
    if path.suffix in (".al3d", ".nid"):  # read through SurfaceTopography (formats extra)
        pytest.importorskip("SurfaceTopography")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        topo = xrough.open_topography(path)
    ax = topo.rough.plot()
    ax.figure.canvas.draw()
    for axis in (ax.xaxis, ax.yaxis, ax.figure.axes[-1].yaxis):
        assert axis.get_offset_text().get_text() == "", (name, axis.get_label_text())
        ticks = [abs(t) for t in axis.get_majorticklocs() if t]
        assert 0.1 <= max(ticks) <= 1000, (name, ticks)
    assert "(m)" not in ax.get_xlabel()


def test_readable_units_convert_not_relabel():
    topo = xrough.topography(1e-8 * np.arange(12.0).reshape(3, 4), spacing=5e-6, unit="m")
    shown = xrough.plot.readable_units(topo)
    assert shown.attrs["units"] == "nm" and shown.x.attrs["units"] == "um"
    np.testing.assert_allclose(shown.values, topo.values * 1e9)
    np.testing.assert_allclose(shown.x.values, topo.x.values * 1e6)


def test_a_result_of_a_stitched_g_breaks_at_its_gap():
    """The stress ACF of a stitched G was drawn across the lags no measurement covers:
    results now carry the uncovered ranges (provenance) and their lines break there."""
    rng = np.random.default_rng(0)
    fine = xrough.self_affine_surface(hurst=0.7, lambda_r=32.0, lambda_s=4.0, size=128.0,
                                      n=128, rms_gradient=0.1, unit="nm", seed=1)
    coarse = xrough.topography(rng.normal(size=(64, 64)), spacing="40 nm", unit="nm")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        G = xrough.stitch({"fine": fine, "coarse": coarse}, windows={
            "fine": (None, "30 nm"), "coarse": ("500 nm", None)}, warn=False)
        S = G.rough.stress_acf(E_star="25 MPa")
    assert "uncovered_dr_min" in S.attrs
    ax = S.rough.plot()
    y = np.asarray(ax.lines[0].get_ydata(), dtype=float)
    inner = y[np.flatnonzero(np.isfinite(y))[0]:]  # from the first value drawn
    assert np.isnan(inner).sum() == 1  # one break, at the gap


def test_failed_result_draws_an_empty_panel_with_its_reason():
    """An all-NaN result (a failed curve) draws no line and says why in the panel."""
    topo = xrough.self_affine_surface(hurst=0.8, n=64, size="64 nm", rms_gradient=0.1,
                                      lambda_r="32 nm", lambda_s="2 nm", unit="nm", seed=1)
    G = topo.rough.acf()
    failed = G.copy(data=np.full(G.shape, np.nan)).assign_attrs(
        quality="failed", quality_notes="too few pairs in every bin")
    ax = failed.rough.plot()
    assert [t.get_text() for t in ax.texts] == ["no finite values: too few pairs in every bin"]
    assert ax.get_yscale() == "linear"


def test_report_figure_of_many_files_stays_readable():
    """Past ten files the report's figure draws no per-file legend (it covered the data)
    but says how many; a questionable contact area is dashed, as on every plot."""
    from xrough.cli.report import _figure

    topo = xrough.self_affine_surface(hurst=0.8, n=64, size="64 nm", rms_gradient=0.1,
                                      lambda_r="32 nm", lambda_s="2 nm", unit="nm", seed=1)
    G = topo.rough.acf()
    contact = G.rough.persson(E_star="1 MPa", p0="10 kPa")
    bad = contact.assign_coords(quality_flag=np.int8(1))
    runs = [{"name": f"scan{k}", "results": {"G": G.copy(), "persson": contact}}
            for k in range(11)]
    fig = _figure(runs, "10 kPa")
    assert all(ax.get_legend() is None for ax in fig.axes)
    assert fig.axes[0].get_title() == "11 measurements"
    few = _figure(runs[:2] + [{"name": "odd", "results": {"G": G.copy(), "persson": bad}}],
                  "10 kPa")
    styles = {ln.get_label(): ln.get_linestyle() for ln in few.axes[1].lines}
    assert styles["scan0"] == "-" and styles["odd (questionable)"] == "--", styles
    assert few.axes[1].get_yscale() in ("log", "linear")
