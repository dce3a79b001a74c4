"""Numba kernels of the contact interaction: the loop over candidate edge pairs.

Every pair ``k`` is described by the 12 indices ``pair_dofs[k]`` in the global vector ``q`` of the
coordinates of its four nodes ``x0, x1`` (edge i) and ``x2, x3`` (edge j), its contact distance
``pair_d[k] = h_a + h_b`` (m) and its friction coefficient ``pair_mu[k]``. The kernels loop over the
pairs with per-pair scratch arrays allocated once per call (no Python loop, no per-pair allocation).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from knotsim.contact.distance import (
    edge_edge_beta_gradients,
    edge_edge_distance,
)
from knotsim.contact.friction import friction_pair
from knotsim.contact.potential import pair_energy
from knotsim.contact.regularized_distance import regularized_beta_gradients
from knotsim.contact.surface_friction import RECORD_SIZE, surface_friction_pair

#: Columns of ``pair_surface``: slip and rolling speed, the two edge-angle torques, the pair's record.
SURFACE_COLUMNS = 4 + RECORD_SIZE
#: Columns of a pair's memo (``pair_memo`` of :func:`contact_evaluate`): kept, E, Δ, β_i, β_j, case,
#: d, δ, η.
MEMO_COLUMNS = 9


@njit(cache=True)
def pair_dofs_from_edges(pairs, edge_dofs):
    """The 12 coordinate indices of every edge pair.

    Parameters
    ----------
    pairs : (k, 2) int64, edge numbers ``(a, b)``.
    edge_dofs : (n_edges, 2) int64, index in ``q`` of the x coordinate of each end node.

    Returns
    -------
    (k, 12) int64: ``x0, x1`` of edge ``a`` then ``x2, x3`` of edge ``b``, 3 coordinates each.
    """
    k = pairs.shape[0]
    out = np.empty((k, 12), dtype=np.int64)
    for p in range(k):
        a = pairs[p, 0]
        b = pairs[p, 1]
        for m in range(3):
            out[p, m] = edge_dofs[a, 0] + m
            out[p, 3 + m] = edge_dofs[a, 1] + m
            out[p, 6 + m] = edge_dofs[b, 0] + m
            out[p, 9 + m] = edge_dofs[b, 1] + m
    return out


@njit(cache=True)
def contact_evaluate_regularized(q, q_prev, dt, pair_dofs, pair_d, pair_mu, tol, nu, kc, residual,
                                 want_jacobian, blocks, block_slot, pair_delta, pair_fc, pair_ff, pair_eta,
                                 pair_theta, pair_h, pair_surface, pair_xi0, pair_mu_limit, stick_distance,
                                 pair_memo, pair_memo_p, pair_memo_grad, pair_memo_hess, pair_memo_beta):
    """:func:`contact_evaluate` with the regularized distance (every ``pair_eta > 0``), centre-line
    friction."""
    return contact_evaluate(q, q_prev, dt, pair_dofs, pair_d, pair_mu, tol, nu, kc, residual, want_jacobian,
                            blocks, block_slot, pair_delta, pair_fc, pair_ff, pair_eta, True, False,
                            pair_theta, pair_h, pair_surface, pair_xi0, pair_mu_limit, stick_distance,
                            pair_memo, pair_memo_p, pair_memo_grad, pair_memo_hess, pair_memo_beta)


@njit(cache=True)
def contact_evaluate_exact(q, q_prev, dt, pair_dofs, pair_d, pair_mu, tol, nu, kc, residual,
                           want_jacobian, blocks, block_slot, pair_delta, pair_fc, pair_ff, pair_eta,
                           pair_theta, pair_h, pair_surface, pair_xi0, pair_mu_limit, stick_distance,
                           pair_memo, pair_memo_p, pair_memo_grad, pair_memo_hess, pair_memo_beta):
    """:func:`contact_evaluate` with the exact segment distance (``pair_eta`` unused), centre-line
    friction."""
    return contact_evaluate(q, q_prev, dt, pair_dofs, pair_d, pair_mu, tol, nu, kc, residual, want_jacobian,
                            blocks, block_slot, pair_delta, pair_fc, pair_ff, pair_eta, False, False,
                            pair_theta, pair_h, pair_surface, pair_xi0, pair_mu_limit, stick_distance,
                            pair_memo, pair_memo_p, pair_memo_grad, pair_memo_hess, pair_memo_beta)


@njit(cache=True)
def contact_evaluate_regularized_surface(q, q_prev, dt, pair_dofs, pair_d, pair_mu, tol, nu, kc, residual,
                                         want_jacobian, blocks, block_slot, pair_delta, pair_fc, pair_ff, pair_eta,
                                         pair_theta, pair_h, pair_surface, pair_xi0, pair_mu_limit, stick_distance,
                                         pair_memo, pair_memo_p, pair_memo_grad, pair_memo_hess, pair_memo_beta):
    """:func:`contact_evaluate` with the regularized distance and friction at the rods' surfaces."""
    return contact_evaluate(q, q_prev, dt, pair_dofs, pair_d, pair_mu, tol, nu, kc, residual, want_jacobian,
                            blocks, block_slot, pair_delta, pair_fc, pair_ff, pair_eta, True, True,
                            pair_theta, pair_h, pair_surface, pair_xi0, pair_mu_limit, stick_distance,
                            pair_memo, pair_memo_p, pair_memo_grad, pair_memo_hess, pair_memo_beta)


