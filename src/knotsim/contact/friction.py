"""Smooth Coulomb friction of one contact pair, fully implicit (Tong, Choi, Joo, Jawed 2022).

The law of docs/physics.md §3.1 with the errata of §6.3–6.4 applied. For edge i (nodes ``x0, x1``) and edge j
(nodes ``x2, x3``), all evaluated at the Newton iterate ``p`` with velocities
``v = (p − p_prev)/dt`` (m/s):

* normal force magnitudes ``F_n,a = |F_c,a|`` (N) from the contact force on each node;
* contact normal ``n = (F_c,0 + F_c,1) / |F_c,0 + F_c,1|`` (points from edge j towards edge i);
* contact-point velocities ``v_i^e = (1 − β_i) v_0 + β_i v_1``, ``v_j^e = (1 − β_j) v_2 + β_j v_3``;
* relative velocity ``v_rel = v_i^e − v_j^e``, tangential part ``v_T = v_rel − (v_rel·n) n``;
* ``γ(s) = 2/(1 + exp(−K2 s)) − 1 = tanh(K2 s/2)``, ``K2 = 15/ν``;
* friction on node ``a`` of edge i: ``−μ γ(|v_T|) v̂_T F_n,a``; on node ``a`` of edge j:
  ``+μ γ(|v_T|) v̂_T F_n,a``.

``γ v̂_T`` is written ``φ(|v_T|) v_T`` with ``φ(s) = tanh(K2 s/2)/s`` (s/m), smooth and even in
``s`` (a Taylor series is used for ``K2 s/2 < 0.02``), so the force and its Jacobian are smooth at
``v_T = 0``: there the force is zero and the Jacobian is ``−μ (K2/2) F_n,a ∂v_T/∂p`` (viscous-like
sticking).

The Jacobian ``∂F_fr/∂p`` (N/m, ``p_prev`` and ``dt`` fixed) includes the dependence through the
velocities, through the contact ratios (``∂β/∂p``), through the normal ``n`` and the magnitudes
``F_n,a`` (chain rule through ``∂F_c/∂p``). Where a node force is exactly zero its magnitude has no
derivative; the zero subgradient is used. If ``|F_c,0 + F_c,1| <= TINY_FORCE`` the friction and
its Jacobian are zero (no normal direction; the friction, being proportional to the normal force,
tends to zero there anyway — for IMC forces ``|F_c,0 + F_c,1| = F_n,0 + F_n,1``).
"""

from __future__ import annotations

import math

from numba import njit

from knotsim import _vec3 as v3

#: K2 = FRICTION_SHARPNESS / ν.
FRICTION_SHARPNESS = 15.0
#: Below this |F_c,0 + F_c,1| (N) the pair carries no friction.
TINY_FORCE = 1e-300
_SERIES_X = 0.02


@njit(cache=True)
def slip_functions(s, nu):
    """Smooth stick-slip switch for a tangential speed ``s >= 0`` (m/s), slip tolerance ``nu`` (m/s).

    Returns ``(gamma, phi, psi)``: ``γ(s) = tanh(K2 s/2)`` (dimensionless), ``φ(s) = γ(s)/s`` (s/m;
    ``K2/2`` at ``s = 0``) and ``ψ(s) = φ'(s)/s`` (s³/m³; ``−(2/3)(K2/2)³`` at ``s = 0``).
    """
    k = 0.5 * FRICTION_SHARPNESS / nu
    x = k * s
    if x < _SERIES_X:
        x2 = x * x
        t = 1.0 + x2 * (-1.0 / 3.0 + x2 * (2.0 / 15.0 + x2 * (-17.0 / 315.0 + x2 * (62.0 / 2835.0))))
        tp = -2.0 / 3.0 + x2 * (
            8.0 / 15.0 + x2 * (-34.0 / 105.0 + x2 * (496.0 / 2835.0 - x2 * (2764.0 / 31185.0)))
        )
        return x * t, k * t, k * k * k * tp
    th = math.tanh(x)
    em = math.exp(-2.0 * x)
    sech2 = 4.0 * em / ((1.0 + em) * (1.0 + em))
    return th, th / s, k * k * k * (x * sech2 - th) / (x * x * x)


