"""Invariances of the public functions: units, argument forms, provenance, bins, G rules.

1. Unit invariance: the same surface or G in nm, um and m gives the same physics.
2. Argument forms: a length, pressure, energy or modulus given as a number, a string, a
   pint Quantity (of xrough's registry or another), a DataArray with ``units`` gives the
   same result; the wrong dimension is a ValueError naming the parameter.
3. Provenance attrs survive every estimator and are carried to results derived from G.
4. Bin density: the elastic energy does not depend on the lag bins.
5. One rule set for what counts as a G, the same in every function that takes one.

numpy = dask is in test_backends.py; shared inputs and comparisons in
invariance_support.py. Tolerances are stated, with the reason, where they are used.
"""

from __future__ import annotations

import functools
import re
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pint
import pytest
import xarray as xr
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from invariance_support import (
    FROM_NM,
    LAGS_NM,
    MODEL,
    assert_attrs_close,
    assert_same_attrs,
    assert_same_physics,
    in_length_unit,
    model_G,
    model_spectrum_nm,
    surface_nm,
    variables,
)

import xrough
from xrough.units import ureg

UNITS = ("um", "m")  # compared with nm

#: Hypothesis: reproducible examples, no shrinking (a failure reports its example at once,
#: and a known failure does not spend minutes shrinking).
PROPERTY = settings(deadline=None, derandomize=True, phases=(Phase.explicit, Phase.generate),
                    suppress_health_check=[HealthCheck.too_slow])


@functools.cache
def _topo_nm(n: int = 128, periodic: bool = True) -> xr.DataArray:
    return surface_nm(n=n, periodic=periodic)


@functools.cache
def _G_nm(n_lags: int = 41) -> xr.DataArray:
    return model_G(n_lags=n_lags)


# ======================================================================================
# 1. unit invariance
# ======================================================================================
ACF_CASES = {
    "fft": {},
    "fft-x": {"direction": "x"},
    "fft-linear": {"bins": "linear", "dr_max": "80 nm"},
    "fft-range": {"dr_min": "6 nm", "dr_max": "150 nm"},
    "random": {"estimator": "random", "n_pairs": 20_000, "seed": 3},
    "tiled": {"estimator": "tiled", "dr_max": "300 nm"},
}


@pytest.mark.parametrize("unit", UNITS)
@pytest.mark.parametrize("case", list(ACF_CASES))
def test_height_difference_acf_is_unit_invariant(case, unit):
    """G of one map in nm, um and m: the same G, bins, errors and attrs.

    Tolerance 1e-10: the pair sums are those of heights scaled by a power of ten (one
    rounding each); log bin edges ``10**((k +- 1/2)/ppd)`` map onto each other between
    units that differ by powers of ten and linear edges scale, so every pair falls in the
    same bin; the random estimator draws the same lattice lags and points from the same
    seed. Measured: ~1e-13 (standard_error, a sum over lags), ~1e-15 elsewhere.
    """
    topo = _topo_nm(periodic=case != "tiled")
    ref = xrough.height_difference_acf(topo, **ACF_CASES[case])
    got = xrough.height_difference_acf(in_length_unit(topo, unit), **ACF_CASES[case])
    assert_same_physics(ref, got, rtol=1e-10)
    assert_same_attrs(ref, got, "nm", unit)


PREPROCESS = {
    "detrend-plane": lambda t, f: xrough.detrend(t, mode="plane"),
    "detrend-curvature-per-line": lambda t, f: xrough.detrend(t, mode="curvature",
                                                              per_line=True),
    "fit_trend-curvature": lambda t, f: xrough.fit_trend(t, mode="curvature"),
    "mask_outliers": lambda t, f: xrough.mask_outliers(t, threshold=2.5),
    # a plain-number window is in the data's lateral unit: 24 nm in every unit
    "mask_outliers-window-number": lambda t, f: xrough.mask_outliers(t, threshold=2.5,
                                                                     window=24 * f),
    "mask_outliers-window-string": lambda t, f: xrough.mask_outliers(t, threshold=2.5,
                                                                     window="24 nm"),
    "reliable": lambda t, f: xrough.reliable(t, tip_radius="50 nm",
                                             lateral_resolution=6 * f),
}


@pytest.mark.parametrize("unit", UNITS)
@pytest.mark.parametrize("case", list(PREPROCESS))
def test_preprocessing_is_unit_invariant(case, unit):
    """Detrending, trend coefficients, outlier masks and reliability windows.

    Tolerance 1e-10 plus 1e-12 of the largest |value|: least-squares fits run on
    coordinates centred and scaled to [-1, 1] (unit-free) and on heights scaled by a
    power of ten, so residuals agree to round-off of the fit; the residuals cross zero,
    hence the absolute part. Robust z-scores are ratios of heights: the same points are
    masked (NaN positions must match exactly).
    """
    f = FROM_NM[unit]
    topo = _topo_nm(64)
    ref = PREPROCESS[case](topo, 1.0)
    got = PREPROCESS[case](in_length_unit(topo, unit), f)
    assert_same_physics(ref, got, rtol=1e-10, atol_frac=1e-12)
    assert_same_attrs(ref, got, "nm", unit)


@pytest.mark.parametrize("units", [("um", "um"), ("m", "m"), ("nm", "um"), ("m", "nm")],
                         ids="-".join)
def test_stitch_is_unit_invariant(units):
    """A crop and a coarse copy of one map, each in its own unit, stitch to one G.

    The stitched G is in the first measurement's units; converted, it is the all-nm G.
    Tolerance 1e-10: common bins are centred on ``10**(k/ppd)`` in every power-of-ten
    unit, windows are in pixels and scan sizes, G per window is exact (see
    test_height_difference_acf_is_unit_invariant), and the combination is a weighted
    mean of ln G.
    """
    topo = _topo_nm()
    fine = topo.isel(x=slice(0, 64), y=slice(0, 64)).assign_attrs(periodic=0)
    coarse = topo.isel(x=slice(None, None, 2), y=slice(None, None, 2))
    ref = xrough.stitch({"fine": fine, "coarse": coarse}, warn=False)
    got = xrough.stitch({"fine": in_length_unit(fine, units[0]),
                         "coarse": in_length_unit(coarse, units[1])}, warn=False)
    assert_same_physics(ref, got, rtol=1e-10)
    assert_same_attrs(ref, got, "nm", units[0])


