"""The main group of the ``knotsim`` command and its commands ``run``, ``validate``, ``warmup``,
``plot``, ``export-vtk`` and ``render``; the other commands are registered from the modules of
this package (see :mod:`knotsim.cli`)."""


from __future__ import annotations

import importlib
import json
import math
from pathlib import Path

import click

from knotsim._version import __version__
from knotsim.cli.errors import EXIT_BAD_INPUT, EXIT_FAILED_CHECKS
from knotsim.cli.errors import error as _error
from knotsim.cli.errors import exit_codes as _exit_codes
from knotsim.cli.output import OUTPUT_DIR, announce_compile, default_dir, prepare_output
from knotsim.errors import SimulationError


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="knotsim")
def main():
    """knotsim: discrete elastic rods in frictional contact -- tie knots and measure their strength."""


# ------------------------------------------------------------------------------------------ run
@main.command()
@click.argument("config", required=False, type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", type=OUTPUT_DIR, default=None,
              help="Output directory (trajectory.h5, log.parquet, run.json, run.toml, checkpoint.npz; default "
                   "runs/<CONFIG name>, or runs/<RUN_DIR name>-continued).")
@click.option("--overwrite", is_flag=True, help="Replace knotsim's files in a non-empty output directory.")
@click.option("--from", "from_dir", type=click.Path(exists=True, file_okay=False, path_type=Path), default=None,
              help="Continue the run in this output directory from its checkpoint (with CONFIG: under the new "
                   "boundary conditions, contact and solver settings of CONFIG).")
@click.option("--duration", type=float, default=None, help="Simulated time in s (overrides run.duration).")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar and no summary.")
@_exit_codes
def run(config: Path | None, outdir: Path | None, overwrite: bool, from_dir: Path | None, duration: float | None,
        quiet: bool):
    """Run the simulation described by CONFIG (a run file, see docs/run-files.md), or continue --from DIR."""
    from knotsim.errors import ConfigError
    from knotsim.runspec import RunSpec, build_run, check_run, run_simulation

    if config is None:
        if from_dir is None:
            raise ConfigError("config", "give a run file CONFIG, or --from DIR to continue a run")
        config = from_dir / "run.toml"
        if not config.is_file():
            raise ConfigError("from", f"{str(from_dir)!r} has no run.toml; give the run file as CONFIG")
    if from_dir is not None and outdir is not None and outdir.resolve() == from_dir.resolve():
        raise ConfigError("output", f"continue into a new directory: -o {outdir} is the --from run itself")
    default = default_dir(f"{from_dir.name}-continued") if from_dir is not None else default_dir(config.stem)
    spec = RunSpec.load(config)
    cfg = check_run(spec, duration=duration)  # input errors first, alone: before any note
    outdir = prepare_output(outdir, default, overwrite)
    announce_compile(contact=cfg.contact, topology=False, obstacles=cfg.obstacles_builder is not None)
    sim, cfg = build_run(cfg, continue_from=from_dir)
    outcome = run_simulation(sim, cfg.duration, outdir, output_interval=cfg.output_interval,
                             progress=False if quiet else None)
    exc = outcome.error
    if exc is not None:
        raise SimulationError(f"{exc} (partial output written to {outdir})",
                              last_good_state=exc.last_good_state, time=exc.time) from exc
    if not quiet:
        click.echo(_run_summary(sim, outcome, outdir))


def _run_summary(sim, outcome, outdir: Path) -> str:
    """One paragraph: steps, Newton iterations per step, wall time, final reactions."""
    log = outcome.log
    steps = len(log)
    t = float(sim.state.time)
    parts = [f"Simulated {outcome.describe()}."]
    reactions = []
    if steps and sim.bcs is not None:
        last = log.iloc[-1]
        for g in sim.bcs.groups.values():
            if not g.prescribed or f"{g.name}_fx" not in log.columns:
                continue
            f = [float(last[f"{g.name}_f{c}"]) for c in "xyz"]
            m = float(last[f"{g.name}_moment"])
            reactions.append(f"{g.name} F = ({f[0]:.4g}, {f[1]:.4g}, {f[2]:.4g}) N, "
                             f"|F| = {math.sqrt(sum(x * x for x in f)):.4g} N, M = {m:.4g} N m")
    if reactions:
        parts.append(f"Final reactions at t = {t:.4g} s: " + "; ".join(reactions) + ".")
    else:
        parts.append("No prescribed groups, so no reaction forces.")
    parts.append(f"Output in {outdir}/ (trajectory.h5, log.parquet, run.json).")
    return " ".join(parts)


# ------------------------------------------------------------------------------------------ validate
def _validation_module():
    try:
        return importlib.import_module("knotsim.validation.cases")
    except ModuleNotFoundError as exc:
        if exc.name in ("knotsim.validation.cases", "knotsim.validation"):
            _error("validation cases are not available in this version", EXIT_BAD_INPUT)
        raise


