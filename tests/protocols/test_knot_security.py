"""The ``knot-security`` protocol: its stages as boundary conditions, its metrics on known logs, its
input checks, and a short run end to end."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

import knotsim as ks
from knotsim.errors import ConfigError
from knotsim.protocols.knot_security import KnotSecurity
from knotsim.protocols.pipeline import build_protocol_run


def _spec(**overrides):
    _, ctx, spec, _ = build_protocol_run("knot-security", "reef_bend", overrides=overrides, quick=True)
    return ctx, spec


def test_stages_are_force_groups_with_their_windows():
    ctx, spec = _spec(set_tension=0.02, hold_tension=0.002, set_ramp=0.4, set_hold=0.6, relax_time=0.2)
    bcs = {b["name"]: b for b in spec.config["bc"]} if hasattr(spec, "config") else {b["name"]: b for b in ctx.bc}
    assert bcs["held"]["type"] == "clamp"
    for end in ("pull", "tail_a", "tail_b"):
        s, r = bcs[f"set_{end}"], bcs[f"relax_{end}"]
        assert s["stop"] == pytest.approx(1.0) and r["start"] == pytest.approx(1.0) and r["stop"] == pytest.approx(1.2)
        assert np.linalg.norm(s["ramp"]["to"]) == pytest.approx(0.02)
        assert np.linalg.norm(r["ramp"]["to"]) == pytest.approx(0.002)
        np.testing.assert_allclose(r["ramp"]["from"], s["ramp"]["to"])
    load = bcs["load"]
    assert load["start"] == pytest.approx(1.2) and load["type"] == "force"
    assert np.linalg.norm(load["ramp"]["from"]) == pytest.approx(0.002)
    np.testing.assert_allclose(np.asarray(load["ramp"]["rate"]) / np.linalg.norm(load["ramp"]["rate"]),
                               ctx.plan.loaded_local[0][3])


def test_slide_and_hold_modes():
    _, spec = _spec(load="slide", pull_speed=0.02)
    ctx, _ = _spec(load="slide", pull_speed=0.02)
    load = {b["name"]: b for b in ctx.bc}["load"]
    assert load["type"] == "move" and np.linalg.norm(load["velocity"]) == pytest.approx(0.02)
    ctx, _ = _spec(load="hold", hold_load=0.004, transient=0.25)
    load = {b["name"]: b for b in ctx.bc}["load"]
    assert np.linalg.norm(load["ramp"]["to"]) == pytest.approx(0.004) and load["ramp"]["duration"] == 0.25


@pytest.mark.parametrize("key, value, field", [("load", "pulse", "load"), ("hold_tension", 0.5, "hold_tension"),
                                               ("set_tension", -1.0, "set_tension"), ("relax_time", 0.0, "relax_time"),
                                               ("set_still_rate", 0.0, "set_still_rate")])
def test_bad_inputs_name_the_field(key, value, field):
    with pytest.raises(ConfigError, match=rf"^{field}:"):
        _spec(**{key: value})


def test_one_rope_knot_is_anchored_and_loaded_at_both_ends():
    """A one-rope knot: its held hint held still, both ends set, relaxed and loaded apart."""
    _, ctx, _, _ = build_protocol_run("knot-security", "single_rod_reef", quick=True,
                                      overrides={"set_tension": 0.02, "hold_tension": 0.002, "load_rate": 0.004})
    bcs = {b["name"]: b for b in ctx.bc}
    assert bcs["knot_hold"]["type"] == "hold" and "held" not in bcs
    n = len(ctx.geometry.ropes[0])
    assert bcs["knot_hold"]["nodes"] == [ctx.geometry.held[0].node] and 2 <= bcs["knot_hold"]["nodes"][0] <= n - 3
    for end in ("start", "end"):
        assert np.linalg.norm(bcs[f"set_{end}"]["ramp"]["to"]) == pytest.approx(0.02)
        assert np.linalg.norm(bcs[f"relax_{end}"]["ramp"]["to"]) == pytest.approx(0.002)
    a, b = bcs["load_start"]["ramp"]["rate"], bcs["load"]["ramp"]["rate"]
    np.testing.assert_allclose(a, -np.asarray(b))  # apart, equal and opposite
    x = ctx.geometry.ropes[0]
    np.testing.assert_allclose(np.asarray(b) / 0.004, (x[-1] - x[0]) / np.linalg.norm(x[-1] - x[0]))
    assert list(bcs["load_start"]["nodes"]) == [0, 1] and [k % n for k in bcs["load"]["nodes"]] == [n - 2, n - 1]


def test_one_rope_knot_needs_an_anchor_and_no_bend_ends():
    with pytest.raises(ConfigError, match="^knot:.*held hint"):
        build_protocol_run("knot-security", "overhand_n1", quick=True)
    with pytest.raises(ConfigError, match="^held_end:"):
        build_protocol_run("knot-security", "single_rod_granny", quick=True, overrides={"held_end": "0:0"})


def test_self_tail_lengths_find_where_a_rope_meets_itself():
    """A rope along x that turns back on itself (centre lines 2h apart, touching) over its last part:
    the first end is outside the knot up to where the returning strand begins, the last end not at all."""
    from knotsim.protocols.rope_measures import self_tail_lengths

    h, seg = 2e-3, 1e-3
    out = np.column_stack([np.arange(0.0, 0.5 + 1e-12, seg), np.zeros(501), np.zeros(501)])
    phi = np.linspace(-np.pi / 2, np.pi / 2, 8)[1:-1]
    turn = np.column_stack([0.5 + h * np.cos(phi), h + h * np.sin(phi), np.zeros(phi.size)])
    back = np.column_stack([np.arange(0.5, 0.3 - 1e-12, -seg), np.full(201, 2 * h), np.zeros(201)])
    x = np.vstack([out, turn, back])
    first, last = self_tail_lengths(x, h, 5e-4)
    mean_seg = float(np.mean(np.linalg.norm(np.diff(x, axis=0), axis=1)))
    # the out strand enters the cut-off 2h + delta + l/2 of the returning strand's end (at x = 0.3,
    # 2h away) where (0.3 − x)² + (2h)² = cut-off²: between nodes, found by interpolation
    cutoff = 2 * h + 5e-4 + 0.5 * mean_seg
    assert first == pytest.approx(0.3 - np.sqrt(cutoff**2 - (2 * h) ** 2), abs=1e-5)
    assert last <= mean_seg
    straight = np.column_stack([np.linspace(0, 1, 101), np.zeros(101), np.zeros(101)])
    assert self_tail_lengths(straight, h, 5e-4) == pytest.approx([1.0, 0.0])


class _Ctx:
    """Enough of a RunContext for :meth:`KnotSecurity.metrics`."""

    def __init__(self, **params):
        base = dict(KnotSecurity.defaults)
        base.update(set_ramp=0.5, set_hold=0.5, relax_time=0.5)  # the set ends at 1 s, the load begins at 1.5 s
        base.update(params)
        self.params = type("P", (dict,), {"contact": {}})(base)
        self.t_pre, self.t_settle = 1.5, 0.0
        self.plan = self.phase_record = self.topology_end = None
        self.radius = 2e-3
        self.EI = 2.26e-6
        self.geometry = None


def _log(t_slip=None, rate=0.002, hold=0.001, mode="ramp", hold_load=0.005, drift=0.0, tails_follow=1.0,
         tails_in=0.0, one_rope=False, capsize_at=None):
    """A knot-security log: the loaded end out at ``drift`` m/s from the load's start (``t_slip``: then
    running away); the two tails drawn in by ``tails_follow`` times the loaded end's displacement (rope
    passing through the knot) plus ``tails_in`` m/s (the knot drawing up); ``one_rope``: no tails."""
    t = np.arange(0.0, 12.0, 0.01)
    t_load = t - 1.5
    if mode == "ramp":
        f = np.where(t_load >= 0, hold + rate * np.maximum(t_load, 0), np.nan)
    else:
        f = np.where(t_load >= 0, hold + (hold_load - hold) * np.clip(t_load / 1.0, 0, 1), np.nan)
    u = drift * np.maximum(t_load, 0)
    if t_slip is not None:
        u = u + np.where(t_load > t_slip, 0.2 * (t_load - t_slip), 0.0)
    in_knot = 0.3 - 0.05 * np.minimum(t, 1.0) + 0.0 * t
    tail = 0.3 - (tails_follow * u + tails_in * np.maximum(t_load, 0)) / 2
    if one_rope:
        tail = np.full(t.size, np.nan)
    # each rope turns 1.5 pi in the set knot; ``capsize_at`` s into the load rope A is pulled straight
    turn_a = np.where(t_load > capsize_at, 0.05 * np.pi, 1.5 * np.pi) if capsize_at is not None else np.full(
        t.size, 1.5 * np.pi)
    turn_b = np.full(t.size, 1.5 * np.pi)
    if one_rope:
        turn_a = turn_b = np.full(t.size, np.nan)
    return pd.DataFrame({"time": t, "F": f, "F_norm": f * 4e-6 / 2.26e-6, "u_pull": u, "tail_a": tail,
                         "tail_b": tail, "rope_gap": np.full(t.size, 4e-3 if not one_rope else np.nan),
                         "in_knot": in_knot, "turn_a": turn_a, "turn_b": turn_b})


def test_ramp_metrics_find_the_slip_load():
    m = KnotSecurity().metrics(_Ctx(), _log(t_slip=4.0))
    onset = m["slip_onset"]["time"]
    assert abs(onset - 4.0) <= 0.25  # the centred 0.5 s average of the displacement smears the corner
    assert m["slip_load"] == pytest.approx(0.001 + 0.002 * onset)
    assert m["slip_load_norm"] == pytest.approx(m["slip_load"] * 4e-6 / 2.26e-6)
    assert m["in_knot_set"] == pytest.approx(0.25, abs=1e-3)
    assert m["set_creep"] == pytest.approx(-0.05, rel=1e-6)  # still drawing in over the end of the set hold
    assert m["slip_during_transient"] is False
    assert m["slow_slip_onset"]["time"] <= onset and m["slow_slip_load"] <= m["slip_load"]
    # detection from 1 s into the load (the rule of the studies before 0.2): a run-away under way by
    # then is flagged, its load a bound
    early = KnotSecurity().metrics(_Ctx(detect_after=1.0), _log(t_slip=0.2))
    assert early["slip_during_transient"] is True and early["slip_onset"]["time"] == pytest.approx(1.0, abs=0.01)
    assert early["slow_slip_during_transient"] is True and m["slow_slip_during_transient"] is False
    held = KnotSecurity().metrics(_Ctx(), _log())
    assert held["slip_onset"] is None and held["slip_load"] is None
    assert held["largest_load_held"] == pytest.approx(0.001 + 0.002 * 10.49, rel=1e-3)


def test_slow_slip_is_rope_through_the_knot_from_the_first_instant():
    """One slip rule: a slow slip is rope passing through the knot (the loaded end out and the tails
    drawn in, the lesser of the two speeds); the loaded end let out while the tails stay (the standing
    part stretching, the knot changing shape) is none. Detection starts with the load, so a knot that
    slips at once is resolved down to the hold tension (no floor at 1 s into the ramp)."""
    from_start = _log(drift=4e-3)  # rope through at 4 mm/s from the load's first instant
    m = KnotSecurity().metrics(_Ctx(), from_start)
    assert m["slow_slip_onset"]["criterion"] == "through"
    assert m["slow_slip_onset"]["time"] < 0.3 and m["slow_slip_load"] < 0.0016  # the hold tension is 1 mN
    assert m["slow_slip_during_transient"] is False
    old = KnotSecurity().metrics(_Ctx(detect_after=1.0, slip_rule="loaded_end"), from_start)
    assert old["slow_slip_load"] == pytest.approx(0.003, abs=1e-4) and old["slow_slip_during_transient"] is True
    stretch = KnotSecurity().metrics(_Ctx(), _log(drift=4e-3, tails_follow=0.0))  # the end out, the tails still
    assert stretch["slow_slip_onset"] is None
    assert KnotSecurity().metrics(_Ctx(slip_rule="loaded_end"), _log(drift=4e-3, tails_follow=0.0))[
        "slow_slip_onset"] is not None
    drawn_up = KnotSecurity().metrics(_Ctx(), _log(drift=0.0, tails_in=4e-3))  # the tails in, the end still
    assert drawn_up["slow_slip_onset"] is None
    one = KnotSecurity().metrics(_Ctx(), _log(drift=4e-3, one_rope=True))  # no tails: the loaded ends decide
    assert one["slow_slip_onset"] is not None
    with pytest.raises(ConfigError, match="^slip_rule:"):
        _spec(slip_rule="tails")


def test_a_knot_still_moving_at_the_end_of_its_set_is_flagged():
    """The rope in the knot still changing faster than set_still_rate when the set ended: the knot
    was loaded before it was set; the metrics say so and the warning names it, by how much, and what
    to change."""
    moving = KnotSecurity().metrics(_Ctx(), _log(t_slip=4.0))  # the log's set creeps at -0.05 m/s
    assert moving["set_still"] is False
    ((flag, text),) = KnotSecurity().warnings(_Ctx(), moving)
    assert flag == "loaded before it was set"
    assert text.startswith("NOT SET") and "-50 mm/s" in text and "set_hold_max" in text
    ((_, fixed),) = KnotSecurity().warnings(_Ctx(set_until_still=False), moving)
    assert "set set_until_still = true" in fixed
    still = KnotSecurity().metrics(_Ctx(set_still_rate=0.06), _log(t_slip=4.0))
    assert still["set_still"] is True and KnotSecurity().warnings(_Ctx(), still) == []
    assert KnotSecurity().warnings(_Ctx(), {"set_still": None}) == []  # not measured: no claim


def test_the_default_sets_until_still_and_stops_at_the_decision():
    """Valid by default: the protocol's defaults hold the set until the knot is still and end the run
    stop_margin s after its decision."""
    assert KnotSecurity.defaults["set_until_still"] is True
    assert KnotSecurity.defaults["stop_at_decision"] is True and KnotSecurity.defaults["stop_margin"] == 1.0


def test_decision_is_the_earliest_of_run_away_apart_capsize_and_spill():
    """The run-away (decided once it has lasted 0.5 s), the ropes apart, a capsize outside a ramp (after
    0.25 s) and a spill, on the run's clock (the load begins at 1.5 s in these logs)."""
    ks_ = KnotSecurity()
    d = ks_.decision(_Ctx(), _log(t_slip=4.0))
    m = ks_.metrics(_Ctx(), _log(t_slip=4.0))
    assert d.outcome == "slipped" and d.time == pytest.approx(1.5 + m["slip_onset"]["time"] + 0.5)
    assert f"{1e3 * m['slip_load']:.3g} mN" in d.reason
    assert ks_.decision(_Ctx(), _log()) is None  # held: the ramp goes on
    # a log that ends before the run-away has lasted 0.5 s: not decided yet
    short = _log(t_slip=4.0)
    assert ks_.decision(_Ctx(), short[short.time <= 1.5 + 4.0 + 0.3]) is None
    apart = _log(t_slip=4.0).assign(rope_gap=lambda x: np.where(x.time > 3.0, 0.05, 4e-3))
    da = ks_.decision(_Ctx(), apart)
    assert da.outcome == "apart" and da.time == pytest.approx(3.01, abs=0.011)
    # a capsize decides a hold, not a ramp (the ramp measures the run-away load)
    assert ks_.decision(_Ctx(), _log(capsize_at=3.0)) is None
    dc = ks_.decision(_Ctx(load="hold"), _log(mode="hold", capsize_at=3.0))
    assert dc.outcome == "capsized" and dc.time == pytest.approx(1.5 + 3.0 + 0.25, abs=0.02)
    assert ks_.decision(_Ctx(), _log(one_rope=True)) is None


