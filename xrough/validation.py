r"""Validation of the contact theories against the reference boundary-element solver.

:func:`compare_with_simulation` solves the contact of one map at several mean pressures
(:func:`xrough.solve_contact`), measures the stress ACF and the relative contact area of
each pressure field, and sets them beside the predictions made from the map's
height-difference ACF ``G`` alone: eq. 24 in full contact and real-space Persson theory
(eq. 29, 30/48-50) in partial contact, with error measures per load.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from . import quality
from . import units as u
from ._kernels.contact import KAPPA_PERSSON, contact_area, improved_area
from ._kernels.deferred import special
from ._kernels.solver import ElasticOperator, full_contact_stress
from .contact import THEORIES, persson, stress_acf
from .correlation import height_difference_acf
from .fitting import fit_acf
from .gradient import rms_gradient
from .solver import check_topography, solve_contact
from .units import QuantityLike

__all__ = ["compare_with_simulation", "fit_kappa", "VALIDATION_THEORIES"]

#: The paper's two theories (Persson's kappa) and the original theory with the kappa
#: fitted to the simulation (or given), named as such.
VALIDATION_THEORIES = (*THEORIES, "persson_kappa")

#: Full-contact load: this factor times the smallest load that closes every gap.
FULL_CONTACT_MARGIN = 1.05


def fit_kappa(contact_area: float, p_star: float) -> float:
    r"""Slope ``kappa`` of eq. 29 that reproduces one measured contact area.

    Inverts ``a = erf(sqrt(pi) kappa p* / 2)``:
    ``kappa = 2 erfinv(a) / (sqrt(pi) p*)``, which is ``a / p*`` to leading order in
    ``p*`` (the two differ by 0.1 % at ``a = 0.05`` and 1 % at ``a = 0.15``).

    Parameters
    ----------
    contact_area : float
        Relative contact area, ``0 < a < 1``.
    p_star : float
        Reduced pressure ``p0 / (E* gbar(0))``, > 0.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        ``a`` outside ``(0, 1)`` or ``p* <= 0``.

    Examples
    --------
    >>> round(fit_kappa(0.02, 0.01), 3)
    2.0
    """
    if not (0 < contact_area < 1):
        raise ValueError(f"the contact area must lie strictly between 0 and 1 to fit kappa, "
                         f"got {contact_area!r}: choose a smaller (but non-zero) load")
    if not (np.isfinite(p_star) and p_star > 0):
        raise ValueError(f"p_star must be positive, got {p_star!r}")
    return float(2 * special.erfinv(contact_area) / (np.sqrt(np.pi) * p_star))


def _theories(theory) -> tuple[str, ...]:
    names = (theory,) if isinstance(theory, str) else tuple(theory)
    bad = [t for t in names if t not in VALIDATION_THEORIES]
    if bad or not names or len(set(names)) != len(names):
        raise ValueError(f"theory must be one or several distinct of "
                         f"{VALIDATION_THEORIES}, got {theory!r}")
    return names


def _full_contact_load(h_lat: np.ndarray, spacing, periodic: bool, E: float, gbar0: float):
    """Mean pressure just beyond full contact (Pa)."""
    if not periodic:  # no exact threshold in free space: a generous multiple
        return 4.0 * E * gbar0
    inverse = full_contact_stress(h_lat, ElasticOperator(h_lat.shape, spacing,
                                                           periodic=True))
    assert inverse is not None  # a periodic grid has one
    stress = inverse * E
    return FULL_CONTACT_MARGIN * float(max(-stress.min(), 1e-3 * E * gbar0))


def _gbar0(h_lat: np.ndarray, spacing, periodic: bool, gbar: xr.DataArray) -> float:
    """Return the map's rms gradient: spectral if periodic, else the largest gbar(dr)."""
    if not periodic:
        return float(np.nanmax(gbar.values))
    ny, nx = h_lat.shape
    qy = 2 * np.pi * np.fft.fftfreq(ny, spacing[0])
    qx = 2 * np.pi * np.fft.fftfreq(nx, spacing[1])
    q2 = qy[:, None] ** 2 + qx[None, :] ** 2
    return float(np.sqrt((q2 * np.abs(np.fft.fft2(h_lat)) ** 2).sum()) / (nx * ny))


