"""The stress ACF of measured maps: NaN and said where G does not determine its Laplacian.

At the first pixels of a measured map the radial bins hold a few lattice distances each
(1, sqrt(2), 2, sqrt(5) px ...) along different directions, the scan is not isotropic at
the pixel scale (fast and slow axes differ) and pixel noise adds to G: G zig-zags between
neighbouring bins by far more than its standard error, and the Laplacian of eq. 24 turns
that into sign flips as large as G_sigma(0) (di-1.di: +1.26e14, -1.20e14, +8.7e13,
-4.4e13 Pa^2 at 1-2.8 px). These tests read the files in ../shared/data and skip when they
are absent.
"""

import importlib.util
import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from dask_counting import computes_nothing

import xrough
from conftest import data_path, needs_bridge

pytestmark = pytest.mark.data

_SPEC = importlib.util.spec_from_file_location(
    "bench_stress_determined",
    Path(__file__).resolve().parents[1] / "benchmarks" / "bench_stress_determined.py")
_BENCH = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(_BENCH)

#: Largest value of a bin whose sign differs from both neighbours' (relative to the largest
#: magnitude shown): lattice noise flips the sign from bin to bin; the negative lobe that
#: every full-contact stress ACF has (its integral over the plane is 0) is smooth.
SIGN_FLIP = 0.10

MAPS = [
    ("instruments", "di-1.di"), ("instruments", "x3p-2.x3p"),
    ("instruments", "sdf-1.sdf"), ("instruments", "sur-2.sur"),
    ("instruments", "spot_1-1000nm.ibw"),
    pytest.param(("instruments", "mi-1.mi"), marks=needs_bridge),
    pytest.param(("instruments", "nid-1.nid"), marks=needs_bridge),
    pytest.param(("instruments", "plu-1.plu"), marks=needs_bridge),
    pytest.param(("instruments", "al3d-1.al3d"), marks=needs_bridge),
    pytest.param(("instruments", "opd-1.opd"), marks=needs_bridge),
    ("uncd", "gain_control_uncd_35_z03tr3R.001"),
]


#: The channel of files whose length channels hold two height quantities (stated).
CHANNEL = {"nid-1.nid": "Scan forward (Z-Axis)"}


def _acf(*parts):
    options = {"channel": CHANNEL[parts[-1]]} if parts[-1] in CHANNEL else {}
    topo = xrough.open_topography(data_path(*parts), **options)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        G = topo.rough.detrend().rough.acf()
    return G


def _isolated_sign_flip(values):
    """Largest |value| of a finite bin whose sign differs from its finite neighbours',
    relative to the largest magnitude (the measure the docs' table prints)."""
    return _BENCH.sign_flip(values)[0]


def _run(func):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = func()
    return result, [w for w in caught if issubclass(w.category, xrough.QualityWarning)]


@pytest.mark.parametrize("parts", MAPS, ids=lambda p: p[-1])
def test_stress_acf_of_measured_maps_shows_no_lattice_noise(parts):
    G = _acf(*parts)
    S, caught = _run(lambda: G.rough.stress_acf(E_star="25 MPa"))
    values = S.values
    assert np.isfinite(values).sum() >= 0.5 * np.isfinite(G.values).sum()  # most kept
    nan = _undetermined(S, G)
    # what is shown does not flip sign from bin to bin
    assert _isolated_sign_flip(values) <= SIGN_FLIP
    # NaN <=> marked: questionable, one warning naming the lag range; else good, silent
    if nan.any():
        lo, hi = S.dr.values[nan].min(), S.dr.values[nan].max()
        assert S.attrs["quality"] == "questionable" and len(caught) == 1
        span = f"{lo:.3g}" if lo == hi else f"{lo:.3g} to {hi:.3g}"  # one lag or a run
        assert f"not determined at dr = {span} " in S.attrs["quality_notes"]
        assert str(caught[0].message).endswith(S.attrs["quality_notes"])
        # a lower bound: every lag up to the last undetermined one is NaN
        assert np.all(np.isnan(values[(S.dr.values > 0) & (S.dr.values <= hi)]))
    elif G.attrs.get("quality", "good") == "good":
        assert S.attrs["quality"] == "good" and not caught
    else:  # G's own mark (directions that differ): inherited, said once
        assert S.attrs["quality"] == G.attrs["quality"] and len(caught) == 1
        assert G.attrs["quality_notes"] in S.attrs["quality_notes"]


