"""Protocol ``single-rod-bend``: reef and granny tied in one rod (MAE259B report; docs/physics.md §4.2).

One rod (``E = 0.18 MPa``, ``h = 2 mm``, ``L = 1 m``, ``rho = 1180 kg/m^3``, ``N = 301``,
``dt = 2.5 ms``, contact ``delta = 5e-4 m``, ``nu = 1e-4 m/s``, default ``mu = 0.1``) tied as
``single_rod_reef`` or ``single_rod_granny``. The two end nodes at each end (and, with
``end_twist = "clamped"``, the default, their edge angle; ``"free"`` lets the end edges twist: the
report does not say) are clamped and moved apart along the initial end-to-end axis (horizontal in the drawing) at
``pull_speed`` per end (10 mm/s: the printed 10 cm/s cannot be right for 17 s of pulling a 1 m
rod). With ``held_end`` / ``pulled_end`` (``"ROPE:NODE"``) one end is held still instead (group
``held``, clamped) and the other pulled at ``pull_speed`` (group ``pull_end``). The node given by the knot's ``held`` hint (the bottom of the first overhand) is held static
(:meth:`~knotsim.bc.BoundaryConditions.hold`, positions only) for ``hold_time`` s (default
``None``: the whole run; 0: no hold), which stops the first overhand from inverting. The report
does not say how much of the loop its hold grips: ``hold_nodes`` (odd, default 1) holds that many
consecutive nodes centred on the hint (e.g. 5 nodes = 4 edges, about 13 mm of rod at N = 301).

Pre-tightening (``pre_pull``, default 0 = off): how loose the knot is at the start of the measured
pull is not given by the report, and the library drawings are loose (end-to-end distance about
0.29 L, so about 0.7 m of rod is in the knot). With ``pre_pull = p`` (m) the ends are first moved
apart by a further ``p`` in total (``p / 2`` each) at ``pre_pull_speed`` per end (default: the
``pull_speed``), taking ``t_pre = p / (2 pre_pull_speed)``; the measured pull then follows at
``pull_speed`` without a pause, and every metric and report time below refers to the pull time
``t_pull = t - t_pre`` (the run lasts ``t_pre + mean_window`` unless ``duration`` is given).
``hold_time`` counts from the start of the run.

Per-step log columns: ``F_start``, ``F_end`` (N): axial traction on the clamped end edges
(positive in tension); ``F`` = their mean; ``F_norm = F h^2 / EI``; ``end_to_end`` (m); ``t_pull``
(s, negative during the pre-tightening).

Metrics: mean ``F_norm`` over the pull window ``t_pull in [0, mean_window]`` s (13 s) and its peak
after the start-up ``transient`` (``F_norm_peak`` at ``F_norm_peak_time``, s of the pull),
``F_norm`` at 2.5, 5, 7.5, 10, 12.5 s, and the slip onset (first drop of ``F_norm`` by more than 30 % below
its 0.5 s moving average's running maximum, once that maximum exceeds half the largest averaged
force, after the first max(2 s, 20 %) of the pull, see
:func:`knotsim.protocols.metrics.slip_onset`); a slip is reported as the outcome ``"slipped"``; also
``pre_pull_time`` (s) and ``end_to_end_at_window_start`` (m).

Outcome ``"loose"`` (the knot never tightened; decided before the slip rule, whose threshold is
relative to the largest force and so fires on the wiggles of a loose knot too): the force after
the start-up ``transient`` never leaves the free-rope level, ``F_norm_peak <= free_rope_level``
(:func:`free_rope_level`, in units of EI/h^2). The free-rope level is the largest end force a rope can take without any contact
holding it in the knot's shape, bending plus drag:

* bending: a rope under end tension ``T`` with no contact force on it is a Kirchhoff elastica; with
  straight tails its first integral ``EI kappa^2 / 2 = T (1 - cos theta)`` (``theta`` the tangent's
  angle to the pull) bounds its curvature by ``kappa <= 2 sqrt(T / EI)``. A tight knot bends one
  strand round another of the same rope, at a centreline radius ``loose_bend_radius`` x h
  (default 2: the centreline distance of two strands in contact). Above ``T = EI / (4 (r h)^2)`` a
  free rope cannot keep such a bend, so a larger force means contact holds the knot's strands
  (``F h^2/EI = 1 / (4 r^2)`` = 0.0625 for r = 2);
* drag: the viscous force ``eta v l`` per node, were the whole half-rope moving at the end speed:
  ``eta pull_speed L / 2`` (an upper bound; ~1e-4 EI/h^2 in the shipped set-ups).

The geometric test of the earlier versions (``tightened``: the rope in the knot at the end, its
length minus the end-to-end distance, at most ``loose_factor`` x the ideal tight knot's
ropelength) is still reported but does not decide the outcome: a knot that jams at high friction
keeps more rope in it and still carries load.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from knotsim.errors import ConfigError
from knotsim.protocols.base import LoadingProtocol, RunContext, end_group_nodes, stage_duration, unit
from knotsim.protocols.geometry import one_rope_ends
from knotsim.protocols.metrics import (
    ideal_ropelength,
    moving_average,
    slip_onset,
    window_mean,
    window_peak_at,
)
from knotsim.protocols.timeline import measured_log, pull_start

#: Times (s) at which F h^2/EI was read off the published figure.
REPORT_TIMES = (2.5, 5.0, 7.5, 10.0, 12.5)


def free_rope_level(params, EI: float, radius: float, length: float) -> float:
    """Free-rope force level of the ``loose`` rule, in units of ``EI / h^2`` (dimensionless): the
    largest tension at which a rope with no contact force on it can keep a bend of centreline radius
    ``loose_bend_radius`` x ``radius`` (Kirchhoff elastica, ``T = EI / (4 (r h)^2)``), plus the
    viscous drag of half the rope moving at ``pull_speed`` (``damping pull_speed length / 2``, N).
    ``EI`` in N m^2, ``radius`` (h) and ``length`` (L) in m; ``params`` holds ``loose_bend_radius``
    (-), ``damping`` (Pa s) and ``pull_speed`` (m/s). See the module docstring."""
    r = params["loose_bend_radius"]
    if not (isinstance(r, int | float) and r > 0 and math.isfinite(r)):
        raise ConfigError("loose_bend_radius", f"must be a positive number of rod radii, got {r!r}")
    bend = 1.0 / (4.0 * float(r) ** 2)
    drag = float(params["damping"]) * float(params["pull_speed"]) * float(length) / 2.0
    return bend + drag * radius**2 / EI


def pre_pull_time(params, moving_ends: int = 2) -> float:
    """Duration (s) of the pre-tightening: ``pre_pull / (moving_ends pre_pull_speed)`` (both ends
    move by default, 1 when one end is held; 0 when off; the speed defaults to ``pull_speed``; see
    :func:`~knotsim.protocols.base.stage_duration` for the errors)."""
    v = params["pre_pull_speed"]
    v = params["pull_speed"] if v is None else v
    return stage_duration(params["pre_pull"], v, "pre_pull", "pre_pull_speed") / moving_ends


@dataclass(frozen=True)
class SingleRodPlan:
    """The run of a single-rod bend: ``axis`` (3,) unit vector from the start end to the pulled end,
    the reaction group of the start end (``start_group``) and the held nodes of the knot
    (``held_nodes``, local indices)."""

    axis: np.ndarray
    start_group: str
    held_nodes: list[int]


class SingleRodBend(LoadingProtocol):
    name = "single-rod-bend"
    event_time_keys = ("F_norm_peak_time",)
    description = "Pull the two ends of a one-rod reef/granny apart, bottom of the first overhand held (MAE259B)"
    kinds = ("single_rod_bend",)
    default_knot = "single_rod_reef"
    defaults = {
        "n_nodes": 301,
        "radius": 2e-3,
        "length": 1.0,
        "mu": 0.1,
        "dt": 2.5e-3,
        "contact.delta": 5e-4,
        "contact.nu": 1e-4,
        "pull_speed": 0.01,     # m/s per end
        "mean_window": 13.0,    # s
        "hold_time": None,      # s, how long the held node stays held (None: the whole run)
        "hold_nodes": 1,        # consecutive nodes held, centred on the knot's hold hint (odd)
        "pre_pull": 0.0,        # m, end-to-end separation added before the measured pull (0: none)
        "pre_pull_speed": None,  # m/s per end during the pre-tightening (None: pull_speed)
        "end_twist": "clamped",  # "clamped": the pulled end edges keep their angle; "free": they may twist
        "held_end": "",         # "ROPE:NODE" held still ("": both ends pulled apart)
        "pulled_end": "",       # "ROPE:NODE" pulled ("": the last node's end)
        "transient": 1.0,       # s of the pull left out of the peak (start-up ringing of the abrupt start)
        "loose_bend_radius": 2.0,  # h; loose: F_norm after the transient never above the free-rope level
        "loose_factor": 3.0,    # reported only: 'tightened' = rope in the knot <= loose_factor x ideal ropelength
        "output_interval": 0.1,
    }
    fixed_geometry = ("n_nodes", "radius", "length")
    # quick: the coarse drawing settles 1 s with its ends held, so that the first figure shows the
    # knot's force, not the drawing's start-up ringing (F h^2/EI -0.03 ... +0.03)
    quick = {"n_nodes": 101, "dt": 5e-3, "duration": 2.0, "mean_window": 2.0, "output_interval": 0.5,
             "settle_time": 1.0}

    def setup(self, ctx: RunContext) -> None:
        x = ctx.geometry.ropes[0]
        n = len(x)
        start, end, held_end = one_rope_ends(ctx.geometry, ctx.params["held_end"], ctx.params["pulled_end"])
        axis = unit(x[end.node] - x[start.node])
        start_nodes, end_nodes = end_group_nodes(start.node, n), end_group_nodes(end.node, n)
        twist = ctx.params["end_twist"]
        if twist not in ("clamped", "free"):
            raise ConfigError("end_twist", f"must be 'clamped' or 'free', got {twist!r}")
        twist = twist == "clamped"
        v = float(ctx.params["pull_speed"])
        t_pre = pre_pull_time(ctx.params, 1 if held_end else 2)
        ctx.t_pre = t_pre
        if held_end:
            ctx.add_bc("clamp", "held", rod=0, nodes=start_nodes, twist=twist)
        if t_pre > 0:
            if float(ctx.params["ramp_time"]) > 0:
                raise ConfigError("ramp_time", "a smooth start goes with the plain pull; with pre_pull the ends "
                                               "already move when the measured pull starts")
            v_pre = float(ctx.params["pre_pull_speed"] or v)
            # each end: pre-tightening at v_pre for t_pre, then the measured pull at v
            moving = [("pull_end", end_nodes, 1.0)] if held_end else [("pull_start", start_nodes, -1.0),
                                                                      ("pull_end", end_nodes, 1.0)]
            for gname, nodes, sign in moving:
                ctx.add_bc("move", gname, rod=0, nodes=nodes, twist=twist, waypoints={
                    "times": [0.0, t_pre], "points": [[0.0, 0.0, 0.0], list(sign * v_pre * t_pre * axis)],
                    "then_velocity": list(sign * v * axis)})
        else:
            ramp = float(ctx.params["ramp_time"]) or None
            if not held_end:
                ctx.add_bc("move", "pull_start", rod=0, nodes=start_nodes, velocity=list(-v * axis), twist=twist,
                           ramp_time=ramp)
            ctx.add_bc("move", "pull_end", rod=0, nodes=end_nodes, velocity=list(v * axis), twist=twist,
                       ramp_time=ramp)
        width = ctx.params["hold_nodes"]
        if not (isinstance(width, int) and width >= 1 and width % 2 == 1):
            raise ConfigError("hold_nodes", f"must be an odd number of nodes >= 1, got {width!r}")
        held = sorted({min(max(h.node + k, 2), n - 3) for h in ctx.geometry.held if h.rope == 0
                       for k in range(-(width // 2), width // 2 + 1)})
        ht = ctx.params["hold_time"]
        hold_time = math.inf if ht is None else float(ht)
        if held and hold_time > 0:
            ctx.add_bc("hold", "knot_hold", rod=0, nodes=held, stop=None if math.isinf(hold_time) else hold_time)
        ctx.plan = SingleRodPlan(axis, "held" if held_end else "pull_start", held)

    def duration(self, ctx: RunContext) -> float:
        return ctx.t_pre + float(ctx.params["mean_window"])

    def record(self, ctx: RunContext, q, t, reactions) -> dict:
        m = ctx.model
        axis = ctx.plan.axis
        x0 = q[m.node_dof[0]:m.node_dof[0] + 3]
        x1 = q[m.node_dof[-1]:m.node_dof[-1] + 3]
        f_end = float(np.dot(reactions["pull_end"][:3], axis))
        f_start = -float(np.dot(reactions[ctx.plan.start_group][:3], axis))
        f = 0.5 * (f_start + f_end)
        x = m.node_positions(q)
        contour = float(np.sum(np.linalg.norm(np.diff(x, axis=0), axis=1)))
        return {"F": f, "F_start": f_start, "F_end": f_end, "F_norm": f * ctx.radius**2 / ctx.EI,
                "end_to_end": float(np.linalg.norm(x1 - x0)), "contour_length": contour,
                "t_pull": float(t) - pull_start(ctx)}

    def metrics(self, ctx: RunContext, log) -> dict:
        w = float(ctx.params["mean_window"])
        t_pre = float(ctx.t_pre)
        # metrics on the pull time (after any settle_time and pre-pull), restricted to the measured pull
        log = measured_log(ctx, log)
        if not len(log):
            return {"pre_pull_time": t_pre}
        t = np.asarray(log["time"], float)
        transient = float(ctx.params["transient"])
        if not transient >= 0:
            raise ConfigError("transient", f"must be a duration >= 0 in s, got {transient!r}")
        peak, t_peak = window_peak_at(log, "F_norm", transient, w) if t[-1] > transient else (None, None)
        out = {
            "F_norm_mean": window_mean(log, "F_norm", 0.0, w),
            "F_norm_peak": peak,
            "F_norm_peak_time": t_peak,
            "mean_window": w,
            "F_norm_final": window_mean(log, "F_norm", float(log["time"].iloc[-1]) - 0.25),  # last 0.25 s
            "pre_pull_time": t_pre,
            "end_to_end_at_window_start": float(log["end_to_end"].iloc[0]),
        }
        for tr in REPORT_TIMES:
            if tr <= t[-1] + 1e-9:
                k = slice(max(0, int(np.searchsorted(t, tr)) - 2), int(np.searchsorted(t, tr)) + 3)
                out[f"F_norm_at_{tr:g}s"] = float(np.mean(log["F_norm"].iloc[k]))
        t_skip = max(0.2 * t[-1], 2.0)  # skip the start-up transient
        fmax = float(np.max(moving_average(log, "F_norm", 0.5)[t >= t_skip])) if t[-1] > t_skip else 0.0
        onset = slip_onset(log, "F_norm", mode="drop", drop_fraction=0.3,
                           min_force=0.5 * max(fmax, 1e-12), smooth=0.5, t0=t_skip)
        out["slip_onset"] = onset
        # tightness: rope still in the knot (the rope's current length minus the end-to-end distance,
        # so that stretch does not count) against the ideal tight knot's ropelength
        in_knot = float(log["contour_length"].iloc[-1] - log["end_to_end"].iloc[-1])
        topo = ctx.topology_end or {}
        ideal = ideal_ropelength(topo.get("rolfsen"))
        out["rope_in_knot_final"] = in_knot
        out["ideal_rope_in_knot"] = None if ideal is None else ideal * 2.0 * ctx.radius
        factor = float(ctx.params["loose_factor"])
        out["tightened"] = None if ideal is None else bool(in_knot <= factor * ideal * 2.0 * ctx.radius)
        # loose: the force after the start-up transient never leaves the free-rope level
        level = free_rope_level(ctx.params, ctx.EI, ctx.radius, ctx.length)
        out["free_rope_level"] = level
        peak = out["F_norm_peak"]
        out["left_free_rope_level"] = None if peak is None else bool(peak > level)
        # the slip rule needs 1 s of pull after its start-up skip to see a drop
        out["decidable"] = bool(t[-1] >= t_skip + 1.0)
        return out

    def slipped(self, ctx: RunContext, metrics: dict) -> bool:
        return metrics.get("slip_onset") is not None

    def verdict(self, ctx: RunContext, metrics: dict) -> str | None:
        """``loose`` when the force after the start-up transient never left the free-rope level
        (``left_free_rope_level`` false: ``F_norm_peak <= free_rope_level``, see
        :func:`free_rope_level`; the knot never tightened, so a drop of that force is no slip), else
        ``slipped`` (a force drop), else ``undecided`` when the pull was too short for the slip rule
        (shorter than its skip + 1 s), else held. The geometric ``tightened`` does not decide."""
        if metrics.get("left_free_rope_level") is False:
            return "loose"
        return self.slip_verdict(ctx, metrics)

