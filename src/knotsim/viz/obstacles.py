"""The rigid obstacles of a run (posts, spheres, planes) in its pictures.

A run's obstacles are the ``[[obstacles]]`` tables of its ``run.toml`` (``docs/run-files.md``).
:func:`read_obstacles` reads them as :class:`ObstacleTrack` objects, each of which gives the
obstacle's :class:`ObstacleShape` at any time of the run (:meth:`ObstacleTrack.at`) with the motion
of :class:`knotsim.contact.obstacles.Obstacle`: the translation of its ``velocity`` or
``waypoints`` (:mod:`knotsim.bc.paths`, time from t = 0) and the rotation of its
``angular_velocity`` about its pivot. Free spin (``spin_inertia``) turns a capsule about its own
axis or a sphere about its centre: it does not change the shape and is not drawn.

:func:`obstacle_mesh` builds the surfaces both picture backends draw: a capsule as a cylinder with
hemispherical caps, a sphere as a sphere (grey, opaque), a plane as a translucent square patch
around the region pictured. A capsule is cut (with a flat end) where it leaves a box well beyond
the picture, so that a long post neither costs much nor disturbs matplotlib's depth sort.
:func:`obstacle_focus` adds to a knot's box the part of a post (or sphere) that the rope touches
inside it (a hitch round a post is framed on the hitch, not on the whole post).

Positions in m, times in s.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from knotsim.errors import ConfigError, KnotsimWarning

__all__ = ["OBSTACLE_COLOR", "PLANE_COLOR", "ObstacleMesh", "ObstacleShape", "ObstacleTrack", "clip_box",
           "obstacle_focus", "obstacle_mesh", "obstacles_at", "read_obstacles"]

#: Colour (RGBA in [0, 1]) of capsules and spheres.
OBSTACLE_COLOR = (0.62, 0.62, 0.64, 1.0)
#: Colour (RGBA in [0, 1]) of planes: translucent.
PLANE_COLOR = (0.55, 0.62, 0.72, 0.3)
#: Vertices round a capsule or sphere.
N_SIDES = 32
#: Quads along each side of a plane's patch.
PLANE_GRID = 16


@dataclass(frozen=True)
class ObstacleShape:
    """An obstacle at one time.

    Attributes
    ----------
    kind:
        ``"capsule"``, ``"sphere"`` or ``"plane"``.
    name:
        Its name in the run file.
    a, b:
        ``(3,)`` m: a capsule's axis end points; a sphere's centre (both); a point of a plane (both).
    radius:
        m (capsules and spheres; 0 for a plane).
    normal:
        ``(3,)`` unit normal of a plane (the side the rods stay on), else None.
    """

    kind: str
    name: str
    a: np.ndarray
    b: np.ndarray
    radius: float = 0.0
    normal: np.ndarray | None = None


@dataclass
class ObstacleTrack:
    """An obstacle of a run and its motion: :meth:`at` gives its shape at a time of the run.

    ``shape`` is its pose at t = 0, ``pivot`` (m) the centre of its rotation at t = 0, ``path`` its
    translation (a :class:`knotsim.bc.paths.Path`, or None) and ``omega`` (rad/s) its prescribed
    angular velocity.
    """

    shape: ObstacleShape
    pivot: np.ndarray
    path: Any = None
    omega: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def moves(self) -> bool:
        """Whether the obstacle has a prescribed motion (it may still look the same, e.g. a post
        turning about its own axis)."""
        return self.path is not None or bool(np.any(self.omega != 0.0))

    def at(self, t: float) -> ObstacleShape:
        """The shape at time ``t`` (s): ``c0 + d(t) + R(ω t) (p − c0)`` for each point ``p`` (the
        pose of :class:`knotsim.contact.obstacles.Obstacle`)."""
        if not self.moves:
            return self.shape
        t = max(float(t), 0.0)
        shift = np.zeros(3) if self.path is None else np.asarray(self.path(t), dtype=np.float64)
        s, c0 = self.shape, self.pivot
        if np.any(self.omega != 0.0):
            from knotsim.contact.obstacles import rotation_matrix

            rot = rotation_matrix(self.omega * t)
        else:
            rot = np.eye(3)

        def move(p):
            return c0 + shift + rot @ (p - c0)

        normal = None if s.normal is None else rot @ s.normal
        return ObstacleShape(s.kind, s.name, move(s.a), move(s.b), s.radius, normal)


def _track(kind: str, name: str, kw: dict) -> ObstacleTrack:
    """An :class:`ObstacleTrack` from one parsed ``[[obstacles]]`` table (``parse_obstacle``)."""
    from knotsim.bc.paths import as_path

    if kind == "plane":
        p = np.asarray(kw.get("point", (0.0, 0.0, 0.0)), dtype=np.float64)
        n = np.asarray(kw.get("normal", (0.0, 0.0, 1.0)), dtype=np.float64)
        if not np.linalg.norm(n) > 0.0:
            raise ConfigError(f"obstacles.{name}.normal", "must not be the zero vector")
        shape = ObstacleShape(kind, name, p, p.copy(), 0.0, n / np.linalg.norm(n))
        ref = p
    elif kind == "sphere":
        c = np.asarray(kw.get("center", (0.0, 0.0, 0.0)), dtype=np.float64)
        shape = ObstacleShape(kind, name, c, c.copy(), float(kw.get("radius", 0.01)))
        ref = c
    else:
        a = np.asarray(kw.get("a", (0.0, 0.0, 0.0)), dtype=np.float64)
        b = np.asarray(kw.get("b", (0.0, 0.0, 1.0)), dtype=np.float64)
        shape = ObstacleShape(kind, name, a, b, float(kw.get("radius", 0.01)))
        ref = 0.5 * (a + b)
    if not shape.radius >= 0.0:
        raise ConfigError(f"obstacles.{name}.radius", f"must be positive, got {shape.radius}")
    pivot = np.asarray(kw["pivot"], dtype=np.float64) if "pivot" in kw else ref
    path = None
    if "path" in kw:
        path = as_path(kw["path"])
        path.bind(pivot)  # a from_current waypoint path starts where the obstacle is, as in Obstacle
    omega = np.asarray(kw.get("angular_velocity", (0.0, 0.0, 0.0)), dtype=np.float64)
    return ObstacleTrack(shape, pivot, path, omega)


def read_obstacles(run_dir: str | os.PathLike) -> list[ObstacleTrack]:
    """The obstacles of the run in ``run_dir``, from the ``[[obstacles]]`` tables of its
    ``run.toml``; empty without that file or without obstacles. A table that cannot be read (a
    run of another version) is left out with a :class:`~knotsim.errors.KnotsimWarning`."""
    import tomllib

    path = Path(run_dir) / "run.toml"
    if not path.is_file():
        return []
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8")).get("obstacles")
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        warnings.warn(f"cannot read the obstacles of {path}: {exc}; the pictures leave them out",
                      KnotsimWarning, stacklevel=2)
        return []
    if not raw:
        return []
    from knotsim.io.config.obstacles import parse_obstacle

    out = []
    for i, table in enumerate(raw if isinstance(raw, list) else [raw]):
        try:
            out.append(_track(*parse_obstacle(table, i)))
        except ConfigError as exc:
            warnings.warn(f"{path}: obstacle {i} is not drawn ({exc})", KnotsimWarning, stacklevel=2)
    return out


def obstacles_at(tracks: Sequence[ObstacleTrack], t: float) -> list[ObstacleShape]:
    """The shapes of ``tracks`` at time ``t`` (s)."""
    return [track.at(t) for track in tracks]


# ---------------------------------------------------------------------------------------- meshes
@dataclass
class ObstacleMesh:
    """Surfaces of obstacles.

    Attributes
    ----------
    vertices, normals:
        ``(V, 3)`` positions (m) and outward unit normals.
    quads:
        ``(Q, 4)`` vertex indices (a pole's quads have two equal vertices: triangles).
    quad_normals:
        ``(Q, 3)`` outward unit normal of each quad.
    quad_obstacle, vertex_obstacle:
        Index (into ``names``) of the obstacle of each quad / vertex.
    names:
        The obstacles drawn.
    rgba:
        ``(n, 4)`` colour of each obstacle in [0, 1] (alpha < 1: translucent).
    two_sided:
        ``(n,)`` whether an obstacle is an open surface seen from both sides (a plane's patch).
    """

    vertices: np.ndarray
    normals: np.ndarray
    quads: np.ndarray
    quad_normals: np.ndarray
    quad_obstacle: np.ndarray
    vertex_obstacle: np.ndarray
    names: list[str]
    rgba: np.ndarray
    two_sided: np.ndarray

    @property
    def empty(self) -> bool:
        return self.quads.shape[0] == 0


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


def _perpendicular(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors ``(e1, e2)`` that make a right-handed basis with the unit vector ``d``: for
    ``d`` along a coordinate axis, the next two axes (a floor's patch along x and y)."""
    k = int(np.argmax(np.abs(d)))
    e = np.zeros(3)
    e[(k + 1) % 3] = 1.0
    e1 = _unit(e - (e @ d) * d)
    return e1, np.cross(d, e1)


def _segment_in_box(a: np.ndarray, b: np.ndarray, box: np.ndarray) -> tuple[float, float] | None:
    """Parameters ``(t0, t1)`` in [0, 1] of the part of the segment ``a + t (b − a)`` inside the
    ``(3, 2)`` box (slab method), or None when it misses it."""
    d = b - a
    t0, t1 = 0.0, 1.0
    for k in range(3):  # three slabs
        if abs(d[k]) < 1e-300:
            if not box[k, 0] <= a[k] <= box[k, 1]:
                return None
            continue
        lo, hi = sorted(((box[k, 0] - a[k]) / d[k], (box[k, 1] - a[k]) / d[k]))
        t0, t1 = max(t0, lo), min(t1, hi)
        if t0 > t1:
            return None
    return t0, t1


def _round_mesh(a, b, radius, cut_a: bool, cut_b: bool, n_sides: int, seg: float):
    """Vertices, normals and quads of a capsule from ``a`` to ``b`` (a sphere when ``a == b``):
    hemispherical ends, or flat ones where the capsule was cut (``cut_a``, ``cut_b``)."""
    axis = b - a
    length = float(np.linalg.norm(axis))
    d = axis / length if length > 0.0 else np.array([0.0, 0.0, 1.0])
    e1, e2 = _perpendicular(d)
    n_lat = max(2, n_sides // 4)
    # rings: (centre along the axis from a (m), ring radius (m), normal's axial and radial parts)
    rings: list[tuple[float, float, float, float]] = []
    if cut_a:
        rings += [(0.0, 0.0, -1.0, 0.0), (0.0, radius, -1.0, 0.0)]
    else:
        phi = 0.5 * np.pi * np.arange(n_lat + 1) / n_lat
        rings += [(-radius * np.cos(f), radius * np.sin(f), -np.cos(f), np.sin(f)) for f in phi]
    if length > 0.0:
        n_ax = int(min(120, max(1, np.ceil(length / seg))))
        rings += [(s, radius, 0.0, 1.0) for s in np.linspace(0.0, length, n_ax + 1)]
    if cut_b:
        rings += [(length, radius, 1.0, 0.0), (length, 0.0, 1.0, 0.0)]
    else:
        phi = 0.5 * np.pi * np.arange(n_lat, -1, -1) / n_lat
        start = 1 if length == 0.0 else 0  # a sphere: the equator is already there
        rings += [(length + radius * np.cos(f), radius * np.sin(f), np.cos(f), np.sin(f)) for f in phi[start:]]
    r = np.array(rings)
    ang = 2.0 * np.pi * np.arange(n_sides) / n_sides
    radial = np.cos(ang)[:, None] * e1 + np.sin(ang)[:, None] * e2  # (S, 3)
    verts = a + r[:, 0, None, None] * d + r[:, 1, None, None] * radial[None]  # (M, S, 3)
    norms = r[:, 2, None, None] * d + r[:, 3, None, None] * radial[None]
    m = r.shape[0]
    i = np.arange(m - 1)[:, None]
    j = np.arange(n_sides)[None, :]
    j1 = (j + 1) % n_sides
    quads = np.stack([i * n_sides + j, i * n_sides + j1, (i + 1) * n_sides + j1, (i + 1) * n_sides + j],
                     axis=-1).reshape(-1, 4)
    return verts.reshape(-1, 3), _unit(norms.reshape(-1, 3)), quads


def _plane_mesh(point, normal, region: np.ndarray, grid: int):
    """A square patch of the plane round the ``(3, 2)`` region: centred on the region's centre
    projected onto the plane, 1.5 times the region's diagonal across; ``grid`` x ``grid`` quads."""
    mid = region.mean(axis=1)
    centre = mid - ((mid - point) @ normal) * normal
    half = 0.75 * float(np.linalg.norm(region[:, 1] - region[:, 0]))
    half = half if half > 0.0 else 1.0
    u, v = _perpendicular(normal)
    s = np.linspace(-half, half, grid + 1)
    verts = centre + s[:, None, None] * u + s[None, :, None] * v  # (g+1, g+1, 3)
    i = np.arange(grid)[:, None]
    j = np.arange(grid)[None, :]
    n = grid + 1
    quads = np.stack([i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1], axis=-1).reshape(-1, 4)
    verts = verts.reshape(-1, 3)
    return verts, np.repeat(normal[None], verts.shape[0], axis=0), quads


def clip_box(box: np.ndarray, size: tuple[int, int] | None = None) -> np.ndarray:
    """``(3, 2)`` box (m) beyond which an obstacle is cut: the framed ``box`` grown about its centre
    to a cube well beyond what a picture of ``size`` ``(w, h)`` pixels shows of it."""
    box = np.asarray(box, dtype=np.float64)
    mid = box.mean(axis=1)
    half = 0.5 * float(np.linalg.norm(box[:, 1] - box[:, 0]))
    aspect = 1.0 if size is None else max(size[0] / size[1], size[1] / size[0])
    reach = 2.5 * max(half, 1e-9) * aspect
    return np.stack([mid - reach, mid + reach], axis=1)


def obstacle_mesh(shapes: Sequence[ObstacleShape], region: np.ndarray, clip: np.ndarray | None = None, *,
                  n_sides: int = N_SIDES, grid: int = PLANE_GRID) -> ObstacleMesh:
    """The surfaces of ``shapes`` (see the module docstring).

    Parameters
    ----------
    shapes:
        The obstacles at the pictured time.
    region:
        ``(3, 2)`` box (m) the picture is framed on: a plane's patch is drawn round it.
    clip:
        ``(3, 2)`` box (m): a capsule is cut (flat ends) where its axis leaves it (grown by its
        radius), and an obstacle wholly outside it is left out; default :func:`clip_box` of ``region``.
    n_sides:
        Vertices round a capsule or sphere.
    grid:
        Quads along each side of a plane's patch.
    """
    region = np.asarray(region, dtype=np.float64)
    clip = clip_box(region) if clip is None else np.asarray(clip, dtype=np.float64)
    V: list[np.ndarray] = []
    N: list[np.ndarray] = []
    Q: list[np.ndarray] = []
    QO: list[np.ndarray] = []
    VO: list[np.ndarray] = []
    names: list[str] = []
    rgba: list[tuple[float, ...]] = []
    two: list[bool] = []
    offset = 0
    for s in shapes:  # a loop over the obstacles (a handful)
        if s.kind == "plane":
            verts, norms, quads = _plane_mesh(np.asarray(s.a, float), _unit(np.asarray(s.normal, float)), region,
                                              int(grid))
            color, both = PLANE_COLOR, True
        else:
            a, b, r = np.asarray(s.a, float), np.asarray(s.b, float), float(s.radius)
            if not r > 0.0:
                continue
            grown = clip + np.array([-r, r])
            span = _segment_in_box(a, b, grown)
            if span is None:
                continue
            t0, t1 = span
            a2, b2 = a + t0 * (b - a), a + t1 * (b - a)
            seg = 1.5 * 2.0 * np.pi * r / int(n_sides)
            verts, norms, quads = _round_mesh(a2, b2, r, t0 > 0.0, t1 < 1.0, int(n_sides), seg)
            color, both = OBSTACLE_COLOR, False
        k = len(names)
        V.append(verts)
        N.append(norms)
        Q.append(quads + offset)
        QO.append(np.full(quads.shape[0], k))
        VO.append(np.full(verts.shape[0], k))
        names.append(s.name)
        rgba.append(color)
        two.append(both)
        offset += verts.shape[0]
    if not names:
        return ObstacleMesh(np.empty((0, 3)), np.empty((0, 3)), np.empty((0, 4), np.int64), np.empty((0, 3)),
                            np.empty(0, np.int64), np.empty(0, np.int64), [], np.empty((0, 4)), np.empty(0, bool))
    verts, norms, quads = np.concatenate(V), np.concatenate(N), np.concatenate(Q).astype(np.int64)
    qo = np.concatenate(QO).astype(np.int64)
    # drop the quads of no area (between the two rings of a flat end's rim); a pole's stay (triangles)
    p = verts[quads]
    area = np.linalg.norm(np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1]), axis=1)
    largest = np.zeros(len(names))
    np.maximum.at(largest, qo, area)
    keep = area > 1e-9 * largest[qo]
    quads, qo = quads[keep], qo[keep]
    return ObstacleMesh(verts, norms, quads, _unit(norms[quads].sum(axis=1)), qo, np.concatenate(VO).astype(np.int64),
                        names, np.array(rgba, dtype=np.float64), np.array(two, dtype=bool))


# --------------------------------------------------------------------------------------- framing
def obstacle_focus(box: np.ndarray, shapes: Sequence[ObstacleShape], centerlines: Sequence[np.ndarray],
                   radii: Any, *, tol: float | None = None) -> np.ndarray:
    """The knot's ``(3, 2)`` ``box`` (m) grown to hold the part of each capsule or sphere that the
    ropes touch inside it: for a capsule, its full thickness along the stretch of axis under those
    nodes; for a sphere, the points of its surface under them. Planes never grow it (a rope lying
    on a floor touches it all along). Nodes touch an obstacle within ``(r + R)(1 + tol)``
    (``tol`` default :data:`knotsim.viz.framing.CONTACT_TOL`) of its axis or centre."""
    from knotsim.viz.framing import CONTACT_TOL

    tol = CONTACT_TOL if tol is None else float(tol)
    box = np.asarray(box, dtype=np.float64)
    lines = [np.asarray(c, dtype=np.float64).reshape(-1, 3) for c in centerlines]
    rad = np.broadcast_to(np.asarray(radii, dtype=np.float64), (len(lines),))
    x = np.concatenate(lines)
    r = np.repeat(rad, [c.shape[0] for c in lines])
    inside = np.all((x >= box[:, 0]) & (x <= box[:, 1]), axis=1)
    x, r = x[inside], r[inside]
    out = box.copy()
    for s in shapes:  # a loop over the obstacles
        if s.kind == "plane" or not s.radius > 0.0 or not x.size:
            continue
        a, b, R = np.asarray(s.a, float), np.asarray(s.b, float), float(s.radius)
        d = b - a
        L2 = float(d @ d)
        t = np.clip(((x - a) @ d) / L2, 0.0, 1.0) if L2 > 0.0 else np.zeros(x.shape[0])
        foot = a + t[:, None] * d
        dist = np.linalg.norm(x - foot, axis=1)
        near = dist <= (r + R) * (1.0 + tol)
        if not near.any():
            continue
        if s.kind == "capsule" and L2 > 0.0:
            ends = a + np.array([t[near].min(), t[near].max()])[:, None] * d
            pts = np.vstack([ends - R, ends + R])
        else:
            pts = foot[near] + R * _unit(x[near] - foot[near])
        out = np.stack([np.minimum(out[:, 0], pts.min(axis=0)), np.maximum(out[:, 1], pts.max(axis=0))], axis=1)
    return out
