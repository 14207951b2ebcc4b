"""A chain never fits the same G twice (xrough.memo), and what it hands out again is exact.

Counts are of calls of the least-squares kernel of the model spectrum, patched where
:mod:`xrough.fitting` and the gradient kernel look it up; results are compared with
``assert_identical`` (a repeated call hands out the very numbers and attrs of the first).
"""

from __future__ import annotations

import warnings

import dask
import numpy as np
import pytest
import xarray as xr

import xrough
from xrough import fitting
from xrough._kernels import gradient as kgrad
from xrough.memo import by_content

E_STAR, P0 = "25 MPa", "0.1 MPa"


@pytest.fixture(scope="module")
def G():
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="40 nm",
                                      size="8 um", n=512, rms_gradient=0.5, seed=3,
                                      unit="nm")
    return topo.rough.acf()


@pytest.fixture
def fits(monkeypatch):
    """The number of spectrum fits of one curve run so far."""
    calls = []
    kernel = fitting.fit_spectrum_kernel

    def counting(*args, **kwargs):
        calls.append(1)
        return kernel(*args, **kwargs)
    for module in (fitting, kgrad):  # where the fit and the gradient look it up
        monkeypatch.setattr(module, "fit_spectrum_kernel", counting)
    return calls


def test_persson_after_fit_does_not_fit_again(G, fits):
    fit = G.rough.fit()
    assert len(fits) == 1
    contact = G.rough.persson(E_star=E_STAR, p0=P0)
    gbar = G.rough.gradient()
    assert len(fits) == 1  # the fit of G above served both
    xr.testing.assert_identical(contact, G.rough.persson(E_star=E_STAR, p0=P0, fit=fit))
    xr.testing.assert_identical(gbar, G.rough.gradient(fit=fit))


def test_an_equal_G_in_another_object_is_the_same_fit(G, fits):
    first = xrough.fit_acf(G)
    again = xrough.fit_acf(G.copy(deep=True), model="spectrum")  # defaults spelled out
    assert len(fits) == 1
    xr.testing.assert_identical(first, again)


@pytest.mark.parametrize("change", ["value", "attr", "unit", "option"])
def test_a_different_G_or_option_is_fitted(G, fits, change):
    xrough.fit_acf(G)
    other, kwargs = G, {}
    if change == "value":
        other = G.copy(deep=True)
        other[5] = other[5] * 1.01
    elif change == "attr":
        other = G.assign_attrs(source_file="another.x3p")
    elif change == "unit":
        other = G.assign_attrs(units="um2")  # the same numbers, 1e6 times the G
    else:
        kwargs = {"rolloff": "sharp"}
    xrough.fit_acf(other, **kwargs)
    assert len(fits) == 2


def test_what_is_handed_out_again_is_a_copy(G):
    first = xrough.fit_acf(G)
    first["hurst"][()] = -1.0
    first.attrs["model"] = "changed"
    again = xrough.fit_acf(G)
    assert float(again.hurst) > 0 and again.attrs["model"] == "spectrum"


def test_a_repeated_fit_says_its_warnings_again():
    dr = np.geomspace(1.0, 1000.0, 31)  # ballistic throughout: H ends on its bound 0.99
    G = xr.DataArray(dr**1.999, dims="dr", attrs={"units": "nm2"},
                     coords={"dr": ("dr", dr, {"units": "nm"})})
    with warnings.catch_warnings(record=True) as first:
        warnings.simplefilter("always")
        xrough.fit_acf(G, model="eq36")
    with warnings.catch_warnings(record=True) as again:
        warnings.simplefilter("always")
        xrough.fit_acf(G, model="eq36")
    assert xrough.fit_acf.cache_info()["hits"] == 1
    said = [(str(w.message), w.category, w.filename) for w in first]
    assert said and all(w.category is xrough.QualityWarning for w in first)
    assert said == [(str(w.message), w.category, w.filename) for w in again]


def test_a_lazy_fit_is_kept_lazy(G, fits):
    stack = xr.concat([G, G * 2], dim="scan").assign_attrs(G.attrs).chunk({"scan": 1})
    lazy = xrough.fit_acf(stack)
    assert lazy.hurst.chunks is not None and len(fits) == 0
    again = xrough.fit_acf(stack)
    assert again.hurst.chunks is not None
    xr.testing.assert_identical(lazy.compute(), again.compute())


