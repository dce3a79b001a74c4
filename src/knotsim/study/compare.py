"""Which of these knots holds better: every knot at every friction coefficient, one table.

:func:`compare_knots` runs each knot at each friction coefficient ``mu`` through one loading
protocol (a study of protocol cases, run by :func:`knotsim.study.run_study`: parallel and
resumable) and writes into ``out_dir``::

    compare.toml     the study it ran (``knotsim study compare.toml -o study --resume`` reruns it)
    study/           the study directory (study.toml, results.parquet, cases/<case_id>/...;
                     ``knotsim report study`` writes the study's own report there)
    report.md        the table, the parameters that differ from the protocol's defaults, the force
                     figure and a picture of each knot at its decision
    forces.png       every force curve on shared axes
    pictures/        one folder of PNG files per case

The table has one row per knot and one column per ``mu``; a cell shows the protocol's headline
metrics (:data:`CELL_METRICS`; knot-security: the run-away slip load and the slow-slip load, mN),
the outcome and any flag (:data:`CELL_FLAGS`, e.g. ``not set``), or the error of a failed case.
A value that is only an upper bound (the knot was already slipping when the detection began) is
written ``≤ x``; a knot that never slipped under the ramp ``> x`` (the largest load it held).
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from knotsim._util.toml import dumps_toml, load_toml, loads_toml
from knotsim.errors import ConfigError

__all__ = ["CELL_FLAGS", "CELL_METRICS", "CellFlag", "CellMetric", "CompareResult", "cell_text", "compare_knots",
           "compare_study", "format_table", "parse_mu_list"]

#: The study file, the study directory and the report in a comparison's directory.
STUDY_FILE = "compare.toml"
STUDY_DIR = "study"
REPORT = "report.md"
FIGURE = "forces.png"
PICTURES = "pictures"
#: What :func:`compare_knots` writes into its directory (removed by ``overwrite``).
COMPARE_FILES = (STUDY_FILE, STUDY_DIR, REPORT, FIGURE, PICTURES)
#: Size of the pictures of the knots, pixels (width, height).
PICTURE_SIZE = (480, 360)
#: Longest error text shown in a cell (characters; the report lists the whole message).
ERROR_WIDTH = 48


@dataclass(frozen=True)
class CellMetric:
    """One metric shown in the cells of a protocol.

    ``name``: the metric (a scalar of the summary's ``metrics``); ``label``: what the legend calls
    it; ``scale`` and ``unit``: the value shown is ``scale * value`` in ``unit`` (e.g. 1e3, "mN"
    for a force in N); ``bound``: a boolean metric which, when true, makes the value an upper bound
    (shown ``≤ x``); ``beyond``: a metric shown as ``> x`` when this one is missing (the knot held
    up to x).
    """

    name: str
    label: str
    scale: float = 1.0
    unit: str = ""
    bound: str | None = None
    beyond: str | None = None


#: The metrics each protocol's cell shows (those the cases have: knot-security's ramp, hold, slide
#: and pulses modes each report their own). A protocol not listed shows ``F_norm_peak``.
CELL_METRICS: dict[str, tuple[CellMetric, ...]] = {
    "knot-security": (
        CellMetric("slip_load", "slip load (run-away)", 1e3, "mN", "slip_during_transient", "largest_load_held"),
        CellMetric("slow_slip_load", "slow-slip load", 1e3, "mN", "slow_slip_during_transient"),
        CellMetric("drift_through_late", "rope let through over the hold's second half", 1e3, "mm"),
        CellMetric("sliding_resistance", "sliding resistance", 1e3, "mN"),
        CellMetric("cycles_to_spill", "pulses to spill"),
    ),
    "two-rope-bend": (CellMetric("F_norm_hold", "holding F h²/EI"), CellMetric("F_norm_peak", "peak F h²/EI")),
    "single-rod-bend": (CellMetric("F_norm_mean", "mean F h²/EI"), CellMetric("F_norm_peak", "peak F h²/EI")),
    "overhand-pull": (CellMetric("F_norm_peak", "peak F h²/EI"),),
}
_DEFAULT_CELL = (CellMetric("F_norm_peak", "peak F h²/EI"),)

@dataclass(frozen=True)
class CellFlag:
    """A short flag added to a cell: ``text`` when metric ``metric`` is ``value``, or when the
    protocol's outcome carries the flag ``outcome_flag`` (``"slipped; loaded before it was set"``);
    ``meaning`` goes into the legend."""

    metric: str
    value: Any
    text: str
    meaning: str
    outcome_flag: str | None = None


#: The flags a cell can carry. Other flags of an outcome (after its ``;``) are shown as they are.
CELL_FLAGS: tuple[CellFlag, ...] = (
    CellFlag("set_still", False, "not set", "the knot was still moving when its set ended (loaded before it was set)",
             "loaded before it was set"),
)


# ------------------------------------------------------------------------------------------ input
def parse_mu_list(text: str) -> list[float]:
    """``"0.2,0.3,0.4"`` -> ``[0.2, 0.3, 0.4]`` (friction coefficients, dimensionless).

    Raises
    ------
    ConfigError
        (field ``mu``) when an entry is not a number, or is negative or not finite.
    """
    parts = [p.strip() for p in str(text).split(",")]
    if not any(parts):
        raise ConfigError("mu", f"expected friction coefficients separated by commas, e.g. 0.2,0.3; got {text!r}")
    out = []
    for p in parts:
        try:
            out.append(float(p))
        except ValueError:
            raise ConfigError("mu", f"--mu {text}: {p!r} is not a number (expected e.g. 0.2,0.3,0.4)") from None
    return _check_mu(out, f"--mu {text}")


def _check_mu(values: Sequence[float], shown: str) -> list[float]:
    out: list[float] = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v < 0:
            raise ConfigError("mu", f"{shown}: {v!r} is not a friction coefficient (a finite number >= 0)")
        if float(v) not in out:
            out.append(float(v))
    if not out:
        raise ConfigError("mu", f"{shown}: no friction coefficient given")
    return out


def _knot_entry(knot: str, builtin: set[str]) -> str:
    """The knot as a case names it: a library name, or the absolute path of a drawing file."""
    if not isinstance(knot, str) or not knot.strip():
        raise ConfigError("knot", f"expected a library knot name or a .toml drawing, got {knot!r}")
    if knot in builtin:
        return knot
    path = Path(knot)
    if path.suffix.lower() == ".toml" or path.exists():
        if not path.is_file():
            raise ConfigError("knot", f"no knot drawing {knot!r} (not a file)")
        return str(path.resolve())
    raise ConfigError("knot", f"unknown knot {knot!r}; `knotsim knots` lists the library "
                              f"({', '.join(sorted(builtin))}), or give the path of a .toml drawing")


#: said with every quick comparison: its coarse settings show that the runs work, they do not rank knots
QUICK_WARNING = ("Quick settings (coarse rope, long time steps, a fast load) are a first look at what the "
                 "runs do, not a measurement: the order of the knots can differ from the full-size runs'. "
                 "Run without --quick to compare them.")


def _protocol_defaults(protocol: str, quick: bool) -> tuple[dict, dict]:
    """The protocol's defaults (common ones included) and its quick settings (empty unless ``quick``)."""
    from knotsim.protocols.params import COMMON_DEFAULTS
    from knotsim.protocols.registry import get_protocol

    proto = get_protocol(protocol)
    return {**COMMON_DEFAULTS, **proto.defaults}, (dict(proto.quick) if quick else {})


def compare_study(knots: Sequence[str], *, protocol: str = "knot-security", mu: float | Sequence[float] | None = None,
                  overrides: dict | None = None, quick: bool = False) -> dict:
    """The study (a dict in the format of study files, ``docs/studies.md``) that compares ``knots``.

    Checks every input first: an unknown knot or protocol, a drawing file that does not exist, an
    unknown or ill-typed override and a bad friction coefficient raise :class:`ConfigError`. Knot
    files are named by their absolute paths. ``mu`` (default: ``overrides["mu"]``, else the
    protocol's default) is swept as ``overrides.mu``, the knots as ``knot``.
    """
    from knotsim.knots.library import knot_names
    from knotsim.protocols.params import resolve_params

    if isinstance(knots, str):
        knots = [knots]
    if not knots:
        raise ConfigError("knots", "give at least one knot to compare")
    defaults, quick_layer = _protocol_defaults(protocol, quick)
    overrides = dict(overrides or {})
    resolve_params(defaults, quick_layer, overrides)  # unknown keys and bad types, before anything runs
    if "contact.mu" in overrides:
        overrides["mu"] = overrides.pop("contact.mu")
    if mu is None:
        mu_list = [overrides.pop("mu") if "mu" in overrides else quick_layer.get("mu", defaults["mu"])]
        mu_list = _check_mu(mu_list, "mu")
    else:
        if "mu" in overrides:
            raise ConfigError("mu", f"given twice: --mu and --set mu={overrides['mu']!r}; give the list with --mu")
        mu_list = _check_mu([mu] if isinstance(mu, int | float) else list(mu), f"mu {mu!r}")
    builtin = set(knot_names())
    entries = list(dict.fromkeys(_knot_entry(k, builtin) for k in knots))
    base: dict[str, Any] = {"protocol": protocol, "knot": entries[0]}
    if quick:
        base["quick"] = True
    base["overrides"] = overrides
    labels = [_label(e) for e in entries]
    return {"name": "compare-" + "-".join(labels),
            "description": f"knotsim compare: {', '.join(labels)} under {protocol}"
                           + (" (quick settings)" if quick else "")
                           + f" at mu = {', '.join(f'{m:g}' for m in mu_list)}",
            "base": base,
            "grid": {"knot": entries, "overrides.mu": mu_list}}


def _label(knot: str) -> str:
    """A knot's name in the table: the library name, or a drawing file's name without ``.toml``."""
    return Path(knot).stem if (os.sep in knot or knot.lower().endswith(".toml")) else knot


# ------------------------------------------------------------------------------------------ cells
def _present(v) -> bool:
    if v is None:
        return False
    try:
        import pandas as pd

        if v is pd.NA:
            return False
    except ImportError:  # pragma: no cover
        pass
    return not (isinstance(v, float) and math.isnan(v))


def _number(v: float) -> str:
    return f"{v:.3g}"


def _short(text: str, width: int = ERROR_WIDTH) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= width else text[: width - 1].rstrip() + "…"


def cell_metrics(protocol: str, available: Sequence[str] | None = None) -> tuple[CellMetric, ...]:
    """The :data:`CELL_METRICS` of ``protocol``, those in ``available`` (metric names) when given."""
    entries = CELL_METRICS.get(protocol, _DEFAULT_CELL)
    if available is None:
        return entries
    return tuple(m for m in entries if m.name in available)


def cell_text(row: dict, metrics: Sequence[CellMetric]) -> str:
    """The text of one cell: the values of ``metrics`` in ``row`` (joined by ``/``, one unit when
    they share it), the outcome and the flags; or ``failed: <short error>``.

    ``row``: a case's record, flat: ``status`` (``"completed"`` or ``"failed"``), ``error``,
    ``outcome`` (the protocol's) and the metrics by name (missing values ``None`` or NaN).
    """
    if row.get("status") == "failed":
        return "failed: " + _short(row.get("error") or "unknown error")
    values = []
    for m in metrics:
        v = row.get(m.name)
        if v is not None and _present(v) and not isinstance(v, bool | str):
            text = _number(m.scale * float(v))
            if m.bound is not None and row.get(m.bound) is True:
                text = "≤ " + text
        elif m.beyond is not None and _present(row.get(m.beyond)):
            text = "> " + _number(m.scale * float(row[m.beyond]))
        else:
            text = "—"
        values.append(text)
    units = {m.unit for m in metrics}
    if len(units) == 1 and units != {""}:
        shown = " / ".join(values) + f" {metrics[0].unit}"
    else:
        shown = " / ".join(v + (f" {m.unit}" if m.unit and v != "—" else "") for v, m in zip(values, metrics,
                                                                                                strict=True))
    outcome, *extra = str(row["outcome"]).split(";") if _present(row.get("outcome")) else [""]
    extra = [e.strip() for e in extra if e.strip()]
    words = [w for w in (shown, outcome.strip()) if w]
    for f in CELL_FLAGS:
        if (f.metric in row and row[f.metric] is f.value) or f.outcome_flag in extra:
            words.append(f.text)
    words += [e for e in extra if e not in {f.outcome_flag for f in CELL_FLAGS}]
    return ", ".join(dict.fromkeys(words)) or "—"


def legend(protocol: str, metrics: Sequence[CellMetric]) -> str:
    """One sentence: what a cell of the table holds."""
    what = " / ".join(m.label for m in metrics)
    units = {m.unit for m in metrics}
    if what and len(units) == 1 and units != {""}:
        what += f", {metrics[0].unit}"
    parts = [f"Each cell ({protocol}): " + (f"{what}; " if what else "") + "the outcome"]
    if any(m.bound for m in metrics):
        parts.append("≤ x: at most x (the knot was already slipping when the detection began)")
    if any(m.beyond for m in metrics):
        parts.append("> x: no run-away up to x, the largest load applied")
    parts.append("—: did not happen")
    return "; ".join(parts + [f"{f.text}: {f.meaning}" for f in CELL_FLAGS]) + "."


def format_table(table, *, markdown: bool = False) -> str:
    """The comparison as text: one row per knot, one column per ``mu``, each cell its ``cell``
    text. ``table``: :attr:`CompareResult.table` (columns ``knot``, ``mu``, ``cell``)."""
    knots = list(dict.fromkeys(table["knot"]))
    mus = sorted(dict.fromkeys(float(m) for m in table["mu"]))
    cells = {(k, float(m)): c for k, m, c in zip(table["knot"], table["mu"], table["cell"], strict=True)}
    head = ["knot", *(f"mu = {m:g}" for m in mus)]
    rows = [[k, *(cells.get((k, m), "not run") for m in mus)] for k in knots]
    if markdown:
        def esc(s: str) -> str:
            return s.replace("|", "\\|")

        lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
        lines += ["| " + " | ".join(esc(c) for c in r) + " |" for r in rows]
        return "\n".join(lines)
    widths = [max(len(r[i]) for r in [head, *rows]) for i in range(len(head))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(head, widths, strict=True)).rstrip(),
             "  ".join("-" * w for w in widths)]
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in rows]
    return "\n".join(lines)


