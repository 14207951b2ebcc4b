"""Contact mechanics from G(dr): energy, stress ACF, Persson theory, patch radius.

Paper sections 2.3-2.6 and 3.4-3.6. Every function takes a height-difference ACF ``G``
(dim ``dr``, length^2; measured, stitched or from a model spectrum; checked by
:func:`xrough.acf.check_acf`) and physical parameters as numbers in SI, strings
(``"25 MPa"``), pint Quantities or DataArrays with units (:mod:`xrough.units`), and returns
DataArrays or Datasets in SI units (Pa, Pa^2, J m-2) with lengths in the unit of ``G``'s
``dr``. The numpy kernels are in :mod:`xrough._kernels.contact`; here they are applied per
curve with :func:`xarray.apply_ufunc`, so that on a chunked G every result is a lazy dask
array and ``.compute()`` runs the graph once.
"""

from __future__ import annotations

import contextlib
import functools
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from . import quality
from . import units as u
from ._kernels import contact as k
from ._kernels import model_error as me
from ._kernels.acf_curve import DETERMINED, FIRST_LAG_SMOOTH, FLAT_SLOPE
from ._kernels.contact import KAPPA_PERSSON
from ._kernels.gaps import bridge_energy
from ._kernels.hankel import acf_from_spectrum_kernel
from .acf import (
    ERROR_OF_NONE,
    ERROR_OF_SURFACE,
    AcfSpec,
    bin_error,
    error_model,
    gap_note,
    inflation_of,
    lag_coord,
    mark_gaps,
    read_acf,
    result_attrs,
    strip_marks,
    with_coord_attrs,
)
from .fit_result import read_fit, rolloff_shapes
from .fitting import fit_acf
from .gradient import rms_gradient
from .memo import by_content
from .preprocess import LagWindow, lag_window, reliability_window
from .spectra import spectrum_input
from .units import QuantityLike

__all__ = ["elastic_energy", "stress_acf", "stress_acf_from_spectrum", "persson",
           "patch_radius", "KAPPA_PERSSON"]

#: Theories of partial contact by their weighting of eq. 49 (:data:`k.WEIGHTINGS`).
THEORIES = tuple(k.WEIGHTINGS)
_ENERGY = "[mass] / [time] ** 2"
_PRESSURE = "[pressure]"
#: Share of v_el from a continuation of G beyond the data above which v_el is questionable.
EXTRAPOLATED = 0.25
#: Share of a result (v_el, the energy at the patch radius) from lags below the
#: instrument's window (reliable_dr_min) above which it is questionable. The same as
#: EXTRAPOLATED: G below the window is measured but shaped by the tip or the optics (mostly
#: lowered: a tip cannot follow valleys curved beyond its radius), which tells no more
#: about the surface than the continuation below the first lag that EXTRAPOLATED rates;
#: without a window the share below it is exactly extrapolated_below. Measured
#: (benchmarks/window_shares.py): dektak-1.csv 32 % and the UNCD stylus 84 % of v_el come
#: from below their windows (1.55 and 2.07 um), both questionable.
BELOW_WINDOW = EXTRAPOLATED
#: Relative change of v_el between the bridge over a gap of G and its alternatives above
#: which v_el is questionable.
BRIDGED = 0.1
#: Largest rise of gbar with dr (relative) that persson smooths away without a mark: it
#: uses the running maximum of gbar from larger lags (gbar cannot rise, eq. 26).
RAISED = 0.05
#: What of each result depends on G inside a gap (:func:`xrough.acf.mark_gaps`).
_GAP_LAPLACIAN = ("the Laplacian of G at the bins next to the gap is that of the "
                  "bridge (the smoothing spline runs across it), not of data")
_GAP_PERSSON = ("G_sigma and Gamma_sigma at the bins next to the gap are the Laplacian of "
                "the bridge; gbar (p_star, a_r, sigma_c) rests on it where its route "
                "integrates the spectrum of G (see the gradient's notes)")
_GAP_PATCH = ("v_el(a_c) of eq. 44/46 integrates G across the bridge for a_c beyond the gap "
              "(see elastic_energy(G).gap_share_error)")
_DERIVATIVE = ("Laplacian of a smoothing spline of ln G against ln dr: smoothing length "
               "0.05 decades of dr, more where cross-validation on the standard errors "
               "asks for it; NaN at and below the largest lag where it differs from the "
               "Laplacians of the even and of the odd bins alone by more than "
               f"{DETERMINED:.0%} of a lower bound of G_sigma(0), and outside "
               "reliable_dr_min/max")


# ---------------------------------------------------------------------------------------
# G as SI lines for the kernels
# ---------------------------------------------------------------------------------------
def acf_in_si(G: xr.DataArray, spec: AcfSpec) -> tuple[xr.DataArray, xr.DataArray | None]:
    """G and its standard error (if any) in m^2, extra dims first."""
    G = G.transpose(..., "dr")
    error = None
    if "standard_error" in G.coords:
        se = bin_error(G)  # in G's unit unless it says otherwise
        factor = (spec.to_m2 if "units" not in se.attrs else u.conversion_factor(
            u.units_of(se, what="coordinate 'standard_error'"), "m**2"))
        error = strip_marks(se.broadcast_like(G).transpose(..., "dr")) * factor
    return strip_marks(G) * spec.to_m2, error


def _error_inputs(G: xr.DataArray, G_si: xr.DataArray, spec: AcfSpec
                  ) -> tuple[dict, xr.DataArray]:
    """Give what the kernels that propagate G's covariance need, in SI as ``G_si``.

    The map geometry of :func:`xrough.acf.error_model` with its lengths in m (empty: G
    states none, so there is no statistical error) and the regions' inflation factor
    curve by curve (ones where the regions agree or were not judged).
    """
    model = error_model(G) or {}
    if model:
        model.update(size=model["size"] * spec.to_m, pixel=model["pixel"] * spec.to_m)
    factor = inflation_of(G)
    return model, xr.ones_like(G_si) if factor is None else factor


def _window_si(G: xr.DataArray, spec: AcfSpec) -> tuple[float, float]:
    """Give the instrument's reliable lag range of G in m.

    None recorded: 0 to inf; also when it holds no lag of G (every result fails then).
    """
    lo, hi = reliability_window(G)
    if lag_window(G, spec.dr).empty is not None:
        lo = hi = None
    return (0.0 if lo is None else lo * spec.to_m, np.inf if hi is None else hi * spec.to_m)


@by_content()
def _laplacian_std(G: xr.DataArray) -> xr.DataArray:
    """Give the standard deviation of the Laplacian of G on its lags (NaN: no map geometry).

    Kept by content, as :func:`_laplacian`: :func:`stress_acf` and :func:`persson` of one
    G compute it once.
    """
    G, spec = read_acf(G)
    G_si, error = acf_in_si(G.transpose(..., "dr"), spec)
    model, factor = _error_inputs(G, G_si, spec)
    if not model:
        return xr.full_like(G_si, np.nan)
    return _per_curve(
        lambda g, e, f, **kw: k.laplacian_std_curve(g, None if np.all(np.isnan(e)) else e,
                                                    f, **kw),
        G_si, xr.full_like(G_si, np.nan) if error is None else error, factor,
        dr=spec.dr * spec.to_m, window=_window_si(G, spec), **model)


def _energy_std(g, inflation, **kwargs):
    """:func:`~xrough._kernels.contact.energy_std_curve` of one curve and its factor."""
    return k.energy_std_curve(g, inflation=inflation, **kwargs)


def _per_curve(func, *arrays, out: dict[str, int] | None = None, **kwargs):
    """Apply ``func`` to each curve (core dim dr); output core dims ``out`` (default dr)."""
    out_dims = [["dr"]] if out is None else [list(out)]
    sizes = {} if out is None else dict(out)
    # a curve is its bins (tens to hundreds): one chunk along dr whatever the inputs had
    gufunc: dict = {"allow_rechunk": True, **({"output_sizes": sizes} if sizes else {})}
    return xr.apply_ufunc(
        func, *arrays, input_core_dims=[["dr"]] * len(arrays), output_core_dims=out_dims,
        vectorize=True, dask="parallelized", output_dtypes=[float],
        dask_gufunc_kwargs=gufunc, kwargs=kwargs, keep_attrs=False)


@by_content()
def _laplacian(G: xr.DataArray):
    """Laplacian of G (dimensionless) on its lags, per curve, why a lag has none, and H(dr).

    Returns the Laplacian (NaN where G does not determine it), the code per lag of
    :func:`xrough._kernels.contact.laplacian_curve` (0, ``UNDETERMINED``,
    ``OUTSIDE_WINDOW``) and the local exponent ``(1/2) dln G / dln dr`` of the same
    smoothed G.  Kept by content: :func:`stress_acf` and :func:`persson` of one G compute
    it once.
    """
    G, spec = read_acf(G)
    G_si, error = acf_in_si(G, spec)
    dr = spec.dr * spec.to_m
    window = _window_si(G, spec)
    parts = {"part": 3, "dr": spec.dr.size}
    if error is None:
        res = _per_curve(lambda g, dr, window: k.laplacian_curve(g, None, dr=dr, window=window),
                         G_si, out=parts, dr=dr, window=window)
    else:
        res = _per_curve(k.laplacian_curve, G_si, error, out=parts, dr=dr, window=window)
    return res.isel(part=0), res.isel(part=1), res.isel(part=2)


def _lag_runs(dr: np.ndarray, hit: np.ndarray, unit: str) -> str:
    """`` at dr = a to b and c to d nm``: the runs of consecutive lags where ``hit``.

    >>> _lag_runs(np.array([1.0, 2.0, 3.0, 4.0, 5.0]), np.array([1, 1, 0, 0, 1], bool), "nm")
    ' at dr = 1 to 2 and 5 nm'
    """
    edges = np.flatnonzero(np.diff(np.concatenate([[0], hit.astype(np.int8), [0]])))
    runs = [f"{dr[a]:.3g}" if b - a == 1 else f"{dr[a]:.3g} to {dr[b - 1]:.3g}"
            for a, b in zip(edges[::2], edges[1::2], strict=True)]
    return f" at dr = {' and '.join(runs)} {unit}" if runs else ""


