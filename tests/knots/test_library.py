"""Tests of the built-in knot library: every drawing builds overlap-free with the intended diagram."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from knotsim.errors import ConfigError
from knotsim.knots import topology as T
from knotsim.knots.geometry import KnotGeometry, NodeRef
from knotsim.knots.library import get_knot, knot_names, list_knots, load_knot_spec

from .brute import brute_min_clearance, count_crossings, letters_along

# name -> (crossings, writhe of the xy projection with the ropes oriented first -> last node)
EXPECTED = {
    "overhand_n1": (3, +3),
    "overhand_n2": (5, +5),
    "overhand_n3": (7, +7),
    "overhand_n4": (9, +9),
    "single_rod_reef": (6, 0),
    "single_rod_granny": (6, -6),
    "reef_bend": (6, 0),
    "granny_bend": (6, -6),
    "thief_bend": (6, 0),
    "grief_bend": (6, -6),
    "carrick_bend": (8, 0),
    "sheet_bend": (7, -3),
    "double_sheet_bend": (12, -4),
    "hunters_bend": (12, -12),
    "zeppelin_bend": (10, 0),
    "ashley_bend": (12, -4),
    "alpine_butterfly_bend": (12, 2),
    "double_fishermans_bend": (26, 10),
}
RESOLUTIONS = (101, 301)


@functools.cache
def built(name: str, n_nodes: int) -> KnotGeometry:
    return get_knot(name, n_nodes=n_nodes)


#: kinds drawn round a post (hitches, loops on a pin): their own tests (test_hitch_library.py, test_loop_library.py)
ON_POST = ("hitch", "loop")


def test_list_knots():
    names = knot_names()
    assert set(EXPECTED) == {n for n in names if load_knot_spec(n).kind not in ON_POST}
    listed = list_knots()
    assert [n for n, _ in listed] == sorted(names)
    for _, description in listed:
        assert description and "\n" not in description


def test_unknown_knot_lists_available():
    with pytest.raises(ConfigError, match=r"unknown knot 'monkeys_fist'.*overhand_n1.*reef_bend") as exc:
        load_knot_spec("monkeys_fist")
    assert isinstance(exc.value, ValueError)
    with pytest.raises(ConfigError, match="cannot read"):
        load_knot_spec("/nonexistent/knot.toml")


def test_user_toml_file(tmp_path):
    text = """
