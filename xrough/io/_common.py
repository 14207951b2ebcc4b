"""Helpers shared by the instrument readers: errors that name the file, size limits, channels."""

from __future__ import annotations

import contextlib
import struct
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path
from xml.etree import ElementTree

import numpy as np

__all__ = ["fail", "reader_errors", "check_file", "check_points", "MAX_POINTS",
           "select_channel"]

#: Largest number of points a reader of this package's native formats (X3P, SUR, SDF)
#: accepts unless the caller passes ``max_points=``: a larger header is taken as corrupted.
MAX_POINTS = 2**31

#: Third-party exceptions and what they mean in a file reader, in words.
_ERROR_WORDS = (
    (UnicodeError, "text that is not validly encoded"),
    (ElementTree.ParseError, "malformed XML"),
    (zlib.error, "corrupted compressed data"),
    (zipfile.BadZipFile, "a corrupted zip archive"),
    (struct.error, "a truncated or corrupted binary structure"),
    (EOFError, "data that ends too early (truncated file)"),
    (ZeroDivisionError, "a zero size or spacing"),
    (OverflowError, "a number out of range"),
    (MemoryError, "sizes too large for memory"),
    (RecursionError, "structures nested too deeply"),
    (KeyError, "a missing entry"),
    (IndexError, "a missing entry"),
)



def fail(path: Path, message: str) -> ValueError:
    """Return (not raise) a ``ValueError`` whose message starts with the file's name.

    Examples
    --------
    >>> fail(Path("scan.spm"), "truncated file")
    ValueError('scan.spm: truncated file')
    """
    return ValueError(f"{path.name}: {message}")


def check_file(path: Path) -> None:
    """Raise ``FileNotFoundError`` or ``IsADirectoryError`` unless ``path`` is a file.

    Examples
    --------
    >>> check_file(Path("no-such-file.x3p"))
    Traceback (most recent call last):
    ...
    FileNotFoundError: no such file: no-such-file.x3p
    """
    if path.is_dir():
        raise IsADirectoryError(f"{path.name}: is a directory, not a file")
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")


def check_points(path: Path, n: int, max_points: int | None, what: str) -> None:
    """Refuse a header that declares more than ``max_points`` points.

    Parameters
    ----------
    path : Path
        The file, named in the message.
    n : int
        The number of points the header declares.
    max_points : int or None
        The limit (``None``: :data:`MAX_POINTS`).
    what : str
        What declares them, for the message.

    Raises
    ------
    ValueError
        ``n > max_points``.

    Examples
    --------
    >>> check_points(Path("a.sur"), 10, 100, "the header")
    >>> check_points(Path("a.sur"), 60000 * 60000, None, "the header")
    Traceback (most recent call last):
    ...
    ValueError: a.sur: the header declares 3600000000 points, more than ...
    """
    limit = MAX_POINTS if max_points is None else int(max_points)
    if n > limit:
        raise ValueError(f"{path.name}: {what} declares {n} points, more than the limit of "
                         f"{limit} (a corrupted header? pass max_points= to read a larger "
                         "file)")


@contextlib.contextmanager
def reader_errors(path: Path, description: str):
    """Turn every error raised inside the block into a ``ValueError`` naming the file.

    ``FileNotFoundError`` and ``IsADirectoryError`` pass unchanged, a ``ValueError``
    that already starts with the file's name too; other errors of a reader choking on a
    corrupted file (``zlib.error``, ``struct.error``, ``UnicodeDecodeError``, XML errors,
    ``ZeroDivisionError``, ``OverflowError``, ``MemoryError``...) are re-raised as
    ``ValueError("<file>: cannot read as <description>: <what is wrong>")``.

    Parameters
    ----------
    path : Path
        The file.
    description : str
        The format, for the message.

    Examples
    --------
    >>> with reader_errors(Path("scan.sur"), "Digital Surf SUR"):
    ...     1 / 0
    Traceback (most recent call last):
    ...
    ValueError: scan.sur: cannot read as Digital Surf SUR: a zero size or spacing ...
    """
    prefix = f"{path.name}:"
    try:
        yield
    except (FileNotFoundError, IsADirectoryError):
        raise
    except Exception as err:  # noqa: BLE001 - a corrupted file fails in many ways
        if isinstance(err, ValueError) and not isinstance(err, UnicodeError):
            if str(err).startswith(prefix):
                raise
            raise ValueError(f"{prefix} {err}") from err
        words = next((w for kind, w in _ERROR_WORDS if isinstance(err, kind)),
                     "a corrupted file")
        raise ValueError(f"{prefix} cannot read as {description}: {words} "
                         f"({type(err).__name__}: {err})") from err


def select_channel(path: Path, channels: list[dict], channel, *,
                   default: Callable[[str], dict], describe: Callable[[dict], str]) -> dict:
    """Pick a channel by name (case-insensitive) or position in ``channels``.

    Parameters
    ----------
    path : Path
        The file, named in error messages.
    channels : list of dict
        The file's channels, each with a ``name``.
    channel : str, int or None
        The user's choice; ``None`` returns ``default(listing)``.
    default : callable
        Called with the listing of the channels (``describe`` of each, ``"; "``-joined)
        when ``channel`` is ``None``; returns a channel or raises.
    describe : callable
        One channel as text for the listing in error messages.

    Raises
    ------
    ValueError
        An index out of range, an unknown name (the message lists the channels), or
        ``channel`` neither a name nor an index.

    Examples
    --------
    >>> chans = [{"name": "Height"}, {"name": "Phase"}]
    >>> select_channel(Path("a.spm"), chans, "phase", default=None, describe=str)
    {'name': 'Phase'}
    >>> select_channel(Path("a.spm"), chans, -2, default=None, describe=str)
    {'name': 'Height'}
    """
    listing = "; ".join(describe(c) for c in channels) or "none"
    if channel is None:
        return default(listing)
    if isinstance(channel, (int, np.integer)) and not isinstance(channel, bool):
        if not -len(channels) <= channel < len(channels):
            raise fail(path, f"channel index {channel} out of range; channels: {listing}")
        return channels[channel]
    if isinstance(channel, str):
        for c in channels:
            if c["name"].lower() == channel.strip().lower():
                return c
        raise fail(path, f"no channel named {channel!r}; channels: {listing}")
    raise fail(path, f"channel must be a name (str) or an index (int), got {channel!r}; "
                     f"channels: {listing}")