def _simulated_stress_acf(pressure: xr.DataArray, lunit: str, periodic: bool,
                          acf_kwargs: dict) -> xr.DataArray:
    """``<p(r) p(r + dr)>`` per load from the pressure field's own G (Pa^2)."""
    field = pressure.copy()
    field.attrs = {"units": "m", "periodic": int(periodic)}  # Pa stored as "m"
    with quality.quiet():  # a tool for the stress ACF: its own verdicts are not the user's
        G_p = height_difference_acf(field, progress=False, **acf_kwargs)
    to_pa2 = u.conversion_factor(G_p.attrs["units"], "m2")
    mean_sq = (pressure**2).mean(("y", "x"))
    return mean_sq - G_p * to_pa2


def _on_lags(da: xr.DataArray, dr: np.ndarray) -> xr.DataArray:
    keep = np.flatnonzero(np.isin(np.round(da["dr"].values, 12), np.round(dr, 12)))
    return da.isel(dr=keep)


def _errors(diff: xr.DataArray, scale: xr.DataArray | float, sel: np.ndarray):
    rel = abs(diff.isel(dr=np.flatnonzero(sel))) / scale
    return rel.max("dr", skipna=True), np.sqrt((rel**2).mean("dr", skipna=True))


@u.accepts_quantified
def compare_with_simulation(
    topography: xr.DataArray,
    *,
    E_star: QuantityLike,
    p0: QuantityLike,
    theory: str | tuple[str, ...] = VALIDATION_THEORIES,
    kappa: float | None = None,
    full_contact: bool = True,
    smooth_full: bool = True,
    error_range: tuple[Any, Any] | None = None,
    gradient_method: str = "auto",
    acf_kwargs: dict | None = None,
    keep_pressure: bool = False,
    tol: float = 1e-8,
    max_iter: int = 10_000,
    workers: int | None = None,
) -> xr.Dataset:
    r"""Compare simulated and predicted contact: stress ACF and contact area on (p0, dr).

    Solves the map (:func:`xrough.solve_contact`) at every ``p0`` and beyond full contact
    and sets the stress ACF ``<p^2> - G_p(dr)`` and area of each field beside eq. 24,
    :func:`xrough.persson` (eq. 30/47/48, 51) and eq. 29/50 from G. Notes (steps, theories,
    ``kappa`` fit, errors): docs/validation.md, "The steps of the comparison".

    Parameters
    ----------
    topography : xarray.DataArray with dims ("y", "x")
        Complete map (no NaN), preferably periodic (``attrs["periodic"]``).
    E_star : float, str or Quantity
        Contact modulus ``E*`` (Pa for numbers), > 0.
    p0 : float, str, Quantity or sequence of them
        Mean pressures of partial contact (Pa for numbers), > 0.
    theory : str or tuple of str
        Any of ``"persson"`` (``W = a_r``), ``"modified"`` (``a_ri^2 / a_r``, eq. 49-50),
        ``"modified_ar2"`` (``a_r^2 / a_ri``), ``"persson_kappa"`` (``kappa`` of eq. 29).
    kappa : float, optional
        Slope of eq. 29 for ``"persson_kappa"``; ``None`` fits it at the smallest load.
    full_contact, keep_pressure : bool
        Also solve just beyond full contact (eq. 24); keep the fields ``pressure``.
    smooth_full : bool
        Continue ``G_sigma_full`` beyond its roll-off by a steep power law (the paper's).
    error_range : pair of float, str or Quantity, optional
        Lags of the stress errors (lateral unit); default 2 pixels to 1/8 of the map.
    gradient_method : {'auto', 'exact', 'simple', 'fit'}
        How ``gbar(dr)`` is computed (see :func:`xrough.rms_gradient`).
    acf_kwargs : dict, optional
        For :func:`xrough.height_difference_acf` of ``G`` and ``G_p`` (default: 10/decade).
    tol, max_iter, workers
        Passed to :func:`xrough.solve_contact`.

    Returns
    -------
    xarray.Dataset
        On ``p0`` (Pa), ``dr`` (lateral unit), ``theory``: simulated and predicted areas,
        ``area_error``, ``G_sigma_sim``, ``G_sigma`` (Pa^2), ``Gamma_sigma*``,
        ``stress_error*``, full-contact variables, ``iterations`` (docs/validation.md).

    Raises
    ------
    ValueError
        Non-positive ``E_star``, ``p0`` or ``kappa``, an unknown theory, an invalid map, or
        a zero (or full) simulated area at the smallest load when ``kappa`` is fitted.

    Examples
    --------
    >>> topo = xrough.self_affine_surface(hurst=0.8, lambda_r=64, lambda_s=4, size=128,
    ...                                   n=128, rms_gradient=0.1, seed=3, unit="nm",
    ...                                   rolloff="smooth")
    >>> cmp = compare_with_simulation(topo, E_star="1 MPa", p0=[2e3, 1e4])
    >>> cmp.G_sigma.dims, cmp.G_sigma.attrs["units"], cmp.contact_area.attrs["units"]
    (('theory', 'p0', 'dr'), 'Pa2', '1')
    >>> cmp.theory.values.tolist()
    ['persson', 'modified', 'modified_ar2', 'persson_kappa']
    >>> 1.0 < cmp.attrs["kappa"] < 3.5, float(cmp.full_contact_area)
    (True, 1.0)
    """
    names = _theories(theory)
    E = u.positive_si(E_star, "[pressure]", what="E_star")
    p0s = np.sort(np.atleast_1d(u.positive_si(p0, "[pressure]", what="p0", many=True)))
    if kappa is not None and not (np.isfinite(kappa) and kappa > 0):
        raise ValueError(f"kappa must be positive, got {kappa!r}")
    grid, h = check_topography(topography)
    acf_kwargs = {"points_per_decade": 10, **(acf_kwargs or {})}
    rough = _roughness(topography, h, grid, gradient_method, acf_kwargs)
    p_star = p0s / (E * rough.gbar0)
    sim = _simulate(topography, h, grid, E, rough, p0s, full_contact, acf_kwargs,
                    {"tol": tol, "max_iter": max_iter, "workers": workers})
    kappa_used, fitted = _kappa(kappa, names, sim.area[0], p_star[0])
    lo, hi, sel = _error_lags(rough.G["dr"].values, grid, error_range)
    pred = _predictions(rough, E, p0s, names, kappa_used, smooth_full)
    coords: dict[str, Any] = {"theory": ("theory", np.array(names, dtype=object),
                         {"long_name": "theory of partial contact (see attrs)"}),
              "p0": ("p0", p0s, {"units": "Pa", "long_name": "mean pressure"}),
              "dr": ("dr", rough.G["dr"].values, {"units": grid.lateral_unit,
                                                  "long_name": "lag distance"})}
    err_attrs = {"units": "1", "error_dr_min": float(lo), "error_dr_max": float(hi)}
    areas = _area_vars(p_star, kappa_used, fitted, sim, names)
    stress, coverage = _stress_vars(pred, sim, coords, sel, err_attrs)
    out = {**areas, **stress}
    if full_contact:
        out.update(_full_contact_vars(rough.G, E, sim, sel, err_attrs))
    if keep_pressure:
        out["pressure"] = (("p0", "y", "x"), sim.pressure[:sim.n], {
            "units": "Pa", "long_name": "simulated contact pressure"})
        coords.update(y=topography["y"], x=topography["x"])
    ds = xr.Dataset(out, coords=coords)
    ds.attrs = _attrs(E, kappa, kappa_used, fitted, rough, gradient_method, (lo, hi),
                      grid, names)
    return _mark_coverage(ds, coverage, names)


