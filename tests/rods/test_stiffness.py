"""Bending and torsional stiffness set independently of the axial stiffness (``RodSpec``'s
``bending_stiffness`` and ``torsional_stiffness``): the model's arrays, input errors, run files and
a closed-form cantilever."""

from __future__ import annotations

import math

import numpy as np
import pytest

import knotsim as ks
from knotsim.errors import ConfigError
from knotsim.io.config.rods import parse_rod


def _line(n=6, length=0.1):
    x = np.zeros((n, 3))
    x[:, 0] = np.linspace(0.0, length, n)
    return x


def test_defaults_are_the_solid_rod():
    rod = ks.RodSpec(_line(), radius=1e-3, youngs_modulus=2e6, density=1000.0, poisson_ratio=0.25)
    m = ks.Model([rod])
    h, E, G = 1e-3, 2e6, 2e6 / 2.5
    np.testing.assert_allclose(m.edge_EA, E * math.pi * h**2, rtol=1e-14)
    np.testing.assert_allclose(m.bend_EI, E * math.pi * h**4 / 4, rtol=1e-14)
    np.testing.assert_allclose(m.twist_GJ, G * math.pi * h**4 / 2, rtol=1e-14)
    assert rod.EA * h**2 / rod.EI == pytest.approx(4.0)


def test_arrays_honour_the_overrides():
    a = ks.RodSpec(_line(), radius=1e-3, youngs_modulus=2e6, density=1000.0, bending_stiffness=3e-7,
                   torsional_stiffness=1e-7, name="a")
    b = ks.RodSpec(_line() + [0, 0.01, 0], radius=1e-3, youngs_modulus=2e6, density=1000.0, name="b")
    m = ks.Model([a, b])
    sa, sb = slice(m.rod_bend_start[0], m.rod_bend_start[1]), slice(m.rod_bend_start[1], m.rod_bend_start[2])
    assert np.all(m.bend_EI[sa] == 3e-7) and np.all(m.twist_GJ[sa] == 1e-7)
    assert np.all(m.bend_EI[sb] == b.EI) and np.all(m.twist_GJ[sb] == b.GJ)
    np.testing.assert_allclose(m.edge_EA, 2e6 * math.pi * 1e-6, rtol=1e-14)  # the axial stiffness is untouched
    assert a.EA * a.radius**2 / a.EI == pytest.approx(2e6 * math.pi * 1e-12 / 3e-7)


@pytest.mark.parametrize("field", ["bending_stiffness", "torsional_stiffness"])
@pytest.mark.parametrize("value", [0.0, -1e-6, math.nan, math.inf, "stiff", True])
def test_bad_stiffness_names_the_field(field, value):
    rod = ks.RodSpec(_line(), radius=1e-3, youngs_modulus=2e6, density=1000.0, **{field: value})
    with pytest.raises(ConfigError) as err:
        ks.Model([rod])
    assert err.value.field == f"rods[0].{field}"


def test_run_file_rods_take_the_keys(tmp_path):
    table = {"shape": "straight", "length": 0.1, "n_nodes": 5, "radius": 1e-3, "youngs_modulus": 2e6,
             "density": 1000.0, "bending_stiffness": 2e-7, "torsional_stiffness": 1e-7}
    rod = parse_rod(table, 0, tmp_path)
    assert rod.EI == 2e-7 and rod.GJ == 1e-7
    with pytest.raises(ConfigError) as err:
        parse_rod({**table, "torsional_stiffness": -1.0}, 0, tmp_path)
    assert err.value.field == "rods[0].torsional_stiffness"


def test_cantilever_tip_drop_uses_the_bending_stiffness():
    """Small deflection under its own weight: the tip drops q L^4 / (8 EI), with EI set 250 times
    below the solid rod's (the axial stiffness keeps the solid rod's value)."""
    n, length, h, rho = 41, 0.2, 2e-3, 1000.0
    l = length / (n - 1.5)
    x = np.zeros((n, 3))
    x[:, 0] = (np.arange(n) - 0.5) * l  # the clamped first edge straddles the wall (free span L)
    solid = ks.RodSpec(x, radius=h, youngs_modulus=1e7, density=rho)
    ei = solid.EI / 250.0
    rod = ks.RodSpec(x, radius=h, youngs_modulus=1e7, density=rho, bending_stiffness=ei)
    q_line = 0.08 * ei / length**3  # weight per length: q L^3 / EI = 0.08
    model = ks.Model([rod], gravity=(0.0, 0.0, -q_line / (rho * rod.area)))
    bcs = ks.BoundaryConditions(model)
    bcs.clamp("wall", nodes=[0, 1], twist=True)
    res = ks.solve_static(model, bcs, load_steps=2)
    drop = -model.node_positions(res.state.q)[-1, 2]
    assert drop == pytest.approx(q_line * length**4 / (8 * ei), rel=1e-2)
