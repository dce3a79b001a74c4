"""Interactive views of a run: a self-contained HTML page (plotly) or a 3D window (pyvista).

:func:`write_html` writes one HTML file with the rods drawn as thick lines (one colour per rod, or
coloured by a node field such as the slip or rolling speed of the contacts) animated over time, a time slider and a play button, and beside them the force curve of the run
with a marker at the shown frame. The plotly.js library is embedded in the page, so the page opens
without network access (about 5 MB). It needs the ``view`` extra (``pip install 'knotsim[view]'``).
The run's rigid obstacles (``[[obstacles]]`` of its ``run.toml``: posts, spheres, planes;
:mod:`knotsim.viz.obstacles`) are drawn as grey surfaces (a plane as a translucent patch), moving
with the frames when they move.

:func:`show_window` opens an interactive pyvista window (the ``render`` extra): the rods as tubes,
a slider over the frames (and the obstacles). It needs a display; :func:`has_display` says whether there is one.

The force curve (N, against time in s) is the protocol's pull force ``F`` when the log has it
(``knotsim pull`` runs), else the magnitude ``<group>_force`` of every boundary-condition group's
reaction force (plain ``knotsim run`` runs; groups that never carry a force are left out).
"""

from __future__ import annotations

import os
import sys
from enum import StrEnum
from pathlib import Path

import numpy as np

from knotsim.errors import ConfigError
from knotsim.viz.scene import DEFAULT_COLORS

__all__ = ["COLOR_FIELDS", "NodeField", "force_curves", "has_display", "run_directory", "select_frames", "show_window", "write_html"]

#: Colour of each rod (cycled), as CSS hex strings: those of the rendered pictures
#: (:data:`knotsim.viz.scene.DEFAULT_COLORS`), the two ropes of a bend red and blue.
ROD_COLORS = DEFAULT_COLORS
#: CSS colour of the nodes without a value (out of contact) when coloured by a node field.
NO_VALUE_COLOR = "#bdbdbd"
#: Share of the colour scale (at its bottom) that stands for "no value".
_NO_VALUE_SHARE = 0.06
#: Not reaction forces, though their names end in ``_force``.
_NOT_REACTIONS = {"contact_force_total", "friction_force_total"}


def run_directory(run_dir: str | os.PathLike) -> Path:
    """``run_dir`` as a Path; :class:`~knotsim.errors.ConfigError` unless it holds ``trajectory.h5``."""
    run = Path(run_dir)
    if not (run / "trajectory.h5").is_file():
        raise ConfigError("run_dir", f"{str(run)!r} has no trajectory.h5 (is it a knotsim run directory?)")
    return run


def select_frames(n_frames: int, max_frames: int) -> np.ndarray:
    """At most ``max_frames`` frame indices out of ``n_frames``, evenly spaced, first and last included."""
    if int(max_frames) < 2:
        raise ConfigError("max_frames", f"must be >= 2, got {max_frames}")
    if n_frames <= max_frames:
        return np.arange(n_frames)
    return np.unique(np.round(np.linspace(0, n_frames - 1, int(max_frames))).astype(np.int64))


def force_curves(run_dir: str | os.PathLike) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """``(time (s), {label: force (N)})`` of the run's ``log.parquet`` (see the module docstring);
    empty when the run has no log."""
    import pandas as pd

    path = Path(run_dir) / "log.parquet"
    if not path.is_file():
        return np.empty(0), {}
    log = pd.read_parquet(path)
    t = log["time"].to_numpy(dtype=float)
    if "F" in log.columns:
        return t, {"pull force F": log["F"].to_numpy(dtype=float)}
    curves = {}
    for col in log.columns:
        if col.endswith("_force") and col not in _NOT_REACTIONS:
            f = log[col].to_numpy(dtype=float)
            if np.any(np.abs(f[np.isfinite(f)]) > 0):
                curves[f"{col[: -len('_force')]} reaction |F|"] = f
    return t, curves


def _frame_lines(traj, i: int) -> list[np.ndarray]:
    """Centre lines of loaded frame ``i``, a ring's first node repeated at its end."""
    lines = traj.centerlines(i)
    return [np.vstack([p, p[:1]]) if traj.rod_closed[r] else p for r, p in enumerate(lines)]


