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
the fit in turn (fitted once per process, in 0.1 s). Outside the table's range of ``p*``
and of G's shape it is NaN, with the reason (:func:`outside_domain`).
"""

from __future__ import annotations

import functools
import itertools
from importlib import resources
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["FEATURES", "features_of", "features_on_lags", "P_STAR_RANGE",
           "FULL_CONTACT_P_STAR", "MIN_PIXELS", "area_table", "area_model_error",
           "outside_domain"]

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
    text = resources.files("xrough").joinpath("data/persson_area_error.csv").read_text()
    lines = [line for line in text.splitlines() if line and not line.startswith("#")]
    names = lines[0].split(",")
    columns = list(zip(*(line.split(",") for line in lines[1:])))
    out = {}
    for name, col in zip(names, columns):
        try:
            out[name] = np.array([float(v) if v else np.nan for v in col])
        except ValueError:  # a text column (set, roll-off, cutoff)
            out[name] = np.array(col)
    return out


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

    ``r_g = (I - H_gg)^-1 (y_g - X_g b)`` with ``H = X (X'X)^-1 X'`` (the fit ``b`` to all
    rows): what a surface the fit has not seen would be missed by.
    """
    b, *_ = np.linalg.lstsq(X, y, rcond=None)
    inv = np.linalg.pinv(X.T @ X)
    r = y - X @ b
    out = np.empty_like(r)
    for g in np.unique(groups):
        idx = np.flatnonzero(groups == g)
        Xg = X[idx]
        out[idx] = np.linalg.solve(np.eye(idx.size) - Xg @ inv @ Xg.T, r[idx])
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
    is_open = t["open"][use].astype(float)
    variables = _variables(t["p_star"][use], features)
    y = np.log(t[area][use] / t["contact_area"][use])
    X = _basis(variables, is_open)
    mean = np.linalg.lstsq(X, y, rcond=None)[0]
    surface = np.unique(np.stack([t[c][use].astype(str) for c in SURFACE], axis=1), axis=0,
                        return_inverse=True)[1].ravel()
    r = held_out_residuals(X, y, surface)
    scale = np.array([np.std(v) for v in variables])
    points = np.stack(variables, axis=-1) / scale
    trees = {flag: (cKDTree(points[is_open == flag]), r[is_open == flag])
             for flag in np.unique(is_open)}
    model = _Model(mean, scale, trees, 1.0, {
        name: (float(f.min()), float(f.max())) for name, f in zip(FEATURES, features)})
    factor = float(np.median(np.abs(r) / _neighbour_rms(model, variables, is_open)) / 0.6745)
    return model._replace(factor=factor)


def outside_domain(p_star, *features) -> np.ndarray:
    """Say where the model has no data (0: inside; bit 1: p* below; bit 2: G's shape)."""
    p = np.asarray(p_star, dtype=float)
    model = _model("a_r")
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
    hi = P_STAR_RANGE[1]
    variables = _variables(p, fs)
    bad = (outside_domain(p, *fs) != 0) | np.isnan(p) | np.any(np.isnan(fs), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        bias = _basis(variables, is_open) @ model.mean
        spread = model.factor * _neighbour_rms(
            model, [np.where(bad, np.nan, v) for v in variables], is_open)
        beyond = np.clip(np.log(np.maximum(p, hi) / FULL_CONTACT_P_STAR)
                         / np.log(hi / FULL_CONTACT_P_STAR), 0.0, 1.0)
    return np.where(bad, np.nan, bias * beyond), np.where(bad, np.nan, spread * beyond)
