"""Building 3D rope centrelines from a knot drawing (:func:`build_knot`) and the result record.

The construction steps are listed in :mod:`knotsim.knots.geometry`. Lengths in metres; node arrays
have shape ``(N, 3)``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from knotsim.errors import ConfigError, GeometryError
from knotsim.knots.clearance import ClosestPair, RopeEdges, closest_edge_pair, same_rope_min_gap
from knotsim.knots.crossings import (
    PlanarCrossing,
    _gauss_signature,
    _letters,
    _planar_intersections,
    projected_crossings,
)
from knotsim.knots.polyline import (
    _arc,
    _bump,
    _fix_edge_lengths,
    _interp_at,
    _resample_polyline,
    _smooth_planar,
    _trim_or_extend,
)
from knotsim.knots.relax import _relax
from knotsim.knots.spec import (
    DEFAULT_LENGTH,
    DEFAULT_N_NODES,
    DEFAULT_RADIUS,
    KnotSpec,
    RopePoint,
    parse_knot_spec,
)


@dataclass(frozen=True)
class NodeRef:
    """A node of the built geometry: rope index and node index."""

    rope: int
    node: int


@dataclass(frozen=True)
class KnotGeometry:
    """Centrelines of a knot ready for simulation.

    Attributes
    ----------
    name, kind:
        From the spec.
    ropes:
        One ``(N, 3)`` float array of node positions per rope (m).
    rope_names:
        Rope names, same order.
    radius:
        Rod radius ``h`` (m); the contact distance is ``2h``.
    length:
        Arc length of every rope (m); edges all have length ``length / (N - 1)``.
    min_clearance:
        Smallest distance between edges that may touch (m), ``>= 2h``.
    closest_pair:
        Where ``min_clearance`` is attained.
    same_rope_min_gap:
        Smallest ``|i - j|`` of same-rope edge pairs that were checked (3 at the usual resolutions,
        see :func:`same_rope_min_gap`).
    crossings:
        Crossings of the ``xy`` projection of the result.
    end_nodes:
        For each rope name, ``(first node, last node)`` indices.
    pulled, held:
        Loading hints of the spec resolved to node references.
    spec:
        The spec the geometry was built from.
    """

    name: str
    kind: str
    ropes: tuple[np.ndarray, ...]
    rope_names: tuple[str, ...]
    radius: float
    length: float
    min_clearance: float
    closest_pair: ClosestPair
    same_rope_min_gap: int
    crossings: tuple[PlanarCrossing, ...]
    end_nodes: Mapping[str, tuple[int, int]]
    pulled: tuple[NodeRef, ...]
    held: tuple[NodeRef, ...]
    spec: KnotSpec

    @property
    def contact_distance(self) -> float:
        """``2h`` (m)."""
        return 2.0 * self.radius

    @property
    def n_crossings(self) -> int:
        """Number of crossings of the ``xy`` projection."""
        return len(self.crossings)

    @property
    def writhe(self) -> int:
        """Sum of the crossing signs of the ``xy`` projection."""
        return int(sum(c.sign for c in self.crossings))

    @property
    def edge_length(self) -> float:
        """Uniform edge length (m)."""
        return self.length / (len(self.ropes[0]) - 1)

    def end_to_end(self, rope: int | str = 0) -> float:
        """Distance between the first and last node of a rope (m)."""
        r = self.ropes[self.rope_names.index(rope) if isinstance(rope, str) else rope]
        return float(np.linalg.norm(r[-1] - r[0]))

    def end_direction(self, ref: NodeRef) -> np.ndarray:
        """Outward unit tangent ``(3,)`` at an end node (the direction to pull it away)."""
        r = self.ropes[ref.rope]
        if ref.node == 0:
            v = r[0] - r[1]
        elif ref.node == len(r) - 1:
            v = r[-1] - r[-2]
        else:
            raise ValueError(f"node {ref.node} of rope {ref.rope} is not an end node")
        return v / np.linalg.norm(v)


def build_knot(spec: KnotSpec | Mapping[str, Any], n_nodes: int | None = None,
               edge_length: float | None = None, radius: float | None = None,
               length: float | None = None, *, margin: float = 0.1, lift: float = 1.15,
               max_iter: int = 3000) -> KnotGeometry:
    """Build 3D centrelines from a knot drawing.

    Parameters
    ----------
    spec:
        A :class:`KnotSpec` or a mapping in the format of the module docstring.
    n_nodes:
        Nodes per rope. Give this or ``edge_length`` (not both); default: the spec's
        ``defaults.n_nodes`` or 301.
    edge_length:
        Target edge length (m); the node count is ``round(length / edge_length) + 1``.
    radius:
        Rod radius ``h`` (m); contact distance ``d = 2h``. Default: spec's or 1.6 mm.
    length:
        Arc length of every rope (m). The drawing is scaled so its longest rope has this length;
        shorter ropes get their tails extended straight. Default: spec's or 1 m.
    margin:
        Relative clearance margin the relaxation aims for: pairs are pushed to ``d (1 + margin)``.
    lift:
        Crossing lift: the over/under strands are moved to ``+-lift * d (1 + margin) / 2``.
    max_iter:
        Relaxation iteration limit.

    Returns
    -------
    KnotGeometry

    Raises
    ------
    ConfigError
        Bad arguments, or a drawing whose crossings do not match its over/under letters.
    GeometryError
        When no overlap-free geometry with the declared crossing diagram was reached; the message
        names the closest pair of edges.
    """
    spec = parse_knot_spec(spec)
    dflt = spec.defaults
    radius = float(radius if radius is not None else dflt.get("radius", DEFAULT_RADIUS))
    length = float(length if length is not None else dflt.get("length", DEFAULT_LENGTH))
    if not radius > 0:
        raise ConfigError("radius", f"must be > 0, got {radius}")
    if not length > 0:
        raise ConfigError("length", f"must be > 0, got {length}")
    if n_nodes is not None and edge_length is not None:
        raise ConfigError("n_nodes", "give n_nodes or edge_length, not both")
    if n_nodes is None:
        if edge_length is None and "edge_length" in dflt and "n_nodes" not in dflt:
            edge_length = float(dflt["edge_length"])
        if edge_length is not None:
            if not edge_length > 0:
                raise ConfigError("edge_length", f"must be > 0, got {edge_length}")
            n_nodes = int(round(length / edge_length)) + 1
        else:
            n_nodes = int(dflt.get("n_nodes", DEFAULT_N_NODES))
    if int(n_nodes) != n_nodes or n_nodes < 4:
        raise ConfigError("n_nodes", f"need an integer >= 4, got {n_nodes}")
    n_nodes = int(n_nodes)
    d = 2.0 * radius
    target = d * (1.0 + margin)
    seg = length / (n_nodes - 1)
    n_ropes = len(spec.ropes)
    names = tuple(r.name for r in spec.ropes)

    # 1-2. smooth, scale to metres
    dense_ds = min(seg / 4.0, length / 2000.0, d / 2.0)
    raw = []
    for r in spec.ropes:
        extent = float(np.ptp(r.waypoints, axis=0).max())
        raw.append(_smooth_planar(r.waypoints, extent / 4000.0))
    scale = length / max(_arc(p)[-1] for p in raw)
    planar = [_resample_polyline(p * scale, dense_ds) for p in raw]

    # 3. crossings of the smoothed drawing, matched with the letters
    pedges = RopeEdges([len(p) for p in planar])
    px = np.concatenate(planar)
    ci, cj, cs, ct = _planar_intersections(px, pedges)
    arcs = [_arc(p) for p in planar]

    def arcpos(e: int, u: float) -> tuple[int, float]:
        r = int(pedges.rope[e])
        k = int(pedges.local[e])
        return r, float(arcs[r][k] + u * (arcs[r][k + 1] - arcs[r][k]))

    # passages[r]: (arc position, crossing id) of every crossing met along rope r
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
    # visits[c]: the two (rope, arc position, is_over) passages of crossing c
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

    # 4. lift the crossings with compact bumps: peak +-amp exactly at each crossing (a bump vanishes,
    # with zero slope, at the neighbouring crossings of the same rope)
    amp = 0.5 * lift * target
    wmax = max(10.0 * d, 4.0 * seg)
    z = [np.zeros(len(p)) for p in planar]
    for r in range(n_ropes):
        pos = np.array([sv for sv, _ in passages[r]])
        for (sv, _), is_over in zip(passages[r], spec.ropes[r].passes, strict=True):
            others = np.abs(pos - sv)
            others = others[others > 0]
            w = min(wmax, float(others.min())) if len(others) else wmax
            z[r] += (amp if is_over else -amp) * _bump((arcs[r] - sv) / w)
    curves = [np.column_stack([p, zz]) for p, zz in zip(planar, z, strict=True)]

    # 5. exact length, resample
    nodes = []
    for cvec in curves:
        full = _trim_or_extend(cvec, length)
        s = _arc(full)
        nodes.append(_interp_at(full, s, np.linspace(0.0, s[-1], n_nodes)))

    # 6. relax
    edges = RopeEdges([n_nodes] * n_ropes)
    x = np.concatenate(nodes)
    rest = np.full(len(edges.i0), seg)
    min_gap = same_rope_min_gap(seg, d)
    x = _relax(x, edges, rest, target, d * (1.0 + 0.5 * margin), max_iter, min_gap)
    ropes = tuple(_fix_edge_lengths(x[edges.node_offset[r]:edges.node_offset[r + 1]], seg)
                  for r in range(n_ropes))

    # 7. checks
    cp = closest_edge_pair(ropes, d, names, min_gap)
    where = (f"knot {spec.name!r} (N={n_nodes}, h={radius * 1e3:.3g} mm, L={length:g} m)")
    if cp.distance < d:
        raise GeometryError(
            f"{where} still overlaps after relaxation: {cp.describe()}. Use more nodes, a thinner rod, "
            f"or a looser drawing")
    xing = projected_crossings(ropes)
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

    def resolve(p: RopePoint) -> NodeRef:
        r = spec.rope_index(p.rope)
        return NodeRef(r, int(round(p.fraction * (n_nodes - 1))))

    return KnotGeometry(
        name=spec.name,
        kind=spec.kind,
        ropes=ropes,
        rope_names=names,
        radius=radius,
        length=length,
        min_clearance=cp.distance,
        closest_pair=cp,
        same_rope_min_gap=min_gap,
        crossings=tuple(xing),
        end_nodes={n: (0, n_nodes - 1) for n in names},
        pulled=tuple(resolve(p) for p in spec.pulled),
        held=tuple(resolve(p) for p in spec.held),
        spec=spec,
    )
