"""Reference contact solver: analytic solutions (Westergaard, Hertz) and contracts."""


import numpy as np
import pytest
import xarray as xr
from scipy import integrate

import xrough
from xrough._kernels import solver as solver_kernels
from xrough._kernels.solver import pixel_influence
from xrough.solver import ConvergenceWarning, solve_contact

E_STAR = 1e6  # Pa
LAM = 1.0  # um, wavelength
H0 = 0.01  # um, amplitude
P_STAR = np.pi * E_STAR * H0 / LAM  # Westergaard's full-contact pressure


def sinusoid(nx, ny=2):
    x = np.arange(nx) * LAM / nx
    h = np.tile(H0 * np.cos(2 * np.pi * x / LAM), (ny, 1))
    return xrough.topography(h, spacing=LAM / nx, unit="um", periodic=True)


def paraboloid(n, R, L):
    c = (np.arange(n) - n // 2) * L / n
    r2 = c[None, :] ** 2 + c[:, None] ** 2
    return xrough.topography(-r2 / (2 * R), spacing=L / n, unit="um", periodic=False)


def test_pixel_influence_is_love_solution():
    # The non-periodic kernel is 1/(pi r) integrated over a dx x dy pixel; compare with
    # adaptive quadrature away from the singularity (atol: quadrature accuracy) and with
    # the closed form at the centre of a square pixel, (4/pi) asinh(1) dx.
    dx, dy = 1.0, 0.7
    for x, y in [(1.0, 0.0), (0.0, 0.7), (3.0, -2.1), (-5.0, 4.2)]:
        ref = integrate.dblquad(lambda yy, xx, x=x, y=y: 1 / np.hypot(x - xx, y - yy) / np.pi,
                                -dx / 2, dx / 2, -dy / 2, dy / 2, epsabs=1e-12)[0]
        got = pixel_influence(np.array(x), np.array(y), dx, dy)
        np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(pixel_influence(np.array(0.0), np.array(0.0), 2.0, 2.0),
                               8 / np.pi * np.arcsinh(1), rtol=1e-14)


def test_westergaard_contact_width():
    # 2048 points per wavelength: the contact edge is located to +-1 pixel on each side,
    # i.e. a to +-dx/2 = 2.4e-4 lambda, 0.7 % of the smallest a (0.072 lambda at 0.05 p*).
    # The discretisation error itself is smaller; the tolerance is 1 % as stated.
    nx = 2048
    loads = np.array([0.05, 0.1, 0.2, 0.35, 0.5, 0.65, 0.8, 0.95])
    res = solve_contact(sinusoid(nx), E_star=E_STAR, p0=loads * P_STAR, progress=False)
    a = res.contact.isel(y=0).sum("x").values * (LAM / nx) / 2
    a_ref = LAM / np.pi * np.arcsin(np.sqrt(loads))
    np.testing.assert_allclose(a, a_ref, rtol=0.01, atol=0)
    assert res.converged.all()
    # the solution is uniform along y (to rounding: the per-pixel displacement updates
    # add in a different order on the two rows, and the preconditioner's transforms
    # round differently; seen 1.6e-10 at one edge pixel)
    np.testing.assert_allclose(res.pressure.isel(y=0), res.pressure.isel(y=1), rtol=1e-9)
    np.testing.assert_allclose(res.mean_pressure, loads * P_STAR, rtol=1e-12)


def test_westergaard_mean_gap_energy_and_stiffness():
    """The wavy surface's closed forms (Westergaard; s = p0 / p*): mean gap
    ``h0 [1 - s (1 - ln s)]``, elastic energy ``h0 p* (s^2 / 4 - s^2 ln(s) / 2)`` (the
    work ``-int p d(gap)``; ``h0 p* / 4`` at full contact) and stiffness
    ``-dp0/d(gap) = p* / (h0 ln(1/s))``. 2048 points per wavelength: measured within 5e-6
    (gap, energy); rtol 1e-4. The stiffness comes from neighbouring loads 1 % apart (its
    central difference: 2e-5); rtol 1e-3."""
    s = np.array([0.05, 0.2, 0.5, 0.8])
    loads = (s[:, None] * np.array([0.99, 1.0, 1.01])).ravel()
    res = solve_contact(sinusoid(2048), E_star=E_STAR, p0=loads * P_STAR, tol=1e-10,
                        progress=False)
    mid = res.isel(p0=slice(1, None, 3))
    assert res.mean_gap.attrs["units"] == "um"
    assert res.elastic_energy.attrs["units"] == "J m-2"
    assert res.stiffness.attrs["units"] == "Pa um-1"
    np.testing.assert_allclose(mid.mean_gap, H0 * (1 - s * (1 - np.log(s))), rtol=1e-4)
    energy = H0 * 1e-6 * P_STAR * (s**2 / 4 - s**2 * np.log(s) / 2)
    np.testing.assert_allclose(mid.elastic_energy, energy, rtol=1e-4)
    np.testing.assert_allclose(mid.stiffness, P_STAR / (H0 * np.log(1 / s)), rtol=1e-3)
    one = solve_contact(sinusoid(64), E_star=E_STAR, p0=0.5 * P_STAR, progress=False)
    assert np.isnan(float(one.stiffness))
    # the gap distribution: 0 on the contact area, rising beyond it, its mean the mean gap
    # (trapezoid over 21 shares of the area: 1 % for these smooth gap profiles)
    q = mid.gap_quantiles
    shares = q.area_share.values
    for k in range(s.size):
        area = float(mid.contact_area[k])
        np.testing.assert_allclose(q[k].values[shares < area - 0.01], 0, atol=1e-9 * H0)
        assert np.all(q[k].values[shares > area + 0.01] > 0)
        assert np.all(np.diff(q[k].values) >= -1e-12)
    np.testing.assert_allclose(np.trapezoid(q.values, shares, axis=-1), mid.mean_gap,
                               rtol=0.01)


def test_warm_start_from_one_contact_point_recovers():
    """A load started from a solution with one point in contact (its mean-shifted gap is
    zero, so the conjugate direction vanishes) stopped at once, unconverged, with the gap
    at -33 nm; it now starts cold and equals a separate solve (to the solver's tol)."""
    topo = xrough.self_affine_surface(hurst=0.3, lambda_r="16 nm", lambda_s="2 nm",
                                      size="32 nm", n=32, rms_gradient=0.1, unit="nm",
                                      seed=0)
    loads = np.array([9e-3, 0.9, 27.0]) * 1e3  # Pa: one contact point at the first
    res = solve_contact(topo, E_star="1 MPa", p0=loads, progress=False)
    assert res.converged.all()
    assert float(res.contact_area[0]) == 1 / 32**2
    alone = solve_contact(topo, E_star="1 MPa", p0=loads[1], progress=False)
    np.testing.assert_allclose(res.mean_gap[1], alone.mean_gap, rtol=1e-6)
    assert float(res.gap.min()) > -1e-6


def test_energy_is_the_work_of_the_load_on_a_random_surface():
    """p0 = -dU/d(mean gap) on a self-affine map (the energy and the gap of the solver
    agree as the work of the load): loads 1 % apart, within 1e-3 (measured 2e-5)."""
    topo = xrough.self_affine_surface(hurst=0.8, n=128, size="128 nm", rms_gradient=0.1,
                                      lambda_r="32 nm", lambda_s="2 nm", seed=1, unit="nm")
    p0 = 3e3 * np.array([0.99, 1.0, 1.01])
    res = solve_contact(topo, E_star="1 MPa", p0=p0, tol=1e-10, progress=False)
    work = -np.gradient(res.elastic_energy.values, res.mean_gap.values * 1e-9)
    assert work[1] == pytest.approx(p0[1], rel=1e-3)


@pytest.mark.parametrize("factor", [1.2, 3.0])
def test_full_contact_pressure_is_exact(factor):
    # Beyond p* the whole surface is in contact and p = p0 + (E*/2)|q| h~(q); with the
    # periodic Green's function this holds exactly, so only the tolerance (1e-8 on the
    # relative residual) limits agreement: 1e-6 relative to p0 is a wide margin. The gap
    # is checked to 1e-9 h0, so the solve asks for tol = 1e-10 (gap error 7e-11 h0 rms).
    topo = sinusoid(256)
    p0 = factor * P_STAR
    res = solve_contact(topo, E_star=E_STAR, p0=p0, tol=1e-10, progress=False)
    assert res.attrs["relative_contact_area"] == 1.0
    x = topo.x.values  # um
    expected = p0 + E_STAR / 2 * (2 * np.pi / LAM) * H0 * np.cos(2 * np.pi * x / LAM)
    np.testing.assert_allclose(res.pressure.isel(y=0), expected, rtol=0, atol=1e-6 * p0)
    np.testing.assert_allclose(res.gap, 0, atol=1e-9 * H0)


def test_full_contact_random_surface():
    # a random periodic surface pressed beyond full contact: p - p0 = (E*/2)|q| h~(q)
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="0.5 um", lambda_s="0.08 um",
                                      size="2 um", n=64, rms_gradient=0.1, seed=3,
                                      unit="um")
    h = topo.values
    qy = 2 * np.pi * np.fft.fftfreq(64, d=2 / 64)
    q = np.hypot(qy[:, None], qy[None, :])
    dp = np.fft.ifft2(np.fft.fft2(h) * q).real * E_STAR / 2
    p0 = 1.5 * -dp.min()
    res = solve_contact(topo, E_star=E_STAR, p0=p0, progress=False)
    assert float(res.contact_area) == 1.0
    np.testing.assert_allclose(res.pressure, p0 + dp, rtol=0, atol=1e-6 * p0)


