"""Contact: assembled residual/Jacobian against finite differences, broad phase against
brute force, statistics, settings validation and the config hook.

FD: the pair set is fixed by one ``begin_step``; ``q_prev`` and ``dt`` are fixed; central
differences of the full contact residual (``k_c ∇E − F_fr``) with step ``H = 1e-9 m`` (coordinates
of order 1e-2 m; 1e-11 m with friction, whose velocity scale ν·dt = 1e-7 m is short); tolerance ``|FD − J|∞ <= 1e-5 |J|∞`` per column set. Configurations are chosen so
that no finite-difference stencil crosses a distance-case boundary or the energy cut-off.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from knotsim.contact.broadphase import segment_distance
from knotsim.contact.distance import CASE_EE, edge_edge_distance
from knotsim.contact.model import Contact, ContactOptions, contact_from_config
from knotsim.errors import ConfigError
from knotsim.rods import Model, RodSpec
from knotsim.solver.state import initial_state

H = 1e-9
RTOL = 1e-5
R = 1e-3  # rod radius, m


def two_rods(z_gap=1.9e-3, n=5, seed=0, angle=np.pi / 2, tilt=0.0):
    """Rod A along x through the origin; rod B at height ``z_gap`` crossing mid-edge at an angle."""
    rng = np.random.default_rng(seed)
    s = np.linspace(-0.02, 0.02, n)
    a = np.stack([s, 0 * s, 0 * s], 1)
    c = np.array([0.005, 0.0, z_gap])
    dirb = np.array([np.cos(angle), np.sin(angle), tilt])
    dirb /= np.linalg.norm(dirb)
    b = c[None, :] + (s[:, None] + 0.005) * dirb[None, :]
    a += 1e-5 * rng.standard_normal(a.shape)
    b += 1e-5 * rng.standard_normal(b.shape)
    rods = [RodSpec(a, radius=R, youngs_modulus=1e6, density=1000.0, name="A"),
            RodSpec(b, radius=R, youngs_modulus=1e6, density=1000.0, name="B")]
    return Model(rods)


def residual_and_jacobian(ci, q, q_prev, dt):
    n = q.size
    r = np.zeros(n)
    _, blocks = ci.evaluate(q, q_prev, dt, r, True)
    J = np.zeros((n, n))
    dofs = ci.block_dofs()
    for k in range(dofs.shape[0]):
        J[np.ix_(dofs[k], dofs[k])] += blocks[k]
    return r, J


def fd_check(ci, q, q_prev, dt, h=H):
    r0, J = residual_and_jacobian(ci, q, q_prev, dt)
    cols = np.unique(ci.block_dofs())
    fd = np.zeros((q.size, cols.size))
    for c, j in enumerate(cols):
        qp = q.copy()
        qp[j] += h
        qm = q.copy()
        qm[j] -= h
        rp = np.zeros(q.size)
        rm = np.zeros(q.size)
        ci.evaluate(qp, q_prev, dt, rp, False)
        ci.evaluate(qm, q_prev, dt, rm, False)
        fd[:, c] = (rp - rm) / (2 * h)
    err = np.max(np.abs(fd - J[:, cols]))
    scale = np.max(np.abs(J[:, cols]))
    return r0, err, scale


def prepared(model, settings, q=None, v=None, dt=1e-3):
    ci = Contact(model, settings)
    st = initial_state(model)
    if q is not None:
        st.q = q
    if v is not None:
        st.v = v
    ci.begin_step(st, dt)
    return ci, st


@pytest.mark.parametrize("smoothing", [0.0, 2e-6])
@pytest.mark.parametrize("z_gap", [1.9e-3, 2.2e-3, 1.7e-3])
def test_contact_gradient_and_jacobian_match_fd_frictionless(z_gap, smoothing):
    m = two_rods(z_gap)
    ci, st = prepared(m, ContactOptions(stiffness_mode="constant", stiffness=50.0, parallel_smoothing=smoothing))
    assert ci.pairs.shape[0] >= 1
    q = st.q.copy()
    r0, err, scale = fd_check(ci, q, q, 1e-3)
    assert np.any(r0 != 0.0)
    assert err <= RTOL * scale, (err, scale)
    # pair of the crossing is edge-edge
    p = q[ci.pair_dofs[np.argmin(ci._last.delta)]]
    assert edge_edge_distance(p)[3] == CASE_EE


@pytest.mark.parametrize("friction_model", ["surface", "centreline"])
@pytest.mark.parametrize("smoothing", [0.0, 2e-6])
@pytest.mark.parametrize("speed", [3e-3, 3e-5, 0.0])
@pytest.mark.parametrize("z_gap", [1.9e-3, 2.2e-3])
def test_contact_with_friction_matches_fd(speed, z_gap, smoothing, friction_model):
    m = two_rods(z_gap, tilt=0.2)
    rng = np.random.default_rng(1)
    st = initial_state(m)
    dt = 1e-3
    # previous positions: rod B slid along x by speed * dt, plus a small random part
    q_prev = st.q.copy()
    nb = m.node_dof[m.rod_node_start[1]:]
    q_prev[nb] -= speed * dt
    q_prev[m.node_dof] += 0.1 * speed * dt * rng.standard_normal(m.n_nodes)
    q_prev[m.edge_theta_dof] += 10 * speed * dt * rng.standard_normal(m.n_edges)  # spins (rad)
    settings = ContactOptions(stiffness_mode="constant", stiffness=50.0, mu=0.4, parallel_smoothing=smoothing,
                               friction_model=friction_model)
    ci, _ = prepared(m, settings)
    r0, err, scale = fd_check(ci, st.q, q_prev, dt, h=1e-11)
    assert err <= RTOL * scale, (err, scale)
    ff = ci._last.ff
    if speed > 0:
        assert np.any(ff != 0.0)
    # with mu = 0 the friction part vanishes and the residual is the gradient of the energy
    ci0, _ = prepared(m, ContactOptions(stiffness_mode="constant", stiffness=50.0, parallel_smoothing=smoothing))
    r1 = np.zeros(m.n_dofs)
    ci0.evaluate(st.q, q_prev, dt, r1, False)
    r2 = np.zeros(m.n_dofs)
    ci.evaluate(st.q, q_prev, dt, r2, False)
    fr = np.zeros(m.n_dofs)
    np.add.at(fr, ci.pair_dofs.ravel(), ci._last.ff.ravel())
    np.add.at(fr, ci.pair_theta.ravel(), ci._last.surface[:, 2:4].ravel())  # torques (surface friction)
    if friction_model == "centreline":
        assert not np.any(ci._last.surface)
    elif speed > 0:
        assert np.any(ci._last.surface[:, 2:4] != 0.0)
    np.testing.assert_allclose(r2, r1 - fr, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("mu", [0.0, 0.4])
@pytest.mark.parametrize("angle", [0.0, 1e-4])
def test_parallel_rods_with_parallel_smoothing_match_fd(mu, angle):
    """Two parallel rods pressed together (the geometry where the exact distance is not smooth):
    with ``parallel_smoothing`` the assembled contact (+ friction) Jacobian matches FD."""
    m = two_rods(1.95e-3, angle=angle)
    st = initial_state(m)
    dt = 1e-3
    q_prev = st.q.copy()
    q_prev[m.node_dof[m.rod_node_start[1]:]] -= 3e-5 * dt
    settings = ContactOptions(stiffness_mode="constant", stiffness=50.0, mu=mu, parallel_smoothing=2e-6)
    ci, _ = prepared(m, settings)
    r0, err, scale = fd_check(ci, st.q, q_prev, dt, h=1e-11 if mu else H)
    assert np.count_nonzero(ci._last.delta < 2 * R + settings.delta) >= 4  # several parallel pairs in contact
    assert err <= RTOL * scale, (err, scale)


def test_parallel_smoothing_per_pair_eta_and_zero_is_exact():
    """η of a pair is 8 d ℓ / (l̄_a² + l̄_b²); ℓ = 0 gives the exact segment distance."""
    m = two_rods(1.95e-3, angle=0.0)
    st = initial_state(m)
    ci, _ = prepared(m, ContactOptions(parallel_smoothing=3e-6))
    la = m.rest_length[ci.pairs[:, 0]]
    lb = m.rest_length[ci.pairs[:, 1]]
    np.testing.assert_allclose(ci.pair_eta, 8 * ci.pair_d * 3e-6 / (la**2 + lb**2))
    r = np.zeros(m.n_dofs)
    ci.evaluate(st.q, st.q, 1e-3, r, False)
    exact = np.array([edge_edge_distance(st.q[d])[0] for d in ci.pair_dofs])
    bias = ci._last.delta - exact
    assert np.all(bias >= -1e-15) and np.all(bias <= 3e-6 * ci.pair_d / exact * (1 + 1e-9)) and bias.max() > 1e-8
    ci0, _ = prepared(m, ContactOptions(parallel_smoothing=0.0))
    assert not ci0.pair_eta.any()
    ci0.evaluate(st.q, st.q, 1e-3, r, False)
    np.testing.assert_array_equal(ci0._last.delta, exact)


def _pair(x0, x1, x2, x3):
    return np.concatenate([x0, x1, x2, x3]).astype(float)


def test_first_side_flip_detects_pass_through_only():
    from knotsim.contact.assembly import first_side_flip

    dofs = np.arange(12)[None, :]
    reach = np.array([2.5e-3])
    a0, a1 = np.array([-5e-3, 0, 0]), np.array([5e-3, 0, 0])
    b0, b1 = np.array([0, -5e-3, 2e-3]), np.array([0, 5e-3, 2e-3])
    start = _pair(a0, a1, b0, b1)
    # edge j jumps from 2 mm above edge i to 2 mm below it within one step: a pass-through
    through = _pair(a0, a1, b0 - [0, 0, 4e-3], b1 - [0, 0, 4e-3])
    k, cos = first_side_flip(start, through, dofs, reach)
    assert k == 0 and cos == pytest.approx(-1.0)
    # pressed closer, slid along, turned through parallel, or moved off the end: no flip
    for end in (_pair(a0, a1, b0 - [0, 0, 5e-4], b1 - [0, 0, 5e-4]),
                _pair(a0, a1, b0 + [1e-3, 0, 0], b1 + [1e-3, 0, 0]),
                _pair(a0, a1, [-5e-3, 1e-4, 2e-3], [5e-3, -1e-4, 2e-3]),
                _pair(a0, a1, b0 + [6e-3, 0, 0], b1 + [6e-3, 0, 0])):
        assert first_side_flip(start, end, dofs, reach)[0] == -1
    # far apart at both ends of the step: not checked
    far = _pair(a0, a1, b0 + [0, 0, 1e-2], b1 + [0, 0, 1e-2])
    assert first_side_flip(far, far - np.r_[np.zeros(6), [0, 0, 2e-2] * 2], dofs, reach)[0] == -1


def test_check_rejects_pass_through():
    m = two_rods(2.1e-3)
    ci, st = prepared(m, ContactOptions())
    q_prev = st.q.copy()
    q = st.q.copy()
    nb = m.node_dof[m.rod_node_start[1]:]
    q[nb + 2] -= 4.2e-3  # rod B moved from 2.1 mm above rod A to 2.1 mm below it
    r = np.zeros(m.n_dofs)
    ci.evaluate(q, q_prev, 1e-3, r, False)
    msg = ci.check(q)
    assert msg is not None and "pass-through" in msg and "changed sides" in msg
    ci.evaluate(q_prev, q_prev, 1e-3, r, False)
    assert ci.check(q_prev) is None


def test_energy_consistent_with_gradient():
    m = two_rods(1.95e-3, angle=1.0, tilt=0.1)
    ci, st = prepared(m, ContactOptions(stiffness_mode="constant", stiffness=50.0))
    q = st.q
    r = np.zeros(m.n_dofs)
    e0, _ = ci.evaluate(q, q, 1e-3, r, False)
    assert e0 > 0
    rng = np.random.default_rng(3)
    dq = rng.standard_normal(m.n_dofs) * 1e-9
    ep, _ = ci.evaluate(q + dq, q, 1e-3, np.zeros(m.n_dofs), False)
    em, _ = ci.evaluate(q - dq, q, 1e-3, np.zeros(m.n_dofs), False)
    assert (ep - em) / 2 == pytest.approx(float(r @ dq), rel=1e-6)


def brute_force_pairs(model, q, extra, self_contact=True):
    out = []
    m = model
    for a in range(m.n_edges):
        for b in range(a + 1, m.n_edges):
            if m.edge_rod[a] == m.edge_rod[b]:
                if not self_contact:
                    continue
                di = abs(int(m.edge_local[a] - m.edge_local[b]))
                r = m.edge_rod[a]
                if m.rod_closed[r]:
                    di = min(di, int(m.rod_n_edges[r]) - di)
                if di < 3:
                    continue
            x = [tuple(q[i:i + 3]) for i in (*m.edge_dofs[a], *m.edge_dofs[b])]
            if segment_distance(*x) < m.edge_radius[a] + m.edge_radius[b] + extra:
                out.append((a, b))
    return np.array(out, dtype=np.int64).reshape(-1, 2)


@pytest.mark.parametrize("self_contact", [True, False])
def test_broad_phase_equals_brute_force(self_contact):
    # a coiled rod (self-contact) plus a straight rod through the coil
    t = np.linspace(0, 4 * np.pi, 60)
    coil = np.stack([0.01 * np.cos(t), 0.01 * np.sin(t), 0.0008 * t], 1)
    s = np.linspace(-0.02, 0.02, 15)
    line = np.stack([s, 0 * s + 0.009, 0 * s + 0.004], 1)
    m = Model([RodSpec(coil, radius=1e-3, youngs_modulus=1e6, density=1e3),
               RodSpec(line, radius=0.7e-3, youngs_modulus=1e6, density=1e3)])
    settings = ContactOptions(self_contact=self_contact)
    ci, st = prepared(m, settings)
    ref = brute_force_pairs(m, st.q, settings.delta + settings.margin, self_contact)
    assert ref.shape[0] > 5
    np.testing.assert_array_equal(ci.pairs, ref)
    # dofs: 4 nodes of every pair
    for (a, b), dofs in zip(ci.pairs, ci.pair_dofs, strict=True):
        expect = np.concatenate([m.edge_dofs[a, 0] + np.arange(3), m.edge_dofs[a, 1] + np.arange(3),
                                 m.edge_dofs[b, 0] + np.arange(3), m.edge_dofs[b, 1] + np.arange(3)])
        np.testing.assert_array_equal(dofs, expect)
    np.testing.assert_allclose(ci.pair_d, m.edge_radius[ci.pairs].sum(axis=1))


def test_stats_of_single_crossing():
    z = 1.98e-3
    m = two_rods(z)
    kc = 80.0
    ci, st = prepared(m, ContactOptions(stiffness_mode="constant", stiffness=kc))
    assert ci.check(st.q) is None
    s = ci.stats()
    assert s["n_contacts"] == 1
    delta = np.min(ci._last.delta)
    assert s["min_gap"] == pytest.approx(delta - 2 * R)
    assert s["max_penetration_ratio"] == pytest.approx(max(0.0, (2 * R - delta) / R))
    from knotsim.contact.potential import imc_energy_derivatives

    _, dE, _ = imc_energy_derivatives(delta, 2 * R, 5e-4)
    # EE contact: each edge gets k_c |E'| in total, parallel over its two nodes
    assert s["contact_force_total"] == pytest.approx(kc * abs(dE), rel=1e-6)
    assert s["friction_force_total"] == 0.0
    assert s["k_c"] == kc
    assert set(ci.timers) == {"broad_phase", "narrow_phase"}


def test_check_rejects_penetration_and_stale_broad_phase():
    m = two_rods(1.9e-3)
    ci, st = prepared(m, ContactOptions())
    k0 = ci.k_c
    q = st.q.copy()
    nb = m.node_dof[m.rod_node_start[1]:]
    q[nb + 2] -= 0.6e-3  # Δ ≈ 1.3 mm: penetration 0.7 R > 0.2 R
    reason = ci.check(q)
    assert reason and "penetration" in reason
    assert ci.k_c > k0  # adaptive: boosted for the retry
    q = st.q.copy()
    q[nb + 2] += 1.5e-3  # moved away by more than margin / 2, but no new pair in range: accepted
    assert ci.check(q) is None
    assert ci.check(st.q) is None
    # a rod out of the list (gap 6 mm > d + delta + margin) moved into contact during the step
    m = two_rods(6e-3)
    ci, st = prepared(m, ContactOptions())
    assert ci.pairs.shape[0] == 0
    q = st.q.copy()
    q[nb + 2] -= 4.1e-3
    reason = ci.check(q)
    assert reason and "stale" in reason
    ci.begin_step(st, 1e-3)  # the retry rebuilds the list
    assert ci.n_rebuilds == 2
    # small motions reuse the list (same arrays: the Jacobian pattern is unchanged)
    dofs = ci.block_dofs()
    st.q = st.q + 1e-4
    ci.begin_step(st, 1e-3)
    assert ci.block_dofs() is dofs and ci.n_rebuilds == 2  # unchanged Jacobian pair set


def test_no_pairs_far_apart():
    m = two_rods(0.05)
    ci, st = prepared(m, ContactOptions())
    assert ci.pairs.shape == (0, 2) and ci.block_dofs().shape == (0, 12)
    r = np.zeros(m.n_dofs)
    e, blocks = ci.evaluate(st.q, st.q, 1e-3, r, True)
    assert e == 0.0 and blocks.shape == (0, 12, 12) and not r.any()
    assert ci.check(st.q) is None
    s = ci.stats()
    assert s["n_contacts"] == 0 and math.isnan(s["min_gap"])


def test_mu_table_per_rod_pair():
    m = two_rods()
    ci = Contact(m, ContactOptions(mu={("A", "B"): 0.3, ("A", "A"): 0.1, "default": 0.05}))
    np.testing.assert_allclose(ci._mu_table, [[0.1, 0.3], [0.3, 0.05]])
    with pytest.raises(ConfigError, match="contact.mu"):
        Contact(m, ContactOptions(mu={("A", "C"): 0.3}))


@pytest.mark.parametrize("kwargs, field", [
    ({"delta": -1.0}, "contact.delta"),
    ({"nu": 0.0}, "contact.nu"),
    ({"mu": -0.1}, "contact.mu"),
    ({"stiffness_mode": "magic"}, "contact.stiffness_mode"),
    ({"stiffness_mode": "constant"}, "contact.stiffness"),
    ({"margin": float("nan")}, "contact.margin"),
    ({"penetration_limit": 0.0}, "contact.penetration_limit"),
    ({"self_contact": "yes"}, "contact.self_contact"),
    ({"stiffness_scaler": 0}, "contact.stiffness_scaler"),
    ({"parallel_smoothing": -1e-3}, "contact.parallel_smoothing"),
    ({"parallel_smoothing": 0.5}, "contact.parallel_smoothing"),
])
def test_settings_validation_names_field(kwargs, field):
    with pytest.raises(ConfigError) as exc:
        ContactOptions(**kwargs).validate()
    assert exc.value.field.startswith(field)


def test_contact_from_config():
    m = two_rods()
    (ci,) = contact_from_config(m, {"delta": 4e-4, "mu": {"default": 0.2, "A,B": 0.5}, "margin": 1e-3})
    assert ci.name == "contact" and ci.options.delta == 4e-4
    np.testing.assert_allclose(ci._mu_table, [[0.2, 0.5], [0.5, 0.2]])
    with pytest.raises(ConfigError) as exc:
        contact_from_config(m, {"delt": 1e-3})
    assert exc.value.field == "contact.delt"
    with pytest.raises(ConfigError):
        contact_from_config(m, {"mu": {"A": 0.5}})


def test_finely_meshed_straight_rod_has_no_self_contact():
    """Edges i and i + 3 of a straight rod with l = 1 mm and h = 2 mm are closer than 2h; they must
    not count as contact (same rule as the knot generator: (|i-j| - 1) l >= 1.5 d)."""
    from knotsim.contact.model import Contact, ContactOptions
    from knotsim.rods import Model, RodSpec
    from knotsim.solver.state import initial_state

    x = np.zeros((201, 3))
    x[:, 0] = np.linspace(0.0, 0.2, 201)
    m = Model([RodSpec(x, radius=2e-3, youngs_modulus=1e6, density=1000.0)])
    ci = Contact(m, ContactOptions())
    st = initial_state(m)
    ci.begin_step(st, 1e-3)
    assert ci._rod_min_gap[0] == 7
    r = np.zeros(m.n_dofs)
    energy, _ = ci.evaluate(st.q, st.q, 1e-3, r, True)
    assert energy == 0.0 and np.all(r == 0.0)
    assert ci.pairs.shape[0] == 0 or np.all(np.abs(np.diff(ci.pairs, axis=1)) >= 7)


def test_describe_near_names_pair_gap_and_angle():
    """The failure diagnosis names the closest pair at a node, its gap and the angle between its
    edges, and flags nearly parallel edges (where the exact edge-edge distance has a kink)."""
    import numpy as np

    from knotsim.contact.model import Contact, ContactOptions
    from knotsim.rods import Model, RodSpec
    from knotsim.solver.state import initial_state

    def rod(points, name):
        return RodSpec(np.asarray(points, float), radius=1.6e-3, youngs_modulus=0.18e6, density=1180.0, name=name)

    xs = np.linspace(0.0, 0.1, 11)
    base = rod([[x, 0.0, 0.0] for x in xs], "a")
    parallel = rod([[x, 0.0, 3.3e-3] for x in xs], "b")
    crossing = rod([[0.05, -0.05 + 0.01 * k, 3.3e-3] for k in range(11)], "c")
    for other, parallel_expected in ((parallel, True), (crossing, False)):
        m = Model([base, other])
        contact = Contact(m, ContactOptions())
        state = initial_state(m)
        contact.begin_step(state, 1e-3)
        text = contact.describe_near(state.q, 5)
        assert "gap of" in text and "deg apart" in text, text
        assert ("nearly parallel" in text) is parallel_expected, text
        angle = float(text.split("(")[1].split(" deg")[0])
        assert angle == pytest.approx(0.0 if parallel_expected else 90.0, abs=1e-6)
        if not parallel_expected:  # node 0 of rod a is 5 cm from the crossing rod: no candidate pair
            assert contact.describe_near(state.q, 0) == ""
