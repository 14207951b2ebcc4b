"""Matplotlib plots of every xrough result, labelled with names and units.

:func:`plot` dispatches on what the DataArray is: a topography map (image), a profile
(line), or a function of lag ``dr`` or wavenumber ``q`` (log-log, with the standard error
as a band when present). :func:`plot_stitched` draws several instruments' G and their
stitched G in one figure. A fit Dataset (:func:`xrough.fit_acf`) plots its model curve
(:func:`plot_fit`), a patch-radius Dataset (:func:`xrough.patch_radius`) its two radii
per curve (:func:`plot_patch_radius`). Every function returns the
:class:`matplotlib.axes.Axes` (:func:`plot_dataset` an array of them).

Conventions of every figure:

- Units in labels are written for reading: ``um`` as ``µm`` (:func:`display_unit`); the
  data's ``units`` attrs stay CF.
- Lines and error bands break at gaps: NaN bins, and the bins of a stitched G that no
  instrument covers (missing points of its log grid, ``attrs["points_per_decade"]``),
  are never bridged by a straight line.
- On a log axis the error band runs from ``max(G - s, G / 10)`` to ``G + s`` (``s`` the
  standard error): where the error reaches G the lower edge is clipped at a tenth of G
  (:data:`BAND_FLOOR`) instead of vanishing.
- Long axis labels are wrapped to the size of their axes, so that they stay inside the
  figure.
- A log axis labels its powers of ten; only when fewer than two of them are in view are the
  minor ticks at 2 and 5 labelled too, so that labels never crowd each other
  (:func:`log_axis`).
"""

from __future__ import annotations

import re
import textwrap
from collections.abc import Hashable

import numpy as np
import xarray as xr

from . import fitting, stitching
from . import quality as _quality
from . import units as _units
from .topography import convert_units

__all__ = ["plot", "plot_topography", "plot_loglog", "plot_dataset", "plot_stitched",
           "plot_fit", "plot_patch_radius", "plot_gap_distribution", "display_unit", "log_axis",
           "BAND_FLOOR"]

#: Lower edge of an error band on a log axis, as a fraction of the curve (G / 10).
BAND_FLOOR = 0.1

_MICRO = re.compile(r"(?<![A-Za-z])u(?=m(?![A-Za-z]))|(?<![A-Za-z])micro(?=m)")


#: Legend words of the quality flags a curve is drawn with (see :mod:`xrough.quality`).
LEVEL_WORDS = {1: "questionable", 2: "failed"}


def display_unit(units: str) -> str:
    """Write a unit string for a label as people write it: ``µm``, ``nm²``, ``J/m²``.

    Powers as superscripts, negative ones as a quotient, dimensionless as nothing (pint's
    compact pretty format, as the command line writes values). Only for display; data
    attrs keep the CF spelling.

    Parameters
    ----------
    units : str
        A CF/UDUNITS unit string such as ``"um"``, ``"um2"``, ``"um-1"`` or ``"J m-2"``.

    Returns
    -------
    str

    Examples
    --------
    >>> display_unit("um"), display_unit("nm2"), display_unit("um-1"), display_unit("J m-2")
    ('µm', 'nm²', '1/µm', 'J/m²')
    >>> display_unit("1")
    ''
    """
    try:
        return format(_units.parse_units(str(units)), "~P")
    except (ValueError, TypeError):  # not a unit pint knows: as written, micro as µ
        return _MICRO.sub("µ", str(units))


def _coord_text(name: Hashable, value, units: str | None) -> str:
    """``"p0 = 0.1 MPa"`` for a legend: a value with its unit, compact prefix.

    A name (a string value, e.g. a measurement) stands alone.
    """
    if isinstance(value, (str, np.str_)):
        return str(value)
    if units is None:
        return f"{name} = {value}"
    try:
        q = _units.compact(_units.ureg.Quantity(float(value), _units.parse_units(units)))
        return f"{name} = {q.magnitude:.3g} {display_unit(format(q.units, '~'))}".rstrip()
    except (ValueError, TypeError):
        return f"{name} = {value}"


def _coord_units(obj, dim: Hashable) -> str | None:
    return obj[dim].attrs.get("units") if dim in obj.coords else None


def _label(da: xr.DataArray, default: Hashable) -> str:
    name = da.attrs.get("long_name", da.name or default)
    units = display_unit(da.attrs["units"]) if da.attrs.get("units") else ""
    return f"{name} ({units})" if units else str(name)


def _wrap(text: str, length_points: float, fontsize: float) -> str:
    """``text`` wrapped to lines that fit ``length_points`` (about 0.55 em a character)."""
    width = max(12, int(length_points / (0.55 * fontsize)))
    return textwrap.fill(text, width=width, break_long_words=False)


def _set_labels(ax, xlabel: str, ylabel: str) -> None:
    """Axis labels wrapped to the axes' size, so that long ones stay inside the figure."""
    box = ax.get_position()
    w, h = ax.figure.get_size_inches()
    size = ax.xaxis.label.get_fontsize()
    ax.set_xlabel(_wrap(xlabel, box.width * w * 72, size))
    ax.set_ylabel(_wrap(ylabel, box.height * h * 72, size))