def test_set_until_still_holds_the_set_until_the_knot_stops_moving(tmp_path):
    """set_until_still: one run, built with the longest set, finds when the rope in the knot stops
    changing and goes on as if built with that set (no preliminary run): its own measure of the set
    agrees that the knot had stopped, its stages and run.toml give the set found, and run.toml
    replays it to the same state, bit for bit."""
    from knotsim.io.checkpoint import read_checkpoint

    ov = {"set_hold": 0.2, "set_hold_max": 10.0, "load_time": 0.4, "transient": 0.1}
    res = ks.run_protocol("knot-security", "reef_bend", quick=True, out_dir=tmp_path / "run",
                          overrides={**ov, "set_until_still": True})
    m, found = res["metrics"], res["metrics"]["set_until_still"]
    assert found["still"] and 0.2 <= found["set_hold"] < 10.0 and abs(found["rate"]) <= 5e-4
    assert res["parameters"]["set_hold"] == found["set_hold"] == m["set_hold"]
    assert m["set_still"] is True and m["set_creep"] == found["rate"]  # the run's own window: the same samples
    stages = {st["name"]: (st["start"], st["end"]) for st in res["timeline"]["stages"]}
    assert stages["set"][1] == 0.3 + found["set_hold"]  # quick set_ramp 0.3: exactly, the step it was found at
    assert res.log["time"].iloc[-1] == pytest.approx(0.3 + found["set_hold"] + 0.2 + 0.4)
    assert res["timeline"]["stopped"] is None and res["valid"] is True
    spec = ks.RunSpec.load(tmp_path / "run" / "run.toml")
    assert {b["name"]: b for b in spec.data["bc"]}["set_pull"]["stop"] == stages["set"][1]
    replay = ks.run(spec)
    np.testing.assert_array_equal(replay.state.q, read_checkpoint(tmp_path / "run" / "checkpoint.npz").state(None).q)
    # a cap too short to reach stillness: the set lasts set_hold_max and the warnings say why
    capped = ks.run_protocol("knot-security", "reef_bend", quick=True,
                             overrides={**ov, "set_until_still": True, "set_hold_max": 0.25})
    rec = capped["metrics"]["set_until_still"]
    assert not rec["still"] and rec["set_hold"] == 0.25 and capped["parameters"]["set_hold"] == 0.25
    assert any("still moving after set_hold_max" in n for n in capped["notes"])
    assert capped["valid"] is False and capped["outcome"].endswith("; loaded before it was set")
    with pytest.raises(ConfigError, match="^set_hold_max:"):
        ks.run_protocol("knot-security", "reef_bend", quick=True,
                        overrides={**ov, "set_until_still": True, "set_hold": 2.0, "set_hold_max": 1.0})