@dataclass(frozen=True)
class _Roughness:
    """The map's ``G``, its fit, the rms gradient ``gbar(dr)`` and ``gbar(0)``."""

    G: xr.DataArray
    fit: Any
    gbar: xr.DataArray
    gbar0: float


def _roughness(topography: xr.DataArray, h: np.ndarray, grid, gradient_method: str,
               acf_kwargs: dict) -> _Roughness:
    """Return ``G`` of the map, its fit (for the gradient and eq. 51), ``gbar`` and ``gbar(0)``."""
    G = height_difference_acf(topography, progress=False, **acf_kwargs)
    # a synthetic map states its cutoff's shape: the fit knows it, as one of the instrument
    known = (topography.attrs.get("cutoff") if topography.attrs.get("model") == "self-affine"
             else None)
    fit = fit_acf(G, cutoff=known)
    gbar = rms_gradient(G, method=gradient_method,
                        fit=fit if gradient_method in ("auto", "fit") else None)
    to_lat = u.conversion_factor(grid.height_unit, grid.lateral_unit)
    return _Roughness(G, fit, gbar, _gbar0(h * to_lat, grid.spacing, grid.periodic, gbar))


@dataclass(frozen=True)
class _Simulation:
    """The solver's fields at the ``n`` loads (and the full-contact one after them).

    ``stress_acf`` is the simulated stress ACF on the lags of ``G`` (load index, dr).
    """

    n: int
    pressure: np.ndarray
    area: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    stress_acf: xr.DataArray
    p_full: float | None