def _json_value(v):
    """Plain JSON value (numpy scalars unwrapped, non-finite numbers as null)."""
    if hasattr(v, "item") and not isinstance(v, str | bytes):
        try:
            v = v.item()
        except (TypeError, ValueError):
            v = v.tolist() if hasattr(v, "tolist") else str(v)
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {str(k): _json_value(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_json_value(x) for x in v]
    if v is None or isinstance(v, bool | int | float | str):
        return v
    return str(v)


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int | float) or hasattr(v, "item"):
        try:
            return f"{float(v):.4g}"
        except (TypeError, ValueError):
            return str(v)
    return "" if v is None else str(v)


_TABLE_COLUMNS = ("case", "quantity", "value", "reference", "error", "tolerance", "passed", "wall_time")


#: Widest ``quantity`` cell of the table; longer texts wrap onto continuation lines.
_QUANTITY_WIDTH = 48


def _results_table(results: list[dict]) -> str:
    import textwrap

    rows = [[_fmt(r.get(c)) for c in _TABLE_COLUMNS] for r in results]
    wrapped = [textwrap.wrap(row[1], _QUANTITY_WIDTH) or [""] for row in rows]
    for row, parts in zip(rows, wrapped, strict=True):
        row[1] = parts[0]
    head = list(_TABLE_COLUMNS[:-1]) + ["wall_time (s)"]
    widths = [max(len(h), *(len(row[i]) for row in rows)) if rows else len(h) for i, h in enumerate(head)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(head, widths, strict=True)),
             "  ".join("-" * w for w in widths)]
    for r, row, parts in zip(results, rows, wrapped, strict=True):
        cells = [c.ljust(w) for c, w in zip(row, widths, strict=True)]
        ok = bool(r.get("passed"))
        cells[6] = click.style(("PASS" if ok else "FAIL").ljust(widths[6]), fg="green" if ok else "red", bold=not ok)
        lines.append("  ".join(cells).rstrip())
        for more in parts[1:]:  # the rest of a long quantity, under its column
            lines.append((" " * (widths[0] + 2) + "  " + more).rstrip())
    return "\n".join(lines)


@main.command()
@click.argument("cases", nargs=-1)
@click.option("--quick", is_flag=True, help="Coarser discretisations, for a fast check.")
@click.option("--json", "as_json", is_flag=True, help="After the table, print one JSON line with every result.")
@click.option("--json-only", is_flag=True, help="Print only the JSON line.")
@_exit_codes
def validate(cases: tuple[str, ...], quick: bool, as_json: bool, json_only: bool):
    """Run validation CASES against analytical or published results (default: all).

    Prints a table (long quantities wrapped) and how many checks passed; with --json also one JSON
    line {"cases": [...], "passed": bool}. Exit code 1 if a check fails.
    """
    mod = _validation_module()
    known = list(mod.CASES)
    unknown = [c for c in cases if c not in known]
    if unknown:
        _error(f"unknown validation case{'s' if len(unknown) > 1 else ''} {', '.join(map(repr, unknown))}; "
               f"known cases: {', '.join(known)}", EXIT_BAD_INPUT)
    names = list(dict.fromkeys(cases)) or known
    import sys

    announce_compile(contact=True)
    results = list(mod.run_cases(names, quick, progress=sys.stderr.isatty()))
    passed = all(bool(r.get("passed")) for r in results)
    if not json_only:
        click.echo(_results_table(results))
        n_fail = sum(not r.get("passed") for r in results)
        click.echo(f"{len(results) - n_fail}/{len(results)} checks passed")
    if as_json or json_only:
        click.echo(json.dumps({"cases": _json_value(results), "passed": passed}))
    if not passed:
        raise click.exceptions.Exit(EXIT_FAILED_CHECKS)


# ------------------------------------------------------------------------------------------ warmup
@main.command()
@click.option("--serial/--parallel", default=None,
              help="One process, or two at the same time (default: two when a CPU is spare).")
@_exit_codes
def warmup(serial: bool | None):
    """Compile every numerical kernel now (numba, cached for later runs) and report the time.

    The first run of a command would otherwise start with this (about 45 s of CPU time)."""
    from knotsim._warmup import GROUPS, kernels_cached, spare_cores, warm_up

    if serial is None:
        serial = spare_cores() < 1.0
    was = kernels_cached()
    click.echo("compiling the numerical kernels (every contact law, obstacles)" + ("" if serial else ", 2 processes")
               + ("; those of a contact run are cached already" if was else "") + " ...", err=True)
    times = warm_up(parallel=not serial, groups=GROUPS)
    second = f" and {times['second']:.1f} s in a second process" if times["second"] else ""
    cpu = times["cpu.first"] + times["cpu.second"]
    click.echo(f"kernels ready in {times['total']:.1f} s ({times['kernels']} compiled: {times['first']:.1f} s here"
               f"{second}; CPU time {cpu:.1f} s); cached: {'yes' if kernels_cached() else 'NO'}")


