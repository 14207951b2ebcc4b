r"""One G(dr) over many decades from several instruments (stitching).

Each instrument resolves G only inside its reliability window: above a few pixels (or its
lateral resolution, or the cutoff of the tip its file states, as ``acf()`` applies it)
and below a fraction of its scan size. Measurements of one
surface by several instruments (TEM profiles, AFM maps, stylus profiles...) cover
different windows; stitching brings their G to one length unit and one log grid of lag
bins and combines them where they overlap.

:func:`stitch_curves`
    G of every measurement (in parallel on the active dask scheduler: threads, or a
    ``dask.distributed`` Client when one exists), restricted to its window, re-binned onto
    the common log grid: a :class:`xarray.Dataset` on ``(measurement, dr)``, NaN outside
    each window.
:func:`stitch_mismatch`
    For every pair of measurements that overlap, the ratio of their G over the overlap and
    its significance; :class:`StitchingMismatchWarning` flags a significant disagreement
    (calibration, tip convolution, detrending).
:func:`stitch`
    The stitched G: inverse-variance weighted combination of the curves (each first
    levelled so that no step remains at a seam, :func:`level_factors`), a ``G``
    DataArray that feeds :func:`xrough.fit_acf` and :func:`xrough.persson` directly.

>>> import xrough
>>> topo = xrough.self_affine_surface(hurst=0.7, lambda_r="2 um", lambda_s="20 nm",
...                                   size="8 um", n=1024, rms_height="10 nm",
...                                   profile=True, seed=3, unit="nm")
>>> fine = topo.isel(x=slice(0, 256)).assign_attrs(periodic=0)  # a crop is not periodic
>>> coarse = topo.isel(x=slice(None, None, 4))
>>> from xrough.stitching import stitch
>>> G = stitch({"fine": fine, "coarse": coarse}, points_per_decade=5)
>>> G.name, G.attrs["units"], G.attrs["stitched_from"]
('G', 'nm2', 'fine, coarse')
>>> int(G.n_measurements.max())
2
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from . import quality
from . import units as u
from ._kernels.binning import check_points_per_decade, log_bin_edges, log_bins
from ._kernels.checks import require_positive
from ._kernels.deferred import dask
from ._kernels.deferred import dask_array as dsa
from .acf import check_acf, result_attrs
from .correlation import height_difference_acf
from .preprocess import TIP_SAFETY_FACTOR, reliability_window, stated_tip_radius, tip_cutoff
from .topography import grid_of

if TYPE_CHECKING:
    from pint.facets.plain import PlainUnit

__all__ = [
    "STITCH_DIAGNOSTICS",
    "LevelFactorWarning",
    "StitchingGapWarning",
    "StitchingMismatchWarning",
    "level_factors",
    "stitch",
    "stitch_curves",
    "stitch_mismatch",
]

#: Default short cutoff of a measurement without a recorded window, in pixels.
DEFAULT_MIN_PIXELS = 4.0
#: Default long cutoff of a measurement without a recorded window, as a fraction of the
#: scan size (a quarter: G of an open, detrended scan is biased low near its size).
DEFAULT_LONG_FRACTION = 0.25


#: Width of the stretch of overlap, from its short end, over which a measurement's level
#: factor is fitted (:func:`level_factors`), in decades of lag.
LEVEL_DECADES = 0.2


#: Attrs of a stitched G that its values decide: on a lazy (dask) stitch they are not known
#: before compute and left out (its verdict is the lazy ``quality_flag`` coordinate);
#: :func:`stitch_curves` with :func:`level_factors` and :func:`stitch_mismatch` give them.
STITCH_DIAGNOSTICS = ("mismatch_pairs", "mismatch_ratio", "mismatch_z", "level_factors",
                      "level_factor_errors", "quality", "quality_notes")


#: Largest level factor of G (and smallest, its inverse) that :func:`stitch` applies
#: without a warning: a factor 2 in G is a factor 1.41 in heights, far beyond the
#: calibration error of an AFM, TEM or stylus (a few %), and beyond the level scatter of
#: one scan of a self-affine surface unless the scan is barely larger than its window.
LEVEL_FACTOR_BOUND = 2.0


class StitchingMismatchWarning(UserWarning):
    """Two measurements give significantly different G where their windows overlap."""


class LevelFactorWarning(StitchingMismatchWarning):
    """A level factor that the errors of G do not explain, or beyond ``LEVEL_FACTOR_BOUND``.

    A subclass of :class:`StitchingMismatchWarning`: filtering that one filters this one.
    """


class StitchingGapWarning(UserWarning):
    """Lags between the windows of the measurements that no measurement covers."""


# ------------------------------------------------------------------------------- inputs


def _as_mapping(measurements: Any) -> dict[str, xr.DataArray]:
    if isinstance(measurements, xr.Dataset):
        items = {str(k): v for k, v in measurements.data_vars.items()}
    elif isinstance(measurements, xr.DataTree):
        items = {}
        for node in measurements.subtree:  # named by their node; "node/var" for several
            variables = node.dataset.data_vars
            path = node.path.strip("/")
            for name, var in variables.items():
                items[path if path and len(variables) == 1 else
                      f"{path}/{name}".strip("/")] = var
    elif isinstance(measurements, Mapping):
        items = {str(k): v for k, v in measurements.items()}
    else:
        raise TypeError("measurements must be a mapping name -> DataArray, an xarray.Dataset "
                        f"or an xarray.DataTree, got {type(measurements).__name__}")
    if not items:
        raise ValueError("no measurements to stitch")
    for name, da in items.items():
        if not isinstance(da, xr.DataArray):
            raise TypeError(f"measurement {name!r} is a {type(da).__name__}, not a DataArray")
    return items


def _is_acf(da: xr.DataArray) -> bool:
    return "dr" in da.dims


def _lateral_unit(da: xr.DataArray) -> str:
    """Return the unit of the lags of a G, or the lateral unit of a topography (its Grid's)."""
    if not _is_acf(da):
        return grid_of(da, what="measurement").lateral_unit
    return u.format_units(u.as_length_unit(u.units_of(da.coords["dr"], what="coordinate 'dr'"),
                                           what="coordinate 'dr'"))


def _height_unit(da: xr.DataArray) -> str:
    unit: PlainUnit = u.units_of(da, what="heights")
    if _is_acf(da):
        unit = unit**0.5
    return u.format_units(u.as_length_unit(unit, what="heights"))


def _require_curve(name: str, da: xr.DataArray) -> None:
    """Refuse a G that has nothing to stitch (it was dropped without a word), or no G.

    Fewer than two lags, or (computed) a G that breaks the rules of :mod:`xrough.acf`
    (an infinite value, wrong units) or has fewer than two finite, positive values at
    positive lags.
    """
    if da.sizes["dr"] < 2:
        raise ValueError(f"measurement {name!r}: its G has {da.sizes['dr']} lag(s); "
                         "stitching needs at least two")
    if _is_lazy(da):
        return
    check_acf(da, what=f"measurement {name!r}: its G")  # inf, units, ... (xrough.acf)
    values, dr = np.asarray(da.values, dtype=float), np.asarray(da["dr"].values, dtype=float)
    usable = np.isfinite(values) & (values > 0) & (dr > 0)
    if np.count_nonzero(usable) < 2:
        what = ("all NaN" if np.all(np.isnan(values)) else
                "not positive" if np.all(values[np.isfinite(values)] <= 0) else
                "one usable lag")
        raise ValueError(f"measurement {name!r}: its G is {what} (fewer than two finite, "
                         "positive values at positive lags): nothing to stitch")


def _window_of(name: str, da: xr.DataArray, override, lunit: str, min_pixels: float,
               long_fraction: float, *, tips: bool = True) -> tuple:
    """Window of one measurement in its own lateral unit, with the rule that set it.

    Returns ``(dr_min, dr_max, rule, said)``. ``said`` may hold a ``"remark"`` (the short
    end raised by a stated tip, or a stated tip not applied to a lazy map) and
    ``"left_out"`` (why the measurement is left out: its stated tip resolves no lag of its
    window; ``dr_min`` and ``dr_max`` are then ``None``). See :func:`_stated_tip_limit`.
    """
    lo, hi = reliability_window(da) if ("x" in da.coords or "dr" in da.coords) else (None,
                                                                                    None)
    recorded_lo = lo is not None
    rule_lo = rule_hi = "reliable_dr (recorded)"
    if _is_acf(da):  # checked by stitch_curves (_require_curve)
        pixel = da.attrs.get("pixel_size", float(da.dr.min()))
        scan = da.attrs.get("scan_size")
    else:
        grid = grid_of(da, what=f"measurement {name!r}")
        pixel = max(grid.spacing)
        scan = min(n * d for n, d in zip(grid.shape, grid.spacing))
    if lo is None:
        lo, rule_lo = min_pixels * pixel, f"{min_pixels:g} pixels of {pixel:g} {lunit}"
    if hi is None:
        if scan is None:
            hi, rule_hi = float(da.dr.max()), "largest lag of G"
        else:
            hi, rule_hi = long_fraction * scan, f"{long_fraction:g} x scan size {scan:g} {lunit}"
    if override is not None:
        if not isinstance(override, (tuple, list)) or len(override) != 2:
            raise ValueError(f"windows[{name!r}] must be a pair (dr_min, dr_max), got "
                             f"{override!r}")
        if override[1] is not None:
            hi = u.length_in(override[1], lunit, what=f"windows[{name!r}][1]")
            rule_hi = "windows= override"
    said: dict[str, str] = {}
    # a topography without a recorded short end whose metadata state a tip: the tip rule
    # sets it, as acf() does by default (reliable=True; xrough.preprocess.tip_window)
    stated = (None if recorded_lo or _is_acf(da) or not tips
              else stated_tip_radius(da.attrs))
    given_lo = override is not None and override[0] is not None
    if stated is not None and given_lo:
        rule_lo = (f"windows= override (the tip radius {stated[0]} stated in the file, attr "
                   f"{stated[1]!r}, not applied)")
    elif stated is not None:
        lo, rule_lo, said = _stated_tip_limit(
            name, da, stated, lo=lo, rule_lo=rule_lo, hi=hi, rule_hi=rule_hi, lunit=lunit,
            min_pixels=min_pixels, long_fraction=long_fraction,
            override=override is not None)
        if "left_out" in said:
            return None, None, "", said
    if given_lo:
        lo = u.length_in(override[0], lunit, what=f"windows[{name!r}][0]")
        if stated is None:
            rule_lo = "windows= override"
    if not 0 < lo < hi:
        raise ValueError(f"measurement {name!r}: empty window dr_min={lo:g} >= dr_max={hi:g} "
                         f"{lunit} ({rule_lo}; {rule_hi})")
    return float(lo), float(hi), f"dr_min: {rule_lo}; dr_max: {rule_hi}", said


def _stated_tip_limit(name: str, da: xr.DataArray, stated: tuple[str, str], *, lo: float,
                      rule_lo: str, hi: float, rule_hi: str, lunit: str, min_pixels: float,
                      long_fraction: float, override: bool) -> tuple:
    """Short end of the window of a topography whose metadata state a tip radius.

    The tip rule of :func:`xrough.reliable` (the cutoff of :func:`xrough.preprocess.
    tip_window`, which :func:`xrough.height_difference_acf` applies by default) on the map,
    against the default short end ``lo``: the larger of the two. Returns ``(dr_min, rule,
    said)`` (see :func:`_window_of`): a remark where the tip raised the short end; where
    the cutoff is not below ``hi`` the measurement is left out (``"left_out"``), unless
    ``windows=`` names it (``override``): then a ValueError asks for its ``dr_min``. A lazy
    (dask) map keeps ``lo``, with a remark that the tip was not applied.
    """
    radius, key = stated
    said_tip = f"the tip radius {radius} stated in the file (attr {key!r})"
    if _is_lazy(da):
        return lo, f"{rule_lo} ({said_tip} not applied: lazy map)", {"remark": (
            f"{name!r}: {said_tip} is not applied: the map is lazy (dask) and the tip rule "
            "reads all of it, while the window must be known before compute; its window "
            f"starts at {lo:.4g} {lunit} ({rule_lo}). To apply the tip, record the window "
            f"first: xrough.reliable(topography, tip_radius={radius!r}, "
            f"min_pixels={min_pixels:g}, long_fraction={long_fraction:g}) (this computes the "
            "map)")}
    cut, _ = tip_cutoff(da, grid_of(da), u.length_in(radius, lunit, what=f"attr {key!r}"),
                         TIP_SAFETY_FACTOR)
    if cut is None:
        return lo, f"{rule_lo} ({said_tip} follows every scale of the map)", {}
    if cut <= lo:
        return lo, f"{rule_lo} (above the cutoff {cut:.4g} {lunit} of {said_tip})", {}
    rule = (f"tip rule (xrough.reliable, curvature above -{TIP_SAFETY_FACTOR:g}/R) of "
            f"{said_tip}: cutoff {cut:.4g} {lunit}")
    if cut >= hi:
        why = (f"{said_tip} resolves no lag of its window: the cutoff of the tip rule, "
               f"{cut:.4g} {lunit}, is not below the window's long end {hi:.4g} {lunit} "
               f"({rule_hi})")
        if override:
            raise ValueError(f"measurement {name!r}: {why}; give windows[{name!r}] a dr_min "
                             "to stitch it")
        return None, rule, {"left_out": (
            f"measurement {name!r} left out of the stitch: {why}: its G at every lag is "
            f"shaped by the tip, not the surface; windows={{{name!r}: (dr_min, dr_max)}} "
            "stitches it in a window of your choice, reliable=False every measurement as "
            "measured")}
    return cut, rule, {"remark": (
        f"{name!r}: G from {cut:.4g} {lunit}, not from {lo:.4g} {lunit} ({rule_lo}): "
        f"{said_tip} resolves no finer lag (tip rule of xrough.reliable, as acf() applies "
        "it)")}


# ------------------------------------------------------------------------------ re-bin


def _rebin(dr, g, se, n, centres, edges, lo, hi):
    """Re-bin one G onto the common bins: pair-weighted, then moved to the bin centres.

    Bins of the measurement whose lag falls into a common bin are combined with pair-count
    weights (G, lag and standard error alike: the errors of neighbouring bins of one
    measurement are strongly correlated, so the error is averaged, not reduced). The value
    at the pair-weighted lag is moved to the bin centre along the local log-log slope of
    the measurement's own curve. Bins whose centre lies outside ``[lo, hi]`` are NaN.
    """
    nb = len(centres)
    ok = np.isfinite(g) & (n > 0) & (dr >= lo) & (dr <= hi)
    se = np.where(np.isfinite(se) & (se > 0), se, np.abs(g) / np.sqrt(np.maximum(n, 1)))
    idx = np.searchsorted(edges, dr[ok], side="right") - 1
    inside = (idx >= 0) & (idx < nb)
    idx, w = idx[inside], n[ok][inside]
    W = np.bincount(idx, w, nb)
    has = W > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        gb = np.bincount(idx, w * g[ok][inside], nb) / W
        drb = np.bincount(idx, w * dr[ok][inside], nb) / W
        seb = np.bincount(idx, w * se[ok][inside], nb) / W
    has &= gb > 0
    out_g = np.full(nb, np.nan)
    out_se = np.full(nb, np.nan)
    if has.sum() >= 1:
        x, y = np.log(drb[has]), np.log(gb[has])
        slope = np.gradient(y, x) if has.sum() >= 2 else np.zeros(1)
        shift = np.exp(slope * (np.log(centres[has]) - x))
        out_g[has], out_se[has] = gb[has] * shift, seb[has] * shift
    keep = has & (centres >= lo) & (centres <= hi)
    out_g[~keep] = np.nan
    out_se[~keep] = np.nan
    return out_g, out_se, np.where(keep, W, 0.0)


def _rebin_packed(curve, *, dr, centres, edges, lo, hi, g_factor):
    """Re-bin one curve (:func:`_rebin`) onto the common bins, as one ``(3, nb)`` array.

    ``curve`` is ``(3, n)``: G, its standard error and the pair count; G and its error are
    multiplied by ``g_factor`` (to the common height unit squared).
    """
    g, se, n = np.asarray(curve, dtype=float)
    return np.stack(_rebin(dr, g * g_factor, se * g_factor, n, centres, edges, lo, hi))


def _is_lazy(da: xr.DataArray) -> bool:
    """Whether the data of a measurement (or of a precomputed G's error coords) is dask."""
    return da.chunks is not None or any(
        da.coords[c].chunks is not None for c in ("standard_error", "pair_count")
        if c in da.coords)


def _curve(name: str, da: xr.DataArray, own_edges: np.ndarray, *, chunk: bool,
           acf_kwargs: dict) -> tuple:
    """G of one measurement on its own lags: ``(dr, G, standard error, pair count, attrs)``.

    ``dr`` is numpy (the lags are known before any data is read), the others numpy or
    dask (lazy where the measurement is, or where ``chunk`` asks that a topography in
    memory be computed in the one graph of all measurements).
    """
    if _is_acf(da):
        if da.ndim != 1:
            raise ValueError(f"measurement {name!r}: G has dims {da.dims} beyond 'dr'; "
                             "select or pool them first")
        se = (da.coords["standard_error"].data if "standard_error" in da.coords
              else np.full(da.shape, np.nan))
        cnt = da.coords["pair_count"].data if "pair_count" in da.coords else np.ones(da.shape)
        return np.asarray(da.dr.values, dtype=float), da.data, se, cnt, dict(da.attrs)
    grid = grid_of(da, what=f"measurement {name!r}")
    extra = tuple(str(d) for d in da.dims if d not in grid.dims)
    if chunk and da.chunks is None:  # a graph of its own, one map per chunk
        da = da.chunk({d: (1 if d in extra else -1) for d in da.dims})
    G = height_difference_acf(da, bins=own_edges, pool=extra or None, **acf_kwargs)
    return (np.asarray(G.dr.values, dtype=float), G.data, G.standard_error.data,
            G.pair_count.data, dict(G.attrs))


@u.accepts_quantified
def stitch_curves(
    measurements: Any,
    *,
    points_per_decade: float = 10,
    windows: Mapping[str, tuple] | None = None,
    unit: str | None = None,
    height_unit: str | None = None,
    min_pixels: float = DEFAULT_MIN_PIXELS,
    long_fraction: float = DEFAULT_LONG_FRACTION,
    parallel: bool = True,
    **acf_kwargs,
) -> xr.Dataset:
    r"""Per-measurement G on a common log grid of lags, each inside its reliable window.

    G of a topography is computed on the common bin edges (in its lateral unit, clipped
    to its window); a precomputed G is re-binned with pair-count weights; each value is
    moved to the bin centre along the curve's local log-log slope. Notes (windows,
    stated tips, re-binning): docs/stitching.md, "Windows" and "Common grid and
    re-binning".

    Parameters
    ----------
    measurements : mapping of str to xarray.DataArray, xarray.Dataset or xarray.DataTree
        Topographies (maps and profiles mixed, each on its own grid and in its own units;
        extra dims such as ``scan`` are pooled into one G) or already computed G (dim
        ``dr``). Measurements on different grids go in a dict or a DataTree (one node
        each, named by the node: ``"afm"``; ``"afm/h"`` for a node of several variables).
    points_per_decade : float
        Common log bins, centred on ``10**(k / points_per_decade)`` in ``unit``.
    windows : mapping of str to (dr_min, dr_max), optional
        Per-measurement window overriding the recorded, stated-tip or default one (numbers
        in the measurement's lateral unit, or strings/Quantities; ``None`` keeps a limit).
    unit, height_unit : str, optional
        Common lateral and height units (default: those of the first measurement).
    min_pixels : float
        Default short cutoff, in pixels, for measurements without ``reliable_dr_min``.
    long_fraction : float
        Default long cutoff, as a fraction of the (shorter) scan size, for measurements
        without ``reliable_dr_max``.
    parallel : bool
        Compute the G of several topographies in parallel threads (dask.delayed).
    **acf_kwargs
        Passed to :func:`xrough.height_difference_acf`; not ``bins``, ``dr_min``,
        ``dr_max`` or ``pool``. ``reliable=False`` ignores stated tip radii.

    Returns
    -------
    xarray.Dataset
        ``G``, ``standard_error`` (height unit squared) and ``pair_count`` on
        ``(measurement, dr)``, NaN (count 0) outside each window; coords ``dr_min``,
        ``dr_max`` and ``window_rule`` per measurement; attrs ``window_rules``,
        ``left_out`` (measurements whose stated tip resolves no lag; then ``quality``
        questionable, with ``quality_notes``) and ``quality_remarks``.

    Raises
    ------
    ValueError
        An empty window, windows for unknown measurements, disallowed ``acf_kwargs``,
        every measurement left out.
    TypeError
        Measurements that are not DataArrays.

    Warns
    -----
    xrough.QualityWarning
        Once per measurement left out (its name, the stated tip radius and why).

    See Also
    --------
    stitch : combine these curves into one G.
    stitch_mismatch : their disagreement where they overlap.
    """
    items = _as_mapping(measurements)
    for name, da in items.items():  # a G that is no G, named before any unit is read
        if _is_acf(da):
            _require_curve(name, da)
    windows = _checked_windows(windows, items, acf_kwargs)
    first = next(iter(items.values()))
    lunit = unit or _lateral_unit(first)
    hunit = height_unit or _height_unit(first)
    u.as_length_unit(lunit, what="unit")
    u.as_length_unit(hunit, what="height_unit")
    ppd = check_points_per_decade(points_per_decade)
    tips = bool(acf_kwargs.pop("reliable", True))  # the tip windows are set here, once
    plans = {name: _plan_measurement(name, da, windows.get(name), lunit, hunit, min_pixels,
                                     long_fraction, tips) for name, da in items.items()}
    left_out = {n: p["said"]["left_out"] for n, p in plans.items() if "left_out" in p["said"]}
    if len(left_out) == len(plans):
        raise ValueError("every measurement is left out of the stitch: "
                         + "; ".join(left_out.values()))
    plans = {n: p for n, p in plans.items() if n not in left_out}
    items = {n: da for n, da in items.items() if n not in left_out}
    acf_kwargs = {**acf_kwargs, "reliable": False}
    centres, edges = log_bins(min(p["lo"] for p in plans.values()),
                              max(p["hi"] for p in plans.values()), ppd)
    # one graph for all measurements: lazy where any input is, else computed at once
    # (in parallel threads, or on a dask.distributed Client when one is active)
    lazy = any(_is_lazy(da) for da in items.values())
    in_graph = lazy or (parallel and sum(not _is_acf(da) for da in items.values()) > 1)
    rows, meta = [], []
    for name, da in items.items():
        row, attrs = _measurement_row(name, da, plans[name], centres, edges, ppd,
                                      in_graph=in_graph, acf_kwargs=acf_kwargs)
        rows.append(row)
        meta.append(_measurement_meta(name, da, attrs, plans[name]["f"]))
    packed = (dsa.stack if in_graph else np.stack)(rows, axis=1)  # (3, measurement, dr)
    ds = _curves_dataset(packed, centres, plans, meta, lunit=lunit, hunit=hunit, ppd=ppd)
    ds = _tip_findings(ds, left_out, [p["said"]["remark"] for p in plans.values()
                                      if "remark" in p["said"]])
    return ds.compute() if in_graph and not lazy else ds


def _tip_findings(ds: xr.Dataset, left_out: dict[str, str], remarks: list[str]) -> xr.Dataset:
    """Record what the stated tips did on the curves.

    ``attrs["left_out"]`` (names), ``quality_remarks`` (windows raised by a tip, tips not
    applied to lazy maps) and, for each measurement left out, a questionable mark with its
    note and one :class:`xrough.QualityWarning` naming it, its tip radius and why.
    """
    ds.attrs["left_out"] = ", ".join(left_out)
    for note in left_out.values():
        ds = quality.mark(ds, note, what="stitch_curves")
    if remarks:
        ds.attrs["quality_remarks"] = _joined(ds.attrs.get("quality_remarks", ""), remarks)
    return ds


def _joined(old: str, new: list[str]) -> str:
    """``"; "``-join the notes ``new`` onto ``old``, each once."""
    parts = [n for n in str(old).split(quality.SEPARATOR) if n]
    return quality.SEPARATOR.join(parts + [n for n in new if n and n not in parts])


def _checked_windows(windows, items: dict, acf_kwargs: dict) -> dict:
    """Check the ``windows`` of :func:`stitch_curves` and return them as a dict.

    Refuses windows of unknown measurements and ACF options that stitching sets itself.
    """
    windows = dict(windows or {})
    unknown = set(windows) - set(items)
    if unknown:
        raise ValueError(f"windows given for unknown measurements {sorted(unknown)}; "
                         f"known: {list(items)}")
    for key in ("bins", "dr_min", "dr_max", "pool", "points_per_decade"):
        if key in acf_kwargs:
            raise ValueError(f"{key!r} is set by stitching; use windows= to restrict lags")
    return windows


def _plan_measurement(name: str, da: xr.DataArray, override, lunit: str, hunit: str,
                      min_pixels: float, long_fraction: float, tips: bool = True) -> dict:
    """Window of one measurement in the common unit, with the factors to reach it.

    ``f`` converts its lags to ``lunit``, ``g_factor`` its G to ``hunit`` squared; ``lo``
    and ``hi`` are its window in ``lunit`` and ``rule`` says what set them; ``said`` what
    a stated tip did (:func:`_window_of`: a ``"remark"``, or ``"left_out"`` when the
    measurement is left out, and then no window).
    """
    own = _lateral_unit(da)
    lo, hi, rule, said = _window_of(name, da, override, own, min_pixels, long_fraction,
                                    tips=tips)
    if lo is None:
        return dict(said=said)
    f = u.conversion_factor(own, lunit)
    return dict(f=f, lo=lo * f, hi=hi * f, rule=rule, said=said,
                g_factor=u.conversion_factor(_height_unit(da), hunit) ** 2)


def _measurement_row(name: str, da: xr.DataArray, plan: dict, centres: np.ndarray,
                     edges: np.ndarray, ppd: float, *, in_graph: bool, acf_kwargs: dict):
    """G, standard error and pair count of one measurement on the common bins.

    Returns a ``(3, len(centres))`` array (dask when ``in_graph``) and the attrs of its G.
    """
    own_edges = log_bin_edges(plan["lo"], plan["hi"], ppd) / plan["f"]
    dr, gm, sem, nm, attrs = _curve(name, da, own_edges, chunk=in_graph,
                                    acf_kwargs=acf_kwargs)
    rebin = dict(dr=dr * plan["f"], centres=centres, edges=edges, lo=plan["lo"],
                 hi=plan["hi"], g_factor=plan["g_factor"])
    if not in_graph:
        return _rebin_packed(np.stack([gm, sem, nm]).astype(float), **rebin), attrs
    # one array (one collection: G and its errors share their graph)
    curve = dsa.stack([dsa.asarray(x).astype(float) for x in (gm, sem, nm)])
    return curve.rechunk(-1).map_blocks(_rebin_packed, **rebin, chunks=((3,), (len(centres),)),
                                        dtype=float, meta=np.empty((0, 0))), attrs


def _measurement_meta(name: str, da: xr.DataArray, attrs: dict, f: float) -> dict:
    """Describe one measurement as the curves record it.

    Its source, checksum, pixel and scan size (in the common unit, ``f`` times its own)
    and kind.
    """
    kind = "G" if _is_acf(da) else ("map" if len(grid_of(da).dims) == 2 else "profile")
    return {"source": str(attrs.get("source_file", attrs.get("source", "")) or name),
            "source_sha256": str(attrs.get("source_sha256", "")),
            "pixel_size": float(attrs.get("pixel_size", np.nan)) * f,
            "scan_size": float(attrs.get("scan_size", np.nan)) * f,
            "kind": kind}


def _curves_dataset(packed, centres: np.ndarray, plans: dict, meta: list[dict], *,
                    lunit: str, hunit: str, ppd: float) -> xr.Dataset:
    """Build the Dataset of :func:`stitch_curves` from packed ``(3, measurement, dr)`` rows."""
    names = list(plans)
    g, se, cnt = packed[0], packed[1], packed[2].astype(np.int64)
    gunits = u.power_units(hunit, 2)
    dims = ("measurement", "dr")

    def per_measurement(key, attrs=None):
        values = [plans[n][key] for n in names] if key in ("lo", "hi") else [
            m[key] for m in meta]
        return ("measurement", values, attrs or {})

    return xr.Dataset(
        {"G": (dims, g, {"units": gunits, "long_name": "height-difference ACF",
                         "symbol": "G"}),
         "standard_error": (dims, se, {"units": gunits, "long_name": "standard error of G"}),
         "pair_count": (dims, cnt, {"units": "1", "long_name": "number of point pairs"})},
        coords={"measurement": ("measurement", names),
                "dr": ("dr", centres, {"units": lunit, "long_name": "lag distance"}),
                "dr_min": per_measurement("lo", {
                    "units": lunit, "long_name": "short end of the reliable window"}),
                "dr_max": per_measurement("hi", {
                    "units": lunit, "long_name": "long end of the reliable window"}),
                "pixel_size": per_measurement("pixel_size", {
                    "units": lunit, "long_name": "pixel size of the measurement"}),
                "scan_size": per_measurement("scan_size", {
                    "units": lunit, "long_name": "scan size of the measurement"}),
                "window_rule": ("measurement", [plans[n]["rule"] for n in names], {
                    "long_name": "what set the reliable window"}),
                "kind": per_measurement("kind"),
                "source": per_measurement("source"),
                "source_sha256": per_measurement("source_sha256", {
                    "long_name": "SHA-256 of the source file ('' if none)"})},
        attrs=result_attrs(None, points_per_decade=ppd, window_rules="; ".join(
            f"{n}: {plans[n]['rule']}" for n in names)))


# ---------------------------------------------------------------------------- mismatch


@u.accepts_quantified
def stitch_mismatch(curves: xr.Dataset, *, threshold: float = 3.0,
                    warn: bool = True) -> xr.Dataset:
    r"""Ratio of G between every pair of overlapping measurements, and its significance.

    Parameters
    ----------
    curves : xarray.Dataset
        Output of :func:`stitch_curves`.
    threshold : float
        ``|z|`` above which the two measurements are said to disagree.
    warn : bool
        Issue a :class:`StitchingMismatchWarning` for each disagreeing pair.

    Returns
    -------
    xarray.Dataset
        On dim ``pair`` (``"a/b"``, only pairs with overlapping bins), coords ``first``,
        ``second``, and variables ``n_bins`` (overlapping bins), ``log_ratio`` (weighted
        mean of ``ln(G_a / G_b)``), ``ratio`` (its exponential), ``log_ratio_error``,
        ``z`` (``log_ratio / log_ratio_error``), ``chi2`` (reduced chi^2 of the log-ratios
        against 0), ``significant`` (``|z| > threshold``) and ``dr_lo``, ``dr_hi``.

    Notes
    -----
    Per overlapping bin ``k``, :math:`r_k = \ln G_a - \ln G_b` with
    :math:`\sigma_k^2 = (s_a/G_a)^2 + (s_b/G_b)^2` from the standard errors. The mean is
    weighted by :math:`1/\sigma_k^2`. Its error assumes that the errors of one
    measurement are fully correlated across the overlap (for H > 1/2 they are dominated
    by the largest scales), :math:`\sigma_{\bar r}^2 = n / \sum_k \sigma_k^{-2}`: an
    overall factor between instruments, such as a height calibration error, shows up in
    ``ratio`` and ``z``; a changing ratio (tip convolution at the short end, detrending
    at the long end) also raises ``chi2``.
    """
    if not (isinstance(curves, xr.Dataset) and "measurement" in curves.dims):
        raise TypeError("curves must be the Dataset of xrough.stitch_curves (dim "
                        f"'measurement'), got {type(curves).__name__}"
                        + (f" with dims {curves.dims}" if hasattr(curves, "dims") else ""))
    threshold = require_positive(threshold, "threshold",
                                 meaning=" (|z| beyond which a mismatch is significant)")
    names = [str(n) for n in curves.measurement.values]
    g = curves.G.values
    rel = curves.standard_error.values / g
    dr = curves.dr.values
    rows = []
    for a, b in itertools.combinations(range(len(names)), 2):
        ok = np.isfinite(g[a]) & np.isfinite(g[b]) & (g[a] > 0) & (g[b] > 0)
        if not ok.any():
            continue
        r = np.log(g[a][ok] / g[b][ok])
        var = rel[a][ok] ** 2 + rel[b][ok] ** 2
        w = 1.0 / var
        mean = float(np.sum(w * r) / np.sum(w))
        err = float(np.sqrt(ok.sum() / np.sum(w)))
        chi2 = float(np.mean(r**2 * w))
        rows.append((f"{names[a]}/{names[b]}", names[a], names[b], int(ok.sum()), mean,
                     err, mean / err, chi2, float(dr[ok].min()), float(dr[ok].max())))
    cols: list[tuple[Any, ...]] = list(zip(*rows)) if rows else [()] * 10
    lunit = curves.dr.attrs.get("units", "")
    ds = xr.Dataset(
        {"n_bins": ("pair", np.asarray(cols[3], dtype=np.int64)),
         "log_ratio": ("pair", np.asarray(cols[4], dtype=float),
                       {"long_name": "weighted mean of ln(G_first / G_second)"}),
         "log_ratio_error": ("pair", np.asarray(cols[5], dtype=float)),
         "z": ("pair", np.asarray(cols[6], dtype=float)),
         "chi2": ("pair", np.asarray(cols[7], dtype=float),
                  {"long_name": "reduced chi^2 of the log-ratios against 0"}),
         "dr_lo": ("pair", np.asarray(cols[8], dtype=float), {"units": lunit}),
         "dr_hi": ("pair", np.asarray(cols[9], dtype=float), {"units": lunit})},
        coords={"pair": ("pair", list(cols[0])), "first": ("pair", list(cols[1])),
                "second": ("pair", list(cols[2]))},
        attrs={"threshold": threshold})
    ds["ratio"] = np.exp(ds.log_ratio).assign_attrs(long_name="G_first / G_second")
    ds["significant"] = abs(ds.z) > threshold
    if warn:
        for p in ds.pair.values[ds.significant.values]:
            row = ds.sel(pair=p)
            quality.warn(
                f"measurements {str(row.first.values)!r} and {str(row.second.values)!r} "
                f"disagree over dr = {float(row.dr_lo):.3g}-{float(row.dr_hi):.3g} {lunit}: "
                f"G ratio {float(row.ratio):.3g} (z = {float(row.z):.1f}, chi2 = "
                f"{float(row.chi2):.2g}); check height calibration, tip convolution or "
                "detrending, or narrow their windows", StitchingMismatchWarning)
    return ds


# ------------------------------------------------------------------------------ stitch


def _combine(g: np.ndarray, se: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Inverse-variance mean of ``ln G`` over the first axis (see :func:`stitch`).

    Returns ``G``, its standard error and the number of curves per bin (NaN, NaN, 0 where
    none covers it).
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        w = (g / se) ** 2
        ok = np.isfinite(w) & (w > 0) & (g > 0)
        w = np.where(ok, w, 0.0)
        W = w.sum(axis=0)
        lng = np.where(ok, np.log(np.where(ok, g, 1.0)), 0.0)
        G = np.exp((w * lng).sum(axis=0) / W)
        return G, G / np.sqrt(W), ok.sum(axis=0)


def level_factors(curves: xr.Dataset, *, with_errors: bool = False):
    r"""Factor per measurement that removes the steps between overlapping measurements.

    The measurements are taken by decreasing scan size. Each one that overlaps those
    already taken is brought to agree with their combination over the bins it shares
    with them, next to the seam (the first ``LEVEL_DECADES`` of the overlap): the
    inverse-variance mean :math:`r` of :math:`\ln G_\text{comb} - \ln G_i` (weights
    :math:`1 / ((s_i/G_i)^2 + (s_\text{comb}/G_\text{comb})^2)`) is shared between the
    two in proportion to their level variances, the mean of :math:`(s/G)^2` over those
    bins of each: :math:`G_i` is multiplied by :math:`e^{r v_i / (v_i + v_c)}` and every
    measurement joined to the combination through overlaps by
    :math:`e^{-r v_c / (v_i + v_c)}`. A precise measurement moves little, a noisy one
    much; measurements without any overlap keep factor 1. The step would otherwise turn
    into a spike of the stress ACF (eq. 24). Notes (why, the errors of the factors):
    docs/stitching.md, "Levelling".

    Parameters
    ----------
    curves : xarray.Dataset
        Output of :func:`stitch_curves`.
    with_errors : bool
        Also return the standard error of each ``ln(factor)``.

    Returns
    -------
    numpy.ndarray or tuple of numpy.ndarray
        One factor per measurement, in the order of ``curves.measurement``; with
        ``with_errors``, ``(factors, errors)``, ``errors`` the standard error of
        ``ln(factor)``: :math:`v_i / \sqrt{v_i + v_c}` per step (0 for factor 1).

    Examples
    --------
    >>> import numpy as np, xarray as xr
    >>> dr = np.array([1.0, 2.0, 4.0, 8.0])
    >>> G = np.array([[1.0, 2.0, 4.0, np.nan], [np.nan, 2.2, 4.4, 8.8]])
    >>> curves = xr.Dataset({"G": (("measurement", "dr"), G),
    ...                      "standard_error": (("measurement", "dr"), 0.05 * G)},
    ...                     coords={"measurement": ["fine", "coarse"], "dr": dr,
    ...                             "scan_size": ("measurement", [10.0, 100.0])})
    >>> level_factors(curves).round(4).tolist()  # equal errors: the step split evenly
    [1.0488, 0.9535]
    >>> f, err = level_factors(curves, with_errors=True)
    >>> err.round(4).tolist()  # v = 0.05^2 each: 0.0025 / sqrt(0.005)
    [0.0354, 0.0354]
    """
    factors, errors = _level_factors(curves.G.values, curves.standard_error.values,
                                     curves.dr.values, _scan_sizes(curves))
    return (factors, errors) if with_errors else factors


def _scan_sizes(curves: xr.Dataset) -> np.ndarray:
    """Scan size per measurement (its window's long end where the size is unknown)."""
    scan = np.asarray(curves.scan_size.values, dtype=float)
    if "dr_max" in curves.coords:
        scan = np.where(np.isfinite(scan), scan, np.asarray(curves.dr_max.values, float))
    return scan


def _level_factors(g, se, dr, scan) -> tuple[np.ndarray, np.ndarray]:
    """Level factors and the errors of their logarithms (:func:`level_factors`), numpy."""
    g = np.array(g, dtype=float)
    se = np.array(se, dtype=float)
    dr = np.asarray(dr, dtype=float)
    order = np.argsort(-np.nan_to_num(scan, nan=-np.inf), kind="stable")
    have = np.isfinite(g) & (g > 0) & (se > 0)
    factors = np.ones(g.shape[0])
    variances = np.zeros(g.shape[0])  # of ln(factor)
    groups: list[list[int]] = []  # measurements joined through overlaps
    for i in (int(k) for k in order):
        touching = [k for k, grp in enumerate(groups)
                    if any((have[j] & have[i]).any() for j in grp)]
        if not touching:
            groups.append([i])
            continue
        group = sorted(j for k in touching for j in groups[k])
        comb, comb_se, _ = _combine(g[group], se[group])
        with np.errstate(invalid="ignore", divide="ignore"):
            ok = have[i] & np.isfinite(comb)
            ok &= dr <= dr[ok].min() * 10**LEVEL_DECADES * (1 + 1e-9)  # next to the seam
            v_i = (se[i][ok] / g[i][ok]) ** 2
            v_c = (comb_se[ok] / comb[ok]) ** 2
            w = 1.0 / (v_i + v_c)
            r = float(np.sum(w * np.log(comb[ok] / g[i][ok])) / np.sum(w))
        # the step r is shared by the two level uncertainties (the errors of one
        # measurement are correlated across its lags: their mean, not divided by n)
        level_i, level_c = float(np.mean(v_i)), float(np.mean(v_c))
        share = level_i / (level_i + level_c)
        for members, part in (([i], share), (group, share - 1.0)):
            f = np.exp(r * part)
            factors[members] *= f
            variances[members] += part**2 * (level_i + level_c)
            g[members] *= f
            se[members] *= f
        groups = [grp for k, grp in enumerate(groups) if k not in touching] + [group + [i]]
    return factors, np.sqrt(variances)


def _unexplained_factors(names: list[str], factors: np.ndarray, errors: np.ndarray,
                         threshold: float) -> list[str]:
    """Say which level factors the level errors do not explain, or lie beyond the bound."""
    def told(f, err):
        return (f"x {f:.3g} (ln f = {np.log(f):+.2f} +- {err:.2f}, "
                f"{abs(np.log(f)) / err if err > 0 else 0.0:.1f} sigma)")

    found = []
    for name, f, err in zip(names, factors, errors):
        z = abs(np.log(f)) / err if err > 0 else 0.0
        beyond = not 1 / LEVEL_FACTOR_BOUND <= f <= LEVEL_FACTOR_BOUND
        if z > threshold or beyond:
            why = ([f"more than {threshold:g} sigma: the level errors of the scans do not "
                    "explain it"] if z > threshold else [])
            if beyond:
                why.append(f"outside [1/{LEVEL_FACTOR_BOUND:g}, {LEVEL_FACTOR_BOUND:g}]: "
                           f"heights rescaled by {np.sqrt(f):.2f}, beyond any height "
                           "calibration error")
            found.append(f"{name!r} {told(f, err)}, {' and '.join(why)}")
    if not found:
        return []
    others = ", ".join(f"{n!r} {told(f, e)}" for n, f, e in zip(names, factors, errors)
                       if f != 1.0)
    return [f"levelling rescaled G of {' and '.join(found)} (all factors: {others}): the "
            "instruments' height calibrations (or detrending) disagree and the level of "
            "the stitched G is a compromise between them; check the calibrations, or "
            "stitch with level=False to see the curves as measured"]


@u.accepts_quantified
def stitch(
    measurements: Any,
    *,
    points_per_decade: float = 10,
    windows: Mapping[str, tuple] | None = None,
    threshold: float = 3.0,
    warn: bool = True,
    level: bool = True,
    **kwargs,
) -> xr.DataArray:
    r"""One G(dr) over many decades from several measurements of a surface.

    In each common bin the measurements ``i`` that cover it are combined by
    inverse-variance weighting of :math:`\ln G_i`, whose variance is
    :math:`(s_i / G_i)^2` from the per-bin standard error :math:`s_i`:

    .. math::

        \ln G = \frac{\sum_i w_i \ln G_i}{\sum_i w_i}, \qquad w_i = (G_i / s_i)^2,
        \qquad s = G \Big/ \sqrt{\textstyle\sum_i w_i},

    each :math:`G_i` first multiplied by its :func:`level_factors` factor (``level=True``).
    Notes (weighting, levelling, its accuracy, mismatch, gaps): docs/stitching.md.

    Parameters
    ----------
    measurements : mapping, xarray.Dataset or xarray.DataTree
        Topographies or precomputed G by name (:func:`stitch_curves`), or its result (then
        ``points_per_decade``, ``windows`` and ``kwargs`` do not apply).
    points_per_decade : float
        Common log bins per decade.
    windows : mapping of str to (dr_min, dr_max), optional
        Per-measurement windows overriding the recorded ones (:func:`stitch_curves`).
    threshold : float
        ``|z|`` of the mismatch diagnostic above which a pair disagrees.
    warn : bool
        Issue the warnings below (the attrs record them either way).
    level : bool
        Remove the steps between overlapping measurements first (:func:`level_factors`;
        the mismatch diagnostic is computed before, on the curves as measured).
    **kwargs
        Passed to :func:`stitch_curves` (``unit``, ``min_pixels``, ``reliable``...).

    Returns
    -------
    xarray.DataArray
        ``G`` on the common ``dr`` (bins covered by no window dropped) with coords
        ``standard_error``, ``pair_count``, ``n_measurements``, ``coverage``; attrs: the
        sources, windows, level factors, mismatch summary and uncovered lags
        (docs/stitching.md, "The stitched G").

    Raises
    ------
    ValueError, TypeError
        See :func:`stitch_curves`.

    Warns
    -----
    StitchingMismatchWarning
        Two measurements disagree significantly over their overlap.
    LevelFactorWarning
        A level factor more than ``threshold`` errors from 1 or outside
        ``[1/LEVEL_FACTOR_BOUND, LEVEL_FACTOR_BOUND]``; the G is then questionable.
    StitchingGapWarning
        Lags between the windows that no measurement covers (once, naming every gap).

    See Also
    --------
    stitch_curves, stitch_mismatch, xrough.fit_acf, xrough.persson
    """
    if isinstance(measurements, xr.Dataset) and "measurement" in measurements.dims:
        curves = measurements
    else:
        curves = stitch_curves(measurements, points_per_decade=points_per_decade,
                               windows=windows, **kwargs)
    names = [str(n) for n in curves.measurement.values]
    keep = _window_bins(curves)
    gaps = _uncovered(curves, keep)
    lazy = any(curves[k].chunks is not None for k in ("G", "standard_error", "pair_count"))
    per_bin, counts, factors, code = _level_and_combine(curves, keep, level=level,
                                                        threshold=threshold, lazy=lazy)
    gunits = curves.G.attrs["units"]
    out = xr.DataArray(
        per_bin[0], dims=("dr",), name="G",
        coords={"dr": ("dr", curves.dr.values[keep], dict(curves.dr.attrs)),
                "pair_count": ("dr", counts[0], {"units": "1", "long_name":
                                                 "number of point pairs averaged"}),
                "standard_error": ("dr", per_bin[1], {"units": gunits,
                                                      "long_name": "standard error of G"}),
                "n_measurements": ("dr", counts[1], {
                    "units": "1", "long_name": "measurements combined in the bin"}),
                "coverage": ("dr", counts[2], _coverage_attrs(names))})
    diagnostics = {}
    if not lazy:  # from the values: known at once on numpy, not before compute on dask
        mism = stitch_mismatch(curves, threshold=threshold, warn=warn)
        diagnostics = {"mismatch_pairs": ", ".join(str(p) for p in mism.pair.values),
                       "mismatch_ratio": mism.ratio.values.astype(float),
                       "mismatch_z": mism.z.values.astype(float),
                       "level_factors": factors[0].astype(float),
                       "level_factor_errors": factors[1].astype(float)}
    out.attrs = _stitched_attrs(curves, level=level, diagnostics=diagnostics, gaps=gaps)
    if gaps and warn:
        quality.warn("; ".join(text for _, _, text in gaps) + ": G is not measured there "
                     "(attrs uncovered_dr_min/max); fit, energy, gradient, stress ACF, "
                     "Persson theory, patch radius and spectrum of this G bridge the gap "
                     "or mark what depends on it", StitchingGapWarning)
    text = "" if lazy else "; ".join(_unexplained_factors(names, factors[0], factors[1],
                                                            threshold))
    out = quality.mark_curves(out, xr.DataArray(code), what="stitch",
                              reason="stitch_levels", notes=text, warn=False)
    if text and warn:
        quality.warn(text, LevelFactorWarning)
    return _carry_findings(out, curves)


def _carry_findings(out: xr.DataArray, curves: xr.Dataset) -> xr.DataArray:
    """Give the stitched G what :func:`stitch_curves` found before any value was computed.

    Measurements left out (their stated tip resolves no lag; their notes, questionable,
    warned by :func:`stitch_curves`) and the remarks on windows cut by a tip. Remarks are
    set directly: a lazy G gets no ``quality`` attr from them (:data:`STITCH_DIAGNOSTICS`).
    """
    level, notes = curves.attrs.get("quality", "good"), curves.attrs.get("quality_notes", "")
    if level != "good" and notes:
        out = quality.mark(out, notes, level=level, what="stitch", warn=False)
    remarks = [n for n in str(curves.attrs.get("quality_remarks", "")).split(
        quality.SEPARATOR) if n]
    if remarks:
        out.attrs["quality_remarks"] = _joined(out.attrs.get("quality_remarks", ""), remarks)
    return out


def _level_and_combine(curves: xr.Dataset, keep: np.ndarray, *, level: bool,
                       threshold: float, lazy: bool) -> tuple:
    """:func:`_combine_curves` on the curves: at once, or one small task on lazy curves.

    On lazy curves the level factors stay unknown (``None``) until compute.
    """
    stack = dsa.stack if lazy else np.stack  # one array: one collection for dask
    curves_3d = stack([curves[k].data.astype(float) for k in
                       ("G", "standard_error", "pair_count")])
    args = (curves_3d, curves.dr.values, _scan_sizes(curves), keep, level,
            [str(n) for n in curves.measurement.values], threshold)
    if not lazy:
        return _combine_curves(*args)
    nk = int(keep.sum())
    parts = dask.delayed(_combine_curves, nout=4, pure=True)(*args)
    return (dsa.from_delayed(parts[0], shape=(2, nk), dtype=float),
            dsa.from_delayed(parts[1], shape=(3, nk), dtype=np.int64), None,
            dsa.from_delayed(parts[3], shape=(), dtype=np.int8))


def _stitched_attrs(curves: xr.Dataset, *, level: bool, diagnostics: dict,
                    gaps: list) -> dict:
    """Attrs of the stitched G (see :func:`stitch`), with the value ``diagnostics``."""
    names = [str(n) for n in curves.measurement.values]
    lunit = curves.dr.attrs["units"]

    def known_or(sizes: xr.DataArray, fallback: xr.DataArray, pick) -> float:
        values = sizes.values
        return float(pick(values)) if np.isfinite(values).any() else float(
            pick(fallback.values))

    return result_attrs(None, **{
        "units": curves.G.attrs["units"],
        "long_name": "height-difference autocorrelation function",
        "symbol": "G",
        "equation": "eq. 1: G(dr) = 1/2 <(h(r) - h(r + dr))^2>",
        "stitched": 1,
        "stitched_from": ", ".join(names),
        "sources": ", ".join(str(s) for s in curves.source.values),
        "windows": "; ".join(f"{n}: {lo:.4g}-{hi:.4g} {lunit}" for n, lo, hi in
                             zip(names, curves.dr_min.values, curves.dr_max.values)),
        "window_rules": curves.attrs.get("window_rules", ""),
        "left_out": str(curves.attrs.get("left_out", "")),
        "weighting": "inverse-variance mean of ln G, weights (G_i / standard_error_i)^2",
        "levelling": (f"each G times a factor fitted next to the seams (level_factors), "
                      f"at most {LEVEL_FACTOR_BOUND:g} or 1/{LEVEL_FACTOR_BOUND:g} "
                      "without a mark" if level else "none (level=False)"),
        "points_per_decade": float(curves.attrs.get("points_per_decade", np.nan)),
        "pixel_size": known_or(curves.pixel_size, curves.dr_min, np.nanmin),
        "scan_size": known_or(curves.scan_size, curves.dr_max, np.nanmax),
        "reliable_dr_min": float(curves.dr_min.min()),
        "reliable_dr_max": float(curves.dr_max.max()),
        "reliable_dr_units": lunit,
        **diagnostics,
        "level_factor_bound": LEVEL_FACTOR_BOUND,
        "uncovered_dr_min": np.array([lo for lo, _, _ in gaps], dtype=float),
        "uncovered_dr_max": np.array([hi for _, hi, _ in gaps], dtype=float),
        "uncovered_dr_units": lunit,
        "source_sha256": ", ".join(str(c) for c in curves.source_sha256.values)
        if "source_sha256" in curves.coords else "",
    })


def _window_bins(curves: xr.Dataset) -> np.ndarray:
    """Select the common bins whose centre lies in the window of some measurement."""
    dr = curves.dr.values
    lo, hi = curves.dr_min.values[:, None], curves.dr_max.values[:, None]
    return ((dr >= lo) & (dr <= hi)).any(axis=0)


def _combine_curves(curves_3d, dr, scan, keep, level, names, threshold):
    """Level and combine the re-binned curves (numpy): the stitched G on the kept bins.

    Returns ``[G, standard error]`` and ``[pair count, measurements, coverage bits]`` on
    the kept bins, ``[level factors, errors of their logs]`` per measurement and the
    quality code (1 when a level factor is unexplained, :func:`_unexplained_factors`).
    Bins of a window that hold no data are NaN (count 0). ``curves_3d`` holds G, its
    standard error and the pair count, each ``(measurement, dr)``.
    """
    g, se, cnt = np.asarray(curves_3d, dtype=float)
    nm = g.shape[0]
    factors, errors = (_level_factors(g, se, dr, scan) if level
                       else (np.ones(nm), np.zeros(nm)))
    G, err, n_meas = _combine(g * factors[:, None], se * factors[:, None])
    covered = np.isfinite(g) & (g > 0) & (se > 0)
    per_bin = np.stack([G[keep], err[keep]])
    counts = np.stack([np.asarray(cnt, dtype=np.int64).sum(axis=0)[keep],
                       n_meas[keep].astype(np.int64), _coverage_bits(covered[:, keep])])
    code = np.int8(1 if _unexplained_factors(names, factors, errors, threshold) else 0)
    return per_bin, counts, np.stack([factors, errors]), code


def _uncovered(curves: xr.Dataset, kept: np.ndarray) -> list[tuple[float, float, str]]:
    """Lag ranges between the windows that no window covers and that lose a common bin.

    Returns ``(dr_lo, dr_hi, text)`` per gap: the window ends around it, and in words.
    """
    lo, hi = curves.dr_min.values.astype(float), curves.dr_max.values.astype(float)
    names = [str(n) for n in curves.measurement.values]
    dr, lunit = curves.dr.values, curves.dr.attrs.get("units", "")
    gaps, end, last = [], -np.inf, None
    for m in np.argsort(lo, kind="stable"):
        if lo[m] > end and last is not None:
            lost = (dr > end) & (dr < lo[m]) & ~kept
            if lost.any():
                below, above = dr[kept & (dr <= end)], dr[kept & (dr >= lo[m])]
                gaps.append((float(end), float(lo[m]), (
                    f"no measurement covers dr = {end:.4g}-{lo[m]:.4g} {lunit} (the window "
                    f"of {names[last]!r} ends at {end:.4g}, that of {names[m]!r} begins at "
                    f"{lo[m]:.4g}): no bin between {below.max():.4g} and {above.min():.4g} "
                    f"{lunit}, {int(lost.sum())} bins of the grid")))
        if hi[m] > end:
            end, last = hi[m], m
    return gaps


def _coverage_bits(covered: np.ndarray) -> np.ndarray:
    """Per bin, which measurements it holds: bit ``2**i`` for the i-th measurement."""
    shifts = np.arange(covered.shape[0], dtype=np.int64)[:, None]
    return (covered.astype(np.int64) << shifts).sum(axis=0).astype(np.int64)


def _coverage_attrs(names: list[str]) -> dict:
    """Attrs of the ``coverage`` coordinate (CF ``flag_masks``, one per measurement)."""
    if len(names) > 62:
        raise ValueError(f"at most 62 measurements can be stitched, got {len(names)}")
    return {
        "units": "1", "long_name": "measurements whose G the bin holds (bit 2**i: the i-th "
        "of stitched_from)",
        **quality.cf_flags(["_".join(n.split()) or f"measurement_{i}"
                            for i, n in enumerate(names)], np.int64, masks=True)}
