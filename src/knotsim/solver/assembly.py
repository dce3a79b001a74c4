"""Assembly of Newton's matrix from dense per-stencil blocks (numba kernels).

Two storages:

- *banded* (LAPACK ``gbsv`` layout, ``ab[kl + ku + i - j, j] = A[i, j]``), used when every block lies
  within a narrow band (rods without contact and without closing edges): the fast path;
- *CSC* with a pattern built once per change of the block structure (e.g. of the contact set);
  every block entry gets the index of its slot in ``data`` so refilling values is a scatter.

Constrained unknowns are eliminated by replacing their rows and columns with the identity (the
Newton increment there is zero because prescribed values are set before the solve).
"""

from __future__ import annotations

import numpy as np
from numba import njit

# ---------------------------------------------------------------------------- banded kernels


@njit(cache=True)
def banded_dense_block(ab, row0, kl, ku, idx, out):
    """``out (m, m) = A[idx][:, idx]`` of the banded ``A`` (``A[i, j] = ab[row0 + i - j, j]``,
    ``kl`` sub- and ``ku`` super-diagonals) for the unknowns ``idx (m,)`` (distinct)."""
    m = idx.shape[0]
    for c in range(m):
        j = idx[c]
        for r in range(m):
            d = idx[r] - j
            out[r, c] = ab[row0 + d, j] if -ku <= d <= kl else 0.0


@njit(cache=True)
def banded_add_blocks(ab, row0, dofs, blocks):
    """``A[dofs[b], dofs[b]] += blocks[b]`` in banded storage with ``row0 = kl + ku``."""
    nb, k = dofs.shape
    for b in range(nb):
        for i in range(k):
            gi = dofs[b, i]
            for j in range(k):
                gj = dofs[b, j]
                ab[row0 + gi - gj, gj] += blocks[b, i, j]


@njit(cache=True)
def banded_add_diagonal(ab, row0, diag):
    for i in range(diag.shape[0]):
        ab[row0, i] += diag[i]


@njit(cache=True)
def banded_constrain(ab, row0, kl, ku, fixed):
    """Identity rows/columns for every unknown in ``fixed`` (bool mask)."""
    n = fixed.shape[0]
    for c in range(n):
        if not fixed[c]:
            continue
        # column c
        for i in range(max(0, c - ku), min(n, c + kl + 1)):
            ab[row0 + i - c, c] = 0.0
        # row c
        for j in range(max(0, c - kl), min(n, c + ku + 1)):
            ab[row0 + c - j, j] = 0.0
        ab[row0, c] = 1.0


# ---------------------------------------------------------------------------- CSC kernels


@njit(cache=True)
def _find(indices, lo, hi, row):
    while lo < hi:
        mid = (lo + hi) // 2
        if indices[mid] < row:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def csc_block_map(indptr, indices, dofs):
    """Slot in ``data`` of every entry of every block: ``(nb, k, k)`` int64."""
    nb, k = dofs.shape
    out = np.empty((nb, k, k), np.int64)
    for b in range(nb):
        for j in range(k):
            col = dofs[b, j]
            lo = indptr[col]
            hi = indptr[col + 1]
            for i in range(k):
                out[b, i, j] = _find(indices, lo, hi, dofs[b, i])
    return out


@njit(cache=True)
def csc_diag_map(indptr, indices, n):
    out = np.empty(n, np.int64)
    for c in range(n):
        out[c] = _find(indices, indptr[c], indptr[c + 1], c)
    return out


@njit(cache=True)
def csc_add_blocks(data, slots, blocks):
    nb, k, _ = blocks.shape
    for b in range(nb):
        for i in range(k):
            for j in range(k):
                data[slots[b, i, j]] += blocks[b, i, j]


@njit(cache=True)
def csc_dense_block(data, indptr, indices, idx, loc, out):
    """``out (m, m) = A[idx][:, idx]`` of the CSC matrix ``A`` for the unknowns ``idx (m,)``, with
    ``loc (n,)`` the local number of each unknown in ``idx`` (−1 for the others)."""
    m = idx.shape[0]
    for c in range(m):
        for r in range(m):
            out[r, c] = 0.0
    for c in range(m):
        j = idx[c]
        for s in range(indptr[j], indptr[j + 1]):
            r = loc[indices[s]]
            if r >= 0:
                out[r, c] += data[s]


@njit(cache=True)
def csc_add_diagonal(data, diag_slots, diag):
    for i in range(diag.shape[0]):
        data[diag_slots[i]] += diag[i]


@njit(cache=True)
def csc_fill_elastic(data, diag_slots, diag, stretch_slots, stretch_blocks, bend_slots, bend_blocks):
    """``data = 0``, then the diagonal ``diag (n,)`` and the elastic blocks ``(ne, 6, 6)`` and
    ``(nb, 11, 11)`` added at their slots (one pass; the same sums in the same order as
    :func:`csc_add_diagonal` followed by :func:`csc_add_blocks` twice)."""
    for p in range(data.shape[0]):
        data[p] = 0.0
    csc_add_diagonal(data, diag_slots, diag)
    csc_add_blocks(data, stretch_slots, stretch_blocks)
    csc_add_blocks(data, bend_slots, bend_blocks)


