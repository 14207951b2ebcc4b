"""Stitching as one lazy graph: a DataTree of file-backed stacks (xrough.stitching).

Three instruments, each a stack of scans in a NetCDF file opened with one scan per chunk,
stitched as ``tree.rough.acf()``: the G is dask-backed, building it runs no graph,
computing it runs one, and no task computes a graph of its own (a nested compute would
run the scheduler from inside a task). The computed G equals the eager stitch of the
same maps in memory to 1e-12 (the same kernels on the same numbers; only the scheduling
differs), and the contact chain after it stays lazy.
"""

from __future__ import annotations

import threading
import warnings

import dask
import dask.threaded
import numpy as np
import pytest
import xarray as xr
from dask_counting import CountingScheduler
from invariance_support import assert_attrs_close

import xrough
from xrough.stitching import STITCH_DIAGNOSTICS, stitch

#: (name, pixel size in nm, pixels per side, scans, unit)
INSTRUMENTS = (("tem", 1.0, 48, 3, "nm"), ("afm", 4.0, 48, 2, "nm"),
               ("optical", 0.008, 56, 2, "um"))


class NoNesting(CountingScheduler):
    """A counting threaded scheduler that fails a compute started inside a running one."""

    def __init__(self) -> None:
        super().__init__()
        self._running = threading.Event()
        self.nested = 0

    def __call__(self, dsk, keys, **kwargs):
        if self._running.is_set():
            self.nested += 1
            raise RuntimeError("a graph was computed inside a task of another")
        self._running.set()
        try:
            return super().__call__(dsk, keys, **kwargs)
        finally:
            self._running.clear()


@pytest.fixture(scope="module")
def stacks():
    """Stacks of open maps of one self-affine surface at three resolutions, in memory."""
    surface = xrough.self_affine_surface(hurst=0.8, lambda_r="100 nm", lambda_s="4 nm",
                                         size="512 nm", n=512, rms_height="2 nm", seed=4,
                                         unit="nm")
    h = surface.values
    rng = np.random.default_rng(2)
    out = {}
    for name, pixel, n, scans, unit in INSTRUMENTS:
        step = int(round(pixel * (1000 if unit == "um" else 1)))
        maps = []
        for _ in range(scans):
            y0, x0 = rng.integers(0, 512 - n * step, size=2)
            block = h[y0:y0 + n * step, x0:x0 + n * step]
            maps.append(block.reshape(n, step, n, step).mean(axis=(1, 3)))
        f = 1e-3 if unit == "um" else 1.0
        x = np.arange(n) * pixel
        out[name] = xr.DataArray(np.stack(maps) * f, dims=("scan", "y", "x"),
                                 coords={"y": ("y", x, {"units": unit}),
                                         "x": ("x", x, {"units": unit})},
                                 attrs={"units": unit, "periodic": 0}, name="h")
    return out


@pytest.fixture(scope="module")
def file_tree(stacks, tmp_path_factory):
    """The stacks as a DataTree of NetCDF files opened lazily, one scan per chunk."""
    folder = tmp_path_factory.mktemp("instruments")
    nodes = {}
    for name, da in stacks.items():
        path = folder / f"{name}.nc"
        da.to_dataset().to_netcdf(path)
        nodes[name] = xr.open_dataset(path, chunks={"scan": 1})
    return xr.DataTree.from_dict(nodes)


