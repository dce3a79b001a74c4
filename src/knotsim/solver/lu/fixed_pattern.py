"""The fixed-pattern sparse LU object: analyse once per pattern, factorise many value sets.

:class:`FixedPatternLU` runs the symbolic analysis (:mod:`knotsim.solver.lu.ordering`,
:mod:`knotsim.solver.lu.symbolic`) in its constructor and the numba multifrontal kernels
(:mod:`knotsim.solver.lu.numeric`) in :meth:`FixedPatternLU.factorize` and
:meth:`FixedPatternLU.solve`. :class:`ZeroPivotError` tells the caller to fall back to a
pivoting LU.
"""

from __future__ import annotations

import numpy as np

from knotsim.solver.lu.numeric import mf_factorize, mf_solve, padded_plan
from knotsim.solver.lu.symbolic import (
    assembly_map,
    check_csc_pattern,
    etree,
    l_pattern,
    ordered_pattern,
    postorder,
    supernodes,
    upper_pattern,
)

__all__ = ["FixedPatternLU", "ZeroPivotError"]


class ZeroPivotError(ArithmeticError):
    """A pivot of the no-pivoting LU was zero, tiny relative to its column, or not finite.

    Attributes
    ----------
    column:
        Index of the offending column in the *original* numbering of the matrix.
    pivot:
        The value of the pivot that was rejected.
    """

    def __init__(self, column: int, pivot: float, message: str):
        self.column = column
        self.pivot = pivot
        super().__init__(message)

    @classmethod
    def rejected(cls, column: int, pivot: float, column_max: float, tol: float) -> ZeroPivotError:
        """The error for ``pivot`` of original ``column`` whose ``max_i |A[i, j]|`` is ``column_max``."""
        return cls(
            column,
            pivot,
            f"LU without pivoting: pivot {pivot:.3e} of column {column} is tiny relative to the column "
            f"max {column_max:.3e} (tol {tol:.1e}); fall back to a pivoting LU",
        )