def test_full_contact_shortcut_equals_iteration():
    # Beyond full contact the periodic solve takes the closed form (one transform pair
    # plus the check) instead of iterating; the Polonsky-Keer iteration, run directly,
    # must reach the same field: to its tol of 1e-10 on the relative residual, so 1e-7
    # of p0 is a wide margin. Just below the threshold the solve iterates as before.
    topo = xrough.self_affine_surface(hurst=0.5, lambda_r="0.5 um", lambda_s="0.04 um",
                                      size="2 um", n=128, rms_gradient=0.1, seed=5,
                                      unit="um")
    h = np.ascontiguousarray(topo.transpose("y", "x").values)
    op = solver_kernels.ElasticOperator(h.shape, (2 / 128, 2 / 128), periodic=True)
    stress = solver_kernels.full_contact_stress(h, op)
    threshold = -float(stress.min()) * E_STAR
    res = solve_contact(topo, E_star=E_STAR, p0=[0.9 * threshold, 1.1 * threshold],
                        tol=1e-10, progress=False)
    assert res.contact_area.values[0] < 1 and res.iterations.values[0] > 1
    assert res.contact_area.values[1] == 1 and res.iterations.values[1] == 1
    assert res.transforms.values[1] == 4 and res.residual.values[1, 0] < 1e-12
    it = solver_kernels.solve_load(h, op, 1.1 * threshold / E_STAR, tol=1e-10,
                                    max_iter=10_000, precondition=False)
    assert it["iterations"] > 10
    np.testing.assert_allclose(res.pressure.values[1], it["pressure"] * E_STAR, rtol=0,
                               atol=1e-7 * 1.1 * threshold)
    # preconditioned, the first step from the uniform start is the closed form itself
    # (K^-1 of the gap on the whole map): converged at the second iteration's check
    pc = solver_kernels.solve_load(h, op, 1.1 * threshold / E_STAR, tol=1e-10,
                                    max_iter=10_000, precondition=True)
    assert pc["iterations"] <= 2
    np.testing.assert_allclose(pc["pressure"], it["pressure"], rtol=0,
                               atol=1e-7 * 1.1 * threshold / E_STAR)


