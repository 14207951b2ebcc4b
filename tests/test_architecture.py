"""The layout the architecture page describes: one direction of imports, kernels without xarray.

Read from the source with :mod:`ast`, so a violation fails here whether or not the import
happens to run.
"""

import ast
import os
import subprocess
import sys
from fnmatch import fnmatch
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "xrough"
#: Imports allowed inside functions: optional extras only.
#: (h5py: what HDF5 stores of a NetCDF-4 file's variables, to refuse unwritten data;
#: xrough.io.netcdf.check_declared_sizes falls back to bounds by the file's size without.)
OPTIONAL = {"SurfaceTopography", "SurfaceTopography.IO", "zarr", "pint_xarray", "h5py"}
#: Imported where first needed, for the import time of xrough (xrough.plot.pyplot; a
#: window of xrough.toolbox.psd: scipy.signal takes 0.27 s to import, for one function), or only
#: where it works (tqdm.auto, which warns in a notebook without ipywidgets; tqdm.dask
#: imports it).
DEFERRED = {"matplotlib", "matplotlib.pyplot", "scipy.signal", "tqdm.auto", "tqdm.dask"}


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _resolve(module: str, node: ast.ImportFrom, is_package: bool) -> list[str]:
    """Absolute names of the xrough modules an ImportFrom refers to."""
    if node.level == 0:
        base = node.module or ""
    else:
        parts = module.split(".")
        keep = len(parts) - node.level + (1 if is_package else 0)
        base = ".".join(parts[:keep] + ([node.module] if node.module else []))
    if not base.startswith("xrough"):
        return []
    return [base] + [f"{base}.{a.name}" for a in node.names]


def _is_type_checking(node: ast.AST) -> bool:
    """Whether ``node`` is an ``if TYPE_CHECKING:`` block (imports for the type checker)."""
    return isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING"


def _graph():
    modules = {}
    for path in PACKAGE.rglob("*.py"):
        name = _module_name(path)
        modules[name] = (path, ast.parse(path.read_text()))
    edges = {name: set() for name in modules}
    local = {name: [] for name in modules}
    for name, (path, tree) in modules.items():
        is_package = path.name == "__init__.py"
        typing_only = {id(n) for block in ast.walk(tree) if _is_type_checking(block)
                       for n in ast.walk(block)}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                targets = _resolve(name, node, is_package)
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                continue
            submodules = [t for t in targets[1:] if t in modules]
            if isinstance(node, ast.ImportFrom) and targets:
                # "from .pkg import module" imports the module; names import the base
                names_from_base = len(submodules) < len(targets) - 1
                targets = submodules + ([targets[0]] if names_from_base else [])
            for t in targets:
                if t in modules and t != name:
                    edges[name].add(t)
            if node.col_offset > 0 and id(node) not in typing_only:  # in a function
                local[name].append((node.lineno, targets or [getattr(node, "module", "")]))
    return modules, edges, local


MODULES, EDGES, LOCAL = _graph()

#: The layers of the architecture page, lowest first, as patterns of module names; a
#: pattern also covers a package's submodules (``xrough.cli`` covers ``xrough.cli.main``).
#: Modules no pattern names are concept modules (``xrough.correlation``, ``xrough.io.x3p``,
#: and any new package of a concept). Foundation: kernels, the unit boundary, the quality
#: vocabulary and the version (``io``'s readers and their shared glue build topographies:
#: concept). Front end: the package root,
#: the accessors, plots, the command line and the test assertions offered to users.
FOUNDATION = ("xrough._kernels", "xrough._version", "xrough.units", "xrough.quality")
FRONT_END = ("xrough", "xrough.__main__", "xrough.accessor", "xrough.plot", "xrough.cli",
             "xrough.testing")
LAYERS = ("foundation", "concept", "front end")


def _matches(name: str, patterns) -> bool:
    return any(fnmatch(name, p) or (p != "xrough" and fnmatch(name, p + ".*"))
               for p in patterns)


def layer(name: str) -> str:
    """The layer of a module, by :data:`FOUNDATION` and :data:`FRONT_END`."""
    if _matches(name, FOUNDATION):
        return "foundation"
    return "front end" if _matches(name, FRONT_END) else "concept"


