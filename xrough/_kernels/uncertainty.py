"""Statistical error of an all-pairs G estimate from a finite map (pure numpy).

The estimate ``G^(d) = (1/A) int d2r f(r)`` with ``f = (h(r+d) - h(r))^2 / 2`` scatters
from map to map because nearby squared differences are correlated. For Gaussian heights
``Cov(f(0; d), f(s; d')) = gamma(s)^2 / 2`` with the increment covariance

    gamma(s; d, d') = G(s + d') + G(s - d) - G(s) - G(s + d' - d),

so that

    Var G^(d) = (1 / 2A) int d2s < gamma(s; d, d')^2 >,

averaged over the orientations of ``d`` and ``d'`` that the radial bin mixes (none for a
profile or one axis). ``G`` itself (the estimate, log-log interpolated, ballistic ``r^2``
below the first bin and flat beyond the last) closes the expression. For ``H > 1/2`` the
integral is dominated by the largest scales, which is why small-lag errors of
self-affine maps are much larger than ``1/sqrt(pairs)``. The variance is never taken
below that of independent pairs, ``2 G^2 / pairs``.

That real-space closure misses at both ends (measured over 40 seeds, mean standard error
against the scatter of G: 1.3-1.6 times too large at 1-2 pixels for ``H = 0.8``, 0.63-0.7
times too small at ``L/2`` for ``L = 8 lambda_r``): the second differences of an
interpolated G are kinked at its bins, and the disk of the map's area leaves out the
separations of lags near ``L/2``.  :func:`finite_area_variance` is the same variance in
Fourier space (:func:`g_covariance`), from the spectrum of the estimate itself (eq.
10/11), relative to the G of the same modes: within 0.86-1.08 of the scatter at every
lag up to ``L/2`` on periodic and open maps, 0.74-1.28 on profiles (against 0.61-1.7 for
:func:`g_variance`; ``benchmarks/calibration_errors.py``). It is G's
``standard_error`` (:func:`~xrough._kernels.pairs.area_variance`); :func:`g_variance`
remains for lags beyond half an open map and for G with fewer than four usable bins.
"""

from __future__ import annotations

import functools

import numpy as np

from .deferred import special
from .hankel import PowerLawInterpolant, profile_spectrum_kernel
from .spectrum_of_acf import smooth_acf_kernel, spectrum_from_acf_kernel

__all__ = ["g_covariance", "g_variance", "covariance_from_acf", "finite_area_variance",
           "relative_covariance", "propagated_std", "linear_std", "regional_scatter"]


def _interpolator(dr: np.ndarray, g: np.ndarray):
    ok = np.isfinite(g) & (g > 0) & (dr > 0)
    x = np.log(dr[ok])
    y = np.log(g[ok])
    if x.size == 0:
        return None
    if x.size == 1:
        x = np.array([x[0], x[0] + 1.0])
        y = np.array([y[0], y[0]])

    def G(r):
        r = np.asarray(r)
        with np.errstate(divide="ignore"):
            lr = np.log(np.maximum(r, 1e-300))
        out = np.exp(np.interp(lr, x, y))
        small = lr < x[0]
        out = np.where(small, np.exp(y[0] + 2.0 * (lr - x[0])), out)  # ballistic
        return np.where(r > 0, out, 0.0)

    return G


def g_variance(dr: np.ndarray, g: np.ndarray, pairs: np.ndarray, *, area: float,
               pixel_area: float, geometry: str, n_s: int = 40, n_angle: int = 16,
               n_orient: int = 6, at: np.ndarray | None = None) -> np.ndarray:
    """Variance of the all-pairs G estimate per bin (Gaussian, finite area).

    Parameters
    ----------
    dr, g, pairs : ndarray (nbins,)
        Bin lags, the G estimate and the number of pairs per bin.
    area : float
        Valid area (2D, length^2) or valid length (profile).
    pixel_area : float
        Area (length) of one grid cell.
    geometry : {'radial', 'axis', 'profile'}
        Radial average on a map, one axis of a map, or a profile.
    at : ndarray of bool (nbins,), optional
        The bins whose variance is asked for (G is still read at every bin); the others
        are NaN.

    Returns
    -------
    ndarray (nbins,)
    """
    G = _interpolator(dr, g)
    if G is None or area <= 0:
        return np.full(dr.shape, np.nan)
    if at is not None:
        out = np.full(dr.shape, np.nan)
        if np.any(at):
            out[at] = _g_variance_at(G, dr[at], g[at], pairs[at], area, pixel_area,
                                     geometry, n_s, n_angle, n_orient)
        return out
    return _g_variance_at(G, dr, g, pairs, area, pixel_area, geometry, n_s, n_angle,
                          n_orient)


