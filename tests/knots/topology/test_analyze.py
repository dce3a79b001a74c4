"""Tests of knotsim.knots.topology.analyze: knots and links identified from parametric curves."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from knotsim.knots import topology as T
from knotsim.knots.topology.polynomials import _mirror, _pmul_jones

from .curves import (
    RIGHT_TREFOIL_JONES,
    circle,
    connected_sum,
    figure_eight,
    hopf,
    random_rotation,
    torus_knot,
    trefoil,
)

# knots from parametric curves
# ---------------------------------------------------------------------------------------------


def test_circle_is_unknot():
    r = T.analyze([circle()], [True])
    assert r.knot_type == "unknot"
    assert r.alexander == [1]
    assert r.determinant == 1
    assert r.jones == {0: 1}
    assert r.n_crossings == 0


def test_right_trefoil():
    r = T.analyze([trefoil()], [True])
    assert r.knot_type == "trefoil_right"
    assert r.rolfsen == "3_1" and r.chirality == "right"
    assert r.alexander == [1, -1, 1]
    assert r.determinant == 3
    assert r.jones == RIGHT_TREFOIL_JONES
    assert r.writhe_reduced == 3
    assert T.writhe_3d(r.closed_curves[0]) > 3.0  # same sign as the diagram writhe


def test_left_trefoil_is_mirror():
    r = T.analyze([trefoil(right=False)], [True])
    assert r.knot_type == "trefoil_left"
    assert r.alexander == [1, -1, 1]
    assert r.jones == {-1: 1, -3: 1, -4: -1}
    assert r.writhe_reduced == -3


def test_figure_eight():
    r = T.analyze([figure_eight()], [True])
    assert r.knot_type == "figure_eight"
    assert r.rolfsen == "4_1" and r.chirality == "achiral"
    assert r.alexander == [-1, 3, -1]
    assert r.determinant == 5
    assert r.jones == {-2: 1, -1: -1, 0: 1, 1: -1, 2: 1}


@pytest.mark.parametrize("mirror", [False, True])
def test_torus_2_5(mirror):
    r = T.analyze([torus_knot(2, 5, 600, mirror=mirror)], [True])
    assert r.knot_type == ("5_1_left" if mirror else "5_1_right")
    assert r.alexander == [1, -1, 1, -1, 1]
    assert r.determinant == 5
    assert (r.writhe_reduced > 0) != mirror


def test_torus_3_4_is_unknown_but_has_right_alexander():
    r = T.analyze([torus_knot(3, 4, 800)], [True])
    assert r.knot_type == "unknown"  # 8_19 is not in the table
    assert r.alexander == [1, -1, 0, 1, 0, -1, 1]
    assert r.determinant == 3


@pytest.mark.parametrize("right", [True, False])
def test_granny(right):
    r = T.analyze([connected_sum(right, right)], [True])
    assert r.knot_type == ("granny_right" if right else "granny_left")
    assert r.rolfsen == "3_1#3_1"
    assert r.alexander == [1, -2, 3, -2, 1]
    assert r.determinant == 9
    v = RIGHT_TREFOIL_JONES if right else _mirror(RIGHT_TREFOIL_JONES)
    assert r.jones == _pmul_jones(v, v)


@pytest.mark.parametrize("right_first", [True, False])
def test_reef(right_first):
    r = T.analyze([connected_sum(right_first, not right_first)], [True])
    assert r.knot_type == "reef"
    assert r.rolfsen == "3_1#3_1*" and r.chirality == "achiral"
    assert r.alexander == [1, -2, 3, -2, 1]  # same Alexander as the granny...
    assert r.determinant == 9
    assert r.jones == _mirror(r.jones)  # ...but the Jones polynomial is symmetric


# ---------------------------------------------------------------------------------------------


# invariance under rotation, perturbation and projection direction
# ---------------------------------------------------------------------------------------------

_CURVES = {
    "trefoil_right": trefoil(300),
    "trefoil_left": trefoil(300, right=False),
    "figure_eight": figure_eight(300),
    "granny_right": connected_sum(True, True),
    "reef": connected_sum(True, False),
}


@settings(max_examples=12, deadline=None)
@given(
    name=st.sampled_from(sorted(_CURVES)),
    seed=st.integers(0, 2**31 - 1),
    noise=st.floats(0.0, 0.01),
)
def test_invariants_survive_rotation_and_noise(name, seed, noise):
    rng = np.random.default_rng(seed)
    c = _CURVES[name] @ random_rotation(rng).T + rng.normal(size=3) * 5.0
    c = c + noise * rng.normal(size=c.shape)
    r = T.analyze([c], [True], seed=seed)
    assert r.knot_type == name


def test_unsimplified_diagrams_give_same_invariants():
    """Projections along several directions (before any Reidemeister move) agree."""
    c = trefoil(300)
    seen = set()
    for seed in range(8):
        d = T.project([c], seed=seed, n_directions=1)
        pd, s, f = d.pd_code()
        seen.add(len(pd))
        assert T.jones_polynomial(pd, s, f, simplify=False) == RIGHT_TREFOIL_JONES
        assert T.alexander_polynomial(pd, s, f, simplify=False) == [1, -1, 1]
        assert T.knot_determinant(pd, s, f) == 3
    assert max(seen) > 3  # some projections had extra (removable) crossings


# links
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("positive", [True, False])
def test_hopf_link(positive):
    c1, c2 = hopf(positive)
    r = T.analyze([c1, c2], [True, True])
    lk = 1 if positive else -1
    assert r.linking[0, 1] == lk and r.linking[1, 0] == lk
    assert T.gauss_linking_number(c1, c2) == pytest.approx(lk, abs=1e-9)
    assert r.knot_type == ("hopf_positive" if positive else "hopf_negative")
    half = Fraction(1, 2)
    expected = {half: -1, 5 * half: -1} if positive else {-half: -1, -5 * half: -1}
    assert r.jones == expected
    assert r.component_types == ["unknot", "unknot"]
    assert r.determinant == 2
    assert r.alexander is None


def test_linking_matches_gauss_integral_under_rotation():
    rng = np.random.default_rng(7)
    c1, c2 = hopf(True)
    for _ in range(5):
        R = random_rotation(rng)
        a, b = c1 @ R.T, c2 @ R.T
        d = T.project([a, b], seed=int(rng.integers(1000)))
        assert d.linking_matrix()[0, 1] == round(T.gauss_linking_number(a, b)) == 1


def test_unlink():
    r = T.analyze([circle(), circle() + [5.0, 0.0, 0.0]], [True, True])
    assert r.knot_type == "unlink"
    assert r.linking[0, 1] == 0
    assert r.determinant == 0


def test_writhe_3d_is_average_diagram_writhe():
    c = trefoil(150)
    rng = np.random.default_rng(0)
    ws = [T.project([c], direction=rng.normal(size=3)).writhe for _ in range(300)]
    assert np.mean(ws) == pytest.approx(T.writhe_3d(c), abs=0.3)


# ---------------------------------------------------------------------------------------------
