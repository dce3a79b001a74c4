"""Obstacle kernels against slow NumPy references and finite differences.

* distance primitives: values against an obvious NumPy closest-point computation (and, for the
  capsule, dense sampling of the axis); gradient and Hessian by central differences, step
  ``H = 1e-6`` (coordinates of order 0.1-1), tolerance ``1e-6`` relative to the largest entry
  (floor 1e-6), including degenerate geometry: a node exactly on the end-cap boundary of a capsule
  (gradient central, Hessian one-sided from the cylinder side, as documented), a node on the axis
  line beyond the cap, a zero-length capsule (a sphere), a node in the plane;
* node contact force = ``−∂(k_c E)/∂x`` (central differences of the energy);
* Jacobian of contact + friction against central differences of the force, for fixed, moving and
  rotating obstacles, in slip and in stick (tiny slip, series branch of φ);
* ``obstacle_evaluate`` against a Python loop of ``node_contact`` (the assembly adds what the
  per-node kernel returns, at the right coordinates).
"""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.contact.obstacle_kernels import (
    CAPSULE,
    PLANE,
    SPHERE,
    node_capsule_distance,
    node_contact,
    node_distance,
    node_plane_distance,
    node_sphere_distance,
    obstacle_evaluate,
)
from knotsim.contact.potential import imc_energy

H = 1e-6
RTOL = 1e-6


def ref_capsule_distance(x, a, b):
    """Obvious closest point on a segment: project, clip."""
    ab = b - a
    L2 = ab @ ab
    t = 0.0 if L2 == 0 else float(np.clip((x - a) @ ab / L2, 0.0, 1.0))
    return float(np.linalg.norm(x - (a + t * ab))), t


def sampled_capsule_distance(x, a, b, n=200001):
    s = np.linspace(0.0, 1.0, n)[:, None]
    return float(np.min(np.linalg.norm(x[None, :] - (a + s * (b - a)), axis=1)))


def dist(kind, x, geom):
    g = np.zeros(3)
    Hm = np.zeros((3, 3))
    d, R = node_distance(kind, np.asarray(x, float), geom, g, Hm)
    return d, g.copy(), Hm.copy()


def fd_grad_hess(kind, x, geom, one_sided=None):
    """Central differences of Δ (gradient) and of the analytic gradient (Hessian); ``one_sided``:
    a direction sign per coordinate for a forward/backward difference of the gradient."""
    g = np.zeros(3)
    Hm = np.zeros((3, 3))
    for m in range(3):
        e = np.zeros(3)
        e[m] = H
        dp = dist(kind, x + e, geom)
        dm = dist(kind, x - e, geom)
        g[m] = (dp[0] - dm[0]) / (2 * H)
        if one_sided is not None and one_sided[m] != 0:
            s = one_sided[m]
            d1 = dist(kind, x + s * e, geom)
            Hm[:, m] = s * (d1[1] - dist(kind, x, geom)[1]) / H
        else:
            Hm[:, m] = (dp[1] - dm[1]) / (2 * H)
    return g, Hm


def close(a, b, rtol=RTOL, floor=1e-6):
    return np.max(np.abs(a - b)) <= rtol * max(np.max(np.abs(b)), floor) * 10


CAPS = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.05])


@pytest.mark.parametrize("x", [[0.5, 0.3, 0.2], [-0.2, 0.1, 0.3], [1.3, -0.2, 0.1], [0.999, 0.01, 0.4],
                               [1.5, 0.0, 0.0], [-0.7, 0.0, 0.0]])
def test_capsule_distance_against_reference_and_fd(x):
    x = np.array(x, float)
    a, b = CAPS[:3], CAPS[3:6]
    d, g, Hm = dist(CAPSULE, x, CAPS)
    dr, _ = ref_capsule_distance(x, a, b)
    assert abs(d - dr) <= 1e-14
    assert abs(d - sampled_capsule_distance(x, a, b)) <= 1e-9
    gf, Hf = fd_grad_hess(CAPSULE, x, CAPS)
    assert close(g, gf)
    assert close(Hm, Hf)
    assert abs(np.linalg.norm(g) - 1.0) <= 1e-14
    assert np.allclose(Hm, Hm.T, atol=0)