@pytest.mark.parametrize("precision", ["float64", "mixed"])
def test_convergence_history_reaches_tol(precision):
    topo = sinusoid(512, ny=256)  # 2^17 points: mixed precision applies
    for tol in (1e-6, 1e-10):
        res = solve_contact(topo, E_star=E_STAR, p0=0.3 * P_STAR, tol=tol, progress=False,
                            precision=precision, timing=True, coarse_to_fine=0)
        hist = res.residual.values
        assert res.attrs["iterations"] == hist.size == int(res.iterations)
        # stops at the first float64 residual below tol (float32 ones are only estimates)
        n32 = int(res.float32_iterations)
        assert (n32 > 0) == (precision == "mixed")
        assert hist[-1] < tol <= hist[n32:-1].min(initial=np.inf)
        assert hist[0] > 1e3 * hist[-1]  # and it did go down from a poor start
        assert int(res.converged) == 1 and res.attrs["tol"] == tol
        assert res.attrs["precision"] == precision
        assert float(res.time_per_iteration) > 0 and res.time_per_iteration.attrs["units"] == "s"
        assert res.attrs["solve_time"] == pytest.approx(
            float(res.time_per_iteration) * hist.size, rel=1e-12)


def self_affine_512():
    return xrough.self_affine_surface(hurst=0.8, lambda_r="0.25 um", lambda_s="8 nm",
                                      size="1 um", n=512, rms_gradient=0.1, seed=2,
                                      unit="um")


