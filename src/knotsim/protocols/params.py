"""Parameters of the loading protocols: defaults, ``--set key=value`` overrides, checking.

Keys are flat (``mu``, ``pull_speed``) or dotted into the contact and solver tables
(``contact.delta``, ``solver.max_iterations``); an unknown key raises
:class:`~knotsim.errors.ConfigError` naming it and listing the accepted ones.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from knotsim.errors import ConfigError

#: Parameters every protocol accepts (value ``None`` = taken from the knot drawing or computed).
COMMON_DEFAULTS: dict[str, Any] = {
    "n_nodes": None,          # nodes per rope (default: the knot drawing's, 301)
    "radius": None,           # rod radius h, m (default: the knot drawing's)
    "length": None,           # rope length L, m (default: the knot drawing's, 1 m)
    "youngs_modulus": 0.18e6,  # E, Pa
    "density": 1180.0,        # rho, kg/m^3
    "poisson_ratio": 0.5,
    "damping": 0.01,          # viscosity eta, Pa s (force -eta v l_voronoi)
    "gravity": 0.0,           # m/s^2 along -z (0: no gravity)
    "mu": 0.1,                # Coulomb friction coefficient
    "dt": 1e-3,               # target time step, s
    "duration": None,         # simulated time, s (None: the protocol decides)
    "output_interval": 0.1,   # trajectory frame interval, s
}

_CONTACT_KEYS = None
_SOLVER_KEYS = None


def _contact_keys() -> set[str]:
    global _CONTACT_KEYS
    if _CONTACT_KEYS is None:
        from knotsim.contact.model import ContactSettings

        _CONTACT_KEYS = {f.name for f in fields(ContactSettings)} - {"mu"}
    return _CONTACT_KEYS


def _solver_keys() -> set[str]:
    global _SOLVER_KEYS
    if _SOLVER_KEYS is None:
        from knotsim.solver.stepper import SolverSettings

        _SOLVER_KEYS = {f.name for f in fields(SolverSettings)} - {"dt"}
    return _SOLVER_KEYS


def parse_value(text: str) -> Any:
    """Value of a ``--set key=value`` string: int, float, bool (``true``/``false``), ``none``, or
    the string itself."""
    s = text.strip()
    low = s.lower()
    if low in ("true", "yes", "on"):
        return True
    if low in ("false", "no", "off"):
        return False
    if low in ("none", "null"):
        return None
    try:
        return int(s)
    except ValueError:
        pass
    try:
        return float(s)
    except ValueError:
        return s


def parse_assignments(items) -> dict[str, Any]:
    """``["mu=0.3", "contact.delta=1e-3"]`` -> ``{"mu": 0.3, "contact.delta": 0.001}``."""
    out = {}
    for item in items or ():
        if "=" not in item:
            raise ConfigError("set", f"expected key=value, got {item!r}")
        k, v = item.split("=", 1)
        k = k.strip()
        if not k:
            raise ConfigError("set", f"empty key in {item!r}")
        out[k] = parse_value(v)
    return out


def _coerce(key: str, default: Any, value: Any) -> Any:
    """Check ``value`` against the type of ``default`` (numbers stay numbers)."""
    if value is None or default is None:
        return value
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ConfigError(key, f"expected true or false, got {value!r}")
        return value
    if isinstance(default, int | float):
        if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
            raise ConfigError(key, f"expected a number, got {value!r}")
        if isinstance(default, int) and not isinstance(default, bool):
            if float(value) != int(value):
                raise ConfigError(key, f"expected an integer, got {value!r}")
            return int(value)
        return float(value)
    if isinstance(default, str) and not isinstance(value, str):
        raise ConfigError(key, f"expected a string, got {value!r}")
    return value


@dataclass
class Params:
    """Resolved parameters of a run: flat protocol keys plus ``contact`` and ``solver`` tables."""

    values: dict[str, Any]
    contact: dict[str, Any] = field(default_factory=dict)
    solver: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, key: str) -> Any:
        return self.values[key]

    def as_dict(self) -> dict[str, Any]:
        d = dict(self.values)
        d.update({f"contact.{k}": v for k, v in self.contact.items()})
        d.update({f"solver.{k}": v for k, v in self.solver.items()})
        return d


def resolve_params(defaults: Mapping[str, Any], *layers: Mapping[str, Any] | None) -> Params:
    """Apply override layers (dotted keys) on top of ``defaults`` (a flat mapping whose keys may
    include ``contact.*`` / ``solver.*`` entries). Unknown keys raise :class:`ConfigError` naming
    the key and listing the accepted ones."""
    values: dict[str, Any] = {}
    contact: dict[str, Any] = {}
    solver: dict[str, Any] = {}
    for k, v in defaults.items():
        if k.startswith("contact."):
            contact[k[8:]] = v
        elif k.startswith("solver."):
            solver[k[7:]] = v
        else:
            values[k] = v
    for layer in layers:
        for key, val in (layer or {}).items():
            if not isinstance(key, str):
                raise ConfigError(str(key), "override keys must be strings")
            if key in ("contact.mu",):
                key = "mu"
            if key.startswith("contact."):
                sub = key[8:]
                if sub not in _contact_keys():
                    raise ConfigError(key, f"unknown contact setting; known: "
                                           f"{', '.join('contact.' + s for s in sorted(_contact_keys()))}")
                contact[sub] = val
            elif key.startswith("solver."):
                sub = key[7:]
                if sub not in _solver_keys():
                    raise ConfigError(key, f"unknown solver setting; known: "
                                           f"{', '.join('solver.' + s for s in sorted(_solver_keys()))}")
                solver[sub] = val
            elif key in values:
                values[key] = _coerce(key, defaults.get(key), val)
            else:
                raise ConfigError(key, f"unknown parameter; known: {', '.join(sorted(values))}, "
                                       "contact.<setting>, solver.<setting>")
    return Params(values, contact, solver)
