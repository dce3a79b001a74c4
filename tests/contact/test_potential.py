"""IMC contact potential: values against a 50-digit reference, derivatives against FD.

Tolerances:

* ``E``, ``E'``, ``E''`` against the mpmath reference: relative ``1e-12`` (absolute floor stated in
  each test where the value is tiny);
* ``E'`` and ``E''`` by central differences of ``E`` and ``E''`` in Δ, step ``1e-5·δ``:
  relative ``1e-6``;
* pair kernel ``∇_p E`` and ``∇²_p E`` by central differences in p (step ``1e-6``, coordinates of
  order 1, δ = 0.05): ``|FD − analytic|∞ <= 1e-6 · max(|analytic|∞, 1e-3 δ)``, only where the
  distance case and the energy branch (Δ on one side of d + δ) are the same at all p ± h e_m.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from knotsim.contact.distance import N_CASES, edge_edge_distance, edge_edge_distance_derivatives
from knotsim.contact.potential import (
    CUTOFF_ENERGY_JUMP_OVER_TOL2,
    contact_pair_energy,
    imc_energy,
    imc_energy_derivatives,
)

from .reference_kernels import ref_imc_energy, ref_imc_energy_derivatives, ref_imc_energy_report_eq5

TOL = 5e-4  # δ (m), the reference-code default
D = 3.2e-3  # d = 2h for h = 1.6 mm


def rel_err(a, b, floor=0.0):
    return abs(a - b) / max(abs(b), floor, 1e-300)


@pytest.mark.parametrize(
    "x", np.concatenate([np.linspace(-3, 1.2, 85), [-1.0, 1.0, 0.999999, -1.000001, 0.0]])
)
def test_energy_matches_mpmath(x):
    """Δ = d + x δ over the whole range, including both branch points."""
    delta = D + x * TOL
    E, dE, d2E = imc_energy_derivatives(delta, D, TOL)
    assert E == imc_energy(delta, D, TOL)
    if x >= 1.0:
        assert (E, dE, d2E) == (0.0, 0.0, 0.0)
        return
    Er, dEr, d2Er = ref_imc_energy_derivatives(delta, D, TOL)
    assert rel_err(E, Er) <= 1e-12
    assert rel_err(dE, dEr) <= 1e-12
    assert rel_err(d2E, d2Er) <= 1e-11
    assert rel_err(E, ref_imc_energy(delta, D, TOL)) <= 1e-12


@pytest.mark.parametrize("x", [-2.5, -1.0 - 1e-3, -1.0, -1.0 + 1e-3, -0.5, 0.0, 0.5, 0.99])
def test_energy_derivatives_fd(x):
    """Central FD in Δ (step 1e-5 δ), including straddling Δ = d − δ: the smooth branch is used
    on both sides, so FD is valid there."""
    delta = D + x * TOL
    h = 1e-5 * TOL
    E, dE, d2E = imc_energy_derivatives(delta, D, TOL)
    dE_fd = (imc_energy(delta + h, D, TOL) - imc_energy(delta - h, D, TOL)) / (2 * h)
    d2E_fd = (imc_energy_derivatives(delta + h, D, TOL)[1] - imc_energy_derivatives(delta - h, D, TOL)[1]) / (
        2 * h
    )
    assert rel_err(dE_fd, dE, floor=1e-9 * TOL) <= 1e-6
    assert rel_err(d2E_fd, d2E, floor=1e-9) <= 1e-6


def test_matches_report_quadratic_below_d_minus_delta():
    """Below d − δ the energy equals (d − Δ)² to 2 log1p(e^-15)/15 ≈ 4.1e-8 relative, and agrees
    with the report's literal eq. 5 to the same amount; in (d − δ, d + δ) eq. 5 is the same formula."""
    bound = 2 * math.log1p(math.exp(-15.0)) / 15.0
    assert 4.0e-8 < bound < 4.2e-8
    for x in np.linspace(-50, -1, 200):
        delta = D + x * TOL
        E = imc_energy(delta, D, TOL)
        assert rel_err(E, (D - delta) ** 2) <= bound * 1.0000001
        assert rel_err(E, ref_imc_energy_report_eq5(delta, D, TOL)) <= bound * 1.0000001
    for x in np.linspace(-0.999, 0.999, 50):
        delta = D + x * TOL
        # the literal log(1 + exp(z)) loses ~eps/exp(z) relative accuracy as z -> -15; the kernel's
        # log1p form is checked against mpmath to 1e-12 in test_energy_matches_mpmath
        assert rel_err(imc_energy(delta, D, TOL), ref_imc_energy_report_eq5(delta, D, TOL)) <= 1e-9


