"""Jacobian blocks only for candidate pairs near contact (:meth:`Contact.block_dofs`).

The reference is the obvious rule, one block for every candidate pair of the Verlet list (the
subclass :class:`AllBlocks`): the assembled Jacobian, a simulation's trajectory and its Newton
iterations must be the same, up to round-off from the different sparse pattern.
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest

from knotsim.bc import BoundaryConditions
from knotsim.contact.assembly import (
    SURFACE_COLUMNS,
    contact_evaluate_regularized,
    contact_evaluate_regularized_surface,
)
from knotsim.contact.model import BLOCK_BAND_FRACTION, Contact, ContactOptions, _pair_memo
from knotsim.rods import Model, RodSpec
from knotsim.simulation import Simulation
from knotsim.solver.state import initial_state
from knotsim.solver.stepper import SolverOptions

R = 1e-3  # rod radius, m


class AllBlocks(Contact):
    """Reference: a Jacobian block for every candidate pair (zero blocks for pairs out of range)."""

    def _set_blocks(self, mask):
        super()._set_blocks(np.ones(mask.shape[0], bool))


def crossing(z_gap: float, n: int = 41, angle: float = np.pi / 2) -> Model:
    """Rod A along x; rod B ``z_gap`` (m) above it, crossing at ``angle``; 1 mm edges."""
    s = np.linspace(-0.02, 0.02, n)
    a = np.stack([s, 0 * s, 0 * s], 1)
    b = np.stack([s * np.cos(angle) + 3e-4, s * np.sin(angle), 0 * s + z_gap], 1)
    rods = [RodSpec(a, radius=R, youngs_modulus=1e6, density=1000.0, name="A"),
            RodSpec(b, radius=R, youngs_modulus=1e6, density=1000.0, name="B")]
    return Model(rods)


def dense(n, dofs, blocks):
    J = np.zeros((n, n))
    for k in range(dofs.shape[0]):
        J[np.ix_(dofs[k], dofs[k])] += blocks[k]
    return J


def start(model, settings):
    ci = Contact(model, settings)
    st = initial_state(model)
    ci.begin_step(st, 1e-3)
    return ci, st


@pytest.mark.parametrize("mu", [0.0, 0.4])
def test_same_jacobian_with_fewer_blocks(mu):
    m = crossing(1.8e-3)
    ci, st = start(m, ContactOptions(mu=mu))
    q = st.q.copy()
    q[m.node_dof[m.rod_node_start[1]:]] += 2e-5  # B slides a little: friction is on
    r = np.zeros(m.n_dofs)
    _, blocks = ci.evaluate(q, st.q, 1e-3, r, True)
    dofs = ci.block_dofs()
    assert 0 < dofs.shape[0] < ci.pair_dofs.shape[0]  # near pairs only, not every candidate
    w = 14 if mu > 0.0 else 12  # surface friction (the default) adds the two edge angles
    assert blocks.shape == (dofs.shape[0], w, w)
    # the blocks of every candidate pair, from the kernel with a slot for each
    k = ci.pair_dofs.shape[0]
    every = np.zeros((k, w, w))
    kernel = contact_evaluate_regularized_surface if mu > 0.0 else contact_evaluate_regularized
    kernel(q, st.q, 1e-3, ci.pair_dofs, ci.pair_d, ci.pair_mu, ci.options.delta,
           ci.options.nu, ci.k_c, np.zeros(m.n_dofs), True, every, np.arange(k),
           np.empty(k), np.empty((k, 12)), np.empty((k, 12)), ci.pair_eta, ci.pair_theta, ci.pair_h,
           np.zeros((k, SURFACE_COLUMNS)), np.zeros((0, 3)), np.zeros(0), 0.0, *_pair_memo(0))
    every_dofs = np.concatenate([ci.pair_dofs, ci.pair_theta], axis=1) if mu > 0.0 else ci.pair_dofs
    # every pair left out has a zero block and is beyond the band
    out = ~ci._block_mask
    assert not np.any(every[out])
    band = ci.options.delta + BLOCK_BAND_FRACTION * ci.options.margin
    assert np.all(ci._last.delta[out] >= ci.pair_d[out] + band)
    np.testing.assert_array_equal(dense(m.n_dofs, dofs, blocks), dense(m.n_dofs, every_dofs, every))


def test_pair_coming_into_range_gets_a_block_before_assembly():
    gap = 1.8e-3  # Δ − d: in the list (below delta + margin), beyond delta + band
    m = crossing(2 * R + gap)
    ci, st = start(m, ContactOptions())
    assert ci.pairs.shape[0] > 0
    r = np.zeros(m.n_dofs)
    ci.evaluate(st.q, st.q, 1e-3, r, True)
    assert ci.block_dofs().shape == (0, 12) and not r.any()
    version = ci.pattern_version
    q = st.q.copy()
    q[m.node_dof[m.rod_node_start[1]:] + 2] -= gap - 2e-4  # a Newton iterate in contact (gap 0.2 mm)
    _, blocks = ci.evaluate(q, st.q, 1e-3, r, True)
    assert ci.pattern_version > version and ci.block_dofs().shape[0] > 0
    full = AllBlocks(m, ContactOptions())
    full.begin_step(st, 1e-3)
    r2 = np.zeros(m.n_dofs)
    _, blocks2 = full.evaluate(q, st.q, 1e-3, r2, True)
    np.testing.assert_array_equal(dense(m.n_dofs, ci.block_dofs(), blocks), dense(m.n_dofs, full.block_dofs(), blocks2))
    assert np.any(blocks)
    # back out of range: the blocks stay until the list is rebuilt (no new pattern)
    dofs, version = ci.block_dofs(), ci.pattern_version
    ci.evaluate(st.q, st.q, 1e-3, r, True)
    assert ci.block_dofs() is dofs and ci.pattern_version == version
    # a rebuild starts without blocks
    st.q = st.q.copy()
    st.q[m.node_dof[m.rod_node_start[1]:] + 2] += 5e-3  # B lifted: drift > margin / 2
    ci.begin_step(st, 1e-3)
    assert ci.n_rebuilds == 2 and ci.block_dofs().shape == (0, 12)


def drop(cls, mu):
    """Rod B (41 nodes) dropped across the clamped rod A; 0.12 s at dt = 1 ms."""
    s = np.linspace(-0.02, 0.02, 41)
    xa = np.stack([s, 0 * s, 0 * s], 1)
    xb = np.stack([s * np.cos(1.2) + 3e-4, s * np.sin(1.2), 0 * s + 2 * R + 2.5e-3], 1)
    m = Model([RodSpec(x, radius=R, youngs_modulus=1e6, density=1000.0, name=name)
               for x, name in ((xa, "A"), (xb, "B"))], gravity=(0.0, 0.0, -9.81), damping=0.02)
    bcs = BoundaryConditions(m)
    bcs.clamp("A", rod="A", nodes=list(range(41)))
    ci = cls(m, ContactOptions(mu=mu))
    sim = Simulation(m, bcs, SolverOptions(dt=1e-3), interactions=[ci])
    log = sim.run(0.12, progress=False)
    return sim.state.q.copy(), log, ci


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_trajectory_same_as_with_every_candidate_block(mu):
    q, log, ci = drop(Contact, mu)
    q_ref, log_ref, ci_ref = drop(AllBlocks, mu)
    assert log["n_contacts"].max() >= 1  # B landed on A
    assert ci.block_dofs().shape[0] < ci_ref.block_dofs().shape[0]
    assert list(log["iterations"]) == list(log_ref["iterations"])
    assert np.max(np.abs(q - q_ref)) <= 1e-9 * np.max(np.abs(q_ref))
    np.testing.assert_allclose(log["contact_force_total"], log_ref["contact_force_total"], rtol=1e-6, atol=1e-12)


def test_checkpoint_restores_the_block_set():
    m = crossing(1.8e-3)
    ci, st = start(m, ContactOptions())
    ci.evaluate(st.q, st.q, 1e-3, np.zeros(m.n_dofs), True)
    restored = st.copy()
    restored.memory.interactions["contact"] = copy.deepcopy(ci.memory)  # as read from a checkpoint
    other = Contact(m, ContactOptions())
    other.begin_step(restored, 1e-3)
    np.testing.assert_array_equal(other.block_dofs(), ci.block_dofs())
    assert other.block_dofs().shape[0] > 0
    restored.memory.interactions["contact"] = dataclasses.replace(ci.memory, block_mask=None)  # an older checkpoint:
    other.begin_step(restored, 1e-3)  # blocks come back at the first evaluation
    assert other.block_dofs().shape == (0, 12)
    other.evaluate(st.q, st.q, 1e-3, np.zeros(m.n_dofs), True)
    np.testing.assert_array_equal(other.block_dofs(), ci.block_dofs())
