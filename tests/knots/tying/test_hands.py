"""Hands of the tying sequences (knotsim.knots.tying.hands): paths that never stretch the rod,
mirror images, and the [[bc]] tables they become."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.knots.tying import hands as th


def _straight(n: int, length: float) -> np.ndarray:
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0.0, length, n)
    return x


def test_overhand_hands_never_stretch_the_rod():
    hands, _ = th.overhand_hands()
    ratio, _, _ = th.hand_stretch(hands, 0.8 / 128)
    assert 0.5 < ratio < 1.01


def test_overhand_hands_grip_the_loop_and_both_ends():
    hands, info = th.overhand_hands()
    names = [h.name for h in hands]
    assert names == ["loop_in", "loop_q1", "loop_top", "loop_q3", "loop_out", "tail", "end_b", "end_a"]
    assert info["loop_nodes"] == [h.nodes[0] for h in hands[:5]]
    assert hands[-2].nodes == [128] and hands[-1].nodes == [0, 1]
    x0 = _straight(129, 0.8)
    for h in hands:  # every path starts where its nodes are on the straight rod, times increasing
        assert len(h.times) == len(h.points) and np.all(np.diff(h.times) >= 0.0)
        h.to_bc(x0)  # raises unless the first point is the nodes' centroid


def test_to_bc_displacements_from_the_centroid():
    x0 = _straight(11, 1.0)
    h = th.Hand("grip", [4, 5, 6], [1.0, 2.0, 3.5], [x0[5], x0[5] + [0.0, 0.1, 0.0], x0[5] + [0.2, 0.1, 0.0]],
                stop=4.0, twist=True)
    bc = h.to_bc(x0)
    assert bc["type"] == "move" and bc["rod"] == "rope" and bc["nodes"] == [4, 5, 6] and bc["twist"] is True
    assert bc["start"] == 1.0 and bc["stop"] == 4.0
    assert bc["waypoints"]["times"] == [0.0, 1.0, 2.5]
    np.testing.assert_allclose(bc["waypoints"]["points"], [[0.0, 0.0, 0.0], [0.0, 0.1, 0.0], [0.2, 0.1, 0.0]],
                               atol=1e-12)


def test_to_bc_first_point_must_be_the_centroid():
    x0 = _straight(11, 1.0)
    with pytest.raises(ValueError, match="not the centroid"):
        th.Hand("grip", [3], [0.0, 1.0], [x0[4], x0[4]]).to_bc(x0)


def test_to_bc_relative_hand_ignores_where_it_starts():
    x0 = _straight(11, 1.0)
    bc = th.Hand("regrip", [3], [2.0, 3.0], [[5.0, 5.0, 5.0], [5.0, 5.5, 5.0]], rel=True).to_bc(x0)
    assert "twist" not in bc and "stop" not in bc
    np.testing.assert_allclose(bc["waypoints"]["points"], [[0.0, 0.0, 0.0], [0.0, 0.5, 0.0]])
