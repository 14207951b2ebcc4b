"""Scaling out: distributed schedulers, lazy graphs and the out-of-core tiled estimator."""

import numpy as np
import pytest
import xarray as xr
from dask_counting import CountingArray, computes_nothing

import xrough
from xrough.correlation import height_difference_acf_tiled


def _stack(n_scans=4, shape=(48, 40), seed=0):
    rng = np.random.default_rng(seed)
    maps = rng.normal(size=(n_scans,) + shape) + 3.0
    maps[rng.random(maps.shape) < 0.2] = np.nan
    base = xrough.topography(maps[0], spacing=1.0, unit="nm")
    return xr.DataArray(maps, dims=("scan", "y", "x"),
                        coords={"scan": np.arange(n_scans), **{k: base[k] for k in "xy"}},
                        attrs=base.attrs, name="height")


def _masked_surface(n=1024, lambda_r=200.0, seed=1):
    topo = xrough.synthetic.self_affine_surface(hurst=0.8, lambda_r=lambda_r, lambda_s=4,
                                                size=n, n=n, rms_height=1.0, unit="nm",
                                                seed=seed)
    h = topo.values.copy()
    rng = np.random.default_rng(seed + 1)
    h[rng.random(h.shape) < 0.1] = np.nan
    h[100:140, 300:700] = np.nan  # a dead band crossing tile borders
    return xrough.topography(h, spacing=1.0, unit="nm", periodic=False)


def test_graph_construction_does_not_compute():
    stack = _stack().chunk({"scan": 1})
    topo = _masked_surface(n=256).chunk({"y": 100, "x": 90})
    with computes_nothing():
        G = stack.rough.acf()
        Gr = stack.rough.acf(estimator="random", n_pairs=1000, seed=0)
        Gt = height_difference_acf_tiled(topo, tile=64, halo=64, factor=4,
                                         min_lag_cells=8)
    assert G.chunks is not None and Gr.chunks is not None and Gt.chunks is not None


def test_stack_same_g_threads_distributed_numpy():
    """One task per scan gives the same G on threads, on worker processes and in numpy.

    Tolerance 1e-12 relative: the same kernel runs on the same data; only the scheduler
    changes (bitwise equality is expected, the tolerance allows another BLAS/FFT thread
    split).
    """
    distributed = pytest.importorskip("distributed")
    import dask

    stack = _stack()
    ref = stack.rough.acf()
    lazy = stack.chunk({"scan": 1}).rough.acf()
    assert lazy.chunks is not None
    with dask.config.set(scheduler="threads"):
        threaded = lazy.compute()
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        on_cluster = lazy.compute()
        topo = _masked_surface(n=256).chunk({"y": 128, "x": 128})
        tiled_cluster = height_difference_acf_tiled(topo, tile=64, halo=64, factor=4,
                                                    min_lag_cells=8).compute()
        assert client.run(lambda: 1)  # really ran on the worker processes
    tiled_local = height_difference_acf_tiled(topo.compute(), tile=64, halo=64, factor=4,
                                              min_lag_cells=8)
    for got in (threaded, on_cluster):
        xr.testing.assert_allclose(got, ref, rtol=1e-12, atol=0)
        np.testing.assert_array_equal(got.pair_count.values, ref.pair_count.values)
    xr.testing.assert_allclose(tiled_cluster, tiled_local, rtol=1e-12, atol=0)


