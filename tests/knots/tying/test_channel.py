"""The studied-form reef and granny fed through a knotting channel (knotsim.knots.tying.channel): the
channels, the grip paths, the shipped files, and (slow) the full ties from the straight rod."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

from tests.processes import map_in_processes  # noqa: E402

from knotsim.knots import tying  # noqa: E402
from knotsim.knots.library import load_knot_spec  # noqa: E402
from knotsim.knots.topology import analyze  # noqa: E402
from knotsim.knots.tying.channel import (  # noqa: E402
    DEFAULT_N_NODES,
    SECOND_HALF_KNOT_PASSES,
    channel_curve,
    channel_sequence,
)
from knotsim.knots.tying.run import GAP_LIMIT_DIAMETERS  # noqa: E402


@pytest.fixture(scope="module")
def curves():
    return {k: channel_curve(k) for k in ("reef", "granny")}


def test_granny_channel_is_the_reef_with_its_second_half_knot_mirrored(curves):
    reef, granny = load_knot_spec("single_rod_reef").ropes[0].passes, load_knot_spec("single_rod_granny").ropes[0].passes
    flipped = [not p if k in SECOND_HALF_KNOT_PASSES else p for k, p in enumerate(reef)]
    assert tuple(flipped) == granny  # the library's granny drawing
    (a, hold_a), (b, hold_b) = curves["reef"], curves["granny"]
    assert hold_a == hold_b
    np.testing.assert_allclose(a[:, :2], b[:, :2], atol=1e-12)  # the same plan
    differ = np.flatnonzero(np.abs(a[:, 2] - b[:, 2]) > 1e-6)
    # only the second half-knot (near both ends' legs, away from the bottom loop) changes level
    assert differ.size and np.all(np.abs(differ - hold_a) > 50)
    assert analyze([a]).knot_type == "reef"
    assert analyze([b]).knot_type in tying.EXPECTED["granny"]


def test_channel_has_clearance(curves):
    x, _ = curves["reef"]
    d = np.linalg.norm(x[:, None] - x[None], axis=2)
    i = np.arange(len(x))
    far = np.abs(i[:, None] - i[None]) >= 4
    assert d[far].min() > 1.6 * 2 * 2.5e-3  # centre distance: surfaces 3 mm or more apart


def _grip_positions(cfg, t):
    """Prescribed positions (m) of the guide grips at time t (s), by node."""
    out = {}
    ds = 1.3 / (cfg["rods"][0]["n_nodes"] - 1)
    for b in cfg["bc"]:
        if not b["name"].startswith("guide_") or t >= b["stop"]:
            continue
        i = b["nodes"][0]
        pts = np.asarray(b["waypoints"]["points"])
        out[i] = np.array([i * ds, 0.0, 0.0]) + np.array(
            [np.interp(t, b["waypoints"]["times"], pts[:, k]) for k in range(3)])
    return out


@pytest.mark.parametrize("kind", ["reef", "granny"])
def test_grips_slide_the_rope_along_the_channel(kind, curves):
    cfg, info = channel_sequence(kind)
    n = DEFAULT_N_NODES
    assert n == 601 and cfg["rods"][0]["n_nodes"] == n  # the shipped resolution (channel.DEFAULT_N_NODES)
    ds = 1.3 / (n - 1)
    # every 4th node and the last: 151 grips at N = 601
    assert info["n_guides"] == len(set(range(0, n, 4)) | {n - 1}) == 151
    assert 0 in _grip_positions(cfg, 0.0) and n - 1 in _grip_positions(cfg, 0.0)
    # at the end of the feed every grip sits on its node of the channel
    x, hold = curves[kind]
    at_end = _grip_positions(cfg, info["t_feed"])
    for i, p in at_end.items():
        np.testing.assert_allclose(p, x[i] - x[0] + [1.3, 0.0, 0.0], atol=2e-6)
    # all the way, neighbouring grips keep the rope between them neither stretched nor bunched more
    # than the channel's own bends do (chord / arc over four edges, the grip spacing)
    lo = np.min(np.linalg.norm(x[4:] - x[:-4], axis=1)) / (4 * ds)
    assert lo > 0.8
    for t in np.linspace(0.0, info["t_feed"], 61):
        g = _grip_positions(cfg, t)
        nodes = sorted(g)
        for a, b in zip(nodes[:-1], nodes[1:], strict=True):
            r = np.linalg.norm(g[b] - g[a]) / ((b - a) * ds)
            assert lo - 0.02 < r <= 1.0 + 2e-4, (t, a, b, r)
    assert info["hold_node"] == hold and info["held_nodes"] == [hold - 1, hold, hold + 1]


@pytest.mark.parametrize("kind", ["reef", "granny"])
def test_shipped_file_is_the_generator_output(kind):
    cfg, _ = channel_sequence(kind)
    shipped = tying.load_tying_config(kind)
    assert shipped == cfg


def _tie(job: tuple[str, str]) -> dict:
    """One full tie in a worker process: what the test checks of it."""
    kind, out = job
    res = tying.tie_from_straight(kind, out, overrides={"run": {"output_interval": 1.0}})
    g = res.half_knot
    return {"ok": res.ok, "knot_type": res.knot_type, "rolfsen": res.topology.rolfsen, "form": g.form,
            "diameters": g.diameters, "hold_node": g.hold_node, "penetration": res.max_penetration_ratio}


@pytest.mark.slow
def test_tie_studied_form_from_straight_rod(tmp_path):
    """Full ties of the reef and the granny (N = 601, about 2-3 min each, side by side): the right
    connected sum, nested, the second half-knot within 10 rope diameters of the first."""
    kinds = ("reef", "granny")
    results = map_in_processes(_tie, [(k, str(tmp_path / k)) for k in kinds])
    for kind, res in zip(kinds, results, strict=True):
        assert res["ok"], (kind, res["knot_type"])
        assert res["rolfsen"] == {"reef": "3_1#3_1*", "granny": "3_1#3_1"}[kind]
        assert res["form"] == "nested" and res["diameters"] <= GAP_LIMIT_DIAMETERS, kind
        assert res["penetration"] < 0.2, kind
        s = json.loads((tmp_path / kind / "summary.json").read_text())
        assert s["half_knot_gap_ok"] is True and s["hold_node"] == res["hold_node"], kind
