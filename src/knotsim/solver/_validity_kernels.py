"""Numba kernels of the validity guards (:mod:`knotsim.solver.validity`), written with scalars."""

from __future__ import annotations

import math

from numba import njit

from knotsim import _vec3 as v3

_DBL_MAX = 1.7976931348623157e308


@njit(cache=True)
def largest_axial_strain(q, edge_dofs, rest_length):
    """``(strain, edge)``: the largest ``|l/l0 - 1|`` over the edges and its global edge index.

    ``q (n_dofs,)`` m / rad; ``edge_dofs (n_edges, 2)`` the first position unknown of each edge's two
    nodes; ``rest_length (n_edges,)`` m. A NaN length counts as infinitely strained."""
    worst = -1.0
    at = -1
    for e in range(edge_dofs.shape[0]):
        d = v3.sub(v3.load(q, edge_dofs[e, 1]), v3.load(q, edge_dofs[e, 0]))
        s = abs(v3.norm(d) / rest_length[e] - 1.0)
        if not (s <= _DBL_MAX):
            s = math.inf
        if s > worst:
            worst = s
            at = e
    return worst, at


@njit(cache=True)
def first_non_finite(x):
    """Index of the first entry of ``x (n,)`` that is NaN or infinite, ``-1`` if there is none."""
    for i in range(x.shape[0]):
        if not (abs(x[i]) <= _DBL_MAX):
            return i
    return -1


@njit(cache=True)
def constrained_work(residual, fixed, f_applied, q_new, q_old):
    """Work (J) done on the rods during a step by the supports and the applied loads:
    ``sum_fixed r_i dq_i + f_applied . dq``.

    ``residual (n_dofs,)``: the step's full residual at ``q_new`` (at a constrained unknown, the
    force or moment the support exerts, N or N m); ``fixed (n_dofs,)`` bool; ``f_applied (n_dofs,)``
    applied forces and moments other than gravity; ``q_new``, ``q_old (n_dofs,)``."""
    w = 0.0
    for i in range(q_new.shape[0]):
        dq = q_new[i] - q_old[i]
        f = f_applied[i]
        if fixed[i]:
            f += residual[i]
        w += f * dq
    return w
