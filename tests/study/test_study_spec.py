"""Study files: parsing, expansion (grid, zip, explicit cases, repeats), case hashes, errors."""

from __future__ import annotations

import tomllib

import pytest

from knotsim.errors import ConfigError
from knotsim.study.spec import dumps_toml, load_study_spec, parse_key, set_key

BASE = {
    "rods": [{"name": "rope", "shape": "straight", "length": 0.1, "n_nodes": 11, "radius": 1e-3,
              "youngs_modulus": 1e7, "density": 1000.0}],
    "bc": [{"type": "move", "name": "left", "nodes": [0, 1], "velocity": [-1e-3, 0.0, 0.0]},
           {"type": "move", "name": "right", "nodes": [-2, -1], "velocity": [1e-3, 0.0, 0.0]}],
    "run": {"duration": 0.1},
}


def study(**kw):
    return {"name": "t", "base": BASE, **kw}


def test_parse_and_set_key():
    assert parse_key("bc[1].velocity[0]") == ["bc", 1, "velocity", 0]
    tree = {"a": [{"b": 1}], "c": {}}
    set_key(tree, "a[0].b", 2)
    set_key(tree, "a[-1].x.y", 3)  # missing tables are created
    set_key(tree, "c.d", [1, 2])
    assert tree == {"a": [{"b": 2, "x": {"y": 3}}], "c": {"d": [1, 2]}}
    for bad in ("", "a..b", "a.", "[0]", "a[x]", "a b"):
        with pytest.raises(ConfigError):
            parse_key(bad)


def test_grid_is_cartesian_product():
    s = load_study_spec(study(grid={"rods[0].youngs_modulus": [1e6, 1e7, 1e8], "bc[1].velocity[0]": [1e-3, 2e-3]}))
    cases = s.expand()
    assert len(cases) == 6
    assert [c.params for c in cases[:2]] == [{"rods[0].youngs_modulus": 1e6, "bc[1].velocity[0]": 1e-3},
                                             {"rods[0].youngs_modulus": 1e6, "bc[1].velocity[0]": 2e-3}]
    assert cases[5].config["rods"][0]["youngs_modulus"] == 1e8
    assert cases[5].config["bc"][1]["velocity"] == [2e-3, 0.0, 0.0]
    assert BASE["rods"][0]["youngs_modulus"] == 1e7  # the base is not modified
    assert len({c.case_id for c in cases}) == 6
    assert all(c.kind == "run" for c in cases)


def test_zip_cases_and_repeats():
    s = load_study_spec(study(
        zip=[{"solver.dt": [1e-2, 5e-3], "run.output_interval": [1e-2, 5e-3]}],
        cases=[{"model.damping": 0.0}, {"model.damping": 0.1, "run.duration": 0.2}],
        repeats=2))
    cases = s.expand()
    assert len(cases) == 2 * 2 * 2
    assert s.swept_keys == ["solver.dt", "run.output_interval", "model.damping", "run.duration"]
    c = cases[-1]
    assert c.params == {"solver.dt": 5e-3, "run.output_interval": 5e-3, "model.damping": 0.1,
                        "run.duration": 0.2, "repeat": 1}
    assert c.config["solver"]["dt"] == 5e-3 and c.config["run"]["output_interval"] == 5e-3
    assert cases[0].params["run.duration"] is None  # not set by that explicit case
    assert cases[0].case_id != cases[1].case_id  # repeats are distinct cases
    assert cases[0].config == cases[1].config


def test_case_ids_depend_only_on_resolved_config():
    a = load_study_spec(study(grid={"rods[0].youngs_modulus": [1e6, 1e7]})).expand()
    b = load_study_spec(study(grid={"rods[0].youngs_modulus": [1e7, 1e8], "solver.dt": [1e-2]})).expand()
    # 1e7 with the default dt vs 1e7 with an explicit dt: different configurations
    assert a[1].case_id != b[0].case_id
    c = load_study_spec(study(grid={"rods[0].youngs_modulus": [1e8, 1e7]})).expand()
    assert c[1].case_id == a[1].case_id  # same resolved configuration, same id, in any order


def test_protocol_cases():
    s = load_study_spec({"base": {"protocol": "single-rod-bend", "knot": "single_rod_reef",
                                  "overrides": {"mu": 0.1}},
                         "grid": {"knot": ["single_rod_granny", "single_rod_reef"], "overrides.mu": [0.1, 0.5]}})
    cases = s.expand()
    assert len(cases) == 4 and all(c.kind == "protocol" for c in cases)
    assert cases[1].config == {"protocol": "single-rod-bend", "knot": "single_rod_granny", "overrides": {"mu": 0.5}}


