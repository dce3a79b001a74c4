"""Contact monitoring kernels against slow references: approach forces, nodal force summary, drift."""

import numpy as np
import pytest

from knotsim.contact.assembly import approach_forces, nodal_force_summary
from knotsim.contact.broadphase import node_drift
from knotsim.contact.distance import edge_edge_distance


def _reference_approach(q, v, dt, pair_dofs, pair_d, tol, mass):
    """Approach speed by central differences of the distance along the velocity."""
    fmax = 0.0
    eps = 1e-7
    for k, dofs in enumerate(pair_dofs):
        p = q[dofs]
        delta = edge_edge_distance(p)[0]
        rate = (edge_edge_distance(p + eps * v[dofs])[0] - edge_edge_distance(p - eps * v[dofs])[0]) / (2 * eps)
        if rate >= 0 or delta + rate * dt >= pair_d[k] + tol:
            continue
        m = 0.25 * (mass[dofs[0]] + mass[dofs[3]] + mass[dofs[6]] + mass[dofs[9]])
        fmax = max(fmax, -rate * m / dt)
    return fmax


@pytest.mark.parametrize("seed", range(8))
def test_approach_forces_match_finite_differences(seed):
    rng = np.random.default_rng(seed)
    n_nodes = 8
    q = rng.normal(scale=3e-3, size=3 * n_nodes)
    v = rng.normal(scale=0.5, size=3 * n_nodes)
    mass = rng.uniform(1e-6, 2e-6, size=3 * n_nodes)
    # all pairs of the 4 disjoint edges (0-1, 2-3, 4-5, 6-7), including point-edge and edge-edge cases
    edges = [(0, 1), (2, 3), (4, 5), (6, 7)]
    pair_dofs = np.array([[3 * a + c for a in (*edges[i], *edges[j]) for c in range(3)]
                          for i in range(4) for j in range(i + 1, 4)], dtype=np.int64)
    pair_d = np.full(len(pair_dofs), 2e-3)
    got = approach_forces(q, v, 2.5e-3, pair_dofs, pair_d, 5e-4, mass)
    want = _reference_approach(q, v, 2.5e-3, pair_dofs, pair_d, 5e-4, mass)
    assert got == pytest.approx(want, rel=1e-6, abs=1e-12)


def test_approach_forces_parallel_edges_closing():
    # two parallel edges 3 mm apart closing at 1 m/s: approach speed 1 m/s exactly
    q = np.array([0, 0, 0, 1e-2, 0, 0, 0, 3e-3, 0, 1e-2, 3e-3, 0], float)
    v = np.zeros(12)
    v[[7, 10]] = -1.0
    mass = np.full(12, 1e-6)
    f = approach_forces(q, v, 1e-3, np.arange(12, dtype=np.int64)[None, :], np.array([2e-3]), 5e-4, mass)
    assert f == pytest.approx(1.0 * 1e-6 / 1e-3, rel=1e-12)


def test_nodal_force_summary_matches_numpy():
    rng = np.random.default_rng(1)
    n_nodes = 10
    node_dof = np.arange(n_nodes, dtype=np.int64) * 4
    n_dofs = 4 * n_nodes - 1
    pair_dofs = np.array([[node_dof[a] + c for a in rng.choice(n_nodes, 4, replace=False) for c in range(3)]
                          for _ in range(6)], dtype=np.int64)
    fc = rng.normal(size=(6, 12))
    ff = rng.normal(size=(6, 12))
    got = nodal_force_summary(pair_dofs, fc, ff, node_dof, n_dofs)
    acc_c = np.zeros(n_dofs)
    acc_f = np.zeros(n_dofs)
    np.add.at(acc_c, pair_dofs.ravel(), fc.ravel())
    np.add.at(acc_f, pair_dofs.ravel(), ff.ravel())
    idx = node_dof[:, None] + np.arange(3)
    nc = np.linalg.norm(acc_c[idx], axis=1)
    nf = np.linalg.norm(acc_f[idx], axis=1)
    assert got == pytest.approx((nc.max(), 0.5 * nc.sum(), 0.5 * nf.sum()), rel=1e-12)


def test_node_drift_ignores_common_translation():
    rng = np.random.default_rng(2)
    node_dof = np.arange(5, dtype=np.int64) * 4
    q0 = rng.normal(size=19)
    u = rng.normal(scale=1e-3, size=(5, 3))
    q1 = q0.copy()
    for i, a in enumerate(node_dof):
        q1[a:a + 3] += u[i] + np.array([5.0, -3.0, 2.0])  # plus a large common translation
    centre = 0.5 * (u.min(axis=0) + u.max(axis=0))
    want = np.linalg.norm(u - centre, axis=1).max()
    assert node_drift(q1, q0, node_dof) == pytest.approx(want, rel=1e-9)
    # the bound the Verlet list relies on: no two nodes approach by more than twice the drift
    assert np.max(np.linalg.norm(u[:, None] - u[None], axis=2)) <= 2 * want + 1e-15
