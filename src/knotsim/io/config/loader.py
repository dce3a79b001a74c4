"""Reading a whole run file: ``load_config`` checks every table and returns a :class:`RunConfig`.

Top-level tables: ``[[rods]]`` (required), ``[model]``, ``[[bc]]``, ``[contact]``, ``[[obstacles]]``, ``[solver]``,
``[run]`` (``duration`` required unless ``[[stages]]`` give it), ``[[stages]]``, and the optional
``description`` string and ``[provenance]`` table (free-form, recorded, never read: who wrote the
file and from what, e.g. the protocol and parameters of ``knotsim pull --save-config``).

``[[stages]]`` chain phases of one run (tie, relax, pre-tighten, pull): each has ``name``,
``duration`` (s) and optionally ``bc`` (an array of bc tables as above, whose ``start`` / ``stop``
count from the start of the stage) and ``release`` (names of groups, from earlier stages or the
top-level ``[[bc]]``, that stop acting when the stage starts). Stages run one after the other in one
simulation: one continuous trajectory and log, whose ``stage`` column names the stage of each step.
"""

from __future__ import annotations

import copy
import dataclasses
import os
import typing
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from knotsim._util.fields import as_table, as_vec3, check_keys, error_message, get_field
from knotsim._util.toml import load_toml
from knotsim._util.validate import as_bool, as_integer, as_number, as_string, type_name
from knotsim.bc import BoundaryConditions
from knotsim.errors import ConfigError
from knotsim.io.config.bc import BCSpec, bcs_builder, parse_bc, resolve_releases
from knotsim.io.config.rods import parse_rod
from knotsim.rods import Model
from knotsim.solver.options import SolverOptions

__all__ = ["RunConfig", "contact_interactions", "load_config"]

_TOP_KEYS = ("description", "rods", "model", "bc", "solver", "run", "contact", "stages", "provenance", "obstacles")
_MODEL_KEYS = ("gravity", "damping")
_RUN_KEYS = ("duration", "output_interval")
_STAGE_KEYS = ("name", "duration", "bc", "release")


@dataclass
class RunConfig:
    """A run description, checked and turned into objects.

    - ``model``: the :class:`~knotsim.rods.Model`;
    - ``bcs_builder``: ``bcs_builder(model) -> BoundaryConditions``, a fresh set each call
      (groups capture anchors while running, so each simulation needs its own; see
      :meth:`build_bcs`);
    - ``solver``: :class:`~knotsim.solver.stepper.SolverOptions`;
    - ``duration`` (s) and ``output_interval`` (s between trajectory frames, ``None``: every step);
    - ``raw``: the configuration as a plain dict (written to ``run.toml`` and ``run.json``);
    - ``contact``: the ``[contact]`` table or ``None``;
    - ``base_dir``: directory relative file names are resolved against;
    - ``stages``: ``[(name, t_start, t_end), ...]`` (s) of the ``[[stages]]``, or ``[]``.
    """

    model: Model
    bcs_builder: Callable[[Model], BoundaryConditions]
    solver: SolverOptions
    duration: float
    output_interval: float | None
    raw: dict
    contact: dict | None = None
    base_dir: Path = field(default_factory=Path.cwd)
    stages: list[tuple[str, float, float]] = field(default_factory=list)
    #: ``build(model) -> [Obstacle, ...]`` from the ``[[obstacles]]`` tables, or ``None``
    obstacles_builder: Callable | None = None

    def build_obstacles(self) -> list:
        """Fresh obstacles (:mod:`knotsim.contact.obstacles`) of the ``[[obstacles]]`` tables."""
        return self.obstacles_builder(self.model) if self.obstacles_builder is not None else []

    def build_bcs(self) -> BoundaryConditions:
        """A fresh :class:`~knotsim.bc.BoundaryConditions` for :attr:`model`."""
        return self.bcs_builder(self.model)


