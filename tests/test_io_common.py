"""What every reader shares (xrough.io._common): micro-sign spellings and channel selection.

Each test builds its files in ``tmp_path`` (the Nanoscope one edits a copy of a measured
file's header there, keeping its length) and reads them with the format's reader, so a
reader that stops going through the shared helpers fails here.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from test_io_afm import make_ibw

import xrough
from conftest import data_path
from xrough.io import bridge, gwy, ibw, nanoscope, netcdf, sur, text
from xrough.io._common import channel_listing, describe_channel, micro_as_u, select_channel
from xrough.topography import grid_of

#: Bytes a file may hold for "µm" (read as Latin-1 by the binary readers): the micro sign,
#: and the UTF-8 bytes of the micro sign and of the Greek mu.
MICRO_BYTES = {"micro sign": b"\xb5m", "UTF-8 micro sign": b"\xc2\xb5m",
               "UTF-8 Greek mu": b"\xce\xbcm", "plain u": b"um"}
#: Text a file may hold for "µm" once decoded.
MICRO_TEXT = {"micro sign": "\u00b5m", "Greek mu": "\u03bcm", "mojibake": "\u00c2\u00b5m",
              "Greek mojibake": "\u00ce\u00bcm", "plain u": "um"}


def test_micro_as_u_spells_every_variant_u():
    assert {micro_as_u(v) for v in MICRO_TEXT.values()} == {"um"}
    assert micro_as_u("µm/V") == "um/V" and micro_as_u("nm") == "nm"


@pytest.mark.parametrize("spelling", MICRO_TEXT.values(), ids=MICRO_TEXT.keys())
def test_text_header_and_column_units(tmp_path, spelling):
    """Gwyddion-style header units and column titles: every spelling is micrometres."""
    path = tmp_path / "m.txt"
    path.write_text(f"# Width: 4 {spelling}\n# Height: 2 {spelling}\n"
                    f"# Value units: {spelling}\n1 2 3 4\n5 6 7 8\n", encoding="utf-8")
    topo = text.read(path)
    assert (topo.x.attrs["units"], topo.attrs["units"]) == ("um", "um")
    assert grid_of(topo).size == (2.0, 4.0)  # numbers as written: exact
    path.write_text(f"x [{spelling}]\th [{spelling}]\n0 1\n1 2\n2 3\n", encoding="utf-8")
    profile = text.read(path)
    assert (profile.x.attrs["units"], profile.attrs["units"]) == ("um", "um")


def test_text_utf8_micro_sign_in_a_latin1_file(tmp_path):
    """A file that is not valid UTF-8 is read as Latin-1: its UTF-8 'µ' becomes 'Âµ'."""
    path = tmp_path / "latin.txt"
    path.write_bytes(b"# Operator: J\xfcrgen\n# Width: 4 \xc2\xb5m\n# Height: 2 \xc2\xb5m\n"
                     b"# Value units: nm\n1 2 3 4\n5 6 7 8\n")
    topo = text.read(path)
    assert topo.attrs["Operator"] == "J\u00fcrgen"  # the decoding is Latin-1
    assert topo.x.attrs["units"] == "um" and grid_of(topo).size == (2.0, 4.0)


def sur_file(path, unit: bytes):
    """A one-object SUR map of 2 x 3 points whose three units are ``unit``."""
    header = bytearray(512)
    header[:12] = b"DIGITAL SURF"
    struct.pack_into("<4H", header, 12, 0, 1, 1, 2)
    struct.pack_into("<H5i", header, 98, 16, 0, 6, 3, 2, 6)
    struct.pack_into("<3f", header, 120, 0.5, 0.25, 0.01)
    for offset in (180, 196, 212):
        header[offset:offset + len(unit)] = unit
    path.write_bytes(bytes(header) + np.arange(6, dtype="<i2").tobytes())
    return path


@pytest.mark.parametrize("unit", [*MICRO_BYTES.values(), b"\xe6m"],
                         ids=[*MICRO_BYTES.keys(), "DOS code page"])
def test_sur_units(tmp_path, unit):
    topo = sur.read(sur_file(tmp_path / "m.sur", unit))
    assert (topo.x.attrs["units"], topo.attrs["units"]) == ("um", "um")


@pytest.mark.parametrize("unit", MICRO_BYTES.values(), ids=MICRO_BYTES.keys())
def test_ibw_units(tmp_path, unit):
    path = tmp_path / "w.ibw"
    path.write_bytes(make_ibw(np.ones((4, 3)), (0.5, 0.25), data_unit=unit,
                              dim_units=(unit, unit)))
    topo = ibw.read(path)
    assert (topo.x.attrs["units"], topo.attrs["units"]) == ("um", "um")
    assert ibw.channels(path)[0]["unit"] == "um"


@pytest.mark.parametrize("spelling", MICRO_TEXT.values(), ids=MICRO_TEXT.keys())
def test_gwy_units(tmp_path, spelling):
    gwyfile = pytest.importorskip("gwyfile")
    c = gwyfile.objects.GwyContainer()
    c["/0/data"] = gwyfile.objects.GwyDataField(np.ones((3, 4)), xreal=4.0, yreal=3.0,
                                                si_unit_xy=spelling, si_unit_z=spelling)
    c.tofile(str(tmp_path / "m.gwy"))
    topo = gwy.read(tmp_path / "m.gwy")
    assert (topo.x.attrs["units"], topo.attrs["units"]) == ("um", "um")


@pytest.mark.parametrize("spelling", MICRO_TEXT.values(), ids=MICRO_TEXT.keys())
def test_netcdf_units(tmp_path, spelling):
    topo = xrough.topography(np.ones((3, 4)), spacing=1.0, unit="um")
    for var in (topo, topo.x, topo.y):
        var.attrs["units"] = spelling
    topo.to_netcdf(tmp_path / "m.nc", engine="netcdf4")
    back = netcdf.read(tmp_path / "m.nc")
    assert (back.x.attrs["units"], back.attrs["units"]) == ("um", "um")


#: The scan size of each image of a measured Nanoscope file, and the same in micrometres
#: with as many bytes ("0.5" written ".5"), spelled in each way.
NANOSCOPE_SIZE = b"\\Scan Size: 500 500 nm"


@pytest.mark.parametrize("unit", [b"~m", *MICRO_BYTES.values()],
                         ids=["tilde", *MICRO_BYTES.keys()])
def test_nanoscope_units(tmp_path, unit):
    raw = data_path("instruments", "di-1.di").read_bytes()
    assert raw.count(NANOSCOPE_SIZE) == 4
    new = b"\\Scan Size: .5 .5 " + unit
    path = tmp_path / "di-um.di"
    path.write_bytes(raw.replace(NANOSCOPE_SIZE, new.ljust(len(NANOSCOPE_SIZE))))
    topo = nanoscope.read(path)
    assert topo.x.attrs["units"] == "um"
    assert grid_of(topo).size == (0.5, 0.5)  # as written: exact


# --------------------------------------------------------------------------- channels


def gwy_two_channels(tmp_path):
    gwyfile = pytest.importorskip("gwyfile")
    c = gwyfile.objects.GwyContainer()
    c["/0/data"] = gwyfile.objects.GwyDataField(np.zeros((3, 4)), xreal=1e-6, yreal=1e-6,
                                                si_unit_xy="m", si_unit_z="deg")
    c["/0/data/title"] = "Phase"
    c["/3/data"] = gwyfile.objects.GwyDataField(np.ones((3, 4)), xreal=1e-6, yreal=1e-6,
                                                si_unit_xy="m", si_unit_z="m")
    c["/3/data/title"] = "Topo"
    c.tofile(str(tmp_path / "two.gwy"))
    return tmp_path / "two.gwy"


def listed(module, path):
    """The listing every reader's channel errors hold, from its public ``channels``."""
    chans = module.channels(path)
    if module is bridge:  # the unit of the values, the first of a tuple (one per axis)
        chans = [dict(c, unit=c["data_unit"][0] if isinstance(c["data_unit"], tuple)
                      else c["data_unit"]) for c in chans]
    for c in chans:  # Nanoscope lists the scan line and direction of each image
        c["scan"] = " ".join(c.pop(k, "") for k in ("scan_line", "line_direction")).strip()
    return channel_listing(chans)


