"""The file options of ``info``, ``acf`` and ``report``: checked, files read and measured.

The options are checked here, in the words of the command line, before the library is
called. A file that does not read for lack of a unit, a size or ``--resample`` raises
:class:`~xrough.io.MissingOptionError`, which says which keywords supply it: the error
names the options of the command line that set them.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import contextlib
import inspect
import multiprocessing
import re
import shutil
import signal
import stat
import sys
import tempfile
import threading
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .. import units as u
from .._kernels.binning import MAX_POINTS_PER_DECADE, check_points_per_decade
from .._kernels.pairs import cores
from ..io import MissingOptionError, detect_format, registered
from ..io.folders import measurement_files, measurement_names
from ..io.readers import reader_of
from ..preprocess import DETREND_MODES, detrend
from ..progress import draw_by_default, progress_bar
from ..toolbox.ensemble import open_measurement
from ._common import CLIError, fail, first_line, warn_lines

NONUNIFORM = ("the profile is sampled non-uniformly: give --resample (linear interpolation "
              "onto a uniform grid with the same number of points)")

#: With ``--jobs 0`` (the default), files are measured in worker processes (one per core)
#: from this many files on: each worker starts by importing the library (about 2 s of
#: CPU), which a few files do not repay (``benchmarks/bench_cli_folder.py``).
AUTO_JOBS_FILES = 16

#: The keywords of :func:`~xrough.open_topography` that an option of the commands sets.
_FILE_OPTIONS = ("size", "unit", "height_unit", "height_scale", "periodic", "channel",
                 "resample")


def add_file_options(p: argparse.ArgumentParser, *, detrend: bool = True) -> None:
    """Add the files and the options that say how to read them."""
    p.add_argument("files", nargs="+", help="topography files (any supported format)")
    p.add_argument("--format", choices=list(registered()),
                   help="file format (default: detected from the content)")
    p.add_argument("--size", help="physical size replacing the file's, e.g. '100 nm' or "
                   "'10 um,20 um' (y, x)")
    p.add_argument("--unit", help="lateral unit replacing the file's, and the height "
                   "unit too unless --height-unit is given (relabels, does not convert)")
    p.add_argument("--height-unit", dest="height_unit",
                   help="height unit replacing the file's (relabels)")
    p.add_argument("--height-scale", type=float, help="factor applied to the heights")
    p.add_argument("--periodic", action="store_true", help="the maps are periodic")
    p.add_argument("--channel", help="channel of multi-channel files (Nanoscope, "
                   "Gwyddion, Igor, ...): a name or an index (0, 1, ...)")
    p.add_argument("--resample", action="store_true",
                   help="resample non-uniformly sampled profiles onto a uniform grid")
    p.add_argument("--json", action="store_true",
                   help="print JSON (numbers in the results' units, with units fields)")
    if detrend:
        p.add_argument("--detrend", default="auto", choices=["auto", "none", *DETREND_MODES],
                       help="trend removed before G: auto (default) is a plane for maps "
                       "and a line for profiles; none keeps the heights")


def add_acf_options(p: argparse.ArgumentParser, name: str) -> None:
    """Add the output and the lag options of the commands that compute G."""
    p.add_argument("-o", "--output", default=f"xrough-{name}.nc",
                   help="NetCDF output, or a Zarr store if it ends in .zarr (its folder "
                   "is created if missing)")
    p.add_argument("--direction", default="radial", choices=["radial", "x", "y"],
                   help="lags in all directions (default) or along x or y only")
    p.add_argument("--points-per-decade", type=float, default=10,
                   help="log-spaced bins of G per decade of lag (default 10)")
    p.add_argument("--jobs", "-j", type=jobs_option, default=0,
                   help="processes that measure files at once (default 0: one per core "
                   f"when there are at least {AUTO_JOBS_FILES} files, else 1)")
    p.add_argument("--all-lags", action="store_true",
                   help="keep every lag: ignore a tip or stylus radius that the file or its "
                   "container states (by default the lags finer than the tip resolves are "
                   "left out of the contact results)")


# -------------------------------------------------------------- options, checked


def _length_unit(given: str | None, option: str) -> str | None:
    return None if given is None else u.format_units(u.as_length_unit(given, what=option))


def _size(given: str | None) -> str | tuple[str, str] | None:
    """``--size``: one length (a profile, or a square map) or two (y, x)."""
    if not given:
        return None
    parts = [p.strip() for p in given.split(",")]
    if len(parts) > 2:
        raise CLIError(f"--size {given}: give one size or two (y, x), e.g. '10 um,20 um'")
    for part in parts:
        q = u.quantity(part, what=f"--size {given}")
        if q.dimensionless:
            raise CLIError(f"--size {given}: the size has no unit; write it with one, e.g. "
                           "--size '10 um'")
        if not (q.check("[length]") and np.isfinite(q.magnitude) and q.magnitude > 0):
            raise CLIError(f"--size {given}: {part!r} is not a positive length")
    return parts[0] if len(parts) == 1 else (parts[0], parts[1])


def _channel(given: str) -> int | str:
    """``--channel`` as an index (``0``, ``-1``) or a name."""
    return int(given) if re.fullmatch(r"[+-]?\d+", given.strip()) else given


def _checked(args: argparse.Namespace) -> dict:
    """Return the keywords of :func:`~xrough.open_topography` for the command's options."""
    scale = args.height_scale
    if scale is not None and not (np.isfinite(scale) and scale != 0):
        raise CLIError(f"--height-scale {scale}: must be a finite, non-zero number")
    try:
        options: dict[str, Any] = {
            "size": _size(args.size), "unit": _length_unit(args.unit, "--unit"),
            "height_unit": _length_unit(args.height_unit, "--height-unit")}
    except CLIError:
        raise
    except ValueError as err:  # a unit's own message, naming the option
        raise CLIError(first_line(err)) from None
    options.update(height_scale=scale, periodic=True if args.periodic else None)
    if args.channel is not None:
        options["channel"] = _channel(args.channel)
    if args.resample:
        options["resample"] = True
    return options


