"""Property tests: exactness on random grids and masks, NetCDF round trips, attrs options."""

import numpy as np
import pytest
import xarray as xr
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_correlation import brute_force_binned

import xrough
from xrough._kernels.binning import log_bin_edges
from xrough.testing import assert_netcdf_round_trip

maps = st.tuples(st.integers(2, 7), st.integers(2, 7), st.integers(0, 2**31 - 1),
                 st.floats(0.0, 0.6), st.booleans(), st.sampled_from([(1.0, 1.0),
                                                                       (0.5, 2.0)]))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(maps)
def test_fft_is_exact_on_random_grids_and_masks(case):
    """Any shape, spacing, periodicity and missing fraction: FFT sums == enumeration."""
    ny, nx, seed, missing, periodic, spacing = case
    rng = np.random.default_rng(seed)
    h = rng.normal(size=(ny, nx)) * 10 ** rng.uniform(-3, 3)
    h[rng.random(h.shape) < missing] = np.nan
    if np.isfinite(h).sum() < 2:
        h.flat[:2] = 1.0, 2.0
    topo = xrough.topography(h, spacing=spacing, unit="um", periodic=periodic)
    edges = log_bin_edges(0.4, 20.0, 6)
    G = topo.rough.acf(bins=edges)
    ref, n = brute_force_binned(h, spacing, periodic, edges)
    _, lattice = brute_force_binned(np.zeros(h.shape), spacing, periodic, edges)
    got = np.full(len(n), np.nan)
    got[lattice > 0] = G.values
    counts = np.zeros(len(n))
    counts[lattice > 0] = G.pair_count.values
    np.testing.assert_array_equal(counts, n)
    scale = np.nanmax(np.abs(h)) ** 2
    np.testing.assert_allclose(got[n > 0], ref[n > 0], rtol=1e-9, atol=1e-12 * scale)


@settings(max_examples=15, deadline=None)
@given(st.integers(1, 4), st.integers(1, 3), st.integers(0, 1000))
def test_dask_chunk_shapes_give_numpy_numbers(nscan, chunk, seed):
    rng = np.random.default_rng(seed)
    base = xrough.topography(np.zeros((10, 12)), spacing=1.0, unit="nm")
    stack = xr.DataArray(rng.normal(size=(nscan, 10, 12)), dims=("scan", "y", "x"),
                         coords={k: base[k] for k in "xy"}, attrs=base.attrs)
    a = stack.rough.acf()
    b = stack.chunk({"scan": chunk}).rough.acf().compute()
    xr.testing.assert_allclose(a, b, rtol=1e-13)
    xr.testing.assert_identical(a.drop_vars(["standard_error"]),
                                b.drop_vars(["standard_error"]))


@settings(max_examples=15, deadline=None)
@given(n=st.integers(2, 20), unit=st.sampled_from(["nm", "um", "m", "mm"]),
       periodic=st.booleans(), seed=st.integers(0, 1000))
def test_netcdf_round_trip_is_identical(tmp_path_factory, n, unit, periodic, seed):
    rng = np.random.default_rng(seed)
    h = rng.normal(size=(n, n + 1))
    h[0, 0] = np.nan
    topo = xrough.topography(h, spacing=0.3, unit=unit, periodic=periodic,
                             attrs={"instrument": "AFM", "note": "é ü"})
    path = tmp_path_factory.mktemp("nc") / "t.nc"
    for da in (topo, topo.rough.acf()):
        assert_netcdf_round_trip(da, path)


@pytest.mark.parametrize("keep_attrs", [True, False])
def test_output_units_do_not_depend_on_keep_attrs(keep_attrs):
    topo = xrough.topography(np.random.default_rng(0).normal(size=(16, 16)), spacing=1.0,
                             unit="um", height_unit="nm")
    with xr.set_options(keep_attrs=keep_attrs):
        G = topo.rough.acf()
        Gr = topo.rough.acf(estimator="random", n_pairs=1000, seed=0)
    for g in (G, Gr):
        assert g.attrs["units"] == "nm2"
        assert g.dr.attrs["units"] == "um"
        assert g.standard_error.attrs["units"] == "nm2"
        assert g.sampling_error.attrs["units"] == "nm2"
        assert g.pair_count.attrs["units"] == "1"
