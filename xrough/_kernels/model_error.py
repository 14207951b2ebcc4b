"""The theory's own error: Persson's contact area against the boundary-element solver.

The table ``xrough/data/persson_area_error.csv`` holds the solver study of
``benchmarks/model_error_study.py``: Persson's ``a_r`` (eq. 29 with ``kappa = sqrt(8/pi)``)
and ``a_ri`` (eq. 50), as :func:`xrough.persson` gives them from a map's G at its finest
lag, against the solver's contact area of the same map, for Hurst exponents 0.1-0.95,
sharp and smooth roll-offs, sharp, smooth and Gaussian short cutoffs, ``lambda_s`` 2-16
pixels, bandwidths 4-256 and reduced pressures ``p*`` 1e-4 to 0.5 (three seeds each).

The error is not a function of ``p*`` alone: at ``p* = 0.01`` Persson's area is 30 % low
on a smooth map and 60 % low on a rough one. What separates them is the shape of G at the
resolution (:func:`features_on_lags`): its local exponent over a factor 2 and 8 in ``dr``
and how much rougher the surface is at G's largest lags. :func:`area_model_error` gives
the expected ``ln(a / a_exact)`` as a cubic polynomial in ``ln p*`` and those three,
fitted by least squares to the table (open maps with a term of their own), and its spread
from the residuals of the study's surfaces nearest in those variables, each left out of
the fit in turn (fitted once per process). Outside the table's range of ``p*``
and of G's shape it is NaN, with the reason (:func:`outside_domain`).
"""

from __future__ import annotations

import functools
import itertools
from importlib import resources
from typing import NamedTuple

import numpy as np
import pandas as pd

from .deferred import spatial

__all__ = ["FEATURES", "features_of", "features_on_lags", "P_STAR_RANGE",
           "FULL_CONTACT_P_STAR", "MIN_PIXELS", "DECAY_MIN", "area_table", "stress_table",
           "area_model_error", "stress_model_error", "outside_domain"]

#: What the model error reads from G at the resolution of a result.
FEATURES = ("h_local", "h_wide", "range")
#: The reduced pressures the study covers.
P_STAR_RANGE = (1e-4, 0.5)
#: Beyond the study the error falls, linearly in ``ln p*``, to 0 where Persson's
#: ``a_r = erf(sqrt(2) p*)`` reaches 0.999 (full contact: no area left to miss).
FULL_CONTACT_P_STAR = 1.65
#: Loads where fewer pixels touch are not used: the solver's area measures the grid.
MIN_PIXELS = 100
_FACTORS = (2.0, 8.0)  # h_local: from dr to 2 dr; h_wide: to 8 dr


def features_on_lags(dr: np.ndarray, G: np.ndarray, at: np.ndarray | None = None
                     ) -> np.ndarray:
    """Read the shape of G at each lag ``at`` (default: G's own): half its log-log slope.

    Returns an array ``(3, len(at))``: ``h_local`` from ``at`` to ``2 at`` and ``h_wide``
    from ``at`` to ``8 at`` (G interpolated linearly in ``ln dr``, ``ln G``): ``H`` on a
    self-affine range, 1 where a smooth cutoff makes G ~ dr^2, lower where G bends into
    its plateau; and ``range``, ``ln sqrt(max G / G(at))``: how much rougher the surface
    is at G's largest lags than at this one. NaN where G does not reach (beyond its
    largest lag / 8 or below its smallest) or is not positive.

    Examples
    --------
    >>> dr = np.geomspace(1, 1000, 40)
    >>> np.round(features_on_lags(dr, dr**1.4)[:, 0], 3)
    array([0.7  , 0.7  , 4.835])
    """
    dr, G = np.asarray(dr, dtype=float), np.asarray(G, dtype=float)
    at = dr if at is None else np.asarray(at, dtype=float)
    ok = np.isfinite(G) & (G > 0) & (dr > 0)
    out = np.full((len(FEATURES), at.size), np.nan)
    if np.count_nonzero(ok) < 2:
        return out
    x, y = np.log(dr[ok]), np.log(G[ok])
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.log(at)
    inside = a >= x[0] - 1e-12  # a zero lag (a = -inf) is not
    with np.errstate(invalid="ignore"):
        for i, factor in enumerate(_FACTORS):
            b = a + np.log(factor)
            slope = 0.5 * (np.interp(b, x, y) - np.interp(a, x, y)) / (b - a)
            out[i] = np.where(inside & (b <= x[-1] + 1e-12), slope, np.nan)
        out[2] = np.where(inside, 0.5 * (y.max() - np.interp(a, x, y)), np.nan)
    return out


