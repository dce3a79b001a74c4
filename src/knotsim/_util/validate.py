"""The checks of parameter values: numbers, ranges, choices and flags.

Every check takes the value and the ``field`` it came from (the full key path, e.g.
``contact.delta``, ``rods[0].youngs_modulus`` or a protocol parameter) and returns the checked
value, or raises :class:`~knotsim.errors.ConfigError` whose message is one line naming the field,
what it must be and the value given, with how to fix it where there is more to say than the
range (``"solver.dt: must be a positive time step in s, got -1"``). Run files, protocol
parameters, study specifications and the options objects of the solver and the contact all check
their values here; the table helpers of :mod:`knotsim._util.fields` build on it.
"""

from __future__ import annotations

import math
from enum import Enum
from typing import Any

import numpy as np

from knotsim.errors import ConfigError

__all__ = ["as_bool", "as_integer", "as_number", "as_string", "choice", "describe", "flag", "is_number",
           "no_nan", "number", "type_name"]


def type_name(value) -> str:
    return type(value).__name__


def is_number(v) -> bool:
    """A real number (Python or numpy), not a boolean."""
    return isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool | np.bool_)


def _fail(field: str, must: str, value, fix: str = ""):
    raise ConfigError(field, f"must {must}, got {value!r}" + (f"; {fix}" if fix else ""))


def describe(*, above: float | None = None, at_least: float | None = None, at_most: float | None = None,
             whole: bool = False) -> str:
    """The range of :func:`number` in words (``"be a positive number"``, ``"be an integer >= 3"``)."""
    if whole:
        low = at_least if at_least is not None else (above + 1 if above is not None else None)
        return "be a positive integer" if low == 1 else f"be an integer >= {low:g}" if low is not None else "be an integer"
    if above == 0 and at_most is None:
        return "be a positive number"
    if at_least == 0 and at_most is None:
        return "be a non-negative number"
    if above is not None and at_most is not None:
        return f"be a number in ({above:g}, {at_most:g}]"
    return "be a finite number"


def number(value, field: str, *, above: float | None = None, at_least: float | None = None,
           at_most: float | None = None, integer: bool = False, whole: bool = False, infinite: bool = False,
           must: str | None = None, fix: str = "") -> Any:
    """``value`` checked to be a number (``integer``: of an integer type; ``whole``: of integral
    value) that is finite (``infinite``: ``inf`` is allowed too), ``> above``, ``>= at_least`` and
    ``<= at_most``; returned as ``int`` (``integer``/``whole``) or ``float``. Otherwise
    :class:`ConfigError` ``"<field>: must <must>, got <value>[; <fix>]"`` (``must`` defaults to
    :func:`describe` of the range)."""
    ok = is_number(value) and (not integer or isinstance(value, int | np.integer))
    if ok:
        x = float(value)
        ok = (math.isfinite(x) or (infinite and x == math.inf)) and (not whole or x.is_integer())
        ok = ok and (above is None or x > above) and (at_least is None or x >= at_least)
        ok = ok and (at_most is None or x <= at_most)
    if not ok:
        _fail(field, must or describe(above=above, at_least=at_least, at_most=at_most, whole=whole or integer),
              value, fix)
    return int(value) if integer or whole else float(value)


def choice(value, field: str, options: type[Enum], *, must: str | None = None):
    """``value`` (a member of the enum ``options`` or its value) as the member; otherwise
    :class:`ConfigError` naming the allowed values (``must`` replaces ``"be one of ..."``)."""
    try:
        return options(value)
    except ValueError:
        allowed = ", ".join(repr(m.value) for m in options)
        _fail(field, must or f"be one of {allowed}", value)


def flag(value, field: str) -> bool:
    """``value`` checked to be a boolean (``"must be true or false"`` otherwise)."""
    if not isinstance(value, bool | np.bool_):
        _fail(field, "be true or false", value)
    return bool(value)


def no_nan(value: Any, field: str) -> None:
    """Raise :class:`ConfigError` naming the first NaN in ``value`` (nested dicts and lists), which
    a run file cannot hold."""
    if isinstance(value, float) and math.isnan(value):
        raise ConfigError(field or "config", "NaN cannot be written to a run file")
    if isinstance(value, dict):
        for k, v in value.items():
            no_nan(v, f"{field}.{k}" if field else k)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            no_nan(v, f"{field}[{i}]")


# ---------------------------------------------------------------- values of configuration tables
def as_number(v, path: str, *, positive: bool = False, nonneg: bool = False) -> float:
    """A finite number (``positive``: > 0, ``nonneg``: >= 0) of a table, with the type named when
    it is not one."""
    if not is_number(v):
        raise ConfigError(path, f"expected a number, got {v!r} ({type_name(v)})")
    x = float(v)
    if not math.isfinite(x):
        raise ConfigError(path, f"expected a finite number, got {v!r}")
    if positive and not x > 0:
        _fail(path, "be positive", v)
    if nonneg and not x >= 0:
        _fail(path, "be non-negative", v)
    return x


def as_integer(v, path: str, *, minimum: int | None = None) -> int:
    """An integer (of an integer type) of a table, at least ``minimum``."""
    if not isinstance(v, int | np.integer) or isinstance(v, bool | np.bool_):
        raise ConfigError(path, f"expected an integer, got {v!r} ({type_name(v)})")
    if minimum is not None and v < minimum:
        _fail(path, f"be at least {minimum}", v)
    return int(v)


def as_bool(v, path: str) -> bool:
    if not isinstance(v, bool | np.bool_):
        raise ConfigError(path, f"expected true or false, got {v!r} ({type_name(v)})")
    return bool(v)


def as_string(v, path: str) -> str:
    if not isinstance(v, str):
        raise ConfigError(path, f"expected a string, got {v!r} ({type_name(v)})")
    return v
