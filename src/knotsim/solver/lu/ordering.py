"""Fill-reducing orderings of a sparse pattern for the fixed-pattern LU.

The pattern of ``A`` is first symmetrised to the graph of ``A + A^T`` (:func:`symmetric_graph`).
:func:`fill_reducing_order` then returns ``perm`` (``perm[new] = old``) for one of:

* ``"md"``: exact minimum degree on the quotient graph of DOF blocks (one bit set per block,
  :func:`minimum_degree_order`); blocks of 4 match one rod node plus one edge twist;
* ``"rcm"``: reverse Cuthill-McKee from ``scipy.sparse.csgraph``;
* ``"natural"``: the identity;
* an explicit permutation ``(n,)``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["fill_reducing_order", "minimum_degree_order", "symmetric_graph"]


@njit(cache=True)
def symmetric_graph(n, indptr, indices):
    """Adjacency of the graph of ``A + A^T`` without self loops, duplicates removed.

    Parameters: ``indptr`` ``(n+1,)``, ``indices`` ``(nnz,)`` CSC pattern.
    Returns ``(gp, gi)``: CSR adjacency, ``gp`` ``(n+1,)``, ``gi`` ``(nnz_g,)`` (unsorted rows).
    """
    cnt = np.zeros(n + 1, np.int64)
    for j in range(n):
        for p in range(indptr[j], indptr[j + 1]):
            i = indices[p]
            if i != j:
                cnt[i] += 1
                cnt[j] += 1
    gp = np.zeros(n + 1, np.int64)
    for i in range(n):
        gp[i + 1] = gp[i] + cnt[i]
    nxt = gp[:n].copy()
    gi = np.empty(gp[n], np.int64)
    for j in range(n):
        for p in range(indptr[j], indptr[j + 1]):
            i = indices[p]
            if i != j:
                gi[nxt[i]] = j
                nxt[i] += 1
                gi[nxt[j]] = i
                nxt[j] += 1
    # remove duplicates in place (compact)
    mark = np.full(n, -1, np.int64)
    out = 0
    start = 0
    for i in range(n):
        end = gp[i + 1]
        gp[i] = out
        for p in range(start, end):
            k = gi[p]
            if mark[k] != i:
                mark[k] = i
                gi[out] = k
                out += 1
        start = end
    gp[n] = out
    return gp, gi[:out].copy()


@njit(cache=True)
def _popcount64(x):
    """Number of set bits of the ``uint64`` ``x``."""
    m1 = np.uint64(0x5555555555555555)
    m2 = np.uint64(0x3333333333333333)
    m4 = np.uint64(0x0F0F0F0F0F0F0F0F)
    h01 = np.uint64(0x0101010101010101)
    x = x - ((x >> np.uint64(1)) & m1)
    x = (x & m2) + ((x >> np.uint64(2)) & m2)
    x = (x + (x >> np.uint64(4))) & m4
    return np.int64((x * h01) >> np.uint64(56))


@njit(cache=True)
def minimum_degree_blocks(n, gp, gi, block_of, nb):
    """Exact minimum-degree elimination order of the quotient graph of DOF blocks.

    The elimination graph is kept explicitly as one bit set per block (``nb x ceil(nb/64)``
    ``uint64``), so eliminating a block of degree ``d`` costs ``d * nb / 64`` word operations.
    Ties are broken by the smallest block index (this keeps the natural order on a band).

    Parameters: graph ``gp`` ``(n+1,)``, ``gi`` of the DOFs; ``block_of`` ``(n,)`` block of each DOF.
    Returns ``order`` ``(nb,)``: blocks in elimination order.
    """
    nw = (nb + 63) // 64
    adj = np.zeros((nb, nw), np.uint64)
    one = np.uint64(1)
    for i in range(n):
        bi = block_of[i]
        for p in range(gp[i], gp[i + 1]):
            bj = block_of[gi[p]]
            if bj != bi:
                adj[bi, bj >> 6] |= one << np.uint64(bj & 63)
    deg = np.zeros(nb, np.int64)
    for b in range(nb):
        s = 0
        for w in range(nw):
            s += _popcount64(adj[b, w])
        deg[b] = s
    done = np.zeros(nb, np.bool_)
    order = np.empty(nb, np.int64)
    nbr = np.empty(nb, np.int64)
    for step in range(nb):
        best = -1
        bestd = nb + 1
        for b in range(nb):
            if not done[b] and deg[b] < bestd:
                bestd = deg[b]
                best = b
        v = best
        order[step] = v
        done[v] = True
        # neighbours of v
        nn = 0
        for w in range(nw):
            x = adj[v, w]
            if x != 0:
                for t in range(64):
                    if (x >> np.uint64(t)) & one:
                        nbr[nn] = w * 64 + t
                        nn += 1
        vw = v >> 6
        vbit = ~(one << np.uint64(v & 63))
        for a in range(nn):
            u = nbr[a]
            s = 0
            for w in range(nw):
                y = adj[u, w] | adj[v, w]
                if w == vw:
                    y &= vbit
                adj[u, w] = y
            adj[u, u >> 6] &= ~(one << np.uint64(u & 63))
            for w in range(nw):
                s += _popcount64(adj[u, w])
            deg[u] = s
    return order


def block_starts(n: int, blocks) -> np.ndarray:
    """Block starts ``(nb+1,)`` int64 from 0 to ``n`` for a block size (``None``: 1) or given starts."""
    if blocks is None:
        blocks = 1
    if np.isscalar(blocks):
        bs = int(blocks)
        if bs < 1:
            raise ValueError(f"blocks: block size must be >= 1, got {bs}")
        starts = np.arange(0, n, bs, dtype=np.int64)
        return np.append(starts, n).astype(np.int64)
    starts = np.asarray(blocks, dtype=np.int64).ravel()
    if starts.size < 2 or starts[0] != 0 or starts[-1] != n or np.any(np.diff(starts) <= 0):
        raise ValueError("blocks: block starts must be strictly increasing from 0 to n")
    return starts


def minimum_degree_order(n: int, indptr: np.ndarray, indices: np.ndarray, blocks=4) -> np.ndarray:
    """Fill-reducing ordering of the pattern of ``A + A^T`` by exact minimum degree on DOF blocks.

    Parameters
    ----------
    n:
        Matrix size.
    indptr, indices:
        CSC (or CSR: the pattern is symmetrised) pattern, ``(n+1,)`` and ``(nnz,)``.
    blocks:
        Either a block size (consecutive DOFs ``[k*bs, (k+1)*bs)`` are ordered together; 4 matches
        one node plus one edge of a rod) or block starts ``(nb+1,)`` from 0 to ``n``.

    Returns
    -------
    perm: ``(n,)`` int64, ``perm[new] = old``.
    """
    indptr = np.ascontiguousarray(indptr, dtype=np.int64)
    indices = np.ascontiguousarray(indices, dtype=np.int64)
    gp, gi = symmetric_graph(n, indptr, indices)
    return md_perm(n, gp, gi, block_starts(n, blocks))


def md_perm(n: int, gp: np.ndarray, gi: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Minimum-degree ordering ``perm`` ``(n,)`` (``perm[new] = old``) of the graph ``gp``, ``gi``.

    The DOF blocks are given by their starts ``(nb+1,)``; the DOFs of a block stay consecutive
    and in order.
    """
    nb = starts.size - 1
    block_of = np.repeat(np.arange(nb, dtype=np.int64), np.diff(starts))
    border = minimum_degree_blocks(n, gp, gi, block_of, nb)
    sizes = np.diff(starts)[border]
    firsts = starts[:-1][border]
    offs = np.repeat(firsts - np.concatenate(([0], np.cumsum(sizes)[:-1])), sizes)
    return (np.arange(n, dtype=np.int64) + offs).astype(np.int64)


