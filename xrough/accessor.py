"""The ``.rough`` accessor: one line per method, each forwarding to a public function.

The accessor holds no state: everything a later step needs lives in coords and attrs, so
``topo.rough.acf().rough.plot()`` chains.
"""

from __future__ import annotations

import xarray as xr

from . import (
    contact,
    correlation,
    fitting,
    gradient,
    plot,
    preprocess,
    solver,
    spectra,
    stitching,
    validation,
)

__all__ = ["RoughDataArrayAccessor", "RoughDatasetAccessor"]


@xr.register_dataarray_accessor("rough")
class RoughDataArrayAccessor:
    """``DataArray.rough``: roughness and contact-mechanics steps on topographies and G."""

    def __init__(self, obj: xr.DataArray) -> None:
        self._obj = obj

    def acf(self, **kwargs) -> xr.DataArray:
        """G(dr) of a topography; see :func:`xrough.height_difference_acf`."""
        return correlation.height_difference_acf(self._obj, **kwargs)

    def detrend(self, **kwargs) -> xr.DataArray:
        """Remove a mean, plane or quadratic trend; see :func:`xrough.detrend`."""
        return preprocess.detrend(self._obj, **kwargs)

    def fit_trend(self, **kwargs) -> xr.Dataset:
        """Coefficients of the least-squares trend; see :func:`xrough.fit_trend`."""
        return preprocess.fit_trend(self._obj, **kwargs)

    def mask_outliers(self, **kwargs) -> xr.DataArray:
        """Spikes and dimples to NaN; see :func:`xrough.mask_outliers`."""
        return preprocess.mask_outliers(self._obj, **kwargs)

    def reliable(self, **kwargs) -> xr.DataArray:
        """Record the reliable lag range; see :func:`xrough.reliable`."""
        return preprocess.reliable(self._obj, **kwargs)

    def reliability_window(self) -> tuple:
        """Reliable (dr_min, dr_max); see :func:`xrough.reliability_window`."""
        return preprocess.reliability_window(self._obj)

    def solve_contact(self, **kwargs) -> xr.Dataset:
        """Boundary-element contact solution; see :func:`xrough.solve_contact`."""
        return solver.solve_contact(self._obj, **kwargs)

    def validate(self, **kwargs) -> xr.Dataset:
        """Theories against the contact solver; see :func:`xrough.compare_with_simulation`."""
        return validation.compare_with_simulation(self._obj, **kwargs)

    def spectrum(self, **kwargs) -> xr.DataArray:
        """Spectrum C(q) from G (eq. 10/11); see :func:`xrough.spectrum`."""
        return spectra.spectrum(self._obj, **kwargs)

    def fit(self, **kwargs) -> xr.Dataset:
        """Fit G (eq. 36 or the model spectrum); see :func:`xrough.fit_acf`."""
        return fitting.fit_acf(self._obj, **kwargs)

    def energy(self, **kwargs) -> xr.Dataset:
        """Elastic energy of full contact (eq. 16, 44); see :func:`xrough.elastic_energy`."""
        return contact.elastic_energy(self._obj, **kwargs)

    def gradient(self, **kwargs) -> xr.DataArray:
        """Scale-dependent rms gradient (eq. 26); see :func:`xrough.rms_gradient`."""
        return gradient.rms_gradient(self._obj, **kwargs)

    def stress_acf(self, **kwargs) -> xr.DataArray:
        """Stress ACF (eq. 24, 30/48); see :func:`xrough.stress_acf`."""
        return contact.stress_acf(self._obj, **kwargs)

    def persson(self, **kwargs) -> xr.Dataset:
        """Real-space Persson theory (eq. 29-50); see :func:`xrough.persson`."""
        return contact.persson(self._obj, **kwargs)

    def patch_radius(self, **kwargs) -> xr.Dataset:
        """Adhesive patch radius (eq. 44, 46); see :func:`xrough.patch_radius`."""
        return contact.patch_radius(self._obj, **kwargs)

    def plot(self, **kwargs):
        """Plot a topography or a correlation function; see :func:`xrough.plot.plot`."""
        return plot.plot(self._obj, **kwargs)


@xr.register_dataset_accessor("rough")
class RoughDatasetAccessor:
    """``Dataset.rough``: stitching several measurements, plots of result Datasets."""

    def __init__(self, obj: xr.Dataset) -> None:
        self._obj = obj

    def acf(self, **kwargs) -> xr.DataArray:
        """One G(dr) stitched from the measurements; see :func:`xrough.stitch`."""
        return stitching.stitch(self._obj, **kwargs)

    def stitch_curves(self, **kwargs) -> xr.Dataset:
        """Each measurement's G on the common grid; see :func:`xrough.stitch_curves`."""
        return stitching.stitch_curves(self._obj, **kwargs)

    def plot(self, **kwargs):
        """One panel per variable; see :func:`xrough.plot.plot_dataset`."""
        return plot.plot_dataset(self._obj, **kwargs)
