"""Progress bars: tqdm's plain bar where notebook widgets are missing, never a warning."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import warnings

import tqdm.std

from xrough import progress


def test_plain_bar_without_widgets(monkeypatch):
    """Without ipywidgets the plain tqdm bar, and no TqdmWarning (tqdm.auto warned
    'IProgress not found' in every notebook of a core install)."""
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "ipywidgets" else
                        importlib.machinery.PathFinder.find_spec(name))
    progress._tqdm_class.cache_clear()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            bar = progress.progress_bar(desc="x", total=2, progress=True)
            bar.update(2)
            bar.close()
        assert type(bar) is tqdm.std.tqdm
    finally:
        progress._tqdm_class.cache_clear()


def test_importing_xrough_imports_no_notebook_bar():
    """Importing xrough does not import tqdm.auto (which warns in a kernel on import)."""
    code = "import sys, xrough; print('tqdm.autonotebook' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "False"


def test_off_and_on():
    assert progress.progress_bar(desc="x", total=3, progress=False) is None
    assert list(progress.progress_bar(desc="x", iterable="ab", progress=False)) == ["a", "b"]
    bar = progress.progress_bar(desc="x", iterable=range(3), progress=True)
    assert list(bar) == [0, 1, 2]


def test_dask_bar_counts_the_tasks(capsys):
    """A computation of three dask tasks inside ``dask_progress`` draws a bar of 3 tasks
    on stderr, with no warning; ``progress=False`` draws nothing."""
    import dask

    tasks = [dask.delayed(abs)(-k) for k in range(3)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with progress.dask_progress(desc="rows", progress=True):
            assert dask.compute(*tasks, scheduler="sync") == (0, 1, 2)
    err = capsys.readouterr().err
    assert "rows" in err and "/3 " in err  # leave=False clears the bar when done
    with progress.dask_progress(desc="rows", progress=False):
        dask.compute(*tasks, scheduler="sync")
    assert capsys.readouterr().err == ""