def test_no_import_cycles():
    """Depth-first search over the module graph. The package root re-exports everything,
    so it is no target here (no module imports it: the test after this one)."""
    state: dict[str, int] = {}

    def visit(node, stack):
        state[node] = 1
        for nxt in EDGES[node]:
            if nxt == "xrough":
                continue
            if state.get(nxt) == 1:
                cycle = stack[stack.index(nxt):] + [nxt]
                pytest.fail(f"import cycle: {' -> '.join(cycle)}")
            if state.get(nxt) is None:
                visit(nxt, stack + [nxt])
        state[node] = 2

    for name in EDGES:
        if name != "xrough" and state.get(name) is None:
            visit(name, [name])


def test_no_module_imports_the_package_root():
    offenders = [name for name, targets in EDGES.items()
                 if name != "xrough" and "xrough" in targets]
    assert offenders == []


def test_kernels_have_no_xarray():
    offenders = []
    for name, (_, tree) in MODULES.items():
        if not name.startswith("xrough._kernels"):
            continue
        for node in ast.walk(tree):
            mods = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                    [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            offenders += [(name, m) for m in mods if m.split(".")[0] == "xarray"]
    assert offenders == []


def test_kernels_import_only_kernels():
    offenders = [(name, t) for name, targets in EDGES.items()
                 if name.startswith("xrough._kernels") for t in targets
                 if not t.startswith("xrough._kernels")]
    assert offenders == []


#: The longest docstring: the contract (parameters with units, returns, the equation, an
#: example); the essays are in the docs pages.
MAX_DOCSTRING_LINES = 60


def test_no_docstring_is_an_essay():
    """Every docstring of the package (modules, classes, functions) is at most
    :data:`MAX_DOCSTRING_LINES` lines."""
    offenders = []
    for name, (_, tree) in MODULES.items():
        for node in [tree, *ast.walk(tree)]:
            if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef,
                                 ast.AsyncFunctionDef)):
                doc = ast.get_docstring(node, clean=False)
                if doc and doc.count("\n") + 1 > MAX_DOCSTRING_LINES:
                    offenders.append(f"{name}.{getattr(node, 'name', '')}: "
                                     f"{doc.count(chr(10)) + 1} lines")
    assert offenders == []


def test_the_centre_never_imports_the_toolbox():
    """The paper's method (G, its errors and fits, spectra, contact theories, quality,
    units, io and the archive) imports nothing of :mod:`xrough.toolbox` (PSD from heights,
    ISO parameters, filters, sets of scans): the toolbox builds on the centre."""
    offenders = [f"{name} imports {t}" for name, targets in EDGES.items()
                 if not name.startswith("xrough.toolbox") and layer(name) != "front end"
                 for t in targets if t.startswith("xrough.toolbox")]
    assert offenders == []
    assert {"xrough.toolbox.psd", "xrough.toolbox.parameters"} <= set(MODULES)


@pytest.mark.parametrize("name, expected", [
    ("xrough", "front end"), ("xrough.cli", "front end"), ("xrough.cli.main", "front end"),
    ("xrough.plot.figures", "front end"), ("xrough.testing", "front end"),
    ("xrough._kernels.pairs", "foundation"), ("xrough.units", "foundation"),
    ("xrough.io._common", "concept"), ("xrough.quality", "foundation"),
    ("xrough.acf", "concept"), ("xrough.correlation", "concept"),
    ("xrough.correlation.fft", "concept"), ("xrough.io", "concept"),
    ("xrough.io.x3p", "concept"), ("xrough.unitsx", "concept"), ("xrough.plotting", "concept"),
])
def test_layers_follow_the_module_names(name, expected):
    """Subpackages fall into their package's layer; a longer name is not a prefix match."""
    assert layer(name) == expected


def test_every_layer_has_modules():
    found = {layer(name) for name in MODULES}
    assert found == set(LAYERS)


def test_imports_go_from_front_end_to_concept_to_foundation():
    """No module imports one of a higher layer (foundation -> concept -> front end), at
    the top of the file or inside a function."""
    rank = {name: LAYERS.index(layer(name)) for name in MODULES}
    offenders = [f"{name} ({layer(name)}) imports {t} ({layer(t)})"
                 for name, targets in EDGES.items() for t in sorted(targets)
                 if rank[t] > rank[name]]
    assert offenders == []


def test_function_local_imports_are_optional_extras_only():
    offenders = [(name, line, targets) for name, items in LOCAL.items()
                 for line, targets in items
                 if not all(t in OPTIONAL | DEFERRED for t in targets)]
    assert offenders == []


