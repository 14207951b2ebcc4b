"""Sphinx configuration of the xrough documentation.

Build (from the repository root, after ``pip install -e ".[docs]"``)::

    python -m sphinx -W -b html docs docs/_build/html

Pages are MyST Markdown (myst-nb): the reference pages are plain Markdown, the tutorials in
``docs/tutorials`` are notebooks stored as text and executed during the build. The gallery
is ``examples/plot_*.py`` run by sphinx-gallery. The API reference of every public module
is written by :func:`write_api_modules` at configuration time, so a new public function or
module shows up without editing a page.
"""

from __future__ import annotations

import importlib
import inspect
import os
import pkgutil
from pathlib import Path

import sphinx_autosummary_accessors

import xrough

HERE = Path(__file__).resolve().parent

project = "xrough"
author = "the xrough developers"
copyright = "the xrough developers"  # noqa: A001 - Sphinx's name
release = xrough.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_autosummary_accessors",
    "myst_nb",
    "sphinx_gallery.gen_gallery",
]

templates_path = ["_templates", sphinx_autosummary_accessors.templates_path]
exclude_patterns = [
    "_build",
    "**.ipynb_checkpoints",
    # sphinx-gallery writes a notebook, a script and a zip beside each example page; the
    # page (.rst) is the document, the notebook is a download, not a second page
    "auto_examples/*.ipynb",
    "auto_examples/*.py",
    "auto_examples/*.zip",
    "auto_examples/*.md5",
    "auto_examples/*.json",
    "_api_*.rst",  # written by write_api_modules, included by api.rst
]

# --- MyST and notebooks -------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence"]
myst_heading_anchors = 3
# Tutorials run at every build: small maps, a few seconds each.
nb_execution_mode = "force"
nb_execution_timeout = 300
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True
# xrough's progress bars are Jupyter widgets in a kernel; a static page keeps no widget
# state, so load no widget manager (it would only report missing models)
nb_ipywidgets_js: dict = {}

# --- API reference ------------------------------------------------------------------------
# the stubs of the generated sections too (autosummary reads only the files it is given)
autosummary_generate = ["api.rst", "_api_accessors.rst", "_api_more.rst",
                        "_api_modules.rst"]
autosummary_imported_members = True
autodoc_typehints = "none"  # numpydoc's "Parameters" sections carry types and units
autodoc_default_options = {"members": False}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()  # the docstrings are checked by ruff (D rules)

# --- Gallery -----------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "ignore_pattern": r"__init__\.py|_data\.py",  # _data: where the measurement files are
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "write_computation_times": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "plot_gallery": "True",
    "abort_on_example_error": True,
    "reset_modules": ("matplotlib",),
}

# --- HTML ---------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"xrough {release}"
html_theme_options = {
    "github_url": "https://github.com/xrough/xrough",
    "navigation_with_keys": False,
    "header_links_before_dropdown": 6,
    "show_toc_level": 2,
}
html_static_path: list[str] = []
html_show_sourcelink = False

# Fail on every warning (the build runs with -W) except these:
suppress_warnings = [
    # examples/plot_validation.py opens with a one-line docstring, not a reST title, so its
    # gallery page has no title for the table of contents
    "toc.no_title",
]

# ------------------------------------------------------------------------------------------
# The API of every public module, written into _api_modules.rst (included by
# api.rst): each module's __all__, functions and classes with their own page, constants
# inline. Names also exported by ``xrough`` itself are documented once, under ``xrough``.

#: Modules documented in the reference (import names), in page order; any other public
#: module of the package is appended, so that nothing public is left out.
API_MODULES = [
    "xrough.topography",
    "xrough.io",
    "xrough.io.readers",
    "xrough.io.archive",
    "xrough.preprocess",
    "xrough.correlation",
    "xrough.synthetic",
    "xrough.spectra",
    "xrough.models",
    "xrough.fitting",
    "xrough.memo",
    "xrough.gradient",
    "xrough.contact",
    "xrough.stitching",
    "xrough.solver",
    "xrough.validation",
    "xrough.toolbox",
    "xrough.toolbox.psd",
    "xrough.toolbox.parameters",
    "xrough.toolbox.filters",
    "xrough.toolbox.bandwidth",
    "xrough.toolbox.cleaning",
    "xrough.toolbox.ensemble",
    "xrough.plot",
    "xrough.units",
    "xrough.acf",
    "xrough.cli",
    "xrough.testing",
]
#: Not reference material: the accessor classes (documented as DataArray.rough...), the
#: xarray backend entry point, and the per-format readers behind open_topography.
API_SKIP = {"xrough.accessor", "xrough.io.backend"}
FORMAT_MODULES = "xrough.io."


