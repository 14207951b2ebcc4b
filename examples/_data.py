"""Where the examples find the measurement files they name.

The measurement files (UNCD, vendor formats) are not shipped with xrough. The folder that
holds ``uncd/`` and ``instruments/`` is taken from the environment variable
``XROUGH_DATA``, else from a folder ``shared/data`` next to the checkout or above it. An
example that names real measurements stops with this message when they are not there; it
never substitutes simulated data under the real data's title.
"""

import os
from pathlib import Path


def data_roots() -> list[Path]:
    """The folders searched for measurement files, first ``XROUGH_DATA``, in order.

    The one definition of where the data are: the tests (``tests/conftest.py``) and the
    benchmarks read the same folders.
    """
    roots = [Path(os.environ["XROUGH_DATA"])] if os.environ.get("XROUGH_DATA") else []
    here = Path(__file__).resolve().parent
    return roots + [base / "shared" / "data" for base in (here, *here.parents)]


def data_root() -> Path:
    """The first of :func:`data_roots` that exists (the first one if none does)."""
    roots = data_roots()
    return next((r for r in roots if r.is_dir()), roots[0])


def data_file(*parts: str) -> Path:
    """Return the path of a measurement file, or raise FileNotFoundError saying where to put it."""
    roots = data_roots()
    for root in roots:
        if root.joinpath(*parts).exists():
            return root.joinpath(*parts)
    raise FileNotFoundError(
        f"{'/'.join(parts)} not found: this example reads real measurements. Set XROUGH_DATA "
        "to the folder that holds uncd/ and instruments/ (looked in "
        + ", ".join(str(r) for r in roots[:3]) + ", ...)")
