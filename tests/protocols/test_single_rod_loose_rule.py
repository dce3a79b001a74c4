"""The ``loose`` outcome of ``single-rod-bend``: the force after the start-up transient never left
the free-rope level (elastica bound of a bend of radius 2h, plus drag), not the rope in the knot.

Synthetic logs go through the protocol's own metrics and verdict (no simulation)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from knotsim.errors import ConfigError
from knotsim.protocols import build_protocol_run
from knotsim.protocols.metrics import knot_status
from knotsim.protocols.params import check_param_ranges
from knotsim.protocols.single_rod_bend import free_rope_level

IDEAL_REEF = 2 * 16.37  # ideal ropelength of 3_1 # 3_1*, diameters


def _ctx(**overrides):
    proto, ctx, _spec, _ = build_protocol_run("single-rod-bend", "single_rod_reef", overrides=overrides or None)
    ctx.topology_end = {"rolfsen": "3_1#3_1*"}
    return proto, ctx


def _log(ctx, f_norm, rope_in_knot, t_end=13.0, dt=0.1):
    """A log of the 13 s pull: F_norm(t) (callable), the rope in the knot constant (m)."""
    t = np.arange(0.0, t_end + 1e-9, dt)
    f = np.array([f_norm(x) for x in t], float)
    e2e = 0.6 + 0.02 * t
    return pd.DataFrame({"time": t, "F_norm": f, "F": f * ctx.EI / ctx.radius**2,
                         "end_to_end": e2e, "contour_length": e2e + rope_in_knot})


def _outcome(proto, ctx, log):
    m = proto.metrics(ctx, log)
    return m, knot_status("reef", "reef", verdict=proto.verdict(ctx, m))


def test_free_rope_level_is_the_elastica_bound_plus_drag():
    _, ctx = _ctx()
    p = ctx.params
    assert p["loose_bend_radius"] == 2.0
    drag = p["damping"] * p["pull_speed"] * ctx.length / 2.0  # N
    level = free_rope_level(p, ctx.EI, ctx.radius, ctx.length)
    assert level == pytest.approx(1.0 / 16.0 + drag * ctx.radius**2 / ctx.EI, rel=1e-12)
    # published set-up: the drag (eta v L / 2 = 5e-5 N) is ~1e-4 EI/h^2, the bend term decides
    assert 0 < level - 1.0 / 16.0 < 1e-3
    # a tighter bend radius raises the level as 1 / r^2
    _, ctx1 = _ctx(loose_bend_radius=1.0)
    assert free_rope_level(ctx1.params, ctx1.EI, ctx1.radius, ctx1.length) - level == pytest.approx(
        0.25 - 1.0 / 16.0, rel=1e-9)


def test_jammed_knot_with_much_rope_in_it_is_not_loose():
    """A knot that jams at high friction keeps much rope in it (here 0.6 m, 7x the ideal reef's)
    and carries F h^2/EI ~ 0.8: the old rule (rope > 3x ideal) called it loose."""
    proto, ctx = _ctx(mu=0.5)
    log = _log(ctx, lambda t: 0.8 * min(t / 2.0, 1.0) + 0.01 * np.sin(7 * t), rope_in_knot=0.6)
    m, status = _outcome(proto, ctx, log)
    assert m["rope_in_knot_final"] > 3 * IDEAL_REEF * 2 * ctx.radius  # the old rule's 'loose'
    assert m["tightened"] is False
    assert m["left_free_rope_level"] is True and m["F_norm_peak"] > 0.8
    assert m["slip_onset"] is None
    assert status == "held"


def test_force_at_free_rope_level_is_loose_even_with_little_rope_in_the_knot():
    """A force that never leaves the free-rope level is loose, whatever the geometry says (here the
    rope in the knot is within the old 3x limit, so the old rule called it held)."""
    proto, ctx = _ctx()
    log = _log(ctx, lambda t: 0.003 + 0.002 * t / 13.0 + 0.001 * np.sin(5 * t), rope_in_knot=0.2)
    m, status = _outcome(proto, ctx, log)
    assert m["tightened"] is True  # the old rule: not loose
    assert m["F_norm_peak"] < m["free_rope_level"]
    assert m["left_free_rope_level"] is False
    assert status == "loose"


def test_start_up_ringing_before_the_transient_does_not_count():
    """A spike during the start-up transient (1 s) does not make a loose knot tight; the same spike
    after it does."""
    proto, ctx = _ctx()
    spike_early = _log(ctx, lambda t: 0.5 if 0.2 <= t <= 0.6 else 0.005, rope_in_knot=0.45)
    assert _outcome(proto, ctx, spike_early)[1] == "loose"
    # just above the level after the transient: it left the free-rope level
    level = free_rope_level(ctx.params, ctx.EI, ctx.radius, ctx.length)
    rise = _log(ctx, lambda t: 1.02 * level * t / 13.0, rope_in_knot=0.45)
    m, status = _outcome(proto, ctx, rise)
    assert m["left_free_rope_level"] is True and status == "held"
    below = _log(ctx, lambda t: 0.98 * level * t / 13.0, rope_in_knot=0.45)
    assert _outcome(proto, ctx, below)[1] == "loose"


def test_short_pull_without_a_peak_is_undecided_not_loose():
    proto, ctx = _ctx()
    log = _log(ctx, lambda t: 0.001, rope_in_knot=0.45, t_end=0.8)  # shorter than the 1 s transient
    m, status = _outcome(proto, ctx, log)
    assert m["F_norm_peak"] is None and m["left_free_rope_level"] is None
    assert status == "undecided"


def test_bad_loose_bend_radius_is_refused():
    with pytest.raises(ConfigError, match="loose_bend_radius"):
        check_param_ranges({"loose_bend_radius": 0.0})
    _, ctx = _ctx()
    params = dict(ctx.params.values, loose_bend_radius=-1.0)
    with pytest.raises(ConfigError, match="loose_bend_radius"):
        free_rope_level(params, ctx.EI, ctx.radius, ctx.length)
