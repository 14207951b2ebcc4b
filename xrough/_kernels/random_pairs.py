"""The random-pair estimator of G (paper section 3.1), pure numpy.

For each lag bin, pairs of grid points are drawn *uniformly from all valid pairs whose lag
falls in the bin*: a lattice lag vector is drawn with probability proportional to the
number of pairs it has (uniform over distinct lags on a periodic map, ``(ny-|i|)(nx-|j|)``
on an open one), then a start point uniformly among those whose partner lies on the map,
and pairs touching a NaN are discarded. The bin mean of ``(h(r) - h(r+d))**2 / 2`` is
therefore an unbiased Monte-Carlo estimate of exactly the all-pairs bin average that the
FFT estimator computes, and its standard error is ``std / sqrt(n)``. Heights are never
interpolated (interpolation would bias G low at small lags).

Lag vectors are drawn under a uniform random angle: small bins enumerate their lattice
vectors exactly; large ones draw a point uniformly in the annulus widened by half a cell
diagonal and round it to the lattice, rejecting vectors outside the bin, which makes every
lattice vector of the bin exactly equally likely (its whole cell lies in the sampled area).
"""

from __future__ import annotations

import numpy as np

from .pairs import require_no_inf
from .tiles import power_of_two_exponent

__all__ = ["random_pair_sums", "scaled_points", "valid_points", "sampled_exponent"]

_ENUMERATE_MAX = 200_000  # lattice vectors; above this a bin is sampled continuously
_MAX_DRAWS = 1000  # draws per wanted pair before a bin of mostly missing pairs gives up
#: Points per map whose largest |h| scales the heights (:func:`sampled_exponent`).
SCALE_SAMPLE = 2**16