@njit(cache=True)
def csc_constrained_slots(indptr, indices, fixed):
    """Slots of the CSC pattern in a prescribed row or column: ``(zero, one)`` int64 arrays, the
    off-diagonal ones (set to 0 by :func:`csc_set_slots`) and the diagonal ones (set to 1)."""
    n = indptr.shape[0] - 1
    zero = np.empty(indptr[n], np.int64)
    one = np.empty(indptr[n], np.int64)
    nz = 0
    no = 0
    for c in range(n):
        for p in range(indptr[c], indptr[c + 1]):
            r = indices[p]
            if fixed[r] or fixed[c]:
                if r == c:
                    one[no] = p
                    no += 1
                else:
                    zero[nz] = p
                    nz += 1
    return zero[:nz].copy(), one[:no].copy()


@njit(cache=True)
def csc_set_slots(data, zero, one):
    """``data[zero] = 0``, ``data[one] = 1`` (identity rows and columns of prescribed unknowns,
    with the slots of :func:`csc_constrained_slots`)."""
    for t in range(zero.shape[0]):
        data[zero[t]] = 0.0
    for t in range(one.shape[0]):
        data[one[t]] = 1.0


@njit(cache=True)
def csc_constrain(indptr, indices, data, fixed):
    n = indptr.shape[0] - 1
    for c in range(n):
        for p in range(indptr[c], indptr[c + 1]):
            r = indices[p]
            if fixed[r] or fixed[c]:
                data[p] = 1.0 if r == c else 0.0


# ---------------------------------------------------------------------------- pattern


def csc_pattern(n: int, dof_groups: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Sorted CSC structure ``(indptr, indices)`` of the union of all blocks plus the diagonal
    (``dof_groups``: ``(k, m)`` int arrays of block unknowns, any ``m``)."""
    indptr = np.arange(n + 1, dtype=np.int64)
    indices = np.arange(n, dtype=np.int64)
    for dofs in dof_groups:
        if dofs.size:
            indptr, indices, _ = merge_pattern(n, indptr, indices, np.ascontiguousarray(dofs, dtype=np.int64))
    return indptr, indices


def bandwidth(dof_groups: list[np.ndarray]) -> int:
    """Largest ``|i - j|`` over all block entries."""
    bw = 0
    for dofs in dof_groups:
        if dofs.size:
            bw = max(bw, int(np.max(dofs.max(axis=1) - dofs.min(axis=1))))
    return bw


@njit(cache=True)
def merge_pattern(n, indptr_e, indices_e, extra_dofs):
    """Union of a fixed CSC pattern with the blocks ``extra_dofs (k, m)`` (numba, no scipy).

    Returns ``(indptr, indices, remap)`` where ``remap[p]`` is the new slot of the fixed pattern's
    slot ``p``, so maps computed once on the fixed pattern stay valid via ``remap[old_map]``.
    Rows stay sorted within each column. Cost: linear in the number of entries (a marker array
    removes duplicates; each column's few new rows are inserted in order among its fixed rows,
    whose new slots are then found by binary search).
    """
    k, m = extra_dofs.shape
    # rows contributed by the blocks, per column (with duplicates)
    cnt = np.zeros(n + 1, np.int64)
    for b in range(k):
        for j in range(m):
            cnt[extra_dofs[b, j] + 1] += m
    for c in range(n):
        cnt[c + 1] += cnt[c]
    xrows = np.empty(cnt[n], np.int64)
    fill = cnt[:n].copy()
    for b in range(k):
        for j in range(m):
            c = extra_dofs[b, j]
            for i in range(m):
                xrows[fill[c]] = extra_dofs[b, i]
                fill[c] += 1
    mark = np.full(n, -1, np.int64)
    indptr = np.zeros(n + 1, np.int64)
    out = np.empty(indptr_e[n] + cnt[n], np.int64)
    remap = np.empty(indices_e.shape[0], np.int64)
    nnz = 0
    for c in range(n):
        lo = indptr_e[c]
        hi = indptr_e[c + 1]
        for p in range(lo, hi):
            mark[indices_e[p]] = c
        # the column's rows: the fixed pattern's (sorted), each new one inserted in order
        nf = hi - lo
        out[nnz:nnz + nf] = indices_e[lo:hi]
        nc = nf
        for p in range(cnt[c], cnt[c + 1]):
            r = xrows[p]
            if mark[r] != c:
                mark[r] = c
                i = nnz + nc
                while i > nnz and out[i - 1] > r:
                    out[i] = out[i - 1]
                    i -= 1
                out[i] = r
                nc += 1
        if nc > nf:
            remap[lo:hi] = np.searchsorted(out[nnz:nnz + nc], indices_e[lo:hi]) + nnz
        else:
            remap[lo:hi] = np.arange(nnz, nnz + nf)
        nnz += nc
        indptr[c + 1] = nnz
    return indptr, out[:nnz].copy(), remap