def _derivative_checks(why: xr.DataArray, spec: AcfSpec, window: bool = True) -> list:
    """Return the :func:`rate_result` checks of the lags without a Laplacian (range named, eager).

    The lags outside the reliable window are NaN by design: a remark (level good), left
    out with ``window=False`` (:func:`persson` says it once for all its variables).
    """
    unit = spec.unit_str
    texts = {
        k.UNDETERMINED: (
            "the Laplacian of G (eq. 24) is not determined{span} (NaN there): its "
            "estimates from all bins and from the even and the odd bins alone differ by "
            f"more than {DETERMINED:.0%} of a lower bound of G_sigma(0) (the bins of the "
            "smallest lags hold a few lattice distances each along different directions, "
            "and pixel noise or a scan that differs along its fast and slow axes makes G "
            "zig-zag between them): the stress ACF there is a property of the pixels, not "
            "of the surface"),
        k.ROUGH_START: (
            "the Laplacian of G (eq. 24) is not determined{span}, the first lag (NaN "
            f"there): G's log-log slope from its first to its second lag is below "
            f"{FIRST_LAG_SMOOTH:g}, so the surface is rough at the first lag already and "
            "the curvature of G there depends on what lies below it, which no lag holds"),
        k.OUTSIDE_WINDOW: (
            "the Laplacian of G (eq. 24) is NaN{span}: outside the reliable lag range "
            "(reliable_dr_min / reliable_dr_max in G's attrs) that the instrument resolves"),
    }
    checks = []
    for code, text in texts.items():
        if code == k.OUTSIDE_WINDOW and not window:
            continue
        hit = why == code
        span = ""
        if why.chunks is None:
            span = _lag_runs(spec.dr, np.asarray(hit.any([d for d in hit.dims if d != "dr"])),
                             unit)
        # NaN by design: outside the window, or at a first lag where G is rough (a remark)
        level = "questionable" if code == k.UNDETERMINED else "good"
        checks.append((hit.any("dr"), level, text.format(span=span)))
    return checks


def _outside_window(ds: xr.Dataset, G: xr.DataArray, spec: AcfSpec) -> tuple:
    """NaN every variable of ``ds`` at lags outside G's reliable window; the checks.

    A remark names the lags (NaN by design); a window that holds no lag of G fails the
    result (:func:`_no_lag`).
    """
    window = lag_window(G, spec.dr)
    if not window.recorded or not window.outside.any():
        return ds, []
    outside = xr.DataArray(window.outside, dims="dr")
    ds = _blank(ds, outside, lambda v: "dr" in v.dims)
    if window.empty is not None:
        return ds, [_no_lag(window)]
    note = (f"NaN{_lag_runs(spec.dr, window.outside, spec.unit_str)}: outside the lag "
            f"range the instrument resolves ({window.said}); acf(reliable=False) or "
            "G.attrs without reliable_dr_min/max keeps them")
    return ds, [(xr.DataArray(True), "good", note)]


def _no_lag(window: LagWindow) -> tuple:
    """Return the :func:`rate_result` check of a window that holds no lag of G: failed.

    One note for every result of such a G (a report says it once).
    """
    return (xr.DataArray(True), "failed", window.no_lag_note)


def _unresolved(G_si: xr.DataArray, error: xr.DataArray | None, spec: AcfSpec,
                depends: str) -> tuple[xr.DataArray, tuple]:
    """Curves whose G is flat from the first lag, and the :func:`rate_result` check that says it.

    Flat: the log-log slope of G over its first decade of lags
    (:func:`xrough._kernels.contact.first_decade_slope`, weighted by the standard errors)
    is below :data:`~xrough._kernels.acf_curve.FLAT_SLOPE`. Lazy where G is.
    """
    dr = spec.dr * spec.to_m
    arrays = (G_si,) if error is None else (G_si, error)
    slope = xr.apply_ufunc(
        k.first_decade_slope, *arrays, input_core_dims=[["dr"]] * len(arrays),
        output_core_dims=[[]], vectorize=True, dask="parallelized", output_dtypes=[float],
        kwargs={"dr": dr}, keep_attrs=False)
    flat = slope < FLAT_SLOPE
    found = ""
    if slope.chunks is None:
        values = np.asarray(slope.values)[np.asarray(flat.values)]
        if values.size:
            found = f" ({values.max():.2g}{' at most' if values.size > 1 else ''})"
    return flat, (flat, "failed", (
        f"G is flat from its first lag: its log-log slope over the first decade of lags "
        f"is below {FLAT_SLOPE:g}{found}, where a rough surface resolved by the lags "
        "rises as dr^2H or dr^2. The roughness is not resolved: heights are uncorrelated "
        "from one pixel to the next (white noise, or roughness finer than the pixel), so "
        f"{depends} would describe the pixels, not the surface; NaN. Measure at a finer "
        "lateral resolution (or check the data for noise only)"))


def _past(lags: xr.DataArray, spec: AcfSpec) -> str:
    """Return the level of a result at ``lags`` next to the gaps of G.

    ``"questionable"`` if any of ``lags`` lies beyond the start of a gap (or is lazy),
    else ``"good"``.
    """
    if not len(spec.gaps):
        return "good"
    if lags.chunks is not None:
        return "questionable"
    return "questionable" if bool((lags > spec.gaps[:, 0].min()).any()) else "good"


#: Calls inside :func:`own_attrs` (all threads) and the ``keep_attrs`` option before them.
_ATTRS_OFF: dict = {"depth": 0, "saved": None}
_ATTRS_LOCK = threading.Lock()


@contextlib.contextmanager
def _attrs_off() -> Iterator[None]:
    """Turn xarray's ``keep_attrs`` off from the first entry to the last exit of any thread.

    xarray's options are one dict for the process: ``with xr.set_options(...)`` in two
    threads at once can exit out of order and leave the option off for good (two
    ``persson`` running in dask's threads did, and a user's ``topo + tilt`` lost its
    units afterwards). Counted here, the last exit restores what the first entry found.
    """
    with _ATTRS_LOCK:
        if _ATTRS_OFF["depth"] == 0:
            _ATTRS_OFF["saved"] = xr.get_options()["keep_attrs"]
            xr.set_options(keep_attrs=False)
        _ATTRS_OFF["depth"] += 1
    try:
        yield
    finally:
        with _ATTRS_LOCK:
            _ATTRS_OFF["depth"] -= 1
            if _ATTRS_OFF["depth"] == 0:
                xr.set_options(keep_attrs=_ATTRS_OFF["saved"])


#: The attrs of the coordinate ``p0`` of every contact result.
P0_ATTRS = {"units": "Pa", "long_name": "mean pressure"}


def own_attrs(func):
    """Run ``func`` with xarray's attrs propagation off: each result sets its own attrs.

    Its coordinates keep theirs: those xarray drops with the rest come back from the
    arguments' coordinates of the same name (:func:`xrough.acf.with_coord_attrs`; ``p0``
    from :data:`P0_ATTRS`).
    """
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with _attrs_off():
            out = func(*args, **kwargs)
        sources = [a for a in (*args, *kwargs.values())
                   if isinstance(a, (xr.DataArray, xr.Dataset))]
        return with_coord_attrs(out, *sources, {"p0": P0_ATTRS})
    return wrapper


def own_coords(G: xr.DataArray) -> dict:
    """G's coords that are not per bin (extra dims, scalars such as gradient_method)."""
    return {c: v for c, v in G.coords.items()
            if "dr" not in v.dims and c not in (quality.FLAG, quality.REASON)}


def rate_result(result, checks, *, what: str, G, inherited=()):
    """Rate a result per curve: ``checks`` are ``(mask, level, note[, variables])``.

    A curve gets the worst level of the checks its mask fires and of its inputs: ``G``
    (its own marks: directions that differ, a stated tip that resolves no lag, a missed
    target error) and the ``inherited`` ones (a gradient or fit with their own
    ``quality_flag``: the input itself, or ``(input, variables, name)``); on numpy results
    the notes of the checks that fired (and the inputs' notes) are joined and warned once.

    A failed check or input with ``variables`` fails only those variables of a Dataset
    (what depends on it): they are NaN (numpy) and the curve is questionable, with a note
    naming them; only when every float variable of the result has failed is the curve
    failed. Without ``variables`` a failure fails the whole curve.
    """
    # Any: numpy's stubs do not know DataArray.__array_ufunc__ (np.maximum gives a DataArray)
    codes: Any = xr.DataArray(np.int8(0))
    notes: list[str] = []
    remarks: list[str] = []  # notes of checks at level "good" (no warning)
    lazy = any(check[0].chunks is not None for check in checks)
    floats = ([n for n, v in result.data_vars.items() if np.issubdtype(v.dtype, np.floating)]
              if isinstance(result, xr.Dataset) else [])
    partial: dict = {}  # variable -> where an input it depends on failed
    said: list[str] = []  # which variables are NaN because of what (numpy)

    def some(variables) -> list | None:
        """Pick the float variables of a partial failure (None: the whole curve)."""
        if variables is None or not floats:
            return None
        chosen = [n for n in floats if n in variables]
        return None if set(chosen) >= set(floats) else chosen

    def failed_part(mask, chosen, because: str | None) -> xr.DataArray:
        for name in chosen:
            partial[name] = partial[name] | mask if name in partial else mask
        if because and chosen and mask.chunks is None and bool(mask.any()):
            others = [n for n in floats if n not in chosen]
            names = (", ".join(map(str, chosen)) if len(chosen) <= len(others) else
                     f"every variable but {', '.join(map(str, others))}")
            said.append(f"{names} NaN: {because} (the other variables do not depend on "
                        "it)")
        return xr.where(mask, np.int8(quality.level_code("questionable")), np.int8(0))

    for mask, level, note, *variables in checks:
        code = quality.level_code(level)
        chosen = some(variables[0] if variables else None)
        if code == quality.level_code("failed") and chosen is not None:
            codes = np.maximum(codes, failed_part(mask, chosen, None))
        else:
            codes = np.maximum(codes, xr.where(mask, np.int8(code), np.int8(0)))
        if not lazy and bool(mask.any()):
            (remarks if level == "good" else notes).append(note)
    own = codes  # the result's own checks (the inputs' reasons are theirs)
    reasons = []
    for item in (G, *inherited):
        source, variables, name = item if isinstance(item, tuple) else (item, None, "")
        if source is None:
            continue
        flag = quality.flag_of(source)
        reasons.append(quality.reasons_from(source))
        chosen = some(variables)
        if chosen is not None:
            failed_here = flag >= quality.level_code("failed")
            flag = xr.where(failed_here, np.int8(0), flag)
            codes = np.maximum(codes, failed_part(failed_here, chosen, f"{name} failed"))
        codes = np.maximum(codes, flag)
        told = source.attrs.get("quality_notes")
        if told and not any(told in note for note in notes):  # one cause, one note
            notes.append(told)
    if partial and set(partial) >= set(floats):  # every variable failed somewhere
        everything = functools.reduce(lambda a, b: a & b, (partial[n] for n in floats))
        codes = np.maximum(codes, xr.where(everything, np.int8(2), np.int8(0)))
    failed = codes >= quality.level_code("failed")
    # a failed curve's numbers mean nothing: NaN (lazy results: the flag says it; a mask
    # from the flag would make every variable depend on every other)
    if not lazy and bool(failed.any()):
        result = _nan_where(result, failed)
    if not lazy:
        for name, mask in partial.items():
            if mask.chunks is None and bool(mask.any()):
                result = _blank(result, mask, lambda v, n=name: v.name == n)
    if not (not lazy and codes.chunks is None and bool(failed.all())):
        notes = said + notes  # which variables are NaN, unless all are
    out = quality.mark_curves(result, codes.astype(np.int8), what=what, reason="contact",
                              notes=quality.SEPARATOR.join(notes))
    bits = functools.reduce(np.bitwise_or, reasons, xr.where(
        own > 0, np.int16(quality.reason_bit("contact")), np.int16(0)))
    out = quality.add_reasons(out.drop_vars(quality.REASON), bits)
    if out[quality.FLAG].ndim == 0:  # one curve: its remarks too (many: the flags only)
        for remark in remarks:
            out = quality.mark(out, remark, level="good", what=what)
    return out