def _undetermined(S, G) -> np.ndarray:
    """The lags NaN because the bins disagree (marked), not the first lag withheld where
    G is rough there already (NaN by design, said in a remark: tests/test_contact.py)."""
    nan = np.isnan(S.values) & (S.dr.values > 0) & np.isfinite(G.values)
    first = np.flatnonzero(np.isfinite(G.values) & (S.dr.values > 0))[0]
    if nan[first] and "the first lag" in S.attrs.get("quality_remarks", ""):
        assert not nan[first + 1], "the rough first lag is a lag of its own"
        nan[first] = False
    return nan


@pytest.mark.parametrize("parts", MAPS, ids=lambda p: p[-1])
def test_persson_of_measured_maps_warns_where_it_marks(parts):
    G = _acf(*parts)
    S, _ = _run(lambda: G.rough.stress_acf(E_star="25 MPa"))
    P, caught = _run(lambda: G.rough.persson(E_star="25 MPa", p0="0.1 MPa"))
    # every QualityWarning belongs to a marked result and every marked result warns once:
    # persson itself, and the fit and gradient it computes, whose notes it carries on
    own = [w for w in caught if str(w.message).startswith("persson:")]
    assert (P.attrs["quality"] != "good") == (len(own) == 1) and len(own) <= 1
    assert {str(w.message).split(" ")[0].rstrip(":") for w in caught} <= {
        "persson", "fit_acf", "rms_gradient"}
    assert bool(caught) == bool(own)  # an input that warns marks persson too
    # the lags without a full-contact Laplacian are NaN in partial contact too, said so
    undetermined = _undetermined(S, G)
    withheld = np.isnan(S.values) & (S.dr.values > 0) & np.isfinite(G.values)
    assert np.all(np.isnan(P.G_sigma.values[withheld]))
    assert np.all(np.isnan(P.Gamma_sigma.values[withheld]))
    assert ("not determined" in P.attrs["quality_notes"]) == bool(undetermined.any())


def test_a_map_without_height_differences_is_refused():
    """nc-1.nc: G is 0 at its first lags (no height differences at the pixel scale), which
    no rough surface has: refused with the rule it breaks, not differentiated."""
    G = _acf("instruments", "nc-1.nc")
    with pytest.raises(ValueError, match="G is 0 at dr = "):
        G.rough.stress_acf(E_star="25 MPa")


def test_di1_zigzag_is_nan_and_the_rest_unchanged():
    """di-1.di (512^2 AFM, 0.98 nm pixels): the sign flips at 1-2.8 px are NaN; from
    3.3 px on the values are those of the smoothing spline as before (the rule only
    removes lags, it does not change the estimate)."""
    G = _acf("instruments", "di-1.di")
    S, caught = _run(lambda: G.rough.stress_acf(E_star="25 MPa"))
    px = G.attrs["pixel_size"]
    nan = np.isnan(S.values)
    assert np.all(nan[S.dr.values < 3 * px]) and not nan[S.dr.values > 3 * px].any()
    from xrough._kernels.acf_curve import AcfCurve
    curve = AcfCurve(G.dr.values * 1e-9, G.values * 1e-18, G.standard_error.values * 1e-18)
    np.testing.assert_allclose(S.values[~nan], (25e6 / 2) ** 2 * curve.laplacian(
        G.dr.values[~nan] * 1e-9), rtol=1e-10)
    # the largest value kept is of the order of the stress variance at the first kept
    # lag, not of the lattice: 1.6e13 Pa^2 (G_sigma(1 px) was 1.26e14)
    assert 1e13 < np.nanmax(S.values) < 3e13


def test_dask_gives_the_same_marks_lazily():
    G = _acf("instruments", "di-1.di")
    S, _ = _run(lambda: G.rough.stress_acf(E_star="25 MPa"))
    stack = xr.concat([G, G], dim="scan").chunk({"scan": 1})
    with computes_nothing():
        lazy, _ = _run(lambda: stack.rough.stress_acf(E_star="25 MPa"))
        P, _ = _run(lambda: stack.rough.persson(E_star="25 MPa", p0="0.1 MPa",
                                                gradient_method="simple"))
    got = lazy.compute()
    np.testing.assert_allclose(got.values, np.stack([S.values, S.values]), rtol=1e-12,
                               equal_nan=True)
    assert got.quality_flag.values.tolist() == [1, 1]
    assert np.all(np.isnan(P.G_sigma.compute().values[:, np.isnan(S.values)]))
