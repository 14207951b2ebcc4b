"""What every command shares.

Errors and exit codes, output paths, numbers with units, warnings as one line each, JSON.
"""

from __future__ import annotations

import json
import os
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import SupportsFloat

import numpy as np
import xarray as xr

from .. import units as u
from ..io.archive import remove_stale_temporaries, temporary_name
from ..quality import QualityWarning

#: Exit status of a successful run.
EXIT_OK = 0
#: Exit status for bad input or data: unreadable file, wrong unit, failed computation.
EXIT_DATA = 1
#: Exit status for a usage error (unknown option, missing argument); argparse's own.
EXIT_USAGE = 2

#: numpy's floating-point warnings inside the computation: not news for the user.
_NUMERIC_NOISE = re.compile(r"encountered in|Mean of empty slice|Degrees of freedom <= 0")


class CLIError(ValueError):
    """A bad input or argument, reported as one line and exit status 1."""


def first_line(err: BaseException | str) -> str:
    """Return the first line of an error's message (empty if it has none)."""
    message = str(err).strip()
    return message.splitlines()[0] if message else ""


def fail(where: str, err: BaseException) -> CLIError:
    """Return a :class:`CLIError` whose one-line message names ``where`` (a file)."""
    message = first_line(err)
    strerror = getattr(err, "strerror", None)
    if isinstance(err, OSError) and strerror and not message.startswith(where):
        message = strerror.lower()
    if not message or not isinstance(err, (ValueError, OSError)):
        message = f"{type(err).__name__}{': ' + message if message else ''}"
    message = message.removeprefix(": ")  # a reader naming a folder's empty name
    name = Path(where).name
    if where in message or (name and name in message):
        return CLIError(message)
    return CLIError(f"{where}: {message}")


# --------------------------------------------------------------------- files out


