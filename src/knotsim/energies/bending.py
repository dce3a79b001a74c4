"""Bending energy of Discrete Elastic Rods (Bergou et al. 2010), numba kernel.

Per interior node ``i`` with edges ``e = x_i - x_{i-1}`` and ``f = x_{i+1} - x_i``:

- curvature binormal ``kb = 2 (t_e x t_f) / (1 + t_e . t_f)`` (dimensionless, integrated curvature),
- material curvatures ``kappa1 = 1/2 kb . (m2_e + m2_f)``, ``kappa2 = -1/2 kb . (m1_e + m1_f)``,
- energy ``EI / (2 l_i) [(kappa1 - kbar1)^2 + (kappa2 - kbar2)^2]`` with ``l_i`` the rest Voronoi
  length (m) and ``kbar`` the natural (integrated) curvature.

Derivatives are taken with the reference frames moving by parallel transport with their edges
(the DER convention), which is exact at the configuration the frames were transported to.

Kernel arguments: ``q (n_dofs,)``; ``bend_dofs (nb, 11)``; ``bend_edges (nb, 2)``;
``tangents (ne, 3)``, ``lengths (ne,)`` m, ``m1, m2 (ne, 3)`` material directors at ``q``;
``EI (nb,)`` N m^2; ``voronoi (nb,)`` m; ``kappa_bar (nb, 2)``. Adds the gradient to ``grad``; when
``want_hessian`` writes each stencil's 11x11 Hessian into ``hess (nb, 11, 11)``. Returns the
energy (J). ``kappa_out (nb, 2)`` receives the material curvatures.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from knotsim import _vec3 as v3
from knotsim.energies._stencil import hessian_to_stencil, scatter_gradient, stencil_geometry


@njit(cache=True)
def _add_curvature_hessians(Hz, kap, dv, me, mf, te, tf, n0, n1, chi, t0, t1, tt, kb):
    """``Hz (8, 8) += dk1 * H_kappa1 + dk2 * H_kappa2``, the Hessians (edge variables) of the two
    material curvatures weighted by ``dk = kappa - kappa_bar``, in one pass.

    Every term of ``H_kappa`` is linear in one of ``kappa``, ``d~``, ``m_e``, ``m_f`` or
    ``m_e^th``, ``m_f^th`` (with a sign ``+1`` for ``kappa1`` and ``-1`` for ``kappa2`` on the
    ``d~`` and ``m`` terms), so the weighted sum is one ``H_kappa`` with the combined arguments
    ``kap = dk1 kappa1 + dk2 kappa2``, ``dv = dk1 d~2 - dk2 d~1``, ``me = dk1 m2_e - dk2 m1_e``,
    ``mf = dk1 m2_f - dk2 m1_f``, ``te = dk1 m1_e + dk2 m2_e``, ``tf = dk1 m1_f + dk2 m2_f``.
    A call, not numba-inlined (inlining multiplied the bending kernel's first-run compile time).
    """
    c1 = v3.cross(t1, dv)  # t_f x d~
    c0 = v3.cross(t0, dv)  # t_e x d~
    # e-e and f-f blocks
    se = 1.0 / (n0 * n0)
    sf = 1.0 / (n1 * n1)
    for p in range(3):
        for k in range(3):
            dd = 1.0 if p == k else 0.0
            Hz[p, k] += se * (
                2.0 * kap * tt[p] * tt[k]
                - c1[p] * tt[k]
                - tt[p] * c1[k]
                + kap / chi * (t0[p] * t0[k] - dd)
                + 0.25 * (kb[p] * me[k] + me[p] * kb[k])
            )
            Hz[4 + p, 4 + k] += sf * (
                2.0 * kap * tt[p] * tt[k]
                + c0[p] * tt[k]
                + tt[p] * c0[k]
                + kap / chi * (t1[p] * t1[k] - dd)
                + 0.25 * (kb[p] * mf[k] + mf[p] * kb[k])
            )
    # e-f block and its transpose
    s = 1.0 / (n0 * n1)
    for p in range(3):
        for k in range(3):
            val = -kap * s / chi * ((1.0 if p == k else 0.0) + t0[p] * t1[k])
            val += s * (2.0 * kap * tt[p] * tt[k] - c1[p] * tt[k] + tt[p] * c0[k])
            Hz[p, 4 + k] += val
            Hz[4 + k, p] += val
    v3.skew_add(Hz, 0, 4, -s, dv)
    v3.skew_add(Hz, 4, 0, s, dv)  # the transpose of [dv]_x is -[dv]_x
    # theta-theta
    Hz[3, 3] += -0.5 * v3.dot(kb, me)
    Hz[7, 7] += -0.5 * v3.dot(kb, mf)
    # theta - e/f mixed
    ae = 0.5 * v3.dot(kb, te)
    af = 0.5 * v3.dot(kb, tf)
    x1e = v3.cross(t1, te)
    x1f = v3.cross(t1, tf)
    x0e = v3.cross(t0, te)
    x0f = v3.cross(t0, tf)
    for p in range(3):
        # d2 kappa / de d theta_e, de d theta_f, df d theta_e, df d theta_f
        ve = (ae * tt[p] - x1e[p] / chi) / n0
        vf = (af * tt[p] - x1f[p] / chi) / n0
        we = (ae * tt[p] + x0e[p] / chi) / n1
        wf = (af * tt[p] + x0f[p] / chi) / n1
        Hz[p, 3] += ve
        Hz[3, p] += ve
        Hz[p, 7] += vf
        Hz[7, p] += vf
        Hz[4 + p, 3] += we
        Hz[3, 4 + p] += we
        Hz[4 + p, 7] += wf
        Hz[7, 4 + p] += wf


@njit(cache=True)
def bending_twisting_energy(q, bend_dofs, bend_edges, tangents, lengths, m1, m2, ref_twist, EI, GJ, voronoi,
                            kappa_bar, twist_bar, grad, hess, want_hessian, kappa_out, twist_out,
                            stencil_grad, stencil_energy, recompute, bend=True, twist=True, accumulate=False):
    """Bending and/or twisting energy of every stencil in one pass: ``(E_bend, E_twist)`` (J).

    Arguments as :func:`bending_energy` and :func:`~knotsim.energies.twisting.twisting_energy`
    (``ref_twist (nb,)`` rad, ``GJ (nb,)`` N m^2, ``twist_bar (nb,)`` rad, ``twist_out (nb,)``
    receives the integrated twist). ``bend``/``twist`` select the terms (the arrays of an
    unselected term are not read and may be empty). Both terms share the stencil geometry, one
    gradient scatter and one ``T^T Hz T`` map of the summed edge-variable Hessians; the blocks
    are written into ``hess (nb, 11, 11)`` (added to it when ``accumulate``).

    The stencils' own terms, kept for a later call (empty arrays: not kept): ``stencil_grad (nb, 8)``
    receives each stencil's gradient in its edge variables ``(e, θ_e, f, θ_f)`` and
    ``stencil_energy (nb, 2)`` its bending and twisting energy (J). ``recompute (nb,)`` bool (empty:
    every stencil): the stencils evaluated; each other one adds the gradient and energies kept in
    ``stencil_grad`` and ``stencil_energy``, and its Hessian block, curvatures and twist are left as
    they are (a caller passes False only for a stencil whose unknowns and frames are those of the
    call that kept them). The sums are then the same, bit for bit, as a full evaluation.
    """
    nb = bend_dofs.shape[0]
    g1 = np.zeros(8)
    g2 = np.zeros(8)
    gz = np.zeros(8)
    Hz = np.zeros((8, 8))
    W = np.zeros((8, 11))
    e_bend = 0.0
    e_twist = 0.0
    keep = stencil_grad.shape[0] > 0
    every = recompute.shape[0] == 0
    for s in range(nb):
        if not every and not recompute[s]:
            for p in range(8):
                gz[p] = stencil_grad[s, p]
            e_bend += stencil_energy[s, 0]
            e_twist += stencil_energy[s, 1]
            scatter_gradient(gz, 1.0, bend_dofs[s], grad)
            continue
        eb_s = 0.0
        et_s = 0.0
        e, f, t0, t1, n0, n1, chi, tt, kb = stencil_geometry(bend_edges, tangents, lengths, s)
        if want_hessian:
            for i in range(8):
                for j in range(8):
                    Hz[i, j] = 0.0
        for p in range(8):
            gz[p] = 0.0
        if bend:
            m1e = (m1[e, 0], m1[e, 1], m1[e, 2])
            m2e = (m2[e, 0], m2[e, 1], m2[e, 2])
            m1f = (m1[f, 0], m1[f, 1], m1[f, 2])
            m2f = (m2[f, 0], m2[f, 1], m2[f, 2])
            d1t = v3.scale(1.0 / chi, v3.add(m1e, m1f))
            d2t = v3.scale(1.0 / chi, v3.add(m2e, m2f))
            k1 = 0.5 * v3.dot(kb, v3.add(m2e, m2f))
            k2 = -0.5 * v3.dot(kb, v3.add(m1e, m1f))
            kappa_out[s, 0] = k1
            kappa_out[s, 1] = k2
            dk1 = k1 - kappa_bar[s, 0]
            dk2 = k2 - kappa_bar[s, 1]
            cb = EI[s] / voronoi[s]
            eb_s = 0.5 * cb * (dk1 * dk1 + dk2 * dk2)
            # gradients of kappa1, kappa2 in edge variables (e, theta_e, f, theta_f)
            a = v3.cross(t1, d2t)
            b = v3.cross(t0, d2t)
            c = v3.cross(t1, d1t)
            d = v3.cross(t0, d1t)
            for p in range(3):
                g1[p] = (-k1 * tt[p] + a[p]) / n0
                g1[4 + p] = (-k1 * tt[p] - b[p]) / n1
                g2[p] = (-k2 * tt[p] - c[p]) / n0
                g2[4 + p] = (-k2 * tt[p] + d[p]) / n1
            g1[3] = -0.5 * v3.dot(kb, m1e)
            g1[7] = -0.5 * v3.dot(kb, m1f)
            g2[3] = -0.5 * v3.dot(kb, m2e)
            g2[7] = -0.5 * v3.dot(kb, m2f)
            for p in range(8):
                gz[p] = cb * (dk1 * g1[p] + dk2 * g2[p])
            if want_hessian:
                for i in range(8):
                    for j in range(8):
                        Hz[i, j] = g1[i] * g1[j] + g2[i] * g2[j]
                kap = dk1 * k1 + dk2 * k2
                dv = v3.sub(v3.scale(dk1, d2t), v3.scale(dk2, d1t))
                me = v3.sub(v3.scale(dk1, m2e), v3.scale(dk2, m1e))
                mf = v3.sub(v3.scale(dk1, m2f), v3.scale(dk2, m1f))
                te = v3.add(v3.scale(dk1, m1e), v3.scale(dk2, m2e))
                tf = v3.add(v3.scale(dk1, m1f), v3.scale(dk2, m2f))
                _add_curvature_hessians(Hz, kap, dv, me, mf, te, tf, n0, n1, chi, t0, t1, tt, kb)
                for i in range(8):
                    for j in range(8):
                        Hz[i, j] *= cb
        if twist:
            # m = theta_f - theta_e + reference twist; dm/de = kb / (2 |e|), dm/df = kb / (2 |f|)
            mt = q[bend_dofs[s, 7]] - q[bend_dofs[s, 3]] + ref_twist[s]
            twist_out[s] = mt
            dm = mt - twist_bar[s]
            ct = GJ[s] / voronoi[s]
            et_s = 0.5 * ct * dm * dm
            for p in range(3):
                g1[p] = 0.5 * kb[p] / n0
                g1[4 + p] = 0.5 * kb[p] / n1
            g1[3] = -1.0
            g1[7] = 1.0
            for p in range(8):
                gz[p] += ct * dm * g1[p]
            if want_hessian:
                # ct * (gm gm^T + dm * Hessian of the reference twist)
                for i in range(8):
                    ci = ct * g1[i]
                    for j in range(8):
                        Hz[i, j] += ci * g1[j]
                a = v3.add(t0, tt)
                b = v3.add(t1, tt)
                s0 = -0.25 * ct * dm / (n0 * n0)
                s1 = -0.25 * ct * dm / (n1 * n1)
                s2 = 0.5 * ct * dm / (n0 * n1)
                for p in range(3):
                    for k in range(3):
                        Hz[p, k] += s0 * (kb[p] * a[k] + a[p] * kb[k])
                        Hz[4 + p, 4 + k] += s1 * (kb[p] * b[k] + b[p] * kb[k])
                        # e-f block (2/chi [t0]_x - kb t~^T) dm / (2 n0 n1); f-e is its transpose
                        v = -s2 * kb[p] * tt[k]
                        Hz[p, 4 + k] += v
                        Hz[4 + k, p] += v
                v3.skew_add(Hz, 0, 4, s2 * 2.0 / chi, t0)
                v3.skew_add(Hz, 4, 0, -s2 * 2.0 / chi, t0)
        if bend:
            e_bend += eb_s
        if twist:
            e_twist += et_s
        if keep:
            for p in range(8):
                stencil_grad[s, p] = gz[p]
            stencil_energy[s, 0] = eb_s
            stencil_energy[s, 1] = et_s
        scatter_gradient(gz, 1.0, bend_dofs[s], grad)
        if want_hessian:
            hessian_to_stencil(Hz, 1.0, hess[s], W, accumulate)
    return e_bend, e_twist


@njit(cache=True)
def bending_energy(q, bend_dofs, bend_edges, tangents, lengths, m1, m2, EI, voronoi, kappa_bar,
                   grad, hess, want_hessian, kappa_out):
    """Bending only (see the module docstring): :func:`bending_twisting_energy` with ``twist=False``."""
    none = np.empty(0)
    eb, _ = bending_twisting_energy(q, bend_dofs, bend_edges, tangents, lengths, m1, m2, none, EI, none, voronoi,
                                    kappa_bar, none, grad, hess, want_hessian, kappa_out, none, np.empty((0, 8)),
                                    np.empty((0, 2)), np.empty(0, dtype=np.bool_), True, False, False)
    return eb
