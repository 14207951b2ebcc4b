"""Checks of numeric inputs shared by the kernels and the concept modules (pure numpy).

One rule, one place: every grid of lags or wavenumbers that a calculation walks along
(``dr`` of a G, ``q`` of a spectrum) must be finite, start at or above 0 and increase
strictly; :func:`require_increasing` says so, naming the argument and the first value
that breaks the rule.  A switch is True or False (:func:`require_flag`: not the string
``"no"``, which is true), a count a whole number (:func:`require_count`: not 64.5 cut to
64, nor the string ``"64"``), a threshold or factor a finite number above 0
(:func:`require_positive`: NaN, inf, 0 and negative values would turn a check off).
"""

from __future__ import annotations

import numpy as np

__all__ = ["require_increasing", "require_flag", "require_count", "require_positive"]


def require_flag(value, name: str) -> bool:
    """Return ``value`` as a bool if it is True or False (numpy bools, 0 and 1 too)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)) and value in (0, 1):
        return bool(value)
    raise ValueError(f"{name} must be True or False, got {value!r}")


def require_count(value, name: str, *, minimum: int = 0) -> int:
    """Return ``value`` as an int if it is a whole number ``>= minimum`` (no bool, str)."""
    whole = (isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)))
    if not whole and isinstance(value, (float, np.floating)) and float(value).is_integer():
        whole = True
    if not whole or value < minimum:
        raise ValueError(f"{name} must be a whole number of at least {minimum}, got {value!r}")
    return int(value)


def require_positive(value, name: str, *, meaning: str = "") -> float:
    """Return ``value`` as a float if it is a finite real number above 0."""
    ok = (isinstance(value, (int, float, np.integer, np.floating))
          and not isinstance(value, (bool, np.bool_)))
    if not ok or not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a finite number above 0{meaning}, got {value!r}")
    return float(value)


def _increasing_problem(x: np.ndarray, allow_zero: bool, min_size: int) -> str:
    """Return what breaks the rule of :func:`require_increasing` first ("" if nothing)."""
    if x.ndim != 1:
        return f"got shape {x.shape}"
    if x.size < min_size:
        return f"got {x.size}"
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        return f"got {x[bad[0]]} at index {bad[0]}"
    if x.size and (x[0] < 0 or (x[0] == 0 and not allow_zero)):
        return f"got {x[0]:g} first"
    down = np.flatnonzero(np.diff(x) <= 0)
    if down.size:
        i = down[0] + 1
        return f"got {x[i]:g} at index {i} after {x[i - 1]:g}"
    return ""


def require_increasing(x, name: str, *, allow_zero: bool = False, noun: str = "values",
                       min_size: int = 0, hint: str = "") -> np.ndarray:
    """Return ``x`` as a float array if it is finite, ``> 0`` and strictly increasing.

    Parameters
    ----------
    x : array_like
        The 1-D grid (lags in length, wavenumbers in 1/length; any unit).
    name : str
        The argument or coordinate in the message, e.g. ``"coordinate 'dr'"``.
    allow_zero : bool
        Accept a first value of 0 (``>= 0`` instead of ``> 0``).
    noun : str
        What the values are, in the message ("lags", "wavenumbers").
    min_size : int
        The fewest values accepted.
    hint : str
        Appended to the message (how to fix it).

    Returns
    -------
    numpy.ndarray
        ``x`` as float.

    Raises
    ------
    ValueError
        Naming ``name``, the rule and the first value that breaks it.

    Examples
    --------
    >>> require_increasing([0.0, 1.0, 2.0], "dr", allow_zero=True, noun="lags")
    array([0., 1., 2.])
    >>> try:
    ...     require_increasing([1.0, 3.0, 2.0], "dr", noun="lags")
    ... except ValueError as error:
    ...     print(error)
    dr must hold lags that are finite, positive and strictly increasing; got 2 at index 2 after 3
    """
    x = np.asarray(x, dtype=float)
    problem = _increasing_problem(x, allow_zero, min_size)
    if problem:
        count = f"at least {min_size} " if min_size > 1 else ""
        bound = ">= 0" if allow_zero else "positive"
        raise ValueError(f"{name} must hold {count}{noun} that are finite, {bound} and "
                         f"strictly increasing{hint}; {problem}")
    return x
