"""Knots drawn round a post: the ``[post]`` table, surface drawings, pins through planar drawings."""

from __future__ import annotations

import math

import numpy as np
import pytest

from knotsim.errors import ConfigError, GeometryError
from knotsim.knots.geometry import build_knot
from knotsim.knots.polyline import _arc, _trim_or_extend
from knotsim.knots.post import Post, surface_projection
from knotsim.knots.spec import parse_knot_spec
from knotsim.protocols.rope_measures import self_tail_lengths

H = 0.002  # m, rope radius
D = 2 * H


def wrap(turns_end: float = 2.0, rise: float = 3.0, letters: str = "", extra=None, post=None) -> dict:
    """A rope wound round a post from turn 0 to ``turns_end``, rising ``rise`` diameters per turn."""
    t = np.linspace(0.0, turns_end, int(12 * turns_end) + 1)
    wp = np.column_stack([t, rise * t]).tolist()
    spec = {"name": "wrap", "kind": "hitch", "post": {"radius": 0.01, **(post or {})},
            "defaults": {"radius": H, "length": 0.5, "n_nodes": 201},
            "ropes": [{"name": "rope", "waypoints": wp, "crossings": letters}],
            "loading": {"pulled": [{"rope": "rope", "end": "start"}]}}
    spec.update(extra or {})
    return spec


def test_post_table_errors_name_the_field():
    base = wrap()
    for post, field in (({"radius": -1.0}, "post.radius"), ({"radius": 0.01, "drawn_on": "cone"}, "post.drawn_on"),
                        ({"radius": 0.01, "colour": "red"}, "post.colour"),
                        ({"radius": 0.01, "drawn_on": "surface", "center": [0, 0]}, "post.center"),
                        ({"radius": 0.01, "split": 1.5}, "post.split"), ({}, "post.radius")):
        with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
            parse_knot_spec({**base, "post": post})
    with pytest.raises(ConfigError, match=r"post\.center"):  # a planar drawing's pin needs its centre
        parse_knot_spec({**base, "post": {"radius": 0.01, "drawn_on": "plane"}})


def test_helix_on_a_post_lies_on_it_and_leaves_straight():
    g = build_knot(wrap())
    x = g.ropes[0]
    r = np.hypot(x[:, 0], x[:, 1])
    assert r.min() >= 0.01 + H  # outside the post's contact distance
    assert g.post is not None and g.post.radius == 0.01
    np.testing.assert_allclose(g.post.axis, [0, 0, 1])
    # the wound part sits at R + h (1 + margin): a 2-turn helix of 3 d per turn
    on = r < 0.01 + 1.5 * H
    assert 0.8 * 2 * (2 * math.pi * 0.0122) < on.sum() * g.edge_length < 1.2 * 2 * (2 * math.pi * 0.0122 + 0.01)
    # the ends leave perpendicular to the axis
    for ref in (g.pulled[0],):
        assert abs(g.end_direction(ref)[2]) < 1e-9
    assert abs(x[-1, 2] - x[-5, 2]) < 1e-9
    # every edge has the same length
    e = np.linalg.norm(np.diff(x, axis=0), axis=1)
    np.testing.assert_allclose(e, g.edge_length, rtol=1e-9)


def test_split_shares_the_rope_off_the_post():
    a = build_knot(wrap(post={"split": 0.8})).ropes[0]
    b = build_knot(wrap(post={"split": 0.2})).ropes[0]
    for x, first_longer in ((a, True), (b, False)):
        r = np.hypot(x[:, 0], x[:, 1])
        off = r > 0.01 + 1.5 * H
        first = np.argmax(~off)  # nodes before the first on the post
        last = len(x) - 1 - np.argmax(~off[::-1])
        assert (first > len(x) - 1 - last) == first_longer


def test_crossings_a_whole_turn_apart_are_found_on_the_surface():
    # one turn rising 1.5 d, then steeply back down across the turn's start, a whole turn later
    t = np.concatenate([np.linspace(0, 1.0, 11), np.linspace(1.1, 1.5, 5), [1.6]])
    a = np.concatenate([1.5 * np.linspace(0, 1.0, 11), 1.5 - 9.0 * np.linspace(0.1, 0.5, 5), [-3.0]])
    spec = wrap(extra={"ropes": [{"name": "rope", "waypoints": np.column_stack([t, a]).tolist(), "crossings": "UO"}]})
    g = build_knot(spec)
    assert g.n_crossings == 1  # found through the annulus map, though the two strands are a turn apart
    c = g.crossings[0]
    assert c.gap > D  # the outer strand lifted clear of the inner one
    wrong = {**spec, "ropes": [{**spec["ropes"][0], "crossings": ""}]}
    with pytest.raises(ConfigError, match=r"passes through 2 crossings .* but 0 over/under letters"):
        build_knot(wrong)


