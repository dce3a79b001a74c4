"""Spin relaxation (:mod:`knotsim.solver.spin_relaxation`): the edge angles solved for with the
nodes held before a Newton step. The angle problem's compiled minimiser against a plain-numpy
version of the same iteration and against a general-purpose optimiser, the Jacobian blocks it starts
from, and whole runs: the same answers within the Newton tolerances with and without it (relaxing
every iterate, or only those far out of balance), nothing done with the centre-line law."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize
from tests.contact.friction_records import random_friction_records

from knotsim.contact.spin_minimiser import SpinFriction
from knotsim.runspec import RunSpec, run
from knotsim.solver.options import SolverOptions
from knotsim.solver.spin_relaxation import joined_spins, relax_spins, relaxed_angles

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
DT = 1e-3
NU = 1e-3


def synthetic_problem(seed, m=12, k=9, slip=1e-2):
    """A twist chain of ``m`` angles (tridiagonal, with inertia) and ``k`` surface-friction pairs
    between random angles (some held: −1), sliding at about ``slip`` m/s."""
    rng = np.random.default_rng(seed)
    a = np.diag(np.full(m, 2e-4)) + np.diag(np.full(m - 1, -1e-4), 1) + np.diag(np.full(m - 1, -1e-4), -1)
    a += np.diag(np.full(m, 1e-6))
    rec = random_friction_records(rng, k, slip, lever=2.5e-3, mufn_min=0.05)
    theta_dofs = 100 + np.arange(m)  # global unknowns of the angles (any numbering)
    pair_dofs = theta_dofs[rng.integers(0, m, size=(k, 2))]
    pair_dofs[0, 1] = 7  # an angle that is held (not among the relaxed ones)
    sf = SpinFriction(pair_dofs, rec, NU)
    # the residual at the iterate: an external torque plus the friction there (r = ∇Ψ(0))
    loc = np.full(200, -1)
    loc[theta_dofs] = np.arange(m)
    g = np.zeros(m)
    h = np.zeros((k, 2, 2))
    sf.terms(np.zeros(m), loc[pair_dofs], DT, g, h)
    r = rng.normal(size=m) * 1e-4 + g
    j = a.copy()
    for p in range(k):
        for i in range(2):
            for jj in range(2):
                li, lj = loc[pair_dofs[p, i]], loc[pair_dofs[p, jj]]
                if li >= 0 and lj >= 0:
                    j[li, lj] += h[p, i, jj]
    return a, j, r, theta_dofs, sf, loc[pair_dofs]


def psi(x, a, r, sf, loc, g0, d0):
    g = np.zeros(x.shape[0])
    h = np.zeros((sf.record.shape[0], 2, 2))
    d = sf.terms(x, loc, DT, g, h)
    return r @ x + 0.5 * x @ a @ x + d - d0 - g0 @ x, r + a @ x + g - g0


class ReferenceAngleProblem:
    """Plain-numpy ``Ψ``, gradient and Hessian over the relaxed angles (the reference for
    :func:`knotsim.contact.spin_minimiser.minimise_spin_potential`)."""

    def __init__(self, j_tt, r_t, sf, loc, dt):
        self.r_t, self.sf, self.loc, self.dt = r_t, sf, loc, dt
        self.m = r_t.shape[0]
        self.grad = np.empty(self.m)
        self.hess = np.empty((loc.shape[0], 2, 2))
        self.d0 = sf.terms(np.zeros(self.m), loc, dt, self.grad, self.hess)
        self.g0 = self.grad.copy()
        self.a = j_tt - self.pair_hessian()

    def pair_hessian(self):
        out = np.zeros((self.m, self.m))
        for p in range(self.loc.shape[0]):
            for i in range(2):
                for j in range(2):
                    if self.loc[p, i] >= 0 and self.loc[p, j] >= 0:
                        out[self.loc[p, i], self.loc[p, j]] += self.hess[p, i, j]
        return out

    def value_and_gradient(self, x):
        d = self.sf.terms(x, self.loc, self.dt, self.grad, self.hess)
        ax = self.a @ x
        return self.r_t @ x + 0.5 * x @ ax + d - self.d0 - self.g0 @ x, self.r_t + ax + self.grad - self.g0


def reference_relax(j_tt, r_t, sf, loc, dt, tol, max_iterations=20, max_cuts=40):
    """Newton's method with an Armijo backtracking on ``Ψ``, written out plainly: (turn, iterations)."""
    prob = ReferenceAngleProblem(j_tt, r_t, sf, loc, dt)
    x = np.zeros(prob.m)
    psi, grad = prob.value_and_gradient(x)
    it = 0
    while it < max_iterations and np.abs(grad).max() > tol:
        step = -np.linalg.solve(prob.a + prob.pair_hessian(), grad)
        slope = grad @ step
        if not slope < 0.0:
            break
        a, cuts = 1.0, 0
        while True:
            psi_t, grad_t = prob.value_and_gradient(x + a * step)
            if psi_t <= psi + 1e-4 * a * slope or cuts >= max_cuts:
                break
            a, cuts = 0.5 * a, cuts + 1
        if not psi_t <= psi:
            break
        x, psi, grad, it = x + a * step, psi_t, grad_t, it + 1
    return x, it


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
@pytest.mark.parametrize("slip", [1e-6, 1e-2, 1.0])
def test_compiled_minimiser_follows_the_reference_iteration(seed, slip):
    a, j, r, theta_dofs, sf, loc = synthetic_problem(seed, slip=slip)
    tol = 1e-10
    ref, ref_it = reference_relax(j, r, sf, loc, DT, tol)
    out = relax_spins(j, r, loc, sf, DT, tol)
    assert out.iterations == ref_it and ref_it >= 1
    # the two stop within the same gradient tolerance; the sums' round-off moves the last iterate
    np.testing.assert_allclose(out.dtheta, ref, rtol=0.0, atol=1e-6 * np.abs(ref).max())


