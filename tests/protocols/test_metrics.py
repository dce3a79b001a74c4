"""Strength metrics on synthetic logs."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from knotsim.errors import ConfigError
from knotsim.protocols import metrics as M


def _log(t, f, **cols):
    return pd.DataFrame({"time": t, "F_norm": f, **cols})


def test_window_mean_and_peak():
    t = np.linspace(0.0, 10.0, 1001)
    log = _log(t, t.copy())
    assert M.window_mean(log, "F_norm", 0.0, 10.0) == pytest.approx(5.0)
    assert M.window_mean(log, "F_norm", 2.0, 4.0) == pytest.approx(3.0)
    assert M.window_peak(log, "F_norm", 0.0, 5.0) == pytest.approx(5.0)
    assert math.isnan(M.window_mean(log, "F_norm", 20.0, 30.0))
    # non-uniform steps: the mean is time-weighted
    t2 = np.array([0.0, 0.1, 10.0])
    assert M.window_mean(_log(t2, np.array([0.0, 0.0, 1.0]))) == pytest.approx(0.5 * 9.9 / 10.0)


def test_force_at_interpolates_first_crossing():
    t = np.linspace(0, 1, 11)
    e = 0.7 - 0.5 * t  # decreasing, like the overhand shortening
    log = _log(t, 2.0 * t, e=e)
    assert M.force_at(log, "e", 0.45) == pytest.approx(1.0)
    assert math.isnan(M.force_at(log, "e", 0.1))


def test_slip_onset_drop():
    t = np.linspace(0, 10, 1001)
    f = np.where(t < 6.0, t, 0.3 * t)  # rises to 6, drops to 1.8 at t = 6
    res = M.slip_onset(_log(t, f), drop_fraction=0.2)
    assert res is not None
    assert res["time"] == pytest.approx(6.0, abs=0.011)
    assert res["force"] == pytest.approx(6.0, abs=0.02)
    assert res["detected_at"] >= res["time"]
    # monotone force: no slip
    assert M.slip_onset(_log(t, t)) is None
    # a small wiggle below the threshold is not a slip
    assert M.slip_onset(_log(t, t + 0.05 * np.sin(20 * t)), drop_fraction=0.2, min_force=0.5) is None
    # noise is smoothed away
    rng = np.random.default_rng(0)
    noisy = t + 0.5 * rng.standard_normal(t.size)
    assert M.slip_onset(_log(t, noisy), drop_fraction=0.2, min_force=2.0, smooth=0.5) is None


def test_slip_onset_plateau():
    t = np.linspace(0, 10, 1001)
    f = np.minimum(t, 4.0)  # stops increasing at t = 4
    res = M.slip_onset(_log(t, f), mode="plateau", drop_fraction=0.01, plateau_time=1.0)
    assert res["time"] == pytest.approx(4.0, abs=0.011)
    assert res["detected_at"] == pytest.approx(5.0, abs=0.05)
    with pytest.raises(ConfigError, match="mode"):
        M.slip_onset(_log(t, f), mode="bogus")


def test_tail_draw_in_and_status():
    log = pd.DataFrame({"time": [0, 1, 2], "tail": [0.30, 0.25, 0.21], "u": [0.0, 0.01, 0.05]})
    assert M.tail_draw_in(log, "tail") == pytest.approx(0.09)
    assert M.tail_draw_in(log, "u", kind="increase") == pytest.approx(0.05)
    with pytest.raises(ConfigError, match="nope"):
        M.tail_draw_in(log, "nope")
    assert M.knot_status("reef", "reef") == "held"
    assert M.knot_status("reef", "reef", slipped=True) == "slipped"
    assert M.knot_status("trefoil_right", "unknot") == "untied"
    assert M.knot_status("reef", "granny_left") == "changed knot type"
    assert M.knot_status(None, "reef") == "unknown"
    assert M.normalized_force(2.0, 0.1, 0.01) == pytest.approx(2.0)
