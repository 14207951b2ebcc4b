"""One call archives a whole analysis; reopening gives identical objects, and nothing is lost.

Every result type round-trips identical (a test per type); attributes of every type the
archive accepts round-trip with their Python type (a property test); a failed save leaves
the previous file untouched; any measurement name is kept. The round trips run for both
storage formats, a NetCDF file and a Zarr store; a stack of scans reopens lazily from Zarr
with its chunks.
"""

import importlib.util
import json
import os
import sys
import unicodedata
import warnings

import dask.array as da
import netCDF4
import numpy as np
import pytest
import xarray as xr
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import xrough
from xrough.io import archive
from xrough.io.archive import PROVENANCE_KEY, safe_name


def _analysis():
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="100 nm",
                                      size="8 um", n=256, rms_gradient=0.5, seed=1,
                                      unit="nm")
    G = topo.rough.acf()
    return {
        "topography": topo,
        "G": G,
        "fit": G.rough.fit(),
        "persson": G.rough.persson(E_star="25 MPa", p0=[1e5, 1e6]),
        "energy": G.rough.energy(E_star="25 MPa"),
        "patch": G.rough.patch_radius(E_star="25 MPa", gamma="50 mJ/m^2"),
    }


#: The storage formats, by the archive's suffix; Zarr needs the optional zarr package.
SUFFIXES = [".nc", pytest.param(".zarr", marks=pytest.mark.skipif(
    importlib.util.find_spec("zarr") is None, reason="zarr not installed (xrough[zarr])"))]


def _round_trip(tmp_path, obj, name="x", suffix=".nc"):
    path = xrough.save_analysis(tmp_path / f"{abs(hash(name))}{suffix}", {name: obj})
    return xrough.open_analysis(path)[name]


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_round_trip_of_several_measurements(tmp_path, suffix):
    one = _analysis()
    other = {"G": one["G"] * 2}
    other["G"].attrs = one["G"].attrs
    path = xrough.save_analysis(tmp_path / f"a{suffix}", {"afm": one, "stylus": other},
                                history="xrough report afm.x3p")
    back = xrough.open_analysis(path)
    for key, value in one.items():
        assert type(back["afm"][key]) is type(value)
        xr.testing.assert_identical(back["afm"][key], value)
    xr.testing.assert_identical(back["stylus"]["G"], other["G"])
    prov = back["_provenance"]
    assert prov["xrough_version"] == xrough.__version__
    assert prov["Conventions"].startswith("CF")
    assert "xrough report afm.x3p" in prov["history"]
    # units travel with every variable
    assert back["afm"]["persson"]["sigma_c"].attrs["units"] == "Pa"
    assert back["afm"]["energy"]["v_el"].attrs["units"] == "J m-2"


def test_flat_analysis_and_bad_entries(tmp_path):
    topo = xrough.topography(np.zeros((4, 4)), spacing=1.0, unit="nm")
    back = xrough.open_analysis(xrough.save_analysis(tmp_path / "b.nc", {"topo": topo}))
    xr.testing.assert_identical(back["topo"], topo)
    with pytest.raises(TypeError, match="can only archive"):
        xrough.save_analysis(tmp_path / "c.nc", {"x": 3})
    assert not (tmp_path / "c.nc").exists()


# --- every result type ----------------------------------------------------------------


