"""Re-derive the outcomes of the committed ``single-rod-bend`` studies under the current ``loose``
rule, from their stored metrics, without running anything again.

The outcome is computed from the run's log when the case runs and stored in the study's
``results.parquet`` (``knot_status``, ``protocol_outcome``; ``knotsim report`` reads them back, it
does not recompute them). The ``loose`` rule of ``single-rod-bend`` compares the stored
``F_norm_peak`` (largest F h^2/EI after the start-up transient) with the free-rope level
(:func:`knotsim.protocols.single_rod_bend.free_rope_level`, from the case's parameters: no log
needed), so the outcome of every stored case can be re-derived exactly: the topology's verdicts
(``untied``, ``changed knot type``, ``unknown``) are kept, the others are replaced by the
protocol's :meth:`~knotsim.protocols.single_rod_bend.SingleRodBend.verdict` (``loose``,
``slipped``, ``undecided`` or ``held``). The columns ``free_rope_level`` and
``left_free_rope_level`` are added (or refreshed). Case records (``cases/<id>/result.json``),
where present, are updated too, so that a later ``--resume`` keeps the new outcomes.

    python validation/recompute_single_rod_outcomes.py            # every committed study
    python validation/recompute_single_rod_outcomes.py --rerun    # re-run the cases the bounds leave open
    python validation/recompute_single_rod_outcomes.py validation/studies/convergence_tied

Then ``knotsim report STUDY_DIR`` rewrites the study's report from the updated table.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Committed single-rod-bend studies: study directory -> (folder of the study file it was run
#: from: relative ``geometry`` paths of the cases are relative to it; whether its stored
#: ``F_norm_peak`` is taken after the 1 s start-up transient). The studies run before commit 0b98d90
#: (2026-12-01) stored the peak over the whole window, start-up ringing included: for them the
#: peak is only an upper bound of the rule's, and the force samples after the transient
#: (``F_norm_at_2.5s`` ... ``F_norm_at_12.5s``, ``F_norm_final``: means of samples) a lower bound.
#: A case whose bounds straddle the free-rope level is re-run (``--rerun``, one at a time) or
#: left with its old outcome and reported.
STUDIES = {
    "docs/studies/granny_vs_reef_mu": ("examples/studies", False),
    "docs/studies/granny_vs_reef_mu_prepull": ("examples/studies", False),
    "docs/studies/granny_vs_reef_mu_tied": ("examples/studies", True),
    "docs/studies/granny_vs_reef_E": ("examples/studies", False),
    "docs/studies/granny_vs_reef_radius": ("examples/studies", False),
    "validation/studies/convergence_single_rod": ("validation/studies", True),
    "validation/studies/convergence_tied": ("validation/studies", True),
    "validation/studies/granny_vs_reef_mu_prepull_each": ("validation/studies", False),
}
_AFTER_TRANSIENT = ("F_norm_at_2.5s", "F_norm_at_5s", "F_norm_at_7.5s", "F_norm_at_10s", "F_norm_at_12.5s",
                    "F_norm_final")

_TOPOLOGY_STATUS = ("untied", "changed knot type", "unknown")


def _nan(v) -> bool:
    return v is None or (isinstance(v, float) and math.isnan(v))


def _rerun_peak(config: dict, base_dir: Path) -> float | None:
    """``F_norm_peak`` (after the transient) of the case ``config`` run again now, into a temporary
    directory that is deleted afterwards."""
    import tempfile

    from knotsim.study.executors import protocol_executor

    with tempfile.TemporaryDirectory() as tmp:
        m = protocol_executor(config, Path(tmp), base_dir)
    return m.get("F_norm_peak")


def new_outcome(config: dict, metrics: dict, base_dir: Path, *, peak_after_transient: bool = True,
                rerun: bool = False) -> dict:
    """The re-derived outcome entries of one case: ``free_rope_level``, ``left_free_rope_level``,
    ``knot_status``, ``protocol_outcome`` and ``outcome_source`` (``"stored peak"``, ``"bounds"``,
    ``"re-run"`` or ``"undetermined"``), from the case ``config`` (protocol, knot or geometry,
    overrides) and its stored ``metrics`` (``peak_after_transient``: see :data:`STUDIES`)."""
    from knotsim.protocols import build_protocol_run
    from knotsim.protocols.single_rod_bend import free_rope_level

    geo = config.get("geometry")
    if geo is not None and not Path(geo).is_absolute():
        geo = str(base_dir / geo)
    proto, ctx, _spec, _ = build_protocol_run(config["protocol"], config.get("knot"), geometry=geo,
                                              overrides=dict(config.get("overrides") or {}),
                                              quick=bool(config.get("quick")))
    level = free_rope_level(ctx.params, ctx.EI, ctx.radius, ctx.length)
    peak = metrics.get("F_norm_peak")
    source = "stored peak"
    if _nan(peak):
        left = None
    elif peak_after_transient:
        left = bool(peak > level)
    else:
        low = max((metrics[k] for k in _AFTER_TRANSIENT if not _nan(metrics.get(k))), default=-math.inf)
        if low > level:
            left, source = True, "bounds"
        elif peak <= level:
            left, source = False, "bounds"
        elif rerun:
            p = _rerun_peak(config, base_dir)
            left, source = (None if p is None else bool(p > level)), "re-run"
        else:
            left, source = None, "undetermined"
    slip = metrics.get("slip_onset", metrics.get("slip_onset.time"))
    pull = float(metrics.get("sim_time") or 0.0) - float(metrics.get("pre_pull_time") or 0.0)
    decidable = metrics.get("decidable")
    if _nan(decidable):  # studies older than the rule: the pull must outlast the slip rule's skip + 1 s
        decidable = pull >= max(0.2 * pull, 2.0) + 1.0
    m = {"left_free_rope_level": left, "slip_onset": None if _nan(slip) else slip, "decidable": bool(decidable)}
    old = metrics.get("knot_status")
    if old in _TOPOLOGY_STATUS or source == "undetermined":
        status, outcome = old, metrics.get("protocol_outcome")
    else:
        status = proto.verdict(ctx, m) or "held"
        outcome = status if metrics.get("run_status") == "completed" else f"{status}; simulation stopped early"
    return {"free_rope_level": level, "left_free_rope_level": left, "knot_status": status,
            "protocol_outcome": outcome, "outcome_source": source}


def recompute(study_dir: str | Path, base_dir: str | Path, *, peak_after_transient: bool = True,
              rerun: bool = False) -> list[tuple[str, str, str, str]]:
    """Update ``study_dir``'s table (and case records) in place; returns ``(case_id, old, new,
    outcome_source)`` for every completed case."""
    import pandas as pd

    from knotsim._util.jsonio import read_json, write_json
    from knotsim.study.spec import load_study_spec
    from knotsim.study.store import CASES, RECORD

    study_dir, base_dir = Path(study_dir), Path(base_dir)
    cases = {c.case_id: c for c in load_study_spec(study_dir / "study.toml").expand()}
    path = study_dir / "results.parquet"
    df = pd.read_parquet(path)
    changes = []
    for col in ("free_rope_level", "left_free_rope_level", "outcome_source"):
        if col not in df.columns:
            df[col] = None
        df[col] = df[col].astype(object)
    for i, row in df.iterrows():
        if row["outcome"] != "completed":
            continue
        case = cases.get(row["case_id"])
        if case is None:
            raise KeyError(f"{study_dir}: case {row['case_id']} is not a case of its study.toml")
        metrics = {k: (None if _nan(v) else v) for k, v in row.items()}
        new = new_outcome(case.config, metrics, base_dir, peak_after_transient=peak_after_transient, rerun=rerun)
        changes.append((row["case_id"], row["knot_status"], new["knot_status"], new["outcome_source"]))
        for k, v in new.items():
            df.at[i, k] = v
        rec_path = study_dir / CASES / row["case_id"] / RECORD
        if rec_path.is_file():
            rec = read_json(rec_path)
            rec["metrics"].update(new)
            write_json(rec_path, rec)
    df["left_free_rope_level"] = df["left_free_rope_level"].astype(object)
    df["free_rope_level"] = pd.to_numeric(df["free_rope_level"])
    tail = [c for c in ("traceback", "case_dir") if c in df.columns]
    df = df[[c for c in df.columns if c not in tail] + tail]
    tmp = path.with_name(".results.recompute.parquet")
    df.to_parquet(tmp, index=False)
    tmp.replace(path)
    return changes


def main(argv: list[str]) -> int:
    rerun = "--rerun" in argv
    dirs = [a for a in argv if a != "--rerun"] or list(STUDIES)
    for d in dirs:
        key = Path(d).as_posix().rstrip("/")
        if key not in STUDIES:
            sys.exit(f"{d}: not a committed single-rod-bend study ({', '.join(STUDIES)})")
        folder, after = STUDIES[key]
        changes = recompute(ROOT / key, ROOT / folder, peak_after_transient=after, rerun=rerun)
        moved = [f"{cid[:8]} {a} -> {b} ({src})" for cid, a, b, src in changes if a != b]
        counts: dict[str, int] = {}
        for _, _, b, src in changes:
            counts[f"{b} ({src})"] = counts.get(f"{b} ({src})", 0) + 1
        print(f"{key}: {len(changes)} cases, now {counts}; changed: {moved or 'none'}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