def _g_variance_at(G, dr, g, pairs, area, pixel_area, geometry, n_s, n_angle, n_orient):
    """:func:`g_variance` at the bins ``dr`` (``G``: the interpolant of every bin)."""
    floor = np.where(pairs > 0, 2.0 * g**2 / np.maximum(pairs, 1), np.nan)
    if geometry == "profile":
        # gamma(s) = G(|s + d|) + G(|s - d|) - 2 G(|s|) is even in s
        half = 0.5 * pixel_area
        s = np.geomspace(half, max(0.5 * area, 2 * half), n_s)
        ws = np.gradient(np.log(s)) * s  # ds in log steps
        d = dr[:, None]
        gam = G(s + d) + G(np.abs(s - d)) - 2 * G(s)
        integral = (2 * G(dr)) ** 2 * pixel_area + 2 * (gam**2 * ws).sum(-1)
        return np.fmax(integral / (2 * area), floor)
    rho0, sx, sy, ws = _polar_grid(area, pixel_area, n_s, n_angle)
    # relative orientation of d' against d = (d, 0): all of them for a radial bin
    psi = (np.arange(n_orient) + 0.5) * np.pi / n_orient if geometry == "radial" else \
        np.zeros(1)
    d = dr[:, None, None, None]
    dpx, dpy = d * np.cos(psi), d * np.sin(psi)
    mean_sq = (_gamma(G, sx, sy, d, dpx, dpy) ** 2).mean(axis=(2, 3))  # angle of s and d'
    centre = (_gamma(G, 0.0, 0.0, d, dpx, dpy) ** 2).mean(axis=(1, 2, 3))
    integral = centre * np.pi * rho0**2 + 2 * np.pi * (mean_sq * ws).sum(-1)
    var = integral / (2 * area)
    return np.fmax(var, floor)


def _gamma(G, x, y, d, dpx, dpy):
    """Increment covariance ``gamma(s; d, d')`` with ``d = (d, 0)``, ``d' = (dpx, dpy)``."""
    return (G(np.hypot(x + dpx, y + dpy)) + G(np.hypot(x - d, y))
            - G(np.hypot(x, y)) - G(np.hypot(x + dpx - d, y + dpy)))


def _polar_grid(area, pixel_area, n_s, n_angle):
    """Separations ``s`` of a map: central disk radius, ``(sx, sy)`` and ``s ds`` weights."""
    rho0 = np.sqrt(pixel_area / np.pi)  # the central cell, as a disk
    s = np.geomspace(rho0, max(np.sqrt(area / np.pi), 2 * rho0), n_s)
    ws = np.gradient(np.log(s)) * s * s  # s ds in log steps
    phi = (np.arange(n_angle) + 0.5) * 2 * np.pi / n_angle
    sx = (s[:, None] * np.cos(phi)[None, :])[None, :, :, None]
    sy = (s[:, None] * np.sin(phi)[None, :])[None, :, :, None]
    return rho0, sx, sy, ws


#: Modes of the other axis summed one by one for G along one axis of a map (the rest in
#: bands): the sum is smooth in them beyond the first few (the variances move by < 1e-3).
CROSS_EXACT_MODES = 256


def _mode_bands(n_max: int, exact: int, per_decade: float) -> tuple[np.ndarray, np.ndarray]:
    """Mode numbers ``1..n_max``: the first ``exact`` one by one, then log bands.

    Returns the band centres and their widths (modes per band; 1 for single modes).
    """
    m_exact = np.arange(1, min(exact, n_max) + 1, dtype=float)
    edges = (np.geomspace(m_exact[-1] + 0.5, n_max + 0.5,
                          max(2, int(per_decade * np.log10((n_max + 0.5)
                                                           / (m_exact[-1] + 0.5))) + 1))
             if n_max > m_exact[-1] else np.empty(0))
    return (np.r_[m_exact, 0.5 * (edges[1:] + edges[:-1])],
            np.r_[np.ones(m_exact.size), np.diff(edges)])


