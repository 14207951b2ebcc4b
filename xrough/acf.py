"""What a height-difference ACF G(dr) is: the one definition every function checks against.

``G(dr) = 1/2 <(h(r) - h(r + dr))^2>`` (eq. 1) comes from :func:`xrough.height_difference_acf`,
:func:`xrough.stitch`, :func:`xrough.acf_from_spectrum` or the user. Every public function
that takes a G reads it through :func:`check_acf`, which applies one rule per property:

=================  =======================================================================
property           rule
=================  =======================================================================
type               an :class:`xarray.DataArray`
dims               a ``dr`` dim with a coordinate; any other dim (``scan``, ...) holds
                   further curves, each treated on its own (functions that need a single
                   curve say so: select one with ``G.isel(scan=0)``)
units              ``units`` on ``dr`` is a length, on the data a length^2 (any unit:
                   nm, um, m; each function works in the unit of ``dr``)
lags               finite, strictly increasing, ``>= 0``; a ``dr = 0`` bin is allowed if
                   G is 0 or NaN there, and is ignored by every calculation
gaps               attrs ``uncovered_dr_min``, ``uncovered_dr_max`` (arrays, in
                   ``uncovered_dr_units``; :func:`xrough.stitch` writes them) name lag
                   ranges that no measurement covers: G between the bins around them is
                   a bridge, not data (:attr:`AcfSpec.gaps`, :func:`mark_gaps`)
values             NaN marks an empty bin and is skipped; no ``inf``; ``G > 0`` at every
                   valid lag ``> 0`` (0 or below cannot come from a rough surface); at
                   least two valid bins (more where a function needs them)
shape              need not be monotone (a periodic surface makes G oscillate), but must
                   not decrease overall: a curve whose last third is more than 10 % below
                   its first third (medians of ``ln G``) is a height ACF
                   ``<h(r) h(r + dr)> = sigma_h^2 - G``, not G
=================  =======================================================================

Value rules are checked at once on numpy data, and when a chunked (dask) G is computed.

The module also builds the attrs of results: :func:`result_attrs` carries the provenance of
the input (source file, checksum, format, overrides, detrending, reliability window) forward
to every G and every result derived from it, and records the xrough version.
Arguments with units (lags, wavenumbers, moduli, pressures) are read by :mod:`xrough.units`.
"""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from . import quality
from . import units as u
from ._kernels.acf_curve import acf_problem, relative_error_problem
from ._kernels.checks import require_increasing
from ._version import __version__

if TYPE_CHECKING:
    from pint.facets.plain import PlainUnit

__all__ = ["AcfSpec", "check_acf", "read_acf", "PROVENANCE", "result_attrs", "lag_coord",
           "mark_gaps", "gap_note", "strip_marks"]

#: Attributes that say where data came from; every estimator and result carries them on.
PROVENANCE = ("source", "source_file", "source_sha256", "format", "overrides", "channel",
              "instrument", "detrend", "reliable_dr_min", "reliable_dr_max",
              "reliable_dr_units", "reliable_rule", "uncovered_dr_min", "uncovered_dr_max",
              "uncovered_dr_units")


@dataclass(frozen=True)
class AcfSpec:
    """What :func:`check_acf` established about a G (its values are not copied).

    Attributes
    ----------
    dr : ndarray
        The lags, in ``length_unit``.
    length_unit : pint.Unit
        Unit of ``dr``; G is read in its square.
    unit_str : str
        CF string of ``length_unit``.
    g_factor : float
        Converts G (and its standard error) to ``length_unit^2``.
    to_m : float
        Converts ``length_unit`` to metres.
    extra_dims : tuple of hashable
        Dims other than ``dr`` (one curve per combination).
    gaps : ndarray
        Lag ranges no measurement covers, shape ``(n, 2)`` in ``length_unit`` (from the
        attrs ``uncovered_dr_min/max`` of a stitched G; empty for a G of one measurement).
    """

    dr: np.ndarray
    length_unit: PlainUnit
    unit_str: str
    g_factor: float
    to_m: float
    extra_dims: tuple[Hashable, ...]
    gaps: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))

    @property
    def to_m2(self) -> float:
        """Converts G (in its own unit) to m^2."""
        return self.g_factor * self.to_m**2


