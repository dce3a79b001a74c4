"""Continuous check over a time step: did a rod pass through an obstacle?

A step moves every node along a straight line from ``q0`` (start of the step) to ``q1`` (its end)
and the obstacle rigidly from its pose at the start to its pose at the end: its pivot ``c`` along a
straight line ``c0 → c0 + Δc`` and its rotation by ``θ s`` (``θ = ω dt``, rad, a 3-vector) about
the moving pivot, at the step fraction ``s`` in ``[0, 1]``. The end-of-step check of
:meth:`knotsim.contact.obstacles.Obstacle.check` sees only where the nodes end; a node (or a thin
post between two nodes) can go through the obstacle within the step and end outside it.

The test works in the obstacle's frame at the start of the step: a point ``x`` at fraction ``s``
is at ``z(s) = Q(s) (x(s) − c(s)) + c0`` (``Q(s)`` the rotation by ``−θ s``), and the obstacle there
is its start pose, packed ``geom0 (7,)`` as in :mod:`knotsim.contact.obstacle_kernels` (plane,
sphere, capsule). ``dz/ds = Q (u − Δc − θ × (x − c))``, so a node moving by ``u`` moves in that
frame at most ``L = |u − Δc| + |θ| max(|x0 − c0|, |x1 − c1|)`` per unit of ``s`` (``|x(s) − c(s)|``
is convex in ``s``: largest at an end), and its distance to the obstacle's core is
``L``-Lipschitz in ``s``. An edge's points move by at most ``L_e = max(|u_a − Δc|, |u_b − Δc|) +
|θ| max|x − c|`` over its four end positions.

Two tests (numba ``@njit(cache=True)``, scalar code, one pass over the nodes and the edges):

- node: the signed gap ``φ(s) = dist(z(s), core) − (R + h)`` (m; the plane's signed distance, the
  distance to the sphere's centre or to the capsule's axis segment, minus the contact distance) fell
  below ``τ = min(0, φ(0), φ(1)) − limit h`` somewhere in the step: the node went deeper than
  ``limit`` (the obstacle's ``penetration_limit``) times its radius below the surface, or below its
  deeper end if that end is already inside. Passing through a plane, or through a post's axis or a
  sphere's centre, is such a dive; so is a slide of ``u`` over a curved obstacle whose chord cuts in
  by its sagitta ``≈ u²/(8 (R + h))`` beyond the limit, i.e. ``u`` above about
  ``√(8 (R + h) limit h)`` in one step (the straight motion is the step's own assumption; a shorter
  step follows the surface). As ``φ(s) ≥ min(φ(0), φ(1)) − L/2``, nodes with ``L ≤ 2 limit h`` are
  never tested (a rod resting on or sliding slowly over an obstacle costs one bound per node), nor
  are nodes with ``φ(0) + φ(1) − L ≥ 2τ``, nor any node on a plane that does not rotate (its gap is
  linear in ``s``).
- edge (sphere and capsule): the edge's centre line came within ``r_core = (R + (1 − limit) h)/2``
  (m) of the core (the capsule's axis segment, the sphere's centre) from outside it: a thin post or
  small ball went between two nodes that never touched it (an edge already that close at the start
  of the step, which only a run that started so can have, is not flagged again). Legal end positions (both nodes at least
  ``R + (1 − limit) h`` from the core) keep every point of an edge of length ``l`` at least
  ``sqrt((R + (1 − limit) h)² − l²/4)`` away (the squared distance to a convex set has curvature at
  most 2), so edges shorter than ``√3 (R + (1 − limit) h)`` never trigger it at rest. It runs every
  step (a rope pulled slowly lengthwise over a thin pin brings its edges onto it in small steps),
  but an edge is skipped at the price of a few flops when the bound ``(d_a + d_b − l)/2 − L_e`` from
  its nodes' end distances ``d`` (given) and end length ``l`` clears ``r_core``.

Both advance conservatively like :func:`knotsim.contact.swept.first_crossing`: from a sample at
``s`` with margin ``m`` above the threshold the next ``m/L`` of the step cannot cross it, so the
next sample is taken there, but at least ``MIN_SUBSTEP`` (1/1024) of the step further on; a
crossing is reported when a sample falls below the threshold. Nothing is flagged that did not go
below it, and what is missed went below it by less than ``MIN_SUBSTEP × L / 2`` (between two samples
``MIN_SUBSTEP`` apart, both above the threshold). A node far from the threshold costs two samples,
one passing within ``m`` of it about ``L/m``, at most 1024.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from knotsim import _vec3 as v3
from knotsim.contact.distance import _point_segment, edge_edge_distance
from knotsim.contact.obstacle_kernels import CAPSULE, PLANE, SPHERE
from knotsim.contact.swept import MIN_SUBSTEP

__all__ = ["EDGE", "MIN_SUBSTEP", "NODE", "NONE", "core_radius", "first_pass_through"]

#: Result codes of :func:`first_pass_through`.
NONE, NODE, EDGE = 0, 1, 2


def core_radius(R: float, h: float, limit: float) -> float:
    """Half the closest legal distance ``R + (1 − limit) h`` of a node to the core (m), the radius
    of the core region of the edge test (``R`` obstacle radius, ``h`` rod radius, m)."""
    return 0.5 * max(R + (1.0 - limit) * h, 0.0)


@njit(cache=True)
def _frame(x0, x1, s, c0, dc, k, ang):
    """``z(s)`` (module doc) of the point moving from ``x0`` to ``x1`` (3-tuples, m): the
    rotation by ``−ang s`` about the unit axis ``k`` of ``x(s) − c(s)``, plus ``c0``."""
    y = (x0[0] + s * (x1[0] - x0[0]) - c0[0] - s * dc[0],
         x0[1] + s * (x1[1] - x0[1]) - c0[1] - s * dc[1],
         x0[2] + s * (x1[2] - x0[2]) - c0[2] - s * dc[2])
    if ang > 0.0:
        a = -ang * s
        cs = math.cos(a)
        sn = math.sin(a)
        kxy = v3.cross(k, y)
        ky = v3.dot(k, y) * (1.0 - cs)
        y = (y[0] * cs + kxy[0] * sn + k[0] * ky, y[1] * cs + kxy[1] * sn + k[1] * ky,
             y[2] * cs + kxy[2] * sn + k[2] * ky)
    return (y[0] + c0[0], y[1] + c0[1], y[2] + c0[2])


@njit(cache=True)
def _core_distance(kind, z, g):
    """Distance (m) of point ``z`` to the core of the obstacle ``g (7,)``: signed to a plane, to
    the sphere's centre, to the capsule's axis segment."""
    if kind == PLANE:
        return (z[0] - g[0]) * g[3] + (z[1] - g[1]) * g[4] + (z[2] - g[2]) * g[5]
    a = (g[0], g[1], g[2])
    if kind == SPHERE:
        return v3.norm(v3.sub(z, a))
    d = (g[3] - g[0], g[4] - g[1], g[5] - g[2])
    _, d2 = _point_segment(z, a, d, v3.dot(d, d))
    return math.sqrt(d2)


@njit(cache=True)
def _edge_core_distance(kind, za, zb, g, p):
    """Distance (m) of the segment ``za zb`` to the core of a sphere or capsule ``g``; ``p (12,)``
    scratch."""
    if kind == SPHERE:
        d = v3.sub(zb, za)
        _, d2 = _point_segment((g[0], g[1], g[2]), za, d, v3.dot(d, d))
        return math.sqrt(d2)
    for c in range(3):
        p[c] = za[c]
        p[3 + c] = zb[c]
        p[6 + c] = g[c]
        p[9 + c] = g[3 + c]
    dist, _, _, _ = edge_edge_distance(p)
    return dist


@njit(cache=True)
def first_pass_through(kind, geom0, c0, dc, theta, q0, q1, node_dof, node_h, gap1, edges, limit, scratch):
    """First node or edge of a rod that passed through an obstacle during the step (module doc).

    Parameters
    ----------
    kind : ``PLANE``, ``SPHERE`` or ``CAPSULE``; ``geom0 (7,)``: the obstacle at the start of the
        step (packed as in :mod:`~knotsim.contact.obstacle_kernels`, m).
    c0, dc, theta : (3,) its pivot at the start of the step (m), the pivot's displacement over the
        step (m) and its rotation over the step ``ω dt`` (rad).
    q0, q1 : (n_dofs,) unknowns at the start and the end of the step (m, rad).
    node_dof : (k,) int64, the first unknown of each node; ``node_h`` (k,) their radii (m).
    gap1 : (k,) the nodes' gaps ``Δ − (R + h)`` at the end of the step (m), as the contact kernels
        give them (the edge test's bounds; a gap's round-off is covered by a margin).
    edges : (e, 2) int64, the edges as pairs of indices into ``node_dof``.
    limit : the obstacle's penetration limit (fraction of ``h``).
    scratch : (k,) float64, work space (the nodes' ``L``, m).

    Returns ``(code, index, s, value)``: ``NODE`` (index into ``node_dof``; ``value`` the gap
    ``φ(s)``, m) or, when no node passed, ``EDGE`` (index into ``edges``; ``value`` the distance of
    its centre line to the core, m), at the first sample ``s`` (step fraction) found beyond the
    threshold; of several, the node whose sample was the deepest in radii, the edge whose was the
    closest to the core in core radii. ``(NONE, -1, 1.0, 0.0)`` if none.
    """
    R = geom0[6] if kind != PLANE else 0.0
    ang = math.sqrt(theta[0] * theta[0] + theta[1] * theta[1] + theta[2] * theta[2])
    k = (0.0, 0.0, 1.0)
    if ang > 0.0:
        k = (theta[0] / ang, theta[1] / ang, theta[2] / ang)
    c = (c0[0], c0[1], c0[2])
    cd = (dc[0], dc[1], dc[2])
    c1 = v3.add(c, cd)
    if kind == PLANE and ang == 0.0:
        return NONE, -1, 1.0, 0.0  # the gap to a plane that does not turn is linear in s
    n = node_dof.shape[0]
    for i in range(n):
        j = node_dof[i]
        x0 = (q0[j], q0[j + 1], q0[j + 2])
        x1 = (q1[j], q1[j + 1], q1[j + 2])
        L = v3.norm(v3.sub(v3.sub(x1, x0), cd))
        if ang > 0.0:
            L += ang * max(v3.norm(v3.sub(x0, c)), v3.norm(v3.sub(x1, c1)))
        scratch[i] = L
    best, best_s, best_value = -1, 1.0, 0.0
    for i in range(n):
        L = scratch[i]
        h = node_h[i]
        if L <= 2.0 * limit * h:
            continue
        j = node_dof[i]
        x0 = (q0[j], q0[j + 1], q0[j + 2])
        x1 = (q1[j], q1[j + 1], q1[j + 2])
        rho = R + h
        phi0 = _core_distance(kind, _frame(x0, x1, 0.0, c, cd, k, ang), geom0) - rho
        phi1 = _core_distance(kind, _frame(x0, x1, 1.0, c, cd, k, ang), geom0) - rho
        tau = min(0.0, phi0, phi1) - limit * h
        if phi0 + phi1 - L >= 2.0 * tau:
            continue
        s = 0.0
        phi = phi0
        while True:
            s += max((phi - tau) / L, MIN_SUBSTEP)
            if s >= 1.0:
                break
            phi = _core_distance(kind, _frame(x0, x1, s, c, cd, k, ang), geom0) - rho
            if phi < tau:
                if best < 0 or -phi / h > -best_value / node_h[best]:
                    best, best_s, best_value = i, s, phi
                break
    if best >= 0:
        return NODE, best, best_s, best_value
    if kind == PLANE:
        return NONE, -1, 1.0, 0.0  # an edge's closest point to a plane is one of its nodes
    p = np.empty(12)
    best_r = 1.0
    for e in range(edges.shape[0]):
        ia = edges[e, 0]
        ib = edges[e, 1]
        h = node_h[ia]
        r_core = 0.5 * (R + (1.0 - limit) * h)
        if r_core <= 0.0:
            continue
        ja = node_dof[ia]
        jb = node_dof[ib]
        xa0 = (q0[ja], q0[ja + 1], q0[ja + 2])
        xa1 = (q1[ja], q1[ja + 1], q1[ja + 2])
        xb0 = (q0[jb], q0[jb + 1], q0[jb + 2])
        xb1 = (q1[jb], q1[jb + 1], q1[jb + 2])
        Le = max(v3.norm(v3.sub(v3.sub(xa1, xa0), cd)), v3.norm(v3.sub(v3.sub(xb1, xb0), cd)))
        if ang > 0.0:
            r = max(max(v3.norm(v3.sub(xa0, c)), v3.norm(v3.sub(xa1, c1))),
                    max(v3.norm(v3.sub(xb0, c)), v3.norm(v3.sub(xb1, c1))))
            Le += ang * r
        # lower bound of the centre line's distance to the core over the whole step, from the end
        da = gap1[ia] + R + h
        db = gap1[ib] + node_h[ib] + R
        lb = 0.5 * (da + db - v3.norm(v3.sub(xb1, xa1))) - Le
        if lb >= r_core + 1e-9 * (R + h):
            continue
        D0 = _edge_core_distance(kind, _frame(xa0, xa1, 0.0, c, cd, k, ang), _frame(xb0, xb1, 0.0, c, cd, k, ang),
                                 geom0, p)
        if D0 < r_core:
            continue  # inside the core region at the start of the step: it did not pass in this step
        D1 = _edge_core_distance(kind, _frame(xa0, xa1, 1.0, c, cd, k, ang), _frame(xb0, xb1, 1.0, c, cd, k, ang),
                                 geom0, p)
        s = 1.0
        D = D1
        if D1 >= r_core and D0 + D1 - Le < 2.0 * r_core:
            s = 0.0
            D = D0
            while True:
                s += max((D - r_core) / Le, MIN_SUBSTEP)
                if s >= 1.0:
                    break
                D = _edge_core_distance(kind, _frame(xa0, xa1, s, c, cd, k, ang),
                                        _frame(xb0, xb1, s, c, cd, k, ang), geom0, p)
                if D < r_core:
                    break
        if D < r_core and (best < 0 or D / r_core < best_value / best_r):
            best, best_s, best_value, best_r = e, min(s, 1.0), D, r_core
    if best >= 0:
        return EDGE, best, best_s, best_value
    return NONE, -1, 1.0, 0.0


def obstacle_edges(model, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The edges of the rods whose global ``nodes (k,)`` (sorted) touch an obstacle: ``(e, 2)``
    int64 indices into ``nodes`` and ``(e,)`` int64 global edge numbers."""
    m = model
    ids = np.flatnonzero(np.isin(m.edge_nodes[:, 0], nodes) & np.isin(m.edge_nodes[:, 1], nodes))
    local = np.searchsorted(nodes, m.edge_nodes[ids]).astype(np.int64)
    return np.ascontiguousarray(local.reshape(-1, 2)), ids.astype(np.int64)


def describe(obstacle, code: int, index: int, s: float, value: float, t0: float, dt: float) -> str:
    """Reason (for :class:`~knotsim.solver.stepper.StepFailure`) of a pass-through found by
    :func:`first_pass_through` in the step from ``t0`` over ``dt`` (s): names the obstacle, the rod,
    the node or edge within the rod and the time."""
    o = obstacle
    m = o.model
    when = f"at t = {t0 + s * dt:.6g} s ({s:.3g} of the step from t = {t0:.6g} s)"
    if code == NODE:
        n = int(o.nodes[index])
        rod = int(m.node_rod[n])
        h = float(o.node_h[index])
        return (f"obstacle {o.name!r}: node {n - int(m.rod_node_start[rod])} of rod {m.rod_names[rod]!r} passed "
                f"through it during the step: along its straight motion it was {-value:.3g} m ({-value / h:.3g} x "
                f"its radius) below the surface {when}; penetration_limit {o.penetration_limit}")
    e = int(o._edge_ids[index])
    rod = int(m.edge_rod[e])
    h = float(m.edge_radius[e])
    core = "axis" if o.kind == CAPSULE else "centre"
    r = core_radius(float(o.radius), h, o.penetration_limit)
    return (f"obstacle {o.name!r}: edge {int(m.edge_local[e])} of rod {m.rod_names[rod]!r} passed through it between "
            f"its nodes during the step: its centre line came {value:.3g} m from the obstacle's {core} {when} (limit "
            f"{r:.3g} m, half the closest legal node distance); use edges shorter than {2 * math.sqrt(3.0) * r:.3g} m "
            f"on this obstacle, or a smaller dt")
