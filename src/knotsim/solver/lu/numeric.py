"""Numeric multifrontal LU kernels (numba): factorisation ``P A P^T = L U`` and solves.

Each supernode assembles a dense row-major frontal matrix from the caller's CSC values and its
children's update matrices, eliminates its pivots without pivoting into its panels of ``L`` (unit
lower) and ``U`` (upper) and passes its Schur complement to its parent on a stack. Large Schur
complements use BLAS ``dgemm`` (through ``np.dot`` in numba); everything else is loops (written so
that LLVM vectorises them) on preallocated storage. The plan (supernodes, assembly map) comes from
:mod:`knotsim.solver.lu.symbolic`; :func:`padded_plan` turns it into the padded layout used here.

Padded layout: a supernode of width ``w`` with ``r`` off-diagonal rows keeps its front rows and
columns at positions ``0:w`` (its pivots) and ``wp:wp+r`` (the other rows), ``wp = pad8(w)``,
``mp = wp + pad16(r)`` (``padN`` rounds up to a multiple of ``N``), so that the off-diagonal part
of every row is a whole number of 16-wide blocks; the padding columns hold zeros. Fronts of width
8 (most of them: relaxed supernodes of two rod nodes) have their own straight-line kernel.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from knotsim.solver.lu.symbolic import update_stack_peak

__all__ = ["mf_factorize", "mf_solve", "padded_plan"]

_u = np.uint64  # unsigned index cast (see the note on loop style below)


@njit(cache=True)
def padded_plan(sf, rp, sparent, nchild, rel, ap, aoff):
    """The padded layout of the plan of :func:`knotsim.solver.lu.symbolic.supernodes`.

    Returns ``(ppoff, paoff, prel, rnp, runs, max_front, max_stack)``: ``ppoff`` ``(ns+1,)``
    offsets of the ``(w, mp)`` panels; ``paoff`` ``(nnz,)`` padded front offset of each assembly
    entry ``q`` (``aoff[q]`` in the padded ``(mp, mp)`` front); ``prel`` the padded positions of ``rel`` in the parents'
    fronts; ``runs[rnp[s]:rnp[s+1]]`` ``(nruns, 3)`` the runs of consecutive positions of
    supernode ``s``'s update in its parent's front (start in the update, start in the parent,
    length); the largest ``mp`` and the stack size (updates ``(r, pad16(r))``).
    """
    ns = sf.shape[0] - 1
    ppoff = np.zeros(ns + 1, np.int64)
    paoff = np.empty(aoff.shape[0], np.int32)
    prel = np.empty(rel.shape[0], np.int64)
    rnp = np.zeros(ns + 1, np.int64)
    runs = np.zeros((rel.shape[0] + 1, 3), np.int64)
    max_front = 1
    nr = 0
    for s in range(ns):
        w = sf[s + 1] - sf[s]
        r = rp[s + 1] - rp[s]
        m = w + r
        wp = (w + 7) & ~7
        mp = wp + ((r + 15) & ~15)
        max_front = max(max_front, mp)
        ppoff[s + 1] = ppoff[s] + w * mp
        for q in range(ap[s], ap[s + 1]):
            i = aoff[q] // m
            j = aoff[q] - i * m
            i = i if i < w else i - w + wp
            j = j if j < w else j - w + wp
            paoff[q] = i * mp + j
        p = sparent[s]
        if p != -1:
            wpar = sf[p + 1] - sf[p]
            wppar = (wpar + 7) & ~7
            for q in range(rp[s], rp[s + 1]):
                g = rel[q]
                prel[q] = g if g < wpar else g - wpar + wppar
            for q in range(rp[s], rp[s + 1]):
                if q == rp[s] or prel[q] != prel[q - 1] + 1:
                    runs[nr, 0] = q - rp[s]
                    runs[nr, 1] = prel[q]
                    nr += 1
                runs[nr - 1, 2] += 1
        rnp[s + 1] = nr
    max_stack = max(1, update_stack_peak(rp, sparent, nchild, 16)[0])  # updates stored (r, pad16(r))
    return ppoff, paoff, prel, rnp, runs[:nr].copy(), max_front, max_stack


_FM = {"nsz", "arcp", "contract", "reassoc"}  # fastmath without no-NaN/no-Inf (pivot checks need them)
#: Schur complements with (m-w)^2 * w >= this use BLAS dgemm (fronts of width w != 8); measured
#: crossover with the loops: w = 16, m - w = 45 to 64 and w = 32, m - w = 32
_GEMM_MIN = 1 << 15

# Loop style of the kernels below: flat indexing of the caller's arrays with unsigned offsets
# (``front[_u(i * mp + j)]``): numba then skips its negative-index wraparound, without which LLVM
# cannot vectorise a loop whose index starts at a run-time offset (measured 2.6x slower), and no
# array views are made per supernode (a slice with a reshape costs ~18 ns: its reference count).
# The off-diagonal parts of the w = 8 fronts go 16 at a time through scratch with constant strides
# (``gbuf[k * 16 + t]``), so that LLVM vectorises those loops without run-time alias checks (with
# more than a few distinct row pointers it does not vectorise at all). The front kernels are written
# inline in mf_factorize: as separate functions LLVM inlined and optimised them twice (+2 s compile).


@njit(cache=True, fastmath=_FM, error_model="numpy")
def mf_factorize(
    data,
    indptr,
    iperm,
    sf,
    rp,
    sparent,
    nchild,
    ppoff,
    ap,
    asrc,
    paoff,
    prel,
    rnp,
    runs,
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
    """Multifrontal LU without pivoting of ``P A P^T`` (plan: :func:`padded_plan`).

    Each supernode ``s`` (width ``w``, ``r`` other rows, padded size ``mp``) assembles its padded
    row-major front ``F`` ``(mp, mp)`` in ``front`` from ``data`` ``(nnz,)`` (CSC values with
    pointers ``indptr``; the largest ``|value|`` of every column ``c`` goes to ``cnorm[iperm[c]]``
    first, for the pivot test, NaN values skipped) and its children's update matrices, eliminates its ``w`` pivots into
    its panels and writes its Schur complement ``F22 - L21 U12`` ``(r, pad16(r))`` straight onto
    ``stack`` (width 8: by blocks of 16 rows or columns; other widths: right-looking in ``front``).
    The panels at ``ppoff[s]`` are ``(w, mp)`` in the padded positions: ``PU[b, a] = U[b, a]`` (``a >= b``) and ``PL[b, a] =
    L[a, b]`` (``a > b``) and the inverse pivot ``PL[b, b] = 1 / U[b, b]``; the other entries are unused.
    ``gbuf`` is scratch. Returns ``-1`` on success or the permuted index ``f + k`` of the first
    bad pivot (its value is left in ``PU[ppoff[s] + k * (mp + 1)]``).
    """
    ns = sf.shape[0] - 1
    for c in range(indptr.shape[0] - 1):  # column maxima, four at a time
        m0 = m1 = m2 = m3 = 0.0
        p = indptr[c]
        e = indptr[c + 1]
        while p + 4 <= e:
            h0, h1, h2, h3 = abs(data[_u(p)]), abs(data[_u(p + 1)]), abs(data[_u(p + 2)]), abs(data[_u(p + 3)])
            m0 = h0 if h0 > m0 else m0
            m1 = h1 if h1 > m1 else m1
            m2 = h2 if h2 > m2 else m2
            m3 = h3 if h3 > m3 else m3
            p += 4
        while p < e:
            h0 = abs(data[_u(p)])
            m0 = h0 if h0 > m0 else m0
            p += 1
        m0 = m1 if m1 > m0 else m0
        m2 = m3 if m3 > m2 else m2
        cnorm[_u(iperm[_u(c)])] = m2 if m2 > m0 else m0
    depth = 0
    sp = 0
    for s in range(ns):
        f = sf[s]
        w = sf[s + 1] - f
        r = rp[s + 1] - rp[s]
        rq = (r + 15) & ~15
        mp = ((w + 7) & ~7) + rq
        for q in range((mp - rq + r) * mp):  # not the padding rows (their results are not used)
            front[_u(q)] = 0.0
        for q in range(ap[s], ap[s + 1]):
            front[_u(paoff[_u(q)])] += data[_u(asrc[_u(q)])]
        for _t in range(nchild[s]):
            depth -= 1
            c = stk_sn[depth]
            off = stk_off[depth]
            rc = rp[c + 1] - rp[c]
            rqc = (rc + 15) & ~15
            rb = rp[c]
            g = rnp[c]
            if rnp[c + 1] == g + 1:  # one block (the padding columns of the update are zeros)
                p0 = runs[_u(g), 1]
                for a in range(rc):
                    ps = (p0 + a) * mp + p0
                    sa = off + a * rqc
                    for t in range(rqc):
                        front[_u(ps + t)] += stack[_u(sa + t)]
            else:
                for a in range(rc):
                    pr = prel[_u(rb + a)] * mp
                    sa = off + a * rqc
                    for g in range(rnp[c], rnp[c + 1]):
                        ps = pr + runs[_u(g), 1]
                        cs = sa + runs[_u(g), 0]
                        for t in range(runs[_u(g), 2]):
                            front[_u(ps + t)] += stack[_u(cs + t)]
            sp = off
        po = ppoff[s]
        so = sp
        if w == 8:  # the usual case: see the note on loop style
            for i in range(8):  # the pivot block in gbuf[128:192], its multipliers l_ik in gbuf[192 + i * 8 + k]
                for j in range(8):
                    gbuf[128 + i * 8 + j] = front[_u(i * mp + j)]
            for k in range(8):
                piv = gbuf[128 + k * 9]
                if not (abs(piv) > tol * cnorm[_u(f + k)]) or not np.isfinite(piv):
                    PU[_u(po + k * (mp + 1))] = piv
                    return f + k
                inv = 1.0 / piv
                x0, x1, x2, x3 = gbuf[128 + k * 8], gbuf[129 + k * 8], gbuf[130 + k * 8], gbuf[131 + k * 8]
                x4, x5, x6, x7 = gbuf[132 + k * 8], gbuf[133 + k * 8], gbuf[134 + k * 8], gbuf[135 + k * 8]
                for i in range(k + 1, 8):  # whole rows (the strictly lower part is not used)
                    lik = gbuf[128 + i * 8 + k] * inv
                    gbuf[192 + i * 8 + k] = lik
                    gbuf[128 + i * 8] -= lik * x0
                    gbuf[129 + i * 8] -= lik * x1
                    gbuf[130 + i * 8] -= lik * x2
                    gbuf[131 + i * 8] -= lik * x3
                    gbuf[132 + i * 8] -= lik * x4
                    gbuf[133 + i * 8] -= lik * x5
                    gbuf[134 + i * 8] -= lik * x6
                    gbuf[135 + i * 8] -= lik * x7
            for k in range(8):
                for j in range(8):
                    PU[_u(po + k * mp + j)] = gbuf[128 + k * 8 + j]
                    PL[_u(po + k * mp + j)] = gbuf[192 + j * 8 + k]
                PL[_u(po + k * (mp + 1))] = 1.0 / gbuf[128 + k * 9]
            # the coefficients of U11 (strictly upper u_pk = gbuf[128 + 8 p + k], inverse pivots d_k) and L11
            u01, u02, u12, u03, u13, u23 = gbuf[129], gbuf[130], gbuf[138], gbuf[131], gbuf[139], gbuf[147]
            u04, u14, u24, u34, u05, u15, u25, u35, u45 = gbuf[132], gbuf[140], gbuf[148], gbuf[156], gbuf[133], gbuf[141], gbuf[149], gbuf[157], gbuf[165]
            u06, u16, u26, u36, u46, u56 = gbuf[134], gbuf[142], gbuf[150], gbuf[158], gbuf[166], gbuf[174]
            u07, u17, u27, u37, u47, u57, u67 = gbuf[135], gbuf[143], gbuf[151], gbuf[159], gbuf[167], gbuf[175], gbuf[183]
            d0, d1, d2, d3 = 1.0 / gbuf[128], 1.0 / gbuf[137], 1.0 / gbuf[146], 1.0 / gbuf[155]
            d4, d5, d6, d7 = 1.0 / gbuf[164], 1.0 / gbuf[173], 1.0 / gbuf[182], 1.0 / gbuf[191]
            l10, l20, l21, l30, l31, l32 = gbuf[200], gbuf[208], gbuf[209], gbuf[216], gbuf[217], gbuf[218]
            l40, l41, l42, l43, l50, l51, l52, l53, l54 = gbuf[224], gbuf[225], gbuf[226], gbuf[227], gbuf[232], gbuf[233], gbuf[234], gbuf[235], gbuf[236]
            l60, l61, l62, l63, l64, l65 = gbuf[240], gbuf[241], gbuf[242], gbuf[243], gbuf[244], gbuf[245]
            l70, l71, l72, l73, l74, l75, l76 = gbuf[248], gbuf[249], gbuf[250], gbuf[251], gbuf[252], gbuf[253], gbuf[254]
            for a0 in range(0, rq, 16):  # L21 = F21 U11^-1, 16 rows at a time (F21 transposed into G)
                for t in range(16):
                    for k in range(8):
                        gbuf[k * 16 + t] = front[_u((8 + a0 + t) * mp + k)]
                for t in range(16):
                    x0 = gbuf[t] * d0
                    x1 = (gbuf[16 + t] - u01 * x0) * d1
                    x2 = (gbuf[32 + t] - (u02 * x0 + u12 * x1)) * d2
                    x3 = (gbuf[48 + t] - ((u03 * x0 + u13 * x1) + u23 * x2)) * d3
                    x4 = (gbuf[64 + t] - ((u04 * x0 + u14 * x1) + (u24 * x2 + u34 * x3))) * d4
                    x5 = (gbuf[80 + t] - (((u05 * x0 + u15 * x1) + (u25 * x2 + u35 * x3)) + u45 * x4)) * d5
                    x6 = (gbuf[96 + t] - (((u06 * x0 + u16 * x1) + (u26 * x2 + u36 * x3)) + (u46 * x4 + u56 * x5))) * d6
                    x7 = (gbuf[112 + t] - (((u07 * x0 + u17 * x1) + (u27 * x2 + u37 * x3)) + ((u47 * x4 + u57 * x5) + u67 * x6))) * d7
                    gbuf[t], gbuf[16 + t], gbuf[32 + t], gbuf[48 + t] = x0, x1, x2, x3
                    gbuf[64 + t], gbuf[80 + t], gbuf[96 + t], gbuf[112 + t] = x4, x5, x6, x7
                for k in range(8):
                    o = po + k * mp + 8 + a0
                    for t in range(16):
                        PL[_u(o + t)] = gbuf[k * 16 + t]
            for b0 in range(0, rq, 16):  # U12 = L11^-1 F12 and S, 16 columns at a time (through G)
                for k in range(8):
                    o = k * mp + 8 + b0
                    for t in range(16):
                        gbuf[k * 16 + t] = front[_u(o + t)]
                for t in range(16):
                    x0 = gbuf[t]
                    x1 = gbuf[16 + t] - l10 * x0
                    x2 = gbuf[32 + t] - (l20 * x0 + l21 * x1)
                    x3 = gbuf[48 + t] - ((l30 * x0 + l31 * x1) + l32 * x2)
                    x4 = gbuf[64 + t] - ((l40 * x0 + l41 * x1) + (l42 * x2 + l43 * x3))
                    x5 = gbuf[80 + t] - (((l50 * x0 + l51 * x1) + (l52 * x2 + l53 * x3)) + l54 * x4)
                    x6 = gbuf[96 + t] - (((l60 * x0 + l61 * x1) + (l62 * x2 + l63 * x3)) + (l64 * x4 + l65 * x5))
                    x7 = gbuf[112 + t] - (((l70 * x0 + l71 * x1) + (l72 * x2 + l73 * x3)) + ((l74 * x4 + l75 * x5) + l76 * x6))
                    gbuf[16 + t], gbuf[32 + t], gbuf[48 + t], gbuf[64 + t] = x1, x2, x3, x4
                    gbuf[80 + t], gbuf[96 + t], gbuf[112 + t] = x5, x6, x7
                for k in range(8):
                    o = po + k * mp + 8 + b0
                    for t in range(16):
                        PU[_u(o + t)] = gbuf[k * 16 + t]
                for a in range(r):
                    o = po + 8 + a
                    l0, l1, l2, l3 = PL[_u(o)], PL[_u(o + mp)], PL[_u(o + 2 * mp)], PL[_u(o + 3 * mp)]
                    l4, l5, l6, l7 = PL[_u(o + 4 * mp)], PL[_u(o + 5 * mp)], PL[_u(o + 6 * mp)], PL[_u(o + 7 * mp)]
                    fo = (8 + a) * mp + 8 + b0
                    sa = so + a * rq + b0
                    for t in range(16):
                        stack[_u(sa + t)] = front[_u(fo + t)] - (
                            ((l0 * gbuf[t] + l1 * gbuf[16 + t]) + (l2 * gbuf[32 + t] + l3 * gbuf[48 + t]))
                            + ((l4 * gbuf[64 + t] + l5 * gbuf[80 + t]) + (l6 * gbuf[96 + t] + l7 * gbuf[112 + t]))
                        )
        else:  # any width: right-looking elimination in the front, then the panels and S
            wp = (w + 7) & ~7
            for k in range(w):
                ok = k * mp
                piv = front[_u(ok + k)]
                if not (abs(piv) > tol * cnorm[_u(f + k)]) or not np.isfinite(piv):
                    PU[_u(po + k * (mp + 1))] = piv
                    return f + k
                inv = 1.0 / piv
                # rows k+1..w-1 are the pivot rows (L11 in place, U11 and U12), then the r rows
                # from wp on (L21 by rows; their columns from wp on are the Schur complement's)
                for i in range(k + 1, w + r):
                    oi = (i if i < w else i - w + wp) * mp
                    lik = front[_u(oi + k)] * inv
                    front[_u(oi + k)] = lik
                    if lik != 0.0:
                        for j in range(k + 1, w):
                            front[_u(oi + j)] -= lik * front[_u(ok + j)]
                        if i < w:
                            for j in range(wp, mp):
                                front[_u(oi + j)] -= lik * front[_u(ok + j)]
            for k in range(w):
                ok = k * mp
                pk = po + k * mp
                for j in range(mp):
                    PU[_u(pk + j)] = front[_u(ok + j)]
                for i in range(k + 1, w):
                    PL[_u(pk + i)] = front[_u(i * mp + k)]
                for i in range(wp, mp):
                    PL[_u(pk + i)] = front[_u(i * mp + k)]
                PL[_u(pk + k)] = 1.0 / front[_u(ok + k)]
            if r == 0:
                pass
            elif r * r * w >= _GEMM_MIN:
                L21 = gbuf[: r * w].reshape((r, w))
                U12 = gbuf[r * w : 2 * r * w].reshape((w, r))
                T = gbuf[2 * r * w : 2 * r * w + r * r].reshape((r, r))
                for k in range(w):
                    for a in range(r):
                        L21[_u(a), _u(k)] = PL[_u(po + k * mp + wp + a)]
                        U12[_u(k), _u(a)] = PU[_u(po + k * mp + wp + a)]
                np.dot(L21, U12, T)
                for a in range(r):
                    fo = (wp + a) * mp + wp
                    for b in range(r):
                        stack[_u(so + a * rq + b)] = front[_u(fo + b)] - T[_u(a), _u(b)]
                    for b in range(r, rq):
                        stack[_u(so + a * rq + b)] = 0.0
            else:
                for a in range(r):
                    fo = (wp + a) * mp + wp
                    sa = so + a * rq
                    for b in range(rq):
                        stack[_u(sa + b)] = front[_u(fo + b)]
                for k in range(w):
                    pk = po + k * mp + wp
                    for a in range(r):
                        lak = PL[_u(pk + a)]
                        if lak != 0.0:
                            sa = so + a * rq
                            for b in range(rq):
                                stack[_u(sa + b)] -= lak * PU[_u(pk + b)]
        if sparent[s] != -1:
            stk_sn[depth] = s
            stk_off[depth] = sp
            depth += 1
            sp += r * rq
    return -1


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _forward8(PL, po, mp, rq, y, f, u):
    """Forward substitution of a supernode of width 8 (panel ``PL`` at ``po``, ``(8, mp)``):
    ``y[f:f+8]`` in place, then ``u[:rq] = L21 y[f:f+8]``."""
    o1, o2, o3, o4, o5, o6, o7 = po + mp, po + 2 * mp, po + 3 * mp, po + 4 * mp, po + 5 * mp, po + 6 * mp, po + 7 * mp
    y0 = y[_u(f)]
    y1 = y[_u(f + 1)] - PL[_u(po + 1)] * y0
    y2 = y[_u(f + 2)] - (PL[_u(po + 2)] * y0 + PL[_u(o1 + 2)] * y1)
    y3 = y[_u(f + 3)] - ((PL[_u(po + 3)] * y0 + PL[_u(o1 + 3)] * y1) + PL[_u(o2 + 3)] * y2)
    y4 = y[_u(f + 4)] - ((PL[_u(po + 4)] * y0 + PL[_u(o1 + 4)] * y1) + (PL[_u(o2 + 4)] * y2 + PL[_u(o3 + 4)] * y3))
    y5 = y[_u(f + 5)] - (
        ((PL[_u(po + 5)] * y0 + PL[_u(o1 + 5)] * y1) + (PL[_u(o2 + 5)] * y2 + PL[_u(o3 + 5)] * y3))
        + PL[_u(o4 + 5)] * y4
    )
    y6 = y[_u(f + 6)] - (
        ((PL[_u(po + 6)] * y0 + PL[_u(o1 + 6)] * y1) + (PL[_u(o2 + 6)] * y2 + PL[_u(o3 + 6)] * y3))
        + (PL[_u(o4 + 6)] * y4 + PL[_u(o5 + 6)] * y5)
    )
    y7 = y[_u(f + 7)] - (
        ((PL[_u(po + 7)] * y0 + PL[_u(o1 + 7)] * y1) + (PL[_u(o2 + 7)] * y2 + PL[_u(o3 + 7)] * y3))
        + ((PL[_u(o4 + 7)] * y4 + PL[_u(o5 + 7)] * y5) + PL[_u(o6 + 7)] * y6)
    )
    y[_u(f + 1)], y[_u(f + 2)], y[_u(f + 3)], y[_u(f + 4)] = y1, y2, y3, y4
    y[_u(f + 5)], y[_u(f + 6)], y[_u(f + 7)] = y5, y6, y7
    for a in range(rq):
        u[_u(a)] = ((PL[_u(po + 8 + a)] * y0 + PL[_u(o1 + 8 + a)] * y1) + (PL[_u(o2 + 8 + a)] * y2 + PL[_u(o3 + 8 + a)] * y3)) + (
            (PL[_u(o4 + 8 + a)] * y4 + PL[_u(o5 + 8 + a)] * y5) + (PL[_u(o6 + 8 + a)] * y6 + PL[_u(o7 + 8 + a)] * y7)
        )


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _backward8(PL, PU, po, mp, rq, y, f, u):
    """Backward substitution of a supernode of width 8 (panels at ``po``, ``(8, mp)``) with
    ``u[:rq]`` its off-diagonal rows of ``y``: ``y[f:f+8]`` in place."""
    o1, o2, o3, o4, o5, o6, o7 = po + mp, po + 2 * mp, po + 3 * mp, po + 4 * mp, po + 5 * mp, po + 6 * mp, po + 7 * mp
    t0 = t1 = t2 = t3 = t4 = t5 = t6 = t7 = 0.0
    for a in range(rq):
        ua = u[_u(a)]
        t0 += PU[_u(po + 8 + a)] * ua
        t1 += PU[_u(o1 + 8 + a)] * ua
        t2 += PU[_u(o2 + 8 + a)] * ua
        t3 += PU[_u(o3 + 8 + a)] * ua
        t4 += PU[_u(o4 + 8 + a)] * ua
        t5 += PU[_u(o5 + 8 + a)] * ua
        t6 += PU[_u(o6 + 8 + a)] * ua
        t7 += PU[_u(o7 + 8 + a)] * ua
    y7 = (y[_u(f + 7)] - t7) * PL[_u(o7 + 7)]
    y6 = (y[_u(f + 6)] - t6 - PU[_u(o6 + 7)] * y7) * PL[_u(o6 + 6)]
    y5 = (y[_u(f + 5)] - t5 - (PU[_u(o5 + 6)] * y6 + PU[_u(o5 + 7)] * y7)) * PL[_u(o5 + 5)]
    y4 = (y[_u(f + 4)] - t4 - ((PU[_u(o4 + 5)] * y5 + PU[_u(o4 + 6)] * y6) + PU[_u(o4 + 7)] * y7)) * PL[_u(o4 + 4)]
    y3 = (
        y[_u(f + 3)] - t3 - ((PU[_u(o3 + 4)] * y4 + PU[_u(o3 + 5)] * y5) + (PU[_u(o3 + 6)] * y6 + PU[_u(o3 + 7)] * y7))
    ) * PL[_u(o3 + 3)]
    y2 = (
        y[_u(f + 2)] - t2 - (((PU[_u(o2 + 3)] * y3 + PU[_u(o2 + 4)] * y4) + (PU[_u(o2 + 5)] * y5 + PU[_u(o2 + 6)] * y6))
                             + PU[_u(o2 + 7)] * y7)
    ) * PL[_u(o2 + 2)]
    y1 = (
        y[_u(f + 1)] - t1 - (((PU[_u(o1 + 2)] * y2 + PU[_u(o1 + 3)] * y3) + (PU[_u(o1 + 4)] * y4 + PU[_u(o1 + 5)] * y5))
                             + (PU[_u(o1 + 6)] * y6 + PU[_u(o1 + 7)] * y7))
    ) * PL[_u(o1 + 1)]
    y0 = (
        y[_u(f)] - t0 - (((PU[_u(po + 1)] * y1 + PU[_u(po + 2)] * y2) + (PU[_u(po + 3)] * y3 + PU[_u(po + 4)] * y4))
                         + ((PU[_u(po + 5)] * y5 + PU[_u(po + 6)] * y6) + PU[_u(po + 7)] * y7))
    ) * PL[_u(po)]
    y[_u(f)], y[_u(f + 1)], y[_u(f + 2)], y[_u(f + 3)] = y0, y1, y2, y3
    y[_u(f + 4)], y[_u(f + 5)], y[_u(f + 6)], y[_u(f + 7)] = y4, y5, y6, y7


@njit(inline="always")
def _panel(sf, rp, ppoff, s):
    """Supernode ``s``'s panel in the packed factor: first column ``f``, width ``w``, rows below
    ``r``, their padded sizes ``wp`` and ``rq``, the panel's leading dimension ``mp``, its offset
    ``po`` and the start ``r0`` of its row list."""
    f = sf[s]
    w = sf[s + 1] - f
    r = rp[s + 1] - rp[s]
    wp = (w + 7) & ~7
    rq = (r + 15) & ~15
    return f, w, r, wp, rq, wp + rq, ppoff[s], rp[s]


@njit(cache=True, fastmath=_FM, error_model="numpy")
def mf_solve(perm, sf, rp, ri, ppoff, PL, PU, b, x, y):
    """Solve ``A x = b`` with the multifrontal factors; ``b``, ``x``, ``y`` ``(n,)`` (``y`` scratch).

    By supernodes (panels in the padded layout of :func:`mf_factorize`): the forward substitution
    accumulates the update of a supernode's off-diagonal rows in a dense work vector and subtracts
    it from ``y`` once per row; the backward substitution gathers those rows of ``y`` once per
    supernode.
    """
    ns = sf.shape[0] - 1
    n = perm.shape[0]
    max_rq = 16
    for s in range(ns):
        max_rq = max(max_rq, (rp[s + 1] - rp[s] + 15) & ~15)
    u = np.empty(max_rq)
    for j in range(n):
        y[_u(j)] = b[_u(perm[_u(j)])]
    for s in range(ns):
        f, w, r, wp, rq, mp, po, r0 = _panel(sf, rp, ppoff, s)
        if w == 8:
            _forward8(PL, po, mp, rq, y, f, u)
            for a in range(r):
                y[_u(ri[_u(r0 + a)])] -= u[_u(a)]
            continue
        for a in range(rq):
            u[_u(a)] = 0.0
        for bb in range(w):
            yb = y[_u(f + bb)]
            if yb != 0.0:
                ob = po + bb * mp
                for a in range(bb + 1, w):
                    y[_u(f + a)] -= PL[_u(ob + a)] * yb
                ob += wp
                for a in range(rq):
                    u[_u(a)] += PL[_u(ob + a)] * yb
        for a in range(r):
            y[_u(ri[_u(r0 + a)])] -= u[_u(a)]
    for s in range(ns - 1, -1, -1):
        f, w, r, wp, rq, mp, po, r0 = _panel(sf, rp, ppoff, s)
        for a in range(r):
            u[_u(a)] = y[_u(ri[_u(r0 + a)])]
        for a in range(r, rq):
            u[_u(a)] = 0.0
        if w == 8:
            _backward8(PL, PU, po, mp, rq, y, f, u)
            continue
        for bb in range(w - 1, -1, -1):
            ob = po + bb * mp
            acc = y[_u(f + bb)]
            for a in range(bb + 1, w):
                acc -= PU[_u(ob + a)] * y[_u(f + a)]
            dot = 0.0
            for a in range(rq):
                dot += PU[_u(ob + wp + a)] * u[_u(a)]
            y[_u(f + bb)] = (acc - dot) * PL[_u(ob + bb)]
    for j in range(n):
        x[_u(perm[_u(j)])] = y[_u(j)]
