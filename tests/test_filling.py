"""Filling missing points (fill_missing).

The harmonic cases are SurfaceTopography's test_imputation.py (randomly rough 1D and 2D:
nothing filled above the threshold that removed the points; linear 1D and 2D: planes
come back exactly) on xrough's API; its patch-numbering helpers have no counterpart
(xrough solves one sparse system per map).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import xrough


def _rough(shape, seed=1):
    profile = len(shape) == 1
    return xrough.self_affine_surface(hurst=0.8, n=shape[0], size="1 nm", lambda_r="1 nm",
                                      lambda_s=f"{2 / shape[0]} nm", rms_height=1.0,
                                      unit="nm", profile=profile, seed=seed)


@pytest.mark.parametrize("shape", [(128,), (128, 128)])
def test_randomly_rough(shape):
    """The points above 80 % of the height range removed: every filled value is below
    that threshold (the maximum principle), the valid points untouched."""
    topo = _rough(shape)
    lo, hi = float(topo.min()), float(topo.max())
    threshold = lo + 0.8 * (hi - lo)
    holed = topo.where(topo <= threshold)
    assert holed.isnull().any()
    filled = holed.rough.fill_missing()
    assert not filled.isnull().any()
    assert float(filled.max()) <= threshold
    xr.testing.assert_equal(filled.where(holed.notnull()), holed)


def test_linear_1d():
    a, b, n, size = -1.3, 2.7, 128, 1.3
    x = np.linspace(-size / 2, size / 2, n)
    h = a * x + b
    topo = xrough.topography(np.where(abs(x) < size / 8, np.nan, h), spacing=size / (n - 1),
                             unit="nm")
    np.testing.assert_allclose(topo.rough.fill_missing(), h)


def test_linear_2d():
    """A plane with a hole, on a grid with different spacings along x and y."""
    a, b, c = -1.3, 2.7, 1.8
    nx, ny, sx, sy = 128, 234, 1.3, 1.6
    x = np.linspace(-sx / 2, sx / 2, nx)[None, :]
    y = np.linspace(-sy / 2, sy / 2, ny)[:, None]
    h = a * x + b * y + c
    hole = (abs(x) < sx / 8) & (abs(y) < sy / 8)
    topo = xrough.topography(np.where(hole, np.nan, h),
                             spacing=(f"{sy / (ny - 1)} nm", f"{sx / (nx - 1)} nm"), unit="nm")
    np.testing.assert_allclose(topo.rough.fill_missing(), h, atol=1e-12)


def test_other_methods_units_dask_and_errors():
    topo = _rough((32, 32))
    holed = topo.copy()
    holed[4:8, 4:8] = np.nan
    mean = holed.rough.fill_missing(method="mean")
    assert float(mean[5, 5]) == pytest.approx(float(holed.mean()))
    const = holed.rough.fill_missing(method="constant", value="0.5 um")
    assert float(const[5, 5]) == 500.0 and const.attrs["filled"] == "16 points (constant)"
    # the same in um
    um = xrough.convert_units(holed, "um", lateral="um").rough.fill_missing()
    np.testing.assert_allclose(um.values, holed.rough.fill_missing().values * 1e-3,
                               rtol=1e-9)
    stack = xr.concat([holed, holed * 2], dim="scan")
    lazy = stack.chunk({"scan": 1}).rough.fill_missing()
    assert lazy.chunks is not None
    xr.testing.assert_allclose(lazy.compute(), stack.rough.fill_missing(),
                               check_dim_order=True)
    with pytest.raises(ValueError, match="method"):
        holed.rough.fill_missing(method="spline")
    with pytest.raises(ValueError, match="value"):
        holed.rough.fill_missing(method="constant")
    with pytest.raises(ValueError, match="no valid point"):
        (holed * np.nan).rough.fill_missing()
    # the filled map goes through what needs every point
    assert not holed.rough.fill_missing().rough.shortcut("0.2 nm").isnull().any()
