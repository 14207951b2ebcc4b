"""The installed version of xrough (one place, imported by every module that records it)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("xrough")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
