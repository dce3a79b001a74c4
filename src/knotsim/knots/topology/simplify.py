"""Reidemeister I and II simplification of PD codes."""

from __future__ import annotations

import numpy as np

from knotsim.knots.topology.curves import TopologyError


def _faces(X: list[list[int]]) -> list[list[tuple[int, int]]]:
    """Faces of a planar 4-valent diagram, as lists of corners ``(crossing, slot)``.

    Corner ``(x, p)`` is the angle between slots ``p`` and ``p+1`` (counterclockwise) of crossing
    ``x``; the next corner of the face is at the other end of the edge in slot ``p+1``.
    """
    occ: dict[int, list[tuple[int, int]]] = {}
    for i, x in enumerate(X):
        for s in range(4):
            occ.setdefault(x[s], []).append((i, s))
    seen = set()
    faces = []
    for i in range(len(X)):
        for p in range(4):
            if (i, p) in seen:
                continue
            face = []
            cur = (i, p)
            while cur not in seen:
                seen.add(cur)
                face.append(cur)
                ci, cp = cur
                s = (cp + 1) % 4
                o = occ[X[ci][s]]
                cur = o[1] if o[0] == (ci, s) else o[0]
            faces.append(face)
    return faces


def _relabel(X: list[list[int]], old: int, new: int) -> None:
    for x in X:
        for s in range(4):
            if x[s] == old:
                x[s] = new


def _merge(X: list[list[int]], keep: int, drop: int) -> int:
    """Join the two edges left by a removed strand: relabel ``drop`` as ``keep``. Returns 1 when they
    are the same edge (the strand closed into a crossing-free loop), else 0."""
    if keep == drop:
        return 1
    _relabel(X, drop, keep)
    return 0


def simplify_pd(pd, signs, free_loops: int = 0) -> tuple[list[tuple[int, int, int, int]], np.ndarray, int]:
    """Remove Reidemeister I kinks and Reidemeister II bigons until none is left.

    Parameters
    ----------
    pd:
        PD code (list of 4-tuples, KnotTheory convention).
    signs:
        ``(n,)`` crossing signs (kept for the surviving crossings).
    free_loops:
        Number of crossing-free components already present.

    Returns
    -------
    ``(pd, signs, free_loops)`` of the simplified diagram; components that lose all their crossings
    are counted in ``free_loops``.  The link type is unchanged; the writhe changes by the signs of
    the removed kinks.
    """
    X = [list(x) for x in pd]
    S = [int(s) for s in signs]
    if len(X) != len(S):
        raise TopologyError(f"simplify_pd: {len(X)} crossings but {len(S)} signs")
    free = int(free_loops)
    while True:
        done = False
        # Reidemeister I: an edge joining two adjacent slots of the same crossing
        for idx, x in enumerate(X):
            for p in range(4):
                if x[p] == x[(p + 1) % 4]:
                    u, v = x[(p + 2) % 4], x[(p + 3) % 4]
                    del X[idx]
                    del S[idx]
                    free += _merge(X, u, v)
                    done = True
                    break
            if done:
                break
        if done:
            continue
        # Reidemeister II: a bigon face whose first edge is over (or under) at both ends
        for face in _faces(X):
            if len(face) != 2:
                continue
            (xa, p), (xb, q) = face
            if xa == xb or (p + 1) % 2 != q % 2:
                continue
            A, B = X[xa], X[xb]
            m1 = (A[(p + 3) % 4], B[(q + 2) % 4])
            m2 = (A[(p + 2) % 4], B[(q + 3) % 4])
            for i in sorted((xa, xb), reverse=True):
                del X[i]
                del S[i]
            u1, v1 = m1
            free += _merge(X, u1, v1)
            u2, v2 = (u1 if m2[0] == v1 else m2[0]), (u1 if m2[1] == v1 else m2[1])
            free += _merge(X, u2, v2)
            done = True
            break
        if not done:
            break
    return [tuple(x) for x in X], np.array(S, dtype=np.int64), free
