"""The command line, run in-process through ``xrough.cli.main`` (one run in a subprocess).

Each defect of the command line found by trying it as a new user has a regression test
here: units of printed numbers, the multi-file figure, options the API has, a short
``info``, the default detrending, JSON output, group names of multi-file archives, atomic
writes, argument checks and one-line errors with documented exit codes.
"""

import contextlib
import csv
import decimal
import importlib.util
import io
import json
import re
import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr

import xrough
import xrough.cli
from conftest import data_path
from xrough import units as u
from xrough.cli import main
from xrough.io.archive import safe_name

E_STAR, P0, GAMMA = "25MPa", "0.1MPa", "50mJ/m^2"


def surface():
    return xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="100 nm",
                                      size="8 um", n=256, rms_gradient=0.5, seed=1,
                                      unit="nm")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A map in um with heights in nm (tilted), the same map in mm with heights in m,
    a profile, a map with many attributes, and broken files."""
    folder = tmp_path_factory.mktemp("cli")
    topo = surface()
    h = topo.values + 0.05 * topo.x.values[None, :]  # a tilt of 50 nm per um
    xrough.topography(h, spacing="31.25 nm", unit="um", height_unit="nm").to_netcdf(
        folder / "afm.nc")
    xrough.topography(h * 1e-9, spacing="31.25 nm", unit="mm", height_unit="m").to_netcdf(
        folder / "stylus.nc")
    xrough.topography(topo.values[0], spacing="31.25 nm", unit="um",
                      height_unit="nm").to_netcdf(folder / "profile.nc")
    header = {f"header_entry_{k:03d}": f"value {k}" for k in range(300)}
    header.update(not_measured=np.nan, count=np.int64(7))
    xrough.topography(topo.values[:64, :64], spacing="31.25 nm", unit="nm",
                      attrs=header).to_netcdf(folder / "long_header.nc")
    (folder / "broken.nc").write_bytes(b"CDF\x01" + b"\x00" * 20)
    (folder / "noise.xyz").write_bytes(bytes(range(256)) * 4)
    return folder


def run(*args, cwd, monkeypatch, capsys):
    """Run ``xrough args`` in ``cwd``; return (exit status, stdout, stderr)."""
    monkeypatch.chdir(cwd)
    status = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return status, out, err


def table(text):
    """Rows of the report table as dicts (columns are separated by two spaces or more)."""
    lines = [line for line in text.splitlines() if line.strip()]
    head = re.split(r"\s{2,}", lines[0].strip())
    rows = []
    for line in lines[1:]:
        cells = re.split(r"\s{2,}", line.strip())
        if len(cells) != len(head):
            break
        rows.append(dict(zip(head, cells)))
    return rows


CELL = re.compile(r"^(?P<value>\S+)(?: \+-(?P<stat>\S+) \(stat\))?"
                  r"(?:, exact (?P<exact>\S+) \[(?P<lower>\S+), (?P<upper>\S+)\])?"
                  r"(?: (?P<unit>.+))?$")


def cell(printed):
    """The parts of a printed ``"17.8 +-3 (stat), exact 14 [12, 16] MPa"``: value, stat,
    exact, lower, upper (None if not printed) and unit ("" for dimensionless)."""
    parts = CELL.match(printed).groupdict()
    parts["unit"] = parts["unit"] or ""
    return parts


def agrees(printed, value, unit, part="value"):
    """Does the printed ``"12.34 nm"`` (or one of its errors: ``part``) equal ``value unit``
    within its last printed digit?"""
    parts = cell(printed)
    number, printed_unit = parts[part], parts["unit"]
    q = u.ureg.Quantity(float(number), printed_unit or "dimensionless")
    half_digit = 0.5 * 10.0 ** decimal.Decimal(number).as_tuple().exponent
    tolerance = u.ureg.Quantity(half_digit, printed_unit or "dimensionless")
    expected = u.ureg.Quantity(float(value), u.parse_units(unit)).to(q.units)
    return abs(expected.magnitude - q.magnitude) <= tolerance.magnitude * (1 + 1e-9)


@pytest.fixture(scope="module")
def report(files):
    """``xrough report afm.nc stylus.nc`` in-process, with its output and figure."""
    out = io.StringIO()
    with pytest.MonkeyPatch.context() as mp, contextlib.redirect_stdout(out):
        mp.chdir(files)
        mp.setattr(plt, "close", lambda *a, **k: None)  # keep the figure to inspect it
        before = set(plt.get_fignums())
        status = main(["report", "afm.nc", "stylus.nc", "--E-star", E_STAR, "--p0", P0,
                       "--gamma", GAMMA, "-o", "out/report.nc"])
        new = sorted(set(plt.get_fignums()) - before)
    fig = plt.figure(new[-1]) if new else None
    yield status, out.getvalue(), fig
    plt.close("all")


def api_results(path):
    """What the report computes, through the API: default plane detrending."""
    topo = xrough.detrend(xrough.open_topography(path), mode="plane")
    G = topo.rough.acf(direction="radial", points_per_decade=10)
    fit = G.rough.fit()
    gbar = G.rough.gradient()
    contact = G.rough.persson(E_star=E_STAR, p0=P0, gradient=gbar, fit=fit)
    # the smallest lag where Persson theory gives numbers (NaN below: undetermined)
    k = int(np.flatnonzero(np.isfinite(contact.a_r) & np.isfinite(contact.sigma_c))[0])
    at = contact.isel(dr=k)
    return {"sigma_h (fit)": fit.sigma_h, "lambda_r": fit.lambda_r,
            "rms grad": gbar.sel(dr=float(at.dr)),
            "v_el": G.rough.energy(E_star=E_STAR).v_el,
            "a_r": at.a_r, "sigma_c": at.sigma_c, "at dr": at.dr,
            "patch radius": G.rough.patch_radius(E_star=E_STAR, gamma=GAMMA).a_c,
            "H": fit.hurst}


def test_report_numbers_agree_with_the_api_in_their_printed_units(files, report):
    status, out, _ = report
    assert status == 0
    rows = {r["measurement"]: r for r in table(out)}
    assert set(rows) == {"afm", "stylus"}
    expected = api_results(files / "afm.nc")
    checked = 0
    for column, value in expected.items():
        printed = rows["afm"][column]
        if column == "H":
            assert printed.startswith(f"{float(value):.3f}+-")
            continue
        if not np.isfinite(float(value)):
            continue
        assert agrees(printed, value, value.attrs.get("units", "1")), (column, printed)
        checked += 1
    assert checked >= 7
    # beside them: one standard deviation (stat) and the expected exact value, its bounds
    errors = api_errors(files / "afm.nc")
    for (column, part), value in errors.items():
        assert agrees(rows["afm"][column], abs(float(value)), value.attrs.get("units", "1"),
                      part), (column, part, rows["afm"][column], float(value))


def api_errors(path):
    """The errors the report prints beside its numbers, through the API."""
    topo = xrough.detrend(xrough.open_topography(path), mode="plane")
    G = topo.rough.acf(direction="radial", points_per_decade=10)
    contact = G.rough.persson(E_star=E_STAR, p0=P0)
    k = int(np.flatnonzero(np.isfinite(contact.a_r) & np.isfinite(contact.sigma_c))[0])
    at = contact.isel(dr=k)
    gbar = G.rough.gradient()
    return {("v_el", "stat"): G.rough.energy(E_star=E_STAR).v_el_std,
            ("rms grad", "stat"): gbar.gbar_std.sel(dr=float(at.dr)).assign_attrs(units="1"),
            **{(name, part): at[f"{name}{suffix}"] for name in ("a_r", "sigma_c")
               for part, suffix in (("stat", "_std"), ("exact", "_exact"),
                                    ("lower", "_exact_lower"), ("upper", "_exact_upper"))}}


def test_mean_gap_states_its_interval(report):
    """The mean gap's bracket is a 90 % interval (the solver study's), Persson theory's a
    one-sigma one: the mean gap's says so, the others print none."""
    _, out, _ = report
    row = {r["measurement"]: r for r in table(out)}["afm"]
    assert row["mean gap"].endswith("nm (90 %)"), row["mean gap"]
    assert "%" not in row["a_r"]


