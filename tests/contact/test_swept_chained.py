"""first_crossing_chained (knotsim.contact.swept): a step's check reuses the distances the check of
the step before computed at its end. Over chains of random steps of many pairs (some crossing) the
results are those of first_crossing bit for bit, and the distances handed on are those computed
afresh; the contact model hands them on only between consecutive steps of one pair list."""

from __future__ import annotations

import numpy as np

from knotsim.contact.distance import edge_edge_distance
from knotsim.contact.swept import first_crossing, first_crossing_chained


def _fresh_start(q, dofs):
    """Distance and closest-point vector of every pair at ``q``, as first_crossing computes them."""
    out = np.empty((dofs.shape[0], 4))
    for k in range(dofs.shape[0]):
        p = q[dofs[k]].copy()
        d, bi, bj, _ = edge_edge_distance(p)
        out[k, 0] = d
        out[k, 1:] = (1 - bi) * p[0:3] + bi * p[3:6] - (1 - bj) * p[6:9] - bj * p[9:12]
    return out


def test_chained_checks_are_the_plain_checks_bitwise():
    rng = np.random.default_rng(7)
    n_nodes = 40
    pairs = [(a, b) for a, b in rng.integers(0, n_nodes - 1, (200, 2)) if abs(a - b) >= 2][:60]
    dofs = np.stack([np.r_[3 * a + np.arange(3), 3 * a + 3 + np.arange(3), 3 * b + np.arange(3),
                           3 * b + 3 + np.arange(3)] for a, b in pairs])
    tol = np.full(60, 1e-5)
    reach = rng.uniform(0.0, 2e-2, 60)
    hits = misses = 0
    for _chain in range(25):
        q = rng.uniform(-5e-2, 5e-2, 3 * n_nodes)
        start = None
        for _step in range(8):
            q_new = q + rng.normal(0.0, 10.0 ** rng.uniform(-6, -2.3), q.size)
            plain = first_crossing(q, q_new, dofs, tol, reach)
            end = np.full((60, 4), np.nan)
            chained = first_crossing_chained(q, q_new, dofs, tol, reach, np.empty((0, 4)) if start is None
                                             else start, end)
            assert np.array(plain).tobytes() == np.array(chained).tobytes()
            if plain[0] >= 0:
                hits += 1
                start = None  # a rejected step hands nothing on
                break
            misses += 1
            assert end.tobytes() == _fresh_start(q_new, dofs).tobytes()
            start, q = end, q_new
    assert hits > 3 and misses > 20


def test_contact_hands_distances_on_only_for_the_same_list_and_start():
    from knotsim.bc import BoundaryConditions
    from knotsim.contact.model import Contact, ContactOptions
    from knotsim.rods import Model, RodSpec
    from knotsim.simulation import Simulation
    from knotsim.solver.stepper import SolverOptions

    s = np.linspace(-0.04, 0.04, 9)
    a = np.stack([s, 0 * s, 0 * s], 1)
    b = np.stack([0 * s + 0.002, s, 0 * s + 2.6e-3], 1)
    model = Model([RodSpec(a, radius=1e-3, youngs_modulus=1e6, density=1000.0),
                   RodSpec(b, radius=1e-3, youngs_modulus=1e6, density=1000.0)])
    bcs = BoundaryConditions(model)
    bcs.clamp("a", rod=0, nodes=[0, 1])
    bcs.clamp("a2", rod=0, nodes=[-2, -1])
    bcs.move("b", rod=1, nodes=[3, 4, 5], path=[0.0, 0.0, -2e-3])
    ci = Contact(model, ContactOptions(mu=0.2))
    sim = Simulation(model, bcs, SolverOptions(dt=2e-3), interactions=[ci])
    used = []
    orig = ci._pass_through_listed

    def spy(q_prev, q):
        last = ci._swept_end
        used.append(last is not None and last[0] is ci.pair_dofs and np.array_equal(last[1], q_prev))
        return orig(q_prev, q)

    ci._pass_through_listed = spy
    sim.run(0.1, progress=False)
    assert ci.n_rebuilds >= 1 and len(used) >= 40
    assert sum(used) >= len(used) - ci.n_rebuilds - 1 and not used[0]
