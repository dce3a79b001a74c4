"""Force figures of a protocol run (matplotlib, Agg; no display needed).

:func:`plot_run` reads a run directory written by :func:`knotsim.protocols.run_protocol`
(``knotsim pull``): ``log.parquet`` (one row per step: ``time`` in s, the pull force ``F`` in N and
``F_norm = F h²/EI``, and the protocol's geometry columns) and ``summary.json`` (protocol,
parameters, metrics). It draws

- the force against time, with the protocol's measuring window shaded (single-rod bend: the mean
  window ``[t_pre, t_pre + mean_window]``; the other protocols: after the start-up ``transient``),
  a settling stage (``settle_time``: the ends held still while the drawn knot settles) shaded grey
  with the force axis scaled to the measured pull (the ringing while settling is said in the
  figure, not drawn off the scale), the peak the summary reports (``F_norm_peak`` at
  ``F_norm_peak_time``: the value and time of the summary, nothing recomputed; for a summary
  without the time, the first row of the protocol's peak window holding that value) and the slip
  onset or force drop (a dashed vertical line at its time, the running-maximum force marked);
- when the protocol logs one, the force against the end-to-end geometry: the shortening ``e``
  (m, overhand pull), the end-to-end distance (m, single-rod bend) or the pulled-end displacement
  ``u_pull`` (m, two-rope bend), with the same peak and onset marked and, for the overhand pull,
  the read-off points ``F h²/EI`` at ``e = 0.4 ... 0.25 m``.

Metric times in ``summary.json`` count from the start of the measured pull, after any settling
(parameter ``settle_time``) and pre-tightening stage (``pre_pull_time`` / ``pre_tighten_time``);
the figure uses the run's time throughout.
A log without a force column (a plain ``knotsim run``) gets its reaction forces ``<group>_fx/fy/fz``
as ``|F|`` (N) against time.
"""

from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path

import numpy as np

from knotsim.errors import ConfigError

__all__ = ["plot_run"]

FIGSIZE_ONE = (6.4, 4.0)  # in
FIGSIZE_TWO = (11.0, 4.0)  # in
DPI = 100

#: Geometry column plotted against (first found), with its axis label.
_X_COLUMNS = (("e", "shortening e = L - end-to-end (m)"), ("end_to_end", "end-to-end distance (m)"),
              ("u_pull", "pulled-end displacement u (m)"))


def _read_summary(run: Path) -> dict:
    path = run / "summary.json"
    if not path.is_file():
        return {}
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ConfigError("summary.json", f"cannot read {path}: {exc}") from None


def _number(v) -> float | None:
    return float(v) if isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) else None


def _settle(params: dict | None) -> float:
    """The settling stage's duration (s), parameter ``settle_time`` (0 when absent)."""
    return _number((params or {}).get("settle_time")) or 0.0


def _offset(metrics: dict, params: dict | None = None) -> float:
    """Start of the measured pull (s of run time): the settling and pre-tightening stages' durations."""
    off = _settle(params)
    for k in ("pre_pull_time", "pre_tighten_time"):
        v = _number(metrics.get(k))
        if v is not None:
            return off + v
    return off


def _window(summary: dict, t_end: float) -> tuple[str, float, float] | None:
    """``(label, t0, t1)`` (s of run time) of the protocol's measuring window, or ``None``."""
    proto = summary.get("protocol")
    params = summary.get("parameters") or {}
    metrics = summary.get("metrics") or {}
    off = _offset(metrics, params)
    if proto == "single-rod-bend" and params.get("mean_window") is not None:
        return "mean window", off, min(off + float(params["mean_window"]), t_end)
    if proto is not None and params.get("transient") is not None:
        return "after the start-up transient", off + float(params["transient"]), t_end
    return None


def _peak_window(summary: dict, t_end: float) -> tuple[float, float]:
    """``(t0, t1)`` (s of run time) over which the protocol takes its ``F_norm_peak``: single-rod
    bend after the start-up ``transient`` of the mean window, two-rope bend the pull after any
    cinching stage, otherwise the whole run."""
    params = summary.get("parameters") or {}
    off = _offset(summary.get("metrics") or {}, params)
    if summary.get("protocol") == "single-rod-bend" and params.get("mean_window") is not None:
        return off + float(params.get("transient") or 0.0), min(off + float(params["mean_window"]), t_end)
    return off, t_end


