"""Commands ``knotsim knots``, ``knotsim pull`` and ``knotsim tie`` (registered on the main group by
:mod:`knotsim.cli` with ``main.add_command``)::

    knotsim knots
    knotsim pull KNOT | --geometry PATH [--protocol P] [--set key=value ...] -o OUT [--quick] [--save-config F]
    knotsim tie SEQUENCE -o OUT | --list

Exit codes as for the other commands: 0 success, 2 bad input (unknown knot, protocol or parameter),
3 the simulation stopped early (the summary is still written and printed).
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from knotsim._cli_errors import EXIT_SIMULATION
from knotsim._cli_errors import exit_codes as _exit_codes


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
    for note in s.get("notes") or ():
        click.echo(f"note: {note}")
    click.echo(f"{s['knot']} ({proto}{', quick' if quick else ''}): {s['outcome']}")
    t = s["topology"]
    click.echo(f"  knot type: {t['start'].get('knot_type')} -> {t['end'].get('knot_type')}")
    for k, v in s["metrics"].items():
        click.echo(f"  {k}: {_fmt(v) if v is not None else '-'}")
    c = s["contact"]
    click.echo(f"  worst penetration: {c['worst_penetration_ratio']:.3g} h; contacts/step "
               f"{_fmt(c['mean_contacts'])} (max {_fmt(c['max_contacts'])})")
    click.echo(f"  {s['n_steps']} steps over {s['sim_time']:.4g} s in {s['wall_time']:.1f} s wall; "
               f"{s['run_status']}")
    click.echo(f"  summary: {outdir / 'summary.json'}")


@click.command()
@click.argument("knot", required=False)
@click.option("--geometry", type=click.Path(exists=True, path_type=Path), default=None,
              help="Start from this node file (text x y z [theta], .csv, .npy, .mat) or earlier run directory "
                   "instead of a library knot.")
@click.option("--protocol", "protocol", default=None,
              help="overhand-pull, single-rod-bend or two-rope-bend (default: from the knot's kind, or the protocol "
                   "that wrote the --geometry run).")
@click.option("--set", "assignments", multiple=True, metavar="KEY=VALUE",
              help="Override a parameter (repeatable), e.g. --set mu=0.3 --set contact.delta=1e-3.")
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Output directory (trajectory.h5, log.parquet, run.json, run.toml, checkpoint.npz, summary.json).")
@click.option("--quick", is_flag=True, help="Coarse and short run (N ~ 80-100, large dt), for a fast look.")
@click.option("--save-config", "save_config", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write the complete run file; `knotsim run FILE -o DIR` replays it.")
@click.option("--progress/--no-progress", default=None, help="Progress bar (default: when on a terminal).")
@click.option("--json", "as_json", is_flag=True, help="Print the whole summary as JSON.")
@_exit_codes
def pull(knot: str | None, geometry: Path | None, protocol: str | None, assignments: tuple[str, ...], outdir: Path,
         quick: bool, save_config: Path | None, progress: bool | None, as_json: bool):
    """Measure the strength of KNOT (library name or .toml drawing) or of --geometry with a loading protocol."""
    import sys

    from knotsim.errors import ConfigError
    from knotsim.protocols.base import run_protocol
    from knotsim.protocols.params import parse_assignments
    from knotsim.protocols.registry import default_protocol

    if (knot is None) == (geometry is None):
        raise ConfigError("knot", "give a library KNOT or --geometry PATH (one of them)")
    overrides = parse_assignments(assignments)
    if protocol is None:
        if knot is not None:
            protocol = default_protocol(knot)
        else:
            from knotsim.protocols.geometry import geometry_from_source

            geo = geometry_from_source(str(geometry), radius=1.0)
            protocol = geo.protocol_hint or ("overhand-pull" if len(geo.ropes) == 1 else "two-rope-bend")
    if progress is None:
        progress = sys.stderr.isatty()
    s = run_protocol(protocol, knot=knot, out_dir=outdir, overrides=overrides, progress=progress, quick=quick,
                     geometry=str(geometry) if geometry is not None else None, save_config=save_config)
    if as_json:
        click.echo(json.dumps(s))
    else:
        _print_summary(s, protocol, quick, outdir)
        if save_config is not None:
            click.echo(f"  run file: {save_config}")
    if s["run_status"] != "completed":
        raise click.exceptions.Exit(EXIT_SIMULATION)


@click.command()
@click.argument("sequence", required=False)
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Output directory (trajectory.h5, log.parquet, run.json, run.toml, checkpoint.npz).")
@click.option("--list", "list_", is_flag=True, help="List the shipped tying sequences.")
@click.option("--progress/--no-progress", default=None, help="Progress bar (default: when on a terminal).")
@_exit_codes
def tie(sequence: str | None, outdir: Path | None, list_: bool, progress: bool | None):
    """Tie SEQUENCE (overhand, reef, granny, ...) from a straight rope by moving its ends; print the knot type.

    The result can be loaded next: knotsim pull --geometry OUTDIR --protocol PROTOCOL -o DIR2."""
    from knotsim.errors import ConfigError
    from knotsim.knots.tying import list_tying_sequences, tie_from_straight

    if list_:
        for name in list_tying_sequences():
            click.echo(name)
        return
    if sequence is None or outdir is None:
        raise ConfigError("tie", "give a SEQUENCE and -o OUTDIR (or --list)")
    res = tie_from_straight(sequence, out_dir=outdir, progress=progress)
    verdict = "as intended" if res.ok else f"NOT the intended {' or '.join(res.expected)}"
    click.echo(f"{sequence}: tied a {res.knot_type} ({verdict})")
    click.echo(f"  {res.steps} steps over {res.sim_time:.4g} s in {res.wall_time:.1f} s wall; worst penetration "
               f"{res.max_penetration_ratio:.3g} h")
    click.echo(f"  output: {outdir}; pull it next with: knotsim pull --geometry {outdir} --protocol overhand-pull "
               f"-o OUT")
    if not res.ok:
        raise click.exceptions.Exit(EXIT_SIMULATION)
