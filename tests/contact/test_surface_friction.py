"""Smooth Coulomb friction at the rods' surfaces (:func:`surface_friction_pair`): forces against the
plain-numpy reference, the exact 14×14 Jacobian against finite differences, and the physics
(dissipation, rolling without slip, the small-radius limit, momentum balance, frame invariance).

The unknowns are ``z = (x0, x1, x2, x3, θ_a, θ_b)``. The contact force ``fc = −k_c ∇E``, its
Jacobian and ``∂β/∂p`` are always built from ``contact_pair_energy`` and
``edge_edge_beta_gradients`` (or ``regularized_beta_gradients`` with the regularized distance,
``η = ETA``) at the same ``p``, so the finite differences of ``z ↦ Q(z)`` (everything recomputed at
``z ± H e_m``, ``z_prev`` and ``dt`` fixed) test the full chain rule.

FD: central, step ``H = 1e-6`` (coordinates of order 1), only where the distance case and the side
of the energy cut-off are the same at all perturbed points. The angle rows and columns are made
dimensionless with a length ``ℓ = max(h_a, h_b)`` (``Q_θ/ℓ``, ``ℓ θ``) so that every block of the
Jacobian is in N/m; the tolerance is ``|FD − J|∞ <= JAC_RTOL · |J|∞`` on that scaled Jacobian,
``JAC_RTOL = 1e-5``. Typical parameters as in test_friction.py: ``dt = 0.1 s``, ``ν = 0.1 m/s``
(``K2 = 150 s/m``), ``δ = 0.05``, node displacements over the step from 1e-7 (deep stick, series
branch of φ) to 0.1 (full slip), radii ``h_a + h_b = d``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from knotsim.contact.distance import (
    CASE_EE,
    CASE_PP_10,
    N_CASES,
    edge_edge_beta_gradients,
    edge_edge_distance,
)
from knotsim.contact.friction import friction_pair
from knotsim.contact.potential import contact_pair_energy
from knotsim.contact.regularized_distance import regularized_beta_gradients, regularized_distance
from knotsim.contact.surface_friction import PAIR_UNKNOWNS, RECORD_SIZE, surface_friction_pair

from .reference_kernels import ref_surface_friction, ref_surface_normal, ref_surface_velocity_map

H = 1e-6
JAC_RTOL = 1e-5
DT = 0.1
NU = 0.1
K2 = 15.0 / NU
TOL = 0.05
KC = 10.0
ETA = 1e-3


@dataclasses.dataclass
class Pair:
    """A contact pair apart from its unknowns: the start of the step, the contact distance, the radii
    and the law's parameters (``eta = 0``: exact distance; ``eta > 0``: regularized distance)."""

    z_prev: np.ndarray
    d: float
    ha: float
    hb: float
    mu: float = 0.3
    eta: float = 0.0
    dt: float = DT
    nu: float = NU
    #: the elastic-stick law when ``kappa > 0`` (1/m): spring at the start of the step (m), limit
    xi0: tuple = (0.0, 0.0, 0.0)
    mu_limit: float = 0.0
    kappa: float = 0.0


@dataclasses.dataclass
class Result:
    Q: np.ndarray
    J: np.ndarray
    slip: float
    rolling: float
    fc: np.ndarray
    beta_a: float
    beta_b: float
    case: int
    delta: float
    record: np.ndarray | None = None


def distance(p, eta):
    return regularized_distance(p, eta) if eta > 0.0 else edge_edge_distance(p)


def contact_inputs(p, pair):
    g = np.zeros(12)
    h = np.zeros((12, 12))
    _, delta, ba, bb, case = contact_pair_energy(p, pair.d, TOL, g, h, pair.eta)
    dba = np.zeros(12)
    dbb = np.zeros(12)
    if pair.eta > 0.0:
        regularized_beta_gradients(p, pair.eta, ba, bb, case, dba, dbb)
    else:
        edge_edge_beta_gradients(p, ba, bb, case, dba, dbb)
    return -KC * g, -KC * h, ba, bb, dba, dbb, case, delta