@pytest.mark.parametrize("end", [0, 1])
def test_capsule_end_cap_boundary(end):
    """A node exactly on the plane through an end perpendicular to the axis: the gradient is
    continuous (central FD), the Hessian is the cylinder's (one-sided FD from inside the axis span)."""
    x = np.array([float(end), 0.2, -0.1])
    d, g, Hm = dist(CAPSULE, x, CAPS)
    _, t = node_capsule_distance(x, CAPS[:3], CAPS[3:6], np.zeros(3), np.zeros((3, 3)))
    assert t == float(end)
    gf, _ = fd_grad_hess(CAPSULE, x, CAPS)
    assert close(g, gf)
    inward = -1 if end == 1 else 1
    _, Hf = fd_grad_hess(CAPSULE, x, CAPS, one_sided=[inward, 0, 0])
    assert close(Hm, Hf)
    # from outside the span the Hessian is the cap's: it differs by e e^T / Δ
    _, Hout = fd_grad_hess(CAPSULE, x, CAPS, one_sided=[-inward, 0, 0])
    assert abs((Hout - Hm)[0, 0] - 1.0 / d) <= 1e-4 / d


def test_capsule_on_axis_line_and_degenerate_axis():
    # on the axis line beyond the end: Δ is the distance to the end point, gradient along the axis
    d, g, Hm = dist(CAPSULE, np.array([1.5, 0.0, 0.0]), CAPS)
    assert d == pytest.approx(0.5) and np.allclose(g, [1, 0, 0])
    assert np.allclose(Hm, np.diag([0.0, 2.0, 2.0]))
    # a zero-length capsule is a sphere
    geom = np.array([0.1, 0.2, 0.3, 0.1, 0.2, 0.3, 0.05])
    x = np.array([0.4, -0.1, 0.5])
    d, g, Hm = dist(CAPSULE, x, geom)
    ds, gs, Hs = dist(SPHERE, x, geom)
    assert d == ds and np.array_equal(g, gs) and np.array_equal(Hm, Hs)
    # exactly on the axis segment: no normal, no force (documented)
    g0, H0 = np.zeros(3), np.zeros((3, 3))
    d0, _ = node_capsule_distance(np.array([0.5, 0.0, 0.0]), CAPS[:3], CAPS[3:6], g0, H0)
    assert d0 == 0.0 and not np.any(g0) and not np.any(H0)


@pytest.mark.parametrize("x", [[0.3, 0.4, 0.5], [0.0, 0.0, 0.0], [1.0, -2.0, -0.5]])
def test_plane_distance(x):
    n = np.array([1.0, 2.0, 2.0]) / 3.0
    p = np.array([0.1, 0.0, -0.2])
    g, Hm = np.zeros(3), np.zeros((3, 3))
    x = np.array(x, float)
    d = node_plane_distance(x, p, n, g, Hm)
    assert d == pytest.approx(float((x - p) @ n), abs=1e-15)
    assert np.array_equal(g, n) and not np.any(Hm)
    geom = np.concatenate([p, n, [0.0]])
    gf, Hf = fd_grad_hess(PLANE, x, geom)
    assert close(g, gf) and np.max(np.abs(Hf)) <= 1e-8


@pytest.mark.parametrize("x", [[0.3, 0.4, 0.5], [0.1, 0.2, 0.36], [-1.0, 0.0, 0.0]])
def test_sphere_distance(x):
    c = np.array([0.1, 0.2, 0.3])
    x = np.array(x, float)
    g, Hm = np.zeros(3), np.zeros((3, 3))
    d = node_sphere_distance(x, c, g, Hm)
    assert d == pytest.approx(float(np.linalg.norm(x - c)), rel=1e-15)
    geom = np.concatenate([c, [0, 0, 0], [0.05]])
    gf, Hf = fd_grad_hess(SPHERE, x, geom)
    assert close(g, gf) and close(Hm, Hf)


# ------------------------------------------------------------------------------------ node contact
DT = 0.1
NU = 0.1
TOL = 0.05
KC = 10.0


