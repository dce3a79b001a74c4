"""Free rod with uniform natural curvature and twist rests as a helix (docs/physics.md §5).

Continuum answer: radius ``kbar / (kbar^2 + tbar^2)``, pitch ``2 pi tbar / (kbar^2 + tbar^2)``.
The rod starts straight with one end clamped (the clamp exerts no force at the stress-free
equilibrium); the natural curvature and twist are switched on by continuation in ``n_ramp``
static solves.
"""

from __future__ import annotations

import numpy as np

from knotsim.bc import BoundaryConditions
from knotsim.rods import Model, RodSpec
from knotsim.solver.state import initial_state
from knotsim.solver.static import solve_static


def helix_reference(kappa: float, tau: float) -> tuple[float, float]:
    """Continuum helix radius and pitch (m) for curvature ``kappa`` and twist ``tau`` (1/m)."""
    s = kappa**2 + tau**2
    return kappa / s, 2.0 * np.pi * tau / s


def fit_helix(points: np.ndarray) -> tuple[float, float]:
    """Radius and pitch (m) of a discrete helix ``points (N, 3)`` (uniformly spaced on a helix).

    The axis is normal to all chord differences; the radius comes from a least-squares circle fit
    of the points projected on the plane normal to the axis, the pitch from the advance along the
    axis per turn.
    """
    c = np.diff(points, axis=0)
    dc = np.diff(c, axis=0)
    # axis: the direction most orthogonal to all chord differences
    _, _, vt = np.linalg.svd(dc - 0 * dc.mean(axis=0))
    axis = vt[-1]
    e1 = np.cross(axis, [1.0, 0.0, 0.0])
    if np.linalg.norm(e1) < 0.1:
        e1 = np.cross(axis, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    u = points @ e1
    v = points @ e2
    # circle fit: u^2 + v^2 = 2 a u + 2 b v + c
    A = np.stack([2 * u, 2 * v, np.ones_like(u)], axis=1)
    sol, *_ = np.linalg.lstsq(A, u**2 + v**2, rcond=None)
    a, b, cc = sol
    radius = float(np.sqrt(cc + a * a + b * b))
    phase = np.unwrap(np.arctan2(v - b, u - a))
    h = points @ axis
    slope = np.polyfit(phase, h, 1)[0]
    return radius, float(abs(slope) * 2.0 * np.pi)


def helix_equilibrium(n_nodes: int, kappa: float = 28.284, tau: float = 13.333, length: float | None = None,
                      n_ramp: int = 10):
    """Equilibrium of a rod with natural curvature ``kappa`` and twist ``tau`` (1/m).

    Returns ``(radius, pitch, positions (N, 3))``. The default length is two helix turns.
    """
    if length is None:
        length = 2.0 * 2.0 * np.pi / np.hypot(kappa, tau)
    x = np.zeros((n_nodes, 3))
    x[:, 0] = np.linspace(0.0, length, n_nodes)
    rod = RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0, poisson_ratio=0.5,
                  natural_curvature=(kappa, 0.0), natural_twist=tau)
    model = Model([rod])
    kbar = model.kappa_bar.copy()
    tbar = model.twist_bar.copy()
    bcs = BoundaryConditions(model)
    bcs.clamp("end", nodes=[0, 1], twist=True)
    state = initial_state(model)
    for s in np.linspace(1.0 / n_ramp, 1.0, n_ramp):
        model.kappa_bar[:] = s * kbar
        model.twist_bar[:] = s * tbar
        state = solve_static(model, bcs, state=state, load_steps=1).state
    pts = model.node_positions(state.q)
    radius, pitch = fit_helix(pts)
    return radius, pitch, pts