def _results():
    """Every kind of result xrough produces, by name (small, built once per module)."""
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="100 nm",
                                      size="8 um", n=256, rms_gradient=0.5, seed=1,
                                      unit="nm")
    G = topo.rough.acf()
    profile = xrough.self_affine_surface(hurst=0.7, lambda_r="2 um", lambda_s="20 nm",
                                         size="8 um", n=1024, rms_height="10 nm",
                                         profile=True, seed=3, unit="nm")
    fine = profile.isel(x=slice(0, 256)).assign_attrs(periodic=0)
    coarse = profile.isel(x=slice(None, None, 4))
    curves = xrough.stitch_curves({"fine": fine, "coarse": coarse})
    small = xrough.self_affine_surface(hurst=0.8, lambda_r="1 um", lambda_s="200 nm",
                                       size="2 um", n=32, rms_gradient=0.3, seed=2,
                                       unit="nm")
    open_map = topo.assign_attrs(periodic=0).chunk({"y": 128, "x": 128})
    out = {
        "topography": topo,
        "profile": profile,
        "G_fft": G,
        "G_random": topo.rough.acf(estimator="random", seed=1),
        "G_tiled": open_map.rough.acf(estimator="tiled").compute(),
        "stitch_curves": curves,
        "G_stitched": xrough.stitch(curves, warn=False),
        "fit_spectrum": G.rough.fit(),
        "fit_eq36": G.rough.fit(model="eq36"),
        "spectrum": G.rough.spectrum(),
        "persson_one_p0": G.rough.persson(E_star="25 MPa", p0="0.1 MPa"),
        "persson_p0s": G.rough.persson(E_star="25 MPa", p0=[1e5, 1e6]),
        "energy": G.rough.energy(E_star="25 MPa"),
        "patch_radius": G.rough.patch_radius(E_star="25 MPa", gamma="50 mJ/m^2"),
        "stress_acf": G.rough.stress_acf(E_star="25 MPa"),
        "stress_acf_p0": G.rough.stress_acf(E_star="25 MPa", p0="0.1 MPa"),
        "solve_contact": xrough.solve_contact(small, E_star="25 MPa", p0=[1e6, 2e6]),
        "compare_with_simulation": xrough.compare_with_simulation(small, E_star="25 MPa",
                                                                  p0=[2e6]),
    }
    for method in ("auto", "exact", "simple", "fit"):
        out[f"gradient_{method}"] = G.rough.gradient(method=method)
    # several curves: auto picks a route per curve and says so in a flagged coordinate
    scans = xr.concat([G, xrough.model_acf(G.rough.fit(), G.dr)
                       .assign_coords(standard_error=G.standard_error)
                       .assign_attrs(G.attrs)], dim="scan")
    out["gradient_auto_scans"] = scans.rough.gradient()
    return out


RESULTS = None


@pytest.fixture(scope="module")
def results():
    global RESULTS
    if RESULTS is None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            RESULTS = _results()
    return RESULTS


RESULT_NAMES = ["topography", "profile", "G_fft", "G_random", "G_tiled", "stitch_curves",
                "G_stitched", "fit_spectrum", "fit_eq36", "spectrum", "persson_one_p0",
                "persson_p0s", "energy", "patch_radius", "stress_acf", "stress_acf_p0",
                "solve_contact", "compare_with_simulation", "gradient_auto",
                "gradient_exact", "gradient_simple", "gradient_fit", "gradient_auto_scans"]


@pytest.mark.parametrize("suffix", SUFFIXES)
@pytest.mark.parametrize("name", RESULT_NAMES)
def test_every_result_type_round_trips_identical(tmp_path, results, name, suffix):
    obj = results[name]
    back = _round_trip(tmp_path, obj, name, suffix)
    assert type(back) is type(obj)
    xr.testing.assert_identical(back, obj)


def _group_alone(archive_path, group, target):
    """Copy one group of an archive, as stored (no decoding), into a file of its own,
    with the root's global attributes (``Conventions``...), as a tool would see it."""
    with netCDF4.Dataset(archive_path) as nc, netCDF4.Dataset(target, "w") as out:
        out.setncatts({k: nc.getncattr(k) for k in nc.ncattrs()})
        source = nc[group]
        out.setncatts({k: source.getncattr(k) for k in source.ncattrs()})
        for name, dim in source.dimensions.items():
            out.createDimension(name, None if dim.isunlimited() else len(dim))
        for name, var in source.variables.items():
            var.set_auto_maskandscale(False)
            fill = var.getncattr("_FillValue") if "_FillValue" in var.ncattrs() else False
            copy = out.createVariable(name, var.datatype, var.dimensions, fill_value=fill)
            copy.set_auto_maskandscale(False)
            copy.setncatts({k: var.getncattr(k) for k in var.ncattrs() if k != "_FillValue"})
            copy[...] = var[...]
    return target


#: What compliance-checker still says of single groups (medium priority): the order of
#: the results' dimensions, ``(p0, dr)``, which it reads as (Z, X) because ``p0`` is a
#: pressure, a vertical coordinate in CF; not about how the archive stores them.
CF_RECOMMENDATIONS = ("spatio-temporal dimensions are not in the recommended order",)


