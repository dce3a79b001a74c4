"""Files written by a run: ``trajectory.h5``, ``log.parquet``, ``run.json``, ``run.toml``,
``checkpoint.npz``.

- ``trajectory.h5``: node positions, edge angles, velocities, reference directors and reference
  twist over time (format in ``docs/architecture.md``), appended as the run goes;
- ``log.parquet``: one row per accepted step (time, dt, Newton iterations, residual, energies,
  reaction force of each named boundary-condition group, contact statistics, stage), written at
  the end; while the run goes the rows are appended to ``log.jsonl`` (JSON lines, flushed every
  ``LOG_FLUSH_STEPS`` steps or ``LOG_FLUSH_SECONDS`` s of wall time, whichever comes first), which
  is removed once ``log.parquet`` is written: after ``kill -9`` the rows up to the last flush are
  in ``log.jsonl`` (:func:`read_log` reads either);
- ``run.json``: configuration (when known), knotsim version, git commit of the knotsim source
  (when it is a git checkout), the friction law of each contact interaction (``friction_models``,
  e.g. ``{"contact": "surface", "floor": "surface"}``), wall time, outcome: written at the start with outcome
  ``"running"``, updated at a log flush (steps, simulated time) at most every
  ``LOG_FLUSH_SECONDS`` s and never sooner than 20 times its last write took (a tying sequence's
  260 kB of grip waypoints took 0.2 s to write: rewritten every 16 steps it cost more than the
  steps), and at the end;
- ``run.toml``: the complete run description (when known), which ``knotsim run`` replays; written
  at the start;
- ``checkpoint.npz``: everything that decides the next step, every ``CHECKPOINT_SECONDS`` s of wall
  time while the run goes and at its end (or at the last accepted step of a failed or interrupted
  one): ``knotsim run --from DIR`` continues from it, also after ``kill -9``.
"""

from __future__ import annotations

import json
import platform
import subprocess
import time as _time
from pathlib import Path

from knotsim._util.jsonio import json_safe, write_json
from knotsim._util.toml import write_toml
from knotsim._version import __version__
from knotsim.io.frame_fields import frame_field_names, frame_fields
from knotsim.io.trajectory import TrajectoryWriter

#: The per-step log side file is flushed after this many new rows ...
LOG_FLUSH_STEPS = 16
#: ... or after this much wall time (s) since the last flush, whichever comes first.
LOG_FLUSH_SECONDS = 2.0
LOG_SIDE_FILE = "log.jsonl"
#: A checkpoint is also written while the run goes, every this many s of wall time, so that a run
#: killed with ``kill -9`` can be continued (``knotsim run --from DIR``) from at most that long ago.
CHECKPOINT_SECONDS = 30.0


def git_commit() -> str | None:
    """Commit of the knotsim source when it is a git checkout (``git rev-parse HEAD``, 5 s
    timeout), else ``None``."""
    pkg = Path(__file__).resolve().parents[1]  # the knotsim package directory
    try:
        out = subprocess.run(["git", "-C", str(pkg), "rev-parse", "HEAD"], capture_output=True, text=True,
                             timeout=5)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None if out.returncode == 0 else None


def read_log(run_dir):
    """The per-step log of a run directory: ``log.parquet``, or for a run that was killed before
    its end, the rows flushed to ``log.jsonl`` (pandas DataFrame; a torn last line is skipped)."""
    import pandas as pd

    d = Path(run_dir)
    if (d / "log.parquet").is_file():
        return pd.read_parquet(d / "log.parquet")
    rows = []
    with open(d / LOG_SIDE_FILE, encoding="utf-8") as fh:
        for line in fh:
            try:
                rows.append(json.loads(line))
            except json.JSONDecodeError:
                break  # the process died in the middle of this line
    return pd.DataFrame(rows)