def readers_with_channels(tmp_path):
    ibw_path = tmp_path / "w.ibw"
    ibw_path.write_bytes(make_ibw(np.ones((4, 3)), (0.5, 0.25), data_unit=b"nm",
                                  dim_units=(b"um", b"um")))
    return {"gwy": (gwy, gwy_two_channels(tmp_path)), "ibw": (ibw, ibw_path),
            "nanoscope": (nanoscope, data_path("instruments", "di-1.di")),
            "bridge": (bridge, data_path("instruments", "nid-1.nid")),
            "bridge-nanoscope": (bridge, data_path("instruments", "di-1.di"))}


@pytest.mark.parametrize("reader", ["gwy", "ibw", "nanoscope", "bridge", "bridge-nanoscope"])
def test_unknown_channel_name_lists_the_channels_the_same_way(tmp_path, reader):
    module, path = readers_with_channels(tmp_path)[reader]
    if module is bridge:
        pytest.importorskip("SurfaceTopography")
    with pytest.raises(ValueError) as err:
        module.read(path, channel="No such channel")
    assert str(err.value) == (f"{path.name}: no channel named 'No such channel'; "
                              f"channels: {listed(module, path)}")


@pytest.mark.parametrize("reader", ["ibw", "nanoscope", "bridge"])
def test_channel_index_out_of_range_lists_the_channels(tmp_path, reader):
    module, path = readers_with_channels(tmp_path)[reader]
    if module is bridge:
        pytest.importorskip("SurfaceTopography")
    with pytest.raises(ValueError) as err:
        module.read(path, channel=99)
    assert str(err.value) == (f"{path.name}: channel index 99 out of range; "
                              f"channels: {listed(module, path)}")


