"""``[[bc]]`` tables of a run file, checked and applied to a
:class:`~knotsim.bc.BoundaryConditions` (see ``docs/run-files.md`` for every key)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from knotsim._util.fields import as_numbers, as_table, as_vec3, check_keys, error_message, get_field
from knotsim._util.validate import as_bool, as_integer, as_number, as_string, type_name
from knotsim.bc import BoundaryConditions, Waypoints
from knotsim.errors import ConfigError
from knotsim.rods import Model

_BC_COMMON = ("type", "name", "rod", "nodes", "start", "stop")
_BC_TYPES = {
    "clamp": _BC_COMMON + ("twist",),
    "hold": _BC_COMMON,
    "move": _BC_COMMON + ("twist", "velocity", "ramp_time", "waypoints", "rotate_about"),
    "rotate": _BC_COMMON + ("rate",),
    "pin": _BC_COMMON + ("axes", "twist"),
    "slide": _BC_COMMON + ("along", "twist"),
    "plane": _BC_COMMON + ("normal", "twist"),
    "force": _BC_COMMON + ("force", "ramp"),
    "moment": ("type", "name", "rod", "edges", "start", "stop", "moment", "ramp"),
    "ring_twist": ("type", "name", "rod", "node", "start", "stop", "total", "rate"),
    "spring": _BC_COMMON + ("stiffness", "velocity", "waypoints"),
    "load_cell": _BC_COMMON + ("twist", "direction", "target", "ramp", "kp", "ki", "max_speed"),
    "release": ("type", "name", "at"),
}


@dataclass
class BCSpec:
    index: int
    kind: str
    name: str
    kwargs: dict
    key_map: dict = field(default_factory=dict)  # API field suffix -> TOML key


def _ramp(value, path: str, shape: tuple):
    r = as_table(value, path)
    check_keys(r, path, ("from", "to", "duration", "rate"))
    conv = as_vec3 if shape == (3,) else as_number
    f0 = get_field(r, "from", path, conv)
    if "rate" in r:
        if "to" in r or "duration" in r:
            raise ConfigError(f"{path}.rate", "give either rate (per s, unbounded) or to and duration")
        rate = get_field(r, "rate", path, conv)

        def growing(elapsed: float):
            """Load ``elapsed`` s after the group's ``start``: ``from + rate elapsed``."""
            return f0 + rate * max(elapsed, 0.0)

        return growing
    f1 = get_field(r, "to", path, conv)
    dur = get_field(r, "duration", path, as_number, positive=True)

    def load(elapsed: float):
        """Load ``elapsed`` s after the group's ``start``: linear over ``duration``, then constant."""
        return f0 + (f1 - f0) * min(max(elapsed / dur, 0.0), 1.0)

    return load


def as_index_spec(v, path: str):
    """Node (or edge) indices of a run file: an integer, ``"all"``, a range ``"a:b"`` / ``"a:b:step"``
    (end excluded, negative from the end), or a non-empty list of integers and range strings; the
    ranges are expanded against the rod by :func:`knotsim.rods.model.expand_indices`."""
    if isinstance(v, str):
        return _range_text(v, path)
    if isinstance(v, int) and not isinstance(v, bool):
        return [v]
    if not isinstance(v, list) or not v:
        raise ConfigError(path, f"expected an index, 'all', a range 'a:b' or a non-empty list of them, got {v!r}")
    return [_range_text(x, f"{path}[{i}]") if isinstance(x, str) else as_integer(x, f"{path}[{i}]")
            for i, x in enumerate(v)]


def _range_text(v: str, path: str) -> str:
    parts = v.strip().split(":")
    ok = v.strip() == "all" or (2 <= len(parts) <= 3 and all(p.strip().lstrip("-").isdigit() or not p.strip()
                                                               for p in parts))
    if not ok:
        raise ConfigError(path, f"expected an integer, 'all' or a range 'a:b' / 'a:b:step', got {v!r}")
    return v


def parse_waypoints(value, wpath: str) -> Waypoints:
    """A ``waypoints = {times, points, absolute, from_current, then_velocity}`` table."""
    w = as_table(value, wpath)
    check_keys(w, wpath, ("times", "points", "absolute", "from_current", "then_velocity"))
    times = get_field(w, "times", wpath, as_numbers)
    points = get_field(w, "points", wpath, as_numbers)
    absolute = get_field(w, "absolute", wpath, as_bool, False)
    from_current = get_field(w, "from_current", wpath, as_bool, False)
    then_v = get_field(w, "then_velocity", wpath, as_vec3, None)
    try:
        return Waypoints(times, points, absolute=absolute, from_current=from_current, then_velocity=then_v)
    except ConfigError as exc:
        raise ConfigError(f"{wpath}.{exc.field}", error_message(exc)) from None


