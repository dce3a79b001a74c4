"""Turning grips: move(..., rotation=...) turns a group rigidly about an axis, its material frames
with it; the reaction moment about the pivot; a clamped beam with a rotated end (4 EI a / L)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import knotsim as ks
from knotsim.bc.rigid import Rotation, frame_turn, rotation_matrix
from knotsim.errors import ConfigError
from knotsim.io.config import load_config
from knotsim.rods.frames import material_frames, signed_angle, transport

L = 0.1


def beam(n):
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0.0, L, n)
    rod = ks.RodSpec(x, radius=1e-3, youngs_modulus=1e7, density=1000.0, name="rod")
    return ks.Model([rod], damping=0.05), rod


def frames(model, state):
    ne = model.n_edges
    m1, m2 = np.zeros((ne, 3)), np.zeros((ne, 3))
    material_frames(state.d1, state.tangents, state.q[model.edge_theta_dof], m1, m2)
    return m1, m2


@pytest.mark.parametrize("axis", [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
def test_quarter_turn_moves_nodes_and_material_frames_with_the_grip(axis):
    model, _ = beam(21)
    bcs = ks.BoundaryConditions(model)
    bcs.clamp("left", nodes=[0, 1])
    bcs.move("grip", nodes=[-2, -1], rotation={"axis": axis, "rate": math.pi / 2 / 0.5})
    sim = ks.Simulation(model, bcs, ks.SolverOptions(dt=5e-3))
    m1_0, m2_0 = frames(model, sim.state)
    x0 = model.node_positions(sim.state.q)
    sim.advance(0.5)
    rot = rotation_matrix(np.asarray(axis) / np.linalg.norm(axis), math.pi / 2)
    x = model.node_positions(sim.state.q)
    pivot = x0[-2:].mean(axis=0)
    assert np.allclose(x[-2:], pivot + (x0[-2:] - pivot) @ rot.T, atol=1e-12)
    edge = (x[-1] - x[-2]) / np.linalg.norm(x[-1] - x[-2])
    assert np.linalg.norm(edge - rot @ np.array([1.0, 0, 0])) < 1e-9
    m1, m2 = frames(model, sim.state)
    assert np.linalg.norm(m1[-1] - rot @ m1_0[-1]) < 1e-9 and np.linalg.norm(m2[-1] - rot @ m2_0[-1]) < 1e-9
    log = sim.log()
    assert log["grip_angle"].iloc[-1] == pytest.approx(math.pi / 2)
    assert {"grip_mx", "grip_my", "grip_mz", "grip_fx"} <= set(log.columns)
    if axis == [1.0, 0.0, 0.0]:  # about the edge: that is twist
        assert sim.state.q[model.edge_theta_dof[-1]] == pytest.approx(math.pi / 2, abs=1e-9)


def test_frame_turn_against_transport_and_signed_angle():
    """Reference: transport a normal vector with the DER kernel and measure the angle to its image."""
    rng = np.random.default_rng(3)
    t_old = rng.standard_normal((30, 3))
    t_old /= np.linalg.norm(t_old, axis=1)[:, None]
    t_old[0] = [0.0, 0.0, 1.0]  # along an axis (degenerate pick of the normal vector)
    for k in range(30):
        ax = rng.standard_normal(3)
        ax /= np.linalg.norm(ax)
        phi = rng.uniform(-2.5, 2.5)
        rot = rotation_matrix(ax, phi)
        a = t_old[k]
        b = rot @ a
        got = frame_turn(a[None], b[None], rot)[0]
        u = np.cross(a, rng.standard_normal(3))
        u /= np.linalg.norm(u)
        pu = transport(tuple(u), tuple(a), tuple(b))
        assert got == pytest.approx(signed_angle(pu, tuple(rot @ u), tuple(b)), abs=1e-12)
    assert frame_turn(np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]),
                      rotation_matrix(np.array([0, 0, 1.0]), math.pi / 2))[0] == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("n", [41, 101])
def test_clamped_beam_with_a_rotated_end(n):
    """Small rotation a of one clamped end about its centre, the other end clamped: end moment
    4 EI a / L and shear 6 EI a / L^2 (linear beam theory), with L the span between the centres of
    the clamped edges."""
    model, rod = beam(n)
    a = 1e-4
    bcs = ks.BoundaryConditions(model)
    bcs.clamp("left", nodes=[0, 1])
    bcs.move("grip", nodes=[-2, -1], rotation=Rotation([0, 0, 1], rate=a))
    res = ks.solve_static(model, bcs, time=1.0, interactions=bcs.interactions())
    span = L - L / (n - 1)
    assert bcs.log_values["grip_mz"] == pytest.approx(4 * rod.EI * a / span, rel=1e-3)
    assert res.reactions["left"][1] == pytest.approx(6 * rod.EI * a / span**2, rel=1e-3)
    assert res.reactions["grip"][1] == pytest.approx(-6 * rod.EI * a / span**2, rel=1e-3)


def test_run_file_form_and_errors():
    raw = {"rods": [{"name": "rod", "shape": "straight", "length": L, "n_nodes": 11, "radius": 1e-3,
                     "youngs_modulus": 1e7, "density": 1000.0}],
           "bc": [{"type": "clamp", "name": "left", "nodes": [0, 1]},
                  {"type": "move", "name": "grip", "nodes": "-2:", "velocity": [0.0, 0.0, 0.01],
                   "rotate_about": {"axis": [0, 1, 0], "point": [0.1, 0.0, 0.0], "rate": 1.0}}],
           "run": {"duration": 0.01}}
    g = load_config(raw).build_bcs().groups["grip"]
    assert g.rotation.point.tolist() == [0.1, 0.0, 0.0] and g.rotation.rate == 1.0
    del raw["bc"][1]["velocity"]
    raw["bc"][1]["rotate_about"] = {"axis": [0, 0, 0], "rate": 1.0}
    with pytest.raises(ConfigError) as info:
        load_config(raw)
    assert info.value.field == "bc[1].rotate_about.axis"
    raw["bc"][1]["rotate_about"] = {"axis": [0, 0, 1], "rate": 1.0, "point": "middle"}
    with pytest.raises(ConfigError) as info:
        load_config(raw)
    assert info.value.field == "bc[1].rotate_about.point"
    model, _ = beam(11)
    with pytest.raises(ConfigError) as info:
        ks.BoundaryConditions(model).move("g", nodes=[-1], rotation={"axis": [0, 0, 1]})
    assert info.value.field == "bc.g.rotation.rate"
