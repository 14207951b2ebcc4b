"""The declared minimum versions are the ones the oldest-versions CI run installs.

pyproject.toml gives each core dependency a minimum (``>=``); .ci/oldest-constraints.txt
pins each of them (``==``) for .ci/oldest, which runs the fast suite on those versions.
The two must name the same versions, or the minimums stop being tested.
"""

import tomllib
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]
CONSTRAINTS = ROOT / ".ci" / "oldest-constraints.txt"


def _minimums() -> dict[str, Version]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    out = {}
    for line in project["dependencies"]:
        req = Requirement(line)
        lower = [Version(s.version) for s in req.specifier if s.operator == ">="]
        assert len(lower) == 1, f"{line!r}: a core dependency needs exactly one '>=' minimum"
        out[canonicalize_name(req.name)] = lower[0]
    return out


def _pins() -> dict[str, Version]:
    out = {}
    for raw in CONSTRAINTS.read_text(encoding="utf-8").splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        name, sep, version = line.partition("==")
        assert sep, f"{raw!r}: constraints pin exact versions ('pkg==version')"
        key = canonicalize_name(name.strip())
        assert key not in out, f"{name.strip()} is pinned twice"
        out[key] = Version(version.strip())
    return out


def _same_release(pin: Version, minimum: Version) -> bool:
    """The pin is the minimum, or a post release of it (the minimum itself was yanked)."""
    return pin == minimum or (pin.is_postrelease and Version(pin.base_version) == minimum)


def test_every_core_dependency_is_pinned_at_its_minimum():
    minimums, pins = _minimums(), _pins()
    assert minimums, "pyproject.toml declares no core dependency"
    missing = sorted(set(minimums) - set(pins))
    assert not missing, f"not pinned in {CONSTRAINTS.name}: {missing}"
    differ = {name: (str(minimum), str(pins[name])) for name, minimum in minimums.items()
              if not _same_release(pins[name], minimum)}
    assert not differ, f"pyproject.toml minimum != pinned version: {differ}"


def test_post_release_rule():
    assert _same_release(Version("1.7.1.post1"), Version("1.7.1"))
    assert _same_release(Version("2.0.0"), Version("2.0"))
    assert not _same_release(Version("1.7.2"), Version("1.7.1"))
    assert not _same_release(Version("1.7.1"), Version("1.7.1.post1"))