name = "my_cross"
description = "two ropes crossing once"
kind = "test"
[defaults]
radius = 0.001
length = 0.5
n_nodes = 41
[[ropes]]
name = "a"
waypoints = [[0, 0], [10, 0]]
crossings = "U"
[[ropes]]
name = "b"
waypoints = [[5, -5], [5, 5]]
crossings = "O"
"""
    path = tmp_path / "cross.toml"
    path.write_text(text)
    spec = load_knot_spec(path)
    assert spec.name == "my_cross" and spec.n_crossings == 1
    geo = get_knot(str(path))
    assert [len(r) for r in geo.ropes] == [41, 41] and geo.radius == 0.001 and geo.length == 0.5
    assert geo.writhe == -1
    bad = tmp_path / "bad.toml"
    bad.write_text("name = [")
    with pytest.raises(ConfigError, match="invalid TOML"):
        load_knot_spec(bad)


@pytest.mark.parametrize("n_nodes", RESOLUTIONS)
@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_library_knot_clearance_and_diagram(name, n_nodes):
    geo = built(name, n_nodes)
    spec = load_knot_spec(name)
    assert all(r.shape == (n_nodes, 3) for r in geo.ropes)
    # no overlap: every pair of edges that may touch is at least 2h apart (independent all-pairs check)
    dist, _ = brute_min_clearance(geo.ropes, min_gap=3)
    assert dist >= geo.contact_distance
    assert geo.min_clearance == pytest.approx(dist, abs=1e-12)
    # every rope has the requested length with uniform edges
    for r in geo.ropes:
        np.testing.assert_allclose(np.linalg.norm(np.diff(r, axis=0), axis=1).sum(), geo.length, rtol=1e-10)
    # the intended diagram: crossing count, writhe, and the declared over/under sequence per rope
    xs = count_crossings(geo.ropes)
    n_cross, writhe = EXPECTED[name]
    assert len(xs) == n_cross == geo.n_crossings
    assert sum(c["sign"] for c in xs) == writhe == geo.writhe
    declared = ["".join("O" if p else "U" for p in r.passes) for r in spec.ropes]
    assert letters_along(len(geo.ropes), xs) == declared
    assert min(c["gap"] for c in xs) >= geo.contact_distance


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_overhand_is_alternating_and_loose(n):
    for n_nodes in RESOLUTIONS:
        geo = built(f"overhand_n{n}", n_nodes)
        assert geo.radius == 1.6e-3 and geo.length == 1.0
        (letters,) = letters_along(1, count_crossings(geo.ropes))
        assert len(letters) == 2 * (2 * n + 1)
        assert all(a != b for a, b in zip(letters, letters[1:], strict=False)), letters  # alternating
        assert all(c.sign == +1 for c in geo.crossings)  # a (2, 2n+1) torus braid: all one sign
        # loose start of the IMC overhand runs: end-to-end distance 0.28-0.33 m for L = 1 m
        assert 0.28 <= geo.end_to_end() <= 0.33
        assert {p.node for p in geo.pulled} == {0, n_nodes - 1}


def _half_knot_writhes(geo: KnotGeometry):
    """Writhe of the lower (first overhand) and upper (second half knot) three-crossing groups."""
    ys = sorted(geo.crossings, key=lambda c: c.point[1])
    assert len(ys) == 6
    low, high = ys[:3], ys[3:]
    assert max(c.point[1] for c in low) < min(c.point[1] for c in high)
    return sum(c.sign for c in low), sum(c.sign for c in high)


@pytest.mark.parametrize("prefix", ["single_rod_{}", "{}_bend"])
def test_reef_and_granny_differ_by_second_half_knot(prefix):
    reef = built(prefix.format("reef"), 301)
    granny = built(prefix.format("granny"), 301)
    r_low, r_high = _half_knot_writhes(reef)
    g_low, g_high = _half_knot_writhes(granny)
    assert abs(r_low) == abs(r_high) == abs(g_low) == abs(g_high) == 3
    assert r_low == g_low                 # same first half knot
    assert r_high == -r_low               # reef: opposite handedness
    assert g_high == g_low                # granny: same handedness


def test_single_rod_loading_hints():
    for name in ("single_rod_reef", "single_rod_granny"):
        geo = built(name, 301)
        assert geo.radius == 2e-3
        (held,) = geo.held
        x = geo.ropes[0]
        # held node: the bottom of the first overhand's loop
        assert held == NodeRef(0, 150)
        assert x[held.node, 1] == pytest.approx(x[:, 1].min(), abs=2e-3)
        # ends point out horizontally, away from each other
        d0 = geo.end_direction(geo.pulled[0])
        d1 = geo.end_direction(geo.pulled[1])
        assert d0[0] < -0.99 and d1[0] > 0.99


@pytest.mark.parametrize("name,free_same_side", [("reef_bend", True), ("granny_bend", True),
                                                 ("thief_bend", False), ("grief_bend", False)])
def test_bend_loading_hints(name, free_same_side):
    geo = built(name, 301)
    assert geo.rope_names == ("a", "b") and len(geo.held) == len(geo.pulled) == 1
    (held,), (pulled,) = geo.held, geo.pulled
    assert held.rope == 0 and pulled.rope == 1
    ph = geo.ropes[0][held.node]
    pp = geo.ropes[1][pulled.node]
    assert ph[0] < 0 < pp[0]                        # held and pulled ends on opposite sides
    assert geo.end_direction(held)[0] < -0.99 and geo.end_direction(pulled)[0] > 0.99
    free = [NodeRef(r, k) for r in (0, 1) for k in (0, 300) if NodeRef(r, k) not in (held, pulled)]
    ya, yb = (geo.ropes[f.rope][f.node][1] for f in free)
    assert (abs(ya - yb) < 1e-3) == free_same_side


def test_topology_module_agrees():
    cases = {"overhand_n1": "3_1", "overhand_n2": "5_1", "overhand_n3": "7_1",
             "single_rod_reef": "3_1#3_1*", "single_rod_granny": "3_1#3_1",
             "reef_bend": "3_1#3_1*", "granny_bend": "3_1#3_1"}
    for name, rolfsen in cases.items():
        geo = built(name, 301)
        if len(geo.ropes) == 2:
            pairing = T.bend_pairing(0, 1, int(geo.held[0].node > 0), int(geo.pulled[0].node > 0))
            res = T.analyze(list(geo.ropes), pairing=pairing)
        else:
            res = T.analyze(list(geo.ropes))
        assert res.n_components == 1
        assert res.rolfsen == rolfsen, (name, res.knot_type)
    assert T.analyze(list(built("overhand_n1", 301).ropes)).knot_type == "trefoil_right"
    # 9_1 (the (2, 9) torus knot) is in the table from closed forms, not from Rolfsen data
    res = T.analyze(list(built("overhand_n4", 301).ropes))
    assert list(res.alexander) == [1, -1, 1, -1, 1, -1, 1, -1, 1]
    assert res.rolfsen == "9_1" and res.knot_type in ("9_1_right", "9_1_left")
