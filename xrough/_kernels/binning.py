"""Bins in lag distance and the lattice geometry of lags (pure numpy).

Lags live on the grid's lattice: ``d = (i dy, j dx)`` for maps, ``d = j dx`` for profiles.
Because ``G(d) = G(-d)`` (squared differences are symmetric), pair sums are kept on the
*folded* quarter plane ``i, j >= 0``: entry ``(i, j)`` holds the sum over the distinct lag
vectors ``(+-i, +-j)``. The multiplicity of each entry (1, 2 or 4, less on a periodic
Nyquist line where ``-i`` and ``i`` are the same lag) is what :func:`lag_multiplicity`
returns.
"""

from __future__ import annotations

import functools
import numbers

import numpy as np

__all__ = ["MAX_POINTS_PER_DECADE", "check_points_per_decade", "log_range",
           "decade_aligned_grid", "log_bins", "log_bin_edges", "linear_bin_edges",
           "lag_multiplicity", "lag_radius2", "bin_index", "folded_bin_index", "binned_sum",
           "max_lags", "lattice_bin_counts"]

#: Densest logarithmic grid accepted: 1000 points per decade are bins 0.23 % wide,
#: narrower than the step between the lags of a profile up to 434 pixels
#: (``10**(1/1000) = 1 + 1/434``) and than anything G or C varies over; a larger number is
#: a typing error (and 1e9 would allocate gigabytes).
MAX_POINTS_PER_DECADE = 1000


def check_points_per_decade(value) -> float:
    """Return ``points_per_decade`` as a float, the one rule of every log grid in xrough.

    A real number, finite, above 0 and at most :data:`MAX_POINTS_PER_DECADE`.

    Raises
    ------
    ValueError
        Anything else, naming the argument.

    Examples
    --------
    >>> from xrough._kernels.binning import check_points_per_decade
    >>> check_points_per_decade(10)
    10.0
    >>> check_points_per_decade(0)
    Traceback (most recent call last):
    ...
    ValueError: points_per_decade must be a positive number up to 1000, got 0
    """
    ok = (isinstance(value, numbers.Real) and not isinstance(value, bool)
          and np.isfinite(float(value)) and 0 < float(value) <= MAX_POINTS_PER_DECADE)
    if not ok:
        raise ValueError(f"points_per_decade must be a positive number up to "
                         f"{MAX_POINTS_PER_DECADE}, got {value!r}")
    return float(value)


def log_range(lo: float, hi: float, points_per_decade: float) -> np.ndarray:
    """Logarithmic grid from ``lo`` to ``hi`` with at least ``points_per_decade``."""
    n = max(2, int(np.ceil(points_per_decade * np.log10(hi / lo))) + 1)
    return np.geomspace(lo, hi, n)


def decade_aligned_grid(lo: float, hi: float, points_per_decade: float) -> np.ndarray:
    """Return the points ``10**(k / points_per_decade)`` that just cover ``[lo, hi]``.

    From the last point at or below ``lo`` to the first at or above ``hi``.

    Parameters
    ----------
    lo, hi : float
        Positive ends to cover, ``lo < hi``.
    points_per_decade : float
        Density of the grid.

    Returns
    -------
    numpy.ndarray
        At least two increasing points. Aligned to whole decades, so for an integer
        ``points_per_decade`` the grid in another unit (a power of ten) is the same grid
        converted, and ends that differ by round-off pick the same points.

    Examples
    --------
    >>> from xrough._kernels.binning import decade_aligned_grid
    >>> decade_aligned_grid(0.15, 0.9, 10).round(4).tolist()
    [0.1259, 0.1585, 0.1995, 0.2512, 0.3162, 0.3981, 0.5012, 0.631, 0.7943, 1.0]
    """
    ppd = float(points_per_decade)
    k0 = int(np.floor(np.log10(lo) * ppd))
    k1 = max(int(np.ceil(np.log10(hi) * ppd)), k0 + 1)
    return 10.0 ** (np.arange(k0, k1 + 1) / ppd)


def log_bin_numbers(dr_min: float, dr_max: float, points_per_decade: float) -> np.ndarray:
    """Return the numbers ``k`` of the log bins that cover ``[dr_min, dr_max]``.

    Bin ``k`` has its centre at ``10**(k / ppd)`` and its edges at ``k +- 1/2``; the
    numbers run from the bin holding ``dr_min`` to the one holding ``dr_max``.
    """
    ppd = float(points_per_decade)
    k0 = int(np.floor(np.log10(dr_min) * ppd + 0.5))
    k1 = int(np.ceil(np.log10(dr_max) * ppd - 0.5))
    return np.arange(k0, k1 + 1)


