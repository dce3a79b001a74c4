"""Common machinery of the loading protocols: parameters, overrides, the run, the summary.

A protocol (:class:`Protocol`) knows its published defaults, how to load a library knot (boundary
conditions), what to record at every step and which strength metrics to compute. The common run
(:func:`run_protocol`) is:

1. resolve the parameters: the protocol defaults, then the knot drawing's defaults (``radius``,
   ``length``, ``n_nodes``) unless the protocol fixes them, then ``quick`` settings, then the user
   ``overrides`` (dotted keys, e.g. ``{"mu": 0.3, "contact.delta": 1e-3, "solver.max_iterations": 40}``;
   an unknown key raises :class:`~knotsim.errors.ConfigError` naming it);
2. build the knot (:func:`knotsim.knots.library.get_knot`) and one :class:`~knotsim.rods.RodSpec`
   per rope whose rest shape is straight and untwisted (only the initial shape is knotted);
3. add the protocol's boundary conditions and a :class:`~knotsim.contact.model.ContactInteraction`;
4. identify the knot type at the start (:func:`knotsim.knots.topology.analyze`);
5. run a :class:`~knotsim.simulation.Simulation` (files ``trajectory.h5``, ``log.parquet``,
   ``run.json`` in ``out_dir``), adding the protocol's quantities to every log row; a failure of
   the solver is recorded in the summary (``run_status``), not raised;
6. identify the knot type at the end; a change is reported in ``outcome`` (``"untied"``,
   ``"changed knot type (a -> b)"``); knots outside the table (``"unknown"``) are compared by their
   Alexander polynomial and determinant; a failed topology check is recorded, not raised;
7. compute the metrics and write ``summary.json`` (when ``out_dir`` is given).

Units: SI throughout (m, s, N, Pa, kg/m^3, Pa s).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from knotsim.errors import ConfigError, SimulationError

#: Parameters every protocol accepts (value ``None`` = taken from the knot drawing or computed).
COMMON_DEFAULTS: dict[str, Any] = {
    "n_nodes": None,          # nodes per rope (default: the knot drawing's, 301)
    "radius": None,           # rod radius h, m (default: the knot drawing's)
    "length": None,           # rope length L, m (default: the knot drawing's, 1 m)
    "youngs_modulus": 0.18e6,  # E, Pa
    "density": 1180.0,        # rho, kg/m^3
    "poisson_ratio": 0.5,
    "damping": 0.01,          # viscosity eta, Pa s (force -eta v l_voronoi)
    "gravity": 0.0,           # m/s^2 along -z (0: no gravity)
    "mu": 0.1,                # Coulomb friction coefficient
    "dt": 1e-3,               # target time step, s
    "duration": None,         # simulated time, s (None: the protocol decides)
    "output_interval": 0.1,   # trajectory frame interval, s
}

_CONTACT_KEYS = None
_SOLVER_KEYS = None


def _contact_keys() -> set[str]:
    global _CONTACT_KEYS
    if _CONTACT_KEYS is None:
        from knotsim.contact.model import ContactSettings

        _CONTACT_KEYS = {f.name for f in fields(ContactSettings)} - {"mu"}
    return _CONTACT_KEYS


def _solver_keys() -> set[str]:
    global _SOLVER_KEYS
    if _SOLVER_KEYS is None:
        from knotsim.solver.stepper import SolverSettings

        _SOLVER_KEYS = {f.name for f in fields(SolverSettings)} - {"dt"}
    return _SOLVER_KEYS


def parse_value(text: str) -> Any:
    """Value of a ``--set key=value`` string: int, float, bool (``true``/``false``), ``none``, or
    the string itself."""
    s = text.strip()
    low = s.lower()
    if low in ("true", "yes", "on"):
        return True
    if low in ("false", "no", "off"):
        return False
    if low in ("none", "null"):
        return None
    try:
        return int(s)
    except ValueError:
        pass
    try:
        return float(s)
    except ValueError:
        return s


def parse_assignments(items) -> dict[str, Any]:
    """``["mu=0.3", "contact.delta=1e-3"]`` -> ``{"mu": 0.3, "contact.delta": 0.001}``."""
    out = {}
    for item in items or ():
        if "=" not in item:
            raise ConfigError("set", f"expected key=value, got {item!r}")
        k, v = item.split("=", 1)
        k = k.strip()
        if not k:
            raise ConfigError("set", f"empty key in {item!r}")
        out[k] = parse_value(v)
    return out


def _coerce(key: str, default: Any, value: Any) -> Any:
    """Check ``value`` against the type of ``default`` (numbers stay numbers)."""
    if value is None or default is None:
        return value
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ConfigError(key, f"expected true or false, got {value!r}")
        return value
    if isinstance(default, int | float):
        if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
            raise ConfigError(key, f"expected a number, got {value!r}")
        if isinstance(default, int) and not isinstance(default, bool):
            if float(value) != int(value):
                raise ConfigError(key, f"expected an integer, got {value!r}")
            return int(value)
        return float(value)
    if isinstance(default, str) and not isinstance(value, str):
        raise ConfigError(key, f"expected a string, got {value!r}")
    return value


@dataclass
class Params:
    """Resolved parameters of a run: flat protocol keys plus ``contact`` and ``solver`` tables."""

    values: dict[str, Any]
    contact: dict[str, Any] = field(default_factory=dict)
    solver: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, key: str) -> Any:
        return self.values[key]

    def as_dict(self) -> dict[str, Any]:
        d = dict(self.values)
        d.update({f"contact.{k}": v for k, v in self.contact.items()})
        d.update({f"solver.{k}": v for k, v in self.solver.items()})
        return d


def resolve_params(defaults: Mapping[str, Any], *layers: Mapping[str, Any] | None) -> Params:
    """Apply override layers (dotted keys) on top of ``defaults`` (a flat mapping whose keys may
    include ``contact.*`` / ``solver.*`` entries). Unknown keys raise :class:`ConfigError` naming
    the key and listing the accepted ones."""
    values: dict[str, Any] = {}
    contact: dict[str, Any] = {}
    solver: dict[str, Any] = {}
    for k, v in defaults.items():
        if k.startswith("contact."):
            contact[k[8:]] = v
        elif k.startswith("solver."):
            solver[k[7:]] = v
        else:
            values[k] = v
    for layer in layers:
        for key, val in (layer or {}).items():
            if not isinstance(key, str):
                raise ConfigError(str(key), "override keys must be strings")
            if key in ("contact.mu",):
                key = "mu"
            if key.startswith("contact."):
                sub = key[8:]
                if sub not in _contact_keys():
                    raise ConfigError(key, f"unknown contact setting; known: "
                                           f"{', '.join('contact.' + s for s in sorted(_contact_keys()))}")
                contact[sub] = val
            elif key.startswith("solver."):
                sub = key[7:]
                if sub not in _solver_keys():
                    raise ConfigError(key, f"unknown solver setting; known: "
                                           f"{', '.join('solver.' + s for s in sorted(_solver_keys()))}")
                solver[sub] = val
            elif key in values:
                values[key] = _coerce(key, defaults.get(key), val)
            else:
                raise ConfigError(key, f"unknown parameter; known: {', '.join(sorted(values))}, "
                                       "contact.<setting>, solver.<setting>")
    return Params(values, contact, solver)


@dataclass
class RunContext:
    """Everything a protocol needs while setting up and recording a run."""

    params: Params
    geometry: Any  # KnotGeometry
    model: Any  # Model
    bcs: Any  # BoundaryConditions
    EI: float  # N m^2 (of the first rope)
    radius: float  # m
    length: float  # m
    data: dict[str, Any] = field(default_factory=dict)  # protocol scratch space (axis, groups, ...)


class Protocol:
    """Base class of a loading protocol (subclasses set the class attributes and hooks)."""

    #: Name used by :func:`run_protocol` and the CLI.
    name: str = ""
    #: One-line description.
    description: str = ""
    #: Knot kinds (``KnotSpec.kind``) this protocol is the default for.
    kinds: tuple[str, ...] = ()
    #: Default knot.
    default_knot: str = ""
    #: Protocol-specific defaults (flat, may contain ``contact.*``/``solver.*`` keys), applied on
    #: top of :data:`COMMON_DEFAULTS`.
    defaults: dict[str, Any] = {}
    #: Keys whose protocol default wins over the knot drawing's defaults.
    fixed_geometry: tuple[str, ...] = ()
    #: Overrides applied with ``quick=True`` (coarse, short runs).
    quick: dict[str, Any] = {}

    # -- hooks ---------------------------------------------------------------------------
    def setup(self, ctx: RunContext) -> None:
        """Add boundary conditions to ``ctx.bcs`` (and anything else to ``ctx.data``)."""
        raise NotImplementedError

    def duration(self, ctx: RunContext) -> float:
        """Simulated time, s (used when the ``duration`` parameter is ``None``)."""
        raise NotImplementedError

    def record(self, ctx: RunContext, q: np.ndarray, t: float, reactions: dict) -> dict[str, float]:
        """Protocol quantities of one accepted step (added to the log row)."""
        raise NotImplementedError

    def closure(self, ctx: RunContext, curves: list[np.ndarray]):
        """Curves, ``closed`` flags and closure pairing handed to
        :func:`knotsim.knots.topology.analyze` (default: the open ropes, each closed on itself)."""
        return curves, None, None

    def metrics(self, ctx: RunContext, log: pd.DataFrame) -> dict[str, Any]:
        """Strength metrics of the finished run."""
        raise NotImplementedError

    def slipped(self, ctx: RunContext, metrics: dict) -> bool:
        """Whether the metrics say the knot slipped (used in the outcome)."""
        return False

    def topology_key(self, ctx: RunContext, topo: dict) -> str | None:
        """What must be equal at the start and the end for the knot to count as unchanged (default:
        the knot type with its handedness, ``topo["signature"]``; ``None`` if the check failed)."""
        return topo.get("signature")


_REGISTRY: dict[str, Protocol] = {}


def register(protocol: Protocol) -> Protocol:
    """Add a protocol instance to the registry (by its ``name``)."""
    _REGISTRY[protocol.name] = protocol
    return protocol


def protocols() -> dict[str, Protocol]:
    """Registered protocols by name."""
    from knotsim.protocols import overhand_pull, single_rod_bend, two_rope_bend  # noqa: F401

    return dict(_REGISTRY)


def get_protocol(name: str) -> Protocol:
    """Protocol called ``name``; :class:`ConfigError` listing the known ones otherwise."""
    reg = protocols()
    if name not in reg:
        raise ConfigError("protocol", f"unknown protocol {name!r}; known: {', '.join(sorted(reg))}")
    return reg[name]


def default_protocol(knot: str) -> str:
    """Name of the protocol used for ``knot`` (a library name or a drawing path) from its kind."""
    from knotsim.knots.library import load_knot_spec

    kind = load_knot_spec(knot).kind
    for p in protocols().values():
        if kind in p.kinds:
            return p.name
    raise ConfigError("protocol", f"no default protocol for knot kind {kind!r} of {knot!r}; choose one of "
                                  f"{', '.join(sorted(protocols()))}")


# ------------------------------------------------------------------------------------------
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
    return {"knot_type": res.knot_type, "signature": sig, "rolfsen": res.rolfsen, "alexander": res.alexander,
            "determinant": int(res.determinant), "n_crossings_reduced": int(res.n_crossings_reduced),
            "writhe": int(res.writhe), "n_components": int(res.n_components), "closure": closure,
            "closure_errors": errors or None, "error": None}


def topology_keys(proto: Protocol, ctx: RunContext, start: dict, end: dict) -> tuple[str | None, str | None]:
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


def _json_default(obj):
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    return str(obj)


def _clean(obj):
    """Replace non-finite floats by None (strict JSON)."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_clean(v) for v in obj]
    if isinstance(obj, float | np.floating):
        return float(obj) if math.isfinite(obj) else None
    return obj


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


