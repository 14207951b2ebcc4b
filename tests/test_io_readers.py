"""Readers from other packages: the entry-point group ``xrough.readers``.

Each test installs a dummy distribution into a temporary folder on ``sys.path`` (a
``*.dist-info`` with ``entry_points.txt`` beside the reader's module), as pip would, and
forgets the registry before and after.
"""

from __future__ import annotations

import textwrap
import warnings

import numpy as np
import pytest

import xrough
from xrough.io import readers

READER = '''
import numpy as np
import xrough

EXTENSIONS = (".foo",)
DESCRIPTION = "the FOO test format"


def sniff(head, path):
    return head.startswith(b"FOO1")


def read(path, *, scale=1.0):
    rows = [line.split() for line in path.read_text().splitlines()[1:]]
    heights = np.array(rows, dtype=float) * scale
    return xrough.topography(heights, spacing=2.0, unit="nm")
'''


def _install(tmp_path, monkeypatch, entries: dict[str, str], modules: dict[str, str]):
    """Install a distribution ``dummy-readers`` with ``entries`` (name -> value) of the
    group and the ``modules`` (name -> source) they point at."""
    info = tmp_path / "dummy_readers-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: dummy-readers\n"
                                   "Version: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[xrough.readers]\n" + "".join(f"{k} = {v}\n" for k, v in entries.items()))
    for name, source in modules.items():
        (tmp_path / f"{name}.py").write_text(textwrap.dedent(source))
    monkeypatch.syspath_prepend(str(tmp_path))
    readers._plugins.cache_clear()


@pytest.fixture(autouse=True)
def _forget_plugins():
    readers._plugins.cache_clear()
    yield
    readers._plugins.cache_clear()


def _foo_file(path, values=((1, 2, 3), (4, 5, 6))):
    path.write_text("FOO1\n" + "\n".join(" ".join(str(v) for v in row) for row in values))
    return path


def test_a_reader_registered_from_outside_is_used(tmp_path, monkeypatch):
    """A package's reader in the entry-point group reads its files through
    open_topography (detected by content, and by ``format=``), with its options and
    xrough's overrides and provenance; it is asked before plain text (its files are text
    that the text reader would take) and the fallback bridge; a folder of its files opens
    as a set."""
    site = tmp_path / "site"
    site.mkdir()
    _install(site, monkeypatch, {"foo": "foo_reader"}, {"foo_reader": READER})
    data = tmp_path / "data"
    data.mkdir()
    path = _foo_file(data / "scan.foo")
    names = list(readers.registered())
    assert "foo" in names and names.index("sdf") < names.index("foo") < names.index("text")
    assert names[-1] == readers.BRIDGE or readers.BRIDGE not in names
    assert xrough.io.detect_format(path) == "foo"
    topo = xrough.open_topography(path, scale=2.0, periodic=True)
    np.testing.assert_array_equal(topo.values, [[2, 4, 6], [8, 10, 12]])
    assert topo.attrs["format"] == "foo" and topo.attrs["source_file"] == "scan.foo"
    assert topo.attrs["periodic"] == 1 and topo.x.attrs["units"] == "nm"
    same = xrough.open_topography(_foo_file(data / "other.txt"), format="foo")
    np.testing.assert_array_equal(same.values, [[1, 2, 3], [4, 5, 6]])
    with pytest.raises(ValueError, match="has no option colour="):
        xrough.open_topography(path, colour="red")
    tree = xrough.open_set(data, progress=False)
    assert sorted(tree.children) == ["other", "scan"]


def test_broken_plugins_are_left_out_by_name(tmp_path, monkeypatch):
    """A plugin that does not import, one that is no reader and one that takes a built-in's
    name are each left out with one warning naming it and its distribution; the good one
    and every built-in reader still read."""
    _install(tmp_path, monkeypatch,
             {"broken": "no_such_module", "empty": "empty_reader", "text": "foo_reader",
              "foo": "foo_reader"},
             {"empty_reader": "EXTENSIONS = ('.emp',)\n", "foo_reader": READER})
    with pytest.warns(UserWarning) as caught:
        names = list(readers.registered())
    said = "\n".join(str(w.message) for w in caught)
    assert "reader 'broken'" in said and "cannot be imported" in said
    assert "reader 'empty'" in said and "has no sniff" in said
    assert "reader 'text'" in said and "name is taken" in said
    assert "dummy-readers" in said and len(caught) == 3
    assert "foo" in names and "broken" not in names and "empty" not in names
    assert readers.FORMATS["text"].module == "xrough.io.text"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # said once: the registry is kept
        assert xrough.io.detect_format(_foo_file(tmp_path / "a.foo")) == "foo"
        line = tmp_path / "line.txt"
        np.savetxt(line, np.column_stack([np.arange(5.0), np.arange(5.0) ** 2]))
        assert xrough.io.detect_format(line) == "text"


def test_a_fallback_plugin_is_tried_last(tmp_path, monkeypatch):
    """A reader that says ``FALLBACK = True`` (as the bridge does) is not asked before
    the native readers and the extensions: a text file stays text even though the
    fallback would take any file; a file no other reader takes goes to it."""
    anything = READER.replace('return head.startswith(b"FOO1")', "return True") + \
        "\nFALLBACK = True\nEXTENSIONS = ()\n"
    _install(tmp_path, monkeypatch, {"anything": "any_reader"}, {"any_reader": anything})
    line = tmp_path / "line.txt"
    np.savetxt(line, np.column_stack([np.arange(5.0), np.arange(5.0) ** 2]))
    assert xrough.io.detect_format(line) == "text"
    odd = _foo_file(tmp_path / "scan.odd")
    odd.write_bytes(b"FOO1\n\x01\x02" + odd.read_bytes()[5:])
    names = list(readers.registered())
    assert names.index("anything") > names.index("text")
    assert xrough.io.detect_format(odd) == "anything"  # before the bridge: by name


def test_unknown_format_names_every_reader():
    """format= of no registered reader: the message lists them, the bridge among them."""
    with pytest.raises(ValueError, match="unknown format 'nope'; known: x3p, sur"):
        readers.reader_of("nope")
