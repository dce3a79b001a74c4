"""An input error is printed alone: no note (--quick settings, the compile notice) comes before it;
notes come only with a run that starts (issue "No silent nonsense", item 7)."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

import knotsim._warmup as warmup
from knotsim.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture
def cold_cache(monkeypatch):
    """Make every command believe the kernels are not compiled yet (it then prints the compile
    notice), without compiling anything in extra processes."""
    monkeypatch.setattr(warmup, "kernels_cached", lambda **kw: False)
    monkeypatch.setattr(warmup, "spare_cores", lambda: 0.0)


def _alone(res) -> str:
    assert res.exit_code == 2, (res.exit_code, res.output)
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.stderr
    assert res.stdout.strip() == "", res.stdout
    return lines[0]


@pytest.mark.parametrize("assignment, field", [("mu=abc", "mu"), ("contact.delta=-1", "contact.delta"),
                                               ("no_such_parameter=1", "no_such_parameter"),
                                               ("dt=0", "dt")])
def test_pull_bad_set_value_is_printed_alone(tmp_path, cold_cache, assignment, field):
    res = CliRunner().invoke(main, ["pull", "overhand_n1", "--quick", "--set", assignment, "-o", str(tmp_path / "o")])
    assert field in _alone(res)


def test_run_bad_file_is_printed_alone(tmp_path, cold_cache):
    f = tmp_path / "bad.toml"
    f.write_text((EXAMPLES / "crossing_rods.toml").read_text().replace("[solver]", "[solver]\nno_such_key = 1", 1))
    assert "solver.no_such_key" in _alone(CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o")]))


def test_tie_unknown_sequence_is_printed_alone(tmp_path, cold_cache):
    assert "unknown tying sequence" in _alone(CliRunner().invoke(main, ["tie", "nonsense", "-o", str(tmp_path / "o")]))


def test_notes_come_with_a_run_that_starts(tmp_path, cold_cache):
    """Control: the same fixture does make a valid run print the compile notice."""
    res = CliRunner().invoke(main, ["run", str(EXAMPLES / "hanging_rod.toml"), "-o", str(tmp_path / "o"),
                                    "--duration", "0.004", "-q"])
    assert res.exit_code == 0, res.output
    assert res.stderr.startswith("note: compiling the numerical kernels"), res.stderr
