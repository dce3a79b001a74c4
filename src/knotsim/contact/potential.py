"""IMC contact potential of one edge pair (Choi, Tong, Jawed, Joo 2021; eq. 5 of the IMC paper as restated in docs/physics.md §2.4).

With ``d = h_a + h_b`` the contact distance (m), ``δ`` the distance tolerance (m) and
``K1 = 15/δ`` (1/m), the energy of a pair at distance ``Δ`` is (units m²; the caller multiplies by
the contact stiffness ``k_c`` in N/m, so that the force is ``−k_c ∇E`` in N)

    E(Δ) = [ softplus(K1 (d − Δ)) / K1 ]²   for Δ < d + δ,
    E(Δ) = 0                                 for Δ ≥ d + δ,

``softplus(z) = log(1 + exp(z))``, evaluated without overflow as ``max(z, 0) + log1p(exp(−|z|))``.

Treatment of the joins (docs/physics.md §6.2, erratum to eq. 5 of Choi et al. 2021). The report uses ``(d − Δ)²`` below
``d − δ``; that branch joins the smooth one only approximately. Here the smooth branch is used
everywhere below ``d + δ``, so ``E``, ``E'`` and ``E''`` are exactly consistent with each other
and infinitely smooth across ``Δ = d − δ``. Below ``d − δ`` (``z ≥ 15``) it differs from
``(d − Δ)²`` by the relative amount ``2 log1p(e^{−z}) / z ≤ 2 log1p(e^{−15}) / 15 ≈ 4.1e-8``.

At ``Δ = d + δ`` (``z = −15``) the energy is cut off to zero. The jumps there are

* energy: ``(δ · log1p(e^{−15}) / 15)² ≈ 4.16e-16 δ²`` (``E`` at ``Δ = d − δ`` is ``≈ δ²``);
* first derivative: ``2 σ(−15) δ log1p(e^{−15}) / 15 ≈ 1.25e-14 δ`` (``E'`` at ``d − δ`` ≈ ``−2δ``);
* second derivative: ``2σ(−15)² + 2 log1p(e^{−15}) σ(−15)(1 − σ(−15)) ≈ 3.7e-13``
  (``E''`` ≈ 2 in contact),

with ``σ`` the logistic function: negligible against the round-off of a Newton solve.
"""

from __future__ import annotations

import math

from numba import njit

from knotsim.contact.distance import edge_edge_distance, edge_edge_distance_derivatives
from knotsim.contact.regularized_distance import regularized_derivatives_at, regularized_distance

#: K1 = IMC_SHARPNESS / δ.
IMC_SHARPNESS = 15.0

#: Exact energy jump at the cut-off Δ = d + δ, divided by δ² (dimensionless).
CUTOFF_ENERGY_JUMP_OVER_TOL2 = (math.log1p(math.exp(-IMC_SHARPNESS)) / IMC_SHARPNESS) ** 2


@njit(cache=True)
def _softplus_parts(z):
    """``softplus(z)``, logistic ``σ(z)`` and ``σ(z)(1 − σ(z))`` without overflow."""
    ez = math.exp(-abs(z))  # in (0, 1]
    sp = max(z, 0.0) + math.log1p(ez)
    inv = 1.0 / (1.0 + ez)
    if z >= 0.0:
        sig = inv
    else:
        sig = ez * inv
    sig1m = ez * inv * inv
    return sp, sig, sig1m


@njit(cache=True)
def imc_energy(delta, d, tol):
    """IMC energy ``E(Δ)`` (m²) for distance ``delta`` (m), contact distance ``d`` (m), tolerance ``tol`` (m)."""
    if delta >= d + tol:
        return 0.0
    k1 = IMC_SHARPNESS / tol
    sp, _, _ = _softplus_parts(k1 * (d - delta))
    g = sp / k1
    return g * g


