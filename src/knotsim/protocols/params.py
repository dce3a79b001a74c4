"""Parameters of the loading protocols: defaults, ``--set key=value`` overrides, checking.

Keys are flat (``mu``, ``pull_speed``) or dotted into the contact and solver tables
(``contact.delta``, ``solver.max_iterations``); an unknown key raises
:class:`~knotsim.errors.ConfigError` naming it and listing the accepted ones.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from knotsim._util.validate import describe, is_number, number
from knotsim.errors import ConfigError

#: Parameters every protocol accepts (value ``None`` = taken from the knot drawing or computed).
COMMON_DEFAULTS: dict[str, Any] = {
    "n_nodes": None,          # nodes per rope (default: the knot drawing's, 301)
    "radius": None,           # rod radius h, m (default: the knot drawing's)
    "length": None,           # rope length L, m (default: the knot drawing's, 1 m)
    "post_radius": None,      # m, the post a hitch or a loop is tied round (default: the knot drawing's)
    "youngs_modulus": 0.18e6,  # E, Pa
    "density": 1180.0,        # rho, kg/m^3
    "poisson_ratio": 0.5,
    "bending_stiffness": None,  # EI, N m^2 (None: the solid rod's E pi h^4 / 4)
    "torsional_stiffness": None,  # GJ, N m^2 (None: the solid rod's G pi h^4 / 2)
    "rope": "",               # a rope preset (knotsim ropes) setting the material and friction ("": none)
    "damping": 0.01,          # viscosity eta, Pa s (force -eta v l_voronoi)
    "gravity": 0.0,           # m/s^2 along -z (0: no gravity)
    "mu": 0.1,                # Coulomb friction coefficient
    "dt": 1e-3,               # target time step, s
    "duration": None,         # simulated time, s (None: the protocol decides)
    "output_interval": 0.1,   # trajectory frame interval, s
    "geometry_scale": 1.0,    # factor from a node file's units to m (geometry sources only)
    "geometry_matrices": "",  # names of a .mat node file's rope matrices, "A,B" ("": the file's rule)
    "ramp_time": 0.0,         # s over which the pull speed grows from 0 (0: abrupt start, as published)
    "settle_time": 0.0,       # s the loaded ends are held still before the loading starts (0: none, as published)
}

#: Unit and one-line meaning of every protocol parameter (of :data:`COMMON_DEFAULTS` and of each
#: protocol's ``defaults``; ``tests/protocols/test_protocol_cli.py`` checks that none is missing).
#: ``"-"``: dimensionless; ``"text"``: a word or name.
PARAM_INFO: dict[str, tuple[str, str]] = {
    # common to every protocol
    "n_nodes": ("-", "nodes per rope (none: the knot drawing's)"),
    "radius": ("m", "rod radius h (none: the knot drawing's)"),
    "post_radius": ("m", "radius of the post a hitch or a loop is tied round (none: the knot drawing's)"),
    "length": ("m", "rope length L (none: the knot drawing's)"),
    "youngs_modulus": ("Pa", "Young's modulus E"),
    "density": ("kg/m^3", "mass density rho"),
    "poisson_ratio": ("-", "Poisson ratio (shear modulus G = E / (2 (1 + nu)))"),
    "bending_stiffness": ("N m^2", "bending stiffness EI, independent of the axial stiffness E pi h^2 (none: the solid "
                                   "rod's E pi h^4 / 4)"),
    "torsional_stiffness": ("N m^2", "torsional stiffness GJ (none: the solid rod's G pi h^4 / 2)"),
    "rope": ("text", "a rope preset (knotsim ropes lists them): sets radius, density, youngs_modulus (its EA / "
                     "pi h^2), bending_stiffness, torsional_stiffness, mu and (elastic-stick law, the preset's "
                     "mu) contact.mu_static; a key given with --set wins (empty: none)"),
    "damping": ("Pa s", "viscosity eta of the viscous force -eta v l_voronoi"),
    "gravity": ("m/s^2", "gravitational acceleration along -z (0: none)"),
    "mu": ("-", "Coulomb friction coefficient"),
    "dt": ("s", "target time step (the stepper halves it on failure and grows it back)"),
    "duration": ("s", "simulated time after any settle_time (none: the protocol computes it)"),
    "output_interval": ("s", "time between trajectory frames"),
    "geometry_scale": ("-", "factor from a --geometry node file's units to m (geometry sources only)"),
    "geometry_matrices": ("text", "the rope matrices of a --geometry .mat file, in order, e.g. A,B (empty: every "
                                  "3 x N or N x 3 matrix; an ambiguous file is refused); the ropes take their names"),
    "ramp_time": ("s", "the pull speed grows linearly from 0 over this time (0: the abrupt start of the published set-ups)"),
    "settle_time": ("s", "the loaded ends are held still this long before the loading starts, while the drawn knot "
                         "settles and its start-up ringing dies down; metrics count from the end (0: none, as published)"),
    "contact.delta": ("m", "contact distance tolerance of the IMC potential"),
    "contact.nu": ("m/s", "slip speed below which friction is smoothed (sticking)"),
    # pulling
    "pull_speed": ("m/s", "speed of each pulled end"),
    "e_final": ("m", "overhand pull: stop when the shortening e = L - end-to-end reaches this"),
    "mean_window": ("s", "single-rod bend: length of the measured pull (mean and peak window)"),
    "hold_time": ("s", "single-rod bend: how long the held node stays held (none: the whole run)"),
    "hold_nodes": ("-", "single-rod bend: consecutive nodes held, centred on the knot's hold hint (odd)"),
    "pre_pull": ("m", "single-rod bend: end separation added before the measured pull (0: none)"),
    "pre_pull_speed": ("m/s", "single-rod bend: speed per end during the pre-pull (none: pull_speed)"),
    "end_twist": ("text", "single-rod bend: 'clamped' (pulled end edges keep their angle) or 'free'"),
    "transient": ("s", "start of the measured pull left out of the peak force and of the force-drop and slip "
                       "detection (the start-up ringing is not the knot's strength)"),
    "loose_bend_radius": ("-", "single-rod bend: bend radius in rod radii h of the free-rope level; 'loose' when "
                               "F h^2/EI after the transient never exceeds 1/(4 r^2) + drag (r = 2: 0.0625)"),
    "loose_factor": ("-", "single-rod bend: metric 'tightened' = rope in the knot <= this x ideal ropelength (reported only)"),
    "mode": ("text", "two-rope bend: 'displacement' (pull at pull_speed) or 'force' (ramp at force_rate)"),
    "held_end": ("text", "the end held still, ROPE:NODE (rope index or name, node 0 or -1; empty: two-rope bend the "
                         "knot's hint, one rope both ends pulled apart; given: that end held, the other pulled)"),
    "pulled_end": ("text", "the pulled end whose force is measured, ROPE:NODE (empty: two-rope bend the knot's hint, "
                           "one rope both ends pulled apart; given: that end pulled, the rope's other end held)"),
    "pull_length": ("m", "two-rope bend, displacement mode: distance pulled when no duration is given"),
    "pre_tighten": ("m", "two-rope bend: distance each of the four ends moves outwards first (0: none)"),
    "pre_tighten_speed": ("m/s", "two-rope bend: speed per end during the cinching stage"),
    "force_rate": ("N/s", "two-rope bend, force mode: growth rate of the applied force"),
    "runaway_speed": ("m/s", "two-rope bend, force mode: pulled end faster than this = slipping"),
    "slip_draw_in_rate": ("-", "two-rope bend: tails drawn in faster than this x pull_speed = slipping"),
    "slip_hold": ("s", "two-rope bend: how long the fast draw-in must last to count as a slip"),
    "contact.stick_distance": ("m", "elastic-stick friction: spring stretch at the kinetic limit (static friction "
                                    "that holds; none: the smooth law of contact.nu)"),
    "set_tension": ("N", "knot security: force on each of the three loaded ends while the knot is set"),
    "set_ramp": ("s", "knot security: time over which the set tension grows from 0"),
    "set_hold": ("s", "knot security: time the set tension is held (with set_until_still: at least)"),
    "hold_tension": ("N", "knot security: force left on the three ends after relaxing (at most set_tension)"),
    "relax_time": ("s", "knot security: time over which the ends go from the set to the hold tension"),
    "load": ("text", "knot security: 'ramp' (force at load_rate until run-away), 'hold' (hold_load for "
                     "load_time), 'slide' (the end moves at pull_speed), 'pulses' (triangular pulses from "
                     "hold_tension to pulse_load) or 'jerks' (from slack to jerk_load in jerk_rise and back)"),
    "load_rate": ("N/s", "knot security, ramp: growth rate of the load"),
    "hold_load": ("N", "knot security, hold: the load held"),
    "load_time": ("s", "knot security: length of the load stage (0: 20 s, hold 10 s after its rise)"),
    "slip_speed": ("m/s", "knot security, ramp: the loaded end faster than this for 0.5 s = a slow slip"),
    "hold_drift": ("m", "knot security, hold: more rope than this through the knot over the hold's second half "
                        "(the loaded end out and the tails in) = a slip"),
    "set_still_rate": ("m/s", "knot security: the rope in the knot changing faster than this at the end of the "
                              "set = the knot was still moving, not set"),
    "set_until_still": ("true/false", "knot security: hold the set until the knot stops moving (at least "
                                      "set_hold, at most set_hold_max; found as the run goes)"),
    "set_hold_max": ("s", "knot security, set_until_still: the longest set hold"),
    "detect_after": ("s", "knot security, ramp: time into the load before slip detection starts (0: from the first "
                          "instant, so slip loads are resolved down to the hold tension)"),
    "slip_rule": ("text", "knot security: 'through' (a slow slip, a spill: rope passing through the knot, the loaded "
                          "end out and the tails in, the lesser of the two) or 'loaded_end' (the loaded end alone, "
                          "the rule of the studies before it)"),
    "load_end": ("text", "knot security, bends: 'standing' (rope B's standing end loaded, the other clamped) or "
                         "'tail' (rope A's tail pulled against its own clamped standing end, rope B free: how a "
                         "reef bend capsizes)"),
    "stop_at_decision": ("true/false", "knot security: end the run stop_margin s after its outcome is decided (the "
                                       "loaded end ran away, the ropes came apart, capsized, spilled)"),
    "stop_margin": ("s", "knot security: simulated time the run goes on after its decision (stop_at_decision)"),
    "set_still_window": ("s", "knot security: the window over which the rope in the knot's rate is read at the "
                              "end of the set"),
    "pulse_load": ("N", "knot security, pulses: the load at the top of each triangular pulse"),
    "pulse_period": ("s", "knot security, pulses: duration of one pulse (rise and fall)"),
    "n_pulses": ("-", "knot security, pulses: number of pulses"),
    "spill_distance": ("m", "knot security, pulses and jerks: this much rope through the knot after a pulse or jerk "
                            "= spilled"),
    "jerk_load": ("N", "knot security, jerks: the load at the top of each jerk (from slack)"),
    "jerk_rise": ("s", "knot security, jerks: time from slack to the top of a jerk, and back"),
    "jerk_period": ("s", "knot security, jerks: time from one jerk to the next (slack between)"),
    "n_jerks": ("-", "knot security, jerks: number of jerks"),
    "load_angle": ("deg", "knot security, a hitch or a loop: the load's angle to the plane across the post (0: the "
                          "standing part pulled straight off the post; 90: along the post, towards its +axis end)"),
}

#: Allowed range of numeric protocol parameters, checked by :func:`check_param_ranges` before
#: anything runs: ``">0"`` positive, ``">=0"`` non-negative, ``"int>=1"`` positive integer,
#: ``"int>=3"``, ``"poisson"`` in (-1, 0.5]. ``None`` values (decided by the protocol) are not
#: checked; keys not listed only need to be finite.
PARAM_RANGES: dict[str, str] = {
    "n_nodes": "int>=3", "radius": ">0", "post_radius": ">0", "length": ">0", "youngs_modulus": ">0", "density": ">0",
    "poisson_ratio": "poisson", "damping": ">=0", "mu": ">=0", "dt": ">0", "duration": ">0",
    "bending_stiffness": ">0", "torsional_stiffness": ">0",
    "output_interval": ">0", "geometry_scale": ">0", "ramp_time": ">=0", "settle_time": ">=0", "pull_speed": ">0", "e_final": ">0",
    "mean_window": ">0", "hold_time": ">=0", "hold_nodes": "int>=1", "pre_pull": ">=0",
    "pre_pull_speed": ">0", "transient": ">=0", "loose_factor": ">0", "loose_bend_radius": ">0", "pull_length": ">0",
    "pre_tighten": ">=0", "pre_tighten_speed": ">0", "force_rate": ">0", "runaway_speed": ">0",
    "slip_draw_in_rate": ">0", "slip_hold": ">=0", "set_tension": ">0", "set_ramp": ">0", "set_hold": ">=0",
    "hold_tension": ">=0", "relax_time": ">0", "load_rate": ">0", "hold_load": ">0", "load_time": ">=0",
    "slip_speed": ">0", "hold_drift": ">0", "pulse_load": ">0", "pulse_period": ">0", "n_pulses": "int>=1",
    "spill_distance": ">0", "set_still_rate": ">0", "set_hold_max": ">0", "set_still_window": ">0",
    "jerk_load": ">0", "jerk_rise": ">0", "jerk_period": ">0", "n_jerks": "int>=1",
    "stop_margin": ">=0", "detect_after": ">=0", "load_angle": "angle",
}
_RANGE_TEXT = {">0": "a positive number", ">=0": "a non-negative number", "int>=1": "a positive integer",
               "int>=3": "an integer >= 3", "poisson": "a number in (-1, 0.5]", "angle": "an angle in [-90, 90] degrees"}


#: :data:`PARAM_RANGES` as the bounds of :func:`knotsim._util.validate.number`
_RANGE_BOUNDS: dict[str, dict[str, Any]] = {">0": {"above": 0.0}, ">=0": {"at_least": 0.0},
                                             "int>=1": {"whole": True, "at_least": 1},
                                             "int>=3": {"whole": True, "at_least": 3},
                                             "poisson": {"above": -1.0, "at_most": 0.5},
                                             "angle": {"at_least": -90.0, "at_most": 90.0}}


def check_param_ranges(values: Mapping[str, Any]) -> None:
    """Raise :class:`ConfigError` naming the first parameter of ``values`` outside its range
    (:data:`PARAM_RANGES`; non-finite numbers are always refused)."""
    for key, v in values.items():
        if v is None or not is_number(v):
            continue
        rule = PARAM_RANGES.get(key)
        unit = PARAM_INFO.get(key, ("", ""))[0]
        unit = f" ({unit})" if unit not in ("", "-", "text") else ""
        bounds = _RANGE_BOUNDS.get(rule, {}) if rule is not None else {}
        number(v, key, **bounds, must=describe(**bounds) + unit, fix=f"set it with --set {key}=VALUE")


_CONTACT_KEYS = None
_SOLVER_KEYS = None


def _contact_keys() -> set[str]:
    global _CONTACT_KEYS
    if _CONTACT_KEYS is None:
        from knotsim.contact.options import ContactOptions

        _CONTACT_KEYS = {f.name for f in fields(ContactOptions)} - {"mu"}
    return _CONTACT_KEYS


def _solver_keys() -> set[str]:
    global _SOLVER_KEYS
    if _SOLVER_KEYS is None:
        from knotsim.solver.options import SolverOptions

        _SOLVER_KEYS = {f.name for f in fields(SolverOptions)} - {"dt"}
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
        if not is_number(value):
            raise ConfigError(key, f"expected a number, got {value!r}")
        if isinstance(default, int) and not isinstance(default, bool):
            if not math.isfinite(float(value)) or float(value) != int(value):
                raise ConfigError(key, f"expected an integer, got {value!r}")
            return int(value)
        return float(value)
    if key == "geometry_matrices" and isinstance(value, list | tuple) and all(isinstance(v, str) for v in value):
        return ",".join(value)
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


def _flatten_tables(layer: Mapping[str, Any]) -> dict[str, Any]:
    """``{"contact": {"delta": 1e-3}}`` -> ``{"contact.delta": 1e-3}`` (the ``contact`` and ``solver``
    tables may be given nested, as a TOML table, or as dotted keys)."""
    out: dict[str, Any] = {}
    for key, val in layer.items():
        if key in ("contact", "solver") and isinstance(val, Mapping):
            out.update({f"{key}.{k}": v for k, v in val.items()})
        else:
            out[key] = val
    return out


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
    tables = {"contact": (contact, _contact_keys()), "solver": (solver, _solver_keys())}
    set_at: dict[str, int] = {}  # the last layer that set each key (a rope preset gives way to it)
    for index, layer in enumerate(layers):
        for key, val in _flatten_tables(layer or {}).items():
            if not isinstance(key, str):
                raise ConfigError(str(key), "override keys must be strings")
            if key in ("contact.mu",):
                key = "mu"
            table, _, sub = key.partition(".")
            if sub and table in tables:
                target, known = tables[table]
                if sub not in known:
                    raise ConfigError(key, f"unknown {table} setting; known: "
                                           f"{', '.join(f'{table}.' + s for s in sorted(known))}")
                # a TOML file (a study) cannot write None: the text "none" unsets a setting, as on the
                # command line (e.g. contact.stick_distance = "none": the smooth friction law)
                target[sub] = None if isinstance(val, str) and val.strip().lower() == "none" else val
            elif key in values:
                values[key] = _coerce(key, defaults.get(key), val)
            else:
                raise ConfigError(key, f"unknown parameter; known: {', '.join(sorted(values))}, "
                                       "contact.<setting>, solver.<setting>")
            set_at[key] = index
    if values.get("rope"):
        _apply_rope(values, contact, set_at)
    check_param_ranges(values)
    return Params(values, contact, solver)


#: Parameters a rope preset sets (``rope``); ``contact.mu_static`` only with the elastic-stick law.
ROPE_KEYS = ("radius", "density", "youngs_modulus", "bending_stiffness", "torsional_stiffness", "mu",
             "contact.mu_static")


def rope_values(name: str) -> dict[str, float]:
    """The parameters (:data:`ROPE_KEYS`) the rope preset ``name`` sets: radius (m), density
    (kg/m^3, its linear density over pi h^2), youngs_modulus (Pa, its EA over pi h^2),
    bending_stiffness and torsional_stiffness (N m^2), mu and contact.mu_static. An unknown name
    raises :class:`ConfigError` naming ``rope`` and listing the presets."""
    from knotsim.rods.ropes import get_rope

    p = get_rope(name)
    return {"radius": p.radius, "density": p.density, "youngs_modulus": p.youngs_modulus,
            "bending_stiffness": p.EI, "torsional_stiffness": p.GJ, "mu": p.mu, "contact.mu_static": p.mu_static}


def _apply_rope(values: dict[str, Any], contact: dict[str, Any], set_at: Mapping[str, int]) -> None:
    """Set the rope preset ``values["rope"]``'s parameters, except those given in the layer that
    named the rope or in a later one (an explicit ``--set`` wins); ``contact.mu_static`` only when
    the elastic-stick law is on (``contact.stick_distance``), which alone uses it, and ``mu`` is the
    preset's."""
    rope = values["rope"]
    if not isinstance(rope, str):
        raise ConfigError("rope", f"expected a rope preset's name, got {rope!r}")
    layer = set_at.get("rope", -1)
    for key, val in rope_values(rope).items():
        if set_at.get(key, -2) >= layer:
            continue
        if key == "contact.mu_static":
            # the preset's static excess belongs to its own mu: an explicit mu has none
            if contact.get("stick_distance") is not None and set_at.get("mu", -2) < layer:
                contact["mu_static"] = val
        else:
            values[key] = val


