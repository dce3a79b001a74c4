"""The run builder: one complete, serialisable run description and one function that turns it into
a simulation. Every entry point goes through it: Python (:func:`build_run`, :func:`run`),
``knotsim run`` files, the loading protocols (``knotsim pull``), study cases and tying sequences
(``knotsim tie``).

>>> spec = RunSpec.load("examples/hanging_rod.toml")       # or RunSpec.from_dict({...})
>>> result = run(spec, "out")                               # trajectory, log, run.toml, checkpoint
>>> later = run(RunSpec.load("out/run.toml"), "out2", duration=1.0, continue_from="out")

:func:`run_simulation` runs a built simulation, catches its failure and summarises its cost
(:class:`RunOutcome`); every entry point runs through it.

A run description is a plain dict with the tables of a run file (``docs/run-files.md``):
``rods``, ``model``, ``bc``, ``contact``, ``solver``, ``run``, ``stages``, ``description``,
``provenance``. :meth:`RunSpec.save` writes it as TOML with every float exact, so the file replays
the run to the last bit; every run directory holds its own ``run.toml``.
"""

from __future__ import annotations

import copy
import dataclasses
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from knotsim._util.toml import load_toml, write_toml
from knotsim.errors import ConfigError, SimulationError

__all__ = ["RunOutcome", "RunResult", "RunSpec", "build_run", "build_simulation", "check_run", "run", "run_line",
           "run_simulation"]

#: rod keys that name files, resolved against the description's directory when it is saved elsewhere
_PATH_KEYS = ("file", "run")


@dataclass
class RunSpec:
    """A complete run description (see the module docstring).

    ``data`` is the plain dict; ``base_dir`` the directory relative file names in it (``rods[i].file``,
    ``rods[i].run``) are resolved against.
    """

    data: dict
    base_dir: Path = field(default_factory=Path.cwd)

    @classmethod
    def load(cls, path: str | os.PathLike) -> RunSpec:
        """Read a run file (TOML)."""
        p = Path(path)
        return cls(load_toml(p, "config"), p.resolve().parent)

    @classmethod
    def from_dict(cls, data: dict, base_dir: str | os.PathLike | None = None) -> RunSpec:
        """A description from a dict (copied)."""
        return cls(copy.deepcopy(data), Path(base_dir) if base_dir is not None else Path.cwd())

    @classmethod
    def coerce(cls, spec: RunSpec | dict | str | os.PathLike) -> RunSpec:
        """``spec`` as a :class:`RunSpec` (a path is loaded, a dict copied)."""
        if isinstance(spec, RunSpec):
            return spec
        if isinstance(spec, dict):
            return cls.from_dict(spec)
        if isinstance(spec, str | os.PathLike):
            return cls.load(spec)
        raise ConfigError("config", f"expected a RunSpec, a dict or a run file path, got {type(spec).__name__}")

    def to_dict(self) -> dict:
        """The description with every relative file name made absolute (valid from any directory)."""
        data = copy.deepcopy(self.data)
        for rod in data.get("rods", []) or []:
            if isinstance(rod, dict):
                for key in _PATH_KEYS:
                    if isinstance(rod.get(key), str) and not Path(rod[key]).expanduser().is_absolute():
                        rod[key] = str((self.base_dir / rod[key]).resolve())
        return data

    def save(self, path: str | os.PathLike, header: str = "") -> Path:
        """Write the description as a TOML run file (floats exact; ``header`` as comment lines)."""
        return write_toml(path, self.to_dict(), header=header)

    def with_changes(self, **tables: Any) -> RunSpec:
        """A copy with top-level tables replaced, e.g. ``spec.with_changes(run={"duration": 2.0})``."""
        data = copy.deepcopy(self.data)
        data.update(copy.deepcopy(tables))
        return RunSpec(data, self.base_dir)