@pytest.mark.parametrize("name", RESULT_NAMES)
def test_every_group_is_cf_alone(tmp_path, results, name):
    """compliance-checker reads the root group only: each group, copied into a file of its
    own, passes CF 1.10 too: no _FillValue on coordinate variables (12 of the result types
    had one), no strings as coordinate variables (the fit's cov_i, cov_j: stored as labels
    on an index dimension); the archive still reopens identical."""
    pytest.importorskip("compliance_checker")
    from compliance_checker.runner import CheckSuite, ComplianceChecker

    path = xrough.save_analysis(tmp_path / "a.nc", {name: results[name]})
    xr.testing.assert_identical(xrough.open_analysis(path)[name], results[name])
    alone = _group_alone(path, name, tmp_path / "alone.nc")
    with xr.open_dataset(alone) as plain:
        assert not [v for v in plain.variables if plain[v].dims == (v,)
                    and plain[v].dtype.kind in "USO"], "a string coordinate variable"
    report = tmp_path / "report.json"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        CheckSuite.load_all_available_checkers()
        if "cf:1.10" not in CheckSuite.checkers:
            pytest.skip("compliance-checker without CF 1.10")
        _, errors = ComplianceChecker.run_checker(str(alone), ["cf:1.10"], 0, "normal",
                                                  output_filename=str(report),
                                                  output_format="json")
    assert not errors, "compliance-checker failed on the file (a string coordinate?)"
    checked = json.loads(report.read_text())["cf:1.10"]
    messages = [m for level in ("high_priorities", "medium_priorities")
                for result in checked[level] for m in result["msgs"]]
    assert [m for m in messages if not any(r in m for r in CF_RECOMMENDATIONS)] == []


@pytest.mark.parametrize("name", RESULT_NAMES)
def test_every_coordinate_says_what_it_is(results, name):
    """Every numeric coordinate of every result type has ``units`` (or is a flag or a
    count) and a ``long_name``: with newer xarray, ``keep_attrs=False`` drops the attrs of
    coordinates too, and stress_acf's ``dr``, persson's scalar ``p0`` and the fits'
    ``height_variance`` came out without units."""
    result = results[name]
    bare = [c for c, v in result.coords.items()
            if v.dtype.kind in "fiu" and not {"units", "long_name"} <= set(v.attrs)
            and not ({"flag_values", "flag_masks"} & set(v.attrs))]
    assert bare == []


def test_string_coordinates_become_labels_and_come_back(tmp_path):
    """A string coordinate variable is stored as ``<dim>_label`` (another name if that one
    is taken) on a dimension without coordinate variable, and reopens as it was."""
    ds = xr.Dataset({"v": (("c", "d"), np.ones((2, 3))), "c_label": ("c", [1, 2])},
                    coords={"c": ("c", ["a", "b"], {"long_name": "case"}),
                            "d": ["x", "y", "z"]})
    for suffix in (".nc", ".zarr") if importlib.util.find_spec("zarr") else (".nc",):
        path = xrough.save_analysis(tmp_path / f"a{suffix}", {"ds": ds})
        xr.testing.assert_identical(xrough.open_analysis(path)["ds"], ds)
    with xr.open_dataset(tmp_path / "a.nc", group="ds") as plain:
        assert {"c", "d"}.isdisjoint(plain.variables)
        assert plain["c_label_2"].attrs["long_name"] == "case"
        assert plain["d_label"].values.tolist() == ["x", "y", "z"]
        assert plain["c_label"].values.tolist() == [1, 2]


def test_result_list_is_complete(results):
    assert sorted(results) == sorted(RESULT_NAMES)
    assert "gradient_method" in results["gradient_auto_scans"].coords


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_stitched_one_element_array_attrs_stay_arrays(tmp_path, results, suffix):
    """Regression: 1-element array attrs (mismatch_ratio...) came back as scalars."""
    G = results["G_stitched"]
    arrays = [k for k, v in G.attrs.items() if isinstance(v, np.ndarray) and v.size == 1]
    assert arrays, "the example should have a 1-element array attr"
    back = _round_trip(tmp_path, G, suffix=suffix)
    for key in arrays:
        assert isinstance(back.attrs[key], np.ndarray) and back.attrs[key].shape == (1,)


# --- attributes: property test ----------------------------------------------------------

_finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
_text = st.text(st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=12)
_json = st.recursive(st.none() | st.booleans() | st.integers(-2**70, 2**70) | _finite
                     | _text,
                     lambda inner: st.lists(inner, max_size=3)
                     | st.dictionaries(_text, inner, max_size=3), max_leaves=6)
_dtypes = st.sampled_from(["i1", "i4", "i8", "u2", "u8", "f4", "f8", "?"])
_arrays = st.builds(
    lambda dtype, shape, seed: np.random.default_rng(seed).integers(0, 50, size=shape)
    .astype(dtype),
    _dtypes, st.lists(st.integers(0, 3), min_size=0, max_size=3).map(tuple),
    st.integers(0, 2**16))
