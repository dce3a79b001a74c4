"""Minimum distance between two edges (segments) and its first and second derivatives.

Edge ``i`` runs from ``x0`` to ``x1`` and edge ``j`` from ``x2`` to ``x3``. Every kernel takes the
12 coordinates as one flat float64 array ``p = (x0, x1, x2, x3)`` (m). The distance is

    Δ = min over β_i, β_j in [0, 1] of |q|,   q = x0 + β_i (x1 − x0) − (x2 + β_j (x3 − x2)),

with ``β_i, β_j`` (dimensionless) the contact ratios at the minimiser. The active-set pattern of
the minimiser decides the *case* and the closed form used for the derivatives:

* point–point (both ratios at a bound), ``Δ = |x_a − x_b|`` (codes ``CASE_PP_00`` … ``CASE_PP_11``,
  the digits being ``β_i, β_j``);
* point–edge (one ratio at a bound): the distance from a node to the *line* of the other edge,
  ``Δ = |(x_a − x_b) × (x_c − x_b)| / |x_c − x_b|``. ``CASE_PE_0`` / ``CASE_PE_1``: node ``x0`` /
  ``x1`` of edge i against the interior of edge j; ``CASE_EP_0`` / ``CASE_EP_1``: node ``x2`` /
  ``x3`` of edge j against the interior of edge i;
* edge–edge (both ratios interior), ``Δ = |(x0 − x2) · û|``, ``û = u/|u|``, ``u = (x1 − x0) × (x3 − x2)``
  (docs/physics.md §2.2 with the erratum §6.1).

Each closed form is smooth inside its region, and the derivatives returned are those of the
closed form of the active case (so finite differences that straddle a case boundary may differ).

Robustness rules (all documented behaviour, never NaN):

* The global minimiser is found as follows: if the edges are not (nearly) parallel the
  unconstrained minimiser of the convex quadratic ``|q|²`` is computed; if it lies strictly inside
  the unit square it is the answer (EE). Otherwise the minimum lies on the boundary of the square
  and is the smallest of the four node-to-segment distances (each PE or PP).
* Nearly parallel: ``|u|² <= PARALLEL_SIN2 · |x1 − x0|² |x3 − x2|²`` (sin of the angle below 1e-6)
  skips the EE candidate, so (nearly) parallel edges always give a PE or PP case. For exactly
  parallel edges this is the exact minimum; at an angle θ below 1e-6 the value differs from the
  exact minimum by at most about ``(θ L)² / (2Δ)``.
* An edge with squared length at most ``MIN_LENGTH2`` (1e-200 m², i.e. shorter than 1e-100 m) is
  treated as a point: its ratio is 0 and only PP or PE cases (with the other edge as the segment)
  can occur.
* Ties between candidates keep the first one in the order x0, x1 (against edge j), x2, x3
  (against edge i); the value is the same.
* If ``|q| <= TINY_DISTANCE`` (1e-150 m) in a PP or PE case the gradient and Hessian are set to
  zero (the distance is not differentiable there). In the EE case the signed distance
  ``(x0 − x2)·û`` is smooth, so at Δ = 0 (edges that really intersect) the derivatives of the
  signed distance with sign +1 are returned.
"""

from __future__ import annotations

import math

from numba import njit

from knotsim import _vec3 as v3
from knotsim.geometry.segments import clamp01, edge_vectors, load_edges

# Case codes. PP digits are (beta_i, beta_j).
CASE_PP_00 = 0  #: point–point x0–x2 (β_i = 0, β_j = 0)
CASE_PP_01 = 1  #: point–point x0–x3 (β_i = 0, β_j = 1)
CASE_PP_10 = 2  #: point–point x1–x2 (β_i = 1, β_j = 0)
CASE_PP_11 = 3  #: point–point x1–x3 (β_i = 1, β_j = 1)
CASE_PE_0 = 4  #: node x0 of edge i (β_i = 0) against the interior of edge j
CASE_PE_1 = 5  #: node x1 of edge i (β_i = 1) against the interior of edge j
CASE_EP_0 = 6  #: node x2 of edge j (β_j = 0) against the interior of edge i
CASE_EP_1 = 7  #: node x3 of edge j (β_j = 1) against the interior of edge i
CASE_EE = 8  #: edge–edge, both ratios interior
N_CASES = 9

