"""Partial constraints: pin (chosen coordinates), slide (rail), plane (symmetry plane); their
reactions, overlaps, run-file form and errors; a pinned-pinned column buckles at the Euler load."""

from __future__ import annotations

import numpy as np
import pytest

import knotsim as ks
from knotsim.bc import BoundaryConditions
from knotsim.errors import ConfigError
from knotsim.io.config import load_config

N = 11


def rod_model(gravity=(0.0, 0.0, 0.0), n=N, length=0.1) -> ks.Model:
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0.0, length, n)
    return ks.Model([ks.RodSpec(x, radius=1e-3, youngs_modulus=1e7, density=1000.0, name="rope")],
                    gravity=gravity, damping=0.05)


def test_pin_prescribes_only_its_axes():
    m = rod_model()
    bcs = BoundaryConditions(m)
    bcs.pin("p", rod="rope", nodes=[0, 3], axes="xz")
    q = np.arange(m.n_dofs, dtype=float)
    dofs, vals, _ = bcs.evaluate(0.001, q, 0.0)
    expected = np.array([m.node_dof[0], m.node_dof[0] + 2, m.node_dof[3], m.node_dof[3] + 2])
    assert dofs.tolist() == expected.tolist() and np.array_equal(vals, q[expected])
    # a rail along y fixes x and z; a plane normal to y fixes y
    assert bcs.slide("r", rod="rope", nodes=[5], along=[0, 2.0, 0]).axes.tolist() == [True, False, True]
    assert bcs.plane("s", rod="rope", nodes=[6], normal=[0, -1, 0]).axes.tolist() == [False, True, False]
    # twist: the edges between the nodes, or a single node's own edge
    assert bcs.pin("t", rod="rope", nodes=[-1], twist=True).edges.tolist() == [N - 2]
    assert bcs.pin("u", rod="rope", nodes=[7, 8], axes="y", twist=True).edges.tolist() == [7]


def test_disjoint_axes_may_share_a_node_overlapping_ones_may_not():
    m = rod_model()
    bcs = BoundaryConditions(m)
    bcs.pin("x", rod="rope", nodes=[0], axes="x")
    bcs.pin("yz", rod="rope", nodes=[0], axes="yz")
    with pytest.raises(ConfigError, match="already prescribed") as info:
        bcs.hold("h", rod="rope", nodes=[0])
    assert info.value.field == "bc.h.nodes"


@pytest.mark.parametrize("call,field", [
    (lambda b: b.pin("p", rod="rope", nodes=[0], axes="xq"), "bc.p.axes"),
    (lambda b: b.pin("p", rod="rope", nodes=[0], axes=""), "bc.p.axes"),
    (lambda b: b.pin("p", rod="rope", nodes=[0], axes="xx"), "bc.p.axes"),
    (lambda b: b.slide("s", rod="rope", nodes=[0], along=[1, 1, 0]), "bc.s.along"),
    (lambda b: b.plane("s", rod="rope", nodes=[0], normal=[0, 0, 0]), "bc.s.normal"),
])
def test_errors(call, field):
    with pytest.raises(ConfigError) as info:
        call(BoundaryConditions(rod_model()))
    assert info.value.field == field


def test_rail_and_symmetry_plane_in_motion():
    """Gravity (1, 0, -9.81): a rod on a frictionless guide plane z = const slides along x and carries
    its weight in z; an end on a rail along x moves only in x."""
    m = rod_model(gravity=(1.0, 0.0, -9.81))
    bcs = BoundaryConditions(m)
    bcs.plane("guide", rod="rope", nodes="all", normal=[0, 0, 1])
    sim = ks.Simulation(m, bcs, ks.SolverOptions(dt=1e-3))
    log = sim.run(0.05)
    x = m.node_positions(sim.state.q)
    assert np.allclose(x[:, 2], 0.0, atol=0) and np.all(x[:, 0] - np.linspace(0, 0.1, N) > 0.0)
    weight = m.total_mass() * 9.81
    assert log["guide_fz"].iloc[-1] == pytest.approx(weight, rel=1e-6)
    assert log["guide_fx"].iloc[-1] == 0.0 and log["guide_fy"].iloc[-1] == 0.0
    m = rod_model(gravity=(1.0, 0.0, -9.81))
    bcs = BoundaryConditions(m)
    bcs.slide("rail", rod="rope", nodes=[0], along=[1, 0, 0])
    sim = ks.Simulation(m, bcs, ks.SolverOptions(dt=1e-3))
    sim.run(0.05)
    x0 = m.node_positions(sim.state.q)[0]
    assert x0[1] == 0.0 and x0[2] == 0.0 and x0[0] > 1e-4


