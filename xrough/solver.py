r"""Reference contact solver: boundary elements with Polonsky & Keer's constrained CG.

Frictionless, non-adhesive normal contact of a linear-elastic half-space (contact modulus
``E*``) with a rigid rough surface ``h`` (the combined roughness of both surfaces, small
slopes). The numerical work is in :mod:`xrough._kernels.solver`; this module validates the
topography and parameters, converts units and labels the result.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from . import quality
from . import units as u
from ._kernels.checks import require_count, require_flag
from ._kernels.pairs import resolve_workers
from ._kernels.separation import GAP_SHARES
from ._kernels.solver import (
    ElasticOperator,
    coarse_start,
    full_contact_solution,
    full_contact_stress,
    solve_approach,
    solve_load,
)
from ._kernels.tiles import scaled_heights
from .progress import progress_bar
from .topography import check_valid_points, grid_of
from .units import QuantityLike

__all__ = ["solve_contact", "ConvergenceWarning"]


class ConvergenceWarning(RuntimeWarning):
    """An iterative solver stopped at ``max_iter`` before reaching its tolerance."""


def _progress_bar(progress: bool | None, desc: str):
    return progress_bar(desc=desc, progress=progress)


def check_topography(topography: xr.DataArray):
    grid = grid_of(topography)
    if grid.dims != ("y", "x"):
        raise ValueError("solve_contact needs a map with dims ('y', 'x'), not a profile")
    extra = [d for d in topography.dims if d not in ("y", "x")]
    if extra:
        raise ValueError(f"solve_contact solves one map at a time; select one along "
                         f"{extra}, e.g. topography.isel({extra[0]}=0)")
    h = np.asarray(topography.transpose("y", "x").values, dtype=float)
    check_valid_points(h)
    if np.isnan(h).any():
        raise ValueError(f"topography has {int(np.isnan(h).sum())} missing (NaN) heights; "
                         "the contact solver needs a complete map: fill or crop them first")
    return grid, h


def _fields(results: list[dict], key: str, factor: float) -> np.ndarray:
    """Stack the field ``key`` of every load, times ``factor``, releasing the originals.

    One load gives a view of its own array, scaled in place: no copy of the map.
    """
    if len(results) == 1:
        out = results[0][key][None]
    else:
        out = np.stack([r[key] for r in results])
    for r in results:
        r[key] = None
    out *= factor
    return out


#: Largest load, relative to the scale of the heights, that float64 solves (its square and
#: the pressures' sums stay finite; a relative load below the reciprocal puts less than
#: 1e-250 of the full-contact pressure on the map).
_LOAD_RANGE = 1e250


def _scaled_targets(targets: np.ndarray, e: int, load_dim: str) -> np.ndarray:
    """Return the loads ``p0/E*`` or approaches in units of the heights' scale ``2**e``."""
    scaled = np.ldexp(np.asarray(targets, dtype=float), -e)
    if np.all((scaled > 1 / _LOAD_RANGE) & (scaled < _LOAD_RANGE)):
        return scaled
    k = int(np.flatnonzero(~((scaled > 1 / _LOAD_RANGE) & (scaled < _LOAD_RANGE)))[0])
    name = "p0 / E_star" if load_dim == "p0" else "displacement"
    raise ValueError(
        f"{name} = {targets[k]:g} is {scaled[k]:g} times the largest height |h| = "
        f"2**{e} (lateral unit): outside {1 / _LOAD_RANGE:g} to {_LOAD_RANGE:g}, the loads "
        "float64 arithmetic solves on these heights (bring the load or the heights to a "
        "common scale)")