def check_run(spec: RunSpec | dict | str | os.PathLike, *, duration: float | None = None):
    """The checked :class:`~knotsim.io.config.RunConfig` of ``spec``: every table and value
    validated (a :class:`~knotsim.errors.ConfigError` naming the field otherwise), nothing built
    or compiled yet. ``duration`` (s) overrides ``run.duration``."""
    from knotsim.io.config import load_config

    rs = RunSpec.coerce(spec)
    cfg = load_config(rs.data, base_dir=rs.base_dir, duration=duration)
    cfg.raw = RunSpec(cfg.raw, rs.base_dir).to_dict()
    return cfg


def build_simulation(config, *, description: dict | None = None):
    """A :class:`~knotsim.simulation.Simulation` ready to run ``config`` (a checked
    :class:`~knotsim.io.config.RunConfig`, a run file path or a dict): the model, fresh boundary
    conditions, the contact and obstacle interactions, a copy of the solver options, and the run
    description (``description``, default a copy of ``config.raw``; written to ``run.toml`` and
    ``run.json``) and stage windows the simulation carries."""
    from knotsim.io.config import RunConfig, contact_interactions, load_config
    from knotsim.simulation import Simulation

    if not isinstance(config, RunConfig):
        config = load_config(config)
    interactions = contact_interactions(config.model, config.contact) + config.build_obstacles()
    return Simulation(config.model, config.build_bcs(), dataclasses.replace(config.solver),
                      interactions=interactions,
                      config=copy.deepcopy(config.raw) if description is None else description,
                      stages=config.stages)


def build_run(spec, *, duration: float | None = None, continue_from: str | os.PathLike | None = None):
    """A :class:`~knotsim.simulation.Simulation` ready to run ``spec`` (a :class:`RunSpec`, a dict, a
    run file, or a :class:`~knotsim.io.config.RunConfig` from :func:`check_run`), and the checked
    :class:`~knotsim.io.config.RunConfig`: ``(sim, config)``.

    ``duration`` (s) overrides ``run.duration``. ``continue_from`` is an earlier run's output
    directory: the simulation starts from its ``checkpoint.npz`` (state, stepper memory, adaptive
    step, contact state) at the time it stopped. Boundary-condition groups of the same name keep
    their captured anchors when ``spec`` is that run's own description; a new description's groups
    capture theirs when they first act.
    """
    from knotsim.io.checkpoint import read_checkpoint
    from knotsim.io.config import RunConfig

    cfg = spec if isinstance(spec, RunConfig) else check_run(spec, duration=duration)
    description = copy.deepcopy(cfg.raw)
    if continue_from is not None:
        description.setdefault("provenance", {})["continued_from"] = str(Path(continue_from).resolve())
    sim = build_simulation(cfg, description=description)
    if continue_from is None:
        for inter in sim.stepper.interactions:
            inter.check_start(sim.state.q)
    if continue_from is not None:
        d = Path(continue_from)
        ckpt_path = d / "checkpoint.npz"
        if not ckpt_path.is_file():
            raise ConfigError("from", f"{str(d)!r} has no checkpoint.npz to continue from (is it a knotsim run "
                                      "directory written by this version?)")
        ckpt = read_checkpoint(ckpt_path)
        same = (d / "run.toml").is_file() and _same_bcs(load_toml(d / "run.toml"), cfg.raw)
        sim.restore(ckpt, boundary_conditions=same)
    return sim, cfg


def _same_bcs(a: dict, b: dict) -> bool:
    return a.get("bc") == b.get("bc") and a.get("stages") == b.get("stages")


def run_line(n_steps: int, sim_time: float, wall_time: float, failed_attempts: int | None = None,
             newton_iterations: int | None = None) -> str:
    """A run's cost in one line, the numbers always in the same format: ``"2 s in 412 steps (0 step
    failures, 3.41 Newton iterations per step), wall time 12.3 s"`` (the parenthesis when the
    failures are given)."""
    detail = ""
    if failed_attempts is not None:
        ips = newton_iterations / n_steps if n_steps and newton_iterations is not None else 0.0
        detail = f" ({failed_attempts} step failures, {ips:.2f} Newton iterations per step)"
    return f"{sim_time:.4g} s in {n_steps} steps{detail}, wall time {wall_time:.1f} s"