def _span(values: xr.DataArray) -> str:
    """``"0.0032"`` or ``"0.0011 to 0.0032"``: the finite values, for a note (eager)."""
    v = np.asarray(values.values if values.chunks is None else [], dtype=float)
    v = v[np.isfinite(v)]
    if not v.size:
        return "see"
    lo, hi = float(v.min()), float(v.max())
    return f"{lo:.3g}" if np.isclose(lo, hi) else f"{lo:.3g} to {hi:.3g}"


def _nan_where(result, mask: xr.DataArray):
    """Return ``result`` (DataArray or Dataset) with every float variable NaN at ``mask``."""
    if isinstance(result, xr.Dataset):
        return _blank(result, mask, lambda v: np.issubdtype(v.dtype, np.floating))
    if not np.issubdtype(result.dtype, np.floating):
        return result
    return result.where(~mask).assign_attrs(result.attrs).rename(result.name)


def _blank(ds: xr.Dataset, mask: xr.DataArray, select) -> xr.Dataset:
    """``ds`` with each data variable that ``select(v)`` picks NaN where ``mask`` holds.

    As ``v.where(~mask)`` with ``v``'s attrs, variable by variable, but on the data
    (without the DataArray's alignment for each variable of a contact result): where
    ``mask``'s dims are among ``v``'s and its indexes are ``ds``'s, and ``v`` is float.
    Otherwise (and for the rest) ``DataArray.where``. Nothing to do (an eager mask that
    holds nowhere): ``ds`` itself.
    """
    if mask.chunks is None and not bool(mask.any()):
        return ds
    keep = ~mask.variable
    same = all(d not in ds.indexes or d not in mask.indexes
               or mask.indexes[d].equals(ds.indexes[d]) for d in mask.dims)
    out = ds.copy(deep=False)
    slow = {}
    for name, v in ds.data_vars.items():
        if not select(v):
            continue
        var = v.variable
        if same and set(keep.dims) <= set(var.dims) and np.issubdtype(var.dtype, np.floating):
            k = keep.set_dims(var.dims).transpose(*var.dims)
            out[name].variable.data = np.where(k.data, var.data, np.nan)
        else:
            slow[name] = v.where(~mask).assign_attrs(v.attrs)
    return out.assign(slow) if slow else out


# ---------------------------------------------------------------------------------------
# full contact: elastic energy (eq. 16, 44)
# ---------------------------------------------------------------------------------------
@u.accepts_quantified
@own_attrs  # inside: it restores coords' units from the dequantified input
def elastic_energy(G: xr.DataArray, *, E_star: QuantityLike,
                   a_c: QuantityLike | None = None) -> xr.Dataset:
    r"""Areal elastic energy of full contact (eq. 16) and of patches of radius a_c (eq. 44).

    .. math:: v_{el} = \frac{E^*}{4}\int_0^\infty d\Delta r\,\frac{G(\Delta r)}{\Delta r^2},
              \qquad v_{el}(a_c) = \frac{E^*}{4}\int_0^{a_c} d\Delta r\,
              \frac{G(\Delta r)}{\Delta r^2}

    Exact within linear elasticity for any (statistically isotropic) surface. Between the
    bins G is a monotone cubic in log-log (a power law where the bins are one); below the
    first bin it is continued as a surface smooth below its finest resolved scale,
    ``G = a r^2 + b r^4`` through the first two bins (``b = 0``, ballistic, unless that is
    concave and rising), beyond the last bin flat; the shares of those continuations in
    ``v_el`` are reported.

    Parameters
    ----------
    G : xarray.DataArray
        Height-difference ACF on ``dr`` (length^2), extra dims allowed.
    E_star : float, str or Quantity
        Contact modulus ``E*`` (Pa for numbers).
    a_c : array_like, str, Quantity or DataArray, optional
        Patch radii for eq. 44 (numbers in the unit of ``dr``; a DataArray with ``units``
        is converted; default: the lags of G).

    Returns
    -------
    xarray.Dataset
        ``v_el`` (J m-2), ``v_el_std`` (its statistical standard deviation, J m-2: the
        finite-area errors of G with their full covariance between bins, from the
        spectrum of G for the map's geometry; NaN for a G without one),
        ``v_el_patch`` on ``a_c`` (J m-2), ``extrapolated_below`` and
        ``extrapolated_above`` (fractions of ``v_el`` from the continuations).

    Raises
    ------
    ValueError
        ``E_star <= 0``, or ``G`` not a height-difference ACF.

    Examples
    --------
    One sinusoid ``h0 cos(q x)`` has ``G = h0^2/2 (1 - J0(q dr))`` and
    ``v_el = q E* h0^2 / 8`` (eq. 12):

    >>> import numpy as np, xarray as xr
    >>> from scipy.special import j0
    >>> dr = np.geomspace(1e-4, 1e5, 4000)  # in um, q = 1 um-1, h0 = 1 um
    >>> G = xr.DataArray(0.5 * (1 - j0(dr)), dims="dr", attrs={"units": "um2"},
    ...                  coords={"dr": ("dr", dr, {"units": "um"})})
    >>> v = xrough.elastic_energy(G, E_star="1 MPa")
    >>> round(float(v.v_el) / (1e6 * 1e-6 / 8), 3)  # J m-2 against q E* h0^2 / 8
    1.0
    """
    E = u.positive_si(E_star, _PRESSURE, what="E_star")
    rated, (G, spec) = G, read_acf(G)  # rated: G with its own verdict, for rate_result
    positive = spec.dr[spec.dr > 0]
    ac = (positive if a_c is None else
          u.array_in(a_c, spec.length_unit, what="a_c", noun="patch radii", positive=True))
    G_si, _ = acf_in_si(G, spec)
    window = lag_window(G, spec.dr)
    edge = _window_edge(window, positive)
    res = _per_curve(k.energy_curve, G_si, out={"k": ac.size + 4}, dr=spec.dr * spec.to_m,
                     a_c=np.append(ac, edge) * spec.to_m)
    quarter = E / 4
    total = res.isel(k=0)
    part = {"v_el": quarter * total, "below": res.isel(k=1), "above": res.isel(k=2),
            "patch": quarter * res.isel(k=slice(3, -1)).rename(k="a_c"),
            "window": res.isel(k=-1) / total}
    model, factor = _error_inputs(G, G_si, spec)
    std = (quarter * _per_curve(_energy_std, G_si, factor, out={"one": 1},
                                dr=spec.dr * spec.to_m, **model).isel(one=0)
           if model else xr.full_like(part["v_el"], np.nan))
    ds = xr.Dataset(
        {
            "v_el": part["v_el"].assign_attrs(
                units="J m-2", long_name="areal elastic energy of full contact",
                equation="eq. 16: v_el = E*/4 int_0^inf G(r) / r^2 dr"),
            "v_el_std": std.assign_attrs(
                units="J m-2", long_name="statistical standard deviation of v_el",
                error_of=ERROR_OF_SURFACE if model else ERROR_OF_NONE),
            "v_el_patch": part["patch"].assign_attrs(
                units="J m-2", long_name="areal elastic energy to flatten patches of radius "
                "a_c", equation="eq. 44: v_el(a_c) = E*/4 int_0^a_c G/r^2 dr"),
            "extrapolated_below": part["below"].assign_attrs(
                units="1", long_name="share of v_el from below the smallest dr (continued as "
                "a dr^2 + b dr^4)"),
            "extrapolated_above": part["above"].assign_attrs(
                units="1", long_name="share of v_el from beyond the largest dr (flat "
                "continuation)"),
            "v_el_below_window": part["window"].assign_attrs(
                units="1", long_name="share of v_el from lags below reliable_dr_min, which "
                "the instrument does not resolve (the continuation below the first lag "
                "included; without a window: below the first lag, as extrapolated_below)"),
        },
        coords={**own_coords(G), **lag_coord(ac, spec.unit_str, name="a_c",
                                               long_name="patch radius")},
        attrs=result_attrs(G, E_star=E, E_star_units="Pa"),
    )
    ds, bridged = _bridged_energy(ds, G_si, spec)
    return rate_result(ds, bridged + _window_share(part["window"], window, spec, "v_el",
                                          "v_el_below_window") + [
        (part["below"] > EXTRAPOLATED, "questionable",
         f"more than {EXTRAPOLATED:.0%} of v_el comes from below the smallest lag, where G "
         "is continued as a smooth surface's a dr^2 + b dr^4: the energy is set by scales "
         "finer than the data "
         "(H < 0.5 puts it at the smallest scales); measure finer, or read v_el as a "
         "lower bound"),
        (part["above"] > EXTRAPOLATED, "questionable",
         f"more than {EXTRAPOLATED:.0%} of v_el comes from beyond the largest lag, where G "
         "is continued flat: measure larger scales")], what="elastic_energy", G=rated)


def _window_edge(window: LagWindow, lags: np.ndarray) -> float:
    """Where the lags the instrument resolves begin: ``reliable_dr_min``, else the first lag.

    ``inf`` when the window holds no lag (nothing is resolved).
    """
    if window.empty is not None:
        return np.inf
    return float(window.lo) if window.lo is not None else float(lags[0])


def _window_share(share: xr.DataArray, window: LagWindow, spec: AcfSpec, what: str,
                  variable: str) -> list:
    """Return the :func:`rate_result` checks of the share of ``what`` below ``reliable_dr_min``.

    Questionable above :data:`BELOW_WINDOW`; said as a remark below it; failed when the
    window holds no lag (every value NaN). None without a recorded window (the share is
    then that of the continuation below the first lag, which its own check rates).
    """
    if window.empty is not None:
        return [_no_lag(window)]
    if window.lo is None:
        return []
    where = (f"lags below reliable_dr_min = {window.lo:.4g} {spec.unit_str}, the smallest "
             f"lag the instrument resolves ({window.said})")
    values = np.asarray(share.values if share.chunks is None else [], dtype=float)
    values = values[np.isfinite(values)]
    pct = ("a share" if not values.size else f"{values.min():.0%}" if
           np.isclose(values.min(), values.max(), atol=0.005) else
           f"{values.min():.0%} to {values.max():.0%}")
    return [
        (share > BELOW_WINDOW, "questionable",
         f"{pct} of {what} (variable {variable}) comes from {where}, more than "
         f"{BELOW_WINDOW:.0%}: G there is shaped by the instrument (a tip cannot follow "
         "valleys curved more sharply than its radius, which mostly lowers G), so the "
         "result rests on scales the data do not resolve (v_el there is at best a lower "
         "bound): measure with a sharper tip or a finer lateral resolution"),
        (share <= BELOW_WINDOW, "good", f"{pct} of {what} ({variable}) comes from {where}")]