def contact(kind, x, xp, geom, h=0.02, mu=0.4, vel=(0, 0, 0), omega=(0, 0, 0), center=(0, 0, 0), jac=True):
    f, ff, J = np.zeros(3), np.zeros(3), np.zeros((3, 3))
    e, gap = node_contact(kind, np.asarray(x, float), np.asarray(xp, float), DT, geom, h, TOL, KC, mu, NU,
                          np.asarray(vel, float), np.asarray(omega, float), np.asarray(center, float), f, ff, J,
                          jac, np.zeros(3), np.zeros((3, 3)))
    return e, gap, f, ff, J


def ref_energy(kind, x, geom, h):
    """The energy of one node from the obvious distance and the shared IMC energy function."""
    x = np.asarray(x, float)
    if kind == PLANE:
        d, R = float((x - geom[:3]) @ geom[3:6]), 0.0
    elif kind == SPHERE:
        d, R = float(np.linalg.norm(x - geom[:3])), geom[6]
    else:
        d, R = ref_capsule_distance(x, geom[:3], geom[3:6])[0], geom[6]
    return KC * imc_energy(d, h + R, TOL)


PLANE_G = np.array([0.0, 0.0, 0.0, 0.0, 0.6, 0.8, 0.0])
SPHERE_G = np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.3])
CAPS_G = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.3])
CASES = [
    (PLANE, [0.2, 0.01, 0.024], [0.19, 0.02, 0.03], {}),
    (PLANE, [0.2, 0.01, 0.024], [0.2, 0.01, 0.024], {}),                      # at rest: stick
    (PLANE, [0.2, 0.01, 0.024], [0.2 - 1e-9, 0.01, 0.024], {}),               # series branch of φ
    (PLANE, [0.2, 0.01, 0.024], [0.2, 0.01, 0.024], {"vel": [0.3, -0.2, 0.1]}),  # moving floor
    (SPHERE, [0.1, 0.31, 0.0], [0.12, 0.3, 0.01], {}),
    (SPHERE, [0.1, 0.31, 0.0], [0.1, 0.31, 0.0], {"omega": [0.0, 0.0, 2.0], "center": [0.1, 0, 0]}),
    (CAPSULE, [0.5, 0.1, 0.3], [0.48, 0.1, 0.31], {}),
    (CAPSULE, [0.5, 0.0, 0.31], [0.5, 0.0, 0.31], {"omega": [3.0, 0.0, 0.0]}),   # driven pulley
    (CAPSULE, [1.1, 0.0, 0.3], [1.1, 0.01, 0.3], {"omega": [0.0, 1.0, 0.5], "vel": [0.1, 0, 0],
                                                   "center": [0.5, 0.0, 0.0]}),
    (CAPSULE, [1.0, 0.0, 0.31], [1.01, 0.0, 0.3], {}),                         # end-cap boundary
]


@pytest.mark.parametrize("kind,x,xp,kw", CASES)
def test_node_contact_force_and_jacobian_fd(kind, x, xp, kw):
    geom = {PLANE: PLANE_G, SPHERE: SPHERE_G, CAPSULE: CAPS_G}[kind]
    x = np.array(x, float)
    e, gap, f, ff, J = contact(kind, x, xp, geom, **kw)
    assert gap < TOL and np.linalg.norm(f) > 0  # in contact
    assert e == pytest.approx(ref_energy(kind, x, geom, 0.02), rel=1e-13)
    fe = np.zeros(3)
    Jf = np.zeros((3, 3))
    for m in range(3):
        d = np.zeros(3)
        d[m] = H
        fe[m] = -(ref_energy(kind, x + d, geom, 0.02) - ref_energy(kind, x - d, geom, 0.02)) / (2 * H)
        one_sided = kind == CAPSULE and x[0] == 1.0 and m == 0
        if one_sided:  # Hessian of the cylinder side (see the distance test)
            fp = contact(kind, x, xp, geom, **kw)
            fm = contact(kind, x - d, xp, geom, **kw)
            Jf[:, m] = ((fp[2] + fp[3]) - (fm[2] + fm[3])) / H
        else:
            fp = contact(kind, x + d, xp, geom, **kw)
            fm = contact(kind, x - d, xp, geom, **kw)
            Jf[:, m] = ((fp[2] + fp[3]) - (fm[2] + fm[3])) / (2 * H)
    assert np.max(np.abs(fe - f)) <= 1e-6 * np.max(np.abs(f))
    tol = 1e-5 * np.max(np.abs(J)) + (1e-3 * np.max(np.abs(J)) if kind == CAPSULE and x[0] == 1.0 else 0.0)
    assert np.max(np.abs(Jf - J)) <= tol