def test_gwy_channel_is_chosen_by_its_id(tmp_path):
    path = gwy_two_channels(tmp_path)
    assert gwy.read(path, channel=3).attrs["channel"] == "Topo"
    assert gwy.read(path, channel="topo").attrs["channel"] == "Topo"
    with pytest.raises(ValueError) as err:
        gwy.read(path, channel=1)  # a position in the listing, but no field has id 1
    assert str(err.value) == f"two.gwy: no channel with id 1; channels: {listed(gwy, path)}"


def test_select_channel_by_position_id_and_name():
    chans = [{"index": 0, "name": "Phase", "unit": "deg"},
             {"index": 3, "name": "Topo", "unit": "m", "scan": "Main Trace"}]
    never = None  # the default is asked for only without a choice
    assert select_channel(Path("a"), chans, 1, default=never) is chans[1]
    assert select_channel(Path("a"), chans, 3, default=never, by_id=True) \
        is chans[1]
    assert select_channel(Path("a"), chans, " TOPO ", default=never) is chans[1]
    assert describe_channel(chans[1]) == "3: 'Topo' (Main Trace, m)"
    with pytest.raises(ValueError, match=r"^a: channel must be a name \(str\) or an index "
                                         r"\(int\), got 1\.5; channels: 0: 'Phase' \(deg\); "
                                         r"3: 'Topo' \(Main Trace, m\)$"):
        select_channel(Path("a"), chans, 1.5, default=never)
    assert select_channel(Path("a"), chans, None,
                          default=lambda path, c, listing, warn: c[0]) is chans[0]


def test_container_metadata_beside_a_file(tmp_path):
    """A contact.engineering meta.yml beside a file: its entry for that file becomes attrs
    container_<key> (nothing applied to the data); an entry for another file, no meta.yml,
    or one that does not parse (warned) give none."""
    import warnings

    from xrough.io.container import container_attrs

    (tmp_path / "meta.yml").write_text(
        "surfaces:\n- topographies:\n"
        "  - datafile: {original: a.txt}\n    description: Tip radius - 20 nm.\n"
        "    is_periodic: false\n    unit: nm\n    size: !!python/tuple [1.5, 2.0]\n"
        "    creator: {name: someone}\n"
        "  - datafile: {original: b.txt}\n    description: other\n", encoding="utf-8")
    got = container_attrs(tmp_path / "a.txt")
    assert got == {"container_file": "meta.yml", "container_description":
                   "Tip radius - 20 nm.", "container_is_periodic": 0,
                   "container_unit": "nm", "container_size": "1.5 2.0"}
    assert container_attrs(tmp_path / "c.txt") == {}
    assert container_attrs(tmp_path / "sub" / "a.txt") == {}
    (tmp_path / "meta.yml").write_text("surfaces: [unclosed", encoding="utf-8")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert container_attrs(tmp_path / "a.txt") == {}
    assert len(caught) == 1 and "not read as a contact.engineering container" in \
        str(caught[0].message)
