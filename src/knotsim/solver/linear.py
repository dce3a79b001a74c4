"""Linear solvers for Newton's system ``J dq = -r``.

- :class:`BandedSolver`: banded LDL^T (numba) or LAPACK ``dgbsv`` on banded storage (rods without
  contact): measured fastest for a single rod (see ``docs/performance.md``).
- :class:`SparseSolver`: sparse LU for general patterns (contact couplings, closed rods). It uses
  knotsim's fixed-pattern LU when available (ordering and symbolic analysis reused while the
  pattern is unchanged) and falls back to ``scipy.sparse.linalg.splu`` with
  ``permc_spec="MMD_AT_PLUS_A"``.
"""

from __future__ import annotations

import time

import numpy as np

from knotsim.errors import KnotsimError
from knotsim.solver._kernels import all_finite
from knotsim.solver.banded import ldlt_banded_factor, ldlt_banded_substitute
from knotsim.solver.lu import FixedPatternLU, ZeroPivotError


class LinearSolveError(KnotsimError, ArithmeticError):
    """The Newton matrix could not be factorised (singular or not finite)."""


class BandedSolver:
    """Banded solve: symmetric LDL^T without pivoting (numba) when the matrix is symmetric, with
    LAPACK ``dgbsv``-style LU (partial pivoting) as fallback and for non-symmetric matrices.
    :meth:`factorize` once, then :meth:`solve` any number of right-hand sides."""

    def __init__(self):
        self.fallbacks = 0
        self._factors = None

    def factorize(self, ab: np.ndarray, kl: int, ku: int, symmetric: bool = False) -> None:
        """Factorise ``ab`` in ``gbsv`` storage (shape ``(2 kl + ku + 1, n)``, preferably
        Fortran-ordered); ``ab`` is left unchanged."""
        n = ab.shape[1]
        if symmetric and kl == ku:
            w = np.empty((n, kl + 1))
            d = np.empty(n)
            if ldlt_banded_factor(ab, kl + ku, kl, w, d):
                self._factors = ("ldlt", w, d, kl)
                return
            self.fallbacks += 1
        from scipy.linalg import lapack  # loaded only when this fallback is used

        lu, piv, info = lapack.dgbtrf(np.array(ab, order="F"), kl, ku)
        if info != 0:
            raise LinearSolveError(f"banded LU failed (LAPACK info={info}): singular Newton matrix")
        self._factors = ("lu", lu, piv, kl, ku)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        f = self._factors
        if f[0] == "ldlt":
            x = np.empty_like(rhs)
            ldlt_banded_substitute(f[1], f[2], f[3], rhs, x)
            return x
        from scipy.linalg import lapack

        x, info = lapack.dgbtrs(f[1], f[3], f[4], rhs, f[2])
        return x


#: A new sparsity pattern is analysed with the ordering of the last fresh minimum-degree analysis
#: as long as its fill stays within this factor of that analysis' fill (scaled by the number of
#: nonzeros of the matrix); beyond it the ordering is computed afresh.
REORDER_FILL_FACTOR = 1.2