def _comparison_table(df, protocol: str, labels: dict[str, str], study_dir: Path | None = None):
    """Long table of the cells from a study's results table ``df`` (:func:`load_study`); the
    metrics of each completed case are read from its ``summary.json`` under ``study_dir`` when
    there is one, in its case directory or in a packed study's ``cases.parquet`` (it keeps the
    metrics that are ``None``, which the results table leaves out)."""
    import pandas as pd

    from knotsim.study.store import StudyStore

    store = StudyStore(study_dir) if study_dir is not None else None
    records = df.to_dict("records")
    for rec in records:
        if store is not None and rec.get("outcome") == "completed" and rec.get("case_dir"):
            metrics_of = (store.read_summary(str(rec["case_id"])) or {}).get("metrics") or {}
            rec.update({k: v for k, v in metrics_of.items() if not isinstance(v, dict | list)})
            rec["_metrics"] = set(metrics_of)
    available = set(df.columns).union(*(rec.get("_metrics", set()) for rec in records))
    metrics = cell_metrics(protocol, sorted(available))
    rows = []
    for rec in records:
        knot = rec.get("knot")
        row: dict[str, Any] = {"knot": labels.get(knot, _label(str(knot))), "mu": float(rec.get("overrides.mu")),
                               "case_id": rec.get("case_id"), "status": rec.get("outcome"),
                               "outcome": "failed" if rec.get("outcome") == "failed" else rec.get("protocol_outcome"),
                               "error": rec.get("error") if rec.get("outcome") == "failed" else None}
        for m in metrics:
            for name in (m.name, m.bound, m.beyond):
                if name is not None:
                    row[name] = _plain(rec.get(name))
        for f in CELL_FLAGS:
            row[f.metric] = _plain(rec.get(f.metric))
        row["cell"] = cell_text(row, metrics)
        row["case_dir"] = rec.get("case_dir")
        rows.append(row)
    cols = ["knot", "mu", "case_id", "status", "outcome", "error", "cell", "case_dir"]
    table = pd.DataFrame(rows, columns=list(dict.fromkeys([*cols, *(k for r in rows for k in r)])))
    order = {k: i for i, k in enumerate(labels.values())}
    table = table.sort_values(["knot", "mu"], key=lambda s: s.map(order) if s.name == "knot" else s, kind="stable")
    return table.reset_index(drop=True), metrics