def test_mixed_precision_reaches_tol():
    # float32 transforms, then a float64 polish: the same solution as float64 throughout
    # to the tolerance, and the residual recomputed in float64 is below tol
    topo = self_affine_512()
    p0 = 0.01 * 0.1 * E_STAR
    tol = 1e-9
    mixed = solve_contact(topo, E_star=E_STAR, p0=p0, tol=tol, progress=False)
    ref = solve_contact(topo, E_star=E_STAR, p0=p0, tol=tol, progress=False,
                        precision="float64")
    assert int(mixed.converged) == 1 and int(mixed.float32_iterations) > 10
    assert int(mixed.transforms) < 4 * int(mixed.iterations)  # fewer than 2 pairs per it
    np.testing.assert_array_equal(mixed.contact, ref.contact)
    np.testing.assert_allclose(mixed.pressure, ref.pressure, rtol=0, atol=1e-5 * p0)
    rms_h = float(topo.std())
    gap_err = np.where(mixed.contact == 1, mixed.gap, np.minimum(mixed.gap, 0))
    assert np.sqrt(np.mean(gap_err**2)) < 10 * tol * rms_h
    assert float(mixed.mean_pressure) == pytest.approx(p0, rel=1e-12)


def test_float64_phase_restarts_reach_the_same_solution(monkeypatch):
    # The float32 phase ended at a residual of 0.1 (far from the solution), with at most
    # two pixels corrected one by one and a restart after two float64 iterations without
    # progress: the float64 phase then corrects u by float32 pairs of transforms and
    # starts again from u transformed afresh. Its solution is the float64 one to the
    # tolerance: the same contact set, pressures within 1e-5 p0 (as the mixed solve above).
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r=64, lambda_s=4, size=256, n=256,
                                      rms_gradient=0.1, seed=2, unit="um", rolloff="smooth")
    h = np.ascontiguousarray(topo.transpose("y", "x").values)
    h = h + 0.3 * float(h.std()) * np.random.default_rng(256).standard_normal(h.shape)
    op = solver_kernels.ElasticOperator(h.shape, (1.0, 1.0), periodic=True)
    p0, tol = 2e-3 * float(np.abs(h).max()), 1e-9
    ref = solver_kernels.solve_load(h, op, p0, tol=tol, max_iter=3000, precision="float64")
    monkeypatch.setattr(solver_kernels, "FLOAT32_TOL", 0.1)
    monkeypatch.setattr(solver_kernels, "STALL", 1)
    monkeypatch.setattr(solver_kernels, "POINT_LOADS_MAX", {np.float32: 2, np.float64: 2})
    mixed = solver_kernels.solve_load(h, op, p0, tol=tol, max_iter=3000, precision="mixed")
    assert mixed["converged"] and ref["converged"]
    assert 0 < mixed["float32_iterations"] < 10 and mixed["refreshes"] > 0
    np.testing.assert_array_equal(mixed["pressure"] > 0, ref["pressure"] > 0)
    np.testing.assert_allclose(mixed["pressure"], ref["pressure"], rtol=0, atol=1e-5 * p0)


