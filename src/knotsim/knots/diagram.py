"""Crossing diagrams of knot drawings: the crossings of a projected drawing matched with its
over/under letters, the lifts that make them, and the check that a built geometry still has them.

Shared by the planar drawings (:mod:`knotsim.knots.build`) and the drawings on a post's surface
(:mod:`knotsim.knots.post`). Lengths in metres.
"""

from __future__ import annotations

import numpy as np

from knotsim.errors import ConfigError, GeometryError
from knotsim.knots.clearance import ClosestPair, RopeEdges
from knotsim.knots.crossings import (
    PlanarCrossing,
    _gauss_signature,
    _letters,
    _planar_intersections,
    projected_crossings,
)
from knotsim.knots.polyline import _bump
from knotsim.knots.spec import KnotSpec

__all__ = ["check_diagram", "crossing_lifts", "match_letters"]


def match_letters(spec: KnotSpec, planar: list[np.ndarray], arcs: list[np.ndarray], length: float):
    """Crossings of the dense projected curves ``planar`` (one ``(K, 2)`` array per rope), matched with
    the drawing's over/under letters. ``arcs``: arc positions (m) of the curves' points.

    Returns ``(passages, visits)``: per rope the ``(arc position, crossing id)`` of every crossing met
    along it, in order; per crossing id its two ``(rope, arc position, is_over)`` passages."""
    n_ropes = len(spec.ropes)
    names = [r.name for r in spec.ropes]
    pedges = RopeEdges([len(p) for p in planar])
    px = np.concatenate(planar)
    ci, cj, cs, ct = _planar_intersections(px, pedges)

    def arcpos(e: int, u: float) -> tuple[int, float]:
        r = int(pedges.rope[e])
        k = int(pedges.local[e])
        return r, float(arcs[r][k] + u * (arcs[r][k + 1] - arcs[r][k]))

    passages: list[list[tuple[float, int]]] = [[] for _ in range(n_ropes)]
    for c, (e1, u1, e2, u2) in enumerate(zip(ci, cs, cj, ct, strict=True)):
        for r, sv in (arcpos(e1, u1), arcpos(e2, u2)):
            passages[r].append((sv, c))
    for r, rs in enumerate(spec.ropes):
        passages[r].sort()
        if len(passages[r]) != len(rs.passes):
            raise ConfigError(
                f"{spec.name}: ropes[{r}].crossings",
                f"the smoothed drawing of rope {rs.name!r} passes through {len(passages[r])} crossings "
                f"({len(ci)} crossings in the whole drawing) but {len(rs.passes)} over/under letters "
                f"are declared ({_letters(rs.passes)!r}); fix the waypoints or the letters")
    visits: dict[int, list[tuple[int, float, bool]]] = {}
    for r in range(n_ropes):
        for (sv, c), is_over in zip(passages[r], spec.ropes[r].passes, strict=True):
            visits.setdefault(c, []).append((r, sv, is_over))
    for (ra, sa, oa), (rb, sb, ob) in visits.values():
        if oa == ob:
            raise ConfigError(
                f"{spec.name}: crossings",
                f"crossing at arc length {sa / length:.3f} L of rope {names[ra]!r} and "
                f"{sb / length:.3f} L of rope {names[rb]!r} is declared {'over' if oa else 'under'} on "
                f"both strands")
    return passages, visits


def crossing_lifts(spec: KnotSpec, passages, arcs: list[np.ndarray], amp: float, wmax: float,
                   under: float = -1.0) -> list[np.ndarray]:
    """Per rope, the lift (m) of each point of the dense curve: compact bumps of height ``amp`` (over)
    or ``under * amp`` (under) centred on its crossings, each at most ``wmax`` wide and vanishing,
    with zero slope, at the neighbouring crossings of the same rope."""
    z = [np.zeros(len(a)) for a in arcs]
    for r in range(len(spec.ropes)):
        pos = np.array([sv for sv, _ in passages[r]])
        for (sv, _), is_over in zip(passages[r], spec.ropes[r].passes, strict=True):
            others = np.abs(pos - sv)
            others = others[others > 0]
            w = min(wmax, float(others.min())) if len(others) else wmax
            z[r] += (amp if is_over else under * amp) * _bump((arcs[r] - sv) / w)
    return z


def check_diagram(where: str, projected: tuple[np.ndarray, ...] | list[np.ndarray], spec: KnotSpec, visits,
                  cp: ClosestPair) -> list[PlanarCrossing]:
    """The crossings of ``projected`` (ropes ``(N, 3)`` whose ``xy`` is the drawing's plane and ``z`` the
    height over it); :class:`GeometryError` unless they have the declared crossing diagram."""
    n_ropes = len(spec.ropes)
    names = [r.name for r in spec.ropes]
    xing = projected_crossings(projected)
    want_letters = [rs.passes for rs in spec.ropes]
    decl = []
    for (ra, sa, oa), (rb, sb, _) in visits.values():
        decl.append((ra, sa, rb, sb) if oa else (rb, sb, ra, sa))
    _, want_pairs = _gauss_signature(decl, n_ropes)
    got = [(c.over_rope, c.over_edge + c.over_t, c.under_rope, c.under_edge + c.under_t) for c in xing]
    got_letters, got_pairs = _gauss_signature(got, n_ropes)
    if [tuple(v) for v in got_letters] != [tuple(v) for v in want_letters] or got_pairs != want_pairs:
        raise GeometryError(
            f"{where}: the relaxed geometry no longer has the declared crossing diagram: got "
            f"{', '.join(f'{n}: {_letters(g)!r}' for n, g in zip(names, got_letters, strict=True))}; declared "
            f"{', '.join(f'{n}: {_letters(g)!r}' for n, g in zip(names, want_letters, strict=True))} "
            f"(closest pair: {cp.describe()}). Use more nodes, a thinner rod, or spread the drawing out")
    return xing
