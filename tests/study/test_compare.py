"""``knotsim.study.compare``: the cells of the comparison table and the checks of the input (no
simulation here; ``tests/test_cli_compare.py`` runs a real comparison)."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from knotsim.errors import ConfigError
from knotsim.study.compare import (
    CELL_METRICS,
    _comparison_table,
    cell_metrics,
    cell_text,
    compare_study,
    format_table,
    legend,
    parse_mu_list,
)

SECURITY = cell_metrics("knot-security", ["slip_load", "slow_slip_load"])


def _row(**kw) -> dict:
    row = {"status": "completed", "outcome": "slipped", "slip_load": 0.0085, "slow_slip_load": 0.0071,
           "slip_during_transient": False, "slow_slip_during_transient": False, "set_still": True}
    row.update(kw)
    return row


def test_cell_shows_both_loads_in_mN_and_the_outcome():
    assert cell_text(_row(), SECURITY) == "8.5 / 7.1 mN, slipped"


def test_a_bound_is_shown_with_le():
    assert cell_text(_row(slow_slip_during_transient=True), SECURITY) == "8.5 / ≤ 7.1 mN, slipped"
    assert cell_text(_row(slip_during_transient=True), SECURITY) == "≤ 8.5 / 7.1 mN, slipped"


def test_a_knot_loaded_before_it_was_set_is_flagged():
    assert cell_text(_row(set_still=False), SECURITY).endswith(", slipped, not set")
    assert "not set" not in cell_text(_row(set_still=None), SECURITY)  # unknown: no flag
    # the protocol's own flag on the outcome is the same flag, said once; other flags stay
    assert cell_text(_row(set_still=False, outcome="slipped; loaded before it was set"),
                     SECURITY) == "8.5 / 7.1 mN, slipped, not set"
    assert cell_text(_row(outcome="held; odd"), SECURITY) == "8.5 / 7.1 mN, held, odd"


def test_held_knot_shows_the_largest_load_held_and_missing_values_as_dash():
    row = _row(outcome="held", slip_load=None, slow_slip_load=float("nan"), largest_load_held=0.021)
    assert cell_text(row, SECURITY) == "> 21 / — mN, held"


def test_failed_case_shows_a_short_error():
    text = cell_text({"status": "failed", "error": "SimulationError: " + "x" * 200}, SECURITY)
    assert text.startswith("failed: SimulationError: xxx") and text.endswith("…") and len(text) < 70


def test_other_protocols_show_their_headline_metric_without_unit():
    metrics = cell_metrics("single-rod-bend")
    assert [m.name for m in metrics] == ["F_norm_mean", "F_norm_peak"]
    assert cell_text({"status": "completed", "outcome": "held", "F_norm_mean": 0.0123, "F_norm_peak": 0.05},
                     metrics) == "0.0123 / 0.05, held"
    assert set(CELL_METRICS) >= {"knot-security", "two-rope-bend", "single-rod-bend", "overhand-pull"}


def test_legend_explains_the_marks():
    text = legend("knot-security", SECURITY)
    assert "slip load (run-away) / slow-slip load, mN" in text and "≤ x" in text and "not set" in text


def test_format_table_rows_are_knots_and_columns_mu():
    table = pd.DataFrame({"knot": ["reef", "reef", "granny"], "mu": [0.3, 0.2, 0.2],
                          "cell": ["a", "b", "failed: X"]})
    text = format_table(table)
    lines = text.splitlines()
    assert lines[0].split() == ["knot", "mu", "=", "0.2", "mu", "=", "0.3"]
    assert lines[2].split() == ["reef", "b", "a"]
    assert lines[3].split()[:3] == ["granny", "failed:", "X"] and lines[3].endswith("not run")
    md = format_table(table, markdown=True)
    assert md.splitlines()[0] == "| knot | mu = 0.2 | mu = 0.3 |" and "| granny | failed: X | not run |" in md


def test_table_from_results_reads_none_metrics_from_the_summaries(tmp_path):
    """A metric that is None in every case (no run-away) is not a column of results.parquet; the
    cell still shows it (from summary.json), as a held knot's '> x'."""
    metrics = {"slip_load": None, "slow_slip_load": 0.0071, "slip_during_transient": False,
               "slow_slip_during_transient": True, "largest_load_held": 0.021, "set_still": False,
               "slip_onset": None}
    (tmp_path / "cases" / "a").mkdir(parents=True)
    (tmp_path / "cases" / "a" / "summary.json").write_text(json.dumps({"metrics": metrics}))
    df = pd.DataFrame([
        {"case_id": "a", "knot": "reef_bend", "overrides.mu": 0.3, "outcome": "completed", "error": None,
         "protocol_outcome": "held", "slow_slip_load": 0.0071, "case_dir": "cases/a"},
        {"case_id": "b", "knot": "/x/bad.toml", "overrides.mu": 0.3, "outcome": "failed",
         "error": "ConfigError: knot: bad", "case_dir": "cases/b"},
    ])
    table, shown = _comparison_table(df, "knot-security", {"reef_bend": "reef_bend", "/x/bad.toml": "bad"}, tmp_path)
    assert [m.name for m in shown] == ["slip_load", "slow_slip_load"]
    assert list(table["knot"]) == ["reef_bend", "bad"]
    assert table.loc[0, "cell"] == "> 21 / ≤ 7.1 mN, held, not set"
    assert table.loc[1, "cell"] == "failed: ConfigError: knot: bad" and table.loc[1, "outcome"] == "failed"


# ------------------------------------------------------------------------------------------ input
def test_parse_mu_list():
    assert parse_mu_list("0.2, 0.3,0.4") == [0.2, 0.3, 0.4]
    with pytest.raises(ConfigError, match=r"^mu: --mu 0\.2,abc: 'abc' is not a number"):
        parse_mu_list("0.2,abc")
    with pytest.raises(ConfigError, match="mu"):
        parse_mu_list("-0.1")


def test_compare_study_sweeps_knots_and_mu(tmp_path):
    drawing = tmp_path / "mine.toml"
    drawing.write_text("")
    study = compare_study(["reef_bend", str(drawing), "reef_bend"], mu=[0.2, 0.4], overrides={"load_time": 1.0},
                          quick=True)
    assert study["grid"] == {"knot": ["reef_bend", str(drawing.resolve())], "overrides.mu": [0.2, 0.4]}
    assert study["base"] == {"protocol": "knot-security", "knot": "reef_bend", "quick": True,
                             "overrides": {"load_time": 1.0}}
    assert study["name"] == "compare-reef_bend-mine"
    default = compare_study(["reef_bend"])  # the protocol's default mu
    assert default["grid"]["overrides.mu"] == [0.3]
    assert compare_study(["reef_bend"], overrides={"mu": 0.25})["grid"]["overrides.mu"] == [0.25]


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"knots": ["no_such_knot"]}, r"^knot: unknown knot 'no_such_knot'"),
    ({"knots": ["missing/file.toml"]}, r"^knot: no knot drawing 'missing/file.toml'"),
    ({"knots": ["reef_bend"], "protocol": "nope"}, r"^protocol: unknown protocol 'nope'"),
    ({"knots": ["reef_bend"], "overrides": {"bogus": 1}}, r"^bogus: unknown parameter"),
    ({"knots": ["reef_bend"], "overrides": {"mu": 0.2}, "mu": [0.3]}, r"^mu: given twice"),
    ({"knots": []}, r"^knots: give at least one knot"),
])
def test_compare_study_refuses_bad_input(kwargs, match):
    knots = kwargs.pop("knots")
    with pytest.raises(ConfigError, match=match):
        compare_study(knots, **kwargs)