def test_sigma_h_is_printed_in_the_height_unit(report):
    """A map in um with 65 nm rms printed 'sigma_h 0.06524 um' in the lateral unit's
    scale... and in mm/m files the lateral unit labelled a height in m."""
    _, out, _ = report
    rows = {r["measurement"]: r for r in table(out)}
    for name in ("afm", "stylus"):  # the same surface: heights in nm and in m
        number, unit = rows[name]["sigma_h (fit)"].split()
        assert unit == "nm" and 50 < float(number) < 80, rows[name]
        assert rows[name]["lambda_r"].endswith("µm")
        assert rows[name]["v_el"].endswith("J/m²") and rows[name]["sigma_c"].endswith("Pa")
    assert rows["afm"]["sigma_h (fit)"] == rows["stylus"]["sigma_h (fit)"]  # unit invariance


def test_multi_file_figure_draws_every_file_in_the_axis_unit(files, report):
    """A file in mm and a file in m were drawn on one axis labelled with one unit."""
    _, _, fig = report
    ax = fig.axes[0]
    dr_unit = re.search(r"\(([^)]*)\)$", ax.get_xlabel()).group(1)
    g_unit = re.search(r"\(([^)]*)\)$", ax.get_ylabel()).group(1)
    for name in ("afm", "stylus"):  # one line each, labelled with the measurement
        (line,) = [ln for ln in ax.lines if ln.get_label() == name]
        G = xrough.detrend(xrough.open_topography(files / f"{name}.nc"),
                           mode="plane").rough.acf()
        dr = G.dr.values * u.conversion_factor(G.dr.attrs["units"], dr_unit)
        g = G.values * u.conversion_factor(G.attrs["units"], g_unit)
        np.testing.assert_allclose(line.get_xdata(), dr, rtol=1e-9, err_msg=name)
        np.testing.assert_allclose(line.get_ydata(), g, rtol=1e-9, err_msg=name)


