"""Averages over a set of measurements of one surface (mean_acf, G.rough.mean)."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
import xarray as xr

import xrough

MAP = dict(hurst=0.8, n=64, size="64 nm", rms_gradient=0.1, lambda_r="16 nm",
           lambda_s="2 nm")


def _maps(seeds, unit="nm", **over):
    kw = {**MAP, **over}
    if unit != "nm":
        f = {"um": 1e-3, "m": 1e-9}[unit]
        kw.update(size=f"{64 * f} {unit}", lambda_r=f"{16 * f} {unit}",
                  lambda_s=f"{2 * f} {unit}")
    return xr.concat([xrough.self_affine_surface(**kw, unit=unit, seed=s) for s in seeds],
                     dim="scan")


def test_mean_is_the_g_of_all_pairs():
    """The pair-weighted mean of per-map G equals acf(pool=) of the maps themselves (to
    1e-12), and its propagated error is the pooled G's where the maps agree."""
    maps = _maps(range(4))
    G = maps.rough.acf()
    mean = G.rough.mean("scan")
    pooled = maps.rough.acf(pool="scan")
    np.testing.assert_allclose(mean.values, pooled.values, rtol=1e-12)
    np.testing.assert_array_equal(mean.pair_count, pooled.pair_count)
    assert mean.attrs["pooled_count"] == pooled.attrs["pooled_count"] == 4
    assert mean.coords["height_variance"] == pytest.approx(float(pooled.height_variance),
                                                           rel=1e-12)
    # never below the propagated error (within 4 %: the pooled G has its own rounding of
    # the finite-area model), raised where the maps scatter more
    assert np.all(mean.standard_error >= 0.96 * pooled.standard_error)
    assert np.all(mean.error_inflation >= 1 - 1e-12)
    assert mean.attrs["averaged_over"] == "scan" and np.all(mean.n_measurements == 4)


def test_error_is_what_a_second_set_gives():
    """Six sets of three maps: the scatter of the sets' means about their average is what
    their stated standard error says (median ratio over lags 0.6-1.7; measured 0.80: the
    larger of the propagated error and the scatter of three maps errs on the safe side)."""
    G = _maps(range(18)).rough.acf()
    sets = [G.isel(scan=slice(3 * k, 3 * k + 3)).rough.mean("scan") for k in range(6)]
    means = xr.concat(sets, dim="set")
    scatter = means.std("set", ddof=1)
    stated = means.standard_error.mean("set")
    ratio = float((scatter / stated).median())
    assert 0.6 < ratio < 1.7, ratio


def test_mean_keeps_errors_for_the_fit_and_units():
    """The mean carries what a fit needs (weighted, rated); the same in um and m; a failed
    curve (all NaN) is left out; a wrong dim is named."""
    G = _maps(range(3)).rough.acf()
    mean = G.rough.mean("scan")
    fit = mean.rough.fit()
    assert fit.attrs.get("quality") in ("good", "questionable")
    assert np.isfinite(float(fit.hurst_std))
    plain = G.mean("scan")  # xarray's mean drops the error: the reason for this function
    assert "standard_error" not in plain.coords
    for unit, f in (("um", 1e-3), ("m", 1e-9)):
        other = _maps(range(3), unit=unit).rough.acf().rough.mean("scan")
        np.testing.assert_allclose(other.values, mean.values * f**2, rtol=1e-9)
        np.testing.assert_allclose(other.standard_error, mean.standard_error * f**2,
                                   rtol=1e-9)
    broken = G.copy()
    broken[1] = np.nan
    assert np.all(broken.rough.mean("scan").n_measurements == 2)
    np.testing.assert_allclose(broken.rough.mean("scan"),
                               G.isel(scan=[0, 2]).rough.mean("scan"), rtol=1e-12)
    with pytest.raises(ValueError, match="'y'"):
        G.rough.mean("y")


def test_dask_equals_numpy_and_archives(tmp_path):
    G = _maps(range(3)).rough.acf()
    eager = G.rough.mean("scan")
    lazy = G.chunk({"scan": 1}).rough.mean("scan")
    assert lazy.chunks is not None
    xr.testing.assert_allclose(lazy.compute(), eager, rtol=1e-12)
    path = tmp_path / "mean.nc"
    xrough.save_analysis(path, {"G": eager})
    xr.testing.assert_identical(xrough.open_analysis(path)["G"], eager)


