"""Newton–Raphson with a backtracking line search, as a function returning a result record."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from knotsim.solver._kernels import all_finite


class NonlinearSystem(Protocol):
    def residual(self, q: np.ndarray, want_jacobian: bool) -> np.ndarray:
        """Full residual at ``q``; when ``want_jacobian`` also assembles the Jacobian there."""

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve with the last assembled Jacobian (constrained unknowns eliminated)."""

    merit: float
    """Incremental potential at the last evaluated point (J), or NaN when not available."""

    def residual_norm(self, r: np.ndarray) -> float:
        """Convergence norm over free unknowns, in units of ``force_tol``'s reference (1 = tolerance)."""

    def step_norm(self, dq: np.ndarray) -> float:
        """Step norm in units of ``step_tol`` (1 = tolerance)."""

    def residual_norm2(self, r: np.ndarray) -> float:
        """Optional: Euclidean norm of the residual in tolerance units (used by the safeguarded line
        search; systems without it are measured by ``np.linalg.norm(r)``)."""

    relax_enabled: bool
    """Optional: whether :meth:`relax` is used."""

    def relax(self, q: np.ndarray, r: np.ndarray, jacobian_current: bool, above: float):
        """Optional nonlinear elimination before a Newton step: ``(q', r')`` with the Jacobian
        assembled at ``q'``, or ``None`` (nothing to relax, or the relaxed unknowns' residual at
        most ``above`` tolerances; e.g. the stepper's spin relaxation)."""


def _acceptable(a: float, rn_try: float, rn: float, merit: float, merit0: float, slope: float) -> bool:
    """Line-search test: the residual norm fell, or the potential fell (Armijo with ``slope``)."""
    if rn_try <= (1.0 - 1e-4 * a) * rn:
        return True
    return slope < 0.0 and math.isfinite(merit) and merit <= merit0 + 1e-4 * a * slope


@dataclass
class NewtonResult:
    """Outcome of :func:`newton_solve`.

    ``residual`` and ``step`` are in tolerance units (converged means ``residual <= 1`` and
    ``step <= 1``, ``step`` being the last step taken or the Newton correction computed at ``q``
    (then not taken), or ``residual <= 0.01``, or ``residual <= 10`` with ``step <= 0.01`` when
    round-off stops the residual from falling further); ``reason`` says why it stopped when not
    converged.
    """

    q: np.ndarray
    converged: bool
    iterations: int
    residual: float
    step: float
    line_search_cuts: int
    reason: str = ""


