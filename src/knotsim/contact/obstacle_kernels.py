"""Numba kernels of rope-obstacle contact: distance primitives, per-node IMC energy and friction.

Layers (each a function of scalars, the last one loops over nodes inside numba):

1. distance primitives ``node_plane_distance``, ``node_sphere_distance``, ``node_capsule_distance``:
   the distance ``Δ`` (m) of a node to the obstacle's *defining set* (the plane itself, signed; the
   sphere's centre; the capsule's axis segment), its gradient ``n = ∂Δ/∂x`` (a unit vector from the
   obstacle towards the node) and Hessian ``H = ∂²Δ/∂x²`` (1/m);
2. the IMC energy of the gap (:func:`knotsim.contact.potential.imc_energy_derivatives`, the same
   function as rope-rope contact) with contact distance ``d = h + R`` (rope radius ``h`` plus the
   obstacle radius ``R``; ``R = 0`` for a plane);
3. per-node force, friction and their 3x3 Jacobians (:func:`node_contact`);
4. :func:`obstacle_evaluate`: every node of the candidate list, summed into the residual.

Geometry is packed into ``geom (7,)``: plane ``[point(3), unit normal(3), 0]``; sphere
``[centre(3), 0, 0, 0, R]``; capsule ``[a(3), b(3), R]`` (axis from ``a`` to ``b``).

Contact is node-based: each node is a ball of radius ``h``. For a plane this is the exact edge
contact (an edge's closest point to a plane is one of its nodes, or all of it when parallel, where
the two node terms are equal and smooth). For a curved obstacle an edge's midpoint may come closer
than its nodes by at most the sagitta ``l²/(8 (R + h))`` (edge length ``l``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from knotsim import _vec3 as v3
from knotsim.contact.friction import slip_functions
from knotsim.contact.potential import imc_energy_derivatives

PLANE, SPHERE, CAPSULE = 0, 1, 2
#: Below this distance (m) to a sphere's centre or a capsule's axis the normal is undefined: the
#: node gets no contact force there (it is deep inside the obstacle, never reached in practice).
TINY_DISTANCE = 1e-300


@njit(cache=True)
def node_plane_distance(x, p, n, grad, hess):
    """Signed distance (m) of node ``x (3,)`` to the plane through ``p`` with unit normal ``n``.

    ``grad (3,)`` gets ``n``; ``hess (3, 3)`` gets zeros. Returns ``Δ``.
    """
    for k in range(3):
        grad[k] = n[k]
        for m in range(3):
            hess[k, m] = 0.0
    return (x[0] - p[0]) * n[0] + (x[1] - p[1]) * n[1] + (x[2] - p[2]) * n[2]


@njit(cache=True)
def _radial(r, rn, grad, hess, axis, ax_len2):
    """``grad = r/|r|``, ``hess = (I - axis axisᵀ/ax_len2 - u uᵀ)/|r|`` (``ax_len2 = 0``: no axis term)."""
    if rn <= TINY_DISTANCE:
        for k in range(3):
            grad[k] = 0.0
            for m in range(3):
                hess[k, m] = 0.0
        return
    inv = 1.0 / rn
    u = v3.scale(inv, r)
    for k in range(3):
        grad[k] = u[k]
        for m in range(3):
            h = -u[k] * u[m]
            if k == m:
                h += 1.0
            if ax_len2 > 0.0:
                h -= axis[k] * axis[m] / ax_len2
            hess[k, m] = h * inv


@njit(cache=True)
def node_sphere_distance(x, c, grad, hess):
    """Distance (m) of node ``x`` to the centre ``c`` of a sphere; ``grad``, ``hess`` as above."""
    r = (x[0] - c[0], x[1] - c[1], x[2] - c[2])
    rn = v3.norm(r)
    _radial(r, rn, grad, hess, r, 0.0)
    return rn


@njit(cache=True)
def node_capsule_distance(x, a, b, grad, hess):
    """Distance (m) of node ``x`` to the segment ``a b`` (a capsule's axis).

    Returns ``(Δ, t)`` with ``t`` in ``[0, 1]`` the parameter of the closest point ``a + t (b - a)``.
    Where the projection parameter lies in ``[0, 1]`` (bounds included) the Hessian is that of the
    distance to the axis line, ``(I - êêᵀ - uuᵀ)/Δ``; beyond the ends that of the distance to the
    end point, ``(I - uuᵀ)/Δ``. The gradient is continuous across the end-cap boundary; the Hessian
    jumps there by ``êêᵀ/Δ`` (its value on the boundary is the cylinder's). A zero-length axis is a
    sphere.
    """
    ab = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
    ax = (x[0] - a[0], x[1] - a[1], x[2] - a[2])
    L2 = v3.dot(ab, ab)
    if L2 <= 0.0:
        rn = v3.norm(ax)
        _radial(ax, rn, grad, hess, ax, 0.0)
        return rn, 0.0
    s = v3.dot(ax, ab) / L2
    if s < 0.0:
        rn = v3.norm(ax)
        _radial(ax, rn, grad, hess, ab, 0.0)
        return rn, 0.0
    if s > 1.0:
        bx = (x[0] - b[0], x[1] - b[1], x[2] - b[2])
        rn = v3.norm(bx)
        _radial(bx, rn, grad, hess, ab, 0.0)
        return rn, 1.0
    r = v3.axpy(-s, ab, ax)
    rn = v3.norm(r)
    _radial(r, rn, grad, hess, ab, L2)
    return rn, s


@njit(cache=True)
def node_distance(kind, x, geom, grad, hess):
    """Distance of node ``x`` to an obstacle of type ``kind`` (``PLANE``, ``SPHERE``, ``CAPSULE``)
    with packed ``geom (7,)``; returns ``(Δ, R)`` (m) with ``R`` the obstacle radius (0 for a plane)."""
    if kind == PLANE:
        return node_plane_distance(x, geom[0:3], geom[3:6], grad, hess), 0.0
    if kind == SPHERE:
        return node_sphere_distance(x, geom[0:3], grad, hess), geom[6]
    d, _ = node_capsule_distance(x, geom[0:3], geom[3:6], grad, hess)
    return d, geom[6]


@njit(cache=True)
def node_contact(kind, x, x_prev, dt, geom, h, tol, k_c, mu, nu, vel, omega, center, out_f, out_ff, jac,
                 want_jacobian, gr, H):
    """Contact and friction force on one node, and the Jacobian of their sum.

    Parameters
    ----------
    kind, geom : obstacle type and packed geometry at the end of the step (see the module doc).
    x, x_prev : (3,) node position at the iterate and at the start of the step (m).
    dt : time step (s). h : rope radius at the node (m). tol : IMC distance tolerance δ (m).
    k_c : contact stiffness (N/m). mu : friction coefficient. nu : slip tolerance (m/s).
    vel, omega, center : (3,) the obstacle's rigid motion: surface velocity at a point ``y`` is
        ``vel + omega × (y − center)`` (m/s, rad/s, m).
    out_f, out_ff : (3,) outputs, contact force ``−k_c E'(Δ) n`` and friction force (N) on the node.
    jac : (3, 3) output, ``∂(out_f + out_ff)/∂x`` (N/m) at fixed ``x_prev``, ``dt``.
    gr, H : (3,) and (3, 3) scratch arrays (the distance gradient and Hessian on return).

    Friction (the law of :mod:`knotsim.contact.friction`): with ``F_n = −k_c E'`` (N),
    ``v_rel = (x − x_prev)/dt − vel − omega × (x − center)`` and ``v_T = (I − nnᵀ) v_rel``, the
    force is ``−μ F_n φ(|v_T|) v_T``. Returns ``(k_c E, Δ − d)`` (J, m).
    """
    delta, R = node_distance(kind, x, geom, gr, H)
    d = h + R
    for k in range(3):
        out_f[k] = 0.0
        out_ff[k] = 0.0
        if want_jacobian:
            for m in range(3):
                jac[k, m] = 0.0
    if delta >= d + tol:
        return 0.0, delta - d
    E, dE, d2E = imc_energy_derivatives(delta, d, tol)
    n = (gr[0], gr[1], gr[2])
    fn = -k_c * dE  # >= 0
    for k in range(3):
        out_f[k] = fn * n[k]
    if want_jacobian:
        # d(-k E' n)/dx = -k (E'' n nᵀ + E' H)
        for k in range(3):
            for m in range(3):
                jac[k, m] = -k_c * (d2E * n[k] * n[m] + dE * H[k, m])
    if mu > 0.0 and fn > 0.0:
        idt = 1.0 / dt
        rel = (x[0] - center[0], x[1] - center[1], x[2] - center[2])
        w = v3.add((vel[0], vel[1], vel[2]), v3.cross((omega[0], omega[1], omega[2]), rel))
        v = ((x[0] - x_prev[0]) * idt, (x[1] - x_prev[1]) * idt, (x[2] - x_prev[2]) * idt)
        vrel = v3.sub(v, w)
        vn = v3.dot(vrel, n)
        vT = v3.axpy(-vn, n, vrel)
        s = v3.norm(vT)
        _, phi, psi = slip_functions(s, nu)
        for k in range(3):
            out_ff[k] = -mu * fn * phi * vT[k]
        if want_jacobian:
            # dvrel/dx = I/dt - [omega]x ; dn/dx = H
            for m in range(3):
                e = (1.0 if m == 0 else 0.0, 1.0 if m == 1 else 0.0, 1.0 if m == 2 else 0.0)
                dvrel = v3.sub(v3.scale(idt, e), v3.cross((omega[0], omega[1], omega[2]), e))
                dn = (H[0, m], H[1, m], H[2, m])
                dvT = v3.axpy(-v3.dot(n, dvrel), n, dvrel)
                dvT = v3.axpy(-v3.dot(vrel, dn), n, dvT)
                dvT = v3.axpy(-vn, dn, dvT)
                dw = v3.axpy(psi * v3.dot(vT, dvT), vT, v3.scale(phi, dvT))
                dfn = -k_c * d2E * n[m]
                for k in range(3):
                    jac[k, m] += -mu * (phi * vT[k] * dfn + fn * dw[k])
    return k_c * E, delta - d


@njit(inline="always", cache=True)
def store_node(i, g, f_contact, f_friction, normal_vec, gap, fc, ff, normal):
    """Write node ``i``'s gap (m), contact and friction forces (N) and unit normal into the per-node
    output arrays of an obstacle evaluation."""
    gap[i] = g
    for k in range(3):
        fc[i, k] = f_contact[k]
        ff[i, k] = f_friction[k]
        normal[i, k] = normal_vec[k]


@njit(cache=True)
def obstacle_evaluate(kind, geom, nodes, node_dof, node_h, q, q_prev, dt, tol, k_c, mu, nu, vel, omega, center,
                      residual, want_jacobian, blocks, fc, ff, gap, normal):
    """Contact and friction of every node in ``nodes`` with one obstacle.

    ``nodes (k,)`` global node numbers, ``node_dof (n_nodes,)``, ``node_h (k,)`` their radii (m);
    ``q``, ``q_prev`` the unknowns at the iterate and at the start of the step. Adds ``−(force)`` to
    ``residual`` at the node coordinates; writes ``blocks (k, 3, 3)`` = ``−∂force/∂x`` (N/m) when
    ``want_jacobian``; ``fc``, ``ff``, ``normal`` ``(k, 3)`` get the contact force, the friction
    force (N) and the contact normal, ``gap (k,)`` the gap ``Δ − d`` (m). Returns the energy (J).
    """
    gr = np.zeros(3)
    H = np.zeros((3, 3))
    jac = np.zeros((3, 3))
    f = np.zeros(3)
    fr = np.zeros(3)
    x = np.zeros(3)
    xp = np.zeros(3)
    energy = 0.0
    for i in range(nodes.shape[0]):
        j = node_dof[nodes[i]]
        for k in range(3):
            x[k] = q[j + k]
            xp[k] = q_prev[j + k]
        e, g = node_contact(kind, x, xp, dt, geom, node_h[i], tol, k_c, mu, nu, vel, omega, center, f, fr, jac,
                            want_jacobian, gr, H)
        energy += e
        store_node(i, g, f, fr, gr, gap, fc, ff, normal)
        for k in range(3):
            residual[j + k] -= f[k] + fr[k]
            if want_jacobian:
                for m in range(3):
                    blocks[i, k, m] = -jac[k, m]
    return energy