def evaluate(z, pair, want_jacobian=True):
    p = np.array(z[:12], dtype=float)
    fc, dfc, ba, bb, dba, dbb, case, delta = contact_inputs(p, pair)
    Q = np.zeros(PAIR_UNKNOWNS)
    J = np.zeros((PAIR_UNKNOWNS, PAIR_UNKNOWNS))
    record = np.zeros(RECORD_SIZE)
    slip, rolling = surface_friction_pair(
        p, np.array(pair.z_prev[:12]), np.array(z[12:], dtype=float), np.array(pair.z_prev[12:]), pair.dt,
        pair.mu, pair.nu, pair.ha, pair.hb, fc, dfc, ba, bb, dba, dbb, np.array(pair.xi0, dtype=float),
        pair.mu_limit, pair.kappa, Q, J, record, want_jacobian,
    )
    return Result(Q, J, slip, rolling, fc, ba, bb, case, delta, record)


def reference(z, pair, res):
    """The reference forces for the contact inputs of ``res`` (the kernel's own ``fc`` and β)."""
    return ref_surface_friction(z[:12], pair.z_prev[:12], z[12:], pair.z_prev[12:], pair.dt, pair.mu, pair.nu,
                                pair.ha, pair.hb, res.fc, res.beta_a, res.beta_b)


def stable(z, pair, h=H):
    """Same distance case and side of the energy cut-off at every ``z ± h e_m``, and in contact."""
    p = np.array(z[:12])
    delta, _, _, case = distance(p, pair.eta)
    if delta >= pair.d + TOL:
        return False
    for m in range(12):
        for sgn in (1.0, -1.0):
            q = p.copy()
            q[m] += sgn * h
            dq, _, _, cq = distance(q, pair.eta)
            if cq != case or dq >= pair.d + TOL:
                return False
    return True


def jac_fd(z, pair, h=H):
    return np.column_stack([(evaluate(z + h * e, pair).Q - evaluate(z - h * e, pair).Q) / (2 * h)
                            for e in np.eye(PAIR_UNKNOWNS)])


def jac_fd_error(z, pair, h=H):
    """``|FD − J|∞ / |J|∞`` of the Jacobian with the angle rows and columns scaled by ``ℓ``."""
    J = evaluate(z, pair).J
    J_fd = jac_fd(z, pair, h)
    ell = max(pair.ha, pair.hb)
    D = np.ones(PAIR_UNKNOWNS)
    D[12:] = 1.0 / ell
    scale = np.abs(D[:, None] * J / D[None, :]).max()
    assert scale > 0.0
    return np.abs(D[:, None] * (J_fd - J) / D[None, :]).max() / scale


# ---------------------------------------------------------------------------------------------
# configurations


def random_pair(rng, disp, spin=None, x=None, w=None, mu=0.3):
    """Random edges (coordinates in [−1, 1]) with Δ > 0.05, ``d`` with Δ = d + x δ, radii
    ``(w d, (1 − w) d)``, node displacements ``disp`` and angle increments ``spin`` over the step."""
    while True:
        p = rng.uniform(-1, 1, 12)
        delta = edge_edge_distance(p)[0]
        if delta > 0.05:
            break
    x = rng.uniform(-1.5, 0.9) if x is None else x
    w = rng.uniform(0.1, 0.9) if w is None else w
    d = delta - x * TOL
    spin = disp / (w * d) * 10.0 ** rng.uniform(-1, 1) if spin is None else spin  # h_a Δθ ~ disp
    theta = rng.uniform(-3, 3, 2)
    z = np.concatenate([p, theta])
    z_prev = z - np.concatenate([disp * rng.normal(size=12), spin * rng.normal(size=2)])
    return z, Pair(z_prev, d, w * d, (1 - w) * d, mu)