def _bridged_energy(ds: xr.Dataset, G_si: xr.DataArray, spec: AcfSpec) -> tuple:
    """Add the share of v_el from the bridges over the gaps of G, with its error.

    Returns the Dataset and the checks (for :func:`rate_result`) that say it.
    """
    if not len(spec.gaps):
        return ds, []
    res = _per_curve(bridge_energy, G_si, out={"k": 2}, dr=spec.dr * spec.to_m,
                     lo=spec.gaps[:, 0] * spec.to_m, hi=spec.gaps[:, 1] * spec.to_m)
    share, err = res.isel(k=0), res.isel(k=1)
    ds = ds.assign(
        gap_share=share.assign_attrs(
            units="1", long_name="share of v_el from the power-law bridges over lags no "
            "measurement covers"),
        gap_share_error=err.assign_attrs(
            units="1", long_name="largest relative change of v_el when a bridge continues "
            "the local slope of the bins below or above it instead"))
    computed = res.chunks is None
    text = gap_note(spec, "v_el takes G there as that bridge (gap_share" + (
        f": {float(share.max()):.1%} of v_el" if computed else "") + "); continuing the "
        "local slope of the bins below or above the gap instead changes v_el by "
        "gap_share_error" + (f" (up to {float(err.max()):.1%})" if computed else ""))
    return ds, [(err > BRIDGED, "questionable", f"{text}, more than {BRIDGED:.0%}: "
                 "measure those lags"), (err <= BRIDGED, "good", text)]


# ---------------------------------------------------------------------------------------
# stress ACF and Persson theory (eq. 24, 29-30, 34, 39-42, 47-50)
# ---------------------------------------------------------------------------------------
@u.accepts_quantified
@own_attrs  # inside: it restores coords' units from the dequantified input
def stress_acf(G: xr.DataArray, *, E_star: QuantityLike, p0: QuantityLike | None = None,
               theory: str = "persson",
               gradient: xr.DataArray | None = None, kappa: float = KAPPA_PERSSON,
               gradient_method: str = "auto", smooth_full: bool = True) -> xr.DataArray:
    r"""Stress autocorrelation function in full (eq. 24) or partial contact (eq. 30/48).

    Full contact (exact within linear elasticity, the ``p0^2`` offset left out):

    .. math:: G_\sigma^{full}(\Delta r) = \left(\frac{E^*}{2}\right)^2 \nabla^2 G
              = \left(\frac{E^*}{2}\right)^2 \frac{1}{\Delta r}\frac{d}{d\Delta r}
              \left[\Delta r \frac{dG}{d\Delta r}\right]

    Partial contact: ``G_sigma = p0^2 + G_sigma_full W[a_r(p*(dr))]`` with
    ``p* = p0 / (E* gbar(dr))`` and ``W = a_r`` (``theory="persson"``, eq. 49),
    ``W = a_ri^2 / a_r`` (``"modified"``, eq. 49-50) or ``W = a_r^2 / a_ri``
    (``"modified_ar2"``, the other reading of the garbled eq. 49; see :func:`persson`).
    The Laplacian is that of a smoothing spline of ``ln G`` against ``ln dr`` (0.05
    decades, ``attrs["derivative"]``); lags where it is not determined (the even and odd
    bins disagree, outside ``reliable_dr_min/max``) are NaN with a ``QualityWarning``, and
    a G flat from its first lag fails. Notes and accuracy: docs/contact.md, "Full
    contact" ("The second derivative", "What the data determine").

    Parameters
    ----------
    G : xarray.DataArray
        Height-difference ACF on ``dr``.
    E_star : float, str or Quantity
        Contact modulus (Pa for numbers).
    p0 : float, str, Quantity or array, optional
        Mean pressure(s) (Pa); None for full contact. Several values give a ``p0`` dim.
    theory : {'persson', 'modified', 'modified_ar2'}
        Weighting of eq. 49.
    gradient : xarray.DataArray, optional
        Precomputed ``gbar(dr)`` (e.g. from :func:`xrough.rms_gradient`), reused.
    kappa : float
        Slope of ``a_r`` at small pressure (eq. 29; Persson: ``sqrt(8/pi)``).
    gradient_method : {'auto', 'exact', 'simple', 'fit'}
        How ``gbar`` is obtained without ``gradient`` (see :func:`xrough.rms_gradient`).
    smooth_full : bool
        In partial contact, continue ``G_sigma_full`` beyond its roll-off by a steep power
        law (the paper's; :func:`xrough.persson`); no effect in full contact.

    Returns
    -------
    xarray.DataArray
        ``G_sigma`` on ``dr`` (and ``p0``) in Pa^2.

    Raises
    ------
    ValueError
        ``E_star <= 0``, ``p0 <= 0``, unknown ``theory``, ``G`` not a height-difference ACF.

    Examples
    --------
    Ballistic G (``gbar = 0.1``): full-contact stress variance ``(E*/2)^2 gbar^2``.

    >>> import numpy as np, xarray as xr
    >>> dr = np.geomspace(1.0, 100.0, 30)
    >>> G = xr.DataArray(0.01 * dr**2 / 4, dims="dr", attrs={"units": "nm2"},
    ...                  coords={"dr": ("dr", dr, {"units": "nm"})})
    >>> S = xrough.stress_acf(G, E_star="1 MPa")
    >>> print(f"{float(S[0]):.4g} {S.attrs['units']}")
    2.5e+09 Pa2
    """
    if theory not in THEORIES:
        raise ValueError(f"theory must be one of {THEORIES}, got {theory!r}")
    E = u.positive_si(E_star, _PRESSURE, what="E_star")
    if p0 is not None:
        ds = persson(G, E_star=E, p0=p0, theory=theory, gradient=gradient, kappa=kappa,
                     gradient_method=gradient_method, variables=("G_sigma",),
                     smooth_full=smooth_full)
        out = ds["G_sigma"].assign_coords(  # its errors beside it, drawn as bands
            {name: ds[name] for name in ds.data_vars if str(name).startswith("G_sigma_")})
        out.attrs = {**ds.attrs, **out.attrs}  # provenance, E_star, theory and the variable's
        return out
    rated, (G, spec) = G, read_acf(G)  # rated: G with its own verdict, for rate_result
    G_si, error = acf_in_si(G, spec)
    lap, why, _ = _laplacian(G)
    full = (E / 2) ** 2 * lap
    std = _laplacian_std(G)
    out = full.transpose(..., "dr").assign_coords(
        {**own_coords(G), **lag_coord(spec.dr, spec.unit_str)})
    out = out.assign_coords(G_sigma_std=(
        ((E / 2) ** 2 * std).where(lap.notnull()).transpose(..., "dr").assign_attrs(
            units="Pa2", long_name="statistical standard deviation of G_sigma",
            error_of=(ERROR_OF_SURFACE + " (propagated through the smoothing spline of "
                      "ln G, linearised)") if error_model(G) else ERROR_OF_NONE)))
    out.name = "G_sigma"
    out.attrs = result_attrs(G, units="Pa2", long_name="stress autocorrelation function",
                             derivative=_DERIVATIVE,
                             equation="eq. 24 (full contact, p0^2 offset left out)")
    few = (G > 0).sum("dr") < 5
    flat, unresolved = _unresolved(G_si, error, spec, "the Laplacian of G (eq. 24)")
    out = out.where(~flat).assign_attrs(out.attrs)
    out = mark_gaps(out, spec, what="stress_acf", depends=_GAP_LAPLACIAN)
    return rate_result(out, [(few, "questionable", "fewer than 5 valid bins: the Laplacian is "
                        "that of the log-log polygon through them, not of a smoothed G; "
                        "use more points per decade"), *_derivative_checks(why, spec),
                       unresolved], what="stress_acf", G=rated)


@u.accepts_quantified
def stress_acf_from_spectrum(C: xr.DataArray, dr: QuantityLike, *,
                             E_star: QuantityLike) -> xr.DataArray:
    r"""Full-contact stress ACF of a model spectrum by the spectral route (eq. 22-24).

    .. math:: G_\sigma^{full}(\Delta r) = \left(\frac{E^*}{2}\right)^2 \frac{1}{2\pi}
              \int dq\, q^3 C(q) J_0(q\Delta r)
              = \left(\frac{E^*}{2}\right)^2 \left[\bar g^2 - G_{q^2C}(\Delta r)\right]

    where ``G_{q^2 C}`` is eq. 9 applied to the spectrum ``q^2 C(q)``: exact per power-law
    piece, so this is the reference that :func:`stress_acf` (a derivative of G) is tested
    against.

    Parameters
    ----------
    C : xarray.DataArray
        A model spectrum from :func:`xrough.model_spectrum` (read as every function of a
        spectrum reads it: values in length^4 that match the model of its attrs, on
        wavenumbers in 1/length).
    dr : array_like
        Lags in the length unit of ``C``.
    E_star : float, str or Quantity
        Contact modulus (Pa for numbers).

    Returns
    -------
    xarray.DataArray
        ``G_sigma`` on ``dr`` in Pa^2.

    Raises
    ------
    ValueError
        ``C`` without a model in its attrs, values that do not match it (NaN, negative or
        modified), values or wavenumbers without length units, or a bad ``E_star`` or
        ``dr``.

    Examples
    --------
    >>> C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_gradient=0.1, unit="nm")
    >>> S = xrough.stress_acf_from_spectrum(C, [1e-3], E_star="1 MPa")
    >>> print(f"{float(S[0]):.4g}")  # (E*/2)^2 gbar^2 at dr -> 0
    2.5e+09
    """
    E = u.positive_si(E_star, _PRESSURE, what="E_star")
    spec = spectrum_input(C)  # dims, units and values, as every function of a spectrum
    model = spec.model
    if model is None:
        raise ValueError("stress_acf_from_spectrum needs a model spectrum "
                         "(xrough.model_spectrum)")
    lunit = spec.length_unit
    dr = u.array_in(dr, lunit, what="dr", noun="distances")
    knots = 0.0 if model.piecewise_power_law else 160.0
    g_q2 = acf_from_spectrum_kernel(dr, lambda q: q**2 * model(q), model.breakpoints,
                                    knots_per_decade=knots)
    values = (E / 2) ** 2 * (model.moment(2) - g_q2)
    return xr.DataArray(values, dims="dr", name="G_sigma",
                        coords=lag_coord(dr, u.format_units(lunit)),
                        attrs=result_attrs(C, units="Pa2",
                                           long_name="stress autocorrelation function",
                                           equation="eq. 22-24, spectral route"))


PERSSON_VARIABLES = ("p_star", "a_r", "a_ri", "sigma_c", "sigma_quick", "G_sigma",
                     "Gamma_sigma", "Gamma_sigma_sa", "Gamma_sigma_51", "G_du")
