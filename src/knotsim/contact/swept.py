"""Continuous collision check over a time step: did a rope pass through another?

A step moves every node along a straight line from ``q0`` (start of the step) to ``q1`` (its end);
an edge sweeps the volume between its two positions. Two centre lines can only swap sides by
crossing each other: at some instant of the step their distance ``D(t)`` is zero. That instant
may lie anywhere in the step, however far apart the edges are at its two ends, so the end
positions alone do not show it.

Two kernels (numba ``@njit(cache=True)`` scalar code):

- :func:`swept_box_pairs`: broad phase over the swept volumes. Every edge gets the axis-aligned
  box of its two end points at ``q0`` and at ``q1`` inflated by ``inflate[e]`` (m); pairs of
  overlapping boxes (not same-rod neighbours, :mod:`knotsim.geometry.exclusion`) are returned
  (sort and sweep along the axis of largest extent). Edges whose boxes do not overlap never come
  closer than the inflations during the step.
- :func:`first_crossing`: narrow phase by conservative advancement. For pair ``k`` the relative
  motion of any two points of its edges is at most ``L = max |u_a - u_b|`` over the four node
  pairs (``u`` the node displacements over the step, m), so ``D`` is ``L``-Lipschitz in the step
  fraction ``t``: from ``D(t) > 0`` the next ``D(t)/L`` of the step cannot bring the centre lines
  together. The kernel advances by that much (at least ``MIN_SUBSTEP`` of the step), and reports
  a crossing when ``D`` falls below ``tol[k]`` (m), or when the closest-point vector turned by
  more than 90° across a sub-step that had to be shorter than the guarantee (``MIN_SUBSTEP``), or,
  for pairs within ``reach[k]`` at the start or the end of the step, between the two ends of the
  step (the side-flip test of :func:`knotsim.contact.assembly.first_side_flip`). A pair at rest
  or far apart costs two distance evaluations; a pair that passes within ``D`` of each other
  costs about ``L / D`` of them (at most ``1 / MIN_SUBSTEP``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from knotsim._util.sorting import argsort_stable
from knotsim.contact.broadphase import _excluded
from knotsim.contact.distance import edge_edge_distance

__all__ = ["MIN_SUBSTEP", "first_crossing", "first_crossing_chained", "pass_through", "swept_box_pairs"]

#: Shortest sub-step of :func:`first_crossing` (fraction of the step).
MIN_SUBSTEP = 1.0 / 1024.0

#: Crossing codes returned by :func:`first_crossing`.
NONE, MET, TURNED, FLIPPED = 0, 1, 2, 3


@njit(cache=True)
def swept_box_pairs(q0, q1, edge_dofs, edge_rod, edge_local, rod_n_edges, rod_closed, inflate):
    """Pairs ``(a, b)``, ``a < b``, of edges whose swept boxes overlap (see the module docstring).

    Parameters
    ----------
    q0, q1 : (n_dofs,) float64, unknowns at the start and the end of the step (m, rad).
    edge_dofs : (n_edges, 2) int64, ``node_dof`` of each edge's two nodes.
    edge_rod, edge_local, rod_n_edges, rod_closed : the model's edge layout (exclusion rule).
    inflate : (n_edges,) float64, margin added to every side of each edge's box (m).

    Returns ``(k, 2)`` int64, unordered.
    """
    n = edge_dofs.shape[0]
    lo = np.empty((n, 3))
    hi = np.empty((n, 3))
    cmin = np.full(3, np.inf)
    cmax = np.full(3, -np.inf)
    for e in range(n):
        i0 = edge_dofs[e, 0]
        i1 = edge_dofs[e, 1]
        for c in range(3):
            a = q0[i0 + c]
            b = q0[i1 + c]
            u = q1[i0 + c]
            w = q1[i1 + c]
            mn = min(min(a, b), min(u, w))
            mx = max(max(a, b), max(u, w))
            if not (math.isfinite(mn) and math.isfinite(mx)):
                raise ValueError("swept_box_pairs: non-finite coordinates")
            pad = inflate[e] + 4e-16 * (abs(mn) + abs(mx))
            lo[e, c] = mn - pad
            hi[e, c] = mx + pad
            cmin[c] = min(cmin[c], 0.5 * (mn + mx))
            cmax[c] = max(cmax[c], 0.5 * (mn + mx))
    ax = 0
    for c in range(1, 3):
        if cmax[c] - cmin[c] > cmax[ax] - cmin[ax]:
            ax = c
    o1 = (ax + 1) % 3
    o2 = (ax + 2) % 3
    order = argsort_stable(lo[:, ax])
    cap = 4 * n + 16
    pairs = np.empty((cap, 2), np.int64)
    k = 0
    for ii in range(n):
        a = order[ii]
        top = hi[a, ax]
        for jj in range(ii + 1, n):
            b = order[jj]
            if lo[b, ax] > top:
                break
            if lo[b, o1] > hi[a, o1] or lo[a, o1] > hi[b, o1]:
                continue
            if lo[b, o2] > hi[a, o2] or lo[a, o2] > hi[b, o2]:
                continue
            if _excluded(a, b, edge_rod, edge_local, rod_n_edges, rod_closed):
                continue
            if k == cap:
                grown = np.empty((2 * cap, 2), np.int64)
                for r in range(cap):  # (a slice assignment costs seconds of first-run compile time)
                    grown[r, 0] = pairs[r, 0]
                    grown[r, 1] = pairs[r, 1]
                pairs = grown
                cap *= 2
            pairs[k, 0] = min(a, b)
            pairs[k, 1] = max(a, b)
            k += 1
    return pairs[:k].copy()


@njit(inline="always", cache=True)
def _at(p0, p1, t, p):
    for m in range(12):
        p[m] = (1.0 - t) * p0[m] + t * p1[m]


@njit(inline="always", cache=True)
def _closest_vector(p, bi, bj, v):
    for c in range(3):
        v[c] = (1.0 - bi) * p[c] + bi * p[3 + c] - (1.0 - bj) * p[6 + c] - bj * p[9 + c]


@njit(cache=True)
def first_crossing(q0, q1, pair_dofs, tol, reach):
    """First pair whose centre lines crossed during the step (see the module docstring).

    Parameters
    ----------
    q0, q1 : (n_dofs,) float64, unknowns at the start and the end of the step (m).
    pair_dofs : (k, 12) int64, the node coordinates of each pair's edges in ``q``.
    tol : (k,) float64, distance of the centre lines counted as met (m).
    reach : (k,) float64, pairs closer than this at the start or the end of the step also get the
        end-to-end side-flip test (m); ``0`` disables it.

    Returns ``(k, code, t, value)``: the pair index (``-1`` if none), ``MET`` (1: ``D < tol`` at
    step fraction ``t``, ``value`` = that distance, m), ``TURNED`` (2: the closest-point vector
    turned by more than 90° within a short sub-step ending at ``t``; ``value`` = cosine) or
    ``FLIPPED`` (3: turned by more than 90° between the ends of the step; ``value`` = cosine).
    """
    none = np.empty((0, 4))
    return first_crossing_chained(q0, q1, pair_dofs, tol, reach, none, none)


@njit(cache=True)
def first_crossing_chained(q0, q1, pair_dofs, tol, reach, start, end):
    """:func:`first_crossing`, with the distances at the start of the step given and those at
    its end returned, so that consecutive steps compute each pair's distance once.

    ``start`` (k, 4) float64: the distance ``D`` (m) and the closest-point vector (3, m) of every
    pair at ``q0`` (as :func:`first_crossing` computes them: ``end`` of the check of the step
    before, for the same pairs), or (0, 4) to compute them. ``end`` (k, 4): filled with the same at
    ``q1`` when no pair crossed (the result is ``-1``; partly filled otherwise), or (0, 4) for no
    output. The results are those of :func:`first_crossing`, bit for bit.
    """
    given = start.shape[0] > 0
    keep = end.shape[0] > 0
    p0 = np.empty(12)
    p1 = np.empty(12)
    p = np.empty(12)
    v = np.empty(3)
    vs = np.empty(3)
    w = np.empty(3)
    for k in range(pair_dofs.shape[0]):
        for m in range(12):
            p0[m] = q0[pair_dofs[k, m]]
            p1[m] = q1[pair_dofs[k, m]]
        lip = 0.0
        for a in range(2):
            for b in range(2):
                s = 0.0
                for c in range(3):
                    du = (p1[3 * a + c] - p0[3 * a + c]) - (p1[6 + 3 * b + c] - p0[6 + 3 * b + c])
                    s += du * du
                lip = max(lip, math.sqrt(s))
        if given:
            d = start[k, 0]
            for c in range(3):
                v[c] = start[k, 1 + c]
        else:
            d, bi, bj, _ = edge_edge_distance(p0)
            _closest_vector(p0, bi, bj, v)
        d_start = d
        for c in range(3):
            vs[c] = v[c]
        if d < tol[k]:
            return k, MET, 0.0, d
        t = 0.0
        while t < 1.0:
            if lip > 0.0 and d < lip:
                h = d / lip
            else:
                h = 1.0
            short = h < MIN_SUBSTEP
            if short:
                h = MIN_SUBSTEP
            t = min(1.0, t + h)
            if t == 1.0:
                for m in range(12):
                    p[m] = p1[m]
            else:
                _at(p0, p1, t, p)
            d_new, bi, bj, _ = edge_edge_distance(p)
            _closest_vector(p, bi, bj, w)
            if d_new < tol[k]:
                return k, MET, t, d_new
            if short:
                cos = (v[0] * w[0] + v[1] * w[1] + v[2] * w[2]) / (d * d_new)
                if cos < 0.0:
                    return k, TURNED, t, cos
            d = d_new
            for c in range(3):
                v[c] = w[c]
        if d_start < reach[k] or d < reach[k]:
            cos = (vs[0] * v[0] + vs[1] * v[1] + vs[2] * v[2]) / (d_start * d)
            if cos < 0.0:
                return k, FLIPPED, 1.0, cos
        if keep:  # the loop ended at t = 1: d and v are those of q1
            end[k, 0] = d
            for c in range(3):
                end[k, 1 + c] = v[c]
    return -1, NONE, 1.0, 0.0


def pass_through(q0, q1, pairs, pair_dofs, tol, reach=None, start=None, end=None) -> str | None:
    """Message naming the first pair of ``pairs`` (``(k, 2)`` edge numbers, with their
    ``pair_dofs``) that crossed during the step from ``q0`` to ``q1`` (:func:`first_crossing` with
    ``tol`` and ``reach``, m; no end-to-end test without ``reach``), or ``None``. ``start`` and
    ``end``: the distances at ``q0`` given and those at ``q1`` returned
    (:func:`first_crossing_chained`)."""
    if reach is None:
        reach = np.zeros(pairs.shape[0])
    none = np.empty((0, 4))
    k, code, t, value = first_crossing_chained(q0, q1, np.ascontiguousarray(pair_dofs), tol, reach,
                                               none if start is None else start, none if end is None else end)
    if k < 0:
        return None
    a, b = (int(x) for x in pairs[k])
    if code == MET:
        return (f"contact pass-through: edges {a} and {b} changed sides during the step (their centre lines "
                f"met, {value:.3g} m apart, at {t:.3g} of the step)")
    angle = math.degrees(math.acos(max(-1.0, min(1.0, value))))
    where = "during the step" if code == FLIPPED else f"within a short part of the step ending at {t:.3g} of it"
    return (f"contact pass-through: edges {a} and {b} changed sides {where} (the vector between their "
            f"closest points turned by {angle:.0f} deg)")
