"""Simulation state: everything that changes during a run."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from knotsim.rods.frames import (
    compute_tangents,
    material_frames,
    reference_twist,
    space_parallel_directors,
    transport_directors,
)


@dataclass
class State:
    """State of all rods at time ``time``.

    - ``q (n_dofs,)``: positions (m) and edge angles (rad), layout in ``docs/architecture.md``;
    - ``v (n_dofs,)``: their rates (m/s, rad/s);
    - ``d1 (n_edges, 3)``: reference directors; ``tangents (n_edges, 3)``: unit edge tangents at ``q``;
    - ``ref_twist (n_bend,)``: reference twist (rad) of each interior node;
    - ``time``: s.
    """

    q: np.ndarray
    v: np.ndarray
    d1: np.ndarray
    tangents: np.ndarray
    ref_twist: np.ndarray
    time: float = 0.0
    extra: dict = field(default_factory=dict)

    def copy(self) -> State:
        return State(self.q.copy(), self.v.copy(), self.d1.copy(), self.tangents.copy(),
                     self.ref_twist.copy(), self.time, dict(self.extra))

    def assign(self, other: State) -> None:
        """Copy ``other`` into this state in place."""
        self.q[:] = other.q
        self.v[:] = other.v
        self.d1[:] = other.d1
        self.tangents[:] = other.tangents
        self.ref_twist[:] = other.ref_twist
        self.time = other.time
        self.extra = dict(other.extra)


def initial_state(model) -> State:
    """The initial state described by the model's :class:`~knotsim.rods.RodSpec` objects.

    Reference directors are given by the specs or computed by space-parallel transport along each
    rod; the reference twist starts as the holonomy of those directors (zero for space-parallel
    frames of an open rod).
    """
    q = np.zeros(model.n_dofs)
    v = np.zeros(model.n_dofs)
    d1 = np.zeros((model.n_edges, 3))
    tang = np.zeros((model.n_edges, 3))
    lengths = np.zeros(model.n_edges)
    for r, rod in enumerate(model.rods):
        n0, n1 = model.rod_node_start[r], model.rod_node_start[r + 1]
        e0, e1 = model.rod_edge_start[r], model.rod_edge_start[r + 1]
        dofs = model.node_dof[n0:n1, None] + np.arange(3)[None, :]
        q[dofs] = rod.positions
        if rod.velocities is not None:
            v[dofs] = rod.velocities
        if rod.edge_angles is not None:
            q[model.edge_theta_dof[e0:e1]] = rod.edge_angles
    compute_tangents(q, model.edge_dofs, tang, lengths)
    for r, rod in enumerate(model.rods):
        e0, e1 = model.rod_edge_start[r], model.rod_edge_start[r + 1]
        t = tang[e0:e1]
        if rod.reference_directors is not None:
            d = np.asarray(rod.reference_directors, float)
            d = d - np.sum(d * t, axis=1)[:, None] * t
            nrm = np.linalg.norm(d, axis=1)
            if np.any(nrm < 1e-9):
                from knotsim.errors import ConfigError

                bad = int(np.argmin(nrm))
                raise ConfigError(f"rods[{r}].reference_directors", f"director of edge {bad} is parallel to the edge")
            d1[e0:e1] = d / nrm[:, None]
        else:
            d1[e0:e1] = space_parallel_directors(t, bool(rod.closed))
    twist = np.zeros(model.n_bend)
    reference_twist(d1, tang, model.bend_edges, np.zeros(model.n_bend), twist)
    return State(q, v, d1, tang, twist, 0.0)


def frames_at(model, q: np.ndarray, source: State):
    """Tangents, reference directors and reference twist at ``q`` transported from ``source``.

    Returns ``(tangents, d1, ref_twist)``."""
    tang = np.zeros((model.n_edges, 3))
    lengths = np.zeros(model.n_edges)
    d1 = np.zeros((model.n_edges, 3))
    twist = np.zeros(model.n_bend)
    compute_tangents(q, model.edge_dofs, tang, lengths)
    transport_directors(source.d1, source.tangents, tang, d1)
    reference_twist(d1, tang, model.bend_edges, source.ref_twist, twist)
    return tang, d1, twist


def material_directors(model, state: State):
    """Material directors ``(m1, m2)``, each ``(n_edges, 3)``, of ``state``."""
    m1 = np.zeros((model.n_edges, 3))
    m2 = np.zeros((model.n_edges, 3))
    material_frames(state.d1, state.tangents, state.q[model.edge_theta_dof], m1, m2)
    return m1, m2
