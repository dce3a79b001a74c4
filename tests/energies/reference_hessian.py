"""Slow reference of the per-stencil bending and twisting Hessian blocks (plain numpy, no numba).

The obvious form: the Hessians of ``kappa1`` and ``kappa2`` built one at a time in the edge
variables ``z = (e, theta_e, f, theta_f)``, combined as ``g1 g1^T + g2 g2^T + dk1 H1 + dk2 H2``
(bending) or ``gz gz^T + dm H_rt`` (twisting), and mapped to the 11 stencil unknowns with the
explicit ``(8, 11)`` matrix ``T`` (``H_x = T^T H_z T``). The kernels fold the two curvature
Hessians into one pass and map by blocks; they must agree with this to round-off.
"""

from __future__ import annotations

import numpy as np


def _skew(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _t_matrix():
    T = np.zeros((8, 11))
    for p in range(3):
        T[p, p], T[p, 4 + p] = -1.0, 1.0  # e = x_i - x_{i-1}
        T[4 + p, 4 + p], T[4 + p, 8 + p] = -1.0, 1.0  # f = x_{i+1} - x_i
    T[3, 3] = T[7, 7] = 1.0
    return T


def _geometry(el, model, s):
    e, f = model.bend_edges[s]
    t0, t1 = el.tangents[e], el.tangents[f]
    chi = 1.0 + t0 @ t1
    return e, f, t0, t1, el.lengths[e], el.lengths[f], chi, (t0 + t1) / chi, 2.0 * np.cross(t0, t1) / chi


def _curvature_hessian(kap, sgn, dt, me, mf, me_th, mf_th, n0, n1, chi, t0, t1, tt, kb):
    H = np.zeros((8, 8))
    c1, c0 = np.cross(t1, dt), np.cross(t0, dt)
    eye = np.eye(3)
    s = 1.0 / n0**2
    H[:3, :3] = s * (2 * kap * np.outer(tt, tt) - sgn * (np.outer(c1, tt) + np.outer(tt, c1)) - kap / chi * eye
                     + kap / chi * np.outer(t0, t0) + 0.25 * sgn * (np.outer(kb, me) + np.outer(me, kb)))
    s = 1.0 / n1**2
    H[4:7, 4:7] = s * (2 * kap * np.outer(tt, tt) + sgn * (np.outer(c0, tt) + np.outer(tt, c0)) - kap / chi * eye
                       + kap / chi * np.outer(t1, t1) + 0.25 * sgn * (np.outer(kb, mf) + np.outer(mf, kb)))
    s = 1.0 / (n0 * n1)
    ef = (-kap * s / chi * (eye + np.outer(t0, t1)) + s * (2 * kap * np.outer(tt, tt) - sgn * np.outer(c1, tt)
          + sgn * np.outer(tt, c0)) - sgn * s * _skew(dt))
    H[:3, 4:7] = ef
    H[4:7, :3] = ef.T
    H[3, 3] = -0.5 * sgn * kb @ me
    H[7, 7] = -0.5 * sgn * kb @ mf
    ae, af = 0.5 * kb @ me_th, 0.5 * kb @ mf_th
    ve = (ae * tt - np.cross(t1, me_th) / chi) / n0
    vf = (af * tt - np.cross(t1, mf_th) / chi) / n0
    we = (ae * tt + np.cross(t0, me_th) / chi) / n1
    wf = (af * tt + np.cross(t0, mf_th) / chi) / n1
    for col, v in ((3, ve), (7, vf)):
        H[:3, col] = H[col, :3] = v
    for col, v in ((3, we), (7, wf)):
        H[4:7, col] = H[col, 4:7] = v
    return H


def bending_blocks(el, model):
    """``(nb, 11, 11)`` bending Hessian blocks at the frames held by ``el`` (an ElasticEnergy)."""
    T = _t_matrix()
    out = np.zeros((model.n_bend, 11, 11))
    for s in range(model.n_bend):
        e, f, t0, t1, n0, n1, chi, tt, kb = _geometry(el, model, s)
        m1e, m2e, m1f, m2f = el.m1[e], el.m2[e], el.m1[f], el.m2[f]
        d1t, d2t = (m1e + m1f) / chi, (m2e + m2f) / chi
        k1, k2 = 0.5 * kb @ (m2e + m2f), -0.5 * kb @ (m1e + m1f)
        dk1, dk2 = k1 - model.kappa_bar[s, 0], k2 - model.kappa_bar[s, 1]
        g1, g2 = np.zeros(8), np.zeros(8)
        g1[:3] = (-k1 * tt + np.cross(t1, d2t)) / n0
        g1[4:7] = (-k1 * tt - np.cross(t0, d2t)) / n1
        g2[:3] = (-k2 * tt - np.cross(t1, d1t)) / n0
        g2[4:7] = (-k2 * tt + np.cross(t0, d1t)) / n1
        g1[3], g1[7] = -0.5 * kb @ m1e, -0.5 * kb @ m1f
        g2[3], g2[7] = -0.5 * kb @ m2e, -0.5 * kb @ m2f
        Hz = np.outer(g1, g1) + np.outer(g2, g2)
        Hz += dk1 * _curvature_hessian(k1, 1.0, d2t, m2e, m2f, m1e, m1f, n0, n1, chi, t0, t1, tt, kb)
        Hz += dk2 * _curvature_hessian(k2, -1.0, d1t, m1e, m1f, m2e, m2f, n0, n1, chi, t0, t1, tt, kb)
        out[s] = model.bend_EI[s] / model.voronoi_rest[s] * T.T @ Hz @ T
    return out


def twisting_blocks(el, model, q):
    """``(nb, 11, 11)`` twisting Hessian blocks at ``q`` and the frames held by ``el``."""
    T = _t_matrix()
    out = np.zeros((model.n_bend, 11, 11))
    for s in range(model.n_bend):
        _, _, t0, t1, n0, n1, chi, tt, kb = _geometry(el, model, s)
        dofs = model.bend_dofs[s]
        dm = q[dofs[7]] - q[dofs[3]] + el.ref_twist[s] - model.twist_bar[s]
        gz = np.concatenate([0.5 * kb / n0, [-1.0], 0.5 * kb / n1, [1.0]])
        Hz = np.outer(gz, gz)
        a, b = t0 + tt, t1 + tt
        Hz[:3, :3] += -0.25 * dm / n0**2 * (np.outer(kb, a) + np.outer(a, kb))
        Hz[4:7, 4:7] += -0.25 * dm / n1**2 * (np.outer(kb, b) + np.outer(b, kb))
        ef = 0.5 * dm / (n0 * n1) * (2.0 / chi * _skew(t0) - np.outer(kb, tt))
        Hz[:3, 4:7] += ef
        Hz[4:7, :3] += ef.T
        out[s] = model.twist_GJ[s] / model.voronoi_rest[s] * T.T @ Hz @ T
    return out