@functools.lru_cache(maxsize=8)
def _cross_modes(size: float, n_max: int, exact: int, cross_exact: int, per_decade: float,
                 q_bytes: bytes):
    """Where G along one axis reads the spectrum: ``|k|`` of its modes, cached per grid.

    Rows: the modes ``m`` along the axis (:func:`_mode_bands`, the first ``exact`` one
    by one); columns: the modes ``0, ny`` of the other axis (``ny`` in bands beyond the
    first ``cross_exact``), of weight 1
    for ``0`` and twice their width beyond (``+ny`` and ``-ny``). Returned with the
    pieces of the sampled spectrum (``q`` its wavenumbers, as bytes) each ``|k|`` falls
    in, so that evaluating a spectrum there is a gather and an exponential.
    """
    step = 2 * np.pi / size
    m, _ = _mode_bands(n_max, exact, per_decade)
    ny, wy = _mode_bands(n_max, cross_exact, per_decade)
    x = np.hypot(m[:, None] * step, np.r_[0.0, ny][None, :] * step)
    q = np.frombuffer(q_bytes)
    j = np.clip(np.searchsorted(q, x, side="right") - 1, 0, q.size - 2)
    with np.errstate(divide="ignore"):
        log_ratio = np.log(x / q[j])
    pieces = (j, log_ratio, (x >= q[0]) & (x <= q[-1]), x == q[-1])
    for a in pieces:
        a.setflags(write=False)
    wn = np.r_[1.0, 2.0 * wy]
    wn.setflags(write=False)
    return pieces, wn


def _power_law_at(spectrum: PowerLawInterpolant, pieces) -> np.ndarray:
    """``spectrum`` at the points of :func:`_cross_modes` (its ``__call__``, pieces known)."""
    j, log_ratio, inside, last = pieces
    with np.errstate(all="ignore"):
        val = spectrum.alpha[j] * log_ratio
        np.exp(val, out=val)
        val *= spectrum.coef[j]
    val[~inside] = 0.0
    val[last] = spectrum.values[-1] if spectrum.coef[-1] > 0 else 0.0
    return val


