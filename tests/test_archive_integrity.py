"""Archives and NetCDF topographies never reopen with changed numbers; killed saves leave nothing.

Every chunk of every numeric variable carries the storage library's checksum (HDF5's
Fletcher-32, Zarr's CRC-32C), checked whenever it is read, lazily too; what those do not
cover has SHA-256 digests in the one global attribute ``xrough``. A byte flipped anywhere
in the file either makes the reader refuse it with a message naming the file (for a lazy
open: when the chunk is computed), or leaves the values identical.
"""

import importlib.util
import json
import os
import re
import subprocess
import sys
import time
import warnings

import dask
import netCDF4
import numpy as np
import pytest
import xarray as xr

import xrough
import xrough.cli._common
from xrough.io import archive, netcdf
from xrough.io._checksum import KEY, LEGACY
from xrough.io._common import CorruptedFileError

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


def _computed(back):
    return {"m": {key: value.compute() for key, value in back["m"].items()}}


@pytest.mark.parametrize("chunks", [None, {}], ids=["eager", "lazy"])
def test_flipped_bytes_never_reopen_with_changed_numbers(tmp_path, chunks):
    """60 single flipped bytes: each one refused naming the file, or values identical.

    Opened eagerly, or lazily (``chunks={}``) and then computed: a corrupted chunk is
    refused when a dask task reads it. Without checksums, 10 of these 60 flips reopened
    with changed heights, G values or coordinates, without any error; opened lazily with
    the SHA-256 digests of earlier versions (values not read at open), 16 of 60.
    """
    analysis = _small()
    raw = xrough.save_analysis(tmp_path / "a.nc", analysis).read_bytes()
    refused = identical = 0
    for position in _positions(len(raw), 60, seed=0):
        path = tmp_path / f"flip{position}.nc"  # a new name each: the library caches files
        path.write_bytes(_flip(raw, position))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                back = _computed(xrough.open_analysis(path, chunks=chunks))
        except Exception as err:  # noqa: BLE001 - any refusal must name the file
            assert path.name in str(err), (position, err)
            refused += 1
            continue
        _assert_same(back, analysis)  # never changed numbers
        identical += 1
    assert refused + identical == 60 and refused > 0


@needs_zarr
@pytest.mark.parametrize("chunks", [None, {}], ids=["eager", "lazy"])
def test_flipped_bytes_in_a_zarr_store_never_change_numbers(tmp_path, chunks):
    """60 single flipped bytes, each in a file of the store drawn at random (metadata and
    compressed chunks alike), restored after each trial: refused naming the store, or
    values identical, eagerly or lazily once computed. Without checksums, 11 of these 60
    reopened with changed numbers."""
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
                back = _computed(xrough.open_analysis(store, chunks=chunks))
        except Exception as err:  # noqa: BLE001 - any refusal must name the store
            assert "a.zarr" in str(err), (file, err)
            refused += 1
        else:
            _assert_same(back, analysis)
        file.write_bytes(raw)
    assert refused > 0


def test_changed_data_is_refused_naming_file_and_variable(tmp_path):
    """HDF5 checks the chunk's Fletcher-32 checksum on every read, at open or computed."""
    analysis = _small()
    path = xrough.save_analysis(tmp_path / "a.nc", analysis)
    raw = path.read_bytes()
    heights = analysis["m"]["topography"].values.astype("<f8").tobytes()
    start = raw.index(heights)  # one chunk, uncompressed
    path.write_bytes(_flip(raw, start + 8 * 37 + 3))  # one height, bit pattern changed
    message = r"a\.nc: corrupted data in (a chunk of )?variable 'height' of group '/m/topography'"
    with pytest.raises(CorruptedFileError, match=message):
        xrough.open_analysis(path)
    lazy = xrough.open_analysis(path, chunks={})["m"]  # only metadata read: opens
    xr.testing.assert_identical(lazy["G"].compute(), analysis["m"]["G"])
    with pytest.raises(CorruptedFileError, match=message.replace("(a chunk of )?", "a chunk of ")):
        lazy["topography"].compute()  # the chunk, read by a dask task, fails its checksum


def _edit(path, edit):
    with netCDF4.Dataset(path, "a") as nc:
        edit(nc)


def _edit_record(nc, edit):
    record = json.loads(nc.getncattr(KEY))
    edit(record["groups"])
    nc.setncattr(KEY, json.dumps(record))


