"""Sorting kernels of the broad phases against numpy."""

import numpy as np
import pytest

from knotsim._util.sorting import argsort_stable, median


@pytest.mark.parametrize("n", [0, 1, 2, 3, 8, 101, 1000])
@pytest.mark.parametrize("kind", ["float", "ties", "int64", "strided"])
def test_argsort_stable_and_median_match_numpy(n, kind):
    rng = np.random.default_rng(n)
    if kind == "float":
        x = rng.random(n)
    elif kind == "ties":
        x = rng.integers(0, 4, n).astype(float)
    elif kind == "int64":
        x = rng.integers(0, 1 << 60, n)
    else:
        x = rng.random((n, 3))[:, 1]  # a non-contiguous column, as the swept broad phase passes
    np.testing.assert_array_equal(argsort_stable(x), np.argsort(x, kind="stable"))
    if n:
        assert median(x) == np.median(x)
    else:
        assert np.isnan(median(x))
