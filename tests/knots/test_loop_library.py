"""The loop library: loops drawn round a pin through the eye (``kind = "loop"``, a ``[post]`` with a
``center``) build overlap-free at the usual resolutions, the pin fits through the eye with room, and each
drawing is the intended knot, not just any knot with an eye: its closure (ends joined far away) and the
two halves of its cut eye are checked against the values recorded in the drawing's ``topology`` table,
and against the library bends the loops are made of (the bowline's tangle is the sheet bend, the alpine
butterfly loop cut at its eye is the alpine butterfly bend)."""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import pytest

from knotsim.knots import topology as T
from knotsim.knots.geometry import KnotGeometry, build_knot
from knotsim.knots.library import get_knot, knot_names, load_knot_spec
from knotsim.knots.polyline import _arc, _smooth_planar

from .brute import brute_min_clearance, count_crossings, letters_along

LOOPS = ("bowline", "dutch_bowline", "figure_eight_loop", "alpine_butterfly_loop")
RESOLUTIONS = (101, 201, 301)
#: the standing parts: rope ends, 0 = first node, 1 = last node (the other end, if any, is the tail)
STANDING = {"bowline": (0,), "dutch_bowline": (0,), "figure_eight_loop": (0,), "alpine_butterfly_loop": (0, 1)}
#: where the tail of a one-standing-part loop leaves the knot: inside or outside the eye
TAIL_INSIDE = {"bowline": True, "dutch_bowline": False}


@functools.cache
def built(name: str, n_nodes: int) -> KnotGeometry:
    return get_knot(name, n_nodes=n_nodes)


def topo(name: str) -> dict:
    return load_knot_spec(name).meta["topology"]


# --- the pin ------------------------------------------------------------------------------------------

def pin(spec, length: float) -> tuple[np.ndarray, float]:
    """Centre ``(2,)`` (m, in the built geometry's xy plane) and radius (m) of the pin of a planar drawing.

    The builder scales the drawing so the smoothed curve has the rope's length (``knotsim.knots.build``,
    steps 1-2: centripetal spline at a spacing of 1/4000 of the drawing's extent); the pin's centre is
    scaled the same way."""
    post = getattr(spec, "post", None)
    centre, radius = (post.center, post.radius) if post is not None else (spec.meta["post"]["center"],
                                                                          spec.meta["post"]["radius"])
    wp = spec.ropes[0].waypoints
    smooth = _smooth_planar(wp, float(np.ptp(wp, axis=0).max()) / 4000.0)
    return np.asarray(centre, float) * (length / _arc(smooth)[-1]), float(radius)


def winding(points: np.ndarray, centre: np.ndarray) -> float:
    """Turns of the closed polygon ``points`` (xy used; last point joined back to the first) round ``centre``."""
    d = points[:, :2] - centre
    a = np.arctan2(d[:, 1], d[:, 0])
    steps = np.diff(np.concatenate([a, a[:1]]))
    return float(np.sum((steps + math.pi) % (2.0 * math.pi) - math.pi) / (2.0 * math.pi))


def rope_winding(x: np.ndarray, centre: np.ndarray) -> float:
    """Turns of the rope round the pin, the rope closed far away: its two ends (far from the pin) joined
    the short way round as seen from the pin, as the far closure of :mod:`knotsim.knots.topology` does
    (the closing chord of the polygon subtends that same angle)."""
    return winding(x, centre)


def passages(geo: KnotGeometry) -> list[tuple[float, float]]:
    """Every crossing met along the (single) rope: ``(position, partner position)`` in edge units,
    sorted by position; each crossing appears twice."""
    out = []
    for c in geo.crossings:
        a, b = c.over_edge + c.over_t, c.under_edge + c.under_t
        out += [(a, b), (b, a)]
    return sorted(out)


def point_at(x: np.ndarray, pos: float) -> np.ndarray:
    k = min(int(pos), len(x) - 2)
    return x[k] + (pos - k) * (x[k + 1] - x[k])


def stretch(x: np.ndarray, p: float, q: float) -> np.ndarray:
    """The rope from edge position ``p`` to ``q`` (``p < q``) as a polyline."""
    inner = x[int(math.floor(p)) + 1:int(math.ceil(q))]
    return np.concatenate([point_at(x, p)[None], inner, point_at(x, q)[None]])


