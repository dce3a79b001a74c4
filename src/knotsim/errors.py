"""Typed exceptions raised by knotsim.

Library code never prints or exits; it raises one of these with a message that says what was
wrong and how to fix it.
"""

from __future__ import annotations

from typing import Any


class KnotsimError(Exception):
    """Base class of every error knotsim raises on purpose."""


class KnotsimWarning(UserWarning):
    """Base class of every warning knotsim issues (the test suite turns them into errors)."""


class ConfigError(KnotsimError, ValueError):
    """Bad input: a configuration value, a function argument or a TOML key.

    The message names the field and the offending value.
    """

    def __init__(self, field: str, message: str):
        self.field = field
        super().__init__(f"{field}: {message}")


class GeometryError(KnotsimError, ValueError):
    """Geometry that cannot be simulated (overlapping rods, zero-length edges, ...)."""


class SimulationError(KnotsimError, RuntimeError):
    """The time stepper could not advance (Newton failed even at the minimum step).

    Attributes
    ----------
    last_good_state:
        The last state that was reached successfully (a :class:`knotsim.solver.state.State`),
        so that a run can be inspected or restarted from it.
    time:
        Simulation time (s) of ``last_good_state``.
    """

    def __init__(self, message: str, last_good_state: Any = None, time: float | None = None):
        self.last_good_state = last_good_state
        self.time = time
        super().__init__(message)


class ValidityError(SimulationError):
    """A converged step left the model's validity (see :mod:`knotsim.solver.validity`): a non-finite
    value, an axial strain beyond ``solver.max_axial_strain`` or energy created without a source.

    Attributes (besides those of :class:`SimulationError`): ``quantity`` (``"axial_strain"``,
    ``"energy_gain"``, ``"energy"``, ``"velocity"``, ...) and ``value``, the offending value.
    """

    def __init__(self, message: str, *, quantity: str, value: float, time: float | None = None,
                 last_good_state: Any = None):
        self.quantity = quantity
        self.value = value
        super().__init__(message, last_good_state=last_good_state, time=time)
