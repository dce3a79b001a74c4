"""Trajectory files (``trajectory.h5``): writing frames as a run goes, and reading them back.

File layout (see ``docs/architecture.md``, section "Trajectory file"); every dataset carries the
attributes ``units`` (UDUNITS-style text, ``"1"`` for dimensionless numbers and indices) and
``description`` (:data:`DATASETS`):

- ``time``: ``(T,)`` float64, s.
- ``positions``: ``(T, n_nodes_total, 3)`` float64, m, chunked along T.
- ``edge_angles``: ``(T, n_edges_total)`` float64, rad.
- optional physical state per frame (a run can continue from any frame): ``velocities``
  ``(T, n_nodes, 3)`` m/s, ``reference_directors`` ``(T, n_edges, 3)``, ``reference_twist``
  ``(T, n_bend)`` rad; and the static ``rest_edge_length`` ``(n_edges,)`` m;
- optional derived output per frame (:data:`FRAME_FIELDS`): ``edge_strain`` and ``edge_tension``
  ``(T, n_edges)`` (1 and N), ``contact_force`` and ``friction_force`` ``(T, n_nodes)`` N;
- ``rod_node_start``: ``(n_rods+1,)`` int64; rod ``r`` owns global nodes
  ``rod_node_start[r]:rod_node_start[r+1]``.
- ``rod_edge_start``: ``(n_rods+1,)`` int64, likewise for edges.
- ``rod_closed``: ``(n_rods,)`` bool; ``rod_radius``: ``(n_rods,)`` float64, m.
- attributes ``rod_names`` (list of str), ``knotsim_version``, ``created`` (ISO 8601, UTC) and
  ``format = "knotsim-trajectory"``.

The writer appends one frame at a time to resizable, chunked datasets and flushes the file after
every ``flush_every`` frames, so that a run that is killed leaves a file readable up to its last
flushed frame. Within a frame every other dataset is written before ``time``; the reader keeps
only frames whose datasets all exist and whose time is finite.
"""

from __future__ import annotations

import datetime as _dt
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from knotsim.errors import ConfigError
from knotsim.io._frames import _LazyFrames, _select_frames, _validate_layout

__all__ = ["DATASETS", "FORMAT_NAME", "FRAME_FIELDS", "Trajectory", "TrajectoryWriter", "read_trajectory"]

#: Units and meaning of every dataset of a trajectory file (stored as its ``units`` and
#: ``description`` attributes). ``"1"``: dimensionless (or an index).
DATASETS: dict[str, tuple[str, str]] = {
    "time": ("s", "simulation time of each frame"),
    "positions": ("m", "node positions (frame, global node, xyz)"),
    "edge_angles": ("rad", "edge angle theta: material frame rotated from the reference frame about the tangent"),
    "velocities": ("m/s", "node velocities (frame, global node, xyz)"),
    "reference_directors": ("1", "unit first reference director d1 of each edge (frame, global edge, xyz)"),
    "reference_twist": ("rad", "reference twist of each interior node (frame, bending stencil, in rod order)"),
    "rest_edge_length": ("m", "rest length of each edge"),
    "edge_strain": ("1", "axial strain |e|/l0 - 1 of each edge"),
    "edge_tension": ("N", "axial force EA * strain of each edge"),
    "contact_force": ("N", "magnitude of the net contact (normal) force on each node at the step that "
                      "ended at this frame; NaN in a frame written before the run's first step"),
    "friction_force": ("N", "magnitude of the net friction force on each node, as contact_force"),
    "slip_speed": ("m/s", "slip speed of the surfaces at each node in contact (the pair of largest normal force "
                   "on its edges), surface friction only; NaN where there is no contact"),
    "rolling_speed": ("m/s", "part of the surfaces' velocity difference from the cross-sections' rotation at each "
                      "node in contact, as slip_speed; large where strands roll"),
    "rod_node_start": ("1", "global node number where each rod starts (last entry: total)"),
    "rod_edge_start": ("1", "global edge number where each rod starts (last entry: total)"),
    "rod_closed": ("1", "whether each rod is closed (a ring)"),
    "rod_radius": ("m", "radius of each rod"),
}
#: Optional derived per-frame datasets and what they are given per: ``"edge"`` or ``"node"``.
FRAME_FIELDS: dict[str, str] = {"edge_strain": "edge", "edge_tension": "edge", "contact_force": "node",
                                "friction_force": "node", "slip_speed": "node", "rolling_speed": "node"}