_values = st.one_of(
    st.booleans(), st.none(), st.integers(-2**63, 2**63 - 1), _finite, _text,
    st.binary(max_size=8), _arrays,
    st.lists(st.integers(-2**60, 2**60), min_size=1, max_size=4),
    st.lists(_finite, min_size=1, max_size=4).map(tuple),
    st.lists(_text, max_size=3), st.dictionaries(_text, _json, max_size=3),
    st.sampled_from([np.float32(1.5), np.int16(-3), np.uint8(7), np.bool_(True)]))
_names = st.from_regex(r"[A-Za-z][A-Za-z0-9_]{0,8}", fullmatch=True).filter(
    lambda s: not s.startswith("xrough") and s not in ("units", "calendar"))


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture,
                                 HealthCheck.too_slow])
@pytest.mark.parametrize("suffix", SUFFIXES)
@given(attrs=st.dictionaries(_names, _values, max_size=5),
       coord_attrs=st.dictionaries(_names, _values, max_size=3))
def test_attrs_of_every_type_round_trip(tmp_path, suffix, attrs, coord_attrs):
    da = xr.DataArray(np.arange(3.0), dims="dr", name="G", attrs=attrs,
                      coords={"dr": ("dr", [1.0, 2.0, 3.0], coord_attrs)})
    ds = xr.Dataset({"a": da}, attrs=attrs)
    for obj in (da, ds):
        back = _round_trip(tmp_path, obj, suffix=suffix)
        xr.testing.assert_identical(back, obj)
        for key, value in attrs.items():
            assert type(back.attrs[key]) is type(value) or (
                isinstance(value, (np.generic, int, float, bool))
                and np.asarray(back.attrs[key]).dtype == np.asarray(value).dtype
            ) or isinstance(value, (int, float)), (key, value, back.attrs[key])
            if isinstance(value, np.ndarray):
                assert back.attrs[key].shape == value.shape
                assert back.attrs[key].dtype == value.dtype


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_bool_and_none_attrs_round_trip(tmp_path, suffix):
    """Regression: a boolean attr made the save fail (and destroyed the previous file)."""
    topo = xrough.topography(np.ones((4, 4)), spacing=1.0, unit="nm")
    topo.attrs.update(flag=True, off=np.False_, missing=None, meta={"a": [1, 2]},
                      one=np.array([2.5]), pair=(1, 2))
    back = _round_trip(tmp_path, topo, suffix=suffix)
    xr.testing.assert_identical(back, topo)
    assert back.attrs["flag"] is True and back.attrs["off"] is False
    assert back.attrs["missing"] is None and back.attrs["pair"] == (1, 2)


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_numpy_types_and_non_finite_attrs_round_trip(tmp_path, suffix):
    """Zarr's attributes are JSON: numpy scalars and arrays keep their dtype all the same."""
    G = xr.DataArray([1.0, 2.0], dims="dr", name="G", coords={"dr": [1.0, 2.0]})
    G.attrs.update(f4=np.float32(1.5), i2=np.int16(-3), u8=np.uint64(2**64 - 1),
                   nan=float("nan"), inf=-np.inf, f4_inf=np.float32("inf"),
                   pair=np.array([np.nan, 1.0], dtype="f4"), ints=np.arange(3, dtype="u2"))
    back = _round_trip(tmp_path, G, suffix=suffix)
    xr.testing.assert_identical(back, G)
    for key, value in G.attrs.items():  # (NetCDF gives Python floats back as np.float64)
        assert type(back.attrs[key]) is type(value) or type(value) is float, key
        assert np.asarray(back.attrs[key]).dtype == np.asarray(value).dtype, key


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_unnamed_dataarray_and_names_clashing_with_coordinates(tmp_path, suffix):
    da = xr.DataArray([1.0, 2.0], dims="dr", coords={"dr": [1.0, 2.0]})
    back = _round_trip(tmp_path, da, suffix=suffix)
    assert back.name is None
    xr.testing.assert_identical(back, da)
    named = da.rename("dr_values").rename({"dr": "dr"})
    xr.testing.assert_identical(_round_trip(tmp_path, named, "n", suffix), named)
    odd = da.rename("(G)")
    xr.testing.assert_identical(_round_trip(tmp_path, odd, "o", suffix), odd)


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_empty_and_nested_mappings_round_trip(tmp_path, suffix):
    G = xr.DataArray([1.0], dims="dr", name="G", coords={"dr": [1.0]})
    analysis = {"empty": {}, "a": {"b": {"c": G}}}
    back = xrough.open_analysis(xrough.save_analysis(tmp_path / f"n{suffix}", analysis))
    assert back["empty"] == {}
    xr.testing.assert_identical(back["a"]["b"]["c"], G)


