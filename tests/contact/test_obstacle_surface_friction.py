"""Surface friction against rigid obstacles (friction_model = "surface") and free-spinning obstacles.

* the kernel's force against a slow NumPy reference written from the definitions (cross products,
  ``Q = Bᵀ f`` with ``B`` built column by column as the linear map ``ż ↦ v_s``), over whole models:
  open rods (end nodes), a closed ring, a 2-node rod, moving and spinning obstacles;
* the Jacobian of a node's stencil against central differences (step 2e-9 in m and rad; tolerance
  1e-5 of the largest entry) at an interior node, both ends, zero slip (q = q_prev, series branch of
  φ), θ = θ_prev, a rod standing on end (t ∥ n), plane, capsule and sphere, and the whole
  interaction's blocks against central differences of its residual (blocks accumulated with
  ``np.add.at``, as the stepper does);
* ``"centreline"``: the obstacle's residual and blocks equal the old kernel call's bit for bit;
* dissipation: the power of friction on rods and obstacle, ``Q·ż − Σ f·w(y)``, equals ``Σ f·u ≤ 0``;
* dynamics: a rod on a floor (μ = 0.3) kicked sideways rolls with ``"surface"`` (its edge angles
  advance by −Δy/h, speed 2/3 of the kick, tangential reaction below 2 % of μ F_n) and slides with
  ``"centreline"`` (reaction μ F_n, deceleration μ g);
* the thick-rope capstan: the surface law gives ``exp(μ θ R/(R + h))``;
* free spin: the spin update solves ``I (ω − ω_n)/dt = P M(ω)`` (NumPy reference of ``M``), the
  objective's gradient and Hessian against differences; a pulley under a jerked rope spins with
  the friction moment, and checkpoints keep the spin (2T = T + T bit for bit);
* errors name the field and value.
"""

from __future__ import annotations

import numpy as np
import pytest

import knotsim as ks
from knotsim.contact.friction import FRICTION_SHARPNESS
from knotsim.contact.obstacle_kernels import CAPSULE, PLANE, SPHERE, obstacle_evaluate
from knotsim.contact.obstacle_surface_kernels import node_surface_contact, spin_objective, spin_update
from knotsim.contact.obstacles import node_stencils
from knotsim.contact.potential import imc_energy_derivatives
from knotsim.errors import ConfigError
from knotsim.solver.state import initial_state

FD = 1e-7
#: finite-difference step of the single-stencil checks (m, rad): their contacts are stiffer and the
#: zero-slip case sits in the viscous branch of φ (K2 = 1.5e4 s/m): truncation error 2e-3 of the
#: largest entry at 1e-7, 2e-7 at 1e-9
FD_NODE = 2e-9
H_ROD = 1.6e-3


def rope(n=11, length=0.1, z=1.0e-3, closed=False, name="", h=H_ROD):
    if closed:
        a = np.linspace(0, 2 * np.pi, n, endpoint=False)
        x = np.stack([0.02 * np.cos(a), 0.02 * np.sin(a), np.full(n, z)], 1)
    else:
        x = np.zeros((n, 3))
        x[:, 0] = np.linspace(0, length, n)
        x[:, 2] = z
    return ks.RodSpec(x, radius=h, youngs_modulus=1e6, density=1000, closed=closed, name=name)


MAKERS = {
    "plane": lambda m, **kw: ks.Plane(m, "p", point=(0, 0, 0), normal=(0.1, 0.2, 1.0), mu=0.4, path=[0.02, 0, 0.01],
                                      stiffness=50.0, delta=2e-3, **kw),
    "capsule": lambda m, **kw: ks.Capsule(m, "c", a=(-0.1, 0.0, -0.03), b=(0.3, 0.0, -0.03), radius=0.03, mu=0.4,
                                          angular_velocity=(1.0, 0, 0.5), stiffness=50.0, delta=2e-3, **kw),
    "sphere": lambda m, **kw: ks.Sphere(m, "s", center=(0.02, 0.0, -0.04), radius=0.04, mu=0.4, stiffness=50.0,
                                        delta=2e-3, path=[0.0, 0.01, 0.0], **kw),
}


