"""Loading protocols (knot tightening and strength tests) and strength metrics.

>>> from knotsim.protocols import run_protocol
>>> result = run_protocol("overhand-pull", knot="overhand_n2", out_dir="runs/n2",
...                       overrides={"mu": 0.1, "dt": 1e-3})
>>> result["outcome"], result.metrics["F_norm_peak"], result.log["F_norm"]

Protocols (see each module for the published set-up it reproduces):

- ``overhand-pull`` (:mod:`~knotsim.protocols.overhand_pull`): overhand knots ``overhand_n1..n4``;
- ``single-rod-bend`` (:mod:`~knotsim.protocols.single_rod_bend`): ``single_rod_reef`` / ``single_rod_granny``;
- ``two-rope-bend`` (:mod:`~knotsim.protocols.two_rope_bend`): reef/granny/thief/grief bends.

Every run can be given any starting geometry (``geometry=``: a node file or an earlier run's
directory) and is a run description plus metrics (:func:`build_protocol_run`). Every run returns a :class:`ProtocolResult` (the summary: parameters, metrics, outcome, wall time,
worst penetration, contact statistics; and the per-step log) and writes it as ``summary.json``
next to ``trajectory.h5`` / ``log.parquet`` / ``run.json`` when ``out_dir`` is given. Metrics are pure functions of the log: :mod:`knotsim.protocols.metrics`.
"""

import importlib

# Names load on first use (PEP 562), so that ``knotsim.cli.protocols`` (imported by ``knotsim --help``)
# does not pull in pandas, scipy and the protocol modules.
_LAZY = {"LoadingProtocol": "base", "ProtocolResult": "base", "RunContext": "base",
         "build_protocol_run": "pipeline", "run_protocol": "pipeline",
         "COMMON_DEFAULTS": "params", "parse_assignments": "params", "resolve_params": "params",
         "default_protocol": "registry", "get_protocol": "registry", "protocols": "registry"}


def __getattr__(name):
    if name in _LAZY:
        return getattr(importlib.import_module(f"knotsim.protocols.{_LAZY[name]}"), name)
    raise AttributeError(f"module 'knotsim.protocols' has no attribute {name!r}")

__all__ = [
    "COMMON_DEFAULTS",
    "LoadingProtocol",
    "ProtocolResult",
    "RunContext",
    "build_protocol_run",
    "default_protocol",
    "get_protocol",
    "parse_assignments",
    "protocols",
    "resolve_params",
    "run_protocol",
]
