"""Beyond the paper: the interfacial separation, stiffness and energy of partial contact.

The paper's conclusion leaves open "predictions on mean gaps as a function of load" and
"the scale-dependent elastic energy in partial contact". Persson's theory of the
separation (Persson 2007; Yang and Persson 2008) is a sum over wavenumbers of the
spectrum; in real space it becomes integrals over the scale-dependent rms gradient
``gbar(dr)`` of eq. 26 (computed from G), with the contact area of eq. 29 at each
resolution (:mod:`xrough._kernels.separation` for the derivation). The solver's exact
counterparts are the per-load ``mean_gap``, ``elastic_energy`` and ``stiffness`` of
:func:`xrough.solve_contact`.
"""

from __future__ import annotations

import functools

import numpy as np
import xarray as xr

from . import quality
from . import units as u
from ._kernels.contact import contact_area
from ._kernels.model_error import read_table
from ._kernels.separation import GAP_SHARES, gap_distribution_kernel, separation_kernel
from .acf import read_acf, result_attrs, strip_marks
from .contact import (
    acf_in_si,
    first_finite,
    gradient_on,
    own_attrs,
    own_coords,
    rate_result,
)
from .gradient import rms_gradient
from .units import QuantityLike

__all__ = ["mean_gap", "exact_interval", "GAMMA", "BEYOND_LAGS", "MODEL_ERROR_QUANTITIES"]

_PRESSURE = "[pressure]"
#: Persson's ``gamma`` (``S = gamma + (1 - gamma) P^2``), the value Almqvist et al. (2011)
#: and Yang and Persson (2008) found against simulations.
GAMMA = 0.42
#: Share of the mean gap from scales beyond the largest lag (``gbar`` continued there as
#: the roll-off's ``dr^-2``) above which the result is questionable.
BEYOND_LAGS = 0.1
#: The outputs with a model error from the solver study (``xrough/data/gap_error.csv``).
MODEL_ERROR_QUANTITIES = ("mean_gap", "stiffness", "elastic_energy")
#: z of the two-sided 90 % interval of a normal error (the statistical part).
_Z90 = 1.6448536269514722
_EQUATION = ("Persson's interfacial separation (PRL 99, 125502, 2007) in real space: "
             "u(p0) = sqrt(2)/(4 pi^1.5) int dmu J(p*)/gbar, dmu = dr (-d gbar^2/d dr) d(dr), "
             "p* = p0/(E* gbar(dr)) (eq. 26, 29)")

_DISTRIBUTION = ("P(u) = a_r(dr_1) delta(u) + int da_r(D) [N(u; u_D, h_D) + N(-u; u_D, h_D)]: "
                 "the area detaching at resolution D has the gap of the roughness finer "
                 "than D (mean u_D at p0/a_r(D), variance h_D^2 = int_0^D r^2/(4 pi^2) "
                 "(-d gbar^2/dr) dr); Almqvist et al., JMPS 59, 2355 (2011)")


