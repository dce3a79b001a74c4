"""Physics checks of the rod engine (no contact)."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.bc import BoundaryConditions
from knotsim.errors import SimulationError
from knotsim.rods import Model, RodSpec
from knotsim.simulation import Simulation
from knotsim.solver.static import solve_static
from knotsim.solver.stepper import SolverOptions
from knotsim.validation.cases import cantilever, helix


def straight(n=21, length=0.2, **kw):
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0.0, length, n)
    kw.setdefault("radius", 1.6e-3)
    kw.setdefault("youngs_modulus", 0.18e6)
    kw.setdefault("density", 1180.0)
    return RodSpec(x, **kw)


def test_hanging_rod_reaction_equals_weight_static():
    rod = straight()
    m = Model([rod], gravity=(0.0, 0.0, -9.81))
    bcs = BoundaryConditions(m)
    bcs.clamp("top", nodes=[0, 1])
    res = solve_static(m, bcs)
    weight = m.total_mass() * 9.81
    np.testing.assert_allclose(res.reactions["top"][:3], [0.0, 0.0, weight], rtol=1e-8, atol=1e-12 * weight)


def test_hanging_rod_reaction_dynamic_settles_to_weight():
    x = np.zeros((11, 3))
    x[:, 2] = -np.linspace(0.0, 0.1, 11)  # hanging straight down: equilibrium from the start
    m = Model([RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0)], gravity=(0, 0, -9.81), damping=0.05)
    bcs = BoundaryConditions(m)
    bcs.clamp("top", nodes=[0, 1])
    sim = Simulation(m, bcs, SolverOptions(dt=1e-3))
    log = sim.run(0.2, progress=False)
    weight = m.total_mass() * 9.81
    assert log["top_fz"].iloc[-1] == pytest.approx(weight, rel=1e-3)


def test_cantilever_quick_validation():
    rows = cantilever(quick=True)
    assert all(r["passed"] for r in rows), rows


def test_helix_quick_validation():
    rows = helix(quick=True)
    assert all(r["passed"] for r in rows), rows


def test_released_rod_conserves_momentum_and_energy_never_grows():
    rod = straight(n=15, length=0.1)
    rod.velocities = np.zeros((15, 3))
    rod.velocities[:, 2] = np.linspace(-0.05, 0.05, 15)  # spin: bending + rotation
    rod.velocities[:, 1] = 0.02
    m = Model([rod])
    bcs = BoundaryConditions(m)
    bcs.move("end", nodes=[0, 1], path=[0.0, 0.02, 0.0], stop=0.01)
    sim = Simulation(m, bcs, SolverOptions(dt=1e-3))
    sim.run(0.01, progress=False)
    p0 = None
    energies = []
    for _ in range(100):
        sim.step()
        v = sim.state.v
        p = np.array([np.sum(m.mass[m.node_dof + k] * v[m.node_dof + k]) for k in range(3)])
        if p0 is None:
            p0 = p
        np.testing.assert_allclose(p, p0, atol=1e-10 * (np.abs(p0).max() + 1e-12) + 1e-14)
        row = sim.rows[-1]
        energies.append(row["energy_elastic"] + row["energy_kinetic"])
    e = np.array(energies)
    assert np.all(np.diff(e) <= 1e-12 * e.max()), np.diff(e).max()
    assert e[-1] < e[0]  # backward Euler dissipates a little


def test_pull_both_ends_reactions_equal_and_opposite():
    m = Model([straight(n=21, length=0.2)], damping=0.01)
    bcs = BoundaryConditions(m)
    bcs.move("left", nodes=[0, 1], path=[-0.005, 0.0, 0.0])
    bcs.move("right", nodes=[-2, -1], path=[0.005, 0.0, 0.0])
    sim = Simulation(m, bcs, SolverOptions(dt=2e-3))
    log = sim.run(0.2, progress=False)
    left = log[["left_fx", "left_fy", "left_fz"]].to_numpy()[-1]
    right = log[["right_fx", "right_fy", "right_fz"]].to_numpy()[-1]
    np.testing.assert_allclose(left, -right, rtol=1e-3, atol=1e-9)
    # tension matches EA * strain of the stretched rod
    rod = m.rods[0]
    # the clamped end edges are rigid, so the 2 mm elongation stretches the free span of 0.18 m
    strain = 0.2 * 0.01 / 0.18
    assert right[0] == pytest.approx(rod.EA * strain, rel=0.01)


def test_banded_and_sparse_solvers_agree():
    results = []
    for solver in ("banded", "sparse"):
        rod = straight(n=21, length=0.2, natural_twist=5.0)
        m = Model([rod], gravity=(0, 0, -9.81))
        bcs = BoundaryConditions(m)
        bcs.clamp("left", nodes=[0, 1])
        bcs.rotate("right", nodes=[-2, -1], rate=3.0)
        sim = Simulation(m, bcs, SolverOptions(dt=2e-3, linear_solver=solver))
        sim.run(0.05, progress=False)
        results.append(sim.state.q.copy())
    np.testing.assert_allclose(results[0], results[1], atol=1e-9)


def test_closed_ring_runs_with_sparse_solver():
    n = 30
    s = np.linspace(0, 2 * np.pi, n, endpoint=False)
    x = np.stack([np.cos(s), np.sin(s), 0 * s], 1) * 0.05
    m = Model([RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1e3, closed=True)], gravity=(0, 0, -9.81))
    bcs = BoundaryConditions(m)
    bcs.hold("pin", nodes=[0])
    sim = Simulation(m, bcs, SolverOptions(dt=1e-3))
    log = sim.run(0.02, progress=False)
    assert sim.stepper.last_solver == "sparse"
    assert log["iterations"].max() < 10


def test_too_large_step_recovers_by_halving():
    # A rod whipped hard: the first attempts at dt = 0.05 s fail and are halved.
    rod = straight(n=21, length=0.2)
    m = Model([rod])
    bcs = BoundaryConditions(m)
    bcs.clamp("left", nodes=[0, 1])
    bcs.move("right", nodes=[-2, -1], path=lambda t: [0.0, 0.0, 0.05 * np.sin(200 * t)])
    sim = Simulation(m, bcs, SolverOptions(dt=0.05, max_iterations=6))
    sim.run(0.1, progress=False)
    assert sim.n_failures > 0
    assert sim.state.time == pytest.approx(0.1)


def test_impossible_case_raises_with_last_good_state():
    rod = straight(n=21, length=0.2)
    m = Model([rod])
    bcs = BoundaryConditions(m)
    bcs.clamp("left", nodes=[0, 1])
    # the right end is yanked 1 m away instantly at t = 0.01 s: no step size can follow it
    bcs.move("right", nodes=[-2, -1], path=lambda t: [0.0, 0.0, 1.0 if t > 0.01 else 0.0])
    sim = Simulation(m, bcs, SolverOptions(dt=5e-3, dt_min=5e-3 / 8, max_iterations=5))
    with pytest.raises(SimulationError) as info:
        sim.run(0.05, progress=False)
    err = info.value
    assert err.last_good_state is not None
    assert err.time == pytest.approx(0.01, abs=1e-9)
    assert np.all(np.isfinite(err.last_good_state.q))


def test_failure_message_says_where_the_residual_is_largest():
    """A failed solve names the rod and node of its largest residual (and, with contact, the nearest
    contact pair and the angle between its edges)."""
    from knotsim.contact.model import Contact, ContactOptions

    cross = RodSpec(np.array([[0.1, -0.1 + 0.01 * k, 3.3e-3] for k in range(21)]), radius=1.6e-3,
                    youngs_modulus=0.18e6, density=1180.0, name="cross")
    m = Model([straight(n=21), cross])
    bcs = BoundaryConditions(m)
    bcs.clamp("left", rod=0, nodes=[0, 1])
    bcs.move("yank", rod=0, nodes=[-2, -1], path=lambda t: [0.0, 0.0, 1.0 if t > 0.01 else 0.0])
    contact = Contact(m, ContactOptions(mu=0.3))
    sim = Simulation(m, bcs, SolverOptions(dt=5e-3, dt_min=5e-3 / 4, max_iterations=3), interactions=[contact])
    with pytest.raises(SimulationError) as info:
        sim.run(0.05, progress=False)
    msg = str(info.value)
    assert "largest residual" in msg and "at rod" in msg and ("node" in msg or "edge" in msg), msg


def test_huge_end_force_is_a_simulation_error_not_a_traceback():
    """A 1e9 N compressive end force makes a Newton trial divide by zero (an edge collapsed to a
    point): that is a failed step that is halved, then a SimulationError with the last good state."""
    rod = straight(n=11, length=0.1)
    m = Model([rod])
    bcs = BoundaryConditions(m)
    bcs.clamp("left", nodes=[0, 1])
    bcs.force("push", nodes=[-1], force=(-1e9, 0.0, 0.0))
    sim = Simulation(m, bcs, SolverOptions(dt=1e-3, dt_min=1e-3 / 16))
    with pytest.raises(SimulationError) as info:
        sim.run(0.01, progress=False)
    assert sim.n_failures >= 4
    good = info.value.last_good_state
    assert good is not None and np.all(np.isfinite(good.q))


def test_closed_option_sets_are_enums_whose_members_are_their_strings():
    from knotsim.errors import ConfigError
    from knotsim.solver.stepper import LinearSolver, Predictor, SolverOptions

    opts = SolverOptions(linear_solver="sparse", predictor=Predictor.VELOCITY)
    opts.validate()
    assert opts.linear_solver is LinearSolver.SPARSE and opts.linear_solver == "sparse"
    assert opts.predictor is Predictor.VELOCITY
    with pytest.raises(ConfigError, match=r"solver\.predictor: must be one of 'acceleration', 'velocity', 'previous'"):
        SolverOptions(predictor="guess").validate()
