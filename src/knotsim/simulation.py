"""High-level driver: adaptive time stepping, logging, output files.

>>> sim = Simulation(model, bcs, SolverOptions(dt=1e-3))
>>> log = sim.run(duration=2.0)            # pandas DataFrame, one row per step
"""

from __future__ import annotations

import math
import time as _time
from collections import Counter
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from knotsim._util.validate import number
from knotsim.errors import ConfigError, SimulationError, ValidityError
from knotsim.solver.diagnosis import STALL_ATTEMPTS, STALL_FRACTION, failure_place, stall_message
from knotsim.solver.options import SolverOptions
from knotsim.solver.state import DriverMemory, RunMemory, State, initial_state
from knotsim.solver.steplog import StepLog
from knotsim.solver.stepper import StepFailure, Stepper, StepResult
from knotsim.solver.validity import ValidityMonitor

if TYPE_CHECKING:
    import pandas as pd


class Simulation:
    """A model, its boundary conditions and interactions, advanced in time.

    Parameters
    ----------
    model: :class:`~knotsim.rods.Model`.
    bcs: :class:`~knotsim.bc.BoundaryConditions` or ``None``.
    options: :class:`~knotsim.solver.options.SolverOptions` (``dt`` is the target step, s).
    interactions: contact/friction terms (see :class:`~knotsim.solver.stepper.Interaction`).
    state: initial :class:`~knotsim.solver.state.State` (default: from the rod specs).
    config: the run description (a plain dict with the tables of a run file) this simulation was
        built from, written to ``run.toml`` and ``run.json`` with the output; ``None`` (built in
        Python): no ``run.toml``. :func:`knotsim.runspec.build_simulation` passes it.
    stages: ``[(name, t_start, t_end), ...]`` (s): the stages of the run description; each log row
        names the stage its step belongs to (column ``stage``).
    """

    def __init__(self, model, bcs=None, options: SolverOptions | None = None, interactions=(),
                 state: State | None = None, *, config: dict | None = None,
                 stages: Sequence[tuple[str, float, float]] = ()):
        self.model = model
        self.bcs = bcs
        self.options = options or SolverOptions()
        own = bcs.interactions() if bcs is not None else []  # spring grips, feedback logs
        self.stepper = Stepper(model, [*interactions, *(i for i in own if all(i is not j for j in interactions))],
                               self.options)
        self.state = state.copy() if state is not None else initial_state(model)
        #: the validity guards (:mod:`knotsim.solver.validity`), checked on every converged step
        self.validity = ValidityMonitor(model, self.options.max_axial_strain, self.options.max_energy_gain,
                                        self.stepper.force_tol, self.stepper.interactions)
        # the run's memory starts afresh (a state handed over from another run brings its rods only);
        # the interactions and the boundary-condition groups bring the memory they hold (e.g. a
        # contact stiffness or a grip's anchor from an earlier stage)
        self.state.memory = RunMemory(driver=DriverMemory(dt=self.options.dt),
                                      interactions={i.name: i.memory for i in self.stepper.interactions
                                                    if i.memory is not None},
                                      bc=bcs.memory() if bcs is not None else {})
        self.dt_min = self.options.dt_min or self.options.dt / 1024.0
        #: consecutive step attempts with the step below ``dt / STALL_FRACTION`` after which the run
        #: stops with a diagnosis (:data:`knotsim.solver.diagnosis.STALL_ATTEMPTS`; see :meth:`step`)
        self.stall_attempts: int = STALL_ATTEMPTS
        #: the places the failures of the current collapsed stretch named, and its last failure
        self._stall_places: Counter = Counter()
        self._stall_last = ""
        #: the state just before a final step that was shortened to land on the requested end time
        #: (its run memory a snapshot; see :meth:`resume_point`), else ``None``
        self._before_short_step: State | None = None
        #: end time (s) a restored checkpoint's run was asked to reach (see :meth:`run`)
        self._continue_end: float | None = None
        #: the running sum of steps before it was set to the requested end time (see :meth:`advance`)
        self._unsnapped_time: float | None = None
        #: the per-step log: one dict per accepted step (a :class:`~knotsim.solver.steplog.StepLog`,
        #: packed by columns; the newest rows are live dicts)
        self.rows: StepLog = StepLog()
        self._row_keys: dict = {}
        #: the run description (``run.toml``), or ``None``
        self.config: dict | None = config
        #: ``[(name, t_start, t_end), ...]`` (s): stages of the run description; each log row names
        #: the stage its step belongs to (column ``stage``).
        self.stages: list[tuple[str, float, float]] = list(stages)
        #: why the last :meth:`run` or :meth:`advance` stopped before its end time (what its ``stop``
        #: predicate returned), or ``None`` when it ran to the end
        self.stopped: str | None = None

    @property
    def dt(self) -> float:
        """The current step size (s) of the adaptive step policy (``state.memory.driver``)."""
        return self.state.memory.driver.dt

    @dt.setter
    def dt(self, value: float) -> None:
        self.state.memory.driver.dt = float(value)

    @property
    def n_failures(self) -> int:
        """Failed step attempts so far (retried with a halved step)."""
        return self.state.memory.driver.n_failures

    # ------------------------------------------------------------------ stepping
    def step(self) -> StepResult:
        """One accepted step of (at most) the current step size, retrying with halved steps.

        A step that cannot be taken above ``dt_min`` stops the run with a
        :class:`~knotsim.errors.SimulationError`; so does a step that stays collapsed: after
        :attr:`stall_attempts` consecutive attempts (accepted or failed) with the step below
        ``dt / STALL_FRACTION`` (:mod:`knotsim.solver.diagnosis`), the error says since when,
        where the failures were and what the interactions report (docs/troubleshooting.md)."""
        return self._advance_one(math.inf)

    def _watch_stall(self, d) -> None:
        """Count an attempt made with the policy's step ``d.dt`` into the collapsed stretch (or end
        the stretch); raise the stall's :class:`~knotsim.errors.SimulationError` at its limit."""
        if not d.dt < self.options.dt / STALL_FRACTION:
            if d.collapsed_attempts:
                d.collapsed_attempts = d.collapsed_failures = 0
                d.collapsed_since, d.collapsed_since_step = math.nan, -1
                self._stall_places.clear()
                self._stall_last = ""
            return
        if d.collapsed_attempts == 0:
            d.collapsed_since, d.collapsed_since_step = self.state.time, d.steps
        if d.collapsed_attempts >= self.stall_attempts:
            hints = []
            for inter in self.stepper.interactions:
                hint = getattr(inter, "stall_hint", None)
                text = hint(d.dt) if callable(hint) else ""
                if text:
                    hints.append(text)
            raise SimulationError(
                stall_message(attempts=d.collapsed_attempts, failures=d.collapsed_failures,
                              since=d.collapsed_since, since_step=d.collapsed_since_step, time=self.state.time,
                              steps=d.steps, dt=d.dt, dt_target=self.options.dt, places=self._stall_places,
                              last_failure=self._stall_last, hints=hints),
                last_good_state=self.state.copy(), time=self.state.time)
        d.collapsed_attempts += 1

    def _advance_one(self, t_end: float) -> StepResult:
        attempts = 0
        d = self.state.memory.driver  # (shared by the trial states: the policy's memory)
        while True:
            if d.dt > self.options.dt and self._stage_change_within(self.state.time, self.state.time + d.dt):
                d.dt, d.easy = self.options.dt, 0  # a stage begins or ends: back to the target step
            h = min(d.dt, t_end - self.state.time)
            if abs(h - d.dt) <= 1e-9 * d.dt:
                h = d.dt  # the last step ends within round-off of t_end: take the full step
            shortened = h < d.dt
            if shortened and attempts == 0:
                before = self.state.copy()
                before.memory = self.state.memory.snapshot()
                self._before_short_step = before
            self._watch_stall(d)  # (after the snapshot: a continued run counts this attempt itself)
            trial = self.state.copy()
            attempts += 1
            try:
                # retries of a failed step use full Newton; the steps after it return to the default
                res = self.stepper.step(self.state, trial, self.bcs, h,
                                        full_newton=attempts > 1 or d.retry_cooldown > 0)
            except StepFailure as exc:
                d.n_failures += 1
                if d.collapsed_attempts:
                    d.collapsed_failures += 1
                    self._stall_last = str(exc)
                    self._stall_places[failure_place(self._stall_last) or "(no place named)"] += 1
                d.dt = h / 2.0
                d.easy = 0
                if d.dt < self.dt_min:
                    raise SimulationError(
                        f"time step fell below dt_min={self.dt_min:.3g} s at t={self.state.time:.6g} s: {exc}. "
                        "The last good state is attached (exception.last_good_state); try a smaller dt, "
                        "softer contact, or check the boundary conditions",
                        last_good_state=self.state.copy(), time=self.state.time) from exc
                continue
            try:
                self.validity.check(trial, res)
            except ValidityError as exc:
                exc.last_good_state, exc.time = self.state.copy(), self.state.time
                raise
            before, self.state = self.state, trial
            d.steps += 1
            if not shortened:
                self._before_short_step = None
            res.attempts = attempts
            d.retry_cooldown = self.options.grow_after if attempts > 1 else max(0, d.retry_cooldown - 1)
            if res.iterations <= self.options.easy_iterations:
                d.easy += 1
            else:
                d.easy = 0
            self._next_step_size(d, h, before, trial)
            self.rows.append(self._row(res))
            return res

    def _stage_change_within(self, t0: float, t1: float) -> bool:
        """Whether a boundary-condition group starts or stops in ``(t0, t1]`` (s)."""
        if self.bcs is None:
            return False
        return any(t0 < g.start <= t1 or t0 < g.stop <= t1 for g in self.bcs.groups.values())

    def _next_step_size(self, d, h: float, before: State, accepted: State) -> None:
        """The step policy after an accepted step of ``h`` s (``d``: its memory): back towards the target
        ``dt`` after ``grow_after`` easy steps; beyond it, up to ``dt_max``, while the local error
        estimate ``h/2 max |Δv|`` stays within ``error_tol`` (and back towards ``dt`` when it exceeds
        4 ``error_tol`` or a step is not easy); see :class:`~knotsim.solver.options.SolverOptions`."""
        opt = self.options
        dt_max = opt.dt_max if opt.dt_max is not None else opt.dt
        if dt_max > opt.dt:
            dv = self.model.node_positions(accepted.v) - self.model.node_positions(before.v)
            err = 0.5 * h * float(np.sqrt(np.max(np.einsum("ij,ij->i", dv, dv)))) if dv.size else 0.0
            if d.dt > opt.dt and (err > 4.0 * opt.error_tol or d.easy == 0):
                d.dt = max(opt.dt, 0.5 * d.dt)
                d.easy = 0
                return
        else:
            err = math.inf
        if d.easy >= opt.grow_after and d.dt < opt.dt:
            d.dt = min(2.0 * d.dt, opt.dt)
            d.easy = 0
        elif d.easy >= opt.grow_after and d.dt < dt_max and err <= opt.error_tol:
            d.dt = min(2.0 * d.dt, dt_max)
            d.easy = 0

    def _row(self, res: StepResult) -> dict:
        row = {"time": res.time, "dt": res.dt, "iterations": res.iterations, "residual": res.residual,
               "line_search_cuts": res.line_search_cuts, "attempts": res.attempts}
        keys = self._row_keys  # the column names, made once per energy and reaction name
        for k, v in res.energies.items():
            key = keys.get(k)
            if key is None:
                key = keys[k] = f"energy_{k}"
            row[key] = v
        for name, r in res.reactions.items():
            names = keys.get((name,))
            if names is None:
                names = keys[(name,)] = tuple(f"{name}_{c}" for c in ("fx", "fy", "fz", "moment", "force"))
            if type(r) is np.ndarray and r.dtype == np.float64 and r.shape == (4,):
                row[names[0]], row[names[1]], row[names[2]], row[names[3]] = r.tolist()
                f = r[:3]
                row[names[4]] = math.sqrt(f.dot(f))  # np.linalg.norm(f), the same operations
            else:
                row[names[0]], row[names[1]], row[names[2]], row[names[3]] = (float(x) for x in r)
                row[names[4]] = float(np.linalg.norm(r[:3]))
        row.update(res.interaction_stats)
        if self.stages:
            # a step belongs to the stage whose boundary conditions governed it: the one active at its
            # end time (the rule of BoundaryConditions: start <= t < stop, within 1e-12 s)
            t = res.time
            row["stage"] = next((name for name, t0, t1 in self.stages if t0 - 1e-12 <= t < t1 - 1e-12),
                                self.stages[-1][0])
        return row

    def advance(self, t_end: float, callback: Callable[[Simulation, StepResult], None] | None = None,
                stop: Callable[[Simulation], str | None] | None = None) -> str | None:
        """Step until ``state.time == t_end`` (s).

        ``callback(sim, step_result)`` is called after every accepted step; then ``stop(sim)``, when
        given: a text (why) ends the stepping there, before ``t_end`` (e.g. a protocol whose outcome
        is decided). Returns that text, or ``None`` when the run reached ``t_end``; it is also kept in
        :attr:`stopped`."""
        if not math.isfinite(t_end) or t_end < self.state.time:
            raise ConfigError("t_end", f"must be a finite time >= current time {self.state.time}, got {t_end}")
        self.stopped = None
        eps = 1e-12 * max(1.0, abs(t_end))
        while self.state.time < t_end - eps:
            res = self._advance_one(t_end)
            if self.state.time >= t_end - eps:
                # time is a running sum of steps: land exactly on the requested end time, so that a
                # continued run starts at t_end and its own end time is not off by round-off
                self._unsnapped_time = self.state.time
                self.state.time = t_end
                res.time = t_end
                self.rows[-1]["time"] = t_end
            if callback is not None:
                callback(self, res)
            if stop is not None and self.state.time < t_end - eps:
                why = stop(self)
                if why:
                    self.stopped = str(why)
                    break
        return self.stopped

    def run(self, duration: float, output_dir=None, output_interval: float | None = None,
            progress: bool | None = None, callback=None,
            stop: Callable[[Simulation], str | None] | None = None) -> pd.DataFrame:
        """Run for ``duration`` s; returns the per-step log as a DataFrame.

        ``stop(sim)``, called after every accepted step, may end the run early by returning why (see
        :meth:`advance`; the reason is kept in :attr:`stopped`); the run's files then end there, and
        its ``run.toml`` gives the duration actually run, so that it replays to the same state.

        With ``output_dir`` writes ``trajectory.h5`` (frames every ``output_interval`` s, default
        every step), ``log.parquet`` and ``run.json`` there (see :mod:`knotsim.io.run_output`).
        ``progress``: show a progress bar (default: only when stderr is a terminal).
        """
        number(duration, "duration", above=0.0, must="be a positive time in s")
        t_start_run = self.state.time if self._continue_end is None else self._continue_end
        self._continue_end = None
        t_end = t_start_run + duration
        out = None
        if output_dir is not None:
            from knotsim.io.run_output import RunOutput  # (h5py is loaded only by runs that write files)

            out = RunOutput(output_dir, self, output_interval)
        bar = _progress_bar(duration, progress)
        wall0 = _time.perf_counter()
        outcome = "completed"
        t_start = self.state.time
        try:
            if out is not None:
                out.frame(self)

            def cb(sim, res):
                if out is not None:
                    out.maybe_frame(sim)
                if bar is not None:
                    bar.update(res.dt)
                if callback is not None:
                    callback(sim, res)

            if self.advance(t_end, cb, stop) is not None and out is not None and out.config is not None:
                run_table = out.config.setdefault("run", {})
                if float(run_table.get("duration", duration)) == float(duration):  # a fresh run of this description
                    run_table["duration"] = float(self.state.time - t_start_run)
        except SimulationError as exc:
            outcome = f"failed: {exc}"
            raise
        except KeyboardInterrupt:
            outcome = "interrupted"
            raise
        except Exception as exc:
            outcome = f"failed: {type(exc).__name__}: {exc}"
            raise
        finally:
            if bar is not None:
                bar.close()
            if out is not None:
                out.close(outcome, _time.perf_counter() - wall0, t_start)
        return self.log()

    def log(self) -> pd.DataFrame:
        """Per-step log so far (one row per accepted step)."""
        return self.rows.to_frame()

    # ------------------------------------------------------------------ checkpoints
    def resume_point(self) -> tuple[State, float]:
        """``(state, end_time)`` to continue this run from.

        The current state (with its :class:`~knotsim.solver.state.RunMemory`), unless the last step
        was shortened to land on the requested end time: then the state just before that step, so
        that a continued run takes the same steps as an uninterrupted one (a run of 2T and a run of T
        continued for T end in the same state). ``end_time`` is the time the run reached (s). The
        state keeps the time as the running sum of its steps (before the run landed it exactly on
        ``end_time``), so that time-dependent boundary conditions see the same times in the
        continued run as in an uninterrupted one."""
        if self._before_short_step is not None:
            return self._before_short_step, float(self.state.time)
        state = self.state
        if self._unsnapped_time is not None and abs(self._unsnapped_time - state.time) < 1e-9:
            state = state.copy()
            state.time = self._unsnapped_time
        return state, float(self.state.time)

    def save_checkpoint(self, path) -> None:
        """Write everything that decides the next step to ``path`` (see :mod:`knotsim.io.checkpoint`)."""
        from knotsim.io.checkpoint import write_checkpoint

        write_checkpoint(path, self)

    def restore(self, checkpoint, *, boundary_conditions: bool = True) -> None:
        """Continue from ``checkpoint`` (a :class:`~knotsim.io.checkpoint.Checkpoint` or a path).

        The state and its run memory (the stepper's, the adaptive step's, the validity guards', the
        interactions' and, with ``boundary_conditions``, the boundary-condition groups' that exist in
        both: their anchors, pivots, path starts and load-cell controllers) are restored
        (``boundary_conditions=False`` when the continuation brings new boundary conditions: they
        capture their anchors afresh when they act)."""
        from knotsim.io.checkpoint import Checkpoint, check_layout, read_checkpoint

        if not isinstance(checkpoint, Checkpoint):
            checkpoint = read_checkpoint(checkpoint)
        check_layout(checkpoint, self.model)
        self.state = checkpoint.state(self.state.memory)
        for inter in self.stepper.interactions:  # (they would take it at the next step: now, to be seen at once)
            mem = self.state.memory.interactions.get(inter.name)
            if mem is not None and mem is not inter.memory:
                inter.use_memory(mem)
        self._continue_end = checkpoint.end_time
        if self.bcs is not None:
            if boundary_conditions:
                self.bcs.use_memory(self.state.memory.bc)
            self.state.memory.bc = self.bcs.memory()  # the memories the groups took (or kept)


def _progress_bar(total: float, progress: bool | None):
    import sys

    if progress is None:
        progress = sys.stderr.isatty()
    if not progress:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, unit="s(sim)", bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]")
