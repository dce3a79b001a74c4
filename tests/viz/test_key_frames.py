"""Key frames of a run (render_key_frames): chosen at the timeline's events, named after them,
framed on the knot so that it fills the picture."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from knotsim.cli import main
from knotsim.io.trajectory import TrajectoryWriter
from knotsim.viz import render_key_frames
from knotsim.viz.render import KEY_EVENTS, key_frames, render_run
from knotsim.viz.scene import BACKGROUND

SIZE = (320, 240)


def _content_fraction(path) -> float:
    """Area of the pixel bounding box of everything that is not background, below the title strip
    and left of any colour bar, as a fraction of that plot area."""
    img = np.asarray(Image.open(path).convert("RGB"), dtype=int)
    h, w = img.shape[:2]
    area = img[int(0.12 * h):, :]
    bg = np.array(BACKGROUND) * 255
    ink = np.abs(area - bg).max(axis=2) > 12
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    if rows.size == 0:
        return 0.0
    return (rows[-1] - rows[0] + 1) * (cols[-1] - cols[0] + 1) / ink.size


def _rope_fraction(path) -> float:
    """Fraction of the picture's pixels that are rope (saturated or dark), not background or text."""
    img = np.asarray(Image.open(path).convert("RGB"), dtype=int)
    return float(((img.max(axis=2) - img.min(axis=2)) > 40).mean())


def test_bend_key_frames_fill_the_picture(reef_run, tmp_path):
    summary = json.loads((reef_run / "summary.json").read_text())
    happened = {e["name"] for e in summary["timeline"]["events"]}
    paths = render_key_frames(reef_run, tmp_path, size=SIZE)
    assert [p.name for p in paths] == [f"{e}.png" for e in KEY_EVENTS if e in happened]
    assert len(paths) >= 2
    for p in paths:
        with Image.open(p) as im:
            assert im.size == SIZE
            assert im.text["knotsim:event"] == p.stem
        assert _content_fraction(p) >= 0.25, p.name
        assert _rope_fraction(p) >= 0.08, p.name  # the knot, not a speck (the old framing: ~1 %)


def test_bend_pictures_of_the_old_framing_are_a_speck(reef_run, tmp_path):
    """The whole-scene framing (frame='scene') shows the knot small: the knot framing is what fills it."""
    [scene] = render_run(reef_run, frames=[0], out_dir=tmp_path / "s", frame="scene", size=SIZE,
                         backend="matplotlib")
    [knot] = render_run(reef_run, frames=[0], out_dir=tmp_path / "k", size=SIZE, backend="matplotlib")
    assert _rope_fraction(knot) > 3 * _rope_fraction(scene)


def test_two_ropes_in_two_colours(reef_run, tmp_path):
    [p] = render_key_frames(reef_run, tmp_path, events=("set_end",), size=SIZE)
    img = np.asarray(Image.open(p).convert("RGB"), dtype=int)
    red = (img[..., 0] > 120) & (img[..., 2] < 90) & (img[..., 1] < 90)
    blue = (img[..., 2] > 100) & (img[..., 0] < 80)
    assert red.mean() > 0.03 and blue.mean() > 0.03


def test_coloured_by_slip_speed(reef_run, tmp_path):
    paths = render_key_frames(reef_run, tmp_path, events=("decision", "slow_slip_onset", "capsize_onset"),
                              color_by="slip_speed", size=SIZE)
    assert [p.name for p in paths] == ["decision.png", "slow_slip_onset.png"]  # no capsize: skipped
    img = np.asarray(Image.open(paths[0]).convert("RGB"), dtype=int)
    grey = (np.abs(img - 189).max(axis=2) < 25) & ((img.max(axis=2) - img.min(axis=2)) < 8)
    assert grey.mean() > 0.005  # nodes out of contact
    green = (img[..., 1] > img[..., 0] + 30) & (img[..., 1] > img[..., 2])  # viridis' middle and top
    assert green.mean() > 0.01
    res = CliRunner().invoke(main, ["render", str(reef_run), "--frames", "0", "-o", str(tmp_path / "cli"),
                                    "--size", "160x120", "--backend", "matplotlib", "--color-by", "rolling_speed"])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "cli" / "frame_000000.png").is_file()


def test_one_rope_gets_its_first_and_last_frames(overhand_run, tmp_path):
    paths = render_key_frames(overhand_run, tmp_path, size=SIZE)
    assert [p.name for p in paths] == ["first.png", "last.png"]
    for p in paths:
        assert _content_fraction(p) >= 0.25, p.name
        assert _rope_fraction(p) >= 0.05, p.name
    assert render_key_frames(overhand_run, tmp_path, events=("decision",)) == []


def _synthetic_run(path, events):
    """A trajectory of 11 frames at t = 0, 0.5, ..., 5 s: two ropes crossing at x = frame index
    (m), and a summary.json with the given timeline events."""
    path.mkdir()
    s = np.linspace(-1.0, 1.0, 41)
    with TrajectoryWriter(path / "trajectory.h5", [0, 41, 82], [0, 40, 80], [False, False], [0.02, 0.02],
                          ["a", "b"]) as w:
        for k in range(11):
            a = np.column_stack([k + s, 0 * s, 0 * s])
            b = np.column_stack([k + 0 * s, s, 0 * s + 0.039])
            w.append(0.5 * k, np.vstack([a, b]), np.zeros(80))
    summary = {"knot": "crossing"}
    if events is not None:
        summary["timeline"] = {"events": events}
    (path / "summary.json").write_text(json.dumps(summary))
    return path


def test_key_frames_at_the_event_times(tmp_path):
    events = [{"name": "set_end", "label": "set knot", "time": 1.1, "force": 0.1},
              {"name": "slip_onset", "label": "run-away", "time": 2.0, "force": None},
              {"name": "slow_slip_onset", "label": "slow slip", "time": 3.74, "force": 0.2},
              {"name": "decision", "label": "decided: slipped", "time": 4.26, "force": 0.3}]
    run = _synthetic_run(tmp_path / "run", events)
    paths = render_key_frames(run, size=(160, 120))
    assert [p.name for p in paths] == ["set_end.png", "slow_slip_onset.png", "decision.png"]
    assert all(p.parent == run / "render" for p in paths)
    frames = [int(Image.open(p).text["knotsim:frame"]) for p in paths]
    assert frames == [2, 7, 9]  # nearest to 1.1, 3.74 and 4.26 s
    # each picture is framed on its own crossing (at x = frame index), not on all of them
    for p in paths:
        assert _rope_fraction(p) > 0.1
    times = np.arange(11) * 0.5
    keys = key_frames({"timeline": {"events": events}}, times, events=("decision", "slip_onset", "stop"))
    assert [(k.name, k.frame, k.label) for k in keys] == [("decision", 9, "decided: slipped"),
                                                          ("slip_onset", 4, "run-away")]
    assert key_frames(None, times) == key_frames({"timeline": {"events": []}}, times)
    assert [(k.name, k.frame) for k in key_frames(None, times)] == [("first", 0), ("last", 10)]


def test_no_timeline_first_and_last(tmp_path):
    run = _synthetic_run(tmp_path / "run", None)
    paths = render_key_frames(run, tmp_path / "out", size=(160, 120))
    assert [p.name for p in paths] == ["first.png", "last.png"]
    assert [int(Image.open(p).text["knotsim:frame"]) for p in paths] == [0, 10]
    with pytest.raises(Exception, match="trajectory.h5"):
        render_key_frames(tmp_path / "out")
