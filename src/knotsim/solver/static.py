"""Quasi-static equilibrium: the Newton machinery of the stepper without inertia.

Loads (gravity and boundary-condition forces) are applied in increments of a load factor from 0 to
1 (continuation); an increment that fails is halved. Prescribed motions are evaluated at
``time`` (default: the state's time).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from knotsim.errors import SimulationError
from knotsim.solver.linear import LinearSolveError
from knotsim.solver.newton import newton_solve
from knotsim.solver.state import State, initial_state
from knotsim.solver.stepper import SolverSettings, Stepper, _StepSystem


@dataclass
class StaticResult:
    """Equilibrium state with its Newton statistics and the reactions of prescribed groups."""

    state: State
    load_increments: int
    iterations: int
    residual: float
    energies: dict
    reactions: dict


def solve_static(model, control=None, state: State | None = None, settings: SolverSettings | None = None,
                 interactions=(), load_steps: int = 10, min_increment: float = 1e-4,
                 time: float | None = None, relaxation: bool = True) -> StaticResult:
    """Find the equilibrium ``grad E(q) = F_ext`` with prescribed unknowns held.

    ``load_steps`` is the initial number of equal load increments. When Newton fails for an
    increment and ``relaxation`` is on, the increment is first retried by pseudo-transient
    continuation (proximal steps ``M (q - q_k)/tau^2 + grad E(q) = F`` with a growing pseudo time
    step ``tau``, which regularises an indefinite Hessian far from equilibrium). Raises
    :class:`~knotsim.errors.SimulationError` (with the last equilibrium reached) if an increment
    smaller than ``min_increment`` fails.
    """
    stepper = Stepper(model, interactions, settings or SolverSettings())
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
            res = newton_solve(system, q0, stepper.settings.max_iterations, stepper.settings.line_search)
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
    reactions = control.reactions(t, system.last_full_residual) if control is not None else {}
    return StaticResult(state, increments, iterations, system.residual_norm(
        np.where(fixed, 0.0, system.last_full_residual)), dict(system.energies), reactions)


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
            res = newton_solve(system, s.q.copy(), stepper.settings.max_iterations, True)
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
                fin = newton_solve(static_sys, s.q.copy(), stepper.settings.max_iterations, True)
            except LinearSolveError:
                continue
            if fin.converged:
                return static_sys, fin
    return None
