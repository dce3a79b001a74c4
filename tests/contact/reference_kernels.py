"""Slow, obvious numpy/mpmath reference implementations of the contact kernels (tests only).

Nothing here is fast or clever on purpose: the references spell the formulas out literally so
that the numba kernels can be checked against an independent implementation.
"""

from __future__ import annotations

import mpmath
import numpy as np
from scipy.optimize import lsq_linear

from knotsim.contact import distance as dist


def nodes(p):
    p = np.asarray(p, dtype=float)
    return p[0:3], p[3:6], p[6:9], p[9:12]


def point_on_edges(p, bi, bj):
    """Closest-point difference vector ``q(β_i, β_j)`` of the two segments."""
    x0, x1, x2, x3 = nodes(p)
    return (x0 + bi * (x1 - x0)) - (x2 + bj * (x3 - x2))


# ---------------------------------------------------------------------------------------------
# distance


def _clamped_line_param(point, a, b):
    """Clamped parameter of the projection of ``point`` on segment a→b (0 for a degenerate edge)."""
    d = b - a
    dd = float(d @ d)
    if dd == 0.0:
        return 0.0
    return float(np.clip((point - a) @ d / dd, 0.0, 1.0))


def ref_distance_kkt(p):
    """Segment–segment distance by enumerating the KKT active sets of the box-constrained QP.

    Candidates: the unconstrained minimiser (if unique and inside the unit square) and, on each of
    the four sides of the square, the exact 1-D minimiser clamped to the side. The distance is
    evaluated directly as ``|q(β_i, β_j)|`` at every candidate; the smallest wins.

    Returns ``(delta, beta_i, beta_j)``.
    """
    x0, x1, x2, x3 = nodes(p)
    cands = []
    A = np.column_stack([x1 - x0, -(x3 - x2)])
    rhs = -(x0 - x2)
    if np.linalg.matrix_rank(A, tol=1e-13 * max(np.abs(A).max(), 1e-300)) == 2:
        sol, *_ = np.linalg.lstsq(A, rhs, rcond=None)
        if 0.0 <= sol[0] <= 1.0 and 0.0 <= sol[1] <= 1.0:
            cands.append((sol[0], sol[1]))
    cands.append((0.0, _clamped_line_param(x0, x2, x3)))
    cands.append((1.0, _clamped_line_param(x1, x2, x3)))
    cands.append((_clamped_line_param(x2, x0, x1), 0.0))
    cands.append((_clamped_line_param(x3, x0, x1), 1.0))
    vals = [np.linalg.norm(point_on_edges(p, bi, bj)) for bi, bj in cands]
    k = int(np.argmin(vals))
    return float(vals[k]), float(cands[k][0]), float(cands[k][1])


def ref_distance_bvls(p):
    """Segment–segment distance by a bounded least-squares solve (scipy ``lsq_linear``, BVLS)."""
    x0, x1, x2, x3 = nodes(p)
    A = np.column_stack([x1 - x0, -(x3 - x2)])
    rhs = -(x0 - x2)
    res = lsq_linear(A, rhs, bounds=(0.0, 1.0), method="bvls", tol=1e-14)
    bi, bj = res.x
    return float(np.linalg.norm(point_on_edges(p, bi, bj))), float(bi), float(bj)


def ref_pp(p, a, b):
    """``|x_a − x_b|`` for node numbers a, b in 0..3."""
    x = nodes(p)
    return float(np.linalg.norm(x[a] - x[b]))


def ref_pe(p, a, b, c):
    """Distance from node ``a`` to the line through nodes ``b``, ``c`` (cross-product form)."""
    x = nodes(p)
    return float(np.linalg.norm(np.cross(x[a] - x[b], x[c] - x[b])) / np.linalg.norm(x[c] - x[b]))


def ref_ee(p):
    """Line–line distance ``|(x0 − x2)·û|``, ``u = (x1 − x0) × (x3 − x2)`` (corrected eq. 4)."""
    x0, x1, x2, x3 = nodes(p)
    u = np.cross(x1 - x0, x3 - x2)
    return float(abs((x0 - x2) @ u) / np.linalg.norm(u))


