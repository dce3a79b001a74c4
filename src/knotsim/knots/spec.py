"""Knot drawings: the spec data classes and the parser of the TOML format.

The format (planar waypoints per rope plus the over/under letter of every crossing met along it) is
described in :mod:`knotsim.knots.geometry`; :func:`parse_knot_spec` validates a parsed TOML mapping.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from knotsim.errors import ConfigError

#: Default rod radius h (m) when neither the call nor the spec gives one.
DEFAULT_RADIUS = 1.6e-3
#: Default rope length (m).
DEFAULT_LENGTH = 1.0
#: Default number of nodes per rope.
DEFAULT_N_NODES = 301


@dataclass(frozen=True)
class RopePoint:
    """A point on a rope named in a spec: an end, or an arc-length fraction.

    Attributes
    ----------
    rope:
        Rope name.
    end:
        ``"start"`` or ``"end"`` for an end node, else ``None``.
    s:
        Arc-length fraction in ``[0, 1]`` (0 = first node) when ``end`` is ``None``.
    """

    rope: str
    end: str | None = None
    s: float | None = None

    @property
    def fraction(self) -> float:
        """Arc-length fraction of this point along its rope (0 for the start, 1 for the end)."""
        if self.end is not None:
            return 0.0 if self.end == "start" else 1.0
        assert self.s is not None
        return float(self.s)


@dataclass(frozen=True)
class RopeSpec:
    """One rope of a drawing.

    Attributes
    ----------
    name:
        Rope name (unique in the knot).
    waypoints:
        ``(M, 2)`` planar waypoints in drawing units, in walking order.
    passes:
        Over/under letter of every crossing met while walking the rope: ``True`` = over.
    """

    name: str
    waypoints: np.ndarray
    passes: tuple[bool, ...]


@dataclass(frozen=True)
class PostSpec:
    """A rigid post the knot is tied round (the ``[post]`` table of a drawing).

    Attributes
    ----------
    radius:
        Post radius ``R`` (m).
    drawn_on:
        ``"surface"``: the ropes' waypoints are drawn on the post's surface, ``(turns, along, height)``:
        the angle round the post in turns (1 = 360 degrees, may exceed 1), the position along the
        post's axis and the height above its surface, both in rope diameters ``2h`` (height optional,
        default 0). ``"plane"``: a planar drawing with the post through it along ``z`` at ``center``
        (a pin through a loop's eye).
    center:
        ``(2,)`` drawing units: where the post crosses a planar drawing; ``None`` for a surface drawing.
    length:
        Length of the post along its axis (m); ``None``: 40 rope diameters, at least the drawing's
        extent along the axis plus 20 diameters.
    split:
        Surface drawings: the share of the rope beyond the drawing given to its start (the rest to its
        end), in ``[0, 1]``.
    spin_inertia:
        ``None``: the post is fixed; else its moment of inertia about its axis (kg m^2): free to spin.
    """

    radius: float
    drawn_on: str = "surface"
    center: tuple[float, float] | None = None
    length: float | None = None
    split: float = 0.5
    spin_inertia: float | None = None


def _parse_post(value: Any, name: str) -> PostSpec:
    fld = f"{name}: post"
    if not isinstance(value, Mapping):
        raise ConfigError(fld, "must be a table [post] with radius (m) and drawn_on or center")
    unknown = sorted(set(value) - {"radius", "drawn_on", "center", "length", "split", "spin_inertia"})
    if unknown:
        raise ConfigError(f"{fld}.{unknown[0]}", "unknown key (allowed: radius, drawn_on, center, length, split, "
                                                 "spin_inertia)")

    def positive(key: str, required: bool = False) -> float | None:
        v = value.get(key)
        if v is None:
            if required:
                raise ConfigError(f"{fld}.{key}", "missing (a positive number, m)")
            return None
        if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v) or v <= 0:
            raise ConfigError(f"{fld}.{key}", f"must be a positive number, got {v!r}")
        return float(v)

    radius = positive("radius", required=True)
    assert radius is not None
    center = value.get("center")
    drawn_on = str(value.get("drawn_on", "plane" if center is not None else "surface"))
    if drawn_on not in ("surface", "plane"):
        raise ConfigError(f"{fld}.drawn_on", f"must be 'surface' or 'plane', got {drawn_on!r}")
    if drawn_on == "plane":
        try:
            c = np.asarray(center, dtype=float)
        except (TypeError, ValueError):
            c = np.zeros(0)
        if c.shape != (2,) or not np.all(np.isfinite(c)):
            raise ConfigError(f"{fld}.center", f"a planar drawing's post needs center = [x, y] in drawing units, "
                                               f"got {center!r}")
        center = (float(c[0]), float(c[1]))
    elif center is not None:
        raise ConfigError(f"{fld}.center", "only for drawn_on = 'plane' (a surface drawing is centred on the post)")
    split = value.get("split", 0.5)
    if isinstance(split, bool) or not isinstance(split, int | float) or not 0.0 <= split <= 1.0:
        raise ConfigError(f"{fld}.split", f"must be a fraction in [0, 1], got {split!r}")
    return PostSpec(radius=radius, drawn_on=drawn_on, center=center, length=positive("length"),
                    split=float(split), spin_inertia=positive("spin_inertia"))


@dataclass(frozen=True)
class KnotSpec:
    """A parsed knot drawing (see the module docstring for the format).

    Attributes
    ----------
    name, description, kind:
        Identification; ``kind`` is free text such as ``"overhand"`` or ``"bend"``.
    ropes:
        The ropes in order.
    pulled, held:
        Loading-protocol hints: points moved by the protocol, points held static.
    defaults:
        Published set-up values (``radius``, ``length``, ``n_nodes``, ...) used by
        :func:`build_knot` when the call does not give them.
    meta:
        Any other keys of the spec, kept verbatim (e.g. ``topology`` notes, references).
    post:
        The post the knot is tied round (:class:`PostSpec`), or ``None``.
    """

    name: str
    description: str
    kind: str
    ropes: tuple[RopeSpec, ...]
    pulled: tuple[RopePoint, ...] = ()
    held: tuple[RopePoint, ...] = ()
    defaults: Mapping[str, Any] = field(default_factory=dict)
    meta: Mapping[str, Any] = field(default_factory=dict)
    post: PostSpec | None = None

    @property
    def n_crossings(self) -> int:
        """Number of crossings declared (half the number of over/under letters)."""
        return sum(len(r.passes) for r in self.ropes) // 2

    def rope_index(self, name: str) -> int:
        """Index of the rope called ``name``; ``ConfigError`` if there is none."""
        for i, r in enumerate(self.ropes):
            if r.name == name:
                return i
        raise ConfigError("rope", f"no rope named {name!r} in knot {self.name!r} (ropes: "
                          f"{', '.join(r.name for r in self.ropes)})")


_LETTER = {"o": True, "over": True, "u": False, "under": False}


def _parse_passes(value: Any, field_name: str) -> tuple[bool, ...]:
    if isinstance(value, str):
        tokens = [c for c in re.sub(r"[\s,;|/_-]", "", value)]
    elif isinstance(value, Sequence):
        tokens = [str(v) for v in value]
    else:
        raise ConfigError(field_name, f"expected a string like 'OUOU' or a list of 'over'/'under', "
                                      f"got {type(value).__name__}")
    out = []
    for tok in tokens:
        key = tok.strip().lower()
        if key not in _LETTER:
            raise ConfigError(field_name, f"unknown over/under letter {tok!r} (use O/U or over/under)")
        out.append(_LETTER[key])
    return tuple(out)


def _parse_point(value: Any, field_name: str, rope_names: Sequence[str]) -> RopePoint:
    if not isinstance(value, Mapping):
        raise ConfigError(field_name, f"expected a table like {{rope = 'a', end = 'start'}}, got {value!r}")
    rope = value.get("rope", rope_names[0] if len(rope_names) == 1 else None)
    if rope not in rope_names:
        raise ConfigError(field_name, f"rope {rope!r} is not one of {list(rope_names)}")
    end = value.get("end")
    s = value.get("s")
    if (end is None) == (s is None):
        raise ConfigError(field_name, "give exactly one of end = 'start'|'end' or s = fraction")
    if end is not None:
        if end not in ("start", "end"):
            raise ConfigError(field_name, f"end must be 'start' or 'end', got {end!r}")
        return RopePoint(str(rope), end=str(end))
    s = float(s)
    if not 0.0 <= s <= 1.0:
        raise ConfigError(field_name, f"s must be an arc-length fraction in [0, 1], got {s}")
    return RopePoint(str(rope), s=s)


def parse_knot_spec(data: Mapping[str, Any] | KnotSpec, source: str = "<dict>") -> KnotSpec:
    """Validate a knot drawing given as a nested mapping (parsed TOML) and return a :class:`KnotSpec`.

    Parameters
    ----------
    data:
        Mapping with the keys of the module docstring (a :class:`KnotSpec` is returned as is).
    source:
        Where ``data`` came from, used in error messages.

    Raises
    ------
    ConfigError
        For a missing or malformed field; the message names the field.
    """
    if isinstance(data, KnotSpec):
        return data
    if not isinstance(data, Mapping):
        raise ConfigError(source, f"a knot spec must be a mapping, got {type(data).__name__}")
    name = str(data.get("name", "")).strip()
    if not name:
        raise ConfigError(f"{source}: name", "missing knot name")
    post = _parse_post(data["post"], name) if data.get("post") is not None else None
    on_surface = post is not None and post.drawn_on == "surface"
    ropes_raw = data.get("ropes")
    if not isinstance(ropes_raw, Sequence) or isinstance(ropes_raw, str) or not ropes_raw:
        raise ConfigError(f"{name}: ropes", "need a non-empty list of [[ropes]] tables")
    ropes: list[RopeSpec] = []
    for k, r in enumerate(ropes_raw):
        fld = f"{name}: ropes[{k}]"
        if not isinstance(r, Mapping):
            raise ConfigError(fld, "each rope must be a table with name, waypoints, crossings")
        rname = str(r.get("name", f"rope{k}"))
        if any(rname == q.name for q in ropes):
            raise ConfigError(f"{fld}.name", f"duplicate rope name {rname!r}")
        try:
            wp = np.asarray(r.get("waypoints"), dtype=float)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"{fld}.waypoints", f"not a list of [x, y] pairs ({exc})") from None
        if on_surface and wp.ndim == 2 and wp.shape[1] == 2:
            wp = np.column_stack([wp, np.zeros(len(wp))])  # on the surface: height 0
        if on_surface and (wp.ndim != 2 or wp.shape[1] != 3 or wp.shape[0] < 2):
            raise ConfigError(f"{fld}.waypoints", f"a drawing on the post's surface needs at least 2 [turns, along, "
                                                  f"height] points, got shape {wp.shape}")
        if not on_surface and (wp.ndim != 2 or wp.shape[1] != 2 or wp.shape[0] < 2):
            raise ConfigError(f"{fld}.waypoints", f"need at least 2 [x, y] pairs, got shape {wp.shape}")
        if not np.all(np.isfinite(wp)):
            raise ConfigError(f"{fld}.waypoints", "contains non-finite values")
        gaps = np.linalg.norm(np.diff(wp[:, :2], axis=0), axis=1)
        if np.any(gaps <= 1e-9 * max(1.0, float(np.ptp(wp)))):
            j = int(np.argmin(gaps))
            raise ConfigError(f"{fld}.waypoints", f"waypoints {j} and {j + 1} coincide ({wp[j].tolist()})")
        passes = _parse_passes(r.get("crossings", ""), f"{fld}.crossings")
        ropes.append(RopeSpec(rname, wp, passes))
    n_letters = sum(len(r.passes) for r in ropes)
    if n_letters % 2:
        raise ConfigError(f"{name}: crossings", f"{n_letters} over/under letters in total; every crossing "
                                                "is met twice, so the total must be even")
    n_over = sum(sum(r.passes) for r in ropes)
    if 2 * n_over != n_letters:
        raise ConfigError(f"{name}: crossings", f"{n_over} 'over' but {n_letters - n_over} 'under' letters; "
                                                "every crossing has one of each")
    names = [r.name for r in ropes]
    loading = data.get("loading", {}) or {}
    if not isinstance(loading, Mapping):
        raise ConfigError(f"{name}: loading", "must be a table")
    pulled = tuple(_parse_point(p, f"{name}: loading.pulled", names) for p in loading.get("pulled", []))
    held = tuple(_parse_point(p, f"{name}: loading.held", names) for p in loading.get("held", []))
    defaults = dict(data.get("defaults", {}) or {})
    for key in defaults:
        if key not in ("radius", "length", "n_nodes", "edge_length"):
            raise ConfigError(f"{name}: defaults.{key}", "unknown key (allowed: radius, length, n_nodes, edge_length)")
    known = {"name", "description", "kind", "ropes", "loading", "defaults", "post"}
    meta = {k: v for k, v in data.items() if k not in known}
    return KnotSpec(
        name=name,
        description=str(data.get("description", "")).strip(),
        kind=str(data.get("kind", "")).strip(),
        ropes=tuple(ropes),
        pulled=pulled,
        held=held,
        defaults=defaults,
        meta=meta,
        post=post,
    )