def _plain(v):
    """A value of the results table as plain Python (NaN and NA as ``None``, numpy unwrapped)."""
    if not _present(v):
        return None
    if hasattr(v, "item") and not isinstance(v, str | bytes):
        v = v.item()
    return v


# ------------------------------------------------------------------------------------------ result
@dataclass
class CompareResult:
    """What :func:`compare_knots` did.

    ``table``: one row per case (pandas DataFrame): ``knot`` (as shown), ``mu``, ``case_id``,
    ``status`` (``completed`` / ``failed``), ``outcome`` (the protocol's, or ``failed``), ``error``,
    ``cell`` (the text of its cell), ``case_dir`` (relative to ``study_dir``), the cell's metrics in
    SI units (knot-security: ``slip_load``, ``slow_slip_load`` in N, ``slip_during_transient``, ...)
    and the flags (``set_still``). ``failed``: the failed cases, ``{"knot", "mu", "case_id",
    "error"}`` each. ``reused``: cases finished by an earlier run into the same directory.
    """

    table: Any
    out_dir: Path
    study_dir: Path
    report: Path
    figure: Path | None
    protocol: str
    metrics: tuple[CellMetric, ...] = ()
    failed: list[dict] = field(default_factory=list)
    reused: int = 0
    notes: list[str] = field(default_factory=list)

    @property
    def all_failed(self) -> bool:
        """True when every case failed (the command then exits with a nonzero code)."""
        return len(self.table) > 0 and len(self.failed) == len(self.table)

    def text(self, markdown: bool = False) -> str:
        """The table of cells (rows: knots, columns: ``mu``), plain text or Markdown."""
        return format_table(self.table, markdown=markdown)

    def legend(self) -> str:
        """What a cell holds (one sentence)."""
        return legend(self.protocol, self.metrics)


