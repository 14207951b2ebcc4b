"""Preprocessing kernels: polynomial trends, outliers and the scale-dependent curvature.

Pure numpy (and :func:`scipy.ndimage.correlate1d`) functions on arrays whose *last* one or
two axes are the grid (``(..., x)`` for profiles, ``(..., y, x)`` for maps); leading axes
are a batch of independent maps or lines. Missing points are NaN everywhere.

Polynomial trends
    Least squares over the valid points only, in coordinates centred on the middle of the
    grid and scaled to ``[-1, 1]`` (well conditioned whatever the unit). The normal
    equations are built from separable moments ``sum m(y, x) v(y)^a u(x)^b``, two matrix
    products per map, so no design matrix of the size of the map is ever formed.
Outliers
    Robust z-scores ``|r - median r| / scale`` with the scale ``1.4826 MAD`` (the standard
    deviation for Gaussian data) of the heights, or of their residual from a local
    reference that is robust (a median of symmetric pair means) and then linear (a local
    plane through the neighbours): :func:`robust_zscore`.
Scale-dependent curvature
    ``(h(x + d) - 2 h(x) + h(x - d)) / d^2`` at lattice distances ``d``; its minimum over the
    map is what a tip of radius ``R`` can follow only if it is above ``-1/R``.
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np

from .deferred import ndimage, optimize
from .derivatives import second_difference

__all__ = [
    "DEGREES",
    "polynomial_terms",
    "fit_polynomial",
    "detrend",
    "checkerboard_detrend",
    "mad_detrend",
    "segment_starts",
    "pair_median_reference",
    "local_plane_reference",
    "robust_zscore",
    "outlier_mask",
    "MAD_TO_SIGMA",
    "min_curvature",
]

#: Polynomial degree of each detrending mode.
DEGREES = {"mean": 0, "plane": 1, "curvature": 2}
#: ``1 / Phi^-1(3/4)``: turns the median absolute deviation into the standard deviation of
#: Gaussian data.
MAD_TO_SIGMA = 1.482602218505602
#: ``2 Phi^-1(0.975)``: the width of the central 95 % of Gaussian data in standard
#: deviations (the scale used where the MAD is 0).
_WIDE_TO_SIGMA = 3.919927969080108
#: Singular values of the (scaled) normal matrix below this fraction of the largest are
#: dropped: a fit with fewer valid points than terms gets the minimum-norm solution.
_RCOND = 1e-10
#: Most passes of the linear stage of the local outlier score (it stops when the set of
#: candidates no longer changes, usually after two to four).
_MAX_ITERATIONS = 8
#: Elements sorted at once by the NaN-aware median (bounds the memory to ~32 MB).
_BLOCK_ELEMENTS = 1 << 22


def polynomial_terms(ndim: int, degree: int) -> list[tuple[int, ...]]:
    """Exponents of the monomials of a polynomial of total ``degree`` in ``ndim`` variables.

    Exponents are ordered like the grid axes: ``(e_y, e_x)`` for a map, ``(e_x,)`` for a
    profile; by total degree, then with the ``x`` power first.

    Examples
    --------
    >>> polynomial_terms(2, 1)
    [(0, 0), (0, 1), (1, 0)]
    >>> polynomial_terms(1, 2)
    [(0,), (1,), (2,)]
    """
    if ndim == 1:
        return [(i,) for i in range(degree + 1)]
    if ndim != 2:
        raise ValueError(f"polynomial trends need 1 or 2 grid axes, got {ndim}")
    return [(total - ex, ex) for total in range(degree + 1) for ex in range(total, -1, -1)]


def _normalised(coords) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """Coordinates mapped to [-1, 1], with their centres and half-ranges."""
    centres, scales, unit = [], [], []
    for c in coords:
        c = np.asarray(c, dtype=float)
        centre = 0.5 * (c[0] + c[-1])
        scale = 0.5 * abs(c[-1] - c[0])
        if not scale > 0:
            raise ValueError("a grid axis needs at least 2 distinct coordinates")
        centres.append(centre)
        scales.append(scale)
        unit.append((c - centre) / scale)
    return unit, np.array(centres), np.array(scales)


def _fit_normalised(h: np.ndarray, unit: list[np.ndarray], degree: int):
    """Least-squares coefficients in the normalised coordinates, and valid-point counts."""
    nd = len(unit)
    terms = polynomial_terms(nd, degree)
    valid = np.isfinite(h)
    h0 = np.where(valid, h, 0.0)
    m = valid.astype(float)
    powers = [u[:, None] ** np.arange(2 * degree + 1) for u in unit]
    if nd == 1:
        (px,) = powers
        moments = m @ px  # (..., 2d+1)
        rhs_m: np.ndarray = h0 @ px[:, : degree + 1]
        normal = np.stack([np.stack([moments[..., a[0] + b[0]] for b in terms], -1)
                           for a in terms], -2)
        rhs = np.stack([rhs_m[..., a[0]] for a in terms], -1)
        count = moments[..., 0]
    else:
        py, px = powers
        moments = py.T @ (m @ px)  # (..., 2d+1, 2d+1): sum m v^a u^b
        rhs_m = py[:, : degree + 1].T @ (h0 @ px[:, : degree + 1])
        normal = np.stack([np.stack([moments[..., a[0] + b[0], a[1] + b[1]] for b in terms],
                                    -1) for a in terms], -2)
        rhs = np.stack([rhs_m[..., a[0], a[1]] for a in terms], -1)
        count = moments[..., 0, 0]
    coef = (np.linalg.pinv(normal, rtol=_RCOND, hermitian=True) @ rhs[..., None])[..., 0]
    coef = np.where((count == 0)[..., None], np.nan, coef)
    return coef, terms, count


def _check_points(count: np.ndarray, nterms: int, what: str) -> None:
    few = count < nterms
    if np.any(few):
        first = np.unravel_index(int(np.argmax(few)), np.shape(count)) if np.ndim(count) else ()
        where = f" (map {tuple(int(i) for i in first)} of the stack)" if first else ""
        raise ValueError(f"{what}{where} has {int(np.asarray(count)[first])} valid (non-NaN) "
                         f"points; the fit needs at least {nterms}")


def fit_polynomial(h: np.ndarray, coords, degree: int, *, strict: bool = True):
    """Least-squares polynomial trend of each map or line, fitted to valid points only.

    Parameters
    ----------
    h : numpy.ndarray, shape (..., [ny,] nx)
        Heights; NaN marks missing points. The last ``len(coords)`` axes are the grid.
    coords : sequence of 1-D arrays
        Coordinates of the grid axes (``(y, x)`` or ``(x,)``), any unit.
    degree : int
        Total degree: 0 (mean), 1 (plane / line), 2 (quadratic surface / parabola).
    strict : bool
        Raise ``ValueError`` when a fit has fewer valid points than terms; otherwise return
        its minimum-norm solution (NaN when it has no valid point at all).

    Returns
    -------
    coef : numpy.ndarray, shape (..., n_terms)
        Coefficients of the monomials ``prod_d (c_d - centre_d)^e_d`` in the units of
        ``h`` over the units of the coordinates to the power of the term's degree.
    terms : list of tuple of int
        The exponents of each monomial (:func:`polynomial_terms`).
    centres : numpy.ndarray
        Middle of each coordinate range (``(c[0] + c[-1]) / 2``), the origin of the fit.

    Examples
    --------
    >>> x = np.linspace(0.0, 4.0, 5)
    >>> coef, terms, centres = fit_polynomial(3.0 + 0.5 * x, (x,), 1)
    >>> np.round(coef, 12).tolist(), terms, centres.tolist()  # value and slope at x = 2
    ([4.0, 0.5], [(0,), (1,)], [2.0])
    """
    h = np.asarray(h, dtype=float)
    unit, centres, scales = _normalised(coords)
    coef, terms, count = _fit_normalised(h, unit, degree)
    if strict:
        _check_points(count, len(terms), "topography")
    for k, e in enumerate(terms):
        coef[..., k] /= np.prod(scales ** np.asarray(e))
    return coef, terms, centres


def detrend(h: np.ndarray, coords, degree: int, *, strict: bool = True) -> np.ndarray:
    """Heights minus their least-squares polynomial trend (NaN stays NaN).

    Parameters are those of :func:`fit_polynomial`; pass only the ``x`` coordinates to
    detrend each line of a map separately.

    Examples
    --------
    >>> x = np.arange(6.0)
    >>> h = 1.0 + 2.0 * x + np.array([0.1, -0.1, 0.1, -0.1, 0.1, -0.1])
    >>> h[2] = np.nan
    >>> bool(np.allclose(np.nanmean(detrend(h, (x,), 1)), 0.0))
    True
    """
    h = np.asarray(h, dtype=float)
    unit, _, _ = _normalised(coords)
    coef, terms, count = _fit_normalised(h, unit, degree)
    if strict:
        _check_points(count, len(terms), "topography")
    return h - _trend(coef, unit, terms)


def _trend(coef: np.ndarray, unit: list[np.ndarray], terms) -> np.ndarray:
    """Evaluate the polynomial of ``coef`` (last axis) on the normalised grid ``unit``."""
    nd = len(unit)
    trend = np.zeros(coef.shape[:-1] + tuple(u.size for u in unit))
    for k, e in enumerate(terms):
        basis = unit[-1] ** e[-1]
        if nd == 2:
            basis = np.multiply.outer(unit[0] ** e[0], basis)
        trend += coef[(...,) + (k,) + (None,) * nd] * basis
    return trend


def mad_detrend(h: np.ndarray, coords, degree: int) -> np.ndarray:
    """Heights minus the polynomial trend that minimises their MAD (robust detrending).

    The coefficients minimise the median absolute deviation of the residual from its
    median (SurfaceTopography's ``mad-tilt`` / ``mad-curvature``): a least-squares fit
    is pulled by spikes and by a few deep features, this one follows the bulk of the
    surface. Nelder-Mead from the least-squares fit, on the normalised coordinates, per
    map; the MAD does not see a constant, so the residual's median is set to 0.

    Examples
    --------
    >>> x = np.arange(200.0)
    >>> h = 0.5 * x + np.sin(x)  # a tilt on roughness, and ten points far above it
    >>> h[::20] += 1000.0
    >>> r = mad_detrend(h, (x,), 1)
    >>> bool(abs(np.median(np.diff(r))) < 0.05)  # the tilt is gone despite the spikes
    True
    """
    h = np.asarray(h, dtype=float)
    unit, _, _ = _normalised(coords)
    coef, terms, count = _fit_normalised(h, unit, degree)
    _check_points(count, len(terms), "topography")
    nd = len(unit)
    flat_h = h.reshape((-1,) + h.shape[h.ndim - nd:])
    flat_c = coef.reshape(-1, len(terms))
    out = np.empty_like(flat_h)
    for i, (one, start) in enumerate(zip(flat_h, flat_c)):
        valid = np.isfinite(one)
        basis = np.stack([_trend(np.eye(len(terms))[k], unit, terms)[valid]
                          for k in range(len(terms))], axis=-1)
        values = one[valid]

        def mad(c, values=values, basis=basis):
            r = values - basis @ c
            return np.median(np.abs(r - np.median(r)))

        scale = max(float(np.std(values)), np.finfo(float).tiny)
        simplex = start + np.vstack([np.zeros(len(terms)), 0.1 * scale * np.eye(len(terms))])
        best = optimize.minimize(mad, start, method="Nelder-Mead",
                                 options={"initial_simplex": simplex, "xatol": 1e-10 * scale,
                                          "fatol": 1e-12 * scale, "maxiter": 4000})
        residual = one - _trend(best.x, unit, terms)
        out[i] = residual - np.nanmedian(residual)  # the MAD leaves the offset free
    return out.reshape(h.shape)


def segment_starts(n: int, parts: int) -> tuple[np.ndarray, np.ndarray]:
    """Cut ``range(n)`` into ``parts`` contiguous segments as ``numpy.array_split`` does.

    Returns their sizes (``n // parts``, the first ``n % parts`` one more) and starts.

    Examples
    --------
    >>> [a.tolist() for a in segment_starts(7, 3)]
    [[3, 2, 2], [0, 3, 5]]
    """
    sizes = np.full(parts, n // parts)
    sizes[: n % parts] += 1
    return sizes, np.concatenate([[0], np.cumsum(sizes)[:-1]])


def _segments(n: int, parts: int) -> list[tuple[int, np.ndarray]]:
    """``(size, starts)`` of the segments of :func:`segment_starts`, per size class."""
    sizes, starts = segment_starts(n, parts)
    return [(int(size), starts[sizes == size]) for size in np.unique(sizes)]


def checkerboard_detrend(h: np.ndarray, coords, degree: int,
                         subdivisions: tuple[int, ...]) -> np.ndarray:
    """Detrend each tile of a checkerboard of the grid on its own (NaN stays NaN).

    The grid axes (the last ``len(coords)`` of ``h``) are cut into ``subdivisions``
    contiguous segments each (sizes as ``numpy.array_split`` gives them); every tile gets
    its own least-squares polynomial of total ``degree`` (:func:`detrend`, minimum-norm
    where a tile has fewer valid points than terms). Tiles of one size are fitted
    together, so the cost is that of one :func:`detrend` of the whole grid.

    Examples
    --------
    >>> h = np.array([1.0, 1.0, 0.0, 0.0, 5.0, 6.0])  # three flat or tilted segments
    >>> np.round(checkerboard_detrend(h, (np.arange(6.0),), 1, (3,)), 12).tolist()
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    """
    h = np.asarray(h, dtype=float)
    nd = len(coords)
    grid_shape = h.shape[h.ndim - nd:]
    for n, parts in zip(grid_shape, subdivisions):
        if not 1 <= parts <= n // 2:
            raise ValueError(f"subdivisions: {parts} tiles of an axis of {n} points leave "
                             "fewer than 2 points a tile")
    out = np.empty_like(h)
    classes = [_segments(n, parts) for n, parts in zip(grid_shape, subdivisions)]
    coords = [np.asarray(c, dtype=float) for c in coords]
    if nd == 1:
        for size, starts in classes[0]:
            idx = starts[:, None] + np.arange(size)  # (tiles, size)
            tiles = h[..., idx]
            out[..., idx] = detrend(tiles, (coords[0][:size],), degree, strict=False)
        return out
    for (sy, y0), (sx, x0) in itertools.product(*classes):
        iy = (y0[:, None] + np.arange(sy))[:, None, :, None]
        ix = (x0[:, None] + np.arange(sx))[None, :, None, :]
        tiles = h[..., iy, ix]  # (..., tiles y, tiles x, sy, sx)
        out[..., iy, ix] = detrend(tiles, (coords[0][:sy], coords[1][:sx]), degree,
                                   strict=False)
    return out


# --------------------------------------------------------------------------- outliers


def _padded(h: np.ndarray, half: tuple[int, ...], periodic: bool) -> np.ndarray:
    nd = len(half)
    pad = [(0, 0)] * (h.ndim - nd) + [(k, k) for k in half]
    if periodic:
        return np.pad(h, pad, mode="wrap")
    return np.pad(h, pad, mode="constant", constant_values=np.nan)


def _sorted_window_median(windows: np.ndarray) -> np.ndarray:
    """Median over the last axis ignoring NaN (np.sort puts NaN last); NaN if none valid."""
    s = np.sort(windows, axis=-1)
    k = np.isfinite(s).sum(axis=-1)
    lo = np.take_along_axis(s, np.maximum((k - 1) // 2, 0)[..., None], -1)[..., 0]
    hi = np.take_along_axis(s, np.maximum(k // 2, 0)[..., None], -1)[..., 0]
    return np.where(k > 0, 0.5 * (lo + hi), np.nan)


def pair_median_reference(h: np.ndarray, size: tuple[int, ...], *,
                          periodic: bool = False) -> np.ndarray:
    """Robust local reference: median of the means of point pairs placed symmetrically.

    For each point ``p`` and each offset ``d`` of the odd ``size`` window (one of ``d`` and
    ``-d``), the pair mean ``(h(p + d) + h(p - d)) / 2`` equals ``h(p)`` on any plane; the
    reference is the median of the pair means whose two points are valid. An outlier
    spoils only the pair it belongs to, so the median ignores spikes and small clusters
    (a running median would too, but is biased on slopes at edges and around missing
    points, where its window is one-sided, and :func:`scipy.ndimage.median_filter` orders
    NaN arbitrarily). NaN where no complete pair exists (corners, ends of profiles).

    Parameters
    ----------
    h : numpy.ndarray, shape ([ny,] nx)
        One map or profile; NaN marks missing points.
    size : tuple of int
        Odd window size along each axis, in pixels.
    periodic : bool
        Wrap the window around the edges.

    Examples
    --------
    >>> h = np.arange(11.0)
    >>> h[5] = 30.0  # a spike on a slope: the reference is the slope
    >>> pair_median_reference(h, (7,))
    array([nan,  1.,  2.,  3.,  4.,  5.,  6.,  7.,  8.,  9., nan])
    """
    h = np.asarray(h, dtype=float)
    nd = len(size)
    if h.ndim != nd or any(w < 3 or w % 2 == 0 for w in size):
        raise ValueError(f"need one {nd}-D map and odd window sizes >= 3, got {size}")
    half = tuple(w // 2 for w in size)
    grids = np.meshgrid(*[np.arange(-k, k + 1) for k in half], indexing="ij")
    offsets = np.stack([g.ravel() for g in grids], -1)
    leading = np.array([next((int(v) for v in o if v != 0), 0) for o in offsets])
    offsets = offsets[leading > 0]  # one offset of each symmetric pair
    padded = _padded(h, half, periodic)
    out = np.empty(h.shape)
    rows = max(1, _BLOCK_ELEMENTS // (len(offsets) * int(np.prod(h.shape[1:]))))
    for r0 in range(0, h.shape[0], rows):
        r1 = min(h.shape[0], r0 + rows)

        def shifted(o, sign, r0=r0, r1=r1):
            idx = [slice(r0 + half[0] + sign * o[0], r1 + half[0] + sign * o[0])]
            idx += [slice(half[d] + sign * o[d], half[d] + sign * o[d] + h.shape[d])
                    for d in range(1, nd)]
            return padded[tuple(idx)]

        means = np.stack([0.5 * (shifted(o, 1) + shifted(o, -1)) for o in offsets], -1)
        out[r0:r1] = _sorted_window_median(means)
    return out


def _sorted_quantile(s: np.ndarray, k: np.ndarray, q: float) -> np.ndarray:
    """Quantile ``q`` of rows sorted with NaN last, ``k`` valid values per row."""
    pos = q * np.maximum(k - 1, 0)
    lo = np.floor(pos).astype(int)[..., None]
    hi = np.ceil(pos).astype(int)[..., None]
    a = np.take_along_axis(s, lo, -1)[..., 0]
    b = np.take_along_axis(s, hi, -1)[..., 0]
    return np.where(k > 0, a + (b - a) * (pos - lo[..., 0]), np.nan)


def _zscore(r: np.ndarray, nd: int, method: str) -> np.ndarray:
    """``|r - centre| / scale`` per map; 0 where the scale is 0 (no outlier in a flat map)."""
    flat = r.reshape(r.shape[: r.ndim - nd] + (-1,))
    valid = np.isfinite(flat)
    n = valid.sum(axis=-1)
    mean = np.sum(np.where(valid, flat, 0.0), axis=-1) / np.maximum(n, 1)
    dev = np.where(valid, flat - mean[..., None], 0.0)
    std = np.sqrt(np.sum(dev**2, axis=-1) / np.maximum(n - 1, 1))
    if method == "std":
        centre, scale = mean, std
    else:
        s = np.sort(flat, axis=-1)
        centre = _sorted_quantile(s, n, 0.5)
        scale = MAD_TO_SIGMA * _sorted_window_median(np.abs(flat - centre[..., None]))
        # more than half the points at one height (quantised data): a wider quantile
        # range, then the standard deviation
        wide = (_sorted_quantile(s, n, 0.975) - _sorted_quantile(s, n, 0.025)
                ) / _WIDE_TO_SIGMA
        scale = np.where(scale > 0, scale, np.where(wide > 0, wide, std))
    good = np.isfinite(scale) & (scale > 0)
    dev = np.abs(flat - centre[..., None])
    z = np.where(good[..., None], dev / np.where(good, scale, 1.0)[..., None], 0.0)
    return np.where(valid, z, np.nan).reshape(r.shape)


def _window_moment(a: np.ndarray, size: tuple[int, ...], powers: tuple[int, ...],
                   periodic: bool) -> np.ndarray:
    """``sum_delta a(p + delta) * prod_d delta_d^powers_d`` over the window around each p."""
    out = a
    nd = len(size)
    for d, (w, e) in enumerate(zip(size, powers)):
        offsets = np.arange(w, dtype=float) - w // 2
        out = ndimage.correlate1d(out, offsets**e, axis=a.ndim - nd + d,
                                  mode="wrap" if periodic else "constant", cval=0.0)
    return out


def local_plane_reference(h: np.ndarray, size: tuple[int, ...], *,
                          periodic: bool = False) -> np.ndarray:
    """Value at each point of the least-squares plane through its valid neighbours.

    The plane (a line for profiles) is fitted to the valid (non-NaN) points of the odd
    ``size`` window around each point, *excluding the point itself*. Inside a map without
    missing points it is the mean of the neighbours; at the edges of a non-periodic map and
    next to missing points the slope term removes the bias a one-sided mean would have.
    A linear function of the heights: the residual of a Gaussian surface is Gaussian.
    Where the neighbours do not determine a plane, their mean is used; NaN where there is
    no valid neighbour.

    Examples
    --------
    >>> local_plane_reference(np.array([0.0, 1.0, 2.0, 30.0, 4.0, 5.0]), (3,))
    array([ 1. ,  1. , 15.5,  3. , 17.5,  4. ])
    >>> x = np.arange(6.0)  # a straight line is its own reference, edges included
    >>> bool(np.allclose(local_plane_reference(x, (5,)), x))
    True
    """
    h = np.asarray(h, dtype=float)
    nd = len(size)
    valid = np.isfinite(h)
    m = valid.astype(float)
    mh = np.where(valid, h, 0.0)
    powers = [(0,) * nd] + [tuple(int(i == d) for i in range(nd)) for d in range(nd)]
    # normal matrix of the plane a + sum_d b_d delta_d, centre point excluded
    normal = np.empty(h.shape + (nd + 1, nd + 1))
    rhs = np.empty(h.shape + (nd + 1,))
    for i, pi in enumerate(powers):
        rhs[..., i] = _window_moment(mh, size, pi, periodic)
        for j, pj in enumerate(powers[i:], start=i):
            normal[..., i, j] = normal[..., j, i] = _window_moment(
                m, size, tuple(a + b for a, b in zip(pi, pj)), periodic)
    normal[..., 0, 0] -= m
    rhs[..., 0] -= mh
    count = np.round(normal[..., 0, 0])
    det = np.linalg.det(normal)
    scale = np.prod(np.diagonal(normal, axis1=-2, axis2=-1), axis=-1)
    ok = (count > nd) & (np.abs(det) > 1e-9 * np.abs(scale))
    ref = np.full(h.shape, np.nan)
    if ok.any():
        sub = normal[ok]
        numerator = sub.copy()
        numerator[..., :, 0] = rhs[ok]
        ref[ok] = np.linalg.det(numerator) / det[ok]  # Cramer's rule for the intercept
    mean = (count > 0) & ~ok
    ref[mean] = rhs[..., 0][mean] / count[mean]
    return ref


def robust_zscore(h: np.ndarray, *, nd: int, method: str = "mad",
                  size: tuple[int, ...] | None = None, periodic: bool = False,
                  threshold: float = 5.0) -> np.ndarray:
    """Outlier score of each point: distance from a reference in units of a scale.

    Parameters
    ----------
    h : numpy.ndarray, shape (..., [ny,] nx)
        Heights; NaN marks missing points (their score is NaN).
    nd : int
        Number of grid axes (1 or 2) at the end of ``h``.
    method : {'mad', 'std'}
        Scale ``1.4826 * median|r - median(r)|`` (robust), or the standard deviation
        (around the mean). Where the MAD is 0 (more than half of the points at one height,
        as on coarsely quantised data), the central 95 % range divided by 3.92 is used, and
        where that is 0 too, the standard deviation.
    size : tuple of int, optional
        Odd window (pixels per grid axis) of the local reference; ``None`` scores the
        heights themselves against the median (``'mad'``) or mean (``'std'``) of the map.
    periodic : bool
        Wrap the window around the edges.
    threshold : float
        Score above which a point is a candidate of the median stage (window only).

    Returns
    -------
    numpy.ndarray
        ``|r - centre(r)| / scale`` of the residuals ``r``; 0 where the scale is 0 (a
        flat map has no outlier).

    Notes
    -----
    With a window, the residual is taken in two stages. A robust local median
    (:func:`pair_median_reference`) is blind to isolated spikes and small clusters, so its
    residual exposes them: the points scoring above ``threshold`` on it are the first
    outlier candidates. But a median is a nonlinear function of the heights, and its
    residual is not Gaussian on a Gaussian surface (on smooth data a plain 3 x 3 running
    median flags several percent of the points). The score is therefore taken from
    the residual of :func:`local_plane_reference` computed without the current
    candidates, which is linear in the heights (a Gaussian residual on Gaussian data,
    hence a known false-positive rate), unbiased at edges, and not pulled by the spikes.
    Candidates that score below ``threshold`` on it are put back among the neighbours and
    the plane stage is repeated until the set no longer changes (it only shrinks, so it
    cannot creep along edges or hole borders).

    Examples
    --------
    >>> h = np.array([0.0, 1.0, -1.0, 0.5, -0.5, 40.0])
    >>> np.round(robust_zscore(h, nd=1), 2)
    array([ 0.22,  0.67,  1.12,  0.22,  0.67, 35.75])
    """
    h = np.asarray(h, dtype=float)
    if method not in ("mad", "std"):
        raise ValueError(f"method must be 'mad' or 'std', got {method!r}")
    if size is None:
        return _zscore(h, nd, method)
    out = np.empty(h.shape)
    for b in np.ndindex(h.shape[: h.ndim - nd]):
        one = h[b] - _sorted_window_median(h[b].reshape(1, -1))[0]  # centred: conditioning
        z = _zscore(one - pair_median_reference(one, size, periodic=periodic), nd, "mad")
        excluded = np.isfinite(z) & (z > threshold)
        for _ in range(_MAX_ITERATIONS):
            ref = local_plane_reference(np.where(excluded, np.nan, one), size,
                                        periodic=periodic)
            z = _zscore(one - ref, nd, method)
            kept = excluded & (z > threshold)  # NaN compares False
            if np.array_equal(kept, excluded):
                break
            excluded = kept
        out[b] = z
    return out


def outlier_mask(h: np.ndarray, *, nd: int, threshold: float, method: str = "mad",
                 size: tuple[int, ...] | None = None, periodic: bool = False) -> np.ndarray:
    """Boolean mask of the valid points whose robust z-score exceeds ``threshold``.

    See :func:`robust_zscore` for the score; with a window, the candidates of the
    running-median stage are those above ``threshold`` too.

    Examples
    --------
    >>> outlier_mask(np.array([0.0, 1.0, -1.0, 0.5, -0.5, 40.0]), nd=1, threshold=5.0)
    array([False, False, False, False, False,  True])
    """
    z = robust_zscore(h, nd=nd, method=method, size=size, periodic=periodic,
                      threshold=threshold)
    return np.isfinite(z) & (z > threshold)


def local_excursions(h: np.ndarray, *, nd: int, z_min: float, half: int = 9) -> int:
    """Points that stand out from their neighbours along an axis by more than ``z_min``.

    Along each of the last ``nd`` axes, the reference of point ``i`` is the mean of the
    medians of the ``half`` points before it and of the ``half`` points after it (exact on
    a tilt, and blind to a spike narrower than ``half // 2 + 1`` points beside it); the
    residual from it, as a robust z-score over its map (:func:`robust_zscore` without a
    window), counts where it exceeds ``z_min``.  Missing points stand in as the map's
    median and are not counted, nor are the ``half`` points at either end.  On Gaussian
    surfaces none exceeds 20 (512^2 maps); a spike on a bowed or wavy profile can exceed
    100 while lying inside the range of the heights.

    Examples
    --------
    >>> h = np.sin(np.linspace(0, 3, 200)) + 1e-3 * np.random.default_rng(0).normal(size=200)
    >>> local_excursions(h, nd=1, z_min=30.0)
    0
    >>> h[50:52] += 0.5  # a spike two points wide, far inside the range of the heights
    >>> local_excursions(h, nd=1, z_min=30.0)
    2
    """
    h = np.asarray(h, dtype=float)
    valid = np.isfinite(h)
    flat = h.reshape(h.shape[: h.ndim - nd] + (-1,))
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN map: no median
        centre = np.nanmedian(flat, axis=-1)
    filled = np.nan_to_num(np.where(valid, h, np.reshape(centre, centre.shape + (1,) * nd)))
    found = np.zeros(h.shape, dtype=bool)
    for axis in range(h.ndim - nd, h.ndim):
        n = h.shape[axis]
        if n < 2 * half + 1:
            continue
        size = [1] * h.ndim
        size[axis] = half
        med = ndimage.median_filter(filled, size=size, mode="nearest")

        def cut(a, b, axis=axis):
            return tuple(slice(a, b) if i == axis else slice(None) for i in range(h.ndim))

        # the median of [i - half, i - 1] sits at i - (half + 1) // 2 of the centred filter
        shift = (half + 1) // 2
        residual = np.full(h.shape, np.nan)
        inner = cut(half, n - half)
        residual[inner] = filled[inner] - 0.5 * (
            med[cut(half - shift, n - half - shift)] + med[cut(half + shift, n - half + shift)])
        residual[~valid] = np.nan
        z = np.nan_to_num(_zscore(residual, nd, "mad"), nan=0.0)
        found |= z > z_min
    return int(found.sum())


# --------------------------------------------------------------- scale-dependent curvature


def min_curvature(h: np.ndarray, *, nd: int, axis: int, steps: np.ndarray, spacing: float,
                  periodic: bool = False) -> np.ndarray:
    """Most negative scale-dependent curvature along one grid axis, per map of a batch.

    ``kappa_k(x) = (h(x + k dx) - 2 h(x) + h(x - k dx)) / (k dx)^2`` over every point whose
    three heights are valid (wrapping around a periodic map), minimised over the map.

    Parameters
    ----------
    h : numpy.ndarray, shape (..., [ny,] nx)
        Heights; NaN marks missing points.
    nd : int
        Number of grid axes (1 or 2) at the end of ``h``.
    axis : int
        Which grid axis the stencil runs along: ``0`` for the first (``y`` of a map, ``x``
        of a profile), ``nd - 1`` for ``x``.
    steps : array of int
        Half-widths ``k`` of the stencil, in pixels.
    spacing : float
        Grid spacing along ``axis``; the curvature is in units of ``h`` per spacing unit
        squared.
    periodic : bool
        Wrap the stencil around the edges.

    Returns
    -------
    numpy.ndarray, shape (..., len(steps))
        The minimum over the map; NaN where no stencil fits between missing points and
        edges.

    Examples
    --------
    >>> x = np.arange(11.0)
    >>> min_curvature(-0.5 * x**2, nd=1, axis=0, steps=np.array([1, 2]), spacing=1.0)
    array([-1., -1.])
    """
    h = np.asarray(h, dtype=float)
    batch = h.shape[: h.ndim - nd]
    grid_axes = tuple(range(h.ndim - nd, h.ndim))
    n = h.shape[h.ndim - nd + axis]
    out = np.empty(batch + (len(steps),))
    least = np.fmin.reduce if np.isnan(h).any() else np.minimum.reduce  # fmin is slower
    with np.errstate(invalid="ignore"):
        for j, k in enumerate(np.asarray(steps, dtype=int)):
            k_mod = k % n if periodic else k
            if periodic and k_mod == 0:  # a whole period: h - 2 h + h
                out[..., j] = 0.0
                continue
            if not periodic and 2 * k >= n:
                out[..., j] = np.nan
                continue
            # the one stencil of xrough (_kernels.derivatives); NaN (a missing point)
            # ignored in the least over the map, NaN if all are
            kappa = second_difference(h, nd=nd, axis=axis, step=int(k_mod),
                                      periodic=periodic)
            out[..., j] = least(kappa, axis=grid_axes) / (k * spacing) ** 2
    out[~np.isfinite(out)] = np.nan
    return out