def _folder(tmp_path, n_maps=3):
    for seed in range(n_maps):
        xrough.self_affine_surface(**{**MAP, "n": 128, "size": "128 nm"}, unit="nm",
                                   seed=seed).to_netcdf(tmp_path / f"scan{seed}.nc")
    (tmp_path / "broken.nc").write_bytes(b"CDF\x01" + bytes(20))
    (tmp_path / "README.md").write_text("not a measurement")
    return tmp_path


def test_open_set_keeps_going_and_tabulates(tmp_path):
    """A folder: every measurement file a node, a broken one a line of the root's
    ``failed`` and a failed row of the table; the table's numbers are each scan's own
    (Sq, H of the fit of its G), in one unit; one bad file never ends the batch."""
    folder = _folder(tmp_path)
    tree = xrough.open_set(folder, progress=False)
    assert sorted(tree.children) == ["scan0", "scan1", "scan2"]
    assert tree.attrs["failed"].startswith("broken: ") and tree.attrs["n_files"] == 4
    with pytest.warns(xrough.QualityWarning, match="of 4 measurements are not good"):
        table = xrough.analyse_set(tree, E_star="1 MPa", p0="1 kPa", progress=False)
    assert list(table.measurement.values) == ["scan0", "scan1", "scan2", "broken"]
    assert table.quality.sel(measurement="broken") == "failed"
    assert "broken.nc" in str(table.error.sel(measurement="broken").values)
    assert np.isnan(table.Sq.sel(measurement="broken")) and np.isnan(
        table.hurst.sel(measurement="broken"))
    topo = tree["scan1"].to_dataset()["heights"]
    clean = xrough.detrend(topo)
    assert float(table.Sq.sel(measurement="scan1")) == pytest.approx(
        float(clean.rough.parameters().Sq), rel=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        fit = clean.rough.acf().rough.fit()  # NaN where the fit fails, in the table too
    np.testing.assert_allclose(float(table.hurst.sel(measurement="scan1")),
                               float(fit.hurst), rtol=1e-9)
    assert np.all(table.a_r.sel(measurement=["scan0", "scan1", "scan2"]) > 0)
    assert table.Sq.attrs["units"] == "nm" and table.a_r_dr.attrs["units"] == "nm"
    # the stitched G of the set, and the table archives
    assert tree.rough.acf().attrs["stitched_from"] == "scan0, scan1, scan2"
    path = tmp_path / "table.nc"
    table.to_netcdf(path)
    xr.testing.assert_identical(xr.open_dataset(path).load(), table)
    with pytest.raises(ValueError, match="broken"):
        xrough.open_set(folder, keep_going=False, progress=False)


def test_analyse_set_rows_as_dask_tasks_in_one_unit(tmp_path):
    """The rows are dask tasks: the table is identical on the sync and threaded
    schedulers; a scan stored in um is converted to the first row's nm (its Sq and fitted
    lambda_r are those of the same scan in nm, to 1e-9)."""
    for seed in range(2):
        xrough.self_affine_surface(**{**MAP, "n": 128, "size": "128 nm"}, unit="nm",
                                   seed=seed).to_netcdf(tmp_path / f"scan{seed}.nc")
    same = xrough.self_affine_surface(**{**MAP, "n": 128, "size": "128 nm"}, unit="nm",
                                      seed=1)
    xrough.convert_units(same, "um", lateral="um").to_netcdf(tmp_path / "scan9_um.nc")
    tree = xrough.open_set(tmp_path, progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        sync = xrough.analyse_set(tree, E_star="1 MPa", p0="1 kPa", progress=False,
                                  scheduler="sync")
        threads = xrough.analyse_set(tree, E_star="1 MPa", p0="1 kPa", progress=False,
                                     scheduler="threads")
        plain = xrough.analyse_set(tree, progress=False, scheduler="sync")
    xr.testing.assert_identical(sync, threads)
    assert sync.Sq.attrs["units"] == "nm" and sync.lambda_r.attrs["units"] == "nm"
    for key in ("Sq", "lambda_r", "hurst", "a_r", "a_r_dr"):
        np.testing.assert_allclose(float(sync[key].sel(measurement="scan9_um")),
                                   float(sync[key].sel(measurement="scan1")), rtol=1e-9)
    assert "a_r" not in plain and np.all(np.isfinite(plain.Sq))


def test_container_supplies_what_a_file_lacks(tmp_path):
    """A contact.engineering container: meta.yml says which files and the unit a text
    profile does not state (the file alone does not read); a file it does not list is
    not opened."""
    x = np.arange(200) * 0.01
    np.savetxt(tmp_path / "line.txt", np.column_stack([x, np.sin(7 * x)]))
    xrough.self_affine_surface(**MAP, unit="nm", seed=1).to_netcdf(tmp_path / "map.nc")
    (tmp_path / "meta.yml").write_text(
        "surfaces:\n- topographies:\n"
        "  - datafile: {original: line.txt}\n    unit: um\n    size: !!python/tuple [1.99]\n")
    with pytest.raises(ValueError, match="unit"):
        xrough.open_topography(tmp_path / "line.txt")
    tree = xrough.open_set(tmp_path, progress=False)
    assert list(tree.children) == ["line"]
    line = tree["line"].to_dataset()["heights"]
    assert line.attrs["units"] == "um" and line.x.attrs["units"] == "um"
    assert tree.attrs["failed"] == ""


def test_mean_psd_of_instruments_in_other_units():
    """Three maps, two of them in um: the averaged PSD in nm is each bin's mode-weighted
    mean of the three converted spectra (to 1e-9), its error never below theirs
    propagated; a profile among them turns every map into its 1D spectrum along x."""
    maps = {f"s{k}": xrough.self_affine_surface(**{**MAP, "n": 128, "size": "128 nm"},
                                                unit="nm", seed=k) for k in range(3)}
    maps["s1"] = xrough.convert_units(maps["s1"], "um", lateral="um")
    maps["s2"] = xrough.convert_units(maps["s2"], "um", lateral="um")
    C = xrough.mean_psd(maps)
    assert C.attrs["units"] == "nm4" and C.q.attrs["units"] == "nm-1"
    own = [xrough.convert_units(m, "nm", lateral="nm").rough.psd() for m in maps.values()]
    np.testing.assert_allclose(C.q, own[0].q, rtol=1e-9)
    expected = sum(c.values * c.n_modes.values for c in own) / sum(c.n_modes.values
                                                                    for c in own)
    real = expected > 1e-12 * expected.max()  # beyond lambda_s: round-off of the FFT
    np.testing.assert_allclose(C.values[real], expected[real], rtol=1e-9)
    assert real.sum() > 20 and np.all(C.n_measurements == 3)
    propagated = np.sqrt(sum((c.standard_error * c.n_modes) ** 2 for c in own).values) / (
        sum(c.n_modes for c in own).values)
    assert np.all(C.standard_error.values[real] >= propagated[real] * (1 - 1e-9))
    line = maps["s0"].isel(y=0).drop_vars("y")
    mixed = xrough.mean_psd({"map": maps["s0"], "line": line})
    assert mixed.attrs["units"] == "nm3" and mixed.attrs["spectrum_kind"] == "1D along x"


@pytest.mark.parametrize("quantity", ["slope", "curvature"])
def test_mean_scale_dependent_of_instruments_in_other_units(quantity):
    """Three maps, one in um: the averaged scale-dependent slope (curvature) in nm is, in
    each log bin (``rint(10 log10 dr)``: steps 6 and 7 px share one), the count-weighted
    mean of the three converted curves' values (to 1e-9), its error their weighted
    scatter; the same map twice has zero scatter; in um it is the same physics (slope
    unchanged, curvature x 1000)."""
    maps = {f"s{k}": xrough.self_affine_surface(**{**MAP, "n": 128, "size": "128 nm"},
                                                unit="nm", seed=k) for k in range(3)}
    maps["s1"] = xrough.convert_units(maps["s1"], "um", lateral="um")
    mean = xrough.mean_scale_dependent(maps, quantity)
    analysis = getattr(xrough, f"scale_dependent_{quantity}")
    own = [analysis(xrough.convert_units(m, "nm", lateral="nm")) for m in maps.values()]
    count = "pair_count" if quantity == "slope" else "point_count"
    frame = pd.concat([pd.DataFrame({"scan": k, "dr": c.dr.values, "v": c.values,
                                     "w": c.coords[count].values.astype(float)})
                       for k, c in enumerate(own)])
    frame["bin"] = np.rint(10 * np.log10(frame.dr)).astype(int)
    frame["wv"], frame["wdr"] = frame.w * frame.v, frame.w * frame.dr
    per = frame.groupby(["bin", "scan"])[["w", "wv", "wdr"]].sum()
    per["v"] = per.wv / per.w
    w, v = per.w.unstack().values.T, per.v.unstack().values.T
    expected = (w * v).sum(axis=0) / w.sum(axis=0)
    dr = per.wdr.groupby("bin").sum() / per.w.groupby("bin").sum()
    np.testing.assert_allclose(mean.dr, dr.values, rtol=1e-9)
    assert mean.dr.size < own[0].dr.size  # steps merged: the test is not vacuous
    np.testing.assert_allclose(mean.values, expected, rtol=1e-9)
    n_eff = w.sum(axis=0) ** 2 / (w**2).sum(axis=0)
    scatter = np.sqrt((w * (v - expected) ** 2).sum(axis=0) / w.sum(axis=0) / (n_eff - 1))
    np.testing.assert_allclose(mean.standard_error, scatter, rtol=1e-9)
    assert np.all(mean.n_measurements == 3) and mean.name == quantity
    twice = xrough.mean_scale_dependent({"a": maps["s0"], "b": maps["s0"]}, quantity)
    np.testing.assert_allclose(twice.values, mean_of_one := xrough.mean_scale_dependent(
        {"a": maps["s0"]}, quantity).values, rtol=1e-12)
    np.testing.assert_allclose(twice.standard_error, 0.0, atol=1e-12 * float(own[0].max()))
    in_um = xrough.mean_scale_dependent(maps, quantity, unit="um")
    assert in_um.dr.attrs["units"] == "um"
    np.testing.assert_allclose(in_um.dr * 1e3, mean.dr, rtol=1e-12)
    np.testing.assert_allclose(in_um.values, mean.values * (1e3 if quantity == "curvature"
                                                            else 1.0), rtol=1e-12)
    one = xrough.mean_scale_dependent({"a": maps["s0"]}, quantity)
    assert np.all(np.isnan(one.standard_error)) and np.array_equal(one.values, mean_of_one)
    with pytest.raises(ValueError, match="quantity 'height'"):
        xrough.mean_scale_dependent(maps, "height")


@pytest.mark.data
def test_open_set_of_the_instruments_folder():
    """Every file of the real instruments folder is a node or a line of ``failed`` that
    says why (three text files state no unit); files only SurfaceTopography reads are in
    the listing when it is installed."""
    import importlib.util

    from conftest import data_path

    folder = data_path("instruments")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tree = xrough.open_set(folder, progress=False)
    failed = [line for line in tree.attrs["failed"].splitlines() if line]
    bridged = importlib.util.find_spec("SurfaceTopography") is not None
    assert len(tree.children) + len(failed) == (16 if bridged else 11)
    assert {"di-1", "x3p-2", "dektak-1"} <= set(tree.children)
    assert all("unit" in line for line in failed if line.startswith(("xy-1", "xyz-1")))


@pytest.mark.data
def test_open_set_of_a_contact_engineering_container():
    """The UNCD demo container: its meta.yml names the three files and the unit the two
    text profiles lack; the TEM profile, sampled non-uniformly, is resampled onto as many
    uniform points and says so; the averaged PSD of the three covers seven decades."""
    from conftest import data_path

    folder = data_path("uncd")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tree = xrough.open_set(folder, progress=False)
        C = xrough.mean_psd({n: xrough.detrend(tree[n].to_dataset()["heights"])
                             for n in tree.children}, unit="um")
    assert len(tree.children) == 3 and tree.attrs["failed"] == ""
    tem = tree["80_Scale10.472_FIXEDv2p1_D7eHXiT"].to_dataset()["heights"]
    assert tem.attrs["sampling"] == "resampled" and tem.x.attrs["units"] == "nm"
    stylus = tree["uncd_stylus_300um_5mar_3_k0HpKJt"].to_dataset()["heights"]
    assert stylus.x.attrs["units"] == "mm"
    assert C.attrs["spectrum_kind"] == "1D along x"
    assert float(C.q.max() / C.q.min()) > 1e5 and int(C.n_measurements.max()) >= 2
