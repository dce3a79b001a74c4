"""Tests of knotsim.knots.clearance: segment distances, closest edge pair, same-rope gap."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.knots import geometry as G

from .brute import brute_min_clearance, brute_segment_distance


def test_segment_distances_match_bruteforce():
    rng = np.random.default_rng(1)
    k = 4000
    p0, p1, q0, q1 = (rng.normal(size=(k, 3)) for _ in range(4))
    # degenerate families: parallel, collinear overlapping, collinear disjoint, touching, crossing
    x = np.array([1.0, 0.0, 0.0])
    p0[:4], p1[:4] = np.zeros((4, 3)), np.tile(x, (4, 1))
    q0[:4] = [[0.2, 0.5, 0.0], [0.5, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 0.0, 0.0]]
    q1[:4] = [[0.8, 0.5, 0.0], [1.5, 0.0, 0.0], [3.0, 0.0, 0.0], [1.0, 1.0, 0.0]]
    p0[4], p1[4], q0[4], q1[4] = [-1, 0, 0], [1, 0, 0], [0, -1, 0.3], [0, 1, 0.3]
    dist, s, t = G.segment_distances(p0, p1, q0, q1)
    ref = brute_segment_distance(p0, p1, q0, q1)
    np.testing.assert_allclose(dist, ref, atol=1e-12)
    np.testing.assert_allclose(dist[:5], [0.5, 0.0, 1.0, 0.0, 0.3], atol=1e-14)
    assert np.all((s >= 0) & (s <= 1) & (t >= 0) & (t <= 1))
    # the ratios give the closest points
    pa = p0 + s[:, None] * (p1 - p0)
    qb = q0 + t[:, None] * (q1 - q0)
    np.testing.assert_allclose(np.linalg.norm(pa - qb, axis=1), dist, atol=1e-12)


def test_closest_edge_pair_is_exact_and_skips_neighbours():
    rng = np.random.default_rng(7)
    ropes = [np.cumsum(rng.normal(scale=0.01, size=(120, 3)), axis=0),
             np.cumsum(rng.normal(scale=0.01, size=(80, 3)), axis=0) + 0.02]
    cp = G.closest_edge_pair(ropes, 0.003, ("a", "b"), min_gap=3)
    dist, (ri, ei, rj, ej) = brute_min_clearance(ropes, 3)
    assert cp.distance == pytest.approx(dist, abs=1e-14)
    assert {(cp.rope_a, cp.edge_a), (cp.rope_b, cp.edge_b)} == {(ri, ei), (rj, ej)}
    # a straight rope: adjacent edges are never reported; |i-j| = 3 edges are 2 l apart
    line = np.c_[np.linspace(0, 1, 11), np.zeros(11), np.zeros(11)]
    assert G.closest_edge_pair([line], 0.01, min_gap=3).distance == pytest.approx(0.2)


def test_same_rope_min_gap():
    assert G.same_rope_min_gap(1.0 / 300, 3.2e-3) == 3      # published overhand set-up
    assert G.same_rope_min_gap(1.0 / 300, 4.0e-3) == 3      # published reef/granny set-up
    assert G.same_rope_min_gap(1.0 / 1000, 4.0e-3) == 7     # fine: skip pairs closer than 1.5 d
    # with that gap a straight fine rope has no spurious overlap
    assert G.same_rope_min_gap(1e-3, 4e-3) * 1e-3 - 1e-3 >= 1.5 * 4e-3
