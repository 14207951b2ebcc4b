"""Cross-check of solve_contact against peer boundary-element solvers (tamaas, ContactMechanics).

The same periodic problem is given to each: the heights are the rigid surface (peaks
towards the elastic body), the periodic half-space has contact modulus ``E*`` (tamaas:
``E = E*``, ``nu = 0``; ContactMechanics: ``young = E*`` without ``poisson``), and the
load is the mean pressure ``p0`` (tamaas) or the total force ``p0 L^2`` (ContactMechanics
works with pixel forces). Each peer is skipped when it is not installed.
"""

import numpy as np
import pytest

import xrough
from xrough.solver import solve_contact

N = 128
L = 1.0  # um
E_STAR = 1.0  # Pa; the problem is linear in E*
LOADS = (0.005, 0.05)  # p0 / (E* gbar): a few percent and about a third in contact
TOL = 1e-8


@pytest.fixture(scope="module")
def problem():
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r=L / 4, lambda_s=4 * L / N,
                                      size=L, n=N, rms_gradient=0.1, seed=7, unit="um")
    h = np.ascontiguousarray(topo.transpose("y", "x").values, dtype=float)
    q = 2 * np.pi * np.fft.fftfreq(N, d=L / N)
    q2 = q[:, None] ** 2 + q[None, :] ** 2
    gbar = float(np.sqrt(np.sum(q2 * np.abs(np.fft.fft2(h)) ** 2)) / N**2)
    p0 = [f * E_STAR * gbar for f in LOADS]
    res = solve_contact(topo, E_star=E_STAR, p0=p0, tol=TOL, progress=False)
    assert res.converged.all()
    return h, p0, res.contact_area.values


def test_contact_area_matches_tamaas(problem):
    tm = pytest.importorskip("tamaas")
    h, p0, area = problem
    for p, a in zip(p0, area):
        model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [L, L], [N, N])
        model.E, model.nu = E_STAR, 0.0
        tm.PolonskyKeerRey(model, h, TOL).solve(p)
        traction = np.asarray(model.traction)
        np.testing.assert_allclose(traction.mean(), p, rtol=1e-10)
        np.testing.assert_allclose(a, np.mean(traction > 0), rtol=0.01)


def test_contact_area_matches_contactmechanics(problem):
    pytest.importorskip("ContactMechanics")
    from ContactMechanics import PeriodicFFTElasticHalfSpace
    from ContactMechanics.Optimization import constrained_conjugate_gradients

    h, p0, area = problem
    for p, a in zip(p0, area):
        substrate = PeriodicFFTElasticHalfSpace((N, N), E_STAR, physical_sizes=(L, L))
        res = constrained_conjugate_gradients(
            substrate, h, external_force=p * L * L, pentol=TOL * float(h.std()),
            forcetol=TOL, thermotol=TOL)
        assert res.success
        force = np.asarray(res.jac)  # compressive pixel forces are positive
        np.testing.assert_allclose(force.sum() / L**2, p, rtol=1e-10)
        np.testing.assert_allclose(a, np.mean(force > 0), rtol=0.01)
