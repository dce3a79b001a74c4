"""Tests of the invariants of knotsim.knots.topology: Kauffman bracket, Reidemeister simplification,
Alexander polynomial, knot table."""

from __future__ import annotations

import itertools

from knotsim.knots import topology as T
from knotsim.knots.topology.alexander import _bareiss_det, _fox_matrices, _minor_poly, _wirtinger
from knotsim.knots.topology.polynomials import _DELTA, _ppow
from knotsim.knots.topology.simplify import _faces
from knotsim.knots.topology.table import _PRIME, _torus_2q

from .curves import (
    circle,
    connected_sum,
    figure_eight,
    hopf,
    trefoil,
)


def brute_force_bracket(pd) -> dict[int, int]:
    """Kauffman bracket by the plain 2^n state sum (reference for small diagrams)."""
    out: dict[int, int] = {}
    n = len(pd)
    for state in itertools.product((0, 1), repeat=n):
        parent: dict[int, int] = {}

        def find(a, parent=parent):
            parent.setdefault(a, a)
            while parent[a] != a:
                a = parent[a]
            return a

        def union(a, b, parent=parent):
            ra, rb = find(a), find(b)
            if ra != rb:
                parent[ra] = rb

        for (a, b, c, d), s in zip(pd, state, strict=True):
            if s == 0:  # A-smoothing
                union(a, b)
                union(c, d)
            else:
                union(a, d)
                union(b, c)
        loops = len({find(x) for x in parent})
        e_a = state.count(0) - state.count(1)
        delta_pow = _ppow(_DELTA, loops - 1)
        for e, c in delta_pow.items():
            out[e + e_a] = out.get(e + e_a, 0) + c
    return {e: c for e, c in out.items() if c}


def test_contraction_bracket_matches_state_sum():
    for curve, seed in ((trefoil(200), 3), (figure_eight(200), 5), (connected_sum(True, False), 1)):
        for s in range(3):
            d = T.project([curve], seed=seed + 17 * s, n_directions=1)
            pd, _, _ = d.pd_code()
            if len(pd) > 12:
                continue
            assert T.kauffman_bracket(pd) == brute_force_bracket(pd)


def test_faces_euler_characteristic():
    d = T.project([figure_eight(200)], seed=2, n_directions=1)
    pd, _, _ = d.pd_code()
    faces = _faces([list(x) for x in pd])
    assert len(faces) == len(pd) + 2  # connected planar 4-valent graph on the sphere


def test_simplify_removes_kinks_and_bigons():
    # a figure-eight-shaped curve: one crossing, R1 leaves a single circle
    pd, signs, free = T.simplify_pd([(0, 0, 1, 1)], [1])
    assert pd == [] and len(signs) == 0 and free == 1
    # the trivial two-crossing diagram of the unlink: circle 1 passes over circle 2 twice (R2)
    c1 = circle(80)
    c2 = circle(80) + [1.0, 0.0, -0.5]
    d = T.project([c1, c2], direction=[0.01, 0.02, 1.0])
    assert d.n_crossings == 2
    pd, signs, free = T.simplify_pd(*d.pd_code())
    assert pd == [] and free == 2
    # a clasp (alternating bigon, the Hopf link) must not be removed
    d = T.project(hopf(True), direction=[0.01, 0.02, 1.0])
    pd, signs, free = T.simplify_pd(*d.pd_code())
    assert len(pd) == 2 and free == 0


# ---------------------------------------------------------------------------------------------


def test_alexander_modular_matches_exact():
    d = T.project([connected_sum(True, False)], seed=4, n_directions=1)
    pd, s, f = d.pd_code()
    n_arcs, rows = _wirtinger(pd, s)
    M0, M1 = _fox_matrices(n_arcs, rows)
    coeffs = _minor_poly(M0, M1)
    for t in (-2, -1, 2, 3):
        exact = _bareiss_det((M0 + t * M1).tolist())
        assert sum(c * t**e for e, c in enumerate(coeffs)) == exact


def test_torus_closed_forms_reproduce_the_table_and_name_9_1():
    table = {rolf: (alex, jones) for rolf, _, alex, jones in _PRIME}
    for q, rolf in ((3, "3_1"), (5, "5_1"), (7, "7_1")):
        alex, jones = _torus_2q(q)
        assert alex == table[rolf][0]
        assert jones == table[rolf][1]
    alex, jones = _torus_2q(9)
    assert alex == [1, -1, 1, -1, 1, -1, 1, -1, 1]
    # Jones polynomial of the positive T(2, 9): t^4 (1 + t^2 - t^3 + t^4 - t^5 + t^6 - t^7 + t^8 - t^9)
    assert jones == {4: 1, 6: 1, 7: -1, 8: 1, 9: -1, 10: 1, 11: -1, 12: 1, 13: -1}
    names = {e.knot_type for e in T.KNOT_TABLE if e.rolfsen == "9_1"}
    assert names == {"9_1_right", "9_1_left"}
