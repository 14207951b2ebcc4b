from importlib.util import find_spec
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")


DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


@pytest.fixture(params=["numpy", "dask"])
def backend(request):
    return request.param


def to_backend(da, backend, chunks=None):
    if backend == "dask":
        extra = {d: 1 for d in da.dims if d not in ("x", "y")}
        return da.chunk(chunks or extra or {})
    return da


#: files that only SurfaceTopography reads (through the bridge, the ``formats`` extra)
needs_bridge = pytest.mark.skipif(find_spec("SurfaceTopography") is None,
                                  reason="the file is read through SurfaceTopography "
                                         "(xrough[formats]), which is not installed")


def data_path(*parts):
    path = DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"measurement data not available: {path.name}")
    return path