def _gap_breaks(da: xr.DataArray, dim: str, x: np.ndarray) -> np.ndarray:
    """Find the indices before which a curve crosses lags no measurement covers.

    A stitched G misses bins of its log grid there; a result of it (a stress ACF, Persson
    theory) keeps its lags but carries the ranges (``uncovered_dr_min/max``) in attrs.
    """
    if x.size < 2:
        return np.array([], dtype=int)
    breaks: set[int] = set()
    ppd = da.attrs.get("points_per_decade")
    if da.attrs.get("stitched") and ppd is not None and np.isfinite(ppd):
        with np.errstate(divide="ignore", invalid="ignore"):
            steps = np.diff(np.log10(x) * float(ppd))
        breaks.update(int(i) + 1 for i in np.flatnonzero(steps > 1.5))
    lows, highs = da.attrs.get("uncovered_dr_min"), da.attrs.get("uncovered_dr_max")
    unit, own = da.attrs.get("uncovered_dr_units"), _coord_units(da, dim)
    if dim == "dr" and lows is not None and highs is not None and unit and own:
        factor = _units.conversion_factor(str(unit), str(own))
        for lo, hi in zip(np.atleast_1d(lows), np.atleast_1d(highs)):
            i = int(np.searchsorted(x, lo * factor, side="right"))
            if 0 < i < x.size and x[i] >= hi * factor * (1 - 1e-9):
                breaks.add(i)
    return np.array(sorted(breaks), dtype=int)


def _with_gaps(x: np.ndarray, arrays: list[np.ndarray], breaks: np.ndarray):
    """Insert a NaN point at each break so that lines and bands are not bridged."""
    if breaks.size == 0:
        return x, arrays
    xg = np.insert(x.astype(float), breaks, np.nan)
    return xg, [np.insert(a.astype(float), breaks, np.nan) for a in arrays]


def pyplot(backend: str | None = None):
    """Return :mod:`matplotlib.pyplot`, imported when the first figure is made.

    ``import xrough`` does not import it (about one second); ``backend`` (e.g.
    ``"Agg"`` for figures that only go to files) is selected first.
    """
    if backend is not None:
        import matplotlib

        matplotlib.use(backend)
    import matplotlib.pyplot as plt

    return plt


def log_axis(axis) -> None:
    """Put ``axis`` (``ax.xaxis`` or ``ax.yaxis``) on a log scale with uncrowded labels.

    The powers of ten are labelled; the minor ticks at 2 and 5 times a power of ten only
    when fewer than two powers of ten are in view (decided when the figure is drawn, so it
    holds after later lines change the limits). Matplotlib's default labels every minor
    tick of an axis spanning about a decade, and they overlap on a narrow axes.

    Examples
    --------
    >>> fig, ax = pyplot("Agg").subplots(figsize=(3, 2))
    >>> _ = ax.plot([150.0, 700.0], [1.0, 2.0])
    >>> log_axis(ax.xaxis)
    >>> fig.canvas.draw()
    >>> minor = [t.get_text() for t in ax.get_xticklabels(which="minor") if t.get_text()]
    >>> [m.split("times")[0][-2] for m in minor]  # the mantissas: 2 and 5 x 10^2 only
    ['2', '5']
    """
    from matplotlib import ticker

    class _SparseMinor(ticker.LogFormatterSciNotation):
        def __init__(self) -> None:
            super().__init__(labelOnlyBase=False, minor_thresholds=(np.inf, np.inf))

        def __call__(self, x, pos=None):
            assert self.axis is not None  # matplotlib sets it before asking for labels
            lo, hi = sorted(self.axis.get_view_interval())
            # matplotlib < 3.9 also asks for the labels of ticks outside the view
            if not (x > 0 and lo > 0 and lo <= x <= hi):
                return ""
            powers = np.floor(np.log10(hi)) - np.ceil(np.log10(lo)) + 1
            mantissa = x / 10 ** np.floor(np.log10(x) + 1e-9)
            wanted = np.isclose(mantissa, 2.0) or np.isclose(mantissa, 5.0)
            return super().__call__(x, pos) if powers < 2 and wanted else ""

    getattr(axis.axes, f"set_{axis.axis_name}scale")("log")
    axis.set_minor_formatter(_SparseMinor())


def _axes(ax):
    if ax is None:  # a new figure makes room for its labels when drawn
        _, ax = pyplot().subplots(layout="constrained")
    return ax


#: Length units a figure may choose from (:func:`readable_units`).
_LENGTH_PREFIXES = ("pm", "nm", "um", "mm", "m", "km")


