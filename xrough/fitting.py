"""Fits of the height-difference ACF G and the gradient they imply.

Two models (:func:`fit_acf`, ``model=...``):

``"spectrum"`` (default)
    the self-affine model spectrum (eq. 35, sharp or smooth roll-off) through its exact G
    of eq. 9, ``G(dr) = (1/2pi) int dq q C(q) [1 - J0(q dr)]``; the gradient is eq. 26 of
    the fitted spectrum.  No model bias for surfaces with that spectrum.
``"eq36"``
    the paper's three-regime interpolation ``1/G = C_b/dr^2 + C_sa/dr^(2H) +
    1/sigma_h^2`` and its gradient (eq. 37/38); closed form and fast, but its crossovers
    have other exponents than G of eq. 35, which biases ``H`` by up to 0.1.

Representation of a fit (netCDF-legal, every variable with CF ``units``, each parameter
with ``<name>_std``, one standard deviation in the same units):

``sigma_h``
    rms height (``G -> sigma_h^2`` at large ``dr``), height unit; ``inf`` when the data
    show no plateau.
``G_sa``
    the self-affine asymptote at the reference lag ``dr_ref`` (a scalar coordinate), so
    that ``G -> G_sa (dr/dr_ref)^(2H)`` between the cutoffs (eq. 36: ``G_sa = dr_ref^(2H) /
    C_sa``).  ``C_sa`` has the units length^(2H-2), which CF cannot spell for
    non-integer exponents; ``G_sa`` is a plain length^2 and, because ``dr_ref`` (the power
    of ten nearest the geometric mean of the fitted lags) lies inside the fitted range,
    far less correlated with ``H`` than ``C_sa``.
``hurst``
    Hurst exponent ``H`` (dimensionless).
``lambda_r``
    roll-off wavelength ``2 pi / q_r``, lateral unit (eq. 36: from where G levels off).
``lambda_s``, ``C_r`` (spectrum)
    short-wavelength cutoff ``2 pi / q_s`` (lateral unit) and the plateau ``C(q -> 0)`` of
    the spectrum (units of G times lateral^2), with the flags ``lambda_s_resolved`` and
    ``lambda_r_resolved`` (0: the data do not resolve that cutoff; see :func:`fit_acf`)
    and the scalar coordinate ``lambda_0`` (the fixed lower cutoff; ``inf``: none).
``C_b`` (eq. 36)
    ballistic coefficient (dimensionless once ``dr`` and ``G`` are in the same length unit;
    ``gbar^2(0) = 4/C_b``, eq. 38a), ``>= 0``; 0 when the ballistic regime is unresolved.

plus ``reduced_chi2`` and ``n_bins``, and (spectrum) ``parameter_covariance`` on the dims
``cov_i``, ``cov_j``: the covariance of ``ln G_sa``, ``H``, ``eta = (dr_ref /
lambda_r)^(2-2H)`` and ``eps = (lambda_s / dr_ref)^(2H)`` (0 where a cutoff is not
resolved), the parameters in which the fit is linear near a cutoff; the ``<name>_std``
are its diagonal carried to each parameter, and the error of the fitted spectrum's gbar
(:func:`xrough.gradient_from_fit`) comes from it.

The least-squares fits themselves (numpy) are in :mod:`xrough._kernels.fitting`.  A fit
is read (its units, the G and the gradient it implies) by :mod:`xrough.fit_result`:
:func:`model_acf` (also here) and :func:`xrough.gradient_from_fit`.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar, cast

import numpy as np
import xarray as xr
from pint.facets.plain import PlainUnit

from . import quality
from . import units as u
from ._kernels.fitting import (
    AIC_MARGIN,
    CHI2_ALONE,
    COVARIANCE_PARAMETERS,
    EQ36_OUTPUTS,
    H_BOUNDS,
    HURST_MARGIN,
    HURST_SEPARATION,
    HURST_STD_MAX,
    MIN_BINS_PER_PARAMETER,
    MISFIT_FAILED,
    MISFIT_QUESTIONABLE,
    MISS_FACTOR,
    MODELS,
    OTHER_BETTER,
    OUTSIDE,
    PARAMETERS,  # noqa: F401  (the fitted parameters, public here)
    PROBLEMS,
    SPECTRUM_OUTPUTS,
    SPECTRUM_PARAMETERS,  # noqa: F401
    fit_covariance,
    fit_eq36_kernel,
    fit_spectrum_kernel,
)
from ._kernels.shape_factors import ROLLOFFS
from ._kernels.spectral_models import CUTOFFS
from .acf import (
    ERROR_OF_BINS,
    ERROR_OF_SURFACE,
    AcfSpec,
    bin_error,
    error_model,
    inflation_of,
    mark_gaps,
    read_acf,
    result_attrs,
)
from .fit_result import (  # noqa: F401  (read a fit; public here)
    COVARIANCE,
    COVARIANCE_DIMS,
    model_acf,
    rolloff_shapes,
)
from .memo import by_content
from .units import QuantityLike

__all__ = ["fit_acf", "model_acf", "describe_problems"]

_SPECTRUM_EQ = ("eq. 9 of the {rolloff} model spectrum (eq. 35): G(dr) = (1/2pi) int dq q "
                "C(q) [1 - J0(q dr)], G -> G_sa (dr/dr_ref)^(2H) for lambda_s << dr << "
                "lambda_r")
_CUTOFFS = ("a cutoff counts as resolved when eps = (lambda_s/dr_min)^(2H) (eta = "
            "(dr_max/lambda_r)^(2-2H)) exceeds 2 standard deviations, or (lambda_r) "
            "when the refit without it misses G by more than 3 times in a bin where the "
            "fit with it does not; otherwise it is "
            "removed and the rest refitted: lambda_s_resolved = 0 reports lambda_s as the "
            "upper bound dr_min (2 std(eps))^(1/(2H)); lambda_r_resolved = 0 reports "
            "lambda_r = sigma_h = C_r = inf (lambda_r = lambda_0 when given)")
_EQ36 = "eq. 36: 1/G(dr) = C_b/dr^2 + C_sa/dr^(2H) + 1/sigma_h^2, C_sa = dr_ref^(2H)/G_sa"


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------
def _area_unit(da: xr.DataArray, what: str) -> PlainUnit:
    unit = u.units_of(da, what=what)
    if unit.dimensionality != (u.ureg.meter**2).dimensionality:
        raise ValueError(f"{what} must be in length^2 (e.g. 'nm2'), but its units are "
                         f"{u.format_units(unit)!r}")
    return unit


def reference_lag(dr: np.ndarray, lateral: PlainUnit) -> float:
    """Return the power of ten (decided in metres) nearest the geometric mean of ``dr``."""
    to_m = u.conversion_factor(lateral, "m")
    mean_m = float(np.exp(np.mean(np.log(dr)))) * to_m
    return float(f"{10.0 ** np.round(np.log10(mean_m)) / to_m:.14g}")


def _variable(da: xr.DataArray, units: str, long_name: str) -> xr.DataArray:
    return da.assign_attrs({"units": units, "long_name": long_name})


# --------------------------------------------------------------------------------------
# the parameters held fixed (argument ``fix``)
# --------------------------------------------------------------------------------------
def _fix_hurst(value, lateral: PlainUnit, height: PlainUnit) -> tuple[float, str]:
    try:
        H = float(value)
    except (TypeError, ValueError):
        H = np.nan
    if not H_BOUNDS[0] <= H <= H_BOUNDS[1]:
        raise ValueError(f"fix: hurst must lie in [{H_BOUNDS[0]}, {H_BOUNDS[1]}], got "
                         f"{value!r}")
    return H, f"hurst={H:g}"


def _fix_ballistic(value, lateral: PlainUnit, height: PlainUnit) -> tuple[float, str]:
    q = u.quantity(value, default_units="", what="fix['C_b']")
    if not q.dimensionless or not (np.isfinite(q.to("").magnitude)
                                   and q.to("").magnitude >= 0):
        raise ValueError(f"fix: C_b must be a dimensionless number >= 0, got {value!r}")
    C_b = float(q.to("").magnitude)
    return C_b, f"C_b={C_b:g}"


def _is_number(value, limit: float) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and value == limit


def _fix_plateau(value, lateral: PlainUnit, height: PlainUnit) -> tuple[float, str]:
    """``1/sigma_h^2`` in ``lateral`` (0: no plateau, ``sigma_h = inf``)."""
    if _is_number(value, np.inf):
        return 0.0, "sigma_h=inf"
    sig = u.length_in(value, height, what="fix['sigma_h']")
    return (1.0 / (sig * u.conversion_factor(height, lateral)) ** 2,
            f"sigma_h={sig:g} {u.format_units(height)}")


def _fix_cutoff(name: str, none: float):
    """Parser of a cutoff wavelength in ``lateral``; ``none`` (inf or 0) means no cutoff."""
    def parse(value, lateral: PlainUnit, height: PlainUnit) -> tuple[float, str]:
        if _is_number(value, none):
            return none, f"{name}={none:g}"
        length = u.length_in(value, lateral, what=f"fix[{name!r}]")
        return length, f"{name}={length:g} {u.format_units(lateral)}"
    return parse


#: The parameters ``fix`` may hold, per model, in the order of the kernel's ``fixed``
#: (eq. 36: ``[H, C_b, 1/sigma_h^2]``; spectrum: ``[H, lambda_r, lambda_s]``), each with
#: the parser of its value: ``parse(value, lateral, height) -> (number, description)``.
FIXABLE = {
    "eq36": {"hurst": _fix_hurst, "C_b": _fix_ballistic, "sigma_h": _fix_plateau},
    "spectrum": {"hurst": _fix_hurst, "lambda_r": _fix_cutoff("lambda_r", np.inf),
                 "lambda_s": _fix_cutoff("lambda_s", 0.0)},
}


def fixed_parameters(fix: dict | None, model: str, lateral: PlainUnit, height: PlainUnit,
                     lambda_0: float = np.inf) -> tuple[np.ndarray, str]:
    """Read ``fix``: the ``fixed`` vector of ``model``'s kernel (NaN: free), a description.

    Lengths in ``lateral``; ``height`` is the unit of a plain ``sigma_h``.

    Examples
    --------
    >>> fixed_parameters({"hurst": 0.5}, "spectrum", u.ureg.nm, u.ureg.nm)
    (array([0.5, nan, nan]), 'hurst=0.5')
    >>> fixed_parameters({"H": 0.5}, "eq36", u.ureg.nm, u.ureg.nm)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: fix: cannot fix ['H'] with model='eq36'; fixable parameters are ...
    """
    fix, table = dict(fix or {}), FIXABLE[model]
    unknown = sorted(set(fix) - set(table))
    if unknown:
        raise ValueError(f"fix: cannot fix {unknown} with model={model!r}; fixable "
                         f"parameters are {tuple(table)}")
    out, text = np.full(len(table), np.nan), []
    for k, (name, parse) in enumerate(table.items()):
        if name in fix:
            out[k], said = parse(fix[name], lateral, height)
            text.append(said)
    if model == "spectrum":
        if out[1] > lambda_0:
            raise ValueError(f"fix: lambda_r must not exceed lambda_0 = {lambda_0:g} "
                             f"{u.format_units(lateral)}")
        if not np.isnan(out[1]) and out[2] >= out[1]:
            raise ValueError("fix: lambda_s must be shorter than lambda_r")
    return out, ", ".join(text) or "none"


# --------------------------------------------------------------------------------------
# the checks of a fit in words
# --------------------------------------------------------------------------------------
def _problem_text(name: str, v: dict) -> str:
    """One problem of a fit in words; ``v`` holds the numbers of one fit, or is empty."""
    one = bool(v)
    if name == "poor_fit":
        if not one:
            return (f"the model misses G by more than {MISFIT_QUESTIONABLE:.0%} rms, or "
                    f"beyond its errors (reduced chi^2 > {CHI2_ALONE:g}): the parameters "
                    "carry a model bias that their std does not include")
        return (f"the model misses G by {v['misfit']:.0%} rms (reduced chi^2 = "
                f"{v['chi2']:.3g}): the parameters carry a model bias that their std does "
                "not include")
    if name == "failed_fit":
        found = f" = {v['misfit']:.2g}" if one else ""
        return (f"the model does not describe G (rms misfit of ln G{found} > "
                f"{MISFIT_FAILED:g}, a factor e^{MISFIT_FAILED:g} in a typical bin, whatever "
                "the standard errors): its parameters are NaN")
    if name == "hurst_pinned":
        return (f"the data do not determine H: the fit sits at the bound of its search "
                f"({H_BOUNDS[0]:g} or {H_BOUNDS[1]:g}, H ended within {HURST_MARGIN:g} of "
                f"it and less than {HURST_SEPARATION:g} standard deviations from it), so "
                "H and the parameters that depend on it are NaN (a G that follows no "
                "power law dr^(2H) with 0 < H < 1: a tilt or a curvature, G ~ dr^2, or a "
                "plateau): look at the plot, detrend, or fit a narrower dr range")
    if name == "too_few_bins":
        found = (f"{v['n_bins']:.0f} bins for {v['n_free']:.0f} free parameters"
                 if one and "n_free" in v else "too few bins")
        return (f"{found} (fewer than {MIN_BINS_PER_PARAMETER:g} per parameter): some "
                "parameter rests on one bin or none, the fit interpolates G rather than "
                "measures it, and its parameters are NaN; measure a larger map or a "
                "longer profile, or fix parameters")
    if name == "misses_data":
        found = f"{v['factor']:.3g} times" if one else f"more than {MISS_FACTOR:g} times"
        return (f"the model misses G by {found} in a bin it fits (plot G with "
                "fit.rough.plot): not a description of this G (narrow the dr range to "
                "where G is self-affine, or detrend)")
    if name == "sigma_h_below_data":
        return ("the fitted sigma_h is too small for G: G exceeds 2 sigma_h^2 (beyond two "
                "standard errors), which no surface allows; the model's plateau is below "
                "the data (a roll-off fitted where G still rises)")
    if name == "hurst_at_bound":
        found = f"H = {v['hurst']:.3g}" if one and np.isfinite(v["hurst"]) else "H"
        return (f"{found} is within {HURST_MARGIN:g} of its bound {H_BOUNDS[0]:g} or "
                f"{H_BOUNDS[1]:g}: the edge of what the model can tell (a surface that "
                "close to H = 0 or 1, or a G that follows no power law dr^(2H) with "
                "0 < H < 1: a tilt or a curvature, G ~ dr^2, or a plateau): look at the "
                "plot, detrend, or fit a narrower dr range")
    if name == "other_model_better":
        found = f" (reduced chi^2 = {v['chi2_eq36']:.3g})" if one else ""
        return (f"eq. 36 fits G more than {OTHER_BETTER:g} times better{found}: use "
                "fit_acf(G, model='eq36')")
    if name == "no_self_affine_range":
        return ("the fitted cutoffs leave no self-affine range inside the lags (lambda_s "
                "beyond the largest lag, lambda_r below the smallest, or lambda_r < 2 "
                "lambda_s): H and the amplitude are not determined and are NaN; detrend "
                "(a tilt makes G ~ dr^2) or measure a wider range of lags")
    if name == "outside_range":
        return (f"lambda_r lies more than {OUTSIDE:g} times beyond the largest lag: an "
                "extrapolation, not a measurement")
    if name == "hurst_undetermined":
        return (f"the standard deviation of H exceeds {HURST_STD_MAX:g}: the data do not "
                "determine H (too few bins or lags, or a short self-affine range); fit a "
                "larger map or fix H")
    if name == "cutoff_shape_undetermined":
        return ("a sharp and a Gaussian short-wavelength cutoff fit G alike but give H's "
                "further apart than H's statistical error and 0.05: the self-affine range "
                "is too short to tell H from the shape of the cutoff; hurst_std includes the "
                "spread; fit a wider range of lags or fix the cutoff shape")
    if name == "cutoff_undetermined":
        return ("a cutoff the fit resolves has a standard deviation beyond its value "
                "(zero within one error, with the covariance of G's bins): its position "
                "is not determined; fit a larger map or fix lambda_r / lambda_s")
    return "the fit gave no finite H, chi^2 or sigma_h: its parameters are NaN"


#: A problem whose note another one says, stronger, when both are found.
_SAID_BY = {"poor_fit": "failed_fit", "hurst_at_bound": "hurst_pinned"}


def describe_problems(bits: int, numbers: dict | None = None) -> str:
    """Say in words what the problem bits of a fit (variable ``fit_problems``) mean.

    Parameters
    ----------
    bits : int
        Bit k set for problem k of :data:`xrough._kernels.fitting.PROBLEMS`.
    numbers : dict, optional
        ``chi2``, ``misfit``, ``factor``, ``hurst``, ``chi2_eq36``, ``n_bins``,
        ``n_free`` and ``weighted`` of one fit, quoted in the text.

    Returns
    -------
    str
        One sentence per problem, ``"; "``-joined (empty for 0).

    Examples
    --------
    >>> describe_problems(4)[:30]
    'H is within 0.05 of its bound '
    """
    names = [name for k, name in enumerate(PROBLEMS) if int(bits) >> k & 1]
    for said, by in _SAID_BY.items():
        if said in names and by in names:
            names.remove(said)
    return quality.SEPARATOR.join(_problem_text(name, numbers or {}) for name in names)


def _fit_notes(ds: xr.Dataset, bits: np.ndarray, model: str, weighted: bool,
               n_free: int) -> str:
    """Describe computed fits: the numbers of one fit, or the count of curves per problem.

    ``n_free``: the free parameters of each fit (the amplitude included).
    """
    bits = np.asarray(bits, dtype=np.int64)
    if bits.ndim == 0:
        eq36 = float(ds.reduced_chi2_eq36) if model == "spectrum" else np.nan
        return describe_problems(int(bits), {"chi2": float(ds.reduced_chi2),
                                             "misfit": float(ds.rms_misfit),
                                             "factor": float(ds.max_misfit_factor),
                                             "hurst": float(ds.hurst),
                                             "n_bins": int(ds.n_bins), "n_free": n_free,
                                             "chi2_eq36": eq36, "weighted": weighted})
    parts = []
    for k, name in enumerate(PROBLEMS):
        said = (bits >> PROBLEMS.index(_SAID_BY[name]) & 1 if name in _SAID_BY
                else np.zeros_like(bits))
        hit = int(np.count_nonzero((bits >> k & 1) & (1 - said)))
        if hit:
            parts.append(f"{hit} of {bits.size} curves: " + describe_problems(1 << k))
    return quality.SEPARATOR.join(parts)


# --------------------------------------------------------------------------------------
# public functions
# --------------------------------------------------------------------------------------
_F = TypeVar("_F", bound=Callable[..., xr.Dataset])


def _rated_as_its_g(func: _F) -> _F:
    """Rate a fit at least as questionable as the G it fits (:func:`quality.inherit`).

    Outside the memo (:func:`by_content`, whose key ignores G's flag): the fit kept for
    a G is the same whoever asked, and each caller's G rates what it gets.
    """
    @functools.wraps(func)
    def wrapper(G, *args, **kwargs):
        fit = func(G, *args, **kwargs)
        if not isinstance(G, xr.DataArray):
            return fit
        what = f"fit_acf (model {kwargs.get('model', 'spectrum')!r})"
        return quality.inherit(fit, G, what=what)

    for name in ("peek", "cache_clear", "cache_info"):
        setattr(wrapper, name, getattr(func, name))
    return cast(_F, wrapper)


@u.accepts_quantified
@_rated_as_its_g
@by_content()
def fit_acf(
    G: xr.DataArray,
    *,
    model: str = "spectrum",
    dr_min: QuantityLike | None = None,
    dr_max: QuantityLike | None = None,
    weights: str | None = "standard_error",
    fix: dict | None = None,
    rolloff: str | None = None,
    lambda_0: QuantityLike | None = None,
    cutoff: str | None = None,
) -> xr.Dataset:
    r"""Fit the height-difference ACF with the model spectrum (eq. 9 of eq. 35) or eq. 36.

    ``model="spectrum"`` (default) fits the parameters of the self-affine model spectrum,
    ``q = 2 pi / lambda``,

    .. math::

        C(q) = C_r \;\; (q_0 \le q < q_r), \qquad
        C(q) = C_r\, (q/q_r)^{-2(1+H)} \;\; (q_r \le q < q_s)

    (``rolloff="sharp"``, eq. 35) or ``C = C_r [1 + (q/q_r)^2]^-(1+H)`` on ``[q_0, q_s)``
    (``"smooth"``), through its exact G of eq. 9,

    .. math::

        G(\Delta r) = \frac{1}{2\pi} \int_0^\infty dq\, q\, C(q) [1 - J_0(q \Delta r)].

    ``model="eq36"`` fits the paper's three-regime closed form

    .. math::

        \frac{1}{G(\Delta r)} = \frac{C_b}{\Delta r^2} + \frac{C_{sa}}{\Delta r^{2H}}
                                + \frac{1}{\sigma_h^2}

    with ``C_b >= 0``, ``1/sigma_h^2 >= 0`` (``sigma_h = inf``: no plateau in the data),
    ``C_sa > 0``.  Both keep ``0.01 <= H <= 0.99``.

    Parameters
    ----------
    G : xarray.DataArray with dims (..., "dr")
        Height-difference ACF in length^2 on a lag coordinate ``dr`` in length (``units``
        required on both), e.g. from :func:`xrough.height_difference_acf` or
        :func:`xrough.acf_from_spectrum`.  Extra dims (e.g. ``scan``) are fitted one by
        one; NaN bins are skipped.
    model : {'spectrum', 'eq36'}
        The model spectrum (default: no model bias for self-affine surfaces with a
        roll-off; see Notes, *Which model*) or eq. 36 (closed form, much cheaper,
        biased by up to 0.1 in ``H`` on such surfaces).
    dr_min, dr_max : float, str or pint.Quantity, optional
        Range of lags to fit (plain numbers in the unit of ``dr``); default: all.
    weights : {'standard_error', None}
        Weight each bin by the coordinate ``standard_error`` of ``G`` (in length^2) when it
        exists; unweighted otherwise, or with None.  ``attrs["weighting"]`` says which.
    fix : dict, optional
        Parameters held fixed (lengths as plain numbers in the unit of ``dr``).
        ``'spectrum'``: ``"hurst"``, ``"lambda_r"`` (``np.inf``: no roll-off),
        ``"lambda_s"`` (``0``: no short-wavelength cutoff).  ``'eq36'``: ``"hurst"``,
        ``"C_b"`` (dimensionless, e.g. 0 when the ballistic regime is unresolved) and
        ``"sigma_h"`` (plain numbers in the height unit of ``G``; ``np.inf`` for no
        plateau).
    rolloff : {'auto', 'sharp', 'smooth'}, optional
        Shape of the model spectrum.  ``'auto'`` (the default of ``'spectrum'``) fits
        both and keeps the one the data support (see Notes, *Roll-off shape*; variable
        ``rolloff_shape``).  For eq. 36 (default ``'sharp'``; ``'auto'`` is not
        available, eq. 36 has no shape), the shape assumed to convert the crossover lag
        into ``lambda_r``.  Both models keep it for :func:`gradient_from_fit`.
    lambda_0 : float, str or pint.Quantity, optional
        ``'spectrum'`` only: long-wavelength cutoff ``2 pi / q_0`` of the model (e.g. the
        size of a periodic map, whose G knows no longer wavelengths); default none.
    cutoff : {'auto', 'sharp', 'gaussian'}, optional
        ``'spectrum'`` only: shape of the short-wavelength cutoff.  ``'sharp'`` is eq. 35
        (``C = 0`` beyond ``q_s``); ``'gaussian'`` the spectrum times ``exp(-(q/q_s)^2)``,
        as an instrument's transfer (tip, optics, stylus) rolls it off; ``'auto'`` (the
        default) fits both where the data resolve ``lambda_s`` and keeps the one they
        support (see Notes, *Cutoff shape*; variable ``cutoff_shape``).

    Returns
    -------
    xarray.Dataset
        On the extra dims of ``G``; each parameter with ``<name>_std`` (one standard
        deviation, same units), plus ``reduced_chi2`` and ``n_bins``, and the scalar
        coordinate ``dr_ref`` (the lag at which ``G_sa`` is given).

        * ``'spectrum'``: ``sigma_h`` (height unit), ``G_sa`` (units of ``G``), ``hurst``
          ("1"), ``lambda_r``, ``lambda_s`` (lateral unit), ``C_r`` (units of ``G`` times
          lateral^2), the flags ``lambda_r_resolved`` and ``lambda_s_resolved`` (1 or 0,
          see Notes), ``rolloff_shape`` (0 sharp, 1 smooth: the shape fitted; CF
          ``flag_values``), ``reduced_chi2_other_rolloff`` (the other shape on the same
          bins; NaN when only one was fitted), ``cutoff_shape`` (0 sharp, 1 Gaussian) and
          ``reduced_chi2_other_cutoff`` (likewise), ``parameter_covariance`` (dims ``cov_i``,
          ``cov_j``: see the module docstring) and the scalar coordinate ``lambda_0``
          (``inf``: none).
        * ``'eq36'``: ``sigma_h``, ``G_sa``, ``hurst``, ``C_b`` ("1"), ``lambda_r``.

        Attrs: ``model``, ``equation``, ``weighting``, ``residuals``,
        ``dr_min``/``dr_max``/``dr_units`` (range of bins used), ``fixed``, ``rolloff``
        (the shape; ``'auto'`` for several or lazy fits: see ``rolloff_shape``),
        ``rolloff_choice`` (spectrum: how the shape was chosen), ``cutoff`` and
        ``cutoff_choice`` (the same for the short-wavelength cutoff),
        ``uncertainty``, ``source``, ``lambda_r_definition`` (eq36) or ``cutoffs``
        (spectrum) and, for a single fit, ``reduced_chi2`` and (spectrum)
        ``ballistic_regime`` and ``plateau`` ("resolved" or why not).

        Quality (docs/quality.md): ``rms_misfit`` (rms of ``ln G_model - ln G``, weighted
        as the fit), ``reduced_chi2_eq36`` (spectrum: eq. 36 on the same bins),
        ``fit_problems`` (one bit per failed check, CF ``flag_masks``), the coordinate
        ``quality_flag`` (0 good, 1 questionable, 2 failed) and, for a single computed
        fit, the attrs ``quality`` and ``quality_notes``.  The parameters of a failed
        fit are NaN (fixed values kept); a :class:`xrough.QualityWarning` says why.

    Raises
    ------
    ValueError
        Missing or non-length units, no ``dr`` coordinate, non-positive ``G`` or standard
        error in the range, fewer valid bins than free parameters + 1, invalid ``model``,
        ``fix``, ``weights``, ``rolloff`` or ``lambda_0``.

    See Also
    --------
    model_acf : the fitted curve G(dr).
    gradient_from_fit : the scale-dependent rms gradient (eq. 26 of the fitted spectrum,
        or eq. 37/38).

    Notes
    -----
    *Computed once.*  A fit of an equal G (same values, coords and attrs, whichever object
    holds them) with equal options is not computed again in the same session: the result
    is handed out from memory (a copy, with the same warnings), so ``G.rough.fit()``
    followed by ``G.rough.persson(...)``, which needs that fit, fits once
    (:func:`xrough.memo.by_content`; ``fit_acf.cache_clear()`` forgets).

    *Residuals.*  Both models minimise ``sum_i [(ln G_model(dr_i) - ln G_i) / s_i]^2``
    with ``s_i = standard_error_i / G_i`` (the standard error of ``ln G``), or ``s_i = 1``
    unweighted: G spans decades and its errors are relative, so log residuals give every
    decade its weight and keep a large plateau from swamping the small-``dr`` bins.

    *Uncertainties.*  One standard deviation from the covariance ``(J^T J)^-1`` of the
    weighted residuals, multiplied by ``max(1, reduced chi^2)`` (by the reduced chi^2
    alone when unweighted), and propagated to derived quantities to first order.  The
    bins of a G measured on one surface are correlated (they share the same large-scale
    heights), so for such data the uncertainties are a lower bound; they are honest for
    independent errors.  On synthetic Gaussian surfaces (``L = 8 lambda_r``) with the
    standard errors of :func:`xrough.height_difference_acf`, ``hurst_std`` was 1.4 to 1.6
    times the scatter of ``H`` between realisations at 512^2 (``lambda_r`` = 64 pixels)
    but 0.5 to 0.8 times at 1024^2 (128 pixels): finer maps shrink the standard errors of
    the bins, not the scatter of the few modes near ``q_r``.

    *Spectrum model.*  ``G_sa`` is the self-affine asymptote at ``dr_ref``,
    ``G -> G_sa (dr/dr_ref)^(2H)`` for ``lambda_s << dr << lambda_r``, i.e.
    ``G_sa = C_r q_r^(2+2H) I(H) dr_ref^(2H) / 2pi`` with
    ``I(H) = 2^(-1-2H) Gamma(1-H) / (H Gamma(1+H))``; ``sigma_h^2`` and ``C_r`` follow
    from the moments of the fitted spectrum.  G is eq. 9 of the model spectrum in closed
    form (:mod:`xrough._kernels.model_acf`: Bessel-function integrals of one variable,
    to about 1e-13 for the sharp shape and 1e-10 for the smooth one; the smooth shape
    with ``lambda_s > lambda_r / 4`` or a ``lambda_0``, and the Gaussian cutoff, fall back
    to the quadrature of :func:`xrough._kernels.hankel.acf_from_spectrum_kernel`).  The optimiser
    (``scipy.optimize.least_squares``, trust-region reflective) works on ``ln G_sa``,
    ``H``, ``ln eta`` and ``ln eps`` with
    ``eta = (dr_max/lambda_r)^(2-2H)`` and ``eps = (lambda_s/dr_min)^(2H)``
    (``dr_min``, ``dr_max``: the fitted range), started from the fit of eq. 36.  To
    leading order ``eps`` (``eta``) is the relative change of G at the short (long) end
    of the range that its cutoff causes: once the cutoff lies beyond the lags, G depends
    on it only through ``eps`` (a constant shift of G, ``-G_sa (lambda_s/2 pi
    dr_ref)^(2H) / (2H I)``) or ``eta`` (a term in ``dr^2``), linearly, and ``eps = 0``
    (``eta = 0``) is the spectrum without that cutoff.  ``ln G_sa`` enters ``ln G``
    linearly: it is solved for at each step (variable projection) and the search runs over
    the other three.

    *Unresolved cutoffs.*  A cutoff is resolved when its ``eps`` (``eta``) exceeds twice
    its standard deviation, or (the roll-off) when the refit without it misses G by more
    than 3 times in a bin where the fit with it does not: the plot shows the plateau.
    Otherwise the data cannot tell it from no cutoff: it is set
    to none (``lambda_s = 0``, ``lambda_r = inf``) and the rest refitted.  Then
    ``lambda_s_resolved = 0`` and ``lambda_s`` is the upper bound
    ``dr_min (2 std(eps))^(1/(2H))`` (about 98 % one-sided) with NaN std: no ballistic
    regime in the data; and ``lambda_r_resolved = 0`` with ``lambda_r = sigma_h = C_r =
    inf`` (NaN std): no plateau.  With ``lambda_0`` the roll-off cannot move beyond
    ``lambda_0``; if it ends there, ``lambda_r = lambda_0`` (NaN std,
    ``lambda_r_resolved = 0``) and ``sigma_h`` is that of the truncated power law.  The
    standard deviations of the other parameters include the freedom of the unresolved
    cutoff (its column of ``J``), e.g. a ``lambda_s`` just below the data.

    *Checks* (docs/quality.md).  A fit is questionable when its rms misfit of ``ln G``
    exceeds 10 % (or, weighted, its reduced chi^2 20 with a misfit above 2 %), when ``H``
    ends within 0.05 of a bound, when (spectrum) eq. 36 fits with a 3 times smaller
    reduced chi^2 (the note recommends ``model='eq36'``; the model asked for is kept),
    or when a resolved ``lambda_r`` lies more than 10 times beyond the largest lag.  It
    has failed (parameters NaN) when its rms misfit exceeds 20 %, whatever its chi^2;
    when its cutoffs leave no self-affine range inside the lags; when a free ``H`` sits
    at its bound (within 0.05 of it and less than 2 standard deviations from it: the
    data do not determine H); or when it has fewer than 2 bins per free parameter.  A
    cutoff more than a decade outside the lags counts as unresolved, unless G shows it:
    a roll-off whose removal leaves the model more than 3 times off G in a bin, where
    with it the model is not, is kept (the plateau of a map whose bins at the largest
    lags have wide errors).  An unresolved ``lambda_s`` whose upper bound lies beyond
    the lags is NaN.  A poor first fit of the spectrum (reduced chi^2 above 10 or above
    that of eq. 36) restarts from the 3 best points of a grid of ``H``, ``ln eta``,
    ``ln eps`` and keeps the best: with cutoffs one decade apart the start from eq. 36
    can end in a local minimum (``H`` near 0.1, ``lambda_s`` beyond ``lambda_r``).

    *Roll-off shape.*  With ``rolloff='auto'`` both shapes are fitted to the same bins and
    compared by Akaike's information criterion of the weighted log residuals (AIC =
    chi^2 + 2 p; unweighted ``n ln(RSS/n) + 2 p``; both shapes have the same number of
    parameters, so this compares their chi^2).  The smooth shape is kept when its AIC is
    lower by more than 2 (a likelihood ratio of e, the usual threshold of substantial
    support); otherwise the data do not tell the shapes apart and eq. 35 (sharp) is kept.
    A fitted shape that failed counts as infinitely worse.  The choice matters: on a
    smooth-roll-off surface (1024^2, ``H = 0.8``, ``lambda_r`` = 128, ``lambda_s`` = 4
    pixels) the sharp shape gives ``H = 0.64 +- 0.01`` at a reduced chi^2 of 1.8 (rated
    good by every other check), the smooth one ``H = 0.77 +- 0.01`` at 0.11.  Because the
    bins of G are correlated the chi^2 difference overstates the evidence; the margin of 2
    is therefore a lower bound of what decides.  Fitting both costs more than the sharp fit
    alone (the smooth G of eq. 9 is slower to evaluate); pass ``rolloff`` to fit
    one shape.

    *Cutoff shape.*  A measured spectrum rarely ends as eq. 35 does: the instrument's
    transfer rolls it off over a decade, like ``exp(-(q/q_s)^2)``.  Fitted with the sharp
    cutoff, such a G gives an ``H`` too high by 0.1 to 0.2, rated good
    (``benchmarks/instrument_cutoffs.py``: 512^2, ``lambda_s`` = 4 pixels, ``H`` 0.65
    fitted as 0.77, ``H`` 0.3 as 0.48).  With ``cutoff='auto'``, where the sharp fit
    resolves ``lambda_s``, the same roll-off is fitted with the Gaussian cutoff (started at
    the same shift of G beyond ``lambda_s``), and the Gaussian is kept where its AIC is
    lower by more than 2 (eq. 35 otherwise, as for the roll-off).  Where the better fit's
    reduced chi^2 is below 1 (G's standard errors carry the scatter of the whole curve,
    which moves its bins together), both are compared on the scale of their misfit, as
    unweighted fits are (``n ln(RSS/n) + 2 p``).  The two fits' values of ``H`` and
    ``sigma_h`` are averaged with Akaike weights ``exp(-AIC/2)`` into their standard
    deviations (the spread about the value kept); where that spread of ``H`` exceeds its
    statistical error and 0.05 the data cannot tell ``H`` from the shape of the cutoff,
    and the fit is questionable (``cutoff_shape_undetermined``).  ``lambda_s`` of the
    Gaussian is the ``2 pi / q_s`` of its ``exp(-(q/q_s)^2)``: shorter, by
    ``Gamma(1-H)^(1/(2H))``, than a sharp cutoff with the same shift of G.  On maps
    through a Gaussian transfer (512^2 and 1024^2, ``H`` 0.3 and 0.65, open and periodic,
    40 seeds each) the default fit gives ``H`` with a mean pull of -0.04 to +0.33 and a
    pull scatter of 0.85 to 1.00, ``sigma_h_std`` 1.03 to 1.48 times the scatter of
    ``sigma_h``; on eq. 35 maps it keeps the sharp cutoff in 80 of 80.  The Gaussian's G is
    a quadrature: where it is fitted the fit costs more than the sharp one
    (``python benchmarks/bench_fit.py``).

    *Which model.*  Eq. 36 approaches the self-affine law as ``dr^(2H-2)`` from the
    ballistic side and as ``dr^(2H)`` from the plateau side, whereas G of eq. 35 does so
    as ``(q_s dr)^(-2H)`` and ``(q_r dr)^(2-2H)``: the crossovers match in form only at
    ``H = 1/2``, and eq. 36 levels off more slowly than G.  Its parameters are those of
    the best interpolation, not of the surface: on the exact G of eq. 35
    (``lambda_r/lambda_s = 1e6``, fitted from ``lambda_s/100`` to ``100 lambda_r``) ``H``
    comes out 0.321, 0.501, 0.764 for ``H = 0.3, 0.5, 0.8``, ``sigma_h`` 9, 6, 3 % high and
    ``lambda_r`` at 0.75, 1.02, 1.25 of its value; with only 1.8 decades of self-affine
    scaling (``lambda_r/lambda_s = 64``) ``H`` is off by up to 0.1 and ``lambda_r`` by up
    to 40 %, and the standard deviations do not include this bias.  The spectrum model
    returns the parameters of the exact G to 1e-9, and on synthetic Gaussian surfaces
    (512^2, ``L = 8 lambda_r``, ``lambda_s`` = 4 pixels, 20 seeds) ``H`` without bias
    (mean error <= 0.003; scatter 0.009 to 0.026 between realisations, growing with
    ``H``) and ``sigma_h`` within 1 % of each realisation's rms height.  It is therefore
    the default; eq. 36 stays for its closed form (the paper's eq. 37/38 build on it),
    for speed, and for G that is not of the self-affine form.

    *Eq. 36 details.*  Parameters of the optimiser (method ``dogbox``, whose active set
    puts a parameter exactly on its bound) are ``ln C_sa``, ``H``, ``C_b`` and
    ``1/sigma_h^2`` (the last two linear, so that they can reach their bound 0), started
    from the best of non-negative linear least-squares fits of ``1/G`` on a grid of
    ``H``.  ``G_sa = dr_ref^(2H) / C_sa`` (``C_sa`` has the units length^(2H-2), which CF
    cannot spell); ``dr_ref`` is the power of ten nearest the geometric mean of the fitted
    lags, so that ``G_sa`` is far less correlated with ``H`` than ``C_sa``.  The roll-off
    wavelength: ``dr_x = (C_sa sigma_h^2)^(1/(2H))`` is where the self-affine term equals
    the plateau term; for the model spectra (no lower cutoff, ``lambda_s << lambda_r``)
    the self-affine asymptote of G meets ``sigma_h^2`` at ``q_r dr_x = kappa(H)`` (see
    :func:`xrough._kernels.shape_factors.rolloff_crossover`; ``kappa = 1.674, 1.5,
    1.066`` at ``H = 0.3, 0.5, 0.8`` for the sharp shape), so
    ``lambda_r = 2 pi dr_x / kappa(H)``, exact when the fitted ``C_sa`` and ``sigma_h``
    are the asymptotic ones.

    Examples
    --------
    The exact G of eq. 35 (``H = 1/2``, ``sigma_h = 2 nm``, two decades of self-affine
    scaling):

    >>> import xrough
    >>> from xrough.fitting import fit_acf
    >>> C = xrough.model_spectrum(hurst=0.5, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_height="2 nm", unit="nm")
    >>> G = xrough.acf_from_spectrum(C, dr_min=1, dr_max=1e5)
    >>> p = fit_acf(G)
    >>> print(f"H = {float(p.hurst):.4f}, sigma_h = {float(p.sigma_h):.4f} nm, "
    ...       f"lambda_r = {float(p.lambda_r):.1f} nm, lambda_s = {float(p.lambda_s):.3f} nm")
    H = 0.5000, sigma_h = 2.0000 nm, lambda_r = 1000.0 nm, lambda_s = 10.000 nm
    >>> p.attrs["weighting"], p.attrs["plateau"]
    ('none (G has no standard_error coordinate)', 'resolved')

    The closed form of eq. 36 on the same data:

    >>> q = fit_acf(G, model="eq36")
    >>> print(f"H = {float(q.hurst):.3f}, sigma_h = {float(q.sigma_h):.2f} nm")
    H = 0.560, sigma_h = 2.05 nm
    """
    setup = prepare_fit(G, model=model, dr_min=dr_min, dr_max=dr_max, weights=weights,
                        fix=fix, rolloff=rolloff, lambda_0=lambda_0, cutoff=cutoff)
    return _fit_dataset(setup, _fit_curves(setup))


# --------------------------------------------------------------------------------------
# a fit, step by step: arguments -> data in one length unit -> kernel per curve -> Dataset
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FitSetup:
    """What :func:`fit_acf` decided before fitting: G, its weights and the kernel options.

    Lengths in ``lateral`` (the unit of the lags of G); G and its standard errors in its
    square.  ``lambda_0`` is ``inf`` for eq. 36 (no such parameter).
    """

    G: xr.DataArray
    acf: AcfSpec
    model: str
    rolloff: str
    cutoff: str
    height: PlainUnit
    g_unit: PlainUnit
    use: np.ndarray
    weighted: bool
    weighting: str
    standard_error: xr.DataArray
    fixed: np.ndarray
    fixed_text: str
    lambda_0: float
    dr_ref: float

    @property
    def lateral(self) -> PlainUnit:
        return self.acf.length_unit

    @property
    def kernel(self):
        return fit_eq36_kernel if self.model == "eq36" else fit_spectrum_kernel

    @property
    def outputs(self) -> tuple[str, ...]:
        return EQ36_OUTPUTS if self.model == "eq36" else SPECTRUM_OUTPUTS

    @property
    def options(self) -> dict:
        """Keyword arguments of :attr:`kernel` for every curve (all but G and its errors)."""
        extra = {} if self.model == "eq36" else {"lambda_0": self.lambda_0,
                                                 "errors": error_model(self.G),
                                                 "cutoff": self.cutoff}
        return {"dr": self.acf.dr, "use": self.use, "dr_ref": self.dr_ref,
                "weighted": self.weighted, "fixed": self.fixed, "rolloff": self.rolloff,
                "unit": self.acf.unit_str, **extra}

    @property
    def gradient_options(self) -> dict:
        """Options of :func:`~xrough._kernels.fitting.fitted_spectrum_gradient`.

        For the outputs of :attr:`kernel` (which are in ``lateral``; spectrum model only).
        """
        return {"dr_ref": self.dr_ref, "lam_0": self.lambda_0, "g_factor": 1.0}

    def inputs(self) -> tuple[xr.DataArray, xr.DataArray]:
        """G and its standard errors in ``lateral^2``, without their per-bin coords."""
        def strip(da):
            return da.drop_vars([c for c in da.coords if "dr" in da[c].dims and c != "dr"])
        return strip(self.G * self.acf.g_factor), strip(self.standard_error)


def _model_and_rolloff(model: str, rolloff: str | None) -> tuple[str, str]:
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")
    shapes = ROLLOFFS if model == "eq36" else ("auto", *ROLLOFFS)
    rolloff = ("sharp" if model == "eq36" else "auto") if rolloff is None else rolloff
    if rolloff not in shapes:
        raise ValueError(f"rolloff must be one of {shapes} for model={model!r}, got "
                         f"{rolloff!r}")
    return model, rolloff


def _cutoff_shape(model: str, cutoff: str | None) -> str:
    """Check the short-wavelength cutoff shape asked of :func:`fit_acf` (default ``'auto'``)."""
    if model == "eq36":
        if cutoff not in (None, "sharp"):
            raise ValueError(f"cutoff={cutoff!r} applies to model='spectrum' only (eq. 36 "
                             "has no cutoff shape)")
        return "sharp"
    cutoff = "auto" if cutoff is None else cutoff
    if cutoff not in ("auto", *CUTOFFS):
        raise ValueError(f"cutoff must be one of {('auto', *CUTOFFS)}, got {cutoff!r}")
    return cutoff


def _lags_used(acf: AcfSpec, dr_min: QuantityLike | None,
               dr_max: QuantityLike | None) -> np.ndarray:
    """Mask of the positive lags of G in ``[dr_min, dr_max]``."""
    lateral, dr = acf.length_unit, acf.dr
    lo = 0.0 if dr_min is None else u.length_in(dr_min, lateral, what="dr_min")
    hi = np.inf if dr_max is None else u.length_in(dr_max, lateral, what="dr_max")
    use = (dr > 0) & (dr >= lo * (1 - 1e-12)) & (dr <= hi * (1 + 1e-12))
    if not np.any(use):
        raise ValueError(f"no lag of G lies in [dr_min, dr_max] = [{lo:g}, {hi:g}] "
                         f"{u.format_units(lateral)}")
    return use


def _weighting(G: xr.DataArray, lateral: PlainUnit, weights: str | None) -> tuple:
    """``(weighted, description, standard error in lateral^2 or ones)``."""
    if weights not in ("standard_error", None):
        raise ValueError(f"weights must be 'standard_error' or None, got {weights!r}")
    if weights == "standard_error" and "standard_error" in G.coords:
        se_da = bin_error(G)
        se_factor = u.conversion_factor(_area_unit(se_da, "coordinate 'standard_error'"),
                                        lateral**2)
        return (True, "standard_error (1/standard error of ln G)",
                (se_da * se_factor).broadcast_like(G))
    return (False, "none" if weights is None else "none (G has no standard_error coordinate)",
            xr.ones_like(G))


def _long_cutoff(model: str, lambda_0: QuantityLike | None, lateral: PlainUnit) -> float:
    if model == "eq36":
        if lambda_0 is not None:
            raise ValueError("lambda_0 applies to model='spectrum' only")
        return np.inf
    return np.inf if lambda_0 is None else u.length_in(lambda_0, lateral, what="lambda_0")


def prepare_fit(G: xr.DataArray, *, model: str = "spectrum", dr_min: Any = None,
                dr_max: Any = None, weights: str | None = "standard_error",
                fix: dict | None = None, rolloff: str | None = None,
                lambda_0: Any = None, cutoff: str | None = None) -> FitSetup:
    """Check the arguments of :func:`fit_acf` (the same) and set up its kernel.

    Raises what :func:`fit_acf` raises for its arguments; the fit of each curve (and its
    errors about too few bins) is left to :attr:`FitSetup.kernel`.
    """
    model, rolloff = _model_and_rolloff(model, rolloff)
    cutoff = _cutoff_shape(model, cutoff)
    G, acf = read_acf(G)
    g_unit = u.units_of(G, what="G")
    use = _lags_used(acf, dr_min, dr_max)
    G = G.chunk({"dr": -1}) if G.chunks is not None else G  # each fit needs all lags
    weighted, weighting, se = _weighting(G, acf.length_unit, weights)
    lam0 = _long_cutoff(model, lambda_0, acf.length_unit)
    fixed, fixed_text = fixed_parameters(fix, model, acf.length_unit, g_unit**0.5, lam0)
    return FitSetup(G=G, acf=acf, model=model, rolloff=rolloff, cutoff=cutoff,
                    height=g_unit**0.5,
                    g_unit=g_unit, use=use, weighted=weighted, weighting=weighting,
                    standard_error=se, fixed=fixed, fixed_text=fixed_text, lambda_0=lam0,
                    dr_ref=reference_lag(acf.dr[use], acf.length_unit))


def _fit_curves(setup: FitSetup) -> xr.DataArray:
    """Fit every curve: the kernel's outputs on the dim ``fit_output``.

    Each curve's covariance carries its own regions' factor (:func:`inflation_of`).
    """
    G, se = setup.inputs()
    factor = inflation_of(setup.G)
    kernel = setup.kernel

    def per_curve(g, s, kk, **kw):
        if kw.get("errors"):
            kw = {**kw, "errors": {**kw["errors"], "inflation": kk}}
        return kernel(g, s, **kw)

    return xr.apply_ufunc(
        per_curve, G, se, xr.ones_like(G) if factor is None else factor,
        input_core_dims=[["dr"], ["dr"], ["dr"]], output_core_dims=[["fit_output"]],
        vectorize=True, dask="parallelized", output_dtypes=[float],
        dask_gufunc_kwargs={"output_sizes": {"fit_output": len(setup.outputs)}},
        kwargs=setup.options, keep_attrs=False,
    )


def _parameter_table(setup: FitSetup) -> dict:
    """``name: (factor from the kernel's units, CF units, long_name)`` of each parameter."""
    lat_s = u.format_units(setup.lateral)
    to_g = 1.0 / setup.acf.g_factor
    spec = {
        "sigma_h": (u.conversion_factor(setup.lateral, setup.height),
                    u.format_units(setup.height), "rms height (plateau of G: G -> sigma_h^2)"),
        "G_sa": (to_g, u.format_units(setup.g_unit), "self-affine term of G at dr_ref"),
        "hurst": (1.0, "1", "Hurst exponent"),
    }
    if setup.model == "eq36":
        spec["C_b"] = (1.0, "1", "ballistic coefficient (gbar^2(0) = 4/C_b)")
        spec["lambda_r"] = (1.0, lat_s, "roll-off wavelength")
        return spec
    spec["lambda_r"] = (1.0, lat_s, "roll-off wavelength 2 pi / q_r")
    spec["lambda_s"] = (1.0, lat_s, "short-wavelength cutoff 2 pi / q_s (upper bound "
                                    "where lambda_s_resolved = 0; NaN: no bound "
                                    "within the lags)")
    spec["C_r"] = (to_g, u.format_units(setup.g_unit * setup.lateral**2),
                   "plateau of the spectrum, C(q -> 0)")
    return spec


def _flag(da: xr.DataArray, dtype, long_name: str, **attrs) -> xr.DataArray:
    return da.astype(dtype).assign_attrs(long_name=long_name, units="1", **attrs)


def _fit_variables(setup: FitSetup, part: dict, out: xr.DataArray) -> dict:
    """Build the data variables of the fit Dataset from the kernel's outputs ``part``."""
    data = {}
    error_of = (ERROR_OF_SURFACE if setup.model == "spectrum" and error_model(setup.G)
                else ERROR_OF_BINS)
    for name, (factor, units, long_name) in _parameter_table(setup).items():
        data[name] = _variable(part[name] * factor, units, long_name)
        data[f"{name}_std"] = _variable(part[f"{name}_std"] * factor, units,
                                        f"standard deviation of {name}").assign_attrs(
                                            error_of=error_of)
    data["reduced_chi2"] = _variable(part["reduced_chi2"], "1",
                                     "reduced chi^2 of the fit (log residuals)")
    data["n_bins"] = _variable(part["n_bins"].astype(np.int64), "1", "number of bins fitted")
    data["rms_misfit"] = _variable(part["rms_misfit"], "1",
                                   "rms of ln G_model - ln G over the bins (weighted as the "
                                   "fit): the typical relative misfit of G")
    data["max_misfit_factor"] = _variable(
        part["max_misfit_factor"], "1",
        "largest factor between the model and G over the bins fitted, "
        "exp(max |ln G_model - ln G|)")
    if setup.model == "spectrum":
        data["reduced_chi2_eq36"] = _variable(
            part["reduced_chi2_eq36"], "1",
            "reduced chi^2 of eq. 36 on the same bins (the fit's starting point)")
        data["rolloff_shape"] = _flag(
            part["rolloff_shape"], np.int8, "roll-off shape of the fitted model spectrum",
            **quality.cf_flags(ROLLOFFS, np.int8))
        data["reduced_chi2_other_rolloff"] = _variable(
            part["reduced_chi2_other_rolloff"], "1",
            "reduced chi^2 of the other roll-off shape on the same bins (NaN: not fitted)")
        data["cutoff_shape"] = _flag(
            part["cutoff_shape"], np.int8,
            "short-wavelength cutoff of the fitted model spectrum",
            **quality.cf_flags(CUTOFFS, np.int8))
        data["reduced_chi2_other_cutoff"] = _variable(
            part["reduced_chi2_other_cutoff"], "1",
            "reduced chi^2 of the other cutoff shape on the same bins (NaN: not fitted)")
    data["fit_problems"] = _flag(
        part["fit_problems"], np.int16,
        "checks of the fit that failed (bit per check; see docs/quality.md)",
        **quality.cf_flags(PROBLEMS, np.int16, masks=True))
    if setup.model == "spectrum":
        data[COVARIANCE] = _covariance(out, error_of)
        data["lambda_r_resolved"] = _variable(
            part["lambda_r_resolved"].astype(np.int8), "1",
            "1: lambda_r fitted; 0: no roll-off in the data")
        data["lambda_s_resolved"] = _variable(
            part["lambda_s_resolved"].astype(np.int8), "1",
            "1: lambda_s fitted; 0: no ballistic regime in the data, lambda_s is an "
            "upper bound")
    return data


def _covariance(out: xr.DataArray, error_of: str) -> xr.DataArray:
    """Build the covariance of a spectrum fit's parameters, on the dims ``cov_i``, ``cov_j``.

    ``out``: the kernel's outputs (dim ``fit_output`` last, one chunk).
    """
    names = list(COVARIANCE_PARAMETERS)
    cov = xr.DataArray(fit_covariance(out.data), dims=(*out.dims[:-1], *COVARIANCE_DIMS),
                       coords={c: v for c, v in out.coords.items() if "fit_output" not in v.dims})
    return cov.assign_coords({d: (d, names, {"long_name": "parameter of the fit"})
                              for d in COVARIANCE_DIMS}).assign_attrs(
        units="1", long_name="covariance of the fit's parameters",
        parameters="ln_G_sa = ln G_sa; hurst; eta = (dr_ref / lambda_r)^(2 - 2 hurst), 0 "
                   "where lambda_r_resolved = 0; eps = (lambda_s / dr_ref)^(2 hurst), 0 "
                   "where lambda_s_resolved = 0 (the fit is linear in a cutoff near none); "
                   "rows and columns of fixed parameters are 0",
        error_of=error_of)


def _fit_attrs(setup: FitSetup, part: dict, single: bool) -> dict:
    """Build the attributes of the fit Dataset (``single``: one computed fit)."""
    eq36 = setup.model == "eq36"
    used = setup.acf.dr[setup.use]
    attrs = result_attrs(setup.G, **{
        "long_name": ("fit of the three-regime form of G" if eq36
                      else "fit of the model spectrum to G"),
        "model": setup.model,
        "equation": _EQ36 if eq36 else _SPECTRUM_EQ.format(rolloff=setup.rolloff),
        "weighting": setup.weighting,
        "residuals": "ln G",
        "dr_min": float(used.min()),
        "dr_max": float(used.max()),
        "dr_units": u.format_units(setup.lateral),
        "fixed": setup.fixed_text,
        "rolloff": setup.rolloff,
        "uncertainty": ("1 standard deviation from the least-squares covariance times "
                        + ("max(1, reduced_chi2)" if setup.weighted else "reduced_chi2")),
    })
    attrs.setdefault("source", str(setup.G.attrs.get("estimator", "")))
    if eq36:
        attrs["lambda_r_definition"] = (
            "2 pi dr_x / kappa(H): dr_x = (C_sa sigma_h^2)^(1/(2H)) where the self-affine "
            f"and plateau terms are equal, kappa(H) = q_r dr_x of the {setup.rolloff} "
            "model spectrum")
    else:
        attrs.update(_spectrum_attrs(setup, part, single))
    if single:  # a single fit: its chi^2 as an attribute too
        attrs["reduced_chi2"] = float(part["reduced_chi2"])
    return attrs


def _spectrum_attrs(setup: FitSetup, part: dict, single: bool) -> dict:
    """How the roll-off shape was chosen, the cutoffs and (one fit) what was resolved."""
    auto = setup.rolloff == "auto"
    attrs = {"rolloff_choice": (
        "by evidence: both shapes fitted, smooth kept when its AIC (chi^2 + 2 p of the "
        f"log residuals) is lower by more than {AIC_MARGIN:g}, else sharp (eq. 35)"
        if auto else "given")}
    if auto and single:
        attrs["rolloff"] = ROLLOFFS[int(part["rolloff_shape"])]
    attrs["cutoff_choice"] = (
        "by evidence: where the sharp cutoff (eq. 35) resolves lambda_s, a Gaussian one "
        "(C times exp(-(q/q_s)^2)) is fitted too and kept where its AIC is lower by more "
        f"than {AIC_MARGIN:g}; their spread enters hurst_std and sigma_h_std"
        if setup.cutoff == "auto" else "given")
    attrs["cutoff"] = (CUTOFFS[int(part["cutoff_shape"])] if single
                       else setup.cutoff)
    attrs["cutoffs"] = _CUTOFFS
    if single:
        attrs["ballistic_regime"] = ("resolved" if int(part["lambda_s_resolved"])
                                     else "unresolved: lambda_s is an upper bound")
        attrs["plateau"] = ("resolved" if int(part["lambda_r_resolved"]) else
                            "unresolved: lambda_r = " + ("sigma_h = inf" if
                                                         np.isinf(setup.lambda_0)
                                                         else "lambda_0"))
    return attrs


def _fit_dataset(setup: FitSetup, out: xr.DataArray) -> xr.Dataset:
    """Build the fit Dataset of :func:`fit_acf` from the kernel's outputs ``out``."""
    part = {name: out.isel(fit_output=k, drop=True) for k, name in enumerate(setup.outputs)
            if not name.startswith("cov_")}
    single = out.ndim == 1 and out.chunks is None
    lat_s = u.format_units(setup.lateral)
    ds = xr.Dataset(_fit_variables(setup, part, out), attrs=_fit_attrs(setup, part, single))
    ds = ds.assign_coords(dr_ref=((), setup.dr_ref, {"units": lat_s,
                                                     "long_name": "reference lag of G_sa"}))
    if setup.model == "spectrum":
        ds = ds.assign_coords(lambda_0=((), setup.lambda_0, {
            "units": lat_s, "long_name": "long-wavelength cutoff of the model (inf: none)"}))
    lazy = part["quality"].chunks is not None
    notes = "" if lazy else _fit_notes(ds, ds["fit_problems"].values, setup.model,
                                       setup.weighted,
                                       int(np.count_nonzero(np.isnan(setup.fixed))) + 1)
    ds = quality.mark_curves(ds, part["quality"], what=f"fit_acf (model {setup.model!r})",
                             reason="fit", notes=notes)
    return mark_gaps(ds, setup.acf, what="fit_acf", level="good", depends="the fit uses "
                     "the measured bins only; over the gap G is bridged by the fitted model")
