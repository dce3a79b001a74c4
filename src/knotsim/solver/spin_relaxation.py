"""Spin relaxation: the edge angles solved for with the positions held, before a Newton step.

With friction at the rods' surfaces, the edge angles ``θ`` of a rope are light unknowns
(rotational inertia ``m h²/2`` per edge) held only by the soft twist of the rope and by friction,
whose stick-slip switch is steep (a band of ``ν dt/h`` in angle). In a tight knot Newton's step then
turns the angles far past the switch and the iterates cycle between sticking and sliding; a step
converges in three times the iterations of the centre-line law or not at all (docs/physics.md
§3.5). The remedy is a nonlinear elimination: before each Newton step the angles are solved for
with the nodes held where they are, then the full Newton step is taken from there (at a point
where the angle equations hold, the full Newton step is the Newton step of the positions with the
angles eliminated).

With the nodes held, the angle equations are the gradient of a convex function (docs/physics.md
§3.5): every term that is linear in the angles (inertia, damping, twist) is exact in the assembled
Jacobian, and the friction of every surface-friction pair is the gradient of its dissipation
potential ``μ F_n dt Γ(|u|)``, with the slip ``u`` affine in the pair's two angles. The model

    Ψ(Δθ) = r_θᵀΔθ + ½ Δθᵀ A Δθ + Σ_pairs [D_p(Δθ) − D_p(0) − ∇D_p(0)ᵀΔθ],   A = J_θθ − Σ ∇²D_p(0),

(``r_θ`` the residual of the angles, ``J_θθ`` their block of the Jacobian) is minimised by Newton's
method with a backtracking line search on ``Ψ``, which converges from any start for a convex
``Ψ`` (in one compiled call, :mod:`knotsim.contact.spin_minimiser`). Terms of the angles that
are not linear (the bending of a rod with a natural curvature, friction against obstacles) enter
``A`` linearised; the Newton step that follows corrects them.

The relaxation changes the path of the Newton iterates, not the equations: a step converges to the
same tolerance on the same residual. It is used only with surface-friction pairs in range (with the
centre-line law nothing changes) and switched by ``SolverOptions.spin_relaxation``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


class SpinFrictionTerms(Protocol):
    """What an interaction hands over for the relaxation (see
    :class:`knotsim.contact.spin_minimiser.SpinFriction`)."""

    theta_dofs: np.ndarray

    def joined(self, others) -> SpinFrictionTerms:
        """One object holding the pairs of this one and of ``others``."""

    def minimise(self, j_tt, r_t, loc, dt: float, tol: float, max_iterations: int, max_cuts: int,
                 dtheta_out) -> tuple[int, float]:
        """The angle problem solved (module docstring): the turn into ``dtheta_out``; returns
        (iterations, largest gradient entry / ``tol``)."""


@dataclass
class SpinRelaxation:
    """Outcome of :func:`relax_spins`: the turn of the free angles and how it was found."""

    #: (m,) rad, turn of each angle of ``theta_dofs`` (the free angles, in their order)
    dtheta: np.ndarray
    #: Newton iterations of the angle problem
    iterations: int
    #: largest residual of the angle model at the end, in units of the tolerance given
    residual: float


def relax_spins(j_tt, r_t: np.ndarray, theta_dofs: np.ndarray, n_dofs: int, spins, dt: float, tol: float,
                max_iterations: int = 20, max_cuts: int = 40) -> SpinRelaxation:
    """Solve the angle equations with the nodes held (module docstring).

    Parameters
    ----------
    j_tt : (m, m) float64, the Jacobian's block of the relaxed angles ``theta_dofs`` (N m/rad).
    r_t : (m,) float64, their residual (N m).
    theta_dofs : (m,) int64, the relaxed angles' unknowns (free angles of edges in contact; every
        other unknown is held).
    n_dofs : number of unknowns of the model.
    spins : sequence of :class:`SpinFrictionTerms` (each interaction's surface-friction pairs).
    dt : time step (s).
    tol : target of the largest angle residual (N m).
    """
    locmap = np.full(n_dofs, -1, dtype=np.int64)
    locmap[theta_dofs] = np.arange(theta_dofs.shape[0])
    spin = spins[0] if len(spins) == 1 else spins[0].joined(spins[1:])
    dtheta = np.zeros(theta_dofs.shape[0])
    it, residual = spin.minimise(j_tt, r_t, locmap[spin.theta_dofs], dt, tol, max_iterations, max_cuts, dtheta)
    return SpinRelaxation(dtheta, it, residual)