def eye(geo: KnotGeometry, centre: np.ndarray) -> tuple[float, float, float, float]:
    """The eye: ``(p, q, m0, m1)`` in edge units along the rope.

    ``p..q``: the crossing-free stretch of rope that goes farthest round the pin. ``m0 = p``: the knot's
    last crossing before the eye; ``m1``: the first crossing after it whose other strand lies before the
    eye (so a tail crossing an eye leg, as the bowline's, is not the knot's mouth)."""
    x = geo.ropes[0]
    pas = passages(geo)
    bounds = [0.0] + [s for s, _ in pas] + [len(x) - 1.0]
    best = None
    for p, q in zip(bounds[:-1], bounds[1:], strict=True):
        if q - p < 2:
            continue
        d = x[int(math.ceil(p)):int(math.floor(q)) + 1, :2] - centre
        a = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
        if best is None or abs(a[-1] - a[0]) > abs(best[2]):
            best = (p, q, a[-1] - a[0])
    p, q, _ = best
    m1 = next((s for s, partner in pas if s >= q and partner < p), None)
    assert m1 is not None, "no crossing after the eye leads back into the knot: no eye round the pin"
    return p, q, p, m1


def eye_polygon(geo: KnotGeometry, centre: np.ndarray) -> np.ndarray:
    """The eye closed across the knot's mouth: the rope from the knot's last crossing before the eye to
    its first crossing after it (a closed polygon, the chord across the knot implied)."""
    _, _, m0, m1 = eye(geo, centre)
    return stretch(geo.ropes[0], m0, m1)