def _check_points_per_decade(args: argparse.Namespace) -> None:
    """``--points-per-decade`` by the rule of every log grid, named as the option."""
    try:
        check_points_per_decade(args.points_per_decade)
    except ValueError:
        raise CLIError(f"--points-per-decade {args.points_per_decade:g}: must be a positive "
                       f"number up to {MAX_POINTS_PER_DECADE}") from None


# -------------------------------------------------------------------- reading


def _reader_keywords(name: str) -> set[str] | None:
    """Keyword options the format's reader takes (``None``: any)."""
    try:
        module = reader_of(name)
        params = inspect.signature(module.read).parameters.values()
    except (ImportError, TypeError, ValueError):
        return None
    if any(p.kind == p.VAR_KEYWORD for p in params):
        return None
    return {p.name for p in params if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)}


def _refuse_foreign_options(path: str, name: str, options: dict) -> None:
    """``--channel`` or ``--resample`` for a format whose reader has no such option."""
    accepted = _reader_keywords(name)
    for key in ("channel", "resample"):
        if key in options and accepted is not None and key not in accepted:
            raise CLIError(f"{path}: --{key} does not apply to the {name} format"
                           + (" (it has one channel)" if key == "channel" else ""))


def _as_options(err: MissingOptionError) -> CLIError | None:
    """Name the reader's missing keywords as this command's options (None: it has none)."""
    flags = [f"--{o.replace('_', '-')}" for o in err.options if o in _FILE_OPTIONS]
    if not flags:
        return None
    return CLIError(f"{err.file}: {err.lacks}: give "
                    + (" or " if err.either else " and ").join(flags))


#: File arguments that name standard input.
STDIN = ("-", "/dev/stdin")


def _is_stream(path: str) -> bool:
    """Whether ``path`` is standard input or another pipe (not a file to reopen)."""
    if path in STDIN:
        return True
    try:
        mode = Path(path).stat().st_mode
    except OSError:
        return False
    return stat.S_ISFIFO(mode) or stat.S_ISCHR(mode)


@contextlib.contextmanager
def readable(path: str):
    """Give the file to read for the argument ``path``.

    Standard input (``-``, ``/dev/stdin``) and other pipes cannot be read twice (format
    detection reads the start of a file, the reader the whole of it): their bytes are
    copied to a temporary file named ``stdin`` (or the pipe's name), whose format is then
    detected from the content, and which is removed after use.
    """
    if not _is_stream(path):
        yield path
        return
    name = "stdin" if path in STDIN else Path(path).name
    with tempfile.TemporaryDirectory(prefix="xrough-") as folder:
        copy = Path(folder) / name
        with open(copy, "wb") as out:
            if path == "-":
                shutil.copyfileobj(sys.stdin.buffer, out)
            else:
                with open(path, "rb") as stream:
                    shutil.copyfileobj(stream, out)
        yield str(copy)


def open_file(path: str, args: argparse.Namespace) -> xr.DataArray:
    """Read a topography with the command's options.

    ``-`` (or ``/dev/stdin``) reads standard input (:func:`readable`). A file that lacks a
    unit, a size or resampling names the option to give.
    """
    options = _checked(args)
    with readable(path) as readable_path:
        name = args.format or detect_format(readable_path)
        _refuse_foreign_options(path, name, options)
        try:
            topo = open_measurement(readable_path, format=name, **options)
        except MissingOptionError as err:
            raise (_as_options(err) or err) from err
        return topo.load() if readable_path != path else topo


