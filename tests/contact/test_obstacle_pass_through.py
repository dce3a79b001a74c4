"""A rod that goes through an obstacle within one time step is caught as for rod pairs (issue 31).

The swept test (:mod:`knotsim.contact.obstacle_swept`) against a slow numpy reference on random
cases; runs that used to end with the rod on the wrong side of a post, a ball, a moving post or a
turning arm, or with a thin pin between two nodes, now have their step cut (and hold) or stop with
a SimulationError naming the rod, the obstacle and the time; fast but legal motion is not flagged,
and runs that never pass through give the same log as without the test, bit for bit.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import knotsim as ks
from knotsim.contact.obstacle_kernels import CAPSULE, PLANE, SPHERE
from knotsim.contact.obstacle_swept import (
    EDGE,
    NODE,
    NONE,
    core_radius,
    describe,
    first_pass_through,
)
from knotsim.contact.obstacles import Obstacle, rotation_matrix

# --------------------------------------------------------------------------- numpy reference


def ref_poses(kind, geom0, c0, dc, theta, s):
    """The obstacle at the step fractions ``s (n,)``, spelled out: rotated by ``θ s`` about the
    pivot, which has moved by ``s Δc`` (world frame, Rodrigues' formula); ``(n, 7)``."""
    s = np.atleast_1d(np.asarray(s, float))
    ang = np.linalg.norm(theta)
    k = theta / ang if ang > 0 else np.array([0.0, 0.0, 1.0])
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    Rm = (np.eye(3)[None] + np.sin(ang * s)[:, None, None] * K[None]
          + (1.0 - np.cos(ang * s))[:, None, None] * (K @ K)[None])                  # (n, 3, 3)
    c = c0[None, :] + s[:, None] * dc[None, :]
    g = np.tile(np.asarray(geom0, float), (s.size, 1))
    g[:, 0:3] = c + Rm @ (geom0[0:3] - c0)
    if kind == PLANE:
        g[:, 3:6] = Rm @ geom0[3:6]
    elif kind == CAPSULE:
        g[:, 3:6] = c + Rm @ (geom0[3:6] - c0)
    return g


def ref_pose(kind, geom0, c0, dc, theta, s):
    """The obstacle at one step fraction ``s`` (7,)."""
    return ref_poses(kind, geom0, c0, dc, theta, [s])[0]


def ref_core_distance(kind, g, x):
    """Distance of points ``x (..., 3)`` to the core of the posed obstacle ``g (7,)`` or ``(n, 7)``
    (broadcast against ``x``'s leading axis; signed for a plane)."""
    g = np.asarray(g)
    if g.ndim == 2:
        g = g.reshape(g.shape[:1] + (1,) * (x.ndim - 2) + (7,))
    if kind == PLANE:
        return np.sum((x - g[..., 0:3]) * g[..., 3:6], axis=-1)
    if kind == SPHERE:
        return np.linalg.norm(x - g[..., 0:3], axis=-1)
    a, b = g[..., 0:3], g[..., 3:6]
    d = b - a
    t = np.clip(np.sum((x - a) * d, axis=-1) / np.maximum(np.sum(d * d, axis=-1), 1e-300), 0.0, 1.0)
    return np.linalg.norm(x - a - t[..., None] * d, axis=-1)


def ref_sweep(kind, geom0, c0, dc, theta, X0, X1, h, edges, limit, ns=1025):
    """Per node ``(min_s φ(s) − τ, band)`` and per edge ``(D(0) − r, min_s D(s) − r, band)`` on a
    grid of ``ns`` step fractions: the module doc's quantities computed the slow, obvious way (an
    edge's distance to the core is convex along it: golden-section search). ``band``: the width
    about the threshold within which the grid or the kernel's shortest sub-step can blur the answer
    (``1/800`` of the module doc's bound on the motion ``L``: the grid misses at most ``L/2048`` of
    a dive, the kernel ``L/2048``)."""
    s = np.linspace(0.0, 1.0, ns)
    R = 0.0 if kind == PLANE else geom0[6]
    poses = ref_poses(kind, geom0, c0, dc, theta, s)
    X = (1 - s)[:, None, None] * X0[None] + s[:, None, None] * X1[None]          # (ns, k, 3)
    phi = ref_core_distance(kind, poses, X) - (R + h)[None, :]
    tau = np.minimum(0.0, np.minimum(phi[0], phi[-1])) - limit * h
    ang = np.linalg.norm(theta)
    reach = np.maximum(np.linalg.norm(X0 - c0, axis=1), np.linalg.norm(X1 - c0 - dc, axis=1))
    move = np.linalg.norm(X1 - X0 - dc, axis=1)
    nodes = np.stack([phi.min(axis=0) - tau, (move + ang * reach) / 800.0 + 1e-12], axis=1)
    out_e = []
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    for a, b in edges:
        r = core_radius(R, h[a], limit)
        lo, hi = np.zeros(ns), np.ones(ns)

        def dist(beta, xa=X[:, a], xb=X[:, b]):
            return ref_core_distance(kind, poses, (1 - beta)[:, None] * xa + beta[:, None] * xb)

        for _ in range(40):  # (0.618^40 = 4e-9 of the edge)
            m1, m2 = hi - g * (hi - lo), lo + g * (hi - lo)
            left = dist(m1) <= dist(m2)
            hi, lo = np.where(left, m2, hi), np.where(left, lo, m1)
        D = np.minimum(dist(0.5 * (lo + hi)), np.minimum(dist(np.zeros(ns)), dist(np.ones(ns))))
        Le = max(move[a], move[b]) + ang * max(reach[a], reach[b])
        out_e.append((D[0] - r, D.min() - r, Le / 800.0 + 1e-12))
    return nodes, np.array(out_e).reshape(-1, 3)


def random_case(rng, kind):
    """An obstacle with a random pose and motion, and a chain of 6 nodes around it (m)."""
    R = 0.0 if kind == PLANE else rng.uniform(1e-3, 1e-2)
    h = rng.uniform(2e-4, 1e-3)
    if kind == PLANE:
        n = rng.normal(size=3)
        geom = np.concatenate([rng.normal(scale=1e-3, size=3), n / np.linalg.norm(n), [0.0]])
    elif kind == SPHERE:
        geom = np.concatenate([rng.normal(scale=1e-3, size=3), [0.0, 0.0, 0.0], [R]])
    else:
        d = rng.normal(size=3)
        half = rng.uniform(0.5, 3.0) * R
        geom = np.concatenate([-half * d / np.linalg.norm(d), half * d / np.linalg.norm(d), [R]])
    size = 1.5 * (R + h) + 1e-3
    X0 = rng.uniform(-size, size, (6, 3))
    X1 = X0 + rng.normal(scale=rng.choice([0.1, 1.0, 2.0]) * size, size=(6, 3))
    c0 = rng.normal(scale=1e-3, size=3)
    dc = rng.normal(scale=0.5 * size, size=3) if rng.random() < 0.5 else np.zeros(3)
    turns = kind == PLANE or rng.random() < 0.5  # (a plane that does not turn is never sampled)
    theta = rng.normal(scale=0.7, size=3) if turns else np.zeros(3)
    return geom, c0, dc, theta, X0, X1, np.full(6, h)


def kernel(kind, geom, c0, dc, theta, X0, X1, h, edges, limit, gap1):
    k = X0.shape[0]
    q0 = np.concatenate([np.append(x, 0.0) for x in X0])  # the layout of a rod: x, y, z, edge angle
    q1 = np.concatenate([np.append(x, 0.0) for x in X1])
    dofs = 4 * np.arange(k, dtype=np.int64)
    return first_pass_through(kind, geom, c0, dc, theta, q0, q1, dofs, h, gap1,
                              np.asarray(edges, np.int64).reshape(-1, 2), limit, np.zeros(k))


@pytest.mark.parametrize("kind", [PLANE, SPHERE, CAPSULE])
def test_kernel_agrees_with_the_numpy_reference_on_random_cases(kind):
    """Every node and edge of 60 random cases: flagged by the kernel exactly when the reference's
    dive goes beyond the threshold, wherever the grids' and the kernel's resolution cannot blur
    the answer (a band of ``L/800`` about the threshold; within it either answer is right)."""
    rng = np.random.default_rng(31 + kind)
    limit = 0.2
    counts = {"node": [0, 0, 0], "edge": [0, 0, 0]}  # flagged, clear, within the band
    for _ in range(60):
        geom, c0, dc, theta, X0, X1, h = random_case(rng, kind)
        edges = [(i, i + 1) for i in range(5)] if kind != PLANE else []
        nodes, ref_edges = ref_sweep(kind, geom, c0, dc, theta, X0, X1, h, edges, limit)
        R = 0.0 if kind == PLANE else geom[6]
        g1 = ref_pose(kind, geom, c0, dc, theta, 1.0)
        gap1 = ref_core_distance(kind, g1, X1) - (R + h)
        node_flag = []
        for i in range(6):
            code, idx, s, value = kernel(kind, geom, c0, dc, theta, X0[i:i + 1], X1[i:i + 1], h[:1], [], limit,
                                         gap1[i:i + 1])
            margin, band = nodes[i]
            node_flag.append(code == NODE)
            if margin < -band:
                assert code == NODE, (i, margin, band)
                counts["node"][0] += 1
            elif margin > band:
                assert code == NONE, (i, margin, band)
                counts["node"][1] += 1
            else:
                counts["node"][2] += 1
            if code == NODE:  # where it says: the node is beyond the threshold there
                g = ref_pose(kind, geom, c0, dc, theta, s)
                phi = ref_core_distance(kind, g, (1 - s) * X0[i] + s * X1[i]) - (R + h[i])
                assert value == pytest.approx(phi, abs=1e-12)
        if kind == PLANE:
            continue
        for e, (a, b) in enumerate(edges):
            if node_flag[a] or node_flag[b]:
                continue  # a node's dive is reported first
            code, idx, s, value = kernel(kind, geom, c0, dc, theta, X0[[a, b]], X1[[a, b]], h[[a, b]], [(0, 1)],
                                         limit, gap1[[a, b]])
            start, low, band = ref_edges[e]
            if start > band and low < -band:
                assert code == EDGE, (e, start, low)
                counts["edge"][0] += 1
            elif start < -band or low > band:
                assert code == NONE, (e, start, low)
                counts["edge"][1] += 1
            else:
                counts["edge"][2] += 1
    flagged, clear, blurred = counts["node"]
    assert flagged >= 30 and clear >= 60 and blurred <= 0.05 * (flagged + clear), counts
    if kind != PLANE:
        flagged, clear, blurred = counts["edge"]
        assert flagged >= 10 and clear >= 100 and blurred <= 0.05 * (flagged + clear), counts


def test_kernel_named_cases():
    """Hand-made cases: through a post's axis, a plane turned by more than half a turn, a ball
    moving through a node at rest, a post slicing an edge between two nodes far from it, and the
    legal motions: sliding fast round a post (its chord's sagitta within the limit), moving with the
    obstacle, a node near the limit sliding along the post."""
    h, R = 5e-4, 5e-3
    post = np.array([0, -0.02, 0, 0, 0.02, 0, R])
    zero = np.zeros(3)
    rho = R + h

    def one(kind, g, X0, X1, c0=zero, dc=zero, theta=zero, edges=(), hh=h):
        X0, X1 = np.atleast_2d(X0).astype(float), np.atleast_2d(X1).astype(float)
        R_ = 0.0 if kind == PLANE else g[6]
        gap1 = ref_core_distance(kind, ref_pose(kind, g, c0, dc, theta, 1.0), X1) - R_ - hh
        return kernel(kind, g, c0, dc, theta, X0, X1, np.full(len(X0), hh), list(edges), 0.2, gap1)

    # through the post's axis, from above to below: deepest at s = 1/2
    code, i, s, value = one(CAPSULE, post, [0, 0, rho + 1e-4], [0, 0, -rho - 1e-4])
    assert code == NODE and 0.0 < s < 0.5 and value < -0.2 * h
    # a plane turned by 1.5 π about the x axis sweeps through a node 30 degrees above it twice:
    # the node ends on the legal side, 120 degrees round
    floor = np.array([0, 0, 0, 0, 0, 1.0, 0.0])
    y = 5e-3 * np.array([0, math.cos(math.pi / 6), math.sin(math.pi / 6)])
    code, *_ = one(PLANE, floor, y, y, theta=np.array([1.5 * math.pi, 0, 0]))
    assert code == NODE
    assert one(PLANE, floor, y, y, theta=np.array([0.1, 0, 0]))[0] == NONE  # turned by 0.1 rad: clear
    # a ball moving through a node at rest
    ball = np.array([0, 0, -3e-3, 0, 0, 0, 2e-3])
    code, *_ = one(SPHERE, ball, [0, 0, 0], [0, 0, 0], c0=np.array([0, 0, -3e-3]), dc=np.array([0, 0, 6e-3]))
    assert code == NODE
    # a thin post slicing an edge whose nodes stay 5 mm from it
    pin = np.array([0, -0.02, 1e-3, 0, 0.02, 1e-3, 2e-4])
    X0 = [[-5e-3, 0, 0], [5e-3, 0, 0]]
    code, i, s, value = one(CAPSULE, pin, X0, X0, c0=np.array([0, 0, 1e-3]), dc=np.array([0, 0, -2e-3]),
                            edges=[(0, 1)])
    # (its centre line comes within r = 3e-4 m of the axis at s = 0.35: the first sample below is
    # 1/1024 of the step later)
    assert code == EDGE and 0.35 < s < 0.352 and value < core_radius(2e-4, h, 0.2)
    # legal: sliding 20 degrees round the post in one step (sagitta 8.4e-5 m, below 0.2 h = 1e-4)
    a0, a1 = 0.5 * math.pi - math.radians(10), 0.5 * math.pi + math.radians(10)
    X0 = [rho * math.cos(a0), 0, rho * math.sin(a0)]
    X1 = [rho * math.cos(a1), 0, rho * math.sin(a1)]
    assert one(CAPSULE, post, X0, X1)[0] == NONE
    # ... but 25 degrees cuts in by 1.3e-4 m: a dive
    a0, a1 = 0.5 * math.pi - math.radians(12.5), 0.5 * math.pi + math.radians(12.5)
    X0b = [rho * math.cos(a0), 0, rho * math.sin(a0)]
    X1b = [rho * math.cos(a1), 0, rho * math.sin(a1)]
    assert one(CAPSULE, post, X0b, X1b)[0] == NODE
    # legal: riding with a post that moves 1 cm and turns 0.1 rad about its axis (the node's chord
    # cuts into the post's turning frame by its sagitta 7e-6 m)
    dc, th, c0 = np.array([0.01, 0.0, 0.0]), np.array([0.0, 0.1, 0.0]), np.array([0.0, 0.0, 0.0])
    x0 = np.array([0.0, 0.0, rho + 1e-5])
    x1 = c0 + dc + rotation_matrix(th) @ (x0 - c0)
    assert one(CAPSULE, post, x0, x1, c0=c0, dc=dc, theta=th)[0] == NONE
    # legal: a node 0.19 h inside, sliding 3 h along the post's axis
    x0 = np.array([0.0, 0.0, rho - 0.19 * h])
    assert one(CAPSULE, post, x0, x0 + [0, 3 * h, 0])[0] == NONE


# --------------------------------------------------------------------------- runs

H_WIRE, R_POST, GAP = 1.25e-4, 5e-3, 2e-5


def wire_round_post(ds=5e-4, leg=0.02):
    """A 0.25 mm wire (radius 0.125 mm) wrapped π round a 10 mm post along y, both legs hanging."""
    rc = R_POST + H_WIRE + GAP
    n_leg, n_arc = int(round(leg / ds)), int(round(math.pi * rc / ds))
    left = np.stack([np.full(n_leg, -rc), np.zeros(n_leg), np.linspace(-leg, 0, n_leg, endpoint=False)], 1)
    th = np.linspace(math.pi, 0, n_arc, endpoint=False)
    arc = np.stack([rc * np.cos(th), np.zeros(n_arc), rc * np.sin(th)], 1)
    right = np.stack([np.full(n_leg + 1, rc), np.zeros(n_leg + 1), np.linspace(0, -leg, n_leg + 1)], 1)
    return np.concatenate([left, arc, right]), n_leg + n_arc // 2


def record_reasons(obstacle) -> list[str]:
    """The reasons ``obstacle.check`` returns (a wrapper on the instance)."""
    reasons = []
    check = obstacle.check

    def wrapped(q):
        r = check(q)
        if r:
            reasons.append(r)
        return r

    obstacle.check = wrapped
    return reasons


def positions(model, q):
    return q[model.node_dof[:, None] + np.arange(3)]


def test_user_case_wire_round_a_post_under_a_4_N_step_load():
    """Issue 31 item 6: the wire, loaded by 4 N at both ends as a step, dt = 1 ms, went through
    the post in its first step (0.33 m down) and the run finished without contact. Now that step
    is cut (the first attempt names node and rod) until the post holds the wire: every accepted
    step keeps the wrap's top above the post and the post carries the two 4 N legs."""
    x, top = wire_round_post()
    model = ks.Model([ks.RodSpec(x, radius=H_WIRE, youngs_modulus=2e11, density=7850, name="wire")], damping=0.05)
    post = ks.Capsule(model, "post", a=(0, -0.01, 0), b=(0, 0.01, 0), radius=R_POST)
    reasons = record_reasons(post)
    bcs = ks.BoundaryConditions(model)
    bcs.force("end_a", nodes=[0], force=[0, 0, -4.0])
    bcs.force("end_b", nodes=[-1], force=[0, 0, -4.0])
    tops = []
    sim = ks.Simulation(model, bcs, ks.SolverOptions(dt=1e-3), interactions=[post])
    log = sim.run(0.005, callback=lambda s, r: tops.append(positions(model, s.state.q)[top, 2]))
    assert log["attempts"].iloc[0] > 1  # the first 1 ms step was cut
    assert re.match(r"obstacle 'post': node \d+ of rod 'wire' passed through it during the step: .* at t = "
                    r"[0-9.e-]+ s", reasons[0]), reasons[0]
    assert min(tops) > R_POST + H_WIRE * 0.8  # never on the wrong side
    assert (log["post_n_contacts"] > 0).all()
    assert log["post_fz"].iloc[-1] == pytest.approx(-8.0, rel=5e-3)


def lying_rope(n=41, length=0.1, z=0.0, h=5e-4, v=None):
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(-length / 2, length / 2, n)
    x[:, 2] = z
    vel = None if v is None else np.tile(np.asarray(v, float), (n, 1))
    return ks.RodSpec(x, radius=h, youngs_modulus=1e7, density=1000, name="rope", velocities=vel)


def test_plane_crossed_in_one_step_is_cut_and_named():
    """A rope lying on a table, pulled down at both ends by 4 N as a step (dt = 1 ms): its ends go
    through the table in the first step; the step is cut, the reason names the node within rod
    'rope' and the table, and the rope ends held on it, never below."""
    model = ks.Model([lying_rope(z=6e-4)])
    table = ks.Plane(model, "table")
    reasons = record_reasons(table)
    bcs = ks.BoundaryConditions(model)
    bcs.force("a", nodes=[0], force=[0, 0, -4.0])
    bcs.force("b", nodes=[-1], force=[0, 0, -4.0])
    low = []
    sim = ks.Simulation(model, bcs, ks.SolverOptions(dt=1e-3), interactions=[table])
    log = sim.run(0.005, callback=lambda s, r: low.append(positions(model, s.state.q)[:, 2].min()))
    assert log["attempts"].iloc[0] > 1
    assert re.match(r"obstacle 'table': node (0|40) of rod 'rope' penetrates", reasons[0]), reasons[0]
    assert min(low) > 5e-4 * 0.8
    assert log["table_fz"].iloc[-1] == pytest.approx(-8.0, rel=5e-3)


def test_rope_thrown_through_a_ball_bounces_off_it():
    """A rope 5 mm above a 2 cm ball, thrown down at 60 m/s (dt = 1 ms): it used to end 3.5 cm
    below the ball without contact. Now the first step is cut (a node's dive through the ball) and
    the rope stays above it at every accepted step."""
    model = ks.Model([lying_rope(z=0.025, v=(0, 0, -60.0))])
    ball = ks.Sphere(model, "ball", center=(0, 0, 0), radius=0.02)
    reasons = record_reasons(ball)
    mid = []
    sim = ks.Simulation(model, ks.BoundaryConditions(model), ks.SolverOptions(dt=1e-3), interactions=[ball])
    log = sim.run(0.003, callback=lambda s, r: mid.append(positions(model, s.state.q)[20, 2]))
    assert log["attempts"].iloc[0] > 1
    assert re.match(r"obstacle 'ball': node \d+ of rod 'rope' passed through it", reasons[0]), reasons[0]
    assert min(mid) > 0.02 + 5e-4 * 0.8


@pytest.mark.parametrize("how", ["translating", "turning"])
def test_moving_obstacle_sweeping_through_a_resting_rope_pushes_it(how):
    """A post moving down at 8 m/s (8 mm per 1 ms step) onto a rope at rest, or a pin on a 5 cm
    arm turning at 800 rad/s (0.8 rad per step) down through it, used to end the step beyond the
    rope, without contact. Now the step is cut, and at every accepted step the rope is pushed
    ahead: the obstacle's axis stays above the rope's centre line. (The energy guard does not
    count an obstacle's work: switched off, it is not what this test measures.)"""
    if how == "translating":
        model = ks.Model([lying_rope()])
        ob = ks.Capsule(model, "post", a=(0, -0.02, 2.5e-3), b=(0, 0.02, 2.5e-3), radius=1e-3, path=[0, 0, -8.0])
    else:  # the pin's circle meets the rope (at z = 1 cm) at x = -3 cm; it ends at x = -5 mm, z = 0.25 mm
        model = ks.Model([lying_rope(z=0.01)])
        x0, z0 = 0.05 * math.sin(-0.9), 0.05 - 0.05 * math.cos(-0.9)
        ob = ks.Capsule(model, "arm", a=(x0, -0.02, z0), b=(x0, 0.02, z0), radius=2e-3,
                        angular_velocity=(0, -800.0, 0), pivot=(0, 0, 0.05))
    reasons = record_reasons(ob)
    above = []

    def side(sim, res):
        x = positions(model, sim.state.q)
        g = ob.geometry(sim.state.time)
        above.append(g[2] - np.interp(g[0], x[:, 0], x[:, 2]))

    sim = ks.Simulation(model, ks.BoundaryConditions(model), ks.SolverOptions(dt=1e-3),
                        interactions=[ob])
    log = sim.run(0.001, callback=side)
    assert log["attempts"].iloc[0] > 1
    assert re.match(rf"obstacle '{ob.name}': node \d+ of rod 'rope' passed through it", reasons[0]), reasons[0]
    assert min(above) > 1e-3
    assert log[f"{ob.name}_n_contacts"].iloc[-1] > 0


def test_thin_pin_slicing_an_edge_stops_the_run_naming_edge_rod_obstacle_and_time():
    """A 0.5 mm pin lowered at 0.1 m/s onto a rope of 1 cm edges, between two nodes: no node ever
    touches it, so no force stops it, and it used to cut through the edge unnoticed. Now the step
    that brings the edge's centre line within half the contact distance of the pin's axis is cut,
    and as no smaller step helps the run stops with a SimulationError naming the edge within the
    rod, the pin and the time; its last good state has the pin still above the edge."""
    model = ks.Model([lying_rope(n=11)])  # nodes at x = -0.05 + 0.01 k: edge 5 spans 0 ... 0.01
    pin = ks.Capsule(model, "pin", a=(0.005, -0.02, 1e-3), b=(0.005, 0.02, 1e-3), radius=5e-4, path=[0, 0, -0.1])
    sim = ks.Simulation(model, ks.BoundaryConditions(model), ks.SolverOptions(dt=1e-3), interactions=[pin])
    with pytest.raises(ks.SimulationError) as info:
        sim.run(0.03)
    msg = str(info.value)
    assert re.search(r"at t=0\.00[0-9]+ s: obstacle 'pin': edge 5 of rod 'rope' passed through it between its "
                     r"nodes", msg), msg
    last = info.value.last_good_state
    x = positions(model, last.q)
    assert pin.geometry(last.time)[2] - 0.5 * (x[5, 2] + x[6, 2]) >= core_radius(5e-4, 5e-4, 0.2) - 1e-12


def flyby(guard: bool):
    """A rope flying up at 30 m/s past a vertical post 0.5 mm from its surface (3 cm per step)."""
    model = ks.Model([lying_rope(z=-0.01, v=(0, 0, 30.0))])
    post = ks.Capsule(model, "post", a=(0, 3e-3, -0.05), b=(0, 3e-3, 0.05), radius=2e-3, mu=0.3)
    if not guard:
        post._pass_through = lambda q: None
    return ks.Simulation(model, ks.BoundaryConditions(model), ks.SolverOptions(dt=1e-3),
                         interactions=[post]).run(0.004)


def capstan(guard: bool):
    """The capstan of tests/contact/test_capstan.py pulled at 0.5 m/s (1 mm per 2 ms step) for 0.1 s."""
    from tests.contact.test_capstan import capstan_rope

    model = ks.Model([ks.RodSpec(capstan_rope(), radius=5e-4, youngs_modulus=1e8, density=1000)], damping=0.05)
    post = ks.Capsule(model, "post", a=(0, -0.05, 0), b=(0, 0.05, 0), radius=0.05, mu=0.3)
    if not guard:
        post._pass_through = lambda q: None
    bcs = ks.BoundaryConditions(model)
    bcs.force("load", nodes=[0], force=[0, 0, -1.0])
    bcs.move("pull", nodes=[-1], path=[0, 0, -0.5], twist=False)
    return ks.Simulation(model, bcs, ks.SolverOptions(dt=2e-3), interactions=[post]).run(0.1)


@pytest.mark.parametrize("run", [flyby, capstan])
def test_fast_legal_motion_is_not_flagged_and_runs_are_unchanged(run, monkeypatch):
    """Negative control: a rope flying past a post at 30 m/s and a rope slipping over a post at
    0.5 m/s are never flagged, and their logs are those of the same runs without the test, bit for
    bit."""
    flagged = []
    original = Obstacle._pass_through

    def spy(self, q):
        r = original(self, q)
        flagged.extend([r] if r else [])
        return r

    monkeypatch.setattr(Obstacle, "_pass_through", spy)
    on = run(True)
    off = run(False)
    assert not flagged
    assert on.equals(off)


def test_reason_names_rod_node_edge_obstacle_and_time():
    model = ks.Model([lying_rope(n=5), ks.RodSpec(np.array([[0, 0, 1.0], [0.1, 0, 1.0], [0.2, 0, 1.0]]),
                                                   radius=1e-3, youngs_modulus=1e7, density=1000, name="cord")])
    post = ks.Capsule(model, "peg", a=(0, -1, 0), b=(0, 1, 0), radius=0.01, rods=["cord"])
    text = describe(post, NODE, 1, 0.25, -5e-4, 0.5, 2e-3)
    assert text.startswith("obstacle 'peg': node 1 of rod 'cord' passed through it") and "t = 0.5005 s" in text
    text = describe(post, EDGE, 1, 0.5, 1e-3, 0.5, 2e-3)
    assert text.startswith("obstacle 'peg': edge 1 of rod 'cord' passed through it between its nodes")
    assert "axis at t = 0.501 s" in text