def _peak_point(summary: dict, t: np.ndarray, y: np.ndarray) -> int | None:
    """Row of the log (``t`` s of run time, ``y`` = ``F_norm``) where the summary's peak is: the row
    at ``F_norm_peak_time`` (s of the pull, plus the offset); for a summary without that time, the
    first row of the protocol's peak window (:func:`_peak_window`) whose value is ``F_norm_peak``.
    ``None`` when the summary reports no peak."""
    metrics = summary.get("metrics") or {}
    peak = _number(metrics.get("F_norm_peak"))
    if peak is None or not len(t):
        return None
    tp = _number(metrics.get("F_norm_peak_time"))
    if tp is not None:
        return int(np.argmin(np.abs(t - (_offset(metrics, summary.get("parameters")) + tp))))
    p0, p1 = _peak_window(summary, float(t[-1]))
    hit = np.flatnonzero((t >= p0 - 1e-9) & (t <= p1 + 1e-9) & np.isclose(y, peak, rtol=1e-12, atol=0.0))
    return int(hit[0]) if hit.size else None


def _onsets(metrics: dict, off: float) -> list[tuple[str, float, float | None]]:
    """``(name, time s of run time, force or None)`` of every slip onset / force drop metric."""
    out = []
    for name, v in metrics.items():
        if isinstance(v, dict) and isinstance(v.get("time"), int | float) and re.search(r"slip|drop", name):
            f = v.get("force")
            out.append((name.replace("_", " "), off + float(v["time"]), float(f) if isinstance(f, int | float) else None))
    return out


def _reaction_magnitudes(log) -> dict[str, np.ndarray]:
    groups = sorted({c[:-3] for c in log.columns if c.endswith("_fx")})
    out = {}
    for g in groups:
        if all(f"{g}_f{c}" in log.columns for c in "xyz"):
            f = np.stack([log[f"{g}_f{c}"].to_numpy(float) for c in "xyz"], axis=1)
            out[g] = np.linalg.norm(f, axis=1)
    return out