# ------------------------------------------------------------------ measuring


def detrend_as_asked(topo: xr.DataArray, mode: str) -> tuple[xr.DataArray, str]:
    """Detrend by ``mode`` (``auto``: a plane, which is a line for a profile).

    Returns the topography and what was removed, in the words of ``--detrend``: ``none``,
    ``mean``, ``plane`` (``line`` for a profile when ``auto`` chose it) or ``curvature``.
    """
    if mode == "none":
        return topo, "none"
    profile = "y" not in topo.dims
    label = ("line" if profile else "plane") if mode == "auto" else mode
    mode = "plane" if mode == "auto" else mode
    return detrend(topo, mode=mode), label


def _check_lags(path: str, topo: xr.DataArray, direction: str) -> None:
    """Refuse what the estimators cannot do, in the options' words."""
    if topo.attrs.get("sampling") == "non-uniform":
        raise CLIError(f"{path}: {NONUNIFORM}")
    if direction == "y" and "y" not in topo.dims:
        raise CLIError(f"{path}: --direction y: a profile has no 'y' direction; use "
                       "--direction 'x'")


def _measure(path: str, name: str, args: argparse.Namespace,
             analyse: Callable[[xr.DataArray], dict] | None = None) -> dict:
    """Open, detrend and compute G (and ``analyse(G)``) for one file; errors name it."""
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            topo = open_file(path, args)
            _check_lags(path, topo, args.direction)
            topo, how = detrend_as_asked(topo, args.detrend)
            G = topo.rough.acf(direction=args.direction,
                               points_per_decade=args.points_per_decade,
                               reliable=not args.all_lags)
            G.attrs.update(measurement=name, source_path=str(path))
            result = {"G": G, **(analyse(G) if analyse is not None else {})}
    except CLIError:
        raise
    except Exception as err:  # noqa: BLE001 - one line naming the file
        raise fail(path, err) from err
    # the map itself is not kept: a folder of large maps would hold them all until the
    # end (and send each back from a worker process)
    return {"file": str(path), "name": name, "detrend": how, "ndim": topo.ndim,
            "results": result, "warnings": warn_lines(path, caught)}


def expand_folders(paths: list[str]) -> list[str]:
    """Replace each folder in ``paths`` by its measurement files (files named stay as given).

    :func:`xrough.io.folders.measurement_files`: a reader's extension, or what a
    ``meta.yml`` lists.

    Raises
    ------
    CLIError
        A folder with no measurement file in it.
    """
    out: list[str] = []
    for path in paths:
        if not Path(path).is_dir():
            out.append(path)
            continue
        try:
            out.extend(str(p) for p in measurement_files(path))
        except ValueError as err:
            raise CLIError(str(err)) from err
    return out


def measure_all(args: argparse.Namespace, analyse=None, *,
                keep_going: bool = False) -> list[dict]:
    """:func:`_measure` each file of the command, with a progress bar on a terminal.

    With ``keep_going`` a file that fails is a record ``{"file", "name", "error"}`` (its
    one-line reason) and the others go on; without it the first failure stops the
    command. With more than one job (:func:`jobs`) the files are measured in worker
    processes; the records come back in the order of the files, the same as one by one.
    ``analyse`` must then be picklable (a module-level function or a
    :func:`functools.partial` of one).
    """
    _check_points_per_decade(args)
    work = list(zip(args.files, measurement_names(args.files)))
    n_jobs = jobs(args, work)
    if n_jobs > 1:
        return _measure_in_processes(work, args, analyse, keep_going, n_jobs)
    out = []
    for path, name in progress_bar(desc="G(dr)", iterable=work):
        out.append(_measure_or_record(path, name, args, analyse, keep_going))
    return out


def jobs(args: argparse.Namespace, work: list) -> int:
    """Return the worker processes for ``work`` (files).

    ``--jobs``, or for 0 (automatic) one per core this process may use from
    :data:`AUTO_JOBS_FILES` files on, when the command runs from the command line
    (``args.console``; a script calling :func:`xrough.cli.main` gets one process unless it
    asks: a worker process imports its ``__main__``). Never more than the files, and 1
    when a file is standard input (read once, by this process).
    """
    asked = getattr(args, "jobs", 1)
    if asked == 0:
        auto = getattr(args, "console", False) and len(work) >= AUTO_JOBS_FILES
        asked = cores() if auto else 1
    if any(_is_stream(path) for path, _ in work):
        return 1
    return max(1, min(asked, len(work), _MAX_WORKERS))


#: Windows waits on at most 61 worker processes (``ProcessPoolExecutor``'s limit).
_MAX_WORKERS = 61 if sys.platform == "win32" else 1 << 16


