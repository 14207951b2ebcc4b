"""Helpers shared by the instrument readers: error messages and channel selection."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

__all__ = ["fail", "select_channel"]


def fail(path: Path, message: str) -> ValueError:
    """Return (not raise) a ``ValueError`` whose message starts with the file's name.

    Examples
    --------
    >>> fail(Path("scan.spm"), "truncated file")
    ValueError('scan.spm: truncated file')
    """
    return ValueError(f"{path.name}: {message}")


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
