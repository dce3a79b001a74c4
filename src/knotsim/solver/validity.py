"""Validity guards: a run stops when its state leaves the model, instead of reporting nonsense.

After every converged step, before it is accepted, :class:`ValidityMonitor` checks three things
(limits in :class:`~knotsim.solver.stepper.SolverOptions`, derived in ``docs/physics.md`` §1.8):

- **finite values**: positions, edge angles, velocities and energies are finite;
- **axial strain** ``|l/l0 - 1|`` of every edge is at most ``max_axial_strain`` (default 2: the
  library's set-ups stretch their ropes by up to 0.72, the MAE259B reef and granny pre-pulled at
  mu = 0.5). The stretching energy of Discrete Elastic Rods is linear elasticity of the centre line;
  a state far beyond that is a load in the wrong units or a grip fighting a clamp;
- **energy without a source**: the total energy ``E`` (elastic, contact and obstacle penalties,
  springs, kinetic, gravity) may only grow by the work ``W`` supplied by the supports (prescribed
  motion: ``W = sum r_i dq_i`` over the constrained unknowns, ``r`` their reaction), the applied
  forces and moments, spring grips' moving anchors, moving obstacles and changes of an adaptive
  contact stiffness. Backward Euler, damping
  and friction dissipate, so the energy created from nothing, ``G = sum (dE - W)``, stays near or
  below zero in a valid run; the run stops when ``G`` exceeds ``max_energy_gain`` times the energy
  the run has handled (the largest of the energies present and of the summed ``|W|``). Where a run
  has a source whose work is not counted (a ring-twist group, which changes the rest twist), the
  energy check is not applied and ``run.json`` says so.

A violation raises :class:`~knotsim.errors.ValidityError` (a :class:`~knotsim.errors.SimulationError`)
naming the rod, the edge or node, the quantity, its value and the time; the state before the
offending step is attached and the run's output up to it is kept. A run that comes within half of a
limit gets a warning in ``run.json`` (:meth:`ValidityMonitor.report`).
"""

from __future__ import annotations

import math

import numpy as np

from knotsim.errors import ValidityError
from knotsim.solver._validity_kernels import first_non_finite, largest_axial_strain
from knotsim.solver.state import ValidityMemory

__all__ = ["WARN_FRACTION", "ValidityMonitor"]

#: a run whose worst strain or energy gain exceeds this fraction of its limit gets a warning
WARN_FRACTION = 0.5


