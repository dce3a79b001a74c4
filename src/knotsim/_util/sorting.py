"""Sorting and selection kernels shared by the broad phases and the crossing sweep.

numba compiles its own ``np.argsort`` / ``np.median`` into each caller (a quicksort or a quickselect
with several helper functions): about 1.4 s of first-run compile time each, per element type. These
loops do the same work and compile in a fraction of that, once for every caller (``cache=True``).

- :func:`argsort_stable` ``(n,)`` -> ``(n,)`` int64: a stable argsort (bottom-up merge sort,
  ``O(n log n)``); equal keys keep their input order.
- :func:`median` ``(n,)`` -> float: the median, as ``np.median`` (mean of the two middle values
  for even ``n``; quickselect on a copy, ``O(n)`` expected); ``nan`` for an empty array.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["argsort_stable", "median"]


@njit(cache=True)
def argsort_stable(values):
    """Indices ``(n,)`` int64 that sort ``values (n,)`` ascending; ties keep their input order."""
    n = values.shape[0]
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        order[i] = i
    if n < 2:
        return order
    buf = np.empty(n, dtype=np.int64)
    width = 1
    src = order
    dst = buf
    while width < n:
        lo = 0
        while lo < n:
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            i = lo
            j = mid
            k = lo
            while i < mid and j < hi:
                if values[src[j]] < values[src[i]]:  # strict: the left run wins ties (stable)
                    dst[k] = src[j]
                    j += 1
                else:
                    dst[k] = src[i]
                    i += 1
                k += 1
            while i < mid:
                dst[k] = src[i]
                i += 1
                k += 1
            while j < hi:
                dst[k] = src[j]
                j += 1
                k += 1
            lo = hi
        src, dst = dst, src
        width *= 2
    return src


@njit(cache=True)
def _select(work, k):
    """The ``k``-th smallest entry of ``work (n,)`` (reordered in place), by quickselect."""
    lo = 0
    hi = work.shape[0] - 1
    while hi > lo:
        mid = (lo + hi) // 2
        # median of three as pivot
        a = work[lo]
        b = work[mid]
        c = work[hi]
        if a < b:
            pivot = b if b < c else (c if a < c else a)
        else:
            pivot = a if a < c else (c if b < c else b)
        i = lo
        j = hi
        while i <= j:
            while work[i] < pivot:
                i += 1
            while work[j] > pivot:
                j -= 1
            if i <= j:
                t = work[i]
                work[i] = work[j]
                work[j] = t
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return work[k]
    return work[k]


@njit(cache=True)
def median(values):
    """Median of ``values (n,)`` (float); the mean of the two middle values when ``n`` is even."""
    n = values.shape[0]
    if n == 0:
        return np.nan
    work = np.empty(n)
    for i in range(n):
        work[i] = values[i]
    upper = _select(work, n // 2)
    if n % 2 == 1:
        return upper
    return 0.5 * (upper + _select(work, n // 2 - 1))
