"""Regularized minimum distance between two edges: smooth for (nearly) parallel edges.

Why. The exact segment distance of :mod:`knotsim.contact.distance` is not smooth when two edges
are (nearly) parallel and overlap: the closest points then sit at one end of the overlap, and they
jump to the other end when the small angle between the edges changes sign. The distance is
continuous but its gradient is not, so the contact force on the four nodes of a pair of parallel
edges pressed together jumps between nodes (measured: 0.03 N moved between nodes for a 1e-12 m
motion), and Newton's method stalls on tight knots whose strands lie side by side.

What. With ``a = x1 − x0``, ``b = x3 − x2``, ``r = x0 − x2`` and
``q(β) = r + β_i a − β_j b`` (the vector between the two contact points), the regularized squared
distance is the minimum over the unit square of a strictly convex quadratic,

    V = min over β_i, β_j in [0, 1] of  f(β) = |q(β)|² + η (|a|² (β_i − ½)² + |b|² (β_j − ½)²),

and ``Δ = √V`` (m). ``η`` (dimensionless, ``eta`` below; 0 gives the exact distance) pulls the
contact points gently towards the middle of each edge. Its effect:

* for parallel edges the minimiser is unique and moves continuously: the contact point is the
  middle of the overlap (equal edge lengths), and for an angle θ it moves towards the end of the
  overlap chosen by the exact distance over ``θ ≈ √(2η)`` (2.6° for ``η = 1e-3``), instead of
  jumping there;
* ``Δ`` exceeds the exact distance by at most ``η (|a|² + |b|²) / (8 Δ)`` (0.7 µm for 3.3 mm edges
  at Δ = 4 mm with ``η = 1e-3``, against the IMC smoothing length δ/15 = 33 µm);
* ``V`` is C¹ with a Lipschitz gradient everywhere (strict convexity in β), so the Hessian is
  bounded; it jumps only where the active set of the minimiser changes, as the exact distance
  does at its PP/PE/EE boundaries.

The active set of the minimiser gives the same case codes as the exact distance (``CASE_PP_*``: both
ratios at a bound, ``CASE_PE_*``: ``β_i`` at a bound, ``CASE_EP_*``: ``β_j`` at a bound,
``CASE_EE``: both free). The derivatives follow from the envelope theorem and the implicit function
theorem on the free ratios ``F``: ``∇V = ∂f/∂p``, ``∂β_F/∂p = −f_ββ,FF⁻¹ f_βp,F``,
``∇²V = f_pp − f_pβ,F f_ββ,FF⁻¹ f_βp,F``; then ``∇Δ = ∇V/(2Δ)`` and
``∇²Δ = ∇²V/(2Δ) − ∇Δ ∇Δᵀ/Δ``.

Degenerate input: an edge with squared length at most
:data:`~knotsim.contact.distance.MIN_LENGTH2` has its ratio fixed at 0. If ``Δ <=``
:data:`~knotsim.contact.distance.TINY_DISTANCE` the derivatives are set to zero.

Every kernel takes the 12 coordinates ``p = (x0, x1, x2, x3)`` (m) as one flat float64 array, like
:mod:`knotsim.contact.distance`, and ``eta > 0``. :class:`~knotsim.contact.model.ContactOptions`
sets ``η`` per pair from a length (``parallel_smoothing`` ℓ, default 2 µm):
``η = 8 d ℓ / (l̄_a² + l̄_b²)``, so the bias is at most about ℓ on any mesh.
"""

from __future__ import annotations

import math

from numba import njit

from knotsim import _vec3 as v3
from knotsim.contact.distance import CASE_EE, CASE_EP_0, CASE_PE_0, MIN_LENGTH2, TINY_DISTANCE
from knotsim.geometry.segments import clamp01, edge_vectors, load_edges


@njit(cache=True)
def _objective(r, d1, d2, A, B, eta, bi, bj):
    q = v3.sub(v3.axpy(bi, d1, r), v3.scale(bj, d2))
    return v3.dot(q, q) + eta * (A * (bi - 0.5) ** 2 + B * (bj - 0.5) ** 2)


