"""Executors: how one case of a study is run.

An executor is a function ``executor(config, out_dir, base_dir) -> dict`` that runs one resolved
case configuration, writes its outputs into ``out_dir`` (an existing, empty directory) and returns
a flat dict of metrics (numbers or strings) that becomes the case's row in ``results.parquet``.
It raises on failure (the runner records the error and traceback).

Built in:

- ``"run"``: a plain knotsim run configuration (see :mod:`knotsim.io.config`); writes
  ``trajectory.h5``, ``log.parquet`` and ``run.json``;
- ``"protocol"``: ``{protocol, knot, overrides}``, run by :func:`knotsim.protocols.run_protocol`.

Register more with :func:`register_executor`; the kind of a case is ``"protocol"`` when its
configuration has a ``protocol`` key, otherwise ``"run"``.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable, Mapping
from pathlib import Path

from knotsim.errors import ConfigError

__all__ = ["EXECUTORS", "get_executor", "register_executor", "run_executor", "protocol_executor"]

Executor = Callable[[dict, Path, Path], dict]

EXECUTORS: dict[str, Executor] = {}


def register_executor(kind: str, func: Executor) -> None:
    """Make ``func`` run the cases of kind ``kind`` (replacing any previous one)."""
    EXECUTORS[kind] = func


def get_executor(kind: str) -> Executor:
    """The executor of ``kind``; :class:`ConfigError` if there is none."""
    try:
        return EXECUTORS[kind]
    except KeyError:
        raise ConfigError("kind", f"no executor for cases of kind {kind!r}; known kinds: "
                          f"{', '.join(sorted(EXECUTORS))}") from None


def _num(x) -> float:
    x = float(x)
    return x if math.isfinite(x) else math.nan


def run_executor(config: dict, out_dir: Path, base_dir: Path) -> dict:
    """Run a plain knotsim run configuration into ``out_dir``.

    Metrics: ``steps``, ``newton_iterations`` (total), ``iterations_per_step``, ``step_failures``,
    ``simulated_time`` (s), ``run_wall_time`` (s), and for every prescribed boundary-condition group
    ``<name>`` its final reaction ``<name>_fx``, ``_fy``, ``_fz`` (N), ``<name>_force`` (|F|, N),
    ``<name>_moment`` (N m) and the largest ``<name>_force_max`` (N) over the run; the final
    energies ``energy_*`` (J).
    """
    from knotsim.runspec import RunSpec, build_run, run_simulation

    sim, cfg = build_run(RunSpec.from_dict(config, base_dir=base_dir) if isinstance(config, dict)
                         else RunSpec.coerce(config))
    ran = run_simulation(sim, cfg.duration, out_dir, output_interval=cfg.output_interval, progress=False)
    if ran.error is not None:  # the case fails (the study records it)
        raise ran.error
    log = ran.log
    steps = ran.n_steps
    out = {
        "steps": steps,
        "newton_iterations": ran.newton_iterations,
        "iterations_per_step": _num(log["iterations"].mean()) if steps else math.nan,
        "step_failures": ran.failed_attempts,
        "simulated_time": _num(sim.state.time),
        "run_wall_time": ran.wall_time,
    }
    if steps:
        last = log.iloc[-1]
        for col in log.columns:
            if col.startswith("energy_"):
                out[col] = _num(last[col])
        groups = sim.bcs.groups.values() if sim.bcs is not None else []
        for g in groups:
            if f"{g.name}_fx" not in log.columns:
                continue
            for c in ("fx", "fy", "fz", "force", "moment"):
                out[f"{g.name}_{c}"] = _num(last[f"{g.name}_{c}"])
            out[f"{g.name}_force_max"] = _num(log[f"{g.name}_force"].max())
    return out


_PROTOCOL_KEYS = ("protocol", "knot", "geometry", "overrides", "quick")


def protocol_executor(config: dict, out_dir: Path, base_dir: Path) -> dict:
    """Run a protocol case ``{protocol, knot | geometry, overrides, quick}`` with
    :func:`knotsim.protocols.run_protocol` (which writes its own ``summary.json`` into ``out_dir``).
    ``geometry`` is a node file or an earlier run's directory (e.g. a tied knot), relative to the
    study's folder ``base_dir`` unless absolute.

    Metrics: the entries of the summary's ``metrics`` under their own names (e.g. ``F_norm_mean``,
    dimensionless), then its other scalar entries (``outcome`` renamed ``protocol_outcome``,
    ``wall_time`` renamed ``protocol_wall_time``, s), nested tables flattened as ``a.b``
    (``contact.worst_penetration_ratio``); ``parameters`` and lists stay in ``summary.json``.
    """
    for k in config:
        if k not in _PROTOCOL_KEYS:
            raise ConfigError(k, f"unknown key of a protocol case; allowed keys are {', '.join(_PROTOCOL_KEYS)}")
    name = config["protocol"]
    if not isinstance(name, str):
        raise ConfigError("protocol", f"expected a protocol name, got {name!r}")
    overrides = config.get("overrides", {})
    if not isinstance(overrides, dict):
        raise ConfigError("overrides", f"expected a table, got {overrides!r}")
    try:
        protocols = importlib.import_module("knotsim.protocols")
        run_protocol = protocols.run_protocol
    except (ImportError, AttributeError) as exc:
        raise ConfigError("protocol", f"protocol cases need knotsim.protocols.run_protocol, which is not "
                          f"available in this installation ({exc})") from None
    kwargs = {"out_dir": out_dir, "overrides": dict(overrides)}
    if "knot" in config:
        kwargs["knot"] = config["knot"]
    if "geometry" in config:
        if "knot" in config:
            raise ConfigError("geometry", "a protocol case takes a knot or a geometry, not both")
        geo = config["geometry"]
        if not isinstance(geo, str) or not geo:
            raise ConfigError("geometry", f"expected the path of a node file or run directory, got {geo!r}")
        kwargs["geometry"] = str(Path(geo) if Path(geo).is_absolute() else Path(base_dir) / geo)
    if config.get("quick"):
        kwargs["quick"] = True
    summary = run_protocol(name, **kwargs)
    if not isinstance(summary, Mapping):  # a ProtocolResult (or a plain dict)
        return {}
    out = flatten_metrics(summary.get("metrics") or {})
    rest = {k: v for k, v in summary.items() if k not in _SKIP_SUMMARY}
    for k, v in flatten_metrics(rest).items():
        k = _RENAME.get(k, k)
        out.setdefault(k, v)
    return out


_SKIP_SUMMARY = ("metrics", "parameters", "protocol", "knot", "knotsim_version", "out_dir")
_RENAME = {"outcome": "protocol_outcome", "wall_time": "protocol_wall_time"}


def flatten_metrics(summary: dict, prefix: str = "") -> dict:
    """Flat ``{name: number | str | bool}`` view of a (nested) summary; lists and None are dropped."""
    out: dict = {}
    for k, v in summary.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten_metrics(v, f"{name}."))
        elif isinstance(v, bool | int | float | str):
            out[name] = v
        elif hasattr(v, "item") and getattr(v, "ndim", 0) == 0:
            out[name] = v.item()
    return out


register_executor("run", run_executor)
register_executor("protocol", protocol_executor)
