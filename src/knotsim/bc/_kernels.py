"""Numba kernels of the per-step boundary-condition work (:mod:`knotsim.bc.conditions`).

The reaction of a prescribed group is a sum of residual entries (N, or N m for angles). The
kernels add them in exactly the order ``numpy.sum`` (numpy 2) does (``0.0`` plus the pairwise sum
of the entries, :func:`pairwise_sum`), so that the reactions, and the pull forces of every log
written before these kernels, stay bitwise the same.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["numpy_order_sum", "pairwise_sum", "prescribed_reaction"]

#: Block size of numpy's pairwise summation (``PW_BLOCKSIZE`` in numpy's loops).
_PW_BLOCKSIZE = 128


@njit(cache=True)
def _block_sum(a, idx, start, n):
    """numpy's pairwise sum of ``n <= _PW_BLOCKSIZE`` terms ``a[idx[start]], ...`` (no split)."""
    if n < 8:
        res = -0.0
        for i in range(n):
            res += a[idx[start + i]]
        return res
    r0 = a[idx[start]]
    r1 = a[idx[start + 1]]
    r2 = a[idx[start + 2]]
    r3 = a[idx[start + 3]]
    r4 = a[idx[start + 4]]
    r5 = a[idx[start + 5]]
    r6 = a[idx[start + 6]]
    r7 = a[idx[start + 7]]
    i = 8
    stop = n - n % 8
    while i < stop:
        r0 += a[idx[start + i]]
        r1 += a[idx[start + i + 1]]
        r2 += a[idx[start + i + 2]]
        r3 += a[idx[start + i + 3]]
        r4 += a[idx[start + i + 4]]
        r5 += a[idx[start + i + 5]]
        r6 += a[idx[start + i + 6]]
        r7 += a[idx[start + i + 7]]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[idx[start + i]]
        i += 1
    return res


@njit(cache=True)
def pairwise_sum(a, idx, start, n):
    """Sum of ``a[idx[start]], ..., a[idx[start + n - 1]]`` in numpy's pairwise order.

    ``a`` (m,) float64, ``idx`` (k,) int64. Below 8 terms a running sum from ``-0.0``; up to
    ``_PW_BLOCKSIZE`` terms eight running sums combined as a tree, then the rest; above, the sum
    of the two halves (the first a multiple of 8 long), each summed so in turn (the recursion
    runs on an explicit stack: cached numba kernels cannot call themselves).
    """
    if n <= _PW_BLOCKSIZE:
        return _block_sum(a, idx, start, n)
    first = np.empty(64, np.int64)  # a segment's start, length, phase and left half's sum
    length = np.empty(64, np.int64)
    phase = np.zeros(64, np.int64)
    left = np.zeros(64)
    first[0] = start
    length[0] = n
    depth = 1
    res = 0.0
    while depth > 0:
        i = depth - 1
        if length[i] <= _PW_BLOCKSIZE:
            res = _block_sum(a, idx, first[i], length[i])
            depth -= 1
            continue
        n2 = length[i] // 2
        n2 -= n2 % 8
        if phase[i] == 0:  # sum the first half
            phase[i] = 1
            first[depth] = first[i]
            length[depth] = n2
            phase[depth] = 0
            depth += 1
        elif phase[i] == 1:  # first half done (res): sum the second
            left[i] = res
            phase[i] = 2
            first[depth] = first[i] + n2
            length[depth] = length[i] - n2
            phase[depth] = 0
            depth += 1
        else:  # both done
            res = left[i] + res
            depth -= 1
    return res


@njit(cache=True)
def numpy_order_sum(a, idx):
    """``a[idx].sum()`` (``a`` (m,) float64, ``idx`` (k,) int64) added in numpy's order: the
    reduction's identity ``0.0`` plus the pairwise sum of the terms (so ``-0.0`` sums to ``0.0``)."""
    return 0.0 + pairwise_sum(a, idx, 0, idx.shape[0])


@njit(cache=True)
def prescribed_reaction(residual, pos_dofs, axes, theta_dofs, out):
    """Reaction of one prescribed group into ``out`` (4,): the sums of the residual (N) over the
    group's ``x``, ``y``, ``z`` unknowns for the coordinates of ``axes`` (3,) bool (0 for the
    others), and over ``theta_dofs`` (N m; 0 when empty).

    ``residual`` (n_dofs,) float64; ``pos_dofs`` (3, n) int64, row ``c`` the unknowns of coordinate
    ``c`` of the group's ``n`` nodes; ``theta_dofs`` (e,) int64.
    """
    for c in range(3):
        out[c] = numpy_order_sum(residual, pos_dofs[c]) if axes[c] else 0.0
    out[3] = numpy_order_sum(residual, theta_dofs) if theta_dofs.shape[0] else 0.0
