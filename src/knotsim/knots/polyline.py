"""Dense polylines of knot drawings: spline smoothing, arc length, resampling, trimming, bumps.

Arrays are ``(K, 2)`` or ``(K, 3)`` node positions (drawing units or m).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import CubicSpline


def _smooth_planar(wp: np.ndarray, ds: float) -> np.ndarray:
    """Centripetal natural cubic spline through ``wp`` ``(M, 2)``, resampled by arc length at a
    spacing close to ``ds`` (drawing units). Returns ``(K, 2)``."""
    if len(wp) == 2:
        n = max(2, int(math.ceil(np.linalg.norm(wp[1] - wp[0]) / ds)) + 1)
        return wp[0] + np.linspace(0.0, 1.0, n)[:, None] * (wp[1] - wp[0])
    u = np.concatenate([[0.0], np.cumsum(np.sqrt(np.linalg.norm(np.diff(wp, axis=0), axis=1)))])
    spl = CubicSpline(u, wp, bc_type="natural")
    fine = spl(np.linspace(0.0, u[-1], 64 * len(wp) + 1))
    return _resample_polyline(fine, ds)


def _arc(x: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))])


def _resample_polyline(x: np.ndarray, ds: float) -> np.ndarray:
    s = _arc(x)
    n = max(2, int(math.ceil(s[-1] / ds)) + 1)
    return _interp_at(x, s, np.linspace(0.0, s[-1], n))


def _interp_at(x: np.ndarray, s: np.ndarray, q: np.ndarray) -> np.ndarray:
    return np.stack([np.interp(q, s, x[:, k]) for k in range(x.shape[1])], axis=1)


def _bump(u: np.ndarray) -> np.ndarray:
    """C2 compact bump ``(1 - u^2)^3`` on ``|u| < 1``, 0 outside; 1 at 0 with zero slope."""
    v = np.clip(1.0 - u * u, 0.0, None)
    return v * v * v


def _trim_or_extend(x: np.ndarray, target: float, split: float = 0.5, tangent_span: float | None = None) -> np.ndarray:
    """Cut both ends (or extend them straight along the end tangents) so that the dense polyline
    ``x`` ``(K, 3)`` has arc length ``target``; an extension gives the share ``split`` of the missing
    length to the start and the rest to the end (a cut is always shared equally). The end tangents
    are taken over ``tangent_span`` (m) of the curve (default: 2 % of ``target``, at most a quarter of
    the curve)."""
    s = _arc(x)
    excess = s[-1] - target
    if excess >= 0:
        q = np.concatenate([[0.5 * excess], s[(s > 0.5 * excess) & (s < s[-1] - 0.5 * excess)],
                            [s[-1] - 0.5 * excess]])
        return _interp_at(x, s, q)
    span = min(s[-1] / 4, 0.02 * target) if tangent_span is None else tangent_span
    k = max(1, min(len(x) - 1, int(np.searchsorted(s, span))))
    t0 = x[0] - x[k]
    t1 = x[-1] - x[-1 - k]
    t0 /= np.linalg.norm(t0)
    t1 /= np.linalg.norm(t1)
    ds = s[-1] / (len(x) - 1)

    def tail(ext: float) -> np.ndarray:  # distances out along a tail, outermost first, 0 excluded
        if ext <= 0:
            return np.zeros((0, 1))
        n = max(2, int(math.ceil(ext / ds)) + 1)
        return np.linspace(1.0, 0.0, n)[:-1, None] * ext

    a0, a1 = tail(-split * excess), tail(-(1.0 - split) * excess)
    return np.concatenate([x[0] + a0 * t0, x, x[-1] + a1[::-1] * t1])


def _fix_edge_lengths(x: np.ndarray, length: float) -> np.ndarray:
    """Make every edge of a polyline exactly ``length`` by moving nodes along their edges,
    sweeping outwards from the middle node (displacements are tiny when edges are nearly right)."""
    y = x.copy()
    m = len(y) // 2
    for k in range(m, len(y) - 1):
        e = y[k + 1] - y[k]
        y[k + 1] = y[k] + e * (length / np.linalg.norm(e))
    for k in range(m, 0, -1):
        e = y[k - 1] - y[k]
        y[k - 1] = y[k] + e * (length / np.linalg.norm(e))
    return y