@u.accepts_quantified
@own_attrs  # inside: it restores coords' units from the dequantified input
def mean_gap(G: xr.DataArray, *, E_star: QuantityLike, p0: QuantityLike,
             gamma: float = GAMMA, gradient: xr.DataArray | None = None,
             gradient_method: str = "auto", fit: xr.Dataset | None = None) -> xr.Dataset:
    r"""Mean gap, contact stiffness and elastic energy of partial contact against load.

    Persson's theory of the interfacial separation with the sums over wavenumbers turned
    into integrals over resolution ``dr``: with ``gbar(dr)`` of eq. 26, the measure
    ``dmu = dr (-d gbar^2 / d dr) d(dr)`` and the contact area ``P = erf(sqrt(2) p*)`` of
    eq. 29 at each resolution, ``p* = p0 / (E* gbar(dr))``:

    .. math::

        U(p_0) &= \frac{E^*}{8\pi}\int d\mu\, P\,[\gamma + (1-\gamma)P^2] \\
        \bar u(p_0) &= \int_{p_0}^\infty \frac{dp}{p}\frac{dU}{dp}
            = \frac{\sqrt 2}{4\pi^{3/2}} \int d\mu\, \frac{J(p^*)}{\bar g} \\
        K(p_0) &= -\frac{dp_0}{d\bar u} = p_0 \Big/ \frac{dU}{dp_0}

    with ``J(s) = int_s^inf dt/t [gamma + 3 (1 - gamma) erf^2(sqrt(2) t)] exp(-2 t^2)``
    (eq. 16 in full contact); beside it eq. 34 in eq. 16, ``U_34 = E*/4 int G a_r / dr^2``.
    Gap distribution: Almqvist et al. (2011). Notes: docs/contact.md, "Beyond the paper".

    Parameters
    ----------
    G : xarray.DataArray
        Height-difference ACF on ``dr`` (extra dims allowed).
    E_star : float, str or Quantity
        Contact modulus (Pa for numbers), > 0.
    p0 : float, str, Quantity or array
        Mean pressure(s), > 0; several give a ``p0`` dim.
    gamma : float
        Persson's ``gamma``, in (0, 1].
    gradient : xarray.DataArray, optional
        ``gbar(dr)`` of :func:`xrough.rms_gradient` on G's lags; computed once otherwise.
    gradient_method : {'auto', 'exact', 'simple', 'fit'}
        See :func:`xrough.rms_gradient`.
    fit : xarray.Dataset, optional
        A :func:`xrough.fit_acf` of G for the gradient's ``'auto'`` and ``'fit'`` routes.

    Returns
    -------
    xarray.Dataset
        On ``p0`` (and G's extra dims): ``mean_gap`` (G's length unit), ``stiffness``
        (Pa per length unit), ``elastic_energy`` and ``elastic_energy_34`` (J m-2), their
        errors ``*_std``, ``gap_quantiles`` on ``area_share`` (as the solver's) and
        ``gap_beyond_lags`` (share of the gap from beyond the largest lag; questionable
        above :data:`BEYOND_LAGS`). Attrs ``equation``, ``gamma``, ``E_star``, quality.

    Raises
    ------
    ValueError
        Non-positive ``E_star`` or ``p0``, ``gamma`` outside (0, 1], an invalid G.

    Examples
    --------
    >>> C = xrough.model_spectrum(hurst=0.8, lambda_r="64 nm", lambda_s="2 nm",
    ...                           rms_gradient=0.1, unit="nm")
    >>> G = xrough.acf_from_spectrum(C, dr_min="0.1 nm", dr_max="100 um")
    >>> ds = G.rough.mean_gap(E_star="1 MPa", p0=["1 kPa", "10 kPa"])
    >>> ds.mean_gap.attrs["units"], ds.stiffness.attrs["units"]
    ('nm', 'Pa nm-1')
    >>> bool(ds.mean_gap[0] > ds.mean_gap[1] > 0)  # the gap closes under load
    True
    """
    E = u.positive_si(E_star, _PRESSURE, what="E_star")
    p0s = u.positive_si(p0, _PRESSURE, what="p0", many=True)
    if not (isinstance(gamma, (int, float, np.floating)) and 0 < gamma <= 1):
        raise ValueError(f"gamma must be in (0, 1], got {gamma!r}")
    rated, (G, spec) = G, read_acf(G)
    G = G.transpose(..., "dr")
    if gradient is None:
        with quality.quiet():  # its notes are this result's: one warning
            gradient = rms_gradient(rated, method=gradient_method,
                                    fit=fit if gradient_method in ("auto", "fit") else None)
    gbar = gradient_on(gradient, G, spec)
    rel = (strip_marks(gradient["gbar_std"] / gradient).fillna(0.0)
           if "gbar_std" in gradient.coords else xr.zeros_like(gbar))
    rel = gradient_on(rel.assign_coords(dr=gradient["dr"]), G, spec)
    loads = xr.DataArray(np.atleast_1d(p0s), dims="p0")
    dr_m = spec.dr * spec.to_m

    def run(g: xr.DataArray) -> xr.DataArray:
        return xr.apply_ufunc(
            separation_kernel, g, input_core_dims=[["dr"]],
            output_core_dims=[["p0", "part"]], dask="parallelized", output_dtypes=[float],
            dask_gufunc_kwargs={"output_sizes": {"p0": loads.size, "part": 4}},
            kwargs={"dr": dr_m, "p0": loads.values, "E": E, "gamma": float(gamma)})

    # one relative error common to all lags, log-normal (gbar_std may exceed gbar)
    base, up, down = (run(g) for g in (gbar, gbar * np.exp(rel), gbar * np.exp(-rel)))
    to_unit = 1.0 / spec.to_m

    def part(res, k):
        return res.isel(part=k, drop=True)

    def half(k):
        return 0.5 * abs(part(up, k) - part(down, k))

    gap, energy, dudp = part(base, 0), part(base, 1), part(base, 2)
    stiffness = loads / dudp
    stiffness_std = abs(loads / part(up, 2) - loads / part(down, 2)) / 2
    quantiles = xr.apply_ufunc(
        gap_distribution_kernel, gbar, input_core_dims=[["dr"]],
        output_core_dims=[["p0", "area_share"]], dask="parallelized", output_dtypes=[float],
        dask_gufunc_kwargs={"output_sizes": {"p0": loads.size, "area_share": GAP_SHARES.size}},
        kwargs={"dr": dr_m, "p0": loads.values, "E": E, "gamma": float(gamma)})
    G_si, _ = acf_in_si(G, spec)
    v34 = _energy_34(G_si, gbar, dr_m, loads, E)
    unit = spec.unit_str
    ds = xr.Dataset(
        {
            "mean_gap": (gap * to_unit).assign_attrs(
                units=unit, long_name="mean gap (interfacial separation)",
                equation=_EQUATION),
            "mean_gap_std": (half(0) * to_unit).assign_attrs(
                units=unit, long_name="statistical standard deviation of mean_gap"),
            "stiffness": (stiffness * spec.to_m).assign_attrs(
                units=f"Pa {unit}-1",
                long_name="normal contact stiffness per area, -dp0/d(mean gap)"),
            "stiffness_std": (stiffness_std * spec.to_m).assign_attrs(
                units=f"Pa {unit}-1", long_name="statistical standard deviation of "
                                               "stiffness"),
            "elastic_energy": energy.assign_attrs(
                units="J m-2", long_name="elastic energy per area at load p0 (Persson, "
                "Yang: E*/(8 pi) int dmu P [gamma + (1 - gamma) P^2])"),
            "elastic_energy_std": half(1).assign_attrs(
                units="J m-2", long_name="statistical standard deviation of "
                                         "elastic_energy"),
            "elastic_energy_34": v34.assign_attrs(
                units="J m-2", long_name="elastic energy per area at load p0 from eq. 34 "
                "(G_du = G a_r) in eq. 16: E*/4 int G a_r / dr^2"),
            "gap_quantiles": (quantiles * to_unit).assign_attrs(
                units=unit, long_name="gap below which the share area_share of the nominal "
                "area lies (Almqvist et al. 2011 in real space)", equation=_DISTRIBUTION),
            "gap_beyond_lags": part(base, 3).assign_attrs(
                units="1", long_name="share of mean_gap from scales beyond the largest lag "
                "(gbar continued as dr^-2)"),
        },
        coords={**own_coords(G), "p0": ("p0", loads.values),
                "area_share": ("area_share", GAP_SHARES, {
            "units": "1", "long_name": "share of the nominal area"})},
        attrs=result_attrs(G, E_star=E, E_star_units="Pa", gamma=float(gamma),
                           equation=_EQUATION, theory="persson 2007 separation, real space"),
    )
    ds = _with_model_error(ds, gbar)
    if np.ndim(p0s) == 0:
        ds = ds.isel(p0=0)
    beyond = ds["gap_beyond_lags"] > BEYOND_LAGS
    result = rate_result(ds, [(beyond, "questionable",
                         f"more than {BEYOND_LAGS:.0%} of the mean gap comes from scales "
                         "beyond the largest lag of G (gbar continued there as the "
                         "roll-off's dr^-2): at such small loads the gap is set by the "
                         "largest asperities; measure larger scales")],
                         what="mean_gap", G=rated, inherited=(gradient,))
    return result  # own_attrs puts back the coords' attrs xarray dropped (p0's too)


