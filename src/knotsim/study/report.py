"""Markdown report of a study: tables and PNG plots (matplotlib, Agg).

``write_report(STUDY_DIR)`` writes ``STUDY_DIR/report.md`` and its figures in
``STUDY_DIR/report_figures/``:

- summary (cases, outcomes, wall time, provenance) and the swept parameters;
- a results table (parameters, outcome, wall time and the main metrics) and the failed cases;
- for a study with the MAE259B shape (a knot axis with granny and reef, a friction axis ``mu``):
  ``F h²/EI`` against time for granny and reef at μ = 0.1 and 0.5 (from each case's
  ``log.parquet``, column ``F_norm``), and the mean ``F h²/EI`` (metric ``F_norm_mean``) against μ;
  beside the published values (docs/physics.md §5) only when every case has the published set-up
  (:func:`published_setup_differences`: protocol ``single-rod-bend``, the full 13 s window and the
  published parameters), otherwise the report says what differs;
- one figure per metric of interest (the strength metrics, or those given as ``plot_metrics``)
  that varies beyond round-off (relative spread above :data:`ROUND_OFF`): against the swept
  parameter with the most values, one line per combination of the other swept parameters (mean
  and spread over repeats). Solver statistics and timings stay in the table.

Everything adapts to the columns that exist; a study with no completed case still gets a report.
Figures are 640 x 400 pixels (6.4 x 4.0 in at 100 dpi).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from knotsim._util.toml import load_toml
from knotsim.errors import ConfigError

__all__ = ["MAE259B_PUBLISHED", "write_report"]

#: Published mean F h²/EI over a 13 s pull (MAE259B; docs/physics.md §5), by knot, at μ = 0.1 ... 0.5.
MAE259B_PUBLISHED = {
    "mu": [0.1, 0.2, 0.3, 0.4, 0.5],
    "granny": [0.264, 0.297, 0.519, 0.576, 0.641],
    "reef": [0.367, 0.470, 0.538, 0.655, 0.834],
}

FIGSIZE = (6.4, 4.0)  # in
DPI = 100
_NOT_METRICS = {"case_id", "kind", "outcome", "error", "wall_time", "traceback", "case_dir", "repeat"}
_MAX_TABLE_METRICS = 8
#: A metric whose spread over the completed cases is below this fraction of its magnitude is
#: constant up to round-off (e.g. ``sim_time`` summed from steps) and not plotted.
ROUND_OFF = 1e-9
#: Parameters of the published MAE259B set-up (values: the single-rod-bend protocol's defaults).
PUBLISHED_KEYS = ("n_nodes", "radius", "length", "youngs_modulus", "density", "poisson_ratio", "damping", "gravity",
                  "dt", "contact.delta", "contact.nu", "pull_speed", "mean_window", "end_twist")


# ------------------------------------------------------------------------------------------ helpers
def _md_cell(v) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    try:
        import pandas as pd

        if v is pd.NA:
            return ""
    except ImportError:  # pragma: no cover
        pass
    if isinstance(v, bool | np.bool_):
        return "yes" if v else "no"
    if isinstance(v, int | np.integer):
        return str(int(v))
    if isinstance(v, float | np.floating):
        return f"{float(v):.4g}"
    return str(v).replace("|", "\\|").replace("\n", " ")


def _md_table(df, columns: list[str]) -> str:
    head = "| " + " | ".join(c.replace("|", "\\|") for c in columns) + " |"
    sep = "|" + "|".join("---" for _ in columns) + "|"
    rows = ["| " + " | ".join(_md_cell(v) for v in rec) + " |" for rec in df[columns].itertuples(index=False)]
    return "\n".join([head, sep, *rows])


def _slug(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", s).strip("_")[:60] or "x"


def _numeric(series) -> bool:
    import pandas as pd

    return pd.api.types.is_numeric_dtype(series) and not pd.api.types.is_bool_dtype(series)


def _figure():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=FIGSIZE, dpi=DPI)
    return fig, ax


def _save(fig, path: Path) -> None:
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


def _finish_plot(fig, ax, labels: tuple[str, str, str], figdir: Path, name: str, alt: str) -> list[str]:
    """Label (x, y, title), add the legend and grid, save ``figdir/name``; the report's image lines."""
    xlabel, ylabel, title = labels
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend()
    ax.grid(alpha=0.3)
    _save(fig, figdir / name)
    return [f"![{alt}](report_figures/{name})", ""]


