"""State of the boundary conditions that are more than prescribed values: a load-cell grip (a
displacement adjusted by a PI controller to hold a target force) and the twist injected at the cut
of a closed ring.

Ring twist. The twisting energy of node ``i`` is ``GJ/(2 l_i) (m_i - mbar_i)^2`` with
``m_i = theta_i - theta_(i-1) + reference twist``. Welding the material frames across a cut with an
angle jump ``Tw`` (rad) is the same as lowering the rest twist of the cut's node by ``Tw``: ``Tw`` of
twist is injected and spreads around the ring. It is not put at one node, though: DER's bending
energy uses the mean of the two edges' material directors, whose length is ``cos(jump/2)``, so a
large jump at one node would soften that node's bending (a ring twisted that way to 0.2 of
Michell's threshold left its plane). The rest twist of every node ``i`` is lowered by
``Tw l_i / L`` (Voronoi length ``l_i``, ring length ``L``) instead, which in equilibrium is the same
ring: the twist strain ``m - mbar`` settles to ``Tw / L`` per unit length either way, with the
frames of neighbouring edges nearly aligned. The moment across the cut is ``GJ/l_c (m_c - mbar_c)``
(N m).

Michell's instability (Michell 1889; Goriely 2006, J. Elasticity 84, 281-299: "Twisted elastic
rings and the rediscoveries of Michell's instability"): a planar circular ring of an isotropic rod
with bending stiffness ``B = EI`` and torsional stiffness ``C = GJ`` carrying a uniform total twist
``Tw`` (rad, ``2 pi R`` times the twist density) is stable while ``Tw < 2 pi sqrt(3) B/C``, and
buckles out of its plane beyond. For a circular section ``B/C = 1 + nu`` (Poisson ratio ``nu``):
``Tw_c = 2 pi sqrt(3) (1 + nu)``, 16.32 rad (2.6 turns) at ``nu = 0.5``. The threshold does not
depend on the ring's radius or size.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from knotsim.solver.state import LoadCellMemory


def michell_twist(rod) -> float:
    """Michell's critical total twist ``2 pi sqrt(3) EI/GJ`` (rad) of a ring of ``rod`` (a
    :class:`~knotsim.rods.RodSpec`; see the module docstring)."""
    return 2.0 * math.pi * math.sqrt(3.0) * rod.EI / rod.GJ


@dataclass
class RingCut:
    """Twist injected at a cut of a closed rod: bend stencil ``stencil`` (the node ``node``, global)
    between edges ``edges = (e_in, e_out)``; ``stencils (k,)`` all bend stencils of the ring, with
    their rest twist ``base (k,)`` (rad) without the injected twist and the share ``weight (k,)``
    (``l_i / L``, summing to 1) of it each takes; ``twist(elapsed) -> rad`` the injected twist."""

    node: int
    stencil: int
    edges: tuple[int, int]
    stencils: np.ndarray
    base: np.ndarray
    weight: np.ndarray
    twist: Callable[[float], float]
    value: float = 0.0  # twist injected at the last evaluation (rad)

    def injected(self, t: float, start: float, stop: float) -> float:
        """Twist (rad) injected at time ``t``: 0 before ``start``; after ``stop`` it stays (a closed
        ring keeps its twist)."""
        if t < start:
            return 0.0
        return float(self.twist(min(t, stop) - start))


@dataclass
class LoadCell:
    """A grip moved along ``direction (3,)`` (unit) by ``u`` (m) so that the reaction force along
    ``direction`` follows ``target(elapsed)`` (N): ``u_cmd = kp e + ki ∫ e dt`` with the error
    ``e = target - F`` (N) measured after every accepted step (gains ``kp`` m/N, ``ki`` m/(N s)); the
    next step moves the grip to ``u_cmd``, at most ``max_speed`` (m/s) fast. The controller's
    numbers are its run memory (:class:`~knotsim.solver.state.LoadCellMemory`)."""

    direction: np.ndarray
    target: Callable[[float], np.ndarray]
    kp: float
    ki: float
    max_speed: float
    #: the controller's state (part of the group's :class:`~knotsim.solver.state.GroupMemory`)
    memory: LoadCellMemory = field(default_factory=LoadCellMemory, repr=False, compare=False)

    def displacement(self, t: float, t_in: float) -> float:
        """Displacement (m) prescribed at the end ``t`` of a step starting at ``t_in``."""
        m = self.memory
        du = m.u_cmd - m.u
        if math.isfinite(self.max_speed):
            lim = self.max_speed * max(t - t_in, 0.0)
            du = min(max(du, -lim), lim)
        m.u_step = m.u + du
        return m.u_step

    def update(self, t: float, start: float, force: float) -> None:
        """After an accepted step ending at ``t`` (s) with measured ``force`` (N) along the direction."""
        m = self.memory
        target = float(self.target(t - start))
        dt = t - (m.t_last if m.t_last is not None else start)
        m.force = force
        m.error = target - force
        m.integral += m.error * max(dt, 0.0)
        m.u = m.u_step
        m.u_cmd = self.kp * m.error + self.ki * m.integral
        m.t_last = t

    def reset(self) -> None:
        m = self.memory
        m.u = m.u_cmd = m.integral = m.force = m.error = m.u_step = 0.0
        m.t_last = None
