"""Do the regions of a map agree? G of its four quarters against their finite-area error.

G's ``standard_error`` is the scatter between maps of a stationary Gaussian surface with
the spectrum of G (:func:`~xrough._kernels.uncertainty.finite_area_variance`). A measured
map need not be one: a band at the start of an AFM scan, a particle on a flat film, a
scratch, drift, a texture that changes across the scan. Then a second measurement of the
same surface differs from the first by far more than that error (the halves of the
instrument maps of the test data by up to 135 of their stated errors).

So the map is cut into its four quarters and G of each is formed on G's own bins, up to
:data:`WINDOW` of a quarter's shorter side (an open FFT of each quarter, padded by that
lag only: no errors, no second pass). Their scatter is compared with the Gaussian error
of a quarter, ``standard_error * sqrt(area ratio)``
(:func:`~xrough._kernels.uncertainty.regional_scatter`). Where it exceeds it beyond
:data:`~xrough._kernels.uncertainty.REGIONS_DISAGREE` in variance at some lag, G is
questionable (the regions disagree), and ``standard_error`` becomes the scatter of the
quarters' mean, the empirical error of a map of this size, wherever that is larger (the
coordinate ``error_inflation`` holds the factor; every result's errors follow it through
:func:`xrough.acf.error_model`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import xarray as xr

from .. import quality
from .._kernels.uncertainty import REGIONS_DISAGREE, regional_scatter
from ..acf import INFLATION
from ..topography import Grid

#: Lags judged: up to this fraction of a quarter's shorter side (a quarter holds few
#: independent pairs beyond it).
WINDOW = 0.25
#: A quarter needs at least this many pixels along each side to be judged.
MIN_SIDE = 16


def quarters(da: xr.DataArray, grid: Grid) -> xr.DataArray | None:
    """Return the four quarters of each map of ``da`` along a new dim ``region``.

    Open maps (whatever the whole), on the coordinates of the first; None when a quarter
    would be narrower than :data:`MIN_SIDE` pixels.
    """
    dy, dx = grid.dims
    ny, nx = da.sizes[dy], da.sizes[dx]
    if min(ny, nx) // 2 < MIN_SIDE:
        return None
    out: list[xr.DataArray] = []
    for sy in (slice(0, ny // 2), slice(ny // 2, 2 * (ny // 2))):
        for sx in (slice(0, nx // 2), slice(nx // 2, 2 * (nx // 2))):
            q = da.isel({dy: sy, dx: sx})
            out.append(q if not out else q.assign_coords({dy: out[0][dy], dx: out[0][dx]}))
    stacked = xr.concat(out, dim="region", coords="minimal", compat="override",
                        join="override")
    stacked.attrs = {**da.attrs, "periodic": 0}
    return stacked


def judge_regions(G: xr.DataArray, *, edges: np.ndarray, grid: Grid,
                  region_g: Callable[[float], xr.DataArray]) -> xr.DataArray:
    """G with the verdict of its regions: errors raised and marked where they disagree.

    ``G``: the labelled G of whole maps (dim ``dr``, coord ``standard_error``; lazy
    allowed); ``edges``: its bin edges (lateral unit); ``region_g(window)``: G of the
    quarters (dim ``region``, and ``dr``: their own mean lags) up to ``window``.  Returns
    G with coordinate :data:`INFLATION` (1 where the quarters agree), ``standard_error``
    times it, and per curve the flag questionable where they disagree (with the note and
    the attrs ``regions_ratio_max`` and ``error_inflation_max`` when computed).
    """
    side = min(n // 2 * d for n, d in zip(grid.shape, grid.spacing))
    window = WINDOW * side
    nb = G.sizes["dr"]
    if np.count_nonzero(edges <= window * (1 + 1e-12)) < 2:  # no bin to judge
        return quality.rate_curves(G, xr.zeros_like(G.isel(dr=0, drop=True).reset_coords(
            drop=True), dtype=np.int8), what="height_difference_acf",
            reason="regions_disagree")
    part = region_g(window)
    full_bin = _bin_of(G.dr.values, edges)
    own_bin = _bin_of(part.dr.values, edges)
    where = np.searchsorted(full_bin, own_bin)
    ok = (where < nb) & (full_bin[np.minimum(where, nb - 1)] == own_bin)
    index = np.full(nb, -1)
    index[where[ok]] = np.flatnonzero(ok)
    regions = xr.apply_ufunc(
        _place, part.reset_coords(drop=True).drop_vars("dr"), input_core_dims=[["dr"]],
        output_core_dims=[["dr"]], exclude_dims={"dr"}, dask="parallelized",
        output_dtypes=[float], dask_gufunc_kwargs={"output_sizes": {"dr": nb}},
        kwargs={"index": index}, keep_attrs=False)
    if regions.chunks is not None:
        regions = regions.chunk({"region": -1})
    se = G.standard_error.reset_coords(drop=True).drop_vars("dr", errors="ignore")
    values = G.reset_coords(drop=True).drop_vars("dr", errors="ignore")
    area_ratio = float(np.prod(grid.shape)) / float(np.prod([n // 2 for n in grid.shape]))
    judged = G.dr.values <= window
    out = xr.apply_ufunc(
        regional_scatter, regions, values, se,
        input_core_dims=[["region", "dr"], ["dr"], ["dr"]], output_core_dims=[["row", "dr"]],
        dask="parallelized", output_dtypes=[float], vectorize=True,
        dask_gufunc_kwargs={"output_sizes": {"row": 2}},
        kwargs={"judged": judged, "area_ratio": area_ratio}, keep_attrs=False)
    r2, k = out.isel(row=0), out.isel(row=1)
    worst_r2 = r2.max("dr", skipna=True)
    codes = (worst_r2 > REGIONS_DISAGREE).astype(np.int8) * np.int8(
        quality.level_code("questionable"))
    new = G.assign_coords({
        "standard_error": (G.standard_error.dims,
                           (G.standard_error.reset_coords(drop=True) * k.transpose(
                               *G.standard_error.dims)).data, G.standard_error.attrs),
        INFLATION: (G.dims, k.transpose(*G.dims).data, {
            "units": "1", "long_name": "standard_error over its Gaussian finite-area value",
            "comment": "the scatter of G between the map's four quarters, where they "
                       "disagree beyond their finite-area errors; 1 where they agree"})})
    if new.chunks is not None or not int(codes.max()):  # lazy, or the regions agree:
        # the verdict per curve (lazy where G is), and in the attrs only a finding
        return quality.rate_curves(new, codes, what="height_difference_acf",
                                   reason="regions_disagree")
    ratio = float(np.sqrt(worst_r2.max()))
    kmax = float(k.max())
    hit = (r2 > REGIONS_DISAGREE).any([d for d in r2.dims if d != "dr"]).values
    lags = G.dr.values[hit]
    note = (f"the regions of the map disagree: G of its four quarters scatters up to "
            f"{ratio:.3g} times their finite-area error (at dr = {lags.min():.3g} to "
            f"{lags.max():.3g} {grid.lateral_unit}): not a stationary Gaussian surface (a "
            "band or drift along the scan, a particle, a scratch, a texture that changes "
            "across the map); standard_error is the scatter of the quarters there (up to "
            f"{kmax:.3g} times the finite-area error) and every error derived from G "
            "follows it; look at the map and crop or mask what differs, or measure more "
            "regions")
    new.attrs.update(regions_ratio_max=ratio, error_inflation_max=kmax)
    return quality.mark_curves(new, codes, what="height_difference_acf",
                               reason="regions_disagree", notes=note)


def _bin_of(dr: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Bin of each mean lag (a lag at an edge, to round-off, in the bin above it)."""
    return np.searchsorted(edges, np.asarray(dr) * (1 + 1e-9), side="right") - 1


def _place(values: np.ndarray, *, index: np.ndarray) -> np.ndarray:
    """Values of a quarter's bins on the whole map's bins (NaN where it has none)."""
    values = np.asarray(values, dtype=float)
    taken = np.take(values, np.maximum(index, 0), axis=-1)
    return np.where(index >= 0, taken, np.nan)
