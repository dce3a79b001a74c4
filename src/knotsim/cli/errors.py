"""Exit codes and error handling shared by every ``knotsim`` command."""

from __future__ import annotations

import errno
import functools
import signal
import threading

import click

EXIT_FAILED_CHECKS = 1  # also: some cases of a study failed
EXIT_BAD_INPUT = 2
EXIT_SIMULATION = 3


def error(message: str, code: int):
    """Print ``message`` on stderr and exit with ``code``."""
    click.echo(f"error: {message}", err=True)
    raise click.exceptions.Exit(code)


EXIT_TERMINATED = 128 + 15  # the shell's code of a process ended by SIGTERM


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived (``timeout``, SLURM, ``docker stop``): handled like Ctrl-C, so a run
    writes its log, ``run.json`` and checkpoint (outcome ``"interrupted"``) before it exits."""


#: s after which a SIGTERM that arrived inside a finaliser is raised again
RETRY_SECONDS = 0.05


def _in_finaliser(frame) -> bool:
    """Whether ``frame`` runs inside a finaliser (``__del__``, a weakref callback), where Python prints
    an exception "ignored" and carries on: a SIGTERM raised there would be lost."""
    while frame is not None:
        if frame.f_code.co_name == "__del__" or frame.f_code.co_filename.endswith("weakref.py"):
            return True
        frame = frame.f_back
    return False


def _on_sigterm(signum, frame):
    if _in_finaliser(frame):  # raise it again shortly, outside the finaliser
        signal.signal(signal.SIGALRM, _on_sigterm)
        signal.setitimer(signal.ITIMER_REAL, RETRY_SECONDS)
        return
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # a second SIGTERM must not cut the final writes
    raise Terminated("terminated by SIGTERM")


def _os_error(exc: OSError) -> str:
    where = f" {exc.filename!r}" if exc.filename else ""
    what = {errno.ENOSPC: "the disk is full", errno.EROFS: "the file system is read-only",
            errno.EACCES: "permission denied", errno.ENOTDIR: "a part of the path is a file, not a directory",
            errno.EEXIST: "it already exists", errno.EDQUOT: "the disk quota is exhausted"}.get(exc.errno)
    return f"cannot write or read{where}: {what or exc.strerror or exc}"


def exit_codes(func):
    """Turn knotsim's errors into a one-line message on stderr (no traceback) and an exit code:
    :data:`EXIT_SIMULATION` for a failed simulation, :data:`EXIT_BAD_INPUT` for bad input
    (operating-system errors too: a full or read-only disk, a path under a file);
    SIGTERM is handled like Ctrl-C (:class:`Terminated`, exit code :data:`EXIT_TERMINATED`)."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        from knotsim.errors import KnotsimError, SimulationError

        old = None
        if threading.current_thread() is threading.main_thread():
            old = signal.signal(signal.SIGTERM, _on_sigterm)
        try:
            return func(*args, **kwargs)
        except SimulationError as exc:
            error(f"simulation failed: {exc}", EXIT_SIMULATION)
        except (KnotsimError, FileNotFoundError) as exc:  # ConfigError, GeometryError, ...
            error(str(exc), EXIT_BAD_INPUT)
        except Terminated:
            error("terminated by SIGTERM; everything up to the last accepted step was written", EXIT_TERMINATED)
        except OSError as exc:
            error(_os_error(exc), EXIT_BAD_INPUT)
        finally:
            if old is not None:
                signal.signal(signal.SIGTERM, old)

    return wrapper
