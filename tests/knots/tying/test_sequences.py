"""Tying sequences (knotsim.knots.tying.sequences): the generators reproduce the shipped files,
and a sequence written as TOML reads back with every float exactly equal."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim._util.toml import loads_toml
from knotsim.knots import tying
from knotsim.knots.tying import sequences as ts


def _assert_identical(a, b, where="cfg"):
    """Same tree, same types, every float equal to the last bit."""
    assert type(a) is type(b), (where, a, b)
    if isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            _assert_identical(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _assert_identical(x, y, f"{where}[{i}]")
    else:
        assert a == b, (where, a, b)


def test_generator_matches_shipped_overhand():
    cfg = ts.overhand_sequence()
    shipped = tying.load_tying_config("overhand")
    assert cfg["rods"] == shipped["rods"] and cfg["contact"] == shipped["contact"]
    assert cfg["run"]["duration"] == shipped["run"]["duration"]
    assert [b["name"] for b in cfg["bc"]] == [b["name"] for b in shipped["bc"]]
    for a, b in zip(cfg["bc"], shipped["bc"], strict=True):
        assert a["nodes"] == b["nodes"] and a.get("start") == b.get("start") and a.get("stop") == b.get("stop")
        np.testing.assert_allclose(a["waypoints"]["times"], b["waypoints"]["times"], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(a["waypoints"]["points"], b["waypoints"]["points"], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("make", [
    ts.overhand_sequence,
    lambda: ts.overhand_sequence(radius=1.0 / 3.0 * 1e-2, youngs=2.0 / 3.0 * 1e6, dt=1e-3 / 7.0),
], ids=["overhand", "overhand_unrounded"])
def test_dumps_toml_round_trips_every_float_exactly(make):
    cfg = make()
    text = tying.dumps_toml(cfg)
    _assert_identical(cfg, loads_toml(text))


def test_write_sequence_header_and_exact_values(tmp_path):
    cfg = ts.overhand_sequence(dt=1e-3 / 7.0)
    path = ts.write_sequence(cfg, tmp_path / "seq.toml", header="line one\n\nline three")
    text = path.read_text()
    assert text.startswith("# line one\n#\n# line three\n")
    _assert_identical(cfg, loads_toml(text))
