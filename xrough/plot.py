"""Matplotlib plots of every xrough result, labelled with names and units.

:func:`plot` dispatches on what the DataArray is: a topography map (image), a profile
(line), or a function of lag ``dr`` or wavenumber ``q`` (log-log, with the standard error
as a band when present). :func:`plot_stitched` draws several instruments' G and their
stitched G in one figure. Every function returns the :class:`matplotlib.axes.Axes`.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from . import stitching

__all__ = ["plot", "plot_topography", "plot_loglog", "plot_dataset", "plot_stitched"]


def _label(da: xr.DataArray, default: str) -> str:
    name = da.attrs.get("long_name", da.name or default)
    units = da.attrs.get("units")
    return f"{name} ({units})" if units else str(name)


def _axes(ax):
    if ax is None:
        _, ax = plt.subplots()
    return ax


def plot_topography(topography: xr.DataArray, *, ax=None, cmap: str = "viridis"):
    """Image of a height map or line of a profile, axes in physical units.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> topo = xrough.topography(np.zeros((4, 5)), spacing=1.0, unit="nm")
    >>> ax = xrough.plot.plot_topography(topo)
    >>> ax.get_xlabel()
    'x position (nm)'
    """
    ax = _axes(ax)
    if "y" not in topography.dims:  # profiles: one line each
        lines = topography.transpose(..., "x")
        flat = lines.values.reshape(-1, lines.sizes["x"])
        for row in flat:
            ax.plot(topography["x"].values, row, linewidth=0.8)
        ax.set_xlabel(_label(topography["x"], "x"))
        ax.set_ylabel(_label(topography, "height"))
        return ax
    if topography.ndim != 2:
        raise ValueError(f"plot one map or profile at a time; got dims {topography.dims} "
                         "(select one, e.g. topo.isel(scan=0))")
    t = topography.transpose("y", "x")
    x, y = t["x"].values, t["y"].values
    dx = (x[-1] - x[0]) / (x.size - 1)
    dy = (y[-1] - y[0]) / (y.size - 1)
    img = ax.imshow(t.values, origin="lower", cmap=cmap, aspect="equal",  # pixel centres
                    extent=(x[0] - dx / 2, x[-1] + dx / 2, y[0] - dy / 2, y[-1] + dy / 2))
    ax.figure.colorbar(img, ax=ax, label=_label(t, "height"))
    ax.set_xlabel(_label(t["x"], "x"))
    ax.set_ylabel(_label(t["y"], "y"))
    return ax


def plot_loglog(da: xr.DataArray, *, ax=None, error: bool = True, **kwargs):
    """Log-log plot of a function of ``dr`` or ``q``, with the standard error as a band.

    Extra dims (e.g. ``scan``) give one line each.

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
    dim = next(d for d in ("dr", "q", "a_c") if d in da.dims)
    extra = [d for d in da.dims if d != dim]
    stacked = da.stack(_line=extra) if extra else da.expand_dims("_line")
    user_label = kwargs.pop("label", None)
    for k in range(stacked.sizes["_line"]):
        line = stacked.isel(_line=k)
        x = line[dim].values
        y = line.values
        label = user_label if k == 0 else None
        if extra:
            index = ", ".join(f"{d}={line[d].item()}" for d in extra if d in line.coords)
            label = f"{user_label} ({index})" if user_label else index
        (ln,) = ax.plot(x, y, label=label, **kwargs)
        if error and "standard_error" in line.coords:
            se = line["standard_error"].values
            lo = np.where(y - se > 0, y - se, np.nan)
            ax.fill_between(x, lo, y + se, color=ln.get_color(), alpha=0.25, linewidth=0)
    ax.set_xscale("log")
    values = np.asarray(da.values, dtype=float)
    positive = bool(np.all(values[np.isfinite(values)] > 0))
    ax.set_yscale("log" if positive else "linear")  # stress ACFs cross zero
    ax.set_xlabel(_label(da[dim], dim))
    ax.set_ylabel(_label(da, da.name or ""))
    if extra or user_label:
        ax.legend()
    return ax


def plot_dataset(ds: xr.Dataset, *, variables=None, axes=None):
    """One panel per variable of a result Dataset (Persson theory, energy, ...).

    Variables on ``dr``, ``q`` or ``a_c`` are drawn against it (log axes); scalars are
    skipped. Returns the array of Axes.

    Examples
    --------
    >>> C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_gradient=0.5, unit="nm")
    >>> G = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="100 um")
    >>> axes = G.rough.persson(E_star="25 MPa", p0="0.1 MPa").rough.plot()
    >>> len(axes)
    8
    """
    names = [n for n in (variables or ds.data_vars)
             if any(d in ds[n].dims for d in ("dr", "q", "a_c"))]
    if not names:
        raise ValueError("nothing to plot: no variable depends on dr, q or a_c")
    if axes is None:
        ncol = min(3, len(names))
        nrow = -(-len(names) // ncol)
        _, axes = plt.subplots(nrow, ncol, figsize=(4.5 * ncol, 3.6 * nrow), squeeze=False)
    flat = np.ravel(axes)
    for name, ax in zip(names, flat):
        plot_loglog(ds[name], ax=ax)
        ax.set_title(name)
    for ax in flat[len(names):]:
        ax.set_visible(False)
    ax.figure.tight_layout()
    return flat[: len(names)]


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
        plot_loglog(curves.G.sel(measurement=name).dropna("dr"), ax=ax, label=str(name),
                    linewidth=1.0)
    G = stitching.stitch(curves, threshold=threshold, warn=warn)
    return plot_loglog(G, ax=ax, error=error, label="stitched", color="k", linewidth=1.5,
                       zorder=3)


def plot(da: xr.DataArray, *, ax=None, **kwargs):
    """Plot any xrough DataArray (topography, G(dr), C(q), ...).

    Parameters
    ----------
    da : xarray.DataArray
        A topography (dims ``y, x`` or ``x``) or a result on ``dr`` / ``q``; a Dataset
        goes to :func:`plot_dataset`, a DataTree of instruments to :func:`plot_stitched`.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into (default: a new figure).
    **kwargs
        Passed to the specific plot function.

    Returns
    -------
    matplotlib.axes.Axes
    """
    if hasattr(xr, "DataTree") and isinstance(da, xr.DataTree):
        return plot_stitched(da, ax=ax, **kwargs)
    if isinstance(da, xr.Dataset):
        return plot_dataset(da, **kwargs)
    if "dr" in da.dims or "q" in da.dims or "a_c" in da.dims:
        return plot_loglog(da, ax=ax, **kwargs)
    if "x" in da.dims:
        return plot_topography(da, ax=ax, **kwargs)
    raise ValueError(f"do not know how to plot a DataArray with dims {da.dims}")
