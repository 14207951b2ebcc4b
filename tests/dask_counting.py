"""Counting what dask computes, for the tests of laziness (one definition for all tests).

- :class:`CountingScheduler`: a dask scheduler that counts the graphs it is asked to run;
- :func:`counting`: a context in which every compute goes through a new counter;
- :func:`computes_nothing`: a context that fails if anything inside it computes (building
  a graph must not compute);
- :class:`CountingArray`: an array whose every read of a (non-empty) block is counted.
"""

from __future__ import annotations

import threading
from contextlib import contextmanager

import dask
import dask.threaded


class CountingScheduler:
    """A dask scheduler (threads) that counts the graphs it is asked to run.

    ``with dask.config.set(scheduler=counter)``, every ``compute``, ``.values`` or
    ``np.asarray`` of a dask-backed object goes through :meth:`__call__`.
    """

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self, dsk, keys, **kwargs):
        self.calls += 1
        return dask.threaded.get(dsk, keys, **kwargs)


@contextmanager
def counting(counter: CountingScheduler | None = None):
    """Run the block with ``counter`` (a new :class:`CountingScheduler` by default) as the
    dask scheduler; yields the counter."""
    counter = CountingScheduler() if counter is None else counter
    with dask.config.set(scheduler=counter):
        yield counter


@contextmanager
def computes_nothing():
    """Fail if a graph is computed inside the block (e.g. while a lazy result is built)."""
    with counting() as counter:
        yield counter
    assert counter.calls == 0, f"{counter.calls} graph(s) computed while building"


class CountingArray:
    """A 2D array whose every read of a (non-empty) block is counted, by block.

    ``dask.array.from_array(CountingArray(h), chunks=...)``: ``reads`` maps each block
    ``((y0, y1), (x0, x1))`` to how often it was read.
    """

    def __init__(self, h) -> None:
        self.h, self.shape, self.dtype, self.ndim = h, h.shape, h.dtype, h.ndim
        self.reads: dict = {}
        self._lock = threading.Lock()

    def __getitem__(self, key):
        out = self.h[key]
        if out.size:
            with self._lock:
                block = tuple((k.start, k.stop) for k in key)
                self.reads[block] = self.reads.get(block, 0) + 1
        return out