@dataclass
class RunOutcome:
    """How :func:`run_simulation` went: ``status`` (``"completed"`` or ``"failed at t = T s:
    reason"``), the :class:`~knotsim.errors.SimulationError` that stopped it (or ``None``), the
    simulation's per-step ``log``, the simulated time ``sim_time`` (s) and ``wall_time`` (s) of this
    run, the failed step attempts so far, and ``stopped``: why the run ended before its duration
    (what the ``stop`` predicate of :func:`run_simulation` returned), or ``None``."""

    status: str
    error: SimulationError | None
    log: pd.DataFrame
    sim_time: float
    wall_time: float
    failed_attempts: int
    stopped: str | None = None

    @property
    def completed(self) -> bool:
        return self.error is None

    @property
    def n_steps(self) -> int:
        return int(len(self.log))

    @property
    def newton_iterations(self) -> int:
        return int(self.log["iterations"].sum()) if len(self.log) else 0

    def describe(self) -> str:
        """:func:`run_line` of this run."""
        return run_line(self.n_steps, self.sim_time, self.wall_time, self.failed_attempts, self.newton_iterations)


def run_simulation(sim, duration: float, output_dir: str | os.PathLike | None = None, *,
                   output_interval: float | None = None, progress: bool | None = None,
                   callback=None, stop=None) -> RunOutcome:
    """Run ``sim`` (a :class:`~knotsim.simulation.Simulation`) for ``duration`` s, writing its files
    to ``output_dir``; a :class:`~knotsim.errors.SimulationError` stops the run and is caught into
    the outcome (the files are written up to the last accepted step). The one place where a run is
    run, its failure caught and its cost summarised (:func:`run`, the protocols, ``knotsim run``,
    study cases). ``stop(sim)``, called after every accepted step, may end the run early by returning
    why (:meth:`knotsim.simulation.Simulation.run`); the run still counts as completed."""
    import time

    t_start = float(sim.state.time)
    wall0 = time.perf_counter()
    status, error = "completed", None
    try:
        sim.run(duration, output_dir=output_dir, output_interval=output_interval, progress=progress,
                callback=callback, stop=stop)
    except SimulationError as exc:
        status, error = f"failed at t = {sim.state.time:.6g} s: {exc}", exc
    wall = time.perf_counter() - wall0
    return RunOutcome(status, error, sim.log(), float(sim.state.time - t_start), wall, int(sim.n_failures),
                      sim.stopped if error is None else None)


@dataclass
class RunResult:
    """What :func:`run` returns: the per-step ``log``, the final ``state``, the ``simulation``,
    ``status`` (``"completed"`` or ``"failed at t = ... s: ..."``) and the ``output_dir``."""

    log: pd.DataFrame
    state: Any
    simulation: Any
    status: str
    output_dir: Path | None


def run(spec: RunSpec | dict | str | os.PathLike, output_dir: str | os.PathLike | None = None, *,
        duration: float | None = None, continue_from: str | os.PathLike | None = None,
        progress: bool | None = None, callback=None, raise_on_failure: bool = True) -> RunResult:
    """Build and run ``spec`` (see :func:`build_run`); with ``output_dir`` write the run files there.

    A failed run (:class:`~knotsim.errors.SimulationError`) keeps everything it computed: the
    files are written up to the last accepted step (with its checkpoint) and, with
    ``raise_on_failure=False``, the result says ``status = "failed ..."`` instead of raising.
    ``duration`` is the simulated time to add (s; default ``run.duration``)."""
    sim, cfg = build_run(spec, duration=duration, continue_from=continue_from)
    outcome = run_simulation(sim, cfg.duration, output_dir, output_interval=cfg.output_interval, progress=progress,
                             callback=callback)
    if outcome.error is not None and raise_on_failure:
        raise outcome.error
    return RunResult(outcome.log, sim.state, sim, outcome.status, Path(output_dir) if output_dir is not None else None)
