"""Tests of knotsim.knots.geometry: spec parsing, crossings, lifting, relaxation and clearance.

The brute-force helpers below (all-pairs crossing counter, all-pairs exact clearance) are
deliberately independent of the library's pruned k-d-tree implementations; test_library.py
imports them.
"""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.errors import ConfigError, GeometryError
from knotsim.knots import geometry as G

# ---------------------------------------------------------------------------------------------
# independent brute-force checks
# ---------------------------------------------------------------------------------------------


def _point_segment(p, a, b):
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    return np.linalg.norm(a + t[:, None] * ab - p, axis=1)


def brute_segment_distance(p0, p1, q0, q1):
    """Exact segment-segment distances: minimum of the four end-point-to-segment distances and of
    the interior stationary point of the two lines when it lies inside both segments."""
    cands = [_point_segment(p0, q0, q1), _point_segment(p1, q0, q1),
             _point_segment(q0, p0, p1), _point_segment(q1, p0, p1)]
    u, v, w = p1 - p0, q1 - q0, p0 - q0
    a, b, c = (u * u).sum(1), (u * v).sum(1), (v * v).sum(1)
    d, e = (u * w).sum(1), (v * w).sum(1)
    den = a * c - b * b
    good = den > 1e-14 * a * c
    den = np.where(good, den, 1.0)
    s = (b * e - c * d) / den
    t = (a * e - b * d) / den
    inside = good & (s > 0) & (s < 1) & (t > 0) & (t < 1)
    interior = np.linalg.norm(w + s[:, None] * u - t[:, None] * v, axis=1)
    cands.append(np.where(inside, interior, np.inf))
    return np.min(np.stack(cands), axis=0)


def _flat_edges(ropes):
    rope = np.concatenate([np.full(len(x) - 1, r) for r, x in enumerate(ropes)])
    loc = np.concatenate([np.arange(len(x) - 1) for x in ropes])
    p0 = np.concatenate([x[:-1] for x in ropes])
    p1 = np.concatenate([x[1:] for x in ropes])
    return rope, loc, p0, p1


def brute_min_clearance(ropes, min_gap=3):
    """Minimum distance over every edge pair that may touch (no pruning); returns
    ``(distance, (rope_i, edge_i, rope_j, edge_j))``."""
    rope, loc, a, b = _flat_edges(ropes)
    i, j = np.triu_indices(len(rope), 1)
    keep = (rope[i] != rope[j]) | (np.abs(loc[i] - loc[j]) >= min_gap)
    i, j = i[keep], j[keep]
    dist = brute_segment_distance(a[i], b[i], a[j], b[j])
    k = int(np.argmin(dist))
    return float(dist[k]), (int(rope[i[k]]), int(loc[i[k]]), int(rope[j[k]]), int(loc[j[k]]))


def count_crossings(ropes):
    """Crossings of the xy projection by testing every pair of edges.

    Returns a list of dicts: ``over``/``under`` = (rope, position along the rope in edge units),
    ``sign`` (+1 right-handed: over direction x under direction points up), ``point``, ``gap``.
    """
    rope, loc, p0, p1 = _flat_edges([np.asarray(x, float) for x in ropes])
    i, j = np.triu_indices(len(rope), 1)
    keep = (rope[i] != rope[j]) | (np.abs(loc[i] - loc[j]) >= 2)
    i, j = i[keep], j[keep]
    dd = p1 - p0
    d1, d2, w = dd[i, :2], dd[j, :2], (p0[j] - p0[i])[:, :2]
    den = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    ok = den != 0
    den = np.where(ok, den, 1.0)
    s = (w[:, 0] * d2[:, 1] - w[:, 1] * d2[:, 0]) / den
    t = (w[:, 0] * d1[:, 1] - w[:, 1] * d1[:, 0]) / den
    hit = ok & (s >= 0) & (s < 1) & (t >= 0) & (t < 1)
    out = []
    for a, b, sa, tb in zip(i[hit], j[hit], s[hit], t[hit], strict=True):
        za = p0[a, 2] + sa * dd[a, 2]
        zb = p0[b, 2] + tb * dd[b, 2]
        (o, so), (u, su) = ((a, sa), (b, tb)) if za > zb else ((b, tb), (a, sa))
        sign = 1 if dd[o, 0] * dd[u, 1] - dd[o, 1] * dd[u, 0] > 0 else -1
        out.append(dict(over=(int(rope[o]), loc[o] + so), under=(int(rope[u]), loc[u] + su), sign=sign,
                        point=p0[a, :2] + sa * dd[a, :2], gap=abs(za - zb)))
    return out


