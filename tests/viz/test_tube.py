"""Tube surface meshes (knotsim.viz.tube)."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.errors import ConfigError
from knotsim.viz import render
from knotsim.viz.tube import TubeMesh, tube_mesh, unit


def _ring(n):
    s = 2 * np.pi * np.arange(n) / n
    return np.column_stack([np.cos(s), np.sin(s), 0 * s])


def test_tube_mesh_closed_ring_has_no_seam():
    ring = _ring(30)
    # a non-planar closed curve makes the rotation-minimising frame pick up holonomy
    s = 2 * np.pi * np.arange(30) / 30
    wavy = ring + np.column_stack([0 * s, 0 * s, 0.4 * np.sin(3 * s)])
    for line in (ring, wavy):
        mesh = tube_mesh([line], [0.1], [True], subdivisions=2, n_sides=8)
        rings = mesh.vertices.reshape(-1, 8, 3)
        step = np.linalg.norm(np.diff(rings, axis=0), axis=2).max()
        seam = np.linalg.norm(rings[0] - rings[-1], axis=1).max()
        assert seam < 1.5 * step
        assert mesh.quads.shape == (60 * 8, 4) and mesh.tris.size == 0
    open_mesh = tube_mesh([ring[:10]], [0.1], [False], subdivisions=1, n_sides=8)
    assert open_mesh.quads.shape == (9 * 8, 4) and open_mesh.tris.shape == (2 * 8, 3)
    np.testing.assert_allclose(np.linalg.norm(open_mesh.normals, axis=1), 1.0)


def test_scalars_follow_the_mesh_and_bad_sides():
    line = _ring(12)[:6]
    mesh = tube_mesh([line], [0.05], [False], scalars=[np.arange(6.0)], subdivisions=2, n_sides=5)
    assert mesh.vertex_values.shape == (mesh.vertices.shape[0],)
    assert mesh.quad_values.shape == (mesh.quads.shape[0],)
    assert mesh.tri_values.shape == (mesh.tris.shape[0],)
    assert mesh.vertex_values.min() == 0.0 and mesh.vertex_values.max() == 5.0
    with pytest.raises(ConfigError, match="n_sides"):
        tube_mesh([line], [0.05], [False], n_sides=2)


def test_unit_keeps_zero_vectors():
    v = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(unit(v), [[0.6, 0.8, 0.0], [0.0, 0.0, 0.0]])


def test_render_module_reexports_the_mesh():
    assert render.TubeMesh is TubeMesh and render.tube_mesh is tube_mesh
