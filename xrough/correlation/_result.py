"""The one definition of G's DataArray: coords, units and attrs, for every estimator."""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
import xarray as xr

from .. import units as u
from ..acf import result_attrs
from ..topography import Grid


def g_unit(grid: Grid) -> str:
    """Return the unit of G (and of its errors): the height unit squared."""
    return _squared(grid.height_unit)


@functools.lru_cache(maxsize=32)
def _squared(unit: str) -> str:
    return u.power_units(unit, 2)


def _variable(da, **attrs) -> xr.Variable:
    """Return the Variable of a coord (a DataArray, or a tuple), its attrs updated by ``attrs``."""
    v = da.variable if isinstance(da, xr.DataArray) else xr.as_variable(da)
    if not attrs:
        return v
    return xr.Variable(v.dims, v.data, {**v.attrs, **attrs}, encoding=v.encoding)


def _variance(h: np.ndarray, n_axes: int) -> np.ndarray:
    """Variance of the finite values over the last ``n_axes`` axes.

    NaN where there are none; ``inf``, without a warning, where it exceeds the floats (the
    estimator says so itself).
    """
    axes = tuple(range(-n_axes, 0))
    valid = np.isfinite(h)
    n = np.count_nonzero(valid, axis=axes)
    with np.errstate(all="ignore"):
        x = np.where(valid, h, 0.0)
        mean = x.sum(axis=axes, keepdims=True) / np.expand_dims(np.maximum(n, 1), axes)
        np.subtract(x, mean, out=x)
        x[~valid] = 0.0
        np.multiply(x, x, out=x)
        return np.where(n > 0, x.sum(axis=axes) / np.maximum(n, 1), np.nan)


def height_variance(topography: xr.DataArray, grid: Grid, *, lag_dims, mean_dims=()
                    ) -> xr.DataArray:
    """Return the variance of the heights G was measured from: its mean over all pairs.

    ``1/2 <(h_i - h_j)^2>`` over all pairs of valid points equals the variance of the
    heights about their mean (eq. 1 averaged over every lag, each with its pair count), the
    level that :func:`xrough.spectrum` extends G to and the integral of its ``C``. Over
    ``lag_dims`` (the pairs of one map, or one line of a one-direction G), averaged over
    ``mean_dims`` (lines, pooled maps) with weight ``n^2`` (the pairs of each, ``n`` its
    valid points), as G pools their pairs. Lazy where the topography is.

    Parameters
    ----------
    topography, grid
        The heights and their grid.
    lag_dims : sequence of str
        Dims along which G pairs points.
    mean_dims : sequence of str
        Dims whose curves G pools.

    Returns
    -------
    xarray.DataArray
        On the remaining dims, float64, units of G (the coord ``height_variance``).
    """
    h = topography if topography.dtype == np.float64 else topography.astype(np.float64)
    lag_dims = list(lag_dims)
    if h.chunks is None or all(len(h.chunksizes[d]) == 1 for d in lag_dims):
        var = xr.apply_ufunc(_variance, h, input_core_dims=[lag_dims], dask="parallelized",
                             output_dtypes=[np.float64], keep_attrs=False,
                             kwargs={"n_axes": len(lag_dims)})
    else:  # a map in tiles (the tiled estimator): dask's reduction over them
        var = h.var(lag_dims, skipna=True)
    if mean_dims:
        n2 = h.notnull().sum(lag_dims).astype(np.float64) ** 2
        var = (var.fillna(0.0) * n2).sum(list(mean_dims)) / n2.sum(list(mean_dims))
    return xr.DataArray(var.variable, attrs={
        "units": g_unit(grid),
        "long_name": "variance of the heights (G averaged over all pairs of points)"})


def g_result(topography: xr.DataArray, grid: Grid, G: xr.DataArray, *, dr: np.ndarray,
             pair_count: xr.DataArray, standard_error: xr.DataArray,
             coords: dict[str, Any] | None = None, estimator: str, direction: str,
             geometry: str, bins, points_per_decade, **attrs) -> xr.DataArray:
    """Label the values of G (dim ``dr``) of ``topography`` with its coords and attrs.

    Parameters
    ----------
    topography, grid
        The input and its grid (units, spacing, periodicity, provenance).
    G, pair_count, standard_error : xarray.DataArray
        Values of the kept bins on dim ``dr`` (any further dims kept).
    dr : numpy.ndarray
        Mean lag of each kept bin, in the lateral unit.
    coords : dict, optional
        Further coords on ``dr`` (estimator specific), with their attrs.
    estimator : str
        How G was computed (attr ``estimator``).
    direction, geometry, bins, points_per_decade
        The options, recorded as attrs (``points_per_decade`` for log bins only).
    **attrs
        Further attrs of the estimator (its parameters).

    Returns
    -------
    xarray.DataArray
        ``G``, units of height squared, with the topography's provenance.
    """
    gu = g_unit(grid)
    # Variables, not DataArrays: no alignment to do (all are on G's dims), at half the
    # cost of assign_coords
    new = {"dr": xr.Variable("dr", dr, {"units": grid.lateral_unit,
                                        "long_name": "lag distance"}),
           "pair_count": _variable(pair_count, long_name="number of point pairs averaged",
                                   units="1"),
           "standard_error": _variable(standard_error, units=gu,
                                       long_name="standard error of G")}
    new.update({k: _variable(v) for k, v in (coords or {}).items()})
    G = xr.DataArray(G.variable, coords={**G.coords, **new}, name="G")
    log = isinstance(bins, str) and bins == "log"
    G.attrs = result_attrs(  # with the topography's provenance
        topography,
        units=gu,
        long_name="height-difference autocorrelation function",
        symbol="G",
        equation="eq. 1: G(dr) = 1/2 <(h(r) - h(r + dr))^2>",
        estimator=estimator,
        direction=direction if len(grid.dims) == 2 else "x",
        lag_geometry=geometry,
        periodic=int(grid.periodic),
        bins=bins if isinstance(bins, str) else "explicit",
        pixel_size=float(min(grid.spacing)),
        scan_size=float(max(grid.size)),
        source=str(topography.attrs.get("source", topography.name or "")),
        **({"points_per_decade": float(points_per_decade)} if log else {}),
        **attrs)
    return G
