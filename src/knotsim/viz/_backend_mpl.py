"""Matplotlib rendering backend (always available).

All tube quads of all rods go into a single ``Poly3DCollection`` with Lambert + specular shading
computed per quad; matplotlib's depth sort of that one collection makes crossing ropes occlude
each other correctly. Back faces are culled first (the tubes are closed surfaces), which halves
the work and removes most sorting artefacts. The obstacles of a run
(:class:`knotsim.viz.obstacles.ObstacleMesh`) go into the same collection, so that a rope round a
post hides it and is hidden by it; a plane's translucent patch is seen from both sides.
"""

from __future__ import annotations

import numpy as np

from knotsim.viz.camera import camera_basis, plot_area
from knotsim.viz.obstacles import ObstacleMesh
from knotsim.viz.scene import BACKGROUND, NO_VALUE
from knotsim.viz.tube import TubeMesh, unit

__all__ = ["render_matplotlib"]


def render_matplotlib(mesh: TubeMesh, rgb, box, fit, view, size, title, cmap, clim, label, dpi,
                      obstacles: ObstacleMesh | None = None) -> np.ndarray:
    """Draw ``mesh`` (and the ``obstacles``, if any) to an ``(h, w, 3)`` uint8-valued RGB array.

    ``rgb`` ``(n_rods, 3)`` colours in [0, 1] (used without scalars); ``box`` ``(3, 2)`` axis limits
    (m); ``fit`` ``(P, 3)`` points (m) the view is framed on; ``view`` ``(elev, azim)`` (deg);
    ``size`` ``(w, h)`` pixels; ``cmap``, ``clim``, ``label``: colour map, range and colour-bar
    label of ``mesh``'s scalars; ``dpi`` of the figure.
    """
    from matplotlib import colormaps
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle
    from mpl_toolkits.mplot3d import proj3d
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    w, h = size
    elev, azim = view
    towards, right, up = camera_basis(elev, azim)
    light = unit(towards + 0.6 * up - 0.4 * right)
    half = unit(light + towards)

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

    cm = (colormaps[cmap] if isinstance(cmap, str) else cmap).with_extremes(bad=NO_VALUE)  # NaN: no value
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
    corners = mesh.vertices[polys]
    edge = face
    if obstacles is not None and not obstacles.empty:
        o_corners, o_face, o_edge = _obstacle_faces(obstacles, towards, light, half)
        corners = np.concatenate([corners, o_corners])
        face = np.concatenate([face, o_face])
        edge = np.concatenate([edge, o_edge])

    fig = Figure(figsize=(w / dpi, h / dpi), dpi=dpi, facecolor=BACKGROUND)
    canvas = FigureCanvasAgg(fig)
    right_frac, top_frac = plot_area(size, values is not None, bool(title))
    ax = fig.add_axes((0.0, 0.0, right_frac, top_frac), projection="3d", facecolor=BACKGROUND)
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
        # a strip of background under the title: tubes running out of the framed box stop there
        fig.add_artist(Rectangle((0.0, top_frac), 1.0, 1.0 - top_frac, transform=fig.transFigure,
                                 facecolor=BACKGROUND, edgecolor="none", zorder=2))
        fig.text(
            0.5,
            1.0 - 0.5 * (1.0 - top_frac),
            title,
            ha="center",
            va="center",
            fontsize=max(6, min(14, h / 40)),
            zorder=3,
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

    coll = Poly3DCollection(corners, facecolors=face, edgecolors=edge, linewidths=0.25)
    coll.set_zsort("average")
    coll.set_clip_on(False)  # the 3D axes clips to a square; the image may use its whole box
    ax.add_collection3d(coll, autolim=False)
    if values is not None:
        fig.add_artist(Rectangle((right_frac, 0.0), 1.0 - right_frac, 1.0, transform=fig.transFigure,
                                 facecolor=BACKGROUND, edgecolor="none", zorder=2))
        cax = fig.add_axes((right_frac, 0.15, min(0.04, 14.0 / w), 0.7 * top_frac))
        cax.set_zorder(3)
        fig.colorbar(ScalarMappable(norm=norm, cmap=cm), cax=cax, label=label)
    canvas.draw()
    img = np.asarray(canvas.buffer_rgba())[..., :3].copy()
    fig.clear()
    return img


def _obstacle_faces(obstacles: ObstacleMesh, towards, light, half):
    """Corners ``(Q, 4, 3)`` (m), face and edge colours ``(Q, 4)`` RGBA of the obstacles' quads seen
    from ``towards``: closed surfaces back-face culled, open ones (a plane's patch) turned to face
    the viewer; shaded as the tubes. Translucent quads get no edges (they would draw a grid)."""
    normals = obstacles.quad_normals
    owner = obstacles.quad_obstacle
    facing = normals @ towards
    two = obstacles.two_sided[owner]
    normals = np.where((two & (facing < 0.0))[:, None], -normals, normals)
    keep = two | (facing > -0.2)
    normals, owner = normals[keep], owner[keep]
    rgba = obstacles.rgba[owner]
    diffuse = np.clip(normals @ light, 0.0, None)
    spec = np.clip(normals @ half, 0.0, None) ** 24
    shade = rgba[:, :3] * (0.28 + 0.72 * diffuse)[:, None] + 0.2 * spec[:, None]
    face = np.concatenate([np.clip(shade, 0, 1), rgba[:, 3:]], axis=1)
    edge = face.copy()
    edge[face[:, 3] < 1.0, 3] = 0.0
    return obstacles.vertices[obstacles.quads[keep]], face, edge
