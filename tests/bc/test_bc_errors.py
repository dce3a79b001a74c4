"""Boundary conditions through the Python API: error messages, start/stop windows, release."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.bc import BoundaryConditions, Waypoints
from knotsim.errors import ConfigError
from knotsim.rods import Model, RodSpec
from knotsim.simulation import Simulation
from knotsim.solver.stepper import SolverOptions

N = 11
L = 0.1


def make_model(gravity=(0.0, 0.0, 0.0)) -> Model:
    x = np.zeros((N, 3))
    x[:, 0] = np.linspace(0.0, L, N)
    return Model([RodSpec(x, radius=1e-3, youngs_modulus=1e7, density=1000.0, name="rope")], gravity=gravity)


@pytest.fixture
def bcs() -> BoundaryConditions:
    return BoundaryConditions(make_model())


# ------------------------------------------------------------------------------------------ errors
@pytest.mark.parametrize("nodes", [[0, N], [-N - 1], [100]])
def test_node_index_out_of_range(bcs, nodes):
    with pytest.raises(ConfigError) as info:
        bcs.clamp("left", rod="rope", nodes=nodes)
    assert info.value.field == "bc.left.nodes"
    bad = [n for n in nodes if not -N <= n < N][0]
    assert f"node index {bad} out of range for rod 'rope' with {N} nodes" in str(info.value)
    assert "left" not in bcs.groups


def test_unknown_rod(bcs):
    with pytest.raises(ConfigError, match=r"bc\.a\.rod: unknown rod 'rop'"):
        bcs.hold("a", rod="rop", nodes=[0])
    with pytest.raises(ConfigError, match=r"bc\.a\.rod: rod index 2 out of range"):
        bcs.hold("a", rod=2, nodes=[0])


def test_non_integer_nodes(bcs):
    with pytest.raises(ConfigError, match="node indices must be integers"):
        bcs.hold("a", nodes=[0.5])


def test_clamped_and_moved_while_both_active(bcs):
    bcs.clamp("left", nodes=[0, 1])
    with pytest.raises(ConfigError) as info:
        bcs.move("drag", nodes=[1, 2], path=[1e-3, 0, 0], start=1.0)
    msg = str(info.value)
    assert info.value.field == "bc.drag.nodes"
    assert "node 1 of rod 'rope' is already prescribed by clamp 'left' while both are active" in msg
    assert "stop time <= 1.0" in msg
    assert "drag" not in bcs.groups


def test_overlapping_windows_detected_and_touching_windows_allowed(bcs):
    bcs.clamp("left", nodes=[0, 1], stop=0.5)
    with pytest.raises(ConfigError, match="already prescribed by clamp 'left'"):
        bcs.move("early", nodes=[0, 1], path=[1e-3, 0, 0], start=0.4)
    bcs.move("late", nodes=[0, 1], path=[1e-3, 0, 0], start=0.5)  # [0, 0.5) then [0.5, inf)
    # forces do not prescribe anything: no conflict
    bcs.force("push", nodes=[0], force=[0.0, 0.0, 1e-3])


def test_absolute_path_away_from_centroid(bcs):
    far = Waypoints([0.0, 1.0], [[0.5, 0.0, 0.0], [0.6, 0.0, 0.0]], absolute=True)
    with pytest.raises(ConfigError) as info:
        bcs.move("right", nodes=[-2, -1], path=far)
    assert info.value.field == "bc.right.path"
    assert "path starts at [0.5, 0.0, 0.0] m but the group's centroid is at [0.095, 0.0, 0.0] m" in str(info.value)
    ok = Waypoints([0.0, 1.0], [[0.095, 0.0, 0.0], [0.1, 0.0, 0.0]], absolute=True)
    bcs.move("right", nodes=[-2, -1], path=ok)


def test_bad_paths(bcs):
    with pytest.raises(ConfigError, match=r"bc\.m\.path: a moving group needs a path"):
        bcs.move("m", nodes=[0])
    with pytest.raises(ConfigError, match=r"bc\.m\.velocity: expected 3 finite components"):
        bcs.move("m", nodes=[0], path=[1.0, 2.0])
    with pytest.raises(ConfigError, match="waypoint times must increase"):
        Waypoints([0.0, 1.0, 1.0], np.zeros((3, 3)))
    with pytest.raises(ConfigError, match=r"must start at \(0, 0, 0\)"):
        Waypoints([0.0, 1.0], [[1.0, 0, 0], [2.0, 0, 0]])


def test_bad_windows_and_names(bcs):
    with pytest.raises(ConfigError, match=r"bc\.w\.stop: need start < stop"):
        bcs.hold("w", nodes=[0], start=1.0, stop=0.5)
    with pytest.raises(ConfigError, match=r"bc\.w\.start: must be a time >= 0 s"):
        bcs.hold("w", nodes=[0], start=-1.0)
    with pytest.raises(ConfigError, match="non-empty name"):
        bcs.hold("", nodes=[0])
    bcs.hold("w", nodes=[0])
    with pytest.raises(ConfigError, match=r"bc\.w: a boundary condition with this name already exists"):
        bcs.hold("w", nodes=[5])


def test_rotate_and_load_errors(bcs):
    with pytest.raises(ConfigError, match="give exactly one of rate"):
        bcs.rotate("r", nodes=[-2, -1])
    with pytest.raises(ConfigError, match="at least two adjacent nodes"):
        bcs.rotate("r", nodes=[-1], rate=1.0)
    with pytest.raises(ConfigError, match=r"bc\.f: expected a value of shape \(3,\)"):
        bcs.force("f", nodes=[-1], force=[1.0, 0.0])
    with pytest.raises(ConfigError, match=r"bc\.mo\.edges: edge index out of range"):
        bcs.moment("mo", edges=[N - 1], moment=1e-3)


def test_release_errors(bcs):
    with pytest.raises(ConfigError, match="no boundary condition named 'ghost'"):
        bcs.release("ghost", at=1.0)
    bcs.hold("h", nodes=[0], start=0.5)
    with pytest.raises(ConfigError, match=r"bc\.h\.release: release time 0.5 s is not after the start"):
        bcs.release("h", at=0.5)
    bcs.release("h", at=0.7)
    assert bcs.groups["h"].stop == 0.7


# ------------------------------------------------------------------------------------------ windows
def _node(sim, k):
    return sim.model.node_positions(sim.state.q)[k].copy()


def test_released_group_keeps_its_velocity():
    """The whole rod is moved at v, then released: with no forces it keeps moving at v."""
    v = np.array([0.01, 0.0, 0.005])
    dt = 1e-3
    model = make_model()
    bcs = BoundaryConditions(model)
    bcs.move("all", nodes=list(range(N)), path=v)
    bcs.release("all", at=0.01)
    sim = Simulation(model, bcs, SolverOptions(dt=dt))
    x0 = _node(sim, -1)
    sim.advance(0.01)
    x_release = _node(sim, -1)
    np.testing.assert_allclose(x_release - x0, v * 0.01, atol=1e-12)
    sim.advance(0.02)
    x_after = _node(sim, -1)
    np.testing.assert_allclose(x_after - x_release, v * 0.01, rtol=1e-6, atol=1e-12)
    log = sim.log()
    after = log[log["time"] > 0.01 + 1e-9]
    assert np.all(after["all_force"] == 0.0)  # released: no reaction
    assert after["iterations"].max() <= 3


def test_released_end_keeps_moving():
    """An end moved sideways and released at t keeps moving sideways (bending is slow: the first
    mode's period is about 0.36 s)."""
    model = make_model()
    bcs = BoundaryConditions(model)
    bcs.clamp("left", nodes=[0, 1])
    bcs.move("right", nodes=[-2, -1], path=[0.0, 0.05, 0.0])
    bcs.release("right", at=0.01)
    sim = Simulation(model, bcs, SolverOptions(dt=1e-3))
    sim.advance(0.009)  # the last step with the group active ends at 0.009 (window [0, 0.01))
    y_release = _node(sim, -1)[1]
    assert y_release == pytest.approx(0.05 * 0.009, rel=1e-9)
    sim.advance(0.015)
    assert _node(sim, -1)[1] > y_release + 0.5 * 0.05 * 0.006


def test_group_starting_later_captures_position_at_activation():
    """A hold starting at t0 holds the node where it is at t0, not where it started."""
    model = make_model(gravity=(0.0, 0.0, -9.81))
    bcs = BoundaryConditions(model)
    bcs.clamp("left", nodes=[0, 1])
    bcs.hold("tip", nodes=[-1], start=0.02)
    sim = Simulation(model, bcs, SolverOptions(dt=1e-3))
    x0 = _node(sim, -1)
    sim.advance(0.02)
    x_start = _node(sim, -1)
    assert x_start[2] < x0[2] - 1e-4  # it fell before the hold became active
    sim.advance(0.04)
    np.testing.assert_allclose(_node(sim, -1), x_start, atol=1e-12)
    log = sim.log()
    assert np.all(log.loc[log["time"] < 0.02 - 1e-9, "tip_force"] == 0.0)
    assert log["tip_fz"].iloc[-1] > 0.0  # holds the tip up against gravity


def test_clamp_then_move_same_nodes():
    """A clamp released at t0 followed by a move on the same nodes from t0."""
    model = make_model()
    bcs = BoundaryConditions(model)
    bcs.clamp("left", nodes=[0, 1])
    bcs.clamp("right", nodes=[-2, -1], stop=0.005)
    bcs.move("pull", nodes=[-2, -1], path=[1e-2, 0.0, 0.0], start=0.005)
    sim = Simulation(model, bcs, SolverOptions(dt=1e-3))
    x0 = _node(sim, -1)
    sim.advance(0.005)
    np.testing.assert_allclose(_node(sim, -1), x0, atol=1e-12)
    sim.advance(0.01)
    np.testing.assert_allclose(_node(sim, -1), x0 + [1e-2 * 0.005, 0, 0], atol=1e-12)


def test_from_current_waypoints_reach_absolute_targets_from_wherever_the_group_is():
    import numpy as np

    from knotsim.bc import Waypoints
    from knotsim.rods import Model, RodSpec
    from knotsim.simulation import Simulation
    from knotsim.solver.stepper import SolverOptions

    x = np.zeros((11, 3))
    x[:, 0] = np.linspace(0.0, 0.1, 11)
    m = Model([RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0)], damping=0.05)
    bcs = BoundaryConditions(m)
    bcs.clamp("left", nodes=[0, 1])
    # the right end first moves 5 mm up, then a grip activated at 0.1 s takes it to a world point
    bcs.move("lift", nodes=[-1], path=[0.0, 0.0, 0.05], stop=0.1)
    bcs.move("grip", nodes=[-1], start=0.1, path=Waypoints([0.1, 0.2], [[0.09, 0.01, 0.0], [0.09, 0.01, 0.0]],
                                                           absolute=True, from_current=True))
    sim = Simulation(m, bcs, SolverOptions(dt=5e-3))
    sim.run(0.1, progress=False)
    start = m.node_positions(sim.state.q)[-1].copy()
    assert start[2] == pytest.approx(0.00475, rel=1e-6)  # lift active for steps ending before 0.1 s
    sim.run(0.05, progress=False)  # half way along the first leg
    mid = m.node_positions(sim.state.q)[-1]
    np.testing.assert_allclose(mid, 0.5 * (start + np.array([0.09, 0.01, 0.0])), atol=1e-9)
    sim.run(0.1, progress=False)
    np.testing.assert_allclose(m.node_positions(sim.state.q)[-1], [0.09, 0.01, 0.0], atol=1e-9)


def test_from_current_needs_absolute_and_positive_first_time():
    from knotsim.bc import Waypoints

    with pytest.raises(ConfigError, match="from_current: from_current needs absolute=true"):
        Waypoints([1.0], [[0, 0, 0]], from_current=True)
    with pytest.raises(ConfigError, match="times: with from_current the first time must be > 0"):
        Waypoints([0.0, 1.0], [[0, 0, 0], [1, 0, 0]], absolute=True, from_current=True)


def test_every_time_dependent_condition_counts_from_its_start():
    """One time convention: force callables, like paths, take the time since the group started."""
    import numpy as np

    from knotsim.bc import BoundaryConditions
    from knotsim.rods import Model, RodSpec

    x = np.zeros((5, 3))
    x[:, 0] = np.linspace(0, 0.1, 5)
    model = Model([RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0)])
    bcs = BoundaryConditions(model)
    bcs.force("f", nodes=[-1], force=lambda e: [e, 0.0, 0.0], start=2.0)
    _, _, f = bcs.evaluate(2.5, np.zeros(model.n_dofs), 2.4)
    assert f[model.node_dof[-1]] == 0.5  # 0.5 s after its start, not 2.5
