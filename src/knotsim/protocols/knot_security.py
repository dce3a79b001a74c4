"""Protocol ``knot-security``: set a bend, then load it as it is used (docs/physics.md §4.4).

A knot's strength is a property of how it was set as much as of the knot. This protocol makes the
setting explicit and loads the set knot in one of four ways. Two-rope bends (the knot's ``held``
and ``pulled`` hints name the standing ends; the other two ends are the tails) and one-rope knots
(below).

Stages (times from the end of any ``settle_time``):

1. **set** (``set_ramp + set_hold`` s): the standing end of rope A is clamped (two end nodes and
   their edge angle, the whole run); the other three ends are pulled outwards along their own end
   directions by a force that grows from 0 to ``set_tension`` (N) over ``set_ramp`` s and stays there
   for ``set_hold`` s (force control, twist free), so the knot draws itself tight under a known
   tension instead of a prescribed displacement;
2. **relax** (``relax_time`` s): the three forces fall linearly to ``hold_tension`` (N);
3. **load**: the tails are let go; the standing end of rope B is loaded along the axis from the
   clamped end to it, in the mode ``load``:

   * ``"ramp"``: a force growing from ``hold_tension`` at ``load_rate`` (N/s) until the end runs away
     (its speed above ``runaway_speed`` for 0.5 s, watched from ``detect_after`` s into the load, 0 by
     default: from its first instant): the **slip load** is the force at the onset; the **slow-slip
     load** is where rope begins to pass through the knot faster than ``slip_speed`` for 0.5 s;
   * ``"hold"``: a force rising to ``hold_load`` (N) over ``transient`` s, then held: the drift of
     the pulled end and of the tails over the rest of the stage says whether the knot holds;
   * ``"slide"``: the end moves at ``pull_speed`` (m/s): the mean force over the second half is the
     **sliding resistance**;
   * ``"pulses"``: ``n_pulses`` triangular pulses from ``hold_tension`` up to ``pulse_load`` (N) and
     back, ``pulse_period`` s each (a jerk test): the knot has **spilled** after the first pulse at
     whose end more than ``spill_distance`` (m) of rope has passed through the knot since the load
     began (``cycles_to_spill``).

**One slip rule** (``slip_rule = "through"``): a slip is rope passing through the knot, which pays
the loaded end out and draws the tails in by about as much; the lesser of the two measures it (the
slow slip's speed, the hold's drift, the pulses' spill). The loaded end let out while the tails stay
(the standing part stretching, the knot changing shape) and the tails drawn in while the loaded end
stays (the knot drawing up) are no slip; a one-rope knot has no free tails, its loaded ends decide.
``slip_rule = "loaded_end"`` reads the loaded end alone for the slow slip and the spill, and
``detect_after = 1`` starts the ramp's detection 1 s into the load: the rules of the studies recorded
before this one.

**One-rope knots** (the single-rope reef and granny of the seed study, ``single_rod_reef`` and
``single_rod_granny``): the node of the knot's ``held`` hint (the bottom of the first overhand's
loop) is held still for the whole run (positions only, a peg through the loop); both ends are set
and relaxed as above, then both are loaded, apart along the axis from the first end to the last,
in the same mode (each end carries the load ``F``; ``u_pull`` is the mean of the two ends'
displacements along their load directions; ``"slide"`` moves both at ``pull_speed`` and reports
the mean of their reactions). There are no free tails: ``tail_a``, ``tail_b`` and ``rope_gap`` are
NaN, ``drift_tails`` is ``None``, and ``in_knot`` counts each end from its tip to the first node
within contact distance of another part of the rope.

With ``contact.stick_distance`` (the default here: 10 µm) the friction holds below its limit without
creep (docs/physics.md §3.6), so a knot below its slip load does not move; ``contact.mu_static``
sets the static coefficient (default: ``mu``).

Log columns: ``F`` (N, the force on the loaded standing end along the axis: the applied one in the
force modes, the reaction in ``"slide"``), ``F_norm = F h²/EI``, ``u_pull`` (m, its displacement
along the axis), ``tail_a``, ``tail_b`` (m, tail lengths outside the knot, as in
:mod:`knotsim.protocols.two_rope_bend`), ``rope_gap`` (m) and ``in_knot`` (m): the rope in the knot,
the total length less the four ends' lengths outside it (each measured like a tail; 0 once the ropes
are apart).

Metrics: ``set_tension`` (N) and its ``F h²/EI``; ``in_knot_set`` (m, at the end of the set stage)
and ``in_knot_load`` (at the start of the load); ``set_creep`` (m/s, the rate at which the rope in the
knot still changed over the last ``set_still_window`` of the set hold, 0.5 s, a least-squares line)
and ``set_still`` (``|set_creep|`` at most
``set_still_rate``, 0.5 mm/s; false: the knot was still moving when the set ended, it was loaded
before it was set, and the summary's notes say so); then by mode ``slip_load`` (N), ``slip_load_norm`` and ``slip_onset`` (ramp: the run-away;
``slow_slip_load`` and ``slow_slip_onset``: rope passing through the knot faster than ``slip_speed``
for 0.5 s, a slow slip that may come well before the run-away, with ``slow_slip_during_transient``;
``slip_during_transient``: the end was already running away when the detection began,
``detect_after`` s into the load, so the slip load is at most the value given),
``drift_pull``, ``drift_tails`` (m over the hold after its rise) and their rates (m/s), and
``drift_pull_late``, ``drift_tails_late`` with their rates over the second half of the hold (the
tails' drift positive when drawn into the knot, their lengths interpolated along the edge where they
enter it, ``None`` for one-rope knots) and ``drift_through_late`` (m), the rope let through the knot
over that half: the smaller of the loaded end's outward drift and the tails' draw-in (a one-rope
knot: its loaded ends' drift). Hold: ``drift_through_late`` beyond ``hold_drift`` is a slip,
criterion ``"drift"``: rope passing through the knot pays the loaded end out and draws the tails in
by about as much. A loaded end drawn in against the load (the knot still settling), tails drawn in
while the loaded end stays (the knot drawing up after its set tension was relaxed) and a loaded end
let out while the tails stay (the knot changing shape) are reported, not slips;
``sliding_resistance`` (N) and its norm (slide); for bends ``turn_load`` (rad, each rope's turning
in the knot when the load began, log columns ``turn_a``, ``turn_b``) and ``capsize_onset``. Outcomes:
``capsized`` (a rope pulled straight through the knot while the other still goes round it,
:data:`CAPSIZE_STRAIGHT`; named so also when the knot then slips or comes apart), then as for
``two-rope-bend``: ``untied`` (the ropes apart and unlinked), ``slipped`` (the loaded end ran away
or, holding, rope passed through), ``undecided`` (a load stage too short to tell), else held.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from knotsim.errors import ConfigError
from knotsim.protocols.base import Decision, Phase, RunContext, end_group_nodes, unit
from knotsim.protocols.geometry import default_ends, parse_end
from knotsim.protocols.metrics import moving_average, sustained_onset, window_mean
from knotsim.protocols.timeline import measured_log, pull_start
from knotsim.protocols.two_rope_bend import (
    APART_RADII,
    TwoRopeBend,
    bend_names,
    ends_interleaved,
    free_tail_ends,
    rope_gap,
    self_tail_lengths,
    tail_lengths,
    turning_in_knot,
)

__all__ = ["KnotSecurity", "SetUntilStill"]

LOAD_MODES = ("ramp", "hold", "slide", "pulses")
SLIP_RULES = ("through", "loaded_end")
#: Capsizing (a bend turning into another form under load, e.g. a reef into two lark's heads round a
#: rope pulled straight): one rope's turning in the knot below ``CAPSIZE_STRAIGHT`` (rad, nearly
#: straight) while the other's is at least ``CAPSIZE_WRAPPED`` (still round it) and the ropes touch,
#: for ``CAPSIZE_HOLD`` s. A set bend turns each rope by about 1.5 π in the knot.
CAPSIZE_STRAIGHT = 0.25 * math.pi
CAPSIZE_WRAPPED = 0.5 * math.pi
CAPSIZE_HOLD = 0.25

#: s between the checks of the rope in the knot's rate while ``set_until_still`` looks for the end of the set
STILL_CHECK = 0.05
#: s the loaded end must stay faster than ``runaway_speed`` (``slip_speed``) for a run-away (slow slip)
SUSTAIN = 0.5
#: the flag a knot loaded before it was set adds to the outcome
NOT_SET = "loaded before it was set"


class SetUntilStill(Phase):
    """The set held until the knot stops moving (``set_until_still``): the run is built with the set
    held for ``set_hold_max``; the rope in the knot (the log's ``in_knot``) is read after every step,
    and from ``set_hold`` into the hold on, every :data:`STILL_CHECK` s, the first time its rate of
    change over the last ``set_still_window`` s (a least-squares line through those samples, the
    run's own ``set_creep``) and over the window before it are both at most ``set_still_rate`` ends
    the set there (one window alone can catch a turning point of a knot still working itself in and
    out): the run goes on as if built with that ``set_hold``, which ``run.toml`` and the summary give
    (``metrics["set_until_still"]`` records the search). A knot still moving after ``set_hold_max``
    is loaded then, and said to be."""

    def __init__(self, p, t_settle: float):
        super().__init__()
        self.hold_min, self.hold_max = float(p["set_hold"]), float(p["set_hold_max"])
        self.window, self.rate_limit = float(p["set_still_window"]), float(p["set_still_rate"])
        if self.hold_max < self.hold_min:
            raise ConfigError("set_hold_max", f"must be at least set_hold = {self.hold_min:g} s, got "
                                              f"{self.hold_max:g}")
        self.set_ramp, self.t_settle = float(p["set_ramp"]), t_settle
        self.t_hold = t_settle + self.set_ramp  # s: the set hold begins
        self.t_first = max(0.0, self.t_hold + self.hold_min - 2.0 * self.window)
        self.next_check = self.t_hold + self.hold_min
        self.times: list[float] = []
        self.in_knot: list[float] = []
        self.rate = math.nan
        self.build_overrides = {"set_hold": self.hold_max}
        self.record = {"set_hold": self.hold_max, "still": False, "rate": math.nan, "set_hold_max": self.hold_max}

    def _set_end(self, hold: float) -> float:
        """The run time (s) at which a set held ``hold`` s ends, summed as the run description sums it."""
        end = self.set_ramp + hold
        return end + self.t_settle if self.t_settle else end

    def observe(self, t: float, row: dict) -> dict | None:
        if self.done or t < self.t_first - 1e-9:
            return None
        if t > self.t_hold + self.hold_max + 1e-9:  # the cap: loaded before it was set
            self.done = True
            self.notes.append(f"set_until_still: the knot was still moving after set_hold_max = {self.hold_max:g} s "
                              f"of set (the rope in it changing at {1e3 * self.rate:+.3g} mm/s); it is loaded before "
                              "it was set")
            return None
        self.times.append(t)
        self.in_knot.append(float(row["in_knot"]))
        if t < self.next_check - 1e-9:
            return None
        self.next_check = t + STILL_CHECK
        tt, ink = np.asarray(self.times), np.asarray(self.in_knot)
        w = min(self.window, t - self.t_hold)
        recent = tt >= t - w - 1e-9
        before = (tt >= t - 2.0 * w - 1e-9) & (tt <= t - w + 1e-9)
        if np.count_nonzero(recent) < 3:
            return None
        self.rate = float(np.polyfit(tt[recent], ink[recent], 1)[0])
        self.record["rate"] = self.rate
        if not (abs(self.rate) <= self.rate_limit and np.count_nonzero(before) >= 3
                and abs(float(np.polyfit(tt[before], ink[before], 1)[0])) <= self.rate_limit):
            return None
        # still over this window and the one before it: the set ends now, at exactly this step's time
        hold = t - self.t_hold
        for _ in range(64):
            end = self._set_end(hold)
            if end == t:
                break
            hold = math.nextafter(hold, math.inf if end < t else -math.inf)
        self.done = True
        self.record.update(set_hold=hold, still=True)
        return {"set_hold": hold}


def pulse_load(t_load: float, base: float, peak: float, period: float, n: int) -> float:
    """The load (N) of the ``"pulses"`` mode ``t_load`` s into the load stage: ``n`` triangular pulses
    of ``period`` s from ``base`` up to ``peak`` and back, then ``base``."""
    if t_load < 0 or t_load >= n * period:
        return base
    x = (t_load % period) / period
    return base + (peak - base) * (2.0 * x if x < 0.5 else 2.0 * (1.0 - x))


def _positive(params, key: str, allow_zero: bool = False) -> float:
    v = params[key]
    ok = isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and (v >= 0 if allow_zero
                                                                                          else v > 0)
    if not ok:
        raise ConfigError(key, f"must be a {'non-negative' if allow_zero else 'positive'} number, got {v!r}")
    return float(v)


class KnotSecurity(TwoRopeBend):
    name = "knot-security"
    description = ("Set a bend or a one-rope knot under a known tension, relax it, then load it (ramp, hold, slide "
                   "or pulses)")
    kinds: tuple[str, ...] = ()
    default_knot = "reef_bend"
    n_ropes = (2, 1)
    defaults = {
        "mu": 0.3,
        "dt": 2e-3,
        "contact.stick_distance": 1e-5,  # m: the elastic-stick law, static friction that holds
        "held_end": "",
        "pulled_end": "",
        "set_tension": 0.01,   # N on each of the three loaded ends while setting
        "set_ramp": 1.0,       # s
        "set_hold": 2.0,       # s
        "hold_tension": 0.001,  # N left on the three ends after relaxing
        "relax_time": 0.5,     # s
        "load": "ramp",
        "load_rate": 0.002,    # N/s (ramp)
        "hold_load": 0.005,    # N (hold)
        "load_time": 0.0,      # s of load stage (0: 20 s for ramp and slide, 10 s + transient for hold,
                               # the pulses and 2 s for pulses)
        "pulse_load": 0.005,   # N at the top of each pulse (pulses)
        "pulse_period": 1.0,   # s per pulse (pulses)
        "n_pulses": 10,        # pulses (pulses)
        "spill_distance": 0.01,  # m the loaded end has moved at the end of a pulse = spilled (pulses)
        "pull_speed": 0.01,    # m/s (slide)
        "runaway_speed": 0.05,  # m/s: the loaded end faster than this for 0.5 s = running away
        "slip_speed": 0.002,   # m/s: faster than this for 0.5 s = slipping slowly (ramp); the elastic
                               # stretch of the standing part under the ramp moves it at ~0.4 mm/s
        "hold_drift": 0.001,   # m: a hold that let more rope through the knot over its second half slipped
        "set_still_rate": 5e-4,  # m/s: the rope in the knot changing faster than this at the end of the
                                 # set hold = the knot was still moving, not set (a quarter of slip_speed)
        "set_until_still": True,  # hold the set until the knot stops moving (at least set_hold, at most
                                  # set_hold_max), found as the run goes
        "set_hold_max": 20.0,  # s (set_until_still)
        "set_still_window": 0.5,  # s over which the rope in the knot must change slower than set_still_rate
        "transient": 1.0,      # s: the hold's rise to hold_load; the hold's drift is measured after it
        "detect_after": 0.0,   # s into the load before the ramp's slip detection starts (0: from the first
                               # instant, resolved down to the hold tension)
        "slip_rule": "through",  # "through": a slow slip is rope passing through the knot (the loaded end out
                                 # and the tails in); "loaded_end": the loaded end's speed alone (before 0.2)
        "stop_at_decision": True,  # end the run stop_margin s after its outcome is decided
        "stop_margin": 1.0,    # s the run goes on after the decision (stop_at_decision)
        "output_interval": 0.1,
    }
    quick = {"n_nodes": 101, "dt": 5e-3, "set_ramp": 0.3, "set_hold": 0.5, "relax_time": 0.2, "load_time": 3.0,
             "load_rate": 0.02, "output_interval": 0.5, "transient": 0.3}

    def setup(self, ctx: RunContext) -> None:
        geo = ctx.geometry
        p = ctx.params
        if len(geo.ropes) not in (1, 2):
            raise ConfigError("knot", f"knot-security loads bends of two ropes and one-rope knots; {geo.name!r} has "
                                      f"{len(geo.ropes)} ropes")
        mode = p["load"]
        if mode not in LOAD_MODES:
            raise ConfigError("load", f"must be one of {', '.join(LOAD_MODES)}, got {mode!r}")
        if p["slip_rule"] not in SLIP_RULES:
            raise ConfigError("slip_rule", f"must be one of {', '.join(SLIP_RULES)}, got {p['slip_rule']!r}")
        t_set_ramp = _positive(p, "set_ramp")
        t_set = t_set_ramp + _positive(p, "set_hold", allow_zero=True)
        t_relax = _positive(p, "relax_time")
        t_set_force = _positive(p, "set_tension")
        t_hold = _positive(p, "hold_tension", allow_zero=True)
        if t_hold > t_set_force:
            raise ConfigError("hold_tension", f"must be at most set_tension = {t_set_force:g} N, got {t_hold:g}")
        t_pre = t_set + t_relax
        ctx.data.update(t_pre=t_pre, t_set=t_set)

        def outward(rope: int, node: int):
            x = geo.ropes[rope]
            inner = min(5, len(x) - 1)
            return unit(x[node] - x[inner if node == 0 else len(x) - 1 - inner])

        def set_and_relax(name: str, rope: int, node: int) -> None:
            nodes = end_group_nodes(node, len(geo.ropes[rope]))
            d = outward(rope, node)
            ctx.add_bc("force", f"set_{name}", rod=rope, nodes=nodes, stop=t_set,
                       ramp={"from": [0.0, 0.0, 0.0], "to": list(t_set_force * d), "duration": t_set_ramp})
            ctx.add_bc("force", f"relax_{name}", rod=rope, nodes=nodes, start=t_set, stop=t_pre,
                       ramp={"from": list(t_set_force * d), "to": list(t_hold * d), "duration": t_relax})

        if len(geo.ropes) == 1:
            loaded = self._setup_one_rope(ctx, set_and_relax)
        else:
            loaded = self._setup_bend(ctx, set_and_relax)
        for group, rope, nodes, axis in loaded:
            self._load_stage(ctx, group, rope, nodes, axis, t_pre, t_hold)
        ctx.data["loaded_local"] = [(rope, nodes, axis) for _, rope, nodes, axis in loaded]

    def _setup_bend(self, ctx: RunContext, set_and_relax) -> list:
        """A bend: rope A's standing end clamped, the other three ends set; rope B's standing end loaded."""
        geo = ctx.geometry
        p = ctx.params
        hint_held, hint_pulled = default_ends(geo)
        he, pe = p["held_end"], p["pulled_end"]
        held_list = (parse_end(he, geo, "held_end"),) if he else hint_held
        pulled_list = (parse_end(pe, geo, "pulled_end"),) if pe else hint_pulled
        if not held_list or not pulled_list:
            raise ConfigError("knot", f"knot {geo.name!r} has no [loading] held/pulled hints; give held_end and "
                                      "pulled_end (ROPE:NODE)")
        held, pulled = held_list[0], pulled_list[0]
        if held.rope == pulled.rope:
            raise ConfigError("knot", "the held and pulled ends must be on different ropes")
        axis = unit(geo.ropes[pulled.rope][pulled.node] - geo.ropes[held.rope][held.node])
        ctx.data.update(held=held, pulled=pulled, held_end=0 if held.node == 0 else 1,
                        pulled_end=0 if pulled.node == 0 else 1)
        ctx.add_bc("clamp", "held", rod=held.rope, nodes=end_group_nodes(held.node, len(geo.ropes[held.rope])))
        set_and_relax("pull", pulled.rope, pulled.node)
        for name, (rope, end) in zip(("tail_a", "tail_b"), free_tail_ends(held, pulled), strict=True):
            set_and_relax(name, rope, 0 if end == 0 else len(geo.ropes[rope]) - 1)
        ctx.data["free_ends"] = free_tail_ends(held, pulled)
        ctx.data["all_ends"] = [(held.rope, 0 if held.node == 0 else 1), (pulled.rope, 0 if pulled.node == 0 else 1),
                                *ctx.data["free_ends"]]
        ctx.data["ends_interleaved"] = ends_interleaved(geo.ropes, [(held.rope, held.node), (pulled.rope, pulled.node)])
        return [("load", pulled.rope, end_group_nodes(pulled.node, len(geo.ropes[pulled.rope])), axis)]

    def _setup_one_rope(self, ctx: RunContext, set_and_relax) -> list:
        """A one-rope knot (the single-rope reef and granny of the seed study): the knot's ``held``
        hint held still (positions only, the whole run: the peg that stops the first overhand
        inverting); both ends set, then both loaded apart along the axis between them."""
        geo = ctx.geometry
        p = ctx.params
        if p["held_end"] or p["pulled_end"]:
            raise ConfigError("held_end" if p["held_end"] else "pulled_end",
                              "a one-rope knot is loaded at both ends, anchored at its held hint; held_end and "
                              "pulled_end are for bends, leave them empty")
        n = len(geo.ropes[0])
        anchor = sorted({min(max(h.node, 2), n - 3) for h in geo.held if h.rope == 0 and 0 < h.node < n - 1})
        if not anchor:
            raise ConfigError("knot", f"one-rope knot {geo.name!r} has no interior [loading] held hint (the node "
                                      "that anchors the knot, e.g. the bottom of the first overhand's loop)")
        ctx.add_bc("hold", "knot_hold", rod=0, nodes=anchor)
        axis = unit(geo.ropes[0][n - 1] - geo.ropes[0][0])
        set_and_relax("start", 0, 0)
        set_and_relax("end", 0, n - 1)
        ctx.data.update(anchor=anchor, free_ends=[], all_ends=[(0, 0), (0, 1)])
        return [("load_start", 0, end_group_nodes(0, n), -axis), ("load", 0, end_group_nodes(n - 1, n), axis)]

    def _load_stage(self, ctx: RunContext, group: str, rope: int, nodes, axis, t_pre: float, t_hold: float) -> None:
        """The load stage's boundary conditions on one loaded end (``axis`` its outward direction)."""
        p = ctx.params
        mode = p["load"]
        if mode == "ramp":
            ctx.add_bc("force", group, rod=rope, nodes=nodes, start=t_pre,
                       ramp={"from": list(t_hold * axis), "rate": list(_positive(p, "load_rate") * axis)})
        elif mode == "hold":
            rise = _positive(p, "transient")
            ctx.add_bc("force", group, rod=rope, nodes=nodes, start=t_pre,
                       ramp={"from": list(t_hold * axis), "to": list(_positive(p, "hold_load") * axis),
                             "duration": rise})
        elif mode == "pulses":
            peak, period = _positive(p, "pulse_load"), _positive(p, "pulse_period")
            n = p["n_pulses"]
            if not (isinstance(n, int | float) and not isinstance(n, bool) and n >= 1 and float(n).is_integer()):
                raise ConfigError("n_pulses", f"must be a positive integer, got {n!r}")
            for i in range(int(n)):  # each pulse: a rise and a fall (set-up, once)
                t0 = t_pre + i * period
                ctx.add_bc("force", f"{group}_up_{i}", rod=rope, nodes=nodes, start=t0,
                           stop=t0 + 0.5 * period,
                           ramp={"from": list(t_hold * axis), "to": list(peak * axis), "duration": 0.5 * period})
                ctx.add_bc("force", f"{group}_down_{i}", rod=rope, nodes=nodes, start=t0 + 0.5 * period,
                           stop=t0 + period,
                           ramp={"from": list(peak * axis), "to": list(t_hold * axis), "duration": 0.5 * period})
            ctx.add_bc("force", group, rod=rope, nodes=nodes, start=t_pre + int(n) * period,
                       force=list(t_hold * axis))
        else:
            ctx.add_bc("move", group, rod=rope, nodes=nodes, start=t_pre,
                       velocity=list(_positive(p, "pull_speed") * axis))

    def prepare(self, ctx: RunContext) -> None:
        geo = ctx.geometry
        loaded = []
        for rope, nodes, axis in ctx.data["loaded_local"]:
            x0 = np.mean([geo.ropes[rope][i] for i in nodes], axis=0)
            loaded.append((ctx.model.global_nodes(rope, nodes), np.asarray(axis, float), x0))
        ctx.data["loaded"] = loaded

    def duration(self, ctx: RunContext) -> float:
        """Set, relax and the load stage (``load_time``, or 20 s for ``"ramp"`` and ``"slide"`` and
        10 s after the rise for ``"hold"``)."""
        p = ctx.params
        load = float(p["load_time"])
        if not load > 0:
            load = (10.0 + float(p["transient"]) if p["load"] == "hold" else
                    int(p["n_pulses"]) * float(p["pulse_period"]) + 2.0 if p["load"] == "pulses" else 20.0)
        return float(ctx.data["t_pre"]) + load

    def record(self, ctx: RunContext, q, t, reactions) -> dict:
        m = ctx.model
        p = ctx.params
        x = m.node_positions(q)
        # the loaded ends' mean displacement along their own load directions
        u = float(np.mean([np.dot(x[nodes].mean(axis=0) - x0, axis) for nodes, axis, x0 in ctx.data["loaded"]]))
        t_load = float(t) - pull_start(ctx)
        t_hold = float(p["hold_tension"])
        if t_load < 0:
            f = math.nan  # setting and relaxing: the ends loaded along their own directions
        elif p["load"] == "ramp":
            f = t_hold + float(p["load_rate"]) * t_load
        elif p["load"] == "hold":
            f = t_hold + (float(p["hold_load"]) - t_hold) * min(t_load / float(p["transient"]), 1.0)
        elif p["load"] == "pulses":
            f = pulse_load(t_load, t_hold, float(p["pulse_load"]), float(p["pulse_period"]), int(p["n_pulses"]))
        else:
            groups = ("load_start", "load") if len(ctx.data["loaded"]) == 2 else ("load",)
            f = (float(np.mean([np.dot(reactions[g][:3], a) for g, (_, a, _) in zip(groups, ctx.data["loaded"],
                                                                                     strict=True)]))
                 if all(g in reactions for g in groups) else math.nan)
        ropes = [x[m.rod_node_start[r]:m.rod_node_start[r + 1]] for r in range(m.n_rods)]
        delta = float(p.contact.get("delta", 5e-4))
        total = sum(float(np.sum(np.linalg.norm(np.diff(r, axis=0), axis=1))) for r in ropes)
        if len(ropes) == 1:
            outside = self_tail_lengths(ropes[0], ctx.radius, delta)
            return {"F": f, "F_norm": f * ctx.radius**2 / ctx.EI, "u_pull": u, "tail_a": math.nan,
                    "tail_b": math.nan, "rope_gap": math.nan, "in_knot": max(total - float(sum(outside)), 0.0),
                    "turn_a": math.nan, "turn_b": math.nan}
        ends = ctx.data["all_ends"]  # standing ends, then the tails
        outside = tail_lengths(ropes, ends, ctx.radius, delta)
        by_end = {end: length for end, length in zip(ends, outside, strict=True)}
        turn = [turning_in_knot(ropes[r], by_end[(r, 0)], by_end[(r, 1)]) for r in (ends[0][0], ends[1][0])]
        return {"F": f, "F_norm": f * ctx.radius**2 / ctx.EI, "u_pull": u, "tail_a": outside[2],
                "tail_b": outside[3], "rope_gap": rope_gap(ropes), "in_knot": max(total - float(sum(outside)), 0.0),
                "turn_a": turn[0], "turn_b": turn[1]}

    def phase(self, ctx: RunContext) -> SetUntilStill | None:
        """With ``set_until_still``: the set, held until the knot stops moving (:class:`SetUntilStill`)."""
        p = ctx.params
        if not isinstance(p["set_until_still"], bool):
            raise ConfigError("set_until_still", f"must be true or false, got {p['set_until_still']!r}")
        return SetUntilStill(p, float(ctx.data.get("t_settle", 0.0))) if p["set_until_still"] else None

    def verdict(self, ctx: RunContext, metrics: dict) -> str | None:
        """``capsized`` when a rope was pulled straight through the knot while the other still went
        round it (``capsize_onset``; it names how the knot failed, also when it then came apart),
        else as for ``two-rope-bend``."""
        if metrics.get("capsize_onset") is not None:
            return "capsized"
        return super().verdict(ctx, metrics)

    def warnings(self, ctx: RunContext, metrics: dict) -> list[tuple[str, str]]:
        """A knot still moving when its set ended (``set_still`` false) was loaded before it was set:
        its loads are those of that moment of a set still under way, not of the set knot."""
        if metrics.get("set_still") is False:
            how = ("give a longer set_hold_max" if ctx.params["set_until_still"]
                   else "set set_until_still = true or give a longer set_hold")
            return [(NOT_SET, f"NOT SET: the knot was still moving when the load began (the rope in it changing at "
                              f"{1e3 * metrics['set_creep']:+.3g} mm/s at the end of the set, limit set_still_rate = "
                              f"{1e3 * float(ctx.params['set_still_rate']):g} mm/s): it was loaded before it was set, "
                              f"so this is not a measurement of the set knot; {how}")]
        return []

    def stages(self, ctx: RunContext, t_end: float) -> list[tuple[str, float, float]]:
        """Settling (``settle_time``), set (``set_ramp + set_hold``), relax (``relax_time``) and load."""
        data = ctx.data
        ts = float(data.get("t_settle", 0.0))
        t_set, t_pre = ts + float(data["t_set"]), ts + float(data["t_pre"])
        out = [("settle", 0.0, ts), ("set", ts, t_set), ("relax", t_set, t_pre), ("load", t_pre, t_end)]
        return [(n, a, min(b, t_end)) for n, a, b in out if b > a and a < t_end]

    def decision(self, ctx: RunContext, log) -> Decision | None:
        """The earliest of: the loaded end running away (faster than ``runaway_speed`` for
        :data:`SUSTAIN` s after the ``transient``: slipped; decided once it has lasted that long), the
        ropes of a bend apart (``rope_gap`` beyond :data:`APART_RADII` radii), and, in the ``hold``,
        ``slide`` and ``pulses`` modes, a capsize (decided after :data:`CAPSIZE_HOLD` s) and a spill
        (at the end of the pulse after which the knot is out by ``spill_distance``). A ramp measures
        the run-away load, so a capsize alone does not end it. Times in s of run time."""
        p = ctx.params
        t0 = pull_start(ctx)
        m = measured_log(ctx, log)
        if len(m) < 3:
            return None
        t = np.asarray(m["time"], float)
        f = np.asarray(m["F"], float)
        found: list[Decision] = []
        if p["load"] != "pulses":
            k, _ = _slip_onsets(p, m, t)
            if k is not None:
                found.append(Decision(t0 + float(t[k]) + SUSTAIN, "slipped",
                                      f"the loaded end ran away from F = {1e3 * f[k]:.3g} mN (faster than "
                                      f"runaway_speed = {float(p['runaway_speed']):g} m/s for {SUSTAIN:g} s)"))
        if "rope_gap" in m.columns:
            gap = np.asarray(m["rope_gap"], float)
            apart = np.flatnonzero(np.isfinite(gap) & (gap > APART_RADII * ctx.radius))
            if apart.size:
                i = int(apart[0])
                found.append(Decision(t0 + float(t[i]), "apart", f"the ropes came apart (gap {1e3 * gap[i]:.3g} mm)"))
        if p["load"] != "ramp":
            cap = _capsize_metrics(ctx, m, t)["capsize_onset"]
            if cap is not None:
                found.append(Decision(t0 + cap["time"] + CAPSIZE_HOLD, "capsized",
                                      f"rope {cap['rope']} was pulled straight through the knot at F = "
                                      f"{1e3 * cap['force']:.3g} mN"))
        if p["load"] == "pulses":
            spill = _pulse_metrics(p, m, t)
            if spill["cycles_to_spill"] is not None:
                n = int(spill["cycles_to_spill"])
                found.append(Decision(t0 + n * float(p["pulse_period"]), "spilled",
                                      f"the loaded end was out by more than spill_distance = "
                                      f"{1e3 * float(p['spill_distance']):g} mm after pulse {n}"))
        return min(found, key=lambda d: d.time) if found else None

    def metrics(self, ctx: RunContext, log) -> dict:
        p = ctx.params
        data = getattr(ctx, "data", {})
        t0 = pull_start(ctx)
        t_set = float(data.get("t_settle", 0.0)) + float(data.get("t_set", 0.0))
        t_all = np.asarray(log["time"], float)
        norm = ctx.radius**2 / ctx.EI
        out: dict = {"load": p["load"], "set_tension": float(p["set_tension"]), "set_hold": float(p["set_hold"]),
                     "set_until_still": data.get("adapted"),
                     "set_tension_norm": float(p["set_tension"]) * norm, "hold_tension": float(p["hold_tension"])}
        if "in_knot" in log.columns and t_all.size:
            ink = np.asarray(log["in_knot"], float)
            i_set = int(np.searchsorted(t_all, t_set - 1e-9))
            out["in_knot_set"] = float(ink[min(i_set, ink.size - 1)])
            i_load = int(np.searchsorted(t_all, t0 - 1e-9))
            out["in_knot_load"] = float(ink[min(i_load, ink.size - 1)])
            # over the last set_still_window of the set hold (the window set_until_still reads)
            tail = (t_all >= t_set - min(float(p["set_still_window"]), float(p["set_hold"])) - 1e-9) & (t_all <= t_set)
            out["set_creep"] = (float(np.polyfit(t_all[tail], ink[tail], 1)[0])
                                if np.count_nonzero(tail) >= 3 else None)
            out["set_still"] = (None if out["set_creep"] is None
                                else bool(abs(out["set_creep"]) <= float(p["set_still_rate"])))
        out.update(bend_names(ctx))
        if "rope_gap" in log.columns and t_all.size and np.isfinite(log["rope_gap"].iloc[-1]):  # a bend's two ropes
            gap = float(log["rope_gap"].iloc[-1])
            out["rope_gap_final"] = gap
            out["ropes_apart"] = bool(gap > APART_RADII * ctx.radius)
        log = measured_log(ctx, log)
        if len(log) < 2:
            out["decidable"] = False
            return out
        t = np.asarray(log["time"], float)
        t_skip = float(p["transient"]) if p["load"] != "ramp" else float(p["detect_after"])
        after = t >= t_skip
        out["load_time"] = float(t[-1])
        out.update(_capsize_metrics(ctx, log, t))
        if p["load"] == "pulses":
            out.update(_pulse_metrics(p, log, t))
            return out
        if p["load"] == "slide":
            half = t >= 0.5 * t[-1]
            out["sliding_resistance"] = window_mean(log, "F", float(t[half][0]) if half.any() else None)
            out["sliding_resistance_norm"] = out["sliding_resistance"] * norm
            out["slip_onset"] = None
            out["decidable"] = bool(t[-1] > t_skip)
            return out
        k, ks = _slip_onsets(p, log, t)
        speed = _pull_speed(log, t)
        slow = _through_speed(p, log, t)
        f = np.asarray(log["F"], float)
        out["slip_onset"] = (None if k is None else
                             {"time": float(t[k]), "force": float(f[k]), "criterion": "runaway"})
        out["slow_slip_onset"] = (None if ks is None else
                                  {"time": float(t[ks]), "force": float(f[ks]),
                                   "criterion": "through" if p["slip_rule"] == "through" else "slip_speed"})
        out["slow_slip_during_transient"] = bool(ks is not None and ks == int(np.argmax(after))
                                                 and np.any(~after[:ks + 1] & (slow[:ks + 1] > float(p["slip_speed"]))))
        out["decidable"] = bool(t[-1] - t_skip >= 0.5)
        # a run-away already under way when the detection starts (at the end of the transient): the
        # slip load is then at most the load there, not that load
        out["slip_during_transient"] = bool(k is not None and np.any(~after[:k + 1] & (speed[:k + 1]
                                                                                      > float(p["runaway_speed"])))
                                            and k == int(np.argmax(after)))
        if p["load"] == "ramp":
            out["slip_load"] = float(f[k]) if k is not None else None
            out["slip_load_norm"] = float(f[k]) * norm if k is not None else None
            out["slow_slip_load"] = float(f[ks]) if ks is not None else None
            out["slow_slip_load_norm"] = float(f[ks]) * norm if ks is not None else None
            out["largest_load_held"] = float(f[k] if k is not None else f[-1])
        else:
            win = after & (t <= (t[k] if k is not None else t[-1]))
            if np.count_nonzero(win) >= 2:
                tw = t[win]
                up = np.asarray(log["u_pull"], float)[win]
                tails = (np.asarray(log["tail_a"], float) + np.asarray(log["tail_b"], float))[win]
                span = float(tw[-1] - tw[0])
                out["hold_window"] = span
                out["drift_pull"] = float(up[-1] - up[0])
                if not np.all(np.isfinite(tails)):  # a one-rope knot has no free tails
                    tails = None
                out["drift_tails"] = float(tails[0] - tails[-1]) if tails is not None else None
                out["drift_pull_rate"] = float(np.polyfit(tw, up, 1)[0]) if span > 0 else None
                out["drift_tails_rate"] = (float(-np.polyfit(tw, tails, 1)[0])
                                           if span > 0 and tails is not None else None)
                # the second half: after the knot has taken up the load (the first seconds of a hold
                # are its elastic and frictional adjustment)
                late = tw >= tw[0] + 0.5 * span
                if np.count_nonzero(late) >= 2:
                    out["drift_pull_late"] = float(up[late][-1] - up[late][0])
                    out["drift_pull_late_rate"] = float(np.polyfit(tw[late], up[late], 1)[0])
                    # the tails over the same half: rope passing through the knot draws them in; the
                    # knot opening up after the set tension was relaxed draws them in too, in the
                    # first half (a set reef bend at μ = 0.26: 115 mm over the hold, under 1 mm late)
                    out["drift_tails_late"] = (float(tails[late][0] - tails[late][-1]) if tails is not None
                                               else None)
                    out["drift_tails_late_rate"] = (float(-np.polyfit(tw[late], tails[late], 1)[0])
                                                    if tails is not None else None)
                    # a slip lets rope through the knot: it pays the loaded end out under the load
                    # and draws the tails in, by about as much. A loaded end drawn in (the knot still
                    # settling after the set, against the load) is no slip, nor are tails drawn in
                    # while the loaded end stays (the knot drawing up), nor a loaded end let out while
                    # the tails stay (the knot changing shape). One-rope knots have no free tails:
                    # their loaded ends' drift decides.
                    through = (out["drift_pull_late"] if tails is None
                               else min(out["drift_pull_late"], out["drift_tails_late"]))
                    out["drift_through_late"] = through
                    if k is None and through > float(p["hold_drift"]):
                        i = int(np.flatnonzero(win)[np.argmax(late)])
                        out["slip_onset"] = {"time": float(t[i]), "force": float(f[i]), "criterion": "drift"}
            out["hold_load"] = float(p["hold_load"])
            out["hold_load_norm"] = float(p["hold_load"]) * norm
        return out


def _pull_speed(log, t: np.ndarray) -> np.ndarray:
    """The loaded end's speed (m/s) along the load, from its displacement averaged over 0.5 s."""
    u = moving_average(log, "u_pull", 0.5)
    return np.gradient(u, t) if len(t) > 2 else np.zeros_like(u)


def _through_speed(p, log, t: np.ndarray) -> np.ndarray:
    """The speed (m/s) at which rope passes through the knot, the quantity of the slow slip: with
    ``slip_rule = "through"`` the lesser of the loaded end's outward speed and the tails' draw-in
    speed (each from its length averaged over 0.5 s: rope through the knot pays the loaded end out and
    draws the tails in by as much; the loaded end stretching alone, or the tails drawn in while it
    stays, is no slip), the loaded end's speed for a one-rope knot (no free tails) and with
    ``slip_rule = "loaded_end"``."""
    speed = _pull_speed(log, t)
    if p["slip_rule"] != "through" or "tail_a" not in log.columns or len(t) <= 2:
        return speed
    tails = np.asarray(log["tail_a"], float) + np.asarray(log["tail_b"], float)
    if not np.all(np.isfinite(tails)):  # a one-rope knot
        return speed
    drawn_in = -np.gradient(moving_average(pd.DataFrame({"time": t, "y": tails}), "y", 0.5), t)
    return np.minimum(speed, drawn_in)


def _slip_onsets(p, log, t: np.ndarray) -> tuple[int | None, int | None]:
    """Rows of the load stage's log (``t`` s since the load began) where the loaded end began to run
    away (faster than ``runaway_speed``: the knot let go) and where rope began to pass through the
    knot faster than ``slip_speed`` (:func:`_through_speed`: the slow slip), each sustained for
    :data:`SUSTAIN` s, from ``detect_after`` s into the load in a ramp (0: from its first instant)
    and after the ``transient`` (the rise) in the other modes; ``None`` where it did not happen."""
    after = t >= float(p["detect_after"] if p["load"] == "ramp" else p["transient"])
    k = sustained_onset(t, after & (_pull_speed(log, t) > float(p["runaway_speed"])), SUSTAIN)
    ks = sustained_onset(t, after & (_through_speed(p, log, t) > float(p["slip_speed"])), SUSTAIN)
    return k, ks


def _capsize_metrics(ctx: RunContext, log, t: np.ndarray) -> dict:
    """``turn_load`` (rad, each rope's turning in the knot when the load began, rope A then B) and
    ``capsize_onset`` (``{"time", "force", "rope"}``: when a rope was pulled straight through the knot
    while the other still went round it, :data:`CAPSIZE_STRAIGHT`; ``None``: it never was) of a bend;
    both ``None`` for a one-rope knot."""
    if "turn_a" not in log.columns:
        return {"turn_load": None, "capsize_onset": None}
    ta, tb = np.asarray(log["turn_a"], float), np.asarray(log["turn_b"], float)
    if not (np.all(np.isfinite(ta)) and np.all(np.isfinite(tb))):
        return {"turn_load": None, "capsize_onset": None}
    touching = np.asarray(log["rope_gap"], float) <= APART_RADII * ctx.radius
    capsized = (np.minimum(ta, tb) < CAPSIZE_STRAIGHT) & (np.maximum(ta, tb) >= CAPSIZE_WRAPPED) & touching
    k = sustained_onset(t, capsized, CAPSIZE_HOLD)
    onset = (None if k is None else
             {"time": float(t[k]), "force": float(np.asarray(log["F"], float)[k]), "rope": "a" if ta[k] < tb[k] else "b"})
    return {"turn_load": [float(ta[0]), float(tb[0])], "capsize_onset": onset}


def _pulse_metrics(p, log, t) -> dict:
    """Cycles to spill of the ``"pulses"`` mode: the loaded end's displacement at the end of each pulse
    (back at the base load) from where the load stage began, ``pulse_drift`` (m); the knot has spilled
    in the first pulse after which it is out by more than ``spill_distance`` (``cycles_to_spill``;
    ``None``: it never was; an end drawn in is the knot settling, not spilling)."""
    period, n, spill = float(p["pulse_period"]), int(p["n_pulses"]), float(p["spill_distance"])
    u = np.asarray(log["u_pull"], float)
    u = u - u[0]
    if p["slip_rule"] == "through" and "tail_a" in log.columns:
        tails = np.asarray(log["tail_a"], float) + np.asarray(log["tail_b"], float)
        if np.all(np.isfinite(tails)):  # a bend: the rope through the knot, the lesser of out and in
            u = np.minimum(u, tails[0] - tails)
    ends = [i * period for i in range(1, n + 1) if i * period <= t[-1] + 1e-9]
    moved = [float(np.interp(te, t, u)) for te in ends]
    spilled = next((i + 1 for i, m in enumerate(moved) if m > spill), None)  # pulled out, not drawn in
    return {"pulse_drift": moved, "pulses_done": len(ends), "cycles_to_spill": spilled,
            "decidable": len(ends) == n or spilled is not None,
            "slip_onset": (None if spilled is None else
                           {"time": float(ends[spilled - 1]), "force": math.nan, "criterion": "spill"})}