def _param_columns(study_dir: Path, df) -> list[str]:
    """Swept parameter columns, from study.toml when it parses, else the columns between ``kind``
    and ``outcome``."""
    try:
        from knotsim.study.spec import load_study_spec

        spec = load_study_spec(study_dir / "study.toml")
        cols = [k for k in spec.swept_keys if k in df.columns]
        if spec.repeats > 1 and "repeat" in df.columns:
            cols.append("repeat")
        return cols
    except Exception:
        cols = list(df.columns)
        if "kind" in cols and "outcome" in cols:
            return cols[cols.index("kind") + 1: cols.index("outcome")]
        return []


def _metric_columns(df, params: list[str]) -> list[str]:
    """Numeric metric columns that vary over the completed cases (wall time last)."""
    done = df[df["outcome"] == "completed"] if "outcome" in df.columns else df
    out = []
    for c in df.columns:
        if c in _NOT_METRICS or c in params or not _numeric(df[c]):
            continue
        vals = done[c].dropna().astype(float).to_numpy()
        vals = vals[np.isfinite(vals)]
        if len(vals) and np.ptp(vals) > ROUND_OFF * max(float(np.max(np.abs(vals))), 1e-300):
            out.append(c)
    return sorted(out, key=_priority)


def _priority(name: str) -> int:
    """Strength metrics first, solver statistics and timings last."""
    if re.search(r"wall_time|iterations|steps|failures|attempts|contact\.|topology\.|detected_at", name):
        return 2
    if re.search(r"F_norm|traction|strength|force|slip", name):
        return 0
    return 1


def _is_numeric_values(values) -> bool:
    return all(isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool) for v in values)


# ------------------------------------------------------------------------------------------ MAE259B
def _find_knot_mu(df, params: list[str]) -> tuple[str | None, str | None]:
    """The knot and friction axes of a study of the MAE259B shape: single-rod reef and granny
    (knots of kind ``single_rod_bend``, or tied by earlier runs, when the table says, so that
    two-rope reef and granny *bends* are not compared with the single-rod published values) against
    ``mu``; the knot axis is ``knot`` or ``geometry`` (tie directories named for their knot)."""
    knot = mu = None
    if "knot_kind" in df.columns:
        kinds = {str(v) for v in df["knot_kind"].dropna().unique()}
        # "run": the knots were tied by an earlier run (a study's ``geometry`` axis of tie directories)
        if kinds and not kinds <= {"single_rod_bend", "run"}:
            return None, None
    for p in params:
        leaf = p.rsplit(".", 1)[-1]
        if leaf in ("knot", "geometry"):
            vals = [str(v).lower() for v in df[p].dropna().unique()]
            if any("granny" in v for v in vals) and any("reef" in v for v in vals):
                knot = p
        elif leaf == "mu":
            mu = p
    return knot, mu


def _knot_label(name) -> str | None:
    n = Path(str(name)).name.lower()  # a geometry axis holds paths: only the last part names the knot
    return "granny" if "granny" in n else "reef" if "reef" in n else None


