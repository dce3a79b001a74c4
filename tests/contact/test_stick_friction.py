"""The elastic-stick law at the rods' surfaces (docs/physics.md §3.6): the pair kernel
:func:`surface_friction_pair` with ``kappa > 0`` against a plain-numpy reference, its Jacobian
against finite differences while the spring holds and while it slides, the law's functions, and
the contact's spring history (:class:`knotsim.contact.stick.StickHistory`)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from knotsim.contact.friction import stick_functions, stick_potential

from .reference_kernels import ref_stick_friction
from .test_surface_friction import JAC_RTOL, evaluate, jac_fd_error, random_pair, stable


def stick_pair(rng, regime, disp=1e-3, spin=1e-2):
    """A random pair whose spring, at the iterate, is well inside its limit (``"stick"``: κ|ξ| = 0.3 μ_L)
    or well beyond it (``"slide"``: 3 μ_L); ``ξ0`` random in the tangent plane."""
    mu_limit = 0.4
    while True:
        z, pair = random_pair(rng, disp, spin)
        if not stable(z, pair):
            continue
        res = evaluate(z, pair)
        s = np.asarray(res.fc[:3] + res.fc[3:6])
        if not np.linalg.norm(s) > 0.0:
            continue
        n = s / np.linalg.norm(s)
        xi0 = (np.eye(3) - np.outer(n, n)) @ rng.normal(size=3) * disp
        probe = dataclasses.replace(pair, xi0=tuple(xi0), mu_limit=mu_limit, kappa=1e-12)
        xi_len = np.linalg.norm(evaluate(z, probe).record[0:3]) * pair.dt  # the record holds ξ/dt
        if xi_len == 0.0:
            continue
        factor = 0.3 if regime == "stick" else 3.0
        return z, dataclasses.replace(probe, kappa=factor * mu_limit / xi_len)


@pytest.mark.parametrize("regime", ["stick", "slide"])
def test_matches_reference(regime):
    rng = np.random.default_rng(21)
    for _ in range(10):
        z, pair = stick_pair(rng, regime)
        res = evaluate(z, pair)
        ref = ref_stick_friction(z[:12], pair.z_prev[:12], z[12:], pair.z_prev[12:], pair.dt, pair.xi0,
                                 pair.mu_limit, pair.kappa, pair.ha, pair.hb, res.fc, res.beta_a, res.beta_b)
        np.testing.assert_allclose(res.Q, ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())


@pytest.mark.parametrize("regime", ["stick", "slide"])
def test_jacobian_against_finite_differences(regime):
    rng = np.random.default_rng(22 if regime == "stick" else 23)
    for _ in range(10):
        z, pair = stick_pair(rng, regime)
        assert jac_fd_error(z, pair) <= JAC_RTOL


def test_zero_slip_spring_holds():
    """No motion over the step: the force is the start spring's, ``−κ F_n ξ0`` (no creep term)."""
    rng = np.random.default_rng(24)
    z, pair = stick_pair(rng, "stick")
    still = dataclasses.replace(pair, z_prev=z.copy())
    res = evaluate(z, still)
    ref = ref_stick_friction(z[:12], z[:12], z[12:], z[12:], pair.dt, pair.xi0, pair.mu_limit, pair.kappa,
                             pair.ha, pair.hb, res.fc, res.beta_a, res.beta_b)
    assert np.abs(res.Q).max() > 0.0
    np.testing.assert_allclose(res.Q, ref, rtol=1e-12, atol=1e-15 * np.abs(ref).max())
    assert jac_fd_error(z, still) <= JAC_RTOL


@pytest.mark.parametrize("r", [0.0, 1e-6, 0.5, 0.999, 1.0, 1.001, 3.0])
def test_law_functions(r):
    mu_l, kappa = 0.4, 0.4  # limit at r = 1
    phi, psi = stick_functions(r, mu_l, kappa)
    if r <= 1.0:
        assert (phi, psi) == (kappa, 0.0)
        assert stick_potential(r, mu_l, kappa) == pytest.approx(0.5 * kappa * r * r, rel=1e-15, abs=0)
    else:
        assert phi == pytest.approx(mu_l / r) and psi == pytest.approx(-mu_l / r**3)
    h = 1e-7
    if r > h and abs(r - 1.0) > 10 * h:  # H' = φ r, away from the kink of H''
        dh = (stick_potential(r + h, mu_l, kappa) - stick_potential(r - h, mu_l, kappa)) / (2 * h)
        assert dh == pytest.approx(phi * r, rel=1e-7)
    # continuous through the limit
    assert stick_potential(1.0 + 1e-12, mu_l, kappa) == pytest.approx(stick_potential(1.0, mu_l, kappa), rel=1e-10)
