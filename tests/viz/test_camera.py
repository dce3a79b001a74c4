"""Views, camera axes and framing (knotsim.viz.camera)."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.errors import ConfigError
from knotsim.viz import render
from knotsim.viz.camera import VIEWS, camera_basis, plot_area, scene_bounds, view_angles


def test_view_angles():
    assert view_angles("top") == (90.0, -90.0)
    assert view_angles((20, 45)) == (20.0, 45.0)
    for bad in ("side", 3.0, (1.0, "x")):
        with pytest.raises(ConfigError, match="view"):
            view_angles(bad)
    assert render.VIEWS is VIEWS


@pytest.mark.parametrize("view", sorted(VIEWS))
def test_camera_basis_is_orthonormal(view):
    towards, right, up = camera_basis(*VIEWS[view])
    basis = np.vstack([towards, right, up])
    np.testing.assert_allclose(basis @ basis.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(np.cross(right, up), towards, atol=1e-12)


def test_camera_basis_top_view():
    towards, right, up = camera_basis(*VIEWS["top"])
    np.testing.assert_allclose(towards, [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(right, [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(up, [0, 1, 0], atol=1e-12)


def test_plot_area():
    assert plot_area((800, 600), False, False) == (1.0, 1.0)
    w, h = plot_area((800, 600), True, True)
    assert w == pytest.approx(1.0 - 95.0 / 800) and h == pytest.approx(1.0 - 36.0 / 600)
    assert plot_area((100, 100), True, True) == pytest.approx((0.7, 0.88))


def test_scene_bounds():
    lines = [np.array([[0.0, 0, 0], [1, 2, 3]]), np.array([[-1.0, 0, 0], [0, 0, 0]])]
    box = scene_bounds(lines, np.array([0.1, 0.2]), None)
    np.testing.assert_allclose(box, [[-1.2, 1.1], [-0.2, 2.1], [-0.2, 3.1]])
    fixed = [[0, 1], [0, 1], [0, 1]]
    np.testing.assert_allclose(scene_bounds(lines, np.array([0.1, 0.2]), fixed), fixed)
    with pytest.raises(ConfigError, match="bounds"):
        scene_bounds(lines, np.array([0.1, 0.2]), [[1, 0], [0, 1], [0, 1]])