@njit(cache=True)
def contact_evaluate_exact_surface(q, q_prev, dt, pair_dofs, pair_d, pair_mu, tol, nu, kc, residual,
                                   want_jacobian, blocks, block_slot, pair_delta, pair_fc, pair_ff, pair_eta,
                                   pair_theta, pair_h, pair_surface, pair_xi0, pair_mu_limit, stick_distance,
                                   pair_memo, pair_memo_p, pair_memo_grad, pair_memo_hess, pair_memo_beta):
    """:func:`contact_evaluate` with the exact segment distance and friction at the rods' surfaces."""
    return contact_evaluate(q, q_prev, dt, pair_dofs, pair_d, pair_mu, tol, nu, kc, residual, want_jacobian,
                            blocks, block_slot, pair_delta, pair_fc, pair_ff, pair_eta, False, True,
                            pair_theta, pair_h, pair_surface, pair_xi0, pair_mu_limit, stick_distance,
                            pair_memo, pair_memo_p, pair_memo_grad, pair_memo_hess, pair_memo_beta)


@njit(inline="always", cache=True)
def contact_evaluate(q, q_prev, dt, pair_dofs, pair_d, pair_mu, tol, nu, kc, residual, want_jacobian,
                     blocks, block_slot, pair_delta, pair_fc, pair_ff, pair_eta, regularized, surface,
                     pair_theta, pair_h, pair_surface, pair_xi0, pair_mu_limit, stick_distance,
                     pair_memo, pair_memo_p, pair_memo_grad, pair_memo_hess, pair_memo_beta):
    """Contact and friction of every candidate pair at the Newton iterate ``q``.

    Called through :func:`contact_evaluate_regularized`, :func:`contact_evaluate_exact` and their
    ``_surface`` twins, which inline it with literal ``regularized`` and ``surface``: a run compiles
    the loop of the distance and friction law it uses only.

    Parameters
    ----------
    q, q_prev : (n_dofs,) float64, iterate and start-of-step unknowns (m, rad).
    dt : time step (s); friction uses the velocities ``(q - q_prev)/dt``.
    pair_dofs : (k, 12) int64; pair_d : (k,) float64 contact distances (m); pair_mu : (k,) float64.
    tol : IMC distance tolerance δ (m); nu : slip tolerance ν (m/s); kc : contact stiffness (N/m).
    residual : (n_dofs,) float64, updated in place: ``+= k_c ∇E − F_fr`` (N).
    want_jacobian : whether to fill ``blocks``.
    blocks : (b, w, w) float64 output (if ``want_jacobian``): ``k_c ∇²E − ∂F_fr/∂p`` (N/m) of the
        pairs that have a Jacobian block, pair ``k`` in ``blocks[block_slot[k]]``; zero for pairs out
        of range. ``w = 12`` (the four nodes' coordinates) with centre-line friction, ``w = 14`` (then
        the two edge angles ``pair_theta[k]`` follow) with surface friction.
    block_slot : (k,) int64, the block of every pair, −1 for a pair without one.
    pair_delta : (k,) float64 output, distance Δ (m) of every pair.
    pair_fc, pair_ff : (k, 12) float64 outputs, contact force ``−k_c ∇E`` and friction force (N) on
        the four nodes of every pair.
    pair_eta : (k,) float64, parallel-edge regularization η > 0 of every pair's distance, see
        :mod:`knotsim.contact.regularized_distance` (unused with the exact distance).
    regularized : bool, ``True``: the regularized distance; ``False``: the exact segment distance.
    surface : bool, ``True``: friction at the rods' surfaces (:mod:`knotsim.contact.surface_friction`,
        forces on the edge angles too); ``False``: centre-line friction (:mod:`knotsim.contact.friction`).
    pair_theta : (k, 2) int64, index in ``q`` of the angles of the pair's edges (used if ``surface``).
    pair_h : (k, 2) float64, radii of the pair's edges (m; used if ``surface``).
    pair_surface : (k, SURFACE_COLUMNS) float64 output (written if ``surface``): slip speed and rolling
        speed (m/s) of every pair in range with friction (see
        :func:`~knotsim.contact.surface_friction.surface_friction_pair`), the friction torques on its two
        edge angles (N m) and its record (columns 4 on: the law in the edge angles alone, for
        :func:`~knotsim.contact.surface_friction.spin_friction_terms`, and the normal); zero for the others.
    pair_xi0 : (k, 3) float64, each pair's tangential spring displacement at the start of the step (m),
        pair_mu_limit : (k,) float64 its limit coefficient (μ_s sticking, μ_k sliding), and
        stick_distance : δ_s (m) of the elastic-stick law (docs/physics.md §3.6), ``κ = μ/δ_s``; 0: the
        smooth law of ``nu`` (``pair_xi0``, ``pair_mu_limit`` unused). Surface friction only.
    pair_memo (b, MEMO_COLUMNS), pair_memo_p (b, 12), pair_memo_grad (b, 12), pair_memo_hess (b, 12, 12),
        pair_memo_beta (b, 2, 12) float64, one row per block (``b`` as ``blocks``; zero rows: no memo):
        with surface friction, what a Jacobian evaluation computed of the distance and potential of
        each pair with a block, kept for the next one. A pair whose coordinates (``pair_memo_p``),
        contact distance, δ and η are those kept (as after the stepper's spin relaxation, which turns
        edge angles only) takes its distance, contact ratios, the potential's gradient and Hessian and
        the ratios' gradients from there instead of computing them again: the results are the same,
        bit for bit. Columns of ``pair_memo``: kept (0: no, 1: yes, 2: with the ratios' gradients),
        ``E``, ``Δ``, ``β_i``, ``β_j``, the distance's case, ``d``, δ, η.

    Returns
    -------
    ``(energy, missing)``: the total contact energy ``k_c Σ E`` (J) and, with ``want_jacobian``, the
    number of pairs within range (``Δ < d + δ``) that have no block (their Jacobian is not stored:
    the caller gives them blocks and evaluates again).
    """
    npair = pair_dofs.shape[0]
    p = np.empty(12)
    pp = np.empty(12)
    grad = np.empty(12)
    hess = np.empty((12, 12))
    if surface and (pair_surface.shape[0] != npair or pair_surface.shape[1] != SURFACE_COLUMNS):
        raise ValueError("pair_surface must be a (k, SURFACE_COLUMNS) array")
    if surface and stick_distance > 0.0 and (pair_xi0.shape[0] != npair or pair_mu_limit.shape[0] != npair):
        raise ValueError("pair_xi0 and pair_mu_limit must have one row per pair")
    fc = np.empty(12)
    dfc = np.empty((12, 12))
    dbi = np.empty(12)
    dbj = np.empty(12)
    ffr = np.empty(12)
    jfr = np.empty((12, 12))
    fsu = np.empty(14)
    jsu = np.empty((14, 14))
    spin = np.empty(RECORD_SIZE)
    xi = np.zeros(3)
    th = np.empty(2)
    thp = np.empty(2)
    nb = blocks.shape[1]
    etot = 0.0
    missing = 0
    memo = surface and want_jacobian and pair_memo.shape[0] == blocks.shape[0]
    p_scratch = p
    grad_scratch = grad
    hess_scratch = hess
    dbi_scratch = dbi
    dbj_scratch = dbj
    for k in range(npair):
        slot = block_slot[k]
        row = slot if memo else -1  # the pair's memo row: that of its block
        if row >= 0:  # the pair's distance and potential are worked in (and kept in) its memo row
            p = pair_memo_p[row]
            grad = pair_memo_grad[row]
            hess = pair_memo_hess[row]
            dbi = pair_memo_beta[row, 0]
            dbj = pair_memo_beta[row, 1]
        else:
            p = p_scratch
            grad = grad_scratch
            hess = hess_scratch
            dbi = dbi_scratch
            dbj = dbj_scratch
        eta = pair_eta[k]
        kept = 0.0
        if row >= 0:
            kept = pair_memo[row, 0]
            if not (pair_memo[row, 6] == pair_d[k] and pair_memo[row, 7] == tol and pair_memo[row, 8] == eta):
                kept = 0.0
            for m in range(12):
                v = q[pair_dofs[k, m]]
                if p[m] != v:
                    kept = 0.0
                    p[m] = v
        else:
            for m in range(12):
                p[m] = q[pair_dofs[k, m]]
        if kept > 0.0:
            E = pair_memo[row, 1]
            delta = pair_memo[row, 2]
            bi = pair_memo[row, 3]
            bj = pair_memo[row, 4]
            case = int(pair_memo[row, 5])
        else:
            E, delta, bi, bj, case = pair_energy(p, pair_d[k], tol, grad, hess, eta, regularized, want_jacobian)
            if row >= 0:
                pair_memo[row, 0] = 1.0
                pair_memo[row, 1] = E
                pair_memo[row, 2] = delta
                pair_memo[row, 3] = bi
                pair_memo[row, 4] = bj
                pair_memo[row, 5] = case
                pair_memo[row, 6] = pair_d[k]
                pair_memo[row, 7] = tol
                pair_memo[row, 8] = eta
        pair_delta[k] = delta
        if surface:
            for m in range(SURFACE_COLUMNS):
                pair_surface[k, m] = 0.0
        if E <= 0.0:
            for m in range(12):
                pair_fc[k, m] = 0.0
                pair_ff[k, m] = 0.0
            if want_jacobian and slot >= 0:
                for m in range(nb):
                    for n in range(nb):
                        blocks[slot, m, n] = 0.0
            continue
        if want_jacobian and slot < 0:
            missing += 1
        etot += E
        for m in range(12):
            g = kc * grad[m]
            fc[m] = -g
            pair_fc[k, m] = -g
            residual[pair_dofs[k, m]] += g
        mu = pair_mu[k]
        if mu > 0.0:
            for m in range(12):
                pp[m] = q_prev[pair_dofs[k, m]]
            if want_jacobian:
                for m in range(12):
                    for n in range(12):
                        dfc[m, n] = -kc * hess[m, n]
                if kept < 2.0:
                    if regularized:
                        regularized_beta_gradients(p, eta, bi, bj, case, dbi, dbj)
                    else:
                        edge_edge_beta_gradients(p, bi, bj, case, dbi, dbj)
                    if row >= 0:
                        pair_memo[row, 0] = 2.0
            if surface:
                ta = pair_theta[k, 0]
                tb = pair_theta[k, 1]
                th[0] = q[ta]
                th[1] = q[tb]
                thp[0] = q_prev[ta]
                thp[1] = q_prev[tb]
                kappa = 0.0
                mu_lim = 0.0
                if stick_distance > 0.0:
                    kappa = mu / stick_distance
                    mu_lim = pair_mu_limit[k]
                    for m in range(3):
                        xi[m] = pair_xi0[k, m]
                slip, rolling = surface_friction_pair(p, pp, th, thp, dt, mu, nu, pair_h[k, 0], pair_h[k, 1], fc,
                                                      dfc, bi, bj, dbi, dbj, xi, mu_lim, kappa, fsu, jsu, spin,
                                                      want_jacobian)
                pair_surface[k, 0] = slip
                pair_surface[k, 1] = rolling
                pair_surface[k, 2] = fsu[12]
                pair_surface[k, 3] = fsu[13]
                for m in range(RECORD_SIZE):
                    pair_surface[k, 4 + m] = spin[m]
                for m in range(12):
                    pair_ff[k, m] = fsu[m]
                    residual[pair_dofs[k, m]] -= fsu[m]
                residual[ta] -= fsu[12]
                residual[tb] -= fsu[13]
                if want_jacobian and slot >= 0:
                    for m in range(14):
                        for n in range(14):
                            if m < 12 and n < 12:
                                blocks[slot, m, n] = kc * hess[m, n] - jsu[m, n]
                            else:
                                blocks[slot, m, n] = -jsu[m, n]
            else:
                friction_pair(p, pp, dt, mu, nu, fc, dfc, bi, bj, dbi, dbj, ffr, jfr, want_jacobian)
                for m in range(12):
                    pair_ff[k, m] = ffr[m]
                    residual[pair_dofs[k, m]] -= ffr[m]
                if want_jacobian and slot >= 0:
                    for m in range(12):
                        for n in range(12):
                            blocks[slot, m, n] = kc * hess[m, n] - jfr[m, n]
        else:
            for m in range(12):
                pair_ff[k, m] = 0.0
            if want_jacobian and slot >= 0:
                for m in range(nb):
                    for n in range(nb):
                        blocks[slot, m, n] = 0.0
                for m in range(12):
                    for n in range(12):
                        blocks[slot, m, n] = kc * hess[m, n]
    return kc * etot, missing


