"""Cantilever under its own weight (docs/physics.md §5).

A rod of free length ``L`` is clamped at one end: its first edge (nodes 0 and 1, with its twist) is
clamped and straddles the wall, whose plane passes through the edge's midpoint. The bending stencil
of node 1 covers the Voronoi region starting at that midpoint, so the free span is exactly ``L``
(``x_k = (k - 1/2) l``, ``l = L / (N - 3/2)``), and the discretisation error is second order. Gravity gives
the load parameter ``alpha = rho A g L^3 / EI``. Static equilibrium is found by Newton with load
continuation. The published tips are for an inextensible elastica; the rod's axial strain is about
``alpha h^2 / (4 L^2)`` (1e-5 at alpha = 39.24 with the default h = 2 mm, L = 1 m), well below the
tolerance.
"""

from __future__ import annotations

import numpy as np

from knotsim.bc import BoundaryConditions
from knotsim.rods import Model, RodSpec
from knotsim.solver.static import solve_static

#: Published tip positions (x/L, z/L) for large deflections.
LARGE_DEFLECTION_TIP = {1.0: (0.99125, -0.12347), 10.0: (0.65635, -0.70020), 39.24: (0.28712, -0.89338)}


def cantilever_model(n_nodes: int, alpha: float, length: float = 1.0, radius: float = 0.002,
                     youngs_modulus: float = 1e7, density: float = 1000.0):
    """Model and boundary conditions; returns ``(model, bcs, weight_of_free_span)``."""
    l = length / (n_nodes - 1.5)
    x = np.zeros((n_nodes, 3))
    x[:, 0] = (np.arange(n_nodes) - 0.5) * l
    rod = RodSpec(x, radius=radius, youngs_modulus=youngs_modulus, density=density, poisson_ratio=0.5)
    g = alpha * rod.EI / (density * rod.area * length**3)
    model = Model([rod], gravity=(0.0, 0.0, -g))
    bcs = BoundaryConditions(model)
    bcs.clamp("wall", nodes=[0, 1], twist=True)
    return model, bcs, density * rod.area * length * g


def tip_position(n_nodes: int, alpha: float, load_steps: int = 4, **kw):
    """Tip position ``(x/L, z/L)`` and the wall reaction (N) at equilibrium."""
    length = kw.get("length", 1.0)
    model, bcs, weight = cantilever_model(n_nodes, alpha, **kw)
    res = solve_static(model, bcs, load_steps=load_steps)
    tip = model.node_positions(res.state.q)[-1]
    return np.array([tip[0] / length, tip[2] / length]), res.reactions["wall"], model
