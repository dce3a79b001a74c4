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

Summaries with a ``timeline`` (written since event times moved onto the log's time axis) give every
event time on the run's clock: the figure shades and names the stages (settle, set, relax, load,
pre-tightening, pull), marks each event (set knot, slow slip, run-away, capsize, decision, ...) where
it happened on the curve, draws the set force of ``knot-security`` over its set and relax stages
(dashed: the force on each of the three set ends), plots ``knot-security`` forces in mN, and draws the
displacement panel in mm from the start of the load up to the decision plus ``stop_margin``. Older
summaries count metric times from the start of the measured pull, after any settling (parameter
``settle_time``) and pre-tightening stage (``pre_pull_time`` / ``pre_tighten_time``); the figure
adds that offset. The figure uses the run's time throughout.
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
        off = 0.0 if _timeline(summary) is not None else _offset(metrics, summary.get("parameters"))
        return int(np.argmin(np.abs(t - (off + tp))))
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


#: shading of the named stages of a summary's ``timeline`` (others: light grey)
_STAGE_COLORS = {"settle": "0.6", "set": "tab:purple", "relax": "tab:olive", "pre-tighten": "tab:purple",
                 "pre-pull": "tab:purple", "load": "tab:green", "pull": "tab:green"}
_EVENT_STYLE = {"set_end": ("tab:purple", "s"), "slow_slip_onset": ("tab:orange", "v"),
                "slip_onset": ("tab:red", "x"), "capsize_onset": ("tab:brown", "D"), "decision": ("k", "*"),
                "stop": ("0.4", "|")}


def _timeline(summary: dict) -> dict | None:
    line = summary.get("timeline")
    return line if isinstance(line, dict) and isinstance(line.get("stages"), list) else None


def _set_force(summary: dict, line: dict, t: np.ndarray) -> np.ndarray | None:
    """The set force (N) on each of ``knot-security``'s three set ends at run times ``t`` (NaN after
    the relax stage), from the parameters and the timeline's set and relax stages."""
    params = summary.get("parameters") or {}
    st = {s["name"]: (float(s["start"]), float(s["end"])) for s in line["stages"]}
    tension, ramp, hold = (_number(params.get(k)) for k in ("set_tension", "set_ramp", "hold_tension"))
    if "set" not in st or tension is None or ramp is None or hold is None:
        return None
    (s0, s1), (r0, r1) = st["set"], st.get("relax", (st["set"][1], st["set"][1]))
    f = np.full(t.shape, np.nan)
    in_set = (t >= s0) & (t <= s1)
    f[in_set] = tension * np.clip((t[in_set] - s0) / ramp, 0.0, 1.0)
    in_relax = (t > r0) & (t <= r1)
    f[in_relax] = tension + (hold - tension) * (t[in_relax] - r0) / max(r1 - r0, 1e-12)
    return f


def _draw_stages(ax, line: dict) -> None:
    """Shade and name the timeline's stages on a time axis."""
    import matplotlib.transforms as mtransforms

    trans = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
    for st in line["stages"]:
        a, b = float(st["start"]), float(st["end"])
        ax.axvspan(a, b, color=_STAGE_COLORS.get(st["name"], "0.8"), alpha=0.08, lw=0)
        ax.text(0.5 * (a + b), 0.99, st["name"], transform=trans, ha="center", va="top", fontsize=7, color="0.25")


def _draw_events(ax, line: dict, t: np.ndarray, y: np.ndarray, scale: float,
                 unit: str = "") -> list[tuple[dict, float | None]]:
    """Mark each event of the timeline where it happened on the curve ``(t, y)`` (``y`` in the axis'
    units; an event's own force, N, times ``scale`` when it has one). Returns ``(event, y)`` pairs."""
    out = []
    ok = np.isfinite(y)
    for ev in line.get("events") or []:
        te = float(ev["time"])
        color, marker = _EVENT_STYLE.get(ev["name"], ("tab:orange", "o"))
        ye = None
        if isinstance(ev.get("force"), int | float) and math.isfinite(ev["force"]):
            ye = float(ev["force"]) * scale
        elif ok.any() and t[ok][0] <= te <= t[ok][-1]:
            k = int(np.clip(np.searchsorted(t, te - 1e-9), 0, len(t) - 1))
            ye = float(y[k]) if np.isfinite(y[k]) else None
        label = f"{ev['label']}: t = {te:.2f} s" + (f", {ye:.3g}{unit}" if ye is not None else "")
        if ye is None:
            ax.axvline(te, color=color, ls=":", lw=1.0, label=label)
        else:
            ax.plot(te, ye, marker, color=color, ms=7, mew=1.5, label=label, zorder=5)
        out.append((ev, ye))
    return out


