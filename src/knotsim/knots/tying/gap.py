"""How far apart the two half-knots of a tied single-rod reef or granny are: :func:`half_knot_gap`.

Definition (``half_knot_gap``, m). The open centreline is closed far away (as
:func:`knotsim.knots.topology.analyze` does) and projected; along the closed curve every crossing is
met twice. A *split* of the diagram is a pair of cut points on the closed curve such that each of the
two stretches between them holds both passes of each of its crossings, and each stretch, taken alone
(its crossings with their signs, the cut points joined by an arc that crosses nothing), is a
non-trivial knot: the two prime factors of ``3_1 # 3_1*`` (reef) or ``3_1 # 3_1`` (granny), the two
half-knots. The *connecting arcs* are the two pieces of curve between the last pass of one factor
and the first pass of the other. An arc that runs through the far closure is not rope; the others
are, and ``half_knot_gap`` is the arc length of the longest rope arc. Two knots tied one after the
other along the rope (*in series*) have one rope arc, the rope between them; the studied form (the
second half-knot tied on top of the first, both legs of the first running through the second:
*nested*) has two, the short bends that take each leg from the first half-knot into the second.
The projection is the one of fewest crossings, among the rope's principal axes (a flat knot seen
face on) and seeded random directions, whose diagram splits; of its splits the one of smallest gap
is reported (a kink or a nugatory crossing near a cut can sit on either side of it). ``None`` when
no projection splits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["HalfKnotGap", "half_knot_gap"]


@dataclass
class HalfKnotGap:
    """Result of :func:`half_knot_gap`.

    ``gap`` (m) and ``diameters`` (gap / rope diameter, 1), ``None`` when no split was found;
    ``arcs``: arc lengths (m) of the connecting arcs that are rope (one: in series, two: nested);
    ``form``: ``"nested"`` or ``"in series"``; ``inner_type`` / ``outer_type``: knot types of the
    factor that lies within the rope and of the one that holds the far closure; ``inner_range``
    (m, m): arc lengths along the rope of the inner factor's first and last passes;
    ``hold_node``: node at the middle of the longest crossing-free stretch inside the inner factor
    (the bottom of the first knot's loop in the studied form); ``n_crossings``: crossings of the
    projection used; ``direction``: its (3,) direction."""

    gap: float | None
    diameters: float | None
    arcs: tuple = ()
    form: str | None = None
    inner_type: str | None = None
    outer_type: str | None = None
    inner_range: tuple | None = None
    hold_node: int | None = None
    n_crossings: int = 0
    direction: tuple | None = None

    def as_dict(self) -> dict:
        """JSON-ready dict (lengths in m)."""
        return {"half_knot_gap": self.gap, "half_knot_gap_diameters": self.diameters,
                "connecting_arcs": list(self.arcs), "form": self.form, "inner_factor": self.inner_type,
                "outer_factor": self.outer_type,
                "inner_factor_range": None if self.inner_range is None else list(self.inner_range),
                "hold_node": self.hold_node, "n_crossings": self.n_crossings,
                "direction": None if self.direction is None else list(self.direction)}


def _passes(comps, d, scale, n_rope: int, s_node: np.ndarray):
    """Crossings of the projection along ``d``: the :class:`Diagram` and, per crossing, the curve
    parameters (segment + fraction) of its over and under pass."""
    from knotsim.knots.topology.diagram import _diagram_from, _project_once

    proj = _project_once(comps, d, scale)
    if proj[-1]:
        return None
    dia = _diagram_from(comps, proj)
    (_, _, _), _, (_, _, h), _, nxt, sa, ta, sb, tb, _ = proj
    ha = h[sa] + ta * (h[nxt[sa]] - h[sa])
    hb = h[sb] + tb * (h[nxt[sb]] - h[sb])
    over = np.where(ha > hb, sa + ta, sb + tb)
    under = np.where(ha > hb, sb + tb, sa + ta)
    return dia, over, under


def _factor_type(dia, crossings: list[int], order: list[tuple[int, bool]]) -> str | None:
    """Knot type of the sub-diagram made of ``crossings`` met in the order ``order``; ``None`` when
    it is the unknot."""
    from knotsim.knots.topology.analyze import _name_knot
    from knotsim.knots.topology.diagram import Diagram
    from knotsim.knots.topology.simplify import simplify_pd

    idx = {c: k for k, c in enumerate(crossings)}
    n = len(crossings)
    sub = Diagram(direction=dia.direction, n_components=1, signs=dia.signs[crossings],
                  over_component=np.zeros(n, np.int64), under_component=np.zeros(n, np.int64),
                  positions=dia.positions[crossings], events=[[(idx[c], o) for c, o in order]])
    pd, signs, free = simplify_pd(*sub.pd_code())
    if not pd:
        return None
    alex, jones, entry = _name_knot(pd, signs, free, True, 80)
    if entry is not None:
        return None if entry.knot_type == "unknot" else entry.knot_type
    trivial = list(alex) == [1] and (jones is None or {k: v for k, v in jones.items() if v} == {0: 1})
    return None if trivial else "unknown"


def _best_split(dia, over, under, n_rope: int, s_node: np.ndarray, edge: np.ndarray):
    """The split of smallest gap of one diagram (see the module docstring), or ``None``."""
    n = len(over)
    if n < 6:
        return None
    param = np.concatenate([over, under])
    cid = np.concatenate([np.arange(n), np.arange(n)])
    is_over = np.concatenate([np.ones(n, bool), np.zeros(n, bool)])
    order = np.argsort(param, kind="stable")
    param, cid, is_over = param[order], cid[order], is_over[order]
    m = 2 * n

    def s_of(p):  # arc length along the rope (m) of a curve parameter on the rope
        k = min(int(p), n_rope - 2)
        return float(s_node[k] + (p - k) * edge[k])

    def rope_arc(a, b):  # the arc from pass a to pass b (b = a + 1 cyclically): length, or None
        if b == 0 or param[a] > n_rope - 1 or param[b] > n_rope - 1:
            return None
        return s_of(param[b]) - s_of(param[a])

    on_rope = param <= n_rope - 1

    def holds_closure(ks):  # a stretch of passes that runs through the far closure
        return any(not on_rope[k] for k in ks) or any(ks[q] == m - 1 and ks[q + 1] == 0 for q in range(len(ks) - 1))

    best = None
    for i in range(m):
        for length in range(6, m - 5):
            ins = [(i + q) % m for q in range(length)]
            inside = np.zeros(n, int)
            np.add.at(inside, cid[ins], 1)
            if np.any(inside == 1):
                continue
            outs = [(i + length + q) % m for q in range(m - length)]
            if ins[0] == 0 or outs[0] == 0:  # the closure lies on a connecting arc (in series):
                if ins[0] != 0 or holds_closure(ins) or holds_closure(outs):  # inner: the first
                    continue
            elif holds_closure(ins) or not holds_closure(outs):
                continue  # each split once: the inner stretch is the one off the closure
            arcs = [rope_arc((i - 1) % m, i), rope_arc(ins[-1], outs[0])]
            rope = [a for a in arcs if a is not None]
            if not rope:
                continue
            gap = max(rope)
            if best is not None and gap >= best[0]:
                continue
            t_in = _factor_type(dia, sorted(set(cid[ins].tolist())), [(int(cid[k]), bool(is_over[k])) for k in ins])
            if t_in is None:
                continue
            t_out = _factor_type(dia, sorted(set(cid[outs].tolist())),
                                 [(int(cid[k]), bool(is_over[k])) for k in outs])
            if t_out is None:
                continue
            best = (gap, tuple(sorted(rope)), "nested" if len(rope) == 2 else "in series", t_in, t_out,
                    [float(param[k]) for k in ins])
    if best is None:
        return None
    gap, arcs, form, t_inner, t_outer, pin = best
    ps = sorted(pin)
    srange = (s_of(ps[0]), s_of(ps[-1]))
    gaps = np.diff(ps)
    k = int(np.argmax(gaps))
    s_mid = 0.5 * (s_of(ps[k]) + s_of(ps[k + 1]))
    hold = int(np.argmin(np.abs(s_node - s_mid)))
    return gap, arcs, form, t_inner, t_outer, srange, hold


def half_knot_gap(x, radius: float, *, n_directions: int = 24, seed: int = 0) -> HalfKnotGap:
    """The rope length between the two half-knots of a tied single-rod reef or granny (module
    docstring).

    ``x``: (N, 3) centreline of the open rope (m); ``radius``: rope radius h (m; diameters are
    ``gap / 2h``). the rope's three principal axes and ``n_directions`` seeded random directions
    are tried, fewest crossings first; the first whose diagram splits gives the smallest gap of its
    splits."""
    from knotsim.knots.topology.closure import _close
    from knotsim.knots.topology.diagram import _random_direction

    x = np.asarray(x, float)
    if x.ndim != 2 or x.shape[1] != 3 or len(x) < 3:
        raise ValueError(f"x must be an (N, 3) array of node positions with N >= 3, got shape {x.shape}")
    if not radius > 0:
        raise ValueError(f"radius must be > 0 m, got {radius!r}")
    keep = np.ones(len(x), bool)
    keep[1:] = np.linalg.norm(np.diff(x, axis=0), axis=1) > 1e-12 * float(np.ptp(x, axis=0).max())
    rope = x[keep]
    nodes = np.flatnonzero(keep)
    comps, _ = _close([rope], None, None, "radial", 20.0)
    poly = comps[0]
    if not np.array_equal(poly[:len(rope)], rope):
        raise ValueError("closure did not keep the rope nodes first")
    edge = np.linalg.norm(np.diff(rope, axis=0), axis=1)
    s_node = np.concatenate([[0.0], np.cumsum(edge)])
    scale = float(np.max(np.linalg.norm(poly - poly.mean(axis=0), axis=1)))
    # candidate directions: the rope's three principal axes (slightly tilted, so that straight
    # tails in a coordinate plane are not seen edge on), then seeded random ones; the diagrams are
    # tried fewest crossings first, and the first that splits is used
    axes = np.linalg.svd(rope - rope.mean(axis=0), full_matrices=False)[2][::-1]
    tilt = np.array([0.0123, 0.0171, 1.0])
    axes = [a + 0.02 * np.cross(a, tilt / np.linalg.norm(tilt)) for a in axes]
    rng = np.random.default_rng(seed)
    found = []
    tried = 0
    while len(found) < n_directions + 3 and tried < 10 * n_directions:
        d = axes[tried] if tried < 3 else _random_direction(rng)
        tried += 1
        got = _passes(comps, d / np.linalg.norm(d), scale, len(rope), s_node)
        if got is not None:
            found.append((len(got[1]), tried, d / np.linalg.norm(d), got))
    best = None
    for ncr, _, d, (dia, over, under) in sorted(found, key=lambda f: (f[0], f[1])):
        split = _best_split(dia, over, under, len(rope), s_node, edge)
        if split is not None:
            best = (split, ncr, d)
            break
    if best is None:
        return HalfKnotGap(None, None, n_crossings=min((f[0] for f in found), default=0))
    (gap, arcs, form, t_inner, t_outer, srange, hold), ncr, d = best
    return HalfKnotGap(gap, gap / (2.0 * radius), arcs, form, t_inner, t_outer, srange, int(nodes[hold]), ncr,
                       tuple(float(v) for v in d))
