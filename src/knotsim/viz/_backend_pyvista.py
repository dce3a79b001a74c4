"""Pyvista rendering backend (optional dependency, ``pip install knotsim[render]``).

OpenGL rendering off screen, smooth shading with per-vertex normals. On Linux without a display,
``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow`` is set (unless already set) before ``vtk`` is
first imported, so that it renders headless through EGL. The obstacles of a run
(:class:`knotsim.viz.obstacles.ObstacleMesh`) are drawn as meshes of their own (a plane's patch
translucent).
"""

from __future__ import annotations

import os
import sys

import numpy as np

from knotsim.viz.camera import camera_basis, plot_area
from knotsim.viz.obstacles import ObstacleMesh
from knotsim.viz.scene import BACKGROUND, NO_VALUE
from knotsim.viz.tube import TubeMesh

__all__ = ["import_pyvista", "render_pyvista"]


def import_pyvista():
    """Import and return ``pyvista`` (headless EGL on Linux without a display); ImportError if missing."""
    if sys.platform.startswith("linux") and not os.environ.get("DISPLAY") and "vtkmodules" not in sys.modules:
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista

    return pyvista


def render_pyvista(mesh: TubeMesh, rgb, fit, view, size, title, cmap, clim, label,
                   obstacles: ObstacleMesh | None = None) -> np.ndarray:
    """Draw ``mesh`` (and the ``obstacles``, if any) off screen to an ``(h, w, 3)`` RGB array.

    Arguments as :func:`knotsim.viz._backend_mpl.render_matplotlib` (no axis box: the parallel
    projection is framed on ``fit`` ``(P, 3)`` (m) alone; the obstacles only push the camera back).
    """
    pv = import_pyvista()
    w, h = size
    elev, azim = view
    towards, right, up = camera_basis(elev, azim)

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

    a_w, a_h = plot_area(size, mesh.vertex_values is not None, bool(title))
    plotter = pv.Plotter(off_screen=True, window_size=[w, h])
    try:
        plotter.set_background(BACKGROUND)
        shading = {"smooth_shading": True, "specular": 0.3, "specular_power": 24.0}
        if mesh.vertex_values is not None:
            plotter.add_mesh(
                polydata(mesh.quads, mesh.tris),
                scalars=label,
                cmap=cmap,
                clim=list(clim),
                nan_color=NO_VALUE,
                scalar_bar_args={
                    "title": label,
                    "vertical": True,
                    "color": "black",
                    "position_x": a_w + 0.01,
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
        if obstacles is not None and not obstacles.empty:
            for k in range(len(obstacles.names)):  # a loop over the obstacles
                sel = np.flatnonzero(obstacles.vertex_obstacle == k)
                quads = obstacles.quads[obstacles.quad_obstacle == k]
                if not sel.size or not quads.size:
                    continue
                remap = np.full(obstacles.vertices.shape[0], -1, dtype=np.int64)
                remap[sel] = np.arange(sel.size)
                tris = remap[quads][:, [0, 1, 2, 0, 2, 3]].reshape(-1, 3)  # a pole's quad: one flat triangle
                surf = pv.PolyData(obstacles.vertices[sel], np.column_stack([np.full(len(tris), 3), tris]).ravel())
                surf.point_data.active_normals = obstacles.normals[sel]
                r, g, b, alpha = (float(c) for c in obstacles.rgba[k])
                plotter.add_mesh(surf, color=(r, g, b), opacity=alpha, smooth_shading=True, specular=0.2,
                                 specular_power=24.0)
        # parallel projection framed on the projected extent of `fit`, leaving room for the
        # title (top) and the colour bar (right)
        u, v = fit @ right, fit @ up
        u_mid, v_mid = 0.5 * (u.min() + u.max()), 0.5 * (v.min() + v.max())
        half_u = max(0.5 * (u.max() - u.min()), 1e-12)
        half_v = max(0.5 * (v.max() - v.min()), 1e-12)
        scale = max(half_v / (0.94 * a_h), half_u * h / (0.94 * a_w * w))
        d = fit @ towards
        target = u_mid * right + v_mid * up + float(d.mean()) * towards
        focal = target + right * (1.0 - a_w) * scale * w / h + up * (1.0 - a_h) * scale
        depth = float(d.max() - d.min()) + 2.0 * scale
        if obstacles is not None and not obstacles.empty:  # the camera in front of them all
            d_all = obstacles.vertices @ towards - float(d.mean())
            depth = max(depth, 2.0 * float(np.abs(d_all).max()) + 2.0 * scale)
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
