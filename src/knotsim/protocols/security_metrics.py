"""The measures of the ``knot-security`` protocol (:mod:`knotsim.protocols.knot_security`), from its
log: the set, the slips (one rule: rope through the knot), the hold's drift, the pulses' and jerks'
spill, the capsize, and the decision that ends a run early.

Logs here are the protocol's columns (``F`` in N, ``u_pull``, ``tail_a``, ``tail_b``, ``in_knot``,
``rope_gap`` in m, ``turn_a``, ``turn_b`` in rad) against ``time`` (s): the whole run for
:func:`set_metrics`, the load stage counted from its start (:func:`~knotsim.protocols.timeline.measured_log`)
for the others. ``sp`` is the run's :class:`~knotsim.protocols.knot_security.SecurityParams`.

Metrics (keys of the summary's ``metrics``): ``in_knot_set`` and ``in_knot_load`` (m of rope in the
knot at the end of the set and at the start of the load), ``set_creep`` (m/s: how fast the rope in the
knot still changed over the last ``set_still_window`` of the set hold, a least-squares line) and
``set_still`` (``|set_creep|`` at most ``set_still_rate``; false: loaded before it was set);
``rope_gap_final`` and ``ropes_apart`` (bends); ``turn_load`` (rad, each rope's turning in the knot
when the load began) and ``capsize_onset``; by mode: ``slip_load`` and ``slip_onset`` (ramp: the
loaded end running away), ``slow_slip_load`` and ``slow_slip_onset`` (rope through the knot faster
than ``slip_speed``), ``slip_during_transient`` / ``slow_slip_during_transient`` (already under way
when detection began: the load given is a bound), ``largest_load_held``; ``drift_pull``,
``drift_tails`` and their rates over the hold after its rise, the same over its second half
(``*_late``) and ``drift_through_late`` (the rope let through the knot over that half, the lesser of
the loaded end's outward drift and the tails' draw-in; beyond ``hold_drift`` a slip, criterion
``"drift"``); ``sliding_resistance`` (slide); ``pulse_drift``, ``pulses_done`` and
``cycles_to_spill`` (pulses and jerks). Forces in N, with ``*_norm`` = F h²/EI.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from knotsim.protocols.base import Decision
from knotsim.protocols.metrics import moving_average, sustained_onset, window_mean
from knotsim.protocols.rope_measures import APART_RADII

__all__ = ["CAPSIZE_HOLD", "CAPSIZE_STRAIGHT", "CAPSIZE_WRAPPED", "SUSTAIN", "capsize_metrics", "decide",
           "load_metrics", "set_metrics", "slip_onsets", "through_speed"]

#: s the loaded end must stay faster than ``runaway_speed`` (rope through the knot faster than
#: ``slip_speed``) for a run-away (a slow slip)
SUSTAIN = 0.5
#: Capsizing (a bend turning into another form under load, e.g. a reef into two lark's heads round a
#: rope pulled straight): one rope's turning in the knot below ``CAPSIZE_STRAIGHT`` (rad, nearly
#: straight) while the other's is at least ``CAPSIZE_WRAPPED`` (still round it) and the ropes touch,
#: for ``CAPSIZE_HOLD`` s. A set bend turns each rope by about 1.5 π in the knot.
CAPSIZE_STRAIGHT = 0.25 * math.pi
CAPSIZE_WRAPPED = 0.5 * math.pi
CAPSIZE_HOLD = 0.25


def set_metrics(sp, t_set: float, t_load: float, log: pd.DataFrame) -> dict[str, Any]:
    """``in_knot_set``, ``in_knot_load``, ``set_creep`` and ``set_still`` from the whole run's log; the
    set ends at ``t_set`` and the load begins at ``t_load`` (s of run time)."""
    t = np.asarray(log["time"], float)
    if "in_knot" not in log.columns or not t.size:
        return {}
    ink = np.asarray(log["in_knot"], float)
    out: dict[str, Any] = {"in_knot_set": float(ink[min(int(np.searchsorted(t, t_set - 1e-9)), ink.size - 1)]),
                           "in_knot_load": float(ink[min(int(np.searchsorted(t, t_load - 1e-9)), ink.size - 1)])}
    # over the last set_still_window of the set hold (the window set_until_still reads)
    tail = (t >= t_set - min(sp.set_still_window, sp.set_hold) - 1e-9) & (t <= t_set)
    out["set_creep"] = float(np.polyfit(t[tail], ink[tail], 1)[0]) if np.count_nonzero(tail) >= 3 else None
    out["set_still"] = None if out["set_creep"] is None else bool(abs(out["set_creep"]) <= sp.set_still_rate)
    return out


def pull_speed(log: pd.DataFrame, t: np.ndarray) -> np.ndarray:
    """The loaded end's speed (m/s) along the load, from its displacement averaged over 0.5 s."""
    u = moving_average(log, "u_pull", 0.5)
    return np.gradient(u, t) if len(t) > 2 else np.zeros_like(u)