def crossing_pair(angle, gap=0.1, shift=0.0, tilt=0.0, x=-0.2, w=0.6, eta=0.0):
    """Edge a along x (length 1, centred at the origin) at height ``gap``; edge b in the plane z = 0
    (or tilted out of it by ``tilt``), through ``(shift, 0, 0)`` at ``angle`` to edge a. At rest;
    ``d`` with Δ = d + x δ."""
    x0 = np.array([-0.5, 0.0, gap])
    x1 = np.array([0.5, 0.0, gap])
    b = np.array([np.cos(angle) * np.cos(tilt), np.sin(angle) * np.cos(tilt), np.sin(tilt)])
    x2 = np.array([shift, 0.0, 0.0]) - 0.5 * b
    p = np.concatenate([x0, x1, x2, x2 + b])
    delta = distance(p, eta)[0]
    d = delta - x * TOL
    z = np.concatenate([p, [0.3, -0.7]])
    return z, Pair(z.copy(), d, w * d, (1 - w) * d, eta=eta)


def with_motion(z, pair, rng, disp, spin):
    """The same pair with a random motion over the step: ``z_prev = z − (disp ξ, spin ξ)``."""
    z_prev = z - np.concatenate([disp * rng.normal(size=12), spin * rng.normal(size=2)])
    return dataclasses.replace(pair, z_prev=z_prev)


def rolling_angles(z, pair):
    """``z`` with the angles changed so that the surface points do not slip (``u = 0``): the two
    spins solve ``P B_θ θ̇ = −P B_x ẋ`` (reference map; needs crossing edges)."""
    fc, _, ba, bb, *_ = contact_inputs(np.array(z[:12]), pair)
    n, _ = ref_surface_normal(fc)
    B_tr, B_rot = ref_surface_velocity_map(z[:12], pair.ha, pair.hb, ba, bb, n)
    P = np.eye(3) - np.outer(n, n)
    B = P @ (B_tr + B_rot)
    xdot = (z[:12] - pair.z_prev[:12]) / pair.dt
    wdot = np.linalg.lstsq(B[:, 12:], -B[:, :12] @ xdot, rcond=None)[0]
    out = z.copy()
    out[12:] = pair.z_prev[12:] + pair.dt * wdot
    return out


def sample_states(seed, count):
    """Random pairs over stick (series branch), transition and slip, with spins from none to
    dominant; every tenth with the regularized distance."""
    rng = np.random.default_rng(seed)
    for it in range(count):
        disp = 10.0 ** rng.uniform(-7, -1)
        z, pair = random_pair(rng, disp, mu=rng.uniform(0.05, 1.0))
        if it % 5 == 1:
            z[12:] = pair.z_prev[12:]  # clamped twist
        elif it % 5 == 2:
            z[12:] = pair.z_prev[12:] + rng.normal(size=2) * 10.0 ** rng.uniform(-1, 0.7)  # spin dominated
        if it % 10 == 3:
            pair = dataclasses.replace(pair, eta=ETA)
        yield z, pair


# ---------------------------------------------------------------------------------------------
# values


def test_matches_reference_over_stick_and_slip():
    """Equal to the plain reference ``Q = Bᵀ f`` to 1e-12 of |Q|∞ (plus 1e-15 μ F_n), from deep stick
    (series branch of φ) to full slip, with and without spin, exact and regularized distance."""
    stick = slip = 0
    for it, (z, pair) in enumerate(sample_states(2025, 400)):
        res = evaluate(z, pair, want_jacobian=False)
        Q_ref = reference(z, pair, res)
        _, fn = ref_surface_normal(res.fc)
        if fn == 0.0:
            continue
        assert np.abs(res.Q - Q_ref).max() <= 1e-12 * np.abs(Q_ref).max() + 1e-15 * pair.mu * fn, it
        x = 0.5 * K2 * res.slip
        stick += x < 0.02
        slip += x > 5.0
    assert stick >= 20 and slip >= 20, (stick, slip)