def test_run_file_forms():
    raw = {"rods": [{"name": "rope", "shape": "straight", "length": 0.1, "n_nodes": N, "radius": 1e-3,
                     "youngs_modulus": 1e7, "density": 1000.0}],
           "bc": [{"type": "pin", "name": "a", "nodes": [0], "axes": "xz", "twist": True},
                  {"type": "slide", "name": "b", "nodes": [-1], "along": [0, 0, 1]},
                  {"type": "plane", "name": "c", "nodes": "2:5", "normal": [1, 0, 0]}],
           "run": {"duration": 0.01}}
    g = load_config(raw).build_bcs().groups
    assert g["a"].axes.tolist() == [True, False, True] and g["a"].edges.tolist() == [0]
    assert g["b"].axes.tolist() == [True, True, False] and g["c"].axes.tolist() == [True, False, False]
    raw["bc"][1]["along"] = [1, 1, 0]
    with pytest.raises(ConfigError) as info:
        load_config(raw)
    assert info.value.field == "bc[1].along"
    raw["bc"][1] = {"type": "slide", "name": "b", "nodes": [-1], "axes": "x"}
    with pytest.raises(ConfigError, match="not used by type 'slide'"):
        load_config(raw)


def euler_column(P, lateral, n=51, length=0.5, h=1e-3, E=1e7):
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0.0, length, n)
    m = ks.Model([ks.RodSpec(x, radius=h, youngs_modulus=E, density=1000.0)])
    bcs = BoundaryConditions(m)
    bcs.pin("left", nodes=[0], twist=True)          # pinned, twist of the first edge fixed
    bcs.pin("right", nodes=[-1], axes="yz")         # roller: free to move along the axis
    bcs.force("P", nodes=[-1], force=[-P, 0, 0])
    bcs.force("lateral", nodes="all", force=[0, 0, lateral])
    res = ks.solve_static(m, bcs)
    return m, res, m.node_positions(res.state.q)[n // 2, 2]


def test_pinned_pinned_column_buckles_at_the_euler_load():
    """Mid-span deflection under a small uniform lateral load is amplified by 1/(1 − P/P_cr); the
    critical load estimated from the amplification at P = 0.9 P_cr is π²EI/L² within 1 %
    (measured 0.07 % with 50 edges; the higher modes of the load bias it by about 0.02 %)."""
    h, E, L = 1e-3, 1e7, 0.5
    p_cr = np.pi**2 * E * np.pi * h**4 / 4 / L**2
    lateral = 1e-3 * p_cr
    _, _, w0 = euler_column(0.0, lateral)
    m, res, w = euler_column(0.9 * p_cr, lateral)
    estimate = 0.9 * p_cr / (1.0 - w0 / w)
    assert estimate == pytest.approx(p_cr, rel=0.01)
    assert w / w0 == pytest.approx(10.0, rel=0.02)
    # reactions: the pin takes the axial load and half the lateral load, the roller the other half
    assert res.reactions["left"][0] == pytest.approx(0.9 * p_cr, rel=1e-6)
    assert res.reactions["left"][2] == pytest.approx(-lateral / 2, rel=1e-4)
    assert res.reactions["right"][2] == pytest.approx(-lateral / 2, rel=1e-4)
    assert res.reactions["right"][0] == 0.0
