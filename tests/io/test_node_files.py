"""Node files read exactly: .mat matrices by name (or an unambiguous file), ropes named after them,
text files with several ropes as blank-line separated blocks, and errors that list what a file holds."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.io import savemat

from knotsim.cli.protocols import pull
from knotsim.errors import ConfigError
from knotsim.io.geometry import read_node_file, read_node_ropes
from knotsim.protocols.pipeline import build_protocol_run
from knotsim.runspec import RunSpec, build_run


def _rope(n: int, y: float = 0.0, length: float = 0.2) -> np.ndarray:
    """``(n, 3)`` straight rope along x at height y (m)."""
    return np.column_stack([np.linspace(0.0, length, n), np.full(n, y), np.zeros(n)])


def _mat(path, **matrices):
    savemat(path, matrices)
    return path


def test_mat_ropes_are_named_after_their_matrices_and_transposed(tmp_path):
    f = _mat(tmp_path / "two.mat", A=_rope(125).T, B=_rope(91, 0.01), L=np.array([[1.0]]))
    nodes = read_node_ropes(f)
    assert nodes.names == ["A", "B"]  # L (1x1) is not a rope candidate and is left alone
    assert [x.shape for x in nodes.ropes] == [(125, 3), (91, 3)]
    np.testing.assert_array_equal(nodes.ropes[1], _rope(91, 0.01))
    assert "L (1x1)" in nodes.found and "A (3x125)" in nodes.found
    # chosen by name, in the order given
    assert read_node_ropes(f, matrices=["B", "A"]).names == ["B", "A"]


@pytest.mark.parametrize("stray,why", [(np.eye(3), "rows or columns could be the nodes"),
                                       (_rope(2).T, "fewer than 4 nodes")])
def test_ambiguous_mat_file_is_refused_listing_every_matrix(tmp_path, stray, why):
    f = _mat(tmp_path / "odd.mat", A=_rope(40).T, B=_rope(30, 0.01).T, C=stray)
    with pytest.raises(ConfigError) as err:
        read_node_ropes(f, field="geometry", choose="choose with --matrices A,B")
    msg = str(err.value)
    assert err.value.field == "geometry"
    assert why in msg and f"C ({'x'.join(map(str, stray.shape))}" in msg
    assert "A (3x40)" in msg and "B (3x30)" in msg and "--matrices A,B" in msg
    # naming the ropes removes the doubt
    assert [x.shape for x in read_node_file(f, matrices=["A", "B"])] == [(40, 3), (30, 3)]


def test_mat_matrix_errors(tmp_path):
    f = _mat(tmp_path / "m.mat", A=_rope(10).T, T=np.eye(3))
    with pytest.raises(ConfigError, match=r"has no matrix 'Z'.*A \(3x10\)"):
        read_node_ropes(f, matrices=["A", "Z"])
    with pytest.raises(ConfigError, match="3x3"):
        read_node_ropes(f, matrices=["T"])
    with pytest.raises(ConfigError, match="twice"):
        read_node_ropes(f, matrices=["A", "A"])
    g = _mat(tmp_path / "none.mat", M=np.ones((5, 5)))
    with pytest.raises(ConfigError, match=r"holds no \(3, N\).*M \(5x5\)"):
        read_node_ropes(g)
    txt = tmp_path / "r.txt"
    txt.write_text("0 0 0\n1 0 0\n")
    with pytest.raises(ConfigError, match=".mat files only"):
        read_node_ropes(txt, matrices=["A"])


def _block(x: np.ndarray, sep: str = " ") -> str:
    return "\n".join(sep.join(repr(float(v)) for v in row) + f"{sep}0.0" for row in x)  # 4th column ignored


def test_text_file_blocks_are_ropes(tmp_path):
    a, b = _rope(12), _rope(7, 0.01)
    f = tmp_path / "two.txt"
    f.write_text(f"# two ropes\n\n# rope: left\n{_block(a)}\n\n\n# rope: right\n{_block(b)}\n\n")
    nodes = read_node_ropes(f)
    assert nodes.names == ["left", "right"]
    np.testing.assert_array_equal(nodes.ropes[0], a)
    np.testing.assert_array_equal(nodes.ropes[1], b)
    # unnamed blocks are numbered; a csv block may start with a header line
    g = tmp_path / "two.csv"
    g.write_text(f"x,y,z,theta\n{_block(a, ',')}\n\nx,y,z,theta\n{_block(b, ',')}\n")
    assert read_node_ropes(g).names == ["rope0", "rope1"]
    # one block (blank lines only around it) is one rope named 'rope'
    h = tmp_path / "one.dat"
    h.write_text(f"\n\n{_block(a)}\n\n")
    one = read_node_ropes(h)
    assert one.names == ["rope"] and one.ropes[0].shape == (12, 3)


def test_text_file_errors_name_the_line(tmp_path):
    f = tmp_path / "bad.txt"
    f.write_text("0 0 0\n1 0 0\n2 x 0\n")
    with pytest.raises(ConfigError, match="line 3"):
        read_node_ropes(f)
    f.write_text("0 0 0\n1 0 0 5\n")
    with pytest.raises(ConfigError, match="line 2: 4 columns"):
        read_node_ropes(f)
    f.write_text("# rope: a\n0 0 0\n1 0 0\n\n# rope: a\n0 1 0\n1 1 0\n")
    with pytest.raises(ConfigError, match="same name"):
        read_node_ropes(f)
    n = tmp_path / "ropes.npy"
    np.save(n, np.stack([_rope(5), _rope(5, 0.01)]))
    with pytest.raises(ConfigError, match=r"expected an \(N, 3\) table.*\(2, 5, 3\)"):
        read_node_ropes(n)


def test_run_file_picks_one_rope_of_a_file(tmp_path):
    a, b = _rope(12), _rope(7, 0.01)
    f = tmp_path / "two.txt"
    f.write_text(f"# rope: left\n{_block(a)}\n\n# rope: right\n{_block(b)}\n")
    base = {"radius": 1e-3, "youngs_modulus": 1e6, "density": 1000.0, "shape": "points", "file": str(f)}
    spec = {"rods": [dict(base, name="p", rope="right"), dict(base, name="q", rope=0)],
            "run": {"duration": 0.001}, "solver": {"dt": 1e-3}}
    sim, cfg = build_run(RunSpec.from_dict(spec))
    np.testing.assert_array_equal(cfg.model.rod_positions(sim.state.q, 0), b)
    np.testing.assert_array_equal(cfg.model.rod_positions(sim.state.q, 1), a)
    with pytest.raises(ConfigError, match=r"rods\[0\]\.file.*2 ropes.*left \(12 nodes\), right \(7 nodes\).*rope ="):
        build_run(RunSpec.from_dict(dict(spec, rods=[dict(base, name="p")])))
    with pytest.raises(ConfigError, match=r"rods\[0\]\.rope.*no rope 'middle'"):
        build_run(RunSpec.from_dict(dict(spec, rods=[dict(base, name="p", rope="middle")])))


def _bend_mat(tmp_path, **extra):
    """Two ropes of the library reef bend (as Patil's files: (3, N) matrices A and B) plus ``extra``."""
    from knotsim.knots.library import get_knot

    geo = get_knot("reef_bend", n_nodes=61)
    return _mat(tmp_path / "bend.mat", A=geo.ropes[0].T, B=geo.ropes[1].T, **extra)


def test_protocol_reads_the_chosen_matrices_and_says_what_it_found(tmp_path):
    f = _bend_mat(tmp_path, C=_rope(40, 0.5).T)
    # the default rule takes three ropes: two-rope-bend is refused with the count, the file and the names
    with pytest.raises(ConfigError) as err:
        build_protocol_run("two-rope-bend", geometry=str(f), overrides={"radius": 2e-3})
    msg = str(err.value)
    assert err.value.field == "protocol"
    assert "3 ropes in" in msg and "bend.mat" in msg and "A: 61 nodes, B: 61 nodes, C: 40 nodes" in msg
    assert "--matrices A,B" in msg
    _, ctx, spec, _ = build_protocol_run("two-rope-bend", geometry=str(f),
                                         overrides={"radius": 2e-3, "geometry_matrices": "A,B"})
    assert ctx.geometry.rope_names == ["A", "B"]
    assert [r["name"] for r in spec.data["rods"]] == ["A", "B"]
    assert ctx.params["geometry_matrices"] == "A,B"
    # a list works from Python, the ends may name the ropes
    _, ctx2, _, _ = build_protocol_run("two-rope-bend", geometry=str(f),
                                       overrides={"radius": 2e-3, "geometry_matrices": ["B", "A"],
                                                  "held_end": "A:-1", "pulled_end": "B:0"})
    assert ctx2.geometry.rope_names == ["B", "A"] and ctx2.plan.ends.held.rope == 1
    with pytest.raises(ConfigError, match="geometry_matrices.*library knot"):
        build_protocol_run("two-rope-bend", "reef_bend", overrides={"geometry_matrices": "A,B"})


def test_pull_matrices_option(tmp_path):
    f = _bend_mat(tmp_path, C=np.eye(3))
    run = CliRunner()
    out = str(tmp_path / "o")
    # ambiguous without --matrices: one error line listing the matrices and the option
    res = run.invoke(pull, ["--geometry", str(f), "--set", "radius=0.002", "-o", out])
    assert res.exit_code == 2
    assert "C (3x3" in res.output and "--matrices A,B" in res.output, res.output
    # --matrices reaches the reader (a missing name is reported), and the protocol is inferred from
    # the chosen ropes (the run then stops at the bad key, before anything is simulated)
    res = run.invoke(pull, ["--geometry", str(f), "--matrices", "A,Z", "-o", out, "--overwrite"])
    assert res.exit_code == 2 and "has no matrix 'Z'" in res.output, res.output
    res = run.invoke(pull, ["--geometry", str(f), "--matrices", "A,B", "--set", "no_such_key=1", "-o", out,
                            "--overwrite"])
    assert res.exit_code == 2 and "no_such_key" in res.output, res.output
    res = run.invoke(pull, ["reef_bend", "--matrices", "A,B", "-o", out, "--overwrite"])
    assert res.exit_code == 2 and "--geometry" in res.output, res.output
