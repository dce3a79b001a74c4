"""The studies committed under docs/studies/ and validation/studies/ reopen: ``knotsim.load_study``
reads their results table and ``knotsim report`` rebuilds their report."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

import knotsim as ks
from knotsim.cli import main

ROOT = Path(__file__).resolve().parents[2]
COMMITTED = sorted(p.parent for p in [*ROOT.glob("docs/studies/*/study.toml"), *ROOT.glob("validation/studies/*/study.toml")])


def test_there_are_committed_studies():
    assert len(COMMITTED) >= 6


@pytest.mark.parametrize("study_dir", COMMITTED, ids=lambda p: p.name)
def test_committed_study_reopens(study_dir):
    df = ks.load_study(study_dir)
    assert len(df) > 0 and "case_id" in df.columns
    assert df["case_id"].is_unique
    # every completed protocol case says which friction law ran: the surface reruns "surface",
    # the studies recorded before surface friction existed "centreline"
    done = (df["kind"] == "protocol") & (df["outcome"] == "completed")
    expected = "surface" if study_dir.name.endswith(("_surface", "_surface_checks")) else "centreline"
    assert set(df.loc[done, "friction_model"]) == {expected}


def test_committed_study_report_is_rebuilt(tmp_path):
    d = ROOT / "docs" / "studies" / "granny_vs_reef_mu"
    res = CliRunner().invoke(main, ["report", str(d), "-o", str(tmp_path / "report.md")])
    assert res.exit_code == 0, res.output
    text = (tmp_path / "report.md").read_text()
    assert "single_rod_reef" in text and "single_rod_granny" in text
