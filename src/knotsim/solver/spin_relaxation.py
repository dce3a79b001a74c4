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

from knotsim.solver._kernels import relaxed_angle_numbering


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


def relaxed_angles(spin: SpinFrictionTerms, free: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The angles a relaxation solves for: the free ones among the pairs' of ``spin``.

    ``free`` (n_dofs,) bool, the unknowns not prescribed; ``r`` (n_dofs,) the residual (N m on
    angles). Returns ``(idx, loc, largest)``: the relaxed angles' unknowns ``idx`` (m,) int64 in
    increasing order, the place in ``idx`` of every pair's two angles ``loc`` (k, 2) int64 (−1:
    prescribed, held), and ``max |r[idx]|`` (N m)."""
    idx, loc, largest = relaxed_angle_numbering(np.ascontiguousarray(spin.theta_dofs, dtype=np.int64), free, r)
    return idx, loc, float(largest)


def relax_spins(j_tt, r_t: np.ndarray, loc: np.ndarray, spin: SpinFrictionTerms, dt: float, tol: float,
                max_iterations: int = 20, max_cuts: int = 40) -> SpinRelaxation:
    """Solve the angle equations with the nodes held (module docstring).

    Parameters
    ----------
    j_tt : (m, m) float64, the Jacobian's block of the relaxed angles (N m/rad; their unknowns
        ``idx`` of :func:`relaxed_angles`, in that order).
    r_t : (m,) float64, their residual (N m).
    loc : (k, 2) int64, the place of every pair's two angles among the relaxed ones (−1: held; see
        :func:`relaxed_angles`).
    spin : :class:`SpinFrictionTerms`, the surface-friction pairs (of every interaction, joined).
    dt : time step (s).
    tol : target of the largest angle residual (N m).
    """
    dtheta = np.zeros(r_t.shape[0])
    it, residual = spin.minimise(j_tt, r_t, loc, dt, tol, max_iterations, max_cuts, dtheta)
    return SpinRelaxation(dtheta, it, residual)


def joined_spins(spins) -> SpinFrictionTerms:
    """One :class:`SpinFrictionTerms` holding the pairs of every one of ``spins`` (a non-empty
    sequence, in its order)."""
    return spins[0] if len(spins) == 1 else spins[0].joined(spins[1:])
