"""Sets of measurements of one surface: one G from many, with errors a second set would give.

A folder of scans of one sample gives a stack of G (one per scan, on the same lags). Their
average is the G of all their pairs, and its error is what a second set of as many scans
would give: never less than the scatter between the scans, which xarray's own ``mean``
cannot know (it drops ``standard_error``, so the next fit would be unweighted).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from . import quality
from .acf import INFLATION, check_acf, result_attrs
from .units import accepts_quantified

__all__ = ["mean_acf"]


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
    W = w.sum(dim)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = (w * values.fillna(0.0)).sum(dim) / W
        n_eff = W**2 / (w**2).sum(dim)

        def pooled(error: xr.DataArray) -> xr.DataArray:
            e = error.reset_coords(drop=True).broadcast_like(values).fillna(0.0)
            return np.sqrt((w**2 * e**2).sum(dim)) / W

        coords = {}
        if "standard_error" in G.coords:
            se = G.coords["standard_error"]
            inflation = (G.coords[INFLATION] if INFLATION in G.coords
                         else xr.ones_like(se))
            own = pooled(se)
            gaussian = pooled(se / inflation)
            scatter = np.sqrt((w * (values - mean) ** 2).sum(dim) / W / (n_eff - 1))
            error = xr.where(n_eff > 1, np.fmax(own, scatter), own)
            coords["standard_error"] = error.assign_attrs(se.attrs)
            coords[INFLATION] = (error / gaussian).assign_attrs(
                long_name="factor of standard_error over the Gaussian finite-area error")
        if "sampling_error" in G.coords:
            coords["sampling_error"] = pooled(G.coords["sampling_error"]).assign_attrs(
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