def _readable_length(span: float, unit: str) -> str:
    """Return the unit of ``_LENGTH_PREFIXES`` in which ``span`` (in ``unit``) is 1-1000."""
    if not (np.isfinite(span) and span > 0):
        return unit
    metres = span * _units.conversion_factor(unit, "m")
    for prefix in _LENGTH_PREFIXES:
        if metres * _units.conversion_factor("m", prefix) < 1000:
            return prefix
    return _LENGTH_PREFIXES[-1]


def readable_units(topography: xr.DataArray) -> xr.DataArray:
    """Return the topography in length units that its figure reads without exponents.

    The lateral coordinates in the unit where the scan's extent is 1 to 1000, the heights
    where their range is (a map in m of a 20 um scan with 1e-8 m heights is drawn in um
    and nm, not with a 1e-5 offset). Only for display: the data are converted, not
    relabelled.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> topo = xrough.topography(1e-8 * np.arange(12.0).reshape(3, 4), spacing=5e-6,
    ...                          unit="m")
    >>> shown = readable_units(topo)
    >>> shown.attrs["units"], shown.x.attrs["units"]
    ('nm', 'um')
    """
    dims = [d for d in ("y", "x") if d in topography.dims]
    lateral = str(topography[dims[-1]].attrs.get("units", ""))
    height = str(topography.attrs.get("units", ""))
    if not (_units.is_length(lateral) and _units.is_length(height)):
        return topography
    extent = max(float(np.ptp(topography[d].values)) for d in dims)
    with np.errstate(all="ignore"):
        values = np.asarray(topography.values, dtype=float)
        finite = values[np.isfinite(values)]
    heights = float(np.ptp(finite)) if finite.size else np.nan
    return convert_units(topography, _readable_length(heights, height),
                         lateral=_readable_length(extent, lateral))


def _offset_removed(t: xr.DataArray) -> tuple[np.ndarray, str]:
    """Return heights for a colour scale and its label.

    The heights less their median where it is more than 100 times their range (a map
    76 um above its instrument's zero with 40 nm of roughness), which the label states.
    """
    values = np.asarray(t.values, dtype=float)
    finite = values[np.isfinite(values)]
    label = _label(t, "height")
    if not finite.size:
        return values, label
    middle, spread = float(np.median(finite)), float(np.ptp(finite))
    if abs(middle) <= 100 * spread:
        return values, label
    unit = display_unit(str(t.attrs.get("units", "")))
    name = label.rsplit(" (", 1)[0] if label.endswith(")") else label
    return values - middle, f"{name} - {middle:.6g} {unit} ({unit})"


def plot_topography(topography: xr.DataArray, *, ax=None, cmap: str = "viridis"):
    """Image of a height map or line of a profile, axes in readable physical units.

    Lengths are shown in the unit where the scan's extent and the heights' range are 1 to
    1000 (:func:`readable_units`): no exponent offsets on the axes.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> topo = xrough.topography(np.zeros((4, 5)), spacing=1.0, unit="nm")
    >>> ax = xrough.plot.plot_topography(topo)
    >>> ax.get_xlabel()
    'x position (nm)'
    """
    ax = _axes(ax)
    topography = readable_units(topography)
    if "y" not in topography.dims:  # profiles: one line each
        lines = topography.transpose(..., "x")
        flat = lines.values.reshape(-1, lines.sizes["x"])
        for row in flat:
            ax.plot(topography["x"].values, row, linewidth=0.8)
        _set_labels(ax, _label(topography["x"], "x"), _label(topography, "height"))
        return ax
    if topography.ndim != 2:
        raise ValueError(f"plot one map or profile at a time; got dims {topography.dims} "
                         "(select one, e.g. topo.isel(scan=0))")
    t = topography.transpose("y", "x")
    x, y = t["x"].values, t["y"].values
    dx = (x[-1] - x[0]) / (x.size - 1)
    dy = (y[-1] - y[0]) / (y.size - 1)
    values, label = _offset_removed(t)
    img = ax.imshow(values, origin="lower", cmap=cmap, aspect="equal",  # pixel centres
                    extent=(x[0] - dx / 2, x[-1] + dx / 2, y[0] - dy / 2, y[-1] + dy / 2))
    ax.figure.colorbar(img, ax=ax, label=label)
    _set_labels(ax, _label(t["x"], "x"), _label(t["y"], "y"))
    return ax