def _traction_series(study_dir: Path, row):
    """(time s, F h²/EI) of a case from its log.parquet, else from the study's thinned series
    (``timeseries.parquet``), or None."""
    import pandas as pd

    from knotsim.study.store import StudyStore

    log = None
    if isinstance(row.get("case_dir"), str) and (study_dir / row["case_dir"] / "log.parquet").is_file():
        try:
            log = pd.read_parquet(study_dir / row["case_dir"] / "log.parquet")
        except Exception:
            log = None
    if log is None and isinstance(row.get("case_id"), str):
        try:
            log = StudyStore(study_dir).read_series(row["case_id"])
        except Exception:
            log = None
    if log is None:
        return None
    for col in ("F_norm", "F_h2_EI", "traction_norm"):
        if col in log.columns and "time" in log.columns:
            return log["time"].to_numpy(float), log[col].to_numpy(float)
    return None


def _fmt_value(v) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def published_setup_differences(study_dir: str | os.PathLike, df) -> list[str]:
    """What keeps the completed cases of ``df`` from being the published MAE259B set-up (empty: it
    matches): the protocol, the measured window (``mean_window`` = 13 s, all of it simulated) and
    the :data:`PUBLISHED_KEYS` parameters, read from each case's ``summary.json`` when the study
    has it (a case directory, or a packed study's ``cases.parquet``), else from the results table
    (its ``overrides.*`` columns)."""
    from knotsim.protocols.params import COMMON_DEFAULTS
    from knotsim.protocols.registry import get_protocol
    from knotsim.study.store import StudyStore

    store = StudyStore(study_dir)

    published = dict(COMMON_DEFAULTS)
    published.update(get_protocol("single-rod-bend").defaults)
    want = {k: published[k] for k in PUBLISHED_KEYS}
    done = df[df["outcome"] == "completed"] if "outcome" in df.columns else df
    diffs: dict[str, str] = {}

    def differ(key, got, ref) -> None:
        same = (math.isclose(float(got), float(ref), rel_tol=1e-9) if isinstance(ref, int | float)
                and isinstance(got, int | float) and not isinstance(got, bool) else got == ref)
        if not same and key not in diffs:
            diffs[key] = f"{key} {_fmt_value(got)} instead of {_fmt_value(ref)}"

    for _, row in done.iterrows():
        summary = store.read_summary(str(row["case_id"])) if isinstance(row.get("case_dir"), str) else None
        if summary is not None:
            if summary.get("protocol") != "single-rod-bend":
                differ("protocol", summary.get("protocol"), "single-rod-bend")
            got = summary.get("parameters") or {}
            for k, ref in want.items():
                if k in got:
                    differ(k, got[k], ref)
            sim_time = summary.get("sim_time")
        else:
            if row.get("kind") not in (None, "protocol"):
                differ("kind", row.get("kind"), "protocol")
            geometry = row.get("geometry")
            if isinstance(geometry, str) and geometry and "geometry" not in diffs:
                # a pulled geometry brings its own rope, which the results table does not record
                diffs["geometry"] = (f"geometry {geometry} (its rope's parameters are not in the results "
                                     "table, and its case directory is not there to read them from)")
            for k, ref in want.items():
                v = row.get(f"overrides.{k}")
                if v is not None and not (isinstance(v, float) and math.isnan(v)):
                    differ(k, v, ref)
            if row.get("mean_window") is not None and not _isna(row.get("mean_window")):
                differ("mean_window", float(row["mean_window"]), want["mean_window"])
            sim_time = row.get("sim_time")
        if sim_time is not None and not _isna(sim_time):
            pre = row.get("pre_pull_time")
            pre = 0.0 if pre is None or _isna(pre) else float(pre)
            if float(sim_time) < pre + want["mean_window"] - 1e-6 and "duration" not in diffs:
                diffs["duration"] = (f"simulated {float(sim_time):.4g} s, not the full "
                                     f"{want['mean_window']:g} s window")
    return list(diffs.values())


def _isna(v) -> bool:
    try:
        return bool(v != v)  # NaN
    except (TypeError, ValueError):
        return False


