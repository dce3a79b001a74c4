"""Rolling and sliding at the rods' surfaces (docs/physics.md §3.3; docs/validation.md).

The log roll: rod B (along y) is pressed onto rod A (along x, clamped at both ends) by moving its
end groups down 1.5 mm (1 mm past first contact), then the end groups are carried ``travel`` along x,
across B's own axis and along A's. Known answers:

- ends free to spin (``twist=False``): a cylinder carried across a fixed one rolls on it; its
  surface point at the contact does not slip, so B turns by ``θ = s/h`` (``s`` the distance its
  centre line moved over A) and the only tangential force is the smooth law's creep (far below
  ``μ F_n``);
- ends twist-clamped: B's middle can turn only against the twist stiffness of its two halves,
  ``M = 4 GJ θ/L'`` (``L'`` the free length between the clamps); it rolls until that moment reaches
  the friction moment ``μ F_n h`` and then slides with the tangential force ``μ F_n``; the clamps
  then carry the twisting moment ``μ F_n h`` between them.

With ``friction_model = "centreline"`` both set-ups slide (the spin never enters the slip): the
tangential force is ``μ F_n`` and B does not turn.

A straight rod on a plane (:func:`plane_roll`), its axis horizontal. A DER rod's mass is lumped at
its nodes (``ρ A`` per length) and each edge angle carries the rotational inertia ``ρ J`` per
length, ``J = π h⁴/2``: a uniform straight rod has ``I = m h²/2`` about its axis, a solid
cylinder. Without damping:

- on an incline of angle ``α`` (gravity tilted, the plane fixed): rolling without slip needs the
  friction ``f = m g sin α (I/(m h²))/(1 + I/(m h²)) = m g sin α / 3``, so the rod rolls while
  ``tan α ≤ 3 μ``, with ``a = g sin α / (1 + I/(m h²)) = (2/3) g sin α``; above, it slides with
  ``a = g (sin α − μ cos α)`` and spins up at ``μ m g h cos α / I``;
- on a level plane, driven by a total torque ``τ`` about its axis: without slip ``m a = f`` and
  ``I a/h = τ − f h`` give ``f = τ / (h (1 + I/(m h²))) = 2τ/(3h)``, so it rolls while
  ``τ ≤ (3/2) μ m g h``, with ``a = 2τ/(3 m h)``; above, the surface slips and ``a = μ g``.

With centre-line friction the spin never meets friction: on the incline the rod slides
(``a = g (sin α − μ cos α)``) whenever ``tan α > μ``, and a torque only spins it in place.
"""

from __future__ import annotations

import math

import numpy as np

from knotsim.contact.model import Contact, ContactOptions
from knotsim.simulation import Simulation
from knotsim.solver.options import SolverOptions
from knotsim.validation.contact import CROSSING_LENGTH, CROSSING_NODES, H, crossing_rods

#: Pressing depth of B's end groups (m, 1 mm past first contact) and pressing time (s).
PRESS_DEPTH = 1.5e-3
PRESS_TIME = 0.15


def log_roll(*, twist_clamped: bool, mu: float = 0.3, friction_model: str = "surface", travel: float = 0.01,
             travel_time: float = 1.0, dt: float = 2e-3) -> dict:
    """Run the log roll; return its measurements.

    Parameters
    ----------
    twist_clamped : whether B's end groups also fix the angles of their edges.
    mu : friction coefficient; friction_model : ``"surface"`` or ``"centreline"``.
    travel : distance (m) the end groups of B move along x after the press; travel_time : in s.
    dt : time step (s).

    Returns
    -------
    dict with ``tangential_ratio`` (mean ``|F_x|/|F_z|`` of the reaction on A over the second half of
    the travel), ``normal_force`` (N, mean ``|F_z|`` there), ``turn`` (rad, change of the angle of
    B's middle edge during the travel), ``carried`` (m, distance B's middle node moved along x),
    ``twist_moment`` (N m, the sum of the twisting moments of B's clamps at the end, along y),
    ``friction_moment`` (``μ F_n h``, N m), ``GJ`` (N m²), ``free_length`` (m), ``node_slip``
    (the contact's per-node ``(slip, rolling)`` speeds at the end, m/s,
    :meth:`~knotsim.contact.model.Contact.node_slip`) and the ``log``.
    """
    L = CROSSING_LENGTH
    n = CROSSING_NODES
    m, bcs = crossing_rods()
    t_travel = PRESS_TIME + 0.05

    def path(t):
        down = -PRESS_DEPTH * min(t, PRESS_TIME) / PRESS_TIME
        along = travel * min(max(t - t_travel, 0.0), travel_time) / travel_time
        return [along, 0.0, down]

    bcs.move("B0", rod="B", nodes=[0, 1], path=path, twist=twist_clamped)
    bcs.move("B1", rod="B", nodes=[-2, -1], path=path, twist=twist_clamped)
    contact = Contact(m, ContactOptions(mu=mu, friction_model=friction_model))
    sim = Simulation(m, bcs, SolverOptions(dt=dt), interactions=[contact])
    mid_edge = int(m.rod_edge_start[1]) + (n - 1) // 2
    mid_node = int(m.rod_node_start[1]) + n // 2
    theta_dof = int(m.edge_theta_dof[mid_edge])
    x_dof = int(m.node_dof[mid_node])
    marks = {}

    def record(s, _res):
        if "start" not in marks and s.state.time >= t_travel:
            marks["start"] = (float(s.state.q[theta_dof]), float(s.state.q[x_dof]))

    log = sim.run(t_travel + travel_time, progress=False, callback=record)
    q = sim.state.q
    t = log["time"].to_numpy()
    window = t > t_travel + 0.5 * travel_time
    fx = np.abs((log["A0_fx"] + log["A1_fx"]).to_numpy()[window])
    fz = np.abs((log["A0_fz"] + log["A1_fz"]).to_numpy()[window])
    rod_b = m.rods[1]
    # B's clamps hold nodes 0-1 and n-2..n-1: the free part spans the edges between them
    free_length = L * (n - 3) / (n - 1)
    last = log.iloc[-1]
    return {
        "tangential_ratio": float(np.mean(fx) / np.mean(fz)),
        "normal_force": float(np.mean(fz)),
        "turn": float(q[theta_dof] - marks["start"][0]),
        "carried": float(q[x_dof] - marks["start"][1]),
        "twist_moment": float(abs(last["B0_moment"] + last["B1_moment"])),
        "friction_moment": float(mu * np.mean(fz) * H),
        "GJ": float(rod_b.GJ),
        "free_length": free_length,
        "node_slip": contact.node_slip(),
        "log": log,
    }


