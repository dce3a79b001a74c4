"""Symmetric banded LDL^T factorisation without pivoting (numba).

Newton's matrix of rods without contact is symmetric (elastic Hessian + lumped mass/dt^2 +
damping/dt) and banded (half-bandwidth 10 for one rod). LDL^T on the band costs about
``n kl^2 / 2`` multiply-adds, far less than LAPACK's pivoting ``gbsv``. Without pivoting it is stable
for the positive definite systems of small time steps; a pivot that is tiny relative to its diagonal
entry (or not finite) makes :func:`ldlt_banded_solve` return ``False`` so the caller falls back to
``gbsv``.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def ldlt_banded_factor(ab, row0, kl, w, d):
    """Factorise symmetric banded ``A`` (``A[i, j] = ab[row0 + i - j, j]``, half-bandwidth ``kl``;
    only the lower band is read, ``ab`` is not modified) into ``w (n, kl+1)``
    (``w[j, i - j] = L[i, j]``) and ``d (n,)``. Returns ``False`` on a tiny or non-finite pivot."""
    n = d.shape[0]
    for j in range(n):
        for r in range(kl + 1):
            w[j, r] = ab[row0 + r, j] if j + r < n else 0.0
    for j in range(n):
        dj = w[j, 0]
        if not (abs(dj) > 1e-13 * (abs(ab[row0, j]) + 1e-300)) or not np.isfinite(dj):
            return False
        d[j] = dj
        iend = min(n, j + kl + 1)
        inv = 1.0 / dj
        for r in range(1, iend - j):
            w[j, r] *= inv
        # trailing update: A[i, k] -= L[i, j] d_j L[k, j] for j < k <= i < j + kl + 1
        for rk in range(1, iend - j):
            k = j + rk
            lkd = w[j, rk] * dj
            if lkd == 0.0:
                continue
            for ri in range(rk, iend - j):
                w[k, ri - rk] -= w[j, ri] * lkd
    return True


@njit(cache=True)
def ldlt_banded_substitute(w, d, kl, rhs, x):
    """Solve ``L D L^T x = rhs`` with the factors of :func:`ldlt_banded_factor`."""
    n = d.shape[0]
    for i in range(n):
        s = rhs[i]
        for k in range(max(0, i - kl), i):
            s -= w[k, i - k] * x[k]
        x[i] = s
    for i in range(n):
        x[i] /= d[i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, min(n, i + kl + 1)):
            s -= w[i, k - i] * x[k]
        x[i] = s


@njit(cache=True)
def ldlt_banded_solve(ab, row0, kl, rhs, x):
    """Factorise and solve in one call (see :func:`ldlt_banded_factor`). Returns ``True`` on success."""
    n = rhs.shape[0]
    w = np.empty((n, kl + 1))
    d = np.empty(n)
    if not ldlt_banded_factor(ab, row0, kl, w, d):
        return False
    ldlt_banded_substitute(w, d, kl, rhs, x)
    return True