def perturbed(model, obs, seed=0, dt=0.01):
    rng = np.random.default_rng(seed)
    st = initial_state(model)
    st.q = st.q + rng.normal(0, 3e-4, st.q.shape)
    obs.begin_step(st, dt)
    q_prev = st.q.copy()
    q = q_prev + rng.normal(0, 1e-4, q_prev.shape)
    q[model.theta_mask] += rng.normal(0, 0.05, int(model.theta_mask.sum()))
    return q, q_prev


# ---------------------------------------------------------------- NumPy reference
def ref_normal(kind, x, geom):
    """Distance to the defining set and unit normal, from the closest point."""
    if kind == PLANE:
        nrm = geom[3:6]
        return float((x - geom[:3]) @ nrm), nrm, 0.0
    if kind == SPHERE:
        r = x - geom[:3]
        return float(np.linalg.norm(r)), r / np.linalg.norm(r), geom[6]
    a, b = geom[:3], geom[3:6]
    s = float(np.clip((x - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1))
    r = x - (a + s * (b - a))
    return float(np.linalg.norm(r)), r / np.linalg.norm(r), geom[6]


def ref_residual(obs, q, q_prev, dt):
    """−(contact + surface friction) from the definitions, node by node, edge by edge (slow)."""
    m = obs.model
    res = np.zeros(m.n_dofs)
    K2 = FRICTION_SHARPNESS / obs.nu
    om = obs.surface_omega
    for node, h in zip(obs.nodes, obs.node_h, strict=True):
        j = m.node_dof[node]
        x = q[j:j + 3]
        dist, n, R = ref_normal(obs.kind, x, obs._geom)
        d = h + R
        if dist >= d + obs.delta:
            continue
        _, dE, _ = imc_energy_derivatives(dist, d, obs.delta)
        fn = -obs.k_c * dE
        res[j:j + 3] -= fn * n
        # unknowns the surface point's velocity depends on, and the linear map B: ż ↦ v_s
        edges = [e for e in range(m.n_edges) if node in m.edge_nodes[e]]
        cols = sorted({int(c) for e in edges for c in (*m.stretch_dofs[e], m.edge_theta_dof[e])})
        w = 1.0 / len(edges)

        def surface_velocity(zdot, edges=edges, w=w, h=h, n=n, j=j):
            v = zdot[j:j + 3].copy()
            for e in edges:
                a, b = m.edge_nodes[e]
                ev = q[m.node_dof[b]:m.node_dof[b] + 3] - q[m.node_dof[a]:m.node_dof[a] + 3]
                l = np.linalg.norm(ev)
                t = ev / l
                edot = zdot[m.node_dof[b]:m.node_dof[b] + 3] - zdot[m.node_dof[a]:m.node_dof[a] + 3]
                Om = np.cross(t, edot) / l + zdot[m.edge_theta_dof[e]] * t
                v += w * np.cross(Om, -h * n)
            return v

        B = np.zeros((3, len(cols)))
        for c, col in enumerate(cols):
            e = np.zeros(m.n_dofs)
            e[col] = 1.0
            B[:, c] = surface_velocity(e)
        zdot = (q - q_prev) / dt
        y = x - h * n
        wo = obs._vel + np.cross(om, y - obs._cen)
        rel = surface_velocity(zdot) - wo
        u = rel - (rel @ n) * n
        s = np.linalg.norm(u)
        f = np.zeros(3) if s == 0 else -obs.mu * fn * np.tanh(K2 * s / 2) * u / s
        res[cols] -= B.T @ f
    return res


def accumulate(model, dofs, blocks):
    J = np.zeros((model.n_dofs, model.n_dofs))
    for d, b in zip(dofs, blocks, strict=True):
        np.add.at(J, np.ix_(d, d), b)
    return J


@pytest.mark.parametrize("kind", list(MAKERS))
def test_force_matches_reference(kind):
    """Two open rods (11 and 2 nodes) and a closed ring: the kernel's residual is the reference's."""
    model = ks.Model([rope(), rope(n=2, length=0.02, name="short"), rope(n=9, closed=True, name="ring")])
    obs = MAKERS[kind](model, spin_inertia=1e-6) if kind == "sphere" else MAKERS[kind](model)
    if kind == "sphere":
        obs.spin = np.array([3.0, -2.0, 5.0])  # a ball spinning freely about a general axis
    q, q_prev = perturbed(model, obs)
    r = np.zeros(model.n_dofs)
    obs.evaluate(q, q_prev, 0.01, r, False)
    ref = ref_residual(obs, q, q_prev, 0.01)
    touching = np.count_nonzero(np.linalg.norm(obs._ff, axis=1))
    assert touching >= 4, touching
    assert np.max(np.abs(r - ref)) <= 1e-12 * np.max(np.abs(ref))
    assert np.any(r[model.theta_mask] != 0.0)  # the friction turns edge angles


@pytest.mark.parametrize("kind", list(MAKERS))
def test_interaction_blocks_match_fd(kind):
    """The assembled blocks are ∂residual/∂q of the whole model (ends, 2-node rod, ring)."""
    model = ks.Model([rope(), rope(n=2, length=0.02, name="short"), rope(n=9, closed=True, name="ring")])
    obs = MAKERS[kind](model)
    q, q_prev = perturbed(model, obs, seed=1)
    r0 = np.zeros(model.n_dofs)
    _, blocks = obs.evaluate(q, q_prev, 0.01, r0, True)
    assert blocks.shape[1:] == (11, 11)
    J = accumulate(model, obs.block_dofs(), blocks)
    Jf = np.zeros_like(J)
    for k in range(model.n_dofs):
        dq = np.zeros(model.n_dofs)
        dq[k] = FD
        rp, rm = np.zeros(model.n_dofs), np.zeros(model.n_dofs)
        obs.evaluate(q + dq, q_prev, 0.01, rp, False)
        obs.evaluate(q - dq, q_prev, 0.01, rm, False)
        Jf[:, k] = (rp - rm) / (2 * FD)
    assert np.max(np.abs(Jf - J)) <= 1e-5 * np.max(np.abs(J))
    # the angle columns matter: friction torques depend on the spin
    assert np.max(np.abs(J[np.ix_(model.theta_mask, model.theta_mask)])) > 0.0


def stencil_case(kind, geom, wA, wB, z, zp, vel=(0, 0, 0), omega=(0, 0, 0), center=(0, 0, 0), mu=0.4, nu=1e-3,
                 stick=None):
    """Force, Jacobian and its central differences of one node; ``stick = (ξ0 (3,), μ_L, κ)``: the
    elastic-stick law (else the smooth law)."""
    law = (np.zeros(3), 0.0, 0.0) if stick is None else (np.asarray(stick[0], float), stick[1], stick[2])
    xo = np.zeros(3)
    force = np.zeros(11)
    jac = np.zeros((11, 11))
    gr, Hm = np.zeros(3), np.zeros((3, 3))
    args = (kind, z, zp, wA, wB, 0.01, geom, H_ROD, 2e-3, 50.0, mu, nu, np.array(vel, float),
            np.array(omega, float), np.array(center, float))
    node_surface_contact(*args, force, jac, True, gr, Hm, *law, xo)
    out = (force.copy(), jac.copy())
    Jf = np.zeros((11, 11))
    for mcol in range(11):
        dz = np.zeros(11)
        dz[mcol] = FD_NODE
        fp, fm = np.zeros(11), np.zeros(11)
        node_surface_contact(kind, z + dz, *args[2:], fp, jac, False, gr, Hm, *law, xo)
        node_surface_contact(kind, z - dz, *args[2:], fm, jac, False, gr, Hm, *law, xo)
        Jf[:, mcol] = (fp - fm) / (2 * FD_NODE)
    return out[0], out[1], Jf


def stencil(rng, straight=False, up=False):
    """An 11-unknown stencil near a floor at z = 0 (nodes 1 cm apart, centre node in contact)."""
    xs = [np.array([-0.01, 0.0, 0.0]), np.array([0.0, 0.0, 0.0]), np.array([0.01, 0.0, 0.0])]
    if up:  # standing on end: edges along the normal
        xs = [np.array([0.0, 0.0, 0.01]), np.zeros(3), np.array([0.0, 0.0, 0.01])]
    z = np.zeros(11)
    for k, x in zip((0, 4, 8), xs, strict=True):
        z[k:k + 3] = x + (0 if straight else rng.normal(0, 1e-3, 3))
    z[[4, 5, 6]] += [0, 0, H_ROD + 2e-4]
    z[3], z[7] = rng.normal(0, 1, 2)
    return z


PLANE_GEOM = np.array([0.0, 0, 0, 0, 0, 1, 0])


@pytest.mark.parametrize("case", ["interior", "first", "last", "zero_slip", "theta_still", "standing", "capsule",
                                  "sphere", "spinning_obstacle"])
def test_node_jacobian_matches_fd(case):
    rng = np.random.default_rng(7)
    wA, wB = {"first": (0.0, 1.0), "last": (1.0, 0.0), "standing": (1.0, 0.0)}.get(case, (0.5, 0.5))
    z = stencil(rng, up=case == "standing")
    zp = z + rng.normal(0, 2e-5, 11)
    zp[[3, 7]] = z[[3, 7]] + rng.normal(0, 0.02, 2)
    if case == "zero_slip":
        zp = z.copy()
    if case == "theta_still":
        zp[[3, 7]] = z[[3, 7]]
    kw = {}
    kind, geom = PLANE, PLANE_GEOM
    if case == "capsule":
        kind, geom = CAPSULE, np.array([-0.05, 0.0, -0.02, 0.05, 0.01, -0.02, 0.02 - 2e-4])
    if case == "sphere":
        kind, geom = SPHERE, np.array([0.001, 0.002, -0.03, 0, 0, 0, 0.03 - 2e-4])
    if case == "spinning_obstacle":
        kind, geom = SPHERE, np.array([0.001, 0.002, -0.03, 0, 0, 0, 0.03 - 2e-4])
        kw = {"vel": (0.001, -0.002, 0.0), "omega": (0.3, -0.5, 0.7), "center": (0.001, 0.002, -0.03)}
    F, J, Jf = stencil_case(kind, geom, wA, wB, z, zp, **kw)
    assert np.linalg.norm(F[4:7]) > 0.0
    if case not in ("zero_slip",):
        assert np.linalg.norm(F[[0, 1, 2, 3, 7, 8, 9, 10]]) > 0.0 or case == "standing"
    else:
        assert np.all(F[[0, 1, 2, 3, 7, 8, 9, 10]] == 0.0)  # no slip, no friction
    assert np.max(np.abs(Jf - J)) <= 1e-5 * np.max(np.abs(J)), np.max(np.abs(Jf - J)) / np.max(np.abs(J))
    # the missing edge's slots carry nothing
    if wA == 0.0:
        assert np.all(J[:4] == 0) and np.all(J[:, :4] == 0) and np.all(F[:4] == 0)
    if wB == 0.0:
        assert np.all(J[7:] == 0) and np.all(J[:, 7:] == 0) and np.all(F[7:] == 0)


@pytest.mark.parametrize("regime", ["stick", "slide"])
@pytest.mark.parametrize("case", ["interior", "first", "zero_slip", "capsule"])
def test_node_jacobian_matches_fd_stick_law(case, regime):
    """The elastic-stick law (docs/physics.md §3.6) at an obstacle: exact Jacobian while the spring
    holds (κ|ξ| < μ_L) and while it slides (beyond), also with no motion over the step (the
    start spring alone pulls)."""
    rng = np.random.default_rng(8)
    wA, wB = (0.0, 1.0) if case == "first" else (0.5, 0.5)
    z = stencil(rng)
    zp = z + rng.normal(0, 2e-5, 11)
    zp[[3, 7]] = z[[3, 7]] + rng.normal(0, 0.02, 2)
    if case == "zero_slip":
        zp = z.copy()
    kind, geom = PLANE, PLANE_GEOM
    if case == "capsule":
        kind, geom = CAPSULE, np.array([-0.05, 0.0, -0.02, 0.05, 0.01, -0.02, 0.02 - 2e-4])
    xi0 = np.array([3e-5, -2e-5, 0.0])
    # the spring at the iterate with the law switched on at a tiny κ (always elastic): its length
    xo = np.zeros(3)
    args = (kind, z, zp, wA, wB, 0.01, geom, H_ROD, 2e-3, 50.0, 0.4, 1e-3, np.zeros(3), np.zeros(3), np.zeros(3))
    node_surface_contact(*args, np.zeros(11), np.zeros((11, 11)), False, np.zeros(3), np.zeros((3, 3)), xi0, 0.4,
                         1e-12, xo)
    r = np.linalg.norm(xo)
    assert r > 0.0
    kappa = (0.3 if regime == "stick" else 3.0) * 0.4 / r
    F, J, Jf = stencil_case(kind, geom, wA, wB, z, zp, stick=(xi0, 0.4, kappa))
    fn = np.linalg.norm(F[4:7] - (F[4:7] @ np.array([0, 0, 1.0])) * np.array([0, 0, 1.0])) if kind == PLANE else None
    assert np.max(np.abs(Jf - J)) <= 1e-5 * np.max(np.abs(J)), np.max(np.abs(Jf - J)) / np.max(np.abs(J))
    if fn is not None:  # the tangential force: κ F_n |ξ| sticking, μ_L F_n sliding (lever terms aside)
        assert fn > 0.0


def test_stencils_layout():
    model = ks.Model([rope(n=4), rope(n=2, length=0.02, name="short"), rope(n=3, closed=True, name="ring")])
    dofs, w = node_stencils(model, np.arange(model.n_nodes))
    # rod 0 (dofs 0..14): first node padded with node 2 and edge 1; last node with node 1 and edge 1
    assert dofs[0].tolist() == [8, 9, 10, 7, 0, 1, 2, 3, 4, 5, 6] and w[0].tolist() == [0.0, 1.0]
    assert dofs[3].tolist() == [8, 9, 10, 11, 12, 13, 14, 7, 4, 5, 6] and w[3].tolist() == [1.0, 0.0]
    assert dofs[1].tolist() == list(range(11)) and w[1].tolist() == [0.5, 0.5]
    # the ring (starts at dof 22, 3 nodes, 3 edges) wraps around
    assert dofs[6].tolist() == [30, 31, 32, 33, 22, 23, 24, 25, 26, 27, 28] and w[6].tolist() == [0.5, 0.5]
    assert all(len(set(d)) == 11 for i, d in enumerate(dofs) if model.node_rod[i] != 1)


@pytest.mark.parametrize("kind", list(MAKERS))
def test_centreline_is_the_old_kernel_bit_for_bit(kind):
    model = ks.Model([rope(), rope(n=9, closed=True, name="ring")])
    obs = MAKERS[kind](model, friction_model="centreline")
    q, q_prev = perturbed(model, obs, seed=2)
    r = np.zeros(model.n_dofs)
    _, blocks = obs.evaluate(q, q_prev, 0.01, r, True)
    k = obs.nodes.size
    r_old = np.zeros(model.n_dofs)
    b_old = np.zeros((k, 3, 3))
    scratch = [np.zeros((k, 3)), np.zeros((k, 3)), np.zeros(k), np.zeros((k, 3))]
    obstacle_evaluate(obs.kind, obs._geom, obs.nodes, model.node_dof, obs.node_h, q, q_prev, 0.01, obs.delta, obs.k_c,
                      obs.mu, obs.nu, obs._vel, obs.omega, obs._cen, r_old, True, b_old, *scratch)
    assert np.array_equal(r, r_old) and np.array_equal(blocks, b_old)
    assert np.array_equal(obs.block_dofs(), obs._dofs) and np.count_nonzero(scratch[1]) > 0


@pytest.mark.parametrize("kind", list(MAKERS))
def test_friction_dissipates(kind):
    model = ks.Model([rope(), rope(n=9, closed=True, name="ring")])
    for seed in range(4):
        obs = MAKERS[kind](model)
        q, q_prev = perturbed(model, obs, seed=10 + seed)
        r_mu, r_0 = np.zeros(model.n_dofs), np.zeros(model.n_dofs)
        obs.evaluate(q, q_prev, 0.01, r_mu, False)
        ff = obs._ff.copy()
        vs = obs._vs.copy()
        x = q[obs._dofs]
        y = x - obs.node_h[:, None] * obs._normal
        w = obs._vel + np.cross(obs.surface_omega, y - obs._cen)
        obs.mu = 0.0
        obs.evaluate(q, q_prev, 0.01, r_0, False)
        Q = -(r_mu - r_0)  # generalised friction force
        power_rods = Q @ ((q - q_prev) / 0.01)
        power_obstacle = -np.einsum("ij,ij->", ff, w)
        total = power_rods + power_obstacle
        scale = np.abs(ff).sum() * np.abs((q - q_prev) / 0.01).max()
        assert total <= 1e-12 * scale and total < -1e-3 * scale
        # virtual power: Q·ż = Σ f·v_s, so the total is Σ f·u (f is tangential)
        assert total == pytest.approx(np.einsum("ij,ij->", ff, vs - w), rel=1e-9)


# ---------------------------------------------------------------- dynamics
def floor_rod(model_kw=None, n=11, length=0.1, v0=0.05, k_c=100.0):
    """A rod resting on a floor at its equilibrium gaps (fixed k_c), kicked across its axis (+y)."""
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0, length, n)
    spec = ks.RodSpec(x, radius=H_ROD, youngs_modulus=1e6, density=1000, velocities=np.tile([0, v0, 0], (n, 1)))
    m0 = ks.Model([spec])
    weight = m0.mass[m0.node_dof] * 9.81
    delta = 5e-4
    for i, wgt in enumerate(weight):  # bisection: k_c (−E'(Δ)) = node weight
        lo, hi = H_ROD - 1e-4, H_ROD + delta
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            if -k_c * imc_energy_derivatives(mid, H_ROD, delta)[1] > wgt:
                lo = mid
            else:
                hi = mid
        x[i, 2] = 0.5 * (lo + hi)
    spec.positions = x
    return ks.Model([spec], gravity=(0, 0, -9.81))


