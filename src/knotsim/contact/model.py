"""Contact and friction between rod edges as a stepper interaction (IMC + smooth Coulomb friction).

>>> contact = Contact(model, ContactOptions(mu=0.3))
>>> sim = Simulation(model, bcs, SolverOptions(dt=2.5e-3), interactions=[contact])

Candidate pairs (:meth:`Contact.begin_step`) come from the broad phase: every pair of
edges closer than ``h_a + h_b + delta + margin``. The list is kept as a Verlet list: rebuilt when
the nodes' *drift* since the last build exceeds ``margin / 2``, reused otherwise (the Jacobian
pattern then stays the same from step to step). The drift is ``max_i |u_i - c|`` over the node
displacements ``u_i`` since the build, with ``c`` the centre of their bounding box: two nodes
approach each other by at most ``|u_a - u_b| <= 2 drift``, so a pair outside the list cannot come
within the cut-off before the drift exceeds ``margin / 2``, while a common translation of the
rods costs nothing; it is fixed during a Newton solve. During Newton
every candidate pair contributes the IMC energy ``k_c E(Δ)`` (:mod:`knotsim.contact.potential`) and,
when ``μ > 0``, the fully implicit smooth Coulomb friction (:mod:`knotsim.contact.friction`). A
converged step is rejected (:meth:`Contact.check`) when a pair penetrates deeper than
``penetration_limit`` times the smaller radius of the pair, when two edges passed through each other
during the step (a swept test over the straight motion of the step, :mod:`knotsim.contact.swept`,
so a rope cannot jump through another however far it moved), or when the list went stale: once the
drift exceeds ``margin / 2``, an exact broad phase at the solution
(cut-off ``d + delta``) must find no pair outside the list.

Contact stiffness ``k_c`` (N/m): ``"constant"`` uses ``stiffness``. ``"adaptive"`` (default) sets,
before each step, ``k_target = stiffness_scaler * F_max / h_min`` with ``h_min`` the smallest edge
radius of the model (m) and ``F_max`` (N) the largest of

* the largest nodal contact force magnitude at the last accepted step (nodes in contact);
* the force needed to stop the fastest approaching candidate pair within one step
  (mean node mass × approach speed / dt; catches first impacts).

``k_c`` jumps up to ``k_target`` at once and relaxes down towards it with an exponential moving
average (weight ``STIFFNESS_RELAX`` per step); it never drops below ``stiffness_floor`` (default
``stiffness_scaler × (largest node mass × 1 m/s²) / h_min``) nor below ``stiffness`` when that is
given. A step rejected for penetration multiplies ``k_c`` by ``PENETRATION_BOOST`` before the retry
(the policy is :mod:`knotsim.contact.stiffness`, shared with the obstacles).

With ``stiffness_scaler = 500`` the most loaded contact rests with ``k_c E'(Δ) = F_max``, at a gap
``Δ − d ≈ (δ/30) ln(stiffness_scaler δ / (7.5 h_min))`` (≈ 50 µm for ``h = 1.6 mm``,
``δ = 0.5 mm``); the force at ``Δ = d`` is ``≈ 0.046 δ k_c``, well above ``F_max``, so resting
contacts do not penetrate.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from knotsim.contact import diagnostics
from knotsim.contact._model_kernels import gap_summary, live_spin_records
from knotsim.contact.assembly import (
    MEMO_COLUMNS,
    SURFACE_COLUMNS,
    approach_forces,
    contact_evaluate_exact,
    contact_evaluate_exact_surface,
    contact_evaluate_regularized,
    contact_evaluate_regularized_surface,
    nodal_force_summary,
    pair_dofs_from_edges,
)
from knotsim.contact.broadphase import find_candidate_pairs, node_drift
from knotsim.contact.options import ContactOptions, StiffnessMode
from knotsim.contact.spin_minimiser import SpinFriction
from knotsim.contact.stick import SpringMemory, StickHistory
from knotsim.contact.stiffness import AdaptiveStiffness, StiffnessMemory, default_floor
from knotsim.contact.surface_friction import RECORD_SIZE
from knotsim.contact.swept import pass_through, swept_box_pairs
from knotsim.errors import ConfigError
from knotsim.geometry import exclusion
from knotsim.solver._kernels import same_values
from knotsim.solver.state import memory_field

#: Largest IMC tolerance δ accepted, in units of the smallest rod radius.
MAX_DELTA_RADII = 2.0
#: The pair list is rebuilt when the node drift (see the module docstring) exceeds this fraction of
#: ``margin`` since the last build.
REBUILD_FRACTION = 0.5
#: Centre lines of two edges closer than this fraction of the smaller radius have met: a
#: pass-through (:mod:`knotsim.contact.swept`).
CROSSING_TOL = 0.01
#: A candidate pair gets a Jacobian block once its gap ``Δ − d`` falls below ``delta`` plus this
#: fraction of ``margin`` at a Jacobian evaluation (:meth:`Contact.block_dofs`).
BLOCK_BAND_FRACTION = 0.5

__all__ = ["Contact", "ContactMemory", "ContactOptions", "StiffnessMode", "contact_from_config"]


@dataclass
class ContactMemory(SpringMemory, StiffnessMemory):
    """What a :class:`Contact` remembers across steps (run memory, carried by the state and written
    to checkpoints field by field): the stiffness ``k_c`` (N/m), the largest nodal contact force of
    the last accepted step (N) and the largest step seen (s) that drive it, the number of broad-phase
    rebuilds, the Verlet pair list ``pairs (k, 2)``, which of them have Jacobian blocks
    ``block_mask (k,)`` and the positions ``q_build`` the list was built at (``None``: build it); with
    the elastic-stick law, every listed pair's tangential spring displacement ``stick_xi (k, 3)`` (m)
    and whether it slides ``stick_sliding (k,)`` (:mod:`knotsim.contact.stick`)."""

    n_rebuilds: int = 0
    pairs: np.ndarray | None = None
    block_mask: np.ndarray | None = None
    q_build: np.ndarray | None = None


#: an attribute of :class:`Contact` kept in its run memory (:class:`ContactMemory`)
_memory_field = memory_field



@dataclass
class _Eval:
    """Results of the last kernel evaluation (per pair)."""

    q: np.ndarray | None = None
    delta: np.ndarray = field(default_factory=lambda: np.zeros(0))
    fc: np.ndarray = field(default_factory=lambda: np.zeros((0, 12)))
    ff: np.ndarray = field(default_factory=lambda: np.zeros((0, 12)))
    #: (k, SURFACE_COLUMNS) slip and rolling speeds (m/s), friction torques on the two edge angles
    #: (N m) and the pair's record (``spin_out``, columns 4 on) of every pair, with surface friction
    #: (zeros otherwise)
    surface: np.ndarray = field(default_factory=lambda: np.zeros((0, SURFACE_COLUMNS)))


#: No evaluation yet this step (shared: an ``_Eval`` is never changed after it is made).
_NO_EVAL = _Eval()
#: Kernel arguments of the smooth law (no spring history): ``pair_xi0``, ``pair_mu_limit``, ``stick_distance``.
_SMOOTH_LAW = (np.zeros((0, 3)), np.zeros(0), 0.0)


def _pair_memo(rows: int) -> tuple[np.ndarray, ...]:
    """Empty memo arrays of the contact loop for ``rows`` blocks (``pair_memo`` … ``pair_memo_beta`` of
    :func:`~knotsim.contact.assembly.contact_evaluate`; a cache of the pairs' distance and potential
    from the last Jacobian evaluation, not run state: it never changes a result)."""
    return (np.zeros((rows, MEMO_COLUMNS)), np.zeros((rows, 12)), np.zeros((rows, 12)), np.zeros((rows, 12, 12)),
            np.zeros((rows, 2, 12)))


class Contact:
    """Edge-edge contact (IMC) and friction of all rods of a model; a stepper ``Interaction``.

    Attributes
    ----------
    name : ``"contact"``.
    pairs : (k, 2) int64, candidate edge pairs of the current step.
    pair_dofs : (k, 12) int64, their node coordinates in ``q``.
    k_c : current contact stiffness (N/m).
    timers : accumulated wall time (s) in ``"broad_phase"`` and ``"narrow_phase"`` (all evaluations).
    """

    name = "contact"

    k_c = _memory_field("k_c", "current contact stiffness (N/m)")
    n_rebuilds = _memory_field("n_rebuilds", "number of broad-phase rebuilds of the pair list")
    pairs = _memory_field("pairs", "(k, 2) int64, candidate edge pairs of the current step")
    _fmax_accepted = _memory_field("fmax_accepted", "N")
    _dt_ref = _memory_field("dt_ref", "s")
    _block_mask = _memory_field("block_mask", "(k,) bool")
    _q_build = _memory_field("q_build", "positions the pair list was built at, or None")

    def __init__(self, model, options: ContactOptions | None = None):
        #: the run memory in use (see :meth:`begin_step`)
        self.memory = ContactMemory()
        self.model = model
        self.options = options or ContactOptions()
        self.options.validate()
        s = self.options
        m = model
        self._mu_table = self._mu_matrix(s.mu)
        #: friction at the rods' surfaces: pair blocks carry the two edge angles (14 unknowns); a
        #: model without friction needs no angles (both laws are then the same)
        self.surface_friction = s.friction_model == "surface" and bool(np.any(self._mu_table > 0.0))
        self._block_width = 14 if self.surface_friction else 12
        #: the elastic-stick law (``stick_distance`` set): per-pair spring history in the run memory
        self.stick = (StickHistory(model, s.stick_distance, self._mu_table,
                                   self._mu_matrix(s.mu_static) if s.mu_static is not None else self._mu_table)
                      if self.surface_friction and s.stick_distance is not None else None)
        self.h_min = float(np.min(m.edge_radius)) if m.n_edges else 1.0
        if m.n_edges and s.delta > MAX_DELTA_RADII * self.h_min:
            raise ConfigError("contact.delta",
                              f"must be at most {MAX_DELTA_RADII:g} x the smallest rod radius ({self.h_min:g} m), got "
                              f"{s.delta!r}: the IMC tolerance is the gap over which the contact force builds up, a "
                              f"fraction of the radius (default 5e-4 m); a larger one puts every pair of edges in "
                              f"contact")
        node_mass = m.mass[m.node_dof] if m.n_nodes else np.zeros(1)
        if s.stiffness_floor is not None:
            floor = s.stiffness_floor
        else:
            floor = default_floor(s.stiffness_scaler, float(np.max(node_mass)), self.h_min)
        if s.stiffness is not None:
            floor = max(floor, s.stiffness) if s.stiffness_mode == "adaptive" else s.stiffness
        self.k_floor = floor
        #: the adaptive stiffness policy (:mod:`knotsim.contact.stiffness`)
        self._stiffness = AdaptiveStiffness(s.stiffness_scaler, self.h_min, floor)
        self.k_c = (s.stiffness if s.stiffness_mode == "constant"
                    else max(floor, s.initial_stiffness) if s.initial_stiffness is not None else floor)
        self._fmax_accepted = 0.0
        self._fmax_pending = 0.0
        self.pairs = np.zeros((0, 2), np.int64)
        self.pair_dofs = np.zeros((0, 12), np.int64)
        self.pair_theta = np.zeros((0, 2), np.int64)
        self.pair_h = np.zeros((0, 2))
        self._dt_ref = 0.0
        # Same-rod pairs closer than 1.5 contact distances along the rod never count as contact
        # (knotsim.geometry.exclusion): on a finely meshed rod, edges i and i + 3 of a straight rod
        # are closer than 2h (the broad phase already skips |i - j| < 3).
        self._rod_min_gap = np.array([
            exclusion.min_index_gap(float(np.mean(
                model.rest_length[model.rod_edge_start[r]:model.rod_edge_start[r + 1]])), 2.0 * rod.radius)
            for r, rod in enumerate(model.rods)], dtype=np.int64)
        self.pair_d = np.zeros(0)
        self.pair_mu = np.zeros(0)
        self.pair_mu_static = np.zeros(0)
        self.pair_hmin = np.zeros(0)
        self._blocks = np.zeros((0, self._block_width, self._block_width))
        self._memo = _pair_memo(0)
        self._block_mask = np.zeros(0, bool)
        self._block_idx = np.zeros(0, np.int64)
        self._block_pair_dofs = np.zeros((0, self._block_width), np.int64)
        self._pair_keys = np.zeros(0, np.int64)
        self._q_build = None
        self._node_xyz = m.node_dof[:, None] + np.arange(3)[None, :]
        self.n_rebuilds = 0
        #: incremented whenever :meth:`block_dofs` changes (the stepper re-analyses the pattern)
        self.pattern_version = 0
        self._q_prev = None
        self._dt = 1.0
        #: ``(q, q_build, drift)`` of the last :meth:`_max_displacement` (reused at the same q)
        self._drift_at: tuple | None = None
        #: ``(key, tol, reach)`` of the swept test of the listed pairs (:meth:`check`)
        self._swept_limits = None
        #: ``(pair_dofs, q, (k, 4) distances at q)`` of the last swept test that found no crossing
        self._swept_end: tuple | None = None
        self._last = _NO_EVAL
        self._stats: dict = {}
        self.timers = {"broad_phase": 0.0, "narrow_phase": 0.0}

    # ------------------------------------------------------------------ setup
    def _mu_matrix(self, mu) -> np.ndarray:
        m = self.model
        nr = m.n_rods
        if not isinstance(mu, dict):
            return np.full((nr, nr), float(mu))
        table = np.full((nr, nr), float(mu.get("default", 0.0)))
        for key, val in mu.items():
            if key == "default":
                continue
            try:
                a = m.rod_index(key[0])
                b = m.rod_index(key[1])
            except ConfigError as exc:
                raise ConfigError("contact.mu", f"unknown rod in pair {key!r}: {exc}") from None
            table[a, b] = table[b, a] = float(val)
        return table

    # ------------------------------------------------------------------ Interaction protocol
    def _max_displacement(self, q) -> float:
        """Drift (m) of the nodes of ``q`` since the last broad phase: ``max_i |u_i - c|`` with
        ``u_i`` the node displacements and ``c`` the centre of their bounding box (a common
        translation does not count; see the module docstring)."""
        m = self.model
        if self._q_build is None or not m.n_nodes:
            return math.inf
        # the next step's begin_step asks again at the q the last check was given: reuse the drift
        # if nothing changed (the same arrays holding the same numbers)
        last = self._drift_at
        if last is not None and last[1] is self._q_build and last[0].shape == q.shape and same_values(last[0], q):
            return last[2]
        drift = node_drift(q, self._q_build, m.node_dof)
        self._drift_at = (q.copy(), self._q_build, drift)
        return drift

    def _broad_phase(self, q, extra: float) -> np.ndarray:
        m = self.model
        pairs = find_candidate_pairs(q, m.edge_dofs, m.edge_rod, m.edge_local, m.rod_n_edges, m.rod_closed,
                                     m.edge_radius, extra)
        if not self.options.self_contact and pairs.shape[0]:
            pairs = pairs[m.edge_rod[pairs[:, 0]] != m.edge_rod[pairs[:, 1]]]
        elif pairs.shape[0] and np.any(self._rod_min_gap > exclusion.MIN_INDEX_GAP):
            pairs = pairs[self._self_pair_allowed(pairs)]
        return np.ascontiguousarray(pairs, dtype=np.int64)

    def _self_pair_allowed(self, pairs) -> np.ndarray:
        """Mask of pairs not excluded by the per-rod minimum index distance (finely meshed rods)."""
        m = self.model
        return exclusion.pairs_allowed(pairs, m.edge_rod, m.edge_local, m.rod_n_edges, m.rod_closed,
                                       self._rod_min_gap)

    def begin_step(self, state_in, dt: float) -> None:
        """Candidate pairs (broad phase, cut-off ``h_a + h_b + delta + margin``) and k_c for a step.

        The pair list is a Verlet list: it is rebuilt at ``state_in.q`` when some node has moved more
        than ``REBUILD_FRACTION × margin`` since the last build (or on the first step), and reused
        otherwise, so the Jacobian pattern changes only when the list is rebuilt.
        :meth:`check` verifies at the end of every step that no pair outside the list came within
        ``d + delta``.
        """
        m = self.model
        s = self.options
        mem = state_in.memory.interactions.get(self.name)
        if mem is None:
            state_in.memory.interactions[self.name] = self.memory
        elif mem is not self.memory:
            self.use_memory(mem)
        t0 = time.perf_counter()
        q = state_in.q
        if self._max_displacement(q) > REBUILD_FRACTION * s.margin:
            self._set_pairs(self._broad_phase(q, s.delta + s.margin))
            self.pattern_version += 1
            self._q_build = q.copy()
            self.n_rebuilds += 1
        self._q_prev = q
        self._dt = dt
        self._last = _NO_EVAL
        if self.stick is not None:
            self.stick.inherit(self.memory, self.pairs)
        self.timers["broad_phase"] += time.perf_counter() - t0
        if s.stiffness_mode == "adaptive":
            def impact_force(dt_ref: float) -> float:
                t1 = time.perf_counter()
                f = (approach_forces(q, state_in.v, dt_ref, self.pair_dofs, self.pair_d, s.delta, m.mass)
                     if self.pair_dofs.shape[0] else 0.0)
                self.timers["narrow_phase"] += time.perf_counter() - t1
                return f

            self._stiffness.update(self.memory, dt, impact_force)

    def _set_pairs(self, pairs) -> None:
        m = self.model
        if self.stick is not None:
            self.stick.remap(self.memory, self.pairs, pairs)
        self.pairs = pairs
        self.pair_dofs = pair_dofs_from_edges(pairs, m.edge_dofs)
        ra = m.edge_radius[pairs[:, 0]]
        rb = m.edge_radius[pairs[:, 1]]
        self.pair_d = ra + rb
        self.pair_hmin = np.minimum(ra, rb)
        self.pair_theta = np.ascontiguousarray(m.edge_theta_dof[pairs].reshape(-1, 2), dtype=np.int64)
        self.pair_h = np.ascontiguousarray(np.stack([ra, rb], axis=1).reshape(-1, 2))
        la = m.rest_length[pairs[:, 0]]
        lb = m.rest_length[pairs[:, 1]]
        self.pair_eta = 8.0 * self.pair_d * self.options.parallel_smoothing / (la * la + lb * lb)
        self.pair_mu = np.ascontiguousarray(self._mu_table[m.edge_rod[pairs[:, 0]], m.edge_rod[pairs[:, 1]]])
        self.pair_mu_static = (np.ascontiguousarray(self.stick.mu_static[m.edge_rod[pairs[:, 0]], m.edge_rod[pairs[:, 1]]])
                               if self.stick is not None else self.pair_mu)
        self._pair_keys = pairs[:, 0] * m.n_edges + pairs[:, 1]
        self._set_blocks(np.zeros(pairs.shape[0], bool))

    def _set_blocks(self, mask) -> None:
        """Give Jacobian blocks to the candidate pairs of ``mask`` ``(k,)`` bool (a new pattern)."""
        self._block_mask = mask
        self._block_idx = np.flatnonzero(mask)
        dofs = self.pair_dofs[self._block_idx]
        if self.surface_friction:
            dofs = np.concatenate([dofs, self.pair_theta[self._block_idx]], axis=1)
        self._block_pair_dofs = np.ascontiguousarray(dofs)
        # the kernel writes the block of pair k into self._blocks[slot[k]] (slot -1: no block)
        self._block_slot = np.full(mask.shape[0], -1, np.int64)
        self._block_slot[self._block_idx] = np.arange(self._block_idx.shape[0])
        if self._blocks.shape[0] != self._block_idx.shape[0]:
            self._blocks = np.zeros((self._block_idx.shape[0], self._block_width, self._block_width))
        self._memo = _pair_memo(self._block_idx.shape[0] if self.surface_friction else 0)
        self.pattern_version += 1

    def block_dofs(self) -> np.ndarray:
        """``(b, w)`` unknowns (``w = 12``: the pair's node coordinates; ``w = 14`` with surface
        friction: then the angles of its two edges) of the Jacobian blocks: the candidate pairs that have been within
        ``d + delta + BLOCK_BAND_FRACTION × margin`` at a Jacobian evaluation since the list was built.

        The block of a pair is exactly zero while its gap ``Δ − d`` is at least ``delta`` (no energy,
        no friction), so the Jacobian is the same as with a block for every candidate pair: whenever
        :meth:`evaluate` finds a pair in range without a block it gives blocks to every pair within
        the band and changes the pattern before the matrix is assembled. Pairs keep their block until
        the list is rebuilt, so the pattern changes only at rebuilds and when a pair comes into the
        band. The Verlet list stays the broad phase (swept checks, stiffness, rebuilds); only the
        matrix and its factorisation shrink, from the candidates (which grow like the square of the
        nodes per metre at a fixed margin) to the contacts (see docs/performance.md)."""
        return self._block_pair_dofs

    def evaluate(self, q, q_prev, dt, residual, want_jacobian):
        """Add ``k_c ∇E − F_friction`` (N) to ``residual``; return ``(k_c ΣE (J), blocks (b, w, w) | None)``
        (``w`` as in :meth:`block_dofs`)."""
        t0 = time.perf_counter()
        k = self.pair_dofs.shape[0]
        ev = _Eval(q.copy(), np.empty(k), np.empty((k, 12)), np.empty((k, 12)), np.zeros((k, SURFACE_COLUMNS)))
        # one kernel per distance and friction law: a run compiles only the one it uses (pair_eta > 0
        # iff smoothing > 0)
        if self.options.parallel_smoothing > 0.0:
            kernel = contact_evaluate_regularized_surface if self.surface_friction else contact_evaluate_regularized
        else:
            kernel = contact_evaluate_exact_surface if self.surface_friction else contact_evaluate_exact
        args = (self.pair_dofs, self.pair_d, self.pair_mu, self.options.delta, self.options.nu, self.k_c)
        tail = (self.pair_eta, self.pair_theta, self.pair_h, ev.surface,
                *(self.stick.kernel_args(self.memory, self.pair_mu, self.pair_mu_static) if self.stick is not None
                  else _SMOOTH_LAW))
        e, missing = kernel(q, q_prev, dt, *args, residual, bool(want_jacobian), self._blocks, self._block_slot,
                            ev.delta, ev.fc, ev.ff, *tail, *self._memo)
        self._last = ev
        self._q_prev = q_prev
        self._dt = dt
        blocks = None
        if want_jacobian:
            if missing:  # pairs in range without a block: new blocks (a new pattern), evaluated again
                live = ev.delta < self.pair_d + self.options.delta
                band = self.options.delta + BLOCK_BAND_FRACTION * self.options.margin
                self._set_blocks(self._block_mask | live | (ev.delta < self.pair_d + band))
                kernel(q, q_prev, dt, *args, np.zeros_like(residual), True, self._blocks, self._block_slot,
                       ev.delta, ev.fc, ev.ff, *tail, *self._memo)
            blocks = self._blocks  # the blocks of block_dofs(), in its order (valid until the next call)
        self.timers["narrow_phase"] += time.perf_counter() - t0
        return float(e), blocks

    @property
    def has_spin_friction(self) -> bool:
        """Whether :meth:`spin_friction` can return friction (surface friction, some μ > 0)."""
        return self.surface_friction

    def spin_friction(self) -> SpinFriction | None:
        """Surface friction of the pairs in range at the last evaluation, as a function of the edge
        angles alone (positions held): for the stepper's spin relaxation. ``None`` with centre-line
        friction or when no pair in range carries friction."""
        ev = self._last
        if not self.surface_friction or ev.q is None or ev.surface.shape[0] == 0:
            return None
        theta_dofs, record = live_spin_records(ev.surface, self.pair_theta, 4, RECORD_SIZE)
        if record.shape[0] == 0:
            return None
        return SpinFriction(theta_dofs, record, self.options.nu)

    def _evaluated_at(self, q) -> _Eval:
        ev = self._last
        if ev.q is None or ev.q.shape != q.shape or not same_values(ev.q, q):
            scratch = np.zeros(q.shape[0])
            self.evaluate(q, self._q_prev if self._q_prev is not None else q, self._dt, scratch, False)
            ev = self._last
        return ev

    def check(self, q) -> str | None:
        """Reject ``q`` if two edges passed through each other during the step, if a pair penetrates
        deeper than the limit, or if the broad phase went stale.

        Pass-through (:mod:`knotsim.contact.swept`): along the straight motion from the start of
        the step to ``q`` the centre lines of two edges met (came within ``CROSSING_TOL`` times the
        smaller radius), or two edges within the list's cut-off (``d + delta + margin``) at the
        start or the end of the step changed sides. The listed pairs are always tested; the other
        pairs only when the drift exceeds ``margin / 2`` (below it no pair outside the list comes
        within ``d + delta`` anywhere along the motion): then a broad phase over the swept boxes of
        all edges finds the pairs to test, however far they moved."""
        s = self.options
        m = self.model
        k = self.pair_dofs.shape[0]
        dmax = self._max_displacement(q)
        q_prev = self._q_prev if self._q_prev is not None and self._q_prev.shape == q.shape else None
        if dmax > 0.5 * s.margin and q_prev is not None:
            t0 = time.perf_counter()
            msg = self._swept_outside_list(q_prev, q)
            self.timers["broad_phase"] += time.perf_counter() - t0
            if msg is not None:
                self._q_build = None  # the retry starts from a fresh list
                return msg
        if dmax > 0.5 * s.margin:
            # a pair outside the list may have come into range: exact test at q
            t0 = time.perf_counter()
            near = self._broad_phase(q, s.delta)
            self.timers["broad_phase"] += time.perf_counter() - t0
            missing = ~np.isin(near[:, 0] * m.n_edges + near[:, 1], self._pair_keys)
            if np.any(missing):
                self._q_build = None  # force a rebuild for the retry
                a, b = near[np.argmax(missing)]
                return (f"contact broad phase stale: edges {a} and {b} came within contact range after nodes "
                        f"drifted {dmax:.3g} m since the pair list was built (margin {s.margin:.3g} m)")
        ev = self._evaluated_at(q)
        worst, ratio = self._compute_stats(ev)
        if k:
            if ratio > s.penetration_limit:
                if s.stiffness_mode == "adaptive":
                    self._stiffness.penetrated(self.memory)
                a, b = self.pairs[worst]
                return (f"contact penetration {ratio:.3g} x radius between edges {a} and {b} exceeds "
                        f"penetration_limit {s.penetration_limit}")
            if q_prev is not None:
                return self._pass_through_listed(q_prev, q)
        return None

    def _pass_through_listed(self, q_prev, q) -> str | None:
        """Swept test of the listed pairs from ``q_prev`` to ``q``. The pairs' distances at ``q``
        are kept: when the next step starts from ``q`` with the same list they are its start
        distances (:func:`~knotsim.contact.swept.first_crossing_chained`, the same numbers)."""
        tol, reach = self._swept_tolerances()
        last = self._swept_end
        self._swept_end = None
        start = None
        if last is not None and last[0] is self.pair_dofs and last[1].shape == q_prev.shape \
                and same_values(last[1], q_prev):
            start = last[2]
        end = np.empty((self.pair_dofs.shape[0], 4))
        msg = pass_through(q_prev, q, self.pairs, self.pair_dofs, tol, reach, start, end)
        if msg is None:
            self._swept_end = (self.pair_dofs, q.copy(), end)
        return msg

    def _swept_tolerances(self) -> tuple[np.ndarray, np.ndarray]:
        """``(tol, reach)`` (k,) m of the swept test of the listed pairs: ``CROSSING_TOL`` times the
        smaller radius and the list's cut-off ``d + delta + margin`` (kept while the list and the
        settings stay)."""
        s = self.options
        key = (self.pair_d, s.delta, s.margin)
        c = self._swept_limits
        if c is None or c[0][0] is not self.pair_d or c[0][1:] != key[1:]:
            c = self._swept_limits = (key, CROSSING_TOL * self.pair_hmin, self.pair_d + s.delta + s.margin)
        return c[1], c[2]

    def _swept_outside_list(self, q_prev, q) -> str | None:
        """Pass-through test of the pairs outside the list whose swept boxes (inflated by the
        radii) overlap during the step from ``q_prev`` to ``q``; the message, or ``None``."""
        m = self.model
        pairs = swept_box_pairs(q_prev, q, m.edge_dofs, m.edge_rod, m.edge_local, m.rod_n_edges, m.rod_closed,
                                m.edge_radius)
        if not pairs.shape[0]:
            return None
        if not self.options.self_contact:
            pairs = pairs[m.edge_rod[pairs[:, 0]] != m.edge_rod[pairs[:, 1]]]
        elif np.any(self._rod_min_gap > exclusion.MIN_INDEX_GAP):
            pairs = pairs[self._self_pair_allowed(pairs)]
        if self._pair_keys.size and pairs.shape[0]:
            pairs = pairs[~np.isin(pairs[:, 0] * m.n_edges + pairs[:, 1], self._pair_keys)]
        if not pairs.shape[0]:
            return None
        hmin = np.minimum(m.edge_radius[pairs[:, 0]], m.edge_radius[pairs[:, 1]])
        return pass_through(q_prev, q, pairs, pair_dofs_from_edges(pairs, m.edge_dofs), CROSSING_TOL * hmin)

    def check_start(self, q) -> None:
        """Raise :class:`~knotsim.errors.GeometryError` when rods overlap at ``q`` (see
        :func:`knotsim.contact.diagnostics.check_start`)."""
        diagnostics.check_start(self, q)

    def use_memory(self, mem: ContactMemory) -> None:
        """Continue from the run memory ``mem`` (restored from a checkpoint): its stiffness, pair list
        (with the blocks it had; without a mask, blocks come back at the first evaluation) and the
        positions the list was built at."""
        self.memory = mem
        pairs = mem.pairs if mem.pairs is not None else np.zeros((0, 2), np.int64)
        mask = mem.block_mask
        self._set_pairs(np.ascontiguousarray(pairs, dtype=np.int64).reshape(-1, 2))
        if mask is not None and np.size(mask) == self.pairs.shape[0]:
            self._set_blocks(np.asarray(mask, bool).reshape(-1))
        if mem.q_build is not None:
            mem.q_build = np.array(mem.q_build, float)

    def supplied_work(self, q_prev, q, dt) -> float:
        """0: rope-rope contact has no moving source."""
        return 0.0

    def untracked_sources(self) -> list[str]:
        """None: the work of a changed ``k_c`` is counted (see :mod:`knotsim.solver.validity`)."""
        return []

    def describe_near(self, q, node: int) -> str:
        """Text naming a candidate pair that has ``node`` (global node number) on one of its edges
        (see :func:`knotsim.contact.diagnostics.describe_near`); "" if none."""
        return diagnostics.describe_near(self, q, node)

    def _compute_stats(self, ev: _Eval) -> tuple[int, float]:
        """The numbers of :meth:`stats` for the evaluation ``ev``; returns the pair of largest
        penetration ratio ``(d - Δ)/h`` and that ratio (``(0, -inf)`` without pairs)."""
        m = self.model
        k = self.pair_dofs.shape[0]
        fmax = 0.0
        worst, ratio = 0, -math.inf
        if k:
            n_contacts, min_gap, worst, ratio = gap_summary(ev.delta, self.pair_d, self.pair_hmin, self.options.delta)
            pen = float(max(0.0, ratio))
            fmax, fc_tot, ff_tot = nodal_force_summary(self.pair_dofs, ev.fc, ev.ff, m.node_dof, m.n_dofs)
        else:
            n_contacts, min_gap, pen, fc_tot, ff_tot = 0, math.nan, 0.0, 0.0, 0.0
        self._fmax_pending = fmax
        self._ev_pending = (self.pair_dofs, ev.fc, ev.ff, ev.surface)
        self._stats = {"n_contacts": n_contacts, "min_gap": min_gap, "max_penetration_ratio": pen,
                       "contact_force_total": fc_tot, "friction_force_total": ff_tot, "k_c": float(self.k_c)}
        return worst, ratio

    def stats(self) -> dict:
        """Numbers of the last accepted step: ``n_contacts`` (pairs with ``Δ < d + δ``), ``min_gap``
        (m, ``min Δ − d``; NaN without candidate pairs), ``max_penetration_ratio`` (``max(d − Δ)/h``,
        ≥ 0), ``contact_force_total`` and ``friction_force_total`` (N, half the sum of nodal force
        magnitudes), ``k_c`` (N/m)."""
        # the stepper asks for stats only for an accepted step: its contact force drives k_c
        self._stiffness.accepted(self.memory, self._fmax_pending)
        self._ev_accepted = self._ev_pending
        if self.stick is not None:
            self.stick.accept(self.memory, self._ev_pending[3], self._dt)
            self._stats.update(self.stick.stats(self.memory, self._ev_pending[3]))
        return dict(self._stats)

    @property
    def friction_model(self) -> str:
        """The friction law (``"surface"`` or ``"centreline"``)."""
        return str(self.options.friction_model)

    @property
    def node_field_names(self) -> tuple[str, ...]:
        """The contact and friction force per node, and with surface friction the slip and rolling
        speeds (:meth:`node_forces`, :meth:`node_slip`)."""
        return ("contact_force", "friction_force", *(("slip_speed", "rolling_speed") if self.surface_friction else ()))

    def node_fields(self) -> dict[str, np.ndarray]:
        out = dict(zip(("contact_force", "friction_force"), self.node_forces(), strict=True))
        if self.surface_friction:
            out["slip_speed"], out["rolling_speed"] = self.node_slip()
        return out

    def node_forces(self) -> tuple[np.ndarray, np.ndarray]:
        """``(contact, friction)``: ``(n_nodes,)`` magnitudes (N) of the net contact (normal) and
        friction force on every global node at the last accepted step (the pairs' nodal forces
        summed per node); NaN before the first accepted step."""
        m = self.model
        last = getattr(self, "_ev_accepted", None)
        if last is None:
            return np.full(m.n_nodes, np.nan), np.full(m.n_nodes, np.nan)
        dofs, fc, ff, _ = last
        xyz = m.node_dof[:, None] + np.arange(3)
        contact, friction = (np.linalg.norm(np.bincount(dofs.ravel(), weights=f.ravel(), minlength=m.n_dofs)[xyz],
                                            axis=1) for f in (fc, ff))
        return contact, friction

    def node_slip(self) -> tuple[np.ndarray, np.ndarray]:
        """``(slip, rolling)``: ``(n_nodes,)`` slip speed and rolling speed (m/s, see
        :func:`~knotsim.contact.surface_friction.surface_friction_pair`) at every node at the last
        accepted step, from the pair in contact with the largest normal force among those on the
        node's edges; NaN at nodes without a contact, everywhere without surface friction, and
        before the first accepted step. Where strands roll the slip is near zero and the rolling
        speed is not; where they slide it is the other way round."""
        m = self.model
        slip = np.full(m.n_nodes, np.nan)
        rolling = np.full(m.n_nodes, np.nan)
        last = getattr(self, "_ev_accepted", None)
        if last is None or not self.surface_friction:
            return slip, rolling
        dofs, fc, _, surface = last
        force = np.linalg.norm(fc[:, 0:3] + fc[:, 3:6], axis=1)
        live = np.flatnonzero(force > 0.0)
        live = live[np.argsort(force[live], kind="stable")]  # the largest force is assigned last
        nodes = np.searchsorted(m.node_dof, dofs[live][:, [0, 3, 6, 9]])
        for c in range(4):  # the four nodes of the pairs (not a loop over pairs)
            slip[nodes[:, c]] = surface[live, 0]
            rolling[nodes[:, c]] = surface[live, 1]
        return slip, rolling



def contact_from_config(model, table: dict) -> list:
    """Interactions described by a ``[contact]`` configuration table
    (:meth:`ContactOptions.from_table` checks it). Returns ``[Contact]``."""
    return [Contact(model, ContactOptions.from_table(table))]