def test_coarse_to_fine_same_solution_as_cold_start():
    topo = self_affine_512()
    p0 = 0.01 * 0.1 * E_STAR
    tol = 1e-9
    cold = solve_contact(topo, E_star=E_STAR, p0=p0, tol=tol, progress=False,
                         coarse_to_fine=0)
    c2f = solve_contact(topo, E_star=E_STAR, p0=p0, tol=tol, progress=False,
                        coarse_to_fine=2)
    assert int(c2f.coarse_iterations) > 0 and int(cold.coarse_iterations) == 0
    assert int(c2f.iterations) > int(c2f.coarse_iterations) and int(c2f.converged) == 1
    assert c2f.attrs["coarse_to_fine"] == 2
    # the history is the fine grid's; the coarse iterations add to the count
    assert int(c2f.iterations) == c2f.residual.size + int(c2f.coarse_iterations)
    np.testing.assert_array_equal(c2f.contact, cold.contact)
    np.testing.assert_allclose(c2f.pressure, cold.pressure, rtol=0, atol=1e-5 * p0)
    np.testing.assert_allclose(c2f.gap, cold.gap, rtol=0, atol=1e-7 * float(topo.std()))


def test_proportioning_same_solution_fewer_iterations(monkeypatch):
    # overlapping points enter late (proportioning); the solution is that of plain
    # Polonsky-Keer (every overlap enters at once) to the tolerance, in fewer iterations
    topo = self_affine_512()
    p0 = 0.01 * 0.1 * E_STAR
    tol = 1e-9
    prop = solve_contact(topo, E_star=E_STAR, p0=p0, tol=tol, progress=False)
    monkeypatch.setattr(solver_kernels, "PROPORTION", 0.0)
    plain = solve_contact(topo, E_star=E_STAR, p0=p0, tol=tol, progress=False)
    assert int(prop.deferred_entries) > 0 and int(plain.deferred_entries) == 0
    assert int(prop.converged) == 1 and int(prop.iterations) < int(plain.iterations)
    np.testing.assert_array_equal(prop.contact, plain.contact)
    np.testing.assert_allclose(prop.pressure, plain.pressure, rtol=0, atol=1e-5 * p0)
    np.testing.assert_allclose(prop.gap, plain.gap, rtol=0, atol=1e-7 * float(topo.std()))


@pytest.mark.parametrize("periodic", [True, False])
@pytest.mark.parametrize("p_star", [0.01, 0.3])
def test_preconditioner_same_solution_fewer_iterations(periodic, p_star):
    # the FFT preconditioner (K^-1 of the gap on the contact set; on open maps the
    # inverse of the zero-padded kernel, an approximate inverse) changes the path, not
    # the solution: both solves meet tol = 1e-10, so the fields agree to 1e-6 of p0 and
    # the contact sets exactly. Iterations measured on this map (plain / preconditioned):
    # periodic 98 / 46 and 245 / 75, open 91 / 46 and 320 / 103 at p* = 0.01 and 0.3
    # (coarse grid included)
    topo = self_affine_512().assign_attrs(periodic=periodic)
    p0 = p_star * 0.1 * E_STAR
    kw = {"E_star": E_STAR, "p0": p0, "tol": 1e-10, "progress": False}
    plain = solve_contact(topo, precondition=False, **kw)
    pc = solve_contact(topo, precondition=True, **kw)
    assert plain.attrs["precondition"] == 0 and pc.attrs["precondition"] == 1
    assert int(pc.converged) == 1
    # K t and K^-1 g: at least two pairs of transforms per fine iteration
    assert int(pc.transforms) >= 4 * pc.residual.size
    assert int(pc.iterations) < (0.75 if p_star < 0.1 else 0.5) * int(plain.iterations)
    np.testing.assert_array_equal(pc.contact, plain.contact)
    np.testing.assert_allclose(pc.pressure, plain.pressure, rtol=0, atol=1e-6 * p0)
    np.testing.assert_allclose(pc.gap, plain.gap, rtol=0, atol=1e-8 * float(topo.std()))


def test_not_converged_warns():
    with pytest.warns(ConvergenceWarning, match="max_iter=3"):
        res = solve_contact(sinusoid(256), E_star=E_STAR, p0=0.3 * P_STAR, max_iter=3,
                            progress=False)
    assert int(res.converged) == 0 and int(res.iterations) == 3