# ------------------------------------------------------------------------------------------ post-processing
@main.command()
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("-o", "--output", "out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Figure file (PNG, or any format matplotlib writes; default RUN_DIR/force.png).")
@_exit_codes
def plot(run_dir: Path, out: Path | None):
    """Plot the pull force of RUN_DIR against time (and against the end separation or shortening),
    with the protocol's window, peak and slip onset marked."""
    from knotsim.viz.plot import plot_run

    click.echo(str(plot_run(run_dir, out)))


@main.command("export-vtk")
@click.argument("run_dir", type=click.Path(exists=True, path_type=Path))
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Directory for the .vtp frames and the .pvd collection.")
@click.option("--every", type=click.IntRange(min=1), default=1, help="Export every N-th frame.")
@click.option("--ascii", "ascii_", is_flag=True, help="ASCII instead of inline binary data.")
@_exit_codes
def export_vtk(run_dir: Path, outdir: Path, every: int, ascii_: bool):
    """Export RUN_DIR's trajectory (or a trajectory.h5 file) to VTK (ParaView) files."""
    from knotsim.io.vtk import export_vtk as _export

    files = _export(run_dir, outdir, every=every, encoding="ascii" if ascii_ else "binary")
    click.echo(f"wrote {len(files)} files to {outdir}")


def _parse_frames(value: str):
    if value in ("last", "first", "all"):
        return value
    try:
        idx = [int(x) for x in value.split(",") if x.strip()]
    except ValueError:
        raise click.BadParameter("expected last, first, all or comma-separated frame indices") from None
    if not idx:
        raise click.BadParameter("no frame given")
    return idx[0] if len(idx) == 1 else idx


def _parse_view(value: str):
    if value in ("iso", "top", "front"):
        return value
    try:
        elev, azim = (float(x) for x in value.split(","))
    except ValueError:
        raise click.BadParameter("expected iso, top, front or ELEV,AZIM in degrees") from None
    return (elev, azim)


def _parse_size(value: str):
    try:
        w, h = (int(x) for x in value.lower().split("x"))
    except ValueError:
        raise click.BadParameter("expected WIDTHxHEIGHT in pixels, e.g. 800x600") from None
    if w <= 0 or h <= 0:
        raise click.BadParameter("width and height must be positive")
    return (w, h)


@main.command()
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--frames", default="last", show_default=True, help="last, first, all, or indices I,J,...")
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Directory for the PNG files (default RUN_DIR/render).")
@click.option("--view", default="iso", show_default=True, help="iso, top, front or ELEV,AZIM (degrees).")
@click.option("--size", default="800x600", show_default=True, help="Image size WIDTHxHEIGHT, pixels.")
@click.option("--backend", type=click.Choice(["auto", "pyvista", "matplotlib"]), default="auto", show_default=True)
@click.option("--color-by", type=click.Choice(["none", "bending_strain", "slip_speed", "rolling_speed"]),
              default="none", show_default=True,
              help="One colour per rope (none), or colour by the bending strain, or by where the contacts "
                   "slide (slip_speed) or roll (rolling_speed), mm/s, nodes out of contact grey (runs with "
                   "surface friction).")
@click.option("--frame", "framing", type=click.Choice(["knot", "scene"]), default="knot", show_default=True,
              help="Frame each picture on the knot (the ropes in contact plus a margin; the rest may be "
                   "clipped) or on the whole scene (all pictures alike).")
@_exit_codes
def render(run_dir: Path, frames: str, outdir: Path | None, view: str, size: str, backend: str, color_by: str,
           framing: str):
    """Render frames of RUN_DIR's trajectory as shaded tubes (PNG)."""
    from knotsim.viz.render import render_run

    paths = render_run(run_dir, frames=_parse_frames(frames), out_dir=outdir, view=_parse_view(view),
                       size=_parse_size(size), backend=backend, frame=framing,
                       color_by=None if color_by == "none" else color_by)
    for p in paths:
        click.echo(str(p))


def _register_subcommands() -> None:
    """The commands of the other modules of this package (their heavy imports happen inside the
    commands)."""
    from knotsim.cli.compare import compare
    from knotsim.cli.protocols import knots, pull, tie
    from knotsim.cli.ropes import ropes
    from knotsim.cli.study import animate, critical_mu, report, study
    from knotsim.cli.view import view

    for command in (knots, ropes, pull, tie, compare, study, report, animate, critical_mu, view):
        main.add_command(command)


_register_subcommands()
