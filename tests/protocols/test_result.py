"""run_protocol returns a ProtocolResult: the summary (attributes and dict-style items) and the
per-step log, also when nothing is written."""

from __future__ import annotations

import json

import pandas as pd
import pytest

import knotsim as ks
from knotsim.protocols import ProtocolResult, run_protocol
from knotsim.study.executors import protocol_executor

TINY = {"n_nodes": 41, "dt": 0.01, "duration": 0.1}


def test_result_carries_the_log_in_memory_when_nothing_is_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = run_protocol("overhand-pull", "overhand_n1", overrides=TINY)
    assert isinstance(r, ks.ProtocolResult) and r.out_dir is None
    assert not any(tmp_path.iterdir())  # nothing written
    assert isinstance(r.log, pd.DataFrame) and len(r.log) == r.n_steps == r["n_steps"] > 0
    assert {"time", "F", "F_norm", "e"} <= set(r.log.columns)
    assert r.log["time"].iloc[-1] == pytest.approx(0.1)
    # dict-style access as before, and the summary alone as a plain, JSON-ready dict
    assert r["outcome"] == r.outcome and r.get("metrics") is r.metrics and "log" not in r
    with pytest.raises(KeyError):
        r["log"]
    d = r.to_dict()
    assert list(d) == list(r) == list(ProtocolResult.summary_keys()) and dict(r) == d
    assert json.loads(json.dumps(r)) == json.loads(json.dumps(d))  # JSON-ready as the plain dict was
    assert r == d and type(d) is dict
    # callers may add their own entries, as to the plain dict of earlier versions
    r["wall_time"] = 1.0
    r["_log"] = r.log
    assert r.wall_time == 1.0 and r["_log"] is r.log
    with pytest.raises(AttributeError):
        getattr(r, "no_such_entry")  # noqa: B009


def test_result_log_is_the_written_log(tmp_path):
    r = run_protocol("overhand-pull", "overhand_n1", out_dir=tmp_path, overrides=TINY)
    on_disk = pd.read_parquet(tmp_path / "log.parquet")
    pd.testing.assert_series_equal(r.log["F_norm"].reset_index(drop=True), on_disk["F_norm"], check_dtype=False)
    assert json.loads((tmp_path / "summary.json").read_text()) == json.loads(json.dumps(r.to_dict()))


def test_study_executor_reads_a_result(tmp_path, monkeypatch):
    import knotsim.protocols as P

    keys = ProtocolResult.summary_keys()
    fake = ProtocolResult({k: None for k in keys} | {"metrics": {"F_norm_peak": 0.5}, "outcome": "held",
                                                       "wall_time": 1.0, "protocol": "overhand-pull"})
    monkeypatch.setattr(P, "run_protocol", lambda name, **kw: fake)
    row = protocol_executor({"protocol": "overhand-pull", "knot": "overhand_n1"}, tmp_path, tmp_path)
    assert row["F_norm_peak"] == 0.5 and row["protocol_outcome"] == "held" and row["protocol_wall_time"] == 1.0


def test_pull_json_prints_the_summary(tmp_path):
    from click.testing import CliRunner

    from knotsim.cli.protocols import pull

    args = ["overhand_n1", "-o", str(tmp_path / "o"), "--json", "--no-figures"]
    for k, v in TINY.items():
        args += ["--set", f"{k}={v}"]
    res = CliRunner().invoke(pull, args)
    assert res.exit_code == 0, res.output
    s = json.loads(res.output.strip().splitlines()[-1])
    assert s["protocol"] == "overhand-pull" and set(s) == set(ProtocolResult.summary_keys())
