"""Rendering of tubes (matplotlib backend; pyvista when installed) and animations."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from knotsim.errors import ConfigError
from knotsim.io.trajectory import TrajectoryWriter
from knotsim.viz.animate import animate_run
from knotsim.viz.render import render_frame, render_run

SIZE = (160, 120)


def _rings(n=40):
    s = 2 * np.pi * np.arange(n) / n
    return [
        np.column_stack([np.cos(s), np.sin(s), 0 * s]),
        np.column_stack([1 + np.cos(s), 0 * s, np.sin(s)]),
    ]


def _load(path):
    img = np.asarray(Image.open(path).convert("RGB"), dtype=float)
    return img


def _not_blank(img):
    assert img.std() > 10.0
    assert (img.min(axis=2) < 200).mean() > 0.05  # a good part of the picture is not background


def test_render_frame_matplotlib(tmp_path):
    out = render_frame(
        _rings(),
        [0.1, 0.1],
        tmp_path / "a" / "rings.png",
        closed=True,
        size=SIZE,
        backend="matplotlib",
        title="rings",
    )
    assert out.exists()
    img = _load(out)
    assert img.shape == (SIZE[1], SIZE[0], 3)
    _not_blank(img)
    red = (img[..., 0] > 120) & (img[..., 2] < 90)
    blue = (img[..., 2] > 100) & (img[..., 0] < 80)
    assert red.mean() > 0.02 and blue.mean() > 0.02  # one default colour per rope


@pytest.mark.parametrize("upper", [0, 1])
def test_crossing_occludes(tmp_path, upper):
    """Two perpendicular rods seen from the top: the one above covers the crossing."""
    x = np.linspace(-1, 1, 9)
    z = np.where(np.arange(2) == upper, 0.1, -0.1)
    a = np.column_stack([x, 0 * x, np.full_like(x, z[0])])
    b = np.column_stack([0 * x, x, np.full_like(x, z[1])])
    out = render_frame(
        [a, b],
        0.1,
        tmp_path / "x.png",
        colors=["red", "blue"],
        view="top",
        size=(100, 100),
        backend="matplotlib",
    )
    img = _load(out)
    centre = img[45:56, 45:56].reshape(-1, 3).mean(axis=0)
    if upper == 0:
        assert centre[0] > centre[2] + 50
    else:
        assert centre[2] > centre[0] + 50


def test_views_and_colour_by(tmp_path):
    s = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    trefoil = np.column_stack([np.sin(s) + 2 * np.sin(2 * s), np.cos(s) - 2 * np.cos(2 * s), -np.sin(3 * s)])
    for view in ("top", "front", (20.0, 45.0)):
        img = _load(
            render_frame(
                [trefoil], 0.3, tmp_path / "t.png", closed=True, view=view, size=SIZE, backend="matplotlib"
            )
        )
        assert img.shape == (SIZE[1], SIZE[0], 3)
        _not_blank(img)
    img = _load(
        render_frame(
            [trefoil],
            0.3,
            tmp_path / "bs.png",
            closed=True,
            color_by="bending_strain",
            size=SIZE,
            backend="matplotlib",
        )
    )
    _not_blank(img)
    vals = [np.linspace(0, 1, 60)]
    img = _load(
        render_frame(
            [trefoil], 0.3, tmp_path / "sc.png", closed=True, scalars=vals, size=SIZE, backend="matplotlib"
        )
    )
    _not_blank(img)


def test_bad_arguments(tmp_path):
    line = [np.array([[0.0, 0, 0], [1, 0, 0]])]
    out = tmp_path / "x.png"
    with pytest.raises(ConfigError, match="view"):
        render_frame(line, 0.1, out, view="side", backend="matplotlib")
    with pytest.raises(ConfigError, match="backend"):
        render_frame(line, 0.1, out, backend="povray")
    with pytest.raises(ConfigError, match="color_by"):
        render_frame(line, 0.1, out, color_by="twist", backend="matplotlib")
    with pytest.raises(ConfigError, match="radii"):
        render_frame(line, -0.1, out, backend="matplotlib")
    with pytest.raises(ConfigError, match="colors"):
        render_frame(line, 0.1, out, colors=["red", "blue"], backend="matplotlib")


@pytest.fixture
def run_dir(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    rings = _rings(24)
    with TrajectoryWriter(
        run / "trajectory.h5", [0, 24, 48], [0, 24, 48], [True, True], [0.1, 0.1], ["a", "b"]
    ) as w:
        for k in range(4):
            pos = np.vstack([rings[0], rings[1] + [0.1 * k, 0, 0]])
            w.append(0.1 * k, pos, np.zeros(48))
    return run


def test_render_run(run_dir):
    paths = render_run(run_dir, size=SIZE, backend="matplotlib")
    assert [p.name for p in paths] == ["frame_000003.png"]
    assert paths[0].parent == run_dir / "render"
    paths = render_run(
        run_dir, frames=[0, -1], out_dir=run_dir / "png", size=SIZE, backend="matplotlib", view="top"
    )
    assert [p.name for p in paths] == ["frame_000000.png", "frame_000003.png"]
    for p in paths:
        img = _load(p)
        assert img.shape == (SIZE[1], SIZE[0], 3)
        _not_blank(img)
    with pytest.raises(ConfigError):
        render_run(run_dir, frames="middle", backend="matplotlib")


def test_animate_gif(run_dir, tmp_path):
    seen = []
    out = animate_run(
        run_dir,
        tmp_path / "anim.gif",
        fps=10,
        every=2,
        size=(80, 60),
        backend="matplotlib",
        progress=lambda i, n: seen.append((i, n)),
    )
    with Image.open(out) as im:
        assert im.size == (80, 60)
        assert im.n_frames == 2
    assert seen == [(1, 2), (2, 2)]
    with pytest.raises(ConfigError):
        animate_run(run_dir, tmp_path / "anim.avi")


def test_animate_mp4(run_dir, tmp_path):
    imageio = pytest.importorskip("imageio.v2")
    pytest.importorskip("imageio_ffmpeg")
    out = animate_run(run_dir, tmp_path / "anim.mp4", fps=10, size=(81, 60), backend="matplotlib")
    reader = imageio.get_reader(out)
    frames = [f for f in reader]
    reader.close()
    assert len(frames) == 4
    assert frames[0].shape[:2] == (60, 82)


def test_render_frame_pyvista(tmp_path):
    pytest.importorskip("pyvista")
    out = render_frame(
        _rings(),
        [0.1, 0.1],
        tmp_path / "pv.png",
        closed=True,
        size=SIZE,
        backend="pyvista",
        title="pv",
        color_by="bending_strain",
    )
    img = _load(out)
    assert img.shape == (SIZE[1], SIZE[0], 3)
    _not_blank(img)
