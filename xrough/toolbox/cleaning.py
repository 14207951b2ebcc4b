"""Do the results depend on how the map was cleaned? The chain run once per choice.

A stated error covers what another region of the same surface would give
(:mod:`xrough.correlation`), not what another cleaning of the same heights gives. The
levelling of an AFM map is such a choice: a plane through the whole map, or a line
through each scan line (which removes the offsets between lines, and with them any
roughness along the slow axis at the scale of a line). Where the two give results
further apart than their errors, the result rests on the choice, and a reader must be
told which was made and what the other gives.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import xarray as xr

from .. import quality
from .. import units as u
from ..acf import result_attrs
from ..preprocess import detrend, mask_outliers
from ..topography import grid_of
from ..units import QuantityLike

#: The choices compared by default: the levelling of a map (a plane, a line per scan
#: line) and, with the plane, the outliers masked (``mask_outliers(threshold=5)``).
CHOICES: dict[str, Callable[[xr.DataArray], xr.DataArray]] = {
    "plane": lambda t: detrend(t, mode="plane"),
    "line by line": lambda t: detrend(t, mode="plane", per_line=True),
    "plane, outliers masked": lambda t: mask_outliers(detrend(t, mode="plane"),
                                                      threshold=5.0),
}
#: Results compared, with the variable of the chain they come from.
QUANTITIES = ("gbar", "v_el", "a_r", "hurst")
#: Two choices differ when their results are further apart than this many combined
#: standard deviations (the z of two independent estimates).
DIFFER = 3.0


def _chain(topo: xr.DataArray, E_star, p0) -> dict[str, Any]:
    """G, fit, gradient, energy and Persson theory of one cleaned map, quietly."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", quality.QualityWarning)
        G = topo.rough.acf()
        fit = G.rough.fit()
        gbar = G.rough.gradient(fit=fit)
        return {"G": G, "fit": fit, "gradient": gbar,
                "energy": G.rough.energy(E_star=E_star),
                "persson": G.rough.persson(E_star=E_star, p0=p0, gradient=gbar, fit=fit)}


def _lag(chain: dict) -> int | None:
    """Index of the finest lag where Persson theory (and gbar) has a number."""
    a_r = chain["persson"].a_r.values.reshape(-1, chain["persson"].sizes["dr"])[0]
    ok = np.flatnonzero(np.isfinite(a_r) & np.isfinite(chain["gradient"].values))
    return int(ok[0]) if ok.size else None


def _values(chain: dict, k: int | None) -> dict[str, tuple[float, float]]:
    """``name: (value, std)`` of :data:`QUANTITIES` (at lag index ``k``)."""
    def at(da):
        return float(da.values.reshape(-1)[0] if da.ndim == 0 else
                     np.nan if k is None else da.isel(dr=k).values.reshape(-1)[0])

    gbar, energy, fit = chain["gradient"], chain["energy"], chain["fit"]
    a_r = chain["persson"].a_r
    a_r = a_r.isel({d: 0 for d in a_r.dims if d != "dr"})
    a_r_std = chain["persson"].a_r_std.isel({d: 0 for d in a_r.dims if d != "dr"})
    return {"gbar": (at(gbar), at(gbar.gbar_std)),
            "v_el": (at(energy.v_el), at(energy.v_el_std)),
            "a_r": (at(a_r), at(a_r_std)),
            "hurst": (at(fit.hurst), at(fit.hurst_std))}


