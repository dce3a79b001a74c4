"""Command ``compare``: which of these knots holds better (registered on the main group by
:mod:`knotsim.cli.commands`; the work is :func:`knotsim.study.compare.compare_knots`)."""

from __future__ import annotations

from pathlib import Path

import click

from knotsim.cli.errors import EXIT_FAILED_CHECKS, exit_codes
from knotsim.cli.output import OUTPUT_DIR, default_dir, prepare_output
from knotsim.cli.protocols import ProtocolOption
from knotsim.cli.ropes import add_rope, rope_option


@click.command("compare")
@click.argument("knots", nargs=-1, required=True)
@click.option("--protocol", default="knot-security", show_default=True, cls=ProtocolOption,
              help="(the protocol every knot goes through).")
@click.option("--set", "assignments", multiple=True, metavar="KEY=VALUE",
              help="A protocol parameter for every case (repeatable), e.g. --set load_time=5.")
@rope_option
@click.option("--mu", "mu_text", default=None, metavar="MU[,MU...]",
              help="Friction coefficients, comma-separated, e.g. 0.2,0.3,0.4 (default: the protocol's).")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Local worker processes (default: number of CPUs).")
@click.option("--quick", is_flag=True, help="The protocol's coarse, short settings, for a fast look.")
@click.option("-o", "--output", "outdir", type=OUTPUT_DIR, default=None,
              help="Directory of the comparison (compare.toml, study/, report.md, forces.png, pictures/; default "
                   "runs/compare-<knots>). Running the same comparison into it again reuses the finished cases.")
@click.option("--overwrite", is_flag=True,
              help="Replace what is in a non-empty output directory (an earlier comparison: every case runs again).")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
@exit_codes
def compare(knots: tuple[str, ...], protocol: str, assignments: tuple[str, ...], rope: str | None, mu_text: str | None,
            workers: int | None, quick: bool, outdir: Path | None, overwrite: bool, quiet: bool):
    """Which of KNOTS holds better: run each knot (library name, see `knotsim knots`, or a .toml
    drawing) at each --mu with one protocol, print one table (rows: knots, columns: mu; each cell
    the slip and slow-slip loads in mN and the outcome, or the protocol's headline metric) and
    write report.md and forces.png.

    A case that fails shows its error in its cell; the others still run. Exit code 0 when at least
    one case completed, 1 when every case failed, 2 for bad input.
    """
    import sys

    from knotsim.cli.output import announce_compile
    from knotsim.cli.study import _Bar
    from knotsim.protocols.params import parse_assignments
    from knotsim.study.compare import STUDY_FILE, compare_knots, compare_study, parse_mu_list

    overrides = add_rope(parse_assignments(assignments), rope)
    mu = parse_mu_list(mu_text) if mu_text is not None else None
    study = compare_study(knots, protocol=protocol, mu=mu, overrides=overrides, quick=quick)  # input errors first
    target = outdir if outdir is not None else default_dir(study["name"])
    if outdir is None:
        click.echo(f"output directory: {target} (choose another with -o DIR)", err=True)
    if not (target / STUDY_FILE).is_file():  # a comparison decides itself: resume or refuse
        prepare_output(target, target, overwrite)
    n = len(study["grid"]["knot"]) * len(study["grid"]["overrides.mu"])
    click.echo(f"{n} cases ({len(study['grid']['knot'])} knots x {len(study['grid']['overrides.mu'])} mu) "
               f"under {protocol}" + (" (quick)" if quick else "") + f"; results in {target}/", err=True)
    announce_compile(contact=True)
    bar = _Bar(enabled=not quiet and sys.stderr.isatty())
    try:
        res = compare_knots(knots, protocol=protocol, mu=mu, overrides=overrides, quick=quick, workers=workers,
                            out_dir=target, overwrite=overwrite, progress=bar,
                            session={"command": " ".join(sys.argv)})
    finally:
        bar.close()
    if res.reused:
        click.echo(f"{res.reused} of {len(res.table)} cases reused from the earlier run in {target}/", err=True)
    click.echo(res.text())
    click.echo("")
    click.echo(res.legend())
    for f in res.failed:
        click.echo(f"failed: {f['knot']} at mu = {f['mu']:g} (case {f['case_id']}): {f['error']}", err=True)
    for note in res.notes:
        click.echo(f"note: pictures: {note}", err=True)
    if quick:
        from knotsim.study.compare import QUICK_WARNING

        click.echo(f"note: {QUICK_WARNING}")
    click.echo(f"report: {res.report}")
    if res.all_failed:
        raise click.exceptions.Exit(EXIT_FAILED_CHECKS)
