"""``python -m knotsim.cli``: the ``knotsim`` command."""

from knotsim.cli import main

main()
