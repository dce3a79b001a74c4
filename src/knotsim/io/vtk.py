"""Export of trajectories to VTK XML PolyData (``.vtp``) files and a ParaView ``.pvd`` collection.

The XML is written directly (no dependency on the ``vtk`` package). Each frame becomes one
``.vtp`` file in which every rod is a polyline (a closed rod's polyline returns to its first node)
with this point data, one value per node:

``radius`` (m)
    The rod's radius.
``twist`` (rad/m)
    Material twist per unit length at each interior node, as in the twisting energy
    (:mod:`knotsim.energies.twisting`): at node ``i`` between edges ``i-1`` and ``i``,
    ``m_i / l_i`` with the integrated twist ``m_i = theta_i - theta_{i-1} + reference_twist_i``
    (rad) and the rest Voronoi length ``l_i = (l0_{i-1} + l0_i) / 2``, so that the twisting energy
    of a rod without natural twist is ``sum_i GJ l_i twist_i^2 / 2``. Uses the trajectory's stored
    ``reference_twist`` and ``rest_edge_length``; a file without them (written before they were
    stored) gives the edge-angle difference alone over the current Voronoi length, which leaves out
    the reference twist. Zero at the two end nodes of an open rod (they lie on a single edge).
``bending_strain`` (dimensionless)
    Curvature times radius, ``kappa_i * r`` with the discrete curvature
    ``kappa_i = 2 |t_{i-1} x t_i| / (1 + t_{i-1} . t_i) / l_i`` (``t`` unit edge tangents, ``l_i``
    the Voronoi length above): the peak axial strain of the rod's surface if it were a beam.
    Zero at the two end nodes of an open rod.
``contact_force`` (N)
    Magnitude of the net contact force on the node (only when the trajectory stores it).
``rod_id``
    Index of the rod (Int32); also stored as cell data of each polyline.

Each file also carries the frame's time as field data ``TimeValue`` (s). The ``.pvd`` collection
lists the files with their times, so ParaView plays them in simulation time.
"""

from __future__ import annotations

import base64
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np

from knotsim.errors import ConfigError
from knotsim.io.trajectory import Trajectory, read_trajectory

__all__ = ["export_vtk", "node_bending_strain", "node_curvature", "node_twist", "voronoi_lengths"]

_VTK_TYPES = {
    np.dtype(np.float64): "Float64",
    np.dtype(np.float32): "Float32",
    np.dtype(np.int64): "Int64",
    np.dtype(np.int32): "Int32",
    np.dtype(np.uint8): "UInt8",
}


# ---------------------------------------------------------------------------- discrete geometry
def _edges(points: np.ndarray, closed: bool) -> np.ndarray:
    """``(E, 3)`` edge vectors of a polyline of ``(N, 3)`` points (E = N closed, N-1 open)."""
    if closed:
        return np.roll(points, -1, axis=0) - points
    return np.diff(points, axis=0)


def voronoi_lengths(points: np.ndarray, closed: bool) -> np.ndarray:
    """``(N,)`` Voronoi length of each node (m): half the summed length of its one or two edges."""
    p = np.asarray(points, dtype=np.float64)
    return _voronoi_from_lengths(np.linalg.norm(_edges(p, closed), axis=1), closed)


def _voronoi_from_lengths(length: np.ndarray, closed: bool) -> np.ndarray:
    """``(N,)`` Voronoi lengths (m) of the nodes of a rod with edge lengths ``length (E,)``."""
    if closed:
        return 0.5 * (length + np.roll(length, 1))
    out = np.empty(length.size + 1)
    out[0] = 0.5 * length[0]
    out[-1] = 0.5 * length[-1]
    out[1:-1] = 0.5 * (length[:-1] + length[1:])
    return out


