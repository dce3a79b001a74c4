"""The run builder: saved run files replay, checkpoints continue runs exactly, stages chain, any
geometry source goes into any protocol."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from knotsim.cli import main
from knotsim.errors import ConfigError, GeometryError
from knotsim.io.trajectory import read_trajectory
from knotsim.runspec import RunSpec, build_run, run

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
FOREIGN = Path(__file__).resolve().parents[3] / "shared" / "data" / "foreign"


def _last_positions(d) -> tuple[float, np.ndarray]:
    t = read_trajectory(Path(d) / "trajectory.h5", frames=-1)
    return float(t.time[0]), t.positions[0]


def test_run_of_2t_equals_t_continued_for_t_bit_for_bit(tmp_path):
    """Contact, friction, moving grips: the continuation takes the same steps (the checkpoint
    resumes before the final step that was shortened to land on T)."""
    spec = RunSpec.load(EXAMPLES / "crossing_rods.toml")
    total = 0.37  # not a multiple of dt: the half run ends with a shortened step
    full = run(spec, tmp_path / "full", duration=total)
    half = run(spec, tmp_path / "half", duration=total / 2)
    assert half.state.time == pytest.approx(total / 2, abs=1e-12)
    cont = run(RunSpec.load(tmp_path / "half" / "run.toml"), tmp_path / "cont", duration=total / 2,
               continue_from=tmp_path / "half")
    assert cont.state.time == full.state.time
    np.testing.assert_array_equal(cont.state.q, full.state.q)
    np.testing.assert_array_equal(cont.state.v, full.state.v)
    # the contact state was restored, not rebuilt from scratch
    assert full.log["k_c"].iloc[-1] == cont.log["k_c"].iloc[-1]


@pytest.mark.parametrize("linear_solver", ["sparse", "banded"])
def test_continuation_starts_from_the_jacobian_the_uninterrupted_run_had(tmp_path, linear_solver):
    """A step may start from the previous step's factorised Jacobian
    (``SolverOptions.jacobian_across_steps``); the checkpoint keeps that Jacobian, so the continued
    run takes the same first step. The runs are split after steps that converged in one iteration
    (the next one starts from their Jacobian), where a continuation that assembled a fresh Jacobian
    would differ in the last bits."""
    from knotsim.io.checkpoint import read_checkpoint

    data = RunSpec.load(EXAMPLES / "crossing_rods.toml").to_dict()
    data["solver"]["linear_solver"] = linear_solver
    spec = RunSpec.from_dict(data)
    total = 0.25
    full = run(spec, tmp_path / "full", duration=total)
    one = full.log[(full.log["iterations"] == 1) & (full.log["time"] > 0.1) & (full.log["time"] < total - 0.02)]
    assert len(one) >= 2, "no steps of one iteration to split at"
    for k, first in enumerate(one["time"].iloc[[0, -1]]):
        run(spec, tmp_path / f"first{k}", duration=float(first))
        meta, _ = read_checkpoint(tmp_path / f"first{k}" / "checkpoint.npz").section("stepper")
        assert meta.get("jacobian_kind") == linear_solver and meta["last_iterations"] == 1
        cont = run(RunSpec.load(tmp_path / f"first{k}" / "run.toml"), tmp_path / f"cont{k}",
                   duration=total - float(first), continue_from=tmp_path / f"first{k}")
        assert cont.state.time == pytest.approx(full.state.time, abs=1e-12)
        np.testing.assert_array_equal(cont.state.q, full.state.q)


def _knot_job():
    """The library's loose overhand (N = 301), held 0.2 s, then pulled apart at 6 mm/s per end,
    mu = 0.3: contact pairs come and go, so the sparse LU meets new patterns (and reuses orderings)
    all the time."""
    import knotsim as ks
    from knotsim.knots.library import get_knot

    x = np.array(get_knot("overhand_n1").ropes[0], float)
    model = ks.Model([ks.RodSpec(x, radius=1.6e-3, youngs_modulus=0.18e6, density=1180.0)], damping=0.01)
    axis = (x[-1] - x[0]) / np.linalg.norm(x[-1] - x[0])
    bcs = ks.BoundaryConditions(model)
    for name, nodes, sign in (("left", [0, 1], -1.0), ("right", [-2, -1], 1.0)):
        bcs.move(name, nodes=nodes, path=ks.Waypoints([0.0, 0.2], [[0, 0, 0], [0, 0, 0]],
                                                     then_velocity=sign * 6e-3 * axis))
    return ks.Simulation(model, bcs, ks.SolverOptions(dt=2.5e-3),
                         interactions=[ks.Contact(model, ks.ContactOptions(mu=0.3))])


def test_knot_continues_bit_for_bit_with_the_sparse_ordering_memory(tmp_path):
    """A new sparsity pattern reuses the ordering of the last fresh analysis (its round-off depends
    on it): the checkpoint keeps that ordering, so the continued run factorises as the uninterrupted
    one (without it the positions differ by a few 1e-15 m after 0.5 s)."""
    from knotsim.io.checkpoint import read_checkpoint

    full = _knot_job()
    full.advance(1.5)
    first = _knot_job()
    first.advance(1.0)
    first.save_checkpoint(tmp_path / "checkpoint.npz")
    meta, arrays = read_checkpoint(tmp_path / "checkpoint.npz").section("stepper")
    assert arrays["ordering_perm"].shape == (first.model.n_dofs,) and meta["ordering_nnz_l"] > 0
    cont = _knot_job()
    cont.restore(tmp_path / "checkpoint.npz")
    cont.advance(1.5)
    assert cont.state.time == full.state.time
    np.testing.assert_array_equal(cont.state.q, full.state.q)


def test_continuing_without_the_checkpoint_differs(tmp_path):
    """The test above can fail: starting the second half from the positions alone (no predictor
    memory, no contact stiffness, no adaptive state) does not give the same answer."""
    spec = RunSpec.load(EXAMPLES / "crossing_rods.toml")
    full = run(spec, tmp_path / "full", duration=0.37)
    run(spec, tmp_path / "half", duration=0.185)
    data = RunSpec.load(tmp_path / "half" / "run.toml").to_dict()
    for r, rod in enumerate(data["rods"]):
        data["rods"][r] = {k: v for k, v in rod.items() if k not in ("length", "n_nodes", "start", "direction")}
        data["rods"][r].update(shape="run", run=str(tmp_path / "half"), rod=r)
    fresh = run(RunSpec.from_dict(data), tmp_path / "fresh", duration=0.185)
    assert np.max(np.abs(fresh.state.q - full.state.q)) > 0.0


def test_restored_run_rejects_other_rods(tmp_path):
    run(RunSpec.load(EXAMPLES / "hanging_rod.toml"), tmp_path / "a", duration=0.01)
    other = RunSpec.load(EXAMPLES / "hanging_rod.toml").to_dict()
    other["rods"][0]["n_nodes"] = 21
    with pytest.raises(ConfigError, match="same rods"):
        build_run(RunSpec.from_dict(other), continue_from=tmp_path / "a")


def test_run_file_in_output_dir_replays_bit_for_bit(tmp_path):
    a = run(RunSpec.load(EXAMPLES / "crossing_rods.toml"), tmp_path / "a", duration=0.1)
    b = run(RunSpec.load(tmp_path / "a" / "run.toml"), tmp_path / "b")
    np.testing.assert_array_equal(a.state.q, b.state.q)


def test_stages_chain_in_one_trajectory(tmp_path):
    data = RunSpec.load(EXAMPLES / "hanging_rod.toml").to_dict()
    data.pop("run", None)
    data["stages"] = [
        {"name": "hang", "duration": 0.02},
        {"name": "lift", "duration": 0.03, "bc": [{"type": "move", "name": "tip", "rod": 0, "nodes": [-1],
                                                  "velocity": [0.0, 0.0, 0.5]}]},
        {"name": "drop", "duration": 0.02, "release": ["tip"]},
    ]
    res = run(RunSpec.from_dict(data), tmp_path / "s", raise_on_failure=True)
    assert res.state.time == pytest.approx(0.07)
    log = res.log
    assert list(dict.fromkeys(log["stage"])) == ["hang", "lift", "drop"]
    lift = log[log["stage"] == "lift"]
    assert (lift["tip_fz"].abs() > 0).all()
    assert (log[log["stage"] == "drop"]["tip_fz"] == 0).all()
    traj = read_trajectory(tmp_path / "s" / "trajectory.h5")
    assert traj.time[0] == 0.0 and traj.time[-1] == pytest.approx(0.07)


def test_stage_release_of_unknown_group_is_named():
    data = RunSpec.load(EXAMPLES / "hanging_rod.toml").to_dict()
    data["stages"] = [{"name": "a", "duration": 0.1}, {"name": "b", "duration": 0.1, "release": ["nope"]}]
    with pytest.raises(ConfigError, match=r"stages\[1\]\.release\[0\]"):
        build_run(RunSpec.from_dict(data))


# ------------------------------------------------------------------------------------------ geometry sources
def _rod_table(**shape):
    base = {"name": "r", "radius": 1e-3, "youngs_modulus": 1e6, "density": 1000.0}
    base.update(shape)
    return {"rods": [base], "run": {"duration": 0.002}, "solver": {"dt": 1e-3}}


@pytest.mark.parametrize("suffix", [".txt", ".csv", ".npy", ".mat", ""])
def test_node_files_of_every_format_give_the_same_rod(tmp_path, suffix):
    x = np.column_stack([np.linspace(0, 0.1, 11), np.zeros(11), np.zeros(11)])
    f = tmp_path / f"nodes{suffix}"
    if suffix == ".npy":
        np.save(f, x)
    elif suffix == ".csv":
        f.write_text("x,y,z\n" + "\n".join(",".join(map(repr, row.tolist())) for row in x))
    elif suffix == ".mat":
        from scipy.io import savemat

        savemat(f, {"A": x.T})  # (3, N), as Patil's files
    else:  # whitespace text with a fourth (theta) column, as imc-der's files
        f.write_text("\n".join(" ".join(map(repr, row.tolist())) + " 0.0" for row in x))
    table = _rod_table(shape="points", file=str(f), **({"matrix": "A"} if suffix == ".mat" else {}))
    sim, cfg = build_run(RunSpec.from_dict(table))
    np.testing.assert_allclose(cfg.model.node_positions(sim.state.q), x, rtol=0, atol=1e-15)


def test_node_file_errors_name_the_field(tmp_path):
    f = tmp_path / "bad.txt"
    f.write_text("1 2\n3 4\n")
    with pytest.raises(ConfigError, match=r"rods\[0\]\.file.*\(N, 3\)"):
        build_run(RunSpec.from_dict(_rod_table(shape="points", file=str(f))))
    with pytest.raises(ConfigError, match=r"rods\[0\]\.file.*not found"):
        build_run(RunSpec.from_dict(_rod_table(shape="points", file=str(tmp_path / "missing.txt"))))


def test_library_knot_shape():
    table = _rod_table(shape="knot", knot="overhand_n1", n_nodes=81)
    sim, cfg = build_run(RunSpec.from_dict(table))
    assert cfg.model.n_nodes == 81


def test_zero_length_edge_is_named(tmp_path):
    from knotsim.protocols.geometry import geometry_from_source

    x = np.column_stack([np.linspace(0, 0.1, 11), np.zeros(11), np.zeros(11)])
    x[5] = x[4]
    f = tmp_path / "dup.txt"
    np.savetxt(f, x)
    with pytest.raises(GeometryError, match=r"edge 4 \(nodes 4, 5\) has zero length"):
        geometry_from_source(str(f), radius=1e-3)


# ------------------------------------------------------------------------------------------ commands
def test_pull_save_config_run_and_restart(tmp_path):
    r = CliRunner()
    a, cfg = tmp_path / "A", tmp_path / "A.toml"
    res = r.invoke(main, ["pull", "overhand_n1", "--quick", "--set", "e_final=0.6", "-o", str(a), "--save-config",
                          str(cfg)])
    assert res.exit_code == 0, res.output
    assert (a / "checkpoint.npz").is_file() and (a / "run.toml").is_file()
    res = r.invoke(main, ["run", str(cfg), "-o", str(tmp_path / "B"), "-q"])
    assert res.exit_code == 0, res.output
    ta, xa = _last_positions(a)
    tb, xb = _last_positions(tmp_path / "B")
    assert ta == tb
    assert np.max(np.abs(xa - xb)) <= 1e-9
    half = repr(ta / 2)
    assert r.invoke(main, ["run", str(cfg), "-o", str(tmp_path / "C"), "--duration", half, "-q"]).exit_code == 0
    res = r.invoke(main, ["run", "--from", str(tmp_path / "C"), "-o", str(tmp_path / "D"), "--duration", half, "-q"])
    assert res.exit_code == 0, res.output
    td, xd = _last_positions(tmp_path / "D")
    assert td == pytest.approx(tb, abs=1e-12)
    assert np.max(np.abs(xd - xb)) <= 1e-9


@pytest.mark.skipif(not (FOREIGN / "imc-der" / "n1").is_file(), reason="shared foreign data not beside the checkout")
def test_pull_on_imc_der_nodes_then_continue_from_the_run(tmp_path):
    r = CliRunner()
    e = tmp_path / "E"
    res = r.invoke(main, ["pull", "--geometry", str(FOREIGN / "imc-der" / "n1"), "--protocol", "overhand-pull",
                          "--quick", "--set", "e_final=0.65", "-o", str(e)])
    assert res.exit_code == 0, res.output
    assert "n_nodes = 81 not applied" in res.output
    assert "knot type: trefoil_left -> trefoil_left" in res.output
    log_e = pd.read_parquet(e / "log.parquet")
    f = tmp_path / "F"
    res = r.invoke(main, ["pull", "--geometry", str(e), "--quick", "--set", "e_final=0.6", "-o", str(f)])
    assert res.exit_code == 0, res.output
    assert "overhand-pull" in res.output  # the protocol of the earlier run
    log_f = pd.read_parquet(f / "log.parquet")
    # the rope goes on physically: tension and stretch carry over (not restarted from rest)
    assert log_f["F"].iloc[0] == pytest.approx(log_e["F"].iloc[-1], rel=0.05)
    assert log_f["energy_stretching"].iloc[0] == pytest.approx(log_e["energy_stretching"].iloc[-1], rel=0.1)


def test_pull_needs_a_knot_or_a_geometry(tmp_path):
    res = CliRunner().invoke(main, ["pull", "-o", str(tmp_path / "x")])
    assert res.exit_code == 2
    assert "KNOT or --geometry" in res.output


def test_tie_lists_sequences():
    res = CliRunner().invoke(main, ["tie", "--list"])
    assert res.exit_code == 0
    assert {"overhand", "reef", "granny"} <= set(res.output.split())


def test_run_dir_without_checkpoint_cannot_be_continued(tmp_path):
    run(RunSpec.load(EXAMPLES / "hanging_rod.toml"), tmp_path / "a", duration=0.01)
    (tmp_path / "a" / "checkpoint.npz").unlink()
    shutil.copy(tmp_path / "a" / "run.toml", tmp_path / "run.toml")
    with pytest.raises(ConfigError, match="no checkpoint.npz"):
        build_run(RunSpec.load(tmp_path / "run.toml"), continue_from=tmp_path / "a")


def test_rods_overlapping_at_the_start_are_named():
    def rod(name, y):
        return {"name": name, "shape": "straight", "length": 0.1, "n_nodes": 11, "start": [0.0, y, 0.0],
                "radius": 1e-3, "youngs_modulus": 1e6, "density": 1000.0}
    table = {"rods": [rod("a", 0.0), rod("b", 1.0e-3)], "contact": {"mu": 0.0}, "run": {"duration": 0.01}}
    with pytest.raises(GeometryError, match=r"rods overlap at the start: rod 'a' edge \d+ and rod 'b' edge \d+"):
        build_run(RunSpec.from_dict(table))
    table["rods"][1]["start"] = [0.0, 2.5e-3, 0.0]  # 0.25 mm clear: accepted
    build_run(RunSpec.from_dict(table))


def test_halves_that_end_on_a_step_boundary_also_continue_bit_for_bit(tmp_path):
    """0.2 s = 80 steps of 2.5 ms: no shortened step, the end time is landed on by rounding; the
    checkpoint keeps the running sum of steps, so time-dependent grips see the same times."""
    spec = RunSpec.load(EXAMPLES / "crossing_rods.toml")
    full = run(spec, tmp_path / "full", duration=0.4)
    run(spec, tmp_path / "half", duration=0.2)
    cont = run(RunSpec.load(tmp_path / "half" / "run.toml"), tmp_path / "cont", duration=0.2,
               continue_from=tmp_path / "half")
    np.testing.assert_array_equal(cont.state.q, full.state.q)


def test_saved_run_files_put_each_node_on_one_line_and_round_trip_exactly():
    from knotsim._util.toml import dumps_toml, loads_toml

    rng = np.random.default_rng(3)
    data = {"rods": [{"name": "r", "shape": "points", "positions": rng.normal(size=(50, 3)).tolist()}]}
    text = dumps_toml(data)
    assert loads_toml(text) == data
    assert len(text.splitlines()) < 60  # one line per node (tomli-w alone writes four)


def test_a_protocol_continuing_a_run_keeps_its_rope_material(tmp_path):
    from knotsim.protocols import build_protocol_run

    run(RunSpec.load(EXAMPLES / "hanging_rod.toml"), tmp_path / "a", duration=0.01)
    _, ctx, spec, notes = build_protocol_run("overhand-pull", geometry=str(tmp_path / "a"), quick=True)
    assert ctx.params["youngs_modulus"] == 1e6 and ctx.params["density"] == 1000.0
    assert spec.data["rods"][0]["youngs_modulus"] == 1e6
    assert any("youngs_modulus = 1000000.0 from the run" in n for n in notes)
    _, ctx2, _, _ = build_protocol_run("overhand-pull", geometry=str(tmp_path / "a"), quick=True,
                                       overrides={"youngs_modulus": 2e6})
    assert ctx2.params["youngs_modulus"] == 2e6


def test_grips_with_memory_continue_bit_for_bit(tmp_path):
    """A load cell (its controller), a spring grip and a turning grip (anchors, pivot) carry their
    memory in the state: a run of 2T and a run of T continued for T end in the same state."""
    L = 0.1
    table = {"rods": [{"name": "rope", "shape": "straight", "length": L, "n_nodes": 11, "radius": 1e-3,
                       "youngs_modulus": 1e6, "density": 1000.0}],
             "model": {"damping": 0.05},
             "bc": [{"type": "clamp", "name": "left", "nodes": [0, 1]},
                    {"type": "load_cell", "name": "cell", "nodes": [-2, -1], "direction": [1, 0, 0],
                     "ramp": {"from": 0.0, "to": 0.05, "duration": 0.1}, "ki": 0.05, "kp": 1e-3, "max_speed": 0.1},
                    {"type": "spring", "name": "side", "nodes": [5], "stiffness": 5.0, "velocity": [0, 0.01, 0]},
                    {"type": "move", "name": "turn", "nodes": [3, 4], "velocity": [0, 0, 0.002],
                     "rotate_about": {"axis": [0, 0, 1], "rate": 0.5}, "start": 0.03}],
             "solver": {"dt": 2e-3}, "run": {"duration": 0.1}}
    spec = RunSpec.from_dict(table)
    total = 0.107  # not a multiple of dt: the half run ends with a shortened step
    full = run(spec, tmp_path / "full", duration=total)
    run(spec, tmp_path / "half", duration=total / 2)
    cont = run(RunSpec.load(tmp_path / "half" / "run.toml"), tmp_path / "cont", duration=total / 2,
               continue_from=tmp_path / "half")
    assert cont.state.time == full.state.time
    np.testing.assert_array_equal(cont.state.q, full.state.q)
    np.testing.assert_array_equal(cont.state.v, full.state.v)
    for col in ("cell_displacement", "cell_error", "side_fy", "turn_angle"):
        assert cont.log[col].iloc[-1] == full.log[col].iloc[-1]


def test_a_group_added_during_the_run_is_carried_and_checkpointed(tmp_path):
    """A boundary-condition group added to a running simulation enters the state's memory at its
    first step and is written to the checkpoint."""
    import knotsim as ks
    from knotsim.io.checkpoint import read_checkpoint

    x = np.zeros((11, 3))
    x[:, 0] = np.linspace(0.0, 0.1, 11)
    model = ks.Model([ks.RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0)], damping=0.05)
    bcs = ks.BoundaryConditions(model)
    bcs.clamp("left", nodes=[0, 1])
    sim = ks.Simulation(model, bcs, ks.SolverOptions(dt=2e-3))
    sim.run(0.01, progress=False)
    bcs.hold("late", nodes=[-1])
    sim.run(0.01, progress=False)
    assert sim.state.memory.bc["late"] is bcs.groups["late"].memory
    sim.save_checkpoint(tmp_path / "checkpoint.npz")
    meta, arrays = read_checkpoint(tmp_path / "checkpoint.npz").section("bc/late")
    assert meta["anchored"] and arrays["anchor"].shape == (1, 3)
