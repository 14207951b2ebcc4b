from importlib.util import find_spec, module_from_spec, spec_from_file_location
from pathlib import Path

import matplotlib
import pytest
import tqdm

matplotlib.use("Agg")
# no tqdm monitor thread: a thread that wakes and allocates while a test starts or stops
# tracemalloc can crash CPython 3.11 (the readers' memory checks trace their reads)
tqdm.tqdm.monitor_interval = 0


def _data_root() -> Path:
    """Where the measurement files are: examples/_data.py's search (``XROUGH_DATA``, else
    ``shared/data`` next to the checkout or above it), the one definition of it."""
    spec = spec_from_file_location(
        "_xrough_example_data", Path(__file__).resolve().parents[1] / "examples" / "_data.py")
    module = module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.data_root()


DATA = _data_root()


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


def uncd_measurements() -> dict:
    """The three UNCD measurements as its meta.yml describes them, detrended as it says
    (TEM: mean, AFM: plane, stylus: curvature); skips when the data are absent."""
    import xrough

    folder = data_path("uncd")
    tem = xrough.open_topography(folder / "80_Scale10.472_FIXEDv2p1_D7eHXiT.asc",
                                 resample=True, unit="nm")
    afm = xrough.open_topography(folder / "gain_control_uncd_35_z03tr3R.001")
    sty = xrough.open_topography(folder / "uncd_stylus_300um_5mar_3_k0HpKJt.txt", unit="mm")
    return {"TEM": tem.rough.detrend(mode="mean"), "AFM": afm.rough.detrend(mode="plane"),
            "stylus": sty.rough.detrend(mode="curvature")}
