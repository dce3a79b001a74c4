"""Physics of ContactInteraction in full simulations (coarse rods, each case a few seconds).

Measured values at the time of writing (default contact settings, δ = 0.5 mm, h = 1 mm):

- crossing rods pressed 1 mm together: max penetration 0 (the IMC layer holds the rods about
  50–80 µm apart); reactions on the two rods equal and opposite to 1e-6 relative;
- rod on a fixed rod, friction μ = 0.3: below the threshold (F = 0.5, 0.9 μN) creep speed ≈ 7e-6 and
  2e-5 m/s (< ν = 1e-4); above (F = 1.5, 2 μN) acceleration within 1.2 % of (F − μN)/m for
  dt = 0.5, 1, 2 ms;
- dropped rod comes to rest hovering ≈ 60 µm above the obstacle; with μ = 0 it slides off a rod
  tilted by 20° (and stays with μ = 0.5 > tan 20°).
"""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.bc import BoundaryConditions
from knotsim.contact.model import ContactInteraction, ContactSettings
from knotsim.rods import Model, RodSpec
from knotsim.simulation import Simulation
from knotsim.solver.stepper import SolverSettings

H = 1e-3  # rod radius, m
DELTA = 5e-4


def rod(points, E=1e7, name=""):
    return RodSpec(np.asarray(points, float), radius=H, youngs_modulus=E, density=1000.0, name=name)


def line(a, b, n):
    s = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(a, float)[None, :] * (1 - s) + np.asarray(b, float)[None, :] * s


def test_pressed_crossing_rods_no_penetration_and_equal_opposite_reactions():
    L = 0.06
    n = 16  # even: the crossing is in the middle of an edge
    a = line([-L / 2, 0, 0], [L / 2, 0, 0], n)
    b = line([0, -L / 2, 2 * H + 5e-4], [0, L / 2, 2 * H + 5e-4], n)
    m = Model([rod(a, E=1e6, name="A"), rod(b, E=1e6, name="B")], damping=0.05)
    bcs = BoundaryConditions(m)
    bcs.clamp("A0", rod="A", nodes=[0, 1])
    bcs.clamp("A1", rod="A", nodes=[-2, -1])
    speed, t_press = 0.01, 0.15  # B's ends go down 1.5 mm: 1 mm past first contact

    def press(t):
        return [0.0, 0.0, -speed * min(t, t_press)]

    bcs.move("B0", rod="B", nodes=[0, 1], path=press)
    bcs.move("B1", rod="B", nodes=[-2, -1], path=press)
    ci = ContactInteraction(m, ContactSettings())
    sim = Simulation(m, bcs, SolverSettings(dt=2e-3), interactions=[ci])
    log = sim.run(0.6, progress=False)  # pressing ends at 0.15 s; damped creep to rest after
    pen = log["max_penetration_ratio"].max()
    assert pen <= 0.01, pen
    last = log.iloc[-1]
    fa = np.array([last[f"A0_f{c}"] + last[f"A1_f{c}"] for c in "xyz"])
    fb = np.array([last[f"B0_f{c}"] + last[f"B1_f{c}"] for c in "xyz"])
    # reactions = forces of the clamps on the rods: B's clamps push B down onto A, A's push A up
    assert fb[2] < -1e-4
    np.testing.assert_allclose(fa, -fb, rtol=1e-4, atol=1e-6 * abs(fb[2]))
    # the pressing force equals the force transmitted through the contact
    assert last["contact_force_total"] == pytest.approx(-fb[2], rel=1e-3)
    assert last["n_contacts"] >= 1
    assert 0.0 < last["min_gap"] < DELTA


