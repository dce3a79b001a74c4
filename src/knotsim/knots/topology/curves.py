"""Input curves of the topology tools: validation and the error type.

A rope centreline is an ``(N, 3)`` float array of node positions (m); the tools take a list of them.
"""

from __future__ import annotations

import numpy as np

from knotsim.errors import GeometryError


class TopologyError(GeometryError):
    """Curves whose topology cannot be computed (too few points, NaN, self-intersecting, ...)."""


def _as_curve_list(curves) -> list[np.ndarray]:
    if isinstance(curves, np.ndarray):
        if curves.ndim == 2:
            curves = [curves]
        elif curves.ndim != 3:
            raise TopologyError(
                f"curves: expected a list of (N, 3) arrays, got an array of shape {curves.shape}"
            )
    out = []
    for k, c in enumerate(curves):
        a = np.asarray(c, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != 3:
            raise TopologyError(f"curves[{k}]: expected shape (N, 3), got {a.shape}")
        if a.shape[0] < 2:
            raise TopologyError(f"curves[{k}]: a rope needs at least 2 points, got {a.shape[0]}")
        if not np.all(np.isfinite(a)):
            raise TopologyError(f"curves[{k}]: contains NaN or infinite coordinates")
        out.append(a)
    if not out:
        raise TopologyError("curves: empty list, give at least one (N, 3) centreline")
    return out


def _as_closed_flags(closed, n: int) -> list[bool]:
    if closed is None:
        return [False] * n
    if isinstance(closed, bool | np.bool_):
        return [bool(closed)] * n
    flags = [bool(f) for f in closed]
    if len(flags) != n:
        raise TopologyError(f"closed: expected {n} flags (one per rope), got {len(flags)}")
    return flags


def _dedupe(a: np.ndarray, closed: bool, tol: float) -> np.ndarray:
    """Remove consecutive duplicate nodes (and the repeated first node of a closed curve)."""
    keep = np.ones(len(a), dtype=bool)
    keep[1:] = np.linalg.norm(np.diff(a, axis=0), axis=1) > tol
    a = a[keep]
    if closed and len(a) > 1 and np.linalg.norm(a[-1] - a[0]) <= tol:
        a = a[:-1]
    return a
