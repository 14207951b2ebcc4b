"""The heavy dependencies, each imported at its first use.

``import xrough`` costs little more than ``import xarray``: scipy's subpackages, dask,
pint and the cf-xarray unit registry take several times xarray's import between them, and
a session that opens one file uses a few of them. Every module of the package takes them
from here, by the name it would have imported (``from xrough._kernels.deferred import
optimize``; ``optimize.least_squares(...)``): the import runs on the first attribute read,
through :func:`importlib.import_module`, which holds the import lock, so that dask's
threads may be first (the standard library's ``importlib.util.LazyLoader``, on which
lazy-loading packages build, is not thread-safe before Python 3.12).

The names below are the modules themselves for a type checker.
"""

from __future__ import annotations

import importlib
import sys
from typing import TYPE_CHECKING, Any


class Deferred:
    """A module, or one attribute of a module, imported when first read from.

    Parameters
    ----------
    module : str
        The module's full name (``"scipy.optimize"``).
    attribute : str, optional
        An attribute of the module to stand for instead (``"units"`` of
        ``cf_xarray.units``: its unit registry).

    Examples
    --------
    >>> special = Deferred("scipy.special")
    >>> float(special.gamma(5.0))
    24.0
    """

    __slots__ = ("_attribute", "_module", "_target")

    def __init__(self, module: str, attribute: str | None = None) -> None:
        self._module = module
        self._attribute = attribute
        self._target: Any = None

    def _load(self) -> Any:
        if self._target is None:
            module = importlib.import_module(self._module)
            self._target = module if self._attribute is None else getattr(module,
                                                                           self._attribute)
        return self._target

    def __getattr__(self, name: str) -> Any:
        return getattr(self._load(), name)

    def __repr__(self) -> str:
        what = self._module + ("" if self._attribute is None else f".{self._attribute}")
        state = "imported" if self._target is not None else "not imported yet"
        return f"<deferred {what} ({state})>"


def load(deferred: Any) -> Any:
    """Return the object a :class:`Deferred` stands for (anything else as it is)."""
    return deferred._load() if isinstance(deferred, Deferred) else deferred  # noqa: SLF001


if TYPE_CHECKING:
    import cf_xarray.units as cf_units
    import dask
    import dask.array as dask_array
    import dask.array.core as dask_array_core
    import dask.base as dask_base
    import dask.diagnostics as dask_diagnostics
    import dask.utils as dask_utils
    import pint
    from scipy import fft, integrate, interpolate, ndimage, optimize, sparse, spatial, special
    from scipy.sparse import linalg as sparse_linalg
else:
    cf_units = Deferred("cf_xarray.units")
    dask = Deferred("dask")
    dask_array = Deferred("dask.array")
    dask_array_core = Deferred("dask.array.core")
    dask_base = Deferred("dask.base")
    dask_diagnostics = Deferred("dask.diagnostics")
    dask_utils = Deferred("dask.utils")
    pint = Deferred("pint")
    fft = Deferred("scipy.fft")
    integrate = Deferred("scipy.integrate")
    interpolate = Deferred("scipy.interpolate")
    ndimage = Deferred("scipy.ndimage")
    optimize = Deferred("scipy.optimize")
    sparse = Deferred("scipy.sparse")
    sparse_linalg = Deferred("scipy.sparse.linalg")
    spatial = Deferred("scipy.spatial")
    special = Deferred("scipy.special")


def is_dask_array(x: Any) -> bool:
    """Whether ``x`` is a dask array, without importing dask where none can exist yet."""
    return "dask.array" in sys.modules and isinstance(x, dask_array.Array)
