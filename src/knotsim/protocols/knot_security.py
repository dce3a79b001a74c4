"""Protocol ``knot-security``: set a bend or a one-rope knot, then load it as it is used
(docs/physics.md §4.4, docs/protocols.md).

A knot's strength is a property of how it was set as much as of the knot. Stages (times from the
end of any ``settle_time``):

1. **set** (``set_ramp + set_hold`` s; with ``set_until_still`` held until the knot stops moving,
   :class:`~knotsim.protocols.set_phase.SetUntilStill`): a bend's standing end of rope A is clamped
   (two end nodes and their edge angle, the whole run), the other three ends are pulled outwards along
   their own end directions by a force growing from 0 to ``set_tension`` (N) over ``set_ramp`` s;
2. **relax** (``relax_time`` s): the three forces fall linearly to ``hold_tension`` (N);
3. **load**: the tails go free; rope B's standing end is loaded along the axis from the clamp to it
   (mode ``load``): ``"ramp"`` a force growing at ``load_rate`` (N/s) until the end runs away (the
   **slip load**; the **slow-slip load** where rope begins to pass through the knot); ``"hold"``
   ``hold_load`` (N) reached over ``transient`` s and held (the rope let through the knot decides);
   ``"slide"`` the end moved at ``pull_speed`` (m/s, the **sliding resistance**); ``"pulses"``
   ``n_pulses`` triangular pulses of ``pulse_period`` s from ``hold_tension`` to ``pulse_load`` and
   back; ``"jerks"`` ``n_jerks`` jerks from slack (0 N) to ``jerk_load`` (N) in ``jerk_rise`` s and
   back as fast, one every ``jerk_period`` s, slack between (**cycles to spill**: the first pulse or
   jerk after which more than ``spill_distance`` of rope has passed through the knot).

**One slip rule** (``slip_rule = "through"``): a slip is rope passing through the knot, which pays the
loaded end out and draws the tails in by about as much; the lesser of the two measures it (the slow
slip, the hold's drift, the spill). ``slip_rule = "loaded_end"`` and ``detect_after = 1`` are the
rules of the studies recorded before it. **One-rope knots** (``single_rod_reef``,
``single_rod_granny``): the node of the knot's ``held`` hint is held still (a peg through the loop),
both ends are set, relaxed and then loaded apart (each by ``F``); no free tails, so their loaded ends
decide. With ``contact.stick_distance`` (the default here: 10 µm) friction holds below its limit
without creep (docs/physics.md §3.6).

Log columns: ``F`` (N, the force on the loaded end along the axis: applied, or the reaction in
``"slide"``; NaN while setting), ``F_norm = F h²/EI``, ``u_pull`` (m, its displacement along the
axis), ``tail_a``, ``tail_b`` (m, the free tails outside the knot,
:func:`~knotsim.protocols.rope_measures.tail_lengths`), ``rope_gap`` (m), ``in_knot`` (m: the total
length less the four ends' lengths outside the knot), ``turn_a``, ``turn_b`` (rad, each rope's turning
inside the knot). Metrics: :mod:`knotsim.protocols.security_metrics`. Outcomes: ``capsized`` (a rope
pulled straight through the knot while the other still goes round it; named so also when the knot
then comes apart), then ``untied`` (the ropes apart and unlinked), ``slipped``, ``undecided``, held.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from knotsim.errors import ConfigError
from knotsim.protocols.base import Decision, LoadingProtocol, RunContext, end_group_nodes, unit
from knotsim.protocols.bends import BendEnds, bend_ends, bend_names, bend_topology_key, untied
from knotsim.protocols.rope_measures import (
    APART_RADII,
    end_direction,
    rope_gap,
    self_tail_lengths,
    tail_lengths,
    turning_in_knot,
)
from knotsim.protocols.security_metrics import decide, load_metrics, set_metrics
from knotsim.protocols.security_params import SecurityParams, load_profile
from knotsim.protocols.set_phase import SetUntilStill
from knotsim.protocols.timeline import measured_log, pull_start

__all__ = ["KnotSecurity", "SecurityParams", "SecurityPlan", "SetUntilStill", "load_profile"]

#: the flag a knot loaded before it was set adds to the outcome
NOT_SET = "loaded before it was set"


@dataclass(frozen=True)
class SecurityPlan:
    """A knot-security run: its parameters, the set's end ``t_set`` (s after any settling), a bend's
    ends (``None`` for a one-rope knot) or a one-rope knot's ``anchor`` (local nodes held), every end
    in the order the log's lengths are measured (``all_ends``: ``(rope, end)``, the standing ends then
    the tails), the loaded ends (``loaded_local``: ``(group, rope, local nodes, outward axis (3,))``)
    and, once the model exists, ``loaded``: ``(global nodes, axis (3,), starting centre (3,) m)``."""

    params: SecurityParams
    t_set: float
    ends: BendEnds | None
    anchor: list[int] | None
    all_ends: list[tuple[int, int]]
    loaded_local: list[tuple[str, int, list[int], np.ndarray]]
    loaded: list[tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None


def _params(ctx: RunContext) -> SecurityParams:
    """The run's typed parameters: its plan's, or (a context without a plan) read from its parameters."""
    return ctx.plan.params if ctx.plan is not None else SecurityParams.from_params(ctx.params)


def _post(ctx: RunContext):
    """The post the run's knot is tied round (:class:`knotsim.knots.post.Post`), ``None`` for a knot
    without one (or a context without geometry)."""
    return ctx.geometry.post if ctx.geometry is not None else None


def _outward(geo, rope: int, node: int) -> np.ndarray:
    return end_direction(geo.ropes[rope], node)


class KnotSecurity(LoadingProtocol):
    name = "knot-security"
    description = ("Set a bend or a one-rope knot under a known tension, relax it, then load it (ramp, hold, slide, "
                   "pulses or jerks)")
    kinds: tuple[str, ...] = ("hitch", "loop")
    default_knot = "reef_bend"
    n_ropes = (2, 1)
    load_stage_name = "load"
    defaults = {
        "mu": 0.3,
        "dt": 2e-3,
        "contact.stick_distance": 1e-5,  # m: the elastic-stick law, static friction that holds
        "held_end": "",
        "pulled_end": "",
        "set_tension": 0.01,   # N on each of the three loaded ends while setting
        "set_ramp": 1.0,       # s
        "set_hold": 2.0,       # s (with set_until_still: at least)
        "hold_tension": 0.001,  # N left on the three ends after relaxing
        "relax_time": 0.5,     # s
        "load": "ramp",
        "load_rate": 0.002,    # N/s (ramp)
        "hold_load": 0.005,    # N (hold)
        "load_time": 0.0,      # s of load stage (0: SecurityParams.default_load_time)
        "pulse_load": 0.005,   # N at the top of each pulse (pulses)
        "pulse_period": 1.0,   # s per pulse (pulses)
        "n_pulses": 10,        # pulses (pulses)
        "jerk_load": 0.005,    # N at the top of each jerk (jerks)
        "jerk_rise": 0.03,     # s from slack to the top, and back (jerks)
        "jerk_period": 1.0,    # s from one jerk to the next (jerks)
        "n_jerks": 10,         # jerks (jerks)
        "spill_distance": 0.01,  # m of rope through the knot after a pulse or jerk = spilled
        "pull_speed": 0.01,    # m/s (slide)
        "runaway_speed": 0.05,  # m/s: the loaded end faster than this for 0.5 s = running away
        "slip_speed": 0.002,   # m/s: rope through the knot faster than this for 0.5 s = slipping slowly
        "hold_drift": 0.001,   # m: a hold that let more rope through the knot over its second half slipped
        "set_still_rate": 5e-4,  # m/s: the rope in the knot changing faster than this at the end of the
                                 # set = the knot was still moving, not set (a quarter of slip_speed)
        "set_until_still": True,  # hold the set until the knot stops moving (at least set_hold, at most
                                  # set_hold_max), found as the run goes
        "set_hold_max": 20.0,  # s (set_until_still)
        "set_still_window": 0.5,  # s over which the rope in the knot must change slower than set_still_rate
        "transient": 1.0,      # s: the hold's rise to hold_load; the hold's drift is measured after it
        "detect_after": 0.0,   # s into the load before the ramp's slip detection starts (0: from the start)
        "slip_rule": "through",  # "through": rope through the knot; "loaded_end": the loaded end alone
        "load_end": "standing",  # "standing": rope B's standing end loaded; "tail": rope A's tail, against
                                 # its own clamped standing end (how a reef bend capsizes; bends only)
        "load_angle": 0.0,     # deg: a hitch's or loop's load tilted from the plane across the post towards its axis
        "stop_at_decision": True,  # end the run stop_margin s after its outcome is decided
        "stop_margin": 1.0,    # s the run goes on after the decision (stop_at_decision)
        "output_interval": 0.1,
    }
    quick = {"n_nodes": 101, "dt": 5e-3, "set_ramp": 0.3, "set_hold": 0.5, "relax_time": 0.2, "load_time": 3.0,
             "load_rate": 0.02, "output_interval": 0.5, "transient": 0.3}

    def setup(self, ctx: RunContext) -> None:
        geo = ctx.geometry
        if len(geo.ropes) not in (1, 2):
            raise ConfigError("knot", f"knot-security loads bends of two ropes and one-rope knots; {geo.name!r} has "
                                      f"{len(geo.ropes)} ropes")
        sp = SecurityParams.from_params(ctx.params)
        t_set = sp.set_ramp + sp.set_hold
        ctx.t_pre = t_set + sp.relax_time
        if geo.post is None and sp.load_angle:
            raise ConfigError("load_angle", f"tilts the load of a knot round a post (a hitch or a loop); {geo.name!r} "
                                            "has no post, leave load_angle = 0")
        if geo.post is not None:
            ends, anchor, all_ends, loaded = self._setup_hitch(ctx, sp, t_set)
        elif len(geo.ropes) == 1:
            ends, anchor, all_ends, loaded = self._setup_one_rope(ctx, sp, t_set)
        else:
            ends, anchor, all_ends, loaded = self._setup_bend(ctx, sp, t_set)
        for group, rope, nodes, axis in loaded:
            self._load_stage(ctx, sp, group, rope, nodes, axis)
        ctx.plan = SecurityPlan(sp, t_set, ends, anchor, all_ends, loaded)

    def _set_and_relax(self, ctx: RunContext, sp: SecurityParams, t_set: float, name: str, rope: int,
                       node: int) -> None:
        """Set (a force growing to ``set_tension``) and relax (falling to ``hold_tension``) one end."""
        nodes = end_group_nodes(node, len(ctx.geometry.ropes[rope]))
        d = _outward(ctx.geometry, rope, node)
        ctx.add_bc("force", f"set_{name}", rod=rope, nodes=nodes, stop=t_set,
                   ramp={"from": [0.0, 0.0, 0.0], "to": list(sp.set_tension * d), "duration": sp.set_ramp})
        ctx.add_bc("force", f"relax_{name}", rod=rope, nodes=nodes, start=t_set, stop=ctx.t_pre,
                   ramp={"from": list(sp.set_tension * d), "to": list(sp.hold_tension * d), "duration": sp.relax_time})

    def _setup_bend(self, ctx: RunContext, sp: SecurityParams, t_set: float) -> tuple:
        """A bend: rope A's standing end clamped, the other three ends set; rope B's standing end loaded."""
        geo = ctx.geometry
        ends = bend_ends(geo, ctx.params)
        held, pulled = ends.held, ends.pulled
        axis = unit(geo.ropes[pulled.rope][pulled.node] - geo.ropes[held.rope][held.node])
        ctx.add_bc("clamp", "held", rod=held.rope, nodes=end_group_nodes(held.node, len(geo.ropes[held.rope])))
        self._set_and_relax(ctx, sp, t_set, "pull", pulled.rope, pulled.node)
        for name, (rope, end) in zip(("tail_a", "tail_b"), ends.free_ends, strict=True):
            self._set_and_relax(ctx, sp, t_set, name, rope, 0 if end == 0 else len(geo.ropes[rope]) - 1)
        all_ends = [(held.rope, ends.held_end), (pulled.rope, ends.pulled_end), *ends.free_ends]
        if sp.load_end == "tail":  # rope A's tail pulled away from its own standing end; rope B free
            rope, end = ends.free_ends[0]
            node = 0 if end == 0 else len(geo.ropes[rope]) - 1
            return ends, None, all_ends, [("load", rope, end_group_nodes(node, len(geo.ropes[rope])),
                                           _outward(geo, rope, node))]
        return ends, None, all_ends, [("load", pulled.rope, end_group_nodes(pulled.node, len(geo.ropes[pulled.rope])),
                                       axis)]

    def _setup_one_rope(self, ctx: RunContext, sp: SecurityParams, t_set: float) -> tuple:
        """A one-rope knot: the knot's ``held`` hint held still (positions only, the whole run: the peg
        that stops the first overhand inverting); both ends set, then both loaded apart along the axis
        between them."""
        geo, p = ctx.geometry, ctx.params
        if sp.load_end != "standing":
            raise ConfigError("load_end", "a one-rope knot is loaded at both ends; load_end = 'tail' is for bends")
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
        self._set_and_relax(ctx, sp, t_set, "start", 0, 0)
        self._set_and_relax(ctx, sp, t_set, "end", 0, n - 1)
        return None, anchor, [(0, 0), (0, 1)], [("load_start", 0, end_group_nodes(0, n), -axis),
                                                ("load", 0, end_group_nodes(n - 1, n), axis)]

    def _setup_hitch(self, ctx: RunContext, sp: SecurityParams, t_set: float) -> tuple:
        """A hitch, or a loop on a pin: the post is fixed (an obstacle of the run, see the pipeline);
        the standing part (the knot's ``pulled`` hint) and the tail are set, then the standing part
        is loaded along its own outward direction (tilted by ``load_angle``) and the tail goes free. A
        mid-line loop (two ``pulled`` ends, e.g. the alpine butterfly) has no tail: both standing parts
        are set and loaded, end to end, with the pin through its eye."""
        geo = ctx.geometry
        if len(geo.ropes) != 1:
            raise ConfigError("knot", f"a knot round a post is loaded with one rope; {geo.name!r} has {len(geo.ropes)}")
        if sp.load_end != "standing":
            raise ConfigError("load_end", "a hitch or a loop is loaded on its standing part; load_end = 'tail' is for "
                                          "bends")
        n = len(geo.ropes[0])
        ends = [p.node for p in geo.pulled if p.rope == 0 and p.node in (0, n - 1)]
        if not ends:
            raise ConfigError("knot", f"{geo.name!r} has no [loading] pulled hint at an end (its standing part)")
        if len(ends) == 2:  # a mid-line loop (two standing parts): both set and loaded, end to end, round the pin
            self._set_and_relax(ctx, sp, t_set, "start", 0, 0)
            self._set_and_relax(ctx, sp, t_set, "end", 0, n - 1)
            return None, None, [(0, 0), (0, 1)], [("load_start", 0, end_group_nodes(0, n), self._hitch_axis(sp, geo, 0)),
                                                  ("load", 0, end_group_nodes(n - 1, n), self._hitch_axis(sp, geo, n - 1))]
        standing = ends[0]
        tail = n - 1 if standing == 0 else 0
        self._set_and_relax(ctx, sp, t_set, "pull", 0, standing)
        self._set_and_relax(ctx, sp, t_set, "tail", 0, tail)
        return None, None, [(0, 0 if standing == 0 else 1), (0, 0 if tail == 0 else 1)], [
            ("load", 0, end_group_nodes(standing, n), self._hitch_axis(sp, geo, standing))]

    @staticmethod
    def _hitch_axis(sp: SecurityParams, geo, node: int) -> np.ndarray:
        """The load direction (3,) of a knot round a post: the end's own outward direction, tilted by
        ``load_angle`` from the plane across the post towards the post's axis."""
        out = _outward(geo, 0, node)
        if not sp.load_angle:
            return out
        across = out - np.dot(out, geo.post.axis) * geo.post.axis
        a = math.radians(sp.load_angle)
        return unit(math.cos(a) * unit(across) + math.sin(a) * geo.post.axis)

    def _load_stage(self, ctx: RunContext, sp: SecurityParams, group: str, rope: int, nodes, axis) -> None:
        """The load stage's boundary conditions on one loaded end (``axis`` its outward direction)."""
        t0, base = ctx.t_pre, sp.hold_tension
        if sp.load == "ramp":
            ctx.add_bc("force", group, rod=rope, nodes=nodes, start=t0,
                       ramp={"from": list(base * axis), "rate": list(sp.load_rate * axis)})
        elif sp.load == "hold":
            ctx.add_bc("force", group, rod=rope, nodes=nodes, start=t0,
                       ramp={"from": list(base * axis), "to": list(sp.hold_load * axis), "duration": sp.transient})
        elif sp.load == "slide":
            ctx.add_bc("move", group, rod=rope, nodes=nodes, start=t0, velocity=list(sp.pull_speed * axis))
        else:  # pulses from the hold tension, jerks from slack: a rise and a fall each (set-up, once)
            peak, low = (sp.pulse_load, base) if sp.load == "pulses" else (sp.jerk_load, 0.0)
            rise = 0.5 * sp.pulse_period if sp.load == "pulses" else sp.jerk_rise
            for i in range(sp.cycles):
                a = t0 + i * sp.cycle_period
                ctx.add_bc("force", f"{group}_up_{i}", rod=rope, nodes=nodes, start=a, stop=a + rise,
                           ramp={"from": list(low * axis), "to": list(peak * axis), "duration": rise})
                ctx.add_bc("force", f"{group}_down_{i}", rod=rope, nodes=nodes, start=a + rise, stop=a + 2.0 * rise,
                           ramp={"from": list(peak * axis), "to": list(low * axis), "duration": rise})
            if sp.load == "pulses":
                ctx.add_bc("force", group, rod=rope, nodes=nodes, start=t0 + sp.cycles * sp.cycle_period,
                           force=list(base * axis))

    def prepare(self, ctx: RunContext) -> None:
        plan, geo = ctx.plan, ctx.geometry
        loaded = [(ctx.model.global_nodes(rope, nodes), np.asarray(axis, float),
                   np.mean([geo.ropes[rope][i] for i in nodes], axis=0)) for _, rope, nodes, axis in plan.loaded_local]
        ctx.plan = replace(plan, loaded=loaded)

    def duration(self, ctx: RunContext) -> float:
        """Set, relax and the load stage (``load_time``, or :meth:`SecurityParams.default_load_time`)."""
        sp = ctx.plan.params
        return ctx.t_pre + (sp.load_time if sp.load_time > 0 else sp.default_load_time())

    def _load_force(self, ctx: RunContext, t_load: float, reactions: dict) -> float:
        """The force (N) on the loaded end along its axis: applied, or the reaction while sliding."""
        plan = ctx.plan
        if plan.params.load != "slide" or t_load < 0:
            return load_profile(plan.params, t_load)
        groups = ("load_start", "load") if len(plan.loaded) == 2 else ("load",)
        if not all(g in reactions for g in groups):
            return math.nan
        return float(np.mean([np.dot(reactions[g][:3], a) for g, (_, a, _) in zip(groups, plan.loaded, strict=True)]))

    def record(self, ctx: RunContext, q, t, reactions) -> dict:
        m, plan = ctx.model, ctx.plan
        x = m.node_positions(q)
        # the loaded ends' mean displacement along their own load directions
        u = float(np.mean([np.dot(x[nodes].mean(axis=0) - x0, axis) for nodes, axis, x0 in plan.loaded]))
        f = self._load_force(ctx, float(t) - pull_start(ctx), reactions)
        ropes = [x[m.rod_node_start[r]:m.rod_node_start[r + 1]] for r in range(m.n_rods)]
        delta = float(ctx.params.contact.get("delta", 5e-4))
        total = sum(float(np.sum(np.linalg.norm(np.diff(r, axis=0), axis=1))) for r in ropes)
        row = {"F": f, "F_norm": f * ctx.radius**2 / ctx.EI, "u_pull": u}
        if len(ropes) == 1:
            post = _post(ctx)
            outside = self_tail_lengths(ropes[0], ctx.radius, delta, post)
            # a hitch's tail (its one free end): the rope through the knot draws it in
            has_tail = post is not None and len(plan.loaded) == 1
            tail = outside[plan.all_ends[1][1]] if has_tail else math.nan
            return {**row, "tail_a": tail, "tail_b": 0.0 if has_tail else math.nan, "rope_gap": math.nan,
                    "in_knot": max(total - float(sum(outside)), 0.0), "turn_a": math.nan, "turn_b": math.nan}
        ends = plan.all_ends  # standing ends, then the tails
        outside = tail_lengths(ropes, ends, ctx.radius, delta)
        by_end = {end: length for end, length in zip(ends, outside, strict=True)}
        turn = [turning_in_knot(ropes[r], by_end[(r, 0)], by_end[(r, 1)]) for r in (ends[0][0], ends[1][0])]
        return {**row, "tail_a": outside[2], "tail_b": outside[3], "rope_gap": rope_gap(ropes),
                "in_knot": max(total - float(sum(outside)), 0.0), "turn_a": turn[0], "turn_b": turn[1]}

    def phase(self, ctx: RunContext) -> SetUntilStill | None:
        """With ``set_until_still``: the set, held until the knot stops moving (:class:`SetUntilStill`)."""
        sp = ctx.plan.params
        return SetUntilStill(sp, ctx.t_settle) if sp.set_until_still else None

    def warnings(self, ctx: RunContext, metrics: dict) -> list[tuple[str, str]]:
        """A knot still moving when its set ended (``set_still`` false) was loaded before it was set:
        its loads are those of that moment of a set still under way, not of the set knot."""
        if metrics.get("set_still") is not False:
            return []
        sp = _params(ctx)
        how = "give a longer set_hold_max" if sp.set_until_still else "set set_until_still = true or give a longer set_hold"
        return [(NOT_SET, f"NOT SET: the knot was still moving when the load began (the rope in it changing at "
                          f"{1e3 * metrics['set_creep']:+.3g} mm/s at the end of the set, limit set_still_rate = "
                          f"{1e3 * sp.set_still_rate:g} mm/s): it was loaded before it was set, so this is not a "
                          f"measurement of the set knot; {how}")]

    def stages(self, ctx: RunContext, t_end: float) -> list[tuple[str, float, float]]:
        """Settling (``settle_time``), set (``set_ramp + set_hold``), relax (``relax_time``) and load."""
        ts = ctx.t_settle
        t_set, t_pre = ts + ctx.plan.t_set, ts + ctx.t_pre
        out = [("settle", 0.0, ts), ("set", ts, t_set), ("relax", t_set, t_pre), ("load", t_pre, t_end)]
        return [(n, a, min(b, t_end)) for n, a, b in out if b > a and a < t_end]

    def decision(self, ctx: RunContext, log) -> Decision | None:
        """The earliest decision of the load stage (:func:`~knotsim.protocols.security_metrics.decide`:
        run-away, ropes apart, and outside a ramp capsize and spill), in s of run time."""
        return decide(_params(ctx), measured_log(ctx, log), pull_start(ctx), ctx.radius)

    def metrics(self, ctx: RunContext, log) -> dict[str, Any]:
        sp, norm = _params(ctx), ctx.radius**2 / ctx.EI
        t0 = pull_start(ctx)
        out: dict[str, Any] = {"load": sp.load, "set_tension": sp.set_tension, "set_hold": sp.set_hold,
                               "set_until_still": ctx.phase_record, "set_tension_norm": sp.set_tension * norm,
                               "hold_tension": sp.hold_tension}
        out.update(set_metrics(sp, ctx.t_settle + (sp.set_ramp + sp.set_hold), t0, log))
        plan = ctx.plan
        out.update(bend_names(ctx.geometry, plan.ends if plan is not None else None))
        if "rope_gap" in log.columns and len(log) and np.isfinite(log["rope_gap"].iloc[-1]):  # a bend's two ropes
            gap = float(log["rope_gap"].iloc[-1])
            out.update(rope_gap_final=gap, ropes_apart=bool(gap > APART_RADII * ctx.radius))
        out.update(load_metrics(sp, measured_log(ctx, log), ctx.radius, norm))
        if _post(ctx) is not None and "post_n_contacts" in log.columns and len(log):
            # a hitch or a loop that let go of its post: no node of the rope touches it any more
            out["post_contacts_end"] = int(log["post_n_contacts"].iloc[-1])
            out["off_post"] = bool(out["post_contacts_end"] == 0)
        return out

    def slipped(self, ctx: RunContext, metrics: dict) -> bool:
        return metrics.get("slip_onset") is not None

    def verdict(self, ctx: RunContext, metrics: dict) -> str | None:
        """``capsized`` when a rope was pulled straight through the knot while the other still went
        round it (``capsize_onset``; it names how the knot failed, also when it then came apart), then
        ``untied`` (:func:`~knotsim.protocols.bends.untied`), ``slipped``, ``undecided``, else held."""
        if metrics.get("capsize_onset") is not None:
            return "capsized"
        if metrics.get("off_post"):
            return "untied"
        if untied(metrics, ctx.topology_end):
            return "untied"
        return self.slip_verdict(ctx, metrics)

    def topology_key(self, ctx: RunContext, topo: dict) -> str | None:
        """As for ``two-rope-bend`` (:func:`~knotsim.protocols.bends.bend_topology_key`); a one-rope
        knot, and a hitch or a loop (the rope alone, ends joined far away: the clove hitch an unknot,
        the constrictor a trefoil), by its signature. A rope off its post is told by its contacts
        (``off_post``), not by its topology."""
        ends = ctx.plan.ends if ctx.plan is not None else None
        return bend_topology_key(topo, ends.interleaved) if ends is not None else topo.get("signature")
