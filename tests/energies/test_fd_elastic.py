"""Finite-difference checks of the elastic energies' gradients and Hessians, against a slow
reference implementation written with plain numpy (no numba, no shared code)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from knotsim.energies.elastic import ElasticEnergy, FrameSource
from knotsim.rods import Model, RodSpec
from knotsim.rods.frames import space_parallel_directors


def _source_at(model, q):
    """Frames whose source is ``q`` itself (so transport is the identity at ``q``)."""
    pos = model.node_positions(q)
    d1 = np.zeros((model.n_edges, 3))
    tang = np.zeros((model.n_edges, 3))
    for r in range(model.n_rods):
        e0, e1 = model.rod_edge_start[r], model.rod_edge_start[r + 1]
        nodes = model.edge_nodes[e0:e1]
        t = pos[nodes[:, 1]] - pos[nodes[:, 0]]
        t /= np.linalg.norm(t, axis=1)[:, None]
        tang[e0:e1] = t
        d1[e0:e1] = space_parallel_directors(t, bool(model.rod_closed[r]))
    el = ElasticEnergy(model)
    zero = FrameSource(d1, tang, np.zeros(model.n_bend))
    el.update_frames(q, zero)
    return FrameSource(d1, tang, el.ref_twist.copy())


def _make_model(rng, n_nodes, closed, bend_scale, kappa_bar=True):
    s = np.linspace(0, 1, n_nodes, endpoint=not closed)
    if closed:
        pts = np.stack([np.cos(2 * np.pi * s), np.sin(2 * np.pi * s), 0.2 * np.sin(4 * np.pi * s)], 1) * 0.05
    else:
        pts = np.stack([s, 0.0 * s, 0.0 * s], 1) * 0.1
    pts = pts + bend_scale * rng.normal(size=pts.shape) * 0.1 / n_nodes
    rod = RodSpec(pts, radius=1e-3, youngs_modulus=1e6, density=1000.0, closed=closed,
                  rest_edge_lengths=np.linalg.norm(RodSpec(pts, 1e-3, 1e6, 1e3, closed=closed).edge_vectors(), axis=1)
                  * (1 + 0.05 * rng.normal(size=n_nodes if closed else n_nodes - 1)),
                  natural_curvature=rng.normal(size=(n_nodes if closed else n_nodes - 2, 2)) * 5 if kappa_bar else None,
                  natural_twist=rng.normal(size=n_nodes if closed else n_nodes - 2) * 3)
    model = Model([rod])
    q = np.zeros(model.n_dofs)
    q[model.node_dof[:, None] + np.arange(3)] = pts
    q[model.edge_theta_dof] = rng.normal(size=model.n_edges) * 0.5
    return model, q


def _total(model, q, source, part):
    el = ElasticEnergy(model)
    el.evaluate(q, source, want_hessian=False)
    return el.energies[part], el.grad.copy()


def _hessian(model, q, source, part):
    el = ElasticEnergy(model, separate_blocks=True)
    el.evaluate(q, source, want_hessian=True)
    n = model.n_dofs
    H = np.zeros((n, n))
    if part == "stretching":
        for e in range(model.n_edges):
            d = model.stretch_dofs[e]
            H[np.ix_(d, d)] += el.stretch_hess[e]
    else:
        blocks = el.bend_hess if part == "bending" else el.twist_hess
        for s in range(model.n_bend):
            d = model.bend_dofs[s]
            H[np.ix_(d, d)] += blocks[s]
    return H


def _part_gradient(model, q, source, part):
    """Gradient of one energy term only."""
    from knotsim.energies.bending import bending_energy
    from knotsim.energies.stretching import stretching_energy
    from knotsim.energies.twisting import twisting_energy

    el = ElasticEnergy(model, separate_blocks=True)
    el.update_frames(q, source)
    g = np.zeros(model.n_dofs)
    m = model
    if part == "stretching":
        stretching_energy(q, m.edge_dofs, m.rest_length, m.edge_EA, g, el.stretch_hess, False)
    elif part == "bending":
        bending_energy(q, m.bend_dofs, m.bend_edges, el.tangents, el.lengths, el.m1, el.m2, m.bend_EI,
                       m.voronoi_rest, m.kappa_bar, g, el.bend_hess, False, el.kappa)
    else:
        twisting_energy(q, m.bend_dofs, m.bend_edges, el.tangents, el.lengths, el.ref_twist, m.twist_GJ,
                        m.voronoi_rest, m.twist_bar, g, el.twist_hess, False, el.twist)
    return g


def _part_energy(model, q, source, part):
    el = ElasticEnergy(model)
    el.evaluate(q, source, want_hessian=False)
    return el.energies[part]


PARTS = ["stretching", "bending", "twisting"]


def check_fd(model, q, part, rtol_g=1e-6, rtol_h=1e-5):
    source = _source_at(model, q)
    g = _part_gradient(model, q, source, part)
    n = model.n_dofs
    scale_x = 1e-7
    g_fd = np.zeros(n)
    for i in range(n):
        h = scale_x if not model.theta_mask[i] else 1e-6
        qp, qm = q.copy(), q.copy()
        qp[i] += h
        qm[i] -= h
        g_fd[i] = (_part_energy(model, qp, source, part) - _part_energy(model, qm, source, part)) / (2 * h)
    gscale = np.max(np.abs(g_fd)) + 1e-30
    assert np.max(np.abs(g - g_fd)) <= rtol_g * gscale + 1e-12, (part, np.max(np.abs(g - g_fd)), gscale)

    H = _hessian(model, q, source, part)
    H_fd = np.zeros((n, n))
    for i in range(n):
        h = scale_x if not model.theta_mask[i] else 1e-6
        qp, qm = q.copy(), q.copy()
        qp[i] += h
        qm[i] -= h
        H_fd[:, i] = (_part_gradient(model, qp, source, part) - _part_gradient(model, qm, source, part)) / (2 * h)
    # The DER gradient is exact only where the frames' transport is the identity, so the finite
    # difference of the gradient carries a skew-symmetric holonomy part; the Hessian is its
    # symmetric part.
    H_fd = 0.5 * (H_fd + H_fd.T)
    hscale = np.max(np.abs(H_fd)) + 1e-30
    err = np.max(np.abs(H - H_fd))
    assert err <= rtol_h * hscale, (part, err, hscale, np.unravel_index(np.argmax(np.abs(H - H_fd)), H.shape))


@pytest.mark.parametrize("part", PARTS)
@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize("bend_scale", [0.0, 0.3, 3.0])
def test_fd_open_closed(part, closed, bend_scale):
    rng = np.random.default_rng(7)
    model, q = _make_model(rng, 6, closed, bend_scale)
    check_fd(model, q, part)


@pytest.mark.parametrize("part", PARTS)
def test_fd_sharp_bend(part):
    # A hairpin: 150 degree turn at one node.
    pts = np.array([[0, 0, 0], [0.01, 0, 0], [0.02, 0, 0.0], [0.02 - 0.01 * np.cos(np.radians(30)),
                    0.01 * np.sin(np.radians(30)), 0.001], [0.005, 0.008, 0.003]])
    rod = RodSpec(pts, radius=1e-3, youngs_modulus=1e6, density=1000.0, natural_twist=1.0, rest_edge_lengths=0.009)
    model = Model([rod])
    q = np.zeros(model.n_dofs)
    q[model.node_dof[:, None] + np.arange(3)] = pts
    q[model.edge_theta_dof] = [0.1, -0.4, 1.2, 0.3]
    check_fd(model, q, part)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), closed=st.booleans(), scale=st.floats(0.0, 4.0),
       part=st.sampled_from(PARTS))
def test_fd_random(seed, closed, scale, part):
    rng = np.random.default_rng(seed)
    model, q = _make_model(rng, 5, closed, scale)
    check_fd(model, q, part)


@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize("seed, fibrous", [(0, False), (1, False), (2, False), (23, True)])
def test_energies_match_naive_reference(closed, seed, fibrous):
    """The energies equal the plain numpy reference's, for a solid rod and for a rope whose EI and GJ
    are set apart from its axial stiffness (``fibrous``)."""
    from .reference_der import reference_energies

    rng = np.random.default_rng(seed)
    model, q = (_fibrous_model if fibrous else _make_model)(rng, 7, closed, 2.0)
    source = _source_at(model, q)
    # perturb away from the source so transport and reference twist are exercised
    q2 = q + 1e-3 * rng.normal(size=q.size)
    el = ElasticEnergy(model)
    el.evaluate(q2, source, want_hessian=False)
    rod = model.rods[0]
    ref = reference_energies(model.node_positions(q2), q2[model.edge_theta_dof], source.d1, source.tangents, closed,
                             model.rest_length, rod.EA, rod.EI, rod.GJ, model.kappa_bar, model.twist_bar,
                             source.ref_twist)
    for value, expected in zip((el.energies["stretching"], el.energies["bending"], el.energies["twisting"]), ref,
                               strict=True):
        assert value == pytest.approx(expected, rel=1e-10, abs=1e-18)


def test_combined_blocks_equal_bending_plus_twisting():
    rng = np.random.default_rng(3)
    model, q = _make_model(rng, 8, False, 1.0)
    source = _source_at(model, q)
    sep = ElasticEnergy(model, separate_blocks=True)
    sep.evaluate(q, source, want_hessian=True)
    comb = ElasticEnergy(model)
    comb.evaluate(q, source, want_hessian=True)
    # to round-off, per block (the combined blocks may come from one map of the summed Hessians)
    ref = sep.bend_hess + sep.twist_hess
    assert np.all(np.abs(comb.bend_hess - ref) <= 1e-13 * np.abs(ref).max(axis=(1, 2))[:, None, None])
    np.testing.assert_allclose(comb.grad, sep.grad, rtol=0, atol=1e-13 * np.abs(sep.grad).max())


@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize("scale", [0.0, 2.0])
def test_hessian_blocks_match_slow_reference(closed, scale):
    """The kernels' folded, block-mapped Hessians equal the obvious numpy form to round-off."""
    from .reference_hessian import bending_blocks, twisting_blocks

    rng = np.random.default_rng(11)
    model, q = _make_model(rng, 9, closed, scale)
    source = _source_at(model, q)
    q2 = q + 1e-3 * rng.normal(size=q.size)  # away from the source: nonzero reference twist change
    el = ElasticEnergy(model, separate_blocks=True)
    el.evaluate(q2, source, want_hessian=True)
    for got, ref in ((el.bend_hess, bending_blocks(el, model)), (el.twist_hess, twisting_blocks(el, model, q2))):
        scale_b = np.abs(ref).max(axis=(1, 2))[:, None, None]
        assert np.all(np.abs(got - ref) <= 1e-13 * scale_b), np.abs(got - ref).max()


