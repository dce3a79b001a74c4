"""Commands ``knotsim knots`` and ``knotsim tie`` (registered on the main group by
:mod:`knotsim.cli` with ``main.add_command``)::

    knotsim knots
    knotsim tie NAME [--protocol P] [--set key=value ...] -o OUT [--quick]

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
    from knotsim.protocols.base import protocols

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


@click.command()
@click.argument("name")
@click.option("--protocol", "protocol", default=None,
              help="overhand-pull, single-rod-bend or two-rope-bend (default: from the knot's kind).")
@click.option("--set", "assignments", multiple=True, metavar="KEY=VALUE",
              help="Override a parameter (repeatable), e.g. --set mu=0.3 --set contact.delta=1e-3.")
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Output directory (trajectory.h5, log.parquet, run.json, summary.json).")
@click.option("--quick", is_flag=True, help="Coarse and short run (N ~ 80-100, large dt), for a fast look.")
@click.option("--progress/--no-progress", default=None, help="Progress bar (default: when on a terminal).")
@click.option("--json", "as_json", is_flag=True, help="Print the whole summary as JSON.")
@_exit_codes
def tie(name: str, protocol: str | None, assignments: tuple[str, ...], outdir: Path, quick: bool,
        progress: bool | None, as_json: bool):
    """Tie knot NAME (library name or .toml drawing), load it with a protocol, print strength metrics."""
    import sys

    from knotsim.protocols.base import default_protocol, parse_assignments, run_protocol

    overrides = parse_assignments(assignments)
    proto = protocol or default_protocol(name)
    if progress is None:
        progress = sys.stderr.isatty()
    s = run_protocol(proto, knot=name, out_dir=outdir, overrides=overrides, progress=progress, quick=quick)
    if as_json:
        click.echo(json.dumps(s))
    else:
        click.echo(f"{s['knot']} ({proto}{', quick' if quick else ''}): {s['outcome']}")
        t = s["topology"]
        click.echo(f"  knot type: {t['start'].get('knot_type')} -> {t['end'].get('knot_type')}")
        for k, v in s["metrics"].items():
            click.echo(f"  {k}: {_fmt(v) if v is not None else '-'}")
        c = s["contact"]
        click.echo(f"  worst penetration: {c['worst_penetration_ratio']:.3g} h; contacts/step "
                   f"{_fmt(c['mean_contacts'])} (max {_fmt(c['max_contacts'])})")
        click.echo(f"  {s['n_steps']} steps to t = {s['sim_time']:.4g} s in {s['wall_time']:.1f} s wall; "
                   f"{s['run_status']}")
        click.echo(f"  summary: {outdir / 'summary.json'}")
    if s["run_status"] != "completed":
        raise click.exceptions.Exit(EXIT_SIMULATION)
