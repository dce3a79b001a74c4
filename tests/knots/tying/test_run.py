"""Shipped tying sequences (knotsim.knots.tying.run): valid one-rod configurations, and full runs
from the straight rod to the expected knot type."""

from __future__ import annotations

import os

import numpy as np
import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

from knotsim.errors import ConfigError  # noqa: E402
from knotsim.io.config import load_config  # noqa: E402
from knotsim.knots import tying  # noqa: E402


def test_shipped_sequences_are_valid_configs():
    names = tying.list_tying_sequences()
    assert "overhand" in names
    for name in names:
        raw = tying.load_tying_config(name)
        rc = load_config(raw)
        assert rc.model.n_rods == 1
        assert rc.duration > 0 and raw["contact"]["mu"] > 0
        assert raw["bc"] and {b["type"] for b in raw["bc"]} <= {"move", "hold"}
        assert {b["rod"] for b in raw["bc"]} == {"rope"}
        last = max(b.get("start", 0.0) + b["waypoints"]["times"][-1] for b in raw["bc"] if b["type"] == "move")
        assert last < rc.duration  # every hand finishes inside the run


def test_unknown_sequence_is_a_config_error():
    with pytest.raises(ConfigError, match="unknown tying sequence"):
        tying.load_tying_config("bowline")


def test_expected_names_are_shipped():
    names = tying.list_tying_sequences()
    assert {"overhand", "reef", "granny"} <= set(names)
    assert set(tying.EXPECTED) <= set(names)
    # reef and granny must be told apart
    assert not set(tying.EXPECTED["reef"]) & set(tying.EXPECTED["granny"])


#: Names of the former single-module ``knotsim.knots.tying`` that code and docs use.
_PUBLIC = ["EXPECTED", "Hand", "TyingResult", "dumps_toml", "hand_stretch", "list_tying_sequences",
           "load_tying_config", "overhand_hands", "overhand_sequence", "tie_from_straight", "tying_sequence_path",
           "write_sequence"]


def test_package_keeps_the_module_names():
    """``from knotsim.knots.tying import X`` and ``tying.X`` for every name of the former module;
    the TOML writer is the package-wide one."""
    from knotsim._util import toml
    from knotsim.knots.tying import dumps_toml, hands, run, sequences

    assert set(_PUBLIC) <= set(tying.__all__)
    owners = {name: m for m in (hands, run, sequences) for name in m.__all__}
    for name in _PUBLIC:
        assert getattr(tying, name) is getattr(owners[name], name), name
    assert dumps_toml is toml.dumps_toml


def test_overhand_from_straight_rod_is_a_trefoil(tmp_path):
    """Coarse full run (N = 129, ~15 s): the straight rod ends as a tight trefoil, no penetration."""
    res = tying.tie_from_straight("overhand", tmp_path / "run", overrides={"run": {"output_interval": 0.5}})
    assert res.ok, res.knot_type
    assert res.knot_type in ("trefoil_left", "trefoil_right")
    assert res.max_penetration_ratio < 0.2
    # pulled tight: the ends 0.6 m apart on a 0.8 m rod leave the knot a few rope diameters long
    x = res.positions
    assert np.linalg.norm(x[-1] - x[0]) > 0.6
    assert (tmp_path / "run" / "trajectory.h5").is_file()