def test_slip_and_rolling_speeds():
    """The returned ``(slip, rolling)`` are ``|P B ż|`` and ``|P B_rot ż|`` of the reference map
    (1e-12 relative to the largest surface speed)."""
    for it, (z, pair) in enumerate(sample_states(7, 150)):
        res = evaluate(z, pair, want_jacobian=False)
        n, fn = ref_surface_normal(res.fc)
        if fn == 0.0:
            assert res.slip == 0.0 and res.rolling == 0.0
            continue
        zdot = (z - pair.z_prev) / pair.dt
        B_tr, B_rot = ref_surface_velocity_map(z[:12], pair.ha, pair.hb, res.beta_a, res.beta_b, n)
        P = np.eye(3) - np.outer(n, n)
        u = P @ (B_tr + B_rot) @ zdot
        r = P @ B_rot @ zdot
        big = np.abs(B_tr @ zdot).max() + np.abs(B_rot @ zdot).max()
        assert abs(res.slip - np.linalg.norm(u)) <= 1e-12 * big, it
        assert abs(res.rolling - np.linalg.norm(r)) <= 1e-12 * big, it


def test_zero_contact_force_gives_zero_friction():
    z, pair = random_pair(np.random.default_rng(1), 0.01)
    Q = np.full(14, 3.0)
    J = np.full((14, 14), 3.0)
    zeros = np.zeros(12)
    out = surface_friction_pair(z[:12].copy(), pair.z_prev[:12].copy(), z[12:].copy(),
                                pair.z_prev[12:].copy(), DT, 0.3, NU, 0.1, 0.1, zeros, np.zeros((12, 12)),
                                0.5, 0.5, zeros, zeros, np.zeros(3), 0.0, 0.0, Q, J, np.full(RECORD_SIZE, 3.0), True)
    assert out == (0.0, 0.0) and not Q.any() and not J.any()


def test_force_only_evaluation_leaves_jacobian_untouched():
    z, pair = random_pair(np.random.default_rng(2), 0.01, x=-0.5)
    full = evaluate(z, pair)
    p = z[:12].copy()
    fc, dfc, ba, bb, dba, dbb, *_ = contact_inputs(p, pair)
    Q = np.zeros(14)
    J = np.full((14, 14), 7.0)
    surface_friction_pair(p, pair.z_prev[:12].copy(), z[12:].copy(), pair.z_prev[12:].copy(), DT, pair.mu, NU,
                          pair.ha, pair.hb, fc, dfc, ba, bb, dba, dbb, np.zeros(3), 0.0, 0.0, Q, J,
                          np.zeros(RECORD_SIZE), False)
    assert np.array_equal(Q, full.Q) and np.all(J == 7.0)


# ---------------------------------------------------------------------------------------------
# physics


def test_dissipation():
    """``Q·ż = f·u = −μ F_n tanh(K2|u|/2) |u| <= 0`` at every state (1e-12 relative)."""
    for it, (z, pair) in enumerate(sample_states(11, 300)):
        res = evaluate(z, pair, want_jacobian=False)
        _, fn = ref_surface_normal(res.fc)
        zdot = (z - pair.z_prev) / pair.dt
        power = res.Q @ zdot
        expected = -pair.mu * fn * np.tanh(0.5 * K2 * res.slip) * res.slip
        scale = np.abs(res.Q).max() * np.abs(zdot).max()
        assert power <= 1e-13 * scale, it
        assert abs(power - expected) <= 1e-12 * scale + 1e-300, it


def rolling_geometry(psi=1.0, V=0.5, ha=0.03, hb=0.02):
    """Rod a along x above rod b (edge b in the plane z = 0 at angle ψ to x), n = +z; over the step a
    translates by ``V dt`` along y, b is fixed; the angles are at rest (no spin)."""
    d = ha + hb
    gap = d - 0.2 * TOL
    b = np.array([np.cos(psi), np.sin(psi), 0.0])
    p_prev = np.concatenate([[-0.5, 0.0, gap], [0.5, 0.0, gap], -0.5 * b, 0.5 * b])
    p = p_prev.copy()
    p[1] += V * DT
    p[4] += V * DT
    theta_prev = np.array([0.2, -0.4])
    z = np.concatenate([p, theta_prev])
    return z, Pair(np.concatenate([p_prev, theta_prev]), d, ha, hb, mu=0.4)


