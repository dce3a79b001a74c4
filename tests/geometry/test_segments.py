"""Tests of knotsim.geometry.segments against a slow, obvious reference (dense sampling)."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.geometry.segments import clamp01, segment_closest, segment_distance, segment_distances


def sampled_distance(p0, p1, q0, q1, n: int = 301) -> float:
    """Minimum distance over an ``n x n`` grid of ratios ``(s, t)``, refined once around the best one."""
    p0, p1, q0, q1 = (np.asarray(v, dtype=float) for v in (p0, p1, q0, q1))

    def grid_min(ss, tt):
        a = p0 + ss[:, None] * (p1 - p0)
        b = q0 + tt[:, None] * (q1 - q0)
        d = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
        i, j = np.unravel_index(np.argmin(d), d.shape)
        return float(d[i, j]), ss[i], tt[j]

    h = 1.0 / (n - 1)
    d0, s0, t0 = grid_min(np.linspace(0.0, 1.0, n), np.linspace(0.0, 1.0, n))
    d1, _, _ = grid_min(np.clip(np.linspace(s0 - h, s0 + h, n), 0.0, 1.0),
                        np.clip(np.linspace(t0 - h, t0 + h, n), 0.0, 1.0))
    return min(d0, d1)


def check(p0, p1, q0, q1, expected=None, rel=1e-12):
    args = tuple(tuple(float(c) for c in v) for v in (p0, p1, q0, q1))
    d, s, t = segment_closest(*args)
    assert 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0
    # the ratios name an actual pair of points at that distance
    pa = np.asarray(p0, float) + s * (np.asarray(p1, float) - np.asarray(p0, float))
    qb = np.asarray(q0, float) + t * (np.asarray(q1, float) - np.asarray(q0, float))
    assert np.linalg.norm(pa - qb) == pytest.approx(d, abs=1e-12)
    ref = sampled_distance(p0, p1, q0, q1)
    scale = max(np.ptp(np.array([p0, p1, q0, q1], float), axis=0).max(), 1.0)
    assert d <= ref + rel * scale  # never above a sampled pair (up to rounding)
    assert d >= ref - 1e-4 * scale  # and within the sampling resolution of the minimum
    if expected is not None:
        assert d == pytest.approx(expected, abs=1e-14)
    assert segment_distance(*args) == d
    return d


@pytest.mark.parametrize(
    ("p0", "p1", "q0", "q1", "expected"),
    [
        ((0, 0, 0), (1, 0, 0), (0.2, 0.5, 0), (0.8, 0.5, 0), 0.5),  # parallel, overlapping
        ((0, 0, 0), (1, 0, 0), (2, 1, 0), (3, 1, 0), np.sqrt(2.0)),  # parallel, disjoint
        ((0, 0, 0), (1, 0, 0), (0.5, 0, 0), (1.5, 0, 0), 0.0),  # collinear, overlapping
        ((0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0), 1.0),  # collinear, disjoint
        ((0, 0, 0), (1, 0, 0), (3, 0, 0), (2, 0, 0), 1.0),  # collinear, opposite direction
        ((0, 0, 0), (1, 0, 0), (1, 0, 0), (1, 1, 0), 0.0),  # touching at an end
        ((-1, 0, 0), (1, 0, 0), (0, -1, 0.3), (0, 1, 0.3), 0.3),  # crossing at a height
        ((0, 0, 0), (0, 0, 0), (1, -1, 2), (1, 1, 2), np.sqrt(5.0)),  # zero-length first segment
        ((0, 0, 0), (1, 0, 0), (0.5, 2, 0), (0.5, 2, 0), 2.0),  # zero-length second segment
        ((0, 0, 0), (0, 0, 0), (0, 3, 4), (0, 3, 4), 5.0),  # both zero-length
        ((0, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0), 0.0),  # coincident points
    ],
)
def test_degenerate_geometry(p0, p1, q0, q1, expected):
    check(p0, p1, q0, q1, expected)


def test_random_segments_match_sampling():
    rng = np.random.default_rng(11)
    for _ in range(60):
        p0, p1, q0, q1 = rng.normal(size=(4, 3))
        check(p0, p1, q0, q1)
    for eps in (1e-3, 1e-5, 1e-7, 1e-9):  # nearly parallel
        for _ in range(10):
            p0, p1 = rng.normal(size=(2, 3))
            off = rng.normal(size=3)
            q0, q1 = p0 + off, p1 + off + eps * rng.normal(size=3)
            # near the parallel threshold (angle ~ 1e-7) the line solution is ill-conditioned: the
            # result is still a pair of points on the segments, within ~1e-8 of the minimum
            check(p0, p1, q0, q1, rel=1e-7)


def test_tiny_distances_are_not_flushed_to_zero():
    d = segment_distance((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.5, 1e-160, -1.0), (0.5, 1e-160, 1.0))
    assert d == pytest.approx(1e-160, rel=1e-12)


def test_vectorized_wrapper_is_the_scalar_kernel():
    rng = np.random.default_rng(2)
    p0, p1, q0, q1 = (rng.normal(size=(300, 3)) for _ in range(4))
    p1[::10] = p0[::10]  # zero-length
    q1[::7] = q0[::7] + (p1[::7] - p0[::7])  # parallel
    dist, s, t = segment_distances(p0, p1, q0, q1)
    for k in range(300):
        ref = segment_closest(tuple(p0[k]), tuple(p1[k]), tuple(q0[k]), tuple(q1[k]))
        assert (dist[k], s[k], t[k]) == ref
    with pytest.raises(ValueError, match=r"\(K, 3\)"):
        segment_distances(p0[:, :2], p1[:, :2], q0[:, :2], q1[:, :2])


def test_clamp01():
    assert [clamp01(x) for x in (-1.0, 0.0, 0.25, 1.0, 3.0)] == [0.0, 0.0, 0.25, 1.0, 1.0]


def test_one_implementation_is_shared():
    from knotsim.contact import broadphase
    from knotsim.knots import clearance, geometry

    assert broadphase.segment_distance is segment_distance
    assert geometry.segment_distances is segment_distances is clearance.segment_distances
