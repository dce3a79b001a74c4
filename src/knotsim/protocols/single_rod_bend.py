"""Protocol ``single-rod-bend``: reef and granny tied in one rod (MAE259B report; physics-notes 4.2).

One rod (``E = 0.18 MPa``, ``h = 2 mm``, ``L = 1 m``, ``rho = 1180 kg/m^3``, ``N = 301``,
``dt = 2.5 ms``, contact ``delta = 5e-4 m``, ``nu = 1e-4 m/s``, default ``mu = 0.1``) tied as
``single_rod_reef`` or ``single_rod_granny``. The two end nodes at each end (and their edge angle)
are clamped and moved apart along the initial end-to-end axis (horizontal in the drawing) at
``pull_speed`` per end (10 mm/s: the printed 10 cm/s cannot be right for 17 s of pulling a 1 m
rod). The node given by the knot's ``held`` hint (the bottom of the first overhand) is held static
(:meth:`~knotsim.bc.BoundaryConditions.hold`, positions only) for ``hold_time`` s (default
``None``: the whole run; 0: no hold), which stops the first overhand from inverting.

Per-step log columns: ``F_start``, ``F_end`` (N): axial traction on the clamped end edges
(positive in tension); ``F`` = their mean; ``F_norm = F h^2 / EI``; ``end_to_end`` (m).

Metrics: mean and peak ``F_norm`` over the pull window ``[0, mean_window]`` s (13 s), ``F_norm``
at 2.5, 5, 7.5, 10, 12.5 s, and the slip onset (first drop of ``F_norm`` by more than 30 % below
its 0.5 s moving average's running maximum, once that maximum exceeds half the largest averaged
force, after the first max(2 s, 20 %) of the pull, see
:func:`knotsim.protocols.metrics.slip_onset`); a slip is reported as the outcome ``"slipped"``.
"""

from __future__ import annotations

import math

import numpy as np

from knotsim.protocols.base import Protocol, RunContext, register, unit
from knotsim.protocols.metrics import moving_average, slip_onset, window_mean, window_peak

#: Times (s) at which F h^2/EI was read off the published figure.
REPORT_TIMES = (2.5, 5.0, 7.5, 10.0, 12.5)


class SingleRodBend(Protocol):
    name = "single-rod-bend"
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
        "output_interval": 0.1,
    }
    fixed_geometry = ("n_nodes", "radius", "length")
    quick = {"n_nodes": 101, "dt": 5e-3, "duration": 2.0, "mean_window": 2.0, "pull_speed": 0.02,
             "output_interval": 0.5}

    def setup(self, ctx: RunContext) -> None:
        x = ctx.geometry.ropes[0]
        axis = unit(x[-1] - x[0])
        ctx.data["axis"] = axis
        v = float(ctx.params["pull_speed"])
        ctx.bcs.move("pull_start", rod=0, nodes=[0, 1], path=list(-v * axis))
        ctx.bcs.move("pull_end", rod=0, nodes=[-2, -1], path=list(v * axis))
        held = [h.node for h in ctx.geometry.held if h.rope == 0]
        ht = ctx.params["hold_time"]
        hold_time = math.inf if ht is None else float(ht)
        if held and hold_time > 0:
            ctx.bcs.hold("knot_hold", rod=0, nodes=held, stop=None if math.isinf(hold_time) else hold_time)
        ctx.data["held_nodes"] = held

    def duration(self, ctx: RunContext) -> float:
        return float(ctx.params["mean_window"])

    def record(self, ctx: RunContext, q, t, reactions) -> dict:
        m = ctx.model
        axis = ctx.data["axis"]
        x0 = q[m.node_dof[0]:m.node_dof[0] + 3]
        x1 = q[m.node_dof[-1]:m.node_dof[-1] + 3]
        f_end = float(np.dot(reactions["pull_end"][:3], axis))
        f_start = -float(np.dot(reactions["pull_start"][:3], axis))
        f = 0.5 * (f_start + f_end)
        return {"F": f, "F_start": f_start, "F_end": f_end, "F_norm": f * ctx.radius**2 / ctx.EI,
                "end_to_end": float(np.linalg.norm(x1 - x0))}

    def metrics(self, ctx: RunContext, log) -> dict:
        w = float(ctx.params["mean_window"])
        t = np.asarray(log["time"], float)
        out = {
            "F_norm_mean": window_mean(log, "F_norm", 0.0, w),
            "F_norm_peak": window_peak(log, "F_norm", 0.0, w),
            "mean_window": w,
            "F_norm_final": window_mean(log, "F_norm", float(log["time"].iloc[-1]) - 0.25),  # last 0.25 s
        }
        for tr in REPORT_TIMES:
            if tr <= t[-1] + 1e-9:
                k = slice(max(0, int(np.searchsorted(t, tr)) - 2), int(np.searchsorted(t, tr)) + 3)
                out[f"F_norm_at_{tr:g}s"] = float(np.mean(log["F_norm"].iloc[k]))
        t_skip = max(0.2 * t[-1], 2.0)  # skip the start-up transient
        fmax = float(np.max(moving_average(log, "F_norm", 0.5)[t >= t_skip])) if t[-1] > t_skip else 0.0
        out["slip_onset"] = slip_onset(log, "F_norm", mode="drop", drop_fraction=0.3,
                                       min_force=0.5 * max(fmax, 1e-12), smooth=0.5, t0=t_skip)
        return out

    def slipped(self, ctx: RunContext, metrics: dict) -> bool:
        return metrics.get("slip_onset") is not None


register(SingleRodBend())
