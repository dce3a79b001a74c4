"""TOML run configuration: round trip to a run, rod shapes, and every bad-input message."""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pandas as pd
import pytest

from knotsim.errors import ConfigError
from knotsim.io import config as cfgmod
from knotsim.io.config import load_config
from knotsim.runspec import build_simulation

TOML = """
description = "pulled rod"

[[rods]]
name = "rope"
shape = "straight"
length = 0.1
n_nodes = 11
start = [0.0, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
radius = 1e-3
youngs_modulus = 1e7
density = 1000.0
poisson_ratio = 0.5

[model]
gravity = [0.0, 0.0, -9.81]
damping = 0.01

[[bc]]
type = "clamp"
name = "left"
rod = "rope"
nodes = [0, 1]

[[bc]]
type = "move"
name = "right"
rod = "rope"
nodes = [-2, -1]
velocity = [1e-3, 0.0, 0.0]

[solver]
dt = 1e-3
max_iterations = 30
linear_solver = "auto"

[run]
duration = 0.02
output_interval = 0.005
"""


def base() -> dict:
    """The same configuration as :data:`TOML`, as a dict."""
    return {
        "rods": [{"name": "rope", "shape": "straight", "length": 0.1, "n_nodes": 11, "radius": 1e-3,
                  "youngs_modulus": 1e7, "density": 1000.0}],
        "model": {"gravity": [0.0, 0.0, -9.81]},
        "bc": [{"type": "clamp", "name": "left", "rod": "rope", "nodes": [0, 1]},
               {"type": "move", "name": "right", "rod": "rope", "nodes": [-2, -1], "velocity": [1e-3, 0, 0]}],
        "solver": {"dt": 1e-3},
        "run": {"duration": 0.02},
    }


def error_of(cfg) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        load_config(cfg)
    return info.value


# ------------------------------------------------------------------------------------------ round trip
def test_round_trip_from_toml_file(tmp_path):
    f = tmp_path / "run.toml"
    f.write_text(TOML)
    cfg = load_config(f)
    assert cfg.duration == pytest.approx(0.02)
    assert cfg.output_interval == pytest.approx(0.005)
    assert cfg.solver.dt == pytest.approx(1e-3) and cfg.solver.max_iterations == 30
    assert cfg.model.n_nodes == 11 and cfg.model.damping == pytest.approx(0.01)
    np.testing.assert_allclose(cfg.model.gravity, [0, 0, -9.81])
    sim = build_simulation(cfg)
    assert sim.config == cfg.raw
    out = tmp_path / "out"
    log = sim.run(cfg.duration, output_dir=out, output_interval=cfg.output_interval, progress=False)
    assert len(log) == 20
    for name in ("trajectory.h5", "log.parquet", "run.json"):
        assert (out / name).is_file()
    saved = pd.read_parquet(out / "log.parquet")
    for col in ("left_fx", "left_fy", "left_fz", "left_moment", "left_force", "right_fx", "right_force"):
        assert col in saved.columns
    # the moving end stretches the rod: each group pulls the rod outwards (force on the rod, N)
    assert saved["right_fx"].iloc[-1] > 0 > saved["left_fx"].iloc[-1]
    info = json.loads((out / "run.json").read_text())
    assert info["config"]["rods"][0]["name"] == "rope"
    assert info["config"]["bc"][1]["velocity"] == [1e-3, 0.0, 0.0]
    # each build gets fresh boundary conditions
    assert build_simulation(cfg).bcs is not sim.bcs


def test_duration_override_recorded(tmp_path):
    f = tmp_path / "run.toml"
    f.write_text(TOML)
    cfg = load_config(f, duration=0.5)
    assert cfg.duration == 0.5 and cfg.raw["run"]["duration"] == 0.5