@njit(cache=True)
def slip_potential(s, nu):
    """Dissipation potential of the smooth law per unit normal force and time, ``Γ(s) = ln cosh(k s)/k``
    (m/s) with ``k = K2/2`` (s/m), for a tangential speed ``s >= 0`` (m/s): ``Γ' = γ = tanh(k s)``, so
    ``μ F_n dt Γ(|u|)`` (J) is the potential whose gradient in the slip ``u dt`` is the friction
    force's magnitude ``μ F_n γ`` along ``û`` (a series is used for ``k s < 0.02``, and a form without
    cancellation up to ``k s = 20``)."""
    k = 0.5 * FRICTION_SHARPNESS / nu
    x = k * s
    if x < _SERIES_X:
        x2 = x * x
        return x2 * (0.5 + x2 * (-1.0 / 12.0 + x2 * (1.0 / 45.0))) / k
    if x < 20.0:  # ln cosh x = ln(1 + (cosh x − 1)), cosh x − 1 = expm1(x)²/(2 eˣ): no cancellation
        em = math.expm1(x)
        return math.log1p(em * em / (2.0 * (1.0 + em))) / k
    return (x - math.log(2.0) + math.log1p(math.exp(-2.0 * x))) / k


@njit(cache=True)
def stick_functions(r, mu_limit, kappa):
    """Elastic-stick law of a tangential spring displacement ``r = |ξ| >= 0`` (m): the friction per unit
    normal force is ``−φ(r) ξ`` with ``φ = κ`` (1/m) while ``κ r <= μ_L`` (sticking, an elastic spring)
    and ``φ = μ_L / r`` beyond (sliding at the limit ``μ_L``). Returns ``(φ, ψ)`` with ``ψ = φ'(r)/r``
    (0 while sticking, ``−μ_L/r³`` beyond; 1/m³). ``kappa`` (1/m) is ``μ_k/δ_s``, ``mu_limit`` the
    limit coefficient ``μ_L`` (μ_s for a sticking contact, μ_k for a sliding one; docs/physics.md §3.6)."""
    if kappa * r <= mu_limit:
        return kappa, 0.0
    return mu_limit / r, -mu_limit / (r * r * r)


@njit(cache=True)
def stick_potential(r, mu_limit, kappa):
    """Potential of :func:`stick_functions` per unit normal force (m): ``H(r) = κ r²/2`` while
    ``κ r <= μ_L``, ``μ_L r − μ_L²/(2κ)`` beyond (``H' = φ r``; convex and C¹)."""
    if kappa * r <= mu_limit:
        return 0.5 * kappa * r * r
    return mu_limit * r - 0.5 * mu_limit * mu_limit / kappa


@njit(inline="always", cache=True)
def law_force(kappa, xi0, u, s, dt, mu, nu, mu_limit, fn):
    """The friction force of the surface laws for a slip ``u`` (3-tuple, m/s, ``s = |u|``) and a normal
    force ``fn`` (N): the elastic-stick law (``kappa > 0``, 1/m) on the spring ``ξ = xi0 + u dt``
    (``xi0`` a 3-tuple, m; limit ``mu_limit``), ``f = −F_n φ(|ξ|) ξ``, or else the smooth law of ``mu``
    and ``nu``, ``f = −μ F_n φ(s) u``.

    Returns ``(vec, φ, ψ, f)``: the vector the law is a function of (``ξ`` or ``u``), the law's
    ``φ`` and ``ψ = φ'/r`` at its length, and ``f`` (N); :func:`law_force_dot` takes them back."""
    if kappa > 0.0:
        vec = v3.add(xi0, v3.scale(dt, u))
        phi, psi = stick_functions(v3.norm(vec), mu_limit, kappa)
        return vec, phi, psi, v3.scale(-fn * phi, vec)
    _, phi, psi = slip_functions(s, nu)
    return u, phi, psi, v3.scale(-mu * fn * phi, u)


@njit(inline="always", cache=True)
def law_force_dot(kappa, dt, mu, fn, dfn, phi, psi, vec, du):
    """Directional derivative of :func:`law_force`'s ``f`` given those of the normal force ``dfn``
    (N) and of the slip ``du`` (m/s): ``−[dF_n φ ξ + F_n (φ dξ + ψ (ξ·dξ) ξ)]`` with ``dξ = dt du``
    (stick), or ``−μ [dF_n φ u + F_n (φ du + ψ (u·du) u)]`` (smooth)."""
    if kappa > 0.0:
        dvec = v3.scale(dt, du)
        vdv = v3.dot(vec, dvec)
        return v3.scale(-1.0, v3.add(v3.scale(dfn * phi, vec),
                                     v3.scale(fn, v3.add(v3.scale(phi, dvec), v3.scale(psi * vdv, vec)))))
    udu = v3.dot(vec, du)
    return v3.scale(-mu, v3.add(v3.scale(dfn * phi, vec),
                                v3.scale(fn, v3.add(v3.scale(phi, du), v3.scale(psi * udu, vec)))))