# --- atomic writes ------------------------------------------------------------------------


def _contents(directory):
    return sorted(p.name for p in directory.iterdir())


def _snapshot(path):
    """The bytes of a file, or of every file of a store by its relative path."""
    if path.is_file():
        return path.read_bytes()
    return {str(f.relative_to(path)): f.read_bytes() for f in sorted(path.rglob("*"))
            if f.is_file()}


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_refused_attr_names_object_and_attr_and_keeps_previous_file(tmp_path, suffix):
    """Regression: a failed save destroyed the archive at that path."""
    good = _analysis()
    path = xrough.save_analysis(tmp_path / f"a{suffix}", {"afm": good})
    before = _snapshot(path)
    bad = good["topography"].copy()
    bad.attrs["when"] = complex(1, 2)
    with pytest.raises(ValueError, match=r"afm/topography.*'when'"):
        xrough.save_analysis(path, {"afm": {**good, "topography": bad}})
    assert _snapshot(path) == before
    assert _contents(tmp_path) == [f"a{suffix}"]
    coord = good["G"].copy()
    coord["dr"].attrs["origin"] = object()
    with pytest.raises(ValueError, match=r"afm/G \(variable 'dr'\).*'origin'"):
        xrough.save_analysis(path, {"afm": {"G": coord}})
    with pytest.raises(ValueError, match="non-string dict key"):
        xrough.save_analysis(path, {"x": good["G"].assign_attrs(table={1: 2})})
    with pytest.raises(ValueError, match="variable name"):
        xrough.save_analysis(path, {"x": xr.Dataset({"-v": ("t", [1.0])})})
    back = xrough.open_analysis(path)
    for key, value in good.items():
        xr.testing.assert_identical(back["afm"][key], value)


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_failure_while_writing_keeps_previous_file(tmp_path, monkeypatch, suffix):
    path = tmp_path / f"a{suffix}"
    G = _analysis()["G"]
    xrough.save_analysis(path, {"G": G})
    before = _snapshot(path)
    method = "to_zarr" if suffix == ".zarr" else "to_netcdf"
    real = getattr(xr.DataTree, method)

    def broken(self, target, *args, **kwargs):
        real(self, target, *args, **kwargs)  # a file on disk, then the failure
        raise RuntimeError("disk hiccup")

    monkeypatch.setattr(xr.DataTree, method, broken)
    with pytest.raises(ValueError, match="previous file at this path is unchanged"):
        xrough.save_analysis(path, {"G": G * 2})
    assert _snapshot(path) == before
    assert _contents(tmp_path) == [f"a{suffix}"]


def test_missing_directory_and_directory_target(tmp_path):
    G = xr.DataArray([1.0], dims="dr", name="G", coords={"dr": [1.0]})
    with pytest.raises(FileNotFoundError, match="does not exist"):
        xrough.save_analysis(tmp_path / "missing" / "a.nc", {"G": G})
    with pytest.raises(IsADirectoryError):
        xrough.save_analysis(tmp_path, {"G": G})
    assert _contents(tmp_path) == []


def test_file_permissions_follow_umask(tmp_path):
    G = xr.DataArray([1.0], dims="dr", name="G", coords={"dr": [1.0]})
    path = xrough.save_analysis(tmp_path / "a.nc", {"G": G})
    umask = os.umask(0o022)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask


# --- names ----------------------------------------------------------------------------------