def test_by_content_keeps_only_maxsize_results():
    calls = []

    @by_content(maxsize=2)
    def double(x):
        calls.append(float(x))
        return 2 * x

    for value in (1.0, 2.0, 3.0, 1.0):  # 1.0 was dropped when 3.0 came
        double(xr.DataArray(value))
    assert calls == [1.0, 2.0, 3.0, 1.0]
    assert double.cache_info() == {"hits": 0, "misses": 4, "size": 2}
    assert double.peek(xr.DataArray(3.0)) is not None and double.peek(xr.DataArray(2.0)) is None


def test_the_accessor_shows_the_signature_of_the_function():
    import inspect

    params = list(inspect.signature(xr.DataArray([1.0]).rough.fit).parameters)
    assert params[:2] == ["model", "dr_min"]
    assert fitting.fit_acf.__wrapped__.__name__ == "fit_acf"


def test_arguments_that_cannot_be_hashed_are_computed_not_kept():
    calls = []

    @by_content()
    def length(x, *, extra):
        calls.append(1)
        return xr.DataArray(float(len(x)))

    with dask.config.set({"tokenize.ensure-deterministic": True}):
        for _ in range(2):  # an object without a deterministic token: never kept
            assert float(length(xr.DataArray([1.0, 2.0]), extra=object())) == 2.0
    assert len(calls) == 2 and length.cache_info()["size"] == 0
    assert length.peek(xr.DataArray([1.0, 2.0]), extra=object()) is None


def test_switched_off_every_call_computes_and_nothing_is_kept(G, fits):
    """Inside ``disabled()`` (and after ``set_enabled(False)``) a repeated fit fits again
    and keeps nothing; the results equal the memoised ones; the switch comes back."""
    from xrough import memo

    kept = xrough.fit_acf(G)
    with memo.disabled():
        first, second = xrough.fit_acf(G), xrough.fit_acf(G)
        assert xrough.fit_acf.peek(G) is None
    assert len(fits) == 3
    xr.testing.assert_identical(first, kept)
    xr.testing.assert_identical(second, kept)
    assert xrough.fit_acf.cache_info()["size"] == 1  # the one kept before
    previous = memo.set_enabled(False)
    try:
        xrough.fit_acf(G)
        assert len(fits) == 4
    finally:
        memo.set_enabled(previous)
    xrough.fit_acf(G)
    assert len(fits) == 4 and previous is True


REAL_FILES = ["al3d-1.al3d", "dektak-1.csv", "di-1.di", "matrix-3.txt", "mi-1.mi", "nc-1.nc",
              "nid-1.nid", "opd-1.opd", "plu-1.plu", "sdf-1.sdf", "spot_1-1000nm.ibw",
              "sur-2.sur", "x3p-2.x3p"]


@pytest.mark.data
@pytest.mark.parametrize("name", REAL_FILES)
def test_the_readme_chain_fits_each_real_file_once(name, fits):
    """The README's chain on every real file (open, detrend, G, fit, persson, energy,
    patch radius, mean gap): one fit of each curve of G, whatever its rating (a G with a
    quality flag, anisotropic or with a roll-off, was fitted again by persson)."""
    from conftest import data_path

    path = data_path("instruments", name)
    if name in ("al3d-1.al3d", "mi-1.mi", "nid-1.nid", "opd-1.opd", "plu-1.plu"):
        pytest.importorskip("SurfaceTopography")
    xrough.memo.forget()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        G = xrough.open_topography(path).rough.detrend().rough.acf()
        curves = int(np.prod([G.sizes[d] for d in G.dims if d != "dr"]))
        steps = [lambda: G.rough.fit(),
                 lambda: G.rough.persson(E_star=E_STAR, p0=[P0, "1 MPa"]),
                 lambda: G.rough.energy(E_star=E_STAR),
                 lambda: G.rough.patch_radius(E_star=E_STAR, gamma="50 mJ/m^2"),
                 lambda: G.rough.mean_gap(E_star=E_STAR, p0=P0)]
        refused = []
        for step in steps:
            try:
                step()
            except ValueError as err:  # a G no theory takes (nc-1: quantized, G = 0)
                refused.append(str(err))
    # a refused G is refused by every step (its check comes before any fit)
    assert len(refused) in (0, len(steps))
    assert len(fits) == (0 if refused else curves)
