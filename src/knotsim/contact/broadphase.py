"""Contact broad phase: find every pair of edges that may be in contact.

A pair of edges ``(a, b)`` is a *candidate* when the minimum distance between the two segments is
below the pair's cut-off ``edge_radius[a] + edge_radius[b] + extra`` (m), unless both edges belong
to the same rod and are fewer than 3 edges apart along it (measured cyclically on closed rods):
such neighbours always "touch" and are never candidates (docs/physics.md §2.1; the rule lives
in :mod:`knotsim.geometry.exclusion`).

Algorithm (linear in the number of edges for bounded density):

1. Every edge gets an axis-aligned box: the box of its two end points inflated by
   ``edge_radius[e] + extra / 2`` (plus a few ulps of slack). Two edges closer than their cut-off
   always have overlapping boxes.
2. Boxes are put into a uniform grid of cubic cells (edge ``h`` about the typical box size). Each box
   is registered in every cell it overlaps; entries are grouped by cell with a counting sort on
   the dense cell index (or, when the occupied region is sparse, a stable merge sort of packed keys).
   Boxes much larger than the cells ("big" edges, more than ``_MAX_CELLS_PER_EDGE`` cells) are not
   registered and are instead tested against every edge, so one very long edge cannot blow up
   memory or the cell size.
3. Inside each cell, pairs of boxes are tested for overlap. A pair is handled only in the cell that
   holds the lower corner of the intersection of the two boxes, so each pair is seen once without
   de-duplication.
4. Surviving pairs that are not same-rod neighbours get an exact segment-segment distance test.
5. The pairs are put in lexicographic order by two stable counting sorts (linear).

Cost: O(n_edges + number of box-overlapping pairs) for the usual case of edges of similar size;
everything in one cell degrades gracefully to the O(n^2) all-pairs test, still exact.
Non-finite coordinates or radii raise ``ValueError``.

The result is exactly the set of pairs (not excluded) for which
:func:`knotsim.geometry.segments.segment_distance` (re-exported here) is below the cut-off; the
grid only decides which pairs are tested. All kernels are numba
``@njit(cache=True)`` scalar code.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from knotsim._util.sorting import argsort_stable, median
from knotsim.geometry.exclusion import MIN_INDEX_GAP, index_distance
from knotsim.geometry.segments import segment_distance

__all__ = ["find_candidate_pairs", "node_drift", "segment_distance"]

# Cells per axis are kept below 2**_AXIS_BITS so a cell (ix, iy, iz) packs into one int64 key.
_AXIS_BITS = 20
_AXIS_CELLS = 1 << _AXIS_BITS
# An edge whose box covers more cells than this is treated as "big" (tested against all edges).
_MAX_CELLS_PER_EDGE = 64
# Cell edge relative to the median box size, capped by the largest box size.
_CELL_FACTOR = 1.0


@njit(inline="always", cache=True)
def _excluded(a, b, edge_rod, edge_local, rod_n_edges, rod_closed):
    """True when edges ``a`` and ``b`` are on the same rod and fewer than ``MIN_INDEX_GAP`` (3) edges
    apart (:mod:`knotsim.geometry.exclusion`)."""
    r = edge_rod[a]
    if r != edge_rod[b]:
        return False
    return index_distance(edge_local[a], edge_local[b], rod_n_edges[r], rod_closed[r]) < MIN_INDEX_GAP


@njit(inline="always", cache=True)
def _close(a, b, ends, edge_radius, extra):
    """Exact test: segment distance of edges ``a``, ``b`` below their cut-off.

    ``ends`` (n_edges, 6) holds the two end points of every edge. The distance is always evaluated
    with the lower edge number first, so rounding (the kernel is not bit-symmetric in its
    arguments) cannot depend on the order in which pairs are visited.
    """
    if a > b:
        a, b = b, a
    d = segment_distance(
        (ends[a, 0], ends[a, 1], ends[a, 2]),
        (ends[a, 3], ends[a, 4], ends[a, 5]),
        (ends[b, 0], ends[b, 1], ends[b, 2]),
        (ends[b, 3], ends[b, 4], ends[b, 5]),
    )
    return d < edge_radius[a] + edge_radius[b] + extra


@njit(inline="always", cache=True)
def _add_if_close(a, b, pairs, npairs, ends, edge_rod, edge_local, rod_n_edges, rod_closed, edge_radius, extra):
    """Append ``(min(a, b), max(a, b))`` to ``pairs[:npairs]`` (grown when full) when the pair is not
    excluded and closer than its cut-off; returns the buffer and the new count."""
    if _excluded(a, b, edge_rod, edge_local, rod_n_edges, rod_closed):
        return pairs, npairs
    if not _close(a, b, ends, edge_radius, extra):
        return pairs, npairs
    if npairs == pairs.shape[0]:
        pairs = _grow(pairs)
    pairs[npairs, 0] = min(a, b)
    pairs[npairs, 1] = max(a, b)
    return pairs, npairs + 1


@njit(inline="always", cache=True)
def _boxes_overlap(lo, hi, a, b):
    for k in range(3):
        if lo[a, k] > hi[b, k] or lo[b, k] > hi[a, k]:
            return False
    return True


@njit(cache=True)
def _grow(pairs):
    """Copy of the (cap, 2) pair buffer with twice the capacity."""
    bigger = np.empty((2 * pairs.shape[0], 2), dtype=np.int64)
    for k in range(pairs.shape[0]):  # (a slice assignment costs seconds of first-run compile time)
        bigger[k, 0] = pairs[k, 0]
        bigger[k, 1] = pairs[k, 1]
    return bigger


@njit(cache=True)
def _counting_order(values, order, n_values):
    """Stable counting sort: the items ``order`` (indices into ``values``, each in
    ``[0, n_values)``) reordered by increasing ``values[item]``."""
    start = np.zeros(n_values + 1, dtype=np.int64)
    for k in range(order.shape[0]):
        start[values[order[k]] + 1] += 1
    for v in range(n_values):
        start[v + 1] += start[v]
    out = np.empty(order.shape[0], dtype=np.int64)
    for k in range(order.shape[0]):
        v = values[order[k]]
        out[start[v]] = order[k]
        start[v] += 1
    return out


@njit(cache=True)
def find_candidate_pairs(q, edge_dofs, edge_rod, edge_local, rod_n_edges, rod_closed, edge_radius, extra):
    """All pairs of edges closer than their contact cut-off.

    Parameters
    ----------
    q : (n_dofs,) float64
        Global vector of unknowns (m, rad). Edge ``e`` runs from ``q[edge_dofs[e, 0]:+3]`` to
        ``q[edge_dofs[e, 1]:+3]``.
    edge_dofs : (n_edges, 2) int64
        Index in ``q`` of the x coordinate of each end node of every edge.
    edge_rod : (n_edges,) int64
        Rod of every edge.
    edge_local : (n_edges,) int64
        Index of every edge inside its rod.
    rod_n_edges : (n_rods,) int64
        Number of edges of every rod.
    rod_closed : (n_rods,) bool
        Whether every rod is a closed ring.
    edge_radius : (n_edges,) float64
        Cross-section radius of every edge (m).
    extra : float
        Additional cut-off distance (m), typically ``delta + margin``.

    Returns
    -------
    pairs : (m, 2) int64
        Every pair ``(a, b)``, ``a < b``, with minimum segment-segment distance
        ``< edge_radius[a] + edge_radius[b] + extra``, excluding same-rod pairs fewer than 3 edges
        apart (``min(|i-j|, n-|i-j|)`` on closed rods). Rows are sorted lexicographically.
    """
    ne = edge_dofs.shape[0]
    if edge_dofs.ndim != 2 or edge_dofs.shape[1] != 2:
        raise ValueError("edge_dofs must have shape (n_edges, 2)")
    if edge_rod.shape[0] != ne or edge_local.shape[0] != ne or edge_radius.shape[0] != ne:
        raise ValueError("edge_rod, edge_local and edge_radius must have n_edges entries")
    if ne < 2:
        return np.empty((0, 2), dtype=np.int64)

    # 1. inflated boxes, global bounds, box sizes
    ends = np.empty((ne, 6))
    lo = np.empty((ne, 3))
    hi = np.empty((ne, 3))
    size = np.empty(ne)
    gmin = np.full(3, np.inf)
    gmax = np.full(3, -np.inf)
    half = 0.5 * extra
    for e in range(ne):
        i0 = edge_dofs[e, 0]
        i1 = edge_dofs[e, 1]
        pad = edge_radius[e] + half
        smax = 0.0
        for k in range(3):
            x0 = q[i0 + k]
            x1 = q[i1 + k]
            ends[e, k] = x0
            ends[e, 3 + k] = x1
            mn = min(x0, x1)
            mx = max(x0, x1)
            # slack of a few ulps so rounding can never separate boxes of a touching pair
            slack = 1e-12 * (abs(mn) + abs(mx) + pad)
            l = mn - pad - slack
            u = mx + pad + slack
            if not (math.isfinite(l) and math.isfinite(u)):
                raise ValueError("non-finite edge coordinates or radius")
            lo[e, k] = l
            hi[e, k] = u
            if l < gmin[k]:
                gmin[k] = l
            if u > gmax[k]:
                gmax[k] = u
            if u - l > smax:
                smax = u - l
        size[e] = smax

    # 2. cell size: about the typical box size, never so small that an axis overflows the key
    h = min(_CELL_FACTOR * median(size), size.max())
    extent = 0.0
    for k in range(3):
        extent = max(extent, gmax[k] - gmin[k])
    # (the 1e-300 floor keeps 1/h finite when all boxes are points; an infinite extent gives one
    # cell, still correct)
    h = max(h, extent / (_AXIS_CELLS - 2), 1e-300)
    inv_h = 1.0 / h

    # cell ranges of every box; big boxes go to a separate list
    clo = np.empty((ne, 3), dtype=np.int64)
    chi = np.empty((ne, 3), dtype=np.int64)
    big = np.zeros(ne, dtype=np.bool_)
    n_entries = 0
    n_big = 0
    for e in range(ne):
        cnt = 1
        for k in range(3):
            a = min(int(math.floor((lo[e, k] - gmin[k]) * inv_h)), _AXIS_CELLS - 1)
            b = min(int(math.floor((hi[e, k] - gmin[k]) * inv_h)), _AXIS_CELLS - 1)
            clo[e, k] = a
            chi[e, k] = b
            cnt *= b - a + 1
        if cnt > _MAX_CELLS_PER_EDGE:
            big[e] = True
            n_big += 1
        else:
            n_entries += cnt

    # Register boxes in every cell they overlap. ``home`` has bit k set when the box starts (lowest
    # cell) in this cell along axis k: a pair belongs to a cell iff max(clo[a], clo[b]) == cell on
    # every axis, i.e. (home_a | home_b) == 7 there.
    nxyz = np.ones(3, dtype=np.int64)
    for e in range(ne):
        if not big[e]:
            for k in range(3):
                nxyz[k] = max(nxyz[k], chi[e, k] + 1)
    n_cells = nxyz[0] * nxyz[1] * nxyz[2]  # < 2**60, no overflow
    dense = n_cells <= 4 * n_entries + 4096
    keys = np.empty(n_entries, dtype=np.int64)
    owner = np.empty(n_entries, dtype=np.int64)
    home_u = np.empty(n_entries, dtype=np.int64)
    m = 0
    for e in range(ne):
        if big[e]:
            continue
        for ix in range(clo[e, 0], chi[e, 0] + 1):
            for iy in range(clo[e, 1], chi[e, 1] + 1):
                for iz in range(clo[e, 2], chi[e, 2] + 1):
                    if dense:
                        keys[m] = (ix * nxyz[1] + iy) * nxyz[2] + iz
                    else:
                        keys[m] = (ix << (2 * _AXIS_BITS)) | (iy << _AXIS_BITS) | iz
                    owner[m] = e
                    home_u[m] = (ix == clo[e, 0]) | ((iy == clo[e, 1]) << 1) | ((iz == clo[e, 2]) << 2)
                    m += 1

    # Group entries by cell: counting sort when the grid is dense, else a comparison sort.
    # ``run[c]:run[c+1]`` are then the entries of the c-th group.
    if dense:
        run = np.zeros(n_cells + 1, dtype=np.int64)
        for m in range(n_entries):
            run[keys[m] + 1] += 1
        for c in range(n_cells):
            run[c + 1] += run[c]
        fill = run[:-1].copy()
        order = np.empty(n_entries, dtype=np.int64)
        for m in range(n_entries):
            order[fill[keys[m]]] = m
            fill[keys[m]] += 1
    else:
        order = argsort_stable(keys)
        n_runs = 0
        for m in range(n_entries):
            if m == 0 or keys[order[m]] != keys[order[m - 1]]:
                n_runs += 1
        run = np.empty(n_runs + 1, dtype=np.int64)
        c = 0
        for m in range(n_entries):
            if m == 0 or keys[order[m]] != keys[order[m - 1]]:
                run[c] = m
                c += 1
        run[n_runs] = n_entries

    # entries in cell order with their box copied next to them (contiguous inner loop)
    sown = np.empty(n_entries, dtype=np.int64)
    home = np.empty(n_entries, dtype=np.int64)
    box = np.empty((n_entries, 6))
    for m in range(n_entries):
        e = owner[order[m]]
        sown[m] = e
        home[m] = home_u[order[m]]
        for k in range(3):
            box[m, k] = lo[e, k]
            box[m, 3 + k] = hi[e, k]

    pairs = np.empty((max(16, 4 * ne), 2), dtype=np.int64)
    npairs = 0

    # 3. pairs inside each cell, each handled only in the cell of its intersection's lower corner
    for c in range(run.shape[0] - 1):
        s = run[c]
        t = run[c + 1]
        for i in range(s, t - 1):
            hi_ = home[i]
            l0 = box[i, 0]
            l1 = box[i, 1]
            l2 = box[i, 2]
            u0 = box[i, 3]
            u1 = box[i, 4]
            u2 = box[i, 5]
            for j in range(i + 1, t):
                # branch-free overlap + ownership test (the outcome is hard to predict)
                hit = (
                    ((hi_ | home[j]) == 7)
                    & (box[j, 0] <= u0)
                    & (box[j, 1] <= u1)
                    & (box[j, 2] <= u2)
                    & (l0 <= box[j, 3])
                    & (l1 <= box[j, 4])
                    & (l2 <= box[j, 5])
                )
                if not hit:
                    continue
                pairs, npairs = _add_if_close(sown[i], sown[j], pairs, npairs, ends, edge_rod, edge_local,
                                              rod_n_edges, rod_closed, edge_radius, extra)

    # big boxes against everything (a big-big pair is handled once, from its smaller index)
    if n_big > 0:
        for a in range(ne):
            if not big[a]:
                continue
            for b in range(ne):
                if b == a or (big[b] and b < a):
                    continue
                if not _boxes_overlap(lo, hi, a, b):
                    continue
                pairs, npairs = _add_if_close(a, b, pairs, npairs, ends, edge_rod, edge_local, rod_n_edges,
                                              rod_closed, edge_radius, extra)

    # 4. lexicographic order: two stable counting sorts (on the second index, then the first)
    by_second = _counting_order(pairs[:npairs, 1], np.arange(npairs), ne)
    by_both = _counting_order(pairs[:npairs, 0], by_second, ne)
    out = np.empty((npairs, 2), dtype=np.int64)
    for k in range(npairs):
        out[k, 0] = pairs[by_both[k], 0]
        out[k, 1] = pairs[by_both[k], 1]
    return out


@njit(cache=True)
def node_drift(q, q_build, node_dof):
    """Drift (m) of the nodes since ``q_build``: ``max_i |u_i - c|``.

    ``u_i`` (m) is the displacement of node ``i`` (x at ``q[node_dof[i]]``) between ``q_build``
    and ``q``, ``c`` the centre of the bounding box of all ``u_i``. Two nodes come closer by at most
    ``|u_a - u_b| <= 2 max_i |u_i - c|``, whatever the common translation of the rods.
    """
    n = node_dof.shape[0]
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for i in range(n):
        a = node_dof[i]
        for k in range(3):
            u = q[a + k] - q_build[a + k]
            if u < lo[k]:
                lo[k] = u
            if u > hi[k]:
                hi[k] = u
    c0 = 0.5 * (lo[0] + hi[0])
    c1 = 0.5 * (lo[1] + hi[1])
    c2 = 0.5 * (lo[2] + hi[2])
    worst = 0.0
    for i in range(n):
        a = node_dof[i]
        u0 = q[a] - q_build[a] - c0
        u1 = q[a + 1] - q_build[a + 1] - c1
        u2 = q[a + 2] - q_build[a + 2] - c2
        d = u0 * u0 + u1 * u1 + u2 * u2
        if d > worst:
            worst = d
    return np.sqrt(worst)