def letters_along(n_ropes, crossings):
    """Over/under letters met walking along each rope, as strings of O/U."""
    seqs = [[] for _ in range(n_ropes)]
    for c in crossings:
        seqs[c["over"][0]].append((c["over"][1], "O"))
        seqs[c["under"][0]].append((c["under"][1], "U"))
    return ["".join(ch for _, ch in sorted(s)) for s in seqs]


# ---------------------------------------------------------------------------------------------
# segment distances
# ---------------------------------------------------------------------------------------------


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


# ---------------------------------------------------------------------------------------------
# specs and construction
# ---------------------------------------------------------------------------------------------

CROSS = {"name": "cross", "kind": "test", "ropes": [
    {"name": "a", "waypoints": [[0, 0], [100, 0]], "crossings": "O"},
    {"name": "b", "waypoints": [[50, -50], [50, 50]], "crossings": ["under"]}],
    "loading": {"held": [{"rope": "a", "end": "start"}], "pulled": [{"rope": "b", "s": 0.5}]}}


def test_simple_crossing_lifted_and_signed():
    geo = G.build_knot(CROSS, n_nodes=51, radius=1e-3, length=0.5)
    a, b = geo.ropes
    assert a.shape == (51, 3) and b.shape == (51, 3) and a.dtype == np.float64
    xs = count_crossings(geo.ropes)
    assert len(xs) == 1 and geo.n_crossings == 1
    c = xs[0]
    assert c["over"][0] == 0 and c["under"][0] == 1     # rope a over rope b
    # a along +x over b along +y: o x u = +z -> positive crossing
    assert c["sign"] == +1 and geo.writhe == +1
    assert c["gap"] >= 2e-3
    assert geo.min_clearance >= geo.contact_distance
    assert geo.held == (G.NodeRef(0, 0),) and geo.pulled == (G.NodeRef(1, 25),)
    np.testing.assert_allclose(geo.end_direction(G.NodeRef(0, 0)), [-1, 0, 0], atol=1e-9)
    # swapping the letters mirrors the crossing
    flipped = {**CROSS, "ropes": [{**CROSS["ropes"][0], "crossings": "U"}, {**CROSS["ropes"][1], "crossings": "O"}]}
    assert G.build_knot(flipped, n_nodes=51, radius=1e-3, length=0.5).writhe == -1


def test_lengths_units_and_node_count_options():
    spec = {"name": "two", "ropes": [
        {"name": "long", "waypoints": [[0, 0], [40, 10], [80, 0]], "crossings": ""},
        {"name": "short", "waypoints": [[0, 30], [40, 35]], "crossings": ""}]}
    geo = G.build_knot(spec, edge_length=0.01, radius=1e-3, length=2.0)
    assert [len(r) for r in geo.ropes] == [201, 201]
    for r in geo.ropes:   # every rope has exactly the requested length, uniform edges
        e = np.linalg.norm(np.diff(r, axis=0), axis=1)
        np.testing.assert_allclose(e, 0.01, rtol=1e-10)
    assert geo.edge_length == pytest.approx(0.01)
    assert geo.end_nodes == {"long": (0, 200), "short": (0, 200)}
    with pytest.raises(ConfigError, match="not both"):
        G.build_knot(spec, n_nodes=11, edge_length=0.1)
    with pytest.raises(ConfigError, match="n_nodes"):
        G.build_knot(spec, n_nodes=3)
    with pytest.raises(ConfigError, match="radius"):
        G.build_knot(spec, radius=-1.0)


def test_letter_forms_and_parse_errors():
    spec = G.parse_knot_spec({"name": "k", "ropes": [
        {"name": "a", "waypoints": [[0, 0], [1, 0]], "crossings": "o, U ,o u"},
        {"name": "b", "waypoints": [[0, 1], [1, 1]], "crossings": ["over", "under", "U", "O"]}]})
    assert spec.ropes[0].passes == (True, False, True, False)
    assert spec.ropes[1].passes == (True, False, False, True)
    assert spec.n_crossings == 4
    bad = [
        ({"ropes": []}, "name"),
        ({"name": "k", "ropes": []}, "ropes"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0]]}]}, "waypoints"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [0, 0], [1, 1]]}]}, "coincide"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]], "crossings": "OX"}]}, "letter"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]], "crossings": "OUO"}]}, "even"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]], "crossings": "OO"}]}, "one of each"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]]}, {"name": "a", "waypoints": [[0, 1], [1, 2]]}]}, "duplicate"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]]}],
          "loading": {"held": [{"rope": "zz", "end": "start"}]}}, "zz"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]]}],
          "loading": {"held": [{"rope": "a", "s": 1.5}]}}, "fraction"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]]}], "defaults": {"radus": 1}}, "radus"),
    ]
    for data, msg in bad:
        with pytest.raises(ConfigError, match=msg):
            G.parse_knot_spec(data)


