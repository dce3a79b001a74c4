"""Diagnostics of the rope-rope contact: overlapping rods at the start, the pair near a stalled node.

Functions of a :class:`~knotsim.contact.model.Contact` (its model, options, pairs and last
evaluation); the contact's methods of the same names call them.
"""

from __future__ import annotations

import math

import numpy as np

from knotsim.errors import GeometryError
from knotsim.geometry.segments import segment_distances


def check_start(contact, q) -> None:
    """Raise :class:`~knotsim.errors.GeometryError` when two rods (or two parts of one rod that
    may touch) overlap at ``q`` deeper than ``penetration_limit`` times the smaller radius: the
    first step would be rejected, and a penalty model cannot undo a start inside the other rope.
    The message names the rods, edges and distance."""
    m = contact.model
    pairs = contact._broad_phase(q, 0.0)
    if not pairs.shape[0]:
        return
    x = m.node_positions(q)
    en = m.edge_nodes
    d, _, _ = segment_distances(x[en[pairs[:, 0], 0]], x[en[pairs[:, 0], 1]], x[en[pairs[:, 1], 0]],
                                x[en[pairs[:, 1], 1]])
    ra, rb = m.edge_radius[pairs[:, 0]], m.edge_radius[pairs[:, 1]]
    depth = (ra + rb - d) / np.minimum(ra, rb)
    k = int(np.argmax(depth))
    if depth[k] > contact.options.penetration_limit:
        a, b = (int(v) for v in pairs[k])
        name = lambda e: f"rod {m.rod_names[m.edge_rod[e]]!r} edge {int(m.edge_local[e])}"  # noqa: E731
        raise GeometryError(
            f"the rods overlap at the start: {name(a)} and {name(b)} are {d[k]:.4g} m apart, "
            f"{depth[k]:.2f} radii closer than contact ({ra[k] + rb[k]:.4g} m; limit "
            f"{contact.options.penetration_limit} radii); move them apart, scale the geometry, or use a "
            f"smaller radius")


def describe_near(contact, q, node: int) -> str:
    """Text naming a candidate pair that has ``node`` (global node number) on one of its edges
    (a nearly parallel pair in contact if there is one, else the closest pair): its edges, gap
    ``Δ − d`` (m) and the angle between the edges (degrees); "" if none. Used in the message of a
    failed step."""
    m = contact.model
    k = contact.pair_dofs.shape[0]
    if not k:
        return ""
    dof = int(m.node_dof[node])
    has = np.flatnonzero(np.any(contact.pair_dofs == dof, axis=1))
    if not has.size:
        return ""
    ev = contact._evaluated_at(q)
    gaps = ev.delta[has] - contact.pair_d[has]

    def angle_of(p: int) -> float:
        x = q[contact.pair_dofs[p]].reshape(4, 3)
        e1, e2 = x[1] - x[0], x[3] - x[2]
        c = abs(float(np.dot(e1, e2))) / max(float(np.linalg.norm(e1) * np.linalg.norm(e2)), 1e-300)
        return math.degrees(math.acos(min(1.0, c)))

    # a nearly parallel pair in contact is the likely culprit; otherwise the closest pair
    touching = [int(p) for p, g in zip(has, gaps, strict=True) if g < contact.options.delta]
    parallel = [p for p in touching if angle_of(p) < 1.0]
    p = parallel[0] if parallel else int(has[np.argmin(gaps)])
    angle = angle_of(p)
    a, b = (int(v) for v in contact.pairs[p])
    text = (f"in contact with a gap of {ev.delta[p] - contact.pair_d[p]:.3g} m between edges {a} and {b} "
            f"({angle:.3g} deg apart)")
    if angle < 1.0:
        if contact.options.parallel_smoothing > 0.0:
            text += "; nearly parallel edges in contact"
        else:
            text += ("; nearly parallel edges in contact: with contact.parallel_smoothing = 0 the edge-edge "
                     "contact energy has a kink there (see docs/performance.md)")
    return text
