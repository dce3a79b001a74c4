"""Render rods as shaded tubes to PNG images.

Two backends draw the same tube surface (built here, so both look alike):

``"pyvista"`` (optional dependency, ``pip install knotsim[render]``)
    OpenGL rendering off screen, smooth shading with per-vertex normals. On Linux without a
    display, ``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow`` is set (unless already set) before
    ``vtk`` is first imported, so that it renders headless through EGL.
``"matplotlib"`` (always available)
    All tube quads of all rods go into a single ``Poly3DCollection`` with Lambert + specular
    shading computed per quad; matplotlib's depth sort of that one collection makes crossing
    ropes occlude each other correctly. Back faces are culled first (the tubes are closed
    surfaces), which halves the work and removes most sorting artefacts.

``backend="auto"`` uses pyvista when it can be imported and falls back to matplotlib otherwise
(or, with a warning, when pyvista fails to render).

The tube around a centerline is built on a rotation-minimising frame (double-reflection method);
for a closed rod the frame's holonomy is spread evenly along the loop, so rings have no seam.
Open rods get flat end caps. Centerlines are first refined with a Catmull-Rom spline through the
nodes (``subdivisions`` points per segment) so that coarse rods still look round.

View convention (degrees, as matplotlib's ``view_init``): ``"iso"`` = (30, -60),
``"top"`` = (90, -90) looking down -z with x to the right and y up, ``"front"`` = (0, -90)
looking along +y with x to the right and z up, or any ``(elev, azim)`` tuple.
"""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from knotsim.errors import ConfigError

__all__ = [
    "DEFAULT_COLORS",
    "VIEWS",
    "TubeMesh",
    "render_frame",
    "render_run",
    "trajectory_bounds",
    "tube_mesh",
]

VIEWS: dict[str, tuple[float, float]] = {"iso": (30.0, -60.0), "top": (90.0, -90.0), "front": (0.0, -90.0)}

DEFAULT_COLORS: tuple[str, ...] = (
    "#d62728",  # red
    "#1f77b4",  # blue
    "#e8b90c",  # yellow
    "#2ca02c",  # green
    "#9467bd",  # purple
    "#ff7f0e",  # orange
    "#17becf",  # cyan
    "#8c564b",  # brown
)

_BACKGROUND = (1.0, 1.0, 1.0)


# ---------------------------------------------------------------------------- geometry
def _subdivide(points: np.ndarray, closed: bool, n_sub: int, values: np.ndarray | None):
    """Catmull-Rom refinement: ``n_sub`` points per segment (the nodes are kept).

    ``values`` (``(N,)`` scalars at the nodes, or None) are interpolated linearly.
    """
    p = np.asarray(points, dtype=np.float64)
    n = p.shape[0]
    if n_sub <= 1 or n < 2:
        return p.copy(), (None if values is None else np.asarray(values, dtype=np.float64).copy())
    if closed:
        ext = np.concatenate([p[-1:], p, p[:2]])
        n_seg = n
    else:
        ext = np.concatenate([2 * p[:1] - p[1:2], p, 2 * p[-1:] - p[-2:-1]])
        n_seg = n - 1
    s = np.arange(n_sub) / n_sub  # (n_sub,)
    p0, p1, p2, p3 = (ext[i : i + n_seg][:, None, :] for i in range(4))
    s2, s3 = (s**2)[None, :, None], (s**3)[None, :, None]
    s1 = s[None, :, None]
    pts = 0.5 * (
        2 * p1 + (-p0 + p2) * s1 + (2 * p0 - 5 * p1 + 4 * p2 - p3) * s2 + (-p0 + 3 * p1 - 3 * p2 + p3) * s3
    ).reshape(-1, 3)
    vals = None
    if values is not None:
        v = np.asarray(values, dtype=np.float64).reshape(-1)
        v_next = np.roll(v, -1) if closed else v[1:]
        v_cur = v if closed else v[:-1]
        vals = (v_cur[:, None] * (1 - s[None, :]) + v_next[:, None] * s[None, :]).reshape(-1)
    if not closed:
        pts = np.concatenate([pts, p[-1:]])
        if vals is not None:
            vals = np.append(vals, v[-1])
    return pts, vals


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