def test_defaults_and_int_values():
    c = base()
    c["rods"][0]["youngs_modulus"] = 10_000_000  # TOML integers are fine where a float is expected
    del c["model"]
    del c["solver"]
    cfg = load_config(c)
    assert cfg.model.rods[0].youngs_modulus == 1e7
    assert cfg.solver.dt == 1e-3  # SolverOptions default
    assert cfg.output_interval is None
    np.testing.assert_allclose(cfg.model.gravity, 0.0)


# ------------------------------------------------------------------------------------------ shapes
def test_straight_direction_and_start():
    c = base()
    c["rods"][0].update(start=[1.0, 2.0, 3.0], direction=[0.0, 0.0, 2.0])
    x = load_config(c).model.rods[0].positions
    np.testing.assert_allclose(x[0], [1, 2, 3])
    np.testing.assert_allclose(x[-1], [1, 2, 3.1])


def test_helix_shape():
    c = base()
    c["rods"][0] = {"shape": "helix", "helix_radius": 0.02, "pitch": 0.01, "turns": 2, "n_nodes": 41,
                    "radius": 1e-3, "youngs_modulus": 1e7, "density": 1000.0}
    c["bc"] = []
    x = load_config(c).model.rods[0].positions
    np.testing.assert_allclose(np.hypot(x[:, 0], x[:, 1]), 0.02)
    assert x[-1, 2] == pytest.approx(0.02)
    np.testing.assert_allclose(x[0], [0.02, 0, 0], atol=1e-15)


def test_circle_shape_is_closed():
    c = base()
    c["rods"][0] = {"shape": "circle", "ring_radius": 0.05, "n_nodes": 20, "center": [0, 0, 1],
                    "normal": [1, 0, 0], "radius": 1e-3, "youngs_modulus": 1e7, "density": 1000.0}
    c["bc"] = []
    m = load_config(c).model
    x = m.rods[0].positions
    assert m.rod_closed[0] and m.n_edges == 20
    np.testing.assert_allclose(np.linalg.norm(x - [0, 0, 1], axis=1), 0.05)
    np.testing.assert_allclose(x[:, 0], 0.0, atol=1e-15)
    c["rods"][0]["closed"] = False
    assert error_of(c).field == "rods[0].closed"


@pytest.mark.parametrize("kind", ["inline", "npy", "csv", "csv_header"])
def test_points_shape(tmp_path, kind):
    pts = np.stack([np.linspace(0, 0.1, 6), np.zeros(6), np.linspace(0, 0.01, 6)], axis=1)
    c = base()
    rod = {"name": "rope", "shape": "points", "radius": 1e-3, "youngs_modulus": 1e7, "density": 1000.0}
    if kind == "inline":
        rod["positions"] = pts.tolist()
    elif kind == "npy":
        np.save(tmp_path / "p.npy", pts)
        rod["file"] = "p.npy"
    else:
        header = "x,y,z" if kind == "csv_header" else ""
        np.savetxt(tmp_path / "p.csv", pts, delimiter=",", header=header, comments="")
        rod["file"] = "p.csv"
    c["rods"][0] = rod
    x = load_config(c, base_dir=tmp_path).model.rods[0].positions
    np.testing.assert_allclose(x, pts)


def test_points_file_relative_to_toml(tmp_path):
    pts = np.stack([np.linspace(0, 0.1, 6), np.zeros(6), np.zeros(6)], axis=1)
    (tmp_path / "geo").mkdir()
    np.save(tmp_path / "geo" / "p.npy", pts)
    text = TOML.replace('shape = "straight"\nlength = 0.1\nn_nodes = 11\nstart = [0.0, 0.0, 0.0]\n'
                        'direction = [1.0, 0.0, 0.0]', 'shape = "points"\nfile = "geo/p.npy"')
    f = tmp_path / "run.toml"
    f.write_text(text)
    np.testing.assert_allclose(load_config(f).model.rods[0].positions, pts)


