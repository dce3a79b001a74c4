"""Measures of ropes in a knot, from their node positions: how much of each end lies outside the knot
(:func:`tail_lengths`, :func:`self_tail_lengths`), how much a rope turns inside it
(:func:`turning_in_knot`), how close two ropes come (:func:`rope_gap`), which ends are the free tails
of a bend (:func:`free_tail_ends`) and whether its ends alternate round it (:func:`ends_interleaved`).
Shared by the protocols that load bends and one-rope knots (composed, not inherited).

Tail length (definition): the arc length from a free end, walking inwards, to where the rope first
comes within ``2h + delta + l/2`` (``l`` the mean edge length) of a node of the *other* rope,
interpolated along the edge between the last node outside and the first inside from their distances
(so it changes continuously as rope slides through, not in steps of one edge): the length of the free
tail outside the knot. Units: m, rad.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["APART_RADII", "end_direction", "ends_interleaved", "entry_arc_length", "free_tail_ends", "rope_gap", "self_tail_lengths",
           "tail_lengths", "turning_in_knot"]


def entry_arc_length(x: np.ndarray, dist: np.ndarray, cutoff: float, from_last: bool) -> float:
    """Arc length (m) from one end of a rope to where it first comes within ``cutoff`` of something
    else, interpolated along the edge on which that happens.

    ``x`` ``(N, 3)`` node positions (m); ``dist`` ``(N,)`` each node's distance (m) to the nearest
    point of the other thing (``inf`` where farther than anything that matters); from the first node
    (``from_last`` False) or the last. With ``i`` the first node (counted from that end) with
    ``dist[i] <= cutoff`` and ``j`` the node before it, the entry is at the fraction
    ``(dist[j] − cutoff)/(dist[j] − dist[i])`` of the edge from ``j`` to ``i``: the length changes
    continuously as the rope slides, not in steps of one edge. The whole length when no node is
    within ``cutoff``; 0 when the end node is."""
    if from_last:
        x = x[::-1]
        dist = dist[::-1]
    seg = np.linalg.norm(np.diff(x, axis=0), axis=1)
    inside = np.flatnonzero(dist <= cutoff)
    if inside.size == 0:
        return float(seg.sum())
    i = int(inside[0])
    if i == 0:
        return 0.0
    d_out, d_in = float(dist[i - 1]), float(dist[i])
    frac = 1.0 if not np.isfinite(d_out) else (d_out - cutoff) / (d_out - d_in)
    return float(seg[:i - 1].sum() + frac * seg[i - 1])


def tail_lengths(ropes: list[np.ndarray], free_ends: list[tuple[int, int]], radius: float,
                 delta: float) -> list[float]:
    """Length (m) of each free tail outside the knot (see the module docstring): the arc length from
    the tail's end to where it first comes within ``2h + delta + l/2`` of a node of another rope
    (``l`` the mean edge length), interpolated along the edge (:func:`entry_arc_length`).

    Parameters
    ----------
    ropes:
        ``(N_k, 3)`` node positions of each rope, m.
    free_ends:
        ``(rope index, end)`` with end 0 (first node) or 1 (last node).
    radius, delta:
        Rod radius ``h`` and contact tolerance, m.
    """
    out = []
    for r, end in free_ends:
        x = ropes[r]
        seg = float(np.mean(np.linalg.norm(np.diff(x, axis=0), axis=1)))
        cutoff = 2.0 * radius + delta + 0.5 * seg
        others = np.concatenate([y for k, y in enumerate(ropes) if k != r])
        dist = cKDTree(others).query(x, distance_upper_bound=4.0 * cutoff)[0]
        out.append(entry_arc_length(x, dist, cutoff, end == 1))
    return out


def _self_distance(x: np.ndarray, cutoff: float, seg: float) -> np.ndarray:
    """Each node's distance (m) to the nodes of the same rope ``(N, 3)`` more than half a turn of
    ``cutoff`` away along it (``inf`` beyond four cut-offs)."""
    skip = int(np.ceil(np.pi * cutoff / seg)) + 1
    tree = cKDTree(x)
    dist = np.full(len(x), np.inf)
    pairs = tree.query_pairs(4.0 * cutoff, output_type="ndarray")
    if len(pairs):
        far = pairs[np.abs(pairs[:, 0] - pairs[:, 1]) > skip]
        if far.size:
            d = np.linalg.norm(x[far[:, 0]] - x[far[:, 1]], axis=1)
            np.minimum.at(dist, far[:, 0], d)
            np.minimum.at(dist, far[:, 1], d)
    return dist


def self_tail_lengths(x: np.ndarray, radius: float, delta: float, post=None) -> list[float]:
    """Length (m) of each end of one rope outside its own knot, ``[first end, last end]``: from the
    end to where it first comes within the contact distance of the rope itself (cut-off as in
    :func:`tail_lengths`, interpolated along the edge as there), not counting the nodes next to it
    along the rope (within half a turn of that distance, ``π`` x the cut-off of arc length: a bend
    cannot bring them closer), or, with a ``post`` (:class:`knotsim.knots.post.Post`: a hitch or a
    loop on a pin), of the post (its surface within ``delta + l/2``).

    ``x`` ``(N, 3)`` node positions (m); ``radius`` and ``delta`` the rod radius and contact
    tolerance (m)."""
    seg = float(np.mean(np.linalg.norm(np.diff(x, axis=0), axis=1)))
    cutoff = 2.0 * radius + delta + 0.5 * seg
    dist = _self_distance(x, cutoff, seg)
    if post is not None:  # touching the post counts as touching the knot: gap to its surface + 2h
        dist = np.minimum(dist, post.axis_distance(x) - post.radius + radius)
    if not np.any(dist <= cutoff):
        return [float(np.linalg.norm(np.diff(x, axis=0), axis=1).sum()), 0.0]  # no knot: counted once
    return [entry_arc_length(x, dist, cutoff, False), entry_arc_length(x, dist, cutoff, True)]


#: The ropes are *apart* when no node of one is within this many rod radii of a node of the other
#: (centreline distance 4h: one rope diameter of clear space between their surfaces).
APART_RADII = 4.0


def turning_in_knot(x: np.ndarray, outside_first: float, outside_last: float) -> float:
    """Total turning angle (rad) of a rope inside the knot: the sum of the angles between successive
    edges at the nodes whose arc length lies between ``outside_first`` (m, from the first node) and
    the total length less ``outside_last`` (m, from the last node), e.g. the lengths of its two ends
    outside the knot (:func:`tail_lengths`). A straight rope through the knot turns by about 0, a rope
    that goes round another and back by π or more. ``x`` ``(N, 3)`` node positions (m)."""
    e = np.diff(np.asarray(x, float), axis=0)
    lengths = np.linalg.norm(e, axis=1)
    t = e / lengths[:, None]
    s = np.cumsum(lengths)[:-1]  # arc length of the interior nodes 1 .. N-2
    inside = (s >= outside_first) & (s <= float(np.sum(lengths)) - outside_last)
    angles = np.arccos(np.clip(np.einsum("ij,ij->i", t[1:], t[:-1]), -1.0, 1.0))
    return float(np.sum(angles[inside]))


def rope_gap(ropes: list[np.ndarray]) -> float:
    """Smallest distance (m) between a node of rope 0 and a node of rope 1 (``(N_k, 3)`` node
    positions, m): the centreline distance, ``2h`` when the ropes touch."""
    return float(cKDTree(ropes[1]).query(ropes[0])[0].min())


def end_direction(x: np.ndarray, node: int) -> np.ndarray:
    """The outward direction (3,) unit vector of a rope's end ``node`` (0 or the last) from the node
    five in from it: where a force or a move that pulls that end points. ``x`` ``(N, 3)`` m."""
    x = np.asarray(x, float)
    inner = min(5, len(x) - 1)
    d = x[node] - x[inner if node == 0 else len(x) - 1 - inner]
    return d / np.linalg.norm(d)


def free_tail_ends(held, pulled) -> list[tuple[int, int]]:
    """``(rope, end)`` of the two free tails: the other end of the held and of the pulled rope
    (end 0 = first node, 1 = last node)."""
    return [(held.rope, 0 if held.node != 0 else 1), (pulled.rope, 0 if pulled.node != 0 else 1)]


def ends_interleaved(ropes: list[np.ndarray], standing: list[tuple[int, int]]) -> bool:
    """Whether the two standing ends and the two tails alternate around the knot (thief and grief
    bends) rather than lying side by side (reef and granny): the angular order of the four end
    nodes about the centroid, in the plane of largest spread of all nodes.

    Parameters
    ----------
    ropes:
        The two ropes' ``(N, 3)`` node positions (m).
    standing:
        ``(rope, node)`` of the two standing ends.
    """
    allp = np.concatenate(ropes)
    c = allp.mean(axis=0)
    e = np.linalg.svd(allp - c, full_matrices=False)[2]
    ends = []
    for r, x in enumerate(ropes):
        for node in (0, len(x) - 1):
            p = x[node] - c
            ends.append((math.atan2(float(p @ e[1]), float(p @ e[0])), (r, node) in standing))
    kinds = [k for _, k in sorted(ends)]
    return all(kinds[i] != kinds[(i + 1) % 4] for i in range(4))
