"""knotsim.viz.plot: the force figure of a run directory (synthetic logs, no simulation)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from knotsim.errors import ConfigError
from knotsim.viz import plot as P


def _run_dir(tmp_path, protocol, params, metrics, columns):
    t = np.linspace(0.0, 4.0, 81)
    f = np.sin(t) + 1.0
    log = pd.DataFrame({"time": t, "F": 0.5 * f, "F_norm": f, **{c: fn(t) for c, fn in columns.items()}})
    log.to_parquet(tmp_path / "log.parquet")
    (tmp_path / "summary.json").write_text(json.dumps({"protocol": protocol, "knot": "k", "parameters": params,
                                                       "metrics": metrics}))
    return tmp_path


def test_single_rod_window_and_onset_in_run_time(tmp_path):
    s = {"protocol": "single-rod-bend", "parameters": {"mean_window": 2.0},
         "metrics": {"pre_pull_time": 0.5, "slip_onset": {"time": 1.0, "force": 1.9}, "F_norm_peak": 2.0}}
    assert P._window(s, 4.0) == ("mean window", 0.5, 2.5)
    assert P._window({**s, "parameters": {"mean_window": 9.0}}, 4.0)[2] == 4.0  # clipped to the record
    assert P._onsets(s["metrics"], P._offset(s["metrics"])) == [("slip onset", 1.5, 1.9)]


def test_peak_window_is_where_the_protocol_takes_its_peak():
    s = {"protocol": "single-rod-bend", "parameters": {"mean_window": 2.0, "transient": 1.0},
         "metrics": {"pre_pull_time": 0.5}}
    assert P._peak_window(s, 4.0) == (1.5, 2.5)
    assert P._peak_window({"protocol": "two-rope-bend", "parameters": {"transient": 0.3},
                           "metrics": {"pre_tighten_time": 1.0}}, 3.0) == (1.0, 3.0)
    assert P._peak_window({"protocol": "overhand-pull", "parameters": {}, "metrics": {}}, 3.0) == (0.0, 3.0)


def test_two_rope_window_after_transient_and_overhand_none():
    s = {"protocol": "two-rope-bend", "parameters": {"transient": 0.3},
         "metrics": {"pre_tighten_time": 1.0, "force_drop_onset": None, "slip_onset": {"time": 0.7}}}
    assert P._window(s, 3.0) == ("after the start-up transient", 1.3, 3.0)
    assert P._onsets(s["metrics"], 1.0) == [("slip onset", 1.7, None)]
    assert P._window({"protocol": "overhand-pull", "parameters": {}, "metrics": {}}, 3.0) is None


@pytest.mark.parametrize("protocol,params,metrics,columns,width", [
    ("overhand-pull", {}, {"force_drop": {"time": 2.0, "force": 1.5}, "F_norm_at_e_400mm": 1.2},
     {"e": lambda t: 0.7 - 0.1 * t}, 1100),
    ("single-rod-bend", {"mean_window": 2.0}, {"pre_pull_time": 0.5, "slip_onset": None},
     {"end_to_end": lambda t: 0.3 + 0.1 * t}, 1100),
    ("two-rope-bend", {"transient": 0.3}, {"slip_onset": {"time": 1.0, "force": 1.0}},
     {"u_pull": lambda t: 0.01 * t}, 1100),
])
def test_plot_run_writes_png(tmp_path, protocol, params, metrics, columns, width):
    import matplotlib.image as mpimg

    run = _run_dir(tmp_path, protocol, params, metrics, columns)
    path = P.plot_run(run)
    assert path == run / "force.png"
    img = mpimg.imread(path)
    assert img.shape[1] == width and img.shape[0] == 400
    assert img[..., :3].std() > 0.05  # something is drawn
    other = P.plot_run(run, tmp_path / "sub" / "f.png")
    assert other.is_file()


def test_plain_run_reactions_and_errors(tmp_path):
    t = np.linspace(0, 1, 11)
    pd.DataFrame({"time": t, "left_fx": t, "left_fy": 0 * t, "left_fz": -t}).to_parquet(tmp_path / "log.parquet")
    assert P.plot_run(tmp_path).is_file()  # no summary.json: reaction magnitudes
    pd.DataFrame({"time": t, "iterations": t}).to_parquet(tmp_path / "log.parquet")
    with pytest.raises(ConfigError, match="no force column"):
        P.plot_run(tmp_path)
    with pytest.raises(ConfigError, match="no log.parquet"):
        P.plot_run(tmp_path / "nothing")


def test_figure_marks_the_summary_peak_in_run_time(tmp_path):
    """The marked peak is the summary's (value and time; metric times count after settling), not
    a maximum the figure finds itself; a settling stage is shaded and the axis scaled to the pull."""
    s = {"protocol": "overhand-pull", "parameters": {"settle_time": 1.0, "transient": 0.5},
         "metrics": {"F_norm_peak": 1.5, "F_norm_peak_time": 1.5}}
    t = np.linspace(0.0, 4.0, 81)
    y = np.where(t < 1.0, 40.0 * np.sin(20 * t), 1.0 + 0.5 * np.sin(t))
    assert P._offset(s["metrics"], s["parameters"]) == 1.0
    assert P._window(s, 4.0) == ("after the start-up transient", 1.5, 4.0)
    assert t[P._peak_point(s, t, y)] == pytest.approx(2.5)
    assert P._peak_point({**s, "metrics": {}}, t, y) is None  # no peak in the summary: none marked
    run = _run_dir(tmp_path, "overhand-pull", s["parameters"], s["metrics"], {"e": lambda t: 0.7 - 0.1 * t})
    log = pd.read_parquet(run / "log.parquet").assign(F_norm=y)
    log.to_parquet(run / "log.parquet")
    assert P.plot_run(run).is_file()
