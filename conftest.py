import matplotlib
import numpy as np
import pytest
import xarray as xr

matplotlib.use("Agg")


@pytest.fixture(autouse=True)
def _doctest_namespace(doctest_namespace):
    import xrough

    doctest_namespace.update(np=np, xr=xr, xrough=xrough)


@pytest.fixture(autouse=True)
def _nothing_in_memory():
    """Each test starts with no result kept in memory (xrough.memo): none rests on another's."""
    from xrough.memo import forget

    forget()
