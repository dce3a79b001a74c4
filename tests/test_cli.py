"""The ``knotsim`` command line (click's CliRunner, no subprocess)."""

from __future__ import annotations

import json
import sys
import types

import pytest
from click.testing import CliRunner

import knotsim
from knotsim.cli import main
from knotsim.errors import SimulationError

CONFIG = """
[[rods]]
name = "rope"
shape = "straight"
length = 0.1
n_nodes = 11
radius = 1e-3
youngs_modulus = 1e7
density = 1000.0

[model]
gravity = [0.0, 0.0, -9.81]

[[bc]]
type = "clamp"
name = "left"
nodes = [0, 1]

[[bc]]
type = "move"
name = "right"
nodes = [-2, -1]
velocity = [1e-3, 0.0, 0.0]

[solver]
dt = 1e-3

[run]
duration = 0.01
"""


@pytest.fixture
def config_file(tmp_path):
    f = tmp_path / "run.toml"
    f.write_text(CONFIG)
    return f


@pytest.fixture
def runner():
    return CliRunner()


def test_version(runner):
    res = runner.invoke(main, ["--version"])
    assert res.exit_code == 0
    assert knotsim.__version__ in res.output


def test_help_lists_commands(runner):
    res = runner.invoke(main, ["--help"])
    assert res.exit_code == 0
    for cmd in ("run", "validate", "warmup", "plot"):
        assert cmd in res.output


# ------------------------------------------------------------------------------------------ run
def test_run_writes_outputs_and_summary(runner, config_file, tmp_path):
    out = tmp_path / "out"
    res = runner.invoke(main, ["run", str(config_file), "-o", str(out)])
    assert res.exit_code == 0, res.output
    for name in ("trajectory.h5", "log.parquet", "run.json"):
        assert (out / name).is_file()
    text = res.stdout
    assert "in 10 steps" in text
    assert "Newton iterations per step" in text and "wall time" in text
    assert "left F = (" in text and "right F = (" in text
    info = json.loads((out / "run.json").read_text())
    assert info["outcome"] == "completed" and info["config"]["run"]["duration"] == 0.01


def test_run_duration_override_and_quiet(runner, config_file, tmp_path):
    out = tmp_path / "out"
    res = runner.invoke(main, ["run", str(config_file), "-o", str(out), "--duration", "0.005", "--quiet"])
    assert res.exit_code == 0, res.output
    assert res.stdout == ""
    info = json.loads((out / "run.json").read_text())
    assert info["steps"] == 5 and info["config"]["run"]["duration"] == 0.005


def test_run_refuses_non_empty_output_unless_overwrite(runner, config_file, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text("{}")  # e.g. left by an earlier knotsim tie
    (out / "render").mkdir()
    res = runner.invoke(main, ["run", str(config_file), "-o", str(out), "-q"])
    assert res.exit_code == 2 and res.output.count("\n") == 1
    assert "is not empty; pass --overwrite" in res.output
    res = runner.invoke(main, ["run", str(config_file), "-o", str(out), "-q", "--overwrite"])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in out.iterdir()) == ["checkpoint.npz", "log.parquet", "run.json", "run.toml",
                                                     "trajectory.h5"]


def test_run_empty_o_is_bad_input_and_default_dir(runner, config_file, tmp_path, monkeypatch):
    res = runner.invoke(main, ["run", str(config_file), "-o", "", "-q"])
    assert res.exit_code == 2 and "must not be empty" in res.output
    monkeypatch.chdir(tmp_path)
    res = runner.invoke(main, ["run", str(config_file), "-q"])
    assert res.exit_code == 0, res.output
    assert "output directory: runs/run" in res.stderr
    assert (tmp_path / "runs" / "run" / "trajectory.h5").is_file()
    res = runner.invoke(main, ["run", "--from", "runs/run", "-o", "runs/run", "-q"])
    assert res.exit_code == 2 and "new directory" in res.output


def test_bc_without_rod_in_two_rod_model_names_the_field(runner, config_file, tmp_path):
    two = CONFIG.replace('[model]', '[[rods]]\nname = "other"\nshape = "straight"\nlength = 0.1\nn_nodes = 11\n'
                         'radius = 1e-3\nyoungs_modulus = 1e7\ndensity = 1000.0\nstart = [0.0, 0.05, 0.0]\n\n[model]')
    config_file.write_text(two)
    res = runner.invoke(main, ["run", str(config_file), "-o", str(tmp_path / "out"), "-q"])
    assert res.exit_code == 2, res.output
    assert "error: bc[0].rod: the model has 2 rods" in res.output
    assert res.output.count("\n") == 1


