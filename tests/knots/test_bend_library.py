"""The bend atlas: library bends against Patil's shapes (same topology) and named by the topology module."""

from __future__ import annotations

import functools
from pathlib import Path

import pytest

from knotsim.knots.library import get_knot, list_knots
from knotsim.knots.topology import BEND_TABLE, analyze, analyze_bend, identify_bend
from knotsim.knots.topology.polynomials import _mirror

PATIL = Path(__file__).resolve().parents[3] / "shared" / "data" / "foreign" / "knot_simulation"
needs_patil = pytest.mark.skipif(not PATIL.is_dir(), reason="Patil's shapes (../shared/data/foreign/knot_simulation) absent")

# library bend -> (bend name, Patil shape with the same topology or None, whether the library drawing
# is the mirror image of Patil's shape: the granny, thief and grief drawings are)
BENDS = {
    "reef_bend": ("reef bend", "reef_loose", False),
    "granny_bend": ("granny bend", "granny_loose", True),
    "thief_bend": ("thief bend", "thief_loose", True),
    "grief_bend": ("grief bend", "grief_loose", True),
    "sheet_bend": ("sheet bend", "bowline13", False),   # the sheet bend is the bowline's tangle
    "carrick_bend": (None, "carrick14", False),
    # control points derived from Patil's centrelines (the TOML comments say how)
    "hunters_bend": ("hunter's bend", "hunter13", False),
    "zeppelin_bend": (None, "zeppelin14", False),
    "ashley_bend": (None, "ashley13", False),
    "alpine_butterfly_bend": ("alpine butterfly bend", "alpine13", False),
    # no Patil shape: checked against the knot itself below
    "double_sheet_bend": (None, None, False),
    "double_fishermans_bend": (None, None, False),
}
# the bends whose every rope, in Patil's shapes, ties an overhand knot: (self-closure types)
TREFOIL_ROPES = {
    "hunters_bend": ["trefoil_left", "trefoil_left"],
    "zeppelin_bend": ["trefoil_left", "trefoil_right"],
    "ashley_bend": ["trefoil_left", "trefoil_left"],
    "alpine_butterfly_bend": ["trefoil_left", "trefoil_right"],
}


@functools.cache
def built(name: str):
    return get_knot(name, n_nodes=151)


def _standing(geo):
    h, p = geo.held[0], geo.pulled[0]
    return ((h.rope, int(h.node > 0)), (p.rope, int(p.node > 0)))


def test_bends_listed():
    names = {n for n, _ in list_knots()}
    assert set(BENDS) <= names and len(BENDS) == 12


@pytest.mark.parametrize("name", sorted(BENDS))
def test_bend_named(name):
    res = analyze_bend(built(name).ropes, _standing(built(name)))
    assert res.n_components == 1
    assert res.bend == BENDS[name][0], (name, res.knot_type)


def test_identify_bend_table():
    assert identify_bend("6_1", 0) == "thief bend" and identify_bend("3_1", -3) == "grief bend"
    assert identify_bend("6_1", 3) == "hunter's bend" and identify_bend("6_1", 1) is None
    assert identify_bend(None, 0) is None and identify_bend("0_1", -1) == "alpine butterfly bend"
    assert len(set(BEND_TABLE.values())) == len(BEND_TABLE)


def _same_link(r1, r2, mirror: bool) -> bool:
    """Same two-component link (or its mirror image) up to reversing one component: |lk|, component
    types (up to mirror), and the Jones polynomial up to the factor t^(3 lk) that reversing a
    component brings."""
    l1, l2 = int(r1.linking[0, 1]), (-1 if mirror else 1) * int(r2.linking[0, 1])
    flip = {"left": "right", "right": "left"}
    types2 = [("_".join(t.split("_")[:-1] + [flip[t.split("_")[-1]]]) if mirror and t.split("_")[-1] in flip else t)
              for t in r2.component_types]
    if abs(l1) != abs(l2) or sorted(r1.component_types) != sorted(types2):
        return False
    j1 = {e: c for e, c in r1.jones.items() if c}
    j2 = {e: c for e, c in (_mirror(r2.jones) if mirror else r2.jones).items() if c}
    shifts = {0} if l1 == l2 else {3 * l1, -3 * l1}
    return any({e + s: c for e, c in j1.items()} == j2 for s in shifts)


