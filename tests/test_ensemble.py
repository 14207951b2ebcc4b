"""Averages over a set of measurements of one surface (mean_acf, G.rough.mean)."""

from __future__ import annotations

import numpy as np
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
