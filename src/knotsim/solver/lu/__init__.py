"""Sparse LU with a fixed, structurally symmetric pattern, for the Newton Jacobian.

The Newton Jacobian ``J`` (``n x n``, ``n = 4 * n_nodes - 1`` per open rod) is banded (half-bandwidth
10) plus dense ``12 x 12`` contact blocks far from the band. Its *pattern* changes only when the
contact set changes (every few time steps) while its *values* change at every Newton iteration.
:class:`FixedPatternLU` therefore splits the work in two:

* **analyse** (once per pattern, in the constructor): symmetrise the pattern, compute a
  fill-reducing ordering (:mod:`~knotsim.solver.lu.ordering`: exact minimum degree on the quotient
  graph of DOF blocks, one bit set per block; or reverse Cuthill-McKee, or natural), postorder the
  elimination tree, find the pattern of ``L`` (``U`` has the pattern of ``L^T``), group columns
  into relaxed supernodes and precompute where every value of the caller's CSC array goes
  (:mod:`~knotsim.solver.lu.symbolic`);
* **factorize** (every iteration): multifrontal LU without pivoting, ``P A P^T = L U`` (``L`` unit
  lower, ``U`` upper; :mod:`~knotsim.solver.lu.numeric`). Each supernode assembles a dense frontal
  matrix, eliminates its pivots by blocks, and passes its Schur complement to its parent; large
  Schur complements use BLAS ``dgemm`` (through ``np.dot`` in numba), everything else is scalar
  numba loops on preallocated storage;
* **solve**: forward and backward substitution by supernodes.

No pivoting is done: the Jacobian is dominated by its diagonal (mass / dt^2 plus stiffness). If a
pivot ``|u_jj|`` is tiny relative to the largest entry of column ``j`` of ``A`` (or not finite),
:class:`ZeroPivotError` is raised so that the caller can fall back to ``scipy.sparse.linalg.splu``.

Typical use in a Newton loop::

    lu = FixedPatternLU(n, J.indptr, J.indices)      # when the contact set (pattern) changes
    try:
        dq = lu.factorize_solve(J.data, -f)          # every iteration
    except ZeroPivotError:
        dq = scipy.sparse.linalg.splu(J).solve(-f)
"""

from knotsim.solver.lu.fixed_pattern import FixedPatternLU, ZeroPivotError
from knotsim.solver.lu.ordering import minimum_degree_order

__all__ = ["FixedPatternLU", "ZeroPivotError", "minimum_degree_order"]