@njit(cache=True)
def pair_distances(q, pair_dofs, out):
    """Distance Δ (m) of every pair at ``q`` into ``out`` (k,)."""
    p = np.empty(12)
    for k in range(pair_dofs.shape[0]):
        for m in range(12):
            p[m] = q[pair_dofs[k, m]]
        delta, _, _, _ = edge_edge_distance(p)
        out[k] = delta


@njit(cache=True)
def first_side_flip(q_start, q_end, pair_dofs, reach):
    """First pair whose edges changed sides during a step: a rope passing through another.

    For every pair closer than ``reach[k]`` (m) at the start or the end of the step, the vector
    between the closest points (edge j to edge i, exact segment distance) at ``q_start`` and at
    ``q_end`` is compared; if it turned by more than 90° (negative dot product) the edges swapped
    sides. Without a pass-through that needs a relative motion of about the distance between the
    edges within one step, itself a step too large to trust.

    Returns ``(k, cos)``: the pair index (−1 if none) and the cosine of the turning angle.
    """
    p = np.empty(12)
    for k in range(pair_dofs.shape[0]):
        for m in range(12):
            p[m] = q_start[pair_dofs[k, m]]
        d0, bi0, bj0, _ = edge_edge_distance(p)
        v0x = (1.0 - bi0) * p[0] + bi0 * p[3] - (1.0 - bj0) * p[6] - bj0 * p[9]
        v0y = (1.0 - bi0) * p[1] + bi0 * p[4] - (1.0 - bj0) * p[7] - bj0 * p[10]
        v0z = (1.0 - bi0) * p[2] + bi0 * p[5] - (1.0 - bj0) * p[8] - bj0 * p[11]
        for m in range(12):
            p[m] = q_end[pair_dofs[k, m]]
        d1, bi1, bj1, _ = edge_edge_distance(p)
        if d0 >= reach[k] and d1 >= reach[k]:
            continue
        if not (d0 > 0.0 and d1 > 0.0):
            continue
        v1x = (1.0 - bi1) * p[0] + bi1 * p[3] - (1.0 - bj1) * p[6] - bj1 * p[9]
        v1y = (1.0 - bi1) * p[1] + bi1 * p[4] - (1.0 - bj1) * p[7] - bj1 * p[10]
        v1z = (1.0 - bi1) * p[2] + bi1 * p[5] - (1.0 - bj1) * p[8] - bj1 * p[11]
        c = (v0x * v1x + v0y * v1y + v0z * v1z) / (d0 * d1)
        if c < 0.0:
            return k, c
    return -1, 1.0


