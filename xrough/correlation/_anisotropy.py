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

import numpy as np

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


def anisotropy_attrs(G, se, G_y, se_y, G_x, se_x, *, dr: np.ndarray, grid: Grid) -> dict:
    """Attributes of a radial G whose directions differ (``{}`` if they do not), and a warning.

    All arguments but ``dr`` and ``grid`` are computed DataArrays on dim ``dr`` (further
    dims: every curve counts).  Where ``G_x / G_y`` leaves ``[1/RATIO, RATIO]`` beyond
    :data:`SIGNIFICANCE` standard errors at some lag up to :data:`WINDOW` of the shorter
    side: ``anisotropy_ratio_min`` and ``_max`` (the extremes of ``G_x / G_y`` there),
    ``quality = "questionable"`` and the finding in ``quality_notes``, with one
    :class:`~xrough.QualityWarning`.  Only what is found is recorded, so an isotropic G
    has the attributes of its lazy twin (a lazy G is not judged: compute it, or compare
    ``acf(direction='x')`` and ``acf(direction='y')``).
    """
    del G, se  # the radial G: its own errors are not those of the comparison
    gx, gy = np.asarray(G_x, dtype=float), np.asarray(G_y, dtype=float)
    ex, ey = np.asarray(se_x, dtype=float), np.asarray(se_y, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        log_ratio = np.log(gx / gy)
        error = np.sqrt((ex / gx) ** 2 + (ey / gy) ** 2)
    inside = np.broadcast_to(dr <= WINDOW * min(grid.size), log_ratio.shape)
    usable = inside & np.isfinite(log_ratio) & (gx > 0) & (gy > 0)
    hit = usable & (np.abs(log_ratio) > np.log(RATIO)) & (
        np.abs(log_ratio) > SIGNIFICANCE * np.nan_to_num(error, nan=np.inf))
    if not hit.any():
        return {}
    lo, hi = (float(np.exp(f(log_ratio[usable]))) for f in (np.min, np.max))
    lags = dr[np.any(hit.reshape(-1, dr.size), axis=0)]
    text = (f"G along x and along y differ beyond {SIGNIFICANCE:g} standard errors "
            f"(G_x / G_y from {lo:.2g} to {hi:.2g}, at dr = {lags.min():.3g} to "
            f"{lags.max():.3g} {grid.lateral_unit}): the surface is anisotropic (a texture, "
            "grooves, stripes) or the scan differs along its fast and slow axes (line "
            "offsets: detrend(..., per_line=True)): the radial G averages directions that "
            "no single direction has, and the contact theory of an isotropic surface may "
            "not hold (compare acf(direction='x') and acf(direction='y'))")
    quality.warn(f"height_difference_acf: questionable: {text}", quality.QualityWarning)
    return {"anisotropy_ratio_min": lo, "anisotropy_ratio_max": hi,
            "quality": "questionable", "quality_notes": text}
