"""Spectrum from the height-difference ACF (eq. 10/11) and the exact rms gradient of G.

Conventions and units as in :mod:`xrough.spectra`.  :func:`spectrum` is the Hankel
transform of G (eq. 10/11) with the range of ``q`` that G determines;
:func:`rms_gradient_exact` is eq. 26 of that spectrum, with the range of ``dr`` that G
determines.  Both are importable from :mod:`xrough.spectra` too.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pint
import xarray as xr

from . import units as _units
from ._kernels.hankel import power_law_moment_kernel
from ._kernels.hankel_inverse import (
    acf_plateau_kernel,
    smooth_acf_kernel,
    spectrum_from_acf_kernel,
    spectrum_support_kernel,
    spectrum_variants_kernel,
    supported_interval,
)
from ._lags import _gradient_da, _lag_values, _log_range

__all__ = ["spectrum", "rms_gradient_exact"]


# --------------------------------------------------------------------------------------
# G(dr) as input
# --------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class _AcfInput:
    """A validated G(dr): valid samples in one length unit and their random scatter."""

    dr: np.ndarray
    G: np.ndarray  # in length_unit^2
    noise: np.ndarray  # relative independent scatter per sample (0: none known)
    length_unit: pint.Unit
    unit_str: str


def _acf_input(G: Any, noise: Any) -> _AcfInput:
    """Check a G(dr) DataArray (dims, units, values), drop NaN bins, convert to dr's unit."""
    if not isinstance(G, xr.DataArray):
        raise TypeError(f"G must be an xarray.DataArray, got {type(G).__name__}")
    if G.ndim != 1:
        raise ValueError(f"G must be 1-D (G(dr) on dim 'dr'), got dims {G.dims}; select one "
                         "curve first, e.g. G.isel(scan=0)")
    dim = G.dims[0]
    if dim not in G.coords:
        raise ValueError(f"G needs a lag-distance coordinate on its dim {dim!r}")
    length_unit = _units.as_length_unit(
        _units.units_of(G[dim], what=f"coordinate {dim!r} of G"),
        what=f"coordinate {dim!r} of G (the lag distance)")
    unit_str = _units.format_units(length_unit)
    g_unit = _units.units_of(G, what="G")
    if g_unit.dimensionality != (_units.ureg.meter**2).dimensionality:
        raise ValueError(f"G must be a height difference squared, in length^2 (e.g. "
                         f"{_units.power_units(unit_str, 2)!r}), but its units are "
                         f"{_units.format_units(g_unit)!r}")
    factor = _units.conversion_factor(g_unit, length_unit**2)
    dr = np.asarray(G[dim].values, dtype=float)
    g = np.asarray(G.values, dtype=float) * factor
    if np.any(np.isinf(g)) or np.any(~np.isfinite(dr)):
        raise ValueError("G and its coordinate must be finite (NaN marks an empty bin)")
    if noise is None:
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = (np.asarray(G["sampling_error"].values, dtype=float) * factor / g
                   if "sampling_error" in G.coords else np.zeros_like(g))
    else:
        rel = np.broadcast_to(np.asarray(noise, dtype=float), g.shape)
        if not np.all(np.isfinite(rel) & (rel >= 0)):
            raise ValueError(f"noise must be a relative scatter >= 0, got {noise!r}")
    valid = np.isfinite(g)
    if np.any(valid & (dr < 0)):
        raise ValueError(f"coordinate {dim!r} of G must hold lag distances >= 0")
    zero_lag = valid & (dr == 0)
    if np.any(g[zero_lag] != 0):
        raise ValueError("G(0) must be 0 (a point differs from itself by nothing)")
    valid &= dr > 0
    dr, g, rel = dr[valid], g[valid], np.nan_to_num(rel[valid])
    if dr.size < 4:
        raise ValueError(f"G has {dr.size} valid (non-NaN) bins at dr > 0; the spectrum needs "
                         "at least 4")
    if np.any(np.diff(dr) <= 0):
        raise ValueError(f"coordinate {dim!r} of G must be strictly increasing (use "
                         f"G.sortby({dim!r}))")
    if np.any(g < 0):
        raise ValueError("G must be >= 0 (a mean of squared height differences); negative at "
                         f"dr = {dr[g < 0][:3]} {unit_str}")
    if np.any(g == 0):
        raise ValueError(f"G is 0 at dr = {dr[g == 0][:3]} {unit_str}: a log-log "
                         "representation needs G > 0 at every lag > 0")
    third = max(1, dr.size // 3)
    ln_g = np.log(g)
    if np.median(ln_g[-third:]) < np.median(ln_g[:third]) - np.log(1.1):
        raise ValueError(
            "G decreases overall (its last third is more than 10 % below its first third), "
            "so it is not a height-difference ACF, which grows from 0 at dr = 0 to "
            "sigma_h^2; was the height autocorrelation sigma_h^2 - G passed instead?")
    return _AcfInput(dr, g, rel, length_unit, unit_str)


def _wavenumbers(q: Any, length_unit: pint.Unit) -> np.ndarray:
    """Wavenumbers in ``1/length_unit`` from numbers, a Quantity or a DataArray."""
    return _units.array_in(q, length_unit**-1, what="q", noun="wavenumbers")


def _check_options(smooth, support_rtol, interpolation, points_per_decade) -> None:
    if smooth is not None and not (np.isfinite(smooth) and smooth > 0):
        raise ValueError(f"smooth must be a positive width in decades or None, got {smooth!r}")
    if not support_rtol > 0:
        raise ValueError(f"support_rtol must be positive, got {support_rtol!r}")
    if interpolation not in ("hermite", "power law"):
        raise ValueError(f"interpolation must be 'hermite' or 'power law', got "
                         f"{interpolation!r}")
    if not (np.isfinite(points_per_decade) and points_per_decade > 0):
        raise ValueError(f"points_per_decade must be positive, got {points_per_decade!r}")


def _support(acf: _AcfInput, *, smooth, support_rtol, interpolation) -> tuple[float, float]:
    q_lo, q_hi = spectrum_support_kernel(acf.dr, acf.G, rtol=support_rtol, noise=acf.noise,
                                         smooth=smooth, interpolation=interpolation)
    if not np.isfinite(q_lo):
        noisy = " or smooth=<decades> (the samples scatter)" if np.any(acf.noise > 0) else ""
        raise ValueError(
            f"G does not determine C anywhere to within support_rtol={support_rtol:g}: the "
            f"extrapolation beyond dr = {acf.dr[0]:g}..{acf.dr[-1]:g} {acf.unit_str} or noise "
            f"dominates; pass a larger support_rtol{noisy}, or measure G over a wider range")
    return q_lo, q_hi


def spectrum(
    G: xr.DataArray,
    q: Any = None,
    *,
    smooth: float | None = None,
    noise: Any = None,
    support_rtol: float = 0.01,
    interpolation: str = "hermite",
    points_per_decade: float = 20,
) -> xr.DataArray:
    r"""Isotropic height spectrum from the height-difference ACF (paper eq. 10/11).

    .. math::

        C(q) = 2\pi \int_0^\infty d\Delta r\, \Delta r\, J_0(q \Delta r)
               \left[\sigma_h^2 - G(\Delta r)\right]
             = \frac{2\pi}{q^2} \int_0^\infty d\Delta r\, J_0(q \Delta r)\,
               \frac{d}{d\Delta r}\left[\Delta r \frac{dG}{d\Delta r}\right]

    The second form (two integrations by parts, every boundary term kept exactly) contains
    no ``sigma_h^2 - G``: there is no round-off where ``G ~ sigma_h^2``, and ``sigma_h^2``
    drops out.  As in eq. 11 it is split, at ``dr = 1/q``: below, ``J0`` is replaced by
    ``-(1 - J0)`` plus the boundary term ``dr dG/d(dr)`` at ``1/q``, so that nothing
    cancels at small ``q`` either.

    ``G`` is represented through its valid (non-NaN) bins as a piecewise power law in
    log-log, times a quintic correction per interval that matches the slopes and
    curvatures of a cubic spline of ``ln G`` against ``ln dr``, so that ``G`` is twice
    continuously differentiable (a kink would add a ``q^-2.5`` tail that swamps the
    ``q^-2(1+H)`` of a self-affine ``C``).
    Beyond the data, the log-log slope of ``G`` turns smoothly (C2, within one decade) to 2
    below the smallest lag (ballistic, ``G ~ dr^2``) and to 0 beyond the largest (flat:
    ``sigma_h^2`` is the level this extension reaches, ``attrs["sigma_h2"]``).  Each
    interval is integrated as in eq. 9 (:func:`acf_from_spectrum`): Gauss-Legendre below
    ``q dr = 64``, asymptotic antiderivatives of ``t^beta J0(t)`` above.

    Parameters
    ----------
    G : xarray.DataArray with one dim (``"dr"``)
        Height-difference ACF in length^2 on a lag coordinate in length (``units``
        required on both), e.g. from :func:`xrough.height_difference_acf` or
        :func:`acf_from_spectrum`.  NaN bins are dropped; at least 4 must remain, with
        strictly increasing lags.
    q : array_like, pint.Quantity or xarray.DataArray, optional
        Angular wavenumbers ``>= 0`` (plain numbers in the inverse length unit of ``dr``).
        Default: logarithmic, ``points_per_decade``, from half the smallest to twice the
        largest supported ``q``.
    smooth : float, optional
        Smooth ``G`` first by local quadratic regression of ``ln G`` on ``log10 dr`` over a
        window of this many decades (power laws pass unchanged).  For noisy ``G`` (random
        pairs): 0.5 to 1.
    noise : float or array_like, optional
        Relative random scatter of the bins, independent from bin to bin, used for the
        supported range.  Default: ``sampling_error / G`` if ``G`` has that coordinate (the
        random-pair estimator), else 0.  ``standard_error`` is not used: finite-area errors
        are correlated across bins and are not amplified.
    support_rtol : float
        Relative change of ``C`` allowed for ``q`` to count as supported (see Notes).
    interpolation : {'hermite', 'power law'}
        ``'power law'`` drops the quintic correction (kinks at the samples; for
        comparison).
    points_per_decade : float
        Density of the default ``q`` grid.

    Returns
    -------
    xarray.DataArray
        ``C`` on dim ``"q"`` (``units`` ``"<len>-1"``, long_name "angular wavenumber"), data
        in ``"<len>4"`` with ``<len>`` the unit of ``dr``; int8 coord ``supported`` (1 inside
        the supported range); attrs ``equation="eq. 10/11"``, ``q_min_supported``,
        ``q_max_supported`` (in ``<len>-1``), ``support_rtol``, ``sigma_h2`` (in
        ``<len>2``), ``smooth_decades`` (0 for none), ``noise`` (median relative scatter
        assumed), ``interpolation``, ``dr_min``, ``dr_max`` (data range, in ``<len>``).

    Raises
    ------
    ValueError
        ``G`` not 1-D, missing units, ``G`` not in length^2, a coordinate that is not a
        length, fewer than 4 valid bins, non-increasing lags, negative or zero ``G``,
        ``G(0) != 0``, a ``G`` that decreases overall (not a height-difference ACF), bad
        options or ``q``, or no supported range at all.

    See Also
    --------
    acf_from_spectrum : the inverse, eq. 9.
    rms_gradient_exact : eq. 26 from this spectrum.

    Notes
    -----
    **Supported range.** ``C(q)`` counts as determined by the data where it is positive
    and changes by at most ``support_rtol |C|`` when the extrapolation changes: the
    measured log-log slope at the smallest lag turns ballistic sooner (within 0.2 instead of
    1 decade) or later (after one more decade), the same for the turn to flat at the
    largest lag, and, with ``noise``, ``G`` is perturbed by that independent relative
    scatter (standard deviation over 16 seeded copies).  Changes are evaluated on a grid
    of 10 per decade over ``[2 pi / dr_max, 2 pi / dr_min]``, and the largest within
    +-0.2 decades counts (the difference of two extrapolations oscillates in ``q``); the
    longest interval that passes is reported, its ends interpolated.  A ballistic ``G``
    at the smallest lags and a plateau at the largest give nearly all of
    ``[2 pi / dr_max, 2 pi / dr_min]`` (less where ``C`` drops to 0); a ``G`` that is
    still self-affine at ``dr_min`` or still rising at ``dr_max`` gives less, or nothing.
    The rule measures what the extrapolation leaves open, not the interpolation error
    (next paragraph).

    **Accuracy** (docs/spectra.md): with noise-free ``G`` sampled at 20 points per decade,
    ``C`` is accurate to ~1e-5 where it is smooth.  A jump of ``C`` (the cutoff ``q_s`` of
    eq. 35) rings in ``G`` as ``dr^-3/2``, which no logarithmic grid follows: ``C`` is off
    by ~1 % from ``q_s / 4`` and by tens of % within a factor 2 of ``q_s``.  A kink of
    ``C`` (``q_r`` in the sharp eq. 35) rings as ``dr^-5/2``: 10-20 % error far below
    ``q_r`` at 20 points per decade, ~1 % at 100.  Noise is amplified where ``C`` is small
    compared with ``sigma_h^2 dr^2`` (below the roll-off): independent 5 % scatter leaves
    nothing supported at 1 %, and with ``smooth=1`` about one decade around the roll-off
    at 20 %.

    Examples
    --------
    Round trip through eq. 9 for the smooth model spectrum:

    >>> from xrough.spectra import acf_from_spectrum, model_spectrum, spectrum
    >>> import numpy as np
    >>> model = dict(hurst=0.8, lambda_r="1 um", lambda_s="10 nm", rms_height="1 nm",
    ...              unit="nm", rolloff="smooth")
    >>> G = acf_from_spectrum(model_spectrum(**model), np.logspace(-1, 6, 141))
    >>> C = spectrum(G, [1e-4, 1e-3, 1e-2])
    >>> C.attrs["units"], C.q.attrs["units"], C.attrs["equation"]
    ('nm4', 'nm-1', 'eq. 10/11')
    >>> exact = model_spectrum(C.q.values, **model)
    >>> print(np.round((C / exact).values, 3))
    [1. 1. 1.]
    >>> C.supported.values.tolist()
    [1, 1, 1]
    """
    _check_options(smooth, support_rtol, interpolation, points_per_decade)
    acf = _acf_input(G, noise)
    q_lo, q_hi = _support(acf, smooth=smooth, support_rtol=support_rtol,
                          interpolation=interpolation)
    q_arr = (_log_range(0.5 * q_lo, 2.0 * q_hi, points_per_decade) if q is None
             else _wavenumbers(q, acf.length_unit))
    g = acf.G if smooth is None else smooth_acf_kernel(acf.dr, acf.G, smooth)
    values = spectrum_from_acf_kernel(q_arr, acf.dr, g, interpolation=interpolation)
    q_unit = _units.power_units(acf.unit_str, -1)
    supported = ((q_arr >= q_lo) & (q_arr <= q_hi)).astype(np.int8)
    attrs = {
        "units": _units.power_units(acf.unit_str, 4),
        "long_name": "isotropic height spectrum",
        "equation": "eq. 10/11",
        "estimator": "Hankel transform of G (eq. 10/11)",
        "spectrum_kind": "isotropic 2D",
        "q_min_supported": q_lo,
        "q_max_supported": q_hi,
        "support_rtol": float(support_rtol),
        "sigma_h2": acf_plateau_kernel(acf.dr, g),
        "smooth_decades": 0.0 if smooth is None else float(smooth),
        "noise": float(np.median(acf.noise)),
        "interpolation": interpolation,
        "dr_min": float(acf.dr[0]),
        "dr_max": float(acf.dr[-1]),
    }
    return xr.DataArray(
        values,
        dims=("q",),
        coords={
            "q": ("q", q_arr, {"units": q_unit, "long_name": "angular wavenumber"}),
            "supported": ("q", supported, {
                "long_name": "1 where G determines C (q_min_supported <= q <= "
                             "q_max_supported), 0 where extrapolation or noise dominates",
                "units": "1"}),
        },
        name="C",
        attrs=attrs,
    )


# --------------------------------------------------------------------------------------
# eq. 26 from G
# --------------------------------------------------------------------------------------
def rms_gradient_exact(
    G: xr.DataArray,
    dr: Any = None,
    *,
    smooth: float | None = None,
    noise: Any = None,
    support_rtol: float = 0.01,
    interpolation: str = "hermite",
    points_per_decade: float = 40,
) -> xr.DataArray:
    r"""Compute the "exact" scale-dependent rms gradient of a ``G`` (eq. 26 via eq. 10/11).

    .. math::

        \bar g^2(\Delta r) = \frac{1}{2\pi} \int_0^{2\pi/\Delta r} dq\, q^3\, C(q),
        \qquad C \text{ from } G \text{ by eq. 10/11 (:func:`spectrum`)}

    ``C`` is evaluated on ``points_per_decade`` from ``0.01 * 2 pi / dr_max`` to
    ``2 pi / dr_min`` (taken flat below, a negligible share) and integrated exactly as a
    piecewise power law (a straight line between samples where ``C <= 0``, possible where
    ``G`` does not determine ``C``: the ringing around a jump of ``C`` must not be
    clipped).  ``gbar`` is returned only where it is supported: where neither the
    extrapolation variants of :func:`spectrum` (the end slopes of ``G`` turning sooner or
    later), nor leaving out ``C`` below the grid, nor noise change ``gbar`` by more than
    ``support_rtol`` (the largest change within +-0.2 decades counts).  ``gbar`` can be
    supported where ``C`` is not: ``q^3 C`` beyond the short-wavelength cutoff decides
    little of ``gbar^2``, and a ``G`` that has reached its plateau fixes the small
    wavenumbers.

    Parameters
    ----------
    G : xarray.DataArray with one dim (``"dr"``)
        Height-difference ACF (length^2 on a lag coordinate in length); see
        :func:`spectrum`.
    dr : array_like, pint.Quantity or xarray.DataArray, optional
        Lags (plain numbers in the unit of ``G``'s coordinate), all within the supported
        range.  Default: the lags of ``G`` that lie within it.
    smooth, noise, support_rtol, interpolation
        As for :func:`spectrum`.
    points_per_decade : float
        Density of the ``q`` grid on which ``C`` is integrated.

    Returns
    -------
    xarray.DataArray
        ``gbar`` on dim ``"dr"`` (units of ``G``'s coordinate), dimensionless, attrs
        ``equation="eq. 26"``, ``dr_min_supported``, ``dr_max_supported``,
        ``support_rtol``, ``smooth_decades``, ``interpolation``.

    Raises
    ------
    ValueError
        Everything :func:`spectrum` raises; a ``dr`` outside the supported range (the
        message names it).

    See Also
    --------
    spectrum, gradient_from_spectrum

    Notes
    -----
    In the ballistic regime ``gbar^2 -> 4 G / dr^2``; the simplest approximation of the
    paper, ``gbar^2(dr) ~ 4 G(dr) / dr^2``, holds only there.

    Examples
    --------
    >>> from xrough.spectra import (acf_from_spectrum, gradient_from_spectrum, model_spectrum,
    ...                             rms_gradient_exact)
    >>> import numpy as np
    >>> model = dict(hurst=0.8, lambda_r="1 um", lambda_s="10 nm", rms_gradient=0.5,
    ...              unit="nm", rolloff="smooth")
    >>> G = acf_from_spectrum(model_spectrum(**model), np.logspace(-1, 6, 141))
    >>> gbar = rms_gradient_exact(G, [1.0, 100.0])
    >>> exact = gradient_from_spectrum(model_spectrum(**model), [1.0, 100.0])
    >>> print(np.round((gbar / exact).values, 2))
    [1. 1.]
    """
    _check_options(smooth, support_rtol, interpolation, points_per_decade)
    acf = _acf_input(G, noise)
    # from two decades below the data's range: the flat C assumed below the grid is
    # negligible, and what G's extrapolation implies there is tested by its variants
    # (on a coarser grid: they only locate the supported range)
    lo, hi = 0.02 * np.pi / acf.dr[-1], 2 * np.pi / acf.dr[0]
    q = _log_range(lo, hi, 10)
    base, extrapolated, noisy = spectrum_variants_kernel(
        q, acf.dr, acf.G, noise=acf.noise, smooth=smooth, interpolation=interpolation)

    def cumulative(q, values):
        """gbar^2 at every grid q: C flat below the grid, a power law between points."""
        below = values[0] * q[0] ** 4 / (8.0 * np.pi)
        return below + power_law_moment_kernel(q, q, values, 2, nonpositive="linear")

    # relative changes of gbar (not gbar^2), the quantity returned
    total = cumulative(q, base)
    below = np.abs(base[0] * q[0] ** 4 / (8.0 * np.pi))
    variants = [cumulative(q, v) for v in extrapolated] + [total - below]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = np.sqrt(np.maximum(np.array(variants), 0.0) / total)
        change = np.max(np.abs(ratios - 1.0), axis=0)
        if noisy.shape[0]:
            sample = np.sqrt(np.maximum([cumulative(q, v) for v in noisy], 0.0) / total)
            change = np.maximum(change, np.std(sample, axis=0))
        change = np.where(total > 0, change, np.inf)
    q_lo, q_hi = supported_interval(q, change, support_rtol, envelope=0.2)
    if not np.isfinite(q_lo):
        raise ValueError(
            f"G does not determine gbar anywhere to within support_rtol={support_rtol:g}: "
            f"the extrapolation beyond dr = {acf.dr[0]:g}..{acf.dr[-1]:g} {acf.unit_str} or "
            "noise dominates; pass a larger support_rtol or smooth=<decades>, or measure G "
            "over a wider range")
    dr_lo, dr_hi = 2 * np.pi / q_hi, 2 * np.pi / q_lo
    tol = 1e-9 * dr_hi
    if dr is None:
        dr_arr = acf.dr[(acf.dr >= dr_lo - tol) & (acf.dr <= dr_hi + tol)]
        if dr_arr.size == 0:
            dr_arr = _log_range(dr_lo, dr_hi, 20)
    else:
        dr_arr = _lag_values(dr, acf.length_unit)
        bad = (dr_arr < dr_lo - tol) | (dr_arr > dr_hi + tol)
        if np.any(bad):
            raise ValueError(
                f"gbar is supported for {dr_lo:.4g} <= dr <= {dr_hi:.4g} {acf.unit_str} only "
                f"(got dr = {dr_arr[bad][:3]}): elsewhere the extrapolation of G or noise "
                f"changes gbar^2 by more than support_rtol={support_rtol:g}")
    q = _log_range(lo, hi, points_per_decade)
    g = acf.G if smooth is None else smooth_acf_kernel(acf.dr, acf.G, smooth)
    values = spectrum_from_acf_kernel(q, acf.dr, g, interpolation=interpolation)
    gbar2 = values[0] * q[0] ** 4 / (8.0 * np.pi) + power_law_moment_kernel(
        2 * np.pi / dr_arr, q, values, 2, nonpositive="linear")
    positive = gbar2 > 0  # noise can drive the cumulative sum negative at a few lags
    if not positive.all():
        if dr is not None or not positive.any():
            raise ValueError(
                f"gbar^2 from the spectrum of G is not positive at dr = "
                f"{dr_arr[~positive][:3]} {acf.unit_str} (noise in G); pass smooth=<decades> "
                "or use rms_gradient(G, method='fit')")
        dr_arr, gbar2 = dr_arr[positive], gbar2[positive]
    attrs = {
        "estimator": "eq. 26 with C from G by eq. 10/11",
        "dr_min_supported": float(dr_lo),
        "dr_max_supported": float(dr_hi),
        "support_rtol": float(support_rtol),
        "smooth_decades": 0.0 if smooth is None else float(smooth),
        "interpolation": interpolation,
    }
    return _gradient_da(np.sqrt(gbar2), dr_arr, acf.unit_str, attrs)