def test_safe_name():
    assert safe_name("(1).sur") == "_(1).sur"
    assert safe_name("-scan") == "_-scan"
    assert safe_name(".hidden") == "_.hidden"
    assert safe_name("a/b") == "a_b"
    assert safe_name("") == "_"
    assert safe_name("scan ") == "scan_"
    assert safe_name("tab\there") == "tab_here"
    assert safe_name("ok(1) µm") == "ok(1) µm"
    assert safe_name(3) == "3"
    assert safe_name(PROVENANCE_KEY) == "_provenance_2"
    assert safe_name("scan", taken=["scan", "scan_2"]) == "scan_3"
    decomposed = unicodedata.normalize("NFD", "é")
    assert safe_name(decomposed) == "é"
    first = safe_name("é" * 300)
    assert len(first.encode()) <= 255
    second = safe_name("é" * 300, taken=[first])
    assert len(second.encode()) <= 255 and second.endswith("_2")


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_any_measurement_name_is_kept(tmp_path, suffix):
    """Regression: forbidden characters broke the save; colliding names lost a result."""
    G = xr.DataArray([1.0, 2.0], dims="dr", name="G", coords={"dr": [1.0, 2.0]})
    names = ["(1).sur", "_(1).sur", "-x", ".x", "a/b", "a_b", "", "é",
             unicodedata.normalize("NFD", "é"), "trailing ", "x" * 300]
    analysis = {name: {"G": G * k} for k, name in enumerate(names, start=1)}
    analysis["flat(2)"] = G
    back = xrough.open_analysis(xrough.save_analysis(tmp_path / f"n{suffix}", analysis))
    assert set(back) == {*names, "flat(2)", PROVENANCE_KEY}
    for k, name in enumerate(names, start=1):
        xr.testing.assert_identical(back[name]["G"], G * k)
    xr.testing.assert_identical(back["flat(2)"], G)


def test_provenance_key_is_reserved(tmp_path):
    """Regression: a measurement named _provenance overwrote the provenance."""
    G = xr.DataArray([1.0], dims="dr", name="G", coords={"dr": [1.0]})
    with pytest.raises(ValueError, match="reserved"):
        xrough.save_analysis(tmp_path / "p.nc", {PROVENANCE_KEY: {"G": G}})
    assert not (tmp_path / "p.nc").exists()
    nested = {"afm": {PROVENANCE_KEY: G}}
    back = xrough.open_analysis(xrough.save_analysis(tmp_path / "p.nc", nested))
    xr.testing.assert_identical(back["afm"][PROVENANCE_KEY], G)
    assert back[PROVENANCE_KEY]["xrough_version"] == xrough.__version__


def test_names_equal_as_strings_are_refused(tmp_path):
    G = xr.DataArray([1.0], dims="dr", name="G", coords={"dr": [1.0]})
    with pytest.raises(ValueError, match="same name"):
        xrough.save_analysis(tmp_path / "s.nc", {1: G, "1": G})


def test_public_helpers():
    assert "safe_name" in archive.__all__


# --- Zarr stores: format, lazy stacks, bad stores -------------------------------------------


def test_format_is_chosen_by_suffix_or_argument(tmp_path):
    pytest.importorskip("zarr")
    G = xr.DataArray([1.0, 2.0], dims="dr", name="G", coords={"dr": [1.0, 2.0]})
    store = xrough.save_analysis(tmp_path / "a.ZARR", {"G": G})
    assert store.is_dir() and (store / ".zgroup").is_file()
    other = xrough.save_analysis(tmp_path / "b", {"G": G}, format="zarr")
    assert other.is_dir()
    again = xrough.save_analysis(other, {"G": G * 2})  # an existing store stays Zarr
    assert again.is_dir()
    plain = xrough.save_analysis(tmp_path / "c.zarr", {"G": G}, format="netcdf")
    assert plain.is_file()
    for path in (store, other, plain):  # a directory is Zarr, a file NetCDF
        xr.testing.assert_identical(xrough.open_analysis(path)["G"],
                                    G * 2 if path == other else G)
    with pytest.raises(ValueError, match="'netcdf' or 'zarr'"):
        xrough.save_analysis(tmp_path / "d.zarr", {"G": G}, format="hdf")
    with pytest.raises(ValueError, match=r"c\.zarr: not a Zarr store"):
        xrough.open_analysis(plain, format="zarr")
    assert _contents(tmp_path) == ["a.ZARR", "b", "c.zarr"]


def _stack(n_scans=4, n=64):
    scans = [xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="500 nm",
                                        size="4 um", n=n, rms_gradient=0.5, seed=s,
                                        unit="nm") for s in range(n_scans)]
    return xr.concat(scans, dim="scan")


@pytest.mark.parametrize(("suffix", "chunks"), [
    pytest.param(".zarr", {}, id="zarr-store-chunks"),
    pytest.param(".nc", {"scan": 1}, id="netcdf-chunks-given")])
