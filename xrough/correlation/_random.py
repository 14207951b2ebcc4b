"""Random pairs (paper section 3.1): the kernel that samples G per bin for each map."""

from __future__ import annotations

import numpy as np
import xarray as xr

from .._kernels.checks import require_count
from .._kernels.pairs import few_points_message, packed
from .._kernels.random_pairs import random_pair_sums, sampled_exponent, valid_points
from ._plan import Plan, progress_bar


def random_kernel(h: np.ndarray, seeds: np.ndarray, *, plan: Plan, n_per_bin: int,
                  progress) -> np.ndarray:
    """Sum G, G^2 and count random pairs per kept bin of each map, packed.

    Reads the drawn points and counts the valid ones in one pass
    (:func:`~xrough._kernels.random_pairs.valid_points`); no copy of the maps. Each map's
    heights are scaled by the power of two nearest the largest ``|h|`` of a regular sample
    of it (:func:`~xrough._kernels.random_pairs.sampled_exponent`), returned with the sums
    (:func:`xrough._kernels.pairs.packed`).
    """
    batch, maps = plan.maps(h)
    seeds = np.broadcast_to(seeds, batch).reshape(-1)
    nb = len(plan.edges) - 1
    out = np.empty((maps.shape[0], 3, int(plan.keep.sum())))
    nvalid = np.empty(maps.shape[0])
    exponents = np.zeros(maps.shape[0])
    bar = progress_bar(maps.shape[0] * nb, progress, "G(dr) by random pairs")
    try:
        for b in range(maps.shape[0]):
            nvalid[b] = valid_points(maps[b])
            if nvalid[b] < 2:
                raise ValueError(few_points_message(b, batch))
            exponents[b] = sampled_exponent(maps[b])
            rng = np.random.default_rng(int(seeds[b]))
            res = random_pair_sums(maps[b], plan.spacing, plan.edges, n_per_bin,
                                   periodic=plan.periodic, rng=rng,
                                   scale=np.ldexp(1.0, int(exponents[b])),
                                   progress=None if bar is None else bar.update)
            out[b] = res[:, plan.keep]
    finally:
        if bar is not None:
            bar.close()
    return packed(batch, out[:, 0], out[:, 2], out[:, 1], nvalid, exponents)


def check_n_pairs(n_pairs) -> int:
    """Return the random-pair budget, a positive integer."""
    return require_count(n_pairs, "n_pairs", minimum=1)


def map_seeds(da: xr.DataArray, extra: list, seed: int | None) -> xr.DataArray:
    """One seed per map along the extra dims (numpy and dask draw the same pairs)."""
    nmaps = int(np.prod([da.sizes[d] for d in extra])) if extra else 1
    seeds = np.random.SeedSequence(seed).generate_state(nmaps, dtype=np.uint64)
    return xr.DataArray(seeds.reshape([da.sizes[d] for d in extra]), dims=extra)
