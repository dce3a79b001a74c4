"""Built-in knot drawings and loading of user drawings.

Built-in knots are TOML files in ``knotsim/data/knots/`` (format: :mod:`knotsim.knots.geometry`).

Example::

    from knotsim.knots.library import get_knot, list_knots

    for name, description in list_knots():
        ...
    geo = get_knot("overhand_n2", n_nodes=301)    # (N, 3) arrays in geo.ropes, metres
    geo = get_knot("my_knots/bowline.toml")      # a user drawing, by path
"""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from knotsim.errors import ConfigError
from knotsim.knots.geometry import KnotGeometry, KnotSpec, build_knot, parse_knot_spec

__all__ = ["get_knot", "knot_names", "list_knots", "load_knot_spec"]

_PACKAGE = "knotsim.data.knots"


def _builtin_files() -> dict[str, Any]:
    root = resources.files(_PACKAGE)
    return {p.name[:-5]: p for p in root.iterdir() if p.name.endswith(".toml")}


def knot_names() -> list[str]:
    """Sorted names of the built-in knots."""
    return sorted(_builtin_files())


def list_knots() -> list[tuple[str, str]]:
    """``(name, one-line description)`` of every built-in knot, sorted by name."""
    return [(name, load_knot_spec(name).description) for name in knot_names()]


def _parse_toml(text: str, source: str) -> KnotSpec:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(source, f"invalid TOML: {exc}") from None
    return parse_knot_spec(data, source)


def load_knot_spec(name_or_path: str | Path) -> KnotSpec:
    """Load a knot drawing: a built-in name (see :func:`knot_names`) or the path of a TOML file.

    Raises
    ------
    ConfigError
        Unknown name (the message lists the built-in knots), unreadable file or bad content.
    """
    files = _builtin_files()
    key = str(name_or_path)
    if key in files:
        return _parse_toml(files[key].read_text(encoding="utf-8"), f"built-in knot {key!r}")
    path = Path(name_or_path)
    if path.suffix.lower() == ".toml" or path.exists():
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise ConfigError("knot", f"cannot read knot file {str(path)!r}: {exc}") from None
        return _parse_toml(text, str(path))
    raise ConfigError("knot", f"unknown knot {key!r}; built-in knots are: {', '.join(sorted(files))} "
                              "(or give the path of a .toml drawing)")


def get_knot(name_or_path: str | Path, **kwargs: Any) -> KnotGeometry:
    """Load a knot drawing and build its geometry.

    ``kwargs`` go to :func:`knotsim.knots.geometry.build_knot` (``n_nodes``, ``edge_length``,
    ``radius``, ``length``, ...); missing ones take the drawing's published defaults.
    """
    return build_knot(load_knot_spec(name_or_path), **kwargs)