def check_acf(G: xr.DataArray, *, what: str = "G", single: bool = False,
              min_bins: int = 2) -> AcfSpec:
    """Check that ``G`` is a height-difference ACF by the rules of :mod:`xrough.acf`.

    Parameters
    ----------
    G : xarray.DataArray
        The candidate G(dr).
    what : str
        Its name in error messages.
    single : bool
        Require one curve (no dims besides ``dr``).
    min_bins : int
        Valid bins (non-NaN, ``dr > 0``) needed per curve.

    Returns
    -------
    AcfSpec

    Raises
    ------
    TypeError
        Not a DataArray.
    ValueError
        Naming the rule broken and the fix.

    Examples
    --------
    >>> import numpy as np, xarray as xr
    >>> G = xr.DataArray([0.0, 1.0, 4.0], dims="dr", attrs={"units": "nm2"},
    ...                  coords={"dr": ("dr", [0.0, 1.0, 2.0], {"units": "nm"})})
    >>> check_acf(G).unit_str
    'nm'
    >>> check_acf(G.assign_attrs(units="nm"))
    Traceback (most recent call last):
    ...
    ValueError: G must be in length^2 (a height-difference ACF, e.g. 'nm2'), but its units are 'nm'
    """
    if not isinstance(G, xr.DataArray):
        raise TypeError(f"{what} must be an xarray.DataArray, got {type(G).__name__}")
    if "dr" not in G.dims:
        raise ValueError(f"{what} needs a 'dr' dim (lag distance); got dims {G.dims}. "
                         "Compute it with topography.rough.acf()")
    if "dr" not in G.coords:
        raise ValueError(f"{what} needs a coordinate 'dr' with the lag distances")
    if single and G.ndim != 1:
        raise ValueError(f"{what} must be one curve G(dr); got dims {G.dims}. Select one "
                         f"first, e.g. G.isel({[d for d in G.dims if d != 'dr'][0]}=0)")
    length_unit = u.as_length_unit(u.units_of(G["dr"], what="coordinate 'dr'"),
                                   what="coordinate 'dr' (the lag distance)")
    unit_str = u.format_units(length_unit)
    g_unit = u.units_of(G, what=what)
    if g_unit.dimensionality != (u.ureg.meter**2).dimensionality:
        raise ValueError(f"{what} must be in length^2 (a height-difference ACF, e.g. "
                         f"{u.power_units(unit_str, 2)!r}), but its units are "
                         f"{u.format_units(g_unit)!r}")
    dr = require_increasing(G["dr"].values, "coordinate 'dr'", allow_zero=True, noun="lags",
                            hint=" (use G.sortby('dr'))")
    spec = AcfSpec(dr=dr, length_unit=length_unit, unit_str=unit_str,
                   g_factor=u.conversion_factor(g_unit, length_unit**2),
                   to_m=u.conversion_factor(length_unit, "m"),
                   extra_dims=tuple(d for d in G.dims if d != "dr"),
                   gaps=_gaps(G.attrs, length_unit, what))
    if G.chunks is None:
        lines = np.moveaxis(np.asarray(G.values, dtype=float), G.get_axis_num("dr"), -1)
        problem = acf_problem(dr, lines.reshape(-1, dr.size) * spec.g_factor,
                              min_bins=min_bins, unit=unit_str,
                              estimated=str(G.attrs.get("equation", "")).startswith("eq. 1:"))
        if not problem and "standard_error" in G.coords:
            se = G.coords["standard_error"].broadcast_like(G)
            factor = (1.0 if "units" not in se.attrs else  # unit-less: read as G's
                      u.conversion_factor(u.units_of(se, what="coordinate 'standard_error'"),
                                          g_unit))
            problem = relative_error_problem(
                lines, np.moveaxis(np.asarray(se.values, dtype=float) * factor,
                                   se.get_axis_num("dr"), -1), dr, unit=unit_str)
            problem = f"coordinate {problem}" if problem else ""
        if problem:
            raise ValueError(f"{what} {problem}")
    return spec


#: The coord of a G measured from heights: their variance, G's mean over all pairs.
HEIGHT_VARIANCE = "height_variance"


def height_variance(G: xr.DataArray, spec: AcfSpec) -> float | None:
    """Return the variance of the heights of one curve ``G`` in ``spec``'s length unit^2.

    Read from the coord ``height_variance`` that the estimators attach (the level G
    reaches in the mean over all pairs of points); ``None`` where G has none (a model, a
    stitched or a hand-made G), it is not one value, or not a positive number.
    """
    coord = G.coords.get(HEIGHT_VARIANCE)
    if coord is None or coord.ndim != 0:
        return None
    factor = (spec.g_factor if "units" not in coord.attrs else u.conversion_factor(
        u.units_of(coord, what=f"coordinate {HEIGHT_VARIANCE!r}"), spec.length_unit**2))
    value = float(coord.values) * factor
    return value if np.isfinite(value) and value > 0 else None