def _signed_range(n: int, periodic: bool) -> tuple[int, int]:
    """Smallest and largest signed lag index along an axis (inclusive)."""
    if periodic:
        return -((n - 1) // 2), n // 2  # on even n, -n/2 is the same lag as +n/2
    return -(n - 1), n - 1


def _weight(i: np.ndarray, n: int, periodic: bool) -> np.ndarray:
    """Count the start points along one axis whose partner lies on the map."""
    if periodic:
        return np.full(i.shape, float(n))
    return (n - np.abs(i)).astype(float)


def _enumerated_lags(lo, hi, shape, spacing, periodic):
    """All signed lattice lags with lo <= |d| < hi, and their pair weights."""
    grids = []
    for n, d in zip(shape, spacing):
        a, b = _signed_range(n, periodic)
        kmax = int(np.floor(hi / d))
        grids.append(np.arange(max(a, -kmax), min(b, kmax) + 1))
    mesh = np.meshgrid(*grids, indexing="ij")
    r2 = sum((m * d) ** 2 for m, d in zip(mesh, spacing))
    sel = (r2 >= lo * lo) & (r2 < hi * hi) & (r2 > 0)
    lags = [m[sel] for m in mesh]
    w = np.ones(lags[0].shape)
    for lag, n in zip(lags, shape):
        w = w * _weight(lag, n, periodic)
    return lags, w


def _box_size(hi, shape, spacing, periodic):
    size = 1
    for n, d in zip(shape, spacing):
        a, b = _signed_range(n, periodic)
        k = int(np.floor(hi / d))
        size *= min(b, k) - max(a, -k) + 1
    return size


def _continuous_lags(rng, count, lo, hi, shape, spacing, periodic):
    """``count`` lag vectors uniform over pairs in the 2D annulus (rejection sampling)."""
    delta = 0.5 * float(np.hypot(*spacing))
    r_lo, r_hi = max(lo - delta, 0.0), hi + delta
    ranges = [_signed_range(n, periodic) for n in shape]
    wmax = float(np.prod([float(n) for n in shape]))
    out_i, out_j, got = [], [], 0
    while got < count:
        m = int(1.3 * (count - got)) + 64
        r = np.sqrt(rng.uniform(r_lo * r_lo, r_hi * r_hi, m))
        phi = rng.uniform(0.0, 2 * np.pi, m)
        i = np.rint(r * np.sin(phi) / spacing[0]).astype(np.int64)
        j = np.rint(r * np.cos(phi) / spacing[1]).astype(np.int64)
        r2 = (i * spacing[0]) ** 2 + (j * spacing[1]) ** 2
        ok = (r2 >= lo * lo) & (r2 < hi * hi) & (r2 > 0)
        for lag, (a, b) in zip((i, j), ranges):
            ok &= (lag >= a) & (lag <= b)
        if not periodic:
            w = _weight(i, shape[0], False) * _weight(j, shape[1], False)
            ok &= rng.uniform(0.0, wmax, m) < w
        out_i.append(i[ok])
        out_j.append(j[ok])
        got += int(ok.sum())
    return [np.concatenate(out_i)[:count], np.concatenate(out_j)[:count]]


def _draw_lags(rng, count, lo, hi, shape, spacing, periodic):
    if len(shape) == 2 and _box_size(hi, shape, spacing, periodic) > _ENUMERATE_MAX:
        return _continuous_lags(rng, count, lo, hi, shape, spacing, periodic)
    lags, w = _enumerated_lags(lo, hi, shape, spacing, periodic)
    if lags[0].size == 0:
        return None
    cdf = np.cumsum(w)
    pick = np.searchsorted(cdf, rng.uniform(0.0, cdf[-1], count), side="right")
    return [lag[np.minimum(pick, lag.size - 1)] for lag in lags]


def random_pair_sums(h: np.ndarray, spacing: tuple[float, ...], edges: np.ndarray,
                     n_per_bin: int, *, periodic: bool, rng: np.random.Generator,
                     scale: float = 1.0, progress=None) -> np.ndarray:
    """Monte-Carlo sums of ``g = (h(r) - h(r+d))**2 / 2`` per lag bin for one map.

    Only the drawn points are read (no copy of the map, whatever its dtype or memory
    layout), so the cost grows with the number of pairs and bins, not with the map.

    Parameters
    ----------
    h : ndarray ([ny,] nx)
        Heights, NaN for missing points.
    spacing : tuple of float
        Grid spacing per lag axis (same length unit as ``edges``). One value for a 2D
        ``h`` means lags along the last axis only, the row drawn with the start point.
    edges : ndarray
        Bin edges in lag distance; bins are ``[edges[b], edges[b+1])``.
    n_per_bin : int
        Valid pairs wanted per bin. Pairs touching a NaN are discarded and replaced by
        new draws, up to 1000 draws per wanted pair (a bin whose pairs are nearly all
        missing then ends with fewer; one with none in ten times the budget stops).
    periodic : bool
    rng : numpy.random.Generator
    scale : float
        A power of two: the sums are those of ``h / scale`` (exactly: dividing by a power
        of two rounds nothing), so that no square leaves the float64 range.
    progress : callable, optional
        Called with the number of finished bins.

    Returns
    -------
    ndarray (3, nbins)
        Sum of g, sum of g**2 and number of valid pairs per bin.

    Raises
    ------
    ValueError
        A drawn point is infinite, or lies more than ``2**200`` times ``scale`` from 0
        (its square could overflow the sums).
    """
    rows = h.ndim - len(spacing)  # 1: a map read as rows of profiles (lags along x only)
    shape = h.shape[rows:]
    nb = len(edges) - 1
    out = np.zeros((3, nb))
    for b in range(nb):
        drawn = 0
        while out[2, b] < n_per_bin and drawn < _MAX_DRAWS * n_per_bin and not (
                out[2, b] == 0 and drawn >= 10 * n_per_bin):  # no valid pair in sight
            want = int(n_per_bin - out[2, b])
            lags = _draw_lags(rng, want, edges[b], edges[b + 1], shape, spacing, periodic)
            if lags is None:
                break
            drawn += want
            g = _squared_differences(h, lags, shape, rows, periodic, rng, scale)
            out[:, b] += g.sum(), (g * g).sum(), g.size
        if progress is not None:
            progress(1)
    return out


#: Drawn heights beyond this many times the scale could overflow the sums of g**2.
_LARGEST_SCALED = 2.0**200


def scaled_points(h: np.ndarray, index: tuple, scale: float) -> np.ndarray:
    """Return ``h[index] / scale`` in float64, refusing infinite or out-of-scale heights."""
    v = np.asarray(h[index], dtype=np.float64) / scale
    with np.errstate(invalid="ignore"):
        big = np.abs(v) > _LARGEST_SCALED
    if big.any():
        require_no_inf(v)
        raise ValueError(
            f"heights up to {np.nanmax(np.abs(v)) * scale:.3g} span more than 1e60 times the "
            f"largest of a regular sample of the map ({scale:.3g}): the random-pair "
            "estimator cannot square them safely; use estimator='fft'")
    return v


def _squared_differences(h, lags, shape, rows, periodic, rng, scale):
    """``(h(r) - h(r+d))^2 / 2`` for the given lags and uniform start points; NaN pairs dropped.

    ``h`` is divided by ``scale``; only the drawn points are read.
    """
    start, end = [], []
    if rows:
        r = rng.integers(0, h.shape[0], lags[0].size)
        start.append(r)
        end.append(r)
    for lag, n in zip(lags, shape):
        if periodic:
            a = rng.integers(0, n, lag.size)
            e = (a + lag) % n
        else:
            lo = np.maximum(0, -lag)
            a = lo + np.floor(rng.random(lag.size) * (n - np.abs(lag))).astype(np.int64)
            e = a + lag
        start.append(a)
        end.append(e)
    diff = scaled_points(h, tuple(start), scale) - scaled_points(h, tuple(end), scale)
    return 0.5 * diff[np.isfinite(diff)] ** 2



#: Points per block of the counting pass of :func:`valid_points` (fits a core's cache).
_COUNT_BLOCK = 2**16


def valid_points(h: np.ndarray) -> float:
    """Count the valid (non-NaN) heights of a map; refuse infinite ones.

    One pass over the map in blocks of rows, without a temporary of the map's size: the
    only step of the random-pair estimator whose cost grows with the map. The count is
    exact because the finite-area error of G depends on the valid area (its quadrature,
    :func:`~xrough._kernels.uncertainty.g_variance`, moves by far more than the area's
    own relative change), which a sample of points would only estimate.
    """
    rows = h.reshape(-1, h.shape[-1]) if h.ndim > 1 else h.reshape(1, -1)
    step = max(1, _COUNT_BLOCK // max(rows.shape[1], 1))
    count = 0
    for i in range(0, rows.shape[0], step):
        finite = np.isfinite(rows[i:i + step])
        count += int(np.count_nonzero(finite))
        if not finite.all() and np.isinf(rows[i:i + step]).any():
            raise ValueError("heights contain infinite values; mark missing points as NaN")
    return float(count)


def sampled_exponent(h: np.ndarray, points: int | None = None) -> int:
    """Exponent of the power of two nearest the largest ``|h|`` of a regular sample of a map.

    About ``points`` (default :data:`SCALE_SAMPLE`) points: every ``n / points^(1/ndim)``-th
    along each axis, instead of a pass over the whole map; enough for an estimator that
    reads few points and checks each against the scale (random pairs). A sample without a
    valid point falls back to the whole map.
    """
    points = SCALE_SAMPLE if points is None else points
    per_dim = max(1, int(round(points ** (1 / h.ndim))))
    sample = h[tuple(slice(None, None, max(1, n // per_dim)) for n in h.shape)]
    valid = np.isfinite(sample)
    if not valid.any():
        sample = h[np.isfinite(h)]
        valid = np.ones(sample.shape, dtype=bool)
    return int(power_of_two_exponent(np.max(np.abs(sample[valid]), initial=0.0)))