def _energy_34(G_si: xr.DataArray, gbar: xr.DataArray, dr_m: np.ndarray,
               loads: xr.DataArray, E: float) -> xr.DataArray:
    """``E*/4 int G a_r / dr^2``: eq. 34's ``G_du = G a_r`` in eq. 16 (J m-2).

    Trapezoid in ``ln dr`` over the lags; below the first lag G is ballistic (``G/dr``
    at the first lag, times its ``a_r``), beyond the last it is flat (``G/dr`` there, in
    full contact).
    """
    positive = dr_m > 0
    g = G_si.isel(dr=positive)
    gb = gbar.isel(dr=positive)
    r = xr.DataArray(dr_m[positive], dims="dr")
    area = xr.apply_ufunc(contact_area, loads / (E * gb), dask="allowed")  # eq. 29
    f = g * area / r
    ends = f.isel(dr=0) + (g / r).isel(dr=-1)
    return E / 4 * (_trapezoid(f, np.log(dr_m[positive])) + ends)


def _trapezoid(f: xr.DataArray, x: np.ndarray) -> xr.DataArray:
    """Trapezoid of ``f`` over ``x`` along ``dr`` (lazy where ``f`` is)."""
    w = np.zeros_like(x)
    w[1:] += 0.5 * np.diff(x)
    w[:-1] += 0.5 * np.diff(x)
    return (f * xr.DataArray(w, dims="dr")).sum("dr")


