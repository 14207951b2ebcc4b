"""Lag distances of the spectral functions: ``dr`` in one length unit and ``gbar(dr)``.

Shared by :mod:`xrough.spectra` (functions of a spectrum) and :mod:`xrough.spectrum_from_acf`
(functions of G): ``dr`` given as numbers, a pint Quantity or a DataArray, logarithmic
grids, and the DataArray of the scale-dependent rms gradient (eq. 26) that both return.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pint
import xarray as xr

from . import units as _units


def _lag_values(dr: Any, length_unit: pint.Unit) -> np.ndarray:
    """1-D lags ``>= 0`` in ``length_unit`` (plain numbers are in it already)."""
    return _units.array_in(dr, length_unit, what="dr", noun="distances")


def _log_range(lo: float, hi: float, points_per_decade: float) -> np.ndarray:
    """Logarithmic grid from ``lo`` to ``hi`` with at least ``points_per_decade``."""
    n = max(2, int(np.ceil(points_per_decade * np.log10(hi / lo))) + 1)
    return np.geomspace(lo, hi, n)


def _gradient_da(gbar: np.ndarray, dr: np.ndarray, unit_str: str, attrs: dict) -> xr.DataArray:
    """``gbar(dr)`` (eq. 26) as a DataArray on dim ``"dr"`` in ``unit_str``."""
    return xr.DataArray(
        gbar,
        dims=("dr",),
        coords={"dr": ("dr", dr, {"units": unit_str, "long_name": "lag distance"})},
        name="gbar",
        attrs={"units": "1", "long_name": "scale-dependent rms gradient",
               "equation": "eq. 26", **attrs},
    )
