"""``[[obstacles]]`` in run files: parsed, built into the simulation, logged, continued from a
checkpoint bit for bit, and every mistake reported with its key path."""

from __future__ import annotations

import copy

import numpy as np
import pytest

import knotsim as ks
from knotsim.contact.obstacles import Capsule, Plane, Sphere
from knotsim.errors import ConfigError
from knotsim.io.config import load_config
from knotsim.runspec import build_simulation

BASE = {
    "rods": [{"name": "rope", "shape": "straight", "length": 0.2, "n_nodes": 21, "start": [0.0, 0.0, 1.7e-3],
              "direction": [1.0, 0.0, 0.0], "radius": 1.6e-3, "youngs_modulus": 1e6, "density": 1000.0}],
    "model": {"gravity": [0.0, 0.0, -9.81], "damping": 0.01},
    "obstacles": [
        {"type": "plane", "name": "floor", "point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0], "mu": 0.4},
        {"type": "capsule", "name": "peg", "a": [0.1, -0.05, 0.05], "b": [0.1, 0.05, 0.05], "radius": 0.01,
         "angular_velocity": [0.0, 1.0, 0.0]},
        {"type": "sphere", "name": "ball", "center": [0.5, 0.0, 0.5], "radius": 0.02, "velocity": [0.0, 0.0, -0.1],
         "stiffness": 100.0, "rods": ["rope"]},
    ],
    "solver": {"dt": 1e-3},
    "run": {"duration": 0.05},
}


def test_run_file_obstacles_are_built_and_logged(tmp_path):
    cfg = load_config(BASE)
    sim = build_simulation(cfg)
    obs = [i for i in sim.stepper.interactions if isinstance(i, ks.Obstacle)]
    assert [type(o) for o in obs] == [Plane, Capsule, Sphere]
    assert [o.name for o in obs] == ["floor", "peg", "ball"]
    assert obs[0].mu == 0.4 and obs[2].stiffness == 100.0 and np.array_equal(obs[1].omega, [0, 1, 0])
    assert np.allclose(obs[2].geometry(1.0)[:3], [0.5, 0.0, 0.4])
    # each build is fresh (the stiffness memory is per simulation)
    assert cfg.build_obstacles()[0] is not cfg.build_obstacles()[0]
    res = ks.run(BASE, tmp_path / "a")
    weight = cfg.model.total_mass() * 9.81
    assert res.log["floor_fz"].iloc[-1] == pytest.approx(-weight, rel=0.05)
    for col in ("floor_fx", "floor_mz", "peg_n_contacts", "ball_k_c", "energy_floor"):
        assert col in res.log.columns


def test_continued_run_matches_uninterrupted(tmp_path):
    """2T = T + T bit for bit with obstacles (T not a multiple of dt: the checkpoint resumes before
    the shortened last step, as for rope contact)."""
    total = 0.0375
    whole = ks.run(BASE, tmp_path / "whole", duration=total)
    first = ks.run(BASE, tmp_path / "first", duration=total / 2)
    second = ks.run(tmp_path / "first" / "run.toml", tmp_path / "second", duration=total / 2,
                    continue_from=first.output_dir)
    assert second.state.time == whole.state.time
    np.testing.assert_array_equal(whole.state.q, second.state.q)
    assert whole.log["floor_k_c"].iloc[-1] == second.log["floor_k_c"].iloc[-1]


@pytest.mark.parametrize("change,field,message", [
    ({"type": "cone"}, "obstacles[0].type", "unknown obstacle type"),
    ({"radius": 0.1}, "obstacles[0].radius", "not used by type 'plane'"),
    ({"colour": "red"}, "obstacles[0].colour", "unknown"),
    ({"normal": [0.0, 0.0, 0.0]}, "obstacles[0].normal", "zero vector"),
    ({"mu": -1.0}, "obstacles[0].mu", "non-negative"),
    ({"rods": ["nope"]}, "obstacles[0].rods", "nope"),
    ({"name": "contact"}, "obstacles[0].name", "other than"),
    ({"velocity": [0, 0, 1], "waypoints": {"times": [0, 1], "points": [[0, 0, 0], [0, 0, 1]]}},
     "obstacles[0].velocity", "at most one"),
    ({"waypoints": {"times": [0, 1], "points": [[0, 0, 1], [0, 0, 1]]}}, "obstacles[0].waypoints.points",
     "start at"),
])
def test_errors_name_the_key(change, field, message):
    raw = copy.deepcopy(BASE)
    raw["obstacles"][0].update(change)
    with pytest.raises(ConfigError, match=message) as info:
        load_config(raw)
    assert info.value.field == field


def test_duplicate_and_clashing_names():
    raw = copy.deepcopy(BASE)
    raw["obstacles"][1]["name"] = "floor"
    with pytest.raises(ConfigError, match="duplicate") as info:
        load_config(raw)
    assert info.value.field == "obstacles[1].name"
    raw = copy.deepcopy(BASE)
    raw["bc"] = [{"type": "hold", "name": "floor", "nodes": [0]}]
    with pytest.raises(ConfigError, match="also a"):
        load_config(raw)
