"""Every run file in examples/ loads (load_config checks every table, node range and path start)
and builds its simulation."""

from __future__ import annotations

from pathlib import Path

import pytest

from knotsim.io.config import load_config
from knotsim.runspec import build_simulation

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.toml"))


def test_the_examples_are_there():
    names = {p.stem for p in EXAMPLES}
    assert {"capstan", "floor", "euler_column", "michell_ring", "spring_grip"} <= names


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_loads(path):
    cfg = load_config(path)
    assert cfg.duration > 0
    sim = build_simulation(cfg)
    assert sim.model.n_dofs > 0
