"""Thinned time series of a study's cases: what a study keeps of each case's log.

A case's ``log.parquet`` has one row per accepted step (thousands of rows, dozens of columns) and
stays with the case directory; a study keeps, in its one ``timeseries.parquet``, each case's log
thinned to one row per :data:`THIN_INTERVAL` of simulated time, plus the rows at which the case's
events happened (every time the summary's metrics and timeline name: slip onsets, decisions, ...),
plus the first and last rows. The columns are ``case_id``, ``time`` (s, the log's own axis) and
the protocol's own log columns its metrics are computed from (:data:`PROTOCOL_COLUMNS`; a case of
kind ``run``, or of a protocol not listed, keeps every numeric column of its log).

The thinning keeps rows of the log as they are (no averaging): a metric recomputed from the
thinned series (e.g. ``KnotSecurity().metrics(ctx, series)``) differs from the one of the full
log by what happens between two kept rows, about the rate of change of the quantity times
:data:`THIN_INTERVAL` (a slip load under a load ramp of 2 mN/s: within 0.1 mN).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

__all__ = ["PROTOCOL_COLUMNS", "SERIES_FILE", "THIN_INTERVAL", "event_times", "series_columns", "thin_log",
           "write_case_series"]

#: Simulated time between two kept rows of a thinned series (s).
THIN_INTERVAL = 0.05
#: File of a case's thinned series inside its case directory, and of all of them in a study.
SERIES_FILE = "timeseries.parquet"

#: The log columns each protocol's metrics are computed from (besides ``time``); forces in N,
#: ``F_norm`` = F h²/EI, lengths in m, turns in radians.
PROTOCOL_COLUMNS: dict[str, tuple[str, ...]] = {
    "knot-security": ("F", "F_norm", "u_pull", "tail_a", "tail_b", "in_knot", "rope_gap", "turn_a", "turn_b"),
    "two-rope-bend": ("F", "F_norm", "F_held", "u_pull", "tail_a", "tail_b", "rope_gap"),
    "overhand-pull": ("F", "F_start", "F_norm", "end_to_end", "e", "R", "sqrt_h_over_R"),
    "single-rod-bend": ("F", "F_start", "F_end", "F_norm", "end_to_end", "contour_length", "t_pull"),
}


def series_columns(log_columns: Iterable[str], protocol: str | None, numeric: Iterable[str] = ()) -> list[str]:
    """The columns of a thinned series: ``time`` and the columns of :data:`PROTOCOL_COLUMNS` of
    ``protocol`` that the log has; for a protocol not listed (or ``None``, a plain run) ``time`` and
    every column of ``numeric`` (the log's numeric columns)."""
    have = list(log_columns)
    own = PROTOCOL_COLUMNS.get(protocol or "")
    keep = [c for c in own if c in have] if own is not None else [c for c in numeric if c != "time"]
    return ["time", *keep]


def event_times(summary: Mapping[str, Any] | None) -> list[float]:
    """Every time (s, log axis) the summary's ``metrics`` and ``timeline`` name: values under a key
    ``time`` or ending in ``_time``, at any depth."""
    found: list[float] = []

    def walk(v: Any, key: str = "") -> None:
        if isinstance(v, Mapping):
            for k, x in v.items():
                walk(x, str(k))
        elif isinstance(v, list | tuple):
            for x in v:
                walk(x, key)
        elif (key == "time" or key.endswith("_time")) and isinstance(v, int | float) and not isinstance(v, bool):
            if math.isfinite(float(v)):
                found.append(float(v))

    if summary:
        walk(summary.get("metrics") or {})
        walk(summary.get("timeline") or {})
    return found


def thin_log(log, protocol: str | None = None, events: Iterable[float] = (), interval: float = THIN_INTERVAL):
    """The thinned series of ``log`` (a DataFrame with a ``time`` column, s): its first row at or
    after every multiple of ``interval`` (s) from the first time, the rows at the times ``events``
    (s; the nearest row), and the last row; the columns of :func:`series_columns`.

    Raises
    ------
    ConfigError
        When ``log`` has no ``time`` column or ``interval`` is not positive.
    """
    import numpy as np
    import pandas as pd

    from knotsim.errors import ConfigError

    if "time" not in log.columns:
        raise ConfigError("log", "a log to thin needs a 'time' column (s)")
    if not (isinstance(interval, int | float) and interval > 0):
        raise ConfigError("interval", f"expected a positive time in s, got {interval!r}")
    numeric = [c for c in log.columns if pd.api.types.is_numeric_dtype(log[c]) and not pd.api.types.is_bool_dtype(log[c])]
    cols = series_columns(log.columns, protocol, numeric)
    t = np.asarray(log["time"], float)
    if len(t) == 0:
        return log[cols].iloc[:0].reset_index(drop=True)
    grid = np.arange(t[0], t[-1] + interval, interval)
    rows = np.searchsorted(t, grid - 1e-9 * interval)
    ev = np.asarray([e for e in events if t[0] <= e <= t[-1]], float)
    if ev.size:
        right = np.clip(np.searchsorted(t, ev), 0, len(t) - 1)
        left = np.clip(right - 1, 0, len(t) - 1)
        rows = np.concatenate([rows, np.where(np.abs(t[left] - ev) < np.abs(t[right] - ev), left, right)])
    rows = np.unique(np.concatenate([rows[rows < len(t)], [0, len(t) - 1]]))
    return log[cols].iloc[rows].reset_index(drop=True)


def write_case_series(case_dir: str | os.PathLike, protocol: str | None, summary: Mapping[str, Any] | None) -> bool:
    """Write ``case_dir/timeseries.parquet``, the thinned series of ``case_dir/log.parquet`` (events
    from ``summary``); returns False (writing nothing) when the case has no log."""
    import pandas as pd

    case_dir = Path(case_dir)
    src = case_dir / "log.parquet"
    if not src.is_file():
        return False
    thinned = thin_log(pd.read_parquet(src), protocol, event_times(summary))
    thinned.to_parquet(case_dir / SERIES_FILE, index=False)
    return True