@njit(cache=True)
def approach_forces(q, v, dt, pair_dofs, pair_d, tol, node_mass):
    """Largest force needed to stop an approaching pair within one step (N).

    For each pair whose distance at ``q`` minus its approach over ``dt`` falls below ``d + δ``, the
    approach speed ``−dΔ/dt = −∇Δ · v`` (m/s) times the mean mass of its four nodes (kg), divided by
    ``dt`` (s). ``node_mass`` is indexed like ``q`` (kg per position unknown).
    """
    p = np.empty(12)
    fmax = 0.0
    for k in range(pair_dofs.shape[0]):
        for m in range(12):
            p[m] = q[pair_dofs[k, m]]
        delta, bi, bj, _ = edge_edge_distance(p)
        if not delta > 0.0:
            continue
        # dΔ/dt = n . (v_i(β_i) - v_j(β_j)), n the unit vector between the closest points (the
        # β derivatives drop out: the closest points minimise the distance)
        rate = 0.0
        for c in range(3):
            xi = (1.0 - bi) * p[c] + bi * p[3 + c]
            xj = (1.0 - bj) * p[6 + c] + bj * p[9 + c]
            vi = (1.0 - bi) * v[pair_dofs[k, c]] + bi * v[pair_dofs[k, 3 + c]]
            vj = (1.0 - bj) * v[pair_dofs[k, 6 + c]] + bj * v[pair_dofs[k, 9 + c]]
            rate += (xi - xj) * (vi - vj)
        rate /= delta
        if rate >= 0.0:
            continue
        if delta + rate * dt >= pair_d[k] + tol:
            continue
        mass = 0.25 * (node_mass[pair_dofs[k, 0]] + node_mass[pair_dofs[k, 3]]
                       + node_mass[pair_dofs[k, 6]] + node_mass[pair_dofs[k, 9]])
        f = -rate * mass / dt
        if f > fmax:
            fmax = f
    return fmax


