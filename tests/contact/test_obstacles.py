"""Obstacles as stepper interactions: weight on a floor, a moving floor dragging a rope, poses of
moving and rotating obstacles, the interaction's residual and Jacobian against finite differences
of the whole model, checkpoints and errors."""

from __future__ import annotations

import numpy as np
import pytest

import knotsim as ks
from knotsim.contact.obstacles import rotation_matrix
from knotsim.errors import ConfigError, GeometryError
from knotsim.solver.state import initial_state


def lying_rope(n=21, length=0.2, z=1.6e-3 + 1e-4, h=1.6e-3):
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0, length, n)
    x[:, 2] = z
    return ks.RodSpec(x, radius=h, youngs_modulus=1e6, density=1000)


def test_rod_on_floor_carries_its_weight():
    model = ks.Model([lying_rope()], gravity=(0, 0, -9.81), damping=0.01)
    floor = ks.Plane(model, "floor", point=(0, 0, 0), normal=(0, 0, 1), mu=0.3)
    log = ks.Simulation(model, ks.BoundaryConditions(model), ks.SolverOptions(dt=1e-3),
                        interactions=[floor]).run(0.3)
    weight = model.total_mass() * 9.81
    last = log.iloc[-1]
    assert last["floor_fz"] == pytest.approx(-weight, rel=1e-5)  # still settling: 2e-6 at 0.3 s
    assert abs(last["floor_fx"]) <= 1e-9 * weight and abs(last["floor_fy"]) <= 1e-9 * weight
    assert last["floor_n_contacts"] == 21
    # resting, not sinking: the gap is positive and below delta
    assert 0 < last["floor_min_gap"] < floor.delta
    # moment about the floor's point (origin): the weight acts at the rope's middle x = 0.1 m
    assert last["floor_my"] == pytest.approx(0.1 * weight, rel=1e-5)
    assert np.array_equal(floor.reaction()[0], [last["floor_fx"], last["floor_fy"], last["floor_fz"]])


def test_tilted_floor_is_the_same_floor():
    """A floor given by a non-unit normal and another point of the plane gives the same result."""
    out = []
    for point, normal in (((0, 0, 0), (0, 0, 1)), ((0.3, -2.0, 0.0), (0, 0, 5.0))):
        model = ks.Model([lying_rope()], gravity=(0, 0, -9.81), damping=0.01)
        floor = ks.Plane(model, "floor", point=point, normal=normal, mu=0.3)
        log = ks.Simulation(model, ks.BoundaryConditions(model), ks.SolverOptions(dt=1e-3),
                            interactions=[floor]).run(0.05)
        out.append(log["floor_fz"].to_numpy())
    assert np.allclose(out[0], out[1], rtol=1e-9, atol=0)


def test_moving_floor_drags_the_rope_along():
    """A conveyor: the rope settles on the belt for 0.2 s, then the belt moves at 5 cm/s (μ = 0.5):
    friction accelerates the rope at μ g (slip) until it moves with the belt (stick)."""
    model = ks.Model([lying_rope()], gravity=(0, 0, -9.81), damping=0.01)
    path = ks.Waypoints([0.0, 0.2], [[0, 0, 0], [0, 0, 0]], then_velocity=[0.05, 0.0, 0.0])
    belt = ks.Plane(model, "belt", point=(0, 0, 0), normal=(0, 0, 1), mu=0.5, path=path)
    sim = ks.Simulation(model, ks.BoundaryConditions(model), ks.SolverOptions(dt=5e-4), interactions=[belt])
    sim.run(0.202)
    v1 = sim.state.v[model.node_dof].mean()
    sim.run(0.004)
    v2 = sim.state.v[model.node_dof].mean()
    assert 0.0 < v1 < v2 < 0.05
    # slipping phase: acceleration mu g (the law's smooth switch is saturated, |v_T| >> nu)
    assert (v2 - v1) / 0.004 == pytest.approx(0.5 * 9.81, rel=0.02)
    sim.run(0.1)
    v = sim.state.v[model.node_dof]
    # then sticking: the rope moves with the belt
    assert v.mean() == pytest.approx(0.05, rel=1e-3)
    assert np.max(np.abs(sim.state.v[model.node_dof + 1])) <= 1e-9


def test_poses_of_moving_and_rotating_obstacles():
    model = ks.Model([lying_rope()])
    w = np.array([0.0, 0.0, 2.0])
    post = ks.Capsule(model, "post", a=(0.1, 0, 0), b=(0.3, 0, 0), radius=0.01, angular_velocity=w,
                      pivot=(0.1, 0, 0), path=[0, 0.5, 0])
    t = 0.3
    R = rotation_matrix(w * t)
    g = post.geometry(t)
    shift = np.array([0, 0.5 * t, 0])
    assert np.allclose(g[:3], [0.1, 0, 0] + shift)
    assert np.allclose(g[3:6], np.array([0.1, 0, 0]) + shift + R @ [0.2, 0, 0])
    assert np.allclose(R @ R.T, np.eye(3)) and np.allclose(R @ [0, 0, 1], [0, 0, 1])
    # a capsule spinning about its own axis keeps its geometry (a driven pulley)
    pulley = ks.Capsule(model, "pulley", a=(0, -1, 0), b=(0, 1, 0), radius=0.05, angular_velocity=(0, 3.0, 0))
    assert np.allclose(pulley.geometry(0.7), pulley.geometry(0.0))
    # waypoints move a sphere; absolute waypoints start at its centre
    ball = ks.Sphere(model, "ball", center=(0, 0, 1), radius=0.1,
                     path=ks.Waypoints([0, 1], [[0, 0, 1], [0, 0, 2]], absolute=True))
    assert np.allclose(ball.geometry(0.5)[:3], [0, 0, 1.5])
    with pytest.raises(ConfigError, match="obstacles.ball2.waypoints"):
        ks.Sphere(model, "ball2", center=(0, 0, 1), radius=0.1,
                  path=ks.Waypoints([0, 1], [[0, 0, 0], [0, 0, 2]], absolute=True))