#: The variables of the theory's own error beside ``a_r``, ``a_ri`` and ``sigma_c``: the
#: expected theory - exact, the expected exact value and its one-sigma interval.
MODEL_ERROR_SUFFIXES = ("_model_error", "_exact", "_exact_lower", "_exact_upper")
#: The outputs that need a fit of G (eq. 42: the roll-off law beyond the lags' reach).
_NEED_FIT = ("sigma_quick",)
#: The outputs that need gbar (eq. 26), with their errors: p_star and a_r (eq. 29), a_ri
#: (eq. 50), sigma_c = p0 / a_r (eq. 39/40), and through W[a_r] (eq. 49) or gbar(0) the
#: stress ACFs (eq. 30/48, 47, 51) and G_du (eq. 34). sigma_quick (eq. 41/42) needs the fit
#: and G only. A failed input blanks only what needs it (:func:`rate_result`). (The Laplacian of
#: G, eq. 24, which G_sigma and Gamma_sigma also need, has checks per lag only: NaN there,
#: questionable; and a G flat from its first lag fails every output, gbar too.)
_NEED_GRADIENT = tuple(
    f"{name}{suffix}" for name in PERSSON_VARIABLES if name not in _NEED_FIT
    for suffix in ("", "_std", *MODEL_ERROR_SUFFIXES))


def gradient_on(gradient: xr.DataArray, G: xr.DataArray, spec: AcfSpec) -> xr.DataArray:
    """Put a given gbar on G's lags (NaN where it is not given), refusing other lags."""
    if not isinstance(gradient, xr.DataArray) or "dr" not in gradient.dims:
        raise TypeError("gradient must be the DataArray gbar(dr) of xrough.rms_gradient")
    unit = u.as_length_unit(u.units_of(gradient["dr"], what="coordinate 'dr' of gradient"),
                            what="coordinate 'dr' of gradient")
    lags = gradient["dr"].values * u.conversion_factor(unit, spec.length_unit)
    gradient = strip_marks(gradient.assign_coords(dr=lags)).drop_vars(
        [c for c in gradient.coords if c not in gradient.dims], errors="ignore")
    match = np.isclose(spec.dr[:, None], lags[None, :], rtol=1e-9, atol=0).any(axis=0)
    if not match.all():
        raise ValueError(
            "the rms gradient is not given on the lags of G; compute it from this G "
            "(xrough.rms_gradient(G)) or pass gradient_method instead")
    if gradient.sizes["dr"] != spec.dr.size:
        gradient = gradient.reindex(dr=spec.dr, method="nearest", tolerance=1e-9 * spec.dr[-1])
    return gradient.assign_coords(dr=spec.dr)


def first_finite(values: np.ndarray) -> np.ndarray:
    """Take the first finite value along the last axis (NaN if none)."""
    finite = np.isfinite(values)
    idx = np.argmax(finite, axis=-1)
    first = np.take_along_axis(values, idx[..., None], axis=-1)[..., 0]
    return np.where(finite.any(axis=-1), first, np.nan)


@u.accepts_quantified
@own_attrs  # inside: it restores coords' units from the dequantified input
def persson(G: xr.DataArray, *, E_star: QuantityLike, p0: QuantityLike, theory: str = "persson",
            kappa: float = KAPPA_PERSSON, gradient: xr.DataArray | None = None,
            gradient_method: str = "auto", variables: tuple[str, ...] | None = None,
            fit: xr.Dataset | None = None, smooth_full: bool = True) -> xr.Dataset:
    r"""Real-space Persson theory of partial contact as a function of resolution ``dr``.

    Each function of wavenumber ``q`` of the theory is evaluated from G at ``dr = 2 pi / q``:

    - ``p_star = p0 / (E* gbar(dr))``; ``a_r = erf(sqrt(pi) kappa p* / 2)`` (eq. 29), the
      contact area at resolution ``dr``; ``a_ri = (1 - a_r^2) erf(sqrt(pi) p*) + a_r^3``
      (eq. 50); ``sigma_c = p0 / a_r`` (eq. 39/40); ``sigma_quick`` (eq. 41/42);
    - ``G_sigma = p0^2 + G_sigma_full W`` (eq. 30/48) with ``G_sigma_full = (E*/2)^2
      Laplacian(G)`` (eq. 24) and ``W`` of eq. 49: ``a_r`` (``"persson"``), ``a_ri^2 /
      a_r`` (``"modified"``) or ``a_r^2 / a_ri`` (``"modified_ar2"``);
    - ``Gamma_sigma = G_sigma / a(dr -> 0)`` (eq. 47), its small-pressure limit
      ``Gamma_sigma_sa`` and eq. 51 as printed, ``Gamma_sigma_51``; ``G_du = G W`` (eq. 34).

    Notes (eq. 49 and 51, errors): docs/contact.md, "Partial contact: real-space Persson theory".

    Parameters
    ----------
    G : xarray.DataArray
        Height-difference ACF on ``dr``.
    E_star : float, str or Quantity
        Contact modulus (Pa for numbers), > 0.
    p0 : float, str, Quantity or array
        Mean pressure(s), > 0; several give a ``p0`` dim (vectorised).
    theory : {'persson', 'modified', 'modified_ar2'}
        Weighting of eq. 49 for ``G_sigma``, ``Gamma_sigma``, ``Gamma_sigma_sa``, ``G_du``.
    kappa : float
        Small-pressure slope of the contact area (simulations suggest about 2).
    gradient : xarray.DataArray, optional
        Precomputed ``gbar(dr)`` on the same ``dr``; computed once otherwise.
    gradient_method : {'auto', 'exact', 'simple', 'fit'}
        See :func:`xrough.rms_gradient`; the result covers the lags ``gbar`` covers.
    variables : tuple of str, optional
        Only these outputs (default all; others are not computed).
    fit : xarray.Dataset, optional
        A :func:`xrough.fit_acf` of G (for eq. 42 and ``gbar``); default: G's own fit.
    smooth_full : bool
        Continue ``G_sigma_full`` beyond its roll-off by ``dr^-4`` (the paper's); False: eq. 24.

    Returns
    -------
    xarray.Dataset
        The variables above on ``dr`` (and ``p0``), in 1, Pa, Pa^2 and length^2, with
        their errors (``<name>_std``) and, for ``a_r``, ``a_ri``, ``sigma_c`` and
        ``G_sigma``, the expected exact values of the solver study (``<name>_exact``,
        ``_exact_lower``/``_upper``, ``<name>_model_error``): docs/contact.md.

    Raises
    ------
    ValueError
        Non-positive ``E_star``, ``p0`` or ``kappa``, unknown options, invalid G.

    Examples
    --------
    >>> C = xrough.model_spectrum(hurst=0.8, lambda_r="10 um", lambda_s="10 nm",
    ...                           rms_gradient=1.0, unit="um")
    >>> G = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="1 mm")
    >>> ds = xrough.persson(G, E_star="25 MPa", p0=["0.1 MPa", "1 MPa"])
    >>> ds.a_r.dims, ds.sigma_c.attrs["units"]
    (('p0', 'dr'), 'Pa')
    """
    wanted = _persson_variables(theory, kappa, variables)
    E = u.positive_si(E_star, _PRESSURE, what="E_star")
    p0s = u.positive_si(p0, _PRESSURE, what="p0", many=True)
    rated, (G, spec) = G, read_acf(G)  # rated: G with its own verdict, for rate_result
    G = G.transpose(..., "dr")
    G_si, error = acf_in_si(G, spec)
    run = _PerssonRun(G=G, spec=spec, G_si=G_si, error=error, E=E, kappa=float(kappa),
                      theory=theory, wanted=wanted, unlike_study=_unlike_study(rated),
                      p0=xr.DataArray(np.atleast_1d(p0s), dims="p0"),
                      dr_m=xr.DataArray(spec.dr * spec.to_m, dims="dr"))
    out: dict[str, xr.DataArray] = {}
    checks: list = []
    derivative: list = []
    area: _ContactArea | None = None
    method = "none"
    if set(wanted) - {"sigma_quick"}:  # everything else needs gbar(dr)
        if gradient is None:
            with quality.quiet():  # their notes are this result's: it warns once
                if set(_NEED_FIT) & set(wanted) and gradient_method in ("auto", "fit"):
                    # of the rated G: its verdict and reasons are theirs
                    fit = fit_acf(rated) if fit is None else fit  # one fit for both
                gradient = rms_gradient(
                    rated, method=gradient_method,
                    fit=fit if gradient_method in ("auto", "fit") else None)
        method = str(gradient.attrs.get("method", "given"))
        area = _contact_area(run, gradient)
        derivative.append(area.check)
        out.update(_area_vars(run, area))
    if "sigma_quick" in wanted:
        if fit is None:
            with quality.quiet():
                fit = fit_acf(rated)
        out["sigma_quick"] = _sigma_quick(run, fit)
    if "G_sigma" in wanted or "Gamma_sigma" in wanted:
        assert area is not None  # every variable but sigma_quick has it
        stress, stress_checks, stress_derivative = _stress_vars(run, area, smooth_full)
        out.update(stress)
        checks += stress_checks
        derivative += stress_derivative
    if {"Gamma_sigma_sa", "Gamma_sigma_51"} & set(wanted):
        assert area is not None
        out.update(_asymptote_vars(run, area))
    if "G_du" in wanted:
        assert area is not None
        out["G_du"] = (strip_marks(G) * area.weight).assign_attrs(
            units=G.attrs["units"], long_name="displacement autocorrelation function",
            equation=f"eq. 34 with W of eq. 49 ({theory})")
    ds = _persson_dataset(run, out, p0s, method)
    if np.ndim(p0s) == 0:
        ds = ds.isel(p0=0)
        checks = [(mask.isel(p0=0), level, note) for mask, level, note in checks]
    flat, unresolved = _unresolved(G_si, error, spec, "the rms gradient (eq. 26) and the "
                                   "Laplacian of G (eq. 24), and so every output,")
    ds = _blank(ds, flat, lambda v: True)
    checks += derivative + [unresolved]  # per curve, no p0 dim
    ds, window = _outside_window(ds, G, spec)
    checks += window + _no_exact(ds, run)
    gap = gap_note(spec, _GAP_PERSSON)  # said with the rest: one warning
    checks += [(xr.DataArray(True), "questionable", gap)] if gap else []
    return rate_result(ds, checks, what="persson", G=rated, inherited=(
        (gradient if set(wanted) - {"sigma_quick"} else None, _NEED_GRADIENT,
         "the rms gradient gbar (eq. 26) they need"),
        (fit if set(_NEED_FIT) & set(wanted) else None, _NEED_FIT,
         "the fit of G it needs (eq. 42: the roll-off law)")))


@dataclass(frozen=True)
class _PerssonRun:
    """What every output of :func:`persson` reads: G in SI, the parameters, the axes."""

    G: xr.DataArray
    spec: AcfSpec
    G_si: xr.DataArray
    error: xr.DataArray | None
    E: float
    kappa: float
    theory: str
    wanted: tuple[str, ...]
    #: per curve: a map unlike the solver study's (regions or directions disagree)
    unlike_study: xr.DataArray
    p0: xr.DataArray
    dr_m: xr.DataArray

    @functools.cached_property
    def shape(self) -> xr.DataArray:
        """Give G's local exponents at each lag (:func:`_shape_of`), computed once.

        Read by the model errors of the areas and of G_sigma.
        """
        return _shape_of(self.G)


