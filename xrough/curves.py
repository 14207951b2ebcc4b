"""G(dr) curves: validate a height-difference ACF and turn it into numeric curves.

Every contact-mechanics function starts here: it checks that a DataArray is a G(dr)
(a ``dr`` dim with length units, data in length^2, non-negative, growing from zero rather
than decaying like a height ACF) and turns each curve into an
:class:`~xrough._kernels.acf_curve.AcfCurve` in metres, so that results come out in SI.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from . import units as u
from ._kernels.acf_curve import AcfCurve

__all__ = ["check_acf", "curves_si"]


def check_acf(G: xr.DataArray, *, what: str = "G") -> tuple[float, float]:
    """Check that ``G`` is a height-difference ACF; return SI factors for dr and G.

    Returns
    -------
    (length_factor, g_factor)
        Multiply ``dr`` by the first and ``G`` by the second to get metres and m^2.

    Raises
    ------
    ValueError
        Naming the problem: wrong type or dims, missing or wrong units, negative values,
        all-NaN, or a decaying curve (a height ACF instead of G).
    """
    if not isinstance(G, xr.DataArray):
        raise TypeError(f"{what} must be an xarray.DataArray, got {type(G).__name__}")
    if "dr" not in G.dims:
        raise ValueError(f"{what} needs a 'dr' dim (lag distance); got dims {G.dims}. "
                         "Compute it with topography.rough.acf()")
    lunit = u.as_length_unit(u.units_of(G["dr"], what="coordinate 'dr'"),
                             what="coordinate 'dr'")
    gunit = u.units_of(G, what=what)
    if gunit.dimensionality != (u.ureg.meter**2).dimensionality:
        raise ValueError(f"{what} must be in length^2 (a height-difference ACF), but its "
                         f"units are {u.format_units(gunit)!r}")
    dr = np.asarray(G["dr"].values, dtype=float)
    if np.any(~np.isfinite(dr)) or np.any(dr <= 0) or np.any(np.diff(dr) <= 0):
        raise ValueError("coordinate 'dr' must be positive, finite and increasing")
    if G.chunks is None:
        values = np.asarray(G.values, dtype=float)
        finite = np.isfinite(values)
        if not finite.any():
            raise ValueError(f"{what} is all NaN")
        if np.any(values[finite] < 0):
            raise ValueError(f"{what} has negative values: a height-difference ACF is "
                             "1/2 <(h(r) - h(r+dr))^2> >= 0")
        lines = values.reshape(-1, values.shape[G.get_axis_num("dr")]) if values.ndim == 1 \
            else np.moveaxis(values, G.get_axis_num("dr"), -1).reshape(-1, dr.size)
        for line in lines:
            ok = np.isfinite(line) & (line > 0)
            if ok.sum() >= 2 and line[ok][-1] < 0.5 * line[ok][0]:
                raise ValueError(
                    f"{what} decreases from {line[ok][0]:.3g} to {line[ok][-1]:.3g} over "
                    "dr: that is a height ACF <h(r) h(r+dr)>, not the height-difference ACF "
                    "G(dr) = sigma_h^2 - <h(r) h(r+dr)>"
                )
    return u.conversion_factor(lunit, "m"), u.conversion_factor(gunit, "m**2")


def curves_si(G: xr.DataArray) -> tuple[np.ndarray, list[AcfCurve], tuple[int, ...]]:
    """Check ``G`` and return its dr in metres and one :class:`AcfCurve` per line (SI).

    Extra dims are flattened in C order; the third value is their shape.
    """
    lf, gf = check_acf(G)
    G = G.transpose(..., "dr")
    dr = np.asarray(G["dr"].values, dtype=float) * lf
    values = np.asarray(G.values, dtype=float).reshape(-1, dr.size) * gf
    error = None
    if "standard_error" in G.coords:
        error = np.broadcast_to(G["standard_error"].transpose(..., "dr").values,
                                G.shape).reshape(-1, dr.size) * gf
    curves = [AcfCurve(dr, values[k], None if error is None else error[k])
              for k in range(values.shape[0])]
    return dr, curves, G.shape[:-1]
