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
from knotsim.energies._stencil import hessian_to_stencil, scatter_gradient, set_block, stencil_geometry


@njit(cache=True)
def _add_curvature_hessians(Hz, H, k1, k2, dk1, dk2, n0, n1, chi, t0, t1, tt, kb, d1t, d2t, m1e, m1f, m2e, m2f):
    """``Hz (8, 8) += dk1 * H_kappa1 + dk2 * H_kappa2``: the Hessians (edge variables) of the two
    material curvatures, each built in the scratch ``H (8, 8)``.

    For ``kappa1``: ``sgn = +1``, ``dt = d~2``, ``me, mf = m2_e, m2_f``, ``me_th, mf_th = m1_e, m1_f``.
    For ``kappa2``: ``sgn = -1``, ``dt = d~1``, ``me, mf = m1_e, m1_f``, ``me_th, mf_th = m2_e, m2_f``.
    A call, not numba-inlined: inlining it (once or twice) doubled or tripled the bending kernel's
    first-run compile time for no measurable gain in speed.
    """
    for comp in range(2):
        if comp == 0:
            kap, sgn, dt, me, mf, me_th, mf_th, dk = k1, 1.0, d2t, m2e, m2f, m1e, m1f, dk1
        else:
            kap, sgn, dt, me, mf, me_th, mf_th, dk = k2, -1.0, d1t, m1e, m1f, m2e, m2f, dk2
        for i in range(8):
            for j in range(8):
                H[i, j] = 0.0
        c1 = v3.cross(t1, dt)  # t_f x d~
        c0 = v3.cross(t0, dt)  # t_e x d~
        # e-e block
        s = 1.0 / (n0 * n0)
        set_block(H, 0, 0, 2.0 * kap * s, tt, tt)
        set_block(H, 0, 0, -sgn * s, c1, tt)
        set_block(H, 0, 0, -sgn * s, tt, c1)
        for p in range(3):
            H[p, p] += -kap * s / chi
        set_block(H, 0, 0, kap * s / chi, t0, t0)
        set_block(H, 0, 0, sgn * 0.25 * s, kb, me)
        set_block(H, 0, 0, sgn * 0.25 * s, me, kb)
        # f-f block
        s = 1.0 / (n1 * n1)
        set_block(H, 4, 4, 2.0 * kap * s, tt, tt)
        set_block(H, 4, 4, sgn * s, c0, tt)
        set_block(H, 4, 4, sgn * s, tt, c0)
        for p in range(3):
            H[4 + p, 4 + p] += -kap * s / chi
        set_block(H, 4, 4, kap * s / chi, t1, t1)
        set_block(H, 4, 4, sgn * 0.25 * s, kb, mf)
        set_block(H, 4, 4, sgn * 0.25 * s, mf, kb)
        # e-f block and its transpose
        s = 1.0 / (n0 * n1)
        for p in range(3):
            for k in range(3):
                val = -kap * s / chi * ((1.0 if p == k else 0.0) + t0[p] * t1[k])
                val += s * (2.0 * kap * tt[p] * tt[k] - sgn * c1[p] * tt[k] + sgn * tt[p] * c0[k])
                H[p, 4 + k] += val
        v3.skew_add(H, 0, 4, -sgn * s, dt)
        for p in range(3):
            for k in range(3):
                H[4 + k, p] = H[p, 4 + k]
        # theta-theta
        H[3, 3] = -0.5 * sgn * v3.dot(kb, me)
        H[7, 7] = -0.5 * sgn * v3.dot(kb, mf)
        # theta - e/f mixed
        ae = 0.5 * v3.dot(kb, me_th)
        af = 0.5 * v3.dot(kb, mf_th)
        x1e = v3.cross(t1, me_th)
        x1f = v3.cross(t1, mf_th)
        x0e = v3.cross(t0, me_th)
        x0f = v3.cross(t0, mf_th)
        for p in range(3):
            # d2 kappa / de d theta_e, de d theta_f, df d theta_e, df d theta_f
            ve = (ae * tt[p] - x1e[p] / chi) / n0
            vf = (af * tt[p] - x1f[p] / chi) / n0
            we = (ae * tt[p] + x0e[p] / chi) / n1
            wf = (af * tt[p] + x0f[p] / chi) / n1
            H[p, 3] = ve
            H[3, p] = ve
            H[p, 7] = vf
            H[7, p] = vf
            H[4 + p, 3] = we
            H[3, 4 + p] = we
            H[4 + p, 7] = wf
            H[7, 4 + p] = wf
        for i in range(8):
            for j in range(8):
                Hz[i, j] += dk * H[i, j]


@njit(cache=True)
def bending_energy(q, bend_dofs, bend_edges, tangents, lengths, m1, m2, EI, voronoi, kappa_bar,
                   grad, hess, want_hessian, kappa_out):
    nb = bend_dofs.shape[0]
    g1 = np.zeros(8)
    g2 = np.zeros(8)
    gz = np.zeros(8)
    H1 = np.zeros((8, 8))
    Hz = np.zeros((8, 8))
    energy = 0.0
    for s in range(nb):
        e, f, t0, t1, n0, n1, chi, tt, kb = stencil_geometry(bend_edges, tangents, lengths, s)
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
        coef = EI[s] / voronoi[s]
        energy += 0.5 * coef * (dk1 * dk1 + dk2 * dk2)

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
            gz[p] = dk1 * g1[p] + dk2 * g2[p]
        scatter_gradient(gz, coef, bend_dofs[s], grad)

        if want_hessian:
            for i in range(8):
                for j in range(8):
                    Hz[i, j] = g1[i] * g1[j] + g2[i] * g2[j]
            _add_curvature_hessians(Hz, H1, k1, k2, dk1, dk2, n0, n1, chi, t0, t1, tt, kb, d1t, d2t, m1e, m1f, m2e, m2f)
            hessian_to_stencil(Hz, coef, hess[s])
    return energy
