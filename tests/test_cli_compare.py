"""``knotsim compare``: a real quick comparison of two bends and a broken drawing (one worker),
rerun to check that it resumes; an input error; every case failing. About 30 s in all."""

from __future__ import annotations

import re

import pytest
from click.testing import CliRunner

from knotsim.cli import main

#: the quick knot-security settings, shortened: a 1 s ramp to 21 mN and no search for a still set
ARGS = ["--protocol", "knot-security", "--quick", "--set", "load_time=1.0", "--set", "set_until_still=false",
        "--workers", "1", "-q"]


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    """One comparison: reef_bend, granny_bend and a drawing that is not TOML (its case fails)."""
    base = tmp_path_factory.mktemp("compare")
    broken = base / "broken.toml"
    broken.write_text("this is = = not a knot\n")
    out = base / "cmp"
    words = ["compare", "reef_bend", "granny_bend", str(broken), *ARGS, "-o", str(out)]
    res = CliRunner().invoke(main, words, catch_exceptions=False)
    return words, out, res


def _cells(output: str) -> dict[str, str]:
    """The rows of the printed table: knot -> the rest of its line."""
    rows = {}
    for line in output.splitlines():
        m = re.match(r"(reef_bend|granny_bend|broken)\s+(.*)", line)
        if m:
            rows[m.group(1)] = m.group(2)
    return rows


def test_compare_prints_one_row_per_knot_with_loads_or_outcomes(compared):
    _, out, res = compared
    assert res.exit_code == 0, res.output  # one case failed, not every case
    assert re.search(r"^knot\s+mu = 0\.3$", res.output, re.M), res.output
    assert "not a measurement" in res.output  # quick settings do not rank knots: said
    cells = _cells(res.output)
    for knot in ("reef_bend", "granny_bend"):
        assert re.fullmatch(r"[≤> ]*[\d.]+ / [≤ ]*([\d.]+|—) mN, (held|slipped|untied|capsized|undecided)(, not set)?",
                            cells[knot]), cells
    assert (out / "report.md").is_file() and (out / "forces.png").stat().st_size > 10_000
    assert (out / "compare.toml").is_file() and (out / "study" / "results.parquet").is_file()
    report = (out / "report.md").read_text()
    assert "| reef_bend |" in report and "![force curves](forces.png)" in report
    assert "| load_time | 1.0 | 0.0 | s |" in report  # a parameter that differs from the default
    pictures = re.findall(r"!\[[^]]*\]\((pictures/[^)]+\.png)\)", report)
    assert len(pictures) >= 2 and all((out / p).is_file() for p in pictures)


def test_a_failing_case_shows_its_error_in_its_cell(compared):
    _, out, res = compared
    cells = _cells(res.output)
    assert cells["broken"].startswith("failed: ConfigError:"), cells
    assert "invalid TOML" in (out / "report.md").read_text()  # the whole message in the report


def test_rerun_reuses_the_finished_cases_and_other_arguments_are_refused(compared):
    words, out, first = compared
    records = sorted((out / "study" / "cases").glob("*/result.json"))
    assert len(records) == 3
    before = {p: p.stat().st_mtime_ns for p in records}
    res = CliRunner().invoke(main, words, catch_exceptions=False)
    assert res.exit_code == 0, res.output
    assert "3 of 3 cases reused" in res.output
    assert {p: p.stat().st_mtime_ns for p in records} == before  # no case ran again
    assert _cells(res.output) == _cells(first.output)
    other = CliRunner().invoke(main, [*words, "--mu", "0.4"], catch_exceptions=False)
    assert other.exit_code == 2 and "--overwrite" in other.output, other.output


def test_bad_mu_is_an_input_error(tmp_path):
    res = CliRunner().invoke(main, ["compare", "reef_bend", "--mu", "0.2,abc", "-o", str(tmp_path / "x")])
    assert res.exit_code == 2 and "--mu 0.2,abc" in res.output, res.output
    assert not (tmp_path / "x").exists()


def test_exit_code_is_nonzero_when_every_case_failed(tmp_path):
    broken = tmp_path / "broken.toml"
    broken.write_text("[[not a knot\n")
    res = CliRunner().invoke(main, ["compare", str(broken), *ARGS, "-o", str(tmp_path / "cmp")],
                             catch_exceptions=False)
    assert res.exit_code == 1, res.output
    assert "failed: ConfigError" in res.output and (tmp_path / "cmp" / "report.md").is_file()
