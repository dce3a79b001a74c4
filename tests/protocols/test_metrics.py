"""Strength metrics on synthetic logs."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from knotsim.errors import ConfigError
from knotsim.protocols import metrics as M


def _log(t, f, **cols):
    return pd.DataFrame({"time": t, "F_norm": f, **cols})


def test_window_mean_and_peak():
    t = np.linspace(0.0, 10.0, 1001)
    log = _log(t, t.copy())
    assert M.window_mean(log, "F_norm", 0.0, 10.0) == pytest.approx(5.0)
    assert M.window_mean(log, "F_norm", 2.0, 4.0) == pytest.approx(3.0)
    assert M.window_peak(log, "F_norm", 0.0, 5.0) == pytest.approx(5.0)
    assert math.isnan(M.window_mean(log, "F_norm", 20.0, 30.0))
    # non-uniform steps: the mean is time-weighted
    t2 = np.array([0.0, 0.1, 10.0])
    assert M.window_mean(_log(t2, np.array([0.0, 0.0, 1.0]))) == pytest.approx(0.5 * 9.9 / 10.0)


def test_force_at_interpolates_first_crossing():
    t = np.linspace(0, 1, 11)
    e = 0.7 - 0.5 * t  # decreasing, like the overhand shortening
    log = _log(t, 2.0 * t, e=e)
    assert M.force_at(log, "e", 0.45) == pytest.approx(1.0)
    assert math.isnan(M.force_at(log, "e", 0.1))


def test_slip_onset_drop():
    t = np.linspace(0, 10, 1001)
    f = np.where(t < 6.0, t, 0.3 * t)  # rises to 6, drops to 1.8 at t = 6
    res = M.slip_onset(_log(t, f), drop_fraction=0.2)
    assert res is not None
    assert res["time"] == pytest.approx(6.0, abs=0.011)
    assert res["force"] == pytest.approx(6.0, abs=0.02)
    assert res["detected_at"] >= res["time"]
    # monotone force: no slip
    assert M.slip_onset(_log(t, t)) is None
    # a small wiggle below the threshold is not a slip
    assert M.slip_onset(_log(t, t + 0.05 * np.sin(20 * t)), drop_fraction=0.2, min_force=0.5) is None
    # noise is smoothed away
    rng = np.random.default_rng(0)
    noisy = t + 0.5 * rng.standard_normal(t.size)
    assert M.slip_onset(_log(t, noisy), drop_fraction=0.2, min_force=2.0, smooth=0.5) is None


def test_slip_onset_plateau():
    t = np.linspace(0, 10, 1001)
    f = np.minimum(t, 4.0)  # stops increasing at t = 4
    res = M.slip_onset(_log(t, f), mode="plateau", drop_fraction=0.01, plateau_time=1.0)
    assert res["time"] == pytest.approx(4.0, abs=0.011)
    assert res["detected_at"] == pytest.approx(5.0, abs=0.05)
    with pytest.raises(ConfigError, match="mode"):
        M.slip_onset(_log(t, f), mode="bogus")


def test_tail_draw_in_and_status():
    log = pd.DataFrame({"time": [0, 1, 2], "tail": [0.30, 0.25, 0.21], "u": [0.0, 0.01, 0.05]})
    assert M.tail_draw_in(log, "tail") == pytest.approx(0.09)
    assert M.tail_draw_in(log, "u", kind="increase") == pytest.approx(0.05)
    with pytest.raises(ConfigError, match="nope"):
        M.tail_draw_in(log, "nope")
    assert M.knot_status("reef", "reef") == "held"
    assert M.knot_status("reef", "reef", slipped=True) == "slipped"
    assert M.knot_status("trefoil_right", "unknot") == "untied"
    assert M.knot_status("reef", "granny_left") == "changed knot type"
    assert M.knot_status("reef", "reef", verdict="loose") == "loose"
    assert M.knot_status("reef", "reef", verdict="undecided") == "undecided"
    assert M.knot_status("reef", "unknot", verdict="loose") == "untied"  # topology first
    with pytest.raises(ValueError):
        M.knot_status("reef", "reef", verdict="fine")


def test_ideal_ropelength_of_composite_knots_is_the_sum_of_factors():
    assert M.ideal_ropelength("3_1") == 16.37
    assert M.ideal_ropelength("3_1#3_1*") == pytest.approx(32.74)
    assert M.ideal_ropelength("8_19") is None and M.ideal_ropelength(None) is None
    assert M.knot_status(None, "reef") == "unknown"
    assert M.normalized_force(2.0, 0.1, 0.01) == pytest.approx(2.0)


def _naive_sustained(t, flag, hold):
    """Slow reference: try every start row, walk forward while the flag holds."""
    for i in range(len(t)):
        if not flag[i] or (i > 0 and flag[i - 1]):
            continue
        j = i
        while j + 1 < len(t) and flag[j + 1]:
            j += 1
        if t[j] - t[i] >= hold or (j == len(t) - 1 and t[j] - t[i] >= hold / 2):
            return i
    return None


def test_sustained_onset_against_reference():
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 10.0, 201)
    for _ in range(200):
        flag = rng.random(t.size) < rng.uniform(0.3, 0.97)
        hold = rng.uniform(0.0, 2.0)
        assert M.sustained_onset(t, flag, hold) == _naive_sustained(t, flag, hold)
    flag = np.zeros(t.size, bool)
    assert M.sustained_onset(t, flag, 1.0) is None
    flag[t >= 9.4] = True  # 0.6 s at the end of the record: counts for hold = 1 s, not for 2 s
    assert t[M.sustained_onset(t, flag, 1.0)] == pytest.approx(9.4)
    assert M.sustained_onset(t, flag, 2.0) is None
    with pytest.raises(ConfigError, match="flag"):
        M.sustained_onset(t, flag[:-1], 1.0)
    with pytest.raises(ConfigError, match="hold"):
        M.sustained_onset(t, flag, -1.0)


def test_draw_in_onset_finds_tails_running_in_under_a_steady_force():
    """A bend that slips under an almost constant force (no 30 % drop) is caught by the tails."""
    v = 0.01
    t = np.linspace(0.0, 40.0, 401)
    tails = np.where(t < 30.0, 0.6, 0.6 - 0.9 * v * (t - 30.0))  # tails run in at 0.9 v from 30 s
    f = np.where(t < 30.0, 0.011 * t / 30.0, 0.0095)  # peak, then only -14 %
    log = _log(t, f, tail_a=tails / 2, tail_b=tails / 2)
    on = M.draw_in_onset(log, ["tail_a", "tail_b"], 0.25 * v, smooth=2.0, hold=2.0, t0=2.0)
    assert on is not None and on["criterion"] == "tail draw-in"
    assert 29.0 <= on["time"] <= 30.5
    assert on["force"] == pytest.approx(0.011, rel=0.1)
    assert on["detected_at"] >= on["time"] + 2.0 - 1e-9
    # the force-drop rule misses it
    assert M.slip_onset(log, "F_norm", drop_fraction=0.3, min_force=0.005, smooth=0.5, t0=2.0) is None
    # a held bend: tails pushed out, or drawn in slower than the threshold
    held = _log(t, f, tail_a=0.3 + 0.1 * v * t, tail_b=0.3 - 0.2 * v * t)
    assert M.draw_in_onset(held, ["tail_a", "tail_b"], 0.25 * v, t0=2.0) is None
    # a loose bend sliding from the very start: onset at the end of the transient
    sliding = _log(t, f, tail_a=0.3 - 0.5 * v * t, tail_b=0.3 - 0.5 * v * t)
    assert M.draw_in_onset(sliding, ["tail_a", "tail_b"], 0.25 * v, t0=2.0)["time"] == pytest.approx(2.0)
    with pytest.raises(ConfigError, match="rate"):
        M.draw_in_onset(log, ["tail_a"], 0.0)
    with pytest.raises(ConfigError, match="tail_c"):
        M.draw_in_onset(log, ["tail_c"], 1e-3)


def test_two_rope_bend_outcome_uses_tail_draw_in():
    """The protocol's metrics on a synthetic log: a slow slip under a steady force is 'slipped'."""
    from types import SimpleNamespace

    from knotsim.protocols.params import resolve_params
    from knotsim.protocols.two_rope_bend import TwoRopeBend

    proto = TwoRopeBend()
    v = 0.01
    t = np.linspace(0.0, 40.0, 401)
    tails = np.where(t < 30.0, 0.6, 0.6 - 0.9 * v * (t - 30.0))
    f = np.where(t < 30.0, 0.011 * t / 30.0, 0.0095)
    log = _log(t, f, tail_a=tails / 2, tail_b=tails / 2, u_pull=v * t)
    bare = {"t_pre": 0.0, "t_settle": 0.0, "plan": None, "geometry": None, "topology_end": None}
    ctx = SimpleNamespace(params=resolve_params(proto.defaults, {"pull_speed": v}), **bare)
    m = proto.metrics(ctx, log)
    assert proto.slipped(ctx, m) and 29.0 <= m["slip_onset"]["time"] <= 30.5
    assert m["force_drop_onset"] is None
    assert m["F_norm_hold"] == pytest.approx(0.011, rel=0.02)
    held = log.assign(tail_a=0.3, tail_b=0.3)
    assert not proto.slipped(ctx, proto.metrics(ctx, held))
    # force control: the pulled end runs away at 20 s
    u = np.where(t < 20.0, 1e-3 * t, 0.02 + 0.2 * (t - 20.0))
    flog = _log(t, 1e-3 * t, tail_a=0.3, tail_b=0.3, u_pull=u)
    fctx = SimpleNamespace(params=resolve_params(proto.defaults, {"mode": "force"}), **bare)
    fm = proto.metrics(fctx, flog)
    assert fm["slip_onset"]["criterion"] == "runaway" and 19.5 <= fm["slip_onset"]["time"] <= 20.5
    assert fm["F_norm_hold"] == pytest.approx(0.02, rel=0.05)


