"""Commands ``knotsim knots``, ``knotsim pull`` and ``knotsim tie`` (registered on the main group by
:mod:`knotsim.cli.commands`)::

    knotsim knots
    knotsim pull KNOT | --geometry PATH [--matrices A,B] [--protocol P] [--set key=value ...] [--rope NAME] [-o OUT]
                 [--overwrite] [--quick] [--save-config F] [--no-figures]
    knotsim pull [KNOT] [--protocol P] --show-params
    knotsim tie SEQUENCE [-o OUT] [--overwrite] | --list

Without ``-o`` the output goes to ``runs/<knot>-<protocol>`` (``runs/tie-<sequence>``); a directory
that is not empty is refused unless ``--overwrite`` (see :mod:`knotsim.cli.output`). ``pull``
writes ``force.png`` (:func:`knotsim.viz.plot.plot_run`) and renders of the first and last frames
(``render/``) unless ``--no-figures``.

Exit codes as for the other commands: 0 success, 2 bad input (unknown knot, protocol or parameter),
3 the simulation stopped early (the summary is still written and printed).
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from knotsim.cli.errors import EXIT_SIMULATION
from knotsim.cli.errors import exit_codes as _exit_codes
from knotsim.cli.output import OUTPUT_DIR, announce_compile, default_dir, prepare_output
from knotsim.cli.ropes import add_rope, rope_option


class ProtocolOption(click.Option):
    """``--protocol``: its help lists the registered protocols (read from the registry when the help
    is shown, so that it names every protocol and importing the command line stays light)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.base_help = self.help or ""

    def get_help_record(self, ctx):
        from knotsim.protocols.registry import protocols

        names = sorted(protocols())
        self.help = f"{', '.join(names[:-1])} or {names[-1]} {self.base_help}"
        return super().get_help_record(ctx)


@click.command()
@_exit_codes
def knots():
    """List the built-in knots (name, kind, default protocol, description)."""
    from knotsim.knots.library import list_knots, load_knot_spec
    from knotsim.protocols.registry import protocols

    by_kind = {k: p.name for p in protocols().values() for k in p.kinds}
    rows = list_knots()
    width = max((len(n) for n, _ in rows), default=4)
    for name, desc in rows:
        kind = load_knot_spec(name).kind
        click.echo(f"{name:<{width}}  {kind:<15}  {by_kind.get(kind, '-'):<15}  {desc}")


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, dict):
        return ", ".join(f"{k} {_fmt(x)}" for k, x in v.items())
    return str(v)


def _print_summary(s: dict, proto: str, quick: bool, outdir: Path) -> None:
    from knotsim.runspec import run_line

    for warning in s.get("warnings") or ():  # first: the measurement is not valid by the protocol's own rule
        click.echo(f"WARNING: {warning}")
    for note in s.get("notes") or ():
        click.echo(f"note: {note}")
    click.echo(f"{s['knot']} ({proto}{', quick' if quick else ''}): {s['outcome']}")
    line = (s.get("timeline") or {})
    if line.get("decision"):
        d = line["decision"]
        click.echo(f"  decided at t = {d['time']:.3f} s: {d['reason']}")
    if line.get("stopped"):
        click.echo(f"  stopped at t = {line['stopped']['time']:.3f} s, {_fmt(s['parameters'].get('stop_margin'))} s "
                   "after the decision (stop_margin; stop_at_decision = false runs to the end)")
    t = s["topology"]
    click.echo(f"  knot type: {t['start'].get('knot_type')} -> {t['end'].get('knot_type')}")
    for k, v in s["metrics"].items():
        click.echo(f"  {k}: {_fmt(v) if v is not None else '-'}")
    c = s["contact"]
    click.echo(f"  worst penetration: {c['worst_penetration_ratio']:.3g} h; contacts/step "
               f"{_fmt(c['mean_contacts'])} (max {_fmt(c['max_contacts'])})")
    click.echo(f"  {run_line(s['n_steps'], s['sim_time'], s['wall_time'], s['failed_attempts'], s['newton_iterations'])}; "
               f"{s['run_status']}")
    click.echo(f"  summary: {outdir / 'summary.json'}")


