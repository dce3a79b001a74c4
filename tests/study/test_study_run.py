"""Running studies: local pool, Dask LocalCluster, kill -9 and resume, failures, report, animation.

Real (small) simulations: a rod pulled at both ends, swept Young's modulus and pull speed; every
case takes well under a second once the worker has loaded knotsim.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

import knotsim.study as study_api
from knotsim.cli.study import animate, report, study
from knotsim.errors import ConfigError
from knotsim.study.runner import run_study
from knotsim.study.spec import dumps_toml

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

STUDY = {
    "name": "pull",
    "description": "rod pulled at both ends",
    "base": {
        "rods": [{"name": "rope", "shape": "straight", "length": 0.1, "n_nodes": 21, "radius": 1e-3,
                  "youngs_modulus": 1e7, "density": 1000.0}],
        "bc": [{"type": "move", "name": "left", "nodes": [0, 1], "velocity": [-1e-3, 0.0, 0.0]},
               {"type": "move", "name": "right", "nodes": [-2, -1], "velocity": [1e-3, 0.0, 0.0]}],
        "solver": {"dt": 2e-3},
        "run": {"duration": 0.2, "output_interval": 0.02},
    },
    # youngs_modulus = -1 is a bad parameter: those cases fail, the others must finish
    "grid": {"rods[0].youngs_modulus": [1e6, 1e7, -1.0], "bc[1].velocity[0]": [1e-3, 2e-3]},
}
N_CASES, N_FAILED = 6, 2
TIMING = ["wall_time", "run_wall_time"]


def comparable(df: pd.DataFrame) -> pd.DataFrame:
    return df.drop(columns=[c for c in TIMING if c in df.columns]).reset_index(drop=True)


@pytest.fixture(scope="module")
def study_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("spec") / "pull.toml"
    path.write_text(dumps_toml(STUDY))
    return path


@pytest.fixture(scope="module")
def local_run(study_file, tmp_path_factory):
    out = tmp_path_factory.mktemp("local") / "study"
    seen = []
    df = run_study(study_file, out, workers=2, progress=seen.append)
    return out, df, seen


def test_local_pool_runs_every_case_and_records_failures(local_run):
    out, df, seen = local_run
    assert len(df) == N_CASES and df["case_id"].is_unique
    assert (df["outcome"] == "completed").sum() == N_CASES - N_FAILED
    failed = df[df["outcome"] == "failed"]
    assert (failed["rods[0].youngs_modulus"] == -1.0).all()
    assert failed["error"].str.contains("youngs_modulus").all()
    assert failed["traceback"].str.contains("Traceback").all()
    for cid in failed["case_id"]:
        assert "Traceback" in (out / "cases" / cid / "error.txt").read_text()
    ok = df[df["outcome"] == "completed"]
    # F = EA * strain, strain = (v_left + v_right) t / L_free (L_free = 18 of 20 edges = 0.09 m)
    area = 3.141592653589793e-6
    expected = ok["rods[0].youngs_modulus"] * area * (ok["bc[1].velocity[0]"] + 1e-3) * 0.2 / 0.09
    assert ((ok["right_fx"] - expected).abs() < 0.02 * expected).all()
    assert (ok["steps"] >= 100).all() and str(ok["steps"].dtype) == "Int64"
    for cid in df["case_id"]:
        d = out / "cases" / cid
        assert (d / "result.json").is_file() and (d / "case.json").is_file()
    for cid in ok["case_id"]:
        assert (out / "cases" / cid / "trajectory.h5").is_file()
    # store files
    assert (out / "study.toml").is_file() and (out / "results.parquet").is_file()
    prov = json.loads((out / "provenance.json").read_text())
    assert prov["knotsim_version"] and prov["python"] and prov["dependencies"]["numpy"]
    assert prov["machine"]["hostname"] and len(prov["sessions"]) == 1
    pd.testing.assert_frame_equal(study_api.load_study(out), df)
    # progress reports
    assert seen[-1].done == N_CASES and seen[-1].failed == N_FAILED and seen[-1].total == N_CASES
    # an existing study directory needs resume; resuming a finished study runs nothing
    with pytest.raises(ConfigError, match="resume"):
        run_study(STUDY, out)
    again = run_study(STUDY, out, resume=True)
    pd.testing.assert_frame_equal(again, df)


def test_dask_local_cluster_gives_the_same_table(local_run, study_file, tmp_path):
    distributed = pytest.importorskip("distributed")
    _, df_local, _ = local_run
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None,
                                  silence_logs=40) as cluster:
        df = run_study(study_file, tmp_path / "study", scheduler=cluster.scheduler_address)
    pd.testing.assert_frame_equal(comparable(df), comparable(df_local))


def test_kill9_then_resume_gives_the_same_table(local_run, study_file, tmp_path):
    _, df_local, _ = local_run
    out = tmp_path / "study"
    cmd = [sys.executable, "-m", "knotsim.cli", "study", str(study_file), "-o", str(out), "--workers", "1",
           "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    cases = out / "cases"
    t0 = time.monotonic()
    try:
        while time.monotonic() - t0 < 60:
            done = [d for d in cases.glob("*") if not d.name.startswith(".")] if cases.is_dir() else []
            if done or proc.poll() is not None:
                break
            time.sleep(0.01)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    finished = [d for d in cases.iterdir() if not d.name.startswith(".")]
    assert 1 <= len(finished) < N_CASES, "the study was not killed mid-run"
    for d in finished:  # a case directory with the final name is always complete
        assert (d / "result.json").is_file()
    time.sleep(0.2)  # the worker dies with its parent (PR_SET_PDEATHSIG)
    df = run_study(study_file, out, workers=2, resume=True)
    assert len(df) == N_CASES and df["case_id"].is_unique
    assert not [d for d in cases.iterdir() if d.name.startswith(".")]  # leftovers cleaned up
    assert len(list(cases.iterdir())) == N_CASES
    pd.testing.assert_frame_equal(comparable(df), comparable(df_local))
    prov = json.loads((out / "provenance.json").read_text())
    assert len(prov["sessions"]) == 2 and prov["sessions"][1]["resume"]


def test_edited_study_reuses_valid_cases(local_run, tmp_path):
    import shutil

    out0, df0, _ = local_run
    out = tmp_path / "study"
    shutil.copytree(out0, out)
    edited = dict(STUDY, grid={"rods[0].youngs_modulus": [1e7, 2e7], "bc[1].velocity[0]": [1e-3, 2e-3]})
    before = {d.name: (d / "result.json").stat().st_mtime_ns for d in (out / "cases").iterdir()}
    df = run_study(edited, out, workers=1, resume=True)
    assert len(df) == 4 and (df["outcome"] == "completed").all()
    reused = set(df["case_id"]) & set(before)
    assert len(reused) == 2  # E = 1e7 cases were not run again
    for cid in reused:
        assert (out / "cases" / cid / "result.json").stat().st_mtime_ns == before[cid]


def test_cli_study_and_report(local_run, study_file, tmp_path):
    out0, df0, _ = local_run
    runner = CliRunner()
    res = runner.invoke(study, [str(study_file), "-o", str(tmp_path / "x"), "--dry-run"])
    assert res.exit_code == 0 and res.output.startswith(f"{N_CASES} cases")
    res = runner.invoke(study, [str(study_file), "-o", str(out0), "--resume", "--quiet"])
    assert res.exit_code == 1, res.output  # some cases failed
    assert f"{N_CASES} cases (6 already finished, 0 to run)" in res.output
    res = runner.invoke(report, [str(out0)])
    assert res.exit_code == 0, res.output
    md = (out0 / "report.md").read_text()
    assert "# Study report: pull" in md and "## Failed cases" in md and "## Results" in md
    assert "| rods[0].youngs_modulus |" in md
    from PIL import Image

    figs = sorted((out0 / "report_figures").glob("*.png"))
    # one figure per strength metric (the forces), against one swept parameter; solver statistics,
    # energies and reaction components stay in the table
    assert sorted(f.name for f in figs) == [f"{m}__vs__rods_0_youngs_modulus.png" for m in
                                            ("left_force", "left_force_max", "right_force", "right_force_max")]
    for f in figs:
        assert f"report_figures/{f.name}" in md
        with Image.open(f) as im:
            assert im.size == (640, 400)


def _synthetic_study(tmp_path, raw: dict, metrics) -> None:
    """Write a finished study of ``raw``'s cases without running them: each case gets a traction
    log ``F_norm = mu t / 13`` over 13 s and the metrics ``metrics(case params)``."""
    import numpy as np

    from knotsim.study.spec import load_study_spec
    from knotsim.study.store import StudyStore

    spec = load_study_spec(raw)
    cases = spec.expand()
    store = StudyStore(tmp_path)
    store.prepare(spec, session={})
    records = {}
    for c in cases:
        d = store.case_dir(c.case_id)
        d.mkdir(parents=True)
        t = np.linspace(0, 13, 27)
        pd.DataFrame({"time": t, "F_norm": c.params["overrides.mu"] * t / 13}).to_parquet(d / "log.parquet")
        rec = {"case_id": c.case_id, "outcome": "completed", "wall_time": 1.0, "host": "h",
               "metrics": metrics(c.params)}
        (d / "result.json").write_text(json.dumps(rec))
        records[c.case_id] = rec
    store.write_results(cases, records)


def test_report_mae259b_shape(tmp_path):
    """A synthetic knot x mu study with traction time series gets the MAE259B figures."""
    raw = {"name": "mae", "base": {"protocol": "single-rod-bend", "knot": "single_rod_reef", "overrides": {}},
           "grid": {"knot": ["single_rod_granny", "single_rod_reef"], "overrides.mu": [0.1, 0.3, 0.5]}}
    _synthetic_study(tmp_path, raw, lambda p: {
        "F_norm_mean": p["overrides.mu"] + (0.1 if "reef" in p["knot"] else 0.0)})
    md = study_api.write_report(tmp_path).read_text()
    assert "MAE259B" in md and "| reef | 0.5 |" in md and "0.834" in md
    from PIL import Image

    for name in ("mae259b_traction_time.png", "mae259b_mean_traction_mu.png"):
        with Image.open(tmp_path / "report_figures" / name) as im:
            assert im.size == (640, 400)


def test_animate_a_case(local_run, tmp_path):
    out0, df, _ = local_run
    cid = df.loc[df["outcome"] == "completed", "case_id"].iloc[0]
    gif = tmp_path / "a.gif"
    res = CliRunner().invoke(animate, [str(out0), "--case", cid[:8], "-o", str(gif), "--every", "2",
                                       "--size", "160x120", "--backend", "matplotlib"])
    assert res.exit_code == 0, res.output
    from PIL import Image

    with Image.open(gif) as im:
        assert im.n_frames == 6  # 11 frames (0.2 s every 0.02 s), every 2nd
        assert im.size == (160, 120)
    res = CliRunner().invoke(animate, [str(out0), "-o", str(gif)])
    assert res.exit_code == 2 and "--case" in res.output


def test_protocol_case(tmp_path):
    """One tiny protocol case, run in this process."""
    from knotsim.study.spec import load_study_spec
    from knotsim.study.store import StudyStore, results_frame, run_case_atomically

    spec = load_study_spec({"base": {"protocol": "single-rod-bend", "knot": "single_rod_reef", "quick": True,
                                     "overrides": {"n_nodes": 61, "duration": 0.01, "dt": 5e-3}},
                            "grid": {"overrides.mu": [0.2]}})
    (case,) = spec.expand()
    rec = run_case_atomically(case.to_dict(), tmp_path, tmp_path)
    assert rec["outcome"] == "completed", rec["traceback"]
    df = results_frame([case], StudyStore(tmp_path).finished())
    assert {"F_norm_mean", "protocol_outcome", "overrides.mu"} <= set(df.columns)
    assert (tmp_path / "cases" / case.case_id / "summary.json").is_file()


def test_report_two_rope_bends_are_not_compared_with_mae259b(tmp_path):
    """Reef and granny *bends* (two ropes, knot kind 'bend') x mu: no single-rod MAE259B section."""
    raw = {"name": "bends", "base": {"protocol": "two-rope-bend", "knot": "reef_bend", "overrides": {}},
           "grid": {"knot": ["granny_bend", "reef_bend"], "overrides.mu": [0.2, 0.4]}}
    _synthetic_study(tmp_path, raw, lambda p: {"F_norm_hold": p["overrides.mu"], "knot_kind": "bend"})
    md = study_api.write_report(tmp_path).read_text()
    assert "MAE259B" not in md and "0.834" not in md
    assert "F_norm_hold" in md


def test_report_plot_metrics_option(local_run, tmp_path):
    """``knotsim report --metric NAME`` plots only the named metrics; an unknown name is an error
    naming it (exit code 2) that leaves the existing figures alone."""
    out0, df, _ = local_run
    from knotsim.cli.study import report

    res = CliRunner().invoke(report, [str(out0), "--metric", "steps"])
    assert res.exit_code == 0, res.output
    figs = sorted(p.name for p in (out0 / "report_figures").glob("*.png"))
    assert figs and all(f.startswith("steps__vs__") for f in figs), figs
    res = CliRunner().invoke(report, [str(out0), "--metric", "no_such_metric"])
    assert res.exit_code == 2 and "no_such_metric" in res.output
    assert sorted(p.name for p in (out0 / "report_figures").glob("*.png")) == figs


def test_report_traction_time_is_pull_time_after_pre_pull(tmp_path, monkeypatch):
    """With a pre-tightening (metric pre_pull_time) the MAE259B traction plot shows the 13 s window
    only, timed from its start."""
    import numpy as np

    import knotsim.study.report as R

    raw = {"name": "mae", "base": {"protocol": "single-rod-bend", "knot": "single_rod_reef", "overrides": {}},
           "grid": {"knot": ["single_rod_granny", "single_rod_reef"], "overrides.mu": [0.1, 0.5]}}
    _synthetic_study(tmp_path, raw, lambda p: {"F_norm_mean": p["overrides.mu"], "pre_pull_time": 5.0,
                                               "knot_kind": "single_rod_bend"})
    drawn = []
    real_figure = R._figure

    def figure():
        fig, ax = real_figure()
        orig = ax.plot

        def plot(x, *a, **k):
            drawn.append(np.asarray(x, float))
            return orig(x, *a, **k)

        ax.plot = plot
        return fig, ax

    monkeypatch.setattr(R, "_figure", figure)
    R.write_report(tmp_path)
    series = [x for x in drawn if x.size > 5]  # the traction series, not the 5-point mean-vs-mu lines
    assert len(series) == 4
    for x in series:  # the synthetic logs run 0..13 s: after a 5 s pre-pull, 0..8 s of window
        assert x[0] >= -1e-9 and x[-1] == pytest.approx(8.0)
