"""Render rods as shaded tubes to PNG images: the public entry points and their options.

Two backends draw the same tube surface (:func:`knotsim.viz.tube.tube_mesh`, so both look alike):

``"pyvista"`` (optional dependency, ``pip install knotsim[render]``)
    OpenGL rendering off screen, smooth shading with per-vertex normals
    (:mod:`knotsim.viz._backend_pyvista`).
``"matplotlib"`` (always available)
    One depth-sorted ``Poly3DCollection`` of all back-face-culled tube quads, shaded per quad
    (:mod:`knotsim.viz._backend_mpl`).

``backend="auto"`` uses pyvista when it can be imported and falls back to matplotlib otherwise
(or, with a warning, when pyvista fails to render).

Views (:mod:`knotsim.viz.camera`, degrees, as matplotlib's ``view_init``): ``"iso"`` = (30, -60),
``"top"`` = (90, -90) looking down -z with x to the right and y up, ``"front"`` = (0, -90)
looking along +y with x to the right and z up, or any ``(elev, azim)`` tuple.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from knotsim.errors import ConfigError, KnotsimWarning
from knotsim.viz._backend_mpl import render_matplotlib
from knotsim.viz._backend_pyvista import import_pyvista, render_pyvista
from knotsim.viz.camera import VIEWS, scene_bounds, view_angles
from knotsim.viz.scene import DEFAULT_COLORS, ColorBy, RenderBackend, as_backend, color_range, prepare_scene
from knotsim.viz.tube import TubeMesh, tube_mesh

__all__ = [
    "DEFAULT_COLORS",
    "VIEWS",
    "ColorBy",
    "RenderBackend",
    "TubeMesh",
    "render_frame",
    "render_run",
    "trajectory_bounds",
    "tube_mesh",
]


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
    backend = as_backend(backend)
    try:
        w, h = (int(s) for s in size)
    except (TypeError, ValueError):
        raise ConfigError("size", f"must be (width, height) in pixels, got {size!r}") from None
    if w < 16 or h < 16:
        raise ConfigError("size", f"must be at least 16x16 pixels, got {size!r}")
    ang = view_angles(view)
    lines, rad, cl, rgb, vals, label = prepare_scene(centerlines, radii, closed, colors, color_by, scalars)
    box = scene_bounds(lines, rad, bounds)
    lim = color_range(vals, clim) if vals is not None else None
    mesh = tube_mesh(lines, rad, cl, vals, subdivisions=subdivisions, n_sides=n_sides)
    # points the view is framed on: the tubes, or the corners of a fixed box
    fit = mesh.vertices if bounds is None else np.array(np.meshgrid(*box, indexing="ij")).reshape(3, -1).T

    use = backend
    if backend is RenderBackend.AUTO:
        try:
            import_pyvista()
            use = RenderBackend.PYVISTA
        except ImportError:
            use = RenderBackend.MATPLOTLIB
    if use is RenderBackend.PYVISTA:
        try:
            img = render_pyvista(mesh, rgb, fit, ang, (w, h), title, cmap, lim, label)
        except ImportError as exc:
            raise ImportError(
                "the pyvista backend needs pyvista: pip install knotsim[render] (or use backend='matplotlib')"
            ) from exc
        except Exception as exc:  # any OpenGL / VTK failure
            if backend is not RenderBackend.AUTO:
                raise
            warnings.warn(f"pyvista rendering failed ({exc}); falling back to matplotlib", KnotsimWarning,
                          stacklevel=3)
            use = RenderBackend.MATPLOTLIB
    if use is RenderBackend.MATPLOTLIB:
        img = render_matplotlib(mesh, rgb, box, fit, ang, (w, h), title, cmap, lim, label, int(dpi))
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
    centerlines, radii:
        Node positions ``(N_k, 3)`` (m) of each rod and its tube radius (m), or one radius for
        all rods (the tubes of :func:`knotsim.viz.tube.tube_mesh`).
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
