"""Where the examples find the measurement files they name.

The measurement files (UNCD, vendor formats) are not shipped with xrough. The folder that
holds ``uncd/`` and ``instruments/`` is taken from the environment variable
``XROUGH_DATA``, else from a folder ``shared/data`` next to the checkout or above it. An
example that names real measurements stops with this message when they are not there; it
never substitutes simulated data under the real data's title.
"""

import os
from pathlib import Path


def data_file(*parts: str) -> Path:
    """Return the path of a measurement file, or raise FileNotFoundError saying where to put it."""
    roots = [Path(os.environ["XROUGH_DATA"])] if os.environ.get("XROUGH_DATA") else []
    here = Path(__file__).resolve().parent
    roots += [base / "shared" / "data" for base in (here, *here.parents)]
    for root in roots:
        if root.joinpath(*parts).exists():
            return root.joinpath(*parts)
    raise FileNotFoundError(
        f"{'/'.join(parts)} not found: this example reads real measurements. Set XROUGH_DATA "
        "to the folder that holds uncd/ and instruments/ (looked in "
        + ", ".join(str(r) for r in roots[:3]) + ", ...)")