def test_several_interactions_are_joined():
    a, j, r, theta_dofs, sf, loc = synthetic_problem(5)
    half = sf.record.shape[0] // 2
    parts = [SpinFriction(sf.theta_dofs[:half], sf.record[:half], NU),
             SpinFriction(sf.theta_dofs[half:], sf.record[half:], NU)]
    one = relax_spins(j, r, loc, sf, DT, 1e-10)
    two = relax_spins(j, r, loc, joined_spins(parts), DT, 1e-10)
    np.testing.assert_array_equal(one.dtheta, two.dtheta)
    assert one.iterations == two.iterations


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_relaxation_finds_the_minimiser_of_the_angle_problem(seed):
    a, j, r, theta_dofs, sf, loc = synthetic_problem(seed)
    m = theta_dofs.shape[0]
    g0 = np.zeros(m)
    d0 = sf.terms(np.zeros(m), loc, DT, g0, np.zeros((loc.shape[0], 2, 2)))
    tol = 1e-12
    out = relax_spins(j, r, loc, sf, DT, tol, max_iterations=100)
    assert out.residual <= 1.0 and out.iterations >= 1
    _, grad = psi(out.dtheta, a, r, sf, loc, g0, d0)
    assert np.abs(grad).max() <= tol
    ref = minimize(lambda x: psi(x, a, r, sf, loc, g0, d0), np.zeros(m), jac=True, method="BFGS",
                   options={"gtol": 1e-13, "maxiter": 10000})
    assert psi(out.dtheta, a, r, sf, loc, g0, d0)[0] <= ref.fun + 1e-15
    np.testing.assert_allclose(out.dtheta, ref.x, atol=1e-6 * np.abs(ref.x).max())


def test_relaxation_leaves_a_solved_problem_alone():
    a, j, r, theta_dofs, sf, loc = synthetic_problem(4)
    out = relax_spins(j, np.zeros_like(r) + (r - r), loc, sf, DT, 1.0)
    assert out.iterations == 0 and not out.dtheta.any()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_relaxed_angles_are_the_free_pair_angles_in_order(seed):
    """The numbering of the relaxed angles against numpy: the free angles among the pairs', sorted and
    each once, every pair's place among them (−1 for a held angle), the largest residual there."""
    rng = np.random.default_rng(seed)
    n = 60
    pair_dofs = rng.integers(0, n, size=(25, 2))
    free = rng.random(n) < 0.7
    r = rng.normal(size=n)
    sf = SpinFriction(pair_dofs, np.zeros((25, 15)), NU)
    idx, loc, largest = relaxed_angles(sf, free, r)
    ref = np.unique(pair_dofs.ravel())
    ref = ref[free[ref]]
    np.testing.assert_array_equal(idx, ref)
    place = np.full(n, -1)
    place[ref] = np.arange(ref.size)
    np.testing.assert_array_equal(loc, place[pair_dofs])
    assert largest == np.abs(r[ref]).max()
    r[ref[0]] = np.nan
    assert math.isnan(relaxed_angles(sf, free, r)[2])
    idx, loc, largest = relaxed_angles(sf, np.zeros(n, bool), r)
    assert idx.size == 0 and (loc == -1).all() and largest == 0.0


