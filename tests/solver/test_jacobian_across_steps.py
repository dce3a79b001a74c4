"""A time step may start from the previous step's factorised Jacobian
(``SolverOptions.jacobian_across_steps``): fewer factorisations, the same answers within the
Newton tolerances, and only after steps that converged in one iteration."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from knotsim.runspec import RunSpec, run
from knotsim.solver.newton import newton_solve

from .test_newton import SpringWithSteepCoupling

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_newton_starts_from_the_jacobian_it_is_given():
    """Without ``jacobian_at_start`` the first iteration uses the Jacobian the system holds (here
    one from a nearby point): no assembly at ``q0`` and the same root; with it, one at ``q0``."""
    K, c, f0 = 30.0, 0.5, 1.0
    root = newton_solve(SpringWithSteepCoupling(K, c, f0), np.array([0.4, -0.1]), 50).q
    for start in (True, False):
        sys_ = SpringWithSteepCoupling(K, c, f0)
        sys_.residual(root + 1e-3, True)  # the Jacobian of a neighbouring point, "the last step's"
        sys_.jacobians = 0
        res = newton_solve(sys_, root + 2e-3, 50, reuse_jacobian=True, jacobian_at_start=start)
        assert res.converged
        np.testing.assert_allclose(res.q, root, atol=1e-9)
        if start:
            assert sys_.jacobians >= 1
        else:
            assert sys_.jacobians == 0  # converged on the Jacobian it was given


def test_a_far_stale_jacobian_is_refreshed_and_newton_still_converges():
    """A held Jacobian from far away contracts poorly: the reuse rule re-assembles it."""
    K, c, f0 = 300.0, 2.0, 1.5
    root = newton_solve(SpringWithSteepCoupling(K, c, f0), np.array([0.0, 0.0]), 50).q
    sys_ = SpringWithSteepCoupling(K, c, f0)
    sys_.residual(np.array([5.0, -5.0]), True)  # far outside the steep transition
    sys_.jacobians = 0
    res = newton_solve(sys_, np.array([0.0, 0.0]), 50, reuse_jacobian=True, jacobian_at_start=False)
    assert res.converged and sys_.jacobians >= 1
    np.testing.assert_allclose(res.q, root, atol=1e-9)


@pytest.fixture(scope="module")
def both_runs(tmp_path_factory):
    """The crossing-rods example (contact, friction, moving grips) with and without the carry-over."""
    out = {}
    for across in (True, False):
        data = RunSpec.load(EXAMPLES / "crossing_rods.toml").to_dict()
        data["solver"]["jacobian_across_steps"] = across
        out[across] = run(RunSpec.from_dict(data), duration=0.3)
    return out


def test_fewer_factorisations_only_after_one_iteration_steps(both_runs):
    on, off = both_runs[True], both_runs[False]
    steps_on, steps_off = len(on.log), len(off.log)
    assert steps_on == steps_off
    f_on, f_off = on.simulation.stepper.factorizations, off.simulation.stepper.factorizations
    assert f_off >= steps_off  # every step assembles and factorises at its start
    # a step can skip its start-of-step factorisation only when the step before it took one iteration
    after_one = int(np.sum(on.log["iterations"].to_numpy()[:-1] == 1))
    assert after_one > 0
    assert steps_on - after_one <= f_on < f_off


def test_same_answers_within_the_newton_tolerance(both_runs):
    on, off = both_runs[True], both_runs[False]
    np.testing.assert_array_equal(on.log["time"].to_numpy(), off.log["time"].to_numpy())
    step_tol = on.simulation.stepper.step_tol
    # each step converges to within a few step tolerances of the same fixed point
    assert np.max(np.abs(on.state.q - off.state.q)) < 10.0 * step_tol
    assert np.max(np.abs(on.state.q - off.state.q)) > 0.0  # (the runs do differ: a carried Jacobian)
    force = [np.hypot(r.log["B0_fz"].to_numpy(), r.log["B0_fx"].to_numpy()) for r in (on, off)]
    assert np.max(np.abs(force[0] - force[1])) <= 1e-6 * np.max(np.abs(force[1]))