def test_rest_shape_fields():
    c = base()
    c["rods"][0].update(natural_curvature=[10.0, 0.0], natural_twist=1.0, rest_edge_length=0.011,
                        shear_modulus=3e6)
    c["rods"][0].pop("poisson_ratio", None)
    m = load_config(c).model
    np.testing.assert_allclose(m.rest_length, 0.011)
    assert m.kappa_bar[:, 0] == pytest.approx(np.full(9, 10.0 * 0.011))
    assert m.rods[0].G == 3e6


# ------------------------------------------------------------------------------------------ boundary conditions
def test_force_ramp_and_moment():
    c = base()
    c["bc"] = [{"type": "clamp", "name": "left", "nodes": [0, 1]},
               {"type": "force", "name": "pull", "nodes": [-1], "start": 0.1,
                "ramp": {"from": [0, 0, 0], "to": [1.0, 0, 0], "duration": 0.2}},
               {"type": "moment", "name": "twist", "edges": [-1], "moment": 1e-4}]
    cfg = load_config(c)
    bcs = cfg.build_bcs()
    m = cfg.model
    q = bcs.initial_q()
    tip = m.node_dof[-1]
    last_edge = m.edge_theta_dof[-1]
    for t, fx in [(0.15, 0.25), (0.2, 0.5), (0.5, 1.0)]:
        _, _, f = bcs.evaluate(t, q, t)
        assert f[tip] == pytest.approx(fx)
        assert f[last_edge] == pytest.approx(1e-4)
    _, _, f = bcs.evaluate(0.05, q, 0.05)
    assert f[tip] == 0.0


def test_release_and_later_group_on_same_nodes():
    c = base()
    c["bc"] = [{"type": "clamp", "name": "left", "nodes": [0, 1]},
               {"type": "clamp", "name": "right", "nodes": [-2, -1]},
               {"type": "move", "name": "pull", "nodes": [-2, -1], "velocity": [1e-3, 0, 0], "start": 0.5},
               {"type": "release", "name": "right", "at": 0.5}]
    bcs = load_config(c).build_bcs()
    assert bcs.groups["right"].stop == 0.5
    assert bcs.groups["pull"].start == 0.5


def test_waypoints_absolute_at_centroid_ok():
    c = base()
    c["bc"][1] = {"type": "move", "name": "right", "nodes": [-2, -1],
                  "waypoints": {"times": [0.0, 1.0], "points": [[0.095, 0, 0], [0.1, 0, 0]], "absolute": True}}
    load_config(c)


def test_contact_table_builds_the_contact_interaction():
    from knotsim.contact.model import Contact

    c = base()
    c["contact"] = {"delta": 1e-4, "mu": 0.3}
    cfg = load_config(c)
    # the friction law that runs is written down, whatever the default (run.toml, run.json)
    assert cfg.contact == {"delta": 1e-4, "mu": 0.3, "friction_model": "surface"}
    assert cfg.raw["contact"]["friction_model"] == "surface"
    (inter,) = cfgmod.contact_interactions(cfg.model, cfg.contact)
    assert isinstance(inter, Contact)
    assert inter.options.delta == 1e-4 and inter.options.mu == 0.3
    assert inter.options.friction_model == "surface"
    c["contact"] = {"mu": 0.3, "friction_model": "centreline"}
    assert load_config(c).contact["friction_model"] == "centreline"


def test_contact_table_unknown_key_is_named():
    c = base()
    c["contact"] = {"delta": 1e-4, "stiffnes": 1.0}
    with pytest.raises(ConfigError, match=r"contact\.stiffnes"):  # found when the file is read
        load_config(c)
    c["contact"] = {"friction_model": "rolling"}
    with pytest.raises(ConfigError, match=r"contact\.friction_model.*'rolling'"):
        load_config(c)


# ------------------------------------------------------------------------------------------ bad input
def _set(c, path, value):
    """Set ``c[path]`` where ``path`` is like ``rods.0.youngs_modulus``; ``value=None`` deletes."""
    keys = [int(k) if k.isdigit() else k for k in path.split(".")]
    d = c
    for k in keys[:-1]:
        d = d[k]
    if value is _DELETE:
        del d[keys[-1]]
    else:
        d[keys[-1]] = value