def test_drawing_longer_than_the_rope_is_refused():
    with pytest.raises(ConfigError, match=r"round the post is .* m long, more than the rope's length 0\.1 m"):
        build_knot(wrap(), length=0.1, n_nodes=101)


def test_surface_projection_is_one_to_one_round_the_post():
    # two points at the same angle but different heights along the axis map apart; a whole turn maps back
    theta = np.array([0.3, 0.3 + 2 * math.pi])
    x = np.column_stack([0.02 * np.cos(theta), 0.02 * np.sin(theta), [0.0, 0.004]])
    p = surface_projection([x], 0.0122, -0.01)[0]
    assert np.linalg.norm(p[0, :2] - p[1, :2]) > 0.1
    np.testing.assert_allclose(np.arctan2(p[:, 1], p[:, 0]), [0.3, 0.3])
    np.testing.assert_allclose(p[:, 2], 0.02)


def planar_loop(center) -> dict:
    """An open loop (one crossing) with a pin at ``center`` (drawing units)."""
    t = np.linspace(0.0, 2 * math.pi, 25)[:-1]
    loop = np.column_stack([10 * np.sin(t), 10 - 10 * np.cos(t)])
    wp = np.vstack([[[-40.0, 3.0], [-20.0, 1.5]], loop[3:-2] * [1, 1] + [0, 0], [[20.0, 1.5], [40.0, 3.0]]])
    return {"name": "eye", "kind": "loop", "post": {"radius": 0.004, "center": center},
            "defaults": {"radius": H, "length": 1.0, "n_nodes": 201},
            "ropes": [{"name": "rope", "waypoints": wp.tolist(), "crossings": "OU"}],
            "loading": {"pulled": [{"rope": "rope", "end": "start"}]}}


def test_pin_through_a_planar_drawing():
    g = build_knot(planar_loop([0.0, 10.0]))
    assert g.post is not None
    np.testing.assert_allclose(g.post.axis, [0, 0, 1])
    gap = g.post.axis_distance(g.ropes[0]) - 0.004 - H
    assert gap.min() > 0
    with pytest.raises(GeometryError, match=r"node \d+ of rope 'rope' is .* mm inside the contact distance of the post"):
        build_knot(planar_loop([0.0, 20.0]))  # on the rope (the top of the loop)


def test_obstacle_table_of_a_post():
    post = Post(center=np.array([0.0, 0.0, 0.01]), axis=np.array([0.0, 0.0, 1.0]), radius=0.01, length=0.2)
    t = post.obstacle_table("post", mu=0.3, stick_distance=None)
    assert t.pop("a") == pytest.approx([0.0, 0.0, -0.09]) and t.pop("b") == pytest.approx([0.0, 0.0, 0.11])
    assert t == {"type": "capsule", "name": "post", "radius": 0.01, "mu": 0.3}
    spinning = Post(center=np.zeros(3), axis=np.array([1.0, 0.0, 0.0]), radius=0.01, length=0.1, spin_inertia=1e-6)
    assert spinning.obstacle_table()["spin_inertia"] == 1e-6
    np.testing.assert_allclose(spinning.axis_distance(np.array([[0.5, 0.03, 0.04]])), [0.05])


def test_tail_lengths_count_the_post_as_part_of_the_knot():
    g = build_knot(wrap())
    x = g.ropes[0]
    no_post = self_tail_lengths(x, H, 5e-4)
    with_post = self_tail_lengths(x, H, 5e-4, g.post)
    assert no_post[1] == 0.0 and no_post[0] == pytest.approx(0.5, rel=1e-6)  # a helix alone is no knot
    r = np.hypot(x[:, 0], x[:, 1])
    touching = np.flatnonzero(r < 0.01 + 2 * H + 5e-4)
    s = _arc(x)
    assert with_post[0] == pytest.approx(s[touching[0]], abs=g.edge_length)
    assert with_post[1] == pytest.approx(s[-1] - s[touching[-1]], abs=g.edge_length)


def test_trim_or_extend_shares_the_extension():
    x = np.column_stack([np.linspace(0, 1, 11), np.zeros(11), np.zeros(11)])
    y = _trim_or_extend(x, 2.0, split=0.25)
    assert _arc(y)[-1] == pytest.approx(2.0)
    assert y[0, 0] == pytest.approx(-0.25) and y[-1, 0] == pytest.approx(1.75)
    z = _trim_or_extend(x, 2.0)
    assert z[0, 0] == pytest.approx(-0.5) and z[-1, 0] == pytest.approx(1.5)