@pytest.mark.parametrize("model_name", ["surface", "centreline"])
def test_kicked_rod_rolls_or_slides(model_name):
    mu, v0, g = 0.3, 0.05, 9.81
    model = floor_rod(v0=v0)
    floor = ks.Plane(model, "floor", mu=mu, stiffness=100.0, friction_model=model_name)
    sim = ks.Simulation(model, ks.BoundaryConditions(model), ks.SolverOptions(dt=5e-4), interactions=[floor])
    fn = model.total_mass() * g
    if model_name == "surface":
        # spin-up by slip until t* = v0/(3 μ g) = 5.7 ms, then rolling at 2/3 v0
        sim.run(0.012)
        y0 = model.node_positions(sim.state.q)[:, 1].mean()
        th0 = model.edge_angles(sim.state.q).mean()
        log = sim.run(0.02)
        dy = model.node_positions(sim.state.q)[:, 1].mean() - y0
        dth = model.edge_angles(sim.state.q).mean() - th0
        assert -dth * H_ROD == pytest.approx(dy, rel=0.01), (dth * H_ROD, dy)
        assert sim.state.v[model.node_dof + 1].mean() == pytest.approx(2 / 3 * v0, rel=0.02)
        late = log[log["time"] > 0.013]
        assert late["floor_fy"].abs().max() <= 0.02 * mu * fn
    else:
        log = sim.run(0.012)
        late = log[log["time"] > 0.002]
        # friction on the rod opposes the motion (−y): on the floor it points along +y
        assert late["floor_fy"].mean() == pytest.approx(mu * fn, rel=0.02)
        assert sim.state.v[model.node_dof + 1].mean() == pytest.approx(v0 - mu * g * 0.012, rel=0.03)
        dth = model.edge_angles(sim.state.q).mean() - model.edge_angles(initial_state(model).q).mean()
        assert abs(dth) * H_ROD <= 1e-3 * 0.012 * v0


