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

The rigid obstacles of a run (``[[obstacles]]`` of its ``run.toml``: posts, spheres, planes) are
drawn with the ropes at each frame's time (:mod:`knotsim.viz.obstacles`); the knot framing stays on
the knot and the part of a post the rope touches there, the rest of the post runs out of the picture.

Views (:mod:`knotsim.viz.camera`, degrees, as matplotlib's ``view_init``): ``"iso"`` = (30, -60),
``"top"`` = (90, -90) looking down -z with x to the right and y up, ``"front"`` = (0, -90)
looking along +y with x to the right and z up, or any ``(elev, azim)`` tuple.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from knotsim.errors import ConfigError, KnotsimWarning
from knotsim.viz._backend_mpl import render_matplotlib
from knotsim.viz._backend_pyvista import import_pyvista, render_pyvista
from knotsim.viz.camera import VIEWS, scene_bounds, view_angles
from knotsim.viz.framing import knot_region
from knotsim.viz.obstacles import (
    ObstacleShape,
    clip_box,
    obstacle_focus,
    obstacle_mesh,
    obstacles_at,
    read_obstacles,
)
from knotsim.viz.scene import (
    DEFAULT_COLORS,
    SPEED_FIELDS,
    ColorBy,
    RenderBackend,
    as_backend,
    color_range,
    prepare_scene,
)
from knotsim.viz.tube import TubeMesh, tube_mesh

__all__ = [
    "DEFAULT_COLORS",
    "FRAMES",
    "KEY_EVENTS",
    "KeyFrame",
    "VIEWS",
    "ColorBy",
    "RenderBackend",
    "TubeMesh",
    "key_frames",
    "node_speeds",
    "render_frame",
    "render_key_frames",
    "render_run",
    "trajectory_bounds",
    "tube_mesh",
]

#: What a picture is framed on: ``"knot"`` (the ropes in contact plus a margin,
#: :mod:`knotsim.viz.framing`; the rest of the ropes may be clipped) or ``"scene"`` (every tube).
FRAMES = ("knot", "scene")


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
    frame: str = "scene",
    focus: Any = None,
    subdivisions: int = 3,
    n_sides: int = 12,
    dpi: int = 100,
    obstacles: Sequence[ObstacleShape] | None = None,
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
    if frame not in FRAMES:
        raise ConfigError("frame", f"must be one of {list(FRAMES)}, got {frame!r}")
    shapes = list(obstacles) if obstacles is not None else []
    if not all(isinstance(o, ObstacleShape) for o in shapes):
        raise ConfigError("obstacles", "must be a list of knotsim.viz.obstacles.ObstacleShape "
                                       "(e.g. obstacles_at(read_obstacles(run_dir), t))")
    if focus is None and bounds is None and frame == "knot":
        focus = np.stack(knot_region(lines, rad, cl), axis=1)
        if shapes:  # and the part of a post the rope touches there
            focus = obstacle_focus(focus, shapes, lines, rad)
    if focus is not None:
        focus = scene_bounds(lines, rad, focus)
    box = scene_bounds(lines, rad, bounds if focus is None else focus)
    lim = color_range(vals, clim, from_zero=color_by in SPEED_FIELDS) if vals is not None else None
    mesh = tube_mesh(lines, rad, cl, vals, subdivisions=subdivisions, n_sides=n_sides)
    # points the view is framed on: the tubes, the tubes inside the focus box, or a fixed box's corners
    corners = np.array(np.meshgrid(*box, indexing="ij")).reshape(3, -1).T
    if focus is not None:
        inside = np.all((mesh.vertices >= box[:, 0]) & (mesh.vertices <= box[:, 1]), axis=1)
        fit = mesh.vertices[inside] if np.count_nonzero(inside) >= 8 else corners
    else:
        fit = mesh.vertices if bounds is None else corners
    # the obstacles round the framed box, a post cut well outside the picture
    extra = obstacle_mesh(shapes, box, clip_box(box, (w, h))) if shapes else None
    extra = None if extra is None or extra.empty else extra

    use = backend
    if backend is RenderBackend.AUTO:
        try:
            import_pyvista()
            use = RenderBackend.PYVISTA
        except ImportError:
            use = RenderBackend.MATPLOTLIB
    if use is RenderBackend.PYVISTA:
        try:
            img = render_pyvista(mesh, rgb, fit, ang, (w, h), title, cmap, lim, label, extra)
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
        img = render_matplotlib(mesh, rgb, box, fit, ang, (w, h), title, cmap, lim, label, int(dpi), extra)
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
        ``None`` (plain colours), ``"bending_strain"`` (curvature x radius, see
        :func:`knotsim.io.vtk.node_curvature`) mapped through ``cmap``, or ``"slip_speed"`` /
        ``"rolling_speed"`` (``scalars`` are then the node speeds in m/s, NaN out of contact; shown
        in mm/s from 0, the nodes out of contact grey); with ``scalars`` and any other string it
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
        animations), ``frame`` (``"scene"``, the default: every tube; ``"knot"``: the ropes in
        contact plus a margin, :func:`knotsim.viz.framing.knot_region`), ``focus`` (a box as
        ``bounds`` the view is framed on, the tubes outside it clipped), ``subdivisions`` (spline points per segment, default 3), ``n_sides``
        (vertices around the tube, default 12), ``dpi`` (matplotlib only, default 100),
        ``obstacles`` (rigid obstacles drawn with the rods: a list of
        :class:`knotsim.viz.obstacles.ObstacleShape`, e.g. ``obstacles_at(read_obstacles(run_dir),
        t)``; capsules and spheres grey, planes a translucent patch; ``frame="knot"`` adds the part
        of a post the ropes touch in the knot, :func:`knotsim.viz.obstacles.obstacle_focus`).

    Returns
    -------
    Path
        ``out_png``.
    """
    text = options.pop("png_text", None)
    img = _render_array(
        centerlines, radii, closed, colors, color_by, scalars, view, size, backend, title, **options
    )
    return _save_png(img, out_png, text)


def _save_png(img: np.ndarray, out_png: str | os.PathLike, text: dict[str, str] | None = None) -> Path:
    """Write ``img`` ``(h, w, 3)`` uint8 to ``out_png`` (directories created), with ``text`` as PNG
    text chunks (e.g. ``knotsim:frame``: which frame of the run the picture shows)."""
    from PIL import Image
    from PIL.PngImagePlugin import PngInfo

    info = PngInfo()
    for key, value in (text or {}).items():
        info.add_text(key, str(value))
    out = Path(out_png)
    out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(img).save(out, format="PNG", pnginfo=info)
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


def node_speeds(traj: Any, frame: int, name: str) -> list[np.ndarray]:
    """``(N_k,)`` node values (m/s, NaN out of contact) of the speed field ``name`` (``"slip_speed"``
    or ``"rolling_speed"``) per rod at loaded frame ``frame`` of ``traj``;
    :class:`~knotsim.errors.ConfigError` (field ``color_by``) when the file has none."""
    if name not in traj.fields:
        raise ConfigError("color_by", f"the trajectory has no {name!r} (written by runs with rod-rod contact "
                                      "and contact.friction_model = 'surface')")
    v = np.asarray(traj.fields[name][int(frame)], dtype=np.float64)
    s = traj.rod_node_start
    return [v[s[r]:s[r + 1]] for r in range(traj.n_rods)]


def _speed_range(traj: Any, frames: Sequence[int], name: str) -> tuple[float, float]:
    """``(0, top)`` mm/s: the colour range of speed field ``name`` shared by the pictures of ``frames``."""
    top = 0.0
    for i in frames:  # a loop over the pictured frames
        v = np.concatenate(node_speeds(traj, i, name))
        v = v[np.isfinite(v)]
        top = max(top, 1e3 * float(v.max()) if v.size else 0.0)
    return 0.0, top if top > 0.0 else 1.0


def _frame_options(traj: Any, i: int, frame: str, opts: dict[str, Any],
                   tracks: Sequence[Any] = ()) -> dict[str, Any]:
    """``opts`` for a picture of loaded frame ``i``: framed on its knot (``frame="knot"``, unless a
    ``bounds`` or ``focus`` is given; with the part of a post the rope touches there), with the
    obstacles of ``tracks`` (:class:`knotsim.viz.obstacles.ObstacleTrack`) at the frame's time,
    and with the node speeds of a speed ``color_by``."""
    out = dict(opts)
    shapes = obstacles_at(tracks, float(traj.time[i]))
    if shapes:
        out["obstacles"] = shapes
    if frame == "knot" and out.get("bounds") is None and out.get("focus") is None:
        from knotsim.viz.framing import trajectory_knot_region

        box = trajectory_knot_region(traj, i).box
        out["focus"] = obstacle_focus(box, shapes, traj.centerlines(i), traj.rod_radius) if shapes else box
    color_by = out.get("color_by")
    if color_by in SPEED_FIELDS and out.get("scalars") is None:
        out["scalars"] = node_speeds(traj, i, str(color_by))
    return out


def _check_frame(frame: str) -> None:
    if frame not in FRAMES:
        raise ConfigError("frame", f"must be one of {list(FRAMES)}, got {frame!r}")


def render_run(
    run_dir: str | os.PathLike,
    frames: str | int | Sequence[int] = "last",
    out_dir: str | os.PathLike | None = None,
    *,
    frame: str = "knot",
    obstacles: bool = True,
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
    frame:
        ``"knot"`` (default): each picture is framed on its knot, the ropes in contact plus a
        margin (:func:`knotsim.viz.framing.trajectory_knot_region`, with its fallbacks when the
        ropes are apart); the rest of the ropes may be clipped. ``"scene"``: on every tube, and
        for several frames on the box enclosing all of them, so that every image has the same framing.
    obstacles:
        Draw the run's rigid obstacles (``[[obstacles]]`` of ``run_dir/run.toml``) at each frame's
        time (:mod:`knotsim.viz.obstacles`).
    **kw:
        Passed to :func:`render_frame` (``view``, ``size``, ``backend``, ``color_by``, ...). Unless
        given, ``title`` is ``"t = ... s"``. ``color_by="slip_speed"`` or ``"rolling_speed"``
        reads the speeds from the trajectory (runs with surface friction), one colour range for
        all the pictures.

    Returns
    -------
    list of Path
        The PNG files, in the order of ``frames``.
    """
    from knotsim.io.trajectory import read_trajectory

    _check_frame(frame)
    run = Path(run_dir)
    traj = read_trajectory(run / "trajectory.h5", lazy=True)
    with traj:
        sel = _select_file_frames(frames, traj.n_frames)
        out = Path(out_dir) if out_dir is not None else run / "render"
        opts = {k: v for k, v in kw.items() if k not in ("title", "closed")}
        tracks = read_obstacles(run) if obstacles else []
        if frame == "scene" and len(sel) > 1 and "bounds" not in opts:
            opts["bounds"] = trajectory_bounds(traj, sel)
        if opts.get("color_by") in SPEED_FIELDS and opts.get("clim") is None:
            opts["clim"] = _speed_range(traj, sel, str(opts["color_by"]))
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
                    png_text={"knotsim:frame": str(i), "knotsim:time": repr(float(traj.time[i]))},
                    **_frame_options(traj, i, frame, opts, tracks),
                )
            )
    return paths