def g_covariance(dr: np.ndarray, q: np.ndarray, C: np.ndarray, *, size: float,
                 pixel: float, geometry: str, exact_modes: int = 65536,
                 bands_per_decade: float = 200, estimated_over: float = 0.0,
                 with_mean: bool = False, diagonal: bool = False):
    """Covariance of the finite-area errors of G between bins, from the surface's spectrum.

    A Gaussian surface is a sum of independent Fourier modes whose powers ``P_k`` scatter as
    much as they are large, and the all-pairs G of a periodic map is linear in them, so
    ``Cov(G_i, G_j) = sum_k <P_k>^2 w_k(d_i) w_k(d_j)`` (``w = 1 - cos(k d)`` along a line,
    ``1 - J0(k d)`` for a radial bin; ``<P_k>`` from ``C``).  Notes (modes, bands, what it
    leaves out): docs/spectra.md, "The covariance model of G (g_covariance)".

    Parameters
    ----------
    dr : ndarray (nbins,)
        Bin lags (length).
    q, C : ndarray
        Samples of the isotropic spectrum (angular wavenumber, length^4), increasing
        ``q``; log-log interpolated, 0 outside.
    size, pixel : float
        Scan size ``L`` (largest side; a square map is assumed) and pixel size.
    geometry : {'profile', 'axis', 'radial'}
        As for :func:`g_variance`.
    exact_modes, bands_per_decade : int, float
        Modes summed individually, and the density of the bands beyond.
    estimated_over : float
        ``C`` is an estimate from the map itself, smoothed over this many decades of
        ``q`` (0: the true spectrum).  Its square then overestimates ``<P_k>^2`` by
        ``1 + 1/n`` on average (``n``: the modes of the map within the smoothing window
        at ``k``, whose powers scatter by their mean each): each mode's weight is divided
        by that factor, which matters where few modes carry the spectrum (the longest
        wavelengths of a profile).
    with_mean : bool
        Also return the expected G of the same modes, ``sum_k <P_k> w_k(d)`` (the mean
        the covariance belongs to: its lattice sum, not the continuum eq. 9).
    diagonal : bool
        Only the variances (the diagonal, ``(nbins,)``): a sum over the modes per bin
        instead of per pair of bins (G's ``standard_error``).

    Returns
    -------
    ndarray (nbins, nbins)
        Symmetric, in the square of ``G``'s unit (the unit of ``C`` over length^2); with
        ``with_mean``, a tuple of it and the expected G (nbins,).

    Examples
    --------
    Profiles whose 1D spectrum is ``1 / k^2`` (``C = 1 / q^3``, ``G = dr / 2 pi``), 4096
    pixels: the error of G at one pixel is 1.76 % of ``1 / 2 pi``, and the errors at 8
    and 16 pixels are correlated by 0.88 (3000 simulated sets of 2048 random mode powers
    give 1.73 % and 0.89).

    >>> import numpy as np
    >>> q = np.geomspace(1e-4, 1e3, 701)
    >>> dr = 2.0 ** np.arange(8)
    >>> cov = g_covariance(dr, q, q**-3.0, size=4096.0, pixel=1.0, geometry="profile")
    >>> sd = np.sqrt(np.diag(cov))
    >>> print(np.round(sd[0] * 2 * np.pi, 4), np.round(cov[3, 4] / (sd[3] * sd[4]), 2))
    0.0176 0.88
    """
    dr = np.asarray(dr, dtype=float)
    nb = dr.size
    ok = np.isfinite(dr) & (dr > 0)
    if not (ok.any() and size > 0 and pixel > 0):
        return np.zeros((nb, nb))
    d = dr[ok]
    spectrum = PowerLawInterpolant(np.asarray(q, dtype=float),
                                   np.clip(np.nan_to_num(C), 0.0, None))
    n_max = max(1, int(np.ceil(0.5 * size / pixel * (np.sqrt(2) if geometry == "radial"
                                                         else 1.0))))
    step = 2 * np.pi / size
    m, width = _mode_bands(n_max, exact_modes, bands_per_decade)  # modes per band along k
    k = m * step
    if geometry == "profile":
        kk = np.geomspace(k[0], k[-1], max(2, int(50 * np.log10(k[-1] / k[0])) + 2))
        c1 = np.maximum(profile_spectrum_kernel(kk, spectrum, (q[0], q[-1])), 1e-300)
        c1 = np.exp(np.interp(np.log(k), np.log(kk), np.log(c1)))  # smooth: 50 per decade
        power = 2.0 * c1 / size
        weight, mean_weight = width * power**2, width * power
    elif geometry == "axis":
        # the sum over the other axis is smooth in it beyond its first modes: bands there
        # (not the millions of modes of a large map one by one)
        # the modes +ky and -ky have the same power: the half plane ky >= 0, doubled
        kq, wn = _cross_modes(float(size), n_max, int(exact_modes),
                              min(exact_modes, CROSS_EXACT_MODES), float(bands_per_decade),
                              spectrum.q.tobytes())
        power = _power_law_at(spectrum, kq)
        power *= 2.0 / size**2
        weight, mean_weight = width * (power**2 @ wn), width * (power @ wn)
    else:
        power = 2.0 * spectrum(k) / size**2
        modes = width * np.pi * m  # half of each annulus
        weight, mean_weight = modes * power**2, modes * power
    if estimated_over > 0:
        spread = 10 ** (estimated_over / 2) - 10 ** (-estimated_over / 2)
        n_window = spread * m if geometry == "profile" else np.pi * m * m * spread
        weight = weight / (1.0 + 1.0 / np.maximum(n_window, 1.0))
    cov = np.zeros(d.size) if diagonal else np.zeros((d.size, d.size))
    mean = np.zeros(d.size)
    for blk in range(0, k.size, 4096):  # bounded memory
        kb, wb = k[blk:blk + 4096, None], weight[blk:blk + 4096, None]
        if geometry == "radial":
            w = 1.0 - special.j0(kb * d[None, :])
        else:  # the cosine averaged over each band (1 for single modes)
            band = (width[blk:blk + 4096, None] - 1.0).clip(0.0) * step
            w = 1.0 - np.cos(kb * d[None, :]) * np.sinc(band * d[None, :] / (2 * np.pi))
        # einsum, not BLAS: the products are small, and a threaded BLAS spends more CPU
        # time starting its threads than on them (twice the fit of a profile)
        cov += (np.einsum("ki,ki->i", w * wb, w) if diagonal
                else np.einsum("ki,kj->ij", w * wb, w))
        mean += np.einsum("k,ki->i", mean_weight[blk:blk + 4096], w)
    idx = np.flatnonzero(ok)
    if diagonal:
        out = np.zeros(nb)
        out[idx] = cov
    else:
        out = np.zeros((nb, nb))
        out[np.ix_(idx, idx)] = 0.5 * (cov + cov.T)
    if not with_mean:
        return out
    expected = np.zeros(nb)
    expected[idx] = mean
    return out, expected