@needs_patil
@pytest.mark.parametrize("name", [n for n, (_, p, _) in sorted(BENDS.items()) if p])
def test_same_topology_as_patil(name):
    """Patil's shape, loaded as in his code (rope A's and rope B's first nodes): the two ropes each
    closed on themselves form the same link, and the loaded-bend closure is the same knot (Alexander
    and Jones polynomials), or both are the mirror images where the table says so."""
    from knotsim.io.geometry import read_node_file

    _, shape, mirror = BENDS[name]
    patil = read_node_file(PATIL / f"{shape}_initial.mat")
    geo = built(name)
    assert _same_link(analyze(list(geo.ropes)), analyze(patil), mirror)
    mine = analyze_bend(geo.ropes, _standing(geo))
    theirs = analyze_bend(patil, ((0, 0), (1, 0)))
    assert mine.alexander == theirs.alexander
    assert mine.jones == (_mirror(theirs.jones) if mirror else theirs.jones)
    assert mine.bend == theirs.bend


@pytest.mark.parametrize("name", sorted(TREFOIL_ROPES))
def test_each_rope_ties_an_overhand(name):
    """Hunter's, zeppelin, Ashley's and alpine butterfly: each rope closed on itself is a trefoil, of the
    hands of Patil's shape (opposite hands in the zeppelin and the alpine butterfly)."""
    res = analyze(list(built(name).ropes))
    assert sorted(res.component_types) == sorted(TREFOIL_ROPES[name])


def test_double_fishermans_is_two_double_overhands():
    """Each rope's end coils twice round both ropes and tucks back through its coils: alone, each rope is
    the (2, 5) torus knot (every coil turn adds two crossings to the two-strand twist of the overhand,
    3_1), and each of the 2 + 2 turns goes once round the other rope: linking number 4."""
    res = analyze(list(built("double_fishermans_bend").ropes))
    assert [t[:3] for t in res.component_types] == ["5_1", "5_1"]
    assert res.component_types[0] == res.component_types[1]      # the two halves are turned copies
    assert abs(int(res.linking[0, 1])) == 4


def test_double_sheet_is_a_sheet_with_a_second_turn():
    """The second turn goes round both legs of the bight, which run in opposite directions: each rope is
    still unknotted and the ropes link as in the sheet bend; the second turn adds its two crossings with
    each leg (4) and its second tuck (1) to the sheet bend's 7 crossings."""
    double, single = analyze(list(built("double_sheet_bend").ropes)), analyze(list(built("sheet_bend").ropes))
    assert double.component_types == ["unknot", "unknot"]
    assert int(double.linking[0, 1]) == int(single.linking[0, 1]) != 0
    inter = [sum(1 for c in built(n).crossings if c.over_rope != c.under_rope) for n in ("double_sheet_bend", "sheet_bend")]
    assert inter == [10, 6] and built("double_sheet_bend").n_crossings == built("sheet_bend").n_crossings + 5


def _patil_ends(spec):
    """Patil's end numbers 1-4 on a drawing (``patil.ends``) as ``(rope index, 0 | 1)``."""
    out = []
    for item in spec.meta["patil"]["ends"]:
        rope, end = item.split(".")
        out.append((spec.rope_index(rope), {"start": 0, "end": 1}[end]))
    return out


PATIL_META = [n for n in sorted(BENDS) if "patil" in built(n).spec.meta]


def test_patil_metadata():
    """The drawings derived from Patil's shapes name his four ends (1, 2 on one rope, 3, 4 on the other)
    and his loadings; the drawing's own loading is the one of the shape it was derived from."""
    assert set(PATIL_META) == {"hunters_bend", "zeppelin_bend", "ashley_bend", "alpine_butterfly_bend"}
    for name in PATIL_META:
        geo = built(name)
        meta = geo.spec.meta["patil"]
        ends = _patil_ends(geo.spec)
        assert sorted(ends) == [(0, 0), (0, 1), (1, 0), (1, 1)]
        assert ends[0][0] == ends[1][0] != ends[2][0] == ends[3][0]
        assert meta["shape"] == BENDS[name][1] and meta["shape"][-2:] in meta["loadings"]
        i, j = (int(c) for c in meta["shape"][-2:])
        assert _standing(geo) == (ends[i - 1], ends[j - 1])


@needs_patil
@pytest.mark.parametrize("name,loading", [(n, ld) for n in PATIL_META for ld in built(n).spec.meta["patil"]["loadings"]])
def test_patil_loadings(name, loading):
    """Every loading Patil simulated, applied to the drawing at his end numbers, gives the loaded-bend
    closure of his shape for that loading (Alexander; Jones up to mirror image): one drawing, his loadings."""
    from knotsim.io.geometry import read_node_file

    geo = built(name)
    ends = _patil_ends(geo.spec)
    family = geo.spec.meta["patil"]["shape"][:-2]
    patil = read_node_file(PATIL / f"{family}{loading}_initial.mat")
    i, j = (int(c) for c in loading)
    mine = analyze_bend(geo.ropes, (ends[i - 1], ends[j - 1]))
    theirs = analyze_bend(patil, ((0, 0), (1, 0)))
    assert mine.alexander == theirs.alexander
    assert mine.jones in (theirs.jones, _mirror(theirs.jones))