@pytest.mark.parametrize("closed", [False, True])
def test_one_pass_bending_twisting_equals_separate_terms(closed):
    """``bending_twisting_energy`` with both terms: energies, gradient and summed blocks of the
    separate bending and twisting evaluations (to round-off: one ``T^T Hz T`` map of the sum)."""
    from knotsim.energies.bending import bending_twisting_energy

    rng = np.random.default_rng(5)
    model, q = _make_model(rng, 8, closed, 1.5)
    source = _source_at(model, q)
    q2 = q + 1e-3 * rng.normal(size=q.size)
    sep = ElasticEnergy(model, separate_blocks=True)
    sep.evaluate(q2, source, want_hessian=True)
    el = ElasticEnergy(model)
    el.update_frames(q2, source)
    m = model
    for want in (True, False):
        grad = np.zeros(m.n_dofs)
        hess = np.full((m.n_bend, 11, 11), np.nan)
        eb, et = bending_twisting_energy(q2, m.bend_dofs, m.bend_edges, el.tangents, el.lengths, el.m1, el.m2,
                                         el.ref_twist, m.bend_EI, m.twist_GJ, m.voronoi_rest, m.kappa_bar,
                                         m.twist_bar, grad, hess, want, el.kappa, el.twist, np.empty((0, 8)),
                                         np.empty((0, 2)), np.empty(0, bool), True, True, False)
        assert eb == pytest.approx(sep.energies["bending"], rel=1e-14)
        assert et == pytest.approx(sep.energies["twisting"], rel=1e-14)
        gs = np.zeros(m.n_dofs)
        stretch = np.zeros((m.n_edges, 6, 6))
        from knotsim.energies.stretching import stretching_energy

        stretching_energy(q2, m.edge_dofs, m.rest_length, m.edge_EA, gs, stretch, False)
        np.testing.assert_allclose(grad + gs, sep.grad, rtol=0, atol=1e-13 * np.abs(sep.grad).max())
        if want:
            ref = sep.bend_hess + sep.twist_hess
            scale_b = np.abs(ref).max(axis=(1, 2))[:, None, None]
            assert np.all(np.abs(hess - ref) <= 1e-13 * scale_b)
        else:
            assert np.isnan(hess).all()


def _fibrous_model(rng, n_nodes, closed, scale):
    """The model of :func:`_make_model` with a fibrous rope's stiffnesses: EI = EA h^2 / 1000 and
    GJ = 0.3 EI, set apart from the axial stiffness (``bending_stiffness``, ``torsional_stiffness``)."""
    model, q = _make_model(rng, n_nodes, closed, scale)
    rod = model.rods[0]
    rod.bending_stiffness = rod.EA * rod.radius**2 / 1000.0
    rod.torsional_stiffness = 0.3 * rod.bending_stiffness
    return Model([rod]), q


@pytest.mark.parametrize("part", PARTS)
@pytest.mark.parametrize("closed", [False, True])
def test_fd_with_independent_bending_and_twisting_stiffness(part, closed):
    """Gradient and Hessian against finite differences when EI and GJ are set independently of EA."""
    rng = np.random.default_rng(19)
    model, q = _fibrous_model(rng, 6, closed, 1.0)
    rod = model.rods[0]
    assert np.all(model.bend_EI == rod.EA * rod.radius**2 / 1000.0)
    assert np.all(model.twist_GJ == 0.3 * model.bend_EI)
    check_fd(model, q, part)


