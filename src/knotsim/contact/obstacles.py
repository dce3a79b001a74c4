"""Rigid obstacles: planes (floor, wall, table), capsules (posts, pulleys, pegs) and spheres.

>>> floor = Plane(model, "floor", point=(0, 0, 0), normal=(0, 0, 1), mu=0.4)
>>> post = Capsule(model, "post", a=(0, -0.1, 0), b=(0, 0.1, 0), radius=0.02, mu=0.3)
>>> sim = Simulation(model, bcs, SolverOptions(dt=1e-3), interactions=[floor, post])

Each obstacle is a stepper interaction (:class:`knotsim.solver.stepper.Interaction`). Every node of
its rods (default: all rods) is a ball of the rod's radius ``h`` in contact with the obstacle
through the IMC energy ``k_c E(Δ)`` of :mod:`knotsim.contact.potential` (the same function of the
gap as rope-rope contact; contact distance ``h + R``) and the smooth Coulomb friction law of
:mod:`knotsim.contact.friction`, with the obstacle's own ``mu``; the obstacle's surface velocity
enters the slip velocity. Both are fully implicit: their 3x3 node Jacobians go into Newton's matrix.
Kernels: :mod:`knotsim.contact.obstacle_kernels`.

Motion: ``path`` translates the obstacle (a :class:`~knotsim.bc.paths.Path`, a velocity in m/s, or
a callable of time returning a displacement in m; time counts from t = 0), ``angular_velocity``
(rad/s, a 3-vector) rotates it about ``pivot`` (m; default its reference point: the plane's
point, the sphere's centre, the capsule's axis midpoint), which moves with the path. The pose at
the end of each step is used (backward Euler); the surface velocity at a point ``y`` is
``(path(t) − path(t − dt))/dt + ω × (y − pivot(t))``. A capsule spinning about its own axis is a
driven pulley: its geometry stays, its surface moves.

Contact stiffness ``k_c`` (N/m): a given ``stiffness`` is used as is. Without one it is adaptive
like rope-rope contact (:mod:`knotsim.contact.model`): before each step ``k_target =
stiffness_scaler × F_max / h_min`` with ``F_max`` the largest node contact force of the last accepted
step or the force that stops the fastest approaching node within one step; ``k_c`` jumps up to the
target and relaxes down towards it; it never drops below ``stiffness_scaler × (largest node mass ×
1 m/s²) / h_min``. A step whose deepest penetration exceeds ``penetration_limit × h`` is rejected
(and, adaptive, retried with ``k_c × 4``), and so is a step during which a rod went through the
obstacle and ended outside it: along the straight motion of the step (the obstacle moving from its
pose at the start to that at the end) a node went deeper than the limit (also ``k_c × 4``), or an
edge's centre line came within half the closest legal node distance of the core, a thin post
between two nodes (:mod:`knotsim.contact.obstacle_swept`). The reasons name the rod, the node or
edge within it and the time.

Friction model (``friction_model``): ``"surface"`` (default) applies friction at the node's
surface point ``x − h n``, whose velocity includes the rotation of the rod's cross-section (the
mean angular velocity of the node's edges), so a rod can roll or spin on the obstacle; the friction
then also acts on the neighbouring nodes and the edge angles (11-unknown blocks, kernels in
:mod:`knotsim.contact.obstacle_surface_kernels`, law in ``docs/_obstacle_surface_friction.md``).
``"centreline"`` applies it to the node alone, with the node's velocity (3x3 blocks; the results
of knotsim before the surface model, bit for bit).

Free spin: a capsule or sphere given ``spin_inertia`` (kg m²) turns freely on a frictionless axle,
the capsule about its own axis, the sphere about ``spin_axis`` (through its centre) or, without
one, about any axis (a ball joint, isotropic inertia); ``initial_spin`` (rad/s, a 3-vector,
projected on the free axes) starts it. The spin ``ω`` is run memory (:class:`ObstacleMemory`)
and logged as ``<name>_spin_x, _spin_y, _spin_z`` (rad/s). It is advanced once per accepted step,
implicitly with the rods' state of that step frozen (a staggered scheme, see
:func:`~knotsim.contact.obstacle_surface_kernels.spin_update`): ``I (ω_{n+1} − ω_n)/dt`` equals the
friction moment about the axis at ``ω_{n+1}``; the rods' step uses ``ω_n``. Each half is implicit
and dissipative, so the scheme is stable for any ``I > 0`` and ``dt`` (a massless axle is the limit
of a small ``I``); its limits: first order, and the rods see the obstacle's surface speed one step
late, so the angular momentum exchanged during a step can be off by up to about ``μ F_n R dt`` (the
exact fully coupled solve would need the spin as an unknown of Newton's system).

Reaction: :meth:`Obstacle.stats` logs the force (N) the rods exert on the obstacle,
``<name>_fx, <name>_fy, <name>_fz``, its moment (N m) about the current pivot, ``<name>_mx,
<name>_my, <name>_mz`` (forces applied at the surface points ``x − (Δ − R) n``), ``<name>_n_contacts``
(nodes within ``δ`` of the surface), ``<name>_min_gap`` (m) and ``<name>_k_c`` (N/m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from knotsim._util.validate import number
from knotsim.bc.paths import Path, as_path
from knotsim.contact.friction import FRICTION_SHARPNESS
from knotsim.contact.obstacle_kernels import CAPSULE, PLANE, SPHERE, obstacle_evaluate
from knotsim.contact.obstacle_surface_kernels import STENCIL, obstacle_surface_evaluate, spin_update
from knotsim.contact.obstacle_swept import NODE, describe, first_pass_through, obstacle_edges
from knotsim.contact.stick import SpringMemory, return_map, spring_arrays
from knotsim.contact.stiffness import AdaptiveStiffness, StiffnessMemory, default_floor
from knotsim.errors import ConfigError, GeometryError
from knotsim.solver.state import memory_field

__all__ = ["Capsule", "Obstacle", "ObstacleMemory", "Plane", "Sphere", "rotation_matrix"]

#: Values of ``friction_model``.
FRICTION_MODELS = ("surface", "centreline")


@dataclass
class ObstacleMemory(SpringMemory, StiffnessMemory):
    """What an :class:`Obstacle` remembers across steps (run memory, carried by the state and written
    to checkpoints field by field): the stiffness ``k_c`` (N/m), the largest node contact force of
    the last accepted step (N) and the largest step seen (s) that drive it, the start its path was
    bound to (m, or ``None``), the free spin ``ω (3,)`` (rad/s; ``None`` without ``spin_inertia``) and,
    with the elastic-stick law, every node's tangential spring ``stick_xi (k, 3)`` (m) and whether it
    slides ``stick_sliding (k,)`` (:mod:`knotsim.contact.stick`)."""

    path_start: np.ndarray | None = None
    spin: np.ndarray | None = None


def _memory_field(name: str) -> property:
    return memory_field(name, f"``{name}`` of the run memory (:class:`ObstacleMemory`)")


_NO_SPIN = np.zeros(3)
_NO_SPIN.flags.writeable = False
#: kernel arguments of the smooth law (no springs)
_NO_XI = np.zeros((0, 3))
_NO_LIMIT = np.zeros(0)


def rotation_matrix(rotvec) -> np.ndarray:
    """Rotation by the rotation vector ``rotvec (3,)`` (rad; axis times angle), Rodrigues' formula."""
    w = np.asarray(rotvec, float)
    a = float(np.linalg.norm(w))
    if a == 0.0:
        return np.eye(3)
    k = w / a
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(a) * K + (1.0 - math.cos(a)) * (K @ K)