def test_thick_rope_capstan():
    """The surface law's capstan: moment balance about the post with the rope's tension at radius
    ``R + h`` and the friction at ``R`` gives ``T1/T2 = exp(μ θ R/(R + h))`` (here 1 % below the thin
    rope's ``exp(μ θ)``, which the centre-line law gives, tests/contact/test_capstan.py)."""
    from tests.contact.test_capstan import H, R, capstan_rope

    mu = 0.5
    model = ks.Model([ks.RodSpec(capstan_rope(), radius=H, youngs_modulus=1e8, density=1000)], damping=0.05)
    post = ks.Capsule(model, "post", a=(0, -0.05, 0), b=(0, 0.05, 0), radius=R, mu=mu)
    bcs = ks.BoundaryConditions(model)
    bcs.force("load", nodes=[0], force=[0, 0, -1.0])
    bcs.move("pull", nodes=[-1], path=[0, 0, -0.02], twist=False)
    log = ks.Simulation(model, bcs, ks.SolverOptions(dt=2e-3), interactions=[post]).run(0.8)
    ratio = -log[log["time"] > 0.6]["pull_fz"].mean()
    assert ratio == pytest.approx(np.exp(mu * np.pi * R / (R + H)), rel=3e-3)
    assert abs(ratio / np.exp(mu * np.pi) - 1) > 0.01


