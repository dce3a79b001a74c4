"""The elastic energy evaluated again after edge angles alone turned
(``ElasticEnergy.evaluate(..., turned_only=True)``, used after the stepper's spin relaxation): the
same energy, gradient and Hessian blocks as a full evaluation, bit for bit, and a full evaluation
whenever its conditions do not hold."""

from __future__ import annotations

import numpy as np
import pytest
from tests.energies.test_fd_elastic import _make_model, _source_at

from knotsim.energies.elastic import ElasticEnergy
from knotsim.rods.frames import turned_material_frames


def _state(el):
    return (el.energies.copy(), el.grad.copy(), el.bend_hess.copy(), el.stretch_hess.copy(), el.kappa.copy(),
            el.twist.copy(), el.m1.copy(), el.m2.copy())


def _assert_same(a, b):
    assert a[0] == b[0]
    for x, y in zip(a[1:], b[1:], strict=True):
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize("turned", [[], [0], [3, 4], "all"])
def test_turned_angles_give_the_full_evaluation_bit_for_bit(closed, turned):
    rng = np.random.default_rng(11)
    model, q = _make_model(rng, 12, closed, 1.5)
    source = _source_at(model, q)
    q0 = q + 1e-3 * rng.normal(size=q.size)
    edges = np.arange(model.n_edges) if turned == "all" else np.array(turned, dtype=np.int64)
    q1 = q0.copy()
    q1[model.edge_theta_dof[edges]] += 0.3 * rng.normal(size=edges.size)
    fast = ElasticEnergy(model)
    fast.evaluate(q0, source, True)
    e_fast = fast.evaluate(q1, source, True, turned_only=True)
    assert int(fast._stencil_turned.sum()) < model.n_bend or turned == "all"  # not a full evaluation
    full = ElasticEnergy(model)
    full.evaluate(q0, source, True)  # the same history: kappa and twist of untouched stencils alike
    e_full = full.evaluate(q1, source, True)
    assert e_fast == e_full
    _assert_same(_state(fast), _state(full))
    # and again from there (the kept terms are those of the last evaluation)
    q2 = q1.copy()
    q2[model.edge_theta_dof[edges]] -= 0.1
    assert fast.evaluate(q2, source, True, turned_only=True) == full.evaluate(q2, source, True)
    _assert_same(_state(fast), _state(full))


def _full_after(model, source, q_before, q, want_before=True):
    el = ElasticEnergy(model)
    el.evaluate(q_before, source, want_before)
    el.evaluate(q, source, True)
    return _state(el)


def test_a_moved_node_a_residual_only_evaluation_or_new_frames_mean_a_full_evaluation():
    rng = np.random.default_rng(3)
    model, q = _make_model(rng, 10, False, 1.0)
    source = _source_at(model, q)
    q0 = q + 1e-3 * rng.normal(size=q.size)
    # a node moved as well as an angle
    q1 = q0.copy()
    q1[model.edge_theta_dof[2]] += 0.2
    q1[model.node_dof[5]] += 1e-4
    el = ElasticEnergy(model)
    el.evaluate(q0, source, True)
    el.evaluate(q1, source, True, turned_only=True)
    _assert_same(_state(el), _full_after(model, source, q0, q1))
    # the last evaluation had no Hessian
    q2 = q0.copy()
    q2[model.edge_theta_dof[2]] += 0.2
    el = ElasticEnergy(model)
    el.evaluate(q0, source, True)
    el.evaluate(q0 + 1e-5, source, False)
    el.evaluate(q2, source, True, turned_only=True)
    _assert_same(_state(el), _full_after(model, source, q0, q2))
    # another frame source (a new step)
    other = _source_at(model, q0)
    el = ElasticEnergy(model)
    el.evaluate(q0, source, True)
    el.evaluate(q2, other, True, turned_only=True)
    _assert_same(_state(el), _full_after(model, other, q0, q2))
    # the frames were updated elsewhere in between
    el = ElasticEnergy(model)
    el.evaluate(q0, source, True)
    el.update_frames(q0 + 1e-4, source)
    el.evaluate(q2, source, True, turned_only=True)
    _assert_same(_state(el), _full_after(model, source, q0, q2))


def test_turned_material_frames_refuses_a_moved_position():
    rng = np.random.default_rng(5)
    model, q = _make_model(rng, 8, False, 1.0)
    el = ElasticEnergy(model)
    el.update_frames(q, _source_at(model, q))
    m1 = el.m1.copy()
    q1 = q.copy()
    q1[model.node_dof[3] + 2] += 1e-9
    q1[model.edge_theta_dof[1]] += 0.5
    turned = np.zeros(model.n_bend, bool)
    assert not turned_material_frames(q1, q, model.theta_mask, model.edge_theta_dof, model.bend_edges, el.d1,
                                      el.tangents, el.m1, el.m2, turned)
    np.testing.assert_array_equal(el.m1, m1)  # nothing written
    q1[model.node_dof[3] + 2] = q[model.node_dof[3] + 2]
    assert turned_material_frames(q1, q, model.theta_mask, model.edge_theta_dof, model.bend_edges, el.d1,
                                  el.tangents, el.m1, el.m2, turned)
    np.testing.assert_array_equal(np.flatnonzero(turned), np.flatnonzero((model.bend_edges == 1).any(axis=1)))
    assert not np.array_equal(el.m1[1], m1[1]) and np.array_equal(np.delete(el.m1, 1, 0), np.delete(m1, 1, 0))
