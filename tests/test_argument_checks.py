"""Arguments that used to turn a result silently wrong are refused, naming the problem.

A switch is True or False (``periodic="no"`` marked a map periodic), a count a whole
number (``n=64.5`` gave 64 points), a threshold finite and above 0 (NaN, inf, 0 or -1 turned
the mismatch test off), a height scale finite and nonzero (0 erased every height), and a
file that is not an analysis archive is not opened as an empty one.
"""

import numpy as np
import pytest
import xarray as xr

import xrough
from xrough._kernels.checks import require_count, require_flag, require_positive


@pytest.mark.parametrize("value", ["no", "yes", "False", 2, -1, 0.5, None, np.nan])
def test_a_switch_is_true_or_false(value):
    with pytest.raises(ValueError, match="periodic must be True or False"):
        require_flag(value, "periodic")


@pytest.mark.parametrize("value, expected", [(True, True), (False, False), (1, True),
                                             (0, False), (np.bool_(True), True)])
def test_true_and_false_pass(value, expected):
    assert require_flag(value, "periodic") is expected


@pytest.mark.parametrize("value", [64.5, "64", True, -3, np.nan, None])
def test_a_count_is_a_whole_number(value):
    with pytest.raises(ValueError, match="n must be a whole number"):
        require_count(value, "n", minimum=2)


@pytest.mark.parametrize("value", [np.nan, np.inf, 0, -1, "3", True, None])
def test_a_threshold_is_finite_and_positive(value):
    with pytest.raises(ValueError, match="threshold must be a finite number above 0"):
        require_positive(value, "threshold")


def test_topography_and_open_refuse_a_string_for_periodic(tmp_path):
    h = np.random.default_rng(0).normal(size=(8, 8))
    with pytest.raises(ValueError, match="periodic must be True or False, got 'no'"):
        xrough.topography(h, spacing="1 nm", unit="nm", periodic="no")
    path = tmp_path / "t.npy"
    np.save(path, h)
    with pytest.raises(ValueError, match="periodic must be True or False, got 'no'"):
        xrough.open_topography(path, size="8 nm", unit="nm", periodic="no")
    assert xrough.open_topography(path, size="8 nm", unit="nm",
                                  periodic=True).attrs["periodic"] == 1


@pytest.mark.parametrize("scale", [0, 0.0, np.nan, np.inf, "2", True])
def test_open_refuses_a_height_scale_that_erases_or_garbles(tmp_path, scale):
    path = tmp_path / "t.npy"
    np.save(path, np.random.default_rng(0).normal(size=(8, 8)))
    with pytest.raises(ValueError, match="height_scale must be a finite nonzero factor"):
        xrough.open_topography(path, size="8 nm", unit="nm", height_scale=scale)


def test_open_scales_heights_by_a_valid_factor(tmp_path):
    path = tmp_path / "t.npy"
    h = np.random.default_rng(0).normal(size=(8, 8))
    np.save(path, h)
    topo = xrough.open_topography(path, size="8 nm", unit="nm", height_scale=-2)
    np.testing.assert_array_equal(topo.values, -2 * h)


@pytest.mark.parametrize("n", [64.5, "64", (64, 32.5)])
def test_synthetic_surface_refuses_a_fractional_or_string_size(n):
    with pytest.raises(ValueError, match="n \\(points per dim\\) must be a whole number"):
        xrough.self_affine_surface(hurst=0.8, lambda_r=16.0, lambda_s=4.0, size=64.0, n=n,
                                   rms_gradient=0.1, unit="nm")
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r=16.0, lambda_s=4.0, size=64.0,
                                      n=64.0, rms_gradient=0.1, unit="nm")
    assert topo.shape == (64, 64)


@pytest.mark.parametrize("threshold", [np.nan, np.inf, 0, -1])
def test_stitch_mismatch_refuses_a_threshold_that_turns_it_off(threshold):
    rng = np.random.default_rng(0)
    fine = xrough.topography(rng.normal(size=(64, 64)), spacing="1 nm", unit="nm")
    coarse = xrough.topography(rng.normal(size=(64, 64)), spacing="4 nm", unit="nm")
    curves = xrough.stitch_curves({"fine": fine, "coarse": coarse})
    with pytest.raises(ValueError, match="threshold must be a finite number above 0"):
        xrough.stitch_mismatch(curves, threshold=threshold)


def test_open_analysis_refuses_a_plain_netcdf(tmp_path):
    """It returned an empty analysis with a warning about checksums."""
    path = tmp_path / "plain.nc"
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_netcdf(path)
    with pytest.raises(ValueError, match="not an analysis archive of xrough.save_analysis"):
        xrough.open_analysis(path)


def _G():
    topo = xrough.topography(np.random.default_rng(0).normal(size=(16, 16)), spacing="1 nm",
                             unit="nm")
    return topo.rough.acf()


@pytest.mark.parametrize("bad, message", [
    (lambda G: G.isel(dr=slice(0, 0)), "has 0 lag"),
    (lambda G: G.isel(dr=slice(0, 1)), "has 1 lag"),
    (lambda G: G * np.nan, "is all NaN"),
    (lambda G: -G, "has negative values"),  # the rules of every G (check_acf)
])
def test_stitch_refuses_a_g_with_nothing_to_stitch(bad, message):
    """An empty G raised numpy's zero-size error; an all-NaN, negative or one-lag G was
    dropped without a word (its name stayed in stitched_from)."""
    G = _G()
    with pytest.raises(ValueError, match=f"measurement 'a': its G {message}"):
        xrough.stitch({"a": bad(G), "b": G})


def test_wrong_types_are_named():
    G = _G()
    with pytest.raises(TypeError, match="analysis must be a mapping"):
        xrough.save_analysis("never-written.nc", G)
    with pytest.raises(TypeError, match="curves must be the Dataset of xrough.stitch_curves"):
        xrough.stitch_mismatch(G)
    with pytest.raises(TypeError, match="path must be a file name"):
        xrough.open_topography(5)


def test_a_number_is_not_a_unit():
    topo = xrough.topography(np.zeros((4, 4)), spacing="1 nm", unit="nm")
    with pytest.raises(ValueError, match="'nan' is a number, not a unit"):
        xrough.convert_units(topo, "nan nm")


def test_a_spectrum_whose_moments_overflow_is_refused_at_once():
    """lambda_r = 1e300 nm raised an OverflowError from deep in the moments."""
    with pytest.raises(ValueError, match="overflow float64"):
        xrough.model_spectrum(hurst=0.8, lambda_r="1e300 nm", lambda_s="1 nm",
                              rms_gradient=0.1, unit="nm")


def test_a_synthetic_surface_beyond_memory_is_refused_before_allocating():
    """n = 10**6 ran into a MemoryError for 7.3 TiB."""
    with pytest.raises(ValueError, match="GiB to synthesise, more than this machine"):
        xrough.self_affine_surface(hurst=0.8, lambda_r=16.0, lambda_s=4.0, size=64.0,
                                   n=10**6, rms_gradient=0.1, unit="nm")
