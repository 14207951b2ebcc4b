"""Bins and plan shared by every estimator of G: lag-bin edges, lattice geometry, the stack."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import units as u
from .._kernels import binning
from .._kernels.pairs import binned_geometry, folded_geometric_counts
from ..progress import progress_bar as bar
from ..topography import Grid

DIRECTIONS = ("radial", "x", "y")
#: More linear bins than this would be mostly empty and cost memory without information.
MAX_BINS = 100_000


@dataclass(frozen=True)
class Plan:
    """What the kernel needs: which axes are transformed, lags, bins, geometry."""

    core_dims: tuple[str, ...]  # dims handed to the kernel, in kernel order
    shape: tuple[int, ...]  # kernel core shape
    lag_axes: int  # number of trailing axes with lags (1 or 2)
    spacing: tuple[float, ...]  # spacing of the lag axes
    periodic: bool
    ks: tuple[int, ...]
    edges: np.ndarray
    keep: np.ndarray  # bins that contain at least one lattice lag
    dr: np.ndarray  # pair-weighted mean lag distance of the kept bins
    geometric_counts: np.ndarray  # pairs per kept bin on a map without missing points

    @property
    def geometry(self) -> str:
        """How the bins average (:func:`lag_geometry`)."""
        return lag_geometry(len(self.shape), self.lag_axes)

    def bin_index(self) -> np.ndarray:
        """Bin of each folded lag of the lag axes (cached with the plan's geometry)."""
        return binned_geometry(self.shape[-self.lag_axes:], self.spacing, self.periodic,
                               self.ks, tuple(self.edges.tolist()))[0]

    @property
    def directional(self) -> bool:
        """Whether the FFT also sums G along the two pixel axes (a radial G of a map)."""
        return self.lag_axes == 2

    def axis_bins(self) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
        """Per lag axis (kernel order): the bin of each lag along it, and pairs per bin.

        The pairs are those of a complete map, ordered, as :func:`binned_geometry` counts.
        """
        out = []
        edges = tuple(self.edges.tolist())
        for a in range(2):
            other = 1 - a
            idx, counts, _ = binned_geometry((self.shape[-2 + a],), (self.spacing[a],),
                                             self.periodic, (self.ks[a],), edges)
            # the lags along axis a have lag 0 along the other axis: every line of it
            rows = folded_geometric_counts((self.shape[-2 + other],), (self.ks[other],),
                                           self.periodic)[0]
            out.append((idx, counts * rows))
        return tuple(out)

    def maps(self, h: np.ndarray) -> tuple[tuple[int, ...], np.ndarray]:
        """Split kernel input ``(..., *core)`` into its batch shape and a flat stack of maps."""
        batch = h.shape[: h.ndim - len(self.shape)]
        return batch, h.reshape((-1,) + self.shape)


def lag_geometry(ndim: int, lag_axes: int) -> str:
    """How the bins average: ``'profile'``, ``'radial'`` or ``'axis'`` (one direction)."""
    return "profile" if ndim == 1 else "radial" if lag_axes == 2 else "axis"


def check_bin_width(bins, bin_width) -> None:
    """Refuse a ``bin_width`` with bins other than ``'linear'``."""
    if bin_width is not None and not (isinstance(bins, str) and bins == "linear"):
        raise ValueError("bin_width applies to bins='linear' only")


def _length(value, lateral_unit: str, what: str) -> float | None:
    return None if value is None else u.length_in(value, lateral_unit, what=what,
                                                  positive=False)


def _explicit_edges(bins, lateral_unit: str) -> np.ndarray:
    edges = u.array_in(bins, lateral_unit, what="bins", noun="bin edges")
    if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0) or edges[0] < 0:
        raise ValueError("bin edges must be a 1D increasing array of >= 2 lags >= 0")
    return edges


def _linear_edges(lo: float, hi_edge: float, hi: float, spacing, lateral_unit: str,
                  bin_width) -> np.ndarray:
    width = min(spacing) if bin_width is None else u.length_in(
        bin_width, lateral_unit, what="bin_width", positive=False)
    n_bins = (hi_edge - lo) / width
    if n_bins > MAX_BINS:
        raise ValueError(
            f"bin_width={width:g} {lateral_unit} gives {n_bins:.3g} linear bins between "
            f"{lo:g} and {hi:g} {lateral_unit}; at most {MAX_BINS:,} are allowed (the "
            f"lattice has no more distinct lags than that: use a bin_width of at least "
            f"{(hi_edge - lo) / MAX_BINS:.3g} {lateral_unit})")
    return binning.linear_bin_edges(lo, hi_edge, width)


