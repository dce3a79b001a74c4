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
    assert set(df.loc[done, "friction_model"]) == _study_friction_models(study_dir)


def _study_friction_models(study_dir: Path) -> set[str]:
    """The friction laws a committed study ran with: its base's ``contact.friction_model`` when the
    study file sets it, else ``"surface"`` for the surface reruns (``*_surface``, ``*_surface_checks``)
    and the ``knot-security`` studies, which came after surface friction became the default, else
    ``"centreline"``, the default when the older studies were recorded (their copies of the study
    file predate the key); with the laws its ``[[cases]]`` set (a study of both laws side by side),
    in place of the base's when every case sets one."""
    import tomllib

    raw = tomllib.loads((study_dir / "study.toml").read_text())
    base = raw.get("base", {})
    over = base.get("overrides", {})
    model = over.get("contact.friction_model", over.get("contact", {}).get("friction_model"))
    if not model:
        model = ("surface" if study_dir.name.endswith(("_surface", "_surface_checks"))
                 or base.get("protocol") == "knot-security" else "centreline")
    cases = raw.get("cases", [])
    named = [c.get("overrides.contact.friction_model") for c in cases]
    models = {m for m in named if m}
    if not cases or any(m is None for m in named):
        models.add(model)
    return models


def test_committed_study_report_is_rebuilt(tmp_path):
    d = ROOT / "docs" / "studies" / "granny_vs_reef_mu"
    res = CliRunner().invoke(main, ["report", str(d), "-o", str(tmp_path / "report.md")])
    assert res.exit_code == 0, res.output
    text = (tmp_path / "report.md").read_text()
    assert "single_rod_reef" in text and "single_rod_granny" in text


PACKED = [d for d in COMMITTED if (d / "cases.parquet").is_file()]


def test_committed_studies_are_packed():
    """No committed study keeps per-case folders: their records are in one cases.parquet each."""
    assert len(PACKED) >= 15
    assert not [d for d in COMMITTED if (d / "cases").is_dir()]


@pytest.mark.parametrize("study_dir", PACKED, ids=lambda p: p.name)
def test_packed_records_give_the_committed_table(study_dir):
    """The packed records rebuild the committed results table: the same cases, outcomes and numbers."""
    import pandas as pd

    from knotsim.study.store import StudyStore, results_frame

    store = StudyStore(study_dir)
    packed = store.packed()
    rebuilt = results_frame([e["case"] for e in packed.values()], {c: e["record"] for c, e in packed.items()})
    table = ks.load_study(study_dir).set_index("case_id")
    rebuilt = rebuilt.set_index("case_id").loc[table.index]
    numbers = [c for c in table.columns if c in rebuilt.columns and c != "wall_time"
               and pd.api.types.is_numeric_dtype(table[c]) and pd.api.types.is_numeric_dtype(rebuilt[c])]
    assert len(numbers) > 3
    pd.testing.assert_frame_equal(rebuilt[numbers].astype(float), table[numbers].astype(float), check_dtype=False)
    assert (rebuilt["outcome"] == table["outcome"]).all()


def test_packed_study_report_matches_the_committed_one(tmp_path):
    d = ROOT / "docs" / "studies" / "security_mu"
    res = CliRunner().invoke(main, ["report", str(d), "-o", str(tmp_path / "report.md")])
    assert res.exit_code == 0, res.output
    tables = [[ln for ln in p.read_text().splitlines() if ln.startswith("|")]
              for p in (d / "report.md", tmp_path / "report.md")]
    assert tables[0] and tables[0] == tables[1]