@pytest.mark.parametrize("kw, field", [
    ({"grid": {"rods[3].radius": [1e-3]}}, "grid.rods[3].radius"),
    ({"grid": {"rods[0].radius": []}}, "grid.rods[0].radius"),
    ({"grid": {"rods[0].radius": 1e-3}}, "grid.rods[0].radius"),
    ({"grid": {"run.duration[0]": [1.0]}}, "grid.run.duration[0]"),
    ({"grid": {"rods..radius": [1.0]}}, "grid.rods..radius"),
    ({"zip": [{"solver.dt": [1e-2, 5e-3], "run.duration": [1.0]}]}, "zip[0]"),
    ({"cases": [{"bc[7].velocity": [0, 0, 0]}]}, "cases[0].bc[7].velocity"),
    ({"grid": {"solver.dt": [1e-2, 5e-3]}, "zip": [{"solver.dt": [1e-3]}]}, "solver.dt"),
    ({"grid": {"solver.dt": [1e-2, 1e-2]}}, "sweep"),
    ({"repeats": 0}, "repeats"),
    ({"sweep": {}}, "sweep"),
])
def test_bad_axes_name_the_axis(kw, field):
    with pytest.raises(ConfigError) as info:
        load_study_spec(study(**kw)).expand()
    assert info.value.field == field
    assert field in str(info.value)


def test_missing_base_and_base_file(tmp_path):
    with pytest.raises(ConfigError, match="base"):
        load_study_spec({"grid": {}})
    (tmp_path / "run.toml").write_text(dumps_toml(BASE))
    (tmp_path / "s.toml").write_text('base = "run.toml"\n[grid]\n"rods[0].youngs_modulus" = [1e6, 2e6]\n')
    s = load_study_spec(tmp_path / "s.toml")
    assert s.name == "s" and s.base == BASE and len(s.expand()) == 2


def test_toml_writer_round_trip():
    doc = study(grid={"rods[0].youngs_modulus": [1e6, 1e7]}, zip=[{"solver.dt": [1e-2, 5e-3]}],
                cases=[{"model.damping": 0.0}])
    assert tomllib.loads(dumps_toml(doc)) == doc


def test_shipped_study_files_expand_to_valid_cases():
    """Every study file in examples/studies/ loads, expands, and each protocol case names a known
    protocol and knot and only parameters that protocol accepts (a typo fails here, not hours into
    a study)."""
    from pathlib import Path

    from knotsim.knots.library import load_knot_spec
    from knotsim.protocols import get_protocol
    from knotsim.protocols.params import COMMON_DEFAULTS, resolve_params
    from knotsim.study.spec import load_study_spec

    files = sorted((Path(__file__).resolve().parents[2] / "examples" / "studies").glob("*.toml"))
    assert len(files) >= 6
    for f in files:
        cases = load_study_spec(f).expand()
        assert cases, f
        for c in cases:
            if c.kind != "protocol":
                continue
            proto = get_protocol(c.config["protocol"])
            load_knot_spec(c.config.get("knot") or proto.default_knot)
            defaults = {**COMMON_DEFAULTS, **proto.defaults}
            resolve_params(defaults, c.config.get("overrides") or {})


def test_results_of_numbers_and_text_in_one_column_are_written(tmp_path):
    """A setting swept over numbers and the text "none" (unset) goes into results.parquet as text."""
    import pandas as pd

    from knotsim.study.store import results_frame

    cases = [{"case_id": "a", "kind": "protocol", "params": {"overrides.contact.stick_distance": 1e-4}},
             {"case_id": "b", "kind": "protocol", "params": {"overrides.contact.stick_distance": "none"}},
             {"case_id": "c", "kind": "protocol", "params": {"overrides.contact.stick_distance": None}}]
    records = {c["case_id"]: {"outcome": "completed", "metrics": {"slip_load": 0.01, "friction_model": "surface"}}
               for c in cases}
    df = results_frame(cases, records)
    df.to_parquet(tmp_path / "r.parquet")
    col = list(df["overrides.contact.stick_distance"])
    assert col[:2] == ["0.0001", "none"] and pd.isna(col[2])
