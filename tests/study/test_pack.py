"""A study keeps what reproduces it: each case's log thinned to 0.05 s in ``timeseries.parquet``,
and, once packed, its case records in ``cases.parquet`` in place of the case folders; a packed
study reopens, reports and resumes as before."""

from __future__ import annotations

import math
import os

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

import knotsim as ks
from knotsim.cli.study import study as study_cmd
from knotsim.protocols.knot_security import KnotSecurity
from knotsim.study.runner import plan_study, run_study
from knotsim.study.series import THIN_INTERVAL, event_times, thin_log
from knotsim.study.spec import dumps_toml
from knotsim.study.store import StudyStore, pack_study

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

def _end(name: str, nodes: list[int], speed: float) -> dict:
    """An end of the rope moved along x at ``speed`` m/s."""
    return {"type": "move", "name": name, "nodes": nodes, "velocity": [speed, 0.0, 0.0]}


#: A 10 cm rod stretched from both ends for 0.2 s (two cases: two speeds of its right end).
TINY = {"name": "tiny",
        "base": {"rods": [dict(name="rope", shape="straight", length=0.1, n_nodes=11, radius=1e-3,
                               youngs_modulus=1e7, density=1000.0)],
                 "bc": [_end("left", [0, 1], -1e-3), _end("right", [-2, -1], 1e-3)],
                 "solver": {"dt": 5e-3}, "run": {"duration": 0.2, "output_interval": 0.1}},
        "grid": {"bc[1].velocity[0]": [1e-3, 2e-3]}}


@pytest.fixture(scope="module")
def tiny_study(tmp_path_factory):
    root = tmp_path_factory.mktemp("tiny")
    spec = root / "tiny.toml"
    spec.write_text(dumps_toml(TINY))
    out = root / "study"
    df = run_study(spec, out, workers=1)
    return spec, out, df


def test_a_study_writes_its_thinned_time_series(tiny_study):
    _, out, df = tiny_study
    series = pd.read_parquet(out / "timeseries.parquet")
    assert list(series.columns[:2]) == ["case_id", "time"]
    assert set(series["case_id"]) == set(df["case_id"])
    for cid, g in series.groupby("case_id"):
        t = g["time"].to_numpy()
        log = pd.read_parquet(out / "cases" / cid / "log.parquet")
        assert t[0] == log["time"].iloc[0] and t[-1] == pytest.approx(0.2)  # the first and last rows
        assert np.all(np.diff(t) <= THIN_INTERVAL + 1e-9)  # one row per 0.05 s at least
        assert len(t) < len(log)  # and thinner than the log
        assert "right_force" in g.columns  # a plain run keeps its numeric columns


def test_packed_study_reopens_reports_and_resumes(tiny_study, tmp_path):
    spec, out, df = tiny_study
    import shutil

    d = tmp_path / "study"
    shutil.copytree(out, d)
    finished = StudyStore(d).finished()
    series = StudyStore(d).read_series()
    res = CliRunner().invoke(study_cmd, ["--pack", "-o", str(d)])
    assert res.exit_code == 0, res.output
    assert not (d / "cases").exists() and (d / "cases.parquet").is_file()
    store = StudyStore(d)
    assert store.finished() == finished
    pd.testing.assert_frame_equal(ks.load_study(d), ks.load_study(out))
    pd.testing.assert_frame_equal(store.read_series(), series)
    assert store.read_series(df["case_id"][0]) is not None
    _, _, reused, todo = plan_study(spec, d, resume=True)
    assert not todo and set(reused) == set(finished)
    again = pack_study(d)  # packing twice changes nothing
    assert again["cases"] == len(finished) and again["removed"] == 0
    assert store.finished() == finished
    ks.write_report(d)
    assert "cases in the table: 2" in (d / "report.md").read_text()


# ---------------------------------------------------------------- a knot-security slip load, thinned
class _Ctx:
    """The parts of a RunContext that :meth:`KnotSecurity.metrics` reads."""

    def __init__(self):
        base = {**KnotSecurity.defaults, "set_ramp": 0.5, "set_hold": 0.5, "relax_time": 0.5}  # the load at 1.5 s
        self.params = type("P", (dict,), {"contact": {}})(base)
        self.t_pre, self.t_settle = 1.5, 0.0
        self.plan = self.phase_record = self.topology_end = None
        self.radius, self.EI, self.geometry = 2e-3, 2.26e-6, None


def _security_log(dt=2e-3, t_end=12.0, t_slip=6.3, hold=0.001, rate=0.002):
    """A knot-security log on a fine step: set, relax, then a load ramp under which the knot gives
    way at ``t_slip`` s into the load (the loaded end runs out, the tails are drawn in)."""
    t = np.arange(0.0, t_end + dt / 2, dt)
    t_load = np.clip(t - 1.5, 0.0, None)
    force = np.where(t < 1.5, 0.002, hold + rate * t_load)
    run = np.clip(t_load - t_slip, 0.0, None)
    out = 0.03 * run**2 + 1e-5 * t_load  # the loaded end: a slow stretch, then a run-away
    return pd.DataFrame({"time": t, "F": force, "F_norm": force * 4e-6 / 2.26e-6, "u_pull": out,
                         "tail_a": 0.05 - out / 2, "tail_b": 0.05 - out / 2,
                         "in_knot": 0.25 + 0.0 * t, "rope_gap": 1e-4 + 0.0 * t,
                         "turn_a": 0.0 * t, "turn_b": 0.0 * t})


def test_slip_load_recomputed_from_the_thinned_series():
    log = _security_log()
    full = KnotSecurity().metrics(_Ctx(), log)
    assert full["slip_load"] is not None
    thinned = thin_log(log, "knot-security", event_times({"metrics": full}))
    assert len(thinned) < len(log) / 10
    assert list(thinned.columns) == ["time", "F", "F_norm", "u_pull", "tail_a", "tail_b", "in_knot", "rope_gap",
                                     "turn_a", "turn_b"]
    again = KnotSecurity().metrics(_Ctx(), thinned)
    # within what the load ramp (2 mN/s) adds over one thinning interval, twice (onset and average)
    assert again["slip_load"] == pytest.approx(full["slip_load"], abs=2 * 0.002 * THIN_INTERVAL)
    assert math.isclose(again["slip_onset"]["time"], full["slip_onset"]["time"], abs_tol=2 * THIN_INTERVAL)


def test_thin_log_keeps_event_rows_and_ends():
    log = pd.DataFrame({"time": np.arange(0.0, 1.0001, 0.001), "F": np.linspace(0, 1, 1001)})
    thin = thin_log(log, "knot-security", events=[0.512])
    assert 0.512 in set(np.round(thin["time"], 4)) and thin["time"].iloc[-1] == pytest.approx(1.0)
    assert len(thin) == 22  # 0, 0.05, ..., 1.0 and the event
