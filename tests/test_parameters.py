"""Roughness parameters, distributions, bearing area, scale-dependent slope and curvature.

Each number is checked against an independent computation: numpy and scipy moments, the
finite differences written out with ``np.diff``/``np.roll``, closed forms of sinusoids,
G(dr) of the FFT estimator (the rms slope at step dr is sqrt(2 G(dr)) / dr on the same
pairs), and SurfaceTopography on the real measurements.

Tolerances (each test says which it uses):

* ``EXACT = 1e-12`` (relative): the same sums in another order, round-off only;
* SurfaceTopography evaluates its stencils by linear interpolation at positions
  ``x / px`` computed in floating point, whose weights are off by ~1e-13: ``ST_RTOL =
  1e-10`` where the stencils agree (profiles; the rms curvature and the corner slopes of
  complete maps; the rms height of every map);
* its ``rms_gradient`` averages both slopes over the points where both exist, Sdq here
  each over all pairs along its axis: they differ by the pairs of one row and one column,
  ``|Sdq / ST - 1| <= 4 / min(nx, ny)`` (measured: 2e-5 to 2e-3 on the maps of 200-768
  points, 2e-3 on 4 x 7 and 0.13 on 4 x 4, whose edge rows are a quarter of the map).
"""

import warnings

import numpy as np
import pytest
import scipy.stats
import xarray as xr
from dask_counting import computes_nothing

import xrough
from conftest import data_path
from xrough._kernels import derivatives as fd
from xrough.toolbox import parameters as par
from xrough.topography import grid_of

EXACT = 1e-12
ST_RTOL = 1e-10


def _map(shape=(48, 64), *, seed=0, nan=(), periodic=False, spacing="2 nm", unit="nm"):
    h = np.random.default_rng(seed).normal(0.0, 3.0, size=shape)
    h = h + 0.4 * np.cumsum(h, axis=-1) / np.sqrt(shape[-1])  # some correlation
    for index in nan:
        h[index] = np.nan
    return xrough.topography(h, spacing=spacing, unit=unit, periodic=periodic,
                             attrs={"detrend": "mean"})