def test_turning_in_knot():
    """A rope's turning between its entry points: 0 straight, pi round a half circle, and only the
    part inside the knot counts."""
    from knotsim.protocols.rope_measures import turning_in_knot

    straight = np.column_stack([np.linspace(0, 1, 101), np.zeros(101), np.zeros(101)])
    assert turning_in_knot(straight, 0.2, 0.2) == pytest.approx(0.0, abs=1e-12)
    phi = np.linspace(-0.5 * np.pi, 0.5 * np.pi, 181)
    arc = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(phi.size)]) * 0.01
    x = np.vstack([np.column_stack([np.linspace(-0.3, 0, 31)[:-1], np.full(30, -0.01), np.zeros(30)]), arc,
                   np.column_stack([np.linspace(0, -0.3, 31)[1:], np.full(30, 0.01), np.zeros(30)])])
    assert turning_in_knot(x, 0.25, 0.25) == pytest.approx(np.pi, rel=1e-3)  # the whole U-turn inside
    assert turning_in_knot(x, 0.30 + 0.5 * np.pi * 0.01, 0.25) == pytest.approx(0.5 * np.pi, rel=0.02)  # half of it


def test_a_rope_pulled_straight_through_the_knot_is_a_capsize():
    """One rope straight through the knot while the other still goes round it, for 0.25 s: the knot
    capsized (named so even if it then slips or comes apart); a set knot, or a one-rope knot, did not."""
    m = KnotSecurity().metrics(_Ctx(), _log(capsize_at=3.0))
    assert m["capsize_onset"]["time"] == pytest.approx(3.0, abs=0.02) and m["capsize_onset"]["rope"] == "a"
    assert m["capsize_onset"]["force"] == pytest.approx(0.001 + 0.002 * 3.0, abs=1e-4)
    assert m["turn_load"] == pytest.approx([1.5 * np.pi, 1.5 * np.pi])
    assert KnotSecurity().verdict(_Ctx(), m) == "capsized"
    held = KnotSecurity().metrics(_Ctx(), _log())
    assert held["capsize_onset"] is None and KnotSecurity().verdict(_Ctx(), held) != "capsized"
    brief = KnotSecurity().metrics(_Ctx(), _log(capsize_at=3.0).assign(
        turn_a=lambda d: np.where((d.time > 4.5) & (d.time < 4.6), 0.05 * np.pi, 1.5 * np.pi)))
    assert brief["capsize_onset"] is None  # straight for 0.1 s only
    one = KnotSecurity().metrics(_Ctx(), _log(one_rope=True))
    assert one["capsize_onset"] is None and one["turn_load"] is None


