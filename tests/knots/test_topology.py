"""Tests of knotsim.knots.topology: closure, diagrams, linking numbers, knot invariants."""

from __future__ import annotations

import itertools
import time
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from knotsim.errors import GeometryError
from knotsim.knots import topology as T

# ---------------------------------------------------------------------------------------------
# curves
# ---------------------------------------------------------------------------------------------

RIGHT_TREFOIL_JONES = {1: 1, 3: 1, 4: -1}


def torus_knot(p: int, q: int, n: int = 400, mirror: bool = False) -> np.ndarray:
    """(p, q) torus knot on a torus R=2, r=1; with z = -sin(q t) (mirror=False) it is right-handed."""
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    z = np.sin(q * t) * (1.0 if mirror else -1.0)
    return np.c_[(2 + np.cos(q * t)) * np.cos(p * t), (2 + np.cos(q * t)) * np.sin(p * t), z]


def trefoil(n: int = 400, right: bool = True) -> np.ndarray:
    return torus_knot(2, 3, n, mirror=not right)


def figure_eight(n: int = 400) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return np.c_[(2 + np.cos(2 * t)) * np.cos(3 * t), (2 + np.cos(2 * t)) * np.sin(3 * t), np.sin(4 * t)]


def circle(n: int = 100, radius: float = 1.0) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return radius * np.c_[np.cos(t), np.sin(t), np.zeros_like(t)]


def trefoil_arc(right: bool = True, delta: float = 0.15, n: int = 400) -> np.ndarray:
    """Open overhand knot: the trefoil cut open at its outermost point (3, 0, 0)."""
    t = np.linspace(delta, 2.0 * np.pi - delta, n)
    z = -np.sin(3 * t) if right else np.sin(3 * t)
    return np.c_[(2 + np.cos(3 * t)) * np.cos(2 * t), (2 + np.cos(3 * t)) * np.sin(2 * t), z]


def rope_with_tails(right: bool = True, tail: float = 20.0) -> np.ndarray:
    """Overhand knot in a rope: the trefoil arc plus straight tails leaving along +y and -y."""
    arc = trefoil_arc(right)
    s = np.linspace(1.0, 0.0, 30, endpoint=False)[:, None]
    head = arc[0] + s * np.array([0.0, tail - arc[0, 1], 0.0])  # from y = tail down to the arc start
    s2 = np.linspace(0.0, 1.0, 31)[1:, None]
    foot = arc[-1] + s2 * np.array([0.0, -tail - arc[-1, 1], 0.0])  # from the arc end down to y = -tail
    return np.concatenate([head, arc, foot])


def rot_z180_shift(a: np.ndarray, dx: float) -> np.ndarray:
    return np.c_[dx - a[:, 0], -a[:, 1], a[:, 2]]


def connected_sum(right_a: bool, right_b: bool, gap: float = 9.0) -> np.ndarray:
    """Closed polyline K_a # K_b of two trefoils, joined by two straight bridges across a gap.

    K_b is K_a's construction rotated by 180 degrees about z (a rotation, so chirality is kept) and
    shifted along x; the plane x = gap/2 meets the curve only on the two bridges.
    """
    a = trefoil_arc(right_a)
    b = rot_z180_shift(trefoil_arc(right_b), gap)
    # a ends at y < 0, b starts at y < 0 (rotated start): a -> b -> back to a
    return np.concatenate([a, b])


