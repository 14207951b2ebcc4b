"""Results computed once per content: a chain never fits the same G twice.

A user's chain calls the same costly step more than once without knowing it:
``G.rough.fit()`` and then ``G.rough.persson(...)``, which needs that fit of G for its
quick stress estimate, its small-pressure asymptotes and the lags where G does not
determine the rms gradient. :func:`by_content` makes such a step answer a repeated call at
once: the key is dask's token of the arguments, which hashes the data, coords and attrs of
an xarray object (and names a dask array by its graph), so an equal G with equal options
gets the same result whichever object holds it, and a G that differs in a single value, a
unit or an attribute does not.

What a hit hands out is what the computation returned: a deep copy of it (changing it does
not change the next answer), with the same :class:`xrough.QualityWarning` issued again at
the caller's line. ``cache_clear()`` empties a function's cache, ``cache_info()`` counts,
:func:`forget` empties them all.

What is kept, and for how long: at most ``maxsize`` results per function (32; the least
recently used goes first), each a small result of G (a fit, a curve on G's lags), for the
life of the process. :func:`disabled` (a block) or :func:`set_enabled` (the process) turn
the keeping off: every call computes, nothing is kept, the results are the same. The
explicit way to hand a step's result on is the argument (``persson(G, fit=fit,
gradient=gbar)``); the memo only spares a chain that does not.
"""

from __future__ import annotations

import contextlib
import functools
import inspect
import threading
from collections import OrderedDict
from collections.abc import Callable, Iterator
from typing import Any, Generic, ParamSpec, Protocol, TypeVar, cast

import xarray as xr

from . import quality
from ._kernels.deferred import dask_base

__all__ = ["by_content", "forget", "disabled", "set_enabled"]

#: ``cache_clear`` of every function decorated in this session.
_CLEARS: list[Callable[[], None]] = []
#: Whether results are kept (:func:`set_enabled`), for every thread of the process.
_STATE = {"enabled": True}

_P = ParamSpec("_P")
_R = TypeVar("_R")


class _Memoized(Protocol, Generic[_P, _R]):
    """A function decorated by :func:`by_content`: the function, with its cache's methods."""

    __wrapped__: Callable[_P, _R]
    #: A copy of the kept result of an equal call, or None (nothing computed or warned).
    peek: Callable[_P, _R | None]
    #: Forget the kept results.
    cache_clear: Callable[[], None]
    #: ``hits``, ``misses`` and ``size``.
    cache_info: Callable[[], dict[str, int]]

    def __call__(self, *args: _P.args, **kwargs: _P.kwargs) -> _R: ...


def _unflagged(value: Any) -> Any:
    """Return ``value`` without its rating (``quality_flag``, its reasons), for the key.

    G's verdict is a function of its data, and :func:`xrough.acf.read_acf` drops it: it
    does not make another G.
    """
    if isinstance(value, (xr.DataArray, xr.Dataset)):
        return quality.unrated(value)
    return value


def _copy(result: Any) -> Any:
    """Copy an xarray result deeply (each of a tuple of them)."""
    if isinstance(result, tuple):
        return tuple(_copy(part) for part in result)
    return result.copy(deep=True) if hasattr(result, "copy") else result


def _again(kept: tuple[Any, list]) -> Any:
    """Hand out a kept result again: a copy, with what it warned said again."""
    result, said = kept
    for message, category in said:
        quality.warn(message, category)
    return _copy(result)


