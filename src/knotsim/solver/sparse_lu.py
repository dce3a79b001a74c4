"""Sparse LU with a fixed, structurally symmetric pattern, for the Newton Jacobian.

The Newton Jacobian ``J`` (``n x n``, ``n = 4 * n_nodes - 1`` per open rod) is banded (half-bandwidth
10) plus dense ``12 x 12`` contact blocks far from the band. Its *pattern* changes only when the
contact set changes (every few time steps) while its *values* change at every Newton iteration.
:class:`FixedPatternLU` therefore splits the work in two:

* **analyse** (once per pattern, in the constructor): symmetrise the pattern, compute a
  fill-reducing ordering (exact minimum degree on the quotient graph of DOF blocks, one bit set
  per block; or reverse Cuthill-McKee, or natural), postorder the elimination tree, find the
  pattern of ``L`` (``U`` has the pattern of ``L^T``), group columns into relaxed supernodes and
  precompute where every value of the caller's CSC array goes;
* **factorize** (every iteration): multifrontal LU without pivoting, ``P A P^T = L U`` (``L`` unit
  lower, ``U`` upper). Each supernode assembles a dense frontal matrix, eliminates its pivots by
  blocks, and passes its Schur complement to its parent; large Schur complements use BLAS
  ``dgemm`` (through ``np.dot`` in numba), everything else is scalar numba loops on preallocated
  storage. A scalar up-looking variant (``method="uplooking"``, no dense blocks) is kept for
  comparison and as a simple reference;
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

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["FixedPatternLU", "ZeroPivotError", "minimum_degree_order"]


class ZeroPivotError(ArithmeticError):
    """A pivot of the no-pivoting LU was zero, tiny relative to its column, or not finite.

    Attributes
    ----------
    column:
        Index of the offending column in the *original* numbering of the matrix.
    pivot:
        The value of the pivot that was rejected.
    """

    def __init__(self, column: int, pivot: float, message: str):
        self.column = column
        self.pivot = pivot
        super().__init__(message)


# ----------------------------------------------------------------------------------------------
# analyse kernels
# ----------------------------------------------------------------------------------------------


@njit(cache=True)
def _symmetric_graph(n, indptr, indices):
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
    m1 = np.uint64(0x5555555555555555)
    m2 = np.uint64(0x3333333333333333)
    m4 = np.uint64(0x0F0F0F0F0F0F0F0F)
    h01 = np.uint64(0x0101010101010101)
    x = x - ((x >> np.uint64(1)) & m1)
    x = (x & m2) + ((x >> np.uint64(2)) & m2)
    x = (x + (x >> np.uint64(4))) & m4
    return np.int64((x * h01) >> np.uint64(56))


@njit(cache=True)
def _minimum_degree_blocks(n, gp, gi, block_of, nb):
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


@njit(cache=True)
def _upper_pattern(n, gp, gi, perm, iperm):
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
def _etree(n, up, ui):
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
def _symbolic(n, up, ui):
    """Elimination tree and pattern of ``L`` for the symmetric pattern given by its upper part.

    Parameters: ``up`` ``(n+1,)``, ``ui``: strictly upper pattern by columns (= lower by rows).
    Returns ``(parent, Lp, Li, Rp, Rk, Rpos)``:

    * ``parent`` ``(n,)``: elimination tree (``-1`` for roots);
    * ``Lp`` ``(n+1,)``, ``Li`` ``(nnz_L,)``: pattern of strictly lower ``L`` by columns, rows ascending;
    * ``Rp`` ``(n+1,)``, ``Rk`` ``(nnz_L,)``, ``Rpos`` ``(nnz_L,)``: for each row ``j``, the columns
      ``k < j`` of its nonzeros in a topological order of the elimination tree, and the position of
      ``L[j, k]`` in ``Li``.
    """
    parent = _etree(n, up, ui)
    # pass 1: row counts and column counts through the row subtrees (ereach)
    mark = np.full(n, -1, np.int64)
    colcnt = np.zeros(n, np.int64)
    Rp = np.zeros(n + 1, np.int64)
    for k in range(n):
        mark[k] = k
        c = 0
        for p in range(up[k], up[k + 1]):
            i = ui[p]
            while mark[i] != k:
                mark[i] = k
                colcnt[i] += 1
                c += 1
                i = parent[i]
        Rp[k + 1] = Rp[k] + c
    Lp = np.zeros(n + 1, np.int64)
    for k in range(n):
        Lp[k + 1] = Lp[k] + colcnt[k]
    nnz = Lp[n]
    Li = np.empty(nnz, np.int64)
    Rk = np.empty(nnz, np.int64)
    Rpos = np.empty(nnz, np.int64)
    fill = Lp[:n].copy()
    stack = np.empty(n, np.int64)
    mark[:] = -1
    for k in range(n):
        mark[k] = k
        top = Rp[k + 1]
        for p in range(up[k], up[k + 1]):
            i = ui[p]
            ln = 0
            while mark[i] != k:
                mark[i] = k
                stack[ln] = i
                ln += 1
                i = parent[i]
            while ln > 0:
                ln -= 1
                top -= 1
                Rk[top] = stack[ln]
        # rows of L[k, :] (in topological order): append k to each column
        for q in range(Rp[k], Rp[k + 1]):
            c = Rk[q]
            pos = fill[c]
            fill[c] += 1
            Li[pos] = k
            Rpos[q] = pos
    return parent, Lp, Li, Rp, Rk, Rpos


@njit(cache=True)
def _lpattern(n, up, ui, parent):
    """Pattern of strictly lower ``L`` by columns (rows ascending): ``(Lp, Li)``, ``(n+1,)``, ``(nnz_L,)``."""
    mark = np.full(n, -1, np.int64)
    colcnt = np.zeros(n, np.int64)
    for k in range(n):
        mark[k] = k
        for p in range(up[k], up[k + 1]):
            i = ui[p]
            while mark[i] != k:
                mark[i] = k
                colcnt[i] += 1
                i = parent[i]
    Lp = np.zeros(n + 1, np.int64)
    for k in range(n):
        Lp[k + 1] = Lp[k] + colcnt[k]
    Li = np.empty(Lp[n], np.int32)
    fill = Lp[:n].copy()
    mark[:] = -1
    for k in range(n):
        mark[k] = k
        for p in range(up[k], up[k + 1]):
            i = ui[p]
            while mark[i] != k:
                mark[i] = k
                Li[fill[i]] = k
                fill[i] += 1
                i = parent[i]
    return Lp, Li


@njit(cache=True)
def _scatter_map(n, indptr, indices, iperm):
    """Map the caller's CSC entries to the up-looking input order.

    For permuted column ``j``: entries with new row ``<= j`` (upper part incl. diagonal) are listed
    in ``(cp, cr, cs)`` (row, source index); for permuted row ``j``: entries with new column ``< j``
    in ``(rp, rc, rs)``. Also returns ``colof`` ``(nnz,)``: permuted column of each entry.
    """
    nnz = indptr[n]
    cc = np.zeros(n + 1, np.int64)
    rc_ = np.zeros(n + 1, np.int64)
    colof = np.empty(nnz, np.int64)
    for c in range(n):
        nc = iperm[c]
        for p in range(indptr[c], indptr[c + 1]):
            nr = iperm[indices[p]]
            colof[p] = nc
            if nr <= nc:
                cc[nc + 1] += 1
            else:
                rc_[nr + 1] += 1
    for j in range(n):
        cc[j + 1] += cc[j]
        rc_[j + 1] += rc_[j]
    cr = np.empty(cc[n], np.int64)
    cs = np.empty(cc[n], np.int64)
    rcol = np.empty(rc_[n], np.int64)
    rs = np.empty(rc_[n], np.int64)
    fc = cc[:n].copy()
    fr = rc_[:n].copy()
    for c in range(n):
        nc = iperm[c]
        for p in range(indptr[c], indptr[c + 1]):
            nr = iperm[indices[p]]
            if nr <= nc:
                q = fc[nc]
                fc[nc] += 1
                cr[q] = nr
                cs[q] = p
            else:
                q = fr[nr]
                fr[nr] += 1
                rcol[q] = nc
                rs[q] = p
    return cc, cr, cs, rc_, rcol, rs, colof


# ----------------------------------------------------------------------------------------------
# numeric kernels
# ----------------------------------------------------------------------------------------------


@njit(cache=True, error_model="numpy")
def _factorize(n, data, cp, cr, cs, rp, rcol, rs, colof, Lp, Li, Rp, Rk, Rpos, Lx, Ux, Ud, work, cnorm, tol):
    """Up-looking LU ``P A P^T = L U`` without pivoting, in place in ``Lx``, ``Ux``, ``Ud``.

    ``work`` ``(n, 2)`` must be zero on entry and is zero on return; ``cnorm`` ``(n,)`` scratch.
    Returns ``-1`` on success, else the permuted index of the first bad pivot.
    """
    for j in range(n):
        cnorm[j] = 0.0
    for p in range(data.shape[0]):
        a = abs(data[p])
        c = colof[p]
        if a > cnorm[c]:
            cnorm[c] = a
    for j in range(n):
        # scatter column j (rows <= j) into work[:, 0] and row j (cols < j) into work[:, 1]
        for p in range(cp[j], cp[j + 1]):
            work[cr[p], 0] += data[cs[p]]
        for p in range(rp[j], rp[j + 1]):
            work[rcol[p], 1] += data[rs[p]]
        d = work[j, 0]
        work[j, 0] = 0.0
        for q in range(Rp[j], Rp[j + 1]):
            k = Rk[q]
            pos = Rpos[q]
            ukj = work[k, 0]
            ljk = work[k, 1] / Ud[k]
            work[k, 0] = 0.0
            work[k, 1] = 0.0
            for p in range(Lp[k], pos):
                i = Li[p]
                work[i, 0] -= Lx[p] * ukj
                work[i, 1] -= Ux[p] * ljk
            Ux[pos] = ukj
            Lx[pos] = ljk
            d -= ljk * ukj
        Ud[j] = d
        if not (abs(d) > tol * cnorm[j]) or not np.isfinite(d):
            # clean the work array before bailing out
            for jj in range(n):
                work[jj, 0] = 0.0
                work[jj, 1] = 0.0
            return j
    return -1


@njit(cache=True, error_model="numpy")
def _solve(n, perm, Lp, Li, Lx, Ux, Ud, b, x, y):
    """Solve ``A x = b`` from ``P A P^T = L U``. ``b``, ``x`` ``(n,)``; ``y`` ``(n,)`` scratch.

    ``x`` may alias ``b``.
    """
    for j in range(n):
        y[j] = b[perm[j]]
    for j in range(n):
        yj = y[j]
        if yj != 0.0:
            for p in range(Lp[j], Lp[j + 1]):
                y[Li[p]] -= Lx[p] * yj
    for j in range(n - 1, -1, -1):
        s = y[j]
        for p in range(Lp[j], Lp[j + 1]):
            s -= Ux[p] * y[Li[p]]
        y[j] = s / Ud[j]
    for j in range(n):
        x[perm[j]] = y[j]


@njit(cache=True, error_model="numpy")
def _solve_multi(n, perm, Lp, Li, Lx, Ux, Ud, B, X, Y):
    """Solve ``A X = B`` for ``B`` ``(n, m)``; ``X`` ``(n, m)`` output, ``Y`` ``(n, m)`` scratch."""
    m = B.shape[1]
    for j in range(n):
        for c in range(m):
            Y[j, c] = B[perm[j], c]
    for j in range(n):
        for p in range(Lp[j], Lp[j + 1]):
            i = Li[p]
            lx = Lx[p]
            for c in range(m):
                Y[i, c] -= lx * Y[j, c]
    for j in range(n - 1, -1, -1):
        for p in range(Lp[j], Lp[j + 1]):
            i = Li[p]
            ux = Ux[p]
            for c in range(m):
                Y[j, c] -= ux * Y[i, c]
        for c in range(m):
            Y[j, c] /= Ud[j]
    for j in range(n):
        for c in range(m):
            X[perm[j], c] = Y[j, c]


# ----------------------------------------------------------------------------------------------
# multifrontal (supernodal) kernels
# ----------------------------------------------------------------------------------------------


@njit(cache=True)
def _postorder(n, parent):
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
def _supernodes(n, parent, Lp, Li, nrelax, relax_frac):
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
    # stack of update matrices (postorder: the children of s are on top when s is processed)
    depth = 0
    size = 0
    max_stack = 0
    max_depth = 0
    stk = np.empty(ns + 1, np.int64)
    for s in range(ns):
        for _t in range(nchild[s]):
            depth -= 1
            size -= stk[depth]
        r = rp[s + 1] - rp[s]
        if sparent[s] != -1:
            stk[depth] = r * r
            depth += 1
            size += r * r
            if size > max_stack:
                max_stack = size
            if depth > max_depth:
                max_depth = depth
    return sf, rp, ri, sparent, nchild, rel, poff, max_front, max_stack, max_depth


@njit(cache=True)
def _assembly_map(n, indptr, indices, iperm, sf, rp, ri):
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


_FM = {"nsz", "arcp", "contract", "reassoc"}  # fastmath without no-NaN/no-Inf (pivot checks need them)
_GEMM_MIN = 4096  # fronts with (m-w)^2 * w >= this use BLAS dgemm for the Schur complement


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _gemm_sub(F, k0, k1, m, gbuf):
    """``F[k1:, k1:] -= F[k1:, k0:k1] @ F[k0:k1, k1:]`` for the ``(m, m)`` front ``F``.

    Uses BLAS ``dgemm`` on contiguous copies in ``gbuf`` when the update is large enough.
    """
    r = m - k1
    w = k1 - k0
    if r * r * w >= _GEMM_MIN:
        L21 = gbuf[: r * w].reshape((r, w))
        U12 = gbuf[r * w : 2 * r * w].reshape((w, r))
        T = gbuf[2 * r * w : 2 * r * w + r * r].reshape((r, r))
        for i in range(r):
            for k in range(w):
                L21[i, k] = F[k1 + i, k0 + k]
        for k in range(w):
            for j in range(r):
                U12[k, j] = F[k0 + k, k1 + j]
        np.dot(L21, U12, T)
        for i in range(r):
            for j in range(r):
                F[k1 + i, k1 + j] -= T[i, j]
    else:
        for i in range(k1, m):
            for k in range(k0, k1):
                lik = F[i, k]
                if lik != 0.0:
                    for j in range(k1, m):
                        F[i, j] -= lik * F[k, j]


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _mf_factorize(
    data,
    colof,
    sf,
    rp,
    sparent,
    nchild,
    rel,
    poff,
    ap,
    asrc,
    aoff,
    PL,
    PU,
    front,
    stack,
    stk_off,
    stk_sn,
    gbuf,
    cnorm,
    tol,
    nb,
):
    """Multifrontal LU without pivoting of ``P A P^T``.

    Each supernode ``s`` (width ``w``, front size ``m``) assembles its dense row-major front
    ``F`` ``(m, m)`` in ``front`` from ``data`` ``(nnz,)`` and its children's update matrices,
    eliminates its ``w`` pivots, stores ``L`` (unit, below the diagonal) and ``U`` (diagonal and
    right of it) as ``(w, m)`` panels ``PL[b, a] = F[a, b]`` and ``PU[b, a] = F[b, a]`` at
    ``poff[s]``, and pushes its ``(m-w, m-w)`` Schur complement on ``stack``. Large Schur
    complements use BLAS ``dgemm`` with ``gbuf`` as contiguous scratch.
    Returns ``-1`` on success or the permuted index of the first bad pivot.
    """
    n = sf[sf.shape[0] - 1]
    ns = sf.shape[0] - 1
    for j in range(n):
        cnorm[j] = 0.0
    for p in range(data.shape[0]):
        a = abs(data[p])
        c = colof[p]
        if a > cnorm[c]:
            cnorm[c] = a
    depth = 0
    sp = 0
    for s in range(ns):
        f = sf[s]
        w = sf[s + 1] - f
        r = rp[s + 1] - rp[s]
        m = w + r
        for q in range(m * m):
            front[q] = 0.0
        for q in range(ap[s], ap[s + 1]):
            front[aoff[q]] += data[asrc[q]]
        for _t in range(nchild[s]):
            depth -= 1
            c = stk_sn[depth]
            off = stk_off[depth]
            rc = rp[c + 1] - rp[c]
            rb = rp[c]
            for a in range(rc):
                ra = rel[rb + a] * m
                so = off + a * rc
                for b in range(rc):
                    front[ra + rel[rb + b]] += stack[so + b]
            sp = off
        F = front[: m * m].reshape((m, m))
        # blocked partial factorisation of the first w rows/columns, the trailing updates of
        # each column block (including the Schur complement F22 -= F21 F12) through _gemm_sub
        for k0 in range(0, w, nb):
            k1 = min(k0 + nb, w)
            for k in range(k0, k1):
                piv = F[k, k]
                if not (abs(piv) > tol * cnorm[f + k]) or not np.isfinite(piv):
                    return f + k
                inv = 1.0 / piv
                for i in range(k + 1, m):
                    lik = F[i, k] * inv
                    F[i, k] = lik
                    if lik != 0.0:
                        for j in range(k + 1, k1):
                            F[i, j] -= lik * F[k, j]
            for i in range(k0 + 1, k1):
                for k in range(k0, i):
                    lik = F[i, k]
                    if lik != 0.0:
                        for j in range(k1, m):
                            F[i, j] -= lik * F[k, j]
            _gemm_sub(F, k0, k1, m, gbuf)
        po = poff[s]
        for b in range(w):
            bm = po + b * m
            for a in range(m):
                PL[bm + a] = F[a, b]
                PU[bm + a] = F[b, a]
        if sparent[s] != -1:
            for a in range(r):
                so = sp + a * r
                for b in range(r):
                    stack[so + b] = F[w + a, w + b]
            stk_sn[depth] = s
            stk_off[depth] = sp
            depth += 1
            sp += r * r
    return -1


@njit(cache=True, error_model="numpy")
def _mf_solve(perm, sf, rp, ri, poff, PL, PU, b, x, y):
    """Solve ``A x = b`` with the multifrontal factors; ``b``, ``x``, ``y`` ``(n,)`` (``y`` scratch)."""
    ns = sf.shape[0] - 1
    n = perm.shape[0]
    for j in range(n):
        y[j] = b[perm[j]]
    for s in range(ns):
        f = sf[s]
        w = sf[s + 1] - f
        m = w + rp[s + 1] - rp[s]
        po = poff[s]
        r0 = rp[s] - w
        for bb in range(w):
            yb = y[f + bb]
            if yb != 0.0:
                bm = po + bb * m
                for a in range(bb + 1, w):
                    y[f + a] -= PL[bm + a] * yb
                for a in range(w, m):
                    y[ri[r0 + a]] -= PL[bm + a] * yb
    for s in range(ns - 1, -1, -1):
        f = sf[s]
        w = sf[s + 1] - f
        m = w + rp[s + 1] - rp[s]
        po = poff[s]
        r0 = rp[s] - w
        for bb in range(w - 1, -1, -1):
            bm = po + bb * m
            acc = y[f + bb]
            for a in range(bb + 1, w):
                acc -= PU[bm + a] * y[f + a]
            for a in range(w, m):
                acc -= PU[bm + a] * y[ri[r0 + a]]
            y[f + bb] = acc / PL[bm + bb]
    for j in range(n):
        x[perm[j]] = y[j]


# ----------------------------------------------------------------------------------------------
# public API
# ----------------------------------------------------------------------------------------------


def _block_starts(n: int, blocks) -> np.ndarray:
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
    gp, gi = _symmetric_graph(n, indptr, indices)
    return _md_perm(n, gp, gi, _block_starts(n, blocks))


def _md_perm(n, gp, gi, starts):
    nb = starts.size - 1
    block_of = np.repeat(np.arange(nb, dtype=np.int64), np.diff(starts))
    border = _minimum_degree_blocks(n, gp, gi, block_of, nb)
    sizes = np.diff(starts)[border]
    firsts = starts[:-1][border]
    offs = np.repeat(firsts - np.concatenate(([0], np.cumsum(sizes)[:-1])), sizes)
    return (np.arange(n, dtype=np.int64) + offs).astype(np.int64)


class FixedPatternLU:
    """LU factorisation ``P A P^T = L U`` reused for many matrices with one sparsity pattern.

    Parameters
    ----------
    n:
        Size of the square matrix ``A`` (``n >= 1``).
    indptr, indices:
        CSC pattern of ``A``: ``(n+1,)`` and ``(nnz,)`` integer arrays (duplicates allowed, they are
        summed; rows need not be sorted). Values passed to :meth:`factorize` follow this order.
    ordering:
        ``"md"`` (default; exact minimum degree on DOF blocks), ``"rcm"`` (reverse Cuthill-McKee
        from ``scipy.sparse.csgraph``), ``"natural"``, or an explicit permutation ``(n,)`` with
        ``perm[new] = old``.
    blocks:
        For ``ordering="md"``: block size (default 4, a rod node's position and its edge's twist)
        or block starts ``(nb+1,)`` (e.g. per rod node, for several rods). ``1`` orders single DOFs.
    method:
        ``"multifrontal"`` (default): relaxed supernodes, dense frontal matrices;
        ``"uplooking"``: scalar up-looking LU (no dense blocks; slower with contacts).
    nrelax, relax_frac:
        Supernode amalgamation (multifrontal only): a chain of columns is merged into one
        supernode while its width is ``<= nrelax`` and explicit zeros are ``<= relax_frac`` of it.
    panel:
        Column-block width of the blocked dense partial factorisation of each front.
    pivot_tol:
        A pivot ``u_jj`` with ``|u_jj| <= pivot_tol * max_i |A[i, j]|`` raises :class:`ZeroPivotError`.
    recycle:
        A previous :class:`FixedPatternLU` (e.g. for the pattern before the contact set changed)
        whose large float work buffers are taken over when big enough; this avoids fresh memory
        (page faults) at every pattern change. The old object must not be used afterwards.

    Attributes
    ----------
    perm: ``(n,)`` ordering, ``perm[new] = old`` (postordered for the multifrontal method).
    nnz_L: number of strictly lower nonzeros of ``L`` (``U`` has as many strictly upper ones).
    n_supernodes, max_front: supernode count and largest frontal matrix (multifrontal only).
    """

    def __init__(
        self,
        n: int,
        indptr,
        indices,
        *,
        ordering="md",
        blocks=4,
        method: str = "multifrontal",
        nrelax: int = 8,
        relax_frac: float = 0.6,
        panel: int = 16,
        pivot_tol: float = 1e-13,
        recycle: FixedPatternLU | None = None,
    ):
        n = int(n)
        if n < 1:
            raise ValueError(f"n: must be >= 1, got {n}")
        if method not in ("multifrontal", "uplooking"):
            raise ValueError(f"method: unknown method {method!r} (multifrontal, uplooking)")
        indptr = np.ascontiguousarray(indptr, dtype=np.int64)
        indices = np.ascontiguousarray(indices, dtype=np.int64)
        if indptr.shape != (n + 1,) or indptr[0] != 0 or indices.shape[0] < indptr[n]:
            raise ValueError("indptr/indices: not a CSC pattern of an n x n matrix")
        indices = indices[: indptr[n]]
        if indices.size and (indices.min() < 0 or indices.max() >= n):
            raise ValueError("indices: row index out of range")
        self.n = n
        self.nnz = int(indptr[n])
        self.indptr = indptr
        self.indices = indices
        self.method = method
        self.pivot_tol = float(pivot_tol)
        self._nb = max(int(panel), 1)
        gp, gi = _symmetric_graph(n, indptr, indices)
        if isinstance(ordering, str):
            if ordering == "md":
                perm = _md_perm(n, gp, gi, _block_starts(n, blocks))
            elif ordering == "rcm":
                from scipy.sparse import csr_matrix
                from scipy.sparse.csgraph import reverse_cuthill_mckee

                g = csr_matrix((np.ones(gi.size, np.int8), gi, gp), shape=(n, n))
                perm = reverse_cuthill_mckee(g, symmetric_mode=True).astype(np.int64)
            elif ordering == "natural":
                perm = np.arange(n, dtype=np.int64)
            else:
                raise ValueError(f"ordering: unknown ordering {ordering!r} (md, rcm, natural)")
        else:
            perm = np.ascontiguousarray(ordering, dtype=np.int64)
            if perm.shape != (n,) or not np.array_equal(np.sort(perm), np.arange(n)):
                raise ValueError("ordering: not a permutation of range(n)")
        iperm = np.empty(n, np.int64)
        iperm[perm] = np.arange(n, dtype=np.int64)
        up, ui = _upper_pattern(n, gp, gi, perm, iperm)
        self._cnorm = np.zeros(n)
        self._y = np.zeros(n)
        if method == "multifrontal":
            parent = _etree(n, up, ui)
            post = _postorder(n, parent)
            if not np.array_equal(post, np.arange(n)):
                perm = perm[post]
                iperm[perm] = np.arange(n, dtype=np.int64)
                up, ui = _upper_pattern(n, gp, gi, perm, iperm)
                parent = _etree(n, up, ui)
            self.parent = parent
            self.Lp, self.Li = _lpattern(n, up, ui, parent)
            (
                self._sf,
                self._rp,
                self._ri,
                self._sparent,
                self._nchild,
                self._rel,
                self._poff,
                max_front,
                max_stack,
                max_depth,
            ) = _supernodes(n, parent, self.Lp, self.Li, int(nrelax), float(relax_frac))
            self._ap, self._asrc, self._aoff, self._colof = _assembly_map(
                n, indptr, indices, iperm, self._sf, self._rp, self._ri
            )
            self.n_supernodes = int(self._sf.size - 1)
            self.max_front = int(max_front)
            old = recycle.__dict__ if isinstance(recycle, FixedPatternLU) else {}

            def buf(name, size):
                b = old.get(name)
                if b is not None and b.size >= size:
                    return b
                return np.zeros(max(size, 1))

            self._PL = buf("_PL", int(self._poff[-1]))
            self._PU = buf("_PU", int(self._poff[-1]))
            self._front = buf("_front", max_front * max_front)
            self._gbuf = buf("_gbuf", 3 * max_front * max_front)
            self._stack = buf("_stack", int(max_stack))
            self._stk_off = np.zeros(max(max_depth, 1), np.int64)
            self._stk_sn = np.zeros(max(max_depth, 1), np.int64)
        else:
            self.parent, self.Lp, self.Li, self.Rp, self.Rk, self.Rpos = _symbolic(n, up, ui)
            self._scatter = _scatter_map(n, indptr, indices, iperm)
            self.Lx = np.zeros(int(self.Lp[n]))
            self.Ux = np.zeros(int(self.Lp[n]))
            self.Ud = np.zeros(n)
            self._work = np.zeros((n, 2))
        self.perm = perm
        self.iperm = iperm
        self.nnz_L = int(self.Lp[n])
        self.factorized = False

    @classmethod
    def from_matrix(cls, A, **kwargs) -> FixedPatternLU:
        """Analyse the pattern of a scipy sparse matrix ``A`` ``(n, n)`` (converted to CSC).

        Pass values in the same CSC order later (``A.tocsc().data``).
        """
        A = A.tocsc()
        return cls(A.shape[0], A.indptr, A.indices, **kwargs)

    def same_pattern(self, indptr, indices) -> bool:
        """True if ``(indptr, indices)`` is exactly the CSC pattern this object was built for."""
        return (
            len(indptr) == self.n + 1
            and np.array_equal(indptr, self.indptr)
            and np.array_equal(np.asarray(indices)[: self.nnz], self.indices)
        )

    def factorize(self, data) -> None:
        """Numeric factorisation for values ``data`` ``(nnz,)`` in the original CSC order.

        Raises :class:`ZeroPivotError` if a pivot is tiny relative to its column or not finite;
        the object then holds no valid factorisation.
        """
        data = np.asarray(data, dtype=np.float64)
        if data.shape[0] < self.nnz:
            raise ValueError(f"data: expected {self.nnz} values, got {data.shape[0]}")
        if self.method == "multifrontal":
            bad = _mf_factorize(
                data,
                self._colof,
                self._sf,
                self._rp,
                self._sparent,
                self._nchild,
                self._rel,
                self._poff,
                self._ap,
                self._asrc,
                self._aoff,
                self._PL,
                self._PU,
                self._front,
                self._stack,
                self._stk_off,
                self._stk_sn,
                self._gbuf,
                self._cnorm,
                self.pivot_tol,
                self._nb,
            )
            piv = float(self._front[0]) if bad >= 0 else 0.0
            if bad >= 0:
                s = int(np.searchsorted(self._sf, bad, side="right") - 1)
                k = bad - int(self._sf[s])
                m = int(self._sf[s + 1] - self._sf[s] + self._rp[s + 1] - self._rp[s])
                piv = float(self._front[k * m + k])
        else:
            cp, cr, cs, rp, rcol, rs, colof = self._scatter
            bad = _factorize(
                self.n,
                data,
                cp,
                cr,
                cs,
                rp,
                rcol,
                rs,
                colof,
                self.Lp,
                self.Li,
                self.Rp,
                self.Rk,
                self.Rpos,
                self.Lx,
                self.Ux,
                self.Ud,
                self._work,
                self._cnorm,
                self.pivot_tol,
            )
            piv = float(self.Ud[bad]) if bad >= 0 else 0.0
        if bad >= 0:
            self.factorized = False
            col = int(self.perm[bad])
            raise ZeroPivotError(
                col,
                piv,
                f"LU without pivoting: pivot {piv:.3e} of column {col} is tiny relative to the column "
                f"max {self._cnorm[bad]:.3e} (tol {self.pivot_tol:.1e}); fall back to a pivoting LU",
            )
        self.factorized = True

    def solve(self, rhs, out=None) -> np.ndarray:
        """Solve ``A x = rhs`` with the last factorisation.

        ``rhs`` ``(n,)`` or ``(n, m)``; ``out`` optional output of the same shape (may be ``rhs``
        itself for an in-place solve). Returns ``x`` with the shape of ``rhs``.
        """
        if not self.factorized:
            raise RuntimeError("solve: no valid factorisation (call factorize first)")
        b = np.asarray(rhs, dtype=np.float64)
        if b.shape[0] != self.n:
            raise ValueError(f"rhs: expected {self.n} rows, got {b.shape[0]}")
        if out is None:
            out = np.empty_like(b)
        if self.method == "multifrontal":
            if b.ndim == 1:
                _mf_solve(
                    self.perm, self._sf, self._rp, self._ri, self._poff, self._PL, self._PU, b, out, self._y
                )
            else:
                col_in = np.empty(self.n)
                col_out = np.empty(self.n)
                for c in range(b.shape[1]):
                    col_in[:] = b[:, c]
                    _mf_solve(
                        self.perm,
                        self._sf,
                        self._rp,
                        self._ri,
                        self._poff,
                        self._PL,
                        self._PU,
                        col_in,
                        col_out,
                        self._y,
                    )
                    out[:, c] = col_out
        elif b.ndim == 1:
            _solve(self.n, self.perm, self.Lp, self.Li, self.Lx, self.Ux, self.Ud, b, out, self._y)
        else:
            _solve_multi(
                self.n, self.perm, self.Lp, self.Li, self.Lx, self.Ux, self.Ud, b, out, np.empty_like(b)
            )
        return out

    def factorize_solve(self, data, rhs, out=None) -> np.ndarray:
        """:meth:`factorize` with ``data`` ``(nnz,)`` then :meth:`solve` ``rhs`` ``(n,)`` or ``(n, m)``."""
        self.factorize(data)
        return self.solve(rhs, out)
