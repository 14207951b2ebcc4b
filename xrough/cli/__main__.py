"""``python -m xrough.cli``: the ``xrough`` command."""

import sys

from . import main

if __name__ == "__main__":  # importing the module does not run the command
    sys.exit(main())