def log_bins(dr_min: float, dr_max: float, points_per_decade: float
             ) -> tuple[np.ndarray, np.ndarray]:
    """Centres ``10**(k / ppd)`` of the log bins covering ``[dr_min, dr_max]``, and edges.

    The edges ``10**((k +- 1/2) / ppd)`` are not clipped (one more than the centres).
    """
    ppd = check_points_per_decade(points_per_decade)
    k = log_bin_numbers(dr_min, dr_max, ppd)
    return 10.0 ** (k / ppd), 10.0 ** ((np.append(k, k[-1] + 1) - 0.5) / ppd)


def log_bin_edges(dr_min: float, dr_max: float, points_per_decade: float) -> np.ndarray:
    """Logarithmic bin edges centred on ``10**(k / points_per_decade)``.

    The edges ``10**((k +- 1/2) / ppd)`` do not depend on the unit as long as units differ
    by powers of ten, so nm and m inputs give the same bins. The first and last edges are
    clipped to ``[dr_min, dr_max]``.
    """
    if not (np.isfinite(dr_min) and np.isfinite(dr_max) and 0 < dr_min < dr_max):
        raise ValueError(f"need 0 < dr_min < dr_max, got dr_min={dr_min:g}, dr_max={dr_max:g}")
    edges = log_bins(dr_min, dr_max, points_per_decade)[1]
    edges = edges[(edges > dr_min) & (edges < dr_max)]
    return np.concatenate([[dr_min], edges, [dr_max]])


def linear_bin_edges(dr_min: float, dr_max: float, width: float) -> np.ndarray:
    """Linear bin edges ``(k +- 1/2) * width`` clipped to ``[dr_min, dr_max]``."""
    if not (0 <= dr_min < dr_max and width > 0):
        raise ValueError(f"need 0 <= dr_min < dr_max and width > 0, got {dr_min:g}, "
                         f"{dr_max:g}, {width:g}")
    k0 = int(np.floor(dr_min / width + 0.5))
    k1 = int(np.ceil(dr_max / width - 0.5))
    edges = (np.arange(k0, k1 + 2) - 0.5) * width
    edges = edges[(edges > dr_min) & (edges < dr_max)]
    return np.concatenate([[dr_min], edges, [dr_max]])


def max_lags(shape: tuple[int, ...], spacing: tuple[float, ...], periodic: bool,
             dr_max: float) -> tuple[int, ...]:
    """Largest lag index per axis that can matter for ``|d| < dr_max`` (inclusive)."""
    out = []
    for n, d in zip(shape, spacing):
        limit = n // 2 if periodic else n - 1
        out.append(int(min(limit, np.floor(dr_max / d * (1 + 1e-12)))))
    return tuple(out)


def lag_multiplicity(n: int, k: int, periodic: bool) -> np.ndarray:
    """Count the distinct signed lags ``+-i`` for ``i = 0..k`` along an axis of length n."""
    mult = np.full(k + 1, 2, dtype=np.int64)
    mult[0] = 1
    if periodic and n % 2 == 0 and k >= n // 2:
        mult[n // 2] = 1  # +n/2 and -n/2 are the same lag on a periodic grid
    return mult


def lag_radius2(ks: tuple[int, ...], spacing: tuple[float, ...]) -> np.ndarray:
    """Squared lag length on the folded lattice ``0..k`` per axis (broadcast to full shape)."""
    r2: np.ndarray | float = 0.0
    for axis, (k, d) in enumerate(zip(ks, spacing)):
        shape = [1] * len(ks)
        shape[axis] = k + 1
        r2 = r2 + ((np.arange(k + 1, dtype=float) * d) ** 2).reshape(shape)
    return np.broadcast_to(r2, tuple(k + 1 for k in ks))


def bin_index(r2: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Bin number of each squared radius for half-open bins ``[edges[b], edges[b+1])``.

    Values outside all bins get ``len(edges) - 1`` (one past the last bin), so that a
    ``bincount`` with ``minlength=len(edges)`` collects them in a discard slot.
    """
    nb = len(edges) - 1
    idx = np.searchsorted(edges**2, r2, side="right") - 1
    idx[(idx < 0) | (idx >= nb)] = nb
    return idx.astype(np.int32 if nb < 2**31 - 1 else np.int64)


def folded_bin_index(ks: tuple[int, ...], spacing: tuple[float, ...],
                     edges: np.ndarray) -> np.ndarray:
    """:func:`bin_index` of the folded lattice ``0..k``; lag 0 (a point and itself) discarded.

    In the smallest unsigned integer type that holds the discard slot (one byte per lag
    for up to 254 bins), built a block of rows at a time: the index of an open map's lags
    is an eighth of the map's size, and no plane of radii is formed.
    """
    nb = len(edges) - 1
    dtype = next(t for t in (np.uint8, np.uint16, np.uint32, np.uint64)
                 if nb <= np.iinfo(t).max)
    shape = tuple(k + 1 for k in ks)
    idx = np.empty(shape, dtype=dtype)
    if len(ks) == 1:
        idx[...] = bin_index(lag_radius2(ks, spacing), edges)
    else:
        step = max(1, 2**18 // shape[-1])
        cols = ((np.arange(shape[-1], dtype=float) * spacing[-1]) ** 2)[None, :]
        for i0 in range(0, shape[0], step):
            i = np.arange(i0, min(shape[0], i0 + step), dtype=float)
            idx[i0:i0 + step] = bin_index(((i * spacing[0]) ** 2)[:, None] + cols, edges)
    idx[(0,) * len(ks)] = nb  # a point paired with itself is no pair
    return idx


def binned_sum(values: np.ndarray, idx: np.ndarray, nbins: int) -> np.ndarray:
    """Sum ``values[..., *core]`` per bin of ``idx`` (core shape), batch dims kept.

    Returns an array ``(..., nbins)``.
    """
    core = idx.ndim
    batch = values.shape[: values.ndim - core]
    flat = values.reshape((-1, idx.size))
    nb1 = nbins + 1
    if flat.shape[0] == 1:
        out = np.bincount(idx.ravel(), weights=flat[0], minlength=nb1)[None, :]
    else:
        offs = (np.arange(flat.shape[0], dtype=np.int64) * nb1)[:, None]
        out = np.bincount((idx.ravel()[None, :] + offs).ravel(), weights=flat.ravel(),
                          minlength=nb1 * flat.shape[0]).reshape(flat.shape[0], nb1)
    return out[:, :nbins].reshape(batch + (nbins,))


@functools.lru_cache(maxsize=4)
def lattice_bin_counts(shape: tuple[int, int], spacing: tuple[float, float],
                       ks: tuple[int, int], edges_key: tuple[float, ...],
                       rows_per_block: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """Ordered pairs of an open map per radial bin, and their lag sums, a block of rows at a time.

    The geometric counts of :func:`~xrough._kernels.pairs.binned_geometry` without a
    ``(ky+1, kx+1)`` array, for maps too large for it (``edges_key`` is the tuple of the
    bin edges). Cached per grid and bins; read-only arrays ``(counts, lag sums)`` per bin.
    """
    edges = np.asarray(edges_key)
    nb = len(edges) - 1
    counts = np.zeros(nb + 1)
    rsum = np.zeros(nb + 1)
    (ny, nx), (dy, dx), (ky, kx) = shape, spacing, ks
    j = np.arange(kx + 1)
    wx = lag_multiplicity(nx, kx, False) * (nx - j).astype(float)
    for i0 in range(0, ky + 1, rows_per_block):
        i = np.arange(i0, min(ky + 1, i0 + rows_per_block))
        wy = lag_multiplicity(ny, ky, False)[i] * (ny - i).astype(float)
        r2 = (i[:, None] * dy) ** 2 + (j[None, :] * dx) ** 2
        idx = bin_index(r2, edges)
        if i0 == 0:
            idx[0, 0] = nb
        w = wy[:, None] * wx[None, :]
        counts += np.bincount(idx.ravel(), weights=w.ravel(), minlength=nb + 1)
        rsum += np.bincount(idx.ravel(), weights=(w * np.sqrt(r2)).ravel(), minlength=nb + 1)
    counts, rsum = counts[:nb], rsum[:nb]
    counts.setflags(write=False)
    rsum.setflags(write=False)
    return counts, rsum