def test_pure_rolling_gives_no_slip_and_no_force():
    """Rod a rolls on the fixed rod b: translation V ŷ with θ̇_a = −V/h_a gives u = 0 and Q = 0 (to
    1e-13 μ F_n); the same translation without spin slips at V (full slip: |f| = μ F_n, opposing
    the motion) with the torques ``Q_θa = −h_a (t_a × n)·f = −h_a μ F_n`` and
    ``Q_θb = −h_b cos ψ μ F_n``; rolling speed V when rolling, 0 when sliding."""
    psi, V, ha, hb = 1.0, 0.5, 0.03, 0.02
    z, pair = rolling_geometry(psi, V, ha, hb)
    slide = evaluate(z, pair)
    n, fn = ref_surface_normal(slide.fc)
    assert np.allclose(n, [0.0, 0.0, 1.0], rtol=0.0, atol=1e-14) and fn > 0.0
    assert slide.case == CASE_EE
    mufn = pair.mu * fn
    f = slide.Q[0:3] + slide.Q[3:6]
    assert np.allclose(f, [0.0, -mufn, 0.0], rtol=0.0, atol=1e-13 * mufn)
    assert np.allclose(slide.Q[6:9] + slide.Q[9:12], -f, rtol=0.0, atol=1e-13 * mufn)
    ta = np.array([1.0, 0.0, 0.0])
    assert slide.Q[12] == pytest.approx(-ha * np.cross(ta, n) @ f, rel=1e-13)
    assert slide.Q[12] == pytest.approx(-ha * mufn, rel=1e-13)
    assert slide.Q[13] == pytest.approx(-hb * np.cos(psi) * mufn, rel=1e-13)
    assert slide.slip == pytest.approx(V, rel=1e-13) and slide.rolling <= 1e-15 * V
    z_roll = z.copy()
    z_roll[12] -= V / ha * DT
    roll = evaluate(z_roll, pair)
    assert np.abs(roll.Q).max() <= 1e-13 * mufn
    assert roll.slip <= 1e-13 * V and roll.rolling == pytest.approx(V, rel=1e-13)
    # the rolling state is found as well by solving for the spins with the reference map
    assert np.allclose(rolling_angles(z, pair)[12:], z_roll[12:], rtol=0.0, atol=1e-12)
    # spinning the wrong way doubles the slip
    z_wrong = z.copy()
    z_wrong[12] += V / ha * DT
    assert evaluate(z_wrong, pair).slip == pytest.approx(2 * V, rel=1e-13)


def test_small_radius_limit_is_the_centreline_law():
    """h = 0: node forces ``(1 − β) f, β f`` on a, ``−(1 − β) f, −β f`` on b with
    ``f = −μ F_n φ(|u|) u`` of the centreline slip, no torques; and then (exact distance, where
    ``|F_c,k| = (1 − β) F_n`` etc.) force and Jacobian equal those of ``friction_pair``
    (1e-12). For small radii ``Q(εh) − Q(0)`` is linear in ε."""
    rng = np.random.default_rng(3)
    for it in range(40):
        disp = 10.0 ** rng.uniform(-7, -1)
        z, pair = random_pair(rng, disp, spin=rng.uniform(0.0, 0.1))
        pair0 = dataclasses.replace(pair, ha=0.0, hb=0.0)
        res = evaluate(z, pair0)
        n, fn = ref_surface_normal(res.fc)
        if fn == 0.0:
            continue
        v = ((z[:12] - pair.z_prev[:12]) / DT).reshape(4, 3)
        ba, bb = res.beta_a, res.beta_b
        w = (1 - ba) * v[0] + ba * v[1] - (1 - bb) * v[2] - bb * v[3]
        u = w - (w @ n) * n
        s = np.linalg.norm(u)
        f = -pair.mu * fn * np.tanh(0.5 * K2 * s) / s * u if s > 0 else np.zeros(3)
        expected = np.concatenate([(1 - ba) * f, ba * f, -(1 - bb) * f, -bb * f, [0.0, 0.0]])
        scale = np.abs(expected).max()
        assert np.abs(res.Q - expected).max() <= 1e-12 * scale + 1e-15 * pair.mu * fn, it
        assert not res.J[12:].any() and not res.J[:, 12:].any()
        # the existing centreline law, forces and Jacobian
        fc, dfc, ba, bb, dba, dbb, *_ = contact_inputs(z[:12].copy(), pair0)
        F = np.zeros(12)
        Jc = np.zeros((12, 12))
        friction_pair(z[:12].copy(), pair.z_prev[:12].copy(), DT, pair.mu, NU, fc, dfc, ba, bb, dba, dbb,
                      F, Jc)
        assert np.abs(res.Q[:12] - F).max() <= 1e-12 * scale + 1e-15 * pair.mu * fn, it
        assert np.abs(res.J[:12, :12] - Jc).max() <= 1e-11 * np.abs(Jc).max(), it
        # linear approach of the h = 0 limit
        diffs = [np.abs(evaluate(z, dataclasses.replace(pair, ha=eps * pair.ha, hb=eps * pair.hb)).Q
                        - res.Q).max() for eps in (1e-3, 1e-4)]
        assert diffs[0] > 0.0
        assert 0.09 <= diffs[1] / diffs[0] <= 0.11, (it, diffs)