def _scene_box(traj, frames: np.ndarray, shapes: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners (m) of the box the page's scene is framed on: the knot (the ropes in
    contact where they cross, plus a margin; :mod:`knotsim.viz.framing`) over every selected frame
    that has one, with the part of a post the ropes touch there (``shapes``: the obstacles at each
    frame, :func:`knotsim.viz.obstacles.obstacle_focus`), else the first frame's closest approach
    between ropes or whole scene. Each side is at least a tenth of the longest (a flat knot keeps
    some depth)."""
    from knotsim.viz.framing import _box, _margin, knot_mask, knot_region, union_box
    from knotsim.viz.obstacles import obstacle_focus

    radius, closed = traj.rod_radius, traj.rod_closed
    pad = _margin(np.asarray(radius, dtype=float), None)
    boxes = []
    for i in frames:  # a loop over the shown frames; the nodes are vectorised
        lines = traj.centerlines(int(i))
        mask = np.concatenate(knot_mask(lines, radius, closed))
        if mask.any():
            box = _box(np.concatenate(lines)[mask], pad)
            if shapes and shapes.get(int(i)):
                box = obstacle_focus(box, shapes[int(i)], lines, radius)
            boxes.append(box)
    if boxes:
        box = union_box(boxes)
        lo, hi = box[:, 0], box[:, 1]
    else:
        lo, hi = knot_region(traj.centerlines(int(frames[0])), radius, closed)
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    half = np.maximum(half, 0.1 * half.max())
    return mid - half, mid + half


def _import_plotly():
    try:
        import plotly.graph_objects as go
        from plotly.subplots import make_subplots
    except ImportError:
        raise ImportError("knotsim view --html needs plotly: pip install 'knotsim[view]'") from None
    return go, make_subplots


class NodeField(StrEnum):
    """A node field of ``trajectory.h5`` a page can colour the rods by (``write_html(color_by=...)``)."""

    SLIP_SPEED = "slip_speed"          #: m/s, surface friction only
    ROLLING_SPEED = "rolling_speed"    #: m/s, surface friction only
    CONTACT_FORCE = "contact_force"    #: N
    FRICTION_FORCE = "friction_force"  #: N


#: The :class:`NodeField` members, in order.
COLOR_FIELDS = tuple(NodeField)


def _obstacle_trace(go, shape, region: np.ndarray, clip: np.ndarray):
    """A plotly ``Mesh3d`` of one obstacle (:class:`knotsim.viz.obstacles.ObstacleShape`): its
    surface round the ``(3, 2)`` ``region`` (m), a post cut at the ``clip`` box (m)."""
    from matplotlib.colors import to_hex

    from knotsim.viz.obstacles import obstacle_mesh

    m = obstacle_mesh([shape], region, clip)
    tris = m.quads[:, [0, 1, 2, 0, 2, 3]].reshape(-1, 3) if not m.empty else np.empty((0, 3), np.int64)
    rgba = m.rgba[0] if not m.empty else np.array([0.6, 0.6, 0.6, 1.0])
    v = m.vertices
    return go.Mesh3d(x=v[:, 0], y=v[:, 1], z=v[:, 2], i=tris[:, 0], j=tris[:, 1], k=tris[:, 2],
                     color=to_hex(rgba[:3]), opacity=float(rgba[3]), name=shape.name, hoverinfo="name",
                     showlegend=True, flatshading=False,
                     lighting={"ambient": 0.6, "diffuse": 0.6, "specular": 0.2, "roughness": 0.6})


def _node_colors(traj, frames: np.ndarray, color_by: str) -> tuple[dict[int, list[np.ndarray]], float, str]:
    """Per-rod node values of ``color_by`` at the selected frames (speeds in mm/s, forces in N; the
    nodes without a value, NaN: out of contact, get a value below 0 that the colour scale shows
    grey), the top of the colour scale (the largest value shown) and its unit."""
    try:
        color_by = NodeField(color_by).value  # checked; a plain string from here on
    except ValueError:
        raise ConfigError("color_by", f"must be one of {[f.value for f in NodeField]}, got {color_by!r}") from None
    if color_by not in traj.fields:
        hint = (" (written by runs with rod-rod contact and contact.friction_model = 'surface')"
                if color_by in ("slip_speed", "rolling_speed") else " (written by runs with contact)")
        raise ConfigError("color_by", f"the trajectory has no {color_by!r}{hint}")
    unit = traj.units.get(color_by, "")
    scale = 1e3 if unit == "m/s" else 1.0
    raw = {int(i): scale * np.asarray(traj.fields[color_by][int(i)], dtype=float) for i in frames}
    finite = [v[np.isfinite(v)] for v in raw.values()]
    top = max((float(v.max()) for v in finite if v.size), default=0.0)
    top = top if top > 0.0 else 1.0
    below = -top * _NO_VALUE_SHARE / (1.0 - _NO_VALUE_SHARE)  # the grey part of the scale
    starts = traj.rod_node_start
    values = {}
    for i, v in raw.items():
        v = np.where(np.isfinite(v), v, below)
        per_rod = []
        for r in range(traj.n_rods):  # a loop over rods, once per shown frame
            w = v[starts[r]:starts[r + 1]]
            per_rod.append(np.append(w, w[:1]) if traj.rod_closed[r] else w)
        values[i] = per_rod
    return values, top, "mm/s" if scale == 1e3 else unit


def _colorscale() -> list:
    """Plotly colour scale: grey for its bottom :data:`_NO_VALUE_SHARE` (no value), Viridis above."""
    from matplotlib import colormaps
    from matplotlib.colors import to_hex

    cm = colormaps["viridis"]
    s = _NO_VALUE_SHARE
    stops = np.round(s + (1.0 - s) * np.arange(11) / 10, 6)
    stops[-1] = 1.0  # plotly refuses a scale that does not end at exactly 1
    return [[0.0, NO_VALUE_COLOR], [s, NO_VALUE_COLOR]] + [
        [float(x), to_hex(cm(k / 10))] for k, x in enumerate(stops)]


def write_html(run_dir: str | os.PathLike, out: str | os.PathLike, *, max_frames: int = 100,
               line_width: float = 8.0, color_by: str | None = None) -> Path:
    """Write the self-contained HTML page of ``run_dir`` (see the module docstring) to ``out``.

    Parameters
    ----------
    run_dir:
        A run directory (``trajectory.h5``; ``log.parquet`` for the force curve).
    out:
        The ``.html`` file to write (its directory is created).
    max_frames:
        At most this many frames are shown, evenly spaced over the run (the first and the last
        included): the page grows by about ``24 * n_nodes`` bytes per frame.
    line_width:
        Width of the rods' lines, in screen pixels.
    color_by:
        ``None`` (one colour per rod) or a node field of the trajectory (:data:`COLOR_FIELDS`):
        ``"slip_speed"`` and ``"rolling_speed"`` (shown in mm/s; where strands slide and where they
        roll, runs with surface friction), ``"contact_force"``, ``"friction_force"`` (N). Nodes
        without a value (out of contact) are grey; the scale runs from 0 to the largest value shown.

    The scene is framed on the knot (the ropes in contact plus a margin, over the frames shown);
    the parts of the ropes outside it are clipped.

    Returns
    -------
    Path
        ``out``.
    """
    from knotsim.io.trajectory import read_trajectory
    from knotsim.viz.obstacles import read_obstacles

    go, make_subplots = _import_plotly()
    run = run_directory(run_dir)
    t_log, curves = force_curves(run)
    tracks = read_obstacles(run)
    with read_trajectory(run / "trajectory.h5", lazy=True) as traj:
        if traj.n_frames == 0:
            raise ConfigError("trajectory", f"{run / 'trajectory.h5'} has no frames")
        frames = select_frames(traj.n_frames, max_frames)
        shapes = {int(i): [tr.at(float(traj.time[i])) for tr in tracks] for i in frames}
        lo, hi = _scene_box(traj, frames, shapes)
        lines = {int(i): _frame_lines(traj, int(i)) for i in frames}
        times = np.asarray(traj.time[frames], dtype=float)
        names = list(traj.rod_names)
        colors = _node_colors(traj, frames, color_by) if color_by is not None else None

    has_force = bool(curves)
    fig = make_subplots(rows=1, cols=2 if has_force else 1, column_widths=[0.58, 0.42] if has_force else None,
                        specs=[[{"type": "scene"}, {"type": "xy"}] if has_force else [{"type": "scene"}]],
                        horizontal_spacing=0.08)

    def line_style(i: int, r: int) -> dict:
        if colors is None:
            return {"width": line_width, "color": ROD_COLORS[r % len(ROD_COLORS)]}
        values, top, unit = colors
        return {"width": line_width, "color": values[i][r], "colorscale": _colorscale(),
                "cmin": -top * _NO_VALUE_SHARE / (1.0 - _NO_VALUE_SHARE), "cmax": top, "showscale": r == 0,
                "colorbar": {"title": f"{str(color_by).replace('_', ' ')} ({unit})<br>grey: no contact",
                             "x": -0.05, "y": 0.45, "len": 0.75, "tick0": 0.0}}

    def rod_traces(i: int) -> list:
        return [go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="lines", name=names[r],
                             line=line_style(i, r), hoverinfo="name")
                for r, p in enumerate(lines[i])]

    first = int(frames[0])
    for trace in rod_traces(first):
        fig.add_trace(trace, row=1, col=1)
    n_rods = len(names)
    marker_index = None
    main_curve = None
    if has_force:
        for k, (label, f) in enumerate(curves.items()):
            fig.add_trace(go.Scatter(x=t_log, y=f, mode="lines", name=label,
                                     line={"color": ROD_COLORS[(n_rods + k) % len(ROD_COLORS)]}), row=1, col=2)
        main_label, main_curve = next(iter(curves.items()))
        marker_index = n_rods + len(curves)

        def marker(t: float):
            j = int(np.argmin(np.abs(t_log - t))) if t_log.size else 0
            y = [main_curve[j]] if t_log.size else []
            return go.Scatter(x=[t] if t_log.size else [], y=y, mode="markers", name=f"t = {t:.4g} s",
                              marker={"size": 11, "color": "black"}, showlegend=False)

        fig.add_trace(marker(float(times[0])), row=1, col=2)
        fig.update_xaxes(title_text="time (s)", row=1, col=2)
        fig.update_yaxes(title_text="force (N)", row=1, col=2)

    # the obstacles, round the scene box and cut just beyond it; those that move are animated
    region = np.stack([lo, hi], axis=1)
    clip = region + 0.02 * float(np.max(hi - lo)) * np.array([-1.0, 1.0])
    first_index = len(fig.data)
    moving = []
    for o, track in enumerate(tracks):
        fig.add_trace(_obstacle_trace(go, shapes[first][o], region, clip), row=1, col=1)
        here = [shapes[int(i)][o] for i in frames]
        if track.moves and not all(np.allclose(np.concatenate([s.a, s.b]), np.concatenate([here[0].a, here[0].b]))
                                   and (s.normal is None or np.allclose(s.normal, here[0].normal)) for s in here):
            moving.append(o)  # (a post turning about its own axis looks the same: not animated)

    def obstacle_traces(i: int) -> list:
        return [_obstacle_trace(go, shapes[i][o], region, clip) for o in moving]

    animated = (list(range(n_rods)) + ([marker_index] if marker_index is not None else [])
                + [first_index + o for o in moving])
    fig.frames = [go.Frame(name=f"{k}", traces=animated,
                           data=rod_traces(int(i)) + ([marker(float(times[k]))] if has_force else [])
                           + obstacle_traces(int(i)))
                  for k, i in enumerate(frames)]
    ext = hi - lo
    fig.update_scenes(xaxis={"range": [lo[0], hi[0]], "title": "x (m)"},
                      yaxis={"range": [lo[1], hi[1]], "title": "y (m)"},
                      zaxis={"range": [lo[2], hi[2]], "title": "z (m)"},
                      aspectmode="manual", aspectratio=dict(zip("xyz", (ext / ext.max()).tolist(), strict=True)))
    still = {"mode": "immediate", "frame": {"duration": 0, "redraw": True}, "transition": {"duration": 0}}
    play = {"frame": {"duration": 80, "redraw": True}, "fromcurrent": True, "transition": {"duration": 0}}
    fig.update_layout(
        title=f"{run.name}: {len(frames)} frames, t = {times[0]:.4g} to {times[-1]:.4g} s",
        width=None, height=640, margin={"l": 10, "r": 10, "t": 60, "b": 10},
        legend={"x": 0.0, "y": 1.0},
        updatemenus=[{"type": "buttons", "direction": "left", "showactive": False, "x": 0.0, "y": -0.02,
                      "xanchor": "left", "yanchor": "top",
                      "buttons": [{"label": "play", "method": "animate", "args": [None, play]},
                                  {"label": "pause", "method": "animate", "args": [[None], still]}]}],
        sliders=[{"active": 0, "x": 0.14, "len": 0.84, "y": 0.0, "currentvalue": {"prefix": "t = ", "suffix": " s"},
                  "steps": [{"label": f"{t:.4g}", "method": "animate", "args": [[f"{k}"], still]}
                            for k, t in enumerate(times)]}],
    )
    path = Path(out)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.write_html(path, include_plotlyjs=True, full_html=True, auto_play=False)
    return path


def has_display() -> bool:
    """Whether an interactive window can open: on Linux (and other X11/Wayland systems) a
    ``DISPLAY`` or ``WAYLAND_DISPLAY``; macOS and Windows always have one."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def show_window(run_dir: str | os.PathLike, *, max_frames: int = 200) -> None:  # pragma: no cover - needs a display
    """Open an interactive pyvista window on ``run_dir``: the rods as tubes, a slider over time.

    Raises :class:`~knotsim.errors.ConfigError` without a display (use :func:`write_html`), and
    ImportError naming the ``render`` extra without pyvista.
    """
    from knotsim.io.trajectory import read_trajectory
    from knotsim.viz.tube import tube_mesh

    run = run_directory(run_dir)
    if not has_display():
        raise ConfigError("display", "no display to open a window on; write a page instead: "
                                     f"knotsim view {run} --html view.html")
    try:
        import pyvista as pv
    except ImportError:
        raise ImportError("knotsim view needs pyvista for its window: pip install 'knotsim[render]' "
                          "(or write a page with --html FILE and the view extra)") from None
    with read_trajectory(run / "trajectory.h5", lazy=True) as traj:
        frames = select_frames(traj.n_frames, max_frames)
        lines = [traj.centerlines(int(i)) for i in frames]
        times = np.asarray(traj.time[frames], dtype=float)
        radii, closed, names = traj.rod_radius.copy(), traj.rod_closed.copy(), list(traj.rod_names)
    from knotsim.viz.obstacles import clip_box, obstacle_mesh, read_obstacles

    tracks = read_obstacles(run)
    every = np.concatenate([np.concatenate(ls) for ls in lines])
    region = np.stack([every.min(axis=0), every.max(axis=0)], axis=1)

    def obstacle_surface(track, k: int):
        m = obstacle_mesh([track.at(float(times[k]))], region, clip_box(region))
        tris = m.quads[:, [0, 1, 2, 0, 2, 3]].reshape(-1, 3)
        return pv.PolyData(m.vertices, np.column_stack([np.full(len(tris), 3), tris]).ravel()), m.rgba

    def surface(k: int):
        mesh = tube_mesh(lines[k], radii, closed)
        faces = np.column_stack([np.full(len(mesh.quads), 4), mesh.quads]).ravel()
        if mesh.tris.size:
            faces = np.concatenate([faces, np.column_stack([np.full(len(mesh.tris), 3), mesh.tris]).ravel()])
        surf = pv.PolyData(mesh.vertices, faces)
        surf.point_data["rod"] = mesh.vertex_rod
        return surf

    plotter = pv.Plotter(title=f"knotsim view {run.name}")
    shown = surface(0)
    plotter.add_mesh(shown, scalars="rod", cmap=[ROD_COLORS[r % len(ROD_COLORS)] for r in range(len(names))],
                     show_scalar_bar=False, smooth_shading=True)
    posts = []
    for track in tracks:
        surf, rgba = obstacle_surface(track, 0)
        if surf.n_points:
            plotter.add_mesh(surf, color=tuple(rgba[0, :3]), opacity=float(rgba[0, 3]), smooth_shading=True)
            posts.append((track, surf))

    def on_slider(value: float) -> None:
        k = int(np.argmin(np.abs(times - value)))
        shown.copy_from(surface(k))
        for track, surf in posts:
            if track.moves:
                surf.copy_from(obstacle_surface(track, k)[0])
        plotter.render()

    plotter.add_slider_widget(on_slider, [float(times[0]), float(times[-1])], value=float(times[0]),
                              title="time (s)")
    plotter.show()