def _simulate(topography: xr.DataArray, h: np.ndarray, grid, E: float, rough: _Roughness,
              p0s: np.ndarray, full_contact: bool, acf_kwargs: dict,
              solver_kwargs: dict) -> _Simulation:
    """Solve at every load (and just beyond full contact) and measure the stress ACF."""
    loads = list(p0s)
    p_full = None
    if full_contact:
        to_lat = u.conversion_factor(grid.height_unit, grid.lateral_unit)
        p_full = _full_contact_load(h * to_lat, grid.spacing, grid.periodic, E,
                                    rough.gbar0)
        loads.append(max(p_full, 1.01 * p0s[-1]))
        p_full = loads[-1]
    sim = solve_contact(topography.transpose("y", "x"), E_star=E, p0=loads,
                        progress=False, **solver_kwargs)
    pressure = sim["pressure"].assign_coords(p0=np.arange(len(loads)))
    S_sim = _simulated_stress_acf(pressure, grid.lateral_unit, grid.periodic, acf_kwargs)
    S_sim = _on_lags(S_sim, rough.G["dr"].values).assign_coords(dr=rough.G["dr"])
    return _Simulation(len(p0s), sim["pressure"].values, sim["contact_area"].values,
                       sim["iterations"].values, sim["converged"].values, S_sim, p_full)


def _kappa(kappa: float | None, names: tuple[str, ...], area: float,
           p_star: float) -> tuple[float, int]:
    """Return ``kappa`` of ``"persson_kappa"`` and 1 if fitted at the smallest load, else 0."""
    if kappa is None and ("persson_kappa" in names or 0 < area < 1):
        return fit_kappa(float(area), float(p_star)), 1
    if kappa is None:  # not asked for, and not measurable at this load
        return np.nan, 0
    return float(kappa), 0


def _error_lags(dr: np.ndarray, grid, error_range) -> tuple[float, float, np.ndarray]:
    """Return the error range ``lo, hi`` (lateral unit) and the mask of the lags in it."""
    lunit = grid.lateral_unit
    if error_range is None:
        lo, hi = 2 * max(grid.spacing), min(grid.size) / 8
    else:
        lo, hi = (u.length_in(v, lunit, what="error_range") for v in error_range)
    sel = (dr >= lo * (1 - 1e-9)) & (dr <= hi * (1 + 1e-9))
    if not sel.any():
        raise ValueError(f"no lag of G lies in error_range [{lo:g}, {hi:g}] {lunit}")
    return lo, hi, sel


