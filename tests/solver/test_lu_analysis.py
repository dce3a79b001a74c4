"""Ordering and symbolic analysis of the fixed-pattern LU (knotsim.solver.lu.ordering, .symbolic),
and agreement of the multifrontal LU with the reference up-looking LU."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.solver.lu import FixedPatternLU, minimum_degree_order
from knotsim.solver.lu.ordering import block_starts, fill_reducing_order, symmetric_graph
from knotsim.solver.lu.symbolic import (
    check_csc_pattern,
    etree,
    l_pattern,
    ordered_pattern,
    postorder,
    supernodes,
)

from .reference_lu import UpLookingLU, _symbolic
from .test_lu import band_chord_matrix


def _pattern(A):
    n = A.shape[0]
    return check_csc_pattern(n, A.indptr, A.indices)


@pytest.mark.parametrize("ordering", ["md", "rcm", "natural"])
def test_l_pattern_matches_reference_symbolic(ordering):
    A, _ = band_chord_matrix(40, 8, 21)
    n, indptr, indices = _pattern(A)
    _, _, perm, _, up, ui = ordered_pattern(n, indptr, indices, ordering, 4)
    parent = etree(n, up, ui)
    Lp, Li = l_pattern(n, up, ui, parent)
    ref_parent, ref_Lp, ref_Li, Rp, _, _ = _symbolic(n, up, ui)
    np.testing.assert_array_equal(parent, ref_parent)
    np.testing.assert_array_equal(Lp, ref_Lp)
    np.testing.assert_array_equal(Li, ref_Li)
    assert Rp[n] == Lp[n]  # as many entries by rows as by columns
    assert np.all(parent[parent >= 0] > np.flatnonzero(parent >= 0))  # parents come later


def test_postorder_and_supernodes_cover_all_columns():
    A, _ = band_chord_matrix(30, 6, 22)
    n, indptr, indices = _pattern(A)
    _, _, _, _, up, ui = ordered_pattern(n, indptr, indices, "md", 4)
    parent = etree(n, up, ui)
    post = postorder(n, parent)
    np.testing.assert_array_equal(np.sort(post), np.arange(n))
    lu = FixedPatternLU.from_matrix(A)
    sf = supernodes(n, lu.parent, lu.Lp, lu.Li, 8, 0.6)[0]
    assert sf[0] == 0 and sf[-1] == n and np.all(np.diff(sf) > 0)
    assert sf.size - 1 == lu.n_supernodes


def test_fill_reducing_order_matches_minimum_degree_order():
    A, _ = band_chord_matrix(50, 10, 23)
    n, indptr, indices = _pattern(A)
    gp, gi = symmetric_graph(n, indptr, indices)
    np.testing.assert_array_equal(
        fill_reducing_order(n, gp, gi, "md", 4), minimum_degree_order(n, indptr, indices, blocks=4)
    )
    np.testing.assert_array_equal(fill_reducing_order(n, gp, gi, "natural", 4), np.arange(n))
    with pytest.raises(ValueError, match="ordering"):
        fill_reducing_order(n, gp, gi, "amd", 4)
    with pytest.raises(ValueError, match="permutation"):
        fill_reducing_order(n, gp, gi, np.zeros(n, dtype=np.int64), 4)


def test_block_starts():
    np.testing.assert_array_equal(block_starts(10, 4), [0, 4, 8, 10])
    np.testing.assert_array_equal(block_starts(3, None), [0, 1, 2, 3])
    np.testing.assert_array_equal(block_starts(7, [0, 3, 7]), [0, 3, 7])
    for bad in (0, [0, 3], [0, 5, 3, 7]):
        with pytest.raises(ValueError, match="blocks"):
            block_starts(7, bad)


@pytest.mark.parametrize(("n_nodes", "n_contacts", "seed"), [(20, 3, 24), (120, 30, 25)])
def test_multifrontal_matches_uplooking(n_nodes, n_contacts, seed):
    A, starts = band_chord_matrix(n_nodes, n_contacts, seed)
    b = np.random.default_rng(seed).standard_normal((A.shape[0], 2))
    mf = FixedPatternLU.from_matrix(A, blocks=starts)
    up = UpLookingLU.from_matrix(A, blocks=starts)
    assert mf.nnz_L == up.nnz_L  # postordering does not change the fill
    x_mf = mf.factorize_solve(A.data, b)
    x_up = up.factorize_solve(A.data, b)
    assert np.linalg.norm(x_mf - x_up) <= 1e-12 * np.linalg.norm(x_up)