@u.accepts_quantified
def solve_contact(
    topography: xr.DataArray,
    *,
    E_star: QuantityLike,
    p0: QuantityLike | None = None,
    displacement: QuantityLike | None = None,
    tol: float = 1e-8,
    max_iter: int = 10_000,
    progress: bool | None = None,
    workers: int | None = None,
    precision: str = "mixed",
    coarse_to_fine: int = 1,
    precondition: bool = True,
    timing: bool = False,
) -> xr.Dataset:
    r"""Solve the normal contact of an elastic half-space with a rigid rough surface.

    Boundary elements with FFT convolutions; constrained conjugate gradients (Polonsky &
    Keer 1999) at a mean pressure ``p0``, or Brent's method on ``p0`` at a ``displacement``.
    Notes: docs/solver.md, "Equations and iteration" (and its "Options", "References").

    Parameters
    ----------
    topography : xarray.DataArray with dims ("y", "x")
        Heights ``h`` (up towards the body), no NaN, uniform grid; ``attrs["periodic"]``.
    E_star : float, str or Quantity
        Contact modulus ``E*`` (Pa for numbers).
    p0 : float, str, Quantity or sequence of them, optional
        Mean pressure (Pa for numbers); several: a ``p0`` dim, each solve warm-started.
    displacement : float, str, Quantity or sequence of them, optional
        Instead of ``p0``: approach from first contact (height unit; a ``delta`` dim).
    tol, max_iter : float, int
        Relative tolerance (pressure change, rms gap error); CG iterations per solve.
    progress : bool, optional
        Show a tqdm bar (default: only in an interactive terminal).
    workers : int, optional
        Threads for ``scipy.fft`` (default: all CPUs).
    precision : {"mixed", "float64"}
        ``"mixed"``: float32 down to ``max(tol, 1e-6)``, then float64 to ``tol``.
    coarse_to_fine : int
        Levels of 2 x 2 averaging whose solve starts the first load (0: a cold start).
    precondition : bool
        Vollebregt's FFT preconditioner ``K^-1 g`` in the search direction.
    timing : bool
        Add the wall-clock ``solve_time`` and ``time_per_iteration`` (s).

    Returns
    -------
    xarray.Dataset
        ``pressure`` (Pa), ``displacement``, ``gap`` (height unit), ``contact`` on ``(y,
        x)``; per load ``contact_area``, ``mean_pressure`` (Pa), ``approach``, ``mean_gap``
        (height unit), ``elastic_energy`` (J m-2), ``stiffness`` (Pa per height unit),
        ``gap_quantiles``, counters, ``residual``: docs/solver.md, "The result".

    Raises
    ------
    ValueError
        Invalid ``E_star``, ``p0``, ``displacement`` (both or neither), heights or options;
        a load beyond float64 on these heights (docs/solver.md, "Options").

    Warns
    -----
    ConvergenceWarning
        A solve stops at ``max_iter`` above ``tol`` (``converged`` is 0 there).

    Examples
    --------
    >>> x = np.arange(256) / 256  # um, one wavelength of Westergaard's sinusoid, h0 = 10 nm
    >>> topo = xrough.topography(np.tile(0.01 * np.cos(2 * np.pi * x), (2, 1)),
    ...                          spacing=1 / 256, unit="um", periodic=True)
    >>> p0 = 0.5 * np.pi * 1e6 * 0.01  # half the full-contact pi E* h0 / lambda, in Pa
    >>> res = xrough.solve_contact(topo, E_star="1 MPa", p0=p0)
    >>> round(res.attrs["relative_contact_area"], 2), bool(res.converged)  # 2a / lambda
    (0.5, True)
    """
    grid, h = check_topography(topography)
    E = u.positive_si(E_star, "[pressure]", what="E_star")
    if (p0 is None) == (displacement is None):
        raise ValueError("give exactly one of p0 (mean pressure) or displacement")
    opts = _options(tol, max_iter, precision, precondition, coarse_to_fine)
    to_lat = u.conversion_factor(grid.height_unit, grid.lateral_unit)
    loads = _loads(p0, displacement, E, grid.height_unit, to_lat)
    workers = resolve_workers(workers)
    op = ElasticOperator(h.shape, grid.spacing, periodic=grid.periodic, workers=workers)
    # the problem is linear in (h, p0/E*, delta): solve it with heights scaled by the power
    # of two 2**e nearest max|h| (exact in floating point), so that no height, square or
    # float32 transform overflows, and scale the fields back
    h_lat, e = scaled_heights(h * to_lat if to_lat != 1 else h)
    assert e is not None  # check_topography: the map has valid points
    targets = _scaled_targets(loads.targets, e, loads.dim)
    results = _solve_loads(h_lat, op, targets, loads.dim, opts, progress)
    _warn_unconverged(results, opts)
    scale = _Scale(E=E, e=e, from_lat=np.ldexp(1.0 / to_lat, e), h_max=float(h_lat.max()))
    ds = _dataset(results, topography, grid, loads, scale, opts)
    if timing:
        _add_timing(ds, results, loads.dim)
    if loads.scalar:
        ds = ds.isel({loads.dim: 0})
        ds.attrs["relative_contact_area"] = float(ds["contact_area"])
    return ds


@dataclass(frozen=True)
class _Options:
    """The solver's checked parameters."""

    tol: float
    max_iter: int
    precision: str
    precondition: bool
    coarse_to_fine: int


