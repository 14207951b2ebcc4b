"""Helpers shared by the instrument readers: error messages and channel selection."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

__all__ = ["fail", "naming", "select_channel"]


def fail(path: Path, message: str) -> ValueError:
    """Return (not raise) a ``ValueError`` whose message starts with the file's name.

    Examples
    --------
    >>> fail(Path("scan.spm"), "truncated file")
    ValueError('scan.spm: truncated file')
    """
    return ValueError(f"{path.name}: {message}")


@contextmanager
def naming(path: Path) -> Iterator[None]:
    """Make every ``ValueError`` raised inside the block name the file.

    Errors from shared helpers (a topography with one point, a unit pint does not know)
    do not know which file they are about; the reader adds its name in front.

    Examples
    --------
    >>> try:
    ...     with naming(Path("scan.txt")):
    ...         raise ValueError("coordinate 'x' needs at least 2 points")
    ... except ValueError as err:
    ...     print(err)
    scan.txt: coordinate 'x' needs at least 2 points
    """
    try:
        yield
    except UnicodeError as err:
        raise fail(path, f"cannot decode the text ({err})") from err
    except ValueError as err:
        if str(err).startswith(f"{path.name}:"):
            raise
        raise fail(path, str(err)) from err


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
