"""Smooth Coulomb friction: values against the literal reference, Coulomb properties, and the exact
Jacobian against finite differences.

The contact force ``fc = −k_c ∇E`` and its Jacobian ``dfc = −k_c ∇²E`` are always built from
``contact_pair_energy`` at the same ``p`` (and ``∂β/∂p`` from ``edge_edge_beta_gradients``), so that
the finite differences of ``p ↦ friction(p)`` (everything recomputed at ``p ± h e_m``, ``p_prev`` and
``dt`` fixed) test the full chain rule.

FD: central, step ``H = 1e-6`` (coordinates of order 1), tolerance
``|FD − J|∞ <= JAC_RTOL · |J|∞`` with ``JAC_RTOL = 1e-5``; used only where the distance case and
the side of the energy cut-off are the same at all ``p ± H e_m``. Typical parameters: ``dt = 0.1 s``,
``ν = 0.1 m/s`` (``K2 = 150 s/m``), ``δ = 0.05``, displacements over the step from 1e-7 (deep
stick, series branch of φ) to 0.1 (full slip).
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from knotsim.contact.distance import CASE_EE, N_CASES, edge_edge_beta_gradients, edge_edge_distance
from knotsim.contact.friction import friction_pair, slip_functions
from knotsim.contact.potential import contact_pair_energy

from .reference_kernels import ref_friction, ref_gamma

H = 1e-6
JAC_RTOL = 1e-5
DT = 0.1
NU = 0.1
TOL = 0.05
KC = 10.0


def contact_inputs(p, d, tol=TOL, kc=KC):
    g = np.zeros(12)
    h = np.zeros((12, 12))
    E, delta, bi, bj, case = contact_pair_energy(p, d, tol, g, h)
    dbi = np.zeros(12)
    dbj = np.zeros(12)
    edge_edge_beta_gradients(p, bi, bj, case, dbi, dbj)
    return -kc * g, -kc * h, bi, bj, dbi, dbj, case, delta


def friction(p, p_prev, d, mu=0.3, nu=NU, dt=DT):
    fc, dfc, bi, bj, dbi, dbj, case, delta = contact_inputs(p, d)
    F = np.zeros(12)
    J = np.zeros((12, 12))
    friction_pair(p, p_prev, dt, mu, nu, fc, dfc, bi, bj, dbi, dbj, F, J)
    return F, J, fc, bi, bj, case, delta


def stable(p, d):
    delta, _, _, case = edge_edge_distance(p)
    for m in range(12):
        for sgn in (1.0, -1.0):
            q = p.copy()
            q[m] += sgn * H
            dq, _, _, cq = edge_edge_distance(q)
            if cq != case or (dq >= d + TOL) != (delta >= d + TOL):
                return False
    return True


def jac_fd_error(p, p_prev, d, mu=0.3, nu=NU, dt=DT):
    F, J, *_ = friction(p, p_prev, d, mu, nu, dt)
    J_fd = np.column_stack(
        [
            (friction(p + H * e, p_prev, d, mu, nu, dt)[0] - friction(p - H * e, p_prev, d, mu, nu, dt)[0])
            / (2 * H)
            for e in np.eye(12)
        ]
    )
    scale = np.abs(J).max()
    assert scale > 0.0
    return np.abs(J_fd - J).max() / scale


def random_config(rng, disp_scale, x=None):
    """Random pair with Δ > 0.05 and d such that Δ = d + x δ (in contact), plus p_prev."""
    while True:
        p = rng.uniform(-1, 1, 12)
        delta = edge_edge_distance(p)[0]
        if delta > 0.05:
            break
    if x is None:
        x = rng.uniform(-1.5, 0.9)
    d = delta - x * TOL
    p_prev = p - disp_scale * rng.normal(size=12)
    return p, p_prev, d


# ---------------------------------------------------------------------------------------------
# slip function


def test_slip_functions():
    k = 7.5 / NU
    for s in np.concatenate(
        [[0.0], np.geomspace(1e-12, 1e2, 400), 0.02 / k * np.array([1 - 1e-12, 1.0, 1 + 1e-12])]
    ):
        gamma, phi, psi = slip_functions(s, NU)
        assert all(math.isfinite(v) for v in (gamma, phi, psi))
        assert abs(gamma - ref_gamma(s, NU)) <= 1e-15 + 1e-13 * gamma
        if s > 0:
            assert abs(phi - gamma / s) <= 1e-13 * phi
        else:
            assert phi == k and abs(psi + 2 / 3 * k**3) <= 1e-12 * k**3
    # psi = phi'(s)/s against 40-digit mpmath differentiation of tanh(k s)/s (relative 1e-10), on
    # both sides of the series switch
    with mpmath.workdps(40):
        for s in np.geomspace(1e-6 / k, 30 / k, 80):
            ref = mpmath.diff(lambda t: mpmath.tanh(k * t) / t, mpmath.mpf(s)) / s
            psi = slip_functions(s, NU)[2]
            assert abs(psi - float(ref)) <= 1e-10 * abs(float(ref)) + 1e-300
    # continuity across the series switch x = 0.02
    lo = slip_functions(np.nextafter(0.02 / k, 0), NU)
    hi = slip_functions(0.02 / k, NU)
    assert all(abs(a - b) <= 1e-12 * abs(b) for a, b in zip(lo, hi, strict=True))


# ---------------------------------------------------------------------------------------------
# values and Coulomb properties


def test_matches_reference_and_coulomb_properties():
    """Random pairs over stick to slip: equal to the literal reference (1e-12 relative to |F|∞, plus
    1e-15 μΣF_n absolute for the cancellation in the literal γ);
    Σ_a |F_fr,a| = μ γ Σ_a F_n,a (1e-12 relative); every nodal friction ⟂ n; friction on edge i
    opposes v_T, on edge j it points along v_T."""
    rng = np.random.default_rng(2024)
    mu = 0.4
    for it in range(600):
        scale = 10.0 ** rng.uniform(-7, -1)
        p, p_prev, d = random_config(rng, scale)
        F, J, fc, bi, bj, case, delta = friction(p, p_prev, d, mu=mu)
        Fr = ref_friction(p, p_prev, DT, mu, NU, fc, bi, bj)
        fn = np.linalg.norm(fc.reshape(4, 3), axis=1)
        # the literal γ = 2/(1 + e^{-x}) − 1 has an absolute error of a few eps for small x
        assert np.abs(F - Fr).max() <= 1e-12 * np.abs(Fr).max() + 1e-15 * mu * fn.sum(), it
        n = (fc[0:3] + fc[3:6]) / np.linalg.norm(fc[0:3] + fc[3:6])
        v = ((p - p_prev) / DT).reshape(4, 3)
        vrel = (1 - bi) * v[0] + bi * v[1] - (1 - bj) * v[2] - bj * v[3]
        vT = vrel - (vrel @ n) * n
        gamma = np.tanh(7.5 / NU * np.linalg.norm(vT))
        Fa = F.reshape(4, 3)
        total = np.linalg.norm(Fa, axis=1).sum()
        assert abs(total - mu * gamma * fn.sum()) <= 1e-12 * mu * fn.sum()
        assert np.abs(Fa @ n).max() <= 1e-12 * max(total, 1e-300)
        for a in range(4):
            if np.linalg.norm(Fa[a]) > 0:
                cosang = Fa[a] @ vT / (np.linalg.norm(Fa[a]) * np.linalg.norm(vT))
                assert abs(cosang - (-1.0 if a < 2 else 1.0)) <= 1e-12
        assert np.all(np.isfinite(J))


@pytest.mark.parametrize("case_kind", ["rest", "normal", "translation"])
def test_zero_tangential_velocity(case_kind):
    """v_T = 0: friction zero (|F| ≤ 1e-12 of μΣF_n), Jacobian still exact (FD, JAC_RTOL)."""
    p = np.array([-1.0, 0.1, 0, 1, -0.2, 0, 0.1, -1, 0.3, -0.2, 1, 0.3])
    delta = edge_edge_distance(p)[0]
    d = delta + 0.5 * TOL
    fc = contact_inputs(p, d)[0]
    n = (fc[0:3] + fc[3:6]) / np.linalg.norm(fc[0:3] + fc[3:6])
    if case_kind == "rest":
        p_prev = p.copy()
    elif case_kind == "normal":  # edge i approaches edge j along the normal
        p_prev = p.copy()
        p_prev[0:6] += 0.01 * np.tile(n, 2)
    else:  # rigid translation of both edges
        p_prev = p + 0.05 * np.tile([0.3, -0.5, 0.2], 4)
    F, *_ = friction(p, p_prev, d)
    assert np.abs(F).max() <= 1e-12 * np.linalg.norm(fc.reshape(4, 3), axis=1).sum()
    assert stable(p, d)
    assert jac_fd_error(p, p_prev, d) <= JAC_RTOL


def test_zero_contact_force_gives_zero_friction():
    p = np.array([-1.0, 0.1, 0, 1, -0.2, 0, 0.1, -1, 0.3, -0.2, 1, 0.3])
    p_prev = p - 0.01
    F = np.full(12, 3.0)
    J = np.full((12, 12), 3.0)
    zeros = np.zeros(12)
    friction_pair(p, p_prev, DT, 0.3, NU, zeros, np.zeros((12, 12)), 0.5, 0.5, zeros, zeros, F, J)
    assert not F.any() and not J.any()
    # out of contact (beyond the cut-off): fc = 0 as well
    F2, J2, fc, *_ = friction(p, p_prev, d=0.01)
    assert not fc.any() and not F2.any() and not J2.any()


# ---------------------------------------------------------------------------------------------
# Jacobian


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(
    seed=st.integers(0, 2**32 - 1),
    log_disp=st.floats(-7.0, -1.0),
    x=st.floats(-1.5, 0.9),
    mu=st.floats(0.05, 1.0),
)
def test_jacobian_fd_hypothesis(seed, log_disp, x, mu):
    rng = np.random.default_rng(seed)
    p, p_prev, d = random_config(rng, 10.0**log_disp, x)
    assume(stable(p, d))
    assert jac_fd_error(p, p_prev, d, mu=mu) <= JAC_RTOL


def test_jacobian_fd_every_case_and_regime():
    """Every distance case, in stick (series branch), transition and slip."""
    rng = np.random.default_rng(99)
    seen = set()
    worst = 0.0
    for _ in range(4000):
        if len(seen) == 3 * N_CASES:
            break
        regime = int(rng.integers(3))
        scale = (1e-7, 1e-3, 1e-1)[regime]
        p, p_prev, d = random_config(rng, scale)
        case = edge_edge_distance(p)[3]
        if (case, regime) in seen or not stable(p, d):
            continue
        worst = max(worst, jac_fd_error(p, p_prev, d))
        assert worst <= JAC_RTOL
        seen.add((case, regime))
    assert len(seen) == 3 * N_CASES, sorted(seen)


def test_jacobian_includes_beta_and_normal_terms():
    """In an EE contact with sliding, leaving out the ∂β/∂p or the ∂F_c/∂p chain-rule terms gives a
    visibly wrong Jacobian (so the FD tests really exercise them)."""
    rng = np.random.default_rng(5)
    while True:
        p, p_prev, d = random_config(rng, 0.05)
        if edge_edge_distance(p)[3] == CASE_EE and stable(p, d):
            break
    fc, dfc, bi, bj, dbi, dbj, *_ = contact_inputs(p, d)
    F = np.zeros(12)
    J = np.zeros((12, 12))
    friction_pair(p, p_prev, DT, 0.3, NU, fc, dfc, bi, bj, dbi, dbj, F, J)
    J_nob = np.zeros((12, 12))
    friction_pair(p, p_prev, DT, 0.3, NU, fc, dfc, bi, bj, 0 * dbi, 0 * dbj, F, J_nob)
    J_nofc = np.zeros((12, 12))
    friction_pair(p, p_prev, DT, 0.3, NU, fc, 0 * dfc, bi, bj, dbi, dbj, F, J_nofc)
    assert jac_fd_error(p, p_prev, d) <= JAC_RTOL
    assert np.abs(J_nob - J).max() > 1e-4 * np.abs(J).max()
    assert np.abs(J_nofc - J).max() > 1e-4 * np.abs(J).max()