def test_changed_attribute_or_missing_checksum_is_refused(tmp_path):
    analysis = _small()
    units = xrough.save_analysis(tmp_path / "units.nc", analysis)
    _edit(units, lambda nc: nc["m/G/G"].setncattr("units", "km2"))
    message = r"units\.nc: checksum mismatch in variable 'G' of group '/m/G'"
    with pytest.raises(CorruptedFileError, match=message):
        xrough.open_analysis(units)
    with pytest.raises(CorruptedFileError, match=message):  # lazily: no values read
        xrough.open_analysis(units, chunks={})
    lost = xrough.save_analysis(tmp_path / "lost.nc", analysis)
    _edit(lost, lambda nc: _edit_record(nc, lambda g: g["/m/G"]["sha256"].pop("G")))
    with pytest.raises(CorruptedFileError, match=r"lost\.nc: checksum mismatch in variable "
                                                 "'G' of group '/m/G'"):
        xrough.open_analysis(lost)
    gone = xrough.save_analysis(tmp_path / "gone.nc", analysis)
    _edit(gone, lambda nc: _edit_record(nc, lambda g: g.pop("/m/G")))
    with pytest.raises(CorruptedFileError, match=r"gone\.nc: group '/m/G' has no checksum"):
        xrough.open_analysis(gone)
    _edit(gone, lambda nc: nc.setncattr(KEY, "{not json"))
    with pytest.raises(CorruptedFileError, match=r"gone\.nc: corrupted file: its attribute "):
        xrough.open_analysis(gone)
    _edit(gone, lambda nc: nc.delncattr(KEY))
    with pytest.raises(ValueError, match=r"gone\.nc: not an analysis archive"):
        xrough.open_analysis(gone)


def test_archive_of_an_earlier_version_opens_with_one_warning(tmp_path):
    """Archives with xrough's attributes in their groups (and SHA-256 checksums per
    variable, or none) open as before, unverified, with one warning per open."""
    analysis = _small()
    path = tmp_path / "old.nc"
    tree = {"/": xr.Dataset(attrs={"xrough_version": "0.1"}), **archive._tree(analysis)}
    tree["/m/G"]["G"].attrs[LEGACY] = "0" * 64
    xr.DataTree.from_dict(tree).to_netcdf(path)
    with pytest.warns(UserWarning, match=r"old\.nc: .*earlier version of xrough") as caught:
        back = xrough.open_analysis(path)
    assert len([w for w in caught if "earlier version" in str(w.message)]) == 1
    _assert_same(back, analysis)


def test_checksums_are_not_in_the_returned_objects(tmp_path):
    analysis = _small()
    path = xrough.save_analysis(tmp_path / "a.nc", analysis)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a checked archive opens without warning
        back = xrough.open_analysis(path)
    assert KEY not in back["_provenance"]
    _assert_same(back, analysis)


@pytest.mark.parametrize("suffix", [".nc", pytest.param(".zarr", marks=needs_zarr)])
def test_archives_are_plain_cf_for_other_tools(tmp_path, suffix):
    """Groups and variables hold their own attributes only; xrough's record and digests
    are the one global attribute ``xrough`` (earlier: xrough_sha256 on every variable,
    xrough_object and xrough_dataarray_name on every group)."""
    analysis = _small()
    analysis["m"]["flags"] = xr.Dataset({"ok": ((), True), "names": ("k", ["a", "b"])},
                                        attrs={"done": True, "when": None})
    path = xrough.save_analysis(tmp_path / f"a{suffix}", analysis)
    engine = "zarr" if suffix == ".zarr" else "netcdf4"
    with xr.open_datatree(path, engine=engine) as tree:
        assert KEY in tree.attrs and tree.attrs["Conventions"] == "CF-1.10"
        own = [(node.path, name) for node in tree.subtree
               for attrs in (node.attrs, *(v.attrs for v in node.variables.values()))
               for name in attrs if name.startswith("xrough") and name != "xrough_version"]
    assert own == [("/", KEY)]  # (results state the xrough_version that made them)
    back = xrough.open_analysis(path)["m"]
    xr.testing.assert_identical(back["flags"], analysis["m"]["flags"])
    _assert_same({"m": back}, analysis)


@needs_zarr
def test_zarr_store_with_changed_values_or_attributes_is_refused(tmp_path):
    analysis = _small()
    store = xrough.save_analysis(tmp_path / "a.zarr", analysis)
    chunk = store / "m" / "topography" / "height" / "0.0"
    chunk.write_bytes(_flip(chunk.read_bytes(), 40))  # compressed: its CRC-32C fails
    message = r"a\.zarr: corrupted data in (a chunk of )?variable 'height' of group '/m/topography'"
    with pytest.raises(CorruptedFileError, match=message):
        xrough.open_analysis(store)
    lazy = xrough.open_analysis(store, chunks={})["m"]["topography"]
    with pytest.raises(CorruptedFileError, match=message.replace("(a chunk of )?", "a chunk of ")):
        lazy.compute()
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