def _vec3(field: str, value) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        v = np.zeros(0)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ConfigError(field, f"expected 3 finite numbers, got {value!r}")
    return v


def _number(field: str, value, allow_zero: bool = False) -> float:
    return (number(value, field, at_least=0.0, must="be a non-negative finite number") if allow_zero
            else number(value, field, above=0.0, must="be a positive finite number"))


def node_stencils(model, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Surface-friction stencils of global ``nodes (k,)``: unknowns ``(k, 11)`` int64, laid out
    ``x_{i−1}, θ_A, x_i, θ_B, x_{i+1}`` (edge ``A = (i−1, i)``, ``B = (i, i+1)``; closed rods wrap
    around), and edge weights ``(k, 2)``: ``(½, ½)``, or ``(0, 1)`` / ``(1, 0)`` at the first / last
    node of an open rod, whose missing edge's slots are filled with the unknowns of nodes ``2`` and
    edge ``1`` (first node) or node ``N − 3`` and edge ``N − 3`` (last node), which the block leaves at
    zero (so no unknown repeats within a block and the bandwidth is that of a bending stencil). A
    2-node rod has only 7 unknowns: its padding repeats them (with zero entries)."""
    m = model
    rod = m.node_rod[nodes]
    N = m.rod_node_start[rod + 1] - m.rod_node_start[rod]
    i = nodes - m.rod_node_start[rod]
    d0 = m.rod_dof_start[rod]
    closed = m.rod_closed[rod]
    prev_n = np.where(closed, (i - 1) % N, i - 1)
    next_n = np.where(closed, (i + 1) % N, i + 1)
    edge_a = np.where(closed, (i - 1) % N, i - 1)
    edge_b = i.copy()
    wa = np.full(nodes.size, 0.5)
    wb = np.full(nodes.size, 0.5)
    first = ~closed & (i == 0)
    last = ~closed & (i == N - 1)
    wa[first], wb[first] = 0.0, 1.0
    wa[last], wb[last] = 1.0, 0.0
    pad = np.minimum(2, N - 1)  # padding node after the first node (repeats node 1 in a 2-node rod)
    prev_n = np.where(first, pad, prev_n)
    edge_a = np.where(first, pad - 1, edge_a)
    next_n = np.where(last, np.maximum(N - 3, 0), next_n)
    edge_b = np.where(last, np.maximum(N - 3, 0), edge_b)
    cols = []
    for node, th in ((prev_n, edge_a), (i, edge_b), (next_n, None)):
        cols += [d0 + 4 * node + k for k in range(3)]
        if th is not None:
            cols.append(d0 + 4 * th + 3)
    # column order: x_{i−1}, θ_A, x_i, θ_B, x_{i+1}
    dofs = np.stack(cols, axis=1).astype(np.int64)
    return np.ascontiguousarray(dofs), np.ascontiguousarray(np.stack([wa, wb], axis=1))


class Obstacle:
    """A rigid obstacle in frictional contact with the rods of ``model`` (see the module doc).

    Parameters (SI units): ``name`` (log columns ``<name>_fx``, ...); ``mu`` friction coefficient
    (default 0); ``delta`` IMC distance tolerance δ (m, default 5e-4); ``nu`` slip tolerance (m/s,
    default 1e-4); ``stiffness`` k_c (N/m, default adaptive); ``stiffness_scaler`` (default 500);
    ``penetration_limit`` (fraction of the rod radius, default 0.2); ``path``, ``angular_velocity``,
    ``pivot`` (motion); ``rods``: rods (names or indices) that touch it, default all;
    ``friction_model``: ``"surface"`` (default) or ``"centreline"``; ``spin_inertia`` (kg m²),
    ``spin_axis`` (spheres), ``initial_spin`` (rad/s): free spin (capsules and spheres; see the
    module doc); ``stick_distance`` δ_s (m) and ``mu_static`` (≥ ``mu``, default ``mu``): the
    elastic-stick law of docs/physics.md §3.6 (surface friction, an obstacle without free spin), a
    node below its static limit holds without creep. Subclasses set the geometry: :class:`Plane`, :class:`Capsule`, :class:`Sphere`.
    """

    kind = -1
    type_name = ""
    k_c = _memory_field("k_c")
    _fmax_accepted = _memory_field("fmax_accepted")
    _dt_ref = _memory_field("dt_ref")

    @property
    def spin(self) -> np.ndarray:
        """Free spin ``ω (3,)`` (rad/s; zeros without ``spin_inertia``)."""
        return self.memory.spin if self.memory.spin is not None else _NO_SPIN

    @spin.setter
    def spin(self, value) -> None:
        self.memory.spin = value

    def __init__(self, model, name: str, *, mu: float = 0.0, delta: float = 5e-4, nu: float = 1e-4,
                 stiffness: float | None = None, stiffness_scaler: float = 500.0, penetration_limit: float = 0.2,
                 path=None, angular_velocity=None, pivot=None, rods=None, friction_model: str = "surface",
                 spin_inertia: float | None = None, spin_axis=None, initial_spin=None,
                 stick_distance: float | None = None, mu_static: float | None = None):
        if not isinstance(name, str) or not name:
            raise ConfigError("obstacle.name", f"an obstacle needs a non-empty name, got {name!r}")
        self.name = name
        #: the run memory in use (see :meth:`begin_step`)
        self.memory = ObstacleMemory()
        f = f"obstacles.{name}"
        self.model = model
        self.mu = _number(f"{f}.mu", mu, allow_zero=True)
        self.delta = _number(f"{f}.delta", delta)
        self.nu = _number(f"{f}.nu", nu)
        self.stiffness = None if stiffness is None else _number(f"{f}.stiffness", stiffness)
        self.stiffness_scaler = _number(f"{f}.stiffness_scaler", stiffness_scaler)
        self.penetration_limit = _number(f"{f}.penetration_limit", penetration_limit)
        if not isinstance(friction_model, str) or friction_model not in FRICTION_MODELS:
            raise ConfigError(f"{f}.friction_model", f"must be 'surface' or 'centreline', got {friction_model!r}")
        self.friction_model = str(friction_model)
        self.stick_distance = None if stick_distance is None else _number(f"{f}.stick_distance", stick_distance)
        self.mu_static = self.mu if mu_static is None else _number(f"{f}.mu_static", mu_static, allow_zero=True)
        if mu_static is not None and self.stick_distance is None:
            raise ConfigError(f"{f}.mu_static", "static friction needs the elastic-stick law: give stick_distance (m), "
                                                "e.g. 1e-5, or remove mu_static")
        if self.mu_static < self.mu:
            raise ConfigError(f"{f}.mu_static", f"must be at least mu = {self.mu:g}, got {self.mu_static:g}")
        if self.stick_distance is not None and self.friction_model != "surface":
            raise ConfigError(f"{f}.stick_distance", "the elastic-stick law acts at the rods' surfaces; set "
                                                     "friction_model = \"surface\" or remove stick_distance")
        if self.stick_distance is not None and spin_inertia is not None:
            raise ConfigError(f"{f}.stick_distance", "not available for a free-spinning obstacle (spin_inertia); "
                                                     "remove one of the two")
        try:
            self.path: Path | None = None if path is None else as_path(path)
        except ConfigError as exc:
            raise ConfigError(f"{f}.{exc.field}", str(exc).split(": ", 1)[1]) from None
        self.omega = np.zeros(3) if angular_velocity is None else _vec3(f"{f}.angular_velocity", angular_velocity)
        self._center0 = None if pivot is None else _vec3(f"{f}.pivot", pivot)
        self._init_spin(f, spin_inertia, spin_axis, initial_spin, angular_velocity, pivot)
        if self.spin_inertia is None:
            self.memory.spin = None
        m = model
        if rods is None:
            sel = np.arange(m.n_rods)
        else:
            try:
                sel = np.array([m.rod_index(r) for r in (rods if isinstance(rods, list | tuple) else [rods])])
            except ConfigError as exc:
                raise ConfigError(f"{f}.rods", str(exc).split(": ", 1)[-1]) from None
        self.nodes = np.ascontiguousarray(np.flatnonzero(np.isin(m.node_rod, sel)), dtype=np.int64)
        self.node_h = np.ascontiguousarray(m.rod_radius[m.node_rod[self.nodes]], dtype=float)
        self.node_mass = m.mass[m.node_dof[self.nodes]]
        self._dofs = np.ascontiguousarray(m.node_dof[self.nodes][:, None] + np.arange(3)[None, :], dtype=np.int64)
        self.h_min = float(np.min(self.node_h)) if self.nodes.size else 1.0
        self._edges, self._edge_ids = obstacle_edges(m, self.nodes)
        self._node_dofs = np.ascontiguousarray(m.node_dof[self.nodes])
        self._sweep_scratch = np.zeros(self.nodes.size)
        self._step_start = self._pose_accepted = None
        self._still = np.zeros(3)
        self.k_floor = default_floor(self.stiffness_scaler, float(np.max(self.node_mass)) if self.nodes.size else 0.0,
                                     self.h_min)
        #: the adaptive stiffness policy (:mod:`knotsim.contact.stiffness`; used without ``stiffness``)
        self._stiffness = AdaptiveStiffness(self.stiffness_scaler, self.h_min, self.k_floor)
        self.k_c = self.stiffness if self.stiffness is not None else self.k_floor
        self._fmax_accepted = 0.0
        self._fmax_pending = 0.0
        self._dt_ref = 0.0
        k = self.nodes.size
        self._blocks = np.zeros((k, 3, 3))
        self._fc = np.zeros((k, 3))
        self._ff = np.zeros((k, 3))
        self._gap = np.full(k, np.inf)
        self._normal = np.zeros((k, 3))
        self._vs = np.zeros((k, 3))
        self._xi = np.zeros((k, 3))
        #: the elastic-stick law is on (a stick distance and some friction)
        self.stick = self.stick_distance is not None and self.mu > 0.0
        self._stick_length = float(self.stick_distance) if self.stick_distance is not None else 0.0
        if self.friction_model == "surface":
            self._stencil, self._weights = node_stencils(m, self.nodes)
            self._blocks = np.zeros((k, STENCIL, STENCIL))
        self._stats: dict = {}
        self._time = 0.0
        self._set_pose(0.0, 1.0)
        if self.path is not None:
            self.path.bind(self.pivot(0.0))
            self.memory.path_start = self.path.bound_state()
            start = self.path.absolute_start
            if start is not None and np.linalg.norm(start - self._ref0) > 1e-9 * max(1.0, float(np.abs(self._ref0).max())):
                raise ConfigError(f"{f}.waypoints", f"absolute waypoints start at {start.tolist()} m but the "
                                                    f"obstacle's centre is at {self._ref0.tolist()} m")

    def _init_spin(self, f, inertia, axis, initial, angular_velocity, pivot) -> None:
        """Validate the free-spin options; set ``spin_inertia``, ``spin_proj (3, 3)`` and ``spin (3,)``."""
        self.spin_inertia = None
        self.spin_proj = np.zeros((3, 3))
        self.spin = np.zeros(3)
        if inertia is None:
            for key, val in (("spin_axis", axis), ("initial_spin", initial)):
                if val is not None:
                    raise ConfigError(f"{f}.{key}", "only for a free-spinning obstacle (give spin_inertia)")
            return
        if self.kind == PLANE:
            raise ConfigError(f"{f}.spin_inertia", "a plane cannot spin freely (only capsules and spheres)")
        if angular_velocity is not None or pivot is not None:
            raise ConfigError(f"{f}.{'angular_velocity' if angular_velocity is not None else 'pivot'}",
                              "a free-spinning obstacle turns about its own axis or centre (spin_inertia "
                              "excludes angular_velocity and pivot)")
        self.spin_inertia = _number(f"{f}.spin_inertia", inertia)
        if self.kind == CAPSULE:
            if axis is not None:
                raise ConfigError(f"{f}.spin_axis", "a capsule spins about its own axis a-b")
            ax = self.b - self.a
            if np.linalg.norm(ax) == 0.0:
                raise ConfigError(f"{f}.spin_inertia", "a zero-length capsule has no axis to spin about")
        elif axis is not None:
            ax = _vec3(f"{f}.spin_axis", axis)
            if np.linalg.norm(ax) == 0.0:
                raise ConfigError(f"{f}.spin_axis", "must not be the zero vector")
        else:
            ax = None
        if ax is None:
            self.spin_proj = np.eye(3)
        else:
            ax = ax / np.linalg.norm(ax)
            self.spin_proj = np.outer(ax, ax)
        if initial is not None:
            self.spin = self.spin_proj @ _vec3(f"{f}.initial_spin", initial)

    # ------------------------------------------------------------------ geometry
    @property
    def _ref0(self) -> np.ndarray:
        return self._center0 if self._center0 is not None else self.reference_point()

    def reference_point(self) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    def _geometry(self, R: np.ndarray, shift: np.ndarray, c0: np.ndarray) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _displacement(self, t: float) -> np.ndarray:
        return np.zeros(3) if self.path is None else np.asarray(self.path(max(t, 0.0)), float)

    def pivot(self, t: float) -> np.ndarray:
        """Centre of rotation (and of the logged moment) at time ``t`` (s), m."""
        return self._ref0 + self._displacement(t)

    def geometry(self, t: float) -> np.ndarray:
        """Packed geometry ``(7,)`` at time ``t`` (s) (see :mod:`~knotsim.contact.obstacle_kernels`)."""
        return self._geometry(rotation_matrix(self.omega * t), self._displacement(t), self._ref0)

    def _set_pose(self, t: float, dt: float) -> None:
        self._time = t
        self._geom = np.ascontiguousarray(self.geometry(t))
        self._vel = (self._displacement(t) - self._displacement(t - dt)) / dt if self.path is not None else np.zeros(3)
        self._cen = np.ascontiguousarray(self.pivot(t))

    # ------------------------------------------------------------------ Interaction protocol
    def begin_step(self, state_in, dt: float) -> None:
        """Pose at the end of the step and, adaptive, the stiffness for it (with the run memory
        ``state_in`` carries, see :class:`ObstacleMemory`)."""
        mem = state_in.memory.interactions.get(self.name)
        if mem is None:
            state_in.memory.interactions[self.name] = self.memory
        elif mem is not self.memory:
            self.use_memory(mem)
        self._step_start = (state_in.time, dt, state_in.q)
        self._set_pose(state_in.time + dt, dt)
        if self.stiffness is not None or not self.nodes.size:
            return
        self._stiffness.update(self.memory, dt, lambda dt_ref: self._impact_force(state_in))

    def _impact_force(self, state_in) -> float:
        """Largest ``mass × approach speed / dt`` (N) of the nodes within ``δ`` + one step of travel."""
        m = self.model
        q = state_in.q
        scratch = np.zeros(m.n_dofs)
        blocks = np.zeros((self.nodes.size, 3, 3))
        fc = np.zeros((self.nodes.size, 3))
        gap = np.zeros(self.nodes.size)
        normal = np.zeros((self.nodes.size, 3))
        obstacle_evaluate(self.kind, self._geom, self.nodes, m.node_dof, self.node_h, q, q, 1.0, self.delta, 1.0,
                          0.0, self.nu, self._vel, self.omega, self._cen, scratch, False, blocks, fc, fc.copy(),
                          gap, normal)
        v = state_in.v[self._dofs]
        vn = -np.einsum("ij,ij->i", v - self._vel[None, :], normal)  # approach speed, m/s
        near = gap < self.delta + np.maximum(vn, 0.0) * self._dt_ref
        if not np.any(near & (vn > 0)):
            return 0.0
        return float(np.max(np.where(near & (vn > 0), self.node_mass * vn / self._dt_ref, 0.0)))

    def block_dofs(self) -> np.ndarray:
        """Unknowns of every node's block (the pattern never changes): ``(k, 3)`` node coordinates
        (``"centreline"``) or ``(k, 11)`` surface-friction stencils (``"surface"``, see
        :func:`node_stencils`)."""
        return self._stencil if self.friction_model == "surface" else self._dofs

    #: constant: the blocks are the same node coordinates every step
    pattern_version = 0

    @property
    def surface_omega(self) -> np.ndarray:
        """Angular velocity of the obstacle's surface (rad/s): the free spin, or the prescribed one."""
        return self.spin if self.spin_inertia is not None else self.omega

    def evaluate(self, q, q_prev, dt, residual, want_jacobian):
        """Add ``−(contact + friction force)`` (N) to ``residual``; return ``(k_c ΣE (J), blocks | None)``
        with blocks ``(k, 3, 3)`` or ``(k, 11, 11)`` (see :meth:`block_dofs`)."""
        m = self.model
        if self.friction_model == "surface":
            xi0, mu_limit, stick = self._stick_args()
            e = obstacle_surface_evaluate(self.kind, self._geom, self._stencil, self._weights, self.node_h, q, q_prev,
                                          dt, self.delta, self.k_c, self.mu, self.nu, self._vel, self.surface_omega,
                                          self._cen, residual, bool(want_jacobian), self._blocks, self._fc, self._ff,
                                          self._gap, self._normal, self._vs, xi0, mu_limit, stick, self._xi)
        else:
            e = obstacle_evaluate(self.kind, self._geom, self.nodes, m.node_dof, self.node_h, q, q_prev, dt,
                                  self.delta, self.k_c, self.mu, self.nu, self._vel, self.surface_omega, self._cen,
                                  residual, bool(want_jacobian), self._blocks, self._fc, self._ff, self._gap,
                                  self._normal)
        self._q_eval = q.copy()
        self._qp_eval, self._dt_eval = q_prev, dt
        return float(e), (self._blocks if want_jacobian else None)

    def _stick_args(self) -> tuple[np.ndarray, np.ndarray, float]:
        """``(node_xi0 (k, 3) m, node_mu_limit (k,), stick_distance m)`` for the kernel (0: smooth law)."""
        if not self.stick:
            return _NO_XI, _NO_LIMIT, 0.0
        xi, sliding = spring_arrays(self.memory, self.nodes.size)
        return xi, np.where(sliding, self.mu, self.mu_static), self._stick_length

    def _evaluate_at(self, q) -> None:
        if getattr(self, "_q_eval", None) is None or not np.array_equal(self._q_eval, q):
            qp = getattr(self, "_qp_eval", None)
            self.evaluate(q, qp if qp is not None else q, getattr(self, "_dt_eval", 1.0), np.zeros(q.shape[0]),
                          False)

    def check(self, q) -> str | None:
        """Reject ``q`` if a node penetrates deeper than ``penetration_limit × h``, or if a node or an
        edge passed through the obstacle during the step (:mod:`knotsim.contact.obstacle_swept`; a
        node's dive also raises an adaptive ``k_c``)."""
        if not self.nodes.size:
            self._stats = self._summary(q)
            return None
        self._evaluate_at(q)
        ratio = -self._gap / self.node_h
        i = int(np.argmax(ratio))
        self._stats = self._summary(q)
        if ratio[i] > self.penetration_limit:
            if self.stiffness is None:
                self._stiffness.penetrated(self.memory)
            m = self.model
            n = int(self.nodes[i])
            rod = int(m.node_rod[n])
            return (f"obstacle {self.name!r}: node {n - int(m.rod_node_start[rod])} of rod {m.rod_names[rod]!r} "
                    f"penetrates {ratio[i]:.3g} x its radius (penetration_limit {self.penetration_limit})")
        return self._pass_through(q)

    def _pass_through(self, q) -> str | None:
        """The swept test of the step from ``begin_step``'s state to ``q`` (the obstacle moving from
        its pose at the step's start to that at its end); its reason, or ``None``."""
        start = self._step_start
        if start is None or start[2].shape != q.shape:
            return None
        t0, dt, q0 = start
        w = self.omega
        still = w[0] == 0.0 and w[1] == 0.0 and w[2] == 0.0
        if still and self.kind == PLANE:
            return None  # a gap to a plane that does not turn is linear along the step
        if still and self.path is None:
            g0, c0, dc, theta = self._geom, self._cen, self._still, self._still
        else:
            pose = self._pose_accepted  # the end of the last accepted step is this step's start
            if pose is not None and pose[0] == t0:
                g0, c0 = pose[1], pose[2]
            else:
                g0, c0 = np.ascontiguousarray(self.geometry(t0)), np.ascontiguousarray(self.pivot(t0))
            dc, theta = self._cen - c0, self.omega * dt
        code, i, s, value = first_pass_through(self.kind, g0, c0, dc, theta, q0, q, self._node_dofs, self.node_h,
                                               self._gap, self._edges, self.penetration_limit, self._sweep_scratch)
        if code == 0:
            return None
        if code == NODE and self.stiffness is None:
            self._stiffness.penetrated(self.memory)
        return describe(self, code, i, s, value, t0, dt)

    def check_start(self, q) -> None:
        """Raise :class:`~knotsim.errors.GeometryError` when a node starts deeper inside the obstacle
        than ``penetration_limit × h`` (the first step would be rejected)."""
        self._set_pose(0.0, 1.0)
        self._evaluate_at(q)
        if not self.nodes.size:
            return
        ratio = -self._gap / self.node_h
        i = int(np.argmax(ratio))
        if ratio[i] > self.penetration_limit:
            m = self.model
            n = int(self.nodes[i])
            rod = int(m.node_rod[n])
            raise GeometryError(
                f"obstacle {self.name!r}: node {n - int(m.rod_node_start[rod])} of rod {m.rod_names[rod]!r} starts "
                f"{-self._gap[i]:.4g} m inside it ({ratio[i]:.2f} radii; limit {self.penetration_limit}); move the "
                f"obstacle or the rod")

    def _summary(self, q) -> dict:
        x = q[self._dofs] if self.nodes.size else np.zeros((0, 3))
        f_on_obstacle = -(self._fc + self._ff)
        # the surface point is x - (Δ - R) n, and Δ - R = gap + h
        surface = x - (self._gap + self.node_h)[:, None] * self._normal if self.nodes.size else x
        arm = surface - self._cen[None, :]
        force = f_on_obstacle.sum(axis=0)
        moment = np.cross(arm, f_on_obstacle).sum(axis=0) if self.nodes.size else np.zeros(3)
        fn = np.linalg.norm(self._fc, axis=1) if self.nodes.size else np.zeros(0)
        self._fmax_pending = float(fn.max()) if fn.size else 0.0
        n = self.name
        return {f"{n}_fx": float(force[0]), f"{n}_fy": float(force[1]), f"{n}_fz": float(force[2]),
                f"{n}_mx": float(moment[0]), f"{n}_my": float(moment[1]), f"{n}_mz": float(moment[2]),
                f"{n}_n_contacts": int(np.count_nonzero(self._gap < self.delta)),
                f"{n}_min_gap": float(self._gap.min()) if self.nodes.size else math.nan, f"{n}_k_c": float(self.k_c)}

    #: no friction for the spin relaxation (see :meth:`spin_friction`)
    has_spin_friction = False

    def spin_friction(self):
        """``None``: this interaction's friction in the edge angles enters the spin relaxation
        linearised, through its Jacobian blocks (see :mod:`knotsim.solver.spin_relaxation`)."""
        return None

    def stats(self) -> dict:
        """Reaction force (N) and moment (N m) on the obstacle and contact numbers of the last accepted
        step (see the module doc); a free-spinning obstacle's spin is advanced here, once per accepted
        step, and logged at the step's end."""
        self._stiffness.accepted(self.memory, self._fmax_pending)
        self._pose_accepted = (self._time, self._geom, self._cen)
        out = dict(self._stats)
        if self.stick and self.nodes.size:  # the springs of the accepted step (its last evaluation)
            _, mu_limit, _ = self._stick_args()
            fn = np.sqrt(np.einsum("ij,ij->i", self._fc, self._fc))
            inside = (fn > 0.0) & (self._gap < self.delta)
            xi, sliding = return_map(self._xi, self._normal, inside, mu_limit * self._stick_length / self.mu,
                                     self._stick_length)
            self.memory.stick_xi, self.memory.stick_sliding = xi, sliding
            out.update({f"{self.name}_stuck_contacts": int(np.count_nonzero(inside & ~sliding)),
                        f"{self.name}_sliding_contacts": int(np.count_nonzero(sliding))})
        if self.spin_inertia is not None:
            self._advance_spin()
            n = self.name
            out.update({f"{n}_spin_x": float(self.spin[0]), f"{n}_spin_y": float(self.spin[1]),
                        f"{n}_spin_z": float(self.spin[2])})
        return out

    def supplied_work(self, q_prev: np.ndarray, q: np.ndarray, dt: float) -> float:
        """Work (J) the obstacle's motion did on the rods during the accepted step that ended at
        ``q``: the power of the contact and friction forces on the rods at the velocity of the
        obstacle's surface where they act (its translation, its prescribed turn or free spin),
        ``dt sum_i f_i . (v + omega x (y_i - c))`` with ``y_i`` the surface point (first order in
        ``dt``, see :mod:`knotsim.solver.validity`). Zero for an obstacle at rest."""
        if not self.nodes.size or (not np.any(self._vel) and not np.any(self.surface_omega)):
            return 0.0
        x = q[self._dofs]
        surface = x - (self._gap + self.node_h)[:, None] * self._normal
        v = self._vel[None, :] + np.cross(self.surface_omega, surface - self._cen[None, :])
        return float(dt * np.einsum("ij,ij->", self._fc + self._ff, v))

    def _advance_spin(self) -> None:
        """``ω_{n+1}`` from the last evaluation (the accepted step) by :func:`spin_update`."""
        q = getattr(self, "_q_eval", None)
        if q is None or not self.nodes.size or self.mu == 0.0:
            return
        fn = np.sqrt(np.einsum("ij,ij->i", self._fc, self._fc))
        on = fn > 0.0
        if not np.any(on):
            return
        if self.friction_model == "surface":
            vs = self._vs[on]
        else:  # the node's own velocity
            vs = (q[self._dofs[on]] - self._qp_eval[self._dofs[on]]) / self._dt_eval
        y = q[self._dofs[on]] - self.node_h[on, None] * self._normal[on]
        self.spin, _ = spin_update(self.spin, self.spin_proj, self.spin_inertia, self._dt_eval, self.mu, self.nu,
                                   np.ascontiguousarray(fn[on]), np.ascontiguousarray(self._normal[on]),
                                   np.ascontiguousarray(y), np.ascontiguousarray(vs), self._vel, self._cen)

    def stall_hint(self, dt: float) -> str:
        """What this obstacle's contacts were doing at its last evaluation (the last step attempt), for
        the message of a run whose step stays collapsed at ``dt`` (s): its free spin, and how many
        contact nodes sat near sticking, where the smooth law's slope ``μ F_n K2/2`` (N s/m) outweighs
        the node's inertia ``m/dt`` by the ratio given; ``""`` without contacts."""
        if not self.nodes.size or getattr(self, "_q_eval", None) is None:
            return ""
        fn = np.sqrt(np.einsum("ij,ij->i", self._fc, self._fc))
        on = (fn > 0.0) & (self._gap < self.delta)
        if not np.any(on):
            return ""
        n = self._normal[on]
        y = self._q_eval[self._dofs[on]] - self.node_h[on, None] * n
        if self.friction_model == "surface":
            vs = self._vs[on]
        else:
            vs = (self._q_eval[self._dofs[on]] - self._qp_eval[self._dofs[on]]) / self._dt_eval
        rel = vs - self._vel[None, :] - np.cross(self.surface_omega, y - self._cen[None, :])
        slip = np.linalg.norm(rel - np.einsum("ij,ij->i", rel, n)[:, None] * n, axis=1)
        m = self.model
        text = f"obstacle {self.name!r}"
        if self.spin_inertia is not None:
            text += f" (free spin {np.round(self.spin, 6).tolist()} rad/s)"
        text += f": {int(on.sum())} contact nodes"
        if self.mu > 0.0:
            near = slip < 10.0 * self.nu
            slope = self.mu * fn[on] * (FRICTION_SHARPNESS / self.nu) / 2.0
            ratio = slope * dt / self.node_mass[on]
            k = int(np.argmax(np.where(near, ratio, -1.0)))
            text += (f", {int(near.sum())} of them near sticking (slip below 10 nu = {10 * self.nu:.3g} m/s; median "
                     f"slip {float(np.median(slip)):.3g} m/s)")
            if near.any():
                node = int(self.nodes[on][k])
                rod = int(m.node_rod[node])
                text += (f"; at node {node - int(m.rod_node_start[rod])} of rod {m.rod_names[rod]!r} the friction "
                         f"law's slope mu F_n K2/2 = {slope[k]:.3g} N s/m is {ratio[k]:.3g} x the node's inertia "
                         f"m/dt at dt = {dt:.3g} s (the smooth stick spans a slip of nu = {self.nu:g} m/s, "
                         f"{self.nu * dt:.2g} m in a step; a larger nu on {self.name!r}, e.g. {10 * self.nu:g} m/s, "
                         f"widens it)")
        return text

    def reaction(self) -> tuple[np.ndarray, np.ndarray]:
        """``(force (3,), moment (3,))`` on the obstacle at the last accepted step (N, N m)."""
        s = self._stats
        n = self.name
        return (np.array([s[f"{n}_fx"], s[f"{n}_fy"], s[f"{n}_fz"]]),
                np.array([s[f"{n}_mx"], s[f"{n}_my"], s[f"{n}_mz"]]))

    # ------------------------------------------------------------------ run memory
    def use_memory(self, mem: ObstacleMemory) -> None:
        """Continue from the run memory ``mem`` (restored from a checkpoint)."""
        self.memory = mem
        if self.path is not None and mem.path_start is not None:
            self.path.bind(np.array(mem.path_start, float))
        if self.spin_inertia is None:
            mem.spin = None
        elif mem.spin is not None:
            mem.spin = np.array(mem.spin, float)

    #: no per-node output (the reaction is logged by :meth:`stats`)
    node_field_names: tuple[str, ...] = ()

    def node_fields(self) -> dict[str, np.ndarray]:
        return {}

    def untracked_sources(self) -> list[str]:
        """None: :meth:`supplied_work` counts the work of the obstacle's motion."""
        return []

    def describe_near(self, q, node: int) -> str:
        """"" (failure messages name the obstacle in its own reasons)."""
        return ""


class Plane(Obstacle):
    """Half-space below the plane through ``point`` (m) with outward ``normal`` (made unit): a floor,
    wall or table top. The rods stay on the side the normal points to."""

    kind = PLANE
    type_name = "plane"

    def __init__(self, model, name: str, point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), **options):
        self.point = _vec3(f"obstacles.{name}.point", point)
        n = _vec3(f"obstacles.{name}.normal", normal)
        if np.linalg.norm(n) == 0.0:
            raise ConfigError(f"obstacles.{name}.normal", "must not be the zero vector")
        self.normal = n / np.linalg.norm(n)
        super().__init__(model, name, **options)

    def reference_point(self) -> np.ndarray:
        return self.point

    def _geometry(self, R, shift, c0):
        return np.concatenate([c0 + shift + R @ (self.point - c0), R @ self.normal, [0.0]])