def read_acf(G: xr.DataArray, *, what: str = "G", single: bool = False,
             min_bins: int = 2) -> tuple[xr.DataArray, AcfSpec]:
    """Check ``G`` (:func:`check_acf`) and return it without its own rating, with its spec.

    The ``quality_flag`` coordinate of a G (a stitched one, :func:`xrough.stitch`, rates
    the levelling; lazily when G is) says how far G itself can be trusted. A function of
    G computes its own rating; carried along, G's would be merged with the flags of fits
    and gradients computed from the same G, so every function of G reads it through
    here.

    Parameters
    ----------
    G, what, single, min_bins
        As for :func:`check_acf`.

    Returns
    -------
    tuple of (xarray.DataArray, AcfSpec)

    Examples
    --------
    >>> import numpy as np, xarray as xr
    >>> G = xr.DataArray([1.0, 4.0], dims="dr", attrs={"units": "nm2"},
    ...                  coords={"dr": ("dr", [1.0, 2.0], {"units": "nm"}),
    ...                          "quality_flag": np.int8(1)})
    >>> G2, spec = read_acf(G)
    >>> "quality_flag" in G2.coords, spec.unit_str
    (False, 'nm')
    """
    spec = check_acf(G, what=what, single=single, min_bins=min_bins)
    return quality.unrated(G), spec


def _gaps(attrs: dict, length_unit: PlainUnit, what: str) -> np.ndarray:
    """Return the uncovered lag ranges recorded on a G, ``(n, 2)`` in ``length_unit``."""
    if "uncovered_dr_min" not in attrs and "uncovered_dr_max" not in attrs:
        return np.empty((0, 2))
    lo = np.atleast_1d(np.asarray(attrs.get("uncovered_dr_min", []), dtype=float))
    hi = np.atleast_1d(np.asarray(attrs.get("uncovered_dr_max", []), dtype=float))
    if lo.shape != hi.shape or lo.ndim != 1 or not np.all(np.isfinite(lo) & (lo < hi)):
        raise ValueError(f"{what}: attrs uncovered_dr_min {lo.tolist()} and "
                         f"uncovered_dr_max {hi.tolist()} must be arrays of one length "
                         "with uncovered_dr_min < uncovered_dr_max")
    unit = attrs.get("uncovered_dr_units")
    f = 1.0 if unit is None else u.conversion_factor(
        u.as_length_unit(unit, what="attr uncovered_dr_units"), length_unit)
    return np.stack([lo * f, hi * f], axis=-1)


def mark_gaps(result, spec, *, what: str, depends: str, level: str = "questionable"):
    """Mark a result of a G with unmeasured lag ranges: what of it rests on the bridge.

    The one place where the consumers of G read its gaps (:attr:`AcfSpec.gaps`): a result
    of a G without gaps is returned as it is; otherwise the note names each gap, the bins
    around it (between which every function of xrough takes G as a power law) and
    ``depends``, at ``level`` (:func:`xrough.quality.mark`; ``"good"`` adds the note
    without a warning). A result without a ``quality_flag`` coordinate gets one, so that
    marking before the caller's own per-curve rating keeps the level.

    Parameters
    ----------
    result : xarray.DataArray or xarray.Dataset
        The result to mark.
    spec : AcfSpec
        Of the G it came from (anything with ``gaps``, ``dr``, ``unit_str``).
    what : str
        The result named in the warning.
    depends : str
        What of the result depends on G inside the gaps, and how.
    level : {'good', 'questionable', 'failed'}

    Returns
    -------
    Same type as ``result``.

    Examples
    --------
    >>> import numpy as np, xarray as xr
    >>> G = xr.DataArray([1.0, 2.0, 20.0], dims="dr", attrs={
    ...     "units": "nm2", "uncovered_dr_min": np.array([3.0]),
    ...     "uncovered_dr_max": np.array([30.0]), "uncovered_dr_units": "nm"},
    ...     coords={"dr": ("dr", [1.0, 2.0, 40.0], {"units": "nm"})})
    >>> r = mark_gaps(xr.DataArray(1.0), check_acf(G), what="demo", depends="a note",
    ...               level="good")
    >>> print(r.attrs["quality_remarks"])  # doctest: +NORMALIZE_WHITESPACE
    G is not measured over dr = 3-30 nm (no measurement covers it: between its bins at 2
    and 40 nm G is taken as a power law): a note
    """
    text = gap_note(spec, depends)
    if not text:
        return result
    if quality.FLAG not in result.coords:  # so that a later per-curve rating keeps it
        result = result.assign_coords({quality.FLAG: quality.flag_coord(0, what=what)})
    return quality.mark(result, text, level=level, what=what)


