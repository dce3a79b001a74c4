"""Files written by a run: ``trajectory.h5``, ``log.parquet``, ``run.json``, ``run.toml``,
``checkpoint.npz``.

- ``trajectory.h5``: node positions, edge angles, velocities, reference directors and reference
  twist over time (format in ``docs/architecture.md``), appended as the run goes;
- ``log.parquet``: one row per accepted step (time, dt, Newton iterations, residual, energies,
  reaction force of each named boundary-condition group, contact statistics, stage);
- ``run.json``: configuration (when known), knotsim version, wall time, outcome;
- ``run.toml``: the complete run description (when known), which ``knotsim run`` replays;
- ``checkpoint.npz``: everything that decides the next step, at the end of the run (or at the
  last accepted step of a failed one): ``knotsim run --from DIR`` continues from it.
"""

from __future__ import annotations

import platform
import time as _time
from pathlib import Path

import knotsim
from knotsim._util.jsonio import write_json
from knotsim._util.toml import write_toml
from knotsim.io.frame_fields import frame_field_names, frame_fields
from knotsim.io.trajectory import TrajectoryWriter


class RunOutput:
    """Writes a run's files into ``output_dir`` while a :class:`~knotsim.simulation.Simulation`
    advances. ``output_interval`` (s) spaces trajectory frames (``None``: every step)."""

    def __init__(self, output_dir, sim, output_interval: float | None = None, config: dict | None = None):
        self.dir = Path(output_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        m = sim.model
        self.model = m
        self.interval = output_interval
        self.config = config if config is not None else getattr(sim, "config", None)
        self.writer = TrajectoryWriter(self.dir / "trajectory.h5", m.rod_node_start, m.rod_edge_start, m.rod_closed,
                                       m.rod_radius, m.rod_names, flush_every=16, n_bend=int(m.n_bend),
                                       rest_edge_length=m.rest_length,
                                       fields=frame_field_names(sim.stepper.interactions))
        self._next = None
        self._last_time = None
        self._rows_start = len(sim.rows)
        self.sim = sim
        self.started = _time.strftime("%Y-%m-%dT%H:%M:%S%z")

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

    def close(self, outcome: str, wall_time: float, t_start: float) -> None:
        # the final state is always a frame, whatever the output interval
        if self._last_time is None or self.sim.state.time > self._last_time:
            self.frame(self.sim)
        self.writer.close()
        log = self.sim.log()
        log.to_parquet(self.dir / "log.parquet", index=False)
        info = {
            "knotsim_version": knotsim.__version__,
            "outcome": outcome,
            "wall_time_s": wall_time,
            "simulated_time_s": float(self.sim.state.time - t_start),
            "steps": int(len(log)),
            "newton_iterations": int(log["iterations"].sum()) if len(log) else 0,
            "step_failures": int(self.sim.n_failures),
            "started": self.started,
            "python": platform.python_version(),
            "machine": platform.machine(),
            "n_rods": int(self.model.n_rods),
            "n_nodes": int(self.model.n_nodes),
            "config": self.config,
        }
        self.sim.save_checkpoint(self.dir / "checkpoint.npz")
        if self.config is not None:
            write_toml(self.dir / "run.toml", self.config,
                       header=f"knotsim {knotsim.__version__} run file, replayed by: knotsim run run.toml -o OUT")
        write_json(self.dir / "run.json", info)