def _row(quantity, value, reference, error, tolerance, wall, passed=None):
    return {"case": "rolling", "quantity": quantity, "value": float(value), "reference": float(reference),
            "error": float(error), "tolerance": float(tolerance),
            "passed": bool(abs(error) <= tolerance) if passed is None else bool(passed), "wall_time": float(wall)}


def rolling_cases(quick: bool = False) -> list[dict]:
    """Rows for ``knotsim validate``: the log roll with free and twist-clamped ends, surface and
    centre-line friction (μ = 0.3). The same size with ``quick`` (about 2 s a run once compiled)."""
    import time

    mu = 0.3
    rows = []
    t0 = time.perf_counter()
    free = log_roll(twist_clamped=False, mu=mu)
    wall = time.perf_counter() - t0
    rows.append(_row("log roll, ends free (surface): |F_t|/F_n", free["tangential_ratio"], 0.0,
                     free["tangential_ratio"], 0.05, wall))
    rolled = free["carried"] / H
    rows.append(_row("log roll, ends free (surface): turn / (s/h)", free["turn"] / rolled, 1.0,
                     free["turn"] / rolled - 1.0, 0.02, 0.0))
    t0 = time.perf_counter()
    held = log_roll(twist_clamped=True, mu=mu)
    wall = time.perf_counter() - t0
    rows.append(_row("log roll, twist clamped (surface): |F_t|/(mu F_n)", held["tangential_ratio"] / mu, 1.0,
                     held["tangential_ratio"] / mu - 1.0, 0.1, wall))
    lever = held["tangential_ratio"] * held["normal_force"] * H
    rows.append(_row("log roll, twist clamped (surface): clamps' twist moment / (h F_t)", held["twist_moment"] / lever,
                     1.0, held["twist_moment"] / lever - 1.0, 0.1, 0.0))
    t0 = time.perf_counter()
    slid = log_roll(twist_clamped=False, mu=mu, friction_model="centreline")
    wall = time.perf_counter() - t0
    rows.append(_row("log roll, ends free (centreline): |F_t|/(mu F_n)", slid["tangential_ratio"] / mu, 1.0,
                     slid["tangential_ratio"] / mu - 1.0, 0.1, wall))
    rows.append(_row("log roll, ends free (centreline): turn (rad)", slid["turn"], 0.0, slid["turn"], 1e-3, 0.0))
    rows += plane_cases()
    return rows


