"""Smooth Coulomb friction at the rods' surfaces: slip of the surface points, rolling and spin.

The law of docs/physics.md §3.3. A contact pair joins edge a (nodes ``x0, x1``, edge angle
``θ_a``, radius ``h_a``) and edge b (nodes ``x2, x3``, ``θ_b``, ``h_b``); its 14 unknowns are
``z = (x0, x1, x2, x3, θ_a, θ_b)`` (m, m, m, m, rad, rad). At the Newton iterate, with the
velocities ``ż = (z − z_prev)/dt``:

* normal ``n = S/|S|``, ``S = F_c,0 + F_c,1`` (contact force on edge a; points from b to a) and
  normal force ``F_n = |S|`` (N);
* tangent ``t_a = e_a/l_a``, ``e_a = x1 − x0``, ``l_a = |e_a|``; likewise ``t_b``;
* angular velocity of a cross-section ``Ω = t × ṫ + θ̇ t`` (reference frames are time-parallel);
  with ``ṫ = (I − t tᵀ) ė / l``, ``t × ṫ = t × ė / l``;
* surface-point velocities ``v_pa = (1 − β_a) v0 + β_a v1 + Ω_a × (−h_a n)`` and
  ``v_pb = (1 − β_b) v2 + β_b v3 + Ω_b × (h_b n)``; slip ``u = (I − n nᵀ)(v_pa − v_pb)``;
* friction on a's surface point ``f = −μ F_n φ(|u|) u`` (the smooth law of
  :mod:`knotsim.contact.friction`, ``φ(s) = tanh(K2 s/2)/s``), ``−f`` on b's.

The generalised forces are those of virtual power, ``Q = Bᵀ f`` with ``B`` the linear map
``ż ↦ v_pa − v_pb`` at ``z``:

* ``Q_x0 = (1 − β_a) f − g_a``, ``Q_x1 = β_a f + g_a`` with the lever-arm term
  ``g_a = −(h_a/l_a) (n × f) × t_a``; ``Q_x2 = −(1 − β_b) f − g_b``, ``Q_x3 = −β_b f + g_b``;
* ``Q_θa = −h_a (t_a × n)·f``, ``Q_θb = −h_b (t_b × n)·f`` (N m).

``Q · ż = f · u ≤ 0``: the law dissipates at every iterate. The Jacobian ``∂Q/∂z`` (p_prev, θ_prev
and dt fixed) is exact, including the dependence through ``β`` (``∂β/∂p``), ``n`` and ``F_n`` (through
``∂F_c/∂p``) and the tangents; it is built column by column from the per-edge 3×3 matrices of
:func:`edge_jacobian_terms` (docs/physics.md §3.3).
Where ``|S| <= TINY_FORCE`` the pair carries no friction.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from knotsim import _vec3 as v3
from knotsim.contact.friction import (
    TINY_FORCE,
    law_force,
    law_force_dot,
    slip_functions,
    slip_potential,
    stick_functions,
    stick_potential,
)

#: Number of unknowns of a surface-friction pair: 4 nodes and 2 edge angles.
PAIR_UNKNOWNS = 14
#: Length of a pair's record (``spin_out`` of :func:`surface_friction_pair`).
RECORD_SIZE = 15


@njit(inline="always", cache=True)
def lever_velocity(c, t, ed, n):
    """``−c [(t·n) ė − (n·ė) t]`` (m/s): the velocity of the surface point at ``−h n`` from the
    turning of an edge's tangent ``t`` (``c (t × ė) × (−n)`` with ``c = h/l``, or ``h w/l`` for a
    node's weighted share of the edge), ``ė`` the edge's rate of change (m/s)."""
    tn = v3.dot(t, n)
    ne = v3.dot(n, ed)
    return (-c * (tn * ed[0] - ne * t[0]), -c * (tn * ed[1] - ne * t[1]), -c * (tn * ed[2] - ne * t[2]))


@njit(inline="always", cache=True)
def lever_velocity_dot(c, cd, t, td, ed, edd, n, nd):
    """Directional derivative of :func:`lever_velocity` given those of its arguments."""
    tn = v3.dot(t, n)
    ne = v3.dot(n, ed)
    tnd = v3.dot(td, n) + v3.dot(t, nd)
    ned = v3.dot(nd, ed) + v3.dot(n, edd)
    out0 = -cd * (tn * ed[0] - ne * t[0]) - c * (tnd * ed[0] + tn * edd[0] - ned * t[0] - ne * td[0])
    out1 = -cd * (tn * ed[1] - ne * t[1]) - c * (tnd * ed[1] + tn * edd[1] - ned * t[1] - ne * td[1])
    out2 = -cd * (tn * ed[2] - ne * t[2]) - c * (tnd * ed[2] + tn * edd[2] - ned * t[2] - ne * td[2])
    return (out0, out1, out2)


@njit(inline="always", cache=True)
def tangential_dot(w, dw, wn, n, dn):
    """Directional derivative of the tangential part ``u = w − (w·n) n`` of ``w`` (``wn = w·n``) given
    those of ``w`` and of the unit normal ``n``."""
    dwn = v3.dot(dw, n) + v3.dot(w, dn)
    return v3.sub(v3.axpy(-dwn, n, dw), v3.scale(wn, dn))


@njit(inline="always", cache=True)
def edge_dot(sign, unit, t, l, c):
    """Directional derivatives for an edge of tangent ``t``, length ``l`` (m) and ``c = h w/l`` when one
    of its nodes moves along ``unit`` (``sign`` +1 for its second node, −1 for its first, 0 for
    neither): ``(ė_dir, ṫ, ċ)`` (the edge vector's change, 1; the tangent's, 1/m; ``c``'s, 1/m)."""
    de = v3.scale(sign, unit)
    dl = v3.dot(t, de)
    return de, v3.scale(1.0 / l, v3.axpy(-dl, t, de)), -c * dl / l


@njit(inline="always", cache=True)
def lever_force(c, t, f, n):
    """``g = −c [(n·t) f − (f·t) n]``, the lever-arm force on the edge's second node (N): the same
    expression as :func:`lever_velocity` with the roles of ``(t, n)`` exchanged, so it is computed by
    it (the same floating-point operations in the same order)."""
    return lever_velocity(c, n, f, t)


@njit(inline="always", cache=True)
def lever_force_dot(c, cd, t, td, f, fd, n, nd):
    """Directional derivative of :func:`lever_force` (that of :func:`lever_velocity`, roles exchanged)."""
    return lever_velocity_dot(c, cd, n, nd, f, fd, t, td)


@njit(cache=True)
def edge_jacobian_terms(c, h, l, t, ed, spin, n, f, idt, out):
    """The 3×3 matrices of one edge of a pair from which :func:`surface_friction_pair` builds its
    Jacobian (docs/physics.md §3.3), for an edge of tangent ``t``, length ``l`` (m), radius ``h`` (m),
    ``c = h/l``, rate ``ed = ė`` (m/s) and spin ``θ̇ = spin`` (rad/s), at the normal ``n`` and the
    friction ``f`` (N); ``idt = 1/dt`` (1/s).

    With ``rot = lever_velocity(c, t, ed, n) − h θ̇ (t × n)`` the edge's share of the surface velocity
    ``w``, ``g = lever_force(c, t, f, n)`` its lever-arm force and ``Q_θ = −h (t × n)·f``, fills
    ``out`` (5, 3, 3) with

    0. ``Wn = ∂rot/∂n`` (1/s);
    1. ``K``: ``∂rot/∂x`` for the edge's second node (its first: ``−K``; 1/s), through the tangent
       (``∂t/∂x = (I − t tᵀ)/l``), ``c`` (``∂c/∂x = −c tᵀ/l``) and ``ė`` (``1/dt``);
    2. ``Mf = ∂g/∂f``; 3. ``Gn = ∂g/∂n`` (N); 4. ``H = ∂g/∂x`` for the second node at fixed ``f`` (N/m).

    Returns ``(r, fxt)``: ``r = (I − t tᵀ)(n × f)/l`` (N/m; ``∂Q_θ/∂x`` at fixed ``f`` and ``n`` is
    ``−h r`` for the second node) and ``fxt = f × t`` (N; ``∂Q_θ/∂n`` at fixed ``f`` is ``−h fxt``).
    """
    tn = v3.dot(t, n)
    ne = v3.dot(n, ed)
    tf = v3.dot(t, f)
    il = 1.0 / l
    hw = h * spin
    # ∂rot/∂c (rot's lever velocity is c lvu), ∂rot/∂t t = c lvu + hw n × t, ∂g/∂c
    lvu = (-(tn * ed[0] - ne * t[0]), -(tn * ed[1] - ne * t[1]), -(tn * ed[2] - ne * t[2]))
    gu = (-(tn * f[0] - tf * n[0]), -(tn * f[1] - tf * n[1]), -(tn * f[2] - tf * n[2]))
    kt = v3.axpy(2.0 * c, lvu, v3.scale(hw, v3.cross(n, t)))
    pn = v3.axpy(-tn, t, n)  # (I − t tᵀ) n
    pf = v3.axpy(-tf, t, f)
    for i in range(3):
        for j in range(3):
            d = 1.0 if i == j else 0.0
            out[0, i, j] = -c * (ed[i] * t[j] - t[i] * ed[j])
            # ∂rot/∂t (I − t tᵀ)/l + ∂rot/∂ė /dt − (c/l) lvu tᵀ, with ∂rot/∂t (t tᵀ) = kt tᵀ − c lvu tᵀ
            out[1, i, j] = il * (-c * (ed[i] * n[j] - ne * d) - kt[i] * t[j]) - idt * c * (tn * d - t[i] * n[j])
            out[2, i, j] = -c * (tn * d - n[i] * t[j])
            out[3, i, j] = -c * (f[i] * t[j] - tf * d)
            out[4, i, j] = -c * il * (f[i] * pn[j] - n[i] * pf[j] + gu[i] * t[j])
    # the spin's terms: −hw [t]× in Wn, (hw/l) [n]× in K
    add_skew(out, 0, -hw, t)
    add_skew(out, 1, hw * il, n)
    nf = v3.cross(n, f)
    r = v3.scale(il, v3.axpy(-v3.dot(t, nf), t, nf))
    return r, v3.cross(f, t)


@njit(inline="always", cache=True)
def add_skew(m, k, s, a):
    """``m[k] += s [a]×`` for the (·, 3, 3) array ``m`` (``[a]× x = a × x``)."""
    m[k, 0, 1] -= s * a[2]
    m[k, 0, 2] += s * a[1]
    m[k, 1, 0] += s * a[2]
    m[k, 1, 2] -= s * a[0]
    m[k, 2, 0] -= s * a[1]
    m[k, 2, 1] += s * a[0]


@njit(inline="always", cache=True)
def _mat_vec(m, k, x):
    """``m[k] x`` for the (·, 3, 3) array ``m``."""
    return (m[k, 0, 0] * x[0] + m[k, 0, 1] * x[1] + m[k, 0, 2] * x[2],
            m[k, 1, 0] * x[0] + m[k, 1, 1] * x[1] + m[k, 1, 2] * x[2],
            m[k, 2, 0] * x[0] + m[k, 2, 1] * x[1] + m[k, 2, 2] * x[2])


@njit(inline="always", cache=True)
def _column(m, k, j):
    """Column ``j`` of ``m[k]``."""
    return (m[k, 0, j], m[k, 1, j], m[k, 2, j])


@njit(cache=True)
def surface_friction_pair(p, p_prev, theta, theta_prev, dt, mu, nu, ha, hb, fc, dfc, beta_a, beta_b,
                          dbeta_a, dbeta_b, xi0, mu_limit, kappa, force_out, jac_out, spin_out, want_jacobian=True):
    """Friction at the surfaces of a contact pair: generalised forces on its 14 unknowns and their
    exact Jacobian.

    Parameters
    ----------
    p, p_prev : (12,) float64, nodes ``x0, x1`` (edge a), ``x2, x3`` (edge b) at the iterate and at
        the start of the step (m).
    theta, theta_prev : (2,) float64, edge angles ``θ_a, θ_b`` at the iterate and the start (rad).
    dt : time step (s).
    mu : friction coefficient; nu : slip tolerance ν (m/s), ``K2 = 15/ν``.
    ha, hb : radii of edges a and b (m).
    fc : (12,) float64, contact force on the 4 nodes at ``p`` (N); dfc : (12, 12) its Jacobian (N/m).
    beta_a, beta_b : contact ratios at ``p``; dbeta_a, dbeta_b : (12,) float64, ``∂β/∂p`` (1/m).
    xi0, mu_limit, kappa : the elastic-stick law (docs/physics.md §3.6) when ``kappa > 0``: ``xi0`` (3,)
        the pair's tangential spring displacement at the start of the step (m), ``mu_limit`` its limit
        coefficient (μ_s sticking, μ_k sliding) and ``kappa = μ_k/δ_s`` (1/m); the friction is then
        ``f = −F_n φ(|ξ|) ξ`` of :func:`~knotsim.contact.friction.stick_functions` with
        ``ξ = xi0 + u dt``. ``kappa = 0``: the smooth law of ``mu`` and ``nu`` (``xi0``, ``mu_limit``
        unused).
    force_out : (14,) float64 output, generalised friction force ``Q`` (N on positions, N m on
        angles).
    jac_out : (14, 14) float64 output, ``∂Q/∂z`` (N/m, N, N/rad, N m/rad by block).
    spin_out : (RECORD_SIZE,) float64 output, the pair's record: its law as a function of the edge
        angles alone (positions held), ``w`` (m/s: the slip ``u``, or ``ξ/dt`` with the stick law),
        ``c_a = −h_a t_a × n`` and ``c_b = −h_b t_b × n`` (m; ``w`` changes by
        ``(c_a Δθ_a + c_b Δθ_b)/dt`` when the angles turn by ``Δθ``), ``F_n`` (N), the coefficient
        (μ, or μ_L with the stick law), ``κ`` (1/m, 0 for the smooth law), then the normal ``n``; all
        zero for a pair without friction (see :func:`spin_friction_terms`).
    want_jacobian : when ``False`` only ``force_out`` is computed.

    Returns
    -------
    ``(slip, rolling)``: the slip speed ``|u|`` (m/s) and the rolling speed, the magnitude of the
    tangential surface velocity difference that comes from the cross-sections' rotation,
    ``|(I − n nᵀ)(Ω_a × (−h_a n) − Ω_b × (h_b n))|`` (m/s).
    """
    S = v3.add(v3.load(fc, 0), v3.load(fc, 3))
    sn = v3.norm(S)
    if not sn > TINY_FORCE:
        for r in range(RECORD_SIZE):
            spin_out[r] = 0.0
        for r in range(14):
            force_out[r] = 0.0
            if want_jacobian:
                for m in range(14):
                    jac_out[r, m] = 0.0
        return 0.0, 0.0
    n = v3.scale(1.0 / sn, S)
    idt = 1.0 / dt
    x0 = v3.load(p, 0)
    x1 = v3.load(p, 3)
    x2 = v3.load(p, 6)
    x3 = v3.load(p, 9)
    v0 = v3.scale(idt, v3.sub(x0, v3.load(p_prev, 0)))
    v1 = v3.scale(idt, v3.sub(x1, v3.load(p_prev, 3)))
    v2 = v3.scale(idt, v3.sub(x2, v3.load(p_prev, 6)))
    v3_ = v3.scale(idt, v3.sub(x3, v3.load(p_prev, 9)))
    ea = v3.sub(x1, x0)
    eb = v3.sub(x3, x2)
    la = v3.norm(ea)
    lb = v3.norm(eb)
    ta = v3.scale(1.0 / la, ea)
    tb = v3.scale(1.0 / lb, eb)
    eda = v3.sub(v1, v0)
    edb = v3.sub(v3_, v2)
    wa = (theta[0] - theta_prev[0]) * idt
    wb = (theta[1] - theta_prev[1]) * idt
    ca = ha / la
    cb = hb / lb
    tan = v3.cross(ta, n)
    tbn = v3.cross(tb, n)
    # rotational parts of the surface velocities: a's at −h_a n, b's at +h_b n
    rot_a = v3.axpy(-ha * wa, tan, lever_velocity(ca, ta, eda, n))
    rot_b = v3.axpy(-hb * wb, tbn, lever_velocity(cb, tb, edb, n))
    w = v3.sub(v3.add(v3.add(v3.scale(1.0 - beta_a, v0), v3.scale(beta_a, v1)), rot_a),
               v3.sub(v3.add(v3.scale(1.0 - beta_b, v2), v3.scale(beta_b, v3_)), rot_b))
    wn = v3.dot(w, n)
    u = v3.axpy(-wn, n, w)
    s = v3.norm(u)
    rr = v3.add(rot_a, rot_b)
    rolling = v3.norm(v3.axpy(-v3.dot(rr, n), n, rr))
    fnorm = sn
    vec, phi, psi, f = law_force(kappa, v3.load(xi0, 0), u, s, dt, mu, nu, mu_limit, fnorm)
    stick = kappa > 0.0  # elastic stick: vec is the spring ξ = ξ0 + u dt
    wrec = v3.scale(idt, vec) if stick else u
    coef = mu_limit if stick else mu
    ga = lever_force(ca, ta, f, n)
    gb = lever_force(cb, tb, f, n)
    for r in range(3):
        force_out[r] = (1.0 - beta_a) * f[r] - ga[r]
        force_out[3 + r] = beta_a * f[r] + ga[r]
        force_out[6 + r] = -(1.0 - beta_b) * f[r] - gb[r]
        force_out[9 + r] = -beta_b * f[r] + gb[r]
    force_out[12] = -ha * v3.dot(tan, f)
    force_out[13] = -hb * v3.dot(tbn, f)
    for r in range(3):
        spin_out[r] = wrec[r]
        spin_out[3 + r] = -ha * tan[r]
        spin_out[6 + r] = -hb * tbn[r]
        spin_out[12 + r] = n[r]
    spin_out[9] = fnorm
    spin_out[10] = coef
    spin_out[11] = kappa
    if not want_jacobian:
        return s, rolling
    # The Jacobian, column by column from per-edge 3×3 matrices (edge_jacobian_terms): a column m of a
    # position moves the normal (dn = (I − n nᵀ) dS/|S|, dF_n = n·dS, dS from dfc), the contact
    # ratios (∂β/∂p) and, for a node of edge a or b, that edge's tangent, length and rate.
    isn = 1.0 / sn
    mats = np.empty((2, 5, 3, 3))  # one allocation for both edges' matrices
    ma = mats[0]
    mb = mats[1]
    ra, fta = edge_jacobian_terms(ca, ha, la, ta, eda, wa, n, f, idt, ma)
    rb, ftb = edge_jacobian_terms(cb, hb, lb, tb, edb, wb, n, f, idt, mb)
    for i in range(3):
        for j in range(3):
            ma[0, i, j] += mb[0, i, j]  # W_n of the pair
    for m in range(12):
        node = m // 3
        comp = m - 3 * node
        dS = (dfc[0, m] + dfc[3, m], dfc[1, m] + dfc[4, m], dfc[2, m] + dfc[5, m])
        dfn = v3.dot(n, dS)
        dn = v3.scale(isn, v3.axpy(-dfn, n, dS))
        bad = dbeta_a[m]
        bbd = dbeta_b[m]
        dw = v3.axpy(bad, eda, v3.axpy(-bbd, edb, _mat_vec(ma, 0, dn)))
        dga = _mat_vec(ma, 3, dn)
        dgb = _mat_vec(mb, 3, dn)
        # the node's own column: translation of the contact point, turn and stretch of its edge
        if node == 0:
            dw = v3.sub(dw, _column(ma, 1, comp))
            wt = (1.0 - beta_a) * idt
            dga = v3.sub(dga, _column(ma, 4, comp))
            sta = -ra[comp]
            stb = 0.0
        elif node == 1:
            dw = v3.add(dw, _column(ma, 1, comp))
            wt = beta_a * idt
            dga = v3.add(dga, _column(ma, 4, comp))
            sta = ra[comp]
            stb = 0.0
        elif node == 2:
            dw = v3.sub(dw, _column(mb, 1, comp))
            wt = -(1.0 - beta_b) * idt
            dgb = v3.sub(dgb, _column(mb, 4, comp))
            sta = 0.0
            stb = -rb[comp]
        else:
            dw = v3.add(dw, _column(mb, 1, comp))
            wt = -beta_b * idt
            dgb = v3.add(dgb, _column(mb, 4, comp))
            sta = 0.0
            stb = rb[comp]
        if comp == 0:
            dw = (dw[0] + wt, dw[1], dw[2])
        elif comp == 1:
            dw = (dw[0], dw[1] + wt, dw[2])
        else:
            dw = (dw[0], dw[1], dw[2] + wt)
        du = tangential_dot(w, dw, wn, n, dn)
        df = law_force_dot(kappa, dt, mu, fnorm, dfn, phi, psi, vec, du)
        dga = v3.add(dga, _mat_vec(ma, 2, df))
        dgb = v3.add(dgb, _mat_vec(mb, 2, df))
        for r in range(3):
            jac_out[r, m] = -bad * f[r] + (1.0 - beta_a) * df[r] - dga[r]
            jac_out[3 + r, m] = bad * f[r] + beta_a * df[r] + dga[r]
            jac_out[6 + r, m] = bbd * f[r] - (1.0 - beta_b) * df[r] - dgb[r]
            jac_out[9 + r, m] = -bbd * f[r] - beta_b * df[r] + dgb[r]
        jac_out[12, m] = -ha * (v3.dot(tan, df) + v3.dot(fta, dn) + sta)
        jac_out[13, m] = -hb * (v3.dot(tbn, df) + v3.dot(ftb, dn) + stb)
    for m in range(12, 14):
        # an edge angle turns: only the rotational velocity of its surface point changes
        dw = v3.scale(-ha * idt, tan) if m == 12 else v3.scale(-hb * idt, tbn)
        du = v3.axpy(-v3.dot(dw, n), n, dw)
        df = law_force_dot(kappa, dt, mu, fnorm, 0.0, phi, psi, vec, du)
        dga = _mat_vec(ma, 2, df)
        dgb = _mat_vec(mb, 2, df)
        for r in range(3):
            jac_out[r, m] = (1.0 - beta_a) * df[r] - dga[r]
            jac_out[3 + r, m] = beta_a * df[r] + dga[r]
            jac_out[6 + r, m] = -(1.0 - beta_b) * df[r] - dgb[r]
            jac_out[9 + r, m] = -beta_b * df[r] + dgb[r]
        jac_out[12, m] = -ha * v3.dot(tan, df)
        jac_out[13, m] = -hb * v3.dot(tbn, df)
    return s, rolling


@njit(cache=True)
def spin_friction_terms(dtheta, loc, record, dt, nu, grad_out, hess_out):
    """The friction of surface-friction pairs as a function of the edge angles alone, positions held.

    With the nodes fixed at the iterate, a pair's slip is affine in its two edge angles,
    ``u(Δθ) = u + (c_a Δθ_a + c_b Δθ_b)/dt``, and its friction is the gradient of the convex potential
    ``D = μ F_n dt Γ(|u|)`` (:func:`~knotsim.contact.friction.slip_potential`), or with the elastic-stick
    law (``κ > 0`` in the record) ``D = F_n H(|ξ|)``, ``ξ = u dt`` (:func:`~knotsim.contact.friction.stick_potential`):
    the residual of an angle (``−Q_θ``) is ``∂D/∂θ``, its Jacobian ``∂²D/∂θ²`` (docs/physics.md §3.5).

    Parameters
    ----------
    dtheta : (m,) float64, turn of the angles from the iterate (rad), in a local numbering.
    loc : (k, 2) int64, local number of each pair's angles ``θ_a, θ_b`` (−1: held, not turned).
    record : (k, RECORD_SIZE) float64, each pair's record at the iterate (``spin_out`` of
        :func:`surface_friction_pair`: ``w`` (m/s), ``c_a``, ``c_b`` (m), ``F_n`` (N), coefficient, ``κ``).
    dt : time step (s); nu : (k,) float64, each pair's slip tolerance ν (m/s).
    grad_out : (m,) float64 output, ``Σ ∂D/∂Δθ`` (N m).
    hess_out : (k, 2, 2) float64 output, each pair's ``∂²D/∂(Δθ_a, Δθ_b)²`` (N m/rad; zero rows and
        columns for held angles).

    Returns
    -------
    ``Σ D`` (J).
    """
    for i in range(grad_out.shape[0]):
        grad_out[i] = 0.0
    total = 0.0
    for p in range(record.shape[0]):
        for i in range(2):
            for j in range(2):
                hess_out[p, i, j] = 0.0
        fn = record[p, 9]
        coef = record[p, 10]
        kap = record[p, 11]
        mufn = coef * fn
        if not mufn > 0.0:
            continue
        ia = loc[p, 0]
        ib = loc[p, 1]
        da = dtheta[ia] if ia >= 0 else 0.0
        db = dtheta[ib] if ib >= 0 else 0.0
        u = (record[p, 0] + (record[p, 3] * da + record[p, 6] * db) / dt,
             record[p, 1] + (record[p, 4] * da + record[p, 7] * db) / dt,
             record[p, 2] + (record[p, 5] * da + record[p, 8] * db) / dt)
        ca = (record[p, 3], record[p, 4], record[p, 5])
        cb = (record[p, 6], record[p, 7], record[p, 8])
        if kap > 0.0:  # the stick law: D = F_n H(|ξ|), ξ = u dt
            u = v3.scale(dt, u)
            s = v3.norm(u)
            phi, psi = stick_functions(s, coef, kap)
            total += fn * stick_potential(s, coef, kap)
            gs = fn
            c = fn
        else:
            s = v3.norm(u)
            _, phi, psi = slip_functions(s, nu[p])
            total += mufn * dt * slip_potential(s, nu[p])
            gs = mufn
            c = mufn / dt
        uca = v3.dot(u, ca)
        ucb = v3.dot(u, cb)
        if ia >= 0:
            grad_out[ia] += gs * phi * uca
            hess_out[p, 0, 0] = c * (phi * v3.dot(ca, ca) + psi * uca * uca)
        if ib >= 0:
            grad_out[ib] += gs * phi * ucb
            hess_out[p, 1, 1] = c * (phi * v3.dot(cb, cb) + psi * ucb * ucb)
        if ia >= 0 and ib >= 0:
            hab = c * (phi * v3.dot(ca, cb) + psi * uca * ucb)
            hess_out[p, 0, 1] = hab
            hess_out[p, 1, 0] = hab
    return total
