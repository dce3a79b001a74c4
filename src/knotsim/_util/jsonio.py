"""JSON output, once for the whole package: strict JSON (non-finite numbers become ``null``),
numpy values unwrapped, files replaced atomically so that a reader never sees half a file."""

from __future__ import annotations

import json
import math
import os
import uuid
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["json_safe", "read_json", "write_json"]


def json_safe(value: Any) -> Any:
    """``value`` as plain JSON data: numpy scalars and arrays unwrapped, tuples as lists, dict keys
    as strings, NaN and infinities as ``None``, paths and other objects as their ``str``."""
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        x = float(value)
        return x if math.isfinite(x) else None
    if value is None or isinstance(value, str):
        return value
    return str(value)


def write_json(path: str | os.PathLike, data: Any, *, fsync: bool = False, indent: int | None = 2) -> Path:
    """Write ``json_safe(data)`` to ``path`` atomically (temporary file in the same directory, then
    ``os.replace``); with ``fsync`` the data reach the disk before the rename."""
    p = Path(path)
    tmp = p.with_name(f".{p.name}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(json_safe(data), fh, indent=indent, allow_nan=False)
            if fsync:
                fh.flush()
                os.fsync(fh.fileno())
        os.replace(tmp, p)
    finally:
        if tmp.exists():
            tmp.unlink()
    return p


def read_json(path: str | os.PathLike) -> Any:
    """Contents of the JSON file ``path``."""
    with open(path, encoding="utf-8") as fh:
        return json.load(fh)
