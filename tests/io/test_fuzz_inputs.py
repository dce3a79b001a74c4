"""Fuzz test of the input layer: run files, protocol parameters and node files, generated at random
(valid and broken) and fed through the loaders. Every outcome is a run (or a built run) or one clear
error line; never a traceback.

Hypothesis draws the cases; ``derandomize=True`` makes the draws the same on every machine, so a
failure in CI reproduces locally.
"""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomli_w
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from knotsim.cli import main
from knotsim.errors import KnotsimError

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
RUN_FILES = sorted(p for p in EXAMPLES.glob("*.toml"))

#: values that break a field's type or range (TOML can hold all of them)
NASTY = [0, -1, 1, 2, 3, 2**62, 0.0, -1e-3, 1e300, -1e300, math.nan, math.inf, -math.inf, "", "abc", "1e-3",
         "-1", True, False, [], [0.0], [1.0, 2.0], [[1.0, 2.0, 3.0]], ["a", "b"], {}, {"x": 1}]

FUZZ = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def _one_clear_error_line(message: str, alone: bool = True) -> None:
    """An error is one line: ``error: <field>: <what and how to fix>``, no traceback; with ``alone``
    (bad input: no run started) nothing comes before it."""
    lines = [ln for ln in message.splitlines() if ln.strip()]
    assert "Traceback" not in message, message
    errors = [ln for ln in lines if ln.startswith("error: ")]
    assert len(errors) == 1, message
    if alone:
        assert lines == errors, f"an input error must be printed alone:\n{message}"
    assert len(errors[0]) > len("error: ") + 10, message


def _paths(obj, prefix=()):
    """Every (path, value) of a nested dict/list of a parsed run file."""
    out = [(prefix, obj)]
    if isinstance(obj, dict):
        for k, v in obj.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            out += _paths(v, prefix + (i,))
    return out


def _set(obj, path, value):
    for key in path[:-1]:
        obj = obj[key]
    if value is _DELETE:
        del obj[path[-1]]
    else:
        obj[path[-1]] = value


_DELETE = object()


@st.composite
def mutated_run_file(draw):
    """An example run file with one to three random mutations (value replaced by a nasty one, key
    deleted, unknown key added), or its text cut or garbled."""
    path = draw(st.sampled_from(RUN_FILES))
    text = path.read_text()
    kind = draw(st.sampled_from(["mutate", "mutate", "mutate", "cut", "garble", "valid"]))
    if kind == "valid":
        return path.name, text
    if kind == "cut":
        return path.name, text[:draw(st.integers(0, len(text)))]
    if kind == "garble":
        i = draw(st.integers(0, len(text)))
        return path.name, text[:i] + draw(st.sampled_from(["[[", "= =", '"', "\x00", "]]\n[rods]\n", "=1\n"])) + text[i:]
    data = tomllib.loads(text)
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p, _ in _paths(data) if p]
        p = draw(st.sampled_from(paths))
        action = draw(st.sampled_from(["replace", "replace", "delete", "add"]))
        try:
            if action == "replace":
                _set(data, p, copy.deepcopy(draw(st.sampled_from(NASTY))))
            elif action == "delete" and isinstance(p[-1], str):
                _set(data, p, _DELETE)
            else:
                parent = data
                for key in p[:-1]:
                    parent = parent[key]
                if isinstance(parent, dict):
                    parent["no_such_key"] = 1
        except (KeyError, IndexError, TypeError):
            pass
    try:
        return path.name, tomli_w.dumps(data)
    except (TypeError, ValueError):  # a value TOML cannot hold at that place
        return path.name, text


@FUZZ
@given(case=mutated_run_file())
def test_run_files(case, tmp_path_factory):
    """``knotsim run FILE --duration`` (a few steps): a run, or one error line (exit 2 for bad input,
    3 for a run that fails)."""
    name, text = case
    d = tmp_path_factory.mktemp("fuzz_run")
    f = d / name
    f.write_text(text)
    res = CliRunner().invoke(main, ["run", str(f), "-o", str(d / "out"), "--duration", "0.004", "-q"])
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise AssertionError(f"traceback for {name}:\n{text}") from res.exception
    assert res.exit_code in (0, 2, 3), (res.exit_code, res.output)
    if res.exit_code:
        _one_clear_error_line(res.stderr, alone=res.exit_code == 2)


