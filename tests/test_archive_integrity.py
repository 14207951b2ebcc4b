"""Archives and NetCDF topographies never reopen with changed numbers; killed saves leave nothing.

Every group and variable carries a SHA-256 checksum (attribute ``xrough_sha256``) taken
from the file read back after writing; a byte flipped anywhere in the file either makes
the reader refuse it with a message naming the file, or leaves the values identical.
"""

import importlib.util
import os
import subprocess
import sys
import time
import warnings

import netCDF4
import numpy as np
import pytest
import xarray as xr

import xrough
import xrough.cli._common
from xrough.io import archive, netcdf
from xrough.io._checksum import CHECKSUM

needs_zarr = pytest.mark.skipif(importlib.util.find_spec("zarr") is None,
                                reason="zarr not installed (xrough[zarr])")


def _small():
    topo = xrough.topography(np.random.default_rng(3).normal(size=(16, 16)), spacing=1.0,
                             unit="nm")
    G = topo.rough.acf()
    return {"m": {"topography": topo, "G": G}}


def _assert_same(back, original):
    for key, value in original["m"].items():
        xr.testing.assert_identical(back["m"][key], value)


def _flip(raw: bytes, position: int) -> bytes:
    flipped = bytearray(raw)
    flipped[position] ^= 0xFF
    return bytes(flipped)


def _positions(size: int, n: int, seed: int) -> np.ndarray:
    """``n`` distinct positions spread over the whole file: one at random in each of ``n``
    equal slices, so the header, the metadata and the data sections are all hit."""
    edges = np.linspace(0, size, n + 1).astype(int)
    rng = np.random.default_rng(seed)
    return np.array([rng.integers(lo, hi) for lo, hi in zip(edges[:-1], edges[1:])])


def test_flipped_bytes_never_reopen_with_changed_numbers(tmp_path):
    """60 single flipped bytes: each one refused naming the file, or values identical.

    Without checksums, 10 of these 60 flips reopened with changed heights, G values or
    coordinates, without any error.
    """
    analysis = _small()
    raw = xrough.save_analysis(tmp_path / "a.nc", analysis).read_bytes()
    refused = identical = 0
    for position in _positions(len(raw), 60, seed=0):
        path = tmp_path / f"flip{position}.nc"
        path.write_bytes(_flip(raw, position))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                back = xrough.open_analysis(path)
        except Exception as err:  # noqa: BLE001 - any refusal must name the file
            assert path.name in str(err), (position, err)
            refused += 1
            continue
        _assert_same(back, analysis)  # never changed numbers
        identical += 1
    assert refused + identical == 60 and refused > 0


@needs_zarr
def test_flipped_bytes_in_a_zarr_store_never_change_numbers(tmp_path):
    """60 single flipped bytes, each in a file of the store drawn at random (metadata and
    compressed chunks alike), restored after each trial: refused naming the store, or
    values identical. Without checksums, 11 of these 60 reopened with changed numbers."""
    analysis = _small()
    store = xrough.save_analysis(tmp_path / "a.zarr", analysis)
    files = sorted(p for p in store.rglob("*") if p.is_file())
    rng = np.random.default_rng(0)
    refused = 0
    for _ in range(60):
        file = files[rng.integers(len(files))]
        raw = file.read_bytes()
        file.write_bytes(_flip(raw, int(rng.integers(len(raw)))))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                back = xrough.open_analysis(store)
        except Exception as err:  # noqa: BLE001 - any refusal must name the store
            assert "a.zarr" in str(err), (file, err)
            refused += 1
        else:
            _assert_same(back, analysis)
        file.write_bytes(raw)
    assert refused > 0


def test_changed_data_is_refused_naming_file_and_variable(tmp_path):
    analysis = _small()
    path = xrough.save_analysis(tmp_path / "a.nc", analysis)
    raw = path.read_bytes()
    heights = analysis["m"]["topography"].values.astype("<f8").tobytes()
    start = raw.index(heights)  # stored contiguous and uncompressed
    path.write_bytes(_flip(raw, start + 8 * 37 + 3))  # one height, bit pattern changed
    with pytest.raises(ValueError, match=r"a\.nc: checksum mismatch in variable "
                                         r"'height' of group '/m/topography'"):
        xrough.open_analysis(path)


def _edit(path, edit):
    with netCDF4.Dataset(path, "a") as nc:
        edit(nc)


