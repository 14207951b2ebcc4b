"""Roughness parameters: ISO heights and slopes, distributions, bearing area, scale dependence.

The toolbox of surface metrology, on the topographies of :func:`xrough.topography`:

:func:`roughness_parameters`
    ISO 25178-2 areal parameters of maps (``Sq Sa Ssk Sku Sp Sv Sz Sdq Sdr``), ISO 21920-2 /
    ISO 4287 profile parameters of profiles (``Rq Ra Rsk Rku Rp Rv Rz Rt Rdq``), and the
    rms curvature, as a Dataset.
:func:`height_distribution`, :func:`slope_distribution`, :func:`curvature_distribution`
    Histograms as probability densities.
:func:`bearing_area_curve`, :func:`material_ratio`
    The Abbott-Firestone curve ``Smc(mr)`` and its inverse ``Smr(c)`` (ISO 25178-2).
:func:`scale_dependent_slope`, :func:`scale_dependent_curvature`
    The rms slope and curvature at every finite-difference step ``dr`` (Sanner et al.
    2022), beside ``gbar(dr)`` of eq. 26; :func:`tip_check` marks the scales that are
    curved beyond what a tip of radius ``R`` can image.

Conventions (docs/parameters.md): heights are taken relative to the mean of the valid
heights of each map; no plane or form is removed (detrend first, :func:`xrough.detrend`).
Every slope and curvature comes from the one stencil of
:mod:`xrough._kernels.derivatives` (a forward difference, a central second difference),
between valid points only; periodic maps wrap around. Lengths are in the height unit,
slopes are pure numbers, curvatures are in 1 / lateral unit.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .. import quality
from .. import units as u
from .._kernels import derivatives as fd
from .._kernels import parameters as k
from .._kernels.binning import check_points_per_decade, log_range
from .._kernels.checks import require_count, require_increasing
from ..acf import lag_coord, result_attrs
from ..preprocess import TIP_SAFETY_FACTOR, stated_tip_radius
from ..topography import SPACING_RTOL, Grid, check_valid_points, grid_of, require_whole_maps
from ..units import QuantityLike

__all__ = ["roughness_parameters", "height_distribution", "slope_distribution",
           "curvature_distribution", "bearing_area_curve", "material_ratio",
           "scale_dependent_slope", "scale_dependent_curvature", "tip_check",
           "DR_FRACTION", "REFERENCE", "SLOPE_STENCIL", "CURVATURE_STENCIL"]

#: Default largest step of the scale-dependent slope and curvature, as a fraction of the
#: shorter side: the curvature stencil (2 dr) then spans half of it.
DR_FRACTION = 0.25
#: What every height statistic is taken relative to.
REFERENCE = ("the mean of the valid heights of each map; no plane or form is removed "
             "(detrend first: xrough.detrend)")
#: The stencils, in words (the attrs of every result that uses them).
SLOPE_STENCIL = ("forward difference [h(x + k d) - h(x)] / (k d) of every pair of valid "
                 "points k pixels apart along an axis (wrapped on a periodic map)")
CURVATURE_STENCIL = ("central second difference [h(x + k d) - 2 h(x) + h(x - k d)] / "
                     "(k d)^2 at every point whose three heights are valid (wrapped on a "
                     "periodic map); of a map, the mean curvature (c_x + c_y) / 2 (half the "
                     "five-point Laplacian)")

_ISO_AREAL, _ISO_PROFILE = "ISO 25178-2", "ISO 21920-2, ISO 4287"
#: name: (long name, unit kind, definition); unit kinds: h height, 1 none, c curvature
_PARAMETERS = {
    "q": ("root mean square height", "h", "sqrt(<z^2>), z = h - <h> over the valid points"),
    "a": ("arithmetic mean height", "h", "<|z|>"),
    "sk": ("skewness", "1", "<z^3> / q^3"),
    "ku": ("kurtosis", "1", "<z^4> / q^4 (3 for Gaussian heights)"),
    "p": ("maximum peak height", "h", "max z"),
    "v": ("maximum valley depth", "h", "-min z"),  # of a map: "maximum pit height"
    "z": ("maximum height", "h", "p + v"),
    "t": ("total height", "h", "max z - min z over the whole profile"),
}
_SECTIONS = ("the mean over the {n} sections (sampling lengths) of the profile of each "
             "section's {what}")


def _validated(topography: xr.DataArray, purpose: str) -> Grid:
    """Return the grid of a topography, checked as every xrough function checks it."""
    grid = grid_of(topography)
    require_whole_maps(topography, grid, purpose=purpose)
    if topography.chunks is None:  # lazy maps are checked by the kernels, when computed
        check_valid_points(topography.transpose(..., *grid.dims).values,
                           ndim=len(grid.dims))
    return grid


def _kernel_options(grid: Grid) -> dict:
    return {"nd": len(grid.dims), "spacing": grid.spacing, "periodic": grid.periodic,
            "hfactor": u.conversion_factor(grid.height_unit, grid.lateral_unit)}


def _apply(kernel, topography: xr.DataArray, grid: Grid, out_dims: dict, **kwargs):
    """``kernel`` on each map of ``topography``, new dims ``out_dims`` last, lazy on dask."""
    return xr.apply_ufunc(
        kernel, topography, input_core_dims=[list(grid.dims)],
        output_core_dims=[list(out_dims)], dask="parallelized", output_dtypes=[float],
        dask_gufunc_kwargs={"output_sizes": out_dims}, kwargs=kwargs, keep_attrs=False)


def _curvature_unit(grid: Grid) -> str:
    return u.power_units(grid.lateral_unit, -1)


# ---------------------------------------------------------------------------- parameters


def _parameter_attrs(grid: Grid, sections: int) -> dict[str, dict]:
    """Attrs of each variable of :func:`roughness_parameters`."""
    areal = len(grid.dims) == 2
    prefix, standard = ("S", _ISO_AREAL) if areal else ("R", _ISO_PROFILE)
    units = {"h": grid.height_unit, "1": "1", "c": _curvature_unit(grid)}
    out = {}
    for key, (long_name, kind, definition) in _PARAMETERS.items():
        if key == "t" and areal:
            continue
        if not areal and sections > 1 and key in ("p", "v", "z"):
            definition = _SECTIONS.format(n=sections, what=definition)
        name = prefix + key
        if name == "Sv":
            long_name = "maximum pit height"
        out[name] = {"units": units[kind], "long_name": f"{long_name} {name} ({standard})",
                     "definition": definition}
    slope = "root mean square gradient" if areal else "root mean square slope"
    out[prefix + "dq"] = {
        "units": "1", "long_name": f"{slope} {prefix}dq ({standard})",
        "definition": ("sqrt(<s_x^2> + <s_y^2>), each mean over every pair of valid "
                       "neighbours along its axis (k = 1)" if areal else
                       "sqrt(<s^2>) over every pair of valid neighbours (k = 1)"),
        "stencil": SLOPE_STENCIL}
    if areal:
        out["Sdr"] = {
            "units": "1",
            "long_name": f"developed interfacial area ratio Sdr ({standard}), a ratio "
                         "(x 100 for percent)",
            "definition": "<sqrt(1 + s_x^2 + s_y^2) - 1> over the points whose forward "
                          "differences along x and y both exist (k = 1)",
            "stencil": SLOPE_STENCIL}
    out["rms_curvature"] = {
        "units": units["c"],
        "long_name": ("root mean square mean curvature (half the Laplacian; no ISO "
                      "parameter)" if areal else
                      "root mean square curvature h'' (no ISO parameter)"),
        "definition": "sqrt(<c^2>) over every valid stencil (k = 1)",
        "stencil": CURVATURE_STENCIL}
    out["median_height"] = {"units": grid.height_unit,
                            "long_name": "median height (no ISO parameter)",
                            "definition": "median of the valid heights as they are (not "
                                          "about the mean)"}
    out["mad_height"] = {
        "units": grid.height_unit,
        "long_name": "MAD height: median absolute deviation scaled to the rms of Gaussian "
                     "heights (no ISO parameter)",
        "definition": "1.4826 median(|h - median(h)|): robust to spikes, equal to the rms "
                      "height of Gaussian heights"}
    return out


@u.accepts_quantified
def roughness_parameters(topography: xr.DataArray, *,
                         sampling_lengths: int = 1) -> xr.Dataset:
    r"""ISO roughness parameters of a map (``S``) or profile (``R``), and the rms curvature.

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        Heights with length units on data and coordinates (see :func:`xrough.topography`);
        NaN marks missing points; ``attrs["periodic"]`` wraps the stencils. Extra dims
        (``scan``, ...) are kept: one value per map.
    sampling_lengths : int
        Profiles only: the number of equal sections (sampling lengths) whose peak,
        valley and maximum height ``Rp``, ``Rv``, ``Rz`` are averaged, as ISO 21920-2 and
        ISO 4287 define them (5 in their default evaluation length). The default 1 takes
        the whole profile as one section: ``Rz`` is then ``Rt`` (see Notes).

    Returns
    -------
    xarray.Dataset
        Maps: ``Sq Sa Ssk Sku Sp Sv Sz Sdq Sdr rms_curvature median_height
        mad_height``; profiles: ``Rq Ra Rsk Rku Rp Rv Rz Rt Rdq rms_curvature
        median_height mad_height``; 0-d for one map. ``mad_height`` is 1.4826 times the
        median absolute deviation from the median, a robust ``Sq``. Heights in the height unit,
        ``Ssk``, ``Sku``, ``Sdq`` and ``Sdr`` pure numbers (``units="1"``; ``Sdr`` a
        ratio, not percent), ``rms_curvature`` in 1 / lateral unit. Each variable's
        ``long_name`` names its standard and ``definition`` its formula; the attrs give
        the ``reference`` (the mean, no plane removed), the stencils, and the provenance
        of the topography. An open topography that was not detrended (no attr
        ``detrend``) carries a remark saying so (``quality_remarks``).

    Raises
    ------
    ValueError
        An invalid topography (dims, units, spacing, infinite heights, fewer than 2 valid
        points), chunked core dims, or ``sampling_lengths`` that is not a whole number
        from 1 to half the profile's points (or not 1 on a map).

    See Also
    --------
    scale_dependent_slope : the rms slope at every step (its first value is ``Sdq``).
    xrough.detrend : remove the plane (or form) first.

    Notes
    -----
    Formulas, stencils, ``Rz`` and the sampling length, and the agreement with
    SurfaceTopography: docs/parameters.md, "The parameters" and "Conventions".

    Examples
    --------
    >>> import numpy as np, xrough
    >>> x = np.arange(256) * 0.1
    >>> line = xrough.topography(2.0 * np.sin(2 * np.pi * x / 6.4), spacing=0.1,
    ...                          unit="um", periodic=True)
    >>> p = line.rough.parameters()
    >>> round(float(p.Rq), 6), round(float(p.Rz), 6), p.Rq.attrs["units"]
    (1.414214, 4.0, 'um')
    >>> p.Rq.attrs["long_name"]
    'root mean square height Rq (ISO 21920-2, ISO 4287)'
    >>> round(float(p.Rdq), 4), round(float(p.rms_curvature), 4)  # ~ 2 pi / 3.2 / sqrt 2
    (1.3878, 1.362)
    """
    grid = _validated(topography, "roughness parameters")
    areal = len(grid.dims) == 2
    sampling_lengths = require_count(sampling_lengths, "sampling_lengths", minimum=1)
    if areal and sampling_lengths != 1:
        raise ValueError("sampling_lengths divides a profile into sections (ISO 21920-2); "
                         "ISO 25178-2 defines no sections of a map: leave it at 1")
    if sampling_lengths > grid.shape[-1] // 2:
        raise ValueError(f"sampling_lengths={sampling_lengths} leaves fewer than 2 points "
                         f"per section of a profile of {grid.shape[-1]} points")
    names = k.AREAL_PARAMETERS if areal else k.PROFILE_PARAMETERS
    packed = _apply(k.roughness_parameters, topography, grid, {"parameter": len(names)},
                    sections=int(sampling_lengths), **_kernel_options(grid))
    attrs = _parameter_attrs(grid, int(sampling_lengths))
    ds = xr.Dataset({name: packed.isel(parameter=i).assign_attrs(attrs[name])
                     for i, name in enumerate(names)})
    ds.attrs = result_attrs(
        topography, long_name=f"roughness parameters ({_ISO_AREAL if areal else _ISO_PROFILE})",
        reference=REFERENCE, slope_stencil=SLOPE_STENCIL,
        curvature_stencil=CURVATURE_STENCIL, periodic=int(grid.periodic),
        **({} if areal else {"sampling_lengths": int(sampling_lengths)}))
    if "detrend" not in topography.attrs and not grid.periodic:  # periodic: no tilt
        ds = quality.mark(ds, "the heights were not detrended (no attr 'detrend'): only "
                              "their mean is removed, so a tilt or form of the sample adds "
                              "to every parameter; xrough.detrend removes it",
                          level="good", what="roughness_parameters")
    return ds


# ------------------------------------------------------------------------- distributions


def _edges(bins: QuantityLike, unit: str, what: str) -> np.ndarray | int:
    """Return a number of bins, or explicit edges in ``unit``, checked."""
    if isinstance(bins, (int, np.integer)) and not isinstance(bins, (bool, np.bool_)):
        if bins < 1:
            raise ValueError(f"bins must be at least 1, got {bins}")
        return int(bins)
    edges = np.atleast_1d(u.magnitude_in(bins, unit, what=f"bins of the {what}"))
    if edges.ndim != 1 or edges.size < 2 or not np.all(np.isfinite(edges)) or np.any(
            np.diff(edges) <= 0):
        raise ValueError(f"bins: give a number of bins or at least 2 finite, strictly "
                         f"increasing edges (in {unit!r}) of the {what}, got {bins!r}")
    return edges


def _data_range(topography, grid, purpose: str, **kwargs) -> tuple[float, float]:
    """Smallest and largest value over all maps (numpy only: needs the data)."""
    if topography.chunks is not None:
        raise ValueError(f"{purpose} of a lazy (dask) topography needs explicit values "
                         "(the range of the data is not known without computing it): "
                         "pass them, or .compute() the topography first")
    r = np.asarray(_apply(k.value_range, topography, grid, {"bound": 2}, **kwargs).values)
    r = r.reshape(-1, 2)
    if not np.isfinite(r).any():
        return np.nan, np.nan
    return float(np.nanmin(r[:, 0])), float(np.nanmax(r[:, 1]))


def _distribution(topography: xr.DataArray, grid: Grid, *, quantity: str, direction: str,
                  unit: str, bins: QuantityLike, long_name: str, attrs: dict) -> xr.DataArray:
    """Return the histogram of :func:`xrough._kernels.parameters.values_of`, labelled."""
    options = {**_kernel_options(grid), "quantity": quantity, "direction": direction}
    edges = _edges(bins, unit, long_name)
    if not isinstance(edges, np.ndarray):
        lo, hi = _data_range(topography, grid, f"a {quantity} distribution with bins="
                             f"{edges}", **options)
        if not np.isfinite(lo):
            raise ValueError(f"no {long_name} is defined on this topography (no stencil "
                             "fits between its missing points)")
        if lo == hi:  # one value: one unit-wide bin around it
            lo, hi = lo - 0.5, hi + 0.5
        edges = np.linspace(lo, hi, edges + 1)
    packed = _apply(k.histogram, topography, grid, {quantity: len(edges)}, edges=edges,
                    **options)
    centres, widths = 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)
    out = packed.isel({quantity: slice(None, -1)}).assign_coords({
        quantity: (quantity, centres, {"units": unit, "long_name": f"{long_name} (bin "
                                                                   "centre)"}),
        "bin_width": (quantity, widths, {"units": unit, "long_name": "width of the bin"}),
        "value_count": packed.isel({quantity: -1}).astype(np.int64).assign_attrs(
            units="1", long_name="valid values binned (the normalisation)")})
    out.name = "probability_density"
    out.attrs = result_attrs(
        topography, units=u.power_units(unit, -1) if unit != "1" else "1",
        long_name=f"probability density of the {long_name}",
        normalisation=("per unit of the binned quantity, over all valid values: it "
                       "integrates to the fraction of them inside the bins"), **attrs)
    return out


@u.accepts_quantified
def height_distribution(topography: xr.DataArray, *, bins: QuantityLike = 100) -> xr.DataArray:
    """Probability density of the heights, relative to the mean of each map.

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        See :func:`roughness_parameters`.
    bins : int or array_like
        Number of equal bins over the range of the heights (of all maps; a lazy
        topography needs edges), or the bin edges (numbers in the height unit, strings
        or Quantities), relative to the mean.

    Returns
    -------
    xarray.DataArray
        On dim ``height`` (bin centres, height unit) with coordinates ``bin_width`` and
        ``value_count`` (per map: the valid heights, the normalisation), in 1 / height
        unit: it integrates to the fraction of the heights inside the bins.

    Raises
    ------
    ValueError
        An invalid topography, or bins that are not a positive number or increasing
        edges.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> h = np.random.default_rng(0).normal(0.0, 2.0, size=(128, 128))
    >>> topo = xrough.topography(h, spacing=1.0, unit="nm")
    >>> p = topo.rough.height_distribution(bins=np.linspace(-10, 10, 41))
    >>> p.attrs["units"], p.height.attrs["units"], round(float((p * p.bin_width).sum()), 6)
    ('nm-1', 'nm', 1.0)
    """
    grid = _validated(topography, "a height distribution")
    return _distribution(topography, grid, quantity="height", direction="",
                         unit=grid.height_unit, bins=bins, long_name="height",
                         attrs={"reference": REFERENCE})


def _direction(direction: str | None, grid: Grid, allowed: tuple[str, ...],
               default_map: str, what: str) -> str:
    if direction is None:
        return default_map if len(grid.dims) == 2 else "x"
    if direction not in allowed:
        raise ValueError(f"direction of the {what} must be one of {allowed}, got "
                         f"{direction!r}")
    if len(grid.dims) == 1 and direction not in ("x", "gradient"):
        raise ValueError(f"a profile has {what}s along 'x' only, not {direction!r}")
    return direction


@u.accepts_quantified
def slope_distribution(topography: xr.DataArray, *, direction: str | None = None,
                       bins: QuantityLike = 100) -> xr.DataArray:
    """Probability density of the slopes between neighbouring points.

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        See :func:`roughness_parameters`.
    direction : {'x', 'y', 'gradient'}, optional
        The slope along one axis (signed, every pair of valid neighbours), or the
        magnitude of the gradient ``|grad h|`` (both forward differences from each point,
        as for ``Sdr``; of a profile ``|h'|``). Default: ``'gradient'`` for a map, ``'x'``
        for a profile.
    bins : int or array_like
        Number of equal bins over the range of the slopes (a lazy topography needs
        edges), or the bin edges (pure numbers).

    Returns
    -------
    xarray.DataArray
        On dim ``slope`` (bin centres, ``units="1"``), with coordinates as for
        :func:`height_distribution`; a density per unit slope.

    Raises
    ------
    ValueError
        As for :func:`height_distribution`, or an unknown ``direction`` (``'y'`` of a
        profile).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> x = np.arange(64) * 1.0
    >>> line = xrough.topography(0.5 * x, spacing=1.0, unit="nm")  # slope 0.5 everywhere
    >>> p = line.rough.slope_distribution(bins=[0.0, 0.25, 0.75, 1.0])
    >>> p.values.tolist(), p.attrs["direction"]
    ([0.0, 2.0, 0.0], 'x')
    """
    grid = _validated(topography, "a slope distribution")
    direction = _direction(direction, grid, k.SLOPE_DIRECTIONS, "gradient", "slope")
    return _distribution(topography, grid, quantity="slope", direction=direction,
                         unit="1", bins=bins,
                         long_name="slope |grad h|" if direction == "gradient" else
                         f"slope along {direction}",
                         attrs={"direction": direction, "stencil": SLOPE_STENCIL})


@u.accepts_quantified
def curvature_distribution(topography: xr.DataArray, *, direction: str | None = None,
                           bins: QuantityLike = 100) -> xr.DataArray:
    """Probability density of the curvatures at one pixel.

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        See :func:`roughness_parameters`.
    direction : {'x', 'y', 'mean'}, optional
        The curvature along one axis (central second difference), or the mean curvature
        of a map (half the five-point Laplacian, whose rms is ``rms_curvature``).
        Default: ``'mean'`` for a map, ``'x'`` for a profile.
    bins : int or array_like
        Number of equal bins over the range of the curvatures (a lazy topography needs
        edges), or the bin edges (numbers in 1 / lateral unit, strings or Quantities).

    Returns
    -------
    xarray.DataArray
        On dim ``curvature`` (bin centres, 1 / lateral unit), with coordinates as for
        :func:`height_distribution`; a density per unit curvature (in the lateral unit).

    Raises
    ------
    ValueError
        As for :func:`slope_distribution`.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> x = np.arange(32) * 0.5
    >>> line = xrough.topography(-0.25 * x**2, spacing=0.5, unit="um")  # h'' = -0.5 / um
    >>> p = line.rough.curvature_distribution(bins=["-1 um-1", 0.0, "1000 mm-1"])
    >>> p.values.tolist(), p.curvature.values.tolist(), p.attrs["units"]
    ([1.0, 0.0], [-0.5, 0.5], 'um')
    """
    grid = _validated(topography, "a curvature distribution")
    direction = _direction(direction, grid, k.CURVATURE_DIRECTIONS, "mean", "curvature")
    unit = _curvature_unit(grid)
    return _distribution(topography, grid, quantity="curvature", direction=direction,
                         unit=unit, bins=bins,
                         long_name="mean curvature" if direction == "mean" else
                         f"curvature along {direction}",
                         attrs={"direction": direction, "stencil": CURVATURE_STENCIL})


# ---------------------------------------------------------------------------- bearing area


@u.accepts_quantified
def bearing_area_curve(topography: xr.DataArray, *,
                       material_ratio: QuantityLike | None = None) -> xr.DataArray:
    """Abbott-Firestone curve: the height at each material ratio, ``Smc(mr)``.

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        See :func:`roughness_parameters`.
    material_ratio : array_like, optional
        Material ratios from 0 to 1 (numbers, or strings such as ``"10 %"``); default 101
        from 0 to 1.

    Returns
    -------
    xarray.DataArray
        Heights relative to the mean (height unit) on dim ``material_ratio``
        (``units="1"``): the ``k``-th highest valid height, ``k = max(1, ceil(mr N))``,
        the highest level at or above which a fraction ``mr`` of the points lie (ISO
        25178-2's inverse areal material ratio on the measured points). ``Smc(0)`` is
        the highest peak ``Sp``, ``Smc(1)`` the deepest valley ``-Sv``.

    Raises
    ------
    ValueError
        An invalid topography, or ratios outside ``[0, 1]``.

    See Also
    --------
    material_ratio : the inverse, the ratio at given heights.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> line = xrough.topography(np.array([1.0, 2.0, 3.0, 6.0]), spacing=1.0, unit="nm")
    >>> c = line.rough.bearing_area_curve(material_ratio=[0.0, "50 %", 1.0])
    >>> c.values.tolist(), c.attrs["units"], c.material_ratio.attrs["units"]
    ([3.0, 0.0, -2.0], 'nm', '1')
    """
    grid = _validated(topography, "a bearing area curve")
    ratios = (np.linspace(0.0, 1.0, 101) if material_ratio is None else
              np.atleast_1d(u.magnitude_in(material_ratio, "1", what="material_ratio")))
    if ratios.ndim != 1 or not ratios.size or not np.all(
            np.isfinite(ratios) & (ratios >= 0) & (ratios <= 1)):
        raise ValueError(f"material_ratio must be a 1-D array of ratios from 0 to 1, got "
                         f"{material_ratio!r}")
    out = _apply(k.inverse_material_ratio, topography, grid,
                 {"material_ratio": ratios.size}, ratios=ratios, nd=len(grid.dims))
    out = out.assign_coords(material_ratio=("material_ratio", ratios, {
        "units": "1", "long_name": "areal material ratio mr (fraction at or above)"}))
    out.name = "height"
    out.attrs = result_attrs(
        topography, units=grid.height_unit,
        long_name="inverse areal material ratio Smc(mr), the Abbott-Firestone curve "
                  f"({_ISO_AREAL if len(grid.dims) == 2 else _ISO_PROFILE})",
        definition="the k-th highest valid height, k = max(1, ceil(mr N)), of the N valid "
                   "points", reference=REFERENCE)
    return out


@u.accepts_quantified
def material_ratio(topography: xr.DataArray, *,
                   height: QuantityLike | None = None, method: str = "points") -> xr.DataArray:
    """Fraction of the surface at or above each height, ``Smr(c)`` (ISO 25178-2).

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        See :func:`roughness_parameters`.
    height : array_like, optional
        Heights ``c`` relative to the mean (numbers in the height unit, strings or
        Quantities); default 101 from the deepest valley to the highest peak (a lazy
        topography needs them).
    method : {'points', 'linear'}
        ``'points'``: the share of the measured points (ISO 25178-2). ``'linear'``: the
        share of the surface interpolated linearly between them (a profile's polyline,
        exact; a map cut into two triangles per square), with the bounds any
        interpolation keeps to (coords ``material_ratio_lower`` / ``_upper``: the share
        of segments or squares entirely at or above ``c``, and with any point at or
        above it); SurfaceTopography's ``bearing_area`` and its ``bounds``.

    Returns
    -------
    xarray.DataArray
        ``Smr(c) = #{z >= c} / N`` over the ``N`` valid points (``units="1"``) on dim
        ``height`` (height unit), or the continuous share with its bounds.

    Raises
    ------
    ValueError
        An invalid topography, heights that are not finite or not lengths, an unknown
        ``method``.

    See Also
    --------
    bearing_area_curve : the inverse.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> line = xrough.topography(np.array([1.0, 2.0, 3.0, 6.0]), spacing=1.0, unit="nm")
    >>> line.rough.material_ratio(height=[-1.0, "0 nm", "4 nm"]).values.tolist()
    [0.75, 0.5, 0.0]
    """
    grid = _validated(topography, "a material ratio")
    if height is None:
        lo, hi = _data_range(topography, grid, "material_ratio without heights",
                             **_kernel_options(grid), quantity="height", direction="")
        levels = np.linspace(lo, hi, 101)
    else:
        levels = np.atleast_1d(u.magnitude_in(height, grid.height_unit, what="height"))
        if levels.ndim != 1 or not levels.size or not np.all(np.isfinite(levels)):
            raise ValueError(f"height must be a 1-D array of finite heights, got {height!r}")
    if method not in ("points", "linear"):
        raise ValueError(f"method must be 'points' or 'linear', got {method!r}")
    bounds = {}
    if method == "points":
        out = _apply(k.material_ratio, topography, grid, {"height": levels.size},
                     heights=levels, nd=len(grid.dims))
        definition = "#{z >= c} / N over the N valid points"
    else:
        packed = _apply(k.continuous_material_ratio, topography, grid,
                        {"height": levels.size, "part": 3}, heights=levels,
                        nd=len(grid.dims), periodic=grid.periodic)
        out = packed.isel(part=0)
        for i, end in ((1, "lower"), (2, "upper")):
            bounds[f"material_ratio_{end}"] = packed.isel(part=i).assign_attrs(
                units="1", long_name=f"{end} bound of the material ratio of any "
                "interpolation between the points")
        definition = ("share of the surface interpolated linearly between the points (a "
                      "profile's polyline; two triangles per square of a map) at or above c")
    out = out.assign_coords(height=("height", levels, {
        "units": grid.height_unit, "long_name": "height c relative to the mean"}), **bounds)
    out.name = "material_ratio"
    out.attrs = result_attrs(
        topography, units="1",
        long_name="areal material ratio Smr(c) "
                  f"({_ISO_AREAL if len(grid.dims) == 2 else _ISO_PROFILE})",
        definition=definition, reference=REFERENCE, method=method)
    return out


# ------------------------------------------------------------------------ scale dependence


def _steps(grid: Grid, dr: QuantityLike | None, points_per_decade: float,
           dr_max: QuantityLike | None,
           width: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the steps ``dr`` (lateral unit) and their pixels per axis, ``(n, nd)``."""
    ppd = check_points_per_decade(points_per_decade)
    finest = min(grid.spacing)
    square = max(grid.spacing) - finest <= SPACING_RTOL * finest
    if dr is None:
        hi = (DR_FRACTION * min(grid.size) if dr_max is None else
              u.length_in(dr_max, grid.lateral_unit, what="dr_max"))
        kmax = int(np.floor(hi / finest * (1 + 1e-9)))
        if dr_max is None:
            kmax = max(kmax, 1)  # a map of fewer than 4 pixels: its one pixel, if it fits
        if kmax < 1:
            raise ValueError(f"dr_max = {hi:g} {grid.lateral_unit} is below one pixel "
                             f"({finest:g} {grid.lateral_unit})")
        ks = np.unique(np.rint(log_range(1.0, max(kmax, 2), ppd)).astype(int))
        dr = ks[ks <= kmax] * finest
    else:
        if dr_max is not None:
            raise ValueError("give dr or dr_max, not both")
        dr = require_increasing(u.array_in(dr, grid.lateral_unit, what="dr", noun="steps",
                                           positive=True), "dr", noun="steps")
    steps = np.stack([np.maximum(1, np.rint(dr / d)).astype(int) for d in grid.spacing],
                     axis=-1)
    if square:
        off = np.abs(steps[:, 0] * finest - dr) > 1e-6 * finest
        if off.any():
            bad = dr[np.argmax(off)]
            raise ValueError(f"dr = {bad:g} {grid.lateral_unit} is not a whole number of "
                             f"pixels ({finest:g} {grid.lateral_unit}): finite differences "
                             "are taken between grid points")
        dr = steps[:, 0] * finest  # the lattice steps, without the round-off of units
    for a, (dim, n) in enumerate(zip(grid.dims, grid.shape)):
        for value, step in zip(dr, steps[:, a]):
            try:
                fd.check_step(step, n, periodic=grid.periodic, width=width)
            except ValueError as err:
                raise ValueError(f"dr = {value:g} {grid.lateral_unit} along {dim!r}: "
                                 f"{err}") from None
    return dr, steps


def _step_coords(grid: Grid, steps: np.ndarray, dr: np.ndarray, what: str) -> dict:
    coords = lag_coord(dr, grid.lateral_unit, long_name=f"finite-difference step of the "
                                                        f"{what}")
    for a, dim in enumerate(grid.dims):
        coords[f"step_{dim}"] = ("dr", steps[:, a], {
            "units": "1", "long_name": f"step along {dim} in pixels (the nearest to dr)"})
    return coords


@u.accepts_quantified
def scale_dependent_slope(topography: xr.DataArray, *, dr: QuantityLike | None = None,
                          points_per_decade: float = 10,
                          dr_max: QuantityLike | None = None) -> xr.DataArray:
    r"""Rms slope of finite differences at every step ``dr`` (scale-dependent slope).

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        See :func:`roughness_parameters`. Extra dims are kept (one curve per map), and
        stay lazy on dask.
    dr : array_like, optional
        Steps (numbers in the lateral unit, strings or Quantities), increasing, whole
        numbers of pixels. Default: log-spaced whole pixels, ``points_per_decade``, from
        one pixel to ``dr_max``.
    points_per_decade : float
        Density of the default grid (before rounding to whole pixels).
    dr_max : float, str or Quantity, optional
        Largest default step (numbers in the lateral unit); default a quarter of the
        shorter side (:data:`DR_FRACTION`).

    Returns
    -------
    xarray.DataArray
        ``slope`` (``units="1"``) on dim ``dr`` (lateral unit), with coordinates
        ``pair_count`` (differences averaged) and ``step_x`` (``step_y``): the pixels of
        each step. Its first value (one pixel) is ``Rdq`` / ``Sdq`` of
        :func:`roughness_parameters`.

    Raises
    ------
    ValueError
        An invalid topography, a step that is not a whole number of pixels or does not
        fit the map, ``dr`` with ``dr_max``.

    See Also
    --------
    xrough.rms_gradient : gbar(dr) of eq. 26, the slope with the wavelengths below
        ``dr`` removed, which this sits beside (docs/parameters.md).

    Notes
    -----
    ``s(dr)^2 = 2 G(dr) / dr^2`` (profile) or ``2 [G_x(dr) + G_y(dr)] / dr^2`` (map), exactly,
    over the pairs of ``G`` (eq. 1) along each axis; for an isotropic map ``s^2 = 4 G / dr^2``.
    Details: docs/parameters.md, "Scale-dependent slope and curvature".

    Examples
    --------
    >>> import numpy as np, xrough
    >>> x = np.arange(512) * 1.0
    >>> line = xrough.topography(np.sin(2 * np.pi * x / 64), spacing=1.0, unit="nm",
    ...                          periodic=True)
    >>> s = line.rough.scale_dependent_slope(dr=[1.0, 32.0, 64.0])
    >>> s.values.round(4).tolist(), s.dr.attrs["units"]  # sqrt 2 sin(pi dr / 64) / dr
    ([0.0694, 0.0442, 0.0], 'nm')
    >>> bool(s[0] == line.rough.parameters().Rdq)
    True
    """
    grid = _validated(topography, "the scale-dependent slope")
    dr, steps = _steps(grid, dr, points_per_decade, dr_max, width=1)
    packed = _apply(k.slope_by_step, topography, grid, {"dr": len(dr), "part": 2},
                    steps=steps, **_kernel_options(grid))
    out = packed.isel(part=0).assign_coords(_step_coords(grid, steps, dr, "slope"))
    out = out.assign_coords(pair_count=packed.isel(part=1).astype(np.int64).assign_attrs(
        units="1", long_name="height differences averaged (all axes)"))
    out.name = "slope"
    out.attrs = result_attrs(
        topography, units="1", long_name="scale-dependent rms slope",
        definition=("sqrt(2 G(dr)) / dr, G along x (eq. 1)" if len(grid.dims) == 1 else
                    "sqrt(2 [G_x(dr) + G_y(dr)]) / dr, G along x and along y (eq. 1): the "
                    "rms |grad h| at step dr"),
        stencil=SLOPE_STENCIL, periodic=int(grid.periodic))
    return out


@u.accepts_quantified
def scale_dependent_statistic(topography: xr.DataArray, statistic, *, order: int = 1,
                              dr: QuantityLike | None = None, points_per_decade: float = 10,
                              dr_max: QuantityLike | None = None, units: str | None = None,
                              name: str = "statistic") -> xr.DataArray:
    r"""Any statistic of the slopes (or curvatures) of finite differences at any distance.

    SurfaceTopography's ``scale_dependent_statistical_property``: at each distance ``dr``
    the derivative of ``order`` 1, :math:`[h(x + \Delta r) - h(x)] / \Delta r`, or 2,
    :math:`[h(x + \Delta r) - 2 h(x) + h(x - \Delta r)] / \Delta r^2`, along ``x`` (and
    ``y`` on a map), heights at fractional pixels interpolated linearly between grid
    points; then ``statistic`` of their valid values.

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        Heights with units; NaN for missing points (derivatives that touch one are left
        out). Extra dims give one curve each, lazy on dask.
    statistic : callable
        ``statistic(d_x)`` of a profile, ``statistic(d_x, d_y)`` of a map: 1-D arrays of
        the valid derivatives (slopes are pure numbers, curvatures in 1 / lateral unit)
        to one number (``lambda d_x, d_y: np.var(d_x)``).
    order : {1, 2}
        Slope or curvature.
    dr : float, str, Quantity or array, optional
        Distances (numbers in the lateral unit), any, not only whole pixels; one gives a
        0-d result. Default: ``points_per_decade`` log-spaced from the pixel to
        ``dr_max`` (a quarter of the shorter side).
    points_per_decade : float
        Density of the default distances.
    dr_max : float, str or Quantity, optional
        Largest default distance.
    units : str, optional
        The unit of the statistic, for the result's ``units`` (unstated by default:
        xrough cannot know what ``statistic`` computes).
    name : str
        The result's name.

    Returns
    -------
    xarray.DataArray
        On dim ``dr`` (lateral unit; none for one distance): the statistic; NaN below
        the pixel (not quoted) or where the stencil does not fit the map.

    Raises
    ------
    ValueError
        ``order`` other than 1 or 2, non-positive distances, ``dr`` with ``dr_max``.

    Notes
    -----
    With whole pixels and ``statistic = mean(d_x^2)`` it is ``2 G_x(dr) / dr^2`` exactly
    (G along x, eq. 1), as :func:`scale_dependent_slope` (whose first value is ``Sdq``).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> x = np.arange(256) * 1.0
    >>> line = xrough.topography(0.3 * x, spacing=1.0, unit="nm")  # a slope of 0.3
    >>> s = xrough.scale_dependent_statistic(line, np.mean, dr=[1.0, 2.5, 10.0])
    >>> s.values.round(12).tolist()  # at any distance, interpolated or not
    [0.3, 0.3, 0.3]
    """
    grid = _validated(topography, "the scale-dependent statistic")
    if order not in (1, 2):
        raise ValueError(f"order must be 1 (slope) or 2 (curvature), got {order!r}")
    if not callable(statistic):
        raise TypeError("statistic must be a callable of the derivatives' values")
    scalar = isinstance(dr, (str, int, float, np.number)) or (
        dr is not None and getattr(dr, "ndim", None) == 0)
    if dr is None:
        hi = (DR_FRACTION * min(grid.size) if dr_max is None else
              u.length_in(dr_max, grid.lateral_unit, what="dr_max"))
        distances = log_range(max(grid.spacing), hi, check_points_per_decade(
            points_per_decade))
    else:
        if dr_max is not None:
            raise ValueError("give dr or dr_max, not both")
        distances = np.atleast_1d(u.array_in(dr, grid.lateral_unit, what="dr",
                                             noun="distances", positive=True))
    values = _apply(k.statistic_by_distance, topography, grid, {"dr": distances.size},
                    distances=distances, order=int(order), statistic=statistic,
                    **_kernel_options(grid))
    out = values.assign_coords(lag_coord(distances, grid.lateral_unit,
                                         long_name="distance of the finite differences"))
    what = "slopes" if order == 1 else "curvatures"
    attrs = {"long_name": f"scale-dependent statistic of the {what}", "order": int(order)}
    if units is not None:
        attrs["units"] = units
    out.attrs = result_attrs(topography, **attrs)
    out.name = name
    return out.isel(dr=0) if scalar else out


@u.accepts_quantified
def scale_dependent_curvature(topography: xr.DataArray, *, dr: QuantityLike | None = None,
                              points_per_decade: float = 10,
                              dr_max: QuantityLike | None = None,
                              tip_radius: QuantityLike | None = None, stated_tip: bool = True,
                              safety_factor: float = TIP_SAFETY_FACTOR) -> xr.DataArray:
    r"""Rms curvature of second differences at every step ``dr``, with the tip check.

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        See :func:`scale_dependent_slope`.
    dr, points_per_decade, dr_max
        The steps, as for :func:`scale_dependent_slope` (the stencil spans ``2 dr``).
    tip_radius : float, str or Quantity, optional
        Radius ``R`` of the tip or stylus (numbers in the lateral unit): the scales
        curved beyond what it can image are marked (:func:`tip_check`).
    stated_tip : bool
        Without ``tip_radius``, check with the radius the file's metadata state, if any
        (:func:`xrough.preprocess.stated_tip_radius`, as ``acf()`` does).
    safety_factor : float
        Of the tip check (:func:`tip_check`).

    Returns
    -------
    xarray.DataArray
        ``curvature`` (1 / lateral unit) on dim ``dr``: the rms of ``h''`` (profile) or
        of the mean curvature ``(c_x + c_y) / 2`` (map), with coordinates
        ``point_count``, ``curvature_min`` (the most negative curvature along the fast
        scan axis ``x``, the tail the tip rule reads), ``step_x`` (``step_y``). Its first
        value is ``rms_curvature`` of :func:`roughness_parameters`. With a tip radius,
        the marks of :func:`tip_check`.

    Raises
    ------
    ValueError
        As for :func:`scale_dependent_slope`; a step whose stencil ``2 dr`` does not fit
        an open map; a tip radius that is not a positive length.

    Notes
    -----
    For a periodic profile (and on average for an open one),

    .. math:: \langle c^2\rangle(\Delta r) = \frac{8\,G(\Delta r) - 2\,G(2\Delta r)}
              {\Delta r^4}.

    SurfaceTopography's ``scale_dependent_curvature_from_profile`` (and its
    ``derivative(n=2, distance=...)``) label the same stencil by its total length
    ``lambda = 2 dr``.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> x = np.arange(512) * 1.0
    >>> line = xrough.topography(np.sin(2 * np.pi * x / 64), spacing=1.0, unit="nm",
    ...                          periodic=True)
    >>> c = line.rough.scale_dependent_curvature(dr=[1.0, 8.0])
    >>> c.values.round(5).tolist(), c.attrs["units"]  # (2 pi / 64)^2 / sqrt 2 at small dr
    ([0.00681, 0.00647], 'nm-1')
    >>> c.curvature_min.values.round(5).tolist()
    [-0.00963, -0.00915]
    """
    grid = _validated(topography, "the scale-dependent curvature")
    dr, steps = _steps(grid, dr, points_per_decade, dr_max, width=2)
    packed = _apply(k.curvature_by_step, topography, grid, {"dr": len(dr), "part": 3},
                    steps=steps, **_kernel_options(grid))
    unit = _curvature_unit(grid)
    out = packed.isel(part=0).assign_coords(_step_coords(grid, steps, dr, "curvature"))
    out = out.assign_coords(
        point_count=packed.isel(part=1).astype(np.int64).assign_attrs(
            units="1", long_name="stencils averaged"),
        curvature_min=packed.isel(part=2).assign_attrs(
            units=unit, long_name="most negative curvature along x"))
    out.name = "curvature"
    out.attrs = result_attrs(
        topography, units=unit,
        long_name="scale-dependent rms curvature" + (" (mean curvature)"
                                                     if len(grid.dims) == 2 else ""),
        definition=("sqrt(<c^2>), <c^2> = [8 G(dr) - 2 G(2 dr)] / dr^4 (periodic; G along "
                    "x, eq. 1)" if len(grid.dims) == 1 else
                    "sqrt(<[(c_x + c_y) / 2]^2>), the mean curvature at step dr"),
        stencil=CURVATURE_STENCIL, periodic=int(grid.periodic))
    source = "given"
    if tip_radius is None and stated_tip:
        stated = stated_tip_radius(topography.attrs)
        if stated is not None:
            tip_radius, key = stated
            source = f"stated in the file (attr {key!r})"
    if tip_radius is None:
        return out
    return tip_check(out, tip_radius=tip_radius, safety_factor=safety_factor,
                     source=source)


#: The CF flags of the coordinate ``beyond_tip`` of :func:`tip_check`.
_TIP_FLAGS = ("within_tip", "tail_beyond_tip", "rms_beyond_tip")


def _runs(dr: np.ndarray, hit: np.ndarray) -> str:
    """``"0.2-0.8, 3.1"``: the runs of consecutive ``dr`` where ``hit``."""
    parts, i = [], 0
    while i < len(dr):
        if not hit[i]:
            i += 1
            continue
        j = i
        while j + 1 < len(dr) and hit[j + 1]:
            j += 1
        parts.append(f"{dr[i]:.3g}" if i == j else f"{dr[i]:.3g}-{dr[j]:.3g}")
        i = j + 1
    return ", ".join(parts)


@u.accepts_quantified
def tip_check(curvature: xr.DataArray, *, tip_radius: QuantityLike,
              safety_factor: float = TIP_SAFETY_FACTOR, source: str = "given") -> xr.DataArray:
    """Mark the scales at which a topography is curved beyond what its tip can image.

    A tip of radius ``R`` cannot image a peak curved more sharply than ``1/R``: its
    image there is the tip's own shape. Where the rms curvature at a step exceeds ``1/R``
    the bulk of the map is curved beyond the tip; where only its most negative curvature
    passes ``-safety_factor / R``, the tail is (the rule of
    :func:`xrough.preprocess.reliable`, after Sanner et al. 2022). At those scales the
    measurement may show the tip rather than the surface.

    Parameters
    ----------
    curvature : xarray.DataArray
        A result of :func:`scale_dependent_curvature` (dim ``dr``, coordinate
        ``curvature_min``).
    tip_radius : float, str or Quantity
        ``R`` (numbers in the unit of ``dr``).
    safety_factor : float
        The tail is beyond the tip where the most negative curvature is below
        ``-safety_factor / R`` (default 1/2, Sanner et al.'s estimate from simulated
        scans).
    source : str
        Where ``R`` comes from, for the notes (``"given"``, or the attr that states it).

    Returns
    -------
    xarray.DataArray
        ``curvature`` with attrs ``tip_radius``, ``tip_radius_units``,
        ``tip_radius_source``, ``tip_rule``, the coordinate ``beyond_tip`` (``int8`` per
        step and curve: 0 within the tip, 1 only the tail beyond it, 2 the rms beyond it;
        CF flags) and the quality marks of docs/quality.md: questionable (with one
        :class:`~xrough.QualityWarning`) where some scale is beyond the tip, the scales
        named in the notes; otherwise a remark.

    Raises
    ------
    ValueError
        Not a scale-dependent curvature, or one already checked against a tip (compute it
        again with ``stated_tip=False``), a tip radius that is not a positive length, or
        a safety factor that is not a positive number.

    Examples
    --------
    >>> import numpy as np, warnings, xrough
    >>> x = np.arange(512) * 1.0
    >>> line = xrough.topography(np.sin(2 * np.pi * x / 64), spacing=1.0, unit="nm",
    ...                          periodic=True)
    >>> c = line.rough.scale_dependent_curvature(dr=[1.0, 8.0])  # 1/rms: 147 nm, 155 nm
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     blunt = c.rough.tip_check(tip_radius="150 nm")
    >>> blunt.attrs["quality"], blunt.beyond_tip.values.tolist()
    ('questionable', [2, 1])
    >>> c.rough.tip_check(tip_radius="50 nm").attrs["quality_remarks"][:60]
    'tip radius 50 nm (given): no scale is curved beyond it (the '
    """
    if not isinstance(curvature, xr.DataArray) or "dr" not in curvature.dims or (
            "curvature_min" not in curvature.coords):
        raise ValueError("tip_check reads a scale-dependent curvature (dim 'dr' and "
                         "coordinate 'curvature_min'): topography.rough."
                         "scale_dependent_curvature()")
    if "tip_radius" in curvature.attrs:
        raise ValueError(f"this curvature was already checked against a tip of radius "
                         f"{curvature.attrs['tip_radius']:g} "
                         f"{curvature.attrs.get('tip_radius_units', '')}; to check "
                         "another, compute it again with tip_radius=... (or "
                         "stated_tip=False and then tip_check)")
    unit = u.units_of(curvature["dr"], what="coordinate 'dr'")
    lunit = u.format_units(unit)
    radius = u.length_in(tip_radius, lunit, what="tip_radius")
    if isinstance(safety_factor, (bool, np.bool_)) or not isinstance(
            safety_factor, (int, float, np.integer, np.floating)) or not (
            np.isfinite(safety_factor) and safety_factor > 0):
        raise ValueError(f"safety_factor must be a positive number, got {safety_factor!r}")
    to_dr = u.conversion_factor(u.units_of(curvature, what="curvature"), unit**-1)
    rms = curvature.reset_coords(drop=True) * to_dr
    lowest = curvature["curvature_min"].reset_coords(drop=True) * to_dr
    flag = xr.where(rms > 1.0 / radius, 2, xr.where(lowest < -safety_factor / radius, 1, 0))
    flag = xr.DataArray(flag.data.astype(np.int8), dims=flag.dims).assign_attrs(
        units="1", long_name=f"curvature beyond a tip of radius {radius:g} {lunit}",
        **quality.cf_flags(_TIP_FLAGS, np.int8))
    rule = (f"beyond_tip = 2 where the rms curvature exceeds 1/R, 1 where only the most "
            f"negative curvature is below -{safety_factor:g}/R (R = {radius:g} {lunit})")
    out = curvature.assign_coords(beyond_tip=flag)
    out.attrs.update(tip_radius=float(radius), tip_radius_units=lunit,
                     tip_radius_source=source, tip_rule=rule)
    codes = (flag.max("dr") > 0).astype(np.int8)
    told = f"tip radius {radius:g} {lunit} " + ("(given)" if source == "given" else source)
    notes = (f"curvature beyond the tip ({told}) at some scales: coordinate beyond_tip "
             "says where")
    single = flag.chunks is None and flag.ndim == 1
    if single and flag.values.any():  # one computed curve: say where
        dr, values = curvature["dr"].values, flag.values
        tail = np.asarray(lowest.values < -safety_factor / radius)
        parts = [f"the rms curvature exceeds 1/R at dr = {_runs(dr, values == 2)} {lunit}"
                 if (values == 2).any() else "",
                 f"the most negative curvature passes -{safety_factor:g}/R at dr = "
                 f"{_runs(dr, tail)} {lunit}" if tail.any() else ""]
        notes = (f"curvature beyond the tip: with a {told}, "
                 + " and ".join(p for p in parts if p)
                 + ": at these scales the map may show the tip's shape, not the surface's; "
                   "leave them out of G with reliable(tip_radius=...)")
    out = quality.mark_curves(out, codes, what="scale_dependent_curvature",
                              reason="beyond_tip", notes=notes)
    if single and not flag.values.any():
        out = quality.mark(out, f"{told}: no scale is curved beyond it (the rms curvature "
                                f"stays below 1/R, the most negative above "
                                f"-{safety_factor:g}/R)", level="good",
                           what="scale_dependent_curvature")
    return out
