"""Exit codes and error handling shared by every ``knotsim`` command (kept apart from
:mod:`knotsim.cli` so that command modules elsewhere can import it without a cycle)."""

from __future__ import annotations

import functools

import click

EXIT_FAILED_CHECKS = 1  # also: some cases of a study failed
EXIT_BAD_INPUT = 2
EXIT_SIMULATION = 3


def error(message: str, code: int):
    """Print ``message`` on stderr and exit with ``code``."""
    click.echo(f"error: {message}", err=True)
    raise click.exceptions.Exit(code)


def exit_codes(func):
    """Turn knotsim's errors into a one-line message on stderr (no traceback) and an exit code:
    :data:`EXIT_SIMULATION` for a failed simulation, :data:`EXIT_BAD_INPUT` for bad input."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        from knotsim.errors import KnotsimError, SimulationError

        try:
            return func(*args, **kwargs)
        except SimulationError as exc:
            error(f"simulation failed: {exc}", EXIT_SIMULATION)
        except (KnotsimError, FileNotFoundError) as exc:  # ConfigError, GeometryError, ...
            error(str(exc), EXIT_BAD_INPUT)

    return wrapper
