"""Channels chosen by what they hold, and lateral sizes checked like heights.

Files from the wild: a Nanosurf contact-mode scan whose first channel in metres is the
deflection; a header whose lateral unit is wrong by 10^6 (a 160 m AFM scan).
"""

import warnings
from pathlib import Path

import numpy as np
import pytest

import xrough
from conftest import data_path, needs_bridge
from xrough.io import gwy, x3p
from xrough.io._common import (
    ChannelChoiceWarning,
    channel_rank,
    check_lateral_size,
    choose_height_channel,
)


@pytest.mark.parametrize("name, rank", [
    ("Height", 0), ("HeightRetrace", 0), ("Topography", 0), ("ZSensor", 0),
    ("Scan forward (Z-Axis)", 0), ("Scan forward (Z-AxisSensor)", 0),
    ("Scan forward (Deflection)", 2), ("AmplitudeTrace", 2), ("Amplitude Error", 2),
    ("Friction", 2), ("Phase", 2), ("Current", 2), ("layer0", 1), ("Default", 1),
    ("Raw", 1)])
def test_a_channel_name_says_what_it_holds(name, rank):
    assert channel_rank(name) == rank


def _gwy_channels(gwyfile, titles):
    """A .gwy of channels all in metres, in this order; channel k holds k + 1 nm."""
    objects = gwyfile.objects
    c = objects.GwyContainer()
    for k, title in enumerate(titles):
        c[f"/{k}/data"] = objects.GwyDataField(np.full((4, 5), (k + 1) * 1e-9), xreal=1e-6,
                                               yreal=1e-6, si_unit_xy="m", si_unit_z="m")
        c[f"/{k}/data/title"] = title
    return c


