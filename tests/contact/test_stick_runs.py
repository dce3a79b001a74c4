"""The elastic-stick law in runs (docs/physics.md §3.6): static friction holds without creep, slides
at the kinetic coefficient, its springs are run state (continued runs equal uninterrupted ones bit
for bit), and its inputs are checked."""

from __future__ import annotations

import math

import numpy as np
import pytest

import knotsim as ks
from knotsim.contact.model import Contact, ContactOptions
from knotsim.contact.stick import StickHistory, return_map
from knotsim.errors import ConfigError
from knotsim.validation.stick import STICK_DISTANCE, drag, incline


def test_incline_holds_between_the_kinetic_and_the_static_coefficient():
    """tan α = 0.25 with μ_k = 0.2, μ_s = 0.3: the stick law holds (drift ≪ δ_s), the smooth law
    (μ = 0.2) slides at g (sin α − μ cos α)."""
    held = incline(0.25, hold=0.1)
    assert abs(held["drift"]) < 1e-3 * STICK_DISTANCE and held["sliding"] == 0
    slid = incline(0.25, stick_distance=None, hold=0.1)
    assert slid["acceleration"] == pytest.approx(slid["reference"], rel=0.01)


def test_incline_below_the_kinetic_coefficient_does_not_creep():
    """tan α = 0.1: the smooth law creeps (speed ~ ν (2/15) atanh(F_t/μF_n)), the stick law does not."""
    held = incline(0.1, hold=0.2)
    creep = incline(0.1, stick_distance=None, hold=0.2)
    assert creep["speed"] > 1e-6  # the regularised law's creep, for contrast
    assert abs(held["speed"]) < 1e-3 * creep["speed"]


def test_incline_above_the_static_coefficient_slides_at_the_kinetic_one():
    r = incline(0.4, hold=0.1)
    assert r["acceleration"] == pytest.approx(r["reference"], rel=0.01)
    assert r["sliding"] > 0


def test_drag_sticks_and_slips():
    """Stick-slip of a rod dragged over two rods through a soft spring: slips start between μ_k N
    and μ_s N and the force falls by about twice its excess over μ_k N."""
    r = drag(duration=1.0)
    assert r["n_slips"] >= 1
    assert np.all(r["peaks"] > r["kinetic"]) and np.all(r["peaks"] <= 1.02 * r["static"])
    assert r["drop"] == pytest.approx(r["overshoot_drop"], rel=0.3)


def _pressed_rods(stick=True):
    from knotsim.validation.contact import crossing_rods

    m, bcs = crossing_rods()
    bcs.move("B0", rod="B", nodes=[0, 1], path=lambda t: [0.002 * t, 0.0, -0.01 * min(t, 0.15)])
    bcs.move("B1", rod="B", nodes=[-2, -1], path=lambda t: [0.002 * t, 0.0, -0.01 * min(t, 0.15)])
    opts = ContactOptions(mu=0.3, stick_distance=1e-5 if stick else None, mu_static=0.4 if stick else None)
    ci = Contact(m, opts)
    return ks.Simulation(m, bcs, ks.SolverOptions(dt=2e-3), interactions=[ci]), ci


def _continued_equals_whole(make, half: float, tmp_path):
    """``make()`` -> ``(simulation, interaction)``: a run of ``2 half`` s and one of ``half`` s, checkpointed,
    restored into a fresh simulation and run ``half`` s more, end at the same positions and springs."""
    whole, iw = make()
    whole.run(2 * half, progress=False)
    assert iw.memory.stick_xi is not None and np.abs(iw.memory.stick_xi).max() > 0.0  # springs in use
    first, _ = make()
    first.run(half, progress=False)
    first.save_checkpoint(tmp_path / "ck")
    second, i2 = make()
    second.restore(tmp_path / "ck")
    second.run(half, progress=False)
    np.testing.assert_array_equal(second.state.q, whole.state.q)
    np.testing.assert_array_equal(i2.memory.stick_xi, iw.memory.stick_xi)
    np.testing.assert_array_equal(i2.memory.stick_sliding, iw.memory.stick_sliding)


def test_pair_springs_continue_bit_for_bit(tmp_path):
    _continued_equals_whole(_pressed_rods, 0.12, tmp_path)


def _floor_rope():
    x = np.zeros((11, 3))
    x[:, 0] = np.linspace(0.0, 0.05, 11)
    x[:, 2] = 1e-3 + 2e-5
    m = ks.Model([ks.RodSpec(x, radius=1e-3, youngs_modulus=1e7, density=1000.0)], gravity=(0.0, 0.0, -9.81))
    floor = ks.Plane(m, "floor", mu=0.2, mu_static=0.3, stick_distance=1e-5)
    bcs = ks.BoundaryConditions(m)
    bcs.force("push", rod=0, nodes=list(range(11)), force=lambda t: [-1e-4 * min(t / 0.05, 1.0), 0.0, 0.0])
    return ks.Simulation(m, bcs, ks.SolverOptions(dt=1e-3), interactions=[floor]), floor