def test_several_p0_equal_separate_calls():
    # warm starts change the path, not the solution: agreement to a few tol
    topo = xrough.self_affine_surface(hurst=0.7, lambda_r="0.5 um", lambda_s="0.08 um",
                                      size="2 um", n=64, rms_gradient=0.2, seed=7,
                                      unit="um")
    loads = [2e3, 5e3, 1e4]
    many = solve_contact(topo, E_star=E_STAR, p0=loads, tol=1e-10, progress=False)
    assert many.pressure.dims == ("p0", "y", "x") and many.residual.dims == ("p0", "iteration")
    for i, p0 in enumerate(loads):
        one = solve_contact(topo, E_star=E_STAR, p0=p0, tol=1e-10, progress=False)
        sel = many.isel(p0=i)
        np.testing.assert_allclose(sel.pressure, one.pressure, rtol=0, atol=1e-6 * p0)
        np.testing.assert_array_equal(sel.contact, one.contact)
        assert float(sel.contact_area) == one.attrs["relative_contact_area"]
    # later loads start from the previous solution: fewer iterations than a cold start
    assert int(many.iterations[-1]) < int(one.iterations)
    # NaN padding of the histories
    n = many.iterations.values
    assert np.isnan(many.residual.values[np.argmin(n), n.min():]).all()


def test_hertz_nonperiodic():
    # Paraboloid R = 10 um on a 128^2 map of 4 um (dx = 31 nm); a = 0.8 um = 26 pixels, so
    # the area-equivalent radius is resolved to ~1/26 of a pixel rim: 3 % is generous.
    n, R, L = 128, 10.0, 4.0
    topo = paraboloid(n, R, L)
    a_target = 0.8e-6  # m
    P = 4 * E_STAR * a_target**3 / (3 * R * 1e-6)  # N
    p0 = P / (L * 1e-6) ** 2
    res = solve_contact(topo, E_star=E_STAR, p0=p0, progress=False)
    assert res.attrs["periodic"] == 0 and "zero-padded" in res.attrs["green_function"]
    a = np.sqrt(float(res.contact.sum()) * (L / n) ** 2 / np.pi)  # um
    np.testing.assert_allclose(a, a_target * 1e6, rtol=0.03)
    # Hertz peak pressure 3P / (2 pi a^2) and approach a^2 / R (a few % on this grid)
    p_max = 3 * P / (2 * np.pi * a_target**2)
    np.testing.assert_allclose(float(res.pressure.max()), p_max, rtol=0.05)
    np.testing.assert_allclose(float(res.approach), 0.8**2 / R, rtol=0.03)
    assert float(res.gap.min()) > -1e-6 * 0.8**2 / R


def test_prescribed_displacement_matches_load():
    # the approach found at p0 is prescribed back: the same mean pressure and field
    n, R, L = 64, 10.0, 4.0
    topo = paraboloid(n, R, L)
    ref = solve_contact(topo, E_star=E_STAR, p0=2e3, progress=False)
    res = solve_contact(topo, E_star=E_STAR, displacement=float(ref.approach),
                        progress=False)
    np.testing.assert_allclose(float(res.mean_pressure), 2e3, rtol=1e-6)
    np.testing.assert_allclose(res.pressure, ref.pressure, rtol=0, atol=1e-5 * 2e3)
    # periodic: the displacement is the approach of the mean surface; below full contact
    wave = sinusoid(256)
    r2 = solve_contact(wave, E_star=E_STAR, displacement=[0.004, "8 nm"], progress=False)
    np.testing.assert_allclose(r2.approach, [0.004, 0.008], rtol=1e-6)
    assert r2.pressure.dims == ("delta", "y", "x") and r2.delta.attrs["units"] == "um"
    with pytest.raises(ValueError, match="full contact"):
        solve_contact(wave, E_star=E_STAR, displacement=0.02, progress=False)


