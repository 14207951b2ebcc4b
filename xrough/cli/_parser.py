"""The parser of ``xrough``, built from each command's ``add_parser``."""

from __future__ import annotations

import argparse
from typing import Any

from .._version import __version__
from . import acf, demo, info, report

_EPILOG = """\
exit status:
  0  success
  1  bad input or data (missing or unreadable file, wrong unit or value, failed
     computation); one line on stderr names the file or argument
  2  usage error (unknown command or option, missing argument)

Every printed number carries its unit; --json prints machine-readable output instead
(numbers in the results' own units, each with a "units" field)."""

#: The commands, in the order ``xrough --help`` lists them.
COMMANDS = (demo, info, acf, report)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors take two lines, not the whole usage."""

    def error(self, message: str):
        """Print what is wrong and where the usage is, and exit with status 2."""
        self.exit(2, f"{self.prog}: error: {message}\n(usage: {self.prog} --help)\n")


def parser() -> argparse.ArgumentParser:
    """Build the parser of ``xrough`` and its commands."""
    common: dict[str, Any] = {"epilog": _EPILOG,
                              "formatter_class": argparse.RawDescriptionHelpFormatter}
    p = _Parser(
        prog="xrough", description="Contact mechanics of rough surfaces from the "
        "height-difference autocorrelation function G(dr).", **common)
    p.add_argument("--version", action="version", version=f"xrough {__version__}")
    p.add_argument("--traceback", action="store_true",
                   help="on an error, show the full traceback (for bug reports)")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for command in COMMANDS:
        command.add_parser(sub, **common)
    return p


def parse(argv: list[str]) -> argparse.Namespace:
    """Parse the arguments of ``xrough``; a negative quantity (``--E-star -25MPa``) is a value."""
    return parser().parse_args(report.negative_values_attached(argv))