def parse_solver(t) -> SolverOptions:
    t = as_table(t, "solver")
    fields = {f.name: f for f in dataclasses.fields(SolverOptions)}
    check_keys(t, "solver", list(fields))
    hints = typing.get_type_hints(SolverOptions)
    kw = {}
    for key, value in t.items():
        hint = hints[key]
        path = f"solver.{key}"
        args = set(typing.get_args(hint)) or {hint}
        if bool in args:
            kw[key] = as_bool(value, path)
        elif int in args:
            kw[key] = as_integer(value, path)
        elif float in args:
            # the validity guards switch off with inf (TOML: max_axial_strain = inf); spin_relaxation_above
            # = inf relaxes only from iteration spin_relaxation_after on
            infinite_ok = key in ("max_axial_strain", "max_energy_gain", "spin_relaxation_above") and value == float("inf")
            kw[key] = float(value) if infinite_ok else as_number(value, path)
        elif str in args:
            kw[key] = as_string(value, path)
        else:  # pragma: no cover - a new field of an unexpected type
            kw[key] = value
    options = SolverOptions(**kw)
    options.validate()
    return options


def contact_interactions(model: Model, table: dict | None) -> list:
    """Interactions (contact, friction) described by a ``[contact]`` table; ``[]`` without one.

    The table is checked by :func:`knotsim.contact.model.contact_from_config` (its keys are the
    fields of :class:`~knotsim.contact.model.ContactOptions`).
    """
    if table is None:
        return []
    from knotsim.contact.model import contact_from_config

    return list(contact_from_config(model, table))


def _parse_stages(raw_stages, n_bc: int) -> tuple[list[BCSpec], list[tuple[str, float, float]], list[tuple]]:
    """Boundary conditions of the ``[[stages]]`` shifted to absolute time, the stage windows, and
    the releases ``(name, at, where)`` they ask for."""
    if not isinstance(raw_stages, list) or not raw_stages:
        raise ConfigError("stages", "expected an array of tables [[stages]] with at least one stage")
    specs: list[BCSpec] = []
    windows: list[tuple[str, float, float]] = []
    releases: list[tuple] = []
    t0 = 0.0
    index = n_bc
    for k, st in enumerate(raw_stages):
        path = f"stages[{k}]"
        st = as_table(st, path)
        check_keys(st, path, _STAGE_KEYS)
        name = get_field(st, "name", path, as_string, f"stage{k}")
        if any(w[0] == name for w in windows):
            raise ConfigError(f"{path}.name", f"duplicate stage name {name!r}")
        dur = get_field(st, "duration", path, as_number, positive=True)
        rel = st.get("release", [])
        if isinstance(rel, str):
            rel = [rel]
        if not isinstance(rel, list):
            raise ConfigError(f"{path}.release", f"expected a list of group names, got {rel!r}")
        for j, r in enumerate(rel):
            releases.append((as_string(r, f"{path}.release[{j}]"), t0, f"{path}.release[{j}]"))
        bcs = st.get("bc", [])
        if not isinstance(bcs, list):
            raise ConfigError(f"{path}.bc", "expected an array of tables [[stages.bc]]")
        for j, t in enumerate(bcs):
            t = copy.deepcopy(as_table(t, f"{path}.bc[{j}]"))
            if t.get("type") == "release":
                raise ConfigError(f"{path}.bc[{j}].type", "inside a stage, list groups to stop under release = [...]")
            for key in ("start", "stop"):
                if key in t:
                    t[key] = as_number(t[key], f"{path}.bc[{j}].{key}") + t0
            t.setdefault("start", t0)
            try:
                spec = parse_bc(t, index)
            except ConfigError as exc:
                fld = exc.field.replace(f"bc[{index}]", f"{path}.bc[{j}]", 1)
                raise ConfigError(fld, error_message(exc)) from None
            specs.append(spec)
            index += 1
        windows.append((name, t0, t0 + dur))
        t0 += dur
    return specs, windows, releases


def _apply_stage_releases(specs: list[BCSpec], releases: list[tuple]) -> None:
    by_name = {s.name: s for s in specs}
    for name, at, where in releases:
        g = by_name.get(name)
        if g is None:
            raise ConfigError(where, f"no boundary condition named {name!r} to release; known: {sorted(by_name)}")
        if g.kwargs["start"] >= at:
            raise ConfigError(where, f"{name!r} starts at {g.kwargs['start']} s, not before this stage ({at} s)")
        stop = g.kwargs.get("stop")
        if stop is None or stop > at:
            g.kwargs["stop"] = at


