"""The rigid obstacles of a run (``[[obstacles]]`` of its run.toml) in its pictures: read with their
motion, meshed at the right place and size, drawn by both backends and the HTML page, the knot
framing kept on the knot (and the part of the post the rope touches); a run without obstacles
pictured as before."""

from __future__ import annotations

import re

import numpy as np
import pytest
from PIL import Image

from knotsim.errors import KnotsimWarning
from knotsim.io.trajectory import TrajectoryWriter, read_trajectory
from knotsim.viz.obstacles import (
    ObstacleShape,
    clip_box,
    obstacle_focus,
    obstacle_mesh,
    obstacles_at,
    read_obstacles,
)
from knotsim.viz.render import _frame_options, _render_array, render_key_frames, render_run

SIZE = (240, 180)
R_ROPE = 0.002  # m
R_POST = 0.01  # m

POST = """
[[obstacles]]
type = "capsule"
name = "post"
a = [0.0, 0.0, -0.5]
b = [0.0, 0.0, 0.5]
radius = 0.01
mu = 0.3
"""


def _crossing(n: int = 81) -> list[np.ndarray]:
    """Two ropes crossing at 45 degrees in front of a post along z (radius R_POST): A along y
    against the post, B over A (the crossing at y = z = 0)."""
    s = np.linspace(-0.1, 0.1, n)
    a = np.column_stack([np.full(n, R_POST + R_ROPE), s, np.zeros(n)])
    b = np.column_stack([np.full(n, R_POST + 3 * R_ROPE), s / np.sqrt(2), s / np.sqrt(2)])
    return [a, b]


def _run_dir(path, obstacles: str | None, times=(0.0, 1.0)):
    """A run directory: the crossing of :func:`_crossing` at each of ``times`` (s) and a run.toml
    holding ``obstacles`` (None: no run.toml)."""
    path.mkdir(parents=True)
    lines = _crossing()
    n = lines[0].shape[0]
    with TrajectoryWriter(path / "trajectory.h5", [0, n, 2 * n], [0, n - 1, 2 * n - 2], [False, False],
                          [R_ROPE, R_ROPE], ["A", "B"]) as w:
        for t in times:
            w.append(float(t), np.vstack(lines), np.zeros(2 * n - 2))
    if obstacles is not None:
        (path / "run.toml").write_text('description = "hand-written"\n' + obstacles)
    return path


def _pixels(img) -> np.ndarray:
    return np.asarray(img if isinstance(img, np.ndarray) else Image.open(img).convert("RGB"), dtype=int)


def _grey(img: np.ndarray) -> np.ndarray:
    """Pixels of the post: grey (unsaturated), neither background white nor black text; below the
    title strip."""
    area = img[int(0.12 * img.shape[0]):]
    sat = area.max(axis=2) - area.min(axis=2)
    return (sat < 14) & (area.max(axis=2) > 50) & (area.max(axis=2) < 215)


# ------------------------------------------------------------------------------ reading, motion
def test_obstacles_of_a_run_toml_and_their_motion(tmp_path):
    (tmp_path / "run.toml").write_text("""
[[obstacles]]
type = "capsule"
name = "post"
a = [0.0, 0.0, -0.1]
b = [0.0, 0.0, 0.1]
radius = 0.02

[[obstacles]]
type = "sphere"
name = "ball"
center = [1.0, 0.0, 0.0]
radius = 0.05
velocity = [0.0, 0.1, 0.0]

[[obstacles]]
type = "plane"
name = "floor"
point = [0.0, 0.0, -0.3]
waypoints = {times = [0.0, 2.0], points = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.2]]}

[[obstacles]]
type = "capsule"
name = "arm"
a = [0.1, 0.0, 0.0]
b = [0.3, 0.0, 0.0]
radius = 0.01
angular_velocity = [0.0, 0.0, 1.5707963267948966]
pivot = [0.0, 0.0, 0.0]

[[obstacles]]
type = "capsule"
name = "pulley"
a = [0.0, -0.05, 1.0]
b = [0.0, 0.05, 1.0]
radius = 0.05
spin_inertia = 1e-4
""")
    tracks = read_obstacles(tmp_path)
    assert [t.shape.name for t in tracks] == ["post", "ball", "floor", "arm", "pulley"]
    assert [t.moves for t in tracks] == [False, True, True, True, False]
    post, ball, floor, arm, pulley = obstacles_at(tracks, 1.0)
    assert post.kind == "capsule" and post.radius == 0.02
    np.testing.assert_allclose(post.a, [0, 0, -0.1])
    np.testing.assert_allclose(post.b, [0, 0, 0.1])
    np.testing.assert_allclose(ball.a, [1.0, 0.1, 0.0])  # velocity x t
    assert ball.radius == 0.05
    np.testing.assert_allclose(floor.a, [0, 0, -0.2])  # half way along the waypoints
    np.testing.assert_allclose(floor.normal, [0, 0, 1])
    np.testing.assert_allclose(arm.a, [0, 0.1, 0], atol=1e-12)  # a quarter turn about the pivot
    np.testing.assert_allclose(arm.b, [0, 0.3, 0], atol=1e-12)
    np.testing.assert_allclose(pulley.a, [0, -0.05, 1.0])  # free spin: the same shape
    np.testing.assert_allclose(obstacles_at(tracks, 5.0)[2].a, [0, 0, -0.1])  # stays at the last waypoint
    np.testing.assert_allclose(obstacles_at(tracks, 0.0)[1].a, [1.0, 0, 0])


