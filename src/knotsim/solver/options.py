"""Settings of the Newton solver and time stepper (:class:`SolverOptions`) and their closed
sets of choices (:class:`LinearSolver`, :class:`Predictor`)."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from knotsim._util.validate import choice, flag, number

__all__ = ["LinearSolver", "Predictor", "SolverOptions"]


class LinearSolver(StrEnum):
    """How Newton's linear systems are solved (:attr:`SolverOptions.linear_solver`)."""

    AUTO = "auto"      #: banded when the bandwidth allows it, else sparse
    BANDED = "banded"  #: banded LDL^T / LU
    SPARSE = "sparse"  #: fixed-pattern sparse LU


class Predictor(StrEnum):
    """Initial Newton guess of a step (:attr:`SolverOptions.predictor`)."""

    ACCELERATION = "acceleration"  #: q_n + dt v*, v extrapolated at constant acceleration
    VELOCITY = "velocity"          #: q_n + dt v_n
    PREVIOUS = "previous"          #: q_n


@dataclass
class SolverOptions:
    """Settings of the Newton solver and time stepper.

    - ``dt``: target time step, s; ``dt_min``: smallest step before giving up (default ``dt/1024``);
    - ``max_iterations``: Newton iterations per attempt;
    - ``force_tol`` (N) and ``moment_tol`` (N m): residual tolerances; default
      ``1e-9 EI/l^2`` and that times the mean edge length ``l`` (smallest over rods); a step is
      converged when the residual is below tolerance and the last Newton step, or the Newton
      correction computed at the current iterate, below ``step_tol`` (or the residual below 1 % of
      tolerance);
    - ``step_tol`` (m): Newton step tolerance, default ``1e-6 l``; ``angle_tol`` (rad) likewise 1e-6;
    - ``grow_after``: consecutive easy steps (at most ``easy_iterations`` iterations) before the step
      doubles back towards ``dt``;
    - ``dt_max`` (s, default ``dt``: no growth beyond it): while the solution is smooth the step may
      double beyond ``dt`` up to ``dt_max``: after ``grow_after`` easy steps whose local error
      estimate of backward Euler, ``h/2 max |v_{n+1} - v_n|`` over the nodes (m), is at most
      ``error_tol``; it halves back towards ``dt`` as soon as the estimate exceeds 4 ``error_tol``, a
      step needs more than ``easy_iterations`` iterations, or a boundary condition starts or stops
      within the step (a protocol's stage change: that step is taken at ``dt`` at most);
    - ``error_tol`` (m, default ``1e-6``): the local error per step that steps beyond ``dt`` keep;
    - ``linear_solver``: ``"auto"`` (banded when possible), ``"banded"``, ``"sparse"``;
    - ``predictor``: initial Newton guess, ``"acceleration"`` (``q_n + dt v*`` with the velocity
      extrapolated at constant acceleration, ``v* = v_n + (v_n - v_{n-1}) dt/dt_{n-1}``; 0.8 fewer
      Newton iterations per step on ``benchmarks/bench_contact.py``, 4.19 against 4.97; falls back to
      ``"velocity"`` when there is no previous step), ``"velocity"`` (``q_n + dt v_n``) or
      ``"previous"`` (``q_n``);
    - ``jacobian_reuse``: modified Newton, keeping the factorised Jacobian while iterations converge
      fast (see :func:`~knotsim.solver.newton.newton_solve`);
    - ``jacobian_across_steps`` (with ``jacobian_reuse``): a step starts from the previous step's
      factorised Jacobian, instead of assembling and factorising one at its start, when that step
      converged in one iteration and the step size, the constrained unknowns and the interactions'
      block pattern are unchanged (the within-step rule above then refreshes it when it stops
      contracting fast). Checkpoints keep that Jacobian, so that continued runs stay bit for bit;
    - validity limits (:mod:`knotsim.solver.validity`): ``max_axial_strain``, the largest
      ``|l/l0 - 1|`` of an edge (default 2: the MAE259B set-ups stretch
      their rope's end edges by up to 0.72), and ``max_energy_gain``, the energy created without a
      source as a fraction of the energy the run handled (default 0.5); a converged step beyond
      either stops the run with a :class:`~knotsim.errors.ValidityError` (``math.inf`` switches a
      guard off).
    - ``spin_relaxation``: before each Newton step, solve the edge angles with the nodes held when
      surface-friction pairs are in range (:mod:`knotsim.solver.spin_relaxation`; default on). It
      changes the Newton path, not the equations; with centre-line friction it does nothing;
    - ``spin_relaxation_above``, ``spin_relaxation_after``: in the first ``spin_relaxation_after``
      Newton iterations of a step (default 3) an iterate is relaxed only when the residual of the
      relaxed edge angles exceeds ``spin_relaxation_above`` moment tolerances (default 1000); from
      then on whenever it exceeds the tolerance. A step whose angles are nearly in balance then
      takes plain Newton iterations and does not pay for the relaxation. ``spin_relaxation_above
      = 1`` relaxes every iterate, as the studies committed before these options existed ran.
    """

    dt: float = 1e-3
    dt_min: float | None = None
    max_iterations: int = 50
    force_tol: float | None = None
    moment_tol: float | None = None
    step_tol: float | None = None
    angle_tol: float = 1e-6
    line_search: bool = True
    grow_after: int = 5
    dt_max: float | None = None
    error_tol: float = 1e-6
    easy_iterations: int = 4
    linear_solver: LinearSolver | str = LinearSolver.AUTO
    predictor: Predictor | str = Predictor.ACCELERATION
    jacobian_reuse: bool = True
    jacobian_across_steps: bool = True
    max_axial_strain: float = 2.0
    max_energy_gain: float = 0.5
    spin_relaxation: bool = True
    spin_relaxation_above: float = 1000.0
    spin_relaxation_after: int = 3

    def validate(self) -> None:
        number(self.dt, "solver.dt", above=0.0, must="be a positive time step in s")
        if self.dt_min is not None:
            number(self.dt_min, "solver.dt_min", above=0.0, at_most=self.dt, must=f"lie in (0, dt={self.dt}]")
        if self.dt_max is not None:
            number(self.dt_max, "solver.dt_max", at_least=self.dt, must=f"be a time step of at least dt = {self.dt} s")
        number(self.error_tol, "solver.error_tol", above=0.0, must="be a positive length in m")
        number(self.max_iterations, "solver.max_iterations", integer=True, at_least=1)
        for name in ("force_tol", "moment_tol", "step_tol", "angle_tol"):
            v = getattr(self, name)
            if v is not None:
                number(v, f"solver.{name}", above=0.0, infinite=True, must="be positive")
        flag(self.spin_relaxation, "solver.spin_relaxation")
        number(self.spin_relaxation_above, "solver.spin_relaxation_above", at_least=1.0, infinite=True,
               must="be at least 1 (moment tolerances; 1: relax every iterate)")
        number(self.spin_relaxation_after, "solver.spin_relaxation_after", integer=True, at_least=0)
        for name in ("max_axial_strain", "max_energy_gain"):
            number(getattr(self, name), f"solver.{name}", above=0.0, infinite=True,
                   must="be a positive number (inf switches the guard off)")
        self.linear_solver = choice(self.linear_solver, "solver.linear_solver", LinearSolver)
        self.predictor = choice(self.predictor, "solver.predictor", Predictor)
