"""Knot-strength metrics: pure functions of a per-step log (a pandas DataFrame).

Every function takes the log written by a protocol run (one row per accepted step, a ``time``
column in s and the protocol's quantities, see :mod:`knotsim.protocols`) and returns numbers;
nothing is modified. Forces are usually the normalised pull force ``F h^2 / EI``
(column ``F_norm``, dimensionless) but any column may be given.

Definitions
-----------
* **window mean / peak**: mean (time-weighted, trapezoidal) and maximum of a column over the
  rows with ``t0 <= time <= t1`` (s).
* **slip onset**: the pull force of a knot rises while it tightens and drops when the knot slips
  (or a loop inverts). Slip onset is the first time the force falls by more than
  ``drop_fraction`` of its running maximum (and by more than ``min_drop`` in absolute terms),
  once that maximum exceeds ``min_force``; the reported force is that running maximum and the
  time the time it was reached (optionally after smoothing the record over ``smooth`` s). With ``mode="plateau"`` the onset is instead the first time the
  running maximum stops growing (by more than ``drop_fraction`` relative) for at least
  ``plateau_time`` s, i.e. "the pull force stops increasing". ``None`` when neither happens
  (the knot held without slipping during the record).
* **draw-in slip onset** (:func:`draw_in_onset`): a bend (or any knot with free tails) slips when
  its tails run into the knot. Onset = the first time (after ``t0``) from which the summed length
  of the given tail columns decreases faster than ``rate`` (m/s; e.g. a fraction of the pull
  speed), measured on a centred moving average of width ``smooth`` s, without interruption for at
  least ``hold`` s (or, at the end of the record, for at least ``hold / 2`` s). This catches the
  slips that the force-drop rule misses: a bend whose tails run in under an almost constant force,
  and a loose bend that slides from the start (no peak to drop from).
* **sustained onset** (:func:`sustained_onset`): the first time a boolean condition holds for
  ``hold`` s without interruption (the same rule, on any condition, e.g. a pulled end running away
  under force control).
* **tail draw-in**: decrease of a length column (e.g. the arc length of a free tail outside the
  knot, m) from the first to the last row (positive when the tail was drawn into the knot), or
  the increase of a displacement column (``kind="increase"``).
* **knot status**: ``"held"`` / ``"slipped"`` / ``"untied"`` / ``"changed knot type"`` from the
  knot type at the start and end and from the slip onset.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from knotsim.errors import ConfigError

__all__ = [
    "force_at",
    "moving_average",
    "draw_in_onset",
    "knot_status",
    "normalized_force",
    "slip_onset",
    "sustained_onset",
    "tail_draw_in",
    "window_mean",
    "window_peak",
    "window_peak_at",
]


def _column(log: pd.DataFrame, column: str) -> np.ndarray:
    if column not in log.columns:
        raise ConfigError("column", f"the log has no column {column!r}; columns are {list(log.columns)}")
    return np.asarray(log[column], dtype=float)


def _window(log: pd.DataFrame, t0: float | None, t1: float | None) -> np.ndarray:
    t = _column(log, "time")
    lo = -math.inf if t0 is None else float(t0)
    hi = math.inf if t1 is None else float(t1)
    if hi < lo:
        raise ConfigError("window", f"need t0 <= t1, got t0={lo}, t1={hi}")
    return (t >= lo - 1e-12) & (t <= hi + 1e-12)


def normalized_force(force, radius: float, EI: float):
    """``F h^2 / EI`` (dimensionless) of a force ``F`` (N, scalar or array), radius ``h`` (m) and
    bending stiffness ``EI`` (N m^2)."""
    return np.asarray(force, dtype=float) * radius**2 / EI if np.ndim(force) else float(force) * radius**2 / EI


def moving_average(log: pd.DataFrame, column: str = "F_norm", width: float = 0.25) -> np.ndarray:
    """Centred moving average of ``column`` over ``width`` s (window in rows from the median step)."""
    t = _column(log, "time")
    y = _column(log, column)
    if width <= 0 or t.size < 2:
        return y
    k = max(1, int(round(width / max(float(np.median(np.diff(t))), 1e-300))))
    return np.asarray(pd.Series(y).rolling(k, center=True, min_periods=1).mean(), dtype=float)


def window_mean(log: pd.DataFrame, column: str = "F_norm", t0: float | None = None,
                t1: float | None = None) -> float:
    """Time-weighted mean of ``column`` over ``t0 <= time <= t1`` (s); NaN for an empty window."""
    sel = _window(log, t0, t1)
    y = _column(log, column)[sel]
    t = _column(log, "time")[sel]
    if y.size == 0:
        return math.nan
    if y.size == 1 or t[-1] <= t[0]:
        return float(np.mean(y))
    return float(np.trapezoid(y, t) / (t[-1] - t[0]))


def window_peak(log: pd.DataFrame, column: str = "F_norm", t0: float | None = None,
                t1: float | None = None) -> float:
    """Largest value of ``column`` over ``t0 <= time <= t1`` (s); NaN for an empty window."""
    y = _column(log, column)[_window(log, t0, t1)]
    return float(np.max(y)) if y.size else math.nan


def window_peak_at(log: pd.DataFrame, column: str = "F_norm", t0: float | None = None,
                   t1: float | None = None) -> tuple[float | None, float | None]:
    """``(value, time)``: the largest value of ``column`` over ``t0 <= time <= t1`` (s) and the time
    (s) of its first occurrence; ``(None, None)`` for an empty window or one without finite values."""
    sel = _window(log, t0, t1)
    y = _column(log, column)[sel]
    t = _column(log, "time")[sel]
    ok = np.isfinite(y)
    if not ok.any():
        return None, None
    k = int(np.flatnonzero(ok)[np.argmax(y[ok])])
    return float(y[k]), float(t[k])


def force_at(log: pd.DataFrame, x_column: str, x_value: float, column: str = "F_norm") -> float:
    """``column`` linearly interpolated where ``x_column`` first reaches ``x_value`` (walking the log
    in time order); NaN if it never does. Used e.g. for ``F h^2/EI`` at ``e = 0.3 m``."""
    x = _column(log, x_column)
    y = _column(log, column)
    if x.size == 0:
        return math.nan
    d = x - float(x_value)
    if d[0] == 0.0:
        return float(y[0])
    idx = np.nonzero(np.sign(d[1:]) != np.sign(d[:-1]))[0]
    if idx.size == 0:
        return math.nan
    i = int(idx[0])
    w = d[i] / (d[i] - d[i + 1])
    return float(y[i] + w * (y[i + 1] - y[i]))


def slip_onset(log: pd.DataFrame, column: str = "F_norm", *, mode: str = "drop",
               drop_fraction: float = 0.2, min_drop: float = 0.0, min_force: float = 0.0,
               plateau_time: float = 1.0, smooth: float = 0.0, t0: float | None = None,
               t1: float | None = None) -> dict | None:
    """Slip onset of a pull-force record (see the module docstring for the definition).

    Parameters
    ----------
    log:
        Per-step log with ``time`` (s) and ``column``.
    mode:
        ``"drop"`` (first large drop below the running maximum) or ``"plateau"`` (running maximum
        stops growing for ``plateau_time`` s).
    drop_fraction:
        Relative drop (``"drop"``) or relative growth threshold (``"plateau"``).
    min_drop:
        Smallest absolute drop that counts (same unit as ``column``).
    min_force:
        The running maximum must exceed this before a slip can be detected (ignores noise at the
        start of the pull).
    plateau_time:
        s, for ``mode="plateau"``.
    smooth:
        Width (s) of a centred moving average applied to ``column`` first (0: none); hides the
        step-to-step noise of contact forces.
    t0, t1:
        Restrict to a time window (s).

    Returns
    -------
    ``{"time": s, "force": value at onset (the running maximum), "detected_at": s}`` or ``None``.
    """
    if mode not in ("drop", "plateau"):
        raise ConfigError("mode", f"must be 'drop' or 'plateau', got {mode!r}")
    if not 0.0 < drop_fraction < 1.0:
        raise ConfigError("drop_fraction", f"must lie in (0, 1), got {drop_fraction!r}")
    sel = _window(log, t0, t1)
    t = _column(log, "time")[sel]
    y = _column(log, column)[sel]
    if y.size < 2:
        return None
    if smooth > 0:
        y = moving_average(pd.DataFrame({"time": t, "y": y}), "y", smooth)
    run_max = np.maximum.accumulate(y)
    arg_max = np.zeros(y.size, dtype=np.int64)
    best = 0
    for k in range(y.size):
        if y[k] > y[best]:
            best = k
        arg_max[k] = best
    if mode == "drop":
        ok = (run_max > min_force) & (y < (1.0 - drop_fraction) * run_max) & (run_max - y > min_drop)
        hit = np.nonzero(ok)[0]
        if hit.size == 0:
            return None
        k = int(hit[0])
        i = int(arg_max[k])
        return {"time": float(t[i]), "force": float(run_max[k]), "detected_at": float(t[k])}
    # plateau: the running maximum has not grown by drop_fraction (relative) for plateau_time
    anchor = 0
    for k in range(1, y.size):
        if run_max[k] > (1.0 + drop_fraction) * run_max[anchor] or run_max[anchor] <= min_force:
            anchor = k
            continue
        if t[k] - t[anchor] >= plateau_time:
            i = int(arg_max[k])
            return {"time": float(t[i]), "force": float(run_max[k]), "detected_at": float(t[k])}
    return None


def sustained_onset(t: np.ndarray, flag: np.ndarray, hold: float) -> int | None:
    """Index of the first row from which ``flag`` stays true for at least ``hold`` s (``t`` in s,
    rows in time order); a run of true rows that reaches the end of the record counts once it
    lasts ``hold / 2`` s. ``None`` when there is none."""
    t = np.asarray(t, float)
    flag = np.asarray(flag, bool)
    if t.shape != flag.shape:
        raise ConfigError("flag", f"needs one value per time, got {flag.shape} for {t.shape}")
    if not hold >= 0:
        raise ConfigError("hold", f"must be a duration >= 0 in s, got {hold!r}")
    n = t.size
    i = 0
    while i < n:
        if not flag[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and flag[j + 1]:
            j += 1
        lasted = t[j] - t[i]
        if lasted >= hold or (j == n - 1 and lasted >= 0.5 * hold):
            return i
        i = j + 1
    return None


def draw_in_onset(log: pd.DataFrame, columns, rate: float, *, smooth: float = 2.0, hold: float = 2.0,
                  t0: float | None = None, force_column: str | None = "F_norm") -> dict | None:
    """Slip onset from tails being drawn into the knot (definition in the module docstring).

    Parameters
    ----------
    log:
        Per-step log with ``time`` (s) and the tail-length ``columns`` (m).
    columns:
        Names of the tail-length columns; their sum is tested.
    rate:
        m/s; the tails must be drawn in faster than this.
    smooth:
        Width (s) of the centred moving average of the summed tail length before differentiating.
    hold:
        s the fast draw-in must last.
    t0:
        Ignore rows before this time (s): the start-up transient.
    force_column:
        Column whose value (moving average of width 0.5 s) is reported as ``force``; ``None``: none.

    Returns
    -------
    ``{"time": s, "force": F at onset, "detected_at": s, "criterion": "tail draw-in"}`` or ``None``.
    """
    if not rate > 0:
        raise ConfigError("rate", f"must be a draw-in speed > 0 in m/s, got {rate!r}")
    cols = [columns] if isinstance(columns, str) else list(columns)
    t = _column(log, "time")
    if t.size < 3:
        return None
    tails = np.zeros_like(t)
    for c in cols:
        tails = tails + _column(log, c)
    smoothed = moving_average(pd.DataFrame({"time": t, "y": tails}), "y", smooth) if smooth > 0 else tails
    speed = -np.gradient(smoothed, t)
    fast = speed > rate
    if t0 is not None:
        fast &= t >= float(t0)
    k = sustained_onset(t, fast, hold)
    if k is None:
        return None
    force = math.nan
    if force_column is not None and force_column in log.columns:
        force = float(moving_average(log, force_column, 0.5)[k])
    j = min(t.size - 1, int(np.searchsorted(t, t[k] + hold)))
    return {"time": float(t[k]), "force": force, "detected_at": float(t[j]), "criterion": "tail draw-in"}


def tail_draw_in(log: pd.DataFrame, column: str, kind: str = "decrease") -> float:
    """Draw-in (m) of a tail length (``kind="decrease"``: first minus last value) or of a pulled-end
    displacement (``kind="increase"``: last minus first value). NaN for an empty log."""
    if kind not in ("decrease", "increase"):
        raise ConfigError("kind", f"must be 'decrease' or 'increase', got {kind!r}")
    y = _column(log, column)
    y = y[np.isfinite(y)]
    if y.size == 0:
        return math.nan
    return float(y[0] - y[-1]) if kind == "decrease" else float(y[-1] - y[0])


#: Outcomes of a strength test, from the protocol's metrics (see :func:`knot_status`); ``"untied"``
#: from the metrics when the topology cannot see it (the two ropes of a reef or thief bend, each
#: closed on itself, are an unlink from the start: the protocol sees them come apart geometrically).
VERDICTS = ("slipped", "loose", "undecided", "untied", "capsized")

#: Ropelength (rope length / diameter) of the ideal tight knots (Pieranski 1998; Baranska et al.
#: 2004): trefoil 16.37, figure-eight 21.04, 5_1 23.55, 5_2 24.68. A composite knot is taken as the
#: sum of its factors (an upper bound).
IDEAL_ROPELENGTH = {"3_1": 16.37, "4_1": 21.04, "5_1": 23.55, "5_2": 24.68}


def ideal_ropelength(rolfsen: str | None) -> float | None:
    """Ideal ropelength (diameters) of a knot by its Rolfsen name (``"3_1"``, ``"3_1#3_1*"``), or
    ``None`` for a knot outside :data:`IDEAL_ROPELENGTH`."""
    if not rolfsen:
        return None
    total = 0.0
    for factor in str(rolfsen).split("#"):
        v = IDEAL_ROPELENGTH.get(factor.rstrip("*"))
        if v is None:
            return None
        total += v
    return total


def knot_status(start_type: str | None, end_type: str | None, slipped: bool = False,
                verdict: str | None = None) -> str:
    """Outcome of a loading run.

    ``"untied"`` (ends as an unknot or unlink), ``"changed knot type"`` or ``"unknown"`` (a topology
    check failed) from the topology; else the protocol's ``verdict`` (``"slipped"``: the force
    dropped or the tails ran; ``"loose"``: the knot never tightened; ``"undecided"``: the run was
    too short to tell; ``"capsized"``: the knot turned into another form, ``knot-security``) or
    ``"slipped"`` when ``slipped``; else ``"held"``."""
    if start_type is None or end_type is None:
        return "unknown"
    if end_type != start_type:
        if end_type in ("unknot", "unlink") and start_type not in ("unknot", "unlink"):
            return "untied"
        return "changed knot type"
    if verdict is not None:
        if verdict not in VERDICTS:
            raise ValueError(f"unknown verdict {verdict!r}; expected one of {VERDICTS}")
        return verdict
    return "slipped" if slipped else "held"
