"""Newton solver on small systems: convergence, and the safeguard against cycling.

The toy system is a spring (the merit: potential ``1/2 |q|^2 - f . q``) plus a steep
friction-like coupling ``c tanh(K (q0 - q1))`` that is *not* the gradient of the merit, like
smooth Coulomb friction in a time step. A line search that accepts any decrease of the potential
can then cycle for ever near the steep transition.
"""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.solver.newton import newton_solve


class SpringWithSteepCoupling:
    def __init__(self, K: float, c: float, f0: float):
        self.K, self.c, self.f0 = K, c, f0
        self.merit = float("nan")
        self.jacobians = 0

    def residual(self, q, want_jacobian):
        s = np.tanh(self.K * (q[0] - q[1]))
        r = np.array([q[0] + self.c * s - self.f0, q[1] - self.c * s + 0.5 * self.f0])
        self.merit = 0.5 * float(q @ q) - self.f0 * q[0] + 0.5 * self.f0 * q[1]
        if want_jacobian:
            d = self.c * self.K * (1.0 - s * s)
            self.J = np.array([[1.0 + d, -d], [-d, 1.0 + d]])
            self.jacobians += 1
        return r

    def solve(self, rhs):
        return np.linalg.solve(self.J, rhs)

    def residual_norm(self, r):
        return float(np.max(np.abs(r))) / 1e-10

    def step_norm(self, dq):
        return float(np.max(np.abs(dq))) / 1e-12


def _cases(n, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        yield (10 ** rng.uniform(2, 6), 10 ** rng.uniform(-1, 1), rng.uniform(-2, 2),
               rng.uniform(-1, 1, size=2))


def test_converged_point_solves_the_system():
    sys_ = SpringWithSteepCoupling(1e3, 0.5, 0.8)
    res = newton_solve(sys_, np.array([0.3, -0.2]), 50)
    assert res.converged
    assert np.max(np.abs(sys_.residual(res.q, False))) <= 1e-10


def test_safeguard_breaks_cycles_that_the_potential_line_search_cannot():
    old_fail = new_fail = 0
    for K, c, f0, q0 in _cases(400):
        old = newton_solve(SpringWithSteepCoupling(K, c, f0), q0, 50, stall_iterations=10**9)
        sys_ = SpringWithSteepCoupling(K, c, f0)
        new = newton_solve(sys_, q0, 50)
        old_fail += not old.converged
        new_fail += not new.converged
        if new.converged:
            assert np.max(np.abs(sys_.residual(new.q, False))) <= 1e-9
    # measured: 112 of 400 cycle without the safeguard, none with it
    assert old_fail > 50
    assert new_fail == 0


def test_safeguard_does_not_touch_fast_convergence():
    """A well-behaved system converges in a few iterations, the same with and without the safeguard."""
    for K, c, f0, q0 in _cases(50, seed=1):
        K = 1.0  # smooth coupling: quadratic convergence
        a = newton_solve(SpringWithSteepCoupling(K, c, f0), q0, 50, stall_iterations=10**9)
        b = newton_solve(SpringWithSteepCoupling(K, c, f0), q0, 50)
        assert a.converged and b.converged
        assert a.iterations == b.iterations <= 8
        np.testing.assert_array_equal(a.q, b.q)


@pytest.mark.parametrize("reuse", [False, True])
def test_safeguard_with_modified_newton(reuse):
    fails = 0
    for K, c, f0, q0 in _cases(100, seed=2):
        fails += not newton_solve(SpringWithSteepCoupling(K, c, f0), q0, 50, reuse_jacobian=reuse).converged
    assert fails == 0



class _Cubic:
    """``r(q) = q + q^3 - 2`` (root 1) with tolerances ``force_tol``, ``step_tol``; counts evaluations."""

    def __init__(self, force_tol, step_tol):
        self.force_tol, self.step_tol, self.evaluations, self.merit = force_tol, step_tol, 0, float("nan")

    def residual(self, q, want_jacobian):
        self.evaluations += 1
        self.merit = 0.5 * q[0] ** 2 + 0.25 * q[0] ** 4 - 2.0 * q[0]
        if want_jacobian:
            self.J = 1.0 + 3.0 * q[0] ** 2
        return np.array([q[0] + q[0] ** 3 - 2.0])

    def solve(self, rhs):
        return rhs / self.J

    def residual_norm(self, r):
        return abs(float(r[0])) / self.force_tol

    def step_norm(self, dq):
        return abs(float(dq[0])) / self.step_tol


def test_stops_at_an_iterate_whose_correction_is_within_tolerance():
    """Once the residual is within tolerance, a correction within the step tolerance ends the solve
    at the current iterate: the result is that Newton iterate itself (not the corrected point), its
    residual the evaluated one, with one residual evaluation per iteration plus the start's."""
    q, iterates = 3.0, []
    for _ in range(12):  # plain Newton by hand (full steps: the cubic is convex here)
        iterates.append(q)
        q -= (q + q**3 - 2.0) / (1.0 + 3.0 * q * q)
    # tolerances where the iterate k has a residual within tolerance but its last step is not,
    # while the correction from it is
    k = next(i for i in range(1, 12) if abs(iterates[i + 1] - iterates[i]) < 1e-7)
    step_tol = 0.5 * (abs(iterates[k + 1] - iterates[k]) + abs(iterates[k] - iterates[k - 1]))
    force_tol = 1.5 * abs(iterates[k] + iterates[k] ** 3 - 2.0)
    assert abs(iterates[k] - iterates[k - 1]) > step_tol > abs(iterates[k + 1] - iterates[k])
    sys_ = _Cubic(force_tol, step_tol)
    res = newton_solve(sys_, np.array([3.0]), 50)
    assert res.converged and res.iterations == k
    assert res.q[0] == iterates[k]
    assert res.residual == pytest.approx(1.0 / 1.5, rel=1e-12) and res.step < 1.0
    assert sys_.evaluations == k + 1
