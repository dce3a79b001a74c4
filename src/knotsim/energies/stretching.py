"""Stretching energy of every edge: ``E = 1/2 EA (|e|/l0 - 1)^2 l0`` (J).

Kernel arguments: ``q (n_dofs,)``; ``edge_dofs (ne, 2)`` index of each end node's x coordinate;
``rest_length (ne,)`` m; ``EA (ne,)`` N. Gradient is added to ``grad (n_dofs,)``; when
``want_hessian`` the 6x6 Hessian of each edge (unknowns x_a, x_b) is written to
``hess (ne, 6, 6)``.
"""

from __future__ import annotations

from numba import njit

from knotsim import _vec3 as v3


@njit(cache=True)
def stretching_energy(q, edge_dofs, rest_length, EA, grad, hess, want_hessian):
    energy = 0.0
    for e in range(edge_dofs.shape[0]):
        ia = edge_dofs[e, 0]
        ib = edge_dofs[e, 1]
        d = v3.sub(v3.load(q, ib), v3.load(q, ia))
        n = v3.norm(d)
        l0 = rest_length[e]
        strain = n / l0 - 1.0
        energy += 0.5 * EA[e] * strain * strain * l0
        t = v3.scale(1.0 / n, d)
        f = EA[e] * strain
        for k in range(3):
            grad[ia + k] -= f * t[k]
            grad[ib + k] += f * t[k]
        if want_hessian:
            a = EA[e] / l0
            b = EA[e] * strain / n
            for r in range(3):
                for c in range(3):
                    val = (a - b) * t[r] * t[c]
                    if r == c:
                        val += b
                    hess[e, r, c] = val
                    hess[e, r + 3, c + 3] = val
                    hess[e, r, c + 3] = -val
                    hess[e, r + 3, c] = -val
    return energy
