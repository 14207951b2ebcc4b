"""The height-difference autocorrelation function G(dr) of topographies (paper eq. 1).

``G(dr) = 1/2 <(h(r) - h(r + dr))^2>`` averaged over every pair of valid points whose lag
falls in a bin of ``|dr|``: over all orientations (``direction="radial"``) or along one
axis (``"x"``, ``"y"``). Three estimators, one module each, around shared bins and one
definition of the result:

``"fft"`` (systematic, all pairs; ``_fft``)
    Exact pair sums by FFT (:mod:`xrough._kernels.pairs`); periodic maps wrap around,
    open maps are zero padded by the largest lag asked for, missing points (NaN) are
    excluded pair by pair.
``"random"`` (paper section 3.1; ``_random``)
    Uniformly drawn pairs per log-spaced bin, a fixed budget, seedable; a Monte-Carlo
    estimate of the same bin averages with its sampling error
    (:mod:`xrough._kernels.random_pairs`).
``"tiled"`` (maps larger than memory, :func:`height_difference_acf_tiled`; ``_tiled``)
    Exact pair sums tile by tile up to a halo, coarse block levels for longer lags
    (:mod:`xrough._kernels.tiles`).

The modules of the package: ``_plan`` (bin edges, lattice geometry and the plan every
estimator follows), ``_result`` (G's DataArray: coords, units and attrs, for every
estimator), ``_choice`` (the estimator ``'auto'`` and ``target_error`` pick, with the
cost model ``COST``) and ``_estimator`` (:func:`height_difference_acf`: options,
plan, estimator, computation, result).
"""

# also importable from here: the cost model of target_error, the options' values, the bins
from ._choice import COST as COST
from ._choice import SAMPLING_KAPPA as SAMPLING_KAPPA
from ._estimator import DEFAULT_PAIRS as DEFAULT_PAIRS
from ._estimator import ESTIMATORS as ESTIMATORS
from ._estimator import height_difference_acf
from ._plan import DIRECTIONS as DIRECTIONS
from ._plan import MAX_BINS as MAX_BINS
from ._plan import bin_edges as bin_edges
from ._tiled import height_difference_acf_tiled

__all__ = ["height_difference_acf", "height_difference_acf_tiled"]
