"""Tests of knotsim.knots.topology.diagram: codes, input errors, degenerate directions, speed;
and the optional spherogram bridge."""

from __future__ import annotations

import time

import numpy as np
import pytest

from knotsim.errors import GeometryError
from knotsim.knots import topology as T

from .curves import (
    circle,
    connected_sum,
    rope_with_tails,
    torus_knot,
    trefoil,
)

# outputs, errors, speed
# ---------------------------------------------------------------------------------------------


def test_codes_are_consistent():
    r = T.analyze([trefoil()], [True])
    d = r.diagram
    gauss = d.gauss_code
    assert sorted(abs(x) for x in gauss[0]) == sorted(list(range(1, d.n_crossings + 1)) * 2)
    pd, signs, free = d.pd_code()
    labels = [v for x in pd for v in x]
    assert all(labels.count(v) == 2 for v in set(labels))
    for (i, j, k, l), s in zip(pd, signs, strict=True):
        n = 2 * len(pd)
        assert (j - l) % n == (1 if s > 0 else n - 1)  # over strand runs l -> j on positive crossings
        assert (k - i) % n == 1


@pytest.mark.parametrize(
    "curves",
    [
        [np.zeros((1, 3))],
        [np.zeros((5, 2))],
        [np.array([[0, 0, 0], [1, np.nan, 0], [2, 0, 0.0]])],
        [],
    ],
)
def test_bad_input_raises(curves):
    with pytest.raises(ValueError):
        T.analyze(curves)


def test_bad_closure_arguments():
    rope = rope_with_tails()
    with pytest.raises(T.TopologyError, match="not paired"):
        T.close_curves([rope, rope + 50], pairing=[((0, 0), (0, 1))])
    with pytest.raises(T.TopologyError, match="more than once"):
        T.close_curves([rope, rope + 50], pairing=[((0, 0), (1, 0)), ((0, 0), (1, 1))])
    with pytest.raises(T.TopologyError, match="closed"):
        T.close_curves([circle(), rope], [True, False], pairing=[((0, 0), (1, 0))])
    with pytest.raises(T.TopologyError, match="method"):
        T.close_curves([rope], method="magic")
    with pytest.raises(T.TopologyError, match="at least 3"):
        T.close_curves([np.eye(3)[:2]], [True])
    with pytest.raises(T.TopologyError):
        T.bend_pairing(0, 0)
    assert issubclass(T.TopologyError, GeometryError) and issubclass(T.TopologyError, ValueError)


def test_degenerate_direction_raises():
    sq = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    with pytest.raises(T.TopologyError, match="not generic"):
        T.project([sq], direction=[1.0, 0.0, 0.0])  # edges parallel to the view direction


def test_projection_speed_3000_segments():
    c = torus_knot(3, 7, 3000)
    T.project([c], n_directions=1)  # compile / warm up
    t0 = time.perf_counter()
    d = T.project([c], n_directions=1)
    assert time.perf_counter() - t0 < 0.5
    assert d.n_crossings >= 14


# ---------------------------------------------------------------------------------------------
# optional spherogram
# ---------------------------------------------------------------------------------------------


def test_spherogram_agrees():
    pytest.importorskip("spherogram")
    pytest.importorskip("knot_floer_homology")
    r = T.analyze([trefoil()], [True])
    L = T.spherogram_link(r.pd_code)
    assert [c.sign for c in L.crossings] == list(r.signs)
    info = T.identify_with_spherogram(r)
    assert info["crossings"] == 3
    assert info["knot_floer_homology"]["tau"] == 1  # right-handed trefoil: tau = +1
    assert info["knot_floer_homology"]["seifert_genus"] == 1
    reef = T.analyze([connected_sum(True, False)], [True])
    hfk = T.identify_with_spherogram(reef)["knot_floer_homology"]
    assert hfk["tau"] == 0 and hfk["seifert_genus"] == 2
    assert T.identify_with_spherogram(T.analyze([circle()], [True]))["identify"] == ["unknot"]
