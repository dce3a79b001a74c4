"""The angle problem of the spin relaxation: the surface friction as a function of the edge angles
alone (:class:`SpinFriction`), and its minimisation in one compiled call.

With the nodes held at a Newton iterate, the edge angles of the edges in contact minimise the
convex function (docs/physics.md §3.5)

    Ψ(Δθ) = r_θᵀΔθ + ½ Δθᵀ A Δθ + Σ_pairs [D_p(Δθ) − D_p(0) − ∇D_p(0)ᵀΔθ],   A = J_θθ − Σ_p ∇²D_p(0),

``D_p`` the pair's friction potential (:func:`~knotsim.contact.surface_friction.spin_friction_terms`).
:func:`minimise_spin_potential` minimises it by Newton's method with a backtracking (Armijo) line
search on ``Ψ``, the dense Hessian factorised by the symmetric LDLᵀ of
:mod:`knotsim.solver.banded` (a full band). It is called once per relaxation through
:meth:`SpinFriction.minimise`; ``tests/solver/test_spin_relaxation.py``
keeps a plain-numpy version of the same iteration as its reference.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from knotsim.contact.surface_friction import spin_friction_terms
from knotsim.solver.banded import ldlt_banded_factor, ldlt_banded_substitute


@njit(cache=True)
def _add_pair_hessians(mat, loc, hess, sign):
    """``mat (m, m) += sign Σ_p`` pair ``p``'s 2 × 2 Hessian ``hess[p]`` at its local angles
    ``loc[p]`` (−1: held, skipped)."""
    for p in range(loc.shape[0]):
        for i in range(2):
            li = loc[p, i]
            if li < 0:
                continue
            for j in range(2):
                lj = loc[p, j]
                if lj >= 0:
                    mat[li, lj] += sign * hess[p, i, j]


@njit(cache=True)
def _potential(x, a, r_t, loc, record, nu, dt, d0, g0, grad_pairs, hess, grad_out):
    """``Ψ(x)`` (J); its gradient (N m) into ``grad_out`` and the pair Hessians at ``x`` into ``hess``."""
    d = spin_friction_terms(x, loc, record, dt, nu, grad_pairs, hess)
    m = x.shape[0]
    psi = d - d0
    for i in range(m):
        ax = 0.0
        for j in range(m):
            ax += a[i, j] * x[j]
        psi += (r_t[i] + 0.5 * ax - g0[i]) * x[i]
        grad_out[i] = r_t[i] + ax + grad_pairs[i] - g0[i]
    return psi


@njit(cache=True)
def _max_abs(x):
    """``max |x|``, NaN when an entry is NaN (unlike :func:`knotsim.solver._kernels.max_abs`, which
    skips it): a NaN gradient then ends the iteration and shows in the residual returned."""
    out = 0.0
    for i in range(x.shape[0]):
        v = abs(x[i])
        if not v <= out:  # also lets a NaN through
            out = v
    return out


@njit(cache=True)
def minimise_spin_potential(j_tt, r_t, loc, record, nu, dt, tol, max_iterations, max_cuts, dtheta):
    """Minimise ``Ψ`` (module docstring) over the turn of ``m`` angles.

    Parameters
    ----------
    j_tt : (m, m) float64, the Newton Jacobian's block of the angles (N m/rad), friction included.
    r_t : (m,) float64, their residual at the iterate (N m).
    loc : (k, 2) int64, local number of each pair's two angles (−1: held).
    record : (k, RECORD_SIZE) float64, the pairs' records (``spin_out`` of ``surface_friction_pair``).
    nu : (k,) float64, each pair's slip tolerance ν (m/s).
    dt : time step (s); tol : target of the largest gradient entry (N m).
    max_iterations, max_cuts : Newton iterations and halvings of one line search, at most.
    dtheta : (m,) float64 output, the turn found (rad).

    Returns
    -------
    (iterations, largest gradient entry at the end / tol). The iteration stops early, where it is,
    when the Hessian has a tiny or non-finite pivot or the line search finds no descent.
    """
    m = r_t.shape[0]
    k = record.shape[0]
    grad_pairs = np.empty(m)
    hess = np.empty((k, 2, 2))
    for i in range(m):
        dtheta[i] = 0.0
    d0 = spin_friction_terms(dtheta, loc, record, dt, nu, grad_pairs, hess)
    g0 = grad_pairs.copy()
    a = j_tt.copy()
    _add_pair_hessians(a, loc, hess, -1.0)
    grad = np.empty(m)
    psi = _potential(dtheta, a, r_t, loc, record, nu, dt, d0, g0, grad_pairs, hess, grad)
    trial = np.empty(m)
    grad_t = np.empty(m)
    step = np.empty(m)
    rhs = np.empty(m)
    h = np.empty((m, m))
    band = np.empty((m, m))  # band[r, j] = H[j + r, j]: the lower triangle as a full band
    w = np.empty((m, m))
    dpiv = np.empty(m)
    it = 0
    while it < max_iterations and _max_abs(grad) > tol:
        for i in range(m):
            for j in range(m):
                h[i, j] = a[i, j]
        _add_pair_hessians(h, loc, hess, 1.0)
        for j in range(m):
            for r in range(m):
                band[r, j] = h[j + r, j] if j + r < m else 0.0
            rhs[j] = -grad[j]
        if not ldlt_banded_factor(band, 0, m - 1, w, dpiv):
            break  # singular angle block (an angle held by nothing): left to Newton
        ldlt_banded_substitute(w, dpiv, m - 1, rhs, step)
        slope = 0.0
        for i in range(m):
            slope += grad[i] * step[i]
        if not np.isfinite(slope) or slope >= 0.0:
            break
        alpha = 1.0
        cuts = 0
        while True:
            for i in range(m):
                trial[i] = dtheta[i] + alpha * step[i]
            psi_t = _potential(trial, a, r_t, loc, record, nu, dt, d0, g0, grad_pairs, hess, grad_t)
            if psi_t <= psi + 1e-4 * alpha * slope or cuts >= max_cuts:
                break
            alpha *= 0.5
            cuts += 1
        if not psi_t <= psi:  # no descent at all: stop where we are
            break
        for i in range(m):
            dtheta[i] = trial[i]
            grad[i] = grad_t[i]
        psi = psi_t
        it += 1
    return it, (_max_abs(grad) / tol if m > 0 else 0.0)


class SpinFriction:
    """The surface friction of a set of pairs as a function of the edge angles alone (positions held at
    the iterate where it was taken): a thin object over
    :func:`~knotsim.contact.surface_friction.spin_friction_terms`, handed by an
    interaction to the stepper's spin relaxation (:mod:`knotsim.solver.spin_relaxation`).

    Attributes
    ----------
    theta_dofs : (k, 2) int64, the unknowns ``θ_a, θ_b`` of each pair.
    record : (k, RECORD_SIZE) float64, each pair's ``spin_out`` record (see
        :func:`~knotsim.contact.surface_friction.surface_friction_pair`).
    nu : (k,) float64, each pair's slip tolerance ν (m/s); a number is taken for every pair.
    """

    def __init__(self, theta_dofs, record, nu):
        self.theta_dofs = theta_dofs
        self.record = record
        nu = np.asarray(nu, dtype=np.float64)
        self.nu = (np.full(record.shape[0], float(nu)) if nu.ndim == 0
                   else np.ascontiguousarray(np.broadcast_to(nu, (record.shape[0],))))

    def terms(self, dtheta, loc, dt: float, grad_out, hess_out) -> float:
        """``Σ D`` (J) at the turn ``dtheta`` (rad, local numbering ``loc`` (k, 2) of the pairs' angles,
        −1 for held ones); the gradient (N m) into ``grad_out`` and the per-pair Hessians (N m/rad)
        into ``hess_out`` (k, 2, 2)."""
        return spin_friction_terms(dtheta, loc, self.record, dt, self.nu, grad_out, hess_out)

    def joined(self, others) -> SpinFriction:
        """One object holding the pairs of this one and of ``others`` (each a :class:`SpinFriction`)."""
        every = [self, *others]
        return SpinFriction(np.concatenate([s.theta_dofs for s in every]),
                            np.concatenate([s.record for s in every]), np.concatenate([s.nu for s in every]))

    def minimise(self, j_tt, r_t, loc, dt: float, tol: float, max_iterations: int, max_cuts: int,
                 dtheta_out) -> tuple[int, float]:
        """The angle problem of the spin relaxation solved (:func:`minimise_spin_potential`): the turn into ``dtheta_out`` (m,); returns (iterations, largest
        gradient entry / ``tol``)."""
        it, res = minimise_spin_potential(np.ascontiguousarray(j_tt), np.ascontiguousarray(r_t),
                                          np.ascontiguousarray(loc), self.record, self.nu, float(dt), float(tol),
                                          int(max_iterations), int(max_cuts), dtheta_out)
        return int(it), float(res)
