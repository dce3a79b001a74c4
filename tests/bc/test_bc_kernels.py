"""The per-step boundary-condition fast paths give bitwise the numbers of the slow obvious code:
the reaction sums (knotsim.bc._kernels) against numpy's sums, the waypoint path outside its times
against np.interp, and the cached unknowns of a group against a fresh computation."""

import numpy as np
import pytest

from knotsim.bc import BoundaryConditions, Waypoints
from knotsim.bc._kernels import numpy_order_sum, prescribed_reaction
from knotsim.rods import Model, RodSpec


def _bits(x) -> bytes:
    return np.float64(x).tobytes()


@pytest.mark.parametrize("n", [0, 1, 2, 3, 7, 8, 9, 15, 16, 17, 127, 128, 129, 130, 255, 256, 257, 300, 1029, 5000])
def test_numpy_order_sum_is_numpy_sum_bitwise(n):
    rng = np.random.default_rng(n)
    for rep in range(10):
        a = rng.standard_normal(n + 20) * 10.0 ** rng.integers(-9, 9, n + 20)
        if rep == 1:
            a[:] = -0.0
        elif rep == 2 and n:
            a[rng.integers(0, n + 20, max(1, n // 3))] = -0.0
        idx = rng.permutation(n + 20)[:n].astype(np.int64)
        assert _bits(numpy_order_sum(a, idx)) == _bits(a[idx].sum())


def test_numpy_order_sum_is_not_a_plain_running_sum():
    """The test above can fail: a running sum differs from numpy's pairwise sum in the last bits."""
    rng = np.random.default_rng(3)
    a = rng.standard_normal(200) * 10.0 ** rng.integers(-9, 9, 200)
    running = 0.0
    for v in a:
        running += v
    assert _bits(numpy_order_sum(a, np.arange(200))) != _bits(running)


def _reaction_reference(model, g, residual):
    """The reaction as the code before the kernel computed it."""
    r = np.zeros(4)
    for k in np.flatnonzero(g.axes):
        r[k] = residual[model.node_dof[g.nodes] + k].sum()
    if g.fix_twist and g.edges.size:
        r[3] = residual[model.edge_theta_dof[g.edges]].sum()
    return r


def _model(n=40):
    x = np.column_stack([np.linspace(0.0, 0.2, n), np.zeros(n), np.zeros(n)])
    return Model([RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0)])


def test_reactions_match_the_slow_reference_bitwise():
    model = _model()
    bcs = BoundaryConditions(model)
    bcs.clamp("left", nodes=[0, 1, 2])
    bcs.move("right", nodes=list(range(-12, 0)), path=[1e-3, 0.0, 0.0])
    bcs.pin("roller", nodes=[20], axes="yz", twist=True)
    bcs.hold("loose", nodes=[25, 26], stop=1.0)
    bcs.move("late", nodes=[10, 11], path=[0.0, 1e-3, 0.0], start=5.0)
    q = bcs.initial_q()
    bcs.evaluate(1e-3, q, 0.0)
    rng = np.random.default_rng(0)
    residual = rng.standard_normal(model.n_dofs) * 10.0 ** rng.integers(-6, 3, model.n_dofs)
    out = bcs.reactions(1e-3, residual)
    assert set(out) == {"left", "right", "roller", "loose", "late"}
    for name, r in out.items():
        g = bcs.groups[name]
        ref = _reaction_reference(model, g, residual) if g.active(1e-3) else np.zeros(4)
        assert r.tobytes() == ref.tobytes(), name
    assert out["roller"][0] == 0.0 and out["roller"][1] != 0.0 and out["roller"][3] != 0.0
    assert not np.any(out["late"])


def test_prescribed_reaction_without_twist_unknowns():
    residual = np.arange(10.0)
    out = np.full(4, np.nan)
    prescribed_reaction(residual, np.array([[0, 3], [1, 4], [2, 5]]), np.array([True, False, True]),
                        np.zeros(0, np.int64), out)
    assert out.tolist() == [3.0, 0.0, 7.0, 0.0]


def _interp_reference(path: Waypoints, e: float) -> np.ndarray:
    out = np.array([np.interp(e, path.times, path.points[:, k]) for k in range(3)])
    if path.then_velocity is not None and e > path.times[-1]:
        out += path.then_velocity * (e - path.times[-1])
    return out - path.points[0]


@pytest.mark.parametrize("then", [None, [0.006, -0.002, 1e-3]])
def test_waypoints_outside_their_times_match_np_interp_bitwise(then):
    pts = [[0.0, 0.0, 0.0], [1e-3, -2e-3, 0.5e-3], [3.3e-3, 0.1, -7e-4]]
    absolute = [[0.1, 0.2, 0.3], [0.2, 0.1, 0.0], [0.3, 0.33, -0.1]]
    for p in (Waypoints([0.0, 0.7, 2.0], pts, then_velocity=then),
              Waypoints([0.0, 0.7, 2.0], absolute, absolute=True, then_velocity=then),
              Waypoints([0.0], [[0.0, 0.0, 0.0]], then_velocity=then)):
        for e in (-1.0, 0.0, 1e-9, 0.35, 0.7, 1.999, 2.0, 2.0 + 1e-12, 2.5, 17.123456789, 61.9975):
            assert p(e).tobytes() == _interp_reference(p, e).tobytes(), (p.times, e)


def test_group_plan_follows_replaced_nodes():
    model = _model()
    bcs = BoundaryConditions(model)
    g = bcs.move("right", nodes=[-2, -1], path=[1e-3, 0.0, 0.0])
    q = bcs.initial_q()
    d1, _, _ = bcs.evaluate(1e-3, q, 0.0)
    g.nodes = np.array([30, 31, 32], np.int64) + model.rod_node_start[0]
    g.edges = bcs._edges_within(g.nodes)
    g.anchor = None
    d2, v2, _ = bcs.evaluate(1e-3, q, 0.0)
    xyz = (model.node_dof[g.nodes][:, None] + np.arange(3)).ravel()
    assert d2.tolist() == [*xyz.tolist(), *model.edge_theta_dof[g.edges].tolist()]
    assert d1.size == 6 + 1 and d2.size == 9 + 2
    assert np.allclose(v2[:9], q[xyz] + np.tile([1e-6, 0.0, 0.0], 3))


def _values_reference(bcs, t, q_in, t_in):
    """The prescribed unknowns and values as the array code (``_prescribed_values``) gives them."""
    m = bcs.model
    dofs, vals = [], []
    for g in bcs.groups.values():
        if not (g.prescribed and g.active(t)):
            continue
        xyz = m.node_dof[g.nodes][:, None] + np.arange(3)[None, :]
        pos, th = bcs._prescribed_values(g, t, q_in, t_in)
        dofs.append(xyz[:, g.axes].ravel())
        vals.append(pos[:, g.axes].ravel())
        if th is not None:
            dofs.append(m.edge_theta_dof[g.edges])
            vals.append(np.asarray(th, float))
    return np.concatenate(dofs), np.concatenate(vals)


def test_evaluate_matches_the_array_code_bitwise():
    from knotsim.bc.paths import RampedVelocity

    model = _model(60)
    bcs = BoundaryConditions(model)
    bcs.clamp("left", nodes=[0, 1])
    bcs.move("ramp", nodes=[5, 6], path=RampedVelocity([3e-3, -1e-3, 2e-3], 0.4), stop=50.0)
    bcs.move("way", nodes=[10, 11, 12], path=Waypoints([0.0, 0.3, 0.9], [[0, 0, 0], [1e-3, 2e-3, -1e-3],
                                                                        [2e-3, 1e-3, 0.0]],
                                                       then_velocity=[-6e-3, 1e-3, 3e-3]))
    bcs.move("func", nodes=[15], path=lambda e: [np.sin(e) * 1e-3, e * e * 1e-4, 0.1 + 0.0 * e], twist=False,
             start=0.2)
    bcs.pin("roller", nodes=[20, 21], axes="xz", twist=True)
    bcs.hold("held", nodes=[25], start=0.1, stop=0.6)
    bcs.rotate("spin", nodes=[30, 31], rate=2.0)
    bcs.move("turn", nodes=[40, 41, 42], path=[1e-3, 0.0, 0.0], rotation={"axis": [0, 0, 1], "rate": 0.5})
    bcs.move("right", nodes=[-2, -1], path=Waypoints([0.0, 0.5], [[0, 0, 0], [0, 0, 0]],
                                                    then_velocity=[6e-3, 0.0, 0.0]))
    rng = np.random.default_rng(5)
    q = bcs.initial_q() + 1e-4 * rng.standard_normal(model.n_dofs)
    t_in, dt, seen = 0.0, 0.0125, 0
    while t_in < 1.3:
        t = t_in + dt
        d, v, _ = bcs.evaluate(t, q, t_in)
        rd, rv = _values_reference(bcs, t, q, t_in)
        assert d.dtype == np.int64 and v.dtype == np.float64
        assert d.tolist() == rd.tolist() and v.tobytes() == rv.tobytes(), t
        assert not d.flags.writeable
        seen = max(seen, d.size)
        q = q.copy()
        q[d] = v
        t_in = t
    # every group at once (held while 0.1 <= t < 0.6): 3 x 16 node coordinates + 2 x 2 of the roller's,
    # 9 edge angles
    assert seen == 3 * 16 + 4 + 9


def test_path_components_are_the_displacement_bitwise():
    from knotsim.bc.paths import ConstantVelocity, FunctionPath, Path, RampedVelocity

    paths = [ConstantVelocity([6e-3, -1e-3, 2.5e-3]), RampedVelocity([3e-3, 1e-3, -2e-3], 0.37),
             Waypoints([0.0, 0.7, 2.0], [[0, 0, 0], [1e-3, -2e-3, 5e-4], [3.3e-3, 0.1, -7e-4]]),
             Waypoints([0.0, 2.0], [[0.1, 0.2, 0.3], [0.2, 0.1, 0.0]], absolute=True, then_velocity=[1e-3, 0, 2e-3]),
             Waypoints([0.0], [[0.0, 0.0, 0.0]], then_velocity=[-6e-3, 0.0, 0.0]),
             FunctionPath(lambda e: [np.cos(e), e**3, 0.5])]
    for p in paths:
        for e in (0.0, 1e-9, 0.2, 0.37, 0.7, 1.3, 2.0, 2.0 + 1e-12, 3.75, 61.9975):
            c = p.components(e)
            assert type(c[0]) is float and np.array(c).tobytes() == p.displacement(e).tobytes(), (p, e)
    assert Path().components(1.0) is None