#: sin² of the angle below which two edges count as parallel (no EE case).
PARALLEL_SIN2 = 1e-12
#: squared edge length (m²) at or below which an edge is treated as a point.
MIN_LENGTH2 = 1e-200
#: distance (m) at or below which PP/PE derivatives are set to zero.
TINY_DISTANCE = 1e-150

_CASE_NAMES = (
    "PP(x0,x2)",
    "PP(x0,x3)",
    "PP(x1,x2)",
    "PP(x1,x3)",
    "PE(x0,edge j)",
    "PE(x1,edge j)",
    "PE(x2,edge i)",
    "PE(x3,edge i)",
    "EE",
)


def case_name(case: int) -> str:
    """Human-readable name of a case code, e.g. ``"PE(x1,edge j)"``."""
    case = int(case)
    if 0 <= case < N_CASES:
        return _CASE_NAMES[case]
    raise ValueError(f"unknown contact case code {case}")


def case_kind(case: int) -> str:
    """``"PP"``, ``"PE"`` or ``"EE"`` for a case code."""
    case = int(case)
    if 0 <= case <= CASE_PP_11:
        return "PP"
    if CASE_PE_0 <= case <= CASE_EP_1:
        return "PE"
    if case == CASE_EE:
        return "EE"
    raise ValueError(f"unknown contact case code {case}")


@njit(cache=True)
def _point_segment(x, a, d, dd):
    """Clamped ratio and squared distance from point ``x`` to segment ``a + t d`` (``dd = d·d``)."""
    if dd <= MIN_LENGTH2:
        t = 0.0
    else:
        t = clamp01(v3.dot(v3.sub(x, a), d) / dd)
    w = v3.sub(v3.sub(x, a), v3.scale(t, d))
    return t, v3.dot(w, w)


@njit(cache=True)
def _case_code(bi, bj):
    at_i = bi == 0.0 or bi == 1.0
    at_j = bj == 0.0 or bj == 1.0
    if at_i and at_j:
        return 2 * int(bi) + int(bj)
    if at_i:
        return CASE_PE_0 + int(bi)
    if at_j:
        return CASE_EP_0 + int(bj)
    return CASE_EE


@njit(cache=True)
def edge_edge_distance(p):
    """Minimum distance between edge i ``(x0, x1)`` and edge j ``(x2, x3)``.

    Parameters
    ----------
    p : (12,) float64, the coordinates ``x0, x1, x2, x3`` (m).

    Returns
    -------
    delta : float, Δ (m), evaluated with the closed form of the case.
    beta_i, beta_j : float, contact ratios in [0, 1] (exactly 0.0 or 1.0 at a bound).
    case : int, one of the ``CASE_*`` codes.
    """
    x0, x1, x2, x3 = load_edges(p)
    d1, d2, r, a, e = edge_vectors(x0, x1, x2, x3)
    u = v3.cross(d1, d2)
    D = v3.dot(u, u)
    if a > MIN_LENGTH2 and e > MIN_LENGTH2 and D > PARALLEL_SIN2 * a * e:
        b = v3.dot(d1, d2)
        c = v3.dot(d1, r)
        f = v3.dot(d2, r)
        s = (b * f - c * e) / D
        t = (a * f - b * c) / D
        if 0.0 < s < 1.0 and 0.0 < t < 1.0:
            delta = abs(v3.dot(r, u)) / math.sqrt(D)
            return delta, s, t, CASE_EE
    # Boundary of the unit square: the four node-to-segment distances.
    t0, q0 = _point_segment(x0, x2, d2, e)
    t1, q1 = _point_segment(x1, x2, d2, e)
    s2, q2 = _point_segment(x2, x0, d1, a)
    s3, q3 = _point_segment(x3, x0, d1, a)
    bi = 0.0
    bj = t0
    best = q0
    if q1 < best:
        bi = 1.0
        bj = t1
        best = q1
    if q2 < best:
        bi = s2
        bj = 0.0
        best = q2
    if q3 < best:
        bi = s3
        bj = 1.0
        best = q3
    case = _case_code(bi, bj)
    if case <= CASE_PP_11:
        xa = x1 if bi == 1.0 else x0
        xb = x3 if bj == 1.0 else x2
        delta = v3.norm(v3.sub(xa, xb))
    elif case <= CASE_PE_1:
        xa = x1 if bi == 1.0 else x0
        delta = v3.norm(v3.cross(v3.sub(xa, x2), d2)) / math.sqrt(e)
    else:
        xb = x3 if bj == 1.0 else x2
        delta = v3.norm(v3.cross(v3.sub(xb, x0), d1)) / math.sqrt(a)
    return delta, bi, bj, case


