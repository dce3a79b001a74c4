"""Which pairs of edges of one rod are never in contact (the same-rod exclusion rule).

Edges ``i`` and ``j`` of one rod with ``n`` edges are ``k = |i - j|`` edges apart (on a closed rod,
cyclically: ``k = min(|i - j|, n - |i - j|)``). Neighbours always "touch" geometrically and are never
contact pairs (docs/physics.md §2.1):

* the contact broad phase skips every same-rod pair with ``k < MIN_INDEX_GAP`` (3);
* on finely meshed rods that is not enough (with edges shorter than ``d / 2`` even a straight rod has
  edges ``i`` and ``i + 3`` closer than the contact distance ``d = 2h``), so pairs whose arc-length
  gap ``(k - 1) l`` is below ``ARC_GAP_FACTOR`` (1.5) contact distances are skipped as well: the
  smallest index distance that may be in contact is :func:`min_index_gap` ``(l, d)``.

Pairs of edges of different rods are never excluded. Used by the contact broad phase
(:mod:`knotsim.contact.broadphase`), the contact model (:mod:`knotsim.contact.model`) and the knot
clearance checks (:mod:`knotsim.knots.clearance`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "ARC_GAP_FACTOR",
    "MIN_INDEX_GAP",
    "index_distance",
    "min_index_gap",
    "pairs_allowed",
]

#: Smallest index distance ``|i - j|`` of same-rod edges that may ever be in contact.
MIN_INDEX_GAP = 3
#: Same-rod pairs closer than this many contact distances along the rod are never in contact.
ARC_GAP_FACTOR = 1.5
# slack of the ceiling in :func:`min_index_gap` (so that exact multiples are not bumped up)
_CEIL_SLACK = 1e-9


def min_index_gap(edge_length: float, contact_distance: float) -> int:
    """Smallest index distance ``k`` of same-rod edge pairs that may be in contact.

    ``max(MIN_INDEX_GAP, ceil(ARC_GAP_FACTOR d / l - 1e-9) + 1)``: it is 3 whenever
    ``2 l >= 1.5 d`` (e.g. L = 1 m, N = 301, h <= 2.2 mm) and grows for finer discretizations.

    Parameters
    ----------
    edge_length:
        ``l`` (m), the (mean) edge length of the rod.
    contact_distance:
        ``d = 2h`` (m).
    """
    need = int(math.ceil(ARC_GAP_FACTOR * contact_distance / edge_length - _CEIL_SLACK)) + 1
    return max(MIN_INDEX_GAP, need)


@njit(cache=True)
def index_distance(i, j, n, closed):
    """Index distance of edges ``i`` and ``j`` of one rod with ``n`` edges (cyclic when ``closed``)."""
    di = abs(i - j)
    if closed:
        if n - di < di:
            di = n - di
    return di


def pairs_allowed(pairs, edge_rod, edge_local, rod_n_edges, rod_closed, rod_min_gap) -> np.ndarray:
    """Mask of the edge pairs that are not excluded by the same-rod rule.

    Parameters
    ----------
    pairs:
        ``(K, 2)`` int array of global edge indices.
    edge_rod, edge_local:
        ``(n_edges,)`` int arrays: rod of every edge and index of the edge inside its rod.
    rod_n_edges, rod_closed:
        ``(n_rods,)`` arrays: edges per rod, and whether the rod is a closed ring.
    rod_min_gap:
        ``(n_rods,)`` int array (or a scalar): smallest index distance allowed on each rod
        (:func:`min_index_gap`, at least :data:`MIN_INDEX_GAP`).

    Returns
    -------
    ``(K,)`` bool array, True where the pair may be in contact.
    """
    a, b = pairs[:, 0], pairs[:, 1]
    ra = edge_rod[a]
    same = ra == edge_rod[b]
    di = np.abs(edge_local[a] - edge_local[b])
    n = rod_n_edges[ra]
    di = np.where(rod_closed[ra], np.minimum(di, n - di), di)
    gap = rod_min_gap[ra] if np.ndim(rod_min_gap) else rod_min_gap
    return ~same | (di >= gap)
