"""The pipeline that runs a loading protocol (:class:`~knotsim.protocols.base.LoadingProtocol`,
found by name in :mod:`knotsim.protocols.registry`). :func:`run_protocol` is the whole pipeline:

1. resolve the parameters: the protocol defaults, then the knot drawing's defaults (``radius``,
   ``length``, ``n_nodes``) unless the protocol fixes them, then ``quick`` settings, then the user
   ``overrides`` (dotted keys, see :mod:`knotsim.protocols.params`);
2. the starting geometry from a library knot or any other source
   (:mod:`knotsim.protocols.geometry`: node files, ``.mat``, an earlier run's directory); the rest
   shape is straight and untwisted (only the initial shape is knotted);
3. the run description (:class:`~knotsim.runspec.RunSpec`): rods, the protocol's boundary conditions,
   contact, solver, duration; it is written to ``run.toml`` (and, on request, anywhere else), and
   ``knotsim run`` replays it to the same final positions;
4. identify the knot type at the start (:func:`knotsim.knots.topology.analyze`);
5. run it through :func:`knotsim.runspec.build_run` (files ``trajectory.h5``, ``log.parquet``,
   ``run.json``, ``run.toml``, ``checkpoint.npz`` in ``out_dir``), adding the protocol's quantities
   to every log row; a failure of the solver is recorded in the summary (``run_status``), not raised;
   While it runs, a protocol that can decide its outcome early (:meth:`LoadingProtocol.decision
   <knotsim.protocols.base.LoadingProtocol.decision>`: the knot ran away, came apart, capsized,
   spilled) is asked every :data:`DECISION_CHECK` s of the load; with ``stop_at_decision`` (where
   the protocol has it) the run ends ``stop_margin`` s after the decision;
6. identify the knot type at the end; a change is reported in ``outcome`` (``"untied"``,
   ``"changed knot type (a -> b)"``); knots outside the table (``"unknown"``) are compared by their
   Alexander polynomial and determinant; a failed topology check is recorded, not raised;
7. compute the metrics and write ``summary.json`` (when ``out_dir`` is given). Every event time in
   the summary is on the log's ``time`` axis (s of run time): the metrics' event tables (``{"time",
   "force", ...}``, each with ``load_stage_time``, s since the measured load began) and the
   protocol's :attr:`~knotsim.protocols.base.LoadingProtocol.event_time_keys`, and ``timeline``:
   the stages (``[{"name", "start", "end"}]``), the events (``[{"name", "label", "time",
   "force"}]``: the set's end, slip onsets, capsize, the decision), ``decision`` (``{"time",
   "outcome", "reason"}`` or ``None``) and ``stopped`` (``{"time", "reason"}`` or ``None``). A
   measurement outside the protocol's own validity rule (e.g. a knot loaded before it was set) is
   named in ``warnings``, flags the ``outcome`` (``"slipped; loaded before it was set"``) and sets
   ``valid`` to false.

Units: SI throughout (m, s, N, Pa, kg/m^3, Pa s).
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from knotsim._util.jsonio import json_safe, write_json
from knotsim.contact.options import ContactOptions
from knotsim.errors import ConfigError
from knotsim.protocols.base import Decision, LoadingProtocol, ProtocolResult, RunContext
from knotsim.protocols.params import COMMON_DEFAULTS, Params, resolve_params, rope_values
from knotsim.protocols.timeline import apply_settle, merge_settle_reactions, pull_start

__all__ = ["DECISION_CHECK", "build_protocol_run", "contact_stats", "on_run_axis", "run_protocol", "timeline",
           "topology_keys"]

#: s of simulated time between two questions to the protocol whether its outcome is decided
DECISION_CHECK = 0.05

#: labels of the metric events on the figure and in ``timeline`` (by metric name, then by criterion)
EVENT_LABELS = {"slow_slip_onset": "slow slip", "capsize_onset": "capsize", "force_drop_onset": "force drop",
                "force_drop": "force drop", "slip_onset": "slip"}
CRITERION_LABELS = {"runaway": "run-away", "drift": "rope through (hold)", "spill": "spilled",
                    "tail draw-in": "tails drawn in"}


def on_run_axis(metrics: dict[str, Any], t0: float, event_keys: tuple[str, ...] = (),
                times: np.ndarray | None = None) -> dict[str, Any]:
    """``metrics`` with every event time moved from the measured load's clock (s since it began,
    as the protocols compute them) to the run's (the log's ``time``): each table with a ``"time"``
    (and ``"detected_at"``) gets ``t0`` added and keeps the load's clock as ``"load_stage_time"``;
    the scalar ``event_keys`` get ``t0`` added. With the log's ``times`` (s), a time within 1e-9 s of
    one of them becomes that time exactly (the sum ``t0 + t`` can differ from it in the last bits)."""
    def shift(t: float) -> float:
        v = float(t) + t0
        if times is not None and len(times):
            k = int(np.argmin(np.abs(times - v)))
            if abs(float(times[k]) - v) <= 1e-9:
                return float(times[k])
        return v

    out: dict[str, Any] = {}
    for key, val in metrics.items():
        if isinstance(val, dict) and isinstance(val.get("time"), int | float) and not isinstance(val["time"], bool):
            ev = dict(val)
            ev["load_stage_time"] = float(val["time"])
            ev["time"] = shift(val["time"])
            if isinstance(val.get("detected_at"), int | float):
                ev["detected_at"] = shift(val["detected_at"])
            out[key] = ev
        elif key in event_keys and isinstance(val, int | float) and not isinstance(val, bool) and math.isfinite(val):
            out[key] = shift(val)
        else:
            out[key] = val
    return out


def _force_at(log: pd.DataFrame, t: float) -> float | None:
    if "F" not in log.columns or not len(log):
        return None
    f = np.asarray(log["F"], float)
    tt = np.asarray(log["time"], float)
    i = int(np.clip(np.searchsorted(tt, t - 1e-9), 0, len(tt) - 1))
    if not np.isfinite(f[i]):  # no force logged then (e.g. the set stage of knot-security)
        return None
    ok = np.isfinite(f)
    v = float(np.interp(t, tt[ok], f[ok]))
    return v if math.isfinite(v) else None


def timeline(proto: LoadingProtocol, ctx: RunContext, metrics: dict[str, Any], log: pd.DataFrame,
             decision: Decision | None, stopped: str | None) -> dict[str, Any]:
    """The run's stages and events on the log's time axis (s), from its metrics already on that axis
    (:func:`on_run_axis`), its ``decision`` and why it ``stopped`` early (module docstring, item 7)."""
    t_end = float(log["time"].iloc[-1]) if len(log) else 0.0
    spans = proto.stages(ctx, t_end)
    stages = [{"name": n, "start": a, "end": b} for n, a, b in spans]
    set_tension = ctx.params.values.get("set_tension")  # on the set ends when the set ends (knot-security)
    events: list[dict[str, Any]] = [{"name": "set_end", "label": "set knot", "time": b,
                                     "force": float(set_tension) if isinstance(set_tension, int | float) else None}
                                    for n, _a, b in spans if n == "set" and b < t_end + 1e-9]
    for key, val in metrics.items():
        if isinstance(val, dict) and isinstance(val.get("time"), int | float):
            label = EVENT_LABELS.get(key, key.replace("_", " "))
            if key == "slip_onset":
                label = CRITERION_LABELS.get(str(val.get("criterion")), label)
            force = val.get("force")
            force = float(force) if isinstance(force, int | float) and math.isfinite(force) else None
            if force is None or "F" not in log.columns:
                force = _force_at(log, float(val["time"]))
            events.append({"name": key, "label": label, "time": float(val["time"]), "force": force})
        elif key in proto.event_time_keys and isinstance(val, int | float) and math.isfinite(val):
            events.append({"name": key.removesuffix("_time"), "label": key.removesuffix("_time").replace("_", " "),
                           "time": float(val), "force": _force_at(log, float(val))})
    dec = None
    if decision is not None:
        dec = {"time": decision.time, "outcome": decision.outcome, "reason": decision.reason}
        events.append({"name": "decision", "label": f"decided: {decision.outcome}", "time": decision.time,
                       "force": _force_at(log, decision.time)})
    stop = None
    if stopped is not None:
        stop = {"time": t_end, "reason": stopped}
        events.append({"name": "stop", "label": "run stopped", "time": t_end, "force": _force_at(log, t_end)})
    events.sort(key=lambda e: e["time"])
    return {"stages": stages, "events": events, "decision": dec, "stopped": stop}


class _Retime:
    """Goes on with a running simulation as if it had been built with other settings (a phase of the
    protocol decided them, :meth:`LoadingProtocol.phase`): the boundary-condition groups take the
    windows of the run description built with them, the simulation's run description (``run.toml``)
    becomes that one, the context its stage times and parameters, the decision watch its load start
    and end."""

    def __init__(self, build, proto: LoadingProtocol, sim, ctx: RunContext, watch: _DecisionWatch):
        self.build, self.proto, self.sim, self.ctx, self.watch = build, proto, sim, ctx, watch

    def __call__(self, t: float, settings: dict[str, Any]) -> None:
        from knotsim.runspec import check_run

        _, ctx2, spec2, _ = self.build(settings)
        for table in spec2.data["bc"]:
            group = self.sim.bcs.groups.get(table["name"])
            if group is None:
                continue
            start = float(table.get("start", 0.0))
            stop = math.inf if table.get("stop") is None else float(table["stop"])
            if (start, stop) != (group.start, group.stop):
                self.sim.bcs.retime(table["name"], start, stop, now=t)
        raw = check_run(spec2).raw
        old_duration = self.sim.config["run"]["duration"]
        self.sim.config.clear()
        self.sim.config.update(raw)
        # the run stops at its new end (its own stop predicate); its run.toml gets the duration it ran
        self.sim.config["run"]["duration"] = old_duration
        self.watch.plan_end = float(ctx2.t_settle) + float(ctx2.params["duration"])
        self.ctx.t_pre, self.ctx.plan = ctx2.t_pre, ctx2.plan
        self.proto.prepare(self.ctx)  # (the plan's parts that need the model)
        self.ctx.params = ctx2.params
        self.ctx.bc = ctx2.bc
        self.watch.next_check = pull_start(self.ctx)


def _stop_rule(p: Params) -> tuple[bool, float]:
    """``(stop_at_decision, stop_margin)`` of a run (false for protocols without them)."""
    on = p.values.get("stop_at_decision", False)
    if not isinstance(on, bool):
        raise ConfigError("stop_at_decision", f"must be true or false, got {on!r}")
    margin = p.values.get("stop_margin", 1.0)
    if not (isinstance(margin, int | float) and not isinstance(margin, bool) and math.isfinite(margin) and margin >= 0):
        raise ConfigError("stop_margin", f"must be a time >= 0 in s, got {margin!r}")
    return on, float(margin)


class _DecisionWatch:
    """Asks the protocol every :data:`DECISION_CHECK` s of the load whether its outcome is decided
    (from the protocol's own log columns, collected as the run goes), and stops the run ``margin`` s
    after the decision when ``stop_on``."""

    def __init__(self, proto: LoadingProtocol, ctx: RunContext, stop_on: bool, margin: float):
        self.proto, self.ctx, self.stop_on, self.margin = proto, ctx, stop_on, margin
        self.columns: dict[str, list] = {"time": []}
        self.decision: Decision | None = None
        self.next_check = pull_start(ctx)
        self.active = type(proto).decision is not LoadingProtocol.decision
        #: run time (s) at which the run ends as planned when a phase retimed it (``None``: its duration)
        self.plan_end: float | None = None
        self.at_plan_end = False

    def add(self, t: float, row: dict) -> None:
        if not self.active:
            return
        cols = self.columns
        n = len(cols["time"])
        if set(row) != set(cols) - {"time"} and n:
            self.active = False  # rows of changing columns: no early decision for this run
            return
        cols["time"].append(float(t))
        for key, val in row.items():
            cols.setdefault(key, []).append(val)

    def __call__(self, sim) -> str | None:
        t = float(sim.state.time)
        if self.plan_end is not None and t >= self.plan_end - 1e-9 * max(1.0, self.plan_end):
            self.at_plan_end = True
            return "the end of the run as retimed"
        if not self.active:
            return None
        if self.decision is None:
            if t < self.next_check - 1e-12:
                return None
            self.next_check = t + DECISION_CHECK
            self.decision = self.proto.decision(self.ctx, pd.DataFrame(self.columns))
            if self.decision is None:
                return None
        if self.stop_on and t >= self.decision.time + self.margin - 1e-9:
            return (f"the outcome was decided at t = {self.decision.time:.3f} s ({self.decision.reason}); the run "
                    f"went on for stop_margin = {self.margin:g} s and stopped")
        return None


def _topology(curves, closed, pairing) -> dict[str, Any]:
    from knotsim.knots.topology import analyze

    errors = []
    res = None
    for closure in ("radial", "tangent"):
        try:
            res = analyze([np.asarray(c) for c in curves], closed, pairing=pairing, closure=closure)
            break
        except Exception as exc:  # recorded, never raised
            errors.append(f"{closure} closure: {type(exc).__name__}: {exc}")
    if res is None:
        return {"knot_type": None, "error": "; ".join(errors)}
    sig = res.knot_type if res.knot_type != "unknown" else f"unknown (Alexander {res.alexander}, det {res.determinant})"
    jones = None if res.jones is None else " ".join(f"{c:+d}t^{e}" for e, c in sorted(res.jones.items()) if c)
    lk = int(sum(res.linking[i, j] for i in range(res.n_components) for j in range(i + 1, res.n_components)))
    if res.n_components > 1:  # a link: its components' own knot types and the total linking number
        sig = f"{res.knot_type} ({' + '.join(res.component_types)}; lk {lk})"
    return {"knot_type": res.knot_type, "signature": sig, "rolfsen": res.rolfsen, "alexander": res.alexander,
            "component_types": list(res.component_types), "linking_number": lk, "jones": jones,
            "determinant": int(res.determinant), "n_crossings_reduced": int(res.n_crossings_reduced),
            "writhe": int(res.writhe), "n_components": int(res.n_components), "closure": closure,
            "closure_errors": errors or None, "error": None}


def topology_keys(proto: LoadingProtocol, ctx: RunContext, start: dict, end: dict) -> tuple[str | None, str | None]:
    """The start and end keys compared for "knot type unchanged" (see :meth:`Protocol.topology_key`).

    When one side is a knot outside the table (``"unknown"``: the simplified diagram was not
    recognised) both sides are compared by their Alexander polynomial and determinant instead, so
    that a failed identification of the same knot is not reported as a change. (These invariants do
    not separate a knot from its mirror image, nor the reef from the granny; the contact model, whose
    penetration is checked, is what keeps a rope from passing through another.)
    """
    k0, k1 = proto.topology_key(ctx, start), proto.topology_key(ctx, end)
    if k0 is None or k1 is None or "unknown" not in (start.get("knot_type"), end.get("knot_type")):
        return k0, k1
    if start.get("alexander") is None or end.get("alexander") is None:
        return k0, k1
    return tuple(f"Alexander {t['alexander']}, det {t['determinant']}" for t in (start, end))


def contact_stats(log: pd.DataFrame) -> dict[str, Any]:
    """Contact statistics of a log: worst penetration (fraction of h), contacts per step, ..."""
    def col(name, fn, default=math.nan):
        if name in log.columns and len(log):
            v = np.asarray(log[name], float)
            v = v[np.isfinite(v)]
            return float(fn(v)) if v.size else default
        return default

    return {
        "worst_penetration_ratio": col("max_penetration_ratio", np.max, 0.0),
        "mean_contacts": col("n_contacts", np.mean),
        "max_contacts": col("n_contacts", np.max),
        "max_contact_force_total": col("contact_force_total", np.max),
        "max_friction_force_total": col("friction_force_total", np.max),
        "max_stiffness": col("k_c", np.max),
        "min_gap": col("min_gap", np.min),
    }


def _geometry_keys(p: Params, geo) -> None:
    p.values["n_nodes"] = int(len(geo.ropes[0]))
    p.values["radius"] = float(geo.radius)
    p.values["length"] = float(geo.length)


def _rope_counts(proto: LoadingProtocol) -> tuple[int, ...]:
    from knotsim.knots.library import load_knot_spec

    return proto.n_ropes if proto.n_ropes is not None else (len(load_knot_spec(proto.default_knot).ropes),)


def _check_fit(proto: LoadingProtocol, geo) -> None:
    """:class:`ConfigError` (field ``protocol``) when ``geo`` has another number of ropes than
    ``proto`` loads, naming the protocols that fit."""
    from knotsim.protocols.geometry import CHOOSE_MATRICES
    from knotsim.protocols.registry import protocols

    want, have = _rope_counts(proto), len(geo.ropes)
    if have in want:
        return
    fits = [p.name for p in protocols().values() if have in _rope_counts(p)]
    ropes = " or ".join(str(n) for n in want) + " rope" + ("s" if want != (1,) else "")
    choose = f"{CHOOSE_MATRICES}, or " if geo.found else ""
    raise ConfigError("protocol", f"{proto.name} loads {ropes}, but found {geo.describe_ropes()}; {choose}"
                                  + (f"use --protocol {' or '.join(fits)}" if fits else "no protocol fits it"))


def build_protocol_run(name: str, knot: str | None = None, *, geometry: str | None = None,
                       overrides: dict | None = None, quick: bool = False):
    """The run description of protocol ``name`` on a library ``knot`` or on ``geometry`` (a node
    file or an earlier run's directory; see :mod:`knotsim.protocols.geometry`).

    Returns ``(protocol, ctx, spec, notes)``: the protocol, its :class:`RunContext`, the complete
    :class:`~knotsim.runspec.RunSpec` and a list of notes for the user (e.g. quick settings that were
    not applied because the geometry fixes the node count)."""
    from knotsim.protocols.geometry import geometry_from_library, geometry_from_source, parse_matrices
    from knotsim.protocols.registry import get_protocol
    from knotsim.rods import RodSpec
    from knotsim.runspec import RunSpec

    proto = get_protocol(name)
    notes: list[str] = []
    defaults = dict(COMMON_DEFAULTS)
    defaults.update(proto.defaults)
    templates = dict(defaults)
    templates.update({"n_nodes": 301, "radius": 1.0, "length": 1.0, "duration": 1.0})
    templates.update({k: 1.0 for k, v in proto.defaults.items() if v is None})  # numeric unless given
    quick_layer = dict(proto.quick) if quick else None
    if geometry is None:
        from knotsim.knots.library import load_knot_spec

        knot = knot or proto.default_knot
        spec = load_knot_spec(knot)
        knot_defaults = {k: v for k, v in spec.defaults.items() if k in ("radius", "length", "n_nodes")
                         and k not in proto.fixed_geometry}
        params = resolve_params(templates, defaults, knot_defaults, quick_layer, overrides)
        if parse_matrices(params["geometry_matrices"]):
            raise ConfigError("geometry_matrices", f"names the matrices of a --geometry .mat file; {knot!r} is a "
                                                   "library knot")
        geo = geometry_from_library(knot, n_nodes=params["n_nodes"], radius=params["radius"],
                                    length=params["length"], post_radius=params["post_radius"])
    else:
        for key in ("n_nodes", "length"):
            if quick_layer and key in quick_layer:
                notes.append(f"--quick: {key} = {quick_layer.pop(key)} not applied (the geometry fixes {key})")
            if overrides and key in overrides:
                raise ConfigError(key, f"the geometry {geometry!r} fixes {key}; it cannot be set")
        from knotsim.io.geometry import is_run_directory
        from knotsim.protocols.geometry import run_material

        if is_run_directory(geometry) and quick_layer:
            # an earlier run's rope is settled and moving: holding its ends still, or starting the
            # pull from rest, would jolt it (its pulled end keeps its speed)
            for key in ("settle_time", "ramp_time"):
                if key in quick_layer:
                    notes.append(f"--quick: {key} = {quick_layer.pop(key)} not applied (the run's rope goes on as it "
                                 "was moving)")
        # an earlier run's rope keeps its material unless overridden (it is the same rope)
        material = run_material(geometry) if is_run_directory(geometry) else {}
        for key, value in material.items():
            if not overrides or key not in overrides:
                notes.append(f"--geometry: {key} = {value} from the run (--set {key}=... to change)")
        params = resolve_params(templates, defaults, material, quick_layer, overrides)
        scale = float(params["geometry_scale"])
        if not (scale > 0 and math.isfinite(scale)):
            raise ConfigError("geometry_scale", f"must be a positive factor (file units to m), got {scale!r}")
        matrices = parse_matrices(params["geometry_matrices"])
        if matrices:
            params.values["geometry_matrices"] = ",".join(matrices)
        geo = geometry_from_source(geometry, radius=params["radius"], scale=scale, matrices=matrices)
        if geo.kind == "run" and overrides and "radius" in overrides and overrides["radius"] != geo.radius:
            raise ConfigError("radius", f"the run {geometry!r} was computed with radius {geo.radius} m; "
                                        "continuing it with another radius is not the same rope")
    _check_fit(proto, geo)
    if params["post_radius"] is not None and geo.post is None:
        raise ConfigError("post_radius", f"{geo.name!r} is not tied round a post (only a library hitch or loop is); "
                                         "leave post_radius unset")
    _geometry_keys(params, geo)
    counts = [len(x) for x in geo.ropes]
    if len(set(counts)) > 1:
        notes.append(f"the ropes have {', '.join(f'{a}: {c}' for a, c in zip(geo.rope_names, counts, strict=True))} "
                     f"nodes; the parameter n_nodes gives rope {geo.rope_names[0]}'s")
    p = params
    if p["rope"] and not math.isclose(geo.radius, rope_values(p["rope"])["radius"]) and "radius" not in (overrides or {}):
        raise ConfigError("rope", f"the geometry fixes the radius {geo.radius:g} m, rope {p['rope']!r} has "
                                  f"{rope_values(p['rope'])['radius']:g} m; set the material keys instead")
    mat: dict[str, Any] = {"youngs_modulus": float(p["youngs_modulus"]), "density": float(p["density"]),
                           "poisson_ratio": float(p["poisson_ratio"])}
    for key in ("bending_stiffness", "torsional_stiffness"):  # EI, GJ of a fibrous rope (none: the solid rod's)
        if p[key] is not None:
            mat[key] = float(p[key])
    rods = []
    for r, (x, rname) in enumerate(zip(geo.ropes, geo.rope_names, strict=True)):
        table = {"name": rname, "shape": "points", "positions": np.asarray(x, float).tolist(), "radius": geo.radius,
                 **mat}
        if geo.state:
            for key, val in geo.state[r].items():
                if val is not None:
                    table[key] = np.asarray(val, float).tolist()
        rods.append(table)
    ei = RodSpec(np.asarray(geo.ropes[0], float), radius=geo.radius, **mat).EI  # ctx.EI: F h^2/EI
    ctx = RunContext(params=p, geometry=geo, EI=ei, radius=geo.radius, length=geo.length)
    proto.setup(ctx)
    apply_settle(ctx, p["settle_time"])  # the loading starts after settle_time (protocols/timeline.py)
    duration = p["duration"] if p["duration"] is not None else proto.duration(ctx)
    if not (isinstance(duration, int | float) and duration > 0 and math.isfinite(duration)):
        raise ConfigError("duration", f"must be a positive time in s, got {duration!r}")
    p.values["duration"] = float(duration)  # the protocol's time, after any settling
    duration = ctx.t_settle + float(duration)  # the run's
    contact = {"mu": p["mu"], **p.contact}
    # the friction law that runs is written down (run.toml, run.json, summary.json)
    contact.setdefault("friction_model", str(ContactOptions().friction_model))
    if geo.contact_stiffness is not None and "initial_stiffness" not in contact:
        # continuing a run: its pressed contacts keep their forces (from the floor stiffness they
        # would give way at once; a tied reef pulled at mu = 0.3 failed in its first step)
        contact["initial_stiffness"] = geo.contact_stiffness
    solver = {"dt": float(p["dt"]), **p.solver}
    obstacles = []
    if geo.post is not None:  # the post a hitch or a loop is tied round: fixed (or free to spin), the ropes' friction
        obstacles.append(geo.post.obstacle_table("post", mu=float(p["mu"]), friction_model=contact["friction_model"],
                                                 stick_distance=(contact.get("stick_distance")
                                                                 if geo.post.spin_inertia is None else None)))
    data = {
        "description": f"{proto.name} on {geo.name}",
        "provenance": {"protocol": proto.name, "knot": geo.name, "geometry": geo.source,
                       "parameters": {k: v for k, v in p.as_dict().items() if v is not None}},
        "rods": rods,
        "model": {"gravity": [0.0, 0.0, -float(p["gravity"])], "damping": float(p["damping"])},
        "bc": ctx.bc,
        "contact": contact,
        "solver": solver,
        "run": {"duration": float(duration), "output_interval": float(p["output_interval"])},
    }
    if obstacles:
        data["obstacles"] = obstacles
    return proto, ctx, RunSpec.from_dict(data), notes


def run_protocol(name: str, knot: str | None = None, out_dir=None, overrides: dict | None = None,
                 progress: bool = False, quick: bool = False, geometry: str | None = None,
                 save_config=None, on_start=None) -> ProtocolResult:
    """Run loading protocol ``name`` on ``knot`` (or on ``geometry``) and return its summary and log.

    Parameters
    ----------
    name:
        A registered protocol (:func:`knotsim.protocols.registry.protocols`): ``"overhand-pull"``,
        ``"single-rod-bend"``, ``"two-rope-bend"`` or ``"knot-security"``.
    knot:
        Library knot name or drawing path (default: the protocol's default knot).
    geometry:
        Instead of ``knot``: a node file (text ``x y z [theta]``, ``.csv``, ``.npy``, ``.mat``) or an
        earlier run's output directory (the run continues from its last state).
    out_dir:
        Directory for ``trajectory.h5``, ``log.parquet``, ``run.json``, ``run.toml``,
        ``checkpoint.npz`` and ``summary.json`` (``None``: nothing is written).
    overrides:
        Dotted parameter overrides (``{"mu": 0.3, "contact.delta": 1e-3}``). Unknown keys raise
        :class:`ConfigError`.
    progress:
        Show a progress bar.
    quick:
        Coarse, short settings (the protocol's ``quick`` overrides, applied before ``overrides``).
    save_config:
        Also write the complete run description to this file (``knotsim run FILE`` replays it).
    on_start:
        Called with the checked run (:class:`~knotsim.io.config.RunConfig`) once every input is
        checked, before the simulation is built (the command line prints its notes there, so that
        an input error comes alone, and compiles the kernels of the run's contact settings).

    Returns
    -------
    :class:`ProtocolResult`: the summary entries ``protocol``, ``knot``, ``parameters``,
    ``friction_model`` (``"surface"`` or ``"centreline"``, the law that ran), ``metrics``,
    ``outcome``, ``run_status``, ``topology`` (start/end), ``contact`` (statistics incl.
    ``worst_penetration_ratio``), ``wall_time`` (s), ``sim_time`` (s), ``n_steps``,
    ``failed_attempts``, ``notes``, ... (as attributes and as ``result["outcome"]``) and ``log``,
    the per-step log (a DataFrame, also when nothing is written).
    """
    from knotsim.protocols.metrics import knot_status
    from knotsim.runspec import build_run, check_run, run_simulation

    wall0 = time.perf_counter()
    proto, ctx, spec, notes = build_protocol_run(name, knot, geometry=geometry, overrides=overrides, quick=quick)
    cfg = check_run(spec)
    if on_start is not None:
        on_start(cfg)
    # a stage whose length the run decides (knot-security's set held until the knot is still): the
    # run is built in its longest form and retimed when the phase ends (_Retime)
    phase = proto.phase(ctx)
    if phase is not None:
        proto, ctx, spec, notes = build_protocol_run(name, knot, geometry=geometry, quick=quick,
                                                     overrides={**(overrides or {}), **phase.build_overrides})
        cfg = check_run(spec)
    if save_config is not None and phase is None:
        spec.save(save_config, header=f"knotsim pull: {spec.data['description']}; replay with "
                                      f"knotsim run {Path(save_config).name} -o OUT")
    sim, cfg = build_run(cfg)
    ctx.model = cfg.model
    proto.prepare(ctx)
    geo = ctx.geometry
    p = ctx.params
    topo_start = _topology(*proto.closure(ctx, [np.array(x) for x in geo.ropes]))

    stop_on, margin = _stop_rule(p)
    watch = _DecisionWatch(proto, ctx, stop_on, margin)
    retime = _Retime(lambda extra: build_protocol_run(name, knot, geometry=geometry, quick=quick,
                                                      overrides={**(overrides or {}), **extra}), proto, sim, ctx,
                     watch)

    def callback(s, res):
        reactions = merge_settle_reactions(ctx, res.reactions)
        row = proto.record(ctx, s.state.q, s.state.time, reactions)
        s.rows[-1].update(row)
        watch.add(s.state.time, row)
        if phase is not None and not phase.done:
            decided = phase.observe(float(s.state.time), row)
            if decided is not None:
                retime(float(s.state.time), {**phase.build_overrides, **decided})

    out = Path(out_dir) if out_dir is not None else None
    ran = run_simulation(sim, cfg.duration, out, output_interval=cfg.output_interval, progress=progress,
                         callback=callback, stop=watch)
    run_status = ran.status
    log = ran.log
    stopped = None if watch.at_plan_end else ran.stopped  # the end of a retimed run is no early stop
    p = ctx.params  # (a phase may have decided some: the parameters the run ran with)
    if phase is not None:
        notes = [*notes, *phase.notes]
        ctx.phase_record = phase.record
        if save_config is not None:
            from knotsim.runspec import RunSpec

            RunSpec.from_dict(sim.config).save(save_config, header=f"knotsim pull: {sim.config['description']}; "
                                                                   f"replay with knotsim run {Path(save_config).name} -o OUT")
    model = cfg.model
    curves = [model.rod_positions(sim.state.q, r) for r in range(model.n_rods)]
    topo_end = _topology(*proto.closure(ctx, curves))
    ctx.topology_end = topo_end
    metrics = proto.metrics(ctx, log) if len(log) else {}
    notes = [*notes, *proto.notes(ctx, metrics)]
    warnings = proto.warnings(ctx, metrics) if len(log) else []
    verdict = proto.verdict(ctx, metrics) if len(log) else "undecided"
    # the decision as the whole log gives it (the same rule the run was watched with)
    decision = proto.decision(ctx, log) if len(log) and watch.active else None
    if stopped is not None and decision is None:  # cannot happen with a consistent rule; said if it does
        notes.append(f"the run was stopped at a decision the complete log does not confirm ({watch.decision})")
    status = knot_status(*topology_keys(proto, ctx, topo_start, topo_end), verdict=verdict)
    if status == "changed knot type":
        outcome = f"changed knot type ({topo_start['signature']} -> {topo_end['signature']})"
    elif status == "unknown":
        which = "start" if topo_start["knot_type"] is None else "end"
        err = (topo_start if which == "start" else topo_end)["error"]
        outcome = f"topology check failed at the {which}: {err}"
    else:
        outcome = status
    for flag, _text in warnings:
        outcome = f"{outcome}; {flag}"
    if run_status != "completed":
        outcome = f"{outcome}; simulation stopped early"
    t0 = pull_start(ctx)
    metrics = on_run_axis(metrics, t0, proto.event_time_keys, np.asarray(log["time"], float) if len(log) else None)
    from knotsim._version import __version__

    summary = {
        "protocol": proto.name,
        "knot": geo.name,
        "knot_kind": geo.kind,
        "geometry": geo.source,
        "parameters": p.as_dict(),
        "friction_model": str(spec.data["contact"]["friction_model"]),
        "EI": ctx.EI,
        "valid": not warnings,
        "warnings": [text for _flag, text in warnings],
        "metrics": metrics,
        "outcome": outcome,
        "knot_status": status,
        "run_status": run_status,
        "timeline": timeline(proto, ctx, metrics, log, decision, stopped),
        "topology": {"start": topo_start, "end": topo_end},
        "contact": contact_stats(log),
        "wall_time": time.perf_counter() - wall0,
        "sim_time": ran.sim_time,
        "n_steps": ran.n_steps,
        "newton_iterations": ran.newton_iterations,
        "failed_attempts": ran.failed_attempts,
        "notes": notes,
        "knotsim_version": __version__,
        "out_dir": str(out) if out is not None else None,
    }
    summary = json_safe(summary)
    if out is not None:
        write_json(out / "summary.json", summary)
    return ProtocolResult(summary, log=log)