@njit(cache=True)
def _beta_blocks(p, bi, bj, case):
    """∂β_i/∂x_l and ∂β_j/∂x_l (l = 0..3) as two 4-tuples of 3-vectors (1/m)."""
    x0, x1, x2, x3 = load_edges(p)
    d1, d2, _, _, _ = edge_vectors(x0, x1, x2, x3)
    z = (0.0, 0.0, 0.0)
    if case <= CASE_PP_11:
        return (z, z, z, z), (z, z, z, z)
    q = v3.sub(v3.axpy(bi, d1, x0), v3.axpy(bj, d2, x2))
    # Stationarity conditions F1 = q·d1 = 0 (beta_i free), F2 = q·d2 = 0 (beta_j free); their
    # partial derivatives with respect to x0..x3 at fixed beta:
    f10 = v3.sub(v3.scale(1.0 - bi, d1), q)
    f11 = v3.add(v3.scale(bi, d1), q)
    f12 = v3.scale(-(1.0 - bj), d1)
    f13 = v3.scale(-bj, d1)
    f20 = v3.scale(1.0 - bi, d2)
    f21 = v3.scale(bi, d2)
    f22 = v3.sub(v3.scale(-(1.0 - bj), d2), q)
    f23 = v3.add(v3.scale(-bj, d2), q)
    if case <= CASE_PE_1:
        # beta_i fixed, beta_j free: d(beta_j) = dF2 / |d2|^2
        ie = 1.0 / v3.dot(d2, d2)
        return (z, z, z, z), (v3.scale(ie, f20), v3.scale(ie, f21), v3.scale(ie, f22), v3.scale(ie, f23))
    if case <= CASE_EP_1:
        # beta_j fixed, beta_i free: d(beta_i) = -dF1 / |d1|^2
        ia = -1.0 / v3.dot(d1, d1)
        return (v3.scale(ia, f10), v3.scale(ia, f11), v3.scale(ia, f12), v3.scale(ia, f13)), (z, z, z, z)
    a = v3.dot(d1, d1)
    e = v3.dot(d2, d2)
    b = v3.dot(d1, d2)
    u = v3.cross(d1, d2)
    iD = 1.0 / v3.dot(u, u)
    # [dbi, dbj] = (1/D) [-e dF1 + b dF2, -b dF1 + a dF2],  D = a e - b^2 = |u|^2
    gi = (
        v3.scale(iD, v3.add(v3.scale(-e, f10), v3.scale(b, f20))),
        v3.scale(iD, v3.add(v3.scale(-e, f11), v3.scale(b, f21))),
        v3.scale(iD, v3.add(v3.scale(-e, f12), v3.scale(b, f22))),
        v3.scale(iD, v3.add(v3.scale(-e, f13), v3.scale(b, f23))),
    )
    gj = (
        v3.scale(iD, v3.add(v3.scale(-b, f10), v3.scale(a, f20))),
        v3.scale(iD, v3.add(v3.scale(-b, f11), v3.scale(a, f21))),
        v3.scale(iD, v3.add(v3.scale(-b, f12), v3.scale(a, f22))),
        v3.scale(iD, v3.add(v3.scale(-b, f13), v3.scale(a, f23))),
    )
    return gi, gj


@njit(cache=True)
def edge_edge_beta_gradients(p, beta_i, beta_j, case, dbeta_i, dbeta_j):
    """Gradients of the contact ratios for the active case.

    Parameters
    ----------
    p : (12,) float64 coordinates (m).
    beta_i, beta_j, case : as returned by :func:`edge_edge_distance` for this ``p``.
    dbeta_i, dbeta_j : (12,) float64 outputs, ``∂β_i/∂p`` and ``∂β_j/∂p`` (1/m). A ratio at a bound
        (0 or 1) has zero gradient; free ratios follow from the implicit function theorem applied
        to the stationarity conditions of the active case.
    """
    gi, gj = _beta_blocks(p, beta_i, beta_j, case)
    for l in range(4):
        for m in range(3):
            dbeta_i[3 * l + m] = gi[l][m]
            dbeta_j[3 * l + m] = gj[l][m]