def newton_solve(system: NonlinearSystem, q0: np.ndarray, max_iterations: int = 25,
                 line_search: bool = True, max_cuts: int = 8, reuse_jacobian: bool = False,
                 reuse_ratio: float = 0.25, stall_iterations: int = 10, safeguard_cuts: int = 30,
                 jacobian_at_start: bool = True, relax_above: float = 1.0, relax_after: int = 0) -> NewtonResult:
    """Solve ``residual(q) = 0`` from ``q0`` (prescribed unknowns already set in ``q0``).

    Each iteration solves ``J dq = -r`` and accepts ``q + a dq`` with the largest
    ``a = 1, 1/2, ...`` (at most ``max_cuts`` halvings) that reduces either the residual norm or the
    system's incremental potential ``merit`` (Armijo condition with slope ``r . dq``); if none does,
    the smallest step is taken. The solve stops at an iterate whose residual is within tolerance
    once the last step or the correction just solved for is within its tolerance (the correction is
    then not applied: the iterate differs from the Newton fixed point by about that correction, and
    its residual, already evaluated, needs no further evaluation). With ``reuse_jacobian``
    (modified Newton), the factorised Jacobian is kept for the next iteration as long as each
    iteration cuts the residual norm by at least ``1/reuse_ratio`` without line-search cuts;
    otherwise it is re-assembled at the new point. With ``reuse_jacobian`` and not
    ``jacobian_at_start``, the first iteration solves with the Jacobian the system already holds
    factorised (the caller's previous solve, e.g. the previous time step's) instead of assembling
    one at ``q0``; the same rule then decides when it is re-assembled.
    Accepting a decrease of the potential lets Newton take the full
    steps that stiff stretching makes look bad in residual norm (a bending step raises the stretching
    residual before the next iteration removes it).

    Safeguard against cycling: friction is not the gradient of a potential, so a step that lowers
    the potential may raise the friction residual, and near a stick-slip transition (the smooth
    Coulomb switch is steep: ``K2 / dt`` in position) the iterates can cycle between two or four
    points for ever, at any time step. When the best residual norm has not halved for
    ``stall_iterations`` iterations, the rest of the solve uses a fresh Jacobian every iteration
    and a line search on the Euclidean residual norm alone (``system.residual_norm2``), for which
    the Newton direction is a descent direction when the Jacobian is exact, with up to
    ``safeguard_cuts`` halvings; an iteration in which that norm does not fall along ``dq`` (an
    inexact Jacobian) takes the ordinary line search instead.
    ``NewtonResult.line_search_cuts`` counts the cuts of both line searches.

    A system with a relaxation (``system.relax_enabled``, e.g. the stepper's spin relaxation) has
    it applied before each Newton step, and to every trial point of the safeguarded line search: in
    the first ``relax_after`` iterations only to an iterate whose relaxed unknowns' residual exceeds
    ``relax_above`` tolerances, from then on to any whose residual exceeds the tolerance
    (``relax_above = 1`` or ``relax_after = 0``: always). A solve whose relaxed unknowns are nearly
    in balance then takes plain Newton iterations and pays nothing for the relaxation.
    """
    try:
        return _newton(system, q0, max_iterations, line_search, max_cuts, reuse_jacobian, reuse_ratio,
                       stall_iterations, safeguard_cuts, jacobian_at_start, relax_above, relax_after)
    except ArithmeticError as exc:  # ZeroDivisionError in a kernel, FloatingPointError, OverflowError
        return NewtonResult(q0, False, 0, np.inf, np.inf, 0,
                            f"numerical failure in a Newton trial ({type(exc).__name__}: {exc})")


class _Trial:
    """Residual evaluations of one solve that turn an arithmetic error of a trial point (a kernel's
    division by zero, an overflow: a diverging iterate) into a non-finite residual norm, so that the
    line search cuts the step; only the first evaluation, at ``q0``, lets the error through."""

    def __init__(self, system):
        self.system = system

    def __call__(self, q, want_jacobian):
        try:
            r = self.system.residual(q, want_jacobian)
        except ArithmeticError:
            self.system.merit = np.nan
            return np.full(q.shape[0], np.nan), np.inf
        return r, self.system.residual_norm(r)


