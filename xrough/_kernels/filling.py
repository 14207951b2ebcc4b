"""Filling missing points of a map: the harmonic interpolation (pure numpy/scipy).

The missing points take the values that solve Laplace's equation with the valid points
around them as boundary values (the discrete 3- or 5-point Laplacian, weighted by the
spacing of each axis; at an open map's edge only the neighbours inside count): smooth,
never above the highest or below the lowest valid neighbour (maximum principle), and
exact for planes.
"""

from __future__ import annotations

import numpy as np

from .deferred import sparse
from .deferred import sparse_linalg as splinalg

__all__ = ["harmonic_fill"]


def harmonic_fill(h: np.ndarray, *, spacing: tuple[float, ...],
                  periodic: bool) -> np.ndarray:
    """Fill the NaN points of each map by the harmonic interpolation of its valid points.

    Parameters
    ----------
    h : numpy.ndarray (..., [ny,] nx)
        Heights, NaN where missing; the last ``len(spacing)`` axes are the grid.
    spacing : tuple of float
        Grid spacing per axis (weights ``1 / d^2`` of the Laplacian).
    periodic : bool
        Neighbours wrap around the edges.

    Returns
    -------
    numpy.ndarray
        ``h`` with its NaN points filled (a map with no valid point stays NaN).

    Examples
    --------
    >>> h = np.array([0.0, np.nan, np.nan, 3.0])
    >>> harmonic_fill(h, spacing=(1.0,), periodic=False).tolist()  # a straight line
    [0.0, 1.0, 2.0, 3.0]
    """
    h = np.asarray(h, dtype=float)
    nd = len(spacing)
    grid = h.shape[h.ndim - nd:]
    out = h.copy()
    flat = out.reshape((-1,) + grid)
    for one in flat:
        missing = np.isnan(one)
        if missing.any() and not missing.all():
            one[missing] = _solve(one, missing, spacing, periodic)
    return out


def _solve(h: np.ndarray, missing: np.ndarray, spacing, periodic: bool) -> np.ndarray:
    """Solve for the values at ``missing`` of the discrete harmonic function (``h`` elsewhere)."""
    index = np.full(h.shape, -1)
    index[missing] = np.arange(int(missing.sum()))
    n = int(missing.sum())
    rows, cols, vals = [], [], []
    rhs = np.zeros(n)
    diag = np.zeros(n)
    where = np.nonzero(missing)
    for axis, d in enumerate(spacing):
        w = 1.0 / d**2
        size = h.shape[axis]
        for step in (-1, 1):
            nb = list(where)
            nb[axis] = where[axis] + step
            if periodic:
                nb[axis] = nb[axis] % size
                inside = np.ones(n, dtype=bool)
            else:
                inside = (nb[axis] >= 0) & (nb[axis] < size)
            me = np.nonzero(inside)[0]
            at = tuple(c[inside] for c in nb)
            diag[me] += w
            other = index[at]
            unknown = other >= 0
            rows.append(me[unknown])
            cols.append(other[unknown])
            vals.append(np.full(int(unknown.sum()), -w))
            np.add.at(rhs, me[~unknown], w * h[at][~unknown])
    A = sparse.csr_matrix((np.concatenate([diag, *vals]),
                           (np.concatenate([np.arange(n), *rows]),
                            np.concatenate([np.arange(n), *cols]))), shape=(n, n))
    return splinalg.spsolve(A.tocsc(), rhs)