def _label(ds: h5py.Dataset, name: str) -> h5py.Dataset:
    """Attach the ``units`` and ``description`` attributes of :data:`DATASETS` to ``ds``."""
    units, text = DATASETS[name]
    ds.attrs["units"] = units
    ds.attrs["description"] = text
    return ds

FORMAT_NAME = "knotsim-trajectory"
_REQUIRED = (
    "time",
    "positions",
    "edge_angles",
    "rod_node_start",
    "rod_edge_start",
    "rod_closed",
    "rod_radius",
)


class TrajectoryWriter:
    """Append frames of a run to an HDF5 trajectory file.

    Use as a context manager::

        with TrajectoryWriter(path, rod_node_start, rod_edge_start, rod_closed, rod_radius,
                              rod_names) as writer:
            for t, positions, edge_angles in frames:
                writer.append(t, positions, edge_angles)

    Parameters
    ----------
    path:
        File to create (an existing file is overwritten).
    rod_node_start, rod_edge_start:
        ``(n_rods+1,)`` int, global node / edge numbers where each rod starts (last entry = totals).
    rod_closed:
        ``(n_rods,)`` bool, whether each rod is a ring.
    rod_radius:
        ``(n_rods,)`` float, rod radii (m).
    rod_names:
        ``n_rods`` names (``None``: ``rod0, rod1, ...``).
    chunk_frames:
        Number of frames per HDF5 chunk along the time axis.
    flush_every:
        Flush the file to disk after this many appended frames (1: after each frame). A killed run
        leaves a file readable up to its last flushed frame.
    compression:
        Optional h5py compression filter for ``positions`` and ``edge_angles`` (e.g. ``"gzip"``).
    attrs:
        Extra file attributes (str, numbers or arrays), e.g. a run's configuration as TOML text.
    n_bend:
        Number of interior (bending) nodes of all rods. When given, every frame also stores the
        rest of the physical state, so that a run can continue from any frame: ``velocities``
        ``(T, n_nodes, 3)`` m/s, ``reference_directors`` ``(T, n_edges, 3)`` (unit first reference
        director of each edge; the material frame is it rotated by the edge angle about the
        tangent) and ``reference_twist`` ``(T, n_bend)`` rad.
    rest_edge_length:
        ``(n_edges,)`` m, the rods' rest edge lengths (stored once), so that a run continued from a
        frame keeps the rope's rest shape.
    fields:
        Names of derived per-frame datasets to store (keys of :data:`FRAME_FIELDS`: ``edge_strain``,
        ``edge_tension`` ``(n_edges,)``, ``contact_force``, ``friction_force`` ``(n_nodes,)``); each
        appended frame then passes them in ``state``.
    """

    def __init__(
        self,
        path: str | os.PathLike,
        rod_node_start: Sequence[int] | np.ndarray,
        rod_edge_start: Sequence[int] | np.ndarray,
        rod_closed: Sequence[bool] | np.ndarray,
        rod_radius: Sequence[float] | np.ndarray,
        rod_names: Sequence[str] | None = None,
        chunk_frames: int = 64,
        *,
        flush_every: int = 1,
        compression: str | None = None,
        attrs: dict[str, Any] | None = None,
        n_bend: int | None = None,
        rest_edge_length: np.ndarray | None = None,
        fields: Sequence[str] = (),
    ):
        node_start, edge_start, closed, radius, names = _validate_layout(
            rod_node_start, rod_edge_start, rod_closed, rod_radius, rod_names
        )
        if int(chunk_frames) < 1:
            raise ConfigError("chunk_frames", f"must be >= 1, got {chunk_frames}")
        if int(flush_every) < 1:
            raise ConfigError("flush_every", f"must be >= 1, got {flush_every}")
        self.path = Path(path)
        self.n_nodes = int(node_start[-1])
        self.n_edges = int(edge_start[-1])
        self.flush_every = int(flush_every)
        unknown = [k for k in fields if k not in FRAME_FIELDS]
        if unknown:
            raise ConfigError("fields", f"unknown per-frame fields {unknown}; known: {sorted(FRAME_FIELDS)}")
        self._n_frames = 0
        self._unflushed = 0
        self._last_time = -np.inf

        from knotsim._version import __version__

        # chunks of at most about 1 MiB (so a few frames of a huge rod do not allocate 64 frames each)
        per_frame = 8 * 3 * max(self.n_nodes, 1)
        cf = max(1, min(int(chunk_frames), (1 << 20) // per_frame))
        f = h5py.File(self.path, "w")
        try:
            f.attrs["format"] = FORMAT_NAME
            f.attrs["knotsim_version"] = __version__
            f.attrs["created"] = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
            f.attrs["rod_names"] = np.array(names, dtype=h5py.string_dtype())
            for key, value in (attrs or {}).items():
                f.attrs[key] = value
            for key, data in (("rod_node_start", node_start), ("rod_edge_start", edge_start),
                              ("rod_closed", closed), ("rod_radius", radius)):
                _label(f.create_dataset(key, data=data), key)
            self._positions = f.create_dataset(
                "positions",
                shape=(0, self.n_nodes, 3),
                maxshape=(None, self.n_nodes, 3),
                chunks=(cf, self.n_nodes, 3),
                dtype=np.float64,
                fillvalue=np.nan,
                compression=compression,
            )
            self._edge_angles = f.create_dataset(
                "edge_angles",
                shape=(0, self.n_edges),
                maxshape=(None, self.n_edges),
                chunks=(cf, self.n_edges),
                dtype=np.float64,
                fillvalue=np.nan,
                compression=compression,
            )
            _label(self._positions, "positions")
            _label(self._edge_angles, "edge_angles")
            if rest_edge_length is not None:
                rest = np.asarray(rest_edge_length, dtype=np.float64).reshape(-1)
                if rest.shape != (self.n_edges,):
                    raise ConfigError("rest_edge_length", f"expected shape ({self.n_edges},), got {rest.shape}")
                _label(f.create_dataset("rest_edge_length", data=rest), "rest_edge_length")
            per_frame: list[tuple[str, tuple[int, ...]]] = []
            if n_bend is not None:
                per_frame += [("velocities", (self.n_nodes, 3)), ("reference_directors", (self.n_edges, 3)),
                              ("reference_twist", (int(n_bend),))]
            per_frame += [(k, (self.n_edges if FRAME_FIELDS[k] == "edge" else self.n_nodes,)) for k in fields]
            self._state_ds = {}
            for key, shape in per_frame:
                self._state_ds[key] = _label(f.create_dataset(
                    key, shape=(0, *shape), maxshape=(None, *shape), chunks=(cf, *shape),
                    dtype=np.float64, fillvalue=np.nan, compression=compression), key)
            self._time = f.create_dataset(
                "time",
                shape=(0,),
                maxshape=(None,),
                chunks=(max(cf, 256),),
                dtype=np.float64,
                fillvalue=np.nan,
            )
            _label(self._time, "time")
            f.flush()
        except BaseException:
            f.close()
            raise
        self._file: h5py.File | None = f

    # ------------------------------------------------------------------ context manager
    def __enter__(self) -> TrajectoryWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def n_frames(self) -> int:
        """Number of frames appended so far."""
        return self._n_frames

    @property
    def closed(self) -> bool:
        """True once :meth:`close` was called."""
        return self._file is None

    def append(self, time: float, positions: np.ndarray, edge_angles: np.ndarray,
               state: dict[str, np.ndarray] | None = None) -> int:
        """Append one frame and return its index.

        Parameters
        ----------
        time:
            Simulation time (s); must not decrease from one frame to the next.
        positions:
            ``(n_nodes_total, 3)`` node positions (m), or the same flattened.
        edge_angles:
            ``(n_edges_total,)`` edge twist angles (rad).
        state:
            With ``n_bend`` given at creation: ``velocities``, ``reference_directors`` and
            ``reference_twist`` of the frame (shapes in the class docstring); and every name in
            ``fields``.
        """
        if self._file is None:
            raise ConfigError("TrajectoryWriter", f"append() after close() on {self.path}")
        t = float(time)
        if not np.isfinite(t) or t < self._last_time:
            raise ConfigError("time", f"must be finite and non-decreasing, got {t} after {self._last_time}")
        x = np.asarray(positions, dtype=np.float64)
        if x.size != 3 * self.n_nodes:
            raise ConfigError("positions", f"expected shape ({self.n_nodes}, 3), got {x.shape}")
        th = np.asarray(edge_angles, dtype=np.float64).reshape(-1)
        if th.size != self.n_edges:
            raise ConfigError("edge_angles", f"expected shape ({self.n_edges},), got {th.shape}")
        k = self._n_frames
        # positions and angles first, time last: a frame counts once its time is written.
        self._positions.resize(k + 1, axis=0)
        self._positions[k] = x.reshape(self.n_nodes, 3)
        self._edge_angles.resize(k + 1, axis=0)
        self._edge_angles[k] = th
        for key, ds in self._state_ds.items():
            if state is None or key not in state:
                raise ConfigError("state", f"this trajectory stores {key} with every frame; pass it in state")
            ds.resize(k + 1, axis=0)
            ds[k] = np.asarray(state[key], dtype=np.float64).reshape(ds.shape[1:])
        self._time.resize(k + 1, axis=0)
        self._time[k] = t
        self._n_frames = k + 1
        self._last_time = t
        self._unflushed += 1
        if self._unflushed >= self.flush_every:
            self.flush()
        return k

    def flush(self) -> None:
        """Write buffered frames and metadata to disk."""
        if self._file is not None:
            self._file.flush()
            self._unflushed = 0

    def close(self) -> None:
        """Flush and close the file (idempotent)."""
        if self._file is not None:
            self._file.flush()
            self._file.close()
            self._file = None


@dataclass
class Trajectory:
    """A trajectory read from ``trajectory.h5``.

    Attributes
    ----------
    time:
        ``(T,)`` float64, simulation time of each loaded frame (s).
    positions:
        ``(T, n_nodes, 3)`` float64 node positions (m); an ndarray, or a lazy view reading from
        disk on indexing when loaded with ``lazy=True``.
    edge_angles:
        ``(T, n_edges)`` float64 edge twist angles (rad); ndarray or lazy view as ``positions``.
    rod_node_start, rod_edge_start:
        ``(n_rods+1,)`` int64 global node / edge offsets of each rod.
    rod_closed:
        ``(n_rods,)`` bool.
    rod_radius:
        ``(n_rods,)`` float64 radii (m).
    rod_names:
        ``n_rods`` names.
    frame_indices:
        ``(T,)`` int64, index in the file of each loaded frame (loaded frame ``i`` is file frame
        ``frame_indices[i]``).
    attrs:
        File attributes (``knotsim_version``, ``created``, and any extra ones).
    path:
        The file that was read.
    """

    time: np.ndarray
    positions: Any
    edge_angles: Any
    rod_node_start: np.ndarray
    rod_edge_start: np.ndarray
    rod_closed: np.ndarray
    rod_radius: np.ndarray
    rod_names: list[str]
    frame_indices: np.ndarray
    attrs: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None
    #: ``velocities``, ``reference_directors``, ``reference_twist`` of the loaded frames and the
    #: static ``rest_edge_length`` when the file stores them (see :class:`TrajectoryWriter`), else empty.
    #: Lazy views (as ``positions``) for the per-frame arrays when loaded with ``lazy=True``.
    state: dict[str, Any] = field(default_factory=dict)
    #: Derived per-frame arrays the file stores (:data:`FRAME_FIELDS`: ``edge_strain``,
    #: ``edge_tension`` ``(T, n_edges)``, ``contact_force``, ``friction_force`` ``(T, n_nodes)``).
    fields: dict[str, Any] = field(default_factory=dict)
    #: ``units`` attribute of every dataset in the file (e.g. ``units["edge_tension"] == "N"``).
    units: dict[str, str] = field(default_factory=dict)
    _file: h5py.File | None = field(default=None, repr=False)

    # ------------------------------------------------------------------ sizes
    @property
    def n_frames(self) -> int:
        """Number of loaded frames ``T``."""
        return int(self.time.size)

    @property
    def n_rods(self) -> int:
        return int(self.rod_node_start.size - 1)

    @property
    def n_nodes(self) -> int:
        """Total number of nodes over all rods."""
        return int(self.rod_node_start[-1])

    @property
    def n_edges(self) -> int:
        """Total number of edges over all rods."""
        return int(self.rod_edge_start[-1])

    # ------------------------------------------------------------------ access
    def rod_index(self, rod: int | str) -> int:
        """Index of a rod given by index (negative allowed) or by name."""
        if isinstance(rod, str):
            try:
                return self.rod_names.index(rod)
            except ValueError:
                raise ConfigError("rod", f"no rod named {rod!r}; rods are {self.rod_names}") from None
        r = int(rod)
        if not -self.n_rods <= r < self.n_rods:
            raise ConfigError("rod", f"index {r} out of range for {self.n_rods} rods")
        return r % self.n_rods

    def _frame(self, frame: int) -> int:
        i = int(frame)
        if not -self.n_frames <= i < self.n_frames:
            raise ConfigError("frame", f"index {i} out of range for {self.n_frames} loaded frames")
        return i % self.n_frames

    def rod_positions(self, frame: int, rod: int | str) -> np.ndarray:
        """``(N_r, 3)`` node positions (m) of rod ``rod`` (index or name) at loaded frame ``frame``."""
        r = self.rod_index(rod)
        a, b = int(self.rod_node_start[r]), int(self.rod_node_start[r + 1])
        return np.asarray(self.positions[self._frame(frame), a:b], dtype=np.float64)

    def rod_edge_angles(self, frame: int, rod: int | str) -> np.ndarray:
        """``(E_r,)`` edge twist angles (rad) of rod ``rod`` at loaded frame ``frame``."""
        r = self.rod_index(rod)
        a, b = int(self.rod_edge_start[r]), int(self.rod_edge_start[r + 1])
        return np.asarray(self.edge_angles[self._frame(frame), a:b], dtype=np.float64)

    def centerlines(self, frame: int) -> list[np.ndarray]:
        """List of ``(N_r, 3)`` node positions (m) of every rod at loaded frame ``frame``."""
        x = np.asarray(self.positions[self._frame(frame)], dtype=np.float64)
        s = self.rod_node_start
        return [x[s[r] : s[r + 1]].copy() for r in range(self.n_rods)]

    def frame_at_time(self, t: float) -> int:
        """Index of the loaded frame whose time is nearest to ``t`` (s).

        Times before the first (after the last) frame give the first (last) frame; on a tie the
        earlier frame is returned.
        """
        t = float(t)
        if not np.isfinite(t):
            raise ConfigError("t", f"must be finite, got {t}")
        if self.n_frames == 0:
            raise ConfigError("frame_at_time", "the trajectory has no frames")
        i = int(np.searchsorted(self.time, t, side="left"))
        if i <= 0:
            return 0
        if i >= self.n_frames:
            return self.n_frames - 1
        return i - 1 if t - self.time[i - 1] <= self.time[i] - t else i

    # ------------------------------------------------------------------ lifetime
    def close(self) -> None:
        """Close the underlying file of a lazily loaded trajectory (no-op otherwise)."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> Trajectory:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


_STATE_KEYS = ("velocities", "reference_directors", "reference_twist")


def read_trajectory(path: str | os.PathLike, frames: Any = None, *, lazy: bool = False) -> Trajectory:
    """Read a trajectory file written by :class:`TrajectoryWriter`.

    Parameters
    ----------
    path:
        The ``trajectory.h5`` file.
    frames:
        Which frames to load: ``None`` (all), an int (negative counts from the end), a slice, or a
        sequence of ints. Indices refer to frames in the file.
    lazy:
        If true, ``positions``, ``edge_angles`` and the per-frame ``state`` and ``fields`` arrays
        are not read now but on indexing, and the file stays open until :meth:`Trajectory.close` (or the end of a ``with`` block).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ConfigError
        If the file is not HDF5 or not a knotsim trajectory, or ``frames`` is invalid.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"trajectory file not found: {path}")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ConfigError("trajectory", f"{path} is not a readable HDF5 file ({exc})") from exc
    try:
        missing = [k for k in _REQUIRED if k not in f]
        if missing:
            raise ConfigError(
                "trajectory", f"{path} is not a knotsim trajectory (missing datasets {missing})"
            )
        node_start, edge_start, closed, radius, names = _validate_layout(
            f["rod_node_start"][()],
            f["rod_edge_start"][()],
            f["rod_closed"][()],
            f["rod_radius"][()],
            [s.decode() if isinstance(s, bytes) else str(s) for s in f.attrs.get("rod_names", [])] or None,
        )
        pos_ds, ang_ds, time_ds = f["positions"], f["edge_angles"], f["time"]
        if pos_ds.ndim != 3 or pos_ds.shape[1:] != (node_start[-1], 3):
            raise ConfigError(
                "trajectory", f"{path}: positions has shape {pos_ds.shape}, expected (T, {node_start[-1]}, 3)"
            )
        if ang_ds.ndim != 2 or ang_ds.shape[1] != edge_start[-1]:
            raise ConfigError(
                "trajectory", f"{path}: edge_angles has shape {ang_ds.shape}, expected (T, {edge_start[-1]})"
            )
        n = min(time_ds.shape[0], pos_ds.shape[0], ang_ds.shape[0])
        all_time = np.asarray(time_ds[:n], dtype=np.float64)
        finite = np.isfinite(all_time)
        if not np.all(finite):  # a run killed mid-frame: keep the complete prefix
            n = int(np.argmin(finite))
            all_time = all_time[:n]
        sel = _select_frames(frames, n)
        attrs = {
            k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items() if k != "rod_names"
        }
        units = {k: (v.decode() if isinstance(v, bytes) else str(v))
                 for k in f for v in [f[k].attrs.get("units")] if v is not None}
        per_frame = [k for k in (*_STATE_KEYS, *FRAME_FIELDS) if k in f and f[k].shape[0] >= n]
        common = dict(
            units=units,
            time=all_time[sel],
            rod_node_start=node_start,
            rod_edge_start=edge_start,
            rod_closed=closed,
            rod_radius=radius,
            rod_names=names,
            frame_indices=sel,
            attrs=attrs,
            path=path,
        )
        views = {key: _LazyFrames(f[key], sel) for key in ("positions", "edge_angles", *per_frame)}
        if not lazy:
            views = {key: view[:] for key, view in views.items()}
        state = {key: views[key] for key in _STATE_KEYS if key in views}
        if "rest_edge_length" in f:
            state["rest_edge_length"] = np.asarray(f["rest_edge_length"][()], dtype=np.float64)
        out = Trajectory(positions=views["positions"], edge_angles=views["edge_angles"], state=state,
                         fields={key: views[key] for key in FRAME_FIELDS if key in views},
                         _file=f if lazy else None, **common)
    except BaseException:
        f.close()
        raise
    if not lazy:
        f.close()
    return out
