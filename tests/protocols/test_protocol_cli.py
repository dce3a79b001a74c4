"""The ``knots``, ``pull`` and ``tie`` commands."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from knotsim.cli.output import RUN_FILES, default_dir, prepare_output
from knotsim.cli.protocols import knots, pull, tie
from knotsim.errors import ConfigError
from knotsim.protocols.params import COMMON_DEFAULTS, PARAM_INFO, describe_params
from knotsim.protocols.registry import protocols


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
    # --quick says what it changes, and that a --set value wins over it
    assert "note: --quick: dt = 0.005 (default 0.0005)" in res.stderr
    assert "note: --quick: n_nodes = 81 not applied (--set n_nodes=61 wins)" in res.stderr
    # the figures: force against time and e, renders of the first and last frames
    assert (out / "force.png").stat().st_size > 1000
    assert {p.name for p in (out / "render").glob("*.png")} == {"first.png", "last.png"}  # framed on the knot
    # the directory is not empty now: refused without --overwrite
    again = CliRunner().invoke(pull, ["overhand_n1", "--quick", "-o", str(out), "--set", "duration=0.1"])
    assert again.exit_code == 2 and "is not empty; pass --overwrite" in again.output
    assert len(again.output.strip().splitlines()) - again.output.count("note: ") == 1
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
    """The quickstart's drawn reef never tightens in 2 s (loose: its force after the 1 s transient
    stays below the free-rope level), and a 1.5 s bend pull is shorter than the 4 s of evidence the
    slip rule needs (undecided): neither is reported as held."""
    from knotsim.protocols import run_protocol

    reef = run_protocol("single-rod-bend", "single_rod_reef", quick=True)
    assert reef["knot_status"] == "loose"
    m = reef["metrics"]
    assert m["F_norm_peak"] < 0.5 * m["free_rope_level"] and m["left_free_rope_level"] is False
    assert m["rope_in_knot_final"] > 3 * m["ideal_rope_in_knot"]  # reported, not deciding
    bend = run_protocol("two-rope-bend", "grief_bend", quick=True)
    assert bend["knot_status"] == "undecided"


def test_every_protocol_parameter_has_unit_and_meaning():
    used = set(COMMON_DEFAULTS)
    for proto in protocols().values():
        rows = describe_params(proto)  # KeyError if one is missing from PARAM_INFO
        keys = [r[0] for r in rows]
        assert set(keys) == set(COMMON_DEFAULTS) | set(proto.defaults)
        assert all(unit and len(meaning) > 10 for _, _, unit, meaning in rows)
        used |= set(keys)
    assert set(PARAM_INFO) == used  # no description of a parameter that no longer exists


@pytest.mark.parametrize("proto", sorted(protocols()))
def test_show_params_prints_every_key_default_and_unit(proto):
    res = CliRunner().invoke(pull, ["--protocol", proto, "--show-params"])
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    for key, default, unit, meaning in describe_params(protocols()[proto]):
        line = next(x for x in lines if x.split()[:1] == [key])
        assert unit in line and meaning in line
        assert ("none" if default is None else f"{default:.4g}" if isinstance(default, float) else str(default)) in line
    assert any(x.startswith("--quick sets: ") for x in lines)
    assert "contact.stiffness_scaler" in res.output


def test_overwrite_clears_only_knotsims_files(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    for name in ("summary.json", "run.json", "force.png"):
        (out / name).write_text("old")
    (out / "render").mkdir()
    (out / "render" / "frame_000003.png").write_text("old")
    (out / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match="output: .* is not empty"):
        prepare_output(out, tmp_path / "unused", overwrite=False)
    assert prepare_output(out, tmp_path / "unused", overwrite=True) == out
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]
    assert {"trajectory.h5", "log.parquet", "run.toml", "checkpoint.npz", "render"} <= set(RUN_FILES)


def test_default_output_dir_and_empty_o(tmp_path, capsys):
    assert default_dir("overhand_n1", "overhand-pull").as_posix() == "runs/overhand_n1-overhand-pull"
    assert default_dir("my knot/x", "p").as_posix() == "runs/my_knot_x-p"
    assert prepare_output(None, tmp_path / "d", overwrite=False) == tmp_path / "d"
    assert "output directory: " in capsys.readouterr().err
    for cmd, args in ((pull, ["overhand_n1", "--quick"]), (tie, ["overhand"])):
        res = CliRunner().invoke(cmd, [*args, "-o", ""])
        assert res.exit_code == 2 and "must not be empty" in res.output


@pytest.mark.parametrize("knot,proto,fits", [("reef_bend", "overhand-pull", "two-rope-bend"),
                                             ("overhand_n1", "two-rope-bend", "overhand-pull")])
def test_protocol_that_does_not_fit_the_knot_is_refused(tmp_path, knot, proto, fits):
    res = CliRunner().invoke(pull, [knot, "--protocol", proto, "--quick", "-o", str(tmp_path / "x")])
    assert res.exit_code == 2
    err = [x for x in res.output.splitlines() if not x.startswith("note: ")]
    assert len(err) == 1 and err[0].startswith("error: protocol: ") and fits in err[0], res.output
    assert not (tmp_path / "x").exists()