def _node_tangents(p: np.ndarray, closed: bool) -> np.ndarray:
    e = _unit((np.roll(p, -1, axis=0) - p) if closed else np.diff(p, axis=0))
    if closed:
        t = e + np.roll(e, 1, axis=0)
    else:
        t = np.empty_like(p)
        t[0], t[-1] = e[0], e[-1]
        t[1:-1] = e[:-1] + e[1:]
    bad = np.linalg.norm(t, axis=1) < 1e-12  # hairpin: fall back to the outgoing edge
    if np.any(bad):
        t[bad] = (e if closed else np.vstack([e, e[-1:]]))[bad]
    return _unit(t)


def _rotation_minimizing_frame(p: np.ndarray, t: np.ndarray, closed: bool) -> np.ndarray:
    """``(M, 3)`` unit normals ``n_i`` perpendicular to ``t_i``, transported with minimal rotation.

    Double-reflection method (Wang, Juettler, Zheng & Liu 2008). For closed curves the angle
    mismatch after one loop is removed by a rotation growing linearly with arc length.
    """
    m = p.shape[0]
    a = np.array([1.0, 0.0, 0.0]) if abs(t[0, 0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    r = np.empty_like(p)
    r[0] = _unit(a - np.dot(a, t[0]) * t[0])
    n_steps = m if closed else m - 1

    def step(ri, xi, xj, ti, tj):
        v1 = xj - xi
        c1 = v1 @ v1
        if c1 < 1e-300:
            return ri
        rl = ri - (2.0 / c1) * (v1 @ ri) * v1
        tl = ti - (2.0 / c1) * (v1 @ ti) * v1
        v2 = tj - tl
        c2 = v2 @ v2
        rj = rl if c2 < 1e-300 else rl - (2.0 / c2) * (v2 @ rl) * v2
        rj = rj - (rj @ tj) * tj
        return rj / max(np.linalg.norm(rj), 1e-300)

    for i in range(min(n_steps, m - 1)):
        r[i + 1] = step(r[i], p[i], p[i + 1], t[i], t[i + 1])
    if closed and m > 2:
        r_end = step(r[m - 1], p[m - 1], p[0], t[m - 1], t[0])
        b0 = np.cross(t[0], r[0])
        phi = np.arctan2(r_end @ b0, r_end @ r[0])  # angle of r_end from r[0] about t[0]
        seg = np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)
        s = np.concatenate([[0.0], np.cumsum(seg[:-1])]) / max(seg.sum(), 1e-300)
        ang = -phi * s
        b = np.cross(t, r)
        r = np.cos(ang)[:, None] * r + np.sin(ang)[:, None] * b
    return r


@dataclass
class TubeMesh:
    """Surface of one or more tubes.

    Attributes
    ----------
    vertices:
        ``(V, 3)`` positions (m).
    normals:
        ``(V, 3)`` outward unit normals at the vertices.
    quads:
        ``(Q, 4)`` vertex indices of the side quads (counter-clockwise seen from outside).
    quad_normals:
        ``(Q, 3)`` outward unit normal of each quad.
    tris:
        ``(C, 3)`` vertex indices of end-cap triangles.
    vertex_rod, quad_rod, tri_rod:
        Rod index of each vertex / quad / triangle.
    vertex_values, quad_values, tri_values:
        Scalar per vertex / quad / triangle, or None when no scalars were given.
    """

    vertices: np.ndarray
    normals: np.ndarray
    quads: np.ndarray
    quad_normals: np.ndarray
    tris: np.ndarray
    vertex_rod: np.ndarray
    quad_rod: np.ndarray
    tri_rod: np.ndarray
    vertex_values: np.ndarray | None = None
    quad_values: np.ndarray | None = None
    tri_values: np.ndarray | None = None


def tube_mesh(
    centerlines: Sequence[np.ndarray],
    radii: Sequence[float],
    closed: Sequence[bool],
    scalars: Sequence[np.ndarray] | None = None,
    subdivisions: int = 3,
    n_sides: int = 12,
) -> TubeMesh:
    """Build the tube surfaces around centerlines.

    Parameters
    ----------
    centerlines:
        One ``(N_k, 3)`` array of node positions (m) per rod.
    radii:
        Tube radius (m) of each rod.
    closed:
        Whether each rod is a ring.
    scalars:
        Optional ``(N_k,)`` node values per rod, interpolated onto the surface.
    subdivisions:
        Spline points per centerline segment (1: use the nodes only).
    n_sides:
        Vertices per ring around the tube.
    """
    n_sides = int(n_sides)
    if n_sides < 3:
        raise ConfigError("n_sides", f"must be >= 3, got {n_sides}")
    ang = 2 * np.pi * np.arange(n_sides) / n_sides
    cos_a, sin_a = np.cos(ang), np.sin(ang)
    V, N, Q, QN, T, VR, QR, TR, VV, QV, TV = ([] for _ in range(11))
    offset = 0
    for k, (line, radius, is_closed) in enumerate(zip(centerlines, radii, closed, strict=True)):
        vals_in = None if scalars is None else np.asarray(scalars[k], dtype=np.float64).reshape(-1)
        p, vals = _subdivide(line, bool(is_closed), int(subdivisions), vals_in)
        m = p.shape[0]
        t = _node_tangents(p, bool(is_closed))
        nrm = _rotation_minimizing_frame(p, t, bool(is_closed))
        bin_ = np.cross(t, nrm)
        radial = cos_a[None, :, None] * nrm[:, None, :] + sin_a[None, :, None] * bin_[:, None, :]  # (m,S,3)
        ring = p[:, None, :] + float(radius) * radial
        V.append(ring.reshape(-1, 3))
        N.append(radial.reshape(-1, 3))
        VR.append(np.full(m * n_sides, k))
        if vals is not None:
            VV.append(np.repeat(vals, n_sides))
        n_seg = m if is_closed else m - 1
        i = np.arange(n_seg)[:, None]
        j = np.arange(n_sides)[None, :]
        i1, j1 = (i + 1) % m, (j + 1) % n_sides
        quads = np.stack(
            [i * n_sides + j, i * n_sides + j1, i1 * n_sides + j1, i1 * n_sides + j], axis=-1
        ).reshape(-1, 4)
        radial_flat = radial.reshape(-1, 3)
        Q.append(quads + offset)
        QN.append(_unit(radial_flat[quads].sum(axis=1)))
        QR.append(np.full(quads.shape[0], k))
        if vals is not None:
            QV.append(0.5 * (vals[:n_seg, None] + vals[(np.arange(n_seg) + 1) % m, None]).repeat(n_sides))
        offset += m * n_sides
        if not is_closed:  # flat end caps: centre + duplicated ring with axial normals
            for end, sign in ((0, -1.0), (m - 1, 1.0)):
                cap = np.vstack([p[end][None], ring[end]])
                V.append(cap)
                N.append(np.repeat(sign * t[end][None], n_sides + 1, axis=0))
                VR.append(np.full(n_sides + 1, k))
                jj = np.arange(n_sides)
                a_, b_ = 1 + jj, 1 + (jj + 1) % n_sides
                tri = np.stack(
                    [np.zeros_like(jj), a_, b_] if sign > 0 else [np.zeros_like(jj), b_, a_], axis=-1
                )
                T.append(tri + offset)
                TR.append(np.full(n_sides, k))
                if vals is not None:
                    VV.append(np.full(n_sides + 1, vals[end]))
                    TV.append(np.full(n_sides, vals[end]))
                offset += n_sides + 1
    has_vals = scalars is not None

    def cat(lst, shape, dtype=np.float64):
        return np.concatenate(lst) if lst else np.empty(shape, dtype=dtype)

    return TubeMesh(
        vertices=cat(V, (0, 3)),
        normals=cat(N, (0, 3)),
        quads=cat(Q, (0, 4), np.int64).astype(np.int64),
        quad_normals=cat(QN, (0, 3)),
        tris=cat(T, (0, 3), np.int64).astype(np.int64),
        vertex_rod=cat(VR, (0,), np.int64).astype(np.int64),
        quad_rod=cat(QR, (0,), np.int64).astype(np.int64),
        tri_rod=cat(TR, (0,), np.int64).astype(np.int64),
        vertex_values=cat(VV, (0,)) if has_vals else None,
        quad_values=cat(QV, (0,)) if has_vals else None,
        tri_values=cat(TV, (0,)) if has_vals else None,
    )


# ---------------------------------------------------------------------------- options
def _view_angles(view: Any) -> tuple[float, float]:
    if isinstance(view, str):
        if view not in VIEWS:
            raise ConfigError("view", f"must be one of {sorted(VIEWS)} or (elev, azim), got {view!r}")
        return VIEWS[view]
    try:
        elev, azim = (float(v) for v in view)
    except (TypeError, ValueError):
        raise ConfigError("view", f"must be one of {sorted(VIEWS)} or (elev, azim), got {view!r}") from None
    return elev, azim


def _camera_basis(elev: float, azim: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit vectors (towards viewer, screen right, screen up) for matplotlib-style angles (deg)."""
    e, a = np.radians(elev), np.radians(azim)
    towards = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    right = np.array([-np.sin(a), np.cos(a), 0.0])
    up = np.cross(towards, right)
    return towards, right, up


def _prepare(
    centerlines: Sequence[np.ndarray],
    radii: Any,
    closed: Any,
    colors: Any,
    color_by: str | None,
    scalars: Any,
):
    lines = [np.asarray(c, dtype=np.float64).reshape(-1, 3) for c in centerlines]
    n = len(lines)
    if n == 0:
        raise ConfigError("centerlines", "need at least one rod")
    for k, c in enumerate(lines):
        if c.shape[0] < 2 or not np.all(np.isfinite(c)):
            raise ConfigError("centerlines", f"rod {k} needs >= 2 finite points, got shape {c.shape}")
    rad = np.broadcast_to(np.asarray(radii, dtype=np.float64), (n,)).copy()
    if np.any(~np.isfinite(rad)) or np.any(rad <= 0):
        raise ConfigError("radii", f"must be positive (m), got {rad.tolist()}")
    cl = [False] * n if closed is None else [bool(x) for x in np.broadcast_to(np.asarray(closed), (n,))]
    if colors is None:
        cols = [DEFAULT_COLORS[k % len(DEFAULT_COLORS)] for k in range(n)]
    elif isinstance(colors, str) or (len(colors) in (3, 4) and np.isscalar(colors[0])):
        cols = [colors] * n
    else:
        cols = list(colors)
        if len(cols) != n:
            raise ConfigError("colors", f"need {n} colours, got {len(cols)}")
    from matplotlib.colors import to_rgb

    try:
        rgb = np.array([to_rgb(c) for c in cols])
    except ValueError as exc:
        raise ConfigError("colors", str(exc)) from None
    vals = None
    label = None
    if scalars is not None:
        vals = [np.asarray(s, dtype=np.float64).reshape(-1) for s in scalars]
        if len(vals) != n or any(v.size != c.shape[0] for v, c in zip(vals, lines, strict=True)):
            raise ConfigError("scalars", "need one (N_k,) array per rod, matching the centerlines")
        label = color_by if isinstance(color_by, str) else "value"
    elif color_by is not None:
        if color_by != "bending_strain":
            raise ConfigError("color_by", f"must be None or 'bending_strain', got {color_by!r}")
        from knotsim.io.vtk import node_bending_strain

        vals = [node_bending_strain(c, r, is_c) for c, r, is_c in zip(lines, rad, cl, strict=True)]
        label = "bending strain"
    return lines, rad, cl, rgb, vals, label


def _bounds(lines: list[np.ndarray], rad: np.ndarray, bounds: Any) -> np.ndarray:
    """``(3, 2)`` axis-aligned box (m) around all tubes, or the given one."""
    if bounds is not None:
        b = np.asarray(bounds, dtype=np.float64)
        if b.shape != (3, 2) or not np.all(np.isfinite(b)) or np.any(b[:, 1] < b[:, 0]):
            raise ConfigError("bounds", f"must be ((xmin, xmax), (ymin, ymax), (zmin, zmax)), got {bounds!r}")
        return b
    lo = np.min([c.min(axis=0) - r for c, r in zip(lines, rad, strict=True)], axis=0)
    hi = np.max([c.max(axis=0) + r for c, r in zip(lines, rad, strict=True)], axis=0)
    return np.stack([lo, hi], axis=1)


def _clim(vals: list[np.ndarray], clim: Any) -> tuple[float, float]:
    if clim is not None:
        lo, hi = (float(x) for x in clim)
    else:
        allv = np.concatenate(vals)
        lo, hi = float(np.nanmin(allv)), float(np.nanmax(allv))
    if not hi > lo:
        hi = lo + 1e-12 if lo == 0 else lo + abs(lo) * 1e-6
    return lo, hi


# ---------------------------------------------------------------------------- matplotlib backend
def _render_matplotlib(
    mesh: TubeMesh, rgb, box, fit, view, size, title, cmap, clim, label, dpi
) -> np.ndarray:
    from matplotlib import colormaps
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d import proj3d
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    w, h = size
    elev, azim = view
    towards, right, up = _camera_basis(elev, azim)
    light = _unit(towards + 0.6 * up - 0.4 * right)
    half = _unit(light + towards)

    # polygons: side quads + caps (triangles padded to quads by repeating a vertex)
    polys = mesh.quads
    normals = mesh.quad_normals
    rods = mesh.quad_rod
    values = mesh.quad_values
    if mesh.tris.size:
        polys = np.vstack([polys, mesh.tris[:, [0, 1, 2, 2]]])
        normals = np.vstack([normals, mesh.normals[mesh.tris[:, 0]]])
        rods = np.concatenate([rods, mesh.tri_rod])
        if values is not None:
            values = np.concatenate([values, mesh.tri_values])
    facing = normals @ towards
    keep = facing > -0.2  # cull back faces of the closed tube surfaces
    polys, normals, rods = polys[keep], normals[keep], rods[keep]
    if values is not None:
        values = values[keep]

    cm = colormaps[cmap] if isinstance(cmap, str) else cmap
    norm = None
    if values is not None:
        norm = Normalize(*clim)
        base = cm(norm(values))[:, :3]
    else:
        base = rgb[rods]
    diffuse = np.clip(normals @ light, 0.0, None)
    spec = np.clip(normals @ half, 0.0, None) ** 24
    shade = base * (0.28 + 0.72 * diffuse)[:, None] + 0.3 * spec[:, None]
    face = np.concatenate([np.clip(shade, 0, 1), np.ones((shade.shape[0], 1))], axis=1)

    fig = Figure(figsize=(w / dpi, h / dpi), dpi=dpi, facecolor=_BACKGROUND)
    canvas = FigureCanvasAgg(fig)
    right_frac = 1.0 - (min(0.3, 95.0 / w) if values is not None else 0.0)
    top_frac = 1.0 - (min(0.12, 36.0 / h) if title else 0.0)
    ax = fig.add_axes((0.0, 0.0, right_frac, top_frac), projection="3d", facecolor=_BACKGROUND)
    ax.set_proj_type("ortho")
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
    pad = 0.02 * float(np.max(box[:, 1] - box[:, 0]))
    lo, hi = box[:, 0] - pad, box[:, 1] + pad
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_autoscale_on(False)
    aspect = hi - lo
    ax.set_box_aspect(tuple(aspect))
    if title:
        fig.text(
            0.5,
            1.0 - 0.5 * (1.0 - top_frac),
            title,
            ha="center",
            va="center",
            fontsize=max(6, min(14, h / 40)),
        )

    # frame the view: pan (shift the axis limits in the screen plane) so that the projected
    # points `fit` are centred, and zoom so that they fill ~92 % of the axes box. Measured on
    # cheap draws without the tubes; two passes absorb matplotlib's small off-centre zoom.
    # (The 3D axes draws in a square inside its position box; the image may use the whole box.)
    bbox = ax.get_position(original=True).transformed(fig.transFigure)
    cx, cy = 0.5 * (bbox.x0 + bbox.x1), 0.5 * (bbox.y0 + bbox.y1)
    zoom = 1.0
    probe = np.vstack([fit, fit.mean(axis=0), fit.mean(axis=0) + right])
    for _ in range(2):
        canvas.draw()
        xs, ys, _z = proj3d.proj_transform(probe[:, 0], probe[:, 1], probe[:, 2], ax.get_proj())
        pix = ax.transData.transform(np.column_stack([xs, ys]))
        per_metre = max(float(np.linalg.norm(pix[-1] - pix[-2])), 1e-300)
        pix = pix[:-2]
        lo_p, hi_p = pix.min(axis=0), pix.max(axis=0)
        off = 0.5 * (lo_p + hi_p) - (cx, cy)
        shift = (off[0] * right + off[1] * up) / per_metre
        lo, hi = lo + shift, hi + shift
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        half = np.maximum(0.5 * (hi_p - lo_p), 1e-9)
        zoom *= 0.92 * min(0.5 * bbox.width / half[0], 0.5 * bbox.height / half[1])
        ax.set_box_aspect(tuple(aspect), zoom=float(zoom))

    coll = Poly3DCollection(mesh.vertices[polys], facecolors=face, edgecolors=face, linewidths=0.25)
    coll.set_zsort("average")
    coll.set_clip_on(False)  # the 3D axes clips to a square; the image may use its whole box
    ax.add_collection3d(coll, autolim=False)
    if values is not None:
        cax = fig.add_axes((right_frac, 0.15, min(0.04, 14.0 / w), 0.7 * top_frac))
        fig.colorbar(ScalarMappable(norm=norm, cmap=cm), cax=cax, label=label)
    canvas.draw()
    img = np.asarray(canvas.buffer_rgba())[..., :3].copy()
    fig.clear()
    return img


# ---------------------------------------------------------------------------- pyvista backend
def _import_pyvista():
    if sys.platform.startswith("linux") and not os.environ.get("DISPLAY") and "vtkmodules" not in sys.modules:
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista

    return pyvista


def _render_pyvista(mesh: TubeMesh, rgb, fit, view, size, title, cmap, clim, label) -> np.ndarray:
    pv = _import_pyvista()
    w, h = size
    elev, azim = view
    towards, right, up = _camera_basis(elev, azim)

    def polydata(quads, tris, sel=None):
        verts, normals, vals = mesh.vertices, mesh.normals, mesh.vertex_values
        if sel is not None:  # keep only vertices `sel`, renumbered
            remap = np.full(len(verts), -1, dtype=np.int64)
            remap[sel] = np.arange(sel.size)
            verts, normals, quads, tris = verts[sel], normals[sel], remap[quads], remap[tris]
            vals = None if vals is None else vals[sel]
        faces = [np.column_stack([np.full(len(quads), 4), quads]).ravel()]
        if tris.size:
            faces.append(np.column_stack([np.full(len(tris), 3), tris]).ravel())
        surf = pv.PolyData(verts, np.concatenate(faces))
        surf.point_data.active_normals = normals
        if vals is not None:
            surf.point_data[label] = vals
        return surf

    plotter = pv.Plotter(off_screen=True, window_size=[w, h])
    try:
        plotter.set_background(_BACKGROUND)
        shading = {"smooth_shading": True, "specular": 0.3, "specular_power": 24.0}
        if mesh.vertex_values is not None:
            plotter.add_mesh(
                polydata(mesh.quads, mesh.tris),
                scalars=label,
                cmap=cmap,
                clim=list(clim),
                scalar_bar_args={
                    "title": label,
                    "vertical": True,
                    "color": "black",
                    "position_x": 1.0 - min(0.3, 95.0 / w) + 0.01,
                    "position_y": 0.12,
                    "width": min(0.06, 20.0 / w),
                    "height": 0.7,
                },
                **shading,
            )
        else:
            for k in range(rgb.shape[0]):
                sel = np.flatnonzero(mesh.vertex_rod == k)
                if sel.size:
                    part = polydata(mesh.quads[mesh.quad_rod == k], mesh.tris[mesh.tri_rod == k], sel)
                    plotter.add_mesh(part, color=tuple(rgb[k]), **shading)
        # parallel projection framed on the projected extent of `fit`, leaving room for the
        # title (top) and the colour bar (right)
        a_w = 1.0 - (min(0.3, 95.0 / w) if mesh.vertex_values is not None else 0.0)
        a_h = 1.0 - (min(0.12, 36.0 / h) if title else 0.0)
        u, v = fit @ right, fit @ up
        u_mid, v_mid = 0.5 * (u.min() + u.max()), 0.5 * (v.min() + v.max())
        half_u = max(0.5 * (u.max() - u.min()), 1e-12)
        half_v = max(0.5 * (v.max() - v.min()), 1e-12)
        scale = max(half_v / (0.94 * a_h), half_u * h / (0.94 * a_w * w))
        d = fit @ towards
        target = u_mid * right + v_mid * up + float(d.mean()) * towards
        focal = target + right * (1.0 - a_w) * scale * w / h + up * (1.0 - a_h) * scale
        depth = float(d.max() - d.min()) + 2.0 * scale
        plotter.enable_parallel_projection()
        plotter.camera_position = [tuple(focal + 2.0 * depth * towards), tuple(focal), tuple(up)]
        plotter.camera.parallel_scale = scale
        plotter.camera.clipping_range = (1e-3 * depth, 4.0 * depth)
        if title:
            plotter.add_text(title, position="upper_edge", font_size=max(6, min(14, h // 45)), color="black")
        img = plotter.screenshot(return_img=True)
    finally:
        plotter.close()
    return np.asarray(img)[..., :3]


# ---------------------------------------------------------------------------- public API
def _render_array(
    centerlines: Sequence[np.ndarray],
    radii: Any,
    closed: Any = None,
    colors: Any = None,
    color_by: str | None = None,
    scalars: Any = None,
    view: Any = "iso",
    size: tuple[int, int] = (800, 600),
    backend: str = "auto",
    title: str | None = None,
    *,
    cmap: Any = "viridis",
    clim: Any = None,
    bounds: Any = None,
    subdivisions: int = 3,
    n_sides: int = 12,
    dpi: int = 100,
) -> np.ndarray:
    """Render to an ``(h, w, 3)`` uint8 RGB array; arguments as :func:`render_frame`."""
    if backend not in ("auto", "pyvista", "matplotlib"):
        raise ConfigError("backend", f"must be 'auto', 'pyvista' or 'matplotlib', got {backend!r}")
    try:
        w, h = (int(s) for s in size)
    except (TypeError, ValueError):
        raise ConfigError("size", f"must be (width, height) in pixels, got {size!r}") from None
    if w < 16 or h < 16:
        raise ConfigError("size", f"must be at least 16x16 pixels, got {size!r}")
    ang = _view_angles(view)
    lines, rad, cl, rgb, vals, label = _prepare(centerlines, radii, closed, colors, color_by, scalars)
    box = _bounds(lines, rad, bounds)
    lim = _clim(vals, clim) if vals is not None else None
    mesh = tube_mesh(lines, rad, cl, vals, subdivisions=subdivisions, n_sides=n_sides)
    # points the view is framed on: the tubes, or the corners of a fixed box
    fit = mesh.vertices if bounds is None else np.array(np.meshgrid(*box, indexing="ij")).reshape(3, -1).T

    use = backend
    if backend == "auto":
        try:
            _import_pyvista()
            use = "pyvista"
        except ImportError:
            use = "matplotlib"
    if use == "pyvista":
        try:
            img = _render_pyvista(mesh, rgb, fit, ang, (w, h), title, cmap, lim, label)
        except ImportError as exc:
            raise ImportError(
                "the pyvista backend needs pyvista: pip install knotsim[render] (or use backend='matplotlib')"
            ) from exc
        except Exception as exc:  # any OpenGL / VTK failure
            if backend != "auto":
                raise
            warnings.warn(f"pyvista rendering failed ({exc}); falling back to matplotlib", stacklevel=3)
            use = "matplotlib"
    if use == "matplotlib":
        img = _render_matplotlib(mesh, rgb, box, fit, ang, (w, h), title, cmap, lim, label, int(dpi))
    img = np.ascontiguousarray(img, dtype=np.uint8)
    if img.shape[:2] != (h, w):  # guard against rounding in backends: pad / crop to the exact size
        out = np.full((h, w, 3), 255, dtype=np.uint8)
        hh, ww = min(h, img.shape[0]), min(w, img.shape[1])
        out[:hh, :ww] = img[:hh, :ww]
        img = out
    return img


def render_frame(
    centerlines: Sequence[np.ndarray],
    radii: float | Sequence[float],
    out_png: str | os.PathLike,
    closed: bool | Sequence[bool] | None = None,
    colors: Any = None,
    color_by: str | None = None,
    scalars: Sequence[np.ndarray] | None = None,
    view: str | tuple[float, float] = "iso",
    size: tuple[int, int] = (800, 600),
    backend: str = "auto",
    title: str | None = None,
    **options: Any,
) -> Path:
    """Render rods as shaded tubes to a PNG file.

    Parameters
    ----------
    centerlines:
        One ``(N_k, 3)`` array of node positions (m) per rod.
    radii:
        Tube radius (m) per rod, or one radius for all.
    out_png:
        Output PNG path (parent directories are created).
    closed:
        Per rod (or one value for all): whether the rod is a ring. ``None``: all open.
    colors:
        One matplotlib colour per rod, or one colour for all; default: a rope palette.
    color_by:
        ``None`` (plain colours) or ``"bending_strain"`` (curvature x radius, see
        :func:`knotsim.io.vtk.node_curvature`) mapped through ``cmap``; with ``scalars`` given it
        is only the colour-bar label.
    scalars:
        Optional ``(N_k,)`` node values per rod to colour by (overrides ``color_by``'s values).
    view:
        ``"iso"``, ``"top"``, ``"front"`` or ``(elev, azim)`` in degrees (see module docstring).
    size:
        ``(width, height)`` of the image in pixels.
    backend:
        ``"auto"``, ``"pyvista"`` or ``"matplotlib"``.
    title:
        Text drawn at the top of the image.
    **options:
        ``cmap`` (colormap name, default ``"viridis"``), ``clim`` ((lo, hi) colour range),
        ``bounds`` (((xmin, xmax), (ymin, ymax), (zmin, zmax)) in m: fixed framing, e.g. for
        animations), ``subdivisions`` (spline points per segment, default 3), ``n_sides``
        (vertices around the tube, default 12), ``dpi`` (matplotlib only, default 100).

    Returns
    -------
    Path
        ``out_png``.
    """
    from PIL import Image

    img = _render_array(
        centerlines, radii, closed, colors, color_by, scalars, view, size, backend, title, **options
    )
    out = Path(out_png)
    out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(img).save(out, format="PNG")
    return out


def _select_file_frames(frames: Any, n: int) -> list[int]:
    if n == 0:
        raise ConfigError("frames", "the trajectory has no frames")
    if isinstance(frames, str):
        table = {"last": [n - 1], "first": [0], "all": list(range(n))}
        if frames not in table:
            raise ConfigError("frames", f"must be 'last', 'first', 'all', an int or a list, got {frames!r}")
        return table[frames]
    sel = [int(frames)] if np.isscalar(frames) else [int(f) for f in frames]
    bad = [f for f in sel if not -n <= f < n]
    if bad:
        raise ConfigError("frames", f"indices {bad} out of range for {n} frames")
    return [f % n for f in sel]


def trajectory_bounds(traj: Any, frames: Sequence[int] | None = None) -> np.ndarray:
    """``(3, 2)`` box (m) enclosing all tubes of ``traj`` over the given loaded frames (default all)."""
    frames = range(traj.n_frames) if frames is None else frames
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for i in frames:
        x = np.asarray(traj.positions[i], dtype=np.float64)
        lo = np.minimum(lo, x.min(axis=0))
        hi = np.maximum(hi, x.max(axis=0))
    r = float(np.max(traj.rod_radius))
    return np.stack([lo - r, hi + r], axis=1)


def render_run(
    run_dir: str | os.PathLike,
    frames: str | int | Sequence[int] = "last",
    out_dir: str | os.PathLike | None = None,
    **kw: Any,
) -> list[Path]:
    """Render frames of a run's ``trajectory.h5`` to PNG files.

    Parameters
    ----------
    run_dir:
        Run directory holding ``trajectory.h5``.
    frames:
        ``"last"``, ``"first"``, ``"all"``, a frame index or a list of frame indices (in the file).
    out_dir:
        Where to write ``frame_{index:06d}.png`` (default ``run_dir/render``).
    **kw:
        Passed to :func:`render_frame` (``view``, ``size``, ``backend``, ``color_by``, ...). Unless
        given, ``title`` is ``"t = ... s"`` and, for several frames, ``bounds`` is the box
        enclosing all of them so that every image has the same framing.

    Returns
    -------
    list of Path
        The PNG files, in the order of ``frames``.
    """
    from knotsim.io.trajectory import read_trajectory

    run = Path(run_dir)
    traj = read_trajectory(run / "trajectory.h5", lazy=True)
    with traj:
        sel = _select_file_frames(frames, traj.n_frames)
        out = Path(out_dir) if out_dir is not None else run / "render"
        opts = dict(kw)
        if len(sel) > 1 and "bounds" not in opts:
            opts["bounds"] = trajectory_bounds(traj, sel)
        paths = []
        for i in sel:
            title = kw["title"] if "title" in kw else f"t = {traj.time[i]:.4g} s"
            paths.append(
                render_frame(
                    traj.centerlines(i),
                    traj.rod_radius,
                    out / f"frame_{i:06d}.png",
                    closed=traj.rod_closed,
                    title=title,
                    **{k: v for k, v in opts.items() if k not in ("title", "closed")},
                )
            )
    return paths
