"""Twisting energy of Discrete Elastic Rods, numba kernel.

Per interior node: ``m = theta_f - theta_e + reference_twist`` (rad, integrated twist) and
``E = GJ / (2 l_i) (m - mbar)^2``. The reference twist moves with the edges by parallel transport;
its gradient is ``kb / (2 |e|)`` with respect to ``e`` and ``kb / (2 |f|)`` with respect to ``f``.

Kernel arguments: ``q (n_dofs,)``; ``bend_dofs (nb, 11)``; ``bend_edges (nb, 2)``; ``tangents (ne, 3)``;
``lengths (ne,)`` m; ``ref_twist (nb,)`` rad; ``GJ (nb,)`` N m^2; ``voronoi (nb,)`` m;
``twist_bar (nb,)`` rad. Adds the gradient to ``grad``; when ``want_hessian`` writes 11x11 blocks into
``hess (nb, 11, 11)`` (added to it when ``accumulate``, e.g. onto the bending blocks). Returns the
energy (J); ``twist_out (nb,)`` receives ``m``. The kernel is
:func:`~knotsim.energies.bending.bending_twisting_energy`, which also evaluates both terms in one
pass.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from knotsim.energies.bending import bending_twisting_energy


@njit(cache=True)
def twisting_energy(q, bend_dofs, bend_edges, tangents, lengths, ref_twist, GJ, voronoi, twist_bar,
                    grad, hess, want_hessian, twist_out, accumulate=False):
    """Twisting only: :func:`~knotsim.energies.bending.bending_twisting_energy` with ``bend=False``
    (the formulas live there, shared with the bending term)."""
    v = np.empty(0)
    m = np.empty((0, 3))
    k = np.empty((0, 2))
    _, et = bending_twisting_energy(q, bend_dofs, bend_edges, tangents, lengths, m, m, ref_twist, v, GJ, voronoi,
                                    k, twist_bar, grad, hess, want_hessian, k, twist_out, np.empty((0, 8)), k,
                                    np.empty(0, dtype=np.bool_), False, True, accumulate)
    return et
