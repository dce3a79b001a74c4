"""``nodes = "all"`` and ranges wherever node (and edge) lists are taken: the Python API, run files,
and every error naming its field."""

from __future__ import annotations

import numpy as np
import pytest

from knotsim.bc import BoundaryConditions
from knotsim.errors import ConfigError
from knotsim.io.config import load_config
from knotsim.rods import Model, RodSpec
from knotsim.rods.model import expand_indices

N = 11


def make_model() -> Model:
    x = np.zeros((N, 3))
    x[:, 0] = np.linspace(0.0, 0.1, N)
    return Model([RodSpec(x, radius=1e-3, youngs_modulus=1e7, density=1000.0, name="rope")])


@pytest.mark.parametrize("spec,expected", [
    ("all", list(range(N))),
    ("0:3", [0, 1, 2]),
    ("-3:", [8, 9, 10]),
    (":2", [0, 1]),
    ("::5", [0, 5, 10]),
    ("8:2:-3", [8, 5]),
    ([0, 1, "5:8"], [0, 1, 5, 6, 7]),
    (range(2, 4), [2, 3]),
    (slice(9, None), [9, 10]),
    ([-1], [-1]),
    (4, [4]),
])
def test_expand_indices_against_python_slicing(spec, expected):
    assert expand_indices(spec, N, "rod").tolist() == expected
    if isinstance(spec, str) and spec != "all":
        parts = [int(p) if p else None for p in spec.split(":")]
        assert list(range(N))[slice(*parts)] == expected


@pytest.mark.parametrize("spec,message", [
    ("0:12", "out of range"), ("-12:", "out of range"), ("3:3", "selects nothing"), ("1:5:0", "step 0"),
    ("1-5", "expected an index"), ("everything", "expected an index"), (["0:2", "x:y"], "expected an index"),
])
def test_expand_indices_errors(spec, message):
    with pytest.raises(ConfigError, match=message) as info:
        expand_indices(spec, N, "rod 'rope' with 11 nodes")
    assert info.value.field == "nodes"


def test_api_groups_take_all_and_ranges():
    m = make_model()
    bcs = BoundaryConditions(m)
    assert bcs.hold("a", rod="rope", nodes="0:3").nodes.tolist() == [0, 1, 2]
    assert bcs.clamp("b", rod="rope", nodes=[5, "8:"]).nodes.tolist() == [5, 8, 9, 10]
    assert bcs.force("w", rod="rope", nodes="all", force=[0, 0, -1.0]).nodes.tolist() == list(range(N))
    assert bcs.moment("t", rod="rope", edges="-2:", moment=1e-3).edges.tolist() == [8, 9]
    # "all" edges of the clamp's nodes: the edges between them are clamped
    assert bcs.groups["b"].edges.tolist() == [8, 9]
    with pytest.raises(ConfigError) as info:
        bcs.hold("c", rod="rope", nodes="4:20")
    assert info.value.field == "bc.c.nodes" and "out of range for rod 'rope' with 11 nodes" in str(info.value)
    with pytest.raises(ConfigError) as info:
        bcs.moment("u", rod="rope", edges="0:11", moment=1.0)
    assert info.value.field == "bc.u.edges"
    with pytest.raises(ConfigError, match="integers"):
        bcs.hold("d", rod="rope", nodes=[0.5])


RAW = {
    "rods": [{"name": "rope", "shape": "straight", "length": 0.1, "n_nodes": N, "radius": 1e-3,
              "youngs_modulus": 1e7, "density": 1000.0}],
    "run": {"duration": 0.01},
}


@pytest.mark.parametrize("nodes,expected", [("all", list(range(N))), ("0:10", list(range(10))),
                                            ([0, 1, "5:8"], [0, 1, 5, 6, 7]), (-1, [10])])
def test_run_file_node_specs(nodes, expected):
    raw = dict(RAW, bc=[{"type": "force", "name": "w", "rod": "rope", "nodes": nodes, "force": [0, 0, -1.0]}])
    cfg = load_config(raw)
    assert cfg.build_bcs().groups["w"].nodes.tolist() == expected


@pytest.mark.parametrize("nodes,field", [("0:99", "bc[0].nodes"), ([], "bc[0].nodes"), ([0, 1.5], "bc[0].nodes[1]"),
                                         ("zz", "bc[0].nodes"), (True, "bc[0].nodes")])
def test_run_file_node_spec_errors(nodes, field):
    raw = dict(RAW, bc=[{"type": "hold", "name": "h", "rod": "rope", "nodes": nodes}])
    with pytest.raises(ConfigError) as info:
        load_config(raw)
    assert info.value.field == field
