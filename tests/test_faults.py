"""Faults of a run: SIGTERM and kill -9 lose nothing beyond the last log flush; operating-system
errors are one-line errors."""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from knotsim.io.run_output import LOG_FLUSH_SECONDS, read_log
from knotsim.study.spec import dumps_toml

RUN = {
    "rods": [{"name": "rope", "shape": "straight", "length": 0.1, "n_nodes": 11, "radius": 1e-3,
              "youngs_modulus": 1e7, "density": 1000.0}],
    "bc": [{"type": "move", "name": "left", "nodes": [0, 1], "velocity": [-1e-4, 0.0, 0.0]},
           {"type": "move", "name": "right", "nodes": [-2, -1], "velocity": [1e-4, 0.0, 0.0]}],
    "solver": {"dt": 1e-3},
    "run": {"duration": 1000.0, "output_interval": 0.05},
}


def _start(tmp_path: Path, checkpoint_seconds: float | None = None) -> tuple[subprocess.Popen, Path]:
    cfg = tmp_path / "run.toml"
    cfg.write_text(dumps_toml(RUN))
    out = tmp_path / "out"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    cmd = [sys.executable, "-m", "knotsim.cli", "run", str(cfg), "-o", str(out)]
    if checkpoint_seconds is not None:  # the same command with a shorter checkpoint interval
        cmd = [sys.executable, "-c", "import sys, knotsim.io.run_output as r, knotsim.cli as c; "
               f"r.CHECKPOINT_SECONDS = {checkpoint_seconds}; sys.argv = ['knotsim'] + sys.argv[1:]; c.main()",
               "run", str(cfg), "-o", str(out)]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    side = out / "log.jsonl"
    while time.monotonic() - t0 < 120:  # until a few flushes went out
        if side.is_file() and sum(1 for _ in side.open()) >= 40:
            break
        if proc.poll() is not None:
            pytest.fail(f"the run ended early: {proc.communicate()}")
        time.sleep(0.05)
    return proc, out


def test_sigterm_writes_log_run_json_and_checkpoint(tmp_path):
    proc, out = _start(tmp_path)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "Traceback" not in err and "SIGTERM" in err
    info = json.loads((out / "run.json").read_text())
    assert info["outcome"] == "interrupted" and info["steps"] >= 40
    log = read_log(out)
    assert len(log) == info["steps"] and (out / "log.parquet").is_file()
    assert not (out / "log.jsonl").exists()  # compacted
    assert (out / "checkpoint.npz").is_file()


def test_kill9_keeps_the_rows_up_to_the_last_flush_and_run_json(tmp_path):
    proc, out = _start(tmp_path)
    time.sleep(LOG_FLUSH_SECONDS + 0.5)
    proc.send_signal(signal.SIGKILL)
    proc.communicate(timeout=60)
    info = json.loads((out / "run.json").read_text())
    assert info["outcome"] == "running" and info["steps"] >= 40
    assert "git_commit" in info
    log = read_log(out)  # from log.jsonl: no log.parquet after kill -9
    assert not (out / "log.parquet").exists()
    assert len(log) >= info["steps"] and log["time"].is_monotonic_increasing
    assert {"time", "dt", "iterations", "left_fx"} <= set(log.columns)


def test_kill9_then_run_from_continues_from_the_last_periodic_checkpoint(tmp_path):
    from knotsim.io.checkpoint import read_checkpoint
    from knotsim.runspec import run

    proc, out = _start(tmp_path, checkpoint_seconds=0.5)
    time.sleep(1.5)
    proc.send_signal(signal.SIGKILL)
    proc.communicate(timeout=60)
    assert (out / "run.toml").is_file() and (out / "checkpoint.npz").is_file()  # written while it ran
    t_ckpt = read_checkpoint(out / "checkpoint.npz").time
    assert t_ckpt > 0.0
    res = run(out / "run.toml", tmp_path / "more", duration=0.05, continue_from=out)
    assert res.state.time == pytest.approx(t_ckpt + 0.05)


