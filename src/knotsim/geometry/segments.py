"""Minimum distance between two 3D segments.

Segment ``P`` runs from ``p0`` to ``p1`` and segment ``Q`` from ``q0`` to ``q1``. The distance is

    min over s, t in [0, 1] of |p0 + s (p1 - p0) - (q0 + t (q1 - q0))|,

with ``s, t`` (dimensionless) the ratios of the closest points. Coordinates are in any length unit
(metres everywhere in knotsim); the distance is in the same unit.

* :func:`segment_closest` / :func:`segment_distance`: the scalar ``@njit`` kernel, arguments are
  3-tuples of floats (numba keeps them in registers). It is the one general segment distance of the
  package (contact broad phase, knot clearance checks).
* :func:`segment_distances`: the same kernel over ``(K, 3)`` arrays.
* :func:`clamp01`, :func:`load_edges`, :func:`edge_vectors`: inline helpers shared with the contact
  distance kernels of :mod:`knotsim.contact.distance` and :mod:`knotsim.contact.regularized_distance`
  (those keep their own case-resolved closed forms, needed for consistent derivatives).

Degenerate input: a zero-length segment is handled as a point; (nearly) parallel segments, with
``a e - b^2 <= PARALLEL_TOL a e`` (``a = |p1 - p0|^2``, ``e = |q1 - q0|^2``, ``b`` their dot product),
take ``s = 0`` for the line problem and let the clamping find the closest pair of the segments, which
is exact for exactly parallel segments. The returned value is always the distance of an actual pair
of points on the two segments (the closest pair, up to rounding). The final norm is rescaled when
its square would underflow, so tiny distances are not flushed to zero.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from knotsim import _vec3 as v3

__all__ = [
    "PARALLEL_TOL",
    "clamp01",
    "edge_vectors",
    "load_edges",
    "segment_closest",
    "segment_distance",
    "segment_distances",
]

#: Relative threshold on ``a e - b^2`` (``sin^2`` of the angle between the segments) below which
#: two segments are treated as parallel.
PARALLEL_TOL = 1e-14


@njit(cache=True)
def clamp01(t):
    """``t`` clamped to ``[0, 1]`` (exactly 0.0 or 1.0 at a bound)."""
    if t <= 0.0:
        return 0.0
    if t >= 1.0:
        return 1.0
    return t


@njit(cache=True)
def load_edges(p):
    """The four points ``x0, x1, x2, x3`` (3-tuples) of a flat ``(12,)`` coordinate array."""
    return v3.load(p, 0), v3.load(p, 3), v3.load(p, 6), v3.load(p, 9)


@njit(cache=True)
def edge_vectors(p0, p1, q0, q1):
    """``d1 = p1 - p0``, ``d2 = q1 - q0``, ``r = p0 - q0`` (3-tuples) and ``|d1|^2``, ``|d2|^2``."""
    d1 = v3.sub(p1, p0)
    d2 = v3.sub(q1, q0)
    r = v3.sub(p0, q0)
    return d1, d2, r, v3.dot(d1, d1), v3.dot(d2, d2)


@njit(cache=True)
def segment_closest(p0, p1, q0, q1):
    """Distance and closest-point ratios of segments ``[p0, p1]`` and ``[q0, q1]``.

    Arguments are 3-tuples of floats. Returns ``(dist, s, t)``: the distance (same unit) and the
    ratios in ``[0, 1]`` of the closest points ``p0 + s (p1 - p0)`` and ``q0 + t (q1 - q0)``.
    """
    d1, d2, r, a, e = edge_vectors(p0, p1, q0, q1)
    f = v3.dot(d2, r)
    s = 0.0
    t = 0.0
    if a <= 0.0 and e <= 0.0:
        pass
    elif a <= 0.0:
        t = clamp01(f / e)
    else:
        c = v3.dot(d1, r)
        if e <= 0.0:
            s = clamp01(-c / a)
        else:
            b = v3.dot(d1, d2)
            denom = a * e - b * b
            # Parallel (or nearly): any s works for the line problem; take s = 0 and let the
            # clamping below find the closest pair of the segments.
            if denom > PARALLEL_TOL * a * e:
                s = clamp01((b * f - c * e) / denom)
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = clamp01(-c / a)
            elif t > 1.0:
                t = 1.0
                s = clamp01((b - c) / a)
    w = v3.sub(v3.axpy(s, d1, p0), v3.axpy(t, d2, q0))
    w2 = v3.dot(w, w)
    if w2 > 1e-280:
        return math.sqrt(w2), s, t
    big = max(abs(w[0]), abs(w[1]), abs(w[2]))
    if big == 0.0:
        return 0.0, s, t
    return big * v3.norm((w[0] / big, w[1] / big, w[2] / big)), s, t


@njit(cache=True)
def segment_distance(p0, p1, q0, q1):
    """Minimum distance between segments ``[p0, p1]`` and ``[q0, q1]`` (3-tuples of floats).

    See :func:`segment_closest`; same unit as the coordinates.
    """
    return segment_closest(p0, p1, q0, q1)[0]


@njit(cache=True)
def _segment_distances_kernel(p0, p1, q0, q1, dist, s, t):
    for k in range(p0.shape[0]):
        dist[k], s[k], t[k] = segment_closest(
            (p0[k, 0], p0[k, 1], p0[k, 2]),
            (p1[k, 0], p1[k, 1], p1[k, 2]),
            (q0[k, 0], q0[k, 1], q0[k, 2]),
            (q1[k, 0], q1[k, 1], q1[k, 2]),
        )


def segment_distances(p0, p1, q0, q1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Minimum distances between pairs of 3D segments ``[p0, p1]`` and ``[q0, q1]``.

    Parameters
    ----------
    p0, p1, q0, q1:
        ``(K, 3)`` arrays of segment end points (any length unit).

    Returns
    -------
    dist, s, t:
        ``(K,)`` float arrays: the distance (same unit) and the ratios ``s, t`` in ``[0, 1]`` of the
        closest points ``p0 + s (p1 - p0)`` and ``q0 + t (q1 - q0)`` (:func:`segment_closest`).
    """
    arrs = [np.ascontiguousarray(a, dtype=np.float64) for a in (p0, p1, q0, q1)]
    shape = arrs[0].shape
    if len(shape) != 2 or shape[1] != 3 or any(a.shape != shape for a in arrs):
        raise ValueError(f"segment_distances: expected four (K, 3) arrays, got shapes {[a.shape for a in arrs]}")
    n = shape[0]
    dist = np.empty(n)
    s = np.empty(n)
    t = np.empty(n)
    _segment_distances_kernel(*arrs, dist, s, t)
    return dist, s, t
