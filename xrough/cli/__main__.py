"""``python -m xrough.cli``: the ``xrough`` command."""

import sys

from . import main

sys.exit(main())