def _mae259b(study_dir: Path, df, params, figdir: Path) -> list[str]:
    knot, mu = _find_knot_mu(df, params)
    if knot is None or mu is None:
        return []
    lines = ["## Reef against granny (MAE259B)", ""]
    differences = published_setup_differences(study_dir, df)
    if differences:
        lines += ["Not compared with the published values: the set-up differs from the published one ("
                  + "; ".join(differences) + ").", ""]
    else:
        lines += ["Every case has the published set-up (protocol single-rod-bend, the full 13 s window, "
                  f"{', '.join(PUBLISHED_KEYS)} as published), so the published values are shown.", ""]
    done = df[df["outcome"] == "completed"].copy()
    done["_knot"] = done[knot].map(_knot_label)
    done = done[done["_knot"].notna()]
    # time series at mu = 0.1 and 0.5
    fig, ax = _figure()
    drawn = 0
    styles = {"granny": "tab:blue", "reef": "tab:red"}
    for m, ls in ((0.1, "-"), (0.5, "--")):
        for k in ("granny", "reef"):
            sel = done[(done["_knot"] == k) & np.isclose(done[mu].astype(float), m)]
            if sel.empty:
                continue
            series = _traction_series(study_dir, sel.iloc[0])
            if series is None:
                continue
            t, f = series
            t_pre = sel.iloc[0].get("pre_pull_time") if "pre_pull_time" in sel.columns else None
            if t_pre is not None and np.isfinite(float(t_pre)) and float(t_pre) > 0:
                keep = t >= float(t_pre) - 1e-9  # the pull window only, timed from its start
                t, f = t[keep] - float(t_pre), f[keep]
            ax.plot(t, f, ls, color=styles[k], label=f"{k}, μ = {m:g}")
            drawn += 1
    if drawn:
        lines += _finish_plot(fig, ax, ("pull time t (s)", "F h²/EI", "Traction against time"), figdir,
                              "mae259b_traction_time.png", "F h²/EI against time")
    else:
        import matplotlib.pyplot as plt

        plt.close(fig)
        lines += ["(no traction time series (log.parquet with F_norm) for μ = 0.1 or 0.5)", ""]
    # mean traction against mu, next to the published values
    metric = next((c for c in ("F_norm_mean", "mean_F_norm", "F_h2_EI_mean") if c in done.columns), None)
    fig, ax = _figure()
    pub = MAE259B_PUBLISHED
    if not differences:
        for k in ("granny", "reef"):
            ax.plot(pub["mu"], pub[k], "o--", color=styles[k], mfc="none", label=f"{k}, published")
    table_rows = []
    if metric is not None:
        for k in ("granny", "reef"):
            sel = done[done["_knot"] == k]
            if sel.empty:
                continue
            g = sel.groupby(sel[mu].astype(float))[metric].agg(["mean", "std", "count"]).sort_index()
            ax.errorbar(g.index, g["mean"], yerr=g["std"].fillna(0.0), fmt="s-", color=styles[k],
                        label=f"{k}, knotsim")
            for m, r in g.iterrows():
                table_rows.append((k, m, r["mean"]))
    lines += _finish_plot(fig, ax, ("friction coefficient μ", "mean F h²/EI", "Mean traction against μ"), figdir,
                          "mae259b_mean_traction_mu.png", "mean F h²/EI against μ")
    if table_rows and differences:
        lines += ["| knot | μ | knotsim mean F h²/EI |", "|---|---|---|"]
        for k, m, v in sorted(table_rows):
            lines.append(f"| {k} | {m:g} | {_md_cell(v)} |")
        lines.append("")
    elif table_rows:
        lines += ["| knot | μ | knotsim mean F h²/EI | published | ratio |", "|---|---|---|---|---|"]
        for k, m, v in sorted(table_rows):
            ref = next((p for x, p in zip(pub["mu"], pub[k], strict=True) if math.isclose(x, m)), None)
            ratio = v / ref if ref else None
            lines.append(f"| {k} | {m:g} | {_md_cell(v)} | {_md_cell(ref)} | {_md_cell(ratio)} |")
        lines.append("")
    elif metric is None:
        lines += ["(no mean-traction metric F_norm_mean in the results)", ""]
    return lines


