"""Simulation state: everything that changes during a run.

:class:`State` holds the rods' configuration and, in :attr:`State.memory` (a :class:`RunMemory`),
what the driver, the stepper, the validity guards, the interactions and the boundary conditions
remember from one step to the next. :mod:`knotsim.io.checkpoint` writes and reads all of it.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from knotsim.rods.frames import (
    compute_tangents,
    material_frames,
    reference_twist,
    space_parallel_directors,
    transport_directors,
)


def memory_field(name: str, doc: str) -> property:
    """A property that reads and writes the field ``name`` of the object's ``memory`` (for the
    holders of run memory: the attribute stays, the value lives in the memory)."""
    def get(self):
        return getattr(self.memory, name)

    def set_(self, value):
        setattr(self.memory, name, value)

    return property(get, set_, doc=doc)


@dataclass
class DriverMemory:
    """The adaptive step policy of :class:`~knotsim.simulation.Simulation`: the current step ``dt``
    (s), the count of easy steps since the last change of ``dt``, the steps of full Newton left
    after a retried step, and the failed step attempts so far; the stall watch
    (:data:`knotsim.solver.diagnosis.STALL_FRACTION`): the accepted steps so far, and the current
    stretch of consecutive step attempts made with the step below ``dt_target / STALL_FRACTION``
    (its attempts, its failures, and the time (s) and accepted-step count at which it began; ``0``,
    ``0``, NaN and ``-1`` outside a stretch)."""

    dt: float = math.nan
    easy: int = 0
    retry_cooldown: int = 0
    n_failures: int = 0
    steps: int = 0
    collapsed_attempts: int = 0
    collapsed_failures: int = 0
    collapsed_since: float = math.nan
    collapsed_since_step: int = -1


@dataclass
class ValidityMemory:
    """What :class:`~knotsim.solver.validity.ValidityMonitor` accumulates over a run (J, s): the
    total energy after the last accepted step, the gravity potential after the first, the energy
    created without a source, the summed ``|work|``, the largest energy handled, the worst strain
    ``(strain, global edge, time)`` and gain ``(gain / scale, time)``, and per stiffened interaction
    ``(k_c, energy)`` at the last step."""

    energy: float = math.nan
    gravity_start: float = math.nan
    gain: float = 0.0
    work_handled: float = 0.0
    scale: float = 0.0
    worst_strain: tuple[float, int, float] = (0.0, -1, math.nan)
    worst_gain: tuple[float, float] = (0.0, math.nan)
    penalty: dict[str, tuple[float, float]] = field(default_factory=dict)


@dataclass(frozen=True)
class PredictorMemory:
    """The acceleration predictor's previous step: its end ``time`` (s), the velocity at its start
    ``v_prev (n_dofs,)`` and its size ``dt`` (s)."""

    time: float
    v_prev: np.ndarray
    dt: float


@dataclass(frozen=True)
class JacobianMemory:
    """The Jacobian a step may start from (``SolverOptions.jacobian_across_steps``): the last
    accepted step's Newton iterations, the step size and constrained unknowns ``fixed (n_dofs,)``
    it was assembled for, the interactions' block unknowns then, and the matrix: ``kind`` is
    ``"banded"`` (``banded``: ``(ab, kl, ku, symmetric)``) or ``"sparse"`` (``sparse``: ``(indptr,
    indices, data)``). ``token`` names the stepper's assembly it came from (``None`` when restored
    from a checkpoint); the stepper reuses its factorisation while the token is its own. The arrays
    may be the stepper's own buffers: :meth:`RunMemory.snapshot` copies them."""

    last_iterations: int
    dt: float
    fixed: np.ndarray
    blocks: tuple[np.ndarray, ...]
    kind: str
    banded: tuple | None = None
    sparse: tuple | None = None
    token: object | None = None

    def __deepcopy__(self, memo):
        def arrays(t):
            return None if t is None else tuple(np.array(a, copy=True) if isinstance(a, np.ndarray) else a for a in t)

        return JacobianMemory(self.last_iterations, self.dt, self.fixed.copy(), tuple(b.copy() for b in self.blocks),
                              self.kind, arrays(self.banded), arrays(self.sparse), self.token)


@dataclass
class StepMemory:
    """What :class:`~knotsim.solver.stepper.Stepper` carries from an accepted step to the next:
    the acceleration predictor's previous step, the Jacobian the next step may start from (``None``
    during an attempt and after a failed one), and the sparse LU's ordering memory ``(perm, nnz_l,
    nnz_a)`` (it decides the round-off of later steps; a failed attempt updates it too)."""

    predictor: PredictorMemory | None = None
    jacobian: JacobianMemory | None = None
    ordering: tuple[np.ndarray, int, int] | None = None