def node_curvature(points: np.ndarray, closed: bool) -> np.ndarray:
    """``(N,)`` discrete curvature (1/m) at each node of a ``(N, 3)`` polyline.

    ``kappa_i = 2 |t0 x t1| / (1 + t0 . t1) / l_i`` with ``t0, t1`` the unit tangents of the edges
    before and after node ``i`` and ``l_i`` its Voronoi length; 0 at the ends of an open rod.
    """
    p = np.asarray(points, dtype=np.float64)
    n = p.shape[0]
    e = _edges(p, closed)
    t = e / np.maximum(np.linalg.norm(e, axis=1), 1e-300)[:, None]
    kappa = np.zeros(n)
    if closed:
        t0, t1, idx = np.roll(t, 1, axis=0), t, np.arange(n)
    else:
        if n < 3:
            return kappa
        t0, t1, idx = t[:-1], t[1:], np.arange(1, n - 1)
    cross = np.linalg.norm(np.cross(t0, t1), axis=1)
    dot = np.einsum("ij,ij->i", t0, t1)
    kb = 2.0 * cross / np.maximum(1.0 + dot, 1e-12)
    kappa[idx] = kb / voronoi_lengths(p, closed)[idx]
    return kappa


def node_bending_strain(points: np.ndarray, radius: float, closed: bool) -> np.ndarray:
    """``(N,)`` bending strain ``kappa * radius`` (dimensionless) at each node; see :func:`node_curvature`."""
    return node_curvature(points, closed) * float(radius)


def node_twist(points: np.ndarray, edge_angles: np.ndarray, closed: bool,
               reference_twist: np.ndarray | None = None, rest_edge_length: np.ndarray | None = None) -> np.ndarray:
    """``(N,)`` twist (rad/m) at each node of one rod: ``m_i / l_i``; 0 at open ends.

    ``m_i = theta_i - theta_{i-1} + reference_twist_i`` is the integrated twist of the twisting
    energy; ``l_i`` the node's Voronoi length, from ``rest_edge_length`` when given (as in the
    energy), else from the current ``points``.

    Parameters
    ----------
    points:
        ``(N, 3)`` node positions (m).
    edge_angles:
        ``(E,)`` edge angles (rad), edge ``i`` joining nodes ``i`` and ``i+1`` (mod N if closed).
    reference_twist:
        ``(n_interior,)`` rad, one per interior node in the model's stencil order (open rod: nodes
        ``1..N-2``; closed rod: nodes ``0..N-1``); ``None`` leaves it out (a frame-dependent number).
    rest_edge_length:
        ``(E,)`` rest edge lengths (m), or ``None``.
    """
    p = np.asarray(points, dtype=np.float64)
    th = np.asarray(edge_angles, dtype=np.float64).reshape(-1)
    n = p.shape[0]
    n_edges = n if closed else n - 1
    if th.size != n_edges:
        raise ConfigError("edge_angles", f"{th.size} angles for {n} nodes (closed={closed})")
    n_int = n if closed else max(n - 2, 0)
    ref = np.zeros(n_int) if reference_twist is None else np.asarray(reference_twist, np.float64).reshape(-1)
    if ref.size != n_int:
        raise ConfigError("reference_twist", f"{ref.size} values for {n_int} interior nodes (closed={closed})")
    if rest_edge_length is None:
        lv = voronoi_lengths(p, closed)
    else:
        rest = np.asarray(rest_edge_length, np.float64).reshape(-1)
        if rest.size != n_edges:
            raise ConfigError("rest_edge_length", f"{rest.size} lengths for {n_edges} edges (closed={closed})")
        lv = _voronoi_from_lengths(rest, closed)
    tw = np.zeros(n)
    if closed:
        tw[:] = (th - np.roll(th, 1) + ref) / lv
    elif n >= 3:
        tw[1:-1] = (np.diff(th) + ref) / lv[1:-1]
    return tw


