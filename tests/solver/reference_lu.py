"""Reference up-looking LU (scalar, no dense blocks) for the tests of knotsim.solver.lu.

This is the second factorisation variant the fixed-pattern LU once offered
(``method="uplooking"``); the production code uses only the multifrontal
:class:`knotsim.solver.lu.FixedPatternLU`. It shares the ordering and the permuted pattern with
it (:func:`knotsim.solver.lu.symbolic.ordered_pattern`) but not the postorder, the supernodes nor
the numeric kernels, so the tests compare two independent factorisations of the same matrices.
``benchmarks/bench_linear_solvers.py`` times it as ``fplu_up``.

For row ``j`` of ``P A P^T`` the up-looking LU solves with the rows ``k < j`` of its pattern (in a
topological order of the elimination tree) to get ``L[j, :j]``, ``U[:j, j]`` and the pivot
``U[j, j]``; ``L`` is unit lower, ``U`` upper, no pivoting.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from knotsim.solver.lu import FixedPatternLU, ZeroPivotError
from knotsim.solver.lu.symbolic import check_csc_pattern, etree, l_counts, ordered_pattern

__all__ = ["UpLookingLU"]


@njit(cache=True)
def column_max_abs(data, colof, cnorm):
    """``cnorm[j] = max |data[p]|`` over the entries ``p`` with permuted column ``colof[p] == j``.

    ``data`` ``(nnz,)`` values, ``colof`` ``(nnz,)`` permuted column of each value, ``cnorm``
    ``(n,)`` output (0 for an empty column; NaN values are skipped by the comparison).
    """
    for j in range(cnorm.shape[0]):
        cnorm[j] = 0.0
    for p in range(data.shape[0]):
        a = abs(data[p])
        c = colof[p]
        if a > cnorm[c]:
            cnorm[c] = a


@njit(cache=True)
def _symbolic(n, up, ui):
    """Elimination tree and pattern of ``L`` for the symmetric pattern given by its upper part.

    Parameters: ``up`` ``(n+1,)``, ``ui``: strictly upper pattern by columns (= lower by rows).
    Returns ``(parent, Lp, Li, Rp, Rk, Rpos)``:

    * ``parent`` ``(n,)``: elimination tree (``-1`` for roots);
    * ``Lp`` ``(n+1,)``, ``Li`` ``(nnz_L,)``: pattern of strictly lower ``L`` by columns, rows ascending;
    * ``Rp`` ``(n+1,)``, ``Rk`` ``(nnz_L,)``, ``Rpos`` ``(nnz_L,)``: for each row ``j``, the columns
      ``k < j`` of its nonzeros in a topological order of the elimination tree, and the position of
      ``L[j, k]`` in ``Li``.
    """
    parent = etree(n, up, ui)
    Lp, rowcnt = l_counts(n, up, ui, parent)
    Rp = np.zeros(n + 1, np.int64)
    for k in range(n):
        Rp[k + 1] = Rp[k] + rowcnt[k]
    mark = np.full(n, -1, np.int64)
    nnz = Lp[n]
    Li = np.empty(nnz, np.int64)
    Rk = np.empty(nnz, np.int64)
    Rpos = np.empty(nnz, np.int64)
    fill = Lp[:n].copy()
    stack = np.empty(n, np.int64)
    for k in range(n):
        mark[k] = k
        top = Rp[k + 1]
        for p in range(up[k], up[k + 1]):
            i = ui[p]
            ln = 0
            while mark[i] != k:
                mark[i] = k
                stack[ln] = i
                ln += 1
                i = parent[i]
            while ln > 0:
                ln -= 1
                top -= 1
                Rk[top] = stack[ln]
        # rows of L[k, :] (in topological order): append k to each column
        for q in range(Rp[k], Rp[k + 1]):
            c = Rk[q]
            pos = fill[c]
            fill[c] += 1
            Li[pos] = k
            Rpos[q] = pos
    return parent, Lp, Li, Rp, Rk, Rpos


@njit(cache=True)
def _scatter_map(n, indptr, indices, iperm):
    """Map the caller's CSC entries to the up-looking input order.

    For permuted column ``j``: entries with new row ``<= j`` (upper part incl. diagonal) are listed
    in ``(cp, cr, cs)`` (row, source index); for permuted row ``j``: entries with new column ``< j``
    in ``(rp, rc, rs)``. Also returns ``colof`` ``(nnz,)``: permuted column of each entry.
    """
    nnz = indptr[n]
    cc = np.zeros(n + 1, np.int64)
    rc_ = np.zeros(n + 1, np.int64)
    colof = np.empty(nnz, np.int64)
    for c in range(n):
        nc = iperm[c]
        for p in range(indptr[c], indptr[c + 1]):
            nr = iperm[indices[p]]
            colof[p] = nc
            if nr <= nc:
                cc[nc + 1] += 1
            else:
                rc_[nr + 1] += 1
    for j in range(n):
        cc[j + 1] += cc[j]
        rc_[j + 1] += rc_[j]
    cr = np.empty(cc[n], np.int64)
    cs = np.empty(cc[n], np.int64)
    rcol = np.empty(rc_[n], np.int64)
    rs = np.empty(rc_[n], np.int64)
    fc = cc[:n].copy()
    fr = rc_[:n].copy()
    for c in range(n):
        nc = iperm[c]
        for p in range(indptr[c], indptr[c + 1]):
            nr = iperm[indices[p]]
            if nr <= nc:
                q = fc[nc]
                fc[nc] += 1
                cr[q] = nr
                cs[q] = p
            else:
                q = fr[nr]
                fr[nr] += 1
                rcol[q] = nc
                rs[q] = p
    return cc, cr, cs, rc_, rcol, rs, colof


@njit(cache=True, error_model="numpy")
def _factorize(n, data, cp, cr, cs, rp, rcol, rs, colof, Lp, Li, Rp, Rk, Rpos, Lx, Ux, Ud, work, cnorm, tol):
    """Up-looking LU ``P A P^T = L U`` without pivoting, in place in ``Lx``, ``Ux``, ``Ud``.

    ``work`` ``(n, 2)`` must be zero on entry and is zero on return; ``cnorm`` ``(n,)`` scratch.
    Returns ``-1`` on success, else the permuted index of the first bad pivot.
    """
    column_max_abs(data, colof, cnorm)
    for j in range(n):
        # scatter column j (rows <= j) into work[:, 0] and row j (cols < j) into work[:, 1]
        for p in range(cp[j], cp[j + 1]):
            work[cr[p], 0] += data[cs[p]]
        for p in range(rp[j], rp[j + 1]):
            work[rcol[p], 1] += data[rs[p]]
        d = work[j, 0]
        work[j, 0] = 0.0
        for q in range(Rp[j], Rp[j + 1]):
            k = Rk[q]
            pos = Rpos[q]
            ukj = work[k, 0]
            ljk = work[k, 1] / Ud[k]
            work[k, 0] = 0.0
            work[k, 1] = 0.0
            for p in range(Lp[k], pos):
                i = Li[p]
                work[i, 0] -= Lx[p] * ukj
                work[i, 1] -= Ux[p] * ljk
            Ux[pos] = ukj
            Lx[pos] = ljk
            d -= ljk * ukj
        Ud[j] = d
        if not (abs(d) > tol * cnorm[j]) or not np.isfinite(d):
            # clean the work array before bailing out
            for jj in range(n):
                work[jj, 0] = 0.0
                work[jj, 1] = 0.0
            return j
    return -1


@njit(cache=True, error_model="numpy")
def _solve(n, perm, Lp, Li, Lx, Ux, Ud, b, x, y):
    """Solve ``A x = b`` from ``P A P^T = L U``. ``b``, ``x`` ``(n,)``; ``y`` ``(n,)`` scratch.

    ``x`` may alias ``b``.
    """
    for j in range(n):
        y[j] = b[perm[j]]
    for j in range(n):
        yj = y[j]
        if yj != 0.0:
            for p in range(Lp[j], Lp[j + 1]):
                y[Li[p]] -= Lx[p] * yj
    for j in range(n - 1, -1, -1):
        s = y[j]
        for p in range(Lp[j], Lp[j + 1]):
            s -= Ux[p] * y[Li[p]]
        y[j] = s / Ud[j]
    for j in range(n):
        x[perm[j]] = y[j]


@njit(cache=True, error_model="numpy")
def _solve_multi(n, perm, Lp, Li, Lx, Ux, Ud, B, X, Y):
    """Solve ``A X = B`` for ``B`` ``(n, m)``; ``X`` ``(n, m)`` output, ``Y`` ``(n, m)`` scratch."""
    m = B.shape[1]
    for j in range(n):
        for c in range(m):
            Y[j, c] = B[perm[j], c]
    for j in range(n):
        for p in range(Lp[j], Lp[j + 1]):
            i = Li[p]
            lx = Lx[p]
            for c in range(m):
                Y[i, c] -= lx * Y[j, c]
    for j in range(n - 1, -1, -1):
        for p in range(Lp[j], Lp[j + 1]):
            i = Li[p]
            ux = Ux[p]
            for c in range(m):
                Y[j, c] -= ux * Y[i, c]
        for c in range(m):
            Y[j, c] /= Ud[j]
    for j in range(n):
        for c in range(m):
            X[perm[j], c] = Y[j, c]


class UpLookingLU:
    """Up-looking LU ``P A P^T = L U`` without pivoting, for one CSC pattern and many value sets.

    Same interface as :class:`knotsim.solver.lu.FixedPatternLU` for ``n``, ``indptr``,
    ``indices``, ``ordering``, ``blocks`` and ``pivot_tol`` (no supernodes, no buffer recycling);
    ``perm`` is the ordering itself (not postordered).
    """

    def __init__(self, n: int, indptr, indices, *, ordering="md", blocks=4, pivot_tol: float = 1e-13):
        n, indptr, indices = check_csc_pattern(n, indptr, indices)
        self.n = n
        self.nnz = int(indptr[n])
        self.pivot_tol = float(pivot_tol)
        _, _, perm, iperm, up, ui = ordered_pattern(n, indptr, indices, ordering, blocks)
        self._cnorm = np.zeros(n)
        self._y = np.zeros(n)
        self.parent, self.Lp, self.Li, self.Rp, self.Rk, self.Rpos = _symbolic(n, up, ui)
        self._scatter = _scatter_map(n, indptr, indices, iperm)
        self.Lx = np.zeros(int(self.Lp[n]))
        self.Ux = np.zeros(int(self.Lp[n]))
        self.Ud = np.zeros(n)
        self._work = np.zeros((n, 2))
        self.perm = perm
        self.iperm = iperm
        self.nnz_L = int(self.Lp[n])
        self.factorized = False

    # the same pattern intake, right-hand-side checks and factorize-then-solve as the production LU
    from_matrix = FixedPatternLU.__dict__["from_matrix"]
    _rhs_and_out = FixedPatternLU._rhs_and_out
    factorize_solve = FixedPatternLU.factorize_solve

    def factorize(self, data) -> None:
        """Numeric factorisation for values ``data`` ``(nnz,)``; :class:`ZeroPivotError` on a bad pivot."""
        data = np.asarray(data, dtype=np.float64)
        if data.shape[0] < self.nnz:
            raise ValueError(f"data: expected {self.nnz} values, got {data.shape[0]}")
        cp, cr, cs, rp, rcol, rs, colof = self._scatter
        bad = _factorize(
            self.n,
            data,
            cp,
            cr,
            cs,
            rp,
            rcol,
            rs,
            colof,
            self.Lp,
            self.Li,
            self.Rp,
            self.Rk,
            self.Rpos,
            self.Lx,
            self.Ux,
            self.Ud,
            self._work,
            self._cnorm,
            self.pivot_tol,
        )
        if bad >= 0:
            self.factorized = False
            raise ZeroPivotError.rejected(
                int(self.perm[bad]), float(self.Ud[bad]), self._cnorm[bad], self.pivot_tol
            )
        self.factorized = True

    def solve(self, rhs, out=None) -> np.ndarray:
        """Solve ``A x = rhs`` (``(n,)`` or ``(n, m)``) with the last factorisation; ``out`` may be ``rhs``."""
        b, out = self._rhs_and_out(rhs, out)
        if b.ndim == 1:
            _solve(self.n, self.perm, self.Lp, self.Li, self.Lx, self.Ux, self.Ud, b, out, self._y)
        else:
            _solve_multi(
                self.n, self.perm, self.Lp, self.Li, self.Lx, self.Ux, self.Ud, b, out, np.empty_like(b)
            )
        return out
