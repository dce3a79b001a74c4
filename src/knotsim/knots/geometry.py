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

from knotsim.geometry.segments import segment_distances
from knotsim.knots.build import KnotGeometry, NodeRef, build_knot
from knotsim.knots.clearance import ClosestPair, closest_edge_pair, same_rope_min_gap
from knotsim.knots.crossings import PlanarCrossing, projected_crossings
from knotsim.knots.spec import KnotSpec, RopePoint, RopeSpec, parse_knot_spec

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