def covariance_from_acf(dr: np.ndarray, g: np.ndarray, *, size: float, pixel: float,
                        geometry: str, per_decade: float = 20.0,
                        estimated_over: float = 0.5, relative: bool = True,
                        diagonal: bool = False) -> np.ndarray:
    """Covariance of the finite-area errors of G's bins, from the spectrum of G itself.

    The spectrum of G (eq. 10/11, :func:`spectrum_from_acf_kernel` of G smoothed over
    half a decade by :func:`smooth_acf_kernel`, which extrapolates it beyond the lags)
    generates the covariance of :func:`g_covariance` for a (periodic, square) map of side
    ``size`` with pixels ``pixel``.  ``dr``, ``g``: the finite, positive bins, increasing;
    the result is in the square of ``g``'s unit.  ``per_decade``: samples of the spectrum
    per decade of ``q`` (20 is within 0.5 % of 40 in the errors; the spectrum is smooth).
    ``estimated_over``: of :func:`g_covariance` (the spectrum is that of G, smoothed over
    half a decade; 0 takes it as the surface's own).  ``relative``: the covariance
    relative to the expected G of the same modes, times ``g``, bin by bin (the modes'
    own G is their lattice sum, which G's spectrum reproduces where it is right;
    otherwise the covariance as computed).  ``diagonal``: the variances only.
    """
    r, g0 = dr / pixel, float(np.median(g))
    q = np.geomspace(np.pi / (8 * size / pixel), 2 * np.pi,
                     int(per_decade * np.log10(16 * size / pixel)) + 2)
    # order 4 panels: G smoothed over half a decade is smooth enough that the errors
    # move by < 2e-7 against the default 8 (self-affine maps, H 0.1-0.9), at 3/4 the cost
    C = spectrum_from_acf_kernel(q, r, smooth_acf_kernel(r, g / g0, 0.5), order=4)
    cov, mean = g_covariance(r, q, C, size=size / pixel, pixel=1.0, geometry=geometry,
                             estimated_over=estimated_over, with_mean=True,
                             diagonal=diagonal)
    if not relative:
        return cov * g0**2
    # relative to the G these modes make: a spectrum of the right shape gives the same;
    # one that G's end blows up at low q (a tilt, a form) keeps each bin's relative error
    # within that of one dominant mode (|error| <= G: the variance is a sum of squares
    # of the terms whose sum is G)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = g / (g0 * mean)
    return cov * (scale**2 if diagonal else np.outer(scale, scale)) * g0**2


