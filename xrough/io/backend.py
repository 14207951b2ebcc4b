"""xarray backend: ``xr.open_dataset(path, engine="xrough")`` for every format xrough reads.

The backend calls :func:`xrough.io.open_topography` and returns a Dataset with the
topography as variable ``height`` (its attrs: units, the file's metadata, provenance) and
the provenance (``source_file``, ``source_sha256``, ``format``, ``overrides``) also in the
Dataset's attrs. Keyword arguments of :func:`xarray.open_dataset` that xarray does not use
itself are passed on: the overrides ``format``, ``size``, ``unit``, ``height_unit``,
``height_scale``, ``periodic`` and the readers' options (``channel``, ``resample``,
``spacing``, ``variable``...).

The engine is registered as the ``xarray.backends`` entry point ``xrough``; before the
package is installed with it, pass the class itself::

    xr.open_dataset(path, engine=XroughBackendEntrypoint)
"""

from __future__ import annotations

import os
from pathlib import Path

import xarray as xr
from xarray.backends import BackendEntrypoint

from . import detect_format, open_topography

__all__ = ["XroughBackendEntrypoint"]

_PROVENANCE = ("source_file", "source_sha256", "format", "overrides")


def _as_path(filename_or_obj) -> Path | None:
    try:
        return Path(os.fspath(filename_or_obj))
    except TypeError:
        return None


class XroughBackendEntrypoint(BackendEntrypoint):
    """Open topography files (instrument formats, text, NumPy, NetCDF) with xarray.

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np, xarray as xr
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = pathlib.Path(tmp) / "h.npy"
    ...     np.save(path, np.zeros((4, 8)))
    ...     ds = xr.open_dataset(path, engine=XroughBackendEntrypoint, size="8 um",
    ...                          height_unit="nm")
    >>> ds["height"].dims, ds["height"].attrs["units"], ds.attrs["format"]
    (('y', 'x'), 'nm', 'npy')
    """

    description = ("Surface topographies from instrument, text, NumPy and NetCDF files, "
                   "with units, via xrough.io.open_topography")
    url = "https://github.com/xrough/xrough/tree/main/docs"
    open_dataset_parameters = (
        "filename_or_obj", "drop_variables", "format", "size", "unit", "height_unit",
        "height_scale", "periodic", "channel", "resample", "spacing", "variable", "group",
        "layout", "column", "encoding", "index",
    )

    def open_dataset(self, filename_or_obj, *, drop_variables=None, format=None, size=None,
                     unit=None, height_unit=None, height_scale=None, periodic=None,
                     **options) -> xr.Dataset:
        """Read a topography file into a Dataset with the variable ``height``.

        Parameters
        ----------
        filename_or_obj : str or os.PathLike
            The file (file objects are not supported: formats are detected and provenance
            hashed from the file itself).
        drop_variables : str or iterable of str, optional
            Variables to leave out (``"height"`` leaves only the coordinates).
        format, size, unit, height_unit, height_scale, periodic
            As in :func:`xrough.io.open_topography`.
        **options
            The format reader's options (``channel=``, ``resample=``, ``spacing=``...);
            options left at None are not passed.

        Returns
        -------
        xarray.Dataset
        """
        path = _as_path(filename_or_obj)
        if path is None:
            raise TypeError("the xrough engine reads files by path (str or os.PathLike), got "
                            f"{type(filename_or_obj).__name__}")
        options = {k: v for k, v in options.items() if v is not None}
        da = open_topography(path, format=format, size=size, unit=unit,
                             height_unit=height_unit, height_scale=height_scale,
                             periodic=periodic, **options)
        ds = da.to_dataset(name="height", promote_attrs=False)
        ds.attrs = {k: da.attrs[k] for k in _PROVENANCE if k in da.attrs}
        if drop_variables is not None:
            names = [drop_variables] if isinstance(drop_variables, str) else drop_variables
            ds = ds.drop_vars(list(names), errors="ignore")
        return ds

    def guess_can_open(self, filename_or_obj) -> bool:
        """Whether :func:`xrough.io.detect_format` recognises the file.

        Parameters
        ----------
        filename_or_obj : str, os.PathLike or other
            Only existing files given by path can be opened.

        Returns
        -------
        bool
        """
        path = _as_path(filename_or_obj)
        if path is None or not path.is_file():
            return False
        try:
            detect_format(path)
        except (ValueError, OSError):
            return False
        return True