def run_protocol(name: str, knot: str | None = None, out_dir=None, overrides: dict | None = None,
                 progress: bool = False, quick: bool = False) -> dict:
    """Run loading protocol ``name`` on ``knot`` and return its summary (a JSON-able dict).

    Parameters
    ----------
    name:
        ``"overhand-pull"``, ``"single-rod-bend"`` or ``"two-rope-bend"``.
    knot:
        Library knot name or drawing path (default: the protocol's default knot).
    out_dir:
        Directory for ``trajectory.h5``, ``log.parquet``, ``run.json`` and ``summary.json``
        (``None``: nothing is written).
    overrides:
        Dotted parameter overrides (see :func:`resolve_params`; ``run_protocol(..., overrides=
        {"mu": 0.3})``). Unknown keys raise :class:`ConfigError`.
    progress:
        Show a progress bar.
    quick:
        Coarse, short settings (the protocol's ``quick`` overrides, applied before ``overrides``).

    Returns
    -------
    dict with ``protocol``, ``knot``, ``parameters``, ``metrics``, ``outcome``, ``run_status``,
    ``topology`` (start/end), ``contact`` (statistics incl. ``worst_penetration_ratio``, the
    largest penetration over the run as a fraction of h), ``wall_time`` (s), ``sim_time`` (s),
    ``n_steps``, ``failed_attempts``, and ``log`` is not included (read ``log.parquet``).
    """
    from knotsim.bc import BoundaryConditions
    from knotsim.contact.model import ContactInteraction, ContactSettings
    from knotsim.knots.library import get_knot, load_knot_spec
    from knotsim.rods import Model, RodSpec
    from knotsim.simulation import Simulation
    from knotsim.solver.stepper import SolverSettings

    proto = get_protocol(name)
    knot = knot or proto.default_knot
    spec = load_knot_spec(knot)
    defaults = dict(COMMON_DEFAULTS)
    defaults.update(proto.defaults)
    knot_defaults = {k: v for k, v in spec.defaults.items() if k in ("radius", "length", "n_nodes")
                     and k not in proto.fixed_geometry}
    # type templates for the geometry keys (their common default is None)
    templates = dict(defaults)
    templates.update({"n_nodes": 301, "radius": 1.0, "length": 1.0, "duration": 1.0})
    templates.update({k: 1.0 for k, v in proto.defaults.items() if v is None})  # numeric unless given
    params = resolve_params(templates, defaults, knot_defaults, proto.quick if quick else None, overrides)

    wall0 = time.perf_counter()
    p = params
    geo = get_knot(knot, n_nodes=p["n_nodes"], radius=p["radius"], length=p["length"])
    p.values["n_nodes"] = int(len(geo.ropes[0]))
    p.values["radius"] = float(geo.radius)
    p.values["length"] = float(geo.length)
    rods = [RodSpec(np.array(x, dtype=float), radius=geo.radius, youngs_modulus=float(p["youngs_modulus"]),
                    density=float(p["density"]), poisson_ratio=float(p["poisson_ratio"]), name=rname)
            for x, rname in zip(geo.ropes, geo.rope_names, strict=True)]
    model = Model(rods, gravity=(0.0, 0.0, -float(p["gravity"])), damping=float(p["damping"]))
    bcs = BoundaryConditions(model)
    ctx = RunContext(params=p, geometry=geo, model=model, bcs=bcs, EI=rods[0].EI, radius=geo.radius,
                     length=geo.length)
    proto.setup(ctx)
    csettings = ContactSettings(mu=p["mu"], **p.contact)
    contact = ContactInteraction(model, csettings)
    ssettings = SolverSettings(dt=float(p["dt"]), **p.solver)
    duration = p["duration"] if p["duration"] is not None else proto.duration(ctx)
    p.values["duration"] = float(duration)
    if not duration > 0:
        raise ConfigError("duration", f"must be a positive time in s, got {duration!r}")
    topo_start = _topology(*proto.closure(ctx, [np.array(x) for x in geo.ropes]))

    sim = Simulation(model, bcs, ssettings, interactions=[contact])
    # record the initial state as a first row-free reference for the protocol
    ctx.data["q0"] = sim.state.q.copy()

    def callback(s, res):
        s.rows[-1].update(proto.record(ctx, s.state.q, s.state.time, res.reactions))

    run_status = "completed"
    out = Path(out_dir) if out_dir is not None else None
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    try:
        sim.run(float(duration), output_dir=out, output_interval=float(p["output_interval"]),
                progress=progress, callback=callback)
    except SimulationError as exc:
        run_status = f"failed at t = {sim.state.time:.4g} s: {exc}"
    log = sim.log()
    curves = [model.rod_positions(sim.state.q, r) for r in range(model.n_rods)]
    topo_end = _topology(*proto.closure(ctx, curves))
    metrics = proto.metrics(ctx, log) if len(log) else {}
    slipped = proto.slipped(ctx, metrics)
    from knotsim.protocols.metrics import knot_status

    status = knot_status(*topology_keys(proto, ctx, topo_start, topo_end), slipped)
    if status == "changed knot type":
        outcome = f"changed knot type ({topo_start['signature']} -> {topo_end['signature']})"
    elif status == "unknown":
        which = "start" if topo_start["knot_type"] is None else "end"
        err = (topo_start if which == "start" else topo_end)["error"]
        outcome = f"topology check failed at the {which}: {err}"
    else:
        outcome = status
    if run_status != "completed":
        outcome = f"{outcome}; simulation stopped early"
    wall = time.perf_counter() - wall0
    import knotsim

    summary = {
        "protocol": proto.name,
        "knot": geo.name,
        "knot_kind": geo.kind,
        "parameters": p.as_dict(),
        "EI": ctx.EI,
        "metrics": metrics,
        "outcome": outcome,
        "knot_status": status,
        "run_status": run_status,
        "topology": {"start": topo_start, "end": topo_end},
        "contact": contact_stats(log),
        "wall_time": wall,
        "sim_time": float(sim.state.time),
        "n_steps": int(len(log)),
        "newton_iterations": int(log["iterations"].sum()) if len(log) else 0,
        "failed_attempts": int(sim.n_failures),
        "knotsim_version": knotsim.__version__,
        "out_dir": str(out) if out is not None else None,
    }
    summary = _clean(summary)
    if out is not None:
        (out / "summary.json").write_text(json.dumps(summary, indent=2, default=_json_default), encoding="utf-8")
    return summary


