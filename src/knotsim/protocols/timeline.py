"""The time line of a protocol run: settling, the protocol's own pre-stage, the measured pull.

A protocol run may start with a **settling** stage (parameter ``settle_time``, s, default 0): the
drawn knot is not in equilibrium (its bending energy falls several-fold in the first tenths of a
second and its strands snap into contact), and that start-up rings the whole rope, whose end
reactions swing far above and below the force the knot carries. With ``settle_time = T`` every
loading group of the protocol (``move`` and ``force`` tables) starts at ``T`` instead of 0, and its
nodes are held still until then by a group ``settle_<name>`` (a ``clamp`` with the move's twist
setting, or a ``hold`` for a force); static groups (``clamp``, ``hold``) act from the start and a
timed release of theirs (``stop``) counts from the end of settling. The run lasts ``T`` plus the
protocol's ``duration`` (given or computed). The protocol's own pre-stage
(single-rod ``pre_pull``, two-rope ``pre_tighten``, knot-security's set and relax: ``ctx.t_pre``, s)
follows, then the
measured pull. Metrics count time from the start of the measured pull (:func:`pull_start`,
:func:`measured_log`); the log keeps run time. While settling, the reactions of a loading group are
those of its settle group (:func:`merge_settle_reactions`), so the protocol's force columns are
continuous.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from knotsim.errors import ConfigError

__all__ = ["apply_settle", "measured_log", "merge_settle_reactions", "pull_start"]

#: Boundary-condition types that load the knot (they start after settling).
LOADING_TYPES = ("move", "force")


def apply_settle(ctx: Any, settle: float) -> None:
    """Shift the loading groups of ``ctx.bc`` (run-file tables) by ``settle`` s and hold their
    nodes still until then (module docstring); record ``ctx.t_settle`` and the loading groups' names
    (``ctx.settle_groups``). Nothing happens for ``settle = 0``."""
    settle = float(settle)
    if not (settle >= 0 and np.isfinite(settle)):
        raise ConfigError("settle_time", f"must be a duration >= 0 in s, got {settle!r}")
    ctx.t_settle = settle
    ctx.settle_groups = []
    if settle == 0:
        return
    tables = []
    for b in ctx.bc:
        if b.get("stop") is not None:
            b["stop"] = float(b["stop"]) + settle
        if b["type"] in LOADING_TYPES:
            b["start"] = float(b.get("start", 0.0)) + settle
            still = ({"type": "clamp", "twist": bool(b.get("twist", True))} if b["type"] == "move"
                     else {"type": "hold"})
            tables.append({**still, "name": f"settle_{b['name']}", "rod": b.get("rod", 0), "nodes": b["nodes"],
                           "stop": settle})
            ctx.settle_groups.append(b["name"])
        tables.append(b)
    ctx.bc[:] = tables


def merge_settle_reactions(ctx: Any, reactions: dict) -> dict:
    """``reactions`` (group name -> ``(fx, fy, fz, moment)``, N and N m) with each loading group's
    settle reaction added to its own: the force on those nodes, whichever group holds them."""
    names = ctx.settle_groups
    if not names:
        return reactions
    out = dict(reactions)
    for name in names:
        extra = reactions.get(f"settle_{name}")
        if extra is not None and name in out:
            out[name] = np.asarray(out[name], float) + np.asarray(extra, float)
    return out


def pull_start(ctx: Any) -> float:
    """Run time (s) at which the measured pull starts: settling plus the protocol's pre-stage."""
    return float(ctx.t_settle) + float(ctx.t_pre)


def measured_log(ctx: Any, log: pd.DataFrame) -> pd.DataFrame:
    """The rows of the measured pull with ``time`` counted from its start (s); ``log`` itself when
    the pull starts at t = 0."""
    t0 = pull_start(ctx)
    if t0 <= 0:
        return log
    out = log[log["time"] >= t0 - 1e-9].copy()
    out["time"] = out["time"] - t0
    return out
