"""The registry of loading protocols, by name (one explicit table; the protocol modules do not
register themselves)."""

from __future__ import annotations

from knotsim.errors import ConfigError
from knotsim.protocols.base import LoadingProtocol
from knotsim.protocols.knot_security import KnotSecurity
from knotsim.protocols.overhand_pull import OverhandPull
from knotsim.protocols.single_rod_bend import SingleRodBend
from knotsim.protocols.two_rope_bend import TwoRopeBend

__all__ = ["default_protocol", "get_protocol", "protocols"]

_REGISTRY: dict[str, LoadingProtocol] = {p.name: p for p in (OverhandPull(), SingleRodBend(), TwoRopeBend(), KnotSecurity())}


def protocols() -> dict[str, LoadingProtocol]:
    """Registered protocols by name."""
    return dict(_REGISTRY)


def get_protocol(name: str) -> LoadingProtocol:
    """Protocol called ``name``; :class:`ConfigError` listing the known ones otherwise."""
    if name not in _REGISTRY:
        raise ConfigError("protocol", f"unknown protocol {name!r}; known: {', '.join(sorted(_REGISTRY))}")
    return _REGISTRY[name]


def default_protocol(knot: str) -> str:
    """Name of the protocol used for ``knot`` (a library name or a drawing path) from its kind."""
    from knotsim.knots.library import load_knot_spec

    kind = load_knot_spec(knot).kind
    for p in _REGISTRY.values():
        if kind in p.kinds:
            return p.name
    raise ConfigError("protocol", f"no default protocol for knot kind {kind!r} of {knot!r}; choose one of "
                                  f"{', '.join(sorted(_REGISTRY))}")