@njit(cache=True)
def regularized_distance(p, eta):
    """Regularized distance of edge i ``(x0, x1)`` and edge j ``(x2, x3)``.

    Parameters
    ----------
    p : (12,) float64, the coordinates ``x0, x1, x2, x3`` (m).
    eta : regularization η > 0 (dimensionless).

    Returns
    -------
    ``(delta, beta_i, beta_j, case)``: ``Δ = √V`` (m), the minimising ratios in [0, 1] (exactly 0.0
    or 1.0 at a bound) and the case code of the active set.
    """
    x0, x1, x2, x3 = load_edges(p)
    d1, d2, r, A, B = edge_vectors(x0, x1, x2, x3)
    C = v3.dot(d1, d2)
    ra = v3.dot(r, d1)
    rb = v3.dot(r, d2)
    free_i = A > MIN_LENGTH2
    free_j = B > MIN_LENGTH2
    Ai = A * (1.0 + eta)
    Bj = B * (1.0 + eta)
    # Stationarity: Ai bi - C bj = -ra + eta A / 2 ;  -C bi + Bj bj = rb + eta B / 2
    gi = -ra + 0.5 * eta * A
    gj = rb + 0.5 * eta * B
    if free_i and free_j:
        det = Ai * Bj - C * C
        if det > 0.0:
            bi = (gi * Bj + C * gj) / det
            bj = (Ai * gj + C * gi) / det
            if 0.0 < bi < 1.0 and 0.0 < bj < 1.0:
                V = _objective(r, d1, d2, A, B, eta, bi, bj)
                return math.sqrt(max(V, 0.0)), bi, bj, CASE_EE
    # The minimum lies on the boundary of the square: minimise along each side (clamped).
    best = math.inf
    bbi = 0.0
    bbj = 0.0
    for side in range(4):
        if side < 2:  # beta_i fixed at 0 or 1, beta_j free
            si = float(side)
            if not free_i and side == 1:
                continue
            sj = clamp01((gj + C * si) / Bj) if free_j else 0.0
        else:  # beta_j fixed at 0 or 1, beta_i free
            sj = float(side - 2)
            if not free_j and side == 3:
                continue
            si = clamp01((gi + C * sj) / Ai) if free_i else 0.0
        V = _objective(r, d1, d2, A, B, eta, si, sj)
        if V < best:
            best = V
            bbi = si
            bbj = sj
    at_i = bbi == 0.0 or bbi == 1.0
    at_j = bbj == 0.0 or bbj == 1.0
    if at_i and at_j:
        case = 2 * int(bbi) + int(bbj)
    elif at_i:
        case = CASE_PE_0 + int(bbi)
    elif at_j:
        case = CASE_EP_0 + int(bbj)
    else:
        case = CASE_EE
    return math.sqrt(max(best, 0.0)), bbi, bbj, case


@njit(cache=True)
def _free_flags(case):
    """(beta_i free, beta_j free) for a case code."""
    if case == CASE_EE:
        return True, True
    if CASE_PE_0 <= case < CASE_EP_0:
        return False, True
    if CASE_EP_0 <= case < CASE_EE:
        return True, False
    return False, False


@njit(cache=True)
def _edges_and_gap(p, bi, bj):
    """Edge vectors ``d1 = x1 − x0``, ``d2 = x3 − x2`` and ``q(β) = x0 + β_i d1 − x2 − β_j d2`` (m)."""
    x0, x1, x2, x3 = load_edges(p)
    d1, d2, r, _, _ = edge_vectors(x0, x1, x2, x3)
    return d1, d2, v3.sub(v3.axpy(bi, d1, r), v3.scale(bj, d2))


