"""Knot geometry "from a drawing": planar waypoints plus over/under choices -> 3D rod centrelines.

A knot is described the way a person draws one on paper. Each rope is an ordered list of planar
waypoints ``(x, y)`` in arbitrary drawing units (only the shape matters: the drawing is scaled to
the requested rope length). Walking along each rope from its first to its last waypoint, the
person writes down, for every crossing met on the way, whether this rope passes **over** (``O``)
or **under** (``U``) the other strand there. Every crossing is met twice (once by each of its two
strands), so a single rope with ``c`` crossings has ``2c`` letters; with several ropes each rope
lists the passages it makes, including those over or under the other ropes.

Why this design: it needs no crossing labels or segment indices, which a person cannot know before
the curve is smoothed, and it is unambiguous once the smoothed curve is fixed: the crossings of the
smoothed drawing are found, ordered by arc length along each rope, and matched one to one with the
letters. The two letters of one crossing must be complementary (one ``O``, one ``U``); a drawing
whose smoothed curve has a different number of crossings than letters is rejected with a message
that gives both counts (move the waypoints apart or add the missing letters).

Spec format (TOML file, or the equivalent nested ``dict``). Example, a hand-drawn open trefoil:
the rope comes in from the left, runs through a three-crossing braid, goes round a loop above it and
through the braid again, and leaves to the right; it passes under, over, under on its first trip
through the braid and over, under, over on the second::

    name = "trefoil_open"
    description = "Open trefoil: a loop closed by a three-crossing braid."
    kind = "overhand"                  # free text: "overhand", "single_rod_bend", "bend", ...

    [defaults]                         # optional: the published set-up, used when build_knot
    radius = 0.0016                    # is called without these arguments (m, m, count)
    length = 1.0
    n_nodes = 301

    [[ropes]]
    name = "rod"
    waypoints = [                      # drawing units, any scale
        [-36, -3], [-24, -3], [-12, -3], [-8, 0], [-4, 3], [0, 0], [4, -3], [8, 0], [12, 3],
        [19, 6], [22, 16], [12, 27], [0, 30], [-12, 27], [-22, 16], [-19, 6],
        [-12, 3], [-8, 0], [-4, -3], [0, 0], [4, 3], [8, 0], [12, -3], [24, -3], [36, -3],
    ]
    crossings = "UOU OUO"              # or ["under", "over", ...]; spaces and commas are ignored

    [loading]                          # hints for the loading protocols (all optional)
    pulled = [{rope = "rod", end = "start"}, {rope = "rod", end = "end"}]
    held = [{rope = "rod", s = 0.5}]   # a node given by its arc-length fraction s in [0, 1],
                                       # or an end: {rope = "rod", end = "start" | "end"}

Any other top-level keys (``topology``, ``reference``, ...) are kept in :attr:`KnotSpec.meta`.
The crossing signs follow the right-hand rule (over direction x under direction along +z is
positive); the example above has three positive crossings (a right-handed trefoil, writhe +3).

Construction (:func:`build_knot`):

1. each rope's waypoints are interpolated by a centripetal natural cubic spline (scipy) and
   sampled densely by arc length;
2. the drawing is scaled uniformly so that its longest rope has the requested ``length``;
3. planar crossings of the smoothed curves are found and matched with the declared letters;
4. each crossing is lifted with smooth compact bumps in ``z``: the over strand up and the under
   strand down by ``lift * d * (1 + margin) / 2`` with flat tangents at the crossing, so that the
   two strands are more than the contact distance ``d = 2h`` apart there;
5. each rope is trimmed (or its straight tails extended) symmetrically to exactly ``length`` and
   resampled to ``n_nodes`` nodes equally spaced in arc length;
6. a position-based relaxation pushes apart every pair of non-adjacent edges closer than
   ``d * (1 + margin)`` (with smoothed corrections) while keeping every edge at the uniform rest
   length ``length / (n_nodes - 1)``;
7. the result is checked: the projected crossing diagram must still be the declared one and every
   pair of edges that may touch (``|i - j| >= 3`` on one rope, every pair across ropes) must be at
   least ``d`` apart (exact segment-segment distances). Otherwise :class:`knotsim.errors.
   GeometryError` names the closest pair.

All lengths of the result are in metres; node arrays have shape ``(N, 3)``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial import cKDTree

from knotsim.errors import ConfigError, GeometryError

__all__ = [
    "ClosestPair",
    "KnotGeometry",
    "KnotSpec",
    "NodeRef",
    "PlanarCrossing",
    "RopePoint",
    "RopeSpec",
    "build_knot",
    "closest_edge_pair",
    "parse_knot_spec",
    "projected_crossings",
    "same_rope_min_gap",
    "segment_distances",
]

#: Default rod radius h (m) when neither the call nor the spec gives one.
DEFAULT_RADIUS = 1.6e-3
#: Default rope length (m).
DEFAULT_LENGTH = 1.0
#: Default number of nodes per rope.
DEFAULT_N_NODES = 301
#: Minimum index distance between edges of one rope that may be in contact.
MIN_EDGE_SEPARATION = 3
#: Same-rope edge pairs whose arc-length gap ``(|i - j| - 1) * l`` is below this many contact
#: distances are never checked (a smooth rod cannot bring them into contact; with edges shorter
#: than ``d / 2`` even a straight rod would otherwise "overlap" with ``|i - j| = 3``).
MIN_ARC_GAP_FACTOR = 1.5


def same_rope_min_gap(edge_length: float, contact_distance: float) -> int:
    """Smallest index distance ``|i - j|`` of same-rope edge pairs that may be in contact.

    It is ``MIN_EDGE_SEPARATION`` (3) whenever ``2 l >= 1.5 d`` (e.g. L = 1 m, N = 301, h <= 2.2 mm),
    and grows for finer discretizations so that pairs closer than ``1.5 d`` in arc length are
    skipped.

    Parameters
    ----------
    edge_length:
        ``l`` (m).
    contact_distance:
        ``d = 2h`` (m).
    """
    need = int(math.ceil(MIN_ARC_GAP_FACTOR * contact_distance / edge_length - 1e-9)) + 1
    return max(MIN_EDGE_SEPARATION, need)


# ---------------------------------------------------------------------------------------------
# Spec data classes and parsing
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RopePoint:
    """A point on a rope named in a spec: an end, or an arc-length fraction.

    Attributes
    ----------
    rope:
        Rope name.
    end:
        ``"start"`` or ``"end"`` for an end node, else ``None``.
    s:
        Arc-length fraction in ``[0, 1]`` (0 = first node) when ``end`` is ``None``.
    """

    rope: str
    end: str | None = None
    s: float | None = None

    @property
    def fraction(self) -> float:
        """Arc-length fraction of this point along its rope (0 for the start, 1 for the end)."""
        if self.end is not None:
            return 0.0 if self.end == "start" else 1.0
        assert self.s is not None
        return float(self.s)


@dataclass(frozen=True)
class RopeSpec:
    """One rope of a drawing.

    Attributes
    ----------
    name:
        Rope name (unique in the knot).
    waypoints:
        ``(M, 2)`` planar waypoints in drawing units, in walking order.
    passes:
        Over/under letter of every crossing met while walking the rope: ``True`` = over.
    """

    name: str
    waypoints: np.ndarray
    passes: tuple[bool, ...]


@dataclass(frozen=True)
class KnotSpec:
    """A parsed knot drawing (see the module docstring for the format).

    Attributes
    ----------
    name, description, kind:
        Identification; ``kind`` is free text such as ``"overhand"`` or ``"bend"``.
    ropes:
        The ropes in order.
    pulled, held:
        Loading-protocol hints: points moved by the protocol, points held static.
    defaults:
        Published set-up values (``radius``, ``length``, ``n_nodes``, ...) used by
        :func:`build_knot` when the call does not give them.
    meta:
        Any other keys of the spec, kept verbatim (e.g. ``topology`` notes, references).
    """

    name: str
    description: str
    kind: str
    ropes: tuple[RopeSpec, ...]
    pulled: tuple[RopePoint, ...] = ()
    held: tuple[RopePoint, ...] = ()
    defaults: Mapping[str, Any] = field(default_factory=dict)
    meta: Mapping[str, Any] = field(default_factory=dict)

    @property
    def n_crossings(self) -> int:
        """Number of crossings declared (half the number of over/under letters)."""
        return sum(len(r.passes) for r in self.ropes) // 2

    def rope_index(self, name: str) -> int:
        """Index of the rope called ``name``; ``ConfigError`` if there is none."""
        for i, r in enumerate(self.ropes):
            if r.name == name:
                return i
        raise ConfigError("rope", f"no rope named {name!r} in knot {self.name!r} (ropes: "
                          f"{', '.join(r.name for r in self.ropes)})")


_LETTER = {"o": True, "over": True, "u": False, "under": False}


def _parse_passes(value: Any, field_name: str) -> tuple[bool, ...]:
    if isinstance(value, str):
        tokens = [c for c in re.sub(r"[\s,;|/_-]", "", value)]
    elif isinstance(value, Sequence):
        tokens = [str(v) for v in value]
    else:
        raise ConfigError(field_name, f"expected a string like 'OUOU' or a list of 'over'/'under', "
                                      f"got {type(value).__name__}")
    out = []
    for tok in tokens:
        key = tok.strip().lower()
        if key not in _LETTER:
            raise ConfigError(field_name, f"unknown over/under letter {tok!r} (use O/U or over/under)")
        out.append(_LETTER[key])
    return tuple(out)


def _parse_point(value: Any, field_name: str, rope_names: Sequence[str]) -> RopePoint:
    if not isinstance(value, Mapping):
        raise ConfigError(field_name, f"expected a table like {{rope = 'a', end = 'start'}}, got {value!r}")
    rope = value.get("rope", rope_names[0] if len(rope_names) == 1 else None)
    if rope not in rope_names:
        raise ConfigError(field_name, f"rope {rope!r} is not one of {list(rope_names)}")
    end = value.get("end")
    s = value.get("s")
    if (end is None) == (s is None):
        raise ConfigError(field_name, "give exactly one of end = 'start'|'end' or s = fraction")
    if end is not None:
        if end not in ("start", "end"):
            raise ConfigError(field_name, f"end must be 'start' or 'end', got {end!r}")
        return RopePoint(str(rope), end=str(end))
    s = float(s)
    if not 0.0 <= s <= 1.0:
        raise ConfigError(field_name, f"s must be an arc-length fraction in [0, 1], got {s}")
    return RopePoint(str(rope), s=s)


def parse_knot_spec(data: Mapping[str, Any] | KnotSpec, source: str = "<dict>") -> KnotSpec:
    """Validate a knot drawing given as a nested mapping (parsed TOML) and return a :class:`KnotSpec`.

    Parameters
    ----------
    data:
        Mapping with the keys of the module docstring (a :class:`KnotSpec` is returned as is).
    source:
        Where ``data`` came from, used in error messages.

    Raises
    ------
    ConfigError
        For a missing or malformed field; the message names the field.
    """
    if isinstance(data, KnotSpec):
        return data
    if not isinstance(data, Mapping):
        raise ConfigError(source, f"a knot spec must be a mapping, got {type(data).__name__}")
    name = str(data.get("name", "")).strip()
    if not name:
        raise ConfigError(f"{source}: name", "missing knot name")
    ropes_raw = data.get("ropes")
    if not isinstance(ropes_raw, Sequence) or isinstance(ropes_raw, str) or not ropes_raw:
        raise ConfigError(f"{name}: ropes", "need a non-empty list of [[ropes]] tables")
    ropes: list[RopeSpec] = []
    for k, r in enumerate(ropes_raw):
        fld = f"{name}: ropes[{k}]"
        if not isinstance(r, Mapping):
            raise ConfigError(fld, "each rope must be a table with name, waypoints, crossings")
        rname = str(r.get("name", f"rope{k}"))
        if any(rname == q.name for q in ropes):
            raise ConfigError(f"{fld}.name", f"duplicate rope name {rname!r}")
        try:
            wp = np.asarray(r.get("waypoints"), dtype=float)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"{fld}.waypoints", f"not a list of [x, y] pairs ({exc})") from None
        if wp.ndim != 2 or wp.shape[1] != 2 or wp.shape[0] < 2:
            raise ConfigError(f"{fld}.waypoints", f"need at least 2 [x, y] pairs, got shape {wp.shape}")
        if not np.all(np.isfinite(wp)):
            raise ConfigError(f"{fld}.waypoints", "contains non-finite values")
        gaps = np.linalg.norm(np.diff(wp, axis=0), axis=1)
        if np.any(gaps <= 1e-9 * max(1.0, float(np.ptp(wp)))):
            j = int(np.argmin(gaps))
            raise ConfigError(f"{fld}.waypoints", f"waypoints {j} and {j + 1} coincide ({wp[j].tolist()})")
        passes = _parse_passes(r.get("crossings", ""), f"{fld}.crossings")
        ropes.append(RopeSpec(rname, wp, passes))
    n_letters = sum(len(r.passes) for r in ropes)
    if n_letters % 2:
        raise ConfigError(f"{name}: crossings", f"{n_letters} over/under letters in total; every crossing "
                                                "is met twice, so the total must be even")
    n_over = sum(sum(r.passes) for r in ropes)
    if 2 * n_over != n_letters:
        raise ConfigError(f"{name}: crossings", f"{n_over} 'over' but {n_letters - n_over} 'under' letters; "
                                                "every crossing has one of each")
    names = [r.name for r in ropes]
    loading = data.get("loading", {}) or {}
    if not isinstance(loading, Mapping):
        raise ConfigError(f"{name}: loading", "must be a table")
    pulled = tuple(_parse_point(p, f"{name}: loading.pulled", names) for p in loading.get("pulled", []))
    held = tuple(_parse_point(p, f"{name}: loading.held", names) for p in loading.get("held", []))
    defaults = dict(data.get("defaults", {}) or {})
    for key in defaults:
        if key not in ("radius", "length", "n_nodes", "edge_length"):
            raise ConfigError(f"{name}: defaults.{key}", "unknown key (allowed: radius, length, n_nodes, edge_length)")
    known = {"name", "description", "kind", "ropes", "loading", "defaults"}
    meta = {k: v for k, v in data.items() if k not in known}
    return KnotSpec(
        name=name,
        description=str(data.get("description", "")).strip(),
        kind=str(data.get("kind", "")).strip(),
        ropes=tuple(ropes),
        pulled=pulled,
        held=held,
        defaults=defaults,
        meta=meta,
    )


# ---------------------------------------------------------------------------------------------
# Geometry kernels
# ---------------------------------------------------------------------------------------------


def segment_distances(p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray):
    """Exact minimum distances between pairs of 3D segments ``[p0, p1]`` and ``[q0, q1]``.

    Parameters
    ----------
    p0, p1, q0, q1:
        ``(K, 3)`` arrays of segment end points (any length unit). Segments must have non-zero
        length.

    Returns
    -------
    dist, s, t:
        ``(K,)`` arrays: the distance and the contact ratios ``s, t`` in ``[0, 1]`` of the closest
        points ``p0 + s (p1 - p0)`` and ``q0 + t (q1 - q0)``.
    """
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = np.einsum("ij,ij->i", d1, d1)
    e = np.einsum("ij,ij->i", d2, d2)
    b = np.einsum("ij,ij->i", d1, d2)
    c = np.einsum("ij,ij->i", d1, r)
    f = np.einsum("ij,ij->i", d2, r)
    denom = a * e - b * b
    ok = denom > 1e-12 * a * e
    s = np.where(ok, np.clip((b * f - c * e) / np.where(ok, denom, 1.0), 0.0, 1.0), 0.0)
    t = (b * s + f) / e
    lo = t < 0.0
    hi = t > 1.0
    s = np.where(lo, np.clip(-c / a, 0.0, 1.0), np.where(hi, np.clip((b - c) / a, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    diff = (p0 + s[:, None] * d1) - (q0 + t[:, None] * d2)
    return np.sqrt(np.einsum("ij,ij->i", diff, diff)), s, t


@dataclass(frozen=True)
class ClosestPair:
    """The closest pair of edges that may be in contact.

    Attributes
    ----------
    rope_a, edge_a, rope_b, edge_b:
        Rope indices and edge indices (edge ``k`` joins nodes ``k`` and ``k+1``).
    distance:
        Their minimum distance (m).
    required:
        The contact distance ``d = 2h`` they must keep (m).
    rope_names:
        Names of all ropes, for messages.
    """

    rope_a: int
    edge_a: int
    rope_b: int
    edge_b: int
    distance: float
    required: float
    rope_names: tuple[str, ...] = ()

    def describe(self) -> str:
        """Human-readable one-line description."""
        na = self.rope_names[self.rope_a] if self.rope_names else str(self.rope_a)
        nb = self.rope_names[self.rope_b] if self.rope_names else str(self.rope_b)
        return (f"rope {na!r} edge {self.edge_a} and rope {nb!r} edge {self.edge_b} are "
                f"{self.distance * 1e3:.3f} mm apart, contact distance is {self.required * 1e3:.3f} mm")


class _Edges:
    """Flattened edge list of several polylines (internal helper)."""

    def __init__(self, counts: Sequence[int]):
        self.counts = np.asarray(counts, dtype=np.int64)
        self.node_offset = np.concatenate([[0], np.cumsum(self.counts)])
        a, rid, loc = [], [], []
        for r, n in enumerate(self.counts):
            k = np.arange(n - 1)
            a.append(self.node_offset[r] + k)
            rid.append(np.full(n - 1, r))
            loc.append(k)
        self.i0 = np.concatenate(a)
        self.i1 = self.i0 + 1
        self.rope = np.concatenate(rid)
        self.local = np.concatenate(loc)

    def candidate_pairs(self, x: np.ndarray, radius: float, min_gap: int = MIN_EDGE_SEPARATION) -> np.ndarray:
        """``(K, 2)`` global edge-index pairs whose midpoints are within ``radius``, minus excluded
        pairs (same rope, fewer than ``min_gap`` edges apart)."""
        mid = 0.5 * (x[self.i0] + x[self.i1])
        pairs = cKDTree(mid).query_pairs(radius, output_type="ndarray")
        if len(pairs) == 0:
            return np.zeros((0, 2), dtype=np.int64)
        i, j = pairs[:, 0], pairs[:, 1]
        keep = (self.rope[i] != self.rope[j]) | (np.abs(self.local[i] - self.local[j]) >= min_gap)
        return pairs[keep]

    def distances(self, x: np.ndarray, pairs: np.ndarray):
        i, j = pairs[:, 0], pairs[:, 1]
        return segment_distances(x[self.i0[i]], x[self.i1[i]], x[self.i0[j]], x[self.i1[j]])


def closest_edge_pair(ropes: Sequence[np.ndarray], contact_distance: float,
                      rope_names: Sequence[str] = (), min_gap: int | None = None) -> ClosestPair:
    """Exact closest pair among all edge pairs that may be in contact.

    Pairs considered: edges of one rope at least ``min_gap`` apart in index, and every pair of
    edges of different ropes. A k-d tree on edge midpoints prunes far pairs; the search radius
    grows until the minimum is provably exact.

    Parameters
    ----------
    ropes:
        Node arrays, each ``(N_r, 3)`` (m).
    contact_distance:
        ``d = 2h`` (m), only stored in the result.
    rope_names:
        Optional names for messages.
    min_gap:
        Smallest same-rope index distance checked; default :func:`same_rope_min_gap` of the mean
        edge length (3 at the usual resolutions).
    """
    edges = _Edges([len(r) for r in ropes])
    x = np.concatenate([np.asarray(r, dtype=float) for r in ropes])
    elen = np.linalg.norm(x[edges.i1] - x[edges.i0], axis=1)
    lmax = float(elen.max())
    if min_gap is None:
        min_gap = same_rope_min_gap(float(elen.mean()), contact_distance)
    span = float(np.ptp(x, axis=0).max()) + lmax
    radius = 2.0 * contact_distance + lmax
    best = None
    while True:
        pairs = edges.candidate_pairs(x, radius, min_gap)
        if len(pairs):
            dist, _, _ = edges.distances(x, pairs)
            k = int(np.argmin(dist))
            # any pair outside the radius is at least radius - lmax apart
            if dist[k] <= radius - lmax or radius > 2 * span:
                i, j = pairs[k]
                best = ClosestPair(int(edges.rope[i]), int(edges.local[i]), int(edges.rope[j]),
                                   int(edges.local[j]), float(dist[k]), float(contact_distance),
                                   tuple(rope_names))
                break
        elif radius > 2 * span:
            break
        radius *= 2.0
    if best is None:  # a single short rope: no pair can touch
        best = ClosestPair(0, 0, 0, 0, math.inf, float(contact_distance), tuple(rope_names))
    return best


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


def _planar_intersections(x2: np.ndarray, edges: _Edges):
    """All proper intersections of the 2D polylines (edges sharing a node are skipped).

    Returns global edge indices ``i, j`` and ratios ``s, t``; half-open ranges ``[0, 1)`` make a
    crossing exactly at a node count once.
    """
    p0 = x2[edges.i0]
    p1 = x2[edges.i1]
    d = p1 - p0
    elen = np.hypot(d[:, 0], d[:, 1])
    mid = 0.5 * (p0 + p1)
    pairs = cKDTree(mid).query_pairs(float(elen.max()) * 1.0001, output_type="ndarray")
    if len(pairs) == 0:
        z = np.zeros(0, dtype=np.int64)
        return z, z, np.zeros(0), np.zeros(0)
    i, j = pairs[:, 0], pairs[:, 1]
    keep = (edges.rope[i] != edges.rope[j]) | (np.abs(edges.local[i] - edges.local[j]) >= 2)
    i, j = i[keep], j[keep]
    d1, d2 = d[i], d[j]
    w = p0[j] - p0[i]
    den = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    okd = np.abs(den) > 1e-14 * elen[i] * elen[j]
    den = np.where(okd, den, 1.0)
    s = (w[:, 0] * d2[:, 1] - w[:, 1] * d2[:, 0]) / den
    t = (w[:, 0] * d1[:, 1] - w[:, 1] * d1[:, 0]) / den
    hit = okd & (s >= 0) & (s < 1) & (t >= 0) & (t < 1)
    return i[hit], j[hit], s[hit], t[hit]


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
    edges = _Edges([len(r) for r in arrs])
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


# ---------------------------------------------------------------------------------------------
# Result
# ---------------------------------------------------------------------------------------------


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


# ---------------------------------------------------------------------------------------------
# Construction
# ---------------------------------------------------------------------------------------------


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


def _trim_or_extend(x: np.ndarray, target: float) -> np.ndarray:
    """Cut both ends (or extend them straight along the end tangents) by equal amounts so that the
    dense polyline ``x`` ``(K, 3)`` has arc length ``target``."""
    s = _arc(x)
    excess = s[-1] - target
    if excess >= 0:
        q = np.concatenate([[0.5 * excess], s[(s > 0.5 * excess) & (s < s[-1] - 0.5 * excess)],
                            [s[-1] - 0.5 * excess]])
        return _interp_at(x, s, q)
    ext = -0.5 * excess
    k = max(1, min(len(x) - 1, int(np.searchsorted(s, min(s[-1] / 4, 0.02 * target)))))
    t0 = x[0] - x[k]
    t1 = x[-1] - x[-1 - k]
    t0 /= np.linalg.norm(t0)
    t1 /= np.linalg.norm(t1)
    n = max(2, int(math.ceil(ext / (s[-1] / (len(x) - 1)))) + 1)
    a = np.linspace(1.0, 0.0, n)[:-1, None] * ext
    return np.concatenate([x[0] + a * t0, x, x[-1] + a[::-1] * t1])


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


def _smooth_field(v: np.ndarray, edges: _Edges, passes: int) -> np.ndarray:
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


def _relax(x: np.ndarray, edges: _Edges, rest: np.ndarray, target: float, accept: float,
           max_iter: int, min_gap: int, stall_iter: int = 200) -> np.ndarray:
    """Position-based relaxation: push apart close edge pairs, keep edge lengths.

    ``x`` is ``(Ntot, 3)``; ``rest`` the rest length of each global edge; pairs closer than
    ``target`` are pushed apart; stops when every pair is at least ``accept`` apart and edge
    strains are below 1e-4, or when the smallest distance has not grown for ``stall_iter``
    iterations.
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
    return x


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
    pedges = _Edges([len(p) for p in planar])
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
    edges = _Edges([n_nodes] * n_ropes)
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
