"""Spring grips (implicit: FD-checked force and Jacobian, F = k delta at equilibrium) and load-cell
grips (a PI controller holds a target force)."""

from __future__ import annotations

import numpy as np
import pytest

import knotsim as ks
from knotsim.bc import Waypoints
from knotsim.errors import ConfigError
from knotsim.io.checkpoint import memory_sections, read_checkpoint
from knotsim.io.config import load_config
from knotsim.runspec import build_simulation
from knotsim.solver.state import RunMemory, initial_state

L = 0.1


def rod_model(n=11, damping=0.05):
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0.0, L, n)
    rod = ks.RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0, name="rope")
    return ks.Model([rod], damping=damping), rod


def spring_energy_reference(model, group, q):
    """Slow obvious reference: sum over nodes of k/(2n) |x - a|^2."""
    e = 0.0
    for i, node in enumerate(group.nodes):
        x = q[model.node_dof[node]:model.node_dof[node] + 3]
        e += 0.5 * group.stiffness / len(group.nodes) * float(np.sum((x - group.target[i]) ** 2))
    return e


@pytest.mark.parametrize("offset", [1e-3, 0.0])  # 0: nodes exactly at their anchors (degenerate)
def test_spring_force_and_jacobian_against_finite_differences(offset):
    model, _ = rod_model()
    bcs = ks.BoundaryConditions(model)
    bcs.spring("s", nodes=[-3, -1], stiffness=40.0, path=[offset, 2 * offset, 0.0])
    q0 = initial_state(model).q
    bcs.evaluate(1.0, q0, 0.0)
    inter = bcs.interactions()[0]
    g = bcs.groups["s"]
    rng = np.random.default_rng(0)
    q = q0 + (1e-4 if offset else 0.0) * rng.standard_normal(q0.size)
    r = np.zeros(q.size)
    energy, blocks = inter.evaluate(q, q0, 1e-3, r, True)
    assert energy == pytest.approx(spring_energy_reference(model, g, q), rel=1e-12, abs=1e-300)
    h = 1e-7
    dofs = inter.block_dofs()
    for b, row in enumerate(dofs):
        for j, d in enumerate(row):
            qp, qm = q.copy(), q.copy()
            qp[d] += h
            qm[d] -= h
            fd = (spring_energy_reference(model, g, qp) - spring_energy_reference(model, g, qm)) / (2 * h)
            assert r[d] == pytest.approx(fd, rel=1e-6, abs=1e-10)
            rp, rm = np.zeros(q.size), np.zeros(q.size)
            inter.evaluate(qp, q0, 1e-3, rp, False)
            inter.evaluate(qm, q0, 1e-3, rm, False)
            assert np.allclose(blocks[b][:, j], (rp[row] - rm[row]) / (2 * h), rtol=1e-6, atol=1e-9)
    mask = np.ones(q.size, bool)
    mask[dofs.ravel()] = False
    assert not np.any(r[mask])


def test_spring_grip_static_equilibrium_is_k_delta():
    model, rod = rod_model()
    k, pull = 20.0, 2e-3
    bcs = ks.BoundaryConditions(model)
    bcs.clamp("left", nodes=[0, 1])
    bcs.spring("grip", nodes=[-1], stiffness=k, path=Waypoints([0.0, 1.0], [[0, 0, 0], [pull, 0, 0]]))
    res = ks.solve_static(model, bcs, time=2.0, interactions=bcs.interactions())
    x_end = model.node_positions(res.state.q)[-1, 0]
    stats = bcs.interactions()[0].stats()
    delta = L + pull - x_end
    assert stats["grip_fx"] == pytest.approx(k * delta, rel=1e-9)
    assert stats["grip_anchor_x"] == pytest.approx(L + pull)
    ea = rod.EA
    # springs in series: the rod (EA/L over the free length) and the grip spring
    assert x_end - L == pytest.approx(pull * k / (k + ea / (L - L / 10)), rel=1e-3)
    assert res.reactions["left"][0] == pytest.approx(-stats["grip_fx"], rel=1e-6)


