"""Numeric multifrontal LU kernels (numba): factorisation ``P A P^T = L U`` and solves.

Each supernode assembles a dense row-major frontal matrix from the caller's CSC values and its
children's update matrices, eliminates its pivots by column blocks without pivoting, stores its
panels of ``L`` (unit lower) and ``U`` (upper) and passes its Schur complement to its parent on a
stack. Large Schur complements use BLAS ``dgemm`` (through ``np.dot`` in numba); everything else
is scalar loops on preallocated storage. The plan (supernodes, assembly map, panel offsets) comes
from :mod:`knotsim.solver.lu.symbolic`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["column_max_abs", "mf_factorize", "mf_solve"]


@njit(cache=True)
def column_max_abs(data, colof, cnorm):
    """``cnorm[j] = max |data[p]|`` over the entries ``p`` with permuted column ``colof[p] == j``.

    ``data`` ``(nnz,)`` values, ``colof`` ``(nnz,)`` permuted column of each value, ``cnorm``
    ``(n,)`` output (0 for an empty column; NaN values are skipped by the comparison).
    """
    for j in range(cnorm.shape[0]):
        cnorm[j] = 0.0
    for p in range(data.shape[0]):
        a = abs(data[p])
        c = colof[p]
        if a > cnorm[c]:
            cnorm[c] = a


_FM = {"nsz", "arcp", "contract", "reassoc"}  # fastmath without no-NaN/no-Inf (pivot checks need them)
#: fronts with (m-w)^2 * w >= this use BLAS dgemm for the Schur complement (1024: 9 % faster
#: factorisations of the N = 301 knot's Jacobians than 4096; never: 10 % slower)
_GEMM_MIN = 1024


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
        y[j] = b[perm[j]]
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
                    y[f + a] -= PL[bm + a] * yb
                bw = bm + w
                for a in range(r):
                    u[a] += PL[bw + a] * yb
        for a in range(r):
            y[ri[r0 + a]] -= u[a]
    for s in range(ns - 1, -1, -1):
        f = sf[s]
        w = sf[s + 1] - f
        r = rp[s + 1] - rp[s]
        m = w + r
        po = poff[s]
        r0 = rp[s]
        for a in range(r):
            u[a] = y[ri[r0 + a]]
        for bb in range(w - 1, -1, -1):
            bm = po + bb * m
            acc = y[f + bb]
            for a in range(bb + 1, w):
                acc -= PU[bm + a] * y[f + a]
            bw = bm + w
            for a in range(r):
                acc -= PU[bw + a] * u[a]
            y[f + bb] = acc / PL[bm + bb]
    for j in range(n):
        x[perm[j]] = y[j]