#: HDF5 1.14.2 (the netCDF4 1.7.1 wheels, the oldest supported) crashed the process in
#: 1-2 of 6 runs of this test when dask's threads read these damaged files (a file
#: closed by the garbage collector in one thread while another reads; xarray serialises
#: the reads, not that close), and never with one thread (4 of 4); HDF5 2.2 never did.
#: Below HDF5 2 the lazy reads here run in one thread: the check tested is the same.
_DAMAGED_INDEX_SCHEDULER = ("threads" if int(netCDF4.__hdf5libversion__.split(".")[0]) >= 2
                            else "synchronous")


@pytest.mark.parametrize("chunks", [None, {}], ids=["eager", "lazy"])
def test_a_damaged_index_of_chunks_is_refused(tmp_path, chunks):
    """HDF5's chunk index (version-1 B-tree nodes) has no checksum: a flipped byte in a
    chunk's key makes the library skip the chunk and return fill values (NaN) without
    reading, hence checking, it. The missing values counted when written catch it."""
    analysis = _small()
    raw = xrough.save_analysis(tmp_path / "a.nc", analysis).read_bytes()
    starts = [i for i in range(len(raw)) if raw.startswith(b"TREE\x01", i)]  # chunk nodes
    assert starts
    for start in starts:
        for position in range(start + 24, start + 40):  # the first chunk's key
            path = tmp_path / f"flip{position}.nc"
            path.write_bytes(_flip(raw, position))
            try:
                with dask.config.set(scheduler=_DAMAGED_INDEX_SCHEDULER):
                    back = _computed(xrough.open_analysis(path, chunks=chunks))
            except ValueError as err:
                assert path.name in str(err), (position, err)
            else:
                _assert_same(back, analysis)


# --- files that declare more than they hold ----------------------------------------------
#
# A header is cheap to forge: a few kB declare a 100000 x 100000 variable whose chunks are
# not written (read as 74.5 GiB of fill values), a shape edited in a Zarr store's metadata
# declares 244 million chunks to look up. Each is refused from the metadata alone: the
# functions that would read the data, or list the chunks, are replaced by ones that fail
# the test, so a check that came too late could neither allocate nor hang.


def _never(*args, **kwargs):
    raise AssertionError("reached the data: the declared sizes were not checked first")


def _forged_netcdf(path, shape=(100_000, 100_000), **kwargs):
    """A NetCDF-4 file declaring a float64 ``height`` of ``shape``, none of it written."""
    with netCDF4.Dataset(path, "w") as nc:
        for dim, n in zip(("y", "x"), shape):
            nc.createDimension(dim, n)
        nc.createVariable("height", "f8", ("y", "x"), **kwargs).units = "nm"
    return path


@pytest.mark.parametrize("h5py_installed", [True, False], ids=["h5py", "no-h5py"])
@pytest.mark.parametrize(("shape", "kwargs"), [
    ((100_000, 100_000), {"zlib": True, "chunksizes": (1000, 1000)}),  # above MAX_POINTS
    ((40_000, 40_000), {"zlib": True, "chunksizes": (1000, 1000)}),  # 12 GiB, below it
    ((20_000, 20_000), {"contiguous": True}),  # uncompressed: 3.2 GB, never stored
], ids=["deflated-huge", "deflated-below-cap", "contiguous"])
def test_netcdf_declaring_unwritten_data_is_refused_before_reading(
        tmp_path, monkeypatch, shape, kwargs, h5py_installed):
    if h5py_installed:
        pytest.importorskip("h5py")
    else:  # the bounds by the file's size alone
        monkeypatch.setattr(netcdf, "_open_h5", lambda path: None)
    path = _forged_netcdf(tmp_path / "forged.nc", shape, **kwargs)
    assert path.stat().st_size < 100_000
    monkeypatch.setattr(netcdf, "_open", _never)
    expected = (r"forged\.nc: variable 'height' of group '/' declares shape "
                + re.escape(str(shape)))
    with pytest.raises(ValueError, match=expected) as err:
        xrough.open_topography(path)
    assert "refused before reading" in str(err.value)
    with pytest.raises(ValueError, match=expected + r".*(written|in the file)"):
        netcdf.read(path, max_points=10**11)  # not the limit of points: the missing data
    if shape[0] > 50_000:
        with pytest.raises(ValueError, match=r"more than the limit of 2147483648 points"):
            xrough.open_topography(path)


