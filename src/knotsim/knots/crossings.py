"""Crossings of the ``xy`` projection of rope polylines, with over/under from ``z`` and signs.

The crossings are found by the sweep of :mod:`knotsim.geometry.planar` (half-open ratios, so a
crossing exactly at a node counts once). Lengths in metres.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from knotsim.geometry.planar import segment_crossings
from knotsim.knots.clearance import RopeEdges


@dataclass(frozen=True)
class PlanarCrossing:
    """A crossing of the projection of the ropes onto the ``xy`` plane.

    Attributes
    ----------
    over_rope, over_edge, over_t:
        Rope index, edge index and ratio along that edge of the over strand.
    under_rope, under_edge, under_t:
        Same for the under strand.
    point:
        ``(x, y)`` of the crossing (m).
    gap:
        Height of the over strand above the under strand there (m).
    sign:
        +1 for a right-handed (positive) crossing, -1 for a left-handed one, with the ropes
        oriented from their first to their last node.
    """

    over_rope: int
    over_edge: int
    over_t: float
    under_rope: int
    under_edge: int
    under_t: float
    point: tuple[float, float]
    gap: float
    sign: int


def _planar_intersections(x2: np.ndarray, edges: RopeEdges):
    """All proper intersections of the 2D polylines (edges sharing a node are skipped).

    ``x2`` is the ``(Ntot, 2)`` projected node array of the ropes of ``edges``. Returns ``(n,)``
    arrays: global edge indices ``i < j`` and ratios ``s, t`` along them, sorted by ``(i, j)``;
    half-open ranges ``[0, 1)`` make a crossing exactly at a node count once.
    """
    x2 = np.asarray(x2, dtype=np.float64)
    pad = 1e-9 * float(np.ptp(x2, axis=0).max()) if len(x2) else 0.0
    i, s, j, t, _ = segment_crossings(x2[:, 0], x2[:, 1], edges.i0, edges.i1, half_open=True,
                                      eps_parallel=1e-14, pad=pad)
    # lower global edge first, pairs in lexicographic order
    swap = i > j
    i, j, s, t = np.where(swap, j, i), np.where(swap, i, j), np.where(swap, t, s), np.where(swap, s, t)
    order = np.lexsort((j, i))
    return i[order], j[order], s[order], t[order]


def projected_crossings(ropes: Sequence[np.ndarray]) -> list[PlanarCrossing]:
    """Crossings of the ``xy`` projection of 3D polylines, with over/under from ``z`` and signs.

    Parameters
    ----------
    ropes:
        Node arrays, each ``(N_r, 3)``.

    Returns
    -------
    list of :class:`PlanarCrossing`, in no particular order. The writhe of the projection is
    ``sum(c.sign for c in crossings)``.
    """
    arrs = [np.asarray(r, dtype=float) for r in ropes]
    edges = RopeEdges([len(r) for r in arrs])
    x = np.concatenate(arrs)
    i, j, s, t = _planar_intersections(x[:, :2], edges)
    out = []
    for a, b, sa, tb in zip(i, j, s, t, strict=True):
        pa = x[edges.i0[a]] + sa * (x[edges.i1[a]] - x[edges.i0[a]])
        pb = x[edges.i0[b]] + tb * (x[edges.i1[b]] - x[edges.i0[b]])
        if pa[2] < pb[2]:
            a, b, sa, tb, pa, pb = b, a, tb, sa, pb, pa
        da = x[edges.i1[a]] - x[edges.i0[a]]
        db = x[edges.i1[b]] - x[edges.i0[b]]
        cz = da[0] * db[1] - da[1] * db[0]
        out.append(PlanarCrossing(int(edges.rope[a]), int(edges.local[a]), float(sa),
                                  int(edges.rope[b]), int(edges.local[b]), float(tb),
                                  (float(pa[0]), float(pa[1])), float(pa[2] - pb[2]),
                                  1 if cz > 0 else -1))
    return out


def _gauss_signature(crossings, n_ropes: int):
    """Per rope, the ordered over/under letters, and the set of passage pairs of the crossings.

    ``crossings`` is a list of ``(rope_over, pos_over, rope_under, pos_under)`` with ``pos`` any
    position increasing along the rope. Passages are numbered ``(rope, k)`` in walking order, so
    two diagrams with the same signature have the same Gauss code.
    """
    passes: list[list[tuple[float, bool, int]]] = [[] for _ in range(n_ropes)]
    for c, (ro, po, ru, pu) in enumerate(crossings):
        passes[ro].append((po, True, c))
        passes[ru].append((pu, False, c))
    letters = []
    where: dict[int, list[tuple[int, int]]] = {}
    for r in range(n_ropes):
        seq = sorted(passes[r])
        letters.append(tuple(p[1] for p in seq))
        for k, p in enumerate(seq):
            where.setdefault(p[2], []).append((r, k))
    pairs = {tuple(sorted(v)) for v in where.values()}
    return letters, pairs


def _letters(seq: Sequence[bool]) -> str:
    return "".join("O" if b else "U" for b in seq)