def test_hold_that_drifts_has_slipped():
    m = KnotSecurity().metrics(_Ctx(load="hold"), _log(mode="hold", drift=4e-3))  # 19 mm over the late half
    assert m["slip_onset"]["criterion"] == "drift" and KnotSecurity().slipped(None, m)
    assert m["drift_through_late"] == pytest.approx(4e-3 * (10.49 - 1.0) / 2, rel=0.01)
    # rope through the knot is the lesser of the two motions: tails drawn in by half the end's drift
    half = KnotSecurity().metrics(_Ctx(load="hold"), _log(mode="hold", drift=4e-3, tails_follow=0.5))
    assert half["drift_through_late"] == pytest.approx(0.5 * m["drift_through_late"], rel=1e-6)
    assert half["slip_onset"]["criterion"] == "drift"


@pytest.mark.parametrize("case", ["end_out_tails_still", "tails_in_end_still", "tails_in_end_in"])
def test_hold_slips_only_when_rope_passes_through(case):
    """A slip lets rope through the knot: the loaded end out and the tails in. Either alone is the
    knot changing shape or drawing up (a set reef bend relaxed to 1 mN draws its tails in by 115 mm
    over a hold it survives), and a loaded end drawn in against the load is the knot settling."""
    kw = {"end_out_tails_still": {"drift": 4e-3, "tails_follow": 0.0},
          "tails_in_end_still": {"drift": 0.0, "tails_in": 4e-3},
          "tails_in_end_in": {"drift": -1e-3, "tails_follow": 0.0, "tails_in": 4e-3}}[case]
    m = KnotSecurity().metrics(_Ctx(load="hold"), _log(mode="hold", **kw))
    assert max(m["drift_pull_late"], m["drift_tails_late"]) > 0.01  # one of the two moved 19 mm
    assert m["drift_through_late"] <= 1e-9
    assert m["slip_onset"] is None and not KnotSecurity().slipped(None, m)