# ---------------------------------------------------------------- node files
@st.composite
def node_file(draw, tmp: Path):
    """A node file of a random format holding a random table (valid or broken)."""
    fmt = draw(st.sampled_from(["txt", "csv", "npy", "mat", "mat", "bytes"]))
    rows = draw(st.integers(0, 6))
    cols = draw(st.integers(0, 5))
    values = draw(st.lists(st.one_of(st.floats(-1.0, 1.0), st.sampled_from([math.nan, math.inf, 1e300])),
                           min_size=rows * cols, max_size=rows * cols))
    a = np.array(values, float).reshape(rows, cols)
    f = tmp / f"nodes.{fmt if fmt != 'bytes' else draw(st.sampled_from(['txt', 'csv', 'npy', 'mat']))}"
    if fmt == "txt":
        np.savetxt(f, a)
        if draw(st.booleans()):
            f.write_text("x y z\n" + f.read_text())
    elif fmt == "csv":
        np.savetxt(f, a, delimiter=",")
    elif fmt == "npy":
        np.save(f, a if draw(st.booleans()) else a.astype(str) if a.size else np.array(["a"]))
    elif fmt == "mat":
        from scipy.io import savemat

        mats = {"rope_a": a}
        if draw(st.booleans()):
            mats["rope_b"] = np.array(draw(st.lists(st.floats(-1, 1), min_size=3 * 4, max_size=3 * 4))).reshape(3, 4)
        if draw(st.booleans()):
            mats["label"] = np.array(["knot"])
        savemat(f, mats)
    else:
        f.write_bytes(draw(st.binary(max_size=64)))
    matrices = draw(st.sampled_from([None, None, ["rope_a"], ["rope_b"], ["nope"], ["rope_a", "rope_b"]]))
    return f, (matrices if f.suffix == ".mat" else None)


@settings(max_examples=80, deadline=None, derandomize=True, database=None)
@given(data=st.data())
def test_node_files(data, tmp_path_factory):
    """``read_node_file``: ropes of finite (N, 3) positions with N >= 2, or one clear error line."""
    from knotsim.io.geometry import read_node_file

    f, matrices = data.draw(node_file(tmp_path_factory.mktemp("fuzz_nodes")))
    try:
        ropes = read_node_file(f, matrices=matrices)
    except KnotsimError as exc:
        msg = str(exc)
        assert msg and "\n" not in msg and "Traceback" not in msg
        return
    assert ropes
    for x in ropes:
        assert x.ndim == 2 and x.shape[1] == 3 and x.shape[0] >= 2 and np.all(np.isfinite(x))


@pytest.mark.parametrize("text", ["", "\n", "# only a comment\n", "1 2\n3 4\n", "1 2 3\n", "a b c\nd e f\n",
                                  "1 2 3\n4 5 6\n7 8\n", "1,2,3\n4,5,6\n"])
def test_node_file_edge_cases(tmp_path, text):
    from knotsim.io.geometry import read_node_file

    f = tmp_path / "nodes.txt"
    f.write_text(text)
    try:
        ropes = read_node_file(f)
    except KnotsimError as exc:
        assert "\n" not in str(exc) and str(f) in str(exc)
        return
    assert all(x.shape[1] == 3 and x.shape[0] >= 2 for x in ropes)


# ---------------------------------------------------------------- protocol parameters
#: strings a user may type after ``--set key=`` (parsed by the command line's own rules)
TYPED = ["abc", "", "-1", "0", "1", "2.5", "1e-3", "1e400", "nan", "inf", "-inf", "true", "false", "[1, 2]", "[]",
         "0:-1", "1:-1", "0:0", "5:3", "centreline", "surface", "clamped", "free", "{}", "'x'", "1,2", "\x00"]
PROTOCOL_KNOTS = [("overhand-pull", "overhand_n1"), ("single-rod-bend", "single_rod_reef"),
                  ("two-rope-bend", "reef_bend")]
#: keys that only change the cost of a run, kept at their quick values so that valid draws stay cheap
_COSTLY = {"n_nodes", "length", "duration", "output_interval"}


@st.composite
def protocol_assignments(draw):
    from knotsim.protocols.params import protocol_defaults
    from knotsim.protocols.registry import get_protocol

    protocol, knot = draw(st.sampled_from(PROTOCOL_KNOTS))
    keys = sorted(k for k in protocol_defaults(get_protocol(protocol)) if k not in _COSTLY)
    keys += ["contact.delta", "contact.friction_model", "contact.stiffness_scaler", "no_such_key", "mu.x"]
    items = [f"{k}={draw(st.sampled_from(TYPED))}" for k in draw(st.lists(st.sampled_from(keys), max_size=3))]
    if draw(st.integers(0, 9)) == 0:
        items.append(draw(st.sampled_from(["novalue", "=1", " = 2"])))
    return protocol, knot, items


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(case=protocol_assignments())
def test_protocol_parameters(case):
    """``--set`` assignments through the parser, the protocol's run description, the run file check,
    the simulation build and a first step: all pass, or one clear error line."""
    from knotsim.protocols.params import parse_assignments
    from knotsim.protocols.pipeline import build_protocol_run
    from knotsim.runspec import build_run, check_run

    protocol, knot, items = case
    try:
        overrides = parse_assignments(items)
        _, _, spec, _ = build_protocol_run(protocol, knot, overrides=overrides, quick=True)
        sim, _ = build_run(check_run(spec))
        sim.step()
    except KnotsimError as exc:
        msg = str(exc)
        assert msg and "\n" not in msg and "Traceback" not in msg, (items, msg)
