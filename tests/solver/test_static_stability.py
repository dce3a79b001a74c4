"""solve_static knows stability: a pinned-pinned column (P_cr = π²EI/L²) is stable below its
buckling load; at 1.01 and 1.2 P_cr the straight equilibrium is reported unstable (warning,
``stable=False``, or an error); perturbed, the solve finds the buckled branch, compared with the
inextensible elastica (end shortening and mid-span deflection, 1 %); the lowest eigenvalue against a
dense NumPy eigen-solve of a finite-difference Hessian."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk

import knotsim as ks
from knotsim.errors import SimulationError
from knotsim.solver.static import UnstableEquilibriumWarning, hessian, lowest_mode
from knotsim.solver.stepper import Stepper, _StepSystem

L, N, H, E = 0.5, 51, 1e-3, 1e7
P_CR = np.pi**2 * E * np.pi * H**4 / 4 / L**2


def column(P):
    x = np.zeros((N, 3))
    x[:, 0] = np.linspace(0.0, L, N)
    m = ks.Model([ks.RodSpec(x, radius=H, youngs_modulus=E, density=1000.0)])
    bcs = ks.BoundaryConditions(m)
    bcs.pin("left", nodes=[0], twist=True)
    bcs.pin("right", nodes=[-1], axes="yz")
    bcs.force("P", nodes=[-1], force=[-P, 0, 0])
    return m, bcs


@pytest.mark.parametrize("ratio", [0.9, 0.99])
def test_below_the_buckling_load_is_stable(ratio):
    m, bcs = column(ratio * P_CR)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = ks.solve_static(m, bcs)
    assert res.stable is True and res.lowest_eigenvalue > 0


@pytest.mark.parametrize("ratio", [1.01, 1.2])
def test_past_the_buckling_load_warns_and_reports_unstable(ratio):
    m, bcs = column(ratio * P_CR)
    with pytest.warns(UnstableEquilibriumWarning, match="unstable"):
        res = ks.solve_static(m, bcs)
    assert res.stable is False and res.lowest_eigenvalue < 0
    # the straight shape was returned
    assert np.max(np.abs(m.node_positions(res.state.q)[:, 1:])) <= 1e-12
    with pytest.raises(SimulationError, match="unstable"):
        ks.solve_static(m, bcs, on_unstable="raise")
    unchecked = ks.solve_static(m, bcs, check_stability=False)
    assert unchecked.stable is None and unchecked.lowest_eigenvalue is None


def test_perturbed_solve_finds_the_buckled_branch():
    ratio = 1.2
    m, bcs = column(ratio * P_CR)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = ks.solve_static(m, bcs, on_unstable="perturb")
    assert res.stable is True and res.perturbations == 1
    x = m.node_positions(res.state.q)
    # inextensible elastica: P/P_cr = (2K(k²)/π)², deflection 2kL/(π√(P/P_cr)), span L(2E/K − 1)
    mm = brentq(lambda v: 2 * ellipk(v) / np.pi - np.sqrt(ratio), 1e-9, 0.99)
    w_ref = 2 * np.sqrt(mm) * L / (np.pi * np.sqrt(ratio))
    span_ref = L * (2 * ellipe(mm) / ellipk(mm) - 1)
    w = np.max(np.hypot(x[:, 1], x[:, 2]))
    assert w == pytest.approx(w_ref, rel=0.01)
    assert x[-1, 0] == pytest.approx(span_ref, rel=0.01)


def test_lowest_eigenvalue_against_dense_fd_hessian():
    """The assembled static Hessian equals central differences of the static residual, and the
    reported eigenvalue is the lowest of its Jacobi-scaled free block (NumPy dense)."""
    m, bcs = column(1.2 * P_CR)
    rng = np.random.default_rng(1)
    from knotsim.solver.state import initial_state

    st = initial_state(m)
    st.q = st.q + rng.normal(0, 1e-4, st.q.shape)
    stepper = Stepper(m)
    fixed_dofs, _, f_bc = bcs.evaluate(0.0, st.q, 0.0)
    fixed = np.zeros(m.n_dofs, np.bool_)
    fixed[fixed_dofs] = True
    system = _StepSystem(stepper, st, 1.0, fixed, f_bc, static=True)
    K = hessian(stepper, system, st.q).toarray()
    h = 1e-7
    Kf = np.zeros_like(K)
    for k in range(m.n_dofs):
        dq = np.zeros(m.n_dofs)
        dq[k] = h
        system.residual(st.q + dq, False)
        rp = system.last_full_residual.copy()
        system.residual(st.q - dq, False)
        rm = system.last_full_residual.copy()
        Kf[:, k] = (rp - rm) / (2 * h)
    assert np.max(np.abs(Kf - K)) <= 1e-5 * np.max(np.abs(K))
    lam, mode = lowest_mode(stepper, system, st.q, fixed)
    free = ~fixed
    A = 0.5 * (K + K.T)[np.ix_(free, free)]
    d = 1 / np.sqrt(np.abs(np.diag(A)))
    ref = np.linalg.eigvalsh(d[:, None] * A * d[None, :])[0]
    assert lam == pytest.approx(ref, rel=1e-8, abs=1e-14)
    assert not np.any(mode[fixed])


def test_sparse_path_agrees_with_dense(monkeypatch):
    """Above DENSE_LIMIT the shift-invert Lanczos path gives the dense path's eigenvalue."""
    import knotsim.solver.static as static

    m, bcs = column(1.01 * P_CR)
    with pytest.warns(UnstableEquilibriumWarning):
        dense = ks.solve_static(m, bcs)
    monkeypatch.setattr(static, "DENSE_LIMIT", 10)
    with pytest.warns(UnstableEquilibriumWarning):
        sparse = ks.solve_static(m, bcs)
    assert sparse.lowest_eigenvalue == pytest.approx(dense.lowest_eigenvalue, rel=1e-6)
