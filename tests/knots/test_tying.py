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


@pytest.mark.parametrize("kind", ["reef", "granny"])
def test_generator_matches_shipped_double(kind):
    cfg = tying.double_knot_sequence(kind)
    shipped = tying.load_tying_config(kind)
    assert cfg["rods"][0]["n_nodes"] == shipped["rods"][0]["n_nodes"]
    assert cfg["run"]["duration"] == shipped["run"]["duration"]
    assert [b["name"] for b in cfg["bc"]] == [b["name"] for b in shipped["bc"]]
    for a, b in zip(cfg["bc"], shipped["bc"], strict=True):
        assert a["nodes"] == b["nodes"]
        np.testing.assert_allclose(a["waypoints"]["times"], b["waypoints"]["times"], atol=1e-9)
        np.testing.assert_allclose(a["waypoints"]["points"], b["waypoints"]["points"], atol=1e-9)


@pytest.mark.parametrize("kind", ["reef", "granny"])
def test_double_hands_never_stretch_the_rod(kind):
    hands, info = tying.two_overhands_hands(kind)
    ratio, _, _ = tying.hand_stretch(hands, info["length"] / (info["n_nodes"] - 1))
    assert ratio < 1.01


def test_reef_and_granny_left_knots_are_mirror_images():
    """Right halves identical; left halves differ exactly by the sign of z (reflection vs rotation)."""
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
    """Full runs (N = 257, 11 s simulated, ~30 s wall each): reef -> 3_1#3_1*, granny -> 3_1#3_1."""
    res = tying.tie_from_straight(name, tmp_path / "run", overrides={"run": {"output_interval": 0.5}})
    assert res.ok, res.knot_type
    assert res.knot_type in tying.EXPECTED[name]
    assert res.topology.rolfsen == {"reef": "3_1#3_1*", "granny": "3_1#3_1"}[name]
    assert res.topology.n_crossings_reduced == 6
    assert res.max_penetration_ratio < 0.2
    x = res.positions
    assert np.linalg.norm(x[-1] - x[0]) > 1.1  # both knots pulled tight