class RunOutput:
    """Writes a run's files into ``output_dir`` while a :class:`~knotsim.simulation.Simulation`
    advances. ``output_interval`` (s) spaces trajectory frames (``None``: every step)."""

    def __init__(self, output_dir, sim, output_interval: float | None = None, config: dict | None = None):
        self.dir = Path(output_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        m = sim.model
        self.model = m
        self.interval = output_interval
        self.config = config if config is not None else sim.config
        self.writer = TrajectoryWriter(self.dir / "trajectory.h5", m.rod_node_start, m.rod_edge_start, m.rod_closed,
                                       m.rod_radius, m.rod_names, flush_every=16, n_bend=int(m.n_bend),
                                       rest_edge_length=m.rest_length,
                                       fields=frame_field_names(sim.stepper.interactions))
        self._next = None
        self._last_time = None
        self._rows_start = len(sim.rows)
        self.sim = sim
        self.started = _time.strftime("%Y-%m-%dT%H:%M:%S%z")
        self._commit = git_commit()
        #: the friction law of every contact interaction by name (``"surface"`` or ``"centreline"``),
        #: whether or not the run came from a configuration file
        self._friction_models = {inter.name: str(inter.friction_model) for inter in sim.stepper.interactions
                                 if inter.friction_model is not None}
        self._t_start = float(sim.state.time)
        self._wall0 = _time.perf_counter()
        self._flushed = len(sim.rows)
        self._last_flush = _time.perf_counter()
        self._last_checkpoint = self._last_flush
        if self.config is not None:
            self._write_run_file()
        self._log_fh = open(self.dir / LOG_SIDE_FILE, "w", encoding="utf-8")
        t0 = _time.perf_counter()
        write_json(self.dir / "run.json", self._info("running"))
        self._info_written = _time.perf_counter()  # run.json: when last written and what it cost (s)
        self._info_cost = self._info_written - t0

    def _info(self, outcome: str) -> dict:
        rows = self.sim.rows[self._rows_start:] if self._rows_start else self.sim.rows
        return {
            "knotsim_version": __version__,
            "git_commit": self._commit,
            "outcome": outcome,
            "stopped": getattr(self.sim, "stopped", None),  # why it ended before its duration (a decided protocol)
            "wall_time_s": _time.perf_counter() - self._wall0,
            "simulated_time_s": float(self.sim.state.time - self._t_start),
            "steps": int(len(self.sim.rows)),
            "newton_iterations": int(sum(r["iterations"] for r in rows)),
            "step_failures": int(self.sim.n_failures),
            "started": self.started,
            "python": platform.python_version(),
            "machine": platform.machine(),
            "n_rods": int(self.model.n_rods),
            "n_nodes": int(self.model.n_nodes),
            "friction_models": self._friction_models,
            "config": self.config,
        }

    def flush_log(self, force: bool = False) -> None:
        """Append the new log rows to ``log.jsonl`` and refresh ``run.json`` when
        ``LOG_FLUSH_STEPS`` rows are waiting or ``LOG_FLUSH_SECONDS`` s have passed (always with
        ``force``)."""
        rows = self.sim.rows
        waiting = len(rows) - self._flushed
        now = _time.perf_counter()
        if waiting <= 0 or not (force or waiting >= LOG_FLUSH_STEPS or now - self._last_flush >= LOG_FLUSH_SECONDS):
            return
        self._log_fh.write("".join(json.dumps(json_safe(r)) + "\n" for r in rows[self._flushed:]))
        self._log_fh.flush()
        self._flushed = len(rows)
        self._last_flush = now
        if force or now - self._info_written >= max(LOG_FLUSH_SECONDS, 20.0 * self._info_cost):
            write_json(self.dir / "run.json", self._info("running"))
            self._info_written = _time.perf_counter()
            self._info_cost = self._info_written - now

    def frame(self, sim) -> None:
        st = sim.state
        q = st.q
        self.writer.append(st.time, self.model.node_positions(q), self.model.edge_angles(q),
                           {"velocities": self.model.node_positions(st.v), "reference_directors": st.d1,
                            "reference_twist": st.ref_twist,
                            **frame_fields(self.model, q, self.sim.stepper.interactions)})
        self._last_time = sim.state.time
        if self.interval:
            self._next = sim.state.time + self.interval

    def maybe_frame(self, sim) -> None:
        if self.interval is None or sim.state.time >= self._next - 1e-9 * self.interval:
            self.frame(sim)
        self.flush_log()
        now = _time.perf_counter()
        if now - self._last_checkpoint >= CHECKPOINT_SECONDS:
            self.sim.save_checkpoint(self.dir / "checkpoint.npz")
            self._last_checkpoint = now

    def close(self, outcome: str, wall_time: float, t_start: float) -> None:
        # the final state is always a frame, whatever the output interval
        if self._last_time is None or self.sim.state.time > self._last_time:
            self.frame(self.sim)
        self.writer.close()
        self.flush_log(force=True)
        self._log_fh.close()
        log = self.sim.log()
        log.to_parquet(self.dir / "log.parquet", index=False)
        (self.dir / LOG_SIDE_FILE).unlink(missing_ok=True)  # compacted into log.parquet
        info = self._info(outcome)
        info["wall_time_s"] = wall_time
        info["simulated_time_s"] = float(self.sim.state.time - t_start)
        info["newton_iterations"] = int(log["iterations"].sum()) if len(log) else 0
        info["validity"] = self.sim.validity.report(self.sim.state.memory.validity)
        info["warnings"] = list(info["validity"]["warnings"])
        self.sim.save_checkpoint(self.dir / "checkpoint.npz")
        if self.config is not None:
            self._write_run_file()
        write_json(self.dir / "run.json", info)

    def _write_run_file(self) -> None:
        write_toml(self.dir / "run.toml", self.config,
                   header=f"knotsim {__version__} run file, replayed by: knotsim run run.toml -o OUT")
