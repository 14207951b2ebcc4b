"""``acf(target_error=...)``: the estimator and budget chosen for a wanted error of G.

The choice is tested against the cost model it states (``xrough.correlation.COST``), not
against wall time; the achieved error against the exact G of the realisations.
"""

import functools
import math
import warnings

import numpy as np
import pytest
import xarray as xr
from dask_counting import computes_nothing

import xrough
from xrough.correlation import COST, SAMPLING_KAPPA


def _noise(shape, *, periodic=False, unit="nm", spacing=1.0):
    """Heights whose values do not matter: the choice reads shapes only."""
    h = np.random.default_rng(0).normal(size=shape)
    return xrough.topography(h, spacing=spacing, unit=unit, periodic=periodic)


def _acf(topo, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        return topo.rough.acf(**kw)


def _modelled(G, topo, *, lag_shape, target):
    """The cost model of the docs, recomputed from the result's bins and the target.

    Random pairs get half the target as sampling error (the floor of these maps is far
    below it): ``SAMPLING_KAPPA / (target / 2)^2`` pairs per bin.
    """
    nb = G.sizes["dr"]
    per_bin = COST["bin_2d"] if len(lag_shape) == 2 else COST["bin_1d"]
    m = float(np.prod(lag_shape))
    n_pairs = math.ceil(SAMPLING_KAPPA / (target / 2) ** 2) * nb
    random = per_bin * nb + COST["pair"] * n_pairs + COST["count"] * topo.size
    return COST["fft"] * m * math.log2(m), random, n_pairs


# (shape, periodic, dr_max, target, expected): cases on both sides of the cost model.
# 1024² open, dr_max 100 px: the FFT transforms (1024 + 100)² points, random pairs need
# 8 / t² pairs per bin; 5 % is cheaper by random pairs (0.025 s against 0.038 s), 1 %
# (80,000 pairs per bin) is not. Periodic maps transform no padding: 256² at 5 % is
# cheaper by FFT. A 2^16-point profile is one short FFT.
DECISIONS = [
    ((1024, 1024), False, 100, 0.05, "random"),
    ((1024, 1024), False, 100, 0.01, "fft"),
    ((256, 256), True, None, 0.05, "fft"),
    ((2**16,), False, 64, 0.05, "fft"),
]


@pytest.mark.parametrize("shape, periodic, dr_max, target, expected", DECISIONS)
def test_choice_follows_the_cost_model(shape, periodic, dr_max, target, expected):
    topo = _noise(shape, periodic=periodic)
    G = _acf(topo, target_error=target, dr_max=dr_max, seed=0)
    assert G.attrs["estimator"].startswith(expected)
    ks = [0 if periodic else min(n - 1, dr_max or n) for n in shape]
    fft, random, n_pairs = _modelled(G, topo, lag_shape=[n + k for n, k in zip(shape, ks)],
                                     target=target)
    assert G.attrs["modelled_seconds_fft"] == pytest.approx(fft, rel=1e-9)
    assert G.attrs["modelled_seconds_random"] == pytest.approx(random, rel=1e-9)
    assert (random < fft) == (expected == "random")
    if expected == "random":
        assert G.attrs["n_pairs"] == n_pairs
        assert G.attrs["sampling_error_budget"] == pytest.approx(target / 2)
    else:
        assert "n_pairs" not in G.attrs and G.attrs["sampling_error_budget"] == 0


@pytest.mark.parametrize("target, expected", [(0.05, "random"), (0.005, "tiled")])
def test_map_beyond_memory_weighs_random_pairs_against_tiles(monkeypatch, target, expected):
    """When the padded FFT would not fit (here: memory pretended to be 64 MB), the exact
    candidate is the tiled estimator, 3.3e-7 s per map point (0.35 s at 1024²): random
    pairs win at 5 % (3,200 pairs per bin) and lose at 0.5 % (320,000 per bin). The error
    floor of a flat G on these bins (0.16 %) is below both targets."""
    monkeypatch.setattr("xrough.correlation._choice._available_memory", lambda: 64e6)
    topo = _noise((1024, 1024))
    options = dict(target_error=target, dr_max=400, points_per_decade=5)
    if expected == "tiled":
        G = _acf(topo, **options)
    else:
        G = _acf(topo, seed=0, **options)
    assert G.attrs["estimator"].startswith(expected)
    assert G.attrs["modelled_seconds_tiled"] == pytest.approx(COST["tiled"] * topo.size)
    n_pairs = math.ceil(SAMPLING_KAPPA / (target / 2) ** 2) * G.sizes["dr"]
    random = (COST["bin_2d"] * G.sizes["dr"] + COST["pair"] * n_pairs
              + COST["count"] * topo.size)
    assert G.attrs["modelled_seconds_random"] == pytest.approx(random)
    assert (random < COST["tiled"] * topo.size) == (expected == "random")


def test_chunked_map_is_computed_tiled_and_lazily():
    """A map split into dask chunks: random pairs cannot read it, the exact choice is the
    tiled estimator (as for ``estimator='auto'``); nothing is computed at build time."""
    topo = _noise((256, 256)).chunk({"y": 128, "x": 128})
    with computes_nothing():
        G = topo.rough.acf(target_error=0.05)
    assert G.attrs["estimator"].startswith("tiled") and G.chunks is not None
    assert "dask chunks" in G.attrs["estimator_choice"]
    assert G.achieved_error.chunks is not None


# (shape, options, target): on a 32² map even uncorrelated heights give G to no better
# than about 5 % (the model of standard_error with a flat G; this map's own: 3.8-5.3 %);
# on 100-400 px of a 1024² map the model takes G as ballistic below the first bin, which
# makes the least error 17 % (white noise's reported one there: 13-17 %).
UNREACHABLE = [((32, 32), {}, 0.001),
               ((1024, 1024), {"dr_min": 100, "dr_max": 400, "points_per_decade": 5}, 0.05)]


@pytest.mark.parametrize("shape, options, target", UNREACHABLE)
def test_target_below_what_the_map_can_give_uses_the_exact_estimator_and_warns(
        shape, options, target):
    """Out of reach for any estimator: the exact one, marked, and one warning saying so."""
    topo = _noise(shape)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        G = topo.rough.acf(target_error=target, **options)
    assert len(caught) == 1 and caught[0].category is xrough.QualityWarning
    assert "below what this map can give" in str(caught[0].message)
    assert G.attrs["estimator"].startswith("fft")
    assert G.attrs["quality"] == "questionable"
    assert G.attrs["error_floor"] > target
    assert "no estimator reaches it" in G.attrs["quality_notes"]
    assert int(G.quality_flag) == 1


# ---------------------------------------------------------------- the achieved error
KW = dict(hurst=0.5, lambda_r=32, lambda_s=4, size=1024, n=1024, rms_height=1.0, unit="nm")
OPTS = dict(dr_min=4, dr_max=64, points_per_decade=5)


@functools.cache
def _exact_g():
    """G of the discrete model spectrum, the expectation of every realisation's G.

    With fixed spectral moduli the all-pairs G of the periodic map does not depend on the
    phases (see tests/test_fitting.py), so it is the exact G of the generator's field.
    """
    return xrough.self_affine_surface(seed=0, random_amplitudes=False, **KW).rough.acf(**OPTS)


def test_exact_g_is_the_model_spectrum_s():
    """The reference against eq. 9 of the model spectrum: within 3 % on 4-64 px (the
    lattice's largest wavenumber and the grid's discrete modes; measured 0.8 %)."""
    ref = _exact_g()
    C = xrough.model_spectrum(hurst=0.5, lambda_r="32 nm", lambda_s="4 nm",
                              rms_height="1 nm")
    exact = xrough.acf_from_spectrum(C, ref.dr)
    to_nm2 = xrough.units.conversion_factor(exact.attrs["units"], "nm2")
    np.testing.assert_allclose(ref.values, exact.values * to_nm2, rtol=0.03)


def test_achieved_error_is_within_the_target():
    """Six Gaussian realisations (1024² open maps, H = 0.5, lambda_r = 32 px), 5 % wanted
    on 4-64 px: random pairs are chosen (22,400 pairs), ``achieved_error`` (the reported
    standard_error / G, 3.6 %) is within the target on each, and the realised rms
    deviation from the exact G over the 6 x 7 bins is within it (measured 2.8 %: the
    finite-area error of about 1 % and the sampling error of 2.5 %). The rms of 42
    correlated deviations scatters by about 15 %, so 5 % is 2.8 % plus 5 sigma."""
    ref = _exact_g()
    deviations = []
    for seed in range(1, 7):
        topo = xrough.self_affine_surface(seed=seed, **KW).assign_attrs(periodic=0)
        G = _acf(topo, target_error=0.05, seed=seed, **OPTS)
        assert G.attrs["estimator"] == "random pairs"
        assert float(G.achieved_error) <= 0.05 and G.attrs["quality"] == "good"
        np.testing.assert_allclose(G.dr.values, ref.dr.values, rtol=2e-3)
        deviations.append(G.values / ref.values - 1)
    rms = float(np.sqrt(np.mean(np.square(deviations))))
    assert rms <= 0.05


def test_missed_target_is_marked_per_curve():
    """A self-affine map whose long lags carry ~10 % finite-area error: 5 % is reachable
    by no estimator there; the curve is questionable and achieved_error says by how much."""
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r=256, lambda_s=4, size=256, n=256,
                                      rms_height=1.0, unit="nm", seed=1)
    with pytest.warns(xrough.QualityWarning, match="exceeds target_error=0.05"):
        G = topo.rough.acf(target_error=0.05)
    assert float(G.achieved_error) > 0.05
    assert G.attrs["quality"] == "questionable" and int(G.quality_flag) == 1