#: Predicted variables of :func:`xrough.persson` compared per theory.
_PREDICTED = ("G_sigma", "Gamma_sigma", "Gamma_sigma_sa")


def _predictions(rough: _Roughness, E: float, p0s: np.ndarray, names: tuple[str, ...],
                 kappa_used: float, smooth_full: bool) -> dict:
    """Return the predictions on (theory, p0, dr) and eq. 51 as printed on (p0, dr).

    Keys: the names of ``_PREDICTED`` and ``"Gamma_sigma_51"`` (the same for every
    theory). Each warning of :func:`xrough.persson` is issued once, not once per theory.
    """
    G, dr = rough.G, rough.G["dr"].values
    predicted: dict[str, list[np.ndarray]] = {v: [] for v in _PREDICTED}
    printed = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for name in names:
            ds = persson(G, E_star=E, p0=p0s, theory=name.removesuffix("_kappa"),
                         kappa=kappa_used if name == "persson_kappa" else KAPPA_PERSSON,
                         gradient=rough.gbar, fit=rough.fit, smooth_full=smooth_full,
                         variables=_PREDICTED + (() if printed is not None else
                                                 ("Gamma_sigma_51",)))
            if ds.sizes.get("p0") is None:
                ds = ds.expand_dims("p0")
            ds = ds.reindex(dr=dr, method="nearest", tolerance=1e-9 * dr[-1])
            for v in _PREDICTED:  # NaN off gbar's lags
                predicted[v].append(ds[v].transpose("p0", "dr").values)
            if printed is None:
                printed = ds["Gamma_sigma_51"].transpose("p0", "dr").values
    for message in dict.fromkeys((w.category, str(w.message)) for w in caught):
        quality.warn(message[1], message[0])
    return {**{v: np.stack(predicted[v]) for v in _PREDICTED}, "Gamma_sigma_51": printed}


#: Source attribute of the simulated variables.
_SIM_SOURCE = "from the boundary-element solution (xrough.solve_contact)"


def _area_vars(p_star: np.ndarray, kappa_used: float, fitted: int, sim: _Simulation,
               names: tuple[str, ...]) -> dict:
    """Return the reduced pressure, the simulated and predicted areas and their errors."""
    n = sim.n
    a_r = contact_area(p_star, KAPPA_PERSSON)
    a_r_kappa = contact_area(p_star, kappa_used)
    a_ri = improved_area(p_star, a_r)
    areas = {"persson": a_r, "modified": a_ri, "modified_ar2": a_ri,
             "persson_kappa": a_r_kappa}
    area_th = np.stack([areas[name] for name in names])
    with np.errstate(divide="ignore", invalid="ignore"):
        area_err = area_th / sim.area[None, :n] - 1
    return {
        "p_star": (("p0",), p_star, {"units": "1", "long_name":
                                     "reduced pressure p0 / (E* gbar(0))"}),
        "contact_area": (("p0",), sim.area[:n], {
            "units": "1", "long_name": "simulated relative contact area",
            "source": _SIM_SOURCE}),
        "a_r": (("p0",), a_r, {"units": "1", "long_name": "Persson's relative contact area",
                               "equation": "eq. 29: erf(sqrt(2) p*), kappa = sqrt(8/pi)",
                               "kappa": KAPPA_PERSSON}),
        "a_r_kappa": (("p0",), a_r_kappa, {
            "units": "1", "long_name": "relative contact area with the fitted kappa"
            if fitted else "relative contact area with the given kappa",
            "equation": "eq. 29: erf(sqrt(pi) kappa p* / 2)", "kappa": kappa_used}),
        "a_ri": (("p0",), a_ri, {"units": "1", "long_name":
                                 "improved relative contact area",
                                 "equation": "eq. 50 with Persson's a_r"}),
        "area_error": (("theory", "p0"), area_err, {
            "units": "1", "long_name": "relative error of the predicted contact area",
            "definition": "a_theory / a_sim - 1, a_theory = a_r (persson), a_ri "
            "(modified, modified_ar2) or a_r_kappa (persson_kappa)"}),
    }


