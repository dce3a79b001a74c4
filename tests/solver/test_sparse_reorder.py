"""SparseSolver: a new pattern reuses the last fresh ordering while the fill stays low."""

import numpy as np
import pytest
import scipy.sparse as sp

from knotsim.solver.linear import REORDER_FILL_FACTOR, SparseSolver


def _chain_with_chords(n_nodes, chords, rng):
    """A block tridiagonal (4x4 node blocks) matrix plus dense 8x8 couplings between node pairs."""
    n = 4 * n_nodes
    rows, cols = [], []
    for i in range(n_nodes):
        for j in (i - 1, i, i + 1):
            if 0 <= j < n_nodes:
                for a in range(4):
                    for b in range(4):
                        rows.append(4 * i + a)
                        cols.append(4 * j + b)
    for i, j in chords:
        for u in (i, j):
            for v in (i, j):
                for a in range(4):
                    for b in range(4):
                        rows.append(4 * u + a)
                        cols.append(4 * v + b)
    vals = rng.normal(size=len(rows))
    A = sp.csc_matrix((vals, (rows, cols)), shape=(n, n))
    A.sum_duplicates()
    A = A + sp.identity(n, format="csc") * (10.0 * n_nodes)  # diagonally dominant: no pivoting needed
    A = A.tocsc()
    A.sort_indices()
    return A


def test_reused_ordering_solves_exactly_and_refreshes_when_fill_grows():
    rng = np.random.default_rng(1)
    solver = SparseSolver(blocks=np.arange(0, 4 * 200 + 1, 4))
    b = rng.normal(size=800)
    A1 = _chain_with_chords(200, [(10, 150), (40, 120)], rng)
    solver.factorize(800, A1.indptr, A1.indices, A1.data, 1)
    assert solver.analyses == 1 and solver.fresh_orderings == 1
    assert np.allclose(A1 @ solver.solve(b), b, rtol=0, atol=1e-9 * np.abs(b).max())
    # one chord more: the old ordering is kept, the solve is exact
    A2 = _chain_with_chords(200, [(10, 150), (40, 120), (60, 90)], rng)
    solver.factorize(800, A2.indptr, A2.indices, A2.data, 2)
    assert solver.analyses == 2 and solver.fresh_orderings == 1
    x = solver.solve(b)
    assert np.abs(A2 @ x - b).max() <= 1e-9 * np.abs(b).max()
    fresh = SparseSolver(blocks=np.arange(0, 4 * 200 + 1, 4))
    fresh.factorize(800, A2.indptr, A2.indices, A2.data, 1)
    assert np.abs(fresh.solve(b) - x).max() <= 1e-10 * np.abs(x).max()
    assert solver._lu.nnz_L <= REORDER_FILL_FACTOR * fresh._lu.nnz_L * 1.5
    # many chords between far nodes: the old ordering fills in too much, a fresh one is computed
    chords = [(int(i), int(j)) for i, j in rng.integers(0, 200, size=(60, 2)) if i != j]
    A3 = _chain_with_chords(200, chords, rng)
    solver.factorize(800, A3.indptr, A3.indices, A3.data, 3)
    assert solver.analyses == 3 and solver.fresh_orderings == 2
    assert np.abs(A3 @ solver.solve(b) - b).max() <= 1e-9 * np.abs(b).max()


def test_statistics_describe_the_factorisation():
    rng = np.random.default_rng(2)
    solver = SparseSolver(blocks=np.arange(0, 4 * 60 + 1, 4))
    assert solver.statistics is None
    A = _chain_with_chords(60, [(5, 50), (20, 40)], rng)
    solver.factorize(240, A.indptr, A.indices, A.data, 1)
    stats = solver.statistics
    lu = solver._lu
    assert stats["unknowns"] == 240 and stats["matrix_nonzeros"] == A.nnz
    assert stats["analyses"] == 1 and stats["fresh_orderings"] == 1
    assert solver.analysis_seconds > 0.0
    # the factor's pattern by a slow structural elimination of the permuted matrix (positive
    # entries and positive updates: nothing cancels), column by column
    P = A[lu.perm][:, lu.perm].toarray()
    work = np.where(P != 0, 1.0, 0.0)
    lower = np.zeros((240, 240), bool)
    for j in range(240):  # right-looking elimination, marking every entry that becomes nonzero
        col = np.flatnonzero(work[j + 1:, j] != 0) + j + 1
        lower[col, j] = True
        row = np.flatnonzero(work[j, j + 1:] != 0) + j + 1
        work[np.ix_(col, row)] += 1.0  # structural update only
    counts = lower.sum(axis=0)
    assert stats["factor_nonzeros"] == int(counts.sum())
    assert stats["multiply_adds"] == int(np.dot(counts, counts))
    assert stats["fill"] == pytest.approx(counts.sum() / ((A.nnz - 240) / 2))
    assert stats["supernodes"] >= 1 and stats["largest_front"] >= counts.max() + 1
