"""Friction at the surfaces as a function of the edge angles alone (positions held):
:func:`spin_friction_terms` against a plain-numpy reference, its gradient and Hessian against finite
differences (including zero slip, held angles, no normal force), and its consistency with the pair
kernel it is taken from (gradient = −Q_θ, Hessian = −∂Q_θ/∂θ of :func:`surface_friction_pair`)."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.contact.spin_minimiser import SpinFriction
from knotsim.contact.surface_friction import RECORD_SIZE, spin_friction_terms

from .friction_records import random_friction_records
from .test_surface_friction import DT, NU, evaluate, random_pair, stable

K = 7.5 / NU  # K2/2


def ref_terms(dtheta, loc, record, dt, nu):
    """Plain numpy: D = Σ μF_n dt ln cosh(k|u|)/k with u = u0 + (c_a Δθ_a + c_b Δθ_b)/dt, or for a
    stick-law record (κ > 0) D = F_n H(|u dt|), H the Huber function of slope κ and limit μ_L."""
    k = 7.5 / nu
    total = 0.0
    grad = np.zeros(dtheta.shape[0])
    hess = np.zeros((record.shape[0], 2, 2))
    for p, rec in enumerate(record):
        u0, ca, cb, fn, coef, kappa = rec[0:3], rec[3:6], rec[6:9], rec[9], rec[10], rec[11]
        mufn = fn * coef
        if mufn <= 0:
            continue
        th = [dtheta[i] if i >= 0 else 0.0 for i in loc[p]]
        c = [ca, cb]
        u = u0 + (ca * th[0] + cb * th[1]) / dt
        if kappa > 0:  # ξ = u dt; H = κ r²/2 within μ_L/κ, μ_L r − μ_L²/(2κ) beyond
            xi = u * dt
            r = np.linalg.norm(xi)
            lim = coef / kappa
            total += fn * (0.5 * kappa * r * r if r <= lim else coef * r - 0.5 * coef * coef / kappa)
            xh = xi / r if r > 0 else np.zeros(3)
            m = kappa * np.eye(3) if r <= lim else coef / r * (np.eye(3) - np.outer(xh, xh))
            for i in range(2):
                if loc[p, i] < 0:
                    continue
                grad[loc[p, i]] += fn * (c[i] @ m @ xi if r <= lim else coef * (xh @ c[i]))
                for j in range(2):
                    if loc[p, j] >= 0:
                        hess[p, i, j] = fn * (c[i] @ m @ c[j])
            continue
        s = np.linalg.norm(u)
        total += mufn * dt * np.log1p(np.expm1(k * s) ** 2 / (2 * np.exp(k * s))) / k  # ln cosh
        # dD/dθ_i = μF_n tanh(k s) û·c_i ; d²D = μF_n/dt c_iᵀ [tanh(ks)/s (I − ûûᵀ) + k sech²(ks) ûûᵀ] c_j
        uh = u / s if s > 0 else np.zeros(3)
        t = np.tanh(k * s)
        m = (t / s if s > 0 else k) * (np.eye(3) - np.outer(uh, uh)) + k / np.cosh(k * s) ** 2 * np.outer(uh, uh)
        for i in range(2):
            if loc[p, i] < 0:
                continue
            grad[loc[p, i]] += mufn * t * (uh @ c[i])
            for j in range(2):
                if loc[p, j] >= 0:
                    hess[p, i, j] = mufn / dt * (c[i] @ m @ c[j])
    return total, grad, hess


def random_records(rng, k, slip_scale, stick=False):
    """Random pair records; ``stick``: elastic-stick records (κ > 0, the spring ``ξ = u dt`` from about
    half to twice its limit)."""
    return random_friction_records(rng, k, slip_scale, lever=1e-3, mufn_min=0.01, stick=stick, dt=DT)


def run(dtheta, loc, rec, dt=DT, nu=NU):
    g = np.zeros(dtheta.shape[0])
    h = np.zeros((rec.shape[0], 2, 2))
    return spin_friction_terms(dtheta, loc, rec, dt, np.full(rec.shape[0], nu), g, h), g, h


@pytest.mark.parametrize("stick", [False, True])
@pytest.mark.parametrize("slip_scale", [0.0, 1e-5, 1e-3, 1.0])
def test_against_reference(slip_scale, stick):
    rng = np.random.default_rng(3)
    rec = random_records(rng, 12, slip_scale, stick)
    loc = rng.integers(-1, 8, size=(12, 2))
    dtheta = rng.normal(size=8) * 1e-3 * (slip_scale > 0)
    d, g, h = run(dtheta, loc, rec)
    d_ref, g_ref, h_ref = ref_terms(dtheta, loc, rec, DT, NU)
    assert abs(d - d_ref) <= 1e-12 * max(abs(d_ref), 1e-300) + 1e-300
    np.testing.assert_allclose(g, g_ref, rtol=1e-10, atol=1e-14 * np.abs(g_ref).max(initial=1e-300))
    np.testing.assert_allclose(h, h_ref, rtol=1e-9, atol=1e-12 * np.abs(h_ref).max(initial=1e-300))


@pytest.mark.parametrize("stick", [False, True])
@pytest.mark.parametrize("slip_scale", [1e-5, 1e-3, 0.3])
def test_gradient_and_hessian_against_finite_differences(slip_scale, stick):
    rng = np.random.default_rng(5)
    rec = random_records(rng, 6, slip_scale, stick)
    loc = np.array([[0, 1], [1, 2], [2, -1], [-1, 3], [3, 0], [4, 4]])
    rec[5, 9] = 0.0  # a pair without normal force contributes nothing
    dtheta = rng.normal(size=5) * slip_scale * DT / 1e-3 * 0.3
    d, g, h = run(dtheta, loc, rec)
    hstep = 1e-7 * max(slip_scale * DT / 1e-3, 1e-6)
    full_h = np.zeros((5, 5))
    for p in range(6):
        for i in range(2):
            for j in range(2):
                if loc[p, i] >= 0 and loc[p, j] >= 0:
                    full_h[loc[p, i], loc[p, j]] += h[p, i, j]
    for m in range(5):
        e = np.zeros(5)
        e[m] = hstep
        dp, gp, _ = run(dtheta + e, loc, rec)
        dm, gm, _ = run(dtheta - e, loc, rec)
        assert abs((dp - dm) / (2 * hstep) - g[m]) <= 1e-6 * np.abs(g).max() + 1e-15
        np.testing.assert_allclose((gp - gm) / (2 * hstep), full_h[:, m], rtol=1e-5,
                                   atol=1e-5 * np.abs(full_h).max())
    assert not g[4] and not full_h[4].any()  # angle 4 is only in the pair without normal force


def test_consistent_with_the_pair_kernel():
    """At Δθ = 0 the gradient is −Q_θ and the Hessian is −∂Q_θ/∂θ of the 14-unknown pair kernel;
    turning the angles by Δθ with the nodes held reproduces the kernel's Q_θ at z + Δθ."""
    rng = np.random.default_rng(11)
    checked = 0
    while checked < 20:
        z, pair = random_pair(rng, 10 ** rng.uniform(-6, -1))
        if not stable(z, pair):
            continue
        spin = np.zeros(RECORD_SIZE)
        res = evaluate(z, pair)
        from knotsim.contact.surface_friction import surface_friction_pair  # the record of this z

        from .test_surface_friction import contact_inputs
        p = z[:12].copy()
        fc, dfc, ba, bb, dba, dbb, *_ = contact_inputs(p, pair)
        Q = np.zeros(14)
        J = np.zeros((14, 14))
        surface_friction_pair(p, pair.z_prev[:12].copy(), z[12:].copy(), pair.z_prev[12:].copy(), pair.dt,
                              pair.mu, pair.nu, pair.ha, pair.hb, fc, dfc, ba, bb, dba, dbb,
                              np.array(pair.xi0, dtype=float), pair.mu_limit, pair.kappa, Q, J, spin, True)
        loc = np.array([[0, 1]])
        d, g, h = run(np.zeros(2), loc, spin[None, :], pair.dt, pair.nu)
        scale = max(np.abs(res.Q[12:]).max(), 1e-300)
        np.testing.assert_allclose(g, -res.Q[12:], rtol=1e-9, atol=1e-12 * scale)
        np.testing.assert_allclose(h[0], -res.J[12:, 12:], rtol=1e-7, atol=1e-9 * np.abs(res.J[12:, 12:]).max())
        dth = rng.normal(size=2) * 1e-3
        _, g2, _ = run(dth, loc, spin[None, :], pair.dt, pair.nu)
        z2 = z.copy()
        z2[12:] += dth
        np.testing.assert_allclose(g2, -evaluate(z2, pair).Q[12:], rtol=1e-8, atol=1e-11 * scale)
        checked += 1


def test_spin_friction_object_and_convexity():
    rng = np.random.default_rng(2)
    rec = random_records(rng, 5, 1e-3)
    sf = SpinFriction(np.arange(10).reshape(5, 2), rec, NU)
    loc = np.arange(10).reshape(5, 2)
    g = np.zeros(10)
    h = np.zeros((5, 2, 2))
    d = sf.terms(np.zeros(10), loc, DT, g, h)
    assert d == run(np.zeros(10), loc, rec)[0]
    for p in range(5):  # every pair's Hessian is positive semidefinite (the potential is convex)
        assert np.linalg.eigvalsh(h[p]).min() >= -1e-12 * np.abs(h[p]).max()