@njit(cache=True)
def _mixed_blocks(p, eta, bi, bj):
    """``∂²f/∂x_k∂β_i`` and ``∂²f/∂x_k∂β_j`` (k = 0..3) as two 4-tuples of 3-vectors (m), and the
    entries ``(f_ii, f_ij, f_jj)`` of ``f_ββ`` (m²)."""
    d1, d2, q = _edges_and_gap(p, bi, bj)
    c0 = 1.0 - bi
    c1 = bi
    c2 = -(1.0 - bj)
    c3 = -bj
    wi = 4.0 * eta * (bi - 0.5)
    wj = 4.0 * eta * (bj - 0.5)
    # d/dx_k of df/dbeta_i = 2 q.a + 2 eta A (bi - 1/2)
    fi = (
        v3.sub(v3.scale(2.0 * c0, d1), v3.add(v3.scale(2.0, q), v3.scale(wi, d1))),
        v3.add(v3.scale(2.0 * c1, d1), v3.add(v3.scale(2.0, q), v3.scale(wi, d1))),
        v3.scale(2.0 * c2, d1),
        v3.scale(2.0 * c3, d1),
    )
    # d/dx_k of df/dbeta_j = -2 q.b + 2 eta B (bj - 1/2)
    fj = (
        v3.scale(-2.0 * c0, d2),
        v3.scale(-2.0 * c1, d2),
        v3.sub(v3.scale(-2.0 * c2, d2), v3.sub(v3.scale(-2.0, q), v3.scale(-wj, d2))),
        v3.add(v3.sub(v3.scale(-2.0 * c3, d2), v3.scale(2.0, q)), v3.scale(wj, d2)),
    )
    A = v3.dot(d1, d1)
    B = v3.dot(d2, d2)
    C = v3.dot(d1, d2)
    return fi, fj, 2.0 * A * (1.0 + eta), -2.0 * C, 2.0 * B * (1.0 + eta)


@njit(cache=True)
def _inverse_2x2(hii, hij, hjj):
    """Entries ``(a, b, c)`` of ``[[hii, hij], [hij, hjj]]⁻¹ = [[a, b], [b, c]]`` (``f_ββ`` is
    positive definite for ``η > 0``)."""
    det = hii * hjj - hij * hij
    return hjj / det, -hij / det, hii / det


@njit(cache=True)
def _beta_blocks(p, eta, bi, bj, case):
    """``∂β_i/∂x_k`` and ``∂β_j/∂x_k`` (k = 0..3) as two 4-tuples of 3-vectors (1/m)."""
    z = (0.0, 0.0, 0.0)
    free_i, free_j = _free_flags(case)
    if not free_i and not free_j:
        return (z, z, z, z), (z, z, z, z)
    fi, fj, hii, hij, hjj = _mixed_blocks(p, eta, bi, bj)
    if free_i and free_j:
        ia, ib, ic = _inverse_2x2(hii, hij, hjj)
        gi = (
            v3.neg(v3.add(v3.scale(ia, fi[0]), v3.scale(ib, fj[0]))),
            v3.neg(v3.add(v3.scale(ia, fi[1]), v3.scale(ib, fj[1]))),
            v3.neg(v3.add(v3.scale(ia, fi[2]), v3.scale(ib, fj[2]))),
            v3.neg(v3.add(v3.scale(ia, fi[3]), v3.scale(ib, fj[3]))),
        )
        gj = (
            v3.neg(v3.add(v3.scale(ib, fi[0]), v3.scale(ic, fj[0]))),
            v3.neg(v3.add(v3.scale(ib, fi[1]), v3.scale(ic, fj[1]))),
            v3.neg(v3.add(v3.scale(ib, fi[2]), v3.scale(ic, fj[2]))),
            v3.neg(v3.add(v3.scale(ib, fi[3]), v3.scale(ic, fj[3]))),
        )
        return gi, gj
    if free_j:
        s = -1.0 / hjj
        return (z, z, z, z), (v3.scale(s, fj[0]), v3.scale(s, fj[1]), v3.scale(s, fj[2]), v3.scale(s, fj[3]))
    s = -1.0 / hii
    return (v3.scale(s, fi[0]), v3.scale(s, fi[1]), v3.scale(s, fi[2]), v3.scale(s, fi[3])), (z, z, z, z)


@njit(cache=True)
def regularized_beta_gradients(p, eta, beta_i, beta_j, case, dbeta_i, dbeta_j):
    """``∂β_i/∂p`` and ``∂β_j/∂p`` (1/m) into the (12,) outputs ``dbeta_i``, ``dbeta_j``.

    ``beta_i, beta_j, case`` are those returned by :func:`regularized_distance` for ``p`` and
    ``eta``; a ratio at a bound has zero gradient.
    """
    gi, gj = _beta_blocks(p, eta, beta_i, beta_j, case)
    for k in range(4):
        for m in range(3):
            dbeta_i[3 * k + m] = gi[k][m]
            dbeta_j[3 * k + m] = gj[k][m]