SOLVER = {
    "p0": lambda t, f: xrough.solve_contact(t, E_star="25 MPa", p0="1 MPa"),
    "p0-many": lambda t, f: xrough.solve_contact(t, E_star=25e6, p0=[5e5, 2e6]),
    # a plain-number displacement is in the height unit: 1 nm in every unit
    "displacement-number": lambda t, f: xrough.solve_contact(t, E_star="25 MPa",
                                                             displacement=1.0 * f),
    "displacement-string": lambda t, f: xrough.solve_contact(t, E_star="25 MPa",
                                                             displacement="1 nm"),
}


@pytest.mark.parametrize("unit", UNITS)
@pytest.mark.parametrize("case", list(SOLVER))
def test_solve_contact_is_unit_invariant(case, unit):
    """The contact solution of one map in nm, um and m.

    Same iterations, contact set and convergence flags exactly. Fields: rtol 1e-9 plus
    1e-9 of their largest value. The iteration runs on p/E* and heights in the lateral
    unit (the same numbers up to round-off in every unit) and stops at tol = 1e-8; the
    pressure vanishes at the contact edges and the gap inside the contact, hence the
    absolute part. The residual history is a relative change of the pressure of order
    tol; the search direction is transformed in float32 (rounding ~1e-7 of each step,
    docs/solver.md), so the history near tol agrees to ~1e-7/1e-8 relative: rtol 1e-3
    (measured 6e-5). Measured: 1e-11 on the fields.
    """
    f = FROM_NM[unit]
    topo = _topo_nm(64)
    ref = SOLVER[case](topo, 1.0)
    got = SOLVER[case](in_length_unit(topo, unit), f)
    assert_same_physics(ref, got, rtol=1e-9, atol_frac=1e-9,
                        tolerances={"residual": (1e-3, 0.0)})
    assert_same_attrs(ref, got, "nm", unit)


def _spectrum(unit):
    return xrough.model_spectrum(hurst=0.8, rms_gradient=0.5, unit=unit, **MODEL)


SPECTRAL = {
    "model_spectrum": _spectrum,
    "model_spectrum-smooth-rms_height-lambda_0": lambda unit: xrough.model_spectrum(
        hurst=0.6, lambda_r="1 um", lambda_s="10 nm", lambda_0="5 um", rms_height="2 nm",
        rolloff="smooth", unit=unit),
    # plain numbers are in `unit` (lengths) and unit^4 (C_r)
    "model_spectrum-numbers-C_r": lambda unit: xrough.model_spectrum(
        hurst=0.8, lambda_r=1000 * FROM_NM[unit], lambda_s=10 * FROM_NM[unit],
        C_r=1e6 * FROM_NM[unit] ** 4, unit=unit),
    "acf_from_spectrum": lambda unit: xrough.acf_from_spectrum(_spectrum(unit)),
    "acf_from_spectrum-dr": lambda unit: xrough.acf_from_spectrum(
        _spectrum(unit), np.geomspace(1.0, 1e5, 30) * FROM_NM[unit]),
    "gradient_from_spectrum": lambda unit: xrough.gradient_from_spectrum(_spectrum(unit)),
    "gradient_from_spectrum-dr": lambda unit: xrough.gradient_from_spectrum(
        _spectrum(unit), np.geomspace(1.0, 1e5, 30) * FROM_NM[unit]),
    "stress_acf_from_spectrum": lambda unit: xrough.stress_acf_from_spectrum(
        _spectrum(unit), np.geomspace(1.0, 1e5, 30) * FROM_NM[unit], E_star="25 MPa"),
    "self_affine_surface": lambda unit: xrough.self_affine_surface(
        hurst=0.8, lambda_r="200 nm", lambda_s="8 nm", size="512 nm", n=128,
        rms_gradient=0.3, seed=1, unit=unit),
    "self_affine_surface-profile-smooth": lambda unit: xrough.self_affine_surface(
        hurst=0.7, lambda_r="200 nm", lambda_s="8 nm", size="1024 nm", n=512,
        rms_height="3 nm", rolloff="smooth", profile=True, seed=2, unit=unit),
}


@pytest.mark.parametrize("unit", UNITS)
@pytest.mark.parametrize("case", list(SPECTRAL))
def test_spectral_functions_are_unit_invariant(case, unit):
    """Model spectra, their G, gbar and stress ACF, synthetic surfaces, in any unit.

    Tolerance 1e-10 plus 1e-12 of the largest |value| (synthetic heights and the stress
    ACF cross zero): every wavenumber and amplitude is the same quantity scaled by a power
    of ten; eq. 9 and eq. 26 are evaluated in the products ``q dr`` (unit-free); the
    synthetic surfaces draw the same white noise from the same seed.
    """
    ref, got = SPECTRAL[case]("nm"), SPECTRAL[case](unit)
    assert_same_physics(ref, got, rtol=1e-10, atol_frac=1e-12)
    assert_same_attrs(ref, got, "nm", unit)


# (function of G and the length factor, tolerances) -- see the test's docstring
_FIT = 1e-7  # least-squares optimiser: stops at its own tolerance
_SPLINE = (1e-8, 1e-8)  # GCV smoothing spline of ln G
_HANKEL = 1e-9  # spectrum of G: oscillatory sums that amplify round-off
_PERSSON_TOL = {"sigma_quick": (_FIT, 0.0), "G_sigma": _SPLINE, "Gamma_sigma": _SPLINE,
                # eq. 51 with G's local exponent: the slope of the same smoothing spline
                "Gamma_sigma_sa": _SPLINE, "Gamma_sigma_51": _SPLINE}