def test_cutoff_jump_is_documented_value_and_negligible():
    """Just below d + δ the energy is the documented jump value; it is 4.2e-16 of E(d − δ)."""
    below = np.nextafter(D + TOL, -np.inf)
    E, dE, d2E = imc_energy_derivatives(below, D, TOL)
    assert rel_err(E, CUTOFF_ENERGY_JUMP_OVER_TOL2 * TOL**2) <= 1e-6
    assert imc_energy(D + TOL, D, TOL) == 0.0
    E_contact = imc_energy(D - TOL, D, TOL)
    assert E / E_contact <= 5e-16
    # derivative jumps (documented): |E'| ~ 1.25e-14 δ, E'' ~ 3.7e-13
    assert abs(dE) <= 1.3e-14 * TOL
    assert abs(d2E) <= 3.8e-13
    _, dE_c, d2E_c = imc_energy_derivatives(D - TOL, D, TOL)
    assert abs(dE / dE_c) <= 1e-14 and abs(d2E / d2E_c) <= 1e-12


@pytest.mark.parametrize("tol", [1e-12, 1e-6, 5e-4, 1e-3])
def test_no_overflow_deep_penetration(tol):
    """Δ = 0 and Δ < 0 (deep penetration, K1 (d − Δ) up to 1e13): no overflow, E ≈ (d − Δ)²."""
    for delta in (0.0, -D, -1.0):
        E, dE, d2E = imc_energy_derivatives(delta, D, tol)
        assert all(math.isfinite(v) for v in (E, dE, d2E))
        assert rel_err(E, (D - delta) ** 2) <= 4.2e-8
        assert rel_err(dE, -2 * (D - delta)) <= 4.2e-8
        assert abs(d2E - 2.0) <= 1e-6
    # far outside
    assert imc_energy_derivatives(1e300, D, tol) == (0.0, 0.0, 0.0)


def test_monotone_and_convex():
    xs = D + TOL * np.linspace(-5, 0.9999, 2001)
    vals = np.array([imc_energy_derivatives(x, D, TOL) for x in xs])
    assert np.all(vals[:, 0] > 0) and np.all(vals[:, 1] < 0) and np.all(vals[:, 2] > 0)
    assert np.all(np.diff(vals[:, 0]) < 0)


# ---------------------------------------------------------------------------------------------
# pair kernel


def pair(p, d, tol):
    g = np.zeros(12)
    h = np.zeros((12, 12))
    out = contact_pair_energy(np.asarray(p, dtype=float), d, tol, g, h)
    return out, g, h


