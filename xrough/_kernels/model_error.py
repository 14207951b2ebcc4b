"""The theory's own error: Persson's contact area against the boundary-element solver.

The table ``xrough/data/persson_area_error.csv`` holds the validation study of
docs/validation.md: the relative error ``a / a_sim - 1`` of Persson's ``a_r`` (eq. 29 with
``kappa = sqrt(8/pi)``) and of ``a_ri`` (eq. 50) against the solver, for H = 0.5 and 0.8,
bandwidths ``lambda_r / lambda_s`` = 16 to 256 and reduced pressures ``p*`` = 0.001 to 0.3
(its header names the commands that made it).  The error depends on ``p*`` far more than
on ``H`` or the bandwidth (at ``p* = 0.01``: -0.25 to -0.35 for ``a_r`` over all of them),
so :func:`area_model_error` gives, at each ``p*``, the mean over the table's
configurations and their spread, interpolated in ``ln p*`` (pure numpy).
"""

from __future__ import annotations

import functools
from importlib import resources

import numpy as np

__all__ = ["AREA_ERROR_PRESSURES", "AREA_ERROR_RANGE", "FULL_CONTACT_P_STAR", "area_table",
           "area_model_error"]

#: The reduced pressures of the table, and the range they cover.
AREA_ERROR_PRESSURES = np.array([0.001, 0.003, 0.01, 0.03, 0.1, 0.3])
AREA_ERROR_RANGE = (float(AREA_ERROR_PRESSURES[0]), float(AREA_ERROR_PRESSURES[-1]))
#: Beyond the table the error falls, linearly in ``ln p*``, to 0 where Persson's
#: ``a_r = erf(sqrt(2) p*)`` reaches 0.999 (full contact: no area left to miss).
FULL_CONTACT_P_STAR = 1.65


@functools.cache
def area_table() -> dict[str, np.ndarray]:
    """Read the validation table, one array per column (``xrough/data/persson_area_error.csv``)."""
    text = resources.files("xrough").joinpath("data/persson_area_error.csv").read_text()
    lines = [line for line in text.splitlines() if line and not line.startswith("#")]
    names = lines[0].split(",")
    rows = [[float(v) if v else np.nan for v in line.split(",")] for line in lines[1:]]
    return dict(zip(names, np.array(rows, dtype=float).T))


@functools.cache
def _by_pressure(area: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(p*, mean, spread)`` of ``<area>_error`` over the table's configurations.

    ``spread``: the largest distance of a configuration from the mean, or of a seed (one
    standard deviation of the seeds) from it.
    """
    table = area_table()
    err, sd = table[f"{area}_error"], np.nan_to_num(table[f"{area}_error_sd"])
    p = np.unique(table["p_star"])
    mean = np.array([err[table["p_star"] == v].mean() for v in p])
    spread = np.array([np.max(np.abs(err[table["p_star"] == v] - m) + sd[table["p_star"] == v])
                       for v, m in zip(p, mean)])
    return p, mean, spread


def area_model_error(p_star, area: str = "a_r") -> tuple[np.ndarray, np.ndarray]:
    """Relative error ``a / a_exact - 1`` of Persson's area at ``p*``, and its spread.

    Parameters
    ----------
    p_star : array_like
        Reduced pressures ``p0 / (E* gbar)`` (any shape; NaN stays NaN).
    area : {'a_r', 'a_ri'}
        Eq. 29 with Persson's ``kappa = sqrt(8/pi)``, or eq. 50.

    Returns
    -------
    error, spread : numpy.ndarray
        The mean over the table's configurations, interpolated in ``ln p*`` (held below
        ``p* = 0.001``, where it is flat; beyond ``p* = 0.3`` falling linearly in ``ln p*``
        to 0 at :data:`FULL_CONTACT_P_STAR`), and the spread of the configurations about it
        (scaled alike beyond 0.3).

    Examples
    --------
    >>> err, spread = area_model_error([0.01, 0.3])
    >>> print(np.round(err, 3))
    [-0.313 -0.149]
    """
    if area not in ("a_r", "a_ri"):
        raise ValueError(f"area must be 'a_r' or 'a_ri', got {area!r}")
    p, mean, spread = _by_pressure(area)
    x = np.log(np.clip(np.asarray(p_star, dtype=float), 1e-300, None))
    xs = np.log(np.append(p, FULL_CONTACT_P_STAR))
    err = np.interp(x, xs, np.append(mean, 0.0))
    unc = np.interp(x, xs, np.append(spread, 0.0))
    nan = np.isnan(np.asarray(p_star, dtype=float))
    return np.where(nan, np.nan, err), np.where(nan, np.nan, unc)