def hopf(positive: bool) -> list[np.ndarray]:
    """Two round circles linked once; with z flipped the linking number changes sign."""
    t = np.linspace(0.0, 2.0 * np.pi, 120, endpoint=False)
    c1 = np.c_[np.cos(t), np.sin(t), 0 * t]
    c2 = np.c_[1 + np.cos(t), 0 * t, np.sin(t)]  # linking number -1 (checked by hand in the docs)
    if positive:
        c2 = c2 * [1, 1, -1]
    return [c1, c2]


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def brute_force_bracket(pd) -> dict[int, int]:
    """Kauffman bracket by the plain 2^n state sum (reference for small diagrams)."""
    out: dict[int, int] = {}
    n = len(pd)
    for state in itertools.product((0, 1), repeat=n):
        parent: dict[int, int] = {}

        def find(a, parent=parent):
            parent.setdefault(a, a)
            while parent[a] != a:
                a = parent[a]
            return a

        def union(a, b, parent=parent):
            ra, rb = find(a), find(b)
            if ra != rb:
                parent[ra] = rb

        for (a, b, c, d), s in zip(pd, state, strict=True):
            if s == 0:  # A-smoothing
                union(a, b)
                union(c, d)
            else:
                union(a, d)
                union(b, c)
        loops = len({find(x) for x in parent})
        e_a = state.count(0) - state.count(1)
        delta_pow = T._ppow(T._DELTA, loops - 1)
        for e, c in delta_pow.items():
            out[e + e_a] = out.get(e + e_a, 0) + c
    return {e: c for e, c in out.items() if c}


# ---------------------------------------------------------------------------------------------
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
    v = RIGHT_TREFOIL_JONES if right else T._mirror(RIGHT_TREFOIL_JONES)
    assert r.jones == T._pmul_jones(v, v)


@pytest.mark.parametrize("right_first", [True, False])
def test_reef(right_first):
    r = T.analyze([connected_sum(right_first, not right_first)], [True])
    assert r.knot_type == "reef"
    assert r.rolfsen == "3_1#3_1*" and r.chirality == "achiral"
    assert r.alexander == [1, -2, 3, -2, 1]  # same Alexander as the granny...
    assert r.determinant == 9
    assert r.jones == T._mirror(r.jones)  # ...but the Jones polynomial is symmetric


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


def test_contraction_bracket_matches_state_sum():
    for curve, seed in ((trefoil(200), 3), (figure_eight(200), 5), (connected_sum(True, False), 1)):
        for s in range(3):
            d = T.project([curve], seed=seed + 17 * s, n_directions=1)
            pd, _, _ = d.pd_code()
            if len(pd) > 12:
                continue
            assert T.kauffman_bracket(pd) == brute_force_bracket(pd)


def test_faces_euler_characteristic():
    d = T.project([figure_eight(200)], seed=2, n_directions=1)
    pd, _, _ = d.pd_code()
    faces = T._faces([list(x) for x in pd])
    assert len(faces) == len(pd) + 2  # connected planar 4-valent graph on the sphere


def test_simplify_removes_kinks_and_bigons():
    # a figure-eight-shaped curve: one crossing, R1 leaves a single circle
    pd, signs, free = T.simplify_pd([(0, 0, 1, 1)], [1])
    assert pd == [] and len(signs) == 0 and free == 1
    # the trivial two-crossing diagram of the unlink: circle 1 passes over circle 2 twice (R2)
    c1 = circle(80)
    c2 = circle(80) + [1.0, 0.0, -0.5]
    d = T.project([c1, c2], direction=[0.01, 0.02, 1.0])
    assert d.n_crossings == 2
    pd, signs, free = T.simplify_pd(*d.pd_code())
    assert pd == [] and free == 2
    # a clasp (alternating bigon, the Hopf link) must not be removed
    d = T.project(hopf(True), direction=[0.01, 0.02, 1.0])
    pd, signs, free = T.simplify_pd(*d.pd_code())
    assert len(pd) == 2 and free == 0


# ---------------------------------------------------------------------------------------------
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
# open ropes and closure
# ---------------------------------------------------------------------------------------------


def test_open_straight_rope_is_unknot():
    rope = np.c_[np.linspace(0, 1, 50), np.zeros(50), np.zeros(50)]
    r = T.analyze([rope])
    assert r.knot_type == "unknot"
    assert r.n_components == 1


@pytest.mark.parametrize("right", [True, False])
def test_open_overhand_arc_closes_to_trefoil(right):
    r = T.analyze([trefoil_arc(right)], [False])
    assert r.knot_type == ("trefoil_right" if right else "trefoil_left")


@pytest.mark.parametrize("method", ["radial", "tangent"])
def test_open_overhand_with_tails(method):
    r = T.analyze([rope_with_tails(True)], closure=method)
    assert r.knot_type == "trefoil_right"
    # the far closure lies on a sphere much larger than the tangle
    comp = r.closed_curves[0]
    assert np.max(np.linalg.norm(comp - comp.mean(axis=0), axis=1)) > 100.0


