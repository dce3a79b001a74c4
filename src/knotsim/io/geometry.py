"""Rod geometry from files: node tables and frames of earlier runs.

Two kinds of source:

- **node files** (:func:`read_node_file`, :func:`read_node_ropes`): node positions, one ``(N, 3)``
  array per rope, m (times ``scale``);
- **run directories** (:func:`read_run_frame`): a frame of an earlier run's output. The last frame
  comes from the run's ``checkpoint.npz`` (exact state: positions, edge angles, velocities,
  reference directors); other frames from ``trajectory.h5`` (velocities and reference directors
  when the file stores them, else zero velocities and space-parallel frames).

Node files, by type:

- **text** (no suffix, ``.txt``, ``.dat``, ``.xyz``, or a numeric suffix) and **``.csv``**: one node
  per line, ``x y z [more columns]`` (whitespace-separated; commas in ``.csv``); columns after the
  third are ignored (imc-der writes ``x y z theta`` and ignores ``theta`` itself). ``#`` starts a
  comment. **Several ropes**: blocks of lines separated by one or more blank lines, one rope per
  block, in file order (a file without blank lines between nodes is one rope; blank lines before
  the first or after the last node do not count). A block may start with a header line that is
  not numbers (``x,y,z``) and be named by a comment line ``# rope: NAME`` directly before its
  first node line; unnamed ropes are ``rope`` (a file with one rope) or ``rope0``, ``rope1``, ...
  (their index).
- **``.npy``**: one ``(N, 3+)`` array, one rope (extra columns ignored), named ``rope``.
- **``.mat``** (MATLAB v5, ``scipy.io.loadmat``): named matrices, one rope each, stored ``(3, N)``
  (one column per node, as Patil et al.'s files) or ``(N, 3)``, and named after the matrix.
  ``matrices`` (a list of names) chooses them, in that order. Without it the ropes are every
  numeric 2-D matrix with one dimension 3 and the other larger than 3, in the file's order;
  the file is refused (:class:`~knotsim.errors.ConfigError` listing every matrix with its shape)
  when a matrix with a dimension 3 does not qualify as a rope: a ``3 x 3`` matrix (rows or columns
  could be the nodes) or a rope of fewer than 4 nodes (``3 x 2``). Other matrices (a ``1 x 1``
  parameter, a ``5 x 5`` table) are left alone. A file with more rope matrices than the run needs
  is refused by the caller (e.g. a protocol that loads one rope), which names them; choose with
  ``matrices``.

Positions are in m (times ``scale``), angles in rad, velocities in m/s.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from knotsim.errors import ConfigError
from knotsim.io.checkpoint import RodFrame

__all__ = ["NodeRopes", "RodFrame", "is_run_directory", "read_node_file", "read_node_ropes", "read_run_frame"]

_TEXT_SUFFIXES = ("", ".txt", ".dat", ".xyz")
#: A comment line naming the rope of the next block of a text node file.
_ROPE_NAME = re.compile(r"#\s*rope\s*:\s*(\S+)\s*$", re.IGNORECASE)


def is_run_directory(path: str | os.PathLike) -> bool:
    """Whether ``path`` is the output directory of a knotsim run (it holds a trajectory or a checkpoint)."""
    p = Path(path)
    return p.is_dir() and ((p / "trajectory.h5").is_file() or (p / "checkpoint.npz").is_file())


@dataclass
class NodeRopes:
    """The ropes of a node file: ``names`` (one per rope), ``ropes`` (``(N_k, 3)`` positions, m),
    ``source`` (the file) and ``found``: what the file holds, for messages (``.mat``: every entry with
    its shape, e.g. ``"A (3x125), B (3x91), L (1x1)"``; text: the blocks and their node counts)."""

    names: list[str]
    ropes: list[np.ndarray]
    source: str
    found: str

    def describe(self) -> str:
        """``"2 ropes in 'F.mat': A (125 nodes), B (91 nodes)"`` (plus what else the file holds)."""
        n = len(self.ropes)
        ropes = ", ".join(f"{a} ({len(x)} nodes)" for a, x in zip(self.names, self.ropes, strict=True))
        return f"{n} rope{'s' if n != 1 else ''} in {self.source!r}: {ropes}; the file holds {self.found}"


def read_node_file(path: str | os.PathLike, *, matrices: list[str] | None = None, scale: float = 1.0,
                   field: str = "file") -> list[np.ndarray]:
    """Node positions in ``path``: a list with one ``(N, 3)`` array (m) per rope (see
    :func:`read_node_ropes`, which also gives the ropes' names)."""
    return read_node_ropes(path, matrices=matrices, scale=scale, field=field).ropes


def read_node_ropes(path: str | os.PathLike, *, matrices: list[str] | None = None, scale: float = 1.0,
                    field: str = "file", choose: str = "name them with 'matrices'") -> NodeRopes:
    """The ropes of a node file (formats and the multi-rope layouts: module docstring).

    Parameters
    ----------
    path:
        Text (``x y z [more columns]`` per line, ``#`` comments, blank lines between ropes), ``.csv``,
        ``.npy`` or ``.mat``.
    matrices:
        ``.mat`` only: names of the matrices to read, one rope each, in this order (default: the
        rule of the module docstring).
    scale:
        Factor applied to the positions (e.g. from a code's dimensionless units to m).
    field:
        Name used in error messages.
    choose:
        How the caller's user chooses ``.mat`` matrices (said in the error of an ambiguous file,
        e.g. ``"choose them with --matrices A,B"``).

    Raises
    ------
    ConfigError
        Naming ``field``: a missing or unreadable file, a table that is not ``(N, 3+)`` numbers, a
        rope of fewer than 2 nodes, NaN, an ambiguous ``.mat`` file, ``matrices`` for another type.
    """
    f = Path(path)
    if not f.is_file():
        raise ConfigError(field, f"file not found: {str(f)!r}")
    suffix = f.suffix.lower()
    if matrices is not None and suffix != ".mat":
        raise ConfigError(field, f"matrices {list(matrices)} apply to .mat files only, {str(f)!r} is not one")
    try:
        if suffix == ".mat":
            names, ropes, found = _read_mat(f, matrices, field, choose)
        elif suffix == ".npy":
            arr = np.load(f, allow_pickle=False)
            names, ropes, found = ["rope"], [arr], f"one array of shape {arr.shape}"
        elif suffix == ".csv" or suffix in _TEXT_SUFFIXES or suffix.lstrip(".").isdigit():
            names, ropes, found = _read_text(f, "," if suffix == ".csv" else None, field)
        else:
            raise ConfigError(field, f"unknown node file type {f.suffix!r} of {str(f)!r}; expected text "
                                     "(x y z columns), .csv, .npy or .mat")
    except ConfigError:
        raise
    except NotImplementedError as exc:  # scipy: MATLAB v7.3 (HDF5) files
        raise ConfigError(field, f"could not read {str(f)!r}: {exc}; save it as a v7 file "
                                 "(MATLAB: save(F, ..., '-v7'))") from None
    except Exception as exc:  # noqa: BLE001 - a foreign file can fail in any reader (EOF, zip, pickle, struct, ...)
        what = " ".join(str(exc).split()) or type(exc).__name__  # one line, whatever the reader said
        if not isinstance(exc, OSError | ValueError):
            what = f"{type(exc).__name__}: {what}"
        raise ConfigError(field, f"could not read {str(f)!r} as a {suffix or 'text'} node file: {what}") from None
    out = [_check_rope(arr, f, name, scale, field) for name, arr in zip(names, ropes, strict=True)]
    return NodeRopes(list(names), out, str(f), found)


def _check_rope(arr, f: Path, name: str, scale: float, field: str) -> np.ndarray:
    arr = np.asarray(arr)
    if not np.issubdtype(arr.dtype, np.number):
        raise ConfigError(field, f"{str(f)!r} does not hold numbers (dtype {arr.dtype})")
    arr = arr.astype(float)
    if arr.ndim != 2 or arr.shape[1] < 3:
        raise ConfigError(field, f"{str(f)!r} rope {name!r}: expected an (N, 3) table of node positions "
                                 f"(x y z columns, m), got shape {arr.shape}")
    x = arr[:, :3] * float(scale)
    if x.shape[0] < 2:
        raise ConfigError(field, f"{str(f)!r} rope {name!r}: a rod needs at least 2 nodes, got {x.shape[0]}")
    if not np.all(np.isfinite(x)):
        raise ConfigError(field, f"{str(f)!r} rope {name!r} contains NaN or infinite values")
    return np.ascontiguousarray(x)


def _numbers(line: str, delimiter: str | None) -> list[float] | None:
    """The numbers of one line (``None`` when a field is not a number)."""
    try:
        return [float(v) for v in (line.split(delimiter) if delimiter else line.split())]
    except ValueError:
        return None


def _read_text(f: Path, delimiter: str | None, field: str) -> tuple[list[str], list[np.ndarray], str]:
    """Ropes of a text or csv node file: blocks separated by blank lines (module docstring)."""
    blocks: list[tuple[str | None, list[tuple[int, str]]]] = []
    rows: list[tuple[int, str]] = []
    name: str | None = None
    for lineno, raw in enumerate(f.read_text(encoding="utf-8").splitlines(), 1):
        line = raw.strip()
        if not line:
            if rows:
                blocks.append((name, rows))
                rows, name = [], None
            continue
        if line.startswith("#"):
            m = _ROPE_NAME.match(line)
            if m and not rows:
                name = m.group(1)
            continue
        rows.append((lineno, line.split("#", 1)[0].strip()))
    if rows:
        blocks.append((name, rows))
    if not blocks:
        raise ConfigError(field, f"{str(f)!r} holds no node lines (x y z per line)")
    names, ropes = [], []
    for k, (bname, brows) in enumerate(blocks):
        if _numbers(brows[0][1], delimiter) is None:
            brows = brows[1:]  # a header line (x,y,z)
        table = []
        for lineno, line in brows:
            vals = _numbers(line, delimiter)
            if vals is None:
                raise ConfigError(field, f"{str(f)!r} line {lineno}: expected numbers (x y z per line), got {line!r}")
            if table and len(vals) != len(table[0]):
                raise ConfigError(field, f"{str(f)!r} line {lineno}: {len(vals)} columns where the lines before "
                                         f"have {len(table[0])}")
            table.append(vals)
        names.append(bname or (f"rope{k}" if len(blocks) > 1 else "rope"))
        ropes.append(np.array(table, float).reshape(len(table), -1))
    if len(set(names)) != len(names):
        raise ConfigError(field, f"{str(f)!r}: two ropes have the same name; names {names}")
    found = ", ".join(f"{a} ({len(x)} lines)" for a, x in zip(names, ropes, strict=True))
    sep = "" if len(blocks) == 1 else f"{len(blocks)} blocks separated by blank lines: "
    return names, ropes, sep + found


def _shape(a) -> str:
    return "x".join(str(n) for n in np.shape(a)) if isinstance(a, np.ndarray) else type(a).__name__


def _read_mat(f: Path, matrices: list[str] | None, field: str,
              choose: str) -> tuple[list[str], list[np.ndarray], str]:
    from scipy.io import loadmat

    data = loadmat(f)
    names = [k for k in data if not k.startswith("__")]
    found = ", ".join(f"{k} ({_shape(data[k])})" for k in names) or "no matrices"

    def numeric(a) -> bool:
        return isinstance(a, np.ndarray) and a.ndim == 2 and np.issubdtype(a.dtype, np.number)

    if matrices is None:
        ropes = [k for k in names if numeric(data[k]) and 3 in data[k].shape and max(data[k].shape) > 3]
        doubtful = [k for k in names if numeric(data[k]) and 3 in data[k].shape and max(data[k].shape) <= 3]
        if doubtful:
            why = "; ".join(f"{k} ({_shape(data[k])}: " + ("rows or columns could be the nodes" if data[k].shape == (3, 3)
                                                             else "fewer than 4 nodes") + ")" for k in doubtful)
            raise ConfigError(field, f"{str(f)!r} is ambiguous: not a rope: {why}; it holds {found}; {choose}")
        if not ropes:
            raise ConfigError(field, f"{str(f)!r} holds no (3, N) or (N, 3) matrix (N > 3); it holds {found}; {choose}")
        chosen = ropes
    else:
        chosen = list(matrices)
        missing = [m for m in chosen if m not in data or m.startswith("__")]
        if missing:
            raise ConfigError(field, f"{str(f)!r} has no matrix {missing[0]!r}; it holds {found}")
        if len(set(chosen)) != len(chosen):
            raise ConfigError(field, f"matrices {chosen} name a matrix twice")
    out = []
    for k in chosen:
        a = data[k]
        if not numeric(a) or 3 not in a.shape:
            raise ConfigError(field, f"{str(f)!r} matrix {k!r} ({_shape(a)}) is not a (3, N) or (N, 3) table of "
                                     "node positions")
        if a.shape == (3, 3):
            raise ConfigError(field, f"{str(f)!r} matrix {k!r} is 3x3: rows or columns could be the nodes; store the "
                                     "rope as (N, 3) or (3, N) with N > 3")
        out.append(np.asarray(a, float).T if a.shape[0] == 3 else np.asarray(a, float))  # (3, N): a column per node
    return chosen, out, found


def _stores_state(traj: Path) -> bool:
    if not traj.is_file():
        return False
    import h5py

    try:
        with h5py.File(traj, "r") as f:
            return "reference_directors" in f and "velocities" in f
    except OSError:
        return False


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
