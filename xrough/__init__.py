"""xrough: contact mechanics of rough surfaces from the height-difference ACF.

Topographies, correlation functions and results are labelled :mod:`xarray` objects with
physical units on data and coordinates; the ``.rough`` accessor chains the steps:

>>> import xrough
>>> topo = xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="40 nm",
...                                   size="10 um", n=512, rms_gradient=0.5, seed=1,
...                                   unit="nm")
>>> G = topo.rough.acf()
>>> G.attrs["units"], G.dr.attrs["units"]
('nm2', 'nm')
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("xrough")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

from . import (  # noqa: E402
    accessor,  # noqa: E402,F401  (registers .rough)
    plot,
    units,
)
from .archive import open_analysis, save_analysis  # noqa: E402
from .contact import (  # noqa: E402
    elastic_energy,
    patch_radius,
    persson,
    stress_acf,
    stress_acf_from_spectrum,
)
from .correlation import height_difference_acf  # noqa: E402
from .fitting import fit_acf, gradient_from_fit, model_acf  # noqa: E402
from .gradient import rms_gradient  # noqa: E402
from .io import open_topography  # noqa: E402
from .models import self_affine_model  # noqa: E402
from .preprocess import (  # noqa: E402
    detrend,
    fit_trend,
    mask_outliers,
    reliability_window,
    reliable,
)
from .solver import ConvergenceWarning, solve_contact  # noqa: E402
from .spectra import (  # noqa: E402
    acf_from_spectrum,
    gradient_from_spectrum,
    model_spectrum,
    rms_gradient_exact,
    spectrum,
)
from .stitching import (  # noqa: E402
    StitchingMismatchWarning,
    stitch,
    stitch_curves,
    stitch_mismatch,
)
from .synthetic import self_affine_surface  # noqa: E402
from .topography import topography  # noqa: E402
from .validation import compare_with_simulation  # noqa: E402

__all__ = [
    "__version__",
    "acf_from_spectrum",
    "compare_with_simulation",
    "ConvergenceWarning",
    "detrend",
    "elastic_energy",
    "fit_acf",
    "fit_trend",
    "gradient_from_fit",
    "gradient_from_spectrum",
    "height_difference_acf",
    "mask_outliers",
    "model_acf",
    "model_spectrum",
    "open_analysis",
    "open_topography",
    "patch_radius",
    "persson",
    "rms_gradient",
    "rms_gradient_exact",
    "save_analysis",
    "solve_contact",
    "plot",
    "reliability_window",
    "reliable",
    "self_affine_model",
    "self_affine_surface",
    "spectrum",
    "stitch",
    "stitch_curves",
    "stitch_mismatch",
    "StitchingMismatchWarning",
    "stress_acf",
    "stress_acf_from_spectrum",
    "topography",
    "units",
]