def test_one_rope_hold_is_decided_by_its_loaded_ends():
    """A one-rope knot has no free tails: its loaded ends' outward drift decides."""
    out = KnotSecurity().metrics(_Ctx(load="hold"), _log(mode="hold", drift=4e-3, one_rope=True))
    assert out["drift_tails_late"] is None and out["drift_through_late"] == out["drift_pull_late"] > 0.01
    assert out["slip_onset"]["criterion"] == "drift"
    still = KnotSecurity().metrics(_Ctx(load="hold"), _log(mode="hold", drift=1e-5, one_rope=True))
    assert still["slip_onset"] is None and still["drift_through_late"] == pytest.approx(4.7e-5, rel=0.02)


def test_hold_drawn_in_is_settling_not_slipping():
    """The loaded end drawn in against the load (a knot still settling after its set) is no slip."""
    m = KnotSecurity().metrics(_Ctx(load="hold"), _log(mode="hold", drift=-4e-3))
    assert m["drift_pull_late"] < -0.01 and m["slip_onset"] is None and not KnotSecurity().slipped(None, m)


def test_hold_metrics_measure_the_drift():
    m = KnotSecurity().metrics(_Ctx(load="hold"), _log(mode="hold", drift=1e-5))
    assert m["slip_onset"] is None
    assert m["drift_pull_rate"] == pytest.approx(1e-5, rel=1e-6)
    assert m["drift_tails_rate"] == pytest.approx(1e-5, rel=1e-6)
    assert m["hold_window"] == pytest.approx(10.49 - 1.0, abs=0.02)
    assert m["drift_pull_late_rate"] == pytest.approx(1e-5, rel=1e-6)
    assert m["drift_pull_late"] == pytest.approx(1e-5 * (10.49 - 1.0) / 2, rel=0.01)
    assert m["drift_tails_late_rate"] == pytest.approx(1e-5, rel=1e-6)
    assert m["drift_tails_late"] == pytest.approx(1e-5 * (10.49 - 1.0) / 2, rel=0.01)


