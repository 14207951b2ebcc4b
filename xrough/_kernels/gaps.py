"""Integrals of G across lag ranges that no measurement covers (numpy only).

A stitched G may have no bin over a range of lags between the windows of its
measurements. Every integral of G bridges it as :class:`AcfCurve` continues G between
two bins (a monotone cubic in log-log through the bins around the gap, which meets the
slopes on either side); how much that choice matters is bounded by the alternatives that
continue either neighbour's own local slope across the gap instead.
"""

from __future__ import annotations

import numpy as np

from .acf_curve import AcfCurve


def _g_over_r2(a: float, b: float, g0: float, r0: float, slope: float) -> float:
    """``int_a^b G / r^2 dr`` of the power law ``G = g0 (r / r0)^slope``."""
    curve = AcfCurve(np.array([a, b]), g0 * (np.array([a, b]) / r0) ** slope)
    ends, _, _ = curve.cumulative_g_over_r2(np.array([a, b]))
    return float(ends[1] - ends[0])


def bridge_energy(g, *, dr, lo, hi) -> np.ndarray:
    """Share of ``int_0^inf G / r^2 dr`` (eq. 16) from the bridges over gaps, and its error.

    Parameters
    ----------
    g, dr : ndarray
        One G on its lags (NaN bins and ``dr = 0`` skipped).
    lo, hi : ndarray
        The gaps: lag ranges without data (same unit as ``dr``).

    Returns
    -------
    ndarray
        ``[share, error]``: the share of the integral that comes from the bridges between
        the bins around each gap (summed over gaps), and the largest relative
        change of the integral when a bridge is replaced by the continuation of the local
        slope of the bin pair below or above it (summed over gaps). ``[0, 0]`` without
        gaps between bins.
    """
    curve = AcfCurve(dr, g)
    total = curve.cumulative_g_over_r2(np.array([np.inf]))[0][0]
    x, y, slope = curve.dr, curve.g, curve.slope
    share = error = 0.0
    for gap_lo, gap_hi in zip(np.atleast_1d(lo), np.atleast_1d(hi)):
        j = int(np.searchsorted(x, gap_hi, side="left"))  # first bin at or beyond the gap
        i = j - 1
        if i < 0 or j >= x.size or x[i] > gap_lo:
            continue  # not between two bins: the continuations' shares cover it
        ends, _, _ = curve.cumulative_g_over_r2(np.array([x[i], x[j]]))
        bridge = float(ends[1] - ends[0])
        others = ([_g_over_r2(x[i], x[j], y[i], x[i], slope[i - 1])] if i >= 1 else []) + (
            [_g_over_r2(x[i], x[j], y[j], x[j], slope[j])] if j + 1 < x.size else [])
        share += bridge / total
        error += max((abs(o - bridge) for o in others), default=bridge) / total
    return np.array([share, error])
