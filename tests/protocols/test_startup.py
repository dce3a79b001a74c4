"""Peaks after the start-up: every protocol takes its peak and its force drop after the start-up
transient, the quick overhand pull settles before it pulls, and force.png marks the summary's peak."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from knotsim.protocols.overhand_pull import OverhandPlan, OverhandPull
from knotsim.protocols.params import COMMON_DEFAULTS, resolve_params
from knotsim.protocols.timeline import apply_settle, measured_log, merge_settle_reactions, pull_start
from knotsim.protocols.two_rope_bend import TwoRopeBend
from knotsim.viz import plot as P


def _ringing_log(t: np.ndarray, **cols) -> pd.DataFrame:
    """A force that rings (+-0.02, decaying within 1 s) over a slow rise to 0.002 at the end."""
    f = 0.002 * t / t[-1] + 0.02 * np.exp(-4.0 * t) * np.sin(60.0 * t)
    return pd.DataFrame({"time": t, "F_norm": f, "F": f, **cols})


def test_overhand_peak_and_force_drop_skip_the_transient():
    proto = OverhandPull()
    t = np.linspace(0.005, 7.0, 1400)
    log = _ringing_log(t, e=0.7 - 0.06 * t)
    ctx = SimpleNamespace(params=resolve_params({**COMMON_DEFAULTS, **proto.defaults}), t_settle=0.0, t_pre=0.0,
                          plan=OverhandPlan(np.array([0.0, 1.0, 0.0]), 0.7, "pull_start", 0.012))
    m = proto.metrics(ctx, log)
    assert m["F_norm_peak_time"] > 2.0 and m["F_norm_peak"] == pytest.approx(0.002, rel=0.01)
    assert m["force_drop"] is None  # the ringing's fall inside the first 2 s is no loop inversion
    # with the old whole-run window the peak was the ringing
    assert float(log["F_norm"].max()) > 5 * m["F_norm_peak"]


def test_two_rope_peak_skips_the_transient():
    proto = TwoRopeBend()
    t = np.linspace(0.005, 6.0, 1200)
    log = _ringing_log(t, tail_a=0.3, tail_b=0.3, u_pull=0.01 * t)
    ctx = SimpleNamespace(params=resolve_params(proto.defaults), t_pre=0.0, t_settle=0.0, plan=None, geometry=None)
    m = proto.metrics(ctx, log)
    assert m["F_norm_peak_time"] >= 2.0 and m["F_norm_peak"] == pytest.approx(0.002, rel=0.01)
    short = proto.metrics(ctx, log[log["time"] <= 1.5])
    assert short["F_norm_peak"] is None and short["F_norm_peak_time"] is None


def test_settling_shifts_the_loading_and_holds_its_nodes():
    ctx = SimpleNamespace(t_pre=0.5, bc=[
        {"type": "clamp", "name": "held", "rod": 0, "nodes": [0, 1]},
        {"type": "hold", "name": "knot_hold", "rod": 0, "nodes": [9], "stop": 3.0},
        {"type": "move", "name": "pull", "rod": 1, "nodes": [-2, -1], "velocity": [0.01, 0, 0], "twist": False},
        {"type": "force", "name": "tug", "rod": 1, "nodes": [0, 1], "start": 0.5, "ramp": {"from": [0, 0, 0]}}])
    apply_settle(ctx, 1.0)
    b = {x["name"]: x for x in ctx.bc}
    assert "start" not in b["held"] and b["knot_hold"]["stop"] == 4.0
    assert b["pull"]["start"] == 1.0 and b["tug"]["start"] == 1.5
    assert b["settle_pull"] == {"type": "clamp", "twist": False, "name": "settle_pull", "rod": 1,
                                "nodes": [-2, -1], "stop": 1.0}
    assert b["settle_tug"]["type"] == "hold" and b["settle_tug"]["stop"] == 1.0
    assert pull_start(ctx) == 1.5
    r = merge_settle_reactions(ctx, {"pull": np.zeros(4), "settle_pull": np.ones(4), "tug": np.ones(4),
                                     "settle_tug": np.zeros(4)})
    assert r["pull"].tolist() == [1.0] * 4 and r["tug"].tolist() == [1.0] * 4
    log = pd.DataFrame({"time": [0.5, 1.5, 2.0], "F": [9.0, 1.0, 2.0]})
    assert measured_log(ctx, log)["time"].tolist() == [0.0, 0.5]


def test_readme_first_command_reports_a_peak_after_the_transient(tmp_path):
    """``knotsim pull overhand_n1 --quick`` (the README's first command): the peak is the knot's
    (after the transient, where the force rises as the knot tightens), not the start-up ringing
    (before: 0.0193 at t = 0.2 s while the knot carried 0.001-0.002), the pulled knot's force never
    swings negative, and force.png marks the summary's peak."""
    from knotsim.cli import main

    out = tmp_path / "n1"
    res = CliRunner().invoke(main, ["pull", "overhand_n1", "--quick", "-o", str(out)])
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    m, p = s["metrics"], s["parameters"]
    settle, transient = p["settle_time"], p["transient"]
    assert settle > 0 and p["ramp_time"] > 0
    log = pd.read_parquet(out / "log.parquet")
    t, f = log["time"].to_numpy(), log["F_norm"].to_numpy()
    # the peak: after the transient, the largest force of the measured pull, where the summary says
    assert m["F_norm_peak_time"] > settle + transient  # on the log's time axis
    pulled = t >= settle + transient - 1e-9
    assert m["F_norm_peak"] == pytest.approx(f[pulled].max(), rel=1e-12)
    assert m["F_norm_peak"] < 0.005  # the knot's force, not the ringing's 0.02
    # once the ends move the force does not swing negative (tolerance: 5 % of the peak)
    assert f[t >= settle - 1e-9].min() > -0.05 * m["F_norm_peak"]
    assert m["force_drop"] is None or m["force_drop"]["time"] > settle + transient
    # the figure marks the summary's peak: the same value at the same time
    assert (out / "force.png").is_file()
    k = P._peak_point(s, t, f)
    assert t[k] == pytest.approx(m["F_norm_peak_time"]) and f[k] == m["F_norm_peak"]