def jobs_option(text: str) -> int:
    """Parse ``--jobs``: a number of processes, 0 for automatic (argparse's ``type``)."""
    try:
        n = int(text)
    except ValueError:
        n = -1
    if n < 0:
        raise argparse.ArgumentTypeError(
            f"{text!r}: give the number of processes (0: one per core for "
            f"{AUTO_JOBS_FILES} files or more)")
    return n


def _measure_or_record(path: str, name: str, args: argparse.Namespace, analyse,
                       keep_going: bool) -> dict:
    try:
        return _measure(path, name, args, analyse)
    except CLIError as err:
        if not keep_going:
            raise
        return {"file": str(path), "name": name, "error": str(err)}


def _worker_start() -> None:
    """Set up a worker process: no bars, Ctrl-C left to the command.

    The command draws the one bar of the files, and ends the workers on Ctrl-C.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    draw_by_default(False)


@contextlib.contextmanager
def _sigint_ignored():
    """Ignore Ctrl-C in this (main) thread while worker processes start.

    They inherit it, so that one pressed during their imports prints no traceback from
    each; the command's own handler is back once they are started.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _measure_in_processes(work: list, args: argparse.Namespace, analyse, keep_going: bool,
                          n_jobs: int) -> list[dict]:
    """:func:`_measure_or_record` of each file in ``n_jobs`` fresh ("spawn") processes.

    As one by one: the records in the order of the files; without ``keep_going`` the
    first file that fails (in the order of the files) stops the command, the files after
    it are cancelled. A worker process that dies (killed, out of memory, a crash) breaks
    the pool: the files it had not returned are measured again, each alone in a worker
    of its own, and a file whose worker dies again is that file's failure, named, with
    ``--jobs 1`` as the way round. Fresh processes, not forks: a fork copies the threads'
    locks of this process (BLAS, HDF5) in whatever state they are. Ctrl-C ends the
    workers and the command.
    """
    out: list = [None] * len(work)
    stop = len(work)  # the first file that failed (keep_going: none stops)
    bar = progress_bar(desc="G(dr)", total=len(work))
    pool = _pool(n_jobs)
    try:
        with _sigint_ignored():
            futures = {pool.submit(_measure_or_record, path, name, args, analyse, True): k
                       for k, (path, name) in enumerate(work)}
        pending = set(futures)
        while pending and any(futures[f] < stop for f in pending):
            done, pending = concurrent.futures.wait(
                pending, return_when=concurrent.futures.FIRST_COMPLETED)
            for future in sorted(done, key=lambda f: futures[f]):
                k = futures[future]
                if future.cancelled():  # a file after one that failed
                    continue
                out[k] = _record(future)
                if out[k] is _BROKEN:
                    continue  # measured again below
                if bar is not None:
                    bar.update()
                if "error" in out[k] and not keep_going and k < stop:
                    stop = k
                    for later in pending:
                        if futures[later] > k:
                            later.cancel()
        pool.shutdown(wait=True)
        usable = False  # a pool a dead worker broke takes no more files
        # one worker, file after file: a file that kills its worker again is its failure
        for k in [k for k in range(len(work)) if out[k] is _BROKEN and k < stop]:
            if not usable:
                pool, usable = _pool(1), True
            path, name = work[k]
            with _sigint_ignored():  # the worker starts at the first submit
                future = pool.submit(_measure_or_record, path, name, args, analyse, True)
            out[k] = _record(future)
            if out[k] is _BROKEN:
                usable = False
                out[k] = {"file": str(path), "name": name, "error": (
                    f"{path}: the worker process measuring it ended abruptly (killed, out of "
                    "memory, or a crash in a library); run with --jobs 1")}
            if bar is not None:
                bar.update()
            if "error" in out[k] and not keep_going:
                stop = k
                break
    except BaseException:
        _end_workers(pool)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
        if bar is not None:
            bar.close()
    if stop < len(work):
        raise CLIError(out[stop]["error"])
    return out


#: The record of a file whose worker process died (:func:`_record`): measured again.
_BROKEN: dict = {"error": "the worker process ended abruptly"}


def _pool(n_jobs: int) -> concurrent.futures.ProcessPoolExecutor:
    return concurrent.futures.ProcessPoolExecutor(
        max_workers=n_jobs, mp_context=multiprocessing.get_context("spawn"),
        initializer=_worker_start)


def _record(future: concurrent.futures.Future) -> dict:
    """Return the record of one file's future; :data:`_BROKEN` where its worker died."""
    try:
        return future.result()
    except concurrent.futures.process.BrokenProcessPool:
        return _BROKEN


def _end_workers(pool: concurrent.futures.ProcessPoolExecutor) -> None:
    """Cancel what has not started and end the worker processes (Ctrl-C, an error)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())  # before shutdown
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
