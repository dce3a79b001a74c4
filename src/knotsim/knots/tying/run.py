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

__all__ = ["EXPECTED", "GAP_LIMIT_DIAMETERS", "TyingResult", "list_tying_sequences", "load_tying_config", "tie_from_straight",
           "tying_sequence_path"]

_PKG = "knotsim.data.tying"

#: Largest rope length between the two half-knots of a tied reef or granny, in rope diameters
#: (issue 12: the second half-knot sits on the first).
GAP_LIMIT_DIAMETERS = 10.0

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
    half_knot: object = field(repr=False, default=None)

    def summary(self) -> dict:
        """The ``summary.json`` record of the tie: sequence, knot type found and expected, topology
        (Rolfsen name, chirality, crossings, writhe), for a reef or granny the
        :func:`~knotsim.knots.tying.gap.half_knot_gap` record (m, and in rope diameters) and its
        limit (10 diameters), wall and simulated time (s), steps and the worst penetration (1)."""
        t = self.topology
        out = {"sequence": self.name, "knot_type": self.knot_type, "expected": list(self.expected), "ok": self.ok,
               "topology": None if t is None else {
                   "knot_type": t.knot_type, "rolfsen": t.rolfsen, "chirality": t.chirality,
                   "n_crossings": int(t.n_crossings), "n_crossings_reduced": int(t.n_crossings_reduced),
                   "writhe_reduced": int(t.writhe_reduced)},
               "wall_time": self.wall_time, "sim_time": self.sim_time, "steps": self.steps,
               "max_penetration_ratio": self.max_penetration_ratio}
        if self.half_knot is not None:
            out.update(self.half_knot.as_dict())
            out["half_knot_gap_limit_diameters"] = GAP_LIMIT_DIAMETERS
            d = self.half_knot.diameters
            out["half_knot_gap_ok"] = d is not None and d <= GAP_LIMIT_DIAMETERS
        return out


def tie_from_straight(name: str, out_dir=None, overrides: dict | None = None,
                      progress: bool | None = None, config: dict | None = None) -> TyingResult:
    """Run the shipped tying sequence ``name`` from the straight rod and identify the knot.

    ``overrides`` is merged into the configuration dict (e.g. ``{"run": {"output_interval": 0.1}}``).
    ``config``: a run configuration dict to tie with instead of the shipped file of ``name`` (e.g. a
    variant ``channel_sequence(name, n_nodes=401)[0]``; relative paths resolve beside the shipped
    sequences); the knot is checked against ``name``'s expected types all the same.
    With ``out_dir`` the run files (trajectory, log, run.json, run.toml, checkpoint.npz) are
    written there, so that ``knotsim pull --geometry OUT_DIR`` loads the tied knot next. The knot
    type is :func:`knotsim.knots.topology.analyze` of the final centreline with its far-away
    closure. The sequence runs through the one run builder (:func:`knotsim.runspec.run`). For a
    reef or granny the rope length between the two half-knots is measured
    (:func:`~knotsim.knots.tying.gap.half_knot_gap`, ``res.half_knot``); with ``out_dir``,
    :meth:`TyingResult.summary` is written there as ``summary.json``.
    """
    from knotsim._util.jsonio import write_json
    from knotsim.knots.topology import analyze
    from knotsim.knots.tying.gap import half_knot_gap
    from knotsim.runspec import RunSpec, run

    cfg = load_tying_config(name) if config is None else config
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
    gap = None
    if name in ("reef", "granny"):
        gap = half_knot_gap(x, float(cfg["rods"][0]["radius"]))
    res = TyingResult(name, topo.knot_type, exp, topo.knot_type in exp, wall, float(sim.state.time), len(log),
                      pen, Path(out_dir) if out_dir is not None else None, topo, x, gap)
    if out_dir is not None:
        write_json(Path(out_dir) / "summary.json", res.summary())
    return res