def test_output_units_and_netcdf_legal_attrs():
    topo = sinusoid(64)
    topo_nm = topo.copy(data=topo.values * 1000)
    topo_nm.attrs["units"] = "nm"  # heights in nm on an um grid
    res = solve_contact(topo, E_star="1 MPa", p0="0.01 MPa", progress=False)
    res_nm = solve_contact(topo_nm, E_star=E_STAR, p0=1e4, progress=False)
    assert res.pressure.attrs["units"] == "Pa" and res.gap.attrs["units"] == "um"
    assert res_nm.gap.attrs["units"] == "nm" and res.x.attrs["units"] == "um"
    np.testing.assert_allclose(res_nm.pressure, res.pressure, rtol=1e-9)
    np.testing.assert_allclose(res_nm.displacement, 1000 * res.displacement, rtol=1e-9,
                               atol=1e-9)
    assert res.contact.dtype == np.int8 and res.attrs["E_star"] == 1e6
    for v in res.attrs.values():
        assert isinstance(v, (str, int, float))
    xr.Dataset.from_dict(res.to_dict())  # plain types only


@pytest.mark.parametrize("kwargs, match", [
    ({"E_star": 0, "p0": 1.0}, "E_star must be positive"),
    ({"E_star": -1e6, "p0": 1.0}, "E_star must be positive"),
    ({"E_star": "1 m", "p0": 1.0}, "not a pressure"),
    ({"E_star": 1e6, "p0": 0.0}, "p0 must be positive"),
    ({"E_star": 1e6, "p0": [1.0, -1.0]}, "p0 must be positive"),
    ({"E_star": 1e6}, "exactly one of p0"),
    ({"E_star": 1e6, "p0": 1.0, "displacement": 1.0}, "exactly one of p0"),
    ({"E_star": 1e6, "displacement": -1.0}, "displacement must be a positive"),
    ({"E_star": 1e6, "p0": 1.0, "tol": 0}, "tol"),
    ({"E_star": 1e6, "p0": 1.0, "precision": "float16"}, "precision"),
    ({"E_star": 1e6, "p0": 1.0, "coarse_to_fine": -1}, "coarse_to_fine"),
    ({"E_star": 1e6, "p0": 1.0, "precondition": "yes"}, "precondition"),
])
def test_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        solve_contact(sinusoid(16), progress=False, **kwargs)


def test_bad_topography():
    topo = sinusoid(16)
    nan = topo.copy()
    nan[0, 3] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        solve_contact(nan, E_star=E_STAR, p0=1.0)
    uneven = topo.assign_coords(x=("x", np.r_[0, np.cumsum(np.linspace(1, 2, 15))] * 0.01,
                                   {"units": "um"}))
    with pytest.raises(ValueError, match="not uniformly spaced"):
        solve_contact(uneven, E_star=E_STAR, p0=1.0)
    with pytest.raises(ValueError, match="profile"):
        solve_contact(topo.isel(y=0), E_star=E_STAR, p0=1.0)
    with pytest.raises(ValueError, match="one map at a time"):
        solve_contact(xr.concat([topo, topo], "scan"), E_star=E_STAR, p0=1.0)


def test_progress_bar_runs(capsys):
    res = solve_contact(sinusoid(64), E_star=E_STAR, p0=0.5 * P_STAR, progress=True)
    assert int(res.converged) == 1
    assert "contact" in capsys.readouterr().err


def test_dask_input_is_computed():
    topo = sinusoid(64)
    res = solve_contact(topo.chunk(), E_star=E_STAR, p0=0.5 * P_STAR, progress=False)
    ref = solve_contact(topo, E_star=E_STAR, p0=0.5 * P_STAR, progress=False)
    xr.testing.assert_identical(res, ref)
    assert res.pressure.chunks is None


def test_self_affine_surface_converges():
    # a 256^2 self-affine surface at p0 = 0.01 E* gbar (run time: benchmarks/bench_solver.py)
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="0.08 um",
                                      size="8 um", n=256, rms_gradient=0.5, seed=1,
                                      unit="um")
    res = solve_contact(topo, E_star=E_STAR, p0=0.01 * E_STAR * 0.5, progress=False)
    assert int(res.converged) == 1 and 0 < res.attrs["relative_contact_area"] < 0.1
