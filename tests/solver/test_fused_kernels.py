"""Fused and reduced kernels of the step against the plain ones they replace."""

import numpy as np
import pytest

from knotsim.contact.potential import contact_pair_energy, pair_energy
from knotsim.contact.regularized_distance import regularized_derivatives_at, regularized_distance
from knotsim.rods.frames import (
    compute_tangents,
    material_frames,
    reference_twist,
    transport_directors,
    update_frames,
)
from knotsim.solver._kernels import all_finite


@pytest.mark.parametrize("n", [0, 1, 7, 1203, 25000])
def test_all_finite_matches_numpy(n):
    rng = np.random.default_rng(n)
    x = rng.normal(size=n) * 1e300
    assert all_finite(x) == bool(np.all(np.isfinite(x)))
    for bad in (np.nan, np.inf, -np.inf):
        if n:
            y = x.copy()
            y[rng.integers(n)] = bad
            assert not all_finite(y)
    if n:
        y = x.copy()
        y[-1] = np.finfo(float).max
        assert all_finite(y)


def test_update_frames_equals_the_four_kernels():
    rng = np.random.default_rng(3)
    ne = 12
    x = np.cumsum(rng.normal(size=(ne + 1, 3)), axis=0)
    # unknowns: node positions interleaved with one edge angle after each node but the last
    q = np.zeros(4 * ne + 3)
    edge_dofs = np.array([[4 * e, 4 * e + 4] for e in range(ne)], np.int64)
    theta_dof = np.array([4 * e + 3 for e in range(ne)], np.int64)
    for i in range(ne + 1):
        q[4 * i:4 * i + 3] = x[i]
    q[theta_dof] = rng.normal(size=ne)
    bend_edges = np.array([[e, e + 1] for e in range(ne - 1)], np.int64)
    t_old = rng.normal(size=(ne, 3))
    t_old /= np.linalg.norm(t_old, axis=1)[:, None]
    d1_old = np.cross(t_old, rng.normal(size=(ne, 3)))
    d1_old /= np.linalg.norm(d1_old, axis=1)[:, None]
    twist_prev = rng.normal(size=ne - 1)
    ref = [np.zeros((ne, 3)), np.zeros(ne), np.zeros((ne, 3)), np.zeros(ne - 1), np.zeros((ne, 3)), np.zeros((ne, 3))]
    compute_tangents(q, edge_dofs, ref[0], ref[1])
    transport_directors(d1_old, t_old, ref[0], ref[2])
    reference_twist(ref[2], ref[0], bend_edges, twist_prev, ref[3])
    material_frames(ref[2], ref[0], q[theta_dof], ref[4], ref[5])
    got = [np.zeros_like(a) for a in ref]
    update_frames(q, edge_dofs, theta_dof, bend_edges, d1_old, t_old, twist_prev, *got)
    for a, b in zip(ref, got, strict=True):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("seed", range(20))
def test_gradient_only_contact_derivatives_equal_the_full_ones(seed):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=12) * 1e-3
    if seed % 4 == 0:  # (nearly) parallel edges
        p[6:9] = p[0:3] + np.array([0.0, 0.0, 1e-3])
        p[9:12] = p[3:6] + np.array([0.0, 0.0, 1e-3]) + rng.normal(size=3) * 1e-9
    eta = 1e-3
    delta, bi, bj, case = regularized_distance(p, eta)
    g_full, h_full = np.zeros(12), np.zeros((12, 12))
    g_only, h_untouched = np.zeros(12), np.full((12, 12), 7.0)
    regularized_derivatives_at(p, eta, delta, bi, bj, case, g_full, h_full, True)
    regularized_derivatives_at(p, eta, delta, bi, bj, case, g_only, h_untouched, False)
    assert np.array_equal(g_full, g_only)
    assert np.all(h_untouched == 7.0)
    d = delta + 0.5e-3  # in range
    g1, h1 = np.zeros(12), np.zeros((12, 12))
    g2, h2 = np.zeros(12), np.zeros((12, 12))
    e1 = contact_pair_energy(p, d, 1e-3, g1, h1, eta)
    e2 = _pair_energy_no_hessian(p, d, 1e-3, g2, h2, eta)
    assert e1[0] > 0.0 and e1[:4] == e2[:4]
    assert np.array_equal(g1, g2)


def test_contact_pair_energy_out_of_range_zeroes_derivatives():
    p = np.array([0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1, 1], float) * 1e-2
    g, h = np.ones(12), np.ones((12, 12))
    e = contact_pair_energy(p, 1e-3, 1e-4, g, h, 1e-3)
    assert e[0] == 0.0 and not g.any() and not h.any()


def _pair_energy_no_hessian(p, d, tol, grad, hess, eta):
    from numba import njit

    @njit
    def call(p, d, tol, grad, hess, eta):
        return pair_energy(p, d, tol, grad, hess, eta, True, False)

    return call(p, d, tol, grad, hess, eta)


@pytest.mark.parametrize("seed", range(6))
def test_split_max_abs_matches_numpy(seed):
    from knotsim.solver._kernels import split_max_abs

    rng = np.random.default_rng(seed)
    n = 1203
    x = rng.normal(size=n) * 10.0 ** rng.integers(-300, 300, size=n)
    theta = np.zeros(n, bool)
    theta[3::4] = True
    if seed == 1:
        x[5] = -np.inf
    if seed == 2:
        x[:] = 0.0
        x[7] = -0.0
    got = split_max_abs(x, theta)
    assert got == (float(np.max(np.abs(x[~theta]))), float(np.max(np.abs(x[theta]))))
    y = x.copy()
    y[rng.integers(n)] = np.nan
    assert all(np.isnan(v) for v in split_max_abs(y, theta))
    assert split_max_abs(np.zeros(0), np.zeros(0, bool)) == (0.0, 0.0)


def test_predict_positions_is_the_numpy_expression_bitwise():
    from knotsim.solver._kernels import predict_positions

    rng = np.random.default_rng(4)
    for _ in range(10):
        q, v, vp = rng.normal(size=(3, 1203)) * 10.0 ** rng.uniform(-5, 5, size=(3, 1203))
        dt, ratio = 2.5e-3 * rng.uniform(0.1, 1.0), rng.uniform(0.2, 2.0)
        out = np.empty(1203)
        predict_positions(q, v, vp, ratio, dt, out)
        assert np.array_equal(out, q + dt * (v + (v - vp) * ratio))


def test_same_values_is_array_equal():
    from knotsim.solver._kernels import same_values

    a = np.arange(5.0)
    assert same_values(a, a.copy())
    b = a.copy()
    b[3] = 7.0
    assert not same_values(a, b)
    assert not same_values(a, a[:4])
    assert not same_values(np.array([np.nan]), np.array([np.nan]))
    c = a.copy()
    c[2] = np.nextafter(c[2], 9.0)
    assert not same_values(a, c)
    assert same_values(np.array([0.0]), np.array([-0.0]))
    m = np.zeros(6, bool)
    assert same_values(m, m.copy()) and not same_values(m, ~m)
