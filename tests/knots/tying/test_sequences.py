"""Tying sequences (knotsim.knots.tying.sequences): the generators reproduce the shipped files,
and a sequence written as TOML reads back with every float exactly equal."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim._util.toml import loads_toml
from knotsim.knots import tying
from knotsim.knots.tying import sequences as ts


def _fake_stage1_state(n=209, length=1.3, k0=107, k1=137):
    """A straight rod with two far-apart nodes touching (a stand-in for the first knot)."""
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0.0, length, n)
    x[k1, :] = x[k0] + [0.0, 0.0, 4e-3]
    return x


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
    lambda: ts.same_end_sequence("reef", state=_fake_stage1_state())[0],
    lambda: ts.double_knot_sequence("granny"),
], ids=["overhand", "overhand_unrounded", "same_end_reef", "double_knot_granny"])
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


def test_same_end_reef_and_granny_second_knots_are_mirror_images():
    x = _fake_stage1_state()
    reef, _ = ts.same_end_sequence("reef", state=x)
    granny, _ = ts.same_end_sequence("granny", state=x)
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
        ts.same_end_sequence("reef", state=x)
    with pytest.raises(ValueError, match="reef"):
        ts.same_end_sequence("bowline", state=x)
    with pytest.raises(ValueError, match="reef"):
        ts.double_sequence("bowline", state=x)
