"""The ``.rough`` accessors: one line per method, each forwarding to a public function.

``DataArray.rough`` works on topographies and on G(dr), ``Dataset.rough`` on several
measurements in one Dataset and on result Datasets, ``DataTree.rough`` on several
instruments, one node each. Every method is the public function with the accessor's object
as its first argument: ``G.rough.persson(E_star=..., p0=...)`` is
``xrough.persson(G, E_star=..., p0=...)``, and ``help``, ``inspect.signature``, IPython's
``?`` and Sphinx show that function's signature (without the data argument) and docstring.

The accessors hold no state: everything a later step needs lives in coords and attrs, so
``topo.rough.acf().rough.plot()`` chains.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

import xarray as xr

from . import (
    contact,
    correlation,
    fitting,
    gradient,
    plot,
    preprocess,
    separation,
    solver,
    spectra,
    stitching,
    units,
    validation,
)
from .toolbox import bandwidth, cleaning, ensemble, filters, parameters, psd
from .topography import convert_units

__all__ = ["RoughDataArrayAccessor", "RoughDatasetAccessor", "RoughDataTreeAccessor"]

_POSITIONAL = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)


class _forward:
    """Accessor method that calls ``func(accessor._obj, *args, **kwargs)``.

    ``func`` takes pint-xarray quantified objects itself
    (:func:`xrough.units.accepts_quantified`), so ``quantified.rough.acf()`` works as on
    the CF ``units`` attributes.

    The class attribute is a plain function ``method(self, ...)`` whose signature is
    ``func``'s with its first (data) parameter renamed ``self``, so that the bound method
    ``obj.rough.name`` shows ``func``'s parameters after the data argument, and the
    unbound one reads like a method written out by hand (which is what Sphinx autodoc
    expects). ``__doc__`` is ``func``'s docstring, ``__wrapped__`` is ``func`` (IPython's
    ``??`` shows its source), and the name is the attribute's (``acf`` for
    :func:`xrough.height_difference_acf`).

    Parameters
    ----------
    func : callable
        A public function whose first parameter takes the DataArray, Dataset or DataTree
        positionally.

    Raises
    ------
    TypeError
        ``func`` has no first parameter that can be passed positionally.
    """

    def __init__(self, func: Callable[..., Any]) -> None:
        sig = inspect.signature(func)
        params = list(sig.parameters.values())
        if not params or params[0].kind not in _POSITIONAL:
            raise TypeError(f"{func.__qualname__}{sig} does not take its data argument "
                            "positionally; it cannot be an accessor method")
        data = params[0]

        def method(self, /, *args, **kwargs):
            return func(self._obj, *args, **kwargs)

        this = data.replace(name="self", annotation=inspect.Parameter.empty)
        attributes: Any = method  # __signature__ and __wrapped__: not typed on functions
        attributes.__signature__ = sig.replace(parameters=[this, *params[1:]])
        method.__doc__ = func.__doc__
        attributes.__wrapped__ = func
        method.__annotations__ = {k: v for k, v in getattr(func, "__annotations__", {}).items()
                                  if k != data.name}
        method.__name__ = method.__qualname__ = func.__name__
        self.method = method

    def __set_name__(self, owner: type, name: str) -> None:
        self.method.__name__ = name
        self.method.__qualname__ = f"{owner.__qualname__}.{name}"

    def __get__(self, instance: Any, owner: type | None = None) -> Callable[..., Any]:
        return self.method.__get__(instance, owner)


@xr.register_dataarray_accessor("rough")
class RoughDataArrayAccessor:
    """``DataArray.rough``: roughness and contact-mechanics steps on topographies and G.

    Parameters
    ----------
    obj : xarray.DataArray
        A topography (dims ``y, x`` or ``x``) or a result on ``dr`` (G) or ``q``.
    """

    def __init__(self, obj: xr.DataArray) -> None:
        self._obj = obj

    acf = _forward(correlation.height_difference_acf)
    convert_units = _forward(convert_units)
    detrend = _forward(preprocess.detrend)
    fit_trend = _forward(preprocess.fit_trend)
    mask_outliers = _forward(preprocess.mask_outliers)
    fill_missing = _forward(preprocess.fill_missing)
    cleaning_sensitivity = _forward(cleaning.cleaning_sensitivity)
    reliable = _forward(preprocess.reliable)
    reliability_window = _forward(preprocess.reliability_window)
    solve_contact = _forward(solver.solve_contact)
    compare_with_simulation = _forward(validation.compare_with_simulation)
    spectrum = _forward(spectra.spectrum)
    psd_2d = _forward(psd.power_spectrum_2d)
    psd = _forward(psd.power_spectrum)
    fit = _forward(fitting.fit_acf)
    energy = _forward(contact.elastic_energy)
    gradient = _forward(gradient.rms_gradient)
    stress_acf = _forward(contact.stress_acf)
    persson = _forward(contact.persson)
    mean_gap = _forward(separation.mean_gap)
    patch_radius = _forward(contact.patch_radius)
    height_distribution = _forward(parameters.height_distribution)
    slope_distribution = _forward(parameters.slope_distribution)
    curvature_distribution = _forward(parameters.curvature_distribution)
    bearing_area_curve = _forward(parameters.bearing_area_curve)
    material_ratio = _forward(parameters.material_ratio)
    scale_dependent_slope = _forward(parameters.scale_dependent_slope)
    scale_dependent_curvature = _forward(parameters.scale_dependent_curvature)
    scale_dependent_statistic = _forward(parameters.scale_dependent_statistic)
    tip_check = _forward(parameters.tip_check)
    variable_bandwidth = _forward(bandwidth.variable_bandwidth)
    fourier_filter = _forward(filters.fourier_filter)
    shortcut = _forward(filters.shortcut)
    longcut = _forward(filters.longcut)
    parameters = _forward(parameters.roughness_parameters)  # last: it hides the module
    plot = _forward(plot.plot)
    sel = _forward(units.sel)
    mean = _forward(ensemble.mean_acf)


@xr.register_dataset_accessor("rough")
class RoughDatasetAccessor:
    """``Dataset.rough``: stitching several measurements, plots of result Datasets.

    Parameters
    ----------
    obj : xarray.Dataset
        Measurements as data variables (on shared dims), the curves of
        :func:`xrough.stitch_curves`, or a result Dataset (Persson theory, energy, ...).
    """

    def __init__(self, obj: xr.Dataset) -> None:
        self._obj = obj

    acf = _forward(stitching.stitch)
    stitch_curves = _forward(stitching.stitch_curves)
    plot = _forward(plot.plot_dataset)
    sel = _forward(units.sel)


class RoughDataTreeAccessor:
    """``DataTree.rough``: one G(dr) from several instruments, one node each.

    Every data variable of the tree is a measurement (a topography on its own grid and
    in its own units, or a precomputed G), named by its path.

    Registered with xarray versions that have :class:`xarray.DataTree` (2024.10 on).

    Parameters
    ----------
    obj : xarray.DataTree
        The measurements.

    Examples
    --------
    >>> import xarray as xr, xrough
    >>> topo = xrough.self_affine_surface(hurst=0.7, lambda_r="2 um", lambda_s="20 nm",
    ...                                   size="8 um", n=1024, rms_height="10 nm",
    ...                                   profile=True, seed=3, unit="nm")
    >>> tree = xr.DataTree.from_dict({
    ...     "afm": topo.isel(x=slice(0, 256)).assign_attrs(periodic=0).to_dataset(name="h"),
    ...     "stylus": topo.isel(x=slice(None, None, 4)).to_dataset(name="h")})
    >>> G = tree.rough.acf(points_per_decade=5)
    >>> G.attrs["stitched_from"]
    'afm, stylus'
    >>> ax = tree.rough.plot(points_per_decade=5)
    >>> [t.get_text() for t in ax.get_legend().get_texts()]
    ['afm', 'stylus', 'stitched']
    """

    def __init__(self, obj: xr.DataTree) -> None:
        self._obj = obj

    acf = _forward(stitching.stitch)
    stitch_curves = _forward(stitching.stitch_curves)
    plot = _forward(plot.plot_stitched)


xr.register_datatree_accessor("rough")(RoughDataTreeAccessor)