@njit(cache=True)
def imc_energy_derivatives(delta, d, tol):
    """``(E, dE/dΔ, d²E/dΔ²)`` in (m², m, dimensionless); all zero for ``Δ ≥ d + δ``.

    With ``g = softplus(z)/K1``, ``z = K1 (d − Δ)``: ``g' = −σ(z)``, ``g'' = K1 σ(z)(1 − σ(z))``,
    ``E = g²``, ``E' = 2 g g'``, ``E'' = 2 g'² + 2 g g''``.
    """
    if delta >= d + tol:
        return 0.0, 0.0, 0.0
    k1 = IMC_SHARPNESS / tol
    sp, sig, sig1m = _softplus_parts(k1 * (d - delta))
    g = sp / k1
    return g * g, -2.0 * g * sig, 2.0 * sig * sig + 2.0 * sp * sig1m


@njit(cache=True)
def contact_pair_energy(p, d, tol, grad, hess, eta=0.0):
    """IMC energy of one edge pair and its derivatives with respect to the 12 node coordinates.

    Parameters
    ----------
    p : (12,) float64, nodes ``x0, x1`` of edge i then ``x2, x3`` of edge j (m).
    d : contact distance ``h_a + h_b`` (m).
    tol : distance tolerance δ (m).
    grad : (12,) float64 output, ``∇_p E`` (m).
    hess : (12, 12) float64 output, ``∇²_p E`` (dimensionless), ``E'' ∇Δ∇Δᵀ + E' ∇²Δ``.
    eta : parallel-edge regularization η of the distance (dimensionless): 0 uses the exact segment
        distance (:mod:`knotsim.contact.distance`), η > 0 the regularized one
        (:mod:`knotsim.contact.regularized_distance`).

    Returns
    -------
    ``(E, delta, beta_i, beta_j, case)``: energy (m²) and the distance data of
    :func:`knotsim.contact.distance.edge_edge_distance` (or of
    :func:`~knotsim.contact.regularized_distance.regularized_distance` for η > 0). For ``Δ ≥ d + δ``
    the energy, gradient and Hessian are zero.
    """
    if eta > 0.0:
        out = pair_energy(p, d, tol, grad, hess, eta, True, True)
    else:
        out = pair_energy(p, d, tol, grad, hess, eta, False, True)
    if out[1] >= d + tol:  # out of range: zero derivatives, as documented
        for k in range(12):
            grad[k] = 0.0
            for l in range(12):
                hess[k, l] = 0.0
    return out


@njit(inline="always", cache=True)
def pair_energy(p, d, tol, grad, hess, eta, regularized, want_hessian):
    """:func:`contact_pair_energy` with the distance chosen by ``regularized`` (``True``: the
    regularized distance with ``eta > 0``; ``False``: the exact one, ``eta`` unused), and the
    Hessian only when ``want_hessian`` (the regularized distance skips it then; ``hess`` is
    undefined afterwards). For ``Δ ≥ d + δ`` it returns ``E = 0`` and leaves ``grad`` and ``hess``
    as they were (the pair loop does not read them then).

    Inlined into its caller: called with a literal ``True`` or ``False``, numba compiles only that
    branch (the loop over pairs of each distance is compiled when first used, not both)."""
    if regularized:
        delta, bi, bj, case = regularized_distance(p, eta)
    else:
        delta, bi, bj, case = edge_edge_distance(p)
    if delta >= d + tol:
        return 0.0, delta, bi, bj, case
    if regularized:
        regularized_derivatives_at(p, eta, delta, bi, bj, case, grad, hess, want_hessian)
    else:
        edge_edge_distance_derivatives(p, grad, hess)
    E, dE, d2E = imc_energy_derivatives(delta, d, tol)
    if want_hessian:
        for k in range(12):
            gk = d2E * grad[k]
            for l in range(k, 12):
                h = dE * hess[k, l] + gk * grad[l]
                hess[k, l] = h
                hess[l, k] = h
    for k in range(12):
        grad[k] *= dE
    return E, delta, bi, bj, case
