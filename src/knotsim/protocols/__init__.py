"""Loading protocols (knot tightening and strength tests) and strength metrics.

>>> from knotsim.protocols import run_protocol
>>> summary = run_protocol("overhand-pull", knot="overhand_n2", out_dir="runs/n2",
...                        overrides={"mu": 0.1, "dt": 1e-3})

Protocols (see each module for the published set-up it reproduces):

- ``overhand-pull`` (:mod:`~knotsim.protocols.overhand_pull`): overhand knots ``overhand_n1..n4``;
- ``single-rod-bend`` (:mod:`~knotsim.protocols.single_rod_bend`): ``single_rod_reef`` / ``single_rod_granny``;
- ``two-rope-bend`` (:mod:`~knotsim.protocols.two_rope_bend`): reef/granny/thief/grief bends.

Every run writes ``summary.json`` (parameters, metrics, outcome, wall time, worst penetration,
contact statistics) next to ``trajectory.h5`` / ``log.parquet`` / ``run.json`` when ``out_dir`` is
given. Metrics are pure functions of the log: :mod:`knotsim.protocols.metrics`.
"""

from knotsim.protocols.base import (
    COMMON_DEFAULTS,
    Protocol,
    default_protocol,
    get_protocol,
    parse_assignments,
    protocols,
    resolve_params,
    run_protocol,
)

__all__ = [
    "COMMON_DEFAULTS",
    "Protocol",
    "default_protocol",
    "get_protocol",
    "parse_assignments",
    "protocols",
    "resolve_params",
    "run_protocol",
]