def friction_run(ratio, dt, mu=0.3, N=1e-3, T=0.08, t_pull=0.02):
    """Rod B (10 nodes, 2 cm, along y) lying across the fixed rod A (along x, all nodes clamped),
    loaded by N (down) and, from ``t_pull``, pulled along A by ``F = ratio μ N``. Returns
    (fitted acceleration for t > t_pull + 10 ms, mean velocity at the end, theory, log)."""
    a = line([-0.06, 0, 0], [0.06, 0, 0], 25)
    b = line([0, -0.01, 2 * H + 2e-4], [0, 0.01, 2 * H + 2e-4], 10)
    m = Model([rod(a, name="A"), rod(b, name="B")])
    bcs = BoundaryConditions(m)
    bcs.clamp("A", rod="A", nodes=list(range(25)))
    bcs.force("load", rod="B", nodes=list(range(10)), force=[0.0, 0.0, -N])
    F = ratio * mu * N
    bcs.force("pull", rod="B", nodes=list(range(10)), force=[F, 0.0, 0.0], start=t_pull)
    ci = ContactInteraction(m, ContactSettings(mu=mu))
    sim = Simulation(m, bcs, SolverSettings(dt=dt), interactions=[ci])
    nb = m.node_dof[m.rod_node_start[1]:]
    ts, vx = [], []

    def cb(s, _res):
        ts.append(s.state.time)
        vx.append(float(np.mean(s.state.v[nb])))

    log = sim.run(T, progress=False, callback=cb)
    ts, vx = np.array(ts), np.array(vx)
    sel = ts > t_pull + 0.01
    acc = np.polyfit(ts[sel], vx[sel], 1)[0]
    theory = (F - mu * N) / m.mass[nb].sum()
    return acc, vx[-1], theory, log


@pytest.mark.parametrize("dt", [5e-4, 1e-3, 2e-3])
def test_friction_threshold_stick_and_slip(dt):
    nu = ContactSettings().nu
    for ratio in (0.5, 0.9):
        _, v_end, _, log = friction_run(ratio, dt)
        assert abs(v_end) < nu, (ratio, v_end)
        assert log["max_penetration_ratio"].max() <= 0.01
    accs = []
    for ratio in (1.5, 2.0):
        acc, _, theory, _ = friction_run(ratio, dt)
        assert acc == pytest.approx(theory, rel=0.03), (ratio, acc, theory)
        accs.append(acc / theory)
    # dt independence over the 4x range (loose: the reference values were within 1.2 %)
    assert max(accs) - min(accs) < 0.03


def test_friction_independent_of_dt():
    res = [friction_run(2.0, dt)[0] for dt in (5e-4, 2e-3)]
    assert res[0] == pytest.approx(res[1], rel=0.02)


def drop_case(tilt_deg=0.0, mu=0.0, T=0.3, damping=0.02):
    th = np.deg2rad(tilt_deg)
    d = np.array([np.cos(th), 0.0, -np.sin(th)])
    a = line(-0.02 * d, 0.02 * d, 11)
    z0 = 2 * H + 3e-3
    b = line([0, -0.01, z0], [0, 0.01, z0], 10)
    m = Model([rod(a, name="A"), rod(b, name="B")], gravity=(0.0, 0.0, -9.81), damping=damping)
    bcs = BoundaryConditions(m)
    bcs.clamp("A", rod="A", nodes=list(range(11)))  # all nodes: a fixed obstacle
    ci = ContactInteraction(m, ContactSettings(mu=mu))
    sim = Simulation(m, bcs, SolverSettings(dt=1e-3), interactions=[ci])
    log = sim.run(T, progress=False)
    xb = m.rod_positions(sim.state.q, "B")
    vb = sim.state.v[m.node_dof[m.rod_node_start[1]:][:, None] + np.arange(3)]
    return log, xb, vb, d


def test_dropped_rod_comes_to_rest_without_penetration():
    log, xb, vb, _ = drop_case()
    assert log["max_penetration_ratio"].max() <= 0.01
    assert np.max(np.linalg.norm(vb, axis=1)) < 2e-3
    last = log.iloc[-1]
    assert last["n_contacts"] >= 1
    assert 0.0 < last["min_gap"] < DELTA
    # at rest the contact carries the weight of B
    weight = 1000.0 * np.pi * H**2 * 0.02 * 9.81
    assert last["contact_force_total"] == pytest.approx(weight, rel=0.02)


def test_frictionless_rod_slides_off_tilted_rod_and_friction_holds_it():
    log, xb, _, d = drop_case(tilt_deg=20.0, mu=0.0, T=0.25)
    c = xb.mean(axis=0)
    assert c @ d > 0.02  # past the lower end of A (half length 2 cm)
    assert log["n_contacts"].iloc[-1] == 0
    assert log["n_contacts"].max() >= 1  # it did land on A first
    assert log["max_penetration_ratio"].max() <= 0.01
    # mu = 0.5 > tan(20 deg): B stays where it landed
    log, xb, vb, d = drop_case(tilt_deg=20.0, mu=0.5, T=0.25)
    assert abs(xb.mean(axis=0) @ d) < 2e-3
    assert log["n_contacts"].iloc[-1] >= 1
