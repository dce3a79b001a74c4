"""The two-rope bend's topology check: the two ropes, each closed on itself, compared by their own
knot types, their linking number and the Jones polynomial of the two-component link; ``untied``
when the ropes have come apart.

Before, the check closed the whole bend (standing ends joined, tails joined, each rope cut to its
core near the other rope): the closure moved with the loose tails, and a 0.3 s quick pull reported
hunter's, Ashley's and the double fisherman's bends as "changed knot type" and the alpine butterfly
as "untied" although no rope had passed through the other.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from knotsim.knots.library import get_knot
from knotsim.knots.topology import gauss_linking_number
from knotsim.protocols import run_protocol
from knotsim.protocols.bends import link_key, split_jones
from knotsim.protocols.metrics import knot_status
from knotsim.protocols.pipeline import _topology, topology_keys
from knotsim.protocols.rope_measures import APART_RADII, rope_gap
from knotsim.protocols.two_rope_bend import TwoRopeBend

BENDS = ["reef", "granny", "thief", "grief", "sheet", "double_sheet", "carrick", "hunters", "zeppelin", "ashley",
         "alpine_butterfly", "double_fishermans"]
#: each rope's own knot and the linking number of the ropes (measured on the drawings at N = 101;
#: the trefoil ropes of hunter's, Ashley's, the zeppelin and the alpine butterfly, the 5_1 ropes of
#: the double fisherman's are the overhand and double overhand knots tied in each rope)
EXPECTED = {"reef": ("unlink", 0), "thief": ("unlink", 0), "granny": ("unknot", -3), "grief": ("unknot", -3),
            "sheet": ("unknot", -1), "double_sheet": ("unknot", -1), "carrick": ("unknot", -1),
            "hunters": ("trefoil_left", -3), "zeppelin": ("trefoil", 0), "ashley": ("trefoil_left", 1),
            "alpine_butterfly": ("trefoil", 1), "double_fishermans": ("5_1_right", -4)}


def _ropes(name: str, n: int = 101) -> list[np.ndarray]:
    return [np.asarray(r, float) for r in get_knot(f"{name}_bend", n_nodes=n).ropes]


def _apart(ropes: list[np.ndarray], dz: float = 2.0) -> list[np.ndarray]:
    """Rope b lifted ``dz`` (m) clear of rope a: the bend taken apart."""
    return [ropes[0], ropes[1] + np.array([0.0, 0.0, dz])]


def _ctx():
    return SimpleNamespace(plan=SimpleNamespace(ends=SimpleNamespace(interleaved=False)), topology_end=None)


@pytest.mark.parametrize("name", BENDS)
def test_link_invariants_of_each_bend(name):
    """Each rope closed on itself: its own knot, the linking number (which agrees with the Gauss
    linking integral of the closed ropes) and a Jones polynomial."""
    topo = _topology(_ropes(name), None, None)
    assert topo["error"] is None and topo["n_components"] == 2
    own, lk = EXPECTED[name]
    key = link_key(topo)
    if own == "unlink":  # the ropes of a reef or thief bend, closed on themselves, are not linked
        assert key == "unlink"
        return
    assert topo["linking_number"] == lk
    assert all(t.startswith(own) for t in topo["component_types"]), topo["component_types"]
    assert topo["jones"] is not None and key != "unlink" and f"lk {lk}" in key


def test_linking_number_matches_gauss_integral():
    from knotsim.knots.topology import close_curves

    for name in ("sheet", "hunters", "double_fishermans"):
        closed = close_curves(_ropes(name))
        assert round(gauss_linking_number(closed[0], closed[1])) == _topology(_ropes(name), None, None)["linking_number"]


@pytest.mark.parametrize("name", ["granny", "sheet", "carrick", "hunters", "ashley", "alpine_butterfly",
                                  "double_fishermans"])
def test_bend_taken_apart_is_untied(name):
    """Rope b lifted clear of rope a: split link (linking number 0, Jones of the split link of the
    ropes' own knots), so ``untied``: the ropes may keep their own overhands."""
    ropes = _ropes(name)
    start, end = _topology(ropes, None, None), _topology(_apart(ropes), None, None)
    assert link_key(end) == "unlink"
    assert end["jones"] == split_jones(end["component_types"])
    proto = TwoRopeBend()
    assert knot_status(*topology_keys(proto, _ctx(), start, end)) == "untied"
    assert knot_status(*topology_keys(proto, _ctx(), start, start)) == "held"


def test_another_link_is_a_change():
    """A link the ropes cannot reach without passing through each other is ``changed knot type``:
    the mirror image of the sheet bend (every crossing flipped: linking number -1 -> +1) and the
    hunter's bend's ropes against the sheet bend's."""
    a, b = _ropes("sheet")
    flip = np.array([1.0, 1.0, -1.0])
    start, end = _topology([a, b], None, None), _topology([a * flip, b * flip], None, None)
    assert end["linking_number"] == -start["linking_number"] == 1
    proto = TwoRopeBend()
    assert knot_status(*topology_keys(proto, _ctx(), start, end)) == "changed knot type"
    hunter = _topology(_ropes("hunters"), None, None)
    assert knot_status(*topology_keys(proto, _ctx(), start, hunter)) == "changed knot type"


def test_split_from_the_start_is_untied_only_when_apart():
    """The reef bend's ropes are an unlink from the start: the verdict says ``untied`` only once
    they are apart (no nodes within 4h), and otherwise leaves the decision to the slip rule."""
    ropes = _ropes("reef")
    h = get_knot("reef_bend", n_nodes=101).radius
    proto = TwoRopeBend()
    start = _topology(ropes, None, None)
    assert link_key(start) == "unlink"
    assert rope_gap(ropes) < APART_RADII * h < rope_gap(_apart(ropes))
    tied = SimpleNamespace(topology_end=start, radius=h)
    assert proto.verdict(tied, {"ropes_apart": False, "decidable": True}) is None
    assert proto.verdict(tied, {"ropes_apart": False, "decidable": True, "slip_onset": {"time": 3.0}}) == "slipped"
    gone = SimpleNamespace(topology_end=_topology(_apart(ropes), None, None), radius=h)
    assert proto.verdict(gone, {"ropes_apart": True, "decidable": True}) == "untied"
    # the ropes of a sheet bend apart but still linked (lk -1): not untied
    sheet = _topology(_ropes("sheet"), None, None)
    assert proto.verdict(SimpleNamespace(topology_end=sheet), {"ropes_apart": True, "decidable": True}) is None
    assert knot_status(*topology_keys(proto, _ctx(), start, start), verdict="untied") == "untied"


def test_rope_gap_against_all_pairs():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(40, 3)), rng.normal(size=(30, 3)) + 0.5
    brute = min(float(np.linalg.norm(p - q)) for p in a for q in b)
    assert rope_gap([a, b]) == pytest.approx(brute, rel=1e-12)


