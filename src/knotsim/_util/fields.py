"""Typed getters for checking configuration tables (run files, protocol parameters, study specs).

Each ``as_*`` converter takes ``(value, path)`` and returns the checked value or raises
:class:`~knotsim.errors.ConfigError` whose field is ``path`` (the full key path, e.g.
``rods[0].youngs_modulus``), with one line saying what was expected and what was given. The
checks of single numbers, flags and strings are those of :mod:`knotsim._util.validate`.
"""

from __future__ import annotations

import difflib

import numpy as np

from knotsim._util.validate import as_bool, as_integer, as_number, as_string, is_number, type_name
from knotsim.errors import ConfigError

__all__ = ["MISSING", "as_bool", "as_int_list", "as_integer", "as_number", "as_numbers", "as_points", "as_string",
           "as_table", "as_unit", "as_vec3", "check_keys", "error_message", "get_field", "is_number", "type_name"]

#: Marker for "no default: the key is required" in :func:`get_field`.
MISSING = object()


def check_keys(table: dict, path: str, allowed, elsewhere: dict[str, str] | None = None) -> None:
    """Raise :class:`ConfigError` for the first key of ``table`` not in ``allowed``.

    ``elsewhere`` maps keys that are valid in another variant (another rod shape, another bc type)
    to a hint naming that variant.
    """
    allowed = list(allowed)
    for key in table:
        if key in allowed:
            continue
        where = f"{path}.{key}" if path else str(key)
        if elsewhere and key in elsewhere:
            raise ConfigError(where, f"unknown key here ({elsewhere[key]})")
        close = difflib.get_close_matches(str(key), allowed, n=1, cutoff=0.6)
        if close:
            raise ConfigError(where, f"unknown key; did you mean '{close[0]}'?")
        raise ConfigError(where, f"unknown key; allowed keys are {', '.join(allowed)}")


def as_table(value, path: str) -> dict:
    if not isinstance(value, dict):
        raise ConfigError(path, f"expected a table, got {value!r} ({type_name(value)})")
    return value


def as_numbers(v, path: str, shape: tuple | None = None) -> np.ndarray:
    """A number or (nested) list of numbers as a float array, optionally of a given shape."""

    def walk(x, p):
        if isinstance(x, list | tuple | np.ndarray):
            for i, y in enumerate(x):
                walk(y, f"{p}[{i}]")
        elif not is_number(x):
            raise ConfigError(path, f"expected numbers, got {x!r} ({type_name(x)}) at {p}")

    walk(v, path)
    try:
        arr = np.asarray(v, dtype=float)
    except ValueError:
        raise ConfigError(path, f"expected a rectangular list of numbers, got {v!r}") from None
    if not np.all(np.isfinite(arr)):
        raise ConfigError(path, f"contains NaN or infinite values: {v!r}")
    if shape is not None and arr.shape != shape:
        want = "a list of 3 numbers [x, y, z]" if shape == (3,) else f"shape {shape}"
        raise ConfigError(path, f"expected {want}, got {v!r}")
    return arr


def as_vec3(v, path: str) -> np.ndarray:
    return as_numbers(v, path, (3,))


def as_unit(v, path: str) -> np.ndarray:
    a = as_vec3(v, path)
    n = float(np.linalg.norm(a))
    if n == 0.0:
        raise ConfigError(path, "must be a non-zero vector")
    return a / n


def as_points(v, path: str) -> np.ndarray:
    arr = as_numbers(v, path)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ConfigError(path, f"expected a list of [x, y, z] points, got shape {arr.shape}")
    return arr


def as_int_list(v, path: str) -> list[int]:
    if isinstance(v, int) and not isinstance(v, bool):
        return [v]
    if not isinstance(v, list) or not v:
        raise ConfigError(path, f"expected a non-empty list of integers, got {v!r}")
    return [as_integer(x, f"{path}[{i}]") for i, x in enumerate(v)]


def get_field(table: dict, key: str, path: str, conv, default=MISSING, **kw):
    """``conv(table[key])`` or ``default``; a missing key without default is an error."""
    if key not in table:
        if default is MISSING:
            raise ConfigError(f"{path}.{key}" if path else key, "missing required field")
        return default
    return conv(table[key], f"{path}.{key}" if path else key, **kw)


def error_message(exc: ConfigError) -> str:
    s = str(exc)
    prefix = f"{exc.field}: "
    return s[len(prefix):] if s.startswith(prefix) else s
