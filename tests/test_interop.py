"""pint-xarray and cf-xarray: quantified input, quantifiable results (optional packages)."""

import numpy as np
import pytest
import xarray as xr

import xrough
from xrough.units import dequantify, is_quantified

pint_xarray = pytest.importorskip("pint_xarray")
cf_units = pytest.importorskip("cf_xarray.units")
REGISTRY = cf_units.units  # reads CF/UDUNITS strings ("nm2", "J m-2")


@pytest.fixture(scope="module")
def results():
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="1 um", lambda_s="40 nm",
                                      size="4 um", n=256, rms_gradient=0.5, seed=1,
                                      unit="nm")
    G = topo.rough.acf()
    return {
        "topography": topo,
        "G": G,
        "fit": G.rough.fit(),
        "persson": G.rough.persson(E_star="25 MPa", p0=["0.1 MPa", "1 MPa"]),
        "energy": G.rough.energy(E_star="25 MPa"),
        "patch": G.rough.patch_radius(E_star="25 MPa", gamma="50 mJ/m^2"),
        "spectrum": G.rough.spectrum(),
        "gradient": G.rough.gradient(),
    }


@pytest.mark.parametrize("name", ["topography", "G", "fit", "persson", "energy", "patch",
                                  "spectrum", "gradient"])
def test_results_quantify_and_come_back_identical(results, name):
    obj = results[name]
    quantified = obj.pint.quantify(unit_registry=REGISTRY)
    names = [None] if isinstance(obj, xr.DataArray) else list(obj.data_vars)
    for n in names:
        before, after = (obj, quantified) if n is None else (obj[n], quantified[n])
        assert is_quantified(after) == ("units" in before.attrs), n
    xr.testing.assert_identical(dequantify(quantified), obj)


def test_quantified_units_convert(results):
    G = results["G"].pint.quantify(unit_registry=REGISTRY)
    in_um2 = G.pint.to("um**2")
    np.testing.assert_allclose(in_um2.pint.magnitude, results["G"].values * 1e-6)
    energy = results["energy"].pint.quantify(unit_registry=REGISTRY)
    assert str(energy.v_el.pint.units) in {"J / m ** 2", "joule / meter ** 2"}


def test_quantified_topography_enters_once(results):
    topo = results["topography"]
    quantified = topo.pint.quantify(unit_registry=REGISTRY)
    assert is_quantified(quantified)
    clean = xrough.topography(quantified)
    xr.testing.assert_identical(clean, topo)
    xr.testing.assert_identical(clean.rough.acf(), results["G"])


def test_quantified_input_is_taken_by_every_public_function(results):
    # every public function whose first argument is data takes it quantified, as the
    # accessor does: one rule (units.accepts_quantified), the same numbers; pint in, pint
    # out: the result is quantified in the input's registry and dequantifies to the plain one
    quantified = results["topography"].pint.quantify(unit_registry=REGISTRY)

    def same(got, plain):
        parts = [got] if isinstance(got, xr.DataArray) else list(got.data_vars.values())
        assert any(is_quantified(p) for p in parts)
        xr.testing.assert_identical(dequantify(got), plain)

    same(quantified.rough.acf(), results["G"])
    same(xrough.height_difference_acf(quantified), results["G"])
    G = results["G"].pint.quantify(unit_registry=REGISTRY)
    same(xrough.fit_acf(G), results["fit"])
    same(xrough.persson(G, E_star="25 MPa", p0=["0.1 MPa", "1 MPa"]), results["persson"])
    same(xrough.stitch_curves({"a": quantified}),
         xrough.stitch_curves({"a": results["topography"]}))
    same(G.rough.fit(), results["fit"])
    # and chains: quantified G -> quantified Persson -> its plot
    contact = quantified.rough.acf().rough.persson(E_star="25 MPa", p0="0.1 MPa")
    assert contact.a_r.pint.units == REGISTRY.Unit("1")
    assert contact.sigma_c.pint.to("MPa").pint.magnitude.size == contact.sizes["dr"]
    assert contact.rough.plot().size == 2
    plain = results["topography"]
    assert not is_quantified(plain.rough.acf())  # plain in, plain out


