"""Validation cases of obstacles and partial constraints (``knotsim validate capstan euler_pinned``).

- ``capstan``: a flexible rope (h = 0.5 mm, E = 1 GPa: axial strain below 2.2 % at 17 N,
  ``EI/(R² T2) = 2e-5``) over a fixed frictional post (capsule of radius R = 5 cm), wrap angle
  θ = π, 2π, 3π (the 2π and 3π wraps are a helix of pitch 4h along the post, with rope–rope contact
  between the turns), one end under a dead load T2 = 1 N, the other pulled steadily along its leg at
  2 cm/s (full slip), 1.5 s: at steady slip (the last 30 %) the pulled tension is
  ``T1 = T2 exp(μ θ)`` (Euler–Eytelwein), μ = 0.3, within 2 %.
- ``euler_pinned``: a pinned–pinned column (L = 0.5 m, h = 1 mm, E = 10 MPa, 50 edges) under an
  axial load P and a small uniform lateral load: the mid-span deflection is amplified by
  ``1 / (1 − P/P_cr)``; the critical load estimated from the amplification at P = 0.9 P_cr is
  ``π² EI / L²`` within 1 %; past it (1.2 P_cr) :func:`~knotsim.solver.static.solve_static` reports the
  straight equilibrium unstable.
- ``floor_friction``: a rope (h = 1 mm, 0.2 m) resting on a frictional floor (μ = 0.4) under gravity:
  dragged by one end at 1 cm/s, the floor's reaction has tangential/normal = μ within 2 % while it
  slides; pushed by a constant force of 0.5 μ m g it sticks (mean speed below 1e-4 m/s, the creep of
  the regularized Coulomb law), by 1.5 μ m g it slides (above 1e-3 m/s).
- ``michell``: a closed ring twisted at a cut loses its planar stability at 2π√3(1 + ν) (2 %).
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np

R, H, GAP, DS, LEG = 0.05, 5e-4, 2e-4, 5e-3, 0.12


def _row(case, quantity, value, reference, error, tolerance, wall, passed=None):
    return {"case": case, "quantity": quantity, "value": float(value), "reference": float(reference),
            "error": float(error), "tolerance": float(tolerance),
            "passed": bool(abs(error) <= tolerance) if passed is None else bool(passed), "wall_time": float(wall)}


def capstan_rope(theta: float) -> tuple[np.ndarray, np.ndarray]:
    """Centreline ``(N, 3)`` (m) of a rope wrapped by ``theta`` (rad) over a post along y, starting on
    the post's -x side with a vertical leg below it, and the unit direction of the far leg (outward).
    Wraps beyond π advance along the post by a pitch of 4h per turn."""
    rc = R + H + GAP
    pitch = 4.0 * H
    n_leg = int(round(LEG / DS))
    n_arc = int(round(theta * rc / DS))
    left = np.stack([np.full(n_leg, -rc), np.zeros(n_leg), np.linspace(-LEG, 0, n_leg, endpoint=False)], 1)
    s = np.linspace(0.0, theta, n_arc, endpoint=False)
    phi = math.pi - s  # clockwise seen from +y: -x side, over the top, down the +x side, ...
    arc = np.stack([rc * np.cos(phi), pitch * s / (2 * math.pi), rc * np.sin(phi)], 1)
    phi_e = math.pi - theta
    end = np.array([rc * math.cos(phi_e), pitch * theta / (2 * math.pi), rc * math.sin(phi_e)])
    tangent = np.array([math.sin(phi_e), 0.0, -math.cos(phi_e)])  # d/ds of the circle at s = theta
    leg = end[None, :] + np.linspace(0.0, LEG, n_leg + 1)[:, None] * tangent[None, :]
    return np.concatenate([left, arc, leg]), tangent


def capstan_ratio(theta: float, mu: float = 0.3, duration: float = 1.5,
                  friction_model: str = "centreline") -> tuple[float, float]:
    """Steady-slip tension ratio T1/T2 and its relative drift over the last 30 % of the run, with
    ``friction_model`` for the post and (wraps beyond π) the rope-rope contact."""
    from knotsim.bc import BoundaryConditions
    from knotsim.contact.model import Contact, ContactOptions
    from knotsim.contact.obstacles import Capsule
    from knotsim.rods import Model, RodSpec
    from knotsim.simulation import Simulation
    from knotsim.solver.options import SolverOptions

    x, tangent = capstan_rope(theta)
    rope = RodSpec(x, radius=H, youngs_modulus=1e9, density=1000)
    model = Model([rope], damping=0.05)
    post = Capsule(model, "post", a=(0, -0.05, 0), b=(0, 0.05 + 4 * H * theta / (2 * math.pi), 0), radius=R,
                      mu=mu, friction_model=friction_model)
    bcs = BoundaryConditions(model)
    bcs.force("load", rod=0, nodes=[0], force=[0, 0, -1.0])
    bcs.move("pull", rod=0, nodes=[-1], path=list(0.02 * tangent), twist=False)
    inter = [post]
    if theta > math.pi:  # the turns touch each other: rope-rope contact as well
        inter.append(Contact(model, ContactOptions(mu=mu, delta=1e-4, friction_model=friction_model)))
    log = Simulation(model, bcs, SolverOptions(dt=2e-3), interactions=inter).run(duration)
    late = log[log["time"] > 0.7 * duration]
    f = late[["pull_fx", "pull_fy", "pull_fz"]].to_numpy() @ tangent
    t1 = float(np.mean(f))  # the grip holds the rope back along its leg
    return t1 / 1.0, float(np.std(f) / abs(t1))


def capstan(quick: bool = False) -> list[dict]:
    """Euler–Eytelwein at θ = π, 2π, 3π (θ = π with ``quick``), μ = 0.3, 2 %: with centre-line
    friction T1/T2 = exp(μθ); with friction at the rope's surface exp(μθ R/(R + h)), the rope's
    inner surface sliding over the post slower than its centre line by R/(R + h)
    (docs/physics.md §3.4)."""
    mu = 0.3
    rows = []
    for k in ((1,) if quick else (1, 2, 3)):
        theta = k * math.pi
        for model, ref in (("centreline", math.exp(mu * theta)), ("surface", math.exp(mu * theta * R / (R + H)))):
            t0 = time.perf_counter()
            ratio, drift = capstan_ratio(theta, mu, friction_model=model)
            rows.append(_row("capstan", f"T1/T2 at theta = {k} pi, mu = {mu:g}, {model} (drift {drift:.1e})", ratio,
                             ref, ratio / ref - 1.0, 0.02, time.perf_counter() - t0))
    return rows


def euler_column(P: float, lateral: float, n: int = 51, length: float = 0.5, h: float = 1e-3, E: float = 1e7,
                 **solve):
    """Pinned–pinned column: pin (twist fixed) at node 0, roller at the last node, axial load P (N)
    and a uniform lateral load (N in all). Returns the model and the static result."""
    from knotsim.bc import BoundaryConditions
    from knotsim.rods import Model, RodSpec
    from knotsim.solver.static import solve_static

    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0.0, length, n)
    m = Model([RodSpec(x, radius=h, youngs_modulus=E, density=1000.0)])
    bcs = BoundaryConditions(m)
    bcs.pin("left", rod=0, nodes=[0], twist=True)
    bcs.pin("right", rod=0, nodes=[-1], axes="yz")
    bcs.force("P", rod=0, nodes=[-1], force=[-P, 0, 0])
    if lateral:
        bcs.force("lateral", rod=0, nodes="all", force=[0, 0, lateral])
    return m, solve_static(m, bcs, **solve)


def euler_pinned(quick: bool = False) -> list[dict]:
    """Buckling load from the amplification of a lateral deflection (1 %), and the instability
    reported past it."""
    h, E, L, n = 1e-3, 1e7, 0.5, 51
    p_cr = math.pi**2 * E * math.pi * h**4 / 4 / L**2
    lateral = 1e-3 * p_cr
    t0 = time.perf_counter()
    m0, r0 = euler_column(0.0, lateral)
    m1, r1 = euler_column(0.9 * p_cr, lateral)
    w0 = m0.node_positions(r0.state.q)[n // 2, 2]
    w1 = m1.node_positions(r1.state.q)[n // 2, 2]
    estimate = 0.9 * p_cr / (1.0 - w0 / w1)
    rows = [_row("euler_pinned", "P_cr from the deflection amplification at 0.9 P_cr (N)", estimate, p_cr,
                 estimate / p_cr - 1.0, 0.01, time.perf_counter() - t0)]
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, r2 = euler_column(1.2 * p_cr, 0.0)
    rows.append(_row("euler_pinned", "straight column at 1.2 P_cr reported unstable (lowest eigenvalue < 0)",
                     float(r2.stable is False), 1.0, 0.0 if r2.stable is False else 1.0, 0.0,
                     time.perf_counter() - t0))
    return rows


def _floor_rope(mu: float, mass_out: list | None = None):
    from knotsim.contact.obstacles import Plane
    from knotsim.rods import Model, RodSpec

    n, length, h, rho = 41, 0.2, 1e-3, 1300.0
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0.0, length, n)
    x[:, 2] = h + 2e-4
    rope = RodSpec(x, radius=h, youngs_modulus=1e7, density=rho)
    model = Model([rope], gravity=(0.0, 0.0, -9.81), damping=0.01)
    floor = Plane(model, "floor", point=(0, 0, 0), normal=(0, 0, 1), mu=mu)
    if mass_out is not None:
        mass_out.append(rho * math.pi * h * h * length)
    return model, floor


def floor_friction(quick: bool = False) -> list[dict]:
    """A rope on a frictional floor (μ = 0.4): dragged by one end at 1 cm/s, the floor's reaction
    while it slides has tangential/normal = μ (2 %); pushed by a force of 0.5 μ m g it sticks (mean
    speed below 1 % of the drag speed), by 1.5 μ m g it slides."""
    from knotsim.bc import BoundaryConditions, Waypoints
    from knotsim.simulation import Simulation
    from knotsim.solver.options import SolverOptions

    mu = 0.4
    rows = []
    t0 = time.perf_counter()
    model, floor = _floor_rope(mu)
    bcs = BoundaryConditions(model)
    bcs.move("drag", rod=0, nodes=[-1], path=Waypoints([0.0, 0.3], [[0, 0, 0], [0, 0, 0]],
                                                          then_velocity=[0.01, 0.0, 0.0]), twist=False)
    log = Simulation(model, bcs, SolverOptions(dt=2e-3), interactions=[floor]).run(1.5)
    late = log[log["time"] > 0.9]
    ratio = float(np.mean(np.abs(late["floor_fx"]) / np.abs(late["floor_fz"])))
    rows.append(_row("floor_friction", "sliding: floor tangential / normal force (mu = 0.4)", ratio, mu,
                     ratio / mu - 1.0, 0.02, time.perf_counter() - t0))
    for factor, sticks in ((0.5, True), (1.5, False)):
        t0 = time.perf_counter()
        mass: list = []
        model, floor = _floor_rope(mu, mass)
        f = factor * mu * mass[0] * 9.81
        bcs = BoundaryConditions(model)
        bcs.force("push", rod=0, nodes=[-1], force=[f, 0.0, 0.0])
        sim = Simulation(model, bcs, SolverOptions(dt=2e-3), interactions=[floor])
        sim.run(0.5)
        x0 = float(np.mean(model.node_positions(sim.state.q)[:, 0]))
        sim.run(0.5)
        speed = (float(np.mean(model.node_positions(sim.state.q)[:, 0])) - x0) / 0.5
        ok = speed < 1e-4 if sticks else speed > 1e-3
        rows.append(_row("floor_friction", f"pushed by {factor:g} mu m g: centroid speed (m/s), "
                         f"{'sticks < 1e-4' if sticks else 'slides > 1e-3'}", speed, 1e-4 if sticks else 1e-3,
                         0.0 if ok else 1.0, 0.0, time.perf_counter() - t0, passed=ok))
    return rows


def michell(quick: bool = False) -> list[dict]:
    """Michell's instability: a closed ring (R = 5 cm, h = 1 mm, ν = 0.5, N = 48), its rigid motions
    and frame gauge removed by statically determinate pins, twisted at a cut
    (:meth:`~knotsim.bc.BoundaryConditions.ring_twist`): the planar equilibrium loses stability (the
    lowest eigenvalue of the static Hessian changes sign) at the total twist 2π√3(1 + ν), found by
    bisection, within 2 %."""
    from knotsim.bc import BoundaryConditions
    from knotsim.bc.feedback import michell_twist
    from knotsim.rods import Model, RodSpec
    from knotsim.solver.static import solve_static

    n, radius = 48, 0.05
    phi = 2 * np.pi * np.arange(n) / n
    x = np.stack([radius * np.cos(phi), radius * np.sin(phi), 0 * phi], 1)
    rod = RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0, poisson_ratio=0.5, closed=True,
                     name="ring")
    model = Model([rod], damping=0.01)
    tw_c = michell_twist(rod)

    def stable(fraction: float) -> bool:
        b = BoundaryConditions(model)
        b.pin("a", rod=0, nodes=[0], twist=True)
        b.pin("b", rod=0, nodes=[n // 2], axes="yz")
        b.pin("c", rod=0, nodes=[n // 4], axes="z")
        b.ring_twist("tw", rod=0, total=fraction * tw_c)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return bool(solve_static(model, b, time=1.0, interactions=b.interactions()).stable)

    t0 = time.perf_counter()
    lo, hi = 0.8, 1.2
    for _ in range(5 if quick else 8):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    est = 0.5 * (lo + hi)
    ref = 2 * math.pi * math.sqrt(3.0) * 1.5
    return [_row("michell", f"critical total twist (rad), bisection to [{lo * tw_c:.3f}, {hi * tw_c:.3f}]",
                 est * tw_c, ref, est * tw_c / ref - 1.0, 0.02, time.perf_counter() - t0)]
