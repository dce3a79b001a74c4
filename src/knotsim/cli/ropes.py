"""Command ``knotsim ropes``: the rope presets (registered on the main group by
:mod:`knotsim.cli.commands`; the table is :data:`knotsim.rods.ropes.ROPE_PRESETS`)::

    knotsim ropes [--sources]

One row per preset: name, diameter, linear density, EA, EI, GJ, friction, ``EA h^2/EI``; with
``--sources`` each number's source below its row. Use a preset with ``knotsim pull KNOT --rope NAME``.
"""

from __future__ import annotations

import click

from knotsim.cli.errors import exit_codes


@click.command("ropes")
@click.option("--sources/--no-sources", default=True, show_default=True,
              help="Print where each number comes from (docs/bibliography.md) below its rope.")
@exit_codes
def ropes(sources: bool):
    """List the rope presets: diameter, linear density, axial (EA), bending (EI) and torsional (GJ)
    stiffness, friction, EA h^2/EI (4 for a solid rod), and the source of each number."""
    from knotsim.rods.ropes import ROPE_PRESETS

    head = ("name", "d mm", "g/m", "EA N", "EI N m^2", "GJ N m^2", "mu", "mu_s", "EA h^2/EI", "T h^2/EI at 10 N")
    rows = [(p.name, f"{p.diameter * 1e3:.3g}", f"{p.linear_density * 1e3:.3g}", f"{p.EA:.3g}", f"{p.EI:.3g}",
             f"{p.GJ:.3g}", f"{p.mu:g}", f"{p.mu_static:g}", f"{p.stiffness_ratio:.3g}",
             f"{p.tension_ratio(10.0):.3g}") for p in ROPE_PRESETS.values()]
    width = [max(len(r[i]) for r in [head, *rows]) for i in range(len(head))]
    click.echo("  ".join(h.ljust(w) for h, w in zip(head, width, strict=True)).rstrip())
    for p, row in zip(ROPE_PRESETS.values(), rows, strict=True):
        click.echo("  ".join(c.ljust(w) for c, w in zip(row, width, strict=True)).rstrip())
        if sources:
            click.echo(f"    {p.description}")
            for key, text in p.sources:
                click.echo(f"    {key}: {text}")
    click.echo("use one: knotsim pull KNOT --rope NAME (a --set KEY=VALUE of radius, density, youngs_modulus, "
               "bending_stiffness, torsional_stiffness, mu or contact.mu_static wins over the preset)")


#: the ``--rope NAME`` option of ``pull``, ``compare`` and ``critical-mu``
rope_option = click.option("--rope", "rope", default=None, metavar="NAME",
                           help="A rope preset (knotsim ropes lists them): its radius, density, EA, EI, GJ and "
                                "friction; a --set of one of those keys wins. Same as --set rope=NAME.")


def add_rope(overrides: dict, rope: str | None) -> dict:
    """``overrides`` with ``rope`` (the ``--rope`` option) as ``overrides["rope"]``; giving both
    ``--rope`` and another ``--set rope=...`` raises :class:`~knotsim.errors.ConfigError`."""
    from knotsim.errors import ConfigError

    if rope is None:
        return overrides
    if overrides.get("rope", rope) != rope:
        raise ConfigError("rope", f"give --rope {rope} or --set rope={overrides['rope']}, not both")
    return {**overrides, "rope": rope}