@dataclass(frozen=True)
class _ContactArea:
    """The rms gradient used (non-increasing), the areas of eq. 29/50 and ``W`` of eq. 49."""

    gbar: xr.DataArray
    p_star: xr.DataArray
    a_r: xr.DataArray
    a_ri: xr.DataArray | None
    weight: xr.DataArray
    check: tuple
    #: ``gbar_std / gbar`` of the given gradient on G's lags, and what it is the error of
    rel_std: xr.DataArray
    error_of: str

    @functools.cached_property
    def gbar0(self) -> xr.DataArray:
        """``gbar`` at the smallest lag where it is finite (eq. 47, 51)."""
        return xr.apply_ufunc(first_finite, self.gbar, input_core_dims=[["dr"]],
                              dask="parallelized", output_dtypes=[float])


def _persson_variables(theory: str, kappa: float, variables) -> tuple[str, ...]:
    """Check ``theory`` and ``kappa``; return the variables asked for."""
    if theory not in THEORIES:
        raise ValueError(f"theory must be one of {THEORIES}, got {theory!r}")
    if not (np.isfinite(kappa) and kappa > 0):
        raise ValueError(f"kappa must be positive, got {kappa!r}")
    wanted = PERSSON_VARIABLES if variables is None else tuple(variables)
    unknown = set(wanted) - set(PERSSON_VARIABLES)
    if unknown:
        raise ValueError(f"unknown variables {sorted(unknown)}; choose from "
                         f"{PERSSON_VARIABLES}")
    return wanted


def _contact_area(run: _PerssonRun, gradient: xr.DataArray) -> _ContactArea:
    """``p*`` and ``a_r`` (eq. 29), ``a_ri`` (eq. 50) where needed, and ``W`` (eq. 49)."""
    given = gradient_on(gradient, run.G, run.spec)
    gbar = _per_curve(k.nonincreasing, given)
    with np.errstate(divide="ignore", invalid="ignore"):
        raised = (gbar / given).max("dr") - 1
    check = (raised > RAISED, "questionable",
             f"the rms gradient rises with dr by more than {RAISED:.0%} somewhere (noise "
             "in G, or a form the detrending left): gbar cannot (eq. 26), so p_star, a_r "
             "and sigma_c use its running maximum from larger lags, which is above the "
             "estimate there")
    with np.errstate(divide="ignore", invalid="ignore"):
        p_star = run.p0 / (run.E * gbar)
    a_r = k.contact_area(p_star, run.kappa)
    need_ai = run.theory != "persson" or "a_ri" in run.wanted
    a_ri = k.improved_area(p_star, a_r) if need_ai else None
    rel_std, error_of = _gradient_error(gradient, run)
    return _ContactArea(gbar=gbar, p_star=p_star, a_r=a_r, a_ri=a_ri,
                        weight=k.weighting(run.theory, a_r, a_ri), check=check,
                        rel_std=rel_std, error_of=error_of)


def _gradient_error(gradient: xr.DataArray, run: _PerssonRun) -> tuple[xr.DataArray, str]:
    """``gbar_std / gbar`` of a gradient on G's lags (NaN: none) and what it is the error of."""
    if "gbar_std" not in gradient.coords:
        return (xr.full_like(gradient_on(gradient, run.G, run.spec), np.nan),
                "none: the given gradient has no coordinate gbar_std")
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = gradient["gbar_std"].reset_coords(drop=True) / gradient.reset_coords(drop=True)
    rel["dr"].attrs = gradient["dr"].attrs
    return (gradient_on(rel, run.G, run.spec),
            str(gradient["gbar_std"].attrs.get("error_of", "")))


def _std_of(value: xr.DataArray, of_p_star, area: _ContactArea, step: float = 1e-6):
    """Return the standard deviation of ``of_p_star(p*)`` from the error of gbar.

    ``p* = p0 / (E* gbar)``: a relative error ``e`` of gbar is one of ``-e`` of ``p*``.
    """
    moved = of_p_star(area.p_star * np.exp(step))
    return abs((moved - value) / step) * area.rel_std


def _area_vars(run: _PerssonRun, area: _ContactArea) -> dict[str, xr.DataArray]:
    """``p_star``, ``a_r``, ``a_ri`` and ``sigma_c``, those asked for."""
    def a_ri() -> xr.DataArray:
        assert area.a_ri is not None  # _contact_area computes it when it is wanted
        return area.a_ri.assign_attrs(
            units="1", long_name="improved relative contact area", equation="eq. 50")

    made = {
        "p_star": lambda: area.p_star.assign_attrs(
            units="1", long_name="reduced pressure p0 / (E* gbar)", equation="eq. 29"),
        "a_r": lambda: area.a_r.assign_attrs(
            units="1", long_name="relative contact area",
            equation="eq. 29: erf(sqrt(pi) kappa p* / 2)"),
        "a_ri": a_ri,
        "sigma_c": lambda: (run.p0 / area.a_r).assign_attrs(
            units="Pa", long_name="mean contact stress at resolution dr",
            equation="eq. 39/40: p0 / a_r"),
    }
    out = {name: make() for name, make in made.items() if name in run.wanted}

    def a_r_of(p_star):
        return k.contact_area(p_star, run.kappa)

    of_p_star = {"p_star": lambda p: p, "a_r": a_r_of,
                 "a_ri": lambda p: k.improved_area(p, a_r_of(p)),
                 "sigma_c": lambda p: run.p0 / a_r_of(p)}
    for name in list(out):
        std = _std_of(out[name], of_p_star[name], area)
        out[f"{name}_std"] = std.assign_attrs(
            units=out[name].attrs["units"],
            long_name=f"statistical standard deviation of {name}",
            error_of=area.error_of + (" (propagated from gbar_std, linearised)"
                                      if area.error_of.startswith("the surface") else ""))
    out.update(_model_errors(run, area, out))
    return out


#: What the model error of an area or stress is, in words.
_MODEL_ERROR = (
    "the theory's own error, expected from the boundary-element study of "
    "benchmarks/model_error_study.py (xrough/data/persson_area_error.csv: H 0.1-0.95, sharp "
    "and smooth roll-offs and short cutoffs, lambda_s 2-16 px, bandwidths 4-256, "
    "p* 1e-4-0.5), as a function of p* and of G's local exponents at this lag "
    "(xrough._kernels.model_error); <name>_exact is the expected exact solution for this "
    "map, <name>_exact_lower / _upper its one-sigma interval (the solver's spread about "
    "the expectation, not statistical: it does not shrink with the map size; an exact "
    "area at most 1); NaN below "
    f"p* = {me.P_STAR_RANGE[0]:g}, where G's local exponents lie outside the study's, and "
    "where G's regions or directions disagree (the study's surfaces are stationary, "
    "isotropic and Gaussian)")


def _model_errors(run: _PerssonRun, area: _ContactArea, out: dict) -> dict:
    """Give the theory's own error of ``a_r``, ``a_ri`` and ``sigma_c``, those asked for.

    ``<name>_model_error`` (theory - expected exact), ``<name>_exact`` and its one-sigma
    interval ``<name>_exact_lower`` / ``_upper``, from :func:`me.area_model_error` at each
    lag's ``p*`` and G's local exponents there.
    """
    wanted = [name for name in ("a_r", "a_ri", "sigma_c") if name in out]
    if not wanted:
        return {}
    persson_kappa = bool(np.isclose(run.kappa, KAPPA_PERSSON, rtol=1e-9))
    shape = run.shape
    made = {}

    @functools.cache
    def exact_area(which: str) -> tuple[xr.DataArray, ...]:
        """Give the expected exact area and its bounds: ln(a / a_exact) = bias, <= 1."""
        bias, spread = xr.apply_ufunc(
            functools.partial(me.area_model_error, area=which,
                              periodic=bool(run.G.attrs.get("periodic", 0))), area.p_star,
            *(shape.sel(feature=f, drop=True) for f in me.FEATURES),
            dask="parallelized", output_dtypes=[float, float], output_core_dims=[[], []])
        if not persson_kappa:
            bias = xr.full_like(bias, np.nan)
        bias = bias.where(~run.unlike_study)  # a map unlike the study's: no correction
        a = area.a_ri if which == "a_ri" else area.a_r
        return tuple(np.minimum(a * np.exp(-bias + s * spread), 1.0) for s in (0, -1, 1))

    for name in wanted:
        exact, lower, upper = exact_area("a_ri" if name == "a_ri" else "a_r")
        if name == "sigma_c":  # p0 / a_r
            exact, lower, upper = run.p0 / exact, run.p0 / upper, run.p0 / lower
        value = out[name]
        units = value.attrs["units"]
        note = (_MODEL_ERROR if persson_kappa else
                f"none: the solver study is for Persson's kappa = {KAPPA_PERSSON:.4f}, not "
                f"{run.kappa:.4g}")
        finite = np.isfinite(value)
        for suffix, data, long_name in (
                ("_model_error", value - exact, "model error of {} (theory - expected exact)"),
                ("_exact", exact, "expected exact {} (theory corrected by the solver study)"),
                ("_exact_lower", lower, "lower one-sigma bound of the exact {}"),
                ("_exact_upper", upper, "upper one-sigma bound of the exact {}")):
            made[name + suffix] = data.where(finite).assign_attrs(
                units=units, long_name=long_name.format(name), error_of=note)
    return made


def _stress_model_errors(run: _PerssonRun, area: _ContactArea, g_sigma: xr.DataArray
                         ) -> dict:
    """Give the theory's own error of ``G_sigma`` (eq. 30/48, ``W = a_r``).

    The fluctuating part ``F = G_sigma - p0^2`` corrected by
    :func:`me.stress_model_error` at each lag's ``p*``, the finest lag's ``p*``, the
    decay of ``F`` and G's shape there: ``G_sigma_exact = p0^2 + F exp(-bias)`` and its
    one-sigma interval (``bias -+ spread``). NaN (and nothing computed) for the
    modified theory and another ``kappa``; NaN where the map is unlike the study's.
    """
    p0sq = run.p0**2
    fluct = g_sigma - p0sq
    if run.theory == "persson" and np.isclose(run.kappa, KAPPA_PERSSON, rtol=1e-9):
        note = _MODEL_ERROR_STRESS
        first, p_star_0 = (xr.apply_ufunc(first_finite, v, input_core_dims=[["dr"]],
                                          dask="parallelized", output_dtypes=[float],
                                          dask_gufunc_kwargs={"allow_rechunk": True})
                           for v in (fluct, area.p_star))  # dr: tens of lags, one chunk
        bias, spread = xr.apply_ufunc(
            functools.partial(me.stress_model_error,
                              periodic=bool(run.G.attrs.get("periodic", 0))),
            area.p_star, p_star_0, fluct / first, *(run.shape.sel(feature=f, drop=True)
                                                    for f in me.FEATURES),
            dask="parallelized", output_dtypes=[float, float], output_core_dims=[[], []])
        bias = bias.where(~run.unlike_study)
    else:
        note = (f"none: the solver study is for the original theory (W = a_r) with Persson's "
                f"kappa = {KAPPA_PERSSON:.4f}")
        bias = spread = xr.full_like(fluct, np.nan)
    exact, lower, upper = (p0sq + fluct * np.exp(-bias + k_ * spread) for k_ in (0, -1, 1))
    finite = np.isfinite(g_sigma)
    made = {}
    for suffix, data, long_name in (
            ("_model_error", g_sigma - exact, "model error of G_sigma (theory - expected "
             "exact)"),
            ("_exact", exact, "expected exact G_sigma (theory corrected by the solver study)"),
            ("_exact_lower", lower, "lower one-sigma bound of the exact G_sigma"),
            ("_exact_upper", upper, "upper one-sigma bound of the exact G_sigma")):
        made["G_sigma" + suffix] = data.where(finite).assign_attrs(
            units="Pa2", long_name=long_name, error_of=note)
    return made


