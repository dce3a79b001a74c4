"""Model layout, masses, rest shape and input errors."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.errors import ConfigError, GeometryError
from knotsim.rods import Model, RodSpec
from knotsim.solver.state import initial_state


def _helix(n):
    s = np.linspace(0, 4 * np.pi, n)
    return np.stack([0.02 * np.cos(s), 0.02 * np.sin(s), 0.005 * s], 1)


def test_layout_open_and_closed_rods():
    a = RodSpec(_helix(10), radius=1e-3, youngs_modulus=1e6, density=1000.0)
    s = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    b = RodSpec(np.stack([np.cos(s), np.sin(s), 0 * s], 1) * 0.05, radius=2e-3, youngs_modulus=1e6,
                density=1000.0, closed=True)
    m = Model([a, b])
    assert m.n_dofs == (4 * 10 - 1) + 4 * 8
    assert m.n_edges == 9 + 8 and m.n_bend == 8 + 8
    # interleaved layout: node k at 4k, edge k angle at 4k+3, rod b after rod a
    assert m.node_dof[3] == 12 and m.edge_theta_dof[3] == 15
    assert m.node_dof[10] == 39 and m.edge_theta_dof[9 + 7] == 39 + 4 * 7 + 3
    # the closing edge of the ring joins its last node to its first
    assert tuple(m.edge_nodes[-1]) == (17, 10)
    # bending stencils of a ring wrap around
    assert tuple(m.bend_edges[8]) == (16, 9)


def test_masses_sum_to_rod_masses():
    rod = RodSpec(_helix(30), radius=1e-3, youngs_modulus=1e6, density=1200.0)
    m = Model([rod])
    length = np.linalg.norm(np.diff(rod.positions, axis=0), axis=1).sum()
    assert m.total_mass() == pytest.approx(1200.0 * np.pi * 1e-6 * length, rel=1e-12)


def test_rest_shape_is_straight_whatever_the_initial_shape():
    m = Model([RodSpec(_helix(20), radius=1e-3, youngs_modulus=1e6, density=1000.0)])
    assert np.all(m.kappa_bar == 0.0) and np.all(m.twist_bar == 0.0)
    m2 = Model([RodSpec(_helix(20), radius=1e-3, youngs_modulus=1e6, density=1000.0,
                        natural_curvature=(10.0, 0.0), natural_twist=2.0)])
    np.testing.assert_allclose(m2.kappa_bar[:, 0], 10.0 * m2.voronoi_rest)
    np.testing.assert_allclose(m2.twist_bar, 2.0 * m2.voronoi_rest)


def test_initial_frames_orthonormal_and_untwisted_for_planar_rod():
    s = np.linspace(0, np.pi, 15)
    x = np.stack([np.cos(s), np.sin(s), 0 * s], 1) * 0.1
    m = Model([RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0)])
    st = initial_state(m)
    np.testing.assert_allclose(np.linalg.norm(st.d1, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.sum(st.d1 * st.tangents, axis=1), 0.0, atol=1e-12)
    np.testing.assert_allclose(st.ref_twist, 0.0, atol=1e-12)


@pytest.mark.parametrize(
    "kwargs, field, fragment",
    [
        ({"positions": np.zeros((3, 2))}, "positions", "expected shape (N, 3)"),
        ({"positions": np.zeros((1, 3))}, "positions", "at least 2 nodes"),
        ({"radius": -1.0}, "radius", "positive number"),
        ({"youngs_modulus": float("nan")}, "youngs_modulus", "positive number"),
        ({"poisson_ratio": 0.7}, "poisson_ratio", "(-1, 0.5]"),
        ({"natural_curvature": np.zeros((3, 3))}, "natural_curvature", "expected shape"),
        ({"edge_angles": np.zeros(2)}, "edge_angles", "expected shape"),
    ],
)
def test_bad_rod_fields_name_the_field(kwargs, field, fragment):
    base = {"positions": _helix(6), "radius": 1e-3, "youngs_modulus": 1e6, "density": 1000.0}
    base.update(kwargs)
    with pytest.raises(ConfigError) as info:
        Model([RodSpec(**base)])
    assert field in info.value.field and fragment in str(info.value)


def test_coincident_nodes_are_a_geometry_error():
    x = _helix(6)
    x[3] = x[2]
    with pytest.raises(GeometryError, match="edge 2 has zero length"):
        Model([RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0)])


def test_duplicate_rod_names_and_unknown_rod():
    a = RodSpec(_helix(6), radius=1e-3, youngs_modulus=1e6, density=1000.0, name="r")
    b = RodSpec(_helix(6) + 1.0, radius=1e-3, youngs_modulus=1e6, density=1000.0, name="r")
    with pytest.raises(ConfigError, match="duplicate rod name"):
        Model([a, b])
    m = Model([RodSpec(_helix(6), radius=1e-3, youngs_modulus=1e6, density=1000.0, name="r")])
    with pytest.raises(ConfigError, match="unknown rod 'x'"):
        m.rod_index("x")