def test_deflection_first_in_metres_is_not_the_default_height(tmp_path):
    """The first channel in a length unit is the deflection: the height is read (by its
    name, a certain choice); with a second height quantity a warning names the one read,
    the others and channel=."""
    gwyfile = pytest.importorskip("gwyfile")
    path = tmp_path / "contact.gwy"
    _gwy_channels(gwyfile, ["Deflection", "Topography", "Friction"]).tofile(str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        topo = xrough.open_topography(path)
    assert topo.attrs["channel"] == "Topography"
    two = tmp_path / "two.gwy"
    _gwy_channels(gwyfile, ["Deflection", "Topography", "ZSensor"]).tofile(str(two))
    with pytest.warns(ChannelChoiceWarning,
                      match=r"two\.gwy: several quantities in a length unit "
                            r"\('Deflection', 'Topography', 'ZSensor'\); reading channel 1: "
                            r"'Topography'\. Pass channel="):
        assert xrough.open_topography(two).attrs["channel"] == "Topography"
    np.testing.assert_array_equal(topo.values, 2e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # chosen: nothing to say
        assert xrough.open_topography(path, channel="Deflection").values[0, 0] == 1e-9
    listed = {c["name"]: c["default"] for c in xrough.io.list_channels(path)}
    assert listed == {"Deflection": False, "Topography": True, "Friction": False}


def test_trace_and_retrace_of_one_height_read_the_trace_quietly(tmp_path):
    gwyfile = pytest.importorskip("gwyfile")
    path = tmp_path / "tr.gwy"
    _gwy_channels(gwyfile, ["HeightTrace", "HeightRetrace"]).tofile(str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        topo = gwy.read(path)
    assert topo.attrs["channel"] == "HeightTrace"


def test_a_name_that_says_nothing_comes_before_a_signal_and_is_said():
    chans = [{"name": "AmplitudeTrace", "index": 0}, {"name": "layer0", "index": 1}]
    with pytest.warns(ChannelChoiceWarning, match="reading channel 1: 'layer0'"):
        assert choose_height_channel(Path("f.x"), chans, warn=True)["index"] == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert choose_height_channel(Path("f.x"), chans[1:], warn=True)["index"] == 1


def test_a_height_beside_its_amplitude_in_metres_is_read_quietly():
    """Asylum's tapping-mode waves: HeightTrace, HeightRetrace, AmplitudeTrace (m)."""
    path = data_path("instruments", "spot_1-1000nm.ibw")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        topo = xrough.open_topography(path)
    assert topo.attrs["channel"] == "HeightTrace"


@needs_bridge
def test_bridged_files_choose_by_the_same_rule():
    """nid-1: the feedback height and the calibrated sensor, forward and backward: the
    first Z-Axis is read (SurfaceTopography's default too), and the choice is said."""
    path = data_path("instruments", "nid-1.nid")
    with pytest.warns(ChannelChoiceWarning, match=r"nid-1\.nid: several quantities .*"
                      r"'Scan forward \(Z-Axis\)', 'Scan forward \(Z-AxisSensor\)'"):
        topo = xrough.open_topography(path)
    assert topo.attrs["channel"] == "Scan forward (Z-Axis)"


def _map(spacing, unit="m"):
    h = np.random.default_rng(0).normal(size=(8, 8)) * 1e-9
    return xrough.topography(h, spacing=spacing, unit=unit, height_unit="m")


def test_a_lateral_unit_wrong_by_a_million_is_refused_with_the_headers_numbers(tmp_path):
    """A pixel of 312.5 stated in m where it is nm: an 8-point map 2500 m across."""
    path = tmp_path / "wrong.x3p"
    x3p.write(_map(312.5), path)
    with pytest.raises(ValueError, match=r"wrong\.x3p: the file states 8 points, 312\.5 m "
                                         r"apart: 2500 m along y, wider than an instrument "
                                         r"scans \(1 m\).*pass size="):
        xrough.open_topography(path)
    topo = xrough.open_topography(path, size=("2.5 um", "2.5 um"))  # the user states it
    assert float(topo.x[1] - topo.x[0]) == pytest.approx(312.5e-9)


@pytest.mark.parametrize("reader, spacing, refused", [
    ("EZDReader", 20e-6, False),     # a 160 um AFM scan
    ("EZDReader", 312.5, True),      # a 2500 m AFM scan
    ("nanoscope", 2e-3, True),       # 16 mm: no scanning probe
    ("PLUReader", 2e-3, False),      # 16 mm: a profilometer
    ("NMSReader", 312.5, True),      # a confocal scan of 2500 m (a pixel read in m, not nm)
    ("x3p", 1e-16, True),            # a pixel of 0.1 fm
    ("HGTReader", 30.0, False),      # an elevation tile
    ("netcdf", 312.5, False),        # data, not an instrument
])
def test_lateral_bounds_follow_the_instrument_class(reader, spacing, refused):
    da = _map(spacing)
    if refused:
        with pytest.raises(ValueError, match=r"a\.f: the file states"):
            check_lateral_size(Path("a.f"), da, reader)
    else:
        check_lateral_size(Path("a.f"), da, reader)


def test_lateral_bounds_read_the_coordinates_unit():
    """312.5 nm pixels are an AFM's; the same numbers in um are not; a coordinate that is
    not a length is left to topography() to refuse."""
    path = Path("a.spm")
    check_lateral_size(path, _map(312.5, unit="nm"), "nanoscope")
    check_lateral_size(path, _map(0.3125e-3, unit="mm"), "nanoscope")
    in_pixels = _map(1.0)
    in_pixels["x"].attrs["units"] = "pixel"
    in_pixels["y"].attrs["units"] = "pixel"
    check_lateral_size(path, in_pixels, "nanoscope")
    with pytest.raises(ValueError, match="wider than a scanning-probe microscope scans"):
        check_lateral_size(path, _map(312.5, unit="um"), "nanoscope")


def test_npy_infinite_points_are_missing_and_counted(tmp_path):
    h = np.arange(12.0).reshape(3, 4)
    h[1, 2], h[0, 0], h[2, 3] = np.inf, -np.inf, np.nan
    path = tmp_path / "h.npy"
    np.save(path, h)
    with pytest.warns(xrough.io.InvalidPointsWarning,
                      match=r"h\.npy: 2 of 12 points stored as \+inf and -inf"):
        topo = xrough.open_topography(path, size=(3.0, 4.0), unit="nm")
    assert topo.attrs["invalid_points"] == 3
    assert topo.attrs["invalid_marker"] == "NaN and +inf and -inf"
    assert int(topo.isnull().sum()) == 3


@needs_bridge
def test_bridged_files_get_the_same_lateral_checks(tmp_path):
    path = tmp_path / "wrong.x3p"
    x3p.write(_map(312.5), path)
    with pytest.raises(ValueError, match=r"wrong\.x3p: the file states 8 points, 312\.5 m "
                                         r"apart: 2500 m along y, wider than an instrument"):
        xrough.open_topography(path, format="surfacetopography")
