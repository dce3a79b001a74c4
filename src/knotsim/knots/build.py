"""Building 3D rope centrelines from a knot drawing (:func:`build_knot`) and the result record.

The construction steps are listed in :mod:`knotsim.knots.geometry`. Lengths in metres; node arrays
have shape ``(N, 3)``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from knotsim.errors import ConfigError, GeometryError
from knotsim.knots.clearance import ClosestPair, RopeEdges, closest_edge_pair, same_rope_min_gap
from knotsim.knots.crossings import PlanarCrossing
from knotsim.knots.diagram import check_diagram, crossing_lifts, match_letters
from knotsim.knots.polyline import (
    _arc,
    _fix_edge_lengths,
    _interp_at,
    _resample_polyline,
    _smooth_planar,
    _trim_or_extend,
)
from knotsim.knots.post import Post, build_on_post, plane_post
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
    post:
        The rigid post the knot is tied round (:class:`~knotsim.knots.post.Post`, in m), or ``None``.
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
    post: Post | None = None

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


def _resolve_size(spec: KnotSpec, n_nodes, edge_length, radius, length) -> tuple[float, float, int]:
    """Rod radius (m), rope length (m) and node count from the call, else the drawing's defaults."""
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
    return radius, length, n_nodes


def _build_planar(spec: KnotSpec, n_nodes: int, radius: float, length: float, margin: float, lift: float,
                  max_iter: int):
    """Steps 1-7 of a planar drawing: ``(ropes, closest pair, crossings, same-rope gap, post or None)``."""
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
    arcs = [_arc(p) for p in planar]
    passages, visits = match_letters(spec, planar, arcs, length)

    # 4. lift the crossings with compact bumps: peak +-amp exactly at each crossing
    z = crossing_lifts(spec, passages, arcs, 0.5 * lift * target, max(10.0 * d, 4.0 * seg))
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
    where = f"knot {spec.name!r} (N={n_nodes}, h={radius * 1e3:.3g} mm, L={length:g} m)"
    if cp.distance < d:
        raise GeometryError(
            f"{where} still overlaps after relaxation: {cp.describe()}. Use more nodes, a thinner rod, "
            f"or a looser drawing")
    xing = check_diagram(where, ropes, spec, visits, cp)
    post = None
    if spec.post is not None:  # a pin through a planar drawing (a loop's eye), along z
        post = plane_post(spec.post, scale, ropes, radius, where, names)

    return ropes, cp, xing, min_gap, post


def build_knot(spec: KnotSpec | Mapping[str, Any], n_nodes: int | None = None,
               edge_length: float | None = None, radius: float | None = None,
               length: float | None = None, *, post_radius: float | None = None, margin: float = 0.1,
               lift: float = 1.15, max_iter: int = 3000) -> KnotGeometry:
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
    post_radius:
        Radius (m) of the post of a knot drawn round one (``[post]``); default: the drawing's.
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
    radius, length, n_nodes = _resolve_size(spec, n_nodes, edge_length, radius, length)
    if post_radius is not None:
        if spec.post is None:
            raise ConfigError("post_radius", f"knot {spec.name!r} is not tied round a post; leave post_radius unset")
        if not (isinstance(post_radius, int | float) and post_radius > 0):
            raise ConfigError("post_radius", f"must be a positive radius in m, got {post_radius!r}")
        spec = replace(spec, post=replace(spec.post, radius=float(post_radius)))
    if spec.post is not None and spec.post.drawn_on == "surface":
        ropes, cp, xing, min_gap, post = build_on_post(spec, n_nodes, radius, length, margin=margin, lift=lift,
                                                       max_iter=max_iter)
    else:
        ropes, cp, xing, min_gap, post = _build_planar(spec, n_nodes, radius, length, margin, lift, max_iter)
    names = tuple(r.name for r in spec.ropes)

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
        post=post,
    )