@njit(cache=True)
def regularized_distance_derivatives(p, eta, grad, hess):
    """Regularized distance, ratios, case, and the gradient and Hessian of Δ.

    Parameters
    ----------
    p : (12,) float64 coordinates ``x0, x1, x2, x3`` (m).
    eta : regularization η > 0.
    grad : (12,) float64 output, ``∂Δ/∂p`` (dimensionless).
    hess : (12, 12) float64 output, ``∂²Δ/∂p²`` (1/m), symmetric.

    Returns
    -------
    ``(delta, beta_i, beta_j, case)`` as :func:`regularized_distance`.
    """
    delta, bi, bj, case = regularized_distance(p, eta)
    regularized_derivatives_at(p, eta, delta, bi, bj, case, grad, hess, True)
    return delta, bi, bj, case


@njit(cache=True)
def regularized_derivatives_at(p, eta, delta, bi, bj, case, grad, hess, want_hessian):
    """:func:`regularized_distance_derivatives` for a pair whose :func:`regularized_distance`
    ``(delta, bi, bj, case)`` is already known; the Hessian only when ``want_hessian`` (``hess``
    is left untouched otherwise). ``grad (12,)``, ``hess (12, 12)`` outputs as there."""
    for k in range(12):
        grad[k] = 0.0
    if want_hessian:
        for k in range(12):
            for l in range(12):
                hess[k, l] = 0.0
    if delta <= TINY_DISTANCE:
        return
    d1, d2, q = _edges_and_gap(p, bi, bj)
    c = (1.0 - bi, bi, -(1.0 - bj), -bj)
    ri = eta * (bi - 0.5) ** 2
    rj = eta * (bj - 0.5) ** 2
    # grad V = df/dp at fixed beta
    gv = (
        v3.sub(v3.scale(2.0 * c[0], q), v3.scale(2.0 * ri, d1)),
        v3.add(v3.scale(2.0 * c[1], q), v3.scale(2.0 * ri, d1)),
        v3.sub(v3.scale(2.0 * c[2], q), v3.scale(2.0 * rj, d2)),
        v3.add(v3.scale(2.0 * c[3], q), v3.scale(2.0 * rj, d2)),
    )
    # f_pp: 2 c_k c_l I + 2 eta (bi-1/2)^2 S_a + 2 eta (bj-1/2)^2 S_b, S = [[1,-1],[-1,1]] blocks
    h2 = 0.5 / delta
    for k in range(4):
        for m in range(3):
            grad[3 * k + m] = h2 * gv[k][m]
    if not want_hessian:
        return
    sa = (-1.0, 1.0, 0.0, 0.0)
    sb = (0.0, 0.0, -1.0, 1.0)
    for k in range(4):
        for l in range(4):
            w = 2.0 * (c[k] * c[l] + ri * sa[k] * sa[l] + rj * sb[k] * sb[l])
            if w != 0.0:
                v3.identity_add(hess, 3 * k, 3 * l, w)
    free_i, free_j = _free_flags(case)
    if free_i or free_j:
        fi, fj, hii, hij, hjj = _mixed_blocks(p, eta, bi, bj)
        if free_i and free_j:
            ia, ib, ic = _inverse_2x2(hii, hij, hjj)
            for k in range(4):
                for l in range(4):
                    v3.outer_add(hess, 3 * k, 3 * l, -ia, fi[k], fi[l])
                    v3.outer_add(hess, 3 * k, 3 * l, -ib, fi[k], fj[l])
                    v3.outer_add(hess, 3 * k, 3 * l, -ib, fj[k], fi[l])
                    v3.outer_add(hess, 3 * k, 3 * l, -ic, fj[k], fj[l])
        elif free_i:
            s = 1.0 / hii
            for k in range(4):
                for l in range(4):
                    v3.outer_add(hess, 3 * k, 3 * l, -s, fi[k], fi[l])
        else:
            s = 1.0 / hjj
            for k in range(4):
                for l in range(4):
                    v3.outer_add(hess, 3 * k, 3 * l, -s, fj[k], fj[l])
    # Delta = sqrt(V): grad = gV/(2 Delta) (above), hess = HV/(2 Delta) - grad grad^T / Delta
    idl = 1.0 / delta
    for k in range(12):
        for l in range(k, 12):
            h = h2 * 0.5 * (hess[k, l] + hess[l, k]) - idl * grad[k] * grad[l]
            hess[k, l] = h
            hess[l, k] = h
