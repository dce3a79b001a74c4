"""Tests of the contact broad phase against an obvious O(N^2) reference."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from knotsim.contact.broadphase import find_candidate_pairs, segment_distance

# ---------------------------------------------------------------------------------------------
# helpers


def build(rods):
    """Global arrays for ``rods``: a list of ``(points (N, 3) m, closed, radius scalar or (n_e,))``.

    Layout as in docs/architecture.md: node k of a rod at ``4k..4k+2``, twist of edge k at ``4k+3``.
    Returns the argument tuple of :func:`find_candidate_pairs` without ``extra``.
    """
    q_parts, edge_dofs, edge_rod, edge_local, rod_n_edges, rod_closed, radii = [], [], [], [], [], [], []
    start = 0
    for r, (pts, closed, rad) in enumerate(rods):
        pts = np.asarray(pts, dtype=float)
        n = len(pts)
        ne = n if closed else n - 1
        block = np.zeros(4 * n if closed else 4 * n - 1)
        for k in range(n):
            block[4 * k : 4 * k + 3] = pts[k]
        q_parts.append(block)
        for k in range(ne):
            edge_dofs.append((start + 4 * k, start + 4 * ((k + 1) % n)))
            edge_rod.append(r)
            edge_local.append(k)
        rod_n_edges.append(ne)
        rod_closed.append(closed)
        radii.append(np.broadcast_to(np.asarray(rad, dtype=float), (ne,)))
        start += len(block)
    return (
        np.concatenate(q_parts) if q_parts else np.zeros(0),
        np.asarray(edge_dofs, dtype=np.int64).reshape(-1, 2),
        np.asarray(edge_rod, dtype=np.int64),
        np.asarray(edge_local, dtype=np.int64),
        np.asarray(rod_n_edges, dtype=np.int64),
        np.asarray(rod_closed, dtype=bool),
        np.concatenate(radii) if radii else np.zeros(0),
    )


def _norm(v):
    """Row norms of (m, 3) without underflow of the squares."""
    return np.hypot(np.hypot(v[:, 0], v[:, 1]), v[:, 2])


def _point_segment(x, a, b):
    """Distance from points x to segments [a, b] (all (m, 3)); zero-length segments are points."""
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    t = np.einsum("ij,ij->i", x - a, d) / np.where(dd > 0, dd, 1.0)
    t = np.clip(np.where(dd > 0, t, 0.0), 0.0, 1.0)
    return _norm(x - (a + t[:, None] * d))


def reference_distance(p0, p1, q0, q1):
    """Segment-segment distance, (m, 3) arrays -> (m,): min over the interior critical point and
    the four end-point-to-segment distances (an exhaustive case analysis, independent of the
    clamping algorithm of the library)."""
    cands = [
        _point_segment(p0, q0, q1),
        _point_segment(p1, q0, q1),
        _point_segment(q0, p0, p1),
        _point_segment(q1, p0, p1),
    ]
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("ij,ij->i", d1, d1)
    b = np.einsum("ij,ij->i", d1, d2)
    c = np.einsum("ij,ij->i", d1, r)
    e = np.einsum("ij,ij->i", d2, d2)
    f = np.einsum("ij,ij->i", d2, r)
    den = a * e - b * b
    ok = den > 1e-12 * a * e
    safe = np.where(ok, den, 1.0)
    s = (b * f - c * e) / safe
    t = (a * f - b * c) / safe
    ok &= (s >= 0) & (s <= 1) & (t >= 0) & (t <= 1)
    interior = _norm((p0 + s[:, None] * d1) - (q0 + t[:, None] * d2))
    cands.append(np.where(ok, interior, np.inf))
    return np.min(cands, axis=0)


def brute_force_pairs(
    q, edge_dofs, edge_rod, edge_local, rod_n_edges, rod_closed, edge_radius, extra, return_margin=False
):
    """O(N^2) reference with the same signature as ``find_candidate_pairs``.

    With ``return_margin`` returns ``(pairs, ambiguous)``, ``ambiguous`` being the set of
    non-excluded pairs whose distance is within rounding (1e-9 relative) of the cut-off: two correct
    implementations may round those either way, so either answer is accepted there.
    """
    ne = len(edge_dofs)
    a, b = np.triu_indices(ne, k=1)
    same = edge_rod[a] == edge_rod[b]
    di = np.abs(edge_local[a] - edge_local[b])
    n = rod_n_edges[edge_rod[a]]
    di = np.where(rod_closed[edge_rod[a]], np.minimum(di, n - di), di)
    keep = ~(same & (di < 3))
    a, b = a[keep], b[keep]
    pts = lambda idx, end: np.stack([q[edge_dofs[idx, end] + k] for k in range(3)], axis=1)  # noqa: E731
    dist = reference_distance(pts(a, 0), pts(a, 1), pts(b, 0), pts(b, 1))
    cut = edge_radius[a] + edge_radius[b] + extra
    pairs = np.stack([a, b], axis=1).astype(np.int64)[dist < cut]
    if not return_margin:
        return pairs
    scale = np.max(np.abs(q)) if len(q) else 0.0
    tol = 1e-9 * cut + 1e-12 * scale
    ambiguous = {
        (int(x), int(y))
        for x, y in zip(a[np.abs(dist - cut) <= tol], b[np.abs(dist - cut) <= tol], strict=True)
    }
    return pairs, ambiguous


def check_against_reference(args, extra):
    got = find_candidate_pairs(*args, extra)
    assert got.dtype == np.int64 and got.ndim == 2 and got.shape[1] == 2
    if len(got):
        assert np.all(got[:, 0] < got[:, 1])
        keys = got[:, 0] * len(args[1]) + got[:, 1]
        assert np.all(np.diff(keys) > 0), "rows must be sorted and unique"
    got_set = {tuple(map(int, p)) for p in got}
    # 1. bit-exact: the grid must neither miss nor invent pairs (same distance kernel, all pairs)
    q, edge_dofs, edge_rod, edge_local, rod_n_edges, rod_closed, edge_radius = args
    exact = set()
    for a, b in itertools.combinations(range(len(edge_dofs)), 2):
        if edge_rod[a] == edge_rod[b]:
            di = abs(int(edge_local[a]) - int(edge_local[b]))
            if rod_closed[edge_rod[a]]:
                di = min(di, int(rod_n_edges[edge_rod[a]]) - di)
            if di < 3:
                continue
        ends = [
            tuple(float(x) for x in q[edge_dofs[e, k] : edge_dofs[e, k] + 3]) for e in (a, b) for k in (0, 1)
        ]
        if segment_distance(*ends) < edge_radius[a] + edge_radius[b] + extra:
            exact.add((a, b))
    assert got_set == exact, f"grid mismatch {sorted(got_set ^ exact)[:10]}"
    # 2. independent reference, up to rounding at the cut-off
    ref, ambiguous = brute_force_pairs(*args, extra, return_margin=True)
    ref_set = {tuple(map(int, p)) for p in ref}
    diff = got_set ^ ref_set
    assert diff <= ambiguous, f"mismatch {sorted(diff - ambiguous)[:10]}"
    return got


# ---------------------------------------------------------------------------------------------
# property test


@st.composite
def scenes(draw):
    """Several clustered rods (open and closed), some on a coarse lattice (parallel / coincident
    segments, zero-length edges), some copies of others, random radii and extra."""
    n_rods = draw(st.integers(1, 4))
    box = draw(st.sampled_from([2e-3, 8e-3, 30e-3]))
    lattice = draw(st.sampled_from([0.0, 1e-3, 2.5e-3]))
    unit = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
    rods = []
    for _ in range(n_rods):
        if rods and draw(st.integers(0, 4)) == 0:
            pts, closed, rad = rods[draw(st.integers(0, len(rods) - 1))]
            shift = np.array(draw(st.tuples(unit, unit, unit))) * box * draw(st.sampled_from([0.0, 0.3]))
            rods.append((pts + shift, closed, rad))  # coincident or translated copy (parallel)
            continue
        closed = draw(st.booleans())
        n_nodes = draw(st.integers(3 if closed else 2, 12))
        centre = np.array(draw(st.tuples(unit, unit, unit))) * box
        step = box * draw(st.sampled_from([0.1, 0.4, 1.0]))
        walk = np.array(draw(st.lists(st.tuples(unit, unit, unit), min_size=n_nodes, max_size=n_nodes)))
        pts = centre + np.cumsum(walk * step, axis=0)
        if lattice > 0:
            pts = np.round(pts / lattice) * lattice
        ne = n_nodes if closed else n_nodes - 1
        if draw(st.booleans()):
            rad = draw(st.floats(0.0, 3e-3))
        else:
            rad = np.array(draw(st.lists(st.floats(0.0, 3e-3), min_size=ne, max_size=ne)))
        rods.append((pts, closed, rad))
    far = draw(st.sampled_from([0.0, 0.0, 1.0]))  # sometimes move the last rod 1 m away
    if far and len(rods) > 1:
        pts, closed, rad = rods[-1]
        rods[-1] = (pts + far, closed, rad)
    extra = draw(st.sampled_from([0.0, 5e-4, 2.5e-3]))
    return rods, extra


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenes())
def test_matches_brute_force(scene):
    rods, extra = scene
    check_against_reference(build(rods), extra)


# ---------------------------------------------------------------------------------------------
# unit tests


def straight(n_nodes, dx=1e-3):
    return np.column_stack([np.arange(n_nodes) * dx, np.zeros(n_nodes), np.zeros(n_nodes)])


def ring(n_nodes, radius):
    ang = 2 * np.pi * np.arange(n_nodes) / n_nodes
    return np.column_stack([radius * np.cos(ang), radius * np.sin(ang), np.zeros(n_nodes)])


def test_three_apart_rule_open_rod():
    # huge radius: every geometric pair is "close", so only the exclusion rule decides
    args = build([(straight(9), False, 1.0)])  # 8 edges
    got = find_candidate_pairs(*args, 0.0)
    expected = [(i, j) for i, j in itertools.combinations(range(8), 2) if j - i >= 3]
    assert [tuple(p) for p in got] == expected


def test_three_apart_rule_closed_rod():
    n = 8
    args = build([(ring(n, 5e-3), True, 1.0)])  # 8 edges, edge 7 joins node 7 to node 0
    got = find_candidate_pairs(*args, 0.0)
    expected = [(i, j) for i, j in itertools.combinations(range(n), 2) if min(j - i, n - (j - i)) >= 3]
    assert [tuple(p) for p in got] == expected
    assert (0, 7) not in expected and (0, 6) not in expected and (0, 5) in expected
    # a ring of 5 edges has no pair 3 apart
    assert len(find_candidate_pairs(*build([(ring(5, 5e-3), True, 1.0)]), 0.0)) == 0


def test_different_rods_always_candidates_single_edge_rods():
    rods = [
        (np.array([[0, 0, 0], [1e-3, 0, 0]]), False, 1e-3),
        (np.array([[0, 0, 0], [1e-3, 0, 0]]), False, 1e-3),  # coincident
        (np.array([[0, 2e-3, 0], [1e-3, 2e-3, 0]]), False, 1e-3),
    ]  # parallel, 2 mm away
    got = find_candidate_pairs(*build(rods), 0.0)
    # 2 mm apart with cut-off exactly 2 mm is not a candidate (strict inequality)
    assert [tuple(p) for p in got] == [(0, 1)]
    got = find_candidate_pairs(*build(rods), 1e-6)
    assert [tuple(p) for p in got] == [(0, 1), (0, 2), (1, 2)]


def test_empty_results():
    far = [(straight(8, 1e-2), False, 1e-3), (ring(12, 0.05) + [0, 1.0, 0], True, 1e-3)]
    got = find_candidate_pairs(*build(far), 2.5e-3)
    assert got.shape == (0, 2) and got.dtype == np.int64
    assert find_candidate_pairs(*build([(straight(2), False, 1e-3)]), 1.0).shape == (0, 2)
    assert find_candidate_pairs(*build([(straight(4), False, 1e-3)]), 1.0).shape == (0, 2)


def test_large_coordinate_offset():
    rng = np.random.default_rng(3)
    rods = [(np.cumsum(rng.normal(0, 2e-3, (40, 3)), axis=0), bool(k % 2), 1.6e-3) for k in range(3)]
    base = check_against_reference(build(rods), 2.5e-3)
    assert len(base) > 20
    for offset in (1e3, -7.5e5):
        shifted = [(p + offset, c, r) for p, c, r in rods]
        got = check_against_reference(build(shifted), 2.5e-3)
        assert {tuple(p) for p in got} == {tuple(p) for p in base}


def test_all_edges_in_one_cell_and_long_edges():
    rng = np.random.default_rng(7)
    # a dense 2 mm ball of short edges crossed by rods with edges much longer than the cells
    ball = (np.cumsum(rng.normal(0, 3e-4, (150, 3)), axis=0), False, 1e-4)
    long_rod = (np.array([[-1.0, 0, 0], [1.0, 0, 0], [1.0, 1.0, 1.0], [-1, -1, -1]]), False, 1e-4)
    diag = (np.array([[-0.5, -0.5, 0.0], [0.5, 0.5, 0.0], [0.5, -0.5, 0.0]]), False, 2e-3)
    got = check_against_reference(build([ball, long_rod, diag]), 5e-4)
    assert len(got) > 100
    # every edge in one cell: all radii huge
    check_against_reference(build([(ball[0], True, 0.5)]), 0.0)


def test_degenerate_and_dense_tangle():
    rng = np.random.default_rng(11)
    pts = np.cumsum(rng.normal(0, 1.9e-3, (400, 3)), axis=0)
    pts[50:53] = pts[50]  # zero-length edges
    rods = [(pts[:200], False, 1.6e-3), (pts[200:], True, rng.uniform(1e-3, 3e-3, 200))]
    got = check_against_reference(build(rods), 2.5e-3)
    assert len(got) > 500


def test_segment_distance_special_cases():
    def d(p0, p1, q0, q1):
        return segment_distance(
            tuple(map(float, p0)), tuple(map(float, p1)), tuple(map(float, q0)), tuple(map(float, q1))
        )

    assert d((0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)) == pytest.approx(1.0)  # parallel overlap
    assert d((0, 0, 0), (1, 0, 0), (2, 1, 0), (3, 1, 0)) == pytest.approx(np.sqrt(2))  # parallel apart
    assert d((0, 0, 0), (1, 0, 0), (-3, 1, 0), (-2, 1, 0)) == pytest.approx(np.sqrt(5))
    assert d((0, 0, 0), (1, 0, 0), (3, 1, 0), (2, 1, 0)) == pytest.approx(np.sqrt(2))  # antiparallel
    assert d((0, 0, 0), (1, 0, 0), (0.5, -1, 1), (0.5, 1, 1)) == pytest.approx(1.0)  # crossing
    assert d((0, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0)) == 0.0  # two points
    assert d((1, 2, 2), (1, 2, 2), (0, 0, 0), (0, 0, 0)) == pytest.approx(3.0)
    assert d((0.5, 1, 0), (0.5, 1, 0), (0, 0, 0), (1, 0, 0)) == pytest.approx(1.0)  # point-segment
    assert d((0, 0, 0), (1, 0, 0), (2, 0, 0), (2, 0, 0)) == pytest.approx(1.0)
    assert d((0, 0, 0), (1, 0, 0), (0, 0, 0), (1, 0, 0)) == 0.0  # coincident
    rng = np.random.default_rng(0)
    x = rng.normal(size=(2000, 4, 3))
    x[:200, 1] = x[:200, 0] + 1e-9 * rng.normal(size=(200, 3))  # nearly degenerate
    x[200:400, 3] = x[200:400, 2] + (x[200:400, 1] - x[200:400, 0]) * rng.uniform(-2, 2, (200, 1))
    ref = reference_distance(x[:, 0], x[:, 1], x[:, 2], x[:, 3])
    got = np.array([d(*xi) for xi in x])
    np.testing.assert_allclose(got, ref, rtol=1e-7, atol=1e-9)
