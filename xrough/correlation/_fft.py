"""All pairs by FFT: the kernel that sums G per bin for each map of a stack."""

from __future__ import annotations

import numpy as np

from .._kernels import binning, tiles
from .._kernels.pairs import (
    binned_map_sums,
    extremes,
    few_points_message,
    folded_pair_sums,
    map_kernel_applies,
    packed,
    require_no_inf,
    resolve_workers,
)
from ._plan import Plan, progress_bar


def fft_kernel(h: np.ndarray, *, plan: Plan, workers: int | None, progress,
               directional: bool = False) -> np.ndarray:
    """Map (..., *core) heights to their sums of G per kept bin, packed.

    ``directional`` (a radial G of a map only, :attr:`Plan.directional`): also the sums
    along each pixel axis, as two further blocks of bins (:func:`split_directions`).

    Each map is scaled by its own power of two (nearest its largest ``|h|``, see
    :func:`scaled_map`), so that no square of a height overflows; the sums are those of
    the scaled heights, and the exponent of each map is packed with them
    (:func:`xrough._kernels.pairs.packed`).
    """
    workers = resolve_workers(workers)  # in the thread that runs it (a dask task: 1)
    batch, flat = plan.maps(h)
    # the lags along each pixel axis are among the folded sums (free), as further blocks
    directional = directional and plan.directional
    sums = np.empty((flat.shape[0], (3 if directional else 1) * int(plan.keep.sum())))
    counts = np.empty_like(sums)
    nvalid = np.empty(flat.shape[0])
    exponents = np.zeros(flat.shape[0])
    bar = progress_bar(flat.shape[0], progress, "G(dr) by FFT")
    try:
        for b in range(flat.shape[0]):
            if map_kernel_applies(plan.shape, plan.ks, plan.periodic):
                exponents[b], complete = map_exponent(flat[b], b, batch, workers)
                sums[b], counts[b], nvalid[b] = _binned_sums(flat[b], int(exponents[b]),
                                                             plan, workers, directional,
                                                             complete)
                continue
            scaled, exponents[b] = scaled_map(flat[b], b, batch)
            sums[b], counts[b], nvalid[b] = _map_sums(scaled, plan, workers, directional)
            if nvalid[b] < 2:
                raise ValueError(few_points_message(b, batch))
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return packed(batch, 0.5 * sums, counts, np.zeros_like(sums), nvalid, exponents)


def _binned_sums(h: np.ndarray, exponent: int, plan: Plan, workers: int,
                 directional: bool, complete: bool | None = None):
    """:func:`_map_sums` of one map by :func:`~xrough._kernels.pairs.binned_map_sums`.

    The heights are read as they are (scaled block by block): no copy of the map, and no
    lag plane.
    """
    nb = len(plan.edges) - 1
    lines = tuple(idx for idx, _ in plan.axis_bins()) if directional else None
    s, n, nvalid = binned_map_sums(h, exponent, plan.ks, periodic=plan.periodic,
                                   index=plan.bin_index(), nbins=nb, lines=lines,
                                   workers=workers, complete=complete)
    blocks = 3 if directional else 1
    keep = np.tile(plan.keep, blocks)
    sums = 0.5 * s[keep]
    if n is not None:
        counts = 0.5 * n[keep]
    elif directional:
        counts = np.concatenate([plan.geometric_counts] + [
            0.5 * c[plan.keep] for _, c in plan.axis_bins()])
    else:
        counts = plan.geometric_counts
    return sums, counts, nvalid


def _map_sums(scaled: np.ndarray, plan: Plan, workers: int, directional: bool):
    """Return a map's sums of squares and pairs per kept bin, and its valid points."""
    idx = plan.bin_index()
    nb = len(plan.edges) - 1
    s, n = folded_pair_sums(scaled, plan.ks, periodic=plan.periodic, workers=workers)
    # the ordered pairs at lag 0 are the valid points themselves
    nvalid = np.prod(plan.shape) if n is None else n[(...,) + (0,) * len(plan.ks)].sum()
    if plan.lag_axes < len(plan.shape):  # pool the rows of a one-direction G
        s = s.sum(axis=0)
        n = None if n is None else n.sum(axis=0)
    # the folded sums run over ordered pairs (r, r+d) and (r, r-d): halve them to count
    # each unordered pair once
    sums = 0.5 * binning.binned_sum(s, idx, nb)[plan.keep]
    counts = (plan.geometric_counts if n is None else
              0.5 * binning.binned_sum(n, idx, nb)[plan.keep])
    if directional:  # lags along y (d_x = 0), then along x (d_y = 0)
        parts_s, parts_n = [sums], [counts]
        for a, (axis_idx, axis_counts) in enumerate(plan.axis_bins()):
            line = (slice(None), 0) if a == 0 else (0, slice(None))
            parts_s.append(0.5 * binning.binned_sum(s[line], axis_idx, nb)[plan.keep])
            parts_n.append(0.5 * (axis_counts if n is None else
                                  binning.binned_sum(n[line], axis_idx, nb))[plan.keep])
        sums, counts = np.concatenate(parts_s), np.concatenate(parts_n)
    return sums, counts, nvalid


def split_directions(sums: np.ndarray, nb: int) -> tuple[np.ndarray, ...]:
    """Packed sums of a radial FFT G as three packed arrays: radial, along y, along x.

    Without the directional blocks (random pairs, profiles, one direction) ``(sums,)``.
    """
    if sums.shape[-1] != 3 * (3 * nb) + 2:
        return (sums,)
    blocks = [sums[..., k * 3 * nb:(k + 1) * 3 * nb] for k in range(3)]  # gsum, counts, gsq
    tail = sums[..., -2:]
    return tuple(np.concatenate([b[..., d * nb:(d + 1) * nb] for b in blocks] + [tail],
                                axis=-1) for d in range(3))


def map_exponent(h: np.ndarray, index: int, batch: tuple[int, ...],
                 workers: int = 1) -> tuple[int, bool]:
    """Return the exponent of :func:`scaled_map` (no scaled copy) and whether the map is whole.

    Whether the map has no NaN comes from the same two passes.

    Raises
    ------
    ValueError
        Infinite heights, or fewer than 2 valid points (naming the map of a stack).
    """
    top, bottom = extremes(h, workers)  # NaN if any point is missing
    complete = not (np.isnan(top) or np.isnan(bottom))
    if not complete:
        top, bottom = np.fmax.reduce(h, axis=None), np.fmin.reduce(h, axis=None)
        if np.isnan(top):
            raise ValueError(few_points_message(index, batch))
    peak = max(float(top), -float(bottom))
    if np.isinf(peak):
        require_no_inf(h)
    return int(tiles.power_of_two_exponent(peak)), complete


def scaled_map(h: np.ndarray, index: int, batch: tuple[int, ...]) -> tuple[np.ndarray, int]:
    """One map as ``(h / 2**e, e)``, ``2**e`` the power of two nearest its largest ``|h|``.

    Raises
    ------
    ValueError
        Infinite heights, or fewer than 2 valid points (naming the map of a stack).
    """
    scaled, exponent = tiles.scaled_heights(h)
    if exponent is None:
        raise ValueError(few_points_message(index, batch))
    return scaled, exponent