# ---------------------------------------------------------------- backends and units
def _stack():
    topo = xrough.self_affine_surface(seed=1, **KW).assign_attrs(periodic=0)
    flipped = topo[::-1].assign_coords(y=topo.y)
    return xr.concat([topo, flipped], dim="scan").assign_attrs(topo.attrs)


def test_numpy_equals_dask_and_dask_stays_lazy():
    stack = _stack()
    with computes_nothing():
        lazy = stack.chunk({"scan": 1}).rough.acf(target_error=0.05, seed=3, **OPTS)
    assert lazy.chunks is not None
    eager = _acf(stack, target_error=0.05, seed=3, **OPTS)
    assert eager.attrs["estimator"] == "random pairs"
    xr.testing.assert_identical(eager, lazy.compute())


@pytest.mark.parametrize("unit, factor", [("um", 1e-3), ("m", 1e-9)])
def test_same_choice_and_relative_error_in_any_unit(unit, factor):
    topo = _noise((1024, 1024))
    other = xrough.topography(topo.values * factor, spacing=factor, unit=unit)
    a = _acf(topo, target_error=0.05, dr_max=100, seed=0)
    b = _acf(other, target_error="5 %", dr_max=100 * factor, seed=0)
    for key in ("estimator", "n_pairs", "target_error", "sampling_error_budget"):
        assert a.attrs[key] == b.attrs[key]
    assert a.attrs["error_floor"] == pytest.approx(b.attrs["error_floor"], rel=1e-9)
    np.testing.assert_allclose(b.values, a.values * factor**2, rtol=1e-12)
    np.testing.assert_allclose(b.achieved_error, a.achieved_error, rtol=1e-9)


def test_attrs_report_the_choice():
    G = _acf(_noise((1024, 1024)), target_error=0.05, dr_max=100, seed=0)
    assert G.attrs["target_error"] == 0.05
    assert G.attrs["estimator_choice"].startswith("random: random pairs need")
    assert {"modelled_seconds_fft", "modelled_seconds_random", "error_floor",
            "error_floor_dr", "n_pairs", "seed"} <= set(G.attrs)
    assert G.achieved_error.attrs["units"] == "1"
    assert G.attrs["xrough_version"]  # result_attrs, with the provenance


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize("value", [-0.1, 0, 0.0, 1.0, 2, float("nan"), float("inf"), True,
                                   "abc", "1 nm", [0.01, 0.02]])
def test_bad_targets_are_refused(value):
    with pytest.raises(ValueError, match="target_error"):
        _noise((16, 16)).rough.acf(target_error=value)


@pytest.mark.parametrize("options", [{"estimator": "fft"}, {"estimator": "random"},
                                     {"estimator": "tiled"}, {"n_pairs": 1000}])
def test_target_with_an_explicit_choice_is_refused(options):
    with pytest.raises(ValueError, match="target_error"):
        _noise((16, 16)).rough.acf(target_error=0.05, **options)
