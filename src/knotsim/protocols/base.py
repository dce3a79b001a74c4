"""Common machinery of the loading protocols: a protocol is a run description plus metrics.

A protocol (:class:`LoadingProtocol`) knows its published defaults, which boundary conditions load
the knot (as run-file tables), what to record at every step and which strength metrics to compute;
:class:`RunContext` is what its hooks see, :class:`ProtocolResult` what a run returns. The pipeline
that runs a protocol (:func:`~knotsim.protocols.pipeline.run_protocol`) is
:mod:`knotsim.protocols.pipeline`; this module imports neither it, the registry nor any protocol.

Units: SI throughout (m, s, N, Pa, kg/m^3, Pa s).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from knotsim.errors import ConfigError
from knotsim.protocols.params import Params

__all__ = ["SUMMARY_KEYS", "Decision", "LoadingProtocol", "Phase", "ProtocolResult", "RunContext", "end_group_nodes",
           "stage_duration", "unit"]


#: The summary entries of a protocol run, in ``summary.json``'s order (``docs/protocols.md``).
SUMMARY_KEYS = ("protocol", "knot", "knot_kind", "geometry", "parameters", "friction_model", "EI", "valid",
                "warnings", "metrics", "outcome", "knot_status", "run_status", "timeline", "topology", "contact", "wall_time",
                "sim_time", "n_steps", "newton_iterations", "failed_attempts", "notes", "knotsim_version", "out_dir")


class Phase:
    """A stage of a run whose end the run decides (:meth:`LoadingProtocol.phase`).

    ``build_overrides``: the parameters the run is built with while the phase lasts (its longest
    form); :meth:`observe` sees every step (``t`` s of run time, the protocol's log row) and returns
    the parameters it decided once the phase is over (``None`` until then); :attr:`record` (a dict,
    kept in the metrics) and :attr:`notes` say what it found."""

    build_overrides: dict[str, Any] = {}

    def __init__(self) -> None:
        self.record: dict[str, Any] = {}
        self.notes: list[str] = []
        self.done = False

    def observe(self, t: float, row: dict[str, Any]) -> dict[str, Any] | None:
        raise NotImplementedError


@dataclass(frozen=True)
class Decision:
    """A run's outcome decided before its end (:meth:`LoadingProtocol.decision`): ``time`` (s of run
    time, when the evidence was complete), ``outcome`` (``"slipped"``, ``"capsized"``, ``"spilled"``,
    ``"apart"``) and ``reason`` (one line for the user)."""

    time: float
    outcome: str
    reason: str


class ProtocolResult(dict):
    """What :func:`~knotsim.protocols.pipeline.run_protocol` returns: the run's summary and its per-step log.

    A dict of the summary entries (those of ``summary.json``: ``protocol``, ``knot``, ``parameters``,
    ``metrics``, ``outcome``, ``run_status``, ``topology``, ``contact``, ``EI`` in N m^2,
    ``wall_time`` and ``sim_time`` in s, ``n_steps``, ..., see :data:`SUMMARY_KEYS` and
    ``docs/protocols.md``), so ``result["outcome"]``, ``json.dumps(result)`` and item assignment work
    as on the plain dict of earlier versions; the entries are also attributes
    (``result.outcome``, ``result.metrics``). ``log`` is an attribute, not an entry: the per-step log
    (:class:`pandas.DataFrame`, one row per accepted step: ``time`` in s, the reactions of every
    boundary-condition group, contact statistics and the protocol's own columns, e.g. ``F`` in N and
    ``F_norm`` = F h^2/EI), in memory whether or not ``out_dir`` was given (with ``out_dir`` it is
    also ``log.parquet``).
    """

    def __init__(self, summary: Mapping[str, Any] = (), log: pd.DataFrame | None = None):
        super().__init__(summary)
        self.log = log if log is not None else pd.DataFrame()

    @staticmethod
    def summary_keys() -> tuple[str, ...]:
        """Names of the summary entries, in ``summary.json``'s order (:data:`SUMMARY_KEYS`)."""
        return SUMMARY_KEYS

    def __getattr__(self, name: str) -> Any:
        if name in SUMMARY_KEYS and name in self:
            return self[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def __dir__(self):
        return sorted(set(super().__dir__()) | {k for k in SUMMARY_KEYS if k in self})

    def to_dict(self) -> dict[str, Any]:
        """The summary as a plain dict (the content of ``summary.json``), without the log."""
        return dict(self)


@dataclass
class RunContext:
    """Everything a protocol needs while describing and recording a run.

    ``bc`` is the list of boundary-condition tables (run-file form, see ``docs/run-files.md``) the
    protocol's :meth:`LoadingProtocol.setup` appends to; ``model`` is set once the run is built
    (for :meth:`LoadingProtocol.prepare` and :meth:`LoadingProtocol.record`). ``plan`` is the
    protocol's own description of the run (a frozen dataclass of its own: ends, axes, groups, stage
    times), made by :meth:`LoadingProtocol.setup` and completed by :meth:`LoadingProtocol.prepare`
    once the model exists; the stage times the pipeline reads are fields here."""

    params: Params
    geometry: Any  # ProtocolGeometry
    EI: float  # N m^2 (of the first rope)
    radius: float  # m
    length: float  # m
    bc: list[dict] = field(default_factory=list)
    model: Any = None
    #: s of settling before the protocol's loading (:func:`~knotsim.protocols.timeline.apply_settle`)
    t_settle: float = 0.0
    #: the loading groups held still while settling (:func:`~knotsim.protocols.timeline.apply_settle`)
    settle_groups: list[str] = field(default_factory=list)
    #: s of the protocol's own stages before the measured load (pre-pull, cinching, set and relax)
    t_pre: float = 0.0
    #: the protocol's own plan of the run (its dataclass), or ``None``
    plan: Any = None
    #: what a :class:`Phase` of the run found (``Phase.record``), or ``None``
    phase_record: dict[str, Any] | None = None
    #: the topology record at the end of the run (set by the pipeline before the metrics)
    topology_end: dict[str, Any] | None = None

    def add_bc(self, kind: str, name: str, **keys: Any) -> None:
        """Append a boundary condition ``{"type": kind, "name": name, **keys}`` (run-file keys:
        ``rod``, ``nodes`` (local indices), ``velocity``, ``waypoints``, ``force``, ``ramp``, ``start``,
        ``stop``, ``twist``)."""
        table = {"type": kind, "name": name}
        for k, v in keys.items():
            if v is None:
                continue
            table[k] = v.tolist() if isinstance(v, np.ndarray) else v
        self.bc.append(table)


class LoadingProtocol:
    """Base class of a loading protocol (subclasses set the class attributes and hooks)."""

    #: Name used by :func:`~knotsim.protocols.pipeline.run_protocol` and the CLI.
    name: str = ""
    #: One-line description.
    description: str = ""
    #: Knot kinds (``KnotSpec.kind``) this protocol is the default for.
    kinds: tuple[str, ...] = ()
    #: Default knot.
    default_knot: str = ""
    #: Protocol-specific defaults (flat, may contain ``contact.*``/``solver.*`` keys), applied on
    #: top of :data:`~knotsim.protocols.params.COMMON_DEFAULTS`.
    defaults: dict[str, Any] = {}
    #: Keys whose protocol default wins over the knot drawing's defaults.
    fixed_geometry: tuple[str, ...] = ()
    #: Overrides applied with ``quick=True`` (coarse, short runs).
    quick: dict[str, Any] = {}
    #: Numbers of ropes the protocol loads (``None``: as many as its :attr:`default_knot` has).
    n_ropes: tuple[int, ...] | None = None
    #: Scalar metrics that are times of events (s from the start of the measured load, as the metrics
    #: are computed); the summary gives them on the run's time axis. Metric tables with a ``"time"``
    #: entry (slip onsets, ...) are events too and need no listing.
    event_time_keys: tuple[str, ...] = ()
    #: Name of the protocol's own stage before the measured load (``ctx.t_pre`` s), if any.
    pre_stage_name: str = "pre-stage"
    #: Name of the measured stage.
    load_stage_name: str = "pull"

    # -- hooks ---------------------------------------------------------------------------
    def setup(self, ctx: RunContext) -> None:
        """Append the boundary conditions to ``ctx.bc`` (with :meth:`RunContext.add_bc`), set
        ``ctx.t_pre`` (s of the protocol's own stages before the measured load) and put what the other
        hooks need in ``ctx.plan``."""
        raise NotImplementedError

    def prepare(self, ctx: RunContext) -> None:
        """Called once ``ctx.model`` exists, before the run (default: nothing)."""

    def duration(self, ctx: RunContext) -> float:
        """Simulated time, s, after any settling (used when the ``duration`` parameter is ``None``)."""
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

    def phase(self, ctx: RunContext) -> Phase | None:
        """A stage whose length the run decides as it goes (e.g. ``knot-security``'s set, held until
        the knot stops moving): a :class:`Phase`, or ``None`` (default: none). The run is built with
        the phase's :attr:`Phase.build_overrides` (its longest form), every step's :meth:`record` row is
        handed to :meth:`Phase.observe`, and when that returns the settings it decided, the run goes
        on as if built with them (its boundary conditions retimed, ``run.toml`` rewritten): one
        simulation, no preliminary run."""
        return None

    def notes(self, ctx: RunContext, metrics: dict) -> list[str]:
        """Warnings for the user that the metrics carry (added to the summary's ``notes``), e.g. a
        knot loaded before its set was complete (default: none)."""
        return []

    def warnings(self, ctx: RunContext, metrics: dict) -> list[tuple[str, str]]:
        """Ways in which this run is not a valid measurement by the protocol's own rules (e.g. a knot
        loaded before it was set): ``[(flag, text), ...]``, the short ``flag`` appended to the outcome
        (``"slipped; loaded before it was set"``), the ``text`` (one line: what, by how much, what to
        change) listed first in the summary's ``warnings``; ``valid`` is false when any is given
        (default: none)."""
        return []

    def verdict(self, ctx: RunContext, metrics: dict) -> str | None:
        """``"slipped"``, ``"loose"`` (never tightened) or ``"undecided"`` (too short to tell) from
        the metrics, or ``None`` when the knot held (default: ``"slipped"`` when :meth:`slipped`)."""
        return "slipped" if self.slipped(ctx, metrics) else None

    def slip_verdict(self, ctx: RunContext, metrics: dict) -> str | None:
        """``"slipped"`` when :meth:`slipped`, else ``"undecided"`` when the metrics say the run was too
        short to tell (``decidable`` false or missing), else ``None`` (held): the end of the verdicts
        of the protocols whose metrics carry ``decidable``."""
        if self.slipped(ctx, metrics):
            return "slipped"
        if not metrics.get("decidable", False):
            return "undecided"
        return None

    def stages(self, ctx: RunContext, t_end: float) -> list[tuple[str, float, float]]:
        """``[(name, start, end), ...]`` (s of run time) of the run's stages up to ``t_end``: settling
        (``settle_time``), the protocol's pre-stage (:attr:`pre_stage_name`, ``ctx.t_pre``) and
        the measured stage (:attr:`load_stage_name`). Stages of no length are left out."""
        t_settle = float(ctx.t_settle)
        t_load = t_settle + float(ctx.t_pre)
        out = [("settle", 0.0, t_settle), (self.pre_stage_name, t_settle, t_load), (self.load_stage_name, t_load, t_end)]
        return [(n, a, min(b, t_end)) for n, a, b in out if b > a and a < t_end]

    def decision(self, ctx: RunContext, log: pd.DataFrame) -> Decision | None:
        """Whether the run's outcome is already decided by ``log`` (the rows so far: ``time`` in s of
        run time and the protocol's :meth:`record` columns): a :class:`Decision`, or ``None`` (the
        default: the run goes on to its end). The pipeline asks during the run and, with the
        ``stop_at_decision`` parameter, ends the run ``stop_margin`` s after the decision."""
        return None

    def topology_key(self, ctx: RunContext, topo: dict) -> str | None:
        """What must be equal at the start and the end for the knot to count as unchanged (default:
        the knot type with its handedness, ``topo["signature"]``; ``None`` if the check failed)."""
        return topo.get("signature")


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
    """Local node indices of the ``count`` nodes at the end of a rope of ``n_nodes`` nodes (that
    rope's own count) where ``node`` (0 or N-1) is: ``[0, 1]`` or ``[-2, -1]``."""
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