def test_changed_attribute_or_missing_checksum_is_refused(tmp_path):
    analysis = _small()
    units = xrough.save_analysis(tmp_path / "units.nc", analysis)
    _edit(units, lambda nc: nc["m/G/G"].setncattr("units", "km2"))
    with pytest.raises(ValueError, match=r"units\.nc: checksum mismatch in variable 'G'"):
        xrough.open_analysis(units)
    # a lazy open reads no values, but compares the attributes (the group's checksum)
    with pytest.raises(ValueError, match=r"units\.nc: checksum mismatch in group '/m/G'"):
        xrough.open_analysis(units, chunks={})
    lost = xrough.save_analysis(tmp_path / "lost.nc", analysis)
    _edit(lost, lambda nc: nc["m/G/G"].delncattr(CHECKSUM))
    with pytest.raises(ValueError, match=r"lost\.nc: variable 'G' of group '/m/G' has no "
                                         "checksum"):
        xrough.open_analysis(lost)


def _strip_all(nc):
    for group in [nc, *nc.groups.values()] + [g for sub in nc.groups.values()
                                              for g in sub.groups.values()]:
        if CHECKSUM in group.ncattrs():
            group.delncattr(CHECKSUM)
        for var in group.variables.values():
            if CHECKSUM in var.ncattrs():
                var.delncattr(CHECKSUM)


def test_archive_without_checksums_opens_with_one_warning(tmp_path):
    """Archives written before checksums open as before, with one warning per open."""
    analysis = _small()
    path = xrough.save_analysis(tmp_path / "old.nc", analysis)
    _edit(path, _strip_all)
    with pytest.warns(UserWarning, match=r"old\.nc: .*written before xrough stored "
                                         "checksums") as caught:
        back = xrough.open_analysis(path)
    assert len([w for w in caught if "checksums" in str(w.message)]) == 1
    _assert_same(back, analysis)


def test_checksums_are_not_in_the_returned_objects(tmp_path):
    analysis = _small()
    path = xrough.save_analysis(tmp_path / "a.nc", analysis)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a checked archive opens without warning
        back = xrough.open_analysis(path)
    assert CHECKSUM not in back["_provenance"]
    assert all(CHECKSUM not in v.attrs for v in back["m"]["G"].coords.values())
    _assert_same(back, analysis)


@needs_zarr
def test_zarr_store_with_changed_values_or_attributes_is_refused(tmp_path):
    import zarr

    analysis = _small()
    store = xrough.save_analysis(tmp_path / "a.zarr", analysis)
    heights = zarr.open_group(store, mode="r+", use_consolidated=False)[
        "m/topography/height"]
    heights[3, 4] = heights[3, 4] + 1e-9  # a silently changed chunk: valid, other numbers
    with pytest.raises(ValueError, match=r"a\.zarr: checksum mismatch in variable "
                                         "'height'"):
        xrough.open_analysis(store)
    other = xrough.save_analysis(tmp_path / "b.zarr", analysis)
    meta = other / ".zmetadata"
    text = meta.read_text()
    assert text.count('"nm"') >= 1
    meta.write_text(text.replace('"nm"', '"um"', 1))  # a changed unit in the metadata
    with pytest.raises(ValueError, match=r"b\.zarr: checksum mismatch"):
        xrough.open_analysis(other)


@pytest.mark.parametrize("fmt", ["NETCDF4", "NETCDF3_64BIT", "NETCDF3_CLASSIC"])
def test_netcdf_topography_flips_are_refused_or_identical(tmp_path, fmt):
    """xrough's NetCDF topographies: 60 flips each, refused naming the file or identical.

    Without checksums, these flips reopened with changed numbers and no error in 40 of 60
    cases for both NETCDF3 formats (no redundancy at all) and 8 of 60 for NETCDF4.
    """
    topo = xrough.topography(np.random.default_rng(1).normal(size=(12, 10)), spacing=1.0,
                             unit="nm")
    netcdf.write(topo, tmp_path / "t.nc", format=fmt)
    raw = (tmp_path / "t.nc").read_bytes()
    refused = 0
    for position in _positions(len(raw), 60, seed=1):
        path = tmp_path / f"flip{position}.nc"
        path.write_bytes(_flip(raw, position))
        try:
            back = netcdf.read(path)
        except ValueError as err:
            assert str(err).startswith(f"{path.name}:"), (position, err)
            refused += 1
            continue
        xr.testing.assert_identical(back, topo)
    assert refused > 0