def plot_loglog(da: xr.DataArray, *, ax=None, error: bool = True,
                short_range_linear: bool = False, **kwargs):
    """Log-log plot of a function of ``dr`` or ``q``, with its errors as bands.

    The statistical error (coordinate ``standard_error`` or ``<name>_std``) is a filled
    band of one standard deviation; the exact solution a theory is expected to miss
    (coordinates ``<name>_exact``, ``<name>_exact_lower`` and ``_upper`` of
    :func:`xrough.persson`) a dotted line in a hatched band of its one-sigma interval.

    Extra dims (e.g. ``scan``) give one line each. Lines and bands break at NaN bins and
    at the uncovered bins of a stitched G. A curve whose ``quality_flag`` is questionable
    is dashed with hollow points and says so in the legend (failed curves are NaN). On a
    log axis the band's lower edge is
    ``max(G - s, BAND_FLOOR * G)``: where the standard error ``s`` reaches G, the band
    stays visible down to G / 10 instead of vanishing. The y axis is linear when the data
    cross zero (stress ACFs), or with ``short_range_linear`` when they span less than a
    decade (Persson theory's panels).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> topo = xrough.topography(np.random.default_rng(0).normal(size=(32, 32)),
    ...                          spacing=1.0, unit="nm")
    >>> ax = topo.rough.acf().rough.plot()
    >>> ax.get_xscale(), ax.get_yscale()
    ('log', 'log')
    """
    ax = _axes(ax)
    dim = next(d for d in _AXES if d in da.dims)
    extra = [d for d in da.dims if d != dim]
    stacked = da.stack(_line=extra) if extra else da.expand_dims("_line")
    user_label = kwargs.pop("label", None)
    values = np.asarray(da.values, dtype=float)
    finite = values[np.isfinite(values)]
    log_y = bool(np.all(finite > 0))  # stress ACFs cross zero
    if short_range_linear and finite.size and finite.max() < 10 * finite.min():
        log_y = False  # an area between 0.1 and 0.3 reads better on a linear axis
    marked = False
    for k in range(stacked.sizes["_line"]):
        line = stacked.isel(_line=k)
        x = np.asarray(line[dim].values, dtype=float)
        y = np.asarray(line.values, dtype=float)
        se = _error_of(line, "std") if error else None
        exact = _exact_of(line) if error else None
        breaks = _gap_breaks(da, dim, x)
        x, (y, *rest) = _with_gaps(x, [y] + [e for e in (se, *(exact or ())) if e is not None],
                                   breaks)
        label = user_label if k == 0 else None
        if extra:
            index = ", ".join(_coord_text(d, line[d].item(), _coord_units(da, d))
                              for d in extra
                              if d in line.coords)
            label = f"{user_label} ({index})" if user_label else index
        flag = (int(line.coords["quality_flag"].values)
                if "quality_flag" in line.coords and line.coords["quality_flag"].ndim == 0
                else 0)
        style = dict(kwargs)
        if flag:  # questionable (failed curves are NaN): dashed, hollow points
            style = {"linestyle": "--", "marker": "o", "markersize": 3,
                     "markerfacecolor": "none", **kwargs}
            label = f"{label} ({LEVEL_WORDS[flag]})" if label else LEVEL_WORDS[flag]
            marked = True
        (ln,) = ax.plot(x, y, label=label, **style)
        if se is not None:
            se = rest.pop(0)
            lo = np.maximum(y - se, BAND_FLOOR * y) if log_y else y - se
            ax.fill_between(x, lo, y + se, color=ln.get_color(), alpha=0.25, linewidth=0)
        if exact is not None:  # where a contact solver is expected, and its interval
            mid, lo, hi = rest[:3]
            ax.fill_between(x, lo, hi, facecolor="none", edgecolor=ln.get_color(),
                            hatch="///", alpha=0.35, linewidth=0)
            ax.plot(x, mid, linestyle=":", color=ln.get_color(),
                    label="expected exact" if k == 0 else None)
            marked = True
    if not finite.size:  # a failed result: an empty panel that says why
        notes = _quality.notes_of(da)
        ax.text(0.5, 0.5, "no finite values" + (": " + notes[0] if notes else ""),
                transform=ax.transAxes, ha="center", va="center", wrap=True,
                fontsize="small")
        log_y = False
    log_axis(ax.xaxis)
    if log_y:
        log_axis(ax.yaxis)
    else:
        ax.set_yscale("linear")
    _set_labels(ax, _label(da[dim], dim), _label(da, da.name or ""))
    if extra or user_label or marked:
        ax.legend()
    return ax


#: Coordinates (or Dataset variables) that hold a result's errors, by kind.
_ERRORS = {"std": ("standard_error", "{name}_std")}
#: Variables beside a theory's value: its expected exact value and that one's interval.
_EXACT = ("_exact", "_exact_lower", "_exact_upper")


def _error_of(da: xr.DataArray, kind: str) -> np.ndarray | None:
    """Return the statistical (``"std"``) or model error of ``da`` (None: none)."""
    for pattern in _ERRORS[kind]:
        name = pattern.format(name=da.name)
        if name in da.coords and da.coords[name].dims == da.dims:
            values = np.asarray(da.coords[name].values, dtype=float)
            return values if np.isfinite(values).any() else None
    return None


def _exact_of(da: xr.DataArray) -> tuple[np.ndarray, ...] | None:
    """Return the expected exact value of ``da`` and its bounds (None: none, or all NaN)."""
    names = [f"{da.name}{suffix}" for suffix in _EXACT]
    if not all(n in da.coords and da.coords[n].dims == da.dims for n in names):
        return None
    values = tuple(np.asarray(da.coords[n].values, dtype=float) for n in names)
    return values if np.isfinite(values[0]).any() else None


