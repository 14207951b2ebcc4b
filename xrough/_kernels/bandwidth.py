"""Variable-bandwidth analysis: rms height of a map detrended in ever smaller tiles.

Pure numpy: :func:`xrough._kernels.detrend.checkerboard_detrend` per magnification, then
the mean square per tile.
"""

from __future__ import annotations

import numpy as np

from .detrend import checkerboard_detrend, segment_starts

__all__ = ["variable_bandwidth_kernel", "BANDWIDTH_OUTPUTS"]

#: What :func:`variable_bandwidth_kernel` returns per magnification, in this order.
BANDWIDTH_OUTPUTS = ("rms_height", "rms_height_std", "tiles")


def _tile_sums(a: np.ndarray, subdivisions: tuple[int, ...]) -> np.ndarray:
    """Sum ``a`` over the tiles of its last ``len(subdivisions)`` axes (array_split's)."""
    for k, parts in enumerate(subdivisions):
        axis = a.ndim - len(subdivisions) + k
        a = np.add.reduceat(a, segment_starts(a.shape[axis], parts)[1], axis=axis)
    return a


def variable_bandwidth_kernel(h, *, coords, degree: int, magnifications,
                              per_line: bool = False) -> np.ndarray:
    """Rms height per magnification ``m``: the grid in ``m`` tiles an axis, each detrended.

    Parameters
    ----------
    h : numpy.ndarray (..., [ny,] nx)
        Heights, NaN for missing points.
    coords : sequence of 1-D arrays
        Grid coordinates (``(y, x)`` or ``(x,)``).
    degree : int
        Polynomial degree of the detrending of each tile (0 mean, 1 plane, 2 curvature).
    magnifications : sequence of int
        Tiles an axis (``m`` along ``x`` only with ``per_line``).
    per_line : bool
        Cut each line (along ``x``) into segments instead of the map into tiles.

    Returns
    -------
    numpy.ndarray (..., n_magnifications, 3)
        :data:`BANDWIDTH_OUTPUTS`: the rms height over every valid point, its standard
        error from the scatter of the tiles' mean squares (NaN for one tile), and the
        number of tiles with a valid point.

    Examples
    --------
    >>> x = np.arange(16.0)
    >>> out = variable_bandwidth_kernel(np.sin(x), coords=(x,), degree=1,
    ...                                 magnifications=[1, 2, 4])
    >>> out.shape, bool(out[0, 0] > out[2, 0])  # smaller tiles, less height left
    ((3, 3), True)
    """
    h = np.asarray(h, dtype=float)
    nd = len(coords)
    out = np.full(h.shape[: h.ndim - nd] + (len(magnifications), 3), np.nan)
    for i, m in enumerate(magnifications):
        tiles = (1, int(m)) if per_line and nd == 2 else (int(m),) * nd
        if per_line and nd == 2:
            r = checkerboard_detrend(h, coords[-1:], degree, tiles[-1:])
        else:
            r = checkerboard_detrend(h, coords, degree, tiles)
        valid = np.isfinite(r)
        if per_line and nd == 2:  # every segment of every line is a tile
            tiles = (h.shape[-2], int(m))
        sq = _tile_sums(np.where(valid, r * r, 0.0), tiles)
        cnt = _tile_sums(valid.astype(float), tiles)
        grid_axes = tuple(range(sq.ndim - nd, sq.ndim))
        total = cnt.sum(axis=grid_axes)
        with np.errstate(invalid="ignore", divide="ignore"):
            ms = sq.sum(axis=grid_axes) / total
            per_tile = sq / cnt
            used = cnt > 0
            n_tiles = used.sum(axis=grid_axes)
            dev = np.where(used, per_tile - np.expand_dims(ms, grid_axes), 0.0)
            var = (dev**2).sum(axis=grid_axes) / (n_tiles - 1)
            ms_std = np.sqrt(var / n_tiles)
            rms = np.sqrt(ms)
            out[..., i, 0] = rms
            out[..., i, 1] = np.where(n_tiles > 1, ms_std / (2 * rms), np.nan)
            out[..., i, 2] = n_tiles
    return out