# ------------------------------------------------------------------------------------------ run
def _prepare_dir(out_dir: Path, study: dict, text: str, overwrite: bool) -> bool:
    """Make ``out_dir`` ready; True when it holds this very comparison (resume)."""
    spec_file = out_dir / STUDY_FILE
    if spec_file.is_file() and not overwrite:
        try:
            same = load_toml(spec_file, "compare") == loads_toml(text, "compare")
        except ConfigError:
            same = False
        if same:
            return (out_dir / STUDY_DIR / "study.toml").is_file()
        raise ConfigError("output", f"{out_dir} holds a comparison with other knots or settings "
                                    f"({spec_file}); pass --overwrite to replace it, or choose another directory")
    if out_dir.is_dir() and any(out_dir.iterdir()):
        if not overwrite:
            raise ConfigError("output", f"{out_dir} is not empty; pass --overwrite to replace knotsim's files "
                                        "there, or choose another directory with -o")
        for name in COMPARE_FILES:
            p = out_dir / name
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            elif p.exists() or p.is_symlink():
                p.unlink()
    out_dir.mkdir(parents=True, exist_ok=True)
    return False


def compare_knots(knots: Sequence[str], *, protocol: str = "knot-security", mu: float | Sequence[float] | None = None,
                  overrides: dict | None = None, quick: bool = False, workers: int | None = None,
                  out_dir: str | os.PathLike, overwrite: bool = False,
                  progress: Callable[[Any], None] | None = None, session: dict | None = None) -> CompareResult:
    """Run every knot of ``knots`` at every friction coefficient ``mu`` with ``protocol`` and
    write the comparison (``compare.toml``, ``study/``, ``report.md``, ``forces.png``,
    ``pictures/``) into ``out_dir``.

    Parameters
    ----------
    knots:
        Library knot names (``knotsim knots``) or paths of ``.toml`` knot drawings.
    protocol:
        The loading protocol (default ``knot-security``: set, relax, then a force ramp).
    mu:
        Friction coefficients (dimensionless), one or a list; default the protocol's.
    overrides:
        Protocol parameters (``{"load_time": 1.0}``, as ``knotsim pull --set``), for every case.
    quick:
        The protocol's coarse, short settings.
    workers:
        Local worker processes (default: the number of CPUs, at most the number of cases).
    out_dir:
        The comparison's directory. When it already holds this comparison (same knots, protocol,
        ``mu``, overrides and ``quick``) the finished cases are reused and only the missing ones
        run; when it holds anything else it is refused unless ``overwrite``, which deletes the
        files a comparison writes (other files stay).
    overwrite:
        Replace an earlier comparison in ``out_dir`` (every case runs again).
    progress, session:
        Passed to :func:`knotsim.study.runner.run_study`.

    Returns
    -------
    CompareResult
        The table of cells, the paths written and the failed cases. A failed case (an error while
        it ran) is in the table with its error; the other cases run regardless.

    Raises
    ------
    ConfigError
        Bad input (an unknown knot or protocol, a missing drawing file, an unknown override, a bad
        ``mu``), or an ``out_dir`` holding something else without ``overwrite``.
    """
    from knotsim.study.runner import plan_study, run_study
    from knotsim.study.spec import load_study_spec
    from knotsim.study.store import load_study

    study = compare_study(knots, protocol=protocol, mu=mu, overrides=overrides, quick=quick)
    out = Path(out_dir)
    header = (f"{study['description']}.\nWritten by `knotsim compare`; rerun with\n"
              f"  knotsim study {out / STUDY_FILE} -o {out / STUDY_DIR} --resume\n"
              f"and open the study's report with `knotsim report {out / STUDY_DIR}`.")
    text = dumps_toml(study, header=header)
    resume = _prepare_dir(out, study, text, overwrite)
    spec_file = out / STUDY_FILE
    if not resume:
        spec_file.write_text(text)
    spec = load_study_spec(spec_file)
    study_dir = out / STUDY_DIR
    _, _, reused, _ = plan_study(spec, study_dir, resume=resume)
    run_study(spec, study_dir, workers=workers, resume=resume, progress=progress, session=session)
    labels = {k: _label(k) for k in study["grid"]["knot"]}
    table, metrics = _comparison_table(load_study(study_dir), protocol, labels, study_dir)
    failed = [{"knot": r["knot"], "mu": r["mu"], "case_id": r["case_id"], "error": r["error"]}
              for r in table.to_dict("records") if r["status"] == "failed"]
    result = CompareResult(table=table, out_dir=out, study_dir=study_dir, report=out / REPORT, figure=None,
                           protocol=protocol, metrics=metrics, failed=failed, reused=len(reused))
    _write_report(result, study, quick)
    return result