def features_of(dr: np.ndarray, G: np.ndarray, at: float) -> dict[str, float]:
    """Return :func:`features_on_lags` at the one lag ``at``, by name."""
    values = features_on_lags(dr, G, np.array([at]))[:, 0]
    return {name: float(v) for name, v in zip(FEATURES, values)}


@functools.cache
def area_table() -> dict[str, np.ndarray]:
    """Read the study's table, one array per column (``xrough/data/persson_area_error.csv``)."""
    return read_table("persson_area_error.csv")


#: Polynomial degree of the expected error in ln p* and G's features.
DEGREE = 3
#: Study rows about a query that give its spread (nearest in the scaled variables).
NEIGHBOURS = 60
#: The columns that name a surface of the study (its seeds share them).
SURFACE = ("hurst", "rolloff", "cutoff", "lambda_s_px", "bandwidth", "ratio_l", "open")


def _basis(variables: list[np.ndarray], is_open: np.ndarray) -> np.ndarray:
    """Build the regressors: a polynomial of :data:`DEGREE` in the variables.

    An open map has a quadratic in ``ln p*`` of its own (its solver has no periodic
    images).
    """
    terms = [np.ones_like(variables[0])]
    for d in range(1, DEGREE + 1):
        for combo in itertools.combinations_with_replacement(range(len(variables)), d):
            terms.append(functools.reduce(np.multiply, [variables[k] for k in combo]))
    lp = variables[0]
    terms += [is_open, is_open * lp, is_open * lp * lp]
    return np.stack(terms, axis=-1)


class _Model(NamedTuple):
    mean: np.ndarray  # coefficients of E[ln(a / a_exact)]
    scale: np.ndarray  # of each variable, for the neighbours' distances
    trees: dict  # open flag -> (cKDTree of the scaled variables, held-out residuals)
    factor: float  # calibrates the neighbours' rms to one sigma
    bounds: dict[str, tuple[float, float]]  # the features' range in the table


def used_rows(table: dict[str, np.ndarray]) -> np.ndarray:
    """Rows of the table that build the model: converged, enough pixels, finite."""
    use = ((table["contact_pixels"] >= MIN_PIXELS) & (table["converged"] > 0)
           & (table["p_star"] <= P_STAR_RANGE[1] * (1 + 1e-9)))
    for name in FEATURES:
        use &= np.isfinite(table[name])
    return use


def _variables(p_star: np.ndarray, features) -> list[np.ndarray]:
    with np.errstate(divide="ignore", invalid="ignore"):
        return [np.log(np.clip(p_star, 1e-300, P_STAR_RANGE[1])), *features]


