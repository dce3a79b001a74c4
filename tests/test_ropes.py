"""Rope presets (knotsim.rods.ropes), the protocol parameter ``rope`` and ``knotsim ropes``."""

from __future__ import annotations

import math

import pytest
from click.testing import CliRunner

import knotsim as ks
from knotsim.cli import main
from knotsim.errors import ConfigError
from knotsim.protocols.pipeline import build_protocol_run
from knotsim.rods.ropes import ROPE_PRESETS, get_rope

FIELDS = ("diameter", "linear_density", "EA", "EI", "GJ", "mu", "mu_static")


@pytest.mark.parametrize("name", list(ROPE_PRESETS))
def test_preset_numbers_are_positive_cited_and_consistent(name):
    p = ROPE_PRESETS[name]
    for f in FIELDS:
        value = getattr(p, f)
        assert math.isfinite(value) and value > 0, f
        assert p.source(f).strip(), f"{f} has no source"
    assert p.mu_static >= p.mu
    # the linear density fills a plausible part of the nominal circle with a polymer of 0.9-1.5 g/cm^3
    packing_max, packing_min = p.linear_density / (900.0 * p.area), p.linear_density / (1500.0 * p.area)
    assert packing_min <= 1.0 and packing_max >= 0.4, (packing_min, packing_max)
    ratio = p.stiffness_ratio
    if name.startswith("suture"):
        assert ratio == pytest.approx(4.0)  # a monofilament is a solid rod
    else:
        assert 10.0 <= ratio <= 1e4, ratio  # a fibrous rope bends far more easily than a solid rod
    kw = p.rod_kwargs()
    rod = ks.RodSpec([[0, 0, 0], [0.01, 0, 0], [0.02, 0, 0]], **kw)
    assert rod.EA == pytest.approx(p.EA) and rod.EI == p.EI and rod.GJ == p.GJ
    assert rod.density * rod.area == pytest.approx(p.linear_density)


def test_public_api_and_unknown_name():
    assert set(ks.rope_presets()) == set(ROPE_PRESETS)
    assert isinstance(ks.rope_presets()["cord-4mm"], ks.RopePreset)
    with pytest.raises(ConfigError) as err:
        get_rope("hemp")
    assert err.value.field == "rope" and "cord-4mm" in str(err.value)


def _build(overrides, protocol="knot-security", knot="reef_bend"):
    return build_protocol_run(protocol, knot, overrides=overrides, quick=True)


def test_rope_parameter_sets_the_rods_and_friction():
    p = get_rope("cord-4mm")
    _, ctx, spec, _ = _build({"rope": "cord-4mm"})
    values = spec.data["provenance"]["parameters"]
    assert values["rope"] == "cord-4mm" and values["radius"] == p.radius and values["mu"] == p.mu
    assert values["bending_stiffness"] == p.EI and values["contact.mu_static"] == p.mu_static
    rod = spec.data["rods"][0]
    assert rod["radius"] == p.radius and rod["bending_stiffness"] == p.EI and rod["torsional_stiffness"] == p.GJ
    assert rod["youngs_modulus"] * math.pi * p.radius**2 == pytest.approx(p.EA)
    assert spec.data["contact"]["mu"] == p.mu and spec.data["contact"]["mu_static"] == p.mu_static
    assert ctx.EI == p.EI  # F h^2/EI is normalised by the rope's own EI


def test_explicit_set_wins_over_the_rope():
    _, ctx, spec, _ = _build({"rope": "cord-4mm", "mu": 0.3, "bending_stiffness": 1e-5})
    values = spec.data["provenance"]["parameters"]
    assert values["mu"] == 0.3 and values["bending_stiffness"] == 1e-5 and ctx.EI == 1e-5
    assert "contact.mu_static" not in values  # the preset's static excess goes with its own mu
    assert values["radius"] == get_rope("cord-4mm").radius


def test_no_rope_keeps_todays_rope_and_no_mu_static_without_stick():
    _, ctx, spec, _ = _build({})
    rod = spec.data["rods"][0]
    assert "bending_stiffness" not in rod and spec.data["provenance"]["parameters"]["rope"] == ""
    assert ctx.EI == pytest.approx(rod["youngs_modulus"] * math.pi * rod["radius"] ** 4 / 4)
    _, _, spec, _ = _build({"rope": "braid-pe1"}, protocol="overhand-pull", knot="overhand_n1")
    assert "mu_static" not in spec.data["contact"]  # the smooth friction law has no static coefficient


def test_unknown_rope_names_the_parameter():
    with pytest.raises(ConfigError) as err:
        _build({"rope": "hemp"})
    assert err.value.field == "rope" and "dynamic-10mm" in str(err.value)


def test_knotsim_ropes_lists_the_presets():
    res = CliRunner().invoke(main, ["ropes"])
    assert res.exit_code == 0, res.output
    for name in ROPE_PRESETS:
        assert name in res.output
    assert "EA h^2/EI" in res.output and "[DSM fact sheet]" in res.output


def test_rope_option_and_set_conflict():
    res = CliRunner().invoke(main, ["pull", "reef_bend", "--rope", "cord-4mm", "--set", "rope=braid-pe1"])
    assert res.exit_code == 2 and "rope" in res.output


def test_pull_quick_with_a_rope_runs(tmp_path):
    """A short quick run with the accessory cord goes through (its physics is not asserted here)."""
    res = CliRunner().invoke(main, ["pull", "reef_bend", "--protocol", "knot-security", "--quick", "--rope",
                                    "cord-4mm", "--set", "load_time=1", "--set", "set_until_still=false",
                                    "--no-figures", "--no-progress", "-o", str(tmp_path / "out")])
    assert res.exit_code in (0, 3), res.output
    assert "reef_bend" in res.output