def gap_note(spec, depends: str) -> str:
    """Return the note of :func:`mark_gaps` (``""`` for a G without gaps).

    For a caller that rates its result per curve itself.
    """
    gaps = np.asarray(spec.gaps, dtype=float).reshape(-1, 2)
    if not len(gaps):
        return ""
    dr = np.asarray(spec.dr, dtype=float)
    dr = dr[dr > 0]
    parts = []
    for lo, hi in gaps:
        below, above = dr[dr <= lo], dr[dr >= hi]
        around = (f"between its bins at {below.max():.4g} and {above.min():.4g} "
                  f"{spec.unit_str} G is taken as a power law" if below.size and above.size
                  else "G is continued beyond its bins there")
        parts.append(f"{lo:.4g}-{hi:.4g} {spec.unit_str} (no measurement covers it: "
                     f"{around})")
    return f"G is not measured over dr = {', '.join(parts)}: {depends}"


#: What a ``_std`` of a result (a fit's parameters, a contact prediction) is the error of,
#: where G states its map geometry (:func:`error_model`).
ERROR_OF_SURFACE = (
    "the surface: the scatter between maps of the same size of a Gaussian surface with "
    "the spectrum of G (finite-area errors of G with their covariance between bins, "
    "propagated linearly), raised to the scatter between the map's four quarters where "
    "they disagree beyond it (G's coordinate error_inflation); the theory's own error "
    "(Persson's against the solver) is not included")
#: ... and where it does not (a stitched or model G).
#: ... and where none is computed: G states no map geometry.
ERROR_OF_NONE = ("none: G states no map geometry (lag_geometry, scan_size, pixel_size) for "
                 "the covariance of its bins, e.g. a stitched or model G")


ERROR_OF_BINS = ("G's bins taken as independent, with their standard_error: G states no "
                 "map geometry (lag_geometry, scan_size, pixel_size) for their covariance")


#: Coordinate of G: the factor by which its ``standard_error`` exceeds the Gaussian
#: finite-area error, where the regions of the map disagree (``correlation._regions``).
INFLATION = "error_inflation"


def bin_error(G: xr.DataArray) -> xr.DataArray:
    """Return G's ``standard_error`` as a weight of its bins against each other.

    Where the regions of the map disagree, ``standard_error`` is their scatter: the
    G of one region lies above another's over a range of lags at once, which widens the
    error of every result (through :func:`error_model`) but says nothing of how one bin
    scatters about its neighbours. The weights of the fits and the smoothing of G's
    derivatives take the finite-area error, ``standard_error`` over :data:`INFLATION`,
    so that the regions change the errors of results, not their values.

    Examples
    --------
    >>> import xarray as xr
    >>> G = xr.DataArray([1.0, 2.0], dims="dr", coords={
    ...     "standard_error": ("dr", [0.2, 0.8], {"units": "nm2"}),
    ...     "error_inflation": ("dr", [2.0, 4.0])})
    >>> bin_error(G).values.tolist(), bin_error(G).attrs["units"]
    ([0.1, 0.2], 'nm2')
    """
    se = G.coords["standard_error"]
    if INFLATION not in G.coords:
        return se
    return (se / G.coords[INFLATION]).assign_attrs(se.attrs).reset_coords(drop=True)


def error_model(G: xr.DataArray) -> dict | None:
    """Return the map geometry the finite-area errors of G need, or None when G has none.

    From G's attrs: ``lag_geometry``, ``scan_size`` and ``pixel_size`` (in the unit of
    ``dr``, as the estimator wrote them) and ``pooled_count`` (maps pooled into G): the
    keywords of :func:`xrough._kernels.uncertainty.relative_covariance` but one, the
    factor of the regions, which each curve has its own (:func:`inflation_of`).  A
    stitched or model G states none.
    """
    geometry = G.attrs.get("lag_geometry")
    size, pixel = G.attrs.get("scan_size"), G.attrs.get("pixel_size")
    if geometry is None or size is None or pixel is None:
        return None  # no map geometry: a stitched or model G
    if geometry not in ("radial", "axis", "profile"):
        raise ValueError(f"G's attrs: lag_geometry {geometry!r} is none of 'radial', "
                         "'axis', 'profile' (the map geometry of its errors)")
    n_maps = G.attrs.get("pooled_count", 1)
    try:
        size_f, pixel_f, maps = float(size), float(pixel), float(n_maps)
    except (TypeError, ValueError):
        raise ValueError(f"G's attrs: scan_size {size!r}, pixel_size {pixel!r} and "
                         f"pooled_count {n_maps!r} must be numbers (the map geometry of "
                         "its errors)") from None
    if not (np.isfinite(size_f) and np.isfinite(pixel_f) and 0 < pixel_f <= size_f):
        raise ValueError(f"G's attrs: scan_size {size!r} and pixel_size {pixel!r} must be "
                         "finite, positive, the pixel not above the scan (the map geometry "
                         "of its errors); a G with no geometry has neither attr")
    if not (maps >= 1 and float(maps).is_integer()):
        raise ValueError(f"G's attrs: pooled_count {n_maps!r} must be a whole number of "
                         "maps, at least 1")
    return {"size": size_f, "pixel": pixel_f, "geometry": geometry, "n_maps": int(maps)}