def _stress_vars(pred: dict, sim: _Simulation, coords: dict, sel: np.ndarray,
                 err_attrs: dict) -> tuple[dict, np.ndarray]:
    """Return the simulated and predicted stress ACFs, their errors, and the coverage."""
    n = sim.n
    S_part = sim.stress_acf.isel(p0=slice(0, n)).values
    g_th = pred["G_sigma"]
    G_sigma = xr.DataArray(g_th, dims=("theory", "p0", "dr"), coords=coords)
    mean_sq = (sim.pressure[:n] ** 2).mean(axis=(1, 2))  # G_sigma_sim(0)
    err_max, err_rms = _errors(G_sigma - S_part, mean_sq[None, :, None], sel)
    coverage = np.isfinite(g_th[..., sel]).mean(axis=-1)
    return {
        "G_sigma_sim": (("p0", "dr"), S_part, {
            "units": "Pa2", "long_name": "simulated stress autocorrelation function",
            "definition": "<p^2> - G_p(dr), G_p the height-difference ACF of the pressure",
            "source": _SIM_SOURCE}),
        "G_sigma": (("theory", "p0", "dr"), g_th, {
            "units": "Pa2", "long_name": "predicted stress autocorrelation function",
            "equation": "eq. 30/48 with W of eq. 49"}),
        "Gamma_sigma_sim": (("p0", "dr"), S_part / sim.area[:n, None], {
            "units": "Pa2", "long_name": "simulated reduced stress ACF",
            "definition": "G_sigma_sim / contact_area"}),
        "Gamma_sigma": (("theory", "p0", "dr"), pred["Gamma_sigma"], {
            "units": "Pa2", "long_name": "predicted reduced stress ACF",
            "equation": "eq. 47 (divided by a_r(0); both modified: a_ri(0))"}),
        "Gamma_sigma_sa": (("theory", "p0", "dr"), pred["Gamma_sigma_sa"], {
            "units": "Pa2", "long_name": "small-pressure asymptote of the reduced stress "
            "ACF", "equation": "small-p* limit of eq. 47-50 per theory (self-affine "
            "range)"}),
        "Gamma_sigma_51": (("p0", "dr"), pred["Gamma_sigma_51"], {
            "units": "Pa2", "long_name": "eq. 51 as printed", "equation":
            "eq. 51: pi gbar(0) H^2 E*^2 sqrt(G / c_sa(H)) / (2 dr), c_sa(H) = gbar^2 "
            "dr^2 / G (the print's c_sa read as its reciprocal)"}),
        "stress_error": (("theory", "p0"), err_max.values, {
            **err_attrs, "long_name": "largest stress-ACF error relative to G_sigma_sim(0)",
            "definition": "max |G_sigma - G_sigma_sim| / G_sigma_sim(dr -> 0) over "
            "error_dr_min <= dr <= error_dr_max"}),
        "stress_error_rms": (("theory", "p0"), err_rms.values, {
            **err_attrs, "long_name": "rms stress-ACF error relative to G_sigma_sim(0)"}),
        "stress_error_coverage": (("theory", "p0"), coverage, {
            **err_attrs, "long_name": "share of the lags in the error range where the "
            "theory predicts G_sigma"}),
        "iterations": (("p0",), sim.iterations[:n], {
            "long_name": "conjugate-gradient iterations"}),
        "converged": (("p0",), sim.converged[:n], {
            "long_name": "1 if the solver reached tol"}),
    }, coverage


