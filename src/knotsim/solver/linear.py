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

from knotsim.errors import KnotsimError
from knotsim.solver._kernels import all_finite
from knotsim.solver.banded import ldlt_banded_factor, ldlt_banded_substitute


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
        self._splu = None

    def factorize(self, n: int, indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, pattern_id: int) -> None:
        if not all_finite(data):
            raise LinearSolveError("Newton matrix has NaN or infinite entries")
        self._splu = None
        if self.method in ("auto", "fixed_lu"):
            if self._key != pattern_id or self._lu is None:
                from knotsim.solver.lu import FixedPatternLU

                blocks = list(self.blocks) if self.blocks is not None else 4
                self._lu = FixedPatternLU(n, indptr, indices, blocks=blocks, recycle=self._lu)
                self._key = pattern_id
            try:
                self._lu.factorize(data)
                return
            except ArithmeticError as exc:  # ZeroPivotError: fall back to a pivoting LU
                from knotsim.solver.lu import ZeroPivotError

                if not isinstance(exc, ZeroPivotError):
                    raise
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
