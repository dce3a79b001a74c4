"""Twisting energy of Discrete Elastic Rods, numba kernel.

Per interior node: ``m = theta_f - theta_e + reference_twist`` (rad, integrated twist) and
``E = GJ / (2 l_i) (m - mbar)^2``. The reference twist moves with the edges by parallel transport;
its gradient is ``kb / (2 |e|)`` with respect to ``e`` and ``kb / (2 |f|)`` with respect to ``f``.

Kernel arguments: ``q (n_dofs,)``; ``bend_dofs (nb, 11)``; ``bend_edges (nb, 2)``; ``tangents (ne, 3)``;
``lengths (ne,)`` m; ``ref_twist (nb,)`` rad; ``GJ (nb,)`` N m^2; ``voronoi (nb,)`` m;
``twist_bar (nb,)`` rad. Adds the gradient to ``grad``; when ``want_hessian`` writes 11x11 blocks into
``hess (nb, 11, 11)`` (added to it when ``accumulate``, e.g. onto the bending blocks). Returns the
energy (J); ``twist_out (nb,)`` receives ``m``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from knotsim import _vec3 as v3
from knotsim.energies._stencil import add_edge_blocks, scatter_gradient, stencil_geometry


@njit(cache=True)
def twisting_energy(q, bend_dofs, bend_edges, tangents, lengths, ref_twist, GJ, voronoi, twist_bar,
                    grad, hess, want_hessian, twist_out, accumulate=False):
    nb = bend_dofs.shape[0]
    gz = np.zeros(8)
    energy = 0.0
    gx = np.zeros(11)
    A = np.zeros((3, 3))
    B = np.zeros((3, 3))
    C = np.zeros((3, 3))
    for s in range(nb):
        _, _, t0, t1, n0, n1, chi, tt, kb = stencil_geometry(bend_edges, tangents, lengths, s)
        m = q[bend_dofs[s, 7]] - q[bend_dofs[s, 3]] + ref_twist[s]
        twist_out[s] = m
        dm = m - twist_bar[s]
        coef = GJ[s] / voronoi[s]
        energy += 0.5 * coef * dm * dm
        for p in range(3):
            gz[p] = 0.5 * kb[p] / n0
            gz[4 + p] = 0.5 * kb[p] / n1
        gz[3] = -1.0
        gz[7] = 1.0
        if want_hessian:
            # coef * (gx gx^T + dm * T^T H_rt T) with gx = T^T gz the stencil gradient of m and
            # H_rt the Hessian of the reference twist (nonzero in its e-e, e-f, f-e, f-f blocks)
            for p in range(3):
                gx[p] = -gz[p]
                gx[4 + p] = gz[p] - gz[4 + p]
                gx[8 + p] = gz[4 + p]
            gx[3] = -1.0
            gx[7] = 1.0
            out = hess[s]
            if accumulate:
                for i in range(11):
                    ci = coef * gx[i]
                    for j in range(11):
                        out[i, j] += ci * gx[j]
            else:
                for i in range(11):
                    ci = coef * gx[i]
                    for j in range(11):
                        out[i, j] = ci * gx[j]
            a = v3.add(t0, tt)
            b = v3.add(t1, tt)
            s0 = -0.25 * dm / (n0 * n0)
            s1 = -0.25 * dm / (n1 * n1)
            s2 = 0.5 * dm / (n0 * n1)
            w = 2.0 / chi
            for p in range(3):
                for k in range(3):
                    A[p, k] = coef * s0 * (kb[p] * a[k] + a[p] * kb[k])
                    C[p, k] = coef * s1 * (kb[p] * b[k] + b[p] * kb[k])
                    # e-f block: (2/chi [t0]_x - kb t~^T) / (2 n0 n1); f-e is its transpose
                    B[p, k] = -coef * s2 * kb[p] * tt[k]
            v3.skew_add(B, 0, 0, coef * s2 * w, t0)
            add_edge_blocks(out, A, B, C)
        for p in range(8):
            gz[p] *= dm
        scatter_gradient(gz, coef, bend_dofs[s], grad)
    return energy
