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


def test_quantified_input_elsewhere_says_what_to_do(results):
    quantified = results["topography"].pint.quantify(unit_registry=REGISTRY)
    # the accessor dequantifies; the functions say what to do
    xr.testing.assert_identical(quantified.rough.acf(), results["G"])
    with pytest.raises(ValueError, match="dequantify"):
        xrough.height_difference_acf(quantified)
    G = results["G"].pint.quantify(unit_registry=REGISTRY)
    xr.testing.assert_identical(G.rough.fit(), results["fit"])
    with pytest.raises(ValueError, match="dequantify"):
        xrough.fit_acf(G)
    xr.testing.assert_identical(dequantify(G).rough.fit(), results["fit"])


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
