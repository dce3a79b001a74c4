"""Edge–edge distance: values against references, derivatives against finite differences.

Finite differences: central, step ``H = 1e-6`` on coordinates of order 1 (m). Tolerances:

* ``∇Δ`` (entries of order 1): ``|FD − analytic|∞ <= GRAD_ATOL = 1e-7``;
* ``∇²Δ`` (central differences of the analytic gradient):
  ``|FD − analytic|∞ <= HESS_RTOL · max(1, |∇²Δ|∞)`` with ``HESS_RTOL = 1e-6``;
* ``∂β/∂p`` (central differences of β): ``<= 1e-6 · max(1, |∂β/∂p|∞)``.

The derivatives are those of the closed form of the active case, so the FD checks only use
configurations whose case is the same at ``p`` and at every ``p ± H e_m`` (one region, not
straddling a boundary). At case boundaries the analytic derivatives are compared with FD of the
reported case's closed form (which is smooth through the boundary), and with full FD just inside
each neighbouring region.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from knotsim.contact.distance import (
    CASE_EE,
    CASE_EP_0,
    CASE_PE_0,
    CASE_PE_1,
    CASE_PP_00,
    N_CASES,
    case_kind,
    case_name,
    edge_edge_beta_gradients,
    edge_edge_distance,
    edge_edge_distance_derivatives,
)

from .reference_kernels import (
    fd_gradient,
    fd_hessian_2nd,
    point_on_edges,
    ref_case_beta,
    ref_case_distance,
    ref_distance_bvls,
    ref_distance_kkt,
)

H = 1e-6
GRAD_ATOL = 1e-7
HESS_RTOL = 1e-6
BETA_RTOL = 1e-6

coords = hnp.arrays(np.float64, 12, elements=st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False))


def derivs(p):
    g = np.zeros(12)
    h = np.zeros((12, 12))
    out = edge_edge_distance_derivatives(np.asarray(p, dtype=float), g, h)
    return out, g, h


def beta_grads(p):
    p = np.asarray(p, dtype=float)
    _, bi, bj, case = edge_edge_distance(p)
    gi = np.zeros(12)
    gj = np.zeros(12)
    edge_edge_beta_gradients(p, bi, bj, case, gi, gj)
    return gi, gj


def case_stable(p, h=H):
    """True if the case is the same at p and at all p ± h e_m."""
    case = edge_edge_distance(p)[3]
    for m in range(12):
        for sgn in (1.0, -1.0):
            q = p.copy()
            q[m] += sgn * h
            if edge_edge_distance(q)[3] != case:
                return False
    return True


def fd_check(p):
    """Full FD check of ∇Δ, ∇²Δ and ∂β/∂p at a case-stable configuration; returns the errors."""
    (delta, bi, bj, case), g, hs = derivs(p)
    g_fd = fd_gradient(lambda x: edge_edge_distance(x)[0], p, H)
    h_fd = np.column_stack([(derivs(p + H * e)[1] - derivs(p - H * e)[1]) / (2 * H) for e in np.eye(12)])
    gi, gj = beta_grads(p)
    gi_fd = fd_gradient(lambda x: edge_edge_distance(x)[1], p, H)
    gj_fd = fd_gradient(lambda x: edge_edge_distance(x)[2], p, H)
    err_g = np.abs(g_fd - g).max()
    err_h = np.abs(h_fd - hs).max() / max(1.0, np.abs(hs).max())
    err_b = max(np.abs(gi_fd - gi).max(), np.abs(gj_fd - gj).max()) / max(
        1.0, np.abs(gi).max(), np.abs(gj).max()
    )
    assert err_g <= GRAD_ATOL, (case_name(case), err_g)
    assert err_h <= HESS_RTOL, (case_name(case), err_h)
    assert err_b <= BETA_RTOL, (case_name(case), err_b)
    assert np.array_equal(hs, hs.T)
    return case, err_g, err_h, err_b


# ---------------------------------------------------------------------------------------------
# values


def test_case_names():
    assert [case_kind(c) for c in range(N_CASES)] == ["PP"] * 4 + ["PE"] * 4 + ["EE"]
    assert case_name(CASE_EE) == "EE"
    assert case_name(CASE_PE_1) == "PE(x1,edge j)"
    with pytest.raises(ValueError):
        case_name(N_CASES)


def test_distance_matches_reference_random_pairs():
    """2000 random pairs (coordinates in [-1, 1]): Δ agrees with the KKT reference to 1e-10 (absolute,
    m) and with the BVLS reference to 1e-9; the ratios reproduce Δ; every case occurs."""
    rng = np.random.default_rng(12345)
    seen = set()
    for _ in range(2000):
        p = rng.uniform(-1, 1, 12)
        delta, bi, bj, case = edge_edge_distance(p)
        seen.add(case)
        d_ref, bi_ref, bj_ref = ref_distance_kkt(p)
        assert abs(delta - d_ref) <= 1e-10
        assert abs(delta - ref_distance_bvls(p)[0]) <= 1e-9
        assert abs(np.linalg.norm(point_on_edges(p, bi, bj)) - delta) <= 1e-10
        assert 0.0 <= bi <= 1.0 and 0.0 <= bj <= 1.0
        # random pairs are never parallel, so the minimiser is unique
        assert abs(bi - bi_ref) <= 1e-8 and abs(bj - bj_ref) <= 1e-8
        assert abs(ref_case_distance(p, case) - delta) <= 1e-12
    assert seen == set(range(N_CASES))


@settings(max_examples=300, deadline=None)
@given(coords)
def test_distance_hypothesis_against_reference(p):
    """Any configuration (including hypothesis' degenerate ones): finite, ratios in [0, 1], Δ within
    1e-10 of the KKT reference and equal to |q(β_i, β_j)|; derivatives finite."""
    delta, bi, bj, case = edge_edge_distance(p)
    assert math.isfinite(delta) and 0 <= case < N_CASES
    assert 0.0 <= bi <= 1.0 and 0.0 <= bj <= 1.0
    assert abs(delta - ref_distance_kkt(p)[0]) <= 1e-10
    # the ratios of nearly parallel edges are ill-conditioned (round-off / sin² of the angle), so
    # the points they give may sit off the minimum by that much times the edge length
    d1, d2 = p[3:6] - p[0:3], p[9:12] - p[6:9]
    sin2 = float(np.sum(np.cross(d1, d2) ** 2)) / max(float(d1 @ d1) * float(d2 @ d2), 1e-300)
    tol = 1e-10 + 1e-15 / max(sin2, 1e-12) * max(np.linalg.norm(d1), np.linalg.norm(d2))
    assert abs(np.linalg.norm(point_on_edges(p, bi, bj)) - delta) <= tol
    _, g, h = derivs(p)
    assert np.all(np.isfinite(g)) and np.all(np.isfinite(h))
    gi, gj = beta_grads(p)
    assert np.all(np.isfinite(gi)) and np.all(np.isfinite(gj))


# ---------------------------------------------------------------------------------------------
# derivatives against finite differences


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(coords)
def test_derivatives_fd_hypothesis(p):
    delta, _, _, case = edge_edge_distance(p)
    assume(delta > 0.02)
    assume(np.linalg.norm(p[3:6] - p[0:3]) > 0.05 and np.linalg.norm(p[9:12] - p[6:9]) > 0.05)
    if case == CASE_EE:
        u = np.cross(p[3:6] - p[0:3], p[9:12] - p[6:9])
        sin = np.linalg.norm(u) / np.linalg.norm(p[3:6] - p[0:3]) / np.linalg.norm(p[9:12] - p[6:9])
        assume(sin > 1e-2)
    assume(case_stable(p))
    fd_check(p)


def test_derivatives_fd_every_case():
    """Seeded random configurations until each of the 9 cases has been FD-checked 15 times."""
    rng = np.random.default_rng(7)
    count = dict.fromkeys(range(N_CASES), 0)
    worst = dict.fromkeys(range(N_CASES), (0.0, 0.0, 0.0))
    for _ in range(20000):
        if min(count.values()) >= 15:
            break
        p = rng.uniform(-1, 1, 12)
        delta, _, _, case = edge_edge_distance(p)
        if count[case] >= 15 or delta < 0.02 or not case_stable(p):
            continue
        c, eg, eh, eb = fd_check(p)
        count[c] += 1
        worst[c] = tuple(max(a, b) for a, b in zip(worst[c], (eg, eh, eb), strict=True))
    assert min(count.values()) >= 15, count


def test_hessian_symmetric_and_gradient_structure():
    rng = np.random.default_rng(3)
    for _ in range(200):
        p = rng.uniform(-1, 1, 12)
        (delta, bi, bj, case), g, h = derivs(p)
        assert np.array_equal(h, h.T)
        G = g.reshape(4, 3)
        # translation invariance: gradient blocks sum to zero, Hessian rows too
        assert np.abs(G.sum(axis=0)).max() <= 1e-14
        assert np.abs(h.reshape(12, 4, 3).sum(axis=1)).max() <= 1e-9 * max(1.0, np.abs(h).max())
        # |∂Δ/∂x_k| = |c_k|
        c = np.array([1 - bi, bi, 1 - bj, bj])
        assert np.allclose(np.linalg.norm(G, axis=1), c, atol=1e-14)


# ---------------------------------------------------------------------------------------------
# degenerate and hand-made configurations


def check_closed_form_derivatives(p, rtol_g=1e-8, rtol_h=1e-5):
    """Analytic ∇Δ, ∇²Δ against FD of the reported case's closed form (valid across boundaries).

    Gradient: central differences, step 1e-6, ``<= rtol_g``. Hessian: second differences of the
    closed form, step 1e-4, ``<= rtol_h · max(1, |∇²Δ|∞)``.
    """
    (delta, bi, bj, case), g, h = derivs(p)

    def f(x):
        return ref_case_distance(x, case)

    assert abs(f(p) - delta) <= 1e-13
    assert np.abs(fd_gradient(f, p, 1e-6) - g).max() <= rtol_g
    h_fd = fd_hessian_2nd(f, p, 1e-4)
    assert np.abs(h_fd - h).max() <= rtol_h * max(1.0, np.abs(h).max())
    gi, gj = beta_grads(p)
    gi_fd = fd_gradient(lambda x: ref_case_beta(x, case)[0], p, 1e-6)
    gj_fd = fd_gradient(lambda x: ref_case_beta(x, case)[1], p, 1e-6)
    assert np.abs(gi_fd - gi).max() <= 1e-8 and np.abs(gj_fd - gj).max() <= 1e-8
    return case


def rot_z(v, ang):
    c, s = math.cos(ang), math.sin(ang)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]])


@pytest.mark.parametrize(
    "p",
    [
        # overlapping parallel edges, offset 0.3
        np.array([0, 0, 0, 1, 0, 0, 0.2, 0.3, 0, 1.5, 0.3, 0.0]),
        # parallel, antiparallel direction, offset in z
        np.array([0, 0, 0, 1, 0, 0, 1.5, 0, 0.3, 0.2, 0, 0.3]),
        # parallel, not overlapping (PP)
        np.array([0, 0, 0, 1, 0, 0, 1.5, 0.3, 0, 2.5, 0.3, 0.0]),
        # collinear, separated
        np.array([0, 0, 0, 1, 0, 0, 1.5, 0, 0, 2.5, 0, 0.0]),
        # parallel edges of very different length, fully overlapping
        np.array([0, 0, 0, 2, 0, 0, 0.5, 0.1, 0.1, 0.7, 0.1, 0.1]),
    ],
)
def test_parallel_edges(p):
    delta, bi, bj, case = edge_edge_distance(p)
    assert case_kind(case) in ("PP", "PE")
    assert abs(delta - ref_distance_kkt(p)[0]) <= 1e-14
    assert abs(delta - ref_distance_bvls(p)[0]) <= 1e-12
    # general FD would straddle the (non-unique) parallel minimiser, so we compare against the
    # closed form of the reported case
    check_closed_form_derivatives(p)


@pytest.mark.parametrize("angle", [1e-8, -1e-8, 1e-7, 1e-12])
def test_nearly_parallel_edges(angle):
    """Edges at 1e-8 rad that cross in projection (the exact minimiser is interior): the kernel falls
    back to a PE/PP case whose value is within (θL)²/Δ of the exact one, with no NaN."""
    x0, x1 = np.array([-1.0, 0, 0]), np.array([1.0, 0, 0])
    x2 = rot_z(np.array([-1.0, 0, 0]), angle) + [0, 0, 0.3]
    x3 = rot_z(np.array([1.0, 0, 0]), angle) + [0, 0, 0.3]
    p = np.concatenate([x0, x1, x2, x3])
    delta, bi, bj, case = edge_edge_distance(p)
    assert case_kind(case) in ("PP", "PE")
    assert abs(delta - 0.3) <= 4 * angle**2 / 0.3 + 1e-15
    assert abs(delta - ref_distance_kkt(p)[0]) <= 1e-12
    _, g, h = derivs(p)
    assert np.all(np.isfinite(g)) and np.all(np.isfinite(h))
    check_closed_form_derivatives(p)
    # and a nearly parallel, offset pair in the same plane
    p2 = p.copy()
    p2[8] = p2[11] = 0.0
    p2[7] += 0.3
    p2[10] += 0.3
    delta2, _, _, case2 = edge_edge_distance(p2)
    assert case_kind(case2) in ("PP", "PE")
    assert abs(delta2 - ref_distance_kkt(p2)[0]) <= 1e-12
    check_closed_form_derivatives(p2)


def test_just_above_parallel_threshold_is_edge_edge():
    """At 1e-4 rad the EE case is used, and it is accurate."""
    ang = 1e-4
    p = np.concatenate(
        [
            [-1.0, 0, 0],
            [1.0, 0, 0],
            rot_z(np.array([-1.0, 0, 0]), ang) + [0, 0, 0.3],
            rot_z(np.array([1.0, 0, 0]), ang) + [0, 0, 0.3],
        ]
    )
    delta, bi, bj, case = edge_edge_distance(p)
    assert case == CASE_EE
    assert abs(delta - 0.3) <= 1e-14
    assert abs(bi - 0.5) <= 1e-9 and abs(bj - 0.5) <= 1e-9


def test_crossing_edges_touching():
    """Edges that intersect (Δ = 0, EE): finite derivatives, equal to those of the signed distance
    (x0 − x2)·û (sign +1 chosen at 0)."""
    p = np.array([-1.0, 0, 0, 1, 0, 0, 0, -1, 0, 0, 1, 0])
    (delta, bi, bj, case), g, h = derivs(p)
    assert case == CASE_EE and delta == 0.0 and bi == 0.5 and bj == 0.5
    assert np.all(np.isfinite(g)) and np.all(np.isfinite(h))

    def signed(x):
        u = np.cross(x[3:6] - x[0:3], x[9:12] - x[6:9])
        return (x[0:3] - x[6:9]) @ u / np.linalg.norm(u)

    assert np.abs(fd_gradient(signed, p, 1e-6) - g).max() <= 1e-8
    assert np.abs(fd_hessian_2nd(signed, p, 1e-4) - h).max() <= 1e-5


@pytest.mark.parametrize("gap", [1e-3, 1e-2, 0.3])
def test_crossing_edges_near(gap):
    p = np.array([-1.0, 0.1, 0, 1, -0.2, 0, 0.1, -1, gap, -0.2, 1, gap])
    assert edge_edge_distance(p)[3] == CASE_EE
    assert case_stable(p)
    fd_check(p)


@pytest.mark.parametrize(
    "p",
    [
        np.zeros(12),
        np.array([0.1, 0.2, 0.3] * 4),
        np.array([0, 0, 0, 0, 0, 0, 1, 1, 1, 2, 1, 1.0]),  # edge i of length 0
        np.array([0, 0, 0, 1, 0, 0, 0.5, 0.5, 0, 0.5, 0.5, 0.0]),  # edge j of length 0, PE
        np.array([0, 0, 0, 1, 0, 0, 0.5, 0.0, 0, 0.5, 0.0, 0.0]),  # point on segment, Δ = 0
        np.array([0, 0, 0, 1, 0, 0, 1, 0, 0, 2, 0, 0.0]),  # shared node, collinear
        np.array([0, 0, 0, 1, 0, 0, 1, 0, 0, 1, 1, 0.0]),  # shared node, perpendicular
        np.array([0, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0, 0.0]),  # identical edges
        np.array([0, 0, 0, 1e-120, 0, 0, 0, 1, 0, 1, 1, 0.0]),  # edge shorter than 1e-100 m
        np.array([0, 0, 0, 1e-90, 0, 0, -1, 1e-95, 0, 1, 1e-95, 0.0]),  # tiny, nearly touching
    ],
)
def test_degenerate_no_nan(p):
    (delta, bi, bj, case), g, h = derivs(p)
    assert math.isfinite(delta) and 0.0 <= bi <= 1.0 and 0.0 <= bj <= 1.0
    assert abs(delta - ref_distance_kkt(p)[0]) <= 1e-12
    assert np.all(np.isfinite(g)) and np.all(np.isfinite(h))
    gi, gj = beta_grads(p)
    assert np.all(np.isfinite(gi)) and np.all(np.isfinite(gj))


# ---------------------------------------------------------------------------------------------
# case boundaries


def boundary_configs():
    # PP/PE boundary: x0 projects exactly onto x2 (β_j = 0 with zero slack). Moving x0 by +x enters
    # PE(x0, edge j); by -x stays PP(x0, x2).
    pp_pe = np.array([0, 0.5, 0, -0.3, 1, 0.2, 0, 0, 0, 1, 0, 0.0])
    # PE/EE boundary: the line-line closest point on edge i is exactly x0 (β_i = 0). Moving edge j
    # by +x enters EE, by -x stays PE(x0, edge j).
    pe_ee = np.array([0, 0, 0, 1, 0, 0, 0, -1, 0.4, 0, 1, 0.4])
    # EE/PE boundary on edge j: closest point on edge j is exactly x2 (β_j = 0).
    ee_ep = np.array([-1, 0, 0.4, 1, 0, 0.4, 0, 0, 0, 0, 1, 0.0])
    return [
        (pp_pe, CASE_PP_00, 0, CASE_PE_0, CASE_PP_00),
        (pe_ee, CASE_PE_0, 6, CASE_EE, CASE_PE_0),
        (ee_ep, CASE_EP_0, 0, CASE_EE, CASE_EP_0),
    ]


@pytest.mark.parametrize("p, case_at, coord, case_plus, case_minus", boundary_configs())
def test_case_boundaries(p, case_at, coord, case_plus, case_minus):
    """At a boundary: the analytic derivatives are those of the reported case's closed form (its FD
    is smooth through the boundary). Just inside each neighbouring region (shift 1e-4 of one
    coordinate; for ee_ep the whole edge i moves): full FD, and Δ and ∇Δ are continuous across
    (|Δ(+) − Δ(−)|, |∇Δ(+) − ∇Δ(−)| = O(shift)); the Hessian may jump."""
    delta, bi, bj, case = edge_edge_distance(p)
    assert case == case_at
    check_closed_form_derivatives(p)
    eps = 1e-4
    shift = np.zeros(12)
    if case_at == CASE_EP_0:
        shift[[1, 4]] = 1.0  # move edge i in +y / -y: closest point on edge j leaves/enters x2
    elif case_at == CASE_PE_0:
        shift[[6, 9]] = 1.0  # move edge j in x
    else:
        shift[coord] = 1.0
    pp, pm = p + eps * shift, p - eps * shift
    assert edge_edge_distance(pp)[3] == case_plus
    assert edge_edge_distance(pm)[3] == case_minus
    assert case_stable(pp) and case_stable(pm)
    fd_check(pp)
    fd_check(pm)
    _, gp, _ = derivs(pp)
    _, gm, _ = derivs(pm)
    _, g0, _ = derivs(p)
    assert np.abs(gp - g0).max() <= 10 * eps and np.abs(gm - g0).max() <= 10 * eps
    assert abs(edge_edge_distance(pp)[0] - edge_edge_distance(pm)[0]) <= 10 * eps