# ---------------------------------------------------------------------------- XML writing
def _data_array(name: str | None, data: np.ndarray, n_components: int, encoding: str, indent: str) -> str:
    data = np.ascontiguousarray(data)
    vtype = _VTK_TYPES[data.dtype]
    attrs = f'type="{vtype}"'
    if name is not None:
        attrs += f" Name={quoteattr(name)}"
    if n_components != 1:
        attrs += f' NumberOfComponents="{n_components}"'
    if encoding == "ascii":
        attrs += ' format="ascii"'
        flat = data.ravel().tolist()
        body = " ".join(map(repr, flat)) if data.dtype.kind == "f" else " ".join(map(str, flat))
    else:
        attrs += ' format="binary"'
        raw = data.astype(data.dtype.newbyteorder("<"), copy=False).tobytes()
        body = base64.b64encode(np.uint64(len(raw)).astype("<u8").tobytes() + raw).decode("ascii")
    return f"{indent}<DataArray {attrs}>{body}</DataArray>\n"


def _frame_vtp(traj: Trajectory, frame: int, encoding: str) -> str:
    """XML text of one PolyData file for loaded frame ``frame``."""
    n_rods = traj.n_rods
    x = np.asarray(traj.positions[frame], dtype=np.float64)
    angles = np.asarray(traj.edge_angles[frame], dtype=np.float64)
    ns, es = traj.rod_node_start, traj.rod_edge_start
    n_points = int(ns[-1])
    ref = traj.state.get("reference_twist")
    ref = None if ref is None else np.asarray(ref[frame], dtype=np.float64)
    rest = traj.state.get("rest_edge_length")
    n_int = np.where(traj.rod_closed, np.diff(ns), np.diff(ns) - 2)
    bs = np.concatenate([[0], np.cumsum(n_int)])
    radius = np.empty(n_points)
    twist = np.empty(n_points)
    strain = np.empty(n_points)
    rod_id = np.empty(n_points, dtype=np.int32)
    conn: list[np.ndarray] = []
    offsets = np.empty(n_rods, dtype=np.int64)
    end = 0
    for r in range(n_rods):
        a, b = int(ns[r]), int(ns[r + 1])
        closed = bool(traj.rod_closed[r])
        p = x[a:b]
        radius[a:b] = traj.rod_radius[r]
        twist[a:b] = node_twist(p, angles[es[r] : es[r + 1]], closed,
                                None if ref is None else ref[bs[r] : bs[r + 1]],
                                None if rest is None else rest[es[r] : es[r + 1]])
        strain[a:b] = node_bending_strain(p, traj.rod_radius[r], closed)
        rod_id[a:b] = r
        idx = np.arange(a, b, dtype=np.int64)
        if closed:
            idx = np.append(idx, a)
        conn.append(idx)
        end += idx.size
        offsets[r] = end
    t = float(traj.time[frame])
    i4, i6 = " " * 4, " " * 10
    parts = [
        '<?xml version="1.0"?>\n',
        '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">\n',
        "  <PolyData>\n",
        "    <FieldData>\n",
        f'      <DataArray type="Float64" Name="TimeValue" NumberOfTuples="1" format="ascii">{t!r}</DataArray>\n',
        "    </FieldData>\n",
        f'    <Piece NumberOfPoints="{n_points}" NumberOfVerts="0" NumberOfLines="{n_rods}" '
        'NumberOfStrips="0" NumberOfPolys="0">\n',
        f"{i4}  <Points>\n",
        _data_array("Points", x, 3, encoding, i6),
        f"{i4}  </Points>\n",
        f'{i4}  <PointData Scalars="bending_strain">\n',
        _data_array("radius", radius, 1, encoding, i6),
        _data_array("twist", twist, 1, encoding, i6),
        _data_array("bending_strain", strain, 1, encoding, i6),
        *([_data_array("contact_force", np.asarray(traj.fields["contact_force"][frame], np.float64), 1,
                       encoding, i6)] if "contact_force" in traj.fields else []),
        _data_array("rod_id", rod_id, 1, encoding, i6),
        f"{i4}  </PointData>\n",
        f"{i4}  <CellData>\n",
        _data_array("rod_id", np.arange(n_rods, dtype=np.int32), 1, encoding, i6),
        f"{i4}  </CellData>\n",
        f"{i4}  <Lines>\n",
        _data_array("connectivity", np.concatenate(conn), 1, encoding, i6),
        _data_array("offsets", offsets, 1, encoding, i6),
        f"{i4}  </Lines>\n",
        f"{i4}</Piece>\n",
        "  </PolyData>\n",
        "</VTKFile>\n",
    ]
    return "".join(parts)


