"""The adaptive penalty stiffness shared by the rod-rod contact (:mod:`knotsim.contact.model`) and
the obstacles (:mod:`knotsim.contact.obstacles`).

Before each step of ``dt`` (s), ``k_target = scaler * F_max / h_min`` (N/m) with ``h_min`` the
smallest radius in contact (m) and ``F_max`` (N) the larger of the largest nodal contact force at
the last accepted step and the force needed to stop the fastest approach within one step (the
largest step seen, ``dt_ref``, not the current attempt's: a step retried with ``dt/2`` must not
double the stiffness). ``k_c`` jumps up to ``k_target`` at once and relaxes down towards it with
an exponential moving average (weight :data:`STIFFNESS_RELAX` per step); it never drops below the
floor. A step rejected for penetration multiplies ``k_c`` by :data:`PENETRATION_BOOST` before the
retry.

The numbers live in the holder's run memory (``k_c``, ``fmax_accepted``, ``dt_ref``: the fields of
:class:`~knotsim.contact.model.ContactMemory` and :class:`~knotsim.contact.obstacles.ObstacleMemory`),
so that they are carried by the state and written to checkpoints; :class:`AdaptiveStiffness` holds
only the constants of the policy.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["PENETRATION_BOOST", "STIFFNESS_RELAX", "AdaptiveStiffness", "StiffnessMemory", "default_floor"]

#: Weight of the new target in the downward moving average of the adaptive stiffness (per step).
STIFFNESS_RELAX = 0.02
#: Factor applied to an adaptive stiffness after a step rejected for penetration.
PENETRATION_BOOST = 4.0


def default_floor(scaler: float, max_node_mass: float, h_min: float) -> float:
    """The default floor of ``k_c`` (N/m): ``scaler`` times the weight of the heaviest node under
    1 m/s² (N) over ``h_min`` (m)."""
    return scaler * max_node_mass * 1.0 / h_min


@dataclass
class StiffnessMemory:
    """The run memory the adaptive stiffness keeps in its holder's memory (contact, obstacle): the
    stiffness ``k_c`` (N/m), the largest contact force of the last accepted step (N) and the largest
    step seen (s)."""

    k_c: float = math.nan
    fmax_accepted: float = 0.0
    dt_ref: float = 0.0


@dataclass(frozen=True)
class AdaptiveStiffness:
    """The policy's constants: ``scaler`` (-), ``h_min`` (m) and the ``floor`` (N/m) of ``k_c``."""

    scaler: float
    h_min: float
    floor: float

    def update(self, memory, dt: float, impact_force: Callable[[float], float]) -> None:
        """Set ``memory.k_c`` for a step of ``dt`` (s); ``impact_force(dt_ref)`` is the force (N)
        needed to stop the fastest approach within ``dt_ref`` (s)."""
        memory.dt_ref = max(memory.dt_ref, dt)
        fmax = max(memory.fmax_accepted, impact_force(memory.dt_ref))
        if fmax > 0.0:
            target = self.scaler * fmax / self.h_min
            memory.k_c = target if target > memory.k_c else memory.k_c + STIFFNESS_RELAX * (target - memory.k_c)
        memory.k_c = max(memory.k_c, self.floor)

    @staticmethod
    def penetrated(memory) -> None:
        """A step was rejected for penetration: raise ``memory.k_c`` for the retry."""
        memory.k_c *= PENETRATION_BOOST

    @staticmethod
    def accepted(memory, fmax: float) -> None:
        """A step was accepted with the largest nodal contact force ``fmax`` (N)."""
        memory.fmax_accepted = fmax
