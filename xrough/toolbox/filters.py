"""Fourier band filters of heights: keep the wavelengths of a band, remove the others.

The filters of contact.engineering and SurfaceTopography (``filter``, ``shortcut``,
``longcut``) on xrough's topographies: the heights' Fourier coefficients times a
function of the wavevector, transformed back. The FFT treats the map as periodic: on an
open map the step between opposite edges leaks into every wavelength, so filter maps
that are periodic or whose edges match (or detrend first), and read the edges with care.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import xarray as xr

from .. import units as u
from .._kernels.filters import fourier_filter_kernel
from ..topography import grid_of, require_whole_maps
from ..units import QuantityLike

__all__ = ["fourier_filter", "shortcut", "longcut", "FILTER_KINDS"]

#: Shapes of the band of :func:`shortcut` and :func:`longcut`: a circle ``|q| = q_c``
#: (isotropic) or a square ``max(|q_x|, |q_y|) = q_c``.
FILTER_KINDS = ("circular", "square")


@u.accepts_quantified
def fourier_filter(topography: xr.DataArray, function: Callable, *,
                   isotropic: bool = True, label: str = "") -> xr.DataArray:
    """Filter heights by a function of the wavevector (SurfaceTopography's ``filter``).

    Parameters
    ----------
    topography : xarray.DataArray with dims (..., "y", "x") or (..., "x")
        Heights with units and no missing points (:func:`xrough.fill_missing` first);
        extra dims are filtered map by map, lazily on dask (one map per chunk).
    function : callable
        ``function(q)`` of the magnitude of the wavevector (``isotropic``), or
        ``function(q_y, q_x)`` of its components (``function(q_x)`` for a profile), in
        radians per lateral unit of the topography (``2 pi / wavelength``); its value
        multiplies the Fourier coefficients (1 keeps, 0 removes).
    isotropic : bool
        Whether ``function`` takes the magnitude or the components.
    label : str
        What the filter is, for ``attrs["filter"]`` (default: ``"fourier_filter"``).

    Returns
    -------
    xarray.DataArray
        Filtered heights: dims, coords, units and attrs of the input, with
        ``attrs["filter"]`` recording the filter (successive ones joined by ``"; "``).

    Raises
    ------
    ValueError
        Missing (NaN) points, or an invalid topography.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> x = np.arange(64.0)
    >>> topo = xrough.topography(np.sin(2 * np.pi * x / 32) + np.sin(2 * np.pi * x / 4),
    ...                          spacing=1.0, unit="nm")
    >>> smooth = xrough.fourier_filter(topo, lambda q: q < 2 * np.pi / 8)
    >>> bool(np.allclose(smooth, np.sin(2 * np.pi * x / 32)))
    True
    """
    grid = grid_of(topography)
    require_whole_maps(topography, grid, purpose="a Fourier filter")
    if topography.chunks is None and not np.isfinite(topography.values).all():
        raise ValueError("the topography has missing (NaN) points: a Fourier filter needs "
                         "every point; fill them first (xrough.fill_missing)")
    result = xr.apply_ufunc(
        fourier_filter_kernel, topography, input_core_dims=[list(grid.dims)],
        output_core_dims=[list(grid.dims)], dask="parallelized", output_dtypes=[float],
        keep_attrs=False,
        kwargs={"spacing": grid.spacing, "function": function,
                "isotropic": bool(isotropic)})
    out = topography.copy(data=result.transpose(*topography.dims).data)
    text = label or "fourier_filter"
    out.attrs["filter"] = (f"{out.attrs['filter']}; {text}" if out.attrs.get("filter")
                           else text)
    return out


def _cutoff(topography: xr.DataArray, wavelength, wavevector, kind: str,
            what: str) -> tuple[float, str]:
    """Return the cutoff wavevector (radians per lateral unit) and its words."""
    if kind not in FILTER_KINDS:
        raise ValueError(f"kind must be one of {FILTER_KINDS}, got {kind!r}")
    if (wavelength is None) == (wavevector is None):
        raise ValueError(f"{what}: give the cutoff as wavelength= or as wavevector=, "
                         "one of them")
    unit = grid_of(topography).lateral_unit
    if wavelength is not None:
        lam = u.length_in(wavelength, unit, what=f"{what} wavelength")
        return 2.0 * np.pi / lam, f"wavelength {lam:g} {unit}"
    q = float(np.reshape(u.magnitude_in(wavevector, u.power_units(unit, -1),
                                        what=f"{what} wavevector"), -1)[0])
    if not (np.isfinite(q) and q > 0):
        raise ValueError(f"{what}: the cutoff wavevector must be positive, got {wavevector!r}")
    return q, f"wavevector {q:g} rad {unit}-1"


def _band(q_c: float, kind: str, keep_long: bool):
    """Return ``(function, isotropic)``: a step at ``q_c`` keeping long or short ones."""
    if kind == "circular":
        return ((lambda q: q <= q_c) if keep_long else (lambda q: q > q_c)), True

    def inside(*q):
        return np.all([np.abs(c) <= q_c for c in np.broadcast_arrays(*q)], axis=0)

    return ((inside if keep_long else (lambda *q: ~inside(*q))), False)


@u.accepts_quantified
def shortcut(topography: xr.DataArray, wavelength: QuantityLike | None = None, *,
             wavevector: QuantityLike | None = None, kind: str = "circular") -> xr.DataArray:
    """Remove the wavelengths shorter than a cutoff (a low-pass step in Fourier space).

    Keeps the Fourier coefficients with ``|q| <= q_c = 2 pi / wavelength`` (``kind=
    'square'``: ``|q_x|, |q_y| <= q_c``). SurfaceTopography's ``shortcut``.

    Parameters
    ----------
    topography : xarray.DataArray
        As :func:`fourier_filter`.
    wavelength : float, str or Quantity, optional
        The cutoff wavelength (numbers in the lateral unit).
    wavevector : float, str or Quantity, optional
        Or the cutoff wavevector ``q_c`` (numbers in radians per lateral unit).
    kind : {'circular', 'square'}
        The shape of the band (:data:`FILTER_KINDS`).

    Returns
    -------
    xarray.DataArray
        The heights without the short wavelengths (``attrs["filter"]`` says which).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> x = np.arange(64.0)
    >>> topo = xrough.topography(np.sin(2 * np.pi * x / 32) + np.sin(2 * np.pi * x / 4),
    ...                          spacing=1.0, unit="nm")
    >>> out = topo.rough.shortcut("8 nm")
    >>> bool(np.allclose(out, np.sin(2 * np.pi * x / 32))), out.attrs["filter"]
    (True, 'shortcut at wavelength 8 nm (circular)')
    """
    q_c, words = _cutoff(topography, wavelength, wavevector, kind, "shortcut")
    function, isotropic = _band(q_c, kind, keep_long=True)
    return fourier_filter(topography, function, isotropic=isotropic,
                          label=f"shortcut at {words} ({kind})")


@u.accepts_quantified
def longcut(topography: xr.DataArray, wavelength: QuantityLike | None = None, *,
            wavevector: QuantityLike | None = None, kind: str = "circular") -> xr.DataArray:
    """Remove the wavelengths longer than a cutoff (a high-pass step in Fourier space).

    Keeps the Fourier coefficients with ``|q| > q_c = 2 pi / wavelength`` (``kind=
    'square'``: outside the square ``|q_x|, |q_y| <= q_c``); the mean goes with them.
    SurfaceTopography's ``longcut``; with :func:`shortcut` at the same cutoff it adds
    up to the input.

    Parameters
    ----------
    topography, wavelength, wavevector, kind
        As :func:`shortcut`.

    Returns
    -------
    xarray.DataArray
        The heights without the long wavelengths (``attrs["filter"]`` says which).

    Examples
    --------
    >>> import numpy as np, xrough
    >>> x = np.arange(64.0)
    >>> topo = xrough.topography(np.sin(2 * np.pi * x / 32) + np.sin(2 * np.pi * x / 4),
    ...                          spacing=1.0, unit="nm")
    >>> bool(np.allclose(topo.rough.longcut("8 nm"), np.sin(2 * np.pi * x / 4)))
    True
    """
    q_c, words = _cutoff(topography, wavelength, wavevector, kind, "longcut")
    function, isotropic = _band(q_c, kind, keep_long=False)
    return fourier_filter(topography, function, isotropic=isotropic,
                          label=f"longcut at {words} ({kind})")