# ------------------------------------------------------------------------------------------ generic
def _primary_axis(done, params: list[str]) -> tuple[str | None, list[str]]:
    """The swept parameter a metric is plotted against (the one with the most values, numeric
    first) and the other swept parameters that vary (one line per combination of them)."""
    axes = [p for p in params if p != "repeat" and done[p].nunique(dropna=True) >= 2]
    if not axes:
        return None, []
    x = max(axes, key=lambda p: (done[p].nunique(dropna=True), _is_numeric_values(list(done[p].dropna()))))
    return x, [q for q in axes if q != x]


def _generic_plots(df, params, metrics, figdir: Path, max_plots: int, bar=None) -> list[str]:
    """One figure per metric: against the primary swept parameter, a line per combination of the
    others."""
    done = df[df["outcome"] == "completed"] if "outcome" in df.columns else df
    p, others = _primary_axis(done, params)
    lines: list[str] = []
    if p is None:
        return lines
    values = list(done[p].dropna().unique())
    numeric_x = _is_numeric_values(values)
    order = sorted(float(v) for v in values) if numeric_x else sorted(values, key=str)
    for n, m in enumerate(metrics):
        if n >= max_plots:
            lines.append(f"(more plots left out: at most {max_plots})")
            break
        if bar is not None:
            bar.update(1)
        sub = done[[p, m, *others]].dropna(subset=[p, m])
        if sub.empty:
            continue
        fig, ax = _figure()
        groups = sub.groupby(others, sort=True, dropna=False) if others else [((), sub)]
        for key, g in groups:
            key = key if isinstance(key, tuple) else (key,)
            if numeric_x:
                xs = g[p].astype(float)
            else:
                pos = {v: i for i, v in enumerate(order)}
                xs = g[p].map(pos).astype(float)
            agg = g.assign(_x=xs.to_numpy()).groupby("_x")[m].agg(["mean", "std"]).sort_index()
            label = ", ".join(f"{q} = {_md_cell(v)}" for q, v in zip(others, key, strict=True)) or None
            ax.errorbar(agg.index, agg["mean"], yerr=agg["std"].fillna(0.0), fmt="o-", capsize=3, label=label)
        if not numeric_x:
            ax.set_xticks(range(len(order)), [str(v) for v in order], rotation=20)
        elif len(order) > 2 and order[0] > 0 and order[-1] / order[0] >= 100:
            ax.set_xscale("log")
        ax.set_xlabel(p)
        ax.set_ylabel(m)
        ax.set_title(f"{m} against {p}")
        ax.grid(alpha=0.3)
        if others and len(sub.groupby(others)) <= 12:
            ax.legend(fontsize=7)
        name = f"{_slug(m)}__vs__{_slug(p)}.png"
        _save(fig, figdir / name)
        lines += [f"![{m} against {p}](report_figures/{name})", ""]
    return lines


def _of_interest(metrics: list[str]) -> list[str]:
    """The strength metrics (force, traction, slip), or the next tier when there is none."""
    for tier in (0, 1):
        picked = [m for m in metrics if _priority(m) == tier]
        if picked:
            return picked
    return []