def _pvd(entries: Sequence[tuple[float, str]]) -> str:
    lines = [
        '<?xml version="1.0"?>\n',
        '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n',
        "  <Collection>\n",
    ]
    for t, fname in entries:
        lines.append(f'    <DataSet timestep="{t!r}" group="" part="0" file={quoteattr(fname)}/>\n')
    lines += ["  </Collection>\n", "</VTKFile>\n"]
    return "".join(lines)


def export_vtk(
    trajectory_or_path: Trajectory | str | os.PathLike,
    out_dir: str | os.PathLike,
    every: int = 1,
    *,
    encoding: str = "binary",
    name: str = "trajectory",
) -> list[Path]:
    """Write one ``.vtp`` file per frame and a ``.pvd`` collection indexing them by time.

    Parameters
    ----------
    trajectory_or_path:
        A :class:`~knotsim.io.trajectory.Trajectory`, a ``trajectory.h5`` file, or a run directory
        containing ``trajectory.h5``.
    out_dir:
        Output directory (created if missing).
    every:
        Export every ``every``-th loaded frame (0, every, 2*every, ...).
    encoding:
        ``"binary"`` (base64-encoded little-endian data with a UInt64 byte-count header, the
        VTK XML inline binary format) or ``"ascii"``.
    name:
        Base name: frames are ``{name}_{k:06d}.vtp`` (``k`` = frame index in the file) and the
        collection is ``{name}.pvd``.

    Returns
    -------
    list of Path
        The ``.vtp`` files, in frame order. The ``.pvd`` file is ``out_dir / f"{name}.pvd"``.
    """
    if int(every) < 1:
        raise ConfigError("every", f"must be >= 1, got {every}")
    if encoding not in ("binary", "ascii"):
        raise ConfigError("encoding", f"must be 'binary' or 'ascii', got {encoding!r}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    own: Trajectory | None = None
    if isinstance(trajectory_or_path, Trajectory):
        traj = trajectory_or_path
        frames: Any = range(0, traj.n_frames, int(every))
    else:
        p = Path(trajectory_or_path)
        if p.is_dir():
            p = p / "trajectory.h5"
        own = traj = read_trajectory(p, frames=slice(None, None, int(every)), lazy=True)
        frames = range(traj.n_frames)
    paths: list[Path] = []
    entries: list[tuple[float, str]] = []
    try:
        for i in frames:
            x = np.asarray(traj.positions[i])
            if not np.all(np.isfinite(x)):
                bad = int(np.argmax(~np.all(np.isfinite(x.reshape(-1, 3)), axis=1)))
                raise ConfigError("trajectory", f"frame {int(traj.frame_indices[i])} (t = {float(traj.time[i]):.6g} s) "
                                                f"has non-finite positions (first at node {bad}); export the frames "
                                                "before it with a frame selection, or rerun the simulation")
            fname = f"{name}_{int(traj.frame_indices[i]):06d}.vtp"
            (out / fname).write_text(_frame_vtp(traj, i, encoding), encoding="ascii")
            paths.append(out / fname)
            entries.append((float(traj.time[i]), fname))
    finally:
        if own is not None:
            own.close()
    (out / f"{name}.pvd").write_text(_pvd(entries), encoding="utf-8")
    return paths
