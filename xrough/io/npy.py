"""NumPy ``.npy`` arrays: a 2D height map ``(y, x)`` or a 1D profile.

A ``.npy`` file stores numbers only: no lateral size and no units. They must be given to
:func:`read` (or :func:`xrough.io.open_topography`); nothing is guessed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.lib.format as npformat
import xarray as xr

from ..topography import topography

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
    """Refuse a header that declares more data than the file holds, before allocating."""
    name = path.name
    try:
        with open(path, "rb") as fh:
            version = npformat.read_magic(fh)
            if version == (1, 0):
                shape, _, dtype = npformat.read_array_header_1_0(fh)
            else:
                shape, _, dtype = npformat.read_array_header_2_0(fh)
            offset = fh.tell()
    except FileNotFoundError:
        raise
    except (ValueError, OSError, EOFError, SyntaxError, TypeError) as err:
        raise ValueError(f"{name}: cannot read as a NumPy .npy array: damaged header "
                         f"({err})") from None
    if dtype.hasobject:
        raise ValueError(f"{name}: the array holds Python objects, not numbers (refused: "
                         "loading them would run code)")
    needed = int(np.prod(shape, dtype=object)) * dtype.itemsize
    available = path.stat().st_size - offset
    if needed > available:
        raise ValueError(f"{name}: truncated or damaged file: the header declares shape "
                         f"{tuple(shape)} of {dtype} ({needed} bytes) but the file holds "
                         f"{available} bytes of data")


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
    name = path.name
    _check_size(path)
    try:
        arr = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise
    except (ValueError, OSError, EOFError) as err:
        raise ValueError(f"{name}: cannot read as a NumPy .npy array ({err})") from None
    if not isinstance(arr, np.ndarray):
        raise ValueError(f"{name}: not a single .npy array")
    if arr.dtype.kind not in "iuf" or arr.ndim not in (1, 2):
        raise ValueError(f"{name}: a topography needs a 1D or 2D array of real numbers, "
                         f"found shape {arr.shape} of dtype {arr.dtype}")
    if spacing is None and size is None:
        raise ValueError(f"{name}: a .npy file stores no lateral size: pass size= (e.g. "
                         "size=('10 um', '10 um')) or spacing=, and unit=")
    if unit is None and height_unit is None:
        raise ValueError(f"{name}: a .npy file stores no units: pass unit= (and "
                         "height_unit= if the heights are in another unit), e.g. unit='nm'")
    return topography(arr, spacing=spacing, size=size, unit=unit, height_unit=height_unit,
                      periodic=periodic, attrs={"npy_dtype": str(arr.dtype)})