@njit(cache=True)
def edge_edge_distance_derivatives(p, grad, hess):
    """Distance, ratios, case, and the gradient and Hessian of Δ for the active case.

    Parameters
    ----------
    p : (12,) float64 coordinates ``x0, x1, x2, x3`` (m).
    grad : (12,) float64 output, ``∂Δ/∂p`` (dimensionless).
    hess : (12, 12) float64 output, ``∂²Δ/∂p²`` (1/m), symmetric.

    Returns
    -------
    ``(delta, beta_i, beta_j, case)`` as :func:`edge_edge_distance`.

    Notes
    -----
    With ``c = (1 − β_i, β_i, −(1 − β_j), −β_j)`` and ``q̂`` the unit vector from the closest point of
    edge j to that of edge i, ``∂Δ/∂x_k = c_k q̂`` in every case (envelope theorem). The Hessian is
    ``q̂ ⊗ ∂c_k/∂x_l + c_k ∂q̂/∂x_l``, with ``∂q̂ = (I − q̂q̂ᵀ) dq / |q|`` for PP and PE, and, for EE,
    ``q̂ = ±û`` so that ``∂q̂ = ±(I − ûûᵀ) du / |u|`` (finite even at Δ = 0).
    """
    delta, bi, bj, case = edge_edge_distance(p)
    for k in range(12):
        grad[k] = 0.0
        for l in range(12):
            hess[k, l] = 0.0
    x0, x1, x2, x3 = load_edges(p)
    d1, d2, _, _, _ = edge_vectors(x0, x1, x2, x3)
    c = (1.0 - bi, bi, -(1.0 - bj), -bj)
    # d c_k / d beta_i and d c_k / d beta_j
    si = (-1.0, 1.0, 0.0, 0.0)
    sj = (0.0, 0.0, 1.0, -1.0)
    gi, gj = _beta_blocks(p, bi, bj, case)
    if case == CASE_EE:
        u = v3.cross(d1, d2)
        nu = v3.norm(u)
        uh = v3.scale(1.0 / nu, u)
        sig = 1.0 if v3.dot(v3.sub(x0, x2), uh) >= 0.0 else -1.0
        qh = v3.scale(sig, uh)
        # du/dx_l = s_l [a_l]x
        avec = (d2, d2, d1, d1)
        asgn = (1.0, -1.0, -1.0, 1.0)
        for k in range(4):
            for m in range(3):
                grad[3 * k + m] = c[k] * qh[m]
        for k in range(4):
            for l in range(4):
                al = avec[l]
                w = sig * c[k] * asgn[l] / nu
                # (I - uh uh^T)[a]x = [a]x - uh (uh x a)^T
                v3.skew_add(hess, 3 * k, 3 * l, w, al)
                v3.outer_add(hess, 3 * k, 3 * l, -w, uh, v3.cross(uh, al))
                dc = v3.add(v3.scale(si[k], gi[l]), v3.scale(sj[k], gj[l]))
                v3.outer_add(hess, 3 * k, 3 * l, 1.0, qh, dc)
    else:
        q = v3.sub(v3.axpy(bi, d1, x0), v3.axpy(bj, d2, x2))
        qn = v3.norm(q)
        if qn <= TINY_DISTANCE:
            return delta, bi, bj, case
        qh = v3.scale(1.0 / qn, q)
        iq = 1.0 / qn
        pd1 = v3.axpy(-v3.dot(qh, d1), qh, d1)
        pd2 = v3.axpy(-v3.dot(qh, d2), qh, d2)
        for k in range(4):
            for m in range(3):
                grad[3 * k + m] = c[k] * qh[m]
        for k in range(4):
            for l in range(4):
                w = c[k] * c[l] * iq
                if w != 0.0:
                    v3.identity_add(hess, 3 * k, 3 * l, w)
                    v3.outer_add(hess, 3 * k, 3 * l, -w, qh, qh)
                ck = c[k] * iq
                v3.outer_add(hess, 3 * k, 3 * l, ck, pd1, gi[l])
                v3.outer_add(hess, 3 * k, 3 * l, -ck, pd2, gj[l])
                dc = v3.add(v3.scale(si[k], gi[l]), v3.scale(sj[k], gj[l]))
                v3.outer_add(hess, 3 * k, 3 * l, 1.0, qh, dc)
    for k in range(12):
        for l in range(k + 1, 12):
            h = 0.5 * (hess[k, l] + hess[l, k])
            hess[k, l] = h
            hess[l, k] = h
    return delta, bi, bj, case