def _show_params(protocol: str) -> None:
    """The parameter table of ``protocol`` (key, default, unit, meaning) and its --quick changes."""
    from knotsim.protocols.params import describe_params, settings_defaults
    from knotsim.protocols.registry import get_protocol

    proto = get_protocol(protocol)
    rows = [(k, "none" if v is None else _fmt(v), u, m) for k, v, u, m in describe_params(proto)]
    w = [max(len(r[i]) for r in rows) for i in range(3)]
    click.echo(f"{proto.name}: {proto.description}")
    click.echo(f"parameters (--set KEY=VALUE; none = from the knot drawing or computed), default knot "
               f"{proto.default_knot}:")
    for k, v, u, m in rows:
        click.echo(f"  {k:<{w[0]}}  {v:<{w[1]}}  {u:<{w[2]}}  {m}")
    quick = ", ".join(f"{k} = {_fmt(v)}" for k, v in proto.quick.items())
    click.echo(f"--quick sets: {quick or 'nothing'}")
    extra = ", ".join(f"{k} = {'none' if v is None else _fmt(v)}" for k, v in settings_defaults().items()
                      if k not in dict.fromkeys(r[0] for r in rows))
    click.echo(f"also accepted (contact and solver settings, see docs/run-files.md): {extra}")


def _quick_notes(protocol: str, overrides: dict, geometry) -> list[str]:
    """What --quick changes: ``--quick: KEY = VALUE (default D)``, or that a --set value wins."""
    from knotsim.protocols.params import protocol_defaults
    from knotsim.protocols.registry import get_protocol

    proto = get_protocol(protocol)
    defaults = protocol_defaults(proto)
    notes = []
    for k, v in proto.quick.items():
        if k in overrides:
            notes.append(f"--quick: {k} = {_fmt(v)} not applied (--set {k}={_fmt(overrides[k])} wins)")
        elif geometry is not None and k in ("n_nodes", "length"):
            continue  # reported by the protocol (the geometry fixes it)
        else:
            d = defaults.get(k)
            notes.append(f"--quick: {k} = {_fmt(v)} (default {'none' if d is None else _fmt(d)})")
    return notes


def _figures(outdir: Path) -> list[Path]:
    """force.png and pictures of the key frames framed on the knot (render/set_end.png,
    slow_slip_onset.png, decision.png; first.png and last.png without those events), matplotlib,
    no display needed."""
    from knotsim.viz.plot import plot_run
    from knotsim.viz.render import render_key_frames

    paths = [plot_run(outdir, outdir / "force.png")]
    paths += render_key_frames(outdir, backend="matplotlib", size=(640, 480))
    return paths


@click.command()
@click.argument("knot", required=False)
@click.option("--geometry", type=click.Path(exists=True, path_type=Path), default=None,
              help="Start from this node file (text x y z [theta], .csv, .npy, .mat) or earlier run directory "
                   "instead of a library knot.")
@click.option("--matrices", default=None, metavar="A,B",
              help="The rope matrices of a --geometry .mat file, in order (the ropes take their names; default: "
                   "every 3 x N or N x 3 matrix, and an ambiguous file is refused). Same as --set geometry_matrices=A,B.")
@click.option("--protocol", "protocol", default=None, cls=ProtocolOption,
              help="(default: from the knot's kind, or the protocol that wrote the --geometry run).")
@click.option("--set", "assignments", multiple=True, metavar="KEY=VALUE",
              help="Override a parameter (repeatable), e.g. --set mu=0.3 --set contact.delta=1e-3.")
@rope_option
@click.option("-o", "--output", "outdir", type=OUTPUT_DIR, default=None,
              help="Output directory (trajectory.h5, log.parquet, run.json, run.toml, checkpoint.npz, summary.json, "
                   "force.png, render/; default runs/<knot>-<protocol>).")
@click.option("--overwrite", is_flag=True, help="Replace knotsim's files in a non-empty output directory.")
@click.option("--quick", is_flag=True, help="Coarse and short run (N ~ 80-100, large dt), for a fast look; "
                                            "prints what it changes.")