def test_obstacle_springs_continue_bit_for_bit(tmp_path):
    _continued_equals_whole(_floor_rope, 0.04, tmp_path)


def test_return_map():
    n = np.array([[0.0, 0.0, 1.0]] * 4)
    xi = np.array([[1e-5, 0.0, 0.0], [3e-5, 4e-5, 0.0], [0.0, 1e-6, 1e-6], [5e-5, 0.0, 0.0]])
    inside = np.array([True, True, True, False])
    limit = np.full(4, 2e-5)
    out, sliding = return_map(xi, n, inside, limit, 1e-5)
    np.testing.assert_allclose(out[0], [1e-5, 0, 0])  # within the limit: kept
    assert not sliding[0] and sliding[1] and not sliding[3]
    np.testing.assert_allclose(out[1], [0.6e-5, 0.8e-5, 0.0])  # beyond: back to |ξ| = δ_s, same direction
    np.testing.assert_allclose(out[2], [0.0, math.sqrt(2) * 1e-6, 0.0])  # into the tangent plane, length kept
    assert not out[3].any()  # out of contact: forgotten


def test_springs_follow_their_pairs_and_pass_to_neighbours():
    m = ks.Model([ks.RodSpec(np.c_[np.linspace(0, 0.1, 11), np.zeros(11), np.zeros(11)], radius=1e-3, youngs_modulus=1e7, density=1000.0),
                  ks.RodSpec(np.c_[np.zeros(11), np.linspace(-0.05, 0.05, 11), np.full(11, 3e-3)], radius=1e-3, youngs_modulus=1e7, density=1000.0)])
    table = np.full((2, 2), 0.3)
    hist = StickHistory(m, 1e-5, table, table)

    class Mem:
        stick_xi = None
        stick_sliding = None

    mem = Mem()
    old = np.array([[4, 14], [5, 15]])
    mem.stick_xi = np.array([[1e-6, 0, 0], [2e-6, 0, 0]])
    mem.stick_sliding = np.array([False, True])
    new = np.array([[5, 15], [6, 15], [3, 12]])
    hist.remap(mem, old, new)
    np.testing.assert_array_equal(mem.stick_xi, [[2e-6, 0, 0], [0, 0, 0], [0, 0, 0]])
    np.testing.assert_array_equal(mem.stick_sliding, [True, False, False])
    hist.inherit(mem, new)  # (6, 15) next to (5, 15) takes its spring; (3, 12) has no neighbour with one
    np.testing.assert_array_equal(mem.stick_xi, [[2e-6, 0, 0], [2e-6, 0, 0], [0, 0, 0]])
    np.testing.assert_array_equal(mem.stick_sliding, [True, True, False])


def test_input_errors_name_the_field():
    m = ks.Model([ks.RodSpec(np.c_[np.linspace(0, 0.1, 11), np.zeros(11), np.zeros(11)], radius=1e-3, youngs_modulus=1e7, density=1000.0)])
    with pytest.raises(ConfigError, match=r"contact\.mu_static.*stick_distance"):
        ContactOptions(mu=0.3, mu_static=0.4).validate()
    with pytest.raises(ConfigError, match=r"contact\.stick_distance.*surface"):
        ContactOptions(mu=0.3, stick_distance=1e-5, friction_model="centreline").validate()
    with pytest.raises(ConfigError, match=r"contact\.stick_distance"):
        ContactOptions(mu=0.3, stick_distance=-1.0).validate()
    with pytest.raises(ConfigError, match=r"contact\.mu_static.*at least mu"):
        Contact(m, ContactOptions(mu=0.3, stick_distance=1e-5, mu_static=0.2))
    with pytest.raises(ConfigError, match=r"contact\.delta.*radius"):
        Contact(m, ContactOptions(delta=1.0))
    with pytest.raises(ConfigError, match=r"obstacles\.f\.mu_static"):
        ks.Plane(m, "f", mu=0.3, mu_static=0.4)
    with pytest.raises(ConfigError, match=r"obstacles\.f\.mu_static.*at least"):
        ks.Plane(m, "f", mu=0.3, mu_static=0.2, stick_distance=1e-5)
    with pytest.raises(ConfigError, match=r"obstacles\.f\.stick_distance.*surface"):
        ks.Plane(m, "f", mu=0.3, stick_distance=1e-5, friction_model="centreline")
    with pytest.raises(ConfigError, match=r"obstacles\.c\.stick_distance.*free-spinning"):
        ks.Capsule(m, "c", mu=0.3, stick_distance=1e-5, spin_inertia=1e-3)


def test_capstan_at_rest_sticks_then_slides_at_the_kinetic_ratio():
    """A rope over a post, far end clamped, hanging load rising: it holds more than the kinetic
    capstan before it slips (at most the static one) and then slides at the kinetic ratio."""
    from knotsim.validation.stick import capstan_hold

    r = capstan_hold(ramp=0.5)
    assert r["sliding"] == pytest.approx(r["kinetic"], rel=0.02)
    assert r["kinetic"] < r["peak"] <= 1.01 * r["static"]