def test_momentum_balance():
    """The four node forces sum to zero (f on a, −f on b, f = Q_x0 + Q_x1) and, exactly (not to
    O(h/l)), the moment of each rod's node forces plus its torque ``Q_θ t`` about the tangent is
    the moment of its friction force at its surface point:
    ``x0 × Q_x0 + x1 × Q_x1 + Q_θa t_a = (c_a − h_a n) × f``,
    ``x2 × Q_x2 + x3 × Q_x3 + Q_θb t_b = −(c_b + h_b n) × f`` (c: the centreline contact points).
    (Virtual power of a rigid rotation ω, for which θ̇ = ω·t: both sides are its power / ω.)"""
    for it, (z, pair) in enumerate(sample_states(13, 200)):
        res = evaluate(z, pair, want_jacobian=False)
        n, fn = ref_surface_normal(res.fc)
        if fn == 0.0:
            continue
        x = z[:12].reshape(4, 3)
        Qx = res.Q[:12].reshape(4, 3)
        f = Qx[0] + Qx[1]
        fmax = max(np.abs(res.Q[:12]).max(), 1e-300)
        assert np.abs(Qx[2] + Qx[3] + f).max() <= 1e-13 * fmax, it
        ta = (x[1] - x[0]) / np.linalg.norm(x[1] - x[0])
        tb = (x[3] - x[2]) / np.linalg.norm(x[3] - x[2])
        ca = (1 - res.beta_a) * x[0] + res.beta_a * x[1]
        cb = (1 - res.beta_b) * x[2] + res.beta_b * x[3]
        mom_a = np.cross(x[0], Qx[0]) + np.cross(x[1], Qx[1]) + res.Q[12] * ta
        mom_b = np.cross(x[2], Qx[2]) + np.cross(x[3], Qx[3]) + res.Q[13] * tb
        tol = 1e-13 * fmax * (np.abs(x).max() + 1.0)
        assert np.abs(mom_a - np.cross(ca - pair.ha * n, f)).max() <= tol, it
        assert np.abs(mom_b + np.cross(cb + pair.hb * n, f)).max() <= tol, it


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    return q if np.linalg.det(q) > 0 else -q