#: The key frames of a run, in order: the set knot, the onset of slow slip, the decision (names of
#: the events of ``summary.json``'s ``timeline``).
KEY_EVENTS = ("set_end", "slow_slip_onset", "decision")
#: Pseudo-events: the first and the last frame of the trajectory.
_ENDS = {"first": "first frame", "last": "last frame"}


@dataclass(frozen=True)
class KeyFrame:
    """One picture of :func:`render_key_frames`: the event ``name`` and ``label``, its ``time`` (s on the
    run's time axis; None for ``first``/``last``) and the loaded ``frame`` nearest to it."""

    name: str
    label: str
    time: float | None
    frame: int


def key_frames(summary: dict[str, Any] | None, times: np.ndarray,
               events: Sequence[str] | None = None) -> list[KeyFrame]:
    """The key frames of a run (see :func:`render_key_frames`).

    Parameters
    ----------
    summary:
        The run's ``summary.json`` (or None): events from ``summary["timeline"]["events"]``, a list
        of ``{"name", "label", "time" (s), "force"}``.
    times:
        ``(T,)`` times (s) of the trajectory's frames.
    events:
        Event names to picture, in order (``"first"`` and ``"last"``: the trajectory's ends); a
        name without an event is skipped. Default :data:`KEY_EVENTS`, or ``("first", "last")``
        when none of them happened (no timeline: a run without one).
    """
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    if t.size == 0:
        raise ConfigError("trajectory", "the trajectory has no frames")
    if isinstance(events, str):
        events = (events,)
    timeline = (summary or {}).get("timeline") if isinstance(summary, dict) else None
    listed = timeline.get("events") if isinstance(timeline, dict) else None
    found: dict[str, dict[str, Any]] = {}
    for ev in listed if isinstance(listed, list) else []:
        ok = isinstance(ev, dict) and isinstance(ev.get("name"), str) and isinstance(ev.get("time"), int | float)
        if ok and np.isfinite(ev["time"]) and ev["name"] not in found:  # the first of a name
            found[ev["name"]] = ev
    wanted = list(events) if events is not None else [e for e in KEY_EVENTS if e in found] or list(_ENDS)
    out = []
    for name in wanted:
        if name in _ENDS:
            out.append(KeyFrame(name, _ENDS[name], None, 0 if name == "first" else t.size - 1))
        elif name in found:
            te = float(found[name]["time"])
            i = int(np.argmin(np.abs(t - te)))  # nearest frame (the earlier one on a tie)
            out.append(KeyFrame(name, str(found[name].get("label") or name.replace("_", " ")), te, i))
    return out