@pytest.mark.parametrize("knot", ["reef_bend", "single_rod_reef"])
def test_short_run_end_to_end(knot):
    """A short quick run: it sets, relaxes and loads the reef bend (or the one-rope reef of the seed
    study) and reports the metrics. Its set of 0.2 s leaves the knot moving: the summary says so
    first, the outcome carries it, and the run is not valid."""
    res = ks.run_protocol("knot-security", knot, quick=True,
                          overrides={"set_ramp": 0.2, "set_hold": 0.2, "relax_time": 0.1, "load_time": 0.6,
                                     "transient": 0.1, "set_until_still": False})
    m = res["metrics"]
    assert res["knot_status"] in ("held", "slipped", "untied", "undecided")
    assert m["set_still"] is False and res["valid"] is False
    assert res["outcome"] == f"{res['knot_status']}; loaded before it was set"
    assert res["warnings"][0].startswith("NOT SET: the knot was still moving")
    assert m["set_tension"] == 0.01 and math.isfinite(m["in_knot_set"]) and 0 < m["in_knot_set"] < 1.0
    assert ("slip_load" in m) and m["largest_load_held"] >= 0.001
    log = res.log
    assert {"F", "u_pull", "in_knot", "tail_a"} <= set(log.columns)
    assert np.isnan(log["F"].iloc[0]) and np.isfinite(log["F"].iloc[-1]) and np.isfinite(log["u_pull"]).all()
    assert np.isnan(log["tail_a"]).all() == (knot == "single_rod_reef")  # one rope: no free tails
    assert ("ropes_apart" in m) == (knot == "reef_bend")


def test_a_run_ends_at_its_decision_with_its_events_on_the_log_time_axis(tmp_path):
    """The reef bend under a fast ramp runs away: the run stops stop_margin s after the decision (not
    at load_time), says when and why, and every event time in the summary is a time of its log; the
    run file replays to the same final state."""
    from knotsim.runspec import RunSpec, run

    res = ks.run_protocol("knot-security", "reef_bend", quick=True, out_dir=tmp_path / "run",
                          overrides={"set_ramp": 0.2, "set_hold": 0.2, "relax_time": 0.1, "load_time": 6.0,
                                     "transient": 0.1, "load_rate": 0.05, "set_until_still": False,
                                     "stop_margin": 0.3})
    line, m, log = res["timeline"], res["metrics"], res.log
    t = log["time"].to_numpy()
    dec, stop = line["decision"], line["stopped"]
    assert dec["outcome"] == "slipped" and "ran away" in dec["reason"]
    assert stop["time"] == pytest.approx(t[-1]) and stop["time"] - dec["time"] == pytest.approx(0.3, abs=0.06)
    assert t[-1] < 0.2 + 0.2 + 0.1 + 6.0 - 1.0  # well before the load stage's end
    assert "stop_margin = 0.3 s" in stop["reason"]
    stages = {st["name"]: (st["start"], st["end"]) for st in line["stages"]}
    assert list(stages) == ["set", "relax", "load"] and stages["load"][1] == pytest.approx(t[-1])
    assert stages["set"][1] == pytest.approx(0.4) and stages["load"][0] == pytest.approx(0.5)
    onset = m["slip_onset"]
    assert onset["time"] == pytest.approx(onset["load_stage_time"] + stages["load"][0])
    assert np.min(np.abs(t - onset["time"])) < 1e-9  # a time of the log
    assert float(log["F"].to_numpy()[np.argmin(np.abs(t - onset["time"]))]) == pytest.approx(onset["force"])
    assert dec["time"] == pytest.approx(onset["time"] + 0.5)
    names = [e["name"] for e in line["events"]]
    assert names[0] == "set_end" and {"slip_onset", "decision", "stop"} <= set(names)
    assert [e["time"] for e in line["events"]] == sorted(e["time"] for e in line["events"])
    replay = run(RunSpec.load(tmp_path / "run" / "run.toml"))
    np.testing.assert_array_equal(replay.state.q, res_state_q(tmp_path / "run"))
    # without stop_at_decision the run goes to its end
    full = ks.run_protocol("knot-security", "reef_bend", quick=True,
                           overrides={"set_ramp": 0.2, "set_hold": 0.2, "relax_time": 0.1, "load_time": 1.6,
                                      "transient": 0.1, "load_rate": 0.05, "set_until_still": False,
                                      "stop_at_decision": False})
    assert full.log["time"].iloc[-1] == pytest.approx(0.5 + 1.6) and full["timeline"]["stopped"] is None


def res_state_q(run_dir):
    from knotsim.io.checkpoint import read_checkpoint

    return read_checkpoint(run_dir / "checkpoint.npz").state(None).q


