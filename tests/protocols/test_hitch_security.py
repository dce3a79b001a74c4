"""``knot-security`` on knots tied round a post (hitches, loops on a pin): the post as an obstacle of
the run, the standing part loaded and the tail free, ``load_angle``, ``post_radius``, mid-line loops,
and one short run end to end."""

from __future__ import annotations

import math

import numpy as np
import pytest

import knotsim as ks
from knotsim.errors import ConfigError
from knotsim.protocols.pipeline import build_protocol_run


def _build(knot="clove_hitch", **overrides):
    return build_protocol_run("knot-security", knot, overrides=overrides, quick=True)


def test_post_is_an_obstacle_with_the_ropes_friction():
    _, ctx, spec, _ = _build(mu=0.35)
    (post,) = spec.data["obstacles"]
    assert post["type"] == "capsule" and post["name"] == "post" and post["radius"] == pytest.approx(0.01)
    assert post["mu"] == pytest.approx(0.35)
    assert post["friction_model"] == spec.data["contact"]["friction_model"]
    assert post["stick_distance"] == pytest.approx(spec.data["contact"]["stick_distance"])
    a, b = np.asarray(post["a"]), np.asarray(post["b"])
    np.testing.assert_allclose(np.cross(b - a, [0, 0, 1]), 0, atol=1e-12)  # along z, the drawing's axis
    # the hitch: the standing part (start) and the tail set, the standing part loaded, nothing clamped
    bcs = {b["name"]: b for b in ctx.bc}
    assert {"set_pull", "set_tail", "relax_pull", "relax_tail", "load"} <= set(bcs)
    assert not any(b["type"] in ("clamp", "hold") for b in ctx.bc)
    assert bcs["load"]["nodes"] == bcs["set_pull"]["nodes"] and 0 in bcs["load"]["nodes"]
    assert ctx.plan.all_ends == [(0, 0), (0, 1)]


def test_load_angle_tilts_the_load_towards_the_axis():
    _, flat, _, _ = _build()
    _, tilted, _, _ = _build(load_angle=30.0)
    a0, a1 = flat.plan.loaded_local[0][3], tilted.plan.loaded_local[0][3]
    assert abs(a0[2]) < 1e-9 and a1[2] == pytest.approx(math.sin(math.radians(30.0)))
    assert np.dot(a0, a1) == pytest.approx(math.cos(math.radians(30.0)))
    with pytest.raises(ConfigError, match="load_angle"):
        _build(load_angle=120.0)
    with pytest.raises(ConfigError, match="load_angle.*has no post"):
        build_protocol_run("knot-security", "reef_bend", overrides={"load_angle": 10.0}, quick=True)


def test_post_radius_changes_the_post_and_is_refused_without_one():
    _, _, spec, _ = _build(post_radius=0.02, length=0.8)
    assert spec.data["obstacles"][0]["radius"] == pytest.approx(0.02)
    with pytest.raises(ConfigError, match="post_radius.*not tied round a post"):
        build_protocol_run("knot-security", "reef_bend", overrides={"post_radius": 0.02}, quick=True)


def test_mid_line_loop_loads_both_standing_parts():
    _, ctx, spec, _ = _build("alpine_butterfly_loop")
    groups = [g for g, *_ in ctx.plan.loaded_local]
    assert groups == ["load_start", "load"] and "obstacles" in spec.data
    bcs = {b["name"] for b in ctx.bc}
    assert {"set_start", "set_end", "load_start", "load"} <= bcs and "set_tail" not in bcs


def test_default_protocol_of_hitches_and_loops():
    from knotsim.protocols.registry import default_protocol

    assert default_protocol("clove_hitch") == "knot-security"
    assert default_protocol("bowline") == "knot-security"


def test_clove_hitch_quick_run_holds_with_friction_and_comes_off_without():
    held = ks.run_protocol("knot-security", "clove_hitch", overrides={"load": "hold", "hold_load": 0.01, "mu": 0.6},
                           quick=True)
    assert held["outcome"] == "held" and held["knot_status"] == "held"
    assert held["metrics"]["off_post"] is False and held["metrics"]["post_contacts_end"] > 0
    log = held.log
    assert {"post_fx", "post_n_contacts", "tail_a", "in_knot"} <= set(log.columns)
    assert np.isfinite(log["tail_a"]).all() and (log["tail_b"] == 0).all()
    loose = ks.run_protocol("knot-security", "clove_hitch", overrides={"load": "hold", "hold_load": 0.01, "mu": 0.05},
                            quick=True)
    assert loose["outcome"] == "untied" and loose["metrics"]["off_post"] is True
