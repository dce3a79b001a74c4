"""Reference and material frames of the edges (numba kernels).

Each edge carries a unit tangent ``t``, a reference director ``d1`` (unit, normal to ``t``) and
``d2 = t x d1``. Reference directors follow the edges in time by parallel transport (time-parallel
transport); the *reference twist* of an interior node is the signed angle, about the second edge's
tangent, from the first edge's ``d1`` parallel-transported onto the second edge to the second edge's
``d1``. The material frame is the reference frame rotated by the edge angle ``theta``:
``m1 = cos(theta) d1 + sin(theta) d2``, ``m2 = -sin(theta) d1 + cos(theta) d2``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from knotsim import _vec3 as v3


@njit(inline="always", cache=True)
def transport(u, a, b):
    """Parallel transport of vector ``u`` from unit tangent ``a`` to unit tangent ``b``.

    Rotation about ``a x b`` taking ``a`` to ``b`` (Rodrigues' formula without trigonometry):
    ``u c + (a x b) x u + (a x b)((a x b) . u)/(1 + c)`` with ``c = a . b``. Undefined for
    ``b = -a``; there the vector is returned unchanged.
    """
    c = v3.dot(a, b)
    w = v3.cross(a, b)
    if c <= -1.0 + 1e-14:
        return u
    k = v3.dot(w, u) / (1.0 + c)
    r = v3.cross(w, u)
    return (u[0] * c + r[0] + w[0] * k, u[1] * c + r[1] + w[1] * k, u[2] * c + r[2] + w[2] * k)


@njit(inline="always", cache=True)
def signed_angle(u, w, axis):
    """Angle (rad) rotating unit vector ``u`` to ``w`` about ``axis`` (both normal to ``axis``)."""
    c = v3.cross(u, w)
    return math.atan2(v3.dot(c, axis), v3.dot(u, w))


@njit(cache=True)
def compute_tangents(q, edge_dofs, tangents, lengths):
    """Unit tangents ``(ne, 3)`` and lengths ``(ne,)`` (m) of every edge, written in place."""
    for e in range(edge_dofs.shape[0]):
        a = v3.load(q, edge_dofs[e, 0])
        b = v3.load(q, edge_dofs[e, 1])
        d = v3.sub(b, a)
        n = v3.norm(d)
        lengths[e] = n
        inv = 1.0 / n if n > 0.0 else 0.0
        tangents[e, 0] = d[0] * inv
        tangents[e, 1] = d[1] * inv
        tangents[e, 2] = d[2] * inv


@njit(cache=True)
def transport_directors(d1_old, t_old, t_new, d1_new):
    """Time-parallel transport of every reference director from ``t_old`` to ``t_new``.

    Arrays of shape ``(ne, 3)``; the result is re-orthonormalised against ``t_new``.
    """
    for e in range(d1_old.shape[0]):
        a = (t_old[e, 0], t_old[e, 1], t_old[e, 2])
        b = (t_new[e, 0], t_new[e, 1], t_new[e, 2])
        u = transport((d1_old[e, 0], d1_old[e, 1], d1_old[e, 2]), a, b)
        u = v3.sub(u, v3.scale(v3.dot(u, b), b))
        n = v3.norm(u)
        d1_new[e, 0] = u[0] / n
        d1_new[e, 1] = u[1] / n
        d1_new[e, 2] = u[2] / n


@njit(cache=True)
def reference_twist(d1, tangents, bend_edges, twist_prev, twist_out):
    """Reference twist (rad) of every bending stencil, continuous with ``twist_prev``.

    ``bend_edges (nb, 2)`` gives the two edges of each stencil. The raw angle lies in
    ``(-pi, pi]``; the result is shifted by a multiple of ``2 pi`` to be closest to
    ``twist_prev`` so the reference twist never jumps.
    """
    for s in range(bend_edges.shape[0]):
        e = bend_edges[s, 0]
        f = bend_edges[s, 1]
        te = (tangents[e, 0], tangents[e, 1], tangents[e, 2])
        tf = (tangents[f, 0], tangents[f, 1], tangents[f, 2])
        u = transport((d1[e, 0], d1[e, 1], d1[e, 2]), te, tf)
        ang = signed_angle(u, (d1[f, 0], d1[f, 1], d1[f, 2]), tf)
        prev = twist_prev[s]
        k = math.floor((prev - ang) / (2.0 * math.pi) + 0.5)
        twist_out[s] = ang + 2.0 * math.pi * k


@njit(inline="always", cache=True)
def material_frame(e, d1, tangents, theta, m1, m2):
    """Material directors ``m1[e], m2[e]`` of edge ``e`` turned by ``theta`` (rad) from its reference
    director ``d1[e]`` about its tangent."""
    t = (tangents[e, 0], tangents[e, 1], tangents[e, 2])
    a = (d1[e, 0], d1[e, 1], d1[e, 2])
    b = v3.cross(t, a)
    c = math.cos(theta)
    s = math.sin(theta)
    for k in range(3):
        m1[e, k] = c * a[k] + s * b[k]
        m2[e, k] = -s * a[k] + c * b[k]


@njit(cache=True)
def material_frames(d1, tangents, theta, m1, m2):
    """Material directors ``m1, m2`` ``(ne, 3)`` from reference directors and edge angles ``theta``."""
    for e in range(d1.shape[0]):
        material_frame(e, d1, tangents, theta[e], m1, m2)


@njit(cache=True)
def turned_material_frames(q, q_at, theta_mask, edge_theta_dof, bend_edges, d1, tangents, m1, m2, stencil_turned):
    """The material frames of the edges turned since ``q_at``, when only edge angles changed.

    ``q``, ``q_at`` (n_dofs,) unknowns now and at the evaluation the frames ``d1, tangents, m1, m2``
    (ne, 3) belong to; ``theta_mask`` (n_dofs,) bool, the edge angles; ``edge_theta_dof`` (ne,),
    ``bend_edges`` (nb, 2) int64. Returns ``False``, writing nothing, when a position differs between
    ``q`` and ``q_at``. Otherwise rewrites ``m1, m2`` of every edge whose angle differs, marks in
    ``stencil_turned`` (nb,) bool the stencils with such an edge, and returns ``True``.
    """
    for i in range(q.shape[0]):
        if q[i] != q_at[i] and not theta_mask[i]:
            return False
    for s in range(bend_edges.shape[0]):
        stencil_turned[s] = False
    for e in range(edge_theta_dof.shape[0]):
        d = edge_theta_dof[e]
        if q[d] != q_at[d]:
            material_frame(e, d1, tangents, q[d], m1, m2)
    for s in range(bend_edges.shape[0]):
        de = edge_theta_dof[bend_edges[s, 0]]
        df = edge_theta_dof[bend_edges[s, 1]]
        stencil_turned[s] = q[de] != q_at[de] or q[df] != q_at[df]
    return True


@njit(cache=True)
def update_frames(q, edge_dofs, edge_theta_dof, bend_edges, d1_old, t_old, twist_prev, tangents, lengths, d1,
                  ref_twist, m1, m2):
    """All frames of a configuration in one call: :func:`compute_tangents`, then
    :func:`transport_directors` from ``(d1_old, t_old)``, :func:`reference_twist` continuous with
    ``twist_prev`` and :func:`material_frames` with the edge angles ``q[edge_theta_dof]``.

    ``q (n_dofs,)``; ``edge_dofs (ne, 2)``, ``edge_theta_dof (ne,)``, ``bend_edges (nb, 2)`` int64;
    outputs ``tangents, d1, m1, m2 (ne, 3)``, ``lengths (ne,)`` (m), ``ref_twist (nb,)`` (rad).
    """
    compute_tangents(q, edge_dofs, tangents, lengths)
    transport_directors(d1_old, t_old, tangents, d1)
    reference_twist(d1, tangents, bend_edges, twist_prev, ref_twist)
    for e in range(d1.shape[0]):
        material_frame(e, d1, tangents, q[edge_theta_dof[e]], m1, m2)


def space_parallel_directors(tangents: np.ndarray, closed: bool, first: np.ndarray | None = None) -> np.ndarray:
    """Reference directors of one rod by space-parallel transport along the rod.

    ``tangents (ne, 3)`` unit tangents; ``first`` optional director of edge 0 (projected normal to
    it). Returns ``(ne, 3)``. Runs once per rod at set-up, so plain Python is fine.
    """
    ne = tangents.shape[0]
    t0 = tangents[0]
    if first is None:
        trial = np.array([0.0, 0.0, 1.0]) if abs(t0[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    else:
        trial = np.asarray(first, float)
    d = trial - np.dot(trial, t0) * t0
    if np.linalg.norm(d) < 1e-12:
        trial = np.array([0.0, 1.0, 0.0])
        d = trial - np.dot(trial, t0) * t0
    d /= np.linalg.norm(d)
    out = np.empty((ne, 3))
    out[0] = d
    for e in range(1, ne):
        u = np.array(transport((out[e - 1, 0], out[e - 1, 1], out[e - 1, 2]), tuple(tangents[e - 1]),
                               tuple(tangents[e])))
        u -= np.dot(u, tangents[e]) * tangents[e]
        out[e] = u / np.linalg.norm(u)
    return out