def _tails(log: pd.DataFrame) -> np.ndarray | None:
    """The two free tails' summed length outside the knot (m) of a bend's log, ``None`` for a
    one-rope knot (no free tails)."""
    if "tail_a" not in log.columns:
        return None
    tails = np.asarray(log["tail_a"], float) + np.asarray(log["tail_b"], float)
    return tails if np.all(np.isfinite(tails)) else None


def through_speed(sp, log: pd.DataFrame, t: np.ndarray) -> np.ndarray:
    """The speed (m/s) at which rope passes through the knot, the quantity of the slow slip: with
    ``slip_rule = "through"`` the lesser of the loaded end's outward speed and the tails' draw-in
    speed (each from its length averaged over 0.5 s: rope through the knot pays the loaded end out and
    draws the tails in by as much; the loaded end stretching alone, or the tails drawn in while it
    stays, is no slip), the loaded end's speed for a one-rope knot (no free tails) and with
    ``slip_rule = "loaded_end"``."""
    speed = pull_speed(log, t)
    tails = _tails(log) if sp.slip_rule == "through" and len(t) > 2 else None
    if tails is None:
        return speed
    drawn_in = -np.gradient(moving_average(pd.DataFrame({"time": t, "y": tails}), "y", 0.5), t)
    return np.minimum(speed, drawn_in)


def slip_onsets(sp, log: pd.DataFrame, t: np.ndarray) -> tuple[int | None, int | None]:
    """Rows of the load stage's log (``t`` s since the load began) where the loaded end began to run
    away (faster than ``runaway_speed``: the knot let go) and where rope began to pass through the
    knot faster than ``slip_speed`` (:func:`through_speed`: the slow slip), each sustained for
    :data:`SUSTAIN` s, from ``detect_after`` s into the load in a ramp (0: from its first instant)
    and after the ``transient`` (the rise) in the other modes; ``None`` where it did not happen."""
    after = t >= sp.detect_from
    k = sustained_onset(t, after & (pull_speed(log, t) > sp.runaway_speed), SUSTAIN)
    ks = sustained_onset(t, after & (through_speed(sp, log, t) > sp.slip_speed), SUSTAIN)
    return k, ks


def capsize_metrics(log: pd.DataFrame, t: np.ndarray, radius: float) -> dict[str, Any]:
    """``turn_load`` (rad, each rope's turning in the knot when the load began, rope A then B) and
    ``capsize_onset`` (``{"time", "force", "rope"}``: when a rope was pulled straight through the knot
    while the other still went round it, :data:`CAPSIZE_STRAIGHT`; ``None``: it never was) of a bend;
    both ``None`` for a one-rope knot. ``radius`` the rod radius (m)."""
    if "turn_a" not in log.columns:
        return {"turn_load": None, "capsize_onset": None}
    ta, tb = np.asarray(log["turn_a"], float), np.asarray(log["turn_b"], float)
    if not (np.all(np.isfinite(ta)) and np.all(np.isfinite(tb))):
        return {"turn_load": None, "capsize_onset": None}
    touching = np.asarray(log["rope_gap"], float) <= APART_RADII * radius
    capsized = (np.minimum(ta, tb) < CAPSIZE_STRAIGHT) & (np.maximum(ta, tb) >= CAPSIZE_WRAPPED) & touching
    k = sustained_onset(t, capsized, CAPSIZE_HOLD)
    onset = (None if k is None else
             {"time": float(t[k]), "force": float(np.asarray(log["F"], float)[k]), "rope": "a" if ta[k] < tb[k] else "b"})
    return {"turn_load": [float(ta[0]), float(tb[0])], "capsize_onset": onset}