def test_frame_invariance():
    """Rotating and translating the configuration (now and at the start of the step) rotates the node
    forces and leaves the torques unchanged; the Jacobian transforms as ``R J Rᵀ`` block by block."""
    rng = np.random.default_rng(17)
    for it, (z, pair) in enumerate(sample_states(19, 60)):
        R = random_rotation(rng)
        c = rng.normal(size=3)
        T = np.eye(PAIR_UNKNOWNS)
        for k in range(4):
            T[3 * k:3 * k + 3, 3 * k:3 * k + 3] = R

        def move(zz, R=R, c=c, T=T):
            out = T @ zz
            out[:12] += np.tile(c, 4)
            return out

        res = evaluate(z, pair)
        rot = evaluate(move(z), dataclasses.replace(pair, z_prev=move(pair.z_prev)))
        assert rot.case == res.case, it
        # moving z and z_prev separately perturbs the velocities by eps |z| / |z − z_prev| (relative)
        amp = (np.abs(z[:12]).max() + np.abs(c).max()) / np.abs(z[:12] - pair.z_prev[:12]).max()
        rtol = 1e-12 + 2e-13 * amp
        assert np.abs(rot.Q - T @ res.Q).max() <= rtol * np.abs(res.Q).max(), it
        assert np.abs(rot.J - T @ res.J @ T.T).max() <= rtol * np.abs(res.J).max(), it
        assert rot.slip == pytest.approx(res.slip, rel=rtol, abs=1e-300), it


# ---------------------------------------------------------------------------------------------
# Jacobian


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(
    seed=st.integers(0, 2**32 - 1),
    log_disp=st.floats(-7.0, -1.0),
    log_spin=st.floats(-7.0, 0.5),
    x=st.floats(-1.5, 0.9),
    w=st.floats(0.1, 0.9),
    mu=st.floats(0.05, 1.0),
)
def test_jacobian_fd_random_geometry(seed, log_disp, log_spin, x, w, mu):
    rng = np.random.default_rng(seed)
    z, pair = random_pair(rng, 10.0**log_disp, 10.0**log_spin, x, w, mu)
    assume(stable(z, pair))
    assert jac_fd_error(z, pair) <= JAC_RTOL


def test_jacobian_fd_every_distance_case():
    """Every distance case (contacts at an end node: PE/EP with β = 0 or 1, and PP), in stick and slip."""
    rng = np.random.default_rng(99)
    seen = set()
    for _ in range(6000):
        if len(seen) == 2 * N_CASES:
            break
        regime = int(rng.integers(2))
        z, pair = random_pair(rng, (1e-7, 3e-2)[regime])
        case = edge_edge_distance(z[:12])[3]
        if (case, regime) in seen or not stable(z, pair):
            continue
        if case != CASE_EE:
            res = evaluate(z, pair)
            assert res.beta_a in (0.0, 1.0) or res.beta_b in (0.0, 1.0)
        assert jac_fd_error(z, pair) <= JAC_RTOL, (case, regime)
        seen.add((case, regime))
    assert len(seen) == 2 * N_CASES, sorted(seen)


def named_state(kind):
    """Named geometries and motions for the FD check: ``(z, pair, h)``."""
    rng = np.random.default_rng(sum(map(ord, kind)))
    if kind.startswith("nearly parallel exact"):  # EE with ∂β/∂p ~ 1/angle
        angle = float(kind.split()[-1])
        z, pair = crossing_pair(angle)
        # the FD truncation error grows like (H/angle)²: 2e-4 relative at angle 1e-3 with H
        return z, with_motion(z, pair, rng, 1e-2, 1e-1), H if angle >= 1e-2 else 2e-9
    if kind.startswith("parallel regularized"):
        angle = float(kind.split()[-1])
        z, pair = crossing_pair(angle, gap=0.2, shift=0.3, tilt=0.5 * angle, eta=ETA)
        return z, with_motion(z, pair, rng, 1e-2, 1e-1), H
    if kind == "parallel exact end to end":  # PP between x1 and x2
        p = np.array([0.0, 0, 0, 1, 0, 0, 1.03, 0, 0.04, 2.03, 0, 0.04])
        delta = edge_edge_distance(p)[0]
        z = np.concatenate([p, [0.1, 0.2]])
        pair = Pair(z.copy(), delta + 0.3 * TOL, 0.5 * (delta + 0.3 * TOL), 0.5 * (delta + 0.3 * TOL))
        assert edge_edge_distance(p)[3] == CASE_PP_10
        return z, with_motion(z, pair, rng, 1e-2, 1e-1), H
    z, pair = random_pair(rng, 1e-2, x=-0.4, w=0.4)
    while not stable(z, pair) or edge_edge_distance(z[:12])[3] != CASE_EE:
        z, pair = random_pair(rng, 1e-2, x=-0.4, w=0.4)
    if kind == "rest":
        pair.z_prev = z.copy()
    elif kind == "rigid translation":
        pair.z_prev = z - np.concatenate([np.tile(rng.normal(size=3) * 0.05, 4), [0.0, 0.0]])
    elif kind == "rolling":
        z = rolling_angles(z, pair)
    elif kind == "rolling on fixed rod":
        z, pair = rolling_geometry()
        z[12] -= 0.5 / pair.ha * DT
    elif kind == "clamped twist":
        z[12:] = pair.z_prev[12:]
    elif kind == "large spin":
        z[12:] = pair.z_prev[12:] + np.array([5.0, -4.0])
    elif kind == "large spin, stick translation":
        pair.z_prev[:12] = z[:12] - 1e-7 * rng.normal(size=12)
        z[12:] = pair.z_prev[12:] + np.array([-3.0, 6.0])
    else:
        raise AssertionError(kind)
    return z, pair, H


