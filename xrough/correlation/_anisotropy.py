"""Does a radial G average directions that differ? G along the axes and the diagonals.

The FFT of a radial G sums every lag vector of the map; the lags along the x axis
(``d_y = 0``) and along the y axis (``d_x = 0``) are among them, so G along each axis comes
with the radial G at no extra transform (:func:`xrough.correlation._fft.split_directions`).
A surface with a texture (grooves, stripes) or a scan whose fast and slow axes differ
(line offsets, drift: the rows of an AFM map are levelled against each other by nothing)
has ``G_x != G_y``; its radial G is an average over directions that no single direction
has, and the contact theory of an isotropic surface does not describe it. A texture at 45
degrees to the pixel axes has ``G_x = G_y``: G along the two diagonals
(:func:`diagonal_g`, direct sums of a few lags) tells it.
"""

from __future__ import annotations

import functools
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

    def error() -> np.ndarray:
        se_y, se_x = (last(a) for a in errors())
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.sqrt((se_x / gx) ** 2 + (se_y / gy) ** 2)

    found = _significant(gx, gy, dr, dr <= WINDOW * min(grid.size), error)
    if found is None:
        return None
    hit, lo, hi, first, last_lag = found
    note = (f"G along x and along y differ beyond {SIGNIFICANCE:g} standard errors "
            f"(G_x / G_y from {lo:.2g} to {hi:.2g}, at dr = {first:.3g} to "
            f"{last_lag:.3g} {grid.lateral_unit}): the surface is anisotropic (a texture, "
            "grooves, stripes) or the scan differs along its fast and slow axes (line "
            "offsets: detrend(..., per_line=True)): the radial G averages directions that "
            "no single direction has, and the contact theory of an isotropic surface may "
            "not hold (compare acf(direction='x') and acf(direction='y'))")
    ref = G_y.isel(dr=0, drop=True)
    return (_codes(hit, ref.dims, ref.coords), note,
            {"anisotropy_ratio_min": lo, "anisotropy_ratio_max": hi})


