"""Animations of a run: every (``every``-th) frame of ``trajectory.h5`` rendered as tubes.

``.gif`` files are written with Pillow (always installed with matplotlib); ``.mp4`` files need
``imageio`` and ``imageio-ffmpeg`` (``pip install knotsim[render]``). All frames share the framing
of the box enclosing the whole animation, so the camera does not jump. The run's rigid obstacles
(``[[obstacles]]`` of its ``run.toml``) are drawn at each frame's time (:mod:`knotsim.viz.obstacles`).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from knotsim.errors import ConfigError

__all__ = ["animate_run"]


def _import_imageio():
    try:
        import imageio.v2 as imageio
        import imageio_ffmpeg  # noqa: F401  (the ffmpeg plugin's binary)
    except ImportError as exc:
        raise ImportError(
            f"writing .mp4 animations needs imageio and imageio-ffmpeg ({exc}): "
            "pip install knotsim[render]   (or write a .gif, which only needs Pillow)"
        ) from exc
    return imageio


def animate_run(
    run_dir: str | os.PathLike,
    out_path: str | os.PathLike,
    fps: float = 20,
    every: int = 1,
    size: tuple[int, int] = (640, 480),
    backend: str = "auto",
    *,
    title: bool = True,
    progress: Callable[[int, int], None] | None = None,
    obstacles: bool = True,
    **render_kw: Any,
) -> Path:
    """Render the frames of ``run_dir/trajectory.h5`` into an ``.mp4`` or ``.gif`` animation.

    Parameters
    ----------
    run_dir:
        Run directory holding ``trajectory.h5``.
    out_path:
        Output file; its suffix (``.mp4`` or ``.gif``) selects the format.
    fps:
        Frames per second of the animation.
    every:
        Use every ``every``-th frame of the trajectory (0, every, 2*every, ...).
    size:
        ``(width, height)`` in pixels. For ``.mp4`` an odd dimension is rounded up to even (H.264).
    backend:
        Rendering backend, as in :func:`knotsim.viz.render.render_frame`.
    title:
        Draw ``"t = ... s"`` on each frame.
    progress:
        Optional callback ``progress(done, total)`` called after each rendered frame.
    obstacles:
        Draw the run's rigid obstacles (posts, spheres, planes) at each frame's time.
    **render_kw:
        More options of :func:`knotsim.viz.render.render_frame` (``view``, ``colors``,
        ``color_by``, ``cmap``, ``clim``, ``bounds``, ...).

    Returns
    -------
    Path
        ``out_path``.

    Notes
    -----
    A ``.gif`` keeps all (palette-quantised) frames in memory until it is written; an ``.mp4`` is
    streamed to ffmpeg frame by frame.
    """
    from knotsim.io.trajectory import read_trajectory
    from knotsim.viz.obstacles import read_obstacles
    from knotsim.viz.render import _render_array, trajectory_bounds

    out = Path(out_path)
    fmt = out.suffix.lower()
    if fmt not in (".mp4", ".gif"):
        raise ConfigError("out_path", f"must end in .mp4 or .gif, got {out.name!r}")
    if not float(fps) > 0:
        raise ConfigError("fps", f"must be > 0, got {fps}")
    if int(every) < 1:
        raise ConfigError("every", f"must be >= 1, got {every}")
    w, h = (int(s) for s in size)
    if fmt == ".mp4":
        w, h = w + w % 2, h + h % 2
        imageio = _import_imageio()  # fail before rendering anything
    out.parent.mkdir(parents=True, exist_ok=True)

    tracks = read_obstacles(run_dir) if obstacles else []
    traj = read_trajectory(Path(run_dir) / "trajectory.h5", frames=slice(None, None, int(every)), lazy=True)
    with traj:
        if traj.n_frames == 0:
            raise ConfigError("run_dir", f"{run_dir}: the trajectory has no frames")
        opts = dict(render_kw)
        opts.setdefault("bounds", trajectory_bounds(traj))
        if (
            "color_by" in opts
            and opts["color_by"] is not None
            and "clim" not in opts
            and "scalars" not in opts
        ):
            opts["clim"] = _common_clim(traj)

        def frames():
            for i in range(traj.n_frames):
                img = _render_array(
                    traj.centerlines(i),
                    traj.rod_radius,
                    closed=traj.rod_closed,
                    size=(w, h),
                    backend=backend,
                    title=f"t = {traj.time[i]:.4g} s" if title else None,
                    obstacles=[track.at(float(traj.time[i])) for track in tracks] or None,
                    **opts,
                )
                yield img
                if progress is not None:
                    progress(i + 1, traj.n_frames)

        if fmt == ".gif":
            from PIL import Image

            images = [
                Image.fromarray(img).quantize(colors=256, method=Image.Quantize.MEDIANCUT) for img in frames()
            ]
            images[0].save(
                out,
                format="GIF",
                save_all=True,
                append_images=images[1:],
                duration=max(1, round(1000.0 / float(fps))),
                loop=0,
                disposal=1,
            )
        else:
            writer = imageio.get_writer(
                out,
                format="FFMPEG",
                mode="I",
                fps=float(fps),
                codec="libx264",
                pixelformat="yuv420p",
                macro_block_size=2,
            )
            try:
                for img in frames():
                    writer.append_data(img)
            finally:
                writer.close()
    return out


def _common_clim(traj: Any) -> tuple[float, float]:
    """Bending-strain colour range over all loaded frames, so that colours mean the same in each."""
    from knotsim.io.vtk import node_bending_strain

    hi = 0.0
    for i in range(traj.n_frames):
        for r, line in enumerate(traj.centerlines(i)):
            s = node_bending_strain(line, traj.rod_radius[r], bool(traj.rod_closed[r]))
            hi = max(hi, float(np.max(s)))
    return 0.0, hi if hi > 0 else 1e-12