NAMED = [
    "nearly parallel exact 1e-2",
    "nearly parallel exact 1e-3",
    "parallel regularized 0.0",
    "parallel regularized 1e-4",
    "parallel regularized 1e-2",
    "parallel exact end to end",
    "rest",
    "rigid translation",
    "rolling",
    "rolling on fixed rod",
    "clamped twist",
    "large spin",
    "large spin, stick translation",
]


@pytest.mark.parametrize("kind", NAMED)
def test_jacobian_fd_named_states(kind):
    z, pair, h = named_state(kind)
    assert stable(z, pair, h)
    res = evaluate(z, pair)
    if kind in ("rest", "rigid translation", "rolling", "rolling on fixed rod"):
        _, fn = ref_surface_normal(res.fc)
        assert res.slip <= 1e-14 and np.abs(res.Q).max() <= 1e-12 * pair.mu * fn
        assert np.abs(res.J).max() > 0.0  # viscous-like sticking
    if kind.startswith("large spin"):
        assert 0.5 * K2 * res.slip > 5.0  # full slip from the spin alone
    assert jac_fd_error(z, pair, h) <= JAC_RTOL


def test_jacobian_includes_beta_normal_and_angle_terms():
    """Leaving out ∂β/∂p or ∂F_c/∂p visibly changes the Jacobian (the FD tests exercise them), and
    the angle columns are not negligible."""
    rng = np.random.default_rng(5)
    while True:
        z, pair = random_pair(rng, 0.05, spin=0.3)
        if edge_edge_distance(z[:12])[3] == CASE_EE and stable(z, pair):
            break
    p = z[:12].copy()
    fc, dfc, ba, bb, dba, dbb, *_ = contact_inputs(p, pair)
    args = (p, pair.z_prev[:12].copy(), z[12:].copy(), pair.z_prev[12:].copy(), DT, pair.mu, NU,
            pair.ha, pair.hb)
    Q = np.zeros(14)
    J = np.zeros((14, 14))
    spin = np.zeros(RECORD_SIZE)
    law = (np.zeros(3), 0.0, 0.0)
    surface_friction_pair(*args, fc, dfc, ba, bb, dba, dbb, *law, Q, J, spin, True)
    J_nob = np.zeros((14, 14))
    surface_friction_pair(*args, fc, dfc, ba, bb, 0 * dba, 0 * dbb, *law, Q, J_nob, spin, True)
    J_nofc = np.zeros((14, 14))
    surface_friction_pair(*args, fc, 0 * dfc, ba, bb, dba, dbb, *law, Q, J_nofc, spin, True)
    assert jac_fd_error(z, pair) <= JAC_RTOL
    assert np.abs(J_nob - J).max() > 1e-4 * np.abs(J).max()
    assert np.abs(J_nofc - J).max() > 1e-4 * np.abs(J).max()
    assert np.abs(J[:, 12:]).max() * max(pair.ha, pair.hb) > 1e-2 * np.abs(J[:, :12]).max()