class ValidityMonitor:
    """Checks every converged step against the model's validity limits; keeps the run's extremes.

    ``model``: the :class:`~knotsim.rods.Model`; ``max_axial_strain`` (dimensionless, ``inf`` to
    switch off); ``max_energy_gain`` (dimensionless, ``inf`` to switch off); ``force_tol`` (N): the
    stepper's force tolerance, which sets the smallest energy scale the gain is measured against,
    ``1e3 force_tol`` times the total rope length (a run at rest handles no energy; its round-off
    must not count as energy created); ``interactions``: the stepper's interactions (their
    ``untracked_sources()`` name sources whose work is not counted: then no energy check).

    What the monitor accumulates is run memory (:class:`~knotsim.solver.state.ValidityMemory`),
    carried by the state: :meth:`check` uses that of the state it checks (``memory`` is the last
    one used, read by :meth:`report`)."""

    def __init__(self, model, max_axial_strain: float, max_energy_gain: float, force_tol: float,
                 interactions=()):
        self.model = model
        #: interactions whose penalty energy is ``k_c`` times a function of the positions (an
        #: adaptive ``k_c`` changes their energy between steps: a source, counted)
        self.stiffened = [i for i in interactions if i.k_c is not None]
        self.max_axial_strain = float(max_axial_strain)
        self.max_energy_gain = float(max_energy_gain)
        self.energy_floor = 1e3 * float(force_tol) * float(np.sum(model.rest_length))
        self.untracked_sources = [name for inter in interactions for name in inter.untracked_sources()]
        #: the run memory of the last check (a new one until then)
        self.memory = ValidityMemory()

    # the accumulated numbers (J, see ValidityMemory), read from the memory in use
    @property
    def gain(self) -> float:
        return self.memory.gain

    @property
    def scale(self) -> float:
        return self.memory.scale

    # ------------------------------------------------------------------ the check
    def check(self, state_out, res) -> None:
        """Raise :class:`ValidityError` if the step that ended in ``state_out`` (its
        :class:`~knotsim.solver.stepper.StepResult` ``res``) left the model's validity; else record it
        (call once per accepted step, after it converged and before it is accepted)."""
        m = self.model
        mem = self.memory = state_out.memory.validity
        t = float(res.time)
        for name, arr in (("position or edge angle", state_out.q), ("velocity", state_out.v)):
            i = int(first_non_finite(arr))
            if i >= 0:
                raise ValidityError(f"non-finite {name} {float(arr[i])!r} at {self._dof_name(i)} at t={t:.6g} s; the "
                                    "state left the model (check the loads, the units and dt)", quantity=name,
                                    value=float(arr[i]))
        strain, edge = largest_axial_strain(state_out.q, m.edge_dofs, m.rest_length)
        edge = int(edge)
        if edge >= 0 and strain > mem.worst_strain[0]:
            mem.worst_strain = (float(strain), edge, t)
        if edge >= 0 and strain > self.max_axial_strain:
            raise ValidityError(
                f"axial strain {strain:.4g} of {self._edge_name(edge)} at t={t:.6g} s exceeds max_axial_strain="
                f"{self.max_axial_strain:g}: the rope is stretched beyond the model (a load in the wrong units? "
                "a grip pulling against a clamp?); raise solver.max_axial_strain only if such strains are meant",
                quantity="axial_strain", value=float(strain))
        self._check_energy(mem, res, t)

    def _check_energy(self, mem: ValidityMemory, res, t: float) -> None:
        e = res.energies
        energy = e.get("elastic", 0.0) + e.get("kinetic", 0.0) + e.get("gravity", 0.0)
        stored = abs(e.get("elastic", 0.0)) + abs(e.get("kinetic", 0.0))
        for value in res.interaction_energies.values():
            energy += value
            stored += abs(value)
        if not math.isfinite(energy):
            raise ValidityError(f"non-finite energy {energy!r} at t={t:.6g} s; the state left the model",
                                quantity="energy", value=energy)
        # a stiffness k_c changed between steps changes the penalty energy k_c phi(q_n) by
        # (k_new / k_old - 1) E_old before the rods move: work of a source, not of the motion
        restiffened = 0.0
        for inter in self.stiffened:
            k_old, e_old = mem.penalty.get(inter.name, (math.nan, 0.0))
            if k_old > 0.0:
                restiffened += (float(inter.k_c) / k_old - 1.0) * e_old
            mem.penalty[inter.name] = (float(inter.k_c), float(res.interaction_energies.get(inter.name, 0.0)))
        if math.isnan(mem.energy):  # the first step: the reference
            mem.energy = energy
            mem.gravity_start = e.get("gravity", 0.0)
            mem.scale = max(stored, self.energy_floor)
            return
        work = res.external_work + restiffened
        mem.gain += energy - mem.energy - work
        mem.work_handled += abs(work)
        stored += abs(e.get("gravity", 0.0) - mem.gravity_start)
        mem.scale = max(mem.scale, stored, mem.work_handled)
        mem.energy = energy
        if self.untracked_sources:
            return
        ratio = mem.gain / mem.scale
        if ratio > mem.worst_gain[0]:
            mem.worst_gain = (ratio, t)
        if ratio > self.max_energy_gain:
            raise ValidityError(
                f"energy grew without a source: {mem.gain:.4g} J created by t={t:.6g} s, {ratio:.3g} x the energy "
                f"the run handled ({mem.scale:.4g} J), beyond max_energy_gain={self.max_energy_gain:g}; the "
                "time integration is unstable here (try a smaller dt, softer contact or a finer rope)",
                quantity="energy_gain", value=ratio)

    def _edge_name(self, edge: int) -> str:
        m = self.model
        rod = int(m.edge_rod[edge])
        return f"edge {int(m.edge_local[edge])} of rod {m.rod_names[rod]!r}"

    def _dof_name(self, i: int) -> str:
        m = self.model
        if m.theta_mask[i]:
            e = int(np.flatnonzero(m.edge_theta_dof == i)[0])
            return f"the angle of {self._edge_name(e)}"
        node = int(np.flatnonzero((m.node_dof <= i) & (i < m.node_dof + 3))[0])
        rod = int(m.node_rod[node])
        return f"node {node - int(m.rod_node_start[rod])} of rod {m.rod_names[rod]!r}"

    # ------------------------------------------------------------------ records
    def report(self, memory: ValidityMemory | None = None) -> dict:
        """What ``run.json`` records under ``validity``: limits, extremes and ``warnings`` (of the run
        memory ``memory``, default: that of the last check)."""
        mem = memory if memory is not None else self.memory
        strain, edge, ts = mem.worst_strain
        gain, tg = mem.worst_gain
        out = {"max_axial_strain": self.max_axial_strain, "max_energy_gain": self.max_energy_gain,
               "largest_axial_strain": strain, "largest_axial_strain_at": self._edge_name(edge) if edge >= 0 else None,
               "largest_axial_strain_time": None if math.isnan(ts) else ts,
               "largest_energy_gain": gain, "largest_energy_gain_time": None if math.isnan(tg) else tg,
               "energy_check": ("applied" if not self.untracked_sources else
                                "not applied: the work of " + ", ".join(self.untracked_sources) + " is not counted"),
               "warnings": []}
        if edge >= 0 and WARN_FRACTION * self.max_axial_strain < strain <= self.max_axial_strain:
            out["warnings"].append(f"axial strain {strain:.3g} of {self._edge_name(edge)} at t={ts:.6g} s is more "
                                   f"than half of max_axial_strain={self.max_axial_strain:g}")
        if WARN_FRACTION * self.max_energy_gain < gain <= self.max_energy_gain:
            out["warnings"].append(f"energy created without a source reached {gain:.3g} x the energy handled at "
                                   f"t={tg:.6g} s, more than half of max_energy_gain={self.max_energy_gain:g}")
        return out