# ------------------------------------------------------------------------------------------ report
def _differing_parameters(study: dict, quick: bool) -> list[tuple[str, Any, Any]]:
    """``(key, value, default)`` of the settings given (quick and overrides) that differ from the
    protocol's defaults; ``mu`` is the table's columns and not listed."""
    defaults, quick_layer = _protocol_defaults(study["base"]["protocol"], quick)
    given = {**quick_layer, **study["base"].get("overrides", {})}
    return [(k, v, defaults.get(k)) for k, v in given.items() if k != "mu" and v != defaults.get(k)]


def _summary(case_dir: Path) -> dict:
    try:
        return json.loads((case_dir / "summary.json").read_text())
    except (OSError, ValueError):
        return {}


def _load_start(summary: dict) -> float:
    """Time (s, on the log's ``time`` axis) at which the load began: the timeline's stage ``load``
    when the summary has one, else from the parameters (knot-security: settle, set and relax)."""
    for stage in (summary.get("timeline") or {}).get("stages") or []:
        if isinstance(stage, dict) and stage.get("name") == "load":
            for key in ("start", "time", "begin"):
                if isinstance(stage.get(key), int | float):
                    return float(stage[key])
    p = summary.get("parameters") or {}
    t = float(p.get("settle_time") or 0.0)
    if summary.get("protocol") == "knot-security":
        hold = (summary.get("metrics") or {}).get("set_hold", p.get("set_hold"))
        t += sum(float(x or 0.0) for x in (p.get("set_ramp"), hold, p.get("relax_time")))
    return t


