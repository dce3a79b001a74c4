"""Tests of knotsim.geometry.planar against an all-pairs reference and hand-made degenerate cases."""

from __future__ import annotations

import numpy as np

from knotsim.geometry.planar import DEGENERACY, segment_crossings


def brute_crossings(x, y, seg0, seg1):
    """All pairs of segments that do not share a node and intersect at ratios in [0, 1)."""
    out = set()
    for a in range(len(seg0)):
        for b in range(a + 1, len(seg0)):
            if {seg0[a], seg1[a]} & {seg0[b], seg1[b]}:
                continue
            p = np.array([x[seg0[a]], y[seg0[a]]])
            r = np.array([x[seg1[a]], y[seg1[a]]]) - p
            q = np.array([x[seg0[b]], y[seg0[b]]])
            u = np.array([x[seg1[b]], y[seg1[b]]]) - q
            m = np.array([r, -u]).T
            if abs(np.linalg.det(m)) < 1e-12:
                continue
            s, t = np.linalg.solve(m, q - p)
            if 0 <= s < 1 and 0 <= t < 1:
                out.add((a, b, round(float(s), 9), round(float(t), 9)))
    return out


def as_set(sa, ta, sb, tb):
    out = set()
    for a, s, b, t in zip(sa, ta, sb, tb, strict=True):
        if a > b:
            a, b, s, t = b, a, t, s
        out.add((int(a), int(b), round(float(s), 9), round(float(t), 9)))
    return out


def test_random_polylines_match_all_pairs():
    rng = np.random.default_rng(4)
    for n_ropes in (1, 3):
        counts = rng.integers(20, 60, size=n_ropes)
        pts = [np.cumsum(rng.normal(size=(c, 2)), axis=0) for c in counts]
        x, y = np.concatenate(pts).T
        off = np.concatenate([[0], np.cumsum(counts)])
        seg0 = np.concatenate([np.arange(off[r], off[r + 1] - 1) for r in range(n_ropes)])
        seg1 = seg0 + 1
        sa, ta, sb, tb, flag = segment_crossings(x, y, seg0, seg1, half_open=True, eps_parallel=1e-14)
        assert flag == 0
        ref = brute_crossings(x, y, seg0, seg1)
        assert len(ref) > 5
        assert as_set(sa, ta, sb, tb) == ref


def test_closed_polygon_and_signs_of_a_figure_of_eight():
    # a closed "figure 8": one crossing, at the middle of two diagonals
    x = np.array([0.0, 1.0, 1.0, 0.0])
    y = np.array([0.0, 1.0, 0.0, 1.0])
    nxt = np.array([1, 2, 3, 0])
    sa, ta, sb, tb, flag = segment_crossings(x, y, np.arange(4), nxt, h=np.zeros(4) + [0, 0, 1, 1],
                                             eps_len=1e-12, eps_h=1e-12)
    assert flag == 0 and len(sa) == 1
    assert {int(sa[0]), int(sb[0])} == {0, 2}
    np.testing.assert_allclose([ta[0], tb[0]], [0.5, 0.5])


def test_degeneracies_are_flagged_in_strict_mode():
    seg0, seg1 = np.array([0, 2]), np.array([1, 3])
    cases = {
        1: ([0.0, 2.0, 1.0, 1.0], [0.0, 0.0, 0.0, 1.0]),  # crossing at a vertex (T junction)
        3: ([0.0, 2.0, 1.0, 3.0], [0.0, 0.0, 0.0, 0.0]),  # collinear overlapping segments
        5: ([0.0, 0.0, 1.0, 1.0], [0.0, 0.0, -1.0, 1.0]),  # zero-length projected segment
    }
    for flag, (x, y) in cases.items():
        *_, got = segment_crossings(np.array(x), np.array(y), seg0, seg1, eps_len=1e-12)
        assert got == flag, DEGENERACY[flag]
    # parallel, apart: no crossing, no flag
    sa, *_, got = segment_crossings(np.array([0.0, 2.0, 0.0, 2.0]), np.array([0.0, 0.0, 1.0, 1.0]),
                                    seg0, seg1, eps_len=1e-12)
    assert len(sa) == 0 and got == 0
    # the strands meet in 3D: flag 4
    x, y = np.array([-1.0, 1.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0, 1.0])
    *_, got = segment_crossings(x, y, seg0, seg1, h=np.zeros(4), eps_len=1e-12, eps_h=1e-12)
    assert got == 4


def test_half_open_counts_a_crossing_at_a_node_once():
    # rope 0 bends exactly on the line of rope 1: the crossing is at node 1 of rope 0
    x = np.array([-1.0, 0.0, 1.0, 0.0, 0.0])
    y = np.array([-1.0, 0.0, 1.0, -2.0, 2.0])
    seg0, seg1 = np.array([0, 1, 3]), np.array([1, 2, 4])
    sa, ta, sb, tb, flag = segment_crossings(x, y, seg0, seg1, half_open=True, eps_parallel=1e-14)
    assert flag == 0 and len(sa) == 1