def bin_edges(lag_shape: tuple[int, ...], spacing: tuple[float, ...], periodic: bool,
              lateral_unit: str, *, bins, points_per_decade, bin_width, dr_min,
              dr_max) -> np.ndarray:
    """Lag-bin edges (lateral unit) for the lag axes of a grid, as every estimator uses.

    Defaults: ``dr_min`` one pixel, ``dr_max`` half the period (periodic) or the scan
    length (open); ``dr_max`` itself is included. ``points_per_decade`` follows the one
    rule of :func:`xrough._kernels.binning.check_points_per_decade`, whatever ``bins``.
    """
    binning.check_points_per_decade(points_per_decade)
    lo = _length(dr_min, lateral_unit, "dr_min")
    hi = _length(dr_max, lateral_unit, "dr_max")
    if periodic:
        longest = min(n * d for n, d in zip(lag_shape, spacing)) / 2
    else:
        longest = max((n - 1) * d for n, d in zip(lag_shape, spacing))
    lo = min(spacing) if lo is None else lo
    hi = longest if hi is None else min(hi, np.sqrt(sum(((n - 1) * d) ** 2 for n, d in
                                                         zip(lag_shape, spacing))))
    if not isinstance(bins, str):
        return _explicit_edges(bins, lateral_unit)
    if not (lo > 0 and hi >= lo and (hi > lo or dr_min is None)):
        raise ValueError(f"need 0 < dr_min < dr_max; got dr_min={lo:g}, dr_max={hi:g} "
                         f"{lateral_unit} (largest lag on this grid: {longest:g})")
    hi_edge = hi * (1 + 1e-12)  # include dr_max itself
    if bins == "log":
        return binning.log_bin_edges(lo, hi_edge, points_per_decade)
    if bins == "linear":
        return _linear_edges(lo, hi_edge, hi, spacing, lateral_unit, bin_width)
    raise ValueError(f"bins must be 'log', 'linear' or an array of edges, got {bins!r}")


def _core(grid: Grid, direction: str) -> tuple[tuple[str, ...], int]:
    """Dims handed to the kernel (lag axes last) and the number of lag axes."""
    if direction not in DIRECTIONS:
        raise ValueError(f"direction must be one of {DIRECTIONS}, got {direction!r}")
    if len(grid.dims) == 1:
        if direction == "y":
            raise ValueError("a profile has no 'y' direction; use direction='x'")
        return ("x",), 1
    return {"radial": (("y", "x"), 2), "x": (("y", "x"), 1), "y": (("x", "y"), 1)}[direction]


def plan(grid: Grid, *, direction: str, bins, points_per_decade, bin_width, dr_min,
         dr_max) -> Plan:
    """Plan of the in-memory estimators (FFT, random pairs) for a grid and options."""
    core, lag_axes = _core(grid, direction)
    sp = dict(zip(grid.dims, grid.spacing))
    shape_all = dict(zip(grid.dims, grid.shape))
    shape = tuple(shape_all[d] for d in core)
    spacing = tuple(sp[d] for d in core[-lag_axes:])
    lag_shape = shape[-lag_axes:]
    edges = bin_edges(lag_shape, spacing, grid.periodic, grid.lateral_unit, bins=bins,
                      points_per_decade=points_per_decade, bin_width=bin_width,
                      dr_min=dr_min, dr_max=dr_max)
    ks = binning.max_lags(lag_shape, spacing, grid.periodic, edges[-1])
    _, counts, rsum = binned_geometry(lag_shape, spacing, grid.periodic, ks,
                                      tuple(edges.tolist()))
    keep = counts > 0
    if not keep.any():
        raise ValueError(f"no lattice lag between {edges[0]:g} and {edges[-1]:g} "
                         f"{grid.lateral_unit}")
    mean_dr = rsum[keep] / counts[keep]
    counts = counts / 2  # unordered pairs
    if lag_axes < len(shape):  # one-direction G of a map: every row contributes
        counts = counts * shape[0]
    return Plan(core_dims=core, shape=shape, lag_axes=lag_axes, spacing=spacing,
                periodic=grid.periodic, ks=ks, edges=edges, keep=keep,
                dr=mean_dr, geometric_counts=counts[keep])


@dataclass(frozen=True)
class OpenMapBins:
    """Radial bins of one open map, from the row-blocked lattice counts (no lag plane)."""

    edges: np.ndarray
    ks: tuple[int, ...]  # largest lag index per axis
    keep: np.ndarray  # bins that contain at least one lattice lag
    dr: np.ndarray  # pair-weighted mean lag distance of the kept bins
    pairs: np.ndarray  # unordered pairs per kept bin on a map without missing points


def open_map_bins(grid: Grid, *, bins, points_per_decade, bin_width, dr_min,
                  dr_max) -> OpenMapBins:
    """Radial bins of an open map for the tiled estimator (and the choice that weighs it)."""
    edges = bin_edges(grid.shape, grid.spacing, False, grid.lateral_unit, bins=bins,
                      points_per_decade=points_per_decade, bin_width=bin_width,
                      dr_min=dr_min, dr_max=dr_max)
    ks = binning.max_lags(grid.shape, grid.spacing, False, edges[-1])
    geo, rsum = binning.lattice_bin_counts(tuple(grid.shape), tuple(grid.spacing), ks,
                                           tuple(edges.tolist()))
    keep = geo > 0
    if not keep.any():
        raise ValueError("no lattice lag in the requested dr range")
    return OpenMapBins(edges=edges, ks=ks, keep=keep, dr=rsum[keep] / geo[keep],
                       pairs=geo[keep] / 2)


def progress_bar(total: int, progress, desc: str):
    """Return a tqdm bar over ``total`` steps, or None (off, or one step by default)."""
    if progress is False or total <= 1 and progress is None:
        return None
    return bar(desc=desc, progress=progress, total=total)