G_FUNCTIONS: dict[str, tuple[Callable, dict]] = {
    "fit_acf": (lambda G, f: xrough.fit_acf(G), {"rtol": _FIT}),
    "fit_acf-range-lambda_0": (lambda G, f: xrough.fit_acf(
        G, dr_min=3 * f, dr_max="50 um", lambda_0=2e5 * f), {"rtol": _FIT}),
    "fit_acf-eq36-fix-sigma_h": (lambda G, f: xrough.fit_acf(
        G, model="eq36", fix={"sigma_h": 23.0 * f}), {"rtol": _FIT}),
    "model_acf": (lambda G, f: xrough.model_acf(
        xrough.fit_acf(G), np.geomspace(2, 2e4, 9) * f), {"rtol": _FIT}),
    "gradient_from_fit-eq36": (lambda G, f: xrough.gradient_from_fit(
        xrough.fit_acf(G, model="eq36")), {"rtol": _FIT}),
    "spectrum": (lambda G, f: xrough.spectrum(G), {
        "rtol": _HANKEL, "tolerances": {"standard_error": (1e-8, 0.0)}}),
    "rms_gradient_exact": (lambda G, f: xrough.rms_gradient_exact(G), {"rtol": _HANKEL}),
    "rms_gradient-simple": (lambda G, f: xrough.rms_gradient(G, method="simple"),
                            {"rtol": 1e-10}),
    "rms_gradient-fit": (lambda G, f: xrough.rms_gradient(G, method="fit"),
                         {"rtol": _FIT}),
    "rms_gradient-exact": (lambda G, f: xrough.rms_gradient(G, method="exact"),
                           {"rtol": _HANKEL}),
    "rms_gradient-auto": (lambda G, f: xrough.rms_gradient(G), {"rtol": _HANKEL}),
    "elastic_energy": (lambda G, f: xrough.elastic_energy(
        G, E_star="25 MPa", a_c=np.array([3.0, 30.0, 300.0, 3000.0]) * f),
        {"rtol": 1e-10}),
    "stress_acf": (lambda G, f: xrough.stress_acf(G, E_star="25 MPa"),
                   {"rtol": _SPLINE[0], "atol_frac": _SPLINE[1]}),
    "stress_acf-p0": (lambda G, f: xrough.stress_acf(G, E_star=25e6, p0="1 MPa"),
                      {"rtol": _SPLINE[0], "atol_frac": _SPLINE[1]}),
    "persson": (lambda G, f: xrough.persson(G, E_star="25 MPa", p0=["0.1 MPa", "1 MPa"]),
                {"rtol": _HANKEL, "tolerances": _PERSSON_TOL}),
    "persson-modified-simple": (lambda G, f: xrough.persson(
        G, E_star=25e6, p0=1e6, theory="modified", gradient_method="simple"),
        {"rtol": 1e-10, "tolerances": _PERSSON_TOL}),
    "patch_radius": (lambda G, f: xrough.patch_radius(G, E_star="25 MPa",
                                                      gamma="50 mJ/m^2"), {"rtol": 1e-10}),
}


