"""Numba kernels of surface friction against rigid obstacles: rolling and spinning nodes, free spin.

The law of ``docs/_obstacle_surface_friction.md`` (to be merged into docs/physics.md). A node
``x_i`` (radius ``h``) touches an obstacle with unit normal ``n`` (from the obstacle to the node)
and normal force ``F_n = −k_c E'(Δ)`` (N), exactly as in :mod:`knotsim.contact.obstacle_kernels`.
Its stencil has 11 unknowns, laid out like a bending stencil (``Model.bend_dofs``)::

    z = (x_{i−1} (3), θ_A, x_i (3), θ_B, x_{i+1} (3))      (m, rad)

with edge ``A = (x_{i−1}, x_i)`` and edge ``B = (x_i, x_{i+1})``. Each edge carries a weight
``w_A, w_B``: ``½, ½`` at an interior node (and at every node of a closed rod), ``1, 0`` or ``0, 1``
at an open rod's end node, whose missing edge's slots are padding (unknowns of the same rod nearby,
with zero force and zero Jacobian). At the Newton iterate, with ``ż = (z − z_prev)/dt``:

* edge angular velocity ``Ω_e = t_e × ė_e / l_e + θ̇_e t_e`` (time-parallel reference frames), and
  the cross-section's at the node ``Ω_i = w_A Ω_A + w_B Ω_B`` (rad/s);
* surface point ``y = x_i − h n``, its velocity ``v_s = v_i + Ω_i × (−h n)`` (m/s);
* slip ``u = (I − n nᵀ)(v_s − w(y))`` with the obstacle's surface velocity
  ``w(y) = vel + ω × (y − c)``; friction on the rod's surface point ``f = −μ F_n φ(|u|) u`` (N),
  the smooth law of :mod:`knotsim.contact.friction`;
* generalised forces by virtual power, ``Q = Bᵀ f`` with ``B`` the linear map ``ż ↦ v_s``:
  ``Q_{x_i} = f + g_A − g_B``, ``Q_{x_{i−1}} = −g_A``, ``Q_{x_{i+1}} = g_B`` with the lever-arm
  forces ``g_e = −(h w_e / l_e) [(n·t_e) f − (f·t_e) n]``, and ``Q_{θ_e} = −h w_e (t_e × n)·f``
  (N m). ``Q·ż = f·v_s``, so the power of friction on rods and obstacle, ``f·(v_s − w) = f·u``, is
  never positive.

The Jacobian ``∂Q/∂z`` (z_prev, dt fixed) is exact, computed column by column by forward-mode
directional derivatives of every intermediate quantity (through ``n``, ``F_n``, the tangents, the
lengths and ``y``). :func:`spin_update` advances a free-spinning obstacle (see its docstring).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from knotsim import _vec3 as v3
from knotsim.contact.friction import FRICTION_SHARPNESS, law_force, law_force_dot, slip_functions
from knotsim.contact.obstacle_kernels import node_distance, store_node
from knotsim.contact.potential import imc_energy_derivatives
from knotsim.contact.surface_friction import (
    edge_dot,
    lever_force,
    lever_force_dot,
    lever_velocity,
    lever_velocity_dot,
    tangential_dot,
)

#: Unknowns of a node's surface-friction stencil: x_{i−1}, θ_A, x_i, θ_B, x_{i+1}.
STENCIL = 11
_ZERO = (0.0, 0.0, 0.0)


@njit(cache=True)
def _edge(z, zp, a, b, th, w, h, idt):
    """Tangent ``t``, length ``l`` (m), edge rate ``ė`` (m/s), spin ``θ̇`` (rad/s) and ``c = h w / l``
    of the edge from stencil slot ``a`` to slot ``b`` (angle slot ``th``); zeros when ``w == 0``."""
    if not w > 0.0:
        return _ZERO, 1.0, _ZERO, 0.0, 0.0
    e = (z[b] - z[a], z[b + 1] - z[a + 1], z[b + 2] - z[a + 2])
    ep = (zp[b] - zp[a], zp[b + 1] - zp[a + 1], zp[b + 2] - zp[a + 2])
    l = v3.norm(e)
    return v3.scale(1.0 / l, e), l, v3.scale(idt, v3.sub(e, ep)), (z[th] - zp[th]) * idt, h * w / l


@njit(cache=True)
def node_surface_contact(kind, z, zp, wA, wB, dt, geom, h, tol, k_c, mu, nu, vel, omega, center, force, jac,
                         want_jacobian, gr, H, xi0, mu_limit, kappa, xi_out):
    """Contact and surface friction of one node: generalised force on its stencil and its Jacobian.

    Parameters
    ----------
    kind, geom : obstacle type and packed geometry (:mod:`knotsim.contact.obstacle_kernels`).
    z, zp : (11,) float64, the stencil's unknowns at the iterate and at the start of the step (m,
        rad; layout in the module doc).
    wA, wB : weights of edges A and B in the node's angular velocity (½ each inside a rod, 1 and 0
        at an open end).
    dt : time step (s). h : rod radius (m). tol : IMC tolerance δ (m). k_c : contact stiffness
        (N/m). mu : friction coefficient. nu : slip tolerance ν (m/s).
    vel, omega, center : (3,) the obstacle's rigid motion, surface velocity
        ``vel + omega × (y − center)`` at a point ``y`` (m/s, rad/s, m).
    force : (11,) output, contact plus friction generalised force (N on positions, N m on angles).
    jac : (11, 11) output, ``∂force/∂z`` (N/m, N, N/rad, N m/rad by block), when ``want_jacobian``.
    gr, H : (3,) and (3, 3) scratch (the distance gradient ``n`` and Hessian on return).
    xi0, mu_limit, kappa, xi_out : the elastic-stick law (docs/physics.md §3.6) when ``kappa > 0``
        (1/m, ``μ_k/δ_s``): ``xi0`` (3,) the node's tangential spring at the start of the step (m),
        ``mu_limit`` its limit coefficient; the friction is ``f = −F_n φ(|ξ|) ξ``
        (:func:`~knotsim.contact.friction.stick_functions`), ``ξ = xi0 + u dt``, written to
        ``xi_out`` (3,) (zeros otherwise). ``kappa = 0``: the smooth law of ``mu`` and ``nu``.

    Returns
    -------
    ``(k_c E (J), gap Δ − d (m), F_c (3-tuple, N), f (3-tuple, N), v_s (3-tuple, m/s))``: the
    contact force on the node, the friction force at its surface point and the surface point's
    velocity (zeros where there is no friction).
    """
    for r in range(STENCIL):
        force[r] = 0.0
        if want_jacobian:
            for m in range(STENCIL):
                jac[r, m] = 0.0
    delta, R = node_distance(kind, z[4:7], geom, gr, H)
    d = h + R
    for k in range(3):
        xi_out[k] = 0.0
    if delta >= d + tol:
        return 0.0, delta - d, _ZERO, _ZERO, _ZERO
    E, dE, d2E = imc_energy_derivatives(delta, d, tol)
    n = (gr[0], gr[1], gr[2])
    fn = -k_c * dE  # >= 0
    fc = v3.scale(fn, n)
    for k in range(3):
        force[4 + k] = fc[k]
        if want_jacobian:
            for m in range(3):
                jac[4 + k, 4 + m] = -k_c * (d2E * n[k] * n[m] + dE * H[k, m])
    if not (mu > 0.0 and fn > 0.0):
        return k_c * E, delta - d, fc, _ZERO, _ZERO
    idt = 1.0 / dt
    vi = ((z[4] - zp[4]) * idt, (z[5] - zp[5]) * idt, (z[6] - zp[6]) * idt)
    tA, lA, edA, omA, cA = _edge(z, zp, 0, 4, 3, wA, h, idt)
    tB, lB, edB, omB, cB = _edge(z, zp, 4, 8, 7, wB, h, idt)
    tAn = v3.cross(tA, n)
    tBn = v3.cross(tB, n)
    rot = v3.add(v3.axpy(-h * wA * omA, tAn, lever_velocity(cA, tA, edA, n)),
                 v3.axpy(-h * wB * omB, tBn, lever_velocity(cB, tB, edB, n)))
    vs = v3.add(vi, rot)
    om = (omega[0], omega[1], omega[2])
    y = v3.axpy(-h, n, (z[4], z[5], z[6]))
    wo = v3.add((vel[0], vel[1], vel[2]), v3.cross(om, v3.sub(y, (center[0], center[1], center[2]))))
    wv = v3.sub(vs, wo)
    wn = v3.dot(wv, n)
    u = v3.axpy(-wn, n, wv)
    s = v3.norm(u)
    vec, phi, psi, f = law_force(kappa, (xi0[0], xi0[1], xi0[2]), u, s, dt, mu, nu, mu_limit, fn)
    if kappa > 0.0:  # elastic stick: vec is the spring ξ = ξ0 + u dt
        for k in range(3):
            xi_out[k] = vec[k]
    gA = lever_force(cA, tA, f, n)
    gB = lever_force(cB, tB, f, n)
    mid = v3.sub(v3.add(f, gA), gB)
    for k in range(3):
        force[k] -= gA[k]
        force[4 + k] += mid[k]
        force[8 + k] += gB[k]
    force[3] = -h * wA * v3.dot(tAn, f)
    force[7] = -h * wB * v3.dot(tBn, f)
    if not want_jacobian:
        return k_c * E, delta - d, fc, f, vs
    for m in range(STENCIL):
        if m == 3 or m == 7:
            node = -1
            comp = 0
        else:
            node = 0 if m < 3 else (1 if m < 7 else 2)
            comp = m - 4 * node
        unit = (1.0 if comp == 0 else 0.0, 1.0 if comp == 1 else 0.0, 1.0 if comp == 2 else 0.0)
        if node == 1:
            dn = (H[0, comp], H[1, comp], H[2, comp])
            dfn = -k_c * d2E * n[comp]
            dx = unit
        else:
            dn = _ZERO
            dfn = 0.0
            dx = _ZERO
        # edge A runs from slot node 0 to node 1, edge B from node 1 to node 2
        sA = (1.0 if node == 1 else (-1.0 if node == 0 else 0.0)) if wA > 0.0 else 0.0
        sB = (1.0 if node == 2 else (-1.0 if node == 1 else 0.0)) if wB > 0.0 else 0.0
        deA, dtA, dcA = edge_dot(sA, unit, tA, lA, cA)
        deB, dtB, dcB = edge_dot(sB, unit, tB, lB, cB)
        domA = idt if m == 3 else 0.0
        domB = idt if m == 7 else 0.0
        dtAn = v3.add(v3.cross(dtA, n), v3.cross(tA, dn))
        dtBn = v3.add(v3.cross(dtB, n), v3.cross(tB, dn))
        drot = v3.add(
            v3.sub(lever_velocity_dot(cA, dcA, tA, dtA, edA, v3.scale(idt, deA), n, dn),
                   v3.scale(h * wA, v3.add(v3.scale(domA, tAn), v3.scale(omA, dtAn)))),
            v3.sub(lever_velocity_dot(cB, dcB, tB, dtB, edB, v3.scale(idt, deB), n, dn),
                   v3.scale(h * wB, v3.add(v3.scale(domB, tBn), v3.scale(omB, dtBn)))))
        dy = v3.axpy(-h, dn, dx)
        dwv = v3.sub(v3.axpy(idt, dx, drot), v3.cross(om, dy))
        du = tangential_dot(wv, dwv, wn, n, dn)
        df = law_force_dot(kappa, dt, mu, fn, dfn, phi, psi, vec, du)
        dgA = lever_force_dot(cA, dcA, tA, dtA, f, df, n, dn)
        dgB = lever_force_dot(cB, dcB, tB, dtB, f, df, n, dn)
        for k in range(3):
            jac[k, m] -= dgA[k]
            jac[4 + k, m] += df[k] + dgA[k] - dgB[k]
            jac[8 + k, m] += dgB[k]
        jac[3, m] = -h * wA * (v3.dot(dtAn, f) + v3.dot(tAn, df))
        jac[7, m] = -h * wB * (v3.dot(dtBn, f) + v3.dot(tBn, df))
    return k_c * E, delta - d, fc, f, vs


@njit(cache=True)
def obstacle_surface_evaluate(kind, geom, stencil, weights, node_h, q, q_prev, dt, tol, k_c, mu, nu, vel, omega,
                              center, residual, want_jacobian, blocks, fc, ff, gap, normal, vs, node_xi0,
                              node_mu_limit, stick_distance, xi_out):
    """Contact and surface friction of every node with one obstacle (:func:`node_surface_contact`).

    ``stencil (k, 11)`` int64 unknowns of each node's stencil, ``weights (k, 2)`` its edge weights
    ``w_A, w_B``, ``node_h (k,)`` radii (m); ``q``, ``q_prev`` ``(n_dofs,)`` the unknowns at the
    iterate and at the start of the step. Adds ``−force`` to ``residual``; writes ``blocks (k, 11, 11)``
    = ``−∂force/∂z`` when ``want_jacobian``; ``fc``, ``ff``, ``normal``, ``vs`` ``(k, 3)`` get the
    contact force on the node, the friction force at its surface point (N), the normal and the
    surface point's velocity (m/s); ``gap (k,)`` the gap ``Δ − d`` (m). With ``stick_distance = δ_s > 0``
    (m) the elastic-stick law: ``node_xi0 (k, 3)`` the nodes' springs at the start of the step (m),
    ``node_mu_limit (k,)`` their limit coefficients, ``κ = mu/δ_s``; ``xi_out (k, 3)`` gets the springs
    at the iterate (m). Returns the energy (J).
    """
    stick = stick_distance > 0.0 and mu > 0.0
    if stick and (node_xi0.shape[0] != stencil.shape[0] or node_mu_limit.shape[0] != stencil.shape[0]
                  or xi_out.shape[0] != stencil.shape[0]):
        raise ValueError("node_xi0, node_mu_limit and xi_out must have one row per node")
    kappa = mu / stick_distance if stick else 0.0
    xi = np.zeros(3)
    xo = np.zeros(3)
    gr = np.zeros(3)
    H = np.zeros((3, 3))
    jac = np.zeros((STENCIL, STENCIL))
    force = np.zeros(STENCIL)
    z = np.zeros(STENCIL)
    zp = np.zeros(STENCIL)
    energy = 0.0
    for i in range(stencil.shape[0]):
        for j in range(STENCIL):
            z[j] = q[stencil[i, j]]
            zp[j] = q_prev[stencil[i, j]]
        mu_lim = 0.0
        if stick:
            mu_lim = node_mu_limit[i]
            for k in range(3):
                xi[k] = node_xi0[i, k]
        e, g, fcv, ffv, vsv = node_surface_contact(kind, z, zp, weights[i, 0], weights[i, 1], dt, geom, node_h[i],
                                                   tol, k_c, mu, nu, vel, omega, center, force, jac, want_jacobian,
                                                   gr, H, xi, mu_lim, kappa, xo)
        if stick:
            for k in range(3):
                xi_out[i, k] = xo[k]
        energy += e
        store_node(i, g, fcv, ffv, gr, gap, fc, ff, normal)
        for k in range(3):
            vs[i, k] = vsv[k]
        for j in range(STENCIL):
            residual[stencil[i, j]] -= force[j]
            if want_jacobian:
                for m in range(STENCIL):
                    blocks[i, j, m] = -jac[j, m]
    return energy


@njit(cache=True)
def _log_cosh(x):
    """``log cosh x`` for ``x >= 0`` without overflow."""
    return x + math.log1p(math.exp(-2.0 * x)) - math.log(2.0)


@njit(cache=True)
def spin_objective(spin, spin_prev, proj, inertia, dt, mu, nu, fn, normal, y, vs, vel, center, grad, hess):
    """The convex function whose minimiser is the obstacle's new spin (see :func:`spin_update`).

    ``Φ(ω) = I |ω − ω_n|² / (2 dt) + Σ μ F_n Γ(|u|)`` (J/s), ``Γ(s) = (2/K2) log cosh(K2 s/2)``
    (``Γ' = γ``, the smooth Coulomb switch), ``u = (I − n nᵀ)(v_s − vel − ω × (y − c))``. Writes
    its gradient ``P ∇Φ`` into ``grad (3,)`` (N m) and ``P ∇²Φ P + (I − P)`` into ``hess (3, 3)``
    (``P = proj``, the projector on the free rotation axes); returns ``Φ``.
    """
    k2 = FRICTION_SHARPNESS / nu
    d = v3.sub((spin[0], spin[1], spin[2]), (spin_prev[0], spin_prev[1], spin_prev[2]))
    phi_val = 0.5 * inertia / dt * v3.dot(d, d)
    g = v3.scale(inertia / dt, d)
    K = np.zeros((3, 3))
    for a in range(3):
        K[a, a] = inertia / dt
    om = (spin[0], spin[1], spin[2])
    for i in range(fn.shape[0]):
        n = (normal[i, 0], normal[i, 1], normal[i, 2])
        r = (y[i, 0] - center[0], y[i, 1] - center[1], y[i, 2] - center[2])
        w = v3.sub(v3.sub((vs[i, 0], vs[i, 1], vs[i, 2]), (vel[0], vel[1], vel[2])), v3.cross(om, r))
        u = v3.axpy(-v3.dot(w, n), n, w)
        s = v3.norm(u)
        _, ph, ps = slip_functions(s, nu)
        c = mu * fn[i]
        phi_val += c * 2.0 / k2 * _log_cosh(0.5 * k2 * s)
        # ∂u/∂ω = P_n [r]x ; ∇ = Σ [r]xᵀ (c φ u) = Σ r × f with f = −c φ u
        g = v3.add(g, v3.cross(r, v3.scale(-c * ph, u)))
        # ∇² = Σ [r]xᵀ P_n c (φ I + ψ u uᵀ) P_n [r]x, column by column
        for b in range(3):
            eb = (1.0 if b == 0 else 0.0, 1.0 if b == 1 else 0.0, 1.0 if b == 2 else 0.0)
            du = v3.cross(r, eb)
            du = v3.axpy(-v3.dot(du, n), n, du)
            col = v3.axpy(c * ps * v3.dot(u, du), u, v3.scale(c * ph, du))
            col = v3.axpy(-v3.dot(col, n), n, col)
            rc = v3.cross(col, r)  # [r]xᵀ col = −r × col = col × r
            for a in range(3):
                K[a, b] += rc[a]
    for a in range(3):
        grad[a] = proj[a, 0] * g[0] + proj[a, 1] * g[1] + proj[a, 2] * g[2]
    for a in range(3):
        for b in range(3):
            acc = 0.0
            for p in range(3):
                for m in range(3):
                    acc += proj[a, p] * K[p, m] * proj[m, b]
            hess[a, b] = acc + ((1.0 if a == b else 0.0) - proj[a, b])
    return phi_val


@njit(cache=True)
def _solve3(A, b):
    """``A⁻¹ b`` for a 3x3 matrix by cofactors."""
    c00 = A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]
    c01 = A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]
    c02 = A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]
    det = A[0, 0] * c00 + A[0, 1] * c01 + A[0, 2] * c02
    inv = np.empty((3, 3))
    inv[0, 0] = c00
    inv[1, 0] = c01
    inv[2, 0] = c02
    inv[0, 1] = A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]
    inv[1, 1] = A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]
    inv[2, 1] = A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]
    inv[0, 2] = A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]
    inv[1, 2] = A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]
    inv[2, 2] = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    return ((inv[0, 0] * b[0] + inv[0, 1] * b[1] + inv[0, 2] * b[2]) / det,
            (inv[1, 0] * b[0] + inv[1, 1] * b[1] + inv[1, 2] * b[2]) / det,
            (inv[2, 0] * b[0] + inv[2, 1] * b[1] + inv[2, 2] * b[2]) / det)


@njit(cache=True)
def spin_update(spin_prev, proj, inertia, dt, mu, nu, fn, normal, y, vs, vel, center, max_iter=200):
    """New angular velocity (rad/s) of an obstacle free to spin on a frictionless axle.

    Implicit (backward Euler) in the spin with the rods' state of the accepted step frozen:
    ``I (ω − ω_n)/dt = P M(ω)``, ``M(ω) = Σ (y − c) × (−f(ω))`` the moment of friction on the
    obstacle, ``ω`` in the range of ``proj (3, 3)`` (the axis ``â âᵀ`` of a capsule, ``I₃`` for a
    ball joint). It is the stationarity condition of the strictly convex :func:`spin_objective`,
    minimised by Newton's method with Armijo backtracking (converges from any start).

    ``spin_prev (3,)`` ω_n (rad/s); ``inertia`` I (kg m²); ``dt`` (s); ``mu``, ``nu`` the friction law;
    over the contact nodes: ``fn (c,)`` normal force (N), ``normal``, ``y`` (surface points, m), ``vs``
    (their velocities, m/s) ``(c, 3)``; ``vel, center (3,)`` the obstacle's translation velocity (m/s)
    and a point of its axis (m). Returns ``(ω (3,), Newton iterations)``.
    """
    grad = np.zeros(3)
    hess = np.zeros((3, 3))
    g2 = np.zeros(3)
    h2 = np.zeros((3, 3))
    spin = np.zeros(3)
    for a in range(3):
        spin[a] = proj[a, 0] * spin_prev[0] + proj[a, 1] * spin_prev[1] + proj[a, 2] * spin_prev[2]
    rmax = 0.0
    for i in range(fn.shape[0]):
        rmax = max(rmax, v3.norm((y[i, 0] - center[0], y[i, 1] - center[1], y[i, 2] - center[2])))
    # converged when the step moves the surface by less than 1e-12 ν (or by round-off of ω)
    tol = 1e-12 * nu / max(rmax, 1e-300)
    trial = np.zeros(3)
    iterations = 0
    for _ in range(max_iter):
        iterations += 1
        F = spin_objective(spin, spin_prev, proj, inertia, dt, mu, nu, fn, normal, y, vs, vel, center, grad, hess)
        step = _solve3(hess, (-grad[0], -grad[1], -grad[2]))
        size = v3.norm(step)
        slope = v3.dot(step, (grad[0], grad[1], grad[2]))
        alpha = 1.0
        for _ in range(60):
            for a in range(3):
                trial[a] = spin[a] + alpha * step[a]
            Ft = spin_objective(trial, spin_prev, proj, inertia, dt, mu, nu, fn, normal, y, vs, vel, center, g2, h2)
            if Ft <= F + 1e-4 * alpha * slope:
                break
            alpha *= 0.5
        for a in range(3):
            spin[a] = trial[a]
        if alpha * size <= tol + 4e-16 * v3.norm((spin[0], spin[1], spin[2])):
            break
    return spin, iterations