def parse_rotation(value, rpath: str):
    """A ``rotate_about = {axis, point, rate}`` table: a :class:`~knotsim.bc.rigid.Rotation`."""
    from knotsim.bc.rigid import Rotation

    r = as_table(value, rpath)
    check_keys(r, rpath, ("axis", "point", "rate"))
    axis = get_field(r, "axis", rpath, as_vec3)
    rate = get_field(r, "rate", rpath, as_number)
    point = r.get("point", "centroid")
    if not (isinstance(point, str) and point == "centroid"):
        point = as_vec3(point, f"{rpath}.point")
    try:
        return Rotation(axis, rate=rate, point=point)
    except ConfigError as exc:
        raise ConfigError(f"{rpath}.{exc.field}", error_message(exc)) from None


def parse_bc(t, i: int) -> BCSpec:
    path = f"bc[{i}]"
    t = as_table(t, path)
    if "type" not in t:
        check_keys(t, path, sorted(set().union(*_BC_TYPES.values())))
    kind = get_field(t, "type", path, as_string)
    if kind not in _BC_TYPES:
        raise ConfigError(f"{path}.type", f"unknown type {kind!r}; expected one of {', '.join(_BC_TYPES)}")
    own = _BC_TYPES[kind]
    elsewhere = {k: f"not used by type '{kind}'" for keys in _BC_TYPES.values() for k in keys if k not in own}
    check_keys(t, path, own, elsewhere)

    if kind == "release":
        name = get_field(t, "name", path, as_string)
        at = get_field(t, "at", path, as_number, nonneg=True)
        return BCSpec(i, kind, name, {"at": at})

    name = get_field(t, "name", path, as_string, f"{kind}{i}")
    if not name:
        raise ConfigError(f"{path}.name", "must not be empty")
    rod = t.get("rod")  # None: rod 0 of a one-rod model, an error with several rods (BoundaryConditions)
    if rod is not None and not (isinstance(rod, str) or (isinstance(rod, int) and not isinstance(rod, bool))):
        raise ConfigError(f"{path}.rod", f"expected a rod name or index, got {rod!r} ({type_name(rod)})")
    start = get_field(t, "start", path, as_number, 0.0, nonneg=True)
    stop = get_field(t, "stop", path, as_number, None)
    kw: dict = {"rod": rod, "start": start, "stop": stop}
    key_map: dict = {}
    if kind == "moment":
        kw["edges"] = get_field(t, "edges", path, as_index_spec)
    elif kind == "ring_twist":
        kw["node"] = get_field(t, "node", path, as_integer, 0)
        for key in ("total", "rate"):
            if key in t:
                kw[key] = as_number(t[key], f"{path}.{key}")
        return BCSpec(i, kind, name, kw, key_map)
    else:
        kw["nodes"] = get_field(t, "nodes", path, as_index_spec)
    if kind == "spring":
        kw["stiffness"] = get_field(t, "stiffness", path, as_number, positive=True)
        if "velocity" in t and "waypoints" in t:
            raise ConfigError(f"{path}.velocity", "give at most one of 'velocity' or 'waypoints' for the anchor")
        if "velocity" in t:
            kw["path"] = as_vec3(t["velocity"], f"{path}.velocity")
            key_map["path"] = "velocity"
        elif "waypoints" in t:
            kw["path"] = parse_waypoints(t["waypoints"], f"{path}.waypoints")
            key_map["path"] = "waypoints"
        return BCSpec(i, kind, name, kw, key_map)
    if kind == "load_cell":
        kw["twist"] = get_field(t, "twist", path, as_bool, True)
        kw["direction"] = get_field(t, "direction", path, as_vec3)
        kw["ki"] = get_field(t, "ki", path, as_number, nonneg=True)
        kw["kp"] = get_field(t, "kp", path, as_number, 0.0, nonneg=True)
        kw["max_speed"] = get_field(t, "max_speed", path, as_number, None, positive=True)
        if ("target" in t) == ("ramp" in t):
            raise ConfigError(f"{path}.target", "give exactly one of 'target' (N, constant) or 'ramp'")
        if "target" in t:
            kw["target"] = as_number(t["target"], f"{path}.target")
        else:
            kw["target"] = _ramp(t["ramp"], f"{path}.ramp", ())
            key_map["target"] = "ramp"
        return BCSpec(i, kind, name, kw, key_map)
    if kind in ("clamp", "move"):
        kw["twist"] = get_field(t, "twist", path, as_bool, True)
    if kind in ("pin", "slide", "plane"):
        kw["twist"] = get_field(t, "twist", path, as_bool, False)
        key = {"pin": "axes", "slide": "along", "plane": "normal"}[kind]
        if key in t:
            kw[key] = as_string(t[key], f"{path}.{key}") if kind == "pin" else as_vec3(t[key], f"{path}.{key}")
    if kind == "move":
        has_v, has_w = "velocity" in t, "waypoints" in t
        if "rotate_about" in t:
            kw["rotation"] = parse_rotation(t["rotate_about"], f"{path}.rotate_about")
            key_map["rotation"] = "rotate_about"
            if has_v and has_w:
                raise ConfigError(f"{path}.velocity", "give at most one of 'velocity' or 'waypoints'")
        elif has_v == has_w:
            raise ConfigError(f"{path}.velocity", "a moving group needs exactly one of 'velocity' or 'waypoints'")
        if has_v:
            kw["path"] = as_vec3(t["velocity"], f"{path}.velocity")
            key_map["path"] = "velocity"
            if "ramp_time" in t:
                from knotsim.bc.paths import RampedVelocity

                kw["path"] = RampedVelocity(kw["path"], get_field(t, "ramp_time", path, as_number, positive=True))
        elif "ramp_time" in t:
            raise ConfigError(f"{path}.ramp_time", "ramp_time goes with velocity (a smooth start of a constant speed)")
        if has_w:
            kw["path"] = parse_waypoints(t["waypoints"], f"{path}.waypoints")
            key_map["path"] = "waypoints"
    elif kind == "rotate":
        kw["rate"] = get_field(t, "rate", path, as_number)
    elif kind in ("force", "moment"):
        shape = (3,) if kind == "force" else ()
        has_c, has_r = kind in t, "ramp" in t
        if has_c == has_r:
            raise ConfigError(f"{path}.{kind}", f"give exactly one of '{kind}' (constant) or 'ramp'")
        if has_c:
            value = as_vec3(t[kind], f"{path}.{kind}") if shape else as_number(t[kind], f"{path}.{kind}")
            key_map[""] = kind
        else:
            value = _ramp(t["ramp"], f"{path}.ramp", shape)
            key_map[""] = "ramp"
        kw[kind] = value
    return BCSpec(i, kind, name, kw, key_map)


