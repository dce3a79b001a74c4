"""Clearance of rope centrelines: the closest pair of edges that may be in contact.

Edges of one rope closer than the same-rope exclusion rule (:mod:`knotsim.geometry.exclusion`) are
never checked; every pair of edges of different ropes is. Distances are exact segment-segment
distances (:func:`knotsim.geometry.segments.segment_distances`). Lengths in metres.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from knotsim.geometry.exclusion import ARC_GAP_FACTOR, MIN_INDEX_GAP, min_index_gap, pairs_allowed
from knotsim.geometry.segments import segment_distances

#: Minimum index distance between edges of one rope that may be in contact
#: (:data:`knotsim.geometry.exclusion.MIN_INDEX_GAP`).
MIN_EDGE_SEPARATION = MIN_INDEX_GAP
#: Same-rope edge pairs whose arc-length gap ``(|i - j| - 1) * l`` is below this many contact
#: distances are never checked (:data:`knotsim.geometry.exclusion.ARC_GAP_FACTOR`).
MIN_ARC_GAP_FACTOR = ARC_GAP_FACTOR


def same_rope_min_gap(edge_length: float, contact_distance: float) -> int:
    """Smallest index distance ``|i - j|`` of same-rope edge pairs that may be in contact.

    It is ``MIN_EDGE_SEPARATION`` (3) whenever ``2 l >= 1.5 d`` (e.g. L = 1 m, N = 301, h <= 2.2 mm),
    and grows for finer discretizations so that pairs closer than ``1.5 d`` in arc length are
    skipped (:func:`knotsim.geometry.exclusion.min_index_gap`).

    Parameters
    ----------
    edge_length:
        ``l`` (m).
    contact_distance:
        ``d = 2h`` (m).
    """
    return min_index_gap(edge_length, contact_distance)


@dataclass(frozen=True)
class ClosestPair:
    """The closest pair of edges that may be in contact.

    Attributes
    ----------
    rope_a, edge_a, rope_b, edge_b:
        Rope indices and edge indices (edge ``k`` joins nodes ``k`` and ``k+1``).
    distance:
        Their minimum distance (m).
    required:
        The contact distance ``d = 2h`` they must keep (m).
    rope_names:
        Names of all ropes, for messages.
    """

    rope_a: int
    edge_a: int
    rope_b: int
    edge_b: int
    distance: float
    required: float
    rope_names: tuple[str, ...] = ()

    def describe(self) -> str:
        """Human-readable one-line description."""
        na = self.rope_names[self.rope_a] if self.rope_names else str(self.rope_a)
        nb = self.rope_names[self.rope_b] if self.rope_names else str(self.rope_b)
        return (f"rope {na!r} edge {self.edge_a} and rope {nb!r} edge {self.edge_b} are "
                f"{self.distance * 1e3:.3f} mm apart, contact distance is {self.required * 1e3:.3f} mm")


class RopeEdges:
    """Flattened edge list of several open polylines (ropes).

    Global edge ``k`` joins nodes ``i0[k]`` and ``i1[k] = i0[k] + 1`` of the concatenated ``(Ntot, 3)``
    node array; ``rope[k]`` and ``local[k]`` are its rope and its index inside that rope, and
    ``node_offset[r]`` is the first node of rope ``r``.
    """

    def __init__(self, counts: Sequence[int]):
        self.counts = np.asarray(counts, dtype=np.int64)
        self.node_offset = np.concatenate([[0], np.cumsum(self.counts)])
        a, rid, loc = [], [], []
        for r, n in enumerate(self.counts):
            k = np.arange(n - 1)
            a.append(self.node_offset[r] + k)
            rid.append(np.full(n - 1, r))
            loc.append(k)
        self.i0 = np.concatenate(a)
        self.i1 = self.i0 + 1
        self.rope = np.concatenate(rid)
        self.local = np.concatenate(loc)

    def candidate_pairs(self, x: np.ndarray, radius: float, min_gap: int = MIN_EDGE_SEPARATION) -> np.ndarray:
        """``(K, 2)`` global edge-index pairs whose midpoints are within ``radius``, minus excluded
        pairs (same rope, fewer than ``min_gap`` edges apart)."""
        mid = 0.5 * (x[self.i0] + x[self.i1])
        pairs = cKDTree(mid).query_pairs(radius, output_type="ndarray")
        if len(pairs) == 0:
            return np.zeros((0, 2), dtype=np.int64)
        keep = pairs_allowed(pairs, self.rope, self.local, self.counts - 1,
                             np.zeros(len(self.counts), dtype=bool), min_gap)
        return pairs[keep]

    def distances(self, x: np.ndarray, pairs: np.ndarray):
        """``(dist, s, t)`` of the edge pairs ``(K, 2)`` (:func:`~knotsim.geometry.segments.segment_distances`)."""
        i, j = pairs[:, 0], pairs[:, 1]
        return segment_distances(x[self.i0[i]], x[self.i1[i]], x[self.i0[j]], x[self.i1[j]])


def closest_edge_pair(ropes: Sequence[np.ndarray], contact_distance: float,
                      rope_names: Sequence[str] = (), min_gap: int | None = None) -> ClosestPair:
    """Exact closest pair among all edge pairs that may be in contact.

    Pairs considered: edges of one rope at least ``min_gap`` apart in index, and every pair of
    edges of different ropes. A k-d tree on edge midpoints prunes far pairs; the search radius
    grows until the minimum is provably exact.

    Parameters
    ----------
    ropes:
        Node arrays, each ``(N_r, 3)`` (m).
    contact_distance:
        ``d = 2h`` (m), only stored in the result.
    rope_names:
        Optional names for messages.
    min_gap:
        Smallest same-rope index distance checked; default :func:`same_rope_min_gap` of the mean
        edge length (3 at the usual resolutions).
    """
    edges = RopeEdges([len(r) for r in ropes])
    x = np.concatenate([np.asarray(r, dtype=float) for r in ropes])
    elen = np.linalg.norm(x[edges.i1] - x[edges.i0], axis=1)
    lmax = float(elen.max())
    if min_gap is None:
        min_gap = same_rope_min_gap(float(elen.mean()), contact_distance)
    span = float(np.ptp(x, axis=0).max()) + lmax
    radius = 2.0 * contact_distance + lmax
    best = None
    while True:
        pairs = edges.candidate_pairs(x, radius, min_gap)
        if len(pairs):
            dist, _, _ = edges.distances(x, pairs)
            k = int(np.argmin(dist))
            # any pair outside the radius is at least radius - lmax apart
            if dist[k] <= radius - lmax or radius > 2 * span:
                i, j = pairs[k]
                best = ClosestPair(int(edges.rope[i]), int(edges.local[i]), int(edges.rope[j]),
                                   int(edges.local[j]), float(dist[k]), float(contact_distance),
                                   tuple(rope_names))
                break
        elif radius > 2 * span:
            break
        radius *= 2.0
    if best is None:  # a single short rope: no pair can touch
        best = ClosestPair(0, 0, 0, 0, math.inf, float(contact_distance), tuple(rope_names))
    return best
