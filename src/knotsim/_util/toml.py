"""TOML reading and writing, once for the whole package.

Reading uses the standard library's :mod:`tomllib`; writing uses ``tomli_w``, which writes every
float with ``repr`` so that a value read back is bit-identical to the value written (a saved run
file replays a run exactly).
"""

from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from knotsim._util.validate import no_nan
from knotsim.errors import ConfigError

__all__ = ["dumps_toml", "load_toml", "loads_toml", "to_toml_value", "write_toml"]


def load_toml(path: str | os.PathLike, field: str = "config") -> dict:
    """Read the TOML file ``path`` as a dict.

    Raises :class:`~knotsim.errors.ConfigError` (naming ``field``) when the file does not exist or
    is not valid UTF-8 TOML."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError(field, f"file not found: {str(p)!r}")
    try:
        with open(p, "rb") as fh:
            return tomllib.load(fh)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(field, f"{str(p)!r} is not valid TOML: {exc}") from None


def loads_toml(text: str, field: str = "config") -> dict:
    """Parse TOML text; :class:`ConfigError` naming ``field`` when it is not valid TOML."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(field, f"not valid TOML: {exc}") from None


def to_toml_value(value: Any) -> Any:
    """``value`` with numpy scalars/arrays turned into Python numbers/lists, tuples into lists,
    dict keys into strings and ``None`` entries of tables dropped (TOML has no null)."""
    if isinstance(value, dict):
        return {str(k): to_toml_value(v) for k, v in value.items() if v is not None}
    if isinstance(value, np.ndarray):
        return to_toml_value(value.tolist())
    if isinstance(value, list | tuple):
        return [to_toml_value(v) for v in value]
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, os.PathLike):
        return str(value)
    return value


def dumps_toml(data: dict, header: str = "") -> str:
    """``data`` (a dict of TOML-compatible values, numpy allowed) as TOML text.

    ``header`` is written first as ``#`` comment lines. Floats round-trip exactly; infinities are
    written as ``inf``; ``None`` values are left out."""
    clean = to_toml_value(data)
    no_nan(clean, "")
    text = _compact_arrays(tomli_w.dumps(clean, multiline_strings=False))
    if header:
        text = "".join(f"# {line}".rstrip() + "\n" for line in header.splitlines()) + "\n" + text
    return text


_INNER_ARRAY = re.compile(r"\[\n((?:[ ]+[^\[\]\n]+,\n)+)[ ]*\]")


def _compact_arrays(text: str) -> str:
    """Innermost arrays written one element per line by tomli-w, put on one line when that line
    stays short (a node's ``[x, y, z]`` is one line; values are untouched)."""

    def join(m: re.Match) -> str:
        items = [line.strip().rstrip(",") for line in m.group(1).splitlines()]
        one = "[" + ", ".join(items) + "]"
        return one if len(one) <= 100 else m.group(0)

    return _INNER_ARRAY.sub(join, text)


def write_toml(path: str | os.PathLike, data: dict, header: str = "") -> Path:
    """Write ``data`` as TOML to ``path`` (atomically: a temporary file, then a rename)."""
    p = Path(path)
    tmp = p.with_name(f".{p.name}.tmp")
    tmp.write_text(dumps_toml(data, header), encoding="utf-8")
    os.replace(tmp, p)
    return p
