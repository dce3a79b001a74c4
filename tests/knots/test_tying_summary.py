"""summary.json of a tie (knotsim.knots.tying.run.TyingResult.summary): topology and, for a reef or
granny, the half-knot gap against its limit of 10 rope diameters."""

from __future__ import annotations

import json
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

from knotsim.knots.library import get_knot  # noqa: E402
from knotsim.knots.topology import analyze  # noqa: E402
from knotsim.knots.tying import half_knot_gap, tie_from_straight  # noqa: E402
from knotsim.knots.tying.run import GAP_LIMIT_DIAMETERS, TyingResult  # noqa: E402


def _result(name, x, radius):
    topo = analyze([x])
    return TyingResult(name, topo.knot_type, ("reef",), topo.knot_type == "reef", 1.0, 2.0, 3, 0.0, None, topo, x,
                       half_knot_gap(x, radius))


def test_summary_reports_topology_and_gap():
    knot = get_knot("single_rod_reef", n_nodes=301)
    s = _result("reef", knot.ropes[0], knot.radius).summary()
    json.dumps(s)  # JSON-ready
    assert s["topology"]["rolfsen"] == "3_1#3_1*" and s["knot_type"] == "reef" and s["ok"]
    assert s["form"] == "nested" and len(s["connecting_arcs"]) == 2
    assert s["half_knot_gap_diameters"] == s["half_knot_gap"] / (2 * knot.radius)
    assert s["half_knot_gap_limit_diameters"] == GAP_LIMIT_DIAMETERS == 10.0
    # the loose library drawing has 23 diameters of rope between its half-knots: over the limit
    assert s["half_knot_gap_ok"] is (s["half_knot_gap_diameters"] <= 10.0)
    assert s["hold_node"] == knot.held[0].node


def test_overhand_tie_writes_summary_without_gap(tmp_path):
    res = tie_from_straight("overhand", tmp_path / "run", overrides={"run": {"output_interval": 0.5}})
    s = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert s["sequence"] == "overhand" and s["knot_type"] == res.knot_type and s["topology"]["rolfsen"] == "3_1"
    assert "half_knot_gap" not in s and res.half_knot is None
