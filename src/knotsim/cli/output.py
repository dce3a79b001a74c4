"""Output directories of the ``knotsim`` commands that write a run (``run``, ``pull``, ``tie``).

- ``-o ''`` is a usage error (exit code 2), not the current directory (:data:`OUTPUT_DIR`);
- without ``-o`` the run goes to a default directory under ``runs/`` (:func:`default_dir`), which is
  printed on stderr;
- a directory that exists and is not empty is refused unless ``--overwrite`` is given; then the
  files knotsim writes into a run directory (:data:`RUN_FILES`) are deleted first, so that old
  results are never left beside new ones; any other file there is left alone.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import click

from knotsim.errors import ConfigError

__all__ = ["OUTPUT_DIR", "RUN_FILES", "announce_compile", "clear_run_files", "default_dir", "prepare_output"]

#: What knotsim writes into a run directory (files and directories), removed by ``--overwrite``.
RUN_FILES = ("trajectory.h5", "log.parquet", "run.json", "run.toml", "checkpoint.npz", "summary.json",
             "render", "force.png", "start.png", "end.png")


class _OutputDir(click.ParamType):
    """A directory path that must not be empty text (``-o ''`` would otherwise mean ``.``)."""

    name = "directory"

    def convert(self, value, param, ctx):
        if isinstance(value, Path):
            return value
        if not str(value).strip():
            self.fail("must not be empty: give a directory, or leave -o out for the default under runs/",
                      param, ctx)
        path = Path(value)
        if path.exists() and not path.is_dir():
            self.fail(f"{str(path)!r} is a file, not a directory", param, ctx)
        return path


#: click parameter type of the ``-o/--output`` options of ``run``, ``pull`` and ``tie``.
OUTPUT_DIR = _OutputDir()


def default_dir(*parts: str) -> Path:
    """``runs/<part1>-<part2>...`` (relative to the current directory), each part reduced to
    letters, digits, ``_``, ``.`` and ``-``."""
    name = "-".join(re.sub(r"[^A-Za-z0-9_.-]+", "_", str(p)).strip("_") for p in parts if p)
    return Path("runs") / (name or "run")


def clear_run_files(outdir: Path) -> list[Path]:
    """Delete the :data:`RUN_FILES` present in ``outdir``; returns what was deleted."""
    removed = []
    for name in RUN_FILES:
        p = outdir / name
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p)
        elif p.exists() or p.is_symlink():
            p.unlink()
        else:
            continue
        removed.append(p)
    return removed


def prepare_output(outdir: Path | None, default: Path, overwrite: bool) -> Path:
    """The output directory of a run command: ``outdir``, or ``default`` (announced on stderr) when
    ``-o`` was not given.

    Raises
    ------
    ConfigError
        (field ``output``) when the directory exists, is not empty and ``overwrite`` is false.
    """
    if outdir is None:
        outdir = default
        click.echo(f"output directory: {outdir} (choose another with -o DIR)", err=True)
    if outdir.is_dir() and any(outdir.iterdir()):
        if not overwrite:
            raise ConfigError("output", f"{outdir} is not empty; pass --overwrite to replace knotsim's files "
                                        "there, or choose another directory with -o")
        clear_run_files(outdir)
    return outdir


def announce_compile(contact=True, topology: bool = True, obstacles: bool = False) -> None:
    """When the kernels a run needs are not in numba's cache yet, say so on stderr before anything
    compiles. With a spare CPU (:func:`knotsim._warmup.spare_cores`) compile them first in two
    processes (:func:`knotsim._warmup.warm_up`) and say how long it took; on a busy machine the run
    compiles them as it goes (a second process would only add CPU time). ``contact``: ``False`` or
    ``None`` (none), ``True`` (the protocols' settings) or the run's ``[contact]`` table
    (:func:`knotsim._warmup.run_groups`)."""
    from knotsim._warmup import kernels_cached, run_groups, spare_cores, warm_up

    if kernels_cached(contact=contact, topology=topology, obstacles=obstacles):
        return
    parallel = spare_cores() >= 1.0
    click.echo("note: compiling the numerical kernels for the first time: about 45 s of CPU time"
               + (", in 2 processes" if parallel else " (the machine is busy: in this process, as the run goes)")
               + "; cached for later runs; `knotsim warmup` does this ahead ...", err=True)
    if parallel:
        times = warm_up(parallel=True, groups=run_groups(contact, topology, obstacles))
        click.echo(f"note: kernels compiled in {times['total']:.0f} s", err=True)
