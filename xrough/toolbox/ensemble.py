"""Sets of measurements of one surface: a folder as one object, a table, one G from many.

A folder of scans of one sample (several instruments, a contact.engineering container)
opens as one DataTree (:func:`open_set`, a file that does not read is a line that says
why); :func:`analyse_set` gives the table contact.engineering shows, one row per scan
with its quality; the averaged G of several instruments is :func:`xrough.stitch` of the
tree. A stack of G on the same lags averages with :func:`mean_acf`: the G of all their
pairs, with an error that is what a second set of as many scans would give (never less
than the scatter between the scans, which xarray's own ``mean`` cannot know: it drops
``standard_error``, so the next fit would be unweighted).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
import xarray as xr

from .. import quality
from .. import units as u
from .._kernels.deferred import dask
from ..acf import INFLATION, check_acf, result_attrs
from ..contact import persson
from ..correlation import height_difference_acf
from ..fitting import fit_acf
from ..io import MissingOptionError, open_topography
from ..io.container import META, container_entries
from ..io.folders import measurement_files, measurement_names
from ..preprocess import detrend
from ..progress import dask_progress, progress_bar
from ..units import QuantityLike, accepts_quantified
from .parameters import roughness_parameters, scale_dependent_curvature, scale_dependent_slope
from .psd import power_spectrum

__all__ = ["mean_acf", "mean_psd", "mean_scale_dependent", "pooled_mean", "open_set",
           "open_measurement", "analyse_set"]


def pooled_mean(values: xr.DataArray, weights: xr.DataArray, dim: str,
                errors: xr.DataArray | None = None, inflation: xr.DataArray | None = None,
                *, propagated_only: bool = False) -> tuple:
    """Weighted mean over ``dim`` and its error: never below the scatter of the values.

    The one rule of :func:`mean_acf` and :func:`mean_psd`: ``mean = sum w v / sum w``; the
    error the larger of the propagated ``sqrt(sum w^2 e^2) / sum w`` and the scatter
    ``sqrt(sum w (v - mean)^2 / sum w / (n_eff - 1))``, ``n_eff = (sum w)^2 / sum w^2``
    (the propagated one alone with ``propagated_only``); the factor by which it exceeds
    the propagated Gaussian error (``errors / inflation``). NaN values have weight 0.

    Returns
    -------
    tuple
        ``(mean, error, factor)``; the last two None without ``errors``.
    """
    finite = values.notnull()
    w = xr.where(finite, weights.broadcast_like(values), 0.0).astype(float)
    W = w.sum(dim)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = (w * values.fillna(0.0)).sum(dim) / W
        if errors is None:
            return mean, None, None

        def propagated(e: xr.DataArray) -> xr.DataArray:
            e = e.reset_coords(drop=True).broadcast_like(values).fillna(0.0)
            return np.sqrt((w**2 * e**2).sum(dim)) / W

        own = propagated(errors)
        if propagated_only:
            return mean, own, None
        gaussian = propagated(errors if inflation is None else errors / inflation)
        n_eff = W**2 / (w**2).sum(dim)
        scatter = np.sqrt((w * (values - mean) ** 2).sum(dim) / W / (n_eff - 1))
        error = xr.where(n_eff > 1, np.fmax(own, scatter), own)
        return mean, error, error / gaussian


@accepts_quantified
def mean_acf(G: xr.DataArray, dim: str) -> xr.DataArray:
    r"""Average G over measurements (dim ``dim``): the G of all their pairs, with its error.

    The mean is pair-weighted (eq. 2 over the pairs of every measurement: what
    ``acf(pool=dim)`` computes from the maps themselves):
    :math:`\bar G = \sum_i n_i G_i / \sum_i n_i` with the pair counts ``n_i`` per lag
    (equal weights where G states none). Its standard error is the larger of

    - the measurements' own errors, propagated: :math:`\sqrt{\sum_i n_i^2 s_i^2}/\sum_i n_i`
      (the finite-area errors of a pooled G: ``pooled_count`` adds up, so every result
      from the mean has the errors of ``n`` maps), and
    - the scatter between the measurements,
      :math:`\sqrt{\sum_i n_i (G_i - \bar G)^2 / \sum_i n_i / (n_\mathrm{eff} - 1)}`
      with :math:`n_\mathrm{eff} = (\sum n_i)^2 / \sum n_i^2`: what a second set of as many
      measurements would give where the scans differ more than their statistics say
      (sample-to-sample variation, drift). The factor by which it exceeds the Gaussian
      error is ``error_inflation``, as the regions of one map set it.

    Parameters
    ----------
    G : xarray.DataArray
        Height-difference ACFs on ``dr`` and ``dim`` (from :func:`xrough.acf` of a stack of
        maps on the same grid, or of one lag binning).
    dim : str
        The dim of the measurements (e.g. ``"scan"``).

    Returns
    -------
    xarray.DataArray
        G on ``dr`` without ``dim``: ``pair_count`` summed, ``standard_error`` as above,
        ``error_inflation``, ``n_measurements`` (finite curves per lag), ``height_variance``
        and ``sampling_error`` pooled alike; attrs of G with ``pooled_count`` (maps in the
        mean) and ``averaged_over``. Curves rated failed are left out, questionable ones
        make the mean questionable. Lazy where G is.

    Raises
    ------
    ValueError
        ``dim`` is not an extra dim of G, or G is not a G.

    Examples
    --------
    >>> import xarray as xr, xrough
    >>> maps = [xrough.self_affine_surface(hurst=0.8, n=64, size="64 nm", rms_gradient=0.1,
    ...                                    lambda_r="16 nm", lambda_s="2 nm", unit="nm",
    ...                                    seed=s) for s in range(3)]
    >>> G = xr.concat([m.rough.acf() for m in maps], dim="scan")
    >>> mean = G.rough.mean("scan")
    >>> mean.attrs["pooled_count"], int(mean.n_measurements[0])
    (3, 3)
    """
    if dim not in G.dims or dim == "dr":
        raise ValueError(f"mean_acf: {dim!r} is not an extra dim of G (dims {G.dims})")
    # a failed measurement (all NaN) is left out, not an error: check the others
    check_acf(G if G.chunks is not None else G.dropna(dim, how="all"))
    flags = G.coords.get(quality.FLAG)
    reasons = G.coords.get(quality.REASON)
    failed = (flags == quality.level_code("failed")) if flags is not None else False
    values = G.reset_coords(drop=True).where(~failed)
    finite = values.notnull()
    count = G.coords["pair_count"] if "pair_count" in G.coords else xr.ones_like(values)
    w = xr.where(finite, count.broadcast_like(values), 0.0).astype(float)
    se = G.coords.get("standard_error")
    mean, error, factor = pooled_mean(
        values, w, dim, se, G.coords[INFLATION] if INFLATION in G.coords else None)
    coords = {}
    if se is not None:
        coords["standard_error"] = error.assign_attrs(se.attrs)
        coords[INFLATION] = factor.assign_attrs(
            long_name="factor of standard_error over the Gaussian finite-area error")
    if "sampling_error" in G.coords:
        coords["sampling_error"] = pooled_mean(
            values, w, dim, G.coords["sampling_error"], propagated_only=True)[1].assign_attrs(
            G.coords["sampling_error"].attrs)
    totals = w.sum("dr")
    if "height_variance" in G.coords:
        hv = G.coords["height_variance"].broadcast_like(totals)
        coords["height_variance"] = ((totals * hv).sum(dim) / totals.sum(dim)).assign_attrs(
            G.coords["height_variance"].attrs)
    coords["pair_count"] = (xr.where(finite, count.broadcast_like(values), 0).sum(dim)
                            .astype(np.int64).assign_attrs(
                                G.coords["pair_count"].attrs if "pair_count" in G.coords
                                else {"long_name": "number of curves"}))
    coords["n_measurements"] = finite.sum(dim).assign_attrs(
        long_name=f"measurements (along {dim}) with a finite G at this lag")
    if flags is not None and dim in flags.dims:
        kept = flags.where(~failed if isinstance(failed, xr.DataArray) else True)
        coords[quality.FLAG] = kept.max(dim).fillna(quality.level_code("failed")).astype(
            flags.dtype).assign_attrs(flags.attrs)
        if reasons is not None and dim in reasons.dims:
            bits = np.bitwise_or.reduce(reasons.values, axis=reasons.get_axis_num(dim))
            coords[quality.REASON] = xr.DataArray(bits, dims=[d for d in reasons.dims
                                                              if d != dim],
                                                  attrs=reasons.attrs)
    n_maps = int(G.sizes[dim]) * int(G.attrs.get("pooled_count", 1))
    out = mean.assign_coords(coords)
    out = out.assign_coords({c: v for c, v in G.coords.items()
                             if dim not in v.dims and c not in out.coords
                             and "dr" not in v.dims})
    out.attrs = result_attrs(G, **{k: v for k, v in G.attrs.items()
                                   if k not in ("quality", "quality_notes")},
                             pooled_count=n_maps, averaged_over=str(dim))
    for key in ("quality", "quality_notes"):
        if key in G.attrs:
            out.attrs[key] = G.attrs[key]
    out.name = G.name
    return out


def _topographies(measurements, unit: str | None, what: str) -> tuple[dict, str]:
    """Return the topographies (a DataTree of :func:`open_set`, or a mapping) and a unit.

    The unit is the result's lateral one: ``unit``, else the first measurement's.
    """
    if isinstance(measurements, xr.DataTree):
        topos = {str(n): measurements[n].to_dataset()["heights"]
                 for n in measurements.children if "heights" in measurements[n].data_vars}
    else:
        topos = {str(k): v for k, v in dict(measurements).items()}
    if not topos:
        raise ValueError(f"{what}: no measurement")
    first = next(iter(topos.values()))
    return topos, unit or u.format_units(u.units_of(first.coords["x"],
                                                    what="coordinate 'x'"))


def _on_common_bins(curves: list[tuple], points_per_decade: float, dim: str) -> tuple:
    """Put curves of several measurements on common log bins and pool them bin by bin.

    ``curves``: ``(x, values, errors, weights)`` per measurement, ``x`` in one unit (> 0);
    a point belongs to the bin ``rint(log10(x) * points_per_decade)``, the same in every
    unit of one decade's multiples, and points of one curve sharing a bin merge
    (weighted). Returns ``(x, values, weights, mean, error)``: the weighted mean ``x`` of
    each bin, the stacked values and weights (measurement, bin) and
    :func:`pooled_mean`'s mean and error over the measurements.
    """
    keyed = [np.rint(np.log10(c[0]) * points_per_decade).astype(int) for c in curves]
    keys = np.unique(np.concatenate(keyed))
    shape = (len(curves), keys.size)
    sums = {k: np.zeros(shape) for k in ("w", "wx", "wv", "wwe")}
    for i, ((x, v, e, w), key) in enumerate(zip(curves, keyed)):
        ok = np.isfinite(v) & (w > 0)
        at = np.searchsorted(keys, key[ok])
        for name, term in (("w", w[ok]), ("wx", w[ok] * x[ok]), ("wv", w[ok] * v[ok]),
                           ("wwe", (w[ok] * np.nan_to_num(e[ok])) ** 2)):
            np.add.at(sums[name][i], at, term)
    w = sums["w"]
    with np.errstate(invalid="ignore", divide="ignore"):
        values = np.where(w > 0, sums["wv"] / w, np.nan)
        errors = np.where(w > 0, np.sqrt(sums["wwe"]) / w, np.nan)
        x = sums["wx"].sum(axis=0) / w.sum(axis=0)
    dims = ("measurement", dim)
    mean, error, _ = pooled_mean(xr.DataArray(values, dims=dims), xr.DataArray(w, dims=dims),
                                 "measurement", xr.DataArray(np.nan_to_num(errors), dims=dims))
    return x, values, w, mean, error


@accepts_quantified
def mean_psd(measurements, *, unit: str | None = None, points_per_decade: float = 20,
             window: str | None = "auto") -> xr.DataArray:
    """Average the PSD of several measurements (any grids, units, instruments) bin by bin.

    Each measurement's :func:`xrough.power_spectrum` on the same log bins (centred on
    ``10^(k / points_per_decade)`` in every unit, so the bins of maps in nm and in um
    coincide once converted), in one unit; then per bin the mode-weighted mean over the
    measurements that hold it, with :func:`pooled_mean`'s error (never below their
    scatter). Maps give the isotropic 2D spectrum; with a profile among them, every map
    gives the 1D spectrum of its lines along ``x`` instead (the two are different
    quantities, length^4 and length^3). contact.engineering's averaged PSD.

    Parameters
    ----------
    measurements : xarray.DataTree or mapping of DataArray
        From :func:`open_set`, or topographies by name (detrend them first: the PSD of a
        tilt leaks into every bin).
    unit : str, optional
        The lateral unit of the result (default: the first measurement's).
    points_per_decade : float
        The log bins' density.
    window : str or None
        As :func:`xrough.power_spectrum`.

    Returns
    -------
    xarray.DataArray
        ``C`` on ``q`` (``unit``-1; the mode-weighted mean ``|q|`` of the bin), with
        ``standard_error``, ``n_modes`` (summed) and ``n_measurements`` (holding the bin).

    Examples
    --------
    >>> import xrough
    >>> maps = {f"s{k}": xrough.self_affine_surface(hurst=0.8, n=64, size="64 nm",
    ...             lambda_r="32 nm", lambda_s="2 nm", rms_gradient=0.1, unit="nm",
    ...             seed=k) for k in range(3)}
    >>> C = xrough.mean_psd(maps)
    >>> C.attrs["units"], int(C.n_measurements.max())
    ('nm4', 3)
    """
    topos, target = _topographies(measurements, unit, "mean_psd")
    profiles = any("y" not in t.dims for t in topos.values())
    power = 3 if profiles else 4
    curves = []
    for topo in topos.values():
        spec = power_spectrum(topo, direction="x" if profiles else "radial", window=window,
                              points_per_decade=points_per_decade)
        fq = u.conversion_factor(u.units_of(spec.coords["q"], what="q"),
                                 u.power_units(target, -1))
        fc = u.conversion_factor(spec.attrs["units"], u.power_units(target, power))
        err = (spec.coords["standard_error"].values * fc if "standard_error" in spec.coords
               else np.full(spec.q.size, np.nan))
        curves.append((spec.q.values * fq, spec.values * fc, err, spec.n_modes.values))
    q, C, n, mean, error = _on_common_bins(curves, points_per_decade, "q")
    kind = "1D along x" if profiles else "isotropic 2D"
    return mean.assign_coords(
        q=("q", q, {"units": u.power_units(target, -1),
                    "long_name": "angular wavenumber (mode-weighted mean)"}),
        standard_error=("q", error.values, {"units": u.power_units(target, power)}),
        n_modes=("q", n.sum(axis=0).astype(np.int64), {"long_name": "modes in the bin"}),
        n_measurements=("q", np.isfinite(C).sum(axis=0), {
            "long_name": "measurements holding the bin"}),
    ).assign_attrs(result_attrs(
        None, units=u.power_units(target, power), long_name=f"averaged PSD ({kind})",
        spectrum_kind=kind, averaged_from=", ".join(topos), points_per_decade=float(
            points_per_decade))).rename("C")


#: The scale-dependent analyses :func:`mean_scale_dependent` averages, and their powers of
#: the lateral unit.
_SCALE_DEPENDENT = {"slope": (scale_dependent_slope, 0, "pair_count"),
                    "curvature": (scale_dependent_curvature, -1, "point_count")}


@accepts_quantified
def mean_scale_dependent(measurements, quantity: str = "slope", *, unit: str | None = None,
                         points_per_decade: float = 10) -> xr.DataArray:
    """Average the scale-dependent slope or curvature of several measurements step by step.

    Each measurement's :func:`xrough.scale_dependent_slope` (or ``_curvature``) on its
    own whole-pixel steps, in one lateral unit; the steps fall into log bins centred on
    ``10^(k / points_per_decade)`` (the same in nm and um), and per bin the mean weighted
    by the differences each measurement averaged. contact.engineering's averaged
    scale-dependent slope and curvature (its "SDRP"); :func:`mean_psd` and
    :func:`mean_acf` are the same average of the PSD and of G.

    The rms values of a bin are averaged, not their squares: where scans differ, the mean
    of the rms slopes is at most the rms of the pooled differences (by less than the
    scatter, ``standard_error``).

    Parameters
    ----------
    measurements : xarray.DataTree or mapping of DataArray
        From :func:`open_set`, or topographies by name (maps and profiles alike: a
        profile's slope is along it, a map's the rms gradient, see
        :func:`xrough.scale_dependent_slope`; mix them knowingly).
    quantity : {'slope', 'curvature'}
        The analysis.
    unit : str, optional
        Lateral unit of the result (default: the first measurement's).
    points_per_decade : float
        Density of the steps and of the common bins.

    Returns
    -------
    xarray.DataArray
        ``slope`` (``1``) or ``curvature`` (``unit``-1) on ``dr`` (``unit``, the weighted
        mean step of the bin), with ``standard_error`` (the scatter between the
        measurements, :func:`pooled_mean`; NaN where fewer than two hold the bin),
        ``n_measurements`` and the summed ``pair_count`` / ``point_count``.

    Raises
    ------
    ValueError
        No measurement, or an unknown ``quantity``.

    Examples
    --------
    >>> import xrough
    >>> nm = xrough.self_affine_surface(hurst=0.8, n=64, size="64 nm", lambda_r="32 nm",
    ...                                 lambda_s="4 nm", rms_gradient=0.1, unit="nm")
    >>> um = xrough.convert_units(nm, "um", lateral="um")  # the same scan in um
    >>> s = xrough.mean_scale_dependent({"nm": nm, "um": um}, "curvature", unit="um")
    >>> s.attrs["units"], int(s.n_measurements[0]), float(s.standard_error[0]) < 1e-9
    ('um-1', 2, True)
    """
    if quantity not in _SCALE_DEPENDENT:
        raise ValueError(f"mean_scale_dependent: quantity {quantity!r} is not one of "
                         f"{sorted(_SCALE_DEPENDENT)}")
    analysis, power, count = _SCALE_DEPENDENT[quantity]
    topos, target = _topographies(measurements, unit, "mean_scale_dependent")
    curves = []
    for topo in topos.values():
        with quality.quiet():  # a tip check's marks are the measurement's own
            curve = analysis(topo, points_per_decade=points_per_decade)
        fx = u.conversion_factor(u.units_of(curve.coords["dr"], what="dr"), target)
        fv = (1.0 if power == 0 else
              u.conversion_factor(curve.attrs["units"], u.power_units(target, power)))
        curves.append((curve.dr.values * fx, curve.values * fv,
                       np.zeros(curve.dr.size), curve.coords[count].values.astype(float)))
    dr, values, w, mean, error = _on_common_bins(curves, points_per_decade, "dr")
    held = np.isfinite(values).sum(axis=0)
    units = "1" if power == 0 else u.power_units(target, power)
    return mean.assign_coords(
        dr=("dr", dr, {"units": target, "long_name": "finite-difference step (weighted mean "
                                                     "of the bin)"}),
        standard_error=("dr", np.where(held > 1, error.values, np.nan), {
            "units": units, "long_name": "scatter of the measurements' values"}),
        n_measurements=("dr", held, {"long_name": "measurements holding the bin"}),
        **{count: ("dr", w.sum(axis=0).astype(np.int64), {
            "long_name": "differences averaged (all measurements)"})},
    ).assign_attrs(result_attrs(
        None, units=units, long_name=f"averaged scale-dependent rms {quantity}",
        averaged_from=", ".join(topos), points_per_decade=float(points_per_decade))
    ).rename(quantity)


# ------------------------------------------------------------------------------ a folder

#: The options of :func:`xrough.open_topography` a container's entry can supply, and how.
_CONTAINER_OPTIONS = ("unit", "size")


def open_measurement(path: str | Path, **options) -> xr.DataArray:
    """Open one file as :func:`xrough.open_topography` does, what it lacks from its container.

    A file that states no unit or size (:class:`~xrough.io.MissingOptionError`) takes
    them from the ``meta.yml`` of a contact.engineering container beside it, when that
    lists the file (``unit``, ``size``; a size given ``(x, y)`` there becomes ``(y, x)``);
    the options given here always win.

    Raises
    ------
    MissingOptionError
        The file lacks what neither the options nor a container supply.
    """
    path = Path(path)
    try:
        return open_topography(path, **options)
    except MissingOptionError as err:
        entry = next((e for e in container_entries(path.parent / META)
                      if e["file"] == path.name), None)
        given = {k: entry[k] for k in _CONTAINER_OPTIONS
                 if entry and k in err.options and entry.get(k) is not None
                 and options.get(k) is None}
        if not given:
            raise
        if "size" in given and isinstance(given["size"], (list, tuple)):
            size = tuple(float(v) for v in given["size"])[::-1]  # (x, y) -> (y, x)
            given["size"] = size[0] if len(size) == 1 else size
        return open_topography(path, **{**options, **given})


def open_set(source: str | Path | Iterable[str | Path], *, keep_going: bool = True,
             progress: bool | None = None, **open_kwargs) -> xr.DataTree:
    """Open a folder of measurements (or a list of files) as one DataTree.

    Parameters
    ----------
    source : str, Path or list of them
        A folder (its measurement files: :func:`xrough.io.folders.measurement_files`;
        a contact.engineering container's ``meta.yml`` says which, and supplies the unit
        or size a file does not state), or the files themselves.
    keep_going : bool
        A file that does not read is left out and said why (root attr ``failed``: one
        line ``name: reason`` each); False raises at the first. A non-uniformly sampled
        profile is resampled onto as many uniform points (``resample=True`` of
        :func:`xrough.open_topography`; its attrs ``sampling`` and ``resampling`` say
        so) unless ``resample`` is given.
    progress : bool or None
        A progress bar over the files (None: in an interactive terminal only).
    **open_kwargs
        Passed to :func:`xrough.open_topography` for every file (``unit=``, ``channel=``).

    Returns
    -------
    xarray.DataTree
        One node per file that reads, named by its stem
        (:func:`xrough.io.folders.measurement_names`), holding ``heights``; root attrs
        ``source``, ``n_files`` and ``failed``. ``tree.rough.acf()`` stitches their G
        (:func:`xrough.stitch`), :func:`analyse_set` tabulates them.

    Raises
    ------
    ValueError
        A folder with no measurement file, no file that reads, or (``keep_going=False``)
        the first file that does not.

    Examples
    --------
    >>> import tempfile, pathlib, xrough
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> for seed in (1, 2):
    ...     xrough.self_affine_surface(hurst=0.8, n=64, size="64 nm", lambda_r="32 nm",
    ...                                lambda_s="2 nm", rms_gradient=0.1, unit="nm",
    ...                                seed=seed).to_netcdf(d / f"scan{seed}.nc")
    >>> _ = (d / "broken.nc").write_bytes(b"CDF" + bytes(4))
    >>> tree = xrough.open_set(d)
    >>> sorted(tree.children), tree.attrs["failed"].split(":")[0]
    (['scan1', 'scan2'], 'broken')
    """
    if isinstance(source, (str, Path)):
        folder = Path(source)
        paths = measurement_files(folder)
        where = str(folder)
    else:
        paths = [Path(p) for p in source]
        where = ", ".join(str(p) for p in paths)
    names = measurement_names(paths)
    nodes: dict[str, xr.Dataset] = {}
    failed: list[str] = []
    for path, name in progress_bar(desc="files", iterable=list(zip(paths, names)),
                                   progress=progress):
        try:
            topo = open_measurement(path, **open_kwargs)
            if topo.attrs.get("sampling") == "non-uniform" and "resample" not in open_kwargs:
                # every estimator needs a uniform grid: as the file's own points, linearly
                # (the attrs 'sampling' and 'resampling' say so)
                topo = open_measurement(path, **open_kwargs, resample=True)
        except (ValueError, OSError, KeyError, TypeError) as err:
            if not keep_going:
                raise
            reason = str(err).splitlines()[0] if str(err) else type(err).__name__
            failed.append(f"{name}: {reason}")
            continue
        nodes[name] = topo.to_dataset(name="heights", promote_attrs=False)
    if not nodes:
        raise ValueError(f"{where}: no file could be read: " + "; ".join(failed))
    root = xr.Dataset(attrs={"source": where, "n_files": len(paths),
                             "failed": "\n".join(failed)})
    return xr.DataTree.from_dict({"/": root, **nodes})


#: The columns of :func:`analyse_set` from the fit of G.
_FIT_COLUMNS = ("hurst", "hurst_std", "sigma_h", "sigma_h_std", "lambda_r", "lambda_r_std")


@accepts_quantified
def analyse_set(tree: xr.DataTree, *, mode: str = "plane",
                E_star: QuantityLike | None = None, p0: QuantityLike | None = None,
                points_per_decade: float = 10, progress: bool | None = None,
                scheduler: str | None = None) -> xr.Dataset:
    """Tabulate a set of measurements: one row per file, as contact.engineering shows it.

    For each measurement of :func:`open_set`: detrend (``mode``), G, its fit, the
    roughness parameters and, with ``E_star`` and ``p0``, Persson theory's contact area
    at the finest lag that determines it. A measurement that fails is a row with its
    ``error`` and NaN numbers; the files that did not read are rows too.

    Parameters
    ----------
    tree : xarray.DataTree
        From :func:`open_set` (nodes holding ``heights``).
    mode : {'mean', 'plane', 'curvature'}
        :func:`xrough.detrend` before G.
    E_star, p0 : float, str or Quantity, optional
        Contact modulus and pressure for the contact-area column (Pa for numbers).
    points_per_decade : float
        G's log bins.
    progress : bool or None
        A progress bar over the measurements.
    scheduler : str, optional
        dask's scheduler for the rows, one task each (``"threads"``, ``"processes"``,
        ``"sync"``; default dask's configured one, or a distributed client's).

    Returns
    -------
    xarray.Dataset
        On dim ``measurement``: ``file``, ``quality`` (worst of G, fit and Persson
        theory), ``notes``, ``error``; ``hurst``, ``sigma_h``, ``lambda_r`` with their
        ``_std`` (in each row's units converted to the first measurement's); every
        parameter of :func:`xrough.roughness_parameters` (``S...`` of maps, ``R...`` of
        profiles, NaN where not applicable); ``a_r`` and ``a_r_dr`` with ``E_star`` and
        ``p0``. The stitched G of all of them is ``xrough.stitch(tree)``.

    Examples
    --------
    >>> import tempfile, pathlib, xrough
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> for seed in (1, 2):
    ...     xrough.self_affine_surface(hurst=0.8, n=256, size="256 nm", lambda_r="64 nm",
    ...                                lambda_s="2 nm", rms_gradient=0.1, unit="nm",
    ...                                seed=seed).to_netcdf(d / f"scan{seed}.nc")
    >>> table = xrough.analyse_set(xrough.open_set(d))
    >>> table.sizes["measurement"], table.Sq.attrs["units"], table.quality.values.tolist()
    (2, 'nm', ['good', 'good'])
    """
    names = [n for n in tree.children if "heights" in tree[n].data_vars]
    failed = [line.split(": ", 1) for line in str(tree.attrs.get("failed", "")).splitlines()
              if ": " in line]
    tasks = [dask.delayed(_row, pure=False)(  # pure: dask would hash every map
        name, tree[name].to_dataset()["heights"], mode, E_star, p0, points_per_decade)
        for name in names]
    with dask_progress(desc="measurements", progress=progress):
        rows = list(dask.compute(*tasks, scheduler=scheduler))
    rows += [{"measurement": n, "file": "", "quality": "failed", "notes": "",
              "error": reason} for n, reason in failed]
    table = _table(rows)
    flagged = [r["measurement"] for r in rows if r["quality"] != "good"]
    if flagged:
        quality.warn(f"analyse_set: {len(flagged)} of {len(rows)} measurements are not good "
                     f"({', '.join(flagged[:5])}{', ...' if len(flagged) > 5 else ''}): "
                     "the table's columns quality, notes and error say why",
                     quality.QualityWarning)
    return table


def _row(name: str, topo: xr.DataArray, mode: str, E_star, p0,
         points_per_decade: float) -> dict:
    """Compute a row of :func:`analyse_set`: numbers as ``(value, unit)`` pairs."""
    row: dict = {"measurement": name, "file": str(topo.attrs.get("source_file", "")),
                 "error": ""}
    try:
        with quality.quiet(), quality.recorded() as notes:  # the row says them
            clean = detrend(topo, mode=mode)
            G = height_difference_acf(clean, points_per_decade=points_per_decade)
            fit = fit_acf(G)
            params = roughness_parameters(clean)
            results = [G, fit]
            if E_star is not None and p0 is not None:
                # the fit once; the one variable the table shows
                contact = persson(G, E_star=E_star, p0=p0, fit=fit, variables=("a_r",))
                results.append(contact)
                finite = np.flatnonzero(np.isfinite(contact.a_r.values))
                if finite.size:
                    at = contact.isel(dr=int(finite[0]))
                    row["a_r"] = (float(at.a_r), "1")
                    row["a_r_dr"] = (float(at.dr), at.dr.attrs["units"])
        row["quality"] = quality.worst(*results)
        row["notes"] = "; ".join(dict.fromkeys(str(message).splitlines()[0]
                                               for message, _ in notes))
        for key in _FIT_COLUMNS:
            if key in fit.data_vars:
                row[key] = (float(fit[key]), fit[key].attrs.get("units", "1"))
        for name_, var in params.data_vars.items():
            row[str(name_)] = (float(var), var.attrs.get("units", "1"))
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as err:
        row.update(quality="failed", notes="", error=str(err).splitlines()[0])
    return row


def _table(rows: list[dict]) -> xr.Dataset:
    """Build the Dataset of the rows on ``measurement`` (NaN or "" where a row has none).

    A number is a ``(value, unit)`` pair; each column takes the unit of its first row, the
    others converted to it.
    """
    keys = list(dict.fromkeys(k for r in rows for k in r if k != "measurement"))
    data: dict[str, tuple] = {}
    for key in keys:
        pairs = [r[key] for r in rows if isinstance(r.get(key), tuple)]
        if pairs:
            unit = pairs[0][1]
            values = [r[key][0] * (u.conversion_factor(r[key][1], unit)
                                   if r[key][1] != unit else 1.0)
                      if isinstance(r.get(key), tuple) else np.nan for r in rows]
            data[key] = ("measurement", np.array(values, dtype=float), {"units": unit})
        else:
            data[key] = ("measurement", np.array([str(r.get(key, "")) for r in rows]))
    return xr.Dataset(data, coords={"measurement": [r["measurement"] for r in rows]},
                      attrs=result_attrs(None, long_name="one row per measurement"))