def finite_area_variance(dr: np.ndarray, g: np.ndarray, pairs: np.ndarray, *, area: float,
                         pixel_area: float, geometry: str, map_area: float | None = None,
                         smooth: float | None = None) -> np.ndarray:
    """Variance of the all-pairs G estimate per bin (Gaussian surface, finite area).

    The diagonal of :func:`covariance_from_acf` for a map of ``area`` (the valid area in
    length^2, or the valid length of a profile; an equivalent square for a map), never
    below that of independent pairs, ``2 G^2 / pairs``.  ``map_area``: the area of one
    map where ``area`` pools several (a stack): their estimates are independent, and the
    variance is that of one map divided by their number.  Lags beyond half the map (an
    open map's, which few pairs span; at ``dr -> L`` the periodic model's variance
    vanishes) take the larger of this and the real-space :func:`g_variance`.  Falls back to
    :func:`g_variance` where G has fewer than four finite, positive bins or its spectrum
    cannot be formed.

    Parameters
    ----------
    dr, g, pairs : ndarray (nbins,)
        Bin lags (length), the G estimate (length^2) and the number of pairs per bin.
    area, pixel_area : float
        Valid area and area of one grid cell (length^2; lengths for a profile).
    geometry : {'radial', 'axis', 'profile'}
    map_area : float, optional
        Area of one map of a pooled stack (default: ``area``).
    smooth : float, optional
        Smooth G over this many decades first (``smooth_acf_kernel``): the spectrum of a
        G with scatter of its own (random pairs) would carry that scatter into the
        variance (0.5 for random pairs: their 2.5 % per bin made the variance of the last
        bins of white noise 1.7 times too large).

    Returns
    -------
    ndarray (nbins,)
        In length^4 (the square of G's unit).

    Examples
    --------
    A profile with ``G = dr / 2 pi`` (1D spectrum ``1/k^2``) of 4096 pixels: 2.3 % at one
    pixel, where the covariance of the true spectrum gives 1.76 % (:func:`g_covariance`)
    and the real-space :func:`g_variance` 33 %.

    >>> import numpy as np
    >>> dr = np.unique(np.round(np.geomspace(1, 2048, 34)))
    >>> var = finite_area_variance(dr, dr / (2 * np.pi), 4096 - dr, area=4096.0,
    ...                            pixel_area=1.0, geometry="profile")
    >>> print(np.round(np.sqrt(var[0]) * 2 * np.pi, 3))
    0.023
    """
    dr, g = np.asarray(dr, dtype=float), np.asarray(g, dtype=float)
    pairs = np.asarray(pairs, dtype=float)
    one = min(area, map_area) if map_area else area
    ok = np.isfinite(g) & (g > 0) & (dr > 0) & (pairs > 0)
    if np.count_nonzero(ok) < 4 or not one > 0:
        return g_variance(dr, g, pairs, area=area, pixel_area=pixel_area, geometry=geometry)
    profile = geometry == "profile"
    size = one if profile else np.sqrt(one)
    pixel = pixel_area if profile else np.sqrt(pixel_area)
    try:
        with np.errstate(all="ignore"):
            g_ok = g[ok] if smooth is None else smooth_acf_kernel(dr[ok], g[ok], smooth)
            var_ok = covariance_from_acf(dr[ok], g_ok, size=size, pixel=pixel,
                                         geometry=geometry, diagonal=True)
    except (ValueError, np.linalg.LinAlgError):
        var_ok = None
    if var_ok is None or not np.all(np.isfinite(var_ok)):
        return g_variance(dr, g, pairs, area=area, pixel_area=pixel_area, geometry=geometry)
    var = np.full(dr.shape, np.nan)
    var[ok] = var_ok * (one / area)  # n independent maps: 1/n
    beyond = dr > 0.5 * size
    if np.any(beyond):  # an open map's lags beyond L/2: the periodic model does not hold
        real = g_variance(dr, g, pairs, area=area, pixel_area=pixel_area, geometry=geometry,
                          at=beyond)
        var[beyond] = np.fmax(var[beyond], real[beyond])
    floor = np.where(pairs > 0, 2.0 * g**2 / np.maximum(pairs, 1), np.nan)
    return np.fmax(var, floor)


#: Samples per decade of G's spectrum behind the errors of predictions: the errors of
#: v_el move by under 1 % against 20 per decade, at half the cost (the chain of a short
#: profile pays it on every prediction).
PREDICTION_PER_DECADE = 10.0