def test_no_run_toml_no_obstacles_and_a_bad_table_is_left_out(tmp_path):
    assert read_obstacles(tmp_path) == []
    (tmp_path / "run.toml").write_text('description = "x"\n')
    assert read_obstacles(tmp_path) == []
    (tmp_path / "run.toml").write_text(POST + '\n[[obstacles]]\ntype = "cone"\nname = "c"\n')
    with pytest.warns(KnotsimWarning, match="obstacle 1 is not drawn"):
        tracks = read_obstacles(tmp_path)
    assert [t.shape.name for t in tracks] == ["post"]


# ----------------------------------------------------------------------------------- meshes
def _distance_to_segment(x, a, b):
    d = b - a
    t = np.clip((x - a) @ d / (d @ d), 0.0, 1.0)
    return np.linalg.norm(x - (a + t[:, None] * d), axis=1)


def test_capsule_mesh_is_the_capsule():
    a, b = np.array([0.1, 0.2, 0.3]), np.array([0.1, 0.25, 0.4])
    shape = ObstacleShape("capsule", "peg", a, b, 0.01)
    m = obstacle_mesh([shape], np.array([[0.0, 0.2], [0.1, 0.35], [0.2, 0.5]]))
    assert m.names == ["peg"] and not m.empty
    np.testing.assert_allclose(_distance_to_segment(m.vertices, a, b), 0.01, rtol=1e-9)
    # the outward normals: from the axis to the vertex; the hemispherical caps reach r beyond a and b
    d = (b - a) / np.linalg.norm(b - a)
    s = (m.vertices - a) @ d
    assert s.min() == pytest.approx(-0.01) and s.max() == pytest.approx(np.linalg.norm(b - a) + 0.01)
    t = np.clip(s / np.linalg.norm(b - a), 0, 1)
    radial = m.vertices - (a + t[:, None] * (b - a))
    np.testing.assert_allclose(np.einsum("ij,ij->i", m.normals, radial / 0.01), 1.0, atol=1e-9)
    p = m.vertices[m.quads]  # no quad without area (a pole's are triangles)
    assert np.all(np.linalg.norm(np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1]), axis=1) > 0)
    assert m.rgba[0, 3] == 1.0 and np.ptp(m.rgba[0, :3]) < 0.05  # opaque grey
    sphere = obstacle_mesh([ObstacleShape("sphere", "ball", a, a, 0.03)], np.array([[0, 1], [0, 1], [0, 1.0]]))
    np.testing.assert_allclose(np.linalg.norm(sphere.vertices - a, axis=1), 0.03, rtol=1e-9)
    np.testing.assert_allclose(sphere.vertices.min(axis=0), a - 0.03, rtol=1e-9)
    np.testing.assert_allclose(sphere.vertices.max(axis=0), a + 0.03, rtol=1e-9)