def test_spring_grip_dynamic_run_settles_and_needs_its_interaction_in_static_solves():
    model, _ = rod_model()
    bcs = ks.BoundaryConditions(model)
    bcs.clamp("left", nodes=[0, 1])
    bcs.spring("grip", nodes=[-1], stiffness=20.0, path=Waypoints([0.0, 0.2], [[0, 0, 0], [2e-3, 0, 0]]))
    sim = ks.Simulation(model, bcs, ks.SolverOptions(dt=2e-3))
    log = sim.run(0.6)
    f = log["grip_fx"].iloc[-1]
    assert f == pytest.approx(-log["left_fx"].iloc[-1], rel=1e-3)
    assert f == pytest.approx(20.0 * log["grip_stretch"].iloc[-1], rel=1e-9)
    with pytest.raises(ConfigError, match="interactions=bcs.interactions"):
        ks.solve_static(model, bcs, time=1.0)


def test_load_cell_holds_its_target_within_one_percent():
    model, rod = rod_model()
    target = 0.05  # N
    stiffness = rod.EA / (L - 2 * L / 10)  # of the rod between the clamped edges, N/m
    bcs = ks.BoundaryConditions(model)
    bcs.clamp("left", nodes=[0, 1])
    bcs.load_cell("cell", nodes=[-2, -1], direction=[1, 0, 0], target=target, ki=1.0 / (stiffness * 0.05))
    log = ks.Simulation(model, bcs, ks.SolverOptions(dt=2e-3)).run(0.6)
    late = log[log["time"] > 0.4]
    assert np.all(np.abs(late["cell_fx"] - target) < 0.01 * target)
    assert late["cell_displacement"].iloc[-1] == pytest.approx(target / stiffness, rel=0.02)
    assert late["cell_target"].iloc[-1] == target and abs(late["cell_error"].iloc[-1]) < 1e-3 * target


def test_run_file_forms_and_checkpointed_state(tmp_path):
    raw = {"rods": [{"name": "rope", "shape": "straight", "length": L, "n_nodes": 11, "radius": 1e-3,
                     "youngs_modulus": 1e6, "density": 1000.0}],
           "model": {"damping": 0.05},
           "bc": [{"type": "clamp", "name": "left", "nodes": [0, 1]},
                  {"type": "load_cell", "name": "cell", "nodes": [-2, -1], "direction": [1, 0, 0],
                   "ramp": {"from": 0.0, "to": 0.05, "duration": 0.1}, "ki": 0.05, "kp": 1e-3, "max_speed": 0.1},
                  {"type": "spring", "name": "side", "nodes": [5], "stiffness": 5.0, "velocity": [0, 0.01, 0]}],
           "solver": {"dt": 2e-3}, "run": {"duration": 0.1}}
    sim = build_simulation(load_config(raw))
    log = sim.run(0.1)
    assert {"cell_displacement", "side_fy", "side_anchor_y"} <= set(log.columns)
    sections = memory_sections(sim.state.memory)
    assert sections["bc/cell"][0]["u"] == pytest.approx(log["cell_displacement"].iloc[-1])
    sim.save_checkpoint(tmp_path / "checkpoint.npz")
    fresh = load_config(raw).build_bcs()
    fresh.use_memory(read_checkpoint(tmp_path / "checkpoint.npz").state(RunMemory(bc=fresh.memory())).memory.bc)
    assert fresh.groups["cell"].cell.memory.integral == sim.bcs.groups["cell"].cell.memory.integral
    assert np.array_equal(fresh.groups["side"].anchor, sim.bcs.groups["side"].anchor)
    bad = dict(raw, bc=[dict(raw["bc"][1], ki=-1.0)])
    with pytest.raises(ConfigError) as info:
        load_config(bad)
    assert info.value.field == "bc[0].ki"
    bad = dict(raw, bc=[dict(raw["bc"][2], stiffness=0.0)])
    with pytest.raises(ConfigError) as info:
        load_config(bad)
    assert info.value.field == "bc[0].stiffness"
