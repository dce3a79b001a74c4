"""Tests of knotsim.knots.build: crossings, lifting, relaxation, node-count options and errors."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.errors import ConfigError, GeometryError
from knotsim.knots import geometry as G

from .brute import CROSS, brute_min_clearance, count_crossings, letters_along


def test_simple_crossing_lifted_and_signed():
    geo = G.build_knot(CROSS, n_nodes=51, radius=1e-3, length=0.5)
    a, b = geo.ropes
    assert a.shape == (51, 3) and b.shape == (51, 3) and a.dtype == np.float64
    xs = count_crossings(geo.ropes)
    assert len(xs) == 1 and geo.n_crossings == 1
    c = xs[0]
    assert c["over"][0] == 0 and c["under"][0] == 1     # rope a over rope b
    # a along +x over b along +y: o x u = +z -> positive crossing
    assert c["sign"] == +1 and geo.writhe == +1
    assert c["gap"] >= 2e-3
    assert geo.min_clearance >= geo.contact_distance
    assert geo.held == (G.NodeRef(0, 0),) and geo.pulled == (G.NodeRef(1, 25),)
    np.testing.assert_allclose(geo.end_direction(G.NodeRef(0, 0)), [-1, 0, 0], atol=1e-9)
    # swapping the letters mirrors the crossing
    flipped = {**CROSS, "ropes": [{**CROSS["ropes"][0], "crossings": "U"}, {**CROSS["ropes"][1], "crossings": "O"}]}
    assert G.build_knot(flipped, n_nodes=51, radius=1e-3, length=0.5).writhe == -1


def test_lengths_units_and_node_count_options():
    spec = {"name": "two", "ropes": [
        {"name": "long", "waypoints": [[0, 0], [40, 10], [80, 0]], "crossings": ""},
        {"name": "short", "waypoints": [[0, 30], [40, 35]], "crossings": ""}]}
    geo = G.build_knot(spec, edge_length=0.01, radius=1e-3, length=2.0)
    assert [len(r) for r in geo.ropes] == [201, 201]
    for r in geo.ropes:   # every rope has exactly the requested length, uniform edges
        e = np.linalg.norm(np.diff(r, axis=0), axis=1)
        np.testing.assert_allclose(e, 0.01, rtol=1e-10)
    assert geo.edge_length == pytest.approx(0.01)
    assert geo.end_nodes == {"long": (0, 200), "short": (0, 200)}
    with pytest.raises(ConfigError, match="not both"):
        G.build_knot(spec, n_nodes=11, edge_length=0.1)
    with pytest.raises(ConfigError, match="n_nodes"):
        G.build_knot(spec, n_nodes=3)
    with pytest.raises(ConfigError, match="radius"):
        G.build_knot(spec, radius=-1.0)


def test_wrong_crossing_count_is_reported():
    spec = {"name": "miscount", "ropes": [
        {"name": "a", "waypoints": [[0, 0], [100, 0]], "crossings": "OU"},
        {"name": "b", "waypoints": [[50, -50], [50, 50]], "crossings": "UO"}]}
    with pytest.raises(ConfigError, match=r"passes through 1 crossings .* but 2 over/under letters"):
        G.build_knot(spec, n_nodes=51, radius=1e-3)
    # a drawing with no crossing at all but letters declared
    spec = {"name": "none", "ropes": [{"name": "a", "waypoints": [[0, 0], [50, 5], [100, 0]], "crossings": "OU"}]}
    with pytest.raises(ConfigError, match="passes through 0 crossings"):
        G.build_knot(spec, n_nodes=51, radius=1e-3)


def test_both_strands_over_is_reported():
    # rope b dips below rope a and comes back up: two crossings, met in the same order by both
    spec = {"name": "bothover", "ropes": [
        {"name": "a", "waypoints": [[0, 0], [100, 0]], "crossings": "OU"},
        {"name": "b", "waypoints": [[30, 30], [30, -10], [50, -30], [70, -10], [70, 30]], "crossings": "OU"}]}
    with pytest.raises(ConfigError, match="declared over on both strands"):
        G.build_knot(spec, n_nodes=101, radius=1e-3)
    ok = {**spec, "ropes": [spec["ropes"][0], {**spec["ropes"][1], "crossings": "UO"}]}
    geo = G.build_knot(ok, n_nodes=101, radius=1e-3)
    assert letters_along(2, count_crossings(geo.ropes)) == ["OU", "UO"]


PARALLEL = {"name": "parallel", "ropes": [
    {"name": "a", "waypoints": [[0, 0], [50, 0], [100, 0]]},
    {"name": "b", "waypoints": [[0, 0.2], [50, 0.2], [100, 0.2]]}]}


def test_relaxation_pushes_close_ropes_apart():
    # drawn 2 mm apart with d = 3.2 mm: the relaxation must separate them and keep them straight
    geo = G.build_knot(PARALLEL, n_nodes=101, radius=1.6e-3, length=1.0)
    dist, _ = brute_min_clearance(geo.ropes)
    assert dist >= geo.contact_distance
    assert geo.min_clearance == pytest.approx(dist, abs=1e-12)
    assert np.ptp(geo.ropes[0][:, 1]) < 1e-3 and geo.n_crossings == 0
    for r in geo.ropes:
        np.testing.assert_allclose(np.linalg.norm(np.diff(r, axis=0), axis=1), 0.01, rtol=1e-10)


def test_overlap_error_names_closest_pair():
    with pytest.raises(GeometryError, match=r"rope 'a' edge \d+ and rope 'b' edge \d+ are 2\.\d+ mm apart, "
                                            r"contact distance is 3\.200 mm") as exc:
        G.build_knot(PARALLEL, n_nodes=101, radius=1.6e-3, length=1.0, max_iter=0)
    assert isinstance(exc.value, ValueError)
    # a rod far too thick for the drawing cannot keep the declared diagram: the knot falls open
    from knotsim.knots.library import load_knot_spec

    with pytest.raises(GeometryError, match=r"no longer has the declared crossing diagram.*closest pair: "
                                            r"rope 'rod' edge \d+ and rope 'rod' edge \d+"):
        G.build_knot(load_knot_spec("overhand_n1"), n_nodes=101, radius=0.04)


def test_projected_crossings_agree_with_bruteforce():
    rng = np.random.default_rng(3)
    ropes = [np.cumsum(rng.normal(size=(60, 3)), axis=0), np.cumsum(rng.normal(size=(40, 3)), axis=0)]
    mine = sorted((c.over_rope, c.over_edge + c.over_t, c.sign) for c in G.projected_crossings(ropes))
    ref = sorted((c["over"][0], c["over"][1], c["sign"]) for c in count_crossings(ropes))
    assert len(mine) == len(ref) > 5
    for m, r in zip(mine, ref, strict=True):
        assert m[0] == r[0] and m[1] == pytest.approx(r[1]) and m[2] == r[2]
