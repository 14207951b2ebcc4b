"""Does a radial G average directions that differ? G along the two pixel axes, compared.

The FFT of a radial G sums every lag vector of the map; the lags along the x axis
(``d_y = 0``) and along the y axis (``d_x = 0``) are among them, so G along each axis comes
with the radial G at no extra transform (:func:`xrough.correlation._fft.split_directions`).
A surface with a texture (grooves, stripes) or a scan whose fast and slow axes differ
(line offsets, drift: the rows of an AFM map are levelled against each other by nothing)
has ``G_x != G_y``; its radial G is an average over directions that no single direction
has, and the contact theory of an isotropic surface does not describe it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import xarray as xr

from .. import quality
from ..topography import Grid

#: G along x and along y differ when their ratio leaves [1/RATIO, RATIO] beyond
#: SIGNIFICANCE standard errors.  On isotropic self-affine maps (128^2 and 256^2, H = 0.3
#: and 0.8, 20 seeds each: tests/test_correlation.py) the ratio stays within 0.74-1.30 up
#: to a quarter of the scan and none is flagged; on the real files it reaches 0.06 (AFM
#: scan lines of the UNCD map) to 10.8 (the grooves of x3p-2).
RATIO, SIGNIFICANCE = 1.5, 3.0
#: Lags beyond this fraction of the shorter side hold few independent pairs along an axis.
WINDOW = 0.25


def anisotropy(G_y: xr.DataArray, G_x: xr.DataArray, *, dr: np.ndarray, grid: Grid,
               errors: Callable[[], tuple[xr.DataArray, xr.DataArray]]):
    """Which curves of a radial G have directions that differ, and what to say.

    ``G_y``, ``G_x``: G along y and along x, computed DataArrays on dim ``dr`` (further
    dims: one verdict per curve); ``errors()`` returns their standard errors, and is
    called only when the ratio alone leaves the band somewhere (the spectrum each error
    needs is most of the cost of a small map's G).  Where ``G_x / G_y`` leaves
    ``[1/RATIO, RATIO]`` beyond :data:`SIGNIFICANCE` standard errors at some lag up to
    :data:`WINDOW` of the shorter side, the curve is questionable.

    Returns ``None`` when no curve is, else ``(codes, note, attrs)``: the level code per
    curve (int8 on the extra dims), the finding in words and the attrs
    ``anisotropy_ratio_min`` / ``_max`` (the extremes of ``G_x / G_y`` over every
    curve's window).  Only what is found is recorded, so an isotropic G has the
    attributes of its lazy twin (a lazy G is not judged: compute it, or compare
    ``acf(direction='x')`` and ``acf(direction='y')``).
    """
    def last(a: xr.DataArray) -> np.ndarray:  # the values with dr last
        return np.asarray(a.transpose(..., "dr").values)

    gy, gx = last(G_y), last(G_x)
    with np.errstate(divide="ignore", invalid="ignore"):
        log_ratio = np.log(gx / gy)
    usable = (dr <= WINDOW * min(grid.size)) & np.isfinite(log_ratio) & (gx > 0) & (gy > 0)
    hit = usable & (np.abs(log_ratio) > np.log(RATIO))
    if not hit.any():
        return None
    se_y, se_x = (last(a) for a in errors())
    with np.errstate(divide="ignore", invalid="ignore"):
        error = np.sqrt((se_x / gx) ** 2 + (se_y / gy) ** 2)
    hit &= np.abs(log_ratio) > SIGNIFICANCE * np.where(np.isnan(error), np.inf, error)
    if not hit.any():
        return None
    values = np.where(usable, log_ratio, np.nan)
    lo, hi = float(np.exp(np.nanmin(values))), float(np.exp(np.nanmax(values)))
    lags = dr[hit.reshape(-1, dr.size).any(axis=0)]
    note = (f"G along x and along y differ beyond {SIGNIFICANCE:g} standard errors "
            f"(G_x / G_y from {lo:.2g} to {hi:.2g}, at dr = {lags.min():.3g} to "
            f"{lags.max():.3g} {grid.lateral_unit}): the surface is anisotropic (a texture, "
            "grooves, stripes) or the scan differs along its fast and slow axes (line "
            "offsets: detrend(..., per_line=True)): the radial G averages directions that "
            "no single direction has, and the contact theory of an isotropic surface may "
            "not hold (compare acf(direction='x') and acf(direction='y'))")
    level = np.int8(quality.level_code("questionable"))
    ref = G_y.isel(dr=0, drop=True)
    codes = xr.DataArray(hit.any(axis=-1).astype(np.int8) * level, dims=ref.dims,
                         coords=ref.coords)
    return codes, note, {"anisotropy_ratio_min": lo, "anisotropy_ratio_max": hi}
