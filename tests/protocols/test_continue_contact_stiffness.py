"""A protocol continuing an earlier run starts its adaptive contact stiffness from that run's."""

from pathlib import Path

import numpy as np
import pytest

from knotsim.contact.model import Contact, ContactOptions
from knotsim.errors import ConfigError
from knotsim.io.checkpoint import read_checkpoint
from knotsim.protocols.pipeline import build_protocol_run
from knotsim.rods import Model, RodSpec

TIED_REEF = Path(__file__).resolve().parents[2] / "docs" / "studies" / "granny_vs_reef_mu_tied" / "tied_reef"


def _rod_model():
    x = np.zeros((11, 3))
    x[:, 0] = np.linspace(0.0, 0.1, 11)
    return Model([RodSpec(x, radius=1e-3, youngs_modulus=1e6, density=1000.0)])


def test_initial_stiffness_starts_the_adaptive_stiffness_but_not_below_the_floor():
    m = _rod_model()
    floor = Contact(m, ContactOptions(mu=0.0)).k_c
    assert Contact(m, ContactOptions(mu=0.0, initial_stiffness=10 * floor)).k_c == pytest.approx(10 * floor)
    assert Contact(m, ContactOptions(mu=0.0, initial_stiffness=0.1 * floor)).k_c == pytest.approx(floor)
    with pytest.raises(ConfigError) as err:
        ContactOptions(mu=0.0, initial_stiffness=-1.0).validate()
    assert "initial_stiffness" in err.value.field


def test_pull_from_a_tie_directory_starts_from_the_ties_contact_stiffness():
    k_tie = read_checkpoint(TIED_REEF / "checkpoint.npz").section("interaction/contact")[0]["k_c"]
    _, _, spec, _ = build_protocol_run("single-rod-bend", geometry=str(TIED_REEF), overrides={"mu": 0.3})
    assert spec.data["contact"]["initial_stiffness"] == pytest.approx(k_tie) and k_tie > 1e4
    _, _, spec2, _ = build_protocol_run("single-rod-bend", geometry=str(TIED_REEF),
                                        overrides={"mu": 0.3, "contact.initial_stiffness": 123.0})
    assert spec2.data["contact"]["initial_stiffness"] == 123.0  # the user's value wins
    _, _, spec3, _ = build_protocol_run("single-rod-bend", knot="single_rod_reef")
    assert "initial_stiffness" not in spec3.data["contact"]  # a drawing starts from the floor
