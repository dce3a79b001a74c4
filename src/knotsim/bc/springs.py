"""The implicit part of the boundary conditions: spring grips, and what the other feedback groups
log (an :class:`~knotsim.solver.stepper.Interaction` named ``"bc"``).

A spring grip ties each of its ``n`` nodes to its own anchor point (the node's position when the
group activates, carried rigidly along the group's path) by a linear spring of stiffness ``k/n``
(N/m): energy ``E = sum_i k/(2n) |x_i - a_i|^2`` (J), force on node ``i`` ``k/n (a_i - x_i)`` (N), total
``F = k (a_bar - x_bar)`` (centroids). Its Jacobian ``k/n I_3`` per node enters Newton's matrix, so
the grip is as implicit as the rod. :meth:`BoundaryConditions.interactions` returns this object
whenever the model has spring, load-cell, ring-twist or turning groups; :class:`Simulation` adds it
to its interactions by itself, and ``solve_static`` needs ``interactions=bcs.interactions()``.

Logged per step (``stats``): spring ``<name>_fx, _fy, _fz`` (force of the spring on the rod, N),
``<name>_force`` (its magnitude), ``<name>_anchor_x, _y, _z`` (anchor centroid, m) and
``<name>_stretch`` (``|a_bar - x_bar|``, m); load cell ``<name>_displacement`` (m along its
direction), ``<name>_target`` (N) and ``<name>_error`` (N); ring twist ``<name>_twist`` (rad
injected) and ``<name>_moment`` (N m across the cut); turning grip ``<name>_angle`` (rad) and
``<name>_mx, _my, _mz`` (N m, moment the grip exerts on the rod about its pivot).
"""

from __future__ import annotations

import numpy as np

from knotsim.bc.group import GroupKind
from knotsim.rods.frames import compute_tangents, reference_twist, transport_directors