_DELETE = object()

BAD = [
    # (path to change, new value, expected field, expected message fragment)
    ("bc.0.nodes", [0, 11], "bc[0].nodes", "node index 11 out of range for rod 'rope' with 11 nodes"),
    ("bc.1.nodes", [-12], "bc[1].nodes", "node index -12 out of range"),
    ("bc.1.rod", "rop", "bc[1].rod", "unknown rod 'rop'"),
    ("bc.1.rod", 3, "bc[1].rod", "out of range"),
    ("bc.1.nodes", [1, 2], "bc[1].nodes", "already prescribed by clamp 'left' while both are active"),
    ("bc.1.waypoints", {"times": [0, 1], "points": [[0.5, 0, 0], [0.6, 0, 0]], "absolute": True},
     "bc[1].waypoints", "path starts at [0.5, 0.0, 0.0] m but the group's centroid is at [0.095, 0.0, 0.0] m"),
    ("bc.1.type", "teleport", "bc[1].type", "unknown type 'teleport'"),
    ("bc.1.rate", 1.0, "bc[1].rate", "unknown key here (not used by type 'move')"),
    ("bc.1.start", -1.0, "bc[1].start", "must be non-negative"),
    ("bc.1.stop", 0.0, "bc[1].stop", "need start < stop"),
    ("bc.1.twist", "yes", "bc[1].twist", "expected true or false, got 'yes' (str)"),
    ("bc.1.nodes", ["a"], "bc[1].nodes[0]", "expected an integer, 'all' or a range 'a:b' / 'a:b:step', got 'a'"),
    ("bc.1.nodes", 1.5, "bc[1].nodes", "expected an index, 'all', a range 'a:b' or a non-empty list of them, got 1.5"),
    ("bc.1.velocity", [1, 2], "bc[1].velocity", "expected a list of 3 numbers [x, y, z], got [1, 2]"),
    ("rods.0.youngs_modulu", 1e7, "rods[0].youngs_modulu", "unknown key; did you mean 'youngs_modulus'?"),
    ("rods.0.helix_radius", 0.1, "rods[0].helix_radius", "belongs to shape 'helix'"),
    ("rods.0.shape", "spiral", "rods[0].shape", "unknown shape 'spiral'"),
    ("rods.0.youngs_modulus", "stiff", "rods[0].youngs_modulus", "expected a number, got 'stiff' (str)"),
    ("rods.0.youngs_modulus", True, "rods[0].youngs_modulus", "expected a number, got True (bool)"),
    ("rods.0.youngs_modulus", -1.0, "rods[0].youngs_modulus", "must be positive, got -1.0"),
    ("rods.0.n_nodes", 10.5, "rods[0].n_nodes", "expected an integer, got 10.5 (float)"),
    ("rods.0.n_nodes", 1, "rods[0].n_nodes", "must be at least 2"),
    ("rods.0.direction", [0, 0, 0], "rods[0].direction", "non-zero"),
    ("rods.0.density", _DELETE, "rods[0].density", "missing required field"),
    ("rods.0.shape", _DELETE, "rods[0].shape", "missing required field"),
    ("rods.0.natural_curvature", [1, 2, 3], "rods[0].natural_curvature", "expected shape (9, 2) or (2,)"),
    ("rods.0.rest_edge_length", [0.01, 0.01], "rods[0].rest_edge_length", "expected 10 positive lengths"),
    ("rods.0.poisson_ratio", 0.7, "rods[0].poisson_ratio", "must lie in (-1, 0.5]"),
    ("model.gravity", [0, -9.81], "model.gravity", "expected a list of 3 numbers"),
    ("model.gravity", "down", "model.gravity", "expected numbers, got 'down' (str)"),
    ("model.damping", -1.0, "model.damping", "must be non-negative"),
    ("model.dampin", 1.0, "model.dampin", "did you mean 'damping'?"),
    ("solver.dt", -1e-3, "solver.dt", "must be a positive time step in s, got -0.001"),
    ("solver.dt", "1ms", "solver.dt", "expected a number, got '1ms' (str)"),
    ("solver.max_iterations", 2.5, "solver.max_iterations", "expected an integer"),
    ("solver.linear_solver", "magic", "solver.linear_solver", "must be one of 'auto', 'banded', 'sparse', got 'magic'"),
    ("solver.line_search", 1, "solver.line_search", "expected true or false"),
    ("solver.dtt", 1e-3, "solver.dtt", "did you mean 'dt'?"),
    ("solver.spin_relaxation_above", 0.5, "solver.spin_relaxation_above", "must be at least 1 (moment tolerances"),
    ("solver.spin_relaxation_after", -1, "solver.spin_relaxation_after", "must be an integer >= 0, got -1"),
    ("solver.spin_relaxation_after", 2.0, "solver.spin_relaxation_after", "expected an integer"),
    ("run.duration", _DELETE, "run.duration", "missing required field"),
    ("run.duration", 0.0, "run.duration", "must be positive"),
    ("run.output_interval", "often", "run.output_interval", "expected a number"),
    ("rum", {}, "rum", "did you mean 'run'?"),
    ("model", [1, 2], "model", "expected a table"),
]