#: What ``import xrough`` leaves for first use (xrough._kernels.deferred): together several
#: times the import of xarray (benchmarks/bench_import.py measures the ratio).
HEAVY = ("scipy.fft", "scipy.special", "scipy.optimize", "scipy.interpolate", "scipy.ndimage",
         "scipy.integrate", "scipy.sparse", "scipy.spatial", "scipy.signal", "scipy.stats",
         "dask", "dask.array", "pint", "cf_xarray", "matplotlib")


def test_import_leaves_the_heavy_dependencies_for_their_first_use():
    """``import xrough`` imports none of :data:`HEAVY` beyond what xarray imports (with
    its oldest versions, scipy.sparse); a G, its fit and Persson theory import what they
    use, and the registry is cf-xarray's (one registry with pint-xarray)."""
    code = (f"import sys, xarray; heavy = {HEAVY!r}; "
            "before = {m for m in heavy if m in sys.modules}; import xrough; "  # xarray's own
            "loaded = [m for m in heavy if m in sys.modules and m not in before]; "
            "assert not loaded, loaded; "
            "import numpy as np; topo = xrough.synthetic.self_affine_surface("
            "n=64, hurst=0.8, lambda_r=20, lambda_s=2, rms_height=1, size=64, unit='nm', "
            "seed=1); G = topo.rough.acf(); G.rough.persson(E_star='25 MPa', p0='0.1 MPa'); "
            "assert 'scipy.optimize' in sys.modules and 'pint' in sys.modules; "
            "import cf_xarray.units, pint; "
            "assert xrough.units.parse_units('nm')._REGISTRY is cf_xarray.units.units; "
            "assert pint.get_application_registry().get() is cf_xarray.units.units")
    run = subprocess.run([sys.executable, "-W", "ignore", "-c", code], capture_output=True,
                         text=True)
    assert run.returncode == 0, run.stderr[-2000:]


def test_import_leaves_pyplot_for_the_first_plot():
    """``import xrough`` and ``xrough --help`` do not import matplotlib.pyplot (about 1 s
    of the 1.5-3 s the import took); the first plot does."""
    code = ("import sys, xrough; assert 'matplotlib.pyplot' not in sys.modules; "
            "import xrough.cli; assert 'matplotlib.pyplot' not in sys.modules; "
            "import numpy as np; "
            "xrough.topography(np.zeros((4, 4)), spacing=1.0, unit='nm').rough.plot(); "
            "assert 'matplotlib.pyplot' in sys.modules")
    env = dict(os.environ, MPLBACKEND="Agg")
    subprocess.run([sys.executable, "-c", code], check=True, env=env)


def test_version_has_one_home():
    assert "xrough._version" in EDGES["xrough"]
    for name, (_, tree) in MODULES.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.Assign) and any(
                    getattr(t, "id", None) == "__version__" for t in node.targets):
                assert name == "xrough._version", name


def test_modules_do_not_reach_into_each_others_private_names():
    """A concept module uses another's public names; kernels and its own subpackage aside."""
    offenders = []
    for name, (path, tree) in MODULES.items():
        if name.startswith("xrough._kernels"):
            continue
        for node in ast.walk(tree):
            if not isinstance(node, ast.ImportFrom) or node.level == 0:
                continue
            source = (node.module or "")
            if source.startswith("_kernels") or (node.level == 1 and "." in name[7:]
                                                  and path.name != "__init__.py"):
                continue  # kernels, or a sibling in the same subpackage (io)
            offenders += [(name, source, a.name) for a in node.names
                          if a.name.startswith("_") and a.name != "__version__"]
    assert offenders == []


def test_no_private_name_is_imported_from_another_module():
    """A name another module imports is public where it is defined (no leading ``_``).

    Every package module counts, kernels and siblings alike; a private module
    (``from . import _checksum``) is a module, not a name, and dunders are not private.
    """
    offenders = []
    for name, (path, tree) in MODULES.items():
        for node in ast.walk(tree):
            if not isinstance(node, ast.ImportFrom):
                continue
            targets = _resolve(name, node, path.name == "__init__.py")
            for alias in node.names if targets else ():
                imported = (targets[0], alias.name)
                if (alias.name.startswith("_") and not alias.name.endswith("__")
                        and f"{targets[0]}.{alias.name}" not in MODULES):
                    offenders.append((name, *imported))
    assert offenders == []