@pytest.mark.parametrize("name", ["hunters", "ashley", "double_fishermans", "alpine_butterfly"])
def test_quick_pull_keeps_the_bend(name):
    """The regression: 0.3 s of quick pull moved the loose tails, and the old whole-bend closure
    called these bends changed (alpine: untied). The ropes did not pass through each other."""
    s = run_protocol("two-rope-bend", f"{name}_bend", quick=True, overrides={"duration": 0.3, "output_interval": 0.3})
    assert s["run_status"] == "completed"
    assert s["knot_status"] == "undecided", s["outcome"]
    start, end = s["topology"]["start"], s["topology"]["end"]
    assert start["component_types"] == end["component_types"]
    assert start["linking_number"] == end["linking_number"] and start["jones"] == end["jones"]
    assert s["metrics"]["ropes_apart"] is False


def test_ropes_apart_from_the_start_run_untied(tmp_path):
    """End to end: two hunter's-bend ropes 2 m apart (a node file, the ends given by hand) stay
    apart: each keeps its overhand (trefoil), the link is split, and the outcome is ``untied``."""
    from scipy.io import savemat

    a, b = _apart(_ropes("hunters"))
    path = tmp_path / "apart.mat"
    savemat(path, {"a": a, "b": b})
    s = run_protocol("two-rope-bend", geometry=str(path), quick=True,
                     overrides={"radius": 0.002, "held_end": "0:100", "pulled_end": "1:0", "duration": 0.1,
                                "output_interval": 0.1})
    assert s["topology"]["end"]["component_types"] == ["trefoil_left", "trefoil_left"]
    assert s["metrics"]["ropes_apart"] is True
    assert s["outcome"] == "untied"