def log_roll_run(relax: bool, friction_model: str = "surface", twist: bool = True, travel_time: float = 0.3,
                 above: float = 1.0, after: int = 3):
    """The log roll of docs/validation.md §2.1 (rod B pressed onto A, its ends then moved 10 mm
    across A in ``travel_time`` s; ``twist``: B's ends also hold their edge angles), cut short;
    ``above``, ``after``: ``solver.spin_relaxation_above`` (1: every iterate relaxed) and ``_after``."""
    from knotsim.contact.model import Contact
    from knotsim.contact.options import ContactOptions
    from knotsim.simulation import Simulation
    from knotsim.solver.options import SolverOptions
    from knotsim.validation import rolling

    m, bcs = rolling.crossing_rods()
    t_travel = rolling.PRESS_TIME + 0.05

    def path(t):
        down = -rolling.PRESS_DEPTH * min(t, rolling.PRESS_TIME) / rolling.PRESS_TIME
        return [0.01 * min(max(t - t_travel, 0.0), travel_time) / travel_time, 0.0, down]

    bcs.move("B0", rod="B", nodes=[0, 1], path=path, twist=twist)
    bcs.move("B1", rod="B", nodes=[-2, -1], path=path, twist=twist)
    contact = Contact(m, ContactOptions(mu=0.3, friction_model=friction_model))
    options = SolverOptions(dt=2e-3, spin_relaxation=relax, spin_relaxation_above=above, spin_relaxation_after=after)
    sim = Simulation(m, bcs, options, interactions=[contact])
    log = sim.run(t_travel + travel_time, progress=False)
    return sim, log


@pytest.fixture(scope="module")
def log_rolls():
    return {key: log_roll_run(*args) for key, args in {
        "on": (True,), "off": (False,), "centreline": (True, "centreline"),
        "default": (True, "surface", True, 0.3, SolverOptions().spin_relaxation_above)}.items()}


def test_relaxation_runs_only_above_its_threshold_in_the_first_iterations():
    """``spin_relaxation_above = inf`` with ``spin_relaxation_after`` beyond any step's iterations:
    no relaxation; the same run relaxing every iterate (``above = 1``) relaxes; a threshold between
    the two relaxes fewer iterates than every one."""
    counts = {}
    for above in (1.0, 1e3, math.inf):
        sim, _ = log_roll_run(True, above=above, travel_time=0.1, after=50)
        counts[above] = sim.stepper.spin_relaxations
    assert counts[math.inf] == 0
    assert counts[1.0] > counts[1e3] >= 0 and counts[1.0] > 0


@pytest.mark.parametrize("variant", ["on", "default"])
def test_same_answers_with_and_without_relaxation(log_rolls, variant):
    (on, log_on), (off, log_off) = log_rolls[variant], log_rolls["off"]
    if variant == "on":
        assert on.stepper.spin_relaxations > 0 and on.stepper.spin_iterations > 0
    assert off.stepper.spin_relaxations == 0
    assert on.state.time == off.state.time
    m = on.model
    pos = ~m.theta_mask
    np.testing.assert_allclose(on.state.q[pos], off.state.q[pos], atol=1e-8)
    np.testing.assert_allclose(on.state.q[m.theta_mask], off.state.q[m.theta_mask], atol=1e-5)
    f_on = np.abs(log_on["A0_fx"] + log_on["A1_fx"]).to_numpy()
    f_off = np.abs(log_off["A0_fx"] + log_off["A1_fx"]).to_numpy()
    np.testing.assert_allclose(f_on, f_off, atol=1e-4 * np.abs(f_off).max())


def test_nothing_relaxed_with_the_centreline_law(log_rolls):
    assert log_rolls["centreline"][0].stepper.spin_relaxations == 0


@pytest.mark.parametrize("solver", ["banded", "sparse"])
def test_jacobian_block_is_the_assembled_matrix(solver):
    data = RunSpec.load(EXAMPLES / "crossing_rods.toml").to_dict()
    data["solver"]["linear_solver"] = solver
    sim = run(RunSpec.from_dict(data), duration=0.01)
    st = sim.simulation.stepper
    n = sim.simulation.model.n_dofs
    kind = st._system[0]
    assert kind == solver
    dense = np.zeros((n, n))
    if kind == "sparse":
        data_, indices, indptr = st._system[1], st._indices, st._indptr
        for col in range(n):
            for s in range(indptr[col], indptr[col + 1]):
                dense[indices[s], col] += data_[s]
    else:
        _, ab, kl, ku, _ = st._system
        for jcol in range(n):
            for i in range(max(0, jcol - ku), min(n, jcol + kl + 1)):
                dense[i, jcol] = ab[kl + ku + i - jcol, jcol]
    idx = np.flatnonzero(sim.simulation.model.theta_mask)[::2]
    np.testing.assert_array_equal(st.jacobian_block(idx), dense[np.ix_(idx, idx)])
    assert np.abs(dense[np.ix_(idx, idx)]).max() > 0