def spill_metrics(sp, log: pd.DataFrame, t: np.ndarray) -> dict[str, Any]:
    """Cycles to spill of the ``"pulses"`` and ``"jerks"`` modes: the rope through the knot at the end
    of each pulse (back at the base load, or slack) since the load began, ``pulse_drift`` (m; the
    lesser of the loaded end's outward displacement and the tails' draw-in, the loaded end alone for a
    one-rope knot or with ``slip_rule = "loaded_end"``); the knot has spilled in the first pulse after
    which that is more than ``spill_distance`` (``cycles_to_spill``; ``None``: it never was; an end
    drawn in is the knot settling, not spilling)."""
    period, n = sp.cycle_period, sp.cycles
    u = np.asarray(log["u_pull"], float)
    u = u - u[0]
    tails = _tails(log) if sp.slip_rule == "through" else None
    if tails is not None:  # a bend: the rope through the knot, the lesser of out and in
        u = np.minimum(u, tails[0] - tails)
    ends = [i * period for i in range(1, n + 1) if i * period <= t[-1] + 1e-9]
    moved = [float(np.interp(te, t, u)) for te in ends]
    spilled = next((i + 1 for i, m in enumerate(moved) if m > sp.spill_distance), None)  # out, not drawn in
    return {"pulse_drift": moved, "pulses_done": len(ends), "cycles_to_spill": spilled,
            "decidable": len(ends) == n or spilled is not None,
            "slip_onset": (None if spilled is None else
                           {"time": float(ends[spilled - 1]), "force": math.nan, "criterion": "spill"})}


def _ramp_metrics(sp, log: pd.DataFrame, t: np.ndarray, norm: float) -> dict[str, Any]:
    """The ramp's slip loads (N) and onsets, and whether they are bounds (module docstring)."""
    k, ks = slip_onsets(sp, log, t)
    f = np.asarray(log["F"], float)
    after = t >= sp.detect_from
    speed, slow = pull_speed(log, t), through_speed(sp, log, t)
    # an onset already under way when the detection starts: its load is at most the load there
    out: dict[str, Any] = {
        "slip_onset": None if k is None else {"time": float(t[k]), "force": float(f[k]), "criterion": "runaway"},
        "slow_slip_onset": (None if ks is None else
                            {"time": float(t[ks]), "force": float(f[ks]),
                             "criterion": "through" if sp.slip_rule == "through" else "slip_speed"}),
        "slow_slip_during_transient": bool(ks is not None and ks == int(np.argmax(after))
                                           and np.any(~after[:ks + 1] & (slow[:ks + 1] > sp.slip_speed))),
        "decidable": bool(t[-1] - sp.detect_from >= 0.5),
        "slip_during_transient": bool(k is not None and np.any(~after[:k + 1] & (speed[:k + 1] > sp.runaway_speed))
                                      and k == int(np.argmax(after))),
    }
    if sp.load == "ramp":
        out.update(slip_load=float(f[k]) if k is not None else None,
                   slip_load_norm=float(f[k]) * norm if k is not None else None,
                   slow_slip_load=float(f[ks]) if ks is not None else None,
                   slow_slip_load_norm=float(f[ks]) * norm if ks is not None else None,
                   largest_load_held=float(f[k] if k is not None else f[-1]))
    return out


def _drift(tw: np.ndarray, up: np.ndarray, tails: np.ndarray | None, suffix: str) -> dict[str, Any]:
    """The loaded end's outward drift and the tails' draw-in (m, tails positive when drawn in) over
    the samples ``tw`` (s), with their rates (m/s, least-squares lines)."""
    span = float(tw[-1] - tw[0])
    return {f"drift_pull{suffix}": float(up[-1] - up[0]),
            f"drift_pull{suffix}_rate": float(np.polyfit(tw, up, 1)[0]) if span > 0 else None,
            f"drift_tails{suffix}": float(tails[0] - tails[-1]) if tails is not None else None,
            f"drift_tails{suffix}_rate": float(-np.polyfit(tw, tails, 1)[0]) if span > 0 and tails is not None
            else None}


