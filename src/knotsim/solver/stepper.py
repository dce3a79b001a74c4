"""Implicit (backward) Euler time stepper: ``step(state_in, state_out, control, dt)``.

Finds ``q`` with ``M (q - q_n - dt v_n)/dt^2 + D (q - q_n)/dt + grad E(q) - F_ext - F_interactions(q) = 0``
by Newton's method (prescribed unknowns removed), then sets ``v = (q - q_n)/dt``. ``D`` is the
viscous damping ``eta * Voronoi length`` per position unknown. Interactions (contact, friction)
plug in through a small protocol (see :class:`Interaction`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from knotsim.energies.elastic import ElasticEnergy, FrameSource
from knotsim.solver import assembly as asm
from knotsim.solver._kernels import (
    all_finite,
    free_part,
    implicit_residual,
    max_abs,
    predict_positions,
    same_values,
    split_max_abs,
)
from knotsim.solver._validity_kernels import constrained_work
from knotsim.solver.diagnosis import largest_residual_at
from knotsim.solver.linear import BandedSolver, LinearSolveError, SparseSolver
from knotsim.solver.newton import newton_solve
from knotsim.solver.options import LinearSolver, Predictor, SolverOptions  # noqa: F401 (re-exported)
from knotsim.solver.spin_relaxation import joined_spins, relax_spins, relaxed_angles
from knotsim.solver.state import JacobianMemory, PredictorMemory, State, StepMemory

_EPS = float(np.finfo(float).eps)


class Interaction(Protocol):
    """What a force term other than elasticity (contact, friction, obstacles, spring grips)
    provides to the stepper and the driver. Every member is required (trivial ones where an
    interaction has nothing to say): the stepper and the driver call them without probing."""

    name: str

    #: the run memory this interaction uses (a dataclass of numbers and arrays, see
    #: :class:`~knotsim.solver.state.RunMemory`), or ``None`` when it remembers nothing across steps.
    #: A :class:`~knotsim.simulation.Simulation` enters it in its state's ``memory.interactions``
    #: under :attr:`name`; :meth:`begin_step` takes the one ``state_in`` carries (a restored one
    #: from a checkpoint) and :mod:`knotsim.io.checkpoint` writes it field by field.
    memory: object | None

    #: the penalty stiffness (N/m) its energy is proportional to (an adaptive one changes the energy
    #: between steps: see :mod:`knotsim.solver.validity`), or ``None``
    k_c: float | None

    #: changes whenever :meth:`block_dofs` changes (the stepper re-analyses the matrix pattern)
    pattern_version: int

    def begin_step(self, state_in: State, dt: float) -> None:
        """Once per step attempt: choose the active set (broad phase), stiffnesses, ...; take the
        memory ``state_in`` carries (``state_in.memory.interactions[name]``, by :meth:`use_memory`)
        when it is another than :attr:`memory`, or enter :attr:`memory` there when it carries none."""

    def use_memory(self, memory) -> None:
        """Continue from ``memory`` (e.g. restored from a checkpoint): make it :attr:`memory` and
        rebuild what derives from it."""

    def block_dofs(self) -> np.ndarray:
        """Unknowns of each Jacobian block this step, ``(k, m)`` int (may be ``(0, m)``)."""

    def evaluate(self, q: np.ndarray, q_prev: np.ndarray, dt: float, residual: np.ndarray,
                 want_jacobian: bool) -> tuple[float, np.ndarray | None]:
        """Add ``-force`` to ``residual`` and return ``(energy, blocks (k, m, m) of d(-force)/dq)``."""

    def check(self, q: np.ndarray) -> str | None:
        """Reason to reject a converged step (e.g. penetration too deep), or ``None``."""

    def stats(self) -> dict:
        """Numbers to log for the last accepted step."""

    #: whether :meth:`spin_friction` can return friction (surface friction with a friction
    #: coefficient above zero)
    has_spin_friction: bool

    def spin_friction(self):
        """Friction in the edge angles alone at the last evaluation (positions held), for the spin
        relaxation (:class:`~knotsim.solver.spin_relaxation.SpinFrictionTerms`), or ``None``."""

    #: the friction law it applies (``"surface"`` or ``"centreline"``, written to ``run.json``), or
    #: ``None`` for an interaction without friction
    friction_model: str | None

    #: the per-node datasets it reports for the output frames (of ``contact_force``,
    #: ``friction_force``, ``slip_speed``, ``rolling_speed``: :mod:`knotsim.io.frame_fields`), or ``()``
    node_field_names: tuple[str, ...]

    def node_fields(self) -> dict[str, np.ndarray]:
        """The datasets :attr:`node_field_names` at the last accepted step, ``(n_nodes,)`` each."""

    def supplied_work(self, q_prev: np.ndarray, q: np.ndarray, dt: float) -> float:
        """Work (J) a moving source of this interaction did on the rods during the accepted step from
        ``q_prev`` to ``q`` (called before :meth:`stats`; see :mod:`knotsim.solver.validity`)."""

    def untracked_sources(self) -> list[str]:
        """Sources whose work :meth:`supplied_work` does not count (then no energy check)."""

    def check_start(self, q: np.ndarray) -> None:
        """Raise :class:`~knotsim.errors.GeometryError` when the start ``q`` is not admissible."""

    def describe_near(self, q: np.ndarray, node: int) -> str:
        """Text naming what of this interaction acts near global ``node`` (for failure messages), or ""."""


class StepFailure(Exception):
    """A step attempt failed (Newton did not converge, or an interaction rejected the result)."""


@dataclass
class StepResult:
    """Record of one accepted step."""

    time: float
    dt: float
    iterations: int
    residual: float
    line_search_cuts: int
    energies: dict = field(default_factory=dict)
    reactions: dict = field(default_factory=dict)
    interaction_stats: dict = field(default_factory=dict)
    solver: str = ""
    attempts: int = 1
    #: J: work done on the rods during the step by supports, applied loads and moving sources
    #: (see :mod:`knotsim.solver.validity`)
    external_work: float = 0.0
    #: J: energy of each interaction at the end of the step (also in ``energies``)
    interaction_energies: dict = field(default_factory=dict)


class _StepSystem:
    """Residual and Jacobian of one implicit step (or of a static equilibrium)."""

    def __init__(self, stepper: Stepper, state_in: State, dt: float, fixed: np.ndarray,
                 f_ext: np.ndarray, static: bool):
        self.s = stepper
        self.q_n = state_in.q
        self.v_n = state_in.v
        self.dt = dt
        self.fixed = fixed
        self.free = ~fixed
        self.f_ext = f_ext
        self.static = static
        self.source = FrameSource(state_in.d1, state_in.tangents, state_in.ref_twist)
        self.last_full_residual = None
        self.energies = {}
        self.merit = float("nan")
        self._r_full = np.zeros(stepper.model.n_dofs)
        if static:
            self.diag = np.zeros(stepper.model.n_dofs)
            self.roundoff_factor = 1.0
        else:
            self.diag, diag_max = stepper._diagonal(dt)
            # The inertia term M (q - q_n - dt v_n)/dt^2 cannot be evaluated more accurately than
            # about eps |q| M/dt^2: at tiny steps the tolerance is raised to that round-off level.
            eps_force = 64.0 * _EPS * (max_abs(state_in.q) + 1e-300) * diag_max
            self.roundoff_factor = max(1.0, eps_force / stepper.force_tol)
        self._mode = None
        #: the spin relaxation is used (:meth:`relax`)
        self.relax_enabled = (not static and stepper.options.spin_relaxation
                              and any(inter.has_spin_friction for inter in stepper.interactions))

    # -- residual / Jacobian --------------------------------------------------------------
    def residual(self, q: np.ndarray, want_jacobian: bool, turned_only: bool = False) -> np.ndarray:
        """The residual at ``q`` ``(n_dofs,)`` (prescribed unknowns zeroed); with ``want_jacobian`` the
        Jacobian is assembled there. ``turned_only``: ``q`` differs from the last evaluation's point in
        edge angles only (the elastic energy then evaluates again only what they change; see
        :meth:`knotsim.energies.elastic.ElasticEnergy.evaluate`)."""
        s = self.s
        el = s.elastic
        t0 = time.perf_counter()
        s._frames_at = None
        e_el = el.evaluate(q, self.source, want_jacobian, turned_only)
        s._frames_at = (q.copy(), self.source)  # the elastic frames are those of q (see store_configuration)
        r_full = self._r_full
        r = np.empty_like(r_full)
        merit = e_el + implicit_residual(el.grad, self.f_ext, q, self.q_n, self.v_n, s.model.mass,
                                         s.damping_coef, self.dt, self.static, self.fixed, r_full, r)
        inter_blocks = []
        self.energies = dict(el.energies)
        for inter in s.interactions:
            e, blocks = inter.evaluate(q, self.q_n, self.dt, r_full, want_jacobian)
            self.energies[inter.name] = e
            merit += e
            inter_blocks.append(blocks)
        self.merit = merit
        self.energies["elastic"] = e_el
        s.timers["forces"] += time.perf_counter() - t0
        if s.interactions:
            free_part(r_full, self.fixed, r)
        self.last_full_residual = r_full
        if want_jacobian:
            t1 = time.perf_counter()
            s._assemble(self.diag, inter_blocks, self.fixed, None if self.static else self.dt)
            s.timers["assembly"] += time.perf_counter() - t1
        return r

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        t0 = time.perf_counter()
        out = self.s._solve(rhs)
        self.s.timers["linear_solve"] += time.perf_counter() - t0
        return out

    def residual_norm(self, r: np.ndarray) -> float:
        rp, rt = split_max_abs(r, self.s.model.theta_mask)
        return max(rp / self.s.force_tol, rt / self.s.moment_tol) / self.roundoff_factor

    def residual_norm2(self, r: np.ndarray) -> float:
        """Euclidean norm of ``r`` with forces in ``force_tol`` and moments in ``moment_tol`` units."""
        theta = self.s.model.theta_mask
        fp = float(np.dot(r[~theta], r[~theta])) / self.s.force_tol**2
        ft = float(np.dot(r[theta], r[theta])) / self.s.moment_tol**2
        return math.sqrt(fp + ft) / self.roundoff_factor

    def relax(self, q: np.ndarray, r: np.ndarray, jacobian_current: bool, above: float = 1.0):
        """Spin relaxation (:mod:`knotsim.solver.spin_relaxation`) from the iterate ``q`` with
        residual ``r`` (the interactions' last evaluation at ``q``; ``jacobian_current``: the
        assembled Jacobian is that of ``q``): ``(q', r')``, the iterate with its edge angles solved for
        and its residual (Jacobian assembled at ``q'``), or ``None`` when there is nothing to relax
        (no surface-friction pair, or the residual of their edge angles at most ``above`` moment
        tolerances)."""
        s = self.s
        if not self.relax_enabled:
            return None
        tol = s.moment_tol * self.roundoff_factor
        if not split_max_abs(r, s.model.theta_mask)[1] > tol * max(above, 1.0):
            return None  # no edge angle out of balance by more than that (the check below, cheaply)
        spins = [f for f in (inter.spin_friction() for inter in s.interactions) if f is not None]
        if not spins:
            return None
        spin = joined_spins(spins)
        idx, loc, largest = relaxed_angles(spin, self.free, r)
        if not largest > tol * max(above, 1.0):
            return None
        if not jacobian_current:
            r = self.residual(q, True)
            spin = joined_spins([f for f in (inter.spin_friction() for inter in s.interactions) if f is not None])
            idx, loc, _ = relaxed_angles(spin, self.free, r)
        t0 = time.perf_counter()
        out = relax_spins(s.jacobian_block(idx), r[idx], loc, spin, self.dt, 0.5 * tol)
        s.spin_relaxations += 1
        s.spin_iterations += out.iterations
        s.timers["spin_relaxation"] += time.perf_counter() - t0
        if out.iterations == 0:
            return None
        q_new = q.copy()
        q_new[idx] += out.dtheta
        return q_new, self.residual(q_new, True, turned_only=True)

    def step_norm(self, dq: np.ndarray) -> float:
        sp_, st = split_max_abs(dq, self.s.model.theta_mask)
        return max(sp_ / self.s.step_tol, st / self.s.options.angle_tol)


class Stepper:
    """Backward-Euler stepper for a :class:`~knotsim.rods.Model` with optional interactions."""

    def __init__(self, model, interactions=(), options: SolverOptions | None = None):
        self.model = model
        self.interactions = list(interactions)
        self.options = options or SolverOptions()
        self.options.validate()
        self.elastic = ElasticEnergy(model)
        m = model
        self.damping_coef = np.zeros(m.n_dofs)
        for k in range(3):
            self.damping_coef[m.node_dof + k] = m.damping * m.node_voronoi
        self.gravity_force = np.zeros(m.n_dofs)
        for k in range(3):
            self.gravity_force[m.node_dof + k] = m.mass[m.node_dof + k] * m.gravity[k]
        # tolerances
        scales = []
        lens = []
        for r, rod in enumerate(m.rods):
            e0, e1 = m.rod_edge_start[r], m.rod_edge_start[r + 1]
            lmean = float(np.mean(m.rest_length[e0:e1]))
            scales.append(rod.EI / lmean**2)
            lens.append(lmean)
        st = self.options
        self.force_tol = st.force_tol if st.force_tol is not None else 1e-9 * min(scales)
        lmin = min(lens)
        self.moment_tol = st.moment_tol if st.moment_tol is not None else self.force_tol * lmin
        self.step_tol = st.step_tol if st.step_tol is not None else 1e-6 * lmin
        # assembly structure
        self._elastic_groups = [m.stretch_dofs, m.bend_dofs]
        self._elastic_bw = asm.bandwidth(self._elastic_groups)
        self._banded = BandedSolver()
        self._sparse = SparseSolver(blocks=np.append(model.node_dof, model.n_dofs))
        self._pattern_key = None
        self._bw_key: tuple | None = None
        self._bw = 0
        self._pattern_id = 0
        self._elastic_pattern = None
        self._needs_factor = True
        self._active = None
        self._data = np.zeros(0)
        self._constrained = None  # (pattern id, fixed mask, zero slots, one slots)
        #: ``(interaction pattern key, dt, fixed mask)`` the last assembled Jacobian was built for
        #: (dt None for a static solve)
        self._assembled_for: tuple | None = None
        #: assemblies so far (names the Jacobian a :class:`~knotsim.solver.state.JacobianMemory` holds)
        self._assemblies = 0
        self._diag_cache = None  # (dt, diagonal mass/dt^2 + damping/dt, its largest position entry)
        #: ``(q, frame source)`` of the last elastic evaluation (the frames the elastic object holds)
        self._frames_at = None
        #: Number of matrix factorisations so far.
        self.factorizations = 0
        self.last_solver = ""
        #: Accumulated wall time (s) in force/energy evaluation, Jacobian assembly and linear solves
        #: (``linear_solve``: factorisations, with their symbolic analyses, and solves;
        #: ``factorization``: the factorisations' part of it).
        self.timers = {"forces": 0.0, "assembly": 0.0, "linear_solve": 0.0, "factorization": 0.0,
                       "spin_relaxation": 0.0}
        #: spin relaxations (:meth:`_StepSystem.relax`) and their Newton iterations, over the run
        self.spin_relaxations = 0
        self.spin_iterations = 0

    # -- assembly -------------------------------------------------------------------------
    @property
    def sparse_factorisation(self) -> dict | None:
        """Size of the sparse factorisation of the last pattern analysed (see
        :attr:`knotsim.solver.linear.SparseSolver.statistics`: nonzeros of the matrix and of its
        factor, fill, multiply-adds, supernodes, largest front); ``None`` while the banded solver
        has served every solve."""
        return self._sparse.statistics

    @property
    def sparse_analysis_seconds(self) -> float:
        """Wall seconds the sparse solver spent analysing patterns (ordering, symbolic
        factorisation; part of the ``factorization`` timer)."""
        return self._sparse.analysis_seconds

    def _diagonal(self, dt: float) -> tuple[np.ndarray, float]:
        """``M/dt^2 + D/dt`` ``(n_dofs,)`` (kg/s^2) and its largest position entry, kept while
        ``dt`` (s) is unchanged (callers must not modify the array)."""
        c = self._diag_cache
        if c is None or c[0] != dt:
            m = self.model
            diag = m.mass / dt**2 + self.damping_coef / dt
            c = self._diag_cache = (dt, diag, float(np.max(diag[m.position_mask])))
        return c[1], c[2]

    def _interaction_pattern(self) -> tuple[list[np.ndarray], tuple, int]:
        """Block unknowns of every interaction, a key that changes with them, and the bandwidth.

        Interactions are keyed by their ``pattern_version`` counter (changed whenever their
        ``block_dofs`` change). The bandwidth is computed once per key.
        """
        inter_dofs = [inter.block_dofs() for inter in self.interactions]
        key = tuple((id(inter), inter.pattern_version) for inter in self.interactions)
        if key != self._bw_key:
            self._bw = max([self._elastic_bw] + [asm.bandwidth([d]) for d in inter_dofs])
            self._bw_key = key
        return inter_dofs, key, self._bw

    def _assemble(self, diag, inter_blocks, fixed, dt) -> None:
        m = self.model
        el = self.elastic
        inter_dofs, key, bw = self._interaction_pattern()
        self._assembled_for = (key, dt, fixed)
        self._assemblies += 1
        n = m.n_dofs
        mode = self.options.linear_solver
        if mode == "banded" or (mode == "auto" and bw <= 24):
            kl = ku = max(bw, 1)
            ab = np.zeros((n, 2 * kl + ku + 1)).T  # Fortran order: columns contiguous
            row0 = kl + ku
            asm.banded_add_diagonal(ab, row0, diag)
            asm.banded_add_blocks(ab, row0, m.stretch_dofs, el.stretch_hess)
            asm.banded_add_blocks(ab, row0, m.bend_dofs, el.bend_hess)  # bending + twisting
            for dofs, blocks in zip(inter_dofs, inter_blocks, strict=True):
                if blocks is not None and dofs.size:
                    asm.banded_add_blocks(ab, row0, dofs, blocks)
            asm.banded_constrain(ab, row0, kl, ku, fixed)
            symmetric = all(b is None or d.size == 0 for d, b in zip(inter_dofs, inter_blocks, strict=True))
            self._system = ("banded", ab, kl, ku, symmetric)
            self._needs_factor = True
            self.last_solver = "banded"
            return
        if key != self._pattern_key:
            if self._elastic_pattern is None:
                indptr_e, indices_e = asm.csc_pattern(n, self._elastic_groups)
                self._elastic_pattern = (indptr_e, indices_e, asm.csc_diag_map(indptr_e, indices_e, n),
                                         asm.csc_block_map(indptr_e, indices_e, m.stretch_dofs),
                                         asm.csc_block_map(indptr_e, indices_e, m.bend_dofs))
            indptr_e, indices_e, diag_e, stretch_e, bend_e = self._elastic_pattern
            extra = [d for d in inter_dofs if d.size]
            if extra:
                width = max(d.shape[1] for d in extra)
                if all(d.shape[1] == width for d in extra):
                    stacked = np.concatenate(extra).astype(np.int64)
                    indptr, indices, remap = asm.merge_pattern(n, indptr_e, indices_e, stacked)
                else:  # blocks of different sizes: general (slower) path
                    indptr, indices = asm.csc_pattern(n, self._elastic_groups + extra)
                    remap = None
            else:
                indptr, indices, remap = indptr_e, indices_e, np.arange(indices_e.size)
            self._indptr, self._indices = indptr, indices
            if remap is not None:
                self._diag_slots = remap[diag_e]
                self._stretch_slots = remap[stretch_e]
                self._bend_slots = remap[bend_e]
            else:
                self._diag_slots = asm.csc_diag_map(indptr, indices, n)
                self._stretch_slots = asm.csc_block_map(indptr, indices, m.stretch_dofs)
                self._bend_slots = asm.csc_block_map(indptr, indices, m.bend_dofs)
            self._inter_slots = [asm.csc_block_map(indptr, indices, d) if d.size else None for d in inter_dofs]
            self._pattern_key = key
            self._pattern_id += 1
        if self._data.size != self._indices.size:
            self._data = np.zeros(self._indices.size)
        data = self._data  # refilled in place: the factorisation keeps no reference to it
        asm.csc_fill_elastic(data, self._diag_slots, diag, self._stretch_slots, el.stretch_hess, self._bend_slots,
                             el.bend_hess)  # bending + twisting in bend_hess
        for slots, blocks in zip(self._inter_slots, inter_blocks, strict=True):
            if slots is not None and blocks is not None:
                asm.csc_add_blocks(data, slots, blocks)
        c = self._constrained
        if c is None or c[0] != self._pattern_id or not same_values(c[1], fixed):
            c = self._constrained = (self._pattern_id, fixed.copy(),
                                     *asm.csc_constrained_slots(self._indptr, self._indices, fixed))
        asm.csc_set_slots(data, c[2], c[3])
        self._system = ("sparse", data)
        self._needs_factor = True
        self.last_solver = "sparse"

    def jacobian_block(self, idx: np.ndarray) -> np.ndarray:
        """The last assembled Jacobian's block of the unknowns ``idx`` (sorted, ``(m,)``) as a dense
        ``(m, m)`` array (the units of those unknowns' residuals per unit unknown)."""
        out = np.empty((idx.size, idx.size))
        if self._system[0] == "sparse":
            loc = np.full(self.model.n_dofs, -1, dtype=np.int64)
            loc[idx] = np.arange(idx.size)
            asm.csc_dense_block(self._system[1], self._indptr, self._indices, idx, loc, out)
            return out
        _, ab, kl, ku, _ = self._system
        asm.banded_dense_block(ab, kl + ku, kl, ku, idx, out)
        return out

    def _jacobian_carries_over(self, jac: JacobianMemory | None, dt: float, fixed: np.ndarray) -> bool:
        """Whether a step over ``dt`` (s) with the constrained unknowns ``fixed`` ``(n_dofs,)``
        starts from the Jacobian ``jac`` of the step memory (see
        ``SolverOptions.jacobian_across_steps``): the last step converged in one iteration, and the
        Jacobian (this stepper's factorised one, or one restored from a checkpoint) was assembled for
        this step size, these constraints and the current interaction blocks."""
        if jac is None or jac.last_iterations != 1 or jac.dt != dt or not same_values(jac.fixed, fixed):
            return False
        inter_dofs, key, _ = self._interaction_pattern()
        if jac.token is None:  # restored: compare the blocks themselves (the interactions' keys are new)
            if len(inter_dofs) != len(jac.blocks) or not all(
                    d.shape == b.shape and same_values(d.ravel(), b.ravel())
                    for d, b in zip(inter_dofs, jac.blocks, strict=True)):
                return False
            self._assembled_for = (key, jac.dt, jac.fixed)
            return True
        a = self._assembled_for
        return (jac.token == self._assemblies and self._active is not None and not self._needs_factor
                and a is not None and key == a[0])

    def _use_restored_jacobian(self, jac: JacobianMemory) -> None:
        """Make the Jacobian of a restored step memory the last assembled one (factorised when used)."""
        if jac.banded is not None:
            ab, kl, ku, symmetric = jac.banded
            self._system = ("banded", ab, kl, ku, symmetric)
        elif jac.sparse is not None:
            # the sparse Jacobian brings its own pattern; the next assembly builds its own again
            indptr, indices, data = jac.sparse
            self._indptr, self._indices, self._data = np.array(indptr), np.array(indices), np.array(data)
            self._system = ("sparse", self._data)
            self._pattern_key = None
            self._pattern_id += 1
        self._assembled_for = None
        self._needs_factor = True

    def _jacobian_memory(self, iterations: int) -> JacobianMemory | None:
        """The Jacobian a next step may start from, after an accepted step of ``iterations`` Newton
        iterations: the last assembled one when it is factorised and was assembled for the
        current interaction blocks (references to the stepper's buffers, valid until it assembles
        again), else ``None``."""
        a = self._assembled_for
        if (iterations != 1 or a is None or a[1] is None or not self.options.jacobian_across_steps
                or self._needs_factor):
            return None
        inter_dofs, key, _ = self._interaction_pattern()
        if key != a[0]:
            return None  # the blocks changed since: the next step assembles afresh
        if self._system[0] == "banded":
            _, ab, kl, ku, symmetric = self._system
            return JacobianMemory(iterations, a[1], a[2], tuple(np.asarray(d) for d in inter_dofs), "banded",
                                  banded=(ab, kl, ku, symmetric), token=self._assemblies)
        return JacobianMemory(iterations, a[1], a[2], tuple(np.asarray(d) for d in inter_dofs), "sparse",
                              sparse=(self._indptr, self._indices, self._system[1]), token=self._assemblies)

    def _solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve with the last assembled Jacobian, factorising it first if it is new."""
        if self._needs_factor:
            t0 = time.perf_counter()
            if self._system[0] == "banded":
                _, ab, kl, ku, symmetric = self._system
                self._banded.factorize(ab, kl, ku, symmetric)
                self._active = self._banded
            else:
                self._sparse.factorize(self.model.n_dofs, self._indptr, self._indices, self._system[1],
                                       self._pattern_id)
                self._active = self._sparse
            self._needs_factor = False
            self.factorizations += 1
            self.timers["factorization"] += time.perf_counter() - t0  # (part of linear_solve)
        return self._active.solve(rhs)

    def store_configuration(self, state: State, q: np.ndarray, source: FrameSource) -> None:
        """Set ``state.q`` to ``q`` with its tangents, reference directors and reference twist
        (transported from ``source``; recomputed, since the last evaluation may have been a
        line-search trial at another point; not when the last evaluation was at ``q`` itself)."""
        last = self._frames_at
        if last is None or last[1] is not source or not same_values(last[0], q):
            self.elastic.update_frames(q, source)
            self._frames_at = (q.copy(), source)
        state.q = q
        state.d1 = self.elastic.d1.copy()
        state.tangents = self.elastic.tangents.copy()
        state.ref_twist = self.elastic.ref_twist.copy()

    # -- stepping -------------------------------------------------------------------------
    def _predict(self, state_in: State, dt: float) -> np.ndarray:
        """Initial Newton guess for the step from ``state_in`` over ``dt`` (see ``predictor``)."""
        mode = self.options.predictor
        if mode == "previous":
            return state_in.q.copy()
        v = state_in.v
        h = state_in.memory.step.predictor
        if mode == "acceleration" and h is not None and h.time == state_in.time and h.v_prev.shape == v.shape:
            # constant acceleration: v_{n+1} ~ v_n + (v_n - v_{n-1}) dt / dt_prev
            out = np.empty_like(state_in.q)
            predict_positions(state_in.q, v, h.v_prev, dt / h.dt, dt, out)
            return out
        return state_in.q + dt * v

    def step(self, state_in: State, state_out: State, control, dt: float, *, full_newton: bool = False) -> StepResult:
        """Advance ``state_in`` by ``dt`` (s) into ``state_out`` (may be the same object only if
        the caller keeps a copy for retries). Raises :class:`StepFailure` if Newton fails.

        ``full_newton``: a fresh Jacobian every iteration, the most robust choice, whatever
        ``options.jacobian_reuse`` says (the driver's choice for retries of a failed step). The
        stepper's memory across steps comes with ``state_in.memory.step`` and goes out with
        ``state_out.memory.step`` (:class:`~knotsim.solver.state.StepMemory`; the driver's states
        share one, so that a failed attempt's LU ordering memory stays for the retry)."""
        mem = state_in.memory.step
        order = self._sparse.ordering_memory
        if mem.ordering is not None and mem.ordering is not order:  # restored: analyse as the saved run did
            self._sparse.restore_ordering_memory(*mem.ordering)
        jac = mem.jacobian
        if jac is not None and jac.token is None:
            self._use_restored_jacobian(jac)
        out_mem = state_out.memory.step
        if out_mem is not mem:
            state_out.memory.step = out_mem = StepMemory(mem.predictor, None, mem.ordering)
        out_mem.jacobian = None  # until this step is accepted
        try:
            return self._step(state_in, state_out, control, dt, full_newton, jac, out_mem)
        finally:
            out_mem.ordering = self._sparse.ordering_memory

    def _step(self, state_in: State, state_out: State, control, dt: float, full_newton: bool,
              jac: JacobianMemory | None, out_mem: StepMemory) -> StepResult:
        m = self.model
        t_new = state_in.time + dt
        if control:
            control.begin_step(state_in)  # the boundary conditions take their memory from state_in
        fixed_dofs, fixed_vals, f_bc = control.evaluate(t_new, state_in.q, state_in.time) if control else (
            np.zeros(0, np.int64), np.zeros(0), np.zeros(m.n_dofs))
        fixed = np.zeros(m.n_dofs, np.bool_)
        fixed[fixed_dofs] = True
        for inter in self.interactions:
            inter.begin_step(state_in, dt)
        q0 = self._predict(state_in, dt)
        q0[fixed_dofs] = fixed_vals
        system = _StepSystem(self, state_in, dt, fixed, self.gravity_force + f_bc, static=False)
        reuse = self.options.jacobian_reuse and not full_newton
        carry = reuse and self.options.jacobian_across_steps and self._jacobian_carries_over(jac, dt, fixed)
        try:
            res = newton_solve(system, q0, self.options.max_iterations, self.options.line_search,
                               reuse_jacobian=reuse, jacobian_at_start=not carry,
                               relax_above=self.options.spin_relaxation_above,
                               relax_after=self.options.spin_relaxation_after)
        except (LinearSolveError, ArithmeticError) as exc:  # ArithmeticError: ZeroDivision, overflow, FPE
            raise StepFailure(f"{type(exc).__name__}: {exc}" if isinstance(exc, ArithmeticError) else str(exc)) from exc
        if not res.converged:
            raise StepFailure(f"{res.reason}{largest_residual_at(m, self.interactions, system, res.q)}")
        if not all_finite(res.q):
            raise StepFailure("Newton returned non-finite positions")
        for inter in self.interactions:
            try:
                reason = inter.check(res.q)
            except ArithmeticError as exc:
                raise StepFailure(f"{type(exc).__name__} in the {inter.name} check: {exc}") from exc
            if reason:
                raise StepFailure(reason)
        q = res.q
        v_new = (q - state_in.q) / dt
        energies = dict(system.energies)
        energies["kinetic"] = 0.5 * float(np.dot(m.mass * v_new, v_new))
        energies["gravity"] = -float(np.dot(self.gravity_force, q))
        reactions = control.reactions(t_new, system.last_full_residual) if control else {}
        v_in = state_in.v.copy()
        self.store_configuration(state_out, q, system.source)
        state_out.v = v_new
        out_mem.predictor = PredictorMemory(t_new, v_in, dt)
        out_mem.jacobian = self._jacobian_memory(res.iterations)
        state_out.time = t_new
        stats = {}
        work = constrained_work(system.last_full_residual, fixed, f_bc, q, state_in.q)
        for inter in self.interactions:  # (before stats: a free-spinning obstacle advances its spin there)
            work += inter.supplied_work(state_in.q, q, dt)
        for inter in self.interactions:
            stats.update(inter.stats())
        return StepResult(t_new, dt, res.iterations, res.residual, res.line_search_cuts, energies, reactions,
                          stats, self.last_solver, external_work=float(work),
                          interaction_energies={i.name: energies[i.name] for i in self.interactions})