def relative_covariance(dr: np.ndarray, g: np.ndarray, *, size: float, pixel: float,
                        geometry: str, n_maps: int = 1,
                        inflation: tuple[float, ...] | np.ndarray | None = None) -> np.ndarray:
    """Covariance of ``ln G`` bin by bin: :func:`covariance_from_acf` over ``g_i g_j``.

    ``n_maps``: independent maps pooled into ``g`` (the covariance of one over their
    number).  ``inflation``: per bin, the factor by which G's standard error exceeds its
    Gaussian finite-area value (:func:`regional_scatter`: the regions of the map scatter
    more than a Gaussian surface's would); the covariance becomes ``K S K`` with ``K =
    diag(inflation)``, its correlations unchanged.  Bins that are not finite and positive
    get zero rows; a G with fewer than four usable bins, or whose spectrum cannot be
    formed, gives NaN.  The fit, the energy and the gradient of one G ask for the same
    covariance: the last few are kept (a copy is returned).
    """
    dr, g = np.asarray(dr, dtype=float), np.asarray(g, dtype=float)
    if inflation is not None:
        k = np.asarray(inflation, dtype=float)
        if k.shape != dr.shape:
            raise ValueError(f"inflation has {k.size} values for {dr.size} bins of G")
        cov = relative_covariance(dr, g, size=size, pixel=pixel, geometry=geometry,
                                  n_maps=n_maps)
        k = np.where(np.isfinite(k) & (k > 1.0), k, 1.0)
        return cov * np.outer(k, k)
    if not (np.isfinite(pixel) and pixel > 0):
        return np.full((dr.size, dr.size), np.nan)
    # unit-free key (lags in pixels, G over its median, rounded to 12 digits): the same G
    # in nm (the fit, the gradient) and in m (the energy) is one entry
    with np.errstate(all="ignore"):
        ok = np.isfinite(g) & (g > 0)
        scale = float(np.median(g[ok])) if ok.any() else 1.0
        key_dr, key_g = (float_key(dr / pixel), float_key(g / scale))
    return _relative_covariance(key_dr.tobytes(), key_g.tobytes(), float_key(size / pixel),
                                str(geometry), int(n_maps)).copy()


def float_key(x):
    """``x`` rounded to 12 significant digits: equal for equal values in other units."""
    x = np.asarray(x, dtype=float)
    with np.errstate(all="ignore"):
        digits = 11 - np.floor(np.log10(np.abs(np.where((x != 0) & np.isfinite(x), x, 1.0))))
        out = np.round(x * 10.0**digits) / 10.0**digits
    return float(out) if out.ndim == 0 else out


@functools.lru_cache(maxsize=16)
def _relative_covariance(dr_bytes: bytes, g_bytes: bytes, size: float, geometry: str,
                         n_maps: int) -> np.ndarray:
    """:func:`relative_covariance` of G given by the bytes of its arrays, lags in pixels."""
    dr, g = np.frombuffer(dr_bytes), np.frombuffer(g_bytes)
    pixel = 1.0
    ok = np.isfinite(g) & (g > 0) & (dr > 0)
    out = np.zeros((dr.size, dr.size))
    if np.count_nonzero(ok) < 4 or not (size > 0 and pixel > 0):
        return np.full_like(out, np.nan)
    try:
        with np.errstate(all="ignore"):
            unit = float(np.median(g[ok]))  # relative: G in units of its median
            cov = covariance_from_acf(dr[ok], g[ok] / unit, size=size, pixel=pixel,
                                      geometry=geometry, per_decade=PREDICTION_PER_DECADE)
    except (ValueError, np.linalg.LinAlgError):
        return np.full_like(out, np.nan)
    rel = g[ok] / unit
    out[np.ix_(ok, ok)] = cov / np.outer(rel, rel) / max(int(n_maps), 1)
    return out