@u.accepts_quantified
def cleaning_sensitivity(topography: xr.DataArray, *, E_star: QuantityLike,
                         p0: QuantityLike,
                         choices: Mapping[str, Callable[[xr.DataArray], xr.DataArray]]
                         | None = None) -> xr.Dataset:
    """Results of the chain for each cleaning choice of one map, and whether they differ.

    Each choice cleans the heights as read; then G (eq. 1), its fit, the rms gradient
    (eq. 26), the elastic energy (eq. 16) and Persson theory (eq. 29) are computed as
    usual. The results are compared at one lag: the finest where Persson theory of the
    first choice has a number (inside the instrument's window). Two choices differ in a
    result when ``|a - b| / sqrt(std_a^2 + std_b^2)`` exceeds :data:`DIFFER`: the result
    rests on the choice, beyond what another region of the surface would change.

    Parameters
    ----------
    topography : xarray.DataArray with dims ("y", "x")
        One map, as read (not yet levelled), with units.
    E_star, p0 : float, str or Quantity
        Contact modulus and mean pressure (Pa for numbers), as for :func:`xrough.persson`
        (one ``p0``).
    choices : mapping of name to function, optional
        Cleaning functions of a topography; default :data:`CHOICES` (a plane, a line per
        scan line, a plane with outliers masked). The first is the reference.

    Returns
    -------
    xarray.Dataset
        On dim ``choice``: ``gbar`` (at the lag ``dr``, a coordinate), ``v_el`` (J m-2),
        ``a_r`` (at ``dr``), ``hurst``, each with ``<name>_std`` and ``z_<name>`` (against
        the first choice), and ``chain_quality`` (the worst level of each choice's
        results, 0 good, 1 questionable, 2 failed). Attrs ``quality`` and
        ``quality_notes``: questionable where a choice moves a result beyond
        :data:`DIFFER` (the note names the choice and both values), and one
        :class:`~xrough.QualityWarning`.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> topo = xrough.self_affine_surface(hurst=0.7, lambda_r="64 nm", lambda_s="4 nm",
    ...                                   size="256 nm", n=256, rms_gradient=0.2, seed=1,
    ...                                   unit="nm")
    >>> rows = np.arange(256)[:, None] * 0.0 + np.random.default_rng(0).normal(
    ...     scale=2.0, size=(256, 1))           # offsets between scan lines
    >>> scan = topo + rows                      # as an AFM records it
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     found = cleaning_sensitivity(scan, E_star="25 MPa", p0="0.1 MPa")
    >>> found.choice.values.tolist()[:2], found.attrs["quality"]
    (['plane', 'line by line'], 'questionable')
    """
    grid = grid_of(topography)
    if len(grid.dims) != 2 or topography.ndim != 2:
        raise ValueError("cleaning_sensitivity compares the cleaning of one map (dims "
                         f"('y', 'x')); got dims {topography.dims}")
    E = u.positive_si(E_star, "[pressure]", what="E_star")
    p = u.positive_si(p0, "[pressure]", what="p0")
    choices = dict(CHOICES if choices is None else choices)
    if len(choices) < 2:
        raise ValueError(f"choices: give at least two ways to clean, got {list(choices)}")
    chains = {name: _chain(clean(topography), E, p) for name, clean in choices.items()}
    first = next(iter(chains.values()))
    k = _lag(first)
    values = {name: _values(chain, k) for name, chain in chains.items()}
    names = list(chains)
    dr_unit = first["G"].dr.attrs["units"]
    dr = float(first["G"].dr.values[k]) if k is not None else np.nan
    units = {"gbar": "1", "v_el": "J m-2", "a_r": "1", "hurst": "1"}
    long = {"gbar": "rms gradient at dr (eq. 26)", "v_el": "elastic energy of full "
            "contact (eq. 16)", "a_r": "relative contact area at dr (eq. 29)",
            "hurst": "Hurst exponent (fit of G)"}
    data: dict[str, Any] = {}
    notes = []
    for q in QUANTITIES:
        v = np.array([values[n][q][0] for n in names])
        s = np.array([values[n][q][1] for n in names])
        with np.errstate(invalid="ignore", divide="ignore"):
            z = (v - v[0]) / np.hypot(s, s[0])
        data[q] = ("choice", v, {"units": units[q], "long_name": long[q]})
        data[f"{q}_std"] = ("choice", s, {"units": units[q],
                                          "long_name": f"standard deviation of {q}"})
        data[f"z_{q}"] = ("choice", z, {"units": "1", "long_name": f"({q} - {q} of "
                                        f"{names[0]!r}) over their combined std"})
        for n, zi, vi, si in zip(names[1:], z[1:], v[1:], s[1:]):
            if np.isfinite(zi) and abs(zi) > DIFFER:
                where = "" if q in ("v_el", "hurst") else f" at dr = {dr:.4g} {dr_unit}"
                notes.append(f"{q} depends on the cleaning{where}: {n!r} gives {vi:.4g} "
                             f"+- {si:.2g}, {names[0]!r} {v[0]:.4g} +- {s[0]:.2g} (z = "
                             f"{zi:+.1f}), beyond what another region of the surface "
                             "would change: state the cleaning with the result")
    data["chain_quality"] = ("choice", np.array(
        [quality.level_code(quality.worst(*(c[key] for key in c))) for c in chains.values()],
        dtype=np.int8), {"long_name": "worst level of the choice's results", "units": "1",
                         **quality.cf_flags(quality.LEVELS, np.int8)})
    ds = xr.Dataset(data, coords={"choice": names, "dr": ((), dr, {
        "units": dr_unit, "long_name": "lag of gbar and a_r (finest where Persson theory "
        "of the first choice has a number)"})}, attrs=result_attrs(
            topography, long_name="results of the chain for each cleaning choice",
            E_star=E, p0=p, threshold=DIFFER))
    if notes:
        ds = quality.mark(ds, quality.SEPARATOR.join(notes), what="cleaning_sensitivity")
    return ds
