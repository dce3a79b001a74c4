"""Shared helpers of the bending and twisting kernels.

Both energies live on the 11-unknown stencil ``(x_{i-1}, theta_e, x_i, theta_f, x_{i+1})``. They
are easiest to differentiate in the 8 "edge variables" ``z = (e, theta_e, f, theta_f)`` with
``e = x_i - x_{i-1}`` and ``f = x_{i+1} - x_i``; these helpers map gradients and Hessians from
``z`` to the stencil unknowns (``g_x = T^T g_z``, ``H_x = T^T H_z T``).
"""

from __future__ import annotations

from numba import njit

from knotsim import _vec3 as v3


@njit(inline="always", cache=True)
def zmap(a):
    """Stencil columns and coefficients of edge variable ``a``: ``(j1, c1, j2, c2)``."""
    if a < 3:
        return a, -1.0, 4 + a, 1.0
    if a == 3:
        return 3, 1.0, 3, 0.0
    if a < 7:
        return a, -1.0, a + 4, 1.0
    return 7, 1.0, 7, 0.0


@njit(inline="always", cache=True)
def scatter_gradient(gz, scale, dofs, grad):
    """``grad[dofs] += scale * T^T gz`` for one stencil (``dofs`` its 11 global unknowns)."""
    for a in range(8):
        j1, c1, j2, c2 = zmap(a)
        val = scale * gz[a]
        grad[dofs[j1]] += c1 * val
        if c2 != 0.0:
            grad[dofs[j2]] += c2 * val


@njit(inline="always", cache=True)
def hessian_to_stencil(Hz, scale, out, accumulate=False):
    """``out (11, 11) = scale * T^T Hz T`` (``+=`` when ``accumulate``)."""
    if not accumulate:
        for i in range(11):
            for j in range(11):
                out[i, j] = 0.0
    for a in range(8):
        ja1, ca1, ja2, ca2 = zmap(a)
        for b in range(8):
            h = scale * Hz[a, b]
            if h == 0.0:
                continue
            jb1, cb1, jb2, cb2 = zmap(b)
            out[ja1, jb1] += ca1 * cb1 * h
            if cb2 != 0.0:
                out[ja1, jb2] += ca1 * cb2 * h
            if ca2 != 0.0:
                out[ja2, jb1] += ca2 * cb1 * h
                if cb2 != 0.0:
                    out[ja2, jb2] += ca2 * cb2 * h


@njit(inline="always", cache=True)
def set_block(H, r0, c0, s, a, b):
    """``H[r0:r0+3, c0:c0+3] += s * outer(a, b)``."""
    for p in range(3):
        for k in range(3):
            H[r0 + p, c0 + k] += s * a[p] * b[k]


@njit(inline="always", cache=True)
def stencil_geometry(bend_edges, tangents, lengths, s):
    """Geometry of stencil ``s``: ``(e, f, t_e, t_f, |e|, |f|, chi, t~, kb)`` with
    ``chi = 1 + t_e . t_f``, ``t~ = (t_e + t_f)/chi`` and the curvature binormal
    ``kb = 2 t_e x t_f / chi``."""
    e = bend_edges[s, 0]
    f = bend_edges[s, 1]
    t0 = (tangents[e, 0], tangents[e, 1], tangents[e, 2])
    t1 = (tangents[f, 0], tangents[f, 1], tangents[f, 2])
    chi = 1.0 + v3.dot(t0, t1)
    tt = v3.scale(1.0 / chi, v3.add(t0, t1))
    kb = v3.scale(2.0 / chi, v3.cross(t0, t1))
    return e, f, t0, t1, lengths[e], lengths[f], chi, tt, kb