def propagated_std(f, g: np.ndarray, rel_cov: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """Return the standard deviation of ``f(g)`` for errors of ``g`` (relative covariance).

    Linearised: ``Var f = J S J^T`` with ``J = d f / d ln g`` by forward differences of
    ``step`` in each ``ln g_i`` (``f`` returns an array, one value per output).  NaN where
    ``f`` or the covariance is not finite.
    """
    g = np.asarray(g, dtype=float)
    f0 = np.atleast_1d(np.asarray(f(g), dtype=float))
    if not np.all(np.isfinite(rel_cov)):
        return np.full(f0.shape, np.nan)
    used = np.flatnonzero(np.diag(rel_cov) > 0)
    J = np.zeros((f0.size, g.size))
    for i in used:
        gi = g.copy()
        gi[i] *= np.exp(step)
        J[:, i] = (np.atleast_1d(f(gi)) - f0) / step
    return linear_std(J, rel_cov)


def linear_std(J: np.ndarray, rel_cov: np.ndarray) -> np.ndarray:
    """Return ``sqrt(diag(J S J^T))``: the standard deviations of outputs ``J`` maps ``ln g`` to.

    ``J[k, i] = d f_k / d ln g_i`` and ``S`` the relative covariance of ``g``; NaN where
    the covariance is not finite (:func:`propagated_std` builds ``J`` by differences).
    """
    if not np.all(np.isfinite(rel_cov)):
        return np.full(J.shape[0], np.nan)
    with np.errstate(invalid="ignore"):
        return np.sqrt(np.maximum(np.einsum("ki,ij,kj->k", J, rel_cov, J), 0.0))


#: The regions of a map disagree when the scatter of their G at some judged lag exceeds
#: their finite-area error by more than this factor in variance (a standard deviation 3
#: times the model's).  Measured (``benchmarks/calibration_real.py``, and the quarters
#: of 72 self-affine maps of 256^2 and 512^2, H 0.3-0.8, open and periodic, lambda_r
#: from L/8 to 2 L): at most 3.8 on the synthetic maps (the 99.9 % point of chi^2 with
#: three degrees of freedom over three is 5.4; the lags are correlated); 34-3e6 on eight
#: of the eleven instrument maps.
REGIONS_DISAGREE = 9.0


def regional_scatter(g_regions, g, se, *, judged, area_ratio) -> np.ndarray:
    """Scatter of G between regions of one map against its Gaussian finite-area error.

    ``g_regions``: ``(n, nb)``, G of ``n`` disjoint regions of the map (NaN where a region
    has no pairs or the lag is not judged); ``g``, ``se``: G of the whole map and its
    Gaussian standard error (``nb``); ``judged``: the lags where the regions hold enough
    pairs (bool, ``nb``); ``area_ratio``: the map's area over a region's, so that a
    region's Gaussian error is ``se sqrt(area_ratio)`` (the finite-area variance goes as
    one over the area; within 10 % of a region's own up to a quarter of its side,
    measured on self-affine maps).

    Returns ``(2, nb)``: the ratio ``r^2`` of the regions' variance about their mean to
    their Gaussian variance (about 1 for a stationary Gaussian surface; NaN where not
    judged), and the factor ``k >= 1`` by which G's error is to be raised: where some
    judged lag has ``r^2 >`` :data:`REGIONS_DISAGREE`, ``k`` is the regions' scatter of
    the mean over the whole map's Gaussian error, ``std(g_regions) / sqrt(n) / se``, at
    least 1, on every judged lag, and beyond the last judged lag the value there; else 1.
    """
    g, se = np.asarray(g, dtype=float), np.asarray(se, dtype=float)
    # relative to G's largest value: G near the float range squares without overflow
    scale = np.nanmax(np.abs(g), initial=0.0) if np.any(np.isfinite(g)) else 0.0
    scale = scale if np.isfinite(scale) and scale > 0 else 1.0
    gr = np.asarray(g_regions, dtype=float) / scale
    g, se = g / scale, se / scale
    n = gr.shape[0]
    out = np.full((2, g.size), np.nan)
    out[1] = 1.0
    ok = np.asarray(judged, dtype=bool) & np.all(np.isfinite(gr), axis=0) & (se > 0)
    if n < 2 or not ok.any():
        return out
    with np.errstate(invalid="ignore", divide="ignore"):
        var = np.var(gr, axis=0, ddof=1)
        r2 = var / (se**2 * area_ratio)
        k = np.sqrt(var / n) / se
    out[0, ok] = r2[ok]
    if not np.nanmax(r2[ok]) > REGIONS_DISAGREE:
        return out
    k = np.where(ok & np.isfinite(k), np.maximum(k, 1.0), np.nan)
    last = np.flatnonzero(ok)[-1]
    k[last + 1:] = k[last]
    # lags inside the judged range that a region missed: the nearest judged value below
    idx = np.where(np.isfinite(k), np.arange(k.size), 0)
    np.maximum.accumulate(idx, out=idx)
    k = np.where(np.isfinite(k), k, k[idx])
    out[1] = np.where(np.isfinite(k), k, 1.0)
    return out
