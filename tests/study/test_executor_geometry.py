"""Protocol cases on a geometry (a node file or an earlier run, e.g. a tied knot) in a study."""

from pathlib import Path

import pytest

import knotsim.protocols as protocols
from knotsim.errors import ConfigError
from knotsim.study.executors import protocol_executor


def _capture(monkeypatch):
    seen = {}

    def fake_run_protocol(name, **kwargs):
        seen.update(kwargs, name=name)
        return {"metrics": {"F_norm_mean": 0.5}, "outcome": "held"}

    monkeypatch.setattr(protocols, "run_protocol", fake_run_protocol)
    return seen


def test_geometry_is_resolved_against_the_study_folder(monkeypatch, tmp_path):
    seen = _capture(monkeypatch)
    out = protocol_executor({"protocol": "single-rod-bend", "geometry": "tied/reef", "overrides": {"mu": 0.2}},
                            tmp_path / "case", tmp_path / "study")
    assert seen["geometry"] == str(tmp_path / "study" / "tied" / "reef") and "knot" not in seen
    assert seen["overrides"] == {"mu": 0.2} and out["F_norm_mean"] == 0.5 and out["protocol_outcome"] == "held"
    absolute = str(Path("/data/ties/reef"))
    protocol_executor({"protocol": "single-rod-bend", "geometry": absolute}, tmp_path / "c2", tmp_path / "study")
    assert seen["geometry"] == absolute


@pytest.mark.parametrize("config, field", [
    ({"protocol": "single-rod-bend", "geometry": "a", "knot": "single_rod_reef"}, "geometry"),
    ({"protocol": "single-rod-bend", "geometry": 3}, "geometry"),
    ({"protocol": "single-rod-bend", "geometry": "a", "shape": "x"}, "shape"),
])
def test_bad_geometry_cases_name_the_field(monkeypatch, tmp_path, config, field):
    _capture(monkeypatch)
    with pytest.raises(ConfigError) as err:
        protocol_executor(config, tmp_path / "case", tmp_path)
    assert err.value.field == field
