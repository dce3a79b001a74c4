"""Contact and friction validation cases (coarse rods; each a few seconds).

- :func:`pressed_crossing_rods`: two crossing rods, one pressed onto the other by moving its clamped
  ends 1 mm past first contact; at rest the clamp reactions must balance and equal the contact force,
  with no penetration.
- :func:`friction_run`: a short rod lying across a fixed rod, loaded by ``N`` and pulled along it by
  ``F = ratio mu N``; it must stick (creep below ``nu``) for ``ratio < 1`` and accelerate at
  ``(F - mu N)/m`` for ``ratio > 1``.
"""

from __future__ import annotations

import time

import numpy as np

from knotsim.bc import BoundaryConditions
from knotsim.contact.model import Contact, ContactOptions
from knotsim.rods import Model, RodSpec
from knotsim.simulation import Simulation
from knotsim.solver.options import SolverOptions

H = 1e-3  # rod radius, m
DELTA = 5e-4  # IMC distance tolerance, m


def rod(points, E=1e7, name=""):
    return RodSpec(np.asarray(points, float), radius=H, youngs_modulus=E, density=1000.0, name=name)


def line(a, b, n):
    s = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(a, float)[None, :] * (1 - s) + np.asarray(b, float)[None, :] * s


#: Crossing rods: length (m) and nodes of each (even: the crossing is in the middle of an edge).
CROSSING_LENGTH = 0.06
CROSSING_NODES = 16


def crossing_rods() -> tuple[Model, BoundaryConditions]:
    """Rod A along x (clamped by its two end pairs, groups ``A0``, ``A1``) and rod B along y,
    0.5 mm above contact, crossing at the middle of both; E = 1 MPa, h = 1 mm, damping 0.05 Pa s."""
    L, n = CROSSING_LENGTH, CROSSING_NODES
    a = line([-L / 2, 0, 0], [L / 2, 0, 0], n)
    b = line([0, -L / 2, 2 * H + 5e-4], [0, L / 2, 2 * H + 5e-4], n)
    m = Model([rod(a, E=1e6, name="A"), rod(b, E=1e6, name="B")], damping=0.05)
    bcs = BoundaryConditions(m)
    bcs.clamp("A0", rod="A", nodes=[0, 1])
    bcs.clamp("A1", rod="A", nodes=[-2, -1])
    return m, bcs


def pressed_crossing_rods(duration: float = 0.6):
    """Run the pressed-rods case; returns ``(log, reaction_on_A (3,), reaction_on_B (3,))`` (N)."""
    m, bcs = crossing_rods()
    speed, t_press = 0.01, 0.15  # B's ends go down 1.5 mm: 1 mm past first contact

    def press(t):
        return [0.0, 0.0, -speed * min(t, t_press)]

    bcs.move("B0", rod="B", nodes=[0, 1], path=press)
    bcs.move("B1", rod="B", nodes=[-2, -1], path=press)
    ci = Contact(m, ContactOptions())
    sim = Simulation(m, bcs, SolverOptions(dt=2e-3), interactions=[ci])
    log = sim.run(duration, progress=False)  # pressing ends at 0.15 s; damped creep to rest after
    last = log.iloc[-1]
    fa = np.array([last[f"A0_f{c}"] + last[f"A1_f{c}"] for c in "xyz"])
    fb = np.array([last[f"B0_f{c}"] + last[f"B1_f{c}"] for c in "xyz"])
    return log, fa, fb


def friction_run(ratio, dt, mu=0.3, N=1e-3, T=0.08, t_pull=0.02, friction_model="centreline"):
    """Rod B (10 nodes, 2 cm, along y) lying across the fixed rod A (along x, all nodes clamped),
    loaded by N (down) and, from ``t_pull``, pulled along A by ``F = ratio μ N``. Returns
    (fitted acceleration for t > t_pull + 10 ms (m/s²), mean velocity at the end (m/s), theory (m/s²),
    log).

    A check of the centre-line law (docs/physics.md §3.1), its default. With surface friction (§3.3)
    the set-up has no sliding answer: pulled along A, across its own axis, B rolls
    (:mod:`knotsim.validation.rolling`); pulled along its own axis, the pull at B's centre line and
    the friction at its lower surface form a couple ``F h`` that tips B, balanced on a single
    crossing, over A (measured: B's ends 2.5 mm apart in height 60 ms after a pull of 0.5 μN)."""
    a = line([-0.06, 0, 0], [0.06, 0, 0], 25)
    b = line([0, -0.01, 2 * H + 2e-4], [0, 0.01, 2 * H + 2e-4], 10)
    m = Model([rod(a, name="A"), rod(b, name="B")])
    bcs = BoundaryConditions(m)
    bcs.clamp("A", rod="A", nodes=list(range(25)))
    bcs.force("load", rod="B", nodes=list(range(10)), force=[0.0, 0.0, -N])
    F = ratio * mu * N
    bcs.force("pull", rod="B", nodes=list(range(10)), force=[F, 0.0, 0.0], start=t_pull)
    ci = Contact(m, ContactOptions(mu=mu, friction_model=friction_model))
    sim = Simulation(m, bcs, SolverOptions(dt=dt), interactions=[ci])
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


def contact_cases(quick: bool = False) -> list[dict]:
    """Rows for ``knotsim validate``: pressed rods and the friction threshold."""
    rows = []
    t0 = time.perf_counter()
    log, fa, fb = pressed_crossing_rods()
    wall = time.perf_counter() - t0
    pen = float(log["max_penetration_ratio"].max())
    rows.append({"case": "contact", "quantity": "pressed rods: max penetration / h", "value": pen,
                 "reference": 0.0, "error": pen, "tolerance": 0.01, "passed": pen <= 0.01, "wall_time": wall})
    bal = float(np.linalg.norm(fa + fb) / np.linalg.norm(fb))
    rows.append({"case": "contact", "quantity": "pressed rods: |R_A + R_B| / |R_B|", "value": bal,
                 "reference": 0.0, "error": bal, "tolerance": 1e-3, "passed": bal <= 1e-3, "wall_time": 0.0})
    fc = float(log["contact_force_total"].iloc[-1])
    err = (fc + fb[2]) / -fb[2]
    rows.append({"case": "contact", "quantity": "pressed rods: contact force (N) vs pressing force", "value": fc,
                 "reference": float(-fb[2]), "error": float(err), "tolerance": 1e-2,
                 "passed": abs(err) <= 1e-2, "wall_time": 0.0})
    for ratio in (0.5, 1.5) if quick else (0.5, 0.9, 1.5, 2.0):
        t0 = time.perf_counter()
        acc, v_end, theory, _ = friction_run(ratio, 1e-3)
        wall = time.perf_counter() - t0
        name = f"friction F = {ratio} muN"
        if ratio < 1:
            rows.append({"case": "contact", "quantity": f"{name}: creep speed (m/s) < nu",
                         "value": abs(float(v_end)), "reference": 1e-4, "error": abs(float(v_end)) / 1e-4,
                         "tolerance": 1.0, "passed": abs(v_end) < 1e-4, "wall_time": wall})
        else:
            err = (acc - theory) / theory
            rows.append({"case": "contact", "quantity": f"{name}: acceleration (m/s^2)",
                         "value": float(acc), "reference": float(theory), "error": float(err), "tolerance": 0.03,
                         "passed": abs(err) <= 0.03, "wall_time": wall})
    return rows
