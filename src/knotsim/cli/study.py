"""Commands ``study``, ``report`` and ``animate`` (registered on the main group by
:mod:`knotsim.cli.commands`)::

    knotsim study STUDY.toml -o STUDY_DIR [--workers N] [--scheduler tcp://HOST:PORT] [--resume]
                  [--retry-failed] [--dry-run] [--quiet] [--pack]
    knotsim study --pack -o STUDY_DIR
    knotsim report STUDY_DIR [-o REPORT.md]
    knotsim animate RUN_DIR [--case ID] -o OUT.gif|OUT.mp4 [--fps F] [--every N] [--size WxH]

Exit codes as in :mod:`knotsim.cli`: 0 success; 1 some cases of the study failed; 2 bad input;
3 a simulation failed.
"""

from __future__ import annotations

import time
from pathlib import Path

import click

from knotsim.cli.errors import EXIT_FAILED_CHECKS as EXIT_FAILED_CASES
from knotsim.cli.errors import exit_codes as _exit_codes
from knotsim.cli.ropes import add_rope, rope_option

__all__ = ["animate", "report", "study"]


def _fmt_time(s: float | None) -> str:
    if s is None:
        return "?"
    s = int(round(s))
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m:02d}:{sec:02d}"


class _Bar:
    """Progress line on stderr: done / failed / running, elapsed and ETA."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.bar = None
        self._last = 0.0

    def __call__(self, p) -> None:
        if not self.enabled:
            return
        if self.bar is None:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=p.todo, unit="case", dynamic_ncols=True,
                            bar_format="{l_bar}{bar}| {n}/{total}{postfix}")
        if p.last is not None and p.last.get("outcome") == "failed":
            self.bar.write(f"case {p.last['case_id']} failed: {p.last.get('error')}")
        now = time.monotonic()
        if p.last is None and now - self._last < 0.5:
            return
        self._last = now
        self.bar.n = p.done
        self.bar.set_postfix_str(f"done {p.done - p.failed}, failed {p.failed}, running {p.running} "
                                 f"[elapsed {_fmt_time(p.elapsed)}, ETA {_fmt_time(p.eta)}]", refresh=False)
        self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


@click.command("study")
@click.argument("study_file", required=False, type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("-o", "--output", "study_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Study directory (study.toml, results.parquet, provenance.json, timeseries.parquet, cases/).")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Local worker processes (default: number of CPUs).")
@click.option("--scheduler", default=None, metavar="tcp://HOST:PORT",
              help="Run on this Dask distributed scheduler instead of local processes.")
@click.option("--resume", is_flag=True, help="Continue STUDY_DIR: run only the cases not finished yet.")
@click.option("--retry-failed", is_flag=True, help="With --resume, run failed cases again too.")
@click.option("--dry-run", is_flag=True, help="List the cases and exit.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
@click.option("--pack", is_flag=True,
              help="Then fold the case directories into cases.parquet and timeseries.parquet and remove them "
                   "(the study still reopens and resumes; full logs and trajectories go). Without STUDY_FILE: "
                   "only pack STUDY_DIR.")
@_exit_codes
def study(study_file: Path | None, study_dir: Path, workers: int | None, scheduler: str | None, resume: bool,
          retry_failed: bool, dry_run: bool, quiet: bool, pack: bool):
    """Run every case of the parametric study STUDY_FILE (see docs/studies.md); with --pack, then
    pack STUDY_DIR (without STUDY_FILE: only pack it)."""
    import sys

    from knotsim.study.runner import plan_study, run_study
    from knotsim.study.spec import load_study_spec

    if study_file is None:
        if not pack:
            raise click.UsageError("missing STUDY_FILE (only --pack goes without one)")
        _pack(study_dir)
        return
    if retry_failed and not resume:
        raise click.UsageError("--retry-failed needs --resume")
    spec = load_study_spec(study_file)
    if dry_run:
        cases = spec.expand()
        click.echo(f"{len(cases)} cases")
        for c in cases:
            params = ", ".join(f"{k} = {v!r}" for k, v in c.params.items())
            click.echo(f"{c.case_id}  {c.kind:8s}  {params}")
        return
    _, cases, reused, todo = plan_study(spec, study_dir, resume=resume, retry_failed=retry_failed)
    where = f"Dask scheduler {scheduler}" if scheduler else f"{workers or 'all'} local worker processes"
    msg = f"{len(cases)} cases"
    if reused:
        msg += f" ({len(reused)} already finished, {len(todo)} to run)"
    click.echo(f"{msg} on {where}; results in {study_dir}/")
    if todo and not scheduler:  # compile once here rather than in every worker process
        from knotsim.cli.output import announce_compile

        announce_compile(contact=True)
    bar = _Bar(enabled=not quiet and sys.stderr.isatty())
    try:
        df = run_study(spec, study_dir, workers=workers, scheduler=scheduler, resume=resume,
                       retry_failed=retry_failed, progress=bar,
                       session={"command": " ".join(sys.argv)})
    finally:
        bar.close()
    n_fail = int((df["outcome"] == "failed").sum()) if len(df) else 0
    click.echo(f"{len(df) - n_fail} cases completed, {n_fail} failed; table in {study_dir / 'results.parquet'}")
    if pack:
        _pack(study_dir)
    if n_fail:
        for _, row in df[df["outcome"] == "failed"].iterrows():
            click.echo(f"  failed {row['case_id']}: {row['error']}", err=True)
        raise click.exceptions.Exit(EXIT_FAILED_CASES)


def _pack(study_dir: Path) -> None:
    from knotsim.study.store import pack_study

    done = pack_study(study_dir)
    click.echo(f"packed {done['cases']} cases ({done['series']} with a time series) into "
               f"{study_dir / 'cases.parquet'}; {done['removed']} case directories removed")


@click.command("report")
@click.argument("study_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("-o", "--output", "out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Report file (default STUDY_DIR/report.md; figures next to it in report_figures/).")
@click.option("--metric", "metrics", multiple=True, metavar="NAME",
              help="Plot only this metric against the swept parameters (repeatable), e.g. --metric F_norm_hold.")
@_exit_codes
def report(study_dir: Path, out: Path | None, metrics: tuple[str, ...]):
    """Write a Markdown report (tables and PNG plots) of the study in STUDY_DIR."""
    import sys

    from knotsim.study.report import write_report

    path = write_report(study_dir, out, plot_metrics=list(metrics) or None, progress=sys.stderr.isatty())
    click.echo(str(path))


@click.command("animate")
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--case", "case_id", default=None,
              help="RUN_DIR is a study directory: animate this case (id or unique prefix).")
@click.option("-o", "--output", "out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Output file, .gif or .mp4.")
@click.option("--fps", type=click.FloatRange(min=0, min_open=True), default=20.0, show_default=True)
@click.option("--every", type=click.IntRange(min=1), default=1, show_default=True, help="Use every N-th frame.")
@click.option("--size", default="640x480", show_default=True, help="WIDTHxHEIGHT, pixels.")
@click.option("--view", default="iso", show_default=True, help="iso, top, front or ELEV,AZIM (degrees).")
@click.option("--backend", type=click.Choice(["auto", "pyvista", "matplotlib"]), default="auto", show_default=True)
@_exit_codes
def animate(run_dir: Path, case_id: str | None, out: Path, fps: float, every: int, size: str, view: str,
            backend: str):
    """Animate the trajectory of RUN_DIR (or of a case of a study directory) as a GIF or MP4."""
    from knotsim.errors import ConfigError
    from knotsim.viz.animate import animate_run

    if case_id is not None:
        cases = run_dir / "cases"
        if not case_id or not all(c in "0123456789abcdef" for c in case_id.lower()):
            raise ConfigError("case", f"expected a case id (hexadecimal digits, e.g. 3f2a), got {case_id!r}")
        found = sorted(d for d in cases.glob(f"{case_id.lower()}*") if d.is_dir()) if cases.is_dir() else []
        if not found:
            raise ConfigError("case", f"no case {case_id!r} in {run_dir}/cases")
        if len(found) > 1:
            raise ConfigError("case", f"{case_id!r} matches {len(found)} cases; give more digits")
        run_dir = found[0]
    if not (run_dir / "trajectory.h5").is_file():
        raise ConfigError("run_dir", f"{run_dir} has no trajectory.h5"
                          + ("; for a study directory pass --case ID" if (run_dir / "cases").is_dir() else ""))
    try:
        w, h = (int(x) for x in size.lower().split("x"))
    except ValueError:
        raise click.BadParameter("expected WIDTHxHEIGHT in pixels, e.g. 640x480", param_hint="--size") from None
    if view in ("iso", "top", "front"):
        v = view
    else:
        try:
            elev, azim = (float(x) for x in view.split(","))
        except ValueError:
            raise click.BadParameter("expected iso, top, front or ELEV,AZIM", param_hint="--view") from None
        v = (elev, azim)
    path = animate_run(run_dir, out, fps=fps, every=every, size=(w, h), backend=backend, view=v)
    click.echo(str(path))


@click.command("critical-mu")
@click.argument("knot")
@click.option("--load", "load", required=True, type=float, help="Load held on the standing end, N.")
@click.option("--mu-low", type=float, default=0.05, show_default=True, help="Bottom of the bracket searched.")
@click.option("--mu-high", type=float, default=0.8, show_default=True, help="Top of the bracket searched.")
@click.option("--tol", type=float, default=0.02, show_default=True, help="Width of the final bracket in mu.")
@click.option("--drift-limit", type=float, default=1e-3, show_default=True,
              help="m; a hold that moved the loaded end this far over its second half counts as slipping.")
@click.option("--set", "assignments", multiple=True, metavar="KEY=VALUE",
              help="A knot-security parameter (repeatable), e.g. --set set_tension=0.02.")
@rope_option
@click.option("--quick", is_flag=True, help="The protocol's coarse, short settings.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@_exit_codes
def critical_mu(knot: str, load: float, mu_low: float, mu_high: float, tol: float, drift_limit: float,
                assignments: tuple[str, ...], rope: str | None, quick: bool, as_json: bool):
    """The least friction coefficient at which KNOT, set by the knot-security protocol, holds LOAD
    (bisection over hold runs; docs/protocols.md)."""
    import json

    from knotsim.protocols.params import parse_assignments
    from knotsim.study.critical import critical_friction

    res = critical_friction(knot, load, mu_low=mu_low, mu_high=mu_high, tol=tol, drift_limit=drift_limit,
                            overrides=add_rope(parse_assignments(assignments), rope), quick=quick)
    if as_json:
        click.echo(json.dumps({"knot": res.knot, "load": res.load, "mu_slip": res.mu_slip, "mu_hold": res.mu_hold,
                               "mu_c": res.mu_c, "runs": res.runs}, default=float))
        return
    if res.mu_slip is None:
        click.echo(f"{knot}: holds {load:g} N already at mu = {res.mu_hold:g} (the bottom of the bracket)")
    elif res.mu_hold is None:
        click.echo(f"{knot}: slips under {load:g} N even at mu = {mu_high:g} (the top of the bracket)")
    else:
        click.echo(f"{knot}: mu_c = {res.mu_c:.4g} (slips at {res.mu_slip:.4g}, holds at {res.mu_hold:.4g}) "
                   f"under {load:g} N")
    for r in res.runs:
        click.echo(f"  mu = {r['mu']:.4g}: {'holds' if r['holds'] else 'slips'} ({r['outcome']}, drift "
                   f"{r['drift_pull'] if r['drift_pull'] is not None else float('nan'):.3g} m)")
