"""Rolling at the rods' surfaces in full simulations (docs/physics.md §3.3, docs/validation.md §2.1):
the log roll (rod B carried across rod A, across its own axis) with its ends free to spin and
twist-clamped, and the per-node slip and rolling speeds that record where strands roll."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.validation.contact import H
from knotsim.validation.rolling import log_roll

MU = 0.3


@pytest.fixture(scope="module")
def free():
    return log_roll(twist_clamped=False, mu=MU)


def test_log_roll_with_free_ends_rolls(free):
    assert free["tangential_ratio"] <= 0.05
    assert free["turn"] == pytest.approx(free["carried"] / H, rel=0.02)  # theta = s/h


def test_rolling_contacts_are_recorded_as_rolling_not_slipping(free):
    slip, rolling = free["node_slip"]
    live = np.isfinite(slip)
    assert 0 < live.sum() <= 8  # the nodes of the pairs at the crossing, NaN elsewhere
    speed = 0.01  # B's ends are carried 10 mm in 1 s
    assert np.all(rolling[live] == pytest.approx(speed, rel=0.1))
    assert np.all(slip[live] < 0.01 * speed)


def test_log_roll_with_clamped_twist_slides_like_the_centreline_law():
    held = log_roll(twist_clamped=True, mu=MU)
    slid = log_roll(twist_clamped=False, mu=MU, friction_model="centreline")
    # both slide; the same tangential force (within 1 %), about mu F_n in this set-up
    assert held["tangential_ratio"] == pytest.approx(slid["tangential_ratio"], rel=0.01)
    assert held["tangential_ratio"] == pytest.approx(MU, rel=0.1)
    # B turned only until its halves' twist balanced the friction moment: a few mrad, not s/h
    assert 1e-3 < held["turn"] < 2e-2
    lever = held["tangential_ratio"] * held["normal_force"] * H
    assert held["twist_moment"] == pytest.approx(lever, rel=0.1)
    assert abs(slid["turn"]) < 1e-3
    assert np.all(np.isnan(slid["node_slip"][0]))  # no surface friction, no slip record