@dataclass
class LoadCellMemory:
    """The PI controller of a load-cell grip (:class:`~knotsim.bc.feedback.LoadCell`): the
    displacement ``u`` (m) at the last accepted step, the one ``u_step`` prescribed in the current
    step and the one ``u_cmd`` commanded for the next, the time ``t_last`` (s) of the last accepted
    step (``None`` before the first), the integral of the force error ``integral`` (N s), the
    measured ``force`` and the ``error`` (N) then."""

    u: float = 0.0
    u_step: float = 0.0
    u_cmd: float = 0.0
    t_last: float | None = None
    integral: float = 0.0
    force: float = 0.0
    error: float = 0.0


@dataclass
class GroupMemory:
    """What a boundary-condition group (:class:`~knotsim.bc.group.Group`) captured when it became
    active: the positions ``anchor (n, 3)`` (m) and edge angles ``anchor_theta (e,)`` (rad) it
    prescribes from (``None`` while not active), the time ``anchor_time`` (s) they were captured,
    a turning grip's ``pivot (3,)`` (m), the start point ``path_start (3,)`` (m) a ``from_current``
    path was bound to, and a load cell's controller ``cell`` (:class:`LoadCellMemory`)."""

    anchor: np.ndarray | None = None
    anchor_theta: np.ndarray | None = None
    anchor_time: float = 0.0
    pivot: np.ndarray | None = None
    path_start: np.ndarray | None = None
    cell: LoadCellMemory | None = None


@dataclass
class RunMemory:
    """What the parts of a run remember across steps, carried with the :class:`State`.

    ``driver`` (:class:`DriverMemory`), ``step`` (:class:`StepMemory`), ``validity``
    (:class:`ValidityMemory`), ``interactions`` (by interaction name: each interaction's
    ``memory``, a dataclass of numbers and arrays) and ``bc`` (by group name: what a
    boundary-condition group captured, :class:`GroupMemory`). :meth:`State.copy` shares the
    sections, the ``bc`` table included (a failed attempt keeps what it changed in them, e.g. a
    raised contact stiffness or a captured anchor, as the holders always did); :meth:`snapshot`
    copies them."""

    driver: DriverMemory = field(default_factory=DriverMemory)
    step: StepMemory = field(default_factory=StepMemory)
    validity: ValidityMemory = field(default_factory=ValidityMemory)
    interactions: dict[str, Any] = field(default_factory=dict)
    bc: dict[str, GroupMemory] = field(default_factory=dict)

    def copy(self) -> RunMemory:
        """A new container holding the same sections."""
        return RunMemory(self.driver, self.step, self.validity, dict(self.interactions), self.bc)

    def snapshot(self) -> RunMemory:
        """A copy of every section (arrays included)."""
        return copy.deepcopy(self)


@dataclass
class State:
    """State of all rods at time ``time``.

    - ``q (n_dofs,)``: positions (m) and edge angles (rad), layout in ``docs/architecture.md``;
    - ``v (n_dofs,)``: their rates (m/s, rad/s);
    - ``d1 (n_edges, 3)``: reference directors; ``tangents (n_edges, 3)``: unit edge tangents at ``q``;
    - ``ref_twist (n_bend,)``: reference twist (rad) of each interior node;
    - ``time``: s;
    - ``memory``: what the run's parts remember across steps (:class:`RunMemory`).
    """

    q: np.ndarray
    v: np.ndarray
    d1: np.ndarray
    tangents: np.ndarray
    ref_twist: np.ndarray
    time: float = 0.0
    extra: dict = field(default_factory=dict)
    memory: RunMemory = field(default_factory=RunMemory)

    def copy(self) -> State:
        """A copy of the arrays; the memory's sections are shared (see :class:`RunMemory`)."""
        return State(self.q.copy(), self.v.copy(), self.d1.copy(), self.tangents.copy(),
                     self.ref_twist.copy(), self.time, dict(self.extra), self.memory.copy())

    def assign(self, other: State) -> None:
        """Copy ``other`` into this state in place."""
        self.q[:] = other.q
        self.v[:] = other.v
        self.d1[:] = other.d1
        self.tangents[:] = other.tangents
        self.ref_twist[:] = other.ref_twist
        self.time = other.time
        self.extra = dict(other.extra)
        self.memory = other.memory.copy()


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
