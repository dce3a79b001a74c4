"""A run whose step stays collapsed stops with a diagnosis instead of crawling
(knotsim.simulation.Simulation.stall_attempts, knotsim.solver.diagnosis)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import knotsim as ks
from knotsim.solver.diagnosis import STALL_ATTEMPTS, STALL_FRACTION, failure_place


def crawling_sim(**options):
    """A cantilever sagging under gravity with one Newton iteration allowed per attempt (an absurd
    setting) and dt_min far below the step: the step falls to about dt/1000 and stays there."""
    x = np.stack([np.linspace(0.0, 0.2, 21), np.zeros(21), np.zeros(21)], 1)
    model = ks.Model([ks.RodSpec(x, radius=1e-3, youngs_modulus=1e7, density=1000, name="rope")],
                     gravity=(0, 0, -9.81))
    bcs = ks.BoundaryConditions(model)
    bcs.hold("end", nodes=[0])
    opts = {"dt": 0.1, "max_iterations": 1, "dt_min": 1e-12, **options}
    return ks.Simulation(model, bcs, ks.SolverOptions(**opts))


def test_collapsed_step_stops_with_place_quantity_and_since(tmp_path):
    sim = crawling_sim()
    sim.stall_attempts = 300
    with pytest.raises(ks.SimulationError) as info:
        sim.run(0.5, output_dir=tmp_path / "out")
    text = str(info.value)
    assert "stayed collapsed: 300 consecutive step attempts" in text
    assert f"below dt/{STALL_FRACTION:g} = {0.1 / STALL_FRACTION:.3g} s" in text
    assert "since t=0 s (step 0)" in text
    assert "failures at rod 'rope' node" in text                      # the place
    assert "largest residual" in text and "N at rod 'rope' node" in text  # the quantity
    assert "docs/troubleshooting.md" in text
    err = info.value
    assert err.time == sim.state.time and 0.0 < err.time < 0.1
    assert err.last_good_state is not None
    d = sim.state.memory.driver
    assert d.collapsed_attempts == 300 and d.steps == len(sim.rows) > 0
    assert (tmp_path / "out" / "log.parquet").exists()  # the failed run keeps its steps


def test_rule_does_not_fire_on_a_healthy_run():
    x = np.stack([np.linspace(0.0, 0.2, 21), np.zeros(21), np.zeros(21)], 1)
    model = ks.Model([ks.RodSpec(x, radius=1e-3, youngs_modulus=1e7, density=1000)], gravity=(0, 0, -9.81))
    bcs = ks.BoundaryConditions(model)
    bcs.hold("end", nodes=[0])
    sim = ks.Simulation(model, bcs, ks.SolverOptions(dt=1e-3))
    assert sim.stall_attempts == STALL_ATTEMPTS
    sim.run(0.05)
    d = sim.state.memory.driver
    assert d.steps == len(sim.rows) and d.collapsed_attempts == 0 and math.isnan(d.collapsed_since)


def test_stall_watch_is_run_state(tmp_path):
    """The stretch's counters go into checkpoints: a continued run stops where the whole one does."""
    whole = crawling_sim()
    whole.stall_attempts = 120
    with pytest.raises(ks.SimulationError, match="stayed collapsed"):
        whole.run(0.008)
    assert whole.state.time > 0.004  # (it stops in the second half)
    first = crawling_sim()
    first.stall_attempts = 120
    first.run(0.004)
    first.save_checkpoint(tmp_path / "ck")
    second = crawling_sim()
    second.restore(tmp_path / "ck")
    assert second.state.memory.driver == first.state.memory.driver
    second.stall_attempts = 120
    with pytest.raises(ks.SimulationError, match="stayed collapsed") as info:
        second.run(0.004)
    assert info.value.time == whole.state.time
    np.testing.assert_array_equal(second.state.q, whole.state.q)


def test_failure_place():
    assert failure_place("no convergence; largest residual 0.02 N at rod 'r' node 26, in contact") == "rod 'r' node 26"
    assert failure_place("obstacle 'post': node 3 of rod 'r' penetrates 0.3 x") == "obstacle 'post': node 3 of rod 'r'"
    assert failure_place("largest residual 1 N m at rod 'a' edge 4 (twist)") == "rod 'a' edge 4 (twist)"
    assert failure_place("Newton returned non-finite positions") == ""
