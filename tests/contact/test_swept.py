"""Continuous collision check (knotsim.contact.swept): a rope passing through another in one step,
however far apart the two ropes are at the ends of the step, is rejected and retried smaller.

References: the swept broad phase against a brute-force test of every pair of boxes; the crossing
kernel against motions built to cross (the centre lines meet at a chosen instant) and motions kept
apart by a plane (no crossing possible)."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.bc import BoundaryConditions
from knotsim.contact.assembly import pair_dofs_from_edges
from knotsim.contact.model import Contact, ContactOptions
from knotsim.contact.swept import MET, TURNED, first_crossing, swept_box_pairs
from knotsim.geometry.exclusion import index_distance
from knotsim.rods import Model, RodSpec
from knotsim.simulation import Simulation
from knotsim.solver.state import initial_state
from knotsim.solver.stepper import SolverOptions

R = 1e-3


def crossed_rods(z_gap: float, n: int = 9) -> Model:
    """Rod A along x (clamped later), rod B along y at height ``z_gap`` above its middle (m)."""
    s = np.linspace(-0.04, 0.04, n)
    a = np.stack([s, 0 * s, 0 * s], 1)
    b = np.stack([0 * s + 0.002, s, 0 * s + z_gap], 1)
    return Model([RodSpec(a, radius=R, youngs_modulus=1e6, density=1000.0, name="A"),
                  RodSpec(b, radius=R, youngs_modulus=1e6, density=1000.0, name="B")])


def test_check_rejects_a_pass_through_between_far_positions():
    """B jumps from 12 mm above A to 12 mm below it: far outside the pair list at both ends of the
    step (the end-position tests see nothing), but the centre lines crossed in between."""
    m = crossed_rods(12e-3)
    ci = Contact(m, ContactOptions())
    st = initial_state(m)
    ci.begin_step(st, 0.1)
    assert ci.pairs.shape[0] == 0
    q = st.q.copy()
    nb = m.node_dof[m.rod_node_start[1]:]
    q[nb + 2] -= 24e-3
    r = np.zeros(m.n_dofs)
    ci.evaluate(q, st.q, 0.1, r, False)
    msg = ci.check(q)
    assert msg is not None and "pass-through" in msg and "centre lines met" in msg
    # the same jump sideways (B moved 24 mm along x, never across A's line at its height) is fine
    ci.begin_step(st, 0.1)
    q2 = st.q.copy()
    q2[nb + 0] += 24e-3
    ci.evaluate(q2, st.q, 0.1, r, False)
    assert ci.check(q2) is None


def test_fast_pass_through_is_retried_and_the_rope_stays_on_its_side():
    """Rod B (both ends prescribed) moved from +12 mm to -12 mm through rod A (clamped at both ends)
    with dt = 0.1 s, the whole motion in one step: that step is rejected, the retries push A
    down, and at the end B is still above A with no penetration beyond the limit."""
    m = crossed_rods(12e-3, n=17)
    bcs = BoundaryConditions(m)
    bcs.clamp("a_left", rod="A", nodes=[0, 1])
    bcs.clamp("a_right", rod="A", nodes=[-2, -1])
    bcs.move("b_left", rod="B", nodes=[0, 1], path=[0.0, 0.0, -0.24])
    bcs.move("b_right", rod="B", nodes=[-2, -1], path=[0.0, 0.0, -0.24])
    contact = Contact(m, ContactOptions())
    sim = Simulation(m, bcs, SolverOptions(dt=0.1), interactions=[contact])
    log = sim.run(0.1, progress=False)
    assert sim.n_failures >= 1 and len(log) > 1
    x = m.node_positions(sim.state.q)
    mid_a = x[m.rod_node_start[0] + 8]
    mid_b = x[m.rod_node_start[1] + 8]
    assert mid_b[2] > mid_a[2] + 1.5 * R  # B above A: no pass-through
    assert x[m.rod_node_start[1], 2] == pytest.approx(-12e-3, abs=1e-9)  # B's ends got to -12 mm
    assert log["max_penetration_ratio"].max() <= ContactOptions().penetration_limit


# ------------------------------------------------------------------------------------------ kernels
def _segment_distance_ref(p):
    """Slow reference: minimum distance of two segments by a dense grid plus local refinement."""
    x0, x1, x2, x3 = p[0:3], p[3:6], p[6:9], p[9:12]
    lo_s, hi_s, lo_t, hi_t = 0.0, 1.0, 0.0, 1.0
    for _ in range(6):  # each pass zooms 10x around the best grid point
        s = np.linspace(lo_s, hi_s, 101)
        t = np.linspace(lo_t, hi_t, 101)
        a = x0[None] + s[:, None] * (x1 - x0)[None]
        b = x2[None] + t[:, None] * (x3 - x2)[None]
        dist = np.linalg.norm(a[:, None] - b[None], axis=2)
        i, j = np.unravel_index(np.argmin(dist), dist.shape)
        ws, wt = (hi_s - lo_s) / 10, (hi_t - lo_t) / 10
        lo_s, hi_s = max(0.0, s[i] - ws), min(1.0, s[i] + ws)
        lo_t, hi_t = max(0.0, t[j] - wt), min(1.0, t[j] + wt)
    return float(dist[i, j])


def test_crossing_kernel_finds_motions_built_to_cross():
    rng = np.random.default_rng(3)
    dofs = np.arange(12)[None, :]
    for _ in range(300):
        t_star = rng.uniform(0.02, 0.98)
        xi = rng.uniform(-5e-3, 5e-3, (2, 3))
        ui = rng.uniform(-2e-2, 2e-2, (2, 3))  # edge i moves too
        xi_t = xi + t_star * ui
        bi = rng.uniform(0.1, 0.9)
        meet = (1 - bi) * xi_t[0] + bi * xi_t[1]
        d = rng.standard_normal(3)
        d *= rng.uniform(3e-3, 8e-3) / np.linalg.norm(d)
        bj = rng.uniform(0.1, 0.9)
        xj_t = np.stack([meet - bj * d, meet + (1 - bj) * d])
        uj = rng.uniform(-3e-2, 3e-2, (2, 3))
        q0 = np.concatenate([(xi_t - t_star * ui).ravel(), (xj_t - t_star * uj).ravel()])
        q1 = np.concatenate([(xi_t + (1 - t_star) * ui).ravel(), (xj_t + (1 - t_star) * uj).ravel()])
        k, code, t, value = first_crossing(q0, q1, dofs, np.array([1e-5]), np.zeros(1))
        assert k == 0 and code in (MET, TURNED)
        if code == MET:
            pt = (1 - t) * q0 + t * q1
            assert _segment_distance_ref(pt) <= 1e-5 + 1e-7


def test_crossing_kernel_accepts_motions_kept_apart_by_a_plane():
    rng = np.random.default_rng(4)
    dofs = np.arange(12)[None, :]
    for _ in range(300):
        # edge i stays in z <= 0, edge j in z >= 1 mm at both ends, so all along the linear motion
        zi = rng.uniform(-5e-3, 0.0, (2, 2))
        zj = rng.uniform(1e-3, 6e-3, (2, 2))
        xy = rng.uniform(-3e-2, 3e-2, (2, 4, 2))  # large sideways motions
        q0 = np.concatenate([np.r_[xy[0, e], zz] for e, zz in zip(range(4), [*zi[0], *zj[0]], strict=True)])
        q1 = np.concatenate([np.r_[xy[1, e], zz] for e, zz in zip(range(4), [*zi[1], *zj[1]], strict=True)])
        assert first_crossing(q0, q1, dofs, np.array([1e-5]), np.zeros(1))[0] == -1
        # also at the ends of the step the distance is above 1 mm; sampled motion agrees
        for t in np.linspace(0, 1, 7):
            assert _segment_distance_ref((1 - t) * q0 + t * q1) >= 1e-3 - 1e-12


def test_crossing_kernel_end_to_end_flip_matches_reach():
    """The end-to-end side-flip test only applies to pairs within ``reach`` at an end of the step."""
    q0 = np.r_[-0.01, 0, 0, 0.01, 0, 0, 0, -0.01, 2e-3, 0, 0.01, 2e-3]
    q1 = q0.copy()
    q1[[8, 11]] = -2e-3
    q1[[6, 9]] += 5e-3  # moved past the end of edge i sideways while crossing its height
    dofs = np.arange(12)[None, :]
    hit = first_crossing(q0, q1, dofs, np.array([1e-5]), np.array([5e-3]))
    assert hit[0] == 0
    assert first_crossing(q0, q0, dofs, np.array([1e-5]), np.array([5e-3]))[0] == -1


def test_swept_box_pairs_match_brute_force():
    rng = np.random.default_rng(5)
    rods = []
    for r in range(3):
        x = np.cumsum(rng.uniform(-4e-3, 4e-3, (12, 3)), axis=0) + rng.uniform(-1e-2, 1e-2, 3)
        rods.append(RodSpec(x, radius=R, youngs_modulus=1e6, density=1000.0, closed=(r == 2)))
    m = Model(rods)
    q0 = initial_state(m).q
    q1 = q0.copy()
    q1[m.node_dof[:, None] + np.arange(3)] += rng.uniform(-8e-3, 8e-3, (m.n_nodes, 3))
    inflate = m.edge_radius.copy()
    got = {tuple(p) for p in swept_box_pairs(q0, q1, m.edge_dofs, m.edge_rod, m.edge_local, m.rod_n_edges,
                                             m.rod_closed, inflate)}
    want = set()
    boxes = []
    for e in range(m.n_edges):
        pts = np.stack([q[m.edge_dofs[e, k] + np.arange(3)] for q in (q0, q1) for k in range(2)])
        boxes.append((pts.min(0) - inflate[e], pts.max(0) + inflate[e]))
    for a in range(m.n_edges):
        for b in range(a + 1, m.n_edges):
            ra, rb = m.edge_rod[a], m.edge_rod[b]
            if ra == rb and index_distance(int(m.edge_local[a]), int(m.edge_local[b]), int(m.rod_n_edges[ra]),
                                           bool(m.rod_closed[ra])) < 3:
                continue
            if np.all(boxes[a][0] <= boxes[b][1]) and np.all(boxes[b][0] <= boxes[a][1]):
                want.add((a, b))
    assert got == want and len(want) > 20
    assert pair_dofs_from_edges(np.array(sorted(got)), m.edge_dofs).shape == (len(got), 12)