@njit(cache=True)
def friction_pair(p, p_prev, dt, mu, nu, fc, dfc, beta_i, beta_j, dbeta_i, dbeta_j, force_out, jac_out,
                  want_jacobian=True):
    """Friction force on the 4 nodes of a contact pair and its exact Jacobian.

    Parameters
    ----------
    p : (12,) float64, node positions ``x0, x1`` (edge i), ``x2, x3`` (edge j) at the iterate (m).
    p_prev : (12,) float64, the same nodes at the start of the step (m).
    dt : time step (s).
    mu : friction coefficient (dimensionless).
    nu : slip tolerance ν (m/s), ``K2 = 15/ν``.
    fc : (12,) float64, contact force on the 4 nodes at ``p`` (N), ``−k_c ∇E``.
    dfc : (12, 12) float64, its Jacobian ``∂fc/∂p`` (N/m), ``−k_c ∇²E``.
    beta_i, beta_j : contact ratios at ``p``.
    dbeta_i, dbeta_j : (12,) float64, ``∂β/∂p`` (1/m) for the active case.
    force_out : (12,) float64 output, friction force (N).
    jac_out : (12, 12) float64 output, ``∂force_out/∂p`` (N/m) at fixed ``p_prev``, ``dt``.
    want_jacobian : when ``False`` only ``force_out`` is computed (``dfc``, ``dbeta_*`` and
        ``jac_out`` are not touched), for residual-only evaluations.
    """
    f0 = v3.load(fc, 0)
    f1 = v3.load(fc, 3)
    f2 = v3.load(fc, 6)
    f3 = v3.load(fc, 9)
    S = v3.add(f0, f1)
    sn = v3.norm(S)
    if not sn > TINY_FORCE:
        for r in range(12):
            force_out[r] = 0.0
            if want_jacobian:
                for m in range(12):
                    jac_out[r, m] = 0.0
        return
    n = v3.scale(1.0 / sn, S)
    fn = (v3.norm(f0), v3.norm(f1), v3.norm(f2), v3.norm(f3))
    idt = 1.0 / dt
    v0 = v3.scale(idt, v3.sub(v3.load(p, 0), v3.load(p_prev, 0)))
    v1 = v3.scale(idt, v3.sub(v3.load(p, 3), v3.load(p_prev, 3)))
    v2 = v3.scale(idt, v3.sub(v3.load(p, 6), v3.load(p_prev, 6)))
    v3_ = v3.scale(idt, v3.sub(v3.load(p, 9), v3.load(p_prev, 9)))
    vi = v3.add(v3.scale(1.0 - beta_i, v0), v3.scale(beta_i, v1))
    vj = v3.add(v3.scale(1.0 - beta_j, v2), v3.scale(beta_j, v3_))
    vrel = v3.sub(vi, vj)
    vn = v3.dot(vrel, n)
    vT = v3.axpy(-vn, n, vrel)
    s = v3.norm(vT)
    _, phi, psi = slip_functions(s, nu)
    w = v3.scale(mu * phi, vT)
    sgn = (1.0, 1.0, -1.0, -1.0)
    c = (1.0 - beta_i, beta_i, -(1.0 - beta_j), -beta_j)
    for a in range(4):
        for r in range(3):
            force_out[3 * a + r] = -sgn[a] * fn[a] * w[r]
    if not want_jacobian:
        return
    # unit node-force directions (zero subgradient for a zero node force)
    fh = (
        v3.scale(1.0 / fn[0] if fn[0] > 0.0 else 0.0, f0),
        v3.scale(1.0 / fn[1] if fn[1] > 0.0 else 0.0, f1),
        v3.scale(1.0 / fn[2] if fn[2] > 0.0 else 0.0, f2),
        v3.scale(1.0 / fn[3] if fn[3] > 0.0 else 0.0, f3),
    )
    dvi = v3.sub(v1, v0)  # d v_i^e / d beta_i
    dvj = v3.sub(v3_, v2)  # d v_j^e / d beta_j
    isn = 1.0 / sn
    # d w = C d v_rel - D dS (3x3 matrices, row-major 9-tuples), from
    #   d n = (I - n n^T) dS / |S|,   d vT = P d v_rel - n (v_rel . dn) - (v_rel . n) dn,
    #   d w = mu (phi d vT + psi vT (vT . d vT)) = A d vT:
    # C = A P and D = A (n vT^T + vn P) / |S| with P = I - n n^T, A = mu (phi I + psi vT vT^T)
    P = _projector(n)
    A = (mu * (phi + psi * vT[0] * vT[0]), mu * psi * vT[0] * vT[1], mu * psi * vT[0] * vT[2],
         mu * psi * vT[1] * vT[0], mu * (phi + psi * vT[1] * vT[1]), mu * psi * vT[1] * vT[2],
         mu * psi * vT[2] * vT[0], mu * psi * vT[2] * vT[1], mu * (phi + psi * vT[2] * vT[2]))
    C = _mat3_mul(A, P)
    G = (isn * (n[0] * vT[0] + vn * P[0]), isn * (n[0] * vT[1] + vn * P[1]), isn * (n[0] * vT[2] + vn * P[2]),
         isn * (n[1] * vT[0] + vn * P[3]), isn * (n[1] * vT[1] + vn * P[4]), isn * (n[1] * vT[2] + vn * P[5]),
         isn * (n[2] * vT[0] + vn * P[6]), isn * (n[2] * vT[1] + vn * P[7]), isn * (n[2] * vT[2] + vn * P[8]))
    D = _mat3_mul(A, G)
    cvi = _mat3_vec(C, dvi)
    cvj = _mat3_vec(C, dvj)
    for m in range(12):
        b = m // 3
        kk = m - 3 * b
        cb = c[b] * idt  # d v_rel / d p_m = cb e_kk + dbeta_i dvi - dbeta_j dvj
        bi_m = dbeta_i[m]
        bj_m = dbeta_j[m]
        dS0 = dfc[0, m] + dfc[3, m]
        dS1 = dfc[1, m] + dfc[4, m]
        dS2 = dfc[2, m] + dfc[5, m]
        dw0 = cb * C[kk] + bi_m * cvi[0] - bj_m * cvj[0] - (D[0] * dS0 + D[1] * dS1 + D[2] * dS2)
        dw1 = cb * C[3 + kk] + bi_m * cvi[1] - bj_m * cvj[1] - (D[3] * dS0 + D[4] * dS1 + D[5] * dS2)
        dw2 = cb * C[6 + kk] + bi_m * cvi[2] - bj_m * cvj[2] - (D[6] * dS0 + D[7] * dS1 + D[8] * dS2)
        for a in range(4):
            fha = fh[a]
            dfn = fha[0] * dfc[3 * a, m] + fha[1] * dfc[3 * a + 1, m] + fha[2] * dfc[3 * a + 2, m]
            sa = -sgn[a]
            fa = fn[a]
            jac_out[3 * a, m] = sa * (w[0] * dfn + fa * dw0)
            jac_out[3 * a + 1, m] = sa * (w[1] * dfn + fa * dw1)
            jac_out[3 * a + 2, m] = sa * (w[2] * dfn + fa * dw2)


