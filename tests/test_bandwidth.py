"""Checkerboard detrending and the variable-bandwidth analysis.

The first tests are SurfaceTopography's (test_variable_bandwidth.py) ported to xrough's
API: ``detrend(..., subdivisions=)`` is their ``checkerboard_detrend_area`` (and with
``per_line=True`` their ``checkerboard_detrend_profile``, along x, xrough's scan lines),
``variable_bandwidth`` their ``variable_bandwidth_from_area/_profile``. Their non-uniform
profile case has no counterpart (xrough resamples non-uniform profiles on reading).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import xrough


def _topo(h, spacing=1.0):
    return xrough.topography(np.asarray(h, dtype=float), spacing=spacing, unit="nm")


def _cb(h, tiles, mode="plane", per_line=False):
    return xrough.detrend(_topo(h), mode=mode, subdivisions=tiles, per_line=per_line).values


def test_checkerboard_detrend_1d():
    arr = np.zeros(6)
    arr[:2] = 1.0
    np.testing.assert_allclose(_cb(arr, 3), 0, atol=1e-12)
    arr[0] = -1.0
    np.testing.assert_allclose(_cb(arr, 3), 0, atol=1e-12)


def test_checkerboard_detrend_order2_1d():
    arr = np.zeros(6)
    arr[:3] = 1.0
    np.testing.assert_allclose(_cb(arr, 2, "curvature"), 0, atol=1e-12)
    arr[0] = -1.0
    np.testing.assert_allclose(_cb(arr, 2, "curvature"), 0, atol=1e-12)
    arr[1] = 1.5
    np.testing.assert_allclose(_cb(arr, 2, "curvature"), 0, atol=1e-12)
    # a line (order 1) cannot take this to zero
    np.testing.assert_allclose(_cb(arr, 2), [-0.5, 1.0, -0.5, 0.0, 0.0, 0.0], atol=1e-12)


def test_checkerboard_detrend_2d():
    arr = np.zeros([4, 4])
    arr[:2, :2] = 1.0
    np.testing.assert_allclose(_cb(arr, (2, 2)), 0, atol=1e-12)
    arr[:2, 1] = 2.0
    np.testing.assert_allclose(_cb(arr, (2, 2)), 0, atol=1e-12)


def test_checkerboard_detrend_profile_2d():
    """Per scan line (along x): offsets between lines do not matter."""
    arr = np.zeros([4, 4])
    arr[:2, :2] = 1.0
    np.testing.assert_allclose(_cb(arr.T, (1, 2), per_line=True), 0, atol=1e-12)
    arr[:2, 1] = 2.0
    arr[:, 1] += 1
    arr[:, 2] += 1.5
    arr[:, 3] += 0.7
    np.testing.assert_allclose(_cb(arr.T, (1, 2), per_line=True), 0, atol=1e-12)


def test_checkerboard_detrend_order2_2d():
    arr = np.zeros([6, 6])
    arr[:3, :3] = 1.0
    np.testing.assert_allclose(_cb(arr, (2, 2), "curvature"), 0, atol=1e-12)
    arr[:3, 1] = 2.0
    np.testing.assert_allclose(_cb(arr, (2, 2), "curvature"), 0, atol=1e-12)
    arr[:3, 2] = -0.5
    np.testing.assert_allclose(_cb(arr, (2, 2), "curvature"), 0, atol=1e-12)


def test_checkerboard_detrend_with_no_subdivisions():
    x, y = np.mgrid[:32, :32].astype(float)
    h = 1.3 * x - 0.3 * y + 0.02 * x * x + 0.03 * y * y - 0.013 * x * y
    np.testing.assert_allclose(_cb(h, (1, 1)), xrough.detrend(_topo(h)).values, atol=1e-10)


@pytest.mark.parametrize("hurst", [0.3, 0.8])
def test_self_affine_profile(hurst):
    """rms(m) ~ m^-H on self-affine profiles (16,384 points, tiles down to 512 points, as
    the peers'); the first point is the detrended profile's rms height; bandwidth = L / m.
    The peers draw one profile with fixed amplitudes and allow 0.1 on H; xrough's have
    random amplitudes, whose slopes scatter by 0.05-0.08: the mean of eight within 0.05
    (measured -0.301 and -0.761), each within 0.2."""
    n = 16384
    slopes = []
    for seed in range(8):
        topo = xrough.self_affine_surface(hurst=hurst, n=n, size=f"{n} nm",
                                          lambda_r=f"{n} nm", lambda_s="2 nm",
                                          rms_gradient=0.1, unit="nm", profile=True,
                                          seed=seed)
        vb = xrough.variable_bandwidth(topo, min_tile=n // 32)
        if seed == 0:
            first = vb.sel(bandwidth=vb.bandwidth.max())
            rms = float(np.sqrt((xrough.detrend(topo) ** 2).mean()))
            assert float(first) == pytest.approx(rms, rel=1e-12)
            np.testing.assert_allclose(vb.bandwidth, n / vb.magnification, rtol=1e-12)
        fine = vb.magnification > 1
        slopes.append(np.polyfit(np.log(vb.magnification[fine]), np.log(vb[fine]), 1)[0])
    assert abs(hurst + np.mean(slopes)) < 0.05, slopes
    assert np.all(np.abs(hurst + np.array(slopes)) < 0.2), slopes


@pytest.mark.parametrize("hurst", [0.3, 0.8])
def test_self_affine_map(hurst):
    """The same on a 1024² map (the peers use 2048²), tiles down to 32 points."""
    n = 1024
    topo = xrough.self_affine_surface(hurst=hurst, n=n, size=f"{n} nm", lambda_r=f"{n} nm",
                                      lambda_s="2 nm", rms_gradient=0.1, unit="nm", seed=3)
    vb = xrough.variable_bandwidth(topo, min_tile=n // 32)
    assert float(vb[-1]) == pytest.approx(float(np.sqrt((xrough.detrend(topo) ** 2).mean())),
                                          rel=1e-12)
    fine = vb.magnification > 1
    slope = np.polyfit(np.log(vb.magnification[fine]), np.log(vb[fine]), 1)[0]
    assert abs(hurst + slope) < 0.1, slope
    assert np.all(vb.rms_height_std[fine] > 0) and np.isnan(vb.rms_height_std[-1])


def test_units_dask_nan_and_errors():
    """Same in nm and um (heights and bandwidths scale); numpy = dask over a stack; a NaN
    hole only leaves out its points; bad arguments are named."""
    topo = xrough.self_affine_surface(hurst=0.7, n=128, size="128 nm", lambda_r="64 nm",
                                      lambda_s="2 nm", rms_gradient=0.1, unit="nm", seed=2)
    vb = topo.rough.variable_bandwidth(min_tile=8)
    um = xrough.convert_units(topo, "um", lateral="um").rough.variable_bandwidth(min_tile=8)
    np.testing.assert_allclose(um.values, vb.values * 1e-3, rtol=1e-9)
    np.testing.assert_allclose(um.bandwidth, vb.bandwidth * 1e-3, rtol=1e-12)
    stack = xr.concat([topo, topo * 2], dim="scan")
    lazy = stack.chunk({"scan": 1}).rough.variable_bandwidth(min_tile=8)
    assert lazy.chunks is not None
    xr.testing.assert_allclose(lazy.compute(), stack.rough.variable_bandwidth(min_tile=8))
    holed = topo.copy()
    holed[10:20, 10:20] = np.nan
    out = holed.rough.variable_bandwidth(min_tile=8)
    assert np.all(np.isfinite(out)) and np.all(out.tiles == vb.tiles)
    with pytest.raises(ValueError, match="min_tile"):
        topo.rough.variable_bandwidth(min_tile=1)
    with pytest.raises(ValueError, match="min_tile"):
        topo.rough.variable_bandwidth(min_tile=500)
    with pytest.raises(ValueError, match="subdivisions"):
        xrough.detrend(topo, subdivisions=(2, 0))
