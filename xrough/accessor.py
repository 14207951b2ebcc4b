"""The ``.rough`` accessor: one line per method, each forwarding to a public function.

The accessor holds no state: everything a later step needs lives in coords and attrs, so
``topo.rough.acf().rough.plot()`` chains.
"""

from __future__ import annotations

import xarray as xr

from . import correlation, plot

__all__ = ["RoughDataArrayAccessor"]


@xr.register_dataarray_accessor("rough")
class RoughDataArrayAccessor:
    """``DataArray.rough``: roughness and contact-mechanics steps on topographies and G."""

    def __init__(self, obj: xr.DataArray) -> None:
        self._obj = obj

    def acf(self, **kwargs) -> xr.DataArray:
        """G(dr) of a topography; see :func:`xrough.height_difference_acf`."""
        return correlation.height_difference_acf(self._obj, **kwargs)

    def plot(self, **kwargs):
        """Plot a topography or a correlation function; see :func:`xrough.plot.plot`."""
        return plot.plot(self._obj, **kwargs)
