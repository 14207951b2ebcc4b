"""Synthetic self-affine surfaces: statistics against the exact G of their model spectrum."""

import numpy as np
import pytest
import xarray as xr

import xrough


@pytest.mark.parametrize("hurst, rolloff, profile", [(0.5, "sharp", False),
                                                     (0.8, "smooth", False),
                                                     (0.3, "sharp", True)])
def test_seed_average_matches_eq9(hurst, rolloff, profile):
    """G averaged over 24 realisations equals eq. 9 of the model within its error.

    The error of the mean is the seed-to-seed standard deviation over sqrt(24); bins are
    correlated, so all |z| < 3.5 (and a mean |z| near 1) is the expectation. The model
    spectrum is the continuous one with lambda_0 = L; the realisation's discrete modes
    differ from it by far less than the statistical error here.
    """
    p = dict(hurst=hurst, lambda_r="32 nm", lambda_s="4 nm", rms_height="1 nm",
             rolloff=rolloff)
    runs = [xrough.self_affine_surface(size="256 nm", n=2048 if profile else 128, seed=s,
                                       unit="nm", profile=profile, **p)
            .rough.acf(points_per_decade=5) for s in range(24)]
    G = xr.concat(runs, dim="seed")
    mean = G.mean("seed")
    err = G.std("seed") / np.sqrt(G.sizes["seed"])
    model = xrough.acf_from_spectrum(xrough.model_spectrum(lambda_0="256 nm", unit="nm",
                                                           **p), dr=mean.dr.values)
    z = ((mean - model) / err).values
    assert np.all(np.abs(z) < 3.5), z
    assert np.mean(np.abs(z)) < 2.0


def test_amplitude_options_and_units():
    common = dict(hurst=0.7, lambda_r="1 um", lambda_s="20 nm", size="4 um", n=512, seed=0)
    a = xrough.self_affine_surface(rms_height="5 nm", unit="nm", **common)
    b = xrough.self_affine_surface(rms_height=5e-9, unit="m", **common)  # numbers in unit
    # identical up to round-off (heights near zero crossings carry relative noise)
    np.testing.assert_allclose(a.values * 1e-9, b.values, rtol=1e-10, atol=1e-12 * 5e-9)
    assert a.attrs["units"] == "nm" and b.attrs["units"] == "m"
    assert a.attrs["rms_height"] == pytest.approx(5.0)
    # one realisation of a 4 lambda_r wide map: rms height within 25 % of the model
    assert float(a.std()) == pytest.approx(5.0, rel=0.25)
    g = xrough.self_affine_surface(rms_gradient=0.2, unit="nm", **common)
    assert g.attrs["rms_gradient"] == pytest.approx(0.2)
    c = xrough.self_affine_surface(C_r=f"{a.attrs['C_r'] * 1e-36!r} m^4", unit="nm", **common)
    assert c.attrs["C_r"] == pytest.approx(a.attrs["C_r"])
    np.testing.assert_allclose(c.values, a.values, rtol=1e-9)


def test_reproducible_fixed_amplitudes_and_profile():
    common = dict(hurst=0.5, lambda_r="64 nm", lambda_s="4 nm", size="256 nm", n=128,
                  rms_height="1 nm", unit="nm")
    a = xrough.self_affine_surface(seed=5, **common)
    xr.testing.assert_identical(a, xrough.self_affine_surface(seed=5, **common))
    f = xrough.self_affine_surface(seed=5, random_amplitudes=False, **common)
    # fixed moduli: the realised variance equals the discrete sum of the spectrum exactly,
    # independent of the seed
    f2 = xrough.self_affine_surface(seed=6, random_amplitudes=False, **common)
    assert float(f.var()) == pytest.approx(float(f2.var()), rel=1e-10)
    p = xrough.self_affine_surface(seed=5, profile=True, **common)
    assert p.dims == ("x",) and p.sizes["x"] == 128 and p.attrs["periodic"] == 1


@pytest.mark.parametrize("kwargs, match", [
    (dict(lambda_s="1 nm"), "shorter than two pixels"),
    (dict(hurst=1.2), "hurst"),
    (dict(lambda_s="2 um"), "shorter than lambda_r"),
    (dict(rms_height=None), "exactly one"),
    (dict(C_r="1 nm", rms_height=None), "length\\^4"),
    (dict(size="-4 um"), "positive"),
    (dict(n=1), "at least 2"),
    (dict(rolloff="wavy"), "rolloff"),
])
def test_bad_parameters(kwargs, match):
    p = dict(hurst=0.5, lambda_r="1 um", lambda_s="20 nm", size="4 um", n=512,
             rms_height="1 nm", unit="nm")
    p.update(kwargs)
    with pytest.raises(ValueError, match=match):
        xrough.self_affine_surface(**p)