def _is_error(name: Hashable) -> bool:
    """Whether a Dataset variable is the error of another (drawn as its band)."""
    return isinstance(name, str) and name.endswith(("_std", "_model_error", *_EXACT))


@_units.accepts_quantified
def plot_dataset(ds: xr.Dataset, *, variables=None, axes=None, ax=None,
                 G: xr.DataArray | None = None):
    """One panel per variable of a result Dataset (Persson theory, energy, ...).

    Variables on ``dr``, ``q``, ``a_c`` or ``p0`` (:func:`xrough.mean_gap`) are drawn
    against it (log axes, see
    :func:`plot_loglog`), one panel each titled by its name; scalars are skipped. Persson
    theory shows :data:`PERSSON_PANELS` (the contact area and stress, titled by
    :data:`PANEL_TITLES`, linear where they span less than a decade) unless ``variables``
    names others. A variable's errors are drawn as bands in
    its panel, not as panels of their own: ``<name>_std`` (one standard deviation, filled)
    and ``<name>_exact`` (a dotted line in the hatched band of its interval: where the exact
    solution is expected). A fit (:func:`xrough.fit_acf`) goes to
    :func:`plot_fit` (with ``G``: the data under the model) and a patch radius
    (:func:`xrough.patch_radius`) to :func:`plot_patch_radius`, each in one panel.

    Parameters
    ----------
    ds : xarray.Dataset
        A result Dataset.
    variables : list of str, optional
        The variables to draw (default: every one on ``dr``, ``q`` or ``a_c``).
    axes : array of matplotlib.axes.Axes, optional
        Axes to draw into, one per variable (default: a new figure, three panels a row).
    ax : matplotlib.axes.Axes, optional
        The Axes of a one-panel plot (a fit, a patch radius, one variable), as for a
        DataArray's ``.rough.plot(ax=ax)``; the same as ``axes=[ax]``.
    G : xarray.DataArray, optional
        For a fit: the G it was fitted to, drawn with its error band under the model
        (``fit.rough.plot(G=G)``).

    Returns
    -------
    numpy.ndarray of matplotlib.axes.Axes
        One Axes per panel drawn.

    Raises
    ------
    ValueError
        Nothing in ``ds`` can be drawn, fewer ``axes`` than panels, both ``ax`` and
        ``axes``, or ``G`` given for a Dataset that is not a fit.

    Examples
    --------
    >>> C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_gradient=0.5, unit="nm")
    >>> G = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="100 um")
    >>> axes = G.rough.persson(E_star="25 MPa", p0="0.1 MPa").rough.plot()
    >>> [ax.get_title() for ax in axes]  # by default the area and the stress
    ['contact area a_r (eq. 29)', 'mean contact stress sigma_c (eq. 39/40)']

    A fit with the data it was fitted to:

    >>> ax, = G.rough.fit().rough.plot(G=G)
    >>> len(ax.lines) >= 2  # the data and the model
    True
    """
    if ax is not None:
        if axes is not None:
            raise ValueError("give ax (one panel) or axes (one per variable), not both")
        axes = [ax]
    if variables is None and _is_fit(ds):
        return np.array([plot_fit(ds, ax=None if axes is None else np.ravel(axes)[0], G=G)])
    if G is not None:
        raise ValueError("G= draws the data under a fit (fit_acf); this Dataset is not one")
    if variables is None and _is_patch_radius(ds):
        return np.array([plot_patch_radius(ds, ax=None if axes is None
                                           else np.ravel(axes)[0])])
    if variables is None and _is_persson(ds):
        variables = [v for v in PERSSON_PANELS if v in ds.data_vars]
    names = [n for n in (variables or [v for v in ds.data_vars if not _is_error(v)])
             if any(d in ds[n].dims for d in _AXES)]
    if not names:
        raise ValueError("nothing to plot: no variable depends on dr, q, a_c or p0, and the "
                         "Dataset is neither a fit (fit_acf) nor a patch radius "
                         "(patch_radius)")
    if axes is None:
        ncol = min(3, len(names))
        nrow = -(-len(names) // ncol)
        _, axes = pyplot().subplots(nrow, ncol, figsize=(4.5 * ncol, 3.6 * nrow),
                               squeeze=False, layout="constrained")
    flat = np.ravel(axes)
    if flat.size < len(names):
        raise ValueError(f"{flat.size} Axes given for {len(names)} panels ({', '.join(names)}): "
                         "pass one per variable, or choose them with variables=[...]")
    for name, ax in zip(names, flat):
        da = ds[name]
        bands = {e: ds[e] for e in (f"{name}_std", *(name + s for s in _EXACT))
                 if e in ds.data_vars and ds[e].dims == da.dims}
        if _SHARE in da.dims:
            plot_gap_distribution(da, ax=ax)
        else:
            plot_loglog(da.assign_coords(bands), ax=ax, short_range_linear=_is_persson(ds))
        ax.set_title(PANEL_TITLES.get(name, name) if _is_persson(ds) else name)
    for ax in flat[len(names):]:
        ax.set_visible(False)
    if ax.figure.get_layout_engine() is None:  # the caller's figure: fit it now
        ax.figure.tight_layout()
    return flat[: len(names)]


#: The dims a result is drawn against (log axes): lag, wavenumber, patch radius, load.
_AXES = ("dr", "q", "a_c", "p0")
#: What a Persson result shows by default: the contact area and the mean contact stress
#: against resolution (``variables=`` draws any others).
PERSSON_PANELS = ("a_r", "sigma_c")
#: Titles of Persson theory's panels (the y axis carries the long name and unit).
PANEL_TITLES = {"a_r": "contact area a_r (eq. 29)", "a_ri": "contact area a_ri (eq. 50)",
                "sigma_c": "mean contact stress sigma_c (eq. 39/40)",
                "p_star": "reduced pressure p*", "G_sigma": "stress ACF G_sigma (eq. 48)"}


#: The dim of a gap distribution's quantiles (:func:`xrough.mean_gap`,
#: :func:`xrough.solve_contact`).
_SHARE = "area_share"


def plot_gap_distribution(quantiles: xr.DataArray, *, ax=None, loads: int = 6):
    """Draw a gap distribution: the share of the area with a gap below ``u``, against ``u``.

    Parameters
    ----------
    quantiles : xarray.DataArray
        ``gap_quantiles`` on ``area_share`` (and ``p0``) of :func:`xrough.mean_gap` or
        :func:`xrough.solve_contact` (its load dim).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into (default: a new figure).
    loads : int
        At most this many loads are drawn (evenly spread in their order), one curve each,
        labelled with the load.

    Returns
    -------
    matplotlib.axes.Axes
        Gap (linear, the result's unit) on x, share of the nominal area on y: each curve
        starts at the contact area (gap 0).

    Examples
    --------
    The solver's on a small map (the theory's, ``mean_gap(...).gap_quantiles``, alike):

    >>> topo = xrough.self_affine_surface(hurst=0.8, lambda_r="16 nm", lambda_s="2 nm",
    ...                                   size="32 nm", n=32, rms_gradient=0.1,
    ...                                   unit="nm", seed=1)
    >>> sol = topo.rough.solve_contact(E_star="1 MPa", p0=["1 kPa", "10 kPa"],
    ...                                progress=False)
    >>> ax = xrough.plot.plot_gap_distribution(sol.gap_quantiles)
    >>> len(ax.lines)
    2
    """
    ax = _axes(ax)
    load_dims = [d for d in quantiles.dims if d != _SHARE]
    da = quantiles.transpose(*load_dims, _SHARE)
    flat = da.stack(_load=load_dims) if load_dims else da.expand_dims(_load=[0])
    flat = flat.transpose("_load", _SHARE)
    pick = np.unique(np.linspace(0, flat.sizes["_load"] - 1,
                                 min(loads, flat.sizes["_load"])).round().astype(int))
    share = np.asarray(da[_SHARE].values, dtype=float)
    unit = da.attrs.get("units", "")
    for i in pick:
        gap = np.asarray(flat.isel(_load=i).values, dtype=float)
        finite = np.isfinite(gap)
        label = None
        if load_dims:
            coords = flat.isel(_load=i)
            label = ", ".join(_coord_text(d, coords[d].values, _coord_units(da, d))
                              for d in load_dims)
        ax.plot(np.maximum(gap[finite], 0.0), share[finite], label=label)
    _set_labels(ax, f"gap ({display_unit(unit)})" if unit else "gap",
                "share of the area with a smaller gap")
    if load_dims:
        ax.legend(fontsize="small")
    return ax


def _is_persson(ds: xr.Dataset) -> bool:
    return "theory" in ds.attrs and all(v in ds.data_vars for v in PERSSON_PANELS)


def _is_fit(ds: xr.Dataset) -> bool:
    return "hurst" in ds.data_vars and "model" in ds.attrs and "dr" not in ds.dims


def _is_patch_radius(ds: xr.Dataset) -> bool:
    return {"a_c", "a_c_upper"} <= set(ds.data_vars) and "a_c" not in ds.dims


def _value(da: xr.DataArray, std: xr.DataArray | None) -> str:
    text = f"{float(da):.3g}"
    if std is not None and np.isfinite(float(std)) and float(std) > 0:
        text += f" ± {float(std):.2g}"
    units = da.attrs.get("units", "")
    return f"{text} {display_unit(units)}" if units not in ("", "1") else text


_FIT_SYMBOLS = {"hurst": "H", "sigma_h": "σ_h", "lambda_r": "λ_r", "lambda_s": "λ_s",
                "G_sa": "G_sa"}


def _fit_summary(fit: xr.Dataset) -> str:
    parts = []
    for name, symbol in _FIT_SYMBOLS.items():
        if name in fit.data_vars and fit[name].ndim == 0:
            std = fit.get(f"{name}_std")
            parts.append(f"{symbol} = {_value(fit[name], std)}".replace(" ", "\u00a0"))
    return ", ".join(parts)  # wrapped between parameters only (no-break spaces inside)


def plot_fit(fit: xr.Dataset, *, ax=None, G: xr.DataArray | None = None, **kwargs):
    """Plot the fitted G(dr) of :func:`xrough.fit_acf` over the fitted range, log-log.

    Parameters
    ----------
    fit : xarray.Dataset
        The result of :func:`xrough.fit_acf` (extra dims give one curve each).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into (default: a new figure).
    G : xarray.DataArray, optional
        The data that were fitted, drawn underneath with their error band.
    **kwargs
        Passed to :meth:`matplotlib.axes.Axes.plot` for the model curve.

    Returns
    -------
    matplotlib.axes.Axes
        The model curve (:func:`xrough.model_acf`, 50 log points over ``dr_min`` to
        ``dr_max`` of the fit), dashed, labelled with the model; the fitted parameters with
        their standard errors in the title (one fit) or legend (several).

    Examples
    --------
    >>> C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_gradient=0.5, unit="nm")
    >>> G = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="100 um")
    >>> ax = xrough.plot.plot_fit(G.rough.fit(), G=G)
    >>> ax.get_title().startswith("H = 0.8")
    True
    """
    ax = _axes(ax)
    if G is not None:
        plot_loglog(G, ax=ax, label="data", color="0.4", linewidth=1.0)
    model = fitting.model_acf(fit)
    name = "eq. 36" if fit.attrs.get("model") == "eq36" else "model spectrum (eq. 9)"
    kwargs.setdefault("linestyle", "--")
    plot_loglog(model, ax=ax, error=False, label=f"fit: {name}", **kwargs)
    summary = _fit_summary(fit)
    if summary:
        width = ax.get_position().width * ax.figure.get_size_inches()[0] * 72
        ax.set_title(_wrap(summary, width, ax.title.get_fontsize()).replace("\u00a0", " "),
                     fontsize="medium")
    return ax


def plot_patch_radius(patch: xr.Dataset, *, ax=None, **kwargs):
    """Plot the adhesive patch radii of :func:`xrough.patch_radius`, one row per curve.

    Each curve (each combination of extra dims, e.g. ``scan``) is a row: a dot at ``a_c``
    (eq. 46) and a bar to ``a_c_upper`` (eq. 44, the upper estimate), on a log axis in the
    unit of ``dr``. An infinite radius (``gamma`` above the full-contact energy: the
    surfaces stick everywhere) is drawn as a right-pointing triangle at the right edge and
    labelled "inf". ``gamma`` and ``E*`` are in the title.

    Parameters
    ----------
    patch : xarray.Dataset
        The result of :func:`xrough.patch_radius`.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into (default: a new figure).
    **kwargs
        Passed to :meth:`matplotlib.axes.Axes.plot` for the markers.

    Returns
    -------
    matplotlib.axes.Axes

    Examples
    --------
    >>> C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_gradient=0.5, unit="nm")
    >>> G = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="100 um")
    >>> ax = xrough.plot.plot_patch_radius(G.rough.patch_radius(E_star="25 MPa",
    ...                                                         gamma="1 mJ/m^2"))
    >>> ax.get_xlabel()
    'adhesive patch radius (nm)'
    """
    ax = _axes(ax)
    a_c, upper = patch["a_c"], patch["a_c_upper"]
    extra = list(a_c.dims)
    a = (a_c.stack(_row=extra) if extra else a_c.expand_dims("_row")).values
    b = (upper.stack(_row=extra) if extra else upper.expand_dims("_row")).values
    if extra:
        stacked = a_c.stack(_row=extra)
        rows = [", ".join(_coord_text(d, stacked[d].values[i], _coord_units(a_c, d))
                          for d in extra)
                for i in range(stacked.sizes["_row"])]
    else:
        rows = [str(a_c.attrs.get("long_name", "a_c")).split(",")[0]]
    y = np.arange(len(rows))
    finite = np.concatenate([a[np.isfinite(a)], b[np.isfinite(b)]])
    finite = finite[finite > 0]
    lo, hi = (finite.min() / 3, finite.max() * 3) if finite.size else (1.0, 10.0)
    edge = hi
    kwargs.setdefault("color", "C0")
    for i in range(len(rows)):
        ai = a[i] if np.isfinite(a[i]) else edge
        bi = b[i] if np.isfinite(b[i]) else edge
        ax.plot([ai, bi], [y[i], y[i]], linewidth=2, alpha=0.5, color=kwargs["color"])
        ax.plot([ai], [y[i]], "o", label="a_c (eq. 46)" if i == 0 else None, **kwargs)
        ax.plot([bi], [y[i]], "|", markersize=14, markeredgewidth=2,
                label="a_c_upper (eq. 44)" if i == 0 else None, **kwargs)
        if not (np.isfinite(a[i]) and np.isfinite(b[i])):
            ax.plot([edge], [y[i]], ">", markersize=9, color="k")
            ax.annotate("inf: sticks everywhere", (edge, y[i]), xytext=(-6, 8),
                        textcoords="offset points", ha="right", fontsize="small")
    log_axis(ax.xaxis)
    ax.set_xlim(lo, hi * 1.5)
    if not finite.size:  # every radius infinite: no scale to show
        ax.xaxis.set_major_formatter("")
        ax.xaxis.set_minor_formatter("")
    ax.set_ylim(-0.8, len(rows) - 0.2)
    ax.set_yticks(y, rows)
    _set_labels(ax, _label(a_c, "a_c").replace(", upper estimate", ""), "")
    gamma, E = patch.attrs.get("gamma"), patch.attrs.get("E_star")
    if gamma is not None and E is not None:
        g_text = _coord_text("γ", gamma, patch.attrs.get("gamma_units"))
        e_text = _coord_text("E*", E, patch.attrs.get("E_star_units"))
        ax.set_title(f"{g_text}, {e_text}", fontsize="medium")
    ax.legend(loc="lower right", fontsize="small")
    return ax


@_units.accepts_quantified
def plot_stitched(measurements, *, ax=None, error: bool = True, threshold: float = 3.0,
                  warn: bool = True, **kwargs):
    """G(dr) of each instrument in its reliable window, and their stitched G on top.

    Parameters
    ----------
    measurements : mapping, xarray.Dataset or xarray.DataTree
        Topographies or precomputed G of several instruments, as for
        :func:`xrough.stitch_curves` (a DataTree holds one instrument per node).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into (default: a new figure).
    error : bool
        Draw the standard error of the stitched G as a band.
    threshold, warn
        Mismatch diagnostic of :func:`xrough.stitch`: ``|z|`` above which two instruments
        disagree, and whether to warn (:class:`xrough.StitchingMismatchWarning`).
    **kwargs
        Passed to :func:`xrough.stitch_curves` (``points_per_decade``, ``windows``,
        ``unit``, ...).

    Returns
    -------
    matplotlib.axes.Axes
        Log-log axes with one line per instrument (labelled by its name, NaN bins outside
        its window left out) and the stitched G (labelled ``stitched``), axis labels in the
        common units.

    See Also
    --------
    xrough.stitch_curves, xrough.stitch, plot_loglog

    Examples
    --------
    >>> topo = xrough.self_affine_surface(hurst=0.7, lambda_r="2 um", lambda_s="20 nm",
    ...                                   size="8 um", n=1024, rms_height="10 nm",
    ...                                   profile=True, seed=3, unit="nm")
    >>> fine = topo.isel(x=slice(0, 256)).assign_attrs(periodic=0)
    >>> coarse = topo.isel(x=slice(None, None, 4))
    >>> ax = xrough.plot.plot_stitched({"fine": fine, "coarse": coarse})
    >>> len(ax.get_lines()), ax.get_xlabel()
    (3, 'lag distance (nm)')
    """
    ax = _axes(ax)
    curves = stitching.stitch_curves(measurements, **kwargs)
    for name in curves.measurement.values:
        G_one = curves.G.sel(measurement=name)
        valid = np.flatnonzero(np.isfinite(G_one.values))
        if valid.size:  # inside its window only; NaN bins within it stay gaps
            G_one = G_one.isel(dr=slice(valid[0], valid[-1] + 1))
        plot_loglog(G_one, ax=ax, label=str(name), linewidth=1.0)
    G = stitching.stitch(curves, threshold=threshold, warn=warn)
    return plot_loglog(G, ax=ax, error=error, label="stitched", color="k", linewidth=1.5,
                       zorder=3)


@_units.accepts_quantified
def plot(da: xr.DataArray, *, ax=None, **kwargs):
    """Plot any xrough DataArray (topography, G(dr), C(q), ...).

    Parameters
    ----------
    da : xarray.DataArray
        A topography (dims ``y, x`` or ``x``), a result on ``dr`` / ``q`` or a gap
        distribution (on ``area_share``: :func:`plot_gap_distribution`); a Dataset goes
        to :func:`plot_dataset`, a DataTree of instruments to :func:`plot_stitched`.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into (default: a new figure).
    **kwargs
        Passed to the specific plot function.

    Returns
    -------
    matplotlib.axes.Axes
    """
    if isinstance(da, xr.DataTree):
        return plot_stitched(da, ax=ax, **kwargs)
    if isinstance(da, xr.Dataset):
        return plot_dataset(da, **kwargs)
    if "dr" in da.dims or "q" in da.dims or "a_c" in da.dims:
        return plot_loglog(da, ax=ax, **kwargs)
    if _SHARE in da.dims:
        return plot_gap_distribution(da, ax=ax, **kwargs)
    if "x" in da.dims:
        return plot_topography(da, ax=ax, **kwargs)
    raise ValueError(f"do not know how to plot a DataArray with dims {da.dims}")
