"""Regularized edge–edge distance: value against a bounded least-squares reference, derivatives
against finite differences (including parallel and nearly parallel edges and case boundaries),
and the property it exists for: the contact force of parallel edges does not jump.

Finite differences are central. The regularized minimiser moves across an edge for node motions
of about ``η L² / Δ`` near parallel, so the steps are scaled to stay well inside that (``1e-7`` on
random coordinates of order 1e-2 m, ``1e-10`` on the 3 mm parallel edges).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from knotsim.contact.distance import (
    CASE_EE,
    CASE_EP_0,
    CASE_PE_0,
    edge_edge_distance,
    edge_edge_distance_derivatives,
)
from knotsim.contact.regularized_distance import (
    regularized_beta_gradients,
    regularized_distance,
    regularized_distance_derivatives,
)

from .reference_kernels import fd_gradient, nodes

ETA = 1e-3
L = 3.3e-3  # edge length of a 1 m rope at N = 301 (m)
GAP = 4e-3  # distance between the axes of two touching 2 mm ropes (m)


def ref_regularized(p, eta):
    """Obvious reference: ``min |r + βi a − βj b|² + η(|a|²(βi−½)² + |b|²(βj−½)²)`` over the unit
    square as a bounded linear least-squares problem (scipy BVLS); returns ``(√V, βi, βj)``."""
    x0, x1, x2, x3 = nodes(p)
    a, b, r = x1 - x0, x3 - x2, x0 - x2
    sa, sb = np.sqrt(eta * (a @ a)), np.sqrt(eta * (b @ b))
    M = np.zeros((5, 2))
    M[:3, 0], M[:3, 1] = a, -b
    M[3, 0], M[4, 1] = sa, sb
    y = np.concatenate([-r, [0.5 * sa, 0.5 * sb]])
    res = lsq_linear(M, y, bounds=(0.0, 1.0), method="bvls", tol=1e-15)
    bi, bj = res.x
    return float(np.sqrt(np.sum((M @ res.x - y) ** 2))), float(bi), float(bj)


def derivs(p, eta=ETA):
    g = np.zeros(12)
    h = np.zeros((12, 12))
    out = regularized_distance_derivatives(np.asarray(p, dtype=float), eta, g, h)
    return out, g, h


def beta_grads(p, eta=ETA):
    _, bi, bj, case = regularized_distance(p, eta)
    gi = np.zeros(12)
    gj = np.zeros(12)
    regularized_beta_gradients(p, eta, bi, bj, case, gi, gj)
    return gi, gj


def fd_errors(p, h, eta=ETA):
    """(case, |∇Δ − FD|∞, relative ∇²Δ error, relative ∂β/∂p error) at ``p``."""
    (_, _, _, case), g, hs = derivs(p, eta)
    g_fd = fd_gradient(lambda x: regularized_distance(x, eta)[0], p, h)
    h_fd = np.column_stack([(derivs(p + h * e, eta)[1] - derivs(p - h * e, eta)[1]) / (2 * h) for e in np.eye(12)])
    gi, gj = beta_grads(p, eta)
    gi_fd = fd_gradient(lambda x: regularized_distance(x, eta)[1], p, h)
    gj_fd = fd_gradient(lambda x: regularized_distance(x, eta)[2], p, h)
    err_g = np.abs(g_fd - g).max()
    err_h = np.abs(h_fd - hs).max() / max(1.0, np.abs(hs).max())
    err_b = max(np.abs(gi_fd - gi).max(), np.abs(gj_fd - gj).max()) / max(1.0, np.abs(gi).max(), np.abs(gj).max())
    assert np.array_equal(hs, hs.T)
    return case, err_g, err_h, err_b


def case_stable(p, h, eta=ETA):
    case = regularized_distance(p, eta)[3]
    return all(regularized_distance(p + s * h * e, eta)[3] == case for e in np.eye(12) for s in (1.0, -1.0))


def parallel_pair(angle, shift=0.3, tilt=0.0):
    """Edge i from the origin along x (length L); edge j GAP above it, shifted by ``shift`` L along
    x, turned by ``angle`` (rad) in the plane of the two edges and by ``tilt`` out of it."""
    x0, x1 = np.zeros(3), np.array([L, 0.0, 0.0])
    x2 = np.array([shift * L, GAP, 0.0])
    d = L * np.array([np.cos(angle) * np.cos(tilt), np.sin(angle) * np.cos(tilt), np.sin(tilt)])
    return np.concatenate([x0, x1, x2, x2 + d])


def test_value_matches_least_squares_reference_random_pairs():
    rng = np.random.default_rng(11)
    worst_v = worst_b = 0.0
    for _ in range(400):
        p = rng.normal(size=12) * 0.01
        for eta in (1e-4, 1e-3, 1e-2):
            delta, bi, bj, _ = regularized_distance(p, eta)
            rd, rbi, rbj = ref_regularized(p, eta)
            worst_v = max(worst_v, abs(delta - rd))
            worst_b = max(worst_b, abs(bi - rbi), abs(bj - rbj))
    assert worst_v < 1e-12
    assert worst_b < 1e-7


@pytest.mark.parametrize("angle", [0.0, 1e-9, 1e-6, 1e-4, 1e-3, 0.05, 0.5, 1.5])
@pytest.mark.parametrize("shift", [0.0, 0.3, -0.6])
def test_value_matches_reference_parallel_and_nearly_parallel(angle, shift):
    p = parallel_pair(angle, shift)
    delta, bi, bj, _ = regularized_distance(p, ETA)
    rd, rbi, rbj = ref_regularized(p, ETA)
    assert abs(delta - rd) < 1e-13
    assert abs(bi - rbi) < 1e-6 and abs(bj - rbj) < 1e-6


def test_bias_bounded_and_vanishes_with_eta():
    """``0 <= Δ_reg − Δ <= η (|a|² + |b|²) / (8 Δ)``, and Δ_reg → Δ as η → 0."""
    rng = np.random.default_rng(5)
    for _ in range(300):
        p = rng.normal(size=12) * 0.01
        exact = edge_edge_distance(p)[0]
        x0, x1, x2, x3 = nodes(p)
        A, B = (x1 - x0) @ (x1 - x0), (x3 - x2) @ (x3 - x2)
        for eta in (1e-2, 1e-3, 1e-5):
            bias = regularized_distance(p, eta)[0] - exact
            assert -1e-15 <= bias <= eta * (A + B) / (8 * exact) * (1 + 1e-9) + 1e-15
        assert regularized_distance(p, 1e-12)[0] - exact < 1e-11
    # parallel edges of a rope at N = 301: below a micrometre
    for angle in (0.0, 1e-4, 0.01):
        assert 0.0 <= regularized_distance(parallel_pair(angle), ETA)[0] - edge_edge_distance(parallel_pair(angle))[0] < 1e-6


def test_derivatives_random_pairs():
    rng = np.random.default_rng(3)
    seen = set()
    n = 0
    while n < 60:
        p = rng.normal(size=12) * 0.01
        if not case_stable(p, 1e-7):
            continue
        case, eg, eh, eb = fd_errors(p, 1e-7)
        seen.add(case)
        assert eg < 2e-7 and eh < 2e-5 and eb < 2e-5, (case, eg, eh, eb)
        n += 1
    assert CASE_EE in seen and (seen & set(range(CASE_PE_0, CASE_EE)))


@pytest.mark.parametrize("angle", [0.0, 1e-9, -1e-9, 1e-5, -1e-5, 3e-4, 0.002, 0.05])
@pytest.mark.parametrize("tilt", [0.0, 1e-5, 0.01])
def test_derivatives_parallel_and_nearly_parallel(angle, tilt):
    """The degenerate geometry of the exact distance: derivatives agree with finite differences."""
    p = parallel_pair(angle, 0.3, tilt)
    h = 1e-10
    assert case_stable(p, h)
    case, eg, eh, eb = fd_errors(p, h)
    assert eg < 1e-5 and eh < 1e-5 and eb < 1e-5, (case, eg, eh, eb)


def test_derivatives_across_case_boundaries():
    """Through the EE → EP boundary (the minimiser reaching the end of edge j) the gradient is
    continuous: just inside both regions it agrees with FD, and the two one-sided gradients agree."""
    # the in-plane angle at which beta_j reaches 0
    lo, hi = 1e-6, 0.01
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if regularized_distance(parallel_pair(mid), ETA)[3] == CASE_EE:
            lo = mid
        else:
            hi = mid
    assert regularized_distance(parallel_pair(lo), ETA)[3] == CASE_EE
    assert regularized_distance(parallel_pair(hi), ETA)[3] == CASE_EP_0
    g_lo = derivs(parallel_pair(lo))[1]
    g_hi = derivs(parallel_pair(hi))[1]
    assert np.abs(g_lo - g_hi).max() < 1e-6
    for a in (lo * (1 - 1e-3), hi * (1 + 1e-3)):
        p = parallel_pair(a)
        case, eg, eh, eb = fd_errors(p, 1e-12)
        assert eg < 1e-4, (case, eg)


def test_parallel_contact_force_does_not_jump():
    """The defect the regularization removes: for the exact distance the gradient (the direction
    in which the contact force acts on each node) jumps by O(1) when the small angle between two
    overlapping parallel edges changes sign; the regularized one is continuous."""
    for eps in (1e-6, 1e-9, 1e-12):
        gp = np.zeros(12)
        gm = np.zeros(12)
        h = np.zeros((12, 12))
        edge_edge_distance_derivatives(parallel_pair(eps), gp, h)
        edge_edge_distance_derivatives(parallel_pair(-eps), gm, h)
        assert np.abs(gp - gm).max() > 0.5  # exact: the force moves from one end of the overlap to the other
        jump = np.abs(derivs(parallel_pair(eps))[1] - derivs(parallel_pair(-eps))[1]).max()
        assert jump < 1e4 * eps  # regularized: Lipschitz, |∇²Δ| bounded
    # the Hessian is bounded at exactly parallel edges, by about Δ / (η |a|²) (the minimiser moves
    # along the overlap for node motions of about η |a|² / Δ)
    for eta in (1e-3, 1e-2):
        hmax = np.abs(derivs(parallel_pair(0.0), eta)[2]).max()
        assert hmax < 2 * GAP / (eta * L**2)


def test_parallel_contact_point_is_middle_of_overlap():
    for shift in (0.0, 0.3, -0.4):
        _, bi, bj, case = regularized_distance(parallel_pair(0.0, shift), ETA)
        lo, hi = max(0.0, shift), min(1.0, 1.0 + shift)
        assert case == CASE_EE
        assert bi == pytest.approx(0.5 * (lo + hi), abs=ETA)
        assert bj == pytest.approx(0.5 * (lo + hi) - shift, abs=ETA)


def test_degenerate_edges():
    """A zero-length edge is a point (its ratio 0); coincident points give zero derivatives."""
    p = np.concatenate([[0, 0, 0], [0, 0, 0], [-1e-3, 2e-3, 0], [1e-3, 2e-3, 0]]).astype(float)
    delta, bi, bj, case = regularized_distance(p, ETA)
    rd, _, rbj = ref_regularized(p, ETA)
    assert bi == 0.0 and case == CASE_PE_0 and abs(delta - rd) < 1e-15 and abs(bj - rbj) < 1e-9
    (_, _, _, _), g, h = derivs(p)
    assert np.all(np.isfinite(g)) and np.all(np.isfinite(h))
    q = np.zeros(12)
    (d0, _, _, _), g, h = derivs(q)
    assert d0 == 0.0 and not g.any() and not h.any()
