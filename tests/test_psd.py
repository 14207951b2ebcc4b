"""Tests of xrough.power_spectrum (``topo.rough.psd()``): the PSD of the heights (eq. 4).

Tolerances, and why:

* ``EXACT = 1e-10`` (relative): identities of the discrete transform (Parseval, one sine's
  power, SurfaceTopography's numbers, a model spectrum sampled exactly). Both sides are
  sums of at most ~1e5 float64 terms; their round-off is ~1e-13, so 1e-10 leaves a margin
  of a thousand and still fails for any wrong factor, mode or bin.
* ``UNITS = 1e-12`` (relative): the same surface in nm, um and m differs by unit factors
  (powers of ten) only.
* statistical checks say their tolerance where they make it (several standard errors of
  the quantity checked, measured over seeded realisations).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import xarray as xr
from dask_counting import computes_nothing

import xrough
from conftest import DATA, data_path, needs_bridge
from xrough._kernels.psd import error_factors, mode_bins

EXACT = 1e-10
UNITS = 1e-12


def _noise(shape, *, seed=0, spacing=1.0, unit="nm", periodic=True):
    h = np.random.default_rng(seed).normal(size=shape)
    return xrough.topography(h, spacing=spacing, unit=unit, periodic=periodic)


def _variance(C: xr.DataArray) -> xr.DataArray:
    """The discrete Parseval sum of the docstring: sum over q of C * bin_measure."""
    return (C * C.bin_measure).sum("q")


def _wave(shape, k, *, amplitude=1.5, spacing=(1.0, 1.0), periodic=True):
    """``amplitude sin(q.r)`` with ``q = 2 pi (ky / Ly, kx / Lx)`` on a map."""
    (ny, nx), (dy, dx) = shape, spacing
    y, x = np.meshgrid(np.arange(ny) * dy, np.arange(nx) * dx, indexing="ij")
    phase = 2 * np.pi * (k[0] * y / (ny * dy) + k[1] * x / (nx * dx)) + 0.3
    return xrough.topography(amplitude * np.sin(phase), spacing=spacing, unit="um",
                             periodic=periodic)


# ---------------------------------------------------------------------------------------
# Parseval
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("shape", [(64, 96), (63, 80), (48, 33), (5, 7)])
def test_parseval_periodic_map(shape):
    topo = _noise(shape, spacing=(1.5, 0.7))
    C = topo.rough.psd()
    assert C.attrs["window"] == "none"
    var = float(np.var(topo.values))
    assert float(_variance(C)) == pytest.approx(var, rel=EXACT)
    # every mode but q = 0 is in a bin: the modes of the bins add up to the grid
    assert int(C.n_modes.sum()) == topo.size - 1
    # the same with linear bins (each mode in one bin)
    assert float(_variance(topo.rough.psd(bins="linear"))) == pytest.approx(var, rel=EXACT)


@pytest.mark.parametrize("n", [256, 255])
def test_parseval_profile(n):
    topo = _noise((n,), spacing="3 nm")
    C = topo.rough.psd()
    assert C.attrs["units"] == "nm3" and C.attrs["spectrum_kind"] == "1D"
    assert float(_variance(C)) == pytest.approx(float(np.var(topo.values)), rel=EXACT)
    assert int(C.n_modes.sum()) == n - 1


@pytest.mark.parametrize("direction", ["x", "y"])
def test_parseval_lines(direction):
    topo = _noise((40, 56), spacing=(2.0, 1.0))
    C = topo.rough.psd(direction=direction)
    lines = topo.values if direction == "x" else topo.values.T
    # the pooled variance of the lines about their own means
    assert float(_variance(C)) == pytest.approx(float(np.var(lines, axis=1).mean()),
                                                rel=EXACT)
    assert C.attrs["units"] == "nm3" and "standard_error" not in C.coords


def test_parseval_with_window_and_missing_points():
    """Windows and masks keep the exact identity, for the w^2 m-weighted variance."""
    from scipy.signal import get_window

    topo = _noise((48, 64), periodic=False)
    h = topo.values.copy()
    h[np.random.default_rng(5).random(h.shape) < 0.04] = np.nan
    C = topo.copy(data=h).rough.psd(window="blackman")
    w = np.outer(get_window("blackman", 48), get_window("blackman", 64))
    m = np.isfinite(h)
    mu = np.sum(np.where(m, h, 0) * w * m) / np.sum(w * m)
    weighted = np.sum(np.where(m, (h - mu) ** 2, 0) * w**2 * m) / np.sum(w**2 * m)
    assert float(_variance(C)) == pytest.approx(weighted, rel=EXACT)
    # periodic map, no window: the variance of the valid points exactly
    P = topo.assign_attrs(periodic=1).copy(data=h).rough.psd()
    assert float(_variance(P)) == pytest.approx(float(np.nanvar(h)), rel=EXACT)


# ---------------------------------------------------------------------------------------
# one sine
# ---------------------------------------------------------------------------------------
def test_sine_gives_one_peak_at_its_wavevector():
    k, amplitude = (4, 3), 1.5
    topo = _wave((64, 64), k, amplitude=amplitude, spacing=(0.5, 0.5))
    C = topo.rough.psd(bins="linear")
    power = (C * C.bin_measure).values
    peak = int(np.argmax(power))
    q0 = 2 * np.pi * np.hypot(*k) / 32.0
    # the peak bin holds |q| = q0 and the whole variance amplitude^2 / 2 ...
    width = C.attrs["bin_width"]
    assert abs(float(C.q[peak]) - q0) < width / 2
    assert power[peak] == pytest.approx(amplitude**2 / 2, rel=EXACT)
    # ... and every other bin nothing but round-off (1e-12 of the peak)
    assert np.all(np.delete(power, peak) < 1e-12 * power[peak])
    # along x and along y: the lines see the components kx and ky exactly
    for direction, kk in (("x", k[1]), ("y", k[0])):
        Cd = topo.rough.psd(direction=direction, bins="linear")
        pd = (Cd * Cd.bin_measure).values
        assert float(Cd.q[np.argmax(pd)]) == pytest.approx(2 * np.pi * kk / 32.0, rel=EXACT)
        assert pd.max() == pytest.approx(amplitude**2 / 2, rel=EXACT)


def test_sine_on_an_open_map_stays_in_the_windows_main_lobe():
    """Hann: a sine not periodic on the map leaks; 99.9 % stays within 3 modes of it."""
    topo = _wave((64, 64), (0, 10.4), spacing=(1.0, 1.0), periodic=False)
    C = topo.rough.psd(direction="x", bins="linear")
    assert C.attrs["window"] == "hann"
    power = (C * C.bin_measure).values
    q = C.q.values / (2 * np.pi / 64)  # in modes
    assert abs(q[np.argmax(power)] - 10.4) <= 0.5
    near = np.abs(q - 10.4) <= 3
    assert power[near].sum() > 0.999 * power.sum()
    # without a window the edges leak: far less within 3 modes
    bare = topo.rough.psd(direction="x", bins="linear", window=None)
    bare_power = (bare * bare.bin_measure).values
    assert bare_power[near].sum() < 0.99 * bare_power.sum()


# ---------------------------------------------------------------------------------------
# SurfaceTopography: the same definition, the same numbers
# ---------------------------------------------------------------------------------------
def test_agrees_with_surface_topography_map():
    """Map, periodic, no window: ST's C = |dA sum h e^{-iqr}|^2 / A on q = 2 pi k / L (rad
    per length, as here); its radial bins average over the modes of the full FFT grid
    and report their mean |q|. With the same bin edges the numbers are the same."""
    st = pytest.importorskip("SurfaceTopography")
    topo = _noise((48, 64), spacing=(0.5, 0.75), seed=2)
    h = topo.values
    # edges away from every |q| of the lattice, inside ST's range (up to pi / 0.75 nm)
    edges = np.geomspace(0.1, 4.0, 13) * (1 + 1e-7)
    ref = st.Topography(h.T, physical_sizes=(64 * 0.75, 48 * 0.5), periodic=True)
    q_st, C_st = ref.power_spectrum_from_area(collocation=edges, reliable=False)
    C = topo.rough.psd(bins=edges)
    keep = ~np.ma.getmaskarray(C_st)
    np.testing.assert_allclose(C.values, np.ma.getdata(C_st)[keep], rtol=EXACT)
    np.testing.assert_allclose(C.q.values, np.ma.getdata(q_st)[keep], rtol=EXACT)


def test_agrees_with_surface_topography_profiles():
    """Profiles: ST's 1D PSD per mode (C(+q) and C(-q) averaged) equals ours in linear
    bins one mode wide; open profiles with ST's Hann window (periodic form, normalised to
    a mean square of 1) agree once ST is given the heights minus our window-weighted
    mean (ST windows the heights as they are); lines of a map agree with ST's average
    over the profiles along x."""
    st = pytest.importorskip("SurfaceTopography")
    from scipy.signal import get_window

    h = np.random.default_rng(4).normal(size=(32, 64))
    dx = 0.75
    line = xrough.topography(h[0], spacing=dx, unit="nm", periodic=True)
    q_st, C_st = st.UniformLineScan(h[0], 64 * dx, periodic=True).power_spectrum_from_profile(
        resampling_method=None, reliable=False)
    C = line.rough.psd(bins="linear")
    np.testing.assert_allclose(C.values[:31], C_st[1:], rtol=EXACT)  # ST stops below Nyquist
    np.testing.assert_allclose(C.q.values[:31], q_st[1:], rtol=EXACT)

    tilted = h[0] + 3.0 + 0.05 * np.arange(64)
    w = get_window("hann", 64)
    mu = np.sum(w * tilted) / np.sum(w)
    _, C_st = st.UniformLineScan(tilted - mu, 64 * dx, periodic=False).power_spectrum_from_profile(
        resampling_method=None, reliable=False, window="hann")
    C = xrough.topography(tilted, spacing=dx, unit="nm").rough.psd(bins="linear")
    assert C.attrs["window"] == "hann"
    np.testing.assert_allclose(C.values[:31], C_st[1:], rtol=EXACT)

    topo = xrough.topography(h, spacing=dx, unit="nm", periodic=True)
    ref = st.Topography(h.T, physical_sizes=(64 * dx, 32 * dx), periodic=True)
    _, C_st = ref.power_spectrum_from_profile(resampling_method=None, reliable=False)
    C = topo.rough.psd(direction="x", bins="linear")
    np.testing.assert_allclose(C.values[:31], C_st[1:], rtol=EXACT)


# ---------------------------------------------------------------------------------------
# the model spectrum and spectrum(G)
# ---------------------------------------------------------------------------------------
MODEL = dict(hurst=0.8, lambda_r=64, lambda_s=4, rms_height=1.0, unit="nm", rolloff="smooth")


def test_fixed_amplitudes_give_the_model_spectrum_exactly():
    """A surface with |h~(q)|^2 = C(q) / A on every mode: each bin is the average of
    model_spectrum over its modes (computed here from the lattice, independently)."""
    topo = xrough.self_affine_surface(size=512, n=256, seed=3, random_amplitudes=False,
                                      **MODEL)
    C = topo.rough.psd()
    dq = 2 * np.pi / 512
    ky, kx = np.meshgrid(np.fft.fftfreq(256, 1 / 256), np.fft.fftfreq(256, 1 / 256),
                         indexing="ij")
    q = dq * np.hypot(ky, kx).ravel()
    model = xrough.model_spectrum(np.where(q > 0, q, 1.0), lambda_0=512, **MODEL).values
    edges = 10 ** ((np.arange(-60, 21) - 0.5) / 20)
    which = np.digitize(q, edges) - 1
    inside = (q > 0) & (which >= 0) & (which < edges.size - 1)
    counts = np.bincount(which[inside], minlength=edges.size - 1)
    sums = np.bincount(which[inside], weights=model[inside], minlength=edges.size - 1)
    expected = sums[counts > 0] / counts[counts > 0]
    # above q_s the model is 0 and the transform leaves round-off: 1e-12 of the largest C
    np.testing.assert_allclose(C.values, expected, rtol=EXACT, atol=1e-12 * expected.max())
    np.testing.assert_array_equal(C.n_modes.values, counts[counts > 0])
    # and the model at the bins' q: within the bias of bin averaging that the docstring
    # states (below 1 % at 20 bins per decade; 1.2 % allows for the corners of the grid)
    at_q = xrough.model_spectrum(C.q.values, lambda_0=512, **MODEL)
    below = (C.q < topo.attrs["q_s"]).values
    np.testing.assert_allclose(C.values[below], at_q.values[below], rtol=0.012)


def test_comparable_with_spectrum_of_G():
    """spectrum(G) (eq. 10/11) and the PSD of the same periodic map agree where G
    determines C: to 1.5 % (the PSD's bias of bin averaging, below 1 % at 20 bins per
    decade, and spectrum's ~0.3 % from its interpolation of G), in the same units, on one
    plot."""
    topo = xrough.self_affine_surface(size=512, n=512, seed=3, random_amplitudes=False,
                                      **MODEL)
    C = topo.rough.psd()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", xrough.QualityWarning)
        CG = topo.rough.acf(points_per_decade=20).rough.spectrum(q=C.q)
    assert (CG.attrs["units"], CG.q.attrs["units"]) == (C.attrs["units"], C.q.attrs["units"])
    assert CG.attrs["long_name"] == C.attrs["long_name"]
    supported = (CG.supported == 1).values
    assert supported.sum() >= 8
    np.testing.assert_allclose(CG.values[supported], C.values[supported], rtol=0.015)
    # the recipe of docs/psd.md: one axes, both curves, labelled
    ax = C.rough.plot(label="PSD of the heights")
    CG.where(CG.supported == 1).rough.plot(ax=ax, label="C from G")
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["PSD of the heights",
                                                                    "C from G"]
    # a radial PSD is a spectrum every function of a spectrum takes
    G = xrough.acf_from_spectrum(C, [2.0, 20.0])
    assert G.attrs["units"] == "nm2"


# ---------------------------------------------------------------------------------------
# units
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("direction", ["radial", "x"])
def test_same_physics_in_nm_um_and_m(direction):
    nm = _noise((32, 40), spacing="2 nm", periodic=False, seed=7)
    C_nm = nm.rough.psd(direction=direction)
    power = 4 if direction == "radial" else 3
    for unit, factor in (("um", 1e-3), ("m", 1e-9)):
        other = xrough.convert_units(nm, unit, lateral=unit)
        C = other.rough.psd(direction=direction)
        assert C.attrs["units"] == f"{unit}{power}" and C.q.attrs["units"] == f"{unit}-1"
        np.testing.assert_allclose(C.q.values * factor, C_nm.q.values, rtol=UNITS)
        np.testing.assert_allclose(C.values / factor**power, C_nm.values, rtol=UNITS)
        np.testing.assert_array_equal(C.n_modes.values, C_nm.n_modes.values)
    # heights in nm on a grid in um: C in um^4, the heights converted (as spectrum(G))
    mixed = xrough.convert_units(nm, lateral="um")
    C = mixed.rough.psd(direction=direction)
    assert C.attrs["units"] == f"um{power}"
    np.testing.assert_allclose(C.values / 1e-3**power, C_nm.values, rtol=UNITS)


# ---------------------------------------------------------------------------------------
# statistical error
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("periodic", [True, False])
def test_standard_error_is_the_scatter_between_realisations(periodic):
    """Over 200 Gaussian maps the scatter of C per bin is the mean standard_error. The
    ratio of the two has a relative error of ~1/sqrt(2 * 200) = 5 %; bins with at least
    8 modes must lie within 0.75..1.33 (over 5 of those errors). The bins run up to
    q_s / 1.3, below the bin that the cutoff q_s = pi cuts in two (there C is not nearly
    constant across the bin, as the error assumes: its scatter is up to sqrt(2) larger)."""
    C_all, se_all = [], []
    for seed in range(200):
        topo = xrough.self_affine_surface(size=128, n=128, seed=seed,
                                          **{**MODEL, "lambda_s": 2})
        if not periodic:  # a quarter of the periodic surface: open (Hann window)
            topo = topo.isel(x=slice(0, 64), y=slice(0, 64)).assign_attrs(periodic=0)
        C = topo.rough.psd(points_per_decade=10)
        C_all.append(C.values)
        se_all.append(C.standard_error.values)
    ratio = np.std(C_all, axis=0, ddof=1) / np.mean(se_all, axis=0)
    use = (C.n_modes >= 8).values & (C.q < np.pi / 1.3).values
    assert use.sum() >= 8
    assert np.all((ratio[use] > 0.75) & (ratio[use] < 1.33)), ratio[use]


def test_error_factors():
    """No window: 1 in every bin; Hann: between 1 and the sum of rho^2 over all lags
    (1.944 per axis: w^2 of Hann has the DFT 3/8, 1/4, 1/16 at lags 0, 1, 2)."""
    shape, spacing = (256, 256), (1.0, 1.0)
    edges = tuple(10 ** ((np.arange(-30, 6) - 0.5) / 10))
    n = mode_bins(shape, spacing, edges)[1]
    np.testing.assert_array_equal(error_factors(shape, spacing, edges, None), np.ones(n.size))
    f = error_factors(shape, spacing, edges, "hann")
    one_axis = 1 + 2 * ((1 / 4) / (3 / 8)) ** 2 + 2 * ((1 / 16) / (3 / 8)) ** 2
    assert one_axis == pytest.approx(1.9444444444444444, rel=1e-15)
    # (1e-12: the round-off of the sums of rho^2 over up to 25 lags)
    assert np.all(f >= 1) and np.all(f <= one_axis**2 * (1 + 1e-12))
    # wide bins (thousands of modes, ~40 modes across): nearly the full sum, the more so
    # the wider (the modes at a bin's edges miss the neighbours outside it)
    assert f[n > 5000].min() > 0.95 * one_axis**2
    assert np.all(np.diff(f[n > 100]) > 0)


# ---------------------------------------------------------------------------------------
# dask
# ---------------------------------------------------------------------------------------
def test_numpy_equals_dask_and_stays_lazy():
    maps = xr.concat([_noise((32, 48), seed=s, periodic=False) for s in range(3)], "scan")
    maps = maps.assign_coords(scan=[10, 20, 30]).assign_attrs(maps.attrs)
    h = maps.values.copy()
    h[1, :20, :20] = np.nan  # one map with a hole of 26 %: flagged
    maps = maps.copy(data=h)
    with pytest.warns(xrough.QualityWarning, match="valid_fraction"):
        C = maps.rough.psd()
    assert C.chunks is None and C.dims == ("scan", "q")
    with computes_nothing():
        lazy = maps.chunk({"scan": 1}).rough.psd()
    assert lazy.chunks is not None
    computed = lazy.compute()
    # the same kernel on the same numbers, one map per task: at most round-off apart
    xr.testing.assert_allclose(computed, C, rtol=1e-12, atol=0)
    assert computed.attrs == C.attrs
    assert computed.quality_flag.values.tolist() == C.quality_flag.values.tolist() == [0, 1, 0]
    np.testing.assert_allclose(computed.standard_error, C.standard_error, rtol=1e-12)


def test_chunked_map_is_refused():
    topo = _noise((32, 32)).chunk({"x": 16})
    with pytest.raises(ValueError, match=r"chunk\(\{'y': -1, 'x': -1\}\)"):
        topo.rough.psd()


# ---------------------------------------------------------------------------------------
# missing points
# ---------------------------------------------------------------------------------------
def test_missing_points_as_documented():
    """Scattered missing points (fraction f = 0.2) on a periodic self-affine map: C drops
    by about f where it is large, and a floor of about f sigma^2 dA appears where the
    surface has nothing (above q_s). Tolerances: 5 % of C at the lowest bins (their
    scatter between masks is ~1 %); the floor within a factor 1.5 (it is f / (1 - f)
    sigma^2 dA spread over the modes only on average)."""
    topo = xrough.self_affine_surface(size=256, n=256, seed=1, **{**MODEL, "lambda_s": 8})
    full = topo.rough.psd()
    h = topo.values.copy()
    f = 0.2
    h[np.random.default_rng(2).random(h.shape) < f] = np.nan
    with pytest.warns(xrough.QualityWarning, match="fewer than 90%"):
        C = topo.copy(data=h).rough.psd()
    assert C.attrs["quality"] == "questionable"
    assert float(C.valid_fraction) == pytest.approx(1 - f, abs=0.01)
    low = (C.q < 0.1).values & (C.n_modes >= 20).values
    np.testing.assert_allclose((C / full).values[low], 1 - f, rtol=0.05)
    above = (C.q > 1.2 * topo.attrs["q_s"]).values
    floor = f / (1 - f) * np.nanvar(h) * 1.0
    assert np.all((C.values[above] > floor / 1.5) & (C.values[above] < floor * 1.5))


def test_a_compact_hole_leaves_C_nearly_unchanged():
    """A missing square of 6 % of the area: C within 3 standard errors of the full map's
    C in every bin below q_s with at least 8 modes (Gaussian scatter: 3 SE)."""
    topo = xrough.self_affine_surface(size=256, n=256, seed=1, **{**MODEL, "lambda_s": 8})
    full = topo.rough.psd()
    h = topo.values.copy()
    h[100:162, 40:102] = np.nan
    C = topo.copy(data=h).rough.psd()
    assert C.attrs["quality"] == "good"
    use = (C.n_modes >= 8).values & (C.q < topo.attrs["q_s"]).values
    assert np.all(np.abs(C - full).values[use] < 3 * C.standard_error.values[use])


def test_all_missing_or_almost_is_refused():
    h = np.full((16, 16), np.nan)
    with pytest.raises(ValueError, match="fewer than 2 valid"):
        xrough.topography(h, spacing=1.0, unit="nm")
    one = _noise((16, 16))  # a stack whose second map is empty
    topo = xr.concat([one, one.copy(data=h)], "scan").assign_attrs(one.attrs)
    with pytest.raises(ValueError, match="fewer than 2 valid"):
        topo.rough.psd()
    lazy = topo.chunk({"scan": 1}).rough.psd()  # dask: at compute time
    with pytest.raises(ValueError, match="fewer than 2 valid"):  # (the map of its chunk)
        lazy.compute()
    rows = _noise((16, 16)).values
    rows[:, 1:] = np.nan  # one valid point per line along x
    with pytest.raises(ValueError, match="no weight on 2 or more valid"):
        _noise((16, 16)).copy(data=rows).rough.psd(direction="x")


# ---------------------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------------------
def test_bad_input_is_refused():
    topo = _noise((16, 16))
    with pytest.raises(ValueError, match=r"dims \('y', 'x'\)"):
        topo.rename({"y": "a", "x": "b"}).rough.psd()
    with pytest.raises(ValueError, match="not uniformly spaced"):
        topo.assign_coords(x=("x", np.r_[0.0, np.cumsum(np.linspace(1, 2, 15))],
                               {"units": "nm"})).rough.psd()
    bare = topo.copy()
    bare.attrs.pop("units")
    with pytest.raises(ValueError, match="units"):
        bare.rough.psd()
    with pytest.raises(ValueError, match="units"):
        topo.assign_coords(x=("x", topo.x.values)).rough.psd()
    with pytest.raises(ValueError, match="infinite"):
        topo.copy(data=np.where(topo.values > 2, np.inf, topo.values)).rough.psd()
    with pytest.raises(ValueError, match="direction must be"):
        topo.rough.psd(direction="z")
    with pytest.raises(ValueError, match="no direction 'y'"):
        _noise((16,)).rough.psd(direction="y")
    with pytest.raises(ValueError, match="window must be"):
        topo.rough.psd(window="gauss")
    with pytest.raises(ValueError, match="points_per_decade"):
        topo.rough.psd(points_per_decade=0)
    with pytest.raises(ValueError, match="bin_width applies"):
        topo.rough.psd(bin_width=0.1)
    with pytest.raises(ValueError, match="bins must hold"):
        topo.rough.psd(bins=[1.0, 0.5, 2.0])
    with pytest.raises(ValueError, match="no Fourier mode"):
        topo.rough.psd(bins=[100.0, 200.0])
    with pytest.raises(ValueError, match="bins must be"):
        topo.rough.psd(bins="quadratic")
    with pytest.raises(ValueError, match="bin_width: '2 nm' is not in nm-1"):
        topo.rough.psd(bins="linear", bin_width="2 nm")
    with pytest.raises(TypeError, match="DataArray"):
        xrough.power_spectrum(topo.values)


def test_explicit_bins_and_widths_with_units():
    topo = _noise((32, 32), spacing="2 nm")
    C = topo.rough.psd(bins="linear", bin_width="0.2 nm-1")
    assert C.attrs["bin_width"] == pytest.approx(0.2, rel=1e-15)  # edges differ by round-off
    again = topo.rough.psd(bins=xrough.units.ureg.Quantity([0.1, 0.5, 1.0], "1/nm"))
    assert again.sizes["q"] == 2 and again.attrs["bins"] == "explicit"
    # explicit bins hold only their modes: their Parseval sum is that part of the variance
    assert float(_variance(again)) < float(np.var(topo.values))


# ---------------------------------------------------------------------------------------
# labels, provenance, archive
# ---------------------------------------------------------------------------------------
def test_labels_and_provenance():
    topo = _noise((16, 24), periodic=False).assign_attrs(
        source_file="scan.x3p", source_sha256="abc", detrend="plane")
    C = xrough.power_spectrum(topo)
    assert C.name == "C" and C.dims == ("q",)
    assert C.attrs["units"] == "nm4" and C.q.attrs["units"] == "nm-1"
    assert C.attrs["long_name"] == "isotropic height spectrum"
    assert C.attrs["equation"].startswith("eq. 4")
    assert C.attrs["window"] == "hann" and C.attrs["periodic"] == 0
    assert C.attrs["source_file"] == "scan.x3p" and C.attrs["detrend"] == "plane"
    assert "xrough_version" in C.attrs
    assert C.n_modes.dtype == np.int64 and C.n_modes.attrs["units"] == "1"
    assert C.bin_measure.attrs["units"] == "nm-2"
    assert C.standard_error.attrs["units"] == "nm4"
    for value in C.attrs.values():  # netCDF-legal
        assert isinstance(value, (str, int, float)) and not isinstance(value, bool)
    xr.testing.assert_identical(topo.rough.psd(), C)  # the accessor is the function
    with xr.set_options(keep_attrs=True):  # the units are computed, never kept
        assert (topo * 1.0).rough.psd().attrs["units"] == "nm4"


def test_archive_round_trip_is_identical(tmp_path):
    maps = xr.concat([_noise((24, 32), seed=s) for s in range(2)], "scan")
    maps = maps.assign_attrs(_noise((24, 32)).attrs)
    results = {"radial": maps.rough.psd(), "x": maps.rough.psd(direction="x"),
               "profile": _noise((64,)).rough.psd(bins="linear"),
               "one": _noise((24, 32)).rough.psd()}
    path = xrough.save_analysis(tmp_path / "psd.nc", results)
    back = xrough.open_analysis(path)
    for name, C in results.items():
        xr.testing.assert_identical(back[name], C)


# ---------------------------------------------------------------------------------------
# every real measurement
# ---------------------------------------------------------------------------------------
def _real_cases():
    from test_real_data import CASES

    return [pytest.param(cid, case, id=cid, marks=[needs_bridge] if case.bridge else [])
            for cid, case in CASES.items() if case.parts != ("uncd",)]  # files, one each


@pytest.mark.data
@pytest.mark.parametrize(("cid", "case"), _real_cases())
def test_every_real_file_gives_a_finite_positive_psd(cid, case):
    """Each file, opened and detrended as the chain of test_real_data does; nc-1 is a pure
    plane (nothing is left after removing it), so only its mean is removed."""
    if not DATA.exists():
        pytest.skip("measurement data not available")
    topo = xrough.open_topography(data_path(*case.parts), **case.open)
    topo = topo.rough.detrend(mode="mean" if cid == "nc-1" else case.detrend)
    C = topo.rough.psd()
    assert C.sizes["q"] >= 1 and C.attrs["units"].endswith("4" if "y" in topo.dims else "3")
    assert np.all(np.isfinite(C.values)) and np.all(np.isfinite(C.standard_error.values))
    # a plane varies along one axis only: bins of the other axis' modes may be 0
    assert np.all(C.values > 0) if cid != "nc-1" else np.all(C.values >= 0)
    assert float(_variance(C)) > 0


def test_power_spectrum_2d_and_its_moments():
    """The 2D periodogram: its modes in a ring average to the radial PSD's bin (to 1e-12),
    Parseval (sum C / A = variance) on a periodic map, moments with a kernel in (qx, qy)
    of an anisotropic map (a wave along x: no power in qy), the same in um (C in um4 is
    1e-12 of nm4), numpy = dask, a profile refused."""
    rng = np.random.default_rng(3)
    h = rng.normal(size=(32, 48))
    topo = xrough.topography(h, spacing="2 nm", unit="nm", periodic=True)
    C2 = topo.rough.psd_2d()
    assert C2.dims == ("qy", "qx") and C2.attrs["units"] == "nm4"
    radial = topo.rough.psd(bins="linear")
    q = np.hypot(*np.meshgrid(C2.qy.values, C2.qx.values, indexing="ij"))
    first = np.isclose(q, float(radial.q[0]), rtol=1e-12)
    assert int(first.sum()) == int(radial.n_modes[0])
    assert float(C2.values[first].mean()) == pytest.approx(float(radial[0]), rel=1e-12)
    assert float(xrough.spectral_moment(C2, order=0)) == pytest.approx(h.var(), rel=1e-12)
    x = np.arange(48) * 2.0
    wave = xrough.topography(np.sin(2 * np.pi * x / 24)[None, :] * np.ones((32, 1)),
                             spacing="2 nm", unit="nm", periodic=True)
    W = wave.rough.psd_2d()
    assert float(xrough.spectral_moment(W, lambda qx, qy: qy**2)) == pytest.approx(0,
                                                                                  abs=1e-20)
    assert float(xrough.spectral_moment(W, order=2)) == pytest.approx(
        0.5 * (2 * np.pi / 24) ** 2, rel=1e-12)
    um = xrough.convert_units(topo, "um", lateral="um").rough.psd_2d()
    np.testing.assert_allclose(um.values, C2.values * 1e-12, rtol=1e-9,
                               atol=1e-9 * float(um.max()))  # q = 0: round-off of the mean
    stack = xr.concat([topo, 2 * topo], dim="scan")
    lazy = stack.chunk({"scan": 1}).rough.psd_2d()
    assert lazy.chunks is not None
    xr.testing.assert_allclose(lazy.compute(), stack.rough.psd_2d())
    with pytest.raises(ValueError, match="map"):
        topo.isel(y=0).rough.psd_2d()
    with pytest.raises(ValueError, match="one of them"):
        xrough.spectral_moment(C2)