class Sphere(Obstacle):
    """Ball of ``radius`` (m) about ``center`` (m)."""

    kind = SPHERE
    type_name = "sphere"

    def __init__(self, model, name: str, center=(0.0, 0.0, 0.0), radius: float = 0.01, **options):
        self.sphere_center = _vec3(f"obstacles.{name}.center", center)
        self.radius = _number(f"obstacles.{name}.radius", radius)
        super().__init__(model, name, **options)

    def reference_point(self) -> np.ndarray:
        return self.sphere_center

    def _geometry(self, R, shift, c0):
        return np.concatenate([c0 + shift + R @ (self.sphere_center - c0), [0.0, 0.0, 0.0], [self.radius]])


class Capsule(Obstacle):
    """Cylinder of ``radius`` (m) about the segment from ``a`` to ``b`` (m) with hemispherical caps:
    a post, peg or pulley (``a == b`` is a sphere)."""

    kind = CAPSULE
    type_name = "capsule"

    def __init__(self, model, name: str, a=(0.0, 0.0, 0.0), b=(0.0, 0.0, 1.0), radius: float = 0.01, **options):
        self.a = _vec3(f"obstacles.{name}.a", a)
        self.b = _vec3(f"obstacles.{name}.b", b)
        self.radius = _number(f"obstacles.{name}.radius", radius)
        super().__init__(model, name, **options)

    def reference_point(self) -> np.ndarray:
        return 0.5 * (self.a + self.b)

    def _geometry(self, R, shift, c0):
        return np.concatenate([c0 + shift + R @ (self.a - c0), c0 + shift + R @ (self.b - c0), [self.radius]])
