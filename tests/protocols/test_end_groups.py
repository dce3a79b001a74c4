"""Loaded end groups sized per rope, and held_end / pulled_end in every protocol that holds and
pulls ends (overhand-pull, single-rod-bend, two-rope-bend)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.io import savemat

from knotsim.errors import ConfigError
from knotsim.knots.library import get_knot
from knotsim.protocols import build_protocol_run, run_protocol


def _bcs(spec) -> dict:
    return {b["name"]: b for b in spec.data["bc"]}


def test_two_ropes_of_different_lengths_and_resolutions(tmp_path):
    """Rope A: the library reef bend's rope a at 125 nodes (1 m); rope B: rope b at 107 nodes with
    its first 16 cut off (91 nodes, 0.85 m). Pulling B's last node (``pulled_end = "1:-1"``) used to
    fail: the groups were sized with rope A's node count ("node 90 is not an end node of a rope with
    125 nodes")."""
    a = get_knot("reef_bend", n_nodes=125).ropes[0]
    b = get_knot("reef_bend", n_nodes=107).ropes[1][16:]
    f = tmp_path / "ab.mat"
    savemat(f, {"A": a.T, "B": b.T})
    out = tmp_path / "run"
    s = run_protocol("two-rope-bend", geometry=str(f), out_dir=out, quick=True,
                     overrides={"radius": 2e-3, "pulled_end": "1:-1", "held_end": "A:-1", "duration": 0.3})
    assert s["run_status"] == "completed", s["run_status"]
    groups = _bcs(build_protocol_run("two-rope-bend", geometry=str(f), quick=True,
                                     overrides={"radius": 2e-3, "pulled_end": "1:-1", "held_end": "A:-1"})[2])
    assert groups["pull"]["rod"] == 1 and groups["pull"]["nodes"] == [-2, -1]
    assert groups["held"]["rod"] == 0 and groups["held"]["nodes"] == [-2, -1]
    assert any("A: 125, B: 91" in n for n in s["notes"])
    log = pd.read_parquet(out / "log.parquet")
    # the pulled end (B's last two nodes) moves at the pull speed, 10 mm/s, from the start
    t = log["time"].to_numpy()
    assert log["u_pull"].iloc[-1] == pytest.approx(0.01 * t[-1], rel=1e-6)
    assert np.all(np.isfinite(log["F"])) and s["contact"]["worst_penetration_ratio"] < 0.2
    # B's tail is now its first node: its length outside the knot is about 16 nodes shorter than
    # A's (both tails of the drawing are alike), measured per rope on its own edge length
    assert 0.05 < log["tail_a"].iloc[0] - log["tail_b"].iloc[0] < 0.3


@pytest.mark.parametrize("proto,knot", [("overhand-pull", "overhand_n1"), ("single-rod-bend", "single_rod_reef")])
def test_one_rope_protocols_hold_one_end_and_pull_the_other(proto, knot):
    _, ctx0, spec0, _ = build_protocol_run(proto, knot, quick=True)
    g0 = _bcs(spec0)
    assert g0["pull_start"]["nodes"] == [0, 1] and g0["pull_end"]["nodes"] == [-2, -1] and "held" not in g0
    v = ctx0.params["pull_speed"]
    x = ctx0.geometry.ropes[0]
    axis = (x[-1] - x[0]) / np.linalg.norm(x[-1] - x[0])
    np.testing.assert_allclose(g0["pull_end"]["velocity"], v * axis)
    # held_end: that end clamped still, the other pulled at pull_speed
    _, ctx, spec, _ = build_protocol_run(proto, knot, quick=True, overrides={"held_end": "0:0"})
    g = _bcs(spec)
    assert g["held"]["type"] == "clamp" and g["held"]["nodes"] == [0, 1] and "pull_start" not in g
    np.testing.assert_allclose(g["pull_end"]["velocity"], v * axis)
    # pulled_end alone: the rope's other end is held; the pull axis points from it to the pulled end
    _, _, spec2, _ = build_protocol_run(proto, knot, quick=True, overrides={"pulled_end": "0:0"})
    g2 = _bcs(spec2)
    assert g2["held"]["nodes"] == [-2, -1] and g2["pull_end"]["nodes"] == [0, 1]
    np.testing.assert_allclose(g2["pull_end"]["velocity"], -v * axis)
    if proto == "overhand-pull":  # e shrinks at pull_speed, not twice it: the pull takes twice as long
        ramp = 0.5 * ctx0.params["ramp_time"]  # what the ramp loses at full speed
        assert ctx.params["duration"] - ramp == pytest.approx(2 * (ctx0.params["duration"] - ramp))
    for bad, field in (({"held_end": "0:0", "pulled_end": "0:0"}, "pulled_end"), ({"held_end": "0:5"}, "held_end"),
                       ({"pulled_end": "2:0"}, "pulled_end"), ({"held_end": "rod"}, "held_end")):
        with pytest.raises(ConfigError) as err:
            build_protocol_run(proto, knot, quick=True, overrides=bad)
        assert err.value.field == field


def test_single_rod_pre_pull_with_one_end_held():
    """With one end held the pulled end covers the whole pre-pull distance: twice the time."""
    ov = {"pre_pull": 0.1, "pre_pull_speed": 0.02}
    _, ctx, _, _ = build_protocol_run("single-rod-bend", "single_rod_reef", quick=True, overrides=ov)
    _, ctx1, spec1, _ = build_protocol_run("single-rod-bend", "single_rod_reef", quick=True,
                                           overrides={**ov, "held_end": "0:-1"})
    assert ctx.t_pre == pytest.approx(2.5) and ctx1.t_pre == pytest.approx(5.0)
    pull = _bcs(spec1)["pull_end"]
    assert pull["nodes"] == [0, 1]
    assert np.linalg.norm(pull["waypoints"]["points"][1]) == pytest.approx(0.1)


def test_overhand_held_end_records_both_reactions(tmp_path):
    s = run_protocol("overhand-pull", "overhand_n1", out_dir=tmp_path,
                     overrides={"n_nodes": 41, "dt": 0.01, "duration": 0.1, "held_end": "0:0"})
    assert s["run_status"] == "completed"
    log = pd.read_parquet(tmp_path / "log.parquet")
    assert {"held_fx", "pull_end_fx"} <= set(log.columns) and "pull_start_fx" not in log.columns
    assert np.all(np.isfinite(log["F_start"])) and np.any(log["F_start"] != 0.0)
    # the held end stays where it was: e shrinks at the pull speed (6 mm/s) alone
    assert log["e"].iloc[0] - log["e"].iloc[-1] == pytest.approx(0.006 * (0.1 - log["time"].iloc[0]), rel=0.02)