class FixedPatternLU:
    """LU factorisation ``P A P^T = L U`` reused for many matrices with one sparsity pattern.

    Multifrontal LU without pivoting: relaxed supernodes, dense frontal matrices.

    Parameters
    ----------
    n:
        Size of the square matrix ``A`` (``n >= 1``).
    indptr, indices:
        CSC pattern of ``A``: ``(n+1,)`` and ``(nnz,)`` integer arrays (duplicates allowed, they are
        summed; rows need not be sorted). Values passed to :meth:`factorize` follow this order.
    ordering:
        ``"md"`` (default; exact minimum degree on DOF blocks), ``"rcm"`` (reverse Cuthill-McKee
        from ``scipy.sparse.csgraph``), ``"natural"``, or an explicit permutation ``(n,)`` with
        ``perm[new] = old``.
    blocks:
        For ``ordering="md"``: block size (default 4, a rod node's position and its edge's twist)
        or block starts ``(nb+1,)`` (e.g. per rod node, for several rods). ``1`` orders single DOFs.
    nrelax, relax_frac:
        Supernode amalgamation: a chain of columns is merged into one supernode while its width
        is ``<= nrelax`` and explicit zeros are ``<= relax_frac`` of it.
    pivot_tol:
        A pivot ``u_jj`` with ``|u_jj| <= pivot_tol * max_i |A[i, j]|`` raises :class:`ZeroPivotError`.
    recycle:
        A previous :class:`FixedPatternLU` (e.g. for the pattern before the contact set changed)
        whose large float work buffers are taken over when big enough; this avoids fresh memory
        (page faults) at every pattern change. The old object must not be used afterwards.

    Attributes
    ----------
    perm: ``(n,)`` ordering, ``perm[new] = old`` (postordered).
    nnz_L: number of strictly lower nonzeros of ``L`` (``U`` has as many strictly upper ones).
    n_supernodes, max_front: supernode count and largest frontal matrix.
    """

    def __init__(
        self,
        n: int,
        indptr,
        indices,
        *,
        ordering="md",
        blocks=4,
        nrelax: int = 8,
        relax_frac: float = 0.6,
        pivot_tol: float = 1e-13,
        recycle: FixedPatternLU | None = None,
    ):
        n, indptr, indices = check_csc_pattern(n, indptr, indices)
        self.n = n
        self.nnz = int(indptr[n])
        self.indptr = indptr
        self.indices = indices
        self.pivot_tol = float(pivot_tol)
        gp, gi, perm, iperm, up, ui = ordered_pattern(n, indptr, indices, ordering, blocks)
        self._cnorm = np.zeros(n)
        self._y = np.zeros(n)
        parent = etree(n, up, ui)
        post = postorder(n, parent)
        if not np.array_equal(post, np.arange(n)):
            perm = perm[post]
            iperm[perm] = np.arange(n, dtype=np.int64)
            up, ui = upper_pattern(n, gp, gi, perm, iperm)
            parent = etree(n, up, ui)
        self.parent = parent
        self.Lp, self.Li = l_pattern(n, up, ui, parent)
        # the unpadded panel offsets, relative row maps and front offsets feed only the padded plan
        (self._sf, self._rp, self._ri, self._sparent, self._nchild, rel, _poff, max_front, _max_stack,
         max_depth) = supernodes(n, parent, self.Lp, self.Li, int(nrelax), float(relax_frac))
        self._ap, self._asrc, aoff, _colof = assembly_map(n, indptr, indices, iperm, self._sf, self._rp, self._ri)
        (self._ppoff, self._paoff, self._prel, self._rnp, self._runs, pad_front,
         pad_stack) = padded_plan(self._sf, self._rp, self._sparent, self._nchild, rel, self._ap, aoff)
        self.n_supernodes = int(self._sf.size - 1)
        self.max_front = int(max_front)
        old = recycle.__dict__ if isinstance(recycle, FixedPatternLU) else {}

        def buf(name, size):
            b = old.get(name)
            if b is not None and b.size >= size:
                return b
            return np.zeros(max(size, 1))

        self._PL = buf("_PL", int(self._ppoff[-1]))
        self._PU = buf("_PU", int(self._ppoff[-1]))
        self._front = buf("_front", pad_front * pad_front + 16)  # + 16: see mf_factorize
        self._gbuf = buf("_gbuf", max(3 * pad_front * pad_front, 256))
        self._stack = buf("_stack", int(pad_stack))
        self._stk_off = np.zeros(max(max_depth, 1), np.int64)
        self._stk_sn = np.zeros(max(max_depth, 1), np.int64)
        self.perm = perm
        self.iperm = iperm
        self.nnz_L = int(self.Lp[n])
        self.factorized = False

    @classmethod
    def from_matrix(cls, A, **kwargs) -> FixedPatternLU:
        """Analyse the pattern of a scipy sparse matrix ``A`` ``(n, n)`` (converted to CSC).

        Pass values in the same CSC order later (``A.tocsc().data``).
        """
        A = A.tocsc()
        return cls(A.shape[0], A.indptr, A.indices, **kwargs)

    @property
    def factor_multiply_adds(self) -> int:
        """Multiply-adds of one numeric factorisation, ``Σ_j c_j²`` with ``c_j`` the strictly lower
        nonzeros of column ``j`` of ``L`` (each column updates a ``c_j × c_j`` block of the rest; the
        supernodes' padding is not counted)."""
        counts = np.diff(self.Lp).astype(np.int64)
        return int(np.dot(counts, counts))

    def same_pattern(self, indptr, indices) -> bool:
        """True if ``(indptr, indices)`` is exactly the CSC pattern this object was built for."""
        return (
            len(indptr) == self.n + 1
            and np.array_equal(indptr, self.indptr)
            and np.array_equal(np.asarray(indices)[: self.nnz], self.indices)
        )

    def factorize(self, data) -> None:
        """Numeric factorisation for values ``data`` ``(nnz,)`` in the original CSC order.

        Raises :class:`ZeroPivotError` if a pivot is tiny relative to its column or not finite;
        the object then holds no valid factorisation.
        """
        data = np.asarray(data, dtype=np.float64)
        if data.shape[0] < self.nnz:
            raise ValueError(f"data: expected {self.nnz} values, got {data.shape[0]}")
        bad = mf_factorize(
            data,
            self.indptr,
            self.iperm,
            self._sf,
            self._rp,
            self._sparent,
            self._nchild,
            self._ppoff,
            self._ap,
            self._asrc,
            self._paoff,
            self._prel,
            self._rnp,
            self._runs,
            self._PL,
            self._PU,
            self._front,
            self._stack,
            self._stk_off,
            self._stk_sn,
            self._gbuf,
            self._cnorm,
            self.pivot_tol,
        )
        if bad >= 0:
            s = int(np.searchsorted(self._sf, bad, side="right") - 1)
            k = bad - int(self._sf[s])
            w = int(self._sf[s + 1] - self._sf[s])
            mp = int(self._ppoff[s + 1] - self._ppoff[s]) // w  # the panels are (w, mp)
            piv = float(self._PU[int(self._ppoff[s]) + k * (mp + 1)])
            self.factorized = False
            raise ZeroPivotError.rejected(int(self.perm[bad]), piv, self._cnorm[bad], self.pivot_tol)
        self.factorized = True

    def solve(self, rhs, out=None) -> np.ndarray:
        """Solve ``A x = rhs`` with the last factorisation.

        ``rhs`` ``(n,)`` or ``(n, m)``; ``out`` optional output of the same shape (may be ``rhs``
        itself for an in-place solve). Returns ``x`` with the shape of ``rhs``.
        """
        if (out is None and self.factorized and type(rhs) is np.ndarray and rhs.dtype == np.float64
                and rhs.shape == (self.n,)):  # the common case, without the general checks
            out = np.empty(self.n)
            mf_solve(self.perm, self._sf, self._rp, self._ri, self._ppoff, self._PL, self._PU, rhs, out, self._y)
            return out
        b, out = self._rhs_and_out(rhs, out)
        factors = (self.perm, self._sf, self._rp, self._ri, self._ppoff, self._PL, self._PU)
        if b.ndim == 1:
            mf_solve(*factors, b, out, self._y)
        else:
            col_in = np.empty(self.n)
            col_out = np.empty(self.n)
            for c in range(b.shape[1]):
                col_in[:] = b[:, c]
                mf_solve(*factors, col_in, col_out, self._y)
                out[:, c] = col_out
        return out

    def _rhs_and_out(self, rhs, out) -> tuple[np.ndarray, np.ndarray]:
        """Checked float64 ``rhs`` ``(n,)`` or ``(n, m)`` and the output array (new if ``out`` is None)."""
        if not self.factorized:
            raise RuntimeError("solve: no valid factorisation (call factorize first)")
        b = np.asarray(rhs, dtype=np.float64)
        if b.shape[0] != self.n:
            raise ValueError(f"rhs: expected {self.n} rows, got {b.shape[0]}")
        if out is None:
            out = np.empty_like(b)
        return b, out

    def factorize_solve(self, data, rhs, out=None) -> np.ndarray:
        """:meth:`factorize` with ``data`` ``(nnz,)`` then :meth:`solve` ``rhs`` ``(n,)`` or ``(n, m)``."""
        self.factorize(data)
        return self.solve(rhs, out)
