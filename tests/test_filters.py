"""Fourier band filters of heights (fourier_filter, shortcut, longcut).

The first five are SurfaceTopography's test_filtering.py (longcut, shortcut, shortcut
against the isotropic and the square filter, the isotropic 1D filter) on xrough's API and
synthetic maps (periodic, so the PSD without a window).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import xrough


def _map(n=100, size=13.0, seed=0, unit="nm", profile=False):
    return xrough.self_affine_surface(hurst=0.9, n=n, size=f"{size} {unit}",
                                      lambda_r=f"{size} {unit}",
                                      lambda_s=f"{2 * size / n} {unit}", rms_height=1.0,
                                      unit=unit, seed=seed, profile=profile)


def _psd(topo):
    return topo.rough.psd(window=None, bins="linear")


def test_longcut():
    """No power left below 0.9 of the cutoff (the peers' atol 1e-12, relative here)."""
    n = 200
    topo = _map(n)
    q_c = 2 * np.pi / 13 * n / 4
    C = _psd(topo.rough.longcut(wavevector=q_c))
    C = C[np.isfinite(C)]
    assert float(abs(C.where(C.q < 0.9 * q_c, 0)).max()) < 1e-12 * float(C.max())


def test_shortcut():
    n = 100
    topo = _map(n)
    q_c = 2 * np.pi / 13 * 0.4 * n
    C = _psd(topo.rough.shortcut(wavevector=q_c))
    C = C[np.isfinite(C)]
    assert float(abs(C.where(C.q > 1.5 * q_c, 0)).max()) < 1e-12 * float(C.max())


def test_shortcut_vs_isotropic_filter():
    topo = _map(100)
    q_c = 2 * np.pi / 13 * 0.4 * 100
    hc = topo.rough.shortcut(wavevector=q_c)
    fhc = topo.rough.fourier_filter(lambda q: q <= q_c)
    np.testing.assert_allclose(fhc, hc)


def test_shortcut_vs_square_filter():
    topo = _map(100)
    q_c = 2 * np.pi / 13 * 0.2 * 100
    hc = topo.rough.shortcut(wavevector=q_c, kind="square")
    fhc = topo.rough.fourier_filter(
        lambda qy, qx: (np.abs(qx) <= q_c) * (np.abs(qy) <= q_c), isotropic=False)
    np.testing.assert_allclose(fhc, hc)
    assert not np.allclose(hc, topo.rough.shortcut(wavevector=q_c))  # not the circle


def test_isotropic_1d():
    n = 32
    line = _map(n, profile=True)
    q_c = 2 * np.pi / 13 * n / 4
    C = _psd(line.rough.fourier_filter(lambda q: q > q_c))
    C = C[np.isfinite(C)]
    assert np.all(C.where(C.q < 0.9 * q_c, 0) < 1e-10 * float(C.max()))


def test_bands_add_up_and_units():
    """shortcut + longcut at one cutoff give back the map (to 1e-12); a wavelength and its
    wavevector, nm and um, the same filter; numpy = dask; bad input named."""
    topo = _map(64)
    for kind in ("circular", "square"):
        low = topo.rough.shortcut("1 nm", kind=kind)
        high = topo.rough.longcut("1 nm", kind=kind)
        np.testing.assert_allclose(low + high, topo, atol=1e-12)
    np.testing.assert_allclose(topo.rough.shortcut("1 nm"),
                               topo.rough.shortcut(wavevector=2 * np.pi), rtol=1e-12)
    np.testing.assert_allclose(topo.rough.shortcut("1 nm"),
                               topo.rough.shortcut(wavevector="6.283185307179586 nm^-1"),
                               rtol=1e-12)
    um = xrough.convert_units(topo, "um", lateral="um")  # a cutoff off the modes' rings
    np.testing.assert_allclose(um.rough.shortcut("0.0011 um").values,
                               topo.rough.shortcut(1.1).values * 1e-3, rtol=1e-9,
                               atol=1e-15)
    stack = xr.concat([topo, 2 * topo], dim="scan")
    lazy = stack.chunk({"scan": 1}).rough.shortcut("1 nm")
    assert lazy.chunks is not None
    xr.testing.assert_allclose(lazy.compute(), stack.rough.shortcut("1 nm"))
    assert lazy.attrs["filter"] == "shortcut at wavelength 1 nm (circular)"
    holed = topo.copy()
    holed[3, 3] = np.nan
    with pytest.raises(ValueError, match="fill_missing"):
        holed.rough.shortcut("1 nm")
    with pytest.raises(ValueError, match="one of them"):
        topo.rough.shortcut("1 nm", wavevector=1.0)
    with pytest.raises(ValueError, match="kind"):
        topo.rough.shortcut("1 nm", kind="round")
    with pytest.raises(ValueError, match="wavelength"):
        topo.rough.longcut("-1 nm")
