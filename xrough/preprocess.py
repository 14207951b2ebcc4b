"""Preprocessing of measured topographies: detrending, outlier masking, reliability window.

The steps the field applies before any roughness statistics:

:func:`detrend`
    Remove the mean, a least-squares plane (tilt) or a quadratic surface (curvature of the
    sample or of the scanner), fitted to the valid points in physical coordinates, for the
    whole map or for each scan line (rows along ``x``: the usual remedy for the line-to-line
    offsets and tilts of AFM images). :func:`fit_trend` returns the fitted coefficients.
:func:`mask_outliers`
    Turn spikes and dimples into NaN, so that the mask-aware ``G(dr)`` simply leaves them out
    (paper, section 3.2, point 3), using robust z-scores based on the median absolute
    deviation, optionally of the residual from a local reference that follows large-scale
    roughness.
:func:`reliable`
    Record the lag range ``[reliable_dr_min, reliable_dr_max]`` that the instrument resolves
    (tip radius, lateral resolution, pixel size; scan size) in the attrs, for the steps that
    need it (:func:`reliability_window`).

A robust order is ``detrend -> mask_outliers -> detrend`` again: the first fit is slightly
pulled by the outliers, the second ignores them because they are NaN by then. Level offset
scan lines (``per_line=True``) before masking with a ``window``, and record the reliable
lag range last, on the cleaned map.

>>> import xrough
>>> from xrough import preprocess
>>> topo = xrough.self_affine_surface(hurst=0.8, lambda_r="1 um", lambda_s="100 nm",
...                                   size="4 um", n=128, rms_height="2 nm", seed=1,
...                                   unit="nm")
>>> tilted = topo + 0.01 * topo.x  # a tilt of 10 nm per um
>>> clean = preprocess.detrend(tilted, mode="plane")
>>> clean.attrs["detrend"], clean.attrs["units"]
('plane', 'nm')
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from . import quality
from . import units as u
from ._kernels import detrend as k
from ._kernels.checks import require_flag
from ._kernels.filling import harmonic_fill
from .topography import Grid, check_finite, grid_of, require_whole_maps
from .units import QuantityLike

__all__ = [
    "DETREND_MODES",
    "DETREND_FITS",
    "OUTLIER_METHODS",
    "detrend",
    "fit_trend",
    "mask_outliers",
    "reliable",
    "reliability_window",
    "lag_window",
    "LagWindow",
    "NO_WINDOW",
    "stated_tip_radius",
    "tip_window",
    "grid_coords",
    "detrend_degree",
    "fill_missing",
    "FILL_METHODS",
]

DETREND_MODES = tuple(k.DEGREES)
#: What :func:`detrend`'s polynomial minimises: the squares, or the median absolute deviation.
DETREND_FITS = ("least_squares", "mad")
#: mask_outliers without a window says how many points stand out from their neighbours
#: beyond this robust z of the residual from the medians of the 9 points on either side
#: along x or y (:func:`xrough._kernels.detrend.local_excursions`): none on Gaussian
#: self-affine maps (20 maps of 512^2), the 30 bumps of dektak-1.csv that a glance shows
#: (1 um wide, inside the range of the heights), and spikes or sharp features of real
#: maps (sur-2: 141, nid-1: 129, spot_1: 164, plu-1: 8; x3p-2, di-1, opd-1: none).
LOCAL_EXCURSION = 30.0
OUTLIER_METHODS = ("mad", "std")
#: Default ``safety_factor`` of the tip-radius rule (Sanner et al. 2022, see :func:`reliable`).
TIP_SAFETY_FACTOR = 0.5


# ------------------------------------------------------------------------------- helpers


def _validated(topography: xr.DataArray) -> Grid:
    grid = grid_of(topography)
    require_whole_maps(topography, grid, purpose="preprocessing")
    return grid


def grid_coords(topography: xr.DataArray, grid: Grid) -> tuple[np.ndarray, ...]:
    """Core coordinates as float arrays in the lateral unit of the grid."""
    out = []
    for d in grid.dims:
        coord = topography.coords[d]
        factor = u.conversion_factor(u.units_of(coord, what=f"coordinate {d!r}"),
                                     grid.lateral_unit)
        out.append(np.asarray(coord.values, dtype=float) * factor)
    return tuple(out)


def detrend_degree(mode: str, per_line: Any, grid: Grid) -> int:
    """Return the polynomial degree of a detrending ``mode``, its arguments checked."""
    if mode not in DETREND_MODES:
        raise ValueError(f"mode must be one of {DETREND_MODES}, got {mode!r}")
    require_flag(per_line, "per_line")
    if per_line and len(grid.dims) != 2:
        raise ValueError("per_line=True detrends each scan line (row along 'x') of a map "
                         "with dims ('y', 'x'); this topography is a profile: use "
                         "per_line=False")
    return k.DEGREES[mode]


def _like(topography: xr.DataArray, result: xr.DataArray, attrs: dict) -> xr.DataArray:
    """Put ``result`` in the dims order, coords (with attrs) and name of the input."""
    out = topography.copy(data=result.transpose(*topography.dims).data)
    out.attrs = attrs
    return out


def _label(mode: str, per_line: bool) -> str:
    return f"{mode} per line" if per_line else mode


# ------------------------------------------------------------------------------ detrend


def _detrend_kernel(h, *, coords, degree, per_line, subdivisions=None, fit="least_squares"):
    check_finite(h)
    if fit == "mad":
        return k.mad_detrend(h, coords, degree)
    if subdivisions is not None:
        if per_line:
            return k.checkerboard_detrend(h, coords[-1:], degree, subdivisions[-1:])
        return k.checkerboard_detrend(h, coords, degree, subdivisions)
    if per_line:
        return k.detrend(h, coords[-1:], degree, strict=False)
    return k.detrend(h, coords, degree, strict=True)


def _subdivisions(subdivisions: Any, grid: Grid) -> tuple[int, ...] | None:
    """``subdivisions`` as one count per grid axis (None: the whole map at once)."""
    if subdivisions is None:
        return None
    counts = ((subdivisions,) * len(grid.dims) if np.ndim(subdivisions) == 0
              else tuple(subdivisions))
    if len(counts) != len(grid.dims) or not all(
            isinstance(c, (int, np.integer)) and not isinstance(c, bool) and c >= 1
            for c in counts):
        raise ValueError(f"subdivisions must be a positive integer or one per grid axis "
                         f"{grid.dims}, got {subdivisions!r}")
    return None if all(c == 1 for c in counts) else tuple(int(c) for c in counts)


@u.accepts_quantified
def detrend(topography: xr.DataArray, *, mode: str = "plane",
            per_line: bool = False, subdivisions: int | tuple[int, ...] | None = None,
            fit: str = "least_squares") -> xr.DataArray:
    r"""Remove a least-squares polynomial trend: mean, plane (tilt) or curvature.

    The fit minimises :math:`\sum_{\text{valid}} [h(\mathbf r) - P(\mathbf r)]^2` over the
    valid points only, in the physical coordinates of the grid, so the result depends
    neither on the units nor on the values hidden by NaN. Notes (lines with few points,
    the effect of ``per_line``, the robust fit): docs/cleaning.md, "Detrending".

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        Heights with length units on data and coordinates; NaN marks missing points.
        Extra dims (``scan``...) are independent maps; dask stacks need one chunk a map.
    mode : {'mean', 'plane', 'curvature'}
        Subtract the mean height, the least-squares plane ``a + b x + c y`` (a line for a
        profile or per line), or the quadratic surface ``a + b x + c y + d x^2 + e x y +
        f y^2`` (a parabola for a profile or per line).
    per_line : bool
        Fit each scan line (row along ``x``) of a map separately, for AFM line artefacts;
        it also removes real roughness (the profile of the line means along ``y``).
    subdivisions : int or tuple of int, optional
        Checkerboard detrending: fit each of ``(n_y, n_x)`` tiles on its own (with
        ``per_line``, ``n_x`` segments a line); see :func:`xrough.variable_bandwidth`.
    fit : {'least_squares', 'mad'}
        Minimise the mean square of the residual, or its median absolute deviation
        (robust to spikes; each map whole, by Nelder-Mead: seconds on a megapixel map).

    Returns
    -------
    xarray.DataArray
        The residual heights, same dims, coords, units and attrs as the input, with
        ``attrs["detrend"]`` recording the mode (``"plane"``, ``"curvature per line"``;
        successive calls are joined by ``"; "``). A plane or curvature is not periodic,
        so removing one sets ``attrs["periodic"] = 0``; ``'mean'`` keeps it.

    Raises
    ------
    ValueError
        Unknown ``mode``, ``per_line`` on a profile, invalid topography (dims, units,
        spacing), core dims split into dask chunks, infinite heights (an invalid point:
        :func:`mask_outliers` turns them into NaN), or a map with fewer valid points than
        the fit has coefficients.

    See Also
    --------
    fit_trend : the fitted coefficients.
    mask_outliers : outliers pull least-squares fits; mask them, then detrend again.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> from xrough.preprocess import detrend
    >>> x = np.arange(8.0)
    >>> h = 5.0 + 0.2 * x + 0.1 * (-1) ** np.arange(8)  # tilt on a zigzag, in nm
    >>> topo = xrough.topography(h, spacing=1.0, unit="nm")
    >>> out = detrend(topo, mode="plane")
    >>> np.round(out.values, 3)
    array([ 0.067, -0.124,  0.086, -0.105,  0.105, -0.086,  0.124, -0.067])
    >>> out.attrs["detrend"], out.attrs["units"], out.x.attrs["units"]
    ('plane', 'nm', 'nm')
    """
    grid = _validated(topography)
    degree = detrend_degree(mode, per_line, grid)
    tiles = _subdivisions(subdivisions, grid)
    if fit not in DETREND_FITS:
        raise ValueError(f"fit must be one of {DETREND_FITS}, got {fit!r}")
    if fit == "mad" and (per_line or tiles is not None):
        raise ValueError("fit='mad' fits each map whole: not with per_line or subdivisions")
    for d, count in zip(grid.dims[-1:] if per_line else grid.dims, (tiles or ())[
            -1:] if per_line else (tiles or ())):
        if count > topography.sizes[d] // 2:
            raise ValueError(f"subdivisions: {count} tiles along {d!r} of "
                             f"{topography.sizes[d]} points leave fewer than 2 a tile")
    result = xr.apply_ufunc(
        _detrend_kernel, topography, input_core_dims=[list(grid.dims)],
        output_core_dims=[list(grid.dims)], dask="parallelized", output_dtypes=[float],
        kwargs={"coords": grid_coords(topography, grid), "degree": degree,
                "per_line": bool(per_line), "subdivisions": tiles, "fit": fit},
        keep_attrs=False)
    attrs = dict(topography.attrs)
    label = _label(mode, bool(per_line))
    if tiles is not None:
        label += f" in {'x'.join(map(str, tiles[-1:] if per_line else tiles))} tiles"
    if fit == "mad":
        label += " (MAD fit)"
    attrs["detrend"] = f"{attrs['detrend']}; {label}" if attrs.get("detrend") else label
    if degree > 0:
        attrs["periodic"] = 0
    return _like(topography, result, attrs)


def _fit_kernel(h, *, coords, degree, per_line):
    check_finite(h)
    if per_line:
        return k.fit_polynomial(h, coords[-1:], degree, strict=False)[0]
    return k.fit_polynomial(h, coords, degree, strict=True)[0]


def _term_name(e: tuple[int, ...]) -> tuple[str, float, int, str]:
    """Variable name, factor from monomial coefficient to derivative, order, long name."""
    ey, ex = (0, e[0]) if len(e) == 1 else e
    names = {(0, 0): ("offset", 1.0, "height of the trend at the centre of the grid"),
             (0, 1): ("slope_x", 1.0, "slope dh/dx of the trend"),
             (1, 0): ("slope_y", 1.0, "slope dh/dy of the trend"),
             (0, 2): ("curvature_x", 2.0, "second derivative d2h/dx2 of the trend"),
             (1, 1): ("curvature_xy", 1.0, "mixed derivative d2h/dxdy of the trend"),
             (2, 0): ("curvature_y", 2.0, "second derivative d2h/dy2 of the trend")}
    name, factor, long_name = names[(ey, ex)]
    return name, factor, ey + ex, long_name


@u.accepts_quantified
def fit_trend(topography: xr.DataArray, *, mode: str = "plane",
              per_line: bool = False) -> xr.Dataset:
    """Coefficients of the least-squares trend that :func:`detrend` removes.

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        As for :func:`detrend`.
    mode : {'mean', 'plane', 'curvature'}
    per_line : bool
        One fit per row along ``x`` (the coefficients then have a ``y`` dim).

    Returns
    -------
    xarray.Dataset
        The trend as a Taylor expansion about the centre of the grid ``(x_c, y_c)``
        (``attrs["x_centre"]``, ``attrs["y_centre"]``, in the lateral unit):
        ``offset`` (height at the centre), ``slope_x``, ``slope_y`` (height per lateral
        unit), ``curvature_x``, ``curvature_xy``, ``curvature_y`` (second derivatives,
        height per lateral unit squared), as far as the mode and dims have them. Each
        variable carries its ``units``; extra dims (and ``y`` per line) are kept.

    Raises
    ------
    ValueError
        As :func:`detrend`.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> from xrough.preprocess import fit_trend
    >>> x = np.arange(11.0)  # um
    >>> topo = xrough.topography(3.0 + 0.5 * x - 0.1 * x**2, spacing="1 um",
    ...                          height_unit="nm")
    >>> c = fit_trend(topo, mode="curvature")
    >>> [round(float(c[v]), 6) for v in ("offset", "slope_x", "curvature_x")]
    [3.0, -0.5, -0.2]
    >>> c["slope_x"].attrs["units"], c["curvature_x"].attrs["units"], c.attrs["x_centre"]
    ('nm um-1', 'nm um-2', 5.0)
    """
    grid = _validated(topography)
    degree = detrend_degree(mode, per_line, grid)
    coords = grid_coords(topography, grid)
    terms = k.polynomial_terms(1 if per_line else len(grid.dims), degree)
    out_dims = ["y", "term"] if per_line else ["term"]
    coef = xr.apply_ufunc(
        _fit_kernel, topography, input_core_dims=[list(grid.dims)],
        output_core_dims=[out_dims], dask="parallelized", output_dtypes=[float],
        dask_gufunc_kwargs={"output_sizes": {"term": len(terms)}},
        kwargs={"coords": coords, "degree": degree, "per_line": bool(per_line)},
        keep_attrs=False)
    hunit = u.parse_units(grid.height_unit)
    lunit = u.parse_units(grid.lateral_unit)
    variables = {}
    for j, e in enumerate(terms):
        name, factor, order, long_name = _term_name(e)
        var = coef.isel(term=j, drop=True) * factor
        var.attrs = {"units": u.format_units(hunit / lunit**order), "long_name": long_name}
        variables[name] = var
    ds = xr.Dataset(variables)
    if per_line:
        ds = ds.assign_coords(y=topography.coords["y"])
    attrs: dict[str, Any] = {"mode": _label(mode, bool(per_line)),
                             "lateral_units": grid.lateral_unit}
    for d, c in zip(grid.dims, coords):
        attrs[f"{d}_centre"] = float(0.5 * (c[0] + c[-1]))
    ds.attrs = attrs
    return ds


# ------------------------------------------------------------------------- missing points

#: How :func:`fill_missing` fills: Laplace's equation, the mean, or a given value.
FILL_METHODS = ("harmonic", "mean", "constant")


@u.accepts_quantified
def fill_missing(topography: xr.DataArray, *, method: str = "harmonic",
                 value: QuantityLike | None = None) -> xr.DataArray:
    r"""Fill the missing (NaN) points of each map, for what needs every point.

    G, the PSD and the parameters skip missing points themselves and need no filling;
    Fourier filters (:func:`xrough.shortcut`), the contact solver and exports to tools
    without masks do. SurfaceTopography's ``interpolate_undefined_data`` (harmonic) and
    ``fill_undefined_data`` (a value).

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        Heights with units, NaN where missing; extra dims are filled map by map (lazy on
        dask, one map per chunk).
    method : {'harmonic', 'mean', 'constant'}
        ``'harmonic'``: the values that solve Laplace's equation :math:`\nabla^2 h = 0`
        with the valid points as boundary values (the 5-point Laplacian weighted by each
        axis' spacing; neighbours wrap around on a periodic map): smooth, within the range
        of the valid neighbours, exact for planes. ``'mean'``: the mean of the valid
        points. ``'constant'``: ``value``.
    value : float, str or Quantity, optional
        The height of ``'constant'`` (numbers in the height unit).

    Returns
    -------
    xarray.DataArray
        The heights with no NaN, dims, coords and attrs of the input, with
        ``attrs["filled"]`` saying how many points were filled and how.

    Raises
    ------
    ValueError
        Unknown ``method``, ``value`` missing or given with another method, a map with no
        valid point, an invalid topography.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> topo = xrough.topography([0.0, np.nan, np.nan, 3.0], spacing=1.0, unit="nm")
    >>> filled = xrough.fill_missing(topo)
    >>> filled.values.tolist(), filled.attrs["filled"]
    ([0.0, 1.0, 2.0, 3.0], '2 points (harmonic)')
    """
    grid = grid_of(topography)
    require_whole_maps(topography, grid, purpose="filling missing points")
    if method not in FILL_METHODS:
        raise ValueError(f"method must be one of {FILL_METHODS}, got {method!r}")
    if (value is None) == (method == "constant"):
        raise ValueError("value= goes with method='constant' (and only with it)")
    fill = (None if value is None else
            float(np.reshape(u.magnitude_in(value, grid.height_unit, what="value"), -1)[0]))
    kernel = functools.partial(_fill_kernel, method=method, value=fill,
                               spacing=grid.spacing, periodic=grid.periodic,
                               nd=len(grid.dims))
    result = xr.apply_ufunc(kernel, topography, input_core_dims=[list(grid.dims)],
                            output_core_dims=[list(grid.dims)], dask="parallelized",
                            output_dtypes=[float], keep_attrs=False)
    out = _like(topography, result, dict(topography.attrs))
    if topography.chunks is None:
        n = int(np.isnan(topography.values).sum())
        out.attrs["filled"] = f"{n} points ({method})"
    else:
        out.attrs["filled"] = f"missing points ({method})"
    return out


def _fill_kernel(h, *, method, value, spacing, periodic, nd):
    h = check_finite(h)
    grid_axes = tuple(range(h.ndim - nd, h.ndim))
    if np.any(np.isnan(h).all(axis=grid_axes)):
        raise ValueError("a map has no valid point to fill from")
    if method == "harmonic":
        return harmonic_fill(h, spacing=spacing, periodic=periodic)
    fill = (np.nanmean(h, axis=grid_axes, keepdims=True) if method == "mean"
            else np.asarray(value))
    return np.where(np.isnan(h), fill, h)


# ------------------------------------------------------------------------------ outliers


def _window_pixels(window: QuantityLike, grid: Grid) -> tuple[int, ...]:
    length = u.length_in(window, grid.lateral_unit, what="window")
    size = []
    for d, n, step in zip(grid.dims, grid.shape, grid.spacing):
        w = max(3, 2 * int(np.floor((length / step - 1) / 2 + 0.5)) + 1)
        if w > n:
            raise ValueError(f"window = {length:g} {grid.lateral_unit} is {w} pixels along "
                             f"{d!r}, more than the {n} points of the map; use a smaller "
                             "window")
        size.append(w)
    return tuple(size)


def _mask_kernel(h, *, nd, threshold, method, size, periodic):
    h = np.where(np.isinf(h), np.nan, h)  # invalid points, left out of the statistics
    bad = k.outlier_mask(h, nd=nd, threshold=threshold, method=method, size=size,
                         periodic=periodic)
    return np.where(bad, np.nan, h)


@u.accepts_quantified
def mask_outliers(topography: xr.DataArray, *, threshold: float = 5.0, method: str = "mad",
                  window: QuantityLike | None = None) -> xr.DataArray:
    r"""Mark spikes and dimples as missing (NaN) by robust z-scores.

    A point is an outlier when its height (or, with a ``window``, its residual ``r`` from a
    local plane) has

    .. math:: z = \frac{|r - \operatorname{med} r|}{1.4826\,\operatorname{med}
              |r - \operatorname{med} r|} > \text{threshold},

    the scale being the median absolute deviation (MAD) of its map. The mask-aware
    ``G(dr)`` then averages over the remaining pairs, which leaves its large-lag
    statistics intact (paper, section 3.2). Notes (a MAD of 0, the two-stage local
    reference, false-positive rates): docs/cleaning.md, "Outlier masking".

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        Heights with length units; NaN marks missing points (left as they are); infinite
        heights are masked too. Each map of a stack gets its own statistics.
    threshold : float
        Positive number of standard deviations; the default 5 flags 0.6 points per
        million of Gaussian data, 3.5 is the classical choice for small maps.
    method : {'mad', 'std'}
        Scale ``1.4826 * MAD`` (robust), or the plain standard deviation (classical sigma
        clipping; outliers inflate it and can hide each other).
    window : float, str or Quantity, optional
        Width (numbers in the lateral unit) of the neighbourhood each point is judged
        against (odd pixels, at least 3), for spikes on large-scale roughness, tilts or
        curvature. ``None`` (default) judges the heights: detrend first.

    Returns
    -------
    xarray.DataArray
        The topography with outliers set to NaN, same coords and units; attrs
        ``outlier_method`` (a description), ``outlier_threshold`` and, in memory (not
        dask), ``outliers_masked`` (over the stack) and ``outlier_fraction`` (of valid points).

    Raises
    ------
    ValueError
        Non-positive or non-finite ``threshold``, unknown ``method``, a window that is
        not a positive length or exceeds the map, invalid topography or chunking.

    See Also
    --------
    detrend : mask outliers before the final detrending (they pull least-squares fits).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> from xrough.preprocess import mask_outliers
    >>> h = np.random.default_rng(0).normal(size=(64, 64))
    >>> h[10, 20], h[40, 5] = 25.0, -30.0  # a spike and a dimple, in nm
    >>> topo = xrough.topography(h, spacing="5 nm", unit="nm")
    >>> out = mask_outliers(topo)
    >>> out.attrs["outliers_masked"], bool(np.isnan(out[10, 20])), bool(np.isnan(out[40, 5]))
    (2, True, True)
    >>> out = mask_outliers(topo, window="25 nm")  # against 5 x 5 neighbourhoods
    >>> out.attrs["outlier_method"]
    'mad, residual from a local reference over 5 x 5 pixels (y, x)'
    """
    grid = _validated(topography)
    if isinstance(threshold, (bool, np.bool_)) or not isinstance(
            threshold, (int, float, np.integer, np.floating)) or not (
            np.isfinite(threshold) and threshold > 0):
        raise ValueError(f"threshold must be a positive number of standard deviations, got "
                         f"{threshold!r}")
    if method not in OUTLIER_METHODS:
        raise ValueError(f"method must be one of {OUTLIER_METHODS}, got {method!r}")
    size = None if window is None else _window_pixels(window, grid)
    result = xr.apply_ufunc(
        _mask_kernel, topography, input_core_dims=[list(grid.dims)],
        output_core_dims=[list(grid.dims)], dask="parallelized", output_dtypes=[float],
        kwargs={"nd": len(grid.dims), "threshold": float(threshold), "method": method,
                "size": size, "periodic": grid.periodic}, keep_attrs=False)
    attrs = dict(topography.attrs)
    desc = method
    if size is not None:
        desc += (f", residual from a local reference over {' x '.join(map(str, size))} "
                 f"pixels ({', '.join(grid.dims)})")
    attrs["outlier_method"] = desc
    attrs["outlier_threshold"] = float(threshold)
    attrs.pop("outliers_masked", None)
    attrs.pop("outlier_fraction", None)
    note = None
    if result.chunks is None:
        before = int((~np.isnan(topography.values)).sum())
        masked = before - int(np.isfinite(result.values).sum())
        attrs["outliers_masked"] = masked
        attrs["outlier_fraction"] = masked / before if before else 0.0
        if size is None:  # what a global threshold cannot see
            found = k.local_excursions(result.values, nd=len(grid.dims),
                                       z_min=LOCAL_EXCURSION)
            attrs["outlier_local_excursions"] = found
            if found:
                note = (f"{found} points stand out from their neighbours by more than "
                        f"{LOCAL_EXCURSION:g} robust standard deviations (of the residual "
                        "from the medians of their neighbours along x or y), which a "
                        f"global threshold of {threshold:g} robust standard deviations of "
                        "the heights does not see (the heights' spread holds the form and "
                        "the large-scale roughness): spikes, or sharp features of the "
                        "surface: look at them, or judge each point against its "
                        "neighbourhood with window=")
    out = _like(topography, result, attrs)
    return quality.mark(out, note, what="mask_outliers") if note else out


# --------------------------------------------------------------------------- reliability


def _stencil_steps(n: int) -> np.ndarray:
    """Half-widths ``k`` (pixels) at which the scale-dependent curvature is evaluated."""
    kmax = max(1, n // 4)
    steps = np.unique(np.concatenate([np.arange(1, min(kmax, 16) + 1),
                                      np.geomspace(1, kmax, 40).round().astype(int)]))
    return steps[steps <= kmax]


def _curvature_kernel(h, **kwargs):
    return k.min_curvature(check_finite(h), **kwargs)


def tip_cutoff(topography: xr.DataArray, grid: Grid, tip_radius: float,
                safety_factor: float) -> tuple[float | None, str]:
    """Return the stencil length below which a tip of radius R cannot follow the curvature.

    The tip rule of :func:`reliable` (``tip_radius`` and ``safety_factor`` in the lateral
    unit of ``grid``), shared with :func:`xrough.stitch`: ``(cutoff, how)``, the cutoff
    ``None`` when no stencil of the map resolves the tip.
    """
    nd = len(grid.dims)
    hfactor = u.conversion_factor(grid.height_unit, grid.lateral_unit)
    target = -safety_factor / tip_radius
    extra = [d for d in topography.dims if d not in grid.dims]
    cutoffs = []
    # along the fast scan axis (x, the last) only, as contact.engineering: across the scan
    # lines the curvature holds their offsets and drift, which no tip makes
    # (tests/test_preprocess.py, test_tip_rule_reads_the_fast_scan_axis)
    fast = nd - 1
    for axis, (n, step) in enumerate(zip(grid.shape, grid.spacing)):
        if axis != fast:
            continue
        steps = _stencil_steps(n)
        low = xr.apply_ufunc(
            _curvature_kernel, topography, input_core_dims=[list(grid.dims)],
            output_core_dims=[["stencil"]], dask="parallelized", output_dtypes=[float],
            dask_gufunc_kwargs={"output_sizes": {"stencil": len(steps)}},
            kwargs={"nd": nd, "axis": axis, "steps": steps, "spacing": step,
                    "periodic": grid.periodic}, keep_attrs=False)
        if extra:
            low = low.min(extra, skipna=True)
        kappa = np.asarray(low.values, dtype=float) * hfactor  # 1 / lateral unit
        dist = steps * step
        too_curved = np.isfinite(kappa) & (kappa < target)
        if not too_curved.any():
            continue  # the tip follows the topography at every scale along this axis
        j = int(np.flatnonzero(too_curved)[-1])
        if j + 1 >= len(steps):
            cutoffs.append(2 * dist[-1])  # nothing reliable up to n/4: reported as is
            continue
        k1, k2 = kappa[j], kappa[j + 1]
        if np.isfinite(k2) and k2 < 0:  # power law between the bracketing distances
            t = np.log(target / k1) / np.log(k2 / k1)
            cross = dist[j] * (dist[j + 1] / dist[j]) ** t
        else:
            cross = dist[j + 1]
        cutoffs.append(2 * cross)  # the stencil spans 2 d
    if not cutoffs:
        return None, (f"tip radius {tip_radius:g} {grid.lateral_unit}: no scale curved "
                      "beyond it")
    return max(cutoffs), (f"tip radius {tip_radius:g} {grid.lateral_unit} (scale-dependent "
                          f"curvature above -{safety_factor:g}/R)")


@u.accepts_quantified
def reliable(
    topography: xr.DataArray,
    *,
    short_cutoff: QuantityLike | None = None,
    long_cutoff: QuantityLike | None = None,
    tip_radius: QuantityLike | None = None,
    lateral_resolution: QuantityLike | None = None,
    safety_factor: float = TIP_SAFETY_FACTOR,
    min_pixels: float = 1.0,
    long_fraction: float = 0.5,
) -> xr.DataArray:
    r"""Record the lag range the measurement resolves: ``reliable_dr_min/max`` in attrs.

    Every given criterion is a limit and the window is their intersection,
    ``dr_min = max(short_cutoff or min_pixels * pixel, lateral_resolution, tip cutoff)``
    and ``dr_max = long_cutoff or long_fraction * scan size``. The tip cutoff (Sanner et
    al., Appl. Surf. Sci. Adv. 7, 100190, 2022) is where the minimum of the curvature
    :math:`[h(x + d) - 2 h(x) + h(x - d)] / d^2` along the fast scan axis rises above
    :math:`-\text{safety\_factor}/R` for good, as the stencil length ``2 d``. Notes:
    docs/cleaning.md, "The reliability window".

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        Heights with length units (ideally detrended and with outliers masked: spikes
        look infinitely curved to the tip rule). A stack gets one window for all maps.
    short_cutoff, long_cutoff : float, str or Quantity, optional
        Explicit limits (numbers in the lateral unit) replacing the defaults.
    tip_radius : float, str or Quantity, optional
        Radius ``R`` of a scanning-probe tip (numbers in the lateral unit), for the tip
        cutoff. The data are read to find it (dask input is computed).
    lateral_resolution : float, str or Quantity, optional
        Instrument resolution (optical, beam or stylus size; numbers in the lateral unit).
    safety_factor : float
        The tip rule flags curvatures below ``-safety_factor / R`` (default 1/2).
    min_pixels : float
        Default short cutoff in pixels (of the coarser spacing); 1 keeps every lag of G.
    long_fraction : float
        Default long cutoff as a fraction ``0 < f <= 1`` of the scan size (the shorter
        side of a map), 1/2 by default.

    Returns
    -------
    xarray.DataArray
        The same topography (data untouched, dask stays lazy without ``tip_radius``) with
        attrs ``reliable_dr_min``, ``reliable_dr_max`` (in the lateral unit),
        ``reliable_dr_units`` (that unit) and ``reliable_rule`` (how they were found).

    Raises
    ------
    ValueError
        Non-positive lengths or factors, ``long_fraction`` outside ``(0, 1]``, an empty
        window (e.g. a tip too blunt for the scan), or infinite heights.

    See Also
    --------
    reliability_window : read the window back, in the current lateral unit.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> from xrough.preprocess import reliable, reliability_window
    >>> topo = xrough.topography(np.zeros((32, 64)), spacing="2 nm", unit="nm")
    >>> out = reliable(topo, lateral_resolution="10 nm")
    >>> reliability_window(out)  # 10 nm, and half of the 64 nm side
    (10.0, 32.0)
    >>> out.attrs["reliable_dr_units"], out.attrs["reliable_rule"]
    ('nm', 'dr_min: lateral resolution 10 nm; dr_max: 0.5 x scan size 64 nm')
    """
    grid = _validated(topography)
    if topography.chunks is None:  # dask input is read only by the tip rule (and checked)
        check_finite(topography.values)
    lunit = grid.lateral_unit
    for name, value in (("safety_factor", safety_factor), ("min_pixels", min_pixels),
                        ("long_fraction", long_fraction)):
        if isinstance(value, (bool, np.bool_)) or not isinstance(
                value, (int, float, np.integer, np.floating)) or not (
                np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number, got {value!r}")
    if long_fraction > 1:
        raise ValueError(f"long_fraction must be in (0, 1], got {long_fraction!r}")
    pixel = max(grid.spacing)
    if short_cutoff is not None:
        base = u.length_in(short_cutoff, lunit, what="short_cutoff")
        limits = [(base, f"short cutoff {base:g} {lunit}")]
    else:
        limits = [(min_pixels * pixel,
                   f"{min_pixels:g} pixel{'s' if min_pixels != 1 else ''} of {pixel:g} "
                   f"{lunit}")]
    if lateral_resolution is not None:
        res = u.length_in(lateral_resolution, lunit, what="lateral_resolution")
        limits.append((res, f"lateral resolution {res:g} {lunit}"))
    notes = []
    if tip_radius is not None:
        radius = u.length_in(tip_radius, lunit, what="tip_radius")
        cut, text = tip_cutoff(topography, grid, radius, float(safety_factor))
        if cut is None:
            notes.append(text)
        else:
            limits.append((cut, text))
    lo, lo_text = max(limits, key=lambda item: item[0])
    lo_rule = [lo_text, *notes]
    if long_cutoff is not None:
        hi = u.length_in(long_cutoff, lunit, what="long_cutoff")
        hi_rule = f"long cutoff {hi:g} {lunit}"
    else:
        side = min(grid.size)
        hi = long_fraction * side
        hi_rule = f"{long_fraction:g} x scan size {side:g} {lunit}"
    if not lo < hi:
        raise ValueError(
            f"no reliable lag range: dr_min = {lo:g} {lunit} ({'; '.join(lo_rule)}) is not "
            f"below dr_max = {hi:g} {lunit} ({hi_rule})"
        )
    attrs = dict(topography.attrs)
    attrs.update(reliable_dr_min=float(lo), reliable_dr_max=float(hi),
                 reliable_dr_units=lunit,
                 reliable_rule=f"dr_min: {'; '.join(lo_rule)}; dr_max: {hi_rule}")
    out = topography.copy(deep=False)
    out.attrs = attrs
    return out


#: Where files state the radius of their tip or stylus: an attribute named like
#: ``tip_radius`` / ``Stylus`` / ``probe`` whose text holds ``radius`` (or ``radii``) and
#: a length, e.g. a Dektak header's ``Stylus: Radius: 2.5 µm``.
_TIP_KEY = re.compile(r"tip|stylus|probe|cantilever", re.IGNORECASE)
_TIP_TEXT = re.compile(r"radi(?:us|i)\b[^0-9~\n]{0,12}~?\s*([0-9]*\.?[0-9]+(?:[eE][-+]?\d+)?)"
                       r"\s*(nm|µm|μm|um|mm|m)\b", re.IGNORECASE)


def stated_tip_radius(attrs: dict) -> tuple[str, str] | None:
    """Find the tip (stylus) radius a file's metadata state, and the attribute stating it.

    Looks through attributes whose name or value names a tip, stylus or probe for
    ``radius <number> <length unit>`` (``tip_radius`` itself may be a number in the
    ``tip_radius_units``, else the lateral unit is not assumed: a bare number is skipped,
    as is a radius that is not a positive length in a unit pint knows: metadata never
    stop the analysis).
    Where several radii are stated (a tip measured before and after the scan), the largest
    counts: the bluntest tip the scan may have had.

    Returns
    -------
    (str, str) or None
        ``("2.5 um", "Stylus")``: the radius as a length string, and the attribute's name.

    Examples
    --------
    >>> stated_tip_radius({"Stylus": "Radius: 2.5 µm", "Force": "3 mg"})
    ('2.5 um', 'Stylus')
    >>> stated_tip_radius({"description": "Initial tip radii - 17 nm. Final tip radii - 26 nm"})
    ('26 nm', 'description')
    >>> stated_tip_radius({"Scan": "2 um"}) is None
    True
    >>> stated_tip_radius({"tip_radius": 20.0, "tip_radius_units": "pixels"}) is None
    True
    """
    def length(number, unit, key):
        """``(value, unit in xrough's spelling, metres, key)``; None if it is no length."""
        try:
            unit = u.format_units(u.as_length_unit(str(unit), what=f"attr {key!r}"))
        except ValueError:
            return None
        value = float(number)
        if not (np.isfinite(value) and value > 0):
            return None
        return value, unit, u.length_in(f"{value} {unit}", "m", what=f"attr {key!r}"), key

    found = []
    for key, value in attrs.items():
        if key == "tip_radius" and isinstance(value, (int, float, np.integer, np.floating)):
            found.append(length(value, attrs.get("tip_radius_units", ""), key))
            continue
        if not isinstance(value, str):
            continue
        text = f"{key}: {value}"
        if _TIP_KEY.search(text):
            found += [length(number, unit.lower(), key)
                      for number, unit in _TIP_TEXT.findall(text)]
    found = [f for f in found if f is not None]  # a statement in no length unit: skipped
    if not found:
        return None
    value, unit, _, key = max(found, key=lambda f: f[2])
    return f"{value:g} {unit}", key


def tip_window(topography: xr.DataArray) -> tuple[xr.DataArray, str | None]:
    """Apply :func:`reliable` with the tip radius the file states, unless a window is set.

    A topography without ``reliable_dr_min`` whose metadata state a tip or stylus radius
    (:func:`stated_tip_radius`) gets the window of the tip rule, and ``reliable_rule``
    says which attribute stated it. :func:`xrough.height_difference_acf` does this by
    default (``reliable=True``). Lazy (dask) maps are returned as they are: the tip rule
    reads the whole map (call :func:`reliable` on them yourself).

    Returns
    -------
    (xarray.DataArray, str or None)
        The topography (with the window, or unchanged), and ``None``, or what to say when
        the stated tip resolves no lag of the map (the tip rule's window would be empty):
        the topography is then returned with its heights and window unchanged, and
        ``reliable_rule`` = :data:`NO_WINDOW` + why (read by :func:`lag_window`: the
        contact results of its G fail).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> x = np.linspace(0, 100, 1001)
    >>> topo = xrough.topography(np.sin(x) * 0.5, spacing=0.1, unit="um")
    >>> topo.attrs["Stylus"] = "Radius: 2.5 µm"
    >>> out, note = tip_window(topo)
    >>> note is None, out.attrs["reliable_rule"].endswith("stated in the file (attr 'Stylus')")
    (True, True)
    """
    if "reliable_dr_min" in topography.attrs or topography.chunks is not None:
        return topography, None
    stated = stated_tip_radius(topography.attrs)
    if stated is None:
        return topography, None
    radius, key = stated
    try:
        out = reliable(topography, tip_radius=radius)
    except ValueError as err:
        why = f"the tip radius {radius} stated in the file (attr {key!r}) resolves no lag " \
              f"of this map ({err})"
        # no reliable_dr_min/max: every lag stays in G; reliable_rule (carried to G and its
        # results, acf.PROVENANCE) says that the window is empty (lag_window reads it)
        unchanged = topography.copy(deep=False)
        unchanged.attrs = {**topography.attrs, "reliable_rule": NO_WINDOW + why}
        return unchanged, (
            f"{why}: G at every lag is shaped by the tip, not the surface: measure with a "
            "sharper tip or a larger scan, or acf(reliable=False) to take G as it is")
    out.attrs["reliable_rule"] += (f"; the tip radius {radius} as stated in the file "
                                   f"(attr {key!r})")
    return out, None


@u.accepts_quantified
def reliability_window(obj: xr.DataArray) -> tuple[float | None, float | None]:
    """Reliable lag range ``(dr_min, dr_max)`` recorded by :func:`reliable`.

    Parameters
    ----------
    obj : xarray.DataArray
        A topography (or any DataArray with ``x`` or ``dr`` coordinates) whose attrs hold
        ``reliable_dr_min`` / ``reliable_dr_max``.

    Returns
    -------
    (float or None, float or None)
        The limits in the current unit of the ``x`` (else ``dr``) coordinate, converted
        from ``reliable_dr_units`` if the coordinates were converted since; ``None`` for
        a limit that is not recorded (then use the default of the next step).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> from xrough.preprocess import reliable, reliability_window
    >>> topo = xrough.topography(np.zeros(100), spacing="10 nm", unit="nm")
    >>> reliability_window(topo)
    (None, None)
    >>> reliability_window(reliable(topo, short_cutoff="30 nm", long_cutoff="0.2 um"))
    (30.0, 200.0)
    """
    if not isinstance(obj, xr.DataArray):
        raise TypeError(f"expected an xarray.DataArray, got {type(obj).__name__}")
    lo = obj.attrs.get("reliable_dr_min")
    hi = obj.attrs.get("reliable_dr_max")
    stored = obj.attrs.get("reliable_dr_units")
    # the lateral unit is that of the first core dim (Grid.lateral_unit): y before x on maps
    current = next((obj.coords[c].attrs["units"] for c in ("dr", "y", "x")
                    if c in obj.dims and "units" in obj.coords[c].attrs), None)
    factor = 1.0
    if stored is not None and current is not None:
        factor = u.conversion_factor(stored, current)
    return (None if lo is None else float(lo) * factor,
            None if hi is None else float(hi) * factor)


#: Start of ``reliable_rule`` when a rule found no lag the instrument resolves (a stated tip
#: too blunt for the scan, :func:`tip_window`); no ``reliable_dr_min/max`` come with it.
NO_WINDOW = "none: "


@dataclass(frozen=True)
class LagWindow:
    """Which lags of a G lie in the instrument's window (:func:`lag_window`).

    Attributes
    ----------
    lo, hi : float or None
        ``reliable_dr_min`` / ``reliable_dr_max`` in the unit of the lags (None: not set).
    outside : numpy.ndarray of bool
        Per lag: outside ``[lo, hi]``.
    empty : str or None
        Why no lag (``dr > 0``) lies inside the window, in words; None when some lag does
        (or when no window is recorded).
    rule : str
        How the window was found (``reliable_rule``, or a generic text).
    """

    lo: float | None
    hi: float | None
    outside: np.ndarray
    empty: str | None
    rule: str

    @property
    def recorded(self) -> bool:
        """A window (or a rule that found none) is recorded."""
        return self.lo is not None or self.hi is not None or self.empty is not None

    @property
    def said(self) -> str:
        """``rule`` for a quality note: its ``"; "`` (the notes' separator) as ``", "``."""
        return self.rule.replace("; ", ", ")

    @property
    def no_lag_note(self) -> str:
        """The note of every result of a G whose window holds no lag (``empty`` said)."""
        why = (self.empty or "").replace("; ", ", ")
        return (f"{why}: no lag of G is resolved, so every number that rests on G (rms "
                "gradient, elastic energy, contact area and stress, patch radius) is NaN: "
                "measure with a sharper tip (a finer lateral resolution) or a larger scan, "
                "or take G as it is with acf(reliable=False)")


def lag_window(obj: xr.DataArray, dr: np.ndarray | None = None) -> LagWindow:
    """Read the instrument's window of a G (or a result of it) against its lags ``dr``.

    Parameters
    ----------
    obj : xarray.DataArray
        A G (or any DataArray whose attrs carry the window, :func:`reliability_window`).
    dr : numpy.ndarray, optional
        The lags, in the unit of ``obj``'s ``dr`` coordinate (default: that coordinate).

    Returns
    -------
    LagWindow

    Examples
    --------
    >>> import numpy as np, xarray as xr
    >>> dr = np.array([1.0, 2.0, 4.0, 8.0])
    >>> G = xr.DataArray(dr, dims="dr", coords={"dr": ("dr", dr, {"units": "um"})},
    ...                  attrs={"units": "um2", "reliable_dr_min": 3.0,
    ...                         "reliable_dr_units": "um"})
    >>> w = lag_window(G)
    >>> w.outside.tolist(), w.empty
    ([True, True, False, False], None)
    >>> lag_window(G.assign_attrs(reliable_dr_min=9.0)).empty[:42]
    'no lag of G lies in the window 9 to inf um'
    """
    lo, hi = reliability_window(obj)
    lags = np.asarray(obj["dr"].values if dr is None else dr, dtype=float)
    unit = obj["dr"].attrs.get("units", "") if "dr" in obj.coords else ""
    rule = str(obj.attrs.get("reliable_rule", "reliable_dr_min / reliable_dr_max in G's "
                                              "attrs"))
    outside = (lags < (-np.inf if lo is None else lo)) | (lags > (np.inf if hi is None else hi))
    empty = None
    if lo is None and hi is None:
        if rule.startswith(NO_WINDOW):
            empty = rule[len(NO_WINDOW):]
            outside = np.ones(lags.shape, dtype=bool)
    elif not np.any(~outside & (lags > 0)):
        empty = (f"no lag of G lies in the window {lo if lo is not None else 0:.4g} to "
                 f"{hi if hi is not None else np.inf:.4g} {unit} that the instrument "
                 f"resolves ({rule}); G's lags are {lags[lags > 0].min():.4g} to "
                 f"{lags.max():.4g} {unit}")
    return LagWindow(lo=lo, hi=hi, outside=outside, empty=empty, rule=rule)