# ------------------------------------------------------------------------------------------ helpers
def stage_duration(distance, speed, distance_field: str, speed_field: str) -> float:
    """Duration (s) of a loading stage that moves ``distance`` (m, ``None`` or 0: no stage) at
    ``speed`` (m/s): ``distance / speed``.

    Raises
    ------
    ConfigError
        Naming ``distance_field`` for a negative or non-finite distance, ``speed_field`` for a
        speed that is not positive.
    """
    d = float(distance or 0.0)
    if d < 0 or not math.isfinite(d):
        raise ConfigError(distance_field, f"must be a distance >= 0 in m, got {d!r}")
    if d == 0:
        return 0.0
    v = float(speed)
    if not v > 0:
        raise ConfigError(speed_field, f"must be a speed > 0 in m/s, got {v!r}")
    return d / v


def end_group_nodes(node: int, n_nodes: int, count: int = 2) -> list[int]:
    """Local node indices of the ``count`` nodes at the end of a rope where ``node`` (0 or N-1) is."""
    if node == 0:
        return list(range(count))
    if node == n_nodes - 1:
        return list(range(-count, 0))
    raise ConfigError("loading", f"node {node} is not an end node of a rope with {n_nodes} nodes")


def unit(v: np.ndarray) -> np.ndarray:
    """``v / |v|``."""
    n = float(np.linalg.norm(v))
    if n == 0.0:
        raise ConfigError("loading", "the pull axis is undefined (coincident end points)")
    return np.asarray(v, float) / n
