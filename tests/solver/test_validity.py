"""Validity guards (knotsim.solver.validity): impossible states stop the run with a named error."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import knotsim as ks
from knotsim.cli import main
from knotsim.errors import ConfigError, SimulationError, ValidityError
from knotsim.runspec import RunSpec, run
from knotsim.solver._validity_kernels import constrained_work, first_non_finite, largest_axial_strain
from knotsim.solver.stepper import SolverOptions, StepResult

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

ROD = """
[[rods]]
name = "cantilever"
shape = "straight"
length = 0.2
n_nodes = 21
start = [0.0, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
radius = 1e-3
youngs_modulus = 1e6
density = 1000.0
poisson_ratio = 0.5

[[bc]]
type = "clamp"
name = "left"
rod = "cantilever"
nodes = [0, 1]
"""


def _spec(tmp_path, extra: str) -> RunSpec:
    f = tmp_path / "run.toml"
    f.write_text(ROD + extra)
    return RunSpec.load(f)


# ---------------------------------------------------------------- kernels against plain numpy
def _straight(length, n_nodes, name, start=(0.0, 0.0, 0.0)):
    x = np.asarray(start) + np.linspace(0.0, length, n_nodes)[:, None] * np.array([1.0, 0.0, 0.0])
    return ks.RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0, name=name)


def _reference_strain(q, model):
    x = q[model.node_dof[:, None] + np.arange(3)]
    lengths = np.linalg.norm(x[model.edge_nodes[:, 1]] - x[model.edge_nodes[:, 0]], axis=1)
    s = np.abs(lengths / model.rest_length - 1.0)
    s[~np.isfinite(s)] = np.inf
    return float(s.max()), int(np.argmax(s))


def test_kernels_equal_plain_numpy():
    rng = np.random.default_rng(3)
    model = ks.Model([_straight(0.3, 12, "a"), _straight(0.2, 7, "b", start=(0.0, 0.1, 0.0))])
    q_start = ks.Simulation(model).state.q
    for _ in range(20):
        q = q_start + rng.normal(scale=5e-3, size=model.n_dofs)
        s, e = largest_axial_strain(q, model.edge_dofs, model.rest_length)
        ref = _reference_strain(q, model)
        assert s == pytest.approx(ref[0], rel=1e-13) and int(e) == ref[1]
        fixed = rng.random(model.n_dofs) < 0.3
        r, f, q0 = (rng.normal(size=model.n_dofs) for _ in range(3))
        expected = float(np.dot(r[fixed], (q - q0)[fixed]) + np.dot(f, q - q0))
        assert constrained_work(r, fixed, f, q, q0) == pytest.approx(expected, rel=1e-12, abs=1e-15)
    q[17] = np.nan
    assert first_non_finite(q) == 17 and first_non_finite(np.ones(4)) == -1
    q[17] = 0.0
    q[model.node_dof[5]] = np.inf  # a node at infinity: its edges count as infinitely strained
    assert largest_axial_strain(q, model.edge_dofs, model.rest_length)[0] == math.inf


# ---------------------------------------------------------------- the case
def test_force_in_wrong_units_stops_with_a_named_error_and_keeps_the_output(tmp_path):
    """A 1e9 N force on a 21-node soft rod (a typo of units) ran to the end with a 3,183 km edge."""
    spec = _spec(tmp_path, '[[bc]]\ntype = "force"\nname = "end"\nnodes = [-1]\nforce = [1e9, 0.0, 0.0]\n'
                           '[solver]\ndt = 1e-3\n[run]\nduration = 0.05\n')
    with pytest.raises(ValidityError) as info:
        run(spec, tmp_path / "out")
    exc = info.value
    assert isinstance(exc, SimulationError) and exc.quantity == "axial_strain" and exc.value > 0.5
    msg = str(exc)
    assert "edge 19 of rod 'cantilever'" in msg and "max_axial_strain=2" in msg and " at t=" in msg
    assert exc.last_good_state is not None and exc.time == exc.last_good_state.time
    model = ks.Model([_straight(0.2, 21, "cantilever")])
    edges = np.diff(exc.last_good_state.q[model.node_dof[:, None] + np.arange(3)], axis=0)
    assert np.max(np.linalg.norm(edges, axis=1)) < 1.5 * 0.01  # the state attached is the last valid one
    info_json = json.loads((tmp_path / "out" / "run.json").read_text())
    assert info_json["outcome"].startswith("failed: axial strain")
    assert info_json["validity"]["largest_axial_strain"] > 0.5
    assert (tmp_path / "out" / "checkpoint.npz").is_file() and (tmp_path / "out" / "log.parquet").is_file()


def test_cli_exit_code_and_one_line(tmp_path):
    f = tmp_path / "huge.toml"
    f.write_text(ROD + '[[bc]]\ntype = "force"\nname = "end"\nnodes = [-1]\nforce = [1e9, 0.0, 0.0]\n'
                       '[solver]\ndt = 1e-3\n[run]\nduration = 0.02\n')
    res = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o")])
    assert res.exit_code != 0 and res.exception is None or isinstance(res.exception, SystemExit)
    assert "axial strain" in res.output and "Traceback" not in res.output


def test_close_to_the_limit_is_a_warning_in_run_json(tmp_path):
    """A force ramped to 0.33 EA stretches the rod by about 33 %, more than half of a limit 0.5 set in
    the run file: the run completes and run.json warns."""
    ea = 1e6 * math.pi * 1e-6
    spec = _spec(tmp_path, f'[[bc]]\ntype = "force"\nname = "end"\nnodes = [-1]\n'
                           f'ramp = {{ from = [0.0, 0.0, 0.0], to = [{0.33 * ea}, 0.0, 0.0], duration = 0.5 }}\n'
                           '[model]\ndamping = 0.5\n[solver]\ndt = 5e-3\nmax_axial_strain = 0.5\n[run]\nduration = 0.6\n')
    run(spec, tmp_path / "out")
    info = json.loads((tmp_path / "out" / "run.json").read_text())
    assert info["outcome"] == "completed"
    v = info["validity"]
    assert 0.25 < v["largest_axial_strain"] < 0.5
    assert any("axial strain" in w for w in info["warnings"]) and v["energy_check"] == "applied"
    # the energy bookkeeping: the force's work is counted, nothing was created (backward Euler and
    # damping dissipate): the gain stays below 1 % of the energy handled
    assert v["largest_energy_gain"] < 0.01


def test_limits_are_run_options(tmp_path):
    spec = _spec(tmp_path, '[[bc]]\ntype = "force"\nname = "end"\nnodes = [-1]\nforce = [1e9, 0.0, 0.0]\n'
                           '[solver]\ndt = 1e-3\nmax_axial_strain = inf\nmax_energy_gain = inf\n[run]\nduration = 0.003\n')
    res = run(spec, tmp_path / "out")  # both guards switched off: the nonsense runs (as the user asked)
    assert res.state.time == pytest.approx(0.003)
    for bad in (0.0, -1.0, "x", True):
        with pytest.raises(ConfigError, match="solver.max_axial_strain"):
            SolverOptions(max_axial_strain=bad).validate()
    with pytest.raises(ConfigError, match="solver.max_energy_gain"):
        SolverOptions(max_energy_gain=-0.1).validate()


# ---------------------------------------------------------------- energy without a source
class _AntiDamping:
    """A non-conservative force along the velocity, ``+c v`` per node (N): it pumps energy into the
    rod, and nothing counts its work (a stand-in for an unstable interaction)."""

    name = "antidamping"
    memory = None
    k_c = None
    pattern_version = 0

    def __init__(self, model, c):
        self.model, self.c = model, c
        self._dofs = (model.node_dof[:, None] + np.arange(3)).ravel()

    def begin_step(self, state_in, dt):
        pass

    def block_dofs(self):
        return np.zeros((0, 3), np.int64)

    def evaluate(self, q, q_prev, dt, residual, want_jacobian):
        residual[self._dofs] -= self.c * (q[self._dofs] - q_prev[self._dofs]) / dt
        return 0.0, None

    def check(self, q):
        return None

    def stats(self):
        return {}

    has_spin_friction = False

    def spin_friction(self):
        return None

    def supplied_work(self, q_prev, q, dt):
        return 0.0  # its work is deliberately not counted

    def untracked_sources(self):
        return []

    def check_start(self, q):
        pass

    def use_memory(self, memory):
        pass

    def describe_near(self, q, node):
        return ""

    friction_model = None
    node_field_names = ()

    def node_fields(self):
        return {}


def _swinging_rod(interactions=()):
    model = ks.Model([_straight(0.2, 21, "rod")], gravity=(0.0, 0.0, -9.81))
    bcs = ks.BoundaryConditions(model)
    bcs.clamp("left", rod="rod", nodes=[0, 1])
    inter = [cls(model, 4e-4) for cls in interactions]
    return ks.Simulation(model, bcs, ks.SolverOptions(dt=2e-3), interactions=inter)


def test_energy_created_without_a_source_stops_the_run():
    sim = _swinging_rod([_AntiDamping])
    with pytest.raises(ValidityError) as info:
        sim.run(2.0)
    assert info.value.quantity == "energy_gain" and "energy grew without a source" in str(info.value)
    assert info.value.time < 2.0


def test_a_falling_cantilever_creates_no_energy():
    sim = _swinging_rod()
    sim.run(0.5)
    rep = sim.validity.report()
    assert rep["energy_check"] == "applied" and rep["warnings"] == []
    assert sim.validity.gain <= 0.0  # backward Euler only dissipates here
    assert sim.validity.scale > 1e-4  # gravity's work was counted in the scale (m g h ~ 6e-4 J)


def test_moving_grip_work_is_counted():
    """A grip pulling the free end supplies the energy the rod stores: counted, so no gain."""
    model = ks.Model([_straight(0.2, 21, "rod")])
    bcs = ks.BoundaryConditions(model)
    bcs.clamp("left", rod="rod", nodes=[0, 1])
    bcs.move("right", rod="rod", nodes=[-1], path=(0.0, 0.05, 0.0))
    sim = ks.Simulation(model, bcs, ks.SolverOptions(dt=2e-3))
    sim.run(0.5)
    e = sim.rows[-1]
    assert e["energy_elastic"] > 1e-5
    assert abs(sim.validity.gain) < 0.05 * sim.validity.scale


def test_ring_twist_is_an_untracked_source(tmp_path):
    res = run(RunSpec.load(EXAMPLES / "michell_ring.toml"), tmp_path / "ring", duration=0.01)
    info = json.loads((tmp_path / "ring" / "run.json").read_text())
    assert info["validity"]["energy_check"].startswith("not applied")
    assert res.state.time == pytest.approx(0.01)


def test_monitor_continues_bit_for_bit(tmp_path):
    spec = RunSpec.load(EXAMPLES / "crossing_rods.toml")
    full = run(spec, tmp_path / "full", duration=0.3)
    run(spec, tmp_path / "half", duration=0.15)
    run(RunSpec.load(tmp_path / "half" / "run.toml"), tmp_path / "cont", duration=0.15,
        continue_from=tmp_path / "half")
    a = json.loads((tmp_path / "full" / "run.json").read_text())["validity"]
    b = json.loads((tmp_path / "cont" / "run.json").read_text())["validity"]
    assert a == b
    assert full.state.time == pytest.approx(0.3)


def test_non_finite_state_names_the_node():
    sim = _swinging_rod()
    sim.run(0.01)
    trial = sim.state.copy()
    trial.v[sim.model.node_dof[7] + 1] = np.nan
    res = StepResult(time=0.012, dt=2e-3, iterations=1, residual=0.0, line_search_cuts=0)
    with pytest.raises(ValidityError, match=r"non-finite velocity nan at node 7 of rod 'rod' at t=0.012"):
        sim.validity.check(trial, res)


# ---------------------------------------------------------------- sources other than the supports
def _rope_on_floor(n=41):
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(-0.05, 0.05, n)
    x[:, 2] = 6e-4
    return ks.Model([ks.RodSpec(x, radius=5e-4, youngs_modulus=1e7, density=1000.0, name="rope")])


def _post_sweeping_a_rope(monkeypatch=None):
    """A post moving at 0.2 m/s across a free rope lying on nothing: all the rope's energy comes
    from the post."""
    model = _rope_on_floor()
    post = ks.Capsule(model, "post", a=(0.0, -0.02, 2.5e-3), b=(0.0, 0.02, 2.5e-3), radius=1e-3, path=[0, 0, -0.2])
    return ks.Simulation(model, ks.BoundaryConditions(model), ks.SolverOptions(dt=1e-3), interactions=[post])


def test_moving_obstacle_work_is_counted(monkeypatch):
    sim = _post_sweeping_a_rope()
    sim.run(0.05)
    v = sim.validity
    assert sim.rows[-1]["energy_kinetic"] > 1e-7  # the post set the rope moving
    assert v.gain < 0.05 * v.scale  # (negative: the impact dissipates)
    # control: without the obstacle's work the same run creates most of its energy from nothing
    monkeypatch.setattr(ks.Obstacle, "supplied_work", lambda self, q_prev, q, dt: 0.0)
    sim = _post_sweeping_a_rope()
    with pytest.raises(ValidityError, match="energy grew without a source"):
        sim.run(0.05)


def test_contact_stiffness_changes_are_counted(monkeypatch):
    """A rope pressed onto a table by 4 N at its ends: the adaptive stiffness grows while the rope
    settles, which raises the penalty energy between steps (a change of the model, counted)."""
    def pressed():
        model = _rope_on_floor()
        table = ks.Plane(model, "table")
        bcs = ks.BoundaryConditions(model)
        bcs.force("a", nodes=[0], force=[0, 0, -4.0])
        bcs.force("b", nodes=[-1], force=[0, 0, -4.0])
        return ks.Simulation(model, bcs, ks.SolverOptions(dt=1e-3), interactions=[table])

    sim = pressed()
    sim.run(0.02)
    k = sim.log()["table_k_c"]
    assert k.max() > 2 * k.iloc[0]  # the stiffness did change
    assert sim.validity.gain < 0.1 * sim.validity.scale
    from knotsim.solver import validity

    monkeypatch.setattr(validity.ValidityMonitor, "__init__", _without_stiffness(validity.ValidityMonitor.__init__))
    sim = pressed()
    try:
        sim.run(0.02)
    except ValidityError:
        return
    assert sim.validity.gain > 0.3 * sim.validity.scale


def _without_stiffness(init):
    def wrapped(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self.stiffened = []
        self.penalty = {}
    return wrapped
