"""Rod geometry from files: node tables and frames of earlier runs.

Two kinds of source:

- **node files** (:func:`read_node_file`): whitespace-separated text with ``x y z [theta]`` columns
  per node (as written by imc-der: extra columns are ignored, as imc-der itself ignores ``theta``),
  ``.csv`` (an optional header line), ``.npy`` (an ``(N, 3+)`` array) and MATLAB ``.mat`` files
  with named matrices (``(N, 3)`` or ``(3, N)``; several matrices are several ropes);
- **run directories** (:func:`read_run_frame`): a frame of an earlier run's output. The last frame
  comes from the run's ``checkpoint.npz`` (exact state: positions, edge angles, velocities,
  reference directors); other frames from ``trajectory.h5`` (velocities and reference directors
  when the file stores them, else zero velocities and space-parallel frames).

Positions are in m (times ``scale``), angles in rad, velocities in m/s.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from knotsim.errors import ConfigError

__all__ = ["RodFrame", "is_run_directory", "read_node_file", "read_run_frame"]

_TEXT_SUFFIXES = ("", ".txt", ".dat", ".xyz")


def is_run_directory(path: str | os.PathLike) -> bool:
    """Whether ``path`` is the output directory of a knotsim run (it holds a trajectory or a checkpoint)."""
    p = Path(path)
    return p.is_dir() and ((p / "trajectory.h5").is_file() or (p / "checkpoint.npz").is_file())


def read_node_file(path: str | os.PathLike, *, matrices: list[str] | None = None, scale: float = 1.0,
                   field: str = "file") -> list[np.ndarray]:
    """Node positions in ``path``: a list with one ``(N, 3)`` array (m) per rope.

    Parameters
    ----------
    path:
        Text (``x y z [more columns]`` per line, ``#`` comments), ``.csv``, ``.npy`` or ``.mat``.
    matrices:
        ``.mat`` only: names of the matrices to read, one rope each (default: every numeric
        matrix with 3 rows or 3 columns, in the file's order).
    scale:
        Factor applied to the positions (e.g. from a code's dimensionless units to m).
    field:
        Name used in error messages.
    """
    f = Path(path)
    if not f.is_file():
        raise ConfigError(field, f"file not found: {str(f)!r}")
    suffix = f.suffix.lower()
    try:
        if suffix == ".mat":
            ropes = _read_mat(f, matrices, field)
        elif suffix == ".npy":
            ropes = [np.load(f, allow_pickle=False)]
        elif suffix == ".csv":
            ropes = [_loadtxt(f, ",")]
        elif suffix in _TEXT_SUFFIXES or suffix.lstrip(".").isdigit():
            ropes = [_loadtxt(f, None)]
        else:
            raise ConfigError(field, f"unknown node file type {f.suffix!r} of {str(f)!r}; expected text "
                                     "(x y z columns), .csv, .npy or .mat")
    except ConfigError:
        raise
    except (OSError, ValueError) as exc:
        raise ConfigError(field, f"could not read {str(f)!r}: {exc}") from None
    if matrices is not None and suffix != ".mat":
        raise ConfigError(field, f"'matrices' applies to .mat files only, {str(f)!r} is not one")
    out = []
    for k, arr in enumerate(ropes):
        arr = np.asarray(arr)
        if not np.issubdtype(arr.dtype, np.number):
            raise ConfigError(field, f"{str(f)!r} does not hold numbers (dtype {arr.dtype})")
        arr = arr.astype(float)
        if arr.ndim != 2 or arr.shape[1] < 3:
            raise ConfigError(field, f"{str(f)!r} rope {k}: expected an (N, 3) table of node positions "
                                     f"(x y z columns, m), got shape {arr.shape}")
        x = arr[:, :3] * float(scale)
        if x.shape[0] < 2:
            raise ConfigError(field, f"{str(f)!r} rope {k}: a rod needs at least 2 nodes, got {x.shape[0]}")
        if not np.all(np.isfinite(x)):
            raise ConfigError(field, f"{str(f)!r} rope {k} contains NaN or infinite values")
        out.append(np.ascontiguousarray(x))
    return out


def _loadtxt(f: Path, delimiter: str | None) -> np.ndarray:
    try:
        return np.loadtxt(f, delimiter=delimiter, ndmin=2, comments="#")
    except ValueError:  # a header line
        return np.loadtxt(f, delimiter=delimiter, ndmin=2, comments="#", skiprows=1)


def _read_mat(f: Path, matrices: list[str] | None, field: str) -> list[np.ndarray]:
    from scipy.io import loadmat

    data = loadmat(f)
    names = [k for k in data if not k.startswith("__")]
    if matrices is None:
        chosen = [k for k in names if isinstance(data[k], np.ndarray) and data[k].ndim == 2
                  and np.issubdtype(data[k].dtype, np.number) and 3 in data[k].shape and data[k].size > 6]
        if not chosen:
            raise ConfigError(field, f"{str(f)!r} holds no (N, 3) or (3, N) matrix; it has {names}")
    else:
        missing = [m for m in matrices if m not in data]
        if missing:
            raise ConfigError(field, f"{str(f)!r} has no matrix {missing[0]!r}; it has {names}")
        chosen = list(matrices)
    out = []
    for k in chosen:
        a = np.asarray(data[k], float)
        if a.ndim == 2 and a.shape[0] == 3 and a.shape[1] != 3:
            a = a.T  # (3, N): one column per node
        out.append(a)
    return out


def _stores_state(traj: Path) -> bool:
    if not traj.is_file():
        return False
    import h5py

    try:
        with h5py.File(traj, "r") as f:
            return "reference_directors" in f and "velocities" in f
    except OSError:
        return False


@dataclass
class RodFrame:
    """The physical state of one rod at one frame of an earlier run.

    ``positions (N, 3)`` m; ``edge_angles (N-1,)`` or ``(N,)`` for a ring, rad;
    ``velocities (N, 3)`` m/s or ``None``; ``reference_directors (n_edges, 3)`` or ``None``;
    ``closed``; ``radius`` m; ``name``; ``time`` s of the frame; ``rest_edge_lengths (n_edges,)`` m
    of the run's rope (``None`` when not stored).
    """

    positions: np.ndarray
    edge_angles: np.ndarray
    velocities: np.ndarray | None
    reference_directors: np.ndarray | None
    closed: bool
    radius: float
    name: str
    time: float
    rest_edge_lengths: np.ndarray | None = None


def read_run_frame(run_dir: str | os.PathLike, frame: int = -1, field: str = "run") -> list[RodFrame]:
    """The state of every rod at ``frame`` (an index into the saved frames, negative from the end)
    of the run in ``run_dir``: one :class:`RodFrame` per rod.

    Frames come from ``trajectory.h5``, which stores the whole state of every frame (the last
    frame is the state the run ended in); for an older trajectory without velocities and frames,
    the last frame comes from ``checkpoint.npz``."""
    d = Path(run_dir)
    if not d.is_dir():
        raise ConfigError(field, f"run directory not found: {str(d)!r}")
    ckpt = d / "checkpoint.npz"
    traj = d / "trajectory.h5"
    if frame == -1 and ckpt.is_file() and not _stores_state(traj):
        from knotsim.io.checkpoint import read_checkpoint

        return read_checkpoint(ckpt).rod_frames()
    if not traj.is_file():
        raise ConfigError(field, f"{str(d)!r} is not a run directory: it has neither checkpoint.npz nor "
                                 "trajectory.h5")
    from knotsim.io.trajectory import read_trajectory

    try:
        tr = read_trajectory(traj, frames=frame)
    except (ConfigError, IndexError) as exc:
        raise ConfigError(field, f"cannot read frame {frame} of {str(traj)!r}: {exc}") from None
    if tr.n_frames != 1:
        raise ConfigError(field, f"frame {frame} of {str(traj)!r} does not exist ({tr.n_frames} frames read)")
    out = []
    for r in range(tr.n_rods):
        a, b = int(tr.rod_node_start[r]), int(tr.rod_node_start[r + 1])
        ea, eb = int(tr.rod_edge_start[r]), int(tr.rod_edge_start[r + 1])
        v = tr.state["velocities"][0, a:b] if "velocities" in tr.state else None
        d1 = tr.state["reference_directors"][0, ea:eb] if "reference_directors" in tr.state else None
        rest = tr.state["rest_edge_length"][ea:eb] if "rest_edge_length" in tr.state else None
        out.append(RodFrame(tr.rod_positions(0, r), tr.rod_edge_angles(0, r), v, d1, bool(tr.rod_closed[r]),
                            float(tr.rod_radius[r]), tr.rod_names[r], float(tr.time[0]), rest))
    return out
