"""Protocol ``two-rope-bend``: bends tied between two ropes (Patil et al., Science 2020;
docs/physics.md §4.3).

Reef, granny, thief and grief bends (``reef_bend``, ``granny_bend``, ``thief_bend``,
``grief_bend``; ``h = 2 mm``, ``L = 1 m`` per rope, ``N = 301``). Loading as in Patil's study: the
end of rope A named by the knot's ``held`` hint is clamped (its two end nodes and their edge
angle), the end of rope B named by the ``pulled`` hint is pulled away along the axis from the
held end to the pulled end, the two other ends (the tails) are free. Patil's friction was a
viscous coupling, so only the ranking of the bends carries over, not the numbers; the default
``mu`` is 0.3, the default time step 2 ms (none published). The loose drawings snap their ring
strands together at t = 0.16 s (contacts jump from about 15 to 80 in 40 ms); Newton used to cycle
there at every step size (grief at 2.5 ms, thief at 1 and 1.5 ms, granny and grief at mu = 0.5);
the safeguard of :func:`knotsim.solver.newton.newton_solve` removed those stalls.

Two modes (parameter ``mode``):

* ``"displacement"``: the pulled end (two nodes + edge angle) moves at ``pull_speed`` (m/s,
  default 10 mm/s) for ``pull_length`` (m, default 0.4: 40 s) unless ``duration`` is given;
  recorded: the axial reaction ``F`` (N) there;
* ``"force"``: a total force ``F = force_rate * t`` (N, ``force_rate`` in N/s) along the axis is
  applied to the two pulled end nodes (twist free) for 40 s unless ``duration`` is given;
  recorded: the applied ``F``.

Cinching stage (``pre_tighten``, m, default 0 = off): the library bends are drawn loose, and
Patil compared tightened bends. With ``pre_tighten = p`` all four ends (two end nodes and their
edge angle each) first move outwards along their own end tangents by ``p`` at
``pre_tighten_speed`` (m/s), taking ``t_pre = p / pre_tighten_speed``; then the tails are released,
the held end stays where it got to, and the pull (or the force ramp) starts. The metrics refer to
the pull after ``t_pre`` (their times count from ``t_pre``); the run lasts ``t_pre`` longer.

In both modes the log has ``F``, ``F_norm = F h^2 / EI``, ``F_held`` (N, axial reaction at the
held end, positive in tension), ``u_pull`` (m): displacement of the pulled end along the axis
since the start, the tail lengths ``tail_a``, ``tail_b`` (m) and ``rope_gap`` (m): the smallest
distance between a node of one rope and a node of the other.

Tail length (definition): the arc length from a free end, walking inwards, to where the rope
first comes within ``2h + delta + l/2`` (``l`` the mean edge length) of a node of the *other* rope,
interpolated along the edge between the last node outside and the first inside from their
distances (so it changes continuously as rope slides through, not in steps of one edge), i.e.
the length of the free tail outside the knot (a bend is held by the two ropes interlocking; a
tail lying on its own standing part away from the knot does not count). Tail draw-in = decrease of the tail length over the
run (positive when the knot swallows its tails); the pulled-end draw-in is the increase of
``u_pull``. In force control ``u_pull`` is the displacement that answers the applied force.

Topology check (start and end): the two ropes, each closed on itself (radial closure), are a
two-component link; the key compared is each rope's own knot type, the linking number and the
link's Jones polynomial (:func:`link_key`). A different key is ``changed knot type``; a split link
at the end (linking number 0, Jones polynomial of the split link of the ropes' own knots) is
``untied``. The ropes of the reef and thief bends, closed on themselves, are an unlink from the
start, so for them (and any bend whose link is split) ``untied`` is decided by geometry: the ropes
are apart at the end (no node of one within ``4h`` of the other, ``rope_gap_final``). The whole-bend
closure :func:`~knotsim.knots.topology.close_bend` (standing ends joined, tails joined) names a bend but moves with the
loose tails and is not used for the outcome.

Metrics (times in s from the start of the pull, after any ``settle_time`` and cinching stage):
mean ``F_norm`` over the pull and its peak after the start-up transient (``F_norm_peak`` at
``F_norm_peak_time``: the loose drawing rings the rope as its strands snap together, far above the
load the bend then holds); the holding force ``F_norm_hold``: the largest
0.5 s moving average of ``F_norm`` after the start-up transient (the first ``transient`` s,
default 2 s), i.e. the peak force the bend carries before or while it gives way; tail and
pulled-end draw-in; and the slip onset, which decides the outcome ``"slipped"``:

* displacement control: the two free tails are drawn into the knot together faster than
  ``slip_draw_in_rate`` x ``pull_speed`` (default 0.25; tail lengths on a 2 s centred average)
  for at least ``slip_hold`` s (default 2 s) after the transient
  (:func:`knotsim.protocols.metrics.draw_in_onset`). A bend's pull force need not drop when it
  slips: a tightened bend whose tails run in loses only ~15 % of its force, and a loose bend
  slides from the start with no peak to drop from, so the force-drop rule (first drop of the
  0.5 s average by more than 30 % below its running maximum, once that exceeds half the largest
  averaged force) is only reported, as ``force_drop_onset``;
* force control: the pulled end runs away, its speed (displacement on a 0.5 s average) above
  ``runaway_speed`` for 0.5 s after the transient; ``F_norm_hold`` is then the applied force at
  the onset (the largest applied force when the bend never runs away).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from knotsim.errors import ConfigError
from knotsim.protocols.base import LoadingProtocol, RunContext, end_group_nodes, stage_duration, unit
from knotsim.protocols.bends import BendEnds, bend_ends, bend_names, bend_topology_key, untied
from knotsim.protocols.metrics import (
    draw_in_onset,
    moving_average,
    slip_onset,
    sustained_onset,
    tail_draw_in,
    window_mean,
    window_peak_at,
)
from knotsim.protocols.rope_measures import APART_RADII, end_direction, rope_gap, tail_lengths
from knotsim.protocols.timeline import measured_log, pull_start


def pre_tighten_time(params) -> float:
    """Duration (s) of the cinching stage, ``pre_tighten / pre_tighten_speed`` (0 when off; see
    :func:`~knotsim.protocols.base.stage_duration` for the errors)."""
    return stage_duration(params["pre_tighten"], params["pre_tighten_speed"], "pre_tighten", "pre_tighten_speed")


@dataclass(frozen=True)
class TwoRopePlan:
    """The run of a two-rope bend: its ends (:class:`~knotsim.protocols.bends.BendEnds`), ``axis``
    (3,) unit vector from the held end to the pulled end, the pulled end's group (``pull_rope``,
    ``pull_local``: local node indices; ``pull_nodes``: global, once the model exists) and its
    starting centre ``x_pull0`` (3,) m."""

    ends: BendEnds
    axis: np.ndarray
    pull_rope: int
    pull_local: list[int]
    x_pull0: np.ndarray
    pull_nodes: np.ndarray | None = None


class TwoRopeBend(LoadingProtocol):
    name = "two-rope-bend"
    event_time_keys = ("F_norm_peak_time",)
    description = "Hold one end of rope A, pull the far end of rope B, tails free (Patil et al. 2020)"
    kinds: tuple[str, ...] = ("bend",)
    default_knot = "reef_bend"
    defaults = {
        "mu": 0.3,
        "dt": 2e-3,  # s; no published value
        "mode": "displacement",
        "held_end": "",        # "ROPE:NODE" of the held end ("": the knot's hint)
        "pulled_end": "",      # "ROPE:NODE" of the pulled end ("": the knot's hint)
        "pull_speed": 0.01,    # m/s (displacement mode)
        "pull_length": 0.4,    # m pulled in displacement mode when no duration is given
        "pre_tighten": 0.0,    # m each of the four ends moves outwards first (0: no cinching stage)
        "pre_tighten_speed": 0.01,  # m/s per end during the cinching stage
        "force_rate": 0.05,    # N/s (force mode)
        "runaway_speed": 0.05,  # m/s, force mode: pulled end faster than this = slipping
        "transient": 2.0,          # s, start-up transient left out of the holding force and slip detection
        "slip_draw_in_rate": 0.25,  # tails drawn in faster than this x pull_speed = slipping
        "slip_hold": 2.0,          # s, the fast draw-in must last this long
        "output_interval": 0.1,
    }
    quick = {"n_nodes": 101, "dt": 5e-3, "duration": 1.5, "output_interval": 0.5, "transient": 0.3}

    def setup(self, ctx: RunContext) -> None:
        geo = ctx.geometry
        if len(geo.ropes) != 2:
            raise ConfigError("knot", f"two-rope-bend needs a knot of two ropes, {geo.name!r} has {len(geo.ropes)}")
        ends = bend_ends(geo, ctx.params)
        mode = ctx.params["mode"]
        if mode not in ("displacement", "force"):
            raise ConfigError("mode", f"must be 'displacement' or 'force', got {mode!r}")
        held, pulled = ends.held, ends.pulled
        axis = unit(geo.ropes[pulled.rope][pulled.node] - geo.ropes[held.rope][held.node])
        # each group sized by its own rope's node count (the ropes may differ in length and resolution)
        pull_nodes = end_group_nodes(pulled.node, len(geo.ropes[pulled.rope]))
        held_nodes = end_group_nodes(held.node, len(geo.ropes[held.rope]))
        ctx.t_pre = t_pre = pre_tighten_time(ctx.params)
        if t_pre > 0:
            self._cinch(ctx, ends, held_nodes)
        else:
            ctx.add_bc("clamp", "held", rod=held.rope, nodes=held_nodes)
        d_pull = end_direction(geo.ropes[pulled.rope], pulled.node) if t_pre > 0 else axis
        if mode == "displacement":
            v = float(ctx.params["pull_speed"])
            if t_pre > 0:
                ctx.add_bc("move", "pull", rod=pulled.rope, nodes=pull_nodes,
                           waypoints=self._out(ctx, d_pull, v * axis))
            else:
                ctx.add_bc("move", "pull", rod=pulled.rope, nodes=pull_nodes, velocity=list(v * axis),
                           ramp_time=float(ctx.params["ramp_time"]) or None)
        else:
            if t_pre > 0:
                ctx.add_bc("move", "pre_pull", rod=pulled.rope, nodes=pull_nodes, waypoints=self._out(ctx, d_pull),
                           stop=t_pre)
            ctx.add_bc("force", "pull", rod=pulled.rope, nodes=pull_nodes, start=t_pre,
                       ramp={"from": [0.0, 0.0, 0.0], "rate": list(float(ctx.params["force_rate"]) * axis)})
        ctx.plan = TwoRopePlan(ends, axis, pulled.rope, list(pull_nodes),
                               np.mean([geo.ropes[pulled.rope][i] for i in pull_nodes], axis=0))

    @staticmethod
    def _out(ctx: RunContext, d: np.ndarray, then=None) -> dict:
        """Waypoints of a cinched end: out along ``d`` (unit) at ``pre_tighten_speed`` for ``ctx.t_pre``
        s, then at the velocity ``then`` (m/s) or still."""
        v_pre, t_pre = float(ctx.params["pre_tighten_speed"]), ctx.t_pre
        w = {"times": [0.0, t_pre], "points": [[0.0, 0.0, 0.0], list(v_pre * t_pre * d)]}
        if then is not None:
            w["then_velocity"] = list(then)
        return w

    def _cinch(self, ctx: RunContext, ends: BendEnds, held_nodes) -> None:
        """The cinching stage's groups: the held end and both tails move outwards along their own end
        tangents; then the tails are released and the held end stays where it got to."""
        geo, held = ctx.geometry, ends.held
        ctx.add_bc("move", "held", rod=held.rope, nodes=held_nodes,
                   waypoints=self._out(ctx, end_direction(geo.ropes[held.rope], held.node)))
        for name, (rope, end) in zip(("tail_a", "tail_b"), ends.free_ends, strict=True):
            n = len(geo.ropes[rope])
            node = 0 if end == 0 else n - 1
            ctx.add_bc("move", f"pre_{name}", rod=rope, nodes=end_group_nodes(node, n),
                       waypoints=self._out(ctx, end_direction(geo.ropes[rope], node)), stop=ctx.t_pre)

    def prepare(self, ctx: RunContext) -> None:
        plan = ctx.plan
        ctx.plan = replace(plan, pull_nodes=ctx.model.global_nodes(plan.pull_rope, plan.pull_local))

    def duration(self, ctx: RunContext) -> float:
        """Default run length (s): ``pull_length / pull_speed`` in displacement control (400 mm of
        pull: the loose library bends are flattened and the reef and granny slip after about
        300 mm, see ``validation/reports/knots_bends.md``), 40 s in force control."""
        t_pre = ctx.t_pre
        if ctx.params["mode"] == "displacement":
            ramp = 0.5 * float(ctx.params["ramp_time"]) if t_pre == 0 else 0.0  # a ramp over T loses T/2 at full speed
            return t_pre + float(ctx.params["pull_length"]) / float(ctx.params["pull_speed"]) + ramp
        return t_pre + 40.0

    def closure(self, ctx: RunContext, curves):
        """The two ropes, each closed on itself (:func:`~knotsim.knots.topology.close_curves`,
        radial): a two-component link whose invariants (each rope's knot type, the linking number,
        the Jones polynomial) change only when rope passes through rope. (The bend closure of
        :func:`~knotsim.knots.topology.close_bend`, which joins the standing ends together and the tails together, names the
        bend but depends on where the loose tails lie: it flagged hunter's, Ashley's and the double
        fisherman's bends as changed and the alpine butterfly as untied after 0.3 s of pull.)"""
        return [np.asarray(c, float) for c in curves], None, None

    def record(self, ctx: RunContext, q, t, reactions) -> dict:
        m = ctx.model
        plan = ctx.plan
        axis = plan.axis
        x = m.node_positions(q)
        u = float(np.dot(x[plan.pull_nodes].mean(axis=0) - plan.x_pull0, axis))
        if ctx.params["mode"] == "displacement":
            f = float(np.dot(reactions["pull"][:3], axis))
        else:
            f = float(ctx.params["force_rate"]) * max(float(t) - pull_start(ctx), 0.0)  # the applied ramp
        f_held = -float(np.dot(reactions["held"][:3], axis))
        ropes = [x[m.rod_node_start[r]:m.rod_node_start[r + 1]] for r in range(m.n_rods)]
        delta = float(ctx.params.contact.get("delta", 5e-4))
        ta, tb = tail_lengths(ropes, plan.ends.free_ends, ctx.radius, delta)
        return {"F": f, "F_norm": f * ctx.radius**2 / ctx.EI, "F_held": f_held, "u_pull": u,
                "tail_a": ta, "tail_b": tb, "rope_gap": rope_gap(ropes)}

    def metrics(self, ctx: RunContext, log) -> dict:
        t_pre = float(ctx.t_pre)
        if pull_start(ctx) > 0:  # metrics on the pull after settling and cinching, time from its start
            log = measured_log(ctx, log)
            if len(log) < 2:
                return {"mode": ctx.params["mode"], "pre_tighten_time": t_pre}
        t = np.asarray(log["time"], float)
        t_skip = float(ctx.params["transient"])
        if not t_skip >= 0:
            raise ConfigError("transient", f"must be a duration >= 0 in s, got {t_skip!r}")
        peak, t_peak = window_peak_at(log, "F_norm", t_skip) if t[-1] > t_skip else (None, None)
        out = {
            "mode": ctx.params["mode"],
            "pre_tighten_time": t_pre,
            "F_norm_mean": window_mean(log, "F_norm"),
            "F_norm_peak": peak,  # after the start-up transient, as F_norm_hold
            "F_norm_peak_time": t_peak,
            "F_norm_final": window_mean(log, "F_norm", float(log["time"].iloc[-1]) - 0.25),  # last 0.25 s
            "tail_a_draw_in": tail_draw_in(log, "tail_a"),
            "tail_b_draw_in": tail_draw_in(log, "tail_b"),
            "pull_draw_in": tail_draw_in(log, "u_pull", kind="increase"),
        }
        out.update(bend_names(ctx.geometry, ctx.plan.ends if ctx.plan is not None else None))
        if "rope_gap" in log.columns:
            gap = float(log["rope_gap"].iloc[-1])
            out["rope_gap_final"] = gap
            out["ropes_apart"] = bool(gap > APART_RADII * ctx.radius)
        p = ctx.params
        after = t >= t_skip
        need = float(p["slip_hold"]) + 2.0 if p["mode"] == "displacement" else 0.5
        out["decidable"] = bool(t[-1] - t_skip >= need)
        f_avg = moving_average(log, "F_norm", 0.5)
        if p["mode"] == "displacement":
            fmax = float(np.max(f_avg[after])) if after.any() else 0.0
            out["F_norm_hold"] = fmax if after.any() else None
            out["force_drop_onset"] = slip_onset(log, "F_norm", mode="drop", drop_fraction=0.3,
                                                 min_force=0.5 * max(fmax, 1e-12), smooth=0.5, t0=t_skip)
            rate = float(p["slip_draw_in_rate"]) * float(p["pull_speed"])
            out["slip_onset"] = draw_in_onset(log, ["tail_a", "tail_b"], rate, smooth=2.0,
                                              hold=float(p["slip_hold"]), t0=t_skip)
        else:
            u = moving_average(log, "u_pull", 0.5)
            speed = np.gradient(u, t) if len(t) > 2 else np.zeros_like(u)
            k = sustained_onset(t, after & (speed > float(p["runaway_speed"])), 0.5)
            f = np.asarray(log["F_norm"], float)
            out["slip_onset"] = (None if k is None else
                                 {"time": float(t[k]), "force": float(f[k]), "detected_at": float(t[k]),
                                  "criterion": "runaway"})
            out["F_norm_hold"] = float(f[k] if k is not None else f[-1])
        return out

    def topology_key(self, ctx: RunContext, topo: dict) -> str | None:
        """What must stay equal for the bend to count as unchanged
        (:func:`~knotsim.protocols.bends.bend_topology_key`)."""
        return bend_topology_key(topo, bool(ctx.plan is not None and ctx.plan.ends.interleaved))

    def slipped(self, ctx: RunContext, metrics: dict) -> bool:
        return metrics.get("slip_onset") is not None

    def verdict(self, ctx: RunContext, metrics: dict) -> str | None:
        """``untied`` when the two ropes are apart at the end (no nodes within ``4h``,
        :data:`~knotsim.protocols.rope_measures.APART_RADII`) and their link is split
        (:func:`~knotsim.protocols.bends.untied`), else ``slipped``, else ``undecided`` when the pull
        after the transient is shorter than the evidence the slip rule needs (``slip_hold`` plus its
        2 s smoothing in displacement control, 0.5 s in force control), else held."""
        if untied(metrics, ctx.topology_end):
            return "untied"
        return self.slip_verdict(ctx, metrics)