def _plot_timeline(summary: dict, log, run: Path, out: Path, line: dict) -> Path:
    """The figure of a summary with a ``timeline`` (module docstring)."""
    import matplotlib.pyplot as plt

    t = log["time"].to_numpy(float)
    knot_security = summary.get("protocol") == "knot-security"
    if knot_security and "F" in log.columns:
        y, ylabel, scale = 1e3 * log["F"].to_numpy(float), "F (mN), the load on the loaded end", 1e3
    elif "F_norm" in log.columns:
        y, ylabel = log["F_norm"].to_numpy(float), "F h²/EI"
        ei, h = _number(summary.get("EI")), _number((summary.get("parameters") or {}).get("radius"))
        scale = h * h / ei if ei and h else math.nan
    else:
        y, ylabel, scale = log["F"].to_numpy(float), "F (N)", 1.0
    xcol = next(((c, lab) for c, lab in _X_COLUMNS if c in log.columns), None)
    fig, axes = plt.subplots(1, 2 if xcol else 1, figsize=(11.0, 5.2) if xcol else (6.4, 5.2), dpi=DPI,
                             squeeze=False)
    ax_t = axes[0, 0]
    title = f"{summary.get('knot', run.name)} ({summary['protocol']}): {summary.get('outcome', '')}"
    _draw_stages(ax_t, line)
    ax_t.plot(t, y, color="tab:blue", lw=1.2, label=ylabel.split(",")[0])
    if knot_security:
        fset = _set_force(summary, line, t)
        if fset is not None and np.isfinite(fset).any():
            ax_t.plot(t, scale * fset, color="tab:purple", lw=1.0, ls="--", label="set force on each set end")
    events = _draw_events(ax_t, line, t, y, scale, " mN" if scale == 1e3 else "")
    stop = line.get("stopped")
    ax_t.set(xlabel="time t (s), the run's clock", ylabel=ylabel, title=title)
    ax_t.grid(alpha=0.3)
    ax_t.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, frameon=False)
    if stop:
        ax_t.text(0.99, 0.02, f"stopped {stop['time'] - line['decision']['time']:.2g} s after the decision"
                  if line.get("decision") else "stopped early", transform=ax_t.transAxes, ha="right",
                  fontsize=7, color="0.3")
    if xcol:
        _displacement_panel(axes[0, 1], summary, log, line, xcol, t, y, ylabel, events)
    return _save(fig, out)


def _displacement_panel(ax, summary: dict, log, line: dict, xcol, t, y, ylabel: str, events) -> None:
    """Force against the geometry column over the measured stage, up to the decision plus the
    margin; ``u_pull`` in mm counted from the start of the load."""
    col, xlabel = xcol
    stages = {s["name"]: s for s in line["stages"]}
    load = stages.get("load") or stages.get("pull")
    t0 = float(load["start"]) if load else float(t[0])
    t1 = float(t[-1])
    dec = line.get("decision")
    if dec is not None:
        margin = _number((summary.get("parameters") or {}).get("stop_margin")) or 1.0
        t1 = min(t1, float(dec["time"]) + margin)
    sel = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
    x = log[col].to_numpy(float)
    if col == "u_pull":
        k0 = int(np.argmax(sel)) if sel.any() else 0
        x = 1e3 * (x - x[k0])
        xlabel = "loaded end out since the load began (mm)"
    ax.plot(x[sel], y[sel], color="tab:blue", lw=1.2)
    for ev, ye in events:
        te = float(ev["time"])
        if ye is None or not (t0 - 1e-9 <= te <= t1 + 1e-9) or ev["name"] == "stop":
            continue
        color, marker = _EVENT_STYLE.get(ev["name"], ("tab:orange", "o"))
        xe = float(np.interp(te, t, x))
        ax.plot(xe, ye, marker, color=color, ms=7, mew=1.5,
                label=f"{ev['label']}: {xe:.3g}{' mm' if col == 'u_pull' else ''}", zorder=5)
    if col == "u_pull" and dec is not None and sel.any():
        # the knot's own regime: up to the decision; the run-away after it is said, not drawn to scale
        xd = float(np.interp(float(dec["time"]), t, x))
        lo, hi = float(np.nanmin(x[sel & (t <= float(dec["time"]) + 1e-9)])), xd
        pad = 0.1 * max(hi - lo, 1.0)
        if float(np.nanmax(x[sel])) > hi + pad:
            ax.set_xlim(lo - pad, hi + pad)
            inside = sel & (x <= hi + pad)
            ax.set_ylim(float(np.nanmin(y[inside])) - 1.0, float(np.nanmax(y[inside])) * 1.1 + 1.0)
            ax.text(0.98, 0.02, f"after the decision the end runs out to {float(np.nanmax(x[sel])):.4g} mm "
                                f"(t = {t1:.2f} s)", transform=ax.transAxes, ha="right", fontsize=7, color="0.3")
    if col == "e":
        ax.invert_xaxis()
    span = f"t = {t0:.2f} ... {t1:.2f} s" + (" (decision + margin)" if dec is not None else "")
    ax.set(xlabel=xlabel, ylabel=ylabel, title=f"the load stage, {span}")
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, frameon=False)


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

    line = _timeline(summary)
    if line is not None and summary.get("protocol") == "knot-security":
        return _plot_timeline(summary, log, run, out, line)
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
    event_off = 0.0 if line is not None else off  # metric times on the run's clock (a timeline) or the pull's
    if settle > 0:
        ax_t.axvspan(0.0, settle, color="0.5", alpha=0.15, label="settling (ends held)")
        _scale_to_pull(ax_t, t, y, settle, ylabel)
    if off > settle:
        ax_t.axvline(off, color="0.5", lw=0.8, ls=":", label="end of pre-tightening")
    k_peak = _peak_point(summary, t, y) if ycol == "F_norm" else None
    peak = _number(metrics.get("F_norm_peak"))
    if k_peak is not None:
        ax_t.plot(t[k_peak], peak, "o", color="tab:red", label=f"peak {peak:.4g} at t = {t[k_peak]:.3g} s")
    onsets = _onsets(metrics, event_off)
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