def _options(tol, max_iter, precision, precondition, coarse_to_fine) -> _Options:
    """Check the solver's parameters (ValueError naming the bad one)."""
    if not (np.isfinite(tol) and 0 < tol < 1):
        raise ValueError(f"tol must be between 0 and 1, got {tol!r}")
    max_iter = require_count(max_iter, "max_iter", minimum=1)
    if precision not in ("mixed", "float64"):
        raise ValueError(f"precision must be 'mixed' or 'float64', got {precision!r}")
    require_flag(precondition, "precondition")
    coarse_to_fine = require_count(coarse_to_fine, "coarse_to_fine")
    return _Options(float(tol), int(max_iter), precision, bool(precondition),
                    int(coarse_to_fine))


@dataclass(frozen=True)
class _Loads:
    """The prescribed loads: dim name, coordinate values and the solver's targets.

    ``targets`` are ``p0 / E*`` or approaches in the lateral unit; ``scalar`` when one
    load was given as a scalar (no load dim in the result).
    """

    dim: str
    values: Any
    targets: np.ndarray
    attrs: dict
    scalar: bool


def _loads(p0, displacement, E: float, hunit: str, to_lat: float) -> _Loads:
    """Read ``p0`` (Pa) or ``displacement`` (height unit) into :class:`_Loads`."""
    if p0 is not None:
        values = u.positive_si(p0, "[pressure]", what="p0", many=True)
        return _Loads("p0", values, np.atleast_1d(values) / E,
                      {"units": "Pa", "long_name": "prescribed mean pressure"},
                      np.ndim(values) == 0)
    mags = u.magnitude_in(displacement, hunit, what="displacement")
    many = np.ndim(mags) > 0
    values = np.atleast_1d(mags).astype(float)
    if values.ndim != 1 or not np.all(np.isfinite(values) & (values > 0)):
        raise ValueError(f"displacement must be a positive, finite length, got "
                         f"{displacement!r}")
    # "delta": "displacement" names the elastic field
    return _Loads("delta", values if many else float(values[0]), values * to_lat,
                  {"units": hunit, "long_name": "prescribed approach from first contact"},
                  not many)


def _solve_loads(h_lat: np.ndarray, op: ElasticOperator, targets: np.ndarray,
                 load_dim: str, opts: _Options, progress: bool | None) -> list[dict]:
    """Solve every load in turn, each started from the previous solution.

    The first load of ``p0`` starts from the coarse grids (``coarse_to_fine``); a load of
    full contact of a periodic map takes the closed-form solution where it meets ``tol``.
    """
    bar = _progress_bar(progress, "contact")
    callback = None if bar is None else (lambda it, res: (
        bar.update(1), bar.set_postfix(residual=f"{res:.1e}", refresh=False)))
    # the smallest load of full contact (periodic maps; open ones never reach it exactly);
    # the map is not kept during the solves: recomputed if a load reaches it
    full = full_contact_stress(h_lat, op) if load_dim == "p0" else None
    full_min = float(full.min()) if full is not None else -np.inf
    del full
    results, p_prev = [], None
    try:
        for target in targets:
            out = _solve_one(h_lat, op, float(target), load_dim, opts, p_prev, callback,
                             full=target + full_min > 0)
            results.append(out)
            p_prev = out["pressure"]
    finally:
        if bar is not None:
            bar.close()
    return results


def _solve_one(h_lat: np.ndarray, op: ElasticOperator, target: float, load_dim: str,
               opts: _Options, p_prev: np.ndarray | None, callback, *, full: bool) -> dict:
    """Solve one load (``full``: try the closed form of full contact first)."""
    t_start = time.perf_counter()
    if full:
        out = full_contact_solution(h_lat, op, target)
        if out["history"][-1] < opts.tol:  # else (round-off): iterate as usual
            out["seconds"] = time.perf_counter() - t_start
            out["coarse_iterations"] = 0
            if callback is not None:
                callback(1, float(out["history"][-1]))
            return out
    coarse_its = 0
    if p_prev is None and load_dim == "p0" and opts.coarse_to_fine:
        p_prev, coarse_its = coarse_start(
            h_lat, op, target, levels=opts.coarse_to_fine, tol=opts.tol,
            max_iter=opts.max_iter, precision=opts.precision,
            precondition=opts.precondition)
    kw = {"tol": opts.tol, "max_iter": opts.max_iter, "p_init": p_prev,
          "callback": callback, "precision": opts.precision,
          "precondition": opts.precondition}
    solve = solve_load if load_dim == "p0" else solve_approach
    out = solve(h_lat, op, target, **kw)
    if not out["converged"] and p_prev is not None and kw["p_init"] is p_prev:
        # a warm start can leave too few points in contact for the conjugate directions
        # (one point: its mean-shifted gap is zero, and the solve stops at once with
        # overlapping points outside); a cold start does not depend on it
        cold = _solve_one(h_lat, op, target, load_dim, opts, None, callback, full=False)
        cold["iterations"] += out["iterations"] + coarse_its
        return cold
    out["seconds"] = time.perf_counter() - t_start
    out["coarse_iterations"] = coarse_its
    out["iterations"] += coarse_its
    return out