def inflation_of(G: xr.DataArray) -> xr.DataArray | None:
    """Return G's :data:`INFLATION` per curve (dims of G, ``dr`` last), or None.

    The factor by which the regions of each map raise the errors of G's bins: an input
    of every kernel that propagates G's covariance (the keyword ``inflation`` of
    :func:`xrough._kernels.uncertainty.relative_covariance`), curve by curve and lazy
    where G is.
    """
    if INFLATION not in G.coords:
        return None
    k = G.coords[INFLATION].broadcast_like(G).transpose(..., "dr")
    return k.reset_coords(drop=True).drop_vars("dr", errors="ignore")


def lag_coord(values: np.ndarray, unit: str, *, name: str = "dr",
              long_name: str = "lag distance") -> dict:
    """Build the coordinate of lags (or patch radii) in ``unit``, ready for ``coords=``."""
    return {name: (name, np.asarray(values, dtype=float),
                   {"units": unit, "long_name": long_name})}


def with_coord_attrs(result, *sources):
    """Return ``result`` with the attrs xarray dropped from its coordinates put back.

    Where ``keep_attrs`` is off (``apply_ufunc(keep_attrs=False)``, arithmetic inside
    :func:`xrough.contact.own_attrs`) xarray drops the attrs of coordinates too, so a
    result's ``dr`` or ``height_variance`` came out without units. A coordinate of
    ``result`` with no attrs takes those of the coordinate of the same name in the first
    of ``sources`` (xarray objects, or mappings of a name to its attrs) that has some.

    Examples
    --------
    >>> import xarray as xr
    >>> G = xr.DataArray([1.0], dims="dr", coords={"dr": ("dr", [1.0], {"units": "nm"})})
    >>> bare = G.copy()
    >>> bare["dr"].attrs = {}
    >>> with_coord_attrs(bare, G).dr.attrs
    {'units': 'nm'}
    """
    restored = {}
    for name, coord in result.coords.items():
        if coord.attrs:
            continue
        for source in sources:
            attrs = (source.get(name) if isinstance(source, dict) else
                     source.coords[name].attrs if name in getattr(source, "coords", {})
                     else None)
            if attrs:
                var = coord.variable.copy(deep=False)
                var.attrs = dict(attrs)
                restored[name] = var
                break
    return result.assign_coords(restored) if restored else result


def result_attrs(source: xr.DataArray | xr.Dataset | dict | None, /, **attrs) -> dict:
    """Attrs of a result: the provenance of ``source``, the result's own attrs, the version.

    Parameters
    ----------
    source : DataArray, Dataset or dict of attrs, optional
        The input (topography or G) whose :data:`PROVENANCE` attrs are carried forward.
    **attrs
        The result's own attrs (units, long_name, equation, parameters); they take
        precedence over the provenance.

    Returns
    -------
    dict
        NetCDF-legal attrs (str, numbers), with ``xrough_version``.

    Examples
    --------
    >>> import xarray as xr
    >>> topo = xr.DataArray([0.0], attrs={"source_file": "scan.x3p", "units": "nm"})
    >>> attrs = result_attrs(topo, units="nm2", long_name="G")
    >>> attrs["source_file"], attrs["units"], "xrough_version" in attrs
    ('scan.x3p', 'nm2', True)
    """
    given = source if isinstance(source, dict) else getattr(source, "attrs", {}) or {}
    out = {k: given[k] for k in PROVENANCE if k in given}
    out.update(attrs)
    out["xrough_version"] = __version__
    return out


def strip_marks(da: xr.DataArray) -> xr.DataArray:
    """``da`` without its per-bin coords (pair counts, errors) and with dr whole per chunk."""
    da = da.drop_vars([c for c in da.coords if c != "dr" and "dr" in da[c].dims])
    return da.chunk({"dr": -1}) if da.chunks is not None else da
