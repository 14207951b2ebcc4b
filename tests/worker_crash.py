"""An analysis whose worker process dies, for the tests of ``xrough acf/report --jobs``.

In a module of its own, importing nothing of the tests: a worker process (spawned)
unpickles it by name, and must not import the test modules or their conftest.
"""

import os


def dies_on_the_profile(G):
    """Analyse G, or end the process at once (a crash) on the measurement named profile."""
    if G.attrs["measurement"] == "profile":
        os._exit(3)
    return {}
