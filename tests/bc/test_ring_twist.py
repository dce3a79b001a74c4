"""Twist injected at the cut of a closed ring (bcs.ring_twist): the moment it takes, and Michell's
instability (a ring twisted past 2 pi sqrt(3) EI/GJ leaves its plane, below it stays planar)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import knotsim as ks
from knotsim.bc.feedback import michell_twist
from knotsim.errors import ConfigError
from knotsim.io.config import load_config

N = 48
R = 0.05


def ring_model(nu=0.5):
    phi = 2 * np.pi * np.arange(N) / N
    x = np.stack([R * np.cos(phi), R * np.sin(phi), 0 * phi], 1)
    rod = ks.RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0, poisson_ratio=nu, closed=True, name="ring")
    return ks.Model([rod], damping=0.01), rod


def supported(model, **twist):
    """Rigid motions and the frame gauge removed by statically determinate pins."""
    b = ks.BoundaryConditions(model)
    b.pin("a", nodes=[0], twist=True)
    b.pin("b", nodes=[N // 2], axes="yz")
    b.pin("c", nodes=[N // 4], axes="z")
    b.ring_twist("tw", **twist)
    return b


def solve(model, bcs, state=None, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return ks.solve_static(model, bcs, state=state, time=1.0, interactions=bcs.interactions(), **kw)


def out_of_plane(model, q):
    return float(np.abs(model.node_positions(q)[:, 2]).max())


def test_injected_twist_spreads_uniformly_and_its_moment_is_GJ_tau():
    model, rod = ring_model()
    tw = 0.5 * michell_twist(rod)
    bcs = supported(model, total=tw)
    res = solve(model, bcs)
    q = res.state.q
    th = q[model.edge_theta_dof]
    strain = th[model.bend_edges[:, 1]] - th[model.bend_edges[:, 0]] + res.state.ref_twist - model.twist_bar
    assert np.allclose(strain, tw / N, rtol=1e-6)
    length = 2 * N * R * np.sin(np.pi / N)
    assert bcs.ring_moment("tw", res.state) == pytest.approx(rod.GJ * tw / length, rel=1e-6)
    assert out_of_plane(model, q) < 1e-12 and res.stable


def test_michell_threshold_within_2_percent():
    """Bisection on the sign of the lowest Hessian eigenvalue of the planar twisted ring."""
    model, rod = ring_model(nu=0.5)
    tw_c = michell_twist(rod)
    assert tw_c == pytest.approx(2 * np.pi * np.sqrt(3) * 1.5)
    lo, hi = 0.8, 1.2
    for _ in range(7):
        mid = 0.5 * (lo + hi)
        if solve(model, supported(model, total=mid * tw_c)).stable:
            lo = mid
        else:
            hi = mid
    assert 0.98 < lo and hi < 1.02, (lo, hi)


@pytest.mark.parametrize("fraction", [0.8, 1.2])
def test_past_the_threshold_the_ring_buckles_below_it_stays_planar(fraction):
    """Dynamics from the planar twisted ring plus a small out-of-plane n = 2 perturbation (2e-7 m):
    above the threshold it grows to a buckled ring, below it dies out."""
    n, r = 40, 0.02
    phi = 2 * np.pi * np.arange(n) / n
    x = np.stack([r * np.cos(phi), r * np.sin(phi), 0 * phi], 1)
    rod = ks.RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0, closed=True, name="ring")
    model = ks.Model([rod])

    def bcs():
        b = ks.BoundaryConditions(model)
        b.pin("a", nodes=[0], twist=True)
        b.pin("b", nodes=[n // 2], axes="yz")
        b.pin("c", nodes=[n // 4], axes="z")
        b.ring_twist("tw", total=fraction * michell_twist(rod))
        return b

    planar = solve(model, bcs()).state
    assert out_of_plane(model, planar.q) < 1e-12
    dz = 1e-5 * r * np.sin(2 * phi + 0.3)
    dz[[0, n // 4, n // 2]] = 0.0  # the pinned nodes define the plane
    planar.q[model.node_dof + 2] += dz
    sim = ks.Simulation(model, bcs(), ks.SolverOptions(dt=2e-3), state=planar)
    sim.advance(0.3)
    dev = out_of_plane(model, sim.state.q)
    log = sim.log()
    assert log["tw_twist"].iloc[-1] == pytest.approx(fraction * michell_twist(rod))
    if fraction < 1:
        assert dev < 0.5 * np.abs(dz).max()
        assert log["tw_moment"].iloc[-1] == pytest.approx(rod.GJ * fraction * michell_twist(rod)
                                                          / (2 * n * r * np.sin(np.pi / n)), rel=1e-3)
    else:
        assert dev > 0.05 * r


def test_rate_total_window_and_reset():
    model, rod = ring_model()
    bcs = supported(model, total=2.0, rate=4.0, start=0.5)
    q = np.zeros(model.n_dofs)
    base = model.twist_bar.copy()
    for t, expect in ((0.2, 0.0), (0.75, 1.0), (3.0, 2.0)):
        bcs.evaluate(t, q, t)
        assert -np.sum(model.twist_bar - base) == pytest.approx(expect)
    bcs.reset()
    assert np.array_equal(model.twist_bar, base)


def test_errors_and_run_file_form():
    model, _ = ring_model()
    x = np.zeros((5, 3))
    x[:, 0] = np.arange(5) * 0.01
    open_model = ks.Model([ks.RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0)])
    with pytest.raises(ConfigError) as info:
        ks.BoundaryConditions(open_model).ring_twist("t", total=1.0)
    assert info.value.field == "bc.t.rod" and "closed" in str(info.value)
    with pytest.raises(ConfigError) as info:
        ks.BoundaryConditions(model).ring_twist("t")
    assert info.value.field == "bc.t.total"
    raw = {"rods": [{"name": "ring", "shape": "circle", "ring_radius": R, "n_nodes": N, "radius": 1e-3,
                     "youngs_modulus": 1e6, "density": 1000.0}],
           "bc": [{"type": "ring_twist", "name": "tw", "total": 3.0, "rate": 1.5, "node": 3}],
           "run": {"duration": 0.01}}
    cfg = load_config(raw)
    g = cfg.build_bcs().groups["tw"]
    assert g.ring.twist(1.0) == pytest.approx(1.5) and g.ring.twist(9.0) == pytest.approx(3.0)
    assert g.ring.node == 3
    raw["bc"][0]["rate"] = -1.0
    with pytest.raises(ConfigError) as info:
        load_config(raw)
    assert info.value.field == "bc[0].rate"
