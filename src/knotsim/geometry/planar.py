"""Crossings of projected polylines: one numba sweep over 2D segments.

The polylines are given by their projected nodes ``(x, y)`` (any length unit) and a segment list
``seg0[k] -> seg1[k]`` (node indices), so open polylines and closed polygons use the same code.
Segments that share a node (consecutive edges) are never paired. Candidates are found by a sweep
over the segment boxes sorted by their lower ``x`` (sweep and prune), and every surviving pair gets
the exact line-line intersection ``s, t`` (ratios along the two segments).

Two acceptance modes:

* ``half_open=True`` (knot drawings, :mod:`knotsim.knots.crossings`): a crossing needs
  ``0 <= s < 1`` and ``0 <= t < 1``, so a crossing exactly at a node counts once; nothing is flagged.
* ``half_open=False`` (knot diagrams, :mod:`knotsim.knots.topology.diagram`): a crossing needs
  ``s, t`` in ``[-eps_param, 1 + eps_param]``; configurations that make the projection non-generic
  set a degeneracy flag (:data:`DEGENERACY`) so the caller can try another direction.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from knotsim._util.sorting import argsort_stable

__all__ = ["DEGENERACY", "segment_crossings"]

#: Degeneracy flags of :func:`segment_crossings` (``half_open=False``).
DEGENERACY = {
    1: "a crossing lies at a polygon vertex",
    2: "a crossing is nearly tangent",
    3: "two projected segments overlap",
    4: "two strands nearly intersect in 3D",
    5: "a segment is parallel to the projection direction",
}


@njit(cache=True)
def _crossings_kernel(x, y, h, seg0, seg1, eps_parallel, eps_param, eps_sin, eps_len, eps_h, pad,
                      half_open, cap):
    """All proper crossings between the projected segments ``seg0[k] -> seg1[k]``.

    Returns ``(seg_a, s_a, seg_b, s_b, count, flag)``; ``count > cap`` means the buffers were too
    small; ``flag != 0`` flags a degeneracy (see ``DEGENERACY``; never with ``half_open``).
    """
    n = seg0.shape[0]
    xmin = np.empty(n)
    xmax = np.empty(n)
    ymin = np.empty(n)
    ymax = np.empty(n)
    flag = 0
    for k in range(n):
        i = seg0[k]
        j = seg1[k]
        xmin[k] = min(x[i], x[j]) - pad
        xmax[k] = max(x[i], x[j]) + pad
        ymin[k] = min(y[i], y[j]) - pad
        ymax[k] = max(y[i], y[j]) + pad
        if not half_open and math.hypot(x[j] - x[i], y[j] - y[i]) <= eps_len:
            flag = 5
    order = argsort_stable(xmin)
    seg_a = np.empty(cap, dtype=np.int64)
    seg_b = np.empty(cap, dtype=np.int64)
    s_a = np.empty(cap)
    s_b = np.empty(cap)
    count = 0
    if flag != 0:
        return seg_a, s_a, seg_b, s_b, count, flag
    for ia in range(n):
        a = order[ia]
        a0 = seg0[a]
        na = seg1[a]
        ax0 = x[a0]
        ay0 = y[a0]
        rx = x[na] - ax0
        ry = y[na] - ay0
        lr = math.hypot(rx, ry)
        for ib in range(ia + 1, n):
            b = order[ib]
            if xmin[b] > xmax[a]:
                break
            if ymin[b] > ymax[a] or ymax[b] < ymin[a]:
                continue
            b0 = seg0[b]
            nb = seg1[b]
            if nb == a0 or na == b0:
                continue
            ux = x[nb] - x[b0]
            uy = y[nb] - y[b0]
            lu = math.hypot(ux, uy)
            qx = x[b0] - ax0
            qy = y[b0] - ay0
            den = rx * uy - ry * ux
            if abs(den) <= eps_parallel * lr * lu:
                if not half_open and abs(qx * ry - qy * rx) / lr <= eps_len:
                    flag = 3
                continue
            s = (qx * uy - qy * ux) / den
            t = (qx * ry - qy * rx) / den
            if half_open:
                if s < 0.0 or s >= 1.0 or t < 0.0 or t >= 1.0:
                    continue
            else:
                if s < -eps_param or s > 1.0 + eps_param or t < -eps_param or t > 1.0 + eps_param:
                    continue
                if s < eps_param or s > 1.0 - eps_param or t < eps_param or t > 1.0 - eps_param:
                    flag = 1
                    continue
                if abs(den) < eps_sin * lr * lu:
                    flag = 2
                ha = h[a0] + s * (h[na] - h[a0])
                hb = h[b0] + t * (h[nb] - h[b0])
                if abs(ha - hb) <= eps_h:
                    flag = 4
            if count < cap:
                seg_a[count] = a
                s_a[count] = s
                seg_b[count] = b
                s_b[count] = t
            count += 1
    return seg_a, s_a, seg_b, s_b, count, flag


def segment_crossings(
    x: np.ndarray,
    y: np.ndarray,
    seg0: np.ndarray,
    seg1: np.ndarray,
    *,
    h: np.ndarray | None = None,
    half_open: bool = False,
    eps_parallel: float = 1e-12,
    eps_param: float = 1e-9,
    eps_sin: float = 1e-7,
    eps_len: float = 0.0,
    eps_h: float = 0.0,
    pad: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """All crossings between the projected segments ``seg0[k] -> seg1[k]``.

    Parameters
    ----------
    x, y:
        ``(N,)`` float arrays, projected node coordinates (any length unit).
    seg0, seg1:
        ``(K,)`` int arrays, first and second node of every segment.
    h:
        ``(N,)`` heights of the nodes along the projection direction (same unit), used only for the
        "strands nearly intersect in 3D" flag (``half_open=False``); ``None``: zeros.
    half_open:
        Acceptance mode (module docstring).
    eps_parallel:
        Pairs with ``|r x u| <= eps_parallel |r| |u|`` (``r, u`` the segment vectors) are parallel and
        never cross.
    eps_param, eps_sin, eps_len, eps_h:
        Degeneracy tolerances (``half_open=False`` only): ratio distance to a vertex, sine of a
        near-tangent crossing, projected length / overlap distance, and height gap (length unit).
    pad:
        Slack (length unit) added to the sweep boxes; it only makes the sweep test more pairs.

    Returns
    -------
    ``(seg_a, s_a, seg_b, s_b, flag)``: ``(n,)`` arrays of the two segment indices of every crossing
    and the ratios along them (the crossing point is at ``s_a`` along ``seg_a`` and ``s_b`` along
    ``seg_b``), in sweep order, and the degeneracy flag (0: none, see :data:`DEGENERACY`).
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    y = np.ascontiguousarray(y, dtype=np.float64)
    h = np.zeros_like(x) if h is None else np.ascontiguousarray(h, dtype=np.float64)
    seg0 = np.ascontiguousarray(seg0, dtype=np.int64)
    seg1 = np.ascontiguousarray(seg1, dtype=np.int64)
    cap = 4 * len(seg0) + 64
    while True:
        res = _crossings_kernel(x, y, h, seg0, seg1, eps_parallel, eps_param, eps_sin, eps_len, eps_h,
                                pad, half_open, cap)
        if res[4] <= cap:
            break
        cap = res[4] + 16
    seg_a, s_a, seg_b, s_b, count, flag = res
    return seg_a[:count], s_a[:count], seg_b[:count], s_b[:count], int(flag)
