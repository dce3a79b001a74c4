"""Quasi-static equilibrium: the Newton machinery of the stepper without inertia.

Loads (gravity and boundary-condition forces) are applied in increments of a load factor from 0 to
1 (continuation); an increment that fails is halved. Prescribed motions are evaluated at
``time`` (default: the state's time).

Stability: Newton finds equilibria, stable or not (a column past its buckling load stays straight).
The converged state's Hessian on the free unknowns is checked: its lowest eigenvalue after Jacobi
scaling, ``λ_min`` of ``D K D`` with ``D = diag(|K_ii|)^(-1/2)`` (dimensionless; by Sylvester's law of
inertia its sign is that of ``K``'s lowest eigenvalue), is reported as
``StaticResult.lowest_eigenvalue``; ``stable`` is ``λ_min > -STABILITY_TOL``. Interaction blocks
(contact, friction) are symmetrised first. Dense ``eigh`` up to ``DENSE_LIMIT`` free unknowns; beyond,
Lanczos in shift-invert mode (``scipy.sparse.linalg.eigsh``, the three eigenvalues nearest
``-STABILITY_TOL``): near a bifurcation, where the lowest eigenvalue crosses zero, it is among them,
but an eigenvalue far below zero with a smaller positive one beside it could be missed. ``on_unstable`` says what happens to an
unstable equilibrium: ``"warn"`` (an :class:`UnstableEquilibriumWarning`, the state is returned with
``stable = False``), ``"raise"`` (:class:`~knotsim.errors.SimulationError` with the state attached), or
``"perturb"`` (push the state along the unstable mode and relax it by pseudo-transient continuation
until a stable equilibrium is found: the buckled branch).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from knotsim.errors import ConfigError, KnotsimWarning, SimulationError
from knotsim.solver.linear import LinearSolveError
from knotsim.solver.newton import newton_solve
from knotsim.solver.options import SolverOptions
from knotsim.solver.state import State, initial_state
from knotsim.solver.stepper import Stepper, _StepSystem


@dataclass
class StaticResult:
    """Equilibrium state with its Newton statistics and the reactions of prescribed groups."""

    state: State
    load_increments: int
    iterations: int
    residual: float
    energies: dict
    reactions: dict
    #: lowest eigenvalue of the Jacobi-scaled Hessian on the free unknowns (``None``: not checked)
    lowest_eigenvalue: float | None = None
    #: whether the equilibrium is stable (``None``: not checked)
    stable: bool | None = None
    #: how many times ``on_unstable="perturb"`` pushed the state off an unstable equilibrium
    perturbations: int = 0


class UnstableEquilibriumWarning(KnotsimWarning, RuntimeWarning):
    """The static solve converged to an unstable equilibrium (a negative Hessian eigenvalue)."""


#: An equilibrium is unstable when the lowest Jacobi-scaled Hessian eigenvalue is below ``-STABILITY_TOL``.
STABILITY_TOL = 1e-9
#: Up to this many free unknowns the eigenvalue is computed densely.
DENSE_LIMIT = 600


def solve_static(model, control=None, state: State | None = None, options: SolverOptions | None = None,
                 interactions=(), load_steps: int = 10, min_increment: float = 1e-4,
                 time: float | None = None, relaxation: bool = True, check_stability: bool = True,
                 on_unstable: str = "warn", max_perturbations: int = 3) -> StaticResult:
    """Find the equilibrium ``grad E(q) = F_ext`` with prescribed unknowns held.

    ``load_steps`` is the initial number of equal load increments. When Newton fails for an
    increment and ``relaxation`` is on, the increment is first retried by pseudo-transient
    continuation (proximal steps ``M (q - q_k)/tau^2 + grad E(q) = F`` with a growing pseudo time
    step ``tau``, which regularises an indefinite Hessian far from equilibrium). Raises
    :class:`~knotsim.errors.SimulationError` (with the last equilibrium reached) if an increment
    smaller than ``min_increment`` fails.

    With ``check_stability`` the converged state's stability is checked (module doc);
    ``on_unstable`` is ``"warn"``, ``"raise"`` or ``"perturb"`` (at most ``max_perturbations``
    pushes along the unstable mode).
    """
    if on_unstable not in ("warn", "raise", "perturb"):
        raise ConfigError("on_unstable", f"must be 'warn', 'raise' or 'perturb', got {on_unstable!r}")
    stepper = Stepper(model, interactions, options or SolverOptions())
    state = (state or initial_state(model)).copy()
    t = state.time if time is None else float(time)
    n = model.n_dofs
    if control is not None:
        fixed_dofs, fixed_vals, f_bc = control.evaluate(t, state.q, state.time)
    else:
        fixed_dofs, fixed_vals, f_bc = np.zeros(0, np.int64), np.zeros(0), np.zeros(n)
    fixed = np.zeros(n, np.bool_)
    fixed[fixed_dofs] = True
    load_total = stepper.gravity_force + f_bc
    lam = 0.0
    dlam = 1.0 / max(1, int(load_steps))
    increments = 0
    iterations = 0
    system = None
    q_fixed_start = state.q[fixed_dofs].copy()
    while lam < 1.0 - 1e-12:
        target = min(1.0, lam + dlam)
        q0 = state.q.copy()
        q0[fixed_dofs] = q_fixed_start + target * (fixed_vals - q_fixed_start)
        for inter in stepper.interactions:
            inter.begin_step(state, 1.0)
        system = _StepSystem(stepper, state, 1.0, fixed, target * load_total, static=True)
        try:
            res = newton_solve(system, q0, stepper.options.max_iterations, stepper.options.line_search)
            ok = res.converged
        except LinearSolveError:
            ok = False
        if not ok and relaxation:
            relaxed = _pseudo_transient(stepper, state, fixed, target * load_total, q0)
            if relaxed is not None:
                system, res = relaxed
                ok = True
        if not ok:
            dlam *= 0.5
            if dlam < min_increment:
                raise SimulationError(
                    f"static solve failed at load factor {lam:.4g}: increment {dlam:.2g} below min_increment; "
                    "the structure may be unstable (buckling) or under-constrained (add a clamp)",
                    last_good_state=state, time=state.time)
            continue
        stepper.store_configuration(state, res.q, system.source)
        state.v[:] = 0.0
        lam = target
        increments += 1
        iterations += res.iterations
        if res.iterations <= 4:
            dlam = min(2 * dlam, 1.0)
    if system is None:  # nothing to do: evaluate once for reactions
        system = _StepSystem(stepper, state, 1.0, fixed, load_total, static=True)
        system.residual(state.q, False)
    else:
        system.residual(state.q, False)
    lam_min, stable, pushes = None, None, 0
    if check_stability:
        while True:
            lam_min, mode = lowest_mode(stepper, system, state.q, fixed)
            stable = lam_min > -STABILITY_TOL
            if stable or on_unstable != "perturb" or pushes >= max_perturbations:
                break
            pushes += 1
            relaxed = _pseudo_transient(stepper, state, fixed, load_total, state.q + _push(model, mode, fixed))
            if relaxed is None:
                break
            system, res = relaxed
            stepper.store_configuration(state, res.q, system.source)
            state.v[:] = 0.0
            iterations += res.iterations
        if not stable:
            text = (f"static equilibrium is unstable: the lowest (Jacobi-scaled) Hessian eigenvalue on the free "
                    f"unknowns is {lam_min:.3g} < 0 (past a bifurcation, e.g. buckling)")
            if on_unstable == "raise":
                raise SimulationError(text + "; solve with on_unstable='perturb' to look for the stable branch",
                                      last_good_state=state, time=state.time)
            warnings.warn(text + ("; perturbing did not reach a stable state" if pushes else
                                  "; on_unstable='perturb' looks for the stable branch"),
                          UnstableEquilibriumWarning, stacklevel=2)
    system.residual(state.q, False)
    reactions = control.reactions(t, system.last_full_residual) if control is not None else {}
    return StaticResult(state, increments, iterations, system.residual_norm(
        np.where(fixed, 0.0, system.last_full_residual)), dict(system.energies), reactions, lam_min, stable,
        pushes)


def hessian(stepper, system, q: np.ndarray) -> sp.csc_matrix:
    """The static Jacobian ``∂(∇E − F)/∂q`` at ``q`` (elastic blocks plus interaction blocks) as a
    sparse ``(n_dofs, n_dofs)`` matrix, N/m, N, N m units by rows and columns."""
    m = stepper.model
    el = stepper.elastic
    el.evaluate(q, system.source, True)
    groups = [(m.stretch_dofs, el.stretch_hess), (m.bend_dofs, el.bend_hess)]
    scratch = np.zeros(m.n_dofs)
    for inter in stepper.interactions:
        _, blocks = inter.evaluate(q, system.q_n, system.dt, scratch, True)
        dofs = inter.block_dofs()
        if blocks is not None and dofs.size:
            groups.append((dofs, np.array(blocks, copy=True)))
    rows, cols, vals = [], [], []
    for dofs, blocks in groups:
        k = dofs.shape[1]
        rows.append(np.repeat(dofs, k, axis=1).ravel())
        cols.append(np.tile(dofs, (1, k)).ravel())
        vals.append(blocks.reshape(blocks.shape[0], -1).ravel())
    n = m.n_dofs
    return sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)).tocsc()


def lowest_mode(stepper, system, q: np.ndarray, fixed: np.ndarray) -> tuple[float, np.ndarray]:
    """Lowest eigenvalue of the Jacobi-scaled, symmetrised Hessian on the free unknowns and its mode
    ``(n_dofs,)`` in the unknowns of ``q`` (zero at the fixed ones)."""
    free = np.flatnonzero(~fixed)
    K = hessian(stepper, system, q)
    K = 0.5 * (K + K.T)
    Kf = K[free][:, free]
    d = np.abs(Kf.diagonal())
    d = 1.0 / np.sqrt(np.where(d > 0, d, 1.0))
    D = sp.diags(d)
    A = (D @ Kf @ D).tocsc()
    if free.size <= DENSE_LIMIT:
        w, v = np.linalg.eigh(A.toarray())
        lam, vec = float(w[0]), v[:, 0]
    else:
        from scipy.sparse.linalg import eigsh

        w, v = eigsh(A, k=min(3, free.size - 1), sigma=-STABILITY_TOL, which="LM")
        j = int(np.argmin(w))
        lam, vec = float(w[j]), v[:, j]
    mode = np.zeros(q.shape[0])
    mode[free] = d * vec
    return lam, mode


def _push(model, mode: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """``mode`` scaled so that its largest node displacement is 10 % of the mean rest edge length."""
    pos = mode[model.position_mask]
    amp = float(np.max(np.abs(pos))) if pos.size else 0.0
    scale = 0.1 * float(np.mean(model.rest_length)) / amp if amp > 0 else 0.0
    out = scale * mode
    out[fixed] = 0.0
    return out


def _pseudo_transient(stepper, state: State, fixed, load, q0, tau0: float = 1e-3, max_steps: int = 400):
    """Reach the equilibrium for ``load`` from ``q0`` by proximal (inertia-like) steps.

    Returns ``(system, newton_result)`` of the final plain Newton solve, or ``None``.
    """
    s = state.copy()
    s.q = q0.copy()
    s.v[:] = 0.0
    tau = tau0
    for _ in range(max_steps):
        system = _StepSystem(stepper, s, tau, fixed, load, static=False)
        system.v_n = np.zeros_like(s.v)
        try:
            res = newton_solve(system, s.q.copy(), stepper.options.max_iterations, True)
        except LinearSolveError:
            res = None
        if res is None or not res.converged:
            tau *= 0.25
            if tau < 1e-9:
                return None
            continue
        stepper.store_configuration(s, res.q, system.source)
        if res.iterations <= 4:
            tau *= 4.0
        # try the plain static problem from here
        if tau > 1e3 * tau0 or res.iterations <= 2:
            static_sys = _StepSystem(stepper, s, 1.0, fixed, load, static=True)
            try:
                fin = newton_solve(static_sys, s.q.copy(), stepper.options.max_iterations, True)
            except LinearSolveError:
                continue
            if fin.converged:
                return static_sys, fin
    return None