@click.option("--show-params", is_flag=True, help="List the protocol's parameters (default, unit, meaning) and exit.")
@click.option("--save-config", "save_config", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write the complete run file; `knotsim run FILE -o DIR` replays it.")
@click.option("--figures/--no-figures", default=True, show_default=True,
              help="Write force.png and renders of the start and end states into the output directory.")
@click.option("--progress/--no-progress", default=None, help="Progress bar (default: when on a terminal).")
@click.option("--json", "as_json", is_flag=True, help="Print the whole summary as JSON.")
@_exit_codes
def pull(knot: str | None, geometry: Path | None, matrices: str | None, protocol: str | None,
         assignments: tuple[str, ...], rope: str | None,
         outdir: Path | None, overwrite: bool, quick: bool, show_params: bool, save_config: Path | None,
         figures: bool, progress: bool | None, as_json: bool):
    """Measure the strength of KNOT (library name or .toml drawing) or of --geometry with a loading protocol."""
    import sys

    from knotsim.errors import ConfigError
    from knotsim.protocols.params import parse_assignments
    from knotsim.protocols.registry import default_protocol

    if show_params:
        _show_params(protocol or (default_protocol(knot) if knot else "overhand-pull"))
        return
    if (knot is None) == (geometry is None):
        raise ConfigError("knot", "give a library KNOT or --geometry PATH (one of them)")
    overrides = add_rope(parse_assignments(assignments), rope)
    if matrices is not None:
        if geometry is None:
            raise ConfigError("matrices", "--matrices names the matrices of a --geometry .mat file")
        if "geometry_matrices" in overrides:
            raise ConfigError("matrices", "give --matrices or --set geometry_matrices=..., not both")
        overrides["geometry_matrices"] = matrices
    if protocol is None:
        if knot is not None:
            protocol = default_protocol(knot)
        else:
            from knotsim.protocols.geometry import geometry_from_source, parse_matrices

            geo = geometry_from_source(str(geometry), radius=1.0,
                                       matrices=parse_matrices(overrides.get("geometry_matrices")))
            protocol = geo.protocol_hint or ("overhand-pull" if len(geo.ropes) == 1 else "two-rope-bend")
    name = Path(knot).stem if knot is not None else Path(str(geometry)).name
    outdir = prepare_output(outdir, default_dir(name, protocol), overwrite)
    if progress is None:
        progress = sys.stderr.isatty()
    from knotsim.protocols.pipeline import run_protocol

    def start(cfg):  # every input checked: the notes, then the run (an input error is printed alone)
        if quick:
            for note in _quick_notes(protocol, overrides, geometry):
                click.echo(f"note: {note}", err=True)
        announce_compile(contact=cfg.contact, obstacles=cfg.obstacles_builder is not None)

    s = run_protocol(protocol, knot=knot, out_dir=outdir, overrides=overrides, progress=progress, quick=quick,
                     geometry=str(geometry) if geometry is not None else None, save_config=save_config,
                     on_start=start)
    drawn = _figures(outdir) if figures and s["n_steps"] else []
    if as_json:
        click.echo(json.dumps(s.to_dict()))
    else:
        _print_summary(s, protocol, quick, outdir)
        if save_config is not None:
            click.echo(f"  run file: {save_config}")
        if drawn:
            click.echo(f"  figures: {drawn[0]}, {', '.join(str(p) for p in drawn[1:])}")
    if s["run_status"] != "completed":
        raise click.exceptions.Exit(EXIT_SIMULATION)


@click.command()
@click.argument("sequence", required=False)
@click.option("-o", "--output", "outdir", type=OUTPUT_DIR, default=None,
              help="Output directory (trajectory.h5, log.parquet, run.json, run.toml, checkpoint.npz; "
                   "default runs/tie-<sequence>).")
@click.option("--overwrite", is_flag=True, help="Replace knotsim's files in a non-empty output directory.")
@click.option("--list", "list_", is_flag=True, help="List the shipped tying sequences.")
@click.option("--progress/--no-progress", default=None, help="Progress bar (default: when on a terminal).")
@_exit_codes
def tie(sequence: str | None, outdir: Path | None, overwrite: bool, list_: bool, progress: bool | None):
    """Tie SEQUENCE (overhand, reef, granny, ...) from a straight rope by moving its ends; print the knot type.

    The result can be loaded next: knotsim pull --geometry OUTDIR --protocol PROTOCOL -o DIR2."""
    from knotsim.errors import ConfigError
    from knotsim.knots.tying import list_tying_sequences, tie_from_straight, tying_sequence_path

    if list_:
        for name in list_tying_sequences():
            click.echo(name)
        return
    if sequence is None:
        raise ConfigError("tie", "give a SEQUENCE (or --list)")
    tying_sequence_path(sequence)  # an unknown name is an error before any note
    outdir = prepare_output(outdir, default_dir("tie", sequence), overwrite)
    announce_compile(contact=True)
    from knotsim.runspec import run_line

    res = tie_from_straight(sequence, out_dir=outdir, progress=progress)
    verdict = "as intended" if res.ok else f"NOT the intended {' or '.join(res.expected)}"
    click.echo(f"{sequence}: tied a {res.knot_type} ({verdict})")
    click.echo(f"  {run_line(res.steps, res.sim_time, res.wall_time)}; worst penetration "
               f"{res.max_penetration_ratio:.3g} h")
    if res.half_knot is not None:  # reef / granny: the rope between the two half-knots
        g = res.half_knot
        click.echo("  half_knot_gap: not measurable (the diagram does not split into two knots)" if g.gap is None
                   else f"  half_knot_gap: {g.gap:.4g} m = {g.diameters:.3g} rope diameters ({g.form}; limit 10)")
    follow = "overhand-pull" if sequence == "overhand" else "single-rod-bend"
    click.echo(f"  output: {outdir}; pull it next with: knotsim pull --geometry {outdir} --protocol {follow} "
               f"-o OUT")
    if not res.ok:
        raise click.exceptions.Exit(EXIT_SIMULATION)