def _full_contact_vars(G: xr.DataArray, E: float, sim: _Simulation, sel: np.ndarray,
                       err_attrs: dict) -> dict:
    """Return the full-contact stress ACF, simulated and of eq. 24, and its error."""
    assert sim.p_full is not None  # simulated with full_contact
    n, p_full = sim.n, float(sim.p_full)
    S_full_sim = sim.stress_acf.isel(p0=n).values - p_full**2
    S_full = stress_acf(G, E_star=E).values
    var = float(sim.pressure[n].var())  # G_sigma_full_sim(0)
    f_max, f_rms = _errors(xr.DataArray(S_full - S_full_sim, dims="dr"), var, sel)
    area_full = float(sim.area[n])
    if area_full < 1:
        quality.warn(f"the full-contact load {p_full:.3g} Pa left "
                     f"{1 - area_full:.2%} of the map out of contact; the full-contact "
                     "comparison is approximate", RuntimeWarning)
    return {
        "G_sigma_full_sim": (("dr",), S_full_sim, {
            "units": "Pa2", "long_name": "simulated full-contact stress ACF",
            "definition": "<p^2> - p0_full^2 - G_p(dr)", "source": _SIM_SOURCE}),
        "G_sigma_full": (("dr",), S_full, {
            "units": "Pa2", "long_name": "full-contact stress ACF from G",
            "equation": "eq. 24 (p0^2 offset left out)"}),
        "full_contact_error": ((), float(f_max), {
            **err_attrs, "long_name": "largest error of eq. 24 relative to the "
            "simulated stress variance"}),
        "full_contact_error_rms": ((), float(f_rms), {
            **err_attrs, "long_name": "rms error of eq. 24 relative to the simulated "
            "stress variance"}),
        "full_contact_area": ((), area_full, {
            "units": "1", "long_name": "simulated relative contact area at p0_full"}),
        "p0_full": ((), p_full, {"units": "Pa", "long_name":
                                 "mean pressure of the full-contact solve"}),
    }


def _attrs(E: float, kappa: float | None, kappa_used: float, fitted: int,
           rough: _Roughness, gradient_method: str, error_range: tuple[float, float],
           grid, names: tuple[str, ...]) -> dict:
    """Return the comparison's attrs (``quality`` good until marked)."""
    lo, hi = error_range
    return {
        "E_star": E, "E_star_units": "Pa", "kappa": kappa_used, "kappa_fitted": fitted,
        "kappa_persson": KAPPA_PERSSON, "gbar0": rough.gbar0, "gbar0_units": "1",
        "gradient_method": str(rough.gbar.attrs.get("method", gradient_method)),
        "error_dr_min": float(lo), "error_dr_max": float(hi),
        "error_dr_units": grid.lateral_unit,
        "theories": ", ".join(names), "periodic": int(grid.periodic),
        "kappa_definition": "fitted: 2 erfinv(a_sim) / (sqrt(pi) p*) at the smallest "
        "load (about a_sim / p*)" if fitted else "given" if kappa is not None else
        "not fitted (contact area 0 or 1 at the smallest load)",
        "kappa_used_by": "persson_kappa and a_r_kappa only; the persson and modified "
        "theories use kappa = sqrt(8/pi) as the paper defines them",
        "quality": "good", "quality_notes": "",
    }


def _mark_coverage(ds: xr.Dataset, coverage: np.ndarray,
                   names: tuple[str, ...]) -> xr.Dataset:
    """Mark the comparison when a theory predicts ``G_sigma`` on only part of the lags."""
    if not (coverage < 1).any():
        return ds
    worst_theory = names[int(np.argmin(coverage.min(axis=1)))]
    return quality.mark(
        ds, f"the theories predict G_sigma on only {coverage.min():.0%} of the lags in "
        f"the error range ({worst_theory}: the rms gradient is not determined on the "
        "others); stress_error covers those lags only (stress_error_coverage)",
        what="compare_with_simulation")
