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
}


@functools.cache
def built(name: str):
    return get_knot(name, n_nodes=151)


def _standing(geo):
    h, p = geo.held[0], geo.pulled[0]
    return ((h.rope, int(h.node > 0)), (p.rope, int(p.node > 0)))


def test_bends_listed():
    names = {n for n, _ in list_knots()}
    assert set(BENDS) <= names


@pytest.mark.parametrize("name", sorted(BENDS))
def test_bend_named(name):
    res = analyze_bend(built(name).ropes, _standing(built(name)))
    assert res.n_components == 1
    assert res.bend == BENDS[name][0], (name, res.knot_type)


def test_identify_bend_table():
    assert identify_bend("6_1", 0) == "thief bend" and identify_bend("3_1", -3) == "grief bend"
    assert identify_bend("6_1", 3) is None and identify_bend(None, 0) is None
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
