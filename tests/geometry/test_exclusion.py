"""Tests of knotsim.geometry.exclusion: the same-rod rule against a direct loop."""

from __future__ import annotations

import math

import numpy as np

from knotsim.geometry.exclusion import (
    ARC_GAP_FACTOR,
    MIN_INDEX_GAP,
    index_distance,
    min_index_gap,
    pairs_allowed,
)


def test_min_index_gap():
    assert MIN_INDEX_GAP == 3 and ARC_GAP_FACTOR == 1.5
    assert min_index_gap(1.0 / 300, 3.2e-3) == 3  # published overhand set-up
    assert min_index_gap(1.0 / 1000, 4.0e-3) == 7  # fine mesh: pairs closer than 1.5 d skipped
    for l, d in ((1e-3, 4e-3), (2e-3, 3e-3), (1e-4, 3.2e-3)):
        g = min_index_gap(l, d)
        assert (g - 1) * l >= ARC_GAP_FACTOR * d - 1e-12 or g == MIN_INDEX_GAP
        assert g == MIN_INDEX_GAP or (g - 2) * l < ARC_GAP_FACTOR * d
    # exact multiples are not bumped up by rounding
    assert min_index_gap(1.0, 2.0) == math.ceil(1.5 * 2.0) + 1


def test_index_distance_is_cyclic_on_closed_rods():
    assert index_distance(0, 9, 10, False) == 9
    assert index_distance(0, 9, 10, True) == 1
    assert index_distance(2, 7, 10, True) == 5


def test_pairs_allowed_matches_a_direct_loop():
    rng = np.random.default_rng(0)
    n_edges = np.array([12, 9, 15])
    closed = np.array([False, True, True])
    gaps = np.array([3, 4, 5])
    edge_rod = np.repeat(np.arange(3), n_edges)
    edge_local = np.concatenate([np.arange(n) for n in n_edges])
    pairs = rng.integers(0, n_edges.sum(), size=(400, 2))
    mask = pairs_allowed(pairs, edge_rod, edge_local, n_edges, closed, gaps)
    for (a, b), ok in zip(pairs, mask, strict=True):
        ra, rb = edge_rod[a], edge_rod[b]
        if ra != rb:
            assert ok
            continue
        k = abs(int(edge_local[a]) - int(edge_local[b]))
        if closed[ra]:
            k = min(k, int(n_edges[ra]) - k)
        assert ok == (k >= gaps[ra])
    # a scalar gap applies to every rod
    np.testing.assert_array_equal(pairs_allowed(pairs, edge_rod, edge_local, n_edges, closed, 3),
                                  pairs_allowed(pairs, edge_rod, edge_local, n_edges, closed, np.full(3, 3)))