def _hold_metrics(sp, log: pd.DataFrame, t: np.ndarray, k: int | None, norm: float) -> dict[str, Any]:
    """The hold's drift after its rise and over its second half (after the knot has taken up the load:
    the first seconds of a hold are its elastic and frictional adjustment), and the slip by the one
    rule: rope through the knot, the lesser of the loaded end's outward drift and the tails' draw-in,
    beyond ``hold_drift`` (a loaded end drawn in, tails drawn in while it stays, or the end let out
    while the tails stay are the knot settling, drawing up or changing shape, not slips; a one-rope
    knot's loaded ends decide)."""
    out: dict[str, Any] = {"hold_load": sp.hold_load, "hold_load_norm": sp.hold_load * norm}
    win = (t >= sp.detect_from) & (t <= (t[k] if k is not None else t[-1]))
    if np.count_nonzero(win) < 2:
        return out
    tw, up = t[win], np.asarray(log["u_pull"], float)[win]
    tails = _tails(log)
    tails = tails[win] if tails is not None else None
    out["hold_window"] = float(tw[-1] - tw[0])
    out.update(_drift(tw, up, tails, ""))
    late = tw >= tw[0] + 0.5 * out["hold_window"]
    if np.count_nonzero(late) < 2:
        return out
    out.update(_drift(tw[late], up[late], tails[late] if tails is not None else None, "_late"))
    through = (out["drift_pull_late"] if tails is None else min(out["drift_pull_late"], out["drift_tails_late"]))
    out["drift_through_late"] = through
    if k is None and through > sp.hold_drift:
        i = int(np.flatnonzero(win)[np.argmax(late)])
        out["slip_onset"] = {"time": float(t[i]), "force": float(np.asarray(log["F"], float)[i]), "criterion": "drift"}
    return out


def load_metrics(sp, log: pd.DataFrame, radius: float, norm: float) -> dict[str, Any]:
    """The load stage's metrics by mode (module docstring); ``log`` counted from the load's start,
    ``norm`` = h²/EI (1/N)."""
    if len(log) < 2:
        return {"decidable": False}
    t = np.asarray(log["time"], float)
    out: dict[str, Any] = {"load_time": float(t[-1]), **capsize_metrics(log, t, radius)}
    if sp.load in ("pulses", "jerks"):
        return {**out, **spill_metrics(sp, log, t)}
    if sp.load == "slide":
        half = t >= 0.5 * t[-1]
        resistance = window_mean(log, "F", float(t[half][0]) if half.any() else None)
        return {**out, "sliding_resistance": resistance, "sliding_resistance_norm": resistance * norm,
                "slip_onset": None, "decidable": bool(t[-1] > sp.detect_from)}
    out.update(_ramp_metrics(sp, log, t, norm))
    if sp.load == "hold":
        k, _ = slip_onsets(sp, log, t)
        out.update(_hold_metrics(sp, log, t, k, norm))
    return out


def decide(sp, log: pd.DataFrame, t0: float, radius: float) -> Decision | None:
    """The earliest decision in the load stage's ``log`` (counted from its start at run time ``t0``):
    the loaded end running away (slipped; decided once it has lasted :data:`SUSTAIN` s), the ropes of a
    bend apart (``rope_gap`` beyond :data:`APART_RADII` radii), and outside a ramp (which measures the
    run-away load) a capsize (decided after :data:`CAPSIZE_HOLD` s) and a spill (at the end of the pulse
    after which the knot is out by ``spill_distance``). Times in s of run time."""
    if len(log) < 3:
        return None
    t = np.asarray(log["time"], float)
    f = np.asarray(log["F"], float)
    found: list[Decision] = []
    if sp.load not in ("pulses", "jerks"):
        k, _ = slip_onsets(sp, log, t)
        if k is not None:
            found.append(Decision(t0 + float(t[k]) + SUSTAIN, "slipped",
                                  f"the loaded end ran away from F = {1e3 * f[k]:.3g} mN (faster than "
                                  f"runaway_speed = {sp.runaway_speed:g} m/s for {SUSTAIN:g} s)"))
    if "rope_gap" in log.columns:
        gap = np.asarray(log["rope_gap"], float)
        apart = np.flatnonzero(np.isfinite(gap) & (gap > APART_RADII * radius))
        if apart.size:
            i = int(apart[0])
            found.append(Decision(t0 + float(t[i]), "apart", f"the ropes came apart (gap {1e3 * gap[i]:.3g} mm)"))
    if sp.load != "ramp":
        cap = capsize_metrics(log, t, radius)["capsize_onset"]
        if cap is not None:
            found.append(Decision(t0 + cap["time"] + CAPSIZE_HOLD, "capsized",
                                  f"rope {cap['rope']} was pulled straight through the knot at F = "
                                  f"{1e3 * cap['force']:.3g} mN"))
    if sp.load in ("pulses", "jerks"):
        n = spill_metrics(sp, log, t)["cycles_to_spill"]
        if n is not None:
            found.append(Decision(t0 + n * sp.cycle_period, "spilled",
                                  f"more than spill_distance = {1e3 * sp.spill_distance:g} mm of rope had passed "
                                  f"through the knot after pulse {n}"))
    return min(found, key=lambda d: d.time) if found else None