@pytest.mark.parametrize(("path", "value", "field", "fragment"), BAD, ids=[f"{b[0]}={b[1]!r}"[:40] for b in BAD])
def test_bad_input(path, value, field, fragment):
    c = base()
    if path == "bc.1.waypoints":
        del c["bc"][1]["velocity"]
    _set(c, path, value)
    e = error_of(c)
    assert e.field == field, str(e)
    assert fragment in str(e), str(e)
    assert str(e).startswith(f"{field}: ")


def test_unknown_key_message_exact():
    c = base()
    c["rods"][0]["youngs_modulu"] = c["rods"][0].pop("youngs_modulus")
    assert str(error_of(c)) == "rods[0].youngs_modulu: unknown key; did you mean 'youngs_modulus'?"


def test_clamped_and_moved_overlapping_windows():
    c = base()
    c["bc"][1].update(nodes=[0, 1], start=0.5)  # the clamp 'left' is active forever
    e = error_of(c)
    assert e.field == "bc[1].nodes" and "already prescribed by clamp 'left'" in str(e)
    c["bc"][0]["stop"] = 0.5  # windows [0, 0.5) and [0.5, inf) do not overlap
    load_config(c)
    c["bc"][0]["stop"] = 0.6
    assert error_of(c).field == "bc[1].nodes"


def test_move_needs_exactly_one_path():
    c = base()
    c["bc"][1]["waypoints"] = {"times": [0, 1], "points": [[0, 0, 0], [1, 0, 0]]}
    assert "exactly one of 'velocity' or 'waypoints'" in str(error_of(c))
    del c["bc"][1]["velocity"]
    del c["bc"][1]["waypoints"]
    assert error_of(c).field == "bc[1].velocity"


@pytest.mark.parametrize(("waypoints", "field", "fragment"), [
    ({"times": [0, 1], "points": [[0, 0, 0]]}, "bc[1].waypoints.points", "expected shape (2, 3)"),
    ({"times": [0.5, 1], "points": [[0, 0, 0], [1, 0, 0]]}, "bc[1].waypoints.times", "start at 0"),
    ({"times": [0, 1], "points": [[1, 0, 0], [2, 0, 0]]}, "bc[1].waypoints.points", "must start at (0, 0, 0)"),
    ({"times": [0, 1], "pints": []}, "bc[1].waypoints.pints", "did you mean 'points'?"),
    ({"times": [0, 1]}, "bc[1].waypoints.points", "missing required field"),
])
def test_bad_waypoints(waypoints, field, fragment):
    c = base()
    del c["bc"][1]["velocity"]
    c["bc"][1]["waypoints"] = waypoints
    e = error_of(c)
    assert e.field == field and fragment in str(e), str(e)