@pytest.mark.parametrize("lambda_r", [200.0, 40.0])
def test_tiled_equals_fft_within_halo_and_stated_error_beyond(lambda_r):
    """Exact (1e-10) for bins within the halo, relative error < 1e-3 beyond (min_lag_cells=16).

    The exact bins carry the round-off of two differently ordered FFT sums (~1e-14
    measured). Beyond the halo a level of b-point blocks files each pair at the lag of its
    blocks; within bins of lags >= 16 blocks the measured error is 2e-4 (b = 4) to 8e-4
    (b = 16) for lambda_r = 200 and similar for the knee at lambda_r = 40.
    """
    topo = _masked_surface(lambda_r=lambda_r)
    ref = topo.rough.acf()
    G = height_difference_acf_tiled(topo, tile=256, halo=96, factor=4, min_lag_cells=16)
    assert G.chunks is None
    np.testing.assert_allclose(G.dr.values, ref.dr.values, rtol=1e-12)
    exact = G.block.values == 1
    assert exact.sum() >= 15 and (~exact).sum() >= 8
    assert G.dr.values[exact].max() <= 96 * np.sqrt(2)
    np.testing.assert_allclose(G.values[exact], ref.values[exact], rtol=1e-10, atol=0)
    np.testing.assert_array_equal(G.pair_count.values[exact], ref.pair_count.values[exact])
    np.testing.assert_allclose(G.values[~exact], ref.values[~exact], rtol=1e-3, atol=0)
    # the coarse levels sum all pairs too, filed by block lag: counts within 2 %
    np.testing.assert_allclose(G.pair_count.values, ref.pair_count.values, rtol=0.02)
    assert G.attrs["units"] == ref.attrs["units"] == "nm2"
    assert G.dr.attrs["units"] == "nm"


def test_tiled_dask_backed_chunks_equal_numpy():
    """Chunks that do not align with tiles or blocks give the same numbers (1e-12)."""
    topo = _masked_surface(n=512)
    kw = dict(tile=128, halo=96, factor=4, min_lag_cells=16, dr_max=400)
    ref = height_difference_acf_tiled(topo, **kw)
    lazy = height_difference_acf_tiled(topo.chunk({"y": 100, "x": 170}), **kw)
    assert lazy.chunks is not None
    xr.testing.assert_allclose(lazy.compute(), ref, rtol=1e-12, atol=0)
    assert ref.dr.max() <= 400


def test_tiled_single_level_is_all_exact():
    topo = _masked_surface(n=256)
    ref = topo.rough.acf(dr_max=60)
    G = height_difference_acf_tiled(topo, tile=100, halo=64, dr_max=60)
    assert (G.block == 1).all()
    np.testing.assert_allclose(G.values, ref.values, rtol=1e-10, atol=0)


def test_tiled_refuses_what_it_cannot_do():
    topo = _masked_surface(n=256)
    with pytest.raises(ValueError, match="halo=16 is too small"):
        height_difference_acf_tiled(topo, halo=16)
    with pytest.raises(ValueError, match="open maps"):
        height_difference_acf_tiled(topo.assign_attrs(periodic=1))
    with pytest.raises(ValueError, match="one map"):
        height_difference_acf_tiled(_stack())
    with pytest.raises(ValueError, match="bin_width"):
        height_difference_acf_tiled(topo, bin_width=2)


def test_auto_estimator_takes_the_tiled_path_for_chunked_maps():
    """A map split into dask chunks in y/x is computed tile by tile, lazily, by default."""
    rng = np.random.default_rng(5)
    topo = xrough.topography(rng.normal(size=(256, 256)), spacing=1.0, unit="nm")
    chunked = topo.chunk({"y": 128, "x": 128})
    G = chunked.rough.acf(dr_max="64 nm")
    assert G.chunks is not None
    exact = topo.rough.acf(dr_max="64 nm")
    np.testing.assert_allclose(G.compute().values, exact.values, rtol=1e-3)
    assert topo.rough.acf().attrs["estimator"] == "fft (all pairs)"


def _counted_topography(h, chunk):
    import dask.array as dsa

    src = CountingArray(h)
    ref = xrough.topography(h, spacing=1.0, unit="nm", periodic=False)
    data = dsa.from_array(src, chunks=chunk, meta=np.empty((0, 0)))
    return ref.copy(data=data), ref, src


def _tile_sums_held(G):
    """Compute ``G`` on one thread; the most tile lag sums (and partial sums of them) held
    at once, and the number of tiles."""
    import dask
    from dask.callbacks import Callback

    def is_sum(key):
        return "tiled-g-tile-sums" in str(key[0] if isinstance(key, tuple) else key)

    class Held(Callback):
        most = 0

        def _posttask(self, key, result, dsk, state, worker_id):
            if is_sum(key):
                Held.most = max(Held.most, sum(map(is_sum, state["cache"])))

    with dask.config.set(scheduler="sync"), Held():
        got = G.compute()
    return got, Held.most


# map of m x m chunks of 128 points, tile = chunk, halo 32: levels 0 and 1 share their
# tiles (the halo of level 1 is 32 blocks of 4 points = one chunk), block levels beyond
_KW = dict(tile=128, halo=32, factor=4, min_lag_cells=4)


