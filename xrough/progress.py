"""Progress bars of long operations (G of large maps, the solver, folders of files).

tqdm draws them; in a notebook its widget bars need ipywidgets, which xrough does not
require: without it the plain text bar is used (``tqdm.auto`` would warn "IProgress not
found" in every notebook instead). A bar can be interrupted like the loop it wraps.
"""

from __future__ import annotations

import contextlib
import functools
import importlib.util
from collections.abc import Iterable
from typing import Any

from tqdm.std import tqdm as plain_tqdm

__all__ = ["progress_bar", "dask_progress", "draw_by_default"]

#: Whether ``progress=None`` draws a bar in an interactive terminal (see
#: :func:`draw_by_default`).
_DRAW = {"default": True}


def draw_by_default(draw: bool) -> bool:
    """Set whether ``progress=None`` draws bars (in an interactive terminal); the previous.

    The command line's worker processes turn it off: they share the command's terminal,
    where their bars would overwrite the command's own (``--jobs``).

    Examples
    --------
    >>> previous = draw_by_default(False)
    >>> progress_bar(desc="tiles", total=3).disable
    True
    >>> draw_by_default(previous)
    False
    """
    previous = _DRAW["default"]
    _DRAW["default"] = bool(draw)
    return previous


def _disable(progress: bool | None) -> bool | None:
    """Return the ``disable`` of tqdm: None (draw in an interactive terminal only) or a bool."""
    if progress is None:
        return None if _DRAW["default"] else True
    return not progress


@functools.lru_cache(maxsize=1)
def _tqdm_class() -> Any:
    """``tqdm.auto.tqdm`` where ipywidgets is installed, else the plain ``tqdm.std.tqdm``."""
    if importlib.util.find_spec("ipywidgets") is None:
        return plain_tqdm
    from tqdm.auto import tqdm
    return tqdm


def progress_bar(*, desc: str, progress: bool | None = None, total: int | None = None,
                 iterable: Iterable | None = None, unit: str = "it") -> Any:
    """Return a tqdm bar, or None (or ``iterable`` itself) when ``progress`` is False.

    Parameters
    ----------
    desc : str
        What the bar counts.
    progress : bool or None
        True shows it, False gives no bar, None shows it in an interactive terminal only.
    total : int, optional
        Steps, where no ``iterable`` gives them.
    iterable : iterable, optional
        Wrapped by the bar (returned as is without one).
    unit : str
        The unit of a step.

    Examples
    --------
    >>> bar = progress_bar(desc="tiles", total=3, progress=False)
    >>> bar is None
    True
    >>> list(progress_bar(desc="files", iterable=range(2), progress=False))
    [0, 1]
    """
    if progress is False:
        return iterable
    return _tqdm_class()(iterable, total=total, desc=desc, unit=unit, leave=False,
                         disable=_disable(progress))


def dask_progress(*, desc: str, progress: bool | None = None) -> Any:
    """Return a context in which dask's local schedulers draw a bar of their tasks.

    tqdm's dask callback with the bar class of :func:`progress_bar`; a context doing
    nothing when ``progress`` is False. A distributed client shows its own dashboard.

    Examples
    --------
    >>> import dask
    >>> with dask_progress(desc="rows", progress=False):
    ...     dask.compute(dask.delayed(sum)([1, 2]))
    (3,)
    """
    if progress is False:
        return contextlib.nullcontext()
    from tqdm.dask import TqdmCallback  # imports tqdm.auto: at the first bar only
    return TqdmCallback(desc=desc, tqdm_class=_tqdm_class(), leave=False,
                        disable=_disable(progress))
