"""Position-based relaxation of rope centrelines: push apart close edge pairs, keep edge lengths."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from knotsim.knots.clearance import RopeEdges


def _smooth_field(v: np.ndarray, edges: RopeEdges, passes: int) -> np.ndarray:
    """Smooth a per-node vector field along each rope with a [1, 2, 1]/4 kernel (ends mirrored)."""
    out = v.copy()
    for _ in range(passes):
        w = out.copy()
        for r in range(len(edges.counts)):
            a, b = edges.node_offset[r], edges.node_offset[r + 1]
            seg = out[a:b]
            if len(seg) < 3:
                continue
            w[a + 1:b - 1] = 0.25 * seg[:-2] + 0.5 * seg[1:-1] + 0.25 * seg[2:]
            w[a] = 0.5 * seg[0] + 0.5 * seg[1]
            w[b - 1] = 0.5 * seg[-1] + 0.5 * seg[-2]
        out = w
    return out


def _relax(x: np.ndarray, edges: RopeEdges, rest: np.ndarray, target: float, accept: float,
           max_iter: int, min_gap: int, stall_iter: int = 200,
           keep_out: Callable[[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    """Position-based relaxation: push apart close edge pairs, keep edge lengths.

    ``x`` is ``(Ntot, 3)``; ``rest`` the rest length of each global edge; pairs closer than
    ``target`` are pushed apart; stops when every pair is at least ``accept`` apart and edge
    strains are below 1e-4, or when the smallest distance has not grown for ``stall_iter``
    iterations. ``keep_out`` (optional) maps the nodes ``(Ntot, 3)`` back outside a rigid body (a post)
    after every iteration.
    """
    x = x.copy()
    lmax = float(rest.max())
    even = edges.local % 2 == 0
    groups = [np.flatnonzero(even), np.flatnonzero(~even)]
    zhat = np.array([0.0, 0.0, 1.0])
    best, best_it = -math.inf, 0
    for it in range(max_iter):
        pairs = edges.candidate_pairs(x, target + lmax, min_gap)
        if len(pairs):
            dist, s, t = edges.distances(x, pairs)
            close = dist < target
        else:
            close = np.zeros(0, dtype=bool)
        elen = np.linalg.norm(x[edges.i1] - x[edges.i0], axis=1)
        strain = float(np.max(np.abs(elen / rest - 1.0)))
        dmin = float(dist.min()) if close.any() else math.inf
        if dmin >= accept and strain < 1e-4:
            break
        if dmin > best * (1.0 + 1e-4) + 1e-12 * target:
            best, best_it = dmin, it
        elif it - best_it > stall_iter:  # no progress: give up, the caller reports the closest pair
            break
        if close.any():
            p = pairs[close]
            dist, s, t = dist[close], s[close], t[close]
            i, j = p[:, 0], p[:, 1]
            a0, a1, b0, b1 = edges.i0[i], edges.i1[i], edges.i0[j], edges.i1[j]
            pa = x[a0] + s[:, None] * (x[a1] - x[a0])
            pb = x[b0] + t[:, None] * (x[b1] - x[b0])
            n = pa - pb
            nn = np.linalg.norm(n, axis=1)
            tiny = nn < 1e-12 * target
            n = np.where(tiny[:, None], zhat, n / np.where(tiny, 1.0, nn)[:, None])
            w = (1 - s) ** 2 + s**2 + (1 - t) ** 2 + t**2
            lam = (target - dist) / w
            dx = np.zeros_like(x)
            cnt = np.zeros(len(x))
            for idx, coef in ((a0, lam * (1 - s)), (a1, lam * s), (b0, -lam * (1 - t)), (b1, -lam * t)):
                np.add.at(dx, idx, coef[:, None] * n)
                np.add.at(cnt, idx, np.abs(coef) > 0)
            dx /= np.maximum(cnt, 1.0)[:, None]
            peak = np.linalg.norm(dx, axis=1).max()
            dx = _smooth_field(dx, edges, 2)
            sm = np.linalg.norm(dx, axis=1).max()
            if sm > 0:  # keep the strongest push after smoothing
                dx *= min(peak / sm, 2.5)
            x += dx
        for _sweep in range(4):
            for g in groups:
                i0, i1 = edges.i0[g], edges.i1[g]
                e = x[i1] - x[i0]
                le = np.linalg.norm(e, axis=1)
                corr = (0.5 * (le - rest[g]) / le)[:, None] * e
                x[i0] += corr
                x[i1] -= corr
        if keep_out is not None:
            x = keep_out(x)
    return x