def test_report_figure_keeps_every_label_inside_and_apart(files, report):
    """The fixed margins leave room: each panel with its labels and tick labels as drawn
    inside the figure, and the right panel's clear of the left panel's frame (a tight
    layout is not run)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    _, _, fig = report
    canvas = FigureCanvasAgg(fig)  # as the report saved it, whatever pyplot's backend now
    canvas.draw()
    renderer = canvas.get_renderer()
    box = fig.bbox
    left, right = fig.axes[:2]
    for ax in (left, right):
        ext = ax.get_tightbbox(renderer)  # what is drawn: labels, tick labels, legend
        assert (ext.x0 >= box.x0 - 0.5 and ext.y0 >= box.y0 - 0.5
                and ext.x1 <= box.x1 + 0.5 and ext.y1 <= box.y1 + 0.5), (ext, box)
    assert right.get_tightbbox(renderer).x0 > left.get_window_extent(renderer).x1


@pytest.mark.parametrize("n_files", [3, 12])
def test_report_figure_names_the_files_without_a_value(n_files):
    """A file whose contact area is all NaN printed 'no finite values' over the others'
    lines, one text per such file on top of each other, without naming it, and turned
    the log axis under the others linear when drawn last. Now the others are drawn as
    they are and one note names the files without a value (four, then how many more)."""
    from xrough.cli.report import _figure

    topo = xrough.self_affine_surface(hurst=0.7, lambda_r=32, lambda_s=4, size=128, n=128,
                                      rms_gradient=0.3, unit="nm", seed=1)
    G = topo.rough.acf()
    P = G.rough.persson(E_star=E_STAR, p0=P0)
    failed = P.assign(a_r=P.a_r * np.nan)
    measured = [{"name": f"f{k}", "results": {"G": G.copy(), "persson": P if k == 0 else
                                              failed}} for k in range(n_files)]
    fig = _figure(measured, "0.1 MPa")
    try:
        ax = fig.axes[1]
        texts = [t.get_text() for t in ax.texts]
        names = ", ".join(f"f{k}" for k in range(1, min(n_files, 5)))
        more = f" and {n_files - 5} more" if n_files > 5 else ""
        assert texts == [f"no finite values: {names}{more}"]
        assert len(ax.lines) >= 1 and ax.get_yscale() == "log"
        assert not fig.axes[0].texts and len(fig.axes[0].lines) == n_files
    finally:
        plt.close(fig)


def test_report_archive_and_figure(files, report):
    status, out, _ = report
    assert status == 0 and "wrote out/report.nc, out/report.csv and out/report.png" in out
    assert (files / "out" / "report.png").stat().st_size > 10_000
    back = xrough.open_analysis(files / "out" / "report.nc")
    assert set(back["afm"]) >= {"G", "fit", "persson", "energy", "patch", "gradient"}
    assert "E_star=25MPa" in back["_provenance"]["history"]
    assert back["afm"]["G"].attrs["detrend"] == "plane"


def test_report_states_the_default_detrending(report):
    """The report detrended nothing by default, and did not say so."""
    _, out, _ = report
    assert "detrend before G: plane" in out


@pytest.mark.slow  # 65 s: the whole job
def test_report_footer_says_which_file_got_which_detrending(files, monkeypatch, capsys):
    """A map and a profile are detrended differently by default (plane, line): the
    footer said 'line, plane' without saying which file got which."""
    status, out, _ = run("report", "afm.nc", "profile.nc", "--E-star", E_STAR, "--p0", P0,
                         "-o", "mixed.nc", cwd=files, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0
    footer = next(line for line in out.splitlines() if line.startswith("detrend before G"))
    assert footer.startswith("detrend before G: afm plane, profile line"), footer
    assert "sigma_h from the fit of G" in footer


def test_detrend_defaults_to_a_plane_for_maps_and_a_line_for_profiles(files, monkeypatch,
                                                                      capsys):
    status, out, _ = run("acf", "afm.nc", "profile.nc", "--json", "-o", "g.nc", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0
    found = {m["name"]: m["detrend"] for m in json.loads(out)["measurements"]}
    assert found == {"afm": "plane", "profile": "line"}
    back = xrough.open_analysis(files / "g.nc")
    assert back["afm"]["G"].attrs["detrend"] == "plane"
    if importlib.util.find_spec("zarr") is not None:  # -o *.zarr writes a Zarr store
        status, _, _ = run("acf", "afm.nc", "profile.nc", "-o", "g.zarr", cwd=files,
                           monkeypatch=monkeypatch, capsys=capsys)
        assert status == 0 and (files / "g.zarr").is_dir()
        xr.testing.assert_identical(xrough.open_analysis(files / "g.zarr")["afm"]["G"],
                                    back["afm"]["G"])
    status, out, _ = run("acf", "afm.nc", "--detrend", "none", "-o", "g_raw.nc",
                         cwd=files, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0 and "detrend before G: none" in out
    back = xrough.open_analysis(files / "g_raw.nc")
    xr.testing.assert_allclose(back["afm"]["G"].drop_attrs(),
                               xrough.open_topography(files / "afm.nc").rough.acf()
                               .drop_attrs())


def test_implausible_heights_are_flagged(files, monkeypatch, capsys):
    """Heights 1.6e7 times too large gave v_el = 6.8e13 J/m^2 without a word."""
    status, out, err = run("report", "afm.nc", "--height-scale", "1.6e7", "--E-star",
                           E_STAR, "--p0", P0, "--json", "-o", "steep.nc", cwd=files,
                           monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0
    assert "afm.nc: rms gradient" in err and "--height-unit" in err
    assert len(err.strip().splitlines()) == 1  # one line, no numpy noise
    assert "steeper than any measured surface" in json.loads(out)["measurements"][0][
        "warnings"][0]


@pytest.mark.slow  # 2 min: the whole job
def test_demo_runs_small(files, monkeypatch, capsys):
    status, out, err = run("demo", "-n", "64", "--pairs", "1000", "-o", "demo", cwd=files,
                           monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0, err
    assert "Traceback" not in err and all(line.startswith("xrough: warning: ")
                                          for line in err.splitlines())
    assert re.search(r"rms height [\d.]+ nm \(model [\d.]+ nm\)", out)
    assert (files / "demo" / "demo.png").exists() and not list(
        (files / "demo").glob(".*.tmp"))


def test_report_json(files, monkeypatch, capsys):
    status, out, err = run("report", "afm.nc", "--E-star", E_STAR, "--p0", P0, "--json",
                           "-o", "rj.nc", cwd=files, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0, err
    doc = json.loads(out)  # nothing but JSON on stdout
    m = doc["measurements"][0]
    assert m["sigma_h"]["units"] == "nm" and m["lambda_r"]["units"] == "um"
    assert m["v_el"]["units"] == "J m-2" and m["sigma_c"]["units"] == "Pa"
    assert doc["parameters"]["E_star"] == {"value": 25e6, "units": "Pa"}
    assert m["patch_radius"] is None and m["detrend"] == "plane"
    fit = xrough.open_analysis(files / "rj.nc")["afm"]["fit"]
    assert m["sigma_h"]["value"] == pytest.approx(float(fit.sigma_h), rel=1e-12)


def test_acf_json_and_text_carry_units(files, monkeypatch, capsys):
    status, out, _ = run("acf", "stylus.nc", "--json", "-o", "gs.nc", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0
    m = json.loads(out)["measurements"][0]
    assert m["dr"]["units"] == "mm" and m["G"]["units"] == "m2"
    assert len(m["dr"]["values"]) == len(m["G"]["values"]) == len(m["pair_count"])
    status, out, _ = run("acf", "stylus.nc", "-o", "gs.nc", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert re.search(r"dr 31\.25 nm to [\d.]+ µm, G [\d.]+ \S+m² to", out), out


def test_info_is_short_and_all_prints_the_header(files, monkeypatch, capsys):
    status, out, _ = run("info", "long_header.nc", cwd=files, monkeypatch=monkeypatch,
                         capsys=capsys)
    assert status == 0
    assert len(out.splitlines()) < 25 and "header_entry_150" not in out
    assert "64 x 64" in out and "valid points  100.00%" in out and "--all" in out
    status, out, _ = run("info", "long_header.nc", "--all", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert len(out.splitlines()) > 300 and "header_entry_150: value 150" in out
    status, out, _ = run("info", "long_header.nc", "--all", "--json", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    attrs = json.loads(out)["files"][0]["attrs"]  # NaN and numpy values as plain JSON
    assert attrs["not_measured"] is None
    assert attrs["count"] == 7 and attrs["header_entry_150"] == "value 150"


def test_info_units_size_and_json(files, monkeypatch, capsys):
    status, out, _ = run("info", "afm.nc", cwd=files, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0
    assert "size          8 µm x 8 µm" in out and "lateral um, height nm" in out
    status, out, _ = run("info", "afm.nc", "--json", cwd=files, monkeypatch=monkeypatch,
                         capsys=capsys)
    doc = json.loads(out)["files"][0]
    assert doc["size"]["x"] == {"value": pytest.approx(8.0), "units": "um"}
    assert doc["height_units"] == "nm" and doc["valid_fraction"] == 1.0
    assert doc["provenance"]["source_file"] == "afm.nc" and doc["channels"] == []


def test_unit_and_height_unit_options(files, monkeypatch, capsys):
    status, out, _ = run("info", "afm.nc", "--unit", "nm", "--height-unit", "um",
                         "--format", "netcdf", "--json", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0
    doc = json.loads(out)["files"][0]
    assert (doc["lateral_units"], doc["height_units"]) == ("nm", "um")


def test_channel_on_a_format_without_channels_is_a_clear_error(files, monkeypatch, capsys):
    status, _, err = run("info", "afm.nc", "--channel", "1", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 1 and len(err.strip().splitlines()) == 1
    assert "afm.nc" in err and "--channel" in err and "TypeError" not in err


def test_errors_name_the_command_line_options_not_the_api_keywords(files, monkeypatch,
                                                                   capsys):
    """Advice such as 'pass unit=' or 'open_topography(path, resample=True)' is the
    API's; on the command line it is --unit and --resample."""
    x = np.sort(np.random.default_rng(0).uniform(0, 10, 200))
    np.savetxt(files / "nonuniform.txt", np.c_[x, np.sin(x)])
    status, _, err = run("info", "nonuniform.txt", cwd=files, monkeypatch=monkeypatch,
                         capsys=capsys)
    assert status == 1 and "--unit" in err and "unit=" not in err
    status, _, err = run("acf", "nonuniform.txt", "--unit", "um", "-o", "nu.nc", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 1 and "--resample" in err and "resample=True" not in err
    status, out, err = run("acf", "nonuniform.txt", "--unit", "um", "--resample", "-o",
                           "nu.nc", cwd=files, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0, err


def test_wrong_format_is_a_one_line_error(files, monkeypatch, capsys):
    status, _, err = run("info", "afm.nc", "--format", "sdf", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 1 and "afm.nc" in err and len(err.strip().splitlines()) == 1


def test_info_lists_and_selects_channels_of_an_afm_file(monkeypatch, capsys):
    path = data_path("instruments", "di-1.di")
    status, out, _ = run("info", path, cwd=path.parent, monkeypatch=monkeypatch,
                         capsys=capsys)
    assert status == 0 and len(out.splitlines()) < 30  # was about 800 header lines
    assert re.search(r"channels +0: Height\W+nm\W+height.*; 1: .*; 3: ", out)
    status, out, _ = run("info", path, "--channel", "2", "--json", cwd=path.parent,
                         monkeypatch=monkeypatch, capsys=capsys)
    if status == 0:  # a phase channel, if the reader accepts non-height channels
        assert json.loads(out)["files"][0]["channel_index"] == 2


def test_info_sur_heights_in_their_unit(monkeypatch, capsys):
    path = data_path("instruments", "sur-2.sur")
    status, out, _ = run("info", path, "--json", cwd=path.parent, monkeypatch=monkeypatch,
                         capsys=capsys)
    doc = json.loads(out)["files"][0]
    topo = xrough.open_topography(path)
    assert doc["rms_height"]["units"] == topo.attrs["units"]
    assert doc["rms_height"]["value"] == pytest.approx(float(topo.std()), rel=1e-9)


def test_acf_keeps_every_measurement_with_safe_group_names(files, monkeypatch, capsys):
    """Same stems overwrote each other; '(1)', '-x', '.x' stems broke the archive; a
    measurement named _provenance replaced the provenance."""
    topo = xrough.open_topography(files / "afm.nc")
    names = ["a/scan.nc", "b/scan.nc", "c/(1).nc", "c/-lead.nc", "c/.hidden.nc",
             "c/_provenance.nc", "c/na me.nc"]
    for name in names:
        (files / name).parent.mkdir(exist_ok=True)
        topo.isel(y=slice(0, 64), x=slice(0, 64)).to_netcdf(files / name)
    status, _, err = run("acf", *names, "-o", "many.nc", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0, err
    back = xrough.open_analysis(files / "many.nc")
    groups = set(back) - {"_provenance"}
    assert len(groups) == len(names)
    assert {"a_scan", "b_scan"} <= groups
    assert all(safe_name(g) == g for g in groups)  # legal NetCDF names as written
    assert "xrough acf" in back["_provenance"]["history"]
    assert {back[g]["G"].attrs["source_path"] for g in groups} == set(names)
    assert "_provenance.nc" in {back[g]["G"].attrs["source_file"] for g in groups}


def test_failed_acf_leaves_no_file_and_keeps_the_previous(files, monkeypatch, capsys):
    status, _, err = run("acf", "afm.nc", "broken.nc", "-o", "fresh.nc", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 1 and "broken.nc" in err and not (files / "fresh.nc").exists()
    (files / "kept.nc").write_bytes(b"previous results")
    status, _, _ = run("acf", "broken.nc", "-o", "kept.nc", cwd=files,
                       monkeypatch=monkeypatch, capsys=capsys)
    assert status == 1 and (files / "kept.nc").read_bytes() == b"previous results"
    assert not list(files.glob(".*.tmp"))


def test_a_failure_while_writing_leaves_the_previous_archive(files, monkeypatch, capsys):
    """A failed write destroyed the archive at the path and left a broken one. The disk
    fills up half way through NetCDF's write of the archive (one atomic write: the
    library's)."""
    def disk_full(tree, path, **kwargs):
        Path(path).write_bytes(b"half an archive")
        raise OSError("no space left on device")

    (files / "previous.nc").write_bytes(b"previous results")
    monkeypatch.setattr(xr.DataTree, "to_netcdf", disk_full)
    status, _, err = run("acf", "long_header.nc", "-o", "previous.nc", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 1 and "no space left" in err
    assert (files / "previous.nc").read_bytes() == b"previous results"
    assert not list(files.glob(".*.tmp"))


def test_output_into_a_missing_folder_is_created(files, monkeypatch, capsys):
    status, _, err = run("acf", "long_header.nc", "-o", "new/deeper/g.nc", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0, err
    assert "G" in xrough.open_analysis(files / "new" / "deeper" / "g.nc")["long_header"]


@pytest.mark.parametrize("args, message", [
    (("demo", "-n", "0"), "-n 0"),
    (("demo", "-n", "16"), "-n 16"),
    (("demo", "--hurst", "1.5"), "--hurst"),
    (("demo", "-o", "afm.nc/inside"), "cannot create the folder"),
    (("acf", "afm.nc", "-o", "afm.nc/g.nc"), "cannot create the folder"),
    (("acf", "afm.nc", "-o", "."), "is a folder"),
    (("info", "missing.nc"), "no such file"),
    (("info", "broken.nc"), "broken.nc"),
    (("info", "noise.xyz"), "noise.xyz"),
    (("report", "afm.nc", "--E-star=-1MPa", "--p0", "1MPa"), "--E-star"),
    (("report", "afm.nc", "--E-star", "25 nm", "--p0", "1MPa"), "not a pressure"),
    (("report", "afm.nc", "--E-star", "25MPa", "--p0", "1MPa", "--gamma", "1 m"),
     "--gamma"),
    (("report", "afm.nc", "--E-star", "1e300", "--p0", "1MPa"), "--E-star 1e300: the value "
     "has no unit"),
    (("report", "afm.nc", "--E-star", "25", "--p0", "1MPa"), "e.g. --E-star 25MPa"),
    (("report", "afm.nc", "--E-star", "25MPa", "--p0", "0.1"), "--p0 0.1: the value has no"),
    (("report", "afm.nc", "--E-star", "-25MPa", "--p0", "1MPa"), "--E-star must be positive"),
    (("report", "afm.nc", "--E-star", "25MPA", "--p0", "1MPa"), "did you mean 'MPa'"),
    (("acf", "afm.nc", "--height-scale", "nan"), "--height-scale"),
    (("acf", "profile.nc", "--direction", "y"), "--direction 'x'"),
    (("acf", "afm.nc", "--points-per-decade", "inf"), "--points-per-decade"),
    (("info", "."), "broken.nc"),  # a folder stands for its files: the first bad one
])
def test_bad_input_exits_1_with_a_one_line_reason(files, monkeypatch, capsys, args,
                                                  message):
    status, _, err = run(*args, cwd=files, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 1
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err and "Errno" not in err and "Permission" not in err


def test_usage_errors_exit_2_and_help_documents_exit_codes(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "exit status" in out and "0  success" in out and "2  usage error" in out
    with pytest.raises(SystemExit) as exc:
        main(["acf", "afm.nc", "--no-such-option"])
    assert exc.value.code == 2
    with pytest.raises(SystemExit) as exc:
        main(["info", "x.nc", "--format", "nonsense"])
    assert exc.value.code == 2


def test_installed_command_runs(files):
    """The console script end to end (one subprocess: the entry point and exit status)."""
    res = subprocess.run([sys.executable, "-m", "xrough.cli", "info", "missing.nc"],
                         cwd=files, capture_output=True, text=True, timeout=300)
    assert res.returncode == 1 and res.stderr.startswith("xrough: error: ")
    assert len(res.stderr.strip().splitlines()) == 1


@pytest.mark.slow  # 90 s: the whole job
def test_report_prints_quality_notes_not_flagged_numbers(files, monkeypatch, capsys):
    """A map on a steep tilt (2 nm per nm), not detrended: G ~ dr^2 over all lags, so the
    fit finds no self-affine range (failed) or H on its bound 0.99, "e.g. G ~ dr^2 from a
    tilt" (questionable; the smooth roll-off fits the tilt's G with a 7 % smaller chi^2 than
    the failed fit of the sharp one); its H, sigma_h and lambda_r were printed as
    findings."""
    topo = surface()
    xrough.topography(topo.values + 2.0 * topo.x.values[None, :], spacing="31.25 nm",
                      unit="um", height_unit="nm").to_netcdf(files / "tilted_map.nc")
    status, out, err = run("report", "tilted_map.nc", "--detrend", "none", "--E-star", E_STAR,
                           "--p0", P0, "-o", "tilted.nc", cwd=files,
                           monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0
    row = table(out)[0]
    fit = xrough.open_analysis(files / "tilted.nc")["tilted_map"]["fit"]
    level = fit.attrs["quality"]
    assert level in ("questionable", "failed")
    assert "tilt" in fit.attrs["quality_notes"] or "no self-affine range" in fit.attrs[
        "quality_notes"]
    for cell in (row["H"], row["sigma_h (fit)"], row["lambda_r"]):  # flagged, each
        assert cell == "failed" if level == "failed" else cell.endswith(" ?")
    notes = out[out.index("quality ("):]
    head = next(line for line in notes.splitlines() if line.startswith("  tilted_map: "))
    assert "fit" in head and level in head
    for note in xrough.quality.notes_of(fit):  # each said once, with what it concerns
        assert notes.count(f"    - {note} (") == 1, note
    assert "QualityWarning" not in err and "fit_acf" not in err  # said once, on stdout
    status, out, _ = run("report", "tilted_map.nc", "--detrend", "none", "--E-star",
                         E_STAR, "--p0", P0, "--json", "-o", "tilted.nc", cwd=files,
                         monkeypatch=monkeypatch, capsys=capsys)
    quality = json.loads(out)["measurements"][0]["quality"]
    assert quality["fit"]["level"] == level and quality["fit"]["notes"]


@pytest.fixture(scope="module")
def unlabelled(tmp_path_factory):
    """Files that lack what only the command's options can give: a height unit, a
    lateral unit, a size, a size and units, or a uniform sampling."""
    folder = tmp_path_factory.mktemp("unlabelled")
    rng = np.random.default_rng(0)
    h = rng.normal(size=(16, 16))
    c = np.arange(16.0)
    with_units = {"y": ("y", c, {"units": "um"}), "x": ("x", c, {"units": "um"})}
    xr.DataArray(h, dims=("y", "x"), coords=with_units, name="height").to_netcdf(
        folder / "no_height_unit.nc")
    xr.DataArray(h, dims=("y", "x"), coords={"y": c, "x": c}, name="height",
                 attrs={"units": "nm"}).to_netcdf(folder / "no_lateral_unit.nc")
    xr.DataArray(h, dims=("y", "x"), name="height", attrs={"units": "nm"}).to_netcdf(
        folder / "no_size.nc")
    np.save(folder / "heights.npy", h)
    np.savetxt(folder / "matrix.txt", h)
    x = np.sort(rng.uniform(0, 10, 200))
    np.savetxt(folder / "nonuniform.txt", np.c_[x, np.sin(x)])
    return folder


#: Each case the library's advice names a Python argument (``unit=``, ``size=``,
#: ``resample=True``, ``points_per_decade``, ``direction='x'``, ``channel=``...): the
#: command line names its option instead, and the Python word is not in the message.
HINT_CASES = [
    (("info", "no_height_unit.nc"), "--height-unit", "height_unit="),
    (("info", "no_lateral_unit.nc"), "give --unit", "unit="),
    (("info", "no_size.nc"), "give --size", "size="),
    (("info", "heights.npy"), "give --size and --unit", "size="),
    (("info", "matrix.txt"), "give --unit or --height-unit", "unit="),
    (("info", "matrix.txt", "--unit", "nm"), "give --size", "size="),
    (("info", "nonuniform.txt"), "give --unit", "unit="),
    (("acf", "nonuniform.txt", "--unit", "um"), "give --resample", "resample="),
    (("acf", "nonuniform.txt", "--unit", "um", "--size", "10 um"), "give --resample",
     "resample="),
    (("acf", "nonuniform.txt", "--unit", "um", "--resample", "--direction", "y"),
     "--direction 'x'", "direction="),
    (("acf", "matrix.txt", "--size", "5 um", "--unit", "um", "--points-per-decade", "0"),
     "--points-per-decade 0", "points_per_decade"),
    (("acf", "matrix.txt", "--size", "5 um", "--unit", "um", "--points-per-decade", "1001"),
     "--points-per-decade 1001", "points_per_decade"),
    (("info", "no_size.nc", "--channel", "0"), "--channel does not apply", "channel="),
    (("info", "matrix.txt", "--unit", "s"), "--unit must be a length", "unit="),
    (("info", "matrix.txt", "--height-unit", "kg"), "--height-unit must be a length",
     "height_unit"),
    (("info", "matrix.txt", "--unit", "um", "--size", "1 s"), "--size 1 s", "size="),
    (("info", "matrix.txt", "--unit", "um", "--size", "1,2,3"), "--size 1,2,3", "size="),
    (("info", "matrix.txt", "--unit", "um", "--size", "5"), "--size 5: the size has no unit",
     "size="),
]


@pytest.mark.parametrize("args, option, python_word", HINT_CASES)
def test_errors_name_the_option_to_give(unlabelled, monkeypatch, capsys, args, option,
                                        python_word):
    status, _, err = run(*args, "-o" if args[0] == "acf" else "--json",
                         *(["g.nc"] if args[0] == "acf" else []), cwd=unlabelled,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 1 and len(err.strip().splitlines()) == 1, err
    assert option in err and python_word not in err, err


def test_the_option_named_makes_the_file_read(unlabelled, monkeypatch, capsys):
    """What the error says to give is enough: the same files then read."""
    for args in (("no_height_unit.nc", "--height-unit", "nm"),
                 ("no_lateral_unit.nc", "--unit", "um"), ("no_size.nc", "--size", "8 um"),
                 ("heights.npy", "--size", "8 um", "--unit", "nm"),
                 ("matrix.txt", "--size", "8 um", "--unit", "nm")):
        status, out, err = run("info", *args, "--json", cwd=unlabelled,
                               monkeypatch=monkeypatch, capsys=capsys)
        assert status == 0, err
        assert json.loads(out)["files"][0]["shape"] == {"y": 16, "x": 16}


def test_a_file_is_read_once_whatever_it_lacks(unlabelled, monkeypatch, capsys):
    """What a file lacks comes with the reader's error (MissingOptionError names the
    keywords), so the command never reads a file again to find out; a corrupted file
    keeps the reader's own message."""
    reads = []
    real = xrough.toolbox.ensemble.open_topography  # the command opens via open_measurement
    monkeypatch.setattr(xrough.toolbox.ensemble, "open_topography",
                        lambda path, **kw: reads.append(kw) or real(path, **kw))
    lines = (unlabelled / "matrix.txt").read_text().splitlines()
    (unlabelled / "cut.txt").write_text("\n".join(lines[:8] + ["1.0 abc"] + lines[8:]))
    status, _, err = run("info", "cut.txt", cwd=unlabelled, monkeypatch=monkeypatch,
                         capsys=capsys)
    assert status == 1 and "cut.txt" in err and "give --" not in err
    assert len(reads) == 1
    reads.clear()
    status, _, err = run("info", "heights.npy", cwd=unlabelled, monkeypatch=monkeypatch,
                         capsys=capsys)
    assert status == 1 and "give --size and --unit" in err and len(reads) == 1


def test_missing_option_error_names_the_keywords_for_python_users(unlabelled):
    """The library's own message names open_topography's keywords; its attributes say
    which, for any front end."""
    with pytest.raises(xrough.io.MissingOptionError) as info:
        xrough.open_topography(unlabelled / "no_size.nc")
    assert info.value.options == ("size",) and "pass size=" in str(info.value)
    with pytest.raises(xrough.io.MissingOptionError) as info:
        xrough.open_topography(unlabelled / "matrix.txt")
    assert info.value.options == ("unit", "height_unit") and info.value.either
    assert "pass unit= or height_unit=" in str(info.value)


def test_detrend_is_said_in_the_words_asked_and_sticking_says_why(files, monkeypatch,
                                                                   capsys):
    """--detrend curvature on a profile is reported as curvature (it said 'parabola'); a
    gamma above the elastic energy of full contact gives no patch radius, and the table
    says why, with both numbers."""
    status, out, _ = run("report", "profile.nc", "--detrend", "curvature", "--E-star",
                         E_STAR, "--p0", P0, "--gamma", "100 J/m^2", "-o", "c.nc",
                         cwd=files, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0
    assert "detrend before G: curvature" in out and "parabola" not in out
    v_el = float(xrough.open_analysis(files / "c.nc")["profile"]["patch"].v_el)
    assert f"none: sticks everywhere (v_el {v_el:.3g} < gamma 100 J/m2)" in out


@pytest.mark.data
def test_report_says_each_cause_once(monkeypatch, capsys, tmp_path):
    """The notes of a fit reappear in the gradient and Persson theory that used it: the
    report prints each once, naming the results it concerns (it printed them three
    times, on dektak-1.csv)."""
    from conftest import data_path

    status, out, _ = run("report", data_path("instruments", "dektak-1.csv"), "--E-star",
                         E_STAR, "--p0", P0, "-o", "once.nc", cwd=tmp_path,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0
    causes = [line.strip() for line in out.splitlines() if line.startswith("    - ")]
    texts = [c.rsplit(" (", 1)[0] for c in causes]
    assert len(texts) == len(set(texts)), causes
    shared = [c for c in causes
              if c.endswith("(fit, rms gradient, Persson theory, mean gap)")]
    assert any(re.search(r"misses G by 1\d\.\d times in a bin", c) for c in shared), causes


@pytest.mark.data
def test_report_uses_the_stylus_the_file_states(monkeypatch, capsys, tmp_path):
    """dektak-1.csv states a 2.5 um stylus: report quotes a_r at 1.64 um, the first lag
    the stylus resolves (it quoted 156 nm); --all-lags keeps every lag."""
    from conftest import data_path

    path = data_path("instruments", "dektak-1.csv")
    status, out, _ = run("report", path, "--E-star", E_STAR, "--p0", P0, "-o", "a.nc",
                         cwd=tmp_path, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0
    row = table(out)[0]
    assert row["at dr"] == "1.641 µm", row
    assert xrough.open_analysis(tmp_path / "a.nc")["dektak-1"]["G"].attrs[
        "reliable_dr_min"] == pytest.approx(1.55, rel=0.02)
    status, out, _ = run("report", path, "--E-star", E_STAR, "--p0", P0, "--all-lags",
                         "-o", "b.nc", cwd=tmp_path, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0 and table(out)[0]["at dr"] == "156.2 nm"


@pytest.mark.parametrize("argv, what", [
    (["frobnicate"], "invalid choice: 'frobnicate'"),
    (["report", "x.nc"], "the following arguments are required: --E-star, --p0"),
    (["acf", "x.nc", "--points-per-decade"], "expected one argument"),
])
def test_usage_errors_take_two_lines(capsys, argv, what):
    """A usage error printed the whole usage (7-11 lines); now what is wrong and where the
    usage is."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and what in err[0] and err[1].endswith("--help)"), err


def test_report_of_a_folder_keeps_going_past_a_bad_file(files, monkeypatch, capsys,
                                                        tmp_path):
    """A folder stands for the measurement files in it; a file that does not read is a
    row that says why (table, CSV, JSON), the others are analysed and archived; the exit
    status is 0. One bad file alone still fails (status 1)."""
    folder = tmp_path / "scans"
    folder.mkdir()
    for name in ("afm.nc", "profile.nc", "broken.nc"):
        (folder / name).write_bytes((files / name).read_bytes())
    (folder / "notes.md").write_text("not a measurement")  # other extensions: skipped
    status, out, err = run("report", folder, "--E-star", E_STAR, "--p0", P0, "-o",
                           "set.nc", cwd=tmp_path, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0, err
    rows = {r["measurement"]: r for r in table(out)}
    assert set(rows) == {"afm", "profile", "broken"}
    assert rows["broken"]["sigma_h (fit)"] == "failed: see below"
    assert re.search(r"^  broken: .*broken\.nc", out, re.M)
    assert set(xrough.open_analysis(tmp_path / "set.nc")) - {"_provenance"} == {"afm",
                                                                             "profile"}
    with open(tmp_path / "set.csv", newline="") as f:
        csv_rows = {r["measurement"]: r for r in csv.DictReader(f)}
    assert csv_rows["afm"]["error"] == "" and "broken.nc" in csv_rows["broken"]["error"]
    assert csv_rows["afm"]["H"] == rows["afm"]["H"]
    status, out, _ = run("report", folder, "--E-star", E_STAR, "--p0", P0, "-o", "j.nc",
                         "--json", cwd=tmp_path, monkeypatch=monkeypatch, capsys=capsys)
    records = {r["name"]: r for r in json.loads(out)["measurements"]}
    assert status == 0 and "broken.nc" in records["broken"]["error"]
    status, _, err = run("report", folder / "broken.nc", "--E-star", E_STAR, "--p0", P0,
                         "-o", "b.nc", cwd=tmp_path, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 1 and "broken.nc" in err
    empty = tmp_path / "empty"
    empty.mkdir()
    status, _, err = run("report", empty, "--E-star", E_STAR, "--p0", P0, cwd=tmp_path,
                         monkeypatch=monkeypatch, capsys=capsys)
    assert status == 1 and "no measurement file" in err


def test_worker_processes_give_what_one_process_gives(files, monkeypatch, capsys,
                                                     tmp_path):
    """--jobs 2 measures the files in two fresh processes: the same table, CSV and
    archive, the rows in the order of the files, the bad file a row saying why; the acf
    command (no keep-going) fails with the first bad file in the order of the files."""
    folder = tmp_path / "scans"
    folder.mkdir()
    for name in ("afm.nc", "broken.nc", "profile.nc"):
        (folder / name).write_bytes((files / name).read_bytes())
    said = {}
    for jobs in ("1", "2"):
        status, out, err = run("report", folder, "--E-star", E_STAR, "--p0", P0, "-o",
                               f"j{jobs}.nc", "--jobs", jobs, cwd=tmp_path,
                               monkeypatch=monkeypatch, capsys=capsys)
        assert status == 0, err
        with open(tmp_path / f"j{jobs}.csv", newline="") as f:
            said[jobs] = (out.replace(f"j{jobs}.", "j."), list(csv.DictReader(f)))
    assert said["1"] == said["2"]
    assert [r["measurement"] for r in said["2"][1]] == ["afm", "profile", "broken"]
    one, two = (xrough.open_analysis(tmp_path / f"j{j}.nc") for j in "12")
    assert set(one) == set(two) and set(one) - {"_provenance"} == {"afm", "profile"}
    for name in ("afm", "profile"):
        for result in ("G", "fit", "persson"):
            xr.testing.assert_identical(one[name][result], two[name][result])
    (folder / "also_broken.nc").write_bytes(b"CDF\x01" + b"\x00" * 20)
    status, _, err = run("acf", *sorted(folder.iterdir()), "--jobs", "2", "-o", "g.nc",
                         cwd=tmp_path, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 1 and "also_broken.nc" in err and "/broken.nc" not in err, err


@pytest.mark.parametrize(("asked", "n_files", "stdin", "console", "expected"),
                         [(0, 3, False, True, 1), (0, 16, False, True, "cores"),
                          (0, 16, False, False, 1), (4, 2, False, False, 2),
                          (3, 10, False, True, 3), (2, 5, True, True, 1),
                          (1, 40, False, True, 1)])
def test_the_number_of_worker_processes(asked, n_files, stdin, console, expected,
                                        monkeypatch):
    """--jobs 0 (default): from the command line, one process per core from
    AUTO_JOBS_FILES files on, else one; a script calling main() gets one unless it asks;
    never more processes than files; standard input is read by the command itself."""
    import argparse

    import xrough.cli._files as files_module

    monkeypatch.setattr(files_module, "cores", lambda: 6)
    assert files_module.AUTO_JOBS_FILES == 16
    work = [(f"f{k}.nc", f"f{k}") for k in range(n_files)]
    if stdin:
        work[0] = ("-", "stdin")
    n = files_module.jobs(argparse.Namespace(jobs=asked, console=console), work)
    assert n == (6 if expected == "cores" else expected)


@pytest.mark.parametrize("given", ["-1", "two"])
def test_a_number_of_jobs_that_is_not_one_is_a_usage_error(given, files, monkeypatch,
                                                           capsys, tmp_path):
    """Refused by the option parser (status 2), before any output folder is made."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(["acf", str(files / "afm.nc"), "--jobs", given, "-o", "new/g.nc"])
    assert exc.value.code == 2 and "--jobs" in capsys.readouterr().err
    assert not (tmp_path / "new").exists()


def test_a_worker_that_dies_fails_its_file_only(files, tmp_path):
    """A worker process that dies (killed, out of memory, a crash in a library) breaks
    the pool: the files it had not returned are measured again one by one, and the file
    whose worker dies again is a failure naming it and --jobs 1; the others are as one
    by one."""
    from worker_crash import dies_on_the_profile

    from xrough.cli import parse
    from xrough.cli._common import CLIError
    from xrough.cli._files import measure_all

    names = ["afm.nc", "profile.nc", "long_header.nc", "stylus.nc"]
    args = parse(["acf", *[str(files / n) for n in names], "--jobs", "2",
                  "-o", str(tmp_path / "g.nc")])
    found = measure_all(args, dies_on_the_profile, keep_going=True)
    assert [m["name"] for m in found] == ["afm", "profile", "long_header", "stylus"]
    assert "error" in found[1] and "profile.nc" in found[1]["error"]
    assert "ended abruptly" in found[1]["error"] and "--jobs 1" in found[1]["error"]
    for m in (found[0], found[2], found[3]):
        assert "error" not in m and m["results"]["G"].sizes["dr"] > 5
        assert "topography" not in m and m["ndim"] == 2  # the maps are not kept
    with pytest.raises(CLIError, match="profile.nc"):
        measure_all(args, dies_on_the_profile, keep_going=False)


def test_report_of_a_container_takes_the_unit_its_meta_states(monkeypatch, capsys, tmp_path):
    """A contact.engineering container: the text profile states no unit, its meta.yml
    does; report of the folder reads it with that unit (alone it asks for --unit)."""
    x = np.arange(400) * 0.01
    np.savetxt(tmp_path / "line.txt", np.column_stack([x, 0.05 * np.sin(7 * x)
                                                       + 0.01 * np.cos(31 * x)]))
    (tmp_path / "meta.yml").write_text(
        "surfaces:\n- topographies:\n  - datafile: {original: line.txt}\n    unit: um\n")
    status, out, err = run("report", tmp_path, "--E-star", E_STAR, "--p0", P0, "-o",
                           "c.nc", cwd=tmp_path, monkeypatch=monkeypatch, capsys=capsys)
    assert status == 0, err
    assert table(out)[0]["measurement"] == "line"
    G = xrough.open_analysis(tmp_path / "c.nc")["line"]["G"]
    assert G.dr.attrs["units"] == "um"