def test_closure_is_far_and_keeps_the_rope():
    rope = rope_with_tails(True)
    (comp,) = T.close_curves([rope], [False], radius_factor=30.0)
    np.testing.assert_array_equal(comp[: len(rope)], rope)
    c = rope.mean(axis=0)
    R = np.max(np.linalg.norm(rope - c, axis=1))
    far = np.linalg.norm(comp[len(rope) :] - c, axis=1)
    assert np.all(far >= 30.0 * R * (1 - 1e-9))


def _bend_ropes(right_b: bool) -> list[np.ndarray]:
    a = rope_with_tails(True)  # from y = +20 through a right trefoil to y = -20
    b = rot_z180_shift(rope_with_tails(right_b), 9.0)  # from y = -20 to y = +20, to the right
    return [a, b]


@pytest.mark.parametrize(("right_b", "name"), [(True, "granny_right"), (False, "reef")])
def test_bend_pairing_makes_one_knot(right_b, name):
    ropes = _bend_ropes(right_b)
    # each rope closed on itself: two separate trefoils, not linked
    r = T.analyze(ropes)
    assert r.n_components == 2
    assert r.linking[0, 1] == 0
    assert r.component_types == ["trefoil_right", "trefoil_right" if right_b else "trefoil_left"]
    # the bend: ends at y = -20 joined, ends at y = +20 joined -> one component
    pairing = T.bend_pairing(0, 1, pull_end_a=1, pull_end_b=0)
    assert pairing == [((0, 1), (1, 0)), ((0, 0), (1, 1))]
    r = T.analyze(ropes, pairing=pairing)
    assert r.n_components == 1 and r.component_ropes == [[0, 1]]
    assert r.knot_type == name


def test_reversed_rope_in_pairing():
    a, b = _bend_ropes(True)
    r = T.analyze([a, b[::-1]], pairing=[((0, 1), (1, 1)), ((1, 0), (0, 0))])
    assert r.knot_type == "granny_right"


def test_mixed_open_and_closed():
    r = T.analyze([trefoil_arc(True), circle(radius=0.3) + [0, 0, 10.0]], [False, True])
    assert r.n_components == 2
    assert r.component_types == ["trefoil_right", "unknot"]
    assert r.linking[0, 1] == 0


# ---------------------------------------------------------------------------------------------
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


def test_alexander_modular_matches_exact():
    d = T.project([connected_sum(True, False)], seed=4, n_directions=1)
    pd, s, f = d.pd_code()
    n_arcs, rows = T._wirtinger(pd, s)
    M0, M1 = T._fox_matrices(n_arcs, rows)
    coeffs = T._minor_poly(M0, M1)
    for t in (-2, -1, 2, 3):
        exact = T._bareiss_det((M0 + t * M1).tolist())
        assert sum(c * t**e for e, c in enumerate(coeffs)) == exact


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


def test_torus_closed_forms_reproduce_the_table_and_name_9_1():
    from knotsim.knots.topology import _PRIME, _torus_2q

    table = {rolf: (alex, jones) for rolf, _, alex, jones in _PRIME}
    for q, rolf in ((3, "3_1"), (5, "5_1"), (7, "7_1")):
        alex, jones = _torus_2q(q)
        assert alex == table[rolf][0]
        assert jones == table[rolf][1]
    alex, jones = _torus_2q(9)
    assert alex == [1, -1, 1, -1, 1, -1, 1, -1, 1]
    # Jones polynomial of the positive T(2, 9): t^4 (1 + t^2 - t^3 + t^4 - t^5 + t^6 - t^7 + t^8 - t^9)
    assert jones == {4: 1, 6: 1, 7: -1, 8: 1, 9: -1, 10: 1, 11: -1, 12: 1, 13: -1}
    names = {e.knot_type for e in T.KNOT_TABLE if e.rolfsen == "9_1"}
    assert names == {"9_1_right", "9_1_left"}