def _warn_unconverged(results: list[dict], opts: _Options) -> None:
    """Warn (:class:`ConvergenceWarning`) when a load stopped above ``tol``."""
    bad = [i for i, r in enumerate(results) if not r["converged"]]
    if bad:
        worst = max(float(results[i]["history"][-1]) for i in bad)
        quality.warn(ConvergenceWarning(
            f"contact solver did not reach tol={opts.tol:g} within "
            f"max_iter={opts.max_iter} for {len(bad)} of {len(results)} load(s) (worst "
            f"residual {worst:.2g}); the result is flagged converged=0: raise max_iter or "
            "loosen tol"))


@dataclass(frozen=True)
class _Scale:
    """From the scaled problem back to units: ``E*`` (Pa), the heights' ``2**e``, ...

    ``from_lat`` takes scaled lengths to the height unit; ``h_max`` is the largest scaled
    height.
    """

    E: float
    e: int
    from_lat: float
    h_max: float


def _history(results: list[dict]) -> np.ndarray:
    """Residual per load and iteration, NaN-padded to the longest history."""
    n_hist = max(len(r["history"]) for r in results)
    hist = np.full((len(results), n_hist), np.nan)
    for i, r in enumerate(results):
        hist[i, : len(r["history"])] = r["history"]
    return hist


def _field_vars(results: list[dict], scale: _Scale, hunit: str, L: tuple) -> dict:
    """Return the maps: pressure (Pa), displacement and gap (height unit), contact."""
    yx = ("y", "x")
    pressure = _fields(results, "pressure", np.ldexp(scale.E, scale.e))
    return {
        "pressure": (L + yx, pressure, {"units": "Pa", "long_name": "contact pressure"}),
        "displacement": (L + yx, _fields(results, "displacement", scale.from_lat), {
            "units": hunit, "long_name": "elastic surface displacement"}),
        "gap": (L + yx, _fields(results, "gap", scale.from_lat), {
            "units": hunit, "long_name": "gap between the surfaces"}),
        "contact": (L + yx, (pressure > 0).view(np.int8), {
            "units": "1", "long_name": "contact mask"}),
    }


#: Per-load outcomes of the solve: result key, dtype and long name.
_COUNTERS = {
    "iterations": (np.int64, "conjugate-gradient iterations"),
    "converged": (np.int8, "1 if the residual reached tol"),
    "float32_iterations": (np.int64, "iterations of the float32 phase"),
    "coarse_iterations": (np.int64, "iterations on the coarse grids"),
    "transforms": (np.int64, "forward plus inverse FFTs of the map"),
    "deferred_entries": (np.int64, "iterations in which overlapping points waited to "
                                   "enter the contact set (proportioning)"),
}