def _significant(a: np.ndarray, b: np.ndarray, lags: np.ndarray, window: np.ndarray,
                 error: Callable[[], np.ndarray]):
    """Find where ``a / b`` leaves ``[1/RATIO, RATIO]`` beyond SIGNIFICANCE ``error()``.

    ``error()``: the relative error of the ratio on ``lags`` (asked for only if the band
    is left); only lags in ``window`` count. Returns ``None`` (nowhere) or ``(hit, lo, hi,
    first, last)``: the lags hit per curve, the extremes of the ratio over the usable lags
    of every curve and the smallest and largest lag hit.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        log_ratio = np.log(a / b)
    usable = window & np.isfinite(log_ratio) & (a > 0) & (b > 0)
    hit = usable & (np.abs(log_ratio) > np.log(RATIO))
    if not hit.any():
        return None
    err = np.asarray(error())
    hit &= np.abs(log_ratio) > SIGNIFICANCE * np.where(np.isnan(err), np.inf, err)
    if not hit.any():
        return None
    kept = np.where(usable, log_ratio, np.nan)
    where = lags[hit.reshape(-1, lags.size).any(axis=0)]
    return (hit, float(np.exp(np.nanmin(kept))), float(np.exp(np.nanmax(kept))),
            float(where.min()), float(where.max()))


def _codes(hit: np.ndarray, dims, coords) -> xr.DataArray:
    """Questionable where a curve has a lag hit (int8 on the extra dims)."""
    level = np.int8(quality.level_code("questionable"))
    return xr.DataArray(hit.any(axis=-1).astype(np.int8) * level, dims=dims, coords=coords)


#: Lags (in pixel steps along a diagonal) at most, and rows used at most, by diagonal_g.
DIAGONAL_LAGS, DIAGONAL_ROWS = 10, 256
#: A diagonal lag with fewer valid pairs is not judged (NaN): the error it is judged by is
#: that of the axis lag of its length, whose pairs are as many only on a map of some size
#: (a 5 x 5 map with half its points missing has a handful; white noise there gave a
#: ratio of 0.04 "beyond 3 standard errors").
DIAGONAL_MIN_PAIRS = 50


def diagonal_steps(shape: tuple[int, int]) -> np.ndarray:
    """Give the diagonal steps ``k`` (pixels along each axis): log-spaced to WINDOW."""
    top = int(WINDOW * min(shape))
    if top < 1:
        return np.zeros(0, dtype=int)
    return np.unique(np.round(np.geomspace(1, top, DIAGONAL_LAGS)).astype(int))


def diagonal_g(h: np.ndarray, steps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """G along the diagonal (``+k, +k``) and the anti-diagonal (``+k, -k``) of maps.

    ``h``: heights ``(..., ny, nx)`` (NaN: missing); returns two arrays ``(..., len(steps))``,
    ``1/2 <(h(r) - h(r + d))^2>`` over the valid pairs (NaN with fewer than
    :data:`DIAGONAL_MIN_PAIRS`). On a map of more than
    :data:`DIAGONAL_ROWS` rows, every m-th row starts a pair (the same rows for both
    diagonals: the comparison stays paired).
    """
    ny = h.shape[-2]
    stride = max(1, ny // DIAGONAL_ROWS)
    out = np.full((2, *h.shape[:-2], steps.size), np.nan)
    with np.errstate(invalid="ignore"):
        for j, k in enumerate(steps):
            start = h[..., 0:ny - k:stride, :]
            end = h[..., k:ny:stride, :][..., :start.shape[-2], :]
            for i, (a, b) in enumerate(((start[..., :-k], end[..., k:]),
                                        (start[..., k:], end[..., :-k]))):
                d = b - a
                valid = np.isfinite(d)
                n = valid.sum(axis=(-2, -1))
                total = np.where(valid, d * d, 0.0).sum(axis=(-2, -1))
                out[i, ..., j] = np.where(n >= DIAGONAL_MIN_PAIRS,
                                          0.5 * total / np.maximum(n, 1), np.nan)
    return out[0], out[1]


def diagonal_anisotropy(h: xr.DataArray, *, grid: Grid, dr: np.ndarray,
                        rel_error: Callable[[], np.ndarray]):
    """Which maps' G along the two diagonals differ, and what to say (as :func:`anisotropy`).

    ``h``: the heights (dims ``(..., y, x)``, computed); ``rel_error()`` the relative
    standard error of G along an axis on the lags ``dr`` (``(..., len(dr))``), called
    only when the ratio alone leaves the band: a diagonal lag takes that of the axis lag
    nearest its length (as many pairs, the same kind of sum). Returns ``None`` or
    ``(codes, note, attrs)`` with ``anisotropy_diagonal_ratio_min`` / ``_max``.
    """
    values = np.asarray(h.transpose(..., "y", "x").values, dtype=float)
    steps = diagonal_steps(values.shape[-2:])
    if steps.size == 0:
        return None
    g1, g2 = diagonal_g(values, steps)
    dy, dx = grid.spacing[-2:]
    lags = steps * float(np.hypot(dy, dx))
    nearest = np.abs(np.log(dr[None, :]) - np.log(lags[:, None])).argmin(axis=1)
    found = _significant(g1, g2, lags, np.ones(lags.size, dtype=bool),
                         lambda: np.sqrt(2.0) * np.asarray(rel_error())[..., nearest])
    if found is None:
        return None
    hit, lo, hi, first, last = found
    note = (f"G along the two diagonals of the pixel grid differs beyond {SIGNIFICANCE:g} "
            f"standard errors (ratio from {lo:.2g} to {hi:.2g}, at dr = {first:.3g} "
            f"to {last:.3g} {grid.lateral_unit}): a texture oblique to the pixel "
            "axes (G along x and along y cannot see it); the radial G averages directions "
            "that no single direction has, and the contact theory of an isotropic surface "
            "may not hold")
    extra = [d for d in h.dims if d not in ("y", "x")]
    return (_codes(hit, extra, {d: h[d] for d in extra if d in h.coords}), note,
            {"anisotropy_diagonal_ratio_min": lo, "anisotropy_diagonal_ratio_max": hi})


def combine(*found):
    """One verdict of several checks of directions (each None or ``(codes, note, attrs)``)."""
    given = [f for f in found if f is not None]
    if not given:
        return None
    codes = functools.reduce(lambda a, b: np.maximum(a, b).astype(np.int8),
                             [f[0] for f in given])
    attrs: dict = {}
    for f in given:
        attrs.update(f[2])
    return codes, quality.SEPARATOR.join(f[1] for f in given), attrs
