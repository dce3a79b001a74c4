"""The hitch atlas: drawings made on a post's surface (``kind = "hitch"``) build cleanly at several
resolutions, have their recorded crossing count, and their link with the post (the post's axis made long,
closed far away with the rope by :func:`~knotsim.knots.topology.analyze`) has the recorded linking number
and Jones polynomial; the clove and cow hitches are told apart by their topology and their ends."""

from __future__ import annotations

import functools
import re
from fractions import Fraction

import numpy as np
import pytest

from knotsim.knots.build import NodeRef
from knotsim.knots.library import get_knot, knot_names, load_knot_spec
from knotsim.knots.topology import analyze

RESOLUTIONS = (101, 201, 301)
NEW_HITCHES = ("cow_hitch", "two_half_hitches", "round_turn_two_half_hitches", "constrictor_hitch",
               "timber_hitch", "rolling_hitch")
#: hitches whose TOML does not record their link with the post (yet): (linking number, Jones polynomial) of
#: the current drawing, closed as in :func:`post_link`
UNRECORDED: dict[str, tuple[int, str]] = {}  # every hitch records its link with the post

HITCHES = sorted(n for n in knot_names() if load_knot_spec(n).kind == "hitch")


def parse_jones(text: str) -> dict[Fraction, int]:
    """``"-t^(1/2) + 2 t^(3/2) - 1"`` -> ``{1/2: -1, 3/2: 2, 0: -1}`` (the TOMLs' short text form)."""
    out: dict[Fraction, int] = {}
    body = text.replace(" ", "")
    pos = 0
    for m in re.finditer(r"([+-]?)(\d*)(t\^\((-?\d+(?:/\d+)?)\)|t)?", body):
        if not m.group(0):
            continue
        assert m.start() == pos, f"cannot read the Jones polynomial {text!r} at {body[pos:]!r}"
        pos = m.end()
        sign = -1 if m.group(1) == "-" else 1
        coeff = int(m.group(2)) if m.group(2) else 1
        exp = Fraction(0) if m.group(3) is None else Fraction(1) if m.group(3) == "t" else Fraction(m.group(4))
        out[exp] = out.get(exp, 0) + sign * coeff
    assert pos == len(body), f"cannot read the Jones polynomial {text!r}"
    return {e: c for e, c in out.items() if c}


def as_jones(j) -> dict[Fraction, int]:
    return {Fraction(e): int(c) for e, c in j.items() if int(c)}


@functools.cache
def built(name: str, n_nodes: int):
    return get_knot(name, n_nodes=n_nodes)


@functools.cache
def post_link(name: str):
    """The rope and the post's axis (made 11 times as long) as a two-component link, at 201 nodes."""
    g = built(name, 201)
    a, b = g.post.ends
    axis = np.linspace(a - 5 * (b - a), b + 5 * (b - a), 201)
    return analyze([g.ropes[0], axis])


def recorded(name: str) -> tuple[int, dict[Fraction, int]]:
    topo = load_knot_spec(name).meta.get("topology", {})
    if "post_linking" in topo and "jones" in topo:
        return int(topo["post_linking"]), parse_jones(str(topo["jones"]))
    if name in UNRECORDED:
        lk, jones = UNRECORDED[name]
        return lk, parse_jones(jones)
    pytest.fail(f"{name}: topology records no post_linking / jones")


def end_dot(name: str) -> float:
    """Dot product of the outward directions of the standing end (pulled) and the tail (last node)."""
    g = built(name, 201)
    ref = g.pulled[0]
    tail = NodeRef(ref.rope, len(g.ropes[ref.rope]) - 1 if ref.node == 0 else 0)
    return float(g.end_direction(ref) @ g.end_direction(tail))


def test_hitch_atlas():
    assert len(HITCHES) >= 7
    assert {"clove_hitch", *NEW_HITCHES} <= set(HITCHES)
    for name in HITCHES:
        spec = load_knot_spec(name)
        assert spec.post is not None and spec.post.drawn_on == "surface", name
        assert spec.description and "\n" not in spec.description, name
        assert "Ashley" in str(spec.meta.get("reference", "")), name
        assert [(p.rope, p.end) for p in spec.pulled] == [("rope", "start")], name


@pytest.mark.parametrize("n_nodes", RESOLUTIONS)
@pytest.mark.parametrize("name", HITCHES)
def test_hitch_builds(name, n_nodes):
    g = built(name, n_nodes)
    h = g.radius
    assert g.min_clearance >= 2.0 * h * (1 - 1e-9), (name, n_nodes, g.closest_pair.describe())
    for rope in g.ropes:
        assert g.post.axis_distance(rope).min() >= (g.post.radius + h) * (1 - 1e-9), (name, n_nodes)
    assert g.n_crossings == int(load_knot_spec(name).meta["topology"]["crossings"]), (name, n_nodes)


@pytest.mark.parametrize("name", HITCHES)
def test_hitch_link_with_post(name):
    res = post_link(name)
    lk, jones = recorded(name)
    assert res.n_components == 2
    assert int(res.linking[0, 1]) == lk, (name, res.linking)
    assert res.jones is not None and as_jones(res.jones) == jones, (name, res.jones)


def test_parse_jones():
    assert parse_jones("-t^(-1/2) - t^(1/2)") == {Fraction(-1, 2): -1, Fraction(1, 2): -1}
    assert parse_jones("t^(-2) + 2 - 3 t^(1) + t") == {Fraction(-2): 1, Fraction(0): 2, Fraction(1): -2}


def test_clove_and_cow_differ():
    clove, cow = post_link("clove_hitch"), post_link("cow_hitch")
    assert abs(int(clove.linking[0, 1])) >= 2          # the clove hitch goes round the post, net
    assert int(cow.linking[0, 1]) == 0                  # the cow hitch goes round and back: net 0 ...
    assert cow.knot_type == "unlink"                    # ... and slides off the post's end
    assert as_jones(clove.jones) != as_jones(cow.jones)
    assert end_dot("clove_hitch") < 0                   # the clove hitch's ends leave in opposite directions
    assert end_dot("cow_hitch") > 0.9                   # the cow hitch's ends leave side by side, parallel
