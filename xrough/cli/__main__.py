"""``python -m xrough.cli``: the ``xrough`` command."""

import sys

from . import main

if __name__ == "__main__":  # not when a worker process imports it (--jobs)
    sys.exit(main())
