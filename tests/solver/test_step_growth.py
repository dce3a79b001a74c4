"""Steps beyond the target dt while the solution is smooth (``SolverOptions.dt_max``, ``error_tol``):
they grow when the local error estimate is small, come back at a stage change and when the motion
changes fast, and keep the answer within the tolerance they are given."""

from __future__ import annotations

import numpy as np
import pytest

import knotsim as ks


def _sagging(**options):
    """A damped cantilever settling under gravity (fast at first, then still), its tip pushed by a
    force from 0.6 s: smooth stretches, one stage change."""
    x = np.stack([np.linspace(0.0, 0.2, 21), np.zeros(21), np.zeros(21)], 1)
    model = ks.Model([ks.RodSpec(x, radius=1e-3, youngs_modulus=1e7, density=1000)], gravity=(0, 0, -9.81),
                     damping=0.5)
    bcs = ks.BoundaryConditions(model)
    bcs.clamp("root", nodes=[0, 1])
    bcs.force("push", nodes=[-1], force=(0.0, 0.0, 1e-4), start=0.6)
    return ks.Simulation(model, bcs, ks.SolverOptions(**{"dt": 1e-3, **options}))


def test_default_never_steps_beyond_dt():
    sim = _sagging()
    sim.run(0.3)
    assert max(r["dt"] for r in sim.rows) == pytest.approx(1e-3)


def test_steps_grow_while_smooth_and_come_back_at_a_stage_change():
    fixed, grown = _sagging(), _sagging(dt_max=8e-3, error_tol=1e-6)
    fixed.run(1.0)
    grown.run(1.0)
    dt = np.array([r["dt"] for r in grown.rows])
    t = np.array([r["time"] for r in grown.rows])
    assert dt.max() == pytest.approx(8e-3) and len(grown.rows) < 0.5 * len(fixed.rows)
    # the step that crosses the push's start is at most the target dt
    k = int(np.searchsorted(t, 0.6 - 1e-12))
    assert dt[k] <= 1e-3 + 1e-15
    # the same answer within the tolerance's scale: the tip's position
    tip_fixed = fixed.model.node_positions(fixed.state.q)[-1]
    tip_grown = grown.model.node_positions(grown.state.q)[-1]
    assert np.linalg.norm(tip_grown - tip_fixed) < 2e-4  # m (the tip moved ~2 cm)
    assert np.linalg.norm(tip_fixed - [0.2, 0.0, 0.0]) > 5e-3


def test_a_tight_tolerance_keeps_the_target_step_while_the_rod_moves():
    """At the start the cantilever falls fast: its error estimate is far above a tight tolerance,
    so the step stays at dt until the motion has died down."""
    sim = _sagging(dt_max=8e-3, error_tol=1e-9)
    sim.run(0.1)
    assert max(r["dt"] for r in sim.rows) == pytest.approx(1e-3)


def test_bad_dt_max_names_the_field():
    with pytest.raises(ks.ConfigError, match="solver.dt_max"):
        ks.SolverOptions(dt=1e-3, dt_max=5e-4).validate()