# ------------------------------------------------------------------------------------------ report
def write_report(study_dir: str | os.PathLike, out: str | os.PathLike | None = None, *, max_plots: int = 12,
                 plot_metrics: Sequence[str] | None = None, progress: bool = False) -> Path:
    """Write the Markdown report of ``study_dir`` (default ``study_dir/report.md``) and its figures
    (``report_figures/`` next to it); returns the report's path. ``max_plots`` limits the
    number of metric figures; ``plot_metrics`` (metric column names, e.g. ``["F_norm_hold"]``)
    plots only those, in that order (default: the strength metrics that vary beyond round-off);
    ``progress`` shows a progress bar (tqdm, on stderr) over the figures.

    Raises
    ------
    ConfigError
        When a name in ``plot_metrics`` is not a metric column of the study.
    """
    from knotsim.study.store import StudyStore, load_study

    study_dir = Path(study_dir)
    df = load_study(study_dir)
    out = Path(out) if out is not None else study_dir / "report.md"
    figdir = out.parent / "report_figures"
    store = StudyStore(study_dir)
    prov = store.read_provenance()
    params = _param_columns(study_dir, df)
    metrics = _metric_columns(df, params) if len(df) else []
    plotted = _of_interest(metrics)
    if plot_metrics is not None:
        unknown = [m for m in plot_metrics if m not in df.columns]
        if unknown:
            raise ConfigError("metric", f"no metric column {unknown[0]!r} in the study; metrics are {metrics}")
        plotted = list(plot_metrics)
    figdir.mkdir(parents=True, exist_ok=True)
    for old in figdir.glob("*.png"):
        old.unlink()

    name = prov.get("study") or study_dir.name
    lines = [f"# Study report: {name}", ""]
    try:
        desc = load_toml(store.study_file, "study").get("description")
        if desc:
            lines += [desc, ""]
    except (OSError, ConfigError):  # unreadable or not TOML: the report goes on without the description
        pass
    counts = df["outcome"].value_counts().to_dict() if "outcome" in df.columns and len(df) else {}
    wall = float(df["wall_time"].dropna().sum()) if "wall_time" in df.columns and len(df) else 0.0
    lines += [f"- cases in the table: {len(df)} ("
              + (", ".join(f"{v} {k}" for k, v in counts.items()) or "none") + ")",
              f"- total case wall time: {wall:.1f} s"]
    if prov:
        commit = prov.get("git_commit")
        lines.append(f"- knotsim {prov.get('knotsim_version')}" + (f", commit {commit[:12]}" if commit else "")
                     + f", Python {prov.get('python')}, host {prov.get('machine', {}).get('hostname')}; "
                     f"{len(prov.get('sessions', []))} session(s), see provenance.json")
    lines.append("")

    if params:
        lines += ["## Swept parameters", "", "| parameter | values |", "|---|---|"]
        for p in params:
            vals = list(df[p].dropna().unique())
            vals = sorted(vals, key=float) if _is_numeric_values(vals) else sorted(vals, key=str)
            lines.append(f"| {p} | {', '.join(_md_cell(v) for v in vals)} |")
        lines.append("")

    if len(df):
        shown = metrics[:_MAX_TABLE_METRICS]
        cols = ["case_id", *params, "outcome", *(["wall_time"] if "wall_time" in df.columns else []), *shown]
        lines += ["## Results", ""]
        if len(metrics) > len(shown):
            lines += [f"{len(metrics) - len(shown)} more metrics in results.parquet "
                      "(`knotsim.load_study(STUDY_DIR)`).", ""]
        lines += [_md_table(df, cols), ""]
        failed = df[df["outcome"] == "failed"] if "outcome" in df.columns else df.iloc[:0]
        if len(failed):
            lines += ["## Failed cases", "", _md_table(failed, ["case_id", *params, "error"]), "",
                      "Tracebacks: column `traceback` of results.parquet and `cases/<case_id>/error.txt`.", ""]
        from tqdm.auto import tqdm

        with tqdm(total=min(len(plotted), max_plots) + 1, desc="report figures", unit="figure",
                  disable=not progress, leave=False) as bar:
            lines += _mae259b(study_dir, df, params, figdir)
            bar.update(1)
            plots = _generic_plots(df, params, plotted, figdir, max_plots, bar)
        if plots:
            lines += ["## Metrics against swept parameters", "",
                      "One figure per strength metric that varies beyond round-off"
                      + (f" ({', '.join(plot_metrics)} as asked)" if plot_metrics is not None else "")
                      + "; the other metrics are in the table above.", "", *plots]
    else:
        lines += ["No finished case yet.", ""]

    out.write_text("\n".join(lines).rstrip() + "\n")
    return out
