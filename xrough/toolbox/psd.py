"""The power spectral density of a topography: ``C(q)`` from the heights (eq. 4).

:func:`power_spectrum` is the periodogram of the heights, the estimate of
``C(q) = A <|h~(q)|^2>`` that SurfaceTopography (contact.engineering), Gwyddion and xrft
compute: radially averaged over the modes of a map (the isotropic ``C(q)`` of the paper,
in length^4, directly comparable with :func:`xrough.spectrum` of G and with
:func:`xrough.model_spectrum`), or the 1D spectrum of a profile or of the lines of a map
(length^3). The numerics are in :mod:`xrough._kernels.psd`; the method, the windows, the
missing points and a comparison with ``spectrum(G)`` are in docs/psd.md.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from .. import quality
from .. import units as u
from .._kernels.binning import check_points_per_decade, linear_bin_edges, log_bins
from .._kernels.checks import require_increasing
from .._kernels.psd import (
    WINDOWS,
    error_factors,
    mode_bins,
    mode_range,
    psd2d_kernel,
    psd_kernel,
)
from ..acf import result_attrs
from ..topography import Grid, check_valid_points, grid_of, require_whole_maps
from ..units import QuantityLike

__all__ = ["power_spectrum", "power_spectrum_2d", "spectral_moment", "MIN_VALID_FRACTION",
           "WINDOWS"]

#: A map with fewer valid points than this fraction gives a questionable spectrum.
MIN_VALID_FRACTION = 0.9

#: ``(spectrum_kind, long_name, estimator)`` per geometry.
_KINDS = {
    "radial": ("isotropic 2D", "isotropic height spectrum",
               "FFT periodogram, averaged over the modes of each |q| bin"),
    "x": ("1D along x", "height spectrum of the lines along x",
          "FFT periodogram of each line along x, pooled over the lines"),
    "y": ("1D along y", "height spectrum of the lines along y",
          "FFT periodogram of each line along y, pooled over the lines"),
    "profile": ("1D", "height spectrum of the profile", "FFT periodogram of the profile"),
}


@u.accepts_quantified
def power_spectrum(
    topography: xr.DataArray,
    *,
    direction: str = "radial",
    window: str | None = "auto",
    bins: str | QuantityLike = "log",
    points_per_decade: float = 20,
    bin_width: QuantityLike | None = None,
    workers: int | None = None,
) -> xr.DataArray:
    r"""Power spectral density ``C(q)`` of the heights of a topography (eq. 4).

    The periodogram of ``C(q) = A <|h~(q)|^2>``, per mode ``q = 2 pi k / L`` ``C = dA |sum w m
    (h - mu) e^{-i q.r}|^2 / sum w^2 m`` (mask ``m``, window ``w``), averaged over bins of ``|q|``
    as SurfaceTopography does.  Notes (formula, Parseval, missing points, bin averages, windows,
    all outputs, examples): docs/psd.md, "power_spectrum in detail".

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        Heights with length units on data and coordinates (:func:`xrough.topography`); NaN
        marks missing points.  Extra dims give one spectrum each (dask: one task per map).
    direction : {'radial', 'x', 'y'}
        ``'radial'``: rings of ``|q|`` of the 2D modes (length^4); ``'x'``, ``'y'``: the 1D
        spectra of the lines along that axis, pooled (length^3).  A profile: its 1D spectrum.
    window : {'auto', 'hann', 'hamming', 'blackman', 'blackmanharris', None}
        Window against edge leakage (separable; power normalised away): ``'auto'`` is None
        for a periodic topography and ``'hann'`` otherwise.
    bins : {'log', 'linear'} or array_like
        Log bins centred on ``10**(k / points_per_decade)``, linear bins of ``bin_width``, or
        edges (angular wavenumbers in the inverse lateral unit); empty bins are dropped.
    points_per_decade : float
        Bins per decade for ``bins='log'`` (0 < ... <= 1000); 20 keeps the bias below 1 %.
    bin_width : float, str or pint.Quantity, optional
        Width of linear bins (inverse lateral unit); default ``2 pi / L`` of the longest side.
    workers : int, optional
        FFT threads (default: all cores).

    Returns
    -------
    xarray.DataArray
        ``C`` on dim ``"q"`` (mean ``|q|`` of a bin, inverse lateral unit), in the lateral
        unit^4 (``'radial'``) or ^3 (lines, profiles); coords ``n_modes``, ``bin_measure``
        (``(C * C.bin_measure).sum("q")`` is the variance), ``standard_error``,
        ``valid_fraction`` and ``quality_flag`` (below :data:`MIN_VALID_FRACTION`).

    Raises
    ------
    TypeError
        ``topography`` is not a DataArray.
    ValueError
        An invalid topography, chunked ``y``/``x``, or an invalid option or bin edges.

    See Also
    --------
    xrough.spectrum : ``C(q)`` from G by eq. 10/11 (plot both on one axes: docs/psd.md).
    xrough.model_spectrum : the model spectrum of eq. 35.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> h = np.random.default_rng(0).normal(size=(128, 128))
    >>> topo = xrough.topography(h, spacing="2 nm", unit="nm", periodic=True)
    >>> C = topo.rough.psd()
    >>> C.attrs["units"], C.q.attrs["units"], C.attrs["window"]
    ('nm4', 'nm-1', 'none')
    >>> variance = float((C * C.bin_measure).sum("q"))
    >>> print(f"{variance:.12f} nm2 = variance {float(h.var()):.12f} nm2")
    0.992257930562 nm2 = variance 0.992257930562 nm2
    """
    grid = grid_of(topography)
    kind = _kind(direction, grid)
    name = _window(window, grid)
    ppd = check_points_per_decade(points_per_decade)
    if bin_width is not None and not (isinstance(bins, str) and bins == "linear"):
        raise ValueError("bin_width applies to bins='linear' only")
    require_whole_maps(topography, grid, purpose="the power spectrum")
    if topography.chunks is None:
        check_valid_points(np.asarray(topography.transpose(..., *grid.dims).values),
                           ndim=len(grid.dims))
    shape, spacing = _transformed(grid, kind)
    edges = _edges(shape, spacing, grid, bins, ppd, bin_width)
    _, n_modes, q_mean, _ = mode_bins(shape, spacing, tuple(edges))
    if n_modes.size == 0:
        raise ValueError(f"no Fourier mode of the topography lies in the bins (its modes "
                         f"run from {mode_range(shape, spacing)[0]:.4g} to "
                         f"{mode_range(shape, spacing)[1]:.4g} "
                         f"{u.power_units(grid.lateral_unit, -1)})")
    nb = n_modes.size
    packed = xr.apply_ufunc(
        psd_kernel, topography, input_core_dims=[list(grid.dims)],
        output_core_dims=[["packed"]], dask="parallelized", output_dtypes=[float],
        dask_gufunc_kwargs={"output_sizes": {"packed": nb + 2}}, keep_attrs=False,
        kwargs={"direction": kind, "spacing": grid.spacing, "window": name,
                "edges": tuple(edges), "workers": workers})
    factors = (error_factors(shape, spacing, tuple(edges), name)
               if kind in ("radial", "profile") else None)
    return _result(topography, grid, packed, kind=kind, window=name, n_modes=n_modes,
                   q=q_mean, area=float(np.prod(np.multiply(shape, spacing))),
                   bins=bins, ppd=ppd, edges=edges, factors=factors)


def _kind(direction: str, grid: Grid) -> str:
    """Return the geometry of the transform: ``'radial'``, ``'x'``, ``'y'`` or ``'profile'``."""
    if direction not in ("radial", "x", "y"):
        raise ValueError(f"direction must be 'radial', 'x' or 'y', got {direction!r}")
    if len(grid.dims) == 1:
        if direction == "y":
            raise ValueError("a profile (dims ('x',)) has no direction 'y'")
        return "profile"
    return direction


def _window(window, grid: Grid) -> str | None:
    """Return the window (None: none): for 'auto', none if periodic, else Hann."""
    if isinstance(window, str) and window == "auto":
        return None if grid.periodic else "hann"
    if window is None or (isinstance(window, str) and window in WINDOWS):
        return window
    raise ValueError(f"window must be 'auto', None or one of {WINDOWS}, got {window!r}")


def _transformed(grid: Grid, kind: str) -> tuple[tuple[int, ...], tuple[float, ...]]:
    """Shape and spacing of the transformed axes (both of a map, or one axis)."""
    if kind == "radial":
        return grid.shape, grid.spacing
    axis = grid.dims.index("y" if kind == "y" else "x")
    return (grid.shape[axis],), (grid.spacing[axis],)


def _edges(shape, spacing, grid: Grid, bins, ppd: float, bin_width) -> np.ndarray:
    """Bin edges in ``|q|`` (inverse lateral unit); the defaults hold every mode but 0."""
    q_unit = u.power_units(grid.lateral_unit, -1)
    q_lo, q_hi = mode_range(shape, spacing)
    if isinstance(bins, str) and bins == "log":  # 1e-9 keeps the extreme modes inside
        return log_bins(q_lo * (1 - 1e-9), q_hi * (1 + 1e-9), ppd)[1]
    if isinstance(bins, str) and bins == "linear":
        width = q_lo
        if bin_width is not None:
            given = u.array_in(bin_width, q_unit, what="bin_width", noun="wavenumbers",
                               positive=True)
            if given.size != 1:
                raise ValueError(f"bin_width must be one wavenumber, got {bin_width!r}")
            width = float(given[0])
        return linear_bin_edges(0.5 * width, q_hi + width, width)
    if isinstance(bins, str):
        raise ValueError(f"bins must be 'log', 'linear' or an array of edges, got {bins!r}")
    edges = u.array_in(bins, q_unit, what="bins", noun="bin edges")
    return require_increasing(edges, "bins", allow_zero=True, min_size=2,
                              noun="bin edges (angular wavenumbers)")


def _result(topography, grid: Grid, packed: xr.DataArray, *, kind, window, n_modes, q,
            area, bins, ppd, edges, factors) -> xr.DataArray:
    """Label the packed output of the kernel: ``C`` on ``q`` with its coords and attrs."""
    nb = n_modes.size
    lateral = grid.lateral_unit
    power = 4 if kind == "radial" else 3
    c_unit = u.power_units(lateral, power)
    factor = u.conversion_factor(grid.height_unit, lateral) ** 2  # heights in lateral unit
    C = packed.isel(packed=slice(0, nb)).rename(packed="q") * factor
    along = "" if kind in ("radial", "profile") else f" along {kind}"
    coords: dict[str, Any] = {
        "q": ("q", q, {"units": u.power_units(lateral, -1),
                       "long_name": f"angular wavenumber{along}"}),
        "n_modes": ("q", n_modes, {"units": "1", "long_name":
                                   "number of Fourier modes in the bin (+q and -q apart)"}),
        "bin_measure": ("q", n_modes / area, {
            "units": u.power_units(lateral, -(power - 2)),
            "long_name": "q-space measure of the bin (n_modes / area, or / length for "
                         "lines): sum(C * bin_measure) is the variance"}),
    }
    if factors is not None:  # Gaussian modes: sqrt(2 f g / n) (error_factors, psd_kernel)
        rel = (xr.DataArray(np.sqrt(2.0 * factors / n_modes), dims="q")
               * np.sqrt(packed.isel(packed=nb, drop=True)))
        coords["standard_error"] = (C * rel).assign_attrs(
            units=c_unit, long_name="standard error of C")
    valid = packed.isel(packed=-1, drop=True).assign_attrs(
        units="1", long_name="fraction of valid (non-NaN) points")
    coords["valid_fraction"] = valid
    C = C.assign_coords(coords)
    C.name = "C"
    kind_name, long_name, estimator = _KINDS[kind]
    q_axes = [mode_range((n,), (d,))[1] for n, d in zip(grid.shape, grid.spacing)]
    log = isinstance(bins, str) and bins == "log"
    linear = isinstance(bins, str) and bins == "linear"
    C.attrs = result_attrs(
        topography,
        units=c_unit,
        long_name=long_name,
        symbol="C",
        equation="eq. 4: C(q) = A <|h~(q)|^2>",
        estimator=estimator,
        spectrum_kind=kind_name,
        direction="x" if kind == "profile" else kind,
        window="none" if window is None else window,
        periodic=int(grid.periodic),
        bins=bins if isinstance(bins, str) else "explicit",
        **({"points_per_decade": float(ppd)} if log else {}),
        **({"bin_width": float(edges[1] - edges[0])} if linear else {}),
        pixel_size=float(min(grid.spacing)),
        scan_size=float(max(grid.size)),
        q_nyquist=float(min(q_axes) if kind == "radial" else
                        q_axes[grid.dims.index("y" if kind == "y" else "x")]),
        source=str(topography.attrs.get("source", topography.name or "")),
    )
    codes = xr.where(valid < MIN_VALID_FRACTION, 1, 0)
    note = (f"fewer than {MIN_VALID_FRACTION:.0%} of the points are valid "
            "(coordinate valid_fraction): the missing points are part of the spectral "
            "window; if they are scattered, C is low by about the missing fraction where "
            "it is large and has a floor of about (missing fraction) sigma_h^2 dA where "
            "it is small (docs/psd.md)")
    return quality.mark_curves(C, codes, what="power_spectrum",
                               reason="few_valid_points", notes=note)


@u.accepts_quantified
def power_spectrum_2d(topography: xr.DataArray, *, window: str | None = "auto",
                      workers: int | None = None) -> xr.DataArray:
    r"""Compute the periodogram ``C(q_x, q_y)`` of a map, mode by mode (no ring average).

    The definition of :func:`power_spectrum` (eq. 4, its window and missing points) on
    every Fourier mode: ``C`` on ``(qy, qx)``, angular wavenumbers ``2 pi k / L`` with
    ``q = 0`` in the middle. What anisotropy, a texture or any kernel of the two
    components needs (:func:`spectral_moment`); its averages over rings of ``|q|`` are
    :func:`power_spectrum`'s radial bins.

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x")
        A map (not a profile) with units; extra dims give one spectrum each (lazy on
        dask, one map per chunk).
    window, workers
        As :func:`power_spectrum`.

    Returns
    -------
    xarray.DataArray
        ``C`` (lateral unit^4) on ``qy``, ``qx`` (inverse lateral unit), attrs as a
        radial spectrum's plus ``mode_measure`` (``1 / A``: ``(C * mode_measure).sum()``
        is the variance of the heights, Parseval).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> h = np.random.default_rng(0).normal(size=(64, 64))
    >>> topo = xrough.topography(h, spacing="2 nm", unit="nm", periodic=True)
    >>> C = xrough.power_spectrum_2d(topo)
    >>> C.dims, C.attrs["units"]
    (('qy', 'qx'), 'nm4')
    >>> bool(np.isclose(float((C * C.attrs["mode_measure"]).sum()), h.var()))
    True
    """
    grid = grid_of(topography)
    if len(grid.dims) != 2:
        raise ValueError("power_spectrum_2d needs a map (dims ('y', 'x')); a profile has "
                         "its 1D spectrum: power_spectrum(profile)")
    name = _window(window, grid)
    require_whole_maps(topography, grid, purpose="the power spectrum")
    if topography.chunks is None:
        check_valid_points(np.asarray(topography.transpose(..., *grid.dims).values), ndim=2)
    factor = u.conversion_factor(grid.height_unit, grid.lateral_unit)
    C = xr.apply_ufunc(
        psd2d_kernel, topography * factor, input_core_dims=[list(grid.dims)],
        output_core_dims=[["qy", "qx"]], dask="parallelized", output_dtypes=[float],
        dask_gufunc_kwargs={"output_sizes": dict(zip(("qy", "qx"), grid.shape))},
        kwargs={"spacing": grid.spacing, "window": name,
                "workers": workers}, keep_attrs=False)
    inverse = u.power_units(grid.lateral_unit, -1)
    coords = {}
    for dim, n, d in zip(("qy", "qx"), grid.shape, grid.spacing):
        q = 2 * np.pi * np.fft.fftshift(np.fft.fftfreq(n, d))
        coords[dim] = (dim, q, {"units": inverse,
                                "long_name": f"angular wavenumber along {dim[1]}"})
    area = float(np.prod(grid.size))
    out = C.assign_coords(coords)
    out.attrs = result_attrs(
        topography, units=u.power_units(grid.lateral_unit, 4),
        long_name="power spectral density C(q_x, q_y) (eq. 4, every mode)",
        spectrum_kind="2D", window="none" if name is None else name,
        periodic=int(grid.periodic), mode_measure=1.0 / area,
        mode_measure_units=u.power_units(grid.lateral_unit, -2))
    out.name = "C"
    return out


@u.accepts_quantified
def spectral_moment(C: xr.DataArray, kernel=None, *, order: int | None = None) -> xr.DataArray:
    r"""Sum ``kernel(q_x, q_y) C / A`` over the modes: a moment of the 2D spectrum.

    ``order=n`` takes ``|q|^n`` (``n = 0``: the variance of the heights; ``2``: the mean
    square gradient; ``4``: the mean square Laplacian); any ``kernel(q_x, q_y)`` of the
    components (radians per lateral unit) weights each mode otherwise, e.g. ``q_x^2`` for
    the mean square slope along ``x``: SurfaceTopography's moments of the PSD, with the
    kernel in ``(q_x, q_y)``.

    Parameters
    ----------
    C : xarray.DataArray
        From :func:`power_spectrum_2d`.
    kernel : callable, optional
        ``kernel(q_x, q_y)`` broadcasting over the modes.
    order : int, optional
        Or the power of ``|q|``.

    Returns
    -------
    xarray.DataArray
        The moment per map (0-d for one), in ``C``'s unit times ``mode_measure``'s (the
        unit of the kernel not included: ``units`` says so for ``order``).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> x = np.arange(64) * 1.0
    >>> h = np.sin(2 * np.pi * x / 16)[None, :] * np.ones((64, 1))  # a wave along x
    >>> C = xrough.power_spectrum_2d(xrough.topography(h, spacing=1.0, unit="nm",
    ...                                                periodic=True))
    >>> sx = float(xrough.spectral_moment(C, lambda qx, qy: qx**2))  # <(dh/dx)^2>
    >>> sy = float(xrough.spectral_moment(C, lambda qx, qy: qy**2))
    >>> round(sx, 6), round(0.5 * (2 * np.pi / 16) ** 2, 6), round(sy, 12)
    (0.077106, 0.077106, 0.0)
    """
    if (kernel is None) == (order is None):
        raise ValueError("give a kernel or an order, one of them")
    if not {"qx", "qy"} <= set(C.dims) or "mode_measure" not in C.attrs:
        raise ValueError("spectral_moment needs the 2D spectrum of power_spectrum_2d")
    qx, qy = C["qx"], C["qy"]
    weight = (np.sqrt(qx**2 + qy**2) ** order if order is not None else kernel(qx, qy))
    out = (C * weight).sum(("qy", "qx")) * float(C.attrs["mode_measure"])
    lateral = str(C.qx.attrs.get("units", "")).removesuffix("-1")
    units = (u.power_units(lateral, 2 - order) if order is not None and lateral else None)
    out.attrs = result_attrs(C, long_name="moment of the 2D spectrum", order=(
        -1 if order is None else int(order)), **({"units": units} if units else {}))
    return out