def output(given: str, option: str = "-o", *, folder: bool = False) -> Path:
    """Return an output path whose folder exists (created if needed), or fail clearly."""
    path = Path(given)
    if not folder and path.is_dir():
        raise CLIError(f"{option} {given}: is a folder; give a file name")
    parent = path if folder else path.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        reason = (err.strerror or str(err)).lower()
        raise CLIError(f"{option} {given}: cannot create the folder {parent}: {reason}") from None
    if not parent.is_dir():
        raise CLIError(f"{option} {given}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise CLIError(f"{option} {given}: the folder {parent} is not writable")
    return path


def write_atomic(path: Path, write: Callable[[Path], object]) -> None:
    """Write through a temporary file in the same folder, renamed over ``path`` at the end.

    For writers that are not atomic themselves (figures, plain NetCDF files); archives
    are written by :func:`xrough.save_analysis`, which is. A failure leaves ``path`` as it
    was (absent or the previous file) and no debris.
    """
    tmp = temporary_name(path)
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    remove_stale_temporaries(path)  # what killed writes to ``path`` left behind


# ------------------------------------------------------------------ numbers, units


def _compact(value: float, unit: str):
    """``value unit`` as a pint Quantity with a readable prefix.

    :func:`xrough.units.compact`: powers of one unit get the prefix of their root
    (``3e6 nm2`` is ``3 um2``).
    """
    q = u.ureg.Quantity(value, u.parse_units(unit))
    if q.dimensionless and not str(q.units) == "dimensionless":
        q = q.to("dimensionless")
    if q.dimensionless or value == 0 or not np.isfinite(value):
        return q
    return u.compact(q)


def text(value: float, unit: str, *, digits: int = 4, none: str = "inf") -> str:
    """Format a number with its unit and a readable prefix: ``12.3 nm``, ``0.906``.

    Parameters
    ----------
    value : float
        The number, in ``unit``.
    unit : str
        Its unit (CF string; ``"1"`` for dimensionless).
    digits : int
        Significant digits.
    none : str
        Text for a non-finite value.
    """
    if not np.isfinite(value):
        return none
    q = _compact(float(value), unit)
    if q.dimensionless:
        return f"{q.to('dimensionless').magnitude:.{digits}g}"
    return f"{q.magnitude:.{digits}g} {q.units:~P}"


def units_of(da: xr.DataArray) -> str:
    return str(da.attrs.get("units", "1"))


def show(da: xr.DataArray, *, none: str = "inf", digits: int = 4) -> str:
    """Format a 0-d result variable in its own unit."""
    return text(float(da), units_of(da), none=none, digits=digits)


def exact_of(at: xr.Dataset, name: str
             ) -> tuple[xr.DataArray, xr.DataArray, xr.DataArray] | None:
    """Give the expected exact value of ``name`` and its one-sigma bounds, if any."""
    names = [f"{name}_exact", f"{name}_exact_lower", f"{name}_exact_upper"]
    if not all(n in at for n in names):
        return None
    return at[names[0]], at[names[1]], at[names[2]]


def show_errors(value: xr.DataArray, std: xr.DataArray | None = None,
                exact: tuple[xr.DataArray, xr.DataArray, xr.DataArray] | None = None, *,
                digits: int = 3, level: str | None = None) -> str:
    """Format a 0-d result with its statistical error and the expected exact value.

    ``0.0213 +-0.0002 (stat), exact 0.031 [0.029, 0.033]``: the standard deviation where it
    is given and finite, and ``exact = (expected, lower, upper)`` (the value a contact
    solver would give and its interval) where finite; all in the value's prefix, the unit
    once at the end. The interval is one-sigma (:func:`xrough.persson`) unless ``level``
    names another, which is then printed at the end (``[0.50, 0.61] nm (90 %)``:
    :func:`xrough.mean_gap`).
    """
    x = float(value)
    if not np.isfinite(x):
        return show(value, digits=digits)
    q = _compact(x, units_of(value))  # dimensionless ones already as plain numbers
    scale = q.magnitude / x if x else 1.0
    unit = "" if q.dimensionless else f" {q.units:~P}"
    text = f"{x * scale:.{digits}g}"
    if std is not None and np.isfinite(float(std)):
        text += f" +-{abs(float(std)) * scale:.2g} (stat)"
    if exact is not None and all(np.isfinite(float(v)) for v in exact):
        mid, lo, hi = (float(v) * scale for v in exact)
        text += f", exact {mid:#.{digits - 1}g} [{lo:#.{digits - 1}g}, {hi:#.{digits - 1}g}]"
        unit += f" ({level})" if level else ""
    return text + unit


def finite(value: SupportsFloat) -> float | None:
    number = float(value)
    return number if np.isfinite(number) else None


def number(da: xr.DataArray | float, unit: str | None = None) -> dict:
    """``{"value": ..., "units": ...}`` for JSON (``null`` for a non-finite value)."""
    if isinstance(da, xr.DataArray):
        return {"value": finite(da), "units": unit or units_of(da)}
    return {"value": finite(da), "units": unit or "1"}


def array(da: xr.DataArray) -> dict:
    return {"values": [finite(v) for v in np.asarray(da.values, dtype=float).ravel()],
            "units": units_of(da)}


def finest(contact: xr.Dataset) -> xr.Dataset:
    """Return Persson theory at the smallest lag where it is determined.

    Below that lag it is NaN: the Laplacian of G is not determined there, or the lag
    lies outside a reliable window.
    """
    determined = np.flatnonzero(np.isfinite(contact.a_r.values)
                                & np.isfinite(contact.sigma_c.values))
    return contact.isel(dr=int(determined[0]) if determined.size else 0)


# -------------------------------------------------------------------- warnings, JSON


def warn_lines(where: str, caught) -> list[str]:
    """Print caught warnings as one line each on stderr; return their texts.

    Quality warnings are left out: the results carry them (``quality_notes``), and the
    report prints them under its table.
    """
    texts = []
    for w in caught:
        message = " ".join(str(w.message).split())
        if _NUMERIC_NOISE.search(message) or issubclass(w.category, QualityWarning):
            continue
        if message not in texts:
            texts.append(message)
            print(f"xrough: warning: {where}: {message}", file=sys.stderr)
    return texts


def show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Show a warning outside a file's processing as one line on stderr."""
    message = " ".join(str(message).split())
    if not _NUMERIC_NOISE.search(message):
        print(f"xrough: warning: {message}", file=sys.stderr)


def jsonable(obj):
    """Plain JSON values: numpy scalars and arrays as numbers and lists, NaN as null."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, (np.ndarray, np.generic)):
        return jsonable(obj.tolist())
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if obj is None or isinstance(obj, (str, int, bool)):
        return obj
    return str(obj)


def emit_json(obj: dict) -> None:
    print(json.dumps(jsonable(obj), indent=2, allow_nan=False))