def resolve_releases(specs: list[BCSpec]) -> list[BCSpec]:
    """Fold ``release`` entries into the ``stop`` of the group they release."""
    groups: dict[str, BCSpec] = {}
    for s in specs:
        if s.kind == "release":
            continue
        if s.name in groups:
            raise ConfigError(f"bc[{s.index}].name",
                              f"duplicate name {s.name!r} (also used by bc[{groups[s.name].index}])")
        groups[s.name] = s
    released: dict[str, int] = {}
    for s in specs:
        if s.kind != "release":
            continue
        where = f"bc[{s.index}]"
        if s.name not in groups:
            raise ConfigError(f"{where}.name", f"no boundary condition named {s.name!r} to release; "
                                               f"known: {sorted(groups)}")
        if s.name in released:
            raise ConfigError(f"{where}.name", f"{s.name!r} is already released by bc[{released[s.name]}]")
        g = groups[s.name]
        at = s.kwargs["at"]
        if g.kwargs["stop"] is not None:
            raise ConfigError(f"{where}.at", f"{s.name!r} already has stop = {g.kwargs['stop']} s; "
                                             "give either a stop time or a release")
        if at <= g.kwargs["start"]:
            raise ConfigError(f"{where}.at",
                              f"release time {at} s is not after the start {g.kwargs['start']} s of {s.name!r}")
        g.kwargs["stop"] = at
        released[s.name] = s.index
    return [s for s in specs if s.kind != "release"]


def _apply_bc(bcs: BoundaryConditions, s: BCSpec) -> None:
    method = getattr(bcs, s.kind)
    try:
        method(s.name, **s.kwargs)
    except ConfigError as exc:
        prefix = f"bc.{s.name}"
        fld = exc.field
        if fld == prefix:
            rest = ""
        elif fld.startswith(prefix + "."):
            rest = fld[len(prefix) + 1:]
        else:
            rest = fld
        rest = s.key_map.get(rest, rest)
        raise ConfigError(f"bc[{s.index}]" + (f".{rest}" if rest else ""), error_message(exc)) from None


def bcs_builder(specs: list[BCSpec]) -> Callable[[Model], BoundaryConditions]:
    def build(model: Model) -> BoundaryConditions:
        bcs = BoundaryConditions(model)
        for s in specs:
            _apply_bc(bcs, s)
        return bcs

    return build
