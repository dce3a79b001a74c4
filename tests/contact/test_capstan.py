"""Validation: a rope slipping over a fixed frictional capsule (capstan, Euler-Eytelwein).

A flexible rope (radius 0.5 mm, E = 1e8 Pa: ``EI/(R² T) ≈ 2e-3``) hangs over a horizontal post of
radius R = 5 cm, wrap angle θ = π, no gravity. One end carries a dead load T2 = 1 N, the other is
pulled down at 2 cm/s (slip speed 200 ν: full slip), so the rope slides over the post. At steady
slip the tension of the pulled end is ``T1 = T2 exp(μ θ)``. Tolerance: 1 % of the ratio (measured
errors 0.03 % at μ = 0.3 and 0.1 % at μ = 0.5 with 5 mm edges). The post's logged reaction must be
the sum of the two end forces (nothing else acts on the rope at steady state but damping, 0.05
N s/m² × 2 cm/s × 0.4 m = 4e-4 N).
"""

from __future__ import annotations

import numpy as np
import pytest

import knotsim as ks

R, H, GAP, DS, LEG = 0.05, 5e-4, 2e-4, 5e-3, 0.12


def capstan_rope() -> np.ndarray:
    rc = R + H + GAP
    n_leg = int(round(LEG / DS))
    n_arc = int(round(np.pi * rc / DS))
    left = np.stack([np.full(n_leg, -rc), np.zeros(n_leg), np.linspace(-LEG, 0, n_leg, endpoint=False)], 1)
    th = np.linspace(np.pi, 0, n_arc, endpoint=False)
    arc = np.stack([rc * np.cos(th), np.zeros(n_arc), rc * np.sin(th)], 1)
    right = np.stack([np.full(n_leg + 1, rc), np.zeros(n_leg + 1), np.linspace(0, -LEG, n_leg + 1)], 1)
    return np.concatenate([left, arc, right])


@pytest.mark.parametrize("mu", [0.3, 0.5])
def test_capstan_tension_ratio(mu):
    rope = ks.RodSpec(capstan_rope(), radius=H, youngs_modulus=1e8, density=1000)
    model = ks.Model([rope], damping=0.05)
    # the centre-line friction law, the thin-rope capstan exp(μθ) (the surface law gives the thick
    # rope's exp(μθ R/(R + h)), tests/contact/test_obstacle_surface_friction.py)
    post = ks.Capsule(model, "post", a=(0, -0.05, 0), b=(0, 0.05, 0), radius=R, mu=mu, friction_model="centreline")
    t2 = 1.0
    bcs = ks.BoundaryConditions(model)
    bcs.force("load", nodes=[0], force=[0, 0, -t2])
    bcs.move("pull", nodes=[-1], path=[0, 0, -0.02], twist=False)
    log = ks.Simulation(model, bcs, ks.SolverOptions(dt=2e-3), interactions=[post]).run(1.0)
    late = log[log["time"] > 0.7]
    t1 = -late["pull_fz"].mean()
    ratio = t1 / t2
    expected = np.exp(mu * np.pi)
    assert abs(ratio / expected - 1.0) <= 0.01, (ratio, expected)
    # steady: the pull force does not drift
    assert late["pull_fz"].std() <= 2e-3 * t1
    # the reaction on the post is the two end tensions, pointing down; no net sideways force
    assert late["post_fz"].mean() == pytest.approx(-(t1 + t2), rel=2e-3)
    assert abs(late["post_fx"].mean()) <= 5e-3 * (t1 + t2)
    # the friction drags the post's surface along the rope's motion (+x over the top): moment about
    # its axis y is +(T1 - T2) R
    assert late["post_my"].mean() == pytest.approx((t1 - t2) * R, rel=0.02)


def test_frictionless_post_transmits_the_load():
    """μ = 0: the rope slides freely and both ends carry the same tension (ratio 1 within 1 %)."""
    rope = ks.RodSpec(capstan_rope(), radius=H, youngs_modulus=1e8, density=1000)
    model = ks.Model([rope], damping=0.05)
    post = ks.Capsule(model, "post", a=(0, -0.05, 0), b=(0, 0.05, 0), radius=R, mu=0.0)
    bcs = ks.BoundaryConditions(model)
    bcs.force("load", nodes=[0], force=[0, 0, -1.0])
    bcs.move("pull", nodes=[-1], path=[0, 0, -0.02], twist=False)
    log = ks.Simulation(model, bcs, ks.SolverOptions(dt=2e-3), interactions=[post]).run(0.6)
    late = log[log["time"] > 0.4]
    assert -late["pull_fz"].mean() == pytest.approx(1.0, rel=0.01)