def test_wrong_crossing_count_is_reported():
    spec = {"name": "miscount", "ropes": [
        {"name": "a", "waypoints": [[0, 0], [100, 0]], "crossings": "OU"},
        {"name": "b", "waypoints": [[50, -50], [50, 50]], "crossings": "UO"}]}
    with pytest.raises(ConfigError, match=r"passes through 1 crossings .* but 2 over/under letters"):
        G.build_knot(spec, n_nodes=51, radius=1e-3)
    # a drawing with no crossing at all but letters declared
    spec = {"name": "none", "ropes": [{"name": "a", "waypoints": [[0, 0], [50, 5], [100, 0]], "crossings": "OU"}]}
    with pytest.raises(ConfigError, match="passes through 0 crossings"):
        G.build_knot(spec, n_nodes=51, radius=1e-3)


def test_both_strands_over_is_reported():
    # rope b dips below rope a and comes back up: two crossings, met in the same order by both
    spec = {"name": "bothover", "ropes": [
        {"name": "a", "waypoints": [[0, 0], [100, 0]], "crossings": "OU"},
        {"name": "b", "waypoints": [[30, 30], [30, -10], [50, -30], [70, -10], [70, 30]], "crossings": "OU"}]}
    with pytest.raises(ConfigError, match="declared over on both strands"):
        G.build_knot(spec, n_nodes=101, radius=1e-3)
    ok = {**spec, "ropes": [spec["ropes"][0], {**spec["ropes"][1], "crossings": "UO"}]}
    geo = G.build_knot(ok, n_nodes=101, radius=1e-3)
    assert letters_along(2, count_crossings(geo.ropes)) == ["OU", "UO"]


PARALLEL = {"name": "parallel", "ropes": [
    {"name": "a", "waypoints": [[0, 0], [50, 0], [100, 0]]},
    {"name": "b", "waypoints": [[0, 0.2], [50, 0.2], [100, 0.2]]}]}


def test_relaxation_pushes_close_ropes_apart():
    # drawn 2 mm apart with d = 3.2 mm: the relaxation must separate them and keep them straight
    geo = G.build_knot(PARALLEL, n_nodes=101, radius=1.6e-3, length=1.0)
    dist, _ = brute_min_clearance(geo.ropes)
    assert dist >= geo.contact_distance
    assert geo.min_clearance == pytest.approx(dist, abs=1e-12)
    assert np.ptp(geo.ropes[0][:, 1]) < 1e-3 and geo.n_crossings == 0
    for r in geo.ropes:
        np.testing.assert_allclose(np.linalg.norm(np.diff(r, axis=0), axis=1), 0.01, rtol=1e-10)


def test_overlap_error_names_closest_pair():
    with pytest.raises(GeometryError, match=r"rope 'a' edge \d+ and rope 'b' edge \d+ are 2\.\d+ mm apart, "
                                            r"contact distance is 3\.200 mm") as exc:
        G.build_knot(PARALLEL, n_nodes=101, radius=1.6e-3, length=1.0, max_iter=0)
    assert isinstance(exc.value, ValueError)
    # a rod far too thick for the drawing cannot keep the declared diagram: the knot falls open
    from knotsim.knots.library import load_knot_spec

    with pytest.raises(GeometryError, match=r"no longer has the declared crossing diagram.*closest pair: "
                                            r"rope 'rod' edge \d+ and rope 'rod' edge \d+"):
        G.build_knot(load_knot_spec("overhand_n1"), n_nodes=101, radius=0.04)


def test_projected_crossings_agree_with_bruteforce():
    rng = np.random.default_rng(3)
    ropes = [np.cumsum(rng.normal(size=(60, 3)), axis=0), np.cumsum(rng.normal(size=(40, 3)), axis=0)]
    mine = sorted((c.over_rope, c.over_edge + c.over_t, c.sign) for c in G.projected_crossings(ropes))
    ref = sorted((c["over"][0], c["over"][1], c["sign"]) for c in count_crossings(ropes))
    assert len(mine) == len(ref) > 5
    for m, r in zip(mine, ref, strict=True):
        assert m[0] == r[0] and m[1] == pytest.approx(r[1]) and m[2] == r[2]


def test_module_docstring_example_builds():
    import tomllib

    doc = G.__doc__
    block = doc[doc.index("::\n") + 3:doc.index("Any other top-level keys")]
    text = "\n".join(line[4:] for line in block.splitlines())
    geo = G.build_knot(tomllib.loads(text))
    assert geo.radius == 1.6e-3 and len(geo.ropes[0]) == 301
    assert geo.n_crossings == 3 and geo.writhe == +3
    assert letters_along(1, count_crossings(geo.ropes)) == ["UOUOUO"]
    assert geo.held == (G.NodeRef(0, 150),) and geo.min_clearance >= geo.contact_distance
