"""Absurd arguments get a ValueError that names them, never an overflow or a huge allocation."""

import numpy as np
import pytest

import xrough


@pytest.fixture(scope="module")
def topo():
    return xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="400 nm",
                                      size="10 um", n=64, rms_gradient=0.5, seed=1, unit="nm")


@pytest.fixture(scope="module")
def G(topo):
    return topo.rough.acf()


@pytest.mark.parametrize("E_star", [1e300, "1e300 Pa", 1e-300])
@pytest.mark.parametrize("call", [
    lambda G, E: G.rough.persson(E_star=E, p0=1e5),
    lambda G, E: G.rough.stress_acf(E_star=E),
    lambda G, E: G.rough.energy(E_star=E),
    lambda G, E: G.rough.patch_radius(E_star=E, gamma=0.05),
])
def test_modulus_whose_square_overflows_is_refused(G, E_star, call):
    # (E*/2)^2 of 1e300 Pa overflows float64: the old code raised OverflowError deep inside
    with pytest.raises(ValueError, match="E_star .* outside 1e-100 to 1e100"):
        call(G, E_star)


@pytest.mark.parametrize("ppd", [np.inf, np.nan, 0, -1, 1e9])
def test_points_per_decade_must_be_finite_and_sane(topo, ppd):
    with pytest.raises(ValueError, match="points_per_decade must be a positive number"):
        topo.rough.acf(points_per_decade=ppd)


def test_linear_bins_finer_than_the_lattice_are_refused_before_allocating(topo):
    # 1e-6 nm bins over 5 um: 5e9 bins (the old code tried to allocate 37 GiB)
    with pytest.raises(ValueError, match="bin_width=1e-06 nm gives .* linear bins"):
        topo.rough.acf(bins="linear", bin_width=1e-6)
