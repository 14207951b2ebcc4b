"""Scale-dependent rms gradient gbar(dr) (eq. 26), by every route.

``gbar^2(dr) = (1/2pi) int_0^{2pi/dr} dq q^3 C(q)`` (eq. 26) is the mean-square slope of
the surface with all wavelengths shorter than ``dr`` removed; it is what Persson theory
needs at resolution ``dr``. Routes:

:func:`gradient_from_spectrum`
    eq. 26 of a spectrum (closed form for the model spectra).
:func:`rms_gradient_exact`
    eq. 26 of the spectrum of a measured G (eq. 10/11), where G determines it.
:func:`gradient_from_fit`
    eq. 26 of the fitted model spectrum, or eq. 37/38 for a fit of eq. 36 (it reads a fit,
    so it lives in :mod:`xrough.fit_result` with the rest of that).
:func:`rms_gradient`
    any of these from a G (``method="exact"``, ``"fit"``), the ballistic approximation
    ``gbar^2 = 4 G / dr^2`` (``"simple"``), or the first that G supports (``"auto"``);
    lazy on a chunked G.

The numpy kernels are in :mod:`xrough._kernels.gradient`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from . import quality
from . import units as u
from ._kernels import gradient as kernels
from ._kernels.binning import log_range
from ._kernels.hankel import binned_moment_kernel, power_law_moment_kernel
from ._kernels.spectral_models import model_gradient2
from .acf import (
    ERROR_OF_NONE,
    ERROR_OF_SURFACE,
    error_model,
    inflation_of,
    lag_coord,
    mark_gaps,
    read_acf,
    result_attrs,
    strip_marks,
)
from .fit_result import gradient_from_fit
from .fitting import describe_problems, fit_acf, prepare_fit
from .memo import by_content
from .models import model_attrs
from .preprocess import lag_window
from .spectra import acf_samples, check_spectrum_options, spectrum_input, spectrum_lags
from .units import QuantityLike

__all__ = ["rms_gradient", "rms_gradient_exact", "gradient_from_spectrum",
           "gradient_from_fit", "GRADIENT_METHODS"]

GRADIENT_METHODS = ("auto", "exact", "simple", "fit")
_EXACT_DEFAULTS = {"smooth": None, "support_rtol": 0.01, "interpolation": "hermite",
                   "points_per_decade": 40}
_EQUATIONS = {
    "exact": "eq. 26 with C(q) from eq. 10/11",
    "simple": "gbar^2 ~ 4 G(dr) / dr^2 (ballistic approximation of eq. 26)",
    "fit": "eq. 26 of the fitted model spectrum",
    "exact+fit": "eq. 26 with C(q) from eq. 10/11 where G determines it, eq. 26 of the "
                 "fitted model spectrum on the other lags",
    "exact+simple": "eq. 26 with C(q) from eq. 10/11 where G determines it, gbar^2 ~ "
                    "4 G(dr) / dr^2 on the other lags",
}


#: What of gbar depends on G inside a gap (:func:`xrough.acf.mark_gaps`).
_GAP = ("the exact route integrates the spectrum of G (eq. 26 of eq. 10/11), a transform "
        "of G across the gap, so gbar at lags below and next to the gap rests on the "
        "bridge; the fit route takes the fitted model there, the ballistic one (simple) "
        "only G at each lag")


def _gradient_da(gbar: np.ndarray, dr: np.ndarray, unit_str: str, attrs: dict) -> xr.DataArray:
    """``gbar(dr)`` (eq. 26) as a DataArray on dim ``"dr"`` in ``unit_str``."""
    return xr.DataArray(gbar, dims=("dr",), coords=lag_coord(dr, unit_str), name="gbar",
                        attrs={"units": "1", "long_name": "scale-dependent rms gradient",
                               "equation": "eq. 26", **attrs})


def _noise(G: xr.DataArray) -> xr.DataArray:
    """Relative independent scatter per bin: ``sampling_error / G`` (random pairs) or 0."""
    if "sampling_error" not in G.coords:
        return strip_marks(xr.zeros_like(G))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = (strip_marks(G.coords["sampling_error"].broadcast_like(G))
               / strip_marks(G)).fillna(0.0)
    return rel


@u.accepts_quantified
def rms_gradient(G: xr.DataArray, *, method: str = "auto",
                 fit: xr.Dataset | None = None) -> xr.DataArray:
    r"""Scale-dependent rms gradient ``gbar(dr)`` (eq. 26 or its approximations).

    Parameters
    ----------
    G : xarray.DataArray
        Height-difference ACF on dim ``dr`` (length^2, ``dr`` in length).
    method : {'auto', 'exact', 'simple', 'fit'}
        Eq. 26 via the spectrum from eq. 10/11; ``sqrt(4 G / dr^2)``; or from the fit of G
        (eq. 26 of the fitted spectrum, or eq. 37/38 for eq. 36). ``'auto'`` (default)
        decides per curve: ``'exact'`` where G determines it and the fit on the other lags
        (``'exact+fit'``), the fit everywhere when the exact gradient covers fewer than half
        of the lags, ``'simple'`` only if the fit fails (``'exact+simple'`` where the
        exact gradient covers part of the lags); a fit whose checks failed counts as no
        fit. The coordinate ``gradient_method`` records the route (CF flags); for one
        curve ``attrs["method"]`` and ``attrs["fallback_reason"]`` say it in words.
        Whatever the route, where G is a smooth surface's at its first lags (``a dr^2 +
        b dr^4`` through its first two bins with ``|b| dr^2 / a`` at most 0.05, the
        weight falling to 0 at 0.08), gbar there is eq. 26's full gradient ``sqrt(4 a)``
        and no lag's gbar exceeds it (docs/quality.md).
    fit : xarray.Dataset, optional
        A :func:`xrough.fit_acf` result of this G, reused by ``'fit'`` and ``'auto'``
        instead of fitting again. Without it, a default fit of this G that the session
        has already made (``G.rough.fit()``) is reused; ``'auto'`` otherwise fits only
        the curves whose exact gradient leaves lags open.

    Returns
    -------
    xarray.DataArray
        ``gbar`` on every lag of ``G`` (dimensionless, ``units="1"``), NaN where the
        method does not determine it (``'exact'`` outside the range G supports, see
        :func:`xrough.rms_gradient_exact`), ``attrs["method"]`` and the paper equation,
        and the quality marks of docs/quality.md: the coordinate ``quality_flag`` and,
        for one computed curve, ``attrs["quality"]``/``["quality_notes"]`` (``'auto'``:
        questionable where the fit was questionable or the ballistic form was used;
        ``'fit'``: the fit's flag; ``'exact'``, ``'simple'``: good). The coordinate
        ``gbar_std`` is its statistical standard deviation (the linear response of eq. 26
        to the covariance of G's bins; NaN where G states no map geometry, attr
        ``error_of``).

    Raises
    ------
    ValueError
        If ``G`` is not a height-difference ACF or ``method`` is unknown.

    Notes
    -----
    .. math:: \bar g^2(\Delta r) = \frac{1}{2\pi}\int_0^{2\pi/\Delta r} dq\, q^3 C(q)
              \approx \frac{4 G(\Delta r)}{\Delta r^2}

    Examples
    --------
    >>> import numpy as np, xarray as xr
    >>> dr = xr.DataArray([1.0, 2.0, 4.0], dims="dr", name="dr", attrs={"units": "nm"})
    >>> G = xr.DataArray([0.25, 1.0, 4.0], dims="dr", coords={"dr": dr},
    ...                  attrs={"units": "nm2"})  # ballistic: G = gbar^2 dr^2 / 4, gbar = 1
    >>> rms_gradient(G, method="simple").values
    array([1., 1., 1.])
    """
    if method not in GRADIENT_METHODS:
        raise ValueError(f"method must be one of {GRADIENT_METHODS}, got {method!r}")
    if fit is None and method == "auto":
        fit = fit_acf.peek(G)  # the fit of this G that the chain has made, if any
    # at least as questionable as G and, where it is used, the fit (outside the memo,
    # whose key ignores their ratings)
    out = quality.inherit(_rms_gradient(G, method, fit), G, what="rms_gradient")
    if fit is not None and method in ("fit", "auto"):
        out = quality.inherit(out, _rating_where_used(fit, out), what="rms_gradient")
    return out


def _rating_where_used(fit: xr.Dataset, gbar: xr.DataArray) -> xr.DataArray:
    """Give the fit's rating on the curves whose gradient it gives (all, or route 1/3)."""
    used = xr.DataArray(True)
    if "gradient_method" in gbar.coords:
        code = gbar["gradient_method"].reset_coords(drop=True)
        used = (code == 1) | (code == 3)
    flag = xr.where(used, quality.flag_of(fit), np.int8(0)).astype(np.int8)
    coords = {quality.FLAG: quality.flag_coord(flag, what="fit_acf")}
    if quality.REASON in fit.coords:
        reasons = fit[quality.REASON].reset_coords(drop=True)
        coords[quality.REASON] = quality.reasons_coord(xr.where(used, reasons, 0))
    proxy = xr.zeros_like(coords[quality.FLAG].variable, dtype=float)
    return xr.DataArray(proxy, attrs={
        "quality_notes": fit.attrs.get("quality_notes", "")}).assign_coords(coords)


@by_content()
def _rms_gradient(G: xr.DataArray, method: str, fit: xr.Dataset | None) -> xr.DataArray:
    """:func:`rms_gradient` once per content: Persson theory and the user share it."""
    G, spec = read_acf(G)
    G = G.transpose(..., "dr")
    if G.chunks is not None:
        G = G.chunk({"dr": -1})  # each curve needs all its lags
    dr = spec.dr
    Gl = strip_marks(G) * spec.g_factor  # in the square of dr's unit
    common: dict[str, Any] = dict(
        input_core_dims=[["dr"], ["dr"]], output_core_dims=[["dr"]], vectorize=True,
        dask="parallelized", output_dtypes=[float], keep_attrs=False)
    extra_attrs: dict = {}
    extra = [d for d in Gl.dims if d != "dr"]
    level = xr.DataArray(np.zeros([Gl.sizes[d] for d in extra], dtype=np.int8), dims=extra)
    notes = ""  # 'simple' and 'exact' are what they say: good
    errors = error_model(G)  # lengths in dr's unit, as Gl
    fit_rel = None  # the relative error of gbar where the fit gives it
    if method == "simple":
        out = xr.apply_ufunc(kernels.simple_gradient, xr.DataArray(dr, dims="dr"), Gl,
                             dask="parallelized", output_dtypes=[float], keep_attrs=False)
    elif method == "fit":
        params = fit_acf(G) if fit is None else fit
        out = _fitted_on_lags(params, G)
        if "gbar_std" in out.coords:
            fit_rel = out["gbar_std"].reset_coords(drop=True) / strip_marks(out)
            out = out.drop_vars("gbar_std")
        if params.attrs.get("model") != "spectrum":
            extra_attrs["equation"] = "eq. 37/38 with the fit of eq. 36"
        # a fit without finite parameters gives no gradient: failed (the fit's own
        # rating and notes join outside the memo, in rms_gradient)
        level = xr.where(out.isnull().all("dr"), np.int8(2), level).astype(np.int8)
        notes = "the fit of G gives no finite gradient on any lag"
    elif method == "exact":
        out = xr.apply_ufunc(kernels.exact_on_lags, Gl, _noise(G),
                             kwargs={"dr": dr, **_EXACT_DEFAULTS}, **common)
        extra_attrs["note"] = "NaN where G does not determine gbar (see rms_gradient_exact)"
    else:
        out, fit_rel, info, level, notes = _auto(G, Gl, _noise(G), spec, fit)
        extra_attrs.update(info)
    out = out.transpose(..., "dr").assign_coords(G["dr"].coords)
    out = out.drop_vars([c for c in out.coords if c not in out.dims and c != "dr"
                         and c != "gradient_method"], errors="ignore")
    out = out.assign_coords(gbar_std=_gradient_std(out, Gl, errors, method, fit_rel,
                                                   inflation_of(G)))
    window = lag_window(G, dr)
    if window.recorded:  # lags outside the instrument's window: NaN, as in persson
        inside = xr.DataArray(~window.outside, dims="dr")
        out = out.where(inside).assign_coords(gbar_std=out["gbar_std"].where(inside))
    level = level.reset_coords(drop=True)
    out.name = "gbar"
    attrs = {"units": "1", "long_name": "scale-dependent rms gradient",
             "equation": _EQUATIONS.get(method, "eq. 26 (route per curve: see "
                                        "coordinate gradient_method)"),
             "method": method}
    attrs.update(extra_attrs)
    out.attrs = result_attrs(G, **attrs)
    what = f"rms_gradient (method {method!r})"
    if window.empty is not None:  # no lag resolved: failed, said with the rest (one warning)
        level = xr.where(level < 2, np.int8(2), level).astype(np.int8)
        notes = quality.SEPARATOR.join(n for n in (notes, window.no_lag_note) if n)
    out = quality.mark_curves(out, level, what=what, reason="gradient", notes=notes)
    out = _mark_window(out, window, spec.unit_str, what)
    return mark_gaps(out, spec, what=what, depends=_GAP,
                     level="good" if out.attrs["method"] in ("simple", "fit") else
                     "questionable")


def _mark_window(out: xr.DataArray, window, unit: str, what: str) -> xr.DataArray:
    """Say which lags are NaN outside the instrument's window (a remark naming them).

    ``window`` is :func:`xrough.preprocess.lag_window` of G. A window that holds no lag of
    G leaves nothing: the caller rates that failed.
    """
    if window.empty is not None or not window.recorded or not window.outside.any():
        return out
    dr = out["dr"].values
    below = dr < (-np.inf if window.lo is None else window.lo)
    runs = [f"{dr[m].min():.4g} to {dr[m].max():.4g}"
            for m in (window.outside & below, window.outside & ~below) if m.any()]
    return quality.mark(out, (
        f"NaN at dr = {' and '.join(runs)} {unit}: outside the lag range the instrument "
        f"resolves ({window.said}); acf(reliable=False) or G.attrs without "
        "reliable_dr_min/max keeps them"), level="good", what=what)


def _gradient_std(gbar: xr.DataArray, Gl: xr.DataArray, errors: dict | None,
                  method: str, fit_rel: xr.DataArray | None,
                  factor: xr.DataArray | None) -> xr.Variable:
    """Build the coordinate ``gbar_std``, the statistical error of gbar (NaN where gbar is).

    ``fit_rel``: the relative error of gbar on the lags where the fitted model gives it;
    ``factor``: the regions' factor on G's errors per curve (:func:`inflation_of`).
    """
    if errors is None:
        std, error_of = xr.full_like(gbar, np.nan), ERROR_OF_NONE
    else:
        gbar_or_none = strip_marks(gbar) if method == "auto" else xr.full_like(Gl, np.nan)
        values = [Gl, gbar_or_none, xr.full_like(Gl, np.nan) if fit_rel is None else fit_rel,
                  xr.ones_like(Gl) if factor is None else factor]
        std = xr.apply_ufunc(
            lambda g, gb, f, kk, errors, **kw: kernels.gradient_std(
                g, gb if method == "auto" else None, f,  # auto: its even start
                errors={**errors, "inflation": kk}, **kw),
            *values, input_core_dims=[["dr"]] * len(values),
            output_core_dims=[["dr"]],
            kwargs={"dr": Gl["dr"].values, "errors": errors, "ballistic": method == "simple",
                    "smooth": _EXACT_DEFAULTS["smooth"],
                    "interpolation": _EXACT_DEFAULTS["interpolation"]},
            vectorize=True, dask="parallelized", output_dtypes=[float], keep_attrs=False)
        std = std * gbar.reset_coords(drop=True)  # relative to absolute (NaN where gbar is)
        error_of = ERROR_OF_SURFACE + (
            "; the relative linear response of eq. 26 of eq. 10/11 to G's errors (the "
            "ballistic sqrt(4 G) / dr where eq. 26 has no value); where the fitted model "
            "gives gbar, eq. 26 of the fitted spectrum linear in the fit's "
            "parameter_covariance" if method != "simple" else "")
    return xr.Variable(gbar.dims, std.transpose(*gbar.dims).data, attrs={
        "units": "1", "long_name": "statistical standard deviation of gbar",
        "error_of": error_of})


def _fitted_on_lags(params: xr.Dataset, G: xr.DataArray) -> xr.DataArray:
    """Gbar of a fit on every lag of G (NaN at a ``dr = 0`` bin)."""
    positive = G["dr"].isel(dr=G["dr"].values > 0)
    return gradient_from_fit(params, positive).reindex(dr=G["dr"].values)


def _auto(G: xr.DataArray, Gl: xr.DataArray, noise: xr.DataArray, spec,
          params: xr.Dataset | None) -> tuple:
    """``method='auto'``: one kernel per curve, exact where it covers, else fit, else simple.

    With ``params`` (a fit of G) its gradient is the fallback; otherwise the kernel fits a
    curve only when the exact gradient leaves lags open.
    """
    dr = spec.dr
    fit = fit_gradient = None
    se = xr.ones_like(Gl)
    fitted_std = xr.full_like(Gl, np.nan)
    if params is not None:
        fitted = _fitted_on_lags(params, G)
        if "gbar_std" in fitted.coords:
            fitted_std = strip_marks(fitted["gbar_std"]) / strip_marks(fitted)
        fitted = strip_marks(fitted.drop_vars(
            [c for c in params.coords if c not in params.dims], errors="ignore"))
    else:
        fitted = xr.full_like(Gl, np.nan)
        if np.any(dr > 0):  # fit_acf(G), run by the kernel on the curves that need it
            setup = prepare_fit(G)
            _, se = setup.inputs()
            fit, fit_gradient = setup.options, setup.gradient_options
    if fitted.chunks is None and Gl.chunks is not None:
        fitted, fitted_std = fitted.chunk(), fitted_std.chunk()

    def kernel(g, s, n, f, fs, kk):
        own = fit  # the fit of this curve carries its regions' factor
        if fit is not None and fit.get("errors"):
            own = {**fit, "errors": {**fit["errors"], "inflation": kk}}
        return kernels.auto_gradient(g, s, n, None if params is None else f,
                                     None if params is None else fs, dr=dr,
                                     exact=_EXACT_DEFAULTS, fit=own,
                                     fit_gradient=fit_gradient)

    factor = inflation_of(G)
    factor = xr.ones_like(Gl) if factor is None else factor
    out, fit_rel, code, n_exact, bits, level, share = xr.apply_ufunc(
        kernel, Gl, se, noise, fitted.transpose(*Gl.dims), fitted_std.transpose(*Gl.dims),
        factor, input_core_dims=[["dr"]] * 6,
        output_core_dims=[["dr"], ["dr"], [], [], [], [], []],
        vectorize=True, dask="parallelized",
        output_dtypes=[float, float, np.int8, np.int64, np.int16, np.int8, float],
        keep_attrs=False)
    code = code.assign_attrs(
        long_name="route of the rms gradient per curve", units="1",
        **quality.cf_flags(kernels.AUTO_METHODS, np.int8))
    out = out.assign_coords(gradient_method=code)
    # the given fit's own rating is applied outside the memo (rms_gradient)
    if params is not None and "fit_problems" in params:  # too few bins: no gradient at all
        few = (params["fit_problems"].reset_coords(drop=True).astype(np.int64)
               & kernels.TOO_FEW_BINS) != 0
        void = few & (code == 2)
        out = out.where(~void)
        level = xr.where(void, np.int8(2), level).astype(np.int8)
        bits = xr.where(void, params["fit_problems"].reset_coords(drop=True), bits)
    info: dict = {}
    notes = ""
    if code.chunks is None:  # computed: say which route, and why
        n_valid = np.count_nonzero(np.isfinite(Gl.values) & (dr > 0), axis=-1)
        reasons = np.vectorize(_route_reason, otypes=[object])(
            code.values, n_exact.values, n_valid, bits.values, level.values,
            params is not None, share.values)
        notes = _curve_notes(reasons, level.values)
        if code.ndim == 0:
            taken = kernels.AUTO_METHODS[int(code)]
            info["method"] = taken
            info["equation"] = _EQUATIONS[taken]
            if taken != "exact":
                info["fallback_reason"] = str(reasons)
    return out, fit_rel, info, level, notes


def _route_reason(code: int, n_exact: int, n_valid: int, bits: int, level: int,
                  given: bool, share: float = np.nan) -> str:
    """Why ``method='auto'`` took route ``code`` for one curve, in words."""
    taken = kernels.AUTO_METHODS[code]
    if taken == "exact":
        return ""
    reason = f"exact: determined on {n_exact} of {n_valid} lags only"
    if taken in ("fit", "exact+fit"):
        where = "the other lags" if taken == "exact+fit" else "every lag"
        reason += f"; eq. 26 of the fitted model spectrum on {where}"
        if level and bits > 0:
            reason += " from a questionable fit: " + describe_problems(bits)
        if np.isfinite(share) and share > kernels.BEYOND_RESOLUTION:
            reason += (f"; {100 * share:.0f} % of gbar^2 at the first lag comes from "
                       "wavelengths below two lags, which the data do not resolve (beyond "
                       "their Nyquist wavenumber): the model's, not the measurement's")
        return reason
    fit_text = ("the given fit failed (see its quality_notes)" if given else
                "failed: " + describe_problems(bits) if bits > 0 else
                "not possible (fewer than 5 lags)" if bits < 0 else "failed")
    if level == 2 and bits > 0:  # too few bins: no route gives a gradient
        return (f"{reason}; fit: {fit_text}; G has too few bins for any estimate of "
                "gbar (NaN): measure a larger map")
    where = "the other lags" if taken == "exact+simple" else "every lag"
    return (f"{reason}; fit: {fit_text}; so the ballistic approximation sqrt(4 G)/dr on "
            f"{where}, which holds only where G ~ dr^2 (dr well below lambda_s) and "
            "misjudges gbar elsewhere")


def _curve_notes(reasons: np.ndarray, level: np.ndarray) -> str:
    """Join the reasons of the curves rated questionable or failed (counted if many)."""
    reasons, level = np.asarray(reasons, dtype=object), np.asarray(level)
    if reasons.ndim == 0:
        return str(reasons) if int(level) else ""
    counts: dict = {}
    for text, lev in zip(reasons.ravel(), level.ravel()):
        if lev:
            counts[text] = counts.get(text, 0) + 1
    return quality.SEPARATOR.join(f"{k} of {reasons.size} curves: {text}"
                                  for text, k in counts.items())


@u.accepts_quantified
def rms_gradient_exact(
    G: xr.DataArray,
    dr: QuantityLike | None = None,
    *,
    smooth: float | None = None,
    noise: ArrayLike | None = None,
    support_rtol: float = 0.01,
    interpolation: str = "hermite",
    points_per_decade: float = 40,
) -> xr.DataArray:
    r"""Compute the "exact" scale-dependent rms gradient of a ``G`` (eq. 26 via eq. 10/11).

    ``gbar^2(dr) = (1/2pi) int_0^(2pi/dr) dq q^3 C(q)`` with ``C`` from ``G`` by eq. 10/11
    (:func:`spectrum`), integrated exactly as a piecewise power law, and returned only where
    the extrapolation of ``G``, the grid and noise change it by at most ``support_rtol``.
    Notes (method, support, the ballistic limit): docs/spectra.md, "rms_gradient_exact and
    gradient_from_spectrum in detail".

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
        ``support_rtol``, ``smooth_decades``, ``interpolation``. Where G determines gbar
        nowhere (a few lags, none ballistic and none at a plateau: a 4 x 7 map), NaN on
        the lags of G (or ``dr``), rated failed with the reason (docs/quality.md).

    Raises
    ------
    ValueError
        Everything :func:`spectrum` raises; a ``dr`` outside the supported range (the
        message names it).

    See Also
    --------
    spectrum, gradient_from_spectrum

    Examples
    --------
    >>> from xrough.spectra import acf_from_spectrum, model_spectrum
    >>> from xrough.gradient import gradient_from_spectrum, rms_gradient_exact
    >>> import numpy as np
    >>> model = dict(hurst=0.8, lambda_r="1 um", lambda_s="10 nm", rms_gradient=0.5,
    ...              unit="nm", rolloff="smooth")
    >>> G = acf_from_spectrum(model_spectrum(**model), np.logspace(-1, 6, 141))
    >>> gbar = rms_gradient_exact(G, [1.0, 100.0])
    >>> exact = gradient_from_spectrum(model_spectrum(**model), [1.0, 100.0])
    >>> print(np.round((gbar / exact).values, 2))
    [1. 1.]
    """
    check_spectrum_options(smooth, support_rtol, interpolation, points_per_decade)
    acf = acf_samples(G, noise)
    dr_lo, dr_hi = kernels.exact_support(acf.dr, acf.G, acf.noise, smooth=smooth,
                                         support_rtol=support_rtol,
                                         interpolation=interpolation)
    if not np.isfinite(dr_lo):  # determined nowhere: NaN on the lags, failed, said why
        lags = (acf.dr if dr is None else
                u.array_in(dr, acf.length_unit, what="dr", noun="distances"))
        attrs = result_attrs(G, estimator="eq. 26 with C from G by eq. 10/11",
                             dr_min_supported=np.nan, dr_max_supported=np.nan,
                             support_rtol=float(support_rtol),
                             smooth_decades=0.0 if smooth is None else float(smooth),
                             interpolation=interpolation)
        out = _gradient_da(np.full(lags.shape, np.nan), lags, acf.unit_str, attrs)
        return quality.mark(out, (
            f"G determines gbar nowhere to support_rtol={support_rtol:g}: the "
            f"extrapolation beyond dr = {acf.dr[0]:.4g} to {acf.dr[-1]:.4g} "
            f"{acf.unit_str} or noise dominates (too few lags, or none ballistic and none "
            "at a plateau); pass a larger support_rtol or smooth=<decades>, use "
            "rms_gradient(G), or measure G over a wider range"),
            what="rms_gradient_exact", level="failed")
    dr_arr = _supported_lags(acf, dr, dr_lo, dr_hi, support_rtol)
    gbar = kernels.exact_gradient(acf.dr, acf.G, dr_arr, smooth=smooth,
                                  interpolation=interpolation,
                                  points_per_decade=points_per_decade)
    dr_arr, gbar = _positive_only(acf, dr_arr, gbar, given=dr is not None)
    attrs = result_attrs(G, **{
        "estimator": "eq. 26 with C from G by eq. 10/11",
        "dr_min_supported": float(dr_lo),
        "dr_max_supported": float(dr_hi),
        "support_rtol": float(support_rtol),
        "smooth_decades": 0.0 if smooth is None else float(smooth),
        "interpolation": interpolation,
    })
    return mark_gaps(_gradient_da(gbar, dr_arr, acf.unit_str, attrs), acf,
                     what="rms_gradient_exact", depends=_GAP)


def _supported_lags(acf, dr: QuantityLike | None, dr_lo: float, dr_hi: float,
                    support_rtol: float) -> np.ndarray:
    """Check the lags ``dr`` asked for (all supported), or take the supported lags of G."""
    tol = 1e-9 * dr_hi
    if dr is None:
        dr_arr = acf.dr[(acf.dr >= dr_lo - tol) & (acf.dr <= dr_hi + tol)]
        return dr_arr if dr_arr.size else log_range(dr_lo, dr_hi, 20)
    dr_arr = u.array_in(dr, acf.length_unit, what="dr", noun="distances")
    bad = (dr_arr < dr_lo - tol) | (dr_arr > dr_hi + tol)
    if np.any(bad):
        raise ValueError(
            f"gbar is supported for {dr_lo:.4g} <= dr <= {dr_hi:.4g} {acf.unit_str} only "
            f"(got dr = {dr_arr[bad][:3]}): elsewhere the extrapolation of G or noise "
            f"changes gbar^2 by more than support_rtol={support_rtol:g}")
    return dr_arr


def _positive_only(acf, dr_arr: np.ndarray, gbar: np.ndarray, *, given: bool) -> tuple:
    """Drop the default lags where noise drove gbar^2 negative; raise at lags ``given``."""
    positive = np.isfinite(gbar)  # noise can drive the cumulative sum negative
    if positive.all():
        return dr_arr, gbar
    if given or not positive.any():
        raise ValueError(
            f"gbar^2 from the spectrum of G is not positive at dr = "
            f"{dr_arr[~positive][:3]} {acf.unit_str} (noise in G); pass smooth=<decades> "
            "or use rms_gradient(G, method='fit')")
    return dr_arr[positive], gbar[positive]


@u.accepts_quantified
def gradient_from_spectrum(
    C: xr.DataArray,
    dr: QuantityLike | None = None,
    *,
    points_per_decade: float = 20,
    dr_min: QuantityLike | None = None,
    dr_max: QuantityLike | None = None,
) -> xr.DataArray:
    r"""Scale-dependent rms gradient from an isotropic spectrum (paper eq. 26).

    :math:`\bar g^2(\Delta r) = \frac{1}{2\pi} \int_0^{2\pi/\Delta r} dq\, q^3\, C(q)`,
    the mean-square gradient of the surface with every wavelength shorter than ``dr``
    removed; ``gbar(0)`` is the rms gradient.  A spectrum with the attributes of
    :func:`model_spectrum` is integrated in closed form; samples are a piecewise power law
    (zero outside the sampled range, as in :func:`acf_from_spectrum`), integrated exactly;
    a binned periodogram (with ``bin_measure``) is summed over its bins.  Notes (closed
    forms, binned spectra and their accuracy): docs/spectra.md, "rms_gradient_exact and
    gradient_from_spectrum in detail".

    Parameters
    ----------
    C : xarray.DataArray with one dim (``"q"``)
        ``C(q)`` in length^4 on an angular-wavenumber coordinate in 1/length (``units``
        required); samples must be finite and ``>= 0`` on positive, increasing ``q``.
    dr : array_like, pint.Quantity or xarray.DataArray, optional
        Lag distances ``>= 0`` (plain numbers in the length unit of ``q``).  Default:
        logarithmic from ``0.01 * 2 pi / q_max`` to ``100 * 2 pi / q_min``.
    points_per_decade : float
        Density of the default ``dr`` grid.
    dr_min, dr_max : float, str or pint.Quantity, optional
        Override the range of the default grid.

    Returns
    -------
    xarray.DataArray
        ``gbar`` on dim ``"dr"`` (``units`` the spectrum's length unit), dimensionless
        (``units`` ``"1"``), attrs ``equation="eq. 26"`` and, for a model spectrum, the
        model attributes.

    Raises
    ------
    ValueError
        Missing or wrong units, invalid samples, model attributes that contradict the
        values, or a bad ``dr``.

    See Also
    --------
    rms_gradient_exact : eq. 26 from a measured ``G``.

    Examples
    --------
    >>> from xrough.spectra import model_spectrum
    >>> from xrough.gradient import gradient_from_spectrum
    >>> C = model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
    ...                    rms_gradient=0.5, unit="nm")
    >>> gbar = gradient_from_spectrum(C, [0.0, 10.0, 1e3])
    >>> gbar.attrs["units"], gbar.dr.attrs["units"], gbar.attrs["equation"]
    ('1', 'nm', 'eq. 26')
    >>> print(np.round(gbar.values, 6))  # gbar(0) is the rms gradient
    [0.5      0.5      0.067981]
    """
    spec = spectrum_input(C)
    dr_arr = spectrum_lags(spec, dr, points_per_decade, dr_min, dr_max)
    with np.errstate(divide="ignore"):
        q_cut = np.where(dr_arr > 0, 2 * np.pi / np.where(dr_arr > 0, dr_arr, 1.0), np.inf)
    if spec.model is not None:
        m = spec.model
        gbar2 = model_gradient2(q_cut, c=m.C_r * m.q_r ** (2 + 2 * m.hurst), hurst=m.hurst,
                                q_r=m.q_r, q_s=m.q_s, q_0=m.q_0, rolloff=m.rolloff,
                                cutoff=m.cutoff)
        extra = model_attrs(spec.model)
    elif "bin_measure" in C.coords and C.attrs.get("spectrum_kind") == "isotropic 2D":
        measure = np.asarray(C["bin_measure"].values, dtype=float) * u.conversion_factor(
            u.units_of(C["bin_measure"], what="coordinate 'bin_measure'"),
            spec.length_unit**-2)
        gbar2 = binned_moment_kernel(q_cut, spec.func.q, spec.func.values, measure, 2)
        extra = {"integration": "sum over the periodogram's bins"}
    else:
        gbar2 = power_law_moment_kernel(q_cut, spec.func.q, spec.func.values, 2)
        extra = {}
    return _gradient_da(np.sqrt(gbar2), dr_arr, spec.unit_str,
                        result_attrs(C, estimator="spectrum", **extra))
