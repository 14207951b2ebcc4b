"""Topographies: construct and validate height maps and line profiles with units.

A topography is an :class:`xarray.DataArray` of heights on uniform lateral coordinates:
dims ``("y", "x")`` for a map or ``("x",)`` for a profile, optionally with extra leading
dims (``scan``, ``sample``...) for stacks. Heights and coordinates carry a CF ``units``
attribute of dimension length; missing points are NaN; ``attrs["periodic"]`` (1 or 0) says
whether the map is one period of a periodically repeated surface.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from . import units as u
from ._kernels.checks import require_flag
from ._kernels.deferred import pint
from ._kernels.pairs import require_no_inf
from .models import MODEL_ATTR_POWERS
from .units import QuantityLike

if TYPE_CHECKING:
    from pint.facets.plain import PlainUnit

__all__ = ["topography", "convert_units", "Grid", "grid_of", "SPACING_RTOL", "stored_step"]

#: Largest relative deviation of coordinate steps from their mean accepted as "uniform".
SPACING_RTOL = 1e-6
_CORE_DIMS = (("y", "x"), ("x",))


@dataclass(frozen=True)
class Grid:
    """Geometry of a validated topography (the core dims only).

    Attributes
    ----------
    dims : tuple of str
        ``("y", "x")`` or ``("x",)``.
    shape : tuple of int
        Number of points along ``dims``.
    spacing : tuple of float
        Grid spacing along ``dims``, in ``lateral_unit``.
    lateral_unit, height_unit : str
        CF unit strings.
    periodic : bool
    """

    dims: tuple[str, ...]
    shape: tuple[int, ...]
    spacing: tuple[float, ...]
    lateral_unit: str
    height_unit: str
    periodic: bool

    @property
    def size(self) -> tuple[float, ...]:
        """Physical size ``n * spacing`` along each dim (lateral unit)."""
        return tuple(n * d for n, d in zip(self.shape, self.spacing))

    @property
    def pixel_area(self) -> float:
        """Area (2D) or length (1D) of one grid cell, in lateral units."""
        return float(np.prod(self.spacing))


def _uniform_spacing(values: np.ndarray, name: str) -> float:
    values = np.asarray(values)
    if values.ndim != 1:
        raise ValueError(f"coordinate {name!r} must be one-dimensional")
    if values.size < 2:
        raise ValueError(f"coordinate {name!r} needs at least 2 points to define a spacing")
    if values.dtype.kind not in "iuf":
        raise ValueError(f"coordinate {name!r} must be numeric, got dtype {values.dtype}")
    steps = np.diff(values.astype(float))
    step = (values[-1] - values[0]) / (values.size - 1)
    if not np.isfinite(step) or step == 0:
        raise ValueError(f"coordinate {name!r} has zero or non-finite spacing")
    tol = SPACING_RTOL if values.dtype.itemsize >= 8 else 1e-4
    dev = np.max(np.abs(steps - step)) / abs(step)
    if dev > tol:
        worst = int(np.argmax(np.abs(steps - step)))
        raise ValueError(
            f"coordinate {name!r} is not uniformly spaced: step {worst} is {steps[worst]:g} "
            f"while the mean step is {step:g} (relative deviation {dev:.2g} > {tol:g}). "
            "Resample the data onto a uniform grid first: read the file with "
            "open_topography(path, resample=True) (linear interpolation onto a uniform "
            "grid with the same number of points), or interpolate it yourself."
        )
    return float(abs(step))


def _core_dims(da: xr.DataArray) -> tuple[str, ...]:
    if "y" in da.dims and "x" in da.dims:
        return ("y", "x")
    if "x" in da.dims and "y" not in da.dims:
        return ("x",)
    last = da.dims[-2:]
    example = ("{" + ", ".join(f"{d!r}: {n!r}" for d, n in zip(last, ("y", "x")[-len(last):]))
               + "}") if last else "{...}"
    raise ValueError(
        f"a topography needs dims ('y', 'x') for a map or ('x',) for a profile; got "
        f"{da.dims}. Rename them, e.g. da.rename({example})."
    )


def grid_of(da: xr.DataArray, *, what: str = "topography") -> Grid:
    """Validate a topography and return its :class:`Grid`.

    Checks dims, units on heights and on every core coordinate (lengths), uniform spacing,
    and that heights are finite or NaN (never inf).

    Raises
    ------
    ValueError
        Naming the dim, coordinate or attribute at fault.
    """
    if not isinstance(da, xr.DataArray):
        raise TypeError(f"{what} must be an xarray.DataArray, got {type(da).__name__}")
    dims = _core_dims(da)
    if da.dtype.kind not in "iuf":
        raise ValueError(f"{what} heights must be real numbers, got dtype {da.dtype}")
    hunit = u.as_length_unit(u.units_of(da, what=f"{what} heights"), what=f"{what} heights")
    spacing = []
    lunit = None
    for dim in dims:
        if dim not in da.coords:
            raise ValueError(
                f"{what} has no coordinate {dim!r}; build it with xrough.topography(..., "
                f"spacing=...) or assign one with units"
            )
        coord = da.coords[dim]
        cunit = u.as_length_unit(u.units_of(coord, what=f"coordinate {dim!r}"),
                                 what=f"coordinate {dim!r}")
        step = _uniform_spacing(coord.values, dim)
        if lunit is None:
            lunit = cunit
        else:
            step *= u.conversion_factor(cunit, lunit)
        spacing.append(step)
    for dim in dims:
        if da.sizes[dim] < 2:
            raise ValueError(f"{what} needs at least 2 points along {dim!r}")
    periodic = bool(int(da.attrs.get("periodic", 0)))
    assert lunit is not None  # _core_dims: at least one dim
    return Grid(dims=dims, shape=tuple(da.sizes[d] for d in dims), spacing=tuple(spacing),
                lateral_unit=u.format_units(lunit), height_unit=u.format_units(hunit),
                periodic=periodic)


def require_whole_maps(da: xr.DataArray, grid: Grid, *, purpose: str) -> None:
    """Refuse dask chunks along the core dims, with the ``.chunk(...)`` that fixes it."""
    if da.chunks is None:
        return
    for d in grid.dims:
        if len(da.chunksizes[d]) > 1:
            whole = ", ".join(f"{c!r}: -1" for c in grid.dims)
            raise ValueError(
                f"dim {d!r} is split into several dask chunks; {purpose} needs each map "
                f"whole: use topography.chunk({{{whole}}}) (parallelism comes from extra "
                f"dims such as 'scan')"
            )


def check_finite(values: np.ndarray, *, what: str = "topography") -> np.ndarray:
    """Return ``values`` as an array; raise if any is infinite (NaN marks missing points)."""
    return require_no_inf(values, what=f"the heights of {what}")


def check_valid_points(values: np.ndarray, *, what: str = "topography", ndim: int = 2) -> None:
    """Raise if any map in ``values`` (core dims last) has inf or fewer than 2 valid points."""
    values = check_finite(values, what=what)
    valid = np.isfinite(values).reshape(values.shape[: values.ndim - ndim] + (-1,)).sum(-1)
    if np.any(valid < 2):
        raise ValueError(
            f"{what} has fewer than 2 valid (non-NaN) points"
            + (" in at least one map of the stack" if np.ndim(valid) else "")
        )


def stored_step(values: np.ndarray) -> float | None:
    """Give the spacing of heights stored in a float of fewer than 64 bits at their largest.

    ``None`` for float64, integers and empty or all-NaN heights: the rounding a float32
    (or float16) made when the heights were stored, ``np.spacing`` at the largest
    ``|h|``, in the heights' unit. Read by :func:`xrough.acf` (attr ``stored_height_step``).

    >>> float(stored_step(np.array([2.6e5, 0.0], dtype=np.float32)))
    0.015625
    """
    values = np.asarray(values)
    if values.dtype.kind != "f" or values.dtype.itemsize >= 8 or values.size == 0:
        return None
    top = np.nanmax(np.abs(values)) if np.isfinite(values).any() else np.nan
    return float(np.spacing(values.dtype.type(top))) if np.isfinite(top) else None


def _pair(value: Any, n: int, what: str) -> list[Any]:
    if isinstance(value, (tuple, list)):
        if len(value) != n:
            raise ValueError(f"{what} must have {n} entries (one per dim), got {len(value)}")
        return list(value)
    return [value] * n


def topography(
    heights: ArrayLike | pint.Quantity | xr.DataArray,
    *,
    spacing: QuantityLike | None = None,
    size: QuantityLike | None = None,
    unit: str | None = None,
    height_unit: str | None = None,
    periodic: bool | None = None,
    name: str | None = None,
    attrs: dict | None = None,
) -> xr.DataArray:
    """Build a validated topography (height map or profile) with physical units.

    Parameters
    ----------
    heights : array_like, pint.Quantity or xarray.DataArray
        2D ``(y, x)`` map or 1D ``(x,)`` profile; NaN marks missing points. A DataArray
        may have extra leading dims (a stack of scans) and keeps its coords and attrs;
        a quantified one (pint Quantities as data or coordinates, as pint-xarray's
        ``.pint.quantify()`` makes) is dequantified into ``units`` attributes.
    spacing : float, str, Quantity or pair of them, optional
        Grid spacing ``(dy, dx)`` or one value for both; plain numbers are in ``unit``.
    size : float, str, Quantity or pair of them, optional
        Physical size ``n * spacing`` per dim (alternative to ``spacing``; the coordinates
        then start at zero).
    unit : str, optional
        Length unit of the lateral coordinates and, unless ``height_unit`` is given, of
        the heights (``"nm"``, ``"um"``, ``"m"``). Required for plain arrays: heights in
        unknown units are refused rather than guessed.
    height_unit : str, optional
        Unit of the heights when it differs from the lateral unit.
    periodic : bool, optional
        Whether the map is one period of a periodic surface (default: keep the
        DataArray's ``attrs["periodic"]``, else False).
    name : str, optional
        Name of the DataArray (default ``"height"``).
    attrs : dict, optional
        Extra attributes (instrument, date, ...).

    Returns
    -------
    xarray.DataArray
        Heights with ``units`` on data and on ``x`` (and ``y``), coordinates starting at
        zero, ``attrs["periodic"]`` = 1 or 0.

    Raises
    ------
    ValueError
        Wrong dims, non-uniform or unit-less coordinates, non-length units, infinite
        values, fewer than 2 valid points, inconsistent spacing/size.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> h = np.random.default_rng(0).normal(size=(4, 6))
    >>> topo = xrough.topography(h, spacing="2 nm", unit="nm")
    >>> topo.dims, topo.attrs["units"], topo.x.attrs["units"], float(topo.x[1])
    (('y', 'x'), 'nm', 'nm', 2.0)
    """
    if isinstance(heights, xr.DataArray):
        # a quantified DataArray (pint Quantity data, e.g. from pint-xarray) comes in here
        # once: its units move to the 'units' attributes every later step reads
        da = u.dequantify(heights).copy()
        if da.dtype.kind in "iu":
            da = da.astype(float)
        if unit is not None or height_unit is not None:
            hu = height_unit or unit
            assert hu is not None  # one of them is given
            if "units" in da.attrs and u.parse_units(da.attrs["units"]) != u.parse_units(hu):
                raise ValueError(f"heights already have units {da.attrs['units']!r}; "
                                 f"convert explicitly instead of relabelling as {hu!r}")
            da.attrs["units"] = u.format_units(hu)
        dims = _core_dims(da)
        if spacing is not None or size is not None:
            da = _assign_coords(da, dims, spacing, size, unit)
        elif unit is not None:
            for d in dims:
                if d in da.coords and "units" not in da.coords[d].attrs:
                    da.coords[d].attrs["units"] = u.format_units(unit)
    else:
        hu = height_unit or unit
        if isinstance(heights, pint.Quantity):
            if hu is None:
                hu = u.format_units(heights.units)
                unit = unit or hu
            values = np.asarray(heights.to(u.parse_units(hu)).magnitude, dtype=float)
        else:
            values = np.asarray(heights)
            if values.dtype.kind not in "iuf":
                raise ValueError(f"heights must be real numbers, got dtype {values.dtype}")
            step = stored_step(values)  # a float32's rounding, before it is float64
            if step is not None:
                attrs = {**(attrs or {}), "stored_height_step": step,
                         "stored_dtype": str(values.dtype)}
            values = values.astype(float, copy=False)
        if hu is None:
            raise ValueError(
                "heights given as plain numbers need a unit: pass unit='nm' (or "
                "height_unit=...) so that no unit is guessed"
            )
        if values.ndim == 2:
            dims = ("y", "x")
        elif values.ndim == 1:
            dims = ("x",)
        else:
            raise ValueError(
                f"heights must be 2D (y, x) or 1D (x,), got {values.ndim} dims; stack "
                "several maps as a DataArray with an extra dim such as 'scan'"
            )
        if spacing is None and size is None:
            raise ValueError("give the grid spacing or the physical size (spacing= or size=)")
        da = xr.DataArray(values, dims=dims, attrs={"units": u.format_units(hu)})
        da = _assign_coords(da, dims, spacing, size, unit)
    if name is not None or da.name is None:
        da.name = name or "height"
    if periodic is not None:
        da.attrs["periodic"] = int(require_flag(periodic, "periodic"))
    else:
        da.attrs["periodic"] = int(bool(int(da.attrs.get("periodic", 0))))
    da.attrs.setdefault("long_name", "height")
    if attrs:
        da.attrs.update(attrs)
    grid_of(da)
    if not _is_dask(da):
        check_valid_points(da.transpose(..., *dims).values, ndim=len(dims))
    return da


@u.accepts_quantified
def convert_units(topography: xr.DataArray, height: str | PlainUnit | None = None, *,
                  lateral: str | PlainUnit | None = None) -> xr.DataArray:
    """Convert a topography's heights and/or lateral coordinates to other units.

    Values are multiplied by the conversion factor and the ``units`` attributes rewritten;
    nothing else changes (no resampling, the dtype is kept, dask stays lazy). Use it to
    work in the data's natural units after reading a file that stores metres (X3P, SDF):
    every later result (``G`` in nm², ``dr`` in µm, ...) follows. The attributes xrough
    writes follow too: the model parameters of a synthetic surface are rescaled
    (:data:`xrough.models.MODEL_ATTR_POWERS`), the reliability window keeps its own
    ``reliable_dr_units``. A file's own header attributes are left as the file wrote them.

    Unlike ``open_topography(unit=...)``, which relabels a file whose unit is missing or
    wrong, this converts: the physical surface stays the same.

    Parameters
    ----------
    topography : xarray.DataArray
        A topography (dims ``y, x`` or ``x``, see :func:`topography`).
    height : str or pint.Unit, optional
        Unit of length for the heights (default: unchanged).
    lateral : str or pint.Unit, optional
        Unit of length for the lateral coordinates ``x`` (and ``y``) (default: unchanged).

    Returns
    -------
    xarray.DataArray

    Raises
    ------
    ValueError
        A unit that is not a length, or an input that is not a topography.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> topo = xrough.topography(np.array([0.0, 2e-9, 1e-9]), spacing="0.5 um", unit="m")
    >>> out = xrough.convert_units(topo, "nm", lateral="um")
    >>> out.values.round(6).tolist(), out.attrs["units"]
    ([0.0, 2.0, 1.0], 'nm')
    >>> out.x.values.round(6).tolist(), out.x.attrs["units"]
    ([0.0, 0.5, 1.0], 'um')
    >>> xrough.convert_units(topo, "MPa")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: height must be a length, but its units are 'MPa' (dimensions ...)
    """
    grid = grid_of(topography)
    h_unit = grid.height_unit if height is None else u.format_units(
        u.as_length_unit(height, what="height"))
    l_unit = grid.lateral_unit if lateral is None else u.format_units(
        u.as_length_unit(lateral, what="lateral"))
    h_factor = u.conversion_factor(grid.height_unit, h_unit)
    l_factor = u.conversion_factor(grid.lateral_unit, l_unit)
    out = topography.copy(deep=False, data=topography.data * _as_dtype(h_factor, topography))
    for dim in grid.dims:
        coord = topography.coords[dim]
        factor = u.conversion_factor(coord.attrs["units"], l_unit)
        out = out.assign_coords({dim: (dim, coord.values * factor,
                                       {**coord.attrs, "units": l_unit})})
    out.attrs = {**topography.attrs, "units": h_unit}
    if topography.attrs.get("model") == "self-affine":
        for name, (lateral_power, height_power) in MODEL_ATTR_POWERS.items():
            if name in out.attrs:
                out.attrs[name] = float(out.attrs[name] * l_factor**lateral_power
                                        * h_factor**height_power)
    return out


def _as_dtype(factor: float, da: xr.DataArray):
    """``factor`` as a scalar of the heights' floating dtype (float32 stays float32)."""
    return np.asarray(factor, dtype=da.dtype if da.dtype.kind == "f" else np.float64)


def _is_dask(da: xr.DataArray) -> bool:
    return da.chunks is not None


def _assign_coords(da, dims, spacing, size, unit):
    """Uniform coordinates from a spacing or size; plain numbers are in the lateral unit."""
    if spacing is not None and size is not None:
        raise ValueError("give either spacing or size, not both")
    what = "spacing" if spacing is not None else "size"
    vals = _pair(spacing if spacing is not None else size, len(dims), what)
    if unit is not None:
        lunit = unit
    else:
        explicit = [u.quantity(v, what=what).units for v in vals
                    if not isinstance(v, (int, float, np.integer, np.floating))]
        if not explicit:
            raise ValueError(
                f"a plain-number {what} needs a lateral unit: pass unit='nm' or give the "
                f"{what} with its unit, e.g. {what}='5 nm'"
            )
        lunit = explicit[0]
    lunit = u.format_units(u.as_length_unit(lunit if not isinstance(lunit, str) else
                                            u.parse_units(lunit), what="lateral unit"))
    for dim, value in zip(dims, vals):
        step = u.length_in(value, lunit, what=f"{what} along {dim!r}")
        if what == "size":
            step /= da.sizes[dim]
        da = da.assign_coords({dim: (dim, np.arange(da.sizes[dim]) * step,
                                     {"units": lunit, "long_name": f"{dim} position"})})
    return da
