"""Tests of the fixed-pattern sparse LU (knotsim.solver.lu), against scipy and the reference
up-looking LU of ``reference_lu.py``."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse.linalg import spsolve

from knotsim.solver.lu import FixedPatternLU, ZeroPivotError, minimum_degree_order

from .reference_lu import UpLookingLU

RTOL = 1e-10
LU_CLASSES = {"multifrontal": FixedPatternLU, "uplooking": UpLookingLU}
METHODS = list(LU_CLASSES)


def band_chord_matrix(n_nodes: int, n_contacts: int, seed: int, n_rods: int = 1, couplings: int = 0):
    """Rod-like Jacobian(s): stencil band + 12x12 contact blocks (+ couplings between rods).

    Returns (A csc, block_starts) with one block per rod node (4 DOFs, 3 for a rod's last node).
    """
    rng = np.random.default_rng(seed)
    n_rod = 4 * n_nodes - 1
    n = n_rods * n_rod
    rows, cols, vals = [], [], []

    def add(dofs, block):
        r, c = np.meshgrid(dofs, dofs, indexing="ij")
        rows.append(r.ravel())
        cols.append(c.ravel())
        vals.append(block.ravel())

    node_dof = []
    for rod in range(n_rods):
        off = rod * n_rod
        node_dof.extend(off + 4 * k for k in range(n_nodes))
        for i in range(1, n_nodes - 1):
            g = rng.standard_normal((11, 11))
            add(off + np.arange(4 * (i - 1), 4 * (i + 1) + 3), g + g.T)
    node_dof = np.array(node_dof)
    n_edges = n_nodes - 1

    def edge_nodes(e):  # global edge -> (rod-local consecutive) node ids
        rod, k = divmod(e, n_edges)
        return rod * n_nodes + k, rod * n_nodes + k + 1

    for c in range(n_contacts + couplings):
        if c < n_contacts:  # inside one rod (rod chosen at random)
            rod = int(rng.integers(n_rods))
            while True:
                a, b = sorted(int(v) for v in rng.integers(0, n_edges, 2))
                if b - a >= 3:
                    break
            ea, eb = rod * n_edges + a, rod * n_edges + b
        else:  # between two rods
            ra, rb = rng.choice(n_rods, 2, replace=False)
            ea = int(ra) * n_edges + int(rng.integers(n_edges))
            eb = int(rb) * n_edges + int(rng.integers(n_edges))
        nodes = [*edge_nodes(ea), *edge_nodes(eb)]
        dofs = np.concatenate([node_dof[k] + np.arange(3) for k in nodes])
        g = rng.standard_normal((12, 12))
        add(dofs, g + g.T + 0.3 * rng.standard_normal((12, 12)))
    rows.append(np.arange(n))
    cols.append(np.arange(n))
    vals.append(np.full(n, 40.0))
    A = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    A = A.tocsc()
    A.sum_duplicates()
    starts = np.append(node_dof, n)
    return A, starts


def check(A, lu: FixedPatternLU | UpLookingLU, rng, data=None):
    b = rng.standard_normal(A.shape[0])
    x = lu.factorize_solve(A.data if data is None else data, b)
    xr = spsolve(A.tocsc(), b)
    assert np.linalg.norm(x - xr) <= RTOL * np.linalg.norm(xr)
    return x


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize(
    ("n_nodes", "n_contacts", "seed"), [(5, 0, 0), (30, 5, 1), (101, 20, 2), (301, 50, 3)]
)
def test_band_chord_matches_spsolve(method, n_nodes, n_contacts, seed):
    A, _ = band_chord_matrix(n_nodes, n_contacts, seed)
    lu = LU_CLASSES[method].from_matrix(A)
    check(A, lu, np.random.default_rng(seed))
    assert lu.nnz_L >= (A.nnz - A.shape[0]) // 2


@pytest.mark.parametrize("ordering", ["md", "rcm", "natural"])
@pytest.mark.parametrize("blocks", [1, 4, 7])
def test_orderings_and_blocks(ordering, blocks):
    A, _ = band_chord_matrix(40, 8, 11)
    lu = FixedPatternLU.from_matrix(A, ordering=ordering, blocks=blocks)
    check(A, lu, np.random.default_rng(0))
    assert np.array_equal(np.sort(lu.perm), np.arange(A.shape[0]))


def test_explicit_permutation_and_relaxation_options():
    A, _ = band_chord_matrix(40, 8, 12)
    perm = np.random.default_rng(3).permutation(A.shape[0])
    for kwargs in (
        dict(ordering=perm),
        dict(nrelax=1, relax_frac=0.0),
        dict(nrelax=64, relax_frac=0.9),
    ):
        check(A, FixedPatternLU.from_matrix(A, **kwargs), np.random.default_rng(1))


@pytest.mark.parametrize("method", METHODS)
def test_pure_banded(method):
    rng = np.random.default_rng(5)
    n, kl = 203, 10
    diags = [rng.standard_normal(n - abs(k)) for k in range(-kl, kl + 1)]
    A = sp.diags(diags, list(range(-kl, kl + 1)), format="csc") + sp.identity(n, format="csc") * 30.0
    check(A.tocsc(), LU_CLASSES[method].from_matrix(A), rng)


@pytest.mark.parametrize("method", METHODS)
def test_dense_rows_and_columns(method):
    rng = np.random.default_rng(6)
    n = 150
    A = sp.random(n, n, density=0.02, random_state=7, format="lil")
    for r in (3, 77, 140):  # dense rows and a dense column
        A[r, :] = rng.standard_normal(n)
    A[:, 20] = rng.standard_normal((n, 1))
    A = (A.tocsc() + sp.identity(n, format="csc") * 60.0).tocsc()
    check(A, LU_CLASSES[method].from_matrix(A), rng)


@pytest.mark.parametrize("method", METHODS)
def test_several_rods_with_couplings(method):
    A, starts = band_chord_matrix(25, 6, 8, n_rods=3, couplings=10)
    for blocks in (starts, 4):
        check(A, LU_CLASSES[method].from_matrix(A, blocks=blocks), np.random.default_rng(2))


@pytest.mark.parametrize("method", METHODS)
def test_pattern_reuse_with_new_values(method):
    A, _ = band_chord_matrix(60, 12, 9)
    lu = LU_CLASSES[method].from_matrix(A)
    rng = np.random.default_rng(10)
    for _ in range(4):
        B = A.copy()
        B.data = A.data * (1.0 + 0.3 * rng.standard_normal(A.nnz))
        B.data[B.indices == np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))] += 20.0
        check(B, lu, rng, data=B.data)
    if isinstance(lu, FixedPatternLU):
        assert lu.same_pattern(A.indptr, A.indices)
        assert not lu.same_pattern(A.indptr[:-1], A.indices)


def test_recycle_buffers():
    A, _ = band_chord_matrix(60, 12, 13)
    lu0 = FixedPatternLU.from_matrix(A)
    lu0.factorize(A.data)
    B, _ = band_chord_matrix(60, 10, 14)
    lu1 = FixedPatternLU.from_matrix(B, recycle=lu0)
    check(B, lu1, np.random.default_rng(4))


@pytest.mark.parametrize("method", METHODS)
def test_unsymmetric_pattern_and_duplicates(method):
    rng = np.random.default_rng(11)
    n = 60
    rows = np.concatenate([np.arange(n), rng.integers(0, n, 200), rng.integers(0, n, 50)])
    cols = np.concatenate([np.arange(n), rng.integers(0, n, 200), rng.integers(0, n, 50)])
    vals = np.concatenate([np.full(n, 25.0), rng.standard_normal(250)])
    # build CSC by hand keeping duplicates and unsorted rows
    order = np.lexsort((rng.random(rows.size), cols))
    indptr = np.concatenate([[0], np.cumsum(np.bincount(cols, minlength=n))])
    indices, data = rows[order], vals[order]
    A = sp.csc_matrix((data.copy(), indices.copy(), indptr.copy()), shape=(n, n))
    lu = LU_CLASSES[method](n, indptr, indices)
    b = rng.standard_normal(n)
    x = lu.factorize_solve(data, b)
    xr = spsolve(A, b)  # scipy sums duplicates
    assert np.linalg.norm(x - xr) <= RTOL * np.linalg.norm(xr)


@pytest.mark.parametrize("method", METHODS)
def test_multiple_rhs_and_in_place(method):
    A, _ = band_chord_matrix(30, 5, 15)
    lu = LU_CLASSES[method].from_matrix(A)
    lu.factorize(A.data)
    B = np.random.default_rng(0).standard_normal((A.shape[0], 3))
    X = lu.solve(B)
    assert np.allclose(A @ X, B, rtol=0, atol=1e-10 * np.abs(B).max())
    b = B[:, 0].copy()
    x_ref = lu.solve(b)
    out = lu.solve(b, out=b)
    assert out is b and np.allclose(b, x_ref, rtol=1e-14, atol=0)


@pytest.mark.parametrize("method", METHODS)
def test_zero_pivot_error(method):
    A2, _ = band_chord_matrix(20, 3, 16)
    data = A2.data.copy()
    data[A2.indices == 10] = 0.0  # singular: row 10 is numerically zero, pattern unchanged
    lu = LU_CLASSES[method].from_matrix(A2)
    with pytest.raises(ZeroPivotError) as info:
        lu.factorize(data)
    assert isinstance(info.value, ArithmeticError)
    with pytest.raises(RuntimeError):
        lu.solve(np.ones(A2.shape[0]))
    # non-finite values are rejected too; the object recovers with good values
    bad = A2.data.copy()
    bad[0] = np.nan
    with pytest.raises(ZeroPivotError):
        lu.factorize(bad)
    check(A2, lu, np.random.default_rng(1))


@pytest.mark.parametrize("method", METHODS)
def test_exactly_singular_2x2_block(method):
    # [[1, 2], [2, 4]] (+ identity elsewhere): second pivot is exactly 0 in natural order
    A = sp.csc_matrix(np.array([[1.0, 2.0, 0.0], [2.0, 4.0, 0.0], [0.0, 0.0, 3.0]]))
    lu = LU_CLASSES[method].from_matrix(A, ordering="natural")
    with pytest.raises(ZeroPivotError):
        lu.factorize(A.data)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("clique", [2, 8, 11])
def test_rejected_pivot_reports_its_value_and_column(method, clique):
    """The error names the column and the value of the pivot that was rejected: a dense
    ``clique x clique`` block (one front of that width) holding ``[[1, 1], [1, 1 + 2^-50]]`` plus
    the identity, among well-conditioned dense 8 x 8 blocks, in natural order: the second pivot of
    the pair is ``2^-50`` (below ``1e-13`` of its column) whatever the padded layout."""
    blocks = [np.eye(8) * 8.0 + np.random.default_rng(k).standard_normal((8, 8)) for k in range(3)]
    bad = np.eye(clique)
    bad[:2, :2] = [[1.0, 1.0], [1.0, 1.0 + 2.0**-50]]
    n = 24 + clique
    dense = np.zeros((n, n))
    for k, b in enumerate(blocks):
        dense[8 * k : 8 * k + 8, 8 * k : 8 * k + 8] = b
    dense[24:, 24:] = bad
    mask = np.zeros((n, n), bool)
    for k in range(3):
        mask[8 * k : 8 * k + 8, 8 * k : 8 * k + 8] = True
    mask[24:, 24:] = True  # the whole block is in the pattern (explicit zeros included)
    rows, cols = np.nonzero(mask.T)
    A = sp.csc_matrix((dense.T[rows, cols], (cols, rows)), shape=(n, n))
    assert A.nnz == mask.sum()
    lu = LU_CLASSES[method].from_matrix(A, ordering="natural")
    with pytest.raises(ZeroPivotError) as info:
        lu.factorize(A.data)
    assert info.value.column == 25
    assert info.value.pivot == pytest.approx(2.0**-50, rel=1e-6, abs=0.0)


@pytest.mark.parametrize("method", METHODS)
def test_n_equal_one(method):
    lu = LU_CLASSES[method](1, np.array([0, 1]), np.array([0]))
    assert np.allclose(lu.factorize_solve(np.array([4.0]), np.array([2.0])), [0.5])
    with pytest.raises(ZeroPivotError):
        lu.factorize(np.array([0.0]))
    # empty pattern: the (implicit) zero diagonal is a zero pivot
    lu0 = LU_CLASSES[method](1, np.array([0, 0]), np.array([], dtype=np.int64))
    with pytest.raises(ZeroPivotError):
        lu0.factorize(np.array([]))


def test_bad_arguments():
    with pytest.raises(ValueError):
        FixedPatternLU(0, np.array([0]), np.array([]))
    with pytest.raises(ValueError):
        FixedPatternLU(2, np.array([0, 1, 2]), np.array([0, 5]))
    with pytest.raises(ValueError):
        FixedPatternLU(2, np.array([0, 1, 2]), np.array([0, 1]), ordering="bogus")
    with pytest.raises(ValueError):
        FixedPatternLU(2, np.array([0, 1, 2]), np.array([0, 1]), ordering=np.array([0, 0]))


def test_minimum_degree_order_is_permutation_and_reduces_fill():
    A, _ = band_chord_matrix(101, 20, 17)
    perm = minimum_degree_order(A.shape[0], A.indptr, A.indices, blocks=4)
    assert np.array_equal(np.sort(perm), np.arange(A.shape[0]))
    fill_md = FixedPatternLU.from_matrix(A, ordering="md").nnz_L
    fill_rcm = FixedPatternLU.from_matrix(A, ordering="rcm").nnz_L
    assert fill_md < fill_rcm


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 40),
    density=st.floats(0.0, 0.3),
    seed=st.integers(0, 2**31 - 1),
    method=st.sampled_from(METHODS),
    blocks=st.sampled_from([1, 2, 4]),
)
def test_random_patterns_hypothesis(n, density, seed, method, blocks):
    rng = np.random.default_rng(seed)
    A = sp.random(n, n, density=density, random_state=rng, format="csc")
    A = (A + sp.diags(5.0 + n * density + rng.random(n))).tocsc()
    lu = LU_CLASSES[method].from_matrix(A, blocks=blocks)
    check(A, lu, rng)


@pytest.mark.parametrize(
    "w, r", [(1, 3), (3, 5), (4, 1), (6, 7), (8, 1), (8, 7), (8, 15), (8, 25), (13, 9), (16, 40), (32, 40)]
)
def test_front_kernels_match_dense_elimination(w, r):
    """Every path of the front elimination in ``mf_factorize`` (width 8; other widths with their
    loops and BLAS for the largest Schur complements) against a dense elimination, on a dense
    matrix planned as a front of width ``w`` and a root of width ``r``, with zero ``L21`` entries:
    the panels in the padded layout, the update matrix on the stack, and the zero padding the solve
    relies on."""
    from knotsim.solver.lu.numeric import _GEMM_MIN, mf_factorize, padded_plan
    from knotsim.solver.lu.symbolic import assembly_map

    rng = np.random.default_rng(w * 100 + r)
    m = w + r
    A = rng.standard_normal((m, m)) + m * np.eye(m)
    A[w::3, :w] = 0.0
    indptr = np.arange(0, m * m + 1, m, dtype=np.int64)
    indices = np.tile(np.arange(m, dtype=np.int64), m)
    data = A.T.ravel().copy()  # CSC of the dense matrix
    iperm = np.arange(m, dtype=np.int64)
    sf, rp, ri = np.array([0, w, m]), np.array([0, r, r]), np.arange(w, m)
    sparent, nchild, rel = np.array([1, -1]), np.array([0, 1]), np.arange(r)
    ap, asrc, aoff, _ = assembly_map(m, indptr, indices, iperm, sf, rp, ri)
    ppoff, paoff, prel, rnp, runs, mf, ms = padded_plan(sf, rp, sparent, nchild, rel, ap, aoff)
    PL, PU = np.full(ppoff[-1], np.nan), np.full(ppoff[-1], np.nan)
    stack = np.full(ms, np.nan)
    front, gbuf = np.full(mf * mf + 16, np.nan), np.full(max(3 * mf * mf, 256), np.nan)
    cnorm = np.empty(m)
    bad = mf_factorize(data, indptr, iperm, sf, rp, sparent, nchild, ppoff, ap, asrc, paoff, prel, rnp, runs,
                       PL, PU, front, stack, np.zeros(2, np.int64), np.zeros(2, np.int64), gbuf, cnorm, 1e-13)
    assert bad == -1
    assert np.array_equal(cnorm, np.abs(A).max(axis=0))

    def dense_lu(M):
        L, U = np.eye(len(M)), M.copy()
        for k in range(len(M)):
            L[k + 1 :, k] = U[k + 1 :, k] / U[k, k]
            U[k + 1 :, :] -= np.outer(L[k + 1 :, k], U[k, :])
        return L, np.triu(U)

    L11, U11 = dense_lu(A[:w, :w])
    U12 = np.linalg.solve(L11, A[:w, w:])
    L21 = np.linalg.solve(U11.T, A[w:, :w].T).T
    S = A[w:, w:] - L21 @ U12  # the root's front: its entries of A and the update -L21 U12
    wp, rq = (w + 7) // 8 * 8, (r + 15) // 16 * 16
    mp = wp + rq
    P_L, P_U = PL[: w * mp].reshape(w, mp), PU[: w * mp].reshape(w, mp)
    iu = np.triu_indices(w)
    assert np.allclose(P_U[:, :w][iu], U11[iu], rtol=1e-13, atol=1e-13)
    expect = L11.T.copy()
    np.fill_diagonal(expect, 1.0 / np.diag(U11))  # the inverse pivots
    assert np.allclose(P_L[:, :w][iu], expect[iu], rtol=1e-13, atol=1e-13)
    assert np.allclose(P_U[:, wp : wp + r], U12, rtol=1e-13, atol=1e-13)
    assert np.allclose(P_L[:, wp : wp + r], L21.T, rtol=1e-13, atol=1e-13)
    assert np.all(P_U[:, wp + r :] == 0.0)
    S_k = stack[: r * rq].reshape(r, rq)
    assert np.allclose(S_k[:, :r], -L21 @ U12, rtol=1e-13, atol=1e-12)
    assert np.all(S_k[:, r:] == 0.0)
    _, U_S = dense_lu(S)  # the root: the LU of the Schur complement
    assert np.allclose(np.diag(PU[ppoff[1] :].reshape(r, -1)), np.diag(U_S), rtol=1e-12)
    assert (r * r * w >= _GEMM_MIN) == (w == 32)