# ---------------------------------------------------------------------------------------- entry points
def load_config(source, *, base_dir=None, duration: float | None = None) -> RunConfig:
    """Read and check a run description.

    Parameters
    ----------
    source:
        Path of a TOML file, or a dict with the same structure.
    base_dir:
        Directory that relative file names (``rods[i].file``, ``rods[i].run``) are resolved
        against. Default: the TOML file's directory, or the current directory for a dict.
    duration:
        Overrides ``run.duration`` (s); the override is recorded in :attr:`RunConfig.raw`.

    Raises
    ------
    ConfigError
        Naming the full key path of the first bad value.
    """
    if isinstance(source, dict):
        raw = copy.deepcopy(source)
        bdir = Path(base_dir) if base_dir is not None else Path.cwd()
    elif isinstance(source, str | os.PathLike):
        fpath = Path(source)
        raw = load_toml(fpath, "config")
        bdir = Path(base_dir) if base_dir is not None else fpath.resolve().parent
    else:
        raise ConfigError("config", f"expected a TOML file path or a dict, got {type_name(source)}")

    if duration is not None:
        run = raw.setdefault("run", {})
        if isinstance(run, dict):
            run["duration"] = duration

    check_keys(raw, "", _TOP_KEYS)
    if "description" in raw:
        as_string(raw["description"], "description")
    if "provenance" in raw:
        as_table(raw["provenance"], "provenance")

    rods_raw = raw.get("rods")
    if rods_raw is None:
        raise ConfigError("rods", "missing required field: add at least one [[rods]] table")
    if not isinstance(rods_raw, list) or not rods_raw:
        raise ConfigError("rods", "expected an array of tables [[rods]] with at least one rod")
    rods = [parse_rod(t, i, bdir) for i, t in enumerate(rods_raw)]

    mt = as_table(raw.get("model", {}), "model")
    check_keys(mt, "model", _MODEL_KEYS)
    gravity = get_field(mt, "gravity", "model", as_vec3, np.zeros(3))
    damping = get_field(mt, "damping", "model", as_number, 0.0, nonneg=True)
    try:
        model = Model(rods, gravity=gravity, damping=damping)
    except ConfigError as exc:
        fld = exc.field if exc.field.startswith("rods") else f"model.{exc.field}"
        raise ConfigError(fld, error_message(exc)) from None

    bc_raw = raw.get("bc", [])
    if not isinstance(bc_raw, list):
        raise ConfigError("bc", "expected an array of tables [[bc]]")
    specs = [parse_bc(t, i) for i, t in enumerate(bc_raw)]
    windows: list[tuple[str, float, float]] = []
    releases: list[tuple] = []
    if "stages" in raw:
        stage_specs, windows, releases = _parse_stages(raw["stages"], len(bc_raw))
        specs = specs + stage_specs
    specs = resolve_releases(specs)
    _apply_stage_releases(specs, releases)
    builder = bcs_builder(specs)
    builder(model)  # check node ranges, overlaps, path starts now rather than at run time

    solver = parse_solver(raw.get("solver", {}))

    rt = raw.get("run")
    if rt is None and not windows:
        raise ConfigError("run.duration", "missing required field: add a [run] table with duration (s)")
    rt = as_table(rt if rt is not None else {}, "run")
    check_keys(rt, "run", _RUN_KEYS)
    dur = get_field(rt, "duration", "run", as_number, windows[-1][2] if windows else None, positive=True)
    if dur is None:
        raise ConfigError("run.duration", "missing required field: the simulated time in s")
    interval = get_field(rt, "output_interval", "run", as_number, None, positive=True)

    contact = raw.get("contact")
    if contact is not None:
        as_table(contact, "contact")
        from knotsim.contact.options import ContactOptions

        # the friction law that runs is written down (run.toml, run.json), whatever the default is
        contact.setdefault("friction_model", str(ContactOptions.from_table(contact).friction_model))

    obstacles = None
    if "obstacles" in raw:
        from knotsim.io.config.obstacles import obstacles_builder

        obstacles = obstacles_builder(raw["obstacles"])
        obstacles(model)  # check geometry, rods and motions now
        clash = sorted(set(obstacles.names) & {s.name for s in specs})
        if clash:
            raise ConfigError("obstacles", f"obstacle name {clash[0]!r} is also a [[bc]] name (their log columns "
                                           f"would clash); rename one")

    return RunConfig(model=model, bcs_builder=builder, solver=solver, duration=dur, output_interval=interval,
                     raw=raw, contact=contact, base_dir=bdir, stages=windows, obstacles_builder=obstacles)