#: What the model error of the stress ACF is, in words.
_MODEL_ERROR_STRESS = (
    "the theory's own error, expected from the boundary-element study of "
    "benchmarks/model_error_study.py (xrough/data/persson_stress_error.csv.gz: the "
    "surfaces of the area's study, the solver's stress ACF <p(r) p(r + dr)> binned as G): "
    "ln(F / F_exact) of the fluctuating part F = G_sigma - p0^2 as a function of p* at "
    "the lag and at the finest lag and of G's local exponents at the lag; G_sigma_exact "
    "is the "
    "expected exact stress ACF, G_sigma_exact_lower / _upper its one-sigma interval (the "
    "solver's spread, not statistical); NaN below "
    f"p* = {me.P_STAR_RANGE[0]:g}, where F has fallen below {me.DECAY_MIN:g} of its first "
    "value, outside the study's shapes of G, and where G's regions or directions disagree")


#: The reasons of G's rating that put a map outside the solver study's surfaces
#: (stationary, isotropic, Gaussian): on such real maps the model error does not hold
#: (benchmarks/model_error_real.py).
UNLIKE_STUDY = ("regions_disagree", "anisotropic")


def _unlike_study(G: xr.DataArray) -> xr.DataArray:
    """Per curve: G's reasons say its map is not stationary or not isotropic (bool)."""
    if quality.REASON not in G.coords:
        return xr.DataArray(False)
    bits = functools.reduce(np.bitwise_or, map(quality.reason_bit, UNLIKE_STUDY))
    return (G[quality.REASON].reset_coords(drop=True).astype(np.int64) & bits) != 0


def _no_exact(ds: xr.Dataset, run: _PerssonRun) -> list:
    """Remark where the theory has a value but no expected exact one (per curve)."""
    name = next((n for n in ("a_r", "a_ri", "sigma_c") if f"{n}_exact" in ds), None)
    if name is None:
        return []
    missing = ds[name].notnull() & ds[f"{name}_exact"].isnull()
    missing = missing.any([d for d in ("dr", "p0") if d in missing.dims])
    why = (f"p* is below {me.P_STAR_RANGE[0]:g}, G's shape (its local exponents and "
           "range, xrough._kernels.model_error.FEATURES) lies outside the solver study's, "
           "or G's regions or directions disagree (a map unlike the study's stationary, "
           "isotropic Gaussian surfaces: on such real maps the solver's area differs from "
           "the corrected one by 20-70 %, benchmarks/model_error_real.py)"
           if np.isclose(run.kappa, KAPPA_PERSSON, rtol=1e-9) else
           f"the solver study is for Persson's kappa = {KAPPA_PERSSON:.4f}")
    return [(missing, "good", f"{name}_exact (the expected exact value) is NaN at some lags "
             f"where {name} is not: {why}; Persson's value stands without it there")]


def _shape_of(G: xr.DataArray) -> xr.DataArray:
    """G's local exponents at each lag (:func:`me.features_on_lags`), dim ``feature``."""
    dr = G["dr"].values
    return xr.apply_ufunc(
        lambda g: me.features_on_lags(dr, g), strip_marks(G).reset_coords(drop=True),
        input_core_dims=[["dr"]], output_core_dims=[["feature", "dr"]], vectorize=True,
        dask="parallelized", output_dtypes=[float],
        dask_gufunc_kwargs={"output_sizes": {"feature": len(me.FEATURES)}},
    ).assign_coords(feature=list(me.FEATURES))


def _sigma_quick(run: _PerssonRun, fit: xr.Dataset) -> xr.DataArray:
    """Estimate the contact stress quickly (eq. 41/42) from a fit, at least ``p0``."""
    reading = read_fit(fit)
    lf, hf = (u.conversion_factor(unit, "m") for unit in (reading.lateral, reading.height))
    params = [a.reset_coords(drop=True)
              for a in (fit["hurst"], fit["sigma_h"], fit["lambda_r"], rolloff_shapes(fit))]
    est = xr.apply_ufunc(
        k.quick_stress, run.dr_m, run.G_si, params[0], params[1] * hf, params[2] * lf,
        params[3], dask="parallelized", output_dtypes=[float], keep_attrs=False,
        kwargs={"E_star": run.E})
    return np.maximum(est, run.p0).assign_attrs(
        units="Pa", long_name="quick estimate of the mean contact stress",
        equation="eq. 41 (dr < lambda_r), eq. 42 (dr > lambda_r), at least p0")


def _stress_vars(run: _PerssonRun, area: _ContactArea, smooth_full: bool):
    """``G_sigma`` (eq. 30/48) and ``Gamma_sigma`` (eq. 47), those asked for.

    Returns the variables, the per-``p0`` checks and the per-curve checks of the Laplacian.
    """
    lap, why, _ = _laplacian(run.G)
    lap_std = _laplacian_std(run.G)
    if smooth_full:
        lap_std = _per_curve(k.smooth_tail_std, lap_std, lap, run.G_si, dr=run.dr_m.values)
        lap = _per_curve(k.smooth_tail, lap, run.G_si, dr=run.dr_m.values)
    full = (run.E / 2) ** 2 * lap
    g_sigma = run.p0**2 + full * area.weight
    # its statistical error: the Laplacian's (G's covariance through the spline) and W's
    # (gbar's, through a_r), independent as a first approximation
    full_std = (run.E / 2) ** 2 * lap_std

    def weighted(p_star):
        a_r = k.contact_area(p_star, run.kappa)
        a_ri = k.improved_area(p_star, a_r) if run.theory != "persson" else None
        return full * k.weighting(run.theory, a_r, a_ri)

    g_sigma_std = np.hypot(area.weight * full_std,
                           _std_of(full * area.weight, weighted, area))
    negative = g_sigma < 0  # <s(r) s(r+dr)> of compressive stresses is never < 0
    checks = [(negative.any("dr"), "questionable",
               "G_sigma < 0 at some lags (set NaN): the stress ACF of a contact without "
               "adhesion cannot be negative: the Laplacian of G is negative there beyond "
               "what W[a_r] can weight (noisy or detrended G, or ringing of a sharp "
               "cutoff)")]
    g_sigma = g_sigma.where(~negative)
    tail = (f"G_sigma_full beyond its roll-off continued by dr^-{k.STEEP_DECAY:g}"
            if smooth_full else "G_sigma_full of eq. 24 as is")
    out = {}
    if "G_sigma" in run.wanted:
        out["G_sigma"] = g_sigma.assign_attrs(
            units="Pa2", long_name="stress autocorrelation function",
            equation=f"eq. 30/48 with W of eq. 49 ({run.theory}); {tail}")
        out["G_sigma_std"] = g_sigma_std.where(g_sigma.notnull()).assign_attrs(
            units="Pa2", long_name="statistical standard deviation of G_sigma",
            error_of=(ERROR_OF_SURFACE + " (the Laplacian of G through the smoothing "
                      "spline of ln G, and W through gbar; linearised)")
            if error_model(run.G) else ERROR_OF_NONE)
        out.update(_stress_model_errors(run, area, out["G_sigma"]))
    if "Gamma_sigma" in run.wanted:
        p_zero = run.p0 / (run.E * area.gbar0)
        a0 = k.contact_area(p_zero, run.kappa)
        if run.theory != "persson":
            a0 = k.improved_area(p_zero, a0)
        out["Gamma_sigma"] = (g_sigma / a0).assign_attrs(
            units="Pa2", long_name="reduced stress autocorrelation function",
            equation=f"eq. 47 ({run.theory}: divided by "
            f"{'a_r' if run.theory == 'persson' else 'a_ri'} at the smallest dr); {tail}")
    return out, checks, _derivative_checks(why, run.spec, window=False)


def _asymptote_vars(run: _PerssonRun, area: _ContactArea) -> dict[str, xr.DataArray]:
    """Return the small-pressure asymptotes of ``Gamma_sigma`` (eq. 51) asked for.

    ``H`` is G's own local exponent ``dln G / (2 dln dr)`` at each lag: no model.
    """
    hurst = _laplacian(run.G)[2]
    asymptotes = {
        "Gamma_sigma_sa": (k.asymptote_weight(run.theory, run.kappa),
                           f"small-p* limit of eq. 47-50 ({run.theory})"),
        "Gamma_sigma_51": (k.EQ51_PRINTED, "eq. 51 as printed, its c_sa read as "
                           "1 / c_sa(H) of xrough")}
    out = {}
    for name in [n for n in asymptotes if n in run.wanted]:
        w, what = asymptotes[name]
        out[name] = xr.apply_ufunc(
            k.stress_asymptote, run.dr_m, run.G_si, hurst, area.gbar0, dask="parallelized",
            output_dtypes=[float], keep_attrs=False,
            kwargs={"E_star": run.E, "weight": w}).expand_dims(
            p0=run.p0.sizes["p0"]).assign_attrs(
            units="Pa2", long_name="small-pressure asymptote of the reduced stress ACF",
            equation=f"eq. 51: w E*^2 H^2 gbar(0) sqrt(G / c_sa(H)) / dr, w = {w:.4g} "
            f"({what}); c_sa(H) = gbar^2 dr^2 / G; H = H(dr) = dln G / (2 dln dr), the "
            "local exponent of G; self-affine range, p* -> 0")
    return out


def _persson_dataset(run: _PerssonRun, out: dict, p0s, method: str) -> xr.Dataset:
    """Build the result Dataset on ``(p0, ..., dr)`` with its coords and attrs."""
    out = {name: v.transpose("p0", ..., "dr") for name, v in out.items()}
    coords = {**own_coords(run.G), **lag_coord(run.spec.dr, run.spec.unit_str),
              "p0": ("p0", np.atleast_1d(p0s), P0_ATTRS)}
    return xr.Dataset(out, coords=coords, attrs=result_attrs(
        run.G, E_star=run.E, E_star_units="Pa", kappa=run.kappa, theory=run.theory,
        gradient_method=method,
        note="real-space Persson theory: functions of q evaluated at dr = 2 pi / q; NaN "
        "where the rms gradient is not determined"))


