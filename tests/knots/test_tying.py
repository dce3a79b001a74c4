"""Tying knots from a straight rod with the shipped boundary-condition sequences."""

from __future__ import annotations

import os

import numpy as np
import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

from knotsim.io.config import load_config  # noqa: E402
from knotsim.knots import tying  # noqa: E402


def test_shipped_sequences_are_valid_configs():
    names = tying.list_tying_sequences()
    assert "overhand" in names
    for name in names:
        rc = load_config(tying.load_tying_config(name))
        assert rc.model.n_rods == 1 if hasattr(rc.model, "n_rods") else True
        assert rc.contact is not None and rc.duration > 0


def test_unknown_sequence_is_a_config_error():
    from knotsim.errors import ConfigError

    with pytest.raises(ConfigError, match="unknown tying sequence"):
        tying.load_tying_config("bowline")


def test_hands_never_stretch_the_rod():
    hands, _ = tying.overhand_hands()
    ratio, _, _ = tying.hand_stretch(hands, 0.8 / 128)
    assert ratio < 1.01


def test_generator_matches_shipped_overhand():
    cfg = tying.overhand_sequence()
    shipped = tying.load_tying_config("overhand")
    assert [b["name"] for b in cfg["bc"]] == [b["name"] for b in shipped["bc"]]
    for a, b in zip(cfg["bc"], shipped["bc"], strict=True):
        np.testing.assert_allclose(a["waypoints"]["points"], b["waypoints"]["points"], atol=1e-9)


def test_overhand_from_straight_rod_is_a_trefoil(tmp_path):
    """Coarse full run (N = 129, ~15 s): the straight rod ends as a tight trefoil, no penetration."""
    res = tying.tie_from_straight("overhand", tmp_path / "run", overrides={"run": {"output_interval": 0.5}})
    assert res.ok, res.knot_type
    assert res.knot_type in ("trefoil_left", "trefoil_right")
    assert res.max_penetration_ratio < 0.2
    # tight: the knot's extent is a few rope diameters
    x = res.positions
    assert np.linalg.norm(x[-1] - x[0]) > 0.6
    assert (tmp_path / "run" / "trajectory.h5").is_file()


def test_expected_names_are_shipped():
    names = tying.list_tying_sequences()
    assert {"overhand", "reef", "granny"} <= set(names)
    assert set(tying.EXPECTED) <= set(names)
    # reef and granny must be told apart
    assert not set(tying.EXPECTED["reef"]) & set(tying.EXPECTED["granny"])


def _fake_stage1_state(n=209, length=1.3, k0=107, k1=137):
    """A straight rod with two far-apart nodes touching (a stand-in for the first knot)."""
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0.0, length, n)
    x[k1, :] = x[k0] + [0.0, 0.0, 4e-3]
    return x


@pytest.mark.parametrize("kind", ["reef", "granny"])
def test_same_end_stage1_matches_shipped(kind):
    """The first stage does not depend on the state: generator and shipped file agree on it."""
    cfg, info = tying.same_end_sequence(kind, state=_fake_stage1_state())
    shipped = tying.load_tying_config(kind)
    assert cfg["rods"] == shipped["rods"] and cfg["contact"] == shipped["contact"]
    assert cfg["run"]["duration"] == shipped["run"]["duration"]
    assert [b["name"] for b in cfg["bc"]] == [b["name"] for b in shipped["bc"]]
    for a, b in zip(cfg["bc"], shipped["bc"], strict=True):
        if a["name"].endswith("2"):  # stage 2: designed on the actual stage-1 state
            continue
        assert a["nodes"] == b["nodes"] and a.get("stop") == b.get("stop")
        np.testing.assert_allclose(a["waypoints"]["times"], b["waypoints"]["times"], atol=1e-9)
        if a["name"] != "end_a":  # end A's last point depends on the stage-1 rope direction
            np.testing.assert_allclose(a["waypoints"]["points"], b["waypoints"]["points"], atol=1e-9)
    assert info["second_start_node"] == 137 + 5


def test_same_end_reef_and_granny_second_knots_are_mirror_images():
    x = _fake_stage1_state()
    reef, _ = tying.same_end_sequence("reef", state=x)
    granny, _ = tying.same_end_sequence("granny", state=x)
    n2 = 0
    for a, b in zip(reef["bc"], granny["bc"], strict=True):
        pa, pb = np.asarray(a["waypoints"]["points"]), np.asarray(b["waypoints"]["points"])
        if a["name"].endswith("2"):  # rope along +x: mirror through its vertical plane = y -> -y
            n2 += 1
            np.testing.assert_allclose(pa[:, [0, 2]], pb[:, [0, 2]], atol=1e-9)
            np.testing.assert_allclose(pa[:, 1], -pb[:, 1], atol=1e-9)
        else:
            np.testing.assert_allclose(pa, pb, atol=1e-9)
    assert n2 == 7


def test_same_end_needs_a_first_knot():
    x = np.zeros((209, 3))
    x[:, 0] = np.linspace(0.0, 1.3, 209)
    with pytest.raises(ValueError, match="no first knot"):
        tying.same_end_sequence("reef", state=x)
    with pytest.raises(ValueError, match="reef"):
        tying.same_end_sequence("bowline", state=x)


@pytest.mark.parametrize("kind", ["reef", "granny"])
def test_two_overhands_hands_never_stretch_the_rod(kind):
    hands, info = tying.two_overhands_hands(kind)
    ratio, _, _ = tying.hand_stretch(hands, info["length"] / (info["n_nodes"] - 1))
    assert ratio < 1.01


def test_two_overhands_reef_and_granny_left_knots_are_mirror_images():
    """Generator-only variant: right halves identical; left halves differ by the sign of z."""
    reef, _ = tying.two_overhands_hands("reef")
    granny, _ = tying.two_overhands_hands("granny")
    for hr, hg in zip(reef, granny, strict=True):
        assert hr.name == hg.name and hr.nodes == hg.nodes
        pr, pg = np.asarray(hr.points), np.asarray(hg.points)
        np.testing.assert_allclose(pr[:, :2], pg[:, :2])
        if hr.name.startswith("L.") or hr.name == "end_a":
            np.testing.assert_allclose(pr[:, 2], -pg[:, 2])
            assert np.abs(pr[:, 2]).max() > 0
        else:
            np.testing.assert_allclose(pr[:, 2], pg[:, 2])


def test_double_knot_kind_is_checked():
    with pytest.raises(ValueError, match="reef"):
        tying.two_overhands_hands("bowline")


@pytest.mark.slow
@pytest.mark.parametrize("name", ["reef", "granny"])
def test_double_knots_from_straight_rod(name, tmp_path):
    """Full runs (N = 209, 18.9 s simulated, 50-80 s wall each): reef -> 3_1#3_1*, granny -> 3_1#3_1."""
    res = tying.tie_from_straight(name, tmp_path / "run", overrides={"run": {"output_interval": 0.5}})
    assert res.ok, res.knot_type
    assert res.knot_type in tying.EXPECTED[name]
    assert res.topology.rolfsen == {"reef": "3_1#3_1*", "granny": "3_1#3_1"}[name]
    assert res.topology.n_crossings_reduced == 6
    assert res.max_penetration_ratio < 0.2
    x = res.positions
    assert np.linalg.norm(x[-1] - x[0]) > 1.05  # both knots pulled snug (L = 1.3 m)
    edges = np.linalg.norm(np.diff(x, axis=0), axis=1)
    assert edges.max() < 1.05 * 1.3 / 208  # and the rod not stretched
