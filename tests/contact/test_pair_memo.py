"""The contact loop's memo of the pairs' distance and potential (surface friction): a Jacobian
evaluation whose pairs' coordinates are those of the last one (edge angles turned only, as after
the spin relaxation) takes them from the memo, with the results of a fresh evaluation bit for bit;
any change of a pair's coordinates or contact settings computes them again."""

from __future__ import annotations

import numpy as np
import pytest
from tests.contact.test_block_pattern import crossing, start

from knotsim.contact.model import ContactOptions


def _evaluate(ci, q, q_prev, want=True):
    r = np.zeros(q.shape[0])
    e, blocks = ci.evaluate(q, q_prev, 1e-3, r, want)
    ev = ci._last
    return e, r, None if blocks is None else blocks.copy(), ev.surface.copy(), ev.fc.copy(), ev.ff.copy()


def _assert_same(a, b):
    assert a[0] == b[0]
    for x, y in zip(a[1:], b[1:], strict=True):
        if x is None:
            assert y is None
        else:
            np.testing.assert_array_equal(x, y)


@pytest.fixture
def pressed():
    m = crossing(1.8e-3)
    ci, st = start(m, ContactOptions(mu=0.4))
    q = st.q.copy()
    q[m.node_dof[m.rod_node_start[1]:]] += 2e-5  # B slides a little: friction is on
    q[m.node_dof[m.rod_node_start[1]:] + 2] -= 3e-4  # and presses on A
    ci.evaluate(q, st.q, 1e-3, np.zeros(m.n_dofs), True)  # the blocks of the pairs in range
    return m, ci, st, q


def test_turned_angles_reuse_the_memo_with_the_fresh_results(pressed):
    m, ci, st, q = pressed
    first = _evaluate(ci, q, st.q)
    kept = ci._memo[0][:, 0]
    assert kept.shape[0] > 0 and (kept == 2.0).any()  # pairs in range with friction kept their terms
    q1 = q.copy()
    q1[m.edge_theta_dof] += 1e-3 * np.arange(m.n_edges)
    again = _evaluate(ci, q1, st.q)
    fresh_ci, _ = start(m, ContactOptions(mu=0.4))
    fresh_ci.evaluate(q, st.q, 1e-3, np.zeros(m.n_dofs), True)  # the same blocks, an empty memo
    fresh_ci._memo = tuple(np.zeros_like(a) for a in fresh_ci._memo)
    fresh = _evaluate(fresh_ci, q1, st.q)
    _assert_same(again, fresh)
    assert not np.array_equal(again[1], first[1])  # the angles' turn changed the friction


def test_the_memo_is_read_only_for_the_coordinates_it_was_made_at(pressed):
    m, ci, st, q = pressed
    _evaluate(ci, q, st.q)
    rows = np.flatnonzero(ci._memo[0][:, 0] == 2.0)
    ci._memo[3][rows] = np.nan  # the kept Hessians spoilt: a reuse shows as NaN blocks
    q1 = q.copy()
    q1[m.edge_theta_dof] += 1e-3
    assert np.isnan(_evaluate(ci, q1, st.q)[2]).any()
    ci._memo[3][rows] = np.nan
    q2 = q1.copy()
    q2[m.node_dof[m.rod_node_start[1]:] + 0] += 1e-9  # rod B's nodes moved: every pair computed again
    out = _evaluate(ci, q2, st.q)
    assert np.isfinite(out[2]).all()
    ci._memo[3][rows] = np.nan
    ci.options.delta *= 1.0 + 1e-12  # another contact range δ: computed again
    assert np.isfinite(_evaluate(ci, q2, st.q)[2]).all()


def test_residual_evaluations_neither_read_nor_write_the_memo(pressed):
    m, ci, st, q = pressed
    _evaluate(ci, q, st.q)
    memo = [a.copy() for a in ci._memo]
    q1 = q.copy()
    q1[m.node_dof] += 1e-6
    _evaluate(ci, q1, st.q, want=False)
    for a, b in zip(memo, ci._memo, strict=True):
        np.testing.assert_array_equal(a, b)


def test_centre_line_friction_keeps_no_memo():
    m = crossing(1.8e-3)
    ci, st = start(m, ContactOptions(mu=0.4, friction_model="centreline"))
    q = st.q.copy()
    q[m.node_dof[m.rod_node_start[1]:] + 2] -= 3e-4
    ci.evaluate(q, st.q, 1e-3, np.zeros(m.n_dofs), True)
    ci.evaluate(q, st.q, 1e-3, np.zeros(m.n_dofs), True)
    assert ci._blocks.shape[0] > 0 and all(a.shape[0] == 0 for a in ci._memo)


def test_spin_friction_holds_the_records_of_the_pairs_with_friction(pressed):
    """``Contact.spin_friction`` (one compiled pass) against numpy's masks: the pairs with
    ``F_n × coefficient > 0``, their angle unknowns and records, in their order."""
    from knotsim.contact.surface_friction import RECORD_SIZE

    m, ci, st, q = pressed
    _evaluate(ci, q, st.q)
    sf = ci.spin_friction()
    surface = ci._last.surface
    live = surface[:, 13] * surface[:, 14] > 0.0
    assert 0 < live.sum() < live.size
    np.testing.assert_array_equal(sf.theta_dofs, ci.pair_theta[live])
    np.testing.assert_array_equal(sf.record, surface[live, 4:4 + RECORD_SIZE])
    np.testing.assert_array_equal(sf.nu, np.full(live.sum(), ci.options.nu))