class BCInteraction:
    """Spring forces and feedback logs of a :class:`~knotsim.bc.BoundaryConditions`."""

    name = "bc"
    #: no run memory of its own (the groups' anchors are the boundary conditions' memory)
    memory = None
    #: no penalty stiffness
    k_c = None
    #: constant: the blocks are the spring nodes' coordinates for the whole run
    pattern_version = 0

    def __init__(self, bcs):
        self.bcs = bcs
        m = bcs.model
        self.springs = [g for g in bcs.groups.values() if g.kind == GroupKind.SPRING]
        self.rings = [g for g in bcs.groups.values() if g.kind == GroupKind.RING_TWIST]
        rows = [m.node_dof[g.nodes][:, None] + np.arange(3)[None, :] for g in self.springs]
        self._dofs = np.concatenate(rows).astype(np.int64) if rows else np.zeros((0, 3), np.int64)
        self._blocks = np.zeros((self._dofs.shape[0], 3, 3))
        self._eye = np.eye(3)
        self._spring_force: dict[str, np.ndarray] = {}
        self._ring_moment: dict[str, float] = {}
        self._source = {}
        self._interval = (0.0, 0.0)

    # -- Interaction protocol ---------------------------------------------------------------
    def begin_step(self, state_in, dt: float) -> None:
        """Keep the frames of the ring cuts at the start of the step (to evaluate their twist) and the
        step's time interval (for :meth:`supplied_work`)."""
        self._interval = (float(state_in.time), float(state_in.time) + dt)
        for g in self.rings:
            c = g.ring
            e = list(c.edges)
            self._source[g.name] = (state_in.d1[e].copy(), state_in.tangents[e].copy(),
                                    state_in.ref_twist[[c.stencil]].copy())

    def block_dofs(self) -> np.ndarray:
        """``(k, 3)``: the position unknowns of every spring node (fixed for the whole run)."""
        return self._dofs

    def evaluate(self, q: np.ndarray, q_prev: np.ndarray, dt: float, residual: np.ndarray,
                 want_jacobian: bool):
        """Add ``-force`` of the active springs to ``residual``; energy (J) and ``(k, 3, 3)`` blocks
        (``None`` when no spring acts)."""
        self.bcs._interaction_seen = True
        energy = 0.0
        row = 0
        any_active = False
        if want_jacobian:
            self._blocks[:] = 0.0
        for g in self.springs:
            n = len(g.nodes)
            if g.target is not None:
                any_active = True
                kn = g.stiffness / n
                dofs = self._dofs[row:row + n]
                d = q[dofs] - g.target
                energy += 0.5 * kn * float(np.sum(d * d))
                residual[dofs] += kn * d  # a group's nodes are distinct
                self._spring_force[g.name] = -kn * d.sum(axis=0)
                if want_jacobian:
                    self._blocks[row:row + n] = kn * self._eye
            else:
                self._spring_force[g.name] = np.zeros(3)
            row += n
        for g in self.rings:
            self._ring_moment[g.name] = self._cut_moment(g, q)
        return energy, (self._blocks if any_active and want_jacobian else None)

    def check(self, q: np.ndarray) -> str | None:
        return None

    def use_memory(self, memory) -> None:
        """Nothing to take (no run memory of its own)."""

    def check_start(self, q: np.ndarray) -> None:
        """Nothing to check: springs act from their anchors wherever the nodes start."""

    def describe_near(self, q: np.ndarray, node: int) -> str:
        return ""

    def supplied_work(self, q_prev: np.ndarray, q: np.ndarray, dt: float) -> float:
        """Work (J) the springs' moving anchors did on the rods during the accepted step from
        ``q_prev`` to ``q``: ``E(q_prev, a_1) - E(q_prev, a_0)``, the change of the spring energy as
        the anchors moved from ``a_0`` to ``a_1`` with the nodes at their start positions. The rest,
        ``E(q, a_1) - E(q_prev, a_1)``, is the work of the spring force at the step's end over the
        nodes' motion, which backward Euler counts as the rods' own (see
        :mod:`knotsim.solver.validity`)."""
        t0, t1 = self._interval
        work = 0.0
        row = 0
        for g in self.springs:
            n = len(g.nodes)
            if g.target is not None:
                t_from = max(t0, g.anchor_time)
                shift = g.path(t1 - g.start) - g.path(max(t_from - g.start, 0.0))
                d1 = q_prev[self._dofs[row:row + n]] - g.target
                d0 = d1 + shift[None, :]
                work += 0.5 * g.stiffness / n * float(np.sum(d1 * d1) - np.sum(d0 * d0))
            row += n
        return work

    def untracked_sources(self) -> list[str]:
        """Sources whose work :meth:`supplied_work` does not count: ring-twist groups (they change the
        rest twist)."""
        return [f"ring-twist group {g.name!r}" for g in self.rings]

    #: no friction for the spin relaxation (see :meth:`spin_friction`)
    has_spin_friction = False

    def spin_friction(self):
        """``None``: spring grips carry no friction in the edge angles (see
        :mod:`knotsim.solver.spin_relaxation`)."""
        return None

    #: no friction, no per-node output
    friction_model = None
    node_field_names: tuple[str, ...] = ()

    def node_fields(self) -> dict:
        return {}

    def stats(self) -> dict:
        out = {}
        for g in self.springs:
            f = self._spring_force.get(g.name, np.zeros(3))
            out[f"{g.name}_fx"], out[f"{g.name}_fy"], out[f"{g.name}_fz"] = (float(x) for x in f)
            out[f"{g.name}_force"] = float(np.linalg.norm(f))
            a = g.target.mean(axis=0) if g.target is not None else np.full(3, np.nan)
            out[f"{g.name}_anchor_x"], out[f"{g.name}_anchor_y"], out[f"{g.name}_anchor_z"] = (float(x) for x in a)
            out[f"{g.name}_stretch"] = float(np.linalg.norm(f)) / g.stiffness if g.target is not None else 0.0
        for g in self.rings:
            out[f"{g.name}_twist"] = float(g.ring.value)
            out[f"{g.name}_moment"] = float(self._ring_moment.get(g.name, 0.0))
        out.update(self.bcs.log_values)
        return out

    # -- helpers -------------------------------------------------------------------------------
    def _cut_moment(self, g, q: np.ndarray) -> float:
        """Twisting moment (N m) across the cut of ring group ``g`` at ``q``: ``GJ/l (m - mbar)``."""
        src = self._source.get(g.name)
        if src is None:
            return 0.0
        m = self.bcs.model
        c = g.ring
        e = list(c.edges)
        tan = np.zeros((2, 3))
        lens = np.zeros(2)
        compute_tangents(q, m.edge_dofs[e], tan, lens)
        d1 = np.zeros((2, 3))
        transport_directors(src[0], src[1], tan, d1)
        ref = np.zeros(1)
        reference_twist(d1, tan, np.array([[0, 1]], np.int64), src[2], ref)
        twist = q[m.edge_theta_dof[e[1]]] - q[m.edge_theta_dof[e[0]]] + ref[0]
        return float(m.twist_GJ[c.stencil] / m.voronoi_rest[c.stencil] * (twist - m.twist_bar[c.stencil]))