def test_output_under_a_regular_file_is_a_one_line_error(tmp_path):
    cfg = tmp_path / "run.toml"
    run = dict(RUN, run={"duration": 0.01})
    cfg.write_text(dumps_toml(run))
    blocker = tmp_path / "file"
    blocker.write_text("x")
    res = subprocess.run([sys.executable, "-m", "knotsim.cli", "run", str(cfg), "-o", str(blocker / "out")],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert "not a directory" in res.stderr


@pytest.mark.parametrize("key,value", [("pull_speed", 0.0), ("pull_speed", -1e-3), ("mean_window", -1.0),
                                       ("dt", float("nan")), ("mu", -0.1), ("n_nodes", 2.5)])
def test_protocol_parameters_are_checked_under_their_own_name_before_running(key, value):
    from knotsim.errors import ConfigError
    from knotsim.protocols.params import COMMON_DEFAULTS, resolve_params

    defaults = {**COMMON_DEFAULTS, "pull_speed": 1e-3, "mean_window": 1.0}
    resolve_params(defaults)  # the defaults themselves are in range
    with pytest.raises(ConfigError) as info:
        resolve_params(defaults, {key: value})
    assert info.value.field == key and "--set" in str(info.value)


def test_every_protocol_default_is_in_range():
    from knotsim.protocols.params import check_param_ranges, protocol_defaults
    from knotsim.protocols.registry import protocols

    for proto in protocols().values():
        check_param_ranges(protocol_defaults(proto))


# ------------------------------------------------------------------------------------------ OS probes
def test_malformed_scheduler_address_is_one_line(tmp_path):
    from click.testing import CliRunner

    from knotsim.cli import main

    study = Path(__file__).resolve().parents[1] / "examples" / "studies" / "bends.toml"
    res = CliRunner().invoke(main, ["study", str(study), "-o", str(tmp_path / "s"), "--scheduler", "tcp://::bad::"])
    assert res.exit_code == 2, res.output
    assert "scheduler" in res.output and "Traceback" not in res.output


@pytest.mark.parametrize("err, words", [(errno.ENOSPC, "the disk is full"), (errno.EROFS, "read-only")])
def test_full_or_read_only_disk_during_a_run_is_one_line(tmp_path, monkeypatch, err, words):
    """The trajectory cannot be written (disk full, or the file system read-only): one line, exit 2."""
    from click.testing import CliRunner

    from knotsim.cli import main
    from knotsim.io import trajectory

    def broken(self, *a, **k):
        raise OSError(err, os.strerror(err), str(tmp_path / "out" / "trajectory.h5"))

    monkeypatch.setattr(trajectory.TrajectoryWriter, "append", broken)
    cfg = Path(__file__).resolve().parents[1] / "examples" / "hanging_rod.toml"
    res = CliRunner().invoke(main, ["run", str(cfg), "-o", str(tmp_path / "out"), "--duration", "0.01", "-q"])
    assert res.exit_code == 2, res.output
    assert words in res.output and "Traceback" not in res.output
    assert len([line for line in res.output.splitlines() if line.startswith("error:")]) == 1


def test_nan_positions_are_refused_at_export(tmp_path):
    import numpy as np

    from knotsim.errors import ConfigError
    from knotsim.io.trajectory import TrajectoryWriter
    from knotsim.io.vtk import export_vtk

    with TrajectoryWriter(tmp_path / "trajectory.h5", [0, 3], [0, 2], [False], [1e-3]) as w:
        x = np.zeros((3, 3))
        x[:, 0] = [0.0, 1e-3, 2e-3]  # a straight rod (coincident nodes would make the fields 0/0)
        w.append(0.0, x, np.zeros(2))
        x = x.copy()
        x[1, 0] = np.nan
        w.append(0.1, x, np.zeros(2))
    with pytest.raises(ConfigError, match=r"frame 1 \(t = 0.1 s\) has non-finite positions \(first at node 1\)"):
        export_vtk(tmp_path / "trajectory.h5", tmp_path / "vtk")


def test_animate_case_accepts_only_case_ids(tmp_path):
    from click.testing import CliRunner

    from knotsim.cli import main

    (tmp_path / "cases").mkdir()
    for bad in ("../../*", "/etc"):
        res = CliRunner().invoke(main, ["animate", str(tmp_path), "--case", bad, "-o", str(tmp_path / "a.gif")])
        assert res.exit_code == 2 and "expected a case id" in res.output and "Traceback" not in res.output


def test_trajectory_chunks_are_sized_by_bytes(tmp_path):
    import h5py
    import numpy as np

    from knotsim.io.trajectory import TrajectoryWriter

    n = 200_000
    with TrajectoryWriter(tmp_path / "t.h5", [0, n], [0, n - 1], [False], [1e-3]) as w:
        w.append(0.0, np.zeros((n, 3)), np.zeros(n - 1))
    with h5py.File(tmp_path / "t.h5") as f:
        chunk = f["positions"].chunks
    assert chunk[0] == 1  # one 4.8 MB frame per chunk, not 64 (307 MB allocated for one frame)
    assert (tmp_path / "t.h5").stat().st_size < 50 << 20


def test_study_base_must_lie_in_the_study_folder(tmp_path):
    from knotsim.errors import ConfigError
    from knotsim.study.spec import load_study_spec

    (tmp_path / "outside.toml").write_text(dumps_toml(RUN))
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "study.toml").write_text('base = "../outside.toml"\n')
    with pytest.raises(ConfigError, match="outside the study's folder"):
        load_study_spec(tmp_path / "s" / "study.toml")
    (tmp_path / "s" / "inside.toml").write_text(dumps_toml(RUN))
    (tmp_path / "s" / "study.toml").write_text('base = "inside.toml"\n[grid]\n"solver.dt" = [1e-3, 2e-3]\n')
    assert len(load_study_spec(tmp_path / "s" / "study.toml").expand()) == 2


def test_sigterm_inside_a_finaliser_is_raised_again_outside_it():
    """A SIGTERM that arrives while a weakref callback or ``__del__`` runs would be printed as
    "Exception ignored" and lost (the run then went on, deaf to further SIGTERMs): it is re-raised
    by a short timer instead."""
    import sys

    from knotsim.cli import errors

    old_term, old_alrm = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGALRM)

    def __del__():  # a frame named like a finaliser (a real one would run again when collected)
        errors._on_sigterm(signal.SIGTERM, sys._getframe())  # must not raise here

    try:
        __del__()
        assert signal.getitimer(signal.ITIMER_REAL)[0] > 0  # armed
        with pytest.raises(errors.Terminated):
            time.sleep(1.0)  # the timer fires and raises outside the finaliser
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGTERM, old_term)
        signal.signal(signal.SIGALRM, old_alrm)