@njit(cache=True)
def _projector(n):
    """``I - n n^T`` (row-major 9-tuple) for a unit 3-vector ``n``."""
    return (1.0 - n[0] * n[0], -n[0] * n[1], -n[0] * n[2],
            -n[1] * n[0], 1.0 - n[1] * n[1], -n[1] * n[2],
            -n[2] * n[0], -n[2] * n[1], 1.0 - n[2] * n[2])


@njit(cache=True)
def _mat3_mul(A, B):
    """Product of two 3x3 matrices given as row-major 9-tuples."""
    return (A[0] * B[0] + A[1] * B[3] + A[2] * B[6], A[0] * B[1] + A[1] * B[4] + A[2] * B[7],
            A[0] * B[2] + A[1] * B[5] + A[2] * B[8],
            A[3] * B[0] + A[4] * B[3] + A[5] * B[6], A[3] * B[1] + A[4] * B[4] + A[5] * B[7],
            A[3] * B[2] + A[4] * B[5] + A[5] * B[8],
            A[6] * B[0] + A[7] * B[3] + A[8] * B[6], A[6] * B[1] + A[7] * B[4] + A[8] * B[7],
            A[6] * B[2] + A[7] * B[5] + A[8] * B[8])


@njit(cache=True)
def _mat3_vec(A, x):
    """``A x`` for a 3x3 row-major 9-tuple ``A`` and a 3-vector ``x``."""
    return (A[0] * x[0] + A[1] * x[1] + A[2] * x[2], A[3] * x[0] + A[4] * x[1] + A[5] * x[2],
            A[6] * x[0] + A[7] * x[1] + A[8] * x[2])
