"""Numba kernels of the per-step bookkeeping of :class:`knotsim.contact.model.Contact`: the gap
statistics of the candidate pairs and the records of the pairs whose friction the spin relaxation
sees. Each replaces a
handful of numpy calls on small arrays (one dispatch instead of several, no temporaries) and gives
exactly the numbers those calls gave.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["gap_summary", "live_spin_records"]


@njit(cache=True)
def gap_summary(delta, pair_d, pair_hmin, contact_range):
    """Statistics of the pairs' gaps ``g = Δ − d`` (m).

    ``delta`` (k,) distances Δ (m), ``pair_d`` (k,) contact distances ``d`` (m), ``pair_hmin``
    (k,) smaller radii (m), ``contact_range`` δ (m). Returns ``(n_contacts, min_gap, worst,
    max_ratio)``: the number of pairs with ``g < δ``; ``min g`` (NaN if a gap is NaN, as
    ``numpy.min``; +inf for ``k = 0``); the first pair of largest penetration ratio ``(d − Δ)/h``
    (the first NaN ratio if there is one, as ``numpy.argmax``) and that ratio (NaN if a ratio is
    NaN, as ``numpy.max``; -inf for ``k = 0``).
    """
    n = 0
    min_gap = math.inf
    gap_nan = False
    worst = 0
    best = -math.inf
    ratio_nan = False
    for i in range(delta.shape[0]):
        g = delta[i] - pair_d[i]
        if g < contact_range:
            n += 1
        if g != g:
            gap_nan = True
        elif g < min_gap:
            min_gap = g
        r = (pair_d[i] - delta[i]) / pair_hmin[i]
        if ratio_nan:
            continue
        if r != r:
            ratio_nan = True
            worst = i
            best = r
        elif r > best or i == 0:
            worst = i
            best = r
    if gap_nan:
        min_gap = math.nan
    return n, min_gap, worst, best


@njit(cache=True)
def live_spin_records(surface, pair_theta, first, size):
    """The surface-friction records of the pairs that carry friction, with their angle unknowns.

    ``surface`` (k, c) float64, the contact loop's ``pair_surface`` (its columns ``first`` to
    ``first + size`` hold each pair's record, in which column 9 is ``F_n`` (N) and 10 the friction
    coefficient; see :func:`knotsim.contact.surface_friction.surface_friction_pair`);
    ``pair_theta`` (k, 2) int64, each pair's two angle unknowns. Returns ``(theta_dofs (m, 2) int64,
    record (m, size) float64)`` of the ``m`` pairs with ``F_n × coefficient > 0``, in their order.
    """
    k = surface.shape[0]
    m = 0
    for i in range(k):
        if surface[i, first + 9] * surface[i, first + 10] > 0.0:
            m += 1
    theta = np.empty((m, 2), dtype=np.int64)
    record = np.empty((m, size))
    j = 0
    for i in range(k):
        if surface[i, first + 9] * surface[i, first + 10] > 0.0:
            theta[j, 0] = pair_theta[i, 0]
            theta[j, 1] = pair_theta[i, 1]
            for c in range(size):
                record[j, c] = surface[i, first + c]
            j += 1
    return theta, record