def by_content(maxsize: int = 32) -> Callable[[Callable[_P, _R]], _Memoized[_P, _R]]:
    """Decorate a pure function of xarray objects: equal arguments, one computation.

    The function returns an xarray object (or a tuple of them); its arguments are what
    :func:`dask.base.tokenize` hashes by value (xarray and numpy objects, numbers,
    strings, pint Quantities, dicts and tuples of these).

    Parameters
    ----------
    maxsize : int
        Results kept (the least recently used goes first).

    Returns
    -------
    callable
        A decorator. An equal call is one with equal arguments once the defaults are
        filled in. The decorated function has ``peek(*args, **kwargs)`` (a copy of the
        kept result of an equal call, or None; nothing is computed or warned),
        ``cache_clear()`` and
        ``cache_info()`` (a dict of ``hits``, ``misses``, ``size``); its signature and
        docstring are those of the function (``__wrapped__``).

    Examples
    --------
    >>> calls = []
    >>> @by_content()
    ... def double(x):
    ...     calls.append(x)
    ...     return xr.DataArray(2 * x)
    >>> import xarray as xr
    >>> a, b = double(xr.DataArray(1.0)), double(xr.DataArray(1.0))  # equal, not the same
    >>> len(calls), float(b), double.cache_info()["hits"]
    (1, 2.0, 1)
    """
    def decorate(func: Callable[_P, _R]) -> _Memoized[_P, _R]:
        cache: OrderedDict[str, tuple[Any, list]] = OrderedDict()
        lock = threading.Lock()
        counts = {"hits": 0, "misses": 0}

        signature = inspect.signature(func)

        def key_of(args, kwargs) -> str:  # f(G) and f(G, model="spectrum") are one call
            bound = signature.bind(*args, **kwargs)
            bound.apply_defaults()
            return dask_base.tokenize(func.__module__, func.__qualname__,
                            {k: _unflagged(v) for k, v in bound.arguments.items()})

        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            if not _STATE["enabled"]:
                return func(*args, **kwargs)
            try:
                key = key_of(args, kwargs)
            except Exception:  # noqa: BLE001  (unhashable arguments: computed, not kept)
                return func(*args, **kwargs)
            with lock:
                hit = cache.get(key)
                if hit is not None:
                    cache.move_to_end(key)
                    counts["hits"] += 1
                else:
                    counts["misses"] += 1
            if hit is not None:
                return _again(hit)
            with quality.recorded() as said:
                result = func(*args, **kwargs)
            with lock:
                cache[key] = (_copy(result), list(said))
                while len(cache) > maxsize:
                    cache.popitem(last=False)
            return result

        def peek(*args, **kwargs):
            """Return the kept result of an equal call (a copy; nothing said), or None."""
            if not _STATE["enabled"]:
                return None
            try:
                key = key_of(args, kwargs)
            except Exception:  # noqa: BLE001
                return None
            with lock:
                hit = cache.get(key)
            return None if hit is None else _copy(hit[0])

        def cache_clear() -> None:
            with lock:
                cache.clear()
                counts.update(hits=0, misses=0)

        def cache_info() -> dict:
            with lock:
                return {**counts, "size": len(cache)}

        _CLEARS.append(cache_clear)
        memoized = cast("_Memoized[_P, _R]", wrapper)  # functools.wraps: func's signature
        memoized.peek = peek
        memoized.cache_clear = cache_clear
        memoized.cache_info = cache_info
        return memoized
    return decorate


def forget() -> None:
    """Forget every result kept by :func:`by_content` (e.g. to time a first run).

    Examples
    --------
    >>> forget()
    >>> xrough.fit_acf.cache_info()["size"]
    0
    """
    for clear in _CLEARS:
        clear()


def set_enabled(enabled: bool) -> bool:
    """Turn the keeping of results on or off for the whole process; the previous state.

    Off, every decorated function computes at each call and keeps nothing (what is kept
    already stays, unused until it is turned on again; :func:`forget` empties it).

    Examples
    --------
    >>> previous = set_enabled(False)
    >>> previous, set_enabled(previous)
    (True, False)
    """
    previous = _STATE["enabled"]
    _STATE["enabled"] = bool(enabled)
    return previous


@contextlib.contextmanager
def disabled() -> Iterator[None]:
    """Compute every call inside the block afresh, keeping nothing (:func:`set_enabled`).

    Examples
    --------
    >>> import xrough
    >>> with disabled():
    ...     pass  # e.g. time a first run, or check a result does not come from the memo
    """
    previous = set_enabled(False)
    try:
        yield
    finally:
        set_enabled(previous)