def _quiet(func, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        return func(*args, **kwargs)


# ------------------------------------------------------------------------------ heights


@pytest.mark.parametrize("nan", [(), ((3, 5), (10, slice(0, 7)))])
def test_sq_is_the_rms_height_and_moments_are_numpys(nan):
    topo = _map(nan=nan)
    p = topo.rough.parameters()
    z = topo.values[np.isfinite(topo.values)]
    z = z - z.mean()
    # Sq is np.std (mean removed, ddof 0) of the valid heights
    np.testing.assert_allclose(float(p.Sq), np.std(z), rtol=EXACT, atol=0)
    np.testing.assert_allclose(float(p.Sa), np.mean(np.abs(z)), rtol=EXACT, atol=0)
    np.testing.assert_allclose(float(p.Ssk), scipy.stats.skew(z), rtol=EXACT, atol=0)
    np.testing.assert_allclose(float(p.Sku), scipy.stats.kurtosis(z, fisher=False),
                               rtol=EXACT, atol=0)
    np.testing.assert_allclose([float(p.Sp), float(p.Sv), float(p.Sz)],
                               [z.max(), -z.min(), z.max() - z.min()], rtol=EXACT, atol=0)
    assert p.Sq.attrs["units"] == "nm" and p.Ssk.attrs["units"] == "1"
    assert "ISO 25178-2" in p.Sq.attrs["long_name"]
    assert "no plane" in p.attrs["reference"] and "forward difference" in p.attrs[
        "slope_stencil"]


def test_profile_parameters_and_rz_over_sampling_lengths():
    rng = np.random.default_rng(4)
    h = rng.normal(size=500)
    line = xrough.topography(h, spacing="1 um", unit="nm", attrs={"detrend": "mean"})
    z = h - h.mean()
    p = line.rough.parameters()
    assert list(p.data_vars) == ["Rq", "Ra", "Rsk", "Rku", "Rp", "Rv", "Rz", "Rt", "Rdq",
                                 "rms_curvature", "median_height", "mad_height"]
    np.testing.assert_allclose(float(p.Rq), np.std(z), rtol=EXACT, atol=0)
    # one section (the default): Rz is Rt
    assert float(p.Rz) == float(p.Rt) == pytest.approx(z.max() - z.min(), rel=EXACT)
    five = line.rough.parameters(sampling_lengths=5)
    parts = np.array_split(z, 5)
    np.testing.assert_allclose(
        [float(five.Rp), float(five.Rv), float(five.Rz)],
        [np.mean([s.max() for s in parts]), np.mean([-s.min() for s in parts]),
         np.mean([s.max() - s.min() for s in parts])], rtol=EXACT, atol=0)
    assert float(five.Rt) == float(p.Rt) and five.attrs["sampling_lengths"] == 5
    assert "5 sections" in five.Rz.attrs["definition"]


def test_slopes_curvatures_and_sdr_against_numpy_differences():
    topo = _map(spacing=("3 nm", "2 nm"), nan=((7, 9),))
    p = topo.rough.parameters()
    h, dy, dx = topo.values, 3.0, 2.0
    sx, sy = np.diff(h, axis=1) / dx, np.diff(h, axis=0) / dy
    sdq = np.sqrt(np.nanmean(sx**2) + np.nanmean(sy**2))  # each over its valid pairs
    np.testing.assert_allclose(float(p.Sdq), sdq, rtol=EXACT, atol=0)
    gx, gy = sx[:-1, :], sy[:, :-1]  # both forward differences from each point
    np.testing.assert_allclose(float(p.Sdr), np.nanmean(np.sqrt(1 + gx**2 + gy**2) - 1),
                               rtol=1e-9, atol=0)  # sqrt(1 + g^2) - 1 by cancellation
    lap = (np.diff(h, 2, axis=1)[1:-1, :] / dx**2 + np.diff(h, 2, axis=0)[:, 1:-1] / dy**2)
    np.testing.assert_allclose(float(p.rms_curvature), np.sqrt(np.nanmean((lap / 2) ** 2)),
                               rtol=EXACT, atol=0)
    assert p.rms_curvature.attrs["units"] == "nm-1" and p.Sdr.attrs["units"] == "1"


def test_periodic_maps_wrap_their_stencils():
    topo = _map(periodic=True)
    h = topo.values
    p = topo.rough.parameters()
    sx = (np.roll(h, -1, axis=1) - h) / 2.0
    sy = (np.roll(h, -1, axis=0) - h) / 2.0
    np.testing.assert_allclose(float(p.Sdq), np.sqrt(np.mean(sx**2) + np.mean(sy**2)),
                               rtol=EXACT, atol=0)
    lap = (np.roll(h, 1, 1) + np.roll(h, -1, 1) + np.roll(h, 1, 0) + np.roll(h, -1, 0)
           - 4 * h) / 4.0
    np.testing.assert_allclose(float(p.rms_curvature), np.sqrt(np.mean((lap / 2) ** 2)),
                               rtol=EXACT, atol=0)


def test_profile_sine_has_the_known_slope_and_curvature():
    # A sin(2 pi x / L), 8 periods of 64 pixels of 0.5 um, periodic: the differences of a
    # sampled sinusoid are sinusoids, so the rms values are known exactly
    A, L, d, n = 3.0, 32.0, 0.5, 512
    x = np.arange(n) * d
    line = xrough.topography(A * np.sin(2 * np.pi * x / L), spacing=d, unit="um",
                             periodic=True)
    p = line.rough.parameters()
    theta = 2 * np.pi * d / L
    np.testing.assert_allclose(float(p.Rq), A / np.sqrt(2), rtol=EXACT)
    np.testing.assert_allclose(float(p.Rdq), np.sqrt(2) * A * np.sin(theta / 2) / d,
                               rtol=EXACT)
    np.testing.assert_allclose(float(p.rms_curvature),
                               A * (2 - 2 * np.cos(theta)) / d**2 / np.sqrt(2), rtol=EXACT)
    # ... and approach the continuum amplitudes A q / sqrt 2, A q^2 / sqrt 2 to the stencil
    # error (theta^2 / 24 and theta^2 / 12: 8e-4 and 2e-3 at 64 pixels per period)
    q = 2 * np.pi / L
    np.testing.assert_allclose(float(p.Rdq), A * q / np.sqrt(2), rtol=theta**2 / 24 * 1.01)
    np.testing.assert_allclose(float(p.rms_curvature), A * q**2 / np.sqrt(2),
                               rtol=theta**2 / 12 * 1.01)
    assert float(p.Rz) == pytest.approx(2 * A, rel=EXACT)


def test_same_physics_in_nm_um_and_m():
    topo = _map(seed=5, nan=((2, 3),))
    base = topo.rough.parameters()
    for unit, f in (("um", 1e-3), ("m", 1e-9)):
        other = xrough.convert_units(topo, unit, lateral=unit).rough.parameters()
        for name in ("Sq", "Sa", "Sp", "Sv", "Sz"):
            np.testing.assert_allclose(float(other[name]), float(base[name]) * f,
                                       rtol=EXACT)
            assert other[name].attrs["units"] == unit
        for name in ("Ssk", "Sku", "Sdq", "Sdr"):
            np.testing.assert_allclose(float(other[name]), float(base[name]), rtol=EXACT)
        np.testing.assert_allclose(float(other.rms_curvature), float(base.rms_curvature) / f,
                                   rtol=EXACT)
        assert other.rms_curvature.attrs["units"] == f"{unit}-1"
    # heights in nm on a lateral grid in um: slopes and curvatures convert the heights
    mixed = xrough.convert_units(topo, lateral="um")
    pm = mixed.rough.parameters()
    np.testing.assert_allclose(float(pm.Sdq), float(base.Sdq), rtol=EXACT)
    np.testing.assert_allclose(float(pm.rms_curvature), float(base.rms_curvature) * 1e3,
                               rtol=EXACT)
    s_nm = topo.rough.scale_dependent_slope()
    s_m = xrough.convert_units(topo, "m", lateral="m").rough.scale_dependent_slope()
    np.testing.assert_allclose(s_m.values, s_nm.values, rtol=EXACT)
    np.testing.assert_allclose(s_m.dr.values, s_nm.dr.values * 1e-9, rtol=EXACT)


# ---------------------------------------------------------------- missing points, errors


def test_missing_points_are_left_out_and_derivatives_need_both_neighbours():
    h = np.arange(12.0) ** 2 / 10
    h[5] = np.nan
    line = xrough.topography(h, spacing=1.0, unit="nm")
    p = _quiet(line.rough.parameters)
    s = np.diff(h)  # pairs (4, 5) and (5, 6) are NaN: left out
    np.testing.assert_allclose(float(p.Rdq), np.sqrt(np.nanmean(s**2)), rtol=EXACT)
    c = np.diff(h, 2)  # three stencils touch point 5
    assert np.isnan(c).sum() == 3
    np.testing.assert_allclose(float(p.rms_curvature), np.sqrt(np.nanmean(c**2)),
                               rtol=EXACT)
    s1 = line.rough.scale_dependent_slope(dr=[1.0, 2.0])
    assert s1.pair_count.values.tolist() == [9, 8]
    # no pair of valid neighbours at all: the slope is undefined, NaN (not an error)
    sparse = xrough.topography(np.array([1.0, np.nan, 2.0, np.nan, 0.0]), spacing=1.0,
                               unit="nm")
    q = _quiet(sparse.rough.parameters)
    assert np.isnan(float(q.Rdq)) and np.isfinite(float(q.Rq))
    with pytest.raises(ValueError, match="no slope along x is defined"):
        sparse.rough.slope_distribution()


def _bad_calls():
    topo = _map()
    line = xrough.topography(np.arange(10.0), spacing=1.0, unit="nm")
    return [
        (lambda: par.roughness_parameters(topo.values), TypeError, "must be an xarray"),
        (lambda: par.roughness_parameters(topo.assign_attrs(units="V")), ValueError,
         "must be a length"),
        (lambda: par.roughness_parameters(topo.rename(x="a", y="b")), ValueError,
         "needs dims"),
        (lambda: par.roughness_parameters(topo.where(topo.x > 1e9)), ValueError,
         "fewer than 2 valid"),
        (lambda: par.roughness_parameters(topo.copy(data=np.where(
            topo.values > 2, np.inf, topo.values))), ValueError, "infinite"),
        (lambda: par.roughness_parameters(topo.chunk({"x": 16})), ValueError,
         "split into several dask chunks"),
        (lambda: par.roughness_parameters(topo, sampling_lengths=5), ValueError,
         "no sections of a map"),
        (lambda: par.roughness_parameters(line, sampling_lengths=6), ValueError,
         "fewer than 2 points per section"),
        (lambda: par.roughness_parameters(line, sampling_lengths=0), ValueError,
         "whole number of at least 1"),
        (lambda: par.height_distribution(topo, bins=[1.0, 0.0]), ValueError,
         "strictly increasing"),
        (lambda: par.height_distribution(topo, bins=0), ValueError, "at least 1"),
        (lambda: par.height_distribution(topo.chunk(), bins=10), ValueError,
         "lazy .* needs explicit"),
        (lambda: par.slope_distribution(topo, direction="z"), ValueError, "one of"),
        (lambda: par.slope_distribution(line, direction="y"), ValueError, "along 'x' only"),
        (lambda: par.curvature_distribution(line, direction="mean"), ValueError,
         "along 'x' only"),
        (lambda: par.bearing_area_curve(topo, material_ratio=[0.5, 1.5]), ValueError,
         "from 0 to 1"),
        (lambda: par.material_ratio(topo, height="2 MPa"), ValueError, "not a length"),
        (lambda: par.scale_dependent_slope(topo, dr=[3.0]), ValueError,
         "not a whole number of pixels"),
        (lambda: par.scale_dependent_slope(topo, dr=[200.0]), ValueError,
         "does not fit an open grid"),
        (lambda: par.scale_dependent_curvature(line, dr=[5.0]), ValueError,
         "2 x 5 pixels does not fit"),
        (lambda: par.scale_dependent_slope(topo, dr=[2.0], dr_max=10), ValueError,
         "not both"),
        (lambda: par.scale_dependent_slope(topo, points_per_decade=0), ValueError,
         "points_per_decade"),
        (lambda: par.scale_dependent_slope(topo, dr=[4.0, 2.0]), ValueError,
         "strictly increasing"),
        (lambda: par.scale_dependent_curvature(topo, tip_radius="-2 nm"), ValueError,
         "positive length"),
        (lambda: par.scale_dependent_curvature(topo, tip_radius="2 s"), ValueError,
         "not a length"),
        (lambda: par.tip_check(topo, tip_radius="2 nm"), ValueError,
         "reads a scale-dependent curvature"),
        (lambda: par.tip_check(par.scale_dependent_curvature(topo), tip_radius=1.0,
                               safety_factor=0), ValueError, "safety_factor"),
    ]


@pytest.mark.parametrize("case", range(len(_bad_calls())))
def test_bad_input_raises_clear_errors(case):
    call, error, match = _bad_calls()[case]
    with pytest.raises(error, match=match):
        _quiet(call)


# -------------------------------------------------------------------------- numpy, dask


def _stack():
    h = np.random.default_rng(1).normal(size=(3, 40, 48))
    h[0, 5, 7] = h[2, 0, 0] = np.nan
    return xrough.topography(xr.DataArray(h, dims=("scan", "y", "x")), spacing="2 nm",
                             unit="nm", attrs={"detrend": "plane"})


CALLS = {
    "parameters": lambda t: t.rough.parameters(),
    "height_distribution": lambda t: t.rough.height_distribution(
        bins=np.linspace(-5, 5, 21)),
    "slope_distribution": lambda t: t.rough.slope_distribution(bins=np.linspace(0, 4, 9)),
    "curvature_distribution_x": lambda t: t.rough.curvature_distribution(
        direction="x", bins=["-1 nm-1", 0.0, "1 nm-1"]),
    "bearing_area_curve": lambda t: t.rough.bearing_area_curve(),
    "material_ratio": lambda t: t.rough.material_ratio(height=[-1.0, 0.0, 1.0]),
    "scale_dependent_slope": lambda t: t.rough.scale_dependent_slope(),
    "scale_dependent_curvature": lambda t: t.rough.scale_dependent_curvature(
        tip_radius="3 nm"),
}


@pytest.mark.parametrize("chunk", [1, 2])
@pytest.mark.parametrize("name", CALLS)
def test_numpy_and_dask_agree_and_graphs_do_not_compute(name, chunk):
    # each map is computed on its own (the kernels loop over maps), so the numbers do not
    # depend on the chunks: identical, not close
    stack = _stack()
    eager = _quiet(CALLS[name], stack)
    assert all(v.chunks is None for v in
               (eager.data_vars.values() if isinstance(eager, xr.Dataset) else [eager]))
    with computes_nothing():
        lazy = CALLS[name](stack.chunk({"scan": chunk}))
    xr.testing.assert_identical(_quiet(lazy.compute), eager)


@pytest.mark.parametrize("name", CALLS)
def test_output_does_not_depend_on_keep_attrs(name):
    stack = _stack()
    with xr.set_options(keep_attrs=True):
        kept = _quiet(CALLS[name], stack)
    with xr.set_options(keep_attrs=False):
        dropped = _quiet(CALLS[name], stack)
    xr.testing.assert_identical(kept, dropped)


def test_stack_gives_each_map_its_own_numbers():
    stack = _stack()
    p = stack.rough.parameters()
    one = stack.isel(scan=1).rough.parameters()
    for name in p.data_vars:
        assert float(p[name].isel(scan=1)) == float(one[name])


# ------------------------------------------------------------------------ distributions


def test_distributions_are_densities_with_units():
    topo = _map(nan=((1, 1),))
    hd = topo.rough.height_distribution(bins=50)
    assert hd.dims == ("height",) and hd.attrs["units"] == "nm-1"
    assert hd.height.attrs["units"] == "nm" and hd.bin_width.attrs["units"] == "nm"
    np.testing.assert_allclose(float((hd * hd.bin_width).sum()), 1.0, rtol=EXACT)
    assert int(hd.value_count) == topo.size - 1
    half = topo.rough.height_distribution(bins=[0.0, 100.0])  # the heights above the mean
    z = topo.values - np.nanmean(topo.values)
    np.testing.assert_allclose(float(half.sum()) * 100.0, np.mean(z[np.isfinite(z)] >= 0),
                               rtol=EXACT)
    sx = topo.rough.slope_distribution(direction="x", bins=200)
    assert int(sx.value_count) == 48 * 63 - 2 and sx.attrs["units"] == "1"
    g = topo.rough.slope_distribution(bins=[0.0, 1.0, 100.0])  # |grad h|, corner stencil
    sy, sxx = fd.gradient(topo.values, steps=(1, 1), spacing=(2.0, 2.0), periodic=False)
    mag = np.hypot(sy, sxx)[np.isfinite(np.hypot(sy, sxx))]
    np.testing.assert_allclose(g.values * np.array([1.0, 99.0]),
                               [np.mean(mag < 1), np.mean(mag >= 1)], rtol=EXACT)
    c = topo.rough.curvature_distribution(bins=40)
    assert c.curvature.attrs["units"] == "nm-1" and c.attrs["units"] == "nm"
    assert c.attrs["direction"] == "mean"


def test_bearing_area_curve_and_material_ratio_are_inverse():
    topo = _map(nan=((0, 0), (4, 4)))
    p = topo.rough.parameters()
    curve = topo.rough.bearing_area_curve()
    assert float(curve.sel(material_ratio=0.0)) == pytest.approx(float(p.Sp), rel=EXACT)
    assert float(curve.sel(material_ratio=1.0)) == pytest.approx(-float(p.Sv), rel=EXACT)
    assert np.all(np.diff(curve.values) <= 0)
    n = topo.size - 2
    ratio = topo.rough.material_ratio(height=curve.values)
    # the fraction at or above Smc(mr) is ceil(mr N) / N (no ties among random heights)
    expected = np.maximum(1, np.ceil(curve.material_ratio.values * n - 1e-9)) / n
    np.testing.assert_allclose(ratio.values, expected, rtol=EXACT)
    default = topo.rough.material_ratio()
    assert default.values[0] == 1.0 and default.values[-1] == pytest.approx(1 / n)
    assert default.height.attrs["units"] == "nm" and default.attrs["units"] == "1"


# --------------------------------------------------------------------- scale dependence


@pytest.mark.parametrize("kind", ["open", "periodic", "missing", "profile", "non-square"])
def test_scale_dependent_values_at_one_pixel_are_the_parameters(kind):
    topo = {"open": _map(), "periodic": _map(periodic=True),
            "missing": _map(nan=((3, 3), (slice(10, 12), 5))),
            "profile": _map(shape=(300,)),
            "non-square": _map(spacing=("2.5 nm", "2 nm"))}[kind]
    p = topo.rough.parameters()
    s = topo.rough.scale_dependent_slope()
    c = topo.rough.scale_dependent_curvature()
    slope = p.Rdq if kind == "profile" else p.Sdq
    assert float(s[0]) == pytest.approx(float(slope), rel=EXACT, abs=0)
    assert float(c[0]) == pytest.approx(float(p.rms_curvature), rel=EXACT, abs=0)
    assert s.dr.attrs["units"] == "nm" and int(s.step_x[0]) == 1
    assert np.all(np.diff(s.dr) > 0) and s.dr[-1] <= 0.25 * min(grid_of(topo).size)


def test_non_square_pixels_take_the_nearest_step_per_axis():
    topo = _map(shape=(40, 90), spacing=("5 nm", "2 nm"))
    s = topo.rough.scale_dependent_slope(dr=[2.0, 4.0, 10.0, 20.0])
    assert s.step_x.values.tolist() == [1, 2, 5, 10]
    assert s.step_y.values.tolist() == [1, 1, 2, 4]


def test_rms_slope_at_step_dr_is_sqrt_2G_over_dr():
    # the same pairs: G (FFT estimator, every pair of valid points dr apart) and the
    # differences at step dr; exact up to round-off
    line = _map(shape=(400,), nan=((17,), (slice(30, 33),)))
    G = line.rough.acf(bins="linear", dr_max=60.0)
    s = line.rough.scale_dependent_slope(dr=G.dr)
    np.testing.assert_allclose(s.values, np.sqrt(2 * G.values) / G.dr.values, rtol=EXACT)
    np.testing.assert_array_equal(s.pair_count.values, G.pair_count.values)
    topo = _map(nan=((5, 6),))
    Gx = topo.rough.acf(bins="linear", direction="x", dr_max=20.0)
    Gy = topo.rough.acf(bins="linear", direction="y", dr_max=20.0)
    s2 = topo.rough.scale_dependent_slope(dr=Gx.dr)
    np.testing.assert_allclose(s2.values**2, 2 * (Gx.values + Gy.values) / Gx.dr.values**2,
                               rtol=EXACT)


def test_rms_curvature_of_a_periodic_profile_is_8G_minus_2G():
    line = _map(shape=(256,), periodic=True)
    G = line.rough.acf(bins="linear", dr_max=64.0)
    dr = G.dr.values[:16]
    c = line.rough.scale_dependent_curvature(dr=dr)
    expected = np.sqrt(8 * G.values[:16] - 2 * G.sel(dr=2 * dr).values) / dr**2
    np.testing.assert_allclose(c.values, expected, rtol=1e-10)  # G^(1/2) of a difference


def test_scale_dependent_slope_beside_gbar():
    # an isotropic periodic surface: the map's rms slope at step dr, sqrt(2 [G_x + G_y]) /
    # dr, is the ballistic gbar sqrt(4 G) / dr of the radial G to within the anisotropy
    # of one realisation (measured 1.3 %; 10 % allowed)
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="1 um", lambda_s="40 nm",
                                      size="2 um", n=256, rms_gradient=0.3, seed=2,
                                      unit="nm")
    s = topo.rough.scale_dependent_slope()
    G = topo.rough.acf(bins="linear", dr_max=2 * float(s.dr[-1]))
    gbar = G.rough.gradient(method="simple")
    assert gbar.attrs["units"] == s.attrs["units"] == "1"
    np.testing.assert_allclose(s.values[1:], gbar.interp(dr=s.dr).values[1:], rtol=0.1)