@functools.lru_cache(maxsize=1)
def _model_error_table() -> dict[str, tuple[np.ndarray, ...]]:
    """Per quantity: ``(log10 p*, median, 5 %, 95 %)`` of ``ln(exact / theory)``."""
    t = read_table("gap_error.csv")
    out = {}
    for q in MODEL_ERROR_QUANTITIES:
        rows = t["quantity"] == q
        order = np.argsort(t["p_star"][rows])
        out[q] = tuple(np.asarray(x, dtype=float)[rows][order] if i else
                       np.log10(np.asarray(x, dtype=float)[rows][order])
                       for i, x in enumerate((t["p_star"], t["median"], t["lower"],
                                              t["upper"])))
    return out


def exact_interval(value, std, p_star, quantity: str) -> tuple:
    """Give the expected exact value and its 90 % interval for a theory ``value``.

    From the solver study (``benchmarks/gap_study.py``, ``xrough/data/gap_error.csv``):
    the 5, 50 and 95 % quantiles of ``ln(exact / theory)`` at ``p*`` (``p0 / (E* gbar)``
    at the finest lag), interpolated in ``log10 p*``, NaN outside the study's range. The
    statistical standard deviation ``std`` widens the interval in quadrature in
    ``ln``, 1.645 of ``std / value`` on each side, so it stays positive.

    Parameters
    ----------
    value, std : array_like or xarray.DataArray
        The theory's value of ``quantity`` (:func:`mean_gap`) and its statistical standard
        deviation, in any one unit (the result is in it).
    p_star : xarray.DataArray
        The reduced pressure ``p0 / (E* gbar)`` at the finest lag (dimensionless).
    quantity : {'mean_gap', 'stiffness', 'elastic_energy'}
        Which study table.

    Returns
    -------
    tuple
        ``(exact, lower, upper)``, in the unit of ``value``.

    Examples
    --------
    >>> import xarray as xr
    >>> exact, lower, upper = exact_interval(1.0, 0.0, xr.DataArray(0.01), "mean_gap")
    >>> bool(lower < exact < upper)  # the theory overestimates the gap at p* = 0.01
    True
    """
    x, med, lo, hi = _model_error_table()[quantity]

    def at(values):
        return xr.apply_ufunc(lambda v: np.interp(np.log10(v), x, values, left=np.nan,
                                                  right=np.nan),
                              p_star, dask="parallelized", output_dtypes=[float])

    with np.errstate(divide="ignore", invalid="ignore"):
        rel = _Z90 * abs(std / value)
    centre = value * np.exp(at(med))
    lower = centre * np.exp(-np.hypot(at(med) - at(lo), rel))
    upper = centre * np.exp(np.hypot(at(hi) - at(med), rel))
    return centre, lower, upper


def _with_model_error(ds: xr.Dataset, gbar: xr.DataArray) -> xr.Dataset:
    """Add ``<q>_exact`` and its 90 % interval ``<q>_exact_lower`` / ``_upper``.

    :func:`exact_interval` at ``p*`` of the finest lag with a ``gbar`` (NaN below a tip's
    window), the study's definition.
    """
    E = float(ds.attrs["E_star"])
    first = xr.apply_ufunc(first_finite, gbar, input_core_dims=[["dr"]],
                           dask="parallelized", output_dtypes=[float])
    p_star = ds["p0"] / (E * first)
    for q in MODEL_ERROR_QUANTITIES:
        value = ds[q]
        centre, lower, upper = exact_interval(value, ds[f"{q}_std"], p_star, q)
        units = value.attrs["units"]
        name = value.attrs["long_name"].split(",")[0]
        ds[f"{q}_exact"] = centre.assign_attrs(
            units=units, long_name=f"expected exact {name} (theory corrected by the "
            "solver study's median)")
        ds[f"{q}_exact_lower"] = lower.assign_attrs(
            units=units, long_name=f"lower end of the 90 % interval of the exact {name}")
        ds[f"{q}_exact_upper"] = upper.assign_attrs(
            units=units, long_name=f"upper end of the 90 % interval of the exact {name}")
    return ds
