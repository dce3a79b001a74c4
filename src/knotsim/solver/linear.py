"""Linear solvers for Newton's system ``J dq = -r``.

- :class:`BandedSolver`: banded LDL^T (numba) or LAPACK ``dgbsv`` on banded storage (rods without
  contact): measured fastest for a single rod (see ``docs/performance.md``).
- :class:`SparseSolver`: sparse LU for general patterns (contact couplings, closed rods). It uses
  knotsim's fixed-pattern LU when available (ordering and symbolic analysis reused while the
  pattern is unchanged) and falls back to ``scipy.sparse.linalg.splu`` with
  ``permc_spec="MMD_AT_PLUS_A"``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.linalg import lapack
from scipy.sparse.linalg import splu

from knotsim.errors import KnotsimError
from knotsim.solver.banded import ldlt_banded_solve


class LinearSolveError(KnotsimError, ArithmeticError):
    """The Newton matrix could not be factorised (singular or not finite)."""


class BandedSolver:
    """Banded solve: symmetric LDL^T without pivoting (numba) when the matrix is symmetric, with
    LAPACK ``dgbsv`` (partial pivoting) as fallback and for non-symmetric matrices."""

    def __init__(self):
        self.fallbacks = 0

    def solve(self, ab: np.ndarray, kl: int, ku: int, rhs: np.ndarray, symmetric: bool = False) -> np.ndarray:
        """Solve with ``ab`` in ``gbsv`` storage (shape ``(2 kl + ku + 1, n)``, preferably
        Fortran-ordered); ``ab`` is left unchanged."""
        if symmetric and kl == ku:
            x = np.empty_like(rhs)
            if ldlt_banded_solve(ab, kl + ku, kl, rhs, x):
                return x
            self.fallbacks += 1
        lu, piv, x, info = lapack.dgbsv(kl, ku, np.array(ab, order="F"), rhs, overwrite_ab=1, overwrite_b=0)
        if info != 0:
            raise LinearSolveError(f"banded LU failed (LAPACK info={info}): singular Newton matrix")
        return x


class SparseSolver:
    def __init__(self, method: str = "auto", blocks=None):
        """``blocks``: starts of the node blocks of unknowns (``model.node_dof``) for the ordering."""
        if method not in ("auto", "splu", "fixed_lu"):
            raise ValueError(f"unknown sparse method {method!r}")
        self.method = method
        self.blocks = blocks
        self.fallbacks = 0
        self._lu = None
        self._key = None

    def solve(self, n: int, indptr: np.ndarray, indices: np.ndarray, data: np.ndarray,
              rhs: np.ndarray, pattern_id: int) -> np.ndarray:
        if not np.all(np.isfinite(data)):
            raise LinearSolveError("Newton matrix has NaN or infinite entries")
        if self.method in ("auto", "fixed_lu"):
            try:
                from knotsim.solver.sparse_lu import FixedPatternLU, ZeroPivotError
            except ImportError:  # pragma: no cover
                FixedPatternLU = None
            if FixedPatternLU is not None:
                if self._key != pattern_id or self._lu is None:
                    blocks = list(self.blocks) if self.blocks is not None else 4
                    self._lu = FixedPatternLU(n, indptr, indices, blocks=blocks, recycle=self._lu)
                    self._key = pattern_id
                try:
                    self._lu.factorize(data)
                    return self._lu.solve(rhs)
                except ZeroPivotError:
                    self.fallbacks += 1
        A = sp.csc_matrix((data, indices, indptr), shape=(n, n))
        try:
            return splu(A, permc_spec="MMD_AT_PLUS_A").solve(rhs)
        except RuntimeError as exc:
            raise LinearSolveError(f"sparse LU failed: {exc}") from exc