def test_contact_and_solver_overrides_may_be_nested_tables():
    from knotsim.protocols.params import resolve_params

    p = resolve_params({"mu": 0.1, "contact.delta": 5e-4}, {"contact": {"stiffness_scaler": 250.0},
                                                          "solver": {"max_iterations": 30}})
    assert p.contact == {"delta": 5e-4, "stiffness_scaler": 250.0}
    assert p.solver == {"max_iterations": 30}


def test_ramped_pull_starts_smoothly_and_reaches_the_speed():
    import numpy as np

    from knotsim.bc.paths import RampedVelocity

    p = RampedVelocity([0.01, 0.0, 0.0], 0.5)
    e = np.linspace(0.0, 1.0, 2001)
    x = np.array([p(t)[0] for t in e])
    v = np.gradient(x, e)
    assert x[0] == 0.0 and abs(v[0]) < 1e-4 and v[-1] == pytest.approx(0.01, rel=1e-6)
    assert np.max(np.abs(np.diff(v))) < 1e-4  # no jump of speed anywhere
    assert p(1.0)[0] == pytest.approx(0.01 * 0.75)


def test_protocol_ramp_time_reaches_the_run_file(tmp_path):
    from knotsim.protocols import build_protocol_run

    _, _, spec, _ = build_protocol_run("single-rod-bend", "single_rod_reef", quick=True,
                                       overrides={"ramp_time": 0.5})
    pulls = [b for b in spec.data["bc"] if b["name"].startswith("pull")]
    assert pulls and all(b["ramp_time"] == 0.5 for b in pulls)
    _, _, spec0, _ = build_protocol_run("single-rod-bend", "single_rod_reef", quick=True)
    assert all("ramp_time" not in b for b in spec0.data["bc"])  # the published abrupt start by default