def _onset_time(summary: dict, name: str, t0: float) -> float | None:
    """Time (s, log axis) of the onset metric ``name`` (``{"time", ...}``), or None: its
    ``load_stage_time`` after the load began when it has one, else its ``time`` counted from there."""
    o = (summary.get("metrics") or {}).get(name)
    if not isinstance(o, dict):
        return None
    for key in ("load_stage_time", "time"):
        if isinstance(o.get(key), int | float) and not isinstance(o.get(key), bool):
            return t0 + float(o[key])
    return None


def _onset(summary: dict, t0: float) -> float | None:
    """When the knot began to give way (s, log axis): the earliest of the run-away slip and capsize
    onsets (the slip load of the table is the force there), or None."""
    times = [t for name in ("slip_onset", "capsize_onset") if (t := _onset_time(summary, name, t0)) is not None]
    return min(times) if times else None


def _decision_time(summary: dict, t0: float) -> float | None:
    """When the knot's fate was decided (s, log axis): the timeline's decision (a run-away is
    decided once it has lasted its 0.5 s), else the onset (:func:`_onset`)."""
    decision = (summary.get("timeline") or {}).get("decision")
    if isinstance(decision, dict) and isinstance(decision.get("time"), int | float):
        return float(decision["time"])
    return _onset(summary, t0)


def _nearest(t, value: float | None) -> int | None:
    import numpy as np

    return None if value is None else int(np.argmin(np.abs(t - value)))


def _force_curves(result: CompareResult) -> list[dict]:
    """Each completed case's load stage: ``t`` (s since the load began), ``F`` (mN), ``u`` (mm or
    None) and the index of its decision (or None)."""
    import numpy as np
    import pandas as pd

    curves = []
    for r in result.table.to_dict("records"):
        if r["status"] != "completed" or not r.get("case_dir"):
            continue
        case_dir = result.study_dir / r["case_dir"]
        try:
            log = pd.read_parquet(case_dir / "log.parquet")
        except (OSError, ValueError):
            continue
        if "F" not in log.columns:
            continue
        summary = _summary(case_dir)
        t0 = _load_start(summary)
        t = np.asarray(log["time"], float)
        f = np.asarray(log["F"], float)
        keep = (t >= t0 - 1e-9) & np.isfinite(f)
        if not keep.any():
            continue
        u = np.asarray(log["u_pull"], float)[keep] * 1e3 if "u_pull" in log.columns else None
        td = _decision_time(summary, t0)
        tn = _onset(summary, t0)
        ts = _onset_time(summary, "slow_slip_onset", t0)
        tk = t[keep] - t0
        curves.append({"knot": r["knot"], "mu": r["mu"], "t": tk, "F": f[keep] * 1e3, "u": u,
                       "decision": _nearest(tk, None if td is None else td - t0),
                       "onset": _nearest(tk, None if tn is None else tn - t0),
                       "slow": _nearest(tk, None if ts is None else ts - t0),
                       "force_control": (summary.get("protocol") == "knot-security"
                                         and (summary.get("parameters") or {}).get("load") != "slide")})
    return curves