def test_a_long_post_is_cut_at_the_clip_box_and_a_plane_is_a_patch_round_the_region():
    post = ObstacleShape("capsule", "post", np.array([0, 0, -50.0]), np.array([0, 0, 50.0]), 0.01)
    floor = ObstacleShape("plane", "floor", np.array([0, 0, -0.1]), np.array([0, 0, -0.1]),
                          normal=np.array([0, 0, 1.0]))
    far = ObstacleShape("sphere", "far", np.array([9.0, 0, 0]), np.array([9.0, 0, 0]), 0.1)
    region = np.array([[-0.05, 0.05], [-0.05, 0.05], [-0.05, 0.05]])
    clip = clip_box(region, (400, 300))
    assert np.all(clip[:, 0] < region[:, 0]) and np.all(clip[:, 1] > region[:, 1])
    m = obstacle_mesh([post, floor, far], region, clip)
    assert m.names == ["post", "floor"]  # the far sphere is out of the clip box
    v = m.vertices[m.vertex_obstacle == 0]
    assert v[:, 2].min() == pytest.approx(clip[2, 0] - 0.01) and v[:, 2].max() == pytest.approx(clip[2, 1] + 0.01)
    assert np.abs(v[:, :2]).max() == pytest.approx(0.01)  # the cut ends are flat discs of the post's radius
    assert m.quads.shape[0] < 5000
    f = m.vertices[m.vertex_obstacle == 1]
    np.testing.assert_allclose(f[:, 2], -0.1)
    assert f[:, 0].min() < -0.05 and f[:, 0].max() > 0.05 and f[:, 1].min() < -0.05 and f[:, 1].max() > 0.05
    assert f[:, 0].max() < 1.0  # a patch round the region, not the whole plane
    assert list(m.two_sided) == [False, True] and m.rgba[1, 3] < 1.0 and m.rgba[0, 3] == 1.0


def test_the_knot_box_takes_the_part_of_the_post_the_rope_touches():
    from knotsim.viz.framing import knot_region

    lines = _crossing()
    post = ObstacleShape("capsule", "post", np.array([0, 0, -0.5]), np.array([0, 0, 0.5]), R_POST)
    box = np.stack(knot_region(lines, R_ROPE), axis=1)
    grown = obstacle_focus(box, [post], lines, R_ROPE)
    assert np.all(grown[:, 0] <= box[:, 0]) and np.all(grown[:, 1] >= box[:, 1])
    assert grown[0, 0] == pytest.approx(-R_POST) and grown[1, 0] == pytest.approx(min(box[1, 0], -R_POST))
    assert np.ptp(grown[2]) == pytest.approx(np.ptp(box[2]))  # along the post: only where the rope is
    far = ObstacleShape("capsule", "far", np.array([1.0, 0, -0.5]), np.array([1.0, 0, 0.5]), R_POST)
    floor = ObstacleShape("plane", "floor", np.zeros(3), np.zeros(3), normal=np.array([1.0, 0, 0]))
    np.testing.assert_array_equal(obstacle_focus(box, [far, floor], lines, R_ROPE), box)


# -------------------------------------------------------------------------------- pictures
@pytest.mark.parametrize("backend", ["matplotlib", "pyvista"])
def test_the_post_is_drawn_and_the_knot_stays_framed(backend):
    if backend == "pyvista":
        pytest.importorskip("pyvista")
    post = ObstacleShape("capsule", "post", np.array([0, 0, -0.5]), np.array([0, 0, 0.5]), R_POST)
    without = _pixels(_render_array(_crossing(), R_ROPE, size=SIZE, backend=backend, frame="knot", title="t"))
    with_post = _pixels(_render_array(_crossing(), R_ROPE, size=SIZE, backend=backend, frame="knot", title="t",
                                      obstacles=[post]))
    assert _grey(without).mean() < 0.01
    grey = _grey(with_post)
    assert grey.mean() > 0.08  # the post, framed near the rope: a broad band
    cols = np.flatnonzero(grey.any(axis=0))
    assert cols.size > 0.15 * SIZE[0]
    assert grey[:3].any() and grey[-3:].any()  # the 1 m post runs out of the picture, top and bottom
    # the ropes still fill the picture (framed on the knot, not on the whole post)
    rope = lambda img: ((img.max(axis=2) - img.min(axis=2)) > 60).mean()  # noqa: E731
    assert rope(with_post) > 0.5 * rope(without) > 0.02


def test_render_run_and_key_frames_draw_the_run_posts(tmp_path):
    run = _run_dir(tmp_path / "post", POST)
    [png] = render_run(run, frames=[0], out_dir=tmp_path / "a", size=SIZE, backend="matplotlib")
    assert _grey(_pixels(png)).mean() > 0.08
    [off] = render_run(run, frames=[0], out_dir=tmp_path / "b", size=SIZE, backend="matplotlib", obstacles=False)
    assert _grey(_pixels(off)).mean() < 0.01
    paths = render_key_frames(run, tmp_path / "k", size=SIZE)
    assert [p.name for p in paths] == ["first.png", "last.png"]
    for p in paths:
        assert _grey(_pixels(p)).mean() > 0.08


