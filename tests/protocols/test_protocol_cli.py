"""The ``knots``, ``pull`` and ``tie`` commands."""

from __future__ import annotations

import json

from click.testing import CliRunner

from knotsim.protocols.cli import knots, pull, tie


def test_knots_lists_library():
    res = CliRunner().invoke(knots, [])
    assert res.exit_code == 0, res.output
    lines = res.output.strip().splitlines()
    assert any(line.startswith("overhand_n1 ") and "overhand-pull" in line for line in lines)
    assert any(line.startswith("reef_bend ") and "two-rope-bend" in line for line in lines)
    assert len(lines) >= 10


def test_pull_quick_and_bad_key(tmp_path):
    out = tmp_path / "pull"
    res = CliRunner().invoke(pull, ["overhand_n1", "--quick", "-o", str(out), "--set", "duration=0.5",
                                   "--set", "n_nodes=61"])
    assert res.exit_code == 0, res.output
    assert "overhand-pull" in res.output and "F_norm_peak" in res.output
    s = json.loads((out / "summary.json").read_text())
    assert s["parameters"]["n_nodes"] == 61
    bad = CliRunner().invoke(pull, ["overhand_n1", "-o", str(tmp_path / "x"), "--set", "nope=1"])
    assert bad.exit_code == 2
    assert "nope" in bad.output
    bad = CliRunner().invoke(pull, ["no_such_knot", "-o", str(tmp_path / "y")])
    assert bad.exit_code == 2


def test_tie_unknown_sequence_is_bad_input(tmp_path):
    res = CliRunner().invoke(tie, ["bowline", "-o", str(tmp_path / "t")])
    assert res.exit_code == 2
    assert "unknown tying sequence" in res.output


def test_quick_runs_do_not_call_loose_or_short_runs_held(tmp_path):
    """The quickstart's drawn reef never tightens in 2 s (loose), and a 1.5 s bend pull is shorter
    than the 4 s of evidence the slip rule needs (undecided): neither is reported as held."""
    from knotsim.protocols import run_protocol

    reef = run_protocol("single-rod-bend", "single_rod_reef", quick=True)
    assert reef["knot_status"] == "loose"
    assert reef["metrics"]["rope_in_knot_final"] > 3 * reef["metrics"]["ideal_rope_in_knot"]
    bend = run_protocol("two-rope-bend", "grief_bend", quick=True)
    assert bend["knot_status"] == "undecided"
