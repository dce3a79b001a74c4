"""The parameters of the ``knot-security`` protocol, typed (:class:`SecurityParams`), and the load it
applies in its force modes (:func:`load_profile`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

from knotsim.errors import ConfigError
from knotsim.protocols.params import check_param_ranges

__all__ = ["LOAD_ENDS", "LOAD_MODES", "SLIP_RULES", "SecurityParams", "load_profile"]

LOAD_MODES = ("ramp", "hold", "slide", "pulses", "jerks")
SLIP_RULES = ("through", "loaded_end")
LOAD_ENDS = ("standing", "tail")


@dataclass(frozen=True)
class SecurityParams:
    """The protocol's own parameters of a run, typed (forces N, times s, lengths m, speeds m/s; the
    meaning of each in ``knotsim pull --protocol knot-security --show-params``), checked once by the
    parameters' validator (:func:`~knotsim.protocols.params.check_param_ranges`) and for what the
    ranges cannot say (the modes, ``hold_tension <= set_tension``, a jerk that fits its period)."""

    load: str
    set_tension: float
    set_ramp: float
    set_hold: float
    hold_tension: float
    relax_time: float
    load_rate: float
    hold_load: float
    load_time: float
    pulse_load: float
    pulse_period: float
    n_pulses: int
    jerk_load: float
    jerk_rise: float
    jerk_period: float
    n_jerks: int
    spill_distance: float
    pull_speed: float
    runaway_speed: float
    slip_speed: float
    hold_drift: float
    set_still_rate: float
    set_until_still: bool
    set_hold_max: float
    set_still_window: float
    transient: float
    detect_after: float
    slip_rule: str
    load_end: str
    load_angle: float

    @classmethod
    def from_params(cls, p) -> SecurityParams:
        """From the resolved parameters ``p`` (a mapping by name); :class:`ConfigError` naming the
        first field that is wrong."""
        values = {f.name: p[f.name] for f in fields(cls)}
        check_param_ranges(values)
        if values["load"] not in LOAD_MODES:
            raise ConfigError("load", f"must be one of {', '.join(LOAD_MODES)}, got {values['load']!r}")
        if values["slip_rule"] not in SLIP_RULES:
            raise ConfigError("slip_rule", f"must be one of {', '.join(SLIP_RULES)}, got {values['slip_rule']!r}")
        if values["load_end"] not in LOAD_ENDS:
            raise ConfigError("load_end", f"must be one of {', '.join(LOAD_ENDS)}, got {values['load_end']!r}")
        if not isinstance(values["set_until_still"], bool):
            raise ConfigError("set_until_still", f"must be true or false, got {values['set_until_still']!r}")
        for key in ("n_pulses", "n_jerks"):
            n = values[key]
            if not (isinstance(n, int | float) and not isinstance(n, bool) and n >= 1 and float(n).is_integer()):
                raise ConfigError(key, f"must be a positive integer, got {n!r}")
        if values["hold_tension"] > values["set_tension"]:
            raise ConfigError("hold_tension", f"must be at most set_tension = {values['set_tension']:g} N, got "
                                              f"{values['hold_tension']:g}")
        if 2.0 * values["jerk_rise"] > values["jerk_period"]:
            raise ConfigError("jerk_rise", f"a jerk (rise and fall, 2 x {values['jerk_rise']:g} s) must fit in "
                                           f"jerk_period = {values['jerk_period']:g} s")
        kinds = {f.name: f.type for f in fields(cls)}
        typed: dict[str, Any] = {k: (int(v) if kinds[k] == "int" else float(v) if kinds[k] == "float" else v)
                                 for k, v in values.items()}
        return cls(**typed)

    @property
    def detect_from(self) -> float:
        """s into the load stage from which slips are detected: ``detect_after`` in a ramp, after the
        rise (``transient``) otherwise."""
        return self.detect_after if self.load == "ramp" else self.transient

    @property
    def cycle_period(self) -> float:
        """s per pulse or jerk."""
        return self.jerk_period if self.load == "jerks" else self.pulse_period

    @property
    def cycles(self) -> int:
        """Number of pulses or jerks."""
        return self.n_jerks if self.load == "jerks" else self.n_pulses

    def default_load_time(self) -> float:
        """s of load stage when ``load_time`` is 0: 20 (ramp, slide), 10 after the rise (hold), the
        pulses or jerks and 2 s."""
        if self.load == "hold":
            return 10.0 + self.transient
        if self.load in ("pulses", "jerks"):
            return self.cycles * self.cycle_period + 2.0
        return 20.0


def load_profile(sp: SecurityParams, t_load: float) -> float:
    """The applied load (N) on each loaded end ``t_load`` s into the load stage in the force modes
    (``"ramp"``, ``"hold"``, ``"pulses"``, ``"jerks"``; NaN before the load)."""
    if t_load < 0:
        return math.nan
    if sp.load == "ramp":
        return sp.hold_tension + sp.load_rate * t_load
    if sp.load == "hold":
        return sp.hold_tension + (sp.hold_load - sp.hold_tension) * min(t_load / sp.transient, 1.0)
    if sp.load == "pulses":
        if t_load >= sp.n_pulses * sp.pulse_period:
            return sp.hold_tension
        x = (t_load % sp.pulse_period) / sp.pulse_period
        return sp.hold_tension + (sp.pulse_load - sp.hold_tension) * (2.0 * x if x < 0.5 else 2.0 * (1.0 - x))
    if t_load >= sp.n_jerks * sp.jerk_period:  # jerks: slack between them
        return 0.0
    s = t_load % sp.jerk_period
    return sp.jerk_load * max(0.0, 1.0 - abs(s - sp.jerk_rise) / sp.jerk_rise)