def test_stack_reopens_lazily_with_its_chunks(tmp_path, suffix, chunks):
    """A stack of scans, one per chunk, reopens as dask with the same chunks; G from it."""
    if suffix == ".zarr":
        pytest.importorskip("zarr")
    stack = _stack()
    lazy_in = stack.chunk({"scan": 1})
    path = xrough.save_analysis(tmp_path / f"s{suffix}", {"scans": lazy_in})
    back = xrough.open_analysis(path, chunks=chunks)["scans"]
    assert isinstance(back.data, da.Array)
    assert back.chunks == lazy_in.chunks == ((1, 1, 1, 1), (64,), (64,))
    xr.testing.assert_identical(back, stack)
    G_lazy = back.rough.acf(pool="scan")
    assert isinstance(G_lazy.data, da.Array)
    G = G_lazy.compute()
    expected = stack.rough.acf(pool="scan")
    xr.testing.assert_allclose(G, expected, rtol=1e-12, atol=0)
    assert G.attrs == expected.attrs


def test_zarr_stack_is_read_when_computed_not_at_open(tmp_path):
    zarr = pytest.importorskip("zarr")
    stack = _stack(n_scans=2, n=32).chunk({"scan": 1})
    store = xrough.save_analysis(tmp_path / "s.zarr", {"scans": stack})
    back = xrough.open_analysis(store, chunks={})["scans"]
    zarr.open_array(store / "scans" / back.name, mode="r+")[0] = 0.0  # after the open
    assert float(abs(back.isel(scan=0)).max()) == 0.0
    np.testing.assert_array_equal(back.isel(scan=1).values, stack.isel(scan=1).values)


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_lazy_results_are_computed_once_while_written(tmp_path, suffix):
    """Every chunk of the input is computed once, for the stack and all results from it."""
    stack = _stack(n_scans=3, n=32).chunk({"scan": 1})
    calls = []

    def spy(block):
        calls.append(block.shape)
        return block

    counted = stack.copy(data=stack.data.map_blocks(spy, meta=np.array((), stack.dtype)))
    results = {"scans": counted, "G": counted.rough.acf(),
               "pooled": counted.rough.acf(pool="scan")}
    assert isinstance(results["G"].data, da.Array) and not calls
    path = xrough.save_analysis(tmp_path / f"r{suffix}", results)
    assert len(calls) == 3
    back = xrough.open_analysis(path)
    xr.testing.assert_allclose(back["pooled"], stack.rough.acf(pool="scan"),
                               rtol=1e-12, atol=0)
    xr.testing.assert_identical(back["scans"], stack)


def test_bad_stores_are_refused_naming_the_path(tmp_path):
    pytest.importorskip("zarr")
    with pytest.raises(FileNotFoundError, match="missing.zarr"):
        xrough.open_analysis(tmp_path / "missing.zarr")
    with pytest.raises(FileNotFoundError, match="missing.nc"):
        xrough.open_analysis(tmp_path / "missing.nc")
    (tmp_path / "plain").mkdir()
    with pytest.raises(ValueError, match="plain: not a Zarr store"):
        xrough.open_analysis(tmp_path / "plain")
    (tmp_path / "junk.nc").write_bytes(b"not a netcdf file at all")
    with pytest.raises(ValueError, match="junk.nc: cannot read as an xrough archive"):
        xrough.open_analysis(tmp_path / "junk.nc")
    stack = _stack(n_scans=2, n=32).chunk({"scan": 1})

    def store(name):
        return xrough.save_analysis(tmp_path / name, {"scans": stack})

    meta = store("meta.zarr")
    (meta / ".zmetadata").write_text("{not json")
    with pytest.raises(ValueError, match="meta.zarr: corrupted Zarr store"):
        xrough.open_analysis(meta)
    lost = store("lost.zarr")
    chunk = next(p for p in (lost / "scans").rglob("1.0.0"))
    chunk.unlink()  # a chunk lost in a copy would read as missing values
    with pytest.raises(ValueError, match=r"lost.zarr: incomplete Zarr store.*1 of 2"):
        xrough.open_analysis(lost, chunks={})
    garbled = store("garbled.zarr")
    next(p for p in (garbled / "scans").rglob("1.0.0")).write_bytes(b"garbage")
    with pytest.raises(ValueError, match="garbled.zarr: corrupted data in variable 'height' "
                                         "of group '/scans'"):
        xrough.open_analysis(garbled)


def test_open_topography_points_a_store_to_open_analysis(tmp_path):
    pytest.importorskip("zarr")
    G = xr.DataArray([1.0], dims="dr", name="G", coords={"dr": [1.0]})
    store = xrough.save_analysis(tmp_path / "a.zarr", {"G": G})
    with pytest.raises(IsADirectoryError, match="a.zarr: .*xrough.open_analysis"):
        xrough.open_topography(store)


