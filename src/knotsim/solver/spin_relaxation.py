"""Spin relaxation: the edge angles solved for with the positions held, before a Newton step.

With friction at the rods' surfaces, the edge angles ``θ`` of a rope are light unknowns
(rotational inertia ``m h²/2`` per edge) held only by the soft twist of the rope and by friction,
whose stick-slip switch is steep (a band of ``ν dt/h`` in angle). In a tight knot Newton's step then
turns the angles far past the switch and the iterates cycle between sticking and sliding; a step
converges in three times the iterations of the centre-line law or not at all (docs/physics.md
§3.6). The remedy is a nonlinear elimination: before each Newton step the angles are solved for
with the nodes held where they are, then the full Newton step is taken from there (at a point
where the angle equations hold, the full Newton step is the Newton step of the positions with the
angles eliminated).

With the nodes held, the angle equations are the gradient of a convex function (docs/physics.md
§3.6): every term that is linear in the angles (inertia, damping, twist) is exact in the assembled
Jacobian, and the friction of every surface-friction pair is the gradient of its dissipation
potential ``μ F_n dt Γ(|u|)``, with the slip ``u`` affine in the pair's two angles. The model

    Ψ(Δθ) = r_θᵀΔθ + ½ Δθᵀ A Δθ + Σ_pairs [D_p(Δθ) − D_p(0) − ∇D_p(0)ᵀΔθ],   A = J_θθ − Σ ∇²D_p(0),

(``r_θ`` the residual of the angles, ``J_θθ`` their block of the Jacobian) is minimised by Newton's
method with a backtracking line search on ``Ψ``, which converges from any start for a convex
``Ψ``. Terms of the angles that are not linear (the bending of a rod with a natural curvature,
friction against obstacles) enter ``A`` linearised; the Newton step that follows corrects them.

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
    :class:`knotsim.contact.surface_friction.SpinFriction`)."""

    theta_dofs: np.ndarray

    def terms(self, dtheta: np.ndarray, loc: np.ndarray, dt: float, grad_out: np.ndarray,
              hess_out: np.ndarray) -> float:
        """Dissipation potential (J), its gradient (N m) and per-pair Hessians (N m/rad)."""


@dataclass
class SpinRelaxation:
    """Outcome of :func:`relax_spins`: the turn of the free angles and how it was found."""

    #: (m,) rad, turn of each angle of ``theta_dofs`` (the free angles, in their order)
    dtheta: np.ndarray
    #: Newton iterations of the angle problem
    iterations: int
    #: largest residual of the angle model at the end, in units of the tolerance given
    residual: float


class _Model:
    """``Ψ``, its gradient and its Hessian over the relaxed angles (dense: they are the angles of the
    edges in contact, a few hundred at most)."""

    def __init__(self, j_tt, r_t, spins, loc_maps, dt):
        self.r_t = r_t
        self.spins = spins
        self.locs = loc_maps
        self.dt = dt
        m = r_t.shape[0]
        self.m = m
        self.grad = [np.empty(m) for _ in spins]
        self.hess = [np.empty((s.theta_dofs.shape[0], 2, 2)) for s in spins]
        # flat positions in the (m, m) matrix of every pair's 2x2 entries (held angles dropped)
        self._take = []
        for i, loc in enumerate(loc_maps):
            for a in range(2):
                for b in range(2):
                    ok = (loc[:, a] >= 0) & (loc[:, b] >= 0)
                    self._take.append((i, a, b, ok, loc[ok, a] * m + loc[ok, b]))
        zero = np.zeros(m)
        self.d0 = self._terms(zero)
        self.g0 = self._grad_sum()
        self.a = j_tt - self._pair_hessian()

    def _terms(self, dtheta):
        return sum(s.terms(dtheta, loc, self.dt, g, h)
                   for s, loc, g, h in zip(self.spins, self.locs, self.grad, self.hess, strict=True))

    def _grad_sum(self):
        out = np.zeros(self.m)
        for g in self.grad:
            out += g
        return out

    def _pair_hessian(self):
        out = np.zeros(self.m * self.m)
        for i, a, b, ok, flat in self._take:
            np.add.at(out, flat, self.hess[i][ok, a, b])
        return out.reshape(self.m, self.m)

    def value_and_gradient(self, dtheta):
        """``Ψ`` (J) and ``∇Ψ`` (N m) at ``dtheta``; leaves the pair Hessians at ``dtheta``."""
        d = self._terms(dtheta)
        ad = self.a @ dtheta
        psi = float(self.r_t @ dtheta + 0.5 * (dtheta @ ad) + d - self.d0 - self.g0 @ dtheta)
        return psi, self.r_t + ad + self._grad_sum() - self.g0

    def hessian(self):
        """``∇²Ψ`` at the point of the last :meth:`value_and_gradient`."""
        return self.a + self._pair_hessian()


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
    locs = [np.ascontiguousarray(locmap[s.theta_dofs]) for s in spins]
    model = _Model(j_tt, r_t, spins, locs, dt)
    dtheta = np.zeros(theta_dofs.shape[0])
    psi, grad = model.value_and_gradient(dtheta)
    it = 0
    while it < max_iterations and np.max(np.abs(grad)) > tol:
        try:
            step = -np.linalg.solve(model.hessian(), grad)
        except np.linalg.LinAlgError:  # singular angle block (an angle held by nothing): leave it to Newton
            break
        slope = float(grad @ step)
        if not np.isfinite(slope) or slope >= 0.0:
            break
        a = 1.0
        cuts = 0
        while True:
            trial = dtheta + a * step
            psi_t, grad_t = model.value_and_gradient(trial)
            if psi_t <= psi + 1e-4 * a * slope or cuts >= max_cuts:
                break
            a *= 0.5
            cuts += 1
        if not psi_t <= psi:  # no descent at all: stop where we are
            model.value_and_gradient(dtheta)
            break
        dtheta, psi, grad = trial, psi_t, grad_t
        it += 1
    return SpinRelaxation(dtheta, it, float(np.max(np.abs(grad))) / tol if grad.size else 0.0)
