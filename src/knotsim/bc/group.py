"""One named boundary-condition group (:class:`Group`, its kind :class:`GroupKind`) and the
unknowns it acts on (:class:`_Plan`); built by :class:`~knotsim.bc.BoundaryConditions`
(:mod:`knotsim.bc.conditions`, :mod:`knotsim.bc.grips`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from knotsim.bc.feedback import LoadCell, RingCut
from knotsim.bc.paths import Path
from knotsim.bc.rigid import Rotation
from knotsim.errors import ConfigError
from knotsim.solver.state import GroupMemory, LoadCellMemory, memory_field

__all__ = ["Group", "GroupKind"]


class GroupKind(StrEnum):
    """What a boundary-condition group does (the method of :class:`~knotsim.bc.BoundaryConditions`
    that made it; the ``type`` of a ``[[bc]]`` table)."""

    CLAMP = "clamp"
    HOLD = "hold"
    MOVE = "move"
    ROTATE = "rotate"
    PIN = "pin"
    LOAD_CELL = "load_cell"
    FORCE = "force"
    MOMENT = "moment"
    SPRING = "spring"
    RING_TWIST = "ring_twist"


#: the kinds whose group prescribes its unknowns (and has a reaction)
_PRESCRIBED = frozenset({GroupKind.CLAMP, GroupKind.HOLD, GroupKind.MOVE, GroupKind.ROTATE, GroupKind.PIN,
                         GroupKind.LOAD_CELL})

_EPS_T = 1e-12


@dataclass
class Group:
    """One named boundary condition (see :class:`BoundaryConditions`)."""

    name: str
    kind: GroupKind  # a plain string of the set is converted
    rod: int
    nodes: np.ndarray  # global node numbers
    edges: np.ndarray  # global edge numbers whose angles are prescribed / loaded
    start: float
    stop: float
    fix_twist: bool = False
    path: Path | None = None
    twist_angle: Callable[[float], float] | None = None
    load: Callable[[float], np.ndarray] | None = None
    #: (3,) bool: the coordinates (x, y, z) the group prescribes (all three except for ``pin``)
    axes: np.ndarray = field(default_factory=lambda: np.ones(3, np.bool_))
    #: a turning grip's rotation (its pivot is captured at activation: :attr:`pivot`)
    rotation: Rotation | None = None
    #: spring grips: total stiffness (N/m) and the anchor points (n, 3) m at the current time
    stiffness: float = 0.0
    target: np.ndarray | None = field(default=None, repr=False)
    cell: LoadCell | None = None
    ring: RingCut | None = None
    #: ``(positions (n, 3), pivot (3,), angle)`` prescribed by the last evaluation (turning grips)
    current: tuple | None = field(default=None, repr=False)
    #: the group's unknowns, worked out at its first evaluation (:class:`_Plan`)
    plan: _Plan | None = field(default=None, repr=False, compare=False)
    #: what the group captured when it became active (run memory, carried by the state as
    #: ``state.memory.bc[name]``; :attr:`anchor`, :attr:`anchor_theta`, :attr:`anchor_time` and
    #: :attr:`pivot` read and write it)
    memory: GroupMemory = field(default_factory=GroupMemory, repr=False, compare=False)

    anchor = memory_field("anchor", "(n, 3) positions (m) the group prescribes from, or ``None``")
    anchor_theta = memory_field("anchor_theta", "(e,) edge angles (rad) it prescribes from, or ``None``")
    anchor_time = memory_field("anchor_time", "time (s) the anchor was captured")
    pivot = memory_field("pivot", "(3,) a turning grip's pivot (m) captured at activation, or ``None``")

    def __post_init__(self):
        self.kind = GroupKind(self.kind)

    def use_memory(self, memory: GroupMemory) -> None:
        """Continue from ``memory`` (e.g. restored from a checkpoint): make it :attr:`memory`, hand
        its controller to the load cell and bind the path to its start point."""
        self.memory = memory
        if self.cell is not None:
            if memory.cell is None:
                memory.cell = LoadCellMemory()
            self.cell.memory = memory.cell
        if self.path is not None and memory.path_start is not None:
            self.path.bind(np.array(memory.path_start, float))

    @property
    def prescribed(self) -> bool:
        return self.kind in _PRESCRIBED

    def active(self, t: float) -> bool:
        """Whether the group acts at time ``t`` (s): ``start <= t < stop``, with a tiny tolerance."""
        return self.start - _EPS_T <= t < self.stop - _EPS_T


class _Plan:
    """The unknowns of a group, kept between steps (:meth:`BoundaryConditions._plan`): worked out
    anew when the group's ``nodes``, ``edges`` or ``axes`` array is replaced.

    ``xyz`` (3, n) int64 (row ``c``: coordinate ``c`` of the ``n`` nodes), ``pos_dofs`` (3 n,) node
    by node, ``fixed_pos_dofs`` those of ``axes``, ``theta_dofs`` (e,) the edge angles."""

    __slots__ = ("axes", "axes_idx", "edges", "fixed_pos_dofs", "nodes", "pos_dofs", "theta_dofs", "xyz")

    def __init__(self, model, g: Group):
        self.nodes, self.edges, self.axes = g.nodes, g.edges, g.axes
        xyz = model.node_dof[g.nodes][:, None] + np.arange(3)[None, :]
        self.xyz = np.ascontiguousarray(xyz.T, dtype=np.int64)
        self.pos_dofs = xyz.ravel()
        self.fixed_pos_dofs = xyz[:, g.axes].ravel()
        #: the prescribed coordinates (indices), ``None`` for all three
        self.axes_idx = None if bool(np.all(g.axes)) else tuple(int(k) for k in np.flatnonzero(g.axes))
        self.theta_dofs = np.ascontiguousarray(model.edge_theta_dof[g.edges], dtype=np.int64)


def _as_load(name: str, value, shape):
    if callable(value):
        def load(t, f=value):
            try:
                out = np.asarray(f(t), dtype=float)
            except Exception as exc:  # user code
                raise ConfigError(f"bc.{name}", f"load function failed at t={t}: {exc}") from exc
            if out.shape != shape or not np.all(np.isfinite(out)):
                raise ConfigError(f"bc.{name}", f"load function must return shape {shape}, got {out!r}")
            return out
        return load
    arr = np.asarray(value, dtype=float)
    if arr.shape != shape or not np.all(np.isfinite(arr)):
        raise ConfigError(f"bc.{name}", f"expected a value of shape {shape} (or a callable of time), got {value!r}")
    return lambda t, a=arr: a