def test_warmup_reports_time_and_leaves_kernels_cached(runner):
    from knotsim._warmup import kernels_cached

    res = runner.invoke(main, ["warmup"])
    assert res.exit_code == 0, res.output
    assert "kernels ready in" in res.stdout and "cached: yes" in res.stdout
    assert kernels_cached()


def test_plot_command(runner, config_file, tmp_path):
    out = tmp_path / "out"
    assert runner.invoke(main, ["run", str(config_file), "-o", str(out), "-q"]).exit_code == 0
    res = runner.invoke(main, ["plot", str(out), "-o", str(tmp_path / "f.png")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "f.png").stat().st_size > 1000
    res = runner.invoke(main, ["plot", str(tmp_path)])
    assert res.exit_code == 2 and "no log.parquet" in res.output


def test_run_config_error_exit_2(runner, config_file, tmp_path):
    config_file.write_text(CONFIG.replace("youngs_modulus", "youngs_modulu"))
    res = runner.invoke(main, ["run", str(config_file), "-o", str(tmp_path / "out")])
    assert res.exit_code == 2
    assert res.stderr.strip() == "error: rods[0].youngs_modulu: unknown key; did you mean 'youngs_modulus'?"
    assert "Traceback" not in res.output
    assert not (tmp_path / "out").exists()


def test_run_bad_value_exit_2(runner, config_file, tmp_path):
    config_file.write_text(CONFIG.replace("nodes = [0, 1]", "nodes = [0, 40]"))
    res = runner.invoke(main, ["run", str(config_file), "-o", str(tmp_path / "out")])
    assert res.exit_code == 2
    assert "bc[0].nodes: node index 40 out of range" in res.stderr
    res = runner.invoke(main, ["run", str(config_file), "-o", str(tmp_path / "out"), "--duration", "-1"])
    assert res.exit_code == 2


def test_run_missing_file_exit_2(runner, tmp_path):
    res = runner.invoke(main, ["run", str(tmp_path / "nope.toml"), "-o", str(tmp_path / "out")])
    assert res.exit_code == 2
    assert "Traceback" not in res.output


def test_run_simulation_error_exit_3(runner, config_file, tmp_path, monkeypatch):
    from knotsim.simulation import Simulation

    def fail(self, *args, **kwargs):
        raise SimulationError("time step fell below dt_min at t=0.003 s", time=0.003)

    monkeypatch.setattr(Simulation, "run", fail)
    res = runner.invoke(main, ["run", str(config_file), "-o", str(tmp_path / "out")])
    assert res.exit_code == 3
    assert res.stderr.startswith("error: simulation failed: time step fell below dt_min")
    assert "partial output written to" in res.stderr
    assert "Traceback" not in res.output


# ------------------------------------------------------------------------------------------ validate
def _fake_cases(results_by_case):
    mod = types.ModuleType("knotsim.validation.cases")
    mod.calls = []

    def run_cases(names, quick, progress=False):
        mod.calls.append((list(names), quick))
        return [r for n in names for r in results_by_case[n]]

    mod.CASES = {name: (lambda: None) for name in results_by_case}
    mod.run_cases = run_cases
    return mod


def _result(case, passed, value=1.0):
    return {"case": case, "quantity": "tip z/L", "value": value, "reference": 1.0, "error": abs(value - 1.0),
            "tolerance": 0.01, "passed": passed, "wall_time": 0.5}


@pytest.fixture
def fake_cases(monkeypatch):
    mod = _fake_cases({"beam": [_result("beam", True)], "helix": [_result("helix", True, 1.001)],
                       "broken": [_result("broken", False, 2.0), _result("broken", True)]})
    monkeypatch.setitem(sys.modules, "knotsim.validation.cases", mod)
    return mod


def test_validate_selected_pass(runner, fake_cases):
    res = runner.invoke(main, ["validate", "beam", "helix", "--quick", "--json"])
    assert res.exit_code == 0, res.output
    assert fake_cases.calls == [(["beam", "helix"], True)]
    lines = res.stdout.strip().splitlines()
    assert lines[0].split()[:3] == ["case", "quantity", "value"]
    assert any("PASS" in ln and "beam" in ln for ln in lines)
    final = json.loads(lines[-1])
    assert final["passed"] is True
    assert [c["case"] for c in final["cases"]] == ["beam", "helix"]
    assert final["cases"][1]["value"] == 1.001


def test_validate_all_with_failure_exit_1(runner, fake_cases):
    res = runner.invoke(main, ["validate", "--json"])
    assert res.exit_code == 1
    assert fake_cases.calls == [(["beam", "helix", "broken"], False)]
    assert "FAIL" in res.stdout
    final = json.loads(res.stdout.strip().splitlines()[-1])
    assert final["passed"] is False and len(final["cases"]) == 4


def test_validate_table_is_narrow_and_json_is_opt_in(runner, fake_cases):
    res = runner.invoke(main, ["validate", "beam", "helix"])
    assert res.exit_code == 0
    lines = res.stdout.strip().splitlines()
    assert lines[-1].endswith("checks passed") and not any(line.startswith("{") for line in lines)
    assert max(len(line) for line in lines) <= 130


def test_validate_json_only(runner, fake_cases):
    res = runner.invoke(main, ["validate", "beam", "--json-only"])
    assert res.exit_code == 0
    lines = res.stdout.strip().splitlines()
    assert len(lines) == 1
    assert json.loads(lines[0]) == {"cases": [_result("beam", True)], "passed": True}


def test_validate_non_finite_values_are_valid_json(runner, monkeypatch):
    mod = _fake_cases({"nan": [_result("nan", False, float("nan"))]})
    monkeypatch.setitem(sys.modules, "knotsim.validation.cases", mod)
    res = runner.invoke(main, ["validate", "--json-only"])
    assert res.exit_code == 1
    final = json.loads(res.stdout.strip(), parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
    assert final["cases"][0]["value"] is None


def test_validate_unknown_case_exit_2(runner, fake_cases):
    res = runner.invoke(main, ["validate", "beam", "cantilevr"])
    assert res.exit_code == 2
    assert "unknown validation case 'cantilevr'" in res.stderr
    assert "known cases: beam, helix, broken" in res.stderr
    assert fake_cases.calls == []
    assert "Traceback" not in res.output


def test_validate_module_missing(runner, monkeypatch):
    monkeypatch.setitem(sys.modules, "knotsim.validation.cases", None)  # import raises ModuleNotFoundError
    res = runner.invoke(main, ["validate"])
    assert res.exit_code == 2
    assert "not available" in res.stderr


# ------------------------------------------------------------------------------------------ post-processing
def test_export_vtk(runner, config_file, tmp_path):
    out = tmp_path / "out"
    assert runner.invoke(main, ["run", str(config_file), "-o", str(out), "-q"]).exit_code == 0
    res = runner.invoke(main, ["export-vtk", str(out), "-o", str(tmp_path / "vtk"), "--every", "5"])
    assert res.exit_code == 0, res.output
    assert list((tmp_path / "vtk").glob("*.pvd"))
    assert list((tmp_path / "vtk").glob("*.vtp"))


@pytest.mark.slow
def test_validate_quick_real_cases_all_pass(runner):
    """``knotsim validate --quick`` on the real cases (engine, contact, overhand, single-rod reef and
    granny, bends; about 20 s): every row passes and the exit code is 0."""
    res = runner.invoke(main, ["validate", "--quick", "--json-only"])
    assert res.exit_code == 0, res.output[-3000:]
    data = json.loads(res.output.strip().splitlines()[-1])
    failed = [(c["case"], c["quantity"]) for c in data["cases"] if not c["passed"]]
    assert data["passed"] and not failed, failed
    assert {c["case"] for c in data["cases"]} >= {"cantilever", "helix", "contact", "overhand_tightening",
                                                   "single_rod_bend", "bends", "rolling"}


def test_kernels_cached_reads_numba_cache_index(tmp_path):
    """An empty NUMBA_CACHE_DIR means not cached (checked in a fresh process, nothing compiled)."""
    import os
    import subprocess

    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", "from knotsim._warmup import kernels_cached as k; "
                          "print(k(), k(contact=False, topology=False))"],
                         env=env, capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "False"]
    assert not list(tmp_path.rglob("*.nbi"))  # the check compiles nothing


@pytest.mark.parametrize("spare", [0.0, 1.5])
def test_compile_notice_before_compiling(monkeypatch, capsys, spare):
    import knotsim._warmup as W
    from knotsim.cli.output import announce_compile

    calls = []
    monkeypatch.setattr(W, "kernels_cached", lambda **kw: False)
    monkeypatch.setattr(W, "spare_cores", lambda: spare)
    monkeypatch.setattr(W, "warm_up", lambda parallel, groups: calls.append(parallel) or {"total": 12.0})
    announce_compile()
    err = capsys.readouterr().err
    assert err.startswith("note: compiling the numerical kernels for the first time")
    assert calls == ([True] if spare >= 1 else [])
    assert ("kernels compiled in 12 s" in err) == (spare >= 1)
    monkeypatch.setattr(W, "kernels_cached", lambda **kw: True)
    announce_compile()
    assert capsys.readouterr().err == ""
