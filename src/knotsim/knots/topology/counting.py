"""Patil's topological counting rules for bends: crossing number N, twist fluctuation τ, circulation Γ.

Patil, Sandt, Kolle and Dunkel (Science 2020) rank bends (two ropes tied together, one end of each
loaded, the two tails free) by three numbers read off a knot diagram once the loaded ends are known.
This module computes them from rope centrelines; the wording below is ours.

Orientation from the loading
    Every rope is oriented from its loaded end towards its free tail: the direction in which the
    tension enters the knot. A rope with no loaded end, or with both ends loaded, has no such
    orientation and is refused (give ``loaded`` explicitly).

N, the crossing number
    The number of crossings of the projection (the drawing plane for library drawings). It is the
    crossing number of the *diagram*, not the minimal crossing number of the knot type; library
    drawings are drawn with as few crossings as the bend needs.

Twist and τ, the twist fluctuation
    At each crossing the two strands, oriented by the loading, turn about each other in one sense or
    the other: the crossing's *twist* is its sign under the loading orientation (right-hand rule,
    ``+1`` when the over strand turns counterclockwise onto the under strand seen by the viewer, the
    convention of :mod:`knotsim.knots.topology`). Walking along each rope from its loaded end, the
    twists of consecutive crossings met either agree or change sign. τ is half the number of sign
    changes met on all the ropes together: every crossing is met twice (once on each strand), so a
    reversal of handedness between two groups of crossings is met once on each rope and counts once.
    A reef or thief bend (a left half knot against a right one) has τ = 1; a granny or grief bend (two
    half knots of the same hand) has τ = 0. τ can be a half-integer when the two ropes meet a
    different number of reversals.

Γ, the circulation
    The crossings cut the projected ropes into arcs and the plane into faces. A bounded face
    *circulates* when the arcs of its boundary, oriented by the loading, all run the same way round
    it (all clockwise or all counterclockwise), so the ropes bounding it form a closed flow. Γ is the
    number of circulating faces. A face reached by a rope end is bounded by the same arc in both
    directions and never circulates; the unbounded face is not counted. Between two antiparallel
    strands twisted about each other (a reef's or granny's braids, whose two ropes are loaded from
    opposite sides) every lens circulates; between parallel strands (thief, grief) none does, and
    the large face between the two bights does instead: reef and granny Γ = 4, thief and grief Γ = 1.

Reversing every rope changes none of the three numbers; reversing one rope of two changes the twist
of every crossing between them and the circulation, which is why the loaded ends must be known (the
reef and thief bends are the same drawing loaded at different ends). Patil's rules then rank the
bends: more twist fluctuation and more circulation hold better; reef > granny and thief > grief (τ),
reef > thief and granny > grief (Γ), granny against thief undecided.

Everything here is scalar Python on a diagram of tens of crossings (not a hot path). Lengths are in
the units of the input (m for knotsim geometry); arrays of node positions have shape ``(N_r, 3)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from knotsim.knots.crossings import projected_crossings
from knotsim.knots.topology.curves import TopologyError

__all__ = ["CountingRules", "counting_rules", "knot_counting_rules"]

End = tuple[int, int]  # (rope index, 0 = first node | 1 = last node)


@dataclass(frozen=True)
class CountingRules:
    """Patil's counting rules of one bend under one loading (definitions: module docstring).

    Attributes
    ----------
    n_crossings:
        N, crossings of the projection.
    twist_fluctuation:
        τ, half the number of twist sign changes along the ropes (a multiple of 0.5).
    circulation:
        Γ, number of bounded faces whose boundary arcs all run the same way round.
    twists:
        ``(N,)`` int array, the twist (+1 / -1) of each crossing under the loading orientation.
    sign_changes:
        Twist sign changes met along each rope, walking from its loaded end.
    orientation:
        Per rope, ``+1`` when its loaded end is its first node (oriented first -> last), else ``-1``.
    n_bounded_faces:
        Bounded faces of the projection (the circulating ones among them make Γ).
    circulating_senses:
        ``+1`` (counterclockwise, seen by the viewer) or ``-1`` for each circulating face.
    """

    n_crossings: int
    twist_fluctuation: float
    circulation: int
    twists: np.ndarray
    sign_changes: tuple[int, ...]
    orientation: tuple[int, ...]
    n_bounded_faces: int
    circulating_senses: tuple[int, ...]

    def as_dict(self) -> dict:
        """``{"N": ..., "tau": ..., "Gamma": ...}`` (plain Python numbers)."""
        return {"N": self.n_crossings, "tau": self.twist_fluctuation, "Gamma": self.circulation}


def _orientation(n_ropes: int, loaded: Sequence[End]) -> tuple[int, ...]:
    ends: dict[int, list[int]] = {}
    for item in loaded:
        try:
            r, e = (int(v) for v in item)
        except (TypeError, ValueError):
            raise TopologyError(f"loaded: each item must be (rope, end), got {item!r}") from None
        if not 0 <= r < n_ropes:
            raise TopologyError(f"loaded: rope index {r} out of range (there are {n_ropes} ropes)")
        if e not in (0, 1):
            raise TopologyError(f"loaded: end must be 0 (first node) or 1 (last node), got {e}")
        ends.setdefault(r, []).append(e)
    out = []
    for r in range(n_ropes):
        e = sorted(set(ends.get(r, [])))
        if len(e) != 1:
            what = "no loaded end" if not e else "both ends loaded"
            raise TopologyError(f"loaded: rope {r} has {what}; the counting rules orient every rope from its "
                                "one loaded end to its free tail, so give exactly one loaded end per rope")
        out.append(+1 if e[0] == 0 else -1)
    return tuple(out)


def _to_view(ropes: list[np.ndarray], direction) -> list[np.ndarray]:
    """Ropes in coordinates ``(e1, e2, d)`` with ``d`` pointing at the viewer (right-handed)."""
    d = np.asarray(direction, dtype=float)
    if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
        raise TopologyError(f"direction: need a non-zero 3-vector, got {direction!r}")
    d = d / np.linalg.norm(d)
    a = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = a - (a @ d) * d
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    basis = np.column_stack([e1, e2, d])
    return [r @ basis for r in ropes]


def counting_rules(ropes: Sequence[np.ndarray], loaded: Sequence[End],
                   direction=(0.0, 0.0, 1.0)) -> CountingRules:
    """Patil's N, τ and Γ of open ropes seen along ``direction`` (definitions: module docstring).

    Parameters
    ----------
    ropes:
        Centrelines, each ``(N_r, 3)`` (any length unit).
    loaded:
        ``(rope, end)`` of the loaded end of every rope (end 0 = first node, 1 = last node).
    direction:
        ``(3,)`` viewing direction, pointing at the viewer (default ``+z``: the drawing plane of the
        library drawings, and the view of Patil's figures).

    Raises
    ------
    TopologyError
        Bad ``loaded`` or ``direction``, or a degenerate projection (a crossing at a rope end).
    """
    arrs = [np.asarray(r, dtype=float) for r in ropes]
    for k, r in enumerate(arrs):
        if r.ndim != 2 or r.shape[1] != 3 or len(r) < 2 or not np.all(np.isfinite(r)):
            raise TopologyError(f"ropes[{k}]: need a finite (N, 3) array with N >= 2, got shape {r.shape}")
    orient = _orientation(len(arrs), loaded)
    view = _to_view(arrs, direction)
    xs = projected_crossings(view)
    n = len(xs)
    # passages: per rope, (position along rope, crossing, is_over)
    passages: list[list[tuple[float, int, bool]]] = [[] for _ in arrs]
    twists = np.zeros(n, dtype=np.int64)
    for c, x in enumerate(xs):
        passages[x.over_rope].append((x.over_edge + x.over_t, c, True))
        passages[x.under_rope].append((x.under_edge + x.under_t, c, False))
        twists[c] = x.sign * orient[x.over_rope] * orient[x.under_rope]
    for p in passages:
        p.sort()
    changes = []
    for r, p in enumerate(passages):
        seq = [twists[c] for _, c, _ in (p if orient[r] > 0 else p[::-1])]
        changes.append(int(sum(1 for a, b in zip(seq, seq[1:], strict=False) if a != b)))
    n_faces, senses = _circulating_faces(view, passages, orient)
    return CountingRules(
        n_crossings=n,
        twist_fluctuation=0.5 * sum(changes),
        circulation=len(senses),
        twists=twists,
        sign_changes=tuple(changes),
        orientation=orient,
        n_bounded_faces=n_faces,
        circulating_senses=tuple(senses),
    )


def _circulating_faces(view: list[np.ndarray], passages, orient) -> tuple[int, list[int]]:
    """Number of bounded faces of the projected ropes and the sense of each circulating one.

    Vertices are the crossings and the rope ends; arcs join consecutive passages along a rope. Faces
    are traced with the face on the left of every half-arc; the unbounded face of each connected
    piece is the one of most negative signed area.
    """
    # arcs: (rope, from vertex, to vertex, polyline (M, 2) in rope order)
    arcs = []
    for r, (x, p) in enumerate(zip(view, passages, strict=True)):
        stops = [(0.0, ("end", r, 0))] + [(s, ("x", c)) for s, c, _ in p] + [(len(x) - 1.0, ("end", r, 1))]
        for (s0, v0), (s1, v1) in zip(stops, stops[1:], strict=False):
            k0, k1 = int(math.floor(s0)) + 1, int(math.ceil(s1))
            pts = [_point(x, s0)] + [x[k, :2] for k in range(k0, k1)] + [_point(x, s1)]
            arcs.append((r, v0, v1, np.array(pts)))
    # half-arcs h = 2 * arc + (0 forward | 1 backward); at each vertex, outgoing half-arcs by angle
    out: dict[tuple, list[tuple[float, int]]] = {}
    for a, (_, v0, v1, pts) in enumerate(arcs):
        for h, v, pts_h in ((2 * a, v0, pts), (2 * a + 1, v1, pts[::-1])):
            d = _first_direction(pts_h)
            out.setdefault(v, []).append((math.atan2(d[1], d[0]), h))
    rot = {v: [h for _, h in sorted(lst)] for v, lst in out.items()}
    where = {h: (v, k) for v, hs in rot.items() for k, h in enumerate(hs)}

    def head(h: int):
        _, v0, v1, _ = arcs[h // 2]
        return v1 if h % 2 == 0 else v0

    seen: set[int] = set()
    faces = []
    for h0 in range(2 * len(arcs)):
        if h0 in seen:
            continue
        cyc = []
        h = h0
        while h not in seen:
            seen.add(h)
            cyc.append(h)
            v = head(h)
            twin = h ^ 1
            hs = rot[v]
            k = where[twin][1]
            h = hs[(k - 1) % len(hs)]  # the next half-arc clockwise from the twin keeps the face on the left
        faces.append(cyc)
    # connected pieces (by shared arcs) and signed areas
    area = []
    for cyc in faces:
        pts = np.concatenate([arcs[h // 2][3] if h % 2 == 0 else arcs[h // 2][3][::-1] for h in cyc])
        area.append(0.5 * float(np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1])))
    piece = _pieces(faces, len(arcs))
    outer = set()
    for pc in set(piece):
        members = [f for f in range(len(faces)) if piece[f] == pc]
        outer.add(min(members, key=lambda f: area[f]))
    senses = []
    n_bounded = 0
    for f, cyc in enumerate(faces):
        if f in outer:
            continue
        n_bounded += 1
        # a half-arc runs with its rope's loading orientation when forward along an oriented-forward rope
        along = {(h % 2 == 0) == (orient[arcs[h // 2][0]] > 0) for h in cyc}
        if len(along) == 1 and len({h // 2 for h in cyc}) == len(cyc):
            senses.append(+1 if along.pop() else -1)
    return n_bounded, senses


def _pieces(faces: list[list[int]], n_arcs: int) -> list[int]:
    """Connected piece of every face (faces sharing an arc are in the same piece)."""
    parent = list(range(n_arcs))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for cyc in faces:
        for h in cyc[1:]:
            parent[find(h // 2)] = find(cyc[0] // 2)
    return [find(cyc[0] // 2) for cyc in faces]


def _point(x: np.ndarray, s: float) -> np.ndarray:
    k = min(int(math.floor(s)), len(x) - 2)
    t = s - k
    return (1.0 - t) * x[k, :2] + t * x[k + 1, :2]


def _first_direction(pts: np.ndarray) -> np.ndarray:
    for q in pts[1:]:
        d = q - pts[0]
        if np.hypot(d[0], d[1]) > 0:
            return d
    raise TopologyError("counting_rules: a zero-length arc between two crossings (degenerate projection)")


def knot_counting_rules(geo, loaded: Sequence[End] | None = None, direction=(0.0, 0.0, 1.0)) -> CountingRules:
    """:func:`counting_rules` of a built knot (:class:`knotsim.knots.geometry.KnotGeometry`).

    ``loaded`` defaults to the drawing's ``held`` and ``pulled`` end hints (one per rope in a bend).
    """
    if loaded is None:
        loaded = []
        for ref in tuple(geo.held) + tuple(geo.pulled):
            n_last = len(geo.ropes[ref.rope]) - 1
            if ref.node not in (0, n_last):
                raise TopologyError(f"knot {geo.name!r}: loaded node {ref.node} of rope {ref.rope} is not an end; "
                                    "give loaded=[(rope, end), ...]")
            loaded.append((ref.rope, 0 if ref.node == 0 else 1))
    return counting_rules(list(geo.ropes), loaded, direction)