def test_none_text_unsets_a_contact_setting():
    """A study (TOML) writes "none" to unset the protocol's stick distance: the smooth law."""
    from knotsim.runspec import build_run, check_run

    for value, stick in (("none", False), ("None", False), (2e-5, True)):
        _, _, spec, _ = build_protocol_run("knot-security", "reef_bend", overrides={"contact.stick_distance": value},
                                           quick=True)
        sim, _ = build_run(check_run(spec))
        contact = next(i for i in sim.stepper.interactions if i.name == "contact")
        assert (contact.stick is not None) is stick


def test_pulses_are_rise_and_fall_groups():
    ctx, _ = _spec(load="pulses", pulse_load=0.006, pulse_period=0.8, n_pulses=3, hold_tension=0.001,
                   set_ramp=0.4, set_hold=0.6, relax_time=0.2, load_time=0.0)  # 0: the pulses and 2 s
    bcs = {b["name"]: b for b in ctx.bc}
    for i in range(3):
        up, down = bcs[f"load_up_{i}"], bcs[f"load_down_{i}"]
        assert up["start"] == pytest.approx(1.2 + 0.8 * i) and up["stop"] == pytest.approx(1.6 + 0.8 * i)
        assert down["start"] == pytest.approx(1.6 + 0.8 * i) and down["stop"] == pytest.approx(2.0 + 0.8 * i)
        assert np.linalg.norm(up["ramp"]["to"]) == pytest.approx(0.006)
        np.testing.assert_allclose(down["ramp"]["from"], up["ramp"]["to"])
    assert bcs["load"]["start"] == pytest.approx(1.2 + 2.4) and np.linalg.norm(bcs["load"]["force"]) == 0.001
    assert KnotSecurity().duration(ctx) == pytest.approx(1.2 + 2.4 + 2.0)
    with pytest.raises(ConfigError, match="^n_pulses:"):
        _spec(load="pulses", n_pulses=2.5)


def test_pulse_metrics_count_cycles_to_spill():
    t = np.arange(0.0, 6.0, 0.01)
    u = np.where(t > 2.5, 0.004 * (t - 2.5) ** 2, 0.0)  # creeps from the third pulse on, faster and faster
    log = pd.DataFrame({"time": t + 1.5, "F": np.ones(t.size), "F_norm": np.ones(t.size), "u_pull": u,
                        "tail_a": 0.3 - u / 2, "tail_b": 0.3 - u / 2,  # rope through the knot: the tails drawn in
                        "rope_gap": np.full(t.size, 4e-3), "in_knot": np.full(t.size, 0.2)})
    m = KnotSecurity().metrics(_Ctx(load="pulses", pulse_period=1.0, n_pulses=5, spill_distance=0.01), log)
    drift = np.interp([1, 2, 3, 4, 5], t, u)
    np.testing.assert_allclose(m["pulse_drift"], drift)
    assert m["cycles_to_spill"] == 5  # 0.009 m after the 4th, 0.025 m after the 5th
    assert m["slip_onset"]["criterion"] == "spill" and KnotSecurity().slipped(None, m)
    held = KnotSecurity().metrics(_Ctx(load="pulses", pulse_period=1.0, n_pulses=5, spill_distance=0.1), log)
    assert held["cycles_to_spill"] is None and held["decidable"] and not KnotSecurity().slipped(None, held)
    drawn_in = KnotSecurity().metrics(_Ctx(load="pulses", pulse_period=1.0, n_pulses=5, spill_distance=0.01),
                                      log.assign(u_pull=-u))  # the knot settling: the end drawn in
    assert drawn_in["cycles_to_spill"] is None and not KnotSecurity().slipped(None, drawn_in)
    # the loaded end paid out while the tails stay is the knot changing shape, not rope through it
    reshaped = log.assign(tail_a=0.3, tail_b=0.3)
    ctx = {"load": "pulses", "pulse_period": 1.0, "n_pulses": 5, "spill_distance": 0.01}
    assert KnotSecurity().metrics(_Ctx(**ctx), reshaped)["cycles_to_spill"] is None
    assert KnotSecurity().metrics(_Ctx(**ctx, slip_rule="loaded_end"), reshaped)["cycles_to_spill"] == 5


