"""NumPy ``.npy`` arrays: a 2D height map ``(y, x)`` or a 1D profile.

A ``.npy`` file stores numbers only: no lateral size and no units. They must be given to
:func:`read` (or :func:`xrough.io.open_topography`); nothing is guessed. The header's
length and the data size its shape and dtype give must add up to the file's size; any
damaged header is a ``ValueError`` naming the file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.lib.format as npformat
import xarray as xr

from ..topography import topography
from ._common import MissingOptionError, check_file, invalid_as_missing, reader_errors

__all__ = ["sniff", "read"]

_MAGIC = b"\x93NUMPY"


def sniff(head: bytes, path: Path) -> bool:
    """Whether ``head`` starts with the ``.npy`` signature.

    Parameters
    ----------
    head : bytes
        The first bytes of the file.
    path : pathlib.Path
        The file (unused).

    Returns
    -------
    bool
    """
    return head.startswith(_MAGIC)


def _check_size(path: Path) -> None:
    """Refuse a damaged header, or one whose data size is not the file's, before allocating.

    The header (a Python literal) states the shape and dtype; the data follow it and end
    the file, so a size that does not add up means a truncated file, bytes inserted into
    the file or appended to it.
    """
    name = path.name
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(12)
    # the header's length: 2 bytes in version 1, 4 in later ones; checked before numpy's
    # parser reads (and allocates) that many bytes
    width = 2 if head[6:8] == b"\x01\x00" else 4
    if len(head) >= 8 + width:
        length = int.from_bytes(head[8:8 + width], "little")
        if 8 + width + length > size:
            raise ValueError(f"{name}: truncated or damaged file: the header length field "
                             f"states {length} bytes of header, the file has {size} bytes")
    try:
        with open(path, "rb") as fh:
            version = npformat.read_magic(fh)
            if version == (1, 0):
                shape, _, dtype = npformat.read_array_header_1_0(fh)
            else:
                shape, _, dtype = npformat.read_array_header_2_0(fh)
            offset = fh.tell()
    except (FileNotFoundError, IsADirectoryError):
        raise
    except Exception as err:  # noqa: BLE001 - the header parser raises SyntaxError, TokenError...
        raise ValueError(f"{name}: cannot read as a NumPy .npy array: damaged header "
                         f"({type(err).__name__}: {err})") from err
    if dtype.hasobject:
        raise ValueError(f"{name}: the array holds Python objects, not numbers (refused: "
                         "loading them would run code)")
    needed = int(np.prod(shape, dtype=object)) * dtype.itemsize
    available = size - offset
    if needed != available:
        raise ValueError(f"{name}: truncated or damaged file: "
                         f"the header declares shape {tuple(shape)} of {dtype} ({needed} "
                         f"bytes) but the file holds {available} bytes of data after its "
                         f"{offset}-byte header")


def read(path, *, spacing=None, size=None, unit: str | None = None,
         height_unit: str | None = None, periodic: bool | None = None) -> xr.DataArray:
    """Read a height map or profile from a ``.npy`` file.

    Parameters
    ----------
    path : str or Path
        The file: a 2D array (rows are ``y``, columns ``x``) or a 1D profile.
    spacing : float, str, Quantity or pair, optional
        Grid spacing ``(dy, dx)`` or one value; plain numbers are in ``unit``.
    size : float, str, Quantity or pair, optional
        Physical size ``(Ly, Lx)`` or ``Lx`` (alternative to ``spacing``).
    unit : str, optional
        Lateral unit, and the height unit unless ``height_unit`` is given.
    height_unit : str, optional
        Unit of the heights.
    periodic : bool, optional
        Whether the map is one period of a periodic surface.

    Returns
    -------
    xarray.DataArray
        The topography.

    Raises
    ------
    ValueError
        No spacing/size or unit given, not a numeric 1D/2D array, or a damaged file.

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     np.save(pathlib.Path(tmp) / "h.npy", np.zeros((3, 4)))
    ...     t = read(pathlib.Path(tmp) / "h.npy", size=("3 um", "4 um"), height_unit="nm")
    >>> t.shape, t.x.attrs["units"], t.attrs["units"], float(t.x[1])
    ((3, 4), 'um', 'nm', 1.0)
    """
    path = Path(path)
    check_file(path)
    with reader_errors(path, "a NumPy .npy array"):
        return _read(path, spacing, size, unit, height_unit, periodic)


def _read(path: Path, spacing, size, unit, height_unit, periodic) -> xr.DataArray:
    name = path.name
    _check_size(path)
    arr = np.load(path, allow_pickle=False)
    if not isinstance(arr, np.ndarray):
        raise ValueError(f"{name}: not a single .npy array")
    if arr.dtype.kind not in "iuf" or arr.ndim not in (1, 2):
        raise ValueError(f"{name}: a topography needs a 1D or 2D array of real numbers, "
                         f"found shape {arr.shape} of dtype {arr.dtype}")
    if spacing is None and size is None:
        if unit is None and height_unit is None:
            raise MissingOptionError(name, "a .npy file stores no lateral size and no units",
                                     ("size", "unit"),
                                     advice=" (e.g. size=('10 um', '10 um'), unit='nm')")
        raise MissingOptionError(name, "a .npy file stores no lateral size", ("size", "spacing"),
                                 either=True, advice=" (e.g. size=('10 um', '10 um'))")
    if unit is None and height_unit is None:
        raise MissingOptionError(name, "a .npy file stores no units", ("unit",),
                                 advice=" (and height_unit= if the heights are in another "
                                 "unit), e.g. unit='nm'")
    attrs = {"npy_dtype": str(arr.dtype)}
    arr = invalid_as_missing(path, arr, attrs, marker="NaN")
    return topography(arr, spacing=spacing, size=size, unit=unit, height_unit=height_unit,
                      periodic=periodic, attrs=attrs)