def cut_eye(geo: KnotGeometry, centre: np.ndarray, gap: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The rope cut at the far side of its eye (the eye's node farthest from the knot's mouth), a node
    removed there: ``(first node .. cut, cut .. last node)``."""
    x = geo.ropes[0]
    p, q, _, _ = eye(geo, centre)
    i0, i1 = int(math.ceil(p)), int(math.floor(q))
    mouth = 0.5 * (x[i0, :2] + x[i1, :2])
    k = i0 + int(np.argmax(np.linalg.norm(x[i0:i1 + 1, :2] - mouth, axis=1)))
    return x[:k - gap + 1], x[k + gap:]


# --- closures for the cut eye: joins straight up over everything, or down under everything -----------

def _join(p: np.ndarray, q: np.ndarray, height: float) -> np.ndarray:
    """From ``p`` straight up (``height`` > 0) or down to ``height``, across, and down (up) to ``q``: the
    two points of the path between ``p`` and ``q`` (seen along z it passes over, or under, everything)."""
    return np.array([[p[0], p[1], height], [q[0], q[1], height]])


def _height(*parts: np.ndarray) -> float:
    x = np.concatenate(parts)
    return 2.0 * float(np.ptp(x[:, :2], axis=0).max()) + float(np.abs(x[:, 2]).max())


def halves_closed(a: np.ndarray, b: np.ndarray) -> list[np.ndarray]:
    """Each half of the cut eye closed on itself: ``a`` joined over everything, ``b`` under everything."""
    h = _height(a, b)
    return [np.concatenate([a, _join(a[-1], a[0], h)]), np.concatenate([b, _join(b[-1], b[0], -h)])]


def bend_closed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A one-standing-part loop's cut eye closed as a bend: ``a`` = standing end .. first leg's cut end,
    ``b`` = second leg's cut end .. tail. The two loaded ends (the standing end and the second leg, which
    continues the standing part's pull round the pin) are joined under everything, the two others (the
    tail and the first leg) over everything: a tail led out over the eye's leg, as the bowline's, slides
    back over it, and the closure is the planar one of the bend (the sheet bend's loaded-bend closure)."""
    h = _height(a, b)
    return np.concatenate([a, _join(a[-1], b[-1], h), b[::-1], _join(b[0], a[0], -h)])


# --- the tests ----------------------------------------------------------------------------------------

def test_loops_listed():
    names = knot_names()
    assert set(LOOPS) <= set(names)
    assert {n for n in names if load_knot_spec(n).kind == "loop"} == set(LOOPS)
    for name in LOOPS:
        spec = load_knot_spec(name)
        assert spec.kind == "loop" and spec.description and "\n" not in spec.description
        assert dict(spec.defaults) == {"radius": 0.002, "length": 1.0, "n_nodes": 301}
        assert [r.name for r in spec.ropes] == ["rope"]
        assert spec.n_crossings == topo(name)["crossings"]
        assert pin(spec, 1.0)[1] == 0.004
        assert "Ashley Book of Knots #" in spec.meta["reference"]
        ends = sorted(p.fraction for p in spec.pulled)
        assert ends == sorted(float(e) for e in STANDING[name]) and not spec.held


@pytest.mark.parametrize("n_nodes", RESOLUTIONS)
@pytest.mark.parametrize("name", LOOPS)
def test_builds_overlap_free_with_the_declared_diagram(name, n_nodes):
    geo = built(name, n_nodes)
    spec = geo.spec
    (x,) = geo.ropes
    assert x.shape == (n_nodes, 3)
    dist, _ = brute_min_clearance(geo.ropes, min_gap=3)
    assert dist >= geo.contact_distance
    np.testing.assert_allclose(np.linalg.norm(np.diff(x, axis=0), axis=1).sum(), 1.0, rtol=1e-10)
    xs = count_crossings(geo.ropes)
    assert len(xs) == geo.n_crossings == topo(name)["crossings"]
    assert sum(c["sign"] for c in xs) == geo.writhe == topo(name)["writhe"]
    assert letters_along(1, xs) == ["".join("O" if p else "U" for p in spec.ropes[0].passes)]
    assert min(c["gap"] for c in xs) >= geo.contact_distance


@pytest.mark.parametrize("n_nodes", RESOLUTIONS)
@pytest.mark.parametrize("name", LOOPS)
def test_pin_fits_in_the_eye(name, n_nodes):
    geo = built(name, n_nodes)
    (x,) = geo.ropes
    centre, radius = pin(geo.spec, geo.length)
    if getattr(geo, "post", None) is not None:  # the builder's own pin, where it places one
        np.testing.assert_allclose(geo.post.center[:2], centre, atol=1e-12)
    # every node clear of the pin: pin radius + 1.1 rope radii from its axis
    assert np.linalg.norm(x[:, :2] - centre, axis=1).min() >= radius + 1.1 * geo.radius
    # the eye, closed across the knot's mouth, goes once round the pin, and so does the whole rope closed
    # far away: the pin is threaded through the eye and nowhere else
    assert abs(winding(eye_polygon(geo, centre), centre)) == pytest.approx(1.0, abs=1e-9)
    assert abs(rope_winding(x, centre)) == pytest.approx(1.0, abs=1e-9)
    # the eye is 4-6 cm across (its part beyond the pin, seen from the knot, measured square to the line
    # from the knot to the pin), and the pin 1.5 cm or more from it
    loop = eye_polygon(geo, centre)[:, :2]
    knot = np.array([c.point for c in geo.crossings]).mean(axis=0)
    axis = (knot - centre) / np.linalg.norm(knot - centre)
    beyond = loop[(loop - centre) @ axis <= 0.0]
    assert 0.04 <= float(np.ptp(beyond @ np.array([-axis[1], axis[0]]))) <= 0.06
    assert np.linalg.norm(loop - centre, axis=1).min() >= 0.015


@pytest.mark.parametrize("n_nodes", RESOLUTIONS)
@pytest.mark.parametrize("name", LOOPS)
def test_closure_signature(name, n_nodes):
    """The rope closed far away (its two ends joined): the Alexander and Jones polynomials recorded."""
    res = T.analyze(list(built(name, n_nodes).ropes))
    t = topo(name)
    assert res.n_components == 1
    assert res.alexander == t["alexander"]
    assert res.jones == {e: c for e, c in t["jones"]}
    assert res.rolfsen in (t["closes_to"], None)  # None: a knot beyond the table (the bowline's 8_20)


@pytest.mark.parametrize("name", LOOPS)
def test_halves_of_the_cut_eye(name):
    """Cut at the eye, each half closed on itself: the knot tied in it (nothing for the bowlines, an
    overhand knot of each hand for the alpine butterfly, a figure-eight knot each for the figure-eight
    loop), and how the two halves link."""
    for n_nodes in (101, 301):
        geo = built(name, n_nodes)
        centre, _ = pin(geo.spec, geo.length)
        res = T.analyze(halves_closed(*cut_eye(geo, centre)), closed=[True, True])
        assert res.component_types == topo(name)["halves"]
        assert abs(int(res.linking[0, 1])) == topo(name)["halves_linking"]


def _sheet_bend_closure():
    g = get_knot("sheet_bend", n_nodes=151)
    h, p = g.held[0], g.pulled[0]
    return T.analyze_bend(g.ropes, ((h.rope, int(h.node > 0)), (p.rope, int(p.node > 0))))


def test_bowline_cut_at_the_eye_is_the_sheet_bend():
    """The bowline's tangle is the sheet bend (ABOK #1010, #1431): cut at the eye and closed as a bend
    (standing end with the eye's second leg, tail with the first) it is the sheet bend's loaded-bend
    closure, 6_2, with the very Jones polynomial of the library's sheet_bend drawing (same mirror image)."""
    assert topo("bowline")["eye_cut"] == "sheet_bend"
    sheet = _sheet_bend_closure()
    assert sheet.rolfsen == "6_2"
    for n_nodes in (101, 301):
        geo = built("bowline", n_nodes)
        centre, _ = pin(geo.spec, geo.length)
        res = T.analyze([bend_closed(*cut_eye(geo, centre))], closed=[True])
        assert res.rolfsen == "6_2" and res.alexander == sheet.alexander and res.jones == sheet.jones


def test_dutch_bowline_closes_as_the_sheet_bend():
    """The Dutch (left-hand) bowline is the left-hand sheet bend with an eye: its eye joins the end of the
    sheet bend's rope b to the bight's other leg, so the rope closed end to tail is exactly the sheet
    bend's loaded-bend closure (6_2, the sheet_bend drawing's Jones polynomial)."""
    assert topo("dutch_bowline")["closure"] == "sheet_bend"
    sheet = _sheet_bend_closure()
    res = T.analyze(list(built("dutch_bowline", 201).ropes))
    assert res.rolfsen == "6_2" and res.alexander == sheet.alexander and res.jones == sheet.jones


def test_alpine_butterfly_loop_cut_at_the_eye_is_the_bend():
    """Cut at the eye, the alpine butterfly loop is the library's alpine butterfly bend: the same knot
    in each half as the bend's two ropes (trefoils of opposite hands), linked once, and the same
    loaded-bend closure (the unknot: the loop's two standing ends joined, its eye the joined tails)."""
    assert topo("alpine_butterfly_loop")["eye_cut"] == "alpine_butterfly_bend"
    bend = get_knot("alpine_butterfly_bend", n_nodes=151)
    ropes = T.analyze(list(bend.ropes))
    closure = T.analyze_bend(bend.ropes, ((0, 0), (1, 0)))
    geo = built("alpine_butterfly_loop", 301)
    centre, _ = pin(geo.spec, geo.length)
    halves = T.analyze(halves_closed(*cut_eye(geo, centre)), closed=[True, True])
    assert sorted(halves.component_types) == sorted(ropes.component_types) == ["trefoil_left", "trefoil_right"]
    assert abs(int(halves.linking[0, 1])) == abs(int(ropes.linking[0, 1])) == 1
    loop = T.analyze(list(geo.ropes))
    assert loop.knot_type == closure.knot_type == "unknot"


def test_bowline_and_dutch_bowline_differ():
    """Told apart by an invariant (the closure, end to tail: 8_20 against 6_2) and by the side of the eye
    the tail is on (tested in test_tail_side)."""
    b, d = (T.analyze(list(built(n, 201).ropes)) for n in ("bowline", "dutch_bowline"))
    assert b.alexander != d.alexander and b.jones != d.jones
    assert topo("bowline")["closes_to"] == "8_20" and topo("dutch_bowline")["closes_to"] == "6_2"


def tail_inside_eye(geo: KnotGeometry, centre: np.ndarray) -> bool:
    """Whether the tail (the rope after the eye, to its last node) comes out of the knot inside the eye:
    the tail's point halfway between its last crossing with the rope before the eye (where it leaves the
    knot) and its next crossing (or its end) lies inside the eye closed across the knot's mouth."""
    x = geo.ropes[0]
    _, _, m0, m1 = eye(geo, centre)
    tail = [(s, partner) for s, partner in passages(geo) if s > m1]
    leave = max(s for s, partner in tail if partner < m0)
    after = [s for s, _ in tail if s > leave]
    end = after[0] if after else len(x) - 1.0
    probe = point_at(x, 0.5 * (leave + end))[:2]
    return abs(winding(eye_polygon(geo, centre), probe)) > 0.5


@pytest.mark.parametrize("name", sorted(TAIL_INSIDE))
def test_tail_side(name):
    """Bowline: the tail ends inside the eye (and crosses its second leg to leave the drawing); Dutch
    bowline: outside it, beside the eye's leg."""
    for n_nodes in RESOLUTIONS:
        geo = built(name, n_nodes)
        assert tail_inside_eye(geo, pin(geo.spec, geo.length)[0]) == TAIL_INSIDE[name]


@pytest.mark.parametrize("n_nodes", RESOLUTIONS)
@pytest.mark.parametrize("name", LOOPS)
def test_standing_ends_leave_the_knot_away_from_the_pin(name, n_nodes):
    geo = built(name, n_nodes)
    (x,) = geo.ropes
    centre, _ = pin(geo.spec, geo.length)
    pts = np.array([c.point for c in geo.crossings])
    middle = pts.mean(axis=0)
    size = float(np.linalg.norm(pts - middle, axis=1).max())
    away = (middle - centre) / np.linalg.norm(middle - centre)  # from the pin across the knot
    ends = {0: 0, 1: len(x) - 1}
    assert sorted(p.node for p in geo.pulled) == sorted(ends[e] for e in STANDING[name])
    dirs = []
    for ref in geo.pulled:
        p = x[ref.node, :2]
        d = geo.end_direction(ref)[:2]
        dirs.append(d)
        # outside the knot: 10 cm and two knot radii from every crossing, and farther from the pin than
        # any crossing
        assert np.linalg.norm(pts - p, axis=1).min() >= max(0.10, 2.0 * size)
        assert np.linalg.norm(p - centre) > np.linalg.norm(pts - centre, axis=1).max()
        # pointing away from the pin
        assert d @ (p - centre) / np.linalg.norm(p - centre) > 0.5
    if len(dirs) == 1:  # the standing part pulls away from the pin across the knot
        assert dirs[0] @ away > 0.8
    else:  # a mid-line loop: the two standing parts pull in opposite directions, across the pin's pull
        assert dirs[0] @ dirs[1] < -0.95 and abs(dirs[0] @ away) < 0.3


# --- the checks above catch a wrong drawing ------------------------------------------------------------

def test_checks_catch_wrong_drawings():
    """The same drawings made wrong fail the checks: a pin beside the knot instead of in the eye (no
    winding), the bowline's tail led under the eye's leg (another closure), the alpine butterfly loop in
    the mirror (the halves' hands swapped), a bowline where a Dutch bowline is wanted (the tail's side)."""
    spec = load_knot_spec("bowline")
    # the pin moved out of the eye, to the left of the standing part: clear of the rope, not through the eye
    wrong = dataclasses.replace(spec, post=dataclasses.replace(spec.post, center=(-8.0, 6.0)))
    geo = build_knot(wrong, n_nodes=201)
    centre, radius = pin(wrong, geo.length)
    assert np.linalg.norm(geo.ropes[0][:, :2] - centre, axis=1).min() >= radius + 1.1 * geo.radius
    assert abs(rope_winding(geo.ropes[0], centre)) == pytest.approx(0.0, abs=1e-9)
    # the tail under the eye's second leg (the crossing met 9th and last along the rope): closes to 6_3, not
    # the recorded 8_20
    letters = list(spec.ropes[0].passes)
    assert (letters[8], letters[-1]) == (False, True)
    letters[8], letters[-1] = True, False
    rope = dataclasses.replace(spec.ropes[0], passes=tuple(letters))
    res = T.analyze(list(build_knot(dataclasses.replace(spec, ropes=(rope,)), n_nodes=201).ropes))
    assert res.rolfsen == "6_3" and res.alexander != topo("bowline")["alexander"]
    # the alpine butterfly loop drawn in the mirror (every letter swapped): each half's overhand knot
    # changes hands, which the recorded halves catch (the closure, the unknot, does not)
    spec = load_knot_spec("alpine_butterfly_loop")
    rope = dataclasses.replace(spec.ropes[0], passes=tuple(not p for p in spec.ropes[0].passes))
    geo = build_knot(dataclasses.replace(spec, ropes=(rope,)), n_nodes=201)
    halves = T.analyze(halves_closed(*cut_eye(geo, pin(spec, geo.length)[0])), closed=[True, True])
    assert halves.component_types == topo("alpine_butterfly_loop")["halves"][::-1]
    # the bowline's tail is inside its eye: drawn as a Dutch bowline, it would not pass test_tail_side
    geo = built("bowline", 201)
    assert tail_inside_eye(geo, pin(geo.spec, geo.length)[0]) != TAIL_INSIDE["dutch_bowline"]
