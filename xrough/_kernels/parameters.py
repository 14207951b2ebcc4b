"""Roughness parameters, distributions and the material ratio of height maps (pure numpy).

Heights arrive with the grid axes last (``(..., n)`` profiles, ``(..., ny, nx)`` maps;
``nd`` says how many) and NaN where missing. Every height statistic is taken relative to
the mean of the valid heights of each map; every slope and curvature comes from the
stencils of :mod:`.derivatives`, on the heights times ``hfactor`` (which converts them to
the unit of the spacing, so that slopes are pure numbers). Each function returns one
packed array per map, so that one task of a dask graph returns one array.
"""

from __future__ import annotations

import numpy as np

from . import derivatives as fd
from .detrend import MAD_TO_SIGMA
from .pairs import few_points_message, require_no_inf

__all__ = ["PROFILE_PARAMETERS", "AREAL_PARAMETERS", "checked", "centred",
           "roughness_parameters", "slope_by_step", "curvature_by_step",
           "SLOPE_DIRECTIONS", "CURVATURE_DIRECTIONS", "values_of", "value_range",
           "histogram", "material_ratio", "inverse_material_ratio",
           "shifted", "statistic_by_distance", "continuous_material_ratio"]

#: The packed order of :func:`roughness_parameters` for profiles (ISO 21920-2) ...
PROFILE_PARAMETERS = ("Rq", "Ra", "Rsk", "Rku", "Rp", "Rv", "Rz", "Rt", "Rdq",
                      "rms_curvature", "median_height", "mad_height")
#: ... and for maps (ISO 25178-2).
AREAL_PARAMETERS = ("Sq", "Sa", "Ssk", "Sku", "Sp", "Sv", "Sz", "Sdq", "Sdr",
                    "rms_curvature", "median_height", "mad_height")
#: What a slope distribution can bin: the slope along an axis, or |grad h|.
SLOPE_DIRECTIONS = ("x", "y", "gradient")
#: What a curvature distribution can bin: along an axis, or the mean curvature of a map.
CURVATURE_DIRECTIONS = ("x", "y", "mean")


def checked(h, nd: int) -> np.ndarray:
    """Return ``h`` as floats; raise on infinite heights or a map with < 2 valid points."""
    h = np.asarray(require_no_inf(h), dtype=float)
    batch = h.shape[: h.ndim - nd]
    valid = np.isfinite(h).reshape(batch + (-1,)).sum(-1)
    if np.any(valid < 2):
        raise ValueError(few_points_message(int(np.argmax(np.reshape(valid < 2, -1))),
                                            batch))
    return h


def centred(h: np.ndarray, nd: int) -> np.ndarray:
    """``h`` minus the mean of the valid heights of each map (NaN stays NaN)."""
    axes = tuple(range(h.ndim - nd, h.ndim))
    valid = np.isfinite(h)
    mean = np.where(valid, h, 0.0).sum(axes, keepdims=True) / valid.sum(axes, keepdims=True)
    return h - mean


def _grid_axes(a: np.ndarray, nd: int) -> tuple[int, ...]:
    return tuple(range(a.ndim - nd, a.ndim))


