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
from typing import TYPE_CHECKING, Any, TypeVar, cast

import numpy as np
import xarray as xr

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
    with_coord_attrs,
)
from .fit_result import (  # noqa: F401  (read a fit; public here)
    COVARIANCE,
    COVARIANCE_DIMS,
    model_acf,
    rolloff_shapes,
)
from .memo import by_content
from .units import QuantityLike

if TYPE_CHECKING:
    from pint.facets.plain import PlainUnit

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

    ``model="spectrum"`` fits eq. 35 (or its smooth roll-off) through its exact G of eq. 9,
    ``model="eq36"`` ``1/G = C_b/dr^2 + C_sa/dr^(2H) + 1/sigma_h^2``; both fit ``ln G``.  Notes
    (formulas, all outputs, errors, cutoffs, shapes, which model, caching): docs/theory.md,
    "fit_acf in detail"; the checks: docs/quality.md, "fit_acf".

    Parameters
    ----------
    G : xarray.DataArray with dims (..., "dr")
        Height-difference ACF in length^2 on a lag coordinate ``dr`` in length (``units`` on
        both), e.g. from :func:`xrough.height_difference_acf`; extra dims fitted one by one.
    model : {'spectrum', 'eq36'}
        The model spectrum (default, unbiased) or eq. 36 (cheaper; ``H`` biased by up to 0.1).
    dr_min, dr_max : float, str or pint.Quantity, optional
        Range of lags to fit (plain numbers in the unit of ``dr``); default: all.
    weights : {'standard_error', None}
        Weight by the coordinate ``standard_error`` of ``G`` (length^2) if any, or not.
    fix : dict, optional
        Fixed parameters (lengths in the unit of ``dr``): ``"hurst"``, ``"lambda_r"`` (inf:
        no roll-off), ``"lambda_s"`` (0: no cutoff); eq36: ``"hurst"``, ``"C_b"``, ``"sigma_h"``.
    rolloff : {'auto', 'sharp', 'smooth'}, optional
        Roll-off shape; ``'auto'`` (spectrum default) fits both, keeps the better (eq36: sharp).
    lambda_0 : float, str or pint.Quantity, optional
        Spectrum only: long-wavelength cutoff ``2 pi / q_0`` (e.g. a periodic map's size).
    cutoff : {'auto', 'sharp', 'gaussian'}, optional
        Spectrum only: eq. 35's cutoff or ``exp(-(q/q_s)^2)``; ``'auto'`` fits both.

    Returns
    -------
    xarray.Dataset
        ``sigma_h``, ``G_sa``, ``hurst``, ``lambda_r`` (spectrum: ``lambda_s``, ``C_r``; eq36:
        ``C_b``), each with ``<name>_std``; ``reduced_chi2``, ``fit_problems``, ``quality_flag``.

    Raises
    ------
    ValueError
        Missing or non-length units, no ``dr``, ``G`` or errors <= 0, too few bins, bad options.

    See Also
    --------
    model_acf : the fitted curve G(dr).
    gradient_from_fit : the rms gradient of the fit (eq. 26, or eq. 37/38).

    Examples
    --------
    >>> import xrough
    >>> C = xrough.model_spectrum(hurst=0.5, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_height="2 nm", unit="nm")
    >>> G = xrough.acf_from_spectrum(C, dr_min=1, dr_max=1e5)
    >>> p = fit_acf(G)
    >>> print(f"H = {float(p.hurst):.4f}, sigma_h = {float(p.sigma_h):.4f} nm, "
    ...       f"lambda_r = {float(p.lambda_r):.1f} nm, lambda_s = {float(p.lambda_s):.3f} nm")
    H = 0.5000, sigma_h = 2.0000 nm, lambda_r = 1000.0 nm, lambda_s = 10.000 nm
    >>> p.attrs["weighting"], p.attrs["plateau"]
    ('none (G has no standard_error coordinate)', 'resolved')
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
    ds = with_coord_attrs(ds, setup.G)  # G's coords (height_variance) that apply_ufunc bared
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
