"""Independent brute-force references for the knot geometry tests (all-pairs crossing counter,
all-pairs exact clearance, a segment distance from point-segment distances), deliberately
independent of the library's pruned implementations; and a small two-rope drawing used by several
tests."""

from __future__ import annotations

import numpy as np


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


CROSS = {"name": "cross", "kind": "test", "ropes": [
    {"name": "a", "waypoints": [[0, 0], [100, 0]], "crossings": "O"},
    {"name": "b", "waypoints": [[50, -50], [50, 50]], "crossings": ["under"]}],
    "loading": {"held": [{"rope": "a", "end": "start"}], "pulled": [{"rope": "b", "s": 0.5}]}}
