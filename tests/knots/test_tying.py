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


@pytest.mark.slow
@pytest.mark.parametrize("name", ["reef", "granny"])
def test_double_knots_from_straight_rod(name, tmp_path):
    if name not in tying.list_tying_sequences():
        pytest.skip(f"no shipped {name} sequence")
    res = tying.tie_from_straight(name, tmp_path / "run", overrides={"run": {"output_interval": 0.5}})
    assert res.knot_type in tying.EXPECTED[name], res.knot_type