def _quiet(func, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return func(*args, **kwargs)


def test_datatree_stitch_is_one_lazy_graph(stacks, file_tree):
    scheduler = NoNesting()
    with dask.config.set(scheduler=scheduler):
        G = _quiet(file_tree.rough.acf, points_per_decade=8)
        built = scheduler.calls
        assert G.chunks is not None and G.standard_error.chunks is not None
        assert G.quality_flag.chunks is not None
        got = G.compute()
    assert built == 0, f"building the stitched G ran {built} graph(s)"
    assert scheduler.calls == 1 and scheduler.nested == 0
    ref = _quiet(stitch, xr.DataTree.from_dict({k: v.to_dataset() for k, v in
                                                stacks.items()}), points_per_decade=8)
    xr.testing.assert_allclose(got, ref, rtol=1e-12, atol=0)
    assert_attrs_close({k: v for k, v in got.attrs.items() if k not in STITCH_DIAGNOSTICS},
                       {k: v for k, v in ref.attrs.items() if k not in STITCH_DIAGNOSTICS},
                       rtol=1e-12)
    assert int(got.quality_flag) == int(ref.quality_flag)
    assert got.attrs["stitched_from"] == "tem, afm, optical"


def test_eager_stitch_computes_once_without_nesting(stacks):
    """Maps in memory: the per-measurement G run in one graph (parallel threads)."""
    scheduler = NoNesting()
    with dask.config.set(scheduler=scheduler):
        G = _quiet(stitch, stacks, points_per_decade=8)
    assert G.chunks is None
    assert scheduler.calls == 1 and scheduler.nested == 0
    serial = _quiet(stitch, stacks, points_per_decade=8, parallel=False)
    xr.testing.assert_allclose(G, serial, rtol=1e-12, atol=0)
    assert_attrs_close(G.attrs, serial.attrs, rtol=1e-12)


def test_contact_chain_after_a_lazy_stitch_stays_lazy(file_tree):
    scheduler = NoNesting()
    with dask.config.set(scheduler=scheduler):
        G = _quiet(file_tree.rough.acf, points_per_decade=8)
        P = _quiet(G.rough.persson, E_star="25 MPa", p0="1 MPa", gradient_method="simple")
        E = _quiet(G.rough.energy, E_star="25 MPa")
        assert scheduler.calls == 0
        assert all(P[v].chunks is not None for v in P.data_vars)
        a_r, v_el = dask.compute(P.a_r, E.v_el)  # two results of one G, one graph
    assert scheduler.calls == 1 and scheduler.nested == 0
    eager = G.compute()
    ref = _quiet(xrough.persson, eager, E_star="25 MPa", p0="1 MPa",
                 gradient_method="simple")
    xr.testing.assert_allclose(a_r, ref.a_r, rtol=1e-12, atol=0)


def test_diagnostics_of_a_lazy_stitch_come_from_its_curves(stacks, file_tree):
    """What the values decide (level factors, mismatch) is absent from a lazy G's attrs
    and computed from its curves on request, equal to the eager attrs."""
    G = _quiet(file_tree.rough.acf, points_per_decade=8)
    assert not set(STITCH_DIAGNOSTICS[:5]) & set(G.attrs)
    curves = _quiet(file_tree.rough.stitch_curves, points_per_decade=8)
    assert curves.G.chunks is not None
    factors, errors = xrough.stitching.level_factors(curves, with_errors=True)
    ref = _quiet(stitch, stacks, points_per_decade=8)
    np.testing.assert_allclose(factors, ref.attrs["level_factors"], rtol=1e-12)
    np.testing.assert_allclose(errors, ref.attrs["level_factor_errors"], rtol=1e-12)


def test_lazy_precomputed_G_in_pieces_mixed_with_a_map_in_memory():
    """A precomputed G chunked along dr stitched with a topography in memory: lazy, and
    equal to the stitch of the same inputs in memory."""
    topo = xrough.self_affine_surface(hurst=0.7, lambda_r="2 um", lambda_s="40 nm",
                                      size="8 um", n=1024, rms_height="10 nm",
                                      profile=True, seed=3, unit="nm")
    fine = topo.isel(x=slice(0, 256)).assign_attrs(periodic=0)
    coarse = topo.isel(x=slice(None, None, 4))
    G_fine = xrough.height_difference_acf(fine)
    ref = _quiet(stitch, {"fine": G_fine, "coarse": coarse})
    scheduler = NoNesting()
    with dask.config.set(scheduler=scheduler):
        got = _quiet(stitch, {"fine": G_fine.chunk(dr=5), "coarse": coarse})
        assert got.chunks is not None and scheduler.calls == 0
        got = got.compute()
    assert scheduler.calls == 1 and scheduler.nested == 0
    xr.testing.assert_allclose(got, ref, rtol=1e-12, atol=0)