# ---------------------------------------------------------------------------------------
# adhesion: patch radius (eq. 43-46)
# ---------------------------------------------------------------------------------------
@u.accepts_quantified
@own_attrs  # inside: it restores coords' units from the dequantified input
def patch_radius(G: xr.DataArray, *, E_star: QuantityLike, gamma: QuantityLike) -> xr.Dataset:
    r"""Radius of spontaneously adhering patches (Dahlquist-type criterion, eq. 43-46).

    - upper estimate (eq. 44): the smallest ``a_c`` with ``gamma = v_el(a_c)``;
    - refined (eq. 46): the patch grows while ``a_c^2 [v_el(a_c) - gamma]`` decreases:
      the smallest ``a_c`` with ``gamma = v_el(a_c) + E* G(a_c) / (8 a_c)``;

    with ``v_el(a_c) = (E*/4) int_0^{a_c} G(r)/r^2 dr``. Outside the lags of G the roots
    are those of G's continuation, in closed form (never a bound of the search):

    - below the first lag ``r0``, G is continued as ``G = a r^2 + b r^4`` (the even start
      of :func:`elastic_energy`), and the radii are the roots of cubics; for ``b = 0``
      (ballistic, ``G = G(r0) (r/r0)^2``) ``a_c = 8 gamma r0^2 / (3 E* G(r0))``,
      ``a_c_upper = 4 gamma r0^2 / (E* G(r0))`` (for ``G = gbar^2 dr^2 / 4``:
      ``32 gamma / (3 E* gbar^2)`` and ``16 gamma / (E* gbar^2)``);
    - beyond the last lag ``rL``, G is continued flat, ``v_el(a) = v_el - E* G(rL) / (4 a)``
      with ``v_el`` of full contact (eq. 16), and ``a_c = E* G(rL) / (8 (v_el - gamma))``,
      ``a_c_upper = E* G(rL) / (4 (v_el - gamma))``.

    Either rests on the continuation, not on data, and is flagged questionable
    (:mod:`xrough.quality`). When ``gamma`` is at least the energy of full contact
    ``v_el``, no finite radius solves the equation and the result is ``inf`` (the surfaces
    stick everywhere; ``attrs["quality_remarks"]`` says so, and the variable ``v_el`` gives
    the energy).

    Parameters
    ----------
    G : xarray.DataArray
        Height-difference ACF on ``dr``.
    E_star : float, str or Quantity
        Contact modulus (Pa for numbers), > 0.
    gamma : float, str or Quantity
        Work of adhesion per area (J m-2 for numbers), > 0.

    Returns
    -------
    xarray.Dataset
        ``a_c`` (eq. 46) and ``a_c_upper`` (eq. 44) in the unit of ``dr``, and ``v_el``
        (J m-2, eq. 16: the elastic energy of full contact per area, which ``gamma`` must
        stay below for a finite radius).

    Raises
    ------
    ValueError
        Non-positive ``E_star`` or ``gamma``; invalid G.

    Examples
    --------
    Ballistic G (``gbar = 1``): eq. 44 gives ``16 gamma / (E* gbar^2)``, eq. 46 two thirds
    of it.

    >>> import numpy as np, xarray as xr
    >>> dr = np.geomspace(1e-3, 1e3, 50)
    >>> G = xr.DataArray(dr**2 / 4, dims="dr", attrs={"units": "nm2"},
    ...                  coords={"dr": ("dr", dr, {"units": "nm"})})
    >>> pr = xrough.patch_radius(G, E_star="25 MPa", gamma="50 mJ/m^2")
    >>> print(f"{float(pr.a_c_upper):.2f} {float(pr.a_c):.2f} {pr.a_c.attrs['units']}")
    32.00 21.33 nm
    """
    E = u.positive_si(E_star, _PRESSURE, what="E_star")
    gam = u.positive_si(gamma, _ENERGY, what="gamma")
    rated, (G, spec) = G, read_acf(G)  # rated: G with its own verdict, for rate_result
    G_si, _ = acf_in_si(G, spec)
    res = _per_curve(k.patch_radius_curve, G_si, out={"k": 3}, dr=spec.dr * spec.to_m,
                     E_star=E, gamma=gam)
    v_full = res.isel(k=2)
    unit = spec.unit_str
    lags = spec.dr[spec.dr > 0]
    window = lag_window(G, spec.dr)
    share = xr.apply_ufunc(
        _share_below, G_si, res.isel(k=0), input_core_dims=[["dr"], []],
        vectorize=True, dask="parallelized", output_dtypes=[float], keep_attrs=False,
        kwargs={"dr": spec.dr * spec.to_m,
                "edge": _window_edge(window, lags) * spec.to_m})
    res = res.isel(k=slice(0, 2)) / spec.to_m
    a_c, upper = res.isel(k=0), res.isel(k=1)
    std = _patch_std(G, G_si, spec, E=E, gamma=gam)
    error_of = (ERROR_OF_SURFACE + " (propagated through the roots of eq. 44/46, "
                "linearised; NaN where a_c is inf)") if std is not None else ERROR_OF_NONE
    if std is None:
        std = xr.full_like(res, np.nan)
    ds = xr.Dataset(
        {"a_c": a_c.assign_attrs(
            units=unit, long_name="adhesive patch radius",
            equation="eq. 46: gamma = v_el(a_c) + E* G(a_c) / (8 a_c)"),
         "a_c_std": std.isel(k=0).assign_attrs(
            units=unit, long_name="statistical standard deviation of a_c",
            error_of=error_of),
         "a_c_upper": res.isel(k=1).assign_attrs(
            units=unit, long_name="adhesive patch radius, upper estimate",
            equation="eq. 44: gamma = v_el(a_c)"),
         "a_c_upper_std": std.isel(k=1).assign_attrs(
            units=unit, long_name="statistical standard deviation of a_c_upper",
            error_of=error_of),
         "v_el": v_full.assign_attrs(
            units="J m-2", long_name="elastic energy per area of full contact",
            equation="eq. 16 (a_c is inf where gamma >= v_el: the surfaces stick "
            "everywhere)"),
         "a_c_below_window": share.assign_attrs(
            units="1", long_name="share of v_el(a_c), the elastic energy that balances "
            "gamma at a_c (eq. 44/46; v_el where a_c is inf), from lags below "
            "reliable_dr_min, which the instrument does not resolve (without a window: "
            "below the first lag; 1 where a_c lies below the window)")},
        coords=own_coords(G),
        attrs=result_attrs(G, E_star=E, E_star_units="Pa", gamma=gam, gamma_units="J m-2"))
    finite = np.isfinite(a_c)
    ds = mark_gaps(ds, spec, what="patch_radius", depends=_GAP_PATCH, level=_past(upper, spec))
    return rate_result(ds, _patch_window(a_c, upper, share, window, spec) + [
        (np.isinf(a_c), "good",
         f"a_c = inf: gamma = {gam:.3g} J m-2 exceeds the elastic energy of full contact "
         f"v_el ({_span(v_full.where(np.isinf(a_c)))} J m-2, variable v_el), so no patch "
         "stops growing: adhesion closes the whole gap and the surfaces stick everywhere"),
        (finite & (upper > lags[-1]), "questionable",
         "a_c (or its upper estimate) lies beyond the largest lag of G: it is the root "
         "of G's flat continuation (in closed form), not of data: measure larger scales "
         "to confirm it"),
        (finite & (a_c < lags[0]), "questionable",
         "a_c lies below the smallest lag of G: it is the root of G's continuation "
         "there (a dr^2 + b dr^4, in closed form), not of data: measure finer scales to "
         "confirm it")], what="patch_radius", G=rated)


def _patch_std(G: xr.DataArray, G_si: xr.DataArray, spec: AcfSpec, *, E: float,
               gamma: float) -> xr.DataArray | None:
    """Give ``[a_c_std, a_c_upper_std]`` (dim ``k``, in G's length unit).

    None: G states no map geometry (a model or stitched G), so no statistical error.
    """
    model, factor = _error_inputs(G, G_si, spec)
    if not model:
        return None
    std = _per_curve(_patch_std_curve, G_si, factor, out={"k": 2},
                     dr=spec.dr * spec.to_m, E_star=E, gamma=gamma, **model)
    return std / spec.to_m


def _patch_std_curve(g, inflation, **kwargs):
    """:func:`~xrough._kernels.contact.patch_radius_std_curve` of one curve, its factor."""
    return k.patch_radius_std_curve(g, inflation=inflation, **kwargs)


def _share_below(g, a, *, dr, edge) -> float:
    """Share of ``int_0^a G / r^2 dr`` (eq. 44; ``a = inf``: eq. 16) from ``r < edge``.

    One curve, through :func:`xrough._kernels.contact.energy_curve`; NaN for a NaN ``a``.
    """
    a = float(a)
    if not a > 0:
        return np.nan
    cum = k.energy_curve(g, dr=dr, a_c=np.array([min(edge, a), a]))[3:]
    return float(cum[0] / cum[1]) if cum[1] > 0 else np.nan


def _patch_window(a_c: xr.DataArray, upper: xr.DataArray, share: xr.DataArray,
                  window: LagWindow, spec: AcfSpec) -> list:
    """Return the :func:`rate_result` checks of a patch radius against the window.

    A radius below ``reliable_dr_min`` is not resolved: failed (NaN), with the radius in
    the note. The share of ``v_el(a_c)`` from below the window is rated as that of
    :func:`elastic_energy` (:data:`BELOW_WINDOW`); a radius beyond ``reliable_dr_max``
    rests on lags the instrument does not resolve either: questionable.
    """
    if window.empty is not None or window.lo is None and window.hi is None:
        return [_no_lag(window)] if window.empty is not None else []
    unit = spec.unit_str
    checks = []
    if window.lo is not None:
        below = np.isfinite(a_c) & (a_c < window.lo)
        found = ""
        if a_c.chunks is None and bool(below.any()):
            found = f" (a_c = {_span(a_c.where(below))} {unit})"
        checks.append((below, "failed", (
            f"the patch radius{found} lies below reliable_dr_min = {window.lo:.4g} {unit}, "
            f"the smallest lag the instrument resolves ({window.said}): it is the root of "
            "G where the instrument shapes it (a tip that cannot follow the valleys "
            "lowers G, so the true radius is smaller still, not resolved by these data), "
            "so NaN: measure with a sharper tip or a finer lateral resolution")))
        checks += _window_share(share.where(~below), window, spec,
                                "the elastic energy v_el(a_c) that balances gamma",
                                "a_c_below_window")
    if window.hi is not None and window.hi < spec.dr[-1]:
        checks.append((np.isfinite(upper) & (upper > window.hi), "questionable", (
            f"a_c (or its upper estimate) lies beyond reliable_dr_max = {window.hi:.4g} "
            f"{unit}, the largest lag the instrument resolves ({window.said}): v_el(a_c) "
            "integrates G where it is not reliable: measure larger scans")))
    return checks