def _run_recording(func, *args):
    """Call ``func``; return its result and the (category, text) of each warning issued."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = func(*args)
    return result, [(w.category, str(w.message)) for w in caught]


@functools.cache
def _G_function_nm(case: str):
    """The nm result of a G_FUNCTIONS case and its warnings (the reference of the units)."""
    return _run_recording(G_FUNCTIONS[case][0], _G_nm(), 1.0)


#: attrs that come from the same optimiser or interpolation as the data they describe
_ATTR_TOL = {"reduced_chi2": _FIT, "dr_min_supported": 1e-8, "dr_max_supported": 1e-8}


@pytest.mark.parametrize("unit", UNITS)
@pytest.mark.parametrize("case", list(G_FUNCTIONS))
def test_functions_of_G_are_unit_invariant(case, unit):
    """Every function of G gives the same physics for G in nm, um and m.

    The G is the model G with 2 % scatter and its standard error (see model_G). Plain
    lengths are in the unit of dr (``f`` converts them). Tolerances, by what limits them:

    - 1e-10 (energy, patch radius, simple gbar, Persson with it): closed-form integrals
      of power-law pieces and root finding at rtol 1e-12;
    - 1e-9 (spectrum, exact gbar): the Hankel transform of eq. 10/11 sums oscillating
      terms, whose cancellation amplifies the round-off of the scaled inputs (measured
      4e-12); the end of the supported range (attrs) is interpolated where a relative
      change crosses support_rtol: 1e-8 (measured 2e-10); the standard error of C
      propagates one perturbation of G per eigenvector of G's error covariance, whose
      small eigenvectors carry the round-off: 1e-8 (measured 1.2e-9);
    - 1e-7 (fits and everything from them: gbar 'fit', sigma_quick): the least-squares
      optimiser stops at its own tolerance and works on ln G_sa, which shifts by ln 1e6
      between nm and um, so the steps differ in the last digits (measured 5e-11 on the
      parameters, 2e-9 on their standard deviations);
    - 1e-8 plus 1e-8 of the largest value (stress ACF): its Laplacian is that of a
      smoothing spline whose smoothing parameter a 1-D GCV minimisation chooses, on
      ln dr shifted by ln 1000 (measured 1e-10 of the largest value); it crosses zero.

    The warnings are the same too: the model G's 2 % scatter makes its exact rms gradient
    rise by 30 % between two lags, which Persson theory marks questionable in every unit.
    """
    func, tol = G_FUNCTIONS[case]
    ref, ref_warnings = _G_function_nm(case)
    got, got_warnings = _run_recording(func, in_length_unit(_G_nm(), unit), FROM_NM[unit])
    assert [c for c, _ in got_warnings] == [c for c, _ in ref_warnings]
    assert_same_physics(ref, got, **tol)
    assert_same_attrs(ref, got, "nm", unit, tolerances=_ATTR_TOL)


@pytest.mark.parametrize("unit", UNITS)
def test_exact_gradient_support_does_not_depend_on_the_unit(unit):
    """The lags where the exact gbar is determined are the same in nm, um and m.

    G on lags from 1 nm to 100 um (whole decades, as ``acf_from_spectrum(C, dr_min=1,
    dr_max=1e5)`` gives): the wavenumber grid of the support test then has exactly 10
    points per decade, so neighbours two steps apart are exactly 0.2 decades apart, the
    width of the envelope the support rule takes its maximum over. Whether they count
    must not be decided by the round-off of the unit (in nm, um and m a different number
    of such pairs does): the same physics must give the same lags. Tolerances as in
    test_functions_of_G_are_unit_invariant.
    """
    C = model_spectrum_nm()
    G = xrough.acf_from_spectrum(C, dr_min=1, dr_max=1e5, points_per_decade=10)
    ref = xrough.rms_gradient_exact(G)
    got = xrough.rms_gradient_exact(in_length_unit(G, unit))
    assert_same_physics(ref, got, rtol=_HANKEL)
    assert_same_attrs(ref, got, "nm", unit, tolerances=_ATTR_TOL)


# ======================================================================================
# 2. argument forms
# ======================================================================================
@functools.cache
def _other_registry() -> pint.UnitRegistry:
    """A pint registry that is not xrough's (as a user's own code would create)."""
    return pint.UnitRegistry()


@dataclass(frozen=True)
class Arg:
    """One parameter of one public function and the same value in every form.

    ``call(value)`` runs the function with the parameter set to ``value``; ``number`` is
    the plain-number form (lengths tied to data in the data's unit, nm here; physical
    parameters in SI), ``magnitude`` the same value in ``unit`` (another unit than the
    data's), ``wrong`` a unit of the wrong dimension; ``dim`` marks an array-valued
    parameter (the dim of a 1-D DataArray), ``strings`` whether it takes a sequence of
    strings (as documented for ``p0``); ``match`` the name the error message must contain.
    """

    call: Callable[[Any], Any]
    number: Any
    magnitude: Any
    unit: str
    wrong: str
    match: str
    dim: str | None = None
    strings: bool = False


def _G21() -> xr.DataArray:
    return _G_nm(21)


@functools.cache
def _fit36() -> xr.Dataset:
    return xrough.fit_acf(_G21(), model="eq36")


@functools.cache
def _contact_map() -> xr.DataArray:
    return xrough.self_affine_surface(hurst=0.8, lambda_r="64 nm", lambda_s="8 nm",
                                      size="128 nm", n=32, rms_gradient=0.1, seed=1,
                                      unit="nm")


def _surface(**kw):
    base = {"hurst": 0.8, "lambda_r": 200, "lambda_s": 8, "size": 256, "n": 64,
            "rms_gradient": 0.3, "seed": 1, "unit": "nm"}
    base.update(kw)
    if "rms_height" in kw or "C_r" in kw:
        base.pop("rms_gradient")
    return xrough.self_affine_surface(**base)


def _model(**kw):
    base = {"hurst": 0.8, "lambda_r": 1000, "lambda_s": 10, "rms_gradient": 0.5,
            "unit": "nm"}
    base.update(kw)
    if "rms_height" in kw or "C_r" in kw:
        base.pop("rms_gradient")
    return xrough.model_spectrum(**base)


MPA = "MPa"
# stress_acf and persson run with gradient_method="simple": the forms of E_star and p0
# are under test here, not the gradient, and it keeps these cases fast
ARGS: dict[str, Arg] = {
    # --- contact mechanics from G: physical parameters (SI numbers), lengths (dr unit)
    "elastic_energy.E_star": Arg(lambda v: xrough.elastic_energy(_G21(), E_star=v),
                                 25e6, 25, MPA, "um", "E_star"),
    "elastic_energy.a_c": Arg(lambda v: xrough.elastic_energy(_G21(), E_star=25e6, a_c=v),
                              200.0, 0.2, "um", "MPa", "a_c"),
    "elastic_energy.a_c[]": Arg(lambda v: xrough.elastic_energy(_G21(), E_star=25e6,
                                                                a_c=v),
                                [200.0, 800.0], [0.2, 0.8], "um", "MPa", "a_c", dim="a_c",
                                strings=True),
    "stress_acf.E_star": Arg(lambda v: xrough.stress_acf(_G21(), E_star=v),
                             25e6, 25, MPA, "um", "E_star"),
    "stress_acf.p0": Arg(lambda v: xrough.stress_acf(_G21(), E_star=25e6, p0=v,
                                                     gradient_method="simple"),
                         1e6, 1, MPA, "um", "p0"),
    "stress_acf.p0[]": Arg(lambda v: xrough.stress_acf(_G21(), E_star=25e6, p0=v,
                                                       gradient_method="simple"),
                           [1e5, 1e6], [0.1, 1.0], MPA, "um", "p0", dim="p0", strings=True),
    "persson.E_star": Arg(lambda v: xrough.persson(_G21(), E_star=v, p0=1e6,
                                                   gradient_method="simple",
                                                   variables=("a_r", "G_sigma")),
                          25e6, 25, MPA, "um", "E_star"),
    "persson.p0": Arg(lambda v: xrough.persson(_G21(), E_star=25e6, p0=v,
                                               gradient_method="simple",
                                               variables=("a_r", "G_sigma")),
                      1e6, 1, MPA, "um", "p0"),
    "persson.p0[]": Arg(lambda v: xrough.persson(_G21(), E_star=25e6, p0=v,
                                                 gradient_method="simple",
                                                 variables=("a_r", "G_sigma")),
                        [1e5, 1e6], [0.1, 1.0], MPA, "um", "p0", dim="p0", strings=True),
    "patch_radius.E_star": Arg(lambda v: xrough.patch_radius(_G21(), E_star=v, gamma=0.05),
                               25e6, 25, MPA, "um", "E_star"),
    "patch_radius.gamma": Arg(lambda v: xrough.patch_radius(_G21(), E_star=25e6, gamma=v),
                              0.05, 50, "mJ/m^2", "MPa", "gamma"),
    # --- fits of G
    "fit_acf.dr_min": Arg(lambda v: xrough.fit_acf(_G21(), model="eq36", dr_min=v),
                          5.0, 0.005, "um", "MPa", "dr_min"),
    "fit_acf.dr_max": Arg(lambda v: xrough.fit_acf(_G21(), model="eq36", dr_max=v),
                          5e4, 50, "um", "MPa", "dr_max"),
    "fit_acf.lambda_0": Arg(lambda v: xrough.fit_acf(_G21(), lambda_0=v),
                            2e5, 0.2, "mm", "MPa", "lambda_0"),
    "fit_acf.fix.lambda_r": Arg(lambda v: xrough.fit_acf(_G21(), fix={"lambda_r": v}),
                                1000.0, 1, "um", "MPa", "lambda_r"),
    "fit_acf.fix.lambda_s": Arg(lambda v: xrough.fit_acf(_G21(), fix={"lambda_s": v}),
                                10.0, 0.01, "um", "MPa", "lambda_s"),
    "fit_acf.fix.sigma_h": Arg(lambda v: xrough.fit_acf(_G21(), model="eq36",
                                                        fix={"sigma_h": v}),
                               23.0, 0.023, "um", "MPa", "sigma_h"),
    "model_acf.dr[]": Arg(lambda v: xrough.model_acf(_fit36(), v),
                          [200.0, 800.0], [0.2, 0.8], "um", "MPa", "dr", dim="dr"),
    "gradient_from_fit.dr[]": Arg(lambda v: xrough.gradient_from_fit(_fit36(), v),
                                  [200.0, 800.0], [0.2, 0.8], "um", "MPa", "dr", dim="dr"),
    # --- spectra
    "spectrum.q[]": Arg(lambda v: xrough.spectrum(_G21(), v),
                        [0.001, 0.01], [1.0, 10.0], "1/um", "um", "q", dim="q"),
    "rms_gradient_exact.dr[]": Arg(lambda v: xrough.rms_gradient_exact(_G21(), v),
                                   [200.0, 800.0], [0.2, 0.8], "um", "MPa", "dr", dim="dr"),
    "model_spectrum.q[]": Arg(lambda v: _model(q=v), [0.001, 0.01], [1.0, 10.0], "1/um",
                              "um", "q", dim="q"),
    "model_spectrum.lambda_r": Arg(lambda v: _model(lambda_r=v), 1000.0, 1, "um", "MPa",
                                   "lambda_r"),
    "model_spectrum.lambda_s": Arg(lambda v: _model(lambda_s=v), 10.0, 0.01, "um", "MPa",
                                   "lambda_s"),
    "model_spectrum.lambda_0": Arg(lambda v: _model(lambda_0=v), 5000.0, 5, "um", "MPa",
                                   "lambda_0"),
    "model_spectrum.rms_height": Arg(lambda v: _model(rms_height=v), 2.0, 0.002, "um",
                                     "MPa", "rms_height"),
    "model_spectrum.C_r": Arg(lambda v: _model(C_r=v), 1e6, 1e-6, "um**4", "MPa", "C_r"),
    "acf_from_spectrum.dr[]": Arg(lambda v: xrough.acf_from_spectrum(model_spectrum_nm(),
                                                                     v),
                                  [200.0, 800.0], [0.2, 0.8], "um", "MPa", "dr", dim="dr"),
    "acf_from_spectrum.dr_min": Arg(lambda v: xrough.acf_from_spectrum(
        model_spectrum_nm(), dr_min=v, dr_max=1e4), 2.0, 0.002, "um", "MPa", "dr_min"),
    "acf_from_spectrum.dr_max": Arg(lambda v: xrough.acf_from_spectrum(
        model_spectrum_nm(), dr_min=2.0, dr_max=v), 1e4, 10, "um", "MPa", "dr_max"),
    "gradient_from_spectrum.dr[]": Arg(lambda v: xrough.gradient_from_spectrum(
        model_spectrum_nm(), v), [200.0, 800.0], [0.2, 0.8], "um", "MPa", "dr", dim="dr"),
    "gradient_from_spectrum.dr_min": Arg(lambda v: xrough.gradient_from_spectrum(
        model_spectrum_nm(), dr_min=v, dr_max=1e4), 2.0, 0.002, "um", "MPa", "dr_min"),
    "gradient_from_spectrum.dr_max": Arg(lambda v: xrough.gradient_from_spectrum(
        model_spectrum_nm(), dr_min=2.0, dr_max=v), 1e4, 10, "um", "MPa", "dr_max"),
    "stress_acf_from_spectrum.dr[]": Arg(lambda v: xrough.stress_acf_from_spectrum(
        model_spectrum_nm(), v, E_star=25e6), [200.0, 800.0], [0.2, 0.8], "um", "MPa", "dr",
        dim="dr"),
    "stress_acf_from_spectrum.E_star": Arg(lambda v: xrough.stress_acf_from_spectrum(
        model_spectrum_nm(), [200.0, 800.0], E_star=v), 25e6, 25, MPA, "um", "E_star"),
    # --- topographies
    "height_difference_acf.dr_min": Arg(lambda v: xrough.height_difference_acf(
        _topo_nm(64), dr_min=v), 8.0, 0.008, "um", "MPa", "dr_min"),
    "height_difference_acf.dr_max": Arg(lambda v: xrough.height_difference_acf(
        _topo_nm(64), dr_max=v), 100.0, 0.1, "um", "MPa", "dr_max"),
    "height_difference_acf.bin_width": Arg(lambda v: xrough.height_difference_acf(
        _topo_nm(64), bins="linear", bin_width=v, dr_max=64), 8.0, 0.008, "um", "MPa",
        "bin_width"),
    "height_difference_acf.bins[]": Arg(lambda v: xrough.height_difference_acf(
        _topo_nm(64), bins=v), [3.0, 10.0, 40.0, 100.0], [0.003, 0.01, 0.04, 0.1], "um",
        "MPa", "bins", dim="edge"),
    "topography.spacing": Arg(lambda v: xrough.topography(_topo_nm(64).values, spacing=v,
                                                          unit="nm"),
                              4.0, 0.004, "um", "MPa", "spacing"),
    "topography.size": Arg(lambda v: xrough.topography(_topo_nm(64).values, size=v,
                                                       unit="nm"),
                           256.0, 0.256, "um", "MPa", "size"),
    "self_affine_surface.size": Arg(lambda v: _surface(size=v), 256.0, 0.256, "um", "MPa",
                                    "size"),
    "self_affine_surface.lambda_r": Arg(lambda v: _surface(lambda_r=v), 200.0, 0.2, "um",
                                        "MPa", "lambda_r"),
    "self_affine_surface.lambda_s": Arg(lambda v: _surface(lambda_s=v), 8.0, 0.008, "um",
                                        "MPa", "lambda_s"),
    "self_affine_surface.lambda_0": Arg(lambda v: _surface(lambda_0=v), 512.0, 0.512, "um",
                                        "MPa", "lambda_0"),
    "self_affine_surface.rms_height": Arg(lambda v: _surface(rms_height=v), 2.0, 0.002,
                                          "um", "MPa", "rms_height"),
    "self_affine_surface.C_r": Arg(lambda v: _surface(C_r=v), 1e5, 1e-7, "um**4", "MPa",
                                   "C_r"),
    "mask_outliers.window": Arg(lambda v: xrough.mask_outliers(_topo_nm(64), threshold=2.5,
                                                               window=v),
                                20.0, 0.02, "um", "MPa", "window"),
    "reliable.short_cutoff": Arg(lambda v: xrough.reliable(_topo_nm(64), short_cutoff=v),
                                 8.0, 0.008, "um", "MPa", "short_cutoff"),
    "reliable.long_cutoff": Arg(lambda v: xrough.reliable(_topo_nm(64), long_cutoff=v),
                                100.0, 0.1, "um", "MPa", "long_cutoff"),
    "reliable.tip_radius": Arg(lambda v: xrough.reliable(_topo_nm(64), tip_radius=v),
                               50.0, 0.05, "um", "MPa", "tip_radius"),
    "reliable.lateral_resolution": Arg(lambda v: xrough.reliable(_topo_nm(64),
                                                                 lateral_resolution=v),
                                       6.0, 0.006, "um", "MPa", "lateral_resolution"),
    "stitch.windows": Arg(lambda v: xrough.stitch(
        {"a": _topo_nm(64), "b": _topo_nm(64).isel(x=slice(None, None, 2),
                                                   y=slice(None, None, 2))},
        windows={"a": (v, None)}, warn=False), 12.0, 0.012, "um", "MPa", "windows"),
    "solve_contact.E_star": Arg(lambda v: xrough.solve_contact(_contact_map(), E_star=v,
                                                               p0=1e6),
                                25e6, 25, MPA, "um", "E_star"),
    "solve_contact.p0": Arg(lambda v: xrough.solve_contact(_contact_map(), E_star=25e6,
                                                           p0=v),
                            1e6, 1, MPA, "um", "p0"),
    "solve_contact.p0[]": Arg(lambda v: xrough.solve_contact(_contact_map(), E_star=25e6,
                                                             p0=v),
                              [5e5, 1e6], [0.5, 1.0], MPA, "um", "p0", dim="p0",
                              strings=True),
    "solve_contact.displacement": Arg(lambda v: xrough.solve_contact(
        _contact_map(), E_star=25e6, displacement=v), 0.5, 0.0005, "um", "MPa",
        "displacement"),
    "solve_contact.displacement[]": Arg(lambda v: xrough.solve_contact(
        _contact_map(), E_star=25e6, displacement=v), [0.3, 0.6], [0.0003, 0.0006], "um",
        "MPa", "displacement", dim="delta", strings=True),
}
# compare_with_simulation forwards E_star and p0 to solve_contact and persson (above);
# one call takes seconds, so it is not repeated for every form here.

SCALAR_FORMS = ("string", "quantity", "other-registry", "dataarray-0d")
ARRAY_FORMS = ("ndarray", "quantity", "other-registry", "dataarray-1d", "strings")


def _form(arg: Arg, form: str, magnitude=None, unit=None):
    """The value of ``arg`` in ``form`` (``magnitude`` in ``unit``, default the Arg's)."""
    mag = arg.magnitude if magnitude is None else magnitude
    unit = arg.unit if unit is None else unit
    if form == "number":
        return arg.number
    if form == "ndarray":
        return np.asarray(arg.number, dtype=float)
    if form == "string":
        return f"{mag!r} {unit}"
    if form == "strings":
        return [f"{m!r} {unit}" for m in mag]
    if form == "quantity":
        return ureg.Quantity(np.asarray(mag) if arg.dim else mag, unit)
    if form == "other-registry":
        return _other_registry().Quantity(np.asarray(mag) if arg.dim else mag, unit)
    if form == "dataarray-0d":
        return xr.DataArray(float(mag), attrs={"units": unit})
    if form == "dataarray-1d":
        return xr.DataArray(np.asarray(mag, dtype=float), dims=arg.dim,
                            attrs={"units": unit})
    raise KeyError(form)


def _form_cases():
    for name, arg in ARGS.items():
        for form in (ARRAY_FORMS if arg.dim else SCALAR_FORMS):
            if form == "strings" and not arg.strings:
                continue
            yield pytest.param(name, form, id=f"{name}-{form}")


@functools.cache
def _number_result(name: str):
    return ARGS[name].call(ARGS[name].number)


def _assert_same_result(got, ref) -> None:
    """The same result to 1e-12: values, coordinates and attrs (numbers to 1e-12)."""
    xr.testing.assert_allclose(got, ref, rtol=1e-12, atol=0)
    assert_attrs_close(got.attrs, ref.attrs, rtol=1e-12)
    for name, var in variables(ref).items():
        assert_attrs_close(variables(got)[name].attrs, var.attrs, rtol=1e-12, what=name)


@pytest.mark.parametrize(("name", "form"), list(_form_cases()))
def test_argument_forms_give_identical_results(name, form):
    """The plain number and every other form of the same value: identical results.

    A string, a pint Quantity (xrough's registry or another one), a DataArray with a
    ``units`` attribute (0-d, or 1-D for array-valued parameters, in another unit than
    the data's) and a sequence of strings all describe the same value as the plain
    number (in the data's unit for lengths tied to data, SI for physical parameters).
    Tolerance 1e-12: one unit conversion (e.g. 0.2 um -> 200 nm) rounds once; nothing
    downstream may depend on the form.
    """
    arg = ARGS[name]
    got = arg.call(_form(arg, form))
    _assert_same_result(got, _number_result(name))


def _wrong_cases():
    for name, arg in ARGS.items():
        forms = ("quantity", "other-registry", "dataarray-1d" if arg.dim else "dataarray-0d")
        if not arg.dim or arg.strings:  # a string form exists for this parameter
            forms = ("strings" if arg.dim else "string",) + forms
        for form in forms:
            yield pytest.param(name, form, id=f"{name}-{form}")


@pytest.mark.parametrize(("name", "form"), list(_wrong_cases()))
def test_wrong_dimension_is_a_value_error_naming_the_parameter(name, form):
    """``E_star="1 um"``, ``a_c="1 MPa"``...: a ValueError whose message names the parameter.

    Never a silent conversion, a TypeError, or pint's DimensionalityError.
    """
    arg = ARGS[name]
    value = _form(arg, form, unit=arg.wrong)
    with pytest.raises(ValueError, match=re.escape(arg.match)) as info:
        arg.call(value)
    assert type(info.value).__module__.split(".")[0] != "pint", repr(info.value)


PREFIXES = {"": 1.0, "k": 1e3, "M": 1e6, "G": 1e9}


@settings(PROPERTY, max_examples=20)
@given(E=st.floats(0.5, 500.0), E_prefix=st.sampled_from(["M", "G"]),
       p=st.floats(0.01, 100.0), p_prefix=st.sampled_from(["", "k", "M"]),
       form=st.sampled_from(SCALAR_FORMS))
def test_pressure_forms_agree_for_any_magnitude_and_prefix(E, E_prefix, p, p_prefix, form):
    """E_star and p0 in any SI prefix and form equal the number in Pa (rtol 1e-12).

    Tolerance: one multiplication by a power of ten per parameter; the persson result
    (contact area, stress ACF) and the energy are smooth in both.
    """
    G = _G21()
    e_arg = Arg(None, E * PREFIXES[E_prefix], E, f"{E_prefix}Pa", "um", "E_star")
    p_arg = Arg(None, p * PREFIXES[p_prefix], p, f"{p_prefix}Pa", "um", "p0")
    ref = xrough.persson(G, E_star=e_arg.number, p0=p_arg.number, gradient_method="simple",
                         variables=("a_r", "G_sigma"))
    got = xrough.persson(G, E_star=_form(e_arg, form), p0=_form(p_arg, form),
                         gradient_method="simple", variables=("a_r", "G_sigma"))
    _assert_same_result(got, ref)
    ref = xrough.elastic_energy(G, E_star=e_arg.number)
    _assert_same_result(xrough.elastic_energy(G, E_star=_form(e_arg, form)), ref)


_LAG_FUNCTIONS = {
    "elastic_energy.a_c[]": "a_c",
    "acf_from_spectrum.dr[]": "dr",
    "gradient_from_spectrum.dr[]": "dr",
    "stress_acf_from_spectrum.dr[]": "dr",
    "model_acf.dr[]": "dr",
    "rms_gradient_exact.dr[]": "dr",
}


@settings(PROPERTY, max_examples=30)
@given(lags=st.lists(st.floats(10.0, 5000.0), min_size=1, max_size=4, unique=True),
       unit=st.sampled_from(["pm", "nm", "um", "mm", "m"]),
       form=st.sampled_from(["quantity", "other-registry", "dataarray-1d"]),
       name=st.sampled_from(sorted(_LAG_FUNCTIONS)))
def test_lag_arrays_in_any_unit_equal_the_numbers_in_the_data_unit(lags, unit, form, name):
    """Lags (a_c, dr) with units of their own: the same as the numbers in nm (1e-12).

    The G and spectra are in nm; the lags come as a Quantity or a 1-D DataArray in pm ...
    m. Tolerance: the conversion to nm and back rounds twice.
    """
    lags = sorted(lags)
    base = ARGS[name]
    in_unit = [x * xrough.units.conversion_factor("nm", unit) for x in lags]
    arg = Arg(base.call, lags, in_unit, unit, "MPa", base.match, dim=_LAG_FUNCTIONS[name])
    ref = arg.call(lags)
    _assert_same_result(arg.call(_form(arg, form)), ref)


# ======================================================================================
# 3. attrs and provenance
# ======================================================================================
PROVENANCE = ("source_file", "source_sha256", "format", "overrides", "source", "instrument")


@pytest.fixture(scope="module")
def opened(tmp_path_factory):
    """A 128^2 open map with an ``instrument`` attr, written to NetCDF, opened back.

    ``xrough.open_topography`` adds ``source_file``, ``source_sha256``, ``format``,
    ``overrides`` (and keeps ``source``).
    """
    path = tmp_path_factory.mktemp("provenance") / "scan.nc"
    topo = _topo_nm(128, periodic=False).assign_attrs(instrument="AFM, tip 8 nm")
    topo.to_netcdf(path)
    out = xrough.open_topography(path)
    for key in PROVENANCE:
        assert key in out.attrs, key
    return out


def _missing(result, topo, keys=PROVENANCE) -> dict:
    return {k: result.attrs.get(k) for k in keys if result.attrs.get(k) != topo.attrs[k]}


ESTIMATORS = {
    "fft": lambda t: xrough.height_difference_acf(t, estimator="fft"),
    "random": lambda t: xrough.height_difference_acf(t, estimator="random", n_pairs=20_000,
                                                     seed=1),
    "tiled": lambda t: xrough.height_difference_acf(t, estimator="tiled"),
    "auto": lambda t: xrough.height_difference_acf(t),
    "auto-chunked-map": lambda t: xrough.height_difference_acf(t.chunk({"y": 64, "x": 64})),
}


@pytest.mark.parametrize("estimator", list(ESTIMATORS))
def test_acf_keeps_the_provenance_of_the_topography(opened, estimator):
    """G from every estimator carries the provenance attrs of the topography.

    'auto' on a map split into dask chunks in y and x takes the tiled estimator
    (xrough.correlation._choice.choose_estimator); that is checked, then the same attrs.
    """
    G = ESTIMATORS[estimator](opened)
    if estimator == "auto-chunked-map":
        assert G.attrs["estimator"].startswith("tiled"), G.attrs["estimator"]
    assert _missing(G, opened) == {}


PREPROCESSING = {
    "detrend": lambda t: xrough.detrend(t),
    "mask_outliers": lambda t: xrough.mask_outliers(t, threshold=3.0),
    "reliable": lambda t: xrough.reliable(t, tip_radius="20 nm"),
}


@pytest.mark.parametrize("step", list(PREPROCESSING))
def test_preprocessing_keeps_the_provenance(opened, step):
    assert _missing(PREPROCESSING[step](opened), opened) == {}


def test_stitch_keeps_the_provenance_of_every_measurement(tmp_path):
    """Two files stitched: each one's source_file and source_sha256 are in the attrs."""
    topo = _topo_nm(128, periodic=False)
    paths = {"fine": tmp_path / "fine.nc", "coarse": tmp_path / "coarse.nc"}
    topo.isel(x=slice(0, 64), y=slice(0, 64)).to_netcdf(paths["fine"])
    topo.isel(x=slice(None, None, 2), y=slice(None, None, 2)).to_netcdf(paths["coarse"])
    opened = {k: xrough.open_topography(p) for k, p in paths.items()}
    G = xrough.stitch(opened, warn=False)
    text = " ".join(str(v) for v in G.attrs.values())
    for name, t in opened.items():
        for key in ("source_file", "source_sha256"):
            assert t.attrs[key] in text, f"{name}: {key} {t.attrs[key]!r} lost"


FROM_G = {
    "fit_acf": lambda G: xrough.fit_acf(G),
    # G of a 128^2 map without a plateau does not fix C to 1 % anywhere, and from one
    # map its standard error exceeds 50 % everywhere: looser support, no error bound
    "spectrum": lambda G: xrough.spectrum(G, support_rtol=0.1, max_error=np.inf),
    "rms_gradient": lambda G: xrough.rms_gradient(G),
    "rms_gradient_exact": lambda G: xrough.rms_gradient_exact(G),
    "persson": lambda G: xrough.persson(G, E_star="25 MPa", p0="1 MPa"),
    "elastic_energy": lambda G: xrough.elastic_energy(G, E_star="25 MPa"),
    "patch_radius": lambda G: xrough.patch_radius(G, E_star="25 MPa", gamma="50 mJ/m^2"),
    "stress_acf": lambda G: xrough.stress_acf(G, E_star="25 MPa"),
    "stress_acf-p0": lambda G: xrough.stress_acf(G, E_star="25 MPa", p0="1 MPa"),
}


@pytest.fixture(scope="module")
def opened_G(opened):
    return xrough.height_difference_acf(opened)


@pytest.mark.parametrize("func", list(FROM_G))
def test_results_from_G_carry_the_source_forward(opened_G, func):
    """Fits, spectra, gradients and contact results name the file they come from."""
    result = FROM_G[func](opened_G)
    assert _missing(result, opened_G, ("source_file", "source_sha256")) == {}


# ======================================================================================
# 4. bin density
# ======================================================================================
@settings(PROPERTY, max_examples=8)
@given(seed=st.integers(0, 2**16), hurst=st.sampled_from([0.3, 0.5, 0.7, 0.9]))
def test_elastic_energy_does_not_depend_on_the_bin_density(seed, hurst):
    """v_el (eq. 16) and v_el(a_c) (eq. 44) at 10, 20 and 40 bins per decade: within 1 %.

    v_el is a property of the surface; the bins only change the quadrature of
    ``int G / r^2 dr`` (monotone cubics in log-log between bin means, the same even start
    below the first bins, which are 1 and sqrt(2) pixels at every density). Measured on such maps:
    0.1-0.3 %; 1 % leaves room and still catches an integral that depends on the number
    of bins (e.g. a sum over bins without their widths, or a misplaced bin centre: 5-50 %).
    """
    topo = surface_nm(n=64, seed=seed, hurst=hurst)
    with warnings.catch_warnings():  # H = 0.3: most of v_el lies below one pixel (flagged)
        warnings.simplefilter("ignore", xrough.quality.QualityWarning)
        energies = [xrough.elastic_energy(topo.rough.acf(points_per_decade=ppd),
                                          E_star="25 MPa", a_c=[20.0, 80.0])
                    for ppd in (10, 20, 40)]
    for e in energies[1:]:
        np.testing.assert_allclose(float(e.v_el), float(energies[0].v_el), rtol=0.01)
        np.testing.assert_allclose(e.v_el_patch.values, energies[0].v_el_patch.values,
                                   rtol=0.01)


# ======================================================================================
# 5. one rule set for G
# ======================================================================================
TAKES_G = {
    "persson": lambda G: xrough.persson(G, E_star="25 MPa", p0="1 MPa"),
    "spectrum": lambda G: xrough.spectrum(G),
    "fit_acf": lambda G: xrough.fit_acf(G),
    "rms_gradient": lambda G: xrough.rms_gradient(G),
    "rms_gradient_exact": lambda G: xrough.rms_gradient_exact(G),
    "elastic_energy": lambda G: xrough.elastic_energy(G, E_star="25 MPa"),
    "stress_acf": lambda G: xrough.stress_acf(G, E_star="25 MPa"),
    "patch_radius": lambda G: xrough.patch_radius(G, E_star="25 MPa", gamma="50 mJ/m^2"),
}


def _falling_G() -> xr.DataArray:
    """A G that falls by 40 %: the plateau of the model G times ``1 - 0.4 t``, t in [0, 1].

    Positive everywhere and falling steadily (not an overshoot): no G can do that.
    """
    G = xrough.acf_from_spectrum(model_spectrum_nm(), np.geomspace(1e4, 1e6, 11))
    return (G * (1 - 0.4 * np.linspace(0, 1, G.sizes["dr"]))).assign_attrs(G.attrs)


def _height_acf() -> xr.DataArray:
    """The height ACF ``sigma_h^2 - G`` of the smooth model up to lambda_r: positive, it
    falls from sigma_h^2 to below 1 % of it (the sharp model's G overshoots sigma_h^2)."""
    C = model_spectrum_nm(rolloff="smooth")
    G = xrough.acf_from_spectrum(C, np.geomspace(LAGS_NM[0], 1e3, 31))
    acf = C.attrs["rms_height"] ** 2 - G
    assert float(acf.min()) > 0
    return acf.assign_attrs(G.attrs)


FALLING = {"falling-40%": _falling_G, "height-acf": _height_acf}
_HEIGHT_ACF = re.compile(r"height (ACF|autocorrelation)")


def _error(func, G) -> str:
    with pytest.raises(ValueError) as info:
        func(G)
    return str(info.value)


@pytest.mark.parametrize("case", list(FALLING))
@pytest.mark.parametrize("func", list(TAKES_G))
def test_a_falling_G_is_refused_as_a_height_acf(func, case):
    """Every function that takes G refuses one that falls overall: a ValueError naming it."""
    G = FALLING[case]()
    assert _HEIGHT_ACF.search(_error(TAKES_G[func], G))


@pytest.mark.parametrize("case", list(FALLING))
def test_a_falling_G_is_refused_with_one_message(case):
    """One validator: the same message from every function (no function-specific rule)."""
    G = FALLING[case]()
    messages = {}
    for name, func in TAKES_G.items():
        try:
            func(G)
            messages[name] = "accepted"
        except Exception as err:  # noqa: BLE001 - any other outcome is reported
            messages[name] = f"{type(err).__name__}: {err}"
    assert len(set(messages.values())) == 1, messages


def _zero_lag_G() -> tuple[xr.DataArray, xr.DataArray]:
    """The model G (no scatter) with and without a first bin at dr = 0 where G = 0."""
    G = model_G(scatter=0)
    dr = np.concatenate([[0.0], G.dr.values])
    G0 = xr.DataArray(np.concatenate([[0.0], G.values]), dims="dr", name="G",
                      coords={"dr": ("dr", dr, dict(G.dr.attrs))}, attrs=dict(G.attrs))
    return G0, G


@pytest.mark.parametrize("func", list(TAKES_G))
def test_a_zero_lag_bin_with_G_zero_is_accepted(func):
    """``G(0) = 0`` is what G is at dr = 0: accepted, and it changes nothing.

    The result on the lags dr > 0 equals that of the G without the bin (1e-10: the same
    data; the zero lag carries no information).
    """
    G0, G = _zero_lag_G()
    got, ref = TAKES_G[func](G0), TAKES_G[func](G)
    if "dr" in ref.dims:
        got = got.sel(dr=ref.dr)
    xr.testing.assert_allclose(got, ref, rtol=1e-10, atol=0)


def _no_dr_units(G):
    G = G.copy()
    G["dr"].attrs.pop("units")
    return G


def _no_units(G):
    G = G.copy()
    G.attrs.pop("units")
    return G


BROKEN = {
    # (how to break G, what the message must mention)
    "no-units-on-dr": (_no_dr_units, r"'dr'.*units|units.*'dr'"),
    "no-units-on-G": (_no_units, r"units"),
    "wrong-dims": (lambda G: G.rename(dr="x"), r"'dr'"),
    "all-NaN": (lambda G: G * np.nan, r"NaN"),
}


@pytest.mark.parametrize("case", list(BROKEN))
@pytest.mark.parametrize("func", list(TAKES_G))
def test_a_broken_G_is_a_value_error_naming_the_problem(func, case):
    """No units on dr or on G, no 'dr' dim, all NaN: a ValueError that says so."""
    breaker, pattern = BROKEN[case]
    G = breaker(model_G(scatter=0))
    assert re.search(pattern, _error(TAKES_G[func], G)), pattern
