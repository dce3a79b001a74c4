"""Protocol ``overhand-pull``: tightening of an open overhand knot (Choi, Tong & Jawed 2021;
docs/physics.md §4.1).

One rod (``L = 1 m``, ``N = 301``, ``h = 1.6 mm``, ``rho = 1180 kg/m^3``, ``E = 0.18 MPa``,
Poisson 0.5, ``eta = 0.01 Pa s``, ``mu = 0.1``, ``dt = 0.5 ms``) tied as a loose overhand knot
``overhand_n1`` ... ``overhand_n4``. The two end nodes at each end (and the angle of the edge
between them) are clamped and moved apart along the initial end-to-end axis at ``pull_speed``
(6 mm/s) each. With ``held_end`` / ``pulled_end`` (``"ROPE:NODE"``) one end is instead held still
(group ``held``) and the other pulled at ``pull_speed`` (group ``pull_end``), so ``e`` shrinks at
``pull_speed`` instead of twice that. The run lasts until the shortening ``e`` reaches ``e_final``
(0.25 m) unless ``duration`` is given.

Per-step log columns:

- ``F`` (N): axial reaction on the clamped nodes of the pulled end (``pull_end``: the last node's
  end unless ``pulled_end`` says otherwise; positive in tension); ``F_start`` (N): the same at the
  other end (``pull_start``, or ``held``);
- ``F_norm = F h^2 / EI``;
- ``end_to_end`` (m) = ``|x_{N-1} - x_0|``; ``e = L - end_to_end`` (m); ``R = e / 2 pi`` (m);
  ``sqrt_h_over_R = sqrt(h / R)``.

Metrics (times in s of the pull, from its start after any ``settle_time``): ``F_norm`` at
``e = 0.4, 0.35, 0.3, 0.25 m``, the peak ``F_norm_peak`` after the start-up ``transient`` (default
2 s: the drawn knot rings the rope at the start, its end reactions swinging far above and below the
force the knot carries) and its time ``F_norm_peak_time``, the final ``e`` and ``F_norm`` (mean over
the last 0.25 s), and ``force_drop``: the first sudden drop of ``F_norm`` (loop inversion, see
:func:`knotsim.protocols.metrics.slip_onset`, drop > 20 % of the running maximum, the first
``transient`` or 10 % of the pull, whichever is longer, ignored), or ``None``.

``--quick``: N = 81, dt = 5 ms, 30 mm/s per end to ``e = 0.29 m``; the ends are held still for the
first second (``settle_time``: the drawn knot settles and its ringing dies down while they are held),
then the pull speed grows over 0.5 s (``ramp_time``), and the peak is taken after that ramp
(``transient`` 0.5 s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from knotsim.protocols.base import LoadingProtocol, RunContext, end_group_nodes, unit
from knotsim.protocols.geometry import one_rope_ends
from knotsim.protocols.metrics import force_at, moving_average, slip_onset, window_mean, window_peak_at
from knotsim.protocols.timeline import measured_log


def force_drop(log, transient: float = 0.0) -> dict | None:
    """First sudden drop of ``F_norm`` (loop inversion): more than 20 % below the running maximum of
    the 0.5 s moving average, once that maximum exceeds a quarter of the largest (averaged) force;
    the first ``transient`` s or 10 % of the record (``time`` in s from the start of the pull),
    whichever is longer, is skipped as start-up transient. ``None`` if there is none."""
    t_skip = max(float(transient), 0.1 * float(log["time"].iloc[-1]))
    late = np.asarray(log["time"] >= t_skip)
    fmax = float(np.max(moving_average(log, "F_norm", 0.5)[late])) if late.any() else 0.0
    return slip_onset(log, "F_norm", mode="drop", drop_fraction=0.2, min_force=0.25 * max(fmax, 1e-12),
                      smooth=0.5, t0=t_skip)


@dataclass(frozen=True)
class OverhandPlan:
    """The run of an overhand pull: ``axis`` (3,) unit vector from the start end to the pulled end,
    ``e0`` (m) the shortening of the drawn knot, the reaction group of the start end
    (``start_group``) and ``separation_speed`` (m/s, the rate at which ``e`` shrinks)."""

    axis: np.ndarray
    e0: float
    start_group: str
    separation_speed: float


class OverhandPull(LoadingProtocol):
    name = "overhand-pull"
    event_time_keys = ("F_norm_peak_time",)
    description = "Tighten an open overhand knot by pulling both clamped ends apart (Choi et al. 2021)"
    kinds = ("overhand",)
    default_knot = "overhand_n1"
    defaults = {
        "n_nodes": 301,
        "radius": 1.6e-3,
        "length": 1.0,
        "mu": 0.1,
        "dt": 5e-4,
        "pull_speed": 6e-3,   # m/s per end
        "e_final": 0.25,      # m, end of the pull (when duration is None)
        "held_end": "",       # "ROPE:NODE" held still ("": both ends pulled apart)
        "pulled_end": "",     # "ROPE:NODE" pulled and measured ("": the last node's end)
        "transient": 2.0,     # s of the pull left out of the peak (start-up ringing of the drawn knot)
        "output_interval": 0.25,
    }
    fixed_geometry = ("n_nodes", "radius", "length")
    quick = {"n_nodes": 81, "dt": 5e-3, "pull_speed": 0.03, "e_final": 0.29, "output_interval": 0.5,
             "settle_time": 1.0, "ramp_time": 0.5, "transient": 0.5}

    def setup(self, ctx: RunContext) -> None:
        x = ctx.geometry.ropes[0]
        start, end, held = one_rope_ends(ctx.geometry, ctx.params["held_end"], ctx.params["pulled_end"])
        axis = unit(x[end.node] - x[start.node])
        v = float(ctx.params["pull_speed"])
        ctx.plan = OverhandPlan(axis, ctx.length - float(np.linalg.norm(x[-1] - x[0])),
                                "held" if held else "pull_start", v if held else 2.0 * v)
        ramp = float(ctx.params["ramp_time"]) or None
        n = len(x)
        if held:
            ctx.add_bc("clamp", "held", rod=0, nodes=end_group_nodes(start.node, n))
        else:
            ctx.add_bc("move", "pull_start", rod=0, nodes=end_group_nodes(start.node, n), velocity=list(-v * axis),
                       ramp_time=ramp)
        ctx.add_bc("move", "pull_end", rod=0, nodes=end_group_nodes(end.node, n), velocity=list(v * axis),
                   ramp_time=ramp)

    def duration(self, ctx: RunContext) -> float:
        ef = float(ctx.params["e_final"])
        # a ramp of the pull speed over T loses T/2 of the travel at full speed
        ramp = 0.5 * float(ctx.params["ramp_time"])
        return max(ctx.plan.e0 - ef, 0.01 * ctx.length) / float(ctx.plan.separation_speed) + ramp

    def record(self, ctx: RunContext, q, t, reactions) -> dict:
        m = ctx.model
        axis = ctx.plan.axis
        x0 = q[m.node_dof[0]:m.node_dof[0] + 3]
        x1 = q[m.node_dof[-1]:m.node_dof[-1] + 3]
        ee = float(np.linalg.norm(x1 - x0))
        e = ctx.length - ee
        f_end = float(np.dot(reactions["pull_end"][:3], axis))
        f_start = -float(np.dot(reactions[ctx.plan.start_group][:3], axis))
        R = e / (2.0 * math.pi)
        return {"F": f_end, "F_start": f_start, "F_norm": f_end * ctx.radius**2 / ctx.EI,
                "end_to_end": ee, "e": e, "R": R,
                "sqrt_h_over_R": math.sqrt(ctx.radius / R) if R > 0 else math.nan}

    def metrics(self, ctx: RunContext, log) -> dict:
        log = measured_log(ctx, log)  # time from the start of the pull (after settle_time)
        if not len(log):
            return {}
        transient = float(ctx.params["transient"])
        drop = force_drop(log, transient)
        peak, t_peak = window_peak_at(log, "F_norm", transient)
        out = {f"F_norm_at_e_{int(round(ev * 1000))}mm": force_at(log, "e", ev) for ev in (0.4, 0.35, 0.3, 0.25)}
        out.update({
            "F_norm_peak": peak,
            "F_norm_peak_time": t_peak,
            "e_start": float(ctx.plan.e0),
            "e_final": float(log["e"].iloc[-1]),
            "F_norm_final": window_mean(log, "F_norm", float(log["time"].iloc[-1]) - 0.25),  # last 0.25 s
            "F_final": window_mean(log, "F", float(log["time"].iloc[-1]) - 0.25),
            "force_drop": drop,
            "force_drop_e": (float(np.interp(drop["time"], log["time"], log["e"])) if drop else None),
        })
        return out

