"""The statistical error of G between its bins, and the error of C(q) it gives (eq. 10/11).

``g_covariance`` is checked against an independent computation (a sum of random mode
powers, as a periodic Gaussian profile is); ``spectrum``'s ``standard_error`` against the
scatter of C between realisations, and its supported range against that scatter.
"""

from __future__ import annotations

import warnings
from functools import cache

import numpy as np
import pytest

import xrough
from xrough._kernels.hankel import PowerLawInterpolant, profile_spectrum_kernel
from xrough._kernels.uncertainty import g_covariance
from xrough.spectra import model_spectrum


def test_covariance_of_a_profile_is_that_of_random_mode_powers():
    """A periodic Gaussian profile's G is ``sum_m P_m (1 - cos k_m d)`` with independent
    exponential ``P_m``: 4000 such sums (spectrum C = q^-3, 4096 pixels) against the model.

    Standard deviations within 5 % (the estimate from 4000 draws scatters by 1.1 %; the
    lattice sum and the model's are the same sum, so only that scatter separates them),
    correlations within 0.06 (an estimated correlation scatters by up to 0.016: 4 of
    those over the 300 pairs).
    """
    q = np.geomspace(1e-4, 1e3, 701)
    C = q**-3.0
    n = 4096
    dr = np.unique(np.round(np.geomspace(1, n / 2, 25)))
    cov = g_covariance(dr, q, C, size=float(n), pixel=1.0, geometry="profile")
    k = 2 * np.pi * np.arange(1, n // 2 + 1) / n
    mean_power = 2 * profile_spectrum_kernel(k, PowerLawInterpolant(q, C), (q[0], q[-1])) / n
    weights = 1 - np.cos(np.outer(k, dr))
    rng = np.random.default_rng(0)
    draws = (mean_power * rng.exponential(size=(4000, k.size))) @ weights
    empirical = np.cov(draws.T)
    sd_model, sd_sim = np.sqrt(np.diag(cov)), np.sqrt(np.diag(empirical))
    np.testing.assert_allclose(sd_model, sd_sim, rtol=0.05)
    rho_model = cov / np.outer(sd_model, sd_model)
    rho_sim = empirical / np.outer(sd_sim, sd_sim)
    np.testing.assert_allclose(rho_model, rho_sim, atol=0.06)


def test_covariance_is_zero_for_invalid_bins_and_symmetric():
    q = np.geomspace(1e-3, 10, 200)
    dr = np.array([1.0, np.nan, 4.0, 16.0])
    for geometry in ("profile", "axis", "radial"):
        cov = g_covariance(dr, q, q**-3.0, size=256.0, pixel=1.0, geometry=geometry)
        assert cov.shape == (4, 4) and np.all(cov[1] == 0) and np.all(cov[:, 1] == 0)
        np.testing.assert_allclose(cov, cov.T, rtol=1e-12)
        assert np.all(np.linalg.eigvalsh(cov[np.ix_([0, 2, 3], [0, 2, 3])]) > 0)


PROFILE = dict(hurst=0.8, lambda_r=128.0, lambda_s=2.0, rms_height=1.0, unit="nm")
N_PROFILE = 2**15
SEEDS = 12


@cache
def profile_spectra():
    """C on a common grid from the G of 12 profiles, with and without the bound."""
    q_r = 2 * np.pi / PROFILE["lambda_r"]
    q = np.geomspace(q_r, 2 * np.pi / 6, 25)  # up to 6 pixels: away from the jump at q_s
    out = []
    for seed in range(SEEDS):
        topo = xrough.self_affine_surface(size=float(N_PROFILE), n=N_PROFILE, profile=True,
                                          seed=seed, **PROFILE)
        G = topo.rough.acf()
        C = xrough.spectrum(G, q, max_error=np.inf, support_rtol=1e3)
        before = xrough.spectrum(G, q, max_error=np.inf)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", xrough.QualityWarning)  # nothing within 10 %
            bounded = xrough.spectrum(G, q)
        out.append((C, before, bounded))
    return q, q_r, out


def test_modelled_error_of_c_follows_the_scatter_between_profiles():
    """standard_error of C against the scatter of C over 12 profiles of 2^15 points: the
    ratio lies in [0.6, 3] at every q from q_r to 6 pixels (measured 1.0-2.7 with
    ``benchmarks/spectrum_errors.py``; 12 draws estimate a scatter to +-21 %)."""
    q, q_r, out = profile_spectra()
    exact = model_spectrum(q, **PROFILE).values
    ratio = np.array([c.values / exact for c, _, _ in out])
    modelled = np.median([c.standard_error.values / exact for c, _, _ in out], axis=0)
    scatter = ratio.std(axis=0, ddof=1)
    assert np.all(modelled / scatter > 0.6) and np.all(modelled / scatter < 3.0), \
        np.round(modelled / scatter, 2)


def test_supported_range_of_one_profile_keeps_its_error_bound():
    """Where any profile's C is supported (default max_error = 0.1), the scatter of C
    between the profiles is at most 0.15 (0.1 plus the +-21 % with which 12 draws estimate
    it, and the model errs on the high side); without the bound, the range reaches down
    to ~2 q_r, where the scatter is 0.2-0.3 and single profiles are off by up to 31 %."""
    q, q_r, out = profile_spectra()
    exact = model_spectrum(q, **PROFILE).values
    ratio = np.array([c.values / exact for c, _, _ in out])
    scatter = ratio.std(axis=0, ddof=1)
    bounded = np.array([b.supported.values == 1 for _, _, b in out])
    before = np.array([b.supported.values == 1 for _, b, _ in out])
    assert bounded.any(axis=0).sum() >= 2  # something is supported
    assert np.all(scatter[bounded.any(axis=0)] <= 0.15), scatter[bounded.any(axis=0)]
    assert np.max(scatter[before.any(axis=0)]) > 0.2  # the check can fail
    for _, _, b in out:
        sup = b.supported.values == 1
        if sup.any():
            assert b.attrs["q_min_supported"] > 4 * q_r
            assert np.all(b.standard_error.values[sup] <= 0.1 * np.abs(b.values[sup]) * 1.05)


def test_no_q_within_the_bound_is_marked_not_raised():
    """A G that determines C, but nowhere to 1 %: nothing supported, a QualityWarning,
    NaN ends, C and its standard error still returned."""
    topo = xrough.self_affine_surface(size=4096.0, n=4096, profile=True, seed=0, **PROFILE)
    G = topo.rough.acf()
    with pytest.warns(xrough.QualityWarning, match="exceeds max_error=0.01 at every q"):
        C = xrough.spectrum(G, max_error=0.01)
    assert C.attrs["quality"] == "questionable"
    assert not C.supported.any() and np.isnan(C.attrs["q_max_supported"])
    assert np.all(np.isfinite(C.values)) and np.all(C.standard_error.values > 0)
    assert C.standard_error.attrs["units"] == "nm4"
    assert "profile G" in C.attrs["error_model"]


@pytest.mark.parametrize("bad", [0.0, -0.1, np.nan, "0.1"])
def test_max_error_must_be_a_positive_number(bad):
    G = xrough.acf_from_spectrum(xrough.model_spectrum(**PROFILE), np.geomspace(1, 1e4, 41))
    with pytest.raises(ValueError, match="max_error must be a positive relative error"):
        xrough.spectrum(G, max_error=bad)


def test_g_without_errors_has_none_in_c():
    G = xrough.acf_from_spectrum(xrough.model_spectrum(**PROFILE), np.geomspace(1, 1e4, 41))
    C = xrough.spectrum(G)
    assert np.all(C.standard_error.values == 0) and C.attrs["error_model"] == "none"
    C = xrough.spectrum(G, noise=0.001)
    assert C.attrs["error_model"] == "noise (independent)"
    assert np.all(C.standard_error.values > 0)
