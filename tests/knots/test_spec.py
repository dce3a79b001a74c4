"""Tests of knotsim.knots.spec: letter forms and parse errors of knot drawings."""

from __future__ import annotations

import pytest

from knotsim.errors import ConfigError
from knotsim.knots import geometry as G


def test_letter_forms_and_parse_errors():
    spec = G.parse_knot_spec({"name": "k", "ropes": [
        {"name": "a", "waypoints": [[0, 0], [1, 0]], "crossings": "o, U ,o u"},
        {"name": "b", "waypoints": [[0, 1], [1, 1]], "crossings": ["over", "under", "U", "O"]}]})
    assert spec.ropes[0].passes == (True, False, True, False)
    assert spec.ropes[1].passes == (True, False, False, True)
    assert spec.n_crossings == 4
    bad = [
        ({"ropes": []}, "name"),
        ({"name": "k", "ropes": []}, "ropes"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0]]}]}, "waypoints"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [0, 0], [1, 1]]}]}, "coincide"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]], "crossings": "OX"}]}, "letter"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]], "crossings": "OUO"}]}, "even"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]], "crossings": "OO"}]}, "one of each"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]]}, {"name": "a", "waypoints": [[0, 1], [1, 2]]}]}, "duplicate"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]]}],
          "loading": {"held": [{"rope": "zz", "end": "start"}]}}, "zz"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]]}],
          "loading": {"held": [{"rope": "a", "s": 1.5}]}}, "fraction"),
        ({"name": "k", "ropes": [{"name": "a", "waypoints": [[0, 0], [1, 1]]}], "defaults": {"radus": 1}}, "radus"),
    ]
    for data, msg in bad:
        with pytest.raises(ConfigError, match=msg):
            G.parse_knot_spec(data)