# ---------------------------------------------------------------- free spin
def contact_data(rng, c=6):
    normal = rng.normal(size=(c, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    y = 0.03 * normal + rng.normal(0, 1e-3, (c, 3))
    return (rng.uniform(0.1, 1.0, c), normal, y, rng.normal(0, 0.01, (c, 3)), np.array([1e-3, 0, -2e-3]),
            np.zeros(3))


def ref_moment(spin, mu, nu, fn, normal, y, vs, vel, center):
    """Moment (N m) of the friction on the obstacle about ``center``, from the definitions."""
    K2 = FRICTION_SHARPNESS / nu
    M = np.zeros(3)
    for i in range(fn.size):
        r = y[i] - center
        w = vs[i] - vel - np.cross(spin, r)
        u = w - (w @ normal[i]) * normal[i]
        s = np.linalg.norm(u)
        f = -mu * fn[i] * np.tanh(K2 * s / 2) * u / s
        M += np.cross(r, -f)
    return M


PROJECTORS = {"axis": np.outer([0.6, 0.0, 0.8], [0.6, 0.0, 0.8]), "ball": np.eye(3)}


@pytest.mark.parametrize("proj", list(PROJECTORS))
def test_spin_objective_derivatives(proj):
    rng = np.random.default_rng(3)
    P = PROJECTORS[proj]
    fn, normal, y, vs, vel, center = contact_data(rng)
    spin_prev = P @ rng.normal(0, 0.3, 3)
    g, Hs, g2, H2 = np.zeros(3), np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3))
    args = (spin_prev, P, 2e-6, 1e-3, 0.4, 1e-3, fn, normal, y, vs, vel, center)
    spin = P @ rng.normal(0, 0.3, 3)
    spin_objective(spin, *args, g, Hs)
    eps = 1e-7
    gf, Hf = np.zeros(3), np.zeros((3, 3))
    for k in range(3):
        d = np.zeros(3)
        d[k] = eps
        gf[k] = (spin_objective(spin + d, *args, g2, H2) - spin_objective(spin - d, *args, g2, H2)) / (2 * eps)
        spin_objective(spin + d, *args, g2, H2)
        gp = g2.copy()
        spin_objective(spin - d, *args, g2, H2)
        Hf[:, k] = (gp - g2) / (2 * eps)
    assert np.allclose(g, P @ gf, rtol=1e-6, atol=1e-9 * np.abs(g).max())
    assert np.allclose(Hs, Hf @ P + (np.eye(3) - P), rtol=1e-5, atol=1e-6 * np.abs(Hs).max())
    # the gradient is I (ω − ω_n)/dt − P M(ω)
    assert np.allclose(g, 2e-6 / 1e-3 * (spin - spin_prev) - P @ ref_moment(spin, 0.4, 1e-3, fn, normal, y, vs, vel,
                                                                             center), rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("proj", list(PROJECTORS))
def test_spin_update_balances_the_friction_moment(proj):
    rng = np.random.default_rng(4)
    P = PROJECTORS[proj]
    fn, normal, y, vs, vel, center = contact_data(rng)
    for inertia in (1e-3, 1e-6, 1e-10):  # heavy, light, nearly massless
        spin_prev = P @ np.array([0.5, -0.2, 0.1])
        spin, it = spin_update(spin_prev, P, inertia, 1e-3, 0.4, 1e-4, fn, normal, y, vs, vel, center)
        M = ref_moment(spin, 0.4, 1e-4, fn, normal, y, vs, vel, center)
        scale = 0.4 * fn.sum() * 0.03
        assert np.allclose(inertia * (spin - spin_prev) / 1e-3, P @ M, rtol=0, atol=1e-9 * scale), it
        assert np.allclose(P @ spin, spin) and it < 60


def pulley_sim(spin_inertia=1e-6, mu=0.3, **kw):
    from tests.contact.test_capstan import H, R, capstan_rope

    model = ks.Model([ks.RodSpec(capstan_rope(), radius=H, youngs_modulus=1e8, density=1000)], damping=0.05)
    pulley = ks.Capsule(model, "pulley", a=(0, -0.05, 0), b=(0, 0.05, 0), radius=R, mu=mu,
                        spin_inertia=spin_inertia, **kw)
    bcs = ks.BoundaryConditions(model)
    bcs.force("load", nodes=[0], force=[0, 0, -1.0])
    bcs.move("pull", nodes=[-1], path=[0, 0, -0.02], twist=False)
    return ks.Simulation(model, bcs, ks.SolverOptions(dt=2e-3), interactions=[pulley]), pulley


def test_free_spin_continues_bit_for_bit(tmp_path):
    """A pulley (I = 1e-3 kg m²) on a frictionless axle under a rope that starts with a jerk (the
    1 N load snaps its leg down): T + T from a checkpoint equals 2T (the spin is run state); the
    spin follows the friction moment about the axle (angular momentum I ω against Σ M_y dt: 19 %
    apart here, the one-step lag of the staggered update, see knotsim.contact.obstacles)."""
    whole, pw = pulley_sim(spin_inertia=1e-3)
    log = whole.run(0.04)
    assert 1e-3 * pw.spin[1] == pytest.approx((log["pulley_my"] * log["dt"]).sum(), rel=0.25)
    assert pw.spin[1] < -0.05 and pw.spin[0] == 0.0 and pw.spin[2] == 0.0
    first, p1 = pulley_sim(spin_inertia=1e-3)
    first.run(0.02)
    assert p1.spin[1] < -0.05
    first.save_checkpoint(tmp_path / "ck")
    second, p2 = pulley_sim(spin_inertia=1e-3)
    second.restore(tmp_path / "ck")
    assert p2.spin[1] < -0.05  # restored (the spin before the last, shortened step of the first run)
    second.run(0.02)
    np.testing.assert_array_equal(second.state.q, whole.state.q)
    assert np.array_equal(p2.spin, whole.stepper.interactions[0].spin)


def test_errors_name_field_and_value():
    model = ks.Model([rope()])
    with pytest.raises(ConfigError, match=r"obstacles\.f\.friction_model.*'rolling'"):
        ks.Plane(model, "f", friction_model="rolling")
    with pytest.raises(ConfigError, match=r"obstacles\.f\.spin_inertia"):
        ks.Plane(model, "f", spin_inertia=1.0)
    with pytest.raises(ConfigError, match=r"obstacles\.c\.spin_inertia"):
        ks.Capsule(model, "c", spin_inertia=-1.0)
    with pytest.raises(ConfigError, match=r"obstacles\.c\.angular_velocity"):
        ks.Capsule(model, "c", spin_inertia=1.0, angular_velocity=(0, 0, 1))
    with pytest.raises(ConfigError, match=r"obstacles\.s\.initial_spin"):
        ks.Sphere(model, "s", initial_spin=(0, 0, 1))
    ball = ks.Sphere(model, "s", spin_inertia=1.0, spin_axis=(0, 0, 2), initial_spin=(1, 2, 3))
    assert np.array_equal(ball.spin, [0, 0, 3]) and ball.friction_model == "surface"


def test_run_file_keys():
    from knotsim.io.config import load_config

    base = {"rods": [{"name": "rope", "shape": "straight", "length": 0.1, "n_nodes": 11, "start": [0.0, 0.0, 2e-3],
                      "direction": [1.0, 0.0, 0.0], "radius": 1.6e-3, "youngs_modulus": 1e6, "density": 1000.0}],
            "obstacles": [{"type": "plane", "name": "floor", "mu": 0.3, "friction_model": "centreline"},
                          {"type": "sphere", "name": "ball", "center": [0.5, 0, 0.5], "radius": 0.02,
                           "spin_inertia": 1e-6, "spin_axis": [0, 1, 0], "initial_spin": [0, 2.0, 0]}],
            "solver": {"dt": 1e-3}, "run": {"duration": 0.01}}
    floor, ball = load_config(base).build_obstacles()
    assert floor.friction_model == "centreline" and ball.friction_model == "surface"
    assert ball.spin_inertia == 1e-6 and np.array_equal(ball.spin, [0, 2.0, 0])
    for change, field in (({"friction_model": "sticky"}, "obstacles[0].friction_model"),
                          ({"friction_model": 3}, "obstacles[0].friction_model"),
                          ({"spin_inertia": 1.0}, "obstacles[0].spin_inertia")):
        bad = {**base, "obstacles": [{**base["obstacles"][0], **change}]}
        with pytest.raises(ConfigError, match=field.replace("[", r"\[").replace("]", r"\]")):
            load_config(bad)
