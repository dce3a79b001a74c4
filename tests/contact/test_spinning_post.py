"""A rope wrapped 1.5 turns round a post free to spin (issue 43, item 5).

The engine test (the pull transmitted within 2 %, rolling without slip) is not here yet: with the
staggered spin update the wrap's contacts sit in the smooth friction law's stick region (slip below
nu = 1e-4 m/s), Newton does not converge there even at dt = 2e-6 s and the run stops at
t = 0.025 s (docs/troubleshooting.md, 'The time step collapses'). What is tested: the obstacle's
report for a run whose step stays collapsed names the post, its spin and the contact whose
friction slope outweighs its inertia."""

from __future__ import annotations

import math

import knotsim as ks
from knotsim.validation.obstacles import H, R, capstan_rope


def spinning_post(turns=1.5, inertia=1e-3):
    theta = 2 * math.pi * turns
    x, tangent = capstan_rope(theta)
    model = ks.Model([ks.RodSpec(x, radius=H, youngs_modulus=1e9, density=1000, name="rope")], damping=0.05)
    post = ks.Capsule(model, "post", a=(0, -0.05, 0), b=(0, 0.05 + 4 * H * turns, 0), radius=R, mu=0.3,
                      spin_inertia=inertia)
    bcs = ks.BoundaryConditions(model)
    bcs.force("load", nodes=[0], force=[0, 0, -1.0])
    bcs.move("pull", nodes=[-1], path=list(0.02 * tangent), twist=False)
    contact = ks.Contact(model, ks.ContactOptions(mu=0.3, delta=1e-4))
    return ks.Simulation(model, bcs, ks.SolverOptions(dt=2e-3), interactions=[post, contact]), post


def test_stall_hint_names_post_spin_and_sticking_contact():
    sim, post = spinning_post()
    sim.run(0.004)
    text = post.stall_hint(1e-5)
    assert text.startswith("obstacle 'post' (free spin [0.0, ")
    assert "contact nodes" in text and "near sticking (slip below 10 nu = 0.001 m/s" in text
    assert "of rod 'rope' the friction law's slope mu F_n K2/2 = " in text and "x the node's inertia" in text
    plain = ks.Capsule(sim.model, "bare", a=(0, -0.05, 0), b=(0, 0.05, 0), radius=R)
    assert plain.stall_hint(1e-5) == ""  # never evaluated: nothing to say