def plot_run(run_dir: str | os.PathLike, out: str | os.PathLike | None = None) -> Path:
    """Write the force figure of ``run_dir`` (PNG; default ``run_dir/force.png``) and return its path.

    Raises
    ------
    ConfigError
        When ``run_dir`` has no ``log.parquet``, or the log has neither a force column (``F_norm``
        or ``F``) nor reaction columns.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    import pandas as pd

    run = Path(run_dir)
    log_path = run / "log.parquet"
    if not log_path.is_file():
        raise ConfigError("run_dir", f"{run} has no log.parquet (is it a run directory?)")
    log = pd.read_parquet(log_path)
    if not len(log) or "time" not in log.columns:
        raise ConfigError("log.parquet", f"{log_path} has no rows with a time column")
    summary = _read_summary(run)
    metrics = summary.get("metrics") or {}
    t = log["time"].to_numpy(float)
    title = f"{summary.get('knot', run.name)} ({summary['protocol']})" if summary.get("protocol") else run.name
    out = Path(out) if out is not None else run / "force.png"

    ycol = "F_norm" if "F_norm" in log.columns else "F" if "F" in log.columns else None
    if ycol is None:
        mags = _reaction_magnitudes(log)
        if not mags:
            raise ConfigError("log.parquet", f"{log_path} has no force column (F_norm, F or <group>_fx)")
        fig, ax = plt.subplots(figsize=FIGSIZE_ONE, dpi=DPI)
        for g, f in mags.items():
            ax.plot(t, f, label=g)
        ax.set(xlabel="time t (s)", ylabel="reaction |F| (N)", title=f"{title}: reaction forces")
        ax.legend()
        ax.grid(alpha=0.3)
        return _save(fig, out)

    y = log[ycol].to_numpy(float)
    ylabel = "F h²/EI" if ycol == "F_norm" else "F (N)"
    xcol = next(((c, lab) for c, lab in _X_COLUMNS if c in log.columns), None)
    fig, axes = plt.subplots(1, 2 if xcol else 1, figsize=FIGSIZE_TWO if xcol else FIGSIZE_ONE, dpi=DPI,
                             squeeze=False)
    ax_t = axes[0, 0]
    params = summary.get("parameters") or {}
    settle = _settle(params)
    k0 = int(np.searchsorted(t, settle - 1e-9))  # first row after settling
    if k0 > 0:  # the settling stage faint: the ends were held, no pull yet
        ax_t.plot(t[:k0 + 1], y[:k0 + 1], color="0.65", lw=0.8)
    ax_t.plot(t[k0:], y[k0:], color="tab:blue", lw=1.2, label=ylabel)
    win = _window(summary, float(t[-1]))
    if win is not None:
        label, t0, t1 = win
        ax_t.axvspan(t0, t1, color="tab:green", alpha=0.12, label=label)
    off = _offset(metrics, params)
    if settle > 0:
        ax_t.axvspan(0.0, settle, color="0.5", alpha=0.15, label="settling (ends held)")
        _scale_to_pull(ax_t, t, y, settle, ylabel)
    if off > settle:
        ax_t.axvline(off, color="0.5", lw=0.8, ls=":", label="end of pre-tightening")
    k_peak = _peak_point(summary, t, y) if ycol == "F_norm" else None
    peak = _number(metrics.get("F_norm_peak"))
    if k_peak is not None:
        ax_t.plot(t[k_peak], peak, "o", color="tab:red", label=f"peak {peak:.4g} at t = {t[k_peak]:.3g} s")
    onsets = _onsets(metrics, off)
    for name, ts, f in onsets:
        ax_t.axvline(ts, color="tab:orange", ls="--", lw=1.0, label=f"{name} at {ts:.3g} s")
        if f is not None and ycol == "F_norm":
            ax_t.plot(ts, f, "x", color="tab:orange")
    ax_t.set(xlabel="time t (s)", ylabel=ylabel, title=title)
    ax_t.grid(alpha=0.3)
    ax_t.legend(fontsize=7)
    if xcol:
        col, xlabel = xcol
        ax_x = axes[0, 1]
        x = log[col].to_numpy(float)
        if k0 > 0:
            ax_x.plot(x[:k0 + 1], y[:k0 + 1], color="0.65", lw=0.8)
        ax_x.plot(x[k0:], y[k0:], color="tab:blue", lw=1.2)
        if k_peak is not None:
            ax_x.plot(x[k_peak], peak, "o", color="tab:red", label=f"peak {peak:.4g}")
        if settle > 0:
            _scale_to_pull(ax_x, t, y, settle, None)
        for name, ts, _ in onsets:
            xs = float(np.interp(ts, t, x))
            ax_x.axvline(xs, color="tab:orange", ls="--", lw=1.0, label=f"{name} at {col} = {xs:.3g} m")
        if col == "e" and ycol == "F_norm":
            pts = [(int(m.group(1)) / 1000.0, v) for k, v in metrics.items()
                   if (m := re.fullmatch(r"F_norm_at_e_(\d+)mm", k)) and isinstance(v, int | float)
                   and math.isfinite(v)]
            if pts:
                ax_x.plot(*zip(*pts, strict=True), "s", mfc="none", color="k", label="F h²/EI at e = ... m")
        if col == "e":
            ax_x.invert_xaxis()  # the knot tightens from left to right
        ax_x.set(xlabel=xlabel, ylabel=ylabel, title=f"{ylabel} against {col}")
        ax_x.grid(alpha=0.3)
        if ax_x.get_legend_handles_labels()[0]:
            ax_x.legend(fontsize=7)
    return _save(fig, out)


def _scale_to_pull(ax, t: np.ndarray, y: np.ndarray, settle: float, label: str | None) -> None:
    """Scale the force axis to the rows after ``settle`` (s); when the settling rows reach beyond
    it, say how far in the corner (``label``: the quantity's name; ``None``: say nothing)."""
    pull = np.isfinite(y) & (t >= settle - 1e-9)
    if not pull.any():
        return
    lo, hi = float(np.min(y[pull])), float(np.max(y[pull]))
    pad = 0.08 * max(hi - lo, abs(hi), 1e-12)
    lo, hi = min(lo - pad, 0.0), hi + pad
    ax.set_ylim(lo, hi)
    early = np.isfinite(y) & (t < settle - 1e-9)
    if label is not None and early.any() and (y[early].min() < lo or y[early].max() > hi):
        ax.text(0.01, 0.98, f"while settling {label} {y[early].min():.3g} ... {y[early].max():.3g} (off scale)",
                transform=ax.transAxes, fontsize=7, color="0.3", va="top")


def _save(fig, out: Path) -> Path:
    import matplotlib.pyplot as plt

    out.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(out, dpi=DPI)
    plt.close(fig)
    return out