@pytest.mark.parametrize("m", [4, 8])
def test_tiled_reads_each_chunk_once_and_sums_as_it_goes(m):
    """Each chunk of the input is read exactly once (counted by the array itself, whatever
    dask's graph optimisations do); the tiles' lag sums are added as the map is swept (a
    tree along each row of tiles, then over the rows: at most about two rows of tiles'
    sums held at once, not all of them); the numbers equal those of the map in memory."""
    rng = np.random.default_rng(m)
    h = rng.normal(size=(128 * m, 128 * m))
    h[rng.random(h.shape) < 0.1] = np.nan
    topo, ref, src = _counted_topography(h, 128)
    G = height_difference_acf_tiled(topo, **_KW)
    assert sorted(set(G.block.values))[:3] == [1, 4, 16]  # shared levels 0-1, and beyond
    assert src.reads == {}  # building the graph read nothing
    got, held = _tile_sums_held(G)
    assert len(src.reads) == m * m
    assert set(src.reads.values()) == {1}
    assert held <= 2 * m + 8 < m * m + 8
    xr.testing.assert_allclose(got, height_difference_acf_tiled(ref, **_KW), rtol=1e-12,
                               atol=0)


def test_tiled_graph_grows_linearly_with_the_chunks():
    """Tasks per chunk stay bounded (dask's overlap: halo strips and their joins, one task
    per tile for levels 0 and 1, trees of sums, the block levels beyond): the graph of a
    map of m x m chunks has at most 20 m^2 + 400 tasks, reads included."""
    tasks = {}
    for m in (4, 8, 16):
        topo, _, _ = _counted_topography(np.zeros((128 * m, 128 * m)), 128)
        tasks[m] = len(height_difference_acf_tiled(topo, **_KW).data.__dask_graph__())
        assert tasks[m] <= 20 * m * m + 400, tasks
    assert tasks[16] - tasks[8] <= 20 * (16**2 - 8**2), tasks


def test_tiled_shared_levels_equal_separate_levels_and_fft():
    """Levels 0 and 1 from one extended tile give the numbers of separate tiles per level
    (1e-12; the separate path runs for a tile that is no multiple of ``factor``) and of
    the in-memory FFT estimator within the halo (1e-10, the same pair counts)."""
    topo = _masked_surface(n=640)
    kw = dict(tile=256, halo=64, factor=4, min_lag_cells=8)
    G = height_difference_acf_tiled(topo, **kw)
    separate = height_difference_acf_tiled(topo, **dict(kw, tile=254))
    assert sorted(set(G.block.values)) == [1, 4, 16]
    xr.testing.assert_allclose(G, separate, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(G.pair_count.values, separate.pair_count.values)
    ref = topo.rough.acf()
    exact = G.block.values == 1
    np.testing.assert_allclose(G.values[exact], ref.values[exact], rtol=1e-10, atol=0)
    np.testing.assert_array_equal(G.pair_count.values[exact], ref.pair_count.values[exact])
    lazy = height_difference_acf_tiled(topo.chunk({"y": 100, "x": 170}), **kw).compute()
    xr.testing.assert_allclose(lazy, G, rtol=1e-12, atol=0)


def test_tiled_chunk_scales_differ_by_far():
    """Chunks whose heights differ by 2^40 get their own scales; the sums meet exactly on
    the largest (relative 1e-10 against the in-memory FFT estimator within the halo, as
    for one scale), and an empty (all-NaN) chunk does not set the scale."""
    rng = np.random.default_rng(3)
    h = rng.normal(size=(256, 256)) * 1e-150
    h[:128, :128] *= 2.0**40
    h[128:, 128:] = np.nan
    topo = xrough.topography(h, spacing=1.0, unit="nm", periodic=False)
    ref = topo.rough.acf(dr_max=40)
    G = height_difference_acf_tiled(topo.chunk({"y": 128, "x": 128}), tile=128, halo=48,
                                    dr_max=40).compute()
    assert (G.block == 1).all()
    np.testing.assert_allclose(G.values, ref.values, rtol=1e-10, atol=0)
    np.testing.assert_array_equal(G.pair_count.values, ref.pair_count.values)
