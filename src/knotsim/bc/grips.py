"""Boundary conditions with feedback or their own stiffness, as methods of
:class:`~knotsim.bc.BoundaryConditions`: twist injected at the cut of a closed ring
(:meth:`~GripMethods.ring_twist`), spring grips (:meth:`~GripMethods.spring`), load-cell grips held at
a target force (:meth:`~GripMethods.load_cell`), and the evaluation of turning grips
(``move(..., rotation=...)``, :mod:`knotsim.bc.rigid`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from knotsim._util.validate import number
from knotsim.bc.feedback import LoadCell, RingCut
from knotsim.bc.group import Group, GroupKind, _as_load
from knotsim.bc.paths import as_path
from knotsim.bc.rigid import frame_turn, rotation_matrix
from knotsim.errors import ConfigError


class GripMethods:
    """Mixin of :class:`~knotsim.bc.BoundaryConditions` (uses its ``model``, ``groups``, ``_add``)."""

    # ------------------------------------------------------------------ building
    def ring_twist(self, name: str, rod=None, total: float | None = None, rate: float | None = None,
                   angle: Callable[[float], float] | None = None, node: int = 0, start: float = 0.0,
                   stop: float | None = None):
        """Inject twist (rad) into a closed rod at a cut at ``node``: the material frames across the
        cut are welded with an angle jump that grows at ``rate`` (rad/s) up to ``total`` (rad), jumps
        to ``total`` at ``start`` (``total`` alone), or follows ``angle(elapsed)`` (rad). It lowers
        the ring's rest twist by the injected twist, spread over its nodes by Voronoi length
        (:mod:`knotsim.bc.feedback` says why; this writes ``model.twist_bar`` at every evaluation). After ``stop`` the injected twist stays.
        The moment across the cut (N m) is logged as ``<name>_moment``, the twist as ``<name>_twist``.
        Michell's threshold: :func:`knotsim.bc.feedback.michell_twist`."""
        self._check_name(name)
        start, stop = self._check_window(name, start, stop)
        r = self.model.rod_index(self._rod(name, rod))
        m = self.model
        spec = m.rods[r]
        if not m.rod_closed[r]:
            raise ConfigError(f"bc.{name}.rod", f"rod {m.rod_names[r]!r} is open; ring_twist needs a closed rod "
                                                f"(closed = true); twist an open rod with rotate")
        if angle is not None:
            if total is not None or rate is not None or not callable(angle):
                raise ConfigError(f"bc.{name}.angle", "give a callable angle alone, or total and/or rate")
            a0 = float(angle(0.0))
            fn = lambda s, f=angle, a0=a0: float(f(s)) - a0  # noqa: E731
        else:
            for key, v in (("total", total), ("rate", rate)):
                if v is not None and not math.isfinite(float(v)):
                    raise ConfigError(f"bc.{name}.{key}", f"must be a finite number, got {v!r}")
            if total is None and rate is None:
                raise ConfigError(f"bc.{name}.total", "give total (rad), rate (rad/s), both, or angle")
            if rate is None:
                fn = lambda s, a=float(total): a  # noqa: E731
            elif total is None:
                fn = lambda s, w=float(rate): w * s  # noqa: E731
            else:
                if float(rate) == 0.0 or float(total) * float(rate) < 0:
                    raise ConfigError(f"bc.{name}.rate", f"must be non-zero with the sign of total={total}, got {rate}")
                fn = lambda s, a=float(total), w=float(rate): max(-abs(a), min(abs(a), w * s))  # noqa: E731
        g_node = self._group_nodes(name, r, [node])[1]
        stencil = np.flatnonzero(m.bend_node == g_node[0])
        s = int(stencil[0])
        e_in, e_out = (int(e) for e in m.bend_edges[s])
        stencils = np.arange(int(m.rod_bend_start[r]), int(m.rod_bend_start[r + 1]))
        base = np.zeros(stencils.size)
        if spec.natural_twist is not None:
            base = np.asarray(spec.natural_twist, float) * m.voronoi_rest[stencils]
        weight = m.voronoi_rest[stencils] / m.voronoi_rest[stencils].sum()
        g = Group(name, GroupKind.RING_TWIST, r, g_node, np.array([e_in, e_out]), start, stop)
        g.ring = RingCut(int(g_node[0]), s, (e_in, e_out), stencils, base, weight, fn)
        return self._add(g)

    def spring(self, name: str, rod=None, nodes: Sequence[int] = (-1,), stiffness: float | None = None,
               path=None, start: float = 0.0, stop: float | None = None):
        """A soft grip: each of the ``n`` nodes is tied by a linear spring of stiffness
        ``stiffness/n`` (N/m) to an anchor point, its position when the group activates carried along
        ``path`` (as for :meth:`move`; default: the anchors stay). The total spring force is
        ``stiffness`` times the offset of the anchors' centroid from the nodes' (logged as
        ``<name>_fx``, ... with ``<name>_anchor_x``, ...); implicit (:mod:`knotsim.bc.springs`)."""
        self._check_name(name)
        start, stop = self._check_window(name, start, stop)
        try:
            k = float(stiffness)
        except (TypeError, ValueError):
            k = float("nan")
        if not (k > 0 and math.isfinite(k)):
            raise ConfigError(f"bc.{name}.stiffness", f"must be a positive stiffness in N/m, got {stiffness!r}")
        try:
            p = as_path(path if path is not None else (0.0, 0.0, 0.0))
        except ConfigError as exc:
            raise ConfigError(f"bc.{name}.{exc.field}", str(exc).split(": ", 1)[1]) from None
        r, g = self._group_nodes(name, rod, nodes)
        return self._add(Group(name, GroupKind.SPRING, r, g, np.zeros(0, np.int64), start, stop, path=p, stiffness=k))

    def load_cell(self, name: str, rod=None, nodes: Sequence[int] = (-2, -1), direction=(1.0, 0.0, 0.0),
                  target=0.0, ki: float | None = None, kp: float = 0.0, max_speed: float | None = None,
                  twist: bool = True, start: float = 0.0, stop: float | None = None):
        """A grip held at a target force: the group is clamped (with ``twist``, also its edge
        angles) and moved along ``direction`` by a displacement ``u`` that a PI controller adjusts
        after every step so that the reaction along ``direction`` follows ``target`` (N, a number
        or a callable of the time since ``start``): ``u = kp e + ki ∫ e dt``, ``e = target - F``
        (``kp`` m/N, ``ki`` m/(N s)), at most ``max_speed`` (m/s) fast. With grip stiffness ``K``
        (N/m: the force per displacement of the rest of the model) the force settles with time
        constant about ``1/(ki K)``; explicit feedback needs ``ki K dt < 2``. Logged:
        ``<name>_displacement`` (m), ``<name>_target``, ``<name>_error`` (N)."""
        self._check_name(name)
        start, stop = self._check_window(name, start, stop)
        d = np.asarray(direction, dtype=float) if np.ndim(direction) == 1 else np.zeros(0)
        if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
            raise ConfigError(f"bc.{name}.direction", f"expected a non-zero 3-vector, got {direction!r}")
        gains = {}
        for key, v, default in (("ki", ki, None), ("kp", kp, 0.0), ("max_speed", max_speed, math.inf)):
            v = default if v is None else v
            if v is None:
                raise ConfigError(f"bc.{name}.ki", "missing required field: the integral gain in m/(N s)")
            gains[key] = number(v, f"bc.{name}.{key}", at_least=0.0, infinite=True, must="be a number >= 0")
        if gains["ki"] == 0.0 and gains["kp"] == 0.0:
            raise ConfigError(f"bc.{name}.ki", "ki and kp are both 0: the grip would never move")
        load = _as_load(name, target, ())
        r, g = self._group_nodes(name, rod, nodes)
        grp = Group(name, GroupKind.LOAD_CELL, r, g, self._edges_within(g) if twist else np.zeros(0, np.int64), start, stop,
                    fix_twist=twist)
        grp.cell = LoadCell(d / np.linalg.norm(d), load, gains["kp"], gains["ki"], gains["max_speed"])
        grp.memory.cell = grp.cell.memory
        return self._add(grp)

    def interactions(self) -> list:
        """``[BCInteraction]`` when a group needs one (springs; the logs of load cells, ring twist and
        turning grips), else ``[]``; the same object on every call (:mod:`knotsim.bc.springs`)."""
        if not any(self._needs_interaction(g) for g in self.groups.values()):
            return []
        if self._interaction is None or set(self._interaction_groups) != set(self.groups):
            from knotsim.bc.springs import BCInteraction

            self._interaction = BCInteraction(self)
            self._interaction_groups = tuple(self.groups)
        return [self._interaction]

    @staticmethod
    def _needs_interaction(g) -> bool:
        return g.kind in (GroupKind.SPRING, GroupKind.LOAD_CELL, GroupKind.RING_TWIST) or g.rotation is not None

    def ring_moment(self, name: str, state) -> float:
        """Twisting moment (N m) across the cut of ring-twist group ``name`` in ``state`` (a
        :class:`~knotsim.solver.state.State`, e.g. ``solve_static(...).state``)."""
        g = self.groups.get(name)
        if g is None or g.ring is None:
            raise ConfigError("name", f"no ring_twist group named {name!r}")
        m, c = self.model, g.ring
        tw = state.q[m.edge_theta_dof[c.edges[1]]] - state.q[m.edge_theta_dof[c.edges[0]]] + state.ref_twist[c.stencil]
        return float(m.twist_GJ[c.stencil] / m.voronoi_rest[c.stencil] * (tw - m.twist_bar[c.stencil]))

    # ------------------------------------------------------------------ evaluation helpers
    def _set_ring_twist(self, t: float) -> None:
        rings = [g for g in self.groups.values() if g.ring is not None]
        for g in rings:
            self.model.twist_bar[g.ring.stencils] = g.ring.base
        for g in rings:
            tw = g.ring.injected(t, g.start, g.stop)
            self.model.twist_bar[g.ring.stencils] -= tw * g.ring.weight
            g.ring.value = tw

    def _activated(self, g) -> None:
        """A prescribed group just captured its anchor: bind its path, pivot and controller."""
        centroid = g.anchor.mean(axis=0)
        if g.path is not None:
            g.path.bind(centroid)
            g.memory.path_start = g.path.bound_state()
            if g.path.absolute_start is not None:
                self._check_path_start(g, centroid)
        if g.rotation is not None:
            g.pivot = g.rotation.pivot(centroid)
        if g.cell is not None:
            g.cell.reset()

    def _spring_targets(self, g, t: float, q_in: np.ndarray, t_in: float) -> None:
        m = self.model
        if g.anchor is None or g.anchor_time > t_in + 1e-12:
            g.anchor = q_in[m.node_dof[g.nodes][:, None] + np.arange(3)[None, :]].copy()
            g.anchor_time = t_in
            g.path.bind(g.anchor.mean(axis=0))
            g.memory.path_start = g.path.bound_state()
            if g.path.absolute_start is not None:
                self._check_path_start(g, g.anchor.mean(axis=0))
        disp = g.path(t - g.start) - g.path(max(g.anchor_time - g.start, 0.0))
        g.target = g.anchor + disp[None, :]

    def _translated_values(self, g, t: float, axes: tuple | None, vals: list) -> bool | None:
        """For a group that only translates (no rotation, load cell or twist rate): append the
        values it prescribes at ``t`` (s) to ``vals`` as floats, the coordinates ``axes`` (indices,
        ``None`` for all three) of every node (m), then its edge angles (rad) when it fixes them;
        return whether it did append angles. ``None`` (nothing appended) for other groups and for
        paths without :meth:`~knotsim.bc.paths.Path.components`. The same numbers as
        :meth:`_prescribed_values`."""
        twist = g.fix_twist and g.edges.size
        if g.rotation is not None or g.cell is not None or (twist and g.twist_angle is not None):
            return None
        if g.path is None:
            dx = dy = dz = 0.0
        else:
            e0 = max(g.anchor_time - g.start, 0.0)
            a = g.path.components(t - g.start)
            b = g.path.components(e0) if a is not None else None
            if b is None:
                return None
            dx, dy, dz = a[0] - b[0], a[1] - b[1], a[2] - b[2]
        if axes is None:
            for x, y, z in g.anchor.tolist():
                vals += (x + dx, y + dy, z + dz)
        else:
            for row in g.anchor.tolist():
                p = (row[0] + dx, row[1] + dy, row[2] + dz)
                vals += [p[k] for k in axes]
        if twist:
            vals += g.anchor_theta.tolist()
            return True
        return False

    def _prescribed_values(self, g, t: float, q_in: np.ndarray, t_in: float):
        """Positions ``(n, 3)`` and edge angles (or ``None``) a prescribed group imposes at ``t``."""
        e0 = max(g.anchor_time - g.start, 0.0)
        disp = g.path.displacement(t - g.start) - g.path.displacement(e0) if g.path is not None else np.zeros(3)
        if g.cell is not None:
            disp = disp + g.cell.direction * g.cell.displacement(t, t_in)
        th = g.anchor_theta if (g.fix_twist and g.edges.size) else None
        if g.rotation is None:
            if th is not None and g.twist_angle is not None:
                th = th + g.twist_angle(t - g.start) - g.twist_angle(e0)
            return g.anchor + disp[None, :], th
        m = self.model
        a0 = g.rotation.angle(e0)
        phi = g.rotation.angle(t - g.start) - a0
        rot = rotation_matrix(g.rotation.axis, phi)
        pos = g.pivot + disp + (g.anchor - g.pivot) @ rot.T
        g.current = (pos, g.pivot + disp, phi)
        if th is not None:
            phi_in = g.rotation.angle(max(t_in - g.start, e0)) - a0
            ends = np.searchsorted(g.nodes, m.edge_nodes[g.edges])
            x_in = q_in[m.node_dof[g.nodes][:, None] + np.arange(3)[None, :]]
            t_old = x_in[ends[:, 1]] - x_in[ends[:, 0]]
            t_new = pos[ends[:, 1]] - pos[ends[:, 0]]
            t_old /= np.linalg.norm(t_old, axis=1)[:, None]
            t_new /= np.linalg.norm(t_new, axis=1)[:, None]
            th = q_in[m.edge_theta_dof[g.edges]] + frame_turn(t_old, t_new, rotation_matrix(g.rotation.axis,
                                                                                              phi - phi_in))
        return pos, th

    def _feedback_log(self, g, r, residual, t: float) -> None:
        """After an accepted step: update a load cell's controller; log load cells and turning grips."""
        m = self.model
        if g.cell is not None:
            c = g.cell
            if r is not None:
                c.update(t, g.start, float(np.dot(r[:3], c.direction)))
            self.log_values[f"{g.name}_displacement"] = c.memory.u
            self.log_values[f"{g.name}_target"] = float(c.target(max(t - g.start, 0.0)))
            self.log_values[f"{g.name}_error"] = c.memory.error
        if g.rotation is not None:
            mom = np.zeros(3)
            if r is not None and g.current is not None:
                pos, pivot, phi = g.current
                f = np.stack([residual[m.node_dof[g.nodes] + k] for k in range(3)], axis=1)
                mom = np.cross(pos - pivot, f).sum(axis=0)
                if g.fix_twist and g.edges.size:
                    ends = np.searchsorted(g.nodes, m.edge_nodes[g.edges])
                    tan = pos[ends[:, 1]] - pos[ends[:, 0]]
                    tan /= np.linalg.norm(tan, axis=1)[:, None]
                    mom += (residual[m.edge_theta_dof[g.edges]][:, None] * tan).sum(axis=0)
                self.log_values[f"{g.name}_angle"] = phi
            else:
                self.log_values[f"{g.name}_angle"] = g.current[2] if g.current is not None else 0.0
            for k, c in enumerate("xyz"):
                self.log_values[f"{g.name}_m{c}"] = float(mom[k])

    def _check_interaction(self, t: float) -> None:
        for g in self.groups.values():
            if g.kind == GroupKind.SPRING and g.active(t) and not self._interaction_seen:
                raise ConfigError(f"bc.{g.name}", "spring grips act through an interaction that this solve does not "
                                                  "have: pass interactions=bcs.interactions() to solve_static "
                                                  "(Simulation and run files add it themselves)")