def held_out_residuals(X: np.ndarray, y: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Residuals of a least-squares fit, each group's from the fit without that group.

    ``r_g = y_g - X_g b_g`` with ``b_g`` the fit to the other groups' rows, solved for
    every group at once from the normal equations less the group's own share:
    ``(X'X - X_g'X_g) b_g = X'y - X_g'y_g`` (what a surface the fit has not seen would
    be missed by).
    """
    order = np.argsort(groups, kind="stable")
    Xs, ys, gs = X[order], y[order], groups[order]
    starts = np.flatnonzero(np.r_[True, gs[1:] != gs[:-1]])
    # each group's X_g'X_g and X_g'y_g, over its (contiguous) rows
    blocks = np.split(np.arange(gs.size), starts[1:])
    XtX_g = np.stack([Xs[i].T @ Xs[i] for i in blocks])
    Xty_g = np.add.reduceat(Xs * ys[:, None], starts, axis=0)
    b = np.linalg.solve(XtX_g.sum(axis=0) - XtX_g, (Xty_g.sum(axis=0) - Xty_g)[..., None])
    which = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, gs.size]))
    out = np.empty_like(y, dtype=float)
    out[order] = ys - np.einsum("ij,ij->i", Xs, b[which, :, 0])
    return out


def _neighbour_rms(model: _Model, variables: list[np.ndarray], is_open: np.ndarray
                   ) -> np.ndarray:
    """Give the rms held-out residual of the study rows nearest each query (same flag)."""
    points = np.stack(variables, axis=-1) / model.scale
    out = np.full(points.shape[:-1], np.nan)
    for flag, (tree, r) in model.trees.items():
        here = (is_open == flag) & np.all(np.isfinite(points), axis=-1)
        if here.any():
            _, idx = tree.query(points[here], k=min(NEIGHBOURS, r.size))
            out[here] = np.sqrt(np.mean(r[idx] ** 2, axis=-1))
    return out


def _surfaces(t: dict[str, np.ndarray], use: np.ndarray) -> np.ndarray:
    """Give each row the index of its surface in the study (its loads and lags share it)."""
    code = np.zeros(np.count_nonzero(use), dtype=np.int64)
    for c in SURFACE:  # mixed radix of each column's codes: one integer per surface
        values, inverse = np.unique(t[c][use], return_inverse=True)
        code = code * values.size + inverse.ravel()
    return np.unique(code, return_inverse=True)[1].ravel()


def _build(variables: list[np.ndarray], y: np.ndarray, is_open: np.ndarray,
           surface: np.ndarray, bounds: dict[str, tuple[float, float]]) -> _Model:
    """Fit the expected ``y`` to the variables, and its spread (see :func:`_model`)."""
    X = _basis(variables, is_open)
    mean = np.linalg.lstsq(X, y, rcond=None)[0]
    r = held_out_residuals(X, y, surface)
    scale = np.array([np.std(v) for v in variables])
    points = np.stack(variables, axis=-1) / scale
    trees = {flag: (spatial.cKDTree(points[is_open == flag]), r[is_open == flag])
             for flag in np.unique(is_open)}
    model = _Model(mean, scale, trees, 1.0, bounds)
    # the calibration from at most 5000 rows (a fixed draw): a median, stable to 1 %
    rows = np.random.default_rng(0).permutation(y.size)[:5000]
    rms = _neighbour_rms(model, [v[rows] for v in variables], is_open[rows])
    factor = float(np.median(np.abs(r[rows]) / rms) / 0.6745)
    return model._replace(factor=factor)


@functools.cache
def _model(area: str) -> _Model:
    """Fit the expected ``ln(a / a_exact)`` to the table, and its spread.

    The spread at a point is the rms residual of the :data:`NEIGHBOURS` study rows nearest
    it (in ``ln p*`` and the features, each scaled by its standard deviation over the
    table; periodic and open maps apart), each residual from the fit without its surface
    (:func:`held_out_residuals`: what a surface the fit has not seen is missed by), scaled
    so that the median of those residuals is 0.674 spreads (a normal one's).
    """
    t = area_table()
    use = used_rows(t)
    features = [t[name][use] for name in FEATURES]
    return _build(_variables(t["p_star"][use], features),
                  np.log(t[area][use] / t["contact_area"][use]),
                  t["open"][use].astype(float), _surfaces(t, use),
                  {name: (float(f.min()), float(f.max())) for name, f in zip(FEATURES, features)})


def read_table(name: str) -> dict[str, np.ndarray]:
    """Read one of the study's tables in ``xrough/data``, one array per column.

    Numeric columns are floats (``nan`` for a missing value), the others text (set,
    roll-off, cutoff). pandas' C parser reads them (xarray's own dependency: seven times
    faster than numpy's ``loadtxt`` on the stress table, the same numbers).
    """
    with resources.as_file(resources.files("xrough").joinpath(f"data/{name}")) as path:
        frame = pd.read_csv(path, comment="#", compression="infer", keep_default_na=False,
                            na_values=["nan"])
    return {col: (frame[col].to_numpy(dtype=float)
                  if pd.api.types.is_numeric_dtype(frame[col].dtype)
                  else frame[col].to_numpy(dtype=str)) for col in frame.columns}


@functools.cache
def stress_table() -> dict[str, np.ndarray]:
    """Read the study's stress table (``xrough/data/persson_stress_error.csv.gz``)."""
    return read_table("persson_stress_error.csv.gz")


#: Lags where Persson's fluctuating stress ACF ``G_sigma - p0^2`` has fallen below this
#: share of its value at the first lag are outside the stress model: there the solver's
#: is a small difference of large numbers (``<p p'>`` near ``p0^2``) and the ratio noise.
DECAY_MIN = 0.05


def _stress_variables(p_star, p_star_0, features) -> list[np.ndarray]:
    with np.errstate(divide="ignore", invalid="ignore"):
        return [*_variables(p_star, features), np.log(np.clip(p_star_0, 1e-300,
                                                              P_STAR_RANGE[1]))]


@functools.cache
def _stress_model() -> _Model:
    """Fit the expected ``ln(F / F_exact)`` of the stress ACF to the table, and its spread.

    As :func:`_model`, with ``ln p*`` at the map's finest lag a variable of its own (how
    much of the map touches sets the stress field at every lag). Chosen on the held-out
    set (``benchmarks/model_error_heldout.py``) over the lag in pixels, the decay of
    ``F``, quadratic polynomials and a larger :data:`DECAY_MIN`: the best calibrated.
    """
    t = stress_table()
    use = (t["decay"] >= DECAY_MIN) & (t["p_star"] <= P_STAR_RANGE[1] * (1 + 1e-9))
    for name in (*FEATURES, "ln_ratio", "p_star_0"):
        use &= np.isfinite(t[name])
    features = [t[name][use] for name in FEATURES]
    bounds = {name: (float(f.min()), float(f.max())) for name, f in zip(FEATURES, features)}
    return _build(_stress_variables(t["p_star"][use], t["p_star_0"][use], features),
                  t["ln_ratio"][use], t["open"][use].astype(float), _surfaces(t, use), bounds)


def stress_model_error(p_star, p_star_0, decay, *features, periodic=False
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Give the expected ``ln(F / F_exact)`` of Persson's stress ACF, and its spread.

    ``F = G_sigma - p0^2`` is the fluctuating part of the stress ACF of eq. 30/48 (``W =
    a_r``), ``F_exact`` the solver's.

    Parameters
    ----------
    p_star : array_like
        Reduced pressure ``p0 / (E* gbar(dr))`` at the lag.
    p_star_0 : array_like
        The same at the map's finest lag.
    decay : array_like
        ``F`` at the lag over ``F`` at the first lag where it has a value; below
        :data:`DECAY_MIN` the model has no data.
    *features : array_like
        G's shape at the lag, :data:`FEATURES` in order (:func:`features_on_lags`).
    periodic : bool or array_like
        A periodic map, else an open one.

    Returns
    -------
    bias, spread : numpy.ndarray
        ``ln(F / F_exact)`` expected and the solver's spread about it (one sigma); beyond
        ``p* = 0.5`` both fall as :func:`area_model_error`'s to 0 at full contact; NaN
        below ``p* = 1e-4``, below :data:`DECAY_MIN`, outside the study's shapes of G, or
        where an input is NaN.

    Examples
    --------
    >>> dr = np.geomspace(1, 1000, 40)
    >>> shape = features_on_lags(dr, dr**1.6 * np.exp(-dr / 300))[:, 4]
    >>> bias, spread = stress_model_error(0.01, 0.005, 0.5, *shape)
    >>> bool(np.isfinite(bias) and spread > 0)
    True
    """
    if len(features) != len(FEATURES):
        raise ValueError(f"give the {len(FEATURES)} features {FEATURES}")
    p, p_0, dec, is_open, *fs = np.broadcast_arrays(
        np.asarray(p_star, dtype=float), np.asarray(p_star_0, dtype=float),
        np.asarray(decay, dtype=float), 1.0 - np.asarray(periodic, dtype=float),
        *(np.asarray(f, dtype=float) for f in features))
    model = _stress_model()
    bad = ((outside_domain(p, *fs, model=model) != 0) | (p_0 < P_STAR_RANGE[0] * (1 - 1e-9))
           | ~(dec >= DECAY_MIN) | np.isnan(p) | np.isnan(p_0)
           | np.any(np.isnan(fs), axis=0))
    variables = [np.where(bad, np.nan, v) for v in _stress_variables(p, p_0, fs)]
    with np.errstate(invalid="ignore"):
        bias = _basis(variables, is_open) @ model.mean
        spread = model.factor * _neighbour_rms(model, variables, is_open)
        beyond = _toward_full_contact(p)
    return np.where(bad, np.nan, bias * beyond), np.where(bad, np.nan, spread * beyond)


def _toward_full_contact(p: np.ndarray) -> np.ndarray:
    """Give 1 up to ``p* = 0.5``, falling linearly in ``ln p*`` to 0 at full contact."""
    hi = P_STAR_RANGE[1]
    return np.clip(np.log(np.maximum(p, hi) / FULL_CONTACT_P_STAR)
                   / np.log(hi / FULL_CONTACT_P_STAR), 0.0, 1.0)


def outside_domain(p_star, *features, model: _Model | None = None) -> np.ndarray:
    """Say where the model has no data (0: inside; bit 1: p* below; bit 2: G's shape)."""
    p = np.asarray(p_star, dtype=float)
    model = _model("a_r") if model is None else model
    code = np.where(p < P_STAR_RANGE[0] * (1 - 1e-9), 1, 0)
    shape = np.zeros(np.broadcast(p, *features).shape, dtype=bool)
    for f, name in zip(features, FEATURES):
        lo, hi = model.bounds[name]
        margin = 0.02 * (hi - lo)
        f = np.asarray(f, dtype=float)
        shape |= ~((f >= lo - margin) & (f <= hi + margin))
    return (code | np.where(shape, 2, 0)).astype(np.int8)


def area_model_error(p_star, *features, periodic=False, area: str = "a_r"
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Give the expected ``ln(a / a_exact)`` of Persson's area, and its spread (1 sigma).

    Parameters
    ----------
    p_star : array_like
        Reduced pressures ``p0 / (E* gbar)`` at the resolution (any shape).
    *features : array_like
        G's shape there, :data:`FEATURES` in order (:func:`features_on_lags`), broadcast
        with ``p_star``.
    periodic : bool or array_like
        A periodic map (its exact solution from the periodic solver), else an open one
        (``G.attrs["periodic"]``).
    area : {'a_r', 'a_ri'}
        Eq. 29 with Persson's ``kappa = sqrt(8/pi)``, or eq. 50.

    Returns
    -------
    bias, spread : numpy.ndarray
        ``ln(a / a_exact)`` expected (negative: the theory's area is low) and the spread of
        the solver about it (:func:`_model`). Beyond ``p* = 0.5`` both fall linearly in
        ``ln p*`` to 0 at :data:`FULL_CONTACT_P_STAR`; NaN below ``p* = 1e-4``, where G's
        shape lies outside the table's (:func:`outside_domain`) or an input is NaN.

    Examples
    --------
    >>> dr = np.geomspace(1, 1000, 40)
    >>> rough, smooth = (features_on_lags(dr, dr**e * np.exp(-dr / 300))[:, 4]
    ...                  for e in (1.0, 1.6))
    >>> bias, spread = area_model_error([0.01, 0.01], *np.stack([rough, smooth], axis=1))
    >>> bool(bias[0] < bias[1] < 0)  # a rough map: the theory's area lower
    True
    """
    if area not in ("a_r", "a_ri"):
        raise ValueError(f"area must be 'a_r' or 'a_ri', got {area!r}")
    if len(features) != len(FEATURES):
        raise ValueError(f"give the {len(FEATURES)} features {FEATURES}")
    p, is_open, *fs = np.broadcast_arrays(
        np.asarray(p_star, dtype=float), 1.0 - np.asarray(periodic, dtype=float),
        *(np.asarray(f, dtype=float) for f in features))
    model = _model(area)
    variables = _variables(p, fs)
    bad = (outside_domain(p, *fs) != 0) | np.isnan(p) | np.any(np.isnan(fs), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        bias = _basis(variables, is_open) @ model.mean
        spread = model.factor * _neighbour_rms(
            model, [np.where(bad, np.nan, v) for v in variables], is_open)
        beyond = _toward_full_contact(p)
    return np.where(bad, np.nan, bias * beyond), np.where(bad, np.nan, spread * beyond)
