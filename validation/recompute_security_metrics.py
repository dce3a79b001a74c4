"""Re-derive the ``knot-security`` metrics and outcomes of a study's cases from their logs.

A study's workers import the protocol once, when they start; a metric added to
:mod:`knotsim.protocols.knot_security` while a study runs (or after) reaches its cases only through
this script. It needs each case's ``log.parquet`` (kept on the machine that ran the study, not in the
repository), recomputes :meth:`KnotSecurity.metrics` with the current code, merges the result into the
case records (``cases/<id>/result.json`` and ``summary.json``: the metrics it computes are replaced,
the others kept), re-derives the outcome (the topology's verdicts ``untied``, ``changed knot type``,
``unknown`` are kept; otherwise ``slipped`` when the new metrics have a slip onset, ``undecided``
when the load stage was too short, else ``held``) and rewrites ``results.parquet``.

    python validation/recompute_security_metrics.py docs/studies/security_mu docs/studies/security_bands
    knotsim report docs/studies/security_mu
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

_TOPOLOGY_STATUS = ("untied", "changed knot type", "unknown")


class _Params(dict):
    """The resolved parameters as the protocol reads them (``p["mu"]``, ``p.contact``)."""

    def __init__(self, values: dict, contact: dict):
        super().__init__(values)
        self.contact = contact


class _Ctx:
    def __init__(self, params: _Params, radius: float, ei: float):
        self.params = params
        self.radius = radius
        self.EI = ei
        self.geometry = None
        p = params
        t_set = float(p["set_ramp"]) + float(p["set_hold"])
        self.data = {"t_set": t_set, "t_pre": t_set + float(p["relax_time"]), "t_settle": float(p.get("settle_time", 0.0))}


def _flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def recompute_case(case_dir: Path) -> dict | None:
    """New metrics and outcome of one case (``None`` when its log or records are missing)."""
    import pandas as pd

    from knotsim.protocols.knot_security import KnotSecurity
    from knotsim.protocols.params import COMMON_DEFAULTS

    summary_file, result_file, log_file = (case_dir / n for n in ("summary.json", "result.json", "log.parquet"))
    if not (summary_file.exists() and result_file.exists() and log_file.exists()):
        return None
    summary = json.loads(summary_file.read_text())
    if summary.get("protocol") != "knot-security":
        return None
    values = dict(COMMON_DEFAULTS)
    values.update({k: v for k, v in KnotSecurity.defaults.items() if not k.startswith("contact.")})
    contact = {k[8:]: v for k, v in KnotSecurity.defaults.items() if k.startswith("contact.")}
    for k, v in (summary.get("parameters") or {}).items():
        if k.startswith("contact."):
            contact[k[8:]] = v
        elif not k.startswith("solver."):
            values[k] = v
    radius = float(summary["geometry_radius"]) if "geometry_radius" in summary else float(values.get("radius") or 0)
    ei = float(summary["EI"])
    if not radius:
        import math

        radius = (4.0 * ei / (math.pi * float(values["youngs_modulus"]))) ** 0.25
    ctx = _Ctx(_Params(values, contact), radius, ei)
    log = pd.read_parquet(log_file)
    proto = KnotSecurity()
    metrics = proto.metrics(ctx, log)
    old = summary.get("metrics") or {}
    for key in ("bend_closure", "bend_name"):
        if key in old:
            metrics[key] = old[key]
    status = summary.get("knot_status")
    if status not in _TOPOLOGY_STATUS:
        status = ("slipped" if proto.slipped(ctx, metrics) else
                  "undecided" if not metrics.get("decidable", False) else "held")
    return {"metrics": metrics, "knot_status": status}


def recompute_study(study_dir: Path) -> int:
    """Recompute every case of ``study_dir`` that has a log; returns how many were updated."""
    from knotsim.study.spec import load_study_spec
    from knotsim.study.store import StudyStore

    store = StudyStore(study_dir)
    n = 0
    for case_dir in sorted((study_dir / "cases").iterdir()):
        new = recompute_case(case_dir)
        if new is None:
            continue
        summary_file, result_file = case_dir / "summary.json", case_dir / "result.json"
        summary = json.loads(summary_file.read_text())
        summary["metrics"] = new["metrics"]
        summary["knot_status"] = new["knot_status"]
        summary["outcome"] = new["knot_status"]
        summary_file.write_text(json.dumps(summary, indent=2, default=float) + "\n")
        rec = json.loads(result_file.read_text())
        flat = _flatten(new["metrics"])
        kept = {k: v for k, v in rec["metrics"].items()
                if not any(k == f or k.startswith(f + ".") for f in new["metrics"])}
        rec["metrics"] = {**kept, **flat, "knot_status": new["knot_status"], "protocol_outcome": new["knot_status"]}
        result_file.write_text(json.dumps(rec, indent=2, default=float) + "\n")
        n += 1
    study = load_study_spec(study_dir / "study.toml")
    store.write_results(study.expand(), store.finished())
    return n


if __name__ == "__main__":
    for arg in sys.argv[1:]:
        print(f"{arg}: {recompute_study(Path(arg))} cases recomputed")
