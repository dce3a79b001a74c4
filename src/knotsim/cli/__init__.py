"""The ``knotsim`` command.

::

    knotsim run CONFIG.toml [-o OUTDIR] [--overwrite] [--duration S] [--quiet]
    knotsim run [CONFIG.toml] --from RUN_DIR [-o OUTDIR] [--duration S]
    knotsim pull KNOT | --geometry PATH -o OUTDIR [--protocol P] [--set K=V] [--quick] [--save-config F]
    knotsim tie SEQUENCE -o OUTDIR | --list
    knotsim critical-mu KNOT --load N [--mu-low M] [--mu-high M] [--tol T] [--set K=V] [--quick]
    knotsim validate [CASE ...] [--quick] [--json-only]
    knotsim warmup [--serial]
    knotsim plot RUN_DIR [-o FILE]
    knotsim export-vtk RUN_DIR -o DIR [--every N] [--ascii]
    knotsim render RUN_DIR [--frames last|first|all|I,J,..] [-o DIR] [--view iso|top|front|ELEV,AZIM]
    knotsim --version

Exit codes: 0 success; 1 validation failures; 2 bad input (:class:`~knotsim.errors.ConfigError`,
:class:`~knotsim.errors.GeometryError`, unknown names, usage errors); 3 the simulation failed
(:class:`~knotsim.errors.SimulationError`). Errors are printed on stderr without a traceback.

Modules: :mod:`~knotsim.cli.commands` (the main group; ``run``, ``validate``, ``warmup``, ``plot``,
``export-vtk``, ``render``), :mod:`~knotsim.cli.protocols` (``knots``, ``pull``, ``tie``),
:mod:`~knotsim.cli.study` (``study``, ``report``, ``animate``, ``critical-mu``), :mod:`~knotsim.cli.view` (``view``),
:mod:`~knotsim.cli.errors` (exit codes, one-line errors) and :mod:`~knotsim.cli.output` (output
directories, the compile notice). ``python -m knotsim.cli`` runs the same command.

Adding a command: write a function decorated with ``@click.command()`` and ``@exit_codes``
(:mod:`knotsim.cli.errors`) in a module of this package and add it in
:func:`knotsim.cli.commands._register_subcommands` (or decorate it with ``@main.command()`` in
:mod:`~knotsim.cli.commands`); import heavy modules inside the function so that ``knotsim --help``
stays fast.
"""

from knotsim.cli.commands import main

__all__ = ["main"]