def test_a_moving_obstacle_is_drawn_where_it_is_at_the_frame(tmp_path):
    run = _run_dir(tmp_path / "moving", POST.replace("mu = 0.3", "velocity = [0.0, 0.0, 0.25]"), times=(0.0, 2.0))
    tracks = read_obstacles(run)
    with read_trajectory(run / "trajectory.h5", lazy=True) as traj:
        first = _frame_options(traj, 0, "knot", {}, tracks)["obstacles"][0]
        last = _frame_options(traj, 1, "knot", {}, tracks)["obstacles"][0]
    np.testing.assert_allclose(first.a, [0, 0, -0.5])
    np.testing.assert_allclose(last.a, [0, 0, 0.0])  # 0.25 m/s for 2 s: its lower end at the crossing
    pngs = render_run(run, frames=[0, 1], out_dir=tmp_path / "p", size=SIZE, backend="matplotlib", view="front")
    at0, at1 = (_grey(_pixels(p)) for p in pngs)
    assert at0[:3].any() and at0[-3:].any()  # through the picture
    assert at1[:3].any() and not at1[-3:].any()  # its round end in the picture, nothing below


def test_a_run_without_obstacles_is_pictured_as_before(tmp_path):
    run = _run_dir(tmp_path / "plain", 'name = "no obstacles"\n')
    bare = _run_dir(tmp_path / "bare", None)
    a = render_run(run, frames=[0], out_dir=tmp_path / "a", size=SIZE, backend="matplotlib")
    b = render_run(bare, frames=[0], out_dir=tmp_path / "b", size=SIZE, backend="matplotlib", obstacles=False)
    expected = _render_array(_crossing(), R_ROPE, closed=[False, False], size=SIZE, backend="matplotlib",
                             title="t = 0 s", frame="knot")
    np.testing.assert_array_equal(_pixels(a[0]), _pixels(b[0]))
    np.testing.assert_array_equal(_pixels(a[0]), expected)


# ------------------------------------------------------------------------------------ HTML page
def test_html_page_draws_the_post_and_moves_a_moving_ball(tmp_path):
    pytest.importorskip("plotly")
    import plotly.graph_objects as go

    from knotsim.viz import view

    ball = '\n[[obstacles]]\ntype = "sphere"\nname = "ball"\ncenter = [0.025, 0.0, -0.012]\nradius = 0.004\n' \
           'velocity = [0.0, 0.0, 0.01]\n'
    run = _run_dir(tmp_path / "run", POST + ball, times=(0.0, 0.5, 1.0))
    text = view.write_html(run, tmp_path / "v.html", max_frames=3).read_text()
    plain = _run_dir(tmp_path / "plain", None)
    plain_text = view.write_html(plain, tmp_path / "p.html", max_frames=3).read_text()
    meshes = text.count('"type":"mesh3d"') - plain_text.count('"type":"mesh3d"')  # (plotly's template has one)
    assert meshes == 2 + 3  # the post and the ball in the page; the ball again in each of the 3 frames
    assert '"name":"post"' in text and '"name":"ball"' in text and '"name":"post"' not in plain_text
    assert '"traces":[0,1,3]' in text  # the frames move the two ropes and the ball (trace 3), not the post
    ranges = np.array([[float(v) for v in re.search(rf'"{a}axis":\{{"range":\[([^,]+),([^\]]+)\]', text).groups()]
                       for a in "xyz"])
    assert ranges[0, 0] <= -R_POST and np.ptp(ranges[2]) < 0.2  # the post's thickness, not its metre
    post = ObstacleShape("capsule", "post", np.array([0, 0, -0.5]), np.array([0, 0, 0.5]), R_POST)
    trace = view._obstacle_trace(go, post, ranges, ranges)
    x, y, z = (np.asarray(trace[c]) for c in "xyz")
    np.testing.assert_allclose(np.hypot(x, y).max(), R_POST)
    assert z.min() == pytest.approx(ranges[2, 0] - R_POST) and z.max() == pytest.approx(ranges[2, 1] + R_POST)
    assert len(trace.i) > 100 and trace.opacity == 1.0


def test_animation_draws_the_post(tmp_path):
    from knotsim.viz.animate import animate_run

    run = _run_dir(tmp_path / "run", POST)
    out = animate_run(run, tmp_path / "a.gif", size=SIZE, backend="matplotlib")
    plain = animate_run(run, tmp_path / "b.gif", size=SIZE, backend="matplotlib", obstacles=False)
    with Image.open(out) as im, Image.open(plain) as im2:
        assert im.n_frames == 2
        assert _grey(np.asarray(im.convert("RGB"), dtype=int)).mean() > 0.02
        assert _grey(np.asarray(im2.convert("RGB"), dtype=int)).mean() < 0.01