def test_friction_is_coulomb_and_opposes_slip():
    """Full slip against a moving plane: |F_fr| = μ F_n, opposite to the slip velocity."""
    x = np.array([0.0, 0.0, 0.015])
    e, gap, f, ff, J = contact(PLANE, x, x, np.array([0, 0, 0, 0, 0, 1.0, 0]), vel=[0.5, 0.0, 0.0])
    assert np.linalg.norm(ff) == pytest.approx(0.4 * np.linalg.norm(f), rel=1e-12)
    assert ff[0] > 0 and abs(ff[1]) < 1e-15 and abs(ff[2]) < 1e-15  # floor moves +x: it drags the node +x
    # no friction with mu = 0, and none out of range
    assert not np.any(contact(PLANE, x, x, PLANE_G * 0 + [0, 0, 0, 0, 0, 1, 0], mu=0.0, vel=[1, 0, 0])[3])
    far = contact(PLANE, [0, 0, 1.0], [0, 0, 0.9], np.array([0, 0, 0, 0, 0, 1.0, 0]))
    assert far[0] == 0.0 and not np.any(far[2]) and not np.any(far[3]) and not np.any(far[4])


def test_edge_parallel_to_plane_is_smooth():
    """Both nodes of an edge parallel to the plane carry equal forces, continuous in a tilt."""
    geom = np.array([0, 0, 0, 0, 0, 1.0, 0])
    z = 0.018
    forces = []
    for tilt in (-1e-7, 0.0, 1e-7):
        f0 = contact(PLANE, [0, 0, z - tilt], [0, 0, z - tilt], geom)[2][2]
        f1 = contact(PLANE, [0.1, 0, z + tilt], [0.1, 0, z + tilt], geom)[2][2]
        forces.append((f0, f1))
    assert forces[1][0] == forces[1][1]
    assert abs(forces[0][0] - forces[2][0]) <= 1e-3 * forces[1][0]


@pytest.mark.parametrize("kind", [PLANE, SPHERE, CAPSULE])
def test_assembly_matches_node_loop(kind):
    rng = np.random.default_rng(3)
    geom = {PLANE: PLANE_G, SPHERE: SPHERE_G, CAPSULE: CAPS_G}[kind]
    n = 12
    node_dof = np.arange(n) * 4  # a rod's layout: x y z theta per node
    q = rng.uniform(-0.1, 0.4, n * 4)
    qp = q + rng.normal(0, 0.01, n * 4)
    nodes = np.arange(0, n, 2).astype(np.int64)
    h = np.full(nodes.size, 0.15)
    res = np.zeros(n * 4)
    blocks = np.zeros((nodes.size, 3, 3))
    fc, ff, normal = np.zeros((nodes.size, 3)), np.zeros((nodes.size, 3)), np.zeros((nodes.size, 3))
    gap = np.zeros(nodes.size)
    vel, om, c = np.array([0.1, 0, 0]), np.array([0, 0.5, 0]), np.zeros(3)
    e = obstacle_evaluate(kind, geom, nodes, node_dof, h, q, qp, DT, TOL, KC, 0.4, NU, vel, om, c, res, True,
                          blocks, fc, ff, gap, normal)
    ref_res = np.zeros(n * 4)
    e_ref = 0.0
    touching = 0
    for i, nd in enumerate(nodes):
        j = node_dof[nd]
        f, fr, J = np.zeros(3), np.zeros(3), np.zeros((3, 3))
        ei, gi = node_contact(kind, q[j:j + 3].copy(), qp[j:j + 3].copy(), DT, geom, 0.15, TOL, KC, 0.4, NU, vel, om,
                              c, f, fr, J, True, np.zeros(3), np.zeros((3, 3)))
        e_ref += ei
        ref_res[j:j + 3] -= f + fr
        assert np.array_equal(blocks[i], -J) and gap[i] == gi
        touching += bool(np.any(f))
    assert touching >= 1
    assert e == pytest.approx(e_ref, rel=1e-14)
    assert np.array_equal(res, ref_res)
