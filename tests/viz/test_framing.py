"""The box a picture is framed on (knotsim.viz.framing): the knot, not the tails."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.errors import ConfigError
from knotsim.viz.framing import contact_mask, knot_mask, knot_region, trajectory_knot_region

R = 0.01  # rope radius, m


def _crossing(tail: float = 10.0, n: int = 2001):
    """Rope a along x and rope b along y, touching at the origin (b above a by 2 R), each with
    tails reaching +-tail m (edges of 1 cm)."""
    s = np.linspace(-tail, tail, n)
    a = np.column_stack([s, 0 * s, 0 * s])
    b = np.column_stack([0 * s, s, 0 * s + 1.9 * R])
    return a, b


def test_two_crossing_ropes_frame_the_crossing():
    a, b = _crossing()
    lo, hi = knot_region([a, b], R, margin=3.0)
    # the crossing's nodes (within ~2.4 R + half an edge of the other rope) plus 3 diameters and a radius
    pad = 3.0 * 2 * R + R
    assert np.all(hi - lo < 2 * (2.5 * R + 0.005 + pad) + 1e-12), hi - lo
    assert np.all(lo < 0) and np.all(hi > [0, 0, 1.9 * R])  # around the crossing
    assert np.all(hi - lo > 2 * pad - 1e-12)
    masks = contact_mask([a, b], R)
    assert 1 <= masks[0].sum() <= 5 and 1 <= masks[1].sum() <= 5
    assert masks[0][1000] and masks[1][1000]  # the two nodes at the crossing


def test_a_rope_does_not_touch_its_own_neighbours():
    s = np.linspace(0, 1, 101)  # a straight rope: 1 cm edges, 1 cm radius (nodes closer than 2 R)
    line = np.column_stack([s, 0 * s, 0 * s])
    assert not contact_mask([line], R)[0].any()
    lo, hi = knot_region([line], R)  # no contact, one rope: the whole rope
    np.testing.assert_allclose(lo, [-R, -R, -R])
    np.testing.assert_allclose(hi, [1 + R, R, R])


def test_legs_side_by_side_are_not_the_knot():
    """A rope folded back on itself (a long U, legs 2 R apart) crossed by a second rope near the
    fold: the legs touch all along, but the knot is where the second rope crosses them."""
    s = np.linspace(0.0, 5.0, 501)
    leg1 = np.column_stack([s, 0 * s, 0 * s])
    turn = np.column_stack([-R * np.sin(np.linspace(0, np.pi, 7)[1:-1]), R - R * np.cos(np.linspace(0, np.pi, 7)[1:-1]),
                            np.zeros(5)])
    leg2 = np.column_stack([s, 0 * s + 2 * R, 0 * s])
    u = np.vstack([leg1[::-1], turn, leg2])
    y = np.linspace(-2.0, 2.0, 401)
    cross = np.column_stack([0 * y + 0.05, y, 0 * y + 2 * R])
    assert contact_mask([u, cross], R)[0].sum() > 400  # the legs touch all along
    assert knot_mask([u, cross], R)[0].sum() < 20
    lo, hi = knot_region([u, cross], R)
    assert hi[0] - lo[0] < 0.25 and hi[1] - lo[1] < 0.25  # the fold and the crossing, not the 5 m legs


def test_apart_frames_the_closest_approach():
    """Two ropes far apart, end to end along x with a 1 m gap: the two facing ends."""
    s = np.linspace(0.0, 10.0, 101)
    a = np.column_stack([-1.0 - s, 0 * s, 0 * s])
    b = np.column_stack([s, 0 * s, 0 * s])
    lo, hi = knot_region([a, b], R)
    assert lo[0] > -1.2 and hi[0] < 0.2  # the gap and a little more, not the 21 m
    assert lo[0] < -1.0 and hi[0] > 0.0


class _Traj:
    """The part of a Trajectory that trajectory_knot_region reads."""

    def __init__(self, frames):
        self.frames = frames
        self.rod_radius = np.full(len(frames[0]), R)
        self.rod_closed = np.zeros(len(frames[0]), bool)

    @property
    def n_frames(self):
        return len(self.frames)

    def centerlines(self, i):
        return [c.copy() for c in self.frames[i]]


def test_a_knot_that_just_came_apart_keeps_its_frame():
    a, b = _crossing(tail=2.0, n=401)
    lifted = [a, b + [0.0, 0.0, 0.1]]       # b lifted 10 cm: out of the crossing's box
    shifted = [a, b + [0.0, 0.0, 3 * R]]    # b just lifted off a (a gap of 1 R)
    away = [a - [50.0, 0, 0], b + [50.0, 0, 0]]  # the ropes pulled 100 m apart
    traj = _Traj([[a, b], shifted, lifted, away])
    first = trajectory_knot_region(traj, 0)
    assert first.source == "contact" and first.frame == 0
    just = trajectory_knot_region(traj, 1)
    assert just.source == "earlier" and just.frame == 0
    np.testing.assert_allclose(just.box, first.box)
    assert trajectory_knot_region(traj, 2).source == "closest"
    gone = trajectory_knot_region(traj, 3)
    assert gone.source == "closest" and gone.frame is None
    assert np.ptp(gone.box[0]) > 50  # between the two ropes, wherever they are
    with pytest.raises(ConfigError, match="frame"):
        trajectory_knot_region(traj, 4)


def test_bad_input():
    with pytest.raises(ConfigError, match="radius"):
        knot_region([np.zeros((3, 3))], -1.0)
    with pytest.raises(ConfigError, match="centerlines"):
        knot_region([], 1.0)
