"""The shipped tying sequences (``knotsim/data/tying/<name>.toml``): listing, loading, and running
one from the straight rod to the knot type of its final centreline."""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from knotsim._util.toml import load_toml
from knotsim.errors import ConfigError

__all__ = ["EXPECTED", "TyingResult", "list_tying_sequences", "load_tying_config", "tie_from_straight",
           "tying_sequence_path"]

_PKG = "knotsim.data.tying"

#: Expected knot type (``analyze(...).knot_type``) at the end of each shipped sequence.
EXPECTED = {"overhand": ("trefoil_left", "trefoil_right"), "reef": ("reef",),
            "granny": ("granny_left", "granny_right")}


def list_tying_sequences() -> list[str]:
    """Names of the shipped tying sequences (``knotsim/data/tying/<name>.toml``)."""
    files = resources.files(_PKG)
    return sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".toml"))


def tying_sequence_path(name: str) -> Path:
    """Path of the shipped sequence ``name``."""
    names = list_tying_sequences()
    if name not in names:
        raise ConfigError("tying", f"unknown tying sequence {name!r}; known: {names}")
    return Path(str(resources.files(_PKG) / f"{name}.toml"))


def load_tying_config(name: str) -> dict:
    """The shipped sequence ``name`` as a plain configuration dict (see :mod:`knotsim.io.config`)."""
    return load_toml(tying_sequence_path(name), "tying")


def _merge(base: dict, over: dict) -> dict:
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


@dataclass
class TyingResult:
    """Outcome of :func:`tie_from_straight`: the knot type found and the one(s) expected
    (``ok``: found among them), wall-clock and simulated time (s), number of output rows,
    the largest contact penetration ratio (penetration depth / rod radius, 1), the output
    directory, the :func:`~knotsim.knots.topology.analyze` result and the final node positions
    (N, 3) (m)."""

    name: str
    knot_type: str
    expected: tuple
    ok: bool
    wall_time: float
    sim_time: float
    steps: int
    max_penetration_ratio: float
    out_dir: Path | None
    topology: object = field(repr=False, default=None)
    positions: np.ndarray | None = field(repr=False, default=None)


def tie_from_straight(name: str, out_dir=None, overrides: dict | None = None,
                      progress: bool | None = None) -> TyingResult:
    """Run the shipped tying sequence ``name`` from the straight rod and identify the knot.

    ``overrides`` is merged into the configuration dict (e.g. ``{"run": {"output_interval": 0.1}}``).
    With ``out_dir`` the run files (trajectory, log, run.json, run.toml, checkpoint.npz) are
    written there, so that ``knotsim pull --geometry OUT_DIR`` loads the tied knot next. The knot
    type is :func:`knotsim.knots.topology.analyze` of the final centreline with its far-away
    closure. The sequence runs through the one run builder (:func:`knotsim.runspec.run`).
    """
    from knotsim.knots.topology import analyze
    from knotsim.runspec import RunSpec, run

    cfg = load_tying_config(name)
    if overrides:
        cfg = _merge(cfg, overrides)
    cfg.setdefault("provenance", {}).update({"tying_sequence": name})
    t0 = time.perf_counter()
    res = run(RunSpec(cfg, tying_sequence_path(name).parent), out_dir, progress=progress)
    wall = time.perf_counter() - t0
    sim, log = res.simulation, res.log
    x = sim.model.node_positions(sim.state.q)
    topo = analyze([x])
    exp = EXPECTED.get(name, ())
    pen = float(log["max_penetration_ratio"].max()) if "max_penetration_ratio" in log else 0.0
    return TyingResult(name, topo.knot_type, exp, topo.knot_type in exp, wall, float(sim.state.time), len(log),
                       pen, Path(out_dir) if out_dir is not None else None, topo, x)