class SparseSolver:
    """Sparse LU of Newton's matrix: knotsim's fixed-pattern LU (``FixedPatternLU``), analysed once
    per sparsity pattern, with ``scipy.sparse.linalg.splu`` as the pivoting fallback.

    Pattern changes (contact pairs coming into range) reuse the fill-reducing ordering of the last
    fresh analysis while the fill stays within ``REORDER_FILL_FACTOR`` of it: the minimum-degree
    ordering is the costliest part of an analysis (48 ms of 90 ms for 24k unknowns), and a pattern
    that gained or lost a few blocks is ordered almost as well by it. The factorisation is exact for
    any ordering (only round-off differs)."""

    def __init__(self, method: str = "auto", blocks=None):
        """``blocks``: starts of the node blocks of unknowns (``model.node_dof``) for the ordering."""
        if method not in ("auto", "splu", "fixed_lu"):
            raise ValueError(f"unknown sparse method {method!r}")
        self.method = method
        self.blocks = blocks
        self.fallbacks = 0
        #: symbolic analyses done, and how many of them computed a fresh ordering
        self.analyses = 0
        self.fresh_orderings = 0
        #: wall seconds spent in the analyses (ordering and symbolic factorisation)
        self.analysis_seconds = 0.0
        self._lu = None
        self._key = None
        self._splu = None
        self._order = None  # (perm, nnz_L, nnz_A) of the last fresh ordering

    def _analyse(self, n: int, indptr: np.ndarray, indices: np.ndarray):
        blocks = list(self.blocks) if self.blocks is not None else 4
        self.analyses += 1
        nnz = int(indptr[n])
        if self._order is not None and self._order[0].shape[0] == n:
            perm, fill, nnz0 = self._order
            lu = FixedPatternLU(n, indptr, indices, ordering=perm, recycle=self._lu)
            if lu.nnz_L <= REORDER_FILL_FACTOR * fill * max(nnz / nnz0, 1.0):
                return lu
            self._lu = lu
        lu = FixedPatternLU(n, indptr, indices, blocks=blocks, recycle=self._lu)
        self.fresh_orderings += 1
        self._order = (lu.perm.copy(), lu.nnz_L, nnz)
        return lu

    def factorize(self, n: int, indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, pattern_id: int) -> None:
        if not all_finite(data):
            raise LinearSolveError("Newton matrix has NaN or infinite entries")
        self._splu = None
        if self.method in ("auto", "fixed_lu"):
            if self._key != pattern_id or self._lu is None:
                t0 = time.perf_counter()
                self._lu = self._analyse(n, indptr, indices)
                self.analysis_seconds += time.perf_counter() - t0
                self._key = pattern_id
            try:
                self._lu.factorize(data)
                return
            except ZeroPivotError:
                self.fallbacks += 1
        import scipy.sparse as sp  # the pivoting fallback only: scipy is not loaded by a run otherwise
        from scipy.sparse.linalg import splu

        A = sp.csc_matrix((data, indices, indptr), shape=(n, n))
        try:
            self._splu = splu(A, permc_spec="MMD_AT_PLUS_A")
        except RuntimeError as exc:
            raise LinearSolveError(f"sparse LU failed: {exc}") from exc

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        if self._splu is not None:
            return self._splu.solve(rhs)
        return self._lu.solve(rhs)

    @property
    def statistics(self) -> dict | None:
        """The factorisation of the last pattern analysed: ``unknowns``, ``matrix_nonzeros``,
        ``factor_nonzeros`` (strictly lower nonzeros of ``L``; ``U`` has as many), ``fill`` (their
        ratio to the matrix's strictly lower nonzeros), ``multiply_adds`` of one factorisation,
        ``supernodes`` and ``largest_front``, and over the solver's life the pattern ``analyses`` and
        the ``fresh_orderings`` among them; ``None`` before the first (or with the pivoting fallback
        only)."""
        lu = self._lu
        if lu is None:
            return None
        lower = (lu.nnz - lu.n) / 2
        return {"unknowns": lu.n, "matrix_nonzeros": lu.nnz, "factor_nonzeros": int(lu.nnz_L),
                "fill": float(lu.nnz_L / lower) if lower > 0 else float("nan"),
                "multiply_adds": lu.factor_multiply_adds, "supernodes": lu.n_supernodes,
                "largest_front": lu.max_front, "analyses": self.analyses, "fresh_orderings": self.fresh_orderings}

    @property
    def ordering_memory(self) -> tuple[np.ndarray, int, int] | None:
        """The ordering the next new pattern starts from (it decides the round-off of every later
        factorisation): ``(perm (n,), its nnz(L), the nnz of the matrix it was computed for)`` of
        the last fresh analysis, or None before the first."""
        return self._order

    def restore_ordering_memory(self, perm: np.ndarray, nnz_l: int, nnz_a: int) -> None:
        """Set what :attr:`ordering_memory` returned (a continued run analyses its patterns as the
        uninterrupted run did); the next factorisation analyses its pattern afresh."""
        self._order = (np.array(perm, np.int64), int(nnz_l), int(nnz_a))
        self._key = None