@njit(cache=True)
def nodal_force_summary(pair_dofs, pair_fc, pair_ff, node_dof, n_dofs):
    """Per-node totals of the pairs' contact and friction forces.

    Parameters
    ----------
    pair_dofs : (k, 12) int64; pair_fc, pair_ff : (k, 12) float64 contact and friction forces (N)
        on the pairs' coordinates; node_dof : (n_nodes,) int64 index of each node's x in ``q``.

    Returns
    -------
    ``(largest nodal contact force magnitude, half the sum of nodal contact force magnitudes,
    half the sum of nodal friction force magnitudes)``, N.
    """
    fc = np.zeros(n_dofs)
    ff = np.zeros(n_dofs)
    for k in range(pair_dofs.shape[0]):
        for m in range(12):
            fc[pair_dofs[k, m]] += pair_fc[k, m]
            ff[pair_dofs[k, m]] += pair_ff[k, m]
    fmax = 0.0
    fc_tot = 0.0
    ff_tot = 0.0
    for i in range(node_dof.shape[0]):
        a = node_dof[i]
        c = np.sqrt(fc[a] * fc[a] + fc[a + 1] * fc[a + 1] + fc[a + 2] * fc[a + 2])
        f = np.sqrt(ff[a] * ff[a] + ff[a + 1] * ff[a + 1] + ff[a + 2] * ff[a + 2])
        fc_tot += c
        ff_tot += f
        if c > fmax:
            fmax = c
    return fmax, 0.5 * fc_tot, 0.5 * ff_tot
