"""knotsim.study.report: what is plotted (beyond round-off, one figure per metric of interest) and
when the published MAE259B values are shown (only for the published set-up). Synthetic studies."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

import knotsim.study.report as R
from knotsim.protocols.params import COMMON_DEFAULTS
from knotsim.protocols.registry import get_protocol
from knotsim.study.spec import load_study_spec
from knotsim.study.store import StudyStore

RAW = {"name": "mae", "base": {"protocol": "single-rod-bend", "knot": "single_rod_reef", "overrides": {}},
       "grid": {"knot": ["single_rod_granny", "single_rod_reef"], "overrides.mu": [0.1, 0.3, 0.5]}}


def _published_parameters() -> dict:
    p = dict(COMMON_DEFAULTS)
    p.update(get_protocol("single-rod-bend").defaults)
    return p


def _study(tmp_path, metrics, parameters=None, sim_time=13.0, raw=RAW):
    """A finished study without simulations; with ``parameters`` every case gets a summary.json."""
    spec = load_study_spec(raw)
    cases = spec.expand()
    store = StudyStore(tmp_path)
    store.prepare(spec, session={})
    records = {}
    for i, c in enumerate(cases):
        d = store.case_dir(c.case_id)
        d.mkdir(parents=True)
        t = np.linspace(0, 13, 27)
        pd.DataFrame({"time": t, "F_norm": c.params["overrides.mu"] * t / 13}).to_parquet(d / "log.parquet")
        if parameters is not None:
            (d / "summary.json").write_text(json.dumps({"protocol": "single-rod-bend", "sim_time": sim_time,
                                                        "parameters": parameters}))
        rec = {"case_id": c.case_id, "outcome": "completed", "wall_time": 1.0 + i, "host": "h",
               "metrics": {**metrics(c.params), "sim_time": sim_time}}
        (d / "result.json").write_text(json.dumps(rec))
        records[c.case_id] = rec
    store.write_results(cases, records)
    return tmp_path


def _mean(p):
    return {"F_norm_mean": p["overrides.mu"] + (0.1 if "reef" in p["knot"] else 0.0), "mean_window": 13.0}


def test_published_setup_is_compared(tmp_path):
    _study(tmp_path, _mean, parameters=_published_parameters())
    assert R.published_setup_differences(tmp_path, pd.read_parquet(tmp_path / "results.parquet")) == []
    md = R.write_report(tmp_path).read_text()
    assert "so the published values are shown" in md and "| reef | 0.5 |" in md and "0.834" in md


def test_quick_setup_is_not_compared_and_says_why(tmp_path):
    params = {**_published_parameters(), "n_nodes": 101, "dt": 5e-3, "mean_window": 2.0}
    _study(tmp_path, lambda p: {**_mean(p), "mean_window": 2.0}, parameters=params, sim_time=2.0)
    diffs = R.published_setup_differences(tmp_path, pd.read_parquet(tmp_path / "results.parquet"))
    assert any(d.startswith("n_nodes 101 instead of 301") for d in diffs)
    assert any(d.startswith("dt 0.005 instead of 0.0025") for d in diffs)
    assert any(d.startswith("mean_window 2 instead of 13") for d in diffs)
    md = R.write_report(tmp_path).read_text()
    assert "Not compared with the published values" in md and "n_nodes 101 instead of 301" in md
    assert "0.834" not in md and "published |" not in md


def test_short_run_without_summaries_is_not_compared(tmp_path):
    """No case summaries: the results table's mean_window and sim_time decide."""
    _study(tmp_path, lambda p: {**_mean(p), "mean_window": 13.0}, sim_time=2.0)
    diffs = R.published_setup_differences(tmp_path, pd.read_parquet(tmp_path / "results.parquet"))
    assert diffs == ["simulated 2 s, not the full 13 s window"]


def test_pulled_geometry_without_summaries_is_not_compared(tmp_path):
    """No case summaries and a pulled geometry: its rope is unknown to the table, no comparison."""
    _study(tmp_path, lambda p: {**_mean(p), "mean_window": 13.0}, sim_time=13.0)
    df = pd.read_parquet(tmp_path / "results.parquet")
    assert R.published_setup_differences(tmp_path, df) == []
    df["geometry"] = "tied_reef"
    diffs = R.published_setup_differences(tmp_path, df)
    assert len(diffs) == 1 and diffs[0].startswith("geometry tied_reef")


def test_round_off_is_not_plotted_and_one_figure_per_strength_metric(tmp_path):
    raw = {**RAW, "grid": {"knot": ["single_rod_granny", "single_rod_reef"], "overrides.mu": [0.1, 0.3]}}
    vals = iter([2.0, 1.9999999999999793, 2.0, 2.0000000000000004])
    _study(tmp_path, lambda p: {"F_norm_mean": p["overrides.mu"], "F_norm_peak": 2 * p["overrides.mu"],
                                "round_off": next(vals), "newton_iterations": 3.0 + p["overrides.mu"]},
           raw=raw)
    df = pd.read_parquet(tmp_path / "results.parquet")
    metrics = R._metric_columns(df, ["knot", "overrides.mu"])
    assert "round_off" not in metrics and "sim_time" not in metrics
    assert {"F_norm_mean", "F_norm_peak", "newton_iterations"} <= set(metrics)
    R.write_report(tmp_path)
    figs = sorted(p.name for p in (tmp_path / "report_figures").glob("*.png") if not p.name.startswith("mae"))
    # one figure per strength metric, against the swept parameter with the most values
    assert figs == ["F_norm_mean__vs__overrides_mu.png", "F_norm_peak__vs__overrides_mu.png"]


def test_report_progress_bar_on_stderr(tmp_path, capsys):
    _study(tmp_path, _mean, parameters=_published_parameters())
    R.write_report(tmp_path, progress=True)
    assert "report figures" in capsys.readouterr().err