def ref_case_distance(p, case):
    """The closed form of a given case code, evaluated at ``p`` (smooth across case boundaries)."""
    if case <= dist.CASE_PP_11:
        return ref_pp(p, case // 2, 2 + case % 2)
    if case == dist.CASE_PE_0:
        return ref_pe(p, 0, 2, 3)
    if case == dist.CASE_PE_1:
        return ref_pe(p, 1, 2, 3)
    if case == dist.CASE_EP_0:
        return ref_pe(p, 2, 0, 1)
    if case == dist.CASE_EP_1:
        return ref_pe(p, 3, 0, 1)
    return ref_ee(p)


def ref_case_beta(p, case):
    """Contact ratios of the closed form of a case (unclamped projections), for FD of ∂β/∂p."""
    x0, x1, x2, x3 = nodes(p)
    if case <= dist.CASE_PP_11:
        return float(case // 2), float(case % 2)
    if case in (dist.CASE_PE_0, dist.CASE_PE_1):
        xa = x0 if case == dist.CASE_PE_0 else x1
        d = x3 - x2
        return float(case - dist.CASE_PE_0), float((xa - x2) @ d / (d @ d))
    if case in (dist.CASE_EP_0, dist.CASE_EP_1):
        xb = x2 if case == dist.CASE_EP_0 else x3
        d = x1 - x0
        return float((xb - x0) @ d / (d @ d)), float(case - dist.CASE_EP_0)
    A = np.column_stack([x1 - x0, -(x3 - x2)])
    sol = np.linalg.solve(A.T @ A, A.T @ (-(x0 - x2)))
    return float(sol[0]), float(sol[1])


# ---------------------------------------------------------------------------------------------
# finite differences


def fd_gradient(fun, p, h):
    """Central-difference gradient of a scalar function."""
    p = np.asarray(p, dtype=float)
    g = np.zeros(p.size)
    for m in range(p.size):
        e = np.zeros(p.size)
        e[m] = h
        g[m] = (fun(p + e) - fun(p - e)) / (2.0 * h)
    return g


def fd_jacobian(fun, p, h):
    """Central-difference Jacobian of a vector function: column m is ∂fun/∂p_m."""
    p = np.asarray(p, dtype=float)
    cols = []
    for m in range(p.size):
        e = np.zeros(p.size)
        e[m] = h
        cols.append((np.asarray(fun(p + e)) - np.asarray(fun(p - e))) / (2.0 * h))
    return np.column_stack(cols)


def fd_hessian_2nd(fun, p, h):
    """Hessian of a scalar function from second differences of the function itself."""
    p = np.asarray(p, dtype=float)
    n = p.size
    H = np.zeros((n, n))
    f0 = fun(p)
    for a in range(n):
        ea = np.zeros(n)
        ea[a] = h
        H[a, a] = (fun(p + ea) - 2.0 * f0 + fun(p - ea)) / h**2
        for b in range(a + 1, n):
            eb = np.zeros(n)
            eb[b] = h
            v = (fun(p + ea + eb) - fun(p + ea - eb) - fun(p - ea + eb) + fun(p - ea - eb)) / (4.0 * h * h)
            H[a, b] = H[b, a] = v
    return H


# ---------------------------------------------------------------------------------------------
# IMC energy


def ref_imc_energy(delta, d, tol, dps=50):
    """IMC energy in 50-digit arithmetic: smooth softplus branch below d + δ, 0 from d + δ on."""
    with mpmath.workdps(dps):
        delta, d, tol = mpmath.mpf(delta), mpmath.mpf(d), mpmath.mpf(tol)
        if delta >= d + tol:
            return 0.0
        k1 = 15 / tol
        g = mpmath.log(1 + mpmath.exp(k1 * (d - delta))) / k1
        return float(g * g)


def ref_imc_energy_derivatives(delta, d, tol, dps=50):
    """``(E, E', E'')`` of :func:`ref_imc_energy` by mpmath differentiation of the formula."""
    with mpmath.workdps(dps):
        if mpmath.mpf(delta) >= mpmath.mpf(d) + mpmath.mpf(tol):
            return 0.0, 0.0, 0.0
        k1 = 15 / mpmath.mpf(tol)
        dd = mpmath.mpf(d)

        def f(x):
            return (mpmath.log(1 + mpmath.exp(k1 * (dd - x))) / k1) ** 2

        x = mpmath.mpf(delta)
        return float(f(x)), float(mpmath.diff(f, x, 1)), float(mpmath.diff(f, x, 2))


def ref_imc_energy_report_eq5(delta, d, tol):
    """Eq. 5 as printed (docs/physics.md §6.2) (with the ``(d − Δ)²`` branch below d − δ)."""
    k1 = 15.0 / tol
    if delta <= d - tol:
        return (d - delta) ** 2
    if delta < d + tol:
        return (np.log(1.0 + np.exp(k1 * (d - delta))) / k1) ** 2
    return 0.0


# ---------------------------------------------------------------------------------------------
# friction


def ref_gamma(s, nu):
    """``γ = 2/(1 + exp(−K2 s)) − 1``, ``K2 = 15/ν`` (the report's eq. 9, literally)."""
    return 2.0 / (1.0 + np.exp(-(15.0 / nu) * s)) - 1.0


def ref_friction(p, p_prev, dt, mu, nu, fc, beta_i, beta_j):
    """Friction on the 4 nodes (12,), docs/physics.md §3.1 with the errata of §6.3–6.4, written literally."""
    p = np.asarray(p, dtype=float)
    v = (p - np.asarray(p_prev, dtype=float)) / dt
    F = np.asarray(fc, dtype=float).reshape(4, 3)
    V = v.reshape(4, 3)
    fn = np.linalg.norm(F, axis=1)
    S = F[0] + F[1]
    if np.linalg.norm(S) == 0.0:
        return np.zeros(12)
    n = S / np.linalg.norm(S)
    vi = (1 - beta_i) * V[0] + beta_i * V[1]
    vj = (1 - beta_j) * V[2] + beta_j * V[3]
    vrel = vi - vj
    vT = vrel - (vrel @ n) * n
    s = np.linalg.norm(vT)
    if s == 0.0:
        return np.zeros(12)
    that = vT / s
    g = ref_gamma(s, nu)
    out = np.zeros((4, 3))
    out[0] = -mu * g * that * fn[0]
    out[1] = -mu * g * that * fn[1]
    out[2] = mu * g * that * fn[2]
    out[3] = mu * g * that * fn[3]
    return out.ravel()


# ---------------------------------------------------------------------------------------------
# friction at the rods' surfaces (slip, rolling and spin)


def skew(a):
    """The 3×3 matrix ``[a]×`` with ``[a]× b = a × b``."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def ref_surface_normal(fc):
    """``(n, F_n)``: unit normal ``S/|S|`` and ``F_n = |S|``, ``S = F_c,0 + F_c,1`` (the contact force
    on edge a); ``(None, 0.0)`` if ``S = 0``."""
    fc = np.asarray(fc, dtype=float)
    S = fc[0:3] + fc[3:6]
    fn = float(np.linalg.norm(S))
    if fn == 0.0:
        return None, 0.0
    return S / fn, fn


def ref_surface_velocity_map(p, ha, hb, beta_a, beta_b, n):
    """The linear maps ``ż ↦`` translational and rotational parts of ``v_pa − v_pb``, as two 3×14
    matrices ``(B_tr, B_rot)`` (``B = B_tr + B_rot``), for ``z = (x0, x1, x2, x3, θ_a, θ_b)``.

    ``v_pa = (1 − β_a) v0 + β_a v1 + Ω_a × (−h_a n)``,
    ``v_pb = (1 − β_b) v2 + β_b v3 + Ω_b × (h_b n)``, with the angular velocity of a cross-section
    ``Ω = t × (ė/l) + θ̇ t`` (``t = e/l``, ``e`` the edge vector) written as a 3×14 matrix.
    """
    x0, x1, x2, x3 = nodes(p)
    eye = np.eye(3)
    B_tr = np.zeros((3, 14))
    B_tr[:, 0:3] = (1.0 - beta_a) * eye
    B_tr[:, 3:6] = beta_a * eye
    B_tr[:, 6:9] = -(1.0 - beta_b) * eye
    B_tr[:, 9:12] = -beta_b * eye
    B_rot = np.zeros((3, 14))
    # (first node column, angle column, start node, end node, arm from the axis, sign in v_pa − v_pb)
    for c0, cth, xs, xe, arm, sign in ((0, 12, x0, x1, -ha * n, 1.0), (6, 13, x2, x3, hb * n, -1.0)):
        e = xe - xs
        l = np.linalg.norm(e)
        t = e / l
        omega = np.zeros((3, 14))  # Ω = [t]× (v_end − v_start)/l + θ̇ t
        omega[:, c0:c0 + 3] = -skew(t) / l
        omega[:, c0 + 3:c0 + 6] = skew(t) / l
        omega[:, cth] = t
        B_rot += sign * (-skew(arm) @ omega)  # Ω × arm = −arm × Ω
    return B_tr, B_rot


def ref_surface_slip(p, p_prev, theta, theta_prev, dt, ha, hb, fc, beta_a, beta_b):
    """``(F_n, B, u)``: the normal force (N), the velocity map ``B`` (3 × 14, of
    :func:`ref_surface_velocity_map`) and the surface slip ``u = (I − n nᵀ) B ż`` (m/s),
    ``ż = (z − z_prev)/dt``; ``None`` when the pair has no normal force."""
    n, fn = ref_surface_normal(fc)
    if n is None:
        return None
    zdot = np.concatenate([np.asarray(p, float) - np.asarray(p_prev, float),
                           np.asarray(theta, float) - np.asarray(theta_prev, float)]) / dt
    B_tr, B_rot = ref_surface_velocity_map(p, ha, hb, beta_a, beta_b, n)
    B = B_tr + B_rot
    return fn, B, (np.eye(3) - np.outer(n, n)) @ (B @ zdot)


def ref_stick_friction(p, p_prev, theta, theta_prev, dt, xi0, mu_limit, kappa, ha, hb, fc, beta_a, beta_b):
    """The elastic-stick law plainly: the spring ``ξ = ξ0 + u dt`` (``u`` the surface slip of
    :func:`ref_surface_slip`), ``f = −κ F_n ξ`` while ``κ|ξ| <= μ_L``, ``−μ_L F_n ξ/|ξ|`` beyond;
    ``Q = Bᵀ f`` (14,)."""
    slip = ref_surface_slip(p, p_prev, theta, theta_prev, dt, ha, hb, fc, beta_a, beta_b)
    if slip is None:
        return np.zeros(14)
    fn, B, u = slip
    xi = np.asarray(xi0, float) + dt * u
    r = np.linalg.norm(xi)
    f = -kappa * fn * xi if kappa * r <= mu_limit else -mu_limit * fn * xi / r
    return B.T @ f


def ref_surface_friction(p, p_prev, theta, theta_prev, dt, mu, nu, ha, hb, fc, beta_a, beta_b):
    """Generalised friction force ``Q = Bᵀ f`` (14,) on ``(x0, x1, x2, x3, θ_a, θ_b)``, written
    plainly from the kinematics (``B`` of :func:`ref_surface_velocity_map` as an explicit matrix):
    ``u = (I − n nᵀ) B ż``, ``f = −μ F_n tanh(K2|u|/2) u/|u|``, ``K2 = 15/ν``,
    ``ż = (z − z_prev)/dt``. ``tanh`` rather than the literal ``2/(1 + e^{−K2 s}) − 1`` of :func:`ref_gamma`, which loses its
    relative accuracy in deep stick (``K2 s`` ~ 1e-4)."""
    slip = ref_surface_slip(p, p_prev, theta, theta_prev, dt, ha, hb, fc, beta_a, beta_b)
    if slip is None:
        return np.zeros(14)
    fn, B, u = slip
    s = np.linalg.norm(u)
    if s == 0.0:
        return np.zeros(14)
    f = -mu * fn * np.tanh(0.5 * (15.0 / nu) * s) * u / s
    return B.T @ f
