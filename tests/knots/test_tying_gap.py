"""half_knot_gap (knotsim.knots.tying.gap): the rope between the two half-knots of a single-rod reef
or granny, on curves where the answer is known from an independent all-pairs crossing search."""

from __future__ import annotations

import numpy as np
import pytest
from tests.knots.brute import count_crossings

from knotsim.knots.library import get_knot
from knotsim.knots.tying import half_knot_gap


def _arc(x):
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))])


def _s(arc, loc):  # arc length at a position along the rope in edge units
    k = int(loc)
    return arc[k] + (loc - k) * (arc[k + 1] - arc[k])


def _in_series(bridge: float, mirror_second: bool, ds=0.005):
    """Two open overhands (library overhand_n1, tails along x) one after the other along a rope,
    joined by a straight bridge of length ``bridge`` (m); the second mirrored through z = 0 for a
    reef. Returns the rope and the node index where the second overhand starts."""
    a = get_knot("overhand_n1", n_nodes=201).ropes[0]
    b = a.copy()
    if mirror_second:
        b[:, 2] *= -1.0
    n_b = int(round(bridge / ds))
    line = a[-1] + np.outer(np.arange(1, n_b) * bridge / n_b, [1.0, 0.0, 0.0])
    b = b - b[0] + a[-1] + [bridge, 0.0, 0.0]
    return np.concatenate([a, line, b]), len(a) + len(line)


@pytest.mark.parametrize("mirror", [True, False], ids=["reef", "granny"])
def test_two_overhands_in_series(mirror):
    x, i2 = _in_series(0.08, mirror)
    g = half_knot_gap(x, 2e-3)
    assert g.form == "in series"
    assert g.direction is not None and abs(g.direction[2]) > 0.99  # seen face on
    assert g.inner_type.startswith("trefoil") and g.outer_type.startswith("trefoil")
    assert (g.inner_type == g.outer_type) is (not mirror)
    # the expected gap: from the last crossing pass of the first overhand to the first of the second
    cr = count_crossings([x])
    locs = sorted(p[1] for c in cr for p in (c["over"], c["under"]))
    first = [p for p in locs if p < i2 - 1]
    second = [p for p in locs if p >= i2 - 1]
    assert len(cr) == 6 and len(first) == len(second) == 6
    arc = _arc(x)
    expected = _s(arc, second[0]) - _s(arc, first[-1])
    assert g.arcs == pytest.approx((expected,), abs=2e-5)
    assert g.gap == pytest.approx(expected, abs=2e-5)
    assert g.diameters == pytest.approx(g.gap / 4e-3, rel=1e-12)
    assert 0.08 < g.gap < 0.08 + arc[-1]


def test_gap_grows_with_the_bridge_by_exactly_its_length():
    g1 = half_knot_gap(_in_series(0.05, True)[0], 2e-3)
    g2 = half_knot_gap(_in_series(0.12, True)[0], 2e-3)
    assert g2.gap - g1.gap == pytest.approx(0.07, abs=1e-9)


@pytest.mark.parametrize("name", ["single_rod_reef", "single_rod_granny"])
def test_studied_form_is_nested_with_its_hold_at_the_bottom_of_the_loop(name):
    """The library drawings (the studied form): the second half-knot on top of the first, the
    two connecting arcs the bends from one into the other, the hold at the drawing's hold hint."""
    knot = get_knot(name, n_nodes=301)
    x = knot.ropes[0]
    g = half_knot_gap(x, knot.radius)
    assert g.form == "nested" and len(g.arcs) == 2
    assert (g.inner_type == g.outer_type) is (name == "single_rod_granny")
    assert g.hold_node == knot.held[0].node
    # independent answer: the drawing's two braids, upper (second half-knot) and lower (first)
    cr = count_crossings([x])
    assert len(cr) == 6
    y_mid = np.mean([c["point"][1] for c in cr])
    arc = _arc(x)
    passes = sorted((p[1], c["point"][1] > y_mid) for c in cr for p in (c["over"], c["under"]))
    joins = [_s(arc, passes[k + 1][0]) - _s(arc, passes[k][0]) for k in range(len(passes) - 1)
             if passes[k][1] != passes[k + 1][1]]
    assert len(joins) == 2
    assert g.arcs == pytest.approx(tuple(sorted(joins)), abs=2e-5)
    assert g.gap == pytest.approx(max(joins), abs=2e-5)


def test_one_overhand_has_no_gap_and_bad_input_is_refused():
    x = get_knot("overhand_n1", n_nodes=201).ropes[0]
    g = half_knot_gap(x, 2e-3)
    assert g.gap is None and g.diameters is None and g.form is None
    assert g.as_dict()["half_knot_gap"] is None
    with pytest.raises(ValueError, match="radius"):
        half_knot_gap(x, 0.0)
    with pytest.raises(ValueError, match="shape"):
        half_knot_gap(x[:, :2], 2e-3)
