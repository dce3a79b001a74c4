"""The bookkeeping kernels of the contact model (knotsim.contact._model_kernels) give exactly the
numbers of the numpy expressions they replace, NaN and empty cases included."""

import math

import numpy as np
import pytest

from knotsim.contact._model_kernels import gap_summary


def _reference(delta, pair_d, hmin, contact_range):
    """The numpy code of Contact._compute_stats and Contact.check before the kernel."""
    gap = delta - pair_d
    ratio = (pair_d - delta) / hmin
    worst = int(np.argmax(ratio))
    return (int(np.count_nonzero(gap < contact_range)), float(np.min(gap)), worst, float(ratio[worst]),
            float(max(0.0, np.max(-gap / hmin))))


def _same(a, b) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


@pytest.mark.parametrize("case", ["random", "nan_first", "nan_late", "ties", "one", "all_far"])
def test_gap_summary_is_the_numpy_reference(case):
    rng = np.random.default_rng(len(case))
    k = 1 if case == "one" else 57
    pair_d = rng.uniform(2e-3, 4e-3, k)
    hmin = rng.uniform(1e-3, 2e-3, k)
    delta = pair_d + rng.uniform(-1e-3, 2e-3, k)
    if case == "nan_first":
        delta[[3, 9]] = np.nan
    elif case == "nan_late":
        delta[40] = np.nan
    elif case == "ties":
        delta[:] = pair_d - 5e-4
        hmin[:] = 1e-3
    elif case == "all_far":
        delta = pair_d + 1.0
    n, min_gap, worst, ratio = gap_summary(delta, pair_d, hmin, 5e-4)
    rn, rmin, rworst, rratio, rpen = _reference(delta, pair_d, hmin, 5e-4)
    assert n == rn and _same(min_gap, rmin) and worst == rworst and _same(ratio, rratio)
    assert float(max(0.0, ratio)) == rpen
    if case == "ties":
        assert worst == 0
    if case == "nan_first":
        assert worst == 3 and math.isnan(min_gap)


def test_gap_summary_of_no_pairs():
    e = np.zeros(0)
    n, min_gap, worst, ratio = gap_summary(e, e, e, 1e-3)
    assert (n, min_gap, worst, ratio) == (0, math.inf, 0, -math.inf)