def _newton(system, q0, max_iterations, line_search, max_cuts, reuse_jacobian, reuse_ratio, stall_iterations,
            safeguard_cuts, jacobian_at_start=True, relax_above=1.0, relax_after=0) -> NewtonResult:
    norm2 = getattr(system, "residual_norm2", None) or (lambda r: float(np.linalg.norm(r)))
    relax = system.relax if getattr(system, "relax_enabled", False) else None
    above = relax_above  # tolerances of the relaxed unknowns' residual above which an iterate is relaxed
    trial = _Trial(system)
    q = q0.copy()
    fresh = jacobian_at_start or not reuse_jacobian  # the assembled Jacobian is that of q
    r = system.residual(q, fresh)
    rn = system.residual_norm(r)
    relaxed_at_q = False

    def relaxed_trial(q_try):
        """Residual at ``q_try`` (Jacobian assembled), after the system's relaxation from there."""
        r_t, rn_t = trial(q_try, True)
        if relax is not None and math.isfinite(rn_t) and rn_t > 1.0:
            out = relax(q_try, r_t, True, above)
            if out is not None:
                q_try, r_t = out
                rn_t = system.residual_norm(r_t)
        return q_try, r_t, rn_t

    step = np.inf
    cuts_total = 0
    best = rn
    since_best = 0
    safeguarded = False
    for it in range(max_iterations + 1):
        if not math.isfinite(rn):
            return NewtonResult(q, False, it, rn, step, cuts_total, "residual is not finite")
        # converged: residual and last step within tolerance; or residual far below tolerance; or
        # (stagnation at round-off) residual within 10x tolerance while steps are 100x below theirs
        if rn <= 0.01 or (it > 0 and ((rn <= 1.0 and step <= 1.0) or (rn <= 10.0 and step <= 0.01))):
            return NewtonResult(q, True, it, rn, step if it else 0.0, cuts_total)
        if it == max_iterations:
            break
        if rn <= 0.5 * best:
            best, since_best = rn, 0
        else:
            since_best += 1
            if since_best >= stall_iterations and line_search and not safeguarded:
                safeguarded = True
                if reuse_jacobian:
                    r, rn = trial(q, True)  # the Jacobian at the current point
                    fresh = True
        if it >= relax_after:
            above = 1.0
        if relax is not None and rn > 1.0 and not relaxed_at_q:
            relaxed = relax(q, r, fresh, above)
            if relaxed is not None:
                q, r = relaxed
                rn = system.residual_norm(r)
                fresh = True
                if not math.isfinite(rn):
                    return NewtonResult(q, False, it, rn, step, cuts_total, "residual is not finite")
        relaxed_at_q = False
        dq = system.solve(-r)
        if not all_finite(dq):
            return NewtonResult(q, False, it, rn, step, cuts_total, "linear solve gave a non-finite step")
        if rn <= 1.0:
            # converged at q: residual within tolerance and the Newton correction from it too (q + dq
            # would differ from q by less than the step tolerance; its residual is not needed)
            correction = system.step_norm(dq)
            if correction <= 1.0:
                return NewtonResult(q, True, it, rn, correction, cuts_total)
        a = 1.0
        if safeguarded:
            n0 = norm2(r)
            merit_q = system.merit
            # with a relaxation, every trial point is relaxed before it is measured: the line search
            # is then one of the residual with the relaxed unknowns eliminated (a cycle between a
            # relaxation and a Newton step that undoes it cannot pass it)
            q_try, r_try, rn_try = relaxed_trial(q + dq) if relax is not None else (q + dq, *trial(q + dq, True))
            n_try = norm2(r_try) if np.isfinite(rn_try) else np.inf
            cuts = 0
            while n_try > (1.0 - 1e-4 * a) * n0 and cuts < safeguard_cuts:
                a *= 0.5
                cuts += 1
                if relax is not None:
                    q_try, r_try, rn_try = relaxed_trial(q + a * dq)
                else:
                    q_try = q + a * dq
                    r_try, rn_try = trial(q_try, False)
                n_try = norm2(r_try) if np.isfinite(rn_try) else np.inf
            cuts_total += cuts
            if n_try <= (1.0 - 1e-4 * a) * n0:
                if cuts and relax is None:
                    r_try, _ = trial(q_try, True)
                fresh = True
                step = system.step_norm(a * dq if relax is None else q_try - q)
                q, r, rn = q_try, r_try, system.residual_norm(r_try)
                relaxed_at_q = relax is not None
                continue
            # no descent of the Euclidean norm along dq (the Jacobian is not exact, e.g. DER's
            # skew reference-twist term): this iteration takes the ordinary line search below
            system.merit = merit_q
            a = 1.0
        merit0 = system.merit
        slope = float(np.dot(r, dq))
        q_try = q + dq
        r_try, rn_try = trial(q_try, not reuse_jacobian)
        cuts = 0

        if line_search:
            while not _acceptable(a, rn_try, rn, system.merit, merit0, slope) and cuts < max_cuts:
                a *= 0.5
                cuts += 1
                q_try = q + a * dq
                r_try, rn_try = trial(q_try, False)
            cuts_total += cuts
        fresh = not reuse_jacobian
        if (cuts and not reuse_jacobian) or (reuse_jacobian and (cuts or rn_try > reuse_ratio * rn)):
            r_try, rn_try = trial(q_try, True)  # fresh Jacobian at the accepted point
            fresh = True
        step = system.step_norm(dq if a == 1.0 else a * dq)
        q, r, rn = q_try, r_try, rn_try
    return NewtonResult(q, False, max_iterations, rn, step, cuts_total,
                        f"no convergence in {max_iterations} iterations (residual {rn:.3g} x tolerance)")
