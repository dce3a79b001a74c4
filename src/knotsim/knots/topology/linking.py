"""3D Gauss integrals of closed polygons (exact for polygons): linking number and writhe."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from knotsim.knots.topology.curves import _as_curve_list


@njit(cache=True)
def _solid_angle(p1, p2, p3, p4):
    """Signed solid-angle term of segments p1->p2 and p3->p4 (Klenin & Langowski 2000), /(4 pi) later."""
    r13 = p3 - p1
    r14 = p4 - p1
    r23 = p3 - p2
    r24 = p4 - p2
    n1 = np.cross(r13, r14)
    n2 = np.cross(r14, r24)
    n3 = np.cross(r24, r23)
    n4 = np.cross(r23, r13)
    l1 = math.sqrt(n1 @ n1)
    l2 = math.sqrt(n2 @ n2)
    l3 = math.sqrt(n3 @ n3)
    l4 = math.sqrt(n4 @ n4)
    if l1 == 0.0 or l2 == 0.0 or l3 == 0.0 or l4 == 0.0:
        return 0.0
    n1 = n1 / l1
    n2 = n2 / l2
    n3 = n3 / l3
    n4 = n4 / l4
    om = (
        math.asin(min(1.0, max(-1.0, n1 @ n2)))
        + math.asin(min(1.0, max(-1.0, n2 @ n3)))
        + math.asin(min(1.0, max(-1.0, n3 @ n4)))
        + math.asin(min(1.0, max(-1.0, n4 @ n1)))
    )
    s = np.cross(p4 - p3, p2 - p1) @ r13
    if s > 0:
        return om
    if s < 0:
        return -om
    return 0.0


@njit(cache=True)
def _gauss_sum(A, B, same):
    na = A.shape[0]
    nb = B.shape[0]
    tot = 0.0
    for i in range(na):
        i1 = (i + 1) % na
        j0 = i + 1 if same else 0
        for j in range(j0, nb):
            j1 = (j + 1) % nb
            if same and (j == i1 or j1 == i):
                continue
            tot += _solid_angle(A[i], A[i1], B[j], B[j1])
    return tot / (4.0 * math.pi)


def gauss_linking_number(curve_a, curve_b) -> float:
    """Gauss linking integral of two closed polygons (``(N, 3)`` and ``(M, 3)`` arrays, m).

    Exact for polygons up to rounding, so the result is within ~1e-9 of an integer for disjoint
    curves.  Same sign convention as :meth:`Diagram.linking_matrix`.
    """
    a, b = _as_curve_list([curve_a, curve_b])
    return float(_gauss_sum(a, b, False))


def writhe_3d(curve) -> float:
    """3D writhe (Gauss double integral) of a closed polygon ``(N, 3)`` (m); dimensionless.

    Equals the average of the diagram writhe over all projection directions.
    """
    (a,) = _as_curve_list([curve])
    return 2.0 * float(_gauss_sum(a, a, True))