def _public_modules() -> list[str]:
    found = []
    for info in pkgutil.walk_packages(xrough.__path__, "xrough."):
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        found.append(info.name)
    order = [m for m in API_MODULES if m in found]
    return order + sorted(m for m in found if m not in order and m not in API_SKIP)


def _accessor_rows(cls: type, owner: str) -> list[str]:
    names = [n for n, v in vars(cls).items() if not n.startswith("_") and hasattr(v, "method")]
    return [f"   {owner}.rough.{n}" for n in names]


def write_api_modules() -> None:
    """Write the accessor tables and one section per public module for api.rst."""
    from xrough import accessor

    lines = [".. currentmodule:: xarray", ""]
    for cls, owner in [(accessor.RoughDataArrayAccessor, "DataArray"),
                       (accessor.RoughDatasetAccessor, "Dataset"),
                       (accessor.RoughDataTreeAccessor, "DataTree")]:
        title = f"``{owner}.rough``"
        summary = inspect.getdoc(cls).split("\n\n")[0]
        lines += [title, "~" * len(title), "", summary, "",
                  ".. autosummary::", "   :toctree: generated/",
                  "   :template: autosummary/accessor_method.rst", "",
                  *_accessor_rows(cls, owner), ""]
    (HERE / "_api_accessors.rst").write_text("\n".join(lines))

    # names of xrough.__all__ that api.rst does not list yet get a section of their own
    listed = {line.strip() for line in (HERE / "api.rst").read_text().splitlines()}
    more = sorted(n for n in xrough.__all__ if n not in listed and n != "__version__"
                  and not inspect.ismodule(getattr(xrough, n)))
    lines = [".. currentmodule:: xrough", ""]
    if more:
        lines += ["More", "~~~~", "", ".. autosummary::", "   :toctree: generated/", "",
                  *[f"   {n}" for n in more], ""]
    (HERE / "_api_more.rst").write_text("\n".join(lines))

    top = set(xrough.__all__)
    lines = []
    for name in _public_modules():
        if name in API_SKIP:
            continue
        mod = importlib.import_module(name)
        public = list(getattr(mod, "__all__", []))
        title = f"``{name}``"
        lines += [title, "-" * len(title), "", f".. automodule:: {name}", "   :no-members:"]
        if not inspect.ismodule(getattr(xrough, name.split(".", 1)[1], mod)):
            lines.append("   :no-index:")  # xrough.topography is also the function's name
        lines.append("")
        objs = {n: getattr(mod, n) for n in public if hasattr(mod, n)}
        callables = [n for n, v in objs.items()
                     if (inspect.isfunction(v) or inspect.isclass(v))
                     and not (n in top and getattr(xrough, n) is v)]
        shared = [n for n, v in objs.items() if n in top and getattr(xrough, n) is v]
        data = [n for n, v in objs.items() if n not in callables and n not in shared]
        if shared:
            refs = ", ".join(f":func:`xrough.{n}`" if inspect.isfunction(objs[n])
                             else f":class:`xrough.{n}`" for n in shared)
            lines += [f"Also in the ``xrough`` namespace (documented there): {refs}.", ""]
        if callables:
            lines += [f".. currentmodule:: {name}", "", ".. autosummary::",
                      "   :toctree: generated/", "", *[f"   {n}" for n in callables], ""]
        for n in data:
            lines += [f".. autodata:: {name}.{n}", "   :no-value:", ""]
    (HERE / "_api_modules.rst").write_text("\n".join(lines))


write_api_modules()

# The tutorials' kernels inherit this environment: their figures are notebook outputs only
# with the inline backend (an MPLBACKEND=Agg from the shell would leave the pages without
# figures). sphinx-gallery switches its own process to agg for the examples.
os.environ["MPLBACKEND"] = "module://matplotlib_inline.backend_inline"