def test_netcdf_topography_changed_height_is_refused(tmp_path):
    topo = xrough.topography(np.arange(12.0).reshape(3, 4), spacing="2 nm", unit="nm")
    path = tmp_path / "t.nc"
    netcdf.write(topo, path, format="NETCDF3_64BIT")
    raw = path.read_bytes()
    start = raw.index(topo.values.astype(">f8").tobytes())  # NetCDF-3 is big-endian
    path.write_bytes(_flip(raw, start + 8 * 5 + 1))
    with pytest.raises(ValueError, match=r"^t\.nc: checksum mismatch in variable"):
        netcdf.read(path)
    foreign = tmp_path / "foreign.nc"
    topo.to_netcdf(foreign, format="NETCDF3_64BIT")  # not written by xrough: no checksums
    xr.testing.assert_identical(netcdf.read(foreign), topo)


# --- temporary files of killed saves ---------------------------------------------------


def _ended_pid() -> int:
    """The id of a process that has ended (a child that ran and was reaped)."""
    child = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                           capture_output=True, text=True, check=True)
    return int(child.stdout)


@pytest.mark.skipif(os.name == "nt", reason="process ids are not checked on Windows")
def test_temporaries_of_killed_saves_are_removed_on_the_next_save(tmp_path):
    dead, alive = _ended_pid(), os.getpid()
    hexa = "0123456789ab"
    stale = [f".a.nc.{dead}-{hexa}.tmp",                       # a killed save_analysis
             f"..a.nc.{dead}-{hexa}.tmp.{dead}-{hexa}.tmp",   # within a killed CLI write
             f".a.nc.{hexa}.tmp"]                             # earlier naming, old
    kept = [f".a.nc.{alive}-{hexa}.tmp",   # a save still running
            f".b.nc.{dead}-{hexa}.tmp",    # another target's
            f".a.nc.{hexa}.tmp.bak", "a.nc.notes", ".a.nc.tmp", f".a.nc.{dead}-xyz.tmp",
            f".xa.nc.{dead}-{hexa}.tmp", f"a.nc.{dead}-{hexa}.tmp"]
    for name in stale + kept:
        (tmp_path / name).write_bytes(b"x" * 100)
    old = time.time() - 2 * archive._STALE_SECONDS
    os.utime(tmp_path / f".a.nc.{hexa}.tmp", (old, old))
    fresh = tmp_path / ".a.nc.fedcba987654.tmp"  # earlier naming, may still be written
    fresh.write_bytes(b"x")
    xrough.save_analysis(tmp_path / "a.nc", _small())
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["a.nc", fresh.name, *kept])


@needs_zarr
@pytest.mark.skipif(os.name == "nt", reason="process ids are not checked on Windows")
def test_temporary_stores_of_killed_zarr_saves_are_removed(tmp_path):
    dead = _ended_pid()
    for kind in ("tmp", "old"):
        left = tmp_path / f".a.zarr.{dead}-0123456789ab.{kind}"
        (left / "sub").mkdir(parents=True)
        (left / "sub" / "0.0").write_bytes(b"x" * 1000)
    other = tmp_path / f".b.zarr.{dead}-0123456789ab.tmp"
    other.mkdir()
    xrough.save_analysis(tmp_path / "a.zarr", _small())
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["a.zarr", other.name])


@pytest.mark.skipif(os.name == "nt", reason="process ids are not checked on Windows")
def test_command_line_writes_remove_their_killed_temporaries(tmp_path):
    dead = _ended_pid()
    left = tmp_path / f".out.nc.{dead}-0123456789ab.tmp"
    left.write_bytes(b"half")
    xrough.cli._common.write_atomic(tmp_path / "out.nc", lambda p: p.write_bytes(b"done"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.nc"]


@pytest.mark.parametrize("error", [FileNotFoundError(2, "No such file or directory"),
                                   RuntimeError("NetCDF: HDF error"), KeyError("x")])
def test_library_errors_on_an_existing_file_name_it(tmp_path, monkeypatch, error):
    """What the NetCDF library raises on a damaged file (a FileNotFoundError for a file
    that exists, too) is a ValueError naming the file, the original chained."""
    path = xrough.save_analysis(tmp_path / "a.nc", _small())

    def broken(*args, **kwargs):
        raise error

    monkeypatch.setattr(xr, "open_datatree", broken)
    with pytest.raises(ValueError, match=r"a\.nc: cannot read as an xrough archive "
                                         r"\(netcdf\)") as caught:
        xrough.open_analysis(path)
    assert caught.value.__cause__ is error
    monkeypatch.undo()
    monkeypatch.setattr(archive, "_restore", broken)  # a failure while reading the groups
    with pytest.raises(ValueError, match=r"a\.nc: cannot read as an xrough archive"):
        xrough.open_analysis(path)
