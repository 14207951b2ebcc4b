"""Variable-bandwidth analysis: how much height is left in tiles of each size.

Cut the map into ``m x m`` tiles (``m`` = 1, 2, 4, ...), detrend each tile on its own
(checkerboard detrending, :func:`xrough.detrend` with ``subdivisions``) and take the rms
height that is left: the roughness with wavelengths up to the tile size ``L / m`` (the
bandwidth). On a self-affine surface it goes as ``(L / m)^H``, so the analysis gives H and
the range where the surface is self-affine in real space, without G or a spectrum; it is
contact.engineering's and SurfaceTopography's ``variable_bandwidth`` (their tests are
ported in the test suite).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .. import units as u
from .._kernels.bandwidth import BANDWIDTH_OUTPUTS, variable_bandwidth_kernel
from .._kernels.checks import require_count
from ..acf import result_attrs
from ..preprocess import detrend_degree, grid_coords
from ..topography import grid_of, require_whole_maps

__all__ = ["variable_bandwidth"]


@u.accepts_quantified
def variable_bandwidth(topography: xr.DataArray, *, min_tile: int = 4, mode: str = "plane",
                       per_line: bool = False) -> xr.DataArray:
    r"""Rms height against bandwidth: the map detrended in ``m x m`` tiles, ``m = 2^k``.

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        Heights with units; NaN for missing points. Extra dims give one curve each (lazy
        on dask, one map per chunk).
    min_tile : int
        Fewest points along a side of the smallest tile (SurfaceTopography's
        ``nb_grid_pts_cutoff``); at least 2, and more than the fit has terms.
    mode : {'mean', 'plane', 'curvature'}
        The polynomial removed from every tile (:func:`xrough.detrend`).
    per_line : bool
        Cut each scan line into ``m`` segments instead of the map into tiles (the
        profile analysis of a map, immune to offsets between lines).

    Returns
    -------
    xarray.DataArray
        ``rms_height`` (height unit) on dim ``bandwidth`` (the tiles' size along ``x``,
        ``L_x / m``, lateral unit; increasing), with coords ``magnification`` (``m``),
        ``tiles`` (tiles with a valid point) and ``rms_height_std`` (the standard error
        from the scatter of the tiles' mean squares; NaN for one tile). The largest
        bandwidth (``m = 1``) is the rms height of the map detrended by ``mode``.

    Raises
    ------
    ValueError
        Invalid topography or ``mode``, ``min_tile`` below 2 or larger than half the map.

    Notes
    -----
    .. math:: h_\mathrm{rms}(L/m)^2 = \frac{1}{N}\sum_{\text{tiles } t}
              \sum_{\mathbf r \in t} \left[h(\mathbf r) - P_t(\mathbf r)\right]^2

    with :math:`P_t` the least-squares polynomial of tile :math:`t`. For a self-affine
    surface :math:`h_\mathrm{rms} \propto (L/m)^H` between the short and long cutoffs
    (the paper's eq. 9 regime); on a map with non-square tiles (non-square map or
    pixels) the bandwidth is their ``x`` side.

    Examples
    --------
    >>> import xrough
    >>> topo = xrough.self_affine_surface(hurst=0.8, n=256, size="1 um", lambda_r="1 um",
    ...                                   lambda_s="8 nm", rms_gradient=0.1, unit="nm",
    ...                                   seed=1)
    >>> vb = xrough.variable_bandwidth(topo, min_tile=16)
    >>> vb.magnification.values.tolist(), vb.attrs["units"]
    ([16, 8, 4, 2, 1], 'nm')
    """
    grid = grid_of(topography)
    require_whole_maps(topography, grid, purpose="the variable-bandwidth analysis")
    degree = detrend_degree(mode, per_line, grid)
    require_count(min_tile, "min_tile", minimum=max(2, degree + 1))
    along = grid.shape[-1:] if per_line else grid.shape
    largest = min(along) // min_tile
    if largest < 1:
        raise ValueError(f"min_tile={min_tile} is larger than the map ({min(along)} points "
                         "along its shorter side)")
    mags = 2 ** np.arange(int(np.floor(np.log2(largest))) + 1)[::-1]  # bandwidth rising
    result = xr.apply_ufunc(
        variable_bandwidth_kernel, topography, input_core_dims=[list(grid.dims)],
        output_core_dims=[["bandwidth", "part"]], dask="parallelized",
        output_dtypes=[float], keep_attrs=False,
        dask_gufunc_kwargs={"output_sizes": {"bandwidth": mags.size,
                                             "part": len(BANDWIDTH_OUTPUTS)}},
        kwargs={"coords": grid_coords(topography, grid), "degree": degree,
                "magnifications": mags, "per_line": bool(per_line)})
    hunit, lunit = grid.height_unit, grid.lateral_unit

    def part(name: str) -> xr.DataArray:
        return result.isel(part=BANDWIDTH_OUTPUTS.index(name), drop=True)

    label = f"{mode} per line" if per_line else mode
    return part("rms_height").assign_coords(
        bandwidth=("bandwidth", grid.size[-1] / mags, {
            "units": lunit, "long_name": "bandwidth (tile size along x)"}),
        magnification=("bandwidth", mags, {"long_name": "tiles along an axis"}),
        tiles=part("tiles").astype(np.int64).assign_attrs(
            long_name="tiles with a valid point"),
        rms_height_std=part("rms_height_std").assign_attrs(
            units=hunit, long_name="standard error of rms_height (scatter of the tiles)"),
    ).assign_attrs(result_attrs(
        topography, units=hunit, long_name="rms height in tiles of the bandwidth",
        equation="h_rms(L/m)^2 = mean over tiles of (h - P_tile)^2, checkerboard "
                 f"detrending ({label})", detrend=label, min_tile=int(min_tile))
    ).rename("rms_height")