def render_key_frames(
    run_dir: str | os.PathLike,
    out_dir: str | os.PathLike | None = None,
    *,
    events: Sequence[str] | None = None,
    color_by: str | None = None,
    size: tuple[int, int] = (640, 480),
    backend: str = "matplotlib",
    obstacles: bool = True,
) -> list[Path]:
    """Render the key frames of a run, each framed on the knot, to ``<event>.png`` files.

    The key frames are the trajectory's frames nearest the events of ``summary.json``'s
    ``timeline`` (:data:`KEY_EVENTS`, in order: the set knot ``set_end``, the onset of slow slip
    ``slow_slip_onset``, the decision ``decision``); a run without them (no ``summary.json``, no
    ``timeline``, other protocols) gets its first and last frames (``first.png``, ``last.png``).
    Each picture is framed on the knot of its frame (:func:`knotsim.viz.framing.trajectory_knot_region`)
    and titled with the knot, the event and the frame's time (``"reef_bend — set knot, t = 4.6 s"``;
    the event's own time follows when the frame is not at it). Its PNG text chunks ``knotsim:event``,
    ``knotsim:frame`` and ``knotsim:time`` say which frame it shows.

    Parameters
    ----------
    run_dir:
        A run directory (``trajectory.h5``; ``summary.json`` for the events and the knot's name).
    out_dir:
        Where to write the PNG files (default ``run_dir/render``).
    events:
        Names of the events to picture, in order (``"first"``, ``"last"``: the trajectory's ends);
        an event that did not happen is skipped. Default: see above.
    color_by:
        ``None`` (one colour per rope), ``"slip_speed"`` or ``"rolling_speed"`` (mm/s, from the
        trajectory of a run with surface friction; one colour range for all the pictures, the
        nodes out of contact grey) or ``"bending_strain"``.
    size:
        ``(width, height)`` of the pictures in pixels.
    backend:
        ``"matplotlib"``, ``"pyvista"`` or ``"auto"`` (:func:`render_frame`).
    obstacles:
        Draw the run's rigid obstacles (``[[obstacles]]`` of its ``run.toml``: the post of a hitch)
        at each frame's time (:mod:`knotsim.viz.obstacles`).

    Returns
    -------
    list of Path
        The PNG files, in the order of the key frames (empty when none of ``events`` happened).
    """
    import json

    from knotsim.io.trajectory import read_trajectory

    run = Path(run_dir)
    if not (run / "trajectory.h5").is_file():
        raise ConfigError("run_dir", f"{str(run)!r} has no trajectory.h5 (is it a knotsim run directory?)")
    summary = None
    if (run / "summary.json").is_file():
        try:
            summary = json.loads((run / "summary.json").read_text())
        except (OSError, ValueError) as exc:
            raise ConfigError("summary.json", f"cannot read {run / 'summary.json'}: {exc}") from None
    name = str(summary.get("knot") or run.name) if isinstance(summary, dict) else run.name
    out = Path(out_dir) if out_dir is not None else run / "render"
    paths = []
    tracks = read_obstacles(run) if obstacles else []
    with read_trajectory(run / "trajectory.h5", lazy=True) as traj:
        keys = key_frames(summary, np.asarray(traj.time), events)
        opts: dict[str, Any] = {"size": size, "backend": backend, "color_by": color_by}
        if color_by in SPEED_FIELDS and keys:
            opts["clim"] = _speed_range(traj, sorted({k.frame for k in keys}), str(color_by))
        for key in keys:
            t = float(traj.time[key.frame])
            title = f"{name} \N{EM DASH} {key.label}, t = {t:.4g} s"
            if key.time is not None and abs(key.time - t) > 1e-9 + 1e-6 * abs(t):
                title += f" (event at {key.time:.4g} s)"
            paths.append(render_frame(
                traj.centerlines(key.frame), traj.rod_radius, out / f"{key.name}.png", closed=traj.rod_closed,
                title=title,
                png_text={"knotsim:event": key.name, "knotsim:frame": str(key.frame), "knotsim:time": repr(t)},
                **_frame_options(traj, key.frame, "knot", opts, tracks)))
    return paths