def fill_reducing_order(n: int, gp: np.ndarray, gi: np.ndarray, ordering="md", blocks=4) -> np.ndarray:
    """Ordering ``perm`` ``(n,)`` int64 (``perm[new] = old``) of the graph ``gp``, ``gi`` of ``A + A^T``.

    ``ordering``: ``"md"``, ``"rcm"``, ``"natural"`` or an explicit permutation ``(n,)``;
    ``blocks``: for ``"md"``, a block size or block starts ``(nb+1,)`` (see
    :func:`minimum_degree_order`). Raises ValueError for an unknown ordering or a bad permutation.
    """
    if isinstance(ordering, str):
        if ordering == "md":
            return md_perm(n, gp, gi, block_starts(n, blocks))
        if ordering == "rcm":
            from scipy.sparse import csr_matrix
            from scipy.sparse.csgraph import reverse_cuthill_mckee

            g = csr_matrix((np.ones(gi.size, np.int8), gi, gp), shape=(n, n))
            return reverse_cuthill_mckee(g, symmetric_mode=True).astype(np.int64)
        if ordering == "natural":
            return np.arange(n, dtype=np.int64)
        raise ValueError(f"ordering: unknown ordering {ordering!r} (md, rcm, natural)")
    perm = np.ascontiguousarray(ordering, dtype=np.int64)
    if perm.shape != (n,) or not np.array_equal(np.sort(perm), np.arange(n)):
        raise ValueError("ordering: not a permutation of range(n)")
    return perm
