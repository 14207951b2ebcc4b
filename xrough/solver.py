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

    Boundary-element (Green's function) method with FFT convolutions and the constrained
    conjugate-gradient iteration of Polonsky & Keer (1999) at a prescribed mean pressure
    ``p0``; or at a prescribed ``displacement`` (approach), found by Brent's method on the
    mean pressure with warm-started load-controlled solves.

    Parameters
    ----------
    topography : xarray.DataArray with dims ("y", "x")
        Combined roughness ``h`` (heights up towards the elastic body), complete (no NaN),
        on a uniform grid. ``attrs["periodic"]`` selects the Green's function.
    E_star : float, str or Quantity
        Contact modulus ``E*`` (Pa for numbers).
    p0 : float, str, Quantity or sequence of them, optional
        Mean pressure over the whole map (Pa for numbers). Several values give a ``p0``
        dim; each solve starts from the previous solution, so order them by load.
    displacement : float, str, Quantity or sequence of them, optional
        Instead of ``p0``: the approach ``delta`` of the elastic body from first contact
        (numbers in the height unit), giving a ``delta`` dim when several. The
        body's undeformed (non-periodic) or mean (periodic) surface lies at
        ``max(h) - delta``. On a periodic map ``delta`` must stay below full contact,
        ``max(h) - mean(h)``.
    tol : float
        Relative tolerance on the pressure change and the gap error (see Notes).
    max_iter : int
        Maximal number of CG iterations per solve.
    progress : bool, optional
        Show a tqdm bar over the iterations (default: only in an interactive terminal).
    workers : int, optional
        Threads for ``scipy.fft`` (default: all CPUs).
    precision : {"mixed", "float64"}
        ``"mixed"`` (default) runs the first iterations in float32, until the residual
        is below ``max(tol, 1e-6)`` or stops decreasing, then restarts the conjugation
        on the float64 displacement and polishes to ``tol`` with float64 displacements
        and gaps (only the transform of the search direction stays float32; the final
        residual is checked on a displacement transformed afresh in float64): the
        result meets ``tol`` as measured in float64. Maps smaller than 256 x 256 points
        always use float64.
        ``"float64"`` uses float64 throughout.
    coarse_to_fine : int
        Number of 2x restrictions for the initial guess of the first load (default 1; 0:
        a cold start from a uniform pressure). With ``k > 0`` the first load is first
        solved on the map averaged over 2 x 2 pixels (itself started from a coarser grid,
        ``k`` levels in all, down to 64 points a side), to a loose tolerance
        (``max(tol, 1e-3)``), and the coarse pressure, repeated onto 2 x 2 pixels, starts
        the fine solve. The solution is the same as from a cold start to within ``tol``;
        the iterations on the coarse grids are counted in ``iterations``.
    precondition : bool
        Vollebregt's FFT preconditioner (default on): the search direction is built
        from ``K^-1 g``, the gap on the contact set mapped through the inverse of the
        Green's function (``|q|/2`` on periodic maps, the inverse of the zero-padded
        kernel on open ones), instead of from ``g``. It costs a pair of transforms per
        iteration and halves the iterations or better; the solve takes 0.57-0.80 of
        the time without it on 1024 x 1024 maps at 0.7-20 % contact, 0.87-0.92 on
        2048 x 2048 at 0.2-2 %, and 0.64-0.99 on 512 x 512 (measured in
        docs/solver.md). The solution is the same to ``tol``.
    timing : bool
        Add the wall-clock ``solve_time`` and ``time_per_iteration`` (off by default:
        they differ from run to run, so results would no longer compare identical).

    Returns
    -------
    xarray.Dataset
        ``pressure`` (Pa), ``displacement`` (elastic surface displacement, height unit),
        ``gap`` (height unit) and ``contact`` (int8 mask, 1 where ``pressure > 0``) on
        ``(y, x)``; per load: ``contact_area`` (relative), ``mean_pressure`` (Pa),
        ``approach`` (``max(h) + offset``, height unit), ``mean_gap`` (the mean of the
        gap, the interfacial separation, height unit), ``elastic_energy`` (J m-2,
        ``(1/2) <(p - p0)(u - <u>)>``: the work of the load, ``p0 = -d energy / d
        mean_gap``), ``stiffness`` (``-dp0 / d mean_gap`` from neighbouring loads, Pa per
        height unit; NaN for one load), ``gap_quantiles`` on ``area_share`` (0 to 1 in
        steps of 0.05: the gap below which that share of the map lies, the gap
        distribution; 0 up to the contact area), ``iterations`` (coarse grids
        included), ``converged``, ``float32_iterations``, ``coarse_iterations``,
        ``transforms`` (forward plus inverse FFTs of the map), ``deferred_entries``
        (iterations in which overlapping points waited to enter) and, with ``timing``,
        ``solve_time`` (s) and ``time_per_iteration`` (s);
        ``residual`` on ``iteration`` (the convergence history, NaN-padded per load).
        Attrs: ``E_star`` (Pa), ``tol``, ``max_iter``, ``method``, ``green_function``,
        ``iterations`` (total), ``precision``, ``coarse_to_fine``, ``precondition``,
        with ``timing``
        ``solve_time`` (s, total), and, for one load, ``relative_contact_area``.

    Raises
    ------
    ValueError
        Non-positive or non-finite ``E_star`` or ``p0``, both or neither of ``p0`` and
        ``displacement``, NaN or infinite heights, a non-uniform grid, or a periodic
        ``displacement`` at or beyond full contact, an unknown ``precision`` or
        ``precondition``, a negative ``coarse_to_fine``, or a load ``p0 / E*`` (or a
        ``displacement``) outside 1e-250 to 1e250 times the largest height (in the
        lateral unit), beyond float64 on these heights.

    Warns
    -----
    ConvergenceWarning
        When a solve stops at ``max_iter`` above ``tol`` (``converged`` is 0 there).

    Notes
    -----
    Small slopes, linear elasticity: ``u~(q) = 2 p~(q) / (E* |q|)``. The gap is
    ``g = u - h - offset``; the solution has ``p >= 0``, ``g >= 0`` and ``p g = 0``.
    Periodic maps use this Fourier-space Green's function with the ``q = 0`` term dropped
    (its effect is the rigid-body offset, fixed by the mean-pressure constraint); in full
    contact the pressure is exactly ``p0 + (E*/2)|q| h~(q)``. Non-periodic maps use
    piecewise-constant pressure pixels in free space: Love's pixel solution (the
    Boussinesq kernel ``1/(pi E* r)`` integrated over one pixel) sampled at all pixel
    offsets on the grid doubled along both axes, Fourier-transformed once, and applied as
    a zero-padded convolution (the surroundings of the map are flat and out of contact).

    Each iteration (Polonsky & Keer 1999): compute ``g`` and subtract its mean over the
    contact set ``I_c = {p > 0}``; conjugate direction ``t = g + delta (G/G_old) t`` on
    ``I_c`` with ``G = sum_{I_c} g^2``; step ``tau = (g.t) / (r.t)`` with ``r = K t``
    (mean-shifted); ``p <- max(p - tau t, 0)``; points with ``p = 0`` and ``g < 0``
    re-enter (``p = -tau g``, ``delta = 0``); rescale to the mean ``p0``. Points out of
    contact with a negative gap enter only when their gap error exceeds half that on the
    contact set (proportioning, as in Dostal's MPRGP); until then the conjugation goes on,
    which halves the iterations on rough surfaces. With the preconditioner, ``g`` in the
    direction (and in ``G = g.z``) becomes ``z = K^-1 g`` restricted to ``I_c`` and
    mean-shifted (Vollebregt 2014), and re-entering points get ``-tau (g.z / g.g) g``.
    The residual is
    ``max(sum|p - p_old| / sum p, rms(g on I_c and g < 0 elsewhere) / rms(h))`` and the
    iteration stops below ``tol``. A load beyond full contact simply converges to full
    contact (``contact_area = 1``).

    The problem is linear in ``(h, p0/E*, delta)``: it is solved on the heights divided
    by the power of two nearest their largest ``|h|`` (exact in floating point, so heights
    of any size give the same solution, scaled, without overflowing squares or float32
    transforms), and the fields are scaled back.

    Full contact of a periodic map needs no iteration: where ``p0 + (E*/2)|q| h~`` is
    positive everywhere it is the solution, computed with one pair of transforms and
    checked (``iterations`` is 1 there).

    Cost: the iterates live on the contact set only; per iteration one forward and one
    inverse transform give ``K t`` (and one pair ``K^-1 g`` with the preconditioner, in
    float32 in both phases of ``"mixed"``), and the displacement ``K p`` is updated linearly
    (``u <- s (u - tau K t)``, plus the kernel of the few pixels that left or entered the
    contact set), so a second pair of transforms is needed only in iterations where many
    pixels change. ``transforms`` counts them.

    References
    ----------
    I. A. Polonsky and L. M. Keer, Wear 231, 206-219 (1999).
    Z. Dostal and J. Schoeberl, Comput. Optim. Appl. 30, 23-43 (2005) (MPRGP,
    proportioning).
    E. A. H. Vollebregt, J. Comput. Phys. 257, 333-351 (2014) (the FFT-based
    preconditioner).
    K. L. Johnson, Contact Mechanics (1985), eq. 3.25 (Love's pixel solution).

    Examples
    --------
    Westergaard's sinusoid at half the full-contact pressure ``p* = pi E* h0 / lambda``
    has the contact half-width ``a = lambda/4``:

    >>> from xrough.solver import solve_contact
    >>> x = np.arange(256) / 256  # um, one wavelength
    >>> h = np.tile(0.01 * np.cos(2 * np.pi * x), (2, 1))  # h0 = 10 nm
    >>> topo = xrough.topography(h, spacing=1 / 256, unit="um", periodic=True)
    >>> p_star = np.pi * 1e6 * 0.01 / 1  # pi E* h0 / lambda in Pa
    >>> res = solve_contact(topo, E_star="1 MPa", p0=0.5 * p_star)
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
                      {"long_name": "iteration"}),
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
