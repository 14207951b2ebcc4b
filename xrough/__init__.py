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

from . import (
    accessor,  # noqa: F401  (registers .rough)
    plot,
    quality,
    units,
)
from ._version import __version__
from .contact import (
    elastic_energy,
    patch_radius,
    persson,
    stress_acf,
    stress_acf_from_spectrum,
)
from .correlation import height_difference_acf
from .fitting import fit_acf, model_acf
from .gradient import (
    gradient_from_fit,
    gradient_from_spectrum,
    rms_gradient,
    rms_gradient_exact,
)
from .io import open_topography
from .io.archive import open_analysis, save_analysis
from .models import self_affine_model
from .preprocess import (
    detrend,
    fill_missing,
    fit_trend,
    mask_outliers,
    reliability_window,
    reliable,
)
from .quality import QualityWarning
from .separation import mean_gap
from .solver import ConvergenceWarning, solve_contact
from .spectra import (
    acf_from_spectrum,
    model_spectrum,
    spectrum,
)
from .stitching import (
    LevelFactorWarning,
    StitchingGapWarning,
    StitchingMismatchWarning,
    stitch,
    stitch_curves,
    stitch_mismatch,
)
from .synthetic import self_affine_surface
from .toolbox.bandwidth import variable_bandwidth
from .toolbox.cleaning import cleaning_sensitivity
from .toolbox.ensemble import analyse_set, mean_acf, mean_psd, mean_scale_dependent, open_set
from .toolbox.filters import fourier_filter, longcut, shortcut
from .toolbox.parameters import (
    bearing_area_curve,
    curvature_distribution,
    height_distribution,
    material_ratio,
    roughness_parameters,
    scale_dependent_curvature,
    scale_dependent_slope,
    scale_dependent_statistic,
    slope_distribution,
    tip_check,
)
from .toolbox.psd import power_spectrum, power_spectrum_2d, spectral_moment
from .topography import convert_units, topography
from .validation import compare_with_simulation

__all__ = [
    "__version__",
    "bearing_area_curve",
    "curvature_distribution",
    "height_distribution",
    "material_ratio",
    "roughness_parameters",
    "scale_dependent_curvature",
    "scale_dependent_slope",
    "scale_dependent_statistic",
    "slope_distribution",
    "tip_check",
    "variable_bandwidth",
    "fourier_filter",
    "fill_missing",
    "shortcut",
    "longcut",
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
    "cleaning_sensitivity",
    "model_acf",
    "model_spectrum",
    "open_analysis",
    "open_topography",
    "convert_units",
    "patch_radius",
    "persson",
    "mean_gap",
    "mean_acf",
    "mean_psd",
    "mean_scale_dependent",
    "open_set",
    "analyse_set",
    "quality",
    "QualityWarning",
    "rms_gradient",
    "rms_gradient_exact",
    "save_analysis",
    "solve_contact",
    "plot",
    "power_spectrum",
    "power_spectrum_2d",
    "spectral_moment",
    "reliability_window",
    "reliable",
    "self_affine_model",
    "self_affine_surface",
    "spectrum",
    "stitch",
    "stitch_curves",
    "stitch_mismatch",
    "StitchingMismatchWarning",
    "StitchingGapWarning",
    "LevelFactorWarning",
    "stress_acf",
    "stress_acf_from_spectrum",
    "topography",
    "units",
]