def protocol_defaults(proto) -> dict[str, Any]:
    """:data:`COMMON_DEFAULTS` updated with ``proto.defaults`` (flat, may hold ``contact.*`` keys)."""
    d = dict(COMMON_DEFAULTS)
    d.update(proto.defaults)
    return d


def describe_params(proto) -> list[tuple[str, Any, str, str]]:
    """``(key, default, unit, meaning)`` of every parameter of protocol ``proto`` (a
    :class:`~knotsim.protocols.base.LoadingProtocol`), common ones first, in the order of the
    defaults tables; the meaning comes from :data:`PARAM_INFO` (``KeyError`` if a key has none)."""
    return [(k, v, *PARAM_INFO[k]) for k, v in protocol_defaults(proto).items()]


def settings_defaults() -> dict[str, Any]:
    """Defaults of the ``contact.<setting>`` and ``solver.<setting>`` keys (from the contact and
    solver settings dataclasses; ``contact.mu`` and ``solver.dt`` are the ``mu`` and ``dt``
    parameters)."""
    from dataclasses import MISSING

    from knotsim.contact.options import ContactOptions
    from knotsim.solver.options import SolverOptions

    out: dict[str, Any] = {}
    for prefix, cls, skip in (("contact.", ContactOptions, "mu"), ("solver.", SolverOptions, "dt")):
        for f in fields(cls):
            if f.name != skip and f.default is not MISSING:
                out[prefix + f.name] = f.default
    return out