def _window_end(c: dict) -> int:
    """Index of the last sample of a curve worth showing: a margin past its decision (a tenth of
    the load stage up to it, at least 3 samples), or the whole curve."""
    import numpy as np

    n = len(c["t"])
    if c["decision"] is None:
        return n - 1
    td = float(c["t"][c["decision"]])
    end = int(np.searchsorted(c["t"], 1.1 * td, side="right")) - 1
    return min(n - 1, max(end, c["decision"] + 3))


def _plot_forces(result: CompareResult, path: Path) -> bool:
    """``forces.png``: F (mN) against the loaded end's displacement u_pull (mm) and against the
    time since the load began (s); one colour per knot, one line style per ``mu``; a dot at each
    decision. False when no case has a force curve."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.lines import Line2D

    from knotsim.study.report import DPI

    curves = _force_curves(result)
    if not curves:
        return False
    knots = list(dict.fromkeys(result.table["knot"]))
    mus = sorted(dict.fromkeys(float(m) for m in result.table["mu"]))
    colours = {k: plt.get_cmap("tab10")(i % 10) for i, k in enumerate(knots)}
    styles = ["-", "--", ":", "-."]
    style = {m: styles[i % len(styles)] for i, m in enumerate(mus)}
    fig, (ax_u, ax_t) = plt.subplots(1, 2, figsize=(11.0, 4.2), dpi=DPI)
    u_lo, u_hi, t_hi, f_hi = math.inf, -math.inf, 0.0, 0.0
    for c in curves:
        e = _window_end(c) + 1
        kw = {"color": colours[c["knot"]], "ls": style[c["mu"]], "lw": 1.4}
        ax_t.plot(c["t"], c["F"], **kw)
        t_hi = max(t_hi, float(c["t"][e - 1]))
        f_hi = max(f_hi, float(np.nanmax(c["F"][:e])))
        if c["u"] is not None:
            ax_u.plot(c["u"], c["F"], **kw)
            u_lo, u_hi = min(u_lo, float(np.nanmin(c["u"][:e]))), max(u_hi, float(np.nanmax(c["u"][:e])))
        for key, marker in (("slow", "v"), ("onset", "o")):
            k = c[key]
            if k is None:
                continue
            mk = {"color": colours[c["knot"]], "ms": 6, "mec": "k", "mew": 0.6, "ls": ""}
            ax_t.plot(c["t"][k], c["F"][k], marker, **mk)
            if c["u"] is not None:
                ax_u.plot(c["u"][k], c["F"][k], marker, **mk)
    top = 1.08 * f_hi if f_hi > 0 else 1.0
    for ax in (ax_u, ax_t):
        ax.set_ylim(min(0.0, ax.get_ylim()[0]), top)
        ax.grid(alpha=0.3)
        ax.set_ylabel("force on the loaded end F (mN)")
    if math.isfinite(u_lo):
        pad = 0.05 * max(u_hi - u_lo, 1e-3)
        ax_u.set_xlim(u_lo - pad, u_hi + pad)
        ax_u.set_xlabel("displacement of the loaded end u_pull (mm, from where the run began)")
    else:
        ax_u.text(0.5, 0.5, "no displacement column (u_pull) in these logs", ha="center", transform=ax_u.transAxes)
    ax_t.set_xlim(0.0, 1.05 * t_hi if t_hi > 0 else 1.0)
    ax_t.set_xlabel("time since the load began (s)")
    if all(c["force_control"] for c in curves):
        ax_t.set_title("the load is prescribed: the curves coincide, each ends soon after its knot's decision",
                       fontsize="small")
    shown = {c["knot"] for c in curves}
    handles = [Line2D([], [], color=colours[k], lw=2, label=k) for k in knots if k in shown]
    if len(mus) > 1:
        handles += [Line2D([], [], color="k", ls=style[m], label=f"mu = {m:g}") for m in mus]
    if any(c["slow"] is not None for c in curves):
        handles.append(Line2D([], [], ls="", marker="v", color="w", mec="k", label="slow slip begins"))
    decided = any(c["decision"] is not None for c in curves)
    if any(c["onset"] is not None for c in curves):
        handles.append(Line2D([], [], ls="", marker="o", color="w", mec="k", label="run-away slip (or capsize) begins"))
    ax_t.legend(handles=handles, fontsize="small")
    title = f"{result.protocol}" + (f", mu = {mus[0]:g}" if len(mus) == 1 else "")
    fig.suptitle(f"Force curves of the load stage ({title})"
                 + ("; the axes stop a little past the last decision" if decided else "; no knot ran away"))
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return True


def _picture(case_dir: Path, out_dir: Path) -> tuple[list[Path], str | None]:
    """The knot at its decision (``render_key_frames``), or its last frame when that function is
    missing or wrote nothing; the PNG files and a note on the fallback (or None)."""
    import importlib

    try:  # written alongside this module: older installations lack it
        render_key_frames = getattr(importlib.import_module("knotsim.viz.render"), "render_key_frames", None)
    except ImportError:
        render_key_frames = None
    note = None
    paths: list[Path] = []
    if render_key_frames is not None:
        paths = list(render_key_frames(case_dir, out_dir, events=("decision",), size=PICTURE_SIZE))
        if not paths:
            note = "no decision: the last frame"
    else:
        note = "render_key_frames is not in this knotsim: the last frame, not the decision"
    if not paths:
        from knotsim.viz.render import render_run

        paths = list(render_run(case_dir, frames=[-1], out_dir=out_dir, size=PICTURE_SIZE, backend="matplotlib"))
    return paths, note


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.]+", "_", text).strip("_") or "knot"


def _write_report(result: CompareResult, study: dict, quick: bool) -> None:
    """``report.md``, ``forces.png`` and ``pictures/`` of a comparison (replacing earlier ones)."""
    out = result.out_dir
    n, n_fail = len(result.table), len(result.failed)
    knots = list(dict.fromkeys(result.table["knot"]))
    lines = [f"# Which knot holds better: {', '.join(knots)}", "",
             f"Protocol `{result.protocol}`" + (" with its quick settings" if quick else "")
             + f"; {n} cases ({n - n_fail} completed, {n_fail} failed"
             + (f", {result.reused} reused from an earlier run" if result.reused else "") + ").",
             *([f"**{QUICK_WARNING}**", ""] if quick else []),
             f"The study is `{STUDY_FILE}` (rerun: `knotsim study {STUDY_FILE} -o {STUDY_DIR} --resume`), "
             f"its results `{STUDY_DIR}/results.parquet` (`knotsim report {STUDY_DIR}` for the study's own "
             "report).", "", "## Results", "", result.legend(), "", result.text(markdown=True), ""]
    params = _differing_parameters(study, quick)
    lines += ["## Parameters that differ from the protocol's defaults", ""]
    if params:
        from knotsim.protocols.params import PARAM_INFO

        lines += ["| parameter | value | default | unit |", "|---|---|---|---|"]
        for k, v, d in params:
            unit = PARAM_INFO.get(k, ("", ""))[0]
            lines.append(f"| {k} | {v} | {'(the knot drawing)' if d is None else d} | {unit} |")
    else:
        lines.append("None (besides mu, the table's columns).")
    lines.append("")
    figure = out / FIGURE
    if figure.exists():
        figure.unlink()
    if _plot_forces(result, figure):
        result.figure = figure
        lines += ["## Force curves", "",
                  "The force on the loaded end against its displacement and against the time since the load "
                  "began; one colour per knot, one line style per mu, a dot where the run-away slip (or a "
                  "capsize) began (the slip load of the table), a triangle where a slow slip began. "
                  "The axes stop a little past the last decision (a run-away is decided once it has lasted "
                  "0.5 s; the ropes then fly apart).", "",
                  f"![force curves]({FIGURE})", ""]
    pictures = out / PICTURES
    if pictures.exists():
        shutil.rmtree(pictures)
    done = [r for r in result.table.to_dict("records") if r["status"] == "completed" and r.get("case_dir")]
    if done:
        lines += ["## The knots at their decision", ""]
        for r in done:
            where = pictures / f"{_slug(r['knot'])}_mu{r['mu']:g}"
            try:
                paths, note = _picture(result.study_dir / r["case_dir"], where)
            except Exception as exc:  # a picture is not worth failing the comparison  # noqa: BLE001
                paths, note = [], f"no picture: {type(exc).__name__}: {_short(str(exc), 80)}"
            if note is not None and note not in result.notes:
                result.notes.append(note)
            lines.append(f"**{r['knot']}, mu = {r['mu']:g}** ({r['outcome']})" + (f": {note}" if note else ""))
            lines.append("")
            lines += [f"![{r['knot']} at mu = {r['mu']:g}]({p.relative_to(out).as_posix()})" for p in paths]
            lines.append("")
    if result.failed:
        lines += ["## Failed cases", "", "| knot | mu | case | error |", "|---|---|---|---|"]
        for f in result.failed:
            err = str(f["error"]).replace("|", "\\|").replace("\n", " ")
            lines.append(f"| {f['knot']} | {f['mu']:g} | `{f['case_id']}` | {err} |")
        lines += ["", f"Tracebacks: `{STUDY_DIR}/cases/<case>/error.txt`.", ""]
    result.report.write_text("\n".join(lines).rstrip() + "\n")
