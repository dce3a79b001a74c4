"""Boundary conditions: clamp, hold, move along paths, twist, release, apply forces and moments.

Every condition is a *named group* of nodes of one rod, active in a time window
``[start, stop)``. Several conditions may be active at once and may start and stop at given times,
like hands tying a knot::

    bcs = BoundaryConditions(model)
    bcs.clamp("left", rod=0, nodes=[0, 1])                      # positions + twist of edge 0
    bcs.move("right", rod=0, nodes=[-2, -1], path=[0.006, 0, 0]) # 6 mm/s along x
    bcs.hold("knot-bottom", rod=0, nodes=[150], stop=2.0)        # held until t = 2 s
    bcs.release("right", at=5.0)                                 # free from t = 5 s on
    bcs.force("weight", rod=0, nodes=[-1], force=[0, 0, -1e-3])  # N, total on the group

Prescribed groups (clamp, hold, move, rotate) capture the positions of their nodes when they become
active and prescribe them from then on; a released group keeps its velocity. The reaction of every
prescribed group (the force, N, and twisting moment, N m, the constraint exerts on the rod) is
reported after each step: it is the pull force of knot tests.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Sequence

import numpy as np

from knotsim.bc._kernels import prescribed_reaction
from knotsim.bc.grips import GripMethods
from knotsim.bc.group import _EPS_T, Group, GroupKind, _as_load, _Plan
from knotsim.bc.paths import as_path
from knotsim.bc.rigid import as_rotation
from knotsim.errors import ConfigError
from knotsim.rods.model import expand_indices
from knotsim.solver.state import GroupMemory

_NO_DOFS = np.zeros(0, np.int64)


class BoundaryConditions(GripMethods):
    """The set of boundary conditions of a run (the *control* of the time stepper).

    All node indices are local to the rod named by ``rod`` (index or name); negative indices count
    from the end. Times are in s, positions in m, forces in N, moments in N m, angles in rad.
    """

    def __init__(self, model):
        self.model = model
        self.groups: dict[str, Group] = {}
        #: extra log columns of the last accepted step (load cells, turning grips), N, N m, m, rad
        self.log_values: dict[str, float] = {}
        self._interaction = None
        self._interaction_seen = False
        self._dofs_cache = None

    # ------------------------------------------------------------------ building
    def _check_name(self, name: str) -> None:
        if not isinstance(name, str) or not name:
            raise ConfigError("name", f"a boundary condition needs a non-empty name, got {name!r}")
        if name in self.groups:
            raise ConfigError(f"bc.{name}", "a boundary condition with this name already exists")

    @staticmethod
    def _check_window(name: str, start: float, stop: float) -> tuple[float, float]:
        start = 0.0 if start is None else float(start)
        stop = math.inf if stop is None else float(stop)
        if not (start >= 0.0) or not math.isfinite(start):
            raise ConfigError(f"bc.{name}.start", f"must be a time >= 0 s, got {start}")
        if math.isnan(stop) or stop <= start:
            raise ConfigError(f"bc.{name}.stop", f"need start < stop, got start={start}, stop={stop}")
        return start, stop

    def _edges_within(self, nodes: np.ndarray) -> np.ndarray:
        m = self.model
        inside = np.isin(m.edge_nodes[:, 0], nodes) & np.isin(m.edge_nodes[:, 1], nodes)
        return np.nonzero(inside)[0]

    def _add(self, group: Group) -> Group:
        if group.prescribed:
            for other in self.groups.values():
                if not other.prescribed:
                    continue
                overlap_t = group.start < other.stop and other.start < group.stop
                common = np.intersect1d(group.nodes, other.nodes)
                if overlap_t and common.size and np.any(group.axes & other.axes):
                    local = int(common[0] - self.model.rod_node_start[group.rod])
                    raise ConfigError(
                        f"bc.{group.name}.nodes",
                        f"node {local} of rod {self.model.rod_names[group.rod]!r} is already prescribed by "
                        f"{other.kind} {other.name!r} while both are active; release one first "
                        f"(give {other.name!r} a stop time <= {group.start})",
                    )
            if group.path is not None and group.path.absolute_start is not None and group.start <= 0.0:
                centroid = self.model.node_positions(self.initial_q())[group.nodes].mean(axis=0)
                self._check_path_start(group, centroid)
        self.groups[group.name] = group
        return group

    def _check_path_start(self, group: Group, centroid: np.ndarray) -> None:
        start = group.path.absolute_start
        tol = 1e-6 * max(1.0, float(np.max(np.abs(centroid))))
        if np.linalg.norm(start - centroid) > tol:
            raise ConfigError(
                f"bc.{group.name}.path",
                f"path starts at {np.round(start, 6).tolist()} m but the group's centroid is at "
                f"{np.round(centroid, 6).tolist()} m; start the path there or use relative displacements",
            )

    def initial_q(self) -> np.ndarray:
        from knotsim.solver.state import initial_state

        return initial_state(self.model).q

    def _rod(self, name, rod):
        """``rod`` (index or name); ``None`` means rod 0 in a one-rod model and is an error naming
        ``bc.<name>.rod`` in a model with several rods (which rod is meant cannot be guessed)."""
        if rod is None:
            if self.model.n_rods == 1:
                return 0
            raise ConfigError(f"bc.{name}.rod", f"the model has {self.model.n_rods} rods "
                              f"({', '.join(map(repr, self.model.rod_names))}); say which one: rod = NAME or index")
        return rod

    def _group_nodes(self, name, rod, nodes):
        rod = self._rod(name, rod)
        try:
            r = self.model.rod_index(rod)
            g = self.model.global_nodes(r, nodes)
        except ConfigError as exc:
            raise ConfigError(f"bc.{name}.{exc.field}", str(exc).split(": ", 1)[1]) from None
        return r, np.unique(g)

    def clamp(self, name: str, rod=None, nodes: Sequence[int] = (0, 1), twist: bool = True,
              start: float = 0.0, stop: float | None = None) -> Group:
        """Fix the positions of ``nodes`` (and, with ``twist``, the angles of the edges between them)
        at their values when the group becomes active."""
        self._check_name(name)
        start, stop = self._check_window(name, start, stop)
        r, g = self._group_nodes(name, rod, nodes)
        return self._add(Group(name, GroupKind.CLAMP, r, g, self._edges_within(g) if twist else np.zeros(0, np.int64),
                               start, stop, fix_twist=twist))

    def hold(self, name: str, rod=None, nodes: Sequence[int] = (0,), start: float = 0.0,
             stop: float | None = None) -> Group:
        """Hold ``nodes`` at the positions they have when the group becomes active (twist free)."""
        self._check_name(name)
        start, stop = self._check_window(name, start, stop)
        r, g = self._group_nodes(name, rod, nodes)
        return self._add(Group(name, GroupKind.HOLD, r, g, np.zeros(0, np.int64), start, stop))

    def move(self, name: str, rod=None, nodes: Sequence[int] = (-2, -1), path=None, twist: bool = True,
             start: float = 0.0, stop: float | None = None, rotation=None) -> Group:
        """Move ``nodes`` rigidly along ``path``: a :class:`~knotsim.bc.paths.Path`, a velocity
        (3-vector, m/s), or a callable of elapsed time returning a displacement (m).

        ``rotation`` (a :class:`~knotsim.bc.rigid.Rotation` or a dict ``{axis, rate | angle,
        point}``) also turns the group rigidly about ``axis`` through ``point`` (m, carried along by
        the path; default ``"centroid"``, the group's centroid at activation), and with ``twist`` the
        edge angles of the group's edges advance so that their material frames turn with it. A
        turning grip without ``path`` only turns."""
        self._check_name(name)
        start, stop = self._check_window(name, start, stop)
        if path is None and rotation is None:
            raise ConfigError(f"bc.{name}.path", "a moving group needs a path (velocity, waypoints or callable)")
        try:
            p = as_path(path if path is not None else (0.0, 0.0, 0.0))
        except ConfigError as exc:
            raise ConfigError(f"bc.{name}.{exc.field}", str(exc).split(": ", 1)[1]) from None
        rot = None
        if rotation is not None:
            try:
                rot = as_rotation(rotation)
            except ConfigError as exc:
                raise ConfigError(f"bc.{name}.rotation.{exc.field}", str(exc).split(": ", 1)[1]) from None
        r, g = self._group_nodes(name, rod, nodes)
        return self._add(Group(name, GroupKind.MOVE, r, g, self._edges_within(g) if twist else np.zeros(0, np.int64),
                               start, stop, fix_twist=twist, path=p, rotation=rot))

    def rotate(self, name: str, rod=None, nodes: Sequence[int] = (-2, -1), rate: float | None = None,
               angle: Callable[[float], float] | None = None, start: float = 0.0,
               stop: float | None = None) -> Group:
        """Clamp ``nodes`` and twist the edges between them: the edge angles grow by ``rate`` (rad/s)
        or follow ``angle(elapsed)`` (rad)."""
        self._check_name(name)
        start, stop = self._check_window(name, start, stop)
        if (rate is None) == (angle is None):
            raise ConfigError(f"bc.{name}.rate", "give exactly one of rate (rad/s) or angle (callable)")
        if rate is not None:
            w = float(rate)
            fn = lambda s, w=w: w * s  # noqa: E731
        else:
            if not callable(angle):
                raise ConfigError(f"bc.{name}.angle", f"expected a callable of time, got {angle!r}")
            a0 = float(angle(0.0))
            fn = lambda s, a=angle, a0=a0: float(a(s)) - a0  # noqa: E731
        r, g = self._group_nodes(name, rod, nodes)
        edges = self._edges_within(g)
        if edges.size == 0:
            raise ConfigError(f"bc.{name}.nodes", "rotating needs at least two adjacent nodes (one edge to twist)")
        return self._add(Group(name, GroupKind.ROTATE, r, g, edges, start, stop, fix_twist=True, twist_angle=fn))

    def pin(self, name: str, rod=None, nodes: Sequence[int] = (0,), axes: str = "xyz", twist: bool = False,
            start: float = 0.0, stop: float | None = None) -> Group:
        """Fix the coordinates ``axes`` (a string of ``x``, ``y``, ``z``) of ``nodes`` at their values
        when the group becomes active; the others stay free. ``pin(nodes=[0])`` is a pinned end
        (rotation free), ``axes="yz"`` a roller along x. ``twist`` also fixes the angles of the edges
        between the nodes (for one node: of the edge it starts, or ends at the last node). The
        reaction has a component only along the fixed axes."""
        self._check_name(name)
        start, stop = self._check_window(name, start, stop)
        mask = np.array([c in str(axes) for c in "xyz"], np.bool_)
        if not isinstance(axes, str) or not mask.any() or set(axes) - set("xyz") or len(set(axes)) != len(axes):
            raise ConfigError(f"bc.{name}.axes", f"expected a string of distinct x, y, z (e.g. \"xz\"), got {axes!r}")
        r, g = self._group_nodes(name, rod, nodes)
        edges = np.zeros(0, np.int64)
        if twist:
            edges = self._edges_within(g)
            if edges.size == 0 and g.size == 1:
                m = self.model
                out = np.flatnonzero(m.edge_nodes[:, 0] == g[0])
                edges = out if out.size else np.flatnonzero(m.edge_nodes[:, 1] == g[0])
        return self._add(Group(name, GroupKind.PIN, r, g, edges, start, stop, fix_twist=bool(twist), axes=mask))

    def slide(self, name: str, rod=None, nodes: Sequence[int] = (0,), along=(1.0, 0.0, 0.0), twist: bool = False,
              start: float = 0.0, stop: float | None = None) -> Group:
        """A rail: ``nodes`` move only along the coordinate axis ``along`` (e.g. ``[1, 0, 0]``), the two
        other coordinates fixed (:meth:`pin` with those axes)."""
        return self.pin(name, rod, nodes, _other_axes(name, "along", along, keep=True), twist, start, stop)

    def plane(self, name: str, rod=None, nodes: Sequence[int] = (0,), normal=(0.0, 0.0, 1.0), twist: bool = False,
              start: float = 0.0, stop: float | None = None) -> Group:
        """A symmetry plane (or a frictionless guide): ``nodes`` keep their coordinate along the
        coordinate axis ``normal`` and move freely in the plane (:meth:`pin` with that axis)."""
        return self.pin(name, rod, nodes, _other_axes(name, "normal", normal, keep=False), twist, start, stop)

    def force(self, name: str, rod=None, nodes: Sequence[int] = (-1,), force=(0.0, 0.0, 0.0),
              start: float = 0.0, stop: float | None = None) -> Group:
        """Apply a total force (N; a 3-vector or a callable of the time elapsed since the group became
        active, s, like every time-dependent boundary condition) split equally over ``nodes``."""
        self._check_name(name)
        start, stop = self._check_window(name, start, stop)
        r, g = self._group_nodes(name, rod, nodes)
        load = _as_load(name, force, (3,))
        return self._add(Group(name, GroupKind.FORCE, r, g, np.zeros(0, np.int64), start, stop, load=load))

    def moment(self, name: str, rod=None, edges: Sequence[int] = (-1,), moment=0.0, start: float = 0.0,
               stop: float | None = None) -> Group:
        """Apply a twisting moment (N m, scalar or callable of the time elapsed since the group became
        active, s) on each of ``edges``."""
        self._check_name(name)
        start, stop = self._check_window(name, start, stop)
        r = self.model.rod_index(self._rod(name, rod))
        ne = int(self.model.rod_n_edges[r])
        idx = expand_indices(edges, ne, f"a rod with {ne} edges", field=f"bc.{name}.edges")
        if not np.issubdtype(idx.dtype, np.integer) or np.any((idx < -ne) | (idx >= ne)):
            raise ConfigError(f"bc.{name}.edges", f"edge index out of range for a rod with {ne} edges: {edges!r}")
        ge = self.model.rod_edge_start[r] + (idx % ne)
        load = _as_load(name, moment, ())
        return self._add(Group(name, GroupKind.MOMENT, r, np.zeros(0, np.int64), ge, start, stop, load=load))

    def release(self, name: str, at: float) -> None:
        """End group ``name`` at time ``at`` (s); a released prescribed group keeps its velocity."""
        if name not in self.groups:
            raise ConfigError("release", f"no boundary condition named {name!r}; known: {sorted(self.groups)}")
        g = self.groups[name]
        at = float(at)
        if at <= g.start:
            raise ConfigError(f"bc.{name}.release", f"release time {at} s is not after the start {g.start} s")
        g.stop = at

    def retime(self, name: str, start: float, stop: float, now: float) -> None:
        """Move group ``name``'s window to ``[start, stop)`` (s) at time ``now`` (s), during a run: a
        group already acting keeps its start and may only end, at ``now`` or later; a group not yet
        acting may start at ``now`` or later (a stage whose length a run decides as it goes, e.g. a
        knot's set held until the knot stops moving). Forces and paths count their time from the
        (new) start."""
        if name not in self.groups:
            raise ConfigError("retime", f"no boundary condition named {name!r}; known: {sorted(self.groups)}")
        g = self.groups[name]
        start, stop = self._check_window(name, start, stop)
        if g.start - _EPS_T <= now:  # acting or done: its past stays as it was
            if start != g.start or stop < now - _EPS_T:
                raise ConfigError(f"bc.{name}.start", f"group {name!r} began at {g.start} s, before t = {now} s: "
                                                      "only its stop can move, to t or later")
        elif start < now - _EPS_T:
            raise ConfigError(f"bc.{name}.start", f"cannot start group {name!r} at {start} s, before t = {now} s")
        g.start, g.stop = start, stop

    # ------------------------------------------------------------------ evaluation
    def _plan(self, g: Group) -> _Plan:
        p = g.plan
        if p is None or p.nodes is not g.nodes or p.edges is not g.edges or p.axes is not g.axes:
            p = g.plan = _Plan(self.model, g)
        return p

    def prescribed_groups(self, t: float) -> list[Group]:
        return [g for g in self.groups.values() if g.prescribed and g.active(t)]

    def evaluate(self, t: float, q_in: np.ndarray, t_in: float):
        """Constraints and loads at time ``t`` (s) for a step starting from ``q_in`` at ``t_in``.

        Returns ``(fixed_dofs (k,) int, fixed_values (k,) float, f_ext (n_dofs,) float)``;
        ``fixed_dofs`` is read-only (the same array from step to step while the active groups stay).
        Groups that become active during the step capture their anchor (the node positions and edge
        angles of ``q_in``)."""
        m = self.model
        dofs: list[np.ndarray] = []
        vals: list[float] = []
        f_ext = np.zeros(m.n_dofs)
        self._interaction_seen = False
        self._set_ring_twist(t)
        for g in self.groups.values():
            if not g.active(t):
                g.anchor = None  # not yet active, or released: (re-)activation captures afresh
                g.target = None
                continue
            if g.kind == GroupKind.SPRING:
                self._spring_targets(g, t, q_in, t_in)
            elif g.prescribed:
                plan = self._plan(g)
                if g.anchor is None or g.anchor_time > t_in + _EPS_T:
                    g.anchor = q_in[plan.pos_dofs].reshape(-1, 3).copy()
                    g.anchor_theta = q_in[plan.theta_dofs].copy()
                    g.anchor_time = t_in
                    self._activated(g)
                dofs.append(plan.fixed_pos_dofs)
                angles = self._translated_values(g, t, plan.axes_idx, vals)  # floats, the common case
                if angles is None:
                    pos, th = self._prescribed_values(g, t, q_in, t_in)
                    vals += (pos.ravel() if plan.axes_idx is None else pos[:, g.axes].ravel()).tolist()
                    angles = th is not None
                    if angles:
                        vals += np.asarray(th, float).ravel().tolist()
                if angles:
                    dofs.append(plan.theta_dofs)
            elif g.kind == GroupKind.FORCE:
                f = g.load(t - g.start) / len(g.nodes)
                for k in range(3):
                    f_ext[m.node_dof[g.nodes] + k] += f[k]
            elif g.kind == GroupKind.MOMENT:
                f_ext[m.edge_theta_dof[g.edges]] += g.load(t - g.start)
        return self._fixed_dofs(dofs), np.array(vals, dtype=float), f_ext

    def _fixed_dofs(self, parts: list[np.ndarray]) -> np.ndarray:
        """``concatenate(parts)`` (int64), the same read-only array while the parts are the same
        arrays (the groups' cached unknowns: the same from step to step)."""
        c = self._dofs_cache
        if c is None or len(c[0]) != len(parts) or not all(map(operator.is_, c[0], parts)):
            d = np.concatenate(parts).astype(np.int64, copy=False) if parts else np.zeros(0, np.int64)
            d.flags.writeable = False
            c = self._dofs_cache = (parts, d)
        return c[1]

    def reactions(self, t: float, residual: np.ndarray) -> dict[str, np.ndarray]:
        """Reaction of every prescribed group active at ``t``: ``{name: (fx, fy, fz, moment)}``.

        ``residual`` is the full residual of the equations of motion at the converged state; at a
        prescribed unknown it is the force the constraint exerts on the rod (N, or N m for angles).
        """
        out = {}
        self._check_interaction(t)
        self.log_values = {}
        for g in self.groups.values():
            if not g.prescribed:
                continue
            if not g.active(t):
                out[g.name] = np.zeros(4)
                self._feedback_log(g, None, None, t)
                continue
            plan = self._plan(g)
            r = np.empty(4)
            # the sums of numpy's a[idx].sum(), in its order (knotsim.bc._kernels)
            prescribed_reaction(residual, plan.xyz, g.axes, plan.theta_dofs if g.fix_twist else _NO_DOFS, r)
            out[g.name] = r
            self._feedback_log(g, r, residual, t)
        return out

    def memory(self) -> dict[str, GroupMemory]:
        """The run memory of the groups that capture one (prescribed and spring groups), by name: the
        objects the groups use (a :class:`~knotsim.simulation.Simulation` carries them in
        ``state.memory.bc``; :mod:`knotsim.io.checkpoint` writes them)."""
        return {g.name: g.memory for g in self.groups.values() if g.prescribed or g.kind == GroupKind.SPRING}

    def use_memory(self, memory: dict[str, GroupMemory]) -> None:
        """Continue from the group memories ``memory`` (by group name, e.g. restored from a
        checkpoint). A group takes the one of its name when it is prescribed or a spring and the
        memory holds an anchor of its node count; the others keep their own (they capture their
        anchors afresh when they act)."""
        for name, mem in memory.items():
            g = self.groups.get(name)
            if g is None or mem is g.memory or not (g.prescribed or g.kind == GroupKind.SPRING):
                continue
            if mem.anchor is not None and mem.anchor.shape == (len(g.nodes), 3):
                g.use_memory(mem)

    def begin_step(self, state_in) -> None:
        """Before a step from ``state_in``: each group that captures a memory takes the one
        ``state_in`` carries under its name (``state_in.memory.bc``) when it is another object than
        its own (a restored run), or enters its own there when the state carries none (also a
        group added after the run started)."""
        carried = state_in.memory.bc
        for g in self.groups.values():
            if g.prescribed or g.kind == GroupKind.SPRING:
                mem = carried.get(g.name)
                if mem is None:
                    carried[g.name] = g.memory
                elif mem is not g.memory:
                    g.use_memory(mem)

    def reset(self) -> None:
        """Forget captured anchors (before re-running from the initial state)."""
        for g in self.groups.values():
            g.anchor = None
            g.anchor_theta = None
            g.target = None
            if g.cell is not None:
                g.cell.reset()
        self._set_ring_twist(-math.inf)


def _other_axes(name: str, key: str, direction, keep: bool) -> str:
    """The axes :meth:`BoundaryConditions.pin` fixes for a rail along (``keep``) or a plane normal to
    a coordinate axis ``direction``. General directions are not supported: constraints are
    prescribed coordinates of the unknowns, so a rail or plane must be aligned with x, y or z."""
    try:
        d = np.asarray(direction, dtype=float)
    except (TypeError, ValueError):
        d = np.zeros(0)
    nz = np.flatnonzero(d != 0.0) if d.shape == (3,) and np.all(np.isfinite(d)) else np.zeros(0, np.int64)
    if nz.size != 1:
        raise ConfigError(f"bc.{name}.{key}", f"must be a coordinate axis such as [1, 0, 0] (constraints fix "
                                              f"coordinates of the unknowns; a general direction is not "
                                              f"supported), got {direction!r}")
    k = int(nz[0])
    return "".join(c for i, c in enumerate("xyz") if (i != k) == keep)