def check_pair_fd(p, d, tol, h=1e-6, rtol=1e-6):
    (E, delta, bi, bj, case), g, hs = pair(p, d, tol)
    assert E == imc_energy(delta, d, tol)
    for m in range(12):
        for sgn in (1, -1):
            q = p.copy()
            q[m] += sgn * h
            dq = edge_edge_distance(q)
            if dq[3] != case or (dq[0] >= d + tol) != (delta >= d + tol):
                return False
    g_fd = np.array(
        [(pair(p + h * e, d, tol)[0][0] - pair(p - h * e, d, tol)[0][0]) / (2 * h) for e in np.eye(12)]
    )
    h_fd = np.column_stack(
        [(pair(p + h * e, d, tol)[1] - pair(p - h * e, d, tol)[1]) / (2 * h) for e in np.eye(12)]
    )
    assert np.abs(g_fd - g).max() <= rtol * max(np.abs(g).max(), 1e-3 * tol)
    assert np.abs(h_fd - hs).max() <= rtol * max(np.abs(hs).max(), 1e-3)
    # chain rule structure: ∇E = E' ∇Δ
    gd = np.zeros(12)
    hd = np.zeros((12, 12))
    edge_edge_distance_derivatives(p, gd, hd)
    _, dE, d2E = imc_energy_derivatives(delta, d, tol)
    assert np.allclose(g, dE * gd, rtol=1e-14, atol=0)
    assert np.array_equal(hs, hs.T)
    return True


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(st.integers(0, 2**32 - 1), st.floats(-2.0, 0.99))
def test_pair_energy_fd_hypothesis(seed, x):
    """Random pair, contact distance chosen so that Δ = d + x δ (penetration to just inside the
    cut-off)."""
    rng = np.random.default_rng(seed)
    p = rng.uniform(-1, 1, 12)
    tol = 0.05
    delta = edge_edge_distance(p)[0]
    assume(delta > 0.05)
    d = delta - x * tol
    assume(check_pair_fd(p, d, tol))


def test_pair_energy_fd_every_case():
    rng = np.random.default_rng(11)
    count = dict.fromkeys(range(N_CASES), 0)
    tol = 0.05
    for _ in range(5000):
        if min(count.values()) >= 5:
            break
        p = rng.uniform(-1, 1, 12)
        delta, _, _, case = edge_edge_distance(p)
        if count[case] >= 5 or delta < 0.05:
            continue
        d = delta - rng.uniform(-1.5, 0.95) * tol
        if check_pair_fd(p, d, tol):
            count[case] += 1
    assert min(count.values()) >= 5, count


def test_pair_energy_at_branch_points():
    """Δ exactly at d − δ (FD straddles the former branch join: valid, same formula) and just inside
    and at d + δ (at the cut-off itself everything is zero)."""
    p = np.array([-1.0, 0.1, 0, 1, -0.2, 0, 0.1, -1, 0.3, -0.2, 1, 0.3])
    delta = edge_edge_distance(p)[0]
    tol = 0.05
    assert check_pair_fd(p, delta + tol, tol)  # Δ = d − δ
    assert check_pair_fd(p, delta - tol + 1e-5, tol)  # just inside the cut-off
    (E, *_), g, h = pair(p, delta - tol, tol)  # Δ = d + δ: cut off
    assert E == 0.0 and not g.any() and not h.any()
    (E, *_), g, h = pair(p, delta - 2 * tol, tol)
    assert E == 0.0 and not g.any() and not h.any()


def test_pair_energy_outputs_overwritten():
    """The kernel overwrites (does not accumulate into) its outputs, also beyond the cut-off."""
    p = np.array([-1.0, 0.1, 0, 1, -0.2, 0, 0.1, -1, 0.3, -0.2, 1, 0.3])
    g = np.full(12, 7.0)
    h = np.full((12, 12), 7.0)
    contact_pair_energy(p, 0.01, 0.01, g, h)
    assert not g.any() and not h.any()
    contact_pair_energy(p, 0.3, 0.01, g, h)
    g2 = np.zeros(12)
    h2 = np.zeros((12, 12))
    contact_pair_energy(p, 0.3, 0.01, g2, h2)
    assert np.array_equal(g, g2) and np.array_equal(h, h2)


def test_pair_energy_touching_edges_finite():
    p = np.array([-1.0, 0, 0, 1, 0, 0, 0, -1, 0, 0, 1, 0])
    (E, delta, *_), g, h = pair(p, 0.01, 0.001)
    assert delta == 0.0 and math.isfinite(E) and np.all(np.isfinite(g)) and np.all(np.isfinite(h))