def plane_cases(mu: float = 0.2) -> list[dict]:
    """Rows of the rod on a plane (:func:`plane_roll`): rolling down an incline below and sliding
    above ``tan α = 3 μ``, rolling and slipping under a torque below and above ``(3/2) μ m g h``
    (accelerations within 1 %), and the centre-line law beside them."""
    import time

    g = 9.81
    rows = []
    h = PLANE_ROD["radius"]
    for deg, model in ((15.0, "surface"), (45.0, "surface"), (15.0, "centreline")):
        alpha = math.radians(deg)
        t0 = time.perf_counter()
        r = plane_roll(incline=alpha, mu=mu, friction_model=model)
        wall = time.perf_counter() - t0
        rolls = model == "surface" and math.tan(alpha) <= 3.0 * mu
        ref = (g * math.sin(alpha) / (1.0 + r["I_ratio"]) if rolls
               else g * (math.sin(alpha) - mu * math.cos(alpha)))
        what = "rolls, a = g sin(a)/(1 + I/mh^2)" if rolls else "slides, a = g (sin(a) - mu cos(a))"
        rows.append(_row(f"incline {deg:g} deg, mu = {mu:g} ({model}): {what} (m/s^2)", r["acceleration"], ref,
                         r["acceleration"] / ref - 1.0, 0.01, wall))
        if rolls:
            rows.append(_row(f"incline {deg:g} deg ({model}): h thetadot / v (rolling without slip)",
                             r["spin_ratio"], 1.0, r["spin_ratio"] - 1.0, 0.01, 0.0))
    mass = plane_roll(duration=0.01, settle=0.0)["mass"]
    threshold = (1.0 + 1.0 / 2.0) * mu * mass * g * h  # (1 + m h^2/I) mu m g h with I = m h^2/2
    for factor, model in ((0.5, "surface"), (2.0, "surface"), (0.5, "centreline")):
        tau = factor * threshold
        t0 = time.perf_counter()
        r = plane_roll(torque=tau, mu=mu, friction_model=model)
        wall = time.perf_counter() - t0
        if model == "centreline":
            rows.append(_row(f"torque {factor:g} x (3/2) mu m g h ({model}): spins in place, a (m/s^2)",
                             r["acceleration"], 0.0, r["acceleration"], 1e-6, wall))
            continue
        rolls = factor <= 1.0
        ref = tau / (h * (1.0 + r["I_ratio"])) / mass if rolls else mu * g
        what = "rolls, a = tau/(h m (1 + I/mh^2))" if rolls else "slips, a = mu g"
        rows.append(_row(f"torque {factor:g} x (3/2) mu m g h ({model}): {what} (m/s^2)", r["acceleration"], ref,
                         r["acceleration"] / ref - 1.0, 0.01, wall))
    return rows


#: Plane-roll rod: nodes, length (m), radius (m), density (kg/m³), Young's modulus (Pa).
PLANE_ROD = {"n_nodes": 11, "length": 0.05, "radius": 1e-3, "density": 1000.0, "E": 1e7}


def plane_roll(*, incline: float = 0.0, torque: float = 0.0, mu: float = 0.2, friction_model: str = "surface",
               duration: float = 0.2, dt: float = 1e-3, settle: float = 0.05) -> dict:
    """A straight rod (along x) on the plane ``z = 0`` under gravity ``g`` tilted by ``incline`` (rad)
    towards −y, and a total twisting moment ``torque`` (N m, about +x, spread over the edges by
    length) from ``settle`` s on; no damping.

    Returns
    -------
    dict with ``acceleration`` (m/s², of the centroid along −y, fitted over the second half of the
    run after ``settle``), ``spin_ratio`` (the rolling rate ``h θ̇`` over the centroid speed at the
    end: 1 for rolling without slip), ``mass`` (kg), ``I_ratio`` (``I/(m h²)`` of the discrete rod),
    ``normal_force`` (N) and the ``log``.
    """
    from knotsim.bc import BoundaryConditions
    from knotsim.contact.obstacles import Plane
    from knotsim.rods import Model, RodSpec
    from knotsim.simulation import Simulation
    from knotsim.solver.options import SolverOptions

    c = PLANE_ROD
    n, length, h = c["n_nodes"], c["length"], c["radius"]
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0.0, length, n)
    x[:, 2] = h + 2e-5
    g = 9.81
    rope = RodSpec(x, radius=h, youngs_modulus=c["E"], density=c["density"])
    model = Model([rope], gravity=(0.0, -g * math.sin(incline), -g * math.cos(incline)), damping=0.0)
    plane = Plane(model, "plane", point=(0, 0, 0), normal=(0, 0, 1), mu=mu, friction_model=friction_model)
    bcs = BoundaryConditions(model)
    if torque:
        # the moment of each edge in proportion to its rest length: a uniform torque per length
        share = model.rest_length / float(np.sum(model.rest_length))
        for e in range(model.n_edges):  # set-up, once
            bcs.moment(f"torque{e}", rod=0, edges=[e], moment=torque * float(share[e]), start=settle)
    sim = Simulation(model, bcs, SolverOptions(dt=dt), interactions=[plane])
    ts, vy, spin = [], [], []
    nodes_y = model.node_dof + 1

    def record(s, _res):
        ts.append(s.state.time)
        vy.append(-float(np.mean(s.state.v[nodes_y])))
        spin.append(float(np.mean(s.state.v[model.edge_theta_dof])))

    log = sim.run(settle + duration, progress=False, callback=record)
    ts, vy, spin = np.array(ts), np.array(vy), np.array(spin)
    sel = ts > settle + 0.5 * duration
    acc = float(np.polyfit(ts[sel], vy[sel], 1)[0])
    mass = float(np.sum(model.mass[model.node_dof]))
    inertia = float(np.sum(model.mass[model.edge_theta_dof]))
    return {"acceleration": acc, "spin_ratio": float(h * spin[-1] / vy[-1]) if vy[-1] != 0.0 else math.nan,
            "mass": mass, "I_ratio": inertia / (mass * h * h), "normal_force": mass * g * math.cos(incline),
            "log": log}