def _mean_of(values: np.ndarray, nd: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean over the grid axes of the finite values of each map, and how many there were.

    NaN (without a warning) where a map has none.
    """
    axes = _grid_axes(values, nd)
    finite = np.isfinite(values)
    if finite.all():
        count = np.full(values.shape[: values.ndim - nd], int(np.prod(
            [values.shape[a] for a in axes])), dtype=np.int64)
        total = values.sum(axes)
    else:
        count = finite.sum(axes)
        total = np.where(finite, values, 0.0).sum(axes)
    with np.errstate(invalid="ignore", divide="ignore"):
        return total / count, count


def _mean_square(d: np.ndarray, nd: int, complete: bool = False
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Mean of ``d**2`` over the finite values of each map, and their number.

    ``complete``: the caller knows that every value is finite (heights without missing
    points), so the sum runs without a mask or a temporary array.
    """
    if not complete:
        return _mean_of(d * d, nd)
    axes = _grid_axes(d, nd)
    letters = "ij"[:nd]
    total = np.einsum(f"...{letters},...{letters}->...", d, d)
    count = int(np.prod([d.shape[a] for a in axes]))
    return total / count, np.full(np.shape(total), count, dtype=np.int64)


def _extreme(values: np.ndarray, nd: int, largest: bool, complete: bool = False
             ) -> np.ndarray:
    """Largest (smallest) finite value over the grid axes; NaN where there is none."""
    axes = _grid_axes(values, nd)
    if complete:
        return values.max(axes) if largest else values.min(axes)
    fill = -np.inf if largest else np.inf
    filled = np.where(np.isfinite(values), values, fill)
    out = filled.max(axes) if largest else filled.min(axes)
    return np.where(np.isinf(out), np.nan, out)


def _each_map(single, h, nd: int, shape: tuple[int, ...], **kwargs) -> np.ndarray:
    """Apply ``single`` to each map of ``h`` in turn; ``shape`` is its output per map.

    One map at a time, so that a map's numbers do not depend on the maps it is stacked or
    chunked with: numpy and dask agree bit for bit.
    """
    h = checked(h, nd)
    batch = h.shape[: h.ndim - nd]
    maps = h.reshape((-1,) + h.shape[h.ndim - nd:])
    out = np.empty((maps.shape[0],) + tuple(shape))
    for i, m in enumerate(maps):
        out[i] = single(m, nd=nd, **kwargs)
    return out.reshape(batch + tuple(shape))


def _fits(n: int, step: int, periodic: bool, width: int) -> bool:
    return step < n if periodic else width * step < n


def _heights(z: np.ndarray, nd: int, sections: int) -> list[np.ndarray]:
    """q, a, sk, ku, p, v, z (mean over sections), t of centred heights ``z``."""
    flat = z.reshape(z.shape[: z.ndim - nd] + (-1,))
    valid = np.isfinite(flat)
    n = valid.sum(-1)
    zf = np.where(valid, flat, 0.0)
    z2 = zf * zf
    m2 = z2.sum(-1) / n
    a = np.abs(zf).sum(-1) / n
    m3 = (z2 * zf).sum(-1) / n
    m4 = (z2 * z2).sum(-1) / n
    with np.errstate(invalid="ignore", divide="ignore"):  # a flat map: NaN
        sk, ku = m3 / m2**1.5, m4 / m2**2
    top, bottom = _extreme(flat, 1, True), _extreme(flat, 1, False)
    if sections == 1:
        p, v = top, -bottom
    else:  # along the profile: the mean of each section's peak and valley
        parts = np.array_split(flat, sections, axis=-1)
        peaks = np.stack([_extreme(s, 1, True) for s in parts], axis=-1)
        valleys = np.stack([-_extreme(s, 1, False) for s in parts], axis=-1)
        p, v = _mean_of(peaks, 1)[0], _mean_of(valleys, 1)[0]
    return [np.sqrt(m2), a, sk, ku, p, v, p + v, top - bottom]


def roughness_parameters(h, *, nd: int, spacing: tuple[float, ...], periodic: bool,
                         hfactor: float, sections: int = 1) -> np.ndarray:
    """Return the parameters of :data:`PROFILE_PARAMETERS` (nd = 1) or :data:`AREAL_PARAMETERS`.

    Parameters
    ----------
    h : numpy.ndarray, shape (..., [ny,] nx)
        Heights; NaN marks missing points.
    nd : int
        1 (profile) or 2 (map).
    spacing : tuple of float
        Grid spacing per grid axis.
    periodic : bool
        Wrap the stencils around the edges.
    hfactor : float
        Converts the heights to the unit of ``spacing`` (for slopes and curvatures).
    sections : int
        Profiles: the number of equal sections (sampling lengths) whose peaks and valleys
        ``Rp``, ``Rv``, ``Rz`` average; maps: 1.

    Returns
    -------
    numpy.ndarray, shape (..., 12)
        Heights in the unit of ``h`` (``Rsk``, ``Rku`` pure numbers), ``Rdq``/``Sdq`` and
        ``Sdr`` pure numbers, the rms curvature in 1 / spacing unit (of a map: the mean
        curvature, half the Laplacian), the median height and the MAD height (the median
        absolute deviation from it times :data:`MAD_TO_SIGMA`: the rms height of Gaussian
        heights). NaN where no stencil fits between missing points.

    Examples
    --------
    >>> x = np.arange(64) / 64
    >>> p = roughness_parameters(np.sin(2 * np.pi * x), nd=1, spacing=(1 / 64,),
    ...                          periodic=True, hfactor=1.0)
    >>> dict(zip(PROFILE_PARAMETERS, p.round(3).tolist()))["Rq"]
    0.707
    """
    names = PROFILE_PARAMETERS if nd == 1 else AREAL_PARAMETERS
    return _each_map(_parameters_of_map, h, nd, (len(names),), spacing=spacing,
                     periodic=periodic, hfactor=hfactor, sections=sections)


def _parameters_of_map(h, *, nd, spacing, periodic, hfactor, sections) -> np.ndarray:
    complete = not np.isnan(h).any()
    out = _heights(centred(h, nd), nd, sections)
    hl = h * hfactor
    if nd == 1:
        n, d = h.shape[-1], spacing[0]
        slopes = (_mean_square(fd.slope(hl, nd=1, axis=0, step=1, spacing=d,
                                         periodic=periodic), 1, complete)[0]
                  if _fits(n, 1, periodic, 1) else np.nan)
        curv = (_mean_square(fd.curvature(hl, nd=1, axis=0, step=1, spacing=d,
                                          periodic=periodic), 1, complete)[0]
                if _fits(n, 1, periodic, 2) else np.nan)
        out += [np.sqrt(slopes), np.sqrt(curv)]
    else:
        out = out[:-1]  # Rt: profiles only (Sz is the total height of a map)
        ms = [_mean_square(fd.slope(hl, nd=2, axis=a, step=1, spacing=spacing[a],
                                    periodic=periodic), 2, complete)[0] for a in (0, 1)]
        sy, sx = fd.gradient(hl, steps=(1, 1), spacing=spacing, periodic=periodic)
        g2 = sy * sy + sx * sx
        # sqrt(1 + g^2) - 1, without the cancellation at small slopes
        developed = _mean_of(g2 / (np.sqrt(1.0 + g2) + 1.0), 2)[0]
        fits = all(_fits(n, 1, periodic, 2) for n in h.shape[-2:])
        curv = (_mean_square(fd.mean_curvature(hl, steps=(1, 1), spacing=spacing,
                                               periodic=periodic), 2, complete)[0]
                if fits else np.nan)
        out += [np.sqrt(ms[0] + ms[1]), developed, np.sqrt(curv)]
    batch = h.shape[: h.ndim - nd]
    flat = h.reshape(batch + (-1,))
    median = np.nanmedian(flat, axis=-1)
    out += [median, MAD_TO_SIGMA * np.nanmedian(np.abs(flat - median[..., None]), axis=-1)]
    return np.stack([np.broadcast_to(np.asarray(v, dtype=float), batch) for v in out],
                    axis=-1)


def slope_by_step(h, *, nd: int, steps: np.ndarray, spacing: tuple[float, ...],
                  periodic: bool, hfactor: float) -> np.ndarray:
    """Rms slope and pair count at each step (the scale-dependent slope).

    Parameters
    ----------
    h, nd, spacing, periodic, hfactor
        As for :func:`roughness_parameters`.
    steps : numpy.ndarray of int, shape (n_steps, nd)
        Pixels per step along each grid axis.

    Returns
    -------
    numpy.ndarray, shape (..., n_steps, 2)
        ``[..., 0]``: the rms slope, ``sqrt(sum over axes of <s_k^2>)`` with each mean over
        every pair of valid points ``k`` pixels apart along that axis (a pure number);
        ``[..., 1]``: the number of pairs (all axes). NaN where an axis has no pair.

    Examples
    --------
    >>> h = np.arange(10.0) * 0.5
    >>> slope_by_step(h, nd=1, steps=np.array([[1], [3]]), spacing=(2.0,), periodic=False,
    ...               hfactor=1.0).tolist()
    [[0.25, 9.0], [0.25, 7.0]]
    """
    return _each_map(_slopes_of_map, h, nd, (len(steps), 2), steps=steps, spacing=spacing,
                     periodic=periodic, hfactor=hfactor)


def _slopes_of_map(h, *, nd, steps, spacing, periodic, hfactor) -> np.ndarray:
    h = h * hfactor
    complete = not np.isnan(h).any()
    out = np.empty((len(steps), 2))
    for i, ks in enumerate(np.asarray(steps, dtype=int).reshape(-1, nd)):
        total: float | np.ndarray = 0.0
        count: int | np.ndarray = 0
        for a in range(nd):
            ms, n = _mean_square(fd.slope(h, nd=nd, axis=a, step=int(ks[a]),
                                          spacing=spacing[a], periodic=periodic), nd,
                                 complete)
            total, count = total + ms, count + n
        out[..., i, 0] = np.sqrt(total)
        out[..., i, 1] = count
    return out


def curvature_by_step(h, *, nd: int, steps: np.ndarray, spacing: tuple[float, ...],
                      periodic: bool, hfactor: float) -> np.ndarray:
    """Rms curvature, stencil count and most negative curvature at each step.

    Parameters
    ----------
    h, nd, steps, spacing, periodic, hfactor
        As for :func:`slope_by_step`; the stencil spans ``2 k`` pixels.

    Returns
    -------
    numpy.ndarray, shape (..., n_steps, 3)
        ``[..., 0]``: the rms of ``c_k`` (profile) or of the mean curvature (map), in
        1 / spacing unit; ``[..., 1]``: the number of stencils averaged; ``[..., 2]``: the
        most negative curvature along the fast scan axis ``x`` (the last), as the tip rule
        of :func:`xrough.preprocess.reliable` reads it (across the scan lines it holds
        their offsets, which no tip makes). NaN where none fits.

    Examples
    --------
    >>> x = np.arange(9.0)
    >>> curvature_by_step(-0.5 * x**2, nd=1, steps=np.array([[1], [2]]), spacing=(1.0,),
    ...                   periodic=False, hfactor=1.0).tolist()
    [[1.0, 7.0, -1.0], [1.0, 5.0, -1.0]]
    """
    return _each_map(_curvatures_of_map, h, nd, (len(steps), 3), steps=steps,
                     spacing=spacing, periodic=periodic, hfactor=hfactor)


def _curvatures_of_map(h, *, nd, steps, spacing, periodic, hfactor) -> np.ndarray:
    h = h * hfactor
    complete = not np.isnan(h).any()
    out = np.empty((len(steps), 3))
    for i, ks in enumerate(np.asarray(steps, dtype=int).reshape(-1, nd)):
        curves = [fd.curvature(h, nd=nd, axis=a, step=int(ks[a]), spacing=spacing[a],
                               periodic=periodic) for a in range(nd)]
        rms = (curves[0] if nd == 1 else
               fd.mean_of_axis_curvatures(*curves, steps=tuple(ks), periodic=periodic))
        ms, count = _mean_square(rms, nd, complete)
        lowest = _extreme(curves[-1], nd, False, complete)  # the fast axis x alone
        out[..., i, 0], out[..., i, 1], out[..., i, 2] = np.sqrt(ms), count, lowest
    return out


def values_of(h, *, quantity: str, direction: str, nd: int, spacing: tuple[float, ...],
              periodic: bool, hfactor: float) -> np.ndarray:
    """Return the values a distribution bins, flattened per map (NaN where none is defined).

    Parameters
    ----------
    quantity : {'height', 'slope', 'curvature'}
        Centred heights (unit of ``h``); slopes at one pixel (pure numbers); curvatures
        at one pixel (1 / spacing unit).
    direction : str
        Slopes: ``'x'``, ``'y'`` (along one axis, every pair) or ``'gradient'`` (``|grad
        h|`` by the corner stencil; ``|h'|`` on a profile). Curvatures: ``'x'``, ``'y'``
        or ``'mean'`` (half the Laplacian of a map). Heights: ignored.
    h, nd, spacing, periodic, hfactor
        As for :func:`roughness_parameters`.

    Returns
    -------
    numpy.ndarray, shape (..., m)
    """
    h = checked(h, nd)
    batch = h.shape[: h.ndim - nd]
    if quantity == "height":
        return centred(h, nd).reshape(batch + (-1,))
    hl = h * hfactor
    axis = {"x": nd - 1, "y": 0}.get(direction)
    if quantity == "slope" and direction == "gradient":
        if nd == 1:
            values = np.abs(fd.slope(hl, nd=1, axis=0, step=1, spacing=spacing[0],
                                     periodic=periodic))
        else:
            sy, sx = fd.gradient(hl, steps=(1, 1), spacing=(spacing[0], spacing[1]),
                                 periodic=periodic)
            values = np.hypot(sy, sx)
    elif quantity == "slope":
        assert axis is not None  # a direction "x" or "y"
        values = fd.slope(hl, nd=nd, axis=axis, step=1, spacing=spacing[axis],
                          periodic=periodic)
    elif direction == "mean":
        values = fd.mean_curvature(hl, steps=(1, 1), spacing=(spacing[0], spacing[1]),
                                   periodic=periodic)
    else:
        assert axis is not None  # a direction "x" or "y"
        values = fd.curvature(hl, nd=nd, axis=axis, step=1, spacing=spacing[axis],
                              periodic=periodic)
    return values.reshape(batch + (-1,))


def value_range(h, **kwargs) -> np.ndarray:
    """Smallest and largest finite value of :func:`values_of` per map, shape (..., 2)."""
    values = values_of(h, **kwargs)
    return np.stack([_extreme(values, 1, False), _extreme(values, 1, True)], axis=-1)


def histogram(h, *, edges: np.ndarray, **kwargs) -> np.ndarray:
    """Probability density of :func:`values_of` in the bins ``edges``, and the count.

    Returns
    -------
    numpy.ndarray, shape (..., len(edges))
        The density in each of the ``len(edges) - 1`` bins (per unit of the binned
        quantity, normalised by all valid values, so that it integrates to the fraction
        inside the edges), then the number of valid values.

    Examples
    --------
    >>> histogram(np.array([0.0, 1.0, 2.0, 3.0]), edges=np.array([-2.0, 0.0, 2.0]),
    ...           quantity="height", direction="", nd=1, spacing=(1.0,), periodic=False,
    ...           hfactor=1.0).tolist()
    [0.25, 0.25, 4.0]
    """
    values = values_of(h, **kwargs)
    batch = values.shape[:-1]
    flat = values.reshape(-1, values.shape[-1])
    widths = np.diff(edges)
    out = np.empty((flat.shape[0], len(edges)))
    for i, v in enumerate(flat):
        v = v[np.isfinite(v)]
        counts = np.histogram(v, bins=edges)[0]
        with np.errstate(invalid="ignore", divide="ignore"):
            out[i, :-1] = counts / (v.size * widths)
        out[i, -1] = v.size
    return out.reshape(batch + (len(edges),))


def _sorted_valid(z: np.ndarray) -> list[np.ndarray]:
    """Each map's valid values, ascending."""
    flat = z.reshape(-1, z.shape[-1])
    return [np.sort(v[np.isfinite(v)]) for v in flat]


def material_ratio(h, *, heights: np.ndarray, nd: int) -> np.ndarray:
    """Fraction of the valid points at or above each height (relative to the mean).

    ``Smr(c) = #{z >= c} / N`` of ISO 25178-2 on the measured points.

    Returns
    -------
    numpy.ndarray, shape (..., len(heights))

    Examples
    --------
    >>> material_ratio(np.array([1.0, 2.0, 3.0, 6.0]), heights=np.array([-1.0, 0.0, 4.0]),
    ...                nd=1).tolist()
    [0.75, 0.5, 0.0]
    """
    h = checked(h, nd)
    z = centred(h, nd)
    batch = h.shape[: h.ndim - nd]
    z = z.reshape(batch + (-1,))
    out = np.empty((int(np.prod(batch, dtype=int)), len(heights)))
    for i, a in enumerate(_sorted_valid(z)):
        out[i] = (a.size - np.searchsorted(a, heights, side="left")) / a.size
    return out.reshape(batch + (len(heights),))


def inverse_material_ratio(h, *, ratios: np.ndarray, nd: int) -> np.ndarray:
    """Height (relative to the mean) at which the material ratio is ``mr``: ``Smc(mr)``.

    The ``k``-th highest valid height, ``k = max(1, ceil(mr N))``: the highest height at
    which at least a fraction ``mr`` of the points lie at or above it (exactly ``mr`` when
    ``mr N`` is whole and no heights tie), so that ``Smc(0)`` is the highest peak and
    ``Smc(1)`` the lowest valley.

    Returns
    -------
    numpy.ndarray, shape (..., len(ratios))

    Examples
    --------
    >>> inverse_material_ratio(np.array([1.0, 2.0, 3.0, 6.0]),
    ...                        ratios=np.array([0.0, 0.25, 0.5, 1.0]), nd=1).tolist()
    [3.0, 3.0, 0.0, -2.0]
    """
    h = checked(h, nd)
    z = centred(h, nd)
    batch = h.shape[: h.ndim - nd]
    z = z.reshape(batch + (-1,))
    ratios = np.asarray(ratios, dtype=float)
    out = np.empty((int(np.prod(batch, dtype=int)), ratios.size))
    for i, a in enumerate(_sorted_valid(z)):
        # 1e-9 of a point: mr N a hair above a whole number (0.07 * 100) is that number
        k = np.maximum(1, np.ceil(ratios * a.size - 1e-9)).astype(int)
        out[i] = a[a.size - np.minimum(k, a.size)]
    return out.reshape(batch + (ratios.size,))


def shifted(h: np.ndarray, axis: int, offset: float, periodic: bool) -> np.ndarray:
    """``h(x + offset)`` along ``axis``, ``offset`` in pixels (either sign, fractional).

    Linear interpolation between the two grid points around ``x + offset``; on an open
    grid the points whose neighbours fall outside are NaN (periodic: wrapped).

    Examples
    --------
    >>> shifted(np.arange(5.0), 0, 1.5, periodic=False).tolist()
    [1.5, 2.5, 3.5, nan, nan]
    """
    k = int(np.floor(offset + 1e-9))
    f = offset - k
    f = 0.0 if abs(f) < 1e-9 or abs(f - 1) < 1e-9 else f
    n = h.shape[axis]

    def take(shift: int) -> np.ndarray:
        if periodic:
            return np.roll(h, -shift, axis=axis)
        out = np.full(h.shape, np.nan)
        src = [slice(None)] * h.ndim
        dst = [slice(None)] * h.ndim
        if abs(shift) < n:
            src[axis] = slice(max(shift, 0), n + min(shift, 0))
            dst[axis] = slice(max(-shift, 0), n - max(shift, 0))
            out[tuple(dst)] = h[tuple(src)]
        return out

    return take(k) if f == 0.0 else (1.0 - f) * take(k) + f * take(k + 1)


def statistic_by_distance(h, *, nd: int, spacing: tuple[float, ...], periodic: bool,
                          hfactor: float, distances: np.ndarray, order: int,
                          statistic) -> np.ndarray:
    """Compute a statistic of the finite-difference derivatives at each (any) distance.

    The derivative of ``order`` 1, ``(h(x + d) - h(x)) / d``, or 2,
    ``(h(x + d) - 2 h(x) + h(x - d)) / d^2``, along each grid axis, with ``h`` at
    fractional offsets by :func:`shifted`; ``statistic(d_x)`` (profile) or
    ``statistic(d_x, d_y)`` (map) of their valid values (1-D arrays). NaN where a distance
    is below the coarser pixel or its stencil does not fit.

    Returns
    -------
    numpy.ndarray (..., n_distances)
    """
    return _each_map(_statistic_of_map, h, nd, (len(distances),), spacing=spacing,
                     periodic=periodic, hfactor=hfactor, distances=distances, order=order,
                     statistic=statistic)


def _statistic_of_map(h, *, nd, spacing, periodic, hfactor, distances, order, statistic):
    hl = h * hfactor
    out = np.full(len(distances), np.nan)
    for i, d in enumerate(distances):
        if d < max(spacing) * (1 - 1e-9):
            continue  # below the resolution: not quoted
        parts = []
        for axis in range(nd):  # x last: the statistic takes (d_x[, d_y])
            ax = nd - 1 - axis
            t = d / spacing[ax]
            if order == 1:
                der = (shifted(hl, ax, t, periodic) - hl) / d
            else:
                der = (shifted(hl, ax, t, periodic) - 2 * hl
                       + shifted(hl, ax, -t, periodic)) / (d * d)
            parts.append(der[np.isfinite(der)])
        if all(p.size for p in parts):
            out[i] = float(statistic(*parts))
    return out


def _above_linear(values: np.ndarray, c: float) -> np.ndarray:
    """Return the share of each simplex (sorted vertex values) at or above ``c``.

    The function linear on it: segments (2 vertices) or triangles (3).
    """
    if values.shape[-1] == 2:
        lo, hi = values[:, 0], values[:, 1]
        with np.errstate(invalid="ignore", divide="ignore"):
            f = np.where(hi > lo, (hi - c) / (hi - lo), (lo >= c).astype(float))
        return np.clip(f, 0.0, 1.0)
    v0, v1, v2 = values[:, 0], values[:, 1], values[:, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        below_low = (c - v0) ** 2 / ((v1 - v0) * (v2 - v0))
        above_high = (v2 - c) ** 2 / ((v2 - v0) * (v2 - v1))
    flat = np.where(v0 >= c, 1.0, 0.0)  # all three equal: the points' rule
    return np.where(v2 == v0, flat, np.where(c <= v0, 1.0, np.where(
        c >= v2, 0.0, np.where(c <= v1, 1.0 - below_low, above_high))))


def continuous_material_ratio(h, *, heights: np.ndarray, nd: int,
                              periodic: bool) -> np.ndarray:
    """Material ratio of the surface interpolated linearly between the points, with bounds.

    A profile is the polyline through its points (exact: each segment's share above
    ``c``); a map is cut into two triangles per square of four points (the linear
    interpolation on each). The bounds are those of any interpolation: the share of the
    elements (segments, squares) whose lowest point is at or above ``c`` (lower) and whose
    highest is (upper). Heights relative to the mean of the valid points; elements with a
    missing corner are left out.

    Returns
    -------
    numpy.ndarray (..., len(heights), 3)
        The ratio, its lower and its upper bound.

    Examples
    --------
    >>> tri = np.concatenate([np.linspace(0, 1, 51), np.linspace(1, 0, 51)[1:]])
    >>> c = np.array([0.2, 0.5]) - tri.mean()  # heights 0.2 and 0.5 above the bottom
    >>> out = continuous_material_ratio(tri, heights=c, nd=1, periodic=False)
    >>> out[:, 0].round(12).tolist()  # a triangle: 1 - (c - min) / (max - min)
    [0.8, 0.5]
    """
    return _each_map(_continuous_ratio_of_map, h, nd, (len(heights), 3), heights=heights,
                     periodic=periodic)


def _continuous_ratio_of_map(h, *, nd, heights, periodic):
    z = centred(h, nd)
    if nd == 1:
        b = np.roll(z, -1) if periodic else z[1:]
        a = z if periodic else z[:-1]
        elements = [np.stack([a, b], axis=-1)]
    else:
        if periodic:
            c00, c01, c10 = z, np.roll(z, -1, axis=1), np.roll(z, -1, axis=0)
            c11 = np.roll(c01, -1, axis=0)
        else:
            c00, c01, c10, c11 = z[:-1, :-1], z[:-1, 1:], z[1:, :-1], z[1:, 1:]
        elements = [np.stack([c00, c01, c10], axis=-1).reshape(-1, 3),
                    np.stack([c11, c01, c10], axis=-1).reshape(-1, 3)]
        squares = np.stack([c00, c01, c10, c11], axis=-1).reshape(-1, 4)
    elements = [e.reshape(-1, e.shape[-1]) for e in elements]
    keep = [np.all(np.isfinite(e), axis=-1) for e in elements]
    simplices = [np.sort(e[k], axis=-1) for e, k in zip(elements, keep)]
    corners = (simplices[0] if nd == 1 else
               np.sort(squares[np.all(np.isfinite(squares), axis=-1)], axis=-1))
    out = np.full((len(heights), 3), np.nan)
    total = sum(s.shape[0] for s in simplices)
    if not total or not corners.shape[0]:
        return out
    for i, c in enumerate(heights):
        out[i, 0] = sum(_above_linear(s, c).sum() for s in simplices) / total
        out[i, 1] = np.mean(corners[:, 0] >= c)
        out[i, 2] = np.mean(corners[:, -1] >= c)
    return out
