"""Command ``knotsim view`` (registered on the main group by :mod:`knotsim.cli.commands`)::

    knotsim view RUN_DIR --html FILE [--max-frames N] [--color-by FIELD]   # HTML page (the view extra)
    knotsim view RUN_DIR                                # interactive window (the render extra, a display)

Exit codes as for the other commands: 0 success, 2 bad input, a missing extra or no display (one
line on stderr, no traceback).
"""

from __future__ import annotations

from pathlib import Path

import click

from knotsim.cli.errors import EXIT_BAD_INPUT, error
from knotsim.cli.errors import exit_codes as _exit_codes


@click.command("view")
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--html", "html", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write a self-contained HTML page (rods animated over time with a slider, the force "
                   "curve beside them; opens without network access) instead of opening a window.")
@click.option("--max-frames", type=click.IntRange(min=2), default=100, show_default=True,
              help="Show at most this many frames, evenly spaced over the run.")
@click.option("--color-by", "color_by", type=click.Choice(["rod", "slip_speed", "rolling_speed", "contact_force",
                                                          "friction_force"]), default="rod", show_default=True,
              help="With --html: colour the rods by a node field of the trajectory: where contacts slide "
                   "(slip_speed) and roll (rolling_speed), mm/s, with surface friction; contact_force and "
                   "friction_force, N; nodes out of contact grey. 'rod': one colour per rod. The scene is "
                   "framed on the knot.")
@_exit_codes
def view(run_dir: Path, html: Path | None, max_frames: int, color_by: str):
    """View the run in RUN_DIR: an interactive 3D window, or with --html FILE a web page."""
    from knotsim.viz import view as _view

    _view.run_directory(run_dir)
    try:
        if html is not None:
            click.echo(str(_view.write_html(run_dir, html, max_frames=max_frames,
                                            color_by=None if color_by == "rod" else color_by)))
            return
        if not _view.has_display():
            error(f"no display to open a window on; write a page instead: knotsim view {run_dir} --html FILE",
                  EXIT_BAD_INPUT)
        _view.show_window(run_dir, max_frames=max_frames)
    except ImportError as exc:
        error(str(exc), EXIT_BAD_INPUT)