@pytest.mark.parametrize("make", [
    lambda m: ks.Plane(m, "p", point=(0, 0, 0), normal=(0.1, 0.2, 1.0), mu=0.4, path=[0.02, 0, 0.01],
                       stiffness=50.0, delta=2e-3),
    lambda m: ks.Capsule(m, "c", a=(-0.1, 0.0, -0.03), b=(0.3, 0.0, -0.03), radius=0.03, mu=0.4,
                         angular_velocity=(1.0, 0, 0.5), stiffness=50.0, delta=2e-3),
    lambda m: ks.Sphere(m, "s", center=(0.1, 0.0, -0.04), radius=0.04, mu=0.4, stiffness=50.0, delta=2e-3),
])
def test_interaction_jacobian_matches_fd_of_residual(make):
    """``evaluate``'s blocks are ``∂residual/∂q`` for the whole model (FD, step 1e-7 m)."""
    rng = np.random.default_rng(0)
    model = ks.Model([lying_rope(n=11, z=1.0e-3)])
    obs = make(model)
    st = initial_state(model)
    st.q = st.q + rng.normal(0, 3e-4, st.q.shape)
    obs.begin_step(st, 0.01)
    q_prev = st.q.copy()
    q = q_prev + rng.normal(0, 1e-4, q_prev.shape)
    r0 = np.zeros(model.n_dofs)
    _, blocks = obs.evaluate(q, q_prev, 0.01, r0, True)
    blocks = blocks.copy()
    J = np.zeros((model.n_dofs, model.n_dofs))
    for dofs, b in zip(obs.block_dofs(), blocks, strict=True):
        J[np.ix_(dofs, dofs)] += b
    assert np.count_nonzero(r0) >= 3  # some nodes touch
    h = 1e-7
    Jf = np.zeros_like(J)
    for k in range(model.n_dofs):
        dq = np.zeros(model.n_dofs)
        dq[k] = h
        rp, rm = np.zeros(model.n_dofs), np.zeros(model.n_dofs)
        obs.evaluate(q + dq, q_prev, 0.01, rp, False)
        obs.evaluate(q - dq, q_prev, 0.01, rm, False)
        Jf[:, k] = (rp - rm) / (2 * h)
    assert np.max(np.abs(Jf - J)) <= 1e-5 * np.max(np.abs(J))


def test_checkpoint_state_round_trip(tmp_path):
    model = ks.Model([lying_rope()], gravity=(0, 0, -9.81))
    floor = ks.Plane(model, "floor", mu=0.3)
    sim = ks.Simulation(model, ks.BoundaryConditions(model), ks.SolverOptions(dt=1e-3), interactions=[floor])
    sim.run(0.01)
    path = tmp_path / "checkpoint.npz"
    sim.save_checkpoint(path)
    other = ks.Plane(model, "floor", mu=0.3)
    again = ks.Simulation(model, ks.BoundaryConditions(model), ks.SolverOptions(dt=1e-3), interactions=[other])
    again.restore(path)
    assert again.state.memory.interactions["floor"] == floor.memory
    again.step()  # the obstacle takes the memory the state carries
    assert other.memory is again.state.memory.interactions["floor"]


def test_errors_name_the_field():
    model = ks.Model([lying_rope()])
    with pytest.raises(ConfigError, match=r"obstacles\.f\.normal"):
        ks.Plane(model, "f", normal=(0, 0, 0))
    with pytest.raises(ConfigError, match=r"obstacles\.c\.radius"):
        ks.Capsule(model, "c", radius=-1.0)
    with pytest.raises(ConfigError, match=r"obstacles\.c\.mu"):
        ks.Capsule(model, "c", mu=-0.1)
    with pytest.raises(ConfigError, match=r"obstacles\.c\.rods"):
        ks.Capsule(model, "c", rods=["nope"])
    sink = ks.Plane(model, "sink", point=(0, 0, 0.01))
    with pytest.raises(GeometryError, match="sink"):
        sink.check_start(initial_state(model).q)


def test_only_selected_rods_touch():
    a = lying_rope()
    x = a.positions.copy()
    x[:, 1] = 0.05
    b = ks.RodSpec(x, radius=1.6e-3, youngs_modulus=1e6, density=1000, name="other")
    model = ks.Model([a, b], gravity=(0, 0, -9.81))
    floor = ks.Plane(model, "floor", rods=["other"])
    assert set(model.node_rod[floor.nodes]) == {1}
    sim = ks.Simulation(model, ks.BoundaryConditions(model), ks.SolverOptions(dt=1e-3), interactions=[floor])
    sim.run(0.05)
    z = model.node_positions(sim.state.q)[:, 2]
    assert np.all(z[model.node_rod == 1] > 1.0e-3) and np.all(z[model.node_rod == 0] < 0.0)