def _load_vars(results: list[dict], scale: _Scale, hunit: str, L: tuple) -> dict:
    """Per-load scalars: area, mean pressure, approach, convergence and counters.

    Read before the maps are stacked (:func:`_fields` releases them).
    """
    area = np.array([np.mean(r["pressure"] > 0) for r in results])
    mean_p = np.ldexp(np.array([r["pressure"].mean() for r in results]) * scale.E, scale.e)
    approach = (scale.h_max + np.array([r["offset"] for r in results])) * scale.from_lat
    mean_gap = np.array([r["gap"].mean() for r in results]) * scale.from_lat
    # (1/2) <(p - <p>)(u - <u>)>: the elastic energy per area beyond the uniform
    # compression (which a periodic half-space does not define), in Pa times the height unit
    energy = np.array([0.5 * np.mean((r["pressure"] - r["pressure"].mean())
                                     * (r["displacement"] - r["displacement"].mean()))
                       for r in results]) * np.ldexp(scale.E, scale.e) * scale.from_lat
    out = {
        "contact_area": (L, area, {"units": "1", "long_name": "relative contact area"}),
        "mean_pressure": (L, mean_p, {"units": "Pa", "long_name": "mean pressure"}),
        "approach": (L, approach, {"units": hunit, "long_name":
                                   "approach from first contact, max(h) + offset"}),
        "mean_gap": (L, mean_gap, {"units": hunit, "long_name":
                                   "mean gap between the surfaces (interfacial separation)"}),
        "elastic_energy": (L, energy * u.conversion_factor(hunit, "m"), {
            "units": "J m-2", "long_name": "elastic energy per area, "
                                           "(1/2) <(p - p0)(u - <u>)>"}),
        "gap_quantiles": (L + ("area_share",), np.array(
            [np.quantile(r["gap"], GAP_SHARES) for r in results]) * scale.from_lat, {
            "units": hunit, "long_name": "gap below which the share area_share of the "
                                         "map lies (the gap distribution)"}),
        "stiffness": (L, _stiffness(mean_p, mean_gap), {
            "units": f"Pa {hunit}-1", "long_name": "contact stiffness per area, "
                                                   "-dp0/d(mean gap) between loads"}),
    }
    for key, (dtype, name) in _COUNTERS.items():
        out[key] = (L, np.array([r[key] for r in results], dtype=dtype),
                    {"long_name": name})
    return out



def _stiffness(mean_p: np.ndarray, mean_gap: np.ndarray) -> np.ndarray:
    """``-dp0 / d(mean gap)`` from neighbouring loads (NaN for one load).

    Second-order differences on the loads in increasing order of the gap (one-sided at
    the ends); loads with equal gaps (full contact) give NaN.
    """
    if mean_p.size < 2:
        return np.full(mean_p.shape, np.nan)
    order = np.argsort(mean_gap)
    g, p = mean_gap[order], mean_p[order]
    out = np.full(mean_p.shape, np.nan)
    if np.all(np.diff(g) > 0):
        out[order] = -np.gradient(p, g)
    return out


def _dataset(results: list[dict], topography: xr.DataArray, grid, loads: _Loads,
             scale: _Scale, opts: _Options) -> xr.Dataset:
    """Label the solutions: maps on (load, y, x), per-load values, the history."""
    L = (loads.dim,)
    hunit = grid.height_unit
    per_load = _load_vars(results, scale, hunit, L)
    hist = _history(results)
    data = {**_field_vars(results, scale, hunit, L), **per_load}
    data["residual"] = (L + ("iteration",), hist, {
        "units": "1", "long_name": "relative residual per iteration "
        "(max of pressure change and gap error)"})
    coords = {
        "y": topography["y"], "x": topography["x"],
        loads.dim: (L, np.atleast_1d(loads.values), loads.attrs),
        "iteration": ("iteration", np.arange(1, hist.shape[1] + 1),
                      {"units": "1", "long_name": "iteration"}),
        "area_share": ("area_share", GAP_SHARES, {
            "units": "1", "long_name": "share of the map's area"}),
    }
    attrs = {
        "E_star": scale.E, "E_star_units": "Pa", "tol": opts.tol, "max_iter": opts.max_iter,
        "method": "polonsky-keer constrained conjugate gradient" + (
            "" if loads.dim == "p0" else ", brent root of the approach in p0"),
        "green_function": ("periodic, u~ = 2 p~ / (E* |q|)" if grid.periodic else
                           "free space, Love pixel kernel, zero-padded to 2n"),
        "periodic": int(grid.periodic),
        "iterations": int(sum(r["iterations"] for r in results)),
        "precision": opts.precision,
        "coarse_to_fine": opts.coarse_to_fine,
        "precondition": int(opts.precondition),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _add_timing(ds: xr.Dataset, results: list[dict], load_dim: str) -> None:
    """Add the wall-clock ``solve_time`` and ``time_per_iteration`` (s) per load, in place."""
    L = (load_dim,)
    ds["solve_time"] = (L, np.array([r["seconds"] for r in results]), {
        "units": "s", "long_name": "wall-clock time of the solve"})
    ds["time_per_iteration"] = (L, np.array([r["seconds"] / max(r["iterations"], 1)
                                             for r in results]), {
        "units": "s", "long_name": "wall-clock time per iteration"})
    ds.attrs["solve_time"] = float(sum(r["seconds"] for r in results))
