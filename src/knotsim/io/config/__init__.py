"""Run files: a TOML description of a run (rods, boundary conditions, contact, solver, stages),
checked key by key and turned into ready-to-use objects.

>>> cfg = load_config("examples/pull_both_ends.toml")
>>> sim = knotsim.runspec.build_simulation(cfg)     # the run builder makes the simulation
>>> log = sim.run(cfg.duration, output_dir="out", output_interval=cfg.output_interval)

Every value is in SI units (m, s, kg, N, Pa, rad). An unknown key, a value of the wrong type or out
of range raises :class:`~knotsim.errors.ConfigError` whose field is the full key path
(``rods[0].youngs_modulus``, ``bc[2].waypoints.times``, ``stages[1].bc[0].nodes``), with a
suggestion for misspelt keys. The format, table by table, is in ``docs/run-files.md``; the
modules: :mod:`~knotsim.io.config.rods` (shapes and geometry sources),
:mod:`~knotsim.io.config.bc` (boundary conditions), :mod:`~knotsim.io.config.loader` (the rest).
"""

from knotsim.io.config.loader import RunConfig, contact_interactions, load_config

__all__ = ["RunConfig", "contact_interactions", "load_config"]
