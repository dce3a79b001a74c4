"""Tests of knotsim.knots.topology.closure: closing open ropes (and bends) far from the tangle."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.knots import topology as T

from .curves import (
    circle,
    rope_with_tails,
    rot_z180_shift,
    trefoil_arc,
)

# open ropes and closure
# ---------------------------------------------------------------------------------------------


def test_open_straight_rope_is_unknot():
    rope = np.c_[np.linspace(0, 1, 50), np.zeros(50), np.zeros(50)]
    r = T.analyze([rope])
    assert r.knot_type == "unknot"
    assert r.n_components == 1


@pytest.mark.parametrize("right", [True, False])
def test_open_overhand_arc_closes_to_trefoil(right):
    r = T.analyze([trefoil_arc(right)], [False])
    assert r.knot_type == ("trefoil_right" if right else "trefoil_left")


@pytest.mark.parametrize("method", ["radial", "tangent"])
def test_open_overhand_with_tails(method):
    r = T.analyze([rope_with_tails(True)], closure=method)
    assert r.knot_type == "trefoil_right"
    # the far closure lies on a sphere much larger than the tangle
    comp = r.closed_curves[0]
    assert np.max(np.linalg.norm(comp - comp.mean(axis=0), axis=1)) > 100.0


def test_closure_is_far_and_keeps_the_rope():
    rope = rope_with_tails(True)
    (comp,) = T.close_curves([rope], [False], radius_factor=30.0)
    np.testing.assert_array_equal(comp[: len(rope)], rope)
    c = rope.mean(axis=0)
    R = np.max(np.linalg.norm(rope - c, axis=1))
    far = np.linalg.norm(comp[len(rope) :] - c, axis=1)
    assert np.all(far >= 30.0 * R * (1 - 1e-9))


def _bend_ropes(right_b: bool) -> list[np.ndarray]:
    a = rope_with_tails(True)  # from y = +20 through a right trefoil to y = -20
    b = rot_z180_shift(rope_with_tails(right_b), 9.0)  # from y = -20 to y = +20, to the right
    return [a, b]


@pytest.mark.parametrize(("right_b", "name"), [(True, "granny_right"), (False, "reef")])
def test_bend_pairing_makes_one_knot(right_b, name):
    ropes = _bend_ropes(right_b)
    # each rope closed on itself: two separate trefoils, not linked
    r = T.analyze(ropes)
    assert r.n_components == 2
    assert r.linking[0, 1] == 0
    assert r.component_types == ["trefoil_right", "trefoil_right" if right_b else "trefoil_left"]
    # the bend: ends at y = -20 joined, ends at y = +20 joined -> one component
    pairing = T.bend_pairing(0, 1, pull_end_a=1, pull_end_b=0)
    assert pairing == [((0, 1), (1, 0)), ((0, 0), (1, 1))]
    r = T.analyze(ropes, pairing=pairing)
    assert r.n_components == 1 and r.component_ropes == [[0, 1]]
    assert r.knot_type == name


def test_reversed_rope_in_pairing():
    a, b = _bend_ropes(True)
    r = T.analyze([a, b[::-1]], pairing=[((0, 1), (1, 1)), ((1, 0), (0, 0))])
    assert r.knot_type == "granny_right"


def test_mixed_open_and_closed():
    r = T.analyze([trefoil_arc(True), circle(radius=0.3) + [0, 0, 10.0]], [False, True])
    assert r.n_components == 2
    assert r.component_types == ["trefoil_right", "unknot"]
    assert r.linking[0, 1] == 0


# ---------------------------------------------------------------------------------------------
