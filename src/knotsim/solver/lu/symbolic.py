"""Symbolic analysis of the fixed-pattern LU: elimination tree, pattern of ``L``, supernodes.

Everything here depends only on the sparsity pattern (never on values) and is done once per
pattern: the strictly upper pattern of the permuted ``P (A + A^T) P^T`` (:func:`upper_pattern`),
its elimination tree (:func:`etree`) and postorder, the pattern of the strictly lower factor ``L``
(``U`` has the pattern of ``L^T``; :func:`l_pattern`), the relaxed supernode partition with the
multifrontal plan (:func:`supernodes`) and where every entry of the caller's CSC values goes in
the frontal matrices (:func:`assembly_map`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from knotsim.solver.lu.ordering import fill_reducing_order, symmetric_graph

__all__ = [
    "assembly_map",
    "check_csc_pattern",
    "ordered_pattern",
    "etree",
    "l_counts",
    "l_pattern",
    "postorder",
    "supernodes",
    "upper_pattern",
]


def check_csc_pattern(n, indptr, indices) -> tuple[int, np.ndarray, np.ndarray]:
    """Validate a CSC pattern of an ``n x n`` matrix; returns ``(n, indptr, indices)``.

    ``indptr`` ``(n+1,)`` and ``indices`` ``(nnz,)`` come back as contiguous int64 arrays
    (``indices`` cut to ``indptr[n]`` entries). Raises ValueError for ``n < 1``, a malformed
    ``indptr`` or a row index out of range.
    """
    n = int(n)
    if n < 1:
        raise ValueError(f"n: must be >= 1, got {n}")
    indptr = np.ascontiguousarray(indptr, dtype=np.int64)
    indices = np.ascontiguousarray(indices, dtype=np.int64)
    if indptr.shape != (n + 1,) or indptr[0] != 0 or indices.shape[0] < indptr[n]:
        raise ValueError("indptr/indices: not a CSC pattern of an n x n matrix")
    indices = indices[: indptr[n]]
    if indices.size and (indices.min() < 0 or indices.max() >= n):
        raise ValueError("indices: row index out of range")
    return n, indptr, indices


def ordered_pattern(n: int, indptr: np.ndarray, indices: np.ndarray, ordering, blocks):
    """Symmetrise a checked CSC pattern, order it and permute it.

    ``ordering``, ``blocks``: as :func:`knotsim.solver.lu.ordering.fill_reducing_order`.
    Returns ``(gp, gi, perm, iperm, up, ui)``: the graph of ``A + A^T`` (CSR, ``(n+1,)`` and
    ``(nnz_g,)``), the ordering ``perm[new] = old`` and its inverse (``(n,)`` each), and the
    strictly upper pattern of ``P (A + A^T) P^T`` by columns (:func:`upper_pattern`).
    """
    gp, gi = symmetric_graph(n, indptr, indices)
    perm = fill_reducing_order(n, gp, gi, ordering, blocks)
    iperm = np.empty(n, np.int64)
    iperm[perm] = np.arange(n, dtype=np.int64)
    up, ui = upper_pattern(n, gp, gi, perm, iperm)
    return gp, gi, perm, iperm, up, ui


@njit(cache=True)
def upper_pattern(n, gp, gi, perm, iperm):
    """Strictly upper pattern of ``P (A + A^T) P^T`` by columns (rows unsorted).

    Returns ``(up, ui)``: ``up`` ``(n+1,)``, ``ui`` ``(nnz_g/2,)``.
    """
    up = np.zeros(n + 1, np.int64)
    for j in range(n):
        old = perm[j]
        c = 0
        for p in range(gp[old], gp[old + 1]):
            if iperm[gi[p]] < j:
                c += 1
        up[j + 1] = up[j] + c
    ui = np.empty(up[n], np.int64)
    for j in range(n):
        old = perm[j]
        q = up[j]
        for p in range(gp[old], gp[old + 1]):
            i = iperm[gi[p]]
            if i < j:
                ui[q] = i
                q += 1
    return up, ui


@njit(cache=True)
def etree(n, up, ui):
    """Elimination tree ``parent`` ``(n,)`` of the symmetric pattern with strictly upper part ``up, ui``."""
    parent = np.full(n, -1, np.int64)
    anc = np.full(n, -1, np.int64)
    for k in range(n):
        for p in range(up[k], up[k + 1]):
            i = ui[p]
            while i != -1 and i < k:
                inext = anc[i]
                anc[i] = k
                if inext == -1:
                    parent[i] = k
                i = inext
    return parent


@njit(cache=True)
def _row_subtrees(n, up, ui, parent, write, colcnt, rowcnt, Li, fill):
    """Visit every strictly lower nonzero ``L[k, i]`` (rows ``k`` ascending) through the row subtrees.

    ``write=False``: count them, ``colcnt[i] += 1`` and ``rowcnt[k] += 1`` (both ``(n,)``);
    ``write=True``: store ``Li[fill[i]] = k`` and advance ``fill[i]`` (``fill`` ``(n,)``: next free
    position of each column of ``Li``).
    """
    mark = np.full(n, -1, np.int64)
    for k in range(n):
        mark[k] = k
        for p in range(up[k], up[k + 1]):
            i = ui[p]
            while mark[i] != k:
                mark[i] = k
                if write:
                    Li[fill[i]] = k
                    fill[i] += 1
                else:
                    colcnt[i] += 1
                    rowcnt[k] += 1
                i = parent[i]


@njit(cache=True)
def l_counts(n, up, ui, parent):
    """Column pointers of strictly lower ``L`` and its row counts, through the row subtrees.

    Parameters: ``up`` ``(n+1,)``, ``ui``: strictly upper pattern by columns; ``parent`` ``(n,)``
    its elimination tree. Returns ``(Lp, rowcnt)``: ``Lp`` ``(n+1,)`` (column ``j`` of ``L`` has
    ``Lp[j+1] - Lp[j]`` entries), ``rowcnt`` ``(n,)`` strictly lower entries of each row of ``L``.
    """
    colcnt = np.zeros(n, np.int64)
    rowcnt = np.zeros(n, np.int64)
    _row_subtrees(n, up, ui, parent, False, colcnt, rowcnt, np.empty(0, np.int32), colcnt)
    Lp = np.zeros(n + 1, np.int64)
    for k in range(n):
        Lp[k + 1] = Lp[k] + colcnt[k]
    return Lp, rowcnt


@njit(cache=True)
def l_pattern(n, up, ui, parent):
    """Pattern of strictly lower ``L`` by columns (rows ascending): ``(Lp, Li)``, ``(n+1,)``, ``(nnz_L,)``."""
    Lp, rowcnt = l_counts(n, up, ui, parent)
    Li = np.empty(Lp[n], np.int32)
    fill = Lp[:n].copy()
    _row_subtrees(n, up, ui, parent, True, rowcnt, rowcnt, Li, fill)
    return Lp, Li


@njit(cache=True)
def postorder(n, parent):
    """Postorder of the forest ``parent`` ``(n,)``: ``post[k]`` is the ``k``-th node visited."""
    head = np.full(n, -1, np.int64)
    nxt = np.full(n, -1, np.int64)
    for j in range(n - 1, -1, -1):
        p = parent[j]
        if p != -1:
            nxt[j] = head[p]
            head[p] = j
    post = np.empty(n, np.int64)
    stack = np.empty(n, np.int64)
    k = 0
    for root in range(n):
        if parent[root] != -1:
            continue
        top = 0
        stack[0] = root
        while top >= 0:
            p = stack[top]
            i = head[p]
            if i == -1:
                top -= 1
                post[k] = p
                k += 1
            else:
                head[p] = nxt[i]
                top += 1
                stack[top] = i
    return post


@njit(cache=True)
def _find(arr, lo, hi, x):
    """Index of ``x`` in the sorted slice ``arr[lo:hi]`` (binary search; ``x`` must be present)."""
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if arr[mid] <= x:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True)
def supernodes(n, parent, Lp, Li, nrelax, relax_frac):
    """Relaxed supernode partition of a postordered elimination tree and the multifrontal plan.

    A column ``j+1`` joins the supernode of ``j`` if ``parent[j] == j+1`` and either no explicit
    zero is added (fundamental supernode) or the width stays ``<= nrelax`` and the stored zeros
    stay ``<= relax_frac`` of the stored entries.

    Returns ``(sf, rp, ri, sparent, nchild, rel, poff, max_front, max_stack, max_depth)``:
    supernode ``s`` owns columns ``sf[s]:sf[s+1]`` and its front rows are those columns followed
    by ``ri[rp[s]:rp[s+1]]`` (sorted); ``rel[relp[s]:relp[s+1]]`` are the positions of those
    rows in the front of ``sparent[s]``; ``poff[s]`` is the offset of its ``(w, m)`` panels.
    """
    cc = np.empty(n, np.int64)
    for j in range(n):
        cc[j] = Lp[j + 1] - Lp[j]
    sf_tmp = np.empty(n + 1, np.int64)
    ns = 0
    sf_tmp[0] = 0
    f = 0
    true_nnz = cc[0]
    zeros = 0
    for j in range(n - 1):
        join = False
        if parent[j] == j + 1:
            w2 = j + 2 - f
            stored = w2 * (w2 - 1) // 2 + w2 * cc[j + 1]
            true2 = true_nnz + cc[j + 1]
            z2 = stored - true2
            if z2 == zeros or (w2 <= nrelax and z2 <= relax_frac * stored):
                join = True
                true_nnz = true2
                zeros = z2
        if not join:
            ns += 1
            sf_tmp[ns] = j + 1
            f = j + 1
            true_nnz = cc[j + 1]
            zeros = 0
    ns += 1
    sf_tmp[ns] = n
    sf = sf_tmp[: ns + 1].copy()
    sn_of = np.empty(n, np.int64)
    rp = np.zeros(ns + 1, np.int64)
    for s in range(ns):
        for j in range(sf[s], sf[s + 1]):
            sn_of[j] = s
        last = sf[s + 1] - 1
        rp[s + 1] = rp[s] + cc[last]
    ri = np.empty(rp[ns], np.int64)
    sparent = np.full(ns, -1, np.int64)
    nchild = np.zeros(ns, np.int64)
    poff = np.zeros(ns + 1, np.int64)
    max_front = 0
    for s in range(ns):
        last = sf[s + 1] - 1
        q = rp[s]
        for p in range(Lp[last], Lp[last + 1]):
            ri[q] = Li[p]
            q += 1
        if parent[last] != -1:
            sparent[s] = sn_of[parent[last]]
            nchild[sparent[s]] += 1
        w = sf[s + 1] - sf[s]
        m = w + rp[s + 1] - rp[s]
        poff[s + 1] = poff[s] + w * m
        if m > max_front:
            max_front = m
    rel = np.empty(rp[ns], np.int64)
    for s in range(ns):
        p = sparent[s]
        if p == -1:
            continue
        fp = sf[p]
        lp = sf[p + 1]
        wp = lp - fp
        for q in range(rp[s], rp[s + 1]):
            g = ri[q]
            if g < lp:
                rel[q] = g - fp
            else:
                rel[q] = wp + _find(ri, rp[p], rp[p + 1], g) - rp[p]
    max_stack, max_depth = update_stack_peak(rp, sparent, nchild, 1)
    return sf, rp, ri, sparent, nchild, rel, poff, max_front, max_stack, max_depth


@njit(cache=True)
def update_stack_peak(rp, sparent, nchild, row_block):
    """Peak size (floats) and depth of the stack of update matrices of a multifrontal factorisation
    in postorder (the children of a supernode are on top when it is processed): every supernode
    ``s`` with a parent pushes its ``r = rp[s+1] - rp[s]`` update rows, each ``r`` long rounded up
    to a multiple of ``row_block`` (1: dense ``(r, r)``), after popping its ``nchild[s]`` children."""
    ns = rp.shape[0] - 1
    depth = 0
    size = 0
    max_stack = 0
    max_depth = 0
    stk = np.empty(ns + 1, np.int64)
    for s in range(ns):
        for _t in range(nchild[s]):
            depth -= 1
            size -= stk[depth]
        if sparent[s] != -1:
            r = rp[s + 1] - rp[s]
            stk[depth] = r * (((r + row_block - 1) // row_block) * row_block)
            size += stk[depth]
            depth += 1
            if size > max_stack:
                max_stack = size
            if depth > max_depth:
                max_depth = depth
    return max_stack, max_depth


@njit(cache=True)
def assembly_map(n, indptr, indices, iperm, sf, rp, ri):
    """Where each original entry goes: ``(ap, asrc, aoff, colof)``.

    Entries of supernode ``s`` are ``asrc[ap[s]:ap[s+1]]`` (indices into ``data``), added at flat
    offsets ``aoff`` of its row-major ``(m, m)`` front. ``colof`` ``(nnz,)``: permuted column.
    """
    ns = sf.shape[0] - 1
    sn_of = np.empty(n, np.int64)
    for s in range(ns):
        for j in range(sf[s], sf[s + 1]):
            sn_of[j] = s
    nnz = indptr[n]
    ap = np.zeros(ns + 1, np.int64)
    colof = np.empty(nnz, np.int32)
    for c in range(n):
        j = iperm[c]
        for p in range(indptr[c], indptr[c + 1]):
            i = iperm[indices[p]]
            colof[p] = j
            ap[sn_of[min(i, j)] + 1] += 1
    for s in range(ns):
        ap[s + 1] += ap[s]
    fill = ap[:ns].copy()
    asrc = np.empty(nnz, np.int32)
    for c in range(n):
        j = iperm[c]
        for p in range(indptr[c], indptr[c + 1]):
            i = iperm[indices[p]]
            s = sn_of[min(i, j)]
            asrc[fill[s]] = p
            fill[s] += 1
    # local positions through a marker map, one supernode at a time
    loc = np.empty(n, np.int64)
    aoff = np.empty(nnz, np.int32)
    for s in range(ns):
        f = sf[s]
        w = sf[s + 1] - f
        m = w + rp[s + 1] - rp[s]
        for j in range(w):
            loc[f + j] = j
        for q in range(rp[s], rp[s + 1]):
            loc[ri[q]] = w + q - rp[s]
        for q in range(ap[s], ap[s + 1]):
            p = asrc[q]
            aoff[q] = loc[iperm[indices[p]]] * m + loc[colof[p]]
    return ap, asrc, aoff, colof