def test_tail_length_follows_a_rope_sliding_through_continuously():
    """Rope A (along x) lies across rope B (along y, a node right under A) with their centre lines 2h
    apart. Sliding A along its axis by s shortens its tail from the first end by exactly s: the entry
    point into B's cut-off is fixed in space at 0.3 − sqrt(cut-off² − (2h)²). The measure follows s
    between nodes (a tail counted in whole edges would move in steps of l = 5 mm)."""
    from knotsim.protocols.rope_measures import tail_lengths

    h, delta, seg = 1.6e-3, 5e-4, 5e-3
    ya = np.arange(-0.1, 0.1 + 1e-12, seg)
    rope_b = np.column_stack([np.full(ya.size, 0.3), ya, np.zeros(ya.size)])
    cutoff = 2 * h + delta + 0.5 * seg
    entry = 0.3 - np.sqrt(cutoff**2 - (2 * h) ** 2)
    lengths = []
    shifts = np.linspace(0.0, 3 * seg, 31)
    for s in shifts:
        xa = np.arange(0.0, 0.6 + 1e-12, seg) + s
        rope_a = np.column_stack([xa, np.zeros(xa.size), np.full(xa.size, 2 * h)])
        first, last = tail_lengths([rope_a, rope_b], [(0, 0), (0, 1)], h, delta)
        lengths.append(first)
        assert last == pytest.approx(0.6 + s - 0.3 - np.sqrt(cutoff**2 - (2 * h) ** 2), abs=0.1 * seg)
    lengths = np.array(lengths)
    # linear interpolation of the convex distance profile d(u) = sqrt(u² + (2h)²) between nodes l
    # apart places the entry off by its chord's gap over the slope there, under a fifth of an edge
    # here; a tenth of an edge is asked (a tail counted in whole edges is off by up to one)
    assert np.abs(lengths - (entry - shifts)).max() <= 0.1 * seg
    # no steps: between shifts a tenth of an edge apart it changes by the shift within half of it
    assert np.abs(np.diff(lengths) + np.diff(shifts)).max() <= 0.5 * np.diff(shifts).max()


def test_jerks_go_from_slack_to_the_peak_and_back():
    """load = "jerks": each jerk rises from slack (0 N) to jerk_load in jerk_rise s and falls back as
    fast, one every jerk_period s, slack between; cycles to spill by the one slip rule."""
    from knotsim.protocols.security_params import SecurityParams, load_profile

    ctx, _ = _spec(load="jerks", jerk_load=0.006, jerk_rise=0.04, jerk_period=0.5, n_jerks=3,
                   set_ramp=0.4, set_hold=0.6, relax_time=0.2, load_time=0.0)
    bcs = {b["name"]: b for b in ctx.bc}
    for i in range(3):
        up, down = bcs[f"load_up_{i}"], bcs[f"load_down_{i}"]
        assert up["start"] == pytest.approx(1.2 + 0.5 * i) and up["stop"] == pytest.approx(1.24 + 0.5 * i)
        assert down["start"] == pytest.approx(1.24 + 0.5 * i) and down["stop"] == pytest.approx(1.28 + 0.5 * i)
        assert np.linalg.norm(up["ramp"]["from"]) == 0.0 and np.linalg.norm(up["ramp"]["to"]) == pytest.approx(0.006)
        assert np.linalg.norm(down["ramp"]["to"]) == 0.0
    assert "load" not in bcs  # slack after the last jerk
    assert KnotSecurity().duration(ctx) == pytest.approx(1.2 + 1.5 + 2.0)
    sp = SecurityParams.from_params(ctx.params)
    assert [load_profile(sp, t) for t in (0.0, 0.02, 0.04, 0.06, 0.08, 0.3, 0.54, 1.6)] == pytest.approx(
        [0.0, 0.003, 0.006, 0.003, 0.0, 0.0, 0.006, 0.0])
    with pytest.raises(ConfigError, match="^jerk_rise:"):
        _spec(load="jerks", jerk_rise=0.3, jerk_period=0.5)
    # spill: rope through the knot after the second jerk (the loaded end out and the tails in by 12 mm)
    t = np.arange(0.0, 5.0, 0.01)
    u = np.where(t > 0.7, 0.012, 0.0)
    log = pd.DataFrame({"time": t + 1.5, "F": np.zeros(t.size), "F_norm": np.zeros(t.size), "u_pull": u,
                        "tail_a": 0.3 - u / 2, "tail_b": 0.3 - u / 2, "rope_gap": np.full(t.size, 4e-3),
                        "in_knot": np.full(t.size, 0.2)})
    m = KnotSecurity().metrics(_Ctx(load="jerks", jerk_period=0.5, n_jerks=3), log)
    assert m["cycles_to_spill"] == 2 and m["slip_onset"]["criterion"] == "spill"
    d = KnotSecurity().decision(_Ctx(load="jerks", jerk_period=0.5, n_jerks=3), log)
    assert d.outcome == "spilled" and d.time == pytest.approx(1.5 + 1.0)


def test_a_short_jerk_run():
    """The reef bend under two jerks (quick): the applied force peaks at jerk_load and is slack
    between; the metrics count the jerks done."""
    res = ks.run_protocol("knot-security", "reef_bend", quick=True,
                          overrides={"set_ramp": 0.2, "set_hold": 0.2, "relax_time": 0.1, "set_until_still": False,
                                     "load": "jerks", "jerk_load": 0.004, "jerk_rise": 0.03, "jerk_period": 0.4,
                                     "n_jerks": 2, "load_time": 1.0})
    log, m = res.log, res["metrics"]
    f = log["F"].to_numpy()
    assert np.nanmax(f) == pytest.approx(0.004, rel=0.2) and np.nanmin(f) == 0.0
    assert m["pulses_done"] == 2 and len(m["pulse_drift"]) == 2
