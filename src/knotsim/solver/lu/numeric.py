"""Numeric multifrontal LU kernels (numba): factorisation ``P A P^T = L U`` and solves.

Each supernode assembles a dense row-major frontal matrix from the caller's CSC values and its
children's update matrices, eliminates its pivots without pivoting, writes its panels of ``L``
(unit lower) and ``U`` (upper) and passes its Schur complement to its parent on a stack. Large
Schur complements use BLAS ``dgemm`` (through ``np.dot`` in numba); everything else is loops
(written so that LLVM vectorises them) on preallocated storage. The plan (supernodes, assembly map, panel offsets) comes
from :mod:`knotsim.solver.lu.symbolic`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["column_max_abs", "mf_factorize", "mf_solve"]

_u = np.uint64  # unsigned index cast (see the note on loop style below)


@njit(cache=True)
def column_max_abs(data, colof, cnorm):
    """``cnorm[j] = max |data[p]|`` over the entries ``p`` with permuted column ``colof[p] == j``.

    ``data`` ``(nnz,)`` values, ``colof`` ``(nnz,)`` permuted column of each value, ``cnorm``
    ``(n,)`` output (0 for an empty column; NaN values are skipped by the comparison).
    """
    for j in range(cnorm.shape[0]):
        cnorm[j] = 0.0
    for p in range(data.shape[0]):
        a = abs(data[_u(p)])
        c = _u(colof[_u(p)])
        if a > cnorm[c]:
            cnorm[c] = a


_FM = {"nsz", "arcp", "contract", "reassoc"}  # fastmath without no-NaN/no-Inf (pivot checks need them)
#: Schur complements with (m-w)^2 * w >= this use BLAS dgemm; measured crossover with the loops of
#: :func:`_schur`: w = 16, m - w = 45 to 64 and w = 32, m - w = 32 (below it the loops are up to
#: 30 % faster, e.g. for the w = 8 fronts of the N = 301 knot)
_GEMM_MIN = 1 << 15

# Loop style of the kernels below: inner loops run ``for j in range(n)`` over 2-D views (``F[i, k + j]``)
# so that LLVM vectorises them; flat indexing with computed offsets (``front[i * m + j]``) and 1-D
# slices do not vectorise in numba (measured: 2-8x slower loops). Scalar gather/scatter loops index
# with unsigned integers (``_u``): numba then skips its negative-index wraparound, whose compare and
# select on every access cost 15 % of a factorisation and 24 % of a solve.


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _schur(F, L, S, w, r, gbuf):
    """``S = F22 - L21 U12`` for the front ``F`` ``(m, m)`` with ``m = w + r`` pivots eliminated.

    ``F[:w, w:]`` is ``U12`` ``(w, r)``, ``F[w:, w:]`` is ``F22``, ``L`` ``(w, m)`` holds ``L21``
    transposed in ``L[:, w:]``; ``S`` ``(r, r)`` output (the caller's stack slot); ``gbuf``
    scratch of at least ``max(2 r w + r^2, 8 r)`` floats (``3 m^2`` always is). Large updates use BLAS ``dgemm``; the others take
    eight pivots per pass over a row of ``S`` (their rows of ``U12`` copied to contiguous scratch,
    so the pass vectorises), the remaining ``w mod 8`` one at a time.
    """
    if r * r * w >= _GEMM_MIN:
        L21 = gbuf[: r * w].reshape((r, w))
        U12 = gbuf[r * w : 2 * r * w].reshape((w, r))
        T = gbuf[2 * r * w : 2 * r * w + r * r].reshape((r, r))
        for k in range(w):
            for a in range(r):
                L21[a, k] = L[k, w + a]
            for b in range(r):
                U12[k, b] = F[k, w + b]
        np.dot(L21, U12, T)
        for a in range(r):
            for b in range(r):
                S[a, b] = F[w + a, w + b] - T[a, b]
        return
    k = 0
    if w < 8:
        for a in range(r):
            for b in range(r):
                S[a, b] = F[w + a, w + b]
    U = gbuf[: 8 * r].reshape((8, r))
    while k + 8 <= w:
        for i in range(8):
            for b in range(r):
                U[i, b] = F[k + i, w + b]
        for a in range(r):
            l0 = L[k, w + a]
            l1 = L[k + 1, w + a]
            l2 = L[k + 2, w + a]
            l3 = L[k + 3, w + a]
            l4 = L[k + 4, w + a]
            l5 = L[k + 5, w + a]
            l6 = L[k + 6, w + a]
            l7 = L[k + 7, w + a]
            if k == 0:
                for b in range(r):
                    S[a, b] = F[w + a, w + b] - (
                        ((l0 * U[0, b] + l1 * U[1, b]) + (l2 * U[2, b] + l3 * U[3, b]))
                        + ((l4 * U[4, b] + l5 * U[5, b]) + (l6 * U[6, b] + l7 * U[7, b]))
                    )
            else:
                for b in range(r):
                    S[a, b] -= ((l0 * U[0, b] + l1 * U[1, b]) + (l2 * U[2, b] + l3 * U[3, b])) + (
                        (l4 * U[4, b] + l5 * U[5, b]) + (l6 * U[6, b] + l7 * U[7, b])
                    )
        k += 8
    while k < w:
        for a in range(r):
            lak = L[k, w + a]
            if lak != 0.0:
                for b in range(r):
                    S[a, b] -= lak * F[k, w + b]
        k += 1


@njit(cache=True, fastmath=_FM, error_model="numpy")
def mf_factorize(
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
):
    """Multifrontal LU without pivoting of ``P A P^T``.

    Each supernode ``s`` (width ``w``, front size ``m``) assembles its dense row-major front
    ``F`` ``(m, m)`` in ``front`` from ``data`` ``(nnz,)`` and its children's update matrices,
    eliminates its ``w`` pivot rows (right-looking), solves ``L21 = F21 U11^-1`` straight into the
    ``L`` panel, and writes its Schur complement ``F22 - L21 U12`` ``(m-w, m-w)`` straight onto
    ``stack``. The panels at ``poff[s]`` are ``(w, m)``: ``PU[b, a] = U[b, a]`` (``a >= b``) and
    ``PL[b, a] = L[a, b]`` (``a > b``) with the pivot ``PL[b, b] = U[b, b]``; the other entries
    are unused. ``gbuf`` is scratch for BLAS (the pivot rows are not blocked: fronts have a few
    dozen rows). Returns ``-1`` on success or the permuted index of the first
    bad pivot (its value is left in ``front``).
    """
    ns = sf.shape[0] - 1
    column_max_abs(data, colof, cnorm)
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
            front[_u(aoff[q])] += data[_u(asrc[q])]
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
                    front[_u(ra + rel[_u(rb + b)])] += stack[_u(so + b)]
            sp = off
        F = front[: m * m].reshape((m, m))
        po = poff[s]
        L = PL[po : po + w * m].reshape((w, m))
        U = PU[po : po + w * m].reshape((w, m))
        # the w pivot rows: U (diagonal and right of it) and L11 (strictly lower) in place
        for k in range(w):
            piv = F[k, k]
            if not (abs(piv) > tol * cnorm[f + k]) or not np.isfinite(piv):
                return f + k
            inv = 1.0 / piv
            n1 = m - k - 1
            for i in range(k + 1, w):
                lik = F[i, k] * inv
                F[i, k] = lik
                if lik != 0.0:
                    for j in range(n1):
                        F[i, k + 1 + j] -= lik * F[k, k + 1 + j]
        # L21 = F21 U11^-1 by columns, stored transposed in L[:, w:]; the panels
        for k in range(w):
            for a in range(r):
                L[k, w + a] = F[w + a, k]
            for j in range(k):
                ujk = F[j, k]
                if ujk != 0.0:
                    for a in range(r):
                        L[k, w + a] -= ujk * L[j, w + a]
            inv = 1.0 / F[k, k]
            for a in range(r):
                L[k, w + a] *= inv
            for i in range(k, w):
                L[k, i] = F[i, k]
            for j in range(m):
                U[k, j] = F[k, j]
        if sparent[s] != -1:
            _schur(F, L, stack[sp : sp + r * r].reshape((r, r)), w, r, gbuf)
            stk_sn[depth] = s
            stk_off[depth] = sp
            depth += 1
            sp += r * r
    return -1


@njit(cache=True, error_model="numpy")
def mf_solve(perm, sf, rp, ri, poff, PL, PU, b, x, y):
    """Solve ``A x = b`` with the multifrontal factors; ``b``, ``x``, ``y`` ``(n,)`` (``y`` scratch).

    By supernodes: the forward substitution accumulates the update of a supernode's off-diagonal
    rows in a dense work vector and subtracts it from ``y`` once per row; the backward substitution
    gathers those rows of ``y`` once per supernode.
    """
    ns = sf.shape[0] - 1
    n = perm.shape[0]
    max_r = 1
    for s in range(ns):
        if rp[s + 1] - rp[s] > max_r:
            max_r = rp[s + 1] - rp[s]
    u = np.empty(max_r)
    for j in range(n):
        y[_u(j)] = b[_u(perm[_u(j)])]
    for s in range(ns):
        f = sf[s]
        w = sf[s + 1] - f
        r = rp[s + 1] - rp[s]
        m = w + r
        po = poff[s]
        r0 = rp[s]
        for a in range(r):
            u[a] = 0.0
        for bb in range(w):
            yb = y[f + bb]
            if yb != 0.0:
                bm = po + bb * m
                for a in range(bb + 1, w):
                    y[_u(f + a)] -= PL[_u(bm + a)] * yb
                bw = bm + w
                for a in range(r):
                    u[_u(a)] += PL[_u(bw + a)] * yb
        for a in range(r):
            y[_u(ri[_u(r0 + a)])] -= u[_u(a)]
    for s in range(ns - 1, -1, -1):
        f = sf[s]
        w = sf[s + 1] - f
        r = rp[s + 1] - rp[s]
        m = w + r
        po = poff[s]
        r0 = rp[s]
        for a in range(r):
            u[_u(a)] = y[_u(ri[_u(r0 + a)])]
        for bb in range(w - 1, -1, -1):
            bm = po + bb * m
            acc = y[f + bb]
            for a in range(bb + 1, w):
                acc -= PU[_u(bm + a)] * y[_u(f + a)]
            bw = bm + w
            for a in range(r):
                acc -= PU[_u(bw + a)] * u[_u(a)]
            y[f + bb] = acc / PL[bm + bb]
    for j in range(n):
        x[_u(perm[_u(j)])] = y[_u(j)]
