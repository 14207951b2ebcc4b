"""Command line: ``xrough demo | info | acf | report``, one module per command.

``xrough demo`` generates a synthetic self-affine surface, computes its G(dr) with both
estimators, compares them with the exact G of the model spectrum (eq. 9), fits G, runs the
contact mechanics (elastic energy, real-space Persson theory, adhesive patch radius),
archives the results to NetCDF, draws a figure and prints a summary table.

``xrough info`` describes topography files, ``xrough acf`` archives their G(dr) and
``xrough report`` runs the contact mechanics on each and prints a table. Every printed
number carries its own unit (heights in the height unit, lags in the lateral unit, with a
readable prefix); ``--json`` prints the same as JSON (numbers in the units of the results,
with ``units`` fields). Exit status: 0 success, 1 bad input or data (one line on stderr
naming the file or argument), 2 usage error.

Errors speak the command line's words: the options are checked before the library is
called, and a file that reads only with a unit, a size or ``--resample`` is named with
the option to give.
"""

from __future__ import annotations

import os
import sys
import traceback
import warnings

from ._common import EXIT_DATA, EXIT_OK, EXIT_USAGE, CLIError, first_line, show_warning
from ._files import expand_folders
from ._parser import parse

__all__ = ["main", "EXIT_OK", "EXIT_DATA", "EXIT_USAGE"]


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``xrough`` command.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0 success, 1 bad input or data (after one line on stderr naming the
        file or argument). Usage errors exit with status 2 (``SystemExit``, argparse's).
    """
    args = parse(sys.argv[1:] if argv is None else list(argv))
    args.console = argv is None  # --jobs 0 takes the cores only from the command line
    try:
        if getattr(args, "files", None):  # a folder stands for the measurements in it
            args.files = expand_folders(args.files)
        with warnings.catch_warnings():
            warnings.simplefilter("default")  # shown once each, as one line
            warnings.showwarning = show_warning
            return args.func(args)
    except KeyboardInterrupt:
        print("xrough: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. ``xrough info --all scan.spm | head``: stop quietly
        _silence_stdout()
        return EXIT_DATA
    except Exception as err:  # noqa: BLE001 - every error is one line, exit status 1
        if args.traceback:
            traceback.print_exc()
        print(f"xrough: error: {_one_line(err)}", file=sys.stderr)
        return EXIT_DATA


def _one_line(err: Exception) -> str:
    """Return the error's first line; its type too where the message is not for users."""
    message = first_line(err)
    if isinstance(err, (CLIError, ValueError, OSError)):
        return message
    return f"{type(err).__name__}: {message}" if message else type(err).__name__


def _silence_stdout() -> None:
    """Send what is left for a closed pipe to the null device."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass
