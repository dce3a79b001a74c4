"""Faults of a study: a worker killed with SIGKILL (locally and on Dask), corrupt case records,
two resumes at once. Real (small) simulations, as in test_study_run.py."""

from __future__ import annotations

import json
import os
import shutil

import pytest

from knotsim.errors import ConfigError
from knotsim.study._faults import KILL_CASE_VAR
from knotsim.study.runner import run_study
from knotsim.study.spec import dumps_toml, load_study_spec
from knotsim.study.store import StudyStore

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

STUDY = {
    "name": "pull",
    "base": {
        "rods": [{"name": "rope", "shape": "straight", "length": 0.1, "n_nodes": 11, "radius": 1e-3,
                  "youngs_modulus": 1e7, "density": 1000.0}],
        "bc": [{"type": "move", "name": "left", "nodes": [0, 1], "velocity": [-1e-3, 0.0, 0.0]},
               {"type": "move", "name": "right", "nodes": [-2, -1], "velocity": [1e-3, 0.0, 0.0]}],
        "solver": {"dt": 5e-3},
        "run": {"duration": 0.05, "output_interval": 0.05},
    },
    "grid": {"rods[0].youngs_modulus": [1e6, 2e6, 5e6, 1e7], "bc[1].velocity[0]": [1e-3, 2e-3]},
}
N_CASES = 8


@pytest.fixture(scope="module")
def study_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("spec") / "pull.toml"
    path.write_text(dumps_toml(STUDY))
    return path


@pytest.fixture
def kill_one(study_file, monkeypatch):
    """Make the worker that starts the third case kill itself with SIGKILL; returns its id."""
    victim = load_study_spec(study_file).expand()[2].case_id
    monkeypatch.setenv(KILL_CASE_VAR, victim)
    return victim


def test_dead_local_worker_costs_only_its_own_case(study_file, kill_one, tmp_path):
    df = run_study(study_file, tmp_path / "s", workers=2)
    assert len(df) == N_CASES
    lost = df[df["outcome"] == "failed"]
    assert list(lost["case_id"]) == [kill_one]
    assert lost["error"].iloc[0].startswith("worker lost") and "SIGKILL" in lost["error"].iloc[0]
    assert (df["outcome"] == "completed").sum() == N_CASES - 1
    assert not (tmp_path / "s" / "cases" / kill_one).exists()  # resume runs it again
    os.environ.pop(KILL_CASE_VAR)
    again = run_study(study_file, tmp_path / "s", workers=2, resume=True)
    assert (again["outcome"] == "completed").all() and len(again) == N_CASES


def test_fresh_worker_per_case_also_survives_a_kill(study_file, kill_one, tmp_path):
    df = run_study(study_file, tmp_path / "s", workers=1, max_cases_per_worker=1)
    assert list(df.loc[df["outcome"] == "failed", "case_id"]) == [kill_one]
    assert (df["outcome"] == "completed").sum() == N_CASES - 1


@pytest.fixture(scope="module")
def finished(study_file, tmp_path_factory):
    out = tmp_path_factory.mktemp("done") / "s"
    df = run_study(study_file, out, workers=2)
    assert (df["outcome"] == "completed").all()
    return out, df


def test_corrupt_records_are_rerun_by_resume(finished, tmp_path):
    src, df = finished
    out = tmp_path / "s"
    shutil.copytree(src, out)
    ids = list(df["case_id"])
    (out / "cases" / ids[0] / "result.json").write_text('{"case_id": "' + ids[0] + '", "outc')  # truncated
    (out / "cases" / ids[1] / "result.json").write_text("[]")
    (out / "cases" / ids[2] / "result.json").write_text("{}")
    (out / "cases" / ids[3] / "result.json").unlink()
    store = StudyStore(out)
    assert set(store.corrupt()) == set(ids[:4]) and len(store.finished()) == N_CASES - 4
    again = run_study(study_file_of(out), out, workers=2, resume=True)
    assert len(again) == N_CASES and (again["outcome"] == "completed").all()
    assert not StudyStore(out).corrupt()
    for cid in ids[:4]:
        rec = json.loads((out / "cases" / cid / "result.json").read_text())
        assert rec["case_id"] == cid and rec["metrics"]["steps"] > 0
    prov = json.loads((out / "provenance.json").read_text())
    assert set(prov["sessions"][-1]["corrupt_cases_rerun"]) == set(ids[:4])
    assert prov["sessions"][-1]["to_run"] == 4


