"""The two contact-evaluate kernels (exact and regularized distance) against a slow per-pair loop
over :func:`knotsim.contact.potential.contact_pair_energy` and :func:`friction_pair`."""

import numpy as np
import pytest

from knotsim.contact.assembly import SURFACE_COLUMNS, contact_evaluate_exact, contact_evaluate_regularized
from knotsim.contact.distance import edge_edge_beta_gradients
from knotsim.contact.friction import friction_pair
from knotsim.contact.model import _pair_memo
from knotsim.contact.potential import contact_pair_energy
from knotsim.contact.regularized_distance import regularized_beta_gradients


def _reference(q, q_prev, dt, pair_dofs, pair_d, pair_mu, tol, nu, kc, pair_eta):
    """Residual, blocks and energy of every pair, one pair at a time in Python."""
    residual = np.zeros_like(q)
    blocks = np.zeros((len(pair_dofs), 12, 12))
    etot = 0.0
    for k, dofs in enumerate(pair_dofs):
        p = q[dofs].copy()
        g = np.zeros(12)
        h = np.zeros((12, 12))
        E, _, bi, bj, case = contact_pair_energy(p, pair_d[k], tol, g, h, pair_eta[k])
        if E <= 0.0:
            continue
        etot += E
        residual[dofs] += kc * g
        dbi, dbj = np.zeros(12), np.zeros(12)
        if pair_eta[k] > 0.0:
            regularized_beta_gradients(p, pair_eta[k], bi, bj, case, dbi, dbj)
        else:
            edge_edge_beta_gradients(p, bi, bj, case, dbi, dbj)
        ffr, jfr = np.zeros(12), np.zeros((12, 12))
        friction_pair(p, q_prev[dofs].copy(), dt, pair_mu[k], nu, -kc * g, -kc * h, bi, bj, dbi, dbj, ffr, jfr,
                      True)
        residual[dofs] -= ffr
        blocks[k] = kc * h - jfr
    return residual, blocks, kc * etot


@pytest.mark.parametrize("regularized", [False, True])
def test_kernel_matches_per_pair_reference(regularized):
    rng = np.random.default_rng(3)
    n_pairs = 6
    # pairs of nearly touching edges (some parallel, some crossing), 4 nodes each, 12 unknowns per pair
    q = np.empty(12 * n_pairs)
    for k in range(n_pairs):
        a0 = rng.normal(size=3) * 0.01
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        w = u if k % 2 == 0 else np.cross(u, rng.normal(size=3))
        w /= np.linalg.norm(w)
        nrm = np.cross(u, w) if k % 2 else np.cross(u, rng.normal(size=3))
        nrm /= np.linalg.norm(nrm)
        b0 = a0 + 0.0019 * nrm + 0.001 * rng.normal(size=3) * 0.1
        q[12 * k:12 * k + 12] = np.concatenate([a0, a0 + 0.01 * u, b0, b0 + 0.01 * w])
    q_prev = q + 1e-6 * rng.normal(size=q.shape)
    pair_dofs = np.arange(12 * n_pairs, dtype=np.int64).reshape(n_pairs, 12)
    pair_d = np.full(n_pairs, 0.002)
    pair_mu = np.array([0.3, 0.0, 0.5, 0.3, 0.2, 0.3])
    pair_eta = np.full(n_pairs, 1e-3 if regularized else 0.0)
    tol, nu, kc, dt = 5e-4, 1e-3, 1e3, 1e-3
    kernel = contact_evaluate_regularized if regularized else contact_evaluate_exact
    residual = np.zeros_like(q)
    # blocks stored for every pair but the second, in reverse order: pair k in blocks[slot[k]]
    slot = np.array([5, -1, 4, 3, 2, 1], np.int64)[:n_pairs]
    blocks = np.full((n_pairs, 12, 12), np.nan)
    e, missing = kernel(q, q_prev, dt, pair_dofs, pair_d, pair_mu, tol, nu, kc, residual, True, blocks, slot,
                        np.empty(n_pairs), np.empty((n_pairs, 12)), np.empty((n_pairs, 12)), pair_eta,
                        np.zeros((n_pairs, 2), np.int64), np.zeros((n_pairs, 2)), np.zeros((n_pairs, SURFACE_COLUMNS)),
                        np.zeros((0, 3)), np.zeros(0), 0.0, *_pair_memo(0))
    r_ref, b_ref, e_ref = _reference(q, q_prev, dt, pair_dofs, pair_d, pair_mu, tol, nu, kc, pair_eta)
    assert e_ref > 0.0  # some pairs are in range: the comparison is not vacuous
    assert e == pytest.approx(e_ref, rel=1e-12)
    np.testing.assert_allclose(residual, r_ref, rtol=1e-10, atol=1e-12 * np.abs(r_ref).max())
    stored = slot >= 0
    np.testing.assert_allclose(blocks[slot[stored]], b_ref[stored], rtol=1e-10, atol=1e-12 * np.abs(b_ref).max())
    assert np.all(np.isnan(blocks[0]))  # slot 0 belongs to no pair: untouched
    assert missing == int(np.any(b_ref[1] != 0.0))  # the blockless pair counts when it is in range