def test_every_data_first_public_function_is_wrapped():
    import inspect

    takes_path = {"open_topography", "open_analysis", "save_analysis", "model_spectrum",
                  "topography", "open_set"}  # a path, plain lags, or the constructor
    for name in xrough.__all__:
        func = getattr(xrough, name)
        if not inspect.isfunction(func) or name in takes_path:
            continue
        first = next(iter(inspect.signature(func).parameters.values()), None)
        if first is not None and first.kind in (first.POSITIONAL_ONLY,
                                                first.POSITIONAL_OR_KEYWORD):
            assert getattr(func, "__wrapped__", None) is not None, name


def test_one_registry_for_xrough_cf_xarray_and_pint_xarray(results):
    import pint

    assert xrough.units.ureg is REGISTRY
    assert pint.get_application_registry().get() is REGISTRY
    for name, obj in results.items():
        ds = obj.to_dataset(name="v") if isinstance(obj, xr.DataArray) else obj
        for key, var in ds.variables.items():
            if "units" in var.attrs:
                REGISTRY.Unit(var.attrs["units"])  # cf-xarray reads it as written
                assert xrough.units.parse_units(var.attrs["units"]) == REGISTRY.Unit(
                    var.attrs["units"]), (name, key)


def test_pint_xarray_default_registry_after_import_xrough(tmp_path):
    # the documented order: import xrough (or cf_xarray.units) before pint_xarray, and
    # .pint.quantify() needs no unit_registry to read "nm2" or "J m-2"
    import subprocess
    import sys

    code = (
        "import xrough, pint_xarray\n"
        "G = xrough.self_affine_surface(hurst=0.8, lambda_r=64.0, lambda_s=16.0, size=256.0,"
        " n=64, rms_height=1.0, seed=1, unit='nm').rough.acf()\n"
        "q = G.pint.quantify()\n"
        "e = G.rough.energy(E_star='1 MPa').pint.quantify()\n"
        "U = xrough.units.ureg\n"
        "print(q.pint.units == U.Unit('nm**2'), q.pint.registry is U,"
        " e.v_el.pint.units == U.Unit('J/m**2'))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "True True True", out


def test_angstrom_maps_chain_through(results):
    # a map in angstrom: G is labelled "angstrom2" (read by cf-xarray too), and fit,
    # energy and persson take it; the physics is that of the same map in nm
    topo = results["topography"]
    in_a = xrough.convert_units(topo, "angstrom", lateral="angstrom")
    G = in_a.rough.acf()
    assert G.attrs["units"] == "angstrom2" and G.dr.attrs["units"] == "angstrom"
    REGISTRY.Unit(G.attrs["units"])
    np.testing.assert_allclose(G.values, results["G"].values * 100, rtol=1e-12)
    fit = G.rough.fit()
    np.testing.assert_allclose(float(fit.hurst), float(results["fit"].hurst), rtol=1e-6)
    e = G.rough.energy(E_star="25 MPa")
    np.testing.assert_allclose(e.v_el.values, results["energy"].v_el.values, rtol=1e-9)
    p = G.rough.persson(E_star="25 MPa", p0=["0.1 MPa", "1 MPa"])
    np.testing.assert_allclose(p.a_r.values, results["persson"].a_r.values, rtol=1e-9)
    assert xrough.units.parse_units("Å2") == REGISTRY.Unit("angstrom2")


def test_pint_xarray_dequantify_is_read_too(results):
    G = results["G"].pint.quantify(unit_registry=REGISTRY).pint.dequantify()
    fit = G.rough.fit()
    np.testing.assert_allclose(fit.hurst, results["fit"].hurst, rtol=1e-12)


def test_quantified_parameters(results):
    G = results["G"]
    E_star = xr.DataArray(25.0).pint.quantify("MPa", unit_registry=REGISTRY)
    p0 = xr.DataArray([0.1, 1.0], dims="p0").pint.quantify("MPa", unit_registry=REGISTRY)
    got = G.rough.persson(E_star=E_star, p0=p0)
    xr.testing.assert_allclose(got.a_r, results["persson"].a_r, rtol=1e-12)


def test_dequantify_tree(results):
    topo = results["topography"]
    tree = xr.DataTree.from_dict({"afm": topo.to_dataset(name="h")})
    quantified = tree.map_over_datasets(lambda ds: ds.pint.quantify(unit_registry=REGISTRY))
    xr.testing.assert_identical(dequantify(quantified), tree)


def test_plain_objects_pass_through(results):
    G = results["G"]
    assert dequantify(G) is G
    assert not is_quantified(G)