def study_file_of(study_dir):
    return study_dir / "study.toml"


def test_second_session_on_a_locked_study_is_refused(finished, tmp_path):
    src, _ = finished
    out = tmp_path / "s"
    shutil.copytree(src, out)
    shutil.rmtree(next(d for d in (out / "cases").iterdir() if not d.name.startswith(".")))
    prov0 = json.loads((out / "provenance.json").read_text())
    from knotsim.study.store import StudyLock

    with StudyLock(out):  # another session holds the directory
        with pytest.raises(ConfigError, match="being run by another session"):
            run_study(study_file_of(out), out, workers=1, resume=True)
    assert json.loads((out / "provenance.json").read_text()) == prov0  # nothing written by the refused one
    df = run_study(study_file_of(out), out, workers=1, resume=True)  # free again
    assert len(df) == N_CASES


def test_lock_is_released_when_its_process_is_killed(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    from knotsim.study.store import StudyLock

    code = ("import sys, time; from knotsim.study.store import StudyLock; StudyLock(sys.argv[1]).acquire(); "
            "print('locked', flush=True); time.sleep(60)")
    proc = subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "locked"
        with pytest.raises(ConfigError, match=f"pid {proc.pid}"):
            StudyLock(tmp_path).acquire()
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    time.sleep(0.05)
    StudyLock(tmp_path).acquire().release()


def _dask_worker(address, env):
    import subprocess
    import sys

    cmd = [sys.executable, "-m", "distributed.cli.dask_worker", address, "--no-nanny", "--nthreads", "1",
           "--no-dashboard"]
    return subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def test_dask_study_whose_only_worker_dies_does_not_hang(study_file, kill_one, tmp_path):
    """One worker without a nanny; it is killed (SIGKILL) by the third case. The killed case is
    recorded worker lost at once, the cases still waiting for a worker after worker_timeout."""
    import time

    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp", host="127.0.0.1",
                                  dashboard_address=None, silence_logs=40) as cl:
        worker = _dask_worker(cl.scheduler_address, dict(os.environ))
        try:
            with distributed.Client(cl.scheduler_address) as client:
                client.wait_for_workers(1, timeout=60)
                t0 = time.monotonic()
                df = run_study(study_file, tmp_path / "s", scheduler=client, worker_timeout=3.0)
                wall = time.monotonic() - t0
        finally:
            worker.kill()
            worker.wait()
    assert len(df) == N_CASES and wall < 60
    lost = df[df["outcome"] == "failed"].set_index("case_id")["error"]
    assert lost[kill_one].startswith("worker lost") and "left the cluster" in lost[kill_one]
    others = lost.drop(kill_one)
    assert others.str.contains("no Dask worker").all()
    assert (df["outcome"] == "completed").sum() + len(lost) == N_CASES


def test_dask_study_with_a_nanny_loses_only_the_killed_case(study_file, kill_one, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, processes=True, threads_per_worker=1, dashboard_address=None,
                                  silence_logs=50) as cluster:
        df = run_study(study_file, tmp_path / "s", scheduler=cluster.scheduler_address, worker_timeout=60.0)
    lost = df[df["outcome"] == "failed"]
    assert list(lost["case_id"]) == [kill_one] and lost["error"].iloc[0].startswith("worker lost")
    assert (df["outcome"] == "completed").sum() == N_CASES - 1