def test_netcdf_within_the_limits_still_reads(tmp_path):
    topo = xrough.topography(np.random.default_rng(0).normal(size=(64, 64)), spacing=1.0,
                             unit="nm")
    netcdf.write(topo, tmp_path / "t.nc")
    xr.testing.assert_identical(netcdf.read(tmp_path / "t.nc"), topo)
    with pytest.raises(ValueError, match=r"t.nc: variable '\w+' of group '/' declares shape "
                                         r"\(64, 64\).*more than the limit of 100 points"):
        netcdf.read(tmp_path / "t.nc", max_points=100)


@pytest.mark.parametrize("chunks", [None, {}], ids=["eager", "lazy"])
def test_archive_declaring_unwritten_data_is_refused_before_reading(tmp_path, monkeypatch,
                                                                    chunks):
    path = xrough.save_analysis(tmp_path / "a.nc", _small())
    with netCDF4.Dataset(path, "a") as nc:
        group = nc["m/topography"]
        group.createDimension("big_y", 100_000)
        group.createDimension("big_x", 100_000)
        group.createVariable("forged", "f8", ("big_y", "big_x"), zlib=True,
                             chunksizes=(1000, 1000))
    assert path.stat().st_size < 64_000
    monkeypatch.setattr(archive, "_open_tree", _never)
    with pytest.raises(ValueError, match=r"a\.nc: variable 'forged' of group '/m/topography' "
                                         r"declares shape \(100000, 100000\)"):
        xrough.open_analysis(path, chunks=chunks)


def _edit_zarr_shape(store, array, shape):
    """Edit an array's shape in the store's metadata, consolidated and its own."""
    own = store / array / ".zarray"
    meta = json.loads(own.read_text())
    meta["shape"] = list(shape)
    own.write_text(json.dumps(meta))
    consolidated = json.loads((store / ".zmetadata").read_text())
    consolidated["metadata"][f"{array}/.zarray"]["shape"] = list(shape)
    (store / ".zmetadata").write_text(json.dumps(consolidated))


@needs_zarr
@pytest.mark.parametrize("chunks", [None, {}], ids=["eager", "lazy"])
def test_zarr_shape_edited_to_a_million_squared_is_refused_before_listing(
        tmp_path, monkeypatch, chunks):
    store = xrough.save_analysis(tmp_path / "a.zarr", _small())
    _edit_zarr_shape(store, "m/topography/height", (10**6, 10**6))  # 244 M chunks of 64^2
    monkeypatch.setattr(archive, "_store_files", _never)
    monkeypatch.setattr(archive, "_open_tree", _never)
    why = "points, more than the limit" if chunks is None else "chunks.*more than the limit"
    with pytest.raises(ValueError, match=rf"a\.zarr: array 'm/topography/height' of the Zarr "
                                         rf"store declares shape \(1000000, 1000000\).*{why}"):
        xrough.open_analysis(store, chunks=chunks)


@needs_zarr
@pytest.mark.parametrize("chunks", [None, {}], ids=["eager", "lazy"])
def test_zarr_v3_array_of_a_million_squared_is_refused_before_listing(
        tmp_path, monkeypatch, chunks):
    import zarr

    store = tmp_path / "v3.zarr"
    group = zarr.open_group(store, mode="w", zarr_format=3)
    group.create_array("height", shape=(10**6, 10**6), chunks=(64, 64), dtype="f8")
    assert (store / "zarr.json").is_file() and (store / "height" / "zarr.json").is_file()
    monkeypatch.setattr(archive, "_store_files", _never)
    with pytest.raises(ValueError, match=r"v3\.zarr: array 'height' of the Zarr store "
                                         r"declares shape \(1000000, 1000000\) with chunks "
                                         r"\(64, 64\)"):
        xrough.open_analysis(store, chunks=chunks)


@needs_zarr
def test_zarr_chunks_are_looked_up_in_one_listing(tmp_path):
    """The chunks of a store are looked up in one listing of its files (zarr's own count
    compared every name with every file: 9 s for 30000 chunks); a lost one is named."""
    many = xr.DataArray(np.arange(300.0), dims="i", name="v").chunk({"i": 1})
    store = xrough.save_analysis(tmp_path / "many.zarr", {"v": many})
    xr.testing.assert_identical(xrough.open_analysis(store, chunks={})["v"].compute(),
                                many.compute())
    (store / "v" / "v" / "299").unlink()
    with pytest.raises(ValueError, match=r"incomplete Zarr store: chunks missing from "
                                         r"'v/v' \(1 of 300\)"):
        xrough.open_analysis(store, chunks={})
