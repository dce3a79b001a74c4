"""knotsim view: the HTML page (plotly, self-contained) drawn by headless Chromium; the window's
one-line refusals without a display or without the extra."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from knotsim.cli import main
from knotsim.errors import ConfigError
from knotsim.runspec import RunSpec, run
from knotsim.viz import view

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """examples/crossing_rods.toml (rod B pressed onto rod A) for 0.2 s: 11 frames."""
    out = tmp_path_factory.mktemp("view") / "run"
    spec = RunSpec.load(EXAMPLES / "crossing_rods.toml")
    run(spec.with_changes(run={"duration": 0.2, "output_interval": 0.02}), out, progress=False)
    return out


def test_select_frames():
    np.testing.assert_array_equal(view.select_frames(5, 10), np.arange(5))
    sel = view.select_frames(1001, 100)
    assert sel.size == 100 and sel[0] == 0 and sel[-1] == 1000 and np.all(np.diff(sel) > 0)
    with pytest.raises(ConfigError, match="max_frames"):
        view.select_frames(10, 1)


def test_force_curves_are_the_reaction_forces(run_dir):
    import pandas as pd

    t, curves = view.force_curves(run_dir)
    log = pd.read_parquet(run_dir / "log.parquet")
    # the four clamped/moved groups, not the contact totals
    assert sorted(curves) == [f"{g} reaction |F|" for g in ("A0", "A1", "B0", "B1")]
    np.testing.assert_array_equal(curves["B0 reaction |F|"], log["B0_force"].to_numpy())
    np.testing.assert_array_equal(t, log["time"].to_numpy())


def test_html_page_is_self_contained(run_dir, tmp_path):
    pytest.importorskip("plotly")
    page = view.write_html(run_dir, tmp_path / "sub" / "view.html", max_frames=6)
    text = page.read_text()
    assert len(text) > 1_000_000  # plotly.js is embedded
    assert not re.search(r"<script[^>]+src=", text)  # nothing is fetched when it opens
    assert text.count('"name":"A"') >= 6 and '"name":"5"' in text  # 6 frames of both rods
    assert "B0 reaction |F|" in text


def test_html_scene_is_framed_on_the_crossing(run_dir, tmp_path):
    """The scene's axis ranges hold the rods' crossing (plus a margin), not their whole length."""
    pytest.importorskip("plotly")
    from knotsim.io.trajectory import read_trajectory
    from knotsim.viz.framing import knot_mask

    text = view.write_html(run_dir, tmp_path / "f.html", max_frames=4).read_text()
    ranges = np.array([[float(v) for v in re.search(rf'"{a}axis":\{{"range":\[([^,]+),([^\]]+)\]', text).groups()]
                       for a in "xyz"])
    with read_trajectory(run_dir / "trajectory.h5") as tr:
        x = np.asarray(tr.positions[-1])
        crossing = x[np.concatenate(knot_mask(tr.centerlines(tr.n_frames - 1), tr.rod_radius))]
        radius = float(tr.rod_radius.max())
    assert crossing.size
    assert np.all(ranges[:, 0] <= crossing.min(axis=0)) and np.all(ranges[:, 1] >= crossing.max(axis=0))
    whole = np.ptp(x, axis=0)
    assert np.ptp(ranges[:2], axis=1).max() < 0.6 * whole[:2].max()  # the crossing, not the rods' length
    assert np.ptp(ranges, axis=1).max() < 20 * radius + np.ptp(crossing, axis=0).max()


def test_html_page_coloured_by_the_contacts_slip_and_rolling(run_dir, tmp_path):
    """crossing_rods (surface friction, the default): the pressed rods' contact nodes carry slip
    and rolling speeds, the page colours the lines by them with a scale from 0 to the largest."""
    pytest.importorskip("plotly")
    from knotsim.io.trajectory import read_trajectory

    with read_trajectory(run_dir / "trajectory.h5") as tr:
        slip = np.asarray(tr.fields["slip_speed"])
        assert tr.units["rolling_speed"] == "m/s"
    live = np.isfinite(slip[-1])
    assert 0 < live.sum() < slip.shape[1]  # the contact nodes only, NaN elsewhere
    page = view.write_html(run_dir, tmp_path / "slip.html", max_frames=4, color_by="slip_speed")
    text = page.read_text()
    assert f'"colorscale":[[0.0,"{view.NO_VALUE_COLOR}"]' in text  # grey: out of contact
    assert "slip speed (mm\\u002fs)" in text  # plotly escapes the slash
    top = max(float(np.nanmax(slip[i])) for i in view.select_frames(slip.shape[0], 4) if np.any(np.isfinite(slip[i])))
    cmax = re.search(r'"cmax":([0-9.eE+-]+)', text)
    assert cmax is not None and float(cmax.group(1)) == pytest.approx(1e3 * top, rel=1e-12)  # mm/s
    res = CliRunner().invoke(main, ["view", str(run_dir), "--html", str(tmp_path / "r.html"), "--color-by",
                                    "rolling_speed"])
    assert res.exit_code == 0, res.output
    with pytest.raises(ConfigError, match="color_by"):
        view.write_html(run_dir, tmp_path / "x.html", color_by="bending_strain")


def test_html_colour_by_slip_needs_surface_friction(tmp_path):
    pytest.importorskip("plotly")
    out = tmp_path / "run"
    spec = RunSpec.load(EXAMPLES / "crossing_rods.toml")
    run(spec.with_changes(run={"duration": 0.02, "output_interval": 0.01},
                          contact={**spec.data["contact"], "friction_model": "centreline"}), out, progress=False)
    with pytest.raises(ConfigError, match="no 'slip_speed'.*surface"):
        view.write_html(out, tmp_path / "x.html", color_by="slip_speed")


def test_cli_html_and_refusals(run_dir, tmp_path, monkeypatch):
    pytest.importorskip("plotly")
    runner = CliRunner()
    res = runner.invoke(main, ["view", str(run_dir), "--html", str(tmp_path / "v.html"), "--max-frames", "3"])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "v.html").is_file() and str(tmp_path / "v.html") in res.output
    # no display: one line that suggests --html
    monkeypatch.setattr(view, "has_display", lambda: False)
    res = runner.invoke(main, ["view", str(run_dir)])
    assert res.exit_code == 2 and "--html" in res.output and len(res.output.strip().splitlines()) == 1
    # the extra is missing: one line that names it
    monkeypatch.setitem(sys.modules, "plotly", None)
    monkeypatch.setitem(sys.modules, "plotly.graph_objects", None)
    res = runner.invoke(main, ["view", str(run_dir), "--html", str(tmp_path / "w.html")])
    assert res.exit_code == 2 and "knotsim[view]" in res.output and len(res.output.strip().splitlines()) == 1
    assert "Traceback" not in res.output
    res = runner.invoke(main, ["view", str(tmp_path)])
    assert res.exit_code == 2 and "trajectory.h5" in res.output


def test_has_display_follows_the_environment(monkeypatch):
    if sys.platform in ("darwin", "win32"):
        pytest.skip("always a display there")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert not view.has_display()
    monkeypatch.setenv("DISPLAY", ":0")
    assert view.has_display()


def _rgb(hex_color: str) -> np.ndarray:
    return np.array([int(hex_color[i : i + 2], 16) for i in (1, 3, 5)])


@pytest.mark.skipif(shutil.which("chromium") is None, reason="chromium is not installed (.ci/run installs it)")
def test_page_draws_in_headless_chromium(run_dir, tmp_path):
    pytest.importorskip("plotly")
    import matplotlib.image as mpimg

    page = view.write_html(run_dir, tmp_path / "view.html", max_frames=4)
    shot = tmp_path / "shot.png"
    subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu", f"--screenshot={shot}",
                    "--window-size=1000,700", "--virtual-time-budget=10000", page.resolve().as_uri()],
                   check=True, capture_output=True, timeout=180)
    img = (mpimg.imread(shot)[..., :3] * 255).round().astype(int)
    assert img.shape[:2] == (700, 1000)
    area = img[60:560]  # below the title, above the slider
    colours = np.unique(area.reshape(-1, 3), axis=0)
    assert colours.shape[0] > 100, f"only {colours.shape[0]} distinct colours: the page looks blank"
    # both rods are drawn in the 3D scene (left part), the force curves in the plot (right part)
    left, right = area[:, :560].reshape(-1, 3), area[:, 560:].reshape(-1, 3)
    for colour in view.ROD_COLORS[:2]:
        assert np.sum(np.abs(left - _rgb(colour)).max(axis=1) < 40) > 200, colour
    assert np.sum(np.abs(right - _rgb(view.ROD_COLORS[3])).max(axis=1) < 40) > 50  # A1's reaction curve