# ---------------------------------------------------------------------------- tip check


def _bumps(amplitude):
    x = np.arange(512) * 2.0  # nm
    return xrough.topography(amplitude * np.sin(2 * np.pi * x / 64.0), spacing=2.0,
                             unit="nm", periodic=True)


def test_tip_check_fires_beyond_one_over_R_and_not_on_a_smooth_surface():
    R = 20.0  # nm; rms curvature of A sin(q x) at small steps: A q^2 / sqrt 2
    sharp, smooth = _bumps(10.0), _bumps(0.5)  # 0.068 nm-1 > 1/R = 0.05, and 0.0034
    with pytest.warns(xrough.QualityWarning, match="curvature beyond the tip"):
        c = sharp.rough.scale_dependent_curvature(tip_radius=R)
    assert c.attrs["quality"] == "questionable" and int(c.quality_flag) == 1
    assert c.beyond_tip[0] == 2 and c.attrs["tip_radius"] == R
    assert c.attrs["tip_radius_units"] == "nm" and c.attrs["tip_radius_source"] == "given"
    assert "exceeds 1/R at dr = " in c.attrs["quality_notes"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ok = smooth.rough.scale_dependent_curvature(tip_radius=f"{R} nm")
    assert ok.attrs["quality"] == "good" and not ok.beyond_tip.any()
    assert "no scale is curved beyond it" in ok.attrs["quality_remarks"]
    # the tail alone: rms 0.0034 nm-1 below 1/R, but the most negative 0.0048 below -0.5/R
    plain = smooth.rough.scale_dependent_curvature()
    tail = _quiet(plain.rough.tip_check, tip_radius="200 nm")
    assert tail.beyond_tip.values[0] == 1 and tail.attrs["quality"] == "questionable"
    with pytest.raises(ValueError, match="already checked against a tip of radius 200 nm"):
        tail.rough.tip_check(tip_radius="10 nm")


def test_tip_check_reads_the_radius_the_file_states():
    sharp = _bumps(10.0).assign_attrs(Stylus="Radius: 0.02 µm")
    with pytest.warns(xrough.QualityWarning):
        c = sharp.rough.scale_dependent_curvature()
    assert c.attrs["tip_radius"] == 20.0
    assert c.attrs["tip_radius_source"] == "stated in the file (attr 'Stylus')"
    plain = sharp.rough.scale_dependent_curvature(stated_tip=False)
    assert "beyond_tip" not in plain.coords and "tip_radius" not in plain.attrs


def test_tip_check_of_a_lazy_stack_flags_each_map():
    stack = xr.concat([_bumps(10.0), _bumps(0.5)], dim="scan")
    with computes_nothing():
        lazy = stack.chunk({"scan": 1}).rough.scale_dependent_curvature(tip_radius=20.0)
    assert lazy.beyond_tip.chunks is not None
    assert lazy.quality_flag.compute().values.tolist() == [1, 0]
    assert xrough.quality.worst(lazy) == "questionable"


# ------------------------------------------------------------------------------ archive


def test_archive_round_trip_is_identical(tmp_path):
    stack = _stack()
    line = _map(shape=(300,)).assign_attrs(Stylus="Radius: 0.01 um")
    results = {
        "parameters": stack.rough.parameters(),
        "profile_parameters": line.rough.parameters(sampling_lengths=5),
        "heights": stack.rough.height_distribution(bins=np.linspace(-6, 6, 13)),
        "slopes": stack.rough.slope_distribution(direction="y", bins=10),
        "bearing": stack.rough.bearing_area_curve(),
        "ratio": stack.rough.material_ratio(height=[0.0, 1.0]),
        "slope": stack.rough.scale_dependent_slope(),
        "curvature": _quiet(line.rough.scale_dependent_curvature),
    }
    assert "beyond_tip" in results["curvature"].coords
    path = xrough.save_analysis(tmp_path / "parameters.nc", results)
    back = xrough.open_analysis(path)
    for name, obj in results.items():
        xr.testing.assert_identical(back[name], obj)


def test_results_carry_the_provenance_of_the_topography():
    topo = _map().assign_attrs(source_file="scan.x3p", source_sha256="ab" * 32,
                               instrument="AFM")
    for name, call in CALLS.items():
        out = _quiet(call, topo)
        for key in ("source_file", "source_sha256", "instrument", "xrough_version"):
            assert key in out.attrs, (name, key)
        coords = [c for c in out.coords if c in out.dims or c.startswith("step_")]
        assert all("units" in out[c].attrs for c in coords), name
    s = topo.rough.scale_dependent_slope(dr=["2 nm", "0.004 um"])
    assert s.dr.values.tolist() == [2.0, 4.0] and s.dr.attrs["units"] == "nm"


def test_accessor_methods_are_the_functions():
    topo = _map()
    assert topo.rough.parameters.__wrapped__ is par.roughness_parameters
    for name in ("height_distribution", "slope_distribution", "curvature_distribution",
                 "bearing_area_curve", "material_ratio", "scale_dependent_slope",
                 "scale_dependent_curvature", "tip_check"):
        assert getattr(topo.rough, name).__wrapped__ is getattr(par, name)
        assert getattr(xrough, name) is getattr(par, name)
    assert xrough.roughness_parameters is par.roughness_parameters


# -------------------------------------------------------------- SurfaceTopography, data


def _real_cases():
    from test_real_data import CASES

    keep = ("x3p-2", "sdf-1", "sur-2", "di-1", "spot_1-1000nm", "plu-1", "opd-1", "mi-1",
            "nid-1", "al3d-1", "xyz-1", "matrix-3", "dektak-1", "xy-1", "nonuniform",
            "uncd-AFM", "uncd-stylus", "uncd-TEM")
    return [pytest.param(CASES[name], id=name) for name in keep]


@pytest.mark.data
@pytest.mark.parametrize("case", _real_cases())
def test_agrees_with_surface_topography(case):
    ST = pytest.importorskip("SurfaceTopography")
    topo = xrough.open_topography(data_path(*case.parts), **case.open)
    topo = topo.rough.detrend(mode="plane")
    grid = grid_of(topo)
    f = xrough.units.conversion_factor(grid.height_unit, grid.lateral_unit)
    h = topo.values * f  # SurfaceTopography has one unit for heights and positions
    p = topo.rough.parameters()
    complete = not np.isnan(h).any()
    if h.ndim == 1:
        st = ST.UniformLineScan(np.ma.masked_invalid(h), physical_sizes=h.size * grid.spacing[0])
        np.testing.assert_allclose(float(p.Rq) * f, st.Rq(), rtol=ST_RTOL)
        np.testing.assert_allclose(float(p.Rdq), st.Rdq(), rtol=ST_RTOL)
        np.testing.assert_allclose(float(p.rms_curvature), st.Rddq(), rtol=ST_RTOL)
        return
    (ny, nx), (dy, dx) = h.shape, grid.spacing
    st = ST.Topography(np.ma.masked_invalid(h).T, physical_sizes=(nx * dx, ny * dy))
    np.testing.assert_allclose(float(p.Sq) * f, st.Sq(), rtol=ST_RTOL)
    if not complete:
        # its linear interpolation makes 0 x NaN of a missing neighbour's weight: it
        # drops the stencils next to missing points too (docs/parameters.md)
        return
    np.testing.assert_allclose(float(p.rms_curvature), st.rms_curvature_from_area(),
                               rtol=ST_RTOL)
    # the same corner stencil gives its rms gradient; Sdq averages over all pairs
    sy, sx = fd.gradient(h, steps=(1, 1), spacing=(dy, dx), periodic=False)
    np.testing.assert_allclose(np.sqrt(np.mean(sx**2 + sy**2)), st.rms_gradient(),
                               rtol=ST_RTOL)
    np.testing.assert_allclose(float(p.Sdq), st.rms_gradient(), rtol=4 / min(nx, ny))


def test_median_and_mad_height():
    """SurfaceTopography's test_median_and_mad: on nearly Gaussian heights the median is
    the mean and the MAD height the rms height (their atol 1e-5 on a 2048² map with
    heights of rms ~2e-3; here 3 % of Sq on 512²: measured 1.2 %, the heights of one map
    of a correlated surface being only nearly Gaussian); heights skewed by exp(): mean
    above median, Sq above the MAD height. Both against numpy's median directly, and
    spikes move Sq but not the MAD height."""
    topo = xrough.self_affine_surface(hurst=0.1, n=512, size="1 um", lambda_r="1 um",
                                      lambda_s="4 nm", rms_gradient=0.1, unit="nm", seed=3)
    p = topo.rough.parameters()
    h = topo.values
    assert float(p.median_height) == pytest.approx(np.median(h), rel=1e-12)
    assert float(p.mad_height) == pytest.approx(
        1.482602218505602 * np.median(np.abs(h - np.median(h))), rel=1e-12)
    assert abs(float(p.median_height) - float(h.mean())) < 0.01 * float(p.Sq)
    assert float(p.mad_height) == pytest.approx(float(p.Sq), rel=0.03)
    skewed = topo.copy(data=np.exp(h / float(p.Sq) / 2))
    q = skewed.rough.parameters()
    assert float(skewed.mean()) > float(q.median_height) and float(q.Sq) > float(q.mad_height)
    spiked = topo.copy()
    spiked[::50, ::50] = 100 * float(p.Sq)
    r = spiked.rough.parameters()
    assert float(r.Sq) > 2 * float(p.Sq)  # 121 spikes of 100 Sq: sqrt(1 + 4.6)
    assert float(r.mad_height) == pytest.approx(float(p.mad_height), rel=0.01)


def test_scale_dependent_statistic():
    """SurfaceTopography's scale_dependent_statistical_property, ported: with whole pixels
    var(d_x) of a periodic map is 2 G_x(dr) / dr^2 less the squared mean slope (exact, the
    same pairs); a scalar distance gives a scalar, the same as in a list; at fractional
    distances a sinusoid's interpolated slope variance within 1 % of the exact one
    (interpolation error ~ (k d)^2 / 8 at 0.25 of the wavelength); below the pixel NaN."""
    topo = xrough.self_affine_surface(hurst=0.8, n=256, size="1 um", lambda_r="250 nm",
                                      lambda_s="8 nm", rms_gradient=0.1, unit="nm", seed=2)
    Gx = topo.rough.acf(bins="linear", direction="x", dr_max=100)
    picks = Gx.dr.values[::20]
    s = topo.rough.scale_dependent_statistic(lambda dx, dy: np.mean(dx * dx), dr=picks)
    np.testing.assert_allclose(s, 2 * Gx.sel(dr=picks).values / picks**2, rtol=1e-10)
    one = topo.rough.scale_dependent_statistic(lambda dx, dy: np.var(dx), dr="39.0625 nm")
    many = topo.rough.scale_dependent_statistic(lambda dx, dy: np.var(dx),
                                                dr=[3.90625, 39.0625, 390.625])
    assert one.ndim == 0 and float(one) == pytest.approx(float(many[1]), rel=1e-12)
    x = np.arange(1024) * 1.0
    wave = xrough.topography(np.sin(2 * np.pi * x / 128), spacing=1.0, unit="nm",
                             periodic=True)
    d = np.array([2.5, 7.3, 16.5])
    got = wave.rough.scale_dependent_statistic(np.var, dr=d, units="1")
    exact = 2 * (1 - np.cos(2 * np.pi * d / 128)) / d**2 / 2  # var of (sin(k(x+d))-sin kx)/d
    np.testing.assert_allclose(got, exact, rtol=0.01)
    assert got.attrs["units"] == "1" and got.dr.attrs["units"] == "nm"
    assert np.isnan(float(wave.rough.scale_dependent_statistic(np.var, dr=0.5)))
    curv = wave.rough.scale_dependent_statistic(lambda c: np.sqrt(np.mean(c * c)), order=2,
                                                dr=[1.0, 8.0])
    np.testing.assert_allclose(curv, wave.rough.scale_dependent_curvature(dr=[1.0, 8.0]),
                               rtol=1e-10)
    with pytest.raises(ValueError, match="order"):
        wave.rough.scale_dependent_statistic(np.var, order=3)


def test_continuous_material_ratio():
    """SurfaceTopography's test_bearing_area_nonuniform on xrough's grid: a triangle wave
    (2048 points, height 0.1) has the bearing area 1 - c / h_max, here within 1e-3 (theirs)
    with method='linear' (measured < 1e-12 off the grid points' kinks); the ISO point
    count is within one point; a map's linear ratio lies within its bounds, and equals
    the point count where the heights step by less than the levels do."""
    n, hm = 2048, 0.1
    tri = hm * (1 - np.abs(np.linspace(-1, 1, n)))
    line = xrough.topography(tri, spacing=1.0, unit="nm")
    c = np.linspace(0, hm, 101)
    levels = c - tri.mean()
    got = line.rough.material_ratio(height=levels, method="linear")
    np.testing.assert_allclose(got, 1 - c / hm, atol=1e-3)
    pts = line.rough.material_ratio(height=levels)
    np.testing.assert_allclose(pts, 1 - c / hm, atol=2 / n)
    assert "material_ratio_lower" in got.coords
    topo = xrough.self_affine_surface(hurst=0.8, n=64, size="64 nm", lambda_r="32 nm",
                                      lambda_s="2 nm", rms_gradient=0.1, unit="nm", seed=4)
    m = topo.rough.material_ratio(method="linear")
    assert np.all(m.material_ratio_lower <= m + 1e-12) and np.all(m <= m.material_ratio_upper
                                                                   + 1e-12)
    assert float(m[0]) == 1.0 and float(m[-1]) == pytest.approx(0.0, abs=1e-3)
    assert np.all(np.diff(m) <= 1e-12)  # falls with the height
    with pytest.raises(ValueError, match="method"):
        topo.rough.material_ratio(method="spline")