def test_zarr_never_replaces_what_is_not_a_store(tmp_path):
    pytest.importorskip("zarr")
    G = xr.DataArray([1.0], dims="dr", name="G", coords={"dr": [1.0]})
    folder = tmp_path / "data.zarr"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="not a Zarr store"):
        xrough.save_analysis(folder, {"G": G})
    (tmp_path / "file.zarr").write_text("mine")
    with pytest.raises(FileExistsError, match="not a Zarr store"):
        xrough.save_analysis(tmp_path / "file.zarr", {"G": G})
    assert (folder / "notes.txt").read_text() == "mine"
    assert _contents(tmp_path) == ["data.zarr", "file.zarr"]
    store = xrough.save_analysis(tmp_path / "a.zarr", {"G": G})
    xrough.save_analysis(store, {"G": G * 3})  # a previous store is replaced
    xr.testing.assert_identical(xrough.open_analysis(store)["G"], G * 3)
    assert _contents(tmp_path) == ["a.zarr", "data.zarr", "file.zarr"]


def test_zarr_without_the_package_says_how_to_install(tmp_path, monkeypatch):
    G = xr.DataArray([1.0], dims="dr", name="G", coords={"dr": [1.0]})
    monkeypatch.setitem(sys.modules, "zarr", None)  # import zarr raises ImportError
    with pytest.raises(ImportError, match=r"xrough\[zarr\]"):
        xrough.save_analysis(tmp_path / "a.zarr", {"G": G})
    assert _contents(tmp_path) == []


def test_saving_from_threads_does_not_crash(tmp_path):
    """Threads that each save and reopen their own NetCDF archive: HDF5 is not thread-safe
    here and 20 threads crashed the interpreter (SIGSEGV or SIGBUS in 3 of 3 runs) before
    xrough held one lock around its NetCDF reads and writes. In a subprocess, so that a
    crash fails this test instead of the test run."""
    import subprocess
    import sys

    code = f"""
import threading, warnings, pathlib, xrough, xrough.io.netcdf
import xarray as xr
warnings.simplefilter("ignore")
topo = xrough.self_affine_surface(hurst=0.8, n=64, size="64 nm", lambda_r="32 nm",
                                  lambda_s="2 nm", rms_gradient=0.1, unit="nm", seed=1)
G = topo.rough.acf()
folder = pathlib.Path({str(tmp_path)!r})
errors = []
def work(i):
    try:
        for _ in range(2):
            xrough.save_analysis(folder / f"a{{i}}.nc", {{"m": {{"G": G, "topo": topo}}}})
            back = xrough.open_analysis(folder / f"a{{i}}.nc")["m"]["G"]
            xr.testing.assert_identical(back, G)
            xrough.io.netcdf.write(topo, folder / f"t{{i}}.nc")
            xrough.open_topography(folder / f"t{{i}}.nc")
    except Exception as err:
        errors.append(repr(err))
threads = [threading.Thread(target=work, args=(i,)) for i in range(16)]
[t.start() for t in threads]
[t.join() for t in threads]
print(len(errors), errors[:1])
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split()[0] == "0", done.stdout


@pytest.mark.skipif(importlib.util.find_spec("zarr") is None, reason="zarr not installed")
def test_a_store_set_aside_by_a_killed_save_comes_back(tmp_path):
    """A Zarr store is replaced by renaming the old one aside, then the new one in; a save
    killed between the two left nothing at the path, and the next save deleted the store
    set aside. Now open and save put it back first, with a warning, and it reads as it
    was; a store set aside by a process still running (this one) is left alone."""
    import os

    from xrough.io.archive import temporary_name

    G = xrough.self_affine_surface(hurst=0.8, n=64, size="64 nm", lambda_r="32 nm",
                                   lambda_s="2 nm", rms_gradient=0.1, unit="nm",
                                   seed=1).rough.acf()
    store = tmp_path / "a.zarr"
    xrough.save_analysis(store, {"m": {"G": G}})
    aside = temporary_name(store, "old")
    dead = aside.with_name(aside.name.replace(f".{os.getpid()}-", ".999999999-"))
    os.replace(store, dead)  # the kill: the old store aside, nothing at the path
    with pytest.warns(UserWarning, match="is back in place"):
        back = xrough.open_analysis(store)
    xr.testing.assert_identical(back["m"]["G"], G)
    assert store.exists() and not dead.exists()
    os.replace(store, aside)  # set aside by a running process (this one): not touched
    with pytest.raises(FileNotFoundError):
        xrough.open_analysis(store)
    assert aside.exists()