def test_release_errors():
    c = base()
    c["bc"].append({"type": "release", "name": "nobody", "at": 1.0})
    e = error_of(c)
    assert e.field == "bc[2].name" and "no boundary condition named 'nobody'" in str(e)
    c["bc"][2] = {"type": "release", "name": "right", "at": 0.0}
    e = error_of(c)
    assert e.field == "bc[2].at" and "not after the start" in str(e)
    c["bc"][2] = {"type": "release", "name": "right", "at": 1.0, "nodes": [0]}
    assert error_of(c).field == "bc[2].nodes"
    c["bc"][2] = {"type": "release", "name": "right", "at": 1.0}
    c["bc"][1]["stop"] = 2.0
    assert "either a stop time or a release" in str(error_of(c))


def test_duplicate_bc_name_and_missing_type():
    c = base()
    c["bc"][1]["name"] = "left"
    e = error_of(c)
    assert e.field == "bc[1].name" and "duplicate" in str(e)
    c = base()
    del c["bc"][0]["type"]
    assert str(error_of(c)) == "bc[0].type: missing required field"


def test_force_needs_value():
    c = base()
    c["bc"].append({"type": "force", "name": "w", "nodes": [-1]})
    assert error_of(c).field == "bc[2].force"
    c["bc"][2]["ramp"] = {"from": [0, 0, 0], "to": [1, 0, 0], "duration": -1.0}
    assert error_of(c).field == "bc[2].ramp.duration"


def test_rods_missing_or_not_array():
    c = base()
    del c["rods"]
    assert error_of(c).field == "rods"
    c["rods"] = {"shape": "straight"}
    assert "array of tables" in str(error_of(c))


def test_points_file_errors(tmp_path):
    c = base()
    c["rods"][0] = {"shape": "points", "file": "missing.npy", "radius": 1e-3, "youngs_modulus": 1e7,
                    "density": 1000.0}
    e = error_of(c)
    assert e.field == "rods[0].file" and "file not found" in str(e)
    np.save(tmp_path / "bad.npy", np.zeros((4, 2)))
    c["rods"][0]["file"] = "bad.npy"
    with pytest.raises(ConfigError, match=r"rods\[0\].file: .*shape \(4, 2\)"):
        load_config(c, base_dir=tmp_path)
    c["rods"][0]["positions"] = [[0, 0, 0], [1, 0, 0]]
    with pytest.raises(ConfigError, match="exactly one of 'positions' or 'file'"):
        load_config(c, base_dir=tmp_path)


def test_toml_syntax_error_and_missing_file(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text("[[rods]]\nname = \n")
    e = error_of(f)
    assert e.field == "config" and "not valid TOML" in str(e)
    e = error_of(tmp_path / "nope.toml")
    assert "file not found" in str(e)


def test_unknown_key_in_toml_file(tmp_path):
    f = tmp_path / "run.toml"
    f.write_text(TOML.replace("youngs_modulus", "youngs_modulu"))
    assert str(error_of(f)) == "rods[0].youngs_modulu: unknown key; did you mean 'youngs_modulus'?"


def test_input_dict_not_modified():
    c = base()
    before = copy.deepcopy(c)
    load_config(c, duration=1.0)
    assert c == before


def test_examples_load():
    from pathlib import Path

    ex = Path(__file__).resolve().parents[2] / "examples"
    files = sorted(ex.glob("*.toml"))
    assert {f.name for f in files} >= {"hanging_rod.toml", "pull_both_ends.toml", "twist_end.toml"}
    for f in files:
        cfg = load_config(f)
        assert cfg.duration > 0 and math.isfinite(cfg.duration)
